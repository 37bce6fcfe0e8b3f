//! `lampost inspect plan|reduce|compare`: flags onto `lampost_inspect` calls.

use lampost_inspect::{compare, plan, program, reduce, InspectError, Measured, Status, Target};
use lampost_kinematics::Machine;

use crate::io::{display_name, open_input, Output};
use crate::json::{self, obj, Obj};
use crate::kin_cmds::{kin_error, load_machine};
use crate::points::parse_points;
use crate::report::CliError;

fn read(file: &str) -> Result<(String, String), CliError> {
    let name = display_name(file);
    let mut text = String::new();
    crate::io::read_to_string_checked(&mut open_input(file)?, &mut text)
        .map_err(|e| CliError::usage(format!("error: cannot read {name}: {e}\n")))?;
    Ok((name, text))
}

/// An inspect error, at its file's line where it has one.
fn error(name: &str, text: &str, e: InspectError) -> CliError {
    match e {
        InspectError::At { line, what } => CliError::failed(format!(
            "error: {what}\n  --> {name}:{line}\n   | {}\n  = help: {}\n",
            text.lines().nth(line - 1).unwrap_or("").trim(),
            "fix or remove the line"
        )),
        InspectError::NoSensor { .. } => CliError::failed(format!(
            "error: {e}\n  = help: use a head with a sensor (nrc-lc's `sensor`), or add a sensor table to the machine file's head\n"
        )),
        other => CliError::failed(format!("error: {other} ({name})\n")),
    }
}

/// The measuring head: `--head`; else, for a touch probe, the head named `probe`; else
/// the first head with a sensor.
fn sensor_head(m: &Machine, head: Option<&str>, touch: bool) -> Result<usize, CliError> {
    match head {
        Some(h) => m.head(h).map_err(kin_error),
        None if touch => Ok(m.head("probe").unwrap_or(0)),
        None => m
            .def
            .heads
            .iter()
            .position(|h| h.sensor.is_some())
            .ok_or_else(|| {
                CliError::failed(format!(
                    "error: machine {} has no head with a sensor\n  = help: give a machine whose head has a `sensor` table (nrc-lc), add one to the machine file, or measure with a touch probe (--stylus-radius)\n",
                    m.def.name
                ))
            }),
    }
}

fn write_file(path: Option<&str>, text: &str) -> Result<(), CliError> {
    let mut o = Output::create(path)?;
    o.writer()
        .write_all(text.as_bytes())
        .map_err(|e| CliError::write(&e))?;
    o.commit()
}

/// Where the sampling points come from.
#[derive(Debug)]
pub struct Sampling {
    /// A point file with normals.
    pub points: Option<String>,
    /// Or a mesh to sample.
    pub mesh: Option<String>,
    /// Spacing of the samples on the mesh.
    pub spacing: Option<f64>,
    /// The mesh file's units.
    pub mesh_units: Option<crate::mesh_cmds::MeshUnits>,
    /// Section planes (`AXIS=VALUES` each) to sample along instead of the whole mesh.
    pub sections: Vec<String>,
}

/// A mesh file in the machine's units (`units`: the file's, default the machine's; a
/// 3MF in the units it says).
fn mesh_in(
    m: &Machine,
    path: &str,
    units: Option<crate::mesh_cmds::MeshUnits>,
) -> Result<lampost_mesh::Mesh, CliError> {
    let want = crate::mesh_cmds::machine_units(m.units);
    crate::mesh_cmds::read_mesh_in(path, units, want).map(|(mesh, _)| mesh)
}

/// The units of a measured file: those of the machine its header names (`# lampost
/// inspect measured: machine NAME, …`), when that machine can be loaded.
fn measured_units(text: &str) -> Option<lampost_mesh::Units> {
    let head = text
        .lines()
        .next()?
        .strip_prefix("# lampost inspect measured: machine ")?;
    let name = head.split(',').next()?.trim();
    let m = crate::kin_cmds::load_machine(name, &[]).ok()?;
    Some(crate::mesh_cmds::machine_units(m.units))
}

/// `inspect plan`.
#[allow(clippy::too_many_arguments)]
pub fn plan_cmd(
    machine: &str,
    sets: &[String],
    head: Option<&str>,
    sampling: &Sampling,
    max_tilt: Option<f64>,
    output: Option<&str>,
    program_out: Option<&str>,
    skip_unreachable: bool,
    stylus: Option<f64>,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let h = sensor_head(&m, head, stylus.is_some())?;
    let probe = match stylus {
        Some(r) => plan::Probe::Touch { stylus: r },
        None => plan::Probe::Sensor,
    };
    let (name, text, targets) = match (&sampling.points, &sampling.mesh) {
        (Some(points), _) => {
            let (name, text) = read(points)?;
            let pts = parse_points(&text, &name)?;
            let mut targets = Vec::with_capacity(pts.len());
            for (k, p) in pts.iter().enumerate() {
                let Some(n) = p.normal else {
                    return Err(CliError::failed(format!(
                        "error: {name} has no normal columns\n  = help: start the file with a header naming the columns: x y z i j k (the outward surface normal), optionally with an id\n"
                    )));
                };
                targets.push(Target {
                    id: format!("p{}", k + 1),
                    point: p.p,
                    normal: n,
                });
            }
            (name, text, targets)
        }
        (None, Some(mesh)) => {
            let mut sections = Vec::new();
            for spec in &sampling.sections {
                sections.extend(lampost_inspect::surface::parse_sections(spec).map_err(|e| {
                    CliError::failed(format!(
                        "error: {e}\n  = help: --sections AXIS=VALUES: x, y or z, then values and start:stop:step ranges, comma-separated (z=5,10,15 or x=0:100:10)\n"
                    ))
                })?);
            }
            let part = mesh_in(&m, mesh, sampling.mesh_units)?;
            let spacing = sampling.spacing.unwrap_or(0.0);
            let targets = if sections.is_empty() {
                lampost_inspect::surface::sample(&part, spacing)
            } else {
                lampost_inspect::surface::sample_sections(&part, &sections, spacing)
            }
            .map_err(|e| error(mesh, "", e))?;
            (display_name(mesh), String::new(), targets)
        }
        (None, None) => {
            return Err(CliError::usage(
                "error: give --points FILE or --mesh PART --spacing S\n".to_string(),
            ))
        }
    };
    let plan = plan::plan(&m, h, probe, &targets, max_tilt).map_err(|e| error(&name, &text, e))?;
    if !plan.unreachable.is_empty() {
        let list: Vec<String> = plan.unreachable.iter().map(|e| format!("  {e}")).collect();
        let msg = format!(
            "{} of {} points cannot be measured:\n{}\n",
            plan.unreachable.len(),
            targets.len(),
            list.join("\n")
        );
        if !skip_unreachable {
            return Err(CliError::failed(format!(
                "error: {msg}  = help: move or re-fixture the part, allow more --max-tilt (up to the sensor's), or pass --skip-unreachable to plan the rest\n"
            )));
        }
        eprint!("warning: {msg}");
    }
    if plan.rows.is_empty() {
        return Err(CliError::failed(format!(
            "error: no point of {name} can be measured; nothing written\n"
        )));
    }
    // Everything is made before anything is written.
    let table = plan::to_text(&m, h, probe, &plan.rows);
    let prog = match program_out {
        Some(_) => {
            let p = match probe {
                plan::Probe::Sensor => program::write(&m, h, &plan.rows),
                plan::Probe::Touch { stylus } => program::write_touch(&m, h, stylus, &plan.rows),
            }
            .map_err(|e| error(&name, &text, e))?;
            let units = match m.units {
                lampost_kinematics::Units::Inch => lampost_gcode::Units::Inch,
                lampost_kinematics::Units::Mm => lampost_gcode::Units::Mm,
            };
            let diags = lampost_gcode::check(
                p.as_bytes(),
                lampost_gcode::Options {
                    units,
                    ..lampost_gcode::Options::default()
                },
            );
            if let Some(d) = diags.iter().find(|d| d.is_error()) {
                return Err(CliError::failed(format!(
                    "error: internal: the measuring program does not check: {d}\n"
                )));
            }
            Some(p)
        }
        None => None,
    };
    // The measuring program and the plan placed as one set.
    let mut files: Vec<(Option<&str>, &[u8])> = Vec::new();
    if let (Some(path), Some(p)) = (program_out, &prog) {
        files.push((Some(path), p.as_bytes()));
    }
    files.push((output, table.as_bytes()));
    crate::io::write_set(&files)?;
    let tilted = plan.rows.iter().filter(|r| r.tilt_deg > 0.0).count();
    eprintln!(
        "planned {} points on {} (head {}){}",
        plan.rows.len(),
        m.def.name,
        m.def.heads[h].name,
        if tilted > 0 {
            format!(", {tilted} with the beam tilted from the normal")
        } else {
            String::new()
        }
    );
    Ok(())
}

fn status_name(s: Status) -> &'static str {
    match s {
        Status::Ok => "ok",
        Status::OutOfRange => "out_of_range",
        Status::NoReading => "no_reading",
        Status::Missing => "missing",
    }
}

/// `inspect reduce`.
pub fn reduce_cmd(
    machine: &str,
    sets: &[String],
    head: Option<&str>,
    plan_file: &str,
    log: &str,
    output: Option<&str>,
    json_out: bool,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let (pname, ptext) = read(plan_file)?;
    let touch = ptext
        .lines()
        .any(|l| l.starts_with("# lampost inspect plan:") && l.contains(", stylus "));
    let h = sensor_head(&m, head, touch)?;
    let (probe, rows) = plan::read_text(&m, h, &ptext).map_err(|e| error(&pname, &ptext, e))?;
    let (lname, ltext) = read(log)?;
    let got = match probe {
        plan::Probe::Sensor => {
            let readings = reduce::read_log(&ltext).map_err(|e| error(&lname, &ltext, e))?;
            reduce::reduce(&m, h, &rows, &readings).map_err(|e| error(&lname, &ltext, e))?
        }
        plan::Probe::Touch { stylus } => {
            let poses = lampost_align::probe::read_pose_log(&ltext)
                .map_err(|e| match e {
                    lampost_align::probe::LogError::Malformed { line, text: _, why } => {
                        error(&lname, &ltext, InspectError::At { line, what: why })
                    }
                    other => CliError::failed(format!("error: {lname}: {other}\n")),
                })?
                .ok_or_else(|| {
                    CliError::failed(format!(
                        "error: {lname} has no POSE records\n  = help: give the RS-232 log of the measuring program `inspect plan --program` wrote\n"
                    ))
                })?;
            reduce::reduce_touch(&m, h, stylus, &rows, &poses)
                .map_err(|e| error(&lname, &ltext, e))?
        }
    };
    let flagged: Vec<&Measured> = got.iter().filter(|g| g.status != Status::Ok).collect();
    for f in &flagged {
        eprintln!(
            "warning: point {}: {}{}",
            f.id,
            status_name(f.status).replace('_', " "),
            f.reading
                .map_or(String::new(), |r| format!(" (reading {r})"))
        );
    }
    let text = if json_out {
        format!("{}\n", json::to_string(&obj! {"points": got})?)
    } else {
        let mut s = format!(
            "# lampost inspect measured: machine {}, plan {pname}, log {lname}; deviation along the nominal normal (+ outside)\nid x y z i j k mx my mz reading deviation status\n",
            m.def.name
        );
        let opt = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.9}"));
        for g in &got {
            let mm = g
                .measured
                .map_or(["-".to_string(), "-".into(), "-".into()], |q| {
                    q.map(|x| format!("{x:.9}"))
                });
            s.push_str(&format!(
                "{} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {} {} {} {} {} {}\n",
                g.id,
                g.nominal[0],
                g.nominal[1],
                g.nominal[2],
                g.normal[0],
                g.normal[1],
                g.normal[2],
                mm[0],
                mm[1],
                mm[2],
                opt(g.reading),
                opt(g.deviation),
                status_name(g.status)
            ));
        }
        s
    };
    write_file(output, &text)?;
    eprintln!(
        "reduced {} of {} points ({} flagged)",
        got.len() - flagged.len(),
        got.len(),
        flagged.len()
    );
    Ok(())
}

/// `inspect simulate`.
#[allow(clippy::too_many_arguments)]
pub fn simulate_cmd(
    machine: &str,
    sets: &[String],
    head: Option<&str>,
    plan_file: &str,
    mesh: &str,
    mesh_units: Option<crate::mesh_cmds::MeshUnits>,
    noise: f64,
    seed: u64,
    output: Option<&str>,
) -> Result<(), CliError> {
    let m = load_machine(machine, sets)?;
    let (pname, ptext) = read(plan_file)?;
    let h = sensor_head(&m, head, false)?;
    let (probe, rows) = plan::read_text(&m, h, &ptext).map_err(|e| error(&pname, &ptext, e))?;
    if probe != plan::Probe::Sensor {
        return Err(CliError::failed(format!(
            "error: {pname} is a touch-probe plan; the simulator reads with a displacement sensor\n"
        )));
    }
    let actual = mesh_in(&m, mesh, mesh_units)?;
    let got = lampost_inspect::surface::simulate(
        &m,
        h,
        &rows,
        &actual,
        lampost_inspect::surface::SimOptions { noise, seed },
    )
    .map_err(|e| error(mesh, "", e))?;
    let mut s = format!(
        "# simulated by lampost inspect simulate: plan {pname}, actual {}, noise {noise}, seed {seed}\n",
        display_name(mesh)
    );
    let mut none = 0;
    for (id, r) in &got {
        match r {
            reduce::Reading::Value(v) => s.push_str(&format!("{id} {v:.9}\n")),
            reduce::Reading::None(_) => {
                none += 1;
                s.push_str(&format!("{id} none\n"));
            }
        }
    }
    write_file(output, &s)?;
    eprintln!("simulated {} readings ({none} with no reading)", got.len());
    Ok(())
}

/// What `inspect compare` is asked for, beyond the measured file: its options, defined
/// once (flattened into the command line's `inspect compare`).
#[derive(Debug, Default, clap::Args)]
pub struct CompareArgs {
    /// The nominal CAD mesh: each measured point's signed distance to it too (unsigned where the mesh is open).
    #[arg(long)]
    pub mesh: Option<String>,
    /// The mesh file's units, when not the measured file's machine's.
    #[arg(long, value_enum)]
    pub mesh_units: Option<crate::mesh_cmds::MeshUnits>,
    /// The setup the measured part's program was posted with: the mesh (program frame) is placed on the part by it, and --write-setup composes the correction with it.
    #[arg(long, requires = "mesh")]
    pub setup: Option<String>,
    /// Tolerance ± (same unit).
    #[arg(long)]
    pub tol: Option<f64>,
    /// Best-fit the measured points to the mesh first (the registration of `align register`, trimmed of points beyond 3 robust sigma), then report deviations after it.
    #[arg(long, requires = "mesh")]
    pub best_fit: bool,
    /// Degrees of freedom the best fit holds: x, y, z, rx, ry, rz, tilt, translation, rotation (comma-separated).
    #[arg(long, requires = "best_fit")]
    pub lock: Option<String>,
    /// Write the best fit as a setup file (atomic) for `lampost post --setup`: the program frame placed on the part as measured.
    #[arg(long, value_name = "FILE.toml", requires = "best_fit")]
    pub write_setup: Option<String>,
    /// Per-point CSV (atomic).
    #[arg(long, value_name = "FILE.csv")]
    pub csv: Option<String>,
    /// SVG colour map of the deviations over the part, top view, with a Tol+/Tol− legend (needs --tol).
    #[arg(long, value_name = "FILE.svg", requires = "tol")]
    pub svg: Option<String>,
    /// Coloured point cloud, ASCII PLY (vertex colours by tolerance band, deviation as quality; needs --tol).
    #[arg(long, value_name = "FILE.ply", requires = "tol")]
    pub ply: Option<String>,
    /// Write JSON.
    #[arg(long)]
    pub json: bool,
}

/// One measured row of a reduced file.
struct Row {
    id: String,
    line: usize,
    nominal: [f64; 3],
    normal: [f64; 3],
    measured: [f64; 3],
    deviation: f64,
}

/// The `ok` rows of a file `inspect reduce` wrote, and the count of flagged ones.
fn read_measured(name: &str, text: &str) -> Result<(Vec<Row>, usize), CliError> {
    let mut header = false;
    let mut flagged = 0usize;
    let mut rows = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let t = raw.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let at = |what: String| {
            CliError::failed(format!(
                "error: {what}\n  --> {name}:{}\n   | {t}\n  = help: give the file `lampost inspect reduce` wrote\n",
                i + 1
            ))
        };
        if !header {
            if !t.starts_with("id x y z i j k") {
                return Err(at(
                    "not a file `lampost inspect reduce` wrote (its header is `id x y z i j k mx my mz reading deviation status`)".into(),
                ));
            }
            header = true;
            continue;
        }
        let f: Vec<&str> = t.split_whitespace().collect();
        if f.len() != 13 {
            return Err(at(format!("{} columns, a reduced row has 13", f.len())));
        }
        if f[12] != "ok" {
            flagged += 1;
            continue;
        }
        let mut v = [0.0; 10];
        for (k, x) in v.iter_mut().enumerate() {
            let col = if k < 9 { k + 1 } else { 11 };
            *x = f[col]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| at(format!("`{}` is not a finite number", f[col])))?;
        }
        rows.push(Row {
            id: f[0].to_string(),
            line: i + 1,
            nominal: [v[0], v[1], v[2]],
            normal: [v[3], v[4], v[5]],
            measured: [v[6], v[7], v[8]],
            deviation: v[9],
        });
    }
    Ok((rows, flagged))
}

fn stats_text(s: &compare::Stats, tol: Option<f64>) -> String {
    let mut t = format!(
        "n {}\nmean {:.6}\nsd {:.6}\nrms {:.6}\nmin {:.6}\nmax {:.6}\np05 {:.6}\np50 {:.6}\np95 {:.6}\n",
        s.n, s.mean, s.sd, s.rms, s.min, s.max, s.p05, s.p50, s.p95
    );
    if let (Some(w), Some(tl)) = (s.within_tol, tol) {
        t.push_str(&format!("within ±{tl}: {:.1} %\n", 100.0 * w));
    }
    t
}

/// `inspect compare`: deviations of a reduced file, with statistics; optionally after a
/// best-fit alignment to the CAD mesh, with the correction as a setup, per-point CSV, an
/// SVG colour map and a coloured PLY.
pub fn compare_cmd(measured: &str, a: &CompareArgs) -> Result<(), CliError> {
    let tol = a.tol;
    if let Some(t) = tol {
        if !(t.is_finite() && t > 0.0) {
            return Err(CliError::usage(format!(
                "error: --tol {t}: give a positive tolerance\n"
            )));
        }
    }
    if (a.svg.is_some() || a.ply.is_some()) && tol.is_none() {
        return Err(CliError::usage(
            "error: --svg and --ply colour by tolerance band: give --tol T\n".to_string(),
        ));
    }
    let (name, text) = read(measured)?;
    let (rows, flagged) = read_measured(&name, &text)?;
    if rows.is_empty() {
        return Err(CliError::failed(format!(
            "error: {name} has no measured point\n  = help: every row is flagged (see its status column)\n"
        )));
    }
    let as_measured: Vec<f64> = rows.iter().map(|r| r.deviation).collect();
    // The nominal mesh, placed on the part by the previous setup when one is given.
    let previous = match &a.setup {
        Some(path) => {
            let (sname, stext) = read(path)?;
            Some(
                lampost_post::read_setup(&stext, &sname)
                    .map_err(|e| CliError::failed(format!("error: {e}\n")))?,
            )
        }
        None => None,
    };
    let part = match &a.mesh {
        Some(path) => {
            // In the measured points' units: those of the machine the file names.
            let mut part = match measured_units(&text) {
                Some(want) => crate::mesh_cmds::read_mesh_in(path, a.mesh_units, want)?.0,
                None if a.mesh_units.is_some() => {
                    return Err(CliError::usage(format!(
                        "error: {name}: its header names no machine lampost can load, so its units are not known: leave out --mesh-units and give the mesh in the measured file's units\n"
                    )))
                }
                None => crate::mesh_cmds::read_mesh_file(path)?,
            };
            if let Some(f) = &previous {
                for v in &mut part.vertices {
                    *v = f.apply(v);
                }
            }
            Some((path.as_str(), part))
        }
        None => None,
    };
    // The best fit: part = R·cad + t, from the points within the trimming threshold.
    let fit = match (a.best_fit, &part) {
        (false, _) => None,
        (true, None) => {
            return Err(CliError::usage(
                "error: --best-fit needs the CAD mesh: give --mesh PART\n".to_string(),
            ))
        }
        (true, Some((path, mesh))) => {
            let locks = match &a.lock {
                Some(l) => lampost_align::register::Locks::parse(l).map_err(|e| {
                    CliError::usage(format!(
                        "error: --lock {l}: {e}\n  = help: e.g. --lock z,tilt\n"
                    ))
                })?,
                None => lampost_align::register::Locks::default(),
            };
            let pts: Vec<[f64; 3]> = rows.iter().map(|r| r.measured).collect();
            let bar = crate::progress::Progress::working("best fit", false);
            let fit = compare::best_fit(mesh, &pts, locks);
            drop(bar);
            Some(fit.map_err(|e| {
                CliError::failed(format!(
                    "error: the best fit of {name} to {path} failed: {e}\n  = help: lock what the measured faces cannot fix (--lock), or measure more faces\n"
                ))
            })?)
        }
    };
    if a.write_setup.is_some() && fit.is_none() {
        return Err(CliError::usage(
            "error: --write-setup writes the best fit's correction: give --best-fit\n".to_string(),
        ));
    }
    // Each point in the CAD frame (after the fit) and its deviation along the normal.
    let cad: Vec<[f64; 3]> = rows
        .iter()
        .map(|r| fit.as_ref().map_or(r.measured, |f| f.to_cad(r.measured)))
        .collect();
    let devs: Vec<f64> = match &fit {
        None => as_measured.clone(),
        Some(_) => rows
            .iter()
            .zip(&cad)
            .map(|(r, q)| (0..3).map(|k| (q[k] - r.nominal[k]) * r.normal[k]).sum())
            .collect(),
    };
    let s = compare::stats(&devs, tol)
        .ok_or_else(|| CliError::failed(format!("error: {name} has no measured point\n")))?;
    // Distances to the CAD mesh, signed where it is a closed solid.
    let (mesh_d, mesh_stats) = match &part {
        Some((path, mesh)) => {
            let (d, signed) =
                lampost_inspect::surface::distances(mesh, &cad).map_err(|e| error(path, "", e))?;
            if !signed {
                eprintln!("warning: {path} is not a closed, consistently oriented solid: its distances are unsigned");
            }
            let st = compare::stats(&d, tol).map(|st| (st, signed));
            (Some(d), st)
        }
        None => (None, None),
    };
    // Everything is made before anything is written.
    let setup_text = match (&fit, &a.write_setup) {
        (Some(f), Some(_)) => {
            let (r, t) = (&f.registration.rotation, f.registration.translation);
            // part = R·(P·program + o) + t: the correction composed with the setup the
            // mesh was placed by (none: the identity).
            let (pr, po) = match &previous {
                Some(p) => (
                    std::array::from_fn::<[f64; 3], 3, _>(|i| {
                        std::array::from_fn(|j| p.rot[(i, j)])
                    }),
                    [p.origin.x, p.origin.y, p.origin.z],
                ),
                None => (
                    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                    [0.0; 3],
                ),
            };
            let rows3: [[f64; 3]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|j| (0..3).map(|k| r[i][k] * pr[k][j]).sum())
            });
            let origin: [f64; 3] =
                std::array::from_fn(|i| (0..3).map(|k| r[i][k] * po[k]).sum::<f64>() + t[i]);
            let setup = lampost_align::Setup::from_transform(
                rows3,
                origin,
                &format!(
                    "lampost inspect compare {name} --best-fit: the program frame placed on the part as measured{}",
                    a.setup.as_deref().map_or(String::new(), |p| format!(" (the correction composed with {})", display_name(p)))
                ),
            );
            Some(setup.to_toml())
        }
        _ => None,
    };
    let in_tol = |d: f64| tol.map(|t| d.abs() <= t);
    let map_points: Vec<lampost_inspect::map::MapPoint> = rows
        .iter()
        .zip(&cad)
        .zip(&devs)
        .map(|((r, q), d)| lampost_inspect::map::MapPoint {
            id: r.id.clone(),
            point: *q,
            deviation: *d,
        })
        .collect();
    let csv_text = a.csv.as_ref().map(|_| {
        let mut c = String::from(
            "id,x,y,z,i,j,k,mx,my,mz,deviation_as_measured,deviation,mesh_distance,within_tol,fit_inlier\n",
        );
        for (k, r) in rows.iter().enumerate() {
            let opt = |v: Option<String>| v.unwrap_or_default();
            c.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                r.id,
                r.nominal[0],
                r.nominal[1],
                r.nominal[2],
                r.normal[0],
                r.normal[1],
                r.normal[2],
                cad[k][0],
                cad[k][1],
                cad[k][2],
                r.deviation,
                devs[k],
                opt(mesh_d.as_ref().map(|d| d[k].to_string())),
                opt(in_tol(devs[k]).map(|b| b.to_string())),
                opt(fit.as_ref().map(|f| f.inlier[k].to_string())),
            ));
        }
        c
    });
    let title = format!("lampost inspect compare {name}");
    let svg_text = match (&a.svg, tol) {
        (Some(_), Some(t)) => Some(lampost_inspect::map::svg(
            &map_points,
            part.as_ref().map(|(_, m)| m),
            t,
            &title,
        )),
        _ => None,
    };
    let ply_text = match (&a.ply, tol) {
        (Some(_), Some(t)) => Some(lampost_inspect::map::ply(&map_points, t, &title)),
        _ => None,
    };
    let out = if a.json {
        let points: Vec<Obj> = rows
            .iter()
            .enumerate()
            .map(|(k, r)| {
                let mut o = obj! {"id": r.id, "line": r.line, "nominal": r.nominal, "normal": r.normal,
                    "measured": cad[k], "deviation": devs[k], "within_tol": in_tol(devs[k])};
                if fit.is_some() {
                    o.set("deviation_as_measured", &r.deviation);
                }
                if let Some(d) = &mesh_d {
                    o.set("mesh_distance", &d[k]);
                }
                if let Some(f) = &fit {
                    o.set("fit_inlier", &f.inlier[k]);
                }
                o
            })
            .collect();
        let mut o = obj! {"stats": s, "flagged": flagged, "points": points};
        if let Some((ms, signed)) = &mesh_stats {
            o.set("mesh_stats", ms);
            o.set("mesh_signed", signed);
        }
        if let Some(f) = &fit {
            let g = &f.registration;
            o.set("stats_as_measured", &compare::stats(&as_measured, tol));
            o.set(
                "fit",
                &obj! {"rotation": g.rotation, "translation": g.translation, "axis": g.axis,
                "angle_deg": g.angle_deg, "rms": g.rms, "iterations": g.iterations,
                "u_rotation_deg": g.u_rotation_deg, "u_translation": g.u_translation,
                "centroid": f.centroid, "kept": f.inlier.iter().filter(|k| **k).count(),
                "trimmed": f.inlier.iter().filter(|k| !**k).count(),
                "threshold": f.threshold, "rounds": f.rounds},
            );
        }
        format!("{}\n", json::to_string(&o)?)
    } else {
        let mut t = String::new();
        if let Some(f) = &fit {
            let g = &f.registration;
            t.push_str(&format!(
                "best fit: {} of {} points kept (trimmed beyond {:.3e} of the surface), {} rounds\ntranslation {:.6} {:.6} {:.6}\nrotation axis {:.6} {:.6} {:.6} by {:.6} deg\nfit rms {:.3e}\n",
                f.inlier.iter().filter(|k| **k).count(),
                f.inlier.len(),
                f.threshold,
                f.rounds,
                g.translation[0], g.translation[1], g.translation[2],
                g.axis[0], g.axis[1], g.axis[2], g.angle_deg, g.rms
            ));
            if let (Some(ur), Some(ut)) = (g.u_rotation_deg, g.u_translation) {
                t.push_str(&format!(
                    "u_rotation_deg {:.3e} {:.3e} {:.3e} (about x, y, z through {:.4} {:.4} {:.4})\nu_translation {:.3e} {:.3e} {:.3e}\n",
                    ur[0], ur[1], ur[2], f.centroid[0], f.centroid[1], f.centroid[2], ut[0], ut[1], ut[2]
                ));
            }
            t.push_str("deviations after the fit:\n");
        }
        t.push_str(&stats_text(&s, tol));
        if flagged > 0 {
            t.push_str(&format!("flagged (not counted): {flagged}\n"));
        }
        if let Some((ms, signed)) = &mesh_stats {
            t.push_str(&format!(
                "distance to the mesh ({}): mean {:.6} sd {:.6} min {:.6} max {:.6}\n",
                if *signed { "signed" } else { "unsigned" },
                ms.mean,
                ms.sd,
                ms.min,
                ms.max
            ));
        }
        t
    };
    for (path, body) in [
        (&a.write_setup, &setup_text),
        (&a.csv, &csv_text),
        (&a.svg, &svg_text),
        (&a.ply, &ply_text),
    ] {
        if let (Some(p), Some(b)) = (path, body) {
            write_file(Some(p), b)?;
        }
    }
    write_file(None, &out)
}

/// `inspect deposits`: where the measured part is out of tolerance, the layers and lines
/// of the posted program that deposited there.
#[allow(clippy::too_many_arguments)]
pub fn deposits_cmd(
    machine: &str,
    sets: &[String],
    head: Option<&str>,
    posted: &str,
    measured: &str,
    tol: f64,
    radius: f64,
    output: Option<&str>,
    json_out: bool,
) -> Result<(), CliError> {
    if !(tol.is_finite() && tol > 0.0) {
        return Err(CliError::usage(format!(
            "error: --tol {tol}: give a positive tolerance\n"
        )));
    }
    let m = load_machine(machine, sets)?;
    let h = match head {
        Some(n) => m.head(n).map_err(kin_error)?,
        None => m.head("laser").unwrap_or(0),
    };
    let (name, text) = read(measured)?;
    let (rows, flagged) = read_measured(&name, &text)?;
    let (pname, ptext) = read(posted)?;
    let dep = lampost_inspect::deposits::replay(&m, h, ptext.as_bytes(), radius)
        .map_err(|e| error(&pname, &ptext, e))?;
    if dep.segments.is_empty() {
        return Err(CliError::failed(format!(
            "error: {pname} deposits nothing on {} (no feed move with the laser on, `{}` … `{}`)\n  = help: give the posted deposition program the part was built with\n",
            m.def.name, m.def.process.laser_on, m.def.process.laser_off
        )));
    }
    // Out of tolerance: missing (below −tol) or in excess (above +tol), each looked up
    // at its nominal point (where the material should be).
    struct Found<'a> {
        row: &'a Row,
        kind: &'static str,
        near: Option<lampost_inspect::deposits::Near>,
    }
    let found: Vec<Found> = rows
        .iter()
        .filter(|r| r.deviation.abs() > tol)
        .map(|r| Found {
            row: r,
            kind: if r.deviation < 0.0 {
                "missing"
            } else {
                "excess"
            },
            near: dep.nearest(r.nominal),
        })
        .collect();
    let mut per_layer = vec![(0usize, 0usize); dep.layers.len()];
    for f in &found {
        if let Some(n) = &f.near {
            let e = &mut per_layer[n.layer - 1];
            if f.kind == "missing" {
                e.0 += 1;
            } else {
                e.1 += 1;
            }
        }
    }
    let unplaced = found.iter().filter(|f| f.near.is_none()).count();
    let text = if json_out {
        let pts: Vec<Obj> = found
            .iter()
            .map(|f| {
                obj! {"id": f.row.id, "line": f.row.line, "nominal": f.row.nominal, "deviation": f.row.deviation,
                "kind": f.kind, "deposited_by": f.near}
            })
            .collect();
        let layers: Vec<Obj> = dep
            .layers
            .iter()
            .zip(&per_layer)
            .enumerate()
            .map(|(k, (l, c))| {
                obj! {"layer": k + 1, "height": l.height, "rotary": l.rotary, "lines": l.lines,
                "moves": l.moves, "missing": c.0, "excess": c.1}
            })
            .collect();
        format!(
            "{}\n",
            json::to_string(
                &obj! {"tol": tol, "radius": radius, "measured": rows.len(), "flagged": flagged,
                "out_of_tol": found.len(), "not_near_a_deposit": unplaced, "points": pts, "layers": layers}
            )?
        )
    } else {
        let mut s = format!(
            "# lampost inspect deposits: {name} against {pname} on {}, tol ±{tol}, radius {radius}\n# {} of {} measured points out of tolerance\nid x y z deviation kind line layer distance layers_within\n",
            m.def.name,
            found.len(),
            rows.len()
        );
        for f in &found {
            let r = f.row;
            let (line, layer, dist, within) = match &f.near {
                Some(n) => (
                    n.line.to_string(),
                    n.layer.to_string(),
                    format!("{:.6}", n.distance),
                    n.layers_within
                        .iter()
                        .map(|l| l.to_string())
                        .collect::<Vec<_>>()
                        .join(","),
                ),
                None => ("-".into(), "-".into(), "-".into(), "-".into()),
            };
            s.push_str(&format!(
                "{} {:.6} {:.6} {:.6} {:.6} {} {line} {layer} {dist} {within}\n",
                r.id, r.nominal[0], r.nominal[1], r.nominal[2], r.deviation, f.kind
            ));
        }
        s.push_str("# per layer: layer height lines missing excess\n");
        for (k, (l, c)) in dep.layers.iter().zip(&per_layer).enumerate() {
            if c.0 + c.1 > 0 {
                s.push_str(&format!(
                    "# layer {} {:.4} {}-{} {} {}\n",
                    k + 1,
                    l.height,
                    l.lines[0],
                    l.lines[1],
                    c.0,
                    c.1
                ));
            }
        }
        s
    };
    write_file(output, &text)?;
    if unplaced > 0 {
        eprintln!("warning: {unplaced} out-of-tolerance points have no deposition within {radius} of them (listed with `-`)");
    }
    eprintln!(
        "{} of {} points out of ±{tol}; {} layers deposited",
        found.len(),
        rows.len(),
        dep.layers.len()
    );
    Ok(())
}
