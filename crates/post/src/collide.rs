//! The part as a triangle mesh, for collision checks (`--part`): does a rapid's straight
//! tool-tip path meet the part, does the head (a cylinder along the tool axis) meet it
//! while it moves, and which points bound the part for safe heights.
//!
//! A [`PartMesh`] holds the mesh in the part frame (the caller places it: [`PartMesh::placed`]
//! with a [`Frame`], [`PartMesh::transformed`], [`PartMesh::scaled`] for units), parry's
//! [`TriMesh`] over it (with its bounding-volume hierarchy) and the vertices of its convex
//! hull ([`PartMesh::hull_points`]): the highest point of the part in any direction is one
//! of them, so a safe height over the part is exact for a fixed table position.
//!
//! ## What counts as a hit
//! - The mesh is a surface: touching it counts (contact within `1e-12` of the size of the
//!   scene, see [`PartMesh::tolerance`]). An open or non-manifold mesh (see
//!   [`PartMesh::manifold`]) is only a surface, so a path wholly inside it is not seen.
//! - A closed mesh (every edge shared by an even number of triangles:
//!   [`PartMesh::is_solid`]) is a solid as well: a path or a head that starts inside it hits
//!   at its start (inside is decided by the parity of crossings along a ray, retried in
//!   other directions when a ray grazes an edge, and by the winding number if all do).
//!   A path that starts outside and ends inside crosses the surface, so the surface test
//!   finds it.
//! - A rapid ([`PartMesh::segment_hits`]): the segment against each triangle near it
//!   (parry's BVH picks them), with exact plane-crossing arithmetic and the tolerance on
//!   the triangle's edges; a segment lying in a face's plane is clipped against the face.
//! - The head ([`PartMesh::head_hits`]): parry's shape casting (`query::cast_shapes`) of
//!   a [`Cylinder`] against the [`TriMesh`], i.e. GJK on the cylinder and each nearby
//!   triangle, over the whole straight move; a move of zero length is parry's static
//!   contact query. GJK is iterative: flat contacts (a face against the cylinder's cap or
//!   side) come out exact to 1e-12 of the size, but against the cylinder's curved side a
//!   head clear of an edge by less than about 1e-8 of the size can be reported touching
//!   (seen on the unit cube; the reverse was not seen). `tests/collide_oracle.rs`
//!   compares both queries with trimesh and exact convex distances: no disagreement
//!   outside 1e-6 of the mesh's size.
//!
//! Every input must be finite; anything else is a [`CollideError`]. Degenerate meshes
//! (zero-area triangles, duplicate vertices, a single triangle) are accepted and never
//! panic.

use std::collections::HashMap;

use lampost_mesh::{manifold_report, ManifoldReport, Mesh};
use nalgebra::{Matrix3, Vector3};
use parry3d_f64::math::{Pose, Rotation, Vector as PV};
use parry3d_f64::partitioning::BvhNode;
use parry3d_f64::query::{self, PointQuery, ShapeCastOptions, ShapeCastStatus};
use parry3d_f64::shape::{Cylinder, TriMesh};

use crate::error::PostError;
use crate::frame::Frame;

/// Why a part mesh or a collision query was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CollideError {
    /// A coordinate or parameter is NaN or infinite.
    #[error("part mesh: {what} is not finite")]
    NotFinite {
        /// What (e.g. `vertex 3`, `the head radius`).
        what: String,
    },
    /// A triangle names a vertex that does not exist.
    #[error(
        "part mesh: triangle {triangle} names vertex {index}, but the mesh has {vertices} vertices"
    )]
    BadIndex {
        /// Triangle (0-based).
        triangle: usize,
        /// The index it gives.
        index: u32,
        /// Vertices in the mesh.
        vertices: usize,
    },
    /// The mesh has no triangles.
    #[error("part mesh: the mesh has no triangles")]
    Empty,
    /// A parameter out of its range (head radius, length, standoff, axis, scale).
    #[error("part mesh: {0}")]
    Invalid(String),
}

impl From<CollideError> for PostError {
    fn from(e: CollideError) -> Self {
        PostError::Options(e.to_string())
    }
}

/// Where a path first meets the part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Fraction of the move (0 at its start, 1 at its end) at the first contact.
    pub t: f64,
    /// A point of the part where it is met (part frame): for a rapid, the tool tip there;
    /// for the head, the point of the mesh it touches (for a head that already overlaps
    /// the mesh at the start, a point of the mesh in the overlap as parry's penetration
    /// query gives it, within the overlap's depth of the head; for a head that starts
    /// inside a closed part, the centre of the head's axis).
    pub point: Vector3<f64>,
}

/// A part mesh placed in the part frame, ready for collision checks. See the module
/// documentation for what counts as a hit.
#[derive(Clone)]
pub struct PartMesh {
    vertices: Vec<Vector3<f64>>,
    triangles: Vec<[u32; 3]>,
    tri: TriMesh,
    hull: Vec<Vector3<f64>>,
    report: ManifoldReport,
    solid: bool,
    lo: Vector3<f64>,
    hi: Vector3<f64>,
    scale: f64,
}

impl std::fmt::Debug for PartMesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PartMesh")
            .field("vertices", &self.vertices.len())
            .field("triangles", &self.triangles.len())
            .field("hull_points", &self.hull.len())
            .field("report", &self.report)
            .field("solid", &self.solid)
            .field("lo", &self.lo)
            .field("hi", &self.hi)
            .finish()
    }
}

/// Relative tolerance of contact: `REL · scale`.
const REL: f64 = 1e-12;

fn pv(v: &Vector3<f64>) -> PV {
    PV::new(v.x, v.y, v.z)
}

fn nv(v: PV) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

fn finite(v: &Vector3<f64>, what: impl FnOnce() -> String) -> Result<(), CollideError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(CollideError::NotFinite { what: what() })
    }
}

fn inf_norm(v: &Vector3<f64>) -> f64 {
    v.x.abs().max(v.y.abs()).max(v.z.abs())
}

impl PartMesh {
    /// A part mesh from vertices and triangles (vertex indices), already in the part frame.
    /// Refused: no triangles, an index beyond the vertices, a vertex that is not finite.
    pub fn new(
        vertices: Vec<Vector3<f64>>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<PartMesh, CollideError> {
        if triangles.is_empty() {
            return Err(CollideError::Empty);
        }
        for (i, v) in vertices.iter().enumerate() {
            finite(v, || format!("vertex {i}"))?;
        }
        for (i, t) in triangles.iter().enumerate() {
            if let Some(&bad) = t.iter().find(|&&k| k as usize >= vertices.len()) {
                return Err(CollideError::BadIndex {
                    triangle: i,
                    index: bad,
                    vertices: vertices.len(),
                });
            }
        }
        // Only the vertices the triangles use bound the part.
        let mut used = vec![false; vertices.len()];
        for t in &triangles {
            for &k in t {
                used[k as usize] = true;
            }
        }
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for (v, _) in vertices.iter().zip(&used).filter(|(_, &u)| u) {
            lo = lo.inf(v);
            hi = hi.sup(v);
        }
        let scale = (hi - lo)
            .norm()
            .max(inf_norm(&lo))
            .max(inf_norm(&hi))
            .max(f64::MIN_POSITIVE);

        // Weld equal coordinates for the topology (an unwelded STL still closes).
        let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
        let mut welded_vertices: Vec<Vector3<f64>> = Vec::new();
        let mut canon = vec![u32::MAX; vertices.len()];
        for (i, v) in vertices.iter().enumerate() {
            if !used[i] {
                continue;
            }
            // `+ 0.0` makes -0.0 and 0.0 one key.
            let key = [
                (v.x + 0.0).to_bits(),
                (v.y + 0.0).to_bits(),
                (v.z + 0.0).to_bits(),
            ];
            let next = u32::try_from(welded_vertices.len()).unwrap_or(u32::MAX);
            canon[i] = *ids.entry(key).or_insert_with(|| {
                welded_vertices.push(*v);
                next
            });
        }
        let welded = Mesh {
            vertices: welded_vertices,
            triangles: triangles
                .iter()
                .map(|t| t.map(|k| canon[k as usize]))
                .collect(),
        };
        let report = manifold_report(&welded);
        let solid = even_edges(&welded.triangles);
        let tri = TriMesh::new(vertices.iter().map(pv).collect(), triangles.clone())
            .map_err(|e| CollideError::Invalid(format!("the mesh cannot be used: {e}")))?;
        let hull = hull_points(&welded.vertices, &tri, scale);
        Ok(PartMesh {
            vertices,
            triangles,
            tri,
            hull,
            report,
            solid,
            lo,
            hi,
            scale,
        })
    }

    /// A part mesh from a mesh read by `lampost_mesh::read_stl` (already in the part
    /// frame; see [`PartMesh::placed`]).
    pub fn from_mesh(mesh: &Mesh) -> Result<PartMesh, CollideError> {
        PartMesh::new(mesh.vertices.clone(), mesh.triangles.clone())
    }

    /// This mesh with every vertex multiplied by `factor` (e.g. 1/25.4 for a mesh in mm on
    /// an inch machine). `factor` must be finite and positive.
    pub fn scaled(&self, factor: f64) -> Result<PartMesh, CollideError> {
        if !factor.is_finite() {
            return Err(CollideError::NotFinite {
                what: "the scale factor".into(),
            });
        }
        if factor <= 0.0 {
            return Err(CollideError::Invalid(format!(
                "the scale factor must be positive, not {factor}"
            )));
        }
        PartMesh::new(
            self.vertices.iter().map(|v| v * factor).collect(),
            self.triangles.clone(),
        )
    }

    /// This mesh with every vertex `v` moved to `rotation·v + translation` (normally a
    /// rotation; any finite matrix is taken).
    pub fn transformed(
        &self,
        rotation: &Matrix3<f64>,
        translation: &Vector3<f64>,
    ) -> Result<PartMesh, CollideError> {
        if !rotation.iter().all(|x| x.is_finite()) {
            return Err(CollideError::NotFinite {
                what: "the rotation".into(),
            });
        }
        finite(translation, || "the translation".into())?;
        PartMesh::new(
            self.vertices
                .iter()
                .map(|v| rotation * v + translation)
                .collect(),
            self.triangles.clone(),
        )
    }

    /// This mesh, given in a frame placed on the part by `frame`, in the part frame
    /// (`part = frame.origin + frame.rot·v`).
    pub fn placed(&self, frame: &Frame) -> Result<PartMesh, CollideError> {
        self.transformed(&frame.rot, &frame.origin)
    }

    /// The vertices (as given, part frame).
    pub fn vertices(&self) -> &[Vector3<f64>] {
        &self.vertices
    }

    /// The triangles (as given).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The vertices of the convex hull (part frame): the highest point of the part along
    /// any direction is one of them. For a flat mesh (or if the hull cannot be built, or
    /// does not hold every vertex within the tolerance) these are all the distinct
    /// vertices, which serve the same purpose.
    pub fn hull_points(&self) -> &[Vector3<f64>] {
        &self.hull
    }

    /// Lowest and highest corners of the mesh's axis-aligned box (part frame).
    pub fn bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.lo, self.hi)
    }

    /// How far the mesh is from a closed manifold (after welding equal vertices), as
    /// `lampost_mesh` reports it: the caller warns on an open or non-manifold mesh.
    pub fn manifold(&self) -> &ManifoldReport {
        &self.report
    }

    /// True when every edge is shared by an even number of triangles, so the mesh bounds
    /// a solid and a path inside it counts as a hit. Otherwise the mesh is a surface only.
    pub fn is_solid(&self) -> bool {
        self.solid
    }

    /// The contact tolerance for the mesh alone: `1e-12 ×` the larger of its box's
    /// diagonal and its largest coordinate (queries also count their own coordinates).
    pub fn tolerance(&self) -> f64 {
        REL * self.scale
    }

    fn tol_with(&self, pts: &[&Vector3<f64>]) -> f64 {
        REL * pts.iter().map(|p| inf_norm(p)).fold(self.scale, f64::max)
    }

    /// Triangles whose boxes (grown by `tol`) meet the segment `a → a + d`.
    fn near_segment<'s>(
        &'s self,
        a: &Vector3<f64>,
        d: &Vector3<f64>,
        tol: f64,
    ) -> impl Iterator<Item = u32> + 's {
        let (a, d) = (*a, *d);
        self.tri
            .bvh()
            .leaves(move |n: &BvhNode| segment_meets_box(&a, &d, &nv(n.mins()), &nv(n.maxs()), tol))
    }

    fn corners(&self, i: u32) -> [Vector3<f64>; 3] {
        let t = self.triangles[i as usize];
        t.map(|k| self.vertices[k as usize])
    }

    /// Whether `p` is inside the solid (or on its surface). Only meaningful when
    /// [`PartMesh::is_solid`].
    pub fn contains(&self, p: &Vector3<f64>) -> Result<bool, CollideError> {
        finite(p, || "the point".into())?;
        Ok(self.solid && self.inside(p))
    }

    fn inside(&self, p: &Vector3<f64>) -> bool {
        let tol = self.tol_with(&[p]);
        let reach = (p - (self.lo + self.hi) * 0.5).norm() + (self.hi - self.lo).norm() + 1.0;
        'dirs: for dir in RAY_DIRS {
            let dir = Vector3::from(dir).normalize();
            let d = dir * reach;
            let mut crossings = 0usize;
            for i in self.near_segment(p, &d, tol) {
                let [p0, p1, p2] = self.corners(i);
                let n = (p1 - p0).cross(&(p2 - p0));
                let nn = n.norm();
                let longest = (p1 - p0).norm().max((p2 - p0).norm()).max((p2 - p1).norm());
                if nn <= 1e-14 * longest * longest {
                    // Zero area: no crossing of its own, but a ray through it grazes the
                    // triangles around it.
                    if seg_seg_dist(p, &(p + d), &p0, &p1)
                        .min(seg_seg_dist(p, &(p + d), &p1, &p2))
                        .min(seg_seg_dist(p, &(p + d), &p2, &p0))
                        <= tol
                    {
                        continue 'dirs;
                    }
                    continue;
                }
                let nu = n / nn;
                let s = nu.dot(&(p - p0));
                let den = nu.dot(&dir);
                if s.abs() <= tol {
                    // On the plane: on the triangle means on the surface.
                    if edge_margin(p, &[p0, p1, p2], &nu) >= -tol {
                        return true;
                    }
                }
                if den.abs() < 1e-9 {
                    // Nearly parallel: a crossing within reach would be at a grazing
                    // angle, so try another ray if the plane is that close.
                    if s.abs() <= tol + 1e-9 * reach {
                        continue 'dirs;
                    }
                    continue;
                }
                let t = -s / den;
                if t <= tol {
                    continue;
                }
                let q = p + dir * t;
                let m = edge_margin(&q, &[p0, p1, p2], &nu);
                if m < -tol {
                    continue;
                }
                if m <= tol * 4.0 {
                    continue 'dirs; // through an edge or a vertex: try another ray
                }
                crossings += 1;
            }
            return crossings % 2 == 1;
        }
        // Every ray grazed an edge: the generalised winding number decides.
        let mut w = 0.0;
        for i in 0..self.triangles.len() as u32 {
            let [p0, p1, p2] = self.corners(i);
            let (a, b, c) = (p0 - p, p1 - p, p2 - p);
            let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
            let num = a.dot(&b.cross(&c));
            let den = la * lb * lc + a.dot(&b) * lc + a.dot(&c) * lb + b.dot(&c) * la;
            w += 2.0 * num.atan2(den);
        }
        (w / (4.0 * std::f64::consts::PI)).abs() > 0.5
    }

    /// The first point where the straight tool-tip path `a → b` (part frame, e.g. a rapid)
    /// meets the part, with the fraction of the path there; `None` when it stays clear.
    /// A path starting inside a solid mesh hits at `a`. A zero-length path is a point test.
    pub fn segment_hits(
        &self,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
    ) -> Result<Option<Hit>, CollideError> {
        finite(a, || "the start of the path".into())?;
        finite(b, || "the end of the path".into())?;
        if self.solid && self.inside(a) {
            return Ok(Some(Hit { t: 0.0, point: *a }));
        }
        let d = b - a;
        let tol = self.tol_with(&[a, b]);
        let mut best: Option<f64> = None;
        for i in self.near_segment(a, &d, tol) {
            let tri = self.corners(i);
            if let Some(t) = segment_triangle(a, &d, &tri, tol) {
                if best.is_none_or(|b| t < b) {
                    best = Some(t);
                }
            }
        }
        Ok(best.map(|t| Hit {
            t,
            point: if t == 1.0 { *b } else { a + d * t },
        }))
    }

    /// Whether the head meets the part while its tool tip moves straight from `tip_a` to
    /// `tip_b` with the tool axis fixed: the head is a cylinder of `radius` along `axis`
    /// (tip → head; any non-zero length, it is normalised) from `tip + standoff·axis` to
    /// `tip + length·axis`. Returns the first contact (fraction of the move, a point of the
    /// mesh there), or `None`. A zero-length move is a static test. Refused: a parameter
    /// that is not finite, `radius ≤ 0`, `standoff < 0`, `length ≤ standoff`, a zero axis.
    pub fn head_hits(
        &self,
        tip_a: &Vector3<f64>,
        tip_b: &Vector3<f64>,
        axis: &Vector3<f64>,
        radius: f64,
        length: f64,
        standoff: f64,
    ) -> Result<Option<Hit>, CollideError> {
        finite(tip_a, || "the start of the move".into())?;
        finite(tip_b, || "the end of the move".into())?;
        finite(axis, || "the tool axis".into())?;
        for (v, what) in [
            (radius, "the head radius"),
            (length, "the head length"),
            (standoff, "the head standoff"),
        ] {
            if !v.is_finite() {
                return Err(CollideError::NotFinite { what: what.into() });
            }
        }
        if radius <= 0.0 {
            return Err(CollideError::Invalid(format!(
                "the head radius must be positive, not {radius}"
            )));
        }
        if standoff < 0.0 {
            return Err(CollideError::Invalid(format!(
                "the head standoff must not be negative, not {standoff}"
            )));
        }
        if length <= standoff {
            return Err(CollideError::Invalid(format!(
                "the head length {length} must exceed its standoff {standoff}"
            )));
        }
        let an = axis.norm();
        if an == 0.0 || !an.is_finite() {
            return Err(CollideError::Invalid(
                "the tool axis has zero length".into(),
            ));
        }
        let u = axis / an;
        let half = (length - standoff) / 2.0;
        let centre = tip_a + u * (standoff + half);
        finite(&centre, || "the head's position".into())?;
        if self.solid && self.inside(&centre) {
            return Ok(Some(Hit {
                t: 0.0,
                point: centre,
            }));
        }
        let cyl = Cylinder::new(half, radius);
        let pose = Pose::from_parts(pv(&centre), Rotation::from_rotation_arc(PV::Y, pv(&u)));
        let mesh_pose = Pose::identity();
        let d = tip_b - tip_a;
        let head = Head {
            centre,
            u,
            half,
            radius,
        };
        if d == Vector3::zeros() {
            return match query::contact(&mesh_pose, &self.tri, &pose, &cyl, 0.0) {
                Ok(Some(c)) => Ok(Some(Hit {
                    t: 0.0,
                    point: self.overlap_witness(&head, nv(c.point1)),
                })),
                Ok(None) => Ok(None),
                Err(_) => Err(CollideError::Invalid(
                    "parry cannot test a cylinder against this mesh".into(),
                )),
            };
        }
        let opts = ShapeCastOptions {
            max_time_of_impact: 1.0,
            target_distance: 0.0,
            stop_at_penetration: true,
            compute_impact_geometry_on_penetration: true,
        };
        match query::cast_shapes(&mesh_pose, PV::ZERO, &self.tri, &pose, pv(&d), &cyl, opts) {
            Ok(Some(h)) => {
                let t = h.time_of_impact.clamp(0.0, 1.0);
                let point = if h.status == ShapeCastStatus::PenetratingOrWithinTargetDist {
                    self.overlap_witness(&head, nv(h.witness1))
                } else {
                    nv(h.witness1)
                };
                Ok(Some(Hit { t, point }))
            }
            Ok(None) => Ok(None),
            Err(_) => Err(CollideError::Invalid(
                "parry cannot cast a cylinder against this mesh".into(),
            )),
        }
    }
}

/// The head at the start of a move: a cylinder of `radius` about the unit axis `u`,
/// `half` its half length, centred at `centre`.
struct Head {
    centre: Vector3<f64>,
    u: Vector3<f64>,
    half: f64,
    radius: f64,
}

impl Head {
    /// Signed distance from `p` to the cylinder (negative inside).
    fn sdf(&self, p: &Vector3<f64>) -> f64 {
        let x = p - self.centre;
        let s = x.dot(&self.u);
        let qx = (x - self.u * s).norm() - self.radius;
        let qy = s.abs() - self.half;
        qx.max(qy).min(0.0) + qx.max(0.0).hypot(qy.max(0.0))
    }
}

impl PartMesh {
    /// A point of the mesh as deep in an overlapping head as can cheaply be found: parry's
    /// penetration witness, where the head's axis crosses the mesh, or the mesh's point
    /// nearest the head's centre, whichever lies deepest.
    fn overlap_witness(&self, head: &Head, parry: Vector3<f64>) -> Vector3<f64> {
        let mut best = (head.sdf(&parry), parry);
        let bottom = head.centre - head.u * head.half;
        let axis = head.u * (2.0 * head.half);
        let tol = self.tol_with(&[&bottom, &head.centre]);
        let mut candidates = vec![nv(self
            .tri
            .project_local_point(pv(&head.centre), false)
            .point)];
        for i in self.near_segment(&bottom, &axis, tol) {
            if let Some(t) = segment_triangle(&bottom, &axis, &self.corners(i), tol) {
                candidates.push(bottom + axis * t);
            }
        }
        for c in candidates {
            let d = head.sdf(&c);
            if d < best.0 {
                best = (d, c);
            }
        }
        best.1
    }
}

/// Directions for the inside test's rays (no two alike, none along an axis or a diagonal).
const RAY_DIRS: [[f64; 3]; 8] = [
    [0.254_731, 0.132_057, 0.957_951],
    [-0.613_218, 0.371_551, 0.697_029],
    [0.431_977, -0.803_517, 0.409_634],
    [-0.181_839, -0.285_771, -0.940_866],
    [0.887_191, 0.219_343, -0.405_906],
    [-0.722_837, -0.611_301, 0.322_611],
    [0.067_429, 0.993_107, -0.095_614],
    [-0.951_219, 0.078_313, -0.298_423],
];

/// Every undirected edge (of triangles with three distinct vertices) used an even number of
/// times, and at least one such triangle.
fn even_edges(tris: &[[u32; 3]]) -> bool {
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in tris {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            continue;
        }
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    !edges.is_empty() && edges.values().all(|&c| c % 2 == 0)
}

/// The smallest signed distance of `q` (in the triangle's plane) inside the triangle's
/// edges (positive inside), for the unit normal `nu` of `p0, p1, p2`.
fn edge_margin(q: &Vector3<f64>, t: &[Vector3<f64>; 3], nu: &Vector3<f64>) -> f64 {
    let mut m = f64::INFINITY;
    for i in 0..3 {
        let (p, r) = (t[i], t[(i + 1) % 3]);
        let e = r - p;
        let l = e.norm();
        if l == 0.0 {
            continue;
        }
        let inward = nu.cross(&e) / l;
        m = m.min(inward.dot(&(q - p)));
    }
    m
}

/// Whether the segment `a → a + d` meets the box `[lo, hi]` grown by `tol` (slab test).
fn segment_meets_box(
    a: &Vector3<f64>,
    d: &Vector3<f64>,
    lo: &Vector3<f64>,
    hi: &Vector3<f64>,
    tol: f64,
) -> bool {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..3 {
        let (l, h) = (lo[k] - tol, hi[k] + tol);
        if d[k] == 0.0 {
            if a[k] < l || a[k] > h {
                return false;
            }
            continue;
        }
        let (mut u, mut v) = ((l - a[k]) / d[k], (h - a[k]) / d[k]);
        if u > v {
            std::mem::swap(&mut u, &mut v);
        }
        t0 = t0.max(u);
        t1 = t1.min(v);
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// The earliest fraction `t ∈ [0, 1]` at which `a + t·d` is on the triangle (within `tol`).
fn segment_triangle(
    a: &Vector3<f64>,
    d: &Vector3<f64>,
    tri: &[Vector3<f64>; 3],
    tol: f64,
) -> Option<f64> {
    let [p0, p1, p2] = *tri;
    let n = (p1 - p0).cross(&(p2 - p0));
    let nn = n.norm();
    let longest = (p1 - p0).norm().max((p2 - p0).norm()).max((p2 - p1).norm());
    let b = a + d;
    if nn <= 1e-14 * longest * longest || nn == 0.0 {
        // Zero area: the triangle is a segment (or a point); contact with its edges.
        let mut best: Option<f64> = None;
        for (p, q) in [(p0, p1), (p1, p2), (p2, p0)] {
            let (dist, t) = seg_seg(a, &b, &p, &q);
            if dist <= tol && best.is_none_or(|bt| t < bt) {
                best = Some(t);
            }
        }
        return best;
    }
    let nu = n / nn;
    let sa = nu.dot(&(a - p0));
    let sb = nu.dot(&(b - p0));
    if (sa > tol && sb > tol) || (sa < -tol && sb < -tol) {
        return None;
    }
    if sa.abs() <= tol && sb.abs() <= tol {
        // In the plane: clip the segment by the three edges' inner half-planes.
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for i in 0..3 {
            let (p, r) = (tri[i], tri[(i + 1) % 3]);
            let e = r - p;
            let l = e.norm();
            if l == 0.0 {
                continue;
            }
            let m = nu.cross(&e) / l;
            let g0 = m.dot(&(a - p)) + tol;
            let gd = m.dot(d);
            if gd == 0.0 {
                if g0 < 0.0 {
                    return None;
                }
            } else if gd > 0.0 {
                t0 = t0.max(-g0 / gd);
            } else {
                t1 = t1.min(-g0 / gd);
            }
            if t0 > t1 {
                return None;
            }
        }
        return Some(t0);
    }
    // Crossing the plane (or touching it at an end).
    let t = if sa.abs() <= tol {
        0.0
    } else if sb.abs() <= tol {
        1.0
    } else {
        (sa / (sa - sb)).clamp(0.0, 1.0)
    };
    let q = a + d * t;
    (edge_margin(&q, tri, &nu) >= -tol).then_some(t)
}

/// Distance between segments `p → q` and `r → s`, and the fraction along `p → q` of the
/// closest point (Ericson, Real-Time Collision Detection, 5.1.9).
fn seg_seg(p: &Vector3<f64>, q: &Vector3<f64>, r: &Vector3<f64>, s: &Vector3<f64>) -> (f64, f64) {
    let d1 = q - p;
    let d2 = s - r;
    let w = p - r;
    let a = d1.dot(&d1);
    let e = d2.dot(&d2);
    let f = d2.dot(&w);
    let (sc, tc);
    if a == 0.0 && e == 0.0 {
        return (w.norm(), 0.0);
    }
    if a == 0.0 {
        sc = 0.0;
        tc = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(&w);
        if e == 0.0 {
            tc = 0.0;
            sc = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(&d2);
            let den = a * e - b * b;
            let mut s0 = if den > 0.0 {
                ((b * f - c * e) / den).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t0 = 0.0;
                s0 = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t0 = 1.0;
                s0 = ((b - c) / a).clamp(0.0, 1.0);
            }
            sc = s0;
            tc = t0;
        }
    }
    let c1 = p + d1 * sc;
    let c2 = r + d2 * tc;
    ((c1 - c2).norm(), sc)
}

fn seg_seg_dist(p: &Vector3<f64>, q: &Vector3<f64>, r: &Vector3<f64>, s: &Vector3<f64>) -> f64 {
    seg_seg(p, q, r, s).0
}

/// The vertices of the convex hull of `pts` (parry), or all of them for a flat set, a
/// failed hull or a hull that leaves a vertex of `mesh` outside by more than the
/// tolerance (checked face by face through the mesh's BVH: only boxes reaching beyond a
/// face's plane are opened).
fn hull_points(pts: &[Vector3<f64>], mesh: &TriMesh, scale: f64) -> Vec<Vector3<f64>> {
    let all = || pts.to_vec();
    if pts.len() < 4 || flat(pts, scale) {
        return all();
    }
    let input: Vec<PV> = pts.iter().map(pv).collect();
    let Ok((hv, hi)) = parry3d_f64::transformation::try_convex_hull(&input) else {
        return all();
    };
    if hi.is_empty() || hi.iter().flatten().any(|&k| k as usize >= hv.len()) {
        return all();
    }
    let mut used = vec![false; hv.len()];
    for &k in hi.iter().flatten() {
        used[k as usize] = true;
    }
    let verts: Vec<Vector3<f64>> = hv
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(v, _)| nv(*v))
        .collect();
    // Every point must lie under every face's plane (outward normals from the centroid).
    let c = verts.iter().fold(Vector3::zeros(), |s, v| s + v) / verts.len() as f64;
    let tol = 1e-9 * scale;
    for f in &hi {
        let [a, b, cc] = f.map(|k| nv(hv[k as usize]));
        let n = (b - a).cross(&(cc - a));
        let l = n.norm();
        if l == 0.0 {
            continue;
        }
        let mut n = n / l;
        if n.dot(&(c - a)) > 0.0 {
            n = -n;
        }
        let limit = n.dot(&a) + tol;
        let beyond = |lo: &Vector3<f64>, hi: &Vector3<f64>| {
            (0..3)
                .map(|k| (n[k] * lo[k]).max(n[k] * hi[k]))
                .sum::<f64>()
                > limit
        };
        let mut leaves = mesh
            .bvh()
            .leaves(|node: &BvhNode| beyond(&nv(node.mins()), &nv(node.maxs())));
        if leaves.any(|i| {
            mesh.indices().get(i as usize).is_some_and(|t| {
                t.iter()
                    .any(|&k| n.dot(&nv(mesh.vertices()[k as usize])) > limit)
            })
        }) {
            return all();
        }
    }
    verts
}

/// True when every point lies within `1e-9·scale` of one plane (or line, or point).
fn flat(pts: &[Vector3<f64>], scale: f64) -> bool {
    let tol = 1e-9 * scale;
    let p0 = pts[0];
    let Some(p1) = pts
        .iter()
        .copied()
        .max_by(|a, b| (a - p0).norm().total_cmp(&(b - p0).norm()))
    else {
        return true;
    };
    let e = p1 - p0;
    if e.norm() <= tol {
        return true;
    }
    let Some(p2) = pts.iter().copied().max_by(|a, b| {
        e.cross(&(a - p0))
            .norm()
            .total_cmp(&e.cross(&(b - p0)).norm())
    }) else {
        return true;
    };
    let n = e.cross(&(p2 - p0));
    if n.norm() <= tol * e.norm() {
        return true;
    }
    let n = n.normalize();
    pts.iter().all(|p| n.dot(&(p - p0)).abs() <= tol)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lampost_mesh::box_mesh;

    fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
        Vector3::new(x, y, z)
    }

    fn cube() -> PartMesh {
        PartMesh::from_mesh(&box_mesh(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0))).expect("cube")
    }

    /// The unit cube without its two top triangles.
    fn open_box() -> PartMesh {
        let m = box_mesh(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0));
        let tris: Vec<[u32; 3]> = m
            .triangles
            .iter()
            .copied()
            .filter(|t| !t.iter().all(|&k| m.vertices[k as usize].z == 1.0))
            .collect();
        assert_eq!(tris.len(), 10);
        PartMesh::new(m.vertices, tris).expect("open box")
    }

    fn triangle() -> PartMesh {
        PartMesh::new(
            vec![v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)],
            vec![[0, 1, 2]],
        )
        .expect("triangle")
    }

    fn seg(m: &PartMesh, a: Vector3<f64>, b: Vector3<f64>) -> Option<Hit> {
        m.segment_hits(&a, &b).expect("finite")
    }

    fn close(a: &Vector3<f64>, b: &Vector3<f64>, tol: f64) -> bool {
        (a - b).norm() <= tol
    }

    #[test]
    fn shareable_between_threads() {
        fn send_sync<T: Send + Sync>() {}
        send_sync::<PartMesh>();
        send_sync::<CollideError>();
    }

    #[test]
    fn reports_and_solidity() {
        let c = cube();
        assert!(c.manifold().closed());
        assert!(c.is_solid());
        let o = open_box();
        assert_eq!(o.manifold().boundary_edges, 4);
        assert!(!o.is_solid());
        let t = triangle();
        assert_eq!(t.manifold().boundary_edges, 3);
        assert!(!t.is_solid());
        assert_eq!(c.bounds(), (v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0)));
        assert!(c.tolerance() > 0.0 && c.tolerance() < 1e-11);
    }

    #[test]
    fn cube_segments() {
        let c = cube();
        // Above.
        assert_eq!(seg(&c, v(-1.0, 0.5, 1.5), v(2.0, 0.5, 1.5)), None);
        // Grazing 1e-9 above the top face: clear; 1e-9 below: enters through x = 0.
        assert_eq!(
            seg(&c, v(-1.0, 0.5, 1.0 + 1e-9), v(2.0, 0.5, 1.0 + 1e-9)),
            None
        );
        let h = seg(&c, v(-1.0, 0.5, 1.0 - 1e-9), v(2.0, 0.5, 1.0 - 1e-9)).expect("hit");
        assert!((h.t - 1.0 / 3.0).abs() < 1e-12, "{h:?}");
        assert!(close(&h.point, &v(0.0, 0.5, 1.0 - 1e-9), 1e-12));
        // Sliding along the top face touches it where it begins.
        let h = seg(&c, v(-1.0, 0.5, 1.0), v(2.0, 0.5, 1.0)).expect("hit");
        assert!((h.t - 1.0 / 3.0).abs() < 1e-12, "{h:?}");
        // Straight down through the top face's diagonal (the edge two triangles share).
        let h = seg(&c, v(0.5, 0.5, 2.0), v(0.5, 0.5, -1.0)).expect("hit");
        assert!((h.t - 1.0 / 3.0).abs() < 1e-12);
        assert!(close(&h.point, &v(0.5, 0.5, 1.0), 1e-12));
        // Ending on the surface, and ending 1e-9 short of it.
        let h = seg(&c, v(0.5, 0.5, 2.0), v(0.5, 0.5, 1.0)).expect("hit");
        assert_eq!(h.t, 1.0);
        assert_eq!(seg(&c, v(0.5, 0.5, 2.0), v(0.5, 0.5, 1.0 + 1e-9)), None);
        // Through a vertical edge exactly.
        let h = seg(&c, v(-1.0, -1.0, 0.5), v(1.0, 1.0, 0.5)).expect("hit");
        assert!((h.t - 0.5).abs() < 1e-12);
        // Past the vertical edge at the origin on the line x + y = -1e-9 (a miss), and
        // across its corner on x + y = 1e-9.
        let e = 1e-9;
        assert_eq!(seg(&c, v(-1.0, 1.0 - e, 0.5), v(1.0 - e, -1.0, 0.5)), None);
        assert!(seg(&c, v(-1.0, 1.0 + e, 0.5), v(1.0 + e, -1.0, 0.5)).is_some());
        // Starting inside (and wholly inside): hit at the start.
        let h = seg(&c, v(0.5, 0.5, 0.5), v(3.0, 0.5, 0.5)).expect("hit");
        assert_eq!((h.t, h.point), (0.0, v(0.5, 0.5, 0.5)));
        let h = seg(&c, v(0.2, 0.3, 0.4), v(0.6, 0.7, 0.8)).expect("hit");
        assert_eq!(h.t, 0.0);
        // Zero length: outside, on the surface, inside.
        assert_eq!(seg(&c, v(2.0, 2.0, 2.0), v(2.0, 2.0, 2.0)), None);
        assert!(seg(&c, v(1.0, 0.5, 0.5), v(1.0, 0.5, 0.5)).is_some());
        assert!(seg(&c, v(0.5, 0.5, 0.5), v(0.5, 0.5, 0.5)).is_some());
        // Starting outside and ending inside: where it enters.
        let h = seg(&c, v(0.5, -1.0, 0.5), v(0.5, 0.5, 0.5)).expect("hit");
        assert!((h.t - 2.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn contains_on_cube() {
        let c = cube();
        assert!(c.contains(&v(0.5, 0.5, 0.5)).expect("finite"));
        assert!(c.contains(&v(1e-9, 1e-9, 1e-9)).expect("finite"));
        assert!(!c.contains(&v(-1e-9, 0.5, 0.5)).expect("finite"));
        assert!(c.contains(&v(0.0, 0.0, 0.0)).expect("finite")); // a vertex: on the surface
        assert!(c.contains(&v(0.5, 0.5, 1.0)).expect("finite"));
        assert!(!c.contains(&v(5.0, 5.0, 5.0)).expect("finite"));
        assert!(!open_box().contains(&v(0.5, 0.5, 0.5)).expect("finite"));
        // Rays through edges and vertices from points on the diagonals retry elsewhere.
        for k in 1..20 {
            let s = k as f64 / 20.0;
            assert!(c.contains(&v(s, s, s)).expect("finite"));
            assert!(c.contains(&v(s, 0.5, s)).expect("finite"));
            assert!(!c.contains(&v(s + 1.0, s, s)).expect("finite"));
        }
    }

    #[test]
    fn open_box_is_a_surface() {
        let o = open_box();
        // Down through the missing top, ending inside: nothing met.
        assert_eq!(seg(&o, v(0.5, 0.5, 2.0), v(0.5, 0.5, 0.5)), None);
        // On through the bottom.
        let h = seg(&o, v(0.5, 0.5, 2.0), v(0.5, 0.5, -1.0)).expect("hit");
        assert!((h.t - 2.0 / 3.0).abs() < 1e-12);
        assert!(close(&h.point, &v(0.5, 0.5, 0.0), 1e-12));
        // From inside out through a wall.
        let h = seg(&o, v(0.5, 0.5, 0.5), v(2.0, 0.5, 0.5)).expect("hit");
        assert!((h.t - 1.0 / 3.0).abs() < 1e-12);
        // Inside, touching nothing.
        assert_eq!(seg(&o, v(0.2, 0.5, 0.5), v(0.8, 0.5, 0.9)), None);
        // A head standing in the opening without touching the walls.
        assert_eq!(
            o.head_hits(
                &v(0.5, 0.5, 0.5),
                &v(0.5, 0.5, 0.6),
                &Vector3::z(),
                0.2,
                2.0,
                0.1
            )
            .expect("ok"),
            None
        );
        // A head too wide for it.
        assert!(o
            .head_hits(
                &v(0.5, 0.5, 0.5),
                &v(0.5, 0.5, 0.6),
                &Vector3::z(),
                0.6,
                2.0,
                0.1
            )
            .expect("ok")
            .is_some());
    }

    #[test]
    fn single_triangle_segments() {
        let t = triangle();
        let e = 1e-9;
        // Crossing inside, and 1e-9 outside the hypotenuse x + y = 1.
        assert!(seg(&t, v(0.25, 0.25, 1.0), v(0.25, 0.25, -1.0)).is_some());
        let h = 0.5 + e;
        assert_eq!(seg(&t, v(h, h, 1.0), v(h, h, -1.0)), None);
        let h = 0.5 - e;
        assert!(seg(&t, v(h, h, 1.0), v(h, h, -1.0)).is_some());
        // Both sides count (a surface).
        assert!(seg(&t, v(0.25, 0.25, -1.0), v(0.25, 0.25, 1.0)).is_some());
        // In its plane: clipped, first contact where it enters.
        let h = seg(&t, v(-1.0, 0.25, 0.0), v(1.0, 0.25, 0.0)).expect("hit");
        assert!((h.t - 0.5).abs() < 1e-12);
        assert_eq!(seg(&t, v(-1.0, 0.25, e), v(1.0, 0.25, e)), None);
        assert_eq!(seg(&t, v(-1.0, 2.0, 0.0), v(2.0, 2.0, 0.0)), None);
        // Missing beside it.
        assert_eq!(seg(&t, v(2.0, 2.0, 1.0), v(2.0, 2.0, -1.0)), None);
        assert_eq!(t.hull_points().len(), 3);
    }

    #[test]
    fn heads_on_cube() {
        let c = cube();
        let z = Vector3::z();
        let (r, len, so) = (0.2, 2.0, 0.1);
        let hh = |a: Vector3<f64>, b: Vector3<f64>, axis: Vector3<f64>| {
            c.head_hits(&a, &b, &axis, r, len, so).expect("ok")
        };
        // Beside: the cylinder spans x in [1.3, 1.7].
        assert_eq!(hh(v(1.5, 0.5, 0.5), v(1.5, 0.5, 0.5), z), None);
        assert_eq!(hh(v(1.5, -1.0, 0.5), v(1.5, 2.0, 0.5), z), None);
        // 1e-9 beside the side face, and 1e-9 into it (flat contacts are exact).
        assert_eq!(
            hh(v(1.2 + 1e-9, 0.5, 0.5), v(1.2 + 1e-9, 0.5, 0.5), z),
            None
        );
        assert!(hh(v(1.2 - 1e-9, 0.5, 0.5), v(1.2 - 1e-9, 0.5, 0.5), z).is_some());
        assert_eq!(hh(v(0.5, 0.5, 2.0), v(0.5, 0.5, 0.9 + 1e-9), z), None);
        assert!(hh(v(0.5, 0.5, 2.0), v(0.5, 0.5, 0.9 - 1e-9), z).is_some());
        // 1e-6 beside, and 1e-6 into the side face.
        assert_eq!(
            hh(v(1.2 + 1e-6, 0.5, 0.5), v(1.2 + 1e-6, 0.5, 0.5), z),
            None
        );
        assert_eq!(
            hh(v(1.2 + 1e-6, -1.0, 0.5), v(1.2 + 1e-6, 2.0, 0.5), z),
            None
        );
        assert!(hh(v(1.2 - 1e-6, 0.5, 0.5), v(1.2 - 1e-6, 0.5, 0.5), z).is_some());
        assert!(hh(v(1.2 - 1e-6, -1.0, 0.5), v(1.2 - 1e-6, 2.0, 0.5), z).is_some());
        // Above the top face (its bottom 0.1 above the tip), standing and travelling.
        assert_eq!(hh(v(0.5, 0.5, 1.0), v(0.5, 0.5, 1.0), z), None);
        assert_eq!(hh(v(-1.0, 0.5, 1.0), v(2.0, 0.5, 1.0), z), None);
        assert_eq!(
            hh(v(0.5, 0.5, 1.0 - 0.1 + 1e-6), v(3.0, 2.0, 0.9 + 1e-6), z),
            None
        );
        // Coming down onto it: the head's bottom meets z = 1 when the tip is at 0.9.
        let h = hh(v(0.5, 0.5, 2.0), v(0.5, 0.5, 0.85), z).expect("hit");
        assert!((h.t - 1.1 / 1.15).abs() < 1e-6, "{h:?}");
        assert!((h.point.z - 1.0).abs() < 1e-6, "{h:?}");
        assert_eq!(hh(v(0.5, 0.5, 2.0), v(0.5, 0.5, 0.95), z), None);
        // Touching at the start (tip 0.1 under the top face, bottom on it).
        assert!(hh(v(0.5, 0.5, 0.9 - 1e-6), v(0.5, 0.5, 0.9 - 1e-6), z).is_some());
        // Sideways into the cube with a tilted axis.
        let axis = v(1.0, 0.0, 1.0);
        assert!(hh(v(-1.0, 0.5, 0.5), v(0.5, 0.5, 0.5), axis).is_some());
        // The same axis, far away.
        assert_eq!(hh(v(-3.0, 0.5, 0.5), v(-3.0, 3.0, 0.5), axis), None);
        // A head standing wholly inside a large solid.
        let big = c.scaled(100.0).expect("scaled");
        let h = big
            .head_hits(&v(50.0, 50.0, 10.0), &v(50.0, 50.0, 10.0), &z, r, len, so)
            .expect("ok")
            .expect("inside");
        assert_eq!(h.t, 0.0);
        // A small triangle wholly inside the head.
        let tiny = PartMesh::new(
            vec![v(0.0, 0.0, 1.0), v(0.01, 0.0, 1.0), v(0.0, 0.01, 1.0)],
            vec![[0, 1, 2]],
        )
        .expect("tiny");
        assert!(tiny
            .head_hits(&Vector3::zeros(), &Vector3::zeros(), &z, r, len, so)
            .expect("ok")
            .is_some());
        assert_eq!(
            tiny.head_hits(&v(1.0, 0.0, 0.0), &v(1.0, 0.0, 0.0), &z, r, len, so)
                .expect("ok"),
            None
        );
    }

    #[test]
    fn refusals() {
        let c = cube();
        let z = Vector3::z();
        let nan = v(f64::NAN, 0.0, 0.0);
        let o = Vector3::zeros();
        assert!(matches!(
            c.segment_hits(&nan, &o),
            Err(CollideError::NotFinite { .. })
        ));
        assert!(matches!(
            c.segment_hits(&o, &v(0.0, f64::INFINITY, 0.0)),
            Err(CollideError::NotFinite { .. })
        ));
        assert!(c.contains(&nan).is_err());
        assert!(c.head_hits(&nan, &o, &z, 1.0, 2.0, 0.0).is_err());
        assert!(c.head_hits(&o, &o, &nan, 1.0, 2.0, 0.0).is_err());
        assert!(c.head_hits(&o, &o, &z, f64::NAN, 2.0, 0.0).is_err());
        assert!(c.head_hits(&o, &o, &z, 1.0, f64::INFINITY, 0.0).is_err());
        assert!(matches!(
            c.head_hits(&o, &o, &z, 0.0, 2.0, 0.0),
            Err(CollideError::Invalid(_))
        ));
        assert!(c.head_hits(&o, &o, &z, 1.0, 2.0, -0.1).is_err());
        assert!(c.head_hits(&o, &o, &z, 1.0, 2.0, 2.0).is_err());
        assert!(c.head_hits(&o, &o, &o, 1.0, 2.0, 0.0).is_err());
        assert!(c
            .head_hits(&o, &o, &v(1e300, 1e300, 1e300), 1.0, 2.0, 0.0)
            .is_err());
        assert_eq!(
            PartMesh::new(vec![o], vec![]).map(|_| ()),
            Err(CollideError::Empty)
        );
        assert!(matches!(
            PartMesh::new(vec![o, z], vec![[0, 1, 2]]),
            Err(CollideError::BadIndex { index: 2, .. })
        ));
        assert!(matches!(
            PartMesh::new(vec![o, z, nan], vec![[0, 1, 2]]),
            Err(CollideError::NotFinite { .. })
        ));
        assert!(c.scaled(0.0).is_err());
        assert!(c.scaled(f64::NAN).is_err());
        assert!(c.transformed(&Matrix3::from_element(f64::NAN), &o).is_err());
        assert!(c.transformed(&Matrix3::identity(), &nan).is_err());
        let e: PostError = CollideError::Empty.into();
        assert!(e.to_string().contains("no triangles"));
    }

    #[test]
    fn degenerate_meshes() {
        let z = Vector3::z();
        // Collinear vertices: a zero-area triangle, met only on its line.
        let line = PartMesh::new(
            vec![v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(2.0, 0.0, 0.0)],
            vec![[0, 1, 2]],
        )
        .expect("line");
        assert!(!line.is_solid());
        assert!(seg(&line, v(0.5, -1.0, 0.0), v(0.5, 1.0, 0.0)).is_some());
        assert_eq!(seg(&line, v(0.5, -1.0, 1e-9), v(0.5, 1.0, 1e-9)), None);
        assert!(line
            .head_hits(&v(1.0, 0.0, -0.5), &v(1.0, 0.0, -0.5), &z, 0.1, 1.0, 0.0)
            .expect("ok")
            .is_some());
        assert_eq!(line.hull_points().len(), 3);
        // A repeated index, and every vertex the same point.
        let dot =
            PartMesh::new(vec![v(1.0, 1.0, 1.0); 3], vec![[0, 0, 1], [0, 1, 2]]).expect("dot");
        assert_eq!(dot.manifold().degenerate_triangles, 2); // welded: one point
        assert!(seg(&dot, v(0.0, 0.0, 0.0), v(2.0, 2.0, 2.0)).is_some());
        assert_eq!(seg(&dot, v(0.0, 0.0, 0.0), v(2.0, 2.0, 2.5)), None);
        assert!(dot
            .head_hits(&v(1.0, 1.0, 0.0), &v(1.0, 1.0, 0.0), &z, 0.1, 2.0, 0.0)
            .expect("ok")
            .is_some());
        assert_eq!(
            dot.head_hits(&v(2.0, 1.0, 0.0), &v(2.0, 1.0, 0.0), &z, 0.1, 2.0, 0.0)
                .expect("ok"),
            None
        );
        // An unwelded cube (every triangle with its own three vertices) plus a
        // zero-area sliver is still closed and solid, and behaves as the cube.
        let m = box_mesh(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0));
        let mut verts = Vec::new();
        let mut tris = Vec::new();
        for t in &m.triangles {
            let base = verts.len() as u32;
            verts.extend(t.iter().map(|&k| m.vertices[k as usize]));
            tris.push([base, base + 1, base + 2]);
        }
        let c = PartMesh::new(verts, tris).expect("unwelded");
        assert!(c.is_solid());
        assert!(c.manifold().closed());
        assert!(c.contains(&v(0.5, 0.5, 0.5)).expect("finite"));
        assert!(seg(&c, v(0.5, 0.5, 2.0), v(0.5, 0.5, -1.0)).is_some());
        assert_eq!(c.hull_points().len(), 8);
    }

    #[test]
    fn hull_and_placement() {
        let c = cube();
        assert_eq!(c.hull_points().len(), 8);
        // Extra vertices inside the faces and inside the cube are not hull points.
        let m = box_mesh(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0));
        let mut verts = m.vertices.clone();
        verts.push(v(0.5, 0.5, 1.0));
        verts.push(v(0.3, 0.4, 0.5));
        let mut tris = m.triangles.clone();
        tris.push([8, 9, 0]);
        let p = PartMesh::new(verts.clone(), tris).expect("mesh");
        let hp = p.hull_points();
        // Whatever the hull keeps, the highest point in every direction is among them.
        for k in 0..200 {
            let a = k as f64 * 0.731;
            let b = k as f64 * 0.377;
            let dir = v(a.cos() * b.sin(), a.sin() * b.sin(), b.cos());
            let top = verts.iter().map(|q| dir.dot(q)).fold(f64::MIN, f64::max);
            let hull_top = hp.iter().map(|q| dir.dot(q)).fold(f64::MIN, f64::max);
            assert!((top - hull_top).abs() < 1e-9, "{dir:?}");
        }
        assert!(hp.len() < verts.len());
        // Placement: scale, turn, move.
        let s = c.scaled(25.4).expect("scaled");
        assert_eq!(s.bounds().1, v(25.4, 25.4, 25.4));
        let rot = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), 0.5).into_inner();
        let t = c.transformed(&rot, &v(10.0, 0.0, 0.0)).expect("moved");
        let centre = rot * v(0.5, 0.5, 0.5) + v(10.0, 0.0, 0.0);
        assert!(t.contains(&centre).expect("finite"));
        assert!(!t.contains(&v(0.5, 0.5, 0.5)).expect("finite"));
        let f = Frame::from_axes(v(0.0, 0.0, 5.0), Vector3::x(), Vector3::z()).expect("frame");
        let pl = c.placed(&f).expect("placed");
        assert_eq!(pl.bounds(), (v(0.0, 0.0, 5.0), v(1.0, 1.0, 6.0)));
        assert_eq!(pl.hull_points().len(), 8);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

        /// Triangle soups with repeated and collinear points: no panic, and the BVH's
        /// pruning loses no contact (the same answer as every triangle tried in turn).
        #[test]
        fn soups_never_panic_and_pruning_is_exact(
            pts in proptest::collection::vec((0i32..4, 0i32..4, 0i32..4), 3..12),
            tris in proptest::collection::vec((0usize..12, 0usize..12, 0usize..12), 1..10),
            a in (-1.0f64..5.0, -1.0f64..5.0, -1.0f64..5.0),
            b in (-1.0f64..5.0, -1.0f64..5.0, -1.0f64..5.0),
            r in 0.01f64..2.0,
        ) {
            let verts: Vec<Vector3<f64>> =
                pts.iter().map(|&(x, y, z)| v(x as f64, y as f64, z as f64)).collect();
            let n = verts.len();
            let tris: Vec<[u32; 3]> = tris
                .iter()
                .map(|&(i, j, k)| [(i % n) as u32, (j % n) as u32, (k % n) as u32])
                .collect();
            let m = PartMesh::new(verts, tris).expect("valid soup");
            let (a, b) = (v(a.0, a.1, a.2), v(b.0, b.1, b.2));
            let got = m.segment_hits(&a, &b).expect("finite");
            let tol = m.tol_with(&[&a, &b]);
            let inside = m.is_solid() && m.inside(&a);
            let brute = if inside {
                Some(0.0)
            } else {
                (0..m.triangles.len() as u32)
                    .filter_map(|i| segment_triangle(&a, &(b - a), &m.corners(i), tol))
                    .reduce(f64::min)
            };
            proptest::prop_assert_eq!(got.map(|h| h.t), brute);
            let _ = m.head_hits(&a, &b, &v(0.2, -0.3, 1.0), r, 3.0, 0.1).expect("valid head");
            let _ = m.hull_points();
        }
    }
}
