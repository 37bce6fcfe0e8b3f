//! Deviation statistics, as CMM software reports them.

use serde::Serialize;

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
}
