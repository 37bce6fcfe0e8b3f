//! [`DistIndex`]: closest points and signed distances to a triangle mesh, in `f64`, for
//! many points at once (the deviations of a whole measurement).
//!
//! A bounding-volume hierarchy of the triangles (median splits on the longest axis of the
//! centroids' box, up to 4 triangles a leaf), searched nearer child first and pruned by
//! the best squared distance found; the closest point on a triangle by its Voronoi regions
//! (Ericson, *Real-Time Collision Detection*, 5.1.5), which also names the feature it lies
//! on. The sign is that of the feature's angle-weighted pseudo-normal (Bærentzen and
//! Aanæs, 2005): the face's normal, the sum of an edge's two face normals, or a vertex's
//! face normals weighted by their angles there; negative inside. Degenerate (zero-area)
//! triangles are left out: each of their points lies on a neighbour's edge.

use lampost_mesh::Mesh;

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

#[derive(Debug, Clone, Copy)]
struct Node {
    lo: V,
    hi: V,
    /// Leaf: first triangle in `order`; inner: the right child (the left is next).
    index: u32,
    /// Leaf: triangle count; inner: 0.
    count: u32,
}

fn box_dist2(p: V, lo: V, hi: V) -> f64 {
    let mut d = 0.0;
    for k in 0..3 {
        let e = if p[k] < lo[k] {
            lo[k] - p[k]
        } else if p[k] > hi[k] {
            p[k] - hi[k]
        } else {
            0.0
        };
        d += e * e;
    }
    d
}

/// A mesh indexed for closest points and pseudo-normal signs.
#[derive(Debug, Clone)]
pub struct DistIndex {
    tris: Vec<[u32; 3]>,
    /// Unit face normals.
    face_n: Vec<V>,
    /// Angle-weighted vertex pseudo-normals.
    vert_n: Vec<V>,
    /// Directed edges (a << 32 | b) sorted, with their face.
    edges: Vec<(u64, u32)>,
    order: Vec<u32>,
    /// The triangles' corners in `order`'s order (a leaf's triangles side by side).
    corners: Vec<[V; 3]>,
    nodes: Vec<Node>,
}

const LEAF: usize = 4;

impl DistIndex {
    /// Index `mesh` (its non-degenerate triangles); `None` when it has none.
    pub fn new(mesh: &Mesh) -> Option<DistIndex> {
        let verts: Vec<V> = mesh.vertices.iter().map(|v| [v.x, v.y, v.z]).collect();
        let mut tris = Vec::with_capacity(mesh.triangles.len());
        let mut face_n = Vec::with_capacity(mesh.triangles.len());
        let mut vert_n = vec![[0.0; 3]; verts.len()];
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| verts[i as usize]);
            let n = cross(sub(b, a), sub(c, a));
            let len = dot(n, n).sqrt();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let n = scale(n, 1.0 / len);
            for k in 0..3 {
                let (p, q, r) = (
                    verts[t[k] as usize],
                    verts[t[(k + 1) % 3] as usize],
                    verts[t[(k + 2) % 3] as usize],
                );
                let (u, w) = (sub(q, p), sub(r, p));
                let angle = dot(cross(u, w), cross(u, w)).sqrt().atan2(dot(u, w));
                let vn = &mut vert_n[t[k] as usize];
                *vn = add(*vn, scale(n, angle));
            }
            tris.push(*t);
            face_n.push(n);
        }
        if tris.is_empty() {
            return None;
        }
        let cent: Vec<V> = tris
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| verts[i as usize]);
                scale(add(add(a, b), c), 1.0 / 3.0)
            })
            .collect();
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        // The edge table and the two halves of the tree on their own threads.
        let (edges, nodes) = std::thread::scope(|s| {
            let edges = s.spawn(|| {
                let mut edges: Vec<(u64, u32)> = Vec::with_capacity(3 * tris.len());
                for (f, t) in tris.iter().enumerate() {
                    for k in 0..3 {
                        let (a, b) = (u64::from(t[k]), u64::from(t[(k + 1) % 3]));
                        edges.push(((a << 32) | b, f as u32));
                    }
                }
                edges.sort_unstable();
                edges
            });
            let nodes = build_top(&verts, &tris, &cent, &mut order);
            (edges.join(), nodes)
        });
        let (Ok(edges), Some(nodes)) = (edges, nodes) else {
            return None;
        };
        let corners = order
            .iter()
            .map(|&f| tris[f as usize].map(|i| verts[i as usize]))
            .collect();
        Some(DistIndex {
            tris,
            face_n,
            vert_n,
            edges,
            order,
            corners,
            nodes,
        })
    }

    fn edge_face(&self, a: u32, b: u32) -> Option<u32> {
        let key = (u64::from(a) << 32) | u64::from(b);
        self.edges
            .binary_search_by(|e| e.0.cmp(&key))
            .ok()
            .map(|i| self.edges[i].1)
    }

    /// The closest point's distance to `p`, and its sign's pseudo-normal's dot product
    /// with `p − closest` (negative: inside).
    fn query(&self, p: V) -> (f64, f64) {
        let mut best = f64::INFINITY;
        let mut hit: Option<(u32, V, Feature)> = None;
        // Depth-first, one pending sibling a level: the tree is at most about 2·log2(n)
        // deep (median splits), far under the 128 slots.
        let mut stack = [0u32; 128];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let ni = stack[top];
            let n = self.nodes[ni as usize];
            if box_dist2(p, n.lo, n.hi) >= best {
                continue;
            }
            if n.count > 0 {
                let range = n.index as usize..(n.index + n.count) as usize;
                for (j, [a, b, c]) in self.corners[range.clone()].iter().enumerate() {
                    let (q, feat) = closest_on_triangle(p, *a, *b, *c);
                    let d = sub(p, q);
                    let d2 = dot(d, d);
                    if d2 < best {
                        best = d2;
                        hit = Some((self.order[range.start + j], q, feat));
                    }
                }
            } else {
                let (l, r) = (ni + 1, n.index);
                let (nl, nr) = (self.nodes[l as usize], self.nodes[r as usize]);
                let (dl, dr) = (box_dist2(p, nl.lo, nl.hi), box_dist2(p, nr.lo, nr.hi));
                // The nearer child is searched first (pushed last).
                // Inside both boxes, the one whose centre is nearer.
                let left_first = if dl == dr {
                    let c = |n: &Node| {
                        let m: V = std::array::from_fn(|k| 0.5 * (n.lo[k] + n.hi[k]));
                        dot(sub(p, m), sub(p, m))
                    };
                    c(&nl) <= c(&nr)
                } else {
                    dl < dr
                };
                let (near, far) = if left_first { (l, r) } else { (r, l) };
                if top + 2 > stack.len() {
                    // Never for a median-split tree; searched the slow way if it were.
                    return self.query_all(p);
                }
                stack[top] = far;
                stack[top + 1] = near;
                top += 2;
            }
        }
        self.finish(p, best, hit)
    }

    /// Every triangle, for a tree too deep for the stack (never expected).
    fn query_all(&self, p: V) -> (f64, f64) {
        let mut best = f64::INFINITY;
        let mut hit = None;
        for (j, [a, b, c]) in self.corners.iter().enumerate() {
            let (q, feat) = closest_on_triangle(p, *a, *b, *c);
            let d2 = dot(sub(p, q), sub(p, q));
            if d2 < best {
                best = d2;
                hit = Some((self.order[j], q, feat));
            }
        }
        self.finish(p, best, hit)
    }

    fn finish(&self, p: V, best: f64, hit: Option<(u32, V, Feature)>) -> (f64, f64) {
        let Some((f, q, feat)) = hit else {
            return (f64::INFINITY, 0.0);
        };
        let t = self.tris[f as usize];
        let pn = match feat {
            Feature::Face => self.face_n[f as usize],
            Feature::Vertex(k) => self.vert_n[t[k as usize] as usize],
            Feature::Edge(k) => {
                let (a, b) = (t[k as usize], t[(k as usize + 1) % 3]);
                let other = self
                    .edge_face(b, a)
                    .map_or([0.0; 3], |g| self.face_n[g as usize]);
                add(self.face_n[f as usize], other)
            }
        };
        (best.sqrt(), dot(sub(p, q), pn))
    }

    /// Unsigned distance from `p` to the mesh.
    pub fn distance(&self, p: V) -> f64 {
        self.query(p).0
    }

    /// Distance from `p` to the mesh, negative inside (meaningful for a closed,
    /// consistently oriented mesh).
    pub fn signed_distance(&self, p: V) -> f64 {
        let (d, s) = self.query(p);
        if s < 0.0 {
            -d
        } else {
            d
        }
    }
}

/// The tree: the root's two halves built on two threads, then joined (the right half's
/// child links moved past the left half's nodes). `None` if a thread failed.
fn build_top(verts: &[V], tris: &[[u32; 3]], cent: &[V], order: &mut [u32]) -> Option<Vec<Node>> {
    let mut nodes = Vec::with_capacity(2 * order.len() / LEAF + 1);
    let [lo, hi] = build_node(verts, tris, cent, order, 0, &mut nodes);
    let root = nodes[0];
    nodes[0].lo = lo;
    nodes[0].hi = hi;
    if order.len() < 65_536 {
        nodes.clear();
        build(verts, tris, cent, order, 0, &mut nodes);
        return Some(nodes);
    }
    let mid = split(cent, &root, order);
    let (left, right) = order.split_at_mut(mid);
    let (l, r) = std::thread::scope(|s| {
        let l = s.spawn(|| {
            let mut v = Vec::with_capacity(2 * left.len() / LEAF + 1);
            build(verts, tris, cent, left, 0, &mut v);
            v
        });
        let mut r = Vec::with_capacity(2 * right.len() / LEAF + 1);
        build(verts, tris, cent, right, mid, &mut r);
        (l.join(), r)
    });
    let l = l.ok()?;
    let (lo, ro) = (1u32, 1 + l.len() as u32);
    nodes[0].index = ro;
    nodes[0].count = 0;
    nodes.extend(l.into_iter().map(|mut n| {
        if n.count == 0 {
            n.index += lo;
        }
        n
    }));
    nodes.extend(r.into_iter().map(|mut n| {
        if n.count == 0 {
            n.index += ro;
        }
        n
    }));
    Some(nodes)
}

/// The node of `order`'s triangles (its box), pushed as a leaf.
fn build_node(
    verts: &[V],
    tris: &[[u32; 3]],
    cent: &[V],
    order: &[u32],
    first: usize,
    nodes: &mut Vec<Node>,
) -> [V; 2] {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut clo = [f64::INFINITY; 3];
    let mut chi = [f64::NEG_INFINITY; 3];
    for &f in order.iter() {
        for &i in &tris[f as usize] {
            let v = verts[i as usize];
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        let c = cent[f as usize];
        for k in 0..3 {
            clo[k] = clo[k].min(c[k]);
            chi[k] = chi[k].max(c[k]);
        }
    }
    nodes.push(Node {
        lo: clo,
        hi: chi,
        index: first as u32,
        count: order.len() as u32,
    });
    // The pushed node holds the centroids' box for `split`; the caller sets the
    // triangles' box.
    [lo, hi]
}

/// Median split of `order` on the longest axis of the centroids' box held in `n`.
fn split(cent: &[V], n: &Node, order: &mut [u32]) -> usize {
    let ext = sub(n.hi, n.lo);
    let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |a, b| {
        cent[*a as usize][axis].total_cmp(&cent[*b as usize][axis])
    });
    mid
}

/// Builds the subtree of `order[..]` (its triangles) into `nodes`; `first` is the
/// position of `order` in the whole.
fn build(
    verts: &[V],
    tris: &[[u32; 3]],
    cent: &[V],
    order: &mut [u32],
    first: usize,
    nodes: &mut Vec<Node>,
) {
    let me = nodes.len();
    let [lo, hi] = build_node(verts, tris, cent, order, first, nodes);
    let centroids = nodes[me];
    nodes[me].lo = lo;
    nodes[me].hi = hi;
    if order.len() <= LEAF {
        return;
    }
    let mid = split(cent, &centroids, order);
    let (left, right) = order.split_at_mut(mid);
    build(verts, tris, cent, left, first, nodes);
    let r = nodes.len();
    build(verts, tris, cent, right, first + mid, nodes);
    nodes[me].index = r as u32;
    nodes[me].count = 0;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the closest point over every triangle, and parry's signs, on a sphere.
    #[test]
    fn agrees_with_brute_force_and_parry() {
        let m = lampost_mesh::uv_sphere(lampost_mesh::P3::new(1.0, -2.0, 0.5), 10.0, 16, 32);
        let idx = DistIndex::new(&m).expect("index");
        let bvh = lampost_mesh::bvh::MeshBvh::new(&m).expect("bvh");
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
            let theirs = bvh
                .signed_distance(lampost_mesh::P3::from(p))
                .expect("parry");
            assert!((d - theirs).abs() < 1e-9, "{p:?}: {d} vs {theirs}");
        }
    }

    /// A mesh big enough for the tree's halves to be built on two threads: the same
    /// answers as parry's.
    #[test]
    fn halves_built_apart_agree() {
        let m = lampost_mesh::uv_sphere(lampost_mesh::P3::zeros(), 10.0, 200, 200);
        assert!(m.triangles.len() >= 65_536);
        let idx = DistIndex::new(&m).expect("index");
        let bvh = lampost_mesh::bvh::MeshBvh::new(&m).expect("bvh");
        for k in 0..500 {
            let t = f64::from(k) * 0.013;
            let p = [
                11.0 * (7.1 * t).sin(),
                12.0 * (5.3 * t).cos(),
                10.5 * (3.7 * t).sin(),
            ];
            let theirs = bvh
                .signed_distance(lampost_mesh::P3::from(p))
                .expect("parry");
            assert!((idx.signed_distance(p) - theirs).abs() < 1e-12, "{p:?}");
        }
    }
}
