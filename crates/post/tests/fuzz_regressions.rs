//! Regressions of the `post` fuzz target (`cargo xtask fuzz --target post`): each input as
//! the fuzzer made it, posted and verified with the same calls and settings as the
//! target (`crates/fuzz/src/targets.rs`), and what was wrong worked out independently.

use lampost_kinematics::{Machine, Vector3};
use lampost_post::pointwise::{on_segment, post_points, read_points, verify_points, PathPoint};
use lampost_post::{Frame, IntendedOptions, PostConfig, PostDialect, PostError, Process};

use lampost_testkit::root;

/// The fixture `tilted-arc.csv` with lines (1-based) replaced.
fn tilted_arc(replace: &[(usize, &str)]) -> String {
    let text =
        std::fs::read_to_string(root().join("fixtures/post/tilted-arc.csv")).expect("fixture");
    text.lines()
        .enumerate()
        .map(|(i, l)| {
            let line = replace
                .iter()
                .find(|(n, _)| *n == i + 1)
                .map_or(l, |(_, r)| *r);
            format!("{line}\n")
        })
        .collect()
}

fn config(head: usize, process: Process, dialect: PostDialect, tol: f64) -> PostConfig {
    PostConfig {
        head,
        process,
        dialect,
        renumber: None,
        tolerance: tol,
        intended: IntendedOptions {
            convert_units: false,
            e_extrusion: false,
            flavor: lampost_gcode::Flavor::Fadal,
            units: None,
        },
        near: [0.0, 0.0],
        program_number: 1000,
        header: vec!["fuzz".into()],
        verify_tolerance: 2.0 * tol,
        work: None,
        part: None,
        max_output_bytes: Some(4 << 20),
    }
}

/// The fuzz target's verification tolerance: twice the chord tolerance, at least the
/// output's resolution allows (0.001 in, 0.02 mm).
fn verify_tol(m: &Machine, cfg: &PostConfig) -> f64 {
    cfg.verify_tolerance.max(match m.units {
        lampost_kinematics::Units::Inch => 0.001,
        lampost_kinematics::Units::Mm => 0.02,
    })
}

/// Post a per-point path as the fuzz target does, verify what was written, and return it.
fn post_and_verify(
    m: &Machine,
    csv: &str,
    origin: [f64; 3],
    cfg: &PostConfig,
) -> Result<String, PostError> {
    let pts = read_points(csv, "fuzz.csv").expect("points read");
    let frame = Frame::translation(Vector3::from(origin));
    let mut out = Vec::new();
    post_points(m, &pts, &frame, "fuzz.csv", cfg, &mut out)?;
    verify_points(
        m,
        &pts,
        &frame,
        cfg.head,
        &cfg.process,
        std::io::Cursor::new(out.as_slice()),
        verify_tol(m, cfg),
        cfg.work.as_ref(),
    )?;
    Ok(String::from_utf8(out).expect("text"))
}

fn point(tip: [f64; 3], axis: [f64; 3], line: usize) -> PathPoint {
    PathPoint {
        tip: Vector3::from(tip),
        axis: Vector3::from(axis).normalize(),
        feed: 100.0,
        deposit: true,
        line,
    }
}

/// Seed 1, input 9334: the last five points are one point (repeated rows), and a piece of
/// the segment onto them came within the tolerance (0.127 mm) of it. The verifier counted
/// that piece as reaching the first of them, each repeat as the next, and the last
/// repeat's move as feeding "on after the last point": the post refused its own program.
/// A point reached early is now one reading among others, kept until a move rules it out.
#[test]
fn repeated_points_reached_early_verify() {
    let m = Machine::builtin("nrc-lc", &[]).expect("machine");
    let csv = "x y z i j k feed laser
25.400000 0.000000 0 0.176300 0.000000 0.984336 0.5
24.838513 5.311148 0 0.172403 0.036864 0.984336 0.5 0
25.386075 0.840956 0 0.176203 0.005837 0.984336 20
16.103772 19.642518 0 0.111775 0.136338 0.984336 20 0
23.996981 8.324956 0 0.166562 0.057783 0.984336 1e5
5.967991 24.688926 0 0.041423 0.171364 0.984336 1e5
8.470590 23.945962 0 0.058794 0.166208 0.984336 1e5 0
16.796695 19.053373 0 0.116585 0.132248 0.984336 600 1
4.212231 25.048296 0 0.029237 0.173859 0.984336
4.723380 24.956957 0 0.032785 0.173225 0.984336
23.078884 10.607785 0 0.160189 0.073628 0.984336 600 1
10.607785 0 0.160189 0.073628 0.984336 600 1
10.607785 0 0.160189 0.073628 0.984336 600 1
10.607785 0 0.160189 0.073628 0.984336 600 1
10.607785 0 0.160189 0.073628 0.984336 600 1
10.607785 0 0.160189 0.073628 0.984336 600 1
";
    let cfg = config(
        1,
        Process::Machine {
            tool: None,
            length_offset: None,
            work_offset: Some("G59".into()),
            spindle: 3000.0,
            coolant: true,
        },
        PostDialect::Iso,
        0.127,
    );
    let origin = [0.23547782968926056, -0.752112618363217, 0.6274079511341958];
    let text = post_and_verify(&m, csv, origin, &cfg).expect("posts and verifies");

    // The program still ends where it must: one move more is refused, one less too.
    let pts = read_points(csv, "fuzz.csv").expect("points");
    let frame = Frame::translation(Vector3::from(origin));
    let verify = |t: &str| {
        verify_points(
            &m,
            &pts,
            &frame,
            1,
            &cfg.process,
            std::io::Cursor::new(t.as_bytes()),
            verify_tol(&m, &cfg),
            None,
        )
    };
    let lines: Vec<&str> = text.lines().collect();
    let last_feed = lines
        .iter()
        .rposition(|l| l.starts_with('X') || l.contains(" X"))
        .expect("a last move");
    let mut extra = lines.clone();
    extra.insert(last_feed + 1, "G1 X5. Y5.");
    let e = verify(&(extra.join("\n") + "\n")).expect_err("a move past the end");
    assert!(e.to_string().contains("after the last point"), "{e}");
    let mut short = lines.clone();
    // Dropping the segment's last piece onto the repeated points and every move after it
    // leaves them unreached.
    let first_repeat = lines
        .iter()
        .position(|l| l.contains("G94 X"))
        .expect("the per-minute move onto the repeats");
    short.drain(first_repeat - 1..=last_feed);
    let e = verify(&(short.join("\n") + "\n")).expect_err("the path cut short");
    assert!(e.to_string().contains("ends before the point"), "{e}");
}

/// Seed 1, input 66226: the tool axis turns by 81° while the tip moves 6e-6 mm. The
/// verifier took the fraction along the segment from the tip alone (1, the end) and
/// compared the axis there: 81° off. A move is now on a segment when one fraction puts
/// both the tip and the axis within their tolerances.
#[test]
fn an_axis_turning_about_a_standing_tip_verifies() {
    let m = Machine::builtin("nrc-lc", &[]).expect("machine");
    let same = "12.136 0 0.298836 0.298836 0.906308 600 1";
    let csv = tilted_arc(&[
        (11, same),
        (12, same),
        (13, same),
        (14, "12.136 0 0.29883,6 0.298836 0.906308 600 1"),
        (15, same),
    ]);
    let cfg = config(
        1,
        Process::Deposit { power: 500.0 },
        PostDialect::Nrc,
        0.0127,
    );
    let origin = [
        0.012262524915905182,
        -0.8581370076446933,
        0.10907847304664364,
    ];
    post_and_verify(&m, &csv, origin, &cfg).expect("posts and verifies");
}

/// Seed 1, input 204252: the segment onto a point whose axis is almost the C axis turns C
/// by 10° in its last 0.04 %: pieces there are within the tolerance of the point's tip
/// and axis before the segment's last piece. The first was counted as reaching the point,
/// and the next piece (still on the way to it) was judged against the following segment.
#[test]
fn a_point_reached_by_several_pieces_verifies() {
    let m = Machine::builtin("fadal-lamp", &[]).expect("machine");
    let csv = tilted_arc(&[(15, "2.610524 19.828897 0 0.055163  0.906308 600 1")]);
    let cfg = config(
        0,
        Process::Deposit { power: 0.0 },
        PostDialect::Iso,
        0.00005,
    );
    let origin = [-0.3386073043426916, 0.3851463584622832, 0.298690473483064];
    post_and_verify(&m, &csv, origin, &cfg).expect("posts and verifies");
}

/// Seed 1, input 111038: a feed of 601e-300 gave an inverse-time feed that the writer
/// wrote as `F0` (a move lasting 10^297 minutes): `verify` read a G93 move without F.
/// Refused at its line before it is written.
#[test]
fn an_inverse_time_feed_that_rounds_to_zero_is_refused_at_its_line() {
    let m = Machine::builtin("nrc-lc", &[]).expect("machine");
    let csv = tilted_arc(&[(
        10,
        "14.142136 14.142136 0 0.298836 0.298836 0.906308 601e-300 1",
    )]);
    let cfg = config(
        0,
        Process::Deposit { power: 0.0 },
        PostDialect::Nrc,
        0.00127,
    );
    let origin = [-0.6865485217514444, 0.9184011175979956, 0.32762491881568856];
    match post_and_verify(&m, &csv, origin, &cfg) {
        Err(PostError::OutOfRange { line, what, .. }) => {
            assert_eq!(line, 10);
            assert!(what.contains("F0"), "{what}");
        }
        other => panic!("expected a refusal at line 10, got {other:?}"),
    }
}

/// Seed 1, input 100159 (and 25 more in 20 s once `verify` followed long rotary turns): on
/// fadal-lamp's laser head (head 2) the segment from line 11 to line 12 crosses the circle
/// of axes where the inverse's two branches meet (its feeds of 1e9 made 600 here, as the
/// re-approach's feed must be writable). Halving towards it, the branch changed between two
/// fractions 6e-8 apart, and the post fed the last piece as it was: A turned 180° and B
/// went from +3.04° to −3.04°, the tool 5.6 mm off the path at the move's middle and 2.9 mm
/// off a quarter of the way. Such a jump is now reached by a retract, index and approach.
/// What the post wrote before (`branch-jump-fed.nc`, its first 274 lines, as the fuzzer
/// kept it) fails `verify` at that move.
#[test]
fn a_branch_jump_inside_a_segment_is_not_fed() {
    let m = Machine::builtin("fadal-lamp", &[]).expect("machine");
    let csv = std::fs::read_to_string(root().join("fixtures/post/findings/branch-jump.csv"))
        .expect("fixture");
    let origin = [0.04314354390229824, 0.6109860719563176, 0.886323999191928];
    for process in [machining(), Process::Deposit { power: 500.0 }] {
        let cfg = config(2, process.clone(), PostDialect::Nrc, 0.0005);
        let text = post_and_verify(&m, &csv, origin, &cfg).expect("posts and verifies");
        // Independently of the verifier: no feed turns a rotary by 90° or more.
        let mut last = [0.0f64; 2];
        let mut rapid = true;
        for l in text.lines() {
            let word = |c: char| {
                l.split_whitespace()
                    .find(|w| w.starts_with(c))
                    .and_then(|w| w[1..].parse::<f64>().ok())
            };
            if word('G') == Some(0.0) {
                rapid = true;
            } else if l.contains("G1 ") || l.contains(" G1") {
                rapid = false;
            }
            for (k, c) in ['A', 'B'].into_iter().enumerate() {
                if let Some(v) = word(c) {
                    assert!(
                        rapid || (v - last[k]).abs() < 90.0,
                        "{process:?}: a feed turns {c} from {} to {v}: {l}",
                        last[k]
                    );
                    last[k] = v;
                }
            }
        }
    }
    let before =
        std::fs::read(root().join("fixtures/post/findings/branch-jump-fed.nc")).expect("fixture");
    let pts = read_points(&csv, "fuzz.csv").expect("points read");
    let cfg = config(2, machining(), PostDialect::Nrc, 0.0005);
    let err = verify_points(
        &m,
        &pts,
        &Frame::translation(Vector3::from(origin)),
        2,
        &cfg.process,
        std::io::Cursor::new(before.as_slice()),
        verify_tol(&m, &cfg),
        None,
    )
    .expect_err("the 180° feed fails");
    let msg = err.to_string();
    assert!(
        msg.contains("posted line 250") && msg.contains("of the way along the move"),
        "{msg}"
    );
}

/// The fuzz target's machining process (spindle, G54).
fn machining() -> Process {
    Process::Machine {
        tool: None,
        length_offset: None,
        work_offset: Some("G54".into()),
        spindle: 1000.0,
        coolant: false,
    }
}

/// `on_segment` against a direct search: a pose is on the segment exactly when some
/// fraction t (sampled every 1e-4) puts the tip within the tolerance of the straight tip
/// path and the axis within 0.5° of the slerped axis (away from the boundaries, where
/// sampling cannot decide).
#[test]
fn on_segment_agrees_with_a_search_over_the_fraction() {
    let slerp = |a: &Vector3<f64>, b: &Vector3<f64>, t: f64| {
        let ang = a.angle(b);
        if ang < 1e-12 {
            return *a;
        }
        (a * ((1.0 - t) * ang).sin() + b * (t * ang).sin()) / ang.sin()
    };
    let deg = |a: &Vector3<f64>, b: &Vector3<f64>| a.angle(b).to_degrees();
    let cases = [
        // The tip barely moves, the axis turns 81° (input 66226).
        (
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 6e-6],
            [0.0005, 0.0015, 1.0],
            [0.9876, 0.0492, 0.1492],
        ),
        // Both move.
        (
            [0.0, 0.0, 0.0],
            [1.0, 0.5, 0.0],
            [0.0, 0.0, 1.0],
            [0.3, 0.0, 0.95],
        ),
        // The tip moves, the axis stands.
        (
            [1.0, 2.0, 3.0],
            [1.2, 2.0, 3.0],
            [0.1, 0.2, 1.0],
            [0.1, 0.2, 1.0],
        ),
    ];
    let tol = 0.01;
    let mut seen = [0usize; 2];
    for (ta, tb, aa, ab) in cases {
        let a = point(ta, aa, 1);
        let b = point(tb, ab, 2);
        for k in 0..150 {
            // Poses near the path: a fraction, a sideways offset, an axis tilt.
            let f = k as f64 / 149.0;
            let t0 = (f * 1.4 - 0.2).clamp(-0.2, 1.2);
            let side = Vector3::new(
                0.013 * (k as f64 * 0.7).sin(),
                0.0,
                0.011 * (k as f64 * 1.3).cos(),
            );
            let tip = a.tip + (b.tip - a.tip) * t0 + side * ((k % 5) as f64 / 4.0);
            let ax0 = slerp(&a.axis, &b.axis, f64::clamp((k % 7) as f64 / 6.0, 0.0, 1.0));
            let tilt = Vector3::new(0.0, 0.004 * (k % 3) as f64, 0.0);
            let axis = (ax0 + tilt).normalize();
            // The search, with its margins: clearly inside, clearly outside.
            let (mut inside, mut near) = (false, false);
            for i in 0..=10_000 {
                let t = i as f64 / 1e4;
                let e = (tip - (a.tip + (b.tip - a.tip) * t)).norm();
                let g = deg(&axis, &slerp(&a.axis, &b.axis, t));
                if e <= tol * 0.98 && g <= 0.5 * 0.98 {
                    inside = true;
                }
                if e <= tol * 1.02 && g <= 0.5 * 1.02 {
                    near = true;
                }
            }
            let got = on_segment(&a, &b, &tip, &axis, tol);
            if inside {
                let (e, g) =
                    got.unwrap_or_else(|| panic!("case {ta:?}: pose {k} is on the segment"));
                assert!(e <= tol * (1.0 + 1e-9) && g <= 0.5 * (1.0 + 1e-9));
                seen[0] += 1;
            } else if !near {
                assert!(
                    got.is_none(),
                    "case {ta:?}: pose {k} is off the segment: {got:?}"
                );
                seen[1] += 1;
            }
        }
    }
    assert!(seen[0] > 100 && seen[1] > 100, "{seen:?}");
}
