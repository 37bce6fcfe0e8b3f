//! Slicing a triangle mesh into closed, oriented loops, layer by layer.
//!
//! ## Planes
//! - [`Planes::Parallel`]: planes normal to the build direction `d` at heights
//!   `lo + first + k·layer` (`lo` the lowest vertex along `d`; `first` defaults to half a
//!   layer) for every such height below the highest vertex.
//! - [`Planes::Fan`]: planes through an axis (point `c`, direction `a`), turned about it by
//!   `step` per layer. The fan's zero plane contains the axis and has normal `d` (the
//!   build direction made perpendicular to `a`); a plane turned by `φ` has the build
//!   direction `cos φ·d − sin φ·w` with `w = d × a`, the in-plane direction away from the
//!   axis. The part must lie on the `+w` side of the axis (a plane through the axis then
//!   cuts it on one side only); its vertices span angles `ψ = atan2((v−c)·d, (v−c)·w)`,
//!   and layer `k` is at `ψmin + (k + ½)·step` for every such angle below `ψmax`.
//!
//! ## Rule for vertices in a plane (symbolic perturbation)
//! A vertex whose height along the layer's build direction equals the plane's is treated
//! as **above** it. A triangle is cut when some vertex is below and some above, so a face
//! lying in a plane is never cut (the faces around it are, along its border), a plane
//! through a vertex cuts the edges to its lower neighbours exactly at the vertex, and
//! every cut triangle gives exactly one segment, from the crossing of its edge going
//! above → below to that of its edge going below → above (in the triangle's order). An
//! edge's crossing is computed from its lower vertex, identically for both its triangles,
//! and equals the upper vertex exactly when that vertex is in the plane.
//!
//! ## Loops
//! Segments are chained through the edges they cross (pairs of vertex indices: topology,
//! not coordinates), so a
//! closed manifold gives closed loops with no tolerance at all. For a closed mesh with
//! outward triangles, outer boundaries run counter-clockwise about the build direction
//! (right-hand rule) and holes clockwise; a closed mesh whose volume is negative (inside
//! out) is sliced as if turned right side out ([`Slicing::flipped`]). Repeated points
//! (crossings at a vertex) are merged; a loop that collapses to fewer than three points
//! (a plane touching a vertex or an edge from below) is dropped and counted
//! ([`Slicing::degenerate_loops`]). Each loop point `i` keeps the face holding the
//! segment from point `i` to point `i + 1`.
//!
//! ## Open meshes
//! Chains that do not close (holes, flipped or non-manifold faces) are stitched end to
//! start when the gap is within the tolerance ([`SliceOptions::stitch`]); each gap is
//! reported ([`Slice::gaps`]) and the stitching segment keeps the face before it. What
//! still does not close is reported as an open chain with its layer and end points
//! ([`Slice::open`]), never as a loop.
//!
//! ## Speed
//! Parallel planes: each triangle's range of layers is found once (its lowest and
//! highest vertex against the plane heights); the triangles are ordered by their first
//! layer, and a sweep keeps those that cut the current layer in one compact list, each
//! copied with its corners when it enters (no random access into the mesh per layer).
//! Segments are chained through a small per-layer hash map of edges that stays in
//! cache. Blocks of layers of about equal work run on `threads` threads,
//! each sweep starting at its block; the result does not depend on the thread count.
//! Fans compute every vertex's height per layer and test every triangle.

use lampost_mesh::{Mesh, P3};

use crate::error::PlanError;

/// The slicing planes.
#[derive(Debug, Clone, PartialEq)]
pub enum Planes {
    /// Planes normal to `dir`, `layer` apart, the first `first` above the lowest vertex
    /// (default: half a layer).
    Parallel {
        /// Build direction (any length but zero).
        dir: P3,
        /// Layer height (> 0).
        layer: f64,
        /// Height of the first plane above the lowest vertex.
        first: Option<f64>,
    },
    /// Planes through the axis `point` + t·`axis`, `step_deg` degrees apart (see the
    /// module documentation).
    Fan {
        /// A point of the axis.
        point: P3,
        /// The axis direction.
        axis: P3,
        /// The build direction at angle 0 (its component along the axis is ignored).
        dir: P3,
        /// Angle between layers, degrees (> 0).
        step_deg: f64,
    },
}

/// Slicing options.
#[derive(Debug, Clone, PartialEq)]
pub struct SliceOptions {
    /// The planes.
    pub planes: Planes,
    /// Largest gap stitched between open chains (absolute, mesh units); `None`: 1e-6 of
    /// the bounding box's diagonal.
    pub stitch: Option<f64>,
    /// Threads (1: this thread only).
    pub threads: usize,
}

impl SliceOptions {
    /// Planes normal to `dir`, `layer` apart, the first half a layer above the lowest
    /// vertex; the default stitching tolerance; one thread.
    pub fn parallel(dir: P3, layer: f64) -> SliceOptions {
        SliceOptions {
            planes: Planes::Parallel {
                dir,
                layer,
                first: None,
            },
            stitch: None,
            threads: 1,
        }
    }
}

/// A closed loop of a slice.
#[derive(Debug, Clone, PartialEq)]
pub struct Loop {
    /// Points in order (the last joins the first).
    pub points: Vec<P3>,
    /// `faces[i]`: the triangle holding the segment from point `i` to point `i + 1`.
    pub faces: Vec<u32>,
    /// Signed area about the layer's build direction: positive counter-clockwise (outer
    /// boundaries), negative clockwise (holes).
    pub area: f64,
    /// Length, closing segment included.
    pub length: f64,
    /// Gaps stitched to close it (0 on a closed manifold).
    pub stitched: usize,
}

/// A chain that could not be closed.
#[derive(Debug, Clone, PartialEq)]
pub struct OpenChain {
    /// Points from start to end.
    pub points: Vec<P3>,
    /// `faces[i]`: the triangle holding the segment from point `i` to point `i + 1`.
    pub faces: Vec<u32>,
}

impl OpenChain {
    /// First point.
    pub fn start(&self) -> P3 {
        self.points.first().copied().unwrap_or_else(P3::zeros)
    }
    /// Last point.
    pub fn end(&self) -> P3 {
        self.points.last().copied().unwrap_or_else(P3::zeros)
    }
}

/// A gap closed by stitching.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gap {
    /// End of one chain.
    pub from: P3,
    /// Start of the next (or its own start).
    pub to: P3,
    /// Its length.
    pub length: f64,
}

/// One layer.
#[derive(Debug, Clone, PartialEq)]
pub struct Slice {
    /// Layer number (0 first).
    pub index: usize,
    /// The layer's build direction (unit; the plane's normal).
    pub normal: P3,
    /// A point of the plane.
    pub origin: P3,
    /// Parallel planes: the plane's height along the build direction (`normal · x`);
    /// fan: its angle in degrees.
    pub height: f64,
    /// Closed loops.
    pub loops: Vec<Loop>,
    /// Chains that could not be closed.
    pub open: Vec<OpenChain>,
    /// Gaps stitched.
    pub gaps: Vec<Gap>,
    /// Triangles cut (segments).
    pub segments: usize,
}

/// All layers.
#[derive(Debug, Clone, PartialEq)]
pub struct Slicing {
    /// Layers in order.
    pub slices: Vec<Slice>,
    /// Segments over all layers.
    pub segments: usize,
    /// The mesh was closed and inside out (negative volume): loops were oriented as if
    /// its triangles were reversed.
    pub flipped: bool,
    /// Loops dropped because they collapsed to fewer than three distinct points.
    pub degenerate_loops: usize,
    /// The stitching tolerance used.
    pub stitch: f64,
}

/// Largest coordinate magnitude sliced (a million kilometres in millimetres): beyond it,
/// squared lengths could overflow `f64`.
pub const MAX_COORD: f64 = 1e12;

/// Most layers a slicing may have.
pub const MAX_LAYERS: usize = 1_000_000;

fn degenerate(t: &[u32; 3]) -> bool {
    t[0] == t[1] || t[1] == t[2] || t[0] == t[2]
}

/// An undirected edge's key: its two vertex indices, lower first.
#[inline]
fn edge_key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

/// One cut triangle: the edges its segment starts and ends on, the triangle, and the
/// two crossing points.
#[derive(Clone, Copy)]
struct Seg {
    from: u64,
    to: u64,
    face: u32,
    p: P3,
    q: P3,
}

/// A small open-addressing map from edge id to segment, sized per layer (it stays in
/// the first-level cache, where a table over all edges would miss on every segment).
#[derive(Default)]
struct EdgeMap {
    keys: Vec<u64>,
    vals: Vec<u32>,
    mask: usize,
    /// Second segments on an edge already taken (non-manifold edges).
    extra: Vec<(u64, u32)>,
}

const EMPTY: u64 = u64::MAX;

impl EdgeMap {
    fn reset(&mut self, n: usize) {
        let size = (2 * n).next_power_of_two().max(16);
        if self.keys.len() < size {
            self.keys.resize(size, EMPTY);
            self.vals.resize(size, 0);
        }
        self.keys[..size].fill(EMPTY);
        self.mask = size - 1;
        self.extra.clear();
    }

    #[inline]
    fn slot(&self, e: u64) -> usize {
        let h = e.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        (h >> 32) as usize & self.mask
    }

    #[inline]
    fn insert(&mut self, e: u64, s: u32) {
        let mut i = self.slot(e);
        loop {
            let k = self.keys[i];
            if k == EMPTY {
                self.keys[i] = e;
                self.vals[i] = s;
                return;
            }
            if k == e {
                self.extra.push((e, s));
                return;
            }
            i = (i + 1) & self.mask;
        }
    }

    /// The segment on `e` that `ok` accepts.
    #[inline]
    fn find(&self, e: u64, ok: impl Fn(u32) -> bool) -> Option<u32> {
        let mut i = self.slot(e);
        loop {
            let k = self.keys[i];
            if k == EMPTY {
                return None;
            }
            if k == e {
                let s = self.vals[i];
                if ok(s) {
                    return Some(s);
                }
                return self
                    .extra
                    .iter()
                    .find(|&&(x, s)| x == e && ok(s))
                    .map(|&(_, s)| s);
            }
            i = (i + 1) & self.mask;
        }
    }
}

/// Per-thread tables, reused across layers.
#[derive(Default)]
struct Scratch {
    starts: EdgeMap,
    ends: EdgeMap,
    segs: Vec<Seg>,
    used: Vec<bool>,
    /// Per-vertex heights (fan layers).
    heights: Vec<f64>,
}

struct Ctx<'a> {
    mesh: &'a Mesh,
    flip: bool,
    stitch: f64,
}

/// A layer's raw result before it is numbered.
struct LayerOut {
    loops: Vec<Loop>,
    open: Vec<OpenChain>,
    gaps: Vec<Gap>,
    segments: usize,
    degenerate: usize,
}

/// The crossing of the edge from `pa` (height `ha`) to `pb` (height `hb`) with the plane
/// at height `z`: computed from the lower end, so both triangles of an edge get the same
/// point; the upper end itself when it is in the plane.
#[inline]
fn cross(pa: &P3, ha: f64, pb: &P3, hb: f64, z: f64) -> P3 {
    let (pl, hl, ph, hh) = if ha < hb {
        (pa, ha, pb, hb)
    } else {
        (pb, hb, pa, ha)
    };
    if hh == z {
        return *ph;
    }
    let t = (z - hl) / (hh - hl);
    pl + (ph - pl) * t
}

/// The segment of a triangle with corners `p` at heights `h` (some below `z`, some at or
/// above it), vertex indices `v`; `None` when the plane does not cut it.
#[inline]
fn cut_triangle(
    p: &[P3; 3],
    h: [f64; 3],
    v: &[u32; 3],
    face: u32,
    z: f64,
    flip: bool,
) -> Option<Seg> {
    let above = [h[0] >= z, h[1] >= z, h[2] >= z];
    if above[0] == above[1] && above[1] == above[2] {
        return None;
    }
    let (mut up, mut down) = (0, 0);
    for k in 0..3 {
        let kn = if k == 2 { 0 } else { k + 1 };
        if !above[k] && above[kn] {
            up = k;
        } else if above[k] && !above[kn] {
            down = k;
        }
    }
    let (a, b) = if flip { (up, down) } else { (down, up) };
    let (an, bn) = ((a + 1) % 3, (b + 1) % 3);
    Some(Seg {
        from: edge_key(v[a], v[an]),
        to: edge_key(v[b], v[bn]),
        face,
        p: cross(&p[a], h[a], &p[an], h[an], z),
        q: cross(&p[b], h[b], &p[bn], h[bn], z),
    })
}

/// Chain the layer's segments (`sc.segs`) into loops and open chains, and stitch.
fn assemble(ctx: &Ctx, sc: &mut Scratch) -> LayerOut {
    let n = sc.segs.len();
    sc.starts.reset(n);
    for (i, s) in sc.segs.iter().enumerate() {
        sc.starts.insert(s.from, i as u32);
    }
    // The map of segment ends is needed only to walk an open chain back to its start.
    let mut ends_built = false;
    sc.used.clear();
    sc.used.resize(n, false);
    let mut out = LayerOut {
        loops: Vec::new(),
        open: Vec::new(),
        gaps: Vec::new(),
        segments: n,
        degenerate: 0,
    };
    let mut chain: Vec<u32> = Vec::new();
    let mut back: Vec<u32> = Vec::new();
    let mut chains: Vec<OpenChain> = Vec::new();
    for first in 0..n {
        if sc.used[first] {
            continue;
        }
        let first32 = first as u32;
        chain.clear();
        chain.push(first32);
        sc.used[first] = true;
        let mut cur = first;
        let mut closed = false;
        loop {
            let e = sc.segs[cur].to;
            let used = &sc.used;
            match sc.starts.find(e, |s| s == first32 || !used[s as usize]) {
                Some(s) if s == first32 => {
                    closed = true;
                    break;
                }
                Some(s) => {
                    sc.used[s as usize] = true;
                    chain.push(s);
                    cur = s as usize;
                }
                None => break,
            }
        }
        if closed {
            let mut points = Vec::with_capacity(chain.len());
            let mut faces = Vec::with_capacity(chain.len());
            for &s in &chain {
                let seg = &sc.segs[s as usize];
                points.push(seg.p);
                faces.push(seg.face);
            }
            match make_loop(points, faces, 0) {
                Some(l) => out.loops.push(l),
                None => out.degenerate += 1,
            }
            continue;
        }
        // Open: walk back from the first segment to the chain's start.
        if !ends_built {
            sc.ends.reset(n);
            for (i, s) in sc.segs.iter().enumerate() {
                sc.ends.insert(s.to, i as u32);
            }
            ends_built = true;
        }
        back.clear();
        let mut cur = first;
        loop {
            let e = sc.segs[cur].from;
            let used = &sc.used;
            match sc.ends.find(e, |s| !used[s as usize]) {
                Some(s) => {
                    sc.used[s as usize] = true;
                    back.push(s);
                    cur = s as usize;
                }
                None => break,
            }
        }
        let whole = back.iter().rev().chain(chain.iter());
        let mut points = Vec::with_capacity(back.len() + chain.len() + 1);
        let mut faces = Vec::with_capacity(back.len() + chain.len());
        let mut last = None;
        for &s in whole {
            let seg = &sc.segs[s as usize];
            points.push(seg.p);
            faces.push(seg.face);
            last = Some(seg.q);
        }
        if let Some(q) = last {
            points.push(q);
        }
        chains.push(OpenChain { points, faces });
    }
    if !chains.is_empty() {
        stitch(ctx, chains, &mut out);
    }
    out
}

/// Join open chains end to start where the gap is within the tolerance (the smallest
/// gap first; a chain's own start closes it); what remains stays open.
/// Join open chains end to start while a gap is within the tolerance, the shortest gap
/// first (of equals, the first chain's end, then the first start, in the chains' order as
/// they stand), a chain's end to its own start closing a loop. Each chain keeps the
/// nearest start to its end, found again only where that start was used up or the end
/// moved: quadratic where comparing every pair at every step was cubic, and the same
/// joins in the same order ([`stitch_reference`], property-tested).
fn stitch(ctx: &Ctx, mut chains: Vec<OpenChain>, out: &mut LayerOut) {
    let mut stitched_in: Vec<usize> = vec![0; chains.len()];
    let nearest = |chains: &[OpenChain], i: usize| -> Option<(f64, usize)> {
        let e = chains[i].end();
        let mut best: Option<(f64, usize)> = None;
        for (j, b) in chains.iter().enumerate() {
            let d = (b.start() - e).norm();
            if d <= ctx.stitch && best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, j));
            }
        }
        best
    };
    let mut best: Vec<Option<(f64, usize)>> =
        (0..chains.len()).map(|i| nearest(&chains, i)).collect();
    loop {
        let mut pick: Option<(f64, usize, usize)> = None;
        for (i, b) in best.iter().enumerate() {
            if let Some((d, j)) = *b {
                if pick.is_none_or(|(pd, _, _)| d < pd) {
                    pick = Some((d, i, j));
                }
            }
        }
        let Some((d, i, j)) = pick else {
            break;
        };
        // The chain removed (`r`), and the last, which takes its place.
        let (r, last) = (j, chains.len() - 1);
        join(&mut chains, &mut stitched_in, (d, i, j), out);
        best.swap_remove(r);
        let moved = (r != last).then_some(r);
        for k in 0..best.len() {
            let Some((dk, t)) = best[k] else {
                continue;
            };
            best[k] = if t == r {
                // Its start used up (joined, or closed into a loop).
                nearest(&chains, k)
            } else if t == last {
                // The same start, now at `r`: still the nearest, and the only one as near
                // (it was the last of the chains).
                Some((dk, r))
            } else if moved
                .is_some_and(|m| m < t && (chains[m].start() - chains[k].end()).norm() == dk)
            {
                // The last chain's start, as near, now before it.
                Some((dk, r))
            } else {
                Some((dk, t))
            };
        }
        if i != j {
            // Chain i's end is now the joined chain's: where it stands now.
            let a = if i == last { r } else { i };
            best[a] = nearest(&chains, a);
        }
    }
    out.open = chains;
}

/// Stitch chain `i`'s end to chain `j`'s start (`i == j`: close chain `i` into a loop),
/// the gap `d` long; the chain removed is swap-removed (from `chains` and `stitched_in`).
fn join(
    chains: &mut Vec<OpenChain>,
    stitched_in: &mut Vec<usize>,
    (d, i, j): (f64, usize, usize),
    out: &mut LayerOut,
) {
    out.gaps.push(Gap {
        from: chains[i].end(),
        to: chains[j].start(),
        length: d,
    });
    if i == j {
        let c = chains.swap_remove(i);
        let k = stitched_in.swap_remove(i) + 1;
        let mut points = c.points;
        let mut faces = c.faces;
        if points.len() > 1 && points.first() == points.last() {
            points.pop();
        } else if let Some(&f) = faces.last() {
            faces.push(f);
        }
        match make_loop(points, faces, k) {
            Some(l) => out.loops.push(l),
            None => out.degenerate += 1,
        }
    } else {
        let b = chains[j].clone();
        let kb = stitched_in[j];
        let a = &mut chains[i];
        let gap_face = a.faces.last().copied().unwrap_or(0);
        let skip = usize::from(a.end() == b.start());
        if skip == 0 {
            a.faces.push(gap_face);
        }
        a.points.extend_from_slice(&b.points[skip..]);
        a.faces.extend_from_slice(&b.faces);
        stitched_in[i] += kb + 1;
        chains.swap_remove(j);
        stitched_in.swap_remove(j);
    }
}

/// [`stitch`] as it was first written: every pair of chains compared at every step
/// (cubic in the chains: 20 s on a 100 KB triangle soup). The reference the fast one is
/// tested against.
#[cfg(test)]
fn stitch_reference(ctx: &Ctx, mut chains: Vec<OpenChain>, out: &mut LayerOut) {
    let mut stitched_in: Vec<usize> = vec![0; chains.len()];
    loop {
        let mut best: Option<(f64, usize, usize)> = None;
        for (i, a) in chains.iter().enumerate() {
            for (j, b) in chains.iter().enumerate() {
                let d = (b.start() - a.end()).norm();
                if d <= ctx.stitch && best.is_none_or(|(bd, _, _)| d < bd) {
                    best = Some((d, i, j));
                }
            }
        }
        let Some((d, i, j)) = best else {
            break;
        };
        join(&mut chains, &mut stitched_in, (d, i, j), out);
    }
    out.open = chains;
}

/// Merge repeated points (in place), then measure. `None` when fewer than three points
/// remain.
fn make_loop(mut points: Vec<P3>, mut faces: Vec<u32>, stitched: usize) -> Option<Loop> {
    let n = points.len();
    // Point i repeats point i + 1: the segment between them is empty, the next one
    // (face i + 1) starts at the same place, so entry i goes.
    let mut w = 0;
    for i in 0..n {
        if points[i] == points[(i + 1) % n] {
            continue;
        }
        points[w] = points[i];
        faces[w] = faces[i];
        w += 1;
    }
    if w < 3 {
        return None;
    }
    points.truncate(w);
    faces.truncate(w);
    Some(Loop {
        area: 0.0,
        length: 0.0,
        points,
        faces,
        stitched,
    })
}

/// Signed area about `n` and length of a closed polygon.
fn measure(points: &[P3], n: &P3) -> (f64, f64) {
    let Some(&o) = points.first() else {
        return (0.0, 0.0);
    };
    let mut cross = P3::zeros();
    let mut len = 0.0;
    for (i, p) in points.iter().enumerate() {
        let q = points[(i + 1) % points.len()];
        cross += (p - o).cross(&(q - o));
        len += (q - p).norm();
    }
    (0.5 * cross.dot(n), len)
}

fn unit(v: P3, what: &'static str) -> Result<P3, PlanError> {
    let l = v.norm();
    if !(l.is_finite() && l > 0.0) {
        return Err(PlanError::Direction {
            what,
            v: [v.x, v.y, v.z],
        });
    }
    Ok(v / l)
}

/// Slice a mesh (see the module documentation for the rules).
pub fn slice(mesh: &Mesh, opts: &SliceOptions) -> Result<Slicing, PlanError> {
    if mesh.triangles.is_empty() {
        return Err(PlanError::Empty);
    }
    for (i, v) in mesh.vertices.iter().enumerate() {
        if !v.iter().all(|x| x.is_finite()) {
            return Err(PlanError::Mesh(format!("vertex {i} is not finite")));
        }
        if v.iter().any(|x| x.abs() > MAX_COORD) {
            return Err(PlanError::Mesh(format!(
                "vertex {i} ({}, {}, {}) is beyond ±{MAX_COORD:e} (lengths and areas would overflow)",
                v.x, v.y, v.z
            )));
        }
    }
    for (i, t) in mesh.triangles.iter().enumerate() {
        if t.iter().any(|&k| k as usize >= mesh.vertices.len()) {
            return Err(PlanError::Mesh(format!(
                "triangle {i} names a vertex beyond the {} there are",
                mesh.vertices.len()
            )));
        }
    }
    let Some((lo, hi)) = lampost_mesh::props::bounds(mesh) else {
        return Err(PlanError::Empty);
    };
    let diag = (hi - lo).norm();
    let stitch = match opts.stitch {
        Some(s) if s.is_finite() && s >= 0.0 => s,
        Some(s) => {
            return Err(PlanError::Layer {
                what: "stitching tolerance",
                value: s,
                why: "not a finite number ≥ 0".into(),
            })
        }
        None => 1e-6 * diag,
    };
    // Inside out: a closed mesh with a negative volume (the report only when it is).
    let flip =
        lampost_mesh::props::volume(mesh) < 0.0 && lampost_mesh::manifold_report(mesh).closed();
    let ctx = Ctx { mesh, flip, stitch };
    let threads = opts.threads.max(1);
    let (slices, degenerate) = match &opts.planes {
        Planes::Parallel { dir, layer, first } => parallel(&ctx, *dir, *layer, *first, threads)?,
        Planes::Fan {
            point,
            axis,
            dir,
            step_deg,
        } => fan(&ctx, *point, *axis, *dir, *step_deg, threads, diag)?,
    };
    let segments = slices.iter().map(|s| s.segments).sum();
    Ok(Slicing {
        slices,
        segments,
        flipped: flip,
        degenerate_loops: degenerate,
        stitch,
    })
}

fn layer_count(start: f64, step: f64, end: f64, what: &'static str) -> Result<usize, PlanError> {
    if start >= end {
        return Ok(0);
    }
    let n = ((end - start) / step).ceil();
    if !(n.is_finite() && n <= MAX_LAYERS as f64) {
        return Err(PlanError::Layer {
            what,
            value: step,
            why: format!("too small: it would make more than {MAX_LAYERS} layers"),
        });
    }
    // `start + k·step < end` decides, exactly as the planes are placed.
    let mut n = n as usize;
    while n > 0 && start + (n - 1) as f64 * step >= end {
        n -= 1;
    }
    while start + n as f64 * step < end {
        n += 1;
    }
    Ok(n)
}

/// Split `0..n` into `parts` contiguous ranges of about equal `work`.
fn blocks(work: &[usize], parts: usize) -> Vec<(usize, usize)> {
    let total: usize = work.iter().sum::<usize>() + work.len();
    let parts = parts.min(work.len()).max(1);
    let mut out = Vec::with_capacity(parts);
    let mut start = 0;
    let mut acc = 0;
    for (i, w) in work.iter().enumerate() {
        acc += w + 1;
        if acc * parts >= total * (out.len() + 1) && out.len() + 1 < parts {
            out.push((start, i + 1));
            start = i + 1;
        }
    }
    out.push((start, work.len()));
    out
}

fn finish(out: LayerOut, index: usize, normal: P3, origin: P3, height: f64) -> (Slice, usize) {
    let mut loops = out.loops;
    for l in &mut loops {
        let (a, len) = measure(&l.points, &normal);
        l.area = a;
        l.length = len;
    }
    (
        Slice {
            index,
            normal,
            origin,
            height,
            loops,
            open: out.open,
            gaps: out.gaps,
            segments: out.segments,
        },
        out.degenerate,
    )
}

/// Run `f` over contiguous blocks of layers of about equal `work`, one thread each,
/// and concatenate their slices in order.
fn run_blocks<F>(n: usize, work: &[usize], threads: usize, f: F) -> (Vec<Slice>, usize)
where
    F: Fn(usize, usize, &mut Scratch, &mut Vec<Slice>) -> usize + Sync,
{
    let parts = blocks(work, threads);
    let run = |(a, b): (usize, usize)| {
        let mut sc = Scratch::default();
        let mut v = Vec::with_capacity(b - a);
        let deg = f(a, b, &mut sc, &mut v);
        (v, deg)
    };
    let results: Vec<(Vec<Slice>, usize)> = if parts.len() <= 1 || n == 0 {
        parts.into_iter().map(run).collect()
    } else {
        std::thread::scope(|s| {
            let handles: Vec<_> = parts
                .iter()
                .map(|&p| {
                    let run = &run;
                    s.spawn(move || run(p))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        })
    };
    let mut slices = Vec::with_capacity(n);
    let mut deg = 0;
    for (v, d) in results {
        slices.extend(v);
        deg += d;
    }
    (slices, deg)
}

/// A triangle as the sweep keeps it: corners, vertex indices, and its layers `k0..k1`.
#[derive(Clone, Copy)]
struct Rec {
    p: [P3; 3],
    v: [u32; 3],
    face: u32,
    k1: u32,
}

fn parallel(
    ctx: &Ctx,
    dir: P3,
    layer: f64,
    first: Option<f64>,
    threads: usize,
) -> Result<(Vec<Slice>, usize), PlanError> {
    let d = unit(dir, "build direction")?;
    if !(layer.is_finite() && layer > 0.0) {
        return Err(PlanError::Layer {
            what: "layer height",
            value: layer,
            why: "not a positive number".into(),
        });
    }
    let mesh = ctx.mesh;
    let h: Vec<f64> = mesh.vertices.iter().map(|v| d.dot(v)).collect();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for t in &mesh.triangles {
        for &k in t {
            lo = lo.min(h[k as usize]);
            hi = hi.max(h[k as usize]);
        }
    }
    let extent = hi - lo;
    if layer > extent {
        return Err(PlanError::LayerTooLarge { layer, extent });
    }
    let first = first.unwrap_or(0.5 * layer);
    if !(first.is_finite() && first >= 0.0) {
        return Err(PlanError::Layer {
            what: "first layer's height",
            value: first,
            why: "not a finite number ≥ 0".into(),
        });
    }
    let z0 = lo + first;
    let n = layer_count(z0, layer, hi, "layer height")?;
    let zs: Vec<f64> = (0..n).map(|k| z0 + k as f64 * layer).collect();
    // Each triangle's layers: z in (min, max].
    let first_above = |x: f64| -> usize {
        // First k with zs[k] > x.
        let est = ((x - z0) / layer).floor() + 1.0;
        let mut k = if est.is_finite() {
            est.clamp(0.0, n as f64) as usize
        } else {
            0
        };
        while k > 0 && zs[k - 1] > x {
            k -= 1;
        }
        while k < n && zs[k] <= x {
            k += 1;
        }
        k
    };
    // Triangles sorted by their first layer (counting sort, stable in triangle order),
    // and the segments per layer (for balancing the threads' blocks).
    let mut ranges: Vec<(u32, u32)> = Vec::with_capacity(mesh.triangles.len());
    let mut count = vec![0isize; n + 1];
    let mut starts = vec![0usize; n + 1];
    for t in &mesh.triangles {
        let a = h[t[0] as usize];
        let b = h[t[1] as usize];
        let c = h[t[2] as usize];
        let (mn, mx) = (a.min(b).min(c), a.max(b).max(c));
        let (k0, k1) = (first_above(mn), first_above(mx));
        if k1 > k0 && !degenerate(t) {
            count[k0] += 1;
            count[k1] -= 1;
            starts[k0 + 1] += 1;
            ranges.push((k0 as u32, k1 as u32));
        } else {
            ranges.push((0, 0));
        }
    }
    let mut per = vec![0usize; n];
    let mut run = 0isize;
    for k in 0..n {
        run += count[k];
        per[k] = run.unsigned_abs();
        starts[k + 1] += starts[k];
    }
    // Triangle ids in order of first layer (counting sort, stable in triangle order).
    let mut fill = starts.clone();
    let mut order = vec![0u32; starts[n]];
    for (t, &(k0, k1)) in ranges.iter().enumerate() {
        if k1 > k0 {
            order[fill[k0 as usize]] = t as u32;
            fill[k0 as usize] += 1;
        }
    }
    drop(fill);
    let rec = |t: u32| {
        let tri = &mesh.triangles[t as usize];
        Rec {
            p: tri.map(|i| mesh.vertices[i as usize]),
            v: *tri,
            face: t,
            k1: ranges[t as usize].1,
        }
    };
    let flip = ctx.flip;
    let out = run_blocks(n, &per, threads, |ka, kb, sc, out| {
        // The sweep: the triangles cutting layer k, in first-layer order (the same
        // whatever the block's start).
        let mut active: Vec<Rec> = order[..starts[ka]]
            .iter()
            .filter(|&&t| ranges[t as usize].1 as usize > ka)
            .map(|&t| rec(t))
            .collect();
        let mut deg = 0;
        for (k, &z) in zs.iter().enumerate().take(kb).skip(ka) {
            active.retain(|r| r.k1 as usize > k);
            active.extend(order[starts[k]..starts[k + 1]].iter().map(|&t| rec(t)));
            sc.segs.clear();
            for r in &active {
                let hh = [d.dot(&r.p[0]), d.dot(&r.p[1]), d.dot(&r.p[2])];
                if let Some(seg) = cut_triangle(&r.p, hh, &r.v, r.face, z, flip) {
                    sc.segs.push(seg);
                }
            }
            let o = assemble(ctx, sc);
            let (slice, dg) = finish(o, k, d, d * z, z);
            deg += dg;
            out.push(slice);
        }
        deg
    });
    Ok(out)
}

#[allow(clippy::too_many_arguments)]
fn fan(
    ctx: &Ctx,
    c: P3,
    axis: P3,
    dir: P3,
    step_deg: f64,
    threads: usize,
    diag: f64,
) -> Result<(Vec<Slice>, usize), PlanError> {
    if !c.iter().all(|x| x.is_finite()) {
        return Err(PlanError::Direction {
            what: "fan axis point",
            v: [c.x, c.y, c.z],
        });
    }
    let a = unit(axis, "fan axis")?;
    let d = unit(dir, "build direction")?;
    let dp = d - a * d.dot(&a);
    if dp.norm() < 1e-9 {
        return Err(PlanError::Fan(
            "the build direction is parallel to the fan axis".into(),
        ));
    }
    let d = dp.normalize();
    let w = d.cross(&a);
    if !(step_deg.is_finite() && step_deg > 0.0) {
        return Err(PlanError::Layer {
            what: "fan step",
            value: step_deg,
            why: "not a positive number of degrees".into(),
        });
    }
    let step = step_deg.to_radians();
    let mesh = ctx.mesh;
    let side = 1e-9 * diag.max(f64::MIN_POSITIVE);
    let (mut pmin, mut pmax) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut used = vec![false; mesh.vertices.len()];
    for t in &mesh.triangles {
        for &k in t {
            used[k as usize] = true;
        }
    }
    for (i, v) in mesh.vertices.iter().enumerate() {
        if !used[i] {
            continue;
        }
        let r = v - c;
        let (xd, xw) = (r.dot(&d), r.dot(&w));
        if xw < -side {
            return Err(PlanError::Fan(format!(
                "vertex {i} ({}, {}, {}) lies behind the axis (the part must lie on the side d × axis = ({:.6}, {:.6}, {:.6}) of it)",
                v.x, v.y, v.z, w.x, w.y, w.z
            )));
        }
        if xd.hypot(xw) <= side {
            continue;
        }
        let psi = xd.atan2(xw.max(0.0));
        pmin = pmin.min(psi);
        pmax = pmax.max(psi);
    }
    if pmax.partial_cmp(&pmin) != Some(std::cmp::Ordering::Greater) {
        return Err(PlanError::Fan(
            "the part has no extent about the axis".into(),
        ));
    }
    if step > pmax - pmin {
        return Err(PlanError::LayerTooLarge {
            layer: step_deg,
            extent: (pmax - pmin).to_degrees(),
        });
    }
    let p0 = pmin + 0.5 * step;
    let n = layer_count(p0, step, pmax, "fan step")?;
    let work = vec![mesh.triangles.len(); n];
    let flip = ctx.flip;
    let out = run_blocks(n, &work, threads, |ka, kb, sc, out| {
        let mut deg = 0;
        for k in ka..kb {
            let phi = p0 + k as f64 * step;
            let b = d * phi.cos() - w * phi.sin();
            let h = &mut sc.heights;
            h.clear();
            h.extend(mesh.vertices.iter().map(|v| b.dot(&(v - c))));
            sc.segs.clear();
            for (t, tri) in mesh.triangles.iter().enumerate() {
                if degenerate(tri) {
                    continue;
                }
                let p = tri.map(|i| mesh.vertices[i as usize]);
                let hh = tri.map(|i| sc.heights[i as usize]);
                if let Some(seg) = cut_triangle(&p, hh, tri, t as u32, 0.0, flip) {
                    sc.segs.push(seg);
                }
            }
            let o = assemble(ctx, sc);
            let (slice, dg) = finish(o, k, b, c, phi.to_degrees());
            deg += dg;
            out.push(slice);
        }
        deg
    });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn layer() -> LayerOut {
        LayerOut {
            loops: Vec::new(),
            open: Vec::new(),
            gaps: Vec::new(),
            segments: 0,
            degenerate: 0,
        }
    }

    /// Chains from grid points (many gaps of equal length, many ends on starts), each
    /// 1 to 4 points long.
    fn chains(raw: &[(Vec<(i8, i8)>, u32)]) -> Vec<OpenChain> {
        raw.iter()
            .map(|(pts, f)| OpenChain {
                points: pts
                    .iter()
                    .map(|&(x, y)| P3::new(f64::from(x), f64::from(y), 0.0))
                    .collect(),
                faces: (0..pts.len().saturating_sub(1) as u32)
                    .map(|k| f + k)
                    .collect(),
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]
        /// The stitch that keeps each chain's nearest start makes the joins the stitch
        /// comparing every pair at every step makes: the same gaps in the same order, the
        /// same loops and open chains.
        #[test]
        fn stitching_agrees_with_the_reference(
            raw in proptest::collection::vec(
                (proptest::collection::vec((-3i8..4, -3i8..4), 1..5), 0u32..1000),
                0..40,
            ),
            tol in prop_oneof![Just(0.0), Just(1.0), Just(1.5), Just(2.0), Just(10.0)],
        ) {
            let mesh = Mesh::default();
            let ctx = Ctx { mesh: &mesh, flip: false, stitch: tol };
            let (mut fast, mut slow) = (layer(), layer());
            stitch(&ctx, chains(&raw), &mut fast);
            stitch_reference(&ctx, chains(&raw), &mut slow);
            prop_assert_eq!(&fast.gaps, &slow.gaps);
            prop_assert_eq!(&fast.loops, &slow.loops);
            prop_assert_eq!(&fast.open, &slow.open);
            prop_assert_eq!(fast.degenerate, slow.degenerate);
        }
    }
}
