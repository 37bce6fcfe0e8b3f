//! Closing the loop for deposition: which layers and lines of a posted program deposited
//! where the measured part is out of tolerance.
//!
//! [`replay`] reads the posted program (its own text, through the interpreter and the
//! machine's forward kinematics of the deposition head, nothing from the post) into the
//! part-frame segments the tool point travelled with the laser on; each segment keeps its
//! posted line and its layer. A layer is one deposition height: the tip's height along the
//! tool axis at the end of the move, with the table position (rotaries), to 1e-4 of the
//! machine's unit; layers are numbered 1, 2, … in the order they first deposit.
//! [`Deposition::nearest`] finds, for a point, the nearest segment within a radius (a
//! uniform grid of the segments' samples, so a query looks at 27 cells) and every layer
//! within that radius.

use std::collections::HashMap;

use lampost_gcode::{Event, MoveKind, Options, Plane, Severity, Stream, Units, AXES};
use lampost_kinematics::{Joints, Machine, Units as MUnits};
use serde::Serialize;

use crate::error::InspectError;

/// A straight piece of deposition in the part frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Segment {
    /// Start (part frame).
    pub a: [f64; 3],
    /// End (part frame).
    pub b: [f64; 3],
    /// The posted program's line (1-based).
    pub line: u32,
    /// The layer (1-based index into [`Deposition::layers`] plus one).
    pub layer: usize,
}

/// One deposition height at one table position.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Layer {
    /// The tip's height along the tool axis (part frame).
    pub height: f64,
    /// The rotaries, degrees.
    pub rotary: [f64; 2],
    /// First and last posted line that deposited in it.
    pub lines: [u32; 2],
    /// Deposition moves in it.
    pub moves: usize,
}

/// What a posted program deposited.
#[derive(Debug, Clone, Default)]
pub struct Deposition {
    /// The segments, in program order (arcs as chords of at most 5°).
    pub segments: Vec<Segment>,
    /// The layers, numbered from 1 in this order.
    pub layers: Vec<Layer>,
    grid: HashMap<[i64; 3], Vec<u32>>,
    cell: f64,
}

/// The nearest deposition to a point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Near {
    /// The nearest segment's posted line.
    pub line: u32,
    /// Its layer (1-based).
    pub layer: usize,
    /// Distance from the point to it.
    pub distance: f64,
    /// Every layer with a segment within the radius, ascending.
    pub layers_within: Vec<usize>,
}

/// The M numbers of a process code such as `M71` (`M71 M8` gives both).
fn m_codes(code: &str) -> Vec<f64> {
    code.split_whitespace()
        .filter_map(|w| {
            let (l, n) = w.split_at(1);
            (l.eq_ignore_ascii_case("m"))
                .then(|| n.parse::<f64>().ok())
                .flatten()
        })
        .collect()
}

const ARC_STEP_DEG: f64 = 5.0;
/// The most grid entries one replay makes (the deposited length over half the radius).
pub const MAX_GRID_ENTRIES: usize = 20_000_000;

/// Replay `posted` on machine `m` with the deposition head `head`: the laser is on after
/// a block holding the machine's `laser_on` M code and off after one holding `laser_off`;
/// every feed move (linear or arc) with the laser on is deposition. `radius` is the
/// search radius [`Deposition::nearest`] will use.
pub fn replay(
    m: &Machine,
    head: usize,
    text: &[u8],
    radius: f64,
) -> Result<Deposition, InspectError> {
    if !(radius.is_finite() && radius > 0.0) {
        return Err(InspectError::Input(format!(
            "--radius {radius}: give a positive distance"
        )));
    }
    let (on, off) = (
        m_codes(&m.def.process.laser_on),
        m_codes(&m.def.process.laser_off),
    );
    if on.is_empty() || off.is_empty() {
        return Err(InspectError::Input(format!(
            "machine {} has no laser_on/laser_off M code in its [process] table: the deposition cannot be told from travel",
            m.def.name
        )));
    }
    let units = match m.units {
        MUnits::Inch => Units::Inch,
        MUnits::Mm => Units::Mm,
    };
    let idx = |name: &str| {
        name.bytes()
            .next()
            .and_then(|c| AXES.iter().position(|&a| a == c.to_ascii_uppercase()))
    };
    let names = m.axis_names();
    let lin: Vec<usize> = names[..3].iter().map(|n| idx(n).unwrap_or(0)).collect();
    let rot: Vec<usize> = names[3..].iter().map(|n| idx(n).unwrap_or(3)).collect();
    let pose = |p: &[f64; 9]| {
        let j = Joints {
            linear: [p[lin[0]], p[lin[1]], p[lin[2]]],
            rotary: [p[rot[0]], p[rot[1]]],
        };
        m.forward(&j, head)
    };
    // The laser's state is read from the text: the lines holding its codes.
    let mut laser_at: Vec<Option<bool>> = Vec::new();
    for (i, raw) in text.split(|&b| b == b'\n').enumerate() {
        let mut state = None;
        if let Ok(block) = lampost_gcode::parse_line(raw, (i + 1) as u32, 0) {
            for w in block.words().filter(|w| w.letter == b'M') {
                if on.contains(&w.value) {
                    state = Some(true);
                } else if off.contains(&w.value) {
                    state = Some(false);
                }
            }
        }
        laser_at.push(state);
    }
    let unit = 1e-4;
    let mut out = Deposition {
        cell: 2.0 * radius,
        ..Deposition::default()
    };
    let mut keys: HashMap<[i64; 3], usize> = HashMap::new();
    let mut laser = false;
    let mut next_line = 1usize;
    let stream = Stream::from_bytes(
        text,
        Options {
            units,
            ..Options::default()
        },
        true,
    );
    for ev in stream {
        let ev = ev.map_err(|e| InspectError::Input(format!("the posted program: {e}")))?;
        let mv = match ev {
            Event::Diagnostic(d) if d.severity == Severity::Error => {
                return Err(InspectError::At {
                    line: d.line as usize,
                    what: format!("the posted program: {}", d.kind),
                })
            }
            Event::Diagnostic(_) => continue,
            Event::Move(mv) => mv,
        };
        // The laser state up to and including the move's own line.
        while next_line <= mv.line as usize {
            if let Some(Some(s)) = laser_at.get(next_line - 1) {
                laser = *s;
            }
            next_line += 1;
        }
        if !laser || matches!(mv.kind, MoveKind::Rapid | MoveKind::Probe) {
            continue;
        }
        let end = pose(&mv.end);
        let height = end.tip.dot(&end.axis);
        let rotary = [mv.end[rot[0]], mv.end[rot[1]]];
        let q = |x: f64| (x / unit).round() as i64;
        let key = [
            q(height),
            (rotary[0] * 1e3).round() as i64,
            (rotary[1] * 1e3).round() as i64,
        ];
        let layer = match keys.get(&key) {
            Some(&k) => k,
            None => {
                out.layers.push(Layer {
                    height,
                    rotary,
                    lines: [mv.line, mv.line],
                    moves: 0,
                });
                keys.insert(key, out.layers.len());
                out.layers.len()
            }
        };
        let l = &mut out.layers[layer - 1];
        l.lines[1] = mv.line;
        l.moves += 1;
        // The move's points: its ends, and an arc's chord points.
        let mut pts = vec![mv.start];
        if let MoveKind::Arc {
            clockwise,
            center,
            plane,
            turns,
        } = mv.kind
        {
            let (a, b, n) = match plane {
                Plane::XY => (0, 1, 2),
                Plane::XZ => (2, 0, 1),
                Plane::YZ => (1, 2, 0),
            };
            let (sa, sb) = (mv.start[a] - center[a], mv.start[b] - center[b]);
            let (ea, eb) = (mv.end[a] - center[a], mv.end[b] - center[b]);
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
                let mut p = mv.end;
                for (v, s) in p.iter_mut().zip(mv.start) {
                    *v = s + (*v - s) * t;
                }
                p[a] = center[a] + r * ang.cos();
                p[b] = center[b] + r * ang.sin();
                p[n] = mv.start[n] + (mv.end[n] - mv.start[n]) * t;
                pts.push(p);
            }
        }
        pts.push(mv.end);
        let tips: Vec<[f64; 3]> = pts
            .iter()
            .map(|p| {
                let t = pose(p).tip;
                [t.x, t.y, t.z]
            })
            .collect();
        for w in tips.windows(2) {
            out.segments.push(Segment {
                a: w[0],
                b: w[1],
                line: mv.line,
                layer,
            });
        }
    }
    out.index()?;
    Ok(out)
}

fn cell_of(p: [f64; 3], cell: f64) -> [i64; 3] {
    p.map(|x| (x / cell).floor() as i64)
}

fn seg_distance(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let d: [f64; 3] = std::array::from_fn(|k| b[k] - a[k]);
    let w: [f64; 3] = std::array::from_fn(|k| p[k] - a[k]);
    let dd: f64 = d.iter().map(|x| x * x).sum();
    let t = if dd > 0.0 {
        (w.iter().zip(&d).map(|(x, y)| x * y).sum::<f64>() / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (0..3)
        .map(|k| (w[k] - t * d[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

impl Deposition {
    /// The grid: each segment sampled every half cell (a cell is twice the radius), each
    /// sample's cell holding the segment; a point within the radius of a segment is then
    /// within 0.75 cell of a sample, in its own cell or a neighbour.
    fn index(&mut self) -> Result<(), InspectError> {
        let cell = self.cell;
        let mut entries = 0usize;
        for (k, s) in self.segments.iter().enumerate() {
            let len = seg_distance(s.b, s.a, s.a);
            let n = (len / (0.5 * cell)).ceil().max(1.0);
            entries += n as usize + 1;
            if !n.is_finite() || entries > MAX_GRID_ENTRIES {
                return Err(InspectError::Input(format!(
                    "the deposition is too long for a search radius of {}: give a larger --radius",
                    0.5 * cell
                )));
            }
            let mut last = None;
            for i in 0..=n as usize {
                let t = i as f64 / n;
                let p: [f64; 3] = std::array::from_fn(|j| s.a[j] + (s.b[j] - s.a[j]) * t);
                let c = cell_of(p, cell);
                if last != Some(c) {
                    let v = self.grid.entry(c).or_default();
                    if v.last() != Some(&(k as u32)) {
                        v.push(k as u32);
                    }
                    last = Some(c);
                }
            }
        }
        Ok(())
    }

    /// The nearest deposition segment to `p` within the radius given to [`replay`], and
    /// every layer within it; `None` when nothing was deposited that near.
    pub fn nearest(&self, p: [f64; 3]) -> Option<Near> {
        let radius = 0.5 * self.cell;
        let c = cell_of(p, self.cell);
        let mut best: Option<(f64, usize)> = None;
        let mut layers = Vec::new();
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(v) = self.grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                        continue;
                    };
                    for &k in v {
                        let s = &self.segments[k as usize];
                        let d = seg_distance(p, s.a, s.b);
                        if d <= radius {
                            layers.push(s.layer);
                            // Ties go to the earlier segment.
                            if best.is_none_or(|(bd, bk)| d < bd || (d == bd && (k as usize) < bk))
                            {
                                best = Some((d, k as usize));
                            }
                        }
                    }
                }
            }
        }
        layers.sort_unstable();
        layers.dedup();
        best.map(|(distance, k)| Near {
            line: self.segments[k].line,
            layer: self.segments[k].layer,
            distance,
            layers_within: layers,
        })
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn distances_and_codes() {
        assert_eq!(super::m_codes("M71"), vec![71.0]);
        assert_eq!(super::m_codes("m3 S100 M8"), vec![3.0, 8.0]);
        assert!(super::m_codes("").is_empty());
        let d = super::seg_distance([1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
        assert!((d - 1.0).abs() < 1e-15);
        let e = super::seg_distance([3.0, 0.0, 0.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
        assert!((e - 1.0).abs() < 1e-15);
    }
}
