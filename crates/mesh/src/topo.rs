//! The closed-manifold report: which edges keep a mesh from bounding a solid.
//!
//! Edges are undirected vertex pairs of a welded mesh. A closed, consistently oriented
//! 2-manifold has every edge in exactly two triangles, traversed in opposite directions.
//! Triangles with a repeated vertex index (degenerate) are counted and left out.

/// What is wrong with one edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EdgeProblem {
    /// In one triangle only: the border of a hole.
    Boundary,
    /// In three or more triangles.
    NonManifold,
    /// In two triangles that traverse it in the same direction: one of them is flipped.
    Inconsistent,
}

impl EdgeProblem {
    /// A short name (`boundary`, `non-manifold`, `inconsistent`).
    pub fn name(self) -> &'static str {
        match self {
            EdgeProblem::Boundary => "boundary",
            EdgeProblem::NonManifold => "non-manifold",
            EdgeProblem::Inconsistent => "inconsistent",
        }
    }
}

/// One bad edge: its vertices (`a < b`), what is wrong, and how many triangles use it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BadEdge {
    /// Lower vertex index.
    pub a: u32,
    /// Higher vertex index.
    pub b: u32,
    /// What is wrong.
    pub problem: EdgeProblem,
    /// Triangles using the edge.
    pub faces: u32,
    /// One triangle using it.
    pub face: u32,
}

/// How far a mesh is from a closed, consistently oriented manifold.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ManifoldReport {
    /// Edges used by one triangle only (holes).
    pub boundary_edges: usize,
    /// Edges used by three or more triangles.
    pub non_manifold_edges: usize,
    /// Edges two triangles traverse in the same direction.
    pub inconsistent_edges: usize,
    /// Triangles with a repeated vertex.
    pub degenerate_triangles: usize,
    /// Triangles without one (those the edges are counted over).
    pub faces: usize,
    /// Triangles whose twin, the same three vertices wound the other way, is in the mesh
    /// too (each of a pair counted): a double-sided export, whose two sides cancel in
    /// every slice.
    pub twin_faces: usize,
    /// Every bad edge, in vertex order.
    pub bad_edges: Vec<BadEdge>,
}

impl ManifoldReport {
    /// True for a closed 2-manifold (orientation aside). Triangles with a repeated
    /// vertex bound nothing and are left out (a UV sphere's collapsed pole quads, as
    /// exporters write them: the surface is closed without them, as trimesh finds).
    pub fn closed(&self) -> bool {
        self.faces > 0 && self.boundary_edges == 0 && self.non_manifold_edges == 0
    }

    /// True for a closed 2-manifold whose triangles agree on their orientation.
    pub fn closed_oriented(&self) -> bool {
        self.closed() && self.inconsistent_edges == 0
    }
}

/// Directed edges of the non-degenerate triangles, sorted by undirected key: `(key, face,
/// forward)` where `key = a << 32 | b` with `a < b` and `forward` says the face runs a → b.
pub(crate) fn sorted_edges(triangles: &[[u32; 3]]) -> (Vec<(u64, u32, bool)>, usize) {
    let mut out = Vec::with_capacity(triangles.len() * 3);
    let mut degenerate = 0;
    for (f, t) in triangles.iter().enumerate() {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            degenerate += 1;
            continue;
        }
        let f = u32::try_from(f).unwrap_or(u32::MAX);
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            let (lo, hi) = (a.min(b), a.max(b));
            out.push(((u64::from(lo) << 32) | u64::from(hi), f, a < b));
        }
    }
    out.sort_unstable();
    (out, degenerate)
}

/// The closed-manifold report of a welded mesh.
pub fn manifold_report(mesh: &crate::Mesh) -> ManifoldReport {
    let (edges, degenerate) = sorted_edges(&mesh.triangles);
    let mut r = ManifoldReport {
        degenerate_triangles: degenerate,
        faces: mesh.triangles.len() - degenerate,
        ..ManifoldReport::default()
    };
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 {
            j += 1;
        }
        let n = j - i;
        let problem = if n == 1 {
            r.boundary_edges += 1;
            Some(EdgeProblem::Boundary)
        } else if n > 2 {
            r.non_manifold_edges += 1;
            Some(EdgeProblem::NonManifold)
        } else if edges[i].2 == edges[i + 1].2 {
            r.inconsistent_edges += 1;
            Some(EdgeProblem::Inconsistent)
        } else {
            None
        };
        if let Some(problem) = problem {
            let k = edges[i].0;
            r.bad_edges.push(BadEdge {
                a: (k >> 32) as u32,
                b: (k & 0xFFFF_FFFF) as u32,
                problem,
                faces: u32::try_from(n).unwrap_or(u32::MAX),
                face: edges[i].1,
            });
        }
        i = j;
    }
    r.twin_faces = twin_faces(&mesh.triangles);
    r
}

/// Triangles whose reverse (the same vertices wound the other way) is in the mesh too.
fn twin_faces(triangles: &[[u32; 3]]) -> usize {
    // Each triangle by its vertices in ascending order and its winding's parity against
    // that order; a twin has the same vertices and the other parity.
    let mut keyed: Vec<([u32; 3], bool)> = triangles
        .iter()
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .map(|t| {
            // The rotation starting at the smallest vertex; even when the next is the
            // middle one.
            let r = if t[0] < t[1] && t[0] < t[2] {
                *t
            } else if t[1] < t[2] {
                [t[1], t[2], t[0]]
            } else {
                [t[2], t[0], t[1]]
            };
            let even = r[1] < r[2];
            let mut k = r;
            k.sort_unstable();
            (k, even)
        })
        .collect();
    keyed.sort_unstable();
    let mut n = 0;
    let mut i = 0;
    while i < keyed.len() {
        let mut j = i + 1;
        while j < keyed.len() && keyed[j].0 == keyed[i].0 {
            j += 1;
        }
        let even = keyed[i..j].iter().filter(|k| k.1).count();
        if even > 0 && even < j - i {
            n += j - i;
        }
        i = j;
    }
    n
}
