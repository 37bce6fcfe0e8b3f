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

/// The largest coordinate magnitude a fit accepts, in the points' unit: no machine
/// measures beyond it, and below it squares and sums of squares cannot overflow.
pub const MAX_COORD: f64 = 1e9;

/// Iterations a Levenberg–Marquardt fit may take before it says it did not converge.
pub const MAX_ITERATIONS: usize = 200;

/// A number with −0 made +0, so that `-0 0 1` and `0 0 1` are one point.
pub fn unsigned_zero(x: f64) -> f64 {
    x + 0.0
}

/// Refuse too few, non-finite, out-of-range or repeated points.
pub fn check_points(pts: &[P3], fit: &'static str, need: usize) -> Result<(), AlignError> {
    if let Some(i) = pts.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(AlignError::NotFinite(i + 1));
    }
    for (i, p) in pts.iter().enumerate() {
        if let Some(&value) = p.iter().find(|x| x.abs() > MAX_COORD) {
            return Err(AlignError::TooLarge {
                index: i + 1,
                value,
            });
        }
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
            .map(|(x, y)| unsigned_zero(*x).total_cmp(&unsigned_zero(*y)))
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

/// A singular value decomposition with an iteration cap (nalgebra's default has none,
/// and loops on non-finite input).
pub(crate) fn svd_capped(
    a: DMatrix<f64>,
    u: bool,
    v: bool,
    what: &'static str,
) -> Result<nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>, AlignError> {
    if !a.iter().all(|x| x.is_finite()) {
        return Err(AlignError::Degenerate(format!(
            "the {what} fit met a non-finite number (the input's magnitudes overflow)"
        )));
    }
    a.try_svd(u, v, f64::EPSILON, 10_000)
        .ok_or(AlignError::NoConvergence(
            what,
            "its singular value decomposition did not settle in 10000 iterations",
        ))
}

/// Refuse a result with a non-finite number in it: never print one.
pub(crate) fn finite_result(what: &'static str, vals: &[f64]) -> Result<(), AlignError> {
    if vals.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(AlignError::Degenerate(format!(
            "the {what} fit gave a non-finite number (the points' spread overflows or vanishes)"
        )))
    }
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

/// The points' spread: their RMS distance from their centroid (0 for fewer than one).
pub fn spread(pts: &[P3]) -> f64 {
    if pts.is_empty() {
        return 0.0;
    }
    let m = centroid(pts);
    let s = scale(pts, &m);
    // Scaled first, so no square overflows.
    (pts.iter()
        .map(|p| ((p - m) / s).norm_squared())
        .sum::<f64>()
        / pts.len() as f64)
        .sqrt()
        * s
}

/// A residual above this fraction of the points' spread means the shape does not fit
/// them: a probed feature's form error and probe noise are far smaller than its size.
pub const MAX_RESIDUAL_OF_SPREAD: f64 = 0.01;

/// What to say when a fit does not fit: its RMS residual above
/// [`MAX_RESIDUAL_OF_SPREAD`] of the points' [`spread`], or above three times the
/// expected probe `noise` (one sigma, when known). `None` when the fit is good.
pub fn residual_warning(shape: &str, rms: f64, pts: &[P3], noise: Option<f64>) -> Option<String> {
    let sp = spread(pts);
    if sp > 0.0 && rms > MAX_RESIDUAL_OF_SPREAD * sp {
        return Some(format!(
            "the {shape} does not fit these points: rms residual {rms:.3e} is {:.1} % of their spread {sp:.3e} (a good fit is under {} %); check for outliers, or whether they are a {shape} at all",
            100.0 * rms / sp,
            100.0 * MAX_RESIDUAL_OF_SPREAD
        ));
    }
    match noise {
        Some(sigma) if sigma > 0.0 && rms > 3.0 * sigma => Some(format!(
            "the {shape}'s rms residual {rms:.3e} is {:.1} times the expected probe noise {sigma:.3e}; check for outliers or form error",
            rms / sigma
        )),
        _ => None,
    }
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

/// RMS and largest magnitude, scaled before squaring so that neither overflows.
fn rms_max(r: &[f64]) -> (f64, f64) {
    let big = r.iter().fold(0.0, |m, x| f64::max(m, x.abs()));
    if big == 0.0 || r.is_empty() {
        return (0.0, big);
    }
    let ss: f64 = r.iter().map(|x| (x / big) * (x / big)).sum();
    (big * (ss / r.len() as f64).sqrt(), big)
}

/// The solution: parameters, each point's residual, and JᵀJ there (p × p).
type Solved = (DVector<f64>, Vec<f64>, DMatrix<f64>);

/// Σr², JᵀJ and Jᵀr in one O(n) pass, without storing the n × p Jacobian.
fn normal_equations(
    x: &DVector<f64>,
    n: usize,
    row: &impl Fn(&DVector<f64>, usize) -> (f64, [f64; 4]),
) -> (f64, DMatrix<f64>, DVector<f64>) {
    let p = x.len();
    let mut jtj = DMatrix::zeros(p, p);
    let mut jtr = DVector::zeros(p);
    let mut cost = 0.0;
    for i in 0..n {
        let (r, g) = row(x, i);
        cost += r * r;
        for a in 0..p {
            jtr[a] += g[a] * r;
            for b in 0..=a {
                jtj[(a, b)] += g[a] * g[b];
            }
        }
    }
    for a in 0..p {
        for b in 0..a {
            jtj[(b, a)] = jtj[(a, b)];
        }
    }
    (cost, jtj, jtr)
}

/// Levenberg–Marquardt on `p ≤ 4` parameters over `n` points; `row(x, i)` gives point
/// i's residual and its gradient (entries past `p` unused). Each iteration is one O(n)
/// pass per trial step; at most [`MAX_ITERATIONS`] iterations.
fn levenberg_marquardt(
    mut x: DVector<f64>,
    n: usize,
    name: &'static str,
    row: impl Fn(&DVector<f64>, usize) -> (f64, [f64; 4]),
) -> Result<Solved, AlignError> {
    let p = x.len();
    let residuals = |x: &DVector<f64>| (0..n).map(|i| row(x, i).0).collect::<Vec<f64>>();
    if !x.iter().all(|v| v.is_finite()) {
        return Err(AlignError::NoConvergence(
            name,
            "its algebraic start is not finite (the points fix no such shape)",
        ));
    }
    let (mut cost, mut jtj, mut g) = normal_equations(&x, n, &row);
    if !cost.is_finite() {
        return Err(AlignError::NoConvergence(
            name,
            "the residuals at its start overflow",
        ));
    }
    let mut lambda = 1e-6;
    for _ in 0..MAX_ITERATIONS {
        let mut improved = false;
        for _ in 0..30 {
            let mut a = jtj.clone();
            for k in 0..p {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-300);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let xn = &x + &step;
            let (cn, jn, gn) = normal_equations(&xn, n, &row);
            if cn.is_finite() && cn <= cost {
                let small = step.norm() <= 1e-15 * (1.0 + x.norm());
                // A fall in cost below the rounding of an n-term sum is no progress.
                let noise = 1e-16_f64.max(4.0 * f64::EPSILON * (n as f64).sqrt());
                let flat = cost - cn <= 1e-30 + noise * cost;
                x = xn;
                jtj = jn;
                g = gn;
                cost = cn;
                lambda = (lambda / 10.0).max(1e-15);
                improved = true;
                if small || flat {
                    let r = residuals(&x);
                    return Ok((x, r, jtj));
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            // No step lowers the cost: at the minimum to working precision.
            let r = residuals(&x);
            return Ok((x, r, jtj));
        }
    }
    Err(AlignError::NoConvergence(
        name,
        "200 Levenberg–Marquardt iterations still lowered the cost (the points may not lie on such a shape)",
    ))
}

/// Standard uncertainties from JᵀJ and the residuals at the solution.
fn uncertainties(jtj: &DMatrix<f64>, r: &[f64]) -> Option<Vec<f64>> {
    let (n, p) = (r.len(), jtj.nrows());
    if n <= p {
        return None;
    }
    let (_, big) = rms_max(r);
    let ss: f64 = if big > 0.0 {
        r.iter().map(|x| (x / big) * (x / big)).sum::<f64>() * big * big
    } else {
        0.0
    };
    let s2 = ss / (n - p) as f64;
    let cov = jtj.clone().try_inverse()?;
    let u: Vec<f64> = (0..p).map(|k| (s2 * cov[(k, k)]).max(0.0).sqrt()).collect();
    u.iter().all(|x| x.is_finite()).then_some(u)
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
    if fixed_radius.is_none() {
        // Noisy points of one plane pass the rank test below, then the sphere runs off to
        // a huge radius or does not settle: say what they are.
        let pl = plane(pts)?;
        let sp = spread(pts);
        if pl.rms < MAX_RESIDUAL_OF_SPREAD * sp {
            return Err(AlignError::Degenerate(format!(
                "the points lie on one plane (coplanar: within {:.2e} rms of it, {:.2} % of their spread): a sphere through them is not fixed; probe points off that plane (touch the ball at several heights), or fix the radius with --radius",
                pl.rms,
                100.0 * pl.rms / sp
            )));
        }
    }
    let svd = svd_capped(a, true, true, "sphere")?;
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
            let (x, r, j) = levenberg_marquardt(x0, n, "sphere", |x, i| {
                let d = q[i] - P3::new(x[0], x[1], x[2]);
                let len = d.norm().max(f64::MIN_POSITIVE);
                (len - x[3], [-d.x / len, -d.y / len, -d.z / len, -1.0])
            })?;
            (P3::new(x[0], x[1], x[2]), x[3], j, r)
        }
        Some(rr) => {
            let rq = rr / s;
            let x0 = DVector::from_vec(vec![start_c.x, start_c.y, start_c.z]);
            let (x, r, j) = levenberg_marquardt(x0, n, "sphere", |x, i| {
                let d = q[i] - P3::new(x[0], x[1], x[2]);
                let len = d.norm().max(f64::MIN_POSITIVE);
                (len - rq, [-d.x / len, -d.y / len, -d.z / len, 0.0])
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
    let mut all = vec![center_w.x, center_w.y, center_w.z, radius_w, rms];
    all.extend(u.iter().flatten().map(|v| v * s));
    finite_result("sphere", &all)?;
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
    // The SVD of the N×3 centred matrix, for accuracy with thin point sets; scaled to
    // unit size first, so nothing squared can overflow or underflow.
    let s = scale(pts, &m);
    let a = DMatrix::from_fn(n, 3, |i, k| (pts[i][k] - m[k]) / s);
    let svd = svd_capped(a, false, true, "plane")?;
    let vt = svd
        .v_t
        .ok_or_else(|| AlignError::Degenerate("the plane fit failed".into()))?;
    let sv = svd.singular_values * s;
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
        // rms·√(n / (n − 3)), without squaring the residuals again.
        let s = rms * (n as f64 / (n - 3) as f64).sqrt();
        (
            Some(s / (n as f64).sqrt()),
            Some([s / sv[i_big], s / sv[i_mid]]),
        )
    } else {
        (None, None)
    };
    let mut all = vec![m.x, m.y, m.z, normal.x, normal.y, normal.z, rms, hi - lo];
    all.extend(u_offset);
    all.extend(u_tilt.iter().flatten());
    finite_result("plane", &all)?;
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
    // Algebraic start (Kåsa: |q|² = 2c·q + d) by its 3 × 3 normal equations, one O(n)
    // pass: the points are centred and scaled to unit size, and the geometric fit below
    // refines it. (plane() has already refused collinear points.)
    let mut ata = nalgebra::Matrix3::<f64>::zeros();
    let mut atb = nalgebra::Vector3::<f64>::zeros();
    for &(u, v) in &uv {
        let row = nalgebra::Vector3::new(2.0 * u, 2.0 * v, 1.0);
        ata += row * row.transpose();
        atb += row * (u * u + v * v);
    }
    let x = ata
        .cholesky()
        .map(|c| c.solve(&atb))
        .filter(|x| x.iter().all(|v| v.is_finite()))
        .ok_or_else(|| {
            AlignError::Degenerate("the points are collinear: no circle passes through them".into())
        })?;
    let r0 = (x[2] + x[0] * x[0] + x[1] * x[1]).max(0.0).sqrt();
    let x0 = DVector::from_vec(vec![x[0], x[1], r0]);
    let (x, r, j) = levenberg_marquardt(x0, n, "circle", |x, i| {
        let (du, dv) = (uv[i].0 - x[0], uv[i].1 - x[1]);
        let len = du.hypot(dv).max(f64::MIN_POSITIVE);
        (len - x[2], [-du / len, -dv / len, -1.0, 0.0])
    })?;
    let center = m + (e1 * x[0] + e2 * x[1]) * s;
    let residuals: Vec<f64> = r.iter().map(|v| v * s).collect();
    let (rms, max_abs_residual) = rms_max(&residuals);
    let u = uncertainties(&j, &r);
    let mut all = vec![center.x, center.y, center.z, x[2] * s, rms];
    all.extend(u.iter().flatten().map(|v| v * s));
    finite_result("circle", &all)?;
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
