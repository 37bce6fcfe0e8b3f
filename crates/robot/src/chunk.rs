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

use crate::arm::{rot_angle, Arm, Config, Frame, Q};
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
pub fn zyz(r: &Matrix3<f64>) -> [f64; 3] {
    let sb = r[(0, 2)].hypot(r[(1, 2)]);
    if sb < 1e-12 {
        if r[(2, 2)] > 0.0 {
            [0.0, 0.0, r[(1, 0)].atan2(r[(0, 0)])]
        } else {
            [0.0, std::f64::consts::PI, r[(1, 0)].atan2(r[(1, 1)])]
        }
    } else {
        [
            r[(1, 2)].atan2(r[(0, 2)]),
            sb.atan2(r[(2, 2)]),
            r[(2, 1)].atan2(-r[(2, 0)]),
        ]
    }
}

/// The rotation of ZYZ Euler angles (radians).
pub fn from_zyz(e: [f64; 3]) -> Matrix3<f64> {
    let (sb, cb) = e[1].sin_cos();
    let ry = Matrix3::new(cb, 0.0, sb, 0.0, 1.0, 0.0, -sb, 0.0, cb);
    Frame::rot_z(e[0]) * ry * Frame::rot_z(e[2])
}

#[allow(clippy::too_many_arguments)]
fn row(
    out: &mut String,
    n: usize,
    kind: &str,
    index: Option<usize>,
    dt: f64,
    part: &Frame,
    laser: bool,
    q: &Q,
) {
    use std::fmt::Write;
    let e = zyz(&part.r);
    let idx = index.map_or("-".to_string(), |i| i.to_string());
    let _ = write!(
        out,
        "{n} {kind} {idx} {dt:.6} {:.6} {:.6} {:.6} {:.7} {:.7} {:.7} {}",
        part.t.x,
        part.t.y,
        part.t.z,
        e[0].to_degrees(),
        e[1].to_degrees(),
        e[2].to_degrees(),
        u8::from(laser)
    );
    for v in q {
        let _ = write!(out, " {:.7}", v.to_degrees());
    }
    out.push('\n');
}

/// The part frame in the working frame for joint values `q`.
pub fn part_of(arm: &Arm, q: &Q) -> Frame {
    arm.head.inverse().mul(&arm.part(q))
}

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
    let units = match arm.units {
        crate::def::Units::Mm => "mm",
        crate::def::Units::Inch => "inch",
    };
    let mut s = format!(
        "# {FORMAT}\n# machine {}\n# chunk {k} of {total}\n# config {}\n# units {units}, degrees, seconds\n# frame: working (origin at the laser focus, z from the focus into the head); pose of the part frame, R = Rz(rz1)·Ry(ry)·Rz(rz2)\n# n kind index dt x y z rz1 ry rz2 laser j1 j2 j3 j4 j5 j6\n",
        arm.name,
        cfg.letters()
    );
    let safe = part_of(arm, &arm.safe);
    row(&mut s, 1, "safe", None, 0.0, &safe, false, &arm.safe);
    let mut n = 2;
    for i in range.clone() {
        let dt = if i == range.start { 0.0 } else { samples[i].dt };
        let laser = i != range.start && samples[i].deposit;
        row(
            &mut s,
            n,
            "path",
            Some(i),
            dt,
            &located[i].part,
            laser,
            &located[i].q,
        );
        n += 1;
    }
    row(&mut s, n, "safe", None, 0.0, &safe, false, &arm.safe);
    s
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
pub fn verify(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    chunks: &[ChunkFile],
    tol: f64,
) -> Result<Report, RobotError> {
    let mut rep = Report {
        chunks: chunks.len(),
        ..Report::default()
    };
    let mut next = 0usize;
    let safe_part = part_of(arm, &arm.safe);
    for (k, c) in chunks.iter().enumerate() {
        let f = c.name.as_str();
        if c.first != next {
            let (a, b) = (next.min(c.first), next.max(c.first));
            return Err(verr(f, 0, gap(samples, a, b)));
        }
        let mut header = Vec::new();
        let mut rows: Vec<(usize, Vec<&str>)> = Vec::new();
        for (i, line) in c.text.lines().enumerate() {
            if let Some(h) = line.strip_prefix('#') {
                header.push((i + 1, h.trim()));
            } else if !line.trim().is_empty() {
                rows.push((i + 1, line.split_whitespace().collect()));
            }
        }
        let want = [
            FORMAT.to_string(),
            format!("machine {}", arm.name),
            format!("chunk {} of {}", k + 1, chunks.len()),
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
        for (r, (line, fields)) in rows.iter().enumerate() {
            let line = *line;
            if fields.len() != 17 {
                return Err(verr(
                    f,
                    line,
                    format!("{} fields; a location row has 17", fields.len()),
                ));
            }
            let num = |k: usize| -> Result<f64, RobotError> {
                fields[k]
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| verr(f, line, format!("`{}` is not a finite number", fields[k])))
            };
            if fields[0] != (r + 1).to_string() {
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
            let part = part_of(arm, &q);
            let pos = Vector3::new(num(4)?, num(5)?, num(6)?);
            let rot = from_zyz([num(7)?, num(8)?, num(9)?].map(f64::to_radians));
            let dpos = (pos - part.t).norm();
            let drot = rot_angle(&rot, &part.r);
            if dpos > 1e-4 || drot > 1e-6 {
                return Err(verr(f, line, format!(
                    "the written pose is not where the joints put the part ({dpos:.2e} away, {:.2e}° turned)",
                    drot.to_degrees()
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
                let _ = safe_part;
                prev = None;
                continue;
            }
            let i = c.first.saturating_add(r - 1);
            if fields[1] != "path" || fields[2] != i.to_string() {
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
            if let Some(co) = arm.config_of(&q) {
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
        next = c.first.saturating_add(c.count);
    }
    if next != samples.len() {
        return Err(verr(
            chunks.last().map_or("manifest", |c| c.name.as_str()),
            0,
            gap(samples, next.min(samples.len()), samples.len().max(next)),
        ));
    }
    Ok(rep)
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
