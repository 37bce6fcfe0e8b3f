//! 6-DOF best-fit registration of probed points to a mesh: point-to-plane ICP with
//! closest points from parry3d (f64), per-axis locks, and a refusal when the points leave
//! a degree of freedom unobservable.

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Unit};
use parry3d_f64::math::Vector as PV;
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::TriMesh;
use serde::Serialize;

use crate::error::AlignError;
use crate::fit::{check_points, P3};
use lampost_mesh::Mesh;

/// Degrees of freedom held fixed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Locks {
    /// Fixed translations along x, y, z.
    pub translate: [bool; 3],
    /// Fixed rotations about x, y, z.
    pub rotate: [bool; 3],
}

impl Locks {
    /// Parse `z,tilt` and the like: `x`, `y`, `z` (translations), `rx`, `ry`, `rz`
    /// (rotations), `tilt` (= rx, ry), `translation`, `rotation`.
    pub fn parse(s: &str) -> Result<Self, String> {
        let mut l = Locks::default();
        for w in s
            .split(',')
            .map(|w| w.trim().to_ascii_lowercase())
            .filter(|w| !w.is_empty())
        {
            match w.as_str() {
                "x" => l.translate[0] = true,
                "y" => l.translate[1] = true,
                "z" => l.translate[2] = true,
                "rx" => l.rotate[0] = true,
                "ry" => l.rotate[1] = true,
                "rz" => l.rotate[2] = true,
                "tilt" => {
                    l.rotate[0] = true;
                    l.rotate[1] = true;
                }
                "translation" => l.translate = [true; 3],
                "rotation" => l.rotate = [true; 3],
                other => {
                    return Err(format!(
                    "unknown lock `{other}` (use x, y, z, rx, ry, rz, tilt, translation, rotation)"
                ))
                }
            }
        }
        Ok(l)
    }
}

/// The result of a registration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Registration {
    /// Rotation taking mesh (CAD) coordinates to part coordinates (row-major).
    pub rotation: [[f64; 3]; 3],
    /// Translation of that transform: part = R·cad + t.
    pub translation: [f64; 3],
    /// The rotation as an axis (unit) and angle in degrees.
    pub axis: [f64; 3],
    /// Angle in degrees.
    pub angle_deg: f64,
    /// RMS of the point-to-surface distances.
    pub rms: f64,
    /// Largest |distance|.
    pub max_abs_residual: f64,
    /// Each point's signed distance from the surface (+ outside), input order.
    pub residuals: Vec<f64>,
    /// Iterations taken.
    pub iterations: usize,
    /// Standard uncertainty (degrees) of the small rotations about axes through the
    /// probed points' centroid along the CAD frame's x, y and z, from the residuals'
    /// spread and the fit's Jacobian at the solution (`s²·(JᵀJ)⁻¹`, s² = SS/(n − p)); 0
    /// for a locked rotation; `None` with no redundancy (n ≤ free parameters).
    pub u_rotation_deg: Option<[f64; 3]>,
    /// Standard uncertainty of the translation of that centroid along the CAD frame's
    /// x, y and z (0 for a locked one; `None` with no redundancy).
    pub u_translation: Option<[f64; 3]>,
}

const NAMES: [&str; 6] = [
    "rotation about x",
    "rotation about y",
    "rotation about z",
    "translation along x",
    "translation along y",
    "translation along z",
];

/// Register `points` (part frame) to `mesh` (CAD frame): the rigid transform
/// part = R·cad + t that best puts the mesh's surface through the points.
pub fn register(mesh: &Mesh, points: &[P3], locks: Locks) -> Result<Registration, AlignError> {
    let free: Vec<usize> = (0..6)
        .filter(|&k| {
            if k < 3 {
                !locks.rotate[k]
            } else {
                !locks.translate[k - 3]
            }
        })
        .collect();
    check_points(points, "a registration", free.len().max(1))?;
    if free.is_empty() {
        return Err(AlignError::Degenerate(
            "every degree of freedom is locked: nothing to fit".into(),
        ));
    }
    // The mesh's coordinates are held to the points' range: a vertex at 1e154 (an STL
    // holds up to 3e38) made residuals whose squares overflow (found by `cargo xtask
    // fuzz`).
    for (i, v) in mesh.vertices.iter().enumerate() {
        if let Some(x) = v
            .iter()
            .find(|x| !(x.is_finite() && x.abs() <= crate::fit::MAX_COORD))
        {
            return Err(AlignError::Degenerate(format!(
                "mesh vertex {} has a coordinate {x:e}, beyond ±1e9 of the unit",
                i + 1
            )));
        }
    }
    let verts: Vec<PV> = mesh
        .vertices
        .iter()
        .map(|v| PV::new(v.x, v.y, v.z))
        .collect();
    let tri = TriMesh::new(verts, mesh.triangles.clone())
        .map_err(|e| AlignError::Degenerate(format!("the mesh cannot be used: {e}")))?;
    let n = points.len();
    let centroid = points.iter().fold(P3::zeros(), |a, p| a + p) / n as f64;
    let size = points
        .iter()
        .map(|p| (p - centroid).norm())
        .fold(0.0, f64::max)
        .max(1e-12);
    // Current transform taking points into the mesh frame: x = R·p + t.
    let mut r = Matrix3::identity();
    let mut t = P3::zeros();
    let mut iterations = 0;
    let mut residuals = vec![0.0; n];
    // (JᵀJ)⁻¹'s diagonal in the scaled parameters, from the last iteration's SVD.
    let mut inv_diag = vec![0.0; free.len()];
    loop {
        iterations += 1;
        let xs: Vec<P3> = points.iter().map(|p| r * p + t).collect();
        let c = xs.iter().fold(P3::zeros(), |a, x| a + x) / n as f64;
        let mut jac = DMatrix::zeros(n, free.len());
        let mut rhs = DVector::zeros(n);
        for (i, x) in xs.iter().enumerate() {
            let proj = tri.project_local_point(PV::new(x.x, x.y, x.z), false);
            let q = P3::new(proj.point.x, proj.point.y, proj.point.z);
            let d = x - q;
            let face = tri
                .triangle(proj.subshape)
                .normal()
                .map(|v| P3::new(v.x, v.y, v.z));
            let nrm = match face {
                Some(f) => f,
                None if d.norm() > 0.0 => d.normalize(),
                None => P3::z(),
            };
            let sd = d.dot(&nrm);
            residuals[i] = sd;
            let full = [
                ((x - c).cross(&nrm)).x / size,
                ((x - c).cross(&nrm)).y / size,
                ((x - c).cross(&nrm)).z / size,
                nrm.x,
                nrm.y,
                nrm.z,
            ];
            for (col, &k) in free.iter().enumerate() {
                jac[(i, col)] = full[k];
            }
            rhs[i] = -sd;
        }
        let svd = crate::fit::svd_capped(jac.clone(), true, true, "registration")?;
        let sv = &svd.singular_values;
        let (smax, smin) = (sv.max(), sv.min());
        if smin <= 1e-6 * smax {
            // Name the unobservable combination of the free parameters.
            let k = (0..sv.len())
                .min_by(|&a, &b| sv[a].total_cmp(&sv[b]))
                .unwrap_or(0);
            let vt = svd
                .v_t
                .as_ref()
                .ok_or_else(|| AlignError::Degenerate("the registration's SVD failed".into()))?;
            let mut parts: Vec<(f64, &str)> = free
                .iter()
                .enumerate()
                .map(|(col, &p)| (vt[(k, col)], NAMES[p]))
                .collect();
            parts.sort_by(|a, b| b.0.abs().total_cmp(&a.0.abs()));
            let what: Vec<String> = parts
                .iter()
                .filter(|(w, _)| w.abs() > 0.2)
                .map(|(w, name)| format!("{name} ({w:+.2})"))
                .collect();
            return Err(AlignError::Degenerate(format!(
                "the probed points leave {} unobservable (all points on one plane, cylinder or sphere of the surface); probe other faces, or lock it with --lock",
                what.join(" with ")
            )));
        }
        if let Some(vt) = svd.v_t.as_ref() {
            for (col, d) in inv_diag.iter_mut().enumerate() {
                *d = (0..sv.len()).map(|k| (vt[(k, col)] / sv[k]).powi(2)).sum();
            }
        }
        let y = svd
            .solve(&rhs, 1e-15)
            .map_err(|_| AlignError::Degenerate("the registration step failed".into()))?;
        let mut omega = P3::zeros();
        let mut dt = P3::zeros();
        for (col, &k) in free.iter().enumerate() {
            if k < 3 {
                omega[k] = y[col] / size;
            } else {
                dt[k - 3] = y[col];
            }
        }
        let rot = if omega.norm() > 0.0 {
            Rotation3::from_axis_angle(&Unit::new_normalize(omega), omega.norm()).into_inner()
        } else {
            Matrix3::identity()
        };
        r = rot * r;
        t = rot * (t - c) + c + dt;
        let step = omega.norm() * size + dt.norm();
        if step <= 1e-13 * size {
            break;
        }
        if iterations >= 200 {
            return Err(AlignError::NoConvergence(
                "registration",
                "200 ICP steps did not settle (start with the points nearer their place on the mesh)",
            ));
        }
    }
    // Re-orthonormalise, then invert: part = Rᵀ·(cad − t).
    let r = Rotation3::from_matrix(&r).into_inner();
    let rp = r.transpose();
    let tp = -(rp * t);
    let rot = Rotation3::from_matrix(&rp);
    let axis = rot.axis_angle().map_or(P3::z(), |(a, _)| a.into_inner());
    // The angle from both the trace and the skew part, the cosine clamped: nalgebra's
    // `acos` of the trace alone gave NaN for a turn of 180° (found by `cargo xtask fuzz`).
    let skew = P3::new(
        rp[(2, 1)] - rp[(1, 2)],
        rp[(0, 2)] - rp[(2, 0)],
        rp[(1, 0)] - rp[(0, 1)],
    );
    let angle = (0.5 * skew.norm()).atan2(((rp.trace() - 1.0) / 2.0).clamp(-1.0, 1.0));
    let ss: f64 = residuals.iter().map(|x| x * x).sum();
    let (u_rotation_deg, u_translation) = if n > free.len() {
        let s2 = ss / (n - free.len()) as f64;
        let mut ur = [0.0; 3];
        let mut ut = [0.0; 3];
        for (col, &k) in free.iter().enumerate() {
            let u = (s2 * inv_diag[col]).sqrt();
            if k < 3 {
                ur[k] = (u / size).to_degrees();
            } else {
                ut[k - 3] = u;
            }
        }
        let finite = ur.iter().chain(&ut).all(|x| x.is_finite());
        (finite.then_some(ur), finite.then_some(ut))
    } else {
        (None, None)
    };
    Ok(Registration {
        rotation: [
            [rp[(0, 0)], rp[(0, 1)], rp[(0, 2)]],
            [rp[(1, 0)], rp[(1, 1)], rp[(1, 2)]],
            [rp[(2, 0)], rp[(2, 1)], rp[(2, 2)]],
        ],
        translation: [tp.x, tp.y, tp.z],
        axis: [axis.x, axis.y, axis.z],
        angle_deg: angle.to_degrees(),
        rms: (ss / n as f64).sqrt(),
        max_abs_residual: residuals.iter().fold(0.0, |m, x| f64::max(m, x.abs())),
        residuals,
        iterations,
        u_rotation_deg,
        u_translation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use lampost_mesh::box_mesh;

    fn moved(points: &[P3], axis: P3, deg: f64, t: P3) -> Vec<P3> {
        let r = Rotation3::from_axis_angle(&Unit::new_normalize(axis), deg.to_radians());
        points.iter().map(|p| r * p + t).collect()
    }

    /// Found by `cargo xtask fuzz` (numeric target, seed 3, input 48525): a mesh at
    /// z = 1e154 registered with `rms inf`; it is refused.
    #[test]
    fn a_mesh_beyond_the_coordinate_range_is_refused() {
        let m = box_mesh(P3::new(-1.0, -4.3, 1e154), P3::new(0.0, 0.1, 1e154));
        let pts = [
            P3::new(0.0, 0.0, 0.0),
            P3::new(1.0, 0.0, 0.0),
            P3::new(0.0, 1.0, 0.0),
            P3::new(1.0, 1.0, 0.5),
            P3::new(2.0, 0.0, 0.25),
            P3::new(0.0, 2.0, 0.75),
        ];
        let r = register(&m, &pts, Locks::default());
        assert!(
            matches!(&r, Err(AlignError::Degenerate(w)) if w.contains("beyond ±1e9")),
            "{r:?}"
        );
    }

    /// Found by `cargo xtask fuzz` (numeric target, seed 2026, input 3698652): a
    /// registration turned 180° reported `angle_deg` NaN.
    #[test]
    fn a_half_turn_has_an_angle() {
        let m = box_mesh(
            P3::new(-1.8955522650204086, -2.1289049374634694, -4.28192972113275),
            P3::new(3.061910000895928, 1.0738304418740534, -2.7747951842139416),
        );
        let pts = [
            P3::new(6.827847196350195, -1.9038795730743077, -8.884508728773934),
            P3::new(5.57756728050065, 1.521277466478758, -8.884508724275307),
            P3::new(2.414753699938728, 3.3355296366975424, -8.88450873300313),
            P3::new(-1.1730728905985084, 2.685605779832, -8.88450872738302),
            P3::new(
                -3.4985015916532722,
                -0.12282474958168063,
                -8.884508732660995,
            ),
        ];
        let locks = Locks {
            translate: [true; 3],
            rotate: [false, false, true],
        };
        let r = register(&m, &pts, locks).expect("registers");
        assert!(r.angle_deg.is_finite(), "{r:?}");
        assert!((r.angle_deg - 180.0).abs() < 1e-3, "{r:?}");
    }

    /// Points on three faces of a box, seen after a small known rigid move.
    fn box_points() -> Vec<P3> {
        let mut v = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                let (a, b) = (10.0 + 25.0 * f64::from(i), 5.0 + 12.0 * f64::from(j));
                v.push(P3::new(a, b, 50.0)); // top
                v.push(P3::new(a, 0.0, 5.0 + 12.0 * f64::from(j))); // front
                v.push(P3::new(0.0, b, 5.0 + 12.0 * f64::from(i))); // left
            }
        }
        v
    }

    #[test]
    fn recovers_a_known_move() {
        let mesh = box_mesh(P3::zeros(), P3::new(100.0, 60.0, 50.0));
        let truth = (P3::new(0.3, -0.2, 1.0), 1.5, P3::new(0.4, -0.3, 0.25));
        let pts = moved(&box_points(), truth.0, truth.1, truth.2);
        let reg = register(&mesh, &pts, Locks::default()).expect("registers");
        assert!(reg.rms < 1e-9, "{reg:?}");
        let r = Matrix3::from_fn(|i, j| reg.rotation[i][j]);
        let want = Rotation3::from_axis_angle(&Unit::new_normalize(truth.0), truth.1.to_radians())
            .into_inner();
        assert!((r - want).norm() < 1e-9);
        assert!((P3::from(reg.translation) - truth.2).norm() < 1e-8);
    }

    #[test]
    fn refuses_an_unobservable_rotation_and_honours_locks() {
        let mesh = box_mesh(P3::zeros(), P3::new(100.0, 60.0, 50.0));
        // Only the top face: rotation about z and x/y translation are not fixed.
        let top: Vec<P3> = box_points().into_iter().filter(|p| p.z == 50.0).collect();
        let e = register(&mesh, &top, Locks::default()).expect_err("unobservable");
        assert!(e.to_string().contains("unobservable"), "{e}");
        // Locking what the top face cannot see leaves z and the tilt, which it fixes.
        let locks = Locks::parse("x,y,rz").expect("locks");
        let pts = moved(&top, P3::new(1.0, 0.0, 0.0), 0.5, P3::new(0.0, 0.0, 0.2));
        let reg = register(&mesh, &pts, locks).expect("registers");
        assert!(reg.rms < 1e-9);
        assert!(Locks::parse("z,tilt,bogus").is_err());
    }
}
