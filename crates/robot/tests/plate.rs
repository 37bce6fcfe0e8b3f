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
    p.points()
        .iter()
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
