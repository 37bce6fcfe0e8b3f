//! Issue 13's numeric cases at the library level: bounded time on large inputs, no
//! non-finite result, out-of-range magnitudes refused.

use lampost_align::{circle3d, plane, sphere, AlignError, P3};

fn circle_points(n: usize) -> Vec<P3> {
    // A radius-25 circle tilted out of XY, with a deterministic ±1 µm wobble.
    let (c, s) = (0.3f64.cos(), 0.3f64.sin());
    (0..n)
        .map(|i| {
            let t = i as f64 * std::f64::consts::TAU / n as f64;
            let wobble = 1e-3 * ((i as f64 * 0.618_033_988_7).fract() - 0.5);
            let (x, y) = ((25.0 + wobble) * t.cos(), (25.0 + wobble) * t.sin());
            P3::new(10.0 + x, -4.0 + y * c, 7.0 + y * s)
        })
        .collect()
}

/// The bound: one O(n) pass per trial step, at most `MAX_ITERATIONS` iterations, no n × p
/// Jacobian stored: 2·10⁵ points fit in seconds even unoptimised (10⁶ took 24 s).
#[test]
fn circle_on_many_points_is_linear_time() {
    let pts = circle_points(200_000);
    let t = std::time::Instant::now();
    let f = circle3d(&pts).expect("fits");
    let secs = t.elapsed().as_secs_f64();
    assert!((f.radius - 25.0).abs() < 1e-3, "{}", f.radius);
    assert!((P3::from(f.center) - P3::new(10.0, -4.0, 7.0)).norm() < 1e-6);
    assert!(secs < 60.0, "2·10⁵ points took {secs} s");
    eprintln!("circle3d on 2e5 points: {secs:.2} s");
}

#[test]
fn huge_coordinates_are_refused_not_looped_on() {
    let v = 1.7e308;
    let pts = [
        P3::new(v, 0.0, 0.0),
        P3::new(-v, 0.0, 0.0),
        P3::new(0.0, v, 0.0),
        P3::new(0.0, -v, 0.0),
        P3::new(0.0, 0.0, v),
    ];
    for r in [
        sphere(&pts, None).map(|_| ()),
        plane(&pts).map(|_| ()),
        circle3d(&pts).map(|_| ()),
    ] {
        assert!(
            matches!(r, Err(AlignError::TooLarge { index: 1, .. })),
            "{r:?}"
        );
    }
}

#[test]
fn plane_rms_never_overflows() {
    // Within range, with a spread whose squares are large: the rms is finite.
    let pts = [
        P3::new(0.0, 0.0, 0.0),
        P3::new(1e9, 0.0, 1e8),
        P3::new(0.0, 1e9, -1e8),
        P3::new(1e9, 1e9, 1e8),
        P3::new(-1e9, 5e8, 0.0),
    ];
    let f = plane(&pts).expect("fits");
    assert!(f.rms.is_finite() && f.rms > 0.0, "{}", f.rms);
    assert!(f.u_offset.is_some_and(f64::is_finite));
}

#[test]
fn negative_zero_is_the_same_point() {
    let pts = [
        P3::new(0.0, 0.0, 1.0),
        P3::new(-0.0, 5.0, 0.0),
        P3::new(-0.0, 0.0, 1.0),
        P3::new(1.0, 0.0, 0.0),
    ];
    assert!(matches!(
        plane(&pts),
        Err(AlignError::DuplicatePoints {
            first: 1,
            second: 3
        })
    ));
}
