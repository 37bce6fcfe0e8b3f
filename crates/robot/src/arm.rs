//! The arm: classic Denavit–Hartenberg forward kinematics, the closed-form inverse of a
//! PUMA-type arm (all eight configurations), a damped-least-squares inverse for other
//! arms, and joint limits.
//!
//! Classic DH: `A_i(q_i) = Rz(q_i + offset_i) · Tz(d_i) · Tx(a_i) · Rx(α_i)`; the flange is
//! `A_1 ⋯ A_6` in the base frame; the part frame in the world is
//! `base · A_1 ⋯ A_6 · holder`. Angles are radians here and degrees in files.
//!
//! The closed form holds for arms with α = (90°, 0, −90°, 90°, −90°, any), a1 = d2 = 0 and
//! a4 = a5 = d5 = 0 (the PUMA 560's shape: a shoulder offset d3, a forearm offset a3 and a
//! spherical wrist). It follows Paul and Zhang (1986), as the Robotics Toolbox's
//! `ikine_a` does, and names the configurations the same way: `l`/`r` shoulder (left,
//! right), `u`/`d` elbow (up, down), `n`/`f` wrist (not flipped: θ5 ≤ 0; flipped: θ5 > 0).

use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

use crate::def::{ArmDef, FrameDef, Units};
use crate::error::RobotError;

mod lanes;

/// Joint values, radians.
pub type Q = [f64; 6];

const TAU: f64 = std::f64::consts::TAU;
const PI: f64 = std::f64::consts::PI;

/// A rigid transform: `p_parent = r · p_child + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Rotation (columns: the child's axes in the parent).
    pub r: Matrix3<f64>,
    /// Translation (the child's origin in the parent).
    pub t: Vector3<f64>,
}

impl Frame {
    /// The identity.
    pub fn identity() -> Frame {
        Frame {
            r: Matrix3::identity(),
            t: Vector3::zeros(),
        }
    }

    /// `self · other`.
    pub fn mul(&self, o: &Frame) -> Frame {
        Frame {
            r: self.r * o.r,
            t: self.r * o.t + self.t,
        }
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Frame {
        let rt = self.r.transpose();
        Frame {
            r: rt,
            t: -(rt * self.t),
        }
    }

    /// A point of the child frame in the parent.
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.r * p + self.t
    }

    /// From a file's origin and axes (x made orthogonal to z; y = z × x).
    pub fn from_def(f: &FrameDef) -> Frame {
        let z = Vector3::from(f.z_axis).normalize();
        let y = z.cross(&Vector3::from(f.x_axis)).normalize();
        let x = y.cross(&z);
        Frame {
            r: Matrix3::from_columns(&[x, y, z]),
            t: Vector3::from(f.origin),
        }
    }

    /// Rotation about z by `a` radians.
    pub fn rot_z(a: f64) -> Matrix3<f64> {
        let (s, c) = a.sin_cos();
        Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
    }
}

/// One joint, radians and file units.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// Name.
    pub name: String,
    /// DH d.
    pub d: f64,
    /// DH a.
    pub a: f64,
    /// DH α, radians.
    pub alpha: f64,
    /// Added to the joint value to give θ, radians.
    pub offset: f64,
    /// Lower limit, radians.
    pub lo: f64,
    /// Upper limit, radians.
    pub hi: f64,
    /// Fastest turn, radians per second.
    pub max_speed: f64,
    sa: f64,
    ca: f64,
}

impl Link {
    /// `A_i(q)`.
    pub fn transform(&self, q: f64) -> Frame {
        let (st, ct) = (q + self.offset).sin_cos();
        let (sa, ca) = (self.sa, self.ca);
        Frame {
            r: Matrix3::new(ct, -st * ca, st * sa, st, ct * ca, -ct * sa, 0.0, sa, ca),
            t: Vector3::new(self.a * ct, self.a * st, self.d),
        }
    }

    /// `f · A_i(q)` multiplied out for the DH form (the columns of `f` turned by θ and
    /// twisted by α; no product with `A_i`'s zeros and ones): `Link::transform`'s
    /// product within rounding (proptest).
    pub fn after(&self, f: &Frame, q: f64) -> Frame {
        let (st, ct) = (q + self.offset).sin_cos();
        let (r0, r1, r2) = (f.r.column(0), f.r.column(1), f.r.column(2));
        let u = r0 * ct + r1 * st;
        let v = r1 * ct - r0 * st;
        Frame {
            r: Matrix3::from_columns(&[u, v * self.ca + r2 * self.sa, r2 * self.ca - v * self.sa]),
            t: f.t + u * self.a + r2 * self.d,
        }
    }
}

/// The wrist centre in the upper arm's plane ([`Arm::reach`]): its signed distance `x`
/// from the waist axis past the shoulder offset (negative for a left shoulder) and height
/// `y` above the shoulder, and the cosine of the shoulder's angle in the elbow's triangle.
struct Reach {
    x: f64,
    y: f64,
    cpsi: f64,
}

/// An arm configuration: shoulder, elbow, wrist.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Config {
    /// Right shoulder (`r`), else left (`l`).
    pub right: bool,
    /// Elbow up (`u`), else down (`d`).
    pub up: bool,
    /// Wrist flipped (`f`), else not (`n`).
    pub flip: bool,
}

impl Config {
    /// All eight.
    pub const ALL: [Config; 8] = {
        let mut all = [Config {
            right: false,
            up: false,
            flip: false,
        }; 8];
        let mut i = 0;
        while i < 8 {
            all[i] = Config {
                right: i & 4 != 0,
                up: i & 2 != 0,
                flip: i & 1 != 0,
            };
            i += 1;
        }
        all
    };

    /// Three letters, in any order: `l`/`r`, `u`/`d`, `n`/`f`.
    pub fn parse(s: &str) -> Option<Config> {
        let s = s.trim().to_ascii_lowercase();
        if s.len() != 3 {
            return None;
        }
        let has = |a: char, b: char| match (s.contains(a), s.contains(b)) {
            (true, false) => Some(true),
            (false, true) => Some(false),
            _ => None,
        };
        Some(Config {
            right: has('r', 'l')?,
            up: has('u', 'd')?,
            flip: has('f', 'n')?,
        })
    }

    /// The letters, e.g. `lun`.
    pub fn letters(&self) -> String {
        format!(
            "{}{}{}",
            if self.right { 'r' } else { 'l' },
            if self.up { 'u' } else { 'd' },
            if self.flip { 'f' } else { 'n' }
        )
    }
}

/// The configuration of joint values; `None` where they lie on the boundary between two
/// (a singular pose), so either configuration holds there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConfigOf {
    /// Right shoulder.
    pub right: Option<bool>,
    /// Elbow up.
    pub up: Option<bool>,
    /// Wrist flipped.
    pub flip: Option<bool>,
}

impl ConfigOf {
    /// Whether `c` holds for these joint values.
    pub fn fits(&self, c: Config) -> bool {
        self.right.is_none_or(|r| r == c.right)
            && self.up.is_none_or(|u| u == c.up)
            && self.flip.is_none_or(|f| f == c.flip)
    }
}

/// Why an inverse has no answer.
#[derive(Debug, Clone, PartialEq)]
pub struct NoReach {
    /// The limiting joint (0-based).
    pub joint: usize,
    /// Why.
    pub why: Why,
}

/// Why an inverse has no answer: words, or a joint outside its limits (kept as numbers
/// until shown: planning meets and drops thousands of these while it searches).
#[derive(Debug, Clone, PartialEq)]
pub enum Why {
    /// In words.
    Words(String),
    /// The joint (named by whoever shows it) would be at `value`, outside `[lo, hi]`
    /// (radians).
    Outside {
        /// The joint's value.
        value: f64,
        /// Its lower limit.
        lo: f64,
        /// Its upper limit.
        hi: f64,
    },
}

impl std::fmt::Display for Why {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Why::Words(w) => f.write_str(w),
            Why::Outside { value, lo, hi } => write!(
                f,
                "would be {:.3}°, outside its limits [{:.1}°, {:.1}°]",
                value.to_degrees(),
                lo.to_degrees(),
                hi.to_degrees()
            ),
        }
    }
}

/// Wrap an angle into (−π, π].
pub fn wrap(a: f64) -> f64 {
    const INV_TAU: f64 = 1.0 / TAU;
    let w = a - TAU * round_even(a * INV_TAU);
    if w <= -PI {
        w + TAU
    } else if w > PI {
        w - TAU
    } else {
        w
    }
}

/// `x` rounded to a whole number, halves to even: adding and taking away 1.5 · 2⁵² leaves
/// no fraction bits (the FPU's rounding does it), where `f64::round` is a library call
/// on x86-64's baseline. Beyond 2⁵¹ `f64::round` (every such value is whole anyway).
fn round_even(x: f64) -> f64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2⁵²
    if x.abs() < 2_251_799_813_685_248.0 {
        (x + MAGIC) - MAGIC
    } else {
        x.round()
    }
}

/// A validated arm.
#[derive(Debug, Clone)]
pub struct Arm {
    /// Machine name.
    pub name: String,
    /// Length units.
    pub units: Units,
    /// The joints.
    pub links: [Link; 6],
    /// World to base.
    pub base: Frame,
    /// Flange to part.
    pub holder: Frame,
    /// World to working frame (origin: the focus; z: into the head).
    pub head: Frame,
    /// The safe location, radians.
    pub safe: Q,
    /// Default configuration.
    pub config: Config,
    /// Locations per controller file, the two safe ones included.
    pub chunk_points: usize,
    /// Largest distance between locations.
    pub spacing: f64,
    /// Verification tolerance (focus to path).
    pub tolerance: f64,
    /// The PUMA closed form applies.
    pub closed_form: bool,
    /// Characteristic length (sum of |a| + |d|), for scaling.
    pub scale: f64,
    /// For an arm with the PUMA's twists but small offsets the closed form does not
    /// allow (a1, d2, a4, a5, d5): the same arm with them zeroed, whose closed-form
    /// solution in the asked configuration seeds the numerical inverse.
    pub approx: Option<Box<Arm>>,
    /// The file it came from.
    pub def: ArmDef,
    /// Constants of the fast closed form, worked out once by [`Arm::new`] from `links`,
    /// `base`, `holder` and `head` (build a new arm rather than change those).
    fast: Fast,
}

/// One location's part frame before the turn about the beam, carried to the wrist frame
/// ([`Arm::at_site`]): what every solve there ([`Arm::inverse_turned`]) shares.
#[derive(Debug, Clone, Copy)]
pub struct Turned {
    r: Matrix3<f64>,
    t: Vector3<f64>,
}

/// The wrist's sin |θ5| below which the wrist counts as singular (θ4 kept).
const SINGULAR: f64 = 1e-10;

/// The closed form's intermediate values ([`Arm::wrist_parts`]).
#[derive(Debug, Clone, Copy)]
struct WristParts {
    c1: f64,
    s1: f64,
    c2: f64,
    s2: f64,
    c23: f64,
    s23: f64,
    m00: f64,
    m02: f64,
    m10: f64,
    m12: f64,
    m01: f64,
    m11: f64,
    m22: f64,
    sb: f64,
}

/// The six joint angles of a closed-form solution as directions `(x, y)`, each angle
/// plus its joint's offset being `atan2(y, x)` (not of unit length): what
/// [`Arm::change_turned`] measures changes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Directions([(f64, f64); 6]);

impl Directions {
    /// From the closed form's parts (`None` at the wrist singularity).
    fn of(w: &WristParts, c: Config) -> Option<Directions> {
        if w.sb < SINGULAR {
            return None;
        }
        // θ3 = (θ2 + θ3) − θ2; θ4 = atan2(m12, m02), θ5 = −atan2(sb, m22), θ6 from θ4
        // by [`zyz_third`], the flipped wrist half a turn on (θ5 negated).
        let d3 = (w.c23 * w.c2 + w.s23 * w.s2, w.s23 * w.c2 - w.c23 * w.s2);
        let (d4, d5) = if c.flip {
            ((-w.m02, -w.m12), (w.m22, w.sb))
        } else {
            ((w.m02, w.m12), (w.m22, -w.sb))
        };
        let d6 = zyz_third([w.m00, w.m01, w.m10, w.m11, w.m22], d4);
        Some(Directions([(w.c1, w.s1), (w.c2, w.s2), d3, d4, d5, d6]))
    }
}

/// In a rotation `R = Rz(a) · Ry(b) · Rz(c)`, the direction `(x, y)` of c (its angle
/// `atan2(y, x)`; not of unit length) from a's direction `a` (any length) and `m` = R's
/// entries `[r00, r01, r10, r11, r22]`. R's upper-left block gives `(1 + cos b)` times
/// the direction of a + c (`r00 + r11`, `r10 − r01`) and `(1 − cos b)` times that of
/// a − c (`r11 − r00`, `−r10 − r01`): the first is read where cos b ≥ 0, the second
/// where cos b < 0, each well conditioned there, and c is that turned back by a (or a
/// turned back by it). Near the singularity (sin b → 0) a rounds by ε / sin b and c so
/// taken rounds with it, so the three angles give R back to rounding; c read from R's
/// third row (`atan2(r21, −r20)`) rounds apart from a, and R by up to ε / sin b (2e-8
/// rad at sin b = 2e-10).
pub(crate) fn zyz_third(m: [f64; 5], a: (f64, f64)) -> (f64, f64) {
    let [r00, r01, r10, r11, r22] = m;
    let s = if r22 >= 0.0 { 1.0 } else { -1.0 };
    let (x, y) = (r11 + s * r00, s * r10 - r01);
    (x * a.0 + y * a.1, s * (y * a.0 - x * a.1))
}

/// The largest change (tangent 0.05, 2.9°) [`Arm::change_turned`] takes by its series.
const SMALL: f64 = 0.05;

/// How far inside its limits (1e-9 rad) a joint changed by [`Arm::change_turned`] must
/// lie (nearer, the full solve decides).
const LIMIT_SLACK: f64 = 1e-9;

/// What [`Arm::inverse_closed_fast`] and [`Arm::inverse_in_work`] take from the arm
/// file once rather than at every solve.
#[derive(Debug, Clone, Copy)]
struct Fast {
    /// `base⁻¹ · head`: the working frame in the arm's base frame.
    work: Frame,
    /// `holder⁻¹ · E⁻¹`, where `E = Tz(d6) · Tx(a6) · Rx(α6)` is A6's fixed part: the
    /// part frame to the wrist frame `T05 · Rz(θ6)`.
    to_wrist: Frame,
    /// `E⁻¹` alone (flange to wrist frame).
    e_inv: Frame,
    /// cos and sin of φ = atan2(d4, a3), the forearm's angle.
    phi: (f64, f64),
    /// φ itself ([`Arm::margin`]'s stretched elbow).
    phi_angle: f64,
}

impl Fast {
    fn new(links: &[Link; 6], base: &Frame, holder: &Frame, head: &Frame) -> Fast {
        let l = &links[5];
        let e = Frame {
            r: Matrix3::new(1.0, 0.0, 0.0, 0.0, l.ca, -l.sa, 0.0, l.sa, l.ca),
            t: Vector3::new(l.a, 0.0, l.d),
        };
        let e_inv = e.inverse();
        let (a3, d4) = (links[2].a, links[3].d);
        let l3 = a3.hypot(d4);
        Fast {
            work: base.inverse().mul(head),
            to_wrist: holder.inverse().mul(&e_inv),
            e_inv,
            phi: if l3 > 0.0 {
                (a3 / l3, d4 / l3)
            } else {
                (1.0, 0.0)
            },
            phi_angle: d4.atan2(a3),
        }
    }
}

impl Arm {
    /// From a checked file.
    pub fn new(def: ArmDef) -> Arm {
        let r = f64::to_radians;
        let links: [Link; 6] = std::array::from_fn(|i| {
            let j = &def.joint[i];
            let alpha = r(j.alpha);
            // Exact quarter turns: sin 90° = 1 and cos 90° = 0, not 6e-17.
            let (sa, ca) = if j.alpha == 90.0 {
                (1.0, 0.0)
            } else if j.alpha == -90.0 {
                (-1.0, 0.0)
            } else if j.alpha == 0.0 {
                (0.0, 1.0)
            } else if j.alpha.abs() == 180.0 {
                (0.0, -1.0)
            } else {
                alpha.sin_cos()
            };
            Link {
                name: j.name.clone(),
                d: j.d,
                a: j.a,
                alpha,
                offset: r(j.offset),
                lo: r(j.limits[0]),
                hi: r(j.limits[1]),
                max_speed: r(j.max_speed),
                sa,
                ca,
            }
        });
        let deg: Vec<f64> = def.joint.iter().map(|j| j.alpha).collect();
        let closed_form = deg[0] == 90.0
            && deg[1] == 0.0
            && deg[2] == -90.0
            && deg[3] == 90.0
            && deg[4] == -90.0
            && links[0].a == 0.0
            && links[1].d == 0.0
            && links[3].a == 0.0
            && links[4].a == 0.0
            && links[4].d == 0.0
            && links[1].a != 0.0
            && links[2].a.hypot(links[3].d) > 0.0;
        let scale = links.iter().map(|l| l.a.abs() + l.d.abs()).sum::<f64>();
        let puma_twists =
            deg[0] == 90.0 && deg[1] == 0.0 && deg[2] == -90.0 && deg[3] == 90.0 && deg[4] == -90.0;
        // The nearest closed-form arm (the small offsets zeroed) seeds the numerical
        // solver; it exists only when the lengths the closed form needs are there (else
        // zeroing would give the same arm again, and building it would recurse for ever:
        // found by `cargo xtask fuzz` on an arm file with a = 0).
        let zeroed_closes = links[1].a != 0.0 && links[2].a.hypot(links[3].d) > 0.0;
        let approx = (!closed_form && puma_twists && zeroed_closes)
            .then(|| {
                let mut d = def.clone();
                d.joint[0].a = 0.0;
                d.joint[1].d = 0.0;
                d.joint[3].a = 0.0;
                d.joint[4].a = 0.0;
                d.joint[4].d = 0.0;
                let a = Arm::new(d);
                a.closed_form.then(|| Box::new(a))
            })
            .flatten();
        let (base, holder, head) = (
            Frame::from_def(&def.base),
            Frame::from_def(&def.holder),
            Frame::from_def(&def.head),
        );
        Arm {
            approx,
            name: def.name.clone(),
            units: def.units,
            fast: Fast::new(&links, &base, &holder, &head),
            base,
            holder,
            head,
            safe: std::array::from_fn(|i| r(def.cell.safe[i])),
            config: Config::parse(&def.cell.config).unwrap_or(Config {
                right: false,
                up: true,
                flip: false,
            }),
            chunk_points: def.cell.chunk_points,
            spacing: def.cell.spacing,
            tolerance: def.cell.tolerance,
            closed_form,
            scale,
            links,
            def,
        }
    }

    /// A built-in arm.
    pub fn builtin(name: &str) -> Option<Arm> {
        ArmDef::builtin(name).map(Arm::new)
    }

    /// Read an arm file.
    pub fn from_toml(text: &str, file: &str) -> Result<Arm, RobotError> {
        ArmDef::from_toml(text, file).map(Arm::new)
    }

    /// Joint names.
    pub fn joint_name(&self, j: usize) -> &str {
        self.links.get(j).map_or("?", |l| l.name.as_str())
    }

    /// The flange in the base frame, `A_1 ⋯ A_6`.
    pub fn flange(&self, q: &Q) -> Frame {
        let mut t = Frame::identity();
        for (l, &v) in self.links.iter().zip(q) {
            t = t.mul(&l.transform(v));
        }
        t
    }

    /// The part frame in the world: `base · flange · holder`.
    pub fn part(&self, q: &Q) -> Frame {
        self.base.mul(&self.flange(q)).mul(&self.holder)
    }

    /// The flange (in the base frame) that puts the part frame at `part` (world).
    pub fn flange_for(&self, part: &Frame) -> Frame {
        self.base.inverse().mul(part).mul(&self.holder.inverse())
    }

    /// Whether every joint lies within its limits (1e-9 rad of slack for rounding).
    pub fn within_limits(&self, q: &Q) -> Option<usize> {
        self.links
            .iter()
            .zip(q)
            .position(|(l, &v)| !(v >= l.lo - 1e-9 && v <= l.hi + 1e-9))
    }

    /// How far joint values lie from trouble, radians: the least of every joint's distance
    /// to its nearer limit and, for arms with the PUMA's twists, the elbow's angle from
    /// stretched (θ3 = −atan2(d4, a3)) and from folded (half a turn on). Near a stretched
    /// elbow a millimetre of travel turns the elbow by degrees: planning keeps away.
    pub fn margin(&self, q: &Q) -> f64 {
        let mut m = f64::INFINITY;
        for (l, &v) in self.links.iter().zip(q) {
            m = m.min(v - l.lo).min(l.hi - v);
        }
        if self.closed_form || self.approx.is_some() {
            let l = &self.links;
            let w = wrap(q[2] + l[2].offset + self.fast.phi_angle).abs();
            m = m.min(w).min(PI - w);
        }
        m
    }

    /// Each joint on the turn (±2π) nearest `near` that lies within its limits; `Err`
    /// names the first joint with none.
    pub fn fit_limits(&self, q: &Q, near: &Q) -> Result<Q, usize> {
        let mut out = *q;
        for j in 0..6 {
            let l = &self.links[j];
            let base = near[j] + wrap(q[j] - near[j]);
            // Mostly the nearest turn lies within the limits: every other is a half turn
            // or more from `near`, so it is the answer (the loop below agrees).
            if (base - near[j]).abs() < PI && base >= l.lo - 1e-9 && base <= l.hi + 1e-9 {
                out[j] = base.clamp(l.lo, l.hi);
                continue;
            }
            let mut best: Option<f64> = None;
            for k in -2..=2 {
                let c = base + TAU * f64::from(k);
                if c >= l.lo - 1e-9 && c <= l.hi + 1e-9 {
                    let c = c.clamp(l.lo, l.hi);
                    if best.is_none_or(|b| (c - near[j]).abs() < (b - near[j]).abs()) {
                        best = Some(c);
                    }
                }
            }
            out[j] = best.ok_or(j)?;
        }
        Ok(out)
    }

    /// Closed-form inverse of a PUMA-type arm: joint values (each in (−π, π]) that put the
    /// flange at `flange` (base frame) in configuration `c`. At the wrist singularity
    /// (θ5 = 0 or π) θ4 is kept at `wrist` (the last value) and θ6 takes the rest.
    pub fn inverse_closed(&self, flange: &Frame, c: Config, wrist: f64) -> Result<Q, NoReach> {
        let l = &self.links;
        let (a2, a3, d3, d4) = (l[1].a, l[2].a, l[2].d, l[3].d);
        // Strip A6's fixed part: T' = T06 · (Tz(d6) Tx(a6) Rx(α6))⁻¹ = T05 · Rz(θ6).
        let e = Frame {
            r: {
                let (sa, ca) = (l[5].sa, l[5].ca);
                Matrix3::new(1.0, 0.0, 0.0, 0.0, ca, -sa, 0.0, sa, ca)
            },
            t: Vector3::new(l[5].a, 0.0, l[5].d),
        };
        let tp = flange.mul(&e.inverse());
        let p = tp.t;
        let Reach { x, y, cpsi, .. } = self.reach(&p, c)?;
        let t1 = p.y.atan2(p.x) + d3.atan2(x);
        let psi = cpsi.clamp(-1.0, 1.0).acos();
        let n2 = if c.up == c.right { 1.0 } else { -1.0 };
        let t2 = y.atan2(x) + n2 * psi;
        let (s2, c2) = t2.sin_cos();
        let phi = d4.atan2(a3);
        let t3 = (y - a2 * s2).atan2(x - a2 * c2) - t2 - phi;
        let th = [t1, t2, t3];
        let mut r03: Matrix3<f64> = Matrix3::identity();
        for (k, lk) in l.iter().take(3).enumerate() {
            r03 *= lk.transform(th[k] - lk.offset).r;
        }
        let m: Matrix3<f64> = r03.transpose() * tp.r; // Rz(θ4) · Ry(−θ5) · Rz(θ6)
        let sb = m[(0, 2)].hypot(m[(1, 2)]);
        let (t4, b, t6);
        let block = [m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)], m[(2, 2)]];
        if sb < 1e-10 {
            // θ4 kept; θ6 from it and the upper-left block ([`zyz_third`]).
            let w = wrist + l[3].offset;
            b = if m[(2, 2)] > 0.0 { 0.0 } else { PI };
            t4 = w;
            let (x, y) = zyz_third(block, (w.cos(), w.sin()));
            t6 = y.atan2(x);
        } else {
            let bb = sb.atan2(m[(2, 2)]);
            let a4 = m[(1, 2)].atan2(m[(0, 2)]);
            let (x, y) = zyz_third(block, (m[(0, 2)], m[(1, 2)]));
            let a6 = y.atan2(x);
            if c.flip {
                b = -bb;
                t4 = a4 + PI;
                t6 = a6 + PI;
            } else {
                b = bb;
                t4 = a4;
                t6 = a6;
            }
        }
        let t5 = -b;
        let th = [t1, t2, t3, t4, t5, t6];
        Ok(std::array::from_fn(|k| wrap(th[k] - l[k].offset)))
    }

    /// [`Arm::inverse_closed`] with fewer transcendental functions: the sines and cosines
    /// of θ1, θ2 and θ2 + θ3 that the wrist needs come from the wrist centre's coordinates
    /// by the angle-sum formulas instead of `atan2`, `acos` and `sin_cos` (six `atan2`
    /// and four square roots in all), and the frame constants are the arm's, worked out
    /// once. (The C library's `atan2` measured faster here than the kinematics crate's
    /// polynomial, which pays off in its four-lane batch.) Agrees with the reference to 1e-12 rad, more where the elbow's triangle is
    /// ill-conditioned (`tests/kinematics.rs`, proptest);
    /// planning uses it.
    pub fn inverse_closed_fast(&self, flange: &Frame, c: Config, wrist: f64) -> Result<Q, NoReach> {
        self.inverse_wrist(&flange.mul(&self.fast.e_inv), c, wrist)
    }

    /// The fast closed form for the part frame at `part` in the working frame (the
    /// flange that puts it there, `base⁻¹ · head · part · holder⁻¹`, with A6's fixed part
    /// stripped, in one product of the arm's constant frames).
    pub fn inverse_in_work(&self, part: &Frame, c: Config, wrist: f64) -> Result<Q, NoReach> {
        let tp = self.fast.work.mul(part).mul(&self.fast.to_wrist);
        self.inverse_wrist(&tp, c, wrist)
    }

    /// What every solve of [`Arm::inverse_turned`] at one location shares: the part frame
    /// `(m, −m·tip)` (the location's pose before the turn about the beam, as
    /// [`crate::plan::part_in_work`] builds it) carried to the wrist frame.
    pub fn at_site(&self, m: &Matrix3<f64>, tip: &Vector3<f64>) -> Turned {
        let tw = &self.fast.to_wrist;
        Turned {
            r: m * tw.r,
            t: m * (tw.t - tip),
        }
    }

    /// [`Arm::inverse_in_work`] for the part frame `Rz(psi) · (m, −m·tip)` in the working
    /// frame, given [`Arm::at_site`]'s `(m·R, m·(t − tip))` of the part-to-wrist frame
    /// `(R, t)`: the wrist frame is `work · Rz(psi) · that`, so a solve at another turn
    /// costs one turn of two of the working frame's axes and one product, where
    /// [`Arm::inverse_in_work`] takes three. Agrees with it to 1e-12 rad
    /// (`tests/kinematics.rs`, proptest).
    pub fn inverse_turned(
        &self,
        at: &Turned,
        psi: f64,
        c: Config,
        wrist: f64,
    ) -> Result<Q, NoReach> {
        let w = self.turned_parts(at, psi, c)?;
        Ok(self.angles(&w, c, wrist))
    }

    /// Where the wrist centre `p` (base frame) lies for the closed forms, in the plane of
    /// the upper arm for shoulder configuration `c`; `Err` naming the waist when it lies
    /// inside the shoulder offset, the elbow when beyond the arm's reach.
    fn reach(&self, p: &Vector3<f64>, c: Config) -> Result<Reach, NoReach> {
        let l = &self.links;
        let (d1, a2, a3, d3, d4) = (l[0].d, l[1].a, l[2].a, l[2].d, l[3].d);
        let r2 = p.x * p.x + p.y * p.y;
        if r2 < d3 * d3 || r2 == 0.0 {
            return Err(NoReach {
                joint: 0,
                why: Why::Words(format!(
                    "the wrist centre is {:.3} from the waist axis, inside the shoulder offset {:.3}",
                    r2.sqrt(),
                    d3.abs()
                )),
            });
        }
        let xr = (r2 - d3 * d3).sqrt();
        let x = if c.right { xr } else { -xr };
        let y = p.z - d1;
        let l3sq = a3 * a3 + d4 * d4;
        let rr = (x * x + y * y).sqrt();
        let cpsi = (a2 * a2 - l3sq + x * x + y * y) / (2.0 * a2 * rr);
        if !cpsi.is_finite() || cpsi.abs() > 1.0 + 1e-12 {
            let (lo, hi) = ((a2.abs() - l3sq.sqrt()).abs(), a2.abs() + l3sq.sqrt());
            return Err(NoReach {
                joint: 2,
                why: Why::Words(format!(
                    "the wrist centre is {rr:.3} from the shoulder; the elbow reaches {lo:.3} to {hi:.3}"
                )),
            });
        }
        Ok(Reach { x, y, cpsi })
    }

    /// The closed form's stages before the angles ([`Arm::parts_lanes`]) for the wrist
    /// frame `T05 · Rz(θ6)` (base frame); `Err` as [`Arm::reach`] says.
    fn wrist_parts(&self, tp: &Frame, c: Config) -> Result<WristParts, NoReach> {
        self.checked_parts(&lanes::Frames::of(tp), c)
    }

    /// [`Arm::wrist_parts`] for the part frame turned `psi` about the beam
    /// ([`Arm::at_site`]).
    fn turned_parts(&self, at: &Turned, psi: f64, c: Config) -> Result<WristParts, NoReach> {
        self.checked_parts(&self.turned_lanes(at, &[psi.sin_cos()]), c)
    }

    fn checked_parts(&self, tp: &lanes::Frames<1>, c: Config) -> Result<WristParts, NoReach> {
        let w = self.parts_lanes(tp, c);
        if w.reached[0] {
            return Ok(w.one());
        }
        let p = Vector3::new(tp.t[0][0], tp.t[1][0], tp.t[2][0]);
        Err(self.reach(&p, c).err().unwrap_or(NoReach {
            joint: 2,
            why: Why::Words("the wrist centre is out of reach".into()),
        }))
    }

    /// The closed form from the wrist frame `T05 · Rz(θ6)` (base frame).
    fn inverse_wrist(&self, tp: &Frame, c: Config, wrist: f64) -> Result<Q, NoReach> {
        let w = self.wrist_parts(tp, c)?;
        Ok(self.angles(&w, c, wrist))
    }

    /// The joint values from [`Arm::wrist_parts`] (six `atan2`); at the wrist
    /// singularity θ4 keeps `wrist`.
    fn angles(&self, w: &WristParts, c: Config, wrist: f64) -> Q {
        let l = &self.links;
        let t1 = w.s1.atan2(w.c1);
        let t2 = w.s2.atan2(w.c2);
        let t3 = w.s23.atan2(w.c23) - t2;
        let (t4, b, t6);
        let block = [w.m00, w.m01, w.m10, w.m11, w.m22];
        if w.sb < SINGULAR {
            let wr = wrist + l[3].offset;
            b = if w.m22 > 0.0 { 0.0 } else { PI };
            t4 = wr;
            let (x, y) = zyz_third(block, (wr.cos(), wr.sin()));
            t6 = y.atan2(x);
        } else {
            let bb = w.sb.atan2(w.m22);
            let a4 = w.m12.atan2(w.m02);
            let (x, y) = zyz_third(block, (w.m02, w.m12));
            let a6 = y.atan2(x);
            if c.flip {
                b = -bb;
                t4 = a4 + PI;
                t6 = a6 + PI;
            } else {
                b = bb;
                t4 = a4;
                t6 = a6;
            }
        }
        let th = [t1, t2, t3, t4, -b, t6];
        std::array::from_fn(|k| wrap(th[k] - l[k].offset))
    }

    /// [`Arm::inverse_turned`], and the directions of the six angles
    /// ([`Directions`]; `None` at the wrist singularity), for [`Arm::change_turned`].
    pub fn inverse_turned_with(
        &self,
        at: &Turned,
        psi: f64,
        c: Config,
        wrist: f64,
    ) -> Result<(Q, Option<Directions>), NoReach> {
        self.inverse_turned_sc(at, psi.sin_cos(), c, wrist)
    }

    /// [`Arm::inverse_turned_with`] given the turn's sine and cosine `(sin ψ, cos ψ)`.
    pub fn inverse_turned_sc(
        &self,
        at: &Turned,
        sc: (f64, f64),
        c: Config,
        wrist: f64,
    ) -> Result<(Q, Option<Directions>), NoReach> {
        let w = self.checked_parts(&self.turned_lanes(at, &[sc]), c)?;
        Ok((self.angles(&w, c, wrist), Directions::of(&w, c)))
    }

    /// The joint changes from `q` (joints within the limits, whose angles point along
    /// `dirs`, from [`Arm::inverse_turned_with`] at the same location) to the solution
    /// turned `psi` about the beam (and that solution's directions), each taken on the
    /// turn nearest `q` (what
    /// [`Arm::fit_limits`] takes from a previous location as near as `q`), without the
    /// six `atan2`: each angle's change from `q`'s by an arctangent series of the two
    /// directions' cross over dot product. `None` (solve in full instead) where the
    /// pose is out of reach, at the wrist singularity, where a change's tangent is over `SMALL` (0.05)
    /// or a joint would come within 1e-9 rad of a limit. Agrees with the full solve's
    /// joints minus `q` to 1e-14 rad (`tests/kinematics.rs`, proptest).
    pub fn change_turned(
        &self,
        at: &Turned,
        psi: f64,
        c: Config,
        q: &Q,
        dirs: &Directions,
    ) -> Option<(Q, Directions)> {
        let [one] = self.changes_lanes(at, &[psi.sin_cos()], c, q, dirs);
        one
    }

    /// Damped-least-squares inverse from `seed`: joint values that put the flange at
    /// `flange` (base frame) to 1e-12 (relative to the arm's size), or `None` when 500 steps do not get there.
    pub fn inverse_dls(&self, flange: &Frame, seed: &Q) -> Option<Q> {
        let s = self.scale.max(1e-9);
        let mut q = *seed;
        let mut best = f64::INFINITY;
        for _ in 0..500 {
            let frames = self.chain(&q);
            let f6 = frames[6];
            let ep = (flange.t - f6.t) / s;
            let eo = rot_vec(&(flange.r * f6.r.transpose()));
            let e = Vector6::new(ep.x, ep.y, ep.z, eo.x, eo.y, eo.z);
            let en = e.norm();
            if !en.is_finite() {
                return None;
            }
            if en < 1e-14 || (en < 1e-12 && en >= best) {
                return Some(q.map(wrap));
            }
            best = best.min(en);
            let mut jm = Matrix6::zeros();
            for i in 0..6 {
                let z = frames[i].r.column(2).into_owned();
                let v = z.cross(&(f6.t - frames[i].t)) / s;
                for k in 0..3 {
                    jm[(k, i)] = v[k];
                    jm[(k + 3, i)] = z[k];
                }
            }
            let lam2 = 1e-4 * en.min(1.0);
            let a = jm * jm.transpose() + Matrix6::identity() * lam2;
            let y = a.lu().solve(&e)?;
            let mut dq = jm.transpose() * y;
            // At most a quarter turn a step: far from the answer the linear model lies.
            let big = dq.amax();
            if big > 0.5 {
                dq *= 0.5 / big;
            }
            for i in 0..6 {
                q[i] += dq[i];
            }
        }
        None
    }

    /// The frames `A_1 ⋯ A_i` for i = 0 … 6 (base frame).
    pub fn chain(&self, q: &Q) -> [Frame; 7] {
        let mut out = [Frame::identity(); 7];
        for i in 0..6 {
            out[i + 1] = out[i].mul(&self.links[i].transform(q[i]));
        }
        out
    }

    /// [`Arm::chain`] by `Link::after`, the DH product multiplied out: the same frames
    /// within rounding (proptest), for verification.
    pub fn chain_dh(&self, q: &Q) -> [Frame; 7] {
        let mut out = [Frame::identity(); 7];
        for i in 0..6 {
            out[i + 1] = self.links[i].after(&out[i], q[i]);
        }
        out
    }

    /// The configuration of joint values (closed-form arms only).
    pub fn config_of(&self, q: &Q) -> Option<ConfigOf> {
        if !self.closed_form {
            return None;
        }
        self.config_of_chain(q, &self.chain(q))
    }

    /// [`Arm::config_of`] given `frames = self.chain(q)` or [`Arm::chain_dh`]
    /// (verification has them; θ1's cosine and sine are read from `frames[1]`).
    pub fn config_of_chain(&self, q: &Q, frames: &[Frame; 7]) -> Option<ConfigOf> {
        if !self.closed_form {
            return None;
        }
        let l = &self.links;
        let th: [f64; 6] = std::array::from_fn(|k| q[k] + l[k].offset);
        // The wrist centre: o3 + d4 · z3.
        let p = frames[3].t + frames[3].r.column(2) * l[3].d;
        // `frames[1]` is A_1: its first column (cos θ1, sin θ1, 0).
        let (s1, c1) = (frames[1].r[(1, 0)], frames[1].r[(0, 0)]);
        let x = p.x * c1 + p.y * s1;
        let y = p.z - l[0].d;
        let eps = 1e-9 * self.scale.max(1.0);
        let right = (x.abs() > eps).then_some(x > 0.0);
        let dev = wrap(th[1] - y.atan2(x));
        let up = match right {
            Some(r) if dev.abs() > 1e-9 => Some((dev > 0.0) == r),
            _ => None,
        };
        let t5 = wrap(th[4]);
        let flip = (t5.sin().abs() > 1e-9).then_some(t5 > 0.0);
        Some(ConfigOf { right, up, flip })
    }
}

/// The rotation vector (axis × angle) of a rotation matrix.
pub fn rot_vec(r: &Matrix3<f64>) -> Vector3<f64> {
    let v = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    );
    let s = v.norm() / 2.0;
    let c = (r.trace() - 1.0) / 2.0;
    let angle = s.atan2(c);
    if s > 1e-12 {
        v * (angle / (2.0 * s))
    } else if c > 0.0 {
        v / 2.0
    } else {
        // Half a turn: the axis from the symmetric part.
        let m = (r + Matrix3::identity()) / 2.0;
        let k = (0..3)
            .max_by(|&a, &b| m[(a, a)].total_cmp(&m[(b, b)]))
            .unwrap_or(0);
        let col = m.column(k).into_owned();
        let n = col.norm();
        if n > 0.0 {
            col / n * PI
        } else {
            Vector3::zeros()
        }
    }
}

/// The angle between two rotations, radians (the reference of verification's chord
/// test).
#[cfg(test)]
pub(crate) fn rot_angle(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    rot_vec(&(a * b.transpose())).norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_letters_round_trip() {
        for c in Config::ALL {
            assert_eq!(Config::parse(&c.letters()), Some(c));
        }
        assert_eq!(Config::parse("lu"), None);
        assert_eq!(Config::parse("lrn"), None);
        assert_eq!(
            Config::parse("nul").map(|c| c.letters()),
            Some("lun".into())
        );
    }

    #[test]
    fn wrap_is_half_open() {
        assert_eq!(wrap(PI), PI);
        assert_eq!(wrap(-PI), PI);
        assert!((wrap(3.0 * PI + 0.1) - (-PI + 0.1)).abs() < 1e-12);
    }
}
