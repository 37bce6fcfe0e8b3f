//! Welding: vertices that are one point become one index.
//!
//! [`weld_exact`] merges bit-equal coordinates (−0 and +0 are one); every reader applies
//! it. [`weld_within`] also merges vertices closer than a tolerance (greedy, in vertex
//! order: a vertex joins the first kept vertex within the tolerance, so chains of close
//! vertices do not drift further than one tolerance from their representative). Both
//! drop vertices no triangle uses and keep triangles in order, so a face index means the
//! same face before and after.

use std::collections::HashMap;

use crate::{Mesh, P3};

fn key(v: &P3) -> [u64; 3] {
    [
        (v.x + 0.0).to_bits(),
        (v.y + 0.0).to_bits(),
        (v.z + 0.0).to_bits(),
    ]
}

/// Merge vertices with equal coordinates (exactly).
pub fn weld_exact(mesh: &Mesh) -> Mesh {
    let mut index: HashMap<[u64; 3], u32> = HashMap::with_capacity(mesh.vertices.len() / 2);
    let mut map = vec![u32::MAX; mesh.vertices.len()];
    let mut vertices = Vec::new();
    let triangles = mesh
        .triangles
        .iter()
        .map(|t| {
            t.map(|i| {
                let i = i as usize;
                if map[i] == u32::MAX {
                    let v = mesh.vertices[i];
                    let next = u32::try_from(vertices.len()).unwrap_or(u32::MAX);
                    map[i] = *index.entry(key(&v)).or_insert_with(|| {
                        vertices.push(v);
                        next
                    });
                }
                map[i]
            })
        })
        .collect();
    Mesh {
        vertices,
        triangles,
    }
}

/// Merge vertices within `tol` (Euclidean) of a kept vertex, after an exact weld. A `tol`
/// that is not a positive finite number welds exactly.
pub fn weld_within(mesh: &Mesh, tol: f64) -> Mesh {
    let exact = weld_exact(mesh);
    if !(tol.is_finite() && tol > 0.0) {
        return exact;
    }
    let cell = |v: &P3| -> [i64; 3] {
        // `as` saturates: huge coordinates share a cell, which only costs time.
        [
            (v.x / tol).floor() as i64,
            (v.y / tol).floor() as i64,
            (v.z / tol).floor() as i64,
        ]
    };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut vertices: Vec<P3> = Vec::new();
    let mut map = Vec::with_capacity(exact.vertices.len());
    for v in &exact.vertices {
        let c = cell(v);
        let mut found = None;
        'search: for dx in -1..=1i64 {
            for dy in -1..=1i64 {
                for dz in -1..=1i64 {
                    let k = [
                        c[0].saturating_add(dx),
                        c[1].saturating_add(dy),
                        c[2].saturating_add(dz),
                    ];
                    if let Some(list) = grid.get(&k) {
                        for &j in list {
                            if (vertices[j as usize] - v).norm() <= tol {
                                found = Some(j);
                                break 'search;
                            }
                        }
                    }
                }
            }
        }
        let id = match found {
            Some(j) => j,
            None => {
                let j = u32::try_from(vertices.len()).unwrap_or(u32::MAX);
                vertices.push(*v);
                grid.entry(c).or_default().push(j);
                j
            }
        };
        map.push(id);
    }
    Mesh {
        vertices,
        triangles: exact
            .triangles
            .iter()
            .map(|t| t.map(|i| map[i as usize]))
            .collect(),
    }
}
