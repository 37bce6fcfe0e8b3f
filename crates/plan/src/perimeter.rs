//! Perimeters with tool axes (paper 001's rule): at every point of a slice's loop the
//! tool axis lies in the surface, across the traversal — the cross product of the
//! surface normal and the traversal direction — so the laser meets the wall along the
//! material already deposited. On a face the axis is that face's; where the loop crosses
//! from one face to the next the two are blended (the mean of the two, made unit), so the
//! axis turns gradually around the loop instead of jumping at every face edge. Points are
//! then spaced to at most a chord length and a tool-axis turn.
//!
//! Sign: with outward normals and loops oriented as [`crate::slice()`] orients them (outer
//! boundaries counter-clockwise about the build direction, holes clockwise), `normal ×
//! traversal` points along the build direction on a wall parallel to it: the tool axis
//! (from the tip into the head) points up the build, the laser comes down onto the
//! layer. The beam's direction (the approach, head to part) is its opposite.

use lampost_mesh::{Mesh, P3};

use crate::error::PlanError;
use crate::slice::Slicing;

/// One point of a planned path, part frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// Tool tip.
    pub p: P3,
    /// Tool axis, unit, from the tip into the head.
    pub axis: P3,
    /// The laser is on while moving to this point.
    pub laser: bool,
    /// Layer index.
    pub layer: usize,
}

/// How perimeter points are spaced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerimeterOptions {
    /// Longest chord between two points.
    pub spacing: f64,
    /// Largest turn of the tool axis between two points, degrees.
    pub max_turn_deg: f64,
}

/// The tool axis of each segment of a loop: `n × t` with the segment's face normal `n`
/// and its direction `t`; `None` where it is not defined by the geometry: a segment of
/// no length against the loop's size (a doubled point, a crack stitched shut: its
/// direction is rounding noise), or running along its face's normal.
fn segment_axes(mesh: &Mesh, points: &[P3], faces: &[u32]) -> Vec<Option<P3>> {
    let k = points.len();
    let size = points
        .iter()
        .map(|p| p - points[0])
        .fold(0.0f64, |m, d| m.max(d.amax()));
    (0..k)
        .map(|i| {
            let t = points[(i + 1) % k] - points[i];
            let f = mesh.triangles.get(*faces.get(i)? as usize)?;
            let [a, b, c] = f.map(|v| mesh.vertices[v as usize]);
            let n = (b - a).cross(&(c - a));
            let ax = n.cross(&t);
            let l = ax.norm();
            let defined = t.norm() > AXIS_NOISE * size && l > AXIS_NOISE * n.norm() * t.norm();
            (defined && l.is_finite()).then(|| ax / l)
        })
        .collect()
}

/// Below this fraction (1e-9) of the loop's size a segment is a point, and below this
/// sine of the angle between a segment and its face's normal they are parallel: either
/// way the segment's axis is rounding noise.
const AXIS_NOISE: f64 = 1e-9;

/// Unit mean of two vectors (the first, made unit, when they cancel).
fn blend(a: P3, b: P3) -> P3 {
    let m = a + b;
    if m.norm() > 1e-12 {
        m / m.norm()
    } else {
        a / a.norm()
    }
}

/// Stage 1 and 2 for one loop: its points with blended axes (a vertex between two faces
/// gets the mean of their axes), then spaced by `opts`. The first point is repeated at
/// the end so the perimeter closes; the laser is off onto the first point.
pub(crate) fn one_loop(
    mesh: &Mesh,
    points: &[P3],
    faces: &[u32],
    layer: usize,
    opts: &PerimeterOptions,
) -> Vec<PathPoint> {
    let k = points.len();
    let seg = segment_axes(mesh, points, faces);
    // A segment without an axis (degenerate) takes the last defined one before it
    // around the loop.
    let Some(last) = seg.iter().rposition(Option::is_some) else {
        return Vec::new();
    };
    let mut carried = seg[last];
    let seg: Vec<P3> = seg
        .iter()
        .map(|a| {
            carried = a.or(carried);
            carried.unwrap_or_else(P3::z)
        })
        .collect();
    let at: Vec<P3> = (0..k)
        .map(|i| blend(seg[(i + k - 1) % k], seg[i]))
        .collect();
    // Points per segment first, so the path is allocated once.
    let max_turn = opts.max_turn_deg.to_radians();
    let steps: Vec<usize> = (0..k)
        .map(|i| {
            let chord = (points[(i + 1) % k] - points[i]).norm();
            let turn = at[i].angle(&at[(i + 1) % k]);
            ((chord / opts.spacing).ceil())
                .max((turn / max_turn).ceil())
                .clamp(1.0, 1e6) as usize
        })
        .collect();
    let mut out = Vec::with_capacity(1 + steps.iter().sum::<usize>());
    out.push(PathPoint {
        p: points[0],
        axis: at[0],
        laser: false,
        layer,
    });
    for (i, &n) in steps.iter().enumerate() {
        let (p0, p1) = (points[i], points[(i + 1) % k]);
        let (a0, a1) = (at[i], at[(i + 1) % k]);
        for j in 1..=n {
            let s = j as f64 / n as f64;
            let axis = blend(a0 * (1.0 - s), a1 * s);
            out.push(PathPoint {
                p: p0 + (p1 - p0) * s,
                axis: if j == n { a1 } else { axis },
                laser: true,
                layer,
            });
        }
    }
    out
}

/// The perimeters of every loop of `slicing`, layer by layer, in the slicing's order.
pub fn perimeters(
    mesh: &Mesh,
    slicing: &Slicing,
    opts: &PerimeterOptions,
) -> Result<Vec<PathPoint>, PlanError> {
    check(opts)?;
    let mut out = Vec::new();
    for s in &slicing.slices {
        for l in &s.loops {
            out.extend(one_loop(mesh, &l.points, &l.faces, s.index, opts));
        }
    }
    Ok(out)
}

/// `opts` refused when the spacing or the turn is not a positive number.
pub(crate) fn check(opts: &PerimeterOptions) -> Result<(), PlanError> {
    if !(opts.spacing.is_finite() && opts.spacing > 0.0) {
        return Err(PlanError::Layer {
            what: "point spacing",
            value: opts.spacing,
            why: "not a positive number".into(),
        });
    }
    if !(opts.max_turn_deg.is_finite() && opts.max_turn_deg > 0.0) {
        return Err(PlanError::Layer {
            what: "largest tool-axis turn",
            value: opts.max_turn_deg,
            why: "not a positive number of degrees".into(),
        });
    }
    Ok(())
}

/// The path as the per-point file `lampost post` reads: a comment, the header `x y z i j
/// k feed laser`, a row per point. Positions to 6 places, directions to 9, each the text
/// `format!("{:.6}")` / `format!("{:.9}")` gives (by [`lampost_gcode::push_exact_fixed`]),
/// -0.0 written as 0.
pub fn to_text(points: &[PathPoint], feed: f64, comment: &str) -> String {
    use std::fmt::Write;
    let mut s = format!("# {}\nx y z i j k feed laser\n", comment.replace('\n', " "));
    s.reserve(points.len() * 80);
    let feed = feed.to_string();
    for q in points {
        for (k, (v, places)) in [
            (q.p.x, 6),
            (q.p.y, 6),
            (q.p.z, 6),
            (q.axis.x, 9),
            (q.axis.y, 9),
            (q.axis.z, 9),
        ]
        .into_iter()
        .enumerate()
        {
            if k > 0 {
                s.push(' ');
            }
            lampost_gcode::push_exact_fixed(&mut s, v + 0.0, places);
        }
        // Writing to a String cannot fail.
        let _ = writeln!(s, " {feed} {}", u8::from(q.laser));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slice::{slice, SliceOptions};

    #[test]
    fn walls_parallel_to_the_build_direction_get_it_as_the_tool_axis() {
        let m = lampost_mesh::box_mesh(P3::new(0.0, 0.0, 0.0), P3::new(20.0, 10.0, 6.0));
        let s = slice(&m, &SliceOptions::parallel(P3::z(), 1.0)).expect("slices");
        let opts = PerimeterOptions {
            spacing: 2.0,
            max_turn_deg: 2.0,
        };
        let pts = perimeters(&m, &s, &opts).expect("perimeters");
        assert_eq!(s.slices.len(), 6);
        assert!(!pts.is_empty());
        for q in &pts {
            assert!((q.axis - P3::z()).norm() < 1e-12, "{q:?}");
        }
        // Spaced to the chord: no two consecutive points of a loop more than 2 apart.
        for w in pts.windows(2) {
            if w[1].laser {
                assert!((w[1].p - w[0].p).norm() <= 2.0 + 1e-9);
            }
        }
    }

    #[test]
    fn on_a_sphere_the_axis_lies_in_the_surface_and_turns_gradually() {
        let r = 20.0;
        let m = lampost_mesh::uv_sphere(P3::zeros(), r, 48, 96);
        let s = slice(&m, &SliceOptions::parallel(P3::z(), 2.0)).expect("slices");
        let opts = PerimeterOptions {
            spacing: 1.0,
            max_turn_deg: 2.0,
        };
        let pts = perimeters(&m, &s, &opts).expect("perimeters");
        // The facets of a 48 × 96 sphere are within 3.75° of the exact surface's normal.
        let facet = (180.0f64 / 48.0).to_radians();
        for (k, q) in pts.iter().enumerate() {
            let radial = q.p / q.p.norm();
            assert!(
                q.axis.dot(&radial).abs() <= facet.sin() + 1e-9,
                "point {k}: {q:?}"
            );
            assert!((q.axis.norm() - 1.0).abs() < 1e-12);
            // Up the build on the upper half (the surface leans in), and never down
            // into the layer below.
            assert!(q.axis.z > 0.0, "point {k}: {q:?}");
            if k > 0 && q.laser && pts[k - 1].layer == q.layer {
                let turn = pts[k - 1].axis.angle(&q.axis).to_degrees();
                assert!(turn <= 2.0 + 1e-9, "point {k}: turned {turn}°");
            }
        }
    }
}
