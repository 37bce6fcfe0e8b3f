//! Paths that carry their own tool axis: `x y z i j k [feed] [laser]` per point (paper
//! 001's tangent approach, or any 5-axis CAM output as points). Each point is solved by
//! inverse kinematics (the branch kept while it can be, continuous axes on the nearest
//! turn); each segment is split until the controller's straight joint-space interpolation
//! keeps the tool tip on the straight segment and the tool axis on the interpolated one;
//! moves that turn a rotary are written with G93 inverse-time feeds.

use std::io::{BufRead, Write};

use lampost_gcode::{Event, MoveKind, AXES};
use lampost_kinematics::{Joints, Machine};
use nalgebra::{Rotation3, Unit, Vector3};

use crate::error::PostError;
use crate::frame::Frame;
use crate::post::{program_units, PostConfig, PostReport, Process};
use crate::safety::{SafeHeights, WorkBounds};
use crate::verify::VerifyReport;
use crate::writer::Writer;

/// The fastest rotary feed assumed when a move only turns the tool (deg/min), to give it
/// an inverse-time feed.
pub const ROTARY_FEED_DEG_PER_MIN: f64 = 3600.0;

/// The shortest time an inverse-time block is given (minutes: 1 ms). A controller
/// cannot run blocks faster than it reads them; a piece next to a singular pose that
/// would take less is written to take this long (slower, never faster, than asked), which
/// also keeps its F word within every dialect's range.
pub const MIN_BLOCK_MINUTES: f64 = 1.0 / 60_000.0;

/// At a singular pose, an inner-axis turn larger than this (degrees) to the next point
/// is made in place, the tip standing (see [`post_points`]); a smaller one is split
/// along the move like any other.
pub const IN_PLACE_TURN_DEG: f64 = 1.0;

/// A laser-off move whose rotaries turn by more than this (degrees) is a linking move:
/// retract, index, approach (see [`post_points`]).
pub const RELINK_TURN_DEG: f64 = 1.0;

/// An unlimited rotary wound past this many degrees (ten turns) is unwound on the next
/// laser-off move: chosen again within half a turn of 0, reached by a linking move at the
/// safe height. A tall part whose walls turn the tool axis a full turn a layer wound C
/// past the ISO word's ±99,999.999° after some 278 layers (h49's frustum).
pub const UNWIND_DEG: f64 = 3600.0;

/// `near` with each unlimited rotary wound past [`UNWIND_DEG`] brought within half a
/// turn of 0 (the same table pose).
fn unwound(machine: &Machine, near: [f64; 2]) -> [f64; 2] {
    std::array::from_fn(|i| {
        let v = near[i];
        if machine.rotary[i].limits.is_none() && v.abs() > UNWIND_DEG {
            v - 360.0 * (v / 360.0).round()
        } else {
            v
        }
    })
}

/// One point of a path with its own tool axis (part frame once placed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// Tool tip.
    pub tip: Vector3<f64>,
    /// Unit tool axis (tip into the head).
    pub axis: Vector3<f64>,
    /// Feed to this point (units/min).
    pub feed: f64,
    /// Deposit on the way to this point.
    pub deposit: bool,
    /// Source line.
    pub line: usize,
}

fn file_err(file: &str, line: usize, column: usize, message: String) -> PostError {
    PostError::File {
        file: file.to_string(),
        line,
        column,
        message,
    }
}

/// The fields of a line of a per-point path, with their byte offsets: the text before
/// any `#` comment, split at spaces, tabs and commas.
fn fields(raw: &str) -> Fields<'_> {
    let code = raw.split('#').next().unwrap_or("");
    let mut out = Fields {
        kept: [(0, ""); KEPT],
        n: 0,
        rest_numeric: false,
    };
    let mut push = |s: usize, p: usize| {
        let f = &code[s..p];
        match out.kept.get_mut(out.n) {
            Some(slot) => *slot = (s, f),
            None => out.rest_numeric |= f.parse::<f64>().is_ok(),
        }
        out.n += 1;
    };
    // The separators are ASCII, so byte offsets between them are character boundaries.
    let mut start = None;
    for (p, &b) in code.as_bytes().iter().enumerate() {
        let sep = matches!(b, b' ' | b'\t' | b',');
        match (sep, start) {
            (false, None) => start = Some(p),
            (true, Some(s)) => {
                push(s, p);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        push(s, code.len());
    }
    out
}

/// The most fields of a line kept (a row has 6 to 8); more are counted.
const KEPT: usize = 9;

/// A line's fields ([`fields`]): the first [`KEPT`] as (byte offset, text), how many
/// there are, and whether any beyond those reads as a number.
struct Fields<'a> {
    kept: [(usize, &'a str); KEPT],
    n: usize,
    rest_numeric: bool,
}

impl<'a> Fields<'a> {
    /// The fields kept.
    fn kept(&self) -> &[(usize, &'a str)] {
        &self.kept[..self.n.min(KEPT)]
    }
}

/// Whether `head` (the start of a file) reads as a per-point path rather than a
/// program: its first line with fields (comments left out) is the column header
/// `x y z i j k …` (any case), or a row of 6 to 8 numbers. Neither is a line of
/// G-code (a letter needs its number, and a number its letter), so a program is never
/// taken for a path: this is how `lampost post -` tells what `lampost plan path -o -`
/// wrote from a program without `--per-point`.
pub fn looks_like_points(head: &str) -> bool {
    let Some(f) = head.lines().map(fields).find(|f| f.n > 0) else {
        return false;
    };
    let header = f.n >= 6
        && f.kept()
            .iter()
            .zip(["x", "y", "z", "i", "j", "k"])
            .all(|((_, a), b)| a.eq_ignore_ascii_case(b));
    let row = (6..=8).contains(&f.n) && f.kept().iter().all(|(_, v)| v.parse::<f64>().is_ok());
    header || row
}

/// Read `x y z i j k [feed] [laser]` rows (spaces, tabs or commas; an optional header;
/// `#` comments). A missing feed repeats the last; laser defaults to on. All of
/// [`points`] or its first error.
pub fn read_points(text: &str, file: &str) -> Result<Vec<PathPoint>, PostError> {
    points(text, file).collect()
}

/// [`read_points`] as the rows come: each point, or the first error (then nothing
/// more); an empty path is [`PostError::Empty`] at the end. A reader that works on the
/// points as they are read (the robot cell's resampling, on another thread) stops at
/// the same error on the same line.
pub fn points<'a>(text: &'a str, file: &'a str) -> Points<'a> {
    Points {
        lines: text.lines().enumerate(),
        file,
        feed: None,
        seen: false,
        any: false,
        done: false,
    }
}

/// The rows of a per-point path ([`points`]).
#[derive(Debug)]
pub struct Points<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    file: &'a str,
    /// The feed so far (a row without one repeats it).
    feed: Option<f64>,
    /// A line with fields was met (only the first may be the header).
    seen: bool,
    /// A point was given.
    any: bool,
    /// An error was given, or the end.
    done: bool,
}

impl Iterator for Points<'_> {
    type Item = Result<PathPoint, PostError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        for (i, raw) in self.lines.by_ref() {
            let line = i + 1;
            let all = fields(raw);
            if all.n == 0 {
                continue;
            }
            let fields = all.kept();
            if !self.seen
                && !all.rest_numeric
                && fields.iter().all(|(_, f)| f.parse::<f64>().is_err())
            {
                self.seen = true;
                // The header names the columns, which are read by place: it must name
                // them in that place (`x y z feed i j k laser` had its feed read as i).
                let names = ["x", "y", "z", "i", "j", "k", "feed", "laser"];
                let fits = (6..=8).contains(&all.n)
                    && fields
                        .iter()
                        .zip(names)
                        .all(|((_, f), n)| f.eq_ignore_ascii_case(n));
                if !fits {
                    self.done = true;
                    return Some(Err(file_err(
                        self.file,
                        line,
                        1,
                        format!(
                            "the header `{}` does not name the columns as they are read: x y z i j k [feed] [laser], in that order; write the columns so (and the header with them)",
                            raw.trim()
                        ),
                    )));
                }
                continue;
            }
            self.seen = true;
            let row = row(&all, fields, line, self.file, &mut self.feed);
            self.done = row.is_err();
            self.any |= row.is_ok();
            return Some(row);
        }
        self.done = true;
        (!self.any).then(|| Err(PostError::Empty(self.file.to_string())))
    }
}

/// One row's point (`feed`: the feed so far, set by a row that gives one).
fn row(
    all: &Fields,
    fields: &[(usize, &str)],
    line: usize,
    file: &str,
    feed: &mut Option<f64>,
) -> Result<PathPoint, PostError> {
    if !(6..=8).contains(&all.n) {
        return Err(file_err(
            file,
            line,
            1,
            format!(
                "expected x y z i j k [feed] [laser], found {} columns",
                all.n
            ),
        ));
    }
    let mut v = [0.0; 8];
    for (k, (col, f)) in fields.iter().enumerate() {
        v[k] = lampost_gcode::parse_number(f)
            .filter(|x| x.is_finite())
            .ok_or_else(|| {
                file_err(file, line, col + 1, format!("`{f}` is not a finite number"))
            })?;
    }
    let axis = Vector3::new(v[3], v[4], v[5]);
    if axis.norm() < 1e-12 {
        return Err(file_err(
            file,
            line,
            fields[3].0 + 1,
            "the tool axis i j k has zero length".into(),
        ));
    }
    if fields.len() >= 7 {
        if v[6] <= 0.0 {
            return Err(file_err(
                file,
                line,
                fields[6].0 + 1,
                "the feed must be positive".into(),
            ));
        }
        *feed = Some(v[6]);
    }
    if fields.len() >= 8 && v[7] != 0.0 && v[7] != 1.0 {
        return Err(file_err(
            file,
            line,
            fields[7].0 + 1,
            format!(
                "the laser column is 1 (on) or 0 (off), not `{}`",
                fields[7].1
            ),
        ));
    }
    let Some(f) = *feed else {
        return Err(file_err(
            file,
            line,
            1,
            "no feed yet: give the feed in the 7th column of the first point".into(),
        ));
    };
    Ok(PathPoint {
        tip: Vector3::new(v[0], v[1], v[2]),
        axis: axis.normalize(),
        feed: f,
        deposit: fields.len() < 8 || v[7] != 0.0,
        line,
    })
}

/// The points in the part frame.
fn place(points: &[PathPoint], frame: &Frame) -> Vec<PathPoint> {
    points
        .iter()
        .map(|q| PathPoint {
            tip: frame.apply(&q.tip),
            axis: frame.dir(&q.axis).normalize(),
            ..*q
        })
        .collect()
}

fn slerp(a: &Vector3<f64>, b: &Vector3<f64>, t: f64) -> Vector3<f64> {
    let c = a.cross(b);
    let ang = c.norm().atan2(a.dot(b));
    if c.norm() < 1e-15 || ang.abs() < 1e-15 {
        return a.normalize();
    }
    Rotation3::from_axis_angle(&Unit::new_normalize(c), ang * t) * a
}

fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b)).to_degrees()
}

/// Largest tool-axis deviation allowed along a linearised segment (degrees).
pub const AXIS_TOLERANCE_DEG: f64 = 0.05;

struct Ctx<'a> {
    m: &'a Machine,
    head: usize,
    tol: f64,
    file: &'a str,
}

impl Ctx<'_> {
    fn fk(&self, j: &[f64; 5]) -> (Vector3<f64>, Vector3<f64>) {
        let p = self.m.forward(
            &Joints {
                linear: [j[0], j[1], j[2]],
                rotary: [j[3], j[4]],
            },
            self.head,
        );
        (p.tip, p.axis)
    }

    /// Joints for (tip, axis) nearest `near` on `branch` where possible.
    fn solve(
        &self,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        near: &[f64; 2],
        branch: Option<i8>,
        line: usize,
    ) -> Result<([f64; 5], i8, bool), PostError> {
        let sols = self
            .m
            .inverse(tip, axis, self.head, near)
            .map_err(|err| PostError::Kin {
                context: format!("{}:{line}: ", self.file),
                err,
            })?;
        let c = self
            .m
            .choose(&sols, branch, axis, self.head)
            .map_err(|err| PostError::Kin {
                context: format!("{}:{line}: ", self.file),
                err,
            })?;
        let j = c.solution.joints;
        Ok((
            [
                j.linear[0],
                j.linear[1],
                j.linear[2],
                j.rotary[0],
                j.rotary[1],
            ],
            c.solution.branch,
            c.branch_flip,
        ))
    }

    /// Whether the tool axis at `j` lies along the inner rotary axis, or within
    /// [`AXIS_TOLERANCE_DEG`] of it: turning that axis then moves the tool axis by at most
    /// twice that, so its angle is free, or as good as (a singular pose, or next to one).
    fn singular(&self, j: &[f64; 5]) -> bool {
        let mut turned = *j;
        turned[3 + self.m.inner] += 180.0;
        angle(&self.fk(j).1, &self.fk(&turned).1) <= 2.0 * AXIS_TOLERANCE_DEG
    }

    /// The joints that put the tip at `tip` with the table at `rot`.
    fn at_table(&self, tip: &Vector3<f64>, rot: [f64; 2]) -> [f64; 5] {
        let (jm, _) = crate::post::index_maps(self.m, self.head, &rot);
        let x = crate::post::joints(&jm, tip);
        [x[0], x[1], x[2], rot[0], rot[1]]
    }

    /// At a singular pose `j0` (tip `a`), turn the inner rotary to that of `j1` with the
    /// tip standing: the linear axes follow the table round, split until straight joint
    /// interpolation keeps the tip within the tolerance (at the move's middle, or every
    /// [`SAMPLE_TURN_DEG`] of a longer turn: [`fractions`]).
    fn turn_in_place(
        &self,
        a: &PathPoint,
        j0: [f64; 5],
        j1: [f64; 5],
        depth: u32,
        out: &mut Vec<[f64; 5]>,
    ) {
        let stands = fractions(&j0, &j1)
            .all(|f| (self.fk(&lerp5(&j0, &j1, f)).0 - a.tip).norm() <= self.tol);
        if depth >= 24 || stands {
            out.push(j1);
            return;
        }
        let jm = lerp5(&j0, &j1, 0.5);
        let js = self.at_table(&a.tip, [jm[3], jm[4]]);
        self.turn_in_place(a, j0, js, depth + 1, out);
        self.turn_in_place(a, js, j1, depth + 1, out);
    }

    /// Split (t0, j0)–(t1, j1) until straight joint interpolation stays on the segment:
    /// at the move's middle, or every [`SAMPLE_TURN_DEG`] of a longer rotary turn
    /// ([`fractions`]). Where halving ends (24 times) on a piece still off the segment,
    /// the joints jump there (the inverse changes branch between two fractions 6e-8
    /// apart, the rotaries half a turn apart: found by the fuzzer as a feed whose table
    /// turned 180° with the tool 5.6 mm off the path at its middle): that piece is a
    /// [`Piece::jump`], reached by a retract, index and approach, never a feed.
    #[allow(clippy::too_many_arguments)]
    fn split(
        &self,
        a: &PathPoint,
        b: &PathPoint,
        t0: f64,
        j0: [f64; 5],
        t1: f64,
        j1: [f64; 5],
        branch: i8,
        depth: u32,
        out: &mut Vec<Piece>,
    ) -> Result<(), PostError> {
        let rotary_moves = (j0[3] - j1[3]).abs() + (j0[4] - j1[4]).abs() > 1e-9;
        let on = |f: f64| {
            let (tip, ax) = self.fk(&lerp5(&j0, &j1, f));
            let t = t0 + (t1 - t0) * f;
            let want_tip = a.tip + (b.tip - a.tip) * t;
            (tip - want_tip).norm() <= self.tol
                && angle(&ax, &slerp(&a.axis, &b.axis, t)) <= AXIS_TOLERANCE_DEG
        };
        if !rotary_moves || fractions(&j0, &j1).all(on) {
            out.push(Piece {
                t: t1,
                j: j1,
                jump: false,
            });
            return Ok(());
        }
        if depth >= 24 {
            out.push(Piece {
                t: t1,
                j: j1,
                jump: true,
            });
            return Ok(());
        }
        let tm = (t0 + t1) / 2.0;
        let jm = lerp5(&j0, &j1, 0.5);
        let want_tip = a.tip + (b.tip - a.tip) * tm;
        let want_ax = slerp(&a.axis, &b.axis, tm);
        let (js, _, _) = self.solve(&want_tip, &want_ax, &[jm[3], jm[4]], Some(branch), b.line)?;
        self.split(a, b, t0, j0, tm, js, branch, depth + 1, out)?;
        self.split(a, b, tm, js, t1, j1, branch, depth + 1, out)
    }
}

/// One piece of a split segment: the fraction `t` of the segment it ends at and the
/// joints there; `jump`: the joints cannot be fed to from the last piece's (see
/// [`Ctx::split`]).
#[derive(Debug, Clone, Copy)]
struct Piece {
    t: f64,
    j: [f64; 5],
    jump: bool,
}

/// The joints a fraction `f` of the way from `j0` to `j1`, every joint linearly (as the
/// control runs a five-axis feed).
fn lerp5(j0: &[f64; 5], j1: &[f64; 5], f: f64) -> [f64; 5] {
    std::array::from_fn(|k| j0[k] + (j1[k] - j0[k]) * f)
}

/// The fractions of a move from `j0` to `j1` at which the post checks the tool: the
/// middle, or, where a rotary turns by more than [`SAMPLE_TURN_DEG`], points at most that
/// turn apart (as `verify` follows such a move).
fn fractions(j0: &[f64; 5], j1: &[f64; 5]) -> impl Iterator<Item = f64> {
    let turn = (j1[3] - j0[3]).abs().max((j1[4] - j0[4]).abs());
    let n = if turn > SAMPLE_TURN_DEG {
        (turn / SAMPLE_TURN_DEG).ceil().min(MAX_SAMPLES as f64) as usize
    } else {
        2
    };
    (1..n).map(move |k| k as f64 / n as f64)
}

/// Post a path of points with their own tool axis (program frame `frame`), through the
/// same writer (`writer.rs`) as planar programs: preamble and machining options, a retract to a
/// height safe over the whole rotary move before the first point and every branch flip,
/// the approach, process codes, travel limits on every point, split points, postamble.
pub fn post_points<W: Write>(
    machine: &Machine,
    points: &[PathPoint],
    frame: &Frame,
    name: &str,
    cfg: &PostConfig,
    out: W,
) -> Result<PostReport, PostError> {
    let placed = place(points, frame);
    // Safe heights over every tip of the path (and the part or stock given).
    let mut work = WorkBounds::empty();
    for q in &placed {
        work.add(&q.tip);
    }
    if let Some(extra) = &cfg.work {
        work.union(extra);
    }
    let heights = SafeHeights::new(machine, cfg.head, work)?;
    let mut w = Writer::new(machine, cfg, heights, out)?;
    w.preamble(cfg)?;
    let ctx = Ctx {
        m: machine,
        head: cfg.head,
        tol: cfg.tolerance,
        file: name,
    };
    let mut cur: Option<([f64; 5], i8)> = None;
    let mut prev: Option<PathPoint> = None;
    for q in &placed {
        let line = u32::try_from(q.line).unwrap_or(u32::MAX);
        let near = cur.map_or(cfg.near, |(j, _)| [j[3], j[4]]);
        // Off the run, a rotary wound far is unwound (a linking move below).
        let near = if q.deposit {
            near
        } else {
            unwound(machine, near)
        };
        let (j, branch, flip) = ctx.solve(&q.tip, &q.axis, &near, cur.map(|c| c.1), q.line)?;
        w.check(name, line, &[j[0], j[1], j[2]], &[j[3], j[4]])?;
        if cur.is_none() || flip {
            if flip {
                w.report.warnings.push(format!(
                    "{name}:{}: the rotary branch flips here; the tool retracts and re-approaches",
                    q.line
                ));
            }
            w.index([j[3], j[4]], cfg.near, name, line)?;
            w.approach(&[j[0], j[1], j[2]], q.feed, name, line)?;
            cur = Some((j, branch));
            prev = Some(*q);
            continue;
        }
        let (mut j0, _) = cur.unwrap_or((j, branch));
        let a = prev.unwrap_or(*q);
        let turn = (j[3] - j0[3]).abs().max((j[4] - j0[4]).abs());
        if !q.deposit && turn > RELINK_TURN_DEG {
            // Travel that turns the table: a linking move, as CAM writes one. Off the
            // run, up to the height safe over the rotary move, index, approach: never a
            // five-axis sweep near the work with the process off.
            w.index([j[3], j[4]], cfg.near, name, line)?;
            w.approach(&[j[0], j[1], j[2]], q.feed, name, line)?;
            cur = Some((j, branch));
            prev = Some(*q);
            continue;
        }
        if ctx.singular(&j0) {
            // The axis stood along the inner rotary axis, whose angle was free there: turn
            // it in place to the angle the next point needs (process off: the tip stands),
            // so the move itself does not sweep the table half a turn.
            let ci = 3 + machine.inner;
            let mut rot = [j0[3], j0[4]];
            rot[machine.inner] = j[ci];
            let jt = ctx.at_table(&a.tip, rot);
            if (jt[ci] - j0[ci]).abs() > IN_PLACE_TURN_DEG {
                let axis = &machine.rotary[machine.inner].name;
                w.report.warnings.push(format!(
                    "{name}:{}: the tool axis leaves the {axis} axis here; {axis} turns {:.3}° in place with the process off",
                    q.line,
                    (jt[ci] - j0[ci]).abs()
                ));
                let mut steps = Vec::new();
                ctx.turn_in_place(&a, j0, jt, 0, &mut steps);
                w.process_for(cfg, false)?;
                let mut j_prev = j0;
                for js in steps {
                    let dr = (js[3] - j_prev[3]).abs().max((js[4] - j_prev[4]).abs());
                    let minutes = (dr / ROTARY_FEED_DEG_PER_MIN).max(MIN_BLOCK_MINUTES);
                    w.move5(&js, q.feed, Some(1.0 / minutes), name, line)?;
                    j_prev = js;
                }
                j0 = jt;
            }
        }
        let mut pieces = Vec::new();
        ctx.split(&a, q, 0.0, j0, 1.0, j, branch, 0, &mut pieces)?;
        let pieces = without_unwritable_pieces(pieces, j0, w.scale);
        w.process_for(cfg, q.deposit)?;
        let mut t_prev = 0.0;
        let mut j_prev = j0;
        for Piece { t, j: jp, jump } in pieces {
            if jump {
                // The joints jump here: off the run, up, index, and back down onto the
                // same point of the path, the process on again for the rest.
                w.report.warnings.push(format!(
                    "{name}:{}: the rotaries jump {:.3}° between two points of this move (the inverse changes branch); the tool retracts and re-approaches there",
                    q.line,
                    (jp[3] - j_prev[3]).abs().max((jp[4] - j_prev[4]).abs())
                ));
                w.index([jp[3], jp[4]], cfg.near, name, line)?;
                w.approach(&[jp[0], jp[1], jp[2]], q.feed, name, line)?;
                w.process_for(cfg, q.deposit)?;
                t_prev = t;
                j_prev = jp;
                continue;
            }
            let seg = (q.tip - a.tip).norm() * (t - t_prev);
            let dr = (jp[3] - j_prev[3]).abs().max((jp[4] - j_prev[4]).abs());
            // Rotaries turning: inverse time, long enough for the rotary feed.
            let per_min = (dr > 1e-9).then(|| {
                1.0 / (seg / q.feed)
                    .max(dr / ROTARY_FEED_DEG_PER_MIN)
                    .max(MIN_BLOCK_MINUTES)
            });
            w.move5(&jp, q.feed, per_min, name, line)?;
            t_prev = t;
            j_prev = jp;
        }
        cur = Some((j, branch));
        prev = Some(*q);
    }
    w.finish(cfg).map(|(report, _)| report)
}

/// The pieces of a split segment without those the output cannot tell from the last one
/// kept (every linear word within half its last digit, every rotary within 0.0005°):
/// halving toward a singular pose leaves a tail of such pieces, each of which would be
/// written as the same block with an inverse-time feed of a move lasting nanoseconds.
/// The segment's last piece always ends where the segment ends.
fn without_unwritable_pieces(pieces: Vec<Piece>, j0: [f64; 5], scale: f64) -> Vec<Piece> {
    let unwritable = |a: &[f64; 5], b: &[f64; 5]| {
        (0..3).all(|k| ((a[k] - b[k]) * scale).abs() < 0.5)
            && (3..5).all(|k| (a[k] - b[k]).abs() < 0.0005)
    };
    let mut kept: Vec<Piece> = Vec::with_capacity(pieces.len());
    let n = pieces.len();
    for (i, p) in pieces.into_iter().enumerate() {
        let last_kept = kept.last().map_or(j0, |k| k.j);
        if !unwritable(&last_kept, &p.j) {
            kept.push(p);
        } else if i + 1 == n {
            // The end itself: it replaces the last piece kept (which the output cannot
            // tell from it; a jump to it stays a jump), or is the only piece.
            match kept.last_mut() {
                Some(k) => {
                    k.t = p.t;
                    k.j = p.j;
                    k.jump |= p.jump;
                }
                None => kept.push(p),
            }
        }
    }
    kept
}

/// Whether the tool at `tip`, `axis` is on the path from point `a` to point `b` as the
/// post interpolates it: some fraction `t` in [0, 1] puts the tip within `tolerance` of
/// `a + (b − a)·t` and the axis within ten times [`AXIS_TOLERANCE_DEG`] of the axes'
/// slerp at `t`. Both conditions hold on an interval of `t` (the tip's: a quadratic in
/// `t`; the axis's: an arc of the great circle), solved exactly, so a segment whose tip
/// barely moves while its axis turns is judged by its axis and the other way round. The
/// tip error and axis angle (degrees) at the fraction used, or `None` off the path.
pub fn on_segment(
    a: &PathPoint,
    b: &PathPoint,
    tip: &Vector3<f64>,
    axis: &Vector3<f64>,
    tolerance: f64,
) -> Option<(f64, f64)> {
    segment_span(a, b, tip, axis, tolerance).map(|s| (s.0, s.1))
}

/// [`on_segment`], and the interval of fractions `[lo, hi]` where both conditions hold:
/// (tip error, axis angle, lo, hi).
fn segment_span(
    a: &PathPoint,
    b: &PathPoint,
    tip: &Vector3<f64>,
    axis: &Vector3<f64>,
    tolerance: f64,
) -> Option<(f64, f64, f64, f64)> {
    let d = b.tip - a.tip;
    let rel = tip - a.tip;
    let len2 = d.norm_squared();
    // The tip: |rel − d·t|² ≤ tol², i.e. len2·t² − 2·(rel·d)·t + |rel|² − tol² ≤ 0.
    let mid = rel.dot(&d) / len2;
    let (mut lo, mut hi) = if len2 > 0.0 && mid.is_finite() {
        let off2 = (rel - d * mid).norm_squared();
        let room2 = tolerance * tolerance - off2;
        if room2.is_nan() || room2 < 0.0 {
            return None;
        }
        let half = (room2 / len2).sqrt();
        ((mid - half).max(0.0), (mid + half).min(1.0))
    } else if rel.norm() <= tolerance {
        // The tip stands still (or moves by less than f64 can divide by).
        (0.0, 1.0)
    } else {
        return None;
    };
    if lo.is_nan() || hi.is_nan() || lo > hi {
        return None;
    }
    // The axis: the interpolated axis is cos(θt)·u + sin(θt)·w (u = a's axis, w the
    // unit normal to u towards b's, θ the turn); its angle to `axis` is within α where
    // ρ·cos(θt − φ) ≥ cos α (ρ, φ: `axis` in the (u, w) plane).
    let alpha = (10.0 * AXIS_TOLERANCE_DEG).to_radians();
    let u = a.axis.normalize();
    let p = axis.normalize();
    let theta = angle(&a.axis, &b.axis).to_radians();
    let w = b.axis - u * u.dot(&b.axis);
    if theta > 1e-12 && w.norm() > 1e-15 {
        let w = w.normalize();
        let (pu, pw) = (p.dot(&u), p.dot(&w));
        let rho = pu.hypot(pw);
        let c = alpha.cos() / rho;
        if c > 1.0 {
            return None;
        }
        let phi = pw.atan2(pu);
        let spread = c.clamp(-1.0, 1.0).acos();
        lo = lo.max((phi - spread) / theta);
        hi = hi.min((phi + spread) / theta);
        if lo.is_nan() || hi.is_nan() || lo > hi {
            return None;
        }
    }
    // The fraction in both intervals nearest the tip's own projection.
    let t = if mid.is_finite() {
        mid.clamp(lo, hi)
    } else {
        lo
    };
    let err = (rel - d * t).norm();
    let ang = angle(axis, &slerp(&a.axis, &b.axis, t));
    // The closed forms above and the measured values can differ by rounding at the
    // interval's ends: the measured ones decide.
    (err <= tolerance * (1.0 + 1e-9) && ang <= 10.0 * AXIS_TOLERANCE_DEG * (1.0 + 1e-9))
        .then_some((err, ang, lo, hi))
}

/// The most readings of a per-point program [`verify_points`] follows at once (each a
/// count of points reached; more than one when a move is within the tolerance of a point
/// and also on the way to it).
const MAX_READINGS: usize = 64;

fn keep_best(best: &mut Option<(f64, f64)>, e: (f64, f64)) {
    if best.is_none_or(|b| e.0 < b.0) {
        *best = Some(e);
    }
}

/// For a message: the tip's distance from the segment `a`–`b` and the axis's angle from
/// the interpolated axis at the tip's own fraction.
fn nearest_miss(
    a: &PathPoint,
    b: &PathPoint,
    tip: &Vector3<f64>,
    axis: &Vector3<f64>,
) -> (f64, f64) {
    let d = b.tip - a.tip;
    let len2 = d.norm_squared();
    let t = if len2 > 0.0 {
        ((tip - a.tip).dot(&d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (
        (tip - (a.tip + d * t)).norm(),
        angle(axis, &slerp(&a.axis, &b.axis, t)),
    )
}

/// Replay a posted program and compare every feed point with the path of `points`
/// (placed by `frame`): tip on the current segment (or at its end), tool axis on the
/// interpolated axis.
#[allow(clippy::too_many_arguments)]
pub fn verify_points<R: BufRead>(
    machine: &Machine,
    points: &[PathPoint],
    frame: &Frame,
    head: usize,
    process: &crate::Process,
    posted: R,
    tolerance: f64,
    work_extra: Option<&WorkBounds>,
) -> Result<VerifyReport, PostError> {
    verify_points_traced(
        machine,
        points,
        frame,
        head,
        process,
        posted,
        tolerance,
        work_extra,
        &mut |_, _| {},
    )
}

/// [`verify_points`], telling `on_point` the posted line and tip deviation of every
/// move it compares (for `verify --preview`).
#[allow(clippy::too_many_arguments)]
pub fn verify_points_traced<R: BufRead>(
    machine: &Machine,
    points: &[PathPoint],
    frame: &Frame,
    head: usize,
    process: &crate::Process,
    posted: R,
    tolerance: f64,
    work_extra: Option<&WorkBounds>,
    on_point: &mut dyn FnMut(u32, f64),
) -> Result<VerifyReport, PostError> {
    crate::verify::check_tolerance(tolerance)?;
    let units = program_units(machine);
    let placed = place(points, frame);
    let mut work = WorkBounds::empty();
    for q in &placed {
        work.add(&q.tip);
    }
    if let Some(extra) = work_extra {
        work.union(extra);
    }
    let mut safety = crate::verify::Safety::new(machine, head, work);
    let names = machine.axis_names();
    let idx = |n: &str| {
        n.bytes()
            .next()
            .and_then(|c| AXES.iter().position(|&a| a == c.to_ascii_uppercase()))
            .unwrap_or(0)
    };
    let ix: Vec<usize> = names.iter().map(|n| idx(n)).collect();
    let mut rep = VerifyReport::default();
    // Segment k runs from placed[k-1] to placed[k]; before the first point is reached,
    // the feeds are the approach onto it. `live`: the readings still possible (the next
    // point to reach), ascending.
    // Each reading carries the least fraction of its segment the tool can have come to
    // so far: moves go forward along the path (each within the tolerance), never back.
    let mut live: Vec<(usize, f64)> = vec![(0, 0.0)];
    let screen = crate::verify::Screen::new(machine, process)?;
    let mut stream = screen.stream(posted, units);
    let mut rules = crate::verify::PostedRules::new(machine.units, true, process)?;
    for ev in stream.by_ref() {
        let ev = ev.map_err(|e| PostError::Io(e.to_string()))?;
        screen.check()?;
        match ev {
            Event::Diagnostic(d) => {
                if let Some(e) = crate::verify::posted_diagnostic(d) {
                    return Err(e);
                }
            }
            Event::Stop(stop) => {
                // A path of points has no stops, and the post writes none.
                return Err(PostError::Verify(format!(
                    "posted line {}: a program stop ({}): a path of points has none, and the post writes none",
                    stop.line,
                    stop.kind.code()
                )));
            }
            Event::Move(m) => {
                rep.moves += 1;
                crate::verify::rotaries_commanded(&m, &ix[3..], ix[2])?;
                rules.check(&m, &ix[3..])?;
                let lin = |p: &[f64; 9]| [p[ix[0]], p[ix[1]], p[ix[2]]];
                let rot = |p: &[f64; 9]| [p[ix[3]], p[ix[4]]];
                safety.travel(&lin(&m.end), &rot(&m.end), m.line)?;
                crate::verify::process_state(&m, screen.switches(), process, None)?;
                if matches!(m.kind, MoveKind::Rapid) {
                    safety.rapid(
                        &lin(&m.start),
                        &rot(&m.start),
                        &lin(&m.end),
                        &rot(&m.end),
                        m.line,
                    )?;
                    continue;
                }
                safety.feed(&lin(&m.start), &lin(&m.end), m.line)?;
                within_between(machine, head, &m, &ix, &placed, &live, tolerance)?;
                let j = Joints {
                    linear: [m.end[ix[0]], m.end[ix[1]], m.end[ix[2]]],
                    rotary: [m.end[ix[3]], m.end[ix[4]]],
                };
                let pose = machine.forward(&j, head);
                let from = machine.forward(
                    &Joints {
                        linear: lin(&m.start),
                        rotary: rot(&m.start),
                    },
                    head,
                );
                let minutes = move_minutes(&m, &lin(&m.start), &lin(&m.end));
                let chord = (pose.tip - from.tip).norm();
                // Not faster than the feed of the point a reading goes to asks (the post
                // writes that feed, or slower where the rotaries or a block's shortest
                // time bound it); the tip's chord in the part frame, against the time the
                // text gives the move, with the tolerance at each end.
                let slow_enough = |k: usize| {
                    placed
                        .get(k)
                        .is_none_or(|q| chord <= q.feed * minutes * (1.0 + 1e-6) + 2.0 * tolerance)
                };
                let mut too_fast: Option<usize> = None;
                let mut paced = false;
                // Each live reading of the program so far (the next point to reach)
                // takes this move: reaching that point moves it on; a move on the way to
                // it (or the approach onto the first) keeps it. A point may be reached
                // by more than one move (a piece of a segment within the tolerance of
                // its end, then the end itself; repeated points), so every reading is
                // kept until a move rules it out.
                let mut next: Vec<(usize, f64)> = Vec::with_capacity(live.len() + 1);
                let mut best: Option<(f64, f64)> = None;
                let mut miss: Option<String> = None;
                // Whether a reading that takes this move lies on a segment that deposits
                // (segment k ends at point k, whose flag the post switches the laser by).
                let mut deposits = false;
                // Whether every reading that takes this move runs it along a segment that
                // deposits (from a start on that segment): the segment's input lines when
                // so, for a feed with the laser off.
                let mut dark: Option<(usize, usize)> = None;
                let mut not_along = false;
                let mut take = |k: usize| {
                    let on = k > 0
                        && placed[k].deposit
                        && segment_span(
                            &placed[k - 1],
                            &placed[k],
                            &from.tip,
                            &from.axis,
                            tolerance,
                        )
                        .is_some();
                    if on {
                        dark.get_or_insert((placed[k - 1].line, placed[k].line));
                    } else {
                        not_along = true;
                    }
                };
                for &(k, at) in live.iter().rev() {
                    let Some(target) = placed.get(k) else {
                        miss.get_or_insert_with(|| {
                            format!("posted line {} feeds on after the last point", m.line)
                        });
                        continue;
                    };
                    let (d_tip, d_ax) = (
                        (pose.tip - target.tip).norm(),
                        angle(&pose.axis, &target.axis),
                    );
                    // Reached: the tip there and the axis too (a path may turn the axis
                    // about a standing tip).
                    let reached = d_tip <= tolerance && d_ax <= AXIS_TOLERANCE_DEG;
                    if reached {
                        deposits |= k > 0 && target.deposit;
                        take(k);
                        next.push((k + 1, 0.0));
                        keep_best(&mut best, (d_tip, d_ax));
                        if slow_enough(k) {
                            paced = true;
                        } else {
                            too_fast.get_or_insert(k);
                        }
                    }
                    if k == 0 {
                        // The approach onto the first point: straight down to it (it
                        // ends once the point is reached).
                        if !reached {
                            take(0);
                            next.push((0, 0.0));
                        }
                        continue;
                    }
                    let a = &placed[k - 1];
                    match segment_span(a, target, &pose.tip, &pose.axis, tolerance) {
                        // Back along the segment from where the tool had come to.
                        Some((.., hi)) if hi < at && !reached => {
                            miss.get_or_insert_with(|| {
                                format!("posted line {}: the tool goes back along the path between points on lines {} and {} (to {:.4} of the way, from {:.4} or more)", m.line, a.line, target.line, hi, at)
                            });
                        }
                        Some((.., hi)) if hi < at => {}
                        Some((err, ang, lo, _)) => {
                            deposits |= target.deposit;
                            take(k);
                            next.push((k, at.max(lo)));
                            keep_best(&mut best, (err, ang));
                            if slow_enough(k) {
                                paced = true;
                            } else {
                                too_fast.get_or_insert(k);
                            }
                        }
                        None if !reached => {
                            miss.get_or_insert_with(|| {
                                let (err, ang) = nearest_miss(a, target, &pose.tip, &pose.axis);
                                format!("posted line {}: the tool is {err:.3e} and {ang:.3}° off the path between points on lines {} and {}", m.line, a.line, target.line)
                            });
                        }
                        None => {}
                    }
                }
                if let (Some(l), false, false) =
                    (screen.switches().laser, deposits, next.is_empty())
                {
                    return Err(PostError::Verify(format!(
                        "posted line {}: a feed with the laser on (posted line {l}) where the path deposits nothing",
                        m.line
                    )));
                }
                // The laser off along a depositing segment, by every reading, where the
                // tip moves (the post turns the laser off for a turn in place only).
                if let (Process::Deposit { .. }, None, false, Some((a, b))) =
                    (process, screen.switches().laser, not_along, dark)
                {
                    if chord > 2.0 * tolerance {
                        return Err(PostError::Verify(format!(
                            "posted line {}: a feed with the laser off along the path between points on lines {a} and {b}, which deposits: it would deposit nothing there",
                            m.line
                        )));
                    }
                }
                // One reading per point to reach: the one that has come least far.
                next.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
                next.dedup_by_key(|r| r.0);
                if next.is_empty() {
                    return Err(PostError::Verify(miss.unwrap_or_default()));
                }
                if let (false, Some(k)) = (paced, too_fast) {
                    return Err(PostError::Verify(format!(
                        "posted line {}: the tool moves along the path at {} units/min, faster than the feed F{} of the point on line {}",
                        m.line,
                        lampost_gcode::Readable((chord / minutes * 10.0).round() / 10.0),
                        lampost_gcode::Readable(placed[k].feed),
                        placed[k].line
                    )));
                }
                // Bounded work per move: the readings that have come furthest.
                if next.len() > MAX_READINGS {
                    next.drain(..next.len() - MAX_READINGS);
                }
                live = next;
                if let Some((err, ang)) = best {
                    on_point(m.line, err);
                    rep.compared += 1;
                    if err > rep.max_position_error {
                        rep.max_position_error = err;
                        rep.worst_line = m.line;
                    }
                    rep.max_axis_error_deg = rep.max_axis_error_deg.max(ang);
                }
            }
        }
    }
    if !live.iter().any(|r| r.0 == placed.len()) {
        let k = live.last().map_or(0, |r| r.0).min(placed.len() - 1);
        return Err(PostError::Verify(format!(
            "the posted program ends before the point on line {}",
            placed[k].line
        )));
    }
    screen.finish()?;
    safety.finish(stream.interpreter().ended())?;
    Ok(rep)
}

/// How long the posted feed `m` takes, as the text gives it (minutes): 1 / F under
/// G93, else its linear axes' distance (`a` to `b`) over F.
fn move_minutes(m: &lampost_gcode::Move, a: &[f64; 3], b: &[f64; 3]) -> f64 {
    if m.modal.feed_mode == lampost_gcode::FeedMode::InverseTime {
        1.0 / m.feed
    } else {
        let d = (0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt();
        d / m.feed
    }
}

/// The most a rotary may turn between two samples of one feed move that
/// [`within_between`] takes.
const SAMPLE_TURN_DEG: f64 = 45.0;

/// The most samples [`within_between`] takes of one move: a feed turning a rotary by
/// more than `SAMPLE_TURN_DEG` times this is refused outright.
const MAX_SAMPLES: usize = 720;

/// A feed move's points between its ends, as the control runs it (every joint
/// linearly), where a rotary turns in it: its middle, or, where a rotary turns by more
/// than [`SAMPLE_TURN_DEG`], points at most that turn apart, each on the segment of one
/// of the `live` readings (the approach onto the first point is not judged here). Only
/// the ends were compared before, so a continuous rotary turned a whole turn more at one
/// point (C348.75 for C−11.25) passed, the table spinning under the head between two
/// points of the path; and so did one feed left of a segment's split pieces, its ends on
/// the path and its middle 1.2 mm off (`safety_cli.rs`). A feed whose rotaries stand
/// moves the tip straight at a fixed axis: its ends decide.
fn within_between(
    machine: &Machine,
    head: usize,
    m: &lampost_gcode::Move,
    ix: &[usize],
    placed: &[PathPoint],
    live: &[(usize, f64)],
    tolerance: f64,
) -> Result<(), PostError> {
    let turn = ix[3..]
        .iter()
        .map(|&r| (m.end[r] - m.start[r]).abs())
        .fold(0.0f64, f64::max);
    if turn == 0.0 {
        return Ok(());
    }
    let n = (turn / SAMPLE_TURN_DEG).ceil().max(2.0);
    if n.is_nan() || n > MAX_SAMPLES as f64 {
        return Err(PostError::Verify(format!(
            "posted line {}: a feed turns a rotary by {turn:.3}°, more than the post ever writes in one move",
            m.line
        )));
    }
    let n = n as usize;
    for s in 1..n {
        let t = s as f64 / n as f64;
        let at = |a: usize| m.start[a] + (m.end[a] - m.start[a]) * t;
        let pose = machine.forward(
            &Joints {
                linear: [at(ix[0]), at(ix[1]), at(ix[2])],
                rotary: [at(ix[3]), at(ix[4])],
            },
            head,
        );
        let on = live.iter().any(|&(k, _)| {
            k == 0
                || (k < placed.len()
                    && on_segment(&placed[k - 1], &placed[k], &pose.tip, &pose.axis, tolerance)
                        .is_some())
        });
        if !on {
            let k = live.last().map_or(1, |r| r.0).clamp(1, placed.len() - 1);
            let (err, ang) = nearest_miss(&placed[k - 1], &placed[k], &pose.tip, &pose.axis);
            return Err(PostError::Verify(format!(
                "posted line {}: {:.0} % of the way along the move, the tool is {err:.3e} and {ang:.3}° off the path between points on lines {} and {}",
                m.line,
                t * 100.0,
                placed[k - 1].line,
                placed[k].line
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{fields, looks_like_points, KEPT};
    use proptest::prelude::*;

    /// The fields of a line by characters, kept whole: the reference [`fields`] (bytes,
    /// the first [`KEPT`] kept, the rest counted) is tested against.
    fn fields_reference(raw: &str) -> Vec<(usize, &str)> {
        let code = raw.split('#').next().unwrap_or("");
        let mut out = Vec::new();
        let mut start = None;
        for (p, ch) in code.char_indices() {
            match (matches!(ch, ' ' | '\t' | ','), start) {
                (false, None) => start = Some(p),
                (true, Some(s)) => {
                    out.push((s, &code[s..p]));
                    start = None;
                }
                _ => {}
            }
        }
        if let Some(s) = start {
            out.push((s, &code[s..]));
        }
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(5_000))]
        /// Lines of numbers, words and non-ASCII text between runs of spaces, tabs and
        /// commas, with and without a comment: the same fields at the same byte offsets.
        #[test]
        fn fields_by_bytes_are_the_fields_by_characters(
            parts in prop::collection::vec(
                (prop_oneof![
                    Just("1.5".to_string()), Just("-2e3".to_string()), Just("x".to_string()),
                    Just("ø÷µ".to_string()), Just("é1".to_string()), Just("600".to_string()),
                    "[0-9.]{1,6}",
                ], prop_oneof![Just(" "), Just("\t"), Just(","), Just(" , "), Just("\u{a0}")]),
                0..14,
            ),
            comment in prop_oneof![Just(""), Just("# note 1 2"), Just("#")],
        ) {
            let mut line = String::new();
            for (f, sep) in &parts {
                line.push_str(f);
                line.push_str(sep);
            }
            line.push_str(comment);
            let want = fields_reference(&line);
            let got = fields(&line);
            prop_assert_eq!(got.n, want.len());
            prop_assert_eq!(got.kept(), &want[..want.len().min(KEPT)]);
            let rest = want.iter().skip(KEPT).any(|(_, f)| f.parse::<f64>().is_ok());
            prop_assert_eq!(got.rest_numeric, rest);
        }
    }

    #[test]
    fn a_path_is_told_from_a_program_by_its_first_line() {
        let path =
            "# lampost plan path plate.stl: 10 layers\nx y z i j k feed laser\n1 2 3 0 0 1 600 1\n";
        assert!(looks_like_points(path));
        assert!(looks_like_points("X,Y,Z,I,J,K\n1,2,3,0,0,1\n"));
        assert!(looks_like_points("\n  1.5 2 3 0 0 1\n"));
        assert!(looks_like_points(
            "1 2 3 0 0 1 600 0 # a row with a comment\n"
        ));
        for program in [
            "%\nO1000\nG0 X1 Y2\n",
            "G21 G90\nG1 X1 F100\n",
            "(x y z i j k)\nG0 X0\n",
            "; generated by PrusaSlicer\nG28\n",
            "#1 = 5\nG0 X#1\n",
            "N10 G0 X1 Y2 Z3 A0 B0\n",
            "1 2 3\n",
            "",
        ] {
            assert!(!looks_like_points(program), "{program:?}");
        }
    }
}
