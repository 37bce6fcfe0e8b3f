//! Safe heights: where the work is, and how high the head must be to travel over it.
//!
//! The work is every tool tip the program feeds through (deposited or cut), over all
//! sections, as a box in the part frame, plus a part or stock given by the user (the
//! vertices of its convex hull, or the stock box's corners). For a fixed table position
//! the highest point of that in machine Z is at one of those points (the joints map is
//! affine), so the safe height of an index is exact for them: the larger of the machine's `clearance_z` and that height plus the machine's
//! `safe_margin`. A rotary move happens at a height safe for every table position it
//! passes through (sampled at most 1° apart, plus what a corner can rise between samples).

use lampost_kinematics::trig::sin_cos_deg;
use lampost_kinematics::Machine;
use nalgebra::Vector3;

use crate::error::PostError;
use crate::intended::{Intended, IntendedOptions, Section, Step, StepKind};

/// The work in the part frame: a box holding every feed tip, and points of a part or
/// stock (the vertices of its convex hull, or a box's corners). The highest point of the
/// work in any direction is one of [`WorkBounds::extremes`].
#[derive(Debug, Clone, PartialEq)]
pub struct WorkBounds {
    /// Lowest corner of the feed tips' box.
    pub min: Vector3<f64>,
    /// Highest corner of the feed tips' box.
    pub max: Vector3<f64>,
    /// Points of a part or stock.
    pub points: Vec<Vector3<f64>>,
}

impl WorkBounds {
    /// No work yet.
    pub fn empty() -> Self {
        WorkBounds {
            min: Vector3::repeat(f64::INFINITY),
            max: Vector3::repeat(f64::NEG_INFINITY),
            points: Vec::new(),
        }
    }

    /// True when nothing was added.
    pub fn is_empty(&self) -> bool {
        self.box_empty() && self.points.is_empty()
    }

    fn box_empty(&self) -> bool {
        (0..3).any(|k| self.min[k] > self.max[k])
    }

    /// Grow the box to hold `p`.
    pub fn add(&mut self, p: &Vector3<f64>) {
        self.min = self.min.inf(p);
        self.max = self.max.sup(p);
    }

    /// Add points of a part or stock.
    pub fn add_points(&mut self, pts: impl IntoIterator<Item = Vector3<f64>>) {
        self.points.extend(pts);
    }

    /// Grow to hold another's work.
    pub fn union(&mut self, o: &WorkBounds) {
        if !o.box_empty() {
            self.add(&o.min);
            self.add(&o.max);
        }
        self.points.extend_from_slice(&o.points);
    }

    /// Grow to hold the path of a feed step: a line by its ends, an arc by the part of
    /// its circle it sweeps (the whole circle from a turn on).
    pub fn add_step(&mut self, s: &Step) {
        match s.kind {
            StepKind::Rapid | StepKind::Retract | StepKind::Stop(_) | StepKind::ToolChange(_) => {}
            StepKind::Feed => {
                self.add(&s.start);
                self.add(&s.end);
            }
            StepKind::Arc {
                center,
                normal,
                sweep,
            } => {
                self.add(&s.start);
                self.add(&s.end);
                let n = normal;
                let rel = s.start - center;
                let radial = rel - n * n.dot(&rel);
                let r = radial.norm();
                let rise = n * n.dot(&(s.end - s.start));
                if r.is_nan() || r <= 0.0 {
                    return;
                }
                if sweep.is_nan() || sweep.abs() >= std::f64::consts::TAU {
                    // The whole circle (its extent along axis k is r·√(1 − n_k²)), at the
                    // start's level and at the end's (a helix rises between them).
                    let half = Vector3::new(
                        r * (1.0 - n.x * n.x).max(0.0).sqrt(),
                        r * (1.0 - n.y * n.y).max(0.0).sqrt(),
                        r * (1.0 - n.z * n.z).max(0.0).sqrt(),
                    );
                    for c in [center, center + rise] {
                        self.add(&(c - half));
                        self.add(&(c + half));
                    }
                    return;
                }
                // The point at angle θ from the start is c + r(u cos θ + v sin θ): along
                // axis k it is greatest at θ = atan2(v_k, u_k) and least half a turn on;
                // each of those within the sweep is added, at the start's level and the
                // end's. (A near-straight arc fitted by a slicer, radius 2 m over 1.5 mm,
                // is its 1.5 mm, not a 4 m circle.)
                // The ends at both levels too: along the helix the rise adds to the
                // flat arc's extent anywhere between 0 and all of it.
                self.add(&(s.start + rise));
                self.add(&(s.end - rise));
                let u = radial / r;
                let v = n.cross(&u);
                for k in 0..3 {
                    let top = v[k].atan2(u[k]);
                    for phi in [top, top + std::f64::consts::PI] {
                        let a = if sweep >= 0.0 {
                            phi.rem_euclid(std::f64::consts::TAU)
                        } else {
                            phi.rem_euclid(std::f64::consts::TAU) - std::f64::consts::TAU
                        };
                        let within = if sweep >= 0.0 { a <= sweep } else { a >= sweep };
                        if within {
                            let p = center + (u * a.cos() + v * a.sin()) * r;
                            self.add(&p);
                            self.add(&(p + rise));
                        }
                    }
                }
            }
        }
    }

    /// The points that bound the work: the box's eight corners and the part's points.
    pub fn extremes(&self) -> impl Iterator<Item = Vector3<f64>> + '_ {
        let n = if self.box_empty() { 0 } else { 8 };
        (0..n)
            .map(move |i| {
                Vector3::new(
                    if i & 1 == 0 { self.min.x } else { self.max.x },
                    if i & 2 == 0 { self.min.y } else { self.max.y },
                    if i & 4 == 0 { self.min.z } else { self.max.z },
                )
            })
            .chain(self.points.iter().copied())
    }

    /// Every feed tip of `sections`' intended path (one pass over the input), read as
    /// the post reads it for `process`.
    pub fn of_program(
        machine: &Machine,
        sections: &[Section],
        opts: IntendedOptions,
        process: &crate::post::Process,
    ) -> Result<WorkBounds, PostError> {
        let mut b = WorkBounds::empty();
        for s in Intended::new(machine, sections, opts).holding_spindle(process) {
            b.add_step(&s?);
        }
        Ok(b)
    }
}

/// Safe heights of a machine, head and work.
#[derive(Debug, Clone)]
pub struct SafeHeights<'m> {
    m: &'m Machine,
    head: usize,
    work: WorkBounds,
    margin: f64,
    clearance: f64,
}

impl<'m> SafeHeights<'m> {
    /// Safe heights over `work` for `head` (the machine's clearance and margin).
    pub fn new(m: &'m Machine, head: usize, work: WorkBounds) -> Result<Self, PostError> {
        let s = SafeHeights {
            m,
            head,
            work,
            margin: m.safe_margin(),
            clearance: m.def.process.clearance_z,
        };
        // The post lifts by raising the Z joint: that must move the head away from the
        // table (true of every table machine lampost knows).
        let sc = [sin_cos_deg(0.0); 2];
        let map = m.joints_map(&sc, head);
        let up = m.machine_to_part_sc(&[(0.0, 1.0); 2], &m.tool_axis)
            - m.machine_to_part_sc(&[(0.0, 1.0); 2], &Vector3::zeros());
        if map.apply(&up).z - map.apply(&Vector3::zeros()).z <= 0.0 {
            return Err(PostError::Options(format!(
                "machine {}: raising its Z joint does not move the head away from the table; the post cannot derive safe heights for it",
                m.def.name
            )));
        }
        Ok(s)
    }

    /// The work box.
    pub fn work(&self) -> &WorkBounds {
        &self.work
    }

    /// The highest point of the work in machine Z (the Z joint that puts the tip there)
    /// at table position `rot`, or `None` without work.
    pub fn work_top(&self, rot: &[f64; 2]) -> Option<f64> {
        if self.work.is_empty() {
            return None;
        }
        let sc = [sin_cos_deg(rot[0]), sin_cos_deg(rot[1])];
        let map = self.m.joints_map(&sc, self.head);
        Some(
            self.work
                .extremes()
                .map(|c| map.apply(&c).z)
                .fold(f64::NEG_INFINITY, f64::max),
        )
    }

    /// The retract height at `rot`.
    pub fn at(&self, rot: &[f64; 2]) -> f64 {
        match self.work_top(rot) {
            Some(t) => self.clearance.max(t + self.margin),
            None => self.clearance,
        }
    }

    /// A height safe for the whole rotary move from `from` to `to` (both axes turning
    /// together, linearly).
    pub fn over_move(&self, from: &[f64; 2], to: &[f64; 2]) -> f64 {
        let top = sweep_positions(from, to)
            .filter_map(|(_, r)| self.work_top(&r))
            .fold(f64::NEG_INFINITY, f64::max);
        if !top.is_finite() {
            return self.clearance;
        }
        self.clearance
            .max(top + self.margin + sweep_slack(self.m, &self.work, from, to))
    }

    /// The top of the machine's Z travel.
    pub fn z_limit(&self) -> f64 {
        self.m.linear[2].limits.1
    }
}

/// How far above a start the vertical approach stops before feeding in: 0.1 in / 2.5 mm.
pub fn approach_lift(m: &Machine) -> f64 {
    match m.units {
        lampost_kinematics::Units::Inch => 0.1,
        lampost_kinematics::Units::Mm => 2.5,
    }
}

/// The part-mesh check of one rapid, shared by the post's in-process check and `verify`:
/// from joints `xs` (rotaries `rs`) to `xe` (`re`), the tool tip's path and the head (a
/// cylinder of the machine's `head_radius` and `head_length` along the tool axis, from
/// the tip) must not meet the part. A table turn is checked at table positions at most
/// 1° apart, the head standing. A lift off the end of a run (`lifting`) starts on the
/// work: its first approach lift is not checked. `Err` holds what was met, for a
/// message.
#[allow(clippy::too_many_arguments)]
pub(crate) fn rapid_meets_part(
    m: &Machine,
    head: usize,
    part: &crate::collide::PartMesh,
    xs: &[f64; 3],
    rs: &[f64; 2],
    xe: &[f64; 3],
    re: &[f64; 2],
    lifting: bool,
) -> Result<Option<String>, PostError> {
    let pose = |x: &[f64; 3], r: &[f64; 2]| {
        let p = m.forward(
            &lampost_kinematics::Joints {
                linear: *x,
                rotary: *r,
            },
            head,
        );
        (p.tip, p.axis.normalize())
    };
    let (radius, length) = (m.head_radius(), m.head_length());
    if rs != re {
        for (t, r) in sweep_positions(rs, re) {
            let x = [
                xs[0] + (xe[0] - xs[0]) * t,
                xs[1] + (xe[1] - xs[1]) * t,
                xs[2] + (xe[2] - xs[2]) * t,
            ];
            let (tip, axis) = pose(&x, &r);
            if let Some(h) = part.head_hits(&tip, &tip, &axis, radius, length, 0.0)? {
                return Ok(Some(format!(
                    "the table turning through {:.3}°, {:.3}° brings the part against the head at ({:.4}, {:.4}, {:.4})",
                    r[0], r[1], h.point.x, h.point.y, h.point.z
                )));
            }
        }
        return Ok(None);
    }
    let (mut a, axis) = pose(xs, rs);
    let (b, _) = pose(xe, re);
    if lifting {
        let len = (b - a).norm();
        if len <= approach_lift(m) {
            return Ok(None);
        }
        a += (b - a) * (approach_lift(m) / len);
    }
    if let Some(h) = part.segment_hits(&a, &b)? {
        return Ok(Some(format!(
            "a rapid's tool tip meets the part at ({:.4}, {:.4}, {:.4})",
            h.point.x, h.point.y, h.point.z
        )));
    }
    if let Some(h) = part.head_hits(&a, &b, &axis, radius, length, 0.0)? {
        return Ok(Some(format!(
            "a rapid brings the head (radius {radius}, length {length}) against the part at ({:.4}, {:.4}, {:.4})",
            h.point.x, h.point.y, h.point.z
        )));
    }
    Ok(None)
}

/// Table positions along a rotary move from `from` to `to` (both axes turning together,
/// linearly), at most 1° apart, both ends included: (fraction of the move, position).
pub(crate) fn sweep_positions(
    from: &[f64; 2],
    to: &[f64; 2],
) -> impl Iterator<Item = (f64, [f64; 2])> {
    let (from, to) = (*from, *to);
    let span = (to[0] - from[0]).abs().max((to[1] - from[1]).abs());
    let n = (span.ceil() as usize).clamp(1, 100_000);
    (0..=n).map(move |k| {
        let t = k as f64 / n as f64;
        (
            t,
            [
                from[0] + (to[0] - from[0]) * t,
                from[1] + (to[1] - from[1]) * t,
            ],
        )
    })
}

/// How far a point of `work` can rise between two of [`sweep_positions`] (at most 1°
/// apart): a point at distance d from an axis rises at most d·(1 − cos 0.5°) above the
/// higher of its neighbouring samples. Zero for a move of one step.
pub(crate) fn sweep_slack(m: &Machine, work: &WorkBounds, from: &[f64; 2], to: &[f64; 2]) -> f64 {
    if (to[0] - from[0]).abs().max((to[1] - from[1]).abs()) <= 1.0 {
        return 0.0;
    }
    let reach = work.extremes().map(|c| c.norm()).fold(0.0, f64::max)
        + m.rotary.iter().map(|r| r.pivot.norm()).fold(0.0, f64::max);
    reach * (1.0 - 0.5f64.to_radians().cos())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn arc_step(
        center: Vector3<f64>,
        n: Vector3<f64>,
        start: Vector3<f64>,
        sweep: f64,
        rise: f64,
    ) -> Step {
        let u = start - center;
        let v = n.cross(&u);
        let end = center + u * sweep.cos() + v * sweep.sin() + n * rise;
        Step {
            section: 0,
            layer: 0,
            line: 1,
            kind: StepKind::Arc {
                center,
                normal: n,
                sweep,
            },
            start,
            end,
            feed: 100.0,
            deposit: true,
            tool: 0,
        }
    }

    proptest! {
        /// The box of an arc holds every point of it (sampled at 2,000 angles, the helix
        /// rising evenly), and is no larger than the whole circle's.
        #[test]
        fn an_arcs_box_holds_the_arc(
            c in prop::array::uniform3(-50.0f64..50.0),
            n in prop::array::uniform3(-1.0f64..1.0),
            d in prop::array::uniform3(-1.0f64..1.0),
            r in 0.01f64..2000.0,
            sweep in -7.0f64..7.0,
            rise in -5.0f64..5.0,
        ) {
            let n = Vector3::from(n);
            prop_assume!(n.norm() > 0.1);
            let n = n.normalize();
            let d = Vector3::from(d);
            let radial = d - n * n.dot(&d);
            prop_assume!(radial.norm() > 0.1);
            let center = Vector3::from(c);
            let start = center + radial.normalize() * r;
            let s = arc_step(center, n, start, sweep, rise);
            let mut b = WorkBounds::empty();
            b.add_step(&s);
            let u = (start - center) / r;
            let v = n.cross(&u);
            let tol = 1e-9 * (1.0 + r);
            for i in 0..=2000 {
                let t = f64::from(i) / 2000.0;
                let a = sweep * t;
                let p = center + (u * a.cos() + v * a.sin()) * r + n * (rise * t);
                for k in 0..3 {
                    prop_assert!(p[k] >= b.min[k] - tol && p[k] <= b.max[k] + tol,
                        "axis {k}: {} outside [{}, {}] at t {t}", p[k], b.min[k], b.max[k]);
                }
            }
            let mut whole = WorkBounds::empty();
            whole.add_step(&arc_step(center, n, start, 7.0, rise));
            for k in 0..3 {
                prop_assert!(b.min[k] >= whole.min[k] - tol && b.max[k] <= whole.max[k] + tol);
            }
        }
    }

    /// h62: an arc-fitted slicer's near-straight arc (radius 2 m, 1.5 mm long) is its
    /// 1.5 mm, not a 4 m circle (the tilted post asked for a retract above its travel).
    #[test]
    fn a_near_straight_arc_is_as_tall_as_its_chord() {
        let center = Vector3::new(0.75, -2000.0, 0.0);
        let start = Vector3::new(0.0, 0.0, 0.0);
        let r: f64 = (start - center).norm();
        let sweep = -2.0 * (0.75 / r).asin();
        let s = arc_step(center, Vector3::z(), start, sweep, 0.0);
        let mut b = WorkBounds::empty();
        b.add_step(&s);
        assert!((b.max - b.min).norm() < 1.6, "{:?} {:?}", b.min, b.max);
    }
}
