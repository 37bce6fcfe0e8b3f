//! Verification: replay a posted program through the interpreter and forward kinematics
//! and compare every feed point's tool tip and tool axis with the intended path.

use std::io::BufRead;

use lampost_gcode::{Event, MoveKind, Options, Severity, Stream, Units, AXES};
use lampost_kinematics::{Joints, Machine, Units as MUnits};
use nalgebra::Vector3;

use crate::error::PostError;
use crate::intended::{Intended, IntendedOptions, Orient, Section, Step, StepKind};

/// What a verification found.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct VerifyReport {
    /// Moves in the posted program.
    pub moves: usize,
    /// Feed points compared (ends and arc midpoints).
    pub compared: usize,
    /// Largest distance from a posted tool tip to the intended path.
    pub max_position_error: f64,
    /// Largest angle between a posted tool axis and the intended one (degrees).
    pub max_axis_error_deg: f64,
    /// Posted line with the largest position error.
    pub worst_line: u32,
}

pub(crate) fn dist_to(step: &Step, p: &Vector3<f64>) -> f64 {
    match step.kind {
        StepKind::Arc {
            center,
            normal,
            sweep,
        } => {
            let n = normal; // unit by construction
            let rel = step.start - center;
            let rel = rel - n * n.dot(&rel);
            let q = p - center;
            let qp = q - n * n.dot(&q);
            if rel.norm() < 1e-12 || qp.norm() < 1e-12 {
                return (p - step.start).norm().min((p - step.end).norm());
            }
            // Angle of p from the start, right-handed about n, into the sweep's range.
            let mut ang = lampost_kinematics::trig::atan2_deg(n.dot(&rel.cross(&qp)), rel.dot(&qp))
                .to_radians();
            let tau = std::f64::consts::TAU;
            if sweep < 0.0 && ang > 0.0 {
                ang -= tau;
            } else if sweep > 0.0 && ang < 0.0 {
                ang += tau;
            }
            let t_raw = ang / sweep;
            let rise = (step.end - step.start).dot(&n);
            if rise.abs() <= 1e-12 * (1.0 + rel.norm()) && t_raw > 0.0 && t_raw < 1.0 {
                // A flat arc, p beside its interior: the nearest point of the arc is the
                // nearest of its circle, at p's angle.
                let radial = qp.norm() - rel.norm();
                let off_plane = n.dot(&q);
                return (radial * radial + off_plane * off_plane).sqrt();
            }
            let t = t_raw.clamp(0.0, 1.0);
            // Near the ends of multi-turn or near-full arcs, try the neighbours too.
            [t, 0.0, 1.0]
                .iter()
                .map(|&t| (p - step.at(t)).norm())
                .fold(f64::INFINITY, f64::min)
        }
        _ => {
            let d = step.end - step.start;
            let len2 = d.norm_squared();
            let t = if len2 > 0.0 {
                ((p - step.start).dot(&d) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p - (step.start + d * t)).norm()
        }
    }
}

/// One arc's points and distances for many points along it (the chord points of a
/// linearised arc): [`Step::at`] and [`dist_to`] with what depends only on the arc
/// worked out once. Results are bit-identical to theirs (the same operations on the same
/// values; tested).
pub(crate) struct ArcPoints {
    pub(crate) center: Vector3<f64>,
    pub(crate) n: Vector3<f64>,
    pub(crate) sweep: f64,
    /// start − centre, n × it, n · it, and the helix's rise (as [`Step::at`] has them).
    pub(crate) rel: Vector3<f64>,
    pub(crate) n_cross_rel: Vector3<f64>,
    pub(crate) n_dot_rel: f64,
    pub(crate) rise: f64,
    /// |start − centre| normal to n, when the arc is flat, within one turn and not
    /// degenerate (where [`dist_to`] has a closed form inside the sweep).
    pub(crate) flat_radius: Option<f64>,
}

impl ArcPoints {
    /// `None` unless `step` is an arc.
    pub(crate) fn new(step: &Step) -> Option<ArcPoints> {
        let StepKind::Arc {
            center,
            normal: n,
            sweep,
        } = step.kind
        else {
            return None;
        };
        let rel = step.start - center;
        let rise = (step.end - step.start).dot(&n);
        let rel_plane = rel - n * n.dot(&rel);
        let r = rel_plane.norm();
        let flat = rise.abs() <= 1e-12 * (1.0 + r) && r >= 1e-12;
        Some(ArcPoints {
            center,
            n,
            sweep,
            rel,
            n_cross_rel: n.cross(&rel),
            n_dot_rel: n.dot(&rel),
            rise,
            flat_radius: (flat && sweep.abs() <= std::f64::consts::TAU).then_some(r),
        })
    }

    /// [`Step::at`].
    #[inline]
    pub(crate) fn at(&self, t: f64) -> Vector3<f64> {
        let (s, c) = lampost_kinematics::trig::sin_cos_deg((self.sweep * t).to_degrees());
        let rotated = self.rel * c + self.n_cross_rel * s + self.n * (self.n_dot_rel * (1.0 - c));
        self.center + rotated + self.n * (self.rise * t)
    }

    /// [`dist_to`] for `p`, given that `p` lies near `at(t)` (`near`). When `p` is
    /// provably inside the sweep (its angle from `near` is under half the angle from
    /// `near` to either end: `|p − near| < (m/π)·|p's radius|`, m that angle capped at
    /// 90°, bounds the sine of that angle), a flat arc's distance is the closed form
    /// [`dist_to`] takes there, with no arctangent; otherwise [`dist_to`] itself.
    #[inline]
    pub(crate) fn dist_near(
        &self,
        step: &Step,
        p: &Vector3<f64>,
        near: &Vector3<f64>,
        t: f64,
    ) -> f64 {
        if let Some(r) = self.flat_radius {
            let n = self.n;
            let q = p - self.center;
            let qp = q - n * n.dot(&q);
            let qn = qp.norm();
            let m = (t.min(1.0 - t) * self.sweep.abs()).min(std::f64::consts::FRAC_PI_2);
            let s = m * std::f64::consts::FRAC_1_PI;
            if qn >= 1e-12 && t > 0.0 && t < 1.0 && (p - near).norm_squared() < s * s * qn * qn {
                let radial = qn - r;
                let off_plane = n.dot(&q);
                return (radial * radial + off_plane * off_plane).sqrt();
            }
        }
        dist_to(step, p)
    }
}

/// Replay `posted` and compare it with the intended path of `sections`.
pub fn verify<R: BufRead>(
    machine: &Machine,
    sections: &[Section],
    head: usize,
    opts: IntendedOptions,
    posted: R,
    tolerance: f64,
) -> Result<VerifyReport, PostError> {
    let units = match machine.units {
        MUnits::Inch => Units::Inch,
        MUnits::Mm => Units::Mm,
    };
    let idx = |name: &str| {
        name.bytes()
            .next()
            .and_then(|c| AXES.iter().position(|&a| a == c.to_ascii_uppercase()))
    };
    let names = machine.axis_names();
    let lin_idx: Vec<usize> = names[..3].iter().map(|n| idx(n).unwrap_or(0)).collect();
    let rot_idx: Vec<usize> = names[3..].iter().map(|n| idx(n).unwrap_or(3)).collect();
    let mut intended = Intended::new(machine, sections, opts).filter(|s| {
        !matches!(
            s,
            Ok(Step {
                kind: StepKind::Rapid,
                ..
            })
        )
    });
    let mut current: Option<Step> = None;
    let mut rep = VerifyReport::default();
    let intended_axis = |s: &Step| match s.orient(sections) {
        Orient::ToolAxis => s.program_z(sections).normalize(),
        Orient::Index(r) => {
            machine
                .forward(
                    &Joints {
                        linear: [0.0; 3],
                        rotary: r,
                    },
                    head,
                )
                .axis
        }
    };
    // Forward kinematics with the rotaries' sin/cos kept between points (they change per
    // section or layer, not per point).
    let cache = std::cell::Cell::new(([f64::NAN; 2], [(0.0, 1.0); 2]));
    let tool = machine.tool_axis;
    let fk = |j: &[f64; 9]| {
        let rot = [j[rot_idx[0]], j[rot_idx[1]]];
        let (r, sc) = cache.get();
        let sc = if r == rot {
            sc
        } else {
            let sc = [
                lampost_kinematics::trig::sin_cos_deg(rot[0]),
                lampost_kinematics::trig::sin_cos_deg(rot[1]),
            ];
            cache.set((rot, sc));
            sc
        };
        let q = machine.head_point(&[j[lin_idx[0]], j[lin_idx[1]], j[lin_idx[2]]], head);
        let inv = [(-sc[0].0, sc[0].1), (-sc[1].0, sc[1].1)];
        let origin = machine.machine_to_part_sc(&inv, &Vector3::zeros());
        lampost_kinematics::Pose {
            tip: machine.machine_to_part_sc(&inv, &q),
            axis: machine.machine_to_part_sc(&inv, &tool) - origin,
        }
    };
    let mut check = |p: Vector3<f64>,
                     a: Vector3<f64>,
                     line: u32,
                     is_end: bool,
                     current: &mut Option<Step>,
                     rep: &mut VerifyReport|
     -> Result<(), PostError> {
        if current.is_none() {
            *current = intended.next().transpose()?;
        }
        let Some(step) = *current else {
            return Err(PostError::Verify(format!("posted line {line} feeds to ({:.5}, {:.5}, {:.5}) after the intended path has ended", p.x, p.y, p.z)));
        };
        let d_end = (p - step.end).norm();
        let err = if is_end && d_end <= tolerance {
            *current = None;
            d_end
        } else {
            let d = dist_to(&step, &p);
            if d > tolerance {
                return Err(PostError::Verify(format!(
                    "posted line {line}: the tool tip ({:.5}, {:.5}, {:.5}) is {d:.3e} from the intended path of input line {} (tolerance {tolerance:.1e})",
                    p.x, p.y, p.z, step.line
                )));
            }
            d
        };
        let want = intended_axis(&step);
        let ang = a.cross(&want).norm().atan2(a.dot(&want)).to_degrees();
        rep.compared += 1;
        if err > rep.max_position_error {
            rep.max_position_error = err;
            rep.worst_line = line;
        }
        rep.max_axis_error_deg = rep.max_axis_error_deg.max(ang);
        Ok(())
    };
    let stream = Stream::from_reader(
        posted,
        Options {
            units,
            ..Options::default()
        },
        true,
    );
    for ev in stream {
        match ev.map_err(|e| PostError::Io(e.to_string()))? {
            Event::Diagnostic(d) if d.severity == Severity::Error => {
                return Err(PostError::Input {
                    file: "the posted program".into(),
                    diag: Box::new(d),
                });
            }
            Event::Diagnostic(_) => {}
            Event::Move(m) => {
                rep.moves += 1;
                match m.kind {
                    MoveKind::Rapid => {}
                    MoveKind::Linear | MoveKind::Probe => {
                        let pose = fk(&m.end);
                        check(pose.tip, pose.axis, m.line, true, &mut current, &mut rep)?;
                    }
                    MoveKind::Arc {
                        clockwise,
                        center,
                        turns,
                        ..
                    } => {
                        // The midpoint in joint space (XY plane), then the end.
                        let (sx, sy) = (m.start[0] - center[0], m.start[1] - center[1]);
                        let (ex, ey) = (m.end[0] - center[0], m.end[1] - center[1]);
                        let tau = std::f64::consts::TAU;
                        let delta = ey.atan2(ex) - sy.atan2(sx);
                        let full = (sx - ex).hypot(sy - ey) < 1e-9;
                        let sweep = if clockwise {
                            (if full {
                                -tau
                            } else {
                                delta.rem_euclid(tau) - tau
                            }) - tau * f64::from(turns.saturating_sub(1))
                        } else {
                            (if full { tau } else { delta.rem_euclid(tau) })
                                + tau * f64::from(turns.saturating_sub(1))
                        };
                        let a = sy.atan2(sx) + sweep / 2.0;
                        let r = sx.hypot(sy);
                        let mut mid = m.end;
                        mid[0] = center[0] + r * a.cos();
                        mid[1] = center[1] + r * a.sin();
                        mid[2] = (m.start[2] + m.end[2]) / 2.0;
                        let pm = fk(&mid);
                        check(pm.tip, pm.axis, m.line, false, &mut current, &mut rep)?;
                        let pe = fk(&m.end);
                        check(pe.tip, pe.axis, m.line, true, &mut current, &mut rep)?;
                    }
                }
            }
        }
    }
    let rest = match current {
        Some(s) => Some(s),
        None => intended.next().transpose()?,
    };
    if let Some(s) = rest {
        return Err(PostError::Verify(format!(
            "the posted program ends before the move of input line {} (to ({:.5}, {:.5}, {:.5}))",
            s.line, s.end.x, s.end.y, s.end.z
        )));
    }
    Ok(rep)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::{dist_to, ArcPoints};
    use crate::intended::{Step, StepKind};
    use nalgebra::Vector3;
    use proptest::prelude::*;

    /// An arc step of radius `r` about `center` in the plane normal to `normal`, from
    /// angle `a0` through `sweep`, rising `rise` along the normal (for tests).
    pub(crate) fn arc(
        center: Vector3<f64>,
        normal: Vector3<f64>,
        r: f64,
        a0: f64,
        sweep: f64,
        rise: f64,
    ) -> Step {
        let n = normal.normalize();
        // A unit vector normal to n, turned by a0 about n.
        let helper = if n.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let u = n.cross(&helper).normalize();
        let v = n.cross(&u);
        let start = center + (u * a0.cos() + v * a0.sin()) * r;
        let a1 = a0 + sweep;
        let end = center + (u * a1.cos() + v * a1.sin()) * r + n * rise;
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
            deposit: false,
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]
        /// The chord-point helpers give exactly what `Step::at` and `dist_to` give, for
        /// points near, on, off and beyond flat and helical arcs of up to two turns.
        #[test]
        fn arc_points_match_step_at_and_dist_to(
            c in prop::array::uniform3(-100.0f64..100.0),
            nrm in prop::array::uniform3(-1.0f64..1.0),
            r in 0.001f64..200.0,
            a0 in -7.0f64..7.0,
            sweep in prop_oneof![-12.6f64..12.6, Just(std::f64::consts::TAU), Just(-std::f64::consts::PI)],
            helix in prop::bool::weighted(0.2),
            k in 0usize..=64,
            n in 1usize..=64,
            off in prop::array::uniform3(-1.0f64..1.0),
            scale_exp in -12i32..1,
        ) {
            let normal = Vector3::from(nrm);
            prop_assume!(normal.norm() > 0.1);
            let step = arc(Vector3::from(c), normal, r, a0, sweep, if helix { 0.3 * r } else { 0.0 });
            let Some(ap) = ArcPoints::new(&step) else { panic!("an arc") };
            let t = (k.min(n)) as f64 / n as f64;
            let near = ap.at(t);
            prop_assert_eq!(near, step.at(t));
            let p = near + Vector3::from(off) * (r * 10f64.powi(scale_exp));
            prop_assert_eq!(ap.dist_near(&step, &p, &near, t).to_bits(), dist_to(&step, &p).to_bits());
        }
    }
}
