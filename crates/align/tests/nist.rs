//! Every certified NIST ATS least-squares fit in ../shared/testdata/nist: centres and
//! points within 1e-8 of the part size, radii and diameters likewise, normals within
//! 1e-9 rad.

use std::path::{Path, PathBuf};

use lampost_align::{circle3d, plane, sphere, P3};

fn nist() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/testdata/nist");
    p.is_dir().then_some(p)
}

fn read_ds(p: &Path) -> Vec<P3> {
    let text = std::fs::read_to_string(p).expect("ds");
    let mut lines = text.lines();
    let n: usize = lines.next().expect("count").trim().parse().expect("count");
    let pts: Vec<P3> = lines
        .map(|l| {
            let v: Vec<f64> = l
                .split('\t')
                .map(|x| x.trim().parse().expect("num"))
                .collect();
            P3::new(v[0], v[1], v[2])
        })
        .collect();
    assert_eq!(pts.len(), n);
    pts
}

fn read_fit(p: &Path) -> Vec<f64> {
    std::fs::read_to_string(p)
        .expect("fit")
        .lines()
        .map(|l| l.trim().parse().expect("num"))
        .collect()
}

fn size(pts: &[P3]) -> f64 {
    let mut lo = P3::repeat(f64::INFINITY);
    let mut hi = P3::repeat(f64::NEG_INFINITY);
    for p in pts {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    (hi - lo).norm()
}

fn sets(dir: &Path) -> Vec<(PathBuf, PathBuf)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .expect("dir")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "ds"))
        .map(|p| (p.clone(), p.with_extension("fit")))
        .collect();
    v.sort();
    v
}

fn angle(a: &P3, b: &P3) -> f64 {
    // Up to sign: the certified normals follow no sign convention.
    let c = a.normalize().dot(&b.normalize()).abs().min(1.0);
    let s = a.normalize().cross(&b.normalize()).norm();
    s.atan2(c)
}

#[test]
fn certified_nist_fits() {
    let Some(root) = nist() else {
        eprintln!("SKIPPED: ../shared/testdata/nist not present");
        return;
    };
    let mut worst = [0.0f64; 3];
    for (ds, fit) in sets(&root.join("Sphere")) {
        let pts = read_ds(&ds);
        let want = read_fit(&fit);
        let tol = 1e-8 * size(&pts);
        let got = sphere(&pts, None).expect("fits");
        let dc = (P3::from(got.center) - P3::new(want[0], want[1], want[2])).norm();
        let dd = (2.0 * got.radius - want[3]).abs();
        assert!(
            dc <= tol && dd <= tol,
            "{}: centre off by {dc}, diameter by {dd} (tol {tol})",
            ds.display()
        );
        worst[0] = worst[0].max(dc / size(&pts)).max(dd / size(&pts));
    }
    for (ds, fit) in sets(&root.join("Plane")) {
        let pts = read_ds(&ds);
        let want = read_fit(&fit);
        let tol = 1e-8 * size(&pts);
        let got = plane(&pts).expect("fits");
        let wn = P3::new(want[3], want[4], want[5]);
        let a = angle(&P3::from(got.normal), &wn);
        // The certified point must lie on our plane (it is the centroid to 1.6e-13).
        let d = (P3::new(want[0], want[1], want[2]) - P3::from(got.point))
            .dot(&P3::from(got.normal))
            .abs();
        assert!(
            a <= 1e-9 && d <= tol,
            "{}: normal off by {a} rad, point by {d}",
            ds.display()
        );
        worst[1] = worst[1].max(a);
    }
    for (ds, fit) in sets(&root.join("Circle3d")) {
        let pts = read_ds(&ds);
        let want = read_fit(&fit);
        let tol = 1e-8 * size(&pts);
        let got = circle3d(&pts).expect("fits");
        let dc = (P3::from(got.center) - P3::new(want[0], want[1], want[2])).norm();
        let a = angle(&P3::from(got.normal), &P3::new(want[3], want[4], want[5]));
        let dd = (2.0 * got.radius - want[6]).abs();
        assert!(
            dc <= tol && dd <= tol && a <= 1e-9,
            "{}: centre {dc}, diameter {dd}, normal {a} rad",
            ds.display()
        );
        worst[2] = worst[2].max(dc / size(&pts)).max(dd / size(&pts));
    }
    eprintln!("NIST: worst sphere {:.1e} of part size, plane normal {:.1e} rad, circle {:.1e} of part size", worst[0], worst[1], worst[2]);
}
