//! Inverse and forward kinematics for many poses at once: the same answers as
//! [`Machine::inverse`] and [`Machine::forward`], bit for bit, several poses per
//! instruction.
//!
//! How: each pose of a chunk goes through a *branch-free* copy of the regular path (no
//! singularity, two distinct branches, finite input, angles of ordinary size), so the
//! compiler can turn the loop over the chunk into vector code; a pose that leaves the
//! regular path is only flagged there, and solved again by the scalar functions
//! afterwards. The branch-free path performs the very operations of the scalar one in
//! the same order (no fused multiply-add: Rust never contracts `a·b + c`), which is why
//! the results are identical (property-tested against the scalar functions, edge cases
//! included).
//!
//! Why the `pulp` crate: vector instructions wider than the x86-64 baseline (AVX2, four
//! `f64` per instruction) must be chosen at run time, since a shop's PC may lack them;
//! that choice needs `unsafe` code, which this workspace forbids and `pulp` keeps inside
//! a well-used crate. `Arch::dispatch` compiles the closure for each instruction set and
//! runs the best one the processor has (plain SSE2 on an old one).

use nalgebra::Vector3;
use pulp::{Arch, Simd, WithSimd};

use crate::error::KinError;
use crate::lanes::{and, lane, not, or, ALL, F4, LANES, M4, W3};
use crate::machine::{Joints, Machine, Pose, Solution, Solutions, Turn, SINGULAR};
use crate::trig::{atan2_deg4, sin_cos_deg4};

/// One inverse-kinematics question: a tool tip and tool axis in the part frame, and the
/// rotary position to stay near (see [`Machine::inverse`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkQuery {
    /// Tool tip, part frame.
    pub tip: Vector3<f64>,
    /// Tool axis (from the tip into the head), part frame; need not be unit.
    pub axis: Vector3<f64>,
    /// Rotary position (degrees, file order) to rank solutions from.
    pub near: [f64; 2],
}

/// One vector pass of [`Machine::inverse_into`] (a `pulp` operation: its body is
/// compiled for each instruction set).
struct IkPass<'a> {
    m: &'a Machine,
    head: usize,
    queries: &'a [IkQuery],
    /// Where the answers go, in order (irregular ones as placeholders).
    out: &'a mut Vec<Result<Solutions, KinError>>,
    /// Indices (into `queries`) of the irregular ones.
    irregular: &'a mut Vec<usize>,
}

impl WithSimd for IkPass<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) {
        let (m, head) = (self.m, self.head);
        let groups = self.queries.chunks_exact(LANES);
        let rest = groups.remainder();
        for (g, q) in groups.enumerate() {
            let (sols, regular) = m.inverse4(q, head);
            for (k, s) in sols.into_iter().enumerate() {
                if !lane(&regular, k) {
                    self.irregular.push(g * LANES + k);
                }
                self.out.push(Ok(s));
            }
        }
        // The last few (fewer than a group): the scalar function.
        for q in rest {
            self.out.push(m.inverse(&q.tip, &q.axis, head, &q.near));
        }
    }
}

/// One vector pass of [`Machine::forward_into`].
struct FkPass<'a> {
    m: &'a Machine,
    head: usize,
    joints: &'a [Joints],
    /// Where the poses go, in order (irregular ones as placeholders).
    out: &'a mut Vec<Pose>,
    /// Indices (into `joints`) of the irregular ones.
    irregular: &'a mut Vec<usize>,
}

impl WithSimd for FkPass<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) {
        let (m, head) = (self.m, self.head);
        let groups = self.joints.chunks_exact(LANES);
        let rest = groups.remainder();
        for (g, j) in groups.enumerate() {
            let (poses, regular) = m.forward4(j, head);
            for (k, p) in poses.into_iter().enumerate() {
                if !lane(&regular, k) {
                    self.irregular.push(g * LANES + k);
                }
                self.out.push(p);
            }
        }
        // The last few (fewer than a group): the scalar function.
        for j in rest {
            self.out.push(m.forward(j, head));
        }
    }
}

impl Machine {
    /// [`Machine::inverse`] for each query, in order, into `out` (cleared first).
    pub fn inverse_into(
        &self,
        queries: &[IkQuery],
        head: usize,
        out: &mut Vec<Result<Solutions, KinError>>,
    ) {
        out.clear();
        out.reserve(queries.len());
        if self.outer_singular() {
            // Every orientation is singular: the scalar function for all.
            out.extend(
                queries
                    .iter()
                    .map(|q| self.inverse(&q.tip, &q.axis, head, &q.near)),
            );
            return;
        }
        let mut irregular = Vec::new();
        Arch::new().dispatch(IkPass {
            m: self,
            head,
            queries,
            out,
            irregular: &mut irregular,
        });
        for i in irregular {
            let q = &queries[i];
            out[i] = self.inverse(&q.tip, &q.axis, head, &q.near);
        }
    }

    /// [`Machine::forward`] for each set of joints, in order, into `out` (cleared first).
    pub fn forward_into(&self, joints: &[Joints], head: usize, out: &mut Vec<Pose>) {
        out.clear();
        out.reserve(joints.len());
        let mut irregular = Vec::new();
        Arch::new().dispatch(FkPass {
            m: self,
            head,
            joints,
            out,
            irregular: &mut irregular,
        });
        for i in irregular {
            out[i] = self.forward(&joints[i], head);
        }
    }

    /// [`Machine::forward`] for four sets of joints, and for each whether its angles
    /// are in the range where this equals the scalar result (else it is discarded).
    #[inline(always)]
    fn forward4(&self, j: &[Joints], head: usize) -> ([Pose; LANES], M4) {
        let (ri, ro) = (&self.rotary[self.inner], &self.rotary[self.outer]);
        let ch = &self.chain;
        let a = F4::from_fn(|i| j[i].rotary[self.inner]);
        let b = F4::from_fn(|i| j[i].rotary[self.outer]);
        // `sin_cos_deg` takes its branch-free path for |x| ≤ 1e15 (NaN fails this).
        let ok = and(a.test(|x| x.abs() <= 1e15), b.test(|x| x.abs() <= 1e15));
        let (si, ci) = sin_cos_deg4(a);
        let (so, co) = sin_cos_deg4(b);
        // `head_point`: the offset plus each axis' direction times its signed value.
        let mut q = W3::splat(&self.heads[head].offset);
        for (k, l) in self.linear.iter().enumerate() {
            let v = l.sign * F4::from_fn(|i| j[i].linear[k]);
            q = q.add(&W3::splat(&l.dir).scale(v));
        }
        let rop = W3::splat(&ro.pivot);
        let rip = W3::splat(&ri.pivot);
        let a = turn4(ch.outer_turn, &ro.axis, -so, co, &q.sub(&rop)).add(&rop);
        let tip = turn4(ch.inner_turn, &ri.axis, -si, ci, &a.sub(&rip)).add(&rip);
        let t = turn4(
            ch.outer_turn,
            &ro.axis,
            -so,
            co,
            &W3::splat(&self.tool_axis),
        );
        let axis = turn4(ch.inner_turn, &ri.axis, -si, ci, &t);
        let blank = Pose {
            tip: Vector3::zeros(),
            axis: Vector3::zeros(),
        };
        let mut poses = [blank; LANES];
        for (i, p) in poses.iter_mut().enumerate() {
            *p = Pose {
                tip: tip.lane(i),
                axis: axis.lane(i),
            };
        }
        (poses, ok)
    }

    /// [`Machine::inverse`] for four queries on the regular path (see the module
    /// documentation), and for each whether it was regular (else it is discarded).
    #[inline(always)]
    fn inverse4(&self, q: &[IkQuery], head: usize) -> ([Solutions; LANES], M4) {
        let ch = &self.chain;
        let tip = W3::from_fn(|i| q[i].tip);
        let axis = W3::from_fn(|i| q[i].axis);
        let near = [F4::from_fn(|i| q[i].near[0]), F4::from_fn(|i| q[i].near[1])];
        let fin = |w: &W3| {
            let f = |x: F4| x.test(f64::is_finite);
            and(and(f(w.x), f(w.y)), f(w.z))
        };
        let finite = and(fin(&tip), fin(&axis));
        // `inverse`: the unit axis.
        let n = axis.dot(&axis).sqrt();
        let v = axis.scale(1.0 / n);
        // `orient_setup`.
        let a = W3::splat(&self.rotary[self.inner].axis).dot(&v);
        let (k, b) = (ch.k, ch.b);
        let alpha = (a - k * b) * ch.inv_det;
        let beta = (b - k * a) * ch.inv_det;
        let base2 = alpha * alpha + beta * beta + 2.0 * alpha * beta * k;
        let g2 = (1.0 - base2) * ch.inv_det;
        let ve = W3::splat(&ch.e1).dot(&v);
        let vn = W3::splat(&ch.n_hat).dot(&v);
        let rv2 = ve * ve + vn * vn;
        // `orient`: two branches, the inner axis regular. (NaN fails these tests where
        // the scalar ones would pass it: such a lane just goes to the scalar function.)
        let g = g2.map(|x| x.max(0.0).sqrt());
        let regular = and(
            and(finite, n.test(|x| x >= 1e-12)),
            and(
                g.test(|x| x >= 1e-12),
                rv2.test(|x| x >= SINGULAR * SINGULAR),
            ),
        );
        // `inner_regular` and `outer_regular`, both branches.
        let phi = atan2_deg4(vn, ve);
        let right = and(beta.test(|x| x == 0.0), g.test(|x| x > 0.0));
        let d1 = F4::select(right, F4::splat(90.0), atan2_deg4(g, beta));
        let inv = 1.0 / ((g * g + beta * beta) * rv2).sqrt();
        let inner = Regular {
            d: d1,
            minus: phi,
            s: g,
            c: beta,
            turn: (vn * inv, ve * inv),
        };
        let d2 = atan2_deg4(g, alpha);
        let inv = 1.0 / (g * g + alpha * alpha).sqrt();
        let (sp, cp) = ch.psi_sc;
        let outer = Regular {
            d: d2,
            minus: F4::splat(ch.psi),
            s: g * inv,
            c: alpha * inv,
            turn: (F4::splat(sp), F4::splat(cp)),
        };
        let pa = self.branch4(1.0, &inner, &outer, &tip, head, &near);
        let pb = self.branch4(-1.0, &inner, &outer, &tip, head, &near);
        let mut sols = [Solutions::EMPTY; LANES];
        for (i, out) in sols.iter_mut().enumerate() {
            let (a, b) = (pa.solution(i, 1), pb.solution(i, -1));
            // `rank`.
            let (n0, n1) = (near[0].0[i], near[1].0[i]);
            let (ca, cb) = (
                (a.joints.rotary[0] - n0).abs() + (a.joints.rotary[1] - n1).abs(),
                (b.joints.rotary[0] - n0).abs() + (b.joints.rotary[1] - n1).abs(),
            );
            let swap = match (a.within_limits, b.within_limits) {
                (false, true) => true,
                (true, false) => false,
                _ => cb < ca,
            };
            *out = Solutions {
                sols: if swap { [b, a] } else { [a, b] },
                n: 2,
            };
        }
        (sols, regular)
    }

    /// One branch (`sign` ±1) of the orientation in file order, placed and solved.
    #[inline(always)]
    fn branch4(
        &self,
        sign: f64,
        inner: &Regular,
        outer: &Regular,
        tip: &W3,
        head: usize,
        near: &[F4; 2],
    ) -> Placed4 {
        let mut deg = [F4::splat(0.0); 2];
        let mut sc = [(F4::splat(0.0), F4::splat(1.0)); 2];
        (deg[self.inner], sc[self.inner]) = inner.branch(sign);
        (deg[self.outer], sc[self.outer]) = outer.branch(sign);
        self.branch_solution4(&deg, &sc, tip, head, near)
    }

    /// `branch_solution` on four lanes: rotaries placed, linear axes from where the
    /// table puts `tip`, and the limit checks.
    #[inline(always)]
    fn branch_solution4(
        &self,
        deg: &[F4; 2],
        sc: &[(F4, F4); 2],
        tip: &W3,
        head: usize,
        near: &[F4; 2],
    ) -> Placed4 {
        let (r0, ok0) = self.place4(0, deg[0], near[0]);
        let (r1, ok1) = self.place4(1, deg[1], near[1]);
        // `part_to_machine_sc`.
        let ch = &self.chain;
        let (ri, ro) = (&self.rotary[self.inner], &self.rotary[self.outer]);
        let (si, ci) = sc[self.inner];
        let (so, co) = sc[self.outer];
        let rip = W3::splat(&ri.pivot);
        let rop = W3::splat(&ro.pivot);
        let a = turn4(ch.inner_turn, &ri.axis, si, ci, &tip.sub(&rip)).add(&rip);
        let qm = turn4(ch.outer_turn, &ro.axis, so, co, &a.sub(&rop)).add(&rop);
        // `linear_for` and `linear_within`.
        let d = qm.sub(&W3::splat(&self.heads[head].offset));
        let l = &self.linear;
        let linear = [
            l[0].sign * d.dot(&W3::splat(&l[0].dir)),
            l[1].sign * d.dot(&W3::splat(&l[1].dir)),
            l[2].sign * d.dot(&W3::splat(&l[2].dir)),
        ];
        let mut within = and(ok0, ok1);
        for (l, x) in self.linear.iter().zip(&linear) {
            let (lo, hi) = l.limits;
            within = and(within, x.test(|v| v >= lo - 1e-9 && v <= hi + 1e-9));
        }
        Placed4 {
            linear,
            rotary: [r0, r1],
            within,
        }
    }

    /// `place` on four lanes, by selection: the representative of `deg` nearest `near`
    /// within travel (the first of the nearest, trying whole turns −2 … +2, as `place`
    /// does), or the nearest one when none is.
    #[inline(always)]
    fn place4(&self, axis: usize, deg: F4, near: F4) -> (F4, M4) {
        let base = near + wrap180_4(deg - near);
        match self.rotary[axis].limits {
            None => (base, ALL),
            Some((lo, hi)) => {
                let within = |c: F4| c.test(|x| x >= lo - 1e-9 && x <= hi + 1e-9);
                let fast = and(within(base), (base - near).abs().test(|x| x < 180.0));
                if fast == ALL {
                    // No lane needs the search (the usual case): `place` returns `base`.
                    return (base, ALL);
                }
                let (mut best, mut best_d, mut any) = (base, F4::splat(0.0), [0; LANES]);
                for k in -2i8..=2 {
                    let c = base + 360.0 * f64::from(k);
                    let d = (c - near).abs();
                    let w = within(c);
                    let take = and(w, or(not(any), d.cmp(best_d, |a, b| a < b)));
                    best = F4::select(take, c, best);
                    best_d = F4::select(take, d, best_d);
                    any = or(any, w);
                }
                let placed = F4::select(or(fast, not(any)), base, best);
                (placed, or(fast, any))
            }
        }
    }
}

/// One rotary's angle on both branches, as `inner_regular` / `outer_regular` make it:
/// `wrap180(±d − minus)`, and its (sin, cos) from the pair (`s`, `c`) turned by `turn`.
struct Regular {
    d: F4,
    minus: F4,
    s: F4,
    c: F4,
    /// (sin, cos) of the fixed part of the angle.
    turn: (F4, F4),
}

impl Regular {
    /// The angle and its (sin, cos) on branch `sign` (±1): `outer_regular`'s
    /// (sd·cp − cd·sp, cd·cp + sd·sp) with sd = ±s, which is also `inner_regular`'s
    /// (sd·cp − β·sp, β·cp + sd·sp) with sd = ±g and (sp, cp) = (v·n̂, v·e₁)/|…|.
    #[inline(always)]
    fn branch(&self, sign: f64) -> (F4, (F4, F4)) {
        let sd = sign * self.s;
        let (sp, cp) = self.turn;
        (
            wrap180_4(sign * self.d - self.minus),
            (sd * cp - self.c * sp, self.c * cp + sd * sp),
        )
    }
}

impl Placed4 {
    /// Lane `i` as a solution on `branch`.
    #[inline(always)]
    fn solution(&self, i: usize, branch: i8) -> Solution {
        Solution {
            joints: Joints {
                linear: [
                    self.linear[0].0[i],
                    self.linear[1].0[i],
                    self.linear[2].0[i],
                ],
                rotary: [self.rotary[0].0[i], self.rotary[1].0[i]],
            },
            within_limits: lane(&self.within, i),
            branch,
            singular: false,
        }
    }
}

/// A branch solved on four lanes (see [`Machine::branch_solution4`]).
struct Placed4 {
    linear: [F4; 3],
    rotary: [F4; 2],
    within: M4,
}

/// `Turn::apply` on four lanes.
#[inline(always)]
fn turn4(turn: Turn, u: &Vector3<f64>, s: F4, c: F4, p: &W3) -> W3 {
    match turn {
        Turn::X(sg) => {
            let s = s * sg;
            W3 {
                x: p.x,
                y: c * p.y - s * p.z,
                z: s * p.y + c * p.z,
            }
        }
        Turn::Y(sg) => {
            let s = s * sg;
            W3 {
                x: c * p.x + s * p.z,
                y: p.y,
                z: c * p.z - s * p.x,
            }
        }
        Turn::Z(sg) => {
            let s = s * sg;
            W3 {
                x: c * p.x - s * p.y,
                y: s * p.x + c * p.y,
                z: p.z,
            }
        }
        // `rot`: p·c + (u × p)·s + u·((u·p)(1 − c)).
        Turn::General => {
            let uw = W3::splat(u);
            let cr = uw.cross(p);
            let d = uw.dot(p) * (1.0 - c);
            W3 {
                x: p.x * c + cr.x * s + u.x * d,
                y: p.y * c + cr.y * s + u.y * d,
                z: p.z * c + cr.z * s + u.z * d,
            }
        }
    }
}

/// `wrap180` on four lanes: both of its ways worked out, one picked per lane.
#[inline(always)]
fn wrap180_4(d: F4) -> F4 {
    let small = d.test(|x| x > -540.0 && x <= 540.0);
    let up = F4::one_if(d.test(|x| x <= -180.0));
    let down = F4::one_if(d.test(|x| x > 180.0));
    let near_turn = d + 360.0 * (up - down);
    if small == ALL {
        // The usual case: no lane more than 1½ turns out.
        return near_turn;
    }
    let x = d - 360.0 * (d / 360.0).map(f64::round);
    let x = F4::select(
        x.test(|v| v > 180.0),
        x - 360.0,
        F4::select(x.test(|v| v <= -180.0), x + 360.0, x),
    );
    F4::select(small, near_turn, x)
}

#[cfg(test)]
mod tests {
    use super::IkQuery;
    use crate::machine::{Joints, Machine};
    use nalgebra::Vector3;
    use proptest::prelude::*;

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    fn machines() -> Vec<Machine> {
        let mut ms: Vec<Machine> = ["fadal-lamp", "nrc-lc"]
            .iter()
            .filter_map(|n| Machine::builtin(n, &[]).ok())
            .collect();
        let trt = include_str!("../../../fixtures/machines/xyzac-trt.toml");
        if let Ok(def) = crate::MachineDef::from_toml(trt, "xyzac-trt.toml") {
            if let Ok(m) = Machine::new(def, &[]) {
                ms.push(m);
            }
        }
        assert_eq!(ms.len(), 3, "three machines to test on");
        ms
    }

    /// A value from a mix of ordinary, tiny, huge, exact and non-finite numbers.
    fn any_value() -> impl Strategy<Value = f64> {
        prop_oneof![
            8 => -200.0f64..200.0,
            1 => -1e-10f64..1e-10,
            1 => prop_oneof![Just(0.0), Just(-0.0), Just(1.0), Just(-1.0), Just(90.0), Just(180.0), Just(-180.0)],
            1 => prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(1e16), Just(-3e17), Just(720.5)],
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(150))]
        /// Every query, batched, gives exactly the scalar `inverse` result (the same bits,
        /// or the same error), and `forward_into` exactly `forward`: random reachable
        /// poses, axes along rotary axes (singular), zero and non-finite input, far
        /// `near` values and angles beyond the limits, on three machines.
        #[test]
        fn batch_equals_scalar(
            raw in prop::collection::vec((
                prop::array::uniform3(any_value()),
                prop::array::uniform3(any_value()),
                prop::array::uniform2(any_value()),
                prop::array::uniform5(-150.0f64..150.0),
                any::<bool>(),
                0usize..4,
            ), 1..300),
        ) {
            for m in machines() {
                let queries: Vec<IkQuery> = raw
                    .iter()
                    .map(|(tip, axis, near, j, reachable, singular)| {
                        if *reachable {
                            // A pose the machine reaches, from random joints.
                            let p = m.forward(&Joints { linear: [j[0], j[1], j[2]], rotary: [j[3], j[4]] }, 0);
                            let axis = match singular {
                                0 => m.rotary[m.inner].axis,
                                _ => p.axis,
                            };
                            IkQuery { tip: p.tip, axis, near: *near }
                        } else {
                            IkQuery { tip: Vector3::from(*tip), axis: Vector3::from(*axis), near: *near }
                        }
                    })
                    .collect();
                let mut out = Vec::new();
                m.inverse_into(&queries, 0, &mut out);
                prop_assert_eq!(out.len(), queries.len());
                let mut joints = Vec::new();
                for (q, got) in queries.iter().zip(&out) {
                    let want = m.inverse(&q.tip, &q.axis, 0, &q.near);
                    match (got, &want) {
                        (Ok(a), Ok(b)) => {
                            prop_assert_eq!(a.as_slice().len(), b.as_slice().len());
                            for (x, y) in a.as_slice().iter().zip(b.as_slice()) {
                                prop_assert_eq!(bits(&x.joints.values()), bits(&y.joints.values()), "{:?}", q);
                                prop_assert_eq!((x.within_limits, x.branch, x.singular), (y.within_limits, y.branch, y.singular));
                                joints.push(x.joints);
                            }
                        }
                        (Err(a), Err(b)) => prop_assert_eq!(a.to_string(), b.to_string()),
                        _ => prop_assert!(false, "{:?}: batch {:?}, scalar {:?}", q, got, want),
                    }
                }
                joints.extend(raw.iter().map(|(_, _, near, j, _, _)| Joints { linear: [j[0], j[1], j[2]], rotary: *near }));
                let mut poses = Vec::new();
                m.forward_into(&joints, 0, &mut poses);
                for (j, p) in joints.iter().zip(&poses) {
                    let want = m.forward(j, 0);
                    prop_assert_eq!(bits(p.tip.as_slice()), bits(want.tip.as_slice()));
                    prop_assert_eq!(bits(p.axis.as_slice()), bits(want.axis.as_slice()));
                }
            }
        }
    }
}
