//! # lampost-mesh
//!
//! Triangle meshes shared by `align` (registration), `post` (the part for collision
//! checks) and `plan` (slicing): readers for STL (ASCII and binary), OBJ, OFF and 3MF with
//! located errors ([`MeshError`]), welding ([`weld_exact`], [`weld_within`]), the closed-manifold report naming
//! the bad edges ([`manifold_report`]), area, volume and normals ([`props`]), ray casts, closest
//! points and signed distance on a bounding-volume hierarchy ([`bvh`], parry3d's), and
//! closest points and signed distances of many points at once, the deviations of a whole
//! measurement, on an index of its own ([`dist::DistIndex`]: `inspect compare`'s).
//!
//! ## Why these dependencies
//! - `nalgebra`: the `f64` vectors every lampost crate uses;
//! - `parry3d-f64`: the BVH and its triangle queries, in `f64`;
//! - `thiserror`: the typed [`MeshError`] and [`bvh::BvhError`];
//! - `roxmltree`: 3MF's model XML, with line and column for every refusal (the ZIP
//!   package and its DEFLATE data are read here, [`read_3mf`]).

pub mod bvh;
pub mod dist;
mod error;
pub mod props;
mod read;
mod threemf;
mod topo;
mod weld;

pub use error::{MeshError, Pos};
pub use read::{read, read_obj, read_off, read_stl, Format};
pub use threemf::{read_3mf, ThreeMf, MAX_PART, MAX_WORK};
pub use topo::{manifold_report, BadEdge, EdgeProblem, ManifoldReport};
pub use weld::{weld_exact, weld_within};

/// A point or vector (`f64`).
pub type P3 = nalgebra::Vector3<f64>;

/// A triangle mesh: vertices and triangles as vertex indices (counter-clockwise seen from
/// outside for a solid).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Mesh {
    /// Vertices (welded when a reader made the mesh).
    pub vertices: Vec<P3>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// The mesh with every vertex multiplied by `factor` (units).
    pub fn scaled(&self, factor: f64) -> Mesh {
        Mesh {
            vertices: self.vertices.iter().map(|v| v * factor).collect(),
            triangles: self.triangles.clone(),
        }
    }
}

/// Length units of a mesh file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Units {
    /// Millimetres.
    Mm,
    /// Inches.
    In,
    /// Metres (Blender's, a robot's CAD).
    M,
}

impl Units {
    /// Millimetres per unit.
    pub fn to_mm(self) -> f64 {
        match self {
            Units::Mm => 1.0,
            Units::In => 25.4,
            Units::M => 1000.0,
        }
    }

    /// `mm`, `in` or `m`.
    pub fn name(self) -> &'static str {
        match self {
            Units::Mm => "mm",
            Units::In => "in",
            Units::M => "m",
        }
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

/// An OFF file of a mesh (full precision; used by tests and the trimesh oracle).
pub fn write_off(mesh: &Mesh) -> String {
    let mut s = format!("OFF\n{} {} 0\n", mesh.vertices.len(), mesh.triangles.len());
    for v in &mesh.vertices {
        s.push_str(&format!("{:?} {:?} {:?}\n", v.x, v.y, v.z));
    }
    for t in &mesh.triangles {
        s.push_str(&format!("3 {} {} {}\n", t[0], t[1], t[2]));
    }
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

/// A UV sphere of radius `r` about `c`: `rings` bands from pole to pole, `segments`
/// around (closed, outward). Its vertices lie on the sphere; a slice at height `z` is a
/// polygon inscribed in the circle of radius `sqrt(r² − z²)` only at ring heights, and
/// within the chordal error `r(1 − cos(π/segments))` … `r(1 − cos(π/rings))` elsewhere.
pub fn uv_sphere(c: P3, r: f64, rings: u32, segments: u32) -> Mesh {
    let rings = rings.max(2);
    let segments = segments.max(3);
    let mut vertices = vec![c + P3::new(0.0, 0.0, -r)];
    for i in 1..rings {
        let th = std::f64::consts::PI * f64::from(i) / f64::from(rings);
        let (z, rr) = (-r * th.cos(), r * th.sin());
        for j in 0..segments {
            let ph = 2.0 * std::f64::consts::PI * f64::from(j) / f64::from(segments);
            vertices.push(c + P3::new(rr * ph.cos(), rr * ph.sin(), z));
        }
    }
    vertices.push(c + P3::new(0.0, 0.0, r));
    let top = u32::try_from(vertices.len() - 1).unwrap_or(u32::MAX);
    let ring = |i: u32, j: u32| 1 + (i - 1) * segments + (j % segments);
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(1, j + 1), ring(1, j)]);
        triangles.push([top, ring(rings - 1, j), ring(rings - 1, j + 1)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            let (a, b, c2, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j),
                ring(i + 1, j + 1),
            );
            triangles.push([a, b, d]);
            triangles.push([a, d, c2]);
        }
    }
    Mesh {
        vertices,
        triangles,
    }
}

/// A torus about the z axis through `c`: tube radius `r` at distance `big_r` from the
/// axis, `n` segments around the axis and `m` around the tube (closed, outward).
pub fn torus(c: P3, big_r: f64, r: f64, n: u32, m: u32) -> Mesh {
    let (n, m) = (n.max(3), m.max(3));
    let mut vertices = Vec::new();
    for i in 0..n {
        let u = 2.0 * std::f64::consts::PI * f64::from(i) / f64::from(n);
        for j in 0..m {
            let v = 2.0 * std::f64::consts::PI * f64::from(j) / f64::from(m);
            let rr = big_r + r * v.cos();
            vertices.push(c + P3::new(rr * u.cos(), rr * u.sin(), r * v.sin()));
        }
    }
    let id = |i: u32, j: u32| (i % n) * m + (j % m);
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (a, b, c2, d) = (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
            triangles.push([a, b, d]);
            triangles.push([a, d, c2]);
        }
    }
    Mesh {
        vertices,
        triangles,
    }
}
