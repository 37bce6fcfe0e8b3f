//! Where a program frame sits on the part: `part = origin + rot·program`.

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};

use crate::error::PostError;

/// A rigid placement of the program frame in the part frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Program origin in the part frame.
    pub origin: Vector3<f64>,
    /// Program axes (columns) in the part frame.
    pub rot: Matrix3<f64>,
}

impl Frame {
    /// The program frame moved to `origin`, axes parallel to the part's.
    pub fn translation(origin: Vector3<f64>) -> Self {
        Frame {
            origin,
            rot: Matrix3::identity(),
        }
    }

    /// From an origin, an X axis and a Z axis (Y = Z × X). X is made orthogonal to Z.
    pub fn from_axes(
        origin: Vector3<f64>,
        x: Vector3<f64>,
        z: Vector3<f64>,
    ) -> Result<Self, String> {
        if !origin
            .iter()
            .chain(x.iter())
            .chain(z.iter())
            .all(|v| v.is_finite())
        {
            return Err("the setup holds a number that is not finite".into());
        }
        // Directions are scaled to a largest component of 1 first: the length of one
        // near 1e308 overflows (found by `cargo xtask fuzz`: a NaN frame).
        let unit = |v: Vector3<f64>| {
            let m = v.amax();
            if m > 0.0 {
                v / m
            } else {
                v
            }
        };
        let (x, z) = (unit(x), unit(z));
        if z.norm() < 1e-12 {
            return Err("z_axis has zero length".into());
        }
        let z = z.normalize();
        let xo = x - z * z.dot(&x);
        if xo.norm() < 1e-9 {
            return Err("x_axis is zero or parallel to z_axis".into());
        }
        let x = xo.normalize();
        let y = z.cross(&x);
        Ok(Frame {
            origin,
            rot: Matrix3::from_columns(&[x, y, z]),
        })
    }

    /// A program point in the part frame.
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.origin + self.rot * p
    }

    /// A program direction in the part frame.
    pub fn dir(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.rot * v
    }

    /// This frame turned by `deg` about the line through `point` along `axis` (part frame).
    pub fn rotated(&self, axis: &Vector3<f64>, point: &Vector3<f64>, deg: f64) -> Self {
        let r =
            Rotation3::from_axis_angle(&Unit::new_normalize(*axis), deg.to_radians()).into_inner();
        Frame {
            origin: r * (self.origin - point) + point,
            rot: r * self.rot,
        }
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Read a setup file (`origin`, `x_axis`, `z_axis`, optional `note`), as `lampost align`
/// writes it.
pub fn read_setup(text: &str, file: &str) -> Result<Frame, PostError> {
    let s: lampost_align::Setup = toml::from_str(text).map_err(|e| {
        let (line, column) = e.span().map_or((0, 0), |sp| line_col(text, sp.start));
        PostError::File {
            file: file.to_string(),
            line,
            column,
            message: e.message().trim().to_string(),
        }
    })?;
    if let Some((key, at, written, read)) = lampost_kinematics::dropped_elements(text, &s) {
        let (line, column) = at.map_or((0, 0), |a| line_col(text, a));
        return Err(PostError::File {
            file: file.to_string(),
            line,
            column,
            message: format!("`{key}` has {written} values; it takes {read}"),
        });
    }
    Frame::from_axes(
        Vector3::from(s.origin),
        Vector3::from(s.x_axis),
        Vector3::from(s.z_axis),
    )
    .map_err(|message| {
        let key = ["z_axis", "x_axis", "origin"]
            .into_iter()
            .find(|k| message.contains(k))
            .unwrap_or("origin");
        let at = text.find(key).unwrap_or(0);
        let (line, column) = line_col(text, at);
        PostError::File {
            file: file.to_string(),
            line,
            column,
            message,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Found by `cargo xtask fuzz` (toml target, seed 2026, input 4006557): a setup file
    /// whose x_axis has components of ±1.8e308 gave a frame of NaN.
    #[test]
    fn axes_near_the_largest_double_give_a_finite_frame() {
        let text = "origin = [-25.4, 0.5, 0.6]\nx_axis = [-1.7976931348623157e308, 1.7976931348623157e308, -0.75]\nz_axis = [0.9377506658644394, -0.6517597444561505, 0.30606564945222914]\n";
        let f = read_setup(text, "setup.toml").expect("a frame");
        assert!(f.rot.iter().all(|v| v.is_finite()), "{f:?}");
        let i = f.rot.transpose() * f.rot;
        assert!((i - Matrix3::identity()).amax() < 1e-12, "{f:?}");
    }
}
