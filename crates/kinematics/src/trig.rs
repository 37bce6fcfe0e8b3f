//! Sine, cosine and arctangent in degrees, in plain `f64` arithmetic.
//!
//! Why not `f64::sin_cos` / `f64::atan2`: they call the C library, which cannot be
//! inlined and was ~40 % of an IK + FK pair (`cargo xtask bench kin`). These are
//! polynomials that inline into the kinematics, and they work in degrees, which makes
//! them *more* exact where it matters to a machine: the argument reduction of `sin_cos_deg`
//! is exact (`x − 90·k` has no rounding), so `sin(90°)`, `cos(90°)`, `sin(180°)` … are
//! exactly 1, 0, 0 …, where `x.to_radians().sin_cos()` gives 6.1e-17 for `cos(90°)`.
//!
//! Accuracy (tests below, against the C library on sweeps and random inputs): within a
//! few units in the last place; `atan2_deg` within 3e-14 degrees of
//! `y.atan2(x).to_degrees()` for every angle and within 4 ulp of it relatively, and
//! `sin_cos_deg` within 2.3e-16 of `x.to_radians().sin_cos()` for |x| ≤ 1e4. Non-finite
//! input and arguments beyond 1e15 degrees go to the C library, so special values behave
//! exactly as `f64`'s.
//!
//! No fused multiply-add is used on purpose: without the `fma` target feature,
//! `f64::mul_add` is a slow library call.
//!
//! The series coefficients are the exact Taylor ones, `±1/n!` and `±1/n`, evaluated by
//! the compiler; the arctangent table holds atan(k/8) in degrees, correctly rounded
//! (computed with 40-digit arithmetic; a test checks each against the C library).

use crate::lanes::F4;

/// π/180 rounded to `f64`.
const RAD: f64 = std::f64::consts::PI / 180.0;
/// 180/π rounded to `f64`.
const DEG: f64 = 180.0 / std::f64::consts::PI;

/// Taylor coefficients 1/n! as `f64` (computed by the compiler from exact integers).
const fn inv_fact(n: u32) -> f64 {
    let mut f = 1.0;
    let mut i = 2;
    while i <= n {
        f *= i as f64;
        i += 1;
    }
    1.0 / f
}

const S3: f64 = -inv_fact(3);
const S5: f64 = inv_fact(5);
const S7: f64 = -inv_fact(7);
const S9: f64 = inv_fact(9);
const S11: f64 = -inv_fact(11);
const S13: f64 = inv_fact(13);
const S15: f64 = -inv_fact(15);
const S17: f64 = inv_fact(17);
const C2: f64 = -inv_fact(2);
const C4: f64 = inv_fact(4);
const C6: f64 = -inv_fact(6);
const C8: f64 = inv_fact(8);
const C10: f64 = -inv_fact(10);
const C12: f64 = inv_fact(12);
const C14: f64 = -inv_fact(14);
const C16: f64 = inv_fact(16);

/// `(sin x, cos x)` for `x` in degrees.
#[inline]
pub fn sin_cos_deg(x: f64) -> (f64, f64) {
    // Beyond 1e15 degrees, 90·k is no longer exact; the C library handles those (and
    // NaN/inf) as `f64` always has.
    if x.is_nan() || x.abs() > 1e15 {
        return x.to_radians().sin_cos();
    }
    sin_cos_deg_core(x)
}

/// [`sin_cos_deg`] for `|x| ≤ 1e15` (not NaN), with no branch at all: what the batch
/// kinematics run on many angles at once (the caller checks the range).
#[inline(always)]
pub(crate) fn sin_cos_deg_core(x: f64) -> (f64, f64) {
    // Nearest multiple of 90, without a branch: adding and removing 1.5·2⁵² rounds to
    // an integer (|x/90| < 2⁵¹). No branch matters: angles arrive in random order, and a
    // mispredicted branch costs as much as the polynomial.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let kf = (x * (1.0 / 90.0) + ROUND) - ROUND;
    // Exact: 90·k is an integer (below 2⁵⁷, so representable) and x − 90·k is small next
    // to x (Sterbenz), so the difference rounds nothing. |r| ≤ 45 (a hair more when
    // x/90 rounded across a half; the series has room to spare).
    let r = x - 90.0 * kf;
    let k = kf as i64;
    let t = r * RAD; // |t| ≤ π/4
    let z = t * t;
    // Truncation error of the series at π/4: < 1e-19 (sine), < 3e-18 (cosine). Estrin's
    // scheme (pairs, then powers z², z⁴) instead of Horner's: the same products with a
    // third of the dependency chain.
    let z2 = z * z;
    let z4 = z2 * z2;
    let ps = (S3 + S5 * z) + z2 * (S7 + S9 * z) + z4 * ((S11 + S13 * z) + z2 * (S15 + S17 * z));
    let pc = (C2 + C4 * z) + z2 * (C6 + C8 * z) + z4 * ((C10 + C12 * z) + z2 * (C14 + C16 * z));
    let s = t + t * z * ps;
    let c = 1.0 + z * pc;
    // Quadrant k mod 4 → (s, c), (c, −s), (−s, −c), (−c, s), by arithmetic: the 0/1 and
    // ±1 factors are exact.
    let odd = (k & 1) as f64;
    let even = 1.0 - odd;
    let (ps, pc) = (even * s + odd * c, even * c + odd * s);
    let sin_sign = 1.0 - 2.0 * ((k >> 1) & 1) as f64;
    let cos_sign = 1.0 - 2.0 * (((k + 1) >> 1) & 1) as f64;
    (sin_sign * ps, cos_sign * pc)
}

/// atan(k/8) in degrees, k = 0..=8, correctly rounded.
const ATAN_EIGHTHS: [f64; 9] = [
    0.0,
    7.125016348901798,
    14.036243467926479,
    20.556045219583464,
    26.56505117707799,
    32.005383208083494,
    36.86989764584402,
    41.18592516570965,
    45.0,
];

const A3: f64 = -1.0 / 3.0;
const A5: f64 = 1.0 / 5.0;
const A7: f64 = -1.0 / 7.0;
const A9: f64 = 1.0 / 9.0;
const A11: f64 = -1.0 / 11.0;
const A13: f64 = 1.0 / 13.0;

/// `atan2(y, x)` in degrees, in (−180, 180] (signed zeros as `f64::atan2`).
#[inline]
pub fn atan2_deg(y: f64, x: f64) -> f64 {
    let (ax, ay) = (x.abs(), y.abs());
    // Zeros, infinities and NaN: the C library's conventions.
    if !(ax > 0.0 || ay > 0.0) || !(ax < f64::INFINITY && ay < f64::INFINITY) {
        return y.atan2(x).to_degrees();
    }
    atan2_deg_core(y, x)
}

/// [`atan2_deg`] for finite `y`, `x`, not both zero, with no branch at all (see
/// [`sin_cos_deg_core`]; the caller checks).
#[inline(always)]
pub(crate) fn atan2_deg_core(y: f64, x: f64) -> f64 {
    let (ax, ay) = (x.abs(), y.abs());
    // No data-dependent branch below (see `sin_cos_deg`): min/max, 0/1 factors, copysign.
    let swap = f64::from(u8::from(ay > ax));
    let t = ax.min(ay) / ax.max(ay); // in [0, 1]
                                     // Nearest eighth c = k/8; atan t = atan c + atan((t − c)/(1 + t·c)), |u| ≤ 1/16.
                                     // (Choosing k by comparisons to save this division measured slower.)
    let k = ((t * 8.0 + 0.5) as u32).min(8) as usize;
    let c = k as f64 * 0.125;
    // t − c is exact (t and c within a factor of two when c > 0).
    let u = (t - c) / (1.0 + t * c);
    let z = u * u;
    let z2 = z * z;
    // Truncation error at |u| = 1/16: below 1e-18 relative. Estrin's scheme.
    let p = (A3 + A5 * z) + z2 * (A7 + A9 * z) + z2 * z2 * (A11 + A13 * z);
    let d = ATAN_EIGHTHS[k] + (u + u * z * p) * DEG;
    // |y| > |x|: 90 − d.
    let d = 90.0 * swap + (1.0 - 2.0 * swap) * d;
    // x < 0 (or −0): 180 − d.
    let sx = 1.0f64.copysign(x);
    let d = 90.0 * (1.0 - sx) + sx * d;
    d.copysign(y)
}

/// `sin_cos_deg_core` on four lanes at once (the same operations on each lane, so the
/// same bits; see [`crate::lanes`]).
#[inline(always)]
pub fn sin_cos_deg4(x: F4) -> (F4, F4) {
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let kf = (x * (1.0 / 90.0) + ROUND) - ROUND;
    let r = x - 90.0 * kf;
    // The quadrant k (an integer, |k| < 2⁵¹) and its bits as exact float arithmetic
    // (vector instructions; a conversion to i64 is not): k & 1 = k − 2⌊k/2⌋,
    // (k >> 1) & 1 = h − 2⌊h/2⌋ with h = ⌊k/2⌋, and the same for k + 1.
    let bit = |m: F4| m - 2.0 * (m * 0.5).map(f64::floor);
    let t = r * RAD;
    let z = t * t;
    let z2 = z * z;
    let z4 = z2 * z2;
    let ps = (S3 + S5 * z) + z2 * (S7 + S9 * z) + z4 * ((S11 + S13 * z) + z2 * (S15 + S17 * z));
    let pc = (C2 + C4 * z) + z2 * (C6 + C8 * z) + z4 * ((C10 + C12 * z) + z2 * (C14 + C16 * z));
    let s = t + t * z * ps;
    let c = 1.0 + z * pc;
    let odd = bit(kf);
    let even = 1.0 - odd;
    let (ps, pc) = (even * s + odd * c, even * c + odd * s);
    let sin_sign = 1.0 - 2.0 * bit((kf * 0.5).map(f64::floor));
    let cos_sign = 1.0 - 2.0 * bit(((kf + 1.0) * 0.5).map(f64::floor));
    (sin_sign * ps, cos_sign * pc)
}

/// `atan2_deg_core` on four lanes at once (see [`sin_cos_deg4`]).
#[inline(always)]
pub fn atan2_deg4(y: F4, x: F4) -> F4 {
    let (ax, ay) = (x.abs(), y.abs());
    let swap = F4::one_if(ay.cmp(ax, |a, b| a > b));
    let t = ax.zip(ay, f64::min) / ax.zip(ay, f64::max);
    // `(v as u32).min(8)` of the scalar code: v is in [0.5, 8.5] (or NaN, 0 either way),
    // where a conversion to i32 (a vector instruction; to u32 is not) is the same.
    let k: [usize; 4] = (t * 8.0 + 0.5).0.map(|v| (v as i32).clamp(0, 8) as usize);
    let c = F4::from_fn(|i| k[i] as f64 * 0.125);
    let u = (t - c) / (1.0 + t * c);
    let z = u * u;
    let z2 = z * z;
    let p = (A3 + A5 * z) + z2 * (A7 + A9 * z) + z2 * z2 * (A11 + A13 * z);
    let d = F4::from_fn(|i| ATAN_EIGHTHS[k[i]]) + (u + u * z * p) * DEG;
    let d = 90.0 * swap + (1.0 - 2.0 * swap) * d;
    let sx = x.map(|v| 1.0f64.copysign(v));
    let d = 90.0 * (1.0 - sx) + sx * d;
    d.zip(y, f64::copysign)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ulp(x: f64) -> f64 {
        let a = x.abs().max(f64::MIN_POSITIVE);
        f64::from_bits(a.to_bits() + 1) - a
    }

    #[test]
    fn table_is_atan_of_eighths() {
        for (k, &v) in ATAN_EIGHTHS.iter().enumerate() {
            let lib = (k as f64 / 8.0).atan().to_degrees();
            assert!((v - lib).abs() <= 2.0 * ulp(lib), "k = {k}: {v} vs {lib}");
        }
    }

    #[test]
    fn quarter_turns_are_exact() {
        for k in -8i32..=8 {
            let (s, c) = sin_cos_deg(90.0 * f64::from(k));
            let (es, ec) = match k.rem_euclid(4) {
                0 => (0.0, 1.0),
                1 => (1.0, 0.0),
                2 => (0.0, -1.0),
                _ => (-1.0, 0.0),
            };
            assert_eq!(s, es, "sin {k}·90°");
            assert_eq!(c, ec, "cos {k}·90°");
        }
        assert!((sin_cos_deg(30.0).0 - 0.5).abs() <= ulp(0.5));
        assert!((sin_cos_deg(60.0).1 - 0.5).abs() <= ulp(0.5));
    }

    /// The C library on the exactly reduced argument (|r| ≤ 45°): what the polynomials
    /// must match; `x.to_radians()` itself rounds, by up to |x|·1.1e-16·π/180.
    fn reference(x: f64) -> (f64, f64) {
        let k = (x / 90.0).round();
        let r = x - 90.0 * k;
        let (s, c) = r.to_radians().sin_cos();
        match (k as i64).rem_euclid(4) {
            0 => (s, c),
            1 => (c, -s),
            2 => (-s, -c),
            _ => (-c, s),
        }
    }

    #[test]
    fn sweep_matches_the_c_library() {
        // Every 0.001° over ±720°, plus large arguments.
        let mut worst = 0.0f64;
        let mut worst_direct = 0.0f64;
        let mut i = -720_000i64;
        while i <= 720_000 {
            let x = i as f64 * 0.001;
            let (s, c) = sin_cos_deg(x);
            let (ls, lc) = reference(x);
            worst = worst.max((s - ls).abs()).max((c - lc).abs());
            let (ds, dc) = x.to_radians().sin_cos();
            let tol = 2.3e-16 + x.to_radians().abs() * 1.2e-16;
            worst_direct = worst_direct.max(((s - ds).abs().max((c - dc).abs())) / tol);
            i += 1;
        }
        assert!(worst <= 2.3e-16, "worst sin/cos difference {worst:e}");
        assert!(worst_direct <= 1.0, "{worst_direct}");
        for x in [1e4, -9999.999, 12345.678, 1e15, -1e15, 1e16, 3e300] {
            let (s, c) = sin_cos_deg(x);
            let (ls, lc) = if x.abs() <= 1e15 {
                reference(x)
            } else {
                x.to_radians().sin_cos()
            };
            assert!(
                (s - ls).abs() <= 2.3e-16 && (c - lc).abs() <= 2.3e-16,
                "{x}"
            );
        }
        // Over whole turns of the circle.
        let mut worst_atan = 0.0f64;
        for i in 0..=1_440_000 {
            let a = -180.0 + i as f64 * 0.00025;
            let (s, c) = a.to_radians().sin_cos();
            for scale in [1.0, 3.7e-3, 2.5e5] {
                let (y, x) = (s * scale, c * scale);
                let d = atan2_deg(y, x);
                let lib = y.atan2(x).to_degrees();
                let e = (d - lib).abs();
                assert!(e <= 4.0 * ulp(lib) + 1e-300, "atan2({y}, {x}) {d} vs {lib}");
                worst_atan = worst_atan.max(e);
            }
        }
        println!(
            "sin/cos vs reduced C library {worst:e}; vs x.to_radians().sin_cos() {worst_direct:.2} of tolerance; atan2 {worst_atan:e}°"
        );
        assert!(worst_atan <= 3e-14, "{worst_atan:e}");
    }

    #[test]
    fn special_values_follow_f64() {
        for (y, x) in [
            (0.0, 0.0),
            (-0.0, 0.0),
            (0.0, -0.0),
            (-0.0, -0.0),
            (0.0, -1.0),
            (-0.0, -1.0),
            (1.0, 0.0),
            (-1.0, -0.0),
            (f64::INFINITY, 1.0),
            (1.0, f64::NEG_INFINITY),
        ] {
            let d = atan2_deg(y, x);
            let lib = y.atan2(x).to_degrees();
            assert_eq!(d.to_bits(), lib.to_bits(), "atan2({y}, {x})");
        }
        assert!(atan2_deg(f64::NAN, 1.0).is_nan());
        assert!(sin_cos_deg(f64::NAN).0.is_nan());
        assert!(sin_cos_deg(f64::INFINITY).1.is_nan());
        // Tiny and huge ratios.
        for (y, x) in [(1e-300, 1.0), (1.0, 1e-300), (-1e-200, -1.0), (5e-324, 1.0)] {
            let d = atan2_deg(y, x);
            let lib = y.atan2(x).to_degrees();
            assert!(
                (d - lib).abs() <= 4.0 * ulp(lib),
                "atan2({y}, {x}) {d} vs {lib}"
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        #[test]
        fn random_atan2(y in -1e6f64..1e6, x in -1e6f64..1e6) {
            prop_assume!(x != 0.0 || y != 0.0);
            let d = atan2_deg(y, x);
            let lib = y.atan2(x).to_degrees();
            prop_assert!((d - lib).abs() <= 4.0 * ulp(lib) + 1e-300, "{} vs {}", d, lib);
        }

        #[test]
        fn random_sin_cos(x in -1e4f64..1e4) {
            let (s, c) = sin_cos_deg(x);
            let (ls, lc) = reference(x);
            prop_assert!((s - ls).abs() <= 2.3e-16 && (c - lc).abs() <= 2.3e-16);
            prop_assert!((s * s + c * c - 1.0).abs() <= 4.5e-16);
        }
    }
}
