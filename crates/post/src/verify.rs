//! Verification: replay a posted program through the interpreter and forward kinematics
//! and compare every feed point's tool tip and tool axis with the intended path.

use std::cell::Cell;
use std::f64::consts::FRAC_PI_4;
use std::io::BufRead;
use std::rc::Rc;

use lampost_gcode::{
    Diagnostic, ErrorKind, Event, Line, LineReader, LineSource, Modal, Move, MoveKind, Options,
    Origin, Plane, Severity, StopKind, Stream, Units, WorkOffset, AXES,
};
use lampost_kinematics::{Joints, Machine, Units as MUnits};
use nalgebra::Vector3;

use crate::error::PostError;
use crate::intended::{Intended, IntendedOptions, Orient, Section, Step, StepKind};
use crate::post::Process;
use crate::safety::WorkBounds;

/// The work offset every move of a program posted for `process` is read in (the
/// reader's G54 where none is posted: then none may be selected, [`Screen`]), and the
/// text it was given as (`None`: none posted). Refused as the post refuses it.
fn posted_work_offset(process: &Process) -> Result<(WorkOffset, Option<String>), PostError> {
    let text = match process {
        Process::Machine {
            work_offset: Some(w),
            ..
        } => w,
        _ => return Ok((Modal::new(Units::Mm).work_offset, None)),
    };
    let w = match crate::writer::work_offset_words(text)?.as_slice() {
        [(b'E', e)] => WorkOffset::Fixture(*e as u8),
        [(b'G', _), (b'P', p)] => WorkOffset::Extended(*p as u16),
        [(b'G', g)] => WorkOffset::of_code((g * 10.0).round() as u16)
            .ok_or_else(|| PostError::Options(format!("--work-offset `{text}`")))?,
        _ => return Err(PostError::Options(format!("--work-offset `{text}`"))),
    };
    Ok((w, Some(text.clone())))
}

/// What a verification found.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct VerifyReport {
    /// Moves in the posted program.
    pub moves: usize,
    /// Feed points compared (ends and arc midpoints).
    pub compared: usize,
    /// Largest distance from a posted tool tip to the intended path.
    pub max_position_error: f64,
    /// Largest angle between a posted tool axis and the intended one (degrees).
    pub max_axis_error_deg: f64,
    /// Posted line with the largest position error.
    pub worst_line: u32,
}

pub(crate) fn dist_to(step: &Step, p: &Vector3<f64>) -> f64 {
    match step.kind {
        StepKind::Arc {
            center,
            normal,
            sweep,
        } => {
            let n = normal; // unit by construction
            let rel = step.start - center;
            let rel = rel - n * n.dot(&rel);
            let q = p - center;
            let qp = q - n * n.dot(&q);
            if rel.norm() < 1e-12 || qp.norm() < 1e-12 {
                return (p - step.start).norm().min((p - step.end).norm());
            }
            // Angle of p from the start, right-handed about n, into the sweep's range.
            let mut ang = lampost_kinematics::trig::atan2_deg(n.dot(&rel.cross(&qp)), rel.dot(&qp))
                .to_radians();
            let tau = std::f64::consts::TAU;
            if sweep < 0.0 && ang > 0.0 {
                ang -= tau;
            } else if sweep > 0.0 && ang < 0.0 {
                ang += tau;
            }
            let t_raw = ang / sweep;
            let rise = (step.end - step.start).dot(&n);
            if rise.abs() <= 1e-12 * (1.0 + rel.norm()) && t_raw > 0.0 && t_raw < 1.0 {
                // A flat arc, p beside its interior: the nearest point of the arc is the
                // nearest of its circle, at p's angle.
                let radial = qp.norm() - rel.norm();
                let off_plane = n.dot(&q);
                return (radial * radial + off_plane * off_plane).sqrt();
            }
            let t = t_raw.clamp(0.0, 1.0);
            // Near the ends of multi-turn or near-full arcs, try the neighbours too.
            let near = [t, 0.0, 1.0]
                .iter()
                .map(|&t| (p - step.at(t)).norm())
                .fold(f64::INFINITY, f64::min);
            // A helix: also the point at p's height along the normal. On a short, steep
            // helix a point beside the path by the output's rounding can lie at an angle
            // just outside the sweep, which names an end, while its height names the
            // middle. (Every candidate is a point of the path: the distance is never
            // understated.)
            let near = if rise.abs() > 1e-12 * (1.0 + rel.norm()) {
                let t_n = (n.dot(&(p - step.start)) / rise).clamp(0.0, 1.0);
                near.min((p - step.at(t_n)).norm())
            } else {
                near
            };
            // A helix of more than one turn passes p's angle once a turn: the passes at
            // and beside p's height (the nearest of them is there; every turn's pass is
            // a point of the path, so fewer of them never understate the distance).
            // A constant number per point, however many turns: chord points of a long
            // helix are checked in linear time.
            let turns = (sweep.abs() / tau).ceil();
            if turns < 2.0 {
                return near;
            }
            let k_mid = if rise.abs() > 1e-12 * (1.0 + rel.norm()) {
                let t_h = n.dot(&(p - step.start)) / rise;
                ((t_h * sweep - ang) / (tau * sweep.signum())).round()
            } else {
                // A flat arc of many turns: every turn is the same circle.
                1.0
            };
            let mut best = near;
            for dk in [-1.0, 0.0, 1.0] {
                let k = k_mid + dk;
                if k >= 1.0 && k < turns {
                    let t = ((ang + k * tau * sweep.signum()) / sweep).clamp(0.0, 1.0);
                    best = best.min((p - step.at(t)).norm());
                }
            }
            best
        }
        _ => {
            let d = step.end - step.start;
            let len2 = d.norm_squared();
            let t = if len2 > 0.0 {
                ((p - step.start).dot(&d) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p - (step.start + d * t)).norm()
        }
    }
}

/// One arc's points and distances for many points along it (the chord points of a
/// linearised arc): [`Step::at`] and [`dist_to`] with what depends only on the arc
/// worked out once. Results are bit-identical to theirs (the same operations on the same
/// values; tested).
pub(crate) struct ArcPoints {
    pub(crate) center: Vector3<f64>,
    pub(crate) n: Vector3<f64>,
    pub(crate) sweep: f64,
    /// start − centre, n × it, n · it, and the helix's rise (as [`Step::at`] has them).
    pub(crate) rel: Vector3<f64>,
    pub(crate) n_cross_rel: Vector3<f64>,
    pub(crate) n_dot_rel: f64,
    pub(crate) rise: f64,
    /// |start − centre| normal to n, when the arc is flat, within one turn and not
    /// degenerate (where [`dist_to`] has a closed form inside the sweep).
    pub(crate) flat_radius: Option<f64>,
}

impl ArcPoints {
    /// `None` unless `step` is an arc.
    pub(crate) fn new(step: &Step) -> Option<ArcPoints> {
        let StepKind::Arc {
            center,
            normal: n,
            sweep,
        } = step.kind
        else {
            return None;
        };
        let rel = step.start - center;
        let rise = (step.end - step.start).dot(&n);
        let rel_plane = rel - n * n.dot(&rel);
        let r = rel_plane.norm();
        let flat = rise.abs() <= 1e-12 * (1.0 + r) && r >= 1e-12;
        Some(ArcPoints {
            center,
            n,
            sweep,
            rel,
            n_cross_rel: n.cross(&rel),
            n_dot_rel: n.dot(&rel),
            rise,
            flat_radius: (flat && sweep.abs() <= std::f64::consts::TAU).then_some(r),
        })
    }

    /// [`Step::at`].
    #[inline]
    pub(crate) fn at(&self, t: f64) -> Vector3<f64> {
        let (s, c) = lampost_kinematics::trig::sin_cos_deg((self.sweep * t).to_degrees());
        let rotated = self.rel * c + self.n_cross_rel * s + self.n * (self.n_dot_rel * (1.0 - c));
        self.center + rotated + self.n * (self.rise * t)
    }

    /// [`dist_to`] for `p`, given that `p` lies near `at(t)` (`near`). When `p` is
    /// provably inside the sweep (its angle from `near` is under half the angle from
    /// `near` to either end: `|p − near| < (m/π)·|p's radius|`, m that angle capped at
    /// 90°, bounds the sine of that angle), a flat arc's distance is the closed form
    /// [`dist_to`] takes there, with no arctangent; otherwise [`dist_to`] itself.
    #[inline]
    pub(crate) fn dist_near(
        &self,
        step: &Step,
        p: &Vector3<f64>,
        near: &Vector3<f64>,
        t: f64,
    ) -> f64 {
        if let Some(r) = self.flat_radius {
            let n = self.n;
            let q = p - self.center;
            let qp = q - n * n.dot(&q);
            let qn = qp.norm();
            let m = (t.min(1.0 - t) * self.sweep.abs()).min(std::f64::consts::FRAC_PI_2);
            let s = m * std::f64::consts::FRAC_1_PI;
            if qn >= 1e-12 && t > 0.0 && t < 1.0 && (p - near).norm_squared() < s * s * qn * qn {
                let radial = qn - r;
                let off_plane = n.dot(&q);
                return (radial * radial + off_plane * off_plane).sqrt();
            }
        }
        dist_to(step, p)
    }
}

/// Replay `posted` and compare it with the intended path of `sections`.
#[allow(clippy::too_many_arguments)]
pub fn verify<R: BufRead>(
    machine: &Machine,
    sections: &[Section],
    head: usize,
    process: &Process,
    opts: IntendedOptions,
    posted: R,
    tolerance: f64,
    work: Option<&WorkBounds>,
    part: Option<&crate::collide::PartMesh>,
) -> Result<VerifyReport, PostError> {
    verify_traced(
        machine,
        sections,
        head,
        process,
        opts,
        posted,
        tolerance,
        work,
        part,
        &mut |_, _| {},
    )
}

/// The fractions of `step` whose points can be the tool at `p` (within `tolerance`
/// along the move), for a straight feed or a flat arc of less than a turn less 0.1 rad
/// (a circle's start and end are one point); `None` for other moves, not followed.
fn progress(step: &Step, p: &Vector3<f64>, tolerance: f64) -> Option<(f64, f64)> {
    let (t, len) = match step.kind {
        StepKind::Feed => {
            let d = step.end - step.start;
            let len2 = d.norm_squared();
            ((p - step.start).dot(&d) / len2, len2.sqrt())
        }
        StepKind::Arc {
            center,
            normal,
            sweep,
        } if sweep.abs() < std::f64::consts::TAU - 0.1
            && (step.end - step.start).dot(&normal).abs() <= tolerance =>
        {
            let rel = step.start - center;
            let q = p - center;
            let q = q - normal * normal.dot(&q);
            let ang = normal.dot(&rel.cross(&q)).atan2(rel.dot(&q));
            // From the start in the sweep's sense, the way round past the end counted
            // back from the start (a point just before the start is at a small negative).
            let tau = std::f64::consts::TAU;
            let mut a = ang * sweep.signum();
            if a < -(tau - sweep.abs()) / 2.0 {
                a += tau;
            }
            (a / sweep.abs(), rel.norm() * sweep.abs())
        }
        _ => return None,
    };
    let band = tolerance / len;
    (t.is_finite() && band.is_finite()).then_some((t - band, t + band))
}

/// Whether a posted feed `f` is the intended `want`: the post writes the input's feed
/// (scaled to the machine's units) with 5 decimals.
fn same_feed(f: f64, want: f64) -> bool {
    (f - want).abs() <= 0.5e-5 + 1e-12 * want.abs()
}

/// Every cut of a machining program made with the input's tool, as the input's own
/// modal state has it at that move (not as the tool changes were found): a program's
/// first tool may be posted under another number (`--tool`) until a tool change is
/// posted; every other is posted as itself. Used by `verify` and by the post on what it
/// writes.
#[derive(Debug)]
pub(crate) struct CutTools {
    machining: bool,
    /// The input's first tool (0: none seen yet).
    first: u32,
    /// A tool change has been posted.
    pub(crate) changed: bool,
}

impl CutTools {
    pub(crate) fn new(process: &Process) -> CutTools {
        CutTools {
            machining: matches!(process, Process::Machine { .. }),
            first: 0,
            changed: false,
        }
    }

    /// Whether the cut `step`, written with tool `posted` in the spindle, is made with
    /// the input's tool.
    #[inline]
    pub(crate) fn hold(&mut self, step: &Step, posted: u32) -> bool {
        if !self.machining || step.tool == 0 {
            return true;
        }
        if self.first == 0 {
            self.first = step.tool;
        }
        step.tool == posted || (step.tool == self.first && !self.changed)
    }

    /// What [`CutTools::hold`] found wrong, for a message.
    #[cold]
    pub(crate) fn missing(step: &Step, posted: u32) -> String {
        format!(
            "the cut of input line {} is made with T{} in the input and with T{posted} in the posted program: its tool change is missing",
            step.line, step.tool
        )
    }
}

/// What an intended step is, for a message: its stop code, its change of tool, or a move.
#[cold]
fn step_name(kind: &StepKind) -> String {
    match kind {
        StepKind::Stop(k) => k.code().to_string(),
        StepKind::ToolChange(c) => format!("change to T{}", c.tool),
        _ => "move".to_string(),
    }
}

/// The stop the post writes for an input's stop `k`: `M60` as `M0` (no pallet is
/// changed), the others as they are.
fn posted_as(k: StopKind) -> StopKind {
    match k {
        StopKind::Pallet => StopKind::Program,
        k => k,
    }
}

/// [`verify`], telling `on_point` the posted line and deviation of every feed point it
/// compares (for a picture of the deviations: `verify --preview`).
#[allow(clippy::too_many_arguments)]
pub fn verify_traced<R: BufRead>(
    machine: &Machine,
    sections: &[Section],
    head: usize,
    process: &Process,
    opts: IntendedOptions,
    posted: R,
    tolerance: f64,
    work: Option<&WorkBounds>,
    part: Option<&crate::collide::PartMesh>,
    on_point: &mut dyn FnMut(u32, f64),
) -> Result<VerifyReport, PostError> {
    check_tolerance(tolerance)?;
    // The work the rapids must clear: the input's feed tips (a pass of its own) and the
    // part or stock given.
    let mut bounds = WorkBounds::of_program(machine, sections, opts, process)?;
    if let Some(w) = work {
        bounds.union(w);
    }
    let mut safety = Safety::new(machine, head, bounds);
    safety.part = part;
    let units = match machine.units {
        MUnits::Inch => Units::Inch,
        MUnits::Mm => Units::Mm,
    };
    let idx = |name: &str| {
        name.bytes()
            .next()
            .and_then(|c| AXES.iter().position(|&a| a == c.to_ascii_uppercase()))
    };
    let names = machine.axis_names();
    let lin_idx: Vec<usize> = names[..3].iter().map(|n| idx(n).unwrap_or(0)).collect();
    let rot_idx: Vec<usize> = names[3..].iter().map(|n| idx(n).unwrap_or(3)).collect();
    // Shared by `check` and the stops' arm below (a step taken is taken for both).
    let steps = Intended::new(machine, sections, opts).holding_spindle(process);
    let intended = std::cell::RefCell::new(steps.filter(|s| {
        !matches!(
            s,
            Ok(Step {
                kind: StepKind::Rapid | StepKind::Retract,
                ..
            })
        )
    }));
    let next_intended = || intended.borrow_mut().next().transpose();
    // The tool the posted moves are made with, and each cut's held to the input's (see
    // `check`).
    let rules_tool = Cell::new(0u32);
    let cut_tools = std::cell::RefCell::new(CutTools::new(process));
    let mut current: Option<Step> = None;
    // The move that ended at the last point (its end within the tolerance), while no
    // point has yet come onto the next one; and the next move, given back when a point
    // turned out to belong to the one that ended (see `check`).
    let mut ended: Option<Step> = None;
    let held: Cell<Option<Step>> = Cell::new(None);
    // The angle the current move (an arc) has swept so far, along its sweep.
    let mut swept = 0.0f64;
    // The least fraction of the current move the tool can have come to (see `progress`).
    let mut reach = 0.0f64;
    let mut rep = VerifyReport::default();
    let intended_axis = |s: &Step| match s.orient(sections) {
        Orient::ToolAxis => s.program_z(sections).normalize(),
        Orient::Index(r) => {
            machine
                .forward(
                    &Joints {
                        linear: [0.0; 3],
                        rotary: r,
                    },
                    head,
                )
                .axis
        }
    };
    // Forward kinematics with the rotaries' sin/cos kept between points (they change per
    // section or layer, not per point).
    let cache = std::cell::Cell::new(([f64::NAN; 2], [(0.0, 1.0); 2]));
    let tool = machine.tool_axis;
    let fk = |j: &[f64; 9]| {
        let rot = [j[rot_idx[0]], j[rot_idx[1]]];
        let (r, sc) = cache.get();
        let sc = if r == rot {
            sc
        } else {
            let sc = [
                lampost_kinematics::trig::sin_cos_deg(rot[0]),
                lampost_kinematics::trig::sin_cos_deg(rot[1]),
            ];
            cache.set((rot, sc));
            sc
        };
        let q = machine.head_point(&[j[lin_idx[0]], j[lin_idx[1]], j[lin_idx[2]]], head);
        let inv = [(-sc[0].0, sc[0].1), (-sc[1].0, sc[1].1)];
        let origin = machine.machine_to_part_sc(&inv, &Vector3::zeros());
        lampost_kinematics::Pose {
            tip: machine.machine_to_part_sc(&inv, &q),
            axis: machine.machine_to_part_sc(&inv, &tool) - origin,
        }
    };
    let mut check = |p: Vector3<f64>,
                     a: Vector3<f64>,
                     feed: f64,
                     line: u32,
                     is_end: bool,
                     entering: bool,
                     current: &mut Option<Step>,
                     rep: &mut VerifyReport|
     -> Result<(u32, bool), PostError> {
        if entering {
            // The first feed after travel comes onto the start of the next move.
            if let Some(s) = current {
                return Err(PostError::Verify(format!(
                    "posted line {line}: travel interrupts the move of input line {}",
                    s.line
                )));
            }
        }
        let fresh = current.is_none();
        if fresh {
            *current = match held.take() {
                Some(s) => Some(s),
                None => next_intended()?,
            };
            swept = 0.0;
            reach = 0.0;
            if let Some(Step {
                kind: kind @ (StepKind::Stop(_) | StepKind::ToolChange(_)),
                line: input,
                ..
            }) = *current
            {
                // A point of the move that ended, after its end (a move shorter than the
                // tolerance, written as chords): checked against it below, and the stop
                // (tool change) given back for the posted one. Any other point goes on
                // past it.
                let of_ended = ended.is_some_and(|e| !entering && (p - e.end).norm() <= tolerance);
                if !of_ended {
                    return Err(PostError::Verify(match kind {
                        StepKind::ToolChange(c) => format!(
                            "posted line {line}: the input changes to T{} here (before input line {input}), and the posted program goes on with T{}",
                            c.tool,
                            rules_tool.get()
                        ),
                        StepKind::Stop(k) => format!(
                            "posted line {line}: the input stops here ({} at input line {input}), and the posted program goes on without stopping",
                            k.code()
                        ),
                        other => format!(
                            "posted line {line}: the posted program goes on past input line {input}'s {other:?}"
                        ),
                    }));
                }
            }
        }
        let Some(step) = *current else {
            return Err(PostError::Verify(format!("posted line {line} feeds to ({:.5}, {:.5}, {:.5}) after the intended path has ended", p.x, p.y, p.z)));
        };
        // An arc of more than one turn passes its end once a turn: a point there ends the
        // move only on its last turn. The angle swept so far is followed from point to
        // point (chords of such an arc turn by at most half a turn each).
        let mut last_turn = true;
        if let StepKind::Arc {
            center,
            normal,
            sweep,
        } = step.kind
        {
            if sweep.abs() > std::f64::consts::TAU + 1e-9 {
                let tau = std::f64::consts::TAU;
                let rel = step.start - center;
                let q = p - center;
                let ang = normal
                    .dot(&rel.cross(&q))
                    .atan2(rel.dot(&q) - normal.dot(&rel) * normal.dot(&q));
                let done = swept.rem_euclid(tau);
                let mut d = (sweep.signum() * ang - done).rem_euclid(tau);
                if d > std::f64::consts::PI + 1e-6 {
                    d -= tau;
                }
                swept += d;
                last_turn = swept >= sweep.abs() - std::f64::consts::PI;
            }
        }
        let d_end = (p - step.end).norm();
        if entering && (p - step.start).norm() > tolerance {
            return Err(PostError::Verify(format!(
                "posted line {line}: the feed after travel ends at ({:.5}, {:.5}, {:.5}), not on the start of input line {}'s move",
                p.x, p.y, p.z, step.line
            )));
        }
        let stop = matches!(step.kind, StepKind::Stop(_) | StepKind::ToolChange(_));
        let (err, step) = if is_end && !entering && d_end <= tolerance && last_turn && !stop {
            *current = None;
            ended = Some(step);
            (d_end, step)
        } else {
            let d = dist_to(&step, &p);
            // A point of a move shorter than the tolerance (an arc smaller than it,
            // written as chords, every one within the tolerance of its end), after the
            // point that ended it: it stays within the tolerance of that end, where the
            // tool already is. Checked against that move; the next is given back.
            let back = ended.filter(|e| {
                fresh && !entering && (d > tolerance || stop) && (p - e.end).norm() <= tolerance
            });
            if let Some(e) = back {
                held.set(current.take());
                ((p - e.end).norm(), e)
            } else if d > tolerance {
                on_point(line, d);
                return Err(PostError::Verify(format!(
                    "posted line {line}: the tool tip ({:.5}, {:.5}, {:.5}) is {d:.3e} from the intended path of input line {} (tolerance {tolerance:.1e})",
                    p.x, p.y, p.z, step.line
                )));
            } else {
                ended = None;
                // Forward along the move: the fractions within the tolerance of p lie
                // wholly before where the tool had come to, it went back.
                if let Some((lo, hi)) = progress(&step, &p, tolerance) {
                    if hi < reach {
                        return Err(PostError::Verify(format!(
                            "posted line {line}: the tool goes back along the intended move of input line {} (to {:.4} of the way, from {:.4} or more)",
                            step.line, hi, reach
                        )));
                    }
                    reach = reach.max(lo);
                }
                (d, step)
            }
        };
        on_point(line, err);
        if !cut_tools.borrow_mut().hold(&step, rules_tool.get()) {
            return Err(PostError::Verify(format!(
                "posted line {line}: {}",
                CutTools::missing(&step, rules_tool.get())
            )));
        }
        if !same_feed(feed, step.feed) {
            return Err(PostError::Verify(format!(
                "posted line {line}: feed F{} along the move of input line {}, which asks F{} (the post writes the input's feed, in the machine's units)",
                lampost_gcode::Readable(feed),
                step.line,
                lampost_gcode::Readable(step.feed)
            )));
        }
        let want = intended_axis(&step);
        let ang = a.cross(&want).norm().atan2(a.dot(&want)).to_degrees();
        rep.compared += 1;
        if err > rep.max_position_error {
            rep.max_position_error = err;
            rep.worst_line = line;
        }
        rep.max_axis_error_deg = rep.max_axis_error_deg.max(ang);
        if ang > AXIS_TOLERANCE_DEG {
            return Err(PostError::Verify(format!(
                "posted line {line}: the tool axis is {ang:.4}° from the intended one of input line {} (tolerance {AXIS_TOLERANCE_DEG}°)",
                step.line
            )));
        }
        // The approach onto a move's start deposits nothing: the laser goes on after it.
        Ok((step.line, step.deposit && !entering))
    };
    let screen = Screen::new(machine, process)?;
    let mut stream = screen.stream(posted, units);
    let mut rules = PostedRules::new(machine.units, false, process)?;
    rules_tool.set(rules.tool);
    // The last move was travel (the next feed must come onto a start).
    let mut after_travel = true;
    for ev in stream.by_ref() {
        let ev = ev.map_err(|e| PostError::Io(e.to_string()))?;
        screen.check()?;
        match ev {
            Event::Diagnostic(d) => {
                if let Some(e) = posted_diagnostic(d) {
                    return Err(e);
                }
            }
            Event::Stop(stop) => {
                // A stop of the input's, where the input makes it: between moves, the
                // next thing along the intended path.
                let fail = |what: String| {
                    Err(PostError::Verify(format!(
                        "posted line {}: a program stop ({}) {what}",
                        stop.line,
                        stop.kind.code()
                    )))
                };
                if let Some(s) = current {
                    return fail(format!("within the move of input line {}", s.line));
                }
                let next = match held.take() {
                    Some(s) => Some(s),
                    None => next_intended()?,
                };
                match next {
                    Some(Step {
                        kind: StepKind::Stop(k),
                        ..
                    }) if posted_as(k) == stop.kind => {}
                    Some(s) => {
                        return fail(format!(
                            "where the input makes {} (the next on the intended path is input line {}'s {})",
                            if matches!(s.kind, StepKind::Stop(_)) {
                                "another"
                            } else {
                                "none"
                            },
                            s.line,
                            step_name(&s.kind)
                        ))
                    }
                    None => return fail("after the intended path has ended".into()),
                }
            }
            Event::Move(m) => {
                rep.moves += 1;
                rotaries_commanded(&m, &rot_idx, lin_idx[2])?;
                if let (true, Some(s)) = (m.modal.tool != rules.tool, current) {
                    return Err(PostError::Verify(format!(
                        "posted line {}: a tool change (to T{}) within the move of input line {}",
                        m.line, m.modal.tool, s.line
                    )));
                }
                if m.modal.tool != rules.tool {
                    // A tool change posted: the input's, where the input makes it (between
                    // moves, the next thing along the intended path); the moves after it
                    // are held to the new tool's length offset and speed.
                    let next = match held.take() {
                        Some(s) => Some(s),
                        None => next_intended()?,
                    };
                    match next {
                        Some(Step {
                            kind: StepKind::ToolChange(c),
                            ..
                        }) if c.tool == m.modal.tool => {
                            rules.tool_changed(&c);
                            rules_tool.set(c.tool);
                            cut_tools.borrow_mut().changed = true;
                        }
                        // The first move's tool is the one posted with (`--tool`): a
                        // wrong one fails on its tool below.
                        other if rep.moves == 1 => held.set(other),
                        Some(s) => {
                            return Err(PostError::Verify(format!(
                                "posted line {}: a tool change (to T{}) where the input makes none (the next on the intended path is input line {}'s {})",
                                m.line,
                                m.modal.tool,
                                s.line,
                                step_name(&s.kind)
                            )))
                        }
                        None => {
                            return Err(PostError::Verify(format!(
                                "posted line {}: a tool change (to T{}) after the intended path has ended",
                                m.line, m.modal.tool
                            )))
                        }
                    }
                }
                rules.check(&m, &rot_idx)?;
                let j = |p: &[f64; 9]| {
                    (
                        [p[lin_idx[0]], p[lin_idx[1]], p[lin_idx[2]]],
                        [p[rot_idx[0]], p[rot_idx[1]]],
                    )
                };
                let (ls, rs) = j(&m.start);
                let (le, re) = j(&m.end);
                safety.travel(&le, &re, m.line)?;
                match m.kind {
                    MoveKind::Rapid => safety.rapid(&ls, &rs, &le, &re, m.line)?,
                    MoveKind::Arc {
                        clockwise, center, ..
                    } => {
                        safety.feed(&ls, &le, m.line)?;
                        let c = [center[lin_idx[0]], center[lin_idx[1]]];
                        safety.arc_travel(&ls, &le, &c, clockwise, &re, m.line)?;
                    }
                    _ => safety.feed(&ls, &le, m.line)?,
                }
                let entering = after_travel;
                after_travel = matches!(m.kind, MoveKind::Rapid);
                // The intended move the move's end lies on (its input line, and whether
                // it deposits).
                let mut along = None;
                match m.kind {
                    MoveKind::Rapid => {}
                    MoveKind::Linear | MoveKind::Probe => {
                        if !entering {
                            // The segment's middle too (a chord left out would bulge).
                            let mut mid = m.end;
                            for (v, s) in mid.iter_mut().zip(m.start) {
                                *v = 0.5 * (s + *v);
                            }
                            let pm = fk(&mid);
                            check(
                                pm.tip,
                                pm.axis,
                                m.feed,
                                m.line,
                                false,
                                false,
                                &mut current,
                                &mut rep,
                            )?;
                        }
                        let pose = fk(&m.end);
                        along = Some(check(
                            pose.tip,
                            pose.axis,
                            m.feed,
                            m.line,
                            true,
                            entering,
                            &mut current,
                            &mut rep,
                        )?);
                    }
                    MoveKind::Arc {
                        clockwise,
                        center,
                        turns,
                        ..
                    } => {
                        // The midpoint in joint space (XY plane), then the end.
                        let (sx, sy) = (m.start[0] - center[0], m.start[1] - center[1]);
                        let (ex, ey) = (m.end[0] - center[0], m.end[1] - center[1]);
                        let tau = std::f64::consts::TAU;
                        let delta = ey.atan2(ex) - sy.atan2(sx);
                        let full = (sx - ex).hypot(sy - ey) < 1e-9;
                        let sweep = if clockwise {
                            (if full {
                                -tau
                            } else {
                                delta.rem_euclid(tau) - tau
                            }) - tau * f64::from(turns.saturating_sub(1))
                        } else {
                            (if full { tau } else { delta.rem_euclid(tau) })
                                + tau * f64::from(turns.saturating_sub(1))
                        };
                        let a = sy.atan2(sx) + sweep / 2.0;
                        let r = sx.hypot(sy);
                        let mut mid = m.end;
                        mid[0] = center[0] + r * a.cos();
                        mid[1] = center[1] + r * a.sin();
                        mid[2] = (m.start[2] + m.end[2]) / 2.0;
                        let pm = fk(&mid);
                        check(
                            pm.tip,
                            pm.axis,
                            m.feed,
                            m.line,
                            false,
                            entering,
                            &mut current,
                            &mut rep,
                        )?;
                        // The way round: a point an eighth of a turn (at most) from the
                        // start, against the intended arc's sense (a full circle run
                        // the other way has its points on the path too).
                        let a = sy.atan2(sx) + sweep.signum() * (sweep.abs() / 4.0).min(FRAC_PI_4);
                        let mut near_start = m.start;
                        near_start[0] = center[0] + r * a.cos();
                        near_start[1] = center[1] + r * a.sin();
                        arc_sense(
                            current.as_ref(),
                            &fk(&m.start).tip,
                            &fk(&near_start).tip,
                            tolerance,
                            m.line,
                        )?;
                        let pe = fk(&m.end);
                        along = Some(check(
                            pe.tip,
                            pe.axis,
                            m.feed,
                            m.line,
                            true,
                            false,
                            &mut current,
                            &mut rep,
                        )?);
                    }
                }
                process_state(&m, screen.switches(), process, along)?;
            }
        }
    }
    let rest = match current.or(held.take()) {
        Some(s) => Some(s),
        None => next_intended()?,
    };
    if let Some(s) = rest {
        return Err(PostError::Verify(match s.kind {
            StepKind::Stop(k) => format!(
                "the posted program ends before the stop of input line {} ({})",
                s.line,
                k.code()
            ),
            StepKind::ToolChange(c) => format!(
                "the posted program ends before the change to T{} (before input line {})",
                c.tool, s.line
            ),
            _ => format!(
                "the posted program ends before the move of input line {} (to ({:.5}, {:.5}, {:.5}))",
                s.line, s.end.x, s.end.y, s.end.z
            ),
        }));
    }
    screen.finish()?;
    safety.finish(stream.interpreter().ended())?;
    Ok(rep)
}

/// A diagnostic of the posted program fails the verification: an error, and any
/// warning, since the post writes nothing lampost's reader warns about, and a warned
/// code (`G68` rotation, `G51` scaling, `G16` polar words, `G43.4`, a macro, an `M99`
/// ending the main program…) means the control would run something other than the
/// moves the reader reports.
pub(crate) fn posted_diagnostic(d: Diagnostic) -> Option<PostError> {
    // A FADAL subprogram call: the text verify is given is read in execution order (the
    // CLI's `ProgramReader` follows the calls), so the interpreter, which is not told,
    // says it does not follow them. A call left unfollowed misses its moves, which the
    // walk along the intended path finds. (Only M98: a FADAL `L` call, which the reader
    // does not follow, fails.)
    if matches!(&d.kind, ErrorKind::SubprogramNotFollowed(w) if w.starts_with("M98")) {
        return None;
    }
    if d.severity == Severity::Error {
        return Some(PostError::Input {
            file: "the posted program".into(),
            diag: Box::new(d),
        });
    }
    Some(PostError::Verify(format!(
        "posted line {}: {}; the post writes no such code, and the control would not run the moves verify reads",
        d.line, d.kind
    )))
}

/// The posted text's lines as they are read, screened for the codes that move the
/// program's frame on the machine without showing in the moves the reader reports:
/// `G92` (all forms), `G52`, `G10` and `G44`. (A `G92 X0 Y0 Z0` before the first move
/// changes nothing the reader can see, which starts from zero, but makes wherever the
/// machine stands the origin.) The first such line found is kept for [`Screen::check`].
/// Also kept: the last program end or return (`M2`, `M30`, `M99`) read, in execution
/// order, for [`Screen::finish`].
/// And the process switches the machine's codes set ([`Switches`]): the laser on after a
/// line holding every word of its `laser_on` code, off after one holding every word of
/// `laser_off` (as `preview` reads them); the powder, the spindle and the coolant alike,
/// for [`process_state`].
#[derive(Default, Clone)]
pub(crate) struct Screen {
    found: Rc<Cell<Option<(u32, u16)>>>,
    last_end: Rc<Cell<Option<(u32, u16)>>>,
    switches: Rc<Cell<Switches>>,
    codes: Rc<ProcessCodes>,
}

/// The process as the posted text has switched it so far: for each switch, the posted
/// line that turned it on, while it is on.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub(crate) struct Switches {
    pub(crate) laser: Option<u32>,
    pub(crate) powder: Option<u32>,
    /// While the spindle turns (or is oriented, `M19`): the line, and whether it was
    /// the machine's `spindle_on` code (else another `M3`, `M4` or `M19`).
    pub(crate) spindle: Option<(u32, bool)>,
    /// Any coolant (the machine's `coolant_on`, `M7` or `M8`; off by `coolant_off` or
    /// `M9`).
    pub(crate) coolant: Option<u32>,
    /// The machine has no powder codes (`powder_on = ""`: a wire-fed head): a deposit
    /// needs the laser alone.
    pub(crate) no_powder: bool,
}

/// The words of the machine's process codes; for deposition, the power word the
/// laser-on line must hold (its letter and the power posted); and whether the program
/// was posted without a work offset (then a line selecting one, `G54` included, is
/// refused: the reader's moves would not show it).
#[derive(Default)]
pub(crate) struct ProcessCodes {
    on: Vec<(u8, f64)>,
    off: Vec<(u8, f64)>,
    powder_on: Vec<(u8, f64)>,
    powder_off: Vec<(u8, f64)>,
    spindle_on: Vec<(u8, f64)>,
    spindle_off: Vec<(u8, f64)>,
    coolant_on: Vec<(u8, f64)>,
    coolant_off: Vec<(u8, f64)>,
    power: Option<(u8, f64)>,
    no_work_offset: bool,
    /// The M codes (in tenths) of the machine's process codes.
    m_codes: Vec<u16>,
}

struct Screened<R> {
    lines: LineReader<R>,
    found: Rc<Cell<Option<(u32, u16)>>>,
    last_end: Rc<Cell<Option<(u32, u16)>>>,
    switches: Rc<Cell<Switches>>,
    codes: Rc<ProcessCodes>,
}

impl Screen {
    /// A screen that also follows `machine`'s laser codes, for a program posted for
    /// `process`.
    pub(crate) fn new(machine: &Machine, process: &Process) -> Result<Screen, PostError> {
        let p = &machine.def.process;
        let power = match process {
            Process::Deposit { power } => Some((
                p.laser_power_word
                    .bytes()
                    .next()
                    .unwrap_or(b'S')
                    .to_ascii_uppercase(),
                *power,
            )),
            Process::Machine { .. } => None,
        };
        Ok(Screen {
            codes: Rc::new(ProcessCodes {
                on: crate::post::code_words(&p.laser_on)?,
                off: crate::post::code_words(&p.laser_off)?,
                powder_on: crate::post::code_words(&p.powder_on)?,
                powder_off: crate::post::code_words(&p.powder_off)?,
                spindle_on: crate::post::code_words(&p.spindle_on)?,
                spindle_off: crate::post::code_words(&p.spindle_off)?,
                coolant_on: crate::post::code_words(&p.coolant_on)?,
                coolant_off: crate::post::code_words(&p.coolant_off)?,
                m_codes: process_m_codes(machine)?,
                power,
                no_work_offset: posted_work_offset(process)?.1.is_none(),
            }),
            switches: Rc::new(Cell::new(Switches {
                no_powder: p.powder_on.is_empty(),
                ..Switches::default()
            })),
            ..Screen::default()
        })
    }

    /// The process switches as the lines read so far have set them.
    pub(crate) fn switches(&self) -> Switches {
        self.switches.get()
    }

    /// A stream of the posted text through this screen, in the machine's units.
    pub(crate) fn stream<R: BufRead>(&self, posted: R, units: Units) -> Stream<impl LineSource> {
        let src = Screened {
            lines: LineReader::new(posted),
            found: Rc::clone(&self.found),
            last_end: Rc::clone(&self.last_end),
            switches: Rc::clone(&self.switches),
            codes: Rc::clone(&self.codes),
        };
        Stream::new(
            src,
            Options {
                units,
                // Each stop is held to the input's (see `verify_traced`).
                stops: true,
                ..Options::default()
            },
            true,
        )
    }

    /// The first screened code read so far, as a failure.
    pub(crate) fn check(&self) -> Result<(), PostError> {
        match self.found.get() {
            None => Ok(()),
            Some((line, BLOCK_DELETE)) => Err(PostError::Verify(format!(
                "posted line {line}: a block-delete line (`/`): whether the control runs it depends on its switch; the post writes none"
            ))),
            Some((line, DWELL)) => Err(PostError::Verify(format!(
                "posted line {line}: a dwell (G4): the head stands still for it (with the laser on, over one spot of the work); the post writes none"
            ))),
            Some((line, LASER_STOP)) => Err(PostError::Verify(format!(
                "posted line {line}: a program stop (M0, M1 or M60) with the laser on: it stays on over one spot while the program waits; the post turns it off first"
            ))),
            Some((line, LASER_POWER)) => Err(PostError::Verify(format!(
                "posted line {line}: the laser goes on, or its power is set, at another power than the program was posted with ({}{}; verify --power names it)",
                char::from(self.codes.power.map_or(b'S', |p| p.0)),
                lampost_gcode::Readable(self.codes.power.map_or(0.0, |p| p.1))
            ))),
            Some((line, BLEND)) => Err(PostError::Verify(format!(
                "posted line {line}: G64 (path blending): the control may leave the path by its P tolerance, or as far as it likes without one; the post writes none"
            ))),
            Some((line, code)) if code & FOREIGN_M != 0 && code < LASER_POWER => {
                let c = code & !FOREIGN_M;
                Err(PostError::Verify(format!(
                    "posted line {line}: M{}{}, a code the post does not write for this machine (its process codes, M0, M1, M2, M30, M98 and M99): the control would act on it where verify cannot see",
                    c / 10,
                    if c % 10 == 0 { String::new() } else { format!(".{}", c % 10) },
                )))
            }
            Some((line, code)) if selects_work_offset(code) => Err(PostError::Verify(format!(
                "posted line {line}: G{}{} selects a work offset, and the program was posted with none (the control's active one places it; give verify the post's --work-offset)",
                code / 10,
                if code % 10 == 0 { String::new() } else { format!(".{}", code % 10) },
            ))),
            Some((line, code)) => Err(PostError::Verify(format!(
                "posted line {line}: G{}{} {}; the post writes no such code, and the moves verify reads would not be where the control runs them",
                code / 10,
                if code % 10 == 0 { String::new() } else { format!(".{}", code % 10) },
                frame_code(code).unwrap_or("moves the program's frame")
            ))),
        }
    }
}

impl Screen {
    /// At the end of the posted text: the program ends with M2 or M30, with the laser,
    /// the powder, the spindle and the coolant off (the machine's own codes; a control's
    /// program end may leave any of them on). (Read in execution order, a FADAL subprogram's `M99` returns into the
    /// main program, whose end comes after it; an `M99` read last ends the main program,
    /// and a control runs such a program again without end.)
    pub(crate) fn finish(&self) -> Result<(), PostError> {
        self.check()?;
        let s = self.switches.get();
        for (what, on) in [
            ("the laser on", s.laser),
            ("the powder on", s.powder),
            ("the spindle turning", s.spindle.map(|x| x.0)),
            ("the coolant on", s.coolant),
        ] {
            if let Some(l) = on {
                return Err(PostError::Verify(format!(
                    "the posted program ends with {what} (turned on at posted line {l}): the post turns it off with the machine's code before the end"
                )));
            }
        }
        match self.last_end.get() {
            Some((line, 990)) => Err(PostError::Verify(format!(
                "posted line {line}: the program ends with M99, and a control runs such a main program again without end (the post ends with M30)"
            ))),
            _ => Ok(()),
        }
    }
}

/// What a G-code (in tenths, as [`lampost_gcode::Word::code`]) does to the frame, if it
/// is one the screen refuses.
fn frame_code(code: u16) -> Option<&'static str> {
    match code {
        100..=109 => Some("sets a work or tool offset"),
        520 => Some("shifts the local coordinate system"),
        920..=929 => Some("sets or restores a coordinate-system offset"),
        440..=449 => Some("applies a tool length offset the other way"),
        _ => None,
    }
}

/// Whether a G-code (in tenths) selects a work offset: `G54`–`G59.3`, `G54.1`, `G154`.
fn selects_work_offset(code: u16) -> bool {
    matches!(code, 540 | 541 | 550 | 560 | 570 | 580 | 590..=593 | 1540)
}

/// The code [`Screen`] keeps for a block-delete line (`/…`).
const BLOCK_DELETE: u16 = u16::MAX;

/// The code [`Screen`] keeps for a dwell (G4, in tenths).
const DWELL: u16 = 40;

/// The code [`Screen`] keeps for path blending (G64, in tenths).
const BLEND: u16 = 640;

/// The flag [`Screen`] sets on an M code (in tenths, at most 0x7000) the post does not
/// write for the machine ([`foreign_m`]).
const FOREIGN_M: u16 = 0x8000;

/// The M codes (in tenths) of `machine`'s process codes (laser, powder, spindle,
/// coolant, tool change, program end).
fn process_m_codes(machine: &Machine) -> Result<Vec<u16>, PostError> {
    let p = &machine.def.process;
    let mut out = Vec::new();
    for code in [
        &p.laser_on,
        &p.laser_off,
        &p.powder_on,
        &p.powder_off,
        &p.spindle_on,
        &p.spindle_off,
        &p.coolant_on,
        &p.coolant_off,
        &p.tool_change,
        &p.program_end,
    ] {
        for (letter, value) in crate::post::code_words(code)? {
            if letter == b'M' && (0.0..3000.0).contains(&value) {
                out.push((value * 10.0).round() as u16);
            }
        }
    }
    Ok(out)
}

/// Whether an M code (in tenths) is one the post does not write for a machine whose
/// process codes hold `m_codes`: any but those, the program stops and ends (M0, M1, M2,
/// M30), the subprogram call and return of a split program (M98, M99), and the spindle
/// and coolant switches (M3, M4, M5, M7, M8, M9, M19), which [`process_state`] judges
/// at every move. (A user M code runs a machine's own action: a LinuxCNC `M100`–`M199`
/// runs a program, `M62`–`M65` set outputs a laser may hang on, `M66` waits, `M60`
/// changes pallets.)
fn foreign_m(code: u16, m_codes: &[u16]) -> bool {
    !matches!(
        code,
        0 | 10 | 20 | 300 | 980 | 990 | 30 | 40 | 50 | 70 | 80 | 90 | 190
    ) && !m_codes.contains(&code)
}

/// The code [`Screen`] keeps for a program stop (M0, M1, M60) with the laser on.
const LASER_STOP: u16 = u16::MAX - 1;

/// The code [`Screen`] keeps for a laser-on line without the power posted.
const LASER_POWER: u16 = u16::MAX - 2;

impl ProcessCodes {
    /// The process switches a parsed line sets, in `switches` (the line `number` kept
    /// for each switched on); whether it turns the laser on at another power than the
    /// one posted.
    fn switch(&self, block: &lampost_gcode::Block, number: u32, switches: &mut Switches) -> bool {
        let holds = |code: &[(u8, f64)]| {
            !code.is_empty()
                && code
                    .iter()
                    .all(|c| block.words().any(|w| (w.letter, w.value) == *c))
        };
        let m_code = |codes: &[u16]| {
            block
                .words()
                .filter(|w| w.letter == b'M')
                .filter_map(|w| w.code())
                .any(|c| codes.contains(&c))
        };
        let mut wrong_power = false;
        let posted_power = |w: &lampost_gcode::Word, want: f64| {
            (w.value - want).abs() <= SPEED_SLACK * want.abs().max(1.0)
        };
        if holds(&self.off) {
            switches.laser = None;
        } else if holds(&self.on) {
            switches.laser = switches.laser.or(Some(number));
            // The power posted, as written (the emitter's rounding allowed).
            if let Some((letter, want)) = self.power {
                wrong_power = !block
                    .words()
                    .any(|w| w.letter == letter && posted_power(w, want));
            }
        } else if let Some((letter, want)) = self.power {
            // The post writes the power word in the laser-on line only: one elsewhere
            // (an `S0` inside a run) sets the laser to another power.
            wrong_power = block
                .words()
                .any(|w| w.letter == letter && !posted_power(w, want));
        }
        if holds(&self.powder_off) {
            switches.powder = None;
        } else if holds(&self.powder_on) {
            switches.powder = switches.powder.or(Some(number));
        }
        // M5 stops the spindle whatever the machine's code; M3, M4 (and M19, which
        // orients it) other than the machine's `spindle_on` turn it otherwise.
        if holds(&self.spindle_off) || m_code(&[50]) {
            switches.spindle = None;
        } else if holds(&self.spindle_on) {
            switches.spindle = Some((number, true));
        } else if m_code(&[30, 40, 190]) {
            switches.spindle = Some((number, false));
        }
        if holds(&self.coolant_off) || m_code(&[90]) {
            switches.coolant = None;
        } else if holds(&self.coolant_on) || m_code(&[70, 80]) {
            switches.coolant = switches.coolant.or(Some(number));
        }
        wrong_power
    }
}

/// A line's first refused G-code (a frame code, or [`DWELL`]; or [`BLOCK_DELETE`]:
/// whether a control runs the line depends on its block-delete switch), its program end
/// or return (M2, M30, M99), if any, and whether it stops the program (M0, M1, M60);
/// lines with neither a `G` nor an `M` are not parsed.
/// The line's process switches are set in `switches` ([`ProcessCodes::switch`]).
fn screen_line(
    bytes: &[u8],
    number: u32,
    offset: usize,
    codes: &ProcessCodes,
    switches: &mut Switches,
) -> (Option<u16>, Option<u16>, bool) {
    if bytes.iter().find(|c| !c.is_ascii_whitespace()) == Some(&b'/') {
        return (Some(BLOCK_DELETE), None, false);
    }
    // Lines with a G, an M or the laser's power word are parsed.
    let power = codes.power.map_or(0, |p| p.0 | 0x20);
    let (g, m) = bytes.iter().fold((false, false), |(g, m), &c| {
        (
            g || c | 0x20 == b'g',
            m || c | 0x20 == b'm' || c | 0x20 == power,
        )
    });
    if !(g || m) {
        return (None, None, false);
    }
    let Ok(block) = lampost_gcode::parse_line(bytes, number, offset) else {
        return (None, None, false);
    };
    let wrong_power = codes.switch(&block, number, switches);
    let refused = block
        .words()
        .filter(|w| w.letter == b'G')
        .filter_map(|w| w.code())
        .find(|&c| {
            frame_code(c).is_some()
                || c == DWELL
                || c == BLEND
                || (codes.no_work_offset && selects_work_offset(c))
        });
    let ms = || {
        block
            .words()
            .filter(|w| w.letter == b'M')
            .filter_map(|w| w.code())
    };
    let end = ms().find(|c| matches!(c, 20 | 300 | 990));
    let stop = ms().any(|c| matches!(c, 0 | 10 | 600));
    let foreign = ms()
        .find(|&c| foreign_m(c, &codes.m_codes))
        .map(|c| FOREIGN_M | c.min(0x7000));
    (
        refused.or(wrong_power.then_some(LASER_POWER)).or(foreign),
        end,
        stop,
    )
}

impl<R: BufRead> LineSource for Screened<R> {
    fn next_line(&mut self) -> std::io::Result<Option<Line<'_>>> {
        let line = self.lines.next_line()?;
        if let Some(l) = &line {
            let mut switches = self.switches.get();
            let (refused, end, stop) =
                screen_line(l.bytes, l.number, l.offset, &self.codes, &mut switches);
            self.switches.set(switches);
            let refused = refused.or((stop && switches.laser.is_some()).then_some(LASER_STOP));
            if let (Some(code), None) = (refused, self.found.get()) {
                self.found.set(Some((l.number, code)));
            }
            if let Some(code) = end {
                self.last_end.set(Some((l.number, code)));
            }
        }
        Ok(line)
    }
}

/// What every posted move's own state must be: written by the block itself (no `G53`,
/// `G28`/`G30` or canned cycle, whose machine positions the reader cannot know), in the
/// machine's units, without cutter compensation, arcs in the XY plane (the plane of the
/// joints verify replays), feeds per minute (or inverse time on a per-point path), and
/// the work offset, tool length offset, tool and S word it was posted with. In a planar
/// program no feed turns the table (the post turns it only in rapids, at a height safe
/// over the sweep).
pub(crate) struct PostedRules {
    units: Units,
    per_point: bool,
    /// The work offset every move is read in, and its text as posted (`None`: none).
    work_offset: WorkOffset,
    work_text: Option<String>,
    /// The tool length offset and the tool (0: no tool change) of every move.
    tool_length: Option<u32>,
    tool: u32,
    /// The S word in force on every move: the laser power, the spindle speed; with
    /// the laser, S is 0 until it first goes on (`speed_set` once it has been).
    speed: f64,
    deposit: bool,
    speed_set: bool,
    /// A tool change has been posted: the tool, its length offset and speed are the
    /// input's (for the messages).
    changed: bool,
}

/// How far a posted S (or laser power word) may lie from the value posted: the emitter's
/// rounding, relative to the value (at least 1).
const SPEED_SLACK: f64 = 1e-6;

impl PostedRules {
    pub(crate) fn new(
        units: lampost_kinematics::Units,
        per_point: bool,
        process: &Process,
    ) -> Result<Self, PostError> {
        let (work_offset, work_text) = posted_work_offset(process)?;
        let (tool_length, tool, speed) = match process.checked()? {
            Process::Deposit { power } => (None, None, *power),
            Process::Machine {
                length_offset,
                tool,
                spindle,
                ..
            } => (*length_offset, *tool, *spindle),
        };
        Ok(PostedRules {
            units: match units {
                lampost_kinematics::Units::Inch => Units::Inch,
                lampost_kinematics::Units::Mm => Units::Mm,
            },
            per_point,
            work_offset,
            work_text,
            tool_length,
            tool: tool.unwrap_or(0),
            speed,
            deposit: matches!(process, Process::Deposit { .. }),
            speed_set: false,
            changed: false,
        })
    }

    /// The moves after a posted tool change (held to the input's, see `verify_traced`)
    /// are made with its tool, length offset and spindle speed.
    fn tool_changed(&mut self, c: &crate::intended::ToolChange) {
        self.changed = true;
        self.tool = c.tool;
        self.tool_length = c.length_offset;
        self.speed = c.speed();
    }

    /// Where a posted value comes from: the option `flag` of verify, or after a tool
    /// change the input's own (its G43 H and S at the tool's first cut).
    fn given_by(&self, flag: &str) -> String {
        if self.changed {
            format!(
                "the input's, for T{}'s cuts after its tool change",
                self.tool
            )
        } else {
            format!("verify {flag}")
        }
    }

    pub(crate) fn check(&mut self, m: &Move, rot_idx: &[usize]) -> Result<(), PostError> {
        let fail = |what: &str| Err(PostError::Verify(format!("posted line {}: {what}", m.line)));
        match m.origin {
            Origin::Block => {}
            Origin::MachineCoords => {
                return fail("a move in machine coordinates (G53): the post writes none, and where it goes on the part is not known")
            }
            Origin::Home => {
                return fail("a move to a home position (G28/G30): the post writes none, and where it goes on the part is not known")
            }
            Origin::CannedCycle => {
                return fail("a canned cycle: the post writes none; its moves depend on the control's reading of it")
            }
        }
        let md = &m.modal;
        if md.units != self.units {
            return fail("a move in other units than the machine's (G20/G21, G70/G71 changed)");
        }
        if md.cutter_comp != Modal::new(self.units).cutter_comp {
            return fail("a move under cutter radius compensation (G41/G42): the control would offset the path");
        }
        let feed = !matches!(m.kind, MoveKind::Rapid);
        if matches!(m.kind, MoveKind::Arc { turns, .. } if turns > 1) {
            return fail("an arc of more than one turn (P): the post writes none, and the turns would run the path again");
        }
        if matches!(m.kind, MoveKind::Arc { .. }) && md.plane != Plane::XY {
            return fail("an arc outside the XY plane (G18/G19): the post writes arcs in G17 only");
        }
        let mode_ok = match md.feed_mode {
            lampost_gcode::FeedMode::PerMinute => true,
            lampost_gcode::FeedMode::InverseTime => self.per_point,
            _ => false,
        };
        if feed && !mode_ok {
            return fail("a feed in a feed mode the post does not write here (G93/G95)");
        }
        if feed && !self.per_point && rot_idx.iter().any(|&r| m.start[r] != m.end[r]) {
            return fail("a feed turns the table: the post turns it only in rapids, at a height safe over the whole sweep");
        }
        if md.work_offset != self.work_offset {
            let posted = match &self.work_text {
                Some(w) => format!("for {w} (verify --work-offset {w})"),
                None => {
                    "with none (the control's active one places it; verify --work-offset names one)"
                        .to_string()
                }
            };
            return fail(&format!(
                "a move in work offset {}, and the program was posted {posted}: it would run elsewhere on the table",
                md.work_offset,
            ));
        }
        if md.tool != self.tool {
            let t = |t: u32| {
                if t == 0 {
                    "none".to_string()
                } else {
                    format!("T{t}")
                }
            };
            return fail(&format!(
                "a move with tool {} in the spindle, and the program was posted with {} ({})",
                t(md.tool),
                t(self.tool),
                self.given_by("--tool")
            ));
        }
        if md.tool_length != self.tool_length {
            let h = |h: Option<u32>| h.map_or("none".to_string(), |h| format!("H{h}"));
            return fail(&format!(
                "a move with tool length offset {}, and the program was posted with {} ({}): the tool would stand off by the difference",
                h(md.tool_length),
                h(self.tool_length),
                self.given_by("--length-offset")
            ));
        }
        let same = (md.speed - self.speed).abs() <= SPEED_SLACK * self.speed.abs().max(1.0);
        if same {
            self.speed_set = true;
        } else if !(self.deposit && !self.speed_set && md.speed == 0.0) {
            let (what, flag) = if self.deposit {
                ("the laser power", "--power")
            } else {
                ("the spindle speed", "--spindle")
            };
            return fail(&format!(
                "a move with S{} in force, and the program was posted with {what} S{} ({})",
                lampost_gcode::Readable(md.speed),
                lampost_gcode::Readable(self.speed),
                self.given_by(flag)
            ));
        }
        Ok(())
    }
}

/// The process at every posted move, as the posted text has switched it ([`Switches`]),
/// against the process the program was posted with:
/// - no rapid with the laser on (the post turns it off before any travel; a rapid with it
///   on deposits along the way);
/// - deposition: along a deposition move (`along`: the intended move a feed's end lies
///   on, its input line, and whether the feed deposits there: not on the approach onto
///   its start) the laser on, and off along any other feed; the
///   laser never on without the powder; the spindle never turning and the coolant never
///   on (the post switches neither);
/// - machining: the laser never on; every feed with the spindle turning as posted (the
///   machine's `spindle_on` code); the coolant on along every feed when posted with it,
///   and never on when posted without.
pub(crate) fn process_state(
    m: &Move,
    s: Switches,
    process: &Process,
    along: Option<(u32, bool)>,
) -> Result<(), PostError> {
    let fail = |what: String| Err(PostError::Verify(format!("posted line {}: {what}", m.line)));
    let feed = !matches!(m.kind, MoveKind::Rapid);
    if let (false, Some(l)) = (feed, s.laser) {
        return fail(format!(
            "a rapid with the laser on (turned on at posted line {l}): it would deposit along the travel"
        ));
    }
    if let (false, Some(l)) = (feed, s.powder) {
        return fail(format!(
            "a rapid with the powder on (turned on at posted line {l}): it would blow powder over the work along the travel; the post turns it off before any travel"
        ));
    }
    match process {
        Process::Deposit { .. } => {
            if let Some((l, _)) = s.spindle {
                return fail(format!(
                    "the spindle turning (posted line {l}) in a program posted for deposition: the post never turns it"
                ));
            }
            if let Some(l) = s.coolant {
                return fail(format!(
                    "coolant on (posted line {l}) in a program posted for deposition: the post never turns it on"
                ));
            }
            if let (true, Some(l), None, false) = (feed, s.laser, s.powder, s.no_powder) {
                return fail(format!(
                    "a feed with the laser on (posted line {l}) and no powder: it would melt the work without adding to it"
                ));
            }
            match (along, s.laser) {
                (Some((input, true)), None) => fail(format!(
                    "a feed with the laser off along the deposition move of input line {input}: it would deposit nothing"
                )),
                (Some((input, false)), Some(l)) => fail(format!(
                    "a feed with the laser on (posted line {l}) where the program deposits nothing (input line {input}'s move, or the approach onto it)"
                )),
                _ => Ok(()),
            }
        }
        Process::Machine { coolant, .. } => {
            if let Some(l) = s.laser {
                return fail(format!(
                    "the laser on (posted line {l}) in a program posted for machining"
                ));
            }
            match (feed, s.spindle) {
                (true, None) => {
                    return fail(
                        "a feed with the spindle stopped: the program was posted with it turning"
                            .into(),
                    )
                }
                (true, Some((l, false))) => {
                    return fail(format!(
                        "a feed with the spindle switched otherwise than posted (posted line {l}: not the machine's spindle_on code)"
                    ))
                }
                _ => {}
            }
            match (*coolant, s.coolant) {
                (true, None) if feed => fail(
                    "a feed without coolant, and the program was posted with it (verify --coolant)"
                        .into(),
                ),
                (false, Some(l)) => fail(format!(
                    "coolant on (posted line {l}), and the program was posted without it (verify --coolant names it)"
                )),
                _ => Ok(()),
            }
        }
    }
}

/// A posted move made before the program has set every rotary axis: the table stands
/// wherever the last program left it, not at 0 as a replay from the start would have
/// it (a posted program with its index line deleted verified). Only a rapid raising Z
/// alone may come first (the post's lift to the safe height before it indexes).
pub(crate) fn rotaries_commanded(m: &Move, rot_idx: &[usize], z: usize) -> Result<(), PostError> {
    let mask = rot_idx.iter().fold(0u16, |a, &i| a | 1 << i);
    if m.axes_named & mask == mask {
        return Ok(());
    }
    let lift = matches!(m.kind, MoveKind::Rapid)
        && (0..9).all(|k| k == z || m.start[k] == m.end[k])
        && m.end[z] >= m.start[z];
    if lift {
        return Ok(());
    }
    let missing: Vec<char> = rot_idx
        .iter()
        .filter(|&&i| m.axes_named & 1 << i == 0)
        .map(|&i| char::from(AXES[i]))
        .collect();
    Err(PostError::Verify(format!(
        "posted line {}: a move before the program sets {}: the table stands wherever the last program left it, and the move would be made there; the post indexes every rotary before the first move (after the lift)",
        m.line,
        missing
            .iter()
            .map(|c| c.to_string())
            .collect::<Vec<_>>()
            .join(" and ")
    )))
}

/// A posted arc from `p0` through `p1` (a little way along it, part frame) turns the
/// way the intended arc `step` does, about its normal; a turn the other way by more than
/// the tolerance allows at its radius fails.
fn arc_sense(
    step: Option<&Step>,
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    tolerance: f64,
    line: u32,
) -> Result<(), PostError> {
    let Some(Step {
        kind: StepKind::Arc {
            center,
            normal,
            sweep,
        },
        line: input_line,
        ..
    }) = step
    else {
        return Ok(());
    };
    let flat = |p: &Vector3<f64>| {
        let v = p - center;
        v - normal * normal.dot(&v)
    };
    let (u0, u1) = (flat(p0), flat(p1));
    let r = u0.norm().max(u1.norm());
    let turn = normal.dot(&u0.cross(&u1)).atan2(u0.dot(&u1));
    if turn * sweep < 0.0 && turn.abs() * r > tolerance {
        return Err(PostError::Verify(format!(
            "posted line {line}: the arc runs the other way round from the intended one of input line {input_line}"
        )));
    }
    Ok(())
}

/// A verification tolerance must be finite and positive.
pub(crate) fn check_tolerance(tolerance: f64) -> Result<(), PostError> {
    if !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(PostError::Options(format!(
            "the verification tolerance must be a finite positive number, not {tolerance}"
        )));
    }
    Ok(())
}

/// The largest angle a posted tool axis may have from the intended one.
pub const AXIS_TOLERANCE_DEG: f64 = 0.01;

/// The safety rules a posted program must keep, checked on the joints as the text gives
/// them, in the part frame by forward kinematics (not the post's joints maps): every point
/// within travel; outside a run no rapid below the safe height (the larger of the
/// machine's clearance and the work's highest point along the tool axis plus the
/// margin) except the vertical lift off an end and the vertical approach onto a start;
/// a rotary move only at a height safe for every table position it passes; the program
/// ends with the head lifted and a program end.
pub(crate) struct Safety<'m> {
    m: &'m Machine,
    head: usize,
    work: WorkBounds,
    margin: f64,
    clearance: f64,
    /// The output resolution and a little: the written rounding.
    eps: f64,
    /// A vertical rapid came down below the safe height to this Z: the next move must be
    /// the feed it approaches, ending no higher.
    approach: Option<(f64, u32)>,
    /// The head is below the safe height after a feed.
    down: Option<u32>,
    /// The last move was a rapid ending at this Z: the feed onto the start begins there.
    entering: Option<(f64, u32)>,
    /// The longest feed onto a start (the approach stops this far above it).
    lift: f64,
    /// The part, for collision checks of every rapid.
    pub(crate) part: Option<&'m crate::collide::PartMesh>,
    /// A move has been made: where the head is is known (the first move starts from
    /// wherever the machine stands, not from the interpreter's zero).
    started: bool,
}

impl<'m> Safety<'m> {
    pub(crate) fn new(m: &'m Machine, head: usize, work: WorkBounds) -> Self {
        // The written words are rounded to the output resolution (1e-4 in, 1e-3 mm);
        // along a tilted tool axis the three roundings add up to at most √3/2 of it.
        let eps = match m.units {
            MUnits::Inch => 1e-4,
            MUnits::Mm => 1e-3,
        } + 1e-9;
        Safety {
            m,
            head,
            work,
            margin: m.safe_margin(),
            clearance: m.def.process.clearance_z,
            eps,
            approach: None,
            down: None,
            entering: None,
            lift: crate::safety::approach_lift(m),
            part: None,
            started: false,
        }
    }

    /// How far the tip at joints `x`, table `rot`, is above the work's highest point,
    /// along the tool axis (part frame); +inf without work.
    fn height(&self, x: &[f64; 3], rot: &[f64; 2]) -> f64 {
        if self.work.is_empty() {
            return f64::INFINITY;
        }
        let pose = self.m.forward(
            &Joints {
                linear: *x,
                rotary: *rot,
            },
            self.head,
        );
        let a = pose.axis.normalize();
        let top = self
            .work
            .extremes()
            .map(|c| c.dot(&a))
            .fold(f64::NEG_INFINITY, f64::max);
        pose.tip.dot(&a) - top
    }

    /// Whether the head at `x`, `rot` is at or above the safe height.
    fn is_safe(&self, x: &[f64; 3], rot: &[f64; 2]) -> bool {
        x[2] >= self.clearance - self.eps && self.height(x, rot) >= self.margin - self.eps
    }

    fn fail(line: u32, what: String) -> PostError {
        PostError::Verify(format!("posted line {line}: {what}"))
    }

    pub(crate) fn travel(&self, x: &[f64; 3], rot: &[f64; 2], line: u32) -> Result<(), PostError> {
        for (l, &v) in self.m.linear.iter().zip(x) {
            if !v.is_finite() || v < l.limits.0 - 1e-9 || v > l.limits.1 + 1e-9 {
                return Err(Self::fail(
                    line,
                    format!(
                        "{} = {} is beyond its travel [{}, {}]",
                        l.name,
                        lampost_gcode::Fixed(v, 4),
                        l.limits.0,
                        l.limits.1
                    ),
                ));
            }
        }
        for (r, &v) in self.m.rotary.iter().zip(rot) {
            if !v.is_finite() || !r.within(v) {
                return Err(Self::fail(
                    line,
                    format!(
                        "{} = {} is beyond its travel {:?}",
                        r.name,
                        lampost_gcode::Fixed(v, 3),
                        r.limits
                    ),
                ));
            }
        }
        Ok(())
    }

    /// An arc's X/Y extremes within travel (the ends are checked as moves).
    fn arc_travel(
        &self,
        s: &[f64; 3],
        e: &[f64; 3],
        c: &[f64; 2],
        clockwise: bool,
        rot: &[f64; 2],
        line: u32,
    ) -> Result<(), PostError> {
        let r = (s[0] - c[0]).hypot(s[1] - c[1]);
        let a0 = (s[1] - c[1]).atan2(s[0] - c[0]);
        let a1 = (e[1] - c[1]).atan2(e[0] - c[0]);
        let tau = std::f64::consts::TAU;
        // Angle travelled (a full circle when the ends meet).
        let mut sweep = if clockwise { a0 - a1 } else { a1 - a0 }.rem_euclid(tau);
        if sweep < 1e-12 {
            sweep = tau;
        }
        for k in 0..4 {
            let dir = f64::from(k) * std::f64::consts::FRAC_PI_2;
            let along = if clockwise { a0 - dir } else { dir - a0 }.rem_euclid(tau);
            if along <= sweep {
                let q = [c[0] + r * dir.cos(), c[1] + r * dir.sin(), s[2].max(e[2])];
                self.travel(&q, rot, line)?;
            }
        }
        Ok(())
    }

    /// A feed from `from` to `x`.
    pub(crate) fn feed(
        &mut self,
        from: &[f64; 3],
        x: &[f64; 3],
        line: u32,
    ) -> Result<(), PostError> {
        self.started = true;
        if let Some((_, l)) = self.approach {
            // Below the safe height only straight down onto the start: the feed the
            // approach makes way for goes along the tool axis, not across the work.
            if (from[0] - x[0]).abs() > self.eps || (from[1] - x[1]).abs() > self.eps {
                return Err(Self::fail(
                    l,
                    format!("a rapid comes down below the safe height, and the feed after it (line {line}) moves across, not straight down onto the start it approaches"),
                ));
            }
        }
        if let Some((z, _)) = self.entering.take() {
            if z - x[2] > self.lift + self.eps {
                return Err(Self::fail(
                    line,
                    format!(
                        "the feed onto a start begins {:.4} above it (the approach comes down to {} above it)",
                        z - x[2],
                        self.lift
                    ),
                ));
            }
        }
        if let Some((z, l)) = self.approach.take() {
            if x[2] > z + self.eps {
                return Err(Self::fail(
                    l,
                    format!("a rapid comes down to Z {z:.4}, below the feed it approaches (line {line}, to Z {:.4}): it goes through the work", x[2]),
                ));
            }
        }
        self.down = Some(line);
        Ok(())
    }

    /// A rapid from `xs`, `rs` to `xe`, `re`.
    pub(crate) fn rapid(
        &mut self,
        xs: &[f64; 3],
        rs: &[f64; 2],
        xe: &[f64; 3],
        re: &[f64; 2],
        line: u32,
    ) -> Result<(), PostError> {
        self.entering = Some((xe[2], line));
        let turns = rs != re;
        let vertical = !turns && xs[0] == xe[0] && xs[1] == xe[1];
        let known = std::mem::replace(&mut self.started, true);
        if let (Some(part), true) = (self.part, known) {
            let lifting = vertical && xe[2] > xs[2] && self.down.is_some();
            if let Some(what) =
                crate::safety::rapid_meets_part(self.m, self.head, part, xs, rs, xe, re, lifting)?
            {
                return Err(PostError::Collision(format!("posted line {line}: {what}")));
            }
        }
        if vertical {
            if xe[2] < xs[2] {
                // Coming down: the approach onto a start, if it goes below the safe height.
                if !self.is_safe(xe, re) {
                    self.approach = Some((xe[2], line));
                }
            } else {
                if let Some((_, l)) = self.approach {
                    // Down below the safe height and up again without the feed: a
                    // plunge into the work at rapid.
                    return Err(Self::fail(
                        l,
                        format!("a rapid comes down below the safe height and goes back up (line {line}) without the feed it approaches: it may go through the work"),
                    ));
                }
                if self.is_safe(xe, re) {
                    self.down = None;
                }
            }
            return Ok(());
        }
        if let Some((_, l)) = self.approach {
            return Err(Self::fail(
                l,
                "a rapid comes down below the safe height and is not followed by the feed it approaches".into(),
            ));
        }
        for (x, r, which) in [(xs, rs, "starts"), (xe, re, "ends")] {
            if !self.is_safe(x, r) {
                return Err(Self::fail(
                    line,
                    format!(
                        "a rapid {which} below the safe height (Z {:.4}: {:.4} above the work along the tool axis; the safe height is the larger of clearance_z {} and the work's top plus {})",
                        x[2],
                        self.height(x, r),
                        self.clearance,
                        self.margin
                    ),
                ));
            }
        }
        if turns {
            self.sweep(xs, rs, re, line)?;
            self.sweep(xe, rs, re, line)?;
        }
        self.down = None;
        Ok(())
    }

    /// The table turning from `from` to `to` with the head at `x`: safe throughout
    /// (sampled at most 1° apart, less what a point can rise between samples).
    fn sweep(
        &self,
        x: &[f64; 3],
        from: &[f64; 2],
        to: &[f64; 2],
        line: u32,
    ) -> Result<(), PostError> {
        if self.work.is_empty() {
            return Ok(());
        }
        let slack = crate::safety::sweep_slack(self.m, &self.work, from, to);
        for (_, r) in crate::safety::sweep_positions(from, to) {
            let h = self.height(x, &r);
            if h < self.margin + slack - self.eps {
                return Err(Self::fail(
                    line,
                    format!(
                        "the table turns with the head {h:.4} above the work at {:.3}°, {:.3}° (needs {:.4})",
                        r[0],
                        r[1],
                        self.margin + slack
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The end of the program: a program end, and the head lifted off the last run.
    pub(crate) fn finish(&self, ended: bool) -> Result<(), PostError> {
        if let Some((_, l)) = self.approach {
            return Err(Self::fail(
                l,
                "the program ends after a rapid down below the safe height".into(),
            ));
        }
        if let Some(l) = self.down {
            return Err(PostError::Verify(format!(
                "the program ends with the head down at the work (last feed on posted line {l}): no lift to the safe height, and the program may be truncated"
            )));
        }
        if !ended {
            return Err(PostError::Verify(
                "the posted program has no program end (M2/M30): it may be truncated".into(),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::{dist_to, ArcPoints};
    use crate::intended::{Step, StepKind};
    use nalgebra::Vector3;
    use proptest::prelude::*;

    /// An arc step of radius `r` about `center` in the plane normal to `normal`, from
    /// angle `a0` through `sweep`, rising `rise` along the normal (for tests).
    pub(crate) fn arc(
        center: Vector3<f64>,
        normal: Vector3<f64>,
        r: f64,
        a0: f64,
        sweep: f64,
        rise: f64,
    ) -> Step {
        let n = normal.normalize();
        // A unit vector normal to n, turned by a0 about n.
        let helper = if n.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let u = n.cross(&helper).normalize();
        let v = n.cross(&u);
        let start = center + (u * a0.cos() + v * a0.sin()) * r;
        let a1 = a0 + sweep;
        let end = center + (u * a1.cos() + v * a1.sin()) * r + n * rise;
        Step {
            section: 0,
            layer: 0,
            line: 1,
            kind: StepKind::Arc {
                center,
                normal: n,
                sweep,
            },
            start,
            end,
            feed: 100.0,
            deposit: false,
            tool: 0,
        }
    }

    /// The distance from `p` to `step`'s path by dense sampling.
    fn sampled(step: &Step, p: &Vector3<f64>, samples: usize) -> f64 {
        (0..=samples)
            .map(|i| (p - step.at(i as f64 / samples as f64)).norm())
            .fold(f64::INFINITY, f64::min)
    }

    /// A short, steep helix (0.0007 rad of a 0.3 radius, rising 0.01; input 16 of the
    /// post fuzz target's seed 1, input 135984): a point beside its middle by the output's
    /// rounding lies at an angle just behind the start, which names an end (0.005 away),
    /// while the path passes within 1e-4. `dist_to` finds that, and never less than the
    /// sampled distance.
    #[test]
    fn a_short_steep_helix_is_measured_at_the_points_height() {
        let step = arc(
            Vector3::new(0.66, 0.43, 0.05),
            Vector3::z(),
            0.3,
            -0.5,
            7e-4,
            0.01,
        );
        let mid = step.at(0.5);
        let c = Vector3::new(0.66, 0.43, mid.z);
        let radial = (mid - c).normalize();
        let along = Vector3::z().cross(&radial);
        for (dr, da) in [(1e-4, -3e-4), (-1e-4, -4e-4), (0.0, 5e-4), (5e-5, 0.0)] {
            let p = mid + radial * dr + along * da;
            let want = sampled(&step, &p, 100_000);
            let got = dist_to(&step, &p);
            assert!(got >= want - 1e-9, "{got} under the sampled {want}");
            assert!(got <= want + 1e-6, "{got} over the sampled {want}");
            assert!(got < 1e-3, "{got}");
        }
    }

    /// A helix of 300 turns: the distance taken at the passes beside the point's height
    /// is the distance to the whole path (sampled), for points near any turn.
    #[test]
    fn a_many_turn_helix_is_measured_at_the_nearest_turn() {
        let tau = std::f64::consts::TAU;
        for sweep in [300.0 * tau + 0.4, -(300.0 * tau) - 0.4] {
            let step = arc(
                Vector3::new(1.0, -2.0, 0.0),
                Vector3::new(0.2, 0.1, 1.0),
                0.8,
                0.3,
                sweep,
                1.5,
            );
            for k in 0..12 {
                let t = (k as f64 + 0.37) / 12.0;
                let off = Vector3::new((k as f64).sin(), (k as f64 * 1.7).cos(), 0.3) * 3e-4;
                let p = step.at(t) + off;
                let got = dist_to(&step, &p);
                // Sampled finely around t (the nearest pass is on t's own turn: the offset
                // is a tenth of the pitch).
                let window = 0.1 / 300.0;
                let want = (0..=8_000)
                    .map(|i| (t - window + 2.0 * window * i as f64 / 8_000.0).clamp(0.0, 1.0))
                    .map(|u| (p - step.at(u)).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    got >= want - 2e-5 && got <= want + 2e-5,
                    "t {t}: {got} vs {want}"
                );
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]
        /// The chord-point helpers give exactly what `Step::at` and `dist_to` give, for
        /// points near, on, off and beyond flat and helical arcs of up to two turns.
        #[test]
        fn arc_points_match_step_at_and_dist_to(
            c in prop::array::uniform3(-100.0f64..100.0),
            nrm in prop::array::uniform3(-1.0f64..1.0),
            r in 0.001f64..200.0,
            a0 in -7.0f64..7.0,
            sweep in prop_oneof![-12.6f64..12.6, Just(std::f64::consts::TAU), Just(-std::f64::consts::PI)],
            helix in prop::bool::weighted(0.2),
            k in 0usize..=64,
            n in 1usize..=64,
            off in prop::array::uniform3(-1.0f64..1.0),
            scale_exp in -12i32..1,
        ) {
            let normal = Vector3::from(nrm);
            prop_assume!(normal.norm() > 0.1);
            let step = arc(Vector3::from(c), normal, r, a0, sweep, if helix { 0.3 * r } else { 0.0 });
            let Some(ap) = ArcPoints::new(&step) else { panic!("an arc") };
            let t = (k.min(n)) as f64 / n as f64;
            let near = ap.at(t);
            prop_assert_eq!(near, step.at(t));
            let p = near + Vector3::from(off) * (r * 10f64.powi(scale_exp));
            prop_assert_eq!(ap.dist_near(&step, &p, &near, t).to_bits(), dist_to(&step, &p).to_bits());
        }
    }

    /// Each cut is held to the input's tool: the first tool may be posted under another
    /// number until a change is posted; a cut with another tool than the one posted fails
    /// (a change left out), as does the first tool's after a change; deposition and T0
    /// are not held.
    #[test]
    fn cuts_are_held_to_the_input_s_tool() {
        use super::CutTools;
        use crate::post::Process;
        let machine = Process::Machine {
            tool: Some(5),
            length_offset: Some(5),
            work_offset: None,
            spindle: 3000.0,
            coolant: false,
        };
        let cut = |tool: u32| Step {
            tool,
            ..arc(Vector3::zeros(), Vector3::z(), 1.0, 0.0, 1.0, 0.0)
        };
        // T1 posted as T5 (--tool 5), then T2 with its change posted.
        let mut c = CutTools::new(&machine);
        assert!(c.hold(&cut(1), 5));
        assert!(c.hold(&cut(0), 5));
        assert!(!c.hold(&cut(2), 5), "T2's change left out");
        c.changed = true;
        assert!(c.hold(&cut(2), 2));
        assert!(!c.hold(&cut(1), 2), "back to T1 without its change");
        assert!(!c.hold(&cut(1), 5), "T1 is posted as itself after a change");
        assert!(c.hold(&cut(1), 1));
        // The first cut made with the tool posted, then another tool's without a change.
        let mut c = CutTools::new(&machine);
        assert!(c.hold(&cut(5), 5));
        assert!(!c.hold(&cut(7), 5));
        // Deposition is not held.
        let mut c = CutTools::new(&Process::Deposit { power: 1000.0 });
        assert!(c.hold(&cut(1), 0) && c.hold(&cut(2), 0));
    }
}
