//! Monte-Carlo accuracy studies of the fits (used by `cargo xtask accuracy` and tests).

use crate::fit::{sphere, sphere4, P3};

/// A small deterministic generator: xorshift64* and Box–Muller.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// Seeded.
    pub fn new(seed: u64) -> Self {
        Rng(seed | 1)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(f64::MIN_POSITIVE);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// Spread of fitted centres about the truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// Standard deviation of the centre's x, y, z.
    pub std_center: [f64; 3],
    /// Root mean square of |centre − truth|.
    pub rms_center_error: f64,
    /// Largest |centre − truth|.
    pub max_center_error: f64,
    /// Standard deviation of the radius.
    pub std_radius: f64,
    /// Fraction of centre coordinates whose reported standard uncertainty, times 2,
    /// covered the true error (N-point fit only; about 95 % expected).
    pub coverage_2u: Option<f64>,
}

fn spread(errs: &[(P3, f64)], covered: Option<usize>) -> Spread {
    let n = errs.len() as f64;
    let mean = errs.iter().fold(P3::zeros(), |a, e| a + e.0) / n;
    let mut var = P3::zeros();
    for e in errs {
        let d = e.0 - mean;
        var += d.component_mul(&d);
    }
    var /= n - 1.0;
    let rmean = errs.iter().map(|e| e.1).sum::<f64>() / n;
    let rvar = errs.iter().map(|e| (e.1 - rmean).powi(2)).sum::<f64>() / (n - 1.0);
    Spread {
        std_center: [var.x.sqrt(), var.y.sqrt(), var.z.sqrt()],
        rms_center_error: (errs.iter().map(|e| e.0.norm_squared()).sum::<f64>() / n).sqrt(),
        max_center_error: errs.iter().map(|e| e.0.norm()).fold(0.0, f64::max),
        std_radius: rvar.sqrt(),
        coverage_2u: covered.map(|c| c as f64 / (3.0 * n)),
    }
}

/// Points on a cap (polar angle ≤ `cap_deg`) of a sphere, on a spherical Fibonacci spiral.
pub fn cap_points(n: usize, radius: f64, cap_deg: f64) -> Vec<P3> {
    let zmin = cap_deg.to_radians().cos();
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (1.0 - zmin) * (i as f64 + 0.5) / n as f64;
            let rho = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            P3::new(rho * phi.cos(), rho * phi.sin(), z) * radius
        })
        .collect()
}

/// The paper's four-point method against the N-point geometric fit: `trials` balls of
/// `radius`, touched with isotropic Gaussian noise `sigma` on every coordinate; the four
/// points are the best-conditioned four on the cap (the pole and three at its edge, 120°
/// apart), the N points a Fibonacci spiral over it. Returns (four-point, N-point).
pub fn four_vs_n(
    trials: usize,
    n: usize,
    radius: f64,
    cap_deg: f64,
    sigma: f64,
    seed: u64,
) -> (Spread, Spread) {
    let mut rng = Rng::new(seed);
    let edge = cap_deg.to_radians();
    let four: Vec<P3> = std::iter::once(P3::new(0.0, 0.0, radius))
        .chain((0..3).map(|k| {
            let phi = f64::from(k) * 2.0 * std::f64::consts::PI / 3.0;
            P3::new(edge.sin() * phi.cos(), edge.sin() * phi.sin(), edge.cos()) * radius
        }))
        .collect();
    let many = cap_points(n, radius, cap_deg);
    let mut e4 = Vec::with_capacity(trials);
    let mut en = Vec::with_capacity(trials);
    let mut covered = 0;
    for _ in 0..trials {
        let c = P3::new(
            rng.uniform() * 100.0,
            rng.uniform() * 100.0,
            rng.uniform() * 100.0,
        );
        let mut noisy = |pts: &[P3]| -> Vec<P3> {
            pts.iter()
                .map(|p| c + p + P3::new(rng.normal(), rng.normal(), rng.normal()) * sigma)
                .collect()
        };
        let p4 = noisy(&four);
        let pn = noisy(&many);
        if let Ok(f) = sphere4(&p4) {
            e4.push((P3::from(f.center) - c, f.radius));
        }
        if let Ok(f) = sphere(&pn, None) {
            let err = P3::from(f.center) - c;
            if let Some(u) = f.u_center {
                covered += (0..3).filter(|&k| err[k].abs() <= 2.0 * u[k]).count();
            }
            en.push((err, f.radius));
        }
    }
    (spread(&e4, None), spread(&en, Some(covered)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_calibration_chain_meets_its_target() {
        // 5 µm between the axis lines and a 0.005° tilt: only the axis-line fit is
        // unbiased; with 8 poses it is within 2 µm and its uncertainty covers the error.
        let cells = calibration_table(40, 0.001 / 25.4, 0.005 / 25.4, 0.005, 11);
        let fit8 = cells
            .iter()
            .find(|c| c.method.starts_with("axis-line") && c.poses == 8)
            .expect("cell");
        assert_eq!(fit8.solved, 40);
        assert!(fit8.max_error < 0.002 / 25.4, "{fit8:?}");
        assert!(fit8.coverage_2u.expect("u") >= 0.85, "{fit8:?}");
        let two = cells
            .iter()
            .filter(|c| c.poses == 2 && !c.method.starts_with("paper"))
            .collect::<Vec<_>>();
        assert!(two.iter().all(|c| c.solved == 0), "two poses never fix R");
    }

    #[test]
    fn n_point_fit_beats_four_points() {
        // 25 mm ball, 120° cap (60° from the pole), σ = 1 µm, 30 points.
        let (f4, fnp) = four_vs_n(200, 30, 12.5, 60.0, 0.001, 7);
        assert!(
            fnp.rms_center_error < f4.rms_center_error / 1.5,
            "{fnp:?} vs {f4:?}"
        );
        assert!(fnp.coverage_2u.expect("coverage") > 0.9, "{fnp:?}");
    }
}

/// One cell of the calibration accuracy table.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibCell {
    /// Method label.
    pub method: &'static str,
    /// Number of poses.
    pub poses: usize,
    /// Trials that gave a number for R.
    pub solved: usize,
    /// Trials run.
    pub trials: usize,
    /// RMS of |R − truth|.
    pub rms_error: f64,
    /// Largest |R − truth|.
    pub max_error: f64,
    /// Fraction of R's coordinates whose 2·u covered the true error.
    pub coverage_2u: Option<f64>,
}

/// The full chain on a simulated FADAL whose table has axis errors: `b_line_offset`
/// moves B's line off A's (in inches), `a_tilt_deg` tilts A; 30 noisy touches (σ per
/// coordinate, inches) on the gage ball at each pose → free sphere fits → each method.
/// Returns the table and the truth's R (ball at home to the midpoint of the axes' common
/// perpendicular).
pub fn calibration_table(
    trials: usize,
    sigma: f64,
    b_line_offset: f64,
    a_tilt_deg: f64,
    seed: u64,
) -> Vec<CalibCell> {
    use crate::calib::{method_fit, method_i, method_iii, simulate_centres, Pose};
    use lampost_kinematics::Machine;
    use nalgebra::Rotation3;
    let Ok(m) = Machine::builtin("fadal-lamp", &[]) else {
        return Vec::new();
    };
    let r_nominal = P3::new(-4.877, 1.4798, 7.0918);
    let b0 = P3::new(2.0, -1.0, -4.0);
    let c = b0 - r_nominal;
    let tilt = Rotation3::from_axis_angle(&P3::x_axis(), a_tilt_deg.to_radians());
    let truth = [
        (tilt * m.rotary[0].axis, c),
        (m.rotary[1].axis, c + P3::new(b_line_offset, 0.0, 0.0)),
    ];
    // The truth's R, as method `fit` defines it.
    let r_true = {
        let (d1, p1, d2, p2) = (truth[0].0, truth[0].1, truth[1].0, truth[1].1);
        let w = p1 - p2;
        let (a, b, cc, d, e) = (
            d1.dot(&d1),
            d1.dot(&d2),
            d2.dot(&d2),
            d1.dot(&w),
            d2.dot(&w),
        );
        let den = a * cc - b * b;
        let s = (b * e - cc * d) / den;
        let t = (a * e - b * d) / den;
        b0 - ((p1 + d1 * s) + (p2 + d2 * t)) / 2.0
    };
    let sets: Vec<(usize, Vec<[f64; 2]>)> = vec![
        (1, vec![[0.0, 0.0], [45.0, -45.0]]),
        (2, vec![[0.0, 0.0], [90.0, 45.0]]),
        (
            4,
            vec![[0.0, 0.0], [90.0, 0.0], [180.0, 45.0], [270.0, -45.0]],
        ),
        (
            8,
            (0..8)
                .map(|i| [90.0 * f64::from(i % 4), if i < 4 { 0.0 } else { 45.0 }])
                .collect(),
        ),
    ];
    let ball = 0.5;
    let stylus = 0.0625;
    let touches = cap_points(30, ball + stylus, 80.0);
    let mut rng = Rng::new(seed);
    let mut cells = Vec::new();
    for (label, set) in &sets {
        let methods: &[(&'static str, u8)] = if *label == 1 {
            &[("paper Method III (home + one pose)", 3)]
        } else {
            &[
                ("Method I (sphere of centres)", 1),
                ("Method III, least squares", 3),
                ("axis-line fit", 4),
            ]
        };
        for &(name, which) in methods {
            let mut errs = Vec::new();
            let mut covered = 0usize;
            let mut with_u = 0usize;
            for _ in 0..trials {
                let poses: Vec<Pose> = set
                    .iter()
                    .enumerate()
                    .map(|(i, r)| {
                        let centre = simulate_centres(&m, &truth, b0, r);
                        let pts: Vec<P3> = touches
                            .iter()
                            .map(|t| {
                                centre
                                    + t
                                    + P3::new(rng.normal(), rng.normal(), rng.normal()) * sigma
                            })
                            .collect();
                        let (fitted, u) = crate::fit::sphere(&pts, None)
                            .map(|s| (P3::from(s.center), s.u_center))
                            .unwrap_or((centre, None));
                        Pose {
                            rotary: *r,
                            center: fitted,
                            row: i + 1,
                            sigma: u,
                        }
                    })
                    .collect();
                let res = match which {
                    1 => method_i(&m, &poses),
                    3 => method_iii(&m, &poses),
                    _ => method_fit(&m, &poses),
                };
                let Ok(res) = res else { continue };
                let r = match (res.r, &res.line) {
                    (Some(r), _) => P3::from(r),
                    // The paper solved its rank-deficient system anyway: take the
                    // minimum-norm point of the line to show what that gives.
                    (None, Some(l)) if *label == 1 => P3::from(l.r_point),
                    _ => continue,
                };
                let e = r - r_true;
                errs.push(e.norm());
                if let Some(u) = res.u_r {
                    with_u += 3;
                    covered += (0..3).filter(|&k| e[k].abs() <= 2.0 * u[k]).count();
                }
            }
            let n = errs.len().max(1) as f64;
            cells.push(CalibCell {
                method: name,
                poses: if *label == 1 { 2 } else { *label },
                solved: errs.len(),
                trials,
                rms_error: (errs.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
                max_error: errs.iter().copied().fold(0.0, f64::max),
                coverage_2u: (with_u > 0).then(|| covered as f64 / with_u as f64),
            });
        }
    }
    cells
}
