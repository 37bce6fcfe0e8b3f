//! The chord points of a linearised arc, planned on the reading thread: each point's joints
//! and how far its written form lands from the arc, four points at a time.
//!
//! The same as the scalar loop ([`plan_one`]: [`ArcPoints::at`], the index's joints map,
//! the written tip, [`ArcPoints::dist_near`] or the distance to the end), bit for bit: the
//! lanes ([`lampost_kinematics::lanes`]) do the very operations in the same order, and a
//! group with a lane off the usual path (an angle beyond 1e15°, a joint beyond 4.5e15
//! output units, a distance that needs the general formula) is done by the scalar loop
//! (property test below). `pulp` compiles the lanes for the widest vector instructions
//! the processor has (as in the batch kinematics).

use lampost_kinematics::lanes::{and, or, ALL, F4, LANES, M4, W3};
use lampost_kinematics::trig::sin_cos_deg4;
use lampost_kinematics::Affine;
use pulp::{Arch, Simd, WithSimd};

use crate::intended::Step;
use crate::pipeline::PlannedPoint;
use crate::post::{joints, written_tip};
use crate::verify::ArcPoints;

/// One arc's chord points under one index: what every point of it is worked out from.
#[derive(Clone, Copy)]
struct Chords<'a> {
    arc: &'a ArcPoints,
    step: &'a Step,
    /// How many chords.
    n: usize,
    /// The index's joints map and written-tip map, and the output resolution factor.
    jm: &'a Affine,
    tm: &'a Affine,
    scale: f64,
}

/// The `n` chord points of `arc` (of `step`), appended to `points`. Never inlined: its
/// frame (four points' worth of lanes) would otherwise be set up on every step planned,
/// arcs or not (measured: 7 % slower on a program without linearised arcs).
#[inline(never)]
pub(crate) fn plan(
    arc: &ArcPoints,
    step: &Step,
    n: usize,
    jm: &Affine,
    tm: &Affine,
    scale: f64,
    points: &mut Vec<PlannedPoint>,
) {
    let c = Chords {
        arc,
        step,
        n,
        jm,
        tm,
        scale,
    };
    if n < LANES {
        points.extend((1..=n).map(|k| c.one(k)));
        return;
    }
    Arch::new().dispatch(Pass { c, points });
}

impl Chords<'_> {
    /// Chord point `k` of `n`, one at a time.
    #[inline]
    fn one(&self, k: usize) -> PlannedPoint {
        let (arc, step, n) = (self.arc, self.step, self.n);
        let t = k as f64 / n as f64;
        let c = arc.at(t);
        let q = joints(self.jm, &c);
        let tip = written_tip(self.tm, self.scale, &q);
        let err = if k == n {
            (tip - step.end).norm()
        } else {
            arc.dist_near(step, &tip, &c, t)
        };
        (q, err)
    }
}

struct Pass<'a> {
    c: Chords<'a>,
    points: &'a mut Vec<PlannedPoint>,
}

impl WithSimd for Pass<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) {
        let (c, n) = (self.c, self.c.n);
        let mut k = 1;
        while k + LANES - 1 <= n {
            match c.group(k) {
                Some(g) => self.points.extend(g),
                None => self.points.extend((k..k + LANES).map(|k| c.one(k))),
            }
            k += LANES;
        }
        self.points.extend((k..=n).map(|k| c.one(k)));
    }
}

/// `m·p + b` as nalgebra's `Matrix3 · Vector3 + Vector3` computes it: each row
/// `((a₀p₀ + a₁p₁) + a₂p₂) + b`.
#[inline(always)]
fn affine4(m: &Affine, p: &W3) -> W3 {
    let a = &m.a;
    let row = |i: usize| a[(i, 0)] * p.x + a[(i, 1)] * p.y + a[(i, 2)] * p.z + m.b[i];
    W3 {
        x: row(0),
        y: row(1),
        z: row(2),
    }
}

/// `round_half_away` on four lanes (valid where `|x| < 4.5e15`, not NaN: checked by the
/// caller): truncation, then a step where the exact remainder is a half or more.
#[inline(always)]
fn round4(x: F4) -> F4 {
    let t = x.map(f64::trunc);
    let f = x - t;
    let r = t + F4::one_if(f.test(|v| v >= 0.5)) - F4::one_if(f.test(|v| v <= -0.5));
    r.zip(x, f64::copysign)
}

/// `(√((x² + y²) + z²))`: nalgebra's `norm` of each lane's vector.
#[inline(always)]
fn norm4(v: &W3) -> F4 {
    v.dot(v).sqrt()
}

impl Chords<'_> {
    /// Chord points `k … k + 3` of `n`, or `None` when a lane is off the usual path.
    #[inline(always)]
    fn group(&self, k: usize) -> Option<[PlannedPoint; LANES]> {
        let (arc, step, n, jm, tm, scale) =
            (self.arc, self.step, self.n, self.jm, self.tm, self.scale);
        let kf = F4::from_fn(|i| (k + i) as f64);
        let t = kf / n as f64;
        // `ArcPoints::at`.
        let deg = (arc.sweep * t).map(f64::to_degrees);
        let mut ok: M4 = deg.test(|d| d.abs() <= 1e15);
        let (s, c) = sin_cos_deg4(deg);
        let nn = &arc.n;
        let one_minus_c = 1.0 - c;
        let rotated = W3 {
            x: arc.rel.x * c + arc.n_cross_rel.x * s + nn.x * (arc.n_dot_rel * one_minus_c),
            y: arc.rel.y * c + arc.n_cross_rel.y * s + nn.y * (arc.n_dot_rel * one_minus_c),
            z: arc.rel.z * c + arc.n_cross_rel.z * s + nn.z * (arc.n_dot_rel * one_minus_c),
        };
        let rise = arc.rise * t;
        let point = W3 {
            x: arc.center.x + rotated.x + nn.x * rise,
            y: arc.center.y + rotated.y + nn.y * rise,
            z: arc.center.z + rotated.z + nn.z * rise,
        };
        // The joints, and the tip where they put the tool as written (`written_tip`).
        let q = affine4(jm, &point);
        let written = |v: F4, ok: &mut M4| {
            let x = v * scale;
            *ok = and(*ok, x.test(|x| x.abs() < 4.5e15));
            round4(x) / scale
        };
        let w = W3 {
            x: written(q.x, &mut ok),
            y: written(q.y, &mut ok),
            z: written(q.z, &mut ok),
        };
        let tip = affine4(tm, &w);
        // Distances: to the end for the last point, else `dist_near`'s closed form.
        let to_end = norm4(&tip.sub(&W3::splat(&step.end)));
        let last = kf.test(|v| v == n as f64);
        let along = match arc.flat_radius {
            Some(r) => {
                let qv = tip.sub(&W3::splat(&arc.center));
                let nw = W3::splat(nn);
                let d = nw.dot(&qv);
                let qp = qv.sub(&nw.scale(d));
                let qn = norm4(&qp);
                let m = (t.zip(1.0 - t, f64::min) * arc.sweep.abs())
                    .map(|m| m.min(std::f64::consts::FRAC_PI_2));
                let sm = m * std::f64::consts::FRAC_1_PI;
                let off = tip.sub(&point);
                let near = off.dot(&off);
                let fast = and(
                    and(qn.test(|v| v >= 1e-12), t.test(|v| v > 0.0 && v < 1.0)),
                    near.cmp(sm * sm * qn * qn, |a, b| a < b),
                );
                ok = and(ok, or(last, fast));
                let radial = qn - r;
                (radial * radial + d * d).sqrt()
            }
            None => {
                // Every point but the last needs the general distance.
                ok = and(ok, last);
                F4::splat(0.0)
            }
        };
        if ok != ALL {
            return None;
        }
        let err = F4::select(last, to_end, along);
        Some(std::array::from_fn(|i| {
            ([q.x.0[i], q.y.0[i], q.z.0[i]], err.0[i])
        }))
    }
}

/// (For the tests: the scalar path.)
#[cfg(test)]
fn plan_scalar(
    arc: &ArcPoints,
    step: &Step,
    n: usize,
    jm: &Affine,
    tm: &Affine,
    scale: f64,
) -> Vec<PlannedPoint> {
    let c = Chords {
        arc,
        step,
        n,
        jm,
        tm,
        scale,
    };
    (1..=n).map(|k| c.one(k)).collect()
}

#[cfg(test)]
mod tests {
    use super::{plan, plan_scalar};
    use crate::verify::tests::arc as arc_step;
    use crate::verify::ArcPoints;
    use lampost_kinematics::lanes::LANES;
    use lampost_kinematics::trig::sin_cos_deg;
    use lampost_kinematics::Machine;
    use nalgebra::Vector3;
    use proptest::prelude::*;

    fn bits(p: &([f64; 3], f64)) -> [u64; 4] {
        [
            p.0[0].to_bits(),
            p.0[1].to_bits(),
            p.0[2].to_bits(),
            p.1.to_bits(),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]
        /// Four at a time gives exactly what one at a time gives: random arcs (flat and
        /// helical, up to two turns), indexes and chord counts, on both built-ins.
        #[test]
        fn chords_in_lanes_match_one_at_a_time(
            c in prop::array::uniform3(-100.0f64..100.0),
            nrm in prop::array::uniform3(-1.0f64..1.0),
            r in 0.001f64..200.0,
            a0 in -7.0f64..7.0,
            sweep in -12.6f64..12.6,
            helix in prop::bool::weighted(0.2),
            n in 1usize..=40,
            rot in prop::array::uniform2(-90.0f64..90.0),
            fadal in any::<bool>(),
        ) {
            let normal = Vector3::from(nrm);
            prop_assume!(normal.norm() > 0.1);
            let step = arc_step(Vector3::from(c), normal, r, a0, sweep, if helix { 0.3 * r } else { 0.0 });
            let m = Machine::builtin(if fadal { "fadal-lamp" } else { "nrc-lc" }, &[]).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let sc = [sin_cos_deg(rot[0]), sin_cos_deg(rot[1])];
            let jm = m.joints_map(&sc, 0);
            let inv = [(-sc[0].0, sc[0].1), (-sc[1].0, sc[1].1)];
            let tm = m.tip_map(&inv, 0);
            let scale = if fadal { 1e4 } else { 1e3 };
            let Some(arc) = ArcPoints::new(&step) else { return Err(TestCaseError::fail("an arc")) };
            let mut got = Vec::new();
            plan(&arc, &step, n, &jm, &tm, scale, &mut got);
            let want = plan_scalar(&arc, &step, n, &jm, &tm, scale);
            prop_assert_eq!(got.len(), want.len());
            for (a, b) in got.iter().zip(&want) {
                prop_assert_eq!(bits(a), bits(b));
            }
            prop_assert!(n < LANES || got.len() == n);
        }
    }
}
