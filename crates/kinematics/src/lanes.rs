//! Four `f64` lanes in lockstep, for the batch kinematics ([`crate::Machine::inverse_into`]).
//!
//! `F4` is four independent numbers; every operation is the scalar IEEE operation on
//! each lane (so results are bit-identical to scalar code doing the same operations in
//! the same order), written as four straight-line statements that the compiler turns
//! into one vector instruction where the target has one. Comparisons give masks of
//! all-ones or zero lanes (what vector compares produce, so no conversion to `bool` in
//! between); `select` blends by them.

use std::ops::{Add, Div, Mul, Neg, Sub};

use nalgebra::Vector3;

/// Lanes per group.
pub const LANES: usize = 4;

/// Four lanes of `f64`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct F4(pub [f64; LANES]);

/// Four lanes of `bool` as vector compares make them: all bits set (true) or none.
pub type M4 = [u64; LANES];

/// Every lane true.
pub const ALL: M4 = [u64::MAX; LANES];

/// The mask of a `bool`.
#[inline(always)]
fn mask(b: bool) -> u64 {
    if b {
        u64::MAX
    } else {
        0
    }
}

/// Lane `i` of a mask as a `bool`.
#[inline(always)]
pub fn lane(m: &M4, i: usize) -> bool {
    m[i] != 0
}

macro_rules! binary {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for F4 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, b: F4) -> F4 {
                let (a, b) = (self.0, b.0);
                F4([a[0] $op b[0], a[1] $op b[1], a[2] $op b[2], a[3] $op b[3]])
            }
        }
        impl $tr<f64> for F4 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, b: f64) -> F4 {
                self $op F4::splat(b)
            }
        }
        impl $tr<F4> for f64 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, b: F4) -> F4 {
                F4::splat(self) $op b
            }
        }
    };
}

binary!(Add, add, +);
binary!(Sub, sub, -);
binary!(Mul, mul, *);
binary!(Div, div, /);

impl Neg for F4 {
    type Output = F4;
    #[inline(always)]
    fn neg(self) -> F4 {
        self.map(|x| -x)
    }
}

impl F4 {
    /// The same value in every lane.
    #[inline(always)]
    pub fn splat(x: f64) -> F4 {
        F4([x; LANES])
    }

    /// Lane `i` of each of four values (a gather from structures).
    #[inline(always)]
    pub fn from_fn(f: impl Fn(usize) -> f64) -> F4 {
        F4([f(0), f(1), f(2), f(3)])
    }

    /// `f` on each lane.
    #[inline(always)]
    pub fn map(self, f: impl Fn(f64) -> f64) -> F4 {
        let a = self.0;
        F4([f(a[0]), f(a[1]), f(a[2]), f(a[3])])
    }

    /// `f` on each pair of lanes.
    #[inline(always)]
    pub fn zip(self, b: F4, f: impl Fn(f64, f64) -> f64) -> F4 {
        let (a, b) = (self.0, b.0);
        F4([f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])])
    }

    /// A comparison on each pair of lanes.
    #[inline(always)]
    pub fn cmp(self, b: F4, f: impl Fn(f64, f64) -> bool) -> M4 {
        let (a, b) = (self.0, b.0);
        [
            mask(f(a[0], b[0])),
            mask(f(a[1], b[1])),
            mask(f(a[2], b[2])),
            mask(f(a[3], b[3])),
        ]
    }

    /// A test of each lane.
    #[inline(always)]
    pub fn test(self, f: impl Fn(f64) -> bool) -> M4 {
        let a = self.0;
        [mask(f(a[0])), mask(f(a[1])), mask(f(a[2])), mask(f(a[3]))]
    }

    #[inline(always)]
    pub fn sqrt(self) -> F4 {
        self.map(f64::sqrt)
    }

    #[inline(always)]
    pub fn abs(self) -> F4 {
        self.map(f64::abs)
    }

    /// `if m { a } else { b }` per lane, by bits (a blend).
    #[inline(always)]
    pub fn select(m: M4, a: F4, b: F4) -> F4 {
        let (a, b) = (a.0, b.0);
        let pick = |i: usize| f64::from_bits((a[i].to_bits() & m[i]) | (b[i].to_bits() & !m[i]));
        F4([pick(0), pick(1), pick(2), pick(3)])
    }

    /// 1.0 where `m`, else 0.0 (as `f64::from(u8::from(m))`).
    #[inline(always)]
    pub fn one_if(m: M4) -> F4 {
        F4::select(m, F4::splat(1.0), F4::splat(0.0))
    }
}

/// Per-lane `&` and `|` of masks.
#[inline(always)]
pub fn and(a: M4, b: M4) -> M4 {
    [a[0] & b[0], a[1] & b[1], a[2] & b[2], a[3] & b[3]]
}

#[inline(always)]
pub fn or(a: M4, b: M4) -> M4 {
    [a[0] | b[0], a[1] | b[1], a[2] | b[2], a[3] | b[3]]
}

#[inline(always)]
pub fn not(a: M4) -> M4 {
    [!a[0], !a[1], !a[2], !a[3]]
}

/// Four 3-vectors, lane by lane.
#[derive(Debug, Clone, Copy)]
pub struct W3 {
    pub x: F4,
    pub y: F4,
    pub z: F4,
}

impl W3 {
    /// The same vector in every lane.
    #[inline(always)]
    pub fn splat(v: &Vector3<f64>) -> W3 {
        W3 {
            x: F4::splat(v.x),
            y: F4::splat(v.y),
            z: F4::splat(v.z),
        }
    }

    /// Lane `i` is `f(i)`.
    #[inline(always)]
    pub fn from_fn(f: impl Fn(usize) -> Vector3<f64>) -> W3 {
        let v = [f(0), f(1), f(2), f(3)];
        W3 {
            x: F4::from_fn(|i| v[i].x),
            y: F4::from_fn(|i| v[i].y),
            z: F4::from_fn(|i| v[i].z),
        }
    }

    /// Lane `i` as a vector.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Vector3<f64> {
        Vector3::new(self.x.0[i], self.y.0[i], self.z.0[i])
    }

    #[inline(always)]
    pub fn add(&self, b: &W3) -> W3 {
        W3 {
            x: self.x + b.x,
            y: self.y + b.y,
            z: self.z + b.z,
        }
    }

    #[inline(always)]
    pub fn sub(&self, b: &W3) -> W3 {
        W3 {
            x: self.x - b.x,
            y: self.y - b.y,
            z: self.z - b.z,
        }
    }

    /// Each component times `s` (`v * s` in nalgebra).
    #[inline(always)]
    pub fn scale(&self, s: F4) -> W3 {
        W3 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }

    /// nalgebra's `dot` of 3-vectors: `(a₀b₀ + a₁b₁) + a₂b₂`.
    #[inline(always)]
    pub fn dot(&self, b: &W3) -> F4 {
        self.x * b.x + self.y * b.y + self.z * b.z
    }

    /// nalgebra's `cross`.
    #[inline(always)]
    pub fn cross(&self, b: &W3) -> W3 {
        W3 {
            x: self.y * b.z - self.z * b.y,
            y: self.z * b.x - self.x * b.z,
            z: self.x * b.y - self.y * b.x,
        }
    }
}
