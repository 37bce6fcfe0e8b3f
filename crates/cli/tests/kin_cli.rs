//! `lampost machines` and `lampost kin` as a user runs them.

mod common;

use common::*;

fn json(o: &std::process::Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("json")
}

#[test]
fn machines_lists_and_shows_builtins() {
    let o = lampost(&["machines"]);
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(s.contains("fadal-lamp") && s.contains("nrc-lc"));
    let o = lampost(&["machines", "show", "fadal-lamp"]);
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(
        s.contains("R = [-4.877, 1.4798, 7.0918]")
            && s.contains("L = [-10.10308, 0.03632, -8.72762]")
    );
    // What `show` prints is a machine file `--machine` accepts.
    let dir = tempdir("show");
    let f = dir.join("copy.toml");
    std::fs::write(&f, &o.stdout).expect("write");
    let o = lampost(&[
        "kin",
        "fk",
        "--machine",
        f.to_str().expect("utf8"),
        "--joints",
        "X=0,Y=0,Z=0,A=0,B=0",
        "--json",
    ]);
    let v = json(&o);
    assert_eq!(v["axis"], serde_json::json!([0.0, 0.0, 1.0]));
}

#[test]
fn fk_ik_and_set() {
    let v = json(&lampost(&[
        "kin",
        "fk",
        "--machine",
        "fadal-lamp",
        "--joints",
        "X=1,Y=2,Z=3,A=30,B=-45",
        "--json",
    ]));
    let p: Vec<f64> = v["position"]
        .as_array()
        .expect("p")
        .iter()
        .map(|x| x.as_f64().expect("f"))
        .collect();
    let a: Vec<f64> = v["axis"]
        .as_array()
        .expect("a")
        .iter()
        .map(|x| x.as_f64().expect("f"))
        .collect();
    let pos = format!("{},{},{}", p[0], p[1], p[2]);
    let axis = format!("{},{},{}", a[0], a[1], a[2]);
    let v = json(&lampost(&[
        "kin",
        "ik",
        "--machine",
        "fadal-lamp",
        "--position",
        &pos,
        "--axis",
        &axis,
        "--near",
        "A=30,B=-45",
        "--json",
    ]));
    let best = &v["solutions"][0]["joints"];
    for (k, want) in [
        ("X", 1.0),
        ("Y", 2.0),
        ("Z", 3.0),
        ("A", 30.0),
        ("B", -45.0),
    ] {
        assert!(
            (best[k].as_f64().expect("num") - want).abs() < 1e-9,
            "{k}: {best}"
        );
    }
    assert_eq!(v["solutions"].as_array().expect("list").len(), 2);
    assert_eq!(v["solutions"][0]["within_limits"], true);
    // --set moves the pivot, so the same joints give another tip.
    let v2 = json(&lampost(&[
        "kin",
        "fk",
        "--machine",
        "fadal-lamp",
        "--joints",
        "X=1,Y=2,Z=3,A=30,B=-45",
        "--set",
        "R=0,0,5",
        "--json",
    ]));
    assert_ne!(v2["position"], serde_json::json!(p));
    // NRC: B/C axis names in the output.
    let v = json(&lampost(&[
        "kin",
        "ik",
        "--machine",
        "nrc-lc",
        "--position",
        "0,0,0",
        "--axis",
        "0,0,1",
        "--json",
    ]));
    assert!(v["solutions"][0]["joints"]["C"].is_number());
}

#[test]
fn rotate_reproduces_table_1_of_paper_002() {
    let o = lampost_stdin(
        &[
            "kin",
            "rotate",
            "--machine",
            "fadal-lamp",
            "--joints",
            "A=45,B=-45",
            "--set",
            "R=0.5857864376269049,0,4",
            "-",
        ],
        b"x y z\n0 0 0\n0,1,0\n1\t1\t0 # corner\n1 0 0\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let want = [
        [2.53553, 0.41421, -1.46447],
        [2.03553, 1.12132, -0.96447],
        [2.5355, 1.8284, -1.4645],
        [3.0355, 1.1213, -1.9645],
    ];
    let text = String::from_utf8_lossy(&o.stdout);
    for (line, w) in text.lines().zip(want) {
        let got: Vec<f64> = line
            .split_whitespace()
            .map(|x| x.parse().expect("num"))
            .collect();
        for i in 0..3 {
            assert!((got[i] - w[i]).abs() <= 5e-5, "{line} vs {w:?}");
        }
    }
    assert_eq!(text.lines().count(), 4);
}

#[test]
fn bad_input_is_refused_clearly() {
    let dir = tempdir("kinbad");
    let bad_machine = dir.join("bad.toml");
    let text =
        lampost_kinematics_text().replace("axis = [0.0, -1.0, 0.0]", "axis = [0.0, -2.0, 0.0]");
    std::fs::write(&bad_machine, text).expect("write");
    let nan_machine = dir.join("nan.toml");
    std::fs::write(
        &nan_machine,
        lampost_kinematics_text().replace(
            "resolution = 0.001\n\n[[rotary]]",
            "resolution = nan\n\n[[rotary]]",
        ),
    )
    .expect("write");
    let pts = dir.join("pts.txt");
    std::fs::write(&pts, "0 0 0\n1 x 2\n").expect("write");
    let bm = bad_machine.to_str().expect("utf8").to_string();
    let nm = nan_machine.to_str().expect("utf8").to_string();
    let pf = pts.to_str().expect("utf8").to_string();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "kin",
                "fk",
                "--machine",
                "fadal-lamp",
                "--joints",
                "X=0,Y=0,Z=0,A=0,Q=1",
            ],
            "unknown axis `Q`",
        ),
        (
            vec![
                "kin",
                "fk",
                "--machine",
                "fadal-lamp",
                "--joints",
                "X=0,Y=0,Z=0,A=0",
            ],
            "no value for axis B",
        ),
        (
            vec![
                "kin",
                "fk",
                "--machine",
                "fadal-lamp",
                "--joints",
                "X=0,Y=0,Z=0,A=0,B=135",
            ],
            "B = 135 is outside its limits [-120, 120]",
        ),
        (
            vec![
                "kin",
                "fk",
                "--machine",
                "fadal-lamp",
                "--joints",
                "X=0,Y=abc,Z=0,A=0,B=0",
            ],
            "`abc` is not a finite number",
        ),
        (
            vec![
                "kin",
                "fk",
                "--machine",
                "fadal-lamp",
                "--joints",
                "X=0,Y=NaN,Z=0,A=0,B=0",
            ],
            "`NaN` is not a finite number",
        ),
        (
            vec![
                "kin",
                "ik",
                "--machine",
                "fadal-lamp",
                "--position",
                "0,0,0",
                "--axis",
                "0,0,0",
            ],
            "zero length",
        ),
        (
            vec![
                "kin",
                "ik",
                "--machine",
                "fadal-lamp",
                "--position",
                "0,0,0",
                "--axis",
                "0.5,0,-0.866",
            ],
            "nearest reachable orientation",
        ),
        (
            vec![
                "kin",
                "fk",
                "--machine",
                &bm,
                "--joints",
                "X=0,Y=0,Z=0,A=0,B=0",
            ],
            "rotary axis B axis is not a unit vector",
        ),
        (
            vec![
                "kin",
                "fk",
                "--machine",
                &nm,
                "--joints",
                "X=0,Y=0,Z=0,A=0,B=0",
            ],
            "nan.toml:",
        ),
        (
            vec![
                "kin",
                "fk",
                "--machine",
                "no-such-machine",
                "--joints",
                "X=0",
            ],
            "not a built-in machine",
        ),
        (
            vec![
                "kin",
                "fk",
                "--machine",
                "fadal-lamp",
                "--joints",
                "X=0,Y=0,Z=0,A=0,B=0",
                "--head",
                "torch",
            ],
            "unknown head `torch`",
        ),
        (
            vec![
                "kin",
                "fk",
                "--machine",
                "fadal-lamp",
                "--joints",
                "X=0,Y=0,Z=0,A=0,B=0",
                "--set",
                "R=1,2",
            ],
            "has 2 values",
        ),
        (
            vec![
                "kin",
                "fk",
                "--machine",
                "nrc-lc",
                "--joints",
                "X=0,Y=0,Z=0,B=0,C=0",
                "--set",
                "H=1,2,3",
            ],
            "is a scalar",
        ),
        (
            vec![
                "kin",
                "rotate",
                "--machine",
                "fadal-lamp",
                "--joints",
                "A=0,B=0",
                &pf,
            ],
            "pts.txt:2:3",
        ),
        (
            vec![
                "kin",
                "rotate",
                "--machine",
                "fadal-lamp",
                "--joints",
                "A=0,B=200",
                &pf,
            ],
            "outside its limits",
        ),
    ];
    for (args, want) in cases {
        let o = lampost(&args);
        let e = stderr(&o);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(e.contains(want), "{args:?}: `{want}` not in\n{e}");
        assert!(e.contains("help:"), "{args:?}: no hint in\n{e}");
        assert!(!e.contains("panicked"));
    }
}

fn lampost_kinematics_text() -> String {
    std::fs::read_to_string(root().join("fixtures/machines/fadal-lamp.toml")).expect("fixture")
}

/// `kin ik --points`: many poses solved by the batch solver give, row by row, the first
/// within-limits solution the one-pose `kin ik` lists (the scalar solver), on both
/// machines; bad rows are named by their line.
#[test]
fn ik_points_agrees_with_the_one_pose_solver() {
    let dir = tempdir("ik-points");
    // A deterministic spread of tips and tool axes within 60° of +Z.
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut u = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for (machine, size) in [("fadal-lamp", 3.0), ("nrc-lc", 60.0)] {
        let mut rows = String::from("x y z i j k\n");
        let mut poses = Vec::new();
        for _ in 0..41 {
            let p = [size * (u() - 0.5), size * (u() - 0.5), size * 0.3 * u()];
            let (th, ph) = (60f64.to_radians() * u(), std::f64::consts::TAU * u());
            let a = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            rows.push_str(&format!(
                "{} {} {} {} {} {}\n",
                p[0], p[1], p[2], a[0], a[1], a[2]
            ));
            poses.push((p, a));
        }
        let f = dir.join(format!("{machine}.txt"));
        std::fs::write(&f, rows).expect("write");
        let v = json(&lampost(&[
            "kin",
            "ik",
            "--machine",
            machine,
            "--points",
            f.to_str().expect("utf8"),
            "--json",
        ]));
        let got = v["poses"].as_array().expect("poses");
        assert_eq!(got.len(), poses.len());
        for (k, ((p, a), g)) in poses.iter().zip(got).enumerate() {
            let one = json(&lampost(&[
                "kin",
                "ik",
                "--machine",
                machine,
                "--position",
                &format!("{},{},{}", p[0], p[1], p[2]),
                "--axis",
                &format!("{},{},{}", a[0], a[1], a[2]),
                "--json",
            ]));
            let best = one["solutions"]
                .as_array()
                .expect("solutions")
                .iter()
                .find(|s| s["within_limits"] == true)
                .expect("a solution within limits");
            assert_eq!(g["line"], k + 2);
            assert_eq!(
                g["joints"], best["joints"],
                "{machine} pose {k}: {g} vs {best}"
            );
        }
    }
    // Bad input: no axis columns, a zero axis, a pose out of reach.
    for (rows, want) in [
        ("x y z\n1 2 3\n", "no tool axis columns"),
        (
            "x y z i j k\n1 2 3 0 0 1\n1 2 3 0 0 0\n",
            "<stdin>:3: the tool axis (0, 0, 0) has no direction",
        ),
        (
            "x y z i j k\n1 2 3 0 0 -1\n",
            "<stdin>:2: no solution within limits",
        ),
        ("x y z i j\n1 2 3 0 0\n", "not all three"),
    ] {
        let o = lampost_stdin(
            &["kin", "ik", "--machine", "fadal-lamp", "--points", "-"],
            rows.as_bytes(),
        );
        assert!(!o.status.success(), "{rows}");
        assert!(stderr(&o).contains(want), "{rows}: {}", stderr(&o));
    }
}
