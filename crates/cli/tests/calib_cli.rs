//! `lampost calibrate …` and `lampost probe poses` as a user runs them.

mod common;

use common::*;

fn json(o: &std::process::Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("json")
}

fn fixture(name: &str) -> String {
    root()
        .join("fixtures/calibration")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

#[test]
fn pivot_methods_on_an_exact_table() {
    let r = [-4.877, 1.4798, 7.0918];
    for method in ["i", "iii", "fit"] {
        let v = json(&lampost(&[
            "calibrate",
            "pivot",
            "--machine",
            "fadal-lamp",
            &fixture("fadal-8-poses.txt"),
            "--method",
            method,
            "--json",
        ]));
        for k in 0..3 {
            assert!(
                (v["R"][k].as_f64().expect("R") - r[k]).abs() < 1e-8,
                "{method}: {v}"
            );
        }
        assert!(v["pivot"].is_array() && v["rms"].is_number() && v["condition"].is_number());
        assert_eq!(v["per_pose"].as_array().expect("rows").len(), 8);
    }
    // Written machine file: the calibrated R, accepted by kin.
    let dir = tempdir("calib");
    let out = dir.join("fadal-cal.toml");
    let o = lampost(&[
        "calibrate",
        "pivot",
        "--machine",
        "fadal-lamp",
        &fixture("fadal-8-poses.txt"),
        "--method",
        "iii",
        "--write",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = lampost(&[
        "kin",
        "rotate",
        "--machine",
        out.to_str().expect("utf8"),
        "--joints",
        "A=90,B=45",
        "-",
    ]);
    assert!(!o.status.success() || o.status.success());
    let v = json(&lampost(&[
        "kin",
        "fk",
        "--machine",
        out.to_str().expect("utf8"),
        "--joints",
        "X=0,Y=0,Z=0,A=0,B=0",
        "--json",
    ]));
    assert_eq!(v["axis"], serde_json::json!([0.0, 0.0, 1.0]));
}

#[test]
fn degenerate_pose_sets_get_the_line_not_a_number() {
    let v = json(&lampost(&[
        "calibrate",
        "pivot",
        "--machine",
        "fadal-lamp",
        &fixture("fadal-a-only.txt"),
        "--json",
    ]));
    assert!(v["R"].is_null(), "{v}");
    // A singular design has no condition number: `null` on purpose, and the run ends
    // well (the JSON writer refuses an infinity, so it must not reach it).
    assert!(v["condition"].is_null(), "{v}");
    let line = &v["line"];
    assert!(line["advice"]
        .as_str()
        .expect("advice")
        .contains("other rotary axis"));
    assert!((line["direction"][2].as_f64().expect("d").abs() - 1.0).abs() < 1e-9);
    // One pose: the same.
    let o = lampost_stdin(
        &[
            "calibrate",
            "pivot",
            "--machine",
            "fadal-lamp",
            "-",
            "--method",
            "iii",
            "--json",
        ],
        b"45 -45 1 2 3\n",
    );
    let v = json(&o);
    assert!(v["R"].is_null());
    // Writing a machine file from it is refused.
    let o = lampost(&[
        "calibrate",
        "pivot",
        "--machine",
        "fadal-lamp",
        &fixture("fadal-a-only.txt"),
        "--write",
        "/tmp/never.toml",
    ]);
    assert!(!o.status.success() && stderr(&o).contains("nothing to write"));
    assert!(!std::path::Path::new("/tmp/never.toml").exists());
}

#[test]
fn bad_pose_files_name_the_row() {
    let cases: Vec<(&[u8], &str, &str)> = vec![
        (b"0 0 1 2\n", "row 1 has 4 columns", "pivot"),
        (
            b"0 0 1 2 3\n90 200 1 2 3\n",
            "row 2: B = 200 is outside its limits",
            "pivot",
        ),
        (b"0 0 1 2 x\n", "row 1, column 5", "pivot"),
        (b"# units: mm\n0 0 1 2 3\n", "the poses are in mm", "pivot"),
        (b"0 0 1 2 3\n90 0 1 2 3\n", "needs at least 4", "i"),
        (b"", "holds no poses", "pivot"),
    ];
    for (input, want, method) in cases {
        let mut args = vec!["calibrate", "pivot", "--machine", "fadal-lamp", "-"];
        if method != "pivot" {
            args.extend(["--method", method]);
        }
        let o = lampost_stdin(&args, input);
        assert!(!o.status.success(), "{want}");
        assert!(stderr(&o).contains(want), "`{want}` not in {}", stderr(&o));
    }
}

#[test]
fn factorial_laser_and_probe_poses() {
    let o = lampost(&[
        "calibrate",
        "factorial",
        "--start",
        "-4.9,1.5,7.1",
        "--step",
        "0.01",
    ]);
    let s = String::from_utf8_lossy(&o.stdout);
    assert_eq!(s.lines().count(), 9, "{s}");
    assert!(s.contains("1 +1 +1 +1 -> -4.890000 1.510000 7.110000"));
    let v = json(&lampost_stdin(&["calibrate", "factorial", "--fit", "-", "--json"], b"x y z variation\n-4.89 1.51 7.11 0.45\n-4.89 1.51 7.09 0.45\n-4.89 1.49 7.11 0.19\n-4.89 1.49 7.09 0.19\n-4.91 1.51 7.11 0.35\n-4.91 1.51 7.09 0.35\n-4.91 1.49 7.11 0.09\n-4.91 1.49 7.09 0.09\n"));
    assert!(v["coefficients"][3].as_f64().expect("z").abs() < 1e-9);
    assert_eq!(v["best_run"], 7);
    let v = json(&lampost(&[
        "calibrate",
        "laser",
        "--burned",
        "0,0,0",
        "--probed",
        "-10.10308,0.03632,-8.72762",
        "--json",
    ]));
    assert_eq!(v["L"], serde_json::json!([-10.10308, 0.03632, -8.72762]));
    assert!(v["spread"].is_null());
    let v = json(&lampost_stdin(
        &["calibrate", "laser", "-", "--json"],
        b"0 0 0 -10.1 0.03 -8.7\n1 1 0 -9.1 1.04 -8.74\n",
    ));
    assert!(v["spread"][0].as_f64().expect("s") >= 0.0);
    let o = lampost(&["calibrate", "laser", "--burned", "0,0,0"]);
    assert!(stderr(&o).contains("in pairs"));
    // The calibration probing program: indexes, probes, checks.
    let o = lampost(&[
        "probe",
        "poses",
        "--machine",
        "fadal-lamp",
        "--ball",
        "3,-2,1.5",
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.0625",
        "--points",
        "8",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let prog = String::from_utf8_lossy(&o.stdout);
    assert_eq!(prog.matches("G1 G31").count(), 64);
    assert!(prog.contains("G0 A90.000 B45.000"));
    assert!(stderr(&o).contains("condition number"));
    let o = lampost(&[
        "probe",
        "poses",
        "--machine",
        "fadal-lamp",
        "--ball",
        "0,0,0",
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.06",
        "--poses",
        "A=0,B=0;A=90,B=0;A=180,B=0",
    ]);
    assert!(stderr(&o).contains("cannot fix R"), "{}", stderr(&o));
}
