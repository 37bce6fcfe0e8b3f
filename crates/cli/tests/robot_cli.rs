//! Issue 17: the robot cell. `lampost post --machine puma-lens PATH -o DIR` writes
//! chunked location files and a manifest; `lampost verify` checks them by forward
//! kinematics and catches tampering; bad input is refused with its line, nothing written.

mod common;

use std::path::Path;

use common::{lampost, tempdir};
use lampost_robot::{Arm, Config, Q};

/// A twisted plate's layers (paper 001's demo part, scaled by `scale`): the long edge
/// along x, the face turning from +z to +y along it; each layer a pass along the edge at
/// distance v, the approach along the face; laser off on each layer's first point.
fn plate(scale: f64, layers: usize, n: usize, feed: f64) -> String {
    let (len, width) = (600.0 * scale, 200.0 * scale);
    let mut s = String::from("x y z i j k feed laser\n");
    for k in 0..layers {
        let v = width * (k as f64 + 0.5) / layers as f64;
        let mut us: Vec<f64> = (0..n)
            .map(|i| -len / 2.0 + len * i as f64 / (n - 1) as f64)
            .collect();
        if k % 2 == 1 {
            us.reverse();
        }
        for (i, u) in us.iter().enumerate() {
            let th = std::f64::consts::FRAC_PI_2 * (u + len / 2.0) / len;
            let (sn, cs) = th.sin_cos();
            s.push_str(&format!(
                "{u:.6} {:.6} {:.6} 0 {sn:.12} {cs:.12} {feed} {}\n",
                v * sn,
                v * cs,
                u8::from(i > 0)
            ));
        }
    }
    s
}

fn ok(o: &std::process::Output) -> String {
    assert!(
        o.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn err(o: &std::process::Output) -> String {
    assert!(!o.status.success(), "succeeded");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn post(dir: &Path, path: &str, out: &str, extra: &[&str]) -> std::process::Output {
    let p = dir.join(path);
    let o = dir.join(out);
    let mut args = vec![
        "post",
        "--machine",
        "puma-lens",
        p.to_str().unwrap_or_default(),
        "-o",
        o.to_str().unwrap_or_default(),
    ];
    args.extend_from_slice(extra);
    lampost(&args)
}

fn verify(dir: &Path, path: &str, out: &str) -> std::process::Output {
    let p = dir.join(path);
    let o = dir.join(out);
    lampost(&[
        "verify",
        "--machine",
        "puma-lens",
        o.to_str().unwrap_or_default(),
        "--input",
        p.to_str().unwrap_or_default(),
    ])
}

fn rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split_whitespace().map(str::to_string).collect())
        .collect()
}

#[test]
fn machines_lists_and_shows_the_arm() {
    let list = ok(&lampost(&["machines"]));
    assert!(list.contains("puma-lens"), "{list}");
    let shown = ok(&lampost(&["machines", "show", "puma-lens"]));
    assert!(shown.contains("kind = \"arm\"") && shown.contains("convention = \"classic\""));
    assert!(shown.contains("a = 431.8") && shown.contains("d = 150.05"));
    // A table command refuses an arm, saying what to do.
    let e = err(&lampost(&[
        "kin",
        "fk",
        "--machine",
        "puma-lens",
        "--joints",
        "X=0",
    ]));
    assert!(e.contains("an arm") && e.contains("lampost post"), "{e}");
}

#[test]
fn post_and_verify_a_plate_in_chunks() {
    let dir = tempdir("robot-plate");
    std::fs::write(dir.join("plate.txt"), plate(0.25, 6, 31, 600.0)).unwrap_or_default();
    let o = post(&dir, "plate.txt", "out", &["--chunk-points", "200"]);
    let said = err_or_ok(&o);
    assert!(said.contains("chunks of at most 200"), "{said}");
    let manifest: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("out/manifest.json")).unwrap_or_default(),
    )
    .unwrap_or_default();
    let chunks = manifest["chunks"].as_array().cloned().unwrap_or_default();
    assert!(chunks.len() >= 2, "{manifest}");
    let arm = Arm::builtin("puma-lens").unwrap_or_else(|| panic!("built-in"));
    let mut total = 0;
    for (k, c) in chunks.iter().enumerate() {
        let text = std::fs::read_to_string(dir.join("out").join(c["file"].as_str().unwrap_or("")))
            .unwrap_or_default();
        assert!(text.contains(&format!("# chunk {} of {}", k + 1, chunks.len())));
        let r = rows(&text);
        assert!(r.len() <= 200 && r.len() == c["locations"].as_u64().unwrap_or(0) as usize);
        // Safe at both ends; the first path row reached with the laser off.
        for end in [&r[0], &r[r.len() - 1]] {
            assert_eq!(end[1], "safe");
            let q: Vec<f64> = end[11..17]
                .iter()
                .map(|v| v.parse().unwrap_or(f64::NAN))
                .collect();
            for (v, s) in q.iter().zip(arm.safe) {
                assert!((v - s.to_degrees()).abs() < 1e-6);
            }
        }
        assert_eq!(r[1][10], "0", "chunk {} starts with the laser on", k + 1);
        total += r.len() - 2;
    }
    assert_eq!(total as u64, manifest["locations"].as_u64().unwrap_or(0));
    let v = ok(&verify(&dir, "plate.txt", "out"));
    assert!(
        v.starts_with("ok: ") && v.contains(&format!("in {} chunks", chunks.len())),
        "{v}"
    );
    // Verify is also reached as INPUT POSTED.
    let p = dir.join("plate.txt");
    let out = dir.join("out");
    ok(&lampost(&[
        "verify",
        "--machine",
        "puma-lens",
        p.to_str().unwrap_or(""),
        out.to_str().unwrap_or(""),
    ]));
    // Posting again with larger chunks leaves no stale chunk behind.
    let o = post(&dir, "plate.txt", "out", &["--chunk-points", "100000"]);
    err_or_ok(&o);
    assert!(dir.join("out/chunk-001.loc").exists());
    assert!(!dir.join("out/chunk-002.loc").exists());
    ok(&verify(&dir, "plate.txt", "out"));
}

fn err_or_ok(o: &std::process::Output) -> String {
    assert!(
        o.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Replace row `n` (1-based, data rows only) of a location file with `f(row)`.
fn edit_row(path: &Path, n: usize, f: impl Fn(&mut Vec<String>)) {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut k = 0;
    let out: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with('#') {
                return l.to_string();
            }
            k += 1;
            if k == n {
                let mut w: Vec<String> = l.split_whitespace().map(str::to_string).collect();
                f(&mut w);
                w.join(" ")
            } else {
                l.to_string()
            }
        })
        .collect();
    std::fs::write(path, out.join("\n") + "\n").unwrap_or_default();
}

#[test]
fn tampered_output_is_caught() {
    let dir = tempdir("robot-tamper");
    std::fs::write(dir.join("plate.txt"), plate(0.2, 4, 21, 600.0)).unwrap_or_default();
    err_or_ok(&post(&dir, "plate.txt", "good", &["--chunk-points", "150"]));
    ok(&verify(&dir, "plate.txt", "good"));
    let fresh = |name: &str| {
        let to = dir.join(name);
        let _ = std::fs::remove_dir_all(&to);
        std::fs::create_dir_all(&to).unwrap_or_default();
        for e in std::fs::read_dir(dir.join("good"))
            .into_iter()
            .flatten()
            .flatten()
        {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap_or_default();
        }
        to
    };
    // An edited joint value.
    let t = fresh("joint");
    edit_row(&t.join("chunk-001.loc"), 10, |w| {
        let v: f64 = w[13].parse().unwrap_or(0.0);
        w[13] = format!("{:.7}", v + 0.01);
    });
    let e = err(&verify(&dir, "plate.txt", "joint"));
    assert!(
        e.contains("chunk-001.loc:") && e.contains("not where the joints put the part"),
        "{e}"
    );
    // The same edit with the pose written to match: the focus leaves the path.
    let arm = Arm::builtin("puma-lens").unwrap_or_else(|| panic!("built-in"));
    let t = fresh("joint2");
    edit_row(&t.join("chunk-001.loc"), 10, |w| {
        let mut q: Q = [0.0; 6];
        for j in 0..6 {
            q[j] = w[11 + j].parse::<f64>().unwrap_or(0.0).to_radians();
        }
        q[1] += 0.05f64.to_radians();
        rewrite(&arm, w, &q);
    });
    let e = err(&verify(&dir, "plate.txt", "joint2"));
    assert!(
        e.contains("the focus is") && e.contains("from the path point"),
        "{e}"
    );
    // A swapped configuration: another configuration's joints for the same pose.
    let t = fresh("config");
    edit_row(&t.join("chunk-001.loc"), 12, |w| {
        let mut q: Q = [0.0; 6];
        for j in 0..6 {
            q[j] = w[11 + j].parse::<f64>().unwrap_or(0.0).to_radians();
        }
        let flange = arm.flange(&q);
        // The first other configuration with a solution within the limits.
        let s = Config::ALL
            .iter()
            .filter(|c| **c != arm.config)
            .find_map(|c| {
                let s = arm.inverse_closed(&flange, *c, q[3]).ok()?;
                arm.fit_limits(&s, &q).ok()
            })
            .unwrap_or_else(|| panic!("no other configuration within the limits"));
        rewrite(&arm, w, &s);
    });
    let e = err(&verify(&dir, "plate.txt", "config"));
    assert!(e.contains("configuration flip"), "{e}");
    // The header's configuration changed.
    let t = fresh("header");
    let p = t.join("chunk-002.loc");
    let text = std::fs::read_to_string(&p).unwrap_or_default();
    std::fs::write(&p, text.replace("# config rdf", "# config rdn")).unwrap_or_default();
    let e = err(&verify(&dir, "plate.txt", "header"));
    assert!(e.contains("header says `config rdn`"), "{e}");
    // A missing chunk file; a chunk dropped from the manifest.
    let t = fresh("missing");
    std::fs::remove_file(t.join("chunk-002.loc")).unwrap_or_default();
    let e = err(&verify(&dir, "plate.txt", "missing"));
    assert!(e.contains("a missing chunk"), "{e}");
    let t = fresh("dropped");
    let mp = t.join("manifest.json");
    let mut m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&mp).unwrap_or_default()).unwrap_or_default();
    if let Some(a) = m["chunks"].as_array_mut() {
        a.remove(1);
    }
    std::fs::write(&mp, m.to_string()).unwrap_or_default();
    let e = err(&verify(&dir, "plate.txt", "dropped"));
    assert!(e.contains("expected `chunk 1 of 3`"), "{e}");
    // Dropped with every header renumbered to match: the gap in the path is found.
    let n = m["chunks"].as_array().map_or(0, Vec::len);
    for k in 1..=n {
        let p = t.join(format!("chunk-{k:03}.loc"));
        let text = std::fs::read_to_string(&p).unwrap_or_default();
        std::fs::write(
            &p,
            text.replace(&format!("of {}", n + 1), &format!("of {n}")),
        )
        .unwrap_or_default();
    }
    let e = err(&verify(&dir, "plate.txt", "dropped"));
    assert!(e.contains("in no chunk"), "{e}");
    // The laser switched on at a chunk's first location.
    let t = fresh("laser");
    edit_row(&t.join("chunk-002.loc"), 2, |w| w[10] = "1".into());
    err(&verify(&dir, "plate.txt", "laser"));
}

/// Write joint values `q` and the pose they give into row `w`.
fn rewrite(arm: &Arm, w: &mut [String], q: &Q) {
    let part = lampost_robot::chunk::part_of(arm, q);
    let e = lampost_robot::chunk::zyz(&part.r);
    w[4] = format!("{:.6}", part.t.x);
    w[5] = format!("{:.6}", part.t.y);
    w[6] = format!("{:.6}", part.t.z);
    for k in 0..3 {
        w[7 + k] = format!("{:.7}", e[k].to_degrees());
    }
    for j in 0..6 {
        w[11 + j] = format!("{:.7}", q[j].to_degrees());
    }
}

#[test]
fn bad_paths_are_refused_with_their_line_and_nothing_written() {
    let dir = tempdir("robot-bad");
    // Beyond reach: a point 2 m from the part's origin.
    std::fs::write(
        dir.join("far.txt"),
        "x y z i j k feed laser\n2000 0 0 0 0 1 600 0\n2010 0 0 0 0 1 600 1\n",
    )
    .unwrap_or_default();
    let e = err(&post(&dir, "far.txt", "far", &[]));
    assert!(
        e.contains("beyond reach") && e.contains("far.txt:2:1"),
        "{e}"
    );
    assert!(
        e.contains("J1") || e.contains("J2") || e.contains("J3"),
        "{e}"
    );
    assert!(!dir.join("far").exists());
    // A chunk smaller than one laser-on run.
    std::fs::write(
        dir.join("run.txt"),
        "x y z i j k feed laser\n0 0 0 0 0 1 600 0\n40 0 0 0 0 1 600 1\n",
    )
    .unwrap_or_default();
    let e = err(&post(&dir, "run.txt", "run", &["--chunk-points", "10"]));
    assert!(
        e.contains("cannot hold the laser-on run") && e.contains("run.txt:2:1"),
        "{e}"
    );
    assert!(!dir.join("run").exists());
    let e = err(&post(&dir, "run.txt", "run", &["--chunk-points", "2"]));
    assert!(e.contains("--chunk-points 2"), "{e}");
    // An approach that flips faster than the wrist can follow at the feed.
    std::fs::write(
        dir.join("flip.txt"),
        "x y z i j k feed laser\n0 0 0 0 0 1 600 0\n10 0 0 0 0 1 600 1\n10.5 0 0 0 0.7071 0.7071 600 1\n",
    )
    .unwrap_or_default();
    let e = err(&post(&dir, "flip.txt", "flip", &[]));
    assert!(
        e.contains("faster than the arm can follow") && e.contains("flip.txt:4:1"),
        "{e}"
    );
    assert!(!dir.join("flip").exists());
    // Table-machine options are refused for an arm, arm options for a table machine.
    let e = err(&post(&dir, "run.txt", "x", &["--index", "A=0,B=0"]));
    assert!(e.contains("--index does not apply to an arm"), "{e}");
    let e = err(&post(&dir, "run.txt", "x", &["--set", "H=1"]));
    assert!(e.contains("--set is for programs of table machines"), "{e}");
    let e = err(&post(&dir, "run.txt", "x", &["--config", "abc"]));
    assert!(e.contains("--config abc"), "{e}");
    let p = dir.join("run.txt");
    let e = err(&lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--per-point",
        p.to_str().unwrap_or(""),
        "--chunk-points",
        "5",
    ]));
    assert!(e.contains("are for arms"), "{e}");
}

#[test]
fn a_degenerate_arm_file_is_refused_at_its_line() {
    let dir = tempdir("robot-arm-file");
    let text = ok(&lampost(&["machines", "show", "puma-lens"]));
    let bad = text.replacen("a = 431.8", "a = nan", 1);
    let f = dir.join("arm.toml");
    std::fs::write(&f, &bad).unwrap_or_default();
    std::fs::write(
        dir.join("run.txt"),
        "0 0 0 0 0 1 600 0\n1 0 0 0 0 1 600 1\n",
    )
    .unwrap_or_default();
    let line = bad
        .lines()
        .position(|l| l == "a = nan")
        .map_or(0, |i| i + 1);
    let e = err(&lampost(&[
        "post",
        "--machine",
        f.to_str().unwrap_or(""),
        dir.join("run.txt").to_str().unwrap_or(""),
        "-o",
        dir.join("out").to_str().unwrap_or(""),
    ]));
    assert!(
        e.contains("not a finite number") && e.contains(&format!("arm.toml:{line}:5")),
        "{e}"
    );
    assert!(!dir.join("out").exists());
}

/// Paper 001's demo part at full size (600 × 200 mm, twisted 90° about a long edge): 20
/// layers posted for puma-lens at the default 1 mm spacing into 1000-location chunks, and
/// verified. The chunk count and sizes are printed (`--nocapture`).
#[test]
fn the_full_size_twisted_plate_posts_and_verifies() {
    let dir = tempdir("robot-twisted");
    std::fs::write(dir.join("plate.txt"), plate(1.0, 20, 61, 600.0)).unwrap_or_default();
    let said = err_or_ok(&post(&dir, "plate.txt", "out", &[]));
    let m: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("out/manifest.json")).unwrap_or_default(),
    )
    .unwrap_or_default();
    let sizes: Vec<u64> = m["chunks"]
        .as_array()
        .map(|a| a.iter().filter_map(|c| c["locations"].as_u64()).collect())
        .unwrap_or_default();
    eprintln!(
        "twisted plate: {} locations, {:.0} s of motion ({:.0} s laser on), {} chunks of at most 1000 locations: {sizes:?}\n{said}",
        m["locations"], m["path_s"].as_f64().unwrap_or(0.0), m["laser_on_s"].as_f64().unwrap_or(0.0), sizes.len()
    );
    assert!(
        sizes.len() >= 13 && sizes.iter().all(|&s| s <= 1000),
        "{sizes:?}"
    );
    let v = ok(&verify(&dir, "plate.txt", "out"));
    assert!(v.starts_with("ok: "), "{v}");
}

/// An arm the closed form does not cover (a 15 mm offset at the wrist, a5): solved by damped
/// least squares, seeded at the first location by the near-PUMA closed form in the asked
/// configuration; posted and verified like the PUMA.
#[test]
fn an_arm_without_the_closed_form_posts_and_verifies() {
    let dir = tempdir("robot-dls");
    let text = ok(&lampost(&["machines", "show", "puma-lens"]))
        .replacen("name = \"puma-lens\"", "name = \"offset-wrist\"", 1)
        .replacen(
            "d = 0.0\na = 0.0\nalpha = -90.0",
            "d = 0.0\na = 15.0\nalpha = -90.0",
            1,
        );
    assert!(text.contains("a = 15.0"));
    let arm = dir.join("offset-wrist.toml");
    std::fs::write(&arm, text).unwrap_or_default();
    std::fs::write(dir.join("plate.txt"), plate(0.25, 4, 16, 100.0)).unwrap_or_default();
    let (p, o) = (dir.join("plate.txt"), dir.join("out"));
    let (a, p, o) = (
        arm.to_str().unwrap_or(""),
        p.to_str().unwrap_or(""),
        o.to_str().unwrap_or(""),
    );
    err_or_ok(&lampost(&["post", "--machine", a, p, "-o", o]));
    let v = ok(&lampost(&["verify", "--machine", a, o, "--input", p]));
    assert!(v.starts_with("ok: "), "{v}");
    let chunk = std::fs::read_to_string(dir.join("out/chunk-001.loc")).unwrap_or_default();
    assert!(chunk.contains("# machine offset-wrist"));
    // Verified against its own arm file: puma-lens refuses the folder.
    let e = err(&lampost(&[
        "verify",
        "--machine",
        "puma-lens",
        o,
        "--input",
        p,
    ]));
    assert!(e.contains("posted for offset-wrist"), "{e}");
}

/// The path is read on one thread and resampled on another as its rows come: a bad row
/// far into the file (after several batches) is refused at its line as when the file
/// was read whole first, and a bad row after one that resampling refuses (a jump needing
/// more than the most locations) is still the error reported, as reading first reports
/// it; nothing is written.
#[test]
fn a_bad_row_is_refused_at_its_line_whatever_the_resampler_met_first() {
    let dir = tempdir("robot-stream");
    let mut long = String::from("x y z i j k feed laser\n");
    for i in 0..10_000 {
        long.push_str(&format!("{} 0 0 0 0 1 600 1\n", f64::from(i) * 0.01));
    }
    long.push_str("100 0 nan 0 0 1 600 1\n");
    std::fs::write(dir.join("long.txt"), &long).unwrap_or_default();
    let e = err(&post(&dir, "long.txt", "long", &[]));
    assert!(
        e.contains("long.txt:10002:") && e.contains("`nan` is not a finite number"),
        "{e}"
    );
    assert!(!dir.join("long").exists());
    // The jump alone is refused by resampling.
    let jump = "x y z i j k feed laser\n0 0 0 0 0 1 600 0\n3000000 0 0 0 0 1 600 1\n";
    std::fs::write(dir.join("jump.txt"), jump).unwrap_or_default();
    let e = err(&post(&dir, "jump.txt", "jump", &[]));
    assert!(e.contains("more than 2000000 locations"), "{e}");
    // With a bad row after it, the bad row is the error.
    std::fs::write(
        dir.join("both.txt"),
        format!("{jump}1 2 3 0 0 1 600 1 9 9\n"),
    )
    .unwrap_or_default();
    let e = err(&post(&dir, "both.txt", "both", &[]));
    assert!(
        e.contains("both.txt:4:") && e.contains("found 10 columns"),
        "{e}"
    );
    assert!(!dir.join("both").exists() && !dir.join("jump").exists());
    // The same with 60,000 good rows between: resampling stops at the jump in the first
    // batch, and the reader, held by the full channel, never reaches the bad row; it is
    // still the error reported (the file read again to find it).
    let mut far = String::from(jump);
    for i in 0..60_000 {
        far.push_str(&format!("3000000 {} 0 0 0 1 600 1\n", f64::from(i) * 0.01));
    }
    far.push_str("1 2 3 0 0 1 600 1 9 9\n");
    std::fs::write(dir.join("far.txt"), far).unwrap_or_default();
    let e = err(&post(&dir, "far.txt", "far", &[]));
    assert!(
        e.contains("far.txt:60004:") && e.contains("found 10 columns"),
        "{e}"
    );
    assert!(!dir.join("far").exists());
}

/// A change made to a manifest.
type Edit = Box<dyn Fn(&mut serde_json::Value)>;

/// h54 (finding 92): verify read the manifest for the chunks' places only, so a
/// controller's figures could be edited and verify passed: `chunk_points` (the memory
/// the chunks were cut for) set below a chunk, the counts, the units, the safe location,
/// the times; a chunk file's header saying inches. Each now fails, and a chunk or
/// manifest that is a named pipe is refused rather than waited on.
#[test]
fn the_manifest_and_chunk_headers_are_held_to_what_verify_finds() {
    let dir = tempdir("robot-h54-manifest");
    std::fs::write(dir.join("p.csv"), plate(0.2, 2, 40, 600.0)).expect("write");
    ok(&post(
        &dir,
        "p.csv",
        "good.robot",
        &["--chunk-points", "400"],
    ));
    ok(&verify(&dir, "p.csv", "good.robot"));
    let manifest: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("good.robot/manifest.json")).expect("manifest"),
    )
    .expect("json");
    let edits: Vec<(&str, Edit, &str)> = vec![
        (
            "locations",
            Box::new(|m| m["locations"] = (m["locations"].as_u64().unwrap_or(0) + 1).into()),
            "`locations` is",
        ),
        (
            "a chunk's locations",
            Box::new(|m| {
                m["chunks"][0]["locations"] =
                    (m["chunks"][0]["locations"].as_u64().unwrap_or(0) + 1).into()
            }),
            "chunk 1: `locations`",
        ),
        (
            "chunk_points",
            Box::new(|m| m["chunk_points"] = 10.into()),
            "`chunk_points` is 10",
        ),
        (
            "units",
            Box::new(|m| m["units"] = "inch".into()),
            "`units` is not mm",
        ),
        (
            "safe",
            Box::new(|m| m["safe"][0] = 10.0.into()),
            "`safe` joint 1",
        ),
        (
            "times",
            Box::new(|m| m["laser_on_s"] = (-5.0).into()),
            "`laser_on_s`",
        ),
    ];
    for (what, edit, says) in edits {
        let t = dir.join("t.robot");
        let _ = std::fs::remove_dir_all(&t);
        std::fs::create_dir_all(&t).expect("dir");
        for e in std::fs::read_dir(dir.join("good.robot")).expect("read") {
            let e = e.expect("entry");
            std::fs::copy(e.path(), t.join(e.file_name())).expect("copy");
        }
        let mut m = manifest.clone();
        edit(&mut m);
        std::fs::write(t.join("manifest.json"), m.to_string()).expect("write");
        let e = err(&verify(&dir, "p.csv", "t.robot"));
        assert!(e.contains(says), "{what}: {e}");
    }
    // A chunk header in other units.
    let t = dir.join("t.robot");
    let c1 = t.join("chunk-001.loc");
    std::fs::write(t.join("manifest.json"), manifest.to_string()).expect("write");
    let text = std::fs::read_to_string(dir.join("good.robot/chunk-001.loc")).expect("chunk");
    std::fs::write(&c1, text.replacen("# units mm,", "# units inch,", 1)).expect("write");
    let e = err(&verify(&dir, "p.csv", "t.robot"));
    assert!(e.contains("its header does not say `# units mm"), "{e}");
    // A named pipe instead of a chunk.
    std::fs::remove_file(&c1).expect("rm");
    if std::process::Command::new("mkfifo")
        .arg(&c1)
        .status()
        .is_ok_and(|s| s.success())
    {
        let o = common::limited(
            &format!(
                "\"$LAMPOST\" verify --machine puma-lens {} --input {}",
                t.display(),
                dir.join("p.csv").display()
            ),
            1 << 20,
            20,
        );
        assert_eq!(o.status.code(), Some(2), "{}", common::stderr(&o));
        assert!(common::stderr(&o).contains("not a regular file"));
    }
}

/// h54 (finding 93): a path's header was passed over and its columns read by place:
/// `x y z feed i j k laser` had its feed read as the tool axis, and verify passed it,
/// reading the file the same way. A laser value other than 0 or 1, and a feed so slow
/// its times ran to 300 digits, were taken too. Each is refused at its line and column; nothing is written.
#[test]
fn a_path_s_header_and_values_are_held_to_its_columns() {
    let dir = tempdir("robot-h54-path");
    for (name, text, says) in [
        (
            "reordered.csv",
            "x y z feed i j k laser\n-50 0 10 600 0 0 1 0\n0 0 10 600 0 0 1 1\n",
            "reordered.csv:1:1: the header `x y z feed i j k laser` does not name the columns",
        ),
        (
            "laser.csv",
            "x y z i j k feed laser\n-50 0 10 0 0 1 600 0\n0 0 10 0 0 1 600 -1\n",
            "laser.csv:3:18: the laser column is 1 (on) or 0 (off), not `-1`",
        ),
        (
            "slow.csv",
            "x y z i j k feed laser\n-50 0 10 0 0 1 600 0\n0 0 10 0 0 1 1e-300 1\n",
            "slow.csv:3:1: the feed 1e-300 is under 0.001 a minute",
        ),
    ] {
        std::fs::write(dir.join(name), text).expect("write");
        let e = err(&post(&dir, name, "out.robot", &[]));
        assert!(e.contains(says), "{name}: {e}");
        assert!(!dir.join("out.robot").exists(), "{name}: written");
    }
}
