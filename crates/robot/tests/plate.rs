//! Paper 001's full-size twisted plate as `lampost plan` plans it (`--layer 20 --approach
//! build --hatch 1.5 --spacing 2`, as `cargo xtask bench robot` plans it): the tried
//! first turns that meet count as one plan, and the plan taken is the very plan the rule
//! without meeting takes.

use lampost_robot::plan::{plan_and_tries_met, plan_every_try_in_full, resample, PathPoint};
use lampost_robot::Arm;

fn plate_path(layer: f64) -> Vec<PathPoint> {
    let Some(mesh) = lampost_plan::demo::twisted_plate(1.0, 3.0, 120, 20) else {
        panic!("plate");
    };
    let slices = lampost_plan::slice(
        &mesh,
        &lampost_plan::SliceOptions {
            planes: lampost_plan::Planes::Parallel {
                dir: lampost_mesh::P3::z(),
                layer,
                first: None,
            },
            stitch: None,
            threads: 2,
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let opts = lampost_plan::PlanOptions {
        perimeter: lampost_plan::PerimeterOptions {
            spacing: 2.0,
            max_turn_deg: 2.0,
        },
        raster: Some(lampost_plan::RasterOptions {
            hatch: 1.5,
            inset: 0.5,
            angle_deg: 0.0,
            turn_deg: 90.0,
        }),
        approach: lampost_plan::Approach::Build,
        max_offset_deg: 45.0,
        max_tilt_deg: 90.0,
        threads: 2,
    };
    let p = lampost_plan::plan(&mesh, &slices, &opts).unwrap_or_else(|e| panic!("{e}"));
    p.iter()
        .enumerate()
        .map(|(i, q)| PathPoint {
            tip: q.p,
            axis: q.axis,
            feed: 600.0,
            deposit: q.laser,
            line: i + 3,
        })
        .collect()
}

#[test]
fn the_plate_takes_the_plan_every_try_in_full_takes() {
    let Some(arm) = Arm::builtin("puma-lens") else {
        panic!("built-in");
    };
    let s = resample(&plate_path(20.0), arm.spacing).unwrap_or_else(|e| panic!("{e}"));
    let (taken, met) =
        plan_and_tries_met(&arm, &s, arm.config, 2).unwrap_or_else(|e| panic!("{e}"));
    let (full, margin) =
        plan_every_try_in_full(&arm, &s, arm.config, 2).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "{} locations; tries met: {met:?}; least margin {:.6}°",
        s.len(),
        margin.to_degrees()
    );
    assert_eq!(met, [2, 3]);
    assert!(taken == full, "a different plan taken");
}

/// A measurement (ignored): the plan at `LAYER` (20 by default) written as every
/// location's turn and joints (`f64`, little-endian) to `PLAN_DUMP`, and compared with
/// the dump at `PLAN_BEFORE` where given (the largest difference printed): how the plans
/// of two builds were compared. Run with `LAYER=2 PLAN_DUMP=/tmp/after.bin
/// PLAN_BEFORE=/tmp/before.bin cargo test --release -p lampost-robot --test plate --
/// --ignored --nocapture` (the file copied into an older checkout to make the dump
/// before).
#[test]
#[ignore = "a measurement: run with --ignored --nocapture"]
fn the_plans_turns_and_joints_dumped_and_compared() {
    let Some(arm) = Arm::builtin("puma-lens") else {
        panic!("built-in");
    };
    let layer: f64 = std::env::var("LAYER")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20.0);
    let s = resample(&plate_path(layer), arm.spacing).unwrap_or_else(|e| panic!("{e}"));
    let t = std::time::Instant::now();
    let (p, met) = plan_and_tries_met(&arm, &s, arm.config, 2).unwrap_or_else(|e| panic!("{e}"));
    let least = p
        .iter()
        .map(|x| arm.margin(&x.q))
        .fold(f64::INFINITY, f64::min);
    println!(
        "{} locations in {} ms; tries met {met:?}; first turn {:.6}°; least margin {:.9}°",
        s.len(),
        t.elapsed().as_millis(),
        p.first().map_or(f64::NAN, |l| l.psi.to_degrees()),
        least.to_degrees()
    );
    let values: Vec<f64> = p
        .iter()
        .flat_map(|l| std::iter::once(l.psi).chain(l.q))
        .collect();
    if let Ok(path) = std::env::var("PLAN_DUMP") {
        let bytes: Vec<u8> = values.iter().flat_map(|x| x.to_le_bytes()).collect();
        std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{path}: {e}"));
    }
    if let Ok(path) = std::env::var("PLAN_BEFORE") {
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
        let before: Vec<f64> = bytes
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(std::array::from_fn(|k| c[k])))
            .collect();
        assert_eq!(
            before.len(),
            values.len(),
            "a different number of locations"
        );
        let most = before
            .iter()
            .zip(&values)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f64, f64::max);
        println!("largest difference from {path}: {most:.3e} rad");
    }
}

/// A measurement (ignored): the plate planned at `LAYER` (2 by default), then its chunk
/// files (4,000 locations each, as `cargo xtask bench robot` cuts them) written and
/// verified `REPS` times (5 by default) on two threads, each stage's best and mean wall
/// time printed; the files' text written to `CHUNK_DUMP` and compared byte for byte with
/// the dump at `CHUNK_BEFORE` where given: how the text of two builds was compared. Run
/// with `CHUNK_DUMP=/tmp/after.txt CHUNK_BEFORE=/tmp/before.txt cargo test --release -p
/// lampost-robot --test plate chunk_text -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement: run with --ignored --nocapture"]
fn chunk_text_timed_dumped_and_compared() {
    use lampost_robot::chunk::{chunk_files, chunk_ranges, verify_threads};
    use std::time::Instant;
    let Some(arm) = Arm::builtin("puma-lens") else {
        panic!("built-in");
    };
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    let layer = env("LAYER").unwrap_or(2.0);
    let reps = env("REPS").map_or(5, |r| r as usize).max(1);
    let s = resample(&plate_path(layer), arm.spacing).unwrap_or_else(|e| panic!("{e}"));
    let (p, _) = plan_and_tries_met(&arm, &s, arm.config, 2).unwrap_or_else(|e| panic!("{e}"));
    let ranges = chunk_ranges(&s, 4000).unwrap_or_else(|e| panic!("{e}"));
    let (mut text_ms, mut verify_ms) = (Vec::new(), Vec::new());
    let (mut text_cpu, mut verify_cpu) = (0.0, 0.0);
    let mut files = Vec::new();
    let mut report = None;
    for _ in 0..reps {
        let (t, c) = (Instant::now(), cpu_ms());
        files = chunk_files(&arm, arm.config, &s, &p, &ranges, 2);
        text_ms.push(t.elapsed().as_secs_f64() * 1e3);
        text_cpu += cpu_ms() - c;
        let (t, c) = (Instant::now(), cpu_ms());
        report = Some(
            verify_threads(&arm, &s, arm.config, &files, arm.tolerance, 2)
                .unwrap_or_else(|e| panic!("{e}")),
        );
        verify_ms.push(t.elapsed().as_secs_f64() * 1e3);
        verify_cpu += cpu_ms() - c;
    }
    let show = |v: &[f64], cpu: f64| {
        format!(
            "best {:.1} ms, mean {:.1} ms wall, {:.0} ms CPU",
            v.iter().copied().fold(f64::INFINITY, f64::min),
            v.iter().sum::<f64>() / v.len() as f64,
            cpu / v.len() as f64
        )
    };
    println!(
        "{} locations in {} chunks, {reps} runs: text {}; verification {}",
        s.len(),
        files.len(),
        show(&text_ms, text_cpu),
        show(&verify_ms, verify_cpu)
    );
    println!("verification: {report:?}");
    let text: String = files.iter().map(|f| f.text.as_str()).collect();
    if let Ok(path) = std::env::var("CHUNK_DUMP") {
        std::fs::write(&path, &text).unwrap_or_else(|e| panic!("{path}: {e}"));
    }
    if let Ok(path) = std::env::var("CHUNK_BEFORE") {
        let before = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
        assert!(before == text, "the chunk text differs from {path}");
        println!("the same text as {path} ({} bytes)", text.len());
    }
}

/// This process's CPU time, ms (user and system, from `/proc/self/stat`; NaN elsewhere).
fn cpu_ms() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let f: Vec<&str> = s.rsplit(')').next()?.split_whitespace().collect();
            let u: f64 = f.get(11)?.parse().ok()?;
            let k: f64 = f.get(12)?.parse().ok()?;
            Some((u + k) * 10.0)
        })
        .unwrap_or(f64::NAN)
}
