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
