//! Levelling and CAD alignment (paper 002), and the setup file `lampost post` reads.

use lampost_kinematics::{Joints, KinError, Machine};
use nalgebra::Rotation3;
use serde::{Deserialize, Serialize};

use crate::fit::P3;

/// One levelling solution.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Level {
    /// Rotary angles in the machine's file order.
    pub rotary: [f64; 2],
    /// Within the rotary limits.
    pub within_limits: bool,
    /// Branch (+1/−1, 0 where the two coincide).
    pub branch: i8,
    /// The normal is parallel to a rotary axis; that axis kept its `near` value.
    pub singular: bool,
    /// Tilt left between the normal and the tool axis once the angles are rounded to the
    /// machine's angular resolution, in degrees.
    pub residual_tilt_deg: f64,
}

/// The A/B (B/C…) positions that make `normal` (outward, part frame) the tool axis, both
/// branches, best first.
pub fn level(machine: &Machine, normal: &P3, near: &[f64; 2]) -> Result<Vec<Level>, KinError> {
    let n = normal.normalize();
    let sols = machine.orientations(&n, near)?;
    Ok(sols
        .into_iter()
        .map(|p| {
            let (rotary, within_limits, branch, singular) =
                (p.rotary, p.within_limits, p.branch, p.singular);
            let mut rounded = rotary;
            for (i, r) in machine.rotary.iter().enumerate() {
                rounded[i] = (rotary[i] / r.resolution).round() * r.resolution;
            }
            let axis = machine
                .forward(
                    &Joints {
                        linear: [0.0; 3],
                        rotary: rounded,
                    },
                    0,
                )
                .axis;
            let residual_tilt_deg = axis.cross(&n).norm().atan2(axis.dot(&n)).to_degrees();
            Level {
                rotary,
                within_limits,
                branch,
                singular,
                residual_tilt_deg,
            }
        })
        .collect())
}

/// The angle between two planes and the rotations that align them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlaneAngle {
    /// The angle between the planes (paper 002, eq. 1), 0–90°.
    pub angle_deg: f64,
    /// The rotation taking the second (CAD) normal onto the first (probed): axis (unit;
    /// zero when already parallel) and angle in degrees.
    pub rotation_axis: [f64; 3],
    /// Angle of that rotation.
    pub rotation_deg: f64,
    /// The rotation about the tool axis (+Z) that turns the CAD plane's trace in XY onto
    /// the probed plane's: rotate the model by this to match the part. `None` when
    /// either normal is along Z (no trace in XY).
    pub rotation_about_z_deg: Option<f64>,
}

/// Angle and aligning rotations between a probed plane normal `probed` and a CAD plane
/// normal `cad` (their signs are made to agree first: planes, not half-spaces).
pub fn plane_angle(probed: &P3, cad: &P3) -> PlaneAngle {
    let a = probed.normalize();
    let mut b = cad.normalize();
    if a.dot(&b) < 0.0 {
        b = -b;
    }
    let cross = b.cross(&a);
    let angle = cross.norm().atan2(b.dot(&a));
    let axis = if cross.norm() > 1e-15 {
        cross.normalize()
    } else {
        P3::zeros()
    };
    let (axy, bxy) = (P3::new(a.x, a.y, 0.0), P3::new(b.x, b.y, 0.0));
    let rz = if axy.norm() > 1e-9 && bxy.norm() > 1e-9 {
        // A plane's trace direction is ⟂ to its normal's XY part; a line, so fold to ±90°.
        let mut phi = (bxy.x * axy.y - bxy.y * axy.x)
            .atan2(bxy.dot(&axy))
            .to_degrees();
        if phi > 90.0 {
            phi -= 180.0;
        } else if phi < -90.0 {
            phi += 180.0;
        }
        Some(phi)
    } else {
        None
    };
    PlaneAngle {
        angle_deg: angle.to_degrees(),
        rotation_axis: [axis.x, axis.y, axis.z],
        rotation_deg: angle.to_degrees(),
        rotation_about_z_deg: rz,
    }
}

/// Where the program (CAD) frame sits on the part: origin and axes in the part frame.
/// Written by `lampost align` and read by `lampost post --setup`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Setup {
    /// Origin of the program frame, part frame.
    pub origin: [f64; 3],
    /// Unit X axis of the program frame, part frame.
    pub x_axis: [f64; 3],
    /// Unit Z axis of the program frame, part frame (the path plane's normal).
    pub z_axis: [f64; 3],
    /// Where it came from.
    #[serde(default)]
    pub note: String,
}

impl Setup {
    /// A setup from an origin and a rotation of the program frame (axis, degrees; a zero
    /// axis is no rotation): its X and Z axes are the part's X and Z turned by it.
    pub fn from_rotation(origin: P3, axis: [f64; 3], degrees: f64, note: &str) -> Self {
        let axis = P3::from(axis);
        let r = if axis.norm() > 0.0 && degrees.is_finite() {
            Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), degrees.to_radians())
        } else {
            Rotation3::identity()
        };
        let (x, z) = (r * P3::x(), r * P3::z());
        Setup {
            origin: [origin.x, origin.y, origin.z],
            x_axis: [x.x, x.y, x.z],
            z_axis: [z.x, z.y, z.z],
            note: note.to_string(),
        }
    }

    /// The CAD (program) frame placed on the part by a rigid transform
    /// `part = rotation·cad + translation` (a registration's): the origin is the
    /// translation and the axes are the rotation's first and third columns. The one
    /// writer of a registration's setup (`align register --write-setup`,
    /// `inspect compare --best-fit --write-setup`).
    pub fn from_transform(rotation: [[f64; 3]; 3], translation: [f64; 3], note: &str) -> Self {
        let r = &rotation;
        Setup {
            origin: translation,
            x_axis: [r[0][0], r[1][0], r[2][0]],
            z_axis: [r[0][2], r[1][2], r[2][2]],
            note: note.to_string(),
        }
    }

    /// The file text.
    pub fn to_toml(&self) -> String {
        let mut s = String::from(
            "# lampost setup: the program frame placed on the part (part-frame coordinates)\n",
        );
        s.push_str(&format!(
            "origin = [{}, {}, {}]\n",
            self.origin[0], self.origin[1], self.origin[2]
        ));
        s.push_str(&format!(
            "x_axis = [{}, {}, {}]\n",
            self.x_axis[0], self.x_axis[1], self.x_axis[2]
        ));
        s.push_str(&format!(
            "z_axis = [{}, {}, {}]\n",
            self.z_axis[0], self.z_axis[1], self.z_axis[2]
        ));
        s.push_str(&format!("note = {:?}\n", self.note));
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq_1_angle_and_rotation() {
        let a = P3::new(1.0, 0.0, 0.0);
        let b = P3::new(1.0, 1.0, 0.0);
        let r = plane_angle(&a, &b);
        assert!((r.angle_deg - 45.0).abs() < 1e-12);
        assert!((r.rotation_about_z_deg.expect("xy") + 45.0).abs() < 1e-12);
        // Rotating b by the reported rotation gives a.
        let rot = Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(P3::from(r.rotation_axis)),
            r.rotation_deg.to_radians(),
        );
        assert!((rot * b.normalize() - a).norm() < 1e-12);
        // Opposite normals are the same plane.
        assert!(plane_angle(&a, &-a).angle_deg.abs() < 1e-12);
    }

    #[test]
    fn levelling_round_trip() {
        let m = Machine::builtin("fadal-lamp", &[]).expect("machine");
        let n = P3::new(0.2, -0.1, 0.97).normalize();
        let sols = level(&m, &n, &[0.0, 0.0]).expect("reachable");
        assert_eq!(sols.len(), 2);
        for s in &sols {
            let axis = m
                .forward(
                    &Joints {
                        linear: [0.0; 3],
                        rotary: s.rotary,
                    },
                    0,
                )
                .axis;
            assert!((axis - n).norm() < 1e-12);
            assert!(s.residual_tilt_deg < 0.001, "{}", s.residual_tilt_deg);
        }
    }
}
