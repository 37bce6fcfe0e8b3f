//! Measuring plans: each sampling point with the machine position that puts the sensor's
//! zero on it, the beam along the surface's inward normal (or tilted from it as little as
//! the machine's limits allow, within the sensor's allowed tilt), ordered to keep rotary
//! motion small; and the plan's text form (the paper's Figure 7b rows, with the nominal
//! point and normal).

use lampost_gcode::fixed;
use lampost_kinematics::{Joints, Machine, Vector3};

use crate::error::InspectError;

/// A sampling point: where the surface should be, and its outward normal (part frame).
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// The point's name.
    pub id: String,
    /// Nominal point, part frame.
    pub point: [f64; 3],
    /// Outward surface normal (need not be unit).
    pub normal: [f64; 3],
}

/// One row of a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanRow {
    /// The point's name.
    pub id: String,
    /// Machine position: linear then rotary, machine file order.
    pub joints: Joints,
    /// Nominal point, part frame.
    pub point: [f64; 3],
    /// Unit outward normal, part frame.
    pub normal: [f64; 3],
    /// The tool axis used (unit, from the tip into the head): the normal, or tilted.
    pub beam: [f64; 3],
    /// Angle between the beam and the normal, degrees.
    pub tilt_deg: f64,
}

/// How the head measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Probe {
    /// A displacement sensor (the head's `sensor` table): its zero on the point.
    Sensor,
    /// A touch probe with this stylus-ball radius: it touches each point moving along the
    /// normal, its stylus centre then one radius out from the surface.
    Touch {
        /// Stylus-ball radius.
        stylus: f64,
    },
}

impl Probe {
    /// Where the tool point is when the point is measured: on it, or a stylus radius out.
    pub fn standoff(self) -> f64 {
        match self {
            Probe::Sensor => 0.0,
            Probe::Touch { stylus } => stylus,
        }
    }
}

/// A plan: the rows in the order to measure, and the points no orientation reaches.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Plan {
    /// Reachable rows, in measuring order.
    pub rows: Vec<PlanRow>,
    /// The points left out, each with the reason.
    pub unreachable: Vec<InspectError>,
}

/// The sensor of `head`, or the error naming the head.
pub fn sensor(m: &Machine, head: usize) -> Result<&lampost_kinematics::SensorDef, InspectError> {
    m.def
        .heads
        .get(head)
        .and_then(|h| h.sensor.as_ref())
        .ok_or_else(|| InspectError::NoSensor {
            machine: m.def.name.clone(),
            head: m.def.heads.get(head).map_or("?".into(), |h| h.name.clone()),
        })
}

/// Unit vector, or `None` for a zero or non-finite one.
fn unit(v: [f64; 3]) -> Option<Vector3<f64>> {
    let v = Vector3::from(v);
    let big = v.amax();
    if !(big.is_finite() && big > 1e-300) {
        return None;
    }
    let u = v / big;
    Some(u / u.norm())
}

/// Beam directions to try for a normal: the normal, then tilted by 5° steps up to
/// `max_tilt` at twelve azimuths, smallest tilt first.
fn beams(n: &Vector3<f64>, max_tilt: f64) -> Vec<(Vector3<f64>, f64)> {
    let mut out = vec![(*n, 0.0)];
    let h = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = (h - n * n.dot(&h)).normalize();
    let e2 = n.cross(&e1);
    let mut tilt = 5.0;
    while tilt <= max_tilt + 1e-9 {
        let (s, c) = tilt.to_radians().sin_cos();
        for k in 0..12 {
            let az = (30.0 * f64::from(k)).to_radians();
            out.push((n * c + (e1 * az.cos() + e2 * az.sin()) * s, tilt));
        }
        tilt += 5.0;
    }
    out
}

/// The machine position measuring `t` with the rotaries near `near`: the smallest tilt
/// the limits allow, or why none does.
fn solve(
    m: &Machine,
    head: usize,
    t: &Target,
    n: &Vector3<f64>,
    max_tilt: f64,
    near: &[f64; 2],
    standoff: f64,
) -> Result<(Joints, Vector3<f64>, f64), InspectError> {
    let tip = Vector3::from(t.point) + n * standoff;
    let mut first_err = None;
    for (beam, tilt) in beams(n, max_tilt) {
        match m
            .inverse(&tip, &beam, head, near)
            .and_then(|s| m.choose(&s, None, &beam, head))
        {
            Ok(c) => return Ok((c.solution.joints, beam, tilt)),
            Err(e) => {
                first_err.get_or_insert(e);
            }
        }
    }
    Err(InspectError::Unreachable {
        id: t.id.clone(),
        why: format!(
            "no orientation within {max_tilt}° of its normal is within the machine's limits ({})",
            first_err.map_or(String::new(), |e| e.to_string())
        ),
    })
}

/// Rotary distance between two positions (degrees; continuous axes the short way round).
fn rotary_distance(m: &Machine, a: &[f64; 2], b: &[f64; 2]) -> f64 {
    (0..2)
        .map(|i| {
            let d = (a[i] - b[i]).abs();
            if m.rotary[i].continuous {
                d.rem_euclid(360.0).min(360.0 - d.rem_euclid(360.0))
            } else {
                d
            }
        })
        .sum()
}

/// Stage 1: plan `targets` for `probe` on `head`, the beam within `max_tilt` degrees of
/// each normal (a sensor: at most its own limit, by default that; a touch probe: 30° by
/// default). Each target is solved on
/// its own first, the reachable ones ordered greedily (the next is the one with the
/// least rotary motion, then the shortest move), then solved again in that order with
/// the rotaries near the previous row's, so a continuous axis does not unwind.
pub fn plan(
    m: &Machine,
    head: usize,
    probe: Probe,
    targets: &[Target],
    max_tilt: Option<f64>,
) -> Result<Plan, InspectError> {
    let limit = match probe {
        Probe::Sensor => sensor(m, head)?.max_tilt_deg,
        Probe::Touch { stylus } => {
            if !(stylus.is_finite() && stylus > 0.0) {
                return Err(InspectError::Input(format!(
                    "the stylus radius {stylus} must be a positive number"
                )));
            }
            90.0
        }
    };
    let max_tilt = match max_tilt {
        Some(t) if t.is_finite() && t >= 0.0 => t.min(limit),
        Some(t) => {
            return Err(InspectError::Input(format!(
                "--max-tilt {t}: give an angle in degrees, 0 or more"
            )))
        }
        None => limit.min(30.0),
    };
    let standoff = probe.standoff();
    let mut seen = std::collections::HashSet::new();
    let mut solved = Vec::with_capacity(targets.len());
    let mut out = Plan::default();
    for t in targets {
        if !seen.insert(t.id.as_str()) {
            return Err(InspectError::Input(format!(
                "point id {} is given twice",
                t.id
            )));
        }
        if !t.point.iter().all(|x| x.is_finite()) {
            return Err(InspectError::Input(format!(
                "point {}: a coordinate is not finite",
                t.id
            )));
        }
        let Some(n) = unit(t.normal) else {
            return Err(InspectError::Input(format!(
                "point {}: the normal ({}, {}, {}) has no direction",
                t.id, t.normal[0], t.normal[1], t.normal[2]
            )));
        };
        match solve(m, head, t, &n, max_tilt, &[0.0, 0.0], standoff) {
            Ok((j, _, _)) => solved.push((t, n, j.rotary)),
            Err(e) => out.unreachable.push(e),
        }
    }
    // Greedy order: least rotary motion, then the shortest move.
    let mut left: Vec<usize> = (0..solved.len()).collect();
    let mut order = Vec::with_capacity(solved.len());
    let mut at: Option<([f64; 2], [f64; 3])> = None;
    while !left.is_empty() {
        let k = match at {
            None => 0,
            Some((r, p)) => {
                let cost = |i: &usize| {
                    let (t, _, q) = &solved[*i];
                    let d = Vector3::from(t.point) - Vector3::from(p);
                    (rotary_distance(m, &r, q), d.norm())
                };
                // The best so far and its cost (priced once, not again at every compare).
                let mut best = (0, cost(&left[0]));
                for (i, idx) in left.iter().enumerate().skip(1) {
                    let (a, b) = cost(idx);
                    let (c, d) = best.1;
                    if a < c - 1e-9 || (a <= c + 1e-9 && b < d) {
                        best = (i, (a, b));
                    }
                }
                best.0
            }
        };
        let i = left.remove(k);
        at = Some((solved[i].2, solved[i].0.point));
        order.push(i);
    }
    // Solved again in order, near the previous row.
    let mut near = [0.0, 0.0];
    for i in order {
        let (t, n, _) = &solved[i];
        let (joints, beam, tilt) = solve(m, head, t, n, max_tilt, &near, standoff)?;
        near = joints.rotary;
        out.rows.push(PlanRow {
            id: t.id.clone(),
            joints,
            point: t.point,
            normal: [n.x, n.y, n.z],
            beam: [beam.x, beam.y, beam.z],
            tilt_deg: tilt,
        });
    }
    Ok(out)
}

/// The plan as text: a comment naming the machine and head, a header of the machine's
/// axis names, then per row `id X Y Z B C x y z i j k tilt_deg`.
pub fn to_text(m: &Machine, head: usize, probe: Probe, rows: &[PlanRow]) -> String {
    let names = m.axis_names();
    let head_name = m.def.heads.get(head).map_or("?", |h| h.name.as_str());
    let touch = match probe {
        Probe::Sensor => String::new(),
        Probe::Touch { stylus } => format!(", stylus {stylus}"),
    };
    let mut s = format!(
        "# lampost inspect plan: machine {}, head {head_name}{touch}, {} points (machine position to measure each, then the nominal point and outward normal, part frame)\nid {} x y z i j k tilt_deg\n",
        m.def.name,
        rows.len(),
        names.join(" ")
    );
    for r in rows {
        // `fixed`: correctly rounded, and a value that rounds to zero is written without
        // a sign (`-0.000000` would read back as another row than the one written).
        let j = r.joints.values();
        let cols = j
            .iter()
            .map(|&x| fixed(x, 6))
            .chain(r.point.iter().chain(&r.normal).map(|&x| fixed(x, 9)))
            .chain([fixed(r.tilt_deg, 3)]);
        s.push_str(&r.id);
        for c in cols {
            s.push(' ');
            s.push_str(&c);
        }
        s.push('\n');
    }
    s
}

/// Read a plan written by [`to_text`] for machine `m` and head `head_name`. The beam of
/// each row is recomputed from its joints by forward kinematics. A plan for another
/// machine or head, a row with the wrong number of columns, a value that is not a
/// finite number, or an id given twice, is an error at its line.
pub fn read_text(
    m: &Machine,
    head: usize,
    text: &str,
) -> Result<(Probe, Vec<PlanRow>), InspectError> {
    let head_name = m.def.heads.get(head).map_or("?", |h| h.name.as_str());
    let mut rows: Vec<PlanRow> = Vec::new();
    let mut probe = Probe::Sensor;
    let mut said = false;
    let mut header = false;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let t = raw.trim();
        if let Some(c) = t.strip_prefix("# lampost inspect plan:") {
            let field = |key: &str| {
                c.split(',')
                    .find_map(|f| f.trim().strip_prefix(key).map(|v| v.trim().to_string()))
            };
            let (mach, hd) = (field("machine "), field("head "));
            if mach.as_deref() != Some(m.def.name.as_str()) || hd.as_deref() != Some(head_name) {
                return Err(InspectError::At {
                    line,
                    what: format!(
                        "this plan is for machine {} head {}, not {} head {head_name}",
                        mach.unwrap_or_default(),
                        hd.unwrap_or_default(),
                        m.def.name
                    ),
                });
            }
            if let Some(st) = field("stylus ") {
                let stylus = st.parse::<f64>().ok().filter(|x| x.is_finite() && *x > 0.0);
                probe = Probe::Touch {
                    stylus: stylus.ok_or_else(|| InspectError::At {
                        line,
                        what: format!("stylus `{st}` is not a positive number"),
                    })?,
                };
            }
            said = true;
            continue;
        }
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        if !header {
            header = true;
            continue;
        }
        let f: Vec<&str> = t.split_whitespace().collect();
        if f.len() != 13 {
            return Err(InspectError::At {
                line,
                what: format!(
                    "{} columns, a plan row has 13 (id, 5 axes, x y z, i j k, tilt)",
                    f.len()
                ),
            });
        }
        let mut v = [0.0; 12];
        for (k, x) in f[1..].iter().enumerate() {
            v[k] = x
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| InspectError::At {
                    line,
                    what: format!("`{x}` is not a finite number"),
                })?;
        }
        if rows.iter().any(|r| r.id == f[0]) {
            return Err(InspectError::At {
                line,
                what: format!("point id {} is given twice", f[0]),
            });
        }
        let joints = Joints {
            linear: [v[0], v[1], v[2]],
            rotary: [v[3], v[4]],
        };
        // A deviation is measured along the normal: one that is not a unit vector
        // (written with 9 decimals) would scale every deviation, or zero it.
        let n = Vector3::new(v[8], v[9], v[10]).norm();
        if (n - 1.0).abs() > 1e-6 {
            return Err(InspectError::At {
                line,
                what: format!(
                    "point {}: the normal {} {} {} has length {n:.9}, not 1",
                    f[0], f[9], f[10], f[11]
                ),
            });
        }
        // The machine ran the plan: a row beyond its travel was not measured.
        m.check_limits(&joints).map_err(|e| InspectError::At {
            line,
            what: format!("point {}: {e}", f[0]),
        })?;
        let beam = m.forward(&joints, head).axis;
        let beam = beam / beam.norm();
        rows.push(PlanRow {
            id: f[0].to_string(),
            joints,
            point: [v[5], v[6], v[7]],
            normal: [v[8], v[9], v[10]],
            beam: [beam.x, beam.y, beam.z],
            tilt_deg: v[11],
        });
    }
    if !said {
        return Err(InspectError::Input(
            "not a lampost inspection plan (no `# lampost inspect plan:` line naming its machine)"
                .into(),
        ));
    }
    Ok((probe, rows))
}
