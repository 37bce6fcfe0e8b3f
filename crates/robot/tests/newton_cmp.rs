//! A measurement, not a check (ignored): the Gauss–Newton search for the turn about the
//! beam (`Search::Newton`, a prototype) against the reference search on paper 001's
//! full-size plate as `cargo xtask bench robot` plans it. Run with
//! `LAYER=2 cargo test --release -p lampost-robot --test newton_cmp -- --ignored --nocapture`
//! (`LAYER` 20 by default).

use lampost_robot::plan::{
    plan_with_search, resample, track_with_search, Located, PathPoint, Search,
};
use lampost_robot::{wrap, Arm};
use std::time::Instant;

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
#[ignore = "a measurement: run with --ignored --nocapture"]
fn newton_against_the_reference_on_the_plate() {
    let Some(arm) = Arm::builtin("puma-lens") else {
        panic!("built-in");
    };
    let layer: f64 = std::env::var("LAYER")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20.0);
    let s = resample(&plate_path(layer), arm.spacing).unwrap_or_else(|e| panic!("{e}"));
    let margin = |l: &[Located]| {
        l.iter()
            .map(|x| arm.margin(&x.q))
            .fold(f64::INFINITY, f64::min)
    };
    for search in [Search::Reference, Search::Newton] {
        let t = Instant::now();
        let (p, met) =
            plan_with_search(&arm, &s, arm.config, 2, search).unwrap_or_else(|e| panic!("{e}"));
        println!(
            "{search:?}: {} ms, tries met {met:?}, first turn {:.3}°, least margin {:.6}°",
            t.elapsed().as_millis(),
            p[0].psi.to_degrees(),
            margin(&p).to_degrees()
        );
    }
    for deg in [45.0f64, 55.0, 230.0] {
        let start = Some(deg.to_radians());
        let t = Instant::now();
        let a = track_with_search(&arm, &s, arm.config, start, Search::Reference)
            .unwrap_or_else(|e| panic!("{e}"));
        let ta = t.elapsed();
        let t = Instant::now();
        let b = track_with_search(&arm, &s, arm.config, start, Search::Newton)
            .unwrap_or_else(|e| panic!("{e}"));
        let tb = t.elapsed();
        let (mut dpsi, mut dq) = (0f64, 0f64);
        for (x, y) in a.iter().zip(&b) {
            dpsi = dpsi.max(wrap(x.psi - y.psi).abs());
            for j in 0..6 {
                dq = dq.max((x.q[j] - y.q[j]).abs());
            }
        }
        println!(
            "{deg}°: reference {:.0} ms, Newton {:.0} ms; least margins {:.6}° and {:.6}°; most apart: turn {dpsi:.2e} rad, joints {dq:.2e} rad",
            ta.as_secs_f64() * 1e3,
            tb.as_secs_f64() * 1e3,
            margin(&a).to_degrees(),
            margin(&b).to_degrees()
        );
    }
}
