//! Plain decimals read fast: `[-]digits[.digits]` of at most 15 digits, as the standard
//! parser reads them, by one exact division (the location files' and the per-point paths'
//! numbers).

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
