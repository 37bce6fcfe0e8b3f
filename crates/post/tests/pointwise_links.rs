//! How the per-point post links runs whose tool axes differ: a laser-off move that turns
//! the table is a linking move (retract, index, approach), and an axis leaving the inner
//! rotary axis turns that axis in place first. Found posting planned perimeters of a
//! sphere and of CGAL's fandisk: the move was written as one five-axis feed whose
//! inverse-time F overflowed the word, or swept the table half a turn at the work.

use lampost_kinematics::Machine;
use lampost_post::pointwise::{post_points, verify_points, PathPoint};
use lampost_post::{Frame, PostConfig, PostReport, Process};
use nalgebra::Vector3;

fn point(tip: [f64; 3], axis: [f64; 3], deposit: bool, line: usize) -> PathPoint {
    PathPoint {
        tip: Vector3::from(tip),
        axis: Vector3::from(axis).normalize(),
        feed: 600.0,
        deposit,
        line,
    }
}

fn post_and_verify(m: &Machine, pts: &[PathPoint]) -> (String, PostReport) {
    let cfg = PostConfig::new(m, Process::Deposit { power: 500.0 });
    let frame = Frame::translation(Vector3::new(0.0, 0.0, 0.0));
    let mut out = Vec::new();
    let report = post_points(m, pts, &frame, "links.csv", &cfg, &mut out).expect("posts");
    verify_points(
        m,
        pts,
        &frame,
        cfg.head,
        &cfg.process,
        std::io::Cursor::new(out.as_slice()),
        cfg.verify_tolerance,
        None,
    )
    .expect("verifies");
    (String::from_utf8(out).expect("text"), report)
}

/// Every F word of the program, as numbers.
fn feeds(text: &str) -> Vec<f64> {
    text.lines()
        .filter(|l| !l.starts_with('('))
        .flat_map(|l| l.split_whitespace())
        .filter_map(|w| w.strip_prefix('F'))
        .map(|v| v.parse::<f64>().expect("an F number"))
        .collect()
}

#[test]
fn a_laser_off_move_that_turns_the_table_is_a_retract_index_and_approach() {
    let m = Machine::builtin("nrc-lc", &[]).expect("machine");
    let s = 20f64.to_radians().sin();
    let c = 20f64.to_radians().cos();
    // A run leaning toward +X, then travel to a run leaning toward −X: C half a turn.
    let pts = [
        point([20.0, 0.0, 0.0], [s, 0.0, c], true, 2),
        point([20.0, 5.0, 0.0], [s, 0.0, c], true, 3),
        point([-20.0, 5.0, 0.0], [-s, 0.0, c], false, 4),
        point([-20.0, 0.0, 0.0], [-s, 0.0, c], true, 5),
    ];
    let (text, report) = post_and_verify(&m, &pts);
    assert_eq!(report.indexes.len(), 2, "{text}");
    // The second index is written at the safe height, after the laser went off.
    let lines: Vec<&str> = text.lines().collect();
    let second = lines
        .iter()
        .rposition(|l| l.contains("INDEX"))
        .expect("an index");
    let before = &lines[..second];
    let last_z = before
        .iter()
        .rev()
        .find_map(|l| {
            l.split_whitespace()
                .find_map(|w| w.strip_prefix('Z'))
                .map(|v| v.parse::<f64>().expect("Z"))
        })
        .expect("a Z before the index");
    assert!(last_z > 50.0, "index at Z{last_z}: {text}");
    assert!(
        feeds(&text).iter().all(|f| f.is_finite() && *f < 1e6),
        "{text}"
    );
}

#[test]
fn an_axis_leaving_the_c_axis_turns_c_in_place_first() {
    let m = Machine::builtin("nrc-lc", &[]).expect("machine");
    let t = 3f64.to_radians();
    // Vertical (C free, kept at 0), then tilted toward −Y: C must stand near ±90.
    let pts = [
        point([10.0, 10.0, 0.0], [0.0, 0.0, 1.0], true, 2),
        point([9.0, 10.0, 0.0], [0.0, 0.0, 1.0], true, 3),
        point([8.99, 10.0, 0.0], [0.0, -t.sin(), t.cos()], true, 4),
        point([8.0, 10.0, 0.0], [0.0, -t.sin(), t.cos()], true, 5),
    ];
    let (text, report) = post_and_verify(&m, &pts);
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.contains("links.csv:4:") && w.contains("turns") && w.contains("in place")),
        "{:?}",
        report.warnings
    );
    assert_eq!(
        report.indexes.len(),
        1,
        "no retract for a turn in place: {text}"
    );
    assert!(
        feeds(&text).iter().all(|f| f.is_finite() && *f < 1e6),
        "{text}"
    );
}
