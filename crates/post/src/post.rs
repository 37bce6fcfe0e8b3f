//! The post: the intended path → joint moves → dialect text.

use std::io::Write;

use lampost_gcode::emit::round_half_away;
use lampost_gcode::{parse_line, Dialect, EmitOptions, Emitter, Units};
use lampost_kinematics::trig::sin_cos_deg;
use lampost_kinematics::{Affine, Machine, Units as MUnits};
use nalgebra::Vector3;

use crate::error::PostError;
use crate::intended::{Intended, IntendedOptions, Orient, Section, Step, StepKind};
use crate::safety::{SafeHeights, WorkBounds};
use crate::verify::ArcPoints;

/// Output dialect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PostDialect {
    /// FADAL: `%` framing, `O` number, G70/G71, forced decimal points.
    Fadal,
    /// Plain ISO/RS274 (what LinuxCNC reads): G20/G21.
    Iso,
    /// The NRC cell's controller: ISO words with N numbers on every block (assumed; the
    /// paper prints no program).
    Nrc,
}

/// What the head does.
#[derive(Debug, Clone, PartialEq)]
pub enum Process {
    /// Laser deposition: feed moves deposit, rapids travel with the laser off.
    Deposit {
        /// Laser power (in the machine's power word).
        power: f64,
    },
    /// Machining with the spindle.
    Machine {
        /// Tool to change to (T… M6).
        tool: Option<u32>,
        /// Tool length offset register (FADAL `G43 H…`).
        length_offset: Option<u32>,
        /// Work offset word, e.g. `E1` (FADAL fixture offset) or `G54`.
        work_offset: Option<String>,
        /// Spindle speed.
        spindle: f64,
        /// Coolant on.
        coolant: bool,
    },
}

/// Post settings.
#[derive(Debug, Clone)]
pub struct PostConfig {
    /// Head index in the machine.
    pub head: usize,
    /// Process.
    pub process: Process,
    /// Dialect.
    pub dialect: PostDialect,
    /// N numbering (start, step).
    pub renumber: Option<(u64, u64)>,
    /// Chord tolerance for linearised arcs (machine units).
    pub tolerance: f64,
    /// Intended-path settings.
    pub intended: IntendedOptions,
    /// Starting rotary position (file order), for choosing solutions.
    pub near: [f64; 2],
    /// Program number (FADAL O word).
    pub program_number: u32,
    /// Header text: what was posted and how.
    pub header: Vec<String>,
    /// The largest distance a written feed point may have from the intended path.
    pub verify_tolerance: f64,
    /// Work besides the program's own feed tips (a part or stock), part frame: the safe
    /// heights clear it too.
    pub work: Option<crate::safety::WorkBounds>,
}

/// What a post did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PostReport {
    /// Blocks of motion written.
    pub moves: usize,
    /// Warnings (with input lines).
    pub warnings: Vec<String>,
    /// Range used per joint, file order: (name, min, max).
    pub limits_used: Vec<(String, f64, f64)>,
    /// Byte offsets in the output where the program may be cut (before travel, laser off).
    pub split_points: Vec<u64>,
    /// Byte offset where the motion body starts and ends.
    pub body: (u64, u64),
    /// Rotary positions used, in order (file order).
    pub indexes: Vec<[f64; 2]>,
    /// The in-process verification of every written feed point.
    pub verify: crate::verify::VerifyReport,
}

/// The machine's length units as the G-code layer names them.
pub(crate) fn program_units(m: &Machine) -> Units {
    match m.units {
        MUnits::Inch => Units::Inch,
        MUnits::Mm => Units::Mm,
    }
}

/// An emitter for the configured dialect (the NRC dialect numbers every block).
pub(crate) fn emitter<W: Write>(out: W, cfg: &PostConfig, units: Units) -> Emitter<W> {
    let (dialect, renumber) = match cfg.dialect {
        PostDialect::Fadal => (Dialect::Fadal, cfg.renumber),
        PostDialect::Iso => (Dialect::Iso, cfg.renumber),
        PostDialect::Nrc => (Dialect::Iso, Some(cfg.renumber.unwrap_or((10, 10)))),
    };
    Emitter::new(
        out,
        EmitOptions {
            dialect: Some(dialect),
            renumber,
            suppress_modal: true,
            units,
        },
    )
}

/// The axis letters, file order.
pub(crate) fn axis_letters(m: &Machine) -> [u8; 5] {
    let names = m.axis_names();
    let letter = |n: &str| n.bytes().next().map_or(b'?', |b| b.to_ascii_uppercase());
    [
        letter(names[0]),
        letter(names[1]),
        letter(names[2]),
        letter(names[3]),
        letter(names[4]),
    ]
}

/// The program number and header comments, then the modal preamble (units, absolute,
/// per-minute feed, XY plane, no compensation, no canned cycle).
pub(crate) fn write_header<W: Write>(
    em: &mut Emitter<W>,
    cfg: &PostConfig,
    units: Units,
) -> Result<(), PostError> {
    if cfg.dialect == PostDialect::Fadal {
        em.program_number(
            cfg.program_number,
            Some(&comment_text(cfg.header.first().map_or("", String::as_str)).to_uppercase()),
        )?;
        for h in cfg.header.iter().skip(1) {
            em.raw_line(&format!("({})", comment_text(h).to_uppercase()))?;
        }
    } else {
        for h in &cfg.header {
            em.raw_line(&format!("({})", comment_text(h)))?;
        }
    }
    let units_code = match (cfg.dialect, units) {
        (PostDialect::Fadal, Units::Inch) => 70.0,
        (PostDialect::Fadal, Units::Mm) => 71.0,
        (_, Units::Inch) => 20.0,
        (_, Units::Mm) => 21.0,
    };
    em.words(
        &[
            (b'G', units_code),
            (b'G', 90.0),
            (b'G', 94.0),
            (b'G', 17.0),
            (b'G', 40.0),
            (b'G', 80.0),
        ],
        None,
    )?;
    Ok(())
}

/// Text safe inside a `( … )` comment on one line: parentheses are dropped, line breaks
/// and other control characters (from machine names, file names, header text) become
/// spaces, so
/// no text can close the comment or start a block of its own.
pub fn comment_text(s: &str) -> String {
    s.chars()
        .filter(|&c| c != '(' && c != ')')
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect()
}

/// Words of a code string from the machine file (`"M3"`, `"M71"`, `"G43 H1"`).
pub(crate) fn code_words(text: &str) -> Result<Vec<(u8, f64)>, PostError> {
    if text.trim().is_empty() {
        return Ok(Vec::new());
    }
    let b = parse_line(text.as_bytes(), 1, 0).map_err(|d| {
        PostError::Options(format!("machine file process code `{text}`: {}", d.kind))
    })?;
    Ok(b.words().map(|w| (w.letter, w.value)).collect())
}

struct Writer<'m, W: Write> {
    em: Emitter<W>,
    m: &'m Machine,
    letters: [u8; 5],
    report: PostReport,
    rot: Option<[f64; 2]>,
    /// The joints map of `rot` (of 0 before the first index).
    jmap: Affine,
    /// (sin, cos) of `rot`.
    rot_sc: [(f64, f64); 2],
    branch: Option<i8>,
    laser: bool,
    pos: Option<[f64; 3]>,
    /// The last written linear words, in output resolution units.
    written: [Option<i64>; 3],
    /// The feed step being written, for the in-process verification.
    step: Option<Step>,
    /// (rotary, tip map of it as written), for forward kinematics.
    fk_cache: ([f64; 2], Affine),
    /// The tool axis (part frame) at the written rotary, with `fk_cache`.
    fk_axis: Vector3<f64>,
    /// The current section's orientation rule and its layer's program +Z.
    orient: Orient,
    program_z: Vector3<f64>,
    /// The intended tool axis for the current orientation: (orientation, axis).
    want_axis: Option<(Orient, Vector3<f64>)>,
    /// The last tool-axis comparison: (written axis, intended axis, angle in degrees).
    axis_err: Option<(Vector3<f64>, Vector3<f64>, f64)>,
    head: usize,
    tol: f64,
    /// 10^decimals of the linear words.
    scale: f64,
    /// A point planned on the reading thread: (joints, is the step's end, its check).
    planned_check: Option<([f64; 3], bool, EndCheck)>,
    /// The safe heights, and that of the table position in force.
    heights: SafeHeights<'m>,
    safe: f64,
    /// The head is down at the end of a feed (a lift comes before any travel).
    in_run: bool,
}

impl<W: Write> Writer<'_, W> {
    /// Bytes of output so far (finished lines).
    fn offset(&self) -> u64 {
        self.em.position()
    }

    fn words(&mut self, w: &[(u8, f64)], comment: Option<&str>) -> Result<(), PostError> {
        self.em.words(w, comment).map_err(PostError::from)
    }

    /// Laser and powder off, if the laser is on.
    fn laser_off(
        &mut self,
        laser_off: &[(u8, f64)],
        powder_off: &[(u8, f64)],
    ) -> Result<(), PostError> {
        if self.laser {
            self.words(laser_off, None)?;
            self.words(powder_off, None)?;
            self.laser = false;
        }
        Ok(())
    }

    /// Check a written feed point: the joints as the text gives them (rounded to the
    /// output resolution), through forward kinematics, against the intended move.
    fn verify_point(&mut self, x: &[f64; 3], is_end: bool) -> Result<(), PostError> {
        // The fields used, not the whole step (a copy of it costs as much as the check).
        let Some((line, orient, program_z)) = self
            .step
            .as_ref()
            .map(|s| (s.line, self.orient, self.program_z))
        else {
            return Ok(());
        };
        let rot = self.rot.unwrap_or([0.0; 2]);
        if self.fk_cache.0 != rot {
            let (_, inv) = written_rotary(&rot);
            self.fk_cache = (rot, self.m.tip_map(&inv, self.head));
            self.fk_axis = self.m.machine_to_part_sc(&inv, &self.m.tool_axis)
                - self.m.machine_to_part_sc(&inv, &Vector3::zeros());
        }
        let err = match self.planned_check {
            // Worked out on the reading thread, for these very joints (with the same
            // end-or-path rule).
            Some((j, end, e)) if end == is_end && j == *x => e,
            _ => {
                let tip = written_tip(&self.fk_cache.1, self.scale, x);
                match &self.step {
                    Some(step) if is_end => (tip - step.end).norm(),
                    Some(step) => crate::verify::dist_to(step, &tip),
                    None => 0.0,
                }
            }
        };
        if err > self.tol {
            let tip = written_tip(&self.fk_cache.1, self.scale, x);
            return Err(PostError::Verify(format!(
                "input line {}: a written point ({:.5}, {:.5}, {:.5}) is {err:.3e} from the intended path (tolerance {:.1e})",
                line, tip.x, tip.y, tip.z, self.tol
            )));
        }
        let axis = self.fk_axis;
        let want = match self.want_axis {
            Some((o, a)) if o == orient && (matches!(o, Orient::Index(_)) || a == program_z) => a,
            _ => {
                self.axis_err = None;
                let a = match orient {
                    Orient::ToolAxis => program_z.normalize(),
                    Orient::Index(r) => {
                        self.m
                            .forward(
                                &lampost_kinematics::Joints {
                                    linear: [0.0; 3],
                                    rotary: r,
                                },
                                self.head,
                            )
                            .axis
                    }
                };
                self.want_axis = Some((orient, a));
                a
            }
        };
        // The axis error changes only with the rotaries or the intended axis.
        let ang = match self.axis_err {
            Some((a, w, e)) if a == axis && w == want => e,
            _ => {
                let e = axis.cross(&want).norm().atan2(axis.dot(&want)).to_degrees();
                self.axis_err = Some((axis, want, e));
                e
            }
        };
        let v = &mut self.report.verify;
        v.compared += 1;
        if err > v.max_position_error {
            v.max_position_error = err;
            v.worst_line = line;
        }
        v.max_axis_error_deg = v.max_axis_error_deg.max(ang);
        if ang > 0.01 {
            return Err(PostError::Verify(format!(
                "input line {}: the tool axis is {ang:.4}° off",
                line
            )));
        }
        Ok(())
    }

    fn note_limits(&mut self, joints: &[f64; 5]) {
        for (k, v) in joints.iter().enumerate() {
            let e = &mut self.report.limits_used[k];
            e.1 = e.1.min(*v);
            e.2 = e.2.max(*v);
        }
    }

    fn check(&self, file: &str, line: u32, x: &[f64; 3], rot: &[f64; 2]) -> Result<(), PostError> {
        for (l, &v) in self.m.linear.iter().zip(x) {
            if !v.is_finite() || v < l.limits.0 - 1e-9 || v > l.limits.1 + 1e-9 {
                return Err(PostError::Limit {
                    file: file.to_string(),
                    line,
                    axis: l.name.clone(),
                    value: v,
                    lo: l.limits.0,
                    hi: l.limits.1,
                });
            }
        }
        for (r, &v) in self.m.rotary.iter().zip(rot) {
            if !r.within(v) {
                let (lo, hi) = r.limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
                return Err(PostError::Limit {
                    file: file.to_string(),
                    line,
                    axis: r.name.clone(),
                    value: v,
                    lo,
                    hi,
                });
            }
        }
        Ok(())
    }

    /// The safe-height invariant for a rapid to `x` from where the head is: only a
    /// vertical move (the lift off an end, the approach onto a start) may go below the
    /// safe height. (Checked on the values as written.)
    fn check_rapid(&self, file: &str, line: u32, x: &[f64; 3]) -> Result<(), PostError> {
        let q = |v: f64| round_half_away(v * self.scale);
        let vertical = self
            .pos
            .is_some_and(|p| q(p[0]) == q(x[0]) && q(p[1]) == q(x[1]));
        let low = |z: f64| q(z) < q(self.safe);
        if !vertical && (low(x[2]) || self.pos.is_some_and(|p| low(p[2]))) {
            return Err(PostError::Verify(format!(
                "{file}:{line}: a rapid to ({:.4}, {:.4}, {:.4}) travels below the safe height {:.4}",
                x[0], x[1], x[2], self.safe
            )));
        }
        Ok(())
    }

    /// Raise the head to the safe height where it is (the lift off an end), or write
    /// the height alone when the position is not known yet (the program's first move).
    fn lift(&mut self, file: &str, line: u32) -> Result<(), PostError> {
        let z = self.safe;
        match self.pos {
            Some(p) => {
                if round_half_away(p[2] * self.scale) < round_half_away(z * self.scale) {
                    self.linear(0.0, &[p[0], p[1], z], None, file, line, false)?;
                }
            }
            None => {
                self.words(&[(b'G', 0.0), (self.letters[2], z)], None)?;
                self.written[2] = Some(round_half_away(z * self.scale) as i64);
                self.report.moves += 1;
            }
        }
        Ok(())
    }

    /// Write a straight move to joints `x`. A feed point is verified against the step
    /// being written: as its end when `step_end` (the stricter test), else as a point on
    /// its path.
    #[allow(clippy::too_many_arguments)]
    fn linear(
        &mut self,
        g: f64,
        x: &[f64; 3],
        feed: Option<f64>,
        file: &str,
        line: u32,
        step_end: bool,
    ) -> Result<(), PostError> {
        let rot = self.rot.unwrap_or([0.0; 2]);
        // A rapid to where the head already is says nothing.
        if g == 0.0
            && self
                .pos
                .is_some_and(|p| (0..3).all(|k| (p[k] - x[k]).abs() < 1e-12))
        {
            return Ok(());
        }
        self.check(file, line, x, &rot)?;
        if g == 0.0 {
            self.check_rapid(file, line, x)?;
        }
        self.note_limits(&[x[0], x[1], x[2], rot[0], rot[1]]);
        // Modal suppression: an axis word equal (as written) to the last one is left out.
        let mut w = [(0u8, 0.0f64, 0i64); 3];
        let mut n = 0;
        for (k, &v) in x.iter().enumerate() {
            let q = round_half_away(v * self.scale) as i64;
            if self.written[k] != Some(q) {
                self.written[k] = Some(q);
                w[n] = (self.letters[k], v, q);
                n += 1;
            }
        }
        if n == 0 && g == 1.0 {
            // A feed to where the head is (as written): keep one axis so the block moves
            // (after the feed word, as posts have always written it).
            let mut v = vec![(b'G', g)];
            v.extend(feed.map(|f| (b'F', f)));
            v.push((self.letters[0], x[0]));
            self.words(&v, None)?;
        } else {
            self.em
                .motion(g, &w[..n], self.scale, feed)
                .map_err(PostError::from)?;
        }
        if g != 0.0 {
            self.verify_point(x, step_end)?;
        }
        self.pos = Some(*x);
        self.report.moves += 1;
        Ok(())
    }
}

/// The safe height `h` at table position `rot` must be within the Z travel.
pub(crate) fn check_height(
    heights: &SafeHeights<'_>,
    h: f64,
    file: &str,
    line: u32,
    rot: &[f64; 2],
) -> Result<(), PostError> {
    if !h.is_finite() || h > heights.z_limit() + 1e-9 {
        return Err(PostError::SafeHeight {
            file: file.to_string(),
            line,
            height: h,
            limit: heights.z_limit(),
            rot: *rot,
        });
    }
    Ok(())
}

/// Rotary positions and the sine and cosine of each.
type RotaryTrig = ([f64; 2], [(f64, f64); 2]);

/// The joints that put the head over part point `p`, by the index's joints map
/// ([`Machine::joints_map`]).
#[inline(always)]
pub(crate) fn joints(map: &Affine, p: &Vector3<f64>) -> [f64; 3] {
    let q = map.apply(p);
    [q.x, q.y, q.z]
}

/// The points of a flat arc in joint space where X or Y is extreme: where the circle
/// about `c` through `start` crosses the X and Y directions within the sweep (turning
/// counter-clockwise in joint X/Y when `ccw`; the ends are checked by the caller). Z
/// along a helix is between the ends'.
fn arc_extremes(
    start: &[f64; 3],
    end: &[f64; 3],
    c: &[f64; 3],
    ccw: bool,
    sweep: f64,
) -> impl Iterator<Item = [f64; 3]> {
    let (rx, ry) = (start[0] - c[0], start[1] - c[1]);
    let r = (rx * rx + ry * ry).sqrt();
    let a0 = lampost_kinematics::trig::atan2_deg(ry, rx);
    let sweep_deg = sweep.to_degrees();
    let z = start[2].max(end[2]);
    let (cx, cy) = (c[0], c[1]);
    (0..4).filter_map(move |k| {
        let dir = 90.0 * f64::from(k);
        // How far along the turn the direction `dir` comes, in [0, 360).
        let along = if ccw { dir - a0 } else { a0 - dir }.rem_euclid(360.0);
        (along <= sweep_deg).then(|| {
            let (s, co) = lampost_kinematics::trig::sin_cos_deg(dir);
            [cx + r * co, cy + r * s, z]
        })
    })
}

/// The rotary position as written (to the output's 0.001°), and the (sin, cos) of minus
/// each angle, for forward kinematics of the written program.
fn written_rotary(rot: &[f64; 2]) -> RotaryTrig {
    let rw = [
        round_half_away(rot[0] * 1e3) / 1e3,
        round_half_away(rot[1] * 1e3) / 1e3,
    ];
    let a = sin_cos_deg(rw[0]);
    let b = sin_cos_deg(rw[1]);
    (rw, [(-a.0, a.1), (-b.0, b.1)])
}

/// The tool tip where the joints `x` put it, as the text gives them (rounded to the
/// output resolution `scale`), by the written index's tip map ([`Machine::tip_map`]).
#[inline(always)]
pub(crate) fn written_tip(tips: &Affine, scale: f64, x: &[f64; 3]) -> Vector3<f64> {
    tips.apply(&Vector3::new(
        round_half_away(x[0] * scale) / scale,
        round_half_away(x[1] * scale) / scale,
        round_half_away(x[2] * scale) / scale,
    ))
}

/// The joints map of `rot` and the tip map of `rot` as written.
fn index_maps(m: &Machine, head: usize, rot: &[f64; 2]) -> (Affine, Affine) {
    let sc = [sin_cos_deg(rot[0]), sin_cos_deg(rot[1])];
    (
        m.joints_map(&sc, head),
        m.tip_map(&written_rotary(rot).1, head),
    )
}

/// What the reading thread works out ahead for a step under a fixed index: the joints
/// of its end and, for a feed, how far the written end lands from the intended one.
/// The writer uses them when its table position is the same `rot` (it always is for an
/// index; it re-solves otherwise).
#[derive(Debug, Clone, Copy)]
struct PlannedEnd {
    joints: [f64; 3],
    /// The end's check, for feeds.
    check: Option<EndCheck>,
    /// For an arc the index does not keep: its chord points, in the batch's `points`.
    chords: (u32, u32),
}

/// A point written for a step, planned with its check (as [`Writer::verify_point`]
/// would make it: against the end for the last point, against the path before).
pub(crate) type PlannedPoint = ([f64; 3], EndCheck);

/// Steps passed from the reading thread to the writing one, with the chord points
/// planned for them.
struct Batch {
    steps: Vec<Result<Planned, PostError>>,
    points: Vec<PlannedPoint>,
}

/// How an arc is written under a table position: kept as an arc (its plane is the
/// machine's XY plane, counter-clockwise in joint X/Y when `ccw`), or linearised into
/// `chords` straight moves to the chord tolerance.
#[derive(Debug, Clone, Copy)]
enum ArcWay {
    Kept { ccw: bool },
    Chords(usize),
}

fn arc_way(
    m: &Machine,
    sc: &[(f64, f64); 2],
    step: &Step,
    center: &Vector3<f64>,
    normal: &Vector3<f64>,
    sweep: f64,
    tolerance: f64,
) -> ArcWay {
    let n_m = m.part_to_machine_sc(sc, normal) - m.part_to_machine_sc(sc, &Vector3::zeros());
    let handed = m.linear[0].sign * m.linear[1].sign * m.linear[0].dir.cross(&m.linear[1].dir).z;
    let keep = (n_m.x.abs() < 1e-9 && n_m.y.abs() < 1e-9)
        && sweep.abs() <= std::f64::consts::TAU + 1e-12
        && handed.abs() > 0.5;
    if keep {
        // Counter-clockwise seen from machine +Z, then in joint axes.
        let ccw_machine = (sweep > 0.0) == (n_m.z > 0.0);
        ArcWay::Kept {
            ccw: ccw_machine == (handed > 0.0),
        }
    } else {
        let r = (step.start - center).norm().max(1e-12);
        let seg_angle = 2.0 * (1.0 - (tolerance / r).min(1.0)).acos();
        ArcWay::Chords(((sweep.abs() / seg_angle.max(1e-6)).ceil() as usize).clamp(1, 100_000))
    }
}

/// How far a written point lands from the intended path (its check, see
/// [`PlannedPoint`]).
pub(crate) type EndCheck = f64;

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
        let check = (!matches!(step.kind, StepKind::Rapid | StepKind::Retract))
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

/// A step and what the reading thread planned for it.
type Planned = (Step, Option<PlannedEnd>);

/// Output resolution factor of the linear words: 10^decimals.
fn linear_scale(units: Units) -> f64 {
    match units {
        Units::Inch => 1e4,
        Units::Mm => 1e3,
    }
}

/// Steps handed from the reading thread to the writing one at a time.
const BATCH: usize = 1024;

/// Post `sections` for `machine` to `out`.
///
/// Two threads: one reads, parses and interprets the input into intended steps (the
/// [`Intended`] iterator), the other solves, writes and verifies them, in order; batches
/// of [`BATCH`] steps pass between them over a bounded channel (at most four in flight,
/// so memory stays flat). The output is the same as one thread's, byte for byte: the
/// writing side consumes the steps in input order. An error on either side stops both.
pub fn post<W: Write>(
    machine: &Machine,
    sections: &[Section],
    cfg: &PostConfig,
    out: W,
    progress: impl FnMut(usize),
) -> Result<PostReport, PostError> {
    let opts = cfg.intended;
    // The work, before anything is written: the safe heights need all of it.
    let mut work = WorkBounds::of_program(machine, sections, opts)?;
    if let Some(extra) = &cfg.work {
        work.union(extra);
    }
    let heights = SafeHeights::new(machine, cfg.head, work)?;
    let mut planner = Planner {
        m: machine,
        sections,
        head: cfg.head,
        scale: linear_scale(program_units(machine)),
        tolerance: cfg.tolerance,
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
                let fresh = || {
                    back_rx.try_recv().unwrap_or_else(|_| Batch {
                        steps: Vec::with_capacity(BATCH),
                        points: Vec::new(),
                    })
                };
                let mut batch = fresh();
                for step in Intended::new(machine, sections, opts) {
                    let failed = step.is_err();
                    let planned = step.map(|s| {
                        let end = planner.plan(&s, &mut batch.points);
                        (s, end)
                    });
                    batch.steps.push(planned);
                    if batch.steps.len() == BATCH || failed {
                        let full = std::mem::replace(&mut batch, fresh());
                        // A closed channel: the writer stopped (an error); so do we.
                        if tx.send(full).is_err() || failed {
                            return;
                        }
                    }
                }
                if !batch.steps.is_empty() {
                    let _ = tx.send(batch);
                }
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
        if let Err(panic) = reader.join() {
            std::panic::resume_unwind(panic);
        }
        result
    })
}

/// [`post`] over batches of steps, on the calling thread.
#[allow(clippy::too_many_arguments)]
fn post_steps<W: Write>(
    machine: &Machine,
    sections: &[Section],
    cfg: &PostConfig,
    heights: SafeHeights<'_>,
    out: W,
    mut progress: impl FnMut(usize),
    batches: impl Iterator<Item = Batch>,
    mut give_back: impl FnMut(Batch),
) -> Result<PostReport, PostError> {
    let units = program_units(machine);
    let em = emitter(out, cfg, units);
    let names = machine.axis_names();
    let mut w = Writer {
        em,
        m: machine,
        letters: axis_letters(machine),
        report: PostReport {
            limits_used: names
                .iter()
                .map(|n| ((*n).to_string(), f64::INFINITY, f64::NEG_INFINITY))
                .collect(),
            ..PostReport::default()
        },
        rot: None,
        jmap: index_maps(machine, cfg.head, &[0.0; 2]).0,
        rot_sc: [(0.0, 1.0); 2],
        branch: None,
        laser: false,
        pos: None,
        written: [None; 3],
        step: None,
        fk_cache: ([f64::NAN; 2], index_maps(machine, cfg.head, &[0.0; 2]).1),
        fk_axis: Vector3::z(),
        orient: Orient::ToolAxis,
        program_z: Vector3::z(),
        want_axis: None,
        axis_err: None,
        head: cfg.head,
        tol: cfg.verify_tolerance,
        scale: linear_scale(units),
        planned_check: None,
        safe: heights.at(&cfg.near),
        heights,
        in_run: false,
    };
    let p = &machine.def.process;
    let laser_on = code_words(&p.laser_on)?;
    let laser_off = code_words(&p.laser_off)?;
    let powder_on = code_words(&p.powder_on)?;
    let powder_off = code_words(&p.powder_off)?;
    let power_letter = p
        .laser_power_word
        .bytes()
        .next()
        .unwrap_or(b'S')
        .to_ascii_uppercase();
    write_header(&mut w.em, cfg, units)?;
    if let Process::Machine {
        tool,
        length_offset,
        work_offset,
        spindle,
        coolant,
    } = &cfg.process
    {
        if let Some(t) = tool {
            let mut v = vec![(b'T', f64::from(*t))];
            v.extend(code_words(&p.tool_change)?);
            w.words(&v, None)?;
        }
        if let Some(o) = work_offset {
            w.words(&code_words(o)?, Some("WORK OFFSET"))?;
        }
        if let Some(h) = length_offset {
            w.words(&[(b'G', 43.0), (b'H', f64::from(*h))], None)?;
        }
        let mut v = vec![(b'S', *spindle)];
        v.extend(code_words(&p.spindle_on)?);
        w.words(&v, None)?;
        if *coolant {
            w.words(&code_words(&p.coolant_on)?, None)?;
        }
    }
    // How far above a feed's start the rapid approach stops: 0.1 in / 2.5 mm.
    let approach_lift = crate::safety::approach_lift(machine);
    let z_axis = 2usize;
    let head = cfg.head;
    let mut cur_key: Option<(usize, usize)> = None;
    let mut need_approach = true;
    let mut retract_noted: Option<u32> = None;
    let mut arc_warned: Option<usize> = None;
    let mut prev_end: Option<(Vector3<f64>, [f64; 3], [f64; 2])> = None;
    w.report.body.0 = w.offset();
    let mut count = 0usize;
    for batch in batches {
        let mut batch = batch;
        let Batch { steps, points } = &mut batch;
        for step in steps.drain(..) {
            let (step, planned): Planned = step?;
            if count % 4096 == 0 {
                progress(count);
            }
            count += 1;
            let file = &sections[step.section].name;
            let key = (step.section, step.layer);
            if cur_key != Some(key) {
                cur_key = Some(key);
                w.orient = step.orient(sections);
                w.program_z = step.program_z(sections);
                // Choose the rotaries for this section/layer.
                let rot = match w.orient {
                    Orient::Index(r) => {
                        for (i, ax) in machine.rotary.iter().enumerate() {
                            if !ax.within(r[i]) {
                                let (lo, hi) =
                                    ax.limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
                                return Err(PostError::Limit {
                                    file: file.clone(),
                                    line: step.line,
                                    axis: ax.name.clone(),
                                    value: r[i],
                                    lo,
                                    hi,
                                });
                            }
                        }
                        r
                    }
                    Orient::ToolAxis => {
                        let near = w.rot.unwrap_or(cfg.near);
                        let sols = machine.orientations(&w.program_z, &near).map_err(|err| {
                            PostError::Kin {
                                context: format!("{file}:{}: ", step.line),
                                err,
                            }
                        })?;
                        let same = sols.iter().find(|s| {
                            s.within_limits
                                && w.branch
                                    .is_none_or(|b| s.branch == 0 || b == 0 || s.branch == b)
                        });
                        let pick = match same {
                            Some(s) => *s,
                            None => match sols.iter().find(|s| s.within_limits) {
                                Some(s) => {
                                    w.report.warnings.push(format!("{file}:{}: the rotary branch flips here; the tool retracts and re-approaches", step.line));
                                    *s
                                }
                                None => {
                                    let names: Vec<String> = machine
                                        .rotary
                                        .iter()
                                        .map(|r| format!("{} {:?}", r.name, r.limits))
                                        .collect();
                                    let cands: Vec<String> = sols
                                        .iter()
                                        .map(|s| {
                                            format!(
                                                "{} = {:.3}°, {} = {:.3}°",
                                                machine.rotary[0].name,
                                                s.rotary[0],
                                                machine.rotary[1].name,
                                                s.rotary[1]
                                            )
                                        })
                                        .collect();
                                    return Err(PostError::Kin {
                                    context: format!("{file}:{}: ", step.line),
                                    err: lampost_kinematics::KinError::Unreachable {
                                        what: format!("no orientation within the rotary limits ({}) turns the program's +Z ({:.4}, {:.4}, {:.4}) to the tool axis; candidates {}", names.join(", "), w.program_z.x, w.program_z.y, w.program_z.z, cands.join("; ")),
                                    },
                                });
                                }
                            },
                        };
                        w.branch = Some(pick.branch);
                        pick.rotary
                    }
                };
                let changed = w
                    .rot
                    .is_none_or(|r| (r[0] - rot[0]).abs() > 1e-9 || (r[1] - rot[1]).abs() > 1e-9);
                if changed {
                    // Laser off, retract, then index: never a rotary move mid-cut, and the
                    // head high enough for every table position the move passes through.
                    w.laser_off(&laser_off, &powder_off)?;
                    let split = w.offset();
                    w.report.split_points.push(split);
                    let from = w.rot.unwrap_or(cfg.near);
                    w.safe = w.heights.over_move(&from, &rot);
                    check_height(&w.heights, w.safe, file, step.line, &rot)?;
                    w.lift(file, step.line)?;
                    w.rot = Some(rot);
                    w.jmap = index_maps(machine, head, &rot).0;
                    w.rot_sc = [sin_cos_deg(rot[0]), sin_cos_deg(rot[1])];
                    w.words(
                        &[(b'G', 0.0), (w.letters[3], rot[0]), (w.letters[4], rot[1])],
                        Some("INDEX"),
                    )?;
                    w.report.indexes.push(rot);
                    w.report.moves += 1;
                    w.safe = w.heights.at(&rot);
                    check_height(&w.heights, w.safe, file, step.line, &rot)?;
                    w.in_run = false;
                    need_approach = true;
                }
            }
            let rot = w.rot.unwrap_or([0.0; 2]);
            let jm = w.jmap;
            // A move starts where the last one ended: reuse its joints (same table position).
            let start = match prev_end {
                Some((p, j, r)) if p == step.start && r == rot => j,
                _ => joints(&jm, &step.start),
            };
            // Planned for the step's own index: usable when that is where the table is.
            let planned = planned.filter(|_| matches!(w.orient, Orient::Index(r) if r == rot));
            let end = match planned {
                Some(p) => p.joints,
                None => joints(&jm, &step.end),
            };
            w.planned_check = planned.and_then(|p| p.check.map(|c| (p.joints, true, c)));
            prev_end = Some((step.end, end, rot));
            let travel = matches!(step.kind, StepKind::Rapid | StepKind::Retract);
            // The move being written, for the in-process verification (approach included).
            w.step = if travel { None } else { Some(step) };
            if travel {
                // Input travel is not written as it stands: the head lifts off the end of
                // the run to the safe height, and is brought over the next start from there.
                if step.kind == StepKind::Retract && retract_noted != Some(step.line) {
                    retract_noted = Some(step.line);
                    w.report.warnings.push(format!(
                        "{file}:{}: a machine-coordinate move (G53/G28/G30) that only moves Z is posted as a retract to the safe height",
                        step.line
                    ));
                }
                w.laser_off(&laser_off, &powder_off)?;
                if w.in_run {
                    let split = w.offset();
                    w.report.split_points.push(split);
                    w.lift(file, step.line)?;
                    w.in_run = false;
                }
                need_approach = true;
                continue;
            }
            let at_start = w
                .pos
                .is_some_and(|p| (0..3).all(|k| (p[k] - start[k]).abs() <= 1e-6));
            if need_approach || !at_start {
                // Off the last end (if the head is down there), over the start at the safe
                // height, straight down to just above it, then in at the feed rate.
                w.laser_off(&laser_off, &powder_off)?;
                if w.in_run {
                    let split = w.offset();
                    w.report.split_points.push(split);
                    w.lift(file, step.line)?;
                }
                let mut above = start;
                above[z_axis] = w.pos.map_or(w.safe, |p| p[z_axis].max(w.safe));
                w.linear(0.0, &above, None, file, step.line, false)?;
                let mut near_start = start;
                near_start[z_axis] = (start[z_axis] + approach_lift).min(w.safe);
                w.linear(0.0, &near_start, None, file, step.line, false)?;
                w.linear(1.0, &start, Some(step.feed), file, step.line, false)?;
                need_approach = false;
            }
            w.in_run = true;
            match step.kind {
                StepKind::Rapid | StepKind::Retract => {}
                StepKind::Feed | StepKind::Arc { .. } => {
                    if let Process::Deposit { power } = cfg.process {
                        if step.deposit && !w.laser {
                            let mut v = laser_on.clone();
                            v.push((power_letter, power));
                            w.words(&v, None)?;
                            w.words(&powder_on, None)?;
                            w.laser = true;
                        } else if !step.deposit {
                            w.laser_off(&laser_off, &powder_off)?;
                        }
                    }
                    match step.kind {
                        StepKind::Arc {
                            center,
                            normal,
                            sweep,
                        } => {
                            // The arc stays an arc when its plane is the machine's XY plane.
                            let way = arc_way(
                                machine,
                                &w.rot_sc,
                                &step,
                                &center,
                                &normal,
                                sweep,
                                cfg.tolerance,
                            );
                            if let ArcWay::Kept { ccw } = way {
                                let c = joints(&jm, &center);
                                let g = if ccw { 3.0 } else { 2.0 };
                                let rot_now = w.rot.unwrap_or([0.0; 2]);
                                w.check(file, step.line, &end, &rot_now)?;
                                // Travel limits along the arc: its extreme points in X and Y.
                                for q in arc_extremes(&start, &end, &c, ccw, sweep.abs()) {
                                    w.check(file, step.line, &q, &rot_now)?;
                                }
                                w.note_limits(&[end[0], end[1], end[2], rot_now[0], rot_now[1]]);
                                let words = [
                                    (b'G', g),
                                    (w.letters[0], end[0]),
                                    (w.letters[1], end[1]),
                                    (w.letters[2], end[2]),
                                    (b'I', c[0] - start[0]),
                                    (b'J', c[1] - start[1]),
                                    (b'F', step.feed),
                                ];
                                w.words(&words, None)?;
                                // The arc's midpoint (joint space) and its end, as written.
                                let mid_part = step.at(0.5);
                                let mid = joints(&jm, &mid_part);
                                w.verify_point(&mid, false)?;
                                w.verify_point(&end, true)?;
                                let scale = w.scale;
                                for (slot, v) in w.written.iter_mut().zip(end) {
                                    *slot = Some(round_half_away(v * scale) as i64);
                                }
                                w.pos = Some(end);
                                w.report.moves += 1;
                            } else {
                                if arc_warned != Some(step.section) {
                                    arc_warned = Some(step.section);
                                    w.report.warnings.push(format!("{file}:{}: an arc in a plane the index does not keep is linearised (chord tolerance {})", step.line, cfg.tolerance));
                                }
                                let n = match way {
                                    ArcWay::Chords(n) => n,
                                    ArcWay::Kept { .. } => 1,
                                };
                                // Planned on the reading thread (same table position), or
                                // solved here.
                                let chords = planned
                                    .and_then(|p| {
                                        points.get(p.chords.0 as usize..p.chords.1 as usize)
                                    })
                                    .filter(|c| c.len() == n);
                                for k in 1..=n {
                                    let (q, check) = match chords {
                                        Some(c) => (c[k - 1].0, Some(c[k - 1].1)),
                                        None => (joints(&jm, &step.at(k as f64 / n as f64)), None),
                                    };
                                    w.planned_check = check.map(|c| (q, k == n, c));
                                    w.linear(1.0, &q, Some(step.feed), file, step.line, k == n)?;
                                }
                            }
                        }
                        _ => w.linear(1.0, &end, Some(step.feed), file, step.line, true)?,
                    }
                }
            }
        }
        points.clear();
        give_back(batch);
    }
    if w.report.moves == 0 {
        return Err(PostError::Empty(
            sections
                .first()
                .map_or_else(String::new, |s| s.name.clone()),
        ));
    }
    w.report.body.1 = w.offset();
    // Postamble.
    w.laser_off(&laser_off, &powder_off)?;
    if let Process::Machine { coolant, .. } = &cfg.process {
        if *coolant {
            w.words(&code_words(&p.coolant_off)?, None)?;
        }
        w.words(&code_words(&p.spindle_off)?, None)?;
    }
    w.lift("", 0)?;
    w.words(&code_words(&p.program_end)?, None)?;
    for e in w.report.limits_used.iter_mut() {
        if !e.1.is_finite() {
            e.1 = 0.0;
            e.2 = 0.0;
        }
    }
    w.report.verify.moves = w.report.moves;
    let report = w.report;
    w.em.finish()?;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::arc_extremes;

    /// The extremes found are those of a dense sampling of the arc (to the sampling's
    /// resolution), for arcs both ways, short and long, starting anywhere.
    #[test]
    fn arc_extremes_match_dense_sampling() {
        let c = [3.0, -2.0, 1.0];
        let r = 5.0;
        for start_deg in [0.0, 10.0, 89.0, 90.0, 135.0, 180.0, 271.0, 359.0] {
            for sweep_deg in [5.0, 45.0, 90.0, 170.0, 181.0, 270.0, 359.0, 360.0] {
                for ccw in [true, false] {
                    let a0 = f64::to_radians(start_deg);
                    let start = [c[0] + r * a0.cos(), c[1] + r * a0.sin(), 1.0];
                    let dir = if ccw { 1.0 } else { -1.0 };
                    let a1 = a0 + dir * f64::to_radians(sweep_deg);
                    let end = [c[0] + r * a1.cos(), c[1] + r * a1.sin(), 1.0];
                    let mut lo = [start[0].min(end[0]), start[1].min(end[1])];
                    let mut hi = [start[0].max(end[0]), start[1].max(end[1])];
                    for q in arc_extremes(&start, &end, &c, ccw, f64::to_radians(sweep_deg)) {
                        for k in 0..2 {
                            lo[k] = lo[k].min(q[k]);
                            hi[k] = hi[k].max(q[k]);
                        }
                    }
                    let (mut slo, mut shi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
                    for i in 0..=20_000 {
                        let a = a0 + dir * f64::to_radians(sweep_deg) * f64::from(i) / 2e4;
                        let p = [c[0] + r * a.cos(), c[1] + r * a.sin()];
                        for k in 0..2 {
                            slo[k] = slo[k].min(p[k]);
                            shi[k] = shi[k].max(p[k]);
                        }
                    }
                    for k in 0..2 {
                        let what =
                            format!("start {start_deg} sweep {sweep_deg} ccw {ccw} axis {k}");
                        assert!(
                            (lo[k] - slo[k]).abs() < 1e-6,
                            "{what}: {} vs {}",
                            lo[k],
                            slo[k]
                        );
                        assert!(
                            (hi[k] - shi[k]).abs() < 1e-6,
                            "{what}: {} vs {}",
                            hi[k],
                            shi[k]
                        );
                    }
                }
            }
        }
    }
}
