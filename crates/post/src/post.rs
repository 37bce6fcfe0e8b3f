//! The post: the intended path → joint moves → dialect text.

use std::io::Write;

use lampost_gcode::round_half_away;
use lampost_gcode::{parse_line, Dialect, EmitOptions, Emitter, Units};
use lampost_kinematics::trig::sin_cos_deg;
use lampost_kinematics::{Affine, Machine, Units as MUnits};
use nalgebra::Vector3;

use crate::error::PostError;
use crate::intended::{IntendedOptions, Orient, Section, Step, StepKind};
use crate::pipeline::{Batch, HeightUsed};
use crate::safety::SafeHeights;
use crate::writer::Writer;

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

impl Process {
    /// The process's numbers usable: the laser power or spindle speed a finite number, 0
    /// or more (the post refuses to write, `verify` to compare with, anything else).
    pub fn checked(&self) -> Result<&Process, PostError> {
        let (value, flag, what) = match self {
            Process::Deposit { power } => (*power, "--power", "the laser power"),
            Process::Machine { spindle, .. } => (*spindle, "--spindle", "the spindle speed"),
        };
        if value.is_finite() && value >= 0.0 {
            Ok(self)
        } else {
            Err(PostError::Options(format!(
                "{flag} {value}: {what} must be a finite number, 0 or more"
            )))
        }
    }
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
    /// The part as a mesh (part frame): no rapid's tip path and no head meets it (checked
    /// in-process on every rapid written). Its hull points belong in `work` too.
    pub part: Option<std::sync::Arc<crate::collide::PartMesh>>,
    /// The largest program the post may write, in bytes (a bound on output growth: a
    /// 300-turn helix linearised at a tilted index is thousands of lines); `None`: no
    /// bound.
    pub max_output_bytes: Option<u64>,
}

/// The head a process uses unless one is named: the laser for deposition, the spindle for
/// machining, else the machine's first head.
pub fn default_head(m: &Machine, deposit: bool) -> usize {
    m.head(if deposit { "laser" } else { "spindle" })
        .unwrap_or(0)
}

/// [`default_head`], where machining takes no head but a spindle: on a machine with no
/// head named `spindle` (the NRC cell has a laser and a sensor) machining is refused
/// rather than done with the first head, spindle codes and all. A head named by the user
/// is taken as named instead.
pub fn process_head(m: &Machine, deposit: bool) -> Result<usize, PostError> {
    if !deposit && m.head("spindle").is_err() {
        let heads: Vec<&str> = m.heads.iter().map(|h| h.name.as_str()).collect();
        return Err(PostError::Options(format!(
            "--process machine: {} has no spindle (no head named `spindle`; its heads: {}): post with --process deposit, or name the head that machines with --head NAME",
            m.name,
            heads.join(", ")
        )));
    }
    Ok(default_head(m, deposit))
}

impl PostConfig {
    /// The settings `lampost post` starts from for `process` on `m`: the laser head for
    /// deposition and the spindle for machining (else the first head); the FADAL dialect
    /// on a `fadal…` machine, NRC on an `nrc…` one, ISO otherwise; a chord tolerance of
    /// 0.0005 in or 0.01 mm and a verification tolerance twice that; programs read as
    /// FADAL-flavoured in the machine's units; the rotaries starting near 0; program 1000;
    /// no part, stock or size bound. Change any field before posting.
    pub fn new(m: &Machine, process: Process) -> PostConfig {
        let head = default_head(m, matches!(process, Process::Deposit { .. }));
        let tolerance = match m.units {
            lampost_kinematics::Units::Inch => 0.0005,
            lampost_kinematics::Units::Mm => 0.01,
        };
        let dialect = if m.name.starts_with("fadal") {
            PostDialect::Fadal
        } else if m.name.starts_with("nrc") {
            PostDialect::Nrc
        } else {
            PostDialect::Iso
        };
        PostConfig {
            head,
            process,
            dialect,
            renumber: None,
            tolerance,
            intended: IntendedOptions {
                convert_units: false,
                e_extrusion: false,
                flavor: lampost_gcode::Flavor::Fadal,
                units: None,
            },
            near: [0.0, 0.0],
            program_number: 1000,
            header: vec![format!(
                "lampost {} post for {}",
                env!("CARGO_PKG_VERSION"),
                m.name
            )],
            verify_tolerance: 2.0 * tolerance,
            work: None,
            part: None,
            max_output_bytes: None,
        }
    }
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
            units_given: true,
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

/// The largest FADAL program number (O9999).
pub const MAX_PROGRAM_NUMBER: u32 = 9999;

/// The program number and header comments, then the modal preamble (units, absolute,
/// per-minute feed, XY plane, no compensation, no canned cycle).
pub(crate) fn write_header<W: Write>(
    em: &mut Emitter<W>,
    cfg: &PostConfig,
    units: Units,
) -> Result<(), PostError> {
    if cfg.dialect == PostDialect::Fadal {
        if cfg.program_number > MAX_PROGRAM_NUMBER {
            return Err(PostError::Options(format!(
                "--program-number {}: a FADAL program number is O0 to O{MAX_PROGRAM_NUMBER}",
                cfg.program_number
            )));
        }
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
    // `%` too: a tape's end to a DNC sender or a FADAL, even inside a comment.
    s.chars()
        .filter(|&c| c != '(' && c != ')' && c != '%')
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
pub(crate) fn arc_extremes(
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
pub(crate) fn written_rotary(rot: &[f64; 2]) -> RotaryTrig {
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
pub(crate) fn index_maps(m: &Machine, head: usize, rot: &[f64; 2]) -> (Affine, Affine) {
    let sc = [sin_cos_deg(rot[0]), sin_cos_deg(rot[1])];
    (
        m.joints_map(&sc, head),
        m.tip_map(&written_rotary(rot).1, head),
    )
}

/// The chord tolerance arcs are linearised to: `cfg.tolerance`, or less where the
/// written points' rounding would carry a chord's middle past the verification tolerance.
/// (The middle of a written chord lies within the chord's sagitta plus the larger of its
/// ends' distances from the arc; an end is off by at most half a grid step on each
/// linear axis, √3/2 of a step; `verify` checks the middles.)
pub(crate) fn chord_tolerance(m: &Machine, cfg: &PostConfig) -> f64 {
    let grid = (0..3)
        .map(|k| m.linear[k].resolution)
        .fold(1.0 / linear_scale(program_units(m)), f64::max);
    let room = cfg.verify_tolerance - 0.5 * 3f64.sqrt() * grid;
    cfg.tolerance.min(room.max(0.05 * cfg.tolerance))
}

/// How an arc is written under a table position: kept as an arc (its plane is the
/// machine's XY plane, counter-clockwise in joint X/Y when `ccw`), or linearised into
/// `chords` straight moves to the chord tolerance.
#[derive(Debug, Clone, Copy)]
pub(crate) enum ArcWay {
    Kept { ccw: bool },
    Chords(usize),
}

pub(crate) fn arc_way(
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
        ArcWay::Chords(chord_count(step, center, sweep, tolerance))
    }
}

/// The most chords one arc is written with. An arc that needs more within the chord
/// tolerance (a helix of thousands of turns at a tilted index) is refused at its line:
/// fewer chords would leave the path between their points.
pub(crate) const MAX_CHORDS: usize = 100_000;

/// Chords for an arc of `sweep` radians about `center` within the chord `tolerance`, at
/// most [`MAX_CHORDS`] (see [`chords_needed`]).
pub(crate) fn chord_count(step: &Step, center: &Vector3<f64>, sweep: f64, tolerance: f64) -> usize {
    (chords_needed(step, center, sweep, tolerance).ceil() as usize).clamp(1, MAX_CHORDS)
}

/// How many chords keep an arc of `sweep` radians about `center` within the chord
/// `tolerance` (not rounded up, not bounded).
pub(crate) fn chords_needed(step: &Step, center: &Vector3<f64>, sweep: f64, tolerance: f64) -> f64 {
    let r = (step.start - center).norm().max(1e-12);
    let seg_angle = 2.0 * (1.0 - (tolerance / r).min(1.0)).acos();
    sweep.abs() / seg_angle.max(1e-6)
}

/// How far a written point lands from the intended path (its check, see
/// [`PlannedPoint`]).
pub(crate) type EndCheck = f64;

/// Output resolution factor of the linear words: 10^decimals.
pub(crate) fn linear_scale(units: Units) -> f64 {
    match units {
        Units::Inch => 1e4,
        Units::Mm => 1e3,
    }
}

/// [`crate::pipeline::post`] over batches of steps, on the calling thread: the rotaries of each section
/// or layer, travel as lift / traverse / approach, and each feed through the [`Writer`].
#[allow(clippy::too_many_arguments)]
pub(crate) fn post_steps<W: Write>(
    machine: &Machine,
    sections: &[Section],
    cfg: &PostConfig,
    heights: SafeHeights<'_>,
    out: W,
    mut progress: impl FnMut(usize),
    batches: impl Iterator<Item = Batch>,
    mut give_back: impl FnMut(Batch),
) -> Result<(PostReport, Vec<HeightUsed>), PostError> {
    let chord_tol = chord_tolerance(machine, cfg);
    let mut w = Writer::new(machine, cfg, heights, out)?;
    w.preamble(cfg)?;
    let mut cur_key: Option<(usize, usize)> = None;
    let mut need_approach = true;
    let mut retract_noted: Option<u32> = None;
    let mut arc_warned: Option<usize> = None;
    let mut round_warned: Option<usize> = None;
    let mut prev_end: Option<(Vector3<f64>, [f64; 3], [f64; 2])> = None;
    let mut count = 0usize;
    // The first move's (section, line), and whether any step cuts (a feed or an arc).
    let mut first: Option<(usize, u32)> = None;
    let mut cut = false;
    for batch in batches {
        let mut batch = batch;
        let Batch {
            steps,
            ends,
            points,
            error,
        } = &mut batch;
        for (step, &planned) in steps.iter().zip(ends.iter()) {
            if count % 4096 == 0 {
                progress(count);
            }
            count += 1;
            if step.start != step.end {
                first.get_or_insert((step.section as usize, step.line));
            }
            let file = &sections[step.section as usize].name;
            let key = (step.section as usize, step.layer);
            if cur_key != Some(key) {
                cur_key = Some(key);
                w.feed_check
                    .set_orientation(step.orient(sections), step.program_z(sections));
                let near = w.rot.unwrap_or(cfg.near);
                let (rot, branch) = crate::orient::rotaries(
                    machine,
                    w.feed_check.orient(),
                    &w.feed_check.program_z(),
                    &near,
                    w.branch,
                    file,
                    step.line,
                    &mut w.report.warnings,
                )?;
                if branch.is_some() {
                    w.branch = branch;
                }
                let changed = w
                    .rot
                    .is_none_or(|r| (r[0] - rot[0]).abs() > 1e-9 || (r[1] - rot[1]).abs() > 1e-9);
                if changed {
                    w.index(rot, cfg.near, file, step.line)?;
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
            let planned =
                planned.filter(|_| matches!(w.feed_check.orient(), Orient::Index(r) if r == rot));
            let end = match planned {
                Some(p) => p.joints,
                None => joints(&jm, &step.end),
            };
            w.feed_check.planned_check = planned.and_then(|p| p.check.map(|c| (p.joints, true, c)));
            prev_end = Some((step.end, end, rot));
            let travel = matches!(
                step.kind,
                StepKind::Rapid | StepKind::Retract | StepKind::Stop(_) | StepKind::ToolChange(_)
            );
            // The move being written, for the in-process verification (approach included).
            w.feed_check.step = if travel { None } else { Some(*step) };
            // A travel that goes nowhere from where the head stands in a run (a slicer's
            // `G1 Z0.3 F9000` at Z0.3 between two extrusions, as PrusaSlicer's spiral
            // vase writes at every layer) moves nothing: the run goes on, not lifted off
            // and started again over the same point (h62).
            let standing = step.kind == StepKind::Rapid
                && step.start == step.end
                && w.in_run
                && !need_approach
                && w.pos.is_some_and(|p| {
                    let here = w.on_grid(&start);
                    (0..3).all(|k| (p[k] - here[k]).abs() <= 1e-6)
                });
            if standing {
                continue;
            }
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
                match step.kind {
                    StepKind::Stop(kind) => w.stop(kind, file, step.line)?,
                    StepKind::ToolChange(change) => w.tool_change(change, file, step.line)?,
                    _ => w.travel(file, step.line)?,
                }
                need_approach = true;
                continue;
            }
            cut = true;
            w.holds_tool(step, file)?;
            let on_grid = w.on_grid(&start);
            let at_start = w
                .pos
                .is_some_and(|p| (0..3).all(|k| (p[k] - on_grid[k]).abs() <= 1e-6));
            if need_approach || !at_start {
                w.approach(&start, step.feed, file, step.line)?;
                need_approach = false;
            }
            w.process_for(cfg, step.deposit)?;
            match step.kind {
                StepKind::Arc {
                    center,
                    normal,
                    sweep,
                } => {
                    // The arc stays an arc when its plane is the machine's XY plane.
                    let way = arc_way(machine, &w.rot_sc, step, &center, &normal, sweep, chord_tol);
                    let center_j = joints(&jm, &center);
                    // An arc kept must read back as itself: one whose end rounds onto its
                    // start (or past it) at the output resolution would read as a full
                    // circle, or nearly one. It is written as chords instead.
                    let n = match way {
                        ArcWay::Kept { ccw }
                            if w.arc_reads_back(
                                &start,
                                &end,
                                &center_j,
                                ccw,
                                &joints(&jm, &step.at(0.5)),
                            ) =>
                        {
                            w.arc(step, &start, &end, &center_j, ccw, sweep, file)?;
                            None
                        }
                        ArcWay::Kept { .. } => {
                            if round_warned != Some(step.section as usize) {
                                round_warned = Some(step.section as usize);
                                w.report.warnings.push(format!("{file}:{}: an arc that would not read back as itself at the output resolution (its end rounding onto or past its start reads as a full circle, or nearly one; or its radii as written beyond the control's arc tolerance) is written as chords", step.line));
                            }
                            Some(chord_count(step, &center, sweep, chord_tol))
                        }
                        ArcWay::Chords(n) => {
                            if arc_warned != Some(step.section as usize) {
                                arc_warned = Some(step.section as usize);
                                w.report.warnings.push(format!("{file}:{}: an arc in a plane the index does not keep is linearised (chord tolerance {})", step.line, chord_tol));
                            }
                            Some(n)
                        }
                    };
                    if let Some(n) = n {
                        // Chords follow the circle of the start's radius, and the last
                        // one goes to the end: an end off that radius (LinuxCNC reads an
                        // arc whose radii differ by up to 0.0028 in as a spiral) would
                        // bend the last chord off the path by as much.
                        let radial = |p: &Vector3<f64>| {
                            let v = p - center;
                            (v - normal * normal.dot(&v)).norm()
                        };
                        let needed = chords_needed(step, &center, sweep, chord_tol);
                        if needed > MAX_CHORDS as f64 {
                            return Err(PostError::Unsupported {
                                file: file.to_string(),
                                line: step.line,
                                what: format!("the arc needs {needed:.0} chords to stay within the chord tolerance {} at this table position, more than {MAX_CHORDS} (fewer would leave the path between them): split it, keep it in the index's plane, or post with a larger --tolerance", chord_tol),
                            });
                        }
                        let off = (radial(&step.end) - radial(&step.start)).abs();
                        if off > cfg.tolerance {
                            return Err(PostError::Unsupported {
                                file: file.to_string(),
                                line: step.line,
                                what: format!("the arc's end is {off:.6} off the radius of its start, more than the chord tolerance {}: linearised at this table position, its chords would leave the path (write the arc's end on its circle, or post with a larger --tolerance)", cfg.tolerance),
                            });
                        }
                        // Planned on the reading thread (same table position), or solved
                        // here.
                        let chords = planned
                            .and_then(|p| points.get(p.chords.0 as usize..p.chords.1 as usize))
                            .filter(|c| c.len() == n);
                        // How far a chord leaves the arc between its points.
                        let r = radial(&step.start).max(radial(&step.end));
                        w.feed_check.bulge = r * (1.0 - (0.5 * sweep.abs() / n as f64).cos());
                        for k in 1..=n {
                            // The last chord ends exactly where the move does (an arc whose
                            // end is off its start's radius by the program's rounding too).
                            let (q, check) = match chords {
                                _ if k == n => (end, planned.and_then(|p| p.check)),
                                Some(c) => (c[k - 1].0, Some(c[k - 1].1)),
                                None => (joints(&jm, &step.at(k as f64 / n as f64)), None),
                            };
                            w.feed_check.planned_check = check.map(|c| (q, k == n, c));
                            w.linear(1.0, &q, Some(step.feed), file, step.line, k == n)?;
                        }
                        w.feed_check.bulge = 0.0;
                    }
                }
                _ => w.linear(1.0, &end, Some(step.feed), file, step.line, true)?,
            }
        }
        if let Some(e) = error.take() {
            return Err(e);
        }
        steps.clear();
        ends.clear();
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
    if let (false, Some((sec, line))) = (cut, first) {
        // Travel alone: the posted program would be a lift and nothing else, while the
        // input (a script that never left G0, say) may have meant its rapids to cut.
        return Err(PostError::Unsupported {
            file: sections[sec].name.clone(),
            line,
            what: "the program has no feed moves: every move is a rapid, which the post rebuilds as travel at the safe height, so the posted program would cut or deposit nothing; if rapids were meant to cut (G0 where G1 was meant), fix the input".into(),
        });
    }
    w.finish(cfg)
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
