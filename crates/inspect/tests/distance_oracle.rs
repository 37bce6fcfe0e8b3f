//! Signed distances of `lampost_inspect::surface::distances` against two independent
//! implementations run in the same test by `distance_oracle.py`, on the real meshes
//! `scripts/install-meshes.sh` puts in `.tools/meshes` (the closed, consistently oriented
//! ones), 500 points each (half anywhere in the box around the mesh, half within 1 % of
//! its diagonal of the surface):
//!
//! - trimesh (`.tools/py`, `scripts/install-python.sh`): the closest point on every
//!   triangle whose bounding box is nearer than the best found (`triangles.closest_point`,
//!   float64; its `proximity.closest_point` missed the nearest face at a point near
//!   `eight.off`, 0.0041400 where the nearest is 0.0041390, so it is not used), the sign
//!   by `Trimesh.contains`; the distances agree to 1e-9 relative (|Δ| ≤ 1e-9·|d| +
//!   1e-12·size, the second term for points on the surface), and the signs wherever
//!   |d| > 1e-9·size.
//! - Open3D (`.tools/py-o3d`, `scripts/install-open3d.sh`): `RaycastingScene` stores
//!   vertices and takes points as float32, so it can agree only to float32's resolution
//!   of the coordinates: |Δ| ≤ 16·2⁻²⁴·size (size: the largest coordinate magnitude; the
//!   vertices and the point are each rounded by 2⁻²⁴ relative, and its closest-point
//!   arithmetic adds a few roundings more); the signs agree wherever |d| exceeds that.
//!
//! Skipped (with a message) when a venv or the meshes are missing, unless
//! `LAMPOST_REQUIRE_PY=1`.

use std::path::Path;
use std::process::Command;

use lampost_mesh::{Mesh, P3};

use lampost_testkit::{oracle_present, root, SplitMix as Rng};

/// Half the points anywhere in the box grown by 10 %, half near the surface.
fn points(m: &Mesh, n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = Rng::new(seed);
    let (mut lo, mut hi) = (P3::repeat(f64::INFINITY), P3::repeat(f64::NEG_INFINITY));
    for v in &m.vertices {
        lo = lo.inf(v);
        hi = hi.sup(v);
    }
    let diag = (hi - lo).norm();
    let (lo, hi) = (lo - (hi - lo) * 0.1, hi + (hi - lo) * 0.1);
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        if k % 2 == 0 {
            let p = P3::from_fn(|i, _| lo[i] + (hi[i] - lo[i]) * rng.unit());
            out.push([p.x, p.y, p.z]);
        } else {
            let t = m.triangles[(rng.next_u64() % m.triangles.len() as u64) as usize];
            let [a, b, c] = t.map(|i| m.vertices[i as usize]);
            let (mut u, mut v) = (rng.unit(), rng.unit());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let nrm = (b - a).cross(&(c - a));
            let nrm = if nrm.norm() > 0.0 {
                nrm.normalize()
            } else {
                nrm
            };
            let p = a + (b - a) * u + (c - a) * v + nrm * (0.02 * diag * (rng.unit() - 0.5));
            out.push([p.x, p.y, p.z]);
        }
    }
    out
}

/// Writes `mesh` and `pts` for the oracle as job `k` in `dir`; the job's arguments.
fn job(k: usize, mesh: &Mesh, pts: &[[f64; 3]], dir: &Path) -> Vec<String> {
    let mut raw = Vec::new();
    for v in &mesh.vertices {
        for x in [v.x, v.y, v.z] {
            raw.extend_from_slice(&x.to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        for i in t {
            raw.extend_from_slice(&i.to_le_bytes());
        }
    }
    let (mp, pp) = (
        dir.join(format!("mesh{k}.bin")),
        dir.join(format!("points{k}.bin")),
    );
    std::fs::write(&mp, raw).expect("write mesh");
    let praw: Vec<u8> = pts.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(&pp, praw).expect("write points");
    vec![
        mesh.vertices.len().to_string(),
        mesh.triangles.len().to_string(),
        pts.len().to_string(),
        mp.display().to_string(),
        pp.display().to_string(),
        dir.join(format!("out{k}.bin")).display().to_string(),
    ]
}

/// Runs the oracle on every job; each job's distances.
fn oracle(py: &Path, which: &str, jobs: &[Vec<String>]) -> Vec<Vec<f64>> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/distance_oracle.py");
    let o = Command::new(py)
        .arg(&script)
        .arg(which)
        .args(jobs.iter().flatten())
        .output()
        .expect("run the oracle");
    assert!(
        o.status.success(),
        "{which}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    jobs.iter()
        .map(|j| {
            std::fs::read(&j[5])
                .expect("oracle output")
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect()
        })
        .collect()
}

#[test]
fn signed_distances_agree_with_trimesh_and_open3d() {
    let root = root();
    let pys = [
        (
            "trimesh",
            root.join(".tools/py/bin/python"),
            "install-python.sh",
        ),
        (
            "open3d",
            root.join(".tools/py-o3d/bin/python"),
            "install-open3d.sh",
        ),
    ];
    let meshes = root.join(".tools/meshes");
    for (_, py, script) in &pys {
        let install = format!("scripts/{script} and scripts/install-meshes.sh");
        if !oracle_present(&[py.clone(), meshes.clone()], &install) {
            return;
        }
    }
    let dir = std::env::temp_dir().join(format!("lampost-distance-oracle-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut cases = Vec::new();
    // cow.off intersects itself: a point 0.0081 outside its nearest face can be inside
    // another part of the cow (winding number 1), so the nearest feature's sign and the
    // oracles' ray parity differ there by definition; its distances are compared, not
    // its signs.
    for (name, signs) in [
        ("eight.off", true),
        ("knot1.off", true),
        ("elephant.off", true),
        ("cow.off", false),
    ] {
        let path = meshes.join(name);
        let Ok(bytes) = std::fs::read(&path) else {
            continue;
        };
        let mesh = lampost_mesh::read(&bytes, lampost_mesh::Format::Off).expect("mesh");
        if !lampost_mesh::manifold_report(&mesh).closed_oriented() {
            eprintln!("{name}: not a closed, oriented solid; left out");
            continue;
        }
        let pts = points(&mesh, 500, 7 + cases.len() as u64);
        let args = job(cases.len(), &mesh, &pts, &dir);
        cases.push((name, signs, mesh, pts, args));
    }
    let solids = cases.len();
    let jobs: Vec<Vec<String>> = cases.iter().map(|c| c.4.clone()).collect();
    let answers: Vec<(&str, Vec<Vec<f64>>)> = pys
        .iter()
        .map(|(which, py, _)| (*which, oracle(py, which, &jobs)))
        .collect();
    for (k, (name, signs, mesh, pts, _)) in cases.iter().enumerate() {
        let (ours, signed) = lampost_inspect::surface::distances(mesh, pts).expect("distances");
        assert!(signed, "{name}");
        let size = mesh
            .vertices
            .iter()
            .flat_map(|v| v.iter().map(|x| x.abs()).collect::<Vec<_>>())
            .fold(0.0, f64::max);
        for (which, all) in &answers {
            let theirs = &all[k];
            assert_eq!(theirs.len(), pts.len());
            let bound = |d: f64| match *which {
                "trimesh" => 1e-9 * d.abs() + 1e-12 * size,
                _ => 16.0 * f64::from(f32::EPSILON) / 2.0 * size,
            };
            let mut worst: f64 = 0.0;
            for ((p, a), b) in pts.iter().zip(&ours).zip(theirs) {
                let diff = (a.abs() - b.abs()).abs();
                assert!(
                    diff <= bound(*a),
                    "{name} {which}: at {p:?} lampost {a} vs {b} (|Δ| {diff:e} > {:e})",
                    bound(*a)
                );
                if *signs && a.abs() > bound(*a) {
                    assert_eq!(
                        a.signum(),
                        b.signum(),
                        "{name} {which}: sign at {p:?}: {a} vs {b}"
                    );
                }
                worst = worst.max(diff / size);
            }
            eprintln!(
                "{name} ({} triangles) vs {which}: largest |Δ| / size {worst:.2e}",
                mesh.triangles.len()
            );
        }
    }
    assert!(
        solids >= 3,
        "only {solids} closed meshes in {}",
        meshes.display()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
