//! FADAL probing programs (touch points on a gage ball, a grid on a face) and the
//! reader of the RS-232 log they produce.
//!
//! Each touch: rapid to a safe height, over the start point, feed down to it, then a
//! `G1 G31 … P1` probing move along the surface normal past the surface (the control
//! stops on touch), `#WAIT` so the macro runs after the move, `#PRINT` (screen) and
//! `#SPRINT` (RS-232 port) of the touch point as `X… Y… Z…`, and back out the way it came.

use lampost_gcode::{Dialect, EmitOptions, Emitter, Units};
use serde::Serialize;

use crate::fit::P3;

/// Options shared by the probing programs.
#[derive(Debug, Clone, Copy)]
pub struct ProbeOptions {
    /// Program units.
    pub units: Units,
    /// Distance outside the surface where each probing move starts.
    pub clearance: f64,
    /// How far past the nominal surface the probing move aims.
    pub overtravel: f64,
    /// Feed to the start point.
    pub approach_feed: f64,
    /// Probing feed.
    pub probe_feed: f64,
    /// Program number (O word).
    pub program_number: u32,
}

impl ProbeOptions {
    /// Defaults for the units: 0.1 in / 2.5 mm clearance, 0.05 in / 1.25 mm overtravel,
    /// 20 in/min / 500 mm/min approach, 10 in/min / 250 mm/min probing.
    pub fn defaults(units: Units) -> Self {
        let k = match units {
            Units::Inch => 1.0,
            Units::Mm => 25.0,
        };
        ProbeOptions {
            units,
            clearance: 0.1 * k,
            overtravel: 0.05 * k,
            approach_feed: 20.0 * k,
            probe_feed: 10.0 * k,
            program_number: 9500,
        }
    }
}

/// One planned touch.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Touch {
    /// Start of the probing move.
    pub start: [f64; 3],
    /// Where the probing move aims (past the surface).
    pub target: [f64; 3],
    /// Expected stylus-centre position at touch.
    pub expected: [f64; 3],
}

/// Touch points spread evenly over a cap of the ball (polar angle from +Z up to
/// `cap_deg`, clear of a stem below), on a spherical Fibonacci spiral.
pub fn sphere_touches(
    center: P3,
    ball_radius: f64,
    stylus_radius: f64,
    n: usize,
    cap_deg: f64,
    opts: &ProbeOptions,
) -> Vec<Touch> {
    let r = ball_radius + stylus_radius;
    crate::study::cap_points(n, 1.0, cap_deg)
        .into_iter()
        .map(|dir| {
            let a = |d: f64| {
                let p = center + dir * d;
                [p.x, p.y, p.z]
            };
            Touch {
                start: a(r + opts.clearance),
                target: a(r - opts.overtravel),
                expected: a(r),
            }
        })
        .collect()
}

/// A grid of `m` × `n` touches on a face whose outward normal is +Z, over the rectangle
/// from `corner` spanning `size` (u along X, v along Y), in serpentine order. The grid
/// stays `inset` inside the rectangle's edges (a stylus radius: a stylus centred on an
/// edge would touch the edge, or miss the face); `None` when the rectangle is not wider
/// than twice the inset in a direction that has more than one touch.
pub fn plane_touches(
    corner: P3,
    size: (f64, f64),
    grid: (usize, usize),
    inset: f64,
    opts: &ProbeOptions,
) -> Option<Vec<Touch>> {
    let (m, n) = grid;
    let span = |len: f64, count: usize| {
        let inner = len - 2.0 * inset;
        (inner > 0.0 || count == 1 && len > 0.0).then_some(inner.max(0.0))
    };
    let (su, sv) = (span(size.0, m)?, span(size.1, n)?);
    let step = |k: usize, count: usize, inner: f64, len: f64| {
        if count > 1 {
            inset + inner * k as f64 / (count - 1) as f64
        } else {
            len / 2.0
        }
    };
    let mut out = Vec::with_capacity(m * n);
    for j in 0..n {
        for jj in 0..m {
            let i = if j % 2 == 0 { jj } else { m - 1 - jj };
            let p = corner + P3::new(step(i, m, su, size.0), step(j, n, sv, size.1), 0.0);
            out.push(Touch {
                start: [p.x, p.y, p.z + opts.clearance],
                target: [p.x, p.y, p.z - opts.overtravel],
                expected: [p.x, p.y, p.z],
            });
        }
    }
    Some(out)
}

/// The FADAL program that makes `touches`, each printed as one `X… Y… Z…` line.
/// `safe_z` is a height clear of the part for moves between touches.
pub fn program(
    touches: &[Touch],
    safe_z: f64,
    title: &str,
    opts: &ProbeOptions,
) -> std::io::Result<String> {
    let mut em = start(title, &[], opts)?;
    em.words(&[(b'G', 0.0), (b'Z', safe_z)], None)?;
    touch_moves(&mut em, touches, safe_z, opts)?;
    finish(em)
}

/// One pose of a rotary calibration: the rotary words that index to it (letter, angle)
/// and the touches made there.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseTouches {
    /// The rotary axes' words, e.g. `[(b'A', 0.0), (b'B', 45.0)]`.
    pub rotary: Vec<(u8, f64)>,
    /// The touches at this pose.
    pub touches: Vec<Touch>,
}

/// The FADAL program of a rotary calibration: the modal setup and the probe switched on
/// once, then at each pose a retract to `safe_z`, the index, a `#SPRINT "POSE k A… B…"`
/// record (so the log says which touches belong to which pose) and the touches; the
/// probe off and `M30` at the end. `comments` go under the program number.
pub fn poses_program(
    poses: &[PoseTouches],
    safe_z: f64,
    title: &str,
    comments: &[String],
    opts: &ProbeOptions,
) -> std::io::Result<String> {
    let mut em = start(title, comments, opts)?;
    for (k, pose) in poses.iter().enumerate() {
        let label: Vec<String> = pose
            .rotary
            .iter()
            .map(|(l, v)| format!("{}{v:.3}", char::from(*l)))
            .collect();
        em.raw_line(&format!(
            "(POSE {} OF {}: {})",
            k + 1,
            poses.len(),
            label.join(" ")
        ))?;
        em.words(&[(b'G', 0.0), (b'Z', safe_z)], None)?;
        let mut index = vec![(b'G', 0.0)];
        index.extend(pose.rotary.iter().copied());
        em.words(&index, None)?;
        em.raw_line(&format!("#SPRINT \"POSE {} {}\"", k + 1, label.join(" ")))?;
        touch_moves(&mut em, &pose.touches, safe_z, opts)?;
    }
    finish(em)
}

/// Stage 1: the program number, comments, the modal setup and the probe on.
fn start(
    title: &str,
    comments: &[String],
    opts: &ProbeOptions,
) -> std::io::Result<Emitter<Vec<u8>>> {
    let mut em = Emitter::new(
        Vec::new(),
        EmitOptions {
            dialect: Some(Dialect::Fadal),
            units: opts.units,
            ..EmitOptions::default()
        },
    );
    em.program_number(opts.program_number, Some(title))?;
    em.raw_line("(WRITTEN BY LAMPOST - EACH TOUCH IS SENT TO THE RS-232 PORT AS X.. Y.. Z..)")?;
    for c in comments {
        em.raw_line(&format!("({})", c.replace(['(', ')'], "")))?;
    }
    let units = match opts.units {
        Units::Inch => 70.0,
        Units::Mm => 71.0,
    };
    em.words(
        &[
            (b'G', units),
            (b'G', 90.0),
            (b'G', 17.0),
            (b'G', 40.0),
            (b'G', 80.0),
        ],
        None,
    )?;
    em.words(&[(b'M', 64.0)], Some("SELECT THE SPINDLE PROBE"))?;
    em.words(&[(b'M', 66.0)], Some("PROBE ON"))?;
    Ok(em)
}

/// Stage 2: each touch from `safe_z`: over the start, feed down to it, the probing move,
/// the touch printed, back out and up.
fn touch_moves(
    em: &mut Emitter<Vec<u8>>,
    touches: &[Touch],
    safe_z: f64,
    opts: &ProbeOptions,
) -> std::io::Result<()> {
    for (k, t) in touches.iter().enumerate() {
        em.raw_line(&format!("(TOUCH {} OF {})", k + 1, touches.len()))?;
        em.words(&[(b'G', 0.0), (b'X', t.start[0]), (b'Y', t.start[1])], None)?;
        em.words(
            &[(b'G', 1.0), (b'Z', t.start[2]), (b'F', opts.approach_feed)],
            None,
        )?;
        em.words(
            &[
                (b'G', 1.0),
                (b'G', 31.0),
                (b'X', t.target[0]),
                (b'Y', t.target[1]),
                (b'Z', t.target[2]),
                (b'F', opts.probe_feed),
                (b'P', 1.0),
            ],
            None,
        )?;
        em.raw_line("#WAIT")?;
        em.raw_line(r#"#PRINT "X",PX1," Y",PY1," Z",PZ1"#)?;
        em.raw_line(r#"#SPRINT "X",PX1," Y",PY1," Z",PZ1"#)?;
        em.words(
            &[
                (b'G', 1.0),
                (b'X', t.start[0]),
                (b'Y', t.start[1]),
                (b'Z', t.start[2]),
                (b'F', opts.approach_feed),
            ],
            None,
        )?;
        em.words(&[(b'G', 0.0), (b'Z', safe_z)], None)?;
    }
    Ok(())
}

/// Stage 3: the probe off and the end.
fn finish(mut em: Emitter<Vec<u8>>) -> std::io::Result<String> {
    em.words(&[(b'M', 67.0)], Some("PROBE OFF"))?;
    em.words(&[(b'M', 30.0)], None)?;
    let bytes = em.finish()?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// A problem with a probe log.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LogError {
    /// A line that starts like a touch line but cannot be read.
    #[error("line {line}: `{text}` {why}")]
    Malformed {
        /// 1-based line.
        line: usize,
        /// The line.
        text: String,
        /// What is wrong.
        why: String,
    },
    /// No touch lines at all.
    #[error("the log has no touch lines (X… Y… Z…)")]
    NoTouches,
}

/// Read the touch points (`X… Y… Z…`, maybe after a label ending in `:`) from a log,
/// ignoring every other line. Returns each point with its line number.
pub fn read_log(text: &str) -> Result<Vec<(usize, [f64; 3])>, LogError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let body = raw.rsplit(':').next().unwrap_or(raw).trim();
        let upper = body.to_ascii_uppercase();
        if !upper.starts_with('X') {
            continue;
        }
        let bad = |why: &str| LogError::Malformed {
            line,
            text: raw.trim().to_string(),
            why: format!("looks like a touch point but {why}"),
        };
        let mut vals = [None; 3];
        let mut rest = upper.as_str();
        while !rest.is_empty() {
            rest = rest.trim_start_matches([' ', '\t', ',', ';']);
            let Some(letter) = rest.chars().next() else {
                break;
            };
            let idx = match letter {
                'X' => 0,
                'Y' => 1,
                'Z' => 2,
                _ => return Err(bad(&format!("has `{letter}` where X, Y or Z belongs"))),
            };
            rest = rest[1..].trim_start();
            let end = rest
                .find(|c: char| {
                    !(c.is_ascii_digit() || c == '.' || c == '-' || c == '+' || c == 'E')
                })
                .unwrap_or(rest.len());
            let num = &rest[..end];
            let v: f64 = num
                .parse()
                .map_err(|_| bad(&format!("`{letter}` has no number")))?;
            if !v.is_finite() {
                return Err(bad("holds a value that is not finite"));
            }
            if vals[idx].replace(v).is_some() {
                return Err(bad(&format!("has {letter} twice")));
            }
            rest = &rest[end..];
        }
        match vals {
            [Some(x), Some(y), Some(z)] => out.push((line, [x, y, z])),
            _ => return Err(bad("lacks one of X, Y, Z")),
        }
    }
    if out.is_empty() {
        return Err(LogError::NoTouches);
    }
    Ok(out)
}

/// One pose of a `probe poses` log: its `POSE k A… B…` record and the touches after it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoggedPose {
    /// 1-based line of the POSE record.
    pub line: usize,
    /// The pose's number in the record.
    pub number: usize,
    /// The rotary words of the record, e.g. `[(b'A', 0.0), (b'B', 45.0)]`.
    #[serde(skip)]
    pub rotary: Vec<(u8, f64)>,
    /// The touches logged after the record (line, stylus centre).
    pub touches: Vec<(usize, [f64; 3])>,
}

/// A pose record's number and rotary words.
type PoseRecord = (usize, Vec<(u8, f64)>);

/// A `POSE k A… B…` record (what [`poses_program`] sends before each pose's touches),
/// maybe after a label ending in `:`. `None` when the line is not one; an error when it
/// starts like one but cannot be read.
fn pose_record(line: usize, raw: &str) -> Result<Option<PoseRecord>, LogError> {
    let body = raw.rsplit(':').next().unwrap_or(raw).trim();
    let upper = body.to_ascii_uppercase();
    let Some(rest) = upper.strip_prefix("POSE") else {
        return Ok(None);
    };
    let bad = |why: String| LogError::Malformed {
        line,
        text: raw.trim().to_string(),
        why,
    };
    let mut tokens = rest.split_whitespace();
    let number = tokens
        .next()
        .and_then(|t| t.parse::<usize>().ok())
        .ok_or_else(|| bad("has no pose number after POSE".into()))?;
    let mut rotary = Vec::new();
    for t in tokens {
        let mut chars = t.chars();
        let letter = chars.next().filter(|c| c.is_ascii_alphabetic());
        let value = chars.as_str().parse::<f64>().ok().filter(|v| v.is_finite());
        match (letter, value) {
            (Some(l), Some(v)) => {
                if rotary.iter().any(|&(k, _)| k == l as u8) {
                    return Err(bad(format!("names {l} twice")));
                }
                rotary.push((l as u8, v));
            }
            _ => {
                return Err(bad(format!(
                    "has `{t}` where a rotary word such as A90. belongs"
                )))
            }
        }
    }
    if rotary.is_empty() {
        return Err(bad("names no rotary angle".into()));
    }
    Ok(Some((number, rotary)))
}

/// Read a `probe poses` log: each `POSE k A… B…` record with the touches that follow
/// it. `Ok(None)` when the log has no POSE records (a plain touch log: read it with
/// [`read_log`]). A touch before the first record, a record with no touches after it,
/// or a pose number given twice is an error at its line.
pub fn read_pose_log(text: &str) -> Result<Option<Vec<LoggedPose>>, LogError> {
    let mut poses: Vec<LoggedPose> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        if let Some((number, rotary)) = pose_record(i + 1, raw)? {
            if let Some(prev) = poses.iter().find(|p| p.number == number) {
                return Err(LogError::Malformed {
                    line: i + 1,
                    text: raw.trim().to_string(),
                    why: format!("repeats pose {number} of line {}", prev.line),
                });
            }
            poses.push(LoggedPose {
                line: i + 1,
                number,
                rotary,
                touches: Vec::new(),
            });
        }
    }
    if poses.is_empty() {
        return Ok(None);
    }
    let lines: Vec<&str> = text.lines().collect();
    for (line, p) in read_log(text)? {
        match poses.iter_mut().rev().find(|q| q.line < line) {
            Some(q) => q.touches.push((line, p)),
            None => {
                return Err(LogError::Malformed {
                    line,
                    text: lines.get(line - 1).map_or("", |t| t.trim()).to_string(),
                    why: "comes before the first POSE record, so no pose owns it".into(),
                })
            }
        }
    }
    if let Some(p) = poses.iter().find(|p| p.touches.is_empty()) {
        return Err(LogError::Malformed {
            line: p.line,
            text: lines.get(p.line - 1).map_or("", |t| t.trim()).to_string(),
            why: "has no touches after it (the log may have been cut short)".into(),
        });
    }
    Ok(Some(poses))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_reader_keeps_touches_and_names_bad_lines() {
        let log = "PROBEKIT READY\nX1.2500 Y-0.5 Z3.\nTOUCH 2: X 1.3 Y -0.4 Z 2.9\nPRESS ENTER\n";
        let pts = read_log(log).expect("reads");
        assert_eq!(pts, vec![(2, [1.25, -0.5, 3.0]), (3, [1.3, -0.4, 2.9])]);
        let e = read_log("X1 Y2\n").expect_err("bad");
        assert!(
            e.to_string().contains("line 1") && e.to_string().contains("lacks"),
            "{e}"
        );
        let e = read_log("X1 Yabc Z3\n").expect_err("bad");
        assert!(e.to_string().contains("`Y` has no number"), "{e}");
        assert_eq!(read_log("HELLO\n"), Err(LogError::NoTouches));
    }

    #[test]
    fn sphere_touches_lie_on_the_cap() {
        let o = ProbeOptions::defaults(Units::Mm);
        let c = P3::new(10.0, 20.0, 30.0);
        let t = sphere_touches(c, 12.5, 1.0, 30, 60.0, &o);
        assert_eq!(t.len(), 30);
        for x in &t {
            let e = P3::from(x.expected) - c;
            assert!((e.norm() - 13.5).abs() < 1e-12);
            assert!(
                e.z / e.norm() >= 60f64.to_radians().cos() - 1e-12,
                "clear of the stem"
            );
        }
    }
}
