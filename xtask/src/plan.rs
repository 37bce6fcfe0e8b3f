//! `cargo xtask bench plan`: slicing speed and the whole plan of the twisted plate.
//!
//! 1. CGAL's bunny (`bunny00.off`, 75,408 triangles, from `scripts/install-meshes.sh`;
//!    a generated UV sphere of the same size when it is missing) scaled to 100 mm,
//!    sliced at 0.1 mm along z: `lampost_plan::slice` on one thread (best of 7, from
//!    the welded mesh: edges, buckets, loops, areas) against trimesh's
//!    `section_multiplane` on the same file and heights (`xtask/plan_baseline.py`,
//!    best of 3, mesh loaded and cached first), same run: the ratio and segments/s.
//! 2. A generated 1M-triangle sphere sliced at 1,000 layers on both cores (target
//!    < 0.5 s).
//! 3. The whole plan of paper 001's twisted plate at full size (600 × 200 mm, 3 mm
//!    wall, `lampost_plan::demo::twisted_plate` with 240 × 80 quads): slicing at 0.5 mm,
//!    perimeters with approach directions (1 mm, 2°), rasters (1 mm bead and hatch), the
//!    offset-angle check (45°, tilting), the path's points; two threads, best of 7
//!    (target < 0.2 s; the paper's planning took 2 minutes).

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use lampost_mesh::{read_off, uv_sphere, write_off, Mesh, P3};
use lampost_plan::{slice, SliceOptions, Slicing};

/// This process's CPU time (user + system, /proc/self/stat, in clock ticks of 1/100 s).
pub(crate) fn cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let rest = s.rsplit(')').next()?.to_string();
            let f: Vec<&str> = rest.split_whitespace().collect();
            let u: f64 = f.get(11)?.parse().ok()?;
            let k: f64 = f.get(12)?.parse().ok()?;
            Some((u + k) / 100.0)
        })
        .unwrap_or(f64::NAN)
}

/// Best wall time of `runs` runs, the mean CPU time per run (on a shared machine the
/// CPU time is what the work costs; wall time includes waiting for a core), the result.
fn best(
    runs: usize,
    f: &dyn Fn() -> Result<Slicing, String>,
) -> Result<(Duration, f64, Slicing), String> {
    let mut best = Duration::MAX;
    let mut last = None;
    let c0 = cpu_seconds();
    for _ in 0..runs {
        let t = Instant::now();
        let s = f()?;
        best = best.min(t.elapsed());
        last = Some(s);
    }
    let cpu = (cpu_seconds() - c0) / runs as f64;
    last.map(|s| (best, cpu, s))
        .ok_or_else(|| "no run".to_string())
}

fn parallel(mesh: &Mesh, layer: f64, threads: usize) -> Result<Slicing, String> {
    slice(
        mesh,
        &SliceOptions {
            threads,
            ..SliceOptions::parallel(P3::z(), layer)
        },
    )
    .map_err(|e| e.to_string())
}

pub fn bench(root: &Path) -> Result<(), String> {
    let dir = root.join("target/xtask");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let bunny = root.join(".tools/meshes/bunny00.off");
    if !bunny.exists() {
        let _ = Command::new(root.join("scripts/install-meshes.sh")).status();
    }
    let (name, mesh) = match std::fs::read(&bunny).ok().and_then(|b| read_off(&b).ok()) {
        Some(m) => ("CGAL bunny00.off", m),
        None => {
            println!("(.tools/meshes/bunny00.off missing: a generated sphere instead)");
            ("UV sphere", uv_sphere(P3::zeros(), 0.5, 194, 195))
        }
    };
    // To millimetres: the bunny is about 1 unit across; 100 mm across.
    let (lo, hi) = lampost_mesh::props::bounds(&mesh).ok_or("empty mesh")?;
    let scale = 100.0 / (hi - lo).max();
    let mesh = mesh.scaled(scale);
    let layer = 0.1;
    println!(
        "(load average {}: the cores are shared, so wall times vary; CPU time is what the work costs)",
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!(
        "== slicing {name} ({} triangles) scaled to 100 mm, {layer} mm layers along z, against trimesh section_multiplane, same run",
        mesh.triangles.len()
    );
    let (t1, c1, s) = best(21, &|| parallel(&mesh, layer, 1))?;
    let (t2, _, _) = best(7, &|| parallel(&mesh, layer, 2))?;
    let loops: usize = s.slices.iter().map(|sl| sl.loops.len()).sum();
    let secs = t1.as_secs_f64();
    println!(
        "lampost-plan, 1 thread:  {:.1} ms wall (best of 21), {:.1} ms CPU (mean), {} layers, {} loops, {} segments: {:.1} M segments/s wall, {:.1} M per CPU second (target ≥ 10)",
        secs * 1e3,
        c1 * 1e3,
        s.slices.len(),
        loops,
        s.segments,
        s.segments as f64 / secs / 1e6,
        s.segments as f64 / c1 / 1e6
    );
    println!(
        "lampost-plan, 2 threads: {:.1} ms ({:.1} M segments/s)",
        t2.as_secs_f64() * 1e3,
        s.segments as f64 / t2.as_secs_f64() / 1e6
    );
    // The same mesh and heights for trimesh.
    let off = dir.join("plan-bench.off");
    std::fs::write(&off, write_off(&mesh)).map_err(|e| e.to_string())?;
    let heights = dir.join("plan-bench-heights.txt");
    let hs: String = s
        .slices
        .iter()
        .map(|sl| format!("{:?}\n", sl.height))
        .collect();
    std::fs::write(&heights, hs).map_err(|e| e.to_string())?;
    let py = root.join(".tools/py/bin/python");
    if !py.exists() {
        let _ = Command::new(root.join("scripts/install-python.sh")).status();
    }
    let out = Command::new(&py)
        .arg(root.join("xtask/plan_baseline.py"))
        .arg(&off)
        .args(["0", "0", "1"])
        .arg(&heights)
        .output();
    match out {
        Ok(o) if o.status.success() => {
            let text = String::from_utf8_lossy(&o.stdout);
            let mut it = text.split_whitespace();
            let tpy: f64 = it.next().and_then(|v| v.parse().ok()).unwrap_or(f64::NAN);
            let tloops: usize = it.next().and_then(|v| v.parse().ok()).unwrap_or(0);
            println!(
                "trimesh section_multiplane: {:.1} ms, {tloops} closed loops; trimesh / lampost = {:.0}× on one thread (target ≥ 50), {:.0}× on two",
                tpy * 1e3,
                tpy / secs,
                tpy / t2.as_secs_f64()
            );
        }
        Ok(o) => println!(
            "trimesh baseline failed: {}",
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(e) => println!("trimesh baseline could not run ({}): {e}", py.display()),
    }
    // 1M triangles, 1,000 layers, both cores.
    let big = uv_sphere(P3::zeros(), 50.0, 708, 708);
    let (lo, hi) = lampost_mesh::props::bounds(&big).ok_or("empty mesh")?;
    let layer = (hi.z - lo.z) / 1000.0;
    let (tb, _, sb) = best(5, &|| parallel(&big, layer, 2))?;
    println!(
        "== generated sphere, {} triangles, {} layers, 2 threads: {:.0} ms, {} segments ({:.1} M segments/s; target < 500 ms)",
        big.triangles.len(),
        sb.slices.len(),
        tb.as_secs_f64() * 1e3,
        sb.segments,
        sb.segments as f64 / tb.as_secs_f64() / 1e6
    );
    plate()
}

/// Item 3: the twisted plate's whole plan.
pub fn plate() -> Result<(), String> {
    let mesh = lampost_plan::demo::twisted_plate(1.0, 3.0, 240, 80).ok_or("plate")?;
    let opts = lampost_plan::PlanOptions {
        perimeter: lampost_plan::PerimeterOptions {
            spacing: 1.0,
            max_turn_deg: 2.0,
        },
        raster: Some(lampost_plan::RasterOptions {
            hatch: 1.0,
            inset: 0.5,
            angle_deg: 0.0,
            turn_deg: 90.0,
        }),
        approach: lampost_plan::Approach::Tangent,
        max_offset_deg: 45.0,
        max_tilt_deg: 90.0,
        threads: 2,
    };
    let run = || -> Result<(lampost_plan::Plan, usize), String> {
        let s = parallel(&mesh, 0.5, 2)?;
        let p = lampost_plan::plan(&mesh, &s, &opts).map_err(|e| e.to_string())?;
        // The path's points, made one by one as a writer takes them (each read: the count
        // and the path's length).
        let (n, _len, _) = p
            .iter()
            .fold((0usize, 0.0f64, None::<P3>), |(n, len, last), q| {
                (
                    n + 1,
                    len + last.map_or(0.0, |l: P3| (q.p - l).norm()),
                    Some(q.p),
                )
            });
        Ok((p, n))
    };
    let mut best = Duration::MAX;
    let c0 = cpu_seconds();
    let mut last = None;
    for _ in 0..7 {
        let t = Instant::now();
        let r = run()?;
        best = best.min(t.elapsed());
        last = Some(r);
    }
    let cpu = (cpu_seconds() - c0) / 7.0;
    let (p, n) = last.ok_or("no run")?;
    println!(
        "== twisted plate 600 x 200 mm, {} triangles: whole plan (slicing at 0.5 mm, perimeters, rasters, offset check) {} layers, {} points, worst offset {:.1} deg, {} tilted, {} over: {:.0} ms wall on 2 threads (best of 7), {:.0} ms CPU (mean); target < 200 ms",
        mesh.triangles.len(),
        p.layers.len(),
        n,
        p.worst_offset_deg(),
        p.tilted,
        p.violations.len(),
        best.as_secs_f64() * 1e3,
        cpu * 1e3
    );
    Ok(())
}
