//! STL meshes (ASCII and binary) for registration, with a closed-manifold check.

use std::collections::HashMap;

use crate::fit::P3;

/// A triangle mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Welded vertices.
    pub vertices: Vec<P3>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

/// A problem reading an STL file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// Binary STL shorter than its triangle count says.
    #[error("binary STL says {count} triangles but has bytes for {fits}")]
    Truncated {
        /// Count from the header.
        count: u32,
        /// Triangles that fit.
        fits: usize,
    },
    /// A malformed ASCII STL line.
    #[error("line {line}: {why}")]
    Ascii {
        /// 1-based line.
        line: usize,
        /// What is wrong.
        why: String,
    },
    /// No triangles.
    #[error("the mesh has no triangles")]
    Empty,
}

/// How far a mesh is from a closed manifold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ManifoldReport {
    /// Edges used by one triangle only (holes).
    pub boundary_edges: usize,
    /// Edges used by three or more triangles.
    pub non_manifold_edges: usize,
    /// Triangles with a repeated vertex.
    pub degenerate_triangles: usize,
}

impl ManifoldReport {
    /// True for a closed 2-manifold.
    pub fn closed(&self) -> bool {
        self.boundary_edges == 0 && self.non_manifold_edges == 0 && self.degenerate_triangles == 0
    }
}

fn weld(tris: Vec<[P3; 3]>) -> Result<Mesh, MeshError> {
    if tris.is_empty() {
        return Err(MeshError::Empty);
    }
    let mut index: HashMap<[u64; 3], u32> = HashMap::new();
    let mut vertices = Vec::new();
    let mut triangles = Vec::with_capacity(tris.len());
    for t in tris {
        let mut ids = [0u32; 3];
        for (k, v) in t.iter().enumerate() {
            // −0 and +0 are one coordinate.
            let key = [
                (v.x + 0.0).to_bits(),
                (v.y + 0.0).to_bits(),
                (v.z + 0.0).to_bits(),
            ];
            let next = u32::try_from(vertices.len()).unwrap_or(u32::MAX);
            ids[k] = *index.entry(key).or_insert_with(|| {
                vertices.push(*v);
                next
            });
        }
        triangles.push(ids);
    }
    Ok(Mesh {
        vertices,
        triangles,
    })
}

/// Read an STL file's bytes (binary or ASCII).
pub fn read_stl(bytes: &[u8]) -> Result<Mesh, MeshError> {
    let is_ascii = bytes.len() >= 5
        && bytes[..5].eq_ignore_ascii_case(b"solid")
        && std::str::from_utf8(bytes).is_ok_and(|t| t.contains("facet") || t.contains("endsolid"));
    if !is_ascii {
        if bytes.len() < 84 {
            return Err(MeshError::Truncated { count: 0, fits: 0 });
        }
        let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]);
        let fits = (bytes.len() - 84) / 50;
        if (count as usize) > fits {
            return Err(MeshError::Truncated { count, fits });
        }
        let f = |o: usize| {
            f64::from(f32::from_le_bytes([
                bytes[o],
                bytes[o + 1],
                bytes[o + 2],
                bytes[o + 3],
            ]))
        };
        let mut tris = Vec::with_capacity(count as usize);
        for i in 0..count as usize {
            let o = 84 + i * 50 + 12;
            let v = |k: usize| P3::new(f(o + 12 * k), f(o + 12 * k + 4), f(o + 12 * k + 8));
            tris.push([v(0), v(1), v(2)]);
        }
        if tris
            .iter()
            .flatten()
            .any(|p| !p.iter().all(|x| x.is_finite()))
        {
            return Err(MeshError::Ascii {
                line: 0,
                why: "a vertex is not finite".into(),
            });
        }
        return weld(tris);
    }
    let text = String::from_utf8_lossy(bytes);
    let mut tris = Vec::new();
    let mut cur: Vec<P3> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        let mut words = t.split_whitespace();
        match words.next() {
            Some("vertex") => {
                let vals: Vec<f64> = words
                    .map(|w| w.parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| MeshError::Ascii {
                        line: i + 1,
                        why: format!("`{t}` is not `vertex x y z`"),
                    })?;
                if vals.len() != 3 || !vals.iter().all(|v| v.is_finite()) {
                    return Err(MeshError::Ascii {
                        line: i + 1,
                        why: format!("`{t}` is not `vertex x y z` with finite numbers"),
                    });
                }
                cur.push(P3::new(vals[0], vals[1], vals[2]));
            }
            Some("endloop") => {
                if cur.len() != 3 {
                    return Err(MeshError::Ascii {
                        line: i + 1,
                        why: format!("a facet has {} vertices, not 3", cur.len()),
                    });
                }
                tris.push([cur[0], cur[1], cur[2]]);
                cur.clear();
            }
            _ => {}
        }
    }
    weld(tris)
}

/// Edges and triangles that keep a mesh from being a closed manifold.
pub fn manifold_report(mesh: &Mesh) -> ManifoldReport {
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    let mut degenerate = 0;
    for t in &mesh.triangles {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            degenerate += 1;
            continue;
        }
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    ManifoldReport {
        boundary_edges: edges.values().filter(|&&c| c == 1).count(),
        non_manifold_edges: edges.values().filter(|&&c| c > 2).count(),
        degenerate_triangles: degenerate,
    }
}

/// An ASCII STL of a mesh (used by tests and fixtures).
pub fn write_ascii_stl(mesh: &Mesh, name: &str) -> String {
    let mut s = format!("solid {name}\n");
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
        let n = (b - a).cross(&(c - a));
        let n = if n.norm() > 0.0 { n.normalize() } else { n };
        s.push_str(&format!(
            "  facet normal {} {} {}\n    outer loop\n",
            n.x, n.y, n.z
        ));
        for v in [a, b, c] {
            s.push_str(&format!("      vertex {} {} {}\n", v.x, v.y, v.z));
        }
        s.push_str("    endloop\n  endfacet\n");
    }
    s.push_str(&format!("endsolid {name}\n"));
    s
}

/// A closed axis-aligned box mesh from `lo` to `hi` (12 triangles, outward normals).
pub fn box_mesh(lo: P3, hi: P3) -> Mesh {
    let v = |x: bool, y: bool, z: bool| {
        P3::new(
            if x { hi.x } else { lo.x },
            if y { hi.y } else { lo.y },
            if z { hi.z } else { lo.z },
        )
    };
    let vertices: Vec<P3> = (0..8)
        .map(|i| v(i & 1 != 0, i & 2 != 0, i & 4 != 0))
        .collect();
    let triangles = vec![
        [0, 2, 1],
        [1, 2, 3], // z = lo
        [4, 5, 6],
        [5, 7, 6], // z = hi
        [0, 1, 4],
        [1, 5, 4], // y = lo
        [2, 6, 3],
        [3, 6, 7], // y = hi
        [0, 4, 2],
        [2, 4, 6], // x = lo
        [1, 3, 5],
        [3, 7, 5], // x = hi
    ];
    Mesh {
        vertices,
        triangles,
    }
}
