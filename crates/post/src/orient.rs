//! The rotaries of a section or layer: a fixed index as given (within travel), or the
//! orientation that turns the program's +Z to the tool axis, on the same branch as the
//! last one where the limits allow (the rule [`Machine::choose`] keeps for points).
//! A new orientation strategy belongs here, with its CLI flag.

use lampost_kinematics::{KinError, Machine};
use nalgebra::Vector3;

use crate::error::PostError;
use crate::intended::Orient;

/// The rotaries (file order) for orientation `orient` whose program +Z is `program_z`
/// (part frame), nearest `near`, keeping `branch` where possible; and the branch chosen
/// (`None` for a fixed index). A branch flip is noted in `warnings`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn rotaries(
    machine: &Machine,
    orient: Orient,
    program_z: &Vector3<f64>,
    near: &[f64; 2],
    branch: Option<i8>,
    file: &str,
    line: u32,
    warnings: &mut Vec<String>,
) -> Result<([f64; 2], Option<i8>), PostError> {
    match orient {
        Orient::Index(r) => {
            for (i, ax) in machine.rotary.iter().enumerate() {
                if !r[i].is_finite() || !ax.within(r[i]) {
                    let (lo, hi) = ax.limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
                    return Err(PostError::Limit {
                        file: file.to_string(),
                        line,
                        axis: ax.name.clone(),
                        value: r[i],
                        lo,
                        hi,
                    });
                }
            }
            Ok((r, None))
        }
        Orient::ToolAxis => {
            let sols = machine
                .orientations(program_z, near)
                .map_err(|err| PostError::Kin {
                    context: format!("{file}:{line}: "),
                    err,
                })?;
            let same = sols.iter().find(|s| {
                s.within_limits && branch.is_none_or(|b| s.branch == 0 || b == 0 || s.branch == b)
            });
            let pick = match same {
                Some(s) => *s,
                None => match sols.iter().find(|s| s.within_limits) {
                    Some(s) => {
                        warnings.push(format!(
                            "{file}:{line}: the rotary branch flips here; the tool retracts and re-approaches"
                        ));
                        *s
                    }
                    None => {
                        let names: Vec<String> = machine
                            .rotary
                            .iter()
                            .map(|r| format!("{} {:?}", r.name, r.limits))
                            .collect();
                        let cands: Vec<String> = sols
                            .iter()
                            .map(|s| {
                                format!(
                                    "{} = {:.3}°, {} = {:.3}°",
                                    machine.rotary[0].name,
                                    s.rotary[0],
                                    machine.rotary[1].name,
                                    s.rotary[1]
                                )
                            })
                            .collect();
                        return Err(PostError::Kin {
                            context: format!("{file}:{line}: "),
                            err: KinError::Unreachable {
                                what: format!(
                                    "no orientation within the rotary limits ({}) turns the program's +Z ({:.4}, {:.4}, {:.4}) to the tool axis; candidates {}",
                                    names.join(", "),
                                    program_z.x,
                                    program_z.y,
                                    program_z.z,
                                    cands.join("; ")
                                ),
                            },
                        });
                    }
                },
            };
            Ok((pick.rotary, Some(pick.branch)))
        }
    }
}
