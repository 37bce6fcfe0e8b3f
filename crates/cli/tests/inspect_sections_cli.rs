//! `inspect plan --sections`: sampling points along section planes of the CAD mesh, as
//! CMM software scans sections. On a box (its faces known exactly) and a sphere: every
//! planned point lies on its plane and on the surface, with the surface's normal there;
//! along a section the points are `--spacing` apart; bad specifications are refused
//! with nothing written.

mod common;

use common::*;

/// Plan rows: (id, nominal point, normal).
fn rows(plan: &str) -> Vec<(String, [f64; 3], [f64; 3])> {
    plan.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("id "))
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            let v: Vec<f64> = f[1..].iter().map(|x| x.parse().expect("number")).collect();
            (f[0].to_string(), [v[5], v[6], v[7]], [v[8], v[9], v[10]])
        })
        .collect()
}

fn plan(mesh: &std::path::Path, out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "inspect",
        "plan",
        "--machine",
        "nrc-lc",
        "--mesh",
        mesh.to_str().expect("utf8"),
        "--skip-unreachable",
        "-o",
        out.to_str().expect("utf8"),
    ];
    args.extend_from_slice(extra);
    lampost(&args)
}

#[test]
fn sections_of_a_box_lie_on_their_planes_and_faces_spaced_along_them() {
    let dir = tempdir("inspect-sections-box");
    // A box 40 × 30 × 20 from (−20, −15, −10): sections z = −5, 0, 5 are rectangles of
    // perimeter 140, sampled every 2.5 (56 points each); its side faces are vertical.
    let (lo, hi) = ([-20.0, -15.0, -10.0], [20.0, 15.0, 10.0]);
    let mesh = lampost_mesh::box_mesh(lo.into(), hi.into());
    let stl = dir.join("box.stl");
    std::fs::write(&stl, lampost_mesh::write_ascii_stl(&mesh, "box")).expect("stl");
    let out = dir.join("box.plan");
    let o = plan(
        &stl,
        &out,
        &[
            "--spacing",
            "2.5",
            "--sections",
            "z=-5:5:5",
            "--max-tilt",
            "0",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let got = rows(&std::fs::read_to_string(&out).expect("plan"));
    let mut per = [Vec::new(), Vec::new(), Vec::new()];
    for (id, p, n) in &got {
        let (sec, k) = id
            .strip_prefix('s')
            .and_then(|r| r.split_once('-'))
            .expect("id s<section>-<n>");
        let sec: usize = sec.parse().expect("section");
        let k: usize = k.parse().expect("number");
        // On its plane.
        let z = [-5.0, 0.0, 5.0][sec - 1];
        assert!((p[2] - z).abs() < 1e-9, "{id}: z {} on plane {z}", p[2]);
        // On a side face, with that face's outward normal.
        let on: Vec<usize> = (0..2)
            .filter(|&a| (p[a] - lo[a]).abs() < 1e-9 || (p[a] - hi[a]).abs() < 1e-9)
            .collect();
        assert!(!on.is_empty(), "{id}: {p:?} is on no side face");
        assert!(n[2].abs() < 1e-12, "{id}: normal {n:?}");
        let a = if n[0].abs() > 0.5 { 0 } else { 1 };
        assert!(
            on.contains(&a),
            "{id}: {p:?} is not on the face of normal {n:?}"
        );
        let face = if n[a] > 0.0 { hi[a] } else { lo[a] };
        assert!((p[a] - face).abs() < 1e-9, "{id}: {p:?} vs normal {n:?}");
        per[sec - 1].push((k, *p));
    }
    // The sensor reaches only the faces it can look at square on; the side faces of the
    // three sections give the same numbers.
    for (s, pts) in per.iter_mut().enumerate() {
        assert!(!pts.is_empty(), "section {} has no reachable points", s + 1);
        pts.sort_by_key(|x| x.0);
        // Numbers along the curve: where two follow each other on one face, exactly
        // the spacing apart.
        let mut steps = 0;
        for w in pts.windows(2) {
            let ((k0, a), (k1, b)) = (w[0], w[1]);
            let same_face = (0..2).any(|ax| {
                ((a[ax] - lo[ax]).abs() < 1e-9 && (b[ax] - lo[ax]).abs() < 1e-9)
                    || ((a[ax] - hi[ax]).abs() < 1e-9 && (b[ax] - hi[ax]).abs() < 1e-9)
            });
            if k1 == k0 + 1 && same_face {
                let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
                assert!(
                    (d - 2.5).abs() < 1e-9,
                    "section {}: {a:?} to {b:?}: {d}",
                    s + 1
                );
                steps += 1;
            }
        }
        assert!(steps > 20, "section {}: {steps} steps checked", s + 1);
    }
    assert_eq!(per[0].len(), per[2].len());
}

#[test]
fn sections_of_a_sphere_lie_on_it() {
    let dir = tempdir("inspect-sections-sphere");
    let c = lampost_mesh::P3::new(0.0, 0.0, -10.0);
    let mesh = lampost_mesh::uv_sphere(c, 20.0, 24, 48);
    let stl = dir.join("s.stl");
    std::fs::write(&stl, lampost_mesh::write_ascii_stl(&mesh, "s")).expect("stl");
    let out = dir.join("s.plan");
    let o = plan(
        &stl,
        &out,
        &[
            "--spacing",
            "3",
            "--sections",
            "x=0",
            "--sections",
            "z=-5,0,5",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let got = rows(&std::fs::read_to_string(&out).expect("plan"));
    assert!(got.len() > 40, "{} rows", got.len());
    let idx = lampost_mesh::dist::DistIndex::new(&mesh).expect("index");
    let mut seen = [false; 4];
    for (id, p, n) in &got {
        let sec: usize = id[1..]
            .split('-')
            .next()
            .and_then(|s| s.parse().ok())
            .expect("id");
        seen[sec - 1] = true;
        let (axis, value) = [(0, 0.0), (2, -5.0), (2, 0.0), (2, 5.0)][sec - 1];
        assert!((p[axis] - value).abs() < 1e-9, "{id}: {p:?}");
        assert!(idx.distance(*p) < 1e-9, "{id}: {p:?} is off the surface");
        // The facet's normal points away from the centre.
        let r = [p[0] - c.x, p[1] - c.y, p[2] - c.z];
        assert!(r[0] * n[0] + r[1] * n[1] + r[2] * n[2] > 0.0, "{id}: {n:?}");
    }
    // The sensor looks down from above: the sections above the equator are reached.
    assert!(seen[0] && seen[3], "{seen:?}");
}

#[test]
fn bad_sections_are_refused_with_nothing_written() {
    let dir = tempdir("inspect-sections-bad");
    let mesh = lampost_mesh::box_mesh([0.0; 3].into(), [10.0; 3].into());
    let stl = dir.join("b.stl");
    std::fs::write(&stl, lampost_mesh::write_ascii_stl(&mesh, "b")).expect("stl");
    let out = dir.join("b.plan");
    for (spec, says) in [
        ("w=5", "not an axis"),
        ("z5", "AXIS=VALUES"),
        ("z=1,abc", "`abc` is not a finite number"),
        ("z=5:1:1", "start ≤ stop"),
        ("z=0:10:0", "positive step"),
        ("z=0:1e9:1e-3", "more than 10000 sections"),
        ("z=25", "misses the mesh"),
    ] {
        let o = plan(&stl, &out, &["--spacing", "1", "--sections", spec]);
        assert!(!o.status.success(), "{spec}");
        assert!(stderr(&o).contains(says), "{spec}: {}", stderr(&o));
        assert!(!out.exists(), "{spec}: a plan was written");
    }
    // --sections needs --mesh.
    let o = lampost(&[
        "inspect",
        "plan",
        "--machine",
        "nrc-lc",
        "--sections",
        "z=1",
    ]);
    assert!(!o.status.success());
}
