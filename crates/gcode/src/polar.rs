//! LinuxCNC's polar coordinates: `@` (the radius) and `^` (the angle in degrees,
//! counter-clockwise from +X) in place of X and Y, resolved into an XY point of the work
//! system as rs274ngc resolves them, for moves (G0–G3, G33, G38.x) and canned cycles:
//! the same formulas in the same order, so the points are bit-equal (checked against
//! rs274 in `crates/cli/tests/polar_rs274.rs`). Points are program coordinates (about
//! the origin of the work system in force); the caller adds the offsets. What the words
//! may stand with (G17, no X or Y, motion only) is checked by the interpreter.

/// A block's polar words, as given (at least one of them).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Polar {
    /// `@`: the radius (G90) or its increment (G91).
    pub radius: Option<f64>,
    /// `^`: the angle in degrees (G90) or its increment (G91).
    pub angle: Option<f64>,
}

/// Why a polar point cannot be resolved: `@` alone (G90) at the origin, whose angle
/// rs274 refuses to guess.
pub(crate) const RADIUS_AT_ORIGIN: &str =
    "`@` without `^` at the origin of the work system: the angle is unknown (LinuxCNC refuses it); give `^` too";
/// Why a polar point cannot be resolved: an incremental (G91) step from the origin.
pub(crate) const INCREMENTAL_AT_ORIGIN: &str =
    "an incremental (G91) polar step from the origin of the work system has no direction (LinuxCNC refuses it)";
/// Why a polar point cannot be resolved: a coordinate that is not a finite number.
pub(crate) const NOT_FINITE: &str = "the point they give is not a finite number";

/// Degrees to radians, as rs274ngc's `D2R` (`r * (M_PI / 180.)`).
fn d2r(degrees: f64) -> f64 {
    degrees * (std::f64::consts::PI / 180.0)
}

/// The point at `radius` and `theta` (radians), as rs274ngc computes it.
fn point(radius: f64, theta: f64) -> [f64; 2] {
    [radius * theta.cos(), radius * theta.sin()]
}

fn finite(p: [f64; 2]) -> Result<[f64; 2], &'static str> {
    if p[0].is_finite() && p[1].is_finite() {
        Ok(p)
    } else {
        Err(NOT_FINITE)
    }
}

impl Polar {
    /// The end of a move from `at` (the current point, program XY). Absolute (G90): the
    /// point at the given radius and angle, an omitted one taken from `at` (`@` alone at
    /// the origin is an error). Incremental (G91): `@` added to `at`'s radius, then `^`
    /// to the angle of the point so reached (either from the origin is an error).
    pub(crate) fn end(self, at: [f64; 2], incremental: bool) -> Result<[f64; 2], &'static str> {
        let [x, y] = at;
        let at_origin = |p: [f64; 2]| p[0] == 0.0 && p[1] == 0.0;
        let p = if incremental {
            let mut p = at;
            if let Some(dr) = self.radius {
                if at_origin(p) {
                    return Err(INCREMENTAL_AT_ORIGIN);
                }
                p = point(p[1].hypot(p[0]) + dr, p[1].atan2(p[0]));
            }
            if let Some(da) = self.angle {
                if at_origin(p) {
                    return Err(INCREMENTAL_AT_ORIGIN);
                }
                p = point(p[1].hypot(p[0]), p[1].atan2(p[0]) + d2r(da));
            }
            p
        } else {
            match (self.radius, self.angle) {
                (Some(r), Some(a)) => point(r, d2r(a)),
                (Some(r), None) => {
                    if at_origin(at) {
                        return Err(RADIUS_AT_ORIGIN);
                    }
                    point(r, y.atan2(x))
                }
                (None, Some(a)) => point(y.hypot(x), d2r(a)),
                (None, None) => at,
            }
        };
        finite(p)
    }

    /// The hole of an absolute (G90) canned cycle with the tool at `at`: the given
    /// radius and angle, an omitted one taken from `at` (at the origin, radius 0 and
    /// angle 0: rs274 checks nothing here). Every repeat drills this hole.
    pub(crate) fn cycle_hole(self, at: [f64; 2]) -> Result<[f64; 2], &'static str> {
        let [x, y] = at;
        let radius = self.radius.unwrap_or_else(|| y.hypot(x));
        let theta = self.angle.map_or_else(|| y.atan2(x), d2r);
        finite(point(radius, theta))
    }

    /// The next hole of an incremental (G91) canned cycle after the hole `at` (the tool's
    /// point for the first repeat): `@` added to the radius, then `^` to the angle; an
    /// increment of zero is no step at all (rs274 skips it, origin or not), and a step
    /// from the origin is an error.
    pub(crate) fn cycle_step(self, at: [f64; 2]) -> Result<[f64; 2], &'static str> {
        let mut p = at;
        let dr = self.radius.unwrap_or(0.0);
        if dr != 0.0 {
            if p[0] == 0.0 && p[1] == 0.0 {
                return Err(INCREMENTAL_AT_ORIGIN);
            }
            p = point(p[1].hypot(p[0]) + dr, p[1].atan2(p[0]));
        }
        let da = self.angle.map_or(0.0, d2r);
        if da != 0.0 {
            if p[0] == 0.0 && p[1] == 0.0 {
                return Err(INCREMENTAL_AT_ORIGIN);
            }
            p = point(p[1].hypot(p[0]), p[1].atan2(p[0]) + da);
        }
        finite(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(p: [f64; 2], q: [f64; 2]) -> bool {
        (p[0] - q[0]).abs() < 1e-12 && (p[1] - q[1]).abs() < 1e-12
    }

    fn polar(radius: Option<f64>, angle: Option<f64>) -> Polar {
        Polar { radius, angle }
    }

    #[test]
    fn absolute_ends_keep_the_omitted_word() {
        let both = polar(Some(2.0), Some(90.0)).end([5.0, 5.0], false);
        assert!(close(both.expect("ends"), [0.0, 2.0]));
        // `@` alone keeps the angle of the current point, `^` alone its radius.
        let r = polar(Some(2.0), None).end([3.0, 3.0], false);
        assert!(close(r.expect("ends"), [2.0_f64.sqrt(), 2.0_f64.sqrt()]));
        let a = polar(None, Some(180.0)).end([3.0, 4.0], false);
        assert!(close(a.expect("ends"), [-5.0, 0.0]));
        // `^` alone at the origin: radius 0 (rs274 moves to the origin).
        assert_eq!(
            polar(None, Some(30.0)).end([0.0, 0.0], false),
            Ok([0.0, 0.0])
        );
        assert_eq!(
            polar(Some(1.0), None).end([0.0, 0.0], false),
            Err(RADIUS_AT_ORIGIN)
        );
    }

    #[test]
    fn incremental_ends_add_radius_then_angle() {
        let p = polar(Some(1.0), Some(90.0)).end([1.0, 0.0], true);
        assert!(close(p.expect("ends"), [0.0, 2.0]));
        let p = polar(None, Some(-45.0)).end([0.0, 2.0], true);
        assert!(close(p.expect("ends"), [2.0_f64.sqrt(), 2.0_f64.sqrt()]));
        for w in [polar(Some(1.0), None), polar(None, Some(1.0))] {
            assert_eq!(w.end([0.0, 0.0], true), Err(INCREMENTAL_AT_ORIGIN));
        }
        // The radius step reaches the origin: the angle has nothing to turn.
        assert_eq!(
            polar(Some(-1.0), Some(30.0)).end([1.0, 0.0], true),
            Err(INCREMENTAL_AT_ORIGIN)
        );
        // A radius made negative goes through the origin.
        let p = polar(Some(-3.0), None).end([1.0, 0.0], true);
        assert!(close(p.expect("ends"), [-2.0, 0.0]));
    }

    #[test]
    fn cycle_holes_as_rs274_places_them() {
        // G90: no origin check.
        assert_eq!(
            polar(Some(2.0), None).cycle_hole([0.0, 0.0]),
            Ok([2.0, 0.0])
        );
        assert_eq!(
            polar(None, Some(45.0)).cycle_hole([0.0, 0.0]),
            Ok([0.0, 0.0])
        );
        // G91: a zero increment is no step, even at the origin.
        assert_eq!(
            polar(Some(0.0), None).cycle_step([0.0, 0.0]),
            Ok([0.0, 0.0])
        );
        assert_eq!(
            polar(Some(1.0), None).cycle_step([0.0, 0.0]),
            Err(INCREMENTAL_AT_ORIGIN)
        );
        let mut at = [1.0, 0.0];
        for want in [[0.0, 2.0], [-3.0, 0.0]] {
            at = polar(Some(1.0), Some(90.0)).cycle_step(at).expect("steps");
            assert!(close(at, want), "{at:?}");
        }
    }

    #[test]
    fn a_point_out_of_range_is_refused() {
        let huge = polar(Some(f64::MAX), None).end([f64::MAX, 1.0], true);
        assert_eq!(huge, Err(NOT_FINITE));
        assert_eq!(
            polar(Some(f64::MAX), None).cycle_step([f64::MAX, 0.0]),
            Err(NOT_FINITE)
        );
    }
}
