//! `cargo xtask bench inspect`: signed deviations of measured points from a CAD mesh.
//!
//! A generated torus of 1M triangles (R 60 mm, r 20 mm) and 1M points near its surface
//! (a measured point lies within its deviation of the part): within ±0.05 mm (best of
//! 3), then within ±0.5 mm (one run). Points
//! far inside a surface of revolution are a pathological case for every BVH (near its
//! axis or its tube's core circle whole rings of triangles are nearly equidistant): with
//! half the points anywhere in the torus's box, both lampost and Open3D took about a
//! minute. `lampost_inspect::surface::distances_on` on 2 threads (the index built
//! and every point answered; best of 3) against Open3D's
//! `RaycastingScene.compute_signed_distance` on the same data (scene built and every
//! point answered; best of 3, `crates/inspect/tests/distance_oracle.py` in
//! `.tools/py-o3d`), same run. Target: under 1 s, and within 2× of Open3D.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use lampost_mesh::{torus, Mesh, P3};

use lampost_testkit::SplitMix as Rng;

fn points(m: &Mesh, n: usize, off: f64) -> Vec<[f64; 3]> {
    let mut rng = Rng::new(2026);
    (0..n)
        .map(|_| {
            let t = m.triangles[(rng.next_u64() % m.triangles.len() as u64) as usize];
            let [a, b, c] = t.map(|i| m.vertices[i as usize]);
            let (mut u, mut v) = (rng.unit(), rng.unit());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let nrm = (b - a).cross(&(c - a)).normalize();
            let p = a + (b - a) * u + (c - a) * v + nrm * (off * (2.0 * rng.unit() - 1.0));
            [p.x, p.y, p.z]
        })
        .collect()
}

pub fn bench(root: &Path) -> Result<(), String> {
    let dir = root.join("target/xtask");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let mesh = torus(P3::zeros(), 60.0, 20.0, 1000, 500);
    println!(
        "(load average {}: the cores are shared, so wall times vary; CPU time is what the work costs)",
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    let t = Instant::now();
    let idx = lampost_mesh::dist::DistIndex::new(&mesh).ok_or("no triangles")?;
    let build = t.elapsed().as_secs_f64();
    drop(idx);
    let t = Instant::now();
    let report = lampost_mesh::manifold_report(&mesh);
    let topo = t.elapsed().as_secs_f64();
    drop(report);
    println!(
        "(the index of {} triangles alone: {:.0} ms (one thread); the manifold report that decides the sign: {:.0} ms (built beside it in a comparison))",
        mesh.triangles.len(),
        build * 1e3,
        topo * 1e3
    );
    // Measured points lie within their deviation of the part: ±0.05 mm (a tolerance
    // band), then ±0.5 mm (gross errors; about two triangles' widths here, so every
    // query meets many more triangles).
    for (off, runs) in [(0.05, 3), (0.5, 1)] {
        one(root, &dir, &mesh, off, runs)?;
    }
    Ok(())
}

fn one(root: &Path, dir: &Path, mesh: &Mesh, off: f64, runs: usize) -> Result<(), String> {
    let n = 1_000_000;
    let pts = points(mesh, n, off);
    println!(
        "== signed distances: {n} points within ±{off} mm of a torus of {} triangles (R 60, r 20 mm)",
        mesh.triangles.len()
    );
    let mut best = Duration::MAX;
    let mut ours = Vec::new();
    let c0 = crate::plan::cpu_seconds();
    for _ in 0..runs {
        let t = Instant::now();
        let (d, signed) =
            lampost_inspect::surface::distances_on(mesh, &pts, 2).map_err(|e| e.to_string())?;
        best = best.min(t.elapsed());
        if !signed {
            return Err("the torus is not a closed solid".into());
        }
        ours = d;
    }
    let secs = best.as_secs_f64();
    let cpu = (crate::plan::cpu_seconds() - c0) / runs as f64;
    println!(
        "lampost-inspect, 2 threads: {:.0} ms wall (best of {runs}; index built and every point answered; target < 1000 ms), {:.0} ms CPU a run (both threads)",
        secs * 1e3,
        cpu * 1e3
    );
    // Open3D on the same data.
    let py = root.join(".tools/py-o3d/bin/python");
    if !py.exists() {
        let _ = Command::new(root.join("scripts/install-open3d.sh")).status();
    }
    let mut raw = Vec::with_capacity(mesh.vertices.len() * 24 + mesh.triangles.len() * 12);
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
    let (mp, pp, op) = (
        dir.join("inspect-bench-mesh.bin"),
        dir.join("inspect-bench-points.bin"),
        dir.join("inspect-bench-out.bin"),
    );
    std::fs::write(&mp, raw).map_err(|e| e.to_string())?;
    let praw: Vec<u8> = pts.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(&pp, praw).map_err(|e| e.to_string())?;
    let out = Command::new(&py)
        .arg(root.join("crates/inspect/tests/distance_oracle.py"))
        .args(["open3d", "--repeat", &runs.to_string()])
        .arg(mesh.vertices.len().to_string())
        .arg(mesh.triangles.len().to_string())
        .arg(n.to_string())
        .args([&mp, &pp, &op])
        .env("OMP_NUM_THREADS", "2")
        .output();
    match out {
        Ok(o) if o.status.success() => {
            let tpy: f64 = String::from_utf8_lossy(&o.stdout)
                .trim()
                .parse()
                .unwrap_or(f64::NAN);
            let theirs: Vec<f64> = std::fs::read(&op)
                .map_err(|e| e.to_string())?
                .chunks_exact(8)
                .filter_map(|c| c.try_into().ok().map(f64::from_le_bytes))
                .collect();
            let worst = ours
                .iter()
                .zip(&theirs)
                .map(|(a, b)| (a.abs() - b.abs()).abs())
                .fold(0.0, f64::max);
            let signs = ours
                .iter()
                .zip(&theirs)
                .filter(|(a, b)| a.abs() > 1e-3 && a.signum() != b.signum())
                .count();
            println!(
                "Open3D RaycastingScene (float32), its threads: {:.0} ms (best of {runs}); lampost / Open3D = {:.2}× (target ≤ 2); largest |Δ| {worst:.2e} mm, {signs} signs differ beyond 1e-3 mm",
                tpy * 1e3,
                secs / tpy
            );
        }
        Ok(o) => println!(
            "Open3D baseline failed: {}",
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(e) => println!("Open3D baseline could not run ({}): {e}", py.display()),
    }
    for p in [&mp, &pp, &op] {
        let _ = std::fs::remove_file(p);
    }
    cloudcompare(root, dir, mesh, &pts, secs)
}

/// CloudCompare's command-line cloud-to-mesh distance (`-C2M_DIST`) on the same points
/// and mesh, timed by its own log line `[ComputeDistances] Time: … s` (the distances
/// alone, after both files are read; its octree is built in that time, as lampost's
/// index is in its own): issue 16 asks lampost to be faster.
fn cloudcompare(
    root: &Path,
    dir: &Path,
    mesh: &Mesh,
    pts: &[[f64; 3]],
    ours: f64,
) -> Result<(), String> {
    let found = |c: &str| {
        Command::new("sh")
            .args(["-c", &format!("command -v {c}")])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !found("CloudCompare") {
        let _ = Command::new(root.join("scripts/install-cloudcompare.sh")).status();
    }
    if !found("CloudCompare") {
        println!("CloudCompare C2M: not installed (scripts/install-cloudcompare.sh, as root)");
        return Ok(());
    }
    let (mp, pp) = (
        dir.join("inspect-bench-mesh.off"),
        dir.join("inspect-bench-points.xyz"),
    );
    std::fs::write(&mp, lampost_mesh::write_off(mesh)).map_err(|e| e.to_string())?;
    let mut text = String::with_capacity(pts.len() * 40);
    for p in pts {
        text.push_str(&format!("{:.9} {:.9} {:.9}\n", p[0], p[1], p[2]));
    }
    std::fs::write(&pp, text).map_err(|e| e.to_string())?;
    let out = Command::new("CloudCompare")
        .args(["-SILENT", "-AUTO_SAVE", "OFF", "-O"])
        .arg(&pp)
        .arg("-O")
        .arg(&mp)
        .arg("-C2M_DIST")
        .env("QT_QPA_PLATFORM", "offscreen")
        .output();
    for p in [&mp, &pp] {
        let _ = std::fs::remove_file(p);
    }
    let log = match out {
        Ok(o) => String::from_utf8_lossy(&o.stdout).into_owned(),
        Err(e) => return Err(format!("CloudCompare could not run: {e}")),
    };
    let time_of = |tag: &str| {
        log.lines()
            .find(|l| l.contains(tag))
            .and_then(|l| l.split("Time:").nth(1))
            .and_then(|t| t.split_whitespace().next())
            .and_then(|t| t.parse::<f64>().ok())
    };
    match (
        time_of("[computeApproxDistances]"),
        time_of("[ComputeDistances]"),
    ) {
        (approx, Some(exact)) => {
            let total = exact + approx.unwrap_or(0.0);
            println!(
                "CloudCompare C2M (its threads): {:.0} ms ({:.0} ms exact + {:.0} ms approximate pass); lampost / CloudCompare = {:.2}× (target < 1)",
                total * 1e3,
                exact * 1e3,
                approx.unwrap_or(0.0) * 1e3,
                ours / total
            );
        }
        _ => println!("CloudCompare C2M: no timing in its log:\n{log}"),
    }
    Ok(())
}
