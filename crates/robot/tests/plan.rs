//! Path to poses: resampling, the planned joints (focus on the point, approach along the
//! beam, one configuration, limits), chunk cuts, and the location files' pose angles.

use lampost_robot::chunk::{chunk_ranges, from_zyz, part_of, zyz};
use lampost_robot::plan::{plan, resample, PathPoint, Sample, MAX_TURN};
use lampost_robot::RobotError;
use lampost_robot::{Arm, Q};
use nalgebra::Vector3;
use proptest::prelude::*;

fn pt(x: f64, y: f64, z: f64, axis: [f64; 3], deposit: bool, line: usize) -> PathPoint {
    PathPoint {
        tip: Vector3::new(x, y, z),
        axis: Vector3::from(axis).normalize(),
        feed: 600.0,
        deposit,
        line,
    }
}

fn arm() -> Arm {
    Arm::builtin("puma-lens").unwrap_or_else(|| panic!("built-in"))
}

#[test]
fn resampling_keeps_points_and_times_segments() {
    let path = [
        pt(0.0, 0.0, 0.0, [0.0, 0.0, 1.0], false, 1),
        pt(10.0, 0.0, 0.0, [0.0, 0.0, 1.0], true, 2),
        pt(10.0, 0.0, 0.0, [0.0, 0.0, 1.0], true, 3), // repeated: dropped
        pt(10.0, 2.5, 0.0, [0.0, 0.1, 1.0], true, 4),
    ];
    let s = resample(&path, 1.0).unwrap_or_else(|e| panic!("{e}"));
    // 10 pieces, then 3 of 2.5/3 (the turn of 5.7° asks for 6).
    assert_eq!(s.len(), 1 + 10 + 6);
    assert_eq!(s[10].tip, Vector3::new(10.0, 0.0, 0.0));
    assert!((s[1].dt - 1.0 / 600.0 * 60.0).abs() < 1e-15);
    assert_eq!(s.last().map(|x| x.line), Some(4));
    assert!(!s[0].deposit && s[1].deposit);
    for w in s.windows(2) {
        assert!((w[1].tip - w[0].tip).norm() <= 1.0 + 1e-12);
        assert!(w[0].axis.angle(&w[1].axis) <= MAX_TURN + 1e-12);
    }
    assert!(matches!(resample(&path, 0.0), Err(RobotError::Option(_))));
    assert!(matches!(resample(&[], 1.0), Err(RobotError::Option(_))));
    let huge = [path[0], pt(1e12, 0.0, 0.0, [0.0, 0.0, 1.0], true, 2)];
    assert!(matches!(resample(&huge, 1.0), Err(RobotError::Option(_))));
}

#[test]
fn planned_joints_bring_every_point_to_the_focus_in_one_configuration() {
    let arm = arm();
    let mut path = vec![pt(0.0, 0.0, 0.0, [0.0, 0.0, 1.0], false, 1)];
    for k in 1..=40 {
        let a = k as f64 / 40.0 * std::f64::consts::TAU;
        // A circle with the approach leaning out by up to 20°.
        let lean = 20f64.to_radians() * (a / 2.0).sin();
        path.push(pt(
            30.0 * a.cos() - 30.0,
            30.0 * a.sin(),
            0.0,
            [lean.sin() * a.cos(), lean.sin() * a.sin(), lean.cos()],
            true,
            k + 1,
        ));
    }
    let s = resample(&path, 1.0).unwrap_or_else(|e| panic!("{e}"));
    let located = plan(&arm, &s, arm.config).unwrap_or_else(|e| panic!("{e}"));
    let mut prev: Option<Q> = None;
    for (x, l) in s.iter().zip(&located) {
        let part = part_of(&arm, &l.q);
        assert!(part.apply(&x.tip).norm() < 1e-9, "focus");
        assert!((part.r * x.axis - Vector3::z()).norm() < 1e-9, "approach");
        assert!((part.r - l.part.r).abs().max() < 1e-9);
        assert!(arm.within_limits(&l.q).is_none());
        let co = arm.config_of(&l.q).unwrap_or_else(|| panic!("closed form"));
        assert!(co.fits(arm.config), "{co:?}");
        if let Some(p) = prev {
            // Smooth: no joint jumps more than its speed allows at the feed.
            for (j, link) in arm.links.iter().enumerate() {
                assert!((l.q[j] - p[j]).abs() <= link.max_speed * x.dt + 1e-9);
            }
        }
        prev = Some(l.q);
    }
}

fn sample(deposit: bool, line: usize) -> Sample {
    Sample {
        tip: Vector3::zeros(),
        axis: Vector3::z(),
        deposit,
        dt: 0.1,
        line,
    }
}

#[test]
fn chunks_are_cut_where_the_laser_is_off() {
    // Runs of 4 laser-on locations after each laser-off one.
    let s: Vec<Sample> = (0..20).map(|i| sample(i % 5 != 0, i + 1)).collect();
    let r = chunk_ranges(&s, 2 + 7).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r, vec![0..5, 5..10, 10..15, 15..20]);
    let r = chunk_ranges(&s, 2 + 10).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r, vec![0..10, 10..20]);
    let r = chunk_ranges(&s, 100).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r, vec![0..20]);
    for cut in chunk_ranges(&s, 8).unwrap_or_default() {
        assert!(cut.start == 0 || !s[cut.start].deposit);
        assert!(cut.len() <= 6);
    }
    match chunk_ranges(&s, 2 + 4) {
        Err(RobotError::ChunkTooSmall { line, what }) => {
            assert_eq!(line, 1, "{what}");
            assert!(what.contains("at least 5 locations"), "{what}");
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(chunk_ranges(&s, 2), Err(RobotError::Option(_))));
}

proptest! {
    #[test]
    fn zyz_round_trips(a in -3.1..3.1f64, b in 0.0..3.1f64, c in -3.1..3.1f64) {
        let r = from_zyz([a, b, c]);
        let back = from_zyz(zyz(&r));
        prop_assert!((back - r).abs().max() < 1e-12);
    }
}
