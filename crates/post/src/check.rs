//! The in-process check of written feed points: the joints as the text gives them
//! (rounded to the output resolution), through the written index's tip map, against the
//! intended move; the tool axis against the intended one. Its caches keep the forward
//! kinematics and the axis comparison per table position and orientation.

use lampost_kinematics::{Affine, Machine};
use nalgebra::Vector3;

use crate::error::PostError;
use crate::intended::{Orient, Step};
use crate::post::{index_maps, written_rotary, written_tip, EndCheck, PostConfig};
use crate::verify::VerifyReport;

/// What the check of written feed points keeps between points.
#[derive(Debug)]
pub(crate) struct FeedCheck {
    /// The feed step being written, for the in-process verification.
    pub(crate) step: Option<Step>,
    /// (rotary, tip map of it as written), for forward kinematics.
    pub(crate) fk_cache: ([f64; 2], Affine),
    /// The tool axis (part frame) at the written rotary, with `fk_cache`.
    pub(crate) fk_axis: Vector3<f64>,
    /// The current section's orientation rule and its layer's program +Z (set with
    /// [`FeedCheck::set_orientation`]).
    orient: Orient,
    program_z: Vector3<f64>,
    /// The angle (degrees) between the written tool axis and the intended one: it
    /// changes only with the rotaries (`fk_cache`) or the orientation, and is worked
    /// out again (`None`) whenever either is set.
    axis_err: Option<f64>,
    /// The largest distance a written point may have from the intended path.
    pub(crate) tol: f64,
    /// A point planned on the reading thread: (joints, is the step's end, its check).
    pub(crate) planned_check: Option<([f64; 3], bool, EndCheck)>,
    /// While a linearised arc is written: how far its chords leave the arc between
    /// their points (the chord's sagitta), added to each point's distance. `verify`
    /// checks the middle of every written segment too; the middle of a chord lies at most
    /// this plus the larger of its ends' distances from the arc, so the check here is
    /// never the weaker one.
    pub(crate) bulge: f64,
}

impl FeedCheck {
    pub(crate) fn new(machine: &Machine, cfg: &PostConfig) -> Self {
        FeedCheck {
            step: None,
            fk_cache: ([f64::NAN; 2], index_maps(machine, cfg.head, &[0.0; 2]).1),
            fk_axis: Vector3::z(),
            orient: Orient::ToolAxis,
            program_z: Vector3::z(),
            axis_err: None,
            tol: cfg.verify_tolerance,
            planned_check: None,
            bulge: 0.0,
        }
    }

    /// The orientation rule of the section and the program +Z of the layer being
    /// written.
    pub(crate) fn set_orientation(&mut self, orient: Orient, program_z: Vector3<f64>) {
        self.orient = orient;
        self.program_z = program_z;
        self.axis_err = None;
    }

    pub(crate) fn orient(&self) -> Orient {
        self.orient
    }

    pub(crate) fn program_z(&self) -> Vector3<f64> {
        self.program_z
    }

    /// Check a written feed point: the joints as the text gives them (rounded to the
    /// output resolution), through forward kinematics, against the intended move.
    /// (The common path: a point the reading thread planned, under a table position
    /// and orientation already seen; the rest is in the out-of-line helpers below.)
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn point(
        &mut self,
        m: &Machine,
        head: usize,
        scale: f64,
        rot: &[f64; 2],
        report: &mut VerifyReport,
        x: &[f64; 3],
        is_end: bool,
    ) -> Result<(), PostError> {
        let Some(line) = self.step.as_ref().map(|s| s.line) else {
            return Ok(());
        };
        if self.fk_cache.0 != *rot {
            self.turn_to(m, head, rot);
        }
        let err = match self.planned_check {
            // Worked out on the reading thread, for these very joints (with the same
            // end-or-path rule).
            Some((j, end, e)) if end == is_end && j == *x => e,
            _ => self.distance(scale, x, is_end),
        } + self.bulge;
        if err > self.tol {
            return Err(self.off_path(scale, x, line, err));
        }
        let ang = match self.axis_err {
            Some(e) => e,
            None => self.axis_angle(m, head),
        };
        let v = report;
        v.compared += 1;
        if err > v.max_position_error {
            v.max_position_error = err;
            v.worst_line = line;
        }
        if ang > v.max_axis_error_deg {
            v.max_axis_error_deg = ang;
        }
        if ang > 0.01 {
            return Err(PostError::Verify(format!(
                "input line {line}: the tool axis is {ang:.4}° off"
            )));
        }
        Ok(())
    }

    /// The tip map and tool axis of the written rotaries `rot`.
    #[inline(never)]
    fn turn_to(&mut self, m: &Machine, head: usize, rot: &[f64; 2]) {
        let (_, inv) = written_rotary(rot);
        self.fk_cache = (*rot, m.tip_map(&inv, head));
        self.fk_axis = m.machine_to_part_sc(&inv, &m.tool_axis)
            - m.machine_to_part_sc(&inv, &Vector3::zeros());
        self.axis_err = None;
    }

    /// How far the written point `x` lands from the step: from its end when `is_end`,
    /// else from its path (a point not planned on the reading thread).
    #[inline(never)]
    fn distance(&self, scale: f64, x: &[f64; 3], is_end: bool) -> f64 {
        let tip = written_tip(&self.fk_cache.1, scale, x);
        match &self.step {
            Some(step) if is_end => (tip - step.end).norm(),
            Some(step) => crate::verify::dist_to(step, &tip),
            None => 0.0,
        }
    }

    /// The angle (degrees) between the written tool axis and the intended one, kept
    /// until the table position or the orientation changes.
    #[inline(never)]
    fn axis_angle(&mut self, m: &Machine, head: usize) -> f64 {
        let want = match self.orient {
            Orient::ToolAxis => self.program_z.normalize(),
            Orient::Index(r) => {
                m.forward(
                    &lampost_kinematics::Joints {
                        linear: [0.0; 3],
                        rotary: r,
                    },
                    head,
                )
                .axis
            }
        };
        let axis = self.fk_axis;
        let e = axis.cross(&want).norm().atan2(axis.dot(&want)).to_degrees();
        self.axis_err = Some(e);
        e
    }

    /// The error for a written point `err` from the intended path.
    #[cold]
    #[inline(never)]
    fn off_path(&self, scale: f64, x: &[f64; 3], line: u32, err: f64) -> PostError {
        let tip = written_tip(&self.fk_cache.1, scale, x);
        PostError::Verify(format!(
            "input line {}: a written point ({:.5}, {:.5}, {:.5}) is {err:.3e} from the intended path (tolerance {:.1e})",
            line, tip.x, tip.y, tip.z, self.tol
        ))
    }
}
