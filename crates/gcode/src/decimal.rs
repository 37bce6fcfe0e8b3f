//! Plain decimals read and written fast: `[-]digits[.digits]` of at most 15 digits read
//! as the standard parser reads them, by one exact division (the location files' and the
//! per-point paths' numbers), and a number written to a fixed number of places as
//! `format!("{:.D$}")` writes it ([`push_exact_fixed`], the per-point paths' text).

/// The powers of ten 10⁰ … 10¹⁵, each exact in `f64`.
pub const POW10: [f64; 16] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
];

/// `field` read as `str::parse::<f64>` reads it (`None` where it fails): a plain decimal
/// `[-]digits[.digits]` of at most 15 digits by [`parse_plain`], anything else by the
/// standard parser.
pub fn parse_number(field: &str) -> Option<f64> {
    parse_plain(field).or_else(|| field.parse::<f64>().ok())
}

/// The fast path of [`parse_number`], the form the location files' numbers take: a plain
/// decimal `[-]digits[.digits]` with at most 15 digits, else `None`. The digits make an
/// integer `m < 10^15 < 2^53` and the decimals a power of ten `10^d` (d ≤ 15), both exact
/// in `f64`, so `m / 10^d` is one correctly rounded division: the `f64` nearest the
/// decimal, as the standard parser gives (proptests in lampost-robot's `tests/plan.rs` and `chunk.rs`).
pub fn parse_plain(field: &str) -> Option<f64> {
    let b = field.as_bytes();
    let (neg, b) = match b.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, b),
    };
    let (mut m, mut digits, mut decimals, mut point) = (0u64, 0usize, 0usize, false);
    for &c in b {
        match c {
            b'0'..=b'9' => {
                m = m * 10 + u64::from(c - b'0');
                digits += 1;
                decimals += usize::from(point);
            }
            b'.' if !point => point = true,
            _ => return None,
        }
        if digits > 15 {
            return None;
        }
    }
    // Digits on the point's left (`.5` and `5.` are the standard parser's too, but rare:
    // left to it).
    if digits == 0 || digits == decimals || (point && decimals == 0) {
        return None;
    }
    let v = m as f64 / POW10[decimals];
    Some(if neg { -v } else { v })
}

/// A number as a message shows it: as Rust writes it where that is short (0, and
/// magnitudes from 1e-6 to below 1e15), in exponent form beyond (`1e-300`, not a point
/// and 300 digits).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Readable(pub f64);

impl std::fmt::Display for Readable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0;
        if v == 0.0 || !v.is_finite() || (1e-6..1e15).contains(&v.abs()) {
            write!(f, "{v}")
        } else {
            write!(f, "{v:e}")
        }
    }
}

/// A number to a fixed number of places as a message shows it: `{:.places$}` below
/// 1e15 in magnitude, in exponent form beyond (`1.0000e300`, not 300 digits).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fixed(pub f64, pub usize);

impl std::fmt::Display for Fixed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Fixed(v, places) = *self;
        if v.is_finite() && v.abs() >= 1e15 {
            write!(f, "{v:.places$e}")
        } else {
            write!(f, "{v:.places$}")
        }
    }
}

/// The largest number of places [`push_exact_fixed`] writes by its fast path.
const EXACT_MAX_PLACES: usize = 9;

/// `value` to `places` decimals appended to `out`, the same text as
/// `format!("{value:.places$}")`: the exact binary value rounded to the nearest
/// `places`-decimal number, a tie to the even last digit, the sign kept for any negative
/// value (`-0.000000` for -1e-9 at 6 places, and for -0.0).
///
/// For `places` ≤ 9 and `|value| · 10^places` < 2⁵² (the coordinates and directions of
/// a path) it works in `f64` alone: the product `p = |value| · 10^places` and its
/// rounding error `e` (Dekker's two-product, exact) make the exact product `p + e`; the
/// whole part of `p` and the comparison of its fraction less a half with `−e` (both
/// exact) decide the rounding without an error. Anything else (not finite, larger, more
/// places) is left to `format!`. Property-tested against `format!` on random values and
/// on values next to every kind of tie.
pub fn push_exact_fixed(out: &mut String, value: f64, places: usize) {
    match exact_scaled(value, places) {
        Some(n) => push_scaled_whole(out, value.is_sign_negative(), n, places),
        None => {
            use std::fmt::Write;
            // Writing to a String cannot fail.
            let _ = write!(out, "{value:.places$}");
        }
    }
}

/// `round_ties_even(|value| · 10^places)` of the exact product, where [`push_exact_fixed`]'s
/// fast path holds; `None` elsewhere.
fn exact_scaled(value: f64, places: usize) -> Option<u64> {
    const TWO52: f64 = 4_503_599_627_370_496.0;
    const SPLIT: f64 = 134_217_729.0; // 2^27 + 1
    if places > EXACT_MAX_PLACES || !value.is_finite() {
        return None;
    }
    let a = value.abs();
    // Below 2^-900 the splitting below could underflow; such a value is written as zero
    // by any number of places up to 9 (its product is far below a half).
    if a < 1e-270 {
        return Some(0);
    }
    let s = POW10[places];
    let p = a * s;
    if p >= TWO52 {
        return None;
    }
    // Dekker: a = ah + al and s = sh + sl, each half of 26 bits, so every partial
    // product is exact and e = (a · s) − p exactly.
    let split = |x: f64| {
        let c = SPLIT * x;
        let h = c - (c - x);
        (h, x - h)
    };
    let (ah, al) = split(a);
    let (sh, sl) = split(s);
    let e = ((ah * sh - p) + ah * sl + al * sh) + al * sl;
    // p < 2^52: its whole part and fraction are exact.
    let whole = p.floor();
    let frac = p - whole;
    let n = whole as u64;
    // The exact product is whole + frac + e, |e| ≤ ulp(p)/2 < 1/2. Its fraction against a
    // half: frac − 0.5 is exact where it matters (frac ≥ 0.25), and the comparison with
    // −e is exact.
    if frac < 0.25 {
        // Never a tie: frac + e < 0.5 (and a negative frac + e rounds to `whole` too).
        return Some(n);
    }
    let d = frac - 0.5;
    Some(if d > -e {
        n + 1
    } else if d < -e {
        n
    } else {
        // Exactly a half: to the even last digit.
        n + (n & 1)
    })
}

/// `n / 10^places` written as `[-]whole.fraction` with exactly `places` decimals.
fn push_scaled_whole(out: &mut String, negative: bool, n: u64, places: usize) {
    let mut buf = [b'0'; 32];
    let mut i = buf.len();
    let mut m = n;
    // The fraction's digits, then the point, then the whole part (at least one digit).
    for _ in 0..places {
        i -= 1;
        buf[i] = b'0' + (m % 10) as u8;
        m /= 10;
    }
    if places > 0 {
        i -= 1;
        buf[i] = b'.';
    }
    loop {
        i -= 1;
        buf[i] = b'0' + (m % 10) as u8;
        m /= 10;
        if m == 0 {
            break;
        }
    }
    if negative {
        out.push('-');
    }
    // Only ASCII digits and the point were written: always UTF-8.
    if let Ok(text) = std::str::from_utf8(&buf[i..]) {
        out.push_str(text);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn exact(v: f64, places: usize) -> String {
        let mut s = String::new();
        push_exact_fixed(&mut s, v, places);
        s
    }

    #[test]
    fn readable_numbers_are_short() {
        for (v, shown) in [
            (0.0, "0"),
            (1.0, "1"),
            (0.5, "0.5"),
            (-2.25, "-2.25"),
            (1e-6, "0.000001"),
            (1e-300, "1e-300"),
            (-1e-9, "-1e-9"),
            (1e300, "1e300"),
            (f64::NAN, "NaN"),
            (f64::INFINITY, "inf"),
        ] {
            assert_eq!(Readable(v).to_string(), shown);
        }
    }

    #[test]
    fn the_standard_texts_of_known_values_and_ties() {
        for (v, places) in [
            (0.0, 6),
            (-0.0, 6),
            (-1e-9, 6),
            (1e-300, 9),
            (0.5, 0),
            (1.5, 0),
            (2.5, 0),
            (0.125, 2),
            (0.375, 2),
            (2.675, 2), // 2.67499999… in binary
            (1.0000005, 6),
            (123.4565, 3),
            (-300.0, 6),
            (4.5e15, 6),
            (f64::NAN, 6),
            (f64::INFINITY, 6),
            (f64::MAX, 9),
            (f64::MIN_POSITIVE, 9),
            (0.1, 12),
        ] {
            assert_eq!(exact(v, places), format!("{v:.places$}"), "{v:e} {places}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]

        #[test]
        fn random_values_are_the_standard_text(
            bits in any::<u64>(),
            places in 0usize..=10,
        ) {
            let v = f64::from_bits(bits);
            prop_assert_eq!(exact(v, places), format!("{v:.places$}"));
        }

        #[test]
        fn path_sized_values_are_the_standard_text(
            v in -1.0e6f64..1.0e6,
            places in 0usize..=9,
        ) {
            prop_assert_eq!(exact(v, places), format!("{v:.places$}"));
        }

        #[test]
        fn values_at_and_next_to_ties_are_the_standard_text(
            k in -10_000_000_000i64..10_000_000_000,
            places in 0usize..=9,
            ulps in -3i64..=3,
        ) {
            // (k + 1/2) / 10^places, and the f64s a few ulps either side.
            let t = (k as f64 + 0.5) / POW10[places];
            let v = if t == 0.0 { t } else {
                f64::from_bits((t.to_bits() as i64 + ulps) as u64)
            };
            prop_assert_eq!(exact(v, places), format!("{v:.places$}"));
        }
    }
}
