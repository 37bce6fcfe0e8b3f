//! A resolved machine: forward and inverse kinematics of a table-table 5-axis chain.
//!
//! Model: three orthogonal linear axes place the head in the *machine frame* (the frame
//! of the rotary table's base: fixed for a moving-column machine, carried by the table
//! axes when they move the table); two rotary axes, each a direction and a point, turn
//! the part about them, the inner one (order 1) riding on the outer one. A part point `p`
//! sits in the machine frame at `T(p) = R₂(θ₂)·(R₁(θ₁)·(p − c₁) + c₁ − c₂) + c₂`; the
//! head's tool point sits at `q = h + Σ sₖ·Xₖ·dₖ` (sₖ = −1 when + moves the table).
//! Forward: tip = T⁻¹(q), axis = (R₂R₁)⁻¹·t. Inverse: solve R₁(θ₁)·v = R₂(−θ₂)·t for the
//! two cones' intersections (two branches), then X from `T(tip)`.

use nalgebra::{Matrix3, Vector3};

use crate::def::{MachineDef, Moves, ParamValue, Units, VecExpr};
use crate::error::KinError;
use crate::trig::{atan2_deg, sin_cos_deg};

/// Below this, a vector is taken as parallel to a rotary axis (singular).
pub(crate) const SINGULAR: f64 = 1e-9;

/// A linear axis, resolved.
#[derive(Debug, Clone)]
pub struct Linear {
    /// Name.
    pub name: String,
    /// Unit direction.
    pub dir: Vector3<f64>,
    /// +1 when + moves the tool, −1 when it moves the table.
    pub sign: f64,
    /// Travel.
    pub limits: (f64, f64),
    /// Output resolution.
    pub resolution: f64,
}

/// A rotary axis, resolved.
#[derive(Debug, Clone)]
pub struct Rotary {
    /// Name.
    pub name: String,
    /// Unit direction of positive rotation.
    pub axis: Vector3<f64>,
    /// A point on the axis.
    pub pivot: Vector3<f64>,
    /// Travel in degrees (`None`: unlimited).
    pub limits: Option<(f64, f64)>,
    /// Continuous (wraps).
    pub continuous: bool,
    /// Output resolution in degrees.
    pub resolution: f64,
}

impl Rotary {
    /// Whether `deg` is within the travel.
    pub fn within(&self, deg: f64) -> bool {
        self.limits
            .is_none_or(|(lo, hi)| deg >= lo - 1e-9 && deg <= hi + 1e-9)
    }
}

/// A head.
#[derive(Debug, Clone)]
pub struct Head {
    /// Name.
    pub name: String,
    /// Offset from the spindle point.
    pub offset: Vector3<f64>,
}

/// Joint values: linear axes then rotary axes, each in file order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Joints {
    /// Linear positions in machine units.
    pub linear: [f64; 3],
    /// Rotary positions in degrees.
    pub rotary: [f64; 2],
}

impl Joints {
    /// All joints, linear first.
    pub fn values(&self) -> [f64; 5] {
        [
            self.linear[0],
            self.linear[1],
            self.linear[2],
            self.rotary[0],
            self.rotary[1],
        ]
    }
}

/// Tool tip and tool axis in the part frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Tool tip.
    pub tip: Vector3<f64>,
    /// Unit vector from the tip into the head.
    pub axis: Vector3<f64>,
}

/// A rotary solution of the orientation alone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orientation {
    /// Angles in degrees, file order, in (−180, 180] (or the kept value when singular).
    pub degrees: [f64; 2],
    /// (sin, cos) of each angle.
    pub sin_cos: [(f64, f64); 2],
    /// +1 or −1 for the two branches, 0 where they coincide.
    pub branch: i8,
    /// The tool axis is parallel to a rotary axis.
    pub singular: bool,
}

/// A rotary orientation placed against the limits (see [`Machine::orientations`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placed {
    /// Angles in file order.
    pub rotary: [f64; 2],
    /// Within the rotary limits.
    pub within_limits: bool,
    /// Branch (+1/−1, 0 where they coincide).
    pub branch: i8,
    /// A rotary axis kept its `near` value.
    pub singular: bool,
}

/// One inverse-kinematics solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solution {
    /// The joints.
    pub joints: Joints,
    /// Every joint within its travel.
    pub within_limits: bool,
    /// Which of the two orientation branches (+1, −1; 0 where they coincide).
    pub branch: i8,
    /// The tool axis is parallel to a rotary axis; that axis kept its previous value.
    pub singular: bool,
}

/// Up to two solutions, best first, without allocating.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solutions {
    pub(crate) sols: [Solution; 2],
    pub(crate) n: usize,
}

impl Solutions {
    /// No solution (filled in by the inverse kinematics).
    pub(crate) const EMPTY: Solutions = Solutions {
        sols: [Solution {
            joints: Joints {
                linear: [0.0; 3],
                rotary: [0.0; 2],
            },
            within_limits: false,
            branch: 0,
            singular: false,
        }; 2],
        n: 0,
    };

    /// The solutions, best first.
    pub fn as_slice(&self) -> &[Solution] {
        &self.sols[..self.n]
    }
}

/// The chooser's pick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Choice {
    /// The chosen solution.
    pub solution: Solution,
    /// The previous branch had no solution within limits: the branch flips here, so
    /// the tool must retract and re-approach.
    pub branch_flip: bool,
}

/// How a rotary axis turns points: about a coordinate axis (±X, ±Y, ±Z: six products,
/// and the coordinate along the axis untouched, exactly) or about a general direction
/// (Rodrigues' formula).
#[derive(Debug, Clone, Copy)]
pub(crate) enum Turn {
    X(f64),
    Y(f64),
    Z(f64),
    General,
}

impl Turn {
    fn of(u: &Vector3<f64>) -> Turn {
        let pick = |i: usize| {
            let others_zero = (0..3).all(|j| j == i || u[j] == 0.0);
            (others_zero && u[i].abs() == 1.0).then_some(u[i])
        };
        if let Some(sg) = pick(0) {
            Turn::X(sg)
        } else if let Some(sg) = pick(1) {
            Turn::Y(sg)
        } else if let Some(sg) = pick(2) {
            Turn::Z(sg)
        } else {
            Turn::General
        }
    }

    /// Rotate `p` about `u` (this turn's axis) by the angle with sine `s`, cosine `c`.
    #[inline(always)]
    fn apply(self, u: &Vector3<f64>, s: f64, c: f64, p: &Vector3<f64>) -> Vector3<f64> {
        match self {
            Turn::X(sg) => {
                let s = s * sg;
                Vector3::new(p.x, c * p.y - s * p.z, s * p.y + c * p.z)
            }
            Turn::Y(sg) => {
                let s = s * sg;
                Vector3::new(c * p.x + s * p.z, p.y, c * p.z - s * p.x)
            }
            Turn::Z(sg) => {
                let s = s * sg;
                Vector3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z)
            }
            Turn::General => rot(u, s, c, p),
        }
    }
}

/// Constants of the orientation solution, fixed per machine (see [`Machine::orient`]).
#[derive(Debug, Clone)]
pub(crate) struct Chain {
    /// How the inner and outer axes turn points.
    pub(crate) inner_turn: Turn,
    pub(crate) outer_turn: Turn,
    /// u₁·u₂.
    pub(crate) k: f64,
    /// 1 / (1 − k²), 1 − k² = |u₁ × u₂|².
    pub(crate) inv_det: f64,
    /// u₂·t.
    pub(crate) b: f64,
    /// (u₂ − k·u₁)/|…|: with `n_hat` an orthonormal basis, positive about u₁, of the
    /// plane normal to u₁.
    pub(crate) e1: Vector3<f64>,
    /// (u₁ × u₂)/|…|.
    pub(crate) n_hat: Vector3<f64>,
    /// ψ, the turn about u₂ from t's part normal to u₂ to (u₁ − k·u₂): degrees and
    /// (sin, cos).
    pub(crate) psi: f64,
    pub(crate) psi_sc: (f64, f64),
    /// The tool axis is parallel to the outer axis (always singular there).
    pub(crate) outer_singular: bool,
}

/// An affine map `p ↦ A·p + b` (see [`Machine::joints_map`], [`Machine::tip_map`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine {
    /// Linear part.
    pub a: Matrix3<f64>,
    /// Offset.
    pub b: Vector3<f64>,
}

impl Affine {
    /// The image of `p`.
    #[inline(always)]
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.a * p + self.b
    }

    /// The image of `p` as an array.
    #[inline]
    pub fn apply3(&self, p: &[f64; 3]) -> [f64; 3] {
        let q = self.apply(&Vector3::new(p[0], p[1], p[2]));
        [q.x, q.y, q.z]
    }
}

/// The scalars of the orientation solve (see [`Machine::orient`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct OrientSetup {
    pub(crate) alpha: f64,
    pub(crate) beta: f64,
    pub(crate) g2: f64,
    pub(crate) ve: f64,
    pub(crate) vn: f64,
    pub(crate) rv2: f64,
}

/// A machine ready for kinematics. Build it with [`Machine::new`] (or
/// [`Machine::builtin`]); the fields are public for reading, and changing them afterwards
/// leaves constants derived from them stale: build a new machine instead.
#[derive(Debug, Clone)]
pub struct Machine {
    /// Name.
    pub name: String,
    /// Units.
    pub units: Units,
    /// Linear axes in file order.
    pub linear: [Linear; 3],
    /// Rotary axes in file order.
    pub rotary: [Rotary; 2],
    /// Index in `rotary` of the inner axis (order 1).
    pub inner: usize,
    /// Index in `rotary` of the outer axis (order 2).
    pub outer: usize,
    /// Heads.
    pub heads: Vec<Head>,
    /// Unit vector from tip into head, machine frame.
    pub tool_axis: Vector3<f64>,
    /// The definition it was built from (with any `--set` applied).
    pub def: MachineDef,
    pub(crate) chain: Chain,
}

fn v3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

/// Rotate `p` about the unit axis `u` by the angle with sine `s` and cosine `c`.
#[inline(always)]
fn rot(u: &Vector3<f64>, s: f64, c: f64, p: &Vector3<f64>) -> Vector3<f64> {
    p * c + u.cross(p) * s + u * (u.dot(p) * (1.0 - c))
}

/// Wrap degrees to (−180, 180].
#[inline(always)]
pub(crate) fn wrap180(d: f64) -> f64 {
    // One turn either way covers differences of two wrapped angles, without a branch.
    if d > -540.0 && d <= 540.0 {
        let up = f64::from(u8::from(d <= -180.0));
        let down = f64::from(u8::from(d > 180.0));
        return d + 360.0 * (up - down);
    }
    // `d - 360·round(d/360)` instead of `%`, which is a slow libm call.
    let mut x = d - 360.0 * (d / 360.0).round();
    if x > 180.0 {
        x -= 360.0;
    } else if x <= -180.0 {
        x += 360.0;
    }
    x
}

impl Machine {
    /// Build from a definition, applying parameter overrides (`--set`).
    pub fn new(mut def: MachineDef, overrides: &[(String, ParamValue)]) -> Result<Self, KinError> {
        // Values written into programs as text (a no-op for a file already read).
        def.check()?;
        let bad = |what: String| KinError::InvalidMachine {
            machine: def.name.clone(),
            what,
        };
        let known = if def.parameters.is_empty() {
            "none".to_string()
        } else {
            def.parameters
                .keys()
                .cloned()
                .collect::<Vec<_>>()
                .join(", ")
        };
        for (name, value) in overrides {
            let slot = def
                .parameters
                .get_mut(name)
                .ok_or_else(|| KinError::Parameter {
                    name: name.clone(),
                    why: format!("this machine has no such parameter (it has {known})"),
                })?;
            match (&*slot, value) {
                (ParamValue::Scalar(_), ParamValue::Scalar(_))
                | (ParamValue::Vector(_), ParamValue::Vector(_)) => *slot = *value,
                (ParamValue::Scalar(_), _) => {
                    return Err(KinError::Parameter {
                        name: name.clone(),
                        why: "is a scalar: give one value".into(),
                    })
                }
                (ParamValue::Vector(_), _) => {
                    return Err(KinError::Parameter {
                        name: name.clone(),
                        why: "is a vector: give x,y,z".into(),
                    })
                }
            }
        }
        for (name, v) in &def.parameters {
            let ok = match v {
                ParamValue::Scalar(x) => x.is_finite(),
                ParamValue::Vector(a) => a.iter().all(|x| x.is_finite()),
            };
            if !ok {
                return Err(KinError::NotFinite(format!("parameter {name}")));
            }
        }
        let params = def.parameters.clone();
        let resolve = |e: &VecExpr, what: &str| -> Result<Vector3<f64>, KinError> {
            match e {
                VecExpr::Literal(a) => Ok(v3(*a)),
                VecExpr::Scaled { param, scale } => match params.get(param) {
                    Some(ParamValue::Vector(a)) => Ok(v3(*a) * *scale),
                    Some(ParamValue::Scalar(_)) => Err(KinError::Parameter {
                        name: param.clone(),
                        why: format!(
                            "{what} uses it as a vector, but it is a scalar (use `along`)"
                        ),
                    }),
                    None => Err(KinError::Parameter {
                        name: param.clone(),
                        why: format!(
                            "{what} refers to it, but it is not defined under [parameters]"
                        ),
                    }),
                },
                VecExpr::Along { param, along } => match params.get(param) {
                    Some(ParamValue::Scalar(x)) => Ok(v3(*along) * *x),
                    Some(ParamValue::Vector(_)) => Err(KinError::Parameter {
                        name: param.clone(),
                        why: format!(
                            "{what} uses it as a scalar, but it is a vector (use `scale`)"
                        ),
                    }),
                    None => Err(KinError::Parameter {
                        name: param.clone(),
                        why: format!(
                            "{what} refers to it, but it is not defined under [parameters]"
                        ),
                    }),
                },
            }
        };
        let unit = |a: [f64; 3], what: String| -> Result<Vector3<f64>, KinError> {
            let v = v3(a);
            if !v.iter().all(|x| x.is_finite()) {
                return Err(KinError::NotFinite(what));
            }
            let n = v.norm();
            if n < 1e-12 {
                return Err(KinError::InvalidMachine {
                    machine: String::new(),
                    what: format!("{what} has zero length"),
                });
            }
            if (n - 1.0).abs() > 1e-9 {
                return Err(KinError::InvalidMachine {
                    machine: String::new(),
                    what: format!("{what} is not a unit vector (length {n})"),
                });
            }
            Ok(v)
        };
        let named = |e: KinError| match e {
            KinError::InvalidMachine { what, .. } => KinError::InvalidMachine {
                machine: def.name.clone(),
                what,
            },
            other => other,
        };
        if def.linear.len() != 3 {
            return Err(bad(format!(
                "has {} linear axes; this model needs exactly 3",
                def.linear.len()
            )));
        }
        if def.rotary.len() != 2 {
            return Err(bad(format!(
                "has {} rotary axes; this model needs exactly 2",
                def.rotary.len()
            )));
        }
        let mut names: Vec<&str> = Vec::new();
        for n in def
            .linear
            .iter()
            .map(|l| l.name.as_str())
            .chain(def.rotary.iter().map(|r| r.name.as_str()))
        {
            if n.is_empty() || names.contains(&n) {
                return Err(bad(format!("axis name `{n}` is empty or used twice")));
            }
            names.push(n);
        }
        let positive_resolution = |kind: &str, name: &str, res: f64| {
            if res.is_finite() && res > 0.0 {
                Ok(())
            } else {
                Err(bad(format!(
                    "{kind} axis {name} resolution must be positive"
                )))
            }
        };
        let mut linear = Vec::with_capacity(3);
        for l in &def.linear {
            let dir =
                unit(l.direction, format!("linear axis {} direction", l.name)).map_err(named)?;
            if !(l.limits[0].is_finite() && l.limits[1].is_finite() && l.limits[0] < l.limits[1]) {
                return Err(bad(format!(
                    "linear axis {} limits must be finite with min < max",
                    l.name
                )));
            }
            positive_resolution("linear", &l.name, l.resolution)?;
            linear.push(Linear {
                name: l.name.clone(),
                dir,
                sign: match l.moves {
                    Moves::Tool => 1.0,
                    Moves::Table => -1.0,
                },
                limits: (l.limits[0], l.limits[1]),
                resolution: l.resolution,
            });
        }
        for i in 0..3 {
            for j in i + 1..3 {
                if linear[i].dir.dot(&linear[j].dir).abs() > 1e-9 {
                    return Err(bad(format!(
                        "linear axes {} and {} are not orthogonal",
                        linear[i].name, linear[j].name
                    )));
                }
            }
        }
        let mut rotary = Vec::with_capacity(2);
        for r in &def.rotary {
            let axis = unit(r.axis, format!("rotary axis {} axis", r.name)).map_err(named)?;
            let pivot = resolve(&r.pivot, &format!("rotary axis {} pivot", r.name))?;
            if !pivot.iter().all(|x| x.is_finite()) {
                return Err(KinError::NotFinite(format!("rotary axis {} pivot", r.name)));
            }
            if let Some(v) = pivot.iter().find(|x| x.abs() > 1e9) {
                return Err(bad(format!(
                    "rotary axis {} pivot has the component {v:e}, beyond ±1e9 of the machine's unit (check its `scale`)",
                    r.name
                )));
            }
            let limits = match r.limits {
                Some([lo, hi]) if lo.is_finite() && hi.is_finite() && lo < hi => Some((lo, hi)),
                Some(_) => {
                    return Err(bad(format!(
                        "rotary axis {} limits must be finite with min < max",
                        r.name
                    )))
                }
                None if r.continuous => None,
                None => {
                    return Err(bad(format!(
                        "rotary axis {} needs limits unless it is continuous",
                        r.name
                    )))
                }
            };
            positive_resolution("rotary", &r.name, r.resolution)?;
            rotary.push(Rotary {
                name: r.name.clone(),
                axis,
                pivot,
                limits,
                continuous: r.continuous,
                resolution: r.resolution,
            });
        }
        let inner = def
            .rotary
            .iter()
            .position(|r| r.order == 1)
            .ok_or_else(|| {
                bad("no rotary axis has order = 1 (the one carrying the workpiece)".into())
            })?;
        let outer = def
            .rotary
            .iter()
            .position(|r| r.order == 2)
            .ok_or_else(|| bad("no rotary axis has order = 2".into()))?;
        if rotary[0].axis.cross(&rotary[1].axis).norm() < 1e-6 {
            return Err(bad("the two rotary axes are parallel".into()));
        }
        let tool_axis = unit(def.tool_axis, "tool_axis".into()).map_err(named)?;
        if def.heads.is_empty() {
            return Err(bad("has no [[head]]".into()));
        }
        let mut heads = Vec::new();
        for h in &def.heads {
            if heads.iter().any(|x: &Head| x.name == h.name) {
                return Err(bad(format!("head `{}` is defined twice", h.name)));
            }
            let offset = resolve(&h.offset, &format!("head {} offset", h.name))?;
            if let Some(v) = offset.iter().find(|x| !x.is_finite() || x.abs() > 1e9) {
                return Err(bad(format!(
                    "head `{}` offset has a component {}, beyond ±1e9 of the machine's unit (check its `scale`)",
                    h.name,
                    if v.is_finite() { format!("{v:e}") } else { "that overflows".into() }
                )));
            }
            heads.push(Head {
                name: h.name.clone(),
                offset,
            });
        }
        let [l0, l1, l2]: [Linear; 3] = linear
            .try_into()
            .map_err(|_| bad("needs 3 linear axes".into()))?;
        let [r0, r1]: [Rotary; 2] = rotary
            .try_into()
            .map_err(|_| bad("needs 2 rotary axes".into()))?;
        let (u1, u2) = ([&r0, &r1][inner].axis, [&r0, &r1][outer].axis);
        let k = u1.dot(&u2);
        let n = u1.cross(&u2);
        let b = u2.dot(&tool_axis);
        let t_perp = tool_axis - u2 * b;
        let e2 = (u1 - u2 * k).normalize();
        let (psi_s, psi_c) = (u2.dot(&t_perp.cross(&e2)), t_perp.dot(&e2));
        let psi_r = (psi_s * psi_s + psi_c * psi_c).sqrt();
        let chain = Chain {
            inner_turn: Turn::of(&u1),
            outer_turn: Turn::of(&u2),
            k,
            inv_det: 1.0 / (1.0 - k * k),
            b,
            e1: (u2 - u1 * k).normalize(),
            n_hat: n.normalize(),
            psi: psi_s.atan2(psi_c).to_degrees(),
            psi_sc: if psi_r > 0.0 {
                (psi_s / psi_r, psi_c / psi_r)
            } else {
                (0.0, 1.0)
            },
            outer_singular: t_perp.norm() < SINGULAR,
        };
        Ok(Machine {
            name: def.name.clone(),
            units: def.units,
            linear: [l0, l1, l2],
            rotary: [r0, r1],
            inner,
            outer,
            heads,
            tool_axis,
            def,
            chain,
        })
    }

    /// A built-in machine with overrides.
    pub fn builtin(name: &str, overrides: &[(String, ParamValue)]) -> Result<Self, KinError> {
        let text = crate::def::builtin_text(name).ok_or_else(|| KinError::MachineFile {
            file: name.to_string(),
            line: 0,
            column: 0,
            message: format!("no built-in machine named {name}"),
            text: String::new(),
        })?;
        Machine::new(
            MachineDef::from_toml(text, &format!("<built-in {name}>"))?,
            overrides,
        )
    }

    /// The retract height is the larger of `clearance_z` and the highest point of the
    /// work at that index plus this margin (machine units): `process.safe_margin`, or
    /// 0.2 in / 5 mm.
    pub fn safe_margin(&self) -> f64 {
        self.def.process.safe_margin(self.units)
    }

    /// Radius of the head, the cylinder along the tool axis used for collision checks
    /// (machine units): `process.head_radius`, or 1 in / 25 mm.
    pub fn head_radius(&self) -> f64 {
        self.def.process.head_radius(self.units)
    }

    /// Length of the head, the cylinder along the tool axis (from the tool point into the
    /// head) used for collision checks (machine units): `process.head_length`, or
    /// 6 in / 150 mm.
    pub fn head_length(&self) -> f64 {
        self.def.process.head_length(self.units)
    }

    /// Axis names: linear then rotary, file order.
    pub fn axis_names(&self) -> [&str; 5] {
        [
            &self.linear[0].name,
            &self.linear[1].name,
            &self.linear[2].name,
            &self.rotary[0].name,
            &self.rotary[1].name,
        ]
    }

    /// Index of a head by name.
    pub fn head(&self, name: &str) -> Result<usize, KinError> {
        self.heads
            .iter()
            .position(|h| h.name.eq_ignore_ascii_case(name))
            .ok_or_else(|| KinError::UnknownHead {
                name: name.to_string(),
                known: self
                    .heads
                    .iter()
                    .map(|h| h.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// Check every joint against its travel.
    pub fn check_limits(&self, j: &Joints) -> Result<(), KinError> {
        for (l, &v) in self.linear.iter().zip(&j.linear) {
            if !v.is_finite() {
                return Err(KinError::NotFinite(format!("axis {}", l.name)));
            }
            if v < l.limits.0 - 1e-9 || v > l.limits.1 + 1e-9 {
                return Err(KinError::JointOutOfLimit {
                    axis: l.name.clone(),
                    value: v,
                    lo: l.limits.0,
                    hi: l.limits.1,
                });
            }
        }
        for (r, &v) in self.rotary.iter().zip(&j.rotary) {
            if !v.is_finite() {
                return Err(KinError::NotFinite(format!("axis {}", r.name)));
            }
            if let Some((lo, hi)) = r.limits {
                if !r.within(v) {
                    return Err(KinError::JointOutOfLimit {
                        axis: r.name.clone(),
                        value: v,
                        lo,
                        hi,
                    });
                }
            }
        }
        Ok(())
    }

    #[inline(always)]
    fn linear_within(&self, x: &[f64; 3]) -> bool {
        self.linear
            .iter()
            .zip(x)
            .all(|(l, &v)| v >= l.limits.0 - 1e-9 && v <= l.limits.1 + 1e-9)
    }

    /// Part → machine: where the part point `p` sits with the table at `rotary`.
    pub fn part_to_machine(&self, rotary: &[f64; 2], p: &Vector3<f64>) -> Vector3<f64> {
        self.part_to_machine_sc(&[sin_cos_deg(rotary[0]), sin_cos_deg(rotary[1])], p)
    }

    /// [`Machine::part_to_machine`] with each rotary given as (sin, cos).
    #[inline(always)]
    pub fn part_to_machine_sc(&self, sc: &[(f64, f64); 2], p: &Vector3<f64>) -> Vector3<f64> {
        let (ri, ro) = (&self.rotary[self.inner], &self.rotary[self.outer]);
        let (si, ci) = sc[self.inner];
        let (so, co) = sc[self.outer];
        let a = self
            .chain
            .inner_turn
            .apply(&ri.axis, si, ci, &(p - ri.pivot))
            + ri.pivot;
        self.chain
            .outer_turn
            .apply(&ro.axis, so, co, &(a - ro.pivot))
            + ro.pivot
    }

    /// Machine → part with each rotary given as (sin, cos) of the *inverse* turn
    /// (of −θ): the outer axis is undone first, then the inner.
    pub fn machine_to_part_sc(
        &self,
        sc_inverse: &[(f64, f64); 2],
        q: &Vector3<f64>,
    ) -> Vector3<f64> {
        let (ri, ro) = (&self.rotary[self.inner], &self.rotary[self.outer]);
        let (si, ci) = sc_inverse[self.inner];
        let (so, co) = sc_inverse[self.outer];
        let a = self
            .chain
            .outer_turn
            .apply(&ro.axis, so, co, &(q - ro.pivot))
            + ro.pivot;
        self.chain
            .inner_turn
            .apply(&ri.axis, si, ci, &(a - ri.pivot))
            + ri.pivot
    }

    /// Machine → part: the inverse of [`Machine::part_to_machine`].
    pub fn machine_to_part(&self, rotary: &[f64; 2], q: &Vector3<f64>) -> Vector3<f64> {
        let inverse = |deg: f64| {
            let (s, c) = sin_cos_deg(deg);
            (-s, c)
        };
        self.machine_to_part_sc(&[inverse(rotary[0]), inverse(rotary[1])], q)
    }

    /// Turn the direction `d` by both rotaries, given as (sin, cos): inner then outer
    /// (part → machine), or outer then inner when `outer_first` (machine → part, with
    /// the inverse turns' sines).
    fn turn_direction(
        &self,
        sc: &[(f64, f64); 2],
        d: &Vector3<f64>,
        outer_first: bool,
    ) -> Vector3<f64> {
        let by = |turn: Turn, i: usize, v: &Vector3<f64>| {
            turn.apply(&self.rotary[i].axis, sc[i].0, sc[i].1, v)
        };
        let inner = |v: &Vector3<f64>| by(self.chain.inner_turn, self.inner, v);
        let outer = |v: &Vector3<f64>| by(self.chain.outer_turn, self.outer, v);
        if outer_first {
            inner(&outer(d))
        } else {
            outer(&inner(d))
        }
    }

    /// Joints for part points with the table fixed at the rotary position whose
    /// (sin, cos) are `sc`: the affine map `p ↦ A·p + b` equal to
    /// `linear_for(part_to_machine_sc(sc, p), head)` (to rounding), for posting many
    /// points at one index.
    pub fn joints_map(&self, sc: &[(f64, f64); 2], head: usize) -> Affine {
        // The rotation part turns directions (no pivots); the offset is where the part
        // origin goes.
        let turn = |d: &Vector3<f64>| self.turn_direction(sc, d, false);
        let r = Matrix3::from_columns(&[
            turn(&Vector3::x()),
            turn(&Vector3::y()),
            turn(&Vector3::z()),
        ]);
        let sd = Matrix3::from_rows(&[
            (self.linear[0].dir * self.linear[0].sign).transpose(),
            (self.linear[1].dir * self.linear[1].sign).transpose(),
            (self.linear[2].dir * self.linear[2].sign).transpose(),
        ]);
        let origin = self.part_to_machine_sc(sc, &Vector3::zeros());
        Affine {
            a: sd * r,
            b: sd * (origin - self.heads[head].offset),
        }
    }

    /// Part-frame tool tips for joints with the table fixed at the rotary position
    /// whose *inverse* turns have (sin, cos) `sc_inverse` (as for
    /// [`Machine::machine_to_part_sc`]): the affine map `x ↦ A·x + b` equal to
    /// `machine_to_part_sc(sc_inverse, head_point(x, head))` (to rounding).
    pub fn tip_map(&self, sc_inverse: &[(f64, f64); 2], head: usize) -> Affine {
        let turn = |d: &Vector3<f64>| self.turn_direction(sc_inverse, d, true);
        let cols: [Vector3<f64>; 3] =
            std::array::from_fn(|k| turn(&(self.linear[k].dir * self.linear[k].sign)));
        Affine {
            a: Matrix3::from_columns(&cols),
            b: self.machine_to_part_sc(sc_inverse, &self.heads[head].offset),
        }
    }

    /// The head's tool point in the machine frame for linear positions `x`.
    #[inline(always)]
    pub fn head_point(&self, x: &[f64; 3], head: usize) -> Vector3<f64> {
        let mut q = self.heads[head].offset;
        for (l, &v) in self.linear.iter().zip(x) {
            q += l.dir * (l.sign * v);
        }
        q
    }

    /// Linear positions that put the head's tool point at machine point `q`.
    #[inline(always)]
    pub fn linear_for(&self, q: &Vector3<f64>, head: usize) -> [f64; 3] {
        let d = q - self.heads[head].offset;
        [
            self.linear[0].sign * d.dot(&self.linear[0].dir),
            self.linear[1].sign * d.dot(&self.linear[1].dir),
            self.linear[2].sign * d.dot(&self.linear[2].dir),
        ]
    }

    /// Forward kinematics: joints and head → tool tip and tool axis in the part frame.
    #[inline]
    pub fn forward(&self, j: &Joints, head: usize) -> Pose {
        self.forward_sc(
            j,
            head,
            sin_cos_deg(j.rotary[self.inner]),
            sin_cos_deg(j.rotary[self.outer]),
        )
    }

    /// [`Machine::forward`] with the inner and outer rotaries' (sin, cos) given.
    #[inline(always)]
    pub(crate) fn forward_sc(
        &self,
        j: &Joints,
        head: usize,
        (si, ci): (f64, f64),
        (so, co): (f64, f64),
    ) -> Pose {
        let (ri, ro) = (&self.rotary[self.inner], &self.rotary[self.outer]);
        let q = self.head_point(&j.linear, head);
        let a = self
            .chain
            .outer_turn
            .apply(&ro.axis, -so, co, &(q - ro.pivot))
            + ro.pivot;
        let tip = self
            .chain
            .inner_turn
            .apply(&ri.axis, -si, ci, &(a - ri.pivot))
            + ri.pivot;
        let t = self
            .chain
            .outer_turn
            .apply(&ro.axis, -so, co, &self.tool_axis);
        let axis = self.chain.inner_turn.apply(&ri.axis, -si, ci, &t);
        Pose { tip, axis }
    }

    /// Rotary angles (degrees, in file order) that turn the part-frame tool axis `v`
    /// (unit) to the machine's tool axis: up to two branches. `near` fills a singular
    /// axis. Returns `None` when no rotation of these axes reaches `v`.
    ///
    /// With u₁, u₂ the inner and outer axes, t the tool axis and w = R₁(θ₁)·v =
    /// R₂(−θ₂)·t: u₁·w = u₁·v = a and u₂·w = u₂·t = b give w = α·u₁ + β·u₂ ± g·n
    /// (n = u₁ × u₂, k = u₁·u₂, α = (a − k·b)/(1 − k²), β = (b − k·a)/(1 − k²),
    /// g² = (1 − |α·u₁ + β·u₂|²)/(1 − k²)), the two branches. Normal to u₁, w is
    /// β·e₁ ± g·n̂ in the orthonormal basis e₁ ∝ u₂ − k·u₁, n̂ ∝ n (positive about u₁),
    /// so θ₁ = atan2(±g, β) − atan2(v·n̂, v·e₁). Normal to u₂, w is α·e₂ ± g·n̂ with
    /// e₂ ∝ u₁ − k·u₂ (a basis negative about u₂), so θ₂ = atan2(±g, α) − ψ with ψ the
    /// machine's fixed turn from t to e₂. Three arctangents for both branches.
    #[inline(always)]
    pub fn orient(&self, v: &Vector3<f64>, near: &[f64; 2]) -> Option<([Orientation; 2], usize)> {
        let ch = &self.chain;
        let st = self.orient_setup(v);
        if st.g2 < -1e-12 {
            return None;
        }
        let g = st.g2.max(0.0).sqrt();
        // Singular for the inner axis: the tool axis along it, or so nearly that g and β
        // both vanish while v still leans off it by a rounding's worth (g² is 1 minus
        // a number that rounds to 1): the inner angle's formula would divide 0 by 0 there
        // (found posting a sphere's perimeters: NaN linear axes at a tilt of 7.8e-9).
        let s1 = st.rv2 < SINGULAR * SINGULAR || (g * g + st.beta * st.beta) * st.rv2 == 0.0;
        let s2 = ch.outer_singular;
        let count = if g < 1e-12 { 1 } else { 2 };
        let mut out = [Orientation {
            degrees: [0.0; 2],
            sin_cos: [(0.0, 1.0); 2],
            branch: 0,
            singular: s1 || s2,
        }; 2];
        // Inner: θ₁ = δ₁ − φ, δ₁ = atan2(±g, β), φ = atan2(v·n̂, v·e₁).
        let (deg, sc) = if s1 {
            let sc = sin_cos_deg(near[self.inner]);
            ([near[self.inner]; 2], [sc; 2])
        } else {
            self.inner_regular(&st, g)
        };
        for (i, o) in out.iter_mut().enumerate() {
            o.degrees[self.inner] = deg[i];
            o.sin_cos[self.inner] = sc[i];
        }
        // Outer: θ₂ = δ₂ − ψ, δ₂ = atan2(±g, α).
        let (deg, sc) = if s2 {
            let sc = sin_cos_deg(near[self.outer]);
            ([near[self.outer]; 2], [sc; 2])
        } else {
            self.outer_regular(st.alpha, g)
        };
        for (i, o) in out.iter_mut().enumerate() {
            o.degrees[self.outer] = deg[i];
            o.sin_cos[self.outer] = sc[i];
        }
        if count == 2 {
            out[0].branch = 1;
            out[1].branch = -1;
        }
        Some((out, count))
    }

    /// The tool axis is parallel to the outer rotary axis (every orientation is
    /// singular there).
    pub(crate) fn outer_singular(&self) -> bool {
        self.chain.outer_singular
    }

    /// The scalars of [`Machine::orient`] for the unit axis `v`.
    #[inline(always)]
    pub(crate) fn orient_setup(&self, v: &Vector3<f64>) -> OrientSetup {
        let ch = &self.chain;
        let u1 = &self.rotary[self.inner].axis;
        let a = u1.dot(v);
        let (k, b) = (ch.k, ch.b);
        let alpha = (a - k * b) * ch.inv_det;
        let beta = (b - k * a) * ch.inv_det;
        let base2 = alpha * alpha + beta * beta + 2.0 * alpha * beta * k;
        let g2 = (1.0 - base2) * ch.inv_det;
        // v's part normal to u₁, in the (e₁, n̂) basis: its length is |v − (u₁·v)·u₁|.
        let (ve, vn) = (ch.e1.dot(v), ch.n_hat.dot(v));
        OrientSetup {
            alpha,
            beta,
            g2,
            ve,
            vn,
            rv2: ve * ve + vn * vn,
        }
    }

    /// The inner angle of both branches (degrees, (sin, cos)), away from its singularity.
    #[inline(always)]
    pub(crate) fn inner_regular(&self, st: &OrientSetup, g: f64) -> ([f64; 2], [(f64, f64); 2]) {
        self.inner_regular_with(st, g, atan2_deg)
    }

    /// [`Machine::inner_regular`] with the arctangent given (the batch kinematics pass
    /// the branch-free one where its input is known regular).
    #[inline(always)]
    pub(crate) fn inner_regular_with(
        &self,
        st: &OrientSetup,
        g: f64,
        atan2_deg: impl Fn(f64, f64) -> f64,
    ) -> ([f64; 2], [(f64, f64); 2]) {
        let (beta, ve, vn) = (st.beta, st.ve, st.vn);
        let phi = atan2_deg(vn, ve);
        // β is exactly 0 on the usual tables (inner axis and tool axis both normal
        // to the outer one: FADAL, NRC, A/C trunnions), where δ₁ is a right angle.
        let d1 = if beta == 0.0 && g > 0.0 {
            90.0
        } else {
            atan2_deg(g, beta)
        };
        // sin, cos of (±δ₁ − φ) from the unnormalised pairs, one square root and one
        // division for both (divisions and roots share one slow unit).
        let inv = 1.0 / ((g * g + beta * beta) * st.rv2).sqrt();
        let (sp, cp) = (vn * inv, ve * inv);
        let branch = |sign: f64| {
            let sd = sign * g;
            (
                wrap180(sign * d1 - phi),
                (sd * cp - beta * sp, beta * cp + sd * sp),
            )
        };
        let (p, m) = (branch(1.0), branch(-1.0));
        ([p.0, m.0], [p.1, m.1])
    }

    /// The outer angle of both branches (degrees, (sin, cos)), away from its singularity.
    #[inline(always)]
    pub(crate) fn outer_regular(&self, alpha: f64, g: f64) -> ([f64; 2], [(f64, f64); 2]) {
        self.outer_regular_with(alpha, g, atan2_deg)
    }

    /// [`Machine::outer_regular`] with the arctangent given (see
    /// [`Machine::inner_regular_with`]).
    #[inline(always)]
    pub(crate) fn outer_regular_with(
        &self,
        alpha: f64,
        g: f64,
        atan2_deg: impl Fn(f64, f64) -> f64,
    ) -> ([f64; 2], [(f64, f64); 2]) {
        let ch = &self.chain;
        let d2 = atan2_deg(g, alpha);
        let inv = 1.0 / (g * g + alpha * alpha).sqrt();
        let (sd, cd) = (g * inv, alpha * inv);
        let (sp, cp) = ch.psi_sc;
        let branch = |sign: f64| {
            let sd = sign * sd;
            (
                wrap180(sign * d2 - ch.psi),
                (sd * cp - cd * sp, cd * cp + sd * sp),
            )
        };
        let (p, m) = (branch(1.0), branch(-1.0));
        ([p.0, m.0], [p.1, m.1])
    }

    /// The representative of `deg` (mod 360) nearest `near` that lies within the axis'
    /// travel, or the nearest one when none does.
    #[inline(always)]
    fn place(&self, axis: usize, deg: f64, near: f64) -> (f64, bool) {
        let r = &self.rotary[axis];
        let base = near + wrap180(deg - near);
        match r.limits {
            None => (base, true),
            // The representative nearest `near` is the answer when it is within travel
            // (the others are 180° or more further away; an exact tie goes the long way).
            Some(_) if r.within(base) && (base - near).abs() < 180.0 => (base, true),
            Some(_) => {
                let mut best: Option<f64> = None;
                for k in -2..=2 {
                    let c = base + 360.0 * f64::from(k);
                    if r.within(c) && best.is_none_or(|b| (c - near).abs() < (b - near).abs()) {
                        best = Some(c);
                    }
                }
                match best {
                    Some(b) => (b, true),
                    None => (base, false),
                }
            }
        }
    }

    /// The rotary positions that turn the part-frame direction `v` to the tool axis
    /// (levelling: `v` a surface's outward normal), placed nearest `near` and within
    /// limits where possible: (angles in file order, within limits, branch), best first.
    pub fn orientations(&self, v: &Vector3<f64>, near: &[f64; 2]) -> Result<Vec<Placed>, KinError> {
        if !v.iter().all(|x| x.is_finite()) {
            return Err(KinError::NotFinite("the direction".into()));
        }
        // A length that overflows (components near 1e300) is scaled down first: the
        // direction is what counts.
        let v = if v.norm().is_finite() {
            *v
        } else {
            v / v.amax()
        };
        if v.norm() < 1e-12 {
            return Err(KinError::ZeroToolAxis);
        }
        let v = v.normalize();
        let (raw, count) = self.orient(&v, near).ok_or_else(|| KinError::Unreachable {
            what: format!(
                "no rotation of {} and {} turns ({:.6}, {:.6}, {:.6}) to the tool axis",
                self.rotary[0].name, self.rotary[1].name, v.x, v.y, v.z
            ),
        })?;
        let mut out: Vec<Placed> = raw
            .iter()
            .take(count)
            .map(|o| {
                let (r0, ok0) = self.place(0, o.degrees[0], near[0]);
                let (r1, ok1) = self.place(1, o.degrees[1], near[1]);
                Placed {
                    rotary: [r0, r1],
                    within_limits: ok0 && ok1,
                    branch: o.branch,
                    singular: o.singular,
                }
            })
            .collect();
        let cost = |r: &[f64; 2]| (r[0] - near[0]).abs() + (r[1] - near[1]).abs();
        out.sort_by(|a, b| {
            b.within_limits
                .cmp(&a.within_limits)
                .then(cost(&a.rotary).total_cmp(&cost(&b.rotary)))
        });
        Ok(out)
    }

    /// Inverse kinematics: every joint solution that puts `head`'s tool point at `tip`
    /// with tool axis `axis` (part frame), best first: within limits first, then the
    /// smallest rotary move from `near` (continuous axes wrap, limited ones don't).
    #[inline]
    pub fn inverse(
        &self,
        tip: &Vector3<f64>,
        axis: &Vector3<f64>,
        head: usize,
        near: &[f64; 2],
    ) -> Result<Solutions, KinError> {
        if !tip.iter().chain(axis.iter()).all(|x| x.is_finite()) {
            return Err(KinError::NotFinite("the position or tool axis".into()));
        }
        // A length that overflows (components near 1e300) is scaled down first; other
        // axes are used as given (the batch functions match this path bit for bit).
        let scaled;
        let axis = if axis.norm().is_finite() {
            axis
        } else {
            scaled = axis / axis.amax();
            &scaled
        };
        let n = axis.norm();
        if n < 1e-12 {
            return Err(KinError::ZeroToolAxis);
        }
        let v = axis * (1.0 / n);
        let Some((raw, count)) = self.orient(&v, near) else {
            return Err(KinError::Unreachable {
                what: format!(
                    "no rotation of {} and {} turns the tool axis to ({:.6}, {:.6}, {:.6}): the axes' geometry cannot reach it",
                    self.rotary[0].name, self.rotary[1].name, v.x, v.y, v.z
                ),
            });
        };
        let mut sols = Solutions::EMPTY;
        for o in raw.iter().take(count) {
            sols.sols[sols.n] = self.branch_solution(o, tip, head, near);
            sols.n += 1;
        }
        Self::rank(&mut sols, near);
        Ok(sols)
    }

    /// The joints of one orientation branch: rotaries placed nearest `near`, linear axes
    /// from where the table puts `tip`.
    #[inline(always)]
    pub(crate) fn branch_solution(
        &self,
        o: &Orientation,
        tip: &Vector3<f64>,
        head: usize,
        near: &[f64; 2],
    ) -> Solution {
        let (r0, ok0) = self.place(0, o.degrees[0], near[0]);
        let (r1, ok1) = self.place(1, o.degrees[1], near[1]);
        // Whole turns do not change sine and cosine: no trigonometry here.
        let q = self.part_to_machine_sc(&o.sin_cos, tip);
        let linear = self.linear_for(&q, head);
        Solution {
            joints: Joints {
                linear,
                rotary: [r0, r1],
            },
            within_limits: ok0 && ok1 && self.linear_within(&linear),
            branch: o.branch,
            singular: o.singular,
        }
    }

    /// Best first: within limits, then the smaller rotary move from `near`.
    #[inline(always)]
    pub(crate) fn rank(sols: &mut Solutions, near: &[f64; 2]) {
        if sols.n == 2 {
            let cost = |s: &Solution| {
                (s.joints.rotary[0] - near[0]).abs() + (s.joints.rotary[1] - near[1]).abs()
            };
            let (a, b) = (sols.sols[0], sols.sols[1]);
            let swap = match (a.within_limits, b.within_limits) {
                (false, true) => true,
                (true, false) => false,
                _ => cost(&b) < cost(&a),
            };
            if swap {
                sols.sols.swap(0, 1);
            }
        }
    }

    /// Pick a solution: within limits, on `previous_branch` when one there is within
    /// limits (a flip is never chosen when the same branch can do it), else the best
    /// within limits on the other branch, flagged as a flip. An error names what blocks
    /// the pose and the nearest reachable orientation when none is within limits.
    pub fn choose(
        &self,
        sols: &Solutions,
        previous_branch: Option<i8>,
        requested_axis: &Vector3<f64>,
        head: usize,
    ) -> Result<Choice, KinError> {
        let s = sols.as_slice();
        let same = |x: &Solution| match previous_branch {
            None | Some(0) => true,
            Some(b) => x.branch == 0 || x.branch == b,
        };
        if let Some(x) = s.iter().find(|x| x.within_limits && same(x)) {
            return Ok(Choice {
                solution: *x,
                branch_flip: false,
            });
        }
        if let Some(x) = s.iter().find(|x| x.within_limits) {
            return Ok(Choice {
                solution: *x,
                branch_flip: true,
            });
        }
        Err(self.unreachable(s, requested_axis, head))
    }

    fn unreachable(&self, s: &[Solution], requested_axis: &Vector3<f64>, head: usize) -> KinError {
        let mut parts = Vec::new();
        let mut best: Option<(f64, [f64; 2])> = None;
        for sol in s {
            let mut blocked = Vec::new();
            let mut clamped = sol.joints.rotary;
            for (i, r) in self.rotary.iter().enumerate() {
                if let Some((lo, hi)) = r.limits {
                    let v = sol.joints.rotary[i];
                    if !r.within(v) {
                        blocked.push(format!(
                            "{} = {:.3}° is beyond its limits [{lo}, {hi}]",
                            r.name, v
                        ));
                        clamped[i] = v.clamp(lo, hi);
                    }
                }
            }
            for (l, &v) in self.linear.iter().zip(&sol.joints.linear) {
                if v < l.limits.0 - 1e-9 || v > l.limits.1 + 1e-9 {
                    blocked.push(format!(
                        "{} = {:.4} is beyond its travel [{}, {}]",
                        l.name, v, l.limits.0, l.limits.1
                    ));
                }
            }
            if !blocked.is_empty() {
                parts.push(blocked.join(" and "));
            }
            let j = Joints {
                linear: sol.joints.linear,
                rotary: clamped,
            };
            let reached = self.forward(&j, head).axis;
            let ang = reached
                .dot(&requested_axis.normalize())
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees();
            if best.is_none_or(|(a, _)| ang < a) {
                best = Some((ang, clamped));
            }
        }
        let nearest = match best {
            Some((ang, r)) => format!(
                "; the nearest reachable orientation is {} = {:.3}°, {} = {:.3}°, {:.3}° from the requested tool axis",
                self.rotary[0].name, r[0], self.rotary[1].name, r[1], ang
            ),
            None => String::new(),
        };
        KinError::Unreachable {
            what: format!(
                "no solution within limits: {}{}",
                parts.join("; or "),
                nearest
            ),
        }
    }
}
