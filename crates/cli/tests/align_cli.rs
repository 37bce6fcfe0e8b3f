//! `lampost fit`, `align`, `probe` as a user runs them.

mod common;

use common::*;

fn json(o: &std::process::Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("json")
}

fn sphere_points(c: [f64; 3], r: f64, n: usize) -> String {
    let mut s = String::from("x y z\n");
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    for i in 0..n {
        let z = 1.0 - 0.5 * (i as f64 + 0.5) / n as f64;
        let rho = (1.0 - z * z).sqrt();
        let phi = golden * i as f64;
        s.push_str(&format!(
            "{} {} {}\n",
            c[0] + r * rho * phi.cos(),
            c[1] + r * rho * phi.sin(),
            c[2] + r * z
        ));
    }
    s
}

#[test]
fn fits_from_files_and_stdin() {
    let pts = sphere_points([1.0, 2.0, 3.0], 12.75, 30);
    let v = json(&lampost_stdin(
        &["fit", "sphere", "-", "--json", "--ball-radius", "12.5"],
        pts.as_bytes(),
    ));
    for (k, w) in [1.0, 2.0, 3.0].iter().enumerate() {
        assert!(
            (v["center"][k].as_f64().expect("c") - w).abs() < 1e-9,
            "{v}"
        );
    }
    assert!((v["radius"].as_f64().expect("r") - 12.75).abs() < 1e-9);
    assert!((v["probe_radius"].as_f64().expect("p") - 0.25).abs() < 1e-9);
    assert_eq!(v["n"], 30);
    let v = json(&lampost_stdin(
        &["fit", "sphere", "-", "--json", "--radius", "12.75"],
        pts.as_bytes(),
    ));
    assert_eq!(v["radius_fixed"], true);
    assert!((v["center"][2].as_f64().expect("c") - 3.0).abs() < 1e-9);
    let four: String = pts.lines().take(5).map(|l| format!("{l}\n")).collect();
    let v = json(&lampost_stdin(
        &["fit", "sphere4", "-", "--json"],
        four.as_bytes(),
    ));
    assert!((v["radius"].as_f64().expect("r") - 12.75).abs() < 1e-9);
    let v = json(&lampost_stdin(
        &["fit", "plane", "-", "--json"],
        b"0 0 0\n1 0 0\n0 1 0\n1 1 0.001\n",
    ));
    assert!(v["flatness"].as_f64().expect("f") > 0.0);
    let v = json(&lampost_stdin(
        &["fit", "circle", "-", "--json"],
        b"1 0 5\n0 1 5\n-1 0 5\n0 -1 5\n",
    ));
    assert!((v["radius"].as_f64().expect("r") - 1.0).abs() < 1e-12);
    if let Some(shared) = shared() {
        let ds = shared.join("testdata/nist/Sphere/sph20.ds");
        let v = json(&lampost(&[
            "fit",
            "sphere",
            ds.to_str().expect("utf8"),
            "--json",
        ]));
        assert!((v["radius"].as_f64().expect("r") * 2.0 - 21.826_658_487_094_81).abs() < 1e-9);
    }
}

#[test]
fn fit_bad_input() {
    let cases: Vec<(Vec<&str>, &[u8], &str)> = vec![
        (
            vec!["fit", "sphere", "-"],
            b"0 0 0\n1 0 0\n0 1 0\n",
            "needs at least 4 points",
        ),
        (
            vec!["fit", "sphere", "-"],
            b"0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 3 0\n",
            "lie on one plane",
        ),
        (
            vec!["fit", "sphere4", "-"],
            b"0 0 0\n1 0 0\n2 0 0\n0 1 1\n",
            "points 1, 2 and 3 are collinear",
        ),
        (
            vec!["fit", "sphere4", "-"],
            b"0 0 0\n1 0 0\n0 1 0\n1 1 0\n",
            "coplanar",
        ),
        (
            vec!["fit", "plane", "-"],
            b"0 0 0\n1 1 1\n2 2 2\n",
            "collinear",
        ),
        (
            vec!["fit", "plane", "-"],
            b"0 0 0\n1 0 0\n# c\n0 1 0\n1 0 0\n",
            "<stdin>:2 and <stdin>:5 are the same point",
        ),
        (vec!["fit", "plane", "-"], b"0 0 0\n1 0 zz\n", "<stdin>:2:5"),
        (vec!["fit", "plane", "-"], b"", "holds no points"),
        (
            vec!["fit", "sphere", "-", "--radius", "-1"],
            b"0 0 0\n",
            "must be a positive number",
        ),
    ];
    for (args, input, want) in cases {
        let o = lampost_stdin(&args, input);
        let e = stderr(&o);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(e.contains(want), "{args:?}: `{want}` not in\n{e}");
        assert!(e.contains("help:"), "{args:?}");
    }
}

#[test]
fn level_and_angle() {
    let plane = b"0 0 0\n1 0 0.1\n0 1 0.05\n1 1 0.15\n";
    let v = json(&lampost_stdin(
        &["align", "level", "-", "--machine", "fadal-lamp", "--json"],
        plane,
    ));
    let sols = v["solutions"].as_array().expect("solutions");
    assert_eq!(sols.len(), 2);
    // Seed notes' closed form: a = −atan2(ny, nx), b = atan2(√(nx²+ny²), nz).
    let n: Vec<f64> = v["normal"]
        .as_array()
        .expect("n")
        .iter()
        .map(|x| x.as_f64().expect("f"))
        .collect();
    let a = -n[1].atan2(n[0]).to_degrees();
    let b = n[0].hypot(n[1]).atan2(n[2]).to_degrees();
    assert!(
        sols.iter()
            .any(|s| (s["joints"]["A"].as_f64().expect("A") - a).abs() < 1e-9
                && (s["joints"]["B"].as_f64().expect("B") - b).abs() < 1e-9),
        "{v}"
    );
    assert!(sols[0]["residual_tilt_deg"].as_f64().expect("t") < 1e-3);
    let dir = tempdir("angle");
    let setup = dir.join("setup.toml");
    let v = json(&lampost_stdin(
        &[
            "align",
            "angle",
            "-",
            "--to-normal",
            "0,0,1",
            "--write-setup",
            setup.to_str().expect("utf8"),
            "--json",
        ],
        plane,
    ));
    let want = (n[2].acos()).to_degrees();
    assert!((v["angle_deg"].as_f64().expect("a") - want).abs() < 1e-9);
    let text = std::fs::read_to_string(&setup).expect("setup written");
    assert!(text.contains("origin = [") && text.contains("x_axis") && text.contains("z_axis"));
    // The setup keeps what was probed: its Z is the probed normal (the CAD face was the
    // program's XY plane), its X perpendicular to it, so the post tilts with the part.
    let z = &v["setup"]["z_axis"];
    let x = &v["setup"]["x_axis"];
    let mut dot = 0.0;
    for k in 0..3 {
        let zk = z[k].as_f64().expect("z");
        assert!(
            (zk - n[k]).abs() < 1e-9,
            "setup z {z} vs probed normal {n:?}"
        );
        dot += zk * x[k].as_f64().expect("x");
    }
    assert!(dot.abs() < 1e-12, "x ⟂ z: {dot}");
    let o = lampost_stdin(&["align", "angle", "-"], plane);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("exactly one of"));
}

#[test]
fn probe_programs_check_and_their_logs_read_back() {
    let o = lampost(&[
        "probe",
        "sphere",
        "--center",
        "1,2,3",
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.0625",
        "--points",
        "12",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let prog = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(prog.starts_with("%\nO9500"));
    assert!(prog.contains("M64") && prog.contains("G31") && prog.contains("#PRINT \"X\",PX1"));
    assert_eq!(prog.matches("G1 G31").count(), 12);
    // Our own checker accepts it, and the trace shows 12 probing moves.
    let t = lampost_stdin(&["trace", "-", "--units", "inch"], prog.as_bytes());
    assert!(t.status.success());
    assert_eq!(
        String::from_utf8_lossy(&t.stdout)
            .matches("(probe)")
            .count(),
        12
    );
    let o = lampost(&[
        "probe", "plane", "--corner", "0,0,-1", "--size", "20,10", "--grid", "3,2", "--units", "mm",
    ]);
    let prog = String::from_utf8_lossy(&o.stdout);
    assert!(prog.contains("G71") && prog.matches("G1 G31").count() == 6);
    // A log with noise and touch lines.
    let log = b"DNC READY\nX1.0 Y2.0 Z3.0\nTOUCH: X1.5 Y2.0 Z3.1\n\nEND\n";
    let o = lampost_stdin(&["probe", "read", "-"], log);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("1.5 2 3.1"));
    let o = lampost_stdin(&["probe", "read", "-"], b"X1.0 Y2.0 Z3.0\nX1.0 Y Z3\n");
    assert!(stderr(&o).contains("<stdin>:2"), "{}", stderr(&o));
    let o = lampost_stdin(&["probe", "read", "-"], b"nothing here\n");
    assert!(stderr(&o).contains("no touch lines"));
    let o = lampost(&[
        "probe",
        "sphere",
        "--center",
        "1,2",
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.06",
    ]);
    assert!(stderr(&o).contains("expected x,y,z"));
}

#[test]
fn register_to_a_mesh() {
    let pts = root().join("fixtures/points/block-probed.txt");
    let stl = root().join("fixtures/meshes/block.stl");
    let (ps, ss) = (pts.to_str().expect("utf8"), stl.to_str().expect("utf8"));
    let dir = tempdir("register");
    let setup = dir.join("setup.toml");
    let v = json(&lampost(&[
        "align",
        "register",
        ps,
        "--mesh",
        ss,
        "--json",
        "--write-setup",
        setup.to_str().expect("utf8"),
    ]));
    assert!(v["rms"].as_f64().expect("rms") < 1e-8, "{v}");
    for (k, w) in [0.4, -0.3, 0.25].iter().enumerate() {
        assert!(
            (v["translation"][k].as_f64().expect("t") - w).abs() < 1e-7,
            "{v}"
        );
    }
    assert!((v["angle_deg"].as_f64().expect("a") - 1.5).abs() < 1e-7);
    assert_eq!(v["residuals"].as_array().expect("r").len(), 48);
    assert!(std::fs::read_to_string(&setup)
        .expect("setup")
        .contains("x_axis"));
    // Top-face points alone leave rotation about z and in-plane translation unobservable.
    let text = std::fs::read_to_string(&pts).expect("read");
    let top: String = text
        .lines()
        .filter(|l| {
            l.split_whitespace()
                .nth(2)
                .and_then(|z| z.parse::<f64>().ok())
                .is_some_and(|z| z > 45.0)
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let o = lampost_stdin(&["align", "register", "-", "--mesh", ss], top.as_bytes());
    assert!(!o.status.success());
    assert!(stderr(&o).contains("unobservable"), "{}", stderr(&o));
    // An open mesh: warned, still registered against its faces.
    let stl_text = std::fs::read_to_string(&stl).expect("stl");
    let cut = stl_text.find("  facet normal 0 0 1").expect("top facet");
    let end = stl_text[cut..].find("endfacet").expect("end") + cut + "endfacet\n".len();
    let open = dir.join("open.stl");
    std::fs::write(&open, format!("{}{}", &stl_text[..cut], &stl_text[end..])).expect("write");
    let o = lampost(&[
        "align",
        "register",
        ps,
        "--mesh",
        open.to_str().expect("utf8"),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("not a closed manifold"));
    // Bad mesh, bad lock.
    let bad = dir.join("bad.stl");
    std::fs::write(
        &bad,
        "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 zz\nendloop\nendfacet\nendsolid\n",
    )
    .expect("write");
    let o = lampost(&[
        "align",
        "register",
        ps,
        "--mesh",
        bad.to_str().expect("utf8"),
    ]);
    assert!(stderr(&o).contains("line 4"), "{}", stderr(&o));
    let o = lampost(&["align", "register", ps, "--mesh", ss, "--lock", "q"]);
    assert!(stderr(&o).contains("unknown lock `q`"));
}

/// The X and Y of every probing move (`G1 G31 X… Y…`) of a probing program.
fn probing_xy(prog: &str) -> Vec<(f64, f64)> {
    prog.lines()
        .filter(|l| l.starts_with("G1 G31"))
        .map(|l| {
            let word = |c: char| {
                l.split_whitespace()
                    .find_map(|w| w.strip_prefix(c))
                    .and_then(|v| v.parse::<f64>().ok())
                    .expect("word")
            };
            (word('X'), word('Y'))
        })
        .collect()
}

#[test]
fn plane_grid_stays_a_stylus_radius_inside_the_edges() {
    // Default stylus (1.5 mm in millimetres): the corners are never touched.
    let o = lampost(&[
        "probe", "plane", "--corner", "10,20,-1", "--size", "40,30", "--grid", "3,2", "--units",
        "mm",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let xy = probing_xy(&String::from_utf8_lossy(&o.stdout));
    assert_eq!(xy.len(), 6);
    let xs: Vec<f64> = xy.iter().map(|p| p.0).collect();
    let ys: Vec<f64> = xy.iter().map(|p| p.1).collect();
    let (xmin, xmax) = (
        xs.iter().copied().fold(f64::MAX, f64::min),
        xs.iter().copied().fold(f64::MIN, f64::max),
    );
    let (ymin, ymax) = (
        ys.iter().copied().fold(f64::MAX, f64::min),
        ys.iter().copied().fold(f64::MIN, f64::max),
    );
    assert!(
        (xmin - 11.5).abs() < 1e-9 && (xmax - 48.5).abs() < 1e-9,
        "{xs:?}"
    );
    assert!(
        (ymin - 21.5).abs() < 1e-9 && (ymax - 48.5).abs() < 1e-9,
        "{ys:?}"
    );
    // The middle column is still the middle.
    assert!(xs.iter().any(|x| (x - 30.0).abs() < 1e-9));
    // An explicit stylus radius, in inches.
    let o = lampost(&[
        "probe",
        "plane",
        "--corner",
        "0,0,0",
        "--size",
        "2,1",
        "--grid",
        "2,2",
        "--stylus-radius",
        "0.125",
    ]);
    let xy = probing_xy(&String::from_utf8_lossy(&o.stdout));
    assert!(
        xy.iter()
            .all(|&(x, y)| (0.125..=1.875).contains(&x) && (0.125..=0.875).contains(&y)),
        "{xy:?}"
    );
    assert!(xy.iter().any(|&(x, _)| (x - 0.125).abs() < 1e-9));
    // A rectangle no wider than the stylus allows is refused, as is a bad radius.
    let o = lampost(&[
        "probe",
        "plane",
        "--corner",
        "0,0,0",
        "--size",
        "0.2,1",
        "--grid",
        "2,2",
        "--stylus-radius",
        "0.1",
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("inside the edges"), "{}", stderr(&o));
    for bad in ["-1", "nan", "inf"] {
        let o = lampost(&[
            "probe",
            "plane",
            "--corner",
            "0,0,0",
            "--size",
            "2,1",
            "--grid",
            "2,2",
            "--stylus-radius",
            bad,
        ]);
        assert!(!o.status.success(), "{bad}");
        assert!(
            stderr(&o).contains("--stylus-radius"),
            "{bad}: {}",
            stderr(&o)
        );
    }
}

#[test]
fn pose_program_sets_its_modes_once_before_any_move() {
    let o = lampost(&[
        "probe",
        "poses",
        "--machine",
        "fadal-lamp",
        "--ball",
        "0,0,2",
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.0625",
        "--points",
        "6",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let prog = String::from_utf8_lossy(&o.stdout);
    let lines: Vec<&str> = prog.lines().collect();
    assert_eq!(prog.matches("G70 G90").count(), 1, "{prog}");
    assert_eq!(prog.matches("M66").count(), 1);
    assert_eq!(prog.matches("M67").count(), 1);
    let setup = lines
        .iter()
        .position(|l| l.starts_with("G70"))
        .expect("setup");
    let first_move = lines
        .iter()
        .position(|l| l.starts_with("G0") || l.starts_with("G1"))
        .expect("a move");
    assert!(
        setup < first_move,
        "setup at {setup}, first move at {first_move}"
    );
    assert!(lines[1].starts_with("O9502"));
    // Each pose: retract, index, record, its touches; 8 poses × 6 touches.
    assert_eq!(prog.matches("#SPRINT \"POSE ").count(), 8);
    assert_eq!(prog.matches("G1 G31").count(), 48);
    // It checks and traces as a whole.
    let c = lampost_stdin(&["check", "-", "--units", "inch"], prog.as_bytes());
    assert!(c.status.success(), "{}", stderr(&c));
}

#[test]
fn fits_say_when_they_do_not_fit() {
    // Points scattered over a plane: a circle "fits" them only in name.
    let mut plane = String::new();
    let mut k = 7u64;
    let mut next = || {
        k = k
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (k >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..30 {
        plane.push_str(&format!(
            "{} {} {}\n",
            20.0 * next() - 10.0,
            20.0 * next() - 10.0,
            0.02 * next() - 0.01
        ));
    }
    let o = lampost_stdin(&["fit", "circle", "-", "--json"], plane.as_bytes());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: the circle does not fit these points"),
        "{}",
        stderr(&o)
    );
    let v = json(&o);
    assert_eq!(v["warnings"].as_array().map(Vec::len), Some(1), "{v}");
    // A sphere through noisy coplanar points: "coplanar", not "did not converge".
    let o = lampost_stdin(&["fit", "sphere", "-"], plane.as_bytes());
    assert!(!o.status.success());
    assert!(stderr(&o).contains("coplanar"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("did not converge"));
    // A good sphere (a cap, 1e-3 noise on r = 5) has no warning; with the probe's noise
    // given as 1e-4 its residual is too large for that probe.
    let mut cap = String::new();
    for i in 0..40 {
        let (th, ph) = (1.3 * next(), std::f64::consts::TAU * next());
        let r = 5.0 + 0.001 * (if i % 2 == 0 { 1.0 } else { -1.0 }) * next();
        cap.push_str(&format!(
            "{} {} {}\n",
            r * th.sin() * ph.cos(),
            r * th.sin() * ph.sin(),
            r * th.cos()
        ));
    }
    let o = lampost_stdin(&["fit", "sphere", "-", "--json"], cap.as_bytes());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    assert_eq!(json(&o)["warnings"].as_array().map(Vec::len), Some(0));
    let o = lampost_stdin(&["fit", "sphere", "-", "--noise", "0.0001"], cap.as_bytes());
    assert!(
        stderr(&o).contains("times the expected probe noise"),
        "{}",
        stderr(&o)
    );
    // A plane through points of a sphere warns too; a bad noise is refused.
    let o = lampost_stdin(&["fit", "plane", "-"], cap.as_bytes());
    assert!(
        stderr(&o).contains("the plane does not fit"),
        "{}",
        stderr(&o)
    );
    let o = lampost_stdin(&["fit", "plane", "-", "--noise", "-1"], cap.as_bytes());
    assert!(
        !o.status.success() && stderr(&o).contains("--noise"),
        "{}",
        stderr(&o)
    );
}

/// The reported uncertainties of a registration are what the scatter of repeated fits
/// shows: 60 copies of the probed block points with independent noise (σ = 2e-4, a
/// deterministic generator), registered one by one; the spread of each rotation
/// component about the true turn, over the trials, is within 35 % of the mean reported
/// `u_rotation_deg`.
#[test]
fn register_uncertainties_match_the_scatter_of_repeated_fits() {
    let text =
        std::fs::read_to_string(root().join("fixtures/points/block-probed.txt")).expect("read");
    let pts: Vec<[f64; 3]> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with('x'))
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .map(|f| f.parse().expect("number"))
                .collect();
            [v[0], v[1], v[2]]
        })
        .collect();
    let stl = root().join("fixtures/meshes/block.stl");
    let dir = tempdir("register-u");
    // A xorshift generator and Box–Muller: the same noise on every run.
    let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let sigma = 2e-4;
    let trials = 60;
    let mut rot: Vec<[f64; 3]> = Vec::new();
    let mut reported = [0.0; 3];
    for trial in 0..trials {
        let mut s = String::from("x y z\n");
        for p in &pts {
            let mut q = *p;
            for c in &mut q {
                let (u1, u2) = (uniform().max(1e-300), uniform());
                *c += sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            }
            s.push_str(&format!("{:.12} {:.12} {:.12}\n", q[0], q[1], q[2]));
        }
        let f = dir.join(format!("noisy-{trial}.txt"));
        std::fs::write(&f, s).expect("write");
        let v = json(&lampost(&[
            "align",
            "register",
            f.to_str().expect("utf8"),
            "--mesh",
            stl.to_str().expect("utf8"),
            "--json",
        ]));
        let ang = v["angle_deg"].as_f64().expect("angle");
        let axis: Vec<f64> = (0..3)
            .map(|k| v["axis"][k].as_f64().expect("axis"))
            .collect();
        rot.push([axis[0] * ang, axis[1] * ang, axis[2] * ang]);
        for (k, r) in reported.iter_mut().enumerate() {
            *r += v["u_rotation_deg"][k].as_f64().expect("u") / trials as f64;
        }
    }
    for k in 0..3 {
        let mean = rot.iter().map(|r| r[k]).sum::<f64>() / trials as f64;
        let sd =
            (rot.iter().map(|r| (r[k] - mean).powi(2)).sum::<f64>() / (trials - 1) as f64).sqrt();
        let ratio = sd / reported[k];
        eprintln!(
            "rotation {k}: scatter {sd:.3e} reported {:.3e} ratio {ratio:.2}",
            reported[k]
        );
        assert!(
            (0.65..=1.35).contains(&ratio),
            "rotation component {k}: scatter {sd:.3e} vs reported {:.3e} (ratio {ratio:.2})",
            reported[k]
        );
    }
}
