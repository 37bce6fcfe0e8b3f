//! The arm file (TOML): a six-axis serial arm by its classic Denavit–Hartenberg
//! parameters, its frames and the cell's settings. Every refusal names the file, line and
//! column of the offending value.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use toml::Spanned;

pub use lampost_kinematics::Units;

use crate::error::RobotError;

/// One joint: classic (standard) DH, `A_i = Rz(θ_i) · Tz(d_i) · Tx(a_i) · Rx(α_i)` with
/// `θ_i = q_i + offset_i`. Angles in degrees, lengths in the file's units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointDef {
    /// Joint name (J1 … J6).
    pub name: String,
    /// Offset along the previous z axis.
    pub d: f64,
    /// Length along the new x axis.
    pub a: f64,
    /// Twist about the new x axis, degrees.
    pub alpha: f64,
    /// Added to the joint value to give θ, degrees (default 0).
    #[serde(default)]
    pub offset: f64,
    /// Travel `[min, max]` of the joint value, degrees.
    pub limits: [f64; 2],
    /// Fastest turn, degrees per second.
    pub max_speed: f64,
}

/// A frame: an origin and two axes (x, and z; y = z × x). x need not be exactly
/// orthogonal to z: it is made so (z kept).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameDef {
    /// Origin, in the parent frame.
    pub origin: [f64; 3],
    /// x axis, in the parent frame.
    #[serde(default = "x_axis")]
    pub x_axis: [f64; 3],
    /// z axis, in the parent frame.
    #[serde(default = "z_axis")]
    pub z_axis: [f64; 3],
}

fn x_axis() -> [f64; 3] {
    [1.0, 0.0, 0.0]
}

fn z_axis() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

/// The cell's settings for posting.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CellDef {
    /// The safe location, joint values in degrees: every chunk starts and ends there.
    pub safe: [f64; 6],
    /// Arm configuration letters (`l`/`r` shoulder, `u`/`d` elbow, `n`/`f` wrist).
    pub config: String,
    /// Locations a controller file holds, the two safe locations included.
    pub chunk_points: usize,
    /// Largest distance between consecutive locations along the path.
    pub spacing: f64,
    /// Largest distance of the focus from the path when verifying.
    pub tolerance: f64,
}

/// A whole arm file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmDef {
    /// Always `"arm"`: what tells an arm file from a table machine's.
    pub kind: String,
    /// Machine name.
    pub name: String,
    /// One line about it.
    #[serde(default)]
    pub description: String,
    /// inch or mm.
    pub units: Units,
    /// `"classic"` (standard DH, as the Robotics Toolbox's `DHRobot`); the only one read.
    pub convention: String,
    /// What the numbers assume where the paper is silent.
    #[serde(default)]
    pub assumptions: Vec<String>,
    /// The six joints, base outward.
    pub joint: Vec<JointDef>,
    /// World to the arm's base frame (frame 0 of the DH chain).
    pub base: FrameDef,
    /// Flange (frame 6) to the part frame: the part holder.
    pub holder: FrameDef,
    /// World to the working frame: origin at the laser's focus, z from the focus into
    /// the laser head (the beam travels along −z), x along the substrate.
    pub head: FrameDef,
    /// Posting settings.
    pub cell: CellDef,
}

/// The built-in arms: name and TOML text.
pub const ARM_BUILTINS: [(&str, &str); 1] = [(
    "puma-lens",
    include_str!("../../../fixtures/machines/puma-lens.toml"),
)];

/// The TOML text of a built-in arm.
pub fn builtin_text(name: &str) -> Option<&'static str> {
    ARM_BUILTINS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, t)| *t)
}

/// Whether a machine file's text is an arm file (`kind = "arm"` at the top).
pub fn is_arm_text(text: &str) -> bool {
    #[derive(Deserialize)]
    struct Kind {
        kind: Option<String>,
    }
    toml::from_str::<Kind>(text).is_ok_and(|k| k.kind.as_deref() == Some("arm"))
}

/// Where in the file a value is.
#[derive(Debug, Clone, Copy)]
enum Place {
    Top(&'static str),
    Joint(usize, &'static str),
    Table(&'static str, &'static str),
}

type Table = BTreeMap<String, Spanned<toml::Value>>;

#[derive(Deserialize)]
struct Located {
    #[serde(default)]
    joint: Vec<Spanned<Table>>,
    #[serde(default)]
    base: Option<Spanned<Table>>,
    #[serde(default)]
    holder: Option<Spanned<Table>>,
    #[serde(default)]
    head: Option<Spanned<Table>>,
    #[serde(default)]
    cell: Option<Spanned<Table>>,
    #[serde(default)]
    kind: Option<Spanned<toml::Value>>,
    #[serde(default)]
    name: Option<Spanned<toml::Value>>,
    #[serde(default)]
    convention: Option<Spanned<toml::Value>>,
    #[serde(default)]
    units: Option<Spanned<toml::Value>>,
}

fn locate(text: &str, place: Place) -> Option<usize> {
    let doc: Located = toml::from_str(text).ok()?;
    let in_table = |t: &Spanned<Table>, key: &str| {
        t.get_ref()
            .get(key)
            .map_or(t.span().start, |v| v.span().start)
    };
    match place {
        Place::Top(key) => match key {
            "kind" => doc.kind.map(|v| v.span().start),
            "name" => doc.name.map(|v| v.span().start),
            "convention" => doc.convention.map(|v| v.span().start),
            "units" => doc.units.map(|v| v.span().start),
            _ => None,
        },
        Place::Joint(i, key) => doc
            .joint
            .get(i)
            .or(doc.joint.last())
            .map(|t| in_table(t, key)),
        Place::Table(table, key) => {
            let t = match table {
                "base" => doc.base,
                "holder" => doc.holder,
                "head" => doc.head,
                _ => doc.cell,
            };
            t.map(|t| in_table(&t, key))
        }
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize, String) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    let col = text[start..offset].chars().count() + 1;
    let end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    (line, col, text[start..end].to_string())
}

fn file_error(text: &str, file: &str, at: Option<usize>, message: String) -> RobotError {
    let (line, column, text) = at.map_or((0, 0, String::new()), |a| line_col(text, a));
    RobotError::MachineFile {
        file: file.to_string(),
        line,
        column,
        message,
        text,
    }
}

/// Unit vector or the reason it is none.
fn unit(v: [f64; 3]) -> Option<nalgebra::Vector3<f64>> {
    let v = nalgebra::Vector3::from(v);
    let n = v.norm();
    (n.is_finite() && n > 1e-9).then(|| v / n)
}

impl ArmDef {
    /// Read an arm file's text; `file` names it in errors.
    pub fn from_toml(text: &str, file: &str) -> Result<Self, RobotError> {
        let def = toml::from_str::<ArmDef>(text).map_err(|e| {
            file_error(
                text,
                file,
                e.span().map(|s| s.start),
                e.message().trim().to_string(),
            )
        })?;
        def.check()
            .map_err(|(place, msg)| file_error(text, file, locate(text, place), msg))?;
        Ok(def)
    }

    /// A built-in arm by name.
    pub fn builtin(name: &str) -> Option<Self> {
        builtin_text(name).and_then(|t| ArmDef::from_toml(t, &format!("<built-in {name}>")).ok())
    }

    /// The file as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_else(|e| format!("# cannot write: {e}\n"))
    }

    /// The arm as data: every number finite, a real arm, limits that make sense.
    fn check(&self) -> Result<(), (Place, String)> {
        if self.kind != "arm" {
            return Err((
                Place::Top("kind"),
                format!("kind `{}`: an arm file says kind = \"arm\"", self.kind),
            ));
        }
        if self.name.trim().is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
        {
            return Err((
                Place::Top("name"),
                "the name takes letters, digits, `-`, `_` and `.` only".into(),
            ));
        }
        if self.convention != "classic" {
            return Err((Place::Top("convention"), format!(
                "convention `{}`: only \"classic\" (standard) Denavit–Hartenberg is read; convert modified (Craig) parameters to classic",
                self.convention
            )));
        }
        if self.joint.len() != 6 {
            return Err((
                Place::Joint(6, ""),
                format!(
                    "the arm has {} joints; a six-axis arm has 6 [[joint]] tables",
                    self.joint.len()
                ),
            ));
        }
        for (i, j) in self.joint.iter().enumerate() {
            for (key, v) in [
                ("d", j.d),
                ("a", j.a),
                ("alpha", j.alpha),
                ("offset", j.offset),
                ("max_speed", j.max_speed),
            ] {
                if !v.is_finite() {
                    return Err((
                        Place::Joint(i, key),
                        format!("joint {}: `{key}` is not a finite number", j.name),
                    ));
                }
            }
            if !(j.d.abs() < 1e6 && j.a.abs() < 1e6) {
                return Err((
                    Place::Joint(i, "d"),
                    format!("joint {}: a link longer than 10^6 units", j.name),
                ));
            }
            let [lo, hi] = j.limits;
            if !(lo.is_finite() && hi.is_finite()) {
                return Err((
                    Place::Joint(i, "limits"),
                    format!("joint {}: a limit is not a finite number", j.name),
                ));
            }
            if lo >= hi || hi - lo > 720.0 {
                return Err((Place::Joint(i, "limits"), format!(
                    "joint {}: limits [{lo}, {hi}] must be [min, max] with min < max, spanning at most 720°",
                    j.name
                )));
            }
            if j.max_speed <= 0.0 {
                return Err((
                    Place::Joint(i, "max_speed"),
                    format!(
                        "joint {}: max_speed must be positive (degrees per second)",
                        j.name
                    ),
                ));
            }
            if j.name.trim().is_empty() || !j.name.chars().all(|c| c.is_ascii_alphanumeric()) {
                return Err((
                    Place::Joint(i, "name"),
                    "a joint name takes letters and digits only".into(),
                ));
            }
        }
        // A degenerate arm: no length at all, or nothing between shoulder and wrist.
        let reach: f64 = self.joint.iter().map(|j| j.a.abs() + j.d.abs()).sum();
        if reach < 1e-9 {
            return Err((
                Place::Joint(0, "d"),
                "every link length a and offset d is zero: the arm has no length and reaches nothing".into(),
            ));
        }
        let arm: f64 = self.joint[1..4].iter().map(|j| j.a.abs()).sum::<f64>()
            + self.joint[2..4].iter().map(|j| j.d.abs()).sum::<f64>();
        if arm < 1e-9 {
            return Err((
                Place::Joint(1, "a"),
                "joints 2–4 have no length (a2, a3, d3, d4 all zero): the arm cannot move its wrist".into(),
            ));
        }
        for (table, f) in [
            ("base", &self.base),
            ("holder", &self.holder),
            ("head", &self.head),
        ] {
            if !f
                .origin
                .iter()
                .chain(&f.x_axis)
                .chain(&f.z_axis)
                .all(|v| v.is_finite())
            {
                return Err((
                    Place::Table(table, "origin"),
                    format!("[{table}]: a number is not finite"),
                ));
            }
            let (Some(x), Some(z)) = (unit(f.x_axis), unit(f.z_axis)) else {
                return Err((
                    Place::Table(table, "z_axis"),
                    format!("[{table}]: an axis has zero length"),
                ));
            };
            if x.cross(&z).norm() < 1e-6 {
                return Err((
                    Place::Table(table, "x_axis"),
                    format!("[{table}]: x_axis is parallel to z_axis"),
                ));
            }
        }
        let c = &self.cell;
        for (i, (v, j)) in c.safe.iter().zip(&self.joint).enumerate() {
            if !(v.is_finite() && *v >= j.limits[0] && *v <= j.limits[1]) {
                return Err((
                    Place::Table("cell", "safe"),
                    format!(
                        "safe location: joint {} ({}) = {v} is outside its limits [{}, {}]",
                        i + 1,
                        j.name,
                        j.limits[0],
                        j.limits[1]
                    ),
                ));
            }
        }
        if crate::arm::Config::parse(&c.config).is_none() {
            return Err((
                Place::Table("cell", "config"),
                format!(
                    "config `{}`: give three letters, l or r, u or d, n or f (e.g. \"lun\")",
                    c.config
                ),
            ));
        }
        if c.chunk_points < 3 {
            return Err((
                Place::Table("cell", "chunk_points"),
                "chunk_points must be at least 3 (two safe locations and one path point)".into(),
            ));
        }
        for (key, v) in [("spacing", c.spacing), ("tolerance", c.tolerance)] {
            if !(v.is_finite() && v > 0.0) {
                return Err((
                    Place::Table("cell", key),
                    format!("[cell] {key} must be a positive number"),
                ));
            }
        }
        Ok(())
    }
}
