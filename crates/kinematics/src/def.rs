//! The machine definition file (TOML): what users copy, edit and recalibrate.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::error::KinError;

/// Length units of a machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Units {
    /// Inches.
    Inch,
    /// Millimetres.
    Mm,
}

/// Which part moves when a linear axis moves in +.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Moves {
    /// The tool moves + relative to the machine frame.
    Tool,
    /// The table moves +, so the tool moves − relative to the part.
    Table,
}

/// A named parameter: a scalar or a vector.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ParamValue {
    /// A scalar (e.g. H).
    Scalar(f64),
    /// A vector (e.g. R, L).
    Vector([f64; 3]),
}

/// A vector given literally or from a parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum VecExpr {
    /// `[x, y, z]`
    Literal([f64; 3]),
    // `Along` first: an untagged map with `along` must not be read as `Scaled`.
    /// `{ param = "H", along = [0, 0, -1] }`: a scalar parameter along a vector.
    Along {
        /// Parameter name.
        param: String,
        /// Direction and scale.
        along: [f64; 3],
    },
    /// `{ param = "R", scale = -1.0 }`: a vector parameter times a scale.
    Scaled {
        /// Parameter name.
        param: String,
        /// Factor (default 1).
        #[serde(default = "one")]
        scale: f64,
    },
}

fn one() -> f64 {
    1.0
}

/// A linear axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearDef {
    /// Axis name (X, Y, Z).
    pub name: String,
    /// Unit direction in the machine frame.
    pub direction: [f64; 3],
    /// Whether + moves the tool or the table.
    pub moves: Moves,
    /// Travel `[min, max]` in machine units.
    pub limits: [f64; 2],
    /// Output resolution (smallest step the control takes).
    pub resolution: f64,
}

/// A rotary axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotaryDef {
    /// Axis name (A, B, C).
    pub name: String,
    /// Unit direction of positive rotation (right-hand rule), machine frame at home.
    pub axis: [f64; 3],
    /// A point on the axis, machine frame at home.
    pub pivot: VecExpr,
    /// Place in the chain from the workpiece outward: 1 carries the workpiece.
    pub order: u32,
    /// Travel `[min, max]` in degrees (absent for a continuous axis).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limits: Option<[f64; 2]>,
    /// Turns without end (and is unwound by the post).
    #[serde(default)]
    pub continuous: bool,
    /// Output resolution in degrees.
    pub resolution: f64,
}

/// A head: spindle, probe, laser, sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadDef {
    /// Head name.
    pub name: String,
    /// Offset of the head's tool point from the spindle point, machine frame.
    pub offset: VecExpr,
    /// A measuring head: the displacement sensor's parameters (its tool point is the
    /// sensor's zero, the middle of its range, on its beam).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor: Option<SensorDef>,
}

/// A laser displacement sensor on a head (paper 003): it reads `r`, the distance of the
/// surface beyond its zero along the beam (the tool axis, from the head to the tip), and
/// the surface is at `z_m = z_t − r` along that axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorDef {
    /// Reference (stand-off) distance from the sensor's face to its zero, machine units.
    pub reference: f64,
    /// Measuring range: readings within ±range of the zero are valid, machine units.
    pub range: f64,
    /// Largest tilt of the beam from the surface normal at which readings hold, degrees.
    pub max_tilt_deg: f64,
    /// The code that takes a reading (M, S, P, Q words, as the process codes).
    pub trigger: String,
}

/// A whole machine file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineDef {
    /// Machine name.
    pub name: String,
    /// One line about it.
    #[serde(default)]
    pub description: String,
    /// inch or mm.
    pub units: Units,
    /// Unit vector from the tool tip into the head, machine frame.
    #[serde(default = "z_axis")]
    pub tool_axis: [f64; 3],
    /// What the numbers in this file assume where the papers are silent.
    #[serde(default)]
    pub assumptions: Vec<String>,
    /// Named parameters users recalibrate (R, L, H, …).
    #[serde(default)]
    pub parameters: BTreeMap<String, ParamValue>,
    /// Linear axes.
    pub linear: Vec<LinearDef>,
    /// Rotary axes.
    pub rotary: Vec<RotaryDef>,
    /// Heads.
    #[serde(rename = "head")]
    pub heads: Vec<HeadDef>,
    /// Process codes and post settings.
    #[serde(default)]
    pub process: ProcessDef,
    /// Where a calibrated file's numbers came from (`lampost calibrate pivot --write`):
    /// a record for people, not used by the kinematics.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<CalibrationRecord>,
}

/// The `[calibration]` table of a calibrated machine file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationRecord {
    /// The measurement file (ball centres or probe log).
    pub source: String,
    /// The method (`i`, `iii`, `fit`).
    pub method: String,
    /// Number of poses.
    pub poses: u64,
    /// RMS of the pose residuals, machine units.
    pub rms: f64,
    /// Largest pose residual, machine units.
    pub max_pose_residual: f64,
    /// Standard uncertainty of R's components.
    #[serde(rename = "u_R", default, skip_serializing_if = "Option::is_none")]
    pub u_r: Option<[f64; 3]>,
    /// The machine file the calibration started from (its name).
    pub calibrated_from: String,
}

/// Process codes (M, S, P and Q words only, e.g. `"M71"` or `"M98 P10"`; see
/// the crate docs' *What a machine file may hold*) and post settings. The papers give no laser or powder codes: the
/// defaults are documented assumptions for the machine's integrator to set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProcessDef {
    /// Laser on (the power follows in the `laser_power_word`).
    pub laser_on: String,
    /// Laser off.
    pub laser_off: String,
    /// The word that carries the laser power with `laser_on` (e.g. S).
    pub laser_power_word: String,
    /// Powder feed on.
    pub powder_on: String,
    /// Powder feed off.
    pub powder_off: String,
    /// Spindle on clockwise (speed follows as S).
    pub spindle_on: String,
    /// Spindle off.
    pub spindle_off: String,
    /// Coolant on.
    pub coolant_on: String,
    /// Coolant off.
    pub coolant_off: String,
    /// Tool change (after the T word).
    pub tool_change: String,
    /// Machine-frame height of the head's tool point for retracts before any rotary
    /// move (the table re-indexes only up there).
    pub clearance_z: f64,
    /// Program end.
    pub program_end: String,
    /// Added to the highest point of the work at an index: the retract height is the
    /// larger of `clearance_z` and the highest point of the work at that index plus this
    /// margin. Machine units, finite, ≥ 0; default 0.2 in / 5 mm (see
    /// [`ProcessDef::safe_margin`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub safe_margin: Option<f64>,
    /// Radius of the head: the cylinder along the tool axis used for collision checks.
    /// Machine units, finite, > 0; default 1 in / 25 mm (see [`ProcessDef::head_radius`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub head_radius: Option<f64>,
    /// Length of the head: the cylinder along the tool axis, from the tool point into the
    /// head, used for collision checks. Machine units, finite, > 0; default 6 in / 150 mm
    /// (see [`ProcessDef::head_length`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub head_length: Option<f64>,
}

impl ProcessDef {
    /// The retract height is the larger of `clearance_z` and the highest point of the
    /// work at that index plus this margin: `safe_margin`, or 0.2 in / 5 mm.
    pub fn safe_margin(&self, units: Units) -> f64 {
        self.safe_margin.unwrap_or(match units {
            Units::Inch => 0.2,
            Units::Mm => 5.0,
        })
    }

    /// Radius of the cylinder along the tool axis used for collision checks:
    /// `head_radius`, or 1 in / 25 mm.
    pub fn head_radius(&self, units: Units) -> f64 {
        self.head_radius.unwrap_or(match units {
            Units::Inch => 1.0,
            Units::Mm => 25.0,
        })
    }

    /// Length of the cylinder along the tool axis (from the tool point into the head) used
    /// for collision checks: `head_length`, or 6 in / 150 mm.
    pub fn head_length(&self, units: Units) -> f64 {
        self.head_length.unwrap_or(match units {
            Units::Inch => 6.0,
            Units::Mm => 150.0,
        })
    }
}

impl Default for ProcessDef {
    fn default() -> Self {
        ProcessDef {
            laser_on: "M71".into(),
            laser_off: "M72".into(),
            laser_power_word: "S".into(),
            powder_on: "M73".into(),
            powder_off: "M74".into(),
            spindle_on: "M3".into(),
            spindle_off: "M5".into(),
            coolant_on: "M8".into(),
            coolant_off: "M9".into(),
            tool_change: "M6".into(),
            clearance_z: 0.0,
            program_end: "M30".into(),
            safe_margin: None,
            head_radius: None,
            head_length: None,
        }
    }
}

fn z_axis() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

/// The built-in machines: name and TOML text.
pub const BUILTINS: [(&str, &str); 2] = [
    (
        "fadal-lamp",
        include_str!("../../../fixtures/machines/fadal-lamp.toml"),
    ),
    (
        "nrc-lc",
        include_str!("../../../fixtures/machines/nrc-lc.toml"),
    ),
];

/// The TOML text of a built-in machine.
pub fn builtin_text(name: &str) -> Option<&'static str> {
    BUILTINS.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

fn line_col(text: &str, offset: usize) -> (usize, usize, String) {
    // A place inside a multi-byte character (a refusal located by bytes in text with an
    // emoji) is that character's start.
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

/// Find a bare `nan` or `inf` (TOML allows them; a machine file must not have them).
fn find_non_finite(text: &str) -> Option<usize> {
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let code = line.split('#').next().unwrap_or("");
        let mut in_str = false;
        let b = code.as_bytes();
        let mut i = 0;
        while i < b.len() {
            let c = b[i];
            if c == b'"' {
                in_str = !in_str;
            } else if !in_str && (c == b'n' || c == b'i') {
                let word_start = i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
                let rest = &code[i..];
                let is = |w: &str| {
                    rest.starts_with(w)
                        && !rest[w.len()..]
                            .bytes()
                            .next()
                            .is_some_and(|n| n.is_ascii_alphanumeric() || n == b'_')
                };
                if word_start && (is("nan") || is("inf")) {
                    // Only where a value stands (after `=`, `[` or `,`).
                    let before = code[..i].trim_end_matches([' ', '+', '-']);
                    if before.ends_with('=') || before.ends_with('[') || before.ends_with(',') {
                        return Some(offset + i);
                    }
                }
            }
            i += 1;
        }
        offset += line.len();
    }
    None
}

impl MachineDef {
    /// Read a machine file's text; `file` names it in errors. The values the post writes
    /// as text are checked as data (the crate docs' *What a machine file may hold*): a refusal names the file, line and
    /// column of the offending text.
    pub fn from_toml(text: &str, file: &str) -> Result<Self, KinError> {
        if let Some(at) = find_non_finite(text) {
            let (line, column, t) = line_col(text, at);
            return Err(KinError::MachineFile {
                file: file.to_string(),
                line,
                column,
                message: "NaN or infinity where a number belongs".into(),
                text: t,
            });
        }
        let mut def = toml::from_str::<MachineDef>(text).map_err(|e| {
            let (line, column, t) = match e.span() {
                Some(sp) => line_col(text, sp.start),
                None => (0, 0, String::new()),
            };
            KinError::MachineFile {
                file: file.to_string(),
                line,
                column,
                message: e.message().trim().to_string(),
                text: t,
            }
        })?;
        if let Some((key, at, written, read)) = crate::check::dropped_elements(text, &def) {
            let (line, column, t) = at.map_or((0, 0, String::new()), |a| line_col(text, a));
            return Err(KinError::MachineFile {
                file: file.to_string(),
                line,
                column,
                message: format!("`{key}` has {written} values; it takes {read}"),
                text: t,
            });
        }
        if let Err((place, refusal)) = def.check_values() {
            let (line, column, t) = match crate::check::locate(text, place, refusal.at) {
                Some(at) => line_col(text, at),
                None => (0, 0, String::new()),
            };
            return Err(KinError::MachineFile {
                file: file.to_string(),
                line,
                column,
                message: refusal.message,
                text: t,
            });
        }
        Ok(def)
    }

    /// The file as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_else(|e| format!("# cannot write: {e}\n"))
    }

    /// A built-in machine by name.
    pub fn builtin(name: &str) -> Option<Self> {
        builtin_text(name)
            .and_then(|t| MachineDef::from_toml(t, &format!("<built-in {name}>")).ok())
    }
}

#[cfg(test)]
mod line_col_tests {
    /// Fuzz run seed 2028, input 464801 (toml): a refusal's place inside an emoji
    /// panicked on slicing the line.
    #[test]
    fn a_place_inside_a_multibyte_character_is_its_start() {
        let text = "a = 1\nname = \"x😀y\"\n";
        let inside = text.find('😀').expect("emoji") + 2;
        let (line, col, shown) = super::line_col(text, inside);
        assert_eq!((line, col), (2, 10));
        assert_eq!(shown, "name = \"x😀y\"");
    }
}
