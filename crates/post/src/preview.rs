//! Pictures of a posted program: the toolpath in the part frame as plain SVG.
//!
//! Two stages, each on its own: [`replay`] reads the posted text (as `verify` does,
//! through the interpreter and forward kinematics, nothing from the post) into polylines
//! in the part frame, one per run of moves of a kind at one table position; [`svg`]
//! draws them: one colour per table position (section or layer, labelled with its
//! rotary words), rapids dashed, process moves solid (deposition with the laser head,
//! cutting with a spindle drawn thicker), and the machine's linear travel at each table
//! position as a dashed outline, projected on the part's XY plane (a top view) or, with
//! [`View::Iso`], an isometric view.

use std::fmt::Write as _;
use std::io::BufRead;

use lampost_gcode::{Event, MoveKind, Options, Plane, Severity, Stream, Units, AXES};
use lampost_kinematics::{Joints, Machine, Units as MUnits};

use crate::error::PostError;

/// A run of moves of one kind at one table position, in the part frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// Rapid (travel) or not (a feed).
    pub rapid: bool,
    /// For a feed: whether the machine's laser was on (its `laser_on` code written and
    /// not yet its `laser_off`). Feeds with the laser off are travel at feed, not
    /// deposition. Always false for rapids.
    pub laser: bool,
    /// Index into [`Preview::positions`].
    pub position: usize,
    /// Tool tips, part frame.
    pub points: Vec<[f64; 3]>,
    /// The posted line of the move that reaches each point (the first point: the line
    /// of the run's first move).
    pub lines: Vec<u32>,
}

/// A posted program's toolpath in the part frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Preview {
    /// The runs, in program order.
    pub runs: Vec<Run>,
    /// The table positions met, in order (rotary words as written, machine order).
    pub positions: Vec<[f64; 2]>,
    /// Moves read.
    pub moves: usize,
}

/// How far apart the points of an arc are drawn, in degrees of its sweep.
const ARC_STEP_DEG: f64 = 5.0;

/// At most this many points (4,000,000) are drawn: some 100 MB of SVG, more than a
/// browser shows usefully. A posted program whose repeats (`M98 … L9999`, a cycle's `L`)
/// or many-turn helices make more is refused at the move that passes it, before its
/// points fill memory (a 6 KB program of cycle repeats made a 618 MB SVG in 1.4 GB).
pub const MAX_POINTS: usize = 4_000_000;

/// The posted lines that switch the machine's laser on or off, in order: (line, on).
/// A line switches it on when it holds every word of the machine's `laser_on` code, off
/// when it holds every word of `laser_off`.
fn laser_switches(machine: &Machine, text: &[u8]) -> Result<Vec<(u32, bool)>, PostError> {
    let on = crate::post::code_words(&machine.def.process.laser_on)?;
    let off = crate::post::code_words(&machine.def.process.laser_off)?;
    let holds = |words: &[(u8, f64)], code: &[(u8, f64)]| {
        !code.is_empty() && code.iter().all(|c| words.contains(c))
    };
    let mut out = Vec::new();
    for (k, line) in text.split(|&c| c == b'\n').enumerate() {
        // Only lines with an M word can hold a process code; others are not parsed.
        if !line.iter().any(|&c| c == b'M' || c == b'm') {
            continue;
        }
        let n = u32::try_from(k + 1).unwrap_or(u32::MAX);
        let Ok(b) = lampost_gcode::parse_line(line, n, 0) else {
            continue;
        };
        let words: Vec<(u8, f64)> = b.words().map(|w| (w.letter, w.value)).collect();
        if holds(&words, &off) {
            out.push((n, false));
        } else if holds(&words, &on) {
            out.push((n, true));
        }
    }
    Ok(out)
}

/// Stage 1: replay `posted` into runs in the part frame, with `head`'s tool point.
pub fn replay<R: BufRead>(
    machine: &Machine,
    head: usize,
    mut posted: R,
) -> Result<Preview, PostError> {
    // A picture holds every point anyway: the text is read whole, once for the laser
    // switches and once through the interpreter.
    let mut text = Vec::new();
    posted
        .read_to_end(&mut text)
        .map_err(|e| PostError::Io(format!("cannot read the posted program: {e}")))?;
    let switches = laser_switches(machine, &text)?;
    let mut next_switch = 0;
    let mut laser = false;
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
    let lin: Vec<usize> = names[..3].iter().map(|n| idx(n).unwrap_or(0)).collect();
    let rot: Vec<usize> = names[3..].iter().map(|n| idx(n).unwrap_or(3)).collect();
    let tip = |p: &[f64; 9]| {
        let j = Joints {
            linear: [p[lin[0]], p[lin[1]], p[lin[2]]],
            rotary: [p[rot[0]], p[rot[1]]],
        };
        let t = machine.forward(&j, head).tip;
        [t.x, t.y, t.z]
    };
    let mut out = Preview::default();
    // Points drawn so far (bounded by MAX_POINTS).
    let mut points = 0usize;
    let stream = Stream::from_reader(
        text.as_slice(),
        Options {
            units,
            ..Options::default()
        },
        true,
    );
    for ev in stream {
        let m = match ev.map_err(|e| PostError::Io(e.to_string()))? {
            Event::Diagnostic(d) if d.severity == Severity::Error => {
                return Err(PostError::Input {
                    file: "the posted program".into(),
                    diag: Box::new(d),
                })
            }
            Event::Diagnostic(_) | Event::Stop(_) => continue,
            Event::Move(m) => m,
        };
        out.moves += 1;
        let r = [m.end[rot[0]], m.end[rot[1]]];
        let position = match out.positions.iter().position(|p| *p == r) {
            Some(k) => k,
            None => {
                out.positions.push(r);
                out.positions.len() - 1
            }
        };
        // The switches up to this move's line are in force (a code precedes the motion
        // of its own block).
        while let Some(&(n, on)) = switches.get(next_switch) {
            if n > m.line {
                break;
            }
            laser = on;
            next_switch += 1;
        }
        let rapid = matches!(m.kind, MoveKind::Rapid);
        let lit = !rapid && laser;
        let same = out
            .runs
            .last()
            .is_some_and(|l| l.rapid == rapid && l.laser == lit && l.position == position);
        if !same {
            out.runs.push(Run {
                rapid,
                laser: lit,
                position,
                points: vec![tip(&m.start)],
                lines: vec![m.line],
            });
        }
        let run = out
            .runs
            .last_mut()
            .ok_or_else(|| PostError::Io("internal: a run was just started".into()))?;
        let before = if same { run.points.len() } else { 0 };
        if let MoveKind::Arc {
            clockwise,
            center,
            plane,
            turns,
        } = m.kind
        {
            let (a, b, n) = match plane {
                Plane::XY => (0, 1, 2),
                Plane::XZ => (2, 0, 1),
                Plane::YZ => (1, 2, 0),
            };
            let (sa, sb) = (m.start[a] - center[a], m.start[b] - center[b]);
            let (ea, eb) = (m.end[a] - center[a], m.end[b] - center[b]);
            let tau = std::f64::consts::TAU;
            let delta = eb.atan2(ea) - sb.atan2(sa);
            let full = (sa - ea).hypot(sb - eb) < 1e-9;
            let extra = tau * f64::from(turns.saturating_sub(1));
            let sweep = if clockwise {
                (if full {
                    -tau
                } else {
                    delta.rem_euclid(tau) - tau
                }) - extra
            } else {
                (if full { tau } else { delta.rem_euclid(tau) }) + extra
            };
            let r = sa.hypot(sb);
            let k = ((sweep.abs().to_degrees() / ARC_STEP_DEG).ceil() as usize).clamp(1, 100_000);
            for i in 1..k {
                let t = i as f64 / k as f64;
                let ang = sb.atan2(sa) + sweep * t;
                let mut p = m.end;
                for (v, s) in p.iter_mut().zip(m.start) {
                    *v = s + (*v - s) * t;
                }
                p[a] = center[a] + r * ang.cos();
                p[b] = center[b] + r * ang.sin();
                p[n] = m.start[n] + (m.end[n] - m.start[n]) * t;
                run.points.push(tip(&p));
                run.lines.push(m.line);
            }
        }
        run.points.push(tip(&m.end));
        run.lines.push(m.line);
        // (One move adds at most 100,001 points: the bound is checked move by move.)
        points += run.points.len() - before;
        if points > MAX_POINTS {
            return Err(PostError::Unsupported {
                file: "the posted program".into(),
                line: m.line,
                what: format!("the picture would hold more than {MAX_POINTS} points by here (the program's repeats and arcs drawn out), more than a browser shows usefully: preview a smaller program, or each section of a job on its own"),
            });
        }
    }
    Ok(out)
}

/// Which view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// Looking down the part's −Z: x right, y up.
    Top,
    /// Isometric: x and y at ±30° below the horizontal, z up.
    Iso,
}

impl View {
    fn project(self, p: &[f64; 3]) -> [f64; 2] {
        match self {
            View::Top => [p[0], p[1]],
            View::Iso => {
                let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
                [(p[0] - p[1]) * c, (p[0] + p[1]) * s + p[2]]
            }
        }
    }
}

/// The colour of table position `k`: distinct hues around the wheel.
fn colour(k: usize) -> String {
    const HUES: [&str; 10] = [
        "#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22",
        "#7f7f7f", "#d62728",
    ];
    HUES[k % HUES.len()].to_string()
}

/// The machine's linear travel at a table position, in the part frame: the 12 edges of
/// the travel box, each a pair of points.
fn envelope(machine: &Machine, head: usize, rotary: [f64; 2]) -> Vec<[[f64; 3]; 2]> {
    let l = &machine.linear;
    let corner = |i: usize| {
        let lin = [
            if i & 1 == 0 {
                l[0].limits.0
            } else {
                l[0].limits.1
            },
            if i & 2 == 0 {
                l[1].limits.0
            } else {
                l[1].limits.1
            },
            if i & 4 == 0 {
                l[2].limits.0
            } else {
                l[2].limits.1
            },
        ];
        let t = machine
            .forward(
                &Joints {
                    linear: lin,
                    rotary,
                },
                head,
            )
            .tip;
        [t.x, t.y, t.z]
    };
    let mut edges = Vec::with_capacity(12);
    for i in 0..8usize {
        for bit in [1usize, 2, 4] {
            if i & bit == 0 {
                edges.push([corner(i), corner(i | bit)]);
            }
        }
    }
    edges
}

/// Escape text for SVG.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// How the feeds are coloured.
#[derive(Debug, Clone, Copy)]
pub enum Colouring<'a> {
    /// One colour per table position (section or layer).
    Position,
    /// By each point's deviation from the intended path as `verify` measured it (posted
    /// line → distance): green at 0, yellow at half the tolerance, red at the tolerance;
    /// grey where nothing was compared.
    Deviation {
        /// Posted line → largest deviation of a point it wrote.
        errors: &'a std::collections::HashMap<u32, f64>,
        /// The tolerance verify used.
        tolerance: f64,
    },
}

/// Green (0) through yellow (0.5) to red (1 and beyond).
fn ramp(t: f64) -> String {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let (a, b, u) = if t < 0.5 {
        ([26.0, 152.0, 80.0], [254.0, 224.0, 139.0], t * 2.0)
    } else {
        ([254.0, 224.0, 139.0], [215.0, 48.0, 39.0], t * 2.0 - 1.0)
    };
    let c = |k: usize| (a[k] + (b[k] - a[k]) * u).round() as u8;
    format!("#{:02x}{:02x}{:02x}", c(0), c(1), c(2))
}

/// Stage 2: the picture. `title` goes in the SVG's `<title>` and heading; `deposit` says
/// whether process moves deposit (a laser head: feeds with the laser off are drawn
/// dotted, as travel) or cut.
pub fn svg(
    machine: &Machine,
    head: usize,
    preview: &Preview,
    view: View,
    title: &str,
    deposit: bool,
    colouring: Colouring<'_>,
) -> String {
    let envelopes: Vec<Vec<[[f64; 3]; 2]>> = preview
        .positions
        .iter()
        .map(|r| envelope(machine, head, *r))
        .collect();
    // The drawing's extent: the process moves (rapids to far safe heights and the travel
    // envelope may reach much further; they are clipped at the drawing's edge).
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let work = preview.runs.iter().any(|r| !r.rapid);
    for run in preview.runs.iter().filter(|r| !work || !r.rapid) {
        for p in &run.points {
            let q = view.project(p);
            for k in 0..2 {
                lo[k] = lo[k].min(q[k]);
                hi[k] = hi[k].max(q[k]);
            }
        }
    }
    if !(lo[0].is_finite() && hi[0].is_finite()) {
        lo = [0.0, 0.0];
        hi = [1.0, 1.0];
    }
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-9);
    let margin = 0.15 * span;
    let (x0, y0) = (lo[0] - margin, lo[1] - margin);
    let (w, h) = (hi[0] - lo[0] + 2.0 * margin, hi[1] - lo[1] + 2.0 * margin);
    let px = 800.0 / w.max(h);
    let (width, height) = (w * px, h * px);
    let legend_h = 22.0 * (preview.positions.len() as f64 + 4.0);
    let to = |p: &[f64; 3]| {
        let q = view.project(p);
        ((q[0] - x0) * px, (y0 + h - q[1]) * px)
    };
    let unit = match machine.units {
        MUnits::Inch => "in",
        MUnits::Mm => "mm",
    };
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{:.0}" height="{:.0}" viewBox="0 0 {:.1} {:.1}" font-family="sans-serif" font-size="13">"#,
        width,
        height + legend_h,
        width,
        height + legend_h
    );
    let _ = writeln!(s, "<title>{}</title>", esc(title));
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<defs><clipPath id="drawing"><rect x="0" y="0" width="{width:.1}" height="{height:.1}"/></clipPath></defs>"#
    );
    // The travel envelopes, dashed, clipped to the drawing.
    let _ = writeln!(
        s,
        r#"<g class="envelope" clip-path="url(#drawing)" fill="none" stroke-width="1" stroke-dasharray="2 4">"#
    );
    for (k, edges) in envelopes.iter().enumerate() {
        for [a, b] in edges {
            let (ax, ay) = to(a);
            let (bx, by) = to(b);
            let _ = writeln!(
                s,
                r#"<line data-position="{k}" x1="{ax:.2}" y1="{ay:.2}" x2="{bx:.2}" y2="{by:.2}" stroke="{}"/>"#,
                colour(k)
            );
        }
    }
    let _ = writeln!(s, "</g>");
    // The path: rapids dashed and thin, process moves solid.
    let _ = writeln!(s, r#"<g class="path" clip-path="url(#drawing)">"#);
    let kind = if deposit { "deposit" } else { "cut" };
    let process_width = if deposit { 1.6 } else { 2.6 };
    for run in &preview.runs {
        let (class, style) = if run.rapid {
            (
                "rapid",
                r#"stroke-width="0.8" stroke-dasharray="6 4""#.to_string(),
            )
        } else if deposit && !run.laser {
            (
                "feed-off",
                r#"stroke-width="1" stroke-dasharray="1 3""#.to_string(),
            )
        } else {
            (kind, format!(r#"stroke-width="{process_width}""#))
        };
        if let (Colouring::Deviation { errors, tolerance }, false) = (colouring, run.rapid) {
            // One segment per move piece, coloured by the deviation of the point it
            // reaches.
            for (k, pair) in run.points.windows(2).enumerate() {
                let line = run.lines.get(k + 1).copied().unwrap_or(0);
                let err = errors.get(&line).copied();
                let stroke = err.map_or_else(|| "#9e9e9e".to_string(), |e| ramp(e / tolerance));
                let (ax, ay) = to(&pair[0]);
                let (bx, by) = to(&pair[1]);
                let _ = writeln!(
                    s,
                    r#"<line class="{class} deviation" data-line="{line}" data-error="{}" x1="{ax:.2}" y1="{ay:.2}" x2="{bx:.2}" y2="{by:.2}" stroke="{stroke}" {style}/>"#,
                    err.map_or_else(|| "none".to_string(), |e| format!("{e:.3e}"))
                );
            }
            continue;
        }
        let pts: Vec<String> = run
            .points
            .iter()
            .map(|p| {
                let (x, y) = to(p);
                format!("{x:.2},{y:.2}")
            })
            .collect();
        let stroke = match colouring {
            Colouring::Position => colour(run.position),
            Colouring::Deviation { .. } => "#9e9e9e".to_string(),
        };
        let _ = writeln!(
            s,
            r#"<polyline class="{class}" data-position="{}" fill="none" stroke="{stroke}" {style} points="{}"/>"#,
            run.position,
            pts.join(" ")
        );
    }
    let _ = writeln!(s, "</g>");
    // Labels: each table position at the first point of its first process run.
    let names = machine.axis_names();
    let label = |r: &[f64; 2]| format!("{}{:.3} {}{:.3}", names[3], r[0], names[4], r[1]);
    for (k, r) in preview.positions.iter().enumerate() {
        if let Some(run) = preview
            .runs
            .iter()
            .find(|x| x.position == k && !x.rapid)
            .or_else(|| preview.runs.iter().find(|x| x.position == k))
        {
            if let Some(p) = run.points.first() {
                let (x, y) = to(p);
                let _ = writeln!(
                    s,
                    r#"<text class="index-label" data-position="{k}" x="{:.2}" y="{:.2}" fill="{}">{}</text>"#,
                    x + 4.0,
                    y - 4.0,
                    colour(k),
                    esc(&label(r))
                );
            }
        }
    }
    // The legend under the drawing.
    let mut y = height + 20.0;
    let view_name = match view {
        View::Top => "top view (part XY)",
        View::Iso => "isometric view",
    };
    let _ = writeln!(
        s,
        r#"<text class="heading" x="8" y="{y:.1}">{} — {view_name}, {} moves, {unit}</text>"#,
        esc(title),
        preview.moves
    );
    y += 20.0;
    let _ = writeln!(
        s,
        r#"<text class="key" x="8" y="{y:.1}">solid: {}; dashed: rapids; dotted: {}the machine's travel at each index</text>"#,
        if deposit { "deposition" } else { "cutting" },
        if deposit {
            "feeds with the laser off (thin), "
        } else {
            ""
        }
    );
    if let Colouring::Deviation { tolerance, .. } = colouring {
        y += 20.0;
        let _ = writeln!(
            s,
            r#"<g class="deviation-legend"><rect x="8" y="{:.1}" width="14" height="10" fill="{}"/><text x="26" y="{y:.1}">0</text><rect x="60" y="{:.1}" width="14" height="10" fill="{}"/><text x="78" y="{y:.1}">{:.2e}</text><rect x="160" y="{:.1}" width="14" height="10" fill="{}"/><text x="178" y="{y:.1}">{:.2e} {unit} (the tolerance) and beyond; grey: not compared</text></g>"#,
            y - 10.0,
            ramp(0.0),
            y - 10.0,
            ramp(0.5),
            tolerance / 2.0,
            y - 10.0,
            ramp(1.0),
            tolerance
        );
    }
    for (k, r) in preview.positions.iter().enumerate() {
        y += 20.0;
        let _ = writeln!(
            s,
            r#"<g class="legend" data-position="{k}"><line x1="8" y1="{:.1}" x2="38" y2="{:.1}" stroke="{c}" stroke-width="3"/><text x="46" y="{y:.1}">index {}: {}</text></g>"#,
            y - 4.0,
            y - 4.0,
            k + 1,
            esc(&label(r)),
            c = colour(k)
        );
    }
    s.push_str("</svg>\n");
    s
}
