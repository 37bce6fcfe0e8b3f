//! Controller output: location files of at most N locations each, cut where the laser is
//! off, each starting and ending at the safe location; and their verification.
//!
//! A location file (format `lampost robot locations 1`, one per chunk) is text: `#`
//! header lines, then one row per location:
//!
//! ```text
//! n kind index dt x y z rz1 ry rz2 laser j1 j2 j3 j4 j5 j6
//! ```
//!
//! `n` counts rows from 1; `kind` is `safe` (first and last row) or `path`; `index` is the
//! location's place on the whole resampled path (from 0; `-` for safe rows); `dt` the
//! seconds allowed for the move to this row (0 for the safe rows and for the first path
//! row, which the controller reaches by a joint move from the safe location); `x y z rz1
//! ry rz2` the part frame's pose in the working frame (origin at the laser's focus, z
//! from the focus into the head), position in the machine's units and orientation as
//! ZYZ Euler angles in degrees, `R = Rz(rz1) · Ry(ry) · Rz(rz2)`; `laser` 1 when the
//! laser is on during the move to this row; `j1 … j6` the joint values in degrees, which
//! put the part there (forward kinematics of the arm file).

use std::ops::Range;

use nalgebra::{Matrix3, Vector3};

use crate::arm::{zyz_third, Arm, Config, Frame, Q};
use crate::error::RobotError;
use crate::plan::{check_speed, Located, Sample};

/// The format line of every location file.
pub const FORMAT: &str = "lampost robot locations 1";

/// Largest angle between the approach and the beam that verification accepts, degrees.
pub const AXIS_TOLERANCE_DEG: f64 = 0.01;

/// Where to cut: ranges of sample indices, each at most `chunk_points − 2` long, every
/// cut before a sample reached with the laser off.
pub fn chunk_ranges(
    samples: &[Sample],
    chunk_points: usize,
) -> Result<Vec<Range<usize>>, RobotError> {
    if chunk_points < 3 {
        return Err(RobotError::Option(format!(
            "--chunk-points {chunk_points}: a chunk holds the two safe locations and at least one path location (3)"
        )));
    }
    let cap = chunk_points - 2;
    let n = samples.len();
    let mut out = Vec::new();
    let mut start = 0;
    while start < n {
        let end = start.saturating_add(cap);
        if end >= n {
            out.push(start..n);
            break;
        }
        // The last cut that fits: before a sample reached with the laser off.
        match (start + 1..=end).rev().find(|&b| !samples[b].deposit) {
            Some(b) => {
                out.push(start..b);
                start = b;
            }
            None => {
                let run_start = (start + 1..=end)
                    .rev()
                    .find(|&b| !samples[b].deposit)
                    .map_or(start, |b| b);
                let run_end = (end..n).find(|&b| !samples[b].deposit).unwrap_or(n);
                let (l0, l1) = (samples[run_start].line, samples[run_end - 1].line);
                return Err(RobotError::ChunkTooSmall {
                    line: l0,
                    what: format!(
                        "a chunk of {chunk_points} locations ({cap} on the path besides the two safe ones) cannot hold the laser-on run from line {l0} to line {l1}, at least {} locations: chunks are cut only where the laser is off",
                        run_end - run_start
                    ),
                });
            }
        }
    }
    Ok(out)
}

/// ZYZ Euler angles (radians) of a rotation: `R = Rz(a) · Ry(b) · Rz(c)`, b in [0, π].
/// c is taken from a and R's upper-left block (a + c or a − c, whichever is well
/// conditioned), so the three give R back
/// to rounding however near b lies to 0 or π.
pub fn zyz(r: &Matrix3<f64>) -> [f64; 3] {
    let sb = r[(0, 2)].hypot(r[(1, 2)]);
    let block = [r[(0, 0)], r[(0, 1)], r[(1, 0)], r[(1, 1)], r[(2, 2)]];
    let (a, b, da) = if sb < 1e-12 {
        let b = if r[(2, 2)] > 0.0 {
            0.0
        } else {
            std::f64::consts::PI
        };
        (0.0, b, (1.0, 0.0))
    } else {
        let da = (r[(0, 2)], r[(1, 2)]);
        (da.1.atan2(da.0), sb.atan2(r[(2, 2)]), da)
    };
    let (x, y) = zyz_third(block, da);
    [a, b, y.atan2(x)]
}

/// The rotation of ZYZ Euler angles (radians), `Rz(a) · Ry(b) · Rz(c)` multiplied out
/// (the product's entries without its multiplications by 0 and 1; against the product in
/// the tests).
pub fn from_zyz(e: [f64; 3]) -> Matrix3<f64> {
    let (sa, ca) = e[0].sin_cos();
    let (sb, cb) = e[1].sin_cos();
    let (sc, cc) = e[2].sin_cos();
    let (cacb, sacb) = (ca * cb, sa * cb);
    Matrix3::new(
        cacb * cc - sa * sc,
        -cacb * sc - sa * cc,
        ca * sb,
        sacb * cc + ca * sc,
        -sacb * sc + ca * cc,
        sa * sb,
        -sb * cc,
        sb * sc,
        cb,
    )
}

/// The Frobenius distance `‖a − b‖` of two rotations, which is `2√2 · sin(θ/2)` for the
/// angle θ between them: an angle test without a product or an arctangent.
fn rot_chord(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (a - b).norm()
}

/// The angle between two rotations from their [`rot_chord`], radians.
fn chord_angle(chord: f64) -> f64 {
    2.0 * (chord / (2.0 * std::f64::consts::SQRT_2)).min(1.0).asin()
}

/// The chord of [`ROT_TOL`]: rotations farther apart than this are more than
/// [`ROT_TOL`] apart.
fn tol_chord() -> f64 {
    2.0 * std::f64::consts::SQRT_2 * (ROT_TOL / 2.0).sin()
}

/// Largest angle between the written pose's rotation and the joints', radians.
const ROT_TOL: f64 = 1e-6;

/// ` value` to `decimals` places by the G-code emitter's fixed-point writer (one rounding
/// of an integer, `-0` written `0`; `lampost_gcode::fixed`'s text, appended without
/// allocating), a fraction of the cost of `format!`.
fn push_num(out: &mut Vec<u8>, value: f64, decimals: usize) {
    out.push(b' ');
    lampost_gcode::push_fixed(out, value, decimals);
}

/// A location row's values as written: the pose's position and ZYZ angles in degrees,
/// the joints in degrees.
struct RowValues {
    n: usize,
    kind: &'static str,
    index: Option<usize>,
    dt: f64,
    pos: [f64; 3],
    angles: [f64; 3],
    laser: bool,
    joints: [f64; 6],
}

impl RowValues {
    fn new(
        n: usize,
        kind: &'static str,
        index: Option<usize>,
        dt: f64,
        part: &Frame,
        laser: bool,
        q: &Q,
    ) -> RowValues {
        RowValues {
            n,
            kind,
            index,
            dt,
            pos: [part.t.x, part.t.y, part.t.z],
            angles: zyz(&part.r).map(f64::to_degrees),
            laser,
            joints: q.map(f64::to_degrees),
        }
    }
}

/// The row's text number by number through `lampost_gcode::push_fixed` and `write!`:
/// the reference [`compose_row`] is held to, and the writer of rows it cannot compose.
fn row_reference(out: &mut Vec<u8>, v: &RowValues) {
    use std::io::Write;
    // Writing to a `Vec` cannot fail.
    let _ = match v.index {
        Some(i) => write!(out, "{} {} {i}", v.n, v.kind),
        None => write!(out, "{} {} -", v.n, v.kind),
    };
    push_num(out, v.dt, 6);
    for x in v.pos {
        push_num(out, x, 6);
    }
    for x in v.angles {
        push_num(out, x, 7);
    }
    out.extend_from_slice(if v.laser { b" 1" } else { b" 0" });
    for x in v.joints {
        push_num(out, x, 7);
    }
    out.push(b'\n');
}

/// The longest row [`compose_row`] writes: two whole numbers of at most 20 digits, a
/// kind of at most 4 letters, 13 numbers of at most 17 bytes and 17 separators.
const ROW_MAX: usize = 2 * 20 + 4 + 13 * 17 + 17 + 2;

/// A row composed on the stack ([`compose_row`]), its length kept.
struct Composed {
    buf: [u8; ROW_MAX + 32],
    len: usize,
}

impl Composed {
    fn room(&mut self) -> Option<&mut [u8; 32]> {
        self.buf.get_mut(self.len..)?.first_chunk_mut()
    }

    fn bytes(&mut self, b: &[u8]) -> Option<()> {
        self.room()?.get_mut(..b.len())?.copy_from_slice(b);
        self.len += b.len();
        Some(())
    }

    fn whole(&mut self, w: usize) -> Option<()> {
        let w = u64::try_from(w).ok()?;
        self.len += lampost_gcode::whole_into(self.room()?, w);
        Some(())
    }

    fn fixed<const D: usize>(&mut self, x: f64) -> Option<()> {
        self.bytes(b" ")?;
        self.len += lampost_gcode::fixed_into::<D>(self.room()?, x)?;
        Some(())
    }
}

/// The row's text composed on the stack by `lampost_gcode::fixed_into` (the same text
/// as [`row_reference`], property-tested) and appended once; `None` (nothing appended)
/// where a value lies beyond its fast range.
fn compose_row(out: &mut Vec<u8>, v: &RowValues) -> Option<()> {
    let mut c = Composed {
        buf: [b' '; ROW_MAX + 32],
        len: 0,
    };
    c.whole(v.n)?;
    c.bytes(b" ")?;
    c.bytes(v.kind.as_bytes())?;
    c.bytes(b" ")?;
    match v.index {
        Some(i) => c.whole(i)?,
        None => c.bytes(b"-")?,
    }
    c.fixed::<6>(v.dt)?;
    for x in v.pos {
        c.fixed::<6>(x)?;
    }
    for x in v.angles {
        c.fixed::<7>(x)?;
    }
    c.bytes(if v.laser { b" 1" } else { b" 0" })?;
    for x in v.joints {
        c.fixed::<7>(x)?;
    }
    c.bytes(b"\n")?;
    out.extend_from_slice(c.buf.get(..c.len)?);
    Some(())
}

/// One row appended: composed on the stack, else number by number.
fn row(out: &mut Vec<u8>, v: &RowValues) {
    if compose_row(out, v).is_none() {
        row_reference(out, v);
    }
}

/// The part frame in the working frame for joint values `q`.
pub fn part_of(arm: &Arm, q: &Q) -> Frame {
    arm.head.inverse().mul(&arm.part(q))
}

/// Room reserved a row in a chunk's text: the plate's rows average 161 bytes (a path
/// row of the full-size plate at `--layer 2`), so the text is not copied as it grows.
const ROW_BYTES: usize = 176;

/// One chunk's location file.
pub fn write_chunk(
    arm: &Arm,
    cfg: Config,
    samples: &[Sample],
    located: &[Located],
    range: Range<usize>,
    k: usize,
    total: usize,
) -> String {
    let mut s = Vec::new();
    write_chunk_into(&mut s, arm, cfg, samples, located, range, k, total);
    // UTF-8 throughout (the header's text and ASCII rows).
    String::from_utf8(s).unwrap_or_else(|e| String::from_utf8_lossy(e.as_bytes()).into_owned())
}

/// [`write_chunk`]'s text into `s` (cleared first; its room kept for the next chunk).
#[allow(clippy::too_many_arguments)]
fn write_chunk_into(
    s: &mut Vec<u8>,
    arm: &Arm,
    cfg: Config,
    samples: &[Sample],
    located: &[Located],
    range: Range<usize>,
    k: usize,
    total: usize,
) {
    let units = match arm.units {
        crate::def::Units::Mm => "mm",
        crate::def::Units::Inch => "inch",
    };
    let head = format!(
        "# {FORMAT}\n# machine {}\n# chunk {k} of {total}\n# config {}\n# units {units}, degrees, seconds\n# frame: working (origin at the laser focus, z from the focus into the head); pose of the part frame, R = Rz(rz1)·Ry(ry)·Rz(rz2)\n# n kind index dt x y z rz1 ry rz2 laser j1 j2 j3 j4 j5 j6\n",
        arm.name,
        cfg.letters()
    );
    s.clear();
    s.reserve(head.len() + (range.len() + 2) * ROW_BYTES);
    s.extend_from_slice(head.as_bytes());
    let safe = part_of(arm, &arm.safe);
    let safe_row = |n| RowValues::new(n, "safe", None, 0.0, &safe, false, &arm.safe);
    row(s, &safe_row(1));
    let mut n = 2;
    for i in range.clone() {
        let dt = if i == range.start { 0.0 } else { samples[i].dt };
        let laser = i != range.start && samples[i].deposit;
        let part = located[i].part(&samples[i]);
        row(
            s,
            &RowValues::new(n, "path", Some(i), dt, &part, laser, &located[i].q),
        );
        n += 1;
    }
    row(s, &safe_row(n));
}

/// The name of chunk `k` (from 1): `chunk-001.loc`, ….
pub fn file_name(k: usize) -> String {
    format!("chunk-{k:03}.loc")
}

/// The number of threads the chunked work takes by default: two where the machine has
/// them (the work is split by chunks; the result does not depend on it).
pub fn default_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get().min(2))
}

/// `f(0) … f(n − 1)` in order, worked out on up to `threads` threads, each taking the
/// next index as it finishes one.
pub(crate) fn par_map<T: Send>(n: usize, threads: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let threads = threads.clamp(1, n.max(1));
    if threads == 1 {
        return (0..n).map(f).collect();
    }
    let next = AtomicUsize::new(0);
    let work = || {
        let mut done = Vec::new();
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= n {
                break done;
            }
            done.push((i, f(i)));
        }
    };
    workers(threads, work).into_iter().map(|x| x.1).collect()
}

/// `work` run on `threads` threads at once (this one among them), each returning what it
/// did as (index, result); all of it in index order. A worker's panic goes on here.
fn workers<T: Send>(threads: usize, work: impl Fn() -> Vec<(usize, T)> + Sync) -> Vec<(usize, T)> {
    let mut all: Vec<(usize, T)> = std::thread::scope(|s| {
        let others: Vec<_> = (1..threads).map(|_| s.spawn(&work)).collect();
        let mut all = work();
        for h in others {
            match h.join() {
                Ok(v) => all.extend(v),
                Err(p) => std::panic::resume_unwind(p),
            }
        }
        all
    });
    all.sort_unstable_by_key(|x| x.0);
    all
}

/// Every chunk's location file ([`write_chunk`]) named by [`file_name`], the chunks
/// written on up to `threads` threads (the text is the same on any number).
pub fn chunk_files(
    arm: &Arm,
    cfg: Config,
    samples: &[Sample],
    located: &[Located],
    ranges: &[Range<usize>],
    threads: usize,
) -> Vec<ChunkFile> {
    par_map(ranges.len(), threads, |k| {
        let r = &ranges[k];
        ChunkFile {
            name: file_name(k + 1),
            first: r.start,
            count: r.len(),
            text: write_chunk(arm, cfg, samples, located, r.clone(), k + 1, ranges.len()),
        }
    })
}

/// A chunk as the manifest lists it, with its file's text.
#[derive(Debug, Clone)]
pub struct ChunkFile {
    /// The file's name (for messages).
    pub name: String,
    /// First path location.
    pub first: usize,
    /// Path locations.
    pub count: usize,
    /// The file's text.
    pub text: String,
}

/// What verification measured.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Report {
    /// Path locations compared.
    pub locations: usize,
    /// Chunks read.
    pub chunks: usize,
    /// Largest distance of the focus from its path point.
    pub max_focus_error: f64,
    /// Largest angle between the beam and the approach, degrees.
    pub max_axis_error_deg: f64,
}

fn verr(file: &str, line: usize, message: String) -> RobotError {
    RobotError::Verify {
        file: file.to_string(),
        line,
        message,
    }
}

/// Verify chunked output against the resampled path: every location's joints within
/// limits and in configuration `cfg`, their forward kinematics putting the path point at
/// the focus (within `tol`) with the approach along the beam (within 0.01°), the written
/// pose equal to it, the laser and times as planned, no joint too fast, the safe
/// location at both ends of every chunk, and every path location in exactly one chunk.
/// The chunks are read on up to two threads ([`verify_threads`]).
pub fn verify(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    chunks: &[ChunkFile],
    tol: f64,
) -> Result<Report, RobotError> {
    verify_threads(arm, samples, cfg, chunks, tol, default_threads())
}

/// [`verify`] with the chunks read on up to `threads` threads (each chunk is checked on
/// its own; the error reported is the first in chunk order, as one thread finds it).
pub fn verify_threads(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    chunks: &[ChunkFile],
    tol: f64,
    threads: usize,
) -> Result<Report, RobotError> {
    let per = par_map(chunks.len(), threads, |k| {
        let c = &chunks[k];
        let read = Read {
            name: &c.name,
            first: c.first,
            count: c.count,
            text: &c.text,
            k,
            total: chunks.len(),
        };
        verify_chunk(arm, samples, cfg, read, tol)
    });
    let places: Vec<(&str, usize, usize)> = chunks
        .iter()
        .map(|c| (c.name.as_str(), c.first, c.count))
        .collect();
    gather(samples, &places, per)
}

/// The chunks' reports gathered in chunk order, with the chunks' order checked: each
/// starting where the last ended, the last ending at the path's end (`places`: each
/// chunk's name, first location and count). The first error in chunk order.
fn gather(
    samples: &[Sample],
    places: &[(&str, usize, usize)],
    per: Vec<Result<Report, RobotError>>,
) -> Result<Report, RobotError> {
    let mut rep = Report {
        chunks: places.len(),
        ..Report::default()
    };
    let mut next = 0usize;
    for (&(name, first, count), r) in places.iter().zip(per) {
        if first != next {
            let (a, b) = (next.min(first), next.max(first));
            return Err(verr(name, 0, gap(samples, a, b)));
        }
        let r = r?;
        rep.locations += r.locations;
        rep.max_focus_error = rep.max_focus_error.max(r.max_focus_error);
        rep.max_axis_error_deg = rep.max_axis_error_deg.max(r.max_axis_error_deg);
        next = first.saturating_add(count);
    }
    if next != samples.len() {
        return Err(verr(
            places.last().map_or("manifest", |c| c.0),
            0,
            gap(samples, next.min(samples.len()), samples.len().max(next)),
        ));
    }
    Ok(rep)
}

/// A chunk's file as verification reads it: its name, place on the path (first path
/// location and count), text, and its number `k` (from 0) of `total`.
#[derive(Clone, Copy)]
struct Read<'a> {
    name: &'a str,
    first: usize,
    count: usize,
    text: &'a str,
    k: usize,
    total: usize,
}

/// A chunk as the manifest lists it (its text handed on by [`post_chunks`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChunkInfo {
    /// The file's name ([`file_name`]).
    pub name: String,
    /// First path location.
    pub first: usize,
    /// Path locations.
    pub count: usize,
}

/// Why [`post_chunks`] stopped: a chunk failed verification, or `keep` failed.
#[derive(Debug)]
pub enum PostError<E> {
    /// Verification (a lampost fault: the text was just written from the plan).
    Verify(RobotError),
    /// What `keep` returned.
    Keep(E),
}

/// Every chunk's location file written ([`write_chunk`]) and verified as [`verify`]
/// verifies it, chunk by chunk on up to `threads` threads, each writing into one buffer
/// it reuses: memory for a chunk a thread, not for the whole output, and each text read
/// back while it is still in the cache. Each verified text is handed to `keep` with its
/// chunk (in whatever order the threads finish; `keep` stages it, say). After a failure
/// no new chunk is started. The chunks as the manifest lists them and the report; the
/// first error in chunk order. The text is the same on any number of threads.
#[allow(clippy::too_many_arguments)]
pub fn post_chunks<E: Send>(
    arm: &Arm,
    cfg: Config,
    samples: &[Sample],
    located: &[Located],
    ranges: &[Range<usize>],
    tol: f64,
    threads: usize,
    keep: impl Fn(&ChunkInfo, &[u8]) -> Result<(), E> + Sync,
) -> Result<(Vec<ChunkInfo>, Report), PostError<E>> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    let total = ranges.len();
    let infos: Vec<ChunkInfo> = ranges
        .iter()
        .enumerate()
        .map(|(k, r)| ChunkInfo {
            name: file_name(k + 1),
            first: r.start,
            count: r.len(),
        })
        .collect();
    let (next, failed) = (AtomicUsize::new(0), AtomicBool::new(false));
    let work = || {
        let mut buf: Vec<u8> = Vec::new();
        let mut done: Vec<(usize, Result<Report, PostError<E>>)> = Vec::new();
        while !failed.load(Ordering::Relaxed) {
            let k = next.fetch_add(1, Ordering::Relaxed);
            let (Some(r), Some(info)) = (ranges.get(k), infos.get(k)) else {
                break;
            };
            write_chunk_into(
                &mut buf,
                arm,
                cfg,
                samples,
                located,
                r.clone(),
                k + 1,
                total,
            );
            let res = match std::str::from_utf8(&buf) {
                Ok(text) => {
                    let read = Read {
                        name: &info.name,
                        first: info.first,
                        count: info.count,
                        text,
                        k,
                        total,
                    };
                    verify_chunk(arm, samples, cfg, read, tol).map_err(PostError::Verify)
                }
                Err(e) => Err(PostError::Verify(verr(&info.name, 0, e.to_string()))),
            };
            let res = res.and_then(|rep| keep(info, &buf).map(|()| rep).map_err(PostError::Keep));
            failed.fetch_or(res.is_err(), Ordering::Relaxed);
            done.push((k, res));
        }
        done
    };
    let all = workers(threads.clamp(1, total.max(1)), work);
    // The first failure in chunk order (chunks after it may not have been started).
    let mut per = Vec::with_capacity(all.len());
    for (_, r) in all {
        match r {
            Ok(rep) => per.push(Ok(rep)),
            Err(PostError::Verify(e)) => per.push(Err(e)),
            Err(keep_failed) if per.iter().all(Result::is_ok) => return Err(keep_failed),
            Err(_) => break,
        }
    }
    if per.len() < total {
        // Stopped early: the failure is among those gathered.
        per.push(Err(verr("manifest", 0, "verification stopped".into())));
    }
    let places: Vec<(&str, usize, usize)> = infos
        .iter()
        .map(|c| (c.name.as_str(), c.first, c.count))
        .collect();
    let rep = gather(samples, &places, per).map_err(PostError::Verify)?;
    Ok((infos, rep))
}

/// Chunk `k` alone: its header, rows and locations (everything but the chunks' order).
fn verify_chunk(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    c: Read,
    tol: f64,
) -> Result<Report, RobotError> {
    let mut rep = Report::default();
    // The working frame's pose of the base, once: a location's part frame is this times
    // the flange times the holder.
    let head_base = arm.head.inverse().mul(&arm.base);
    let chord_tol = tol_chord();
    let f = c.name;
    let mut header = Vec::new();
    let mut rows: Vec<(usize, &str)> = Vec::new();
    for (i, line) in c.text.lines().enumerate() {
        if let Some(h) = line.strip_prefix('#') {
            header.push((i + 1, h.trim()));
        } else if !line.trim().is_empty() {
            rows.push((i + 1, line));
        }
    }
    let want = [
        FORMAT.to_string(),
        format!("machine {}", arm.name),
        format!("chunk {} of {}", c.k + 1, c.total),
        format!("config {}", cfg.letters()),
    ];
    for (w, (line, h)) in want
        .iter()
        .zip(header.iter().chain(std::iter::repeat(&(0, ""))))
    {
        if h != w {
            return Err(verr(f, *line, format!("header says `{h}`, expected `{w}`")));
        }
    }
    if c.count.checked_add(2) != Some(rows.len()) {
        return Err(verr(
            f,
            0,
            format!(
                "{} rows; the manifest gives {} path locations plus two safe ones",
                rows.len(),
                c.count
            ),
        ));
    }
    let mut prev: Option<Q> = None;
    for (r, &(line, text)) in rows.iter().enumerate() {
        let (fields, plain, count) = read_row(text);
        if count != 17 {
            return Err(verr(
                f,
                line,
                format!("{count} fields; a location row has 17"),
            ));
        }
        let num = |k: usize| -> Result<f64, RobotError> {
            plain[k]
                .or_else(|| parse_number(fields[k]))
                .filter(|v| v.is_finite())
                .ok_or_else(|| verr(f, line, format!("`{}` is not a finite number", fields[k])))
        };
        if !is_decimal(fields[0], r + 1) {
            return Err(verr(
                f,
                line,
                format!("row number `{}`, expected {}", fields[0], r + 1),
            ));
        }
        let q: Q =
            [num(11)?, num(12)?, num(13)?, num(14)?, num(15)?, num(16)?].map(f64::to_radians);
        if let Some(j) = arm.within_limits(&q) {
            return Err(verr(
                f,
                line,
                format!(
                    "{} = {}° is outside its limits [{:.1}°, {:.1}°]",
                    arm.joint_name(j),
                    fields[11 + j],
                    arm.links[j].lo.to_degrees(),
                    arm.links[j].hi.to_degrees()
                ),
            ));
        }
        // One chain for the pose and the configuration.
        let frames = arm.chain_dh(&q);
        let part = head_base.mul(&frames[6]).mul(&arm.holder);
        let pos = Vector3::new(num(4)?, num(5)?, num(6)?);
        let rot = from_zyz([num(7)?, num(8)?, num(9)?].map(f64::to_radians));
        let dpos = (pos - part.t).norm();
        let chord = rot_chord(&rot, &part.r);
        if dpos > 1e-4 || chord > chord_tol {
            return Err(verr(f, line, format!(
                "the written pose is not where the joints put the part ({dpos:.2e} away, {:.2e}° turned)",
                chord_angle(chord).to_degrees()
            )));
        }
        let is_safe = r == 0 || r == rows.len() - 1;
        let laser = match fields[10] {
            "0" => false,
            "1" => true,
            other => return Err(verr(f, line, format!("laser `{other}`: 0 or 1"))),
        };
        if is_safe {
            let off = q
                .iter()
                .zip(&arm.safe)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            if fields[1] != "safe" || fields[2] != "-" || off > 1e-8 || laser {
                return Err(verr(
                    f,
                    line,
                    "a chunk starts and ends at the safe location, laser off".into(),
                ));
            }
            prev = None;
            continue;
        }
        let i = c.first.saturating_add(r - 1);
        if fields[1] != "path" || !is_decimal(fields[2], i) {
            return Err(verr(
                f,
                line,
                format!("`{} {}`, expected `path {i}`", fields[1], fields[2]),
            ));
        }
        let Some(s) = samples.get(i) else {
            return Err(verr(
                f,
                line,
                format!(
                    "location {i} is beyond the path's {} locations",
                    samples.len()
                ),
            ));
        };
        let first_row = r == 1;
        let want_laser = !first_row && s.deposit;
        if first_row && i > 0 && s.deposit {
            return Err(verr(
                f,
                line,
                "the chunk starts inside a laser-on run".into(),
            ));
        }
        if laser != want_laser {
            return Err(verr(
                f,
                line,
                format!(
                    "laser {}, the path has it {}",
                    u8::from(laser),
                    u8::from(want_laser)
                ),
            ));
        }
        let dt = num(3)?;
        let want_dt = if first_row { 0.0 } else { s.dt };
        if (dt - want_dt).abs() > 1e-6 * want_dt.max(1.0) {
            return Err(verr(
                f,
                line,
                format!("dt {dt}, the path's feed gives {want_dt:.6}"),
            ));
        }
        // The focus on the path, the approach along the beam.
        let focus = part.apply(&s.tip).norm();
        let axis = part.r * s.axis;
        let ang = axis.cross(&Vector3::z()).norm().atan2(axis.z).to_degrees();
        if focus > tol {
            return Err(verr(
                f,
                line,
                format!(
                    "the focus is {focus:.4} from the path point of line {} (tolerance {tol})",
                    s.line
                ),
            ));
        }
        if ang > AXIS_TOLERANCE_DEG {
            return Err(verr(f, line, format!(
                "the approach is {ang:.4}° off the beam at the path point of line {} (tolerance {AXIS_TOLERANCE_DEG}°)",
                s.line
            )));
        }
        if let Some(co) = arm.config_of_chain(&q, &frames) {
            if !co.fits(cfg) {
                return Err(verr(f, line, format!(
                    "the joints are not in configuration {} (shoulder {}, elbow {}, wrist {}): a configuration flip inside the chunk",
                    cfg.letters(),
                    co.right.map_or("either", |r| if r { "right" } else { "left" }),
                    co.up.map_or("either", |u| if u { "up" } else { "down" }),
                    co.flip.map_or("either", |x| if x { "flipped" } else { "not flipped" }),
                )));
            }
        }
        if let Some(p) = prev {
            check_speed(arm, &Sample { dt: want_dt, ..*s }, &p, &q)
                .map_err(|e| verr(f, line, e.to_string()))?;
        }
        rep.max_focus_error = rep.max_focus_error.max(focus);
        rep.max_axis_error_deg = rep.max_axis_error_deg.max(ang);
        rep.locations += 1;
        prev = Some(q);
    }
    Ok(rep)
}

/// The first 17 fields of a row split at ASCII whitespace (the format's separators), and
/// how many fields the row has: [`read_row`]'s reference. A field is a run of bytes
/// other than ASCII whitespace; cut at ASCII bytes, each is whole UTF-8 text.
#[cfg(test)]
fn fields_of(text: &str) -> ([&str; 17], usize) {
    let mut fields = [""; 17];
    let mut count = 0;
    let mut start = None;
    let b = text.as_bytes();
    for (i, c) in b.iter().enumerate() {
        match (c.is_ascii_whitespace(), start) {
            (true, Some(s)) => {
                if let Some(x) = fields.get_mut(count) {
                    *x = text.get(s..i).unwrap_or_default();
                }
                count += 1;
                start = None;
            }
            (false, None) => start = Some(i),
            _ => {}
        }
    }
    if let Some(s) = start {
        if let Some(x) = fields.get_mut(count) {
            *x = text.get(s..).unwrap_or_default();
        }
        count += 1;
    }
    (fields, count)
}

/// A row's fields as [`fields_of`] splits them, each read as a number by
/// [`parse_plain`] as the same pass goes over its bytes (`None` where it is not in
/// `parse_plain`'s form: read by [`parse_number`] from the field's text), and how many
/// fields the row has. Property-tested against [`fields_of`] and [`parse_plain`].
fn read_row(text: &str) -> ([&str; 17], [Option<f64>; 17], usize) {
    let mut fields = [""; 17];
    let mut plain = [None; 17];
    let mut count = 0;
    let b = text.as_bytes();
    let mut i = 0;
    loop {
        while b.get(i).is_some_and(u8::is_ascii_whitespace) {
            i += 1;
        }
        if i >= b.len() {
            break;
        }
        let start = i;
        let (value, end) = plain_prefix(b, start);
        i = end;
        let value = match b.get(i) {
            Some(c) if !c.is_ascii_whitespace() => {
                // More than a number: the field goes on to the next space.
                while b.get(i).is_some_and(|c| !c.is_ascii_whitespace()) {
                    i += 1;
                }
                None
            }
            _ => value,
        };
        if let (Some(x), Some(v)) = (fields.get_mut(count), plain.get_mut(count)) {
            *x = text.get(start..i).unwrap_or_default();
            *v = value;
        }
        count += 1;
    }
    (fields, plain, count)
}

/// The longest prefix of `b[start..]` made of `-`, digits and points as a plain decimal
/// begins, read as [`parse_plain`] reads it, and where it ends: `(value, end)`, the
/// value `None` where the prefix is not in `parse_plain`'s form. (`b[start..end]` is
/// then `parse_plain`'s whole field when `end` is the field's end.)
#[inline]
fn plain_prefix(b: &[u8], start: usize) -> (Option<f64>, usize) {
    let mut i = start;
    let neg = b.get(i) == Some(&b'-');
    i += usize::from(neg);
    let mut m = 0u64;
    let first = i;
    // The whole part.
    while let Some(&c) = b.get(i).filter(|c| c.is_ascii_digit()) {
        m = m.wrapping_mul(10).wrapping_add(u64::from(c - b'0'));
        i += 1;
    }
    let whole = i - first;
    let mut decimals = 0;
    let point = b.get(i) == Some(&b'.');
    if point {
        i += 1;
        let from = i;
        while let Some(&c) = b.get(i).filter(|c| c.is_ascii_digit()) {
            m = m.wrapping_mul(10).wrapping_add(u64::from(c - b'0'));
            i += 1;
        }
        decimals = i - from;
    }
    // `parse_plain`'s form: digits before the point, some after it if there is one, at
    // most 15 in all (so `m` is exact).
    let ok = whole > 0 && (!point || decimals > 0) && whole + decimals <= 15;
    let value = POW10.get(decimals).filter(|_| ok).map(|p| {
        let v = m as f64 / p;
        if neg {
            -v
        } else {
            v
        }
    });
    (value, i)
}

use lampost_gcode::POW10;
pub use lampost_gcode::{parse_number, parse_plain};

/// Whether `field` is `n` written in decimal as `n.to_string()` writes it (no sign, no
/// leading zero).
fn is_decimal(field: &str, n: usize) -> bool {
    field.bytes().all(|b| b.is_ascii_digit())
        && (field.len() == 1 || !field.starts_with('0'))
        && field.parse::<usize>() == Ok(n)
}

fn gap(samples: &[Sample], a: usize, b: usize) -> String {
    let line = |i: usize| {
        samples
            .get(i.min(samples.len().saturating_sub(1)))
            .map_or(0, |s| s.line)
    };
    format!(
        "path locations {a} to {} (lines {} to {}) are in no chunk, or in two: a chunk is missing or repeated",
        b.saturating_sub(1),
        line(a),
        line(b.saturating_sub(1))
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            -1e3..1e3f64,
            -400.0..400.0f64,
            -1e-6..1e-6f64,
            -1e10..1e10f64,
            Just(-0.0),
            Just(0.0),
            Just(1e8),
            Just(-99_999_999.999_999_95),
            Just(1e9 - 0.000_000_4),
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(1e300),
        ]
    }

    fn rot_y(b: f64) -> Matrix3<f64> {
        let (sb, cb) = b.sin_cos();
        Matrix3::new(cb, 0.0, sb, 0.0, 1.0, 0.0, -sb, 0.0, cb)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(5_000))]
        /// `from_zyz` multiplied out is the product `Rz(a) · Ry(b) · Rz(c)`; the angle
        /// from the chord of two rotations is `rot_angle`'s (the rotation vector's
        /// length), and the chord test against the tolerance decides as `rot_angle`
        /// against 1e-6 rad does, for angles from 1e-9 to 3.1 rad.
        #[test]
        fn the_chord_angle_is_the_rotation_angle(
            e in prop::array::uniform3(-7.0..7.0f64),
            axis in prop::array::uniform3(-1.0..1.0f64),
            angle in prop_oneof![1e-9..1e-5f64, 0.999e-6..1.001e-6f64, 1e-5..3.1f64],
        ) {
            let a = from_zyz(e);
            let product = Frame::rot_z(e[0]) * rot_y(e[1]) * Frame::rot_z(e[2]);
            prop_assert!((a - product).abs().max() < 1e-15, "{} vs {}", a, product);
            let axis = Vector3::from(axis);
            prop_assume!(axis.norm() > 0.1);
            let turn = nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
            let b = turn.matrix() * a;
            let reference = crate::arm::rot_angle(&b, &a);
            let chord = rot_chord(&b, &a);
            prop_assert!((chord_angle(chord) - reference).abs() < 1e-14 + 1e-9 * reference, "{} vs {}", chord_angle(chord), reference);
            if (reference - ROT_TOL).abs() > 1e-14 {
                prop_assert_eq!(chord > tol_chord(), reference > ROT_TOL);
            }
        }
    }

    fn token() -> impl Strategy<Value = String> {
        prop_oneof![
            (-1e4..1e4f64, 0usize..9).prop_map(|(v, d)| lampost_gcode::fixed(v, d)),
            "[-+]?[0-9]{0,18}(\\.[0-9]{0,18})?([eE][-+]?[0-9]{1,3})?",
            "[-+.0-9a-z]{1,6}",
            Just("path".to_string()),
            Just("-".to_string()),
            Just("1é".to_string()),
            Just("\u{a0}2".to_string()),
        ]
    }

    fn gap() -> impl Strategy<Value = String> {
        prop_oneof![
            4 => Just(" ".to_string()),
            1 => "[ \t\r\x0c]{1,3}",
            1 => Just("\x0b".to_string()),
            1 => Just("\u{a0}".to_string()),
            1 => Just(String::new()),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(5_000))]
        /// `read_row` splits a row as `fields_of` does (ASCII whitespace), and reads a
        /// field as a number exactly where `parse_plain` does, to the same bits.
        #[test]
        fn rows_are_read_as_split_and_parsed_one_by_one(
            lead in gap(),
            parts in prop::collection::vec((token(), gap()), 0..22),
        ) {
            let mut text = lead;
            for (t, g) in &parts {
                text.push_str(t);
                text.push_str(g);
            }
            let (fields, plain, count) = read_row(&text);
            let (want, want_count) = fields_of(&text);
            prop_assert_eq!(count, want_count, "{:?}", text);
            prop_assert_eq!(fields, want, "{:?}", text);
            for (f, v) in fields.iter().zip(plain) {
                prop_assert_eq!(v.map(f64::to_bits), parse_plain(f).map(f64::to_bits), "{:?} in {:?}", f, text);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(5_000))]
        /// The row composed on the stack is the reference's text, or nothing where it
        /// leaves the row to the reference (a value beyond the fast range).
        #[test]
        fn composed_rows_are_the_references_text(
            n in prop_oneof![1usize..5000, any::<usize>()],
            index in prop::option::of(prop_oneof![0usize..400_000, any::<usize>()]),
            path in any::<bool>(),
            laser in any::<bool>(),
            dt in value(),
            pos in prop::array::uniform3(value()),
            angles in prop::array::uniform3(value()),
            joints in prop::array::uniform6(value()),
        ) {
            let v = RowValues { n, kind: if path { "path" } else { "safe" }, index, dt, pos, angles, laser, joints };
            let mut want = b"prefix".to_vec();
            row_reference(&mut want, &v);
            let mut got = b"prefix".to_vec();
            let fast = [dt].iter().chain(&pos).all(|x| x.abs() < 1e9)
                && angles.iter().chain(&joints).all(|x| x.abs() < 1e8);
            match compose_row(&mut got, &v) {
                Some(()) => {
                    prop_assert!(fast);
                    prop_assert_eq!(String::from_utf8_lossy(&got), String::from_utf8_lossy(&want));
                }
                None => {
                    prop_assert!(!fast);
                    prop_assert_eq!(&got, b"prefix");
                }
            }
        }
    }

    #[test]
    fn decimal_fields_are_read_as_to_string_writes_them() {
        for n in [0usize, 1, 9, 10, 4000, 367_810] {
            assert!(is_decimal(&n.to_string(), n));
            for bad in [
                format!("0{n}"),
                format!("+{n}"),
                format!("{n} "),
                format!("{}", n + 1),
            ] {
                assert!(!is_decimal(&bad, n), "{bad}");
            }
        }
        assert!(!is_decimal("", 0));
        assert!(!is_decimal("-0", 0));
    }
}
