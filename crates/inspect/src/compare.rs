//! Deviation statistics, as CMM software reports them, and the best-fit alignment of
//! measured points to the CAD mesh (the registration of `lampost-align`, trimmed of the
//! points that do not fit).

use lampost_align::register::{register, Locks, Registration};
use lampost_mesh::dist::DistIndex;
use lampost_mesh::Mesh;
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

use crate::error::InspectError;

/// Statistics of signed deviations.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stats {
    /// Points counted.
    pub n: usize,
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (n − 1).
    pub sd: f64,
    /// Root mean square.
    pub rms: f64,
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
    /// 5th, 50th and 95th percentiles (linear between order statistics).
    pub p05: f64,
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Share within ±tolerance (when one is given).
    pub within_tol: Option<f64>,
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    let x = q * (sorted.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x - x.floor());
    match sorted.get(i + 1) {
        Some(b) => sorted[i] + f * (b - sorted[i]),
        None => sorted[i],
    }
}

/// The statistics of `d` (finite values), `None` when empty.
pub fn stats(d: &[f64], tol: Option<f64>) -> Option<Stats> {
    if d.is_empty() {
        return None;
    }
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let sd = if d.len() > 1 {
        (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    let mut s = d.to_vec();
    s.sort_by(f64::total_cmp);
    Some(Stats {
        n: d.len(),
        mean,
        sd,
        rms,
        min: s[0],
        max: s[s.len() - 1],
        p05: percentile(&s, 0.05),
        p50: percentile(&s, 0.5),
        p95: percentile(&s, 0.95),
        within_tol: tol.map(|t| d.iter().filter(|x| x.abs() <= t).count() as f64 / n),
    })
}

/// A best-fit alignment of measured points (part frame) to the CAD mesh.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BestFit {
    /// The registration of the points kept (`part = R·cad + t`), with its uncertainty.
    pub registration: Registration,
    /// Per input point: kept in the last fit (false: trimmed as not fitting).
    pub inlier: Vec<bool>,
    /// Each input point's distance to the mesh after the fit (CAD frame; signed when the
    /// mesh is a closed, consistently oriented solid).
    pub residuals: Vec<f64>,
    /// The trimming threshold of the last round: points farther from the surface are
    /// left out of the fit.
    pub threshold: f64,
    /// Fits made (the first on every point, then one per change of the kept set).
    pub rounds: usize,
    /// The kept points' centroid in the CAD frame: the rotation uncertainties are about
    /// axes through it and the translation uncertainty is its own.
    pub centroid: [f64; 3],
}

impl BestFit {
    /// A part-frame point taken back to the CAD frame: `Rᵀ·(p − t)`.
    pub fn to_cad(&self, p: [f64; 3]) -> [f64; 3] {
        let r = Matrix3::from_fn(|i, j| self.registration.rotation[i][j]);
        let q = r.transpose() * (Vector3::from(p) - Vector3::from(self.registration.translation));
        [q.x, q.y, q.z]
    }

    /// A part-frame direction taken back to the CAD frame: `Rᵀ·v`.
    pub fn dir_to_cad(&self, v: [f64; 3]) -> [f64; 3] {
        let r = Matrix3::from_fn(|i, j| self.registration.rotation[i][j]);
        let q = r.transpose() * Vector3::from(v);
        [q.x, q.y, q.z]
    }
}

/// Times the robust standard deviation (1.4826 × the median absolute deviation from
/// the median) beyond which a point is left out of the fit.
pub const TRIM_K: f64 = 3.0;

/// The most fits [`best_fit`] makes before it gives up on a settled kept set.
pub const MAX_ROUNDS: usize = 20;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    percentile(v, 0.5)
}

/// The best-fit alignment of `points` (part frame) to `mesh` (CAD frame), with `locks`:
/// `lampost_align::register` on every point, then again on the points within
/// [`TRIM_K`] robust standard deviations of the surface (the median absolute deviation
/// of all residuals, so a local bump or dent — a minority of the points — does not set
/// the scale), until the kept set no longer changes. The uncertainty is the last fit's,
/// from the kept points. Refused: fewer kept points than the free parameters and one, a
/// mesh or points the registration refuses.
pub fn best_fit(mesh: &Mesh, points: &[[f64; 3]], locks: Locks) -> Result<BestFit, InspectError> {
    // The residuals by the same index as the deviations (`surface::distances`).
    let index = DistIndex::new(mesh)
        .ok_or_else(|| InspectError::Input("the mesh cannot be indexed: no triangles".into()))?;
    let solid = lampost_mesh::manifold_report(mesh).closed_oriented();
    let all: Vec<Vector3<f64>> = points.iter().map(|p| Vector3::from(*p)).collect();
    let free = locks
        .translate
        .iter()
        .chain(&locks.rotate)
        .filter(|l| !**l)
        .count();
    let size = {
        let n = all.len().max(1) as f64;
        let c = all.iter().fold(Vector3::zeros(), |a, p| a + p) / n;
        all.iter().map(|p| (p - c).norm()).fold(0.0, f64::max)
    };
    let mut inlier = vec![true; points.len()];
    let mut rounds = 0;
    loop {
        rounds += 1;
        let kept: Vec<Vector3<f64>> = all
            .iter()
            .zip(&inlier)
            .filter(|(_, k)| **k)
            .map(|(p, _)| *p)
            .collect();
        let registration =
            register(mesh, &kept, locks).map_err(|e| InspectError::Input(e.to_string()))?;
        let fit = BestFit {
            registration,
            inlier: inlier.clone(),
            residuals: Vec::new(),
            threshold: f64::INFINITY,
            rounds,
            centroid: [0.0; 3],
        };
        let mut residuals = Vec::with_capacity(points.len());
        for (i, p) in points.iter().enumerate() {
            let q = fit.to_cad(*p);
            if !q.iter().all(|x| x.is_finite()) {
                return Err(InspectError::Input(format!(
                    "point {} of {}: not finite in the CAD frame",
                    i + 1,
                    points.len()
                )));
            }
            residuals.push(if solid {
                index.signed_distance(q)
            } else {
                index.distance(q)
            });
        }
        let mut r = residuals.clone();
        let med = median(&mut r);
        let mut dev: Vec<f64> = residuals.iter().map(|x| (x - med).abs()).collect();
        let sigma = 1.4826 * median(&mut dev);
        // A floor keeps exact data (noise-free tests) from trimming rounding.
        let threshold = (TRIM_K * sigma).max(1e-9 * size.max(1.0));
        let next: Vec<bool> = residuals
            .iter()
            .map(|x| (x - med).abs() <= threshold)
            .collect();
        let kept_n = next.iter().filter(|k| **k).count();
        if kept_n <= free {
            return Err(InspectError::Input(format!(
                "only {kept_n} of {} points lie within {threshold:.3e} of the surface after the fit: too few to fit {free} degrees of freedom (is this the part's mesh, in the same units and near its place?)",
                points.len()
            )));
        }
        if next == inlier || rounds >= MAX_ROUNDS {
            let n = kept.len() as f64;
            let c = kept.iter().fold(Vector3::zeros(), |a, p| {
                a + Vector3::from(fit.to_cad([p.x, p.y, p.z]))
            }) / n;
            return Ok(BestFit {
                residuals,
                threshold,
                centroid: [c.x, c.y, c.z],
                ..fit
            });
        }
        inlier = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_of_a_known_set() {
        let s = stats(&[-2.0, -1.0, 0.0, 1.0, 2.0], Some(1.0)).expect("stats");
        assert_eq!((s.n, s.mean, s.min, s.max, s.p50), (5, 0.0, -2.0, 2.0, 0.0));
        assert!((s.sd - 2.5f64.sqrt()).abs() < 1e-15);
        assert!((s.rms - 2f64.sqrt()).abs() < 1e-15);
        assert!((s.p05 + 1.8).abs() < 1e-12 && (s.p95 - 1.8).abs() < 1e-12);
        assert_eq!(s.within_tol, Some(0.6));
        assert_eq!(stats(&[], None), None);
    }

    /// Points on a box's faces after a known move, a tenth of them on a bump 0.5 high:
    /// the trimmed fit recovers the move as if the bump were not there and leaves the
    /// bump's points out.
    #[test]
    fn a_bump_does_not_spoil_the_fit() {
        let mesh = lampost_mesh::box_mesh(Vector3::zeros(), Vector3::new(100.0, 60.0, 50.0));
        let mut pts = Vec::new();
        for i in 0..6 {
            for j in 0..6 {
                let (a, b) = (5.0 + 18.0 * f64::from(i), 5.0 + 10.0 * f64::from(j));
                pts.push(Vector3::new(a, b, 50.0));
                pts.push(Vector3::new(a, 0.0, 3.0 + 8.0 * f64::from(j)));
                pts.push(Vector3::new(0.0, b, 3.0 + 8.0 * f64::from(i)));
            }
        }
        // The bump: the top face's points with x < 25 and y < 25 raised by 0.5.
        let bump: Vec<bool> = pts
            .iter()
            .map(|p| p.z == 50.0 && p.x < 25.0 && p.y < 25.0)
            .collect();
        let rot = nalgebra::Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(0.3, -0.5, 1.0)),
            0.2f64.to_radians(),
        );
        let t = Vector3::new(0.05, -0.04, 0.03);
        let moved: Vec<[f64; 3]> = pts
            .iter()
            .zip(&bump)
            .map(|(p, b)| {
                let q = rot * (p + Vector3::new(0.0, 0.0, if *b { 0.5 } else { 0.0 })) + t;
                [q.x, q.y, q.z]
            })
            .collect();
        let fit = best_fit(&mesh, &moved, Locks::default()).expect("fits");
        let r = Matrix3::from_fn(|i, j| fit.registration.rotation[i][j]);
        assert!((r - rot.into_inner()).norm() < 1e-9, "{fit:?}");
        assert!((Vector3::from(fit.registration.translation) - t).norm() < 1e-9);
        assert_eq!(fit.inlier, bump.iter().map(|b| !b).collect::<Vec<_>>());
        for (d, b) in fit.residuals.iter().zip(&bump) {
            let want = if *b { 0.5 } else { 0.0 };
            assert!((d - want).abs() < 1e-9, "{d} {b}");
        }
        assert!(fit.rounds >= 2);
        // Without trimming (the registration alone) the bump drags the fit.
        let plain = register(
            &mesh,
            &moved.iter().map(|p| Vector3::from(*p)).collect::<Vec<_>>(),
            Locks::default(),
        )
        .expect("registers");
        assert!((Vector3::from(plain.translation) - t).norm() > 1e-3);
    }
}
