//! Measures of a mesh: bounding box, area, enclosed volume, face normals and angle-weighted
//! vertex normals.

use crate::{Mesh, P3};

/// The corners of a triangle.
fn corners(mesh: &Mesh, t: &[u32; 3]) -> [P3; 3] {
    t.map(|i| mesh.vertices[i as usize])
}

/// Lowest and highest coordinates of the vertices the triangles use (`None` without
/// triangles).
pub fn bounds(mesh: &Mesh) -> Option<(P3, P3)> {
    let mut it = mesh.triangles.iter().flatten();
    let first = mesh.vertices[*it.next()? as usize];
    let (mut lo, mut hi) = (first, first);
    for &i in it {
        let v = &mesh.vertices[i as usize];
        lo = lo.inf(v);
        hi = hi.sup(v);
    }
    Some((lo, hi))
}

/// Total surface area.
pub fn area(mesh: &Mesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = corners(mesh, t);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .sum()
}

/// Signed enclosed volume (divergence theorem, about the bounding box's centre to keep
/// precision far from the origin): positive for a closed mesh with outward (counter-
/// clockwise seen from outside) triangles, negative when it is inside out. Meaningful only
/// for a closed mesh.
pub fn volume(mesh: &Mesh) -> f64 {
    let Some((lo, hi)) = bounds(mesh) else {
        return 0.0;
    };
    let o = (lo + hi) * 0.5;
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = corners(mesh, t);
            (a - o).dot(&(b - o).cross(&(c - o)))
        })
        .sum::<f64>()
        / 6.0
}

/// Unit normal of each triangle (right-hand rule over its corners); zero for a degenerate
/// triangle.
pub fn face_normals(mesh: &Mesh) -> Vec<P3> {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = corners(mesh, t);
            let n = (b - a).cross(&(c - a));
            let l = n.norm();
            if l > 0.0 && l.is_finite() {
                n / l
            } else {
                P3::zeros()
            }
        })
        .collect()
}

/// Angle-weighted vertex normals (Thürmer–Wüthrich): each triangle adds its unit normal
/// times its corner angle at the vertex. Zero for a vertex no triangle uses (or whose
/// weights cancel).
pub fn vertex_normals(mesh: &Mesh) -> Vec<P3> {
    let fnorm = face_normals(mesh);
    let mut out = vec![P3::zeros(); mesh.vertices.len()];
    for (t, n) in mesh.triangles.iter().zip(&fnorm) {
        let p = corners(mesh, t);
        for k in 0..3 {
            let e1 = p[(k + 1) % 3] - p[k];
            let e2 = p[(k + 2) % 3] - p[k];
            let angle = e1.cross(&e2).norm().atan2(e1.dot(&e2));
            out[t[k] as usize] += n * angle;
        }
    }
    for v in &mut out {
        let l = v.norm();
        if l > 0.0 {
            *v /= l;
        }
    }
    out
}
