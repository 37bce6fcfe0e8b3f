//! Test support shared by lampost's oracle tests and benchmarks, written once: the
//! workspace root, a seeded generator (the same cases on every run), and the rule for
//! the external oracles that the project's scripts install into `.tools/` (skipped with
//! a message when missing, a failure when `LAMPOST_REQUIRE_PY=1`, as in CI).
//!
//! Only tests and `xtask` depend on it; no product crate does.
//!
//! ```
//! let mut r = lampost_testkit::SplitMix::new(7);
//! let x = r.range(-1.0, 1.0);
//! assert!((-1.0..1.0).contains(&x));
//! assert_eq!(lampost_testkit::SplitMix::new(7).range(-1.0, 1.0), x);
//! ```

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

/// The workspace's root folder (where `.tools/`, `fixtures/` and `scripts/` are).
pub fn root() -> PathBuf {
    let r = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    r.canonicalize().unwrap_or(r)
}

/// splitmix64: a small seeded generator, the same sequence on every run and platform.
#[derive(Debug, Clone)]
pub struct SplitMix(u64);

impl SplitMix {
    /// The generator seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        SplitMix(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`, 53 bits.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }

    /// A unit vector, uniform on the sphere (rejection from the cube).
    pub fn dir(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let n = v.norm();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
    }
}

/// xorshift64*: the generator of the oracle tests' random programs (`g76_cli`, `g7x_cli`,
/// `cutter_comp_cli`, the post's `tamper`): the same programs on every run, so the
/// figures their docs quote are those of every run.
#[derive(Debug, Clone)]
pub struct XorShift(pub u64);

impl XorShift {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in `[0, 1)`, 53 bits.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn pick(&mut self, n: u64) -> u64 {
        self.next_u64() % n.max(1)
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        self.pick(n as u64) as usize
    }

    /// −1 or +1, even odds.
    pub fn sign(&mut self) -> f64 {
        if self.chance(0.5) {
            -1.0
        } else {
            1.0
        }
    }
}

/// Whether every file an external oracle needs is there (e.g. `.tools/py/bin/python`).
/// When one is missing: a failure naming it and the script that installs it
/// (`install`) if `LAMPOST_REQUIRE_PY=1`, else `false` and a SKIPPED line on standard
/// error, so a plain `cargo test` on a fresh clone passes and CI cannot skip.
pub fn oracle_present(paths: &[PathBuf], install: &str) -> bool {
    let missing: Vec<String> = paths
        .iter()
        .filter(|p| !p.exists())
        .map(|p| p.display().to_string())
        .collect();
    if missing.is_empty() {
        return true;
    }
    let required = std::env::var("LAMPOST_REQUIRE_PY").is_ok_and(|v| v == "1");
    assert!(
        !required,
        "LAMPOST_REQUIRE_PY=1 but {} missing: run {install}",
        missing.join(" and ")
    );
    eprintln!(
        "SKIPPED: {} missing (run {install}, or set LAMPOST_REQUIRE_PY=1 to require it)",
        missing.join(" and ")
    );
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sequence_is_splitmix64() {
        // The first outputs of splitmix64 seeded with 0 (Vigna's reference).
        let mut r = SplitMix::new(0);
        assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    }

    #[test]
    fn draws_stay_in_their_ranges() {
        let mut r = SplitMix::new(42);
        for _ in 0..10_000 {
            let u = r.unit();
            assert!((0.0..1.0).contains(&u));
            assert!(r.below(7) < 7);
            assert_eq!(r.below(0), 0);
            assert!((r.dir().norm() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn the_root_holds_the_workspace() {
        assert!(root().join("Cargo.toml").is_file());
        assert!(root().join("crates/testkit").is_dir());
    }
}
