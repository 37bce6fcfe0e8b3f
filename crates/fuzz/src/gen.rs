//! Randomness, seeds and mutation: everything an input is made of is a function of the
//! run's seed, the target and the input's index, so any input can be made again alone.

use std::path::Path;

/// xorshift64*: small, fast and deterministic.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// The generator of input `index` of `target` in the run seeded with `seed`.
    pub fn for_input(seed: u64, target: &str, index: u64) -> Self {
        let mut h = seed ^ 0x9E37_79B9_7F4A_7C15;
        for b in target.bytes() {
            h = splitmix(h ^ u64::from(b));
        }
        Rng(splitmix(h ^ splitmix(index)) | 1)
    }
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    pub fn coin(&mut self) -> bool {
        self.next() & 1 == 1
    }
    /// True once in `n`.
    pub fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }
    pub fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    pub fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }
    /// One of `xs` (a seed).
    pub fn pick_bytes<'a>(&mut self, xs: &'a [Vec<u8>]) -> &'a [u8] {
        xs[self.below(xs.len())].as_slice()
    }
    /// A finite number of any magnitude: ordinary ones, the edges of `f64`, and
    /// magnitudes where squares and products overflow or underflow.
    pub fn extreme(&mut self) -> f64 {
        const MAGS: &[f64] = &[
            0.0,
            5e-324,
            f64::MIN_POSITIVE,
            1e-300,
            1e-154,
            1e-12,
            1e-6,
            1e-3,
            1.0,
            25.4,
            1e3,
            1e6,
            1e9,
            1.0000001e9,
            1e12,
            1e154,
            1e155,
            1e200,
            1e300,
            1.7e308,
            f64::MAX,
        ];
        let m = *self.pick(MAGS);
        let v = if self.coin() {
            m
        } else {
            m * self.range(0.5, 1.0)
        };
        if self.coin() {
            -v
        } else {
            v
        }
    }
    /// Mostly ordinary numbers, sometimes extreme ones.
    pub fn mostly(&mut self, lo: f64, hi: f64) -> f64 {
        if self.one_in(8) {
            self.extreme()
        } else {
            self.range(lo, hi)
        }
    }
}

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Numbers as text, for splicing into any textual input.
pub const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    ".5",
    "-.",
    ".",
    "1e999",
    "-1e999",
    "1e308",
    "1.7976931348623157e308",
    "4.9e-324",
    "1e-300",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "+inf",
    "99999999999999999999",
    "18446744073709551615",
    "18446744073709551616",
    "9223372036854775807",
    "4294967296",
    "65536",
    "1e9",
    "1000000001",
    "0x10",
    "1_000",
    "1e",
    "--1",
    "+",
];

/// Mutate `input` in place: a few byte, range and token edits.
pub fn mutate(r: &mut Rng, input: &mut Vec<u8>, tokens: &[&str]) {
    for _ in 0..=r.below(8) {
        let at = r.below(input.len() + 1);
        match r.below(9) {
            0 => input.insert(at, r.next() as u8),
            1 if !input.is_empty() => {
                let end = (at + r.below(16)).min(input.len());
                input.drain(at.min(end)..end);
            }
            2 if !input.is_empty() => {
                let i = r.below(input.len());
                input[i] ^= 1 << r.below(8);
            }
            3 if !input.is_empty() => {
                // Repeat a slice (long lines, many copies).
                let end = (at + 1 + r.below(64)).min(input.len());
                let start = at.min(end.saturating_sub(1));
                let piece = input[start..end].to_vec();
                for _ in 0..1 + r.below(8) {
                    input.splice(end..end, piece.iter().copied());
                }
            }
            4 if !input.is_empty() => {
                // Replace a number-looking run with another number.
                let i = r.below(input.len());
                if let Some(s) = (i..input.len()).find(|&k| input[k].is_ascii_digit()) {
                    let e = (s..input.len())
                        .find(|&k| !(input[k].is_ascii_digit() || input[k] == b'.'))
                        .unwrap_or(input.len());
                    let n = r.pick(NUMBERS).as_bytes();
                    input.splice(s..e, n.iter().copied());
                }
            }
            5 => {
                let n = r.pick(NUMBERS).as_bytes();
                input.splice(at..at, n.iter().copied());
            }
            _ if !tokens.is_empty() => {
                let t = r.pick(tokens).as_bytes();
                input.splice(at..at, t.iter().copied());
            }
            _ => {}
        }
    }
    // Bound the size: an input is a few kilobytes.
    input.truncate(1 << 16);
}

/// Files under `dir` (not recursive) whose names end in one of `exts` (any when empty).
pub fn read_dir(dir: &Path, exts: &[&str]) -> Vec<Vec<u8>> {
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .map(|rd| rd.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    paths.sort();
    paths
        .into_iter()
        .filter(|p| {
            p.is_file()
                && (exts.is_empty()
                    || p.extension()
                        .and_then(|e| e.to_str())
                        .is_some_and(|e| exts.iter().any(|x| x.eq_ignore_ascii_case(e))))
        })
        .filter_map(|p| std::fs::read(p).ok())
        .collect()
}

/// `files` cut into pieces of at most `lines` lines.
pub fn chunks(files: &[Vec<u8>], lines: usize) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for f in files {
        let all: Vec<&[u8]> = f.split(|&c| c == b'\n').collect();
        for c in all.chunks(lines) {
            out.push(c.join(&b'\n'));
        }
    }
    out
}

/// Whether `text` (a `Debug` rendering) shows a non-finite number: `NaN` or `inf` as a
/// token of its own.
pub fn shows_nonfinite(text: &str) -> bool {
    let b = text.as_bytes();
    let word = |i: usize| {
        b.get(i)
            .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_')
    };
    for pat in ["NaN", "inf"] {
        let mut from = 0;
        while let Some(k) = text[from..].find(pat) {
            let s = from + k;
            let e = s + pat.len();
            if (s == 0 || !word(s - 1)) && !word(e) {
                return true;
            }
            from = e;
        }
    }
    false
}
