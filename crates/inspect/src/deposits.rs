//! Closing the loop for deposition: which layers and lines of a posted program deposited
//! where the measured part is out of tolerance.
//!
//! [`replay`] reads the posted program through the post's one replay
//! ([`lampost_post::preview::replay`]: the text through the interpreter and the machine's
//! forward kinematics of the deposition head, the laser followed by the machine's process
//! codes, nothing from the post) into the part-frame segments the tool point travelled
//! with the laser on; each segment keeps its
//! posted line and its layer. A layer is one deposition height: the tip's height along the
//! tool axis at the end of the move, with the table position (rotaries), to 1e-4 of the
//! machine's unit; layers are numbered 1, 2, … in the order they first deposit.
//! [`Deposition::nearest`] finds, for a point, the nearest segment within a radius (a
//! uniform grid of the segments' samples, so a query looks at 27 cells) and every layer
//! within that radius.

use std::collections::HashMap;

use lampost_kinematics::{Joints, Machine};
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
    if m.def.process.laser_on.trim().is_empty() || m.def.process.laser_off.trim().is_empty() {
        return Err(InspectError::Input(format!(
            "machine {} has no laser_on/laser_off M code in its [process] table: the deposition cannot be told from travel",
            m.def.name
        )));
    }
    let preview = lampost_post::preview::replay(m, head, text).map_err(|e| match e {
        lampost_post::PostError::Input { diag, .. } => InspectError::At {
            line: diag.line as usize,
            what: format!("the posted program: {}", diag.kind),
        },
        other => InspectError::Input(format!("the posted program: {other}")),
    })?;
    // The tool axis at each table position (part frame), for the layers' heights.
    let axes: Vec<lampost_kinematics::Vector3<f64>> = preview
        .positions
        .iter()
        .map(|r| {
            m.forward(
                &Joints {
                    linear: [0.0; 3],
                    rotary: *r,
                },
                head,
            )
            .axis
        })
        .collect();
    let unit = 1e-4;
    let mut out = Deposition {
        cell: 2.0 * radius,
        ..Deposition::default()
    };
    let mut keys: HashMap<[i64; 3], usize> = HashMap::new();
    for run in preview.runs.iter().filter(|r| r.laser) {
        let rotary = preview.positions[run.position];
        let axis = axes[run.position];
        let mut last_line = None;
        for (k, pair) in run.points.windows(2).enumerate() {
            let line = run.lines.get(k + 1).copied().unwrap_or(0);
            let end = pair[1];
            let height = end[0] * axis.x + end[1] * axis.y + end[2] * axis.z;
            let key = [
                (height / unit).round() as i64,
                (rotary[0] * 1e3).round() as i64,
                (rotary[1] * 1e3).round() as i64,
            ];
            let layer = match keys.get(&key) {
                Some(&l) => l,
                None => {
                    out.layers.push(Layer {
                        height,
                        rotary,
                        lines: [line, line],
                        moves: 0,
                    });
                    keys.insert(key, out.layers.len());
                    out.layers.len()
                }
            };
            let l = &mut out.layers[layer - 1];
            l.lines[1] = line;
            // A move's chord points (an arc's) count once.
            if last_line != Some(line) {
                l.moves += 1;
                last_line = Some(line);
            }
            out.segments.push(Segment {
                a: pair[0],
                b: end,
                line,
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
    fn segment_distances() {
        let d = super::seg_distance([1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
        assert!((d - 1.0).abs() < 1e-15);
        let e = super::seg_distance([3.0, 0.0, 0.0], [0.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
        assert!((e - 1.0).abs() < 1e-15);
    }
}
