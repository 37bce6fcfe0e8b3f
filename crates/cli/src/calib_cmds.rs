//! `lampost calibrate …` and `lampost probe poses`.

use lampost_align::calib::{self, Method, PivotResult, Pose};
use lampost_align::P3;
use lampost_kinematics::{Machine, Units};

use crate::align_cmds::align_error;
use crate::io::{display_name, open_input, Output};
use crate::json::{self, obj, Obj};
use crate::kin_cmds::{load_machine, vector};
use crate::report::CliError;

fn located(file: &str, line: usize, text: &str, what: &str, hint: &str) -> CliError {
    CliError::failed(format!(
        "error: {what}\n  --> {file}:{line}\n   | {text}\n  = help: {hint}\n"
    ))
}

/// The fields of a data row: separated by spaces, tabs or commas.
fn row_fields(code: &str) -> Vec<&str> {
    code.split([' ', '\t', ','])
        .filter(|f| !f.is_empty())
        .collect()
}

fn read_text(file: &str) -> Result<(String, String), CliError> {
    let name = display_name(file);
    let mut text = String::new();
    crate::io::read_to_string_checked(&mut open_input(file)?, &mut text)
        .map_err(|e| CliError::usage(format!("error: cannot read {name}: {e}\n")))?;
    Ok((name, text))
}

/// POSES: `A B x y z [ux uy uz]` per row in the machine's rotary order (or the order a
/// header names), `#` comments, an optional `# units: mm|inch` line checked against the
/// machine.
///
/// Or a `probe poses` log as the controller sent it: each `POSE k A… B…` record and the
/// touches after it become one pose, its ball centre from a sphere fit of those touches
/// (radius fixed at `--radius` + `--stylus-radius` when both are given, else free); the
/// fits come back too, to report.
pub fn read_poses(m: &Machine, file: &str, ball: &BallSize) -> Result<PoseInput, CliError> {
    let (name, text) = read_text(file)?;
    let logged = lampost_align::probe::read_pose_log(&text).map_err(|e| log_error(&name, e))?;
    if let Some(logged) = logged {
        let (poses, fits) = poses_from_log(m, &name, &text, &logged, ball)?;
        return Ok(PoseInput {
            name,
            poses,
            fits: Some(fits),
        });
    }
    if ball.radius.is_some() || ball.stylus_radius.is_some() {
        return Err(CliError::usage(format!(
            "error: --radius and --stylus-radius apply to a probe log, but {name} has no POSE records\n  = help: give the `probe poses` log as captured from the RS-232 port, or leave the radii out for a file of ball centres\n"
        )));
    }
    let poses = parse_pose_rows(m, &name, &text)?;
    Ok(PoseInput {
        name,
        poses,
        fits: None,
    })
}

/// What [`read_poses`] read.
#[derive(Debug)]
pub struct PoseInput {
    /// The input's name as shown.
    pub name: String,
    /// The poses.
    pub poses: Vec<Pose>,
    /// Each pose's sphere fit, when read from a probe log.
    pub fits: Option<Vec<PoseFit>>,
}

/// The ball and stylus radii for fitting a `probe poses` log.
#[derive(Debug, Clone, Copy, Default)]
pub struct BallSize {
    /// The gage ball's radius.
    pub radius: Option<f64>,
    /// The stylus ball's radius.
    pub stylus_radius: Option<f64>,
}

/// The sphere fit of one logged pose.
#[derive(Debug, Clone)]
pub struct PoseFit {
    /// The pose's number in its record.
    pub number: usize,
    /// Line of the POSE record.
    pub line: usize,
    /// Rotary angles, machine order.
    pub rotary: [f64; 2],
    /// The fit of the stylus centres.
    pub fit: lampost_align::fit::SphereFit,
}

impl PoseFit {
    fn json(&self, m: &Machine) -> Obj {
        let mut o = obj! {
            "pose": self.number,
            "line": self.line,
        };
        o.set(&m.rotary[0].name, &self.rotary[0]);
        o.set(&m.rotary[1].name, &self.rotary[1]);
        o.field("center", &self.fit.center)
            .field("radius", &self.fit.radius)
            .field("rms", &self.fit.rms)
            .field("max_abs_residual", &self.fit.max_abs_residual)
            .field("n", &self.fit.n)
            .field("u_center", &self.fit.u_center)
    }
}
/// A probe log's error at its line.
fn log_error(name: &str, e: lampost_align::probe::LogError) -> CliError {
    match e {
        lampost_align::probe::LogError::Malformed { line, text, why } => located(
            name,
            line,
            &text,
            &format!("`{text}` {why}"),
            "fix or delete the line: a POSE record reads `POSE k A… B…`, a touch line X… Y… Z…",
        ),
        lampost_align::probe::LogError::NoTouches => CliError::failed(format!(
            "error: {name} has no touch lines (X… Y… Z…)\n  = help: check that the log was captured from the RS-232 port while the probing program ran\n"
        )),
    }
}

/// Stage 2 of reading a log: each logged pose's angles in machine order, and its ball
/// centre from a sphere fit of its touches.
fn poses_from_log(
    m: &Machine,
    name: &str,
    text: &str,
    logged: &[lampost_align::probe::LoggedPose],
    ball: &BallSize,
) -> Result<(Vec<Pose>, Vec<PoseFit>), CliError> {
    let fixed = match (ball.radius, ball.stylus_radius) {
        (Some(r), Some(s)) if r > 0.0 && s > 0.0 && (r + s).is_finite() => Some(r + s),
        (None, None) => None,
        _ => {
            return Err(CliError::usage(
                "error: give both --radius (the gage ball) and --stylus-radius, positive, or neither (the sphere radius is then fitted)\n".to_string(),
            ))
        }
    };
    let raw = |line: usize| text.lines().nth(line - 1).unwrap_or("").trim().to_string();
    let mut poses = Vec::with_capacity(logged.len());
    let mut fits = Vec::with_capacity(logged.len());
    for lp in logged {
        let mut rotary = [0.0; 2];
        let mut seen = [false; 2];
        for &(letter, v) in &lp.rotary {
            let Some(i) = m.rotary.iter().position(|a| {
                a.name
                    .as_bytes()
                    .first()
                    .is_some_and(|c| c.eq_ignore_ascii_case(&letter))
            }) else {
                return Err(located(
                    name,
                    lp.line,
                    &raw(lp.line),
                    &format!(
                        "the record names axis {} but machine {} has {} and {}",
                        char::from(letter),
                        m.name,
                        m.rotary[0].name,
                        m.rotary[1].name
                    ),
                    "use the machine the probing program was written for (`--machine`)",
                ));
            };
            rotary[i] = v;
            seen[i] = true;
        }
        if let Some(i) = seen.iter().position(|s| !s) {
            return Err(located(
                name,
                lp.line,
                &raw(lp.line),
                &format!("the record does not give {}", m.rotary[i].name),
                "a POSE record names both rotary angles, as `lampost probe poses` writes it",
            ));
        }
        let pts: Vec<P3> = lp.touches.iter().map(|(_, p)| P3::from(*p)).collect();
        let fit = lampost_align::fit::sphere(&pts, fixed).map_err(|e| {
            located(
                name,
                lp.line,
                &raw(lp.line),
                &format!(
                    "pose {}: the sphere fit of its {} touches failed: {e}",
                    lp.number,
                    pts.len()
                ),
                e.hint(),
            )
        })?;
        poses.push(Pose {
            rotary,
            center: P3::from(fit.center),
            row: lp.line,
            sigma: None,
        });
        fits.push(PoseFit {
            number: lp.number,
            line: lp.line,
            rotary,
            fit,
        });
    }
    Ok((poses, fits))
}

/// Stage 2 of reading a file of ball centres: one pose per row.
fn parse_pose_rows(m: &Machine, name: &str, text: &str) -> Result<Vec<Pose>, CliError> {
    let name = name.to_string();
    let names = [m.rotary[0].name.as_str(), m.rotary[1].name.as_str()];
    let mut order = [0usize, 1];
    let mut poses = Vec::new();
    let mut seen_data = false;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let (code, comment) = match raw.split_once('#') {
            Some((c, k)) => (c, Some(k)),
            None => (raw, None),
        };
        if let Some(k) = comment {
            let k = k.trim().to_ascii_lowercase();
            if let Some(u) = k.strip_prefix("units:").map(str::trim) {
                let file_units = match u {
                    "mm" => Units::Mm,
                    "inch" | "in" => Units::Inch,
                    other => {
                        return Err(located(
                            &name,
                            line,
                            raw,
                            &format!("unknown units `{other}`"),
                            "write `# units: mm` or `# units: inch`",
                        ))
                    }
                };
                if file_units != m.units {
                    return Err(located(&name, line, raw, &format!("the poses are in {u} but machine {} is in {:?}", m.name, m.units).to_lowercase(), "convert the ball centres to the machine's units, or use the machine file for those units"));
                }
            }
        }
        let fields: Vec<&str> = row_fields(code);
        if fields.is_empty() {
            continue;
        }
        if !seen_data && fields.iter().all(|f| f.parse::<f64>().is_err()) {
            // A header: take the rotary order from it.
            let pos = |n: &str| fields.iter().position(|f| f.eq_ignore_ascii_case(n));
            if let (Some(a), Some(b)) = (pos(names[0]), pos(names[1])) {
                if a < 2 && b < 2 {
                    order = [a, b];
                }
            }
            seen_data = true;
            continue;
        }
        seen_data = true;
        if fields.len() != 5 && fields.len() != 8 {
            return Err(located(
                &name,
                line,
                raw,
                &format!(
                    "row {line} has {} columns; expected {} {} x y z (and optionally ux uy uz)",
                    fields.len(),
                    names[0],
                    names[1]
                ),
                "write one pose per row: the two rotary angles, then the measured ball centre",
            ));
        }
        let mut v = Vec::with_capacity(fields.len());
        for (k, f) in fields.iter().enumerate() {
            match f.parse::<f64>() {
                Ok(x) if x.is_finite() && x.abs() > lampost_align::MAX_COORD => {
                    return Err(located(
                        &name,
                        line,
                        raw,
                        &format!(
                            "row {line}, column {}: `{f}` is beyond ±1e9 of the unit",
                            k + 1
                        ),
                        "no machine measures that far: check the units and the numbers",
                    ))
                }
                Ok(x) if x.is_finite() => v.push(x + 0.0),
                _ => {
                    return Err(located(
                        &name,
                        line,
                        raw,
                        &format!("row {line}, column {}: `{f}` is not a finite number", k + 1),
                        "give plain decimal numbers",
                    ))
                }
            }
        }
        let mut rotary = [0.0; 2];
        rotary[0] = v[order[0]];
        rotary[1] = v[order[1]];
        let sigma = (v.len() == 8).then(|| [v[5], v[6], v[7]]);
        if let Some(s) = sigma {
            if s.iter().any(|x| *x <= 0.0) {
                return Err(located(
                    &name,
                    line,
                    raw,
                    &format!("row {line}: uncertainties must be positive"),
                    "give each coordinate's standard uncertainty, or leave them out",
                ));
            }
        }
        poses.push(Pose {
            rotary,
            center: P3::new(v[2], v[3], v[4]),
            row: line,
            sigma,
        });
    }
    if poses.is_empty() {
        return Err(CliError::failed(format!(
            "error: {name} holds no poses\n  = help: one row per pose: {} {} x y z\n",
            names[0], names[1]
        )));
    }
    Ok(poses)
}

/// The per-pose fits as report lines.
fn report_fits(m: &Machine, fits: &[PoseFit]) -> String {
    let mut s = String::new();
    for f in fits {
        s.push_str(&format!(
            "pose {} (line {}) {} {} {} {}: centre {} radius {:.6} rms {:.3e} ({} touches)\n",
            f.number,
            f.line,
            m.rotary[0].name,
            f.rotary[0],
            m.rotary[1].name,
            f.rotary[1],
            v3(f.fit.center),
            f.fit.radius,
            f.fit.rms,
            f.fit.n
        ));
    }
    s
}

fn out_text(s: String) -> Result<(), CliError> {
    let mut o = Output::create(None)?;
    o.writer()
        .write_all(s.as_bytes())
        .map_err(|e| CliError::write(&e))?;
    o.commit()
}

fn v3(a: [f64; 3]) -> String {
    format!("{:.6} {:.6} {:.6}", a[0], a[1], a[2])
}

fn report_pivot(m: &Machine, r: &PivotResult) -> String {
    let mut s = format!("method {:?}\n", r.method).to_lowercase();
    match (r.r, r.pivot, &r.line) {
        (Some(rr), Some(p), _) => {
            s.push_str(&format!("R {}\npivot {}\n", v3(rr), v3(p)));
            if let Some(u) = r.u_r {
                s.push_str(&format!("u_R {:.2e} {:.2e} {:.2e}\n", u[0], u[1], u[2]));
            }
        }
        (_, _, Some(l)) => {
            s.push_str(&format!(
                "R not fixed: the poses allow a line of solutions\n  R = ({}) + t·({})\n  pivot = ({}) − t·({})\n  {}\n",
                v3(l.r_point), v3(l.direction), v3(l.pivot_point), v3(l.direction), l.advice
            ));
        }
        _ => s.push_str("R not fixed: see the note\n"),
    }
    s.push_str(&format!("rms {:.3e}\n", r.rms));
    if r.condition.is_finite() && r.condition < f64::MAX {
        s.push_str(&format!("condition {:.3e}\n", r.condition));
    } else {
        s.push_str("condition n/a (the design is singular)\n");
    }
    if let Some(axes) = &r.axes {
        for (i, a) in axes.iter().enumerate() {
            s.push_str(&format!(
                "axis {} direction {} point {}\n",
                m.rotary[i].name,
                v3(a.direction),
                v3(a.point)
            ));
        }
    }
    for p in &r.per_pose {
        s.push_str(&format!(
            "row {} residual {:.3e} {:.3e} {:.3e}\n",
            p.row, p.residual[0], p.residual[1], p.residual[2]
        ));
    }
    for n in &r.notes {
        s.push_str(&format!("note: {n}\n"));
    }
    s
}

#[allow(clippy::too_many_arguments)]
pub fn pivot(
    machine: &str,
    sets: &[String],
    file: &str,
    ball: &BallSize,
    method: Option<&str>,
    write: Option<&str>,
    json: bool,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let PoseInput { name, poses, fits } = read_poses(&m, file, ball)?;
    let method = match method {
        Some("i") => Method::I,
        Some("iii") => Method::Iii,
        Some("fit") => Method::Fit,
        Some(other) => {
            return Err(CliError::usage(format!(
                "error: --method {other}: use i, iii or fit\n"
            )))
        }
        None if poses.len() < 4 => Method::Iii,
        None => Method::Fit,
    };
    let res = match method {
        Method::I => calib::method_i(&m, &poses),
        Method::Iii => calib::method_iii(&m, &poses),
        Method::Fit => calib::method_fit(&m, &poses),
    }
    .map_err(|e| align_error(&name, e))?;
    let mut numbers: Vec<f64> = res
        .r
        .iter()
        .chain(res.pivot.iter())
        .flatten()
        .copied()
        .collect();
    numbers.extend(res.u_r.iter().flatten());
    numbers.push(res.rms);
    crate::kin_cmds::finite("the calibration (R, its centre, u_R or the rms)", &numbers)?;
    if let Some(path) = write {
        // An edit of the machine file the calibration started from (its comments and
        // layout kept), or of the built-in it names.
        let original = match lampost_kinematics::builtin_text(machine) {
            Some(t) => t.to_string(),
            None => crate::io::read_settings_file(machine)
                .map_err(|e| CliError::usage(format!("error: cannot read {machine}: {e}\n")))?,
        };
        let text = lampost_align::calibrated_text(&original, &m, &res, &name)
            .map_err(|e| align_error(&name, e))?;
        let mut o = Output::create(Some(path))?;
        o.writer()
            .write_all(text.as_bytes())
            .map_err(|e| CliError::write(&e))?;
        o.commit()?;
    }
    if json {
        let mut o = Obj::of(&res)?;
        if let Some(f) = &fits {
            o.set(
                "pose_fits",
                &f.iter().map(|f| f.json(&m)).collect::<Vec<_>>(),
            );
        }
        out_text(format!("{}\n", json::to_string(&o)?))
    } else {
        let mut s = fits
            .as_deref()
            .map_or(String::new(), |f| report_fits(&m, f));
        s.push_str(&report_pivot(&m, &res));
        out_text(s)
    }
}

pub fn axes(
    machine: &str,
    sets: &[String],
    file: &str,
    ball: &BallSize,
    json: bool,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let PoseInput { name, poses, fits } = read_poses(&m, file, ball)?;
    let e = calib::axes_from_circles(&m, &poses).map_err(|e| align_error(&name, e))?;
    if json {
        let mut o = Obj::of(&e)?;
        if let Some(f) = &fits {
            o.set(
                "pose_fits",
                &f.iter().map(|f| f.json(&m)).collect::<Vec<_>>(),
            );
        }
        return out_text(format!("{}\n", json::to_string(&o)?));
    }
    let mut s = fits
        .as_deref()
        .map_or(String::new(), |f| report_fits(&m, f));
    for a in &e.axes {
        s.push_str(&format!(
            "{}: direction {} through {}; tilt from nominal {:.6}° ({:.1} µrad); circle rms {:.3e}\n",
            a.name, v3(a.direction), v3(a.point), a.tilt_deg, a.tilt_deg.to_radians() * 1e6, a.rms
        ));
    }
    s.push_str(&format!(
        "{} and {}: {} ({:.3e} apart at the closest points {} and {}); squareness error {:.6}° ({:.1} µrad)\n",
        e.axes[0].name, e.axes[1].name,
        if e.offset < 1e-9 { "intersect" } else { "do not intersect" },
        e.offset, v3(e.closest_points[0]), v3(e.closest_points[1]), e.squareness_deg, e.squareness_deg.to_radians() * 1e6
    ));
    out_text(s)
}

pub fn factorial(
    start: Option<&str>,
    step: Option<f64>,
    fit: Option<&str>,
    json: bool,
) -> Result<(), CliError> {
    match (start, step, fit) {
        (Some(st), Some(d), None) => {
            let c = vector("--start", st)?;
            if !(d.is_finite() && d > 0.0) {
                return Err(CliError::usage(format!(
                    "error: --step {d}: must be positive\n"
                )));
            }
            let runs = calib::factorial_design(c, d).map_err(|e| {
                CliError::usage(format!(
                    "error: --start {st} --step {d:e}: {e}\n  = help: give the start centre and the step in the machine's units\n"
                ))
            })?;
            if json {
                let v: Vec<Obj> = runs
                    .iter()
                    .map(|(r, l, c)| obj! {"run": r, "levels": l, "center": [c.x, c.y, c.z]})
                    .collect();
                return out_text(format!("{}\n", json::to_string(&obj! { "runs": v })?));
            }
            let mut s = String::from("run x y z (levels) -> centre\n");
            for (r, l, c) in runs {
                s.push_str(&format!(
                    "{r} {:+} {:+} {:+} -> {:.6} {:.6} {:.6}\n",
                    l[0], l[1], l[2], c.x, c.y, c.z
                ));
            }
            out_text(s)
        }
        (None, None, Some(f)) => {
            let (name, text) = read_text(f)?;
            let mut rows = Vec::new();
            for (i, raw) in text.lines().enumerate() {
                let code = raw.split('#').next().unwrap_or("");
                let fields: Vec<&str> = row_fields(code);
                if fields.is_empty()
                    || (rows.is_empty()
                        && fields.iter().any(|x| x.chars().any(char::is_alphabetic)))
                {
                    continue;
                }
                let nums: Result<Vec<f64>, _> = fields.iter().map(|x| x.parse::<f64>()).collect();
                let nums = nums.map_err(|_| {
                    located(
                        &name,
                        i + 1,
                        raw,
                        "not a number in this row",
                        "rows are: x y z variation (or run x y z variation)",
                    )
                })?;
                let v = match nums.len() {
                    4 => nums,
                    5 => nums[1..].to_vec(),
                    n => {
                        return Err(located(
                            &name,
                            i + 1,
                            raw,
                            &format!("row has {n} columns"),
                            "rows are: x y z variation (or run x y z variation)",
                        ))
                    }
                };
                rows.push((P3::new(v[0], v[1], v[2]), v[3]));
            }
            let r = calib::factorial_fit(&rows).map_err(|e| align_error(&name, e))?;
            if json {
                return out_text(format!("{}\n", json::to_string(&r)?));
            }
            out_text(format!(
                "variation = {:.6} + {:.6}x + {:.6}y + {:.6}z (coded levels; eq. 18)\nleast variation: run {} at {}\nproposed next centre (zero predicted variation): {}\nregression rms {:.3e}\nnote: Method II ignores z's coupling and needs drilled test holes; Method III and the axis-line fit measure the centre directly\n",
                r.coefficients[0], r.coefficients[1], r.coefficients[2], r.coefficients[3], r.best_run, v3(r.best_center), v3(r.proposed_center), r.rms
            ))
        }
        _ => Err(CliError::usage(
            "error: give --start x,y,z --step d (the design), or --fit RESULTS (the regression)\n"
                .to_string(),
        )),
    }
}

pub fn laser(
    burned: &[String],
    probed: &[String],
    file: Option<&str>,
    json: bool,
) -> Result<(), CliError> {
    let mut pairs = Vec::new();
    if burned.len() != probed.len() {
        return Err(CliError::usage(format!(
            "error: {} --burned but {} --probed\n  = help: give them in pairs, one --probed for each --burned\n",
            burned.len(),
            probed.len()
        )));
    }
    for (b, p) in burned.iter().zip(probed) {
        pairs.push((vector("--burned", b)?, vector("--probed", p)?));
    }
    if let Some(f) = file {
        let (name, text) = read_text(f)?;
        for (i, raw) in text.lines().enumerate() {
            let code = raw.split('#').next().unwrap_or("");
            let fields: Vec<&str> = row_fields(code);
            if fields.is_empty() || fields.iter().all(|x| x.parse::<f64>().is_err()) {
                continue;
            }
            let nums: Result<Vec<f64>, _> = fields.iter().map(|x| x.parse::<f64>()).collect();
            match nums {
                Ok(v) if v.len() == 6 && v.iter().all(|x| x.is_finite()) => {
                    pairs.push((P3::new(v[0], v[1], v[2]), P3::new(v[3], v[4], v[5])))
                }
                _ => {
                    return Err(located(
                        &name,
                        i + 1,
                        raw,
                        "expected six numbers: burned x y z, probed x y z",
                        "one burn mark per row",
                    ))
                }
            }
        }
    }
    let (l, spread) = calib::laser_offset(&pairs).map_err(|e| align_error("the burn marks", e))?;
    if json {
        return out_text(format!(
            "{}\n",
            json::to_string(&obj! {"L": l, "spread": spread, "n": pairs.len()})?
        ));
    }
    out_text(format!(
        "L {}\nspread {}\nn {}\nnote: L = probed − burned; to aim the laser at a point q in probe coordinates, command q − L\n",
        v3(l),
        spread.map_or("n/a (one mark)".into(), |s| format!("{:.2e} {:.2e} {:.2e}", s[0], s[1], s[2])),
        pairs.len()
    ))
}

/// `A=0,B=0;A=90,B=0;…`, or the default set for `purpose`: `pivot`, the inner axis at
/// 0/90/180/270 at two tilts of the outer (8 poses); `axes`, those and the outer axis at
/// half the tilt and at minus it (or three-quarters, if its limits forbid that) with the
/// inner at home, so the outer axis turns alone through three angles (10 poses).
fn pose_set(m: &Machine, text: Option<&str>, purpose: &str) -> Result<Vec<[f64; 2]>, CliError> {
    let Some(t) = text else {
        let (i, o) = (m.inner, m.outer);
        let clamp = |x: f64| m.rotary[o].limits.map_or(x, |(lo, hi)| x.min(hi).max(lo));
        let tilt = clamp(45.0);
        let mut v = Vec::new();
        for b in [0.0, tilt] {
            for a in [0.0, 90.0, 180.0, 270.0] {
                let mut r = [0.0; 2];
                r[i] = a;
                r[o] = b;
                v.push(r);
            }
        }
        match purpose {
            "pivot" => {}
            "axes" => {
                let third = if m.rotary[o].within(-tilt) {
                    -tilt
                } else {
                    0.75 * tilt
                };
                for b in [0.5 * tilt, third] {
                    let mut r = [0.0; 2];
                    r[o] = b;
                    v.push(r);
                }
            }
            other => {
                return Err(CliError::usage(format!(
                    "error: --for {other}: give pivot or axes\n"
                )))
            }
        }
        return Ok(v);
    };
    let mut out = Vec::new();
    for item in t.split(';').filter(|s| !s.trim().is_empty()) {
        let v = crate::kin_cmds::joints_arg(m, "--poses", item, &[3, 4], &[])?;
        out.push([v[3].unwrap_or(0.0), v[4].unwrap_or(0.0)]);
    }
    Ok(out)
}

/// A point the probing program moves to, in the machine frame: within every linear
/// axis's travel, or refused naming the axis, its value and the limits.
fn travel_check(m: &Machine, pose: usize, q: &P3) -> Result<(), CliError> {
    let x = m.linear_for(q, 0);
    for (l, &v) in m.linear.iter().zip(&x) {
        if !(v.is_finite() && v >= l.limits.0 && v <= l.limits.1) {
            return Err(CliError::failed(format!(
                "error: at pose {pose} the probing program would move {} to {v:.4}, outside its travel [{}, {}]\n  = help: check --ball (the ball centre at home, in the machine frame) and --radius, or the machine's limits\n",
                l.name, l.limits.0, l.limits.1
            )));
        }
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
pub fn probe_poses(
    machine: &str,
    sets: &[String],
    ball: &str,
    poses: Option<&str>,
    purpose: &str,
    radius: f64,
    stylus: f64,
    points: usize,
    output: Option<&str>,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let b0 = vector("--ball", ball)?;
    let set = pose_set(&m, poses, purpose)?;
    for r in &set {
        for (i, ax) in m.rotary.iter().enumerate() {
            if !ax.within(r[i]) {
                let (lo, hi) = ax.limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
                return Err(CliError::failed(format!(
                    "error: pose {}={}: outside its limits [{lo}, {hi}]\n",
                    ax.name, r[i]
                )));
            }
        }
    }
    if points < 4 || !(radius > 0.0 && stylus > 0.0) {
        return Err(CliError::usage(
            "error: need --points ≥ 4 and positive --radius and --stylus-radius\n".to_string(),
        ));
    }
    // The program holds every touch of every pose: bounded as the other probing
    // programs are (a count of 2³² asked 412 GB).
    let max = crate::align_cmds::MAX_TOUCHES;
    if points.saturating_mul(set.len()) > max {
        return Err(CliError::usage(format!(
            "error: --points {points}: {} poses of {points} touches is more than {max} touches in one program\n  = help: 12 to 30 touches a pose fit each ball centre well\n",
            set.len()
        )));
    }
    // A set that fixes nothing (no poses, every pose at the same angles) is refused,
    // not written as if it fixed R.
    let (cond, line) = calib::pose_conditioning(&m, &set).map_err(|e| {
        CliError::failed(format!(
            "error: --poses: {e}\n  = help: give poses turning about both rotary axes, e.g. A=0,B=0;A=90,B=0;A=0,B=30;A=90,B=30\n"
        ))
    })?;
    let units = match m.units {
        Units::Inch => lampost_gcode::Units::Inch,
        Units::Mm => lampost_gcode::Units::Mm,
    };
    let opts = lampost_align::probe::ProbeOptions {
        program_number: 9502,
        ..lampost_align::probe::ProbeOptions::defaults(units)
    };
    // One program: index, then probe the ball where the nominal model puts it.
    let mut body = Vec::new();
    for (k, r) in set.iter().enumerate() {
        // The ball moves with the table; its stem (table −Z) turns with it. Touch the
        // upper half of the ball (machine +Z side) away from the stem.
        let centre = m.part_to_machine(r, &P3::zeros()) + b0;
        let stem =
            m.part_to_machine(r, &P3::new(0.0, 0.0, -1.0)) - m.part_to_machine(r, &P3::zeros());
        let cands =
            lampost_align::probe::sphere_touches(centre, radius, stylus, points * 4, 90.0, &opts);
        // Touch directions at least 45° away from the stem.
        let stem_unit = stem.normalize();
        let clear = 45f64.to_radians().cos();
        let ok: Vec<_> = cands
            .into_iter()
            .filter(|t| (P3::from(t.expected) - centre).normalize().dot(&stem_unit) < clear)
            .collect();
        let step = (ok.len() / points).max(1);
        let chosen: Vec<_> = ok.into_iter().step_by(step).take(points).collect();
        if chosen.len() < 4 {
            return Err(CliError::failed(format!(
                "error: at pose {k} the stem leaves fewer than 4 reachable touch points\n"
            )));
        }
        for t in &chosen {
            for q in [t.start, t.target] {
                travel_check(&m, k + 1, &P3::from(q))?;
            }
        }
        body.push((*r, centre, chosen));
    }
    let safe = body
        .iter()
        .map(|(_, c, _)| c.z)
        .fold(f64::NEG_INFINITY, f64::max)
        + radius
        + stylus
        + 10.0 * opts.clearance;
    for (k, (_, _, touches)) in body.iter().enumerate() {
        for t in touches {
            travel_check(&m, k + 1, &P3::new(t.start[0], t.start[1], safe))?;
        }
    }
    let comments = vec![
        format!(
            "MACHINE {} - PROBE THE GAGE BALL AT EACH A/B POSE",
            m.name.to_uppercase()
        ),
        format!(
            "POSE SET CONDITION NUMBER {cond:.3e}{}",
            if line.is_some() {
                " - RANK DEFICIENT"
            } else {
                ""
            }
        ),
    ];
    let poses: Vec<lampost_align::probe::PoseTouches> = body
        .iter()
        .map(|(r, _, touches)| lampost_align::probe::PoseTouches {
            rotary: m
                .rotary
                .iter()
                .zip(r)
                .map(|(ax, v)| (ax.name.as_bytes().first().copied().unwrap_or(b'A'), *v))
                .collect(),
            touches: touches.clone(),
        })
        .collect();
    let text = lampost_align::probe::poses_program(
        &poses,
        safe,
        &format!("LAMPOST ROTARY CALIBRATION {} POSES", set.len()),
        &comments,
        &opts,
    )
    .map_err(|e| CliError::write(&e))?;
    let diags = lampost_gcode::check(
        text.as_bytes(),
        lampost_gcode::Options {
            units,
            ..lampost_gcode::Options::default()
        },
    );
    if let Some(d) = diags.iter().find(|d| d.is_error()) {
        return Err(CliError::failed(format!(
            "error: internal: the generated program does not check: {d}\n"
        )));
    }
    match &line {
        None => eprintln!("pose set: {} poses, condition number {cond:.3e} (Method III design); R and the centre are fixed", set.len()),
        Some(d) => eprintln!(
            "warning: this pose set cannot fix R: every pose turns about ({:.4}, {:.4}, {:.4}); add a pose that moves the other axis",
            d[0], d[1], d[2]
        ),
    }
    let mut o = Output::create(output)?;
    o.writer()
        .write_all(text.as_bytes())
        .map_err(|e| CliError::write(&e))?;
    o.commit()
}
