//! Reduction: each reading r of the sensor back to workpiece coordinates. The surface is
//! at `z_m = z_t − r` along the beam; with the machine at the row's position, forward
//! kinematics gives the sensor's zero and the beam in the part frame, and the measured
//! point is `zero − r·beam` (on the NRC cell this is paper 003's eq. (3) applied to
//! `[x_t, y_t, z_m]`). A reading beyond the sensor's range, or none, is flagged with its
//! id, never dropped.

use lampost_kinematics::{Machine, Vector3};
use serde::Serialize;

use crate::error::InspectError;
use crate::plan::{sensor, PlanRow};

/// One reading of a log.
#[derive(Debug, Clone, PartialEq)]
pub enum Reading {
    /// A distance r from the sensor's zero along the beam (positive: farther).
    Value(f64),
    /// No reading (the sensor saw nothing), with what the log said.
    None(String),
}

/// What became of a plan row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Measured.
    Ok,
    /// The reading is beyond the sensor's range.
    OutOfRange,
    /// The sensor gave no reading.
    NoReading,
    /// The log has no line for this point.
    Missing,
}

/// A reduced point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measured {
    /// The point's id.
    pub id: String,
    /// Nominal point, part frame.
    pub nominal: [f64; 3],
    /// Unit outward normal, part frame.
    pub normal: [f64; 3],
    /// The reading (when there is one).
    pub reading: Option<f64>,
    /// The measured point, part frame (when measured).
    pub measured: Option<[f64; 3]>,
    /// Signed deviation along the nominal normal (+ outside: material in excess).
    pub deviation: Option<f64>,
    /// What happened.
    pub status: Status,
}

/// Read a sensor log: `id r` per line (`#` comments; r a number, or a word such as
/// `none` or `NaN` for no reading). Each entry keeps its line.
pub fn read_log(text: &str) -> Result<Vec<(String, Reading, usize)>, InspectError> {
    let mut out: Vec<(String, Reading, usize)> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let t = raw.split('#').next().unwrap_or("").trim();
        if t.is_empty() {
            continue;
        }
        let f: Vec<&str> = t.split_whitespace().collect();
        if f.len() != 2 {
            return Err(InspectError::At {
                line,
                what: format!("`{t}`: a log line is `id r` (the point's id and the reading)"),
            });
        }
        let r = match f[1].parse::<f64>() {
            Ok(v) if v.is_finite() => Reading::Value(v),
            Ok(_) => Reading::None(f[1].to_string()),
            Err(_) if f[1].chars().all(|c| c.is_ascii_alphabetic() || c == '-') => {
                Reading::None(f[1].to_string())
            }
            Err(_) => {
                return Err(InspectError::At {
                    line,
                    what: format!("`{}` is neither a reading nor a word for none", f[1]),
                })
            }
        };
        out.push((f[0].to_string(), r, line));
    }
    Ok(out)
}

/// Reduce `readings` against the plan `rows` (in plan order). A reading whose id is not
/// in the plan, or an id read twice, is an error at its line: the log is not this plan's.
pub fn reduce(
    m: &Machine,
    head: usize,
    rows: &[PlanRow],
    readings: &[(String, Reading, usize)],
) -> Result<Vec<Measured>, InspectError> {
    let sn = sensor(m, head)?;
    let mut by_id: std::collections::HashMap<&str, (&Reading, usize)> =
        std::collections::HashMap::new();
    for (id, r, line) in readings {
        if !rows.iter().any(|p| p.id == *id) {
            return Err(InspectError::At {
                line: *line,
                what: format!("point {id} is not in the plan (is this the plan's log?)"),
            });
        }
        if let Some((_, first)) = by_id.insert(id.as_str(), (r, *line)) {
            return Err(InspectError::At {
                line: *line,
                what: format!("point {id} was read already at line {first}"),
            });
        }
    }
    let mut out = Vec::with_capacity(rows.len());
    for p in rows {
        let mut row = Measured {
            id: p.id.clone(),
            nominal: p.point,
            normal: p.normal,
            reading: None,
            measured: None,
            deviation: None,
            status: Status::Missing,
        };
        match by_id.get(p.id.as_str()) {
            None => {}
            Some((Reading::None(_), _)) => row.status = Status::NoReading,
            Some((Reading::Value(r), _)) => {
                row.reading = Some(*r);
                if r.abs() > sn.range {
                    row.status = Status::OutOfRange;
                } else {
                    let pose = m.forward(&p.joints, head);
                    let beam = pose.axis / pose.axis.norm();
                    let q = pose.tip - beam * *r;
                    let n = Vector3::from(p.normal);
                    row.measured = Some([q.x, q.y, q.z]);
                    row.deviation = Some((q - Vector3::from(p.point)).dot(&n));
                    row.status = Status::Ok;
                }
            }
        }
        out.push(row);
    }
    Ok(out)
}

/// Reduce a touch probe's RS-232 log (the program of [`crate::program::write_touch`]):
/// its POSE records in order are the plan's groups of rows at one table position, and
/// each group's touches its rows in order. A touch (the stylus centre, linear axes) goes
/// to the part frame by forward kinematics at the group's table position; the surface
/// point is one stylus radius back along the nominal normal. Rows of a pose the log lacks
/// are `missing`; a pose with another number of touches than the plan's is an error at
/// its record.
pub fn reduce_touch(
    m: &Machine,
    head: usize,
    stylus: f64,
    rows: &[PlanRow],
    log: &[lampost_align::probe::LoggedPose],
) -> Result<Vec<Measured>, InspectError> {
    // The plan's groups: consecutive rows at one table position.
    let mut groups: Vec<Vec<&PlanRow>> = Vec::new();
    for r in rows {
        match groups.last_mut() {
            Some(g) if g[0].joints.rotary == r.joints.rotary => g.push(r),
            _ => groups.push(vec![r]),
        }
    }
    let mut out = Vec::with_capacity(rows.len());
    for (k, g) in groups.iter().enumerate() {
        let logged = log.iter().find(|p| p.number == k + 1);
        if let Some(lp) = logged {
            if lp.touches.len() != g.len() {
                return Err(InspectError::At {
                    line: lp.line,
                    what: format!(
                        "pose {} has {} touches; the plan has {} points at that table position",
                        lp.number,
                        lp.touches.len(),
                        g.len()
                    ),
                });
            }
        }
        for (i, r) in g.iter().enumerate() {
            let mut row = Measured {
                id: r.id.clone(),
                nominal: r.point,
                normal: r.normal,
                reading: None,
                measured: None,
                deviation: None,
                status: Status::Missing,
            };
            if let Some((_, x)) = logged.and_then(|lp| lp.touches.get(i)) {
                let j = lampost_kinematics::Joints {
                    linear: *x,
                    rotary: r.joints.rotary,
                };
                let n = Vector3::from(r.normal);
                let q = m.forward(&j, head).tip - n * stylus;
                row.measured = Some([q.x, q.y, q.z]);
                row.deviation = Some((q - Vector3::from(r.point)).dot(&n));
                row.status = Status::Ok;
            }
            out.push(row);
        }
    }
    if let Some(extra) = log
        .iter()
        .find(|p| p.number > groups.len() || p.number == 0)
    {
        return Err(InspectError::At {
            line: extra.line,
            what: format!(
                "pose {} is not in the plan (it has {} table positions)",
                extra.number,
                groups.len()
            ),
        });
    }
    Ok(out)
}
