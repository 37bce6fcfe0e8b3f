//! The closed form's stages before the angles, written once for `N` poses side by side
//! ("lanes": every intermediate an `[f64; N]`, each lane computed by the same operations
//! in the same order as a lone pose, so lane `k` is bit for bit the pose alone): the
//! scalar inverse is `N = 1`, and planning prices three turns about the beam at one
//! location at once, which the compiler turns into vector instructions.

use super::{
    zyz_third, Arm, Config, Directions, Frame, Turned, WristParts, LIMIT_SLACK, SINGULAR, SMALL,
};
use crate::arm::Q;

/// `N` lanes of one value.
type L<const N: usize> = [f64; N];

/// `f` on every lane.
fn lanes<const N: usize>(f: impl FnMut(usize) -> f64) -> L<N> {
    std::array::from_fn(f)
}

/// atan(t) lane by lane for |t| ≤ [`SMALL`] by its series to t¹³ (truncation below
/// 5e-20 relative), by Horner's rule across the lanes.
fn atan_small<const N: usize>(t: &L<N>) -> L<N> {
    const C: [f64; 7] = [
        1.0,
        -1.0 / 3.0,
        1.0 / 5.0,
        -1.0 / 7.0,
        1.0 / 9.0,
        -1.0 / 11.0,
        1.0 / 13.0,
    ];
    let u = lanes::<N>(|k| t[k] * t[k]);
    let mut acc = [C[6]; N];
    for c in C[..6].iter().rev() {
        acc = lanes(|k| acc[k] * u[k] + c);
    }
    lanes(|k| t[k] * acc[k])
}

/// `N` frames (rotation entries `r[i][j]`, translation `t[i]`), lane by lane.
pub(super) struct Frames<const N: usize> {
    r: [[L<N>; 3]; 3],
    pub(super) t: [L<N>; 3],
}

impl Frames<1> {
    /// One frame.
    pub(super) fn of(f: &Frame) -> Frames<1> {
        Frames {
            r: std::array::from_fn(|i| std::array::from_fn(|j| [f.r[(i, j)]])),
            t: std::array::from_fn(|i| [f.t[i]]),
        }
    }
}

/// [`WristParts`] of `N` poses, and whether each lane's wrist centre is within reach
/// (`false`: [`Arm::reach`] says why).
pub(super) struct Parts<const N: usize> {
    c1: L<N>,
    s1: L<N>,
    c2: L<N>,
    s2: L<N>,
    c23: L<N>,
    s23: L<N>,
    m00: L<N>,
    m02: L<N>,
    m10: L<N>,
    m12: L<N>,
    m01: L<N>,
    m11: L<N>,
    m22: L<N>,
    sb: L<N>,
    pub(super) reached: [bool; N],
}

impl Parts<1> {
    /// The one lane.
    pub(super) fn one(&self) -> WristParts {
        WristParts {
            c1: self.c1[0],
            s1: self.s1[0],
            c2: self.c2[0],
            s2: self.s2[0],
            c23: self.c23[0],
            s23: self.s23[0],
            m00: self.m00[0],
            m02: self.m02[0],
            m10: self.m10[0],
            m12: self.m12[0],
            m01: self.m01[0],
            m11: self.m11[0],
            m22: self.m22[0],
            sb: self.sb[0],
        }
    }
}

impl Arm {
    /// The wrist frames `work · Rz(ψ) · (R, t)` for `N` turns about the beam given as
    /// `(sin ψ, cos ψ)`, at the location [`Arm::at_site`] gave `(R, t)` for.
    pub(super) fn turned_lanes<const N: usize>(
        &self,
        at: &Turned,
        sc: &[(f64, f64); N],
    ) -> Frames<N> {
        let w = &self.fast.work;
        let (sn, cs) = (lanes::<N>(|k| sc[k].0), lanes::<N>(|k| sc[k].1));
        // a = work · Rz(ψ): columns w0 cos ψ + w1 sin ψ, w1 cos ψ − w0 sin ψ, w2.
        let a: [[L<N>; 3]; 3] = std::array::from_fn(|i| {
            let (w0, w1, w2) = (w.r[(i, 0)], w.r[(i, 1)], w.r[(i, 2)]);
            [
                lanes(|k| w0 * cs[k] + w1 * sn[k]),
                lanes(|k| w1 * cs[k] - w0 * sn[k]),
                [w2; N],
            ]
        });
        let (r, t) = (&at.r, &at.t);
        Frames {
            r: std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    lanes(|k| {
                        a[i][0][k] * r[(0, j)] + a[i][1][k] * r[(1, j)] + a[i][2][k] * r[(2, j)]
                    })
                })
            }),
            t: std::array::from_fn(|i| {
                lanes(|k| a[i][0][k] * t[0] + a[i][1][k] * t[1] + a[i][2][k] * t[2] + w.t[i])
            }),
        }
    }

    /// The closed form's stages before the angles for `N` wrist frames `T05 · Rz(θ6)`
    /// (base frame): the sines and cosines of θ1, θ2 and θ2 + θ3 and the wrist's matrix
    /// `m = R03ᵀ · R = Rz(θ4) · Ry(−θ5) · Rz(θ6)`, by the angle-sum formulas (no `atan2`).
    pub(super) fn parts_lanes<const N: usize>(&self, tp: &Frames<N>, c: Config) -> Parts<N> {
        let l = &self.links;
        let (d1, a2, a3, d3, d4) = (l[0].d, l[1].a, l[2].a, l[2].d, l[3].d);
        let [px, py, pz] = &tp.t;
        // Where the wrist centre lies in the upper arm's plane ([`Arm::reach`]).
        let r2 = lanes::<N>(|k| px[k] * px[k] + py[k] * py[k]);
        let xr = lanes::<N>(|k| (r2[k] - d3 * d3).sqrt());
        let x = lanes::<N>(|k| if c.right { xr[k] } else { -xr[k] });
        let y = lanes::<N>(|k| pz[k] - d1);
        let l3sq = a3 * a3 + d4 * d4;
        let rr = lanes::<N>(|k| (x[k] * x[k] + y[k] * y[k]).sqrt());
        let cpsi =
            lanes::<N>(|k| (a2 * a2 - l3sq + x[k] * x[k] + y[k] * y[k]) / (2.0 * a2 * rr[k]));
        let reached = std::array::from_fn(|k| {
            !(r2[k] < d3 * d3 || r2[k] == 0.0)
                && cpsi[k].is_finite()
                && cpsi[k].abs() <= 1.0 + 1e-12
        });
        // θ1 = atan2(py, px) + atan2(d3, x), and x² + d3² = r2.
        let c1 = lanes(|k| (px[k] * x[k] - py[k] * d3) / r2[k]);
        let s1 = lanes(|k| (py[k] * x[k] + px[k] * d3) / r2[k]);
        // θ2 = atan2(y, x) ± ψ, cos ψ = cpsi, sin ψ ≥ 0.
        let cp = lanes::<N>(|k| cpsi[k].clamp(-1.0, 1.0));
        let sp = lanes::<N>(|k| ((1.0 - cp[k]) * (1.0 + cp[k])).sqrt());
        let n2 = if c.up == c.right { 1.0 } else { -1.0 };
        let cx = lanes::<N>(|k| x[k] / rr[k]);
        let sy = lanes::<N>(|k| y[k] / rr[k]);
        let c2 = lanes(|k| cx[k] * cp[k] - sy[k] * n2 * sp[k]);
        let s2 = lanes(|k| sy[k] * cp[k] + cx[k] * n2 * sp[k]);
        // θ2 + θ3 = atan2(y − a2 s2, x − a2 c2) − φ.
        let xx = lanes::<N>(|k| x[k] - a2 * c2[k]);
        let yy = lanes::<N>(|k| y[k] - a2 * s2[k]);
        let n = lanes::<N>(|k| (xx[k] * xx[k] + yy[k] * yy[k]).sqrt());
        let (cf, sf) = self.fast.phi;
        let c23 = lanes(|k| (xx[k] * cf + yy[k] * sf) / n[k]);
        let s23 = lanes(|k| (yy[k] * cf - xx[k] * sf) / n[k]);
        // m = R03ᵀ · R, with R03 = Rz(θ1) Rx(90°) Rz(θ2 + θ3) Rx(−90°): columns
        // (c1 c23, s1 c23, s23), (−s1, c1, 0), (−c1 s23, −s1 s23, c23).
        let r = &tp.r;
        let row = |a: &L<N>, b: &L<N>, cc: &L<N>, j: usize| -> L<N> {
            lanes(|k| a[k] * r[0][j][k] + b[k] * r[1][j][k] + cc[k] * r[2][j][k])
        };
        let (u0, u1) = (lanes(|k| c1[k] * c23[k]), lanes(|k| s1[k] * c23[k]));
        let (w0, w1) = (lanes(|k| -c1[k] * s23[k]), lanes(|k| -s1[k] * s23[k]));
        let (v0, zero) = (lanes(|k| -s1[k]), [0.0; N]);
        let (m00, m01) = (row(&u0, &u1, &s23, 0), row(&u0, &u1, &s23, 1));
        let m02 = row(&u0, &u1, &s23, 2);
        let (m10, m11) = (row(&v0, &c1, &zero, 0), row(&v0, &c1, &zero, 1));
        let m12 = row(&v0, &c1, &zero, 2);
        let m22 = row(&w0, &w1, &c23, 2);
        let sb = lanes(|k| (m02[k] * m02[k] + m12[k] * m12[k]).sqrt());
        Parts {
            c1,
            s1,
            c2,
            s2,
            c23,
            s23,
            m00,
            m02,
            m10,
            m12,
            m01,
            m11,
            m22,
            sb,
            reached,
        }
    }

    /// [`Arm::change_turned`] for `N` turns about the beam at once, given as `(sin ψ,
    /// cos ψ)`, all measured from the same joints `q` and directions `dirs`: lane `k` is
    /// bit for bit the lone turn's answer.
    pub(crate) fn changes_lanes<const N: usize>(
        &self,
        at: &Turned,
        sc: &[(f64, f64); N],
        c: Config,
        q: &Q,
        dirs: &Directions,
    ) -> [Option<(Q, Directions)>; N] {
        let w = self.parts_lanes(&self.turned_lanes(at, sc), c);
        // The six angles' directions (`Directions::of`), lane by lane.
        let d3 = (
            lanes::<N>(|k| w.c23[k] * w.c2[k] + w.s23[k] * w.s2[k]),
            lanes::<N>(|k| w.s23[k] * w.c2[k] - w.c23[k] * w.s2[k]),
        );
        let neg = |v: &L<N>| lanes::<N>(|k| -v[k]);
        let (d4, d5) = if c.flip {
            ((neg(&w.m02), neg(&w.m12)), (w.m22, w.sb))
        } else {
            ((w.m02, w.m12), (w.m22, neg(&w.sb)))
        };
        let d6s: [(f64, f64); N] = std::array::from_fn(|k| {
            zyz_third(
                [w.m00[k], w.m01[k], w.m10[k], w.m11[k], w.m22[k]],
                (d4.0[k], d4.1[k]),
            )
        });
        let d6 = (lanes::<N>(|k| d6s[k].0), lanes::<N>(|k| d6s[k].1));
        let to = [(w.c1, w.s1), (w.c2, w.s2), d3, d4, d5, d6];
        // Each angle's change from `q`'s: atan of the two directions' cross over dot.
        let mut ok: [bool; N] = std::array::from_fn(|k| w.reached[k] && w.sb[k] >= SINGULAR);
        let mut out = [[0.0; N]; 6];
        for (j, (dir, lk)) in dirs.0.iter().zip(&self.links).enumerate() {
            let (x0, y0) = *dir;
            let (x1, y1) = (&to[j].0, &to[j].1);
            let dot = lanes::<N>(|k| x0 * x1[k] + y0 * y1[k]);
            let cross = lanes::<N>(|k| x0 * y1[k] - y0 * x1[k]);
            let t = lanes::<N>(|k| cross[k] / dot[k]);
            out[j] = atan_small(&t);
            let v = lanes::<N>(|k| q[j] + out[j][k]);
            ok = std::array::from_fn(|k| {
                ok[k]
                    && dot[k] > 0.0
                    && t[k].abs() <= SMALL
                    && v[k] > lk.lo + LIMIT_SLACK
                    && v[k] < lk.hi - LIMIT_SLACK
            });
        }
        std::array::from_fn(|k| {
            ok[k].then(|| {
                (
                    std::array::from_fn(|j| out[j][k]),
                    Directions(std::array::from_fn(|j| (to[j].0[k], to[j].1[k]))),
                )
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::Config;
    use crate::Arm;

    /// Four turns priced in lanes are, lane by lane, bit for bit the lone turn's
    /// [`Arm::change_turned`], on random reachable poses in every configuration.
    #[test]
    fn lanes_are_the_lone_turns_bit_for_bit() {
        let Some(arm) = Arm::builtin("puma-lens") else {
            panic!("built-in");
        };
        let mut rng = lampost_testkit::XorShift(7);
        let mut next = || rng.unit();
        let head_inv = arm.head.inverse();
        let mut compared = 0;
        for _ in 0..4000 {
            let q: [f64; 6] = std::array::from_fn(|j| {
                let l = &arm.links[j];
                l.lo + (l.hi - l.lo) * next()
            });
            let c = Config::ALL[(next() * 8.0) as usize % 8];
            // The part frame (R, t) in the working frame is (m, −m·tip).
            let part = head_inv.mul(&arm.part(&q));
            let tip = -(part.r.transpose() * part.t);
            let at = arm.at_site(&part.r, &tip);
            let psi0 = (next() - 0.5) * 0.2;
            let Ok((q0, Some(dirs))) = arm.inverse_turned_with(&at, psi0, c, q[3]) else {
                continue;
            };
            let psis: [f64; 4] = std::array::from_fn(|_| psi0 + (next() - 0.5) * 0.1);
            let sc = psis.map(f64::sin_cos);
            let lanes = arm.changes_lanes(&at, &sc, c, &q0, &dirs);
            for k in 0..4 {
                let one = arm.change_turned(&at, psis[k], c, &q0, &dirs);
                assert_eq!(lanes[k], one, "lane {k}");
                compared += usize::from(one.is_some());
            }
        }
        assert!(compared > 1000, "{compared} priced");
    }
}
