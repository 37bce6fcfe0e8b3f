//! The one writer of posted programs: every block the planar and the per-point post
//! write goes through it (preamble and machining options, retract and index, approach,
//! process codes, straight moves with their limits and in-process check, five-axis
//! moves, postamble), so both paths keep the same safety rules and honour the same
//! options.

use std::io::Write;

use lampost_gcode::round_half_away;
use lampost_gcode::Emitter;
use lampost_gcode::StopKind;
use lampost_gcode::{ARC_RADIUS_TOLERANCE, ARC_SPIRAL_RELATIVE, ARC_SPIRAL_TOLERANCE};
use lampost_kinematics::trig::sin_cos_deg;
use lampost_kinematics::{Affine, Machine};

use crate::check::FeedCheck;
use crate::error::PostError;
use crate::intended::{Step, ToolChange};
use crate::pipeline::HeightUsed;
use crate::post::{
    axis_letters, check_height, code_words, emitter, index_maps, linear_scale, program_units,
    write_header, written_rotary, PostConfig, PostReport, Process,
};
use crate::safety::SafeHeights;

/// The machine's process codes as words, read once; laser on carries the process's power.
#[derive(Debug, Clone)]
pub(crate) struct Codes {
    laser_on: Vec<(u8, f64)>,
    laser_off: Vec<(u8, f64)>,
    powder_on: Vec<(u8, f64)>,
    powder_off: Vec<(u8, f64)>,
}

impl Codes {
    fn of(m: &Machine, process: &Process) -> Result<Codes, PostError> {
        let p = &m.def.process;
        let mut laser_on = code_words(&p.laser_on)?;
        if let (Process::Deposit { .. }, true) = (process, laser_on.is_empty()) {
            return Err(PostError::Options(format!(
                "machine {}: its file has no laser codes (`process.laser_on` is empty), so it cannot deposit: post with --process machine, or give the machine's laser_on and laser_off",
                m.def.name
            )));
        }
        if let Process::Deposit { power } = process {
            let letter = p
                .laser_power_word
                .bytes()
                .next()
                .unwrap_or(b'S')
                .to_ascii_uppercase();
            laser_on.push((letter, *power));
        }
        Ok(Codes {
            laser_on,
            laser_off: code_words(&p.laser_off)?,
            powder_on: code_words(&p.powder_on)?,
            powder_off: code_words(&p.powder_off)?,
        })
    }
}

pub(crate) struct Writer<'m, W: Write> {
    pub(crate) em: Emitter<W>,
    pub(crate) m: &'m Machine,
    pub(crate) letters: [u8; 5],
    pub(crate) report: PostReport,
    pub(crate) rot: Option<[f64; 2]>,
    /// The joints map of `rot` (of 0 before the first index).
    pub(crate) jmap: Affine,
    /// (sin, cos) of `rot`.
    pub(crate) rot_sc: [(f64, f64); 2],
    pub(crate) branch: Option<i8>,
    pub(crate) laser: bool,
    pub(crate) pos: Option<[f64; 3]>,
    /// The last written linear words, in output resolution units.
    pub(crate) written: [Option<i64>; 3],
    /// The in-process check of written feed points.
    pub(crate) feed_check: FeedCheck,
    pub(crate) head: usize,
    /// 10^decimals of the linear words.
    pub(crate) scale: f64,
    /// The safe heights, and that of the table position in force.
    pub(crate) heights: SafeHeights<'m>,
    pub(crate) safe: f64,
    /// The head is down at the end of a feed (a lift comes before any travel).
    pub(crate) in_run: bool,
    /// The machine's process codes, read once.
    pub(crate) codes: Codes,
    /// Inverse-time feeds (G93) in force.
    pub(crate) inverse_time: bool,
    /// Every safe height used, for [`crate::pipeline::post`]'s check of its first pass.
    pub(crate) heights_used: Vec<HeightUsed>,
    /// The part, for the collision check of every rapid written.
    pub(crate) part: Option<std::sync::Arc<crate::collide::PartMesh>>,
    /// Machine resolutions coarser than the output's (0.0001 in, 0.001 mm, 0.001°): every
    /// value written lands on the machine's grid, so the controller runs what was checked.
    pub(crate) lin_snap: [Option<f64>; 3],
    pub(crate) rot_snap: [Option<f64>; 2],
    /// The bound on the program's size (bytes).
    pub(crate) max_bytes: u64,
    /// A machining program's spindle speed and coolant in force (the first tool's from
    /// the process, each later tool's from its [`ToolChange`]).
    spindle: Option<(f64, bool)>,
    /// The spindle (and coolant) are to be turned on again before the next approach
    /// (after a program stop).
    respin: bool,
    /// The tool in the spindle as posted (0: none named), and every cut held to the
    /// input's tool ([`Writer::holds_tool`]).
    tool: u32,
    cut_tools: crate::verify::CutTools,
    /// The linear axes' travel as [`Writer::check`] compares with it (1e-9 of slack
    /// included), read once from the machine.
    lin_within: [(f64, f64); 3],
    /// The last rotary values [`Writer::check`] found within travel (they change only
    /// at an index, so most points need not compare them again).
    rot_within: std::cell::Cell<Option<[f64; 2]>>,
}

impl<'m, W: Write> Writer<'m, W> {
    /// A writer for `machine` and `cfg` over `out`, with the safe heights of the work.
    pub(crate) fn new(
        machine: &'m Machine,
        cfg: &PostConfig,
        heights: SafeHeights<'m>,
        out: W,
    ) -> Result<Self, PostError> {
        let units = program_units(machine);
        let names = machine.axis_names();
        Ok(Writer {
            em: emitter(out, cfg, units),
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
            feed_check: FeedCheck::new(machine, cfg),
            head: cfg.head,
            scale: linear_scale(units),
            safe: heights.at(&cfg.near),
            heights,
            in_run: false,
            codes: Codes::of(machine, &cfg.process)?,
            inverse_time: false,
            heights_used: Vec::new(),
            part: cfg.part.clone(),
            lin_snap: [0, 1, 2].map(|k| {
                let r = machine.linear[k].resolution;
                (r * linear_scale(units) > 1.0 + 1e-9).then_some(r)
            }),
            max_bytes: cfg.max_output_bytes.unwrap_or(u64::MAX),
            spindle: None,
            respin: false,
            tool: match &cfg.process {
                Process::Machine { tool, .. } => tool.unwrap_or(0),
                Process::Deposit { .. } => 0,
            },
            cut_tools: crate::verify::CutTools::new(&cfg.process),
            rot_snap: [0, 1].map(|k| {
                let r = machine.rotary[k].resolution;
                (r * 1e3 > 1.0 + 1e-9).then_some(r)
            }),
            lin_within: [0, 1, 2].map(|k| {
                machine
                    .linear
                    .get(k)
                    .map_or((f64::INFINITY, f64::NEG_INFINITY), |l| {
                        (l.limits.0 - 1e-9, l.limits.1 + 1e-9)
                    })
            }),
            rot_within: std::cell::Cell::new(None),
        })
    }

    /// Joints `x` on the machine's linear grid (unchanged where the output's is coarser).
    #[inline]
    pub(crate) fn on_grid(&self, x: &[f64; 3]) -> [f64; 3] {
        let mut y = *x;
        for (v, r) in y.iter_mut().zip(self.lin_snap) {
            if let Some(r) = r {
                *v = round_half_away(*v / r) * r;
            }
        }
        y
    }

    /// A height on the machine's Z grid and the output's resolution, at or above `z`: a
    /// retract rounds toward safety, never below the height it must reach.
    fn up_on_grid(&self, z: f64) -> f64 {
        let z = match self.lin_snap[2] {
            Some(r) => (z / r).ceil() * r,
            None => z,
        };
        // Written as round_half_away(z·scale): a whole number of steps is written as it
        // stands, so the ceiling of it is what the text says.
        (z * self.scale).ceil() / self.scale
    }

    /// Rotaries on the machine's rotary grid.
    pub(crate) fn rot_on_grid(&self, rot: &[f64; 2]) -> [f64; 2] {
        let mut y = *rot;
        for (v, r) in y.iter_mut().zip(self.rot_snap) {
            if let Some(r) = r {
                *v = round_half_away(*v / r) * r;
            }
        }
        y
    }

    /// The header, the modal preamble and the machining options (tool change, work
    /// offset, length offset, spindle, coolant); the body starts after it.
    pub(crate) fn preamble(&mut self, cfg: &PostConfig) -> Result<(), PostError> {
        let units = program_units(self.m);
        write_header(&mut self.em, cfg, units)?;
        let p = &self.m.def.process;
        match cfg.process.checked()? {
            Process::Machine {
                tool,
                length_offset,
                work_offset,
                spindle,
                coolant,
            } => {
                if let Some(t) = tool {
                    let mut v = vec![(b'T', f64::from(*t))];
                    v.extend(code_words(&p.tool_change)?);
                    self.em
                        .words(&v, None)
                        .map_err(|e| option_out_of_range(e, "--tool"))?;
                }
                if let Some(o) = work_offset {
                    self.words(&work_offset_words(o)?, Some("WORK OFFSET"))?;
                }
                if let Some(h) = length_offset {
                    self.em
                        .words(&[(b'G', 43.0), (b'H', f64::from(*h))], None)
                        .map_err(|e| option_out_of_range(e, "--length-offset"))?;
                }
                self.spindle_on(*spindle, *coolant)?;
                self.spindle = Some((*spindle, *coolant));
            }
            Process::Deposit { .. } => {}
        }
        self.report.body.0 = self.offset();
        Ok(())
    }

    /// The spindle on at `speed`, and the coolant when `coolant` (machining).
    fn spindle_on(&mut self, speed: f64, coolant: bool) -> Result<(), PostError> {
        let p = &self.m.def.process;
        let mut v = vec![(b'S', speed)];
        v.extend(code_words(&p.spindle_on)?);
        self.words(&v, None)?;
        if coolant {
            self.words(&code_words(&p.coolant_on)?, None)?;
        }
        Ok(())
    }

    /// A program stop of the input: off the end of the run with the process off (as for
    /// [`Writer::travel`]), then the stop, `M0` (`M60` too: the pallet is not changed,
    /// said in a warning) or `M1`. A machining program turns the spindle (and coolant)
    /// on again before its next approach ([`Writer::approach`]; a tool change right after
    /// the stop turns them on for the new tool): a control may stop them with the
    /// program (Haas's M0 does), and the next feed would cut with the spindle stopped.
    pub(crate) fn stop(&mut self, kind: StopKind, file: &str, line: u32) -> Result<(), PostError> {
        self.travel(file, line)?;
        let code = match kind {
            StopKind::Program => 0.0,
            StopKind::Optional => 1.0,
            StopKind::Pallet => {
                self.report.warnings.push(format!(
                    "{file}:{line}: M60 (pallet change and stop) is posted as M0: the machine stops, and no pallet is changed"
                ));
                0.0
            }
        };
        self.words(&[(b'M', code)], None)?;
        self.respin = self.spindle.is_some();
        Ok(())
    }

    /// The cut `step` is made with the input's tool (see [`crate::verify::CutTools`]), as
    /// `verify` holds it.
    #[inline]
    pub(crate) fn holds_tool(&mut self, step: &Step, file: &str) -> Result<(), PostError> {
        if self.cut_tools.hold(step, self.tool) {
            return Ok(());
        }
        Err(PostError::Verify(format!(
            "{file}:{}: {}",
            step.line,
            crate::verify::CutTools::missing(step, self.tool)
        )))
    }

    /// A tool change of the input's (machining): off the end of the run to the safe
    /// height (as for [`Writer::travel`]), coolant and spindle off, the new tool loaded
    /// (`T`, the machine's `tool_change` code), its length offset (`G43 H`) and spindle
    /// speed applied, the coolant on again where the program is posted with it. The
    /// control moves Z for the change: every axis is written again on the next move.
    pub(crate) fn tool_change(
        &mut self,
        change: ToolChange,
        file: &str,
        line: u32,
    ) -> Result<(), PostError> {
        let Some((_, coolant)) = self.spindle else {
            return Err(PostError::Unsupported {
                file: file.to_string(),
                line,
                what: format!(
                    "a tool change to T{}: a deposition program is posted for one tool",
                    change.tool
                ),
            });
        };
        self.travel(file, line)?;
        let p = &self.m.def.process;
        if coolant {
            self.words(&code_words(&p.coolant_off)?, None)?;
        }
        self.words(&code_words(&p.spindle_off)?, None)?;
        let mut v = vec![(b'T', f64::from(change.tool))];
        v.extend(code_words(&p.tool_change)?);
        // A T or H the dialect cannot hold (FADAL's H1–H99) is the new tool's: refused at
        // its first cut's line.
        self.move_words(&v, file, line)?;
        if let Some(h) = change.length_offset {
            self.move_words(&[(b'G', 43.0), (b'H', f64::from(h))], file, line)?;
        }
        self.spindle_on(change.speed(), coolant)?;
        self.spindle = Some((change.speed(), coolant));
        self.respin = false;
        self.written = [None; 3];
        self.tool = change.tool;
        self.cut_tools.changed = true;
        Ok(())
    }

    /// The process for a feed: laser and powder on for a deposition move (when the
    /// process deposits), off otherwise.
    pub(crate) fn process_for(&mut self, cfg: &PostConfig, deposit: bool) -> Result<(), PostError> {
        if let Process::Deposit { .. } = cfg.process {
            if deposit && !self.laser {
                emit_words(&mut self.em, &self.codes.laser_on, None)?;
                emit_words(&mut self.em, &self.codes.powder_on, None)?;
                self.laser = true;
            } else if !deposit {
                self.laser_off()?;
            }
        }
        Ok(())
    }

    /// Back to per-minute feeds after inverse-time moves.
    fn per_minute(&mut self) -> Result<(), PostError> {
        if self.inverse_time {
            self.words(&[(b'G', 94.0)], None)?;
            self.inverse_time = false;
        }
        Ok(())
    }

    /// Laser off, a split point, up to a height safe over the whole rotary move, then
    /// the rotaries to `rot`; the safe height becomes that of `rot`. Never a rotary move
    /// mid-cut.
    pub(crate) fn index(
        &mut self,
        rot: [f64; 2],
        near: [f64; 2],
        file: &str,
        line: u32,
    ) -> Result<(), PostError> {
        let rot = self.rot_on_grid(&rot);
        self.laser_off()?;
        self.per_minute()?;
        let split = self.offset();
        self.report.split_points.push(split);
        // The heights over the table positions as written (0.001°), which is where the
        // table goes and what `verify` checks: at a long reach the rounding of an angle
        // moves the work's top by more than the output's step.
        let from = written_rotary(&self.rot.unwrap_or(near)).0;
        let to = written_rotary(&rot).0;
        let over = self.heights.over_move(&from, &to);
        let at = self.heights.at(&to);
        self.heights_used.push(HeightUsed { from, to, over, at });
        self.safe = over;
        check_height(&self.heights, self.safe, file, line, &rot)?;
        self.lift(file, line)?;
        if let (Some(part), Some(p), Some(old)) = (&self.part, self.pos, self.rot) {
            if let Some(what) =
                crate::safety::rapid_meets_part(self.m, self.head, part, &p, &old, &p, &rot, false)?
            {
                return Err(PostError::Collision(format!("{file}:{line}: {what}")));
            }
        }
        self.rot = Some(rot);
        self.jmap = index_maps(self.m, self.head, &rot).0;
        self.rot_sc = [sin_cos_deg(rot[0]), sin_cos_deg(rot[1])];
        self.words(
            &[
                (b'G', 0.0),
                (self.letters[3], rot[0]),
                (self.letters[4], rot[1]),
            ],
            Some("INDEX"),
        )?;
        self.report.indexes.push(rot);
        self.report.moves += 1;
        self.safe = at;
        check_height(&self.heights, self.safe, file, line, &rot)?;
        self.in_run = false;
        Ok(())
    }

    /// Travel between runs: laser off, and the lift off the end of the run (a split
    /// point) if the head is down there.
    pub(crate) fn travel(&mut self, file: &str, line: u32) -> Result<(), PostError> {
        self.laser_off()?;
        self.per_minute()?;
        if self.in_run {
            let split = self.offset();
            self.report.split_points.push(split);
            self.lift(file, line)?;
            self.in_run = false;
        }
        Ok(())
    }

    /// Onto a start at joints `start`: off the last end (if the head is down there), over
    /// the start at the safe height, straight down to the approach lift above it, then
    /// in at `feed`. The head is then in a run.
    pub(crate) fn approach(
        &mut self,
        start: &[f64; 3],
        feed: f64,
        file: &str,
        line: u32,
    ) -> Result<(), PostError> {
        self.travel(file, line)?;
        if std::mem::take(&mut self.respin) {
            if let Some((speed, coolant)) = self.spindle {
                self.spindle_on(speed, coolant)?;
            }
        }
        let lift = crate::safety::approach_lift(self.m);
        let mut above = *start;
        above[2] = self.up_on_grid(self.pos.map_or(self.safe, |p| p[2].max(self.safe)));
        self.linear(0.0, &above, None, file, line, false)?;
        let mut near_start = *start;
        near_start[2] = (start[2] + lift).min(self.safe);
        self.linear(0.0, &near_start, None, file, line, false)?;
        self.linear(1.0, start, Some(feed), file, line, false)?;
        self.in_run = true;
        Ok(())
    }

    /// A five-axis feed to joints `j` (rotaries turning: inverse time `per_min` = 1 /
    /// minutes, G93; else per-minute `feed`), within travel, in a run.
    pub(crate) fn move5(
        &mut self,
        j: &[f64; 5],
        feed: f64,
        per_min: Option<f64>,
        file: &str,
        line: u32,
    ) -> Result<(), PostError> {
        let x = self.on_grid(&[j[0], j[1], j[2]]);
        let rot = self.rot_on_grid(&[j[3], j[4]]);
        let j = &[x[0], x[1], x[2], rot[0], rot[1]];
        self.check(file, line, &x, &rot)?;
        // An inverse-time feed of a move lasting years (a tiny per-point feed) would be
        // written as F0: refused at its line.
        located_feed(per_min.unwrap_or(feed), file, line)?;
        let mut w: Vec<(u8, f64)> = Vec::with_capacity(8);
        match per_min {
            Some(f) => {
                if !self.inverse_time {
                    w.push((b'G', 93.0));
                    self.inverse_time = true;
                }
                w.push((b'G', 1.0));
                for (k, v) in j.iter().enumerate() {
                    w.push((self.letters[k], *v));
                }
                w.push((b'F', f));
            }
            None => {
                if self.inverse_time {
                    w.push((b'G', 94.0));
                    self.inverse_time = false;
                }
                w.push((b'G', 1.0));
                for (k, v) in x.iter().enumerate() {
                    w.push((self.letters[k], *v));
                }
                w.push((b'F', feed));
            }
        }
        self.move_words(&w, file, line)?;
        self.note_limits(j);
        if self.rot != Some(rot) {
            // The table turned under the head: the safe height to lift to (at the end, or
            // before a re-index) is the one at this table position.
            self.safe = self.heights.at(&written_rotary(&rot).0);
        }
        self.rot = Some(rot);
        self.pos = Some(x);
        for (slot, v) in self.written.iter_mut().zip(x) {
            *slot = Some(round_half_away(v * self.scale) as i64);
        }
        self.report.moves += 1;
        self.in_run = true;
        self.within_size(file, line)
    }

    /// Whether `G2`/`G3` (counter-clockwise in joint X/Y when `ccw`) from joints `start`
    /// to `end` about `c`, as [`Writer::arc`] would write it, reads back as the intended
    /// arc whose midpoint is at joints `mid`. A controller (and `verify`) starts the arc
    /// where the head is as written, puts the centre at that plus the written I and J,
    /// and reads a full circle when the written ends meet: an arc whose end rounds onto
    /// its start, or past it, would read as a full circle or nearly one. The midpoint of
    /// the arc as read must be within the check's tolerance of `mid`.
    pub(crate) fn arc_reads_back(
        &self,
        start: &[f64; 3],
        end: &[f64; 3],
        c: &[f64; 3],
        ccw: bool,
        mid: &[f64; 3],
    ) -> bool {
        let (Some(sx), Some(sy)) = (self.written[0], self.written[1]) else {
            return false;
        };
        let (end, c) = (self.on_grid(end), self.on_grid(c));
        // In output steps, as the text gives them.
        let q = |v: f64| round_half_away(v * self.scale);
        let s = [sx as f64, sy as f64];
        let e = [q(end[0]), q(end[1])];
        let cc = [s[0] + q(c[0] - start[0]), s[1] + q(c[1] - start[1])];
        let tau = std::f64::consts::TAU;
        let a0 = (s[1] - cc[1]).atan2(s[0] - cc[0]);
        let a1 = (e[1] - cc[1]).atan2(e[0] - cc[0]);
        let read = if s == e {
            tau
        } else if ccw {
            (a1 - a0).rem_euclid(tau)
        } else {
            (a0 - a1).rem_euclid(tau)
        };
        let r = (s[0] - cc[0]).hypot(s[1] - cc[1]);
        // The control must accept it: the written radii within its arc tolerances
        // (LinuxCNC's, which lampost's interpreter and `verify` apply). An arc at the
        // edge of them in the input can pass them by the rounding of its end.
        let r_end = (e[0] - cc[0]).hypot(e[1] - cc[1]);
        let (spiral, zero) = match program_units(self.m) {
            lampost_gcode::Units::Inch => (ARC_SPIRAL_TOLERANCE.0, ARC_RADIUS_TOLERANCE.0),
            lampost_gcode::Units::Mm => (ARC_SPIRAL_TOLERANCE.1, ARC_RADIUS_TOLERANCE.1),
        };
        let (r1, r2) = (r / self.scale, r_end / self.scale);
        let diff = (r1 - r2).abs();
        if r1 < zero
            || r2 < zero
            || diff > 100.0 * spiral
            || (diff / r1.max(r2) > ARC_SPIRAL_RELATIVE && diff > spiral)
        {
            return false;
        }
        let am = if ccw {
            a0 + read / 2.0
        } else {
            a0 - read / 2.0
        };
        let (mx, my) = (
            (cc[0] + r * am.cos()) / self.scale,
            (cc[1] + r * am.sin()) / self.scale,
        );
        (mx - mid[0]).hypot(my - mid[1]) <= self.feed_check.tol
    }

    /// An arc kept as an arc (its plane is the machine's XY plane): `G2`/`G3` from joints
    /// `start` to `end` about `c`, its X/Y extremes within travel, its midpoint and end
    /// checked as written.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn arc(
        &mut self,
        step: &Step,
        start: &[f64; 3],
        end: &[f64; 3],
        c: &[f64; 3],
        ccw: bool,
        sweep: f64,
        file: &str,
    ) -> Result<(), PostError> {
        let g = if ccw { 3.0 } else { 2.0 };
        let (end, c) = (&self.on_grid(end), &self.on_grid(c));
        located_feed(step.feed, file, step.line)?;
        let rot_now = self.rot.unwrap_or([0.0; 2]);
        self.check(file, step.line, end, &rot_now)?;
        // Travel limits along the arc: its extreme points in X and Y.
        for q in crate::post::arc_extremes(start, end, c, ccw, sweep.abs()) {
            self.check(file, step.line, &q, &rot_now)?;
        }
        self.note_limits(&[end[0], end[1], end[2], rot_now[0], rot_now[1]]);
        let words = [
            (b'G', g),
            (self.letters[0], end[0]),
            (self.letters[1], end[1]),
            (self.letters[2], end[2]),
            (b'I', c[0] - start[0]),
            (b'J', c[1] - start[1]),
            (b'F', step.feed),
        ];
        self.move_words(&words, file, step.line)?;
        // The arc's midpoint (joint space) and its end, as written.
        let mid = crate::post::joints(&self.jmap, &step.at(0.5));
        self.verify_point(&mid, false)?;
        self.verify_point(end, true)?;
        let scale = self.scale;
        for (slot, v) in self.written.iter_mut().zip(end) {
            *slot = Some(round_half_away(v * scale) as i64);
        }
        self.pos = Some(*end);
        self.report.moves += 1;
        self.within_size(file, step.line)
    }

    /// The postamble: laser off, coolant and spindle off, the lift to the safe height,
    /// the program end; the report.
    pub(crate) fn finish(
        mut self,
        cfg: &PostConfig,
    ) -> Result<(PostReport, Vec<HeightUsed>), PostError> {
        self.report.body.1 = self.offset();
        self.laser_off()?;
        self.per_minute()?;
        let p = &self.m.def.process;
        if let Process::Machine { coolant, .. } = &cfg.process {
            if *coolant {
                self.words(&code_words(&p.coolant_off)?, None)?;
            }
            self.words(&code_words(&p.spindle_off)?, None)?;
        }
        self.lift("", 0)?;
        self.words(&code_words(&p.program_end)?, None)?;
        for e in self.report.limits_used.iter_mut() {
            if !e.1.is_finite() {
                e.1 = 0.0;
                e.2 = 0.0;
            }
        }
        self.report.verify.moves = self.report.moves;
        self.em.finish()?;
        Ok((self.report, self.heights_used))
    }

    /// Bytes of output so far (finished lines).
    pub(crate) fn offset(&self) -> u64 {
        self.em.position()
    }

    pub(crate) fn words(
        &mut self,
        w: &[(u8, f64)],
        comment: Option<&str>,
    ) -> Result<(), PostError> {
        emit_words(&mut self.em, w, comment)
    }

    /// [`Writer::words`] of a move made from input line `line`: a value the dialect
    /// cannot hold is that line's error.
    fn move_words(&mut self, w: &[(u8, f64)], file: &str, line: u32) -> Result<(), PostError> {
        self.em.words(w, None).map_err(|e| at_line(e, file, line))
    }

    /// Laser and powder off, if the laser is on.
    pub(crate) fn laser_off(&mut self) -> Result<(), PostError> {
        if self.laser {
            emit_words(&mut self.em, &self.codes.laser_off, None)?;
            emit_words(&mut self.em, &self.codes.powder_off, None)?;
            self.laser = false;
        }
        Ok(())
    }

    /// Check a written feed point (see [`FeedCheck::point`]).
    #[inline]
    pub(crate) fn verify_point(&mut self, x: &[f64; 3], is_end: bool) -> Result<(), PostError> {
        let rot = self.rot.unwrap_or([0.0; 2]);
        self.feed_check.point(
            self.m,
            self.head,
            self.scale,
            &rot,
            &mut self.report.verify,
            x,
            is_end,
        )
    }

    #[inline]
    pub(crate) fn note_limits(&mut self, joints: &[f64; 5]) {
        for (k, v) in joints.iter().enumerate() {
            // Comparisons, not `min`/`max` (whose NaN handling costs more): a NaN is
            // skipped either way.
            let e = &mut self.report.limits_used[k];
            if *v < e.1 {
                e.1 = *v;
            }
            if *v > e.2 {
                e.2 = *v;
            }
        }
    }

    #[inline(always)]
    pub(crate) fn check(
        &self,
        file: &str,
        line: u32,
        x: &[f64; 3],
        rot: &[f64; 2],
    ) -> Result<(), PostError> {
        // The common case in a few comparisons; the axis at fault is found below.
        let linear_ok = x
            .iter()
            .zip(&self.lin_within)
            .all(|(&v, &(lo, hi))| v.is_finite() && v >= lo && v <= hi);
        if linear_ok && self.m.linear.len() == 3 {
            return self.check_rotary(file, line, rot);
        }
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
        self.check_rotary(file, line, rot)
    }

    /// The rotaries within their travel.
    #[inline]
    fn check_rotary(&self, file: &str, line: u32, rot: &[f64; 2]) -> Result<(), PostError> {
        if self.rot_within.get() == Some(*rot) {
            return Ok(());
        }
        for (r, &v) in self.m.rotary.iter().zip(rot) {
            if !v.is_finite() || !r.within(v) {
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
        self.rot_within.set(Some(*rot));
        Ok(())
    }

    /// The safe-height invariant for a rapid to `x` from where the head is: only a
    /// vertical move (the lift off an end, the approach onto a start) may go below the
    /// safe height. (Checked on the values as written.)
    pub(crate) fn check_rapid(&self, file: &str, line: u32, x: &[f64; 3]) -> Result<(), PostError> {
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
        if let (Some(part), Some(p)) = (&self.part, self.pos) {
            // As written: the values rounded to the output resolution.
            let w = |v: &[f64; 3]| {
                [
                    q(v[0]) / self.scale,
                    q(v[1]) / self.scale,
                    q(v[2]) / self.scale,
                ]
            };
            let rot = self.rot.unwrap_or([0.0; 2]);
            let lifting = vertical && self.in_run && x[2] > p[2];
            if let Some(what) = crate::safety::rapid_meets_part(
                self.m,
                self.head,
                part,
                &w(&p),
                &rot,
                &w(x),
                &rot,
                lifting,
            )? {
                return Err(PostError::Collision(format!("{file}:{line}: {what}")));
            }
        }
        Ok(())
    }

    /// Raise the head to the safe height where it is (the lift off an end), or write
    /// the height alone when the position is not known yet (the program's first move).
    pub(crate) fn lift(&mut self, file: &str, line: u32) -> Result<(), PostError> {
        let z = self.up_on_grid(self.safe);
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
    pub(crate) fn linear(
        &mut self,
        g: f64,
        x: &[f64; 3],
        feed: Option<f64>,
        file: &str,
        line: u32,
        step_end: bool,
    ) -> Result<(), PostError> {
        let grid = self.on_grid(x);
        let x = &grid;
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
        if n == 0 && g == 0.0 {
            // A rapid that changes no word as written moves nowhere: no block.
            self.pos = Some(*x);
            return Ok(());
        }
        if let Some(f) = feed {
            located_feed(f, file, line)?;
        }
        if n == 0 && g == 1.0 {
            // A feed to where the head is (as written): keep one axis so the block moves
            // (after the feed word, as posts have always written it).
            let mut v = vec![(b'G', g)];
            v.extend(feed.map(|f| (b'F', f)));
            v.push((self.letters[0], x[0]));
            self.move_words(&v, file, line)?;
        } else {
            self.em
                .motion(g, &w[..n], self.scale, feed)
                .map_err(|e| at_line(e, file, line))?;
        }
        if g != 0.0 {
            self.verify_point(x, step_end)?;
        }
        self.pos = Some(*x);
        self.report.moves += 1;
        self.within_size(file, line)
    }

    /// The program so far within its bound on size.
    #[inline]
    fn within_size(&self, file: &str, line: u32) -> Result<(), PostError> {
        if self.offset() > self.max_bytes {
            return Err(PostError::TooLarge {
                file: file.to_string(),
                line,
                limit: self.max_bytes,
            });
        }
        Ok(())
    }
}

/// Words as one block (the header's, the process codes', any the post makes): a feed
/// that would be written as `F0` is refused first.
fn emit_words<W: Write>(
    em: &mut Emitter<W>,
    w: &[(u8, f64)],
    comment: Option<&str>,
) -> Result<(), PostError> {
    if w.is_empty() && comment.is_none() {
        // A code the machine has none of (`powder_on = ""`): no line.
        return Ok(());
    }
    for &(l, v) in w {
        if l == b'F' {
            feed_writable(v)?;
        }
    }
    em.words(w, comment).map_err(PostError::from)
}

/// An emitter error of the words an option gives (`--tool`, `--length-offset`): a value
/// out of the dialect's range is the option's error (FADAL's length offsets are H1–H99);
/// anything else is I/O.
fn option_out_of_range(e: std::io::Error, option: &str) -> PostError {
    if e.kind() == std::io::ErrorKind::InvalidData {
        PostError::Options(format!(
            "{option}: {e}; give the number the control's table holds this tool's offset under"
        ))
    } else {
        PostError::from(e)
    }
}

/// An emitter error of a move from input line `line`: a value out of the dialect's
/// range (or not finite) is that line's [`PostError::OutOfRange`]; anything else is I/O.
fn at_line(e: std::io::Error, file: &str, line: u32) -> PostError {
    if e.kind() == std::io::ErrorKind::InvalidData {
        PostError::OutOfRange {
            file: file.to_string(),
            line,
            what: e.to_string(),
        }
    } else {
        PostError::from(e)
    }
}

/// A work offset as words: `G54`–`G59.3`, `G54.1 Pn` or a FADAL fixture offset `E0`–`E48`;
/// anything else (a motion word, say) is refused.
pub(crate) fn work_offset_words(text: &str) -> Result<Vec<(u8, f64)>, PostError> {
    let bad = || {
        PostError::Options(format!(
            "--work-offset `{text}`: give one of G54 to G59.3, G54.1 P1 to P300, or a FADAL fixture offset E0 to E48"
        ))
    };
    let words = code_words(text).map_err(|_| bad())?;
    let ok = match words.as_slice() {
        [(b'G', g)] => (54.0..=59.3).contains(g) && (g * 10.0).fract() == 0.0,
        [(b'G', g), (b'P', p)] => *g == 54.1 && p.fract() == 0.0 && (1.0..=300.0).contains(p),
        [(b'E', e)] => e.fract() == 0.0 && (0.0..=48.0).contains(e),
        _ => false,
    };
    if ok {
        Ok(words)
    } else {
        Err(bad())
    }
}

/// [`feed_writable`] for a feed of a move from input line `line`: refused at that line.
/// (Called for every feed point written: the test is inlined, the error made apart.)
#[inline]
fn located_feed(f: f64, file: &str, line: u32) -> Result<(), PostError> {
    if rounds_to_f0(f) {
        return Err(located_f0(f, file, line));
    }
    Ok(())
}

#[cold]
#[inline(never)]
fn located_f0(f: f64, file: &str, line: u32) -> PostError {
    PostError::OutOfRange {
        file: file.to_string(),
        line,
        what: f0_error(f).to_string(),
    }
}

/// A feed is written with 5 decimals: one that rounds to `F0` (a feed of 1e-300 in the
/// input, or an inverse-time feed of a move lasting years) would be a program the
/// controller refuses or runs at no feed, and `verify` refuses it (found by `cargo xtask
/// fuzz`). Refused before it is written.
fn feed_writable(f: f64) -> Result<(), PostError> {
    if rounds_to_f0(f) {
        return Err(f0_error(f));
    }
    Ok(())
}

/// A finite feed whose 5 decimals round to zero: `round_half_away(|f|·10⁵) == 0`, which
/// holds exactly when `|f|·10⁵ < 0.5` (the rounding is zero only for a value whose
/// whole part is zero and whose fraction is below one half; tested to agree).
#[inline]
fn rounds_to_f0(f: f64) -> bool {
    f.is_finite() && f.abs() * 1e5 < 0.5
}

fn f0_error(f: f64) -> PostError {
    PostError::Options(format!(
        "a feed of {f:e} would be written as F0 (feeds have 5 decimals): give a feed of at least 0.00001 units per minute"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::intended::IntendedOptions;
    use crate::post::PostDialect;
    use crate::safety::WorkBounds;
    use nalgebra::Vector3;

    fn cfg() -> PostConfig {
        PostConfig {
            head: 0,
            process: Process::Deposit { power: 100.0 },
            dialect: PostDialect::Iso,
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
            work: None,
            part: None,
            max_output_bytes: None,
        }
    }

    /// A retract goes to a height at or above the safe one as written: Z rounds up to
    /// the output step (class (c) of the post fuzz target: retracts one step low).
    #[test]
    fn a_retract_rounds_up_to_the_output_step() {
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../fixtures/machines/xyzac-trt.toml"),
        )
        .expect("machine file");
        let def =
            lampost_kinematics::MachineDef::from_toml(&text, "xyzac-trt.toml").expect("reads");
        let m = Machine::new(def, &[]).expect("machine");
        let c = cfg();
        let heights = SafeHeights::new(&m, 0, WorkBounds::empty()).expect("heights");
        let mut w = Writer::new(&m, &c, heights, Vec::new()).expect("writer");
        let step = 1.0 / w.scale;
        for safe in [30.0004, 30.00001, 30.000_000_001, 30.0] {
            w.safe = safe;
            w.pos = Some([1.0, 2.0, 0.0]);
            w.written = [Some(1000), Some(2000), Some(0)];
            w.lift("t", 1).expect("lift");
            let z = w.pos.expect("lifted")[2];
            let written = w.written[2].expect("written") as f64 * step;
            assert!(written >= safe - 1e-12, "safe {safe}: written {written}");
            assert!(written < safe + step, "safe {safe}: written {written}");
            assert_eq!(
                round_half_away(z * w.scale) as i64,
                w.written[2].expect("z")
            );
        }
    }

    /// The safe heights of an index are those of the table positions as written (0.001°):
    /// at a long reach the unwritten digits of an angle move the work's top by more than
    /// an output step (class (c): a sweep checked by `verify` 1e-4 too low).
    #[test]
    fn index_heights_are_those_of_the_written_table_positions() {
        let m = Machine::builtin("fadal-lamp", &[]).expect("machine");
        let mut work = WorkBounds::empty();
        work.add_points([Vector3::new(20.0, 3.0, 0.5), Vector3::new(-5.0, 18.0, 0.2)]);
        let heights = SafeHeights::new(&m, 0, work.clone()).expect("heights");
        let check = SafeHeights::new(&m, 0, work).expect("heights");
        let c = cfg();
        let mut w = Writer::new(&m, &c, heights, Vec::new()).expect("writer");
        w.rot = Some([-67.885_37, 25.361_64]);
        w.index([105.000_4, -24.999_6], [0.0, 0.0], "t", 1)
            .expect("index");
        let used = w.heights_used.last().expect("a height used");
        assert_eq!(used.from, [-67.885, 25.362]);
        assert_eq!(used.to, [105.0, -25.0]);
        assert_eq!(
            used.over.to_bits(),
            check
                .over_move(&[-67.885, 25.362], &[105.0, -25.0])
                .to_bits()
        );
        assert_eq!(w.safe.to_bits(), check.at(&[105.0, -25.0]).to_bits());
    }

    /// The F0 test as the writer makes it agrees with its definition (the feed as the
    /// emitter rounds it to 5 decimals is zero) on random feeds of every magnitude and on
    /// the values around the boundary.
    #[test]
    fn the_f0_test_agrees_with_rounding() {
        let reference = |f: f64| f.is_finite() && round_half_away(f.abs() * 1e5) == 0.0;
        let mut cases = vec![
            0.0,
            -0.0,
            5e-6,
            -5e-6,
            4.999_999_999_999_999e-6,
            5.000_000_000_000_001e-6,
            1e-5,
            1e-300,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            1200.0,
        ];
        for k in -200..200 {
            let b = 5e-6f64.to_bits();
            let near = f64::from_bits(b.wrapping_add_signed(k));
            cases.extend([near, -near, near * 0.5, near * 2.0]);
        }
        let mut rng = lampost_testkit::SplitMix::new(11);
        for _ in 0..200_000 {
            // Every bit pattern: all magnitudes, NaNs and infinities.
            let z = rng.next_u64();
            let f = f64::from_bits(z);
            cases.extend([f, f * 1e-300, (z >> 11) as f64 * 1e-21]);
        }
        for f in cases {
            assert_eq!(rounds_to_f0(f), reference(f), "{f:e}");
        }
    }
}
