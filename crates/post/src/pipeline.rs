//! The post's two threads: the reading thread turns the input into intended steps and
//! plans what needs no state (the joints of ends under a fixed index, chord points and
//! their checks); the writing thread (`post_steps` in `post.rs`) writes them in
//! order. Batches pass between them over a bounded channel, and come back emptied for
//! reuse. Also the one-pass handling of safe heights (a guess checked at the end, a
//! second pass when it was wrong).

use std::io::Write;

use lampost_kinematics::trig::sin_cos_deg;
use lampost_kinematics::{Affine, Machine};

use crate::error::PostError;
use crate::intended::{Intended, Orient, Section, Step, StepKind};
use crate::post::{
    arc_way, index_maps, joints, linear_scale, post_steps, program_units, written_tip, ArcWay,
    EndCheck, PostConfig, PostReport,
};
use crate::safety::{SafeHeights, WorkBounds};
use crate::verify::ArcPoints;

/// What the reading thread works out ahead for a step under a fixed index: the joints
/// of its end and, for a feed, how far the written end lands from the intended one.
/// The writer uses them when its table position is the same `rot` (it always is for an
/// index; it re-solves otherwise).
#[derive(Debug, Clone, Copy)]
pub(crate) struct PlannedEnd {
    pub(crate) joints: [f64; 3],
    /// The end's check, for feeds.
    pub(crate) check: Option<EndCheck>,
    /// For an arc the index does not keep: its chord points, in the batch's `points`.
    pub(crate) chords: (u32, u32),
}

/// A point written for a step, planned with its check (as [`Writer::verify_point`]
/// would make it: against the end for the last point, against the path before).
pub(crate) type PlannedPoint = ([f64; 3], EndCheck);

/// Steps passed from the reading thread to the writing one, with what was planned for
/// them: `ends[i]` for `steps[i]`, chord points in `points`. Steps stay where the
/// reading thread put them (the writer reads them in place).
pub(crate) struct Batch {
    pub(crate) steps: Vec<Step>,
    pub(crate) ends: Vec<Option<PlannedEnd>>,
    pub(crate) points: Vec<PlannedPoint>,
    /// The error that stopped the reading thread, after `steps`.
    pub(crate) error: Option<PostError>,
}

/// A rotary position, its (sin, cos), joints map and written tip map.
type IndexCache = ([f64; 2], [(f64, f64); 2], Affine, Affine);

/// Plans ends on the reading thread (see [`PlannedEnd`]).
struct Planner<'m> {
    m: &'m Machine,
    sections: &'m [Section],
    head: usize,
    scale: f64,
    tolerance: f64,
    /// The last index and what is derived from it.
    cache: Option<IndexCache>,
}

impl Planner<'_> {
    fn plan(&mut self, step: &Step, points: &mut Vec<PlannedPoint>) -> Option<PlannedEnd> {
        let Orient::Index(rot) = step.orient(self.sections) else {
            return None;
        };
        let (sc, jm, tm) = match self.cache {
            Some((r, sc, jm, tm)) if r == rot => (sc, jm, tm),
            _ => {
                let (jm, tm) = index_maps(self.m, self.head, &rot);
                let sc = [sin_cos_deg(rot[0]), sin_cos_deg(rot[1])];
                self.cache = Some((rot, sc, jm, tm));
                (sc, jm, tm)
            }
        };
        let end_joints = joints(&jm, &step.end);
        let check = (!matches!(
            step.kind,
            StepKind::Rapid | StepKind::Retract | StepKind::Stop(_) | StepKind::ToolChange(_)
        ))
        .then(|| (written_tip(&tm, self.scale, &end_joints) - step.end).norm());
        let first = points.len();
        if let StepKind::Arc {
            center,
            normal,
            sweep,
        } = step.kind
        {
            if let ArcWay::Chords(n) =
                arc_way(self.m, &sc, step, &center, &normal, sweep, self.tolerance)
            {
                // (Always an arc here.)
                let arc = ArcPoints::new(step)?;
                crate::chords::plan(&arc, step, n, &jm, &tm, self.scale, points);
            }
        }
        Some(PlannedEnd {
            joints: end_joints,
            check,
            chords: (
                u32::try_from(first).unwrap_or(u32::MAX),
                u32::try_from(points.len()).unwrap_or(u32::MAX),
            ),
        })
    }
}

/// Steps handed from the reading thread to the writing one at a time.
const BATCH: usize = 1024;

/// An output the post can start again: a first pass that guessed the safe heights
/// wrong is thrown away (see [`post`]).
pub trait Rewind: Write {
    /// Discard everything written so far.
    fn rewind_output(&mut self) -> std::io::Result<()>;
}

impl Rewind for Vec<u8> {
    fn rewind_output(&mut self) -> std::io::Result<()> {
        self.clear();
        Ok(())
    }
}

impl Rewind for std::fs::File {
    fn rewind_output(&mut self) -> std::io::Result<()> {
        use std::io::Seek;
        self.set_len(0)?;
        self.rewind()
    }
}

impl<T: Rewind> Rewind for std::io::BufWriter<T> {
    fn rewind_output(&mut self) -> std::io::Result<()> {
        self.flush()?;
        self.get_mut().rewind_output()
    }
}

impl<T: Rewind + ?Sized> Rewind for &mut T {
    fn rewind_output(&mut self) -> std::io::Result<()> {
        (**self).rewind_output()
    }
}

/// Post `sections` for `machine` to `out`.
///
/// Two threads: one reads, parses and interprets the input into intended steps (the
/// intended-path iterator), the other solves, writes and verifies them, in order; batches
/// of 1,024 steps pass between them over a bounded channel (at most four in flight,
/// so memory stays flat). The output is the same as one thread's, byte for byte: the
/// writing side consumes the steps in input order. An error on either side stops both.
///
/// Safe heights need all of the work before the first retract. The first pass assumes
/// the work known beforehand (a part or stock; the machine's clearance otherwise) and the
/// reading thread gathers every feed tip as it goes; at the end every safe height the
/// pass used (each index and each rotary move) is worked out again over all the work.
/// When they are all the same numbers (the usual case: the clearance is above the
/// work), the program stands as written, exactly as a post that knew the work first
/// would have written it. When any differs, `out` is rewound and a second pass writes the
/// program with the true safe heights.
pub fn post<W: Rewind>(
    machine: &Machine,
    sections: &[Section],
    cfg: &PostConfig,
    mut out: W,
    mut progress: impl FnMut(usize),
) -> Result<PostReport, PostError> {
    let extra = cfg.work.clone().unwrap_or_else(WorkBounds::empty);
    let guess = SafeHeights::new(machine, cfg.head, extra.clone())?;
    let (report, seen, used) = post_pass(machine, sections, cfg, guess, &mut out, &mut progress)?;
    let mut all = seen;
    all.union(&extra);
    let truth = SafeHeights::new(machine, cfg.head, all)?;
    let same = |a: f64, b: f64| a.to_bits() == b.to_bits();
    if used
        .iter()
        .all(|u| same(truth.over_move(&u.from, &u.to), u.over) && same(truth.at(&u.to), u.at))
    {
        return Ok(report);
    }
    out.rewind_output()?;
    let (report, _, _) = post_pass(machine, sections, cfg, truth, &mut out, &mut progress)?;
    Ok(report)
}

/// One pass of [`post`] with the given safe heights: the report, every feed tip the
/// reading thread saw, and the safe heights the writer used.
fn post_pass<W: Write>(
    machine: &Machine,
    sections: &[Section],
    cfg: &PostConfig,
    heights: SafeHeights<'_>,
    out: W,
    progress: impl FnMut(usize),
) -> Result<(PostReport, WorkBounds, Vec<HeightUsed>), PostError> {
    let opts = cfg.intended;
    let mut planner = Planner {
        m: machine,
        sections,
        head: cfg.head,
        scale: linear_scale(program_units(machine)),
        tolerance: crate::post::chord_tolerance(machine, cfg),
        cache: None,
    };
    std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Batch>(4);
        // Emptied batches come back: their memory is reused, not freed on one core
        // and allocated again on the other.
        let (back_tx, back_rx) = std::sync::mpsc::sync_channel::<Batch>(8);
        let reader = std::thread::Builder::new()
            .name("lampost-read".into())
            .spawn_scoped(scope, move || {
                let mut seen = WorkBounds::empty();
                let fresh = || {
                    back_rx.try_recv().unwrap_or_else(|_| Batch {
                        steps: Vec::with_capacity(BATCH),
                        ends: Vec::with_capacity(BATCH),
                        points: Vec::new(),
                        error: None,
                    })
                };
                let mut batch = fresh();
                let mut intended =
                    Intended::new(machine, sections, opts).holding_spindle(&cfg.process);
                loop {
                    match intended.next_step() {
                        Ok(Some(s)) => {
                            seen.add_step(&s);
                            batch.ends.push(planner.plan(&s, &mut batch.points));
                            batch.steps.push(s);
                        }
                        Ok(None) => break,
                        Err(e) => batch.error = Some(e),
                    }
                    let failed = batch.error.is_some();
                    if batch.steps.len() == BATCH || failed {
                        let full = std::mem::replace(&mut batch, fresh());
                        // A closed channel: the writer stopped (an error); so do we.
                        if tx.send(full).is_err() || failed {
                            return (seen, intended.take_notes());
                        }
                    }
                }
                if !batch.steps.is_empty() {
                    let _ = tx.send(batch);
                }
                (seen, intended.take_notes())
            })
            .map_err(|e| PostError::Io(format!("cannot start the reading thread: {e}")))?;
        let result = post_steps(
            machine,
            sections,
            cfg,
            heights,
            out,
            progress,
            rx.into_iter(),
            |b| {
                // A full return channel or a finished reader: the batch is just freed.
                let _ = back_tx.try_send(b);
            },
        );
        // `post_steps` has dropped the receiver, so the reader cannot block on a send.
        let (seen, notes) = match reader.join() {
            Ok(r) => r,
            Err(panic) => std::panic::resume_unwind(panic),
        };
        result.map(|(mut report, used)| {
            report.warnings.extend(notes);
            (report, seen, used)
        })
    })
}

/// A safe height the writer used: the rotary move `from` → `to` at `over`, then `at` at
/// `to`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct HeightUsed {
    pub(crate) from: [f64; 2],
    pub(crate) to: [f64; 2],
    pub(crate) over: f64,
    pub(crate) at: f64,
}

#[cfg(test)]
mod tests {
    /// The speculative first pass of `post` gives exactly what a post that read the work
    /// first gives, whether its guess of the safe heights holds (clearance above the work)
    /// or not (the part tilted and raised: a second pass), on both heads and with a stock.
    #[test]
    fn post_equals_a_post_that_knew_the_work_first() {
        use super::*;
        use crate::frame::Frame;
        use crate::intended::IntendedOptions;
        use crate::intended::Source;
        use crate::post::{PostDialect, Process};
        use nalgebra::Vector3;
        let m = Machine::builtin("fadal-lamp", &[]).expect("machine");
        let program = "G20 G90\nG0 X0 Y0 Z0.2\nG1 Z0 F20.\nG1 X1.\nG1 Y0.5\nG2 X0.5 Y1. I-0.5 J0\nG1 X0\nG0 Z0.2\nG0 X2 Y2\nG1 Z0\nG1 X3\nG0 Z0.2\nM30\n";
        let mut reruns = 0;
        for (rot, z, head, stock) in [
            ([0.0, 0.0], 0.0, "spindle", None),
            ([0.0, 0.0], 9.9, "spindle", None),
            ([0.0, -20.0], 1.0, "laser", None),
            ([30.0, 45.0], 0.5, "spindle", None),
            ([0.0, 0.0], 0.0, "spindle", Some(9.95)),
            ([90.0, -30.0], 0.2, "laser", Some(1.0)),
        ] {
            let secs = vec![Section {
                name: "t.nc".into(),
                source: Source::Bytes(program.as_bytes().to_vec()),
                frame: Frame::translation(Vector3::new(0.0, 0.0, z)),
                orient: Orient::Index(rot),
                layers: None,
            }];
            let mut extra = WorkBounds::empty();
            if let Some(top) = stock {
                extra.add_points([Vector3::new(-1.0, -1.0, -1.0), Vector3::new(4.0, 4.0, top)]);
            }
            let cfg = PostConfig {
                head: m.head(head).expect("head"),
                process: Process::Deposit { power: 500.0 },
                dialect: PostDialect::Fadal,
                renumber: None,
                tolerance: 0.0005,
                intended: IntendedOptions {
                    convert_units: false,
                    e_extrusion: false,
                    flavor: lampost_gcode::Flavor::Fadal,
                    units: None,
                },
                near: [0.0, 0.0],
                program_number: 1000,
                header: vec!["t".into()],
                verify_tolerance: 0.001,
                work: stock.map(|_| extra.clone()),
                part: None,
                max_output_bytes: None,
            };
            let mut spec = Vec::new();
            let r = post(&m, &secs, &cfg, &mut spec, |_| {}).expect("posts");
            let mut all =
                WorkBounds::of_program(&m, &secs, cfg.intended, &cfg.process).expect("bounds");
            all.union(&extra);
            let truth = SafeHeights::new(&m, cfg.head, all).expect("heights");
            let guess = SafeHeights::new(&m, cfg.head, extra.clone()).expect("heights");
            if truth.at(&rot).to_bits() != guess.at(&rot).to_bits() {
                reruns += 1;
            }
            let mut known = Vec::new();
            let (k, _, _) = post_pass(&m, &secs, &cfg, truth, &mut known, |_| {}).expect("posts");
            assert_eq!(
                String::from_utf8_lossy(&spec),
                String::from_utf8_lossy(&known),
                "{rot:?} {head}"
            );
            assert_eq!(r, k);
        }
        assert!(reruns >= 2, "the second pass was not exercised ({reruns})");
    }
}
