//! `lampost inspect` end to end on the NRC cell, with the truth known: sampling points on
//! a dome (a sphere cap), readings made in this test by intersecting each planned beam
//! with an "actual" sphere (grown and moved by known amounts), reduced back; checked
//! against paper 003's eq. (3) written out here, and against the actual sphere.

mod common;

use common::*;

const R: f64 = 20.0;
const C: [f64; 3] = [0.0, 0.0, -10.0];
const H: f64 = 150.0;

/// Points on a sphere cap (centre `c`, radius `r`) with their outward normals, at the
/// polar angles `tilts` (degrees) and `per_ring` azimuths each (one at the pole), as a
/// point file `x y z i j k` in `dir`.
fn cap(
    dir: &std::path::Path,
    c: [f64; 3],
    r: f64,
    tilts: &[i32],
    per_ring: i32,
) -> std::path::PathBuf {
    let mut s = String::from("x y z i j k\n");
    for &t in tilts {
        let az: Vec<i32> = if t == 0 {
            vec![0]
        } else {
            (0..per_ring).map(|k| k * 360 / per_ring).collect()
        };
        for a in az {
            let (th, ph) = (f64::from(t).to_radians(), f64::from(a).to_radians());
            let n = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            s.push_str(&format!(
                "{} {} {} {} {} {}\n",
                c[0] + r * n[0],
                c[1] + r * n[1],
                c[2] + r * n[2],
                n[0],
                n[1],
                n[2]
            ));
        }
    }
    let p = dir.join("dome.txt");
    std::fs::write(&p, s).expect("write");
    p
}

/// The NRC dome: 25 points, polar angles 0–60° by 15°, six azimuths a ring.
fn dome(dir: &std::path::Path) -> std::path::PathBuf {
    cap(dir, C, R, &[0, 15, 30, 45, 60], 6)
}

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "{}", stderr(o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Plan rows: (id, X, Y, Z, B, C, nominal point, normal).
type Row = (String, [f64; 5], [f64; 3], [f64; 3]);

fn rows(plan: &str) -> Vec<Row> {
    plan.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("id "))
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            let v: Vec<f64> = f[1..].iter().map(|x| x.parse().expect("number")).collect();
            (
                f[0].to_string(),
                [v[0], v[1], v[2], v[3], v[4]],
                [v[5], v[6], v[7]],
                [v[8], v[9], v[10]],
            )
        })
        .collect()
}

/// Paper 003's eq. (3): x_w = Rot(B, C)·(x_t + (−X, −Y, Z + H)) − (0, 0, H), with the
/// surface at x_t = (0, 0, −r) in the tool frame.
fn eq3(j: &[f64; 5], r: f64) -> [f64; 3] {
    let (sb, cb) = j[3].to_radians().sin_cos();
    let (sc, cc) = j[4].to_radians().sin_cos();
    let rot = [
        [cc * cb, sc, -cc * sb],
        [-sc * cb, cc, sc * sb],
        [sb, 0.0, cb],
    ];
    let v = [-j[0], -j[1], -r + j[2] + H];
    let mut x = [0.0; 3];
    for i in 0..3 {
        x[i] = (0..3).map(|k| rot[i][k] * v[k]).sum();
    }
    x[2] -= H;
    x
}

/// The reading at a row: where the beam from the sensor's zero (eq. (3) at r = 0) into
/// the part meets the actual sphere, as a distance beyond the zero.
fn reading(j: &[f64; 5], centre: [f64; 3], radius: f64) -> f64 {
    let p = eq3(j, 0.0);
    let q = eq3(j, 1.0);
    let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]]; // unit: one unit of r
    let f = [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]];
    let b: f64 = 2.0 * (0..3).map(|k| d[k] * f[k]).sum::<f64>();
    let c: f64 = f.iter().map(|x| x * x).sum::<f64>() - radius * radius;
    let disc = b * b - 4.0 * c;
    assert!(disc > 0.0);
    let (t1, t2) = ((-b - disc.sqrt()) / 2.0, (-b + disc.sqrt()) / 2.0);
    if t1.abs() < t2.abs() {
        t1
    } else {
        t2
    }
}

#[test]
fn plan_simulate_reduce_compare_on_the_nrc_cell() {
    let dir = tempdir("inspect");
    let pts = dome(&dir);
    let plan = dir.join("dome.plan");
    let prog = dir.join("dome.nc");
    ok(&lampost(&[
        "inspect",
        "plan",
        "--machine",
        "nrc-lc",
        "--points",
        pts.to_str().expect("utf8"),
        "-o",
        plan.to_str().expect("utf8"),
        "--program",
        prog.to_str().expect("utf8"),
    ]));
    let text = std::fs::read_to_string(&plan).expect("plan");
    let rs = rows(&text);
    assert_eq!(rs.len(), 25);
    // The plan puts the sensor's zero on each nominal point, the beam along its normal
    // (eq. (3) written out: r = 0 is the point, r = 1 one unit inside along −n).
    for (id, j, p, n) in &rs {
        let z = eq3(j, 0.0);
        let inside = eq3(j, 1.0);
        for k in 0..3 {
            assert!((z[k] - p[k]).abs() < 1e-5, "{id}: {z:?} vs {p:?}");
            assert!(((z[k] - inside[k]) - n[k]).abs() < 1e-6, "{id}: beam");
        }
    }
    // The order keeps rotary motion small: less in all than measuring the points in the
    // order they were given (the same rows, sorted by id).
    let travel = |order: &[&Row]| -> f64 {
        order
            .windows(2)
            .map(|w| {
                let db = (w[1].1[3] - w[0].1[3]).abs();
                let dc = (w[1].1[4] - w[0].1[4]).abs().rem_euclid(360.0);
                db + dc.min(360.0 - dc)
            })
            .sum()
    };
    let planned: Vec<&Row> = rs.iter().collect();
    let mut given = planned.clone();
    given.sort_by_key(|r| r.0[1..].parse::<usize>().expect("id"));
    let (tp, tg) = (travel(&planned), travel(&given));
    assert!(
        tp < tg,
        "planned order {tp}° of rotary motion, given order {tg}°"
    );
    // The program reads back clean.
    let o = lampost(&["check", prog.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The actual part: the dome grown by 0.03 and moved by (0.01, −0.02, 0.015).
    let centre = [C[0] + 0.01, C[1] - 0.02, C[2] + 0.015];
    let radius = R + 0.03;
    let mut log = String::from("# simulated readings\n");
    let mut want = Vec::new();
    for (id, j, _, _) in &rs {
        let r = reading(j, centre, radius);
        log.push_str(&format!("{id} {r:.12}\n"));
        want.push(eq3(j, r));
    }
    let logf = dir.join("dome.log");
    std::fs::write(&logf, &log).expect("log");
    let v: serde_json::Value = serde_json::from_str(&ok(&lampost(&[
        "inspect",
        "reduce",
        "--machine",
        "nrc-lc",
        "--plan",
        plan.to_str().expect("utf8"),
        logf.to_str().expect("utf8"),
        "--json",
    ])))
    .expect("json");
    let got = v["points"].as_array().expect("points");
    assert_eq!(got.len(), 25);
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g["status"], "ok");
        for k in 0..3 {
            let q = g["measured"][k].as_f64().expect("measured");
            // eq. (3) and lampost's kinematics agree, and the point is on the actual sphere.
            assert!((q - w[k]).abs() < 1e-9, "{g} vs {w:?}");
        }
        let q: Vec<f64> = (0..3)
            .map(|k| g["measured"][k].as_f64().expect("m"))
            .collect();
        let dist =
            ((q[0] - centre[0]).powi(2) + (q[1] - centre[1]).powi(2) + (q[2] - centre[2]).powi(2))
                .sqrt();
        assert!((dist - radius).abs() < 1e-9, "{g}: {dist}");
        // Deviation along the normal ≈ growth + the move's component along the normal.
        let n: Vec<f64> = (0..3)
            .map(|k| g["normal"][k].as_f64().expect("n"))
            .collect();
        let expect = 0.03 + 0.01 * n[0] - 0.02 * n[1] + 0.015 * n[2];
        assert!(
            (g["deviation"].as_f64().expect("d") - expect).abs() < 1e-4,
            "{g}"
        );
    }
    // The text form and the statistics.
    let red = dir.join("dome.measured");
    ok(&lampost(&[
        "inspect",
        "reduce",
        "--machine",
        "nrc-lc",
        "--plan",
        plan.to_str().expect("utf8"),
        logf.to_str().expect("utf8"),
        "-o",
        red.to_str().expect("utf8"),
    ]));
    let s: serde_json::Value = serde_json::from_str(&ok(&lampost(&[
        "inspect",
        "compare",
        red.to_str().expect("utf8"),
        "--tol",
        "0.04",
        "--json",
    ])))
    .expect("json");
    assert_eq!(s["stats"]["n"], 25);
    let mean = s["stats"]["mean"].as_f64().expect("mean");
    assert!((mean - 0.03).abs() < 0.02, "{s}");
    // Growth 0.03 plus the move (|m| = 0.0269) along each normal: within 0.03 ± 0.0270.
    let (lo, hi) = (
        s["stats"]["min"].as_f64().expect("min"),
        s["stats"]["max"].as_f64().expect("max"),
    );
    assert!(lo > 0.03 - 0.027 && hi < 0.03 + 0.027, "{s}");
    let share = s["stats"]["within_tol"].as_f64().expect("share");
    assert!(share > 0.0 && share < 1.0, "{s}");
}

#[test]
fn readings_out_of_range_or_missing_are_flagged_and_bad_logs_refused() {
    let dir = tempdir("inspect-bad");
    let pts = dome(&dir);
    let plan = dir.join("dome.plan");
    ok(&lampost(&[
        "inspect",
        "plan",
        "--machine",
        "nrc-lc",
        "--points",
        pts.to_str().expect("utf8"),
        "-o",
        plan.to_str().expect("utf8"),
    ]));
    let text = std::fs::read_to_string(&plan).expect("plan");
    let ids: Vec<String> = rows(&text).into_iter().map(|r| r.0).collect();
    // p? out of range (7 > ±5), one with no reading, the last missing from the log.
    let mut log = format!("{} 7.0\n{} none\n", ids[0], ids[1]);
    for id in &ids[2..ids.len() - 1] {
        log.push_str(&format!("{id} 0.01\n"));
    }
    let logf = dir.join("bad.log");
    std::fs::write(&logf, &log).expect("log");
    let reduce = |log: &std::path::Path| {
        lampost(&[
            "inspect",
            "reduce",
            "--machine",
            "nrc-lc",
            "--plan",
            plan.to_str().expect("utf8"),
            log.to_str().expect("utf8"),
            "--json",
        ])
    };
    let o = reduce(&logf);
    let v: serde_json::Value = serde_json::from_str(&ok(&o)).expect("json");
    let status: Vec<&str> = v["points"]
        .as_array()
        .expect("points")
        .iter()
        .map(|p| p["status"].as_str().expect("status"))
        .collect();
    assert_eq!(status[0], "out_of_range");
    assert_eq!(status[1], "no_reading");
    assert_eq!(status[ids.len() - 1], "missing");
    assert_eq!(status.iter().filter(|s| **s == "ok").count(), ids.len() - 3);
    let e = stderr(&o);
    assert!(
        e.contains(&format!("point {}: out of range (reading 7)", ids[0])),
        "{e}"
    );
    // A log whose ids do not match the plan; an id read twice; a garbled reading.
    for (bad, want) in [
        ("p999 0.1\n".to_string(), "not in the plan"),
        (
            format!("{0} 0.1\n{0} 0.2\n", ids[0]),
            "read already at line 1",
        ),
        (format!("{} 0..1\n", ids[0]), "neither a reading"),
    ] {
        let f = dir.join("x.log");
        std::fs::write(&f, bad).expect("log");
        let o = reduce(&f);
        assert!(!o.status.success());
        assert!(
            stderr(&o).contains(want) && stderr(&o).contains("x.log:"),
            "{}",
            stderr(&o)
        );
    }
    // A plan for another machine.
    let other = dir.join("other.plan");
    std::fs::write(
        &other,
        text.replacen("machine nrc-lc", "machine fadal-lamp", 1),
    )
    .expect("w");
    let o = lampost(&[
        "inspect",
        "reduce",
        "--machine",
        "nrc-lc",
        "--plan",
        other.to_str().expect("utf8"),
        logf.to_str().expect("utf8"),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("this plan is for machine fadal-lamp"),
        "{}",
        stderr(&o)
    );
    // A sensor table with a bad value: refused at its head, with the file's line.
    let shown = ok(&lampost(&["machines", "show", "nrc-lc"]));
    let badm = dir.join("bad-sensor.toml");
    std::fs::write(&badm, shown.replace("range = 5.0", "range = -1.0")).expect("w");
    let o = lampost(&[
        "inspect",
        "plan",
        "--machine",
        badm.to_str().expect("utf8"),
        "--points",
        pts.to_str().expect("utf8"),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("sensor.range = -1"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("bad-sensor.toml:"), "{}", stderr(&o));
    // A machine without a sensor; points no orientation reaches (nothing written).
    let o = lampost(&[
        "inspect",
        "plan",
        "--machine",
        "fadal-lamp",
        "--points",
        pts.to_str().expect("utf8"),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("no head with a sensor"),
        "{}",
        stderr(&o)
    );
    let under = dir.join("under.txt");
    std::fs::write(&under, "x y z i j k\n0 0 0 0 0 1\n0 0 -5 0 0 -1\n").expect("w");
    let out = dir.join("under.plan");
    let o = lampost(&[
        "inspect",
        "plan",
        "--machine",
        "nrc-lc",
        "--points",
        under.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("1 of 2 points cannot be measured"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists(), "nothing written");
    let o = lampost(&[
        "inspect",
        "plan",
        "--machine",
        "nrc-lc",
        "--points",
        under.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
        "--skip-unreachable",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(rows(&std::fs::read_to_string(&out).expect("plan")).len(), 1);
}

/// The FADAL's touch probe: `inspect plan --stylus-radius` writes a G31 program along the
/// normals (a POSE record per table position); a probe simulated here with paper 000's
/// table transform written out (a part point p sits at M(a, b)·(p + R) − R, M =
/// Ry(−b)·Rz(a)) touches an "actual" sphere; `inspect reduce` reads the RS-232 log.
#[test]
fn touch_probe_inspection_on_the_fadal() {
    const RT: [f64; 3] = [-4.877, 1.4798, 7.0918];
    let (r0, c0) = (1.0, [0.0, 0.0, 0.5]);
    let stylus = 0.0625;
    let dir = tempdir("inspect-fadal");
    let pts = cap(&dir, c0, r0, &[0, 30, 60], 4);
    let (plan, prog) = (dir.join("dome.plan"), dir.join("dome.nc"));
    ok(&lampost(&[
        "inspect",
        "plan",
        "--machine",
        "fadal-lamp",
        "--points",
        pts.to_str().expect("utf8"),
        "--stylus-radius",
        "0.0625",
        "-o",
        plan.to_str().expect("utf8"),
        "--program",
        prog.to_str().expect("utf8"),
    ]));
    let program = std::fs::read_to_string(&prog).expect("program");
    // Machine → part: p = M⁻¹·(q + R) − R, M = Ry(−b)·Rz(a).
    let to_part = |q: [f64; 3], a: f64, b: f64| {
        let v = [q[0] + RT[0], q[1] + RT[1], q[2] + RT[2]];
        // M⁻¹ = Rz(−a)·Ry(b).
        let (sb, cb) = b.to_radians().sin_cos();
        let w = [cb * v[0] + sb * v[2], v[1], -sb * v[0] + cb * v[2]];
        let (sa, ca) = (-a).to_radians().sin_cos();
        let u = [ca * w[0] - sa * w[1], sa * w[0] + ca * w[1], w[2]];
        [u[0] - RT[0], u[1] - RT[1], u[2] - RT[2]]
    };
    let centre = [0.004, -0.003, 0.5 + 0.002];
    let radius = r0 + 0.005;
    let mut log = String::from("SIMULATED RS-232 CAPTURE\n");
    let (mut pos, mut rot) = ([0.0f64; 3], (0.0, 0.0));
    let mut touch = None;
    for line in program.lines() {
        let t = line.trim();
        if let Some(rec) = t.strip_prefix("#SPRINT \"POSE") {
            log.push_str(&format!("POSE{}\n", rec.trim_end_matches('"')));
            continue;
        }
        if t.starts_with("#SPRINT") {
            let p: [f64; 3] = touch.take().expect("touch");
            log.push_str(&format!("X{:.4} Y{:.4} Z{:.4}\n", p[0], p[1], p[2]));
            continue;
        }
        if t.starts_with('(') || t.starts_with('#') || t == "%" {
            continue;
        }
        let mut to = pos;
        let mut g31 = false;
        for w in t.split_whitespace() {
            let (l, v) = w.split_at(1);
            let Ok(v) = v.trim_end_matches('.').parse::<f64>() else {
                continue;
            };
            match l {
                "X" => to[0] = v,
                "Y" => to[1] = v,
                "Z" => to[2] = v,
                "A" => rot.0 = v,
                "B" => rot.1 = v,
                "G" if v == 31.0 => g31 = true,
                _ => {}
            }
        }
        if g31 {
            let (p0, p1) = (to_part(pos, rot.0, rot.1), to_part(to, rot.0, rot.1));
            let d = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]];
            let f = [p0[0] - centre[0], p0[1] - centre[1], p0[2] - centre[2]];
            let a: f64 = d.iter().map(|x| x * x).sum();
            let b: f64 = 2.0 * (0..3).map(|k| d[k] * f[k]).sum::<f64>();
            let c: f64 = f.iter().map(|x| x * x).sum::<f64>() - (radius + stylus).powi(2);
            let tt = (-b - (b * b - 4.0 * a * c).sqrt()) / (2.0 * a);
            assert!((0.0..=1.0).contains(&tt), "{t}: {tt}");
            let q = [
                pos[0] + tt * (to[0] - pos[0]),
                pos[1] + tt * (to[1] - pos[1]),
                pos[2] + tt * (to[2] - pos[2]),
            ];
            touch = Some(q);
            pos = q;
        } else {
            pos = to;
        }
    }
    let logf = dir.join("dome.log");
    std::fs::write(&logf, &log).expect("log");
    let v: serde_json::Value = serde_json::from_str(&ok(&lampost(&[
        "inspect",
        "reduce",
        "--machine",
        "fadal-lamp",
        "--plan",
        plan.to_str().expect("utf8"),
        logf.to_str().expect("utf8"),
        "--json",
    ])))
    .expect("json");
    let got = v["points"].as_array().expect("points");
    assert_eq!(got.len(), 9);
    for g in got {
        assert_eq!(g["status"], "ok", "{g}");
        let q: Vec<f64> = (0..3)
            .map(|k| g["measured"][k].as_f64().expect("m"))
            .collect();
        let n: Vec<f64> = (0..3)
            .map(|k| g["normal"][k].as_f64().expect("n"))
            .collect();
        // On the actual sphere, to the 0.0001-in rounding of the log.
        let dist =
            ((q[0] - centre[0]).powi(2) + (q[1] - centre[1]).powi(2) + (q[2] - centre[2]).powi(2))
                .sqrt();
        assert!((dist - radius).abs() < 2e-4, "{g}: {dist}");
        let expect = 0.005 + 0.004 * n[0] - 0.003 * n[1] + 0.002 * n[2];
        assert!(
            (g["deviation"].as_f64().expect("d") - expect).abs() < 2e-4,
            "{g}"
        );
    }
    // A log with a touch too few at a pose is refused at that POSE record.
    let cut: Vec<&str> = log.lines().collect();
    let k = cut.iter().rposition(|l| l.starts_with('X')).expect("touch");
    let short: String = cut
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != k)
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    let bad = dir.join("short.log");
    std::fs::write(&bad, short).expect("w");
    let o = lampost(&[
        "inspect",
        "reduce",
        "--machine",
        "fadal-lamp",
        "--plan",
        plan.to_str().expect("utf8"),
        bad.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("short.log:"), "{}", stderr(&o));
}

/// From a CAD mesh: sample it, simulate the sensor on an "actual" mesh (grown by 0.1 and
/// moved by (0.05, 0, 0.02)), reduce and compare with the CAD mesh: the deviations are the
/// growth plus the move along each normal; the simulator's readings are exact without
/// noise and scatter by the noise asked for with it.
#[test]
fn from_a_mesh_simulated_and_compared() {
    let dir = tempdir("inspect-mesh");
    let write = |name: &str, mesh: &lampost_mesh::Mesh| {
        let p = dir.join(name);
        std::fs::write(&p, lampost_mesh::write_ascii_stl(mesh, name)).expect("stl");
        p
    };
    let c = lampost_mesh::P3::new(0.0, 0.0, -10.0);
    let nominal = write("nominal.stl", &lampost_mesh::uv_sphere(c, 20.0, 24, 48));
    let moved = c + lampost_mesh::P3::new(0.05, 0.0, 0.02);
    let actual = write("actual.stl", &lampost_mesh::uv_sphere(moved, 20.1, 24, 48));
    let plan = dir.join("s.plan");
    let o = lampost(&[
        "inspect",
        "plan",
        "--machine",
        "nrc-lc",
        "--mesh",
        nominal.to_str().expect("utf8"),
        "--spacing",
        "8",
        "--skip-unreachable",
        "-o",
        plan.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let n_rows = rows(&std::fs::read_to_string(&plan).expect("plan")).len();
    assert!(n_rows > 100, "{n_rows} rows");
    let sim = |noise: &str, out: &std::path::Path| {
        ok(&lampost(&[
            "inspect",
            "simulate",
            "--machine",
            "nrc-lc",
            "--plan",
            plan.to_str().expect("utf8"),
            "--mesh",
            actual.to_str().expect("utf8"),
            "--noise",
            noise,
            "--seed",
            "7",
            "-o",
            out.to_str().expect("utf8"),
        ]))
    };
    let (exact_log, noisy_log) = (dir.join("exact.log"), dir.join("noisy.log"));
    sim("0", &exact_log);
    sim("0.002", &noisy_log);
    let reduce = |log: &std::path::Path, out: &std::path::Path| {
        ok(&lampost(&[
            "inspect",
            "reduce",
            "--machine",
            "nrc-lc",
            "--plan",
            plan.to_str().expect("utf8"),
            log.to_str().expect("utf8"),
            "-o",
            out.to_str().expect("utf8"),
        ]))
    };
    let (exact, noisy) = (dir.join("exact.m"), dir.join("noisy.m"));
    reduce(&exact_log, &exact);
    reduce(&noisy_log, &noisy);
    let compare = |m: &std::path::Path, mesh: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&ok(&lampost(&[
            "inspect",
            "compare",
            m.to_str().expect("utf8"),
            "--mesh",
            mesh.to_str().expect("utf8"),
            "--json",
        ])))
        .expect("json")
    };
    // Without noise every measured point is on the actual mesh, or inside it by the
    // sensor's tilt bias exactly (0.15 % or 0.5 % of its 5 mm range where the beam meets
    // a facet tilted 5–15° or 15–30° from it, near the facets' edges).
    let on_actual = compare(&exact, &actual);
    assert_eq!(on_actual["mesh_signed"], true);
    let mut biased = 0;
    for p in on_actual["points"].as_array().expect("points") {
        let d = p["mesh_distance"].as_f64().expect("d");
        // The bias runs along the beam: off a facet tilted by θ it is b·cos θ.
        let within = |b: f64, lo_deg: f64, hi_deg: f64| {
            d <= -b * hi_deg.to_radians().cos() + 1e-9 && d >= -b * lo_deg.to_radians().cos() - 1e-9
        };
        let ok = d.abs() < 1e-8 || within(0.0075, 5.0, 15.0) || within(0.025, 15.0, 30.0);
        assert!(ok, "{p}");
        biased += usize::from(d.abs() > 1e-8);
    }
    let total = on_actual["points"].as_array().expect("points").len();
    assert!(biased * 2 < total, "{biased} of {total} biased");
    // Against the nominal mesh: the growth plus the move along the normal, within the
    // facets' chordal error (a 24 × 48 sphere of radius 20: under 0.2).
    let v = compare(&exact, &nominal);
    let dev = &v["stats"];
    assert!(
        (dev["mean"].as_f64().expect("mean") - 0.1).abs() < 0.06,
        "{dev}"
    );
    for p in v["points"].as_array().expect("points") {
        let (d, m) = (
            p["deviation"].as_f64().expect("d"),
            p["mesh_distance"].as_f64().expect("m"),
        );
        assert!((d - m).abs() < 0.2, "{p}");
    }
    // With noise σ = 0.002: the same mean, the scatter of the noise (and the facets).
    let w = compare(&noisy, &nominal);
    let (m0, m1) = (
        dev["mean"].as_f64().expect("m"),
        w["stats"]["mean"].as_f64().expect("m"),
    );
    assert!((m0 - m1).abs() < 0.002, "{m0} vs {m1}");
}
