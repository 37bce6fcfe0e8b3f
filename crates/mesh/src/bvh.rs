//! [`MeshBvh`]: ray casts, closest points and signed distance through parry's `TriMesh`
//! (its bounding-volume hierarchy), in `f64`.

use nalgebra::Vector3;
use parry3d_f64::math::Vector as PV;
use parry3d_f64::query::{PointQuery, PointQueryWithLocation, Ray, RayCast};
use parry3d_f64::shape::{TriMesh, TriMeshFlags};

use crate::{Mesh, P3};

/// Why a BVH could not be built or a query answered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BvhError {
    /// The mesh has no triangles or parry refused it.
    #[error("the mesh cannot be indexed: {0}")]
    Mesh(String),
    /// Signed distance needs a closed, consistently oriented mesh.
    #[error("signed distance needs a closed, consistently oriented mesh ({0})")]
    NotSolid(String),
    /// A query point or direction that is not finite (or a zero direction).
    #[error("{0}")]
    Query(String),
}

/// A ray's first hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Distance along the ray in units of its direction's length.
    pub t: f64,
    /// The point hit.
    pub point: P3,
    /// The triangle hit.
    pub face: u32,
}

/// The closest point of the mesh to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// The point of the mesh.
    pub point: P3,
    /// Its triangle.
    pub face: u32,
    /// Distance from the query point.
    pub distance: f64,
}

/// A mesh indexed for queries.
pub struct MeshBvh {
    tri: TriMesh,
    solid: bool,
}

impl std::fmt::Debug for MeshBvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MeshBvh")
            .field("triangles", &self.tri.indices().len())
            .field("solid", &self.solid)
            .finish()
    }
}

fn pv(v: &P3) -> PV {
    PV::new(v.x, v.y, v.z)
}

fn p3(v: PV) -> P3 {
    Vector3::new(v.x, v.y, v.z)
}

fn finite(v: &P3, what: &str) -> Result<(), BvhError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(BvhError::Query(format!("{what} is not finite")))
    }
}

impl MeshBvh {
    /// Index a welded mesh. Degenerate triangles are kept in the count but never hit.
    pub fn new(mesh: &Mesh) -> Result<MeshBvh, BvhError> {
        if mesh.triangles.is_empty() {
            return Err(BvhError::Mesh("no triangles".into()));
        }
        let report = crate::topo::manifold_report(mesh);
        let solid = report.closed_oriented();
        let verts = mesh.vertices.iter().map(pv).collect();
        let flags = if solid {
            TriMeshFlags::ORIENTED
        } else {
            TriMeshFlags::empty()
        };
        let tri = TriMesh::with_flags(verts, mesh.triangles.clone(), flags)
            .map_err(|e| BvhError::Mesh(e.to_string()))?;
        Ok(MeshBvh { tri, solid })
    }

    /// True when the mesh is closed and consistently oriented (signed distance works).
    pub fn is_solid(&self) -> bool {
        self.solid
    }

    /// The first triangle the ray `origin + t·dir` (t in `[0, max_t]`) meets.
    pub fn ray_cast(&self, origin: P3, dir: P3, max_t: f64) -> Result<Option<RayHit>, BvhError> {
        finite(&origin, "the ray's origin")?;
        finite(&dir, "the ray's direction")?;
        if dir.norm() == 0.0 {
            return Err(BvhError::Query("the ray's direction is zero".into()));
        }
        let ray = Ray::new(pv(&origin), pv(&dir));
        Ok(self
            .tri
            .cast_local_ray_and_get_normal(&ray, max_t, false)
            .map(|h| {
                let point = origin + dir * h.time_of_impact;
                // The hit's feature names the triangle's own face (front or back), not
                // which triangle: the triangle is the one under the hit point.
                let (_, (face, _)) = self
                    .tri
                    .project_local_point_and_get_location(pv(&point), false);
                RayHit {
                    t: h.time_of_impact,
                    point,
                    face,
                }
            }))
    }

    /// The closest point of the mesh's surface.
    pub fn closest(&self, p: P3) -> Result<Closest, BvhError> {
        finite(&p, "the query point")?;
        let (proj, (face, _)) = self.tri.project_local_point_and_get_location(pv(&p), false);
        let point = p3(proj.point);
        Ok(Closest {
            point,
            face,
            distance: (point - p).norm(),
        })
    }

    /// Distance to the surface, negative inside (closed, consistently oriented meshes
    /// only; the sign comes from angle-weighted pseudo-normals at the closest feature).
    pub fn signed_distance(&self, p: P3) -> Result<f64, BvhError> {
        if !self.solid {
            return Err(BvhError::NotSolid(
                "see the manifold report for its bad edges".into(),
            ));
        }
        finite(&p, "the query point")?;
        let proj = self.tri.project_local_point(pv(&p), false);
        let d = (p3(proj.point) - p).norm();
        Ok(if proj.is_inside { -d } else { d })
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_ray_hit_names_the_triangle_it_hit() {
        let m = crate::uv_sphere(crate::P3::new(0.0, 0.0, -10.0), 20.0, 24, 48);
        let bvh = super::MeshBvh::new(&m).expect("bvh");
        let normals = crate::props::face_normals(&m);
        for dir in [
            crate::P3::new(0.3, 0.2, 1.0),
            crate::P3::new(-1.0, 0.1, 0.2),
            crate::P3::new(0.0, -0.4, -1.0),
        ] {
            let d = dir.normalize();
            let o = crate::P3::new(0.0, 0.0, -10.0) + d * 30.0;
            let h = bvh.ray_cast(o, -d, 50.0).expect("query").expect("hit");
            let t = m.triangles[h.face as usize].map(|i| m.vertices[i as usize]);
            // The hit lies in that triangle's plane, which faces the ray.
            let n = normals[h.face as usize];
            assert!(
                (h.point - t[0]).dot(&n).abs() < 1e-9,
                "{dir:?}: face {}",
                h.face
            );
            assert!(n.dot(&d) > 0.9, "{dir:?}: face {}", h.face);
        }
    }
}
