//! Forward and closed-form inverse kinematics of the built-in `puma-lens` arm against an
//! independent model: the Robotics Toolbox for Python's `models.DH.Puma560()` (`fkine`,
//! `ikine_a`), run by `rtb_oracle.py` with the interpreter `scripts/install-robotics.sh`
//! puts in `.tools/py-rtb`. The toolbox works in metres, lampost in millimetres.
//!
//! Random joints within the limits (a fixed seed): the flange poses agree to 1e-9 m
//! relative; for every configuration the toolbox solves, lampost solves it too, to the
//! same joint values (mod 2π, 1e-7 rad) and both reach the pose.
//!
//! Skipped (with a message) when `.tools/py-rtb` is missing, unless `LAMPOST_REQUIRE_PY=1`.

use std::path::Path;
use std::process::Command;

use lampost_robot::{wrap, Arm, Config, Q};

use lampost_testkit::{oracle_present, root, SplitMix as Rng};

#[test]
fn puma_agrees_with_the_robotics_toolbox() {
    let root = root();
    let py = root.join(".tools/py-rtb/bin/python");
    if !oracle_present(std::slice::from_ref(&py), "scripts/install-robotics.sh") {
        return;
    }
    let arm = Arm::builtin("puma-lens").unwrap_or_else(|| panic!("built-in"));
    let mut rng = Rng::new(17);
    let n = 300;
    let cases: Vec<Q> = (0..n)
        .map(|_| {
            std::array::from_fn(|j| {
                let l = &arm.links[j];
                rng.range(l.lo, l.hi)
            })
        })
        .collect();
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("rtb-oracle");
    std::fs::create_dir_all(&work).unwrap_or_else(|e| panic!("{e}"));
    let text: String = cases
        .iter()
        .map(|q| {
            q.iter()
                .map(|v| format!("{v:e}"))
                .collect::<Vec<_>>()
                .join(" ")
                + "\n"
        })
        .collect();
    let (cases_path, out_path) = (work.join("cases.txt"), work.join("oracle.txt"));
    std::fs::write(&cases_path, text).unwrap_or_else(|e| panic!("{e}"));
    let letters: Vec<String> = Config::ALL.iter().map(Config::letters).collect();
    let run = Command::new(&py)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/rtb_oracle.py"))
        .arg(&cases_path)
        .arg(&out_path)
        .arg(letters.join(","))
        .output()
        .unwrap_or_else(|e| panic!("run the oracle: {e}"));
    assert!(
        run.status.success(),
        "oracle failed: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    let out = std::fs::read_to_string(&out_path).unwrap_or_else(|e| panic!("{e}"));
    let mut lines = out.lines();
    let nums = |l: &str, skip: usize| -> Vec<f64> {
        l.split_whitespace()
            .skip(skip)
            .map(|w| w.parse::<f64>().unwrap_or_else(|_| panic!("`{w}`")))
            .collect()
    };
    let (mut fk_worst, mut ik_worst, mut solved) = (0.0f64, 0.0f64, 0);
    for q in &cases {
        let fk = nums(lines.next().unwrap_or_else(|| panic!("short")), 1);
        let ours = arm.flange(q);
        for r in 0..3 {
            for c in 0..3 {
                fk_worst = fk_worst.max((ours.r[(r, c)] - fk[3 * r + c]).abs());
            }
            fk_worst = fk_worst.max((ours.t[r] / 1000.0 - fk[9 + r]).abs());
        }
        for c in Config::ALL {
            let l = lines.next().unwrap_or_else(|| panic!("short"));
            let w: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(w[1], c.letters());
            let theirs = nums(l, 3);
            let mine = arm.inverse_closed(&ours, c, 0.0);
            if w[2] != "1" {
                continue;
            }
            let mine = mine.unwrap_or_else(|e| {
                panic!("{}: the toolbox solves {q:?}, lampost: {e:?}", c.letters())
            });
            solved += 1;
            let back = arm.flange(&mine);
            assert!((back.t - ours.t).norm() < 1e-9 * 1000.0);
            for j in 0..6 {
                ik_worst = ik_worst.max(wrap(mine[j] - theirs[j]).abs());
            }
        }
    }
    eprintln!(
        "{n} random joint sets: FK agrees to {fk_worst:.2e} (m, rotation entries); {solved} inverse solutions agree to {ik_worst:.2e} rad"
    );
    assert!(fk_worst < 1e-12, "FK differs by {fk_worst:e}");
    assert!(ik_worst < 1e-7, "IK differs by {ik_worst:e} rad");
    assert!(solved > n * 6, "only {solved} solutions compared");
}
