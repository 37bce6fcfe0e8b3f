//! The whole deposition plan of a slicing (paper 001): per layer the perimeters with
//! their approach directions, then the raster fill, then the offset-angle check.
//!
//! ## Offset angle
//! Paper 001's offset angle is how far a new layer may overhang the one under it. At a
//! perimeter point `p` with tool axis `a` (tip → head; the beam runs along `−a`) the beam
//! meets the previous layer's plane at `q = p − t·a`; the previous layer's bead runs
//! along its loops, nearest to `q` at `b`. The offset angle is `atan(|q − b| / t)`: the
//! angle, seen from the new bead, between the beam and the bead it lands on. A wall
//! parallel to the approach gives 0; a wall leaning `φ` from a vertical approach gives
//! `φ` (on both faces of a thin wall: a bead shifted either way loses support). Rasters
//! are not checked: they are laid inside the perimeter just deposited. Layer 0 lies on the
//! substrate. A beam parallel to the previous plane (or pointing away from it) counts as
//! 90°.
//!
//! With the tangent approach ([`Approach::Tangent`]) a point over the limit is tilted: its
//! axis is turned towards `p − b` (the axis that puts the beam on the previous bead) just
//! far enough to come back under the limit, provided `p − b` is within the largest tilt
//! from the build direction. What stays over the limit is reported
//! ([`Plan::violations`]).

use lampost_mesh::{Mesh, P3};

use crate::error::PlanError;
use crate::perimeter::{check, one_loop, PathPoint, PerimeterOptions};
use crate::raster::{layer_runs, plane_axes, RasterOptions, Run};
use crate::slice::{Slice, Slicing};

/// Most perimeter points a plan may have (by its loops' length over the spacing).
pub const MAX_POINTS: f64 = 5e7;
/// Most raster rays a layer may have (its width over the hatch).
pub const MAX_RAYS: f64 = 1e6;
/// How far past the offset-angle limit an angle may be by rounding alone, degrees: a
/// wall leaning exactly at the limit (the twisted plate's ends at 45°) computes to 45 ±
/// 1e-14, which is not over it.
pub const ANGLE_ROUNDING_DEG: f64 = 1e-9;
/// The smallest largest tool-axis turn between points, degrees.
pub const MIN_TURN_DEG: f64 = 0.01;

/// Where the perimeters' tool axes come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Approach {
    /// Paper 001's rule: tangent to the surface, across the traversal.
    Tangent,
    /// Along the build direction everywhere (a three-axis build).
    Build,
}

/// Options of [`plan()`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanOptions {
    /// Perimeter point spacing.
    pub perimeter: PerimeterOptions,
    /// Raster fill; `None`: hollow (perimeters only).
    pub raster: Option<RasterOptions>,
    /// The perimeters' approach.
    pub approach: Approach,
    /// Largest offset angle, degrees.
    pub max_offset_deg: f64,
    /// Largest tilt of a tilted axis from the build direction, degrees.
    pub max_tilt_deg: f64,
    /// Threads (1: this thread only); the plan does not depend on it.
    pub threads: usize,
}

/// A perimeter point over the offset-angle limit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Violation {
    /// Layer index.
    pub layer: usize,
    /// Loop within the layer.
    pub loop_index: usize,
    /// Point within the loop's path.
    pub point: usize,
    /// Its offset angle, degrees.
    pub angle_deg: f64,
    /// The point.
    pub p: P3,
}

/// One layer of the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerPlan {
    /// Layer index.
    pub index: usize,
    /// The build direction of the layer (unit).
    pub normal: P3,
    /// Each loop's path: laser off onto the first point, then on.
    pub loops: Vec<Vec<PathPoint>>,
    /// Each loop path point's offset angle, degrees (0 on layer 0).
    pub offset_deg: Vec<Vec<f64>>,
    /// Raster runs in order.
    pub runs: Vec<Run>,
    /// The raster angle, degrees (`None`: hollow).
    pub raster_angle_deg: Option<f64>,
}

impl LayerPlan {
    /// Perimeter length (laser on).
    pub fn perimeter_length(&self) -> f64 {
        self.loops
            .iter()
            .map(|l| l.windows(2).map(|w| (w[1].p - w[0].p).norm()).sum::<f64>())
            .sum()
    }
    /// Raster length (laser on).
    pub fn raster_length(&self) -> f64 {
        self.runs.iter().map(Run::length).sum()
    }
    /// The largest offset angle, degrees.
    pub fn worst_offset_deg(&self) -> f64 {
        self.offset_deg
            .iter()
            .flatten()
            .fold(0.0f64, |a, &b| a.max(b))
    }
}

/// A plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Layers in order.
    pub layers: Vec<LayerPlan>,
    /// Points left over the offset-angle limit.
    pub violations: Vec<Violation>,
    /// Points whose axis was tilted to come under the limit.
    pub tilted: usize,
}

impl Plan {
    /// The path: per layer its perimeters, then its rasters (laser off onto each run's
    /// start, on along it, the tool axis the build direction).
    pub fn points(&self) -> Vec<PathPoint> {
        self.iter().collect()
    }

    /// The path's points in order, without holding them all.
    pub fn iter(&self) -> impl Iterator<Item = PathPoint> + '_ {
        self.layers.iter().flat_map(|l| {
            l.loops
                .iter()
                .flatten()
                .copied()
                .chain(l.runs.iter().flat_map(move |r| {
                    [(r.from, false), (r.to, true)].map(|(p, laser)| PathPoint {
                        p,
                        axis: l.normal,
                        laser,
                        layer: l.index,
                    })
                }))
        })
    }

    /// The largest offset angle over all layers, degrees.
    pub fn worst_offset_deg(&self) -> f64 {
        self.layers
            .iter()
            .map(LayerPlan::worst_offset_deg)
            .fold(0.0, f64::max)
    }
}

/// A segment of the previous layer's loops as the grid keeps it: its start `a`, its
/// direction `d` (end − start) and `l2 = d·d`, so that a query computes only the
/// projection.
#[derive(Debug, Clone, Copy)]
struct GridSeg {
    a: [f64; 2],
    d: [f64; 2],
    l2: f64,
}

impl GridSeg {
    fn new(a: [f64; 2], b: [f64; 2]) -> GridSeg {
        let d = [b[0] - a[0], b[1] - a[1]];
        GridSeg {
            a,
            d,
            l2: d[0] * d[0] + d[1] * d[1],
        }
    }

    /// The point of the segment nearest `q` and its squared distance.
    #[inline]
    fn closest(&self, q: [f64; 2]) -> ([f64; 2], f64) {
        let (a, d) = (self.a, self.d);
        let t = if self.l2 > 0.0 {
            (((q[0] - a[0]) * d[0] + (q[1] - a[1]) * d[1]) / self.l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let p = [a[0] + t * d[0], a[1] + t * d[1]];
        let (x, y) = (p[0] - q[0], p[1] - q[1]);
        (p, x * x + y * y)
    }
}

/// The previous layer's loops as segments in its plane, bucketed in a grid for nearest-
/// point queries.
struct SegGrid {
    origin: P3,
    e1: P3,
    e2: P3,
    normal: P3,
    lo: [f64; 2],
    cell: f64,
    nx: usize,
    ny: usize,
    /// Cell `c`'s segments are `items[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    /// Each cell's segments (copied into every cell the segment's bounding box meets),
    /// cell after cell, in the loops' order within a cell.
    items: Vec<GridSeg>,
}

impl SegGrid {
    fn new(s: &Slice) -> Option<SegGrid> {
        let (e1, e2) = plane_axes(s.normal);
        let o = s.origin;
        let mut segs: Vec<GridSeg> =
            Vec::with_capacity(s.loops.iter().map(|l| l.points.len()).sum());
        let mut uv: Vec<[f64; 2]> = Vec::new();
        for l in &s.loops {
            let k = l.points.len();
            uv.clear();
            uv.extend(
                l.points
                    .iter()
                    .map(|p| [(p - o).dot(&e1), (p - o).dot(&e2)]),
            );
            for i in 0..k {
                segs.push(GridSeg::new(uv[i], uv[(i + 1) % k]));
            }
        }
        if segs.is_empty() {
            return None;
        }
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        let mut total = 0.0;
        for g in &segs {
            for c in [g.a, [g.a[0] + g.d[0], g.a[1] + g.d[1]]] {
                for d in 0..2 {
                    lo[d] = lo[d].min(c[d]);
                    hi[d] = hi[d].max(c[d]);
                }
            }
            total += g.l2.sqrt();
        }
        let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
        // Cells about twice the mean segment's length, at most 16 per segment.
        let mean = total / segs.len() as f64;
        let mut cell = (2.0 * mean).max(w.max(h) / 4096.0).max(1e-9);
        while ((w / cell).floor() + 1.0) * ((h / cell).floor() + 1.0)
            > 16.0 * segs.len() as f64 + 1024.0
        {
            cell *= 1.5;
        }
        let nx = (w / cell).floor() as usize + 1;
        let ny = (h / cell).floor() as usize + 1;
        let idx = |x: f64, d: usize, m: usize| {
            // `as` truncates (a floor for the non-negative) and saturates (NaN: 0).
            (((x - lo[d]) / cell).max(0.0) as usize).min(m - 1)
        };
        // Each segment's block of cells, found once.
        let ranges: Vec<[usize; 4]> = segs
            .iter()
            .map(|g| {
                let b = [g.a[0] + g.d[0], g.a[1] + g.d[1]];
                [
                    idx(g.a[0].min(b[0]), 0, nx),
                    idx(g.a[0].max(b[0]), 0, nx),
                    idx(g.a[1].min(b[1]), 1, ny),
                    idx(g.a[1].max(b[1]), 1, ny),
                ]
            })
            .collect();
        let mut count = vec![0u32; nx * ny + 1];
        for &[x0, x1, y0, y1] in &ranges {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    count[y * nx + x + 1] += 1;
                }
            }
        }
        for i in 1..count.len() {
            count[i] += count[i - 1];
        }
        let mut fill = count.clone();
        let mut items = vec![segs[0]; count[nx * ny] as usize];
        for (g, &[x0, x1, y0, y1]) in segs.iter().zip(&ranges) {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let c = y * nx + x;
                    items[fill[c] as usize] = *g;
                    fill[c] += 1;
                }
            }
        }
        Some(SegGrid {
            origin: o,
            e1,
            e2,
            normal: s.normal,
            lo,
            cell,
            nx,
            ny,
            start: count,
            items,
        })
    }

    /// The segments of cell `(i, j)`.
    #[inline]
    fn cell_items(&self, i: usize, j: usize) -> &[GridSeg] {
        let c = j * self.nx + i;
        &self.items[self.start[c] as usize..self.start[c + 1] as usize]
    }

    /// The nearest point of the segments to `q` (in the plane's coordinates) and its
    /// distance.
    fn nearest(&self, q: [f64; 2]) -> ([f64; 2], f64) {
        // `as` truncates (a floor for the non-negative) and saturates.
        let ci = (((q[0] - self.lo[0]) / self.cell).max(0.0) as usize).min(self.nx - 1);
        let cj = (((q[1] - self.lo[1]) / self.cell).max(0.0) as usize).min(self.ny - 1);
        // Squared distances while searching.
        let mut best = (q, f64::INFINITY);
        let search = |i: usize, j: usize, best: &mut ([f64; 2], f64)| {
            for g in self.cell_items(i, j) {
                let (p, d) = g.closest(q);
                if d < best.1 {
                    *best = (p, d);
                }
            }
        };
        let reach = self.nx.max(self.ny);
        for r in 0..=reach {
            let (i0, i1) = (ci.saturating_sub(r), (ci + r).min(self.nx - 1));
            let (j0, j1) = (cj.saturating_sub(r), (cj + r).min(self.ny - 1));
            // The ring of cells at Chebyshev distance r (those inside the grid), row by
            // row: whole rows at its top and bottom, the two side cells between.
            for j in j0..=j1 {
                if j.abs_diff(cj) == r {
                    for i in i0..=i1 {
                        search(i, j, &mut best);
                    }
                } else {
                    if ci >= r {
                        search(ci - r, j, &mut best);
                    }
                    if r > 0 && ci + r < self.nx {
                        search(ci + r, j, &mut best);
                    }
                }
            }
            // Every cell not yet searched lies beyond the searched block's sides (those
            // with cells beyond them): no nearer point there than the nearest side.
            let mut bound = f64::INFINITY;
            if i0 > 0 {
                bound = bound.min(q[0] - (self.lo[0] + i0 as f64 * self.cell));
            }
            if i1 + 1 < self.nx {
                bound = bound.min(self.lo[0] + (i1 + 1) as f64 * self.cell - q[0]);
            }
            if j0 > 0 {
                bound = bound.min(q[1] - (self.lo[1] + j0 as f64 * self.cell));
            }
            if j1 + 1 < self.ny {
                bound = bound.min(self.lo[1] + (j1 + 1) as f64 * self.cell - q[1]);
            }
            if bound == f64::INFINITY || (bound >= 0.0 && best.1 <= bound * bound) {
                break;
            }
        }
        (best.0, best.1.sqrt())
    }

    fn to_plane(&self, p: P3) -> [f64; 2] {
        let d = p - self.origin;
        [d.dot(&self.e1), d.dot(&self.e2)]
    }

    fn point_at(&self, u: [f64; 2]) -> P3 {
        self.origin + self.e1 * u[0] + self.e2 * u[1]
    }

    /// The offset angle (degrees) of a point `p` with axis `a` over this layer, and the
    /// nearest bead point `b` in the plane's coordinates ([`SegGrid::point_at`] makes it
    /// a point, needed only to tilt).
    fn offset(&self, p: P3, a: P3) -> (f64, [f64; 2]) {
        let down = a.dot(&self.normal);
        let t = (p - self.origin).dot(&self.normal);
        if down.is_nan() || t.is_nan() || down <= 1e-12 || t <= 0.0 {
            let (bq, _) = self.nearest(self.to_plane(p));
            return (90.0, bq);
        }
        let t = t / down;
        let q = p - a * t;
        let (b, s) = self.nearest(self.to_plane(q));
        (s.atan2(t).to_degrees(), b)
    }
}

fn unit(v: P3) -> Option<P3> {
    let n = v.norm();
    (n > 1e-300 && n.is_finite()).then(|| v / n)
}

/// Plan every layer of `slicing`: perimeters (tool axes by `opts.approach`), rasters,
/// the offset-angle check and tilting.
pub fn plan(mesh: &Mesh, slicing: &Slicing, opts: &PlanOptions) -> Result<Plan, PlanError> {
    check(&opts.perimeter)?;
    let angle = |what: &'static str, v: f64, hi: f64| {
        if v.is_finite() && v > 0.0 && v <= hi {
            Ok(())
        } else {
            Err(PlanError::Layer {
                what,
                value: v,
                why: format!("not an angle above 0° and at most {hi}°"),
            })
        }
    };
    angle("largest offset angle", opts.max_offset_deg, 90.0)?;
    angle("largest tilt", opts.max_tilt_deg, 180.0)?;
    // Bounded output: a spacing, turn or hatch so small that the path would not fit in
    // memory is refused, not attempted.
    let length: f64 = slicing
        .slices
        .iter()
        .flat_map(|s| s.loops.iter().map(|l| l.length))
        .sum();
    if length / opts.perimeter.spacing > MAX_POINTS {
        return Err(PlanError::Layer {
            what: "point spacing",
            value: opts.perimeter.spacing,
            why: format!(
                "so small that the perimeters ({} long) would have more than {MAX_POINTS:e} points",
                lampost_gcode::Readable(length)
            ),
        });
    }
    if opts.perimeter.max_turn_deg < MIN_TURN_DEG {
        return Err(PlanError::Layer {
            what: "largest tool-axis turn",
            value: opts.perimeter.max_turn_deg,
            why: format!("below {MIN_TURN_DEG}°"),
        });
    }
    if let Some(r) = &opts.raster {
        let widest = slicing
            .slices
            .iter()
            .map(|s| {
                let mut lo = P3::repeat(f64::INFINITY);
                let mut hi = P3::repeat(f64::NEG_INFINITY);
                for p in s.loops.iter().flat_map(|l| &l.points) {
                    lo = lo.inf(p);
                    hi = hi.sup(p);
                }
                (hi - lo).norm()
            })
            .filter(|d| d.is_finite())
            .fold(0.0, f64::max);
        if widest / r.hatch > MAX_RAYS {
            return Err(PlanError::Layer {
                what: "hatch spacing",
                value: r.hatch,
                why: format!(
                    "so small that a layer {widest:.6} mm wide would have more than {MAX_RAYS:e} rays"
                ),
            });
        }
        if !(r.hatch.is_finite() && r.hatch > 0.0) {
            return Err(PlanError::Layer {
                what: "hatch spacing",
                value: r.hatch,
                why: "not a positive number".into(),
            });
        }
        if !(r.inset.is_finite() && r.inset >= 0.0) {
            return Err(PlanError::Layer {
                what: "bead width",
                value: r.inset * 2.0,
                why: "not a number ≥ 0".into(),
            });
        }
        for (what, v) in [("raster angle", r.angle_deg), ("raster turn", r.turn_deg)] {
            if !v.is_finite() {
                return Err(PlanError::Layer {
                    what,
                    value: v,
                    why: "not a finite number of degrees".into(),
                });
            }
        }
    }
    let n = slicing.slices.len();
    let threads = opts.threads.clamp(1, 64).min(n.max(1));
    // Every layer depends only on its own slice and the one before: contiguous blocks of
    // layers on `threads` threads, joined in order (the result does not depend on the
    // thread count).
    let block = |r: std::ops::Range<usize>| -> Vec<(LayerPlan, Vec<Violation>, usize)> {
        r.map(|k| plan_layer(mesh, slicing, k, opts)).collect()
    };
    let parts: Vec<Vec<(LayerPlan, Vec<Violation>, usize)>> = if threads <= 1 {
        vec![block(0..n)]
    } else {
        let cuts: Vec<usize> = (0..=threads).map(|t| t * n / threads).collect();
        std::thread::scope(|sc| {
            let handles: Vec<_> = cuts
                .windows(2)
                .map(|w| {
                    let r = w[0]..w[1];
                    sc.spawn(move || block(r))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_default())
                .collect()
        })
    };
    let mut layers = Vec::with_capacity(n);
    let mut violations = Vec::new();
    let mut tilted = 0;
    for (l, v, t) in parts.into_iter().flatten() {
        layers.push(l);
        violations.extend(v);
        tilted += t;
    }
    if layers.len() != n {
        return Err(PlanError::Mesh("a planning thread failed".into()));
    }
    Ok(Plan {
        layers,
        violations,
        tilted,
    })
}

/// Layer `k` of the plan: its perimeters, the offset-angle check against layer `k − 1`
/// (and tilting), its rasters; the points over the limit; how many were tilted.
fn plan_layer(
    mesh: &Mesh,
    slicing: &Slicing,
    k: usize,
    opts: &PlanOptions,
) -> (LayerPlan, Vec<Violation>, usize) {
    let s = &slicing.slices[k];
    let prev = k
        .checked_sub(1)
        .and_then(|j| SegGrid::new(&slicing.slices[j]));
    let mut violations = Vec::new();
    let mut tilted = 0;
    let max_tilt = opts.max_tilt_deg.to_radians();
    {
        let mut loops: Vec<Vec<PathPoint>> = s
            .loops
            .iter()
            .map(|l| one_loop(mesh, &l.points, &l.faces, s.index, &opts.perimeter))
            .collect();
        if opts.approach == Approach::Build {
            for q in loops.iter_mut().flatten() {
                q.axis = s.normal;
            }
        }
        let mut offset_deg: Vec<Vec<f64>> = loops.iter().map(|l| vec![0.0; l.len()]).collect();
        if let Some(g) = &prev {
            for (li, l) in loops.iter_mut().enumerate() {
                for (pi, q) in l.iter_mut().enumerate() {
                    let (mut ang, b) = g.offset(q.p, q.axis);
                    if ang > opts.max_offset_deg + ANGLE_ROUNDING_DEG
                        && opts.approach == Approach::Tangent
                    {
                        if let Some(target) =
                            unit(q.p - g.point_at(b)).filter(|t| t.angle(&s.normal) <= max_tilt)
                        {
                            // The smallest turn towards the target that comes under the
                            // limit (the target itself gives 0).
                            let (mut lo, mut hi) = (0.0f64, 1.0f64);
                            let at =
                                |f: f64| unit(q.axis * (1.0 - f) + target * f).unwrap_or(target);
                            let limit = opts.max_offset_deg * (1.0 - 1e-9);
                            if g.offset(q.p, target).0 <= limit {
                                for _ in 0..40 {
                                    let mid = 0.5 * (lo + hi);
                                    if g.offset(q.p, at(mid)).0 <= limit {
                                        hi = mid;
                                    } else {
                                        lo = mid;
                                    }
                                }
                                q.axis = at(hi);
                                ang = g.offset(q.p, q.axis).0;
                                tilted += 1;
                            }
                        }
                    }
                    offset_deg[li][pi] = ang;
                    if ang > opts.max_offset_deg + ANGLE_ROUNDING_DEG {
                        violations.push(Violation {
                            layer: s.index,
                            loop_index: li,
                            point: pi,
                            angle_deg: ang,
                            p: q.p,
                        });
                    }
                }
            }
        }
        let (runs, raster_angle_deg) = match &opts.raster {
            Some(r) => (
                layer_runs(s, r),
                Some(crate::raster::layer_angle(r, s.index)),
            ),
            None => (Vec::new(), None),
        };
        (
            LayerPlan {
                index: s.index,
                normal: s.normal,
                loops,
                offset_deg,
                runs,
                raster_angle_deg,
            },
            violations,
            tilted,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slice::Loop;
    use proptest::prelude::*;

    /// A slice holding `loops` (points in the plane z = 0).
    fn slice_of(loops: Vec<Vec<P3>>) -> Slice {
        Slice {
            index: 0,
            normal: P3::z(),
            origin: P3::zeros(),
            height: 0.0,
            loops: loops
                .into_iter()
                .map(|points| Loop {
                    faces: vec![0; points.len()],
                    points,
                    area: 0.0,
                    length: 0.0,
                    stitched: 0,
                })
                .collect(),
            open: Vec::new(),
            gaps: Vec::new(),
            segments: 0,
        }
    }

    proptest! {
        /// The grid's nearest point is the nearest of all segments (the reference: every
        /// segment tried), to the last bit of the distance.
        #[test]
        fn the_grids_nearest_point_is_the_nearest_of_every_segment(
            loops in prop::collection::vec(
                prop::collection::vec((-50.0f64..50.0, -20.0f64..20.0), 3..40),
                1..4,
            ),
            queries in prop::collection::vec((-80.0f64..80.0, -60.0f64..60.0), 1..30),
        ) {
            let loops: Vec<Vec<P3>> = loops
                .iter()
                .map(|l| l.iter().map(|&(x, y)| P3::new(x, y, 0.0)).collect())
                .collect();
            let s = slice_of(loops.clone());
            let g = SegGrid::new(&s).expect("segments");
            for &(x, y) in &queries {
                let q = g.to_plane(P3::new(x, y, 0.0));
                let (_, d) = g.nearest(q);
                let mut best = f64::INFINITY;
                for l in &loops {
                    let k = l.len();
                    for i in 0..k {
                        let (a, b) = (g.to_plane(l[i]), g.to_plane(l[(i + 1) % k]));
                        let (_, d2) = GridSeg::new(a, b).closest(q);
                        best = best.min(d2);
                    }
                }
                prop_assert_eq!(d, best.sqrt());
            }
        }
    }
}
