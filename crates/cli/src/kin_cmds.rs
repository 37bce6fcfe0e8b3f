//! `lampost machines` and `lampost kin fk|ik|rotate`.

use lampost_kinematics::{
    builtin_text, Joints, KinError, Machine, MachineDef, ParamValue, Vector3,
};

use crate::io::{display_name, open_input, Output};
use crate::json::{self, obj, Obj};
use crate::points::parse_points;
use crate::report::CliError;

/// Render a kinematics error for people.
pub fn kin_error(e: KinError) -> CliError {
    let hint = e.hint();
    match &e {
        KinError::MachineFile {
            file,
            line,
            column,
            message,
            text,
        } if *line > 0 => {
            let num = line.to_string();
            let pad = " ".repeat(num.len());
            CliError::failed(format!(
                "error: {message}\n{pad}--> {file}:{line}:{column}\n{pad} |\n{num} | {text}\n{pad} | {}^\n  = help: {hint}\n",
                " ".repeat(column.saturating_sub(1))
            ))
        }
        _ => CliError::failed(format!("error: {e}\n  = help: {hint}\n")),
    }
}

fn usage(flag: &str, msg: String, hint: &str) -> CliError {
    CliError::usage(format!("error: {flag}: {msg}\n  = help: {hint}\n"))
}

fn number(flag: &str, item: &str, text: &str) -> Result<f64, CliError> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(usage(
            flag,
            format!("in `{item}`, `{}` is not a finite number", text.trim()),
            "give plain decimal numbers, e.g. 1.25",
        )),
    }
}

/// `x,y,z`
pub fn vector(flag: &str, text: &str) -> Result<Vector3<f64>, CliError> {
    let parts: Vec<&str> = text.split(',').collect();
    if parts.len() != 3 {
        return Err(usage(
            flag,
            format!("`{text}` has {} values; expected x,y,z", parts.len()),
            "give three comma-separated numbers, e.g. 0,0,1",
        ));
    }
    Ok(Vector3::new(
        number(flag, text, parts[0])?,
        number(flag, text, parts[1])?,
        number(flag, text, parts[2])?,
    ))
}

/// The largest coordinate a place given on the command line may have (1e9 units: a
/// thousand kilometres in millimetres): beyond it no machine reaches, and the
/// numbers would be written with hundreds of digits.
pub const MAX_PLACE: f64 = 1e9;

/// `x,y,z` as a place ([`vector`], each coordinate within [`MAX_PLACE`]).
pub fn position(flag: &str, text: &str) -> Result<Vector3<f64>, CliError> {
    let v = vector(flag, text)?;
    if v.iter().any(|c| c.abs() > MAX_PLACE) {
        return Err(usage(
            flag,
            format!("`{text}` lies more than 1e9 from the origin"),
            "give the place in the machine's units (in or mm), e.g. 0,0,25",
        ));
    }
    Ok(v)
}

/// `i,j,k` as a unit direction: scaled by its largest component before its length is
/// taken, so `1e300,1e300,1e300` is (1,1,1)/√3, not an overflow; zero length refused.
pub fn direction(flag: &str, text: &str) -> Result<Vector3<f64>, CliError> {
    unit(vector(flag, text)?).ok_or_else(|| {
        usage(
            flag,
            format!("`{text}` has zero length: it names no direction"),
            "give a non-zero direction i,j,k, e.g. 0,0,1",
        )
    })
}

/// `v` as a unit vector, its length taken without overflow (scaled by its largest
/// component first); `None` for a zero (or vanishing) vector.
pub fn unit(v: Vector3<f64>) -> Option<Vector3<f64>> {
    let big = v.amax();
    let u = if big > 0.0 { v / big } else { v };
    let n = u.norm();
    if !(n > 0.0 && n.is_finite()) || big < 1e-300 {
        return None;
    }
    Some(u / n)
}

/// Refuse a result with a non-finite number: say so instead of printing it.
pub fn finite(what: &str, vals: &[f64]) -> Result<(), CliError> {
    if vals.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(CliError::failed(format!(
            "error: {what} is not a finite number (the machine's geometry overflows)\n  = help: check the machine file's offsets and their `scale`, and the joint values\n"
        )))
    }
}

/// `NAME=x,y,z` or `NAME=value`, repeatable.
pub fn overrides(sets: &[String]) -> Result<Vec<(String, ParamValue)>, CliError> {
    let mut out = Vec::new();
    for s in sets {
        let (name, value) = s.split_once('=').ok_or_else(|| {
            usage(
                "--set",
                format!("`{s}` is not NAME=value"),
                "e.g. --set R=-4.877,1.4798,7.0918 or --set H=150",
            )
        })?;
        let parts: Vec<&str> = value.split(',').collect();
        let v = match parts.len() {
            1 => ParamValue::Scalar(number("--set", s, parts[0])?),
            3 => ParamValue::Vector([
                number("--set", s, parts[0])?,
                number("--set", s, parts[1])?,
                number("--set", s, parts[2])?,
            ]),
            n => {
                return Err(usage(
                    "--set",
                    format!("`{s}` has {n} values"),
                    "give one value or three (x,y,z)",
                ))
            }
        };
        out.push((name.trim().to_string(), v));
    }
    Ok(out)
}

/// Every built-in machine's name, tables and arms.
pub fn builtin_names() -> Vec<&'static str> {
    lampost_kinematics::BUILTINS
        .iter()
        .chain(lampost_robot::ARM_BUILTINS.iter())
        .map(|(n, _)| *n)
        .collect()
}

/// Load a machine by built-in name or path.
/// A machine file is a file: a named pipe with no writer would wait for ever, a
/// device give endless bytes.
pub(crate) fn regular_machine_file(spec: &str) -> Result<(), CliError> {
    if std::fs::metadata(spec).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        return Err(CliError::usage(format!(
            "error: --machine {spec}: not a regular file (a pipe or a device)\n  = help: give the path of a machine file, or a built-in machine's name\n"
        )));
    }
    Ok(())
}

pub fn load_machine(spec: &str, sets: &[String]) -> Result<Machine, CliError> {
    let ov = overrides(sets)?;
    if crate::robot_cmds::arm_for(spec)?.is_some() {
        return Err(CliError::usage(format!(
            "error: --machine {spec}: an arm (six-axis robot); this command is for table machines\n  = help: arms are posted and verified: `lampost post --machine {spec} PATH -o DIR`, `lampost verify --machine {spec} DIR --input PATH`\n"
        )));
    }
    if builtin_text(spec).is_some() {
        return Machine::builtin(spec, &ov).map_err(kin_error);
    }
    regular_machine_file(spec)?;
    let text = crate::io::read_settings_file(spec).map_err(|e| {
        let names = builtin_names();
        CliError::usage(format!(
            "error: --machine {spec}: not a built-in machine and not a readable file ({e})\n  = help: built-in machines: {}; or give the path of a machine file\n",
            names.join(", ")
        ))
    })?;
    let d = MachineDef::from_toml(&text, spec).map_err(kin_error)?;
    Machine::new(d, &ov).map_err(kin_error)
}

/// `A=1,B=2` against the machine's axis names; `need` lists the indices (0–4) that must
/// be given, `allowed` those that may.
pub(crate) fn joints_arg(
    m: &Machine,
    flag: &str,
    text: &str,
    allowed: &[usize],
    need: &[usize],
) -> Result<[Option<f64>; 5], CliError> {
    let names = m.axis_names();
    let mut vals = [None; 5];
    for item in text.split(',').filter(|s| !s.trim().is_empty()) {
        let (n, v) = item.split_once('=').ok_or_else(|| {
            usage(
                flag,
                format!("`{item}` is not NAME=value"),
                "e.g. X=0,Y=0,Z=0,A=30,B=-45",
            )
        })?;
        let n = n.trim();
        let idx = names
            .iter()
            .position(|a| a.eq_ignore_ascii_case(n))
            .ok_or_else(|| {
                kin_error(KinError::UnknownAxis {
                    name: n.to_string(),
                    known: names.join(", "),
                })
            })?;
        if !allowed.contains(&idx) {
            let ok: Vec<&str> = allowed.iter().map(|&i| names[i]).collect();
            return Err(usage(
                flag,
                format!("axis {n} does not belong here"),
                &format!("this takes {}", ok.join(", ")),
            ));
        }
        if vals[idx].is_some() {
            return Err(usage(
                flag,
                format!("axis {n} is given twice"),
                "give each axis once",
            ));
        }
        vals[idx] = Some(number(flag, item, v)?);
    }
    for &i in need {
        if vals[i].is_none() {
            return Err(kin_error(KinError::MissingJoint(names[i].to_string())));
        }
    }
    Ok(vals)
}

/// `--near A=..,B=..` (default all 0) as rotary values in file order.
pub fn near_rotary(m: &Machine, near: Option<&str>) -> Result<[f64; 2], CliError> {
    match near {
        Some(t) => {
            let v = joints_arg(m, "--near", t, &[3, 4], &[])?;
            Ok([v[3].unwrap_or(0.0), v[4].unwrap_or(0.0)])
        }
        None => Ok([0.0, 0.0]),
    }
}

/// The named head, or the machine's first head.
fn head_index(m: &Machine, head: Option<&str>) -> Result<usize, CliError> {
    match head {
        Some(h) => m.head(h).map_err(kin_error),
        None => Ok(0),
    }
}

fn fmt6(v: f64) -> String {
    let s = format!("{v:.6}");
    if s.starts_with('-') && s[1..].bytes().all(|c| c == b'0' || c == b'.') {
        s[1..].to_string()
    } else {
        s
    }
}

fn write_out(output: &mut Output, text: &str) -> Result<(), CliError> {
    output
        .writer()
        .write_all(text.as_bytes())
        .map_err(|e| CliError::write(&e))
}

pub fn machines(show: Option<&str>) -> Result<(), CliError> {
    let mut out = Output::create(None)?;
    match show {
        None => {
            let mut s = String::new();
            for (name, _) in lampost_kinematics::BUILTINS {
                let d = MachineDef::builtin(name)
                    .map(|d| d.description)
                    .unwrap_or_default();
                s.push_str(&format!("{name:<12} {d}\n"));
            }
            for (name, _) in lampost_robot::ARM_BUILTINS {
                let d = lampost_robot::ArmDef::builtin(name)
                    .map(|d| d.description)
                    .unwrap_or_default();
                s.push_str(&format!("{name:<12} {d}\n"));
            }
            write_out(&mut out, &s)?;
        }
        Some(name) => {
            let text = builtin_text(name)
                .or_else(|| lampost_robot::builtin_text(name))
                .ok_or_else(|| {
                    let names = builtin_names();
                    CliError::usage(format!(
                    "error: no built-in machine named {name}\n  = help: built-in machines: {}\n",
                    names.join(", ")
                ))
                })?;
            write_out(&mut out, text)?;
        }
    }
    out.commit()
}

pub fn fk(
    machine: &str,
    joints: &str,
    head: Option<&str>,
    sets: &[String],
    json: bool,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let h = head_index(&m, head)?;
    let v = joints_arg(&m, "--joints", joints, &[0, 1, 2, 3, 4], &[0, 1, 2, 3, 4])?;
    let j = Joints {
        linear: [
            v[0].unwrap_or(0.0),
            v[1].unwrap_or(0.0),
            v[2].unwrap_or(0.0),
        ],
        rotary: [v[3].unwrap_or(0.0), v[4].unwrap_or(0.0)],
    };
    m.check_limits(&j).map_err(kin_error)?;
    let pose = m.forward(&j, h);
    finite(
        "the forward kinematics' result",
        &[
            pose.tip.x,
            pose.tip.y,
            pose.tip.z,
            pose.axis.x,
            pose.axis.y,
            pose.axis.z,
        ],
    )?;
    let mut out = Output::create(None)?;
    let text = if json {
        format!(
            "{}\n",
            json::to_string(
                &obj! {"position": [pose.tip.x, pose.tip.y, pose.tip.z], "axis": [pose.axis.x, pose.axis.y, pose.axis.z]}
            )?
        )
    } else {
        format!(
            "position {} {} {}\naxis {} {} {}\n",
            fmt6(pose.tip.x),
            fmt6(pose.tip.y),
            fmt6(pose.tip.z),
            fmt6(pose.axis.x),
            fmt6(pose.axis.y),
            fmt6(pose.axis.z)
        )
    };
    write_out(&mut out, &text)?;
    out.commit()
}

pub fn ik(
    machine: &str,
    position: &str,
    axis: &str,
    head: Option<&str>,
    near: Option<&str>,
    sets: &[String],
    json: bool,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let h = head_index(&m, head)?;
    let p = vector("--position", position)?;
    let a = direction("--axis", axis)?;
    let near = match near {
        Some(t) => {
            let v = joints_arg(&m, "--near", t, &[3, 4], &[])?;
            [v[3].unwrap_or(0.0), v[4].unwrap_or(0.0)]
        }
        None => [0.0, 0.0],
    };
    let sols = m.inverse(&p, &a, h, &near).map_err(kin_error)?;
    if !sols.as_slice().iter().any(|s| s.within_limits) {
        return Err(kin_error(match m.choose(&sols, None, &a, h) {
            Err(e) => e,
            Ok(_) => KinError::Unreachable {
                what: "no solution within limits".into(),
            },
        }));
    }
    for sol in sols.as_slice() {
        finite("an inverse-kinematics solution", &sol.joints.values())?;
    }
    let names = m.axis_names();
    let mut out = Output::create(None)?;
    let text = if json {
        let list: Vec<Obj> = sols
            .as_slice()
            .iter()
            .map(|s| {
                let mut j = Obj::new();
                for (n, v) in names.iter().zip(s.joints.values()) {
                    j.set(n, &v);
                }
                obj!{"joints": j, "within_limits": s.within_limits, "branch": s.branch, "singular": s.singular}
            })
            .collect();
        format!("{}\n", json::to_string(&obj! { "solutions": list })?)
    } else {
        let mut s = String::new();
        for sol in sols.as_slice() {
            let parts: Vec<String> = names
                .iter()
                .zip(sol.joints.values())
                .map(|(n, v)| format!("{n}={}", fmt6(v)))
                .collect();
            s.push_str(&parts.join(" "));
            s.push_str(if sol.within_limits {
                "  within limits"
            } else {
                "  OUTSIDE LIMITS"
            });
            if sol.singular {
                s.push_str("  (singular: an axis kept its --near value)");
            }
            s.push('\n');
        }
        s
    };
    write_out(&mut out, &text)?;
    out.commit()
}

/// `kin ik --points FILE`: every row's pose (tip `x y z`, tool axis `i j k`) solved by
/// the batch solver ([`Machine::inverse_into`], the scalar function's answers bit for
/// bit), each ranked from `--near`; out, one row of joints per pose (the best within
/// limits), or the first pose no solution reaches, named by its line.
pub fn ik_points(
    machine: &str,
    file: &str,
    head: Option<&str>,
    near: Option<&str>,
    sets: &[String],
    json: bool,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let h = head_index(&m, head)?;
    let near = match near {
        Some(t) => {
            let v = joints_arg(&m, "--near", t, &[3, 4], &[])?;
            [v[3].unwrap_or(0.0), v[4].unwrap_or(0.0)]
        }
        None => [0.0, 0.0],
    };
    let mut text = String::new();
    crate::io::read_to_string_checked(&mut open_input(file)?, &mut text)
        .map_err(|e| CliError::usage(format!("error: cannot read {file}: {e}\n")))?;
    let name = display_name(file);
    let pts = parse_points(&text, &name)?;
    // Stage 1: the queries, each axis a direction.
    let mut queries = Vec::with_capacity(pts.len());
    for pt in &pts {
        let Some(n) = pt.normal else {
            return Err(CliError::failed(format!(
                "error: {name} has no tool axis columns\n  = help: start the file with a header naming the columns: x y z i j k\n"
            )));
        };
        // Made unit as `--axis` is, so each row asks what `kin ik --axis` would.
        let Some(axis) = unit(Vector3::from(n)) else {
            return Err(CliError::failed(format!(
                "error: {name}:{}: the tool axis ({}, {}, {}) has no direction\n  = help: give i j k of the axis from the tip into the head\n",
                pt.line, n[0], n[1], n[2]
            )));
        };
        queries.push(lampost_kinematics::IkQuery {
            tip: Vector3::from(pt.p),
            axis,
            near,
        });
    }
    // Stage 2: all solved at once, then the best within limits of each.
    let mut sols = Vec::new();
    m.inverse_into(&queries, h, &mut sols);
    let mut rows = Vec::with_capacity(pts.len());
    for ((pt, q), s) in pts.iter().zip(&queries).zip(&sols) {
        let at = |e: KinError| {
            CliError::failed(format!(
                "error: {name}:{}: {e}\n  = help: {}\n",
                pt.line,
                e.hint()
            ))
        };
        let s = s.clone().map_err(at)?;
        let c = m.choose(&s, None, &q.axis, h).map_err(at)?;
        finite(
            &format!("the joints of the pose on {name}:{}", pt.line),
            &c.solution.joints.values(),
        )?;
        rows.push(c.solution);
    }
    // Stage 3: written.
    let names = m.axis_names();
    let mut out = Output::create(None)?;
    let text = if json {
        let list: Vec<Obj> = pts
            .iter()
            .zip(&rows)
            .map(|(pt, s)| {
                let mut j = Obj::new();
                for (n, v) in names.iter().zip(s.joints.values()) {
                    j.set(n, &v);
                }
                obj! {"line": pt.line, "joints": j, "branch": s.branch, "singular": s.singular}
            })
            .collect();
        format!("{}\n", json::to_string(&obj! { "poses": list })?)
    } else {
        let mut t = format!("{}\n", names.join(" "));
        for s in &rows {
            let v: Vec<String> = s.joints.values().iter().map(|x| fmt6(*x)).collect();
            t.push_str(&v.join(" "));
            t.push('\n');
        }
        t
    };
    write_out(&mut out, &text)?;
    out.commit()
}

pub fn rotate(
    machine: &str,
    joints: &str,
    head: Option<&str>,
    sets: &[String],
    file: &str,
    json: bool,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let h = head_index(&m, head)?;
    let v = joints_arg(&m, "--joints", joints, &[3, 4], &[3, 4])?;
    let rotary = [v[3].unwrap_or(0.0), v[4].unwrap_or(0.0)];
    let probe = Joints {
        linear: [0.0; 3],
        rotary,
    };
    // Rotary limits only: the linear travel is checked point by point below.
    for (i, r) in m.rotary.iter().enumerate() {
        if let Some((lo, hi)) = r.limits {
            if !r.within(rotary[i]) {
                return Err(kin_error(KinError::JointOutOfLimit {
                    axis: r.name.clone(),
                    value: probe.rotary[i],
                    lo,
                    hi,
                }));
            }
        }
    }
    let mut text = String::new();
    crate::io::read_to_string_checked(&mut open_input(file)?, &mut text)
        .map_err(|e| CliError::usage(format!("error: cannot read {file}: {e}\n")))?;
    let name = display_name(file);
    let pts = parse_points(&text, &name)?;
    let mut moved = Vec::with_capacity(pts.len());
    for pt in &pts {
        let q = m.part_to_machine(&rotary, &Vector3::from(pt.p));
        let x = m.linear_for(&q, h);
        finite(
            &format!("the machine position of the point on {name}:{}", pt.line),
            &x,
        )?;
        for (l, &val) in m.linear.iter().zip(&x) {
            if val < l.limits.0 || val > l.limits.1 {
                return Err(CliError::failed(format!(
                    "error: the point on {name}:{} needs {} = {val:.4}, outside its travel [{}, {}]\n  = help: move the part or the origin, or check the machine's limits\n",
                    pt.line, l.name, l.limits.0, l.limits.1
                )));
            }
        }
        moved.push(x);
    }
    let mut out = Output::create(None)?;
    let s = if json {
        format!("{}\n", json::to_string(&obj! { "points": moved })?)
    } else {
        moved
            .iter()
            .map(|x| format!("{} {} {}\n", fmt6(x[0]), fmt6(x[1]), fmt6(x[2])))
            .collect()
    };
    write_out(&mut out, &s)?;
    out.commit()
}
