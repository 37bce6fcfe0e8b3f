//! The measuring program: the plan's rows as motion the controller runs (ISO dialect, as
//! the NRC cell reads it). Per row: a retract to the machine's clearance height, the
//! table indexed when the rotaries change (never while the head is low), a traverse over
//! the point, a feed down to the measuring position, a short dwell for the motion to
//! settle, and the sensor's trigger code with the point's id in a comment; then the
//! retract and the program end.

use lampost_gcode::{Dialect, EmitOptions, Emitter, Units};
use lampost_kinematics::{Machine, Units as MUnits};

use crate::error::InspectError;
use crate::plan::{sensor, PlanRow};

/// Write the program of `rows` for the sensor on `head`.
pub fn write(m: &Machine, head: usize, rows: &[PlanRow]) -> Result<String, InspectError> {
    let sn = sensor(m, head)?;
    let io = |e: std::io::Error| InspectError::Input(format!("cannot write the program: {e}"));
    let (units, code, feed) = match m.units {
        MUnits::Inch => (Units::Inch, 20.0, 20.0),
        MUnits::Mm => (Units::Mm, 21.0, 500.0),
    };
    let mut em = Emitter::new(
        Vec::new(),
        EmitOptions {
            dialect: Some(Dialect::Iso),
            units,
            ..EmitOptions::default()
        },
    );
    em.program_number(
        9600,
        Some(&format!("LAMPOST INSPECTION {} POINTS", rows.len())),
    )
    .map_err(io)?;
    em.raw_line(&format!(
        "(MACHINE {} - SENSOR RANGE +-{} - EACH {} TAKES A READING)",
        m.def.name.to_uppercase().replace(['(', ')'], ""),
        sn.range,
        sn.trigger
    ))
    .map_err(io)?;
    em.words(
        &[
            (b'G', code),
            (b'G', 90.0),
            (b'G', 17.0),
            (b'G', 40.0),
            (b'G', 80.0),
            (b'G', 94.0),
        ],
        None,
    )
    .map_err(io)?;
    let names = m.axis_names();
    let letter = |k: usize| names[k].as_bytes().first().copied().unwrap_or(b'X');
    let clearance = m.def.process.clearance_z;
    let trigger: Vec<(u8, f64)> = sn
        .trigger
        .split_whitespace()
        .filter_map(|w| {
            let mut c = w.chars();
            let l = c.next()? as u8;
            c.as_str().parse::<f64>().ok().map(|v| (l, v))
        })
        .collect();
    let mut rotary: Option<[f64; 2]> = None;
    for r in rows {
        let j = r.joints.values();
        em.words(&[(b'G', 0.0), (letter(2), clearance)], None)
            .map_err(io)?;
        if rotary != Some(r.joints.rotary) {
            em.words(
                &[(b'G', 0.0), (letter(3), j[3]), (letter(4), j[4])],
                Some("INDEX"),
            )
            .map_err(io)?;
            rotary = Some(r.joints.rotary);
        }
        em.words(&[(b'G', 0.0), (letter(0), j[0]), (letter(1), j[1])], None)
            .map_err(io)?;
        em.words(&[(b'G', 1.0), (letter(2), j[2]), (b'F', feed)], None)
            .map_err(io)?;
        em.words(&[(b'G', 4.0), (b'P', 0.2)], None).map_err(io)?;
        let id = r.id.replace(['(', ')'], "");
        em.words(&trigger, Some(&format!("READ {id}")))
            .map_err(io)?;
    }
    em.words(&[(b'G', 0.0), (letter(2), clearance)], None)
        .map_err(io)?;
    let end = m.def.process.program_end.clone();
    if let Some((l, v)) = end.split_whitespace().next().and_then(|w| {
        let mut c = w.chars();
        let l = c.next()? as u8;
        c.as_str().parse::<f64>().ok().map(|v| (l, v))
    }) {
        em.words(&[(l, v)], None).map_err(io)?;
    }
    let bytes = em.finish().map_err(io)?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// The touch-probe measuring program (FADAL): the rows grouped by table position, each
/// group one pose of a `probe poses`-style program (the index, a `POSE k …` record, the
/// touches), so the log says which touches belong to which rows. Each touch starts
/// `clearance` out from the surface along the normal, aims `overtravel` past it, and
/// expects the stylus centre a stylus radius out; positions are the linear axes that put
/// the probe's tool point there at that table position.
pub fn write_touch(
    m: &Machine,
    head: usize,
    stylus: f64,
    rows: &[PlanRow],
) -> Result<String, InspectError> {
    use lampost_align::probe::{poses_program, PoseTouches, ProbeOptions, Touch};
    use lampost_kinematics::Vector3;
    let units = match m.units {
        MUnits::Inch => Units::Inch,
        MUnits::Mm => Units::Mm,
    };
    let opts = ProbeOptions {
        program_number: 9601,
        ..ProbeOptions::defaults(units)
    };
    let names = m.axis_names();
    let letter = |k: usize| names[k].as_bytes().first().copied().unwrap_or(b'A');
    let mut poses: Vec<PoseTouches> = Vec::new();
    let mut last: Option<[f64; 2]> = None;
    let mut top = f64::NEG_INFINITY;
    for r in rows {
        let rot = r.joints.rotary;
        let n = Vector3::from(r.normal);
        let p = Vector3::from(r.point);
        let mut at = |q: Vector3<f64>| {
            let x = m.linear_for(&m.part_to_machine(&rot, &q), head);
            top = top.max(x[2]);
            x
        };
        let touch = Touch {
            start: at(p + n * (stylus + opts.clearance)),
            target: at(p + n * (stylus - opts.overtravel)),
            expected: at(p + n * stylus),
        };
        if last != Some(rot) {
            poses.push(PoseTouches {
                rotary: vec![(letter(3), rot[0]), (letter(4), rot[1])],
                touches: Vec::new(),
            });
            last = Some(rot);
        }
        if let Some(g) = poses.last_mut() {
            g.touches.push(touch);
        }
    }
    let safe = top + 10.0 * opts.clearance;
    poses_program(
        &poses,
        safe,
        &format!("LAMPOST INSPECTION {} POINTS", rows.len()),
        &[format!(
            "MACHINE {} - TOUCH PROBE, STYLUS RADIUS {stylus}",
            m.def.name.to_uppercase()
        )],
        &opts,
    )
    .map_err(|e| InspectError::Input(format!("cannot write the program: {e}")))
}
