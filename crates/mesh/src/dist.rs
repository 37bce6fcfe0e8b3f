//! [`DistIndex`]: closest points and signed distances to a triangle mesh, in `f64`, for
//! many points at once (the deviations of a whole measurement).
//!
//! A bounding-volume hierarchy of the triangles, four children a node, up to 4 triangles
//! a leaf, built in one pass over the triangles sorted by the Morton code of their
//! centroids (each node a run of that order, cut where the codes' highest bit changes;
//! boxes bottom-up). A search runs down from the root, nearer children first, pruned by
//! the best squared distance found; or, for points taken in a spatial order
//! ([`DistIndex::answer_run`]), starts at the leaf of the point before's closest point
//! and climbs to the root, searching at each level the other children nearer than the
//! best. The closest point on a triangle by its Voronoi regions (Ericson, *Real-Time
//! Collision Detection*, 5.1.5), which also names the feature it lies on. The sign is
//! that of the feature's angle-weighted pseudo-normal (Bærentzen and Aanæs, 2005): the
//! face's normal, the sum of an edge's two face normals, or a vertex's face normals
//! weighted by their angles there (worked out when asked, from the triangles around the
//! vertex); negative inside. Degenerate (zero-area) triangles are left out: each of
//! their points lies on a neighbour's edge. The scalar reference, every triangle tried,
//! is in the tests, which hold the tree's answers to it bit for bit.

use crate::Mesh;

type V = [f64; 3];

fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V, b: V) -> V {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn add(a: V, b: V) -> V {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: V, s: f64) -> V {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// Where on a triangle its closest point lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Feature {
    Vertex(u8),
    /// The edge from corner k to corner (k + 1) mod 3.
    Edge(u8),
    Face,
}

/// The closest point of triangle (a, b, c) to p, and the feature it lies on.
#[inline(always)]
fn closest_on_triangle(p: V, a: V, b: V, c: V) -> (V, Feature) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Vertex(0));
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (add(a, scale(ab, v)), Feature::Edge(0));
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (add(a, scale(ac, w)), Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add(b, scale(sub(c, b), w)), Feature::Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (add(a, add(scale(ab, v), scale(ac, w))), Feature::Face)
}

/// A node of the tree: up to four children side by side (each axis's bounds of the four
/// in one array), each a leaf (`count` triangles from position `child` of the leaf
/// order) or a node (`count` 0, `child` its index). An empty slot has an empty box
/// (`lo` +∞, `hi` −∞), whose distance is +∞.
#[derive(Debug, Clone, Copy)]
struct Node {
    lo: [[f64; 4]; 3],
    hi: [[f64; 4]; 3],
    child: [u32; 4],
    count: [u32; 4],
}

const EMPTY: Node = Node {
    lo: [[f64::INFINITY; 4]; 3],
    hi: [[f64::NEG_INFINITY; 4]; 3],
    child: [0; 4],
    count: [0; 4],
};

/// The larger of two numbers that are not NaN (`f64::max` without its NaN handling: one
/// instruction).
#[inline(always)]
fn larger(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// Squared distances from `p` to the four boxes of `n` (0 inside; an empty slot's +∞).
#[inline(always)]
fn box_dist2(p: V, n: &Node) -> [f64; 4] {
    let mut d = [0.0; 4];
    for ((lo, hi), pk) in n.lo.iter().zip(&n.hi).zip(p) {
        for (dj, (l, h)) in d.iter_mut().zip(lo.iter().zip(hi)) {
            // Beyond lo, beyond hi, or between (lo ≤ hi): the value of the three-way
            // branch, without its unpredictable jumps.
            let e = larger(larger(l - pk, pk - h), 0.0);
            *dj += e * e;
        }
    }
    d
}

/// The closest point found so far: the triangle (position in the leaf order), the point,
/// its feature and the squared distance.
#[derive(Debug, Clone, Copy)]
struct Near {
    pos: u32,
    q: V,
    feat: Feature,
    d2: f64,
}

/// A mesh indexed for closest points and pseudo-normal signs.
#[derive(Debug, Clone)]
pub struct DistIndex {
    verts: Vec<V>,
    /// The kept triangles' vertex indices in the leaf order (a leaf's triangles side by
    /// side); every triangle below is named by its position here.
    tris: Vec<[u32; 3]>,
    /// Their corners.
    corners: Vec<[V; 3]>,
    /// Their unit normals.
    face_n: Vec<V>,
    /// The triangles around each vertex, in the mesh's triangle order:
    /// `around[start[v]..start[v + 1]]`.
    start: Vec<u32>,
    around: Vec<u32>,
    nodes: Vec<Node>,
    /// Each node's parent and its slot there (the root: itself).
    parent: Vec<(u32, u32)>,
}

/// The search's best so far: its squared distance (+∞ before any), the closest point,
/// and the leaf it is in (a node and a slot).
#[derive(Debug, Clone, Copy)]
struct Best {
    d2: f64,
    near: Option<Near>,
    leaf: (u32, u32),
}

/// Triangles in a leaf at most.
const LEAF: usize = 4;

/// Points answered in turn from the one before (see [`DistIndex::answer_run`]): a run of
/// this many in the spatial order is one piece of work for a thread.
pub const RUN: usize = 512;

impl DistIndex {
    /// Index `mesh` (its non-degenerate triangles); `None` when it has none, or a
    /// triangle names a vertex it lacks.
    ///
    /// The tree is built over the triangles sorted by the Morton code of their
    /// centroids: each node's triangles are a run of that order, split where the
    /// highest bit of the codes changes (the middle when all codes are equal), and
    /// each box is the union of its children's.
    pub fn new(mesh: &Mesh) -> Option<DistIndex> {
        let verts: Vec<V> = mesh.vertices.iter().map(|v| [v.x, v.y, v.z]).collect();
        let nt = mesh.triangles.len();
        if u32::try_from(3 * nt).is_err() || u32::try_from(verts.len()).is_err() {
            return None;
        }
        // The kept triangles (mesh order), their normals and centroids.
        let mut kept: Vec<(u32, V, V)> = Vec::with_capacity(nt);
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for (f, t) in mesh.triangles.iter().enumerate() {
            let mut c = [[0.0; 3]; 3];
            for k in 0..3 {
                c[k] = *verts.get(t[k] as usize)?;
            }
            let [a, b, cc] = c;
            let n = cross(sub(b, a), sub(cc, a));
            let len = dot(n, n).sqrt();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let m = scale(add(add(a, b), cc), 1.0 / 3.0);
            for k in 0..3 {
                lo[k] = lo[k].min(m[k]);
                hi[k] = hi[k].max(m[k]);
            }
            kept.push((f as u32, scale(n, 1.0 / len), m));
        }
        if kept.is_empty() {
            return None;
        }
        let keys = morton_keys(kept.iter().map(|k| k.2), lo, hi);
        let sorted = radix_sort(keys);
        let codes: Vec<u64> = sorted.iter().map(|k| k.0).collect();
        let tris: Vec<[u32; 3]> = sorted
            .iter()
            .map(|k| mesh.triangles[kept[k.1 as usize].0 as usize])
            .collect();
        let face_n: Vec<V> = sorted.iter().map(|k| kept[k.1 as usize].1).collect();
        let corners: Vec<[V; 3]> = tris.iter().map(|t| t.map(|i| verts[i as usize])).collect();
        // Where each kept triangle went, then the triangles around each vertex.
        let mut pos = vec![0u32; kept.len()];
        for (p, k) in sorted.iter().enumerate() {
            pos[k.1 as usize] = p as u32;
        }
        let mut start = vec![0u32; verts.len() + 1];
        for k in &kept {
            for &i in &mesh.triangles[k.0 as usize] {
                start[i as usize + 1] += 1;
            }
        }
        for v in 0..verts.len() {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut around = vec![0u32; start[verts.len()] as usize];
        for (k, &p) in kept.iter().zip(&pos) {
            for &i in &mesh.triangles[k.0 as usize] {
                around[fill[i as usize] as usize] = p;
                fill[i as usize] += 1;
            }
        }
        let mut nodes = Vec::with_capacity(tris.len() / LEAF + 2);
        build(&codes, &corners, 0, &mut nodes);
        let mut parent = vec![(0, 0); nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            for j in 0..4 {
                if n.count[j] == 0 && n.lo[0][j] <= n.hi[0][j] {
                    parent[n.child[j] as usize] = (i as u32, j as u32);
                }
            }
        }
        Some(DistIndex {
            verts,
            tris,
            corners,
            face_n,
            start,
            around,
            nodes,
            parent,
        })
    }

    /// The closest points of a leaf's triangles to `p`, kept in `best` when nearer
    /// (with the leaf: `node`'s slot `slot`).
    #[inline(always)]
    fn leaf(&self, p: V, node: u32, slot: usize, best: &mut Best) {
        let n = &self.nodes[node as usize];
        let first = n.child[slot] as usize;
        for (i, [a, b, c]) in self.corners[first..first + n.count[slot] as usize]
            .iter()
            .enumerate()
        {
            let (q, feat) = closest_on_triangle(p, *a, *b, *c);
            let d = sub(p, q);
            let d2 = dot(d, d);
            if d2 < best.d2 {
                *best = Best {
                    d2,
                    near: Some(Near {
                        pos: (first + i) as u32,
                        q,
                        feat,
                        d2,
                    }),
                    leaf: (node, slot as u32),
                };
            }
        }
    }

    /// Searches the children of `node` whose boxes are nearer than the best, nearer
    /// first, skipping slot `skip` (4: none); depth-first below, each pending node with
    /// its box's distance, skipped when something nearer has been found since it was
    /// pushed.
    #[inline(always)]
    fn below(&self, p: V, node: u32, skip: usize, best: &mut Best, stack: &mut Vec<(f64, u32)>) {
        stack.clear();
        let mut node = node;
        let mut skip = skip;
        loop {
            let n = &self.nodes[node as usize];
            let d = box_dist2(p, n);
            // The slots nearer than the best, nearest last.
            let mut near = [(0.0, 0usize); 4];
            let mut k = 0;
            for (j, &dj) in d.iter().enumerate() {
                if j != skip && dj < best.d2 {
                    let mut i = k;
                    while i > 0 && near[i - 1].0 < dj {
                        near[i] = near[i - 1];
                        i -= 1;
                    }
                    near[i] = (dj, j);
                    k += 1;
                }
            }
            // Leaves at once (nearest first); nodes onto the stack (nearest last).
            for &(_, j) in near[..k].iter().rev() {
                if n.count[j] > 0 {
                    self.leaf(p, node, j, best);
                }
            }
            for &(dj, j) in &near[..k] {
                if n.count[j] == 0 && dj < best.d2 {
                    stack.push((dj, n.child[j]));
                }
            }
            skip = 4;
            loop {
                let Some((dj, next)) = stack.pop() else {
                    return;
                };
                if dj < best.d2 {
                    node = next;
                    break;
                }
            }
        }
    }

    /// The closest point of the mesh to `p`. Without a hint, the search runs down from
    /// the root; with one (the leaf of the point before's closest point), it starts
    /// there and climbs to the root, searching at each level the other children whose
    /// boxes are nearer than the best so far: for a point near the one before, most of
    /// the tree is pruned at once. Either way every triangle that may be nearer is
    /// seen, so the answer is the same; of two equally near triangles another may be
    /// named.
    #[inline(always)]
    fn nearest(&self, p: V, hint: Option<(u32, u32)>, stack: &mut Vec<(f64, u32)>) -> Best {
        let mut best = Best {
            d2: f64::INFINITY,
            near: None,
            leaf: (0, 0),
        };
        let Some((mut node, slot)) = hint else {
            self.below(p, 0, 4, &mut best, stack);
            return best;
        };
        let mut from = slot as usize;
        self.leaf(p, node, from, &mut best);
        loop {
            self.below(p, node, from, &mut best, stack);
            if node == 0 {
                return best;
            }
            let (up, at) = self.parent[node as usize];
            (node, from) = (up, at as usize);
        }
    }

    /// The closest point over every triangle: the reference the tree's search is
    /// tested against.
    #[cfg(test)]
    fn nearest_all(&self, p: V) -> Option<Near> {
        let mut best: Option<Near> = None;
        for (pos, [a, b, c]) in self.corners.iter().enumerate() {
            let (q, feat) = closest_on_triangle(p, *a, *b, *c);
            let d2 = dot(sub(p, q), sub(p, q));
            if best.is_none_or(|n| d2 < n.d2) {
                best = Some(Near {
                    pos: pos as u32,
                    q,
                    feat,
                    d2,
                });
            }
        }
        best
    }

    /// The angle-weighted pseudo-normal of a closest point's feature.
    fn pseudo_normal(&self, n: &Near) -> V {
        let f = n.pos as usize;
        let t = self.tris[f];
        match n.feat {
            Feature::Face => self.face_n[f],
            Feature::Vertex(k) => {
                let v = t[k as usize];
                let mut sum = [0.0; 3];
                for &g in self.around(v) {
                    let tg = self.tris[g as usize];
                    let Some(j) = tg.iter().position(|&i| i == v) else {
                        continue;
                    };
                    let (p, q, r) = (
                        self.verts[tg[j] as usize],
                        self.verts[tg[(j + 1) % 3] as usize],
                        self.verts[tg[(j + 2) % 3] as usize],
                    );
                    let (u, w) = (sub(q, p), sub(r, p));
                    let angle = dot(cross(u, w), cross(u, w)).sqrt().atan2(dot(u, w));
                    sum = add(sum, scale(self.face_n[g as usize], angle));
                }
                sum
            }
            Feature::Edge(k) => {
                let (a, b) = (t[k as usize], t[(k as usize + 1) % 3]);
                // The triangle across the edge runs it from b to a.
                let other = self.around(b).iter().find(|&&g| {
                    let tg = self.tris[g as usize];
                    (0..3).any(|j| tg[j] == b && tg[(j + 1) % 3] == a)
                });
                let other = other.map_or([0.0; 3], |&g| self.face_n[g as usize]);
                add(self.face_n[f], other)
            }
        }
    }

    fn around(&self, v: u32) -> &[u32] {
        let v = v as usize;
        &self.around[self.start[v] as usize..self.start[v + 1] as usize]
    }

    /// The distance of `p` to the closest point `n`, negative inside when `signed`.
    fn answer(&self, p: V, n: Option<Near>, signed: bool) -> f64 {
        let Some(n) = n else {
            return f64::INFINITY;
        };
        let d = n.d2.sqrt();
        if signed && dot(sub(p, n.q), self.pseudo_normal(&n)) < 0.0 {
            -d
        } else {
            d
        }
    }

    /// Unsigned distance from `p` to the mesh.
    pub fn distance(&self, p: V) -> f64 {
        self.answer(p, self.nearest(p, None, &mut Vec::new()).near, false)
    }

    /// Distance from `p` to the mesh, negative inside (meaningful for a closed,
    /// consistently oriented mesh).
    pub fn signed_distance(&self, p: V) -> f64 {
        self.answer(p, self.nearest(p, None, &mut Vec::new()).near, true)
    }

    /// The distances of `points` into `out` (signed when `signed`), taken in turn,
    /// each search started from the leaf of the point before's closest point: for
    /// points in a spatial order ([`morton_order`]) most of the tree is then pruned at
    /// once. The same distances as [`Self::distance`] and [`Self::signed_distance`]
    /// one by one; of two equally near triangles another may be named, so a sign may
    /// differ only where the distance is nothing.
    pub fn answer_run(&self, points: &[V], signed: bool, out: &mut [f64]) {
        let mut hint = None;
        let mut stack = Vec::new();
        for (o, &p) in out.iter_mut().zip(points) {
            let b = self.nearest(p, hint, &mut stack);
            hint = b.near.map(|_| b.leaf);
            *o = self.answer(p, b.near, signed);
        }
    }
}

/// Where the triangles `codes` (a run of the leaf order, their Morton codes sorted) are
/// cut in two: where the highest bit of the codes changes, or the middle when all codes
/// are equal.
fn cut(codes: &[u64]) -> usize {
    let (a, z) = (codes[0], codes[codes.len() - 1]);
    if a == z {
        codes.len() / 2
    } else {
        let bit = 1u64 << (63 - (a ^ z).leading_zeros());
        codes.partition_point(|c| c & bit == 0)
    }
}

/// Builds the node of the triangles `first..first + codes.len()` of the leaf order
/// (their Morton codes, sorted) into `nodes`, and below it its children's nodes; its
/// box. Its children: the run cut in two, and each half of more than [`LEAF`]
/// triangles cut again; a part of at most [`LEAF`] triangles is a leaf.
fn build(codes: &[u64], corners: &[[V; 3]], first: usize, nodes: &mut Vec<Node>) -> [V; 2] {
    let me = nodes.len();
    nodes.push(EMPTY);
    let mut parts = Vec::with_capacity(4);
    if codes.len() <= LEAF {
        parts.push((first, codes.len()));
    } else {
        let mid = cut(codes);
        for (s, n) in [(0, mid), (mid, codes.len() - mid)] {
            if n <= LEAF {
                parts.push((first + s, n));
            } else {
                let m = cut(&codes[s..s + n]);
                parts.push((first + s, m));
                parts.push((first + s + m, n - m));
            }
        }
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for (j, &(s, n)) in parts.iter().enumerate() {
        let (clo, chi, child, count) = if n <= LEAF {
            let (mut clo, mut chi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for v in corners[s..s + n].iter().flatten() {
                for k in 0..3 {
                    clo[k] = clo[k].min(v[k]);
                    chi[k] = chi[k].max(v[k]);
                }
            }
            (clo, chi, s as u32, n as u32)
        } else {
            let child = nodes.len() as u32;
            let [clo, chi] = build(&codes[s - first..s - first + n], corners, s, nodes);
            (clo, chi, child, 0)
        };
        let node = &mut nodes[me];
        for k in 0..3 {
            node.lo[k][j] = clo[k];
            node.hi[k][j] = chi[k];
            lo[k] = lo[k].min(clo[k]);
            hi[k] = hi[k].max(chi[k]);
        }
        node.child[j] = child;
        node.count[j] = count;
    }
    [lo, hi]
}

/// Morton (Z-curve) codes of `points` over the box `lo..hi`, 21 bits an axis, with each
/// point's index; a point that is not finite gets `u64::MAX`.
fn morton_keys(points: impl Iterator<Item = V>, lo: V, hi: V) -> Vec<(u64, u32)> {
    let spread = |mut x: u64| {
        x &= 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    };
    points
        .enumerate()
        .map(|(i, p)| {
            if !p.iter().all(|x| x.is_finite()) {
                return (u64::MAX, i as u32);
            }
            let q = |k: usize| {
                let w = hi[k] - lo[k];
                let t = if w > 0.0 { (p[k] - lo[k]) / w } else { 0.0 };
                // `as` saturates: NaN and below 0 to 0, beyond to the top.
                ((t * 2_097_151.0) as u64).min(0x1f_ffff)
            };
            (
                spread(q(0)) | spread(q(1)) << 1 | spread(q(2)) << 2,
                i as u32,
            )
        })
        .collect()
}

/// `keys` sorted by code, then index (least significant digit first, 16 bits a pass,
/// passes where every key has the same digit skipped): the order of
/// `sort_unstable` on the pairs, when the indices come in increasing order as
/// [`morton_keys`] makes them.
fn radix_sort(mut keys: Vec<(u64, u32)>) -> Vec<(u64, u32)> {
    let mut tmp = vec![(0u64, 0u32); keys.len()];
    for shift in [0u32, 16, 32, 48] {
        let mut count = vec![0usize; 1 << 16];
        for k in &keys {
            count[((k.0 >> shift) & 0xffff) as usize] += 1;
        }
        if count.contains(&keys.len()) {
            continue;
        }
        let mut sum = 0;
        for c in count.iter_mut() {
            (*c, sum) = (sum, sum + *c);
        }
        for k in &keys {
            let d = ((k.0 >> shift) & 0xffff) as usize;
            tmp[count[d]] = *k;
            count[d] += 1;
        }
        std::mem::swap(&mut keys, &mut tmp);
    }
    keys
}

/// The points' indices in Morton (Z-curve) order over their bounding box (the order in
/// which [`DistIndex::answer_run`] answers them fastest); points that are not finite go
/// last.
pub fn morton_order(points: &[V]) -> Vec<u32> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points.iter().filter(|p| p.iter().all(|x| x.is_finite())) {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    radix_sort(morton_keys(points.iter().copied(), lo, hi))
        .into_iter()
        .map(|k| k.1)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the closest point over every triangle, and parry's signs, on a sphere.
    #[test]
    fn agrees_with_brute_force_and_parry() {
        let m = crate::uv_sphere(crate::P3::new(1.0, -2.0, 0.5), 10.0, 16, 32);
        let idx = DistIndex::new(&m).expect("index");
        let bvh = crate::bvh::MeshBvh::new(&m).expect("bvh");
        for k in 0..2000 {
            let t = f64::from(k) * 0.01;
            let p = [
                1.0 + 13.0 * (7.1 * t).sin(),
                -2.0 + 12.0 * (5.3 * t).cos(),
                0.5 + 11.0 * (3.7 * t).sin() * (1.3 * t).cos(),
            ];
            let brute = m
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| {
                        let v = m.vertices[i as usize];
                        [v.x, v.y, v.z]
                    });
                    let (q, _) = closest_on_triangle(p, a, b, c);
                    dot(sub(p, q), sub(p, q)).sqrt()
                })
                .fold(f64::INFINITY, f64::min);
            let d = idx.signed_distance(p);
            assert_eq!(d.abs(), brute, "{p:?}");
            let theirs = bvh.signed_distance(crate::P3::from(p)).expect("parry");
            assert!((d - theirs).abs() < 1e-9, "{p:?}: {d} vs {theirs}");
        }
    }

    /// A mesh of 80,000 triangles (a deep tree): the same answers as parry's.
    #[test]
    fn a_big_mesh_agrees_with_parry() {
        let m = crate::uv_sphere(crate::P3::zeros(), 10.0, 200, 200);
        assert!(m.triangles.len() >= 65_536);
        let idx = DistIndex::new(&m).expect("index");
        let bvh = crate::bvh::MeshBvh::new(&m).expect("bvh");
        for k in 0..500 {
            let t = f64::from(k) * 0.013;
            let p = [
                11.0 * (7.1 * t).sin(),
                12.0 * (5.3 * t).cos(),
                10.5 * (3.7 * t).sin(),
            ];
            let theirs = bvh.signed_distance(crate::P3::from(p)).expect("parry");
            assert!((idx.signed_distance(p) - theirs).abs() < 1e-12, "{p:?}");
        }
    }

    /// A generated solid, moved and turned, and a few triangles copied on top of
    /// others (equal Morton codes: the middle split) and a zero-area one.
    fn solid(kind: u8, n: u32, shift: [f64; 3], dup: usize) -> Mesh {
        let c = crate::P3::from(shift);
        let mut m = match kind % 3 {
            0 => crate::uv_sphere(c, 7.0, n + 3, 2 * n + 3),
            1 => crate::torus(c, 9.0, 3.0, 2 * n + 3, n + 3),
            _ => {
                let half = crate::P3::new(4.0, 2.5, 1.5);
                crate::box_mesh(c - half, c + half)
            }
        };
        let t = m.triangles[0];
        for _ in 0..dup {
            m.triangles.push(t);
        }
        m.triangles.push([t[0], t[0], t[1]]);
        m
    }

    /// The pseudo-normal of a feature worked out from the whole mesh in its own
    /// order, as the index did before it kept the triangles around each vertex: a
    /// vertex's face normals weighted by their angles there, summed in triangle order;
    /// an edge's face normal plus that of the first triangle running it backwards.
    fn reference_normal(m: &Mesh, idx: &DistIndex, n: &Near) -> V {
        let v = |i: u32| {
            let p = m.vertices[i as usize];
            [p.x, p.y, p.z]
        };
        let unit = |t: &[u32; 3]| {
            let nn = cross(sub(v(t[1]), v(t[0])), sub(v(t[2]), v(t[0])));
            let len = dot(nn, nn).sqrt();
            (len > 0.0 && len.is_finite()).then(|| scale(nn, 1.0 / len))
        };
        let t = idx.tris[n.pos as usize];
        match n.feat {
            Feature::Face => unit(&t).unwrap_or([0.0; 3]),
            Feature::Vertex(k) => {
                let x = t[k as usize];
                let mut sum = [0.0; 3];
                for tg in &m.triangles {
                    let Some(fnorm) = unit(tg) else { continue };
                    for j in 0..3 {
                        if tg[j] == x {
                            let (p, q, r) = (v(tg[j]), v(tg[(j + 1) % 3]), v(tg[(j + 2) % 3]));
                            let (u, w) = (sub(q, p), sub(r, p));
                            let angle = dot(cross(u, w), cross(u, w)).sqrt().atan2(dot(u, w));
                            sum = add(sum, scale(fnorm, angle));
                        }
                    }
                }
                sum
            }
            Feature::Edge(k) => {
                let (a, b) = (t[k as usize], t[(k as usize + 1) % 3]);
                let other = m
                    .triangles
                    .iter()
                    .filter(|tg| unit(tg).is_some())
                    .find(|tg| (0..3).any(|j| tg[j] == b && tg[(j + 1) % 3] == a))
                    .and_then(unit)
                    .unwrap_or([0.0; 3]);
                add(unit(&t).unwrap_or([0.0; 3]), other)
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

        /// The tree's search (from the root, and from a hint) against every triangle:
        /// the same squared distance bit for bit, and the same pseudo-normal as the
        /// reference's; a run answered in turn agrees with the points one by one.
        #[test]
        fn the_fast_paths_agree_with_the_references(
            kind in 0u8..3,
            n in 0u32..12,
            shift in proptest::array::uniform3(-50.0f64..50.0),
            dup in 0usize..12,
            raw in proptest::collection::vec(proptest::array::uniform3(-1.3f64..1.3), 1..120),
        ) {
            let m = solid(kind, n, shift, dup);
            let idx = DistIndex::new(&m).expect("index");
            let pts: Vec<V> = raw
                .iter()
                .map(|r| std::array::from_fn(|k| shift[k] + 12.0 * r[k]))
                .collect();
            let mut stack = Vec::new();
            let mut hint = None;
            for &p in &pts {
                let all = idx.nearest_all(p).expect("triangles");
                for h in [None, hint] {
                    let b = idx.nearest(p, h, &mut stack);
                    let near = b.near.expect("found");
                    proptest::prop_assert_eq!(near.d2.to_bits(), all.d2.to_bits());
                    proptest::prop_assert_eq!(
                        idx.pseudo_normal(&near).map(f64::to_bits),
                        reference_normal(&m, &idx, &near).map(f64::to_bits)
                    );
                    hint = Some(b.leaf);
                }
            }
            let mut out = vec![f64::NAN; pts.len()];
            idx.answer_run(&pts, true, &mut out);
            for (p, d) in pts.iter().zip(&out) {
                let one = idx.signed_distance(*p);
                proptest::prop_assert_eq!(d.abs().to_bits(), one.abs().to_bits());
                if one.abs() > 1e-9 {
                    proptest::prop_assert_eq!(d.signum(), one.signum());
                }
            }
        }

        /// The radix sort gives `sort_unstable`'s order.
        #[test]
        fn radix_sort_agrees_with_sort(codes in proptest::collection::vec(proptest::prelude::any::<u64>(), 0..3000), small in proptest::prelude::any::<bool>()) {
            let keys: Vec<(u64, u32)> = codes
                .iter()
                .enumerate()
                .map(|(i, &c)| (if small { c % 7 } else { c }, i as u32))
                .collect();
            let mut want = keys.clone();
            want.sort_unstable();
            proptest::prop_assert_eq!(radix_sort(keys), want);
        }
    }
}
