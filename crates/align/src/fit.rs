//! Least-squares fits of probe points: sphere (four-point determinant, geometric N-point,
//! fixed radius), plane (total least squares), circle in 3D.
//!
//! The nonlinear fits are Levenberg–Marquardt iterations written here on nalgebra (four
//! parameters at most, so a general crate buys nothing; written out, the stopping rule
//! is ours and reaches the NIST certified values to ~1e-14). Each fit works in
//! coordinates centred on the centroid, for conditioning, and reports the standard
//! uncertainty of each parameter from `s²·(JᵀJ)⁻¹`, `s² = Σr²/(N − p)`.

use nalgebra::{DMatrix, DVector, Vector3};
use serde::Serialize;

use crate::error::AlignError;

/// A point.
pub type P3 = Vector3<f64>;

/// A fitted sphere.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SphereFit {
    /// Centre.
    pub center: [f64; 3],
    /// Radius.
    pub radius: f64,
    /// Root mean square of the radial residuals |p − c| − r.
    pub rms: f64,
    /// Largest |residual|.
    pub max_abs_residual: f64,
    /// Number of points.
    pub n: usize,
    /// Standard uncertainty of the centre's coordinates (`None` with no redundancy).
    pub u_center: Option<[f64; 3]>,
    /// Standard uncertainty of the radius (`None` when fixed or with no redundancy).
    pub u_radius: Option<f64>,
    /// Each point's residual, in input order.
    pub residuals: Vec<f64>,
}

/// A fitted plane.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlaneFit {
    /// The centroid (a point on the plane).
    pub point: [f64; 3],
    /// Unit normal, oriented with its largest… see [`orient_normal`].
    pub normal: [f64; 3],
    /// Root mean square of the signed distances.
    pub rms: f64,
    /// Largest |distance|.
    pub max_abs_residual: f64,
    /// Max minus min signed distance.
    pub flatness: f64,
    /// Number of points.
    pub n: usize,
    /// Standard uncertainty of the plane's position along its normal.
    pub u_offset: Option<f64>,
    /// Standard uncertainty of the normal's tilt about the two in-plane directions (rad).
    pub u_tilt: Option<[f64; 2]>,
    /// Each point's signed distance, in input order.
    pub residuals: Vec<f64>,
}

/// A fitted circle in 3D.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CircleFit {
    /// Centre.
    pub center: [f64; 3],
    /// Unit normal of the circle's plane.
    pub normal: [f64; 3],
    /// Radius.
    pub radius: f64,
    /// Root mean square of the in-plane radial residuals.
    pub rms: f64,
    /// Largest |in-plane residual|.
    pub max_abs_residual: f64,
    /// Root mean square of the distances from the plane.
    pub rms_out_of_plane: f64,
    /// Number of points.
    pub n: usize,
    /// Standard uncertainty of the centre (3D).
    pub u_center: Option<[f64; 3]>,
    /// Standard uncertainty of the radius.
    pub u_radius: Option<f64>,
}

/// Refuse too few, non-finite or repeated points.
pub fn check_points(pts: &[P3], fit: &'static str, need: usize) -> Result<(), AlignError> {
    if let Some(i) = pts.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(AlignError::NotFinite(i + 1));
    }
    if pts.len() < need {
        return Err(AlignError::TooFewPoints {
            fit,
            need,
            got: pts.len(),
        });
    }
    let mut idx: Vec<usize> = (0..pts.len()).collect();
    idx.sort_by(|&a, &b| {
        pts[a]
            .iter()
            .zip(pts[b].iter())
            .map(|(x, y)| x.total_cmp(y))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    for w in idx.windows(2) {
        if pts[w[0]] == pts[w[1]] {
            let (a, b) = (w[0].min(w[1]), w[0].max(w[1]));
            return Err(AlignError::DuplicatePoints {
                first: a + 1,
                second: b + 1,
            });
        }
    }
    Ok(())
}

fn centroid(pts: &[P3]) -> P3 {
    pts.iter().fold(P3::zeros(), |a, p| a + p) / pts.len() as f64
}

fn scale(pts: &[P3], m: &P3) -> f64 {
    pts.iter()
        .map(|p| (p - m).norm())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE)
}

fn arr(v: &P3) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// Orient a normal deterministically: +Z hemisphere; on the equator, +Y; then +X.
pub fn orient_normal(n: P3) -> P3 {
    let key = if n.z.abs() > 1e-12 {
        n.z
    } else if n.y.abs() > 1e-12 {
        n.y
    } else {
        n.x
    };
    if key < 0.0 {
        -n
    } else {
        n
    }
}

fn rms_max(r: &[f64]) -> (f64, f64) {
    let ss: f64 = r.iter().map(|x| x * x).sum();
    (
        (ss / r.len() as f64).sqrt(),
        r.iter().fold(0.0, |m, x| f64::max(m, x.abs())),
    )
}

/// Parameters, residuals and Jacobian at the solution.
type Solved = (DVector<f64>, DVector<f64>, DMatrix<f64>);

/// Levenberg–Marquardt on `p` parameters. `eval` fills residuals and the Jacobian.
fn levenberg_marquardt(
    mut x: DVector<f64>,
    n: usize,
    name: &'static str,
    eval: impl Fn(&DVector<f64>, &mut DVector<f64>, &mut DMatrix<f64>),
) -> Result<Solved, AlignError> {
    let p = x.len();
    let mut r = DVector::zeros(n);
    let mut j = DMatrix::zeros(n, p);
    eval(&x, &mut r, &mut j);
    let mut cost = r.norm_squared();
    let mut lambda = 1e-6;
    for _ in 0..500 {
        let jtj = j.transpose() * &j;
        let g = j.transpose() * &r;
        let mut improved = false;
        for _ in 0..30 {
            let mut a = jtj.clone();
            for k in 0..p {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-300);
            }
            let Some(step) = a.clone().cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let xn = &x + &step;
            let mut rn = DVector::zeros(n);
            let mut jn = DMatrix::zeros(n, p);
            eval(&xn, &mut rn, &mut jn);
            let cn = rn.norm_squared();
            if cn.is_finite() && cn <= cost {
                let small = step.norm() <= 1e-15 * (1.0 + x.norm());
                let flat = cost - cn <= 1e-30 + 1e-16 * cost;
                x = xn;
                r = rn;
                j = jn;
                cost = cn;
                lambda = (lambda / 10.0).max(1e-15);
                improved = true;
                if small || flat {
                    return Ok((x, r, j));
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            // No step lowers the cost: at the minimum to working precision.
            return Ok((x, r, j));
        }
    }
    Err(AlignError::NoConvergence(name))
}

/// Standard uncertainties from the Jacobian at the solution.
fn uncertainties(j: &DMatrix<f64>, r: &DVector<f64>) -> Option<Vec<f64>> {
    let (n, p) = j.shape();
    if n <= p {
        return None;
    }
    let s2 = r.norm_squared() / (n - p) as f64;
    let cov = (j.transpose() * j).try_inverse()?;
    Some((0..p).map(|k| (s2 * cov[(k, k)]).max(0.0).sqrt()).collect())
}

/// The sphere through exactly four points, by paper 000's determinant method
/// (eqs. 1–7). Refuses three collinear points or four coplanar ones, saying which.
pub fn sphere4(pts: &[P3]) -> Result<SphereFit, AlignError> {
    check_points(pts, "the four-point sphere", 4)?;
    if pts.len() != 4 {
        return Err(AlignError::Degenerate(format!(
            "the four-point method takes exactly 4 points, got {}; use the N-point fit for more",
            pts.len()
        )));
    }
    let m = centroid(pts);
    let s = scale(pts, &m);
    let q: Vec<P3> = pts.iter().map(|p| (p - m) / s).collect();
    for (a, b, c) in [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)] {
        let area = (q[b] - q[a]).cross(&(q[c] - q[a])).norm();
        if area < 1e-10 {
            return Err(AlignError::Degenerate(format!(
                "points {}, {} and {} are collinear: no sphere passes through them and a fourth point uniquely",
                a + 1,
                b + 1,
                c + 1
            )));
        }
    }
    let det4 = |rows: [[f64; 4]; 4]| nalgebra::Matrix4::from_fn(|i, k| rows[i][k]).determinant();
    let row = |p: &P3, f: &dyn Fn(&P3) -> [f64; 4]| f(p);
    let s2 = |p: &P3| p.norm_squared();
    let build =
        |f: &dyn Fn(&P3) -> [f64; 4]| [row(&q[0], f), row(&q[1], f), row(&q[2], f), row(&q[3], f)];
    let m11 = det4(build(&|p| [p.x, p.y, p.z, 1.0]));
    if m11.abs() < 1e-10 {
        return Err(AlignError::Degenerate(
            "the four points are coplanar (M11 = 0): no single sphere passes through them".into(),
        ));
    }
    let m12 = det4(build(&|p| [s2(p), p.y, p.z, 1.0]));
    let m13 = det4(build(&|p| [s2(p), p.x, p.z, 1.0]));
    let m14 = det4(build(&|p| [s2(p), p.x, p.y, 1.0]));
    let m15 = det4(build(&|p| [s2(p), p.x, p.y, p.z]));
    let c = P3::new(0.5 * m12 / m11, -0.5 * m13 / m11, 0.5 * m14 / m11);
    let r2 = c.norm_squared() - m15 / m11;
    let radius = r2.max(0.0).sqrt() * s;
    let center = c * s + m;
    let residuals: Vec<f64> = pts.iter().map(|p| (p - center).norm() - radius).collect();
    let (rms, max_abs_residual) = rms_max(&residuals);
    Ok(SphereFit {
        center: arr(&center),
        radius,
        rms,
        max_abs_residual,
        n: 4,
        u_center: None,
        u_radius: None,
        residuals,
    })
}

/// Geometric least-squares sphere: minimise Σ(|p − c| − r)², from the algebraic fit.
/// With `fixed_radius`, only the centre is fitted (stylus-centre points on a gage ball
/// of known radius: ball radius + stylus radius).
pub fn sphere(pts: &[P3], fixed_radius: Option<f64>) -> Result<SphereFit, AlignError> {
    let need = if fixed_radius.is_some() { 3 } else { 4 };
    check_points(pts, "a sphere", need)?;
    if let Some(r) = fixed_radius {
        if !(r.is_finite() && r > 0.0) {
            return Err(AlignError::Degenerate(format!(
                "the fixed radius {r} must be positive"
            )));
        }
    }
    let m = centroid(pts);
    let s = scale(pts, &m);
    let q: Vec<P3> = pts.iter().map(|p| (p - m) / s).collect();
    let n = q.len();
    // Algebraic start: |q|² = 2c·q + d.
    let a = DMatrix::from_fn(n, 4, |i, k| if k < 3 { 2.0 * q[i][k] } else { 1.0 });
    let b = DVector::from_fn(n, |i, _| q[i].norm_squared());
    let svd = a.clone().svd(true, true);
    let sv = &svd.singular_values;
    let (smax, smin) = (sv.max(), sv.min());
    let start_c;
    let start_r;
    if smin <= 1e-9 * smax {
        if fixed_radius.is_none() {
            return Err(AlignError::Degenerate(
                "the points lie on one plane (or circle): a sphere through them is not fixed; probe points off that plane".into(),
            ));
        }
        // With the radius known, a cap of coplanar points still fixes the centre up to a
        // side: start above the centroid along the plane's normal.
        let pl = plane(pts)?;
        let nrm = P3::from(pl.normal);
        let ring = pts.iter().map(|p| (p - m).norm()).sum::<f64>() / n as f64;
        let rr = fixed_radius.unwrap_or(1.0);
        let h = (rr * rr - ring * ring).max(0.0).sqrt();
        start_c = (-nrm * h) / s;
        start_r = rr / s;
    } else {
        let x = svd
            .solve(&b, 1e-14)
            .map_err(|_| AlignError::Degenerate("the algebraic sphere fit failed".into()))?;
        start_c = P3::new(x[0], x[1], x[2]);
        start_r = (x[3] + start_c.norm_squared()).max(0.0).sqrt();
    }
    let (center, radius, j, r) = match fixed_radius {
        None => {
            let x0 = DVector::from_vec(vec![start_c.x, start_c.y, start_c.z, start_r]);
            let (x, r, j) = levenberg_marquardt(x0, n, "sphere", |x, res, jac| {
                let c = P3::new(x[0], x[1], x[2]);
                for (i, p) in q.iter().enumerate() {
                    let d = p - c;
                    let len = d.norm().max(f64::MIN_POSITIVE);
                    res[i] = len - x[3];
                    for k in 0..3 {
                        jac[(i, k)] = -d[k] / len;
                    }
                    jac[(i, 3)] = -1.0;
                }
            })?;
            (P3::new(x[0], x[1], x[2]), x[3], j, r)
        }
        Some(rr) => {
            let rq = rr / s;
            let x0 = DVector::from_vec(vec![start_c.x, start_c.y, start_c.z]);
            let (x, r, j) = levenberg_marquardt(x0, n, "sphere", |x, res, jac| {
                let c = P3::new(x[0], x[1], x[2]);
                for (i, p) in q.iter().enumerate() {
                    let d = p - c;
                    let len = d.norm().max(f64::MIN_POSITIVE);
                    res[i] = len - rq;
                    for k in 0..3 {
                        jac[(i, k)] = -d[k] / len;
                    }
                }
            })?;
            (P3::new(x[0], x[1], x[2]), rq, j, r)
        }
    };
    let u = uncertainties(&j, &r);
    let center_w = center * s + m;
    let radius_w = radius * s;
    let residuals: Vec<f64> = pts
        .iter()
        .map(|p| (p - center_w).norm() - radius_w)
        .collect();
    let (rms, max_abs_residual) = rms_max(&residuals);
    Ok(SphereFit {
        center: arr(&center_w),
        radius: radius_w,
        rms,
        max_abs_residual,
        n,
        u_center: u.as_ref().map(|u| [u[0] * s, u[1] * s, u[2] * s]),
        u_radius: if fixed_radius.is_none() {
            u.as_ref().map(|u| u[3] * s)
        } else {
            None
        },
        residuals,
    })
}

/// Total-least-squares plane: the centroid and the smallest singular vector.
pub fn plane(pts: &[P3]) -> Result<PlaneFit, AlignError> {
    check_points(pts, "a plane", 3)?;
    let m = centroid(pts);
    let n = pts.len();
    // The SVD of the N×3 centred matrix, for accuracy with thin point sets.
    let a = DMatrix::from_fn(n, 3, |i, k| pts[i][k] - m[k]);
    let svd = a.svd(false, true);
    let vt = svd
        .v_t
        .ok_or_else(|| AlignError::Degenerate("the plane fit failed".into()))?;
    let sv = svd.singular_values;
    let mut order = [0usize, 1, 2];
    order.sort_by(|&x, &y| sv[y].total_cmp(&sv[x]));
    let (i_big, i_mid, i_small) = (order[0], order[1], order[2]);
    if sv[i_mid] <= 1e-9 * sv[i_big] {
        return Err(AlignError::Degenerate(
            "the points are collinear: a plane through them is not fixed; probe points off that line".into(),
        ));
    }
    let row = |i: usize| P3::new(vt[(i, 0)], vt[(i, 1)], vt[(i, 2)]);
    let normal = orient_normal(row(i_small).normalize());
    let residuals: Vec<f64> = pts.iter().map(|p| (p - m).dot(&normal)).collect();
    let (rms, max_abs_residual) = rms_max(&residuals);
    let lo = residuals.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = residuals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (u_offset, u_tilt) = if n > 3 {
        let s = (residuals.iter().map(|r| r * r).sum::<f64>() / (n - 3) as f64).sqrt();
        (
            Some(s / (n as f64).sqrt()),
            Some([s / sv[i_big], s / sv[i_mid]]),
        )
    } else {
        (None, None)
    };
    Ok(PlaneFit {
        point: arr(&m),
        normal: arr(&normal),
        rms,
        max_abs_residual,
        flatness: hi - lo,
        n,
        u_offset,
        u_tilt,
        residuals,
    })
}

/// A circle in 3D: the total-least-squares plane, then a geometric 2D circle fit of the
/// points projected onto it.
pub fn circle3d(pts: &[P3]) -> Result<CircleFit, AlignError> {
    check_points(pts, "a circle", 3)?;
    let pl = plane(pts)?;
    let m = P3::from(pl.point);
    let nrm = P3::from(pl.normal);
    // In-plane basis.
    let helper = if nrm.x.abs() < 0.9 { P3::x() } else { P3::y() };
    let e1 = (helper - nrm * nrm.dot(&helper)).normalize();
    let e2 = nrm.cross(&e1);
    let s = scale(pts, &m);
    let uv: Vec<(f64, f64)> = pts
        .iter()
        .map(|p| ((p - m).dot(&e1) / s, (p - m).dot(&e2) / s))
        .collect();
    let n = uv.len();
    let a = DMatrix::from_fn(n, 3, |i, k| match k {
        0 => 2.0 * uv[i].0,
        1 => 2.0 * uv[i].1,
        _ => 1.0,
    });
    let b = DVector::from_fn(n, |i, _| uv[i].0 * uv[i].0 + uv[i].1 * uv[i].1);
    let svd = a.svd(true, true);
    if svd.singular_values.min() <= 1e-9 * svd.singular_values.max() {
        return Err(AlignError::Degenerate(
            "the points are collinear: no circle passes through them".into(),
        ));
    }
    let x = svd
        .solve(&b, 1e-14)
        .map_err(|_| AlignError::Degenerate("the algebraic circle fit failed".into()))?;
    let r0 = (x[2] + x[0] * x[0] + x[1] * x[1]).max(0.0).sqrt();
    let x0 = DVector::from_vec(vec![x[0], x[1], r0]);
    let (x, r, j) = levenberg_marquardt(x0, n, "circle", |x, res, jac| {
        for (i, &(u, v)) in uv.iter().enumerate() {
            let (du, dv) = (u - x[0], v - x[1]);
            let len = du.hypot(dv).max(f64::MIN_POSITIVE);
            res[i] = len - x[2];
            jac[(i, 0)] = -du / len;
            jac[(i, 1)] = -dv / len;
            jac[(i, 2)] = -1.0;
        }
    })?;
    let center = m + (e1 * x[0] + e2 * x[1]) * s;
    let residuals: Vec<f64> = r.iter().map(|v| v * s).collect();
    let (rms, max_abs_residual) = rms_max(&residuals);
    let u = uncertainties(&j, &r);
    Ok(CircleFit {
        center: arr(&center),
        normal: pl.normal,
        radius: x[2] * s,
        rms,
        max_abs_residual,
        rms_out_of_plane: pl.rms,
        n,
        u_center: u.as_ref().map(|u| {
            let c = (e1 * u[0]).abs() + (e2 * u[1]).abs();
            [c.x * s, c.y * s, c.z * s]
        }),
        u_radius: u.as_ref().map(|u| u[2] * s),
    })
}
