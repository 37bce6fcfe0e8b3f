//! Calibration straight from the probe log: `probe poses` writes the program, a touch
//! probe simulated here (written out in this test, sharing nothing with lampost's
//! calibration) runs it against a gage ball on a table whose true R differs from the
//! machine file's, and `calibrate pivot` / `calibrate axes` read the log it sends.
//!
//! The simulated logs are also fixtures the user guide uses
//! (`fixtures/calibration/fadal-poses.log`, and `fixtures/points/tilted-face.log`: a
//! `probe plane` grid run against a face tilted by a known small angle); this test
//! regenerates them and fails if a committed one differs (`LAMPOST_UPDATE_FIXTURES=1`
//! rewrites them).

mod common;

use common::*;

/// The true R of the simulated table (the machine file says -4.877, 1.4798, 7.0918).
const R_TRUE: [f64; 3] = [-4.8652, 1.4911, 7.0803];
const BALL: [f64; 3] = [3.0, -2.0, 1.5];
const RADIUS: f64 = 0.5;
const STYLUS: f64 = 0.0625;

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "{}", stderr(o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn words(line: &str) -> Vec<(char, f64)> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(i) = rest.find(|c: char| c.is_ascii_alphabetic()) {
        let l = rest[i..].chars().next().unwrap_or(' ');
        let tail = &rest[i + 1..];
        let end = tail
            .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
            .unwrap_or(tail.len());
        if let Ok(v) = tail[..end].parse::<f64>() {
            out.push((l, v));
        }
        rest = &tail[end..];
    }
    out
}

/// The true ball centre at a pose: the table turns the ball's home point about the true
/// rotation centre (`kin rotate` with R overridden) — the ball at home is `BALL`.
fn true_centre(a: f64, b: f64) -> [f64; 3] {
    let dir = tempdir("calib-log-kin");
    let p = dir.join("origin.txt");
    std::fs::write(&p, "0 0 0\n").expect("write");
    let text = ok(&lampost(&[
        "kin",
        "rotate",
        "--machine",
        "fadal-lamp",
        "--set",
        &format!("R={},{},{}", R_TRUE[0], R_TRUE[1], R_TRUE[2]),
        "--joints",
        &format!("A={a},B={b}"),
        "--json",
        p.to_str().expect("utf8"),
    ]));
    let v: serde_json::Value = serde_json::from_str(&text).expect("json");
    let q = &v["points"][0];
    let c = |k: usize| q[k].as_f64().expect("number") + BALL[k];
    [c(0), c(1), c(2)]
}

/// Run the probing program against the true ball: each `G31` move from where the probe
/// is stops where the stylus ball first touches the gage ball (|p − c| = R + r); the
/// log gets what the program's `#SPRINT` lines send, at the FADAL's 4 decimals.
fn simulate(program: &str) -> String {
    let mut log =
        String::from("FADAL RS-232 CAPTURE (simulated by crates/cli/tests/calib_log_cli.rs)\n");
    let mut pos = [0.0f64; 3];
    let mut rot = (0.0, 0.0);
    let mut centre = true_centre(0.0, 0.0);
    let mut touch: Option<[f64; 3]> = None;
    for line in program.lines() {
        let t = line.trim();
        if t.starts_with('(') || t == "%" || t.starts_with("#WAIT") || t.starts_with("#PRINT") {
            continue;
        }
        if let Some(rec) = t.strip_prefix("#SPRINT \"POSE") {
            log.push_str(&format!("POSE{}\n", rec.trim_end_matches('"')));
            continue;
        }
        if t.starts_with("#SPRINT") {
            let p = touch.take().expect("a touch before its #SPRINT");
            log.push_str(&format!("X{:.4} Y{:.4} Z{:.4}\n", p[0], p[1], p[2]));
            continue;
        }
        let w = words(t);
        let probing = w.iter().any(|&(l, v)| l == 'G' && v == 31.0);
        let mut to = pos;
        let mut turned = false;
        for &(l, v) in &w {
            match l {
                'X' => to[0] = v,
                'Y' => to[1] = v,
                'Z' => to[2] = v,
                'A' => {
                    rot.0 = v;
                    turned = true
                }
                'B' => {
                    rot.1 = v;
                    turned = true
                }
                _ => {}
            }
        }
        if turned {
            centre = true_centre(rot.0, rot.1);
        }
        if probing {
            // |pos + t·d − c|² = (R + r)², the smallest root in [0, 1].
            let d = [to[0] - pos[0], to[1] - pos[1], to[2] - pos[2]];
            let f = [pos[0] - centre[0], pos[1] - centre[1], pos[2] - centre[2]];
            let a: f64 = d.iter().map(|x| x * x).sum();
            let b: f64 = 2.0 * (0..3).map(|k| d[k] * f[k]).sum::<f64>();
            let c: f64 = f.iter().map(|x| x * x).sum::<f64>() - (RADIUS + STYLUS).powi(2);
            let disc = b * b - 4.0 * a * c;
            assert!(disc >= 0.0, "a probing move misses the ball: {t}");
            let s = (-b - disc.sqrt()) / (2.0 * a);
            assert!(
                (0.0..=1.0).contains(&s),
                "the probe does not reach the ball: {t} ({s})"
            );
            let p = [pos[0] + s * d[0], pos[1] + s * d[1], pos[2] + s * d[2]];
            touch = Some(p);
            pos = p;
        } else {
            pos = to;
        }
    }
    log
}

fn poses_log() -> String {
    let program = ok(&lampost(&[
        "probe",
        "poses",
        "--machine",
        "fadal-lamp",
        "--ball",
        "3,-2,1.5",
        "--radius",
        &RADIUS.to_string(),
        "--stylus-radius",
        &STYLUS.to_string(),
        "--points",
        "8",
        "--for",
        "axes",
    ]));
    simulate(&program)
}

fn fixture() -> std::path::PathBuf {
    root().join("fixtures/calibration/fadal-poses.log")
}

/// The tilted face: z = 1 + x·tan 0.4° − y·tan 0.25° (inch).
fn face_z(x: f64, y: f64) -> f64 {
    1.0 + x * 0.4f64.to_radians().tan() - y * 0.25f64.to_radians().tan()
}

/// `probe plane` (a 4 × 3 in rectangle at z = 1, 4 × 3 touches, 1/16-in stylus) run
/// against the tilted face: each vertical `G31` move stops where the stylus ball meets
/// the face, its centre one stylus radius off the face along the normal.
fn face_log() -> String {
    let program = ok(&lampost(&[
        "probe", "plane", "--corner", "0,0,1", "--size", "4,3", "--grid", "4,3",
    ]));
    let (a, b) = (0.4f64.to_radians().tan(), -0.25f64.to_radians().tan());
    let lift = STYLUS * (1.0 + a * a + b * b).sqrt();
    let mut log =
        String::from("FADAL RS-232 CAPTURE (simulated by crates/cli/tests/calib_log_cli.rs)\n");
    let mut pos = [0.0f64; 3];
    let mut touch = None;
    for line in program.lines() {
        let t = line.trim();
        if t.starts_with("#SPRINT") {
            let p: [f64; 3] = touch.take().expect("a touch before its #SPRINT");
            log.push_str(&format!("X{:.4} Y{:.4} Z{:.4}\n", p[0], p[1], p[2]));
            continue;
        }
        if t.starts_with('(') || t.starts_with('#') || t == "%" {
            continue;
        }
        let w = words(t);
        let mut to = pos;
        for &(l, v) in &w {
            match l {
                'X' => to[0] = v,
                'Y' => to[1] = v,
                'Z' => to[2] = v,
                _ => {}
            }
        }
        if w.iter().any(|&(l, v)| l == 'G' && v == 31.0) {
            assert!(
                to[0] == pos[0] && to[1] == pos[1],
                "a vertical probing move: {t}"
            );
            let z = face_z(pos[0], pos[1]) + lift;
            assert!(z <= pos[2] && z >= to[2], "the probe reaches the face: {t}");
            let p = [pos[0], pos[1], z];
            touch = Some(p);
            pos = p;
        } else {
            pos = to;
        }
    }
    log
}

#[test]
fn the_committed_logs_are_what_the_simulated_probe_sends() {
    let face = root().join("fixtures/points/tilted-face.log");
    for (path, log) in [(fixture(), poses_log()), (face, face_log())] {
        if std::env::var_os("LAMPOST_UPDATE_FIXTURES").is_some() {
            std::fs::write(&path, &log).expect("write fixture");
        }
        let committed = std::fs::read_to_string(&path).expect("fixture");
        assert_eq!(
            committed,
            log,
            "{}: regenerate with LAMPOST_UPDATE_FIXTURES=1",
            path.display()
        );
    }
}

#[test]
fn the_face_log_levels_to_its_tilt() {
    let face = root().join("fixtures/points/tilted-face.log");
    let dir = tempdir("calib-log-face");
    let pts = dir.join("face.txt");
    ok(&lampost(&[
        "probe",
        "read",
        face.to_str().expect("utf8"),
        "-o",
        pts.to_str().expect("utf8"),
    ]));
    let v: serde_json::Value = serde_json::from_str(&ok(&lampost(&[
        "fit",
        "plane",
        pts.to_str().expect("utf8"),
        "--json",
    ])))
    .expect("json");
    let n = &v["normal"];
    let (a, b) = (0.4f64.to_radians().tan(), -0.25f64.to_radians().tan());
    let k = (1.0 + a * a + b * b).sqrt();
    let want = [-a / k, -b / k, 1.0 / k];
    for i in 0..3 {
        let got = n[i].as_f64().expect("normal");
        assert!((got - want[i]).abs() < 5e-5, "normal {n} vs {want:?}");
    }
}

#[test]
fn pivot_from_the_log_recovers_the_true_r() {
    let f = fixture();
    let f = f.to_str().expect("utf8");
    for radii in [vec!["--radius", "0.5", "--stylus-radius", "0.0625"], vec![]] {
        let mut args = vec!["calibrate", "pivot", "--machine", "fadal-lamp", f, "--json"];
        args.extend(&radii);
        let v: serde_json::Value = serde_json::from_str(&ok(&lampost(&args))).expect("json");
        assert_eq!(v["method"], "fit", "{v}");
        let fits = v["pose_fits"].as_array().expect("pose fits");
        assert_eq!(fits.len(), 10, "{v}");
        for p in fits {
            assert_eq!(p["n"], 8, "{p}");
            // The touches are rounded to 0.0001 in: the fit's rms is that rounding.
            assert!(p["rms"].as_f64().expect("rms") < 1e-4, "{p}");
        }
        assert_eq!(fits[9]["A"], 0.0);
        assert_eq!(fits[9]["B"], -45.0);
        for k in 0..3 {
            let r = v["R"][k].as_f64().expect("R");
            assert!(
                (r - R_TRUE[k]).abs() < 2e-4,
                "R[{k}] = {r} vs {} ({radii:?})",
                R_TRUE[k]
            );
            // …and against the machine file's nominal R the difference is seen.
        }
        let nominal = [-4.877, 1.4798, 7.0918];
        let moved: f64 = (0..3)
            .map(|k| (v["R"][k].as_f64().expect("R") - nominal[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(moved > 0.015, "R moved by {moved}");
    }
    // The text report lists each pose's fit before the result.
    let text = ok(&lampost(&[
        "calibrate",
        "pivot",
        "--machine",
        "fadal-lamp",
        f,
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.0625",
    ]));
    assert!(
        text.starts_with("pose 1 (line 2) A 0 B 0: centre"),
        "{text}"
    );
    assert!(text.contains("\nmethod fit\nR -4.86"), "{text}");
}

#[test]
fn axes_from_the_log_finds_both_lines() {
    let f = fixture();
    let v: serde_json::Value = serde_json::from_str(&ok(&lampost(&[
        "calibrate",
        "axes",
        "--machine",
        "fadal-lamp",
        f.to_str().expect("utf8"),
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.0625",
        "--json",
    ])))
    .expect("json");
    let axes = v["axes"].as_array().expect("axes");
    assert_eq!(axes.len(), 2, "{v}");
    // The true table's axes intersect and are square: what the log shows, to the
    // rounding of the touches.
    assert!(v["offset"].as_f64().expect("offset") < 1e-3, "{v}");
    assert!(
        v["squareness_deg"].as_f64().expect("sq").abs() < 0.01,
        "{v}"
    );
    assert_eq!(v["pose_fits"].as_array().expect("fits").len(), 10);
    // The default 8-pose set cannot serve `axes`, and the hint says how to get one that does.
    let o = lampost(&[
        "calibrate",
        "axes",
        "--machine",
        "fadal-lamp",
        root()
            .join("fixtures/calibration/fadal-8-poses.txt")
            .to_str()
            .expect("utf8"),
    ]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("moves B alone") && e.contains("--for axes"),
        "{e}"
    );
    assert!(
        !e.contains("sphere"),
        "the hint is about poses, not spheres: {e}"
    );
}

#[test]
fn probe_read_keeps_the_pose_records() {
    let f = fixture();
    let text = ok(&lampost(&["probe", "read", f.to_str().expect("utf8")]));
    assert!(text.contains("\n# pose 1 A0 B0 (line 2)\n"), "{text}");
    assert!(text.contains("\n# pose 10 A0 B-45 (line "), "{text}");
    assert_eq!(text.lines().filter(|l| !l.starts_with('#')).count(), 81);
    let v: serde_json::Value = serde_json::from_str(&ok(&lampost(&[
        "probe",
        "read",
        f.to_str().expect("utf8"),
        "--json",
    ])))
    .expect("json");
    assert_eq!(v["points"].as_array().expect("points").len(), 80);
    assert_eq!(v["poses"][9]["B"], -45.0);
    assert_eq!(v["poses"][9]["points"].as_array().expect("pts").len(), 8);
}

#[test]
fn bad_logs_are_located() {
    let dir = tempdir("calib-log-bad");
    let good = std::fs::read_to_string(fixture()).expect("fixture");
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "touch before any pose",
            format!("X1.0 Y2.0 Z3.0\n{good}"),
            "comes before the first POSE record",
        ),
        (
            "pose with no touches",
            format!("{good}POSE 11 A0.000 B10.000\n"),
            "has no touches after it",
        ),
        (
            "repeated pose",
            good.replacen("POSE 2 ", "POSE 1 ", 1),
            "repeats pose 1",
        ),
        (
            "axis the machine lacks",
            good.replacen("POSE 1 A0.000 B0.000", "POSE 1 A0.000 C0.000", 1),
            "names axis C",
        ),
        (
            "unreadable record",
            good.replacen("POSE 1 A0.000 B0.000", "POSE 1 A0.000 Bx", 1),
            "where a rotary word",
        ),
    ];
    for (what, text, want) in cases {
        let p = dir.join("bad.log");
        std::fs::write(&p, text).expect("write");
        let o = lampost(&[
            "calibrate",
            "pivot",
            "--machine",
            "fadal-lamp",
            p.to_str().expect("utf8"),
        ]);
        assert!(!o.status.success(), "{what}");
        let e = stderr(&o);
        assert!(e.contains(want) && e.contains("bad.log:"), "{what}: {e}");
    }
    // Radii with a file of ball centres, or only one of the two: refused.
    let centres = root().join("fixtures/calibration/fadal-8-poses.txt");
    let o = lampost(&[
        "calibrate",
        "pivot",
        "--machine",
        "fadal-lamp",
        centres.to_str().expect("utf8"),
        "--radius",
        "0.5",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("no POSE records"),
        "{}",
        stderr(&o)
    );
    let f = fixture();
    let o = lampost(&[
        "calibrate",
        "pivot",
        "--machine",
        "fadal-lamp",
        f.to_str().expect("utf8"),
        "--radius",
        "0.5",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("give both --radius"),
        "{}",
        stderr(&o)
    );
}

/// `--write` edits the machine file it started from: comments and layout kept, only the
/// calibrated numbers replaced (rounded a digit below their uncertainty), a distinct
/// name, one more assumption and a `[calibration]` table; the posted header names it;
/// calibrating the calibrated file again replaces the table, not adds one.
#[test]
fn the_written_machine_file_is_an_edit_of_the_original() {
    let dir = tempdir("calib-write");
    let out = dir.join("fadal-cal.toml");
    let log = fixture();
    let args = |machine: &str, out: &std::path::Path| {
        ok(&lampost(&[
            "calibrate",
            "pivot",
            "--machine",
            machine,
            log.to_str().expect("utf8"),
            "--radius",
            "0.5",
            "--stylus-radius",
            "0.0625",
            "--method",
            "iii",
            "--write",
            out.to_str().expect("utf8"),
        ]))
    };
    args("fadal-lamp", &out);
    let original = ok(&lampost(&["machines", "show", "fadal-lamp"]));
    let text = std::fs::read_to_string(&out).expect("written");
    // Every comment of the original is still there, in order.
    let comments = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| l.trim_start().starts_with('#'))
            .map(str::to_string)
            .collect()
    };
    let (c0, c1) = (comments(&original), comments(&text));
    assert!(c0.iter().all(|c| c1.contains(c)), "{text}");
    assert!(text.contains("name = \"fadal-lamp-cal\""), "{text}");
    assert!(
        text.contains("R = [-4.865211, 1.491088, 7.080284]"),
        "{text}"
    );
    assert!(
        text.contains("L = [-10.10308, 0.03632, -8.72762]"),
        "{text}"
    );
    assert!(
        text.contains("\n[calibration]\n") && text.contains("method = \"iii\""),
        "{text}"
    );
    assert!(text.contains("calibrated_from = \"fadal-lamp\""), "{text}");
    assert!(
        !text.contains("e-16") && !text.contains("00000000"),
        "{text}"
    );
    // Only those lines differ.
    let changed = original
        .lines()
        .filter(|l| !text.lines().any(|m| m == *l))
        .count();
    assert_eq!(changed, 2, "the name and R lines only:\n{text}");
    // The posted header names the calibrated file.
    let posted = ok(&lampost(&[
        "post",
        "--machine",
        out.to_str().expect("utf8"),
        "--job",
        root()
            .join("fixtures/post/bearing-seat/job.toml")
            .to_str()
            .expect("utf8"),
        "-q",
    ]));
    assert!(posted.contains("POST FOR FADAL-LAMP-CAL)"), "{posted}");
    // Again from the calibrated file: one [calibration] table, the same name.
    let again = dir.join("again.toml");
    args(out.to_str().expect("utf8"), &again);
    let t2 = std::fs::read_to_string(&again).expect("written");
    assert_eq!(t2.matches("[calibration]").count(), 1, "{t2}");
    assert!(t2.contains("name = \"fadal-lamp-cal\""), "{t2}");
}
