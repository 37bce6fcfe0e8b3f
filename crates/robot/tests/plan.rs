//! Path to poses: resampling, the planned joints (focus on the point, approach along the
//! beam, one configuration, limits), chunk cuts, and the location files' pose angles.

use lampost_robot::chunk::{
    chunk_files, chunk_ranges, from_zyz, part_of, verify_threads, zyz, ChunkFile,
};
use lampost_robot::plan::{
    plan, plan_and_tries_met, plan_every_try_in_full, plan_every_try_to_its_end, plan_threads,
    resample, PathPoint, Sample, CLEAR, MAX_TURN, MEET, MEET_AT,
};
use lampost_robot::RobotError;
use lampost_robot::{Arm, ArmDef, Q};
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
        assert!((part.r - l.part(x).r).abs().max() < 1e-9);
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
        u: Vector3::x(),
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
    /// Every rotation comes back to rounding, b near 0 or π (the singularity, where a
    /// and c alone are ill-conditioned) included, down to 2e-12 from it (below 1e-12 zyz
    /// takes b as 0 or π). The rotation is made as a product `Rz(a) Ry(b1) · Ry(b − b1)
    /// Rz(c)`, so that its entries carry rounding as a pose made by a chain of frames
    /// does. (Taking c from the third row alone gave back 4e-6 off at b = 2e-12.)
    fn zyz_round_trips(
        a in -3.1..3.1f64,
        b in prop_oneof![0.0..3.1f64, 2e-12..1e-6f64, 3.141_591..3.141_592_653_587],
        b1 in -3.1..3.1f64,
        c in -3.1..3.1f64,
    ) {
        let r = from_zyz([a, b1, 0.0]) * from_zyz([0.0, b - b1, c]);
        let back = from_zyz(zyz(&r));
        prop_assert!((back - r).abs().max() < 2e-15, "{:e}", (back - r).abs().max());
    }
}

/// The start of the planned full-size plate's first layer (`lampost plan path --approach
/// build`): the beam vertical, the first move 0.06 mm towards the end of a 600 mm pass.
/// The first turn about the beam used to be the one nearest the safe location (the arm
/// upright, its elbow stretched), which put this end of the plate 1.5° from the elbow's
/// stretch: J3 had to turn 0.68° for the first 0.06 mm (116°/s at 600 mm/min). Chosen for
/// the whole path, the turn keeps every location well away from the stretch and the
/// limits, and every joint well within its speed.
fn plate_end() -> Vec<PathPoint> {
    let up = [0.0, 0.0, 1.0];
    vec![
        pt(-299.301970, 1.143362, 1.0, up, false, 3),
        pt(-299.360139, 1.141525, 1.0, up, true, 4),
        pt(-300.0, 1.12132, 1.0, up, true, 5),
        pt(-300.0, -1.12132, 1.0, up, true, 6),
        pt(300.0, -1.12132, 1.0, up, true, 7),
        pt(300.0, 1.12132, 200.0, up, false, 8),
        pt(-300.0, 1.12132, 200.0, up, true, 9),
    ]
}

#[test]
fn the_first_turn_about_the_beam_keeps_the_whole_path_away_from_the_elbow_stretch() {
    let arm = arm();
    let s = resample(&plate_end(), 1.0).unwrap_or_else(|e| panic!("{e}"));
    let located = plan(&arm, &s, arm.config).unwrap_or_else(|e| panic!("{e}"));
    // The elbow 20° or more from its stretch, every joint 2° or more within its limits.
    let stretch = -(431.8f64.atan2(20.3));
    for l in &located {
        let q = l.q.map(f64::to_degrees);
        assert!((l.q[2] - stretch).abs() > 20f64.to_radians(), "{q:?}");
        assert!(arm.margin(&l.q) > 2f64.to_radians(), "{q:?}");
    }
    for (w, x) in located.windows(2).zip(&s[1..]) {
        for (j, link) in arm.links.iter().enumerate() {
            let dq = (w[1].q[j] - w[0].q[j]).abs();
            assert!(
                dq <= 0.5 * link.max_speed * x.dt + 1e-9,
                "J{} at line {}",
                j + 1,
                x.line
            );
        }
    }
}

/// `Arm::margin`: the distance to the nearer limit, or to the elbow's stretch.
#[test]
fn the_margin_is_the_nearest_limit_or_elbow_stretch() {
    let arm = arm();
    let stretch = -(431.8f64.atan2(20.3));
    let mut q = [0.0, 1.0, stretch + 0.3, 0.0, 0.5, 0.0];
    assert!((arm.margin(&q) - 0.3).abs() < 1e-12);
    q[2] = stretch - 0.2;
    assert!((arm.margin(&q) - 0.2).abs() < 1e-12);
    // J5 0.1 rad from its upper limit (100°).
    q[2] = -1.0;
    q[4] = 100f64.to_radians() - 0.1;
    assert!((arm.margin(&q) - 0.1).abs() < 1e-12);
}

/// The scalar reference of `Arm::fit_limits`: every turn of each joint within ±3 turns
/// of the value, the one within the limits nearest the previous value (the first of
/// equals, in order of turns).
fn fit_limits_reference(arm: &Arm, q: &Q, near: &Q) -> Result<Q, usize> {
    let tau = std::f64::consts::TAU;
    let mut out = *q;
    for j in 0..6 {
        let l = &arm.links[j];
        let base = near[j] + lampost_robot::wrap(q[j] - near[j]);
        let mut best: Option<f64> = None;
        for k in -3..=3 {
            let c = base + tau * f64::from(k);
            if c >= l.lo - 1e-9 && c <= l.hi + 1e-9 {
                let c = c.clamp(l.lo, l.hi);
                if best.is_none_or(|b| (c - near[j]).abs() < (b - near[j]).abs()) {
                    best = Some(c);
                }
            }
        }
        out[j] = best.ok_or(j)?;
    }
    Ok(out)
}

proptest! {
    /// The nearest-turn fast path of `fit_limits` gives what the whole search gives.
    #[test]
    fn fitting_the_limits_agrees_with_the_whole_search(
        q in proptest::array::uniform6(-7.0..7.0f64),
        near in proptest::array::uniform6(-5.0..5.0f64),
    ) {
        let arm = arm();
        prop_assert_eq!(arm.fit_limits(&q, &near), fit_limits_reference(&arm, &q, &near));
    }
}

/// The tried first turns planned on threads give the plan one thread gives: the first
/// clear one (the plate's end on puma-lens), and, on an arm whose J1 limits hug the
/// path so that no plan is clear, the one keeping farthest from the limits.
#[test]
fn planning_on_threads_takes_the_plan_one_thread_takes() {
    let s = resample(&plate_end(), 1.0).unwrap_or_else(|e| panic!("{e}"));
    let puma = arm();
    let one = plan_threads(&puma, &s, puma.config, 1).unwrap_or_else(|e| panic!("{e}"));
    for threads in [2, 4] {
        assert_eq!(
            plan_threads(&puma, &s, puma.config, threads),
            Ok(one.clone())
        );
    }
    // J1 within 12° of the range it sweeps, so every plan comes within 10° of a limit.
    let (lo, hi) = one
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), l| {
            (a.min(l.q[0]), b.max(l.q[0]))
        });
    let mut def = ArmDef::builtin("puma-lens").unwrap_or_else(|| panic!("built-in"));
    def.joint[0].limits = [lo.to_degrees() - 12.0, hi.to_degrees() + 3.0];
    let tight = Arm::new(def);
    let one = plan_threads(&tight, &s, tight.config, 1).unwrap_or_else(|e| panic!("{e}"));
    let worst = one
        .iter()
        .map(|l| tight.margin(&l.q))
        .fold(f64::INFINITY, f64::min);
    assert!(worst < CLEAR, "{}", worst.to_degrees());
    for threads in [2, 4] {
        assert_eq!(
            plan_threads(&tight, &s, tight.config, threads),
            Ok(one.clone())
        );
    }
    // Tries that stop once they cannot be taken leave the plan taken as it is.
    for threads in [1, 2] {
        assert_eq!(
            plan_every_try_to_its_end(&tight, &s, tight.config, threads),
            Ok(one.clone())
        );
    }
}

/// The plate's end planned at 1 mm, the laser off every 50 locations, cut into chunks of
/// 200 (four or more): the arm, the locations, the plan and the cuts.
fn plate_end_in_chunks() -> (
    Arm,
    Vec<Sample>,
    Vec<lampost_robot::plan::Located>,
    Vec<std::ops::Range<usize>>,
) {
    let puma = arm();
    let mut s = resample(&plate_end(), 1.0).unwrap_or_else(|e| panic!("{e}"));
    // The laser off every 50 locations, so that chunks may be cut there.
    for x in s.iter_mut().step_by(50) {
        x.deposit = false;
    }
    let located = plan(&puma, &s, puma.config).unwrap_or_else(|e| panic!("{e}"));
    let ranges = chunk_ranges(&s, 200).unwrap_or_else(|e| panic!("{e}"));
    assert!(ranges.len() >= 4, "{}", ranges.len());
    (puma, s, located, ranges)
}

/// Chunk files written on threads are the same text, verified on threads the same
/// figures; with two chunks spoiled, the error named is the first chunk's, as one
/// thread finds it.
#[test]
fn chunks_written_and_verified_on_threads_agree_with_one_thread() {
    let (puma, s, located, ranges) = plate_end_in_chunks();
    let one = chunk_files(&puma, puma.config, &s, &located, &ranges, 1);
    let two = chunk_files(&puma, puma.config, &s, &located, &ranges, 2);
    let text = |f: &[ChunkFile]| -> Vec<(String, usize, usize, String)> {
        f.iter()
            .map(|c| (c.name.clone(), c.first, c.count, c.text.clone()))
            .collect()
    };
    assert_eq!(text(&one), text(&two));
    assert_eq!(one[0].name, "chunk-001.loc");
    let verify = |f: &[ChunkFile], threads| {
        verify_threads(&puma, &s, puma.config, f, puma.tolerance, threads)
    };
    let rep = verify(&one, 1).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rep.locations, s.len());
    assert_eq!(verify(&one, 2), Ok(rep));
    // Spoil the second and the last chunk: the second's error, on any number of threads.
    let mut bad = one.clone();
    let spoil = |c: &mut ChunkFile| c.text = c.text.replacen(" path ", " path x", 1);
    spoil(&mut bad[1]);
    let last = bad.len() - 1;
    spoil(&mut bad[last]);
    let e1 = verify(&bad, 1);
    assert!(
        matches!(&e1, Err(RobotError::Verify { file, .. }) if file == "chunk-002.loc"),
        "{e1:?}"
    );
    assert_eq!(verify(&bad, 2), e1);
}

/// Posting chunk by chunk (`post_chunks`: each written into a reused buffer, verified,
/// handed on) hands on exactly `chunk_files`' texts with `verify`'s figures, on one or two
/// threads; a plan spoiled beyond the tolerance is caught and names its chunk, that chunk
/// never handed on; a failure to keep a chunk is returned as it is.
#[test]
fn chunks_posted_one_by_one_are_the_files_verified() {
    use lampost_robot::chunk::{post_chunks, PostError};
    use std::sync::Mutex;
    let (puma, s, located, ranges) = plate_end_in_chunks();
    let files = chunk_files(&puma, puma.config, &s, &located, &ranges, 1);
    let want = verify_threads(&puma, &s, puma.config, &files, puma.tolerance, 1)
        .unwrap_or_else(|e| panic!("{e}"));
    let post = |located: &[lampost_robot::plan::Located], threads| {
        let kept: Mutex<Vec<(String, usize, usize, String)>> = Mutex::new(Vec::new());
        let r = post_chunks(
            &puma,
            puma.config,
            &s,
            located,
            &ranges,
            puma.tolerance,
            threads,
            |c, text| {
                let text = String::from_utf8(text.to_vec()).map_err(|e| e.to_string())?;
                kept.lock().map_err(|e| e.to_string())?.push((
                    c.name.clone(),
                    c.first,
                    c.count,
                    text,
                ));
                Ok::<(), String>(())
            },
        );
        let mut kept = kept.into_inner().unwrap_or_else(|e| panic!("{e}"));
        kept.sort();
        (r, kept)
    };
    let files: Vec<_> = files
        .iter()
        .map(|c| (c.name.clone(), c.first, c.count, c.text.clone()))
        .collect();
    for threads in [1, 2] {
        let (r, kept) = post(&located, threads);
        let Ok((infos, rep)) = r else {
            panic!("{r:?}");
        };
        assert_eq!(rep, want);
        assert_eq!(kept, files);
        assert_eq!(infos.len(), files.len());
    }
    // A joint of the third chunk's first location moved by 1e-3 rad: caught there.
    let mut bad = located.clone();
    bad[ranges[2].start + 1].q[1] += 1e-3;
    for threads in [1, 2] {
        let (r, kept) = post(&bad, threads);
        assert!(
            matches!(&r, Err(PostError::Verify(RobotError::Verify { file, .. })) if file == "chunk-003.loc"),
            "{r:?}"
        );
        assert!(kept.iter().all(|k| k.0 != "chunk-003.loc"));
    }
    // Keeping fails at the second chunk: that failure comes back.
    let r = post_chunks(
        &puma,
        puma.config,
        &s,
        &located,
        &ranges,
        puma.tolerance,
        2,
        |c, _| {
            if c.name == "chunk-002.loc" {
                Err("disk full")
            } else {
                Ok(())
            }
        },
    );
    assert!(matches!(r, Err(PostError::Keep("disk full"))), "{r:?}");
}

/// The plate's end in passes up its face (5 passes of 600 mm, the laser off between):
/// 3,400 locations at 1 mm, longer than `MEET_AT`, where the tried first turns 5° apart
/// meet.
fn plate_passes() -> Vec<PathPoint> {
    let up = [0.0, 0.0, 1.0];
    let mut path = plate_end();
    for (k, z) in [50.0, 100.0, 150.0].into_iter().enumerate() {
        let (a, b) = if k % 2 == 0 {
            (-300.0, 300.0)
        } else {
            (300.0, -300.0)
        };
        path.push(pt(a, 1.12132, z, up, false, 10 + 2 * k));
        path.push(pt(b, 1.12132, z, up, true, 11 + 2 * k));
    }
    path
}

/// Planning keeps joints found by changes from the last location's (without the closed
/// form's angles, up to 64 locations in a row): every location's joints are the full
/// closed form's at its pose, on the turn nearest them, to 1e-11 rad.
#[test]
fn planned_joints_are_the_full_solves_at_their_poses() {
    let arm = arm();
    let s = resample(&plate_passes(), 1.0).unwrap_or_else(|e| panic!("{e}"));
    let located = plan(&arm, &s, arm.config).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(located.len(), s.len());
    let mut most = 0.0f64;
    for (l, x) in located.iter().zip(&s) {
        let raw = arm
            .inverse_in_work(&l.part(x), arm.config, l.q[3])
            .unwrap_or_else(|e| panic!("{}", e.why));
        let q = arm
            .fit_limits(&raw, &l.q)
            .unwrap_or_else(|j| panic!("J{}", j + 1));
        for (a, b) in q.iter().zip(&l.q) {
            most = most.max((a - b).abs());
        }
    }
    assert!(most < 1e-11, "{most:e} rad");
}

/// Tries whose tracks meet at `MEET_AT` count as one plan: some are dropped on the
/// plate's passes, the plan taken is the one the rule without meeting takes or keeps as
/// far from trouble within `MEET`, on any number of threads, with or without the early
/// stop.
#[test]
fn tries_that_meet_count_as_one_plan() {
    let arm = arm();
    let s = resample(&plate_passes(), 1.0).unwrap_or_else(|e| panic!("{e}"));
    assert!(s.len() > MEET_AT, "{}", s.len());
    let (taken, met) =
        plan_and_tries_met(&arm, &s, arm.config, 1).unwrap_or_else(|e| panic!("{e}"));
    let (full, full_margin) =
        plan_every_try_in_full(&arm, &s, arm.config, 1).unwrap_or_else(|e| panic!("{e}"));
    let margin = taken
        .iter()
        .map(|l| arm.margin(&l.q))
        .fold(f64::INFINITY, f64::min);
    println!(
        "{} locations; tries met: {met:?}; margin {:.6}° (every try in full: {:.6}°, the same plan: {})",
        s.len(),
        margin.to_degrees(),
        full_margin.to_degrees(),
        taken == full
    );
    assert!(!met.is_empty(), "no try met another");
    assert!(margin >= full_margin - MEET, "{margin} {full_margin}");
    for threads in [2, 4] {
        assert_eq!(
            plan_and_tries_met(&arm, &s, arm.config, threads),
            Ok((taken.clone(), met.clone()))
        );
    }
    for threads in [1, 2] {
        assert_eq!(
            plan_every_try_to_its_end(&arm, &s, arm.config, threads),
            Ok(taken.clone())
        );
    }
}

/// Bit for bit what the standard parser reads (`None` where it fails).
fn std_bits(s: &str) -> Option<u64> {
    s.parse::<f64>().ok().map(f64::to_bits)
}

proptest! {
    /// The location files' numbers (`lampost_gcode::fixed`, any places) are read by the
    /// fast path, bit for bit as the standard parser reads them.
    #[test]
    fn numbers_as_written_are_read_as_the_standard_parser_reads_them(
        v in prop_oneof![-1e6..1e6f64, -1.0..1.0f64, -1e-7..1e-7f64, Just(-0.0), Just(0.0)],
        places in 0usize..10,
    ) {
        let s = lampost_gcode::fixed(v, places);
        let fast = lampost_robot::chunk::parse_plain(&s);
        if s.bytes().filter(u8::is_ascii_digit).count() <= 15 {
            prop_assert!(fast.is_some(), "{}", s);
        }
        prop_assert_eq!(fast.map(f64::to_bits).or_else(|| std_bits(&s)), std_bits(&s), "{}", s);
    }

    /// Any text of digits, signs and points (and a few other characters): the fast path
    /// gives the standard parser's value or leaves the text to it.
    #[test]
    fn any_number_text_is_read_as_the_standard_parser_reads_it(
        s in "[-+]?[0-9]{0,18}(\\.[0-9]{0,18})?([eE][-+]?[0-9]{1,3})?|[-+.0-9a-z ]{0,12}",
    ) {
        let fast = lampost_robot::chunk::parse_plain(&s);
        if let Some(v) = fast {
            prop_assert_eq!(Some(v.to_bits()), std_bits(&s), "{}", s);
        }
        prop_assert_eq!(
            lampost_robot::chunk::parse_number(&s).map(f64::to_bits),
            std_bits(&s),
            "{}",
            s
        );
    }
}

/// A location row as the format's description gives it, number by number through
/// `lampost_gcode::fixed`: the reference the chunk writer is held to.
#[allow(clippy::too_many_arguments)]
fn row_reference(
    n: usize,
    kind: &str,
    index: &str,
    dt: f64,
    part: &lampost_robot::Frame,
    laser: bool,
    q: &Q,
) -> String {
    use lampost_gcode::fixed;
    let mut f = vec![
        n.to_string(),
        kind.to_string(),
        index.to_string(),
        fixed(dt, 6),
    ];
    f.extend([part.t.x, part.t.y, part.t.z].map(|v| fixed(v, 6)));
    f.extend(zyz(&part.r).map(|v| fixed(v.to_degrees(), 7)));
    f.push(if laser { "1" } else { "0" }.to_string());
    f.extend(q.map(|v| fixed(v.to_degrees(), 7)));
    f.join(" ")
}

/// Every row of the chunk files (the plate's end, cut for a 1000-location controller) is
/// the reference's text.
#[test]
fn chunk_rows_are_the_formats_numbers() {
    let puma = arm();
    let s = resample(&plate_end(), 1.0).unwrap_or_else(|e| panic!("{e}"));
    let located = plan(&puma, &s, puma.config).unwrap_or_else(|e| panic!("{e}"));
    let ranges = chunk_ranges(&s, 1000).unwrap_or_else(|e| panic!("{e}"));
    let files = chunk_files(&puma, puma.config, &s, &located, &ranges, 1);
    let safe = part_of(&puma, &puma.safe);
    let mut rows = 0;
    for (f, r) in files.iter().zip(&ranges) {
        let lines: Vec<&str> = f.text.lines().filter(|l| !l.starts_with('#')).collect();
        assert_eq!(lines.len(), r.len() + 2);
        let safe_row = |n| row_reference(n, "safe", "-", 0.0, &safe, false, &puma.safe);
        assert_eq!(lines[0], safe_row(1));
        assert_eq!(lines[lines.len() - 1], safe_row(lines.len()));
        for (k, i) in r.clone().enumerate() {
            let first = i == r.start;
            let dt = if first { 0.0 } else { s[i].dt };
            let want = row_reference(
                k + 2,
                "path",
                &i.to_string(),
                dt,
                &located[i].part(&s[i]),
                !first && s[i].deposit,
                &located[i].q,
            );
            assert_eq!(lines[k + 1], want);
            rows += 1;
        }
    }
    assert_eq!(rows, s.len());
}
