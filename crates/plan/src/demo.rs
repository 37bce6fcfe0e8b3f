//! Paper 001's demonstration part: a 60 cm × 20 cm rectangle twisted 90° about one of
//! its long edges, made a closed thin wall.
//!
//! The long edge lies on the substrate along x (centred on the origin), the build
//! direction is +z. At `x` the face leans `ψ(x)` from the build direction in the y–z
//! plane, `ψ` running linearly from −45° at one end to +45° at the other (a 90° twist about
//! the edge, set up symmetric so that no layer leans more than 45°): the face's point at
//! distance `v` from the edge is `(x, v·sin ψ, v·cos ψ)`. The wall is the set of points
//! shifted from the face along y by at most `t / (2 cos ψ)` (a thickness `t` across
//! the face in the y–z plane), so its bottom lies flat on the substrate (z = 0). The mesh
//! is closed and oriented outward (two faces, the bottom and top strips and the two end
//! caps sharing their vertices).

use lampost_mesh::{Mesh, P3};

/// The full-size part's length (mm).
pub const LENGTH: f64 = 600.0;
/// The full-size part's width, the distance from the twisting edge (mm).
pub const WIDTH: f64 = 200.0;

/// The most quads the demo plate is made of (along × across): about 1.5 M triangles and
/// a few hundred MB; 1000 × 1000 took 1.3 GB and 10⁵ × 10⁵ asked 480 GB.
pub const MAX_QUADS: usize = 250_000;

/// The twisted plate, `LENGTH × WIDTH` times `scale`, wall thickness `thickness` (mm),
/// `nu` quads along the edge and `nv` across (at most [`MAX_QUADS`] in all); `None` for
/// non-positive or non-finite sizes, no quads or too many.
pub fn twisted_plate(scale: f64, thickness: f64, nu: usize, nv: usize) -> Option<Mesh> {
    if !(scale.is_finite() && scale > 0.0 && thickness.is_finite() && thickness > 0.0)
        || nu == 0
        || nv == 0
        || nu > 100_000
        || nv > 100_000
        || nu.saturating_mul(nv) > MAX_QUADS
    {
        return None;
    }
    let (len, width) = (LENGTH * scale, WIDTH * scale);
    let row = nv + 1;
    let side = (nu + 1) * row;
    let mut vertices = Vec::with_capacity(2 * side);
    for s in [1.0, -1.0] {
        for i in 0..=nu {
            let x = -len / 2.0 + len * i as f64 / nu as f64;
            let psi = (-45.0 + 90.0 * i as f64 / nu as f64).to_radians();
            let (sn, cs) = psi.sin_cos();
            for j in 0..=nv {
                let v = width * j as f64 / nv as f64;
                vertices.push(P3::new(x, v * sn + s * thickness / (2.0 * cs), v * cs));
            }
        }
    }
    let f = |i: usize, j: usize| (i * row + j) as u32;
    let b = |i: usize, j: usize| (side + i * row + j) as u32;
    let mut triangles = Vec::with_capacity(4 * nu * nv + 4 * (nu + nv));
    // A quad a-b-c-d (counter-clockwise seen from outside) as two triangles.
    let mut quad = |a: u32, b: u32, c: u32, d: u32| {
        triangles.push([a, b, c]);
        triangles.push([a, c, d]);
    };
    for i in 0..nu {
        for j in 0..nv {
            // Front (+y): seen from +y, x grows to the left... order chosen so the
            // normal points to +y.
            quad(f(i, j), f(i, j + 1), f(i + 1, j + 1), f(i + 1, j));
            quad(b(i, j), b(i + 1, j), b(i + 1, j + 1), b(i, j + 1));
        }
        // Bottom (v = 0) facing −z, top (v = width) facing +z.
        quad(f(i, 0), f(i + 1, 0), b(i + 1, 0), b(i, 0));
        quad(f(i, nv), b(i, nv), b(i + 1, nv), f(i + 1, nv));
    }
    for j in 0..nv {
        // End caps: x = −len/2 facing −x, x = +len/2 facing +x.
        quad(f(0, j), b(0, j), b(0, j + 1), f(0, j + 1));
        quad(f(nu, j), f(nu, j + 1), b(nu, j + 1), b(nu, j));
    }
    let mesh = Mesh {
        vertices,
        triangles,
    };
    // Outward by construction; turned if the sign convention above is off.
    Some(if lampost_mesh::props::volume(&mesh) < 0.0 {
        Mesh {
            triangles: mesh.triangles.iter().map(|t| [t[0], t[2], t[1]]).collect(),
            vertices: mesh.vertices,
        }
    } else {
        mesh
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plate_is_a_closed_outward_thin_wall_of_the_right_volume() {
        let m = twisted_plate(1.0, 3.0, 120, 20).expect("plate");
        let report = lampost_mesh::manifold_report(&m);
        assert!(report.closed_oriented(), "{report:?}");
        let vol = lampost_mesh::props::volume(&m);
        // Thickness across the face × its area (the twist adds under 0.1 %).
        let want = 3.0 * LENGTH * WIDTH;
        assert!((vol - want).abs() / want < 2e-3, "{vol} vs {want}");
        let (lo, hi) = lampost_mesh::props::bounds(&m).expect("bounds");
        assert!(lo.z.abs() < 1e-12, "{lo:?}");
        assert!((hi.z - WIDTH).abs() < 1e-9, "{hi:?}");
        assert!((hi.x - 300.0).abs() < 1e-12 && (lo.x + 300.0).abs() < 1e-12);
        // The face at the ends leans 45°: the top corners at y = ±200·sin 45°.
        assert!((hi.y - (WIDTH * 0.5f64.sqrt() + 1.5 / 0.5f64.sqrt())).abs() < 1e-9);
        assert!(twisted_plate(0.0, 3.0, 4, 4).is_none());
        assert!(twisted_plate(1.0, f64::NAN, 4, 4).is_none());
        assert!(twisted_plate(1.0, 1.0, 0, 4).is_none());
    }
}
