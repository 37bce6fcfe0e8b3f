//! Calibration of the rotary table (paper 000's Methods I, II, III and a full nonlinear
//! fit) and of the spindle-to-laser offset.
//!
//! Measurement model: the gage-ball centre measured at pose k (machine coordinates) is
//! `b_k = T_k(b₀)`, where `b₀` is the ball centre at A = B = 0 and `T_k` turns the table
//! about its axis lines. With intersecting axes through the rotation centre `c` and
//! `R = b₀ − c`, this is linear: `b_k = M_k·R + c` (`M_k` the table rotation). Method III
//! (eq. 21, `(I − R_B·R_A)·R = −D`) is the difference of two such equations; stacking the
//! undifferenced ones solves for R and c together and needs no pose at A = B = 0.

use lampost_kinematics::Machine;
use nalgebra::{DMatrix, DVector, Rotation3, Unit};
use serde::Serialize;

use crate::error::AlignError;
use crate::fit::{sphere, P3};

/// One measured pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Rotary angles, machine file order.
    pub rotary: [f64; 2],
    /// Measured ball centre, machine coordinates.
    pub center: P3,
    /// Source row (1-based line).
    pub row: usize,
    /// Standard uncertainty of the measured centre per coordinate (from its sphere fit);
    /// `None` weighs every pose alike.
    pub sigma: Option<[f64; 3]>,
}

impl Pose {
    fn weight(&self, k: usize) -> f64 {
        self.sigma.map_or(1.0, |s| 1.0 / s[k].max(1e-300))
    }
}

/// Which method.
/// A condition number as JSON: `null` for a singular design (infinite, or the
/// `f64::MAX` a result with nothing fixed carries), the number otherwise.
fn condition_or_null<S: serde::Serializer>(c: &f64, s: S) -> Result<S::Ok, S::Error> {
    if c.is_finite() && *c < f64::MAX {
        s.serialize_some(c)
    } else {
        s.serialize_none()
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Method I: a sphere through the ball centres; its centre is the rotation centre.
    I,

    /// Method III done right: eq. 21 over all poses, least squares.
    Iii,
    /// A nonlinear fit of both axis lines (direction and position) over all poses.
    Fit,
}

/// The residual of one pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PoseResidual {
    /// Source row.
    pub row: usize,
    /// Measured minus modelled ball centre.
    pub residual: [f64; 3],
    /// Its length.
    pub norm: f64,
}

/// When the poses cannot fix R: the line of solutions.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SolutionLine {
    /// One solution for R (the minimum-norm one).
    pub r_point: [f64; 3],
    /// The rotation centre for that solution.
    pub pivot_point: [f64; 3],
    /// Direction along which R (and, opposite, the centre) may move without changing any
    /// measurement: the common rotation axis of the poses.
    pub direction: [f64; 3],
    /// What pose would fix it.
    pub advice: String,
}

/// An axis line.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AxisLine {
    /// Axis name.
    pub name: &'static str,
    /// Unit direction.
    pub direction: [f64; 3],
    /// The point on the line nearest the ball centre at home.
    pub point: [f64; 3],
}

/// A pivot calibration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PivotResult {
    /// The method.
    pub method: Method,
    /// From the rotation centre to the ball centre at A = B = 0 (`None` when not fixed).
    #[serde(rename = "R")]
    pub r: Option<[f64; 3]>,
    /// Standard uncertainty of R's components.
    pub u_r: Option<[f64; 3]>,
    /// The rotation centre, machine coordinates (`None` when not fixed).
    pub pivot: Option<[f64; 3]>,
    /// The ball centre at A = B = 0 as the model sees it.
    pub ball_home: Option<[f64; 3]>,
    /// RMS of the pose residuals (per coordinate).
    pub rms: f64,
    /// Condition number of the (scaled) design: infinite (or `f64::MAX`) when the design
    /// is singular, written `null` in JSON (a number could not be, and the CLI's JSON
    /// writer refuses a non-finite one).
    #[serde(serialize_with = "condition_or_null")]
    pub condition: f64,
    /// Residual of each pose.
    pub per_pose: Vec<PoseResidual>,
    /// The line of solutions when the poses cannot fix R.
    pub line: Option<SolutionLine>,
    /// The fitted axis lines (method `fit`).
    pub axes: Option<[AxisLine; 2]>,
    /// Remarks (assumptions of the method).
    pub notes: Vec<String>,
}

fn rot(m: &Machine, rotary: &[f64; 2]) -> nalgebra::Matrix3<f64> {
    let (ri, ro) = (&m.rotary[m.inner], &m.rotary[m.outer]);
    let a = Rotation3::from_axis_angle(&Unit::new_normalize(ri.axis), rotary[m.inner].to_radians());
    let b = Rotation3::from_axis_angle(&Unit::new_normalize(ro.axis), rotary[m.outer].to_radians());
    (b * a).into_inner()
}

/// The smallest standard uncertainty of a pose's centre that [`check_poses`] accepts, in
/// the machine's unit.
pub const MIN_SIGMA: f64 = 1e-9;

/// Check poses against the machine: limits, coordinates and uncertainties in range, and
/// enough of them.
pub fn check_poses(m: &Machine, poses: &[Pose], need: usize) -> Result<(), AlignError> {
    for p in poses {
        for (i, r) in m.rotary.iter().enumerate() {
            if !r.within(p.rotary[i]) {
                let (lo, hi) = r.limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
                return Err(AlignError::Calibration {
                    what: format!(
                        "row {}: {} = {} is outside its limits [{lo}, {hi}]",
                        p.row, r.name, p.rotary[i]
                    ),
                    hint: "check the angle columns (their order follows the header, else the machine's rotary order) and the machine file's limits",
                });
            }
        }
        if !p
            .center
            .iter()
            .chain(p.rotary.iter())
            .all(|x| x.is_finite())
        {
            return Err(AlignError::NotFinite(p.row));
        }
        if let Some(&value) = p
            .center
            .iter()
            .chain(p.rotary.iter())
            .find(|x| x.abs() > crate::fit::MAX_COORD)
        {
            return Err(AlignError::TooLarge {
                index: p.row,
                value,
            });
        }
        // Weights are 1/σ: beyond these bounds their squares overflow or vanish beside
        // the coordinates' (and no machine measures to 1e-9 of its unit).
        if let Some(&s) = p
            .sigma
            .iter()
            .flatten()
            .find(|s| !(s.is_finite() && (MIN_SIGMA..=crate::fit::MAX_COORD).contains(*s)))
        {
            return Err(AlignError::Calibration {
                what: format!(
                    "row {}: the uncertainty {s:e} is outside [{MIN_SIGMA:e}, {:e}] of the unit",
                    p.row,
                    crate::fit::MAX_COORD
                ),
                hint: "give each coordinate's standard uncertainty in the machine's unit, or leave the three columns out",
            });
        }
    }
    if poses.len() < need {
        return Err(AlignError::TooFewPoints {
            fit: "this calibration method (poses)",
            need,
            got: poses.len(),
        });
    }
    Ok(())
}

/// Standard uncertainties from variances; `None` when one is negative or not finite (an
/// inverse too ill-conditioned to mean anything: found by `cargo xtask fuzz`, where it
/// gave NaN).
fn variances_to_u(v: [f64; 3]) -> Option<[f64; 3]> {
    v.iter()
        .all(|x| x.is_finite() && *x >= 0.0)
        .then(|| v.map(f64::sqrt))
}

/// Each pose's measured minus modelled ball centre under the intersecting-axes model.
fn residuals(m: &Machine, poses: &[Pose], r: &P3, c: &P3) -> Vec<PoseResidual> {
    poses
        .iter()
        .map(|p| {
            let d = p.center - (rot(m, &p.rotary) * r + c);
            PoseResidual {
                row: p.row,
                residual: [d.x, d.y, d.z],
                norm: d.norm(),
            }
        })
        .collect()
}

/// Column `q` of a Jacobian by central differences with step `h`.
fn central_difference(
    f: &dyn Fn(&DVector<f64>) -> DVector<f64>,
    x: &DVector<f64>,
    q: usize,
    h: f64,
) -> DVector<f64> {
    let mut xp = x.clone();
    xp[q] += h;
    let mut xm = x.clone();
    xm[q] -= h;
    (f(&xp) - f(&xm)) / (2.0 * h)
}

/// A result that fixes nothing about R (the reason in `notes`).
fn unfixed(poses: &[Pose], rms: f64, note: String) -> PivotResult {
    PivotResult {
        method: Method::Iii,
        r: None,
        u_r: None,
        pivot: None,
        ball_home: None,
        rms,
        condition: f64::MAX,
        per_pose: poses
            .iter()
            .map(|p| PoseResidual {
                row: p.row,
                residual: [0.0; 3],
                norm: 0.0,
            })
            .collect(),
        line: None,
        axes: None,
        notes: vec![note],
    }
}

/// Method III done right: `[M_k  I]·[R; c] = b_k` stacked over all poses.
pub fn method_iii(m: &Machine, poses: &[Pose]) -> Result<PivotResult, AlignError> {
    check_poses(m, poses, 1)?;
    let k = poses.len();
    if k < 2 {
        // Three equations, six unknowns: R can be anything and the centre follows.
        return Ok(unfixed(
            poses,
            0.0,
            "one measured pose fixes nothing: any R fits it, with the centre following; measure the ball at home (A = B = 0) too for the paper's one-pose case (a line of solutions), and at poses turning about both axes to fix R".into(),
        ));
    }
    let mut a = DMatrix::zeros(3 * k, 6);
    let mut b = DVector::zeros(3 * k);
    for (i, p) in poses.iter().enumerate() {
        let mk = rot(m, &p.rotary);
        for r in 0..3 {
            let w = p.weight(r);
            for c in 0..3 {
                a[(3 * i + r, c)] = mk[(r, c)] * w;
            }
            a[(3 * i + r, 3 + r)] = w;
            b[3 * i + r] = p.center[r] * w;
        }
    }
    let svd = crate::fit::svd_capped(a.clone(), true, true, "Method III")?;
    let sv = svd.singular_values.clone();
    let smax = sv.max();
    let smin = sv.min();
    let condition = if smin > 0.0 {
        smax / smin
    } else {
        f64::INFINITY
    };
    let x = svd
        .solve(&b, 1e-9 * smax)
        .map_err(|_| AlignError::Calibration {
            what: "the Method III solve failed".into(),
            hint: "the poses are nearly degenerate: add poses that turn each rotary axis further",
        })?;
    let r = P3::new(x[0], x[1], x[2]);
    let c = P3::new(x[3], x[4], x[5]);
    let per_pose = residuals(m, poses, &r, &c);
    let ss: f64 = per_pose.iter().map(|p| p.norm * p.norm).sum();
    let rms = (ss / (3 * k) as f64).sqrt();
    // Weighted sum of squares, for the uncertainties.
    let wss: f64 = poses
        .iter()
        .zip(&per_pose)
        .map(|(p, r)| {
            (0..3)
                .map(|c| (r.residual[c] * p.weight(c)).powi(2))
                .sum::<f64>()
        })
        .sum();
    let notes =
        vec!["assumes the two rotary axes intersect (R is from their common point)".to_string()];
    let nullity =
        sv.iter().filter(|&&x| x <= 1e-9 * smax).count() + 6usize.saturating_sub(sv.len());
    if nullity > 1 {
        let mut r = unfixed(
            poses,
            rms,
            format!("all {k} poses are at the same rotary angles: they fix nothing about R (a {nullity}-dimensional family fits); measure the ball at poses turning about both axes"),
        );
        r.per_pose = per_pose;
        return Ok(r);
    }
    if smin <= 1e-9 * smax {
        // The null direction: R and c move oppositely along the poses' common axis.
        let vt = svd.v_t.as_ref().ok_or_else(|| AlignError::Calibration {
            what: "the SVD of the Method III design failed".into(),
            hint: "the poses are nearly degenerate: add poses that turn each rotary axis further",
        })?;
        let j = (0..sv.len())
            .min_by(|&p, &q| sv[p].total_cmp(&sv[q]))
            .unwrap_or(0);
        let dir = P3::new(vt[(j, 0)], vt[(j, 1)], vt[(j, 2)]);
        let dir = if dir.norm() > 0.0 {
            dir.normalize()
        } else {
            dir
        };
        let advice = if k == 1 {
            "one pose fixes R only up to a line (eq. 21's matrix I − M has the rotation axis in its null space); add a second pose that turns about a different axis".to_string()
        } else {
            format!(
                "every pose turns the table about one axis ({:.4}, {:.4}, {:.4}); add a pose that moves the other rotary axis",
                dir.x, dir.y, dir.z
            )
        };
        let mut res = unfixed(poses, rms, notes.join("; "));
        res.condition = condition;
        res.per_pose = per_pose;
        res.line = Some(SolutionLine {
            r_point: [r.x, r.y, r.z],
            pivot_point: [c.x, c.y, c.z],
            direction: [dir.x, dir.y, dir.z],
            advice,
        });
        return Ok(res);
    }
    let dof = (3 * k).saturating_sub(6);
    let u_r = if dof > 0 {
        let s2 = wss / dof as f64;
        (a.transpose() * &a)
            .try_inverse()
            .and_then(|cov| variances_to_u([s2 * cov[(0, 0)], s2 * cov[(1, 1)], s2 * cov[(2, 2)]]))
    } else {
        None
    };
    let home = r + c;
    Ok(PivotResult {
        method: Method::Iii,
        r: Some([r.x, r.y, r.z]),
        u_r,
        pivot: Some([c.x, c.y, c.z]),
        ball_home: Some([home.x, home.y, home.z]),
        rms,
        condition,
        per_pose,
        line: None,
        axes: None,
        notes,
    })
}

/// Method I: a sphere through the ball centres; its centre is the rotation centre.
pub fn method_i(m: &Machine, poses: &[Pose]) -> Result<PivotResult, AlignError> {
    check_poses(m, poses, 4)?;
    let pts: Vec<P3> = poses.iter().map(|p| p.center).collect();
    let s = sphere(&pts, None).map_err(|e| match e {
        AlignError::Degenerate(_) => AlignError::Calibration {
            what: "the ball centres lie on one plane (e.g. only one axis moved): Method I cannot place the rotation centre".into(),
            hint: "add poses that move the other rotary axis, or use --method iii",
        },
        other => other,
    })?;
    let c = P3::from(s.center);
    let mut r = P3::zeros();
    for p in poses {
        r += rot(m, &p.rotary).transpose() * (p.center - c);
    }
    r /= poses.len() as f64;
    let per_pose = residuals(m, poses, &r, &c);
    let ss: f64 = per_pose.iter().map(|p| p.norm * p.norm).sum();
    let home = r + c;
    // The condition of the sphere fit's centre: its uncertainty relative to the noise.
    let condition = method_iii(m, poses)
        .map(|x| x.condition)
        .unwrap_or(f64::INFINITY);
    Ok(PivotResult {
        method: Method::I,
        r: Some([r.x, r.y, r.z]),
        u_r: s.u_center,
        pivot: Some([c.x, c.y, c.z]),
        ball_home: Some([home.x, home.y, home.z]),
        rms: (ss / (3 * poses.len()) as f64).sqrt(),
        condition,
        per_pose,
        line: None,
        axes: None,
        notes: vec![
            "valid only when the two rotary axes intersect: the ball centres then lie on a sphere about their common point".into(),
            format!("sphere through the {} ball centres: radius |R| = {:.6}, rms {:.3e}", poses.len(), s.radius, s.rms),
        ],
    })
}

/// Parameters of the general model: b₀, and per axis two tilt angles of the direction and
/// two offsets of the line, both perpendicular to the nominal direction.
struct General<'m> {
    m: &'m Machine,
    bases: [(P3, P3, P3); 2],
    c0: [P3; 2],
}

impl General<'_> {
    fn axes(&self, x: &DVector<f64>) -> [(P3, P3); 2] {
        let mut out = [(P3::zeros(), P3::zeros()); 2];
        for (i, (n, e1, e2)) in self.bases.iter().enumerate() {
            let o = 3 + 4 * i;
            let d = (n + e1 * x[o] + e2 * x[o + 1]).normalize();
            let c = self.c0[i] + e1 * x[o + 2] + e2 * x[o + 3];
            out[i] = (d, c);
        }
        out
    }

    fn predict(&self, x: &DVector<f64>, rotary: &[f64; 2]) -> P3 {
        let b0 = P3::new(x[0], x[1], x[2]);
        let ax = self.axes(x);
        let (ii, oo) = (self.m.inner, self.m.outer);
        let turn = |p: P3, (d, c): (P3, P3), deg: f64| {
            Rotation3::from_axis_angle(&Unit::new_normalize(d), deg.to_radians()) * (p - c) + c
        };
        let p = turn(b0, ax[ii], rotary[ii]);
        turn(p, ax[oo], rotary[oo])
    }
}

/// Closest points of two lines (point, direction): (on the first, on the second).
fn closest(p1: P3, d1: P3, p2: P3, d2: P3) -> (P3, P3) {
    let w = p1 - p2;
    let (a, b, c, d, e) = (
        d1.dot(&d1),
        d1.dot(&d2),
        d2.dot(&d2),
        d1.dot(&w),
        d2.dot(&w),
    );
    let den = a * c - b * b;
    if den.abs() < 1e-15 {
        return (p1, p2 + d2 * (e / c));
    }
    let s = (b * e - c * d) / den;
    let t = (a * e - b * d) / den;
    (p1 + d1 * s, p2 + d2 * t)
}

/// The nonlinear fit of both axis lines over all poses (needs Method III's start, so
/// poses that move both axes), with R from the ball centre at home to the midpoint of
/// the axes' common perpendicular (their intersection when they meet).
pub fn method_fit(m: &Machine, poses: &[Pose]) -> Result<PivotResult, AlignError> {
    check_poses(m, poses, 4)?;
    let start = method_iii(m, poses)?;
    let (Some(r0), Some(c0)) = (start.r, start.pivot) else {
        let mut res = start;
        res.method = Method::Fit;
        return Ok(res);
    };
    let (r0, c0) = (P3::from(r0), P3::from(c0));
    let b0 = r0 + c0;
    let basis = |n: P3| {
        let h = if n.x.abs() < 0.9 { P3::x() } else { P3::y() };
        let e1 = (h - n * n.dot(&h)).normalize();
        (n, e1, n.cross(&e1))
    };
    let g = General {
        m,
        bases: [basis(m.rotary[0].axis), basis(m.rotary[1].axis)],
        c0: [c0, c0],
    };
    let k = poses.len();
    let np = 11;
    let mut x = DVector::zeros(np);
    x[0] = b0.x;
    x[1] = b0.y;
    x[2] = b0.z;
    let resid = |x: &DVector<f64>| -> DVector<f64> {
        let mut r = DVector::zeros(3 * k);
        for (i, p) in poses.iter().enumerate() {
            let d = g.predict(x, &p.rotary) - p.center;
            for c in 0..3 {
                r[3 * i + c] = d[c] * p.weight(c);
            }
        }
        r
    };
    let scale = (r0.norm() + 1.0).max(1e-9);
    // Difference steps: lengths (b₀ and the line offsets) scale with the table, tilts do not.
    let step = |q: usize| {
        if q < 3 || (q - 3) % 4 >= 2 {
            1e-7 * scale
        } else {
            1e-7
        }
    };
    let jac = |x: &DVector<f64>| -> DMatrix<f64> {
        let mut j = DMatrix::zeros(3 * k, np);
        for q in 0..np {
            j.set_column(q, &central_difference(&resid, x, q, step(q)));
        }
        j
    };
    // Gauss–Newton with SVD steps (the model is nearly linear near the start).
    let mut converged = false;
    for _ in 0..50 {
        let j = jac(&x);
        let r = resid(&x);
        let svd = crate::fit::svd_capped(j, true, true, "axis-line")?;
        let step = svd
            .solve(&(-&r), 1e-12 * svd.singular_values.max())
            .map_err(|_| AlignError::Calibration {
                what: "the axis-line fit failed".into(),
                hint: "the poses are nearly degenerate: move each axis to at least three angles, with the other axis at two or more positions",
            })?;
        x += &step;
        if step.norm() < 1e-13 * scale {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(AlignError::NoConvergence(
            "axis-line",
            "50 Gauss–Newton steps did not settle the axis lines (the poses may not fit two fixed axes)",
        ));
    }
    let j = jac(&x);
    let r = resid(&x);
    let jsv = crate::fit::svd_capped(j.clone(), false, false, "axis-line")?.singular_values;
    let condition = jsv.max() / jsv.min().max(f64::MIN_POSITIVE);
    if jsv.min() <= 1e-9 * jsv.max() {
        return Err(AlignError::Calibration {
            what: "the poses do not fix both axis lines".into(),
            hint: "move each axis to at least three angles, with the other axis at two or more positions, or use --method iii",
        });
    }
    let ax = g.axes(&x);
    let b0 = P3::new(x[0], x[1], x[2]);
    let r_of = |x: &DVector<f64>| {
        let ax = g.axes(x);
        let (p, q) = closest(ax[0].1, ax[0].0, ax[1].1, ax[1].0);
        P3::new(x[0], x[1], x[2]) - (p + q) / 2.0
    };
    let rv = r_of(&x);
    let ss = r.norm_squared();
    let dof = (3 * k).saturating_sub(np);
    let u_r = if dof > 0 {
        (j.transpose() * &j).try_inverse().and_then(|cov| {
            let s2 = ss / dof as f64;
            // Propagate to R numerically.
            let mut jr = DMatrix::zeros(3, np);
            for q in 0..np {
                let d = central_difference(
                    &|x: &DVector<f64>| DVector::from_column_slice(r_of(x).as_slice()),
                    &x,
                    q,
                    step(q),
                );
                for c in 0..3 {
                    jr[(c, q)] = d[c];
                }
            }
            let cr = &jr * (cov * s2) * jr.transpose();
            variances_to_u([cr[(0, 0)], cr[(1, 1)], cr[(2, 2)]])
        })
    } else {
        None
    };
    let per_pose: Vec<PoseResidual> = poses
        .iter()
        .map(|p| {
            let d = p.center - g.predict(&x, &p.rotary);
            PoseResidual {
                row: p.row,
                residual: [d.x, d.y, d.z],
                norm: d.norm(),
            }
        })
        .collect();
    let plain_ss: f64 = per_pose.iter().map(|p| p.norm * p.norm).sum();
    let line = |i: usize| {
        let (d, c) = ax[i];
        let foot = c + d * d.dot(&(b0 - c));
        AxisLine {
            name: if i == 0 { "first" } else { "second" },
            direction: [d.x, d.y, d.z],
            point: [foot.x, foot.y, foot.z],
        }
    };
    let (p, q) = closest(ax[0].1, ax[0].0, ax[1].1, ax[1].0);
    let mid = (p + q) / 2.0;
    Ok(PivotResult {
        method: Method::Fit,
        r: Some([rv.x, rv.y, rv.z]),
        u_r,
        pivot: Some([mid.x, mid.y, mid.z]),
        ball_home: Some([b0.x, b0.y, b0.z]),
        rms: (plain_ss / (3 * k) as f64).sqrt(),
        condition,
        per_pose,
        line: None,
        axes: Some([line(0), line(1)]),
        notes: vec![format!("axis lines fitted independently; they pass {:.3e} apart (R is to the midpoint of their common perpendicular)", (p - q).norm())],
    })
}

/// ISO 230-1 style location errors of the two axis lines.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisErrors {
    /// Each axis: name, direction, point, and its tilt from nominal about the two
    /// perpendicular machine axes (degrees).
    pub axes: Vec<AxisReport>,
    /// Shortest distance between the two lines (0 when they intersect).
    pub offset: f64,
    /// Angle between the lines minus the nominal angle (degrees): the squareness error.
    pub squareness_deg: f64,
    /// The common perpendicular's feet (on the first, on the second).
    pub closest_points: [[f64; 3]; 2],
}

/// One axis in [`AxisErrors`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisReport {
    /// Name.
    pub name: String,
    /// Unit direction.
    pub direction: [f64; 3],
    /// Point on the line nearest the ball at home.
    pub point: [f64; 3],
    /// Angle from the nominal direction (degrees).
    pub tilt_deg: f64,
    /// RMS of the circle fit(s) that found it.
    pub rms: f64,
}

/// Identify each rotary axis from poses that move one axis at a time: ball centres at
/// one fixed value of the other axis lie on a circle about the moving one.
pub fn axes_from_circles(m: &Machine, poses: &[Pose]) -> Result<AxisErrors, AlignError> {
    check_poses(m, poses, 3)?;
    // (axis index, +10 when measured with the outer axis away from home), centre,
    // direction, the outer axis' value, circle rms.
    let mut lines: Vec<(usize, P3, P3, f64, f64)> = Vec::new();
    for moving in 0..2 {
        let other = 1 - moving;
        let mut groups: Vec<(f64, Vec<&Pose>)> = Vec::new();
        for p in poses {
            match groups
                .iter_mut()
                .find(|(v, _)| (v - p.rotary[other]).abs() < 1e-9)
            {
                Some((_, g)) => g.push(p),
                None => groups.push((p.rotary[other], vec![p])),
            }
        }
        // Prefer the group at the other axis' home.
        groups.sort_by(|a, b| a.0.abs().total_cmp(&b.0.abs()));
        for (v, g) in groups {
            let mut angles: Vec<f64> = g.iter().map(|p| p.rotary[moving]).collect();
            angles.sort_by(f64::total_cmp);
            angles.dedup_by(|x, y| (*x - *y).abs() < 1e-9);
            if angles.len() < 3 {
                continue;
            }
            let pts: Vec<P3> = g.iter().map(|p| p.center).collect();
            let c = crate::fit::circle3d(&pts)?;
            let mut dir = P3::from(c.normal);
            if dir.dot(&m.rotary[moving].axis) < 0.0 {
                dir = -dir;
            }
            let id = if moving == m.inner && v.abs() > 1e-12 {
                moving + 10
            } else {
                moving
            };
            lines.push((id, P3::from(c.center), dir, v, c.rms));
            break;
        }
    }
    let outer = lines.iter().find(|l| l.0 == m.outer).copied();
    let mut found: [Option<(P3, P3, f64)>; 2] = [None, None];
    for &(id, c, d, v, rms) in &lines {
        if id < 10 {
            found[id] = Some((c, d, rms));
        } else if let Some((_, oc, od, _, _)) = outer {
            // Measured with the outer axis at v: turn the line back to home.
            let back = Rotation3::from_axis_angle(&Unit::new_normalize(od), -v.to_radians());
            found[id - 10] = Some((back * (c - oc) + oc, back * d, rms));
        }
    }
    let (Some(a0), Some(a1)) = (found[0], found[1]) else {
        let missing: Vec<&str> = (0..2)
            .filter(|&i| found[i].is_none())
            .map(|i| m.rotary[i].name.as_str())
            .collect();
        return Err(AlignError::Calibration {
            what: format!(
                "no group of at least three poses moves {} alone (the other axis fixed)",
                missing.join(" or ")
            ),
            hint: "probe at least three angles of that axis with the other axis fixed (`lampost probe poses --for axes` writes such a set)",
        });
    };
    let (p, q) = closest(a0.0, a0.1, a1.0, a1.1);
    let nominal_angle = m.rotary[0].axis.angle(&m.rotary[1].axis);
    let actual = a0.1.angle(&a1.1);
    let report = |i: usize, (c, d, rms): (P3, P3, f64)| AxisReport {
        name: m.rotary[i].name.clone(),
        direction: [d.x, d.y, d.z],
        point: [c.x, c.y, c.z],
        tilt_deg: d.angle(&m.rotary[i].axis).to_degrees(),
        rms,
    };
    Ok(AxisErrors {
        axes: vec![report(0, a0), report(1, a1)],
        offset: (p - q).norm(),
        squareness_deg: (actual - nominal_angle).to_degrees(),
        closest_points: [[p.x, p.y, p.z], [q.x, q.y, q.z]],
    })
}

/// Method II: the 2³ factorial design of paper 000's Table 1 around a start centre.
/// Refuses a start or step beyond ±[`crate::fit::MAX_COORD`] (or a step that is not
/// positive): no machine has such a centre, and the runs' centres would overflow.
pub fn factorial_design(start: P3, step: f64) -> Result<Vec<(usize, [i8; 3], P3)>, AlignError> {
    if !(step.is_finite() && step > 0.0 && step <= crate::fit::MAX_COORD) {
        return Err(AlignError::Calibration {
            what: format!("the step {step:e} must be positive and at most 1e9 of the unit"),
            hint:
                "give --step as the factor level, a small positive distance in the machine's unit",
        });
    }
    if let Some(&value) = start
        .iter()
        .find(|x| !x.is_finite() || x.abs() > crate::fit::MAX_COORD)
    {
        return Err(AlignError::Calibration {
            what: format!("the start coordinate {value:e} is beyond ±1e9 of the unit"),
            hint: "give --start as the nominal centre x,y,z in the machine's unit",
        });
    }
    let mut v = Vec::new();
    let mut run = 1;
    for sx in [1i8, -1] {
        for sy in [1i8, -1] {
            for sz in [1i8, -1] {
                let c = start + P3::new(f64::from(sx), f64::from(sy), f64::from(sz)) * step;
                v.push((run, [sx, sy, sz], c));
                run += 1;
            }
        }
    }
    Ok(v)
}

/// Method II's regression (eq. 18): variation = β₀ + β₁x + β₂y + β₃z in coded levels.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FactorialFit {
    /// β₀ … β₃.
    pub coefficients: [f64; 4],
    /// The run with the least variation (the paper's next start).
    pub best_run: usize,
    /// Its centre.
    pub best_center: [f64; 3],
    /// Where the fitted plane predicts zero variation, nearest the design centre.
    pub proposed_center: [f64; 3],
    /// RMS of the regression residuals.
    pub rms: f64,
}

/// Fit eq. 18 to measured variations at the design's centres: rows (centre, variation).
pub fn factorial_fit(rows: &[(P3, f64)]) -> Result<FactorialFit, AlignError> {
    if rows.len() < 4 {
        return Err(AlignError::TooFewPoints {
            fit: "the factorial regression (runs)",
            need: 4,
            got: rows.len(),
        });
    }
    for (i, (c, var)) in rows.iter().enumerate() {
        if let Some(&value) = c
            .iter()
            .chain(std::iter::once(var))
            .find(|x| !x.is_finite() || x.abs() > crate::fit::MAX_COORD)
        {
            return Err(AlignError::TooLarge {
                index: i + 1,
                value,
            });
        }
    }
    let mean = rows.iter().fold(P3::zeros(), |a, r| a + r.0) / rows.len() as f64;
    let half = rows
        .iter()
        .map(|r| (r.0 - mean).abs().max())
        .fold(0.0, f64::max);
    if half <= 0.0 {
        return Err(AlignError::Calibration {
            what: "all runs use the same centre".into(),
            hint: "give the eight runs of the 2³ design (`lampost calibrate factorial --start … --step …` lists them)",
        });
    }
    let a = DMatrix::from_fn(rows.len(), 4, |i, k| {
        if k == 0 {
            1.0
        } else {
            (rows[i].0[k - 1] - mean[k - 1]) / half
        }
    });
    let b = DVector::from_fn(rows.len(), |i, _| rows[i].1);
    let svd = crate::fit::svd_capped(a.clone(), true, true, "factorial regression")?;
    if svd.singular_values.min() <= 1e-9 * svd.singular_values.max() {
        return Err(AlignError::Calibration {
            what: "the runs do not vary x, y and z independently".into(),
            hint: "use the full 2³ design (`lampost calibrate factorial --start … --step …` lists its eight runs)",
        });
    }
    let beta = svd
        .solve(&b, 1e-12)
        .map_err(|_| AlignError::Calibration {
            what: "the factorial regression failed".into(),
            hint: "use the full 2³ design (`lampost calibrate factorial --start … --step …` lists its eight runs)",
        })?;
    let res = &a * &beta - &b;
    let g = P3::new(beta[1], beta[2], beta[3]);
    let u = if g.norm_squared() > 0.0 {
        -g * (beta[0] / g.norm_squared())
    } else {
        P3::zeros()
    };
    let proposed = mean + u * half;
    let (bi, br) = rows
        .iter()
        .enumerate()
        .min_by(|x, y| x.1 .1.total_cmp(&y.1 .1))
        .map(|(i, r)| (i, r.0))
        .unwrap_or((0, mean));
    let rms = (res.norm_squared() / rows.len() as f64).sqrt();
    crate::fit::finite_result(
        "factorial regression",
        &[
            beta[0], beta[1], beta[2], beta[3], proposed.x, proposed.y, proposed.z, rms,
        ],
    )?;
    Ok(FactorialFit {
        coefficients: [beta[0], beta[1], beta[2], beta[3]],
        best_run: bi + 1,
        best_center: [br.x, br.y, br.z],
        proposed_center: [proposed.x, proposed.y, proposed.z],
        rms,
    })
}

/// The spindle-to-laser offset from burn marks: L = probed − burned, averaged, with the
/// spread (standard deviation per component; `None` with one pair).
pub fn laser_offset(pairs: &[(P3, P3)]) -> Result<([f64; 3], Option<[f64; 3]>), AlignError> {
    if pairs.is_empty() {
        return Err(AlignError::TooFewPoints {
            fit: "the laser offset (burn marks)",
            need: 1,
            got: 0,
        });
    }
    for (k, (burned, probed)) in pairs.iter().enumerate() {
        let both = [*burned, *probed];
        crate::fit::check_points(&both, "the laser offset (burn marks)", 0)
            .map_err(|e| {
                match e {
                    AlignError::TooLarge { value, .. } => AlignError::TooLarge {
                        index: k + 1,
                        value,
                    },
                    AlignError::NotFinite(_) => AlignError::NotFinite(k + 1),
                    // The same point burned and probed: an offset of zero.
                    _ => e,
                }
            })
            .or_else(|e| match e {
                AlignError::DuplicatePoints { .. } => Ok(()),
                e => Err(e),
            })?;
    }
    let ls: Vec<P3> = pairs
        .iter()
        .map(|(burned, probed)| probed - burned)
        .collect();
    let mean = ls.iter().fold(P3::zeros(), |a, l| a + l) / ls.len() as f64;
    let spread = if ls.len() > 1 {
        let mut v = P3::zeros();
        for l in &ls {
            v += (l - mean).component_mul(&(l - mean));
        }
        v /= (ls.len() - 1) as f64;
        Some([v.x.sqrt(), v.y.sqrt(), v.z.sqrt()])
    } else {
        None
    };
    Ok(([mean.x, mean.y, mean.z], spread))
}

/// The machine file with a calibration written into it: R (intersecting-axes methods, as
/// the parameter the pivots use) or both axis lines (the fit), relative to the ball
/// centre at home (the machine frame's origin).
pub fn updated_machine(
    m: &Machine,
    res: &PivotResult,
) -> Result<lampost_kinematics::MachineDef, AlignError> {
    use lampost_kinematics::{ParamValue, VecExpr};
    let mut def = m.def.clone();
    let (Some(r), Some(home)) = (res.r, res.ball_home) else {
        return Err(AlignError::Calibration {
            what: "the poses do not fix R; nothing to write".into(),
            hint: "add poses that turn about both rotary axes (see the report's line of solutions)",
        });
    };
    let mut numbers: Vec<f64> = r.iter().chain(home.iter()).copied().collect();
    numbers.extend(res.u_r.iter().flatten());
    numbers.push(res.rms);
    for a in res.axes.iter().flatten() {
        numbers.extend(a.direction.iter().chain(a.point.iter()));
    }
    if !numbers.iter().all(|x| x.is_finite()) {
        return Err(AlignError::Calibration {
            what: "the calibration has a non-finite number (R, its uncertainty u_R, or the rms): no machine file is written from it".into(),
            hint: "check the ball centres for outliers and the poses for a degenerate set",
        });
    }
    match &res.axes {
        Some(axes) => {
            for (i, a) in axes.iter().enumerate() {
                let rd = &mut def.rotary[i];
                rd.axis = a.direction;
                let p = P3::from(a.point) - P3::from(home);
                rd.pivot = VecExpr::Literal([p.x, p.y, p.z]);
            }
            if def.parameters.contains_key("R") {
                def.parameters.insert("R".into(), ParamValue::Vector(r));
            }
        }
        None => {
            let uses_r = def.rotary.iter().all(|rd| matches!(&rd.pivot, VecExpr::Scaled { param, scale } if param == "R" && *scale == -1.0));
            if uses_r {
                def.parameters.insert("R".into(), ParamValue::Vector(r));
            } else {
                for rd in def.rotary.iter_mut() {
                    rd.pivot = VecExpr::Literal([-r[0], -r[1], -r[2]]);
                }
            }
        }
    }
    def.assumptions.push(format!(
        "Rotary pivots calibrated by lampost calibrate pivot (method {}), rms {:.3e}.",
        format!("{:?}", res.method).to_lowercase(),
        res.rms
    ));
    // Check it builds.
    Machine::new(def.clone(), &[])
        .map_err(|e| AlignError::Calibration {
            what: format!("the updated machine is not valid: {e}"),
            hint: "the measured R moves the machine out of its own limits: check the poses and the ball centres",
        })?;
    Ok(def)
}

/// Condition of a pose set for Method III, before anyone probes: (condition number, the
/// line of solutions' direction when rank-deficient). Refuses a set that fixes nothing
/// at all (no poses, or every pose at the same angles).
pub fn pose_conditioning(
    m: &Machine,
    rotary: &[[f64; 2]],
) -> Result<(f64, Option<[f64; 3]>), AlignError> {
    if rotary.is_empty() {
        return Err(AlignError::Calibration {
            what: "the pose set is empty: it fixes nothing".into(),
            hint: "give poses turning about both rotary axes, e.g. A=0,B=0;A=90,B=0;A=0,B=30;A=90,B=30",
        });
    }
    let poses: Vec<Pose> = rotary
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let c = m.part_to_machine(r, &P3::zeros());
            Pose {
                rotary: *r,
                center: c,
                row: i + 1,
                sigma: None,
            }
        })
        .collect();
    let r = method_iii(m, &poses)?;
    match (&r.r, &r.line) {
        (Some(_), _) => Ok((r.condition, None)),
        (None, Some(l)) => Ok((r.condition, Some(l.direction))),
        (None, None) => Err(AlignError::Calibration {
            what: format!(
                "the pose set fixes nothing about R and the centre: {}",
                r.notes.join("; ")
            ),
            hint: "give poses turning about both rotary axes, e.g. A=0,B=0;A=90,B=0;A=0,B=30;A=90,B=30",
        }),
    }
}

/// Simulated ball centres for a machine whose axis lines are `truth` (direction, point;
/// file order), ball centre `b0` at home: the centre at each pose.
pub fn simulate_centres(m: &Machine, truth: &[(P3, P3); 2], b0: P3, rotary: &[f64; 2]) -> P3 {
    let (ii, oo) = (m.inner, m.outer);
    let turn = |p: P3, (d, c): (P3, P3), deg: f64| {
        Rotation3::from_axis_angle(&Unit::new_normalize(d), deg.to_radians()) * (p - c) + c
    };
    turn(turn(b0, truth[ii], rotary[ii]), truth[oo], rotary[oo])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::Rng;

    fn fadal() -> Machine {
        Machine::builtin("fadal-lamp", &[]).expect("machine")
    }

    /// Found by `cargo xtask fuzz` (numeric target): burn marks beyond ±1e9 gave an
    /// infinite spread, and uncertainties of 1e-300 or 1e308 NaN residuals and `u_R`.
    #[test]
    fn laser_offset_and_uncertainties_out_of_range_are_refused() {
        let far = P3::new(1e308, 0.0, 0.0);
        let r = laser_offset(&[(P3::zeros(), P3::zeros()), (-far, far)]);
        assert!(
            matches!(r, Err(AlignError::TooLarge { index: 2, .. })),
            "{r:?}"
        );
        let (l, spread) = laser_offset(&[
            (P3::zeros(), P3::new(1.0, 0.0, 0.0)),
            (P3::zeros(), P3::zeros()),
        ])
        .expect("in range");
        assert_eq!(l, [0.5, 0.0, 0.0]);
        assert!(spread.is_some_and(|s| s.iter().all(|v| v.is_finite())));
        let m = fadal();
        let c = P3::new(7.877, -3.4798, -6.0918);
        let truth = [(m.rotary[0].axis, c), (m.rotary[1].axis, c)];
        let mut poses = exact(&m, &truth, P3::new(3.0, -2.0, 1.0), &poses8());
        for p in &mut poses {
            p.sigma = Some([1e-4; 3]);
        }
        assert!(method_iii(&m, &poses)
            .is_ok_and(|r| r.u_r.is_some_and(|u| u.iter().all(|v| v.is_finite()))));
        for bad in [1e-300, 1e308, 0.0, f64::NAN] {
            poses[1].sigma = Some([1e-4, bad, 1e-4]);
            let r = method_iii(&m, &poses);
            assert!(
                matches!(&r, Err(AlignError::Calibration { what, .. }) if what.starts_with("row 2: the uncertainty")),
                "{bad}: {r:?}"
            );
        }
    }

    /// Found by `cargo xtask fuzz` (numeric target, seed 3, input 126194): an
    /// ill-conditioned Method III design (uncertainties 1e3 and 1e9 beside unweighted
    /// poses) gave `u_R` = NaN from a negative variance; it is now left out.
    #[test]
    fn ill_conditioned_uncertainty_is_left_out_not_nan() {
        assert_eq!(variances_to_u([4.0, 0.0, 1.0]), Some([2.0, 0.0, 1.0]));
        assert_eq!(variances_to_u([4.0, -1e-20, 1.0]), None);
        assert_eq!(variances_to_u([f64::INFINITY, 1.0, 1.0]), None);
        let m = Machine::builtin("nrc-lc", &[]).expect("machine");
        let pose = |rotary: [f64; 2], x: f64, sigma: Option<[f64; 3]>, row: usize| Pose {
            rotary,
            center: P3::new(x, 3.633826562083369, -3.159122641960284),
            row,
            sigma,
        };
        let s = 0.8589743093803003;
        let poses = [
            pose(
                [-90.0, -157.14359908444328],
                -2.2250738585072014e-308,
                Some([1e3; 3]),
                1,
            ),
            pose([105.85023488894646, -180.0], s, Some([1e9; 3]), 2),
            pose(
                [67.23553195635353, 653.9704184458857],
                1.7179486187606006,
                None,
                3,
            ),
            pose(
                [113.12982999500124, 140.1807612784674],
                2.5769229281409007,
                Some([539070896.204483; 3]),
                4,
            ),
        ];
        let r = method_iii(&m, &poses).expect("R fixed");
        assert!(r.r.is_some(), "{r:?}");
        assert!(
            r.u_r.is_none_or(|u| u.iter().all(|v| v.is_finite())),
            "{r:?}"
        );
    }

    fn poses8() -> Vec<[f64; 2]> {
        let mut v = Vec::new();
        for b in [0.0, 45.0] {
            for a in [0.0, 90.0, 180.0, 270.0] {
                v.push([a, b]);
            }
        }
        v
    }

    fn exact(m: &Machine, truth: &[(P3, P3); 2], b0: P3, set: &[[f64; 2]]) -> Vec<Pose> {
        set.iter()
            .enumerate()
            .map(|(i, r)| Pose {
                rotary: *r,
                center: simulate_centres(m, truth, b0, r),
                row: i + 1,
                sigma: None,
            })
            .collect()
    }

    #[test]
    fn every_method_recovers_an_ideal_table() {
        let m = fadal();
        let r = P3::new(-4.877, 1.4798, 7.0918);
        let b0 = P3::new(3.0, -2.0, 1.0);
        let c = b0 - r;
        let truth = [(m.rotary[0].axis, c), (m.rotary[1].axis, c)];
        let poses = exact(&m, &truth, b0, &poses8());
        for res in [
            method_i(&m, &poses).expect("I"),
            method_iii(&m, &poses).expect("III"),
            method_fit(&m, &poses).expect("fit"),
        ] {
            let got = P3::from(res.r.expect("fixed"));
            assert!((got - r).norm() < 1e-9, "{:?}: {got:?}", res.method);
            assert!((P3::from(res.pivot.expect("pivot")) - c).norm() < 1e-9);
        }
    }

    #[test]
    fn no_machine_file_from_a_non_finite_uncertainty() {
        let m = fadal();
        let r = P3::new(-4.877, 1.4798, 7.0918);
        let b0 = P3::new(3.0, -2.0, 1.0);
        let c = b0 - r;
        let truth = [(m.rotary[0].axis, c), (m.rotary[1].axis, c)];
        let poses = exact(&m, &truth, b0, &poses8());
        let mut res = method_iii(&m, &poses).expect("III");
        assert!(updated_machine(&m, &res).is_ok());
        res.u_r = Some([f64::INFINITY, 0.0, 0.0]);
        let e = updated_machine(&m, &res).expect_err("refused");
        assert!(e.to_string().contains("no machine file"), "{e}");
    }

    #[test]
    fn pose_sets_that_fix_nothing_are_refused() {
        let m = fadal();
        assert!(pose_conditioning(&m, &[]).is_err());
        assert!(pose_conditioning(&m, &[[10.0, 0.0]; 4]).is_err());
        assert!(pose_conditioning(&m, &poses8()).is_ok_and(|(c, l)| c.is_finite() && l.is_none()));
    }

    #[test]
    fn huge_pose_coordinates_are_refused() {
        let m = fadal();
        let mut poses = exact(
            &m,
            &[
                (m.rotary[0].axis, P3::zeros()),
                (m.rotary[1].axis, P3::zeros()),
            ],
            P3::new(1.0, 0.0, 0.0),
            &poses8(),
        );
        poses[2].center.x = 1e200;
        for r in [
            method_i(&m, &poses),
            method_iii(&m, &poses),
            method_fit(&m, &poses),
        ] {
            assert!(
                matches!(r, Err(AlignError::TooLarge { index: 3, .. })),
                "{r:?}"
            );
        }
        assert!(factorial_design(P3::new(1e308, 0.0, 0.0), 1e308).is_err());
    }

    #[test]
    fn one_pose_gives_the_line_of_solutions() {
        let m = fadal();
        let r = P3::new(-4.877, 1.4798, 7.0918);
        let b0 = P3::new(0.0, 0.0, 0.0);
        let c = b0 - r;
        let truth = [(m.rotary[0].axis, c), (m.rotary[1].axis, c)];
        let poses = exact(&m, &truth, b0, &[[0.0, 0.0], [45.0, -45.0]]);
        let res = method_iii(&m, &poses).expect("runs");
        assert!(res.r.is_none());
        let line = res.line.expect("line");
        // The truth lies on the line.
        let d = P3::from(line.direction);
        let off = r - P3::from(line.r_point);
        assert!((off - d * d.dot(&off)).norm() < 1e-9, "{line:?}");
        // Only A moved: the line runs along A's axis.
        let only_a = exact(&m, &truth, b0, &[[0.0, 0.0], [90.0, 0.0], [180.0, 0.0]]);
        let l = method_iii(&m, &only_a).expect("runs").line.expect("line");
        assert!(P3::from(l.direction).cross(&P3::z()).norm() < 1e-9);
        assert!(l.advice.contains("other rotary axis"));
    }

    #[test]
    fn fit_handles_offset_and_tilted_axes() {
        let m = fadal();
        let r = P3::new(-4.877, 1.4798, 7.0918);
        let b0 = P3::new(1.0, 2.0, -3.0);
        let c = b0 - r;
        // A tilted 0.02 deg, B's line 0.0004 in (10 µm) away from A's.
        let tilt = Rotation3::from_axis_angle(&P3::x_axis(), 0.02f64.to_radians());
        let truth = [
            (tilt * m.rotary[0].axis, c),
            (m.rotary[1].axis, c + P3::new(0.0004, 0.0, 0.0)),
        ];
        let poses = exact(&m, &truth, b0, &poses8());
        let fit = method_fit(&m, &poses).expect("fit");
        assert!(fit.rms < 1e-10, "{}", fit.rms);
        let axes = fit.axes.expect("axes");
        assert!((P3::from(axes[0].direction) - truth[0].0).norm() < 1e-9);
        let iii = method_iii(&m, &poses).expect("iii");
        assert!(
            iii.rms > 1e-5,
            "the intersecting model cannot fit offset axes: {}",
            iii.rms
        );
        // Identification by circles.
        let mut set = poses8();
        set.extend([[0.0, -45.0], [0.0, 30.0]]);
        let e = axes_from_circles(&m, &exact(&m, &truth, b0, &set)).expect("axes");
        assert!((e.offset - 0.0004).abs() < 1e-7, "{e:?}");
        assert!((e.axes[0].tilt_deg - 0.02).abs() < 1e-6, "{e:?}");
    }

    #[test]
    fn noisy_fit_is_within_two_micrometres_with_eight_poses() {
        let m = fadal();
        let r = P3::new(-4.877, 1.4798, 7.0918);
        let b0 = P3::new(1.0, 2.0, -3.0);
        let truth = [(m.rotary[0].axis, b0 - r), (m.rotary[1].axis, b0 - r)];
        let sigma = 0.001 / 25.4 / 30f64.sqrt() * 2.0; // ~ a 30-point centre's noise
        let mut rng = Rng::new(3);
        let mut covered = 0;
        let trials = 50;
        for _ in 0..trials {
            let poses: Vec<Pose> = exact(&m, &truth, b0, &poses8())
                .into_iter()
                .map(|mut p| {
                    p.center += P3::new(rng.normal(), rng.normal(), rng.normal()) * sigma;
                    p
                })
                .collect();
            let fit = method_iii(&m, &poses).expect("iii");
            let err = P3::from(fit.r.expect("r")) - r;
            assert!(err.norm() < 0.002 / 25.4, "{err:?}");
            let u = fit.u_r.expect("u");
            covered += (0..3).filter(|&k| err[k].abs() <= 2.0 * u[k]).count();
        }
        assert!(
            covered as f64 / (3.0 * f64::from(trials)) > 0.85,
            "{covered}"
        );
    }

    #[test]
    fn factorial_and_laser() {
        let runs = factorial_design(P3::new(-4.9, 1.5, 7.1), 0.01).expect("design");
        assert_eq!(runs.len(), 8);
        assert_eq!(runs[0].1, [1, 1, 1]);
        assert_eq!(runs[7].1, [-1, -1, -1]);
        // Variation linear in x, y as eq. 18, zero at x = -4.905.
        let rows: Vec<(P3, f64)> = runs
            .iter()
            .map(|(_, _, c)| (*c, 0.4 * (c.x + 4.905) / 0.01 + 0.13 * (c.y - 1.5) / 0.01))
            .collect();
        let f = factorial_fit(&rows).expect("fits");
        let [x, y, _] = f.proposed_center;
        let predicted = 0.4 * (x + 4.905) / 0.01 + 0.13 * (y - 1.5) / 0.01;
        assert!(predicted.abs() < 1e-9, "{f:?}");
        assert!((f.coefficients[1] - 0.4).abs() < 1e-9 && f.coefficients[3].abs() < 1e-9);
        let (l, spread) = laser_offset(&[
            (P3::new(0.0, 0.0, 0.0), P3::new(-10.1, 0.04, -8.7)),
            (P3::new(1.0, 1.0, 0.0), P3::new(-9.1, 1.02, -8.72)),
        ])
        .expect("l");
        assert!((l[0] + 10.1).abs() < 1e-12 && spread.is_some());
    }
}

#[cfg(test)]
mod edge_tests {
    use super::*;

    #[test]
    fn one_pose_is_a_line_not_a_panic() {
        let m = Machine::builtin("fadal-lamp", &[]).expect("machine");
        let r = method_iii(
            &m,
            &[Pose {
                rotary: [45.0, -45.0],
                center: P3::new(1.0, 2.0, 3.0),
                row: 1,
                sigma: None,
            }],
        )
        .expect("runs");
        assert!(r.r.is_none() && r.line.is_none());
        let two = [
            Pose {
                rotary: [0.0, 0.0],
                center: P3::new(1.0, 2.0, 3.0),
                row: 1,
                sigma: None,
            },
            Pose {
                rotary: [45.0, -45.0],
                center: P3::new(1.5, 2.5, 2.0),
                row: 2,
                sigma: None,
            },
        ];
        let r = method_iii(&m, &two).expect("runs");
        assert!(r.r.is_none() && r.line.is_some());
        let same = [two[1], Pose { row: 3, ..two[1] }, Pose { row: 4, ..two[1] }];
        let r = method_iii(&m, &same).expect("runs");
        assert!(
            r.r.is_none() && r.line.is_none() && r.notes[0].contains("same rotary angles"),
            "{r:?}"
        );
        let r = method_iii(
            &m,
            &[Pose {
                rotary: [0.0, 0.0],
                center: P3::new(1.0, 2.0, 3.0),
                row: 1,
                sigma: None,
            }],
        )
        .expect("runs");
        assert!(r.r.is_none());
    }
}
