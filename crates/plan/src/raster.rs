//! Raster fill (paper 001's rule): parallel rays in the slice plane, clipped to the
//! slice's region inset by half a bead width, connected in a zig-zag.
//!
//! ## Clipping, exactly
//! The inset region is `{x ∈ P : dist(x, ∂P) ≥ r}` for the region `P` the oriented loops
//! bound (non-zero winding: outer loops counter-clockwise, holes clockwise) and the inset
//! `r` (half the bead). On one ray (a line in the plane) that is the part of the line
//! inside `P` minus every edge's *capsule* (the points within `r` of the edge): inside
//! `P` is found from the crossings of the line with the edges and their winding; a
//! capsule meets the line in one interval (it is convex: the union of the two end
//! disks' chords and the rectangle's), so the runs are intervals minus intervals. No
//! polygon offsetting, no tolerance: a concave corner, a hole or a loop narrower than the
//! bead come out right by construction.
//!
//! ## Rays and order
//! The rays of a layer run along `cos α·e₁ + sin α·e₂` in the plane (`e₁`, `e₂` the
//! plane's axes, see [`plane_axes`]), `α = angle + layer·turn`; they are `hatch` apart
//! across, the first half a hatch inside the inset's extent, so the rays sample it at
//! the middles of strips `hatch` wide (Σ run length × hatch ≈ the inset's area). Runs
//! are taken in a zig-zag: from the current run, the next is the nearest-ended run on
//! the next ray that overlaps it along the ray; each run is entered from its end nearer
//! the last position; where no run continues, a new zig-zag starts from the first run
//! left. Moves between runs are travel (laser off).

use lampost_mesh::P3;

use crate::slice::Slice;

/// How rasters are laid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RasterOptions {
    /// Distance between rays (> 0).
    pub hatch: f64,
    /// Inset of the rays' region from the loops: half a bead width (≥ 0).
    pub inset: f64,
    /// Ray angle of layer 0 in the plane, degrees from `e₁`.
    pub angle_deg: f64,
    /// Added to the angle per layer, degrees.
    pub turn_deg: f64,
}

/// One run: laser on from `from` to `to`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Run {
    /// Start.
    pub from: P3,
    /// End.
    pub to: P3,
}

impl Run {
    /// Its length.
    pub fn length(&self) -> f64 {
        (self.to - self.from).norm()
    }
}

/// Two unit axes of the plane normal to `n` (unit): `e₁` is the x axis made
/// perpendicular to `n` (the y axis where `n` is near x), `e₂ = n × e₁`.
pub fn plane_axes(n: P3) -> (P3, P3) {
    let seed = if n.x.abs() < 0.9 { P3::x() } else { P3::y() };
    let e1 = seed - n * seed.dot(&n);
    let e1 = e1 / e1.norm();
    (e1, n.cross(&e1))
}

/// The ray angle of layer `k`, degrees.
pub fn layer_angle(opts: &RasterOptions, k: usize) -> f64 {
    (opts.angle_deg + opts.turn_deg * k as f64).rem_euclid(360.0)
}

/// An edge in the ray frame: `(u, v)` ends, `u` along the rays, `v` across, with its
/// unit direction and length (computed once per layer, not once per ray).
#[derive(Debug, Clone, Copy)]
struct Edge {
    a: [f64; 2],
    b: [f64; 2],
    /// Unit direction from `a` to `b` (zero for a zero-length edge).
    t: [f64; 2],
    /// Length.
    len: f64,
}

impl Edge {
    fn new(a: [f64; 2], b: [f64; 2]) -> Edge {
        let (du, dv) = (b[0] - a[0], b[1] - a[1]);
        let len = du.hypot(dv);
        let t = if len > 0.0 {
            [du / len, dv / len]
        } else {
            [0.0, 0.0]
        };
        Edge { a, b, t, len }
    }
}

/// The interval of `u` on the line `v = const` within `r` of the edge (one interval: the
/// capsule is convex), or `None`.
fn capsule(e: &Edge, v: f64, r: f64) -> Option<(f64, f64)> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for c in [e.a, e.b] {
        let dv = v - c[1];
        let h = r * r - dv * dv;
        if h >= 0.0 {
            let s = h.sqrt();
            lo = lo.min(c[0] - s);
            hi = hi.max(c[0] + s);
        }
    }
    // The rectangle: 0 ≤ (P − a)·t ≤ L and |(P − a)·m| ≤ r, with P = (u, v), t the unit
    // direction, m its normal; each is c0 + c1·u within bounds.
    let len = e.len;
    if len > 0.0 {
        let [tu, tv] = e.t;
        let (mu, mv) = (-tv, tu);
        let mut rl = f64::NEG_INFINITY;
        let mut rh = f64::INFINITY;
        let mut empty = false;
        for (c1, c0, blo, bhi) in [
            (tu, (v - e.a[1]) * tv - e.a[0] * tu, 0.0, len),
            (mu, (v - e.a[1]) * mv - e.a[0] * mu, -r, r),
        ] {
            if c1.abs() < 1e-300 {
                if c0 < blo || c0 > bhi {
                    empty = true;
                }
            } else {
                let (x0, x1) = ((blo - c0) / c1, (bhi - c0) / c1);
                rl = rl.max(x0.min(x1));
                rh = rh.min(x0.max(x1));
            }
        }
        if !empty && rl <= rh && rl.is_finite() && rh.is_finite() {
            lo = lo.min(rl);
            hi = hi.max(rh);
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// Sorted, merged union of intervals, in place.
fn merge(iv: &mut Vec<(f64, f64)>) {
    iv.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let mut n = 0;
    for k in 0..iv.len() {
        let (a, b) = iv[k];
        if n > 0 && a <= iv[n - 1].1 {
            iv[n - 1].1 = iv[n - 1].1.max(b);
        } else {
            iv[n] = (a, b);
            n += 1;
        }
    }
    iv.truncate(n);
}

/// `inside` minus `cut` (both sorted, disjoint), appended to `out`; pieces shorter than
/// `min` dropped.
fn subtract(inside: &[(f64, f64)], cut: &[(f64, f64)], min: f64, out: &mut Vec<(f64, f64)>) {
    let mut j = 0;
    for &(a, b) in inside {
        let mut s = a;
        while j < cut.len() && cut[j].1 <= s {
            j += 1;
        }
        let mut k = j;
        while k < cut.len() && cut[k].0 < b {
            if cut[k].0 > s && cut[k].0 - s > min {
                out.push((s, cut[k].0));
            }
            s = s.max(cut[k].1);
            if s >= b {
                break;
            }
            k += 1;
        }
        if b - s > min {
            out.push((s, b));
        }
    }
}

/// The intervals of the line `v` inside the loops (non-zero winding), into `out`
/// (cleared first); `x` is scratch.
fn inside(
    edges: &[Edge],
    active: &[usize],
    v: f64,
    x: &mut Vec<(f64, i32)>,
    out: &mut Vec<(f64, f64)>,
) {
    x.clear();
    out.clear();
    for &i in active {
        let e = &edges[i];
        let (a, b) = (e.a, e.b);
        // Half-open rule: an end exactly on the line counts as above it.
        if (a[1] <= v) != (b[1] <= v) {
            let t = (v - a[1]) / (b[1] - a[1]);
            let u = a[0] + t * (b[0] - a[0]);
            x.push((u, if b[1] > a[1] { 1 } else { -1 }));
        }
    }
    x.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let mut w = 0;
    let mut start = 0.0;
    for &(u, d) in x.iter() {
        // Walking along +u, an upward edge (counter-clockwise outer loop's right side)
        // closes: winding counts the edges to the right, so subtract.
        let before = w;
        w -= d;
        if before == 0 && w != 0 {
            start = u;
        } else if before != 0 && w == 0 && u > start {
            out.push((start, u));
        }
    }
}

/// One ray's run before ordering: `u` from `a` to `b` on ray `ray`.
#[derive(Debug, Clone, Copy)]
struct Span {
    a: f64,
    b: f64,
    ray: usize,
}

/// The raster runs of one slice, in zig-zag order, at layer `k`'s angle.
pub fn layer_runs(slice: &Slice, opts: &RasterOptions) -> Vec<Run> {
    let n = slice.normal;
    let (e1, e2) = plane_axes(n);
    let (s, c) = layer_angle(opts, slice.index).to_radians().sin_cos();
    let along = e1 * c + e2 * s;
    let across = n.cross(&along);
    let o = slice.origin;
    let mut edges = Vec::with_capacity(slice.loops.iter().map(|l| l.points.len()).sum());
    let mut uv: Vec<[f64; 2]> = Vec::new();
    for l in &slice.loops {
        let k = l.points.len();
        uv.clear();
        uv.extend(l.points.iter().map(|p| {
            let d = p - o;
            [d.dot(&along), d.dot(&across)]
        }));
        for i in 0..k {
            edges.push(Edge::new(uv[i], uv[(i + 1) % k]));
        }
    }
    if edges.is_empty() || opts.hatch.is_nan() || opts.hatch <= 0.0 {
        return Vec::new();
    }
    let r = opts.inset.max(0.0);
    let vmin = edges.iter().map(|e| e.a[1]).fold(f64::INFINITY, f64::min);
    let vmax = edges
        .iter()
        .map(|e| e.a[1])
        .fold(f64::NEG_INFINITY, f64::max);
    // Edges ordered by their lowest v (less the inset) for a sweep over the rays (ties in
    // the loops' order).
    let lo_of = |e: &Edge| e.a[1].min(e.b[1]) - r;
    let hi_of = |e: &Edge| e.a[1].max(e.b[1]) + r;
    // A stable sort: the loops run mostly monotone in v, runs it merges cheaply.
    let mut order: Vec<(f64, usize)> = edges.iter().map(lo_of).zip(0..).collect();
    order.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut active: Vec<usize> = Vec::new();
    let mut next = 0;
    let span = (vmax - r) - (vmin + r);
    if span.is_nan() || span <= 0.0 {
        return Vec::new();
    }
    let count = (span / opts.hatch).ceil().min(1e7) as usize;
    // Centre the rays in the inset's extent.
    let v0 = vmin + r + 0.5 * (span - (count as f64 - 1.0) * opts.hatch);
    // Every ray's runs, ray after ray; `first[j]..first[j + 1]` are ray j's.
    let mut spans: Vec<Span> = Vec::new();
    let mut first: Vec<usize> = Vec::with_capacity(count + 1);
    let min_run = 1e-9 * (1.0 + span);
    let mut xs = Vec::new();
    let mut cut = Vec::new();
    let mut ins = Vec::new();
    let mut pieces = Vec::new();
    for j in 0..count {
        let v = v0 + j as f64 * opts.hatch;
        while next < order.len() && order[next].0 <= v {
            active.push(order[next].1);
            next += 1;
        }
        active.retain(|&i| hi_of(&edges[i]) >= v);
        inside(&edges, &active, v, &mut xs, &mut ins);
        cut.clear();
        if r > 0.0 {
            cut.extend(active.iter().filter_map(|&i| capsule(&edges[i], v, r)));
            merge(&mut cut);
        }
        first.push(spans.len());
        pieces.clear();
        subtract(&ins, &cut, min_run, &mut pieces);
        spans.extend(pieces.iter().map(|&(a, b)| Span { a, b, ray: j }));
    }
    first.push(spans.len());
    // Zig-zag.
    let point = |u: f64, v: f64| o + along * u + across * v;
    let mut used = vec![false; spans.len()];
    let mut runs = Vec::with_capacity(spans.len());
    // The last run's end, along the rays.
    let mut pos: Option<f64> = None;
    // Spans before `free` are used: the first one left starts each zig-zag (the first
    // run left on the first ray that has one).
    let mut free = 0;
    loop {
        while free < spans.len() && used[free] {
            free += 1;
        }
        if free == spans.len() {
            break;
        }
        let mut i = free;
        loop {
            used[i] = true;
            let Span { a, b, ray: j } = spans[i];
            let v = v0 + j as f64 * opts.hatch;
            // Enter from the end nearer the last position (both ends are on the ray, as
            // far across from it: the nearer along the ray).
            let forward = pos.is_none_or(|pu| (a - pu).abs() <= (b - pu).abs());
            let (ua, ub) = if forward { (a, b) } else { (b, a) };
            runs.push(Run {
                from: point(ua, v),
                to: point(ub, v),
            });
            pos = Some(ub);
            // The next ray's unused run overlapping this one, nearest the end.
            if j + 1 >= count {
                break;
            }
            let best = (first[j + 1]..first[j + 2])
                .filter(|&k| !used[k] && spans[k].a < b && spans[k].b > a)
                .min_by(|&x, &y| {
                    let dx = (spans[x].a - ub).abs().min((spans[x].b - ub).abs());
                    let dy = (spans[y].a - ub).abs().min((spans[y].b - ub).abs());
                    dx.total_cmp(&dy)
                });
            match best {
                Some(k) => i = k,
                None => break,
            }
        }
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_capsule_meets_a_line_in_the_right_interval() {
        let e = Edge::new([0.0, 0.0], [10.0, 0.0]);
        assert_eq!(capsule(&e, 0.5, 1.0), {
            let s = (1.0f64 - 0.25).sqrt();
            Some((-s, 10.0 + s))
        });
        assert_eq!(capsule(&e, 1.5, 1.0), None);
        // A vertical edge: the line crosses the rectangle across.
        let e = Edge::new([3.0, -5.0], [3.0, 5.0]);
        assert_eq!(capsule(&e, 0.0, 0.5), Some((2.5, 3.5)));
        let (a, b) = capsule(&e, 5.3, 0.5).expect("meets");
        assert!(
            (a - 2.6).abs() < 1e-12 && (b - 3.4).abs() < 1e-12,
            "{a} {b}"
        );
        assert_eq!(capsule(&e, 5.6, 0.5), None);
    }

    #[test]
    fn subtracting_intervals() {
        let sub = |inside: &[(f64, f64)], cut: &[(f64, f64)]| {
            let mut out = vec![(-7.0, -6.0)];
            subtract(inside, cut, 0.0, &mut out);
            // Appended after what was there.
            assert_eq!(out.remove(0), (-7.0, -6.0));
            out
        };
        assert_eq!(
            sub(&[(0.0, 10.0)], &[(-1.0, 1.0), (4.0, 5.0), (9.0, 12.0)]),
            vec![(1.0, 4.0), (5.0, 9.0)]
        );
        assert_eq!(sub(&[(0.0, 10.0)], &[(-1.0, 11.0)]), vec![]);
        assert_eq!(
            sub(&[(0.0, 2.0), (3.0, 6.0)], &[(1.0, 4.0)]),
            vec![(0.0, 1.0), (4.0, 6.0)]
        );
    }
}
