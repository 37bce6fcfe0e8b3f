//! `lampost post` and `lampost verify` for arm machines (paper 001's robot cell): a
//! per-point path becomes chunked location files and a manifest in a folder.

use std::io::Write;
use std::path::{Path, PathBuf};

use lampost_robot::chunk::{self, ChunkFile};
use lampost_robot::plan::{self, PathPoint, Sample};
use lampost_robot::RobotError;
use lampost_robot::{Arm, Config};

use crate::io::{display_name, TempFile};
use crate::json::{self, obj, Obj};
use crate::post_cmds::{post_error, Placement, PostArgs};
use crate::report::CliError;

/// The arm a `--machine` names, if it is one: a built-in arm, or a file with
/// `kind = "arm"`.
pub fn arm_for(spec: &str) -> Result<Option<Arm>, CliError> {
    if let Some(text) = lampost_robot::builtin_text(spec) {
        return Arm::from_toml(text, &format!("<built-in {spec}>"))
            .map(Some)
            .map_err(|e| robot_error(e, None));
    }
    if lampost_kinematics::builtin_text(spec).is_some() {
        return Ok(None);
    }
    crate::kin_cmds::regular_machine_file(spec)?;
    let Ok(text) = crate::io::read_settings_file(spec) else {
        return Ok(None);
    };
    if !lampost_robot::is_arm_text(&text) {
        return Ok(None);
    }
    Arm::from_toml(&text, spec)
        .map(Some)
        .map_err(|e| robot_error(e, None))
}

/// Render a robot error; `path` (file name, text) locates errors about path points.
pub fn robot_error(e: RobotError, path: Option<(&str, &str)>) -> CliError {
    let hint = e.hint();
    match (&e, path, e.point_line()) {
        (
            RobotError::MachineFile {
                file,
                line,
                column,
                message,
                text,
            },
            _,
            _,
        ) if *line > 0 => {
            let num = line.to_string();
            let pad = " ".repeat(num.len());
            CliError::failed(format!(
                "error: {message}\n{pad}--> {file}:{line}:{column}\n{pad} |\n{num} | {text}\n{pad} | {}^\n  = help: {hint}\n",
                " ".repeat(column.saturating_sub(1))
            ))
        }
        (_, Some((file, text)), Some(line)) if line > 0 => {
            let shown = text.lines().nth(line - 1).unwrap_or("");
            let col = shown.len() - shown.trim_start().len() + 1;
            let num = line.to_string();
            let pad = " ".repeat(num.len());
            CliError::failed(format!(
                "error: {e}\n{pad}--> {file}:{line}:{col}\n{pad} |\n{num} | {shown}\n{pad} | {}^\n  = help: {hint}\n",
                " ".repeat(col - 1)
            ))
        }
        _ => CliError::failed(format!("error: {e}\n  = help: {hint}\n")),
    }
}

/// Placement options a robot path does not take.
fn refuse_placement(pl: &Placement) -> Result<(), CliError> {
    let given = [
        (pl.index.is_some(), "--index"),
        (pl.setup.is_some(), "--setup"),
        (pl.job.is_some(), "--job"),
        (pl.origin.is_some(), "--origin"),
        (
            pl.layer_axis.is_some() || pl.layer_angle.is_some(),
            "--layer-axis/--layer-angle",
        ),
        (pl.near.is_some(), "--near"),
        (pl.stock.is_some(), "--stock"),
        (pl.part.is_some(), "--part"),
        (pl.e_extrusion, "--e-extrusion"),
    ];
    if let Some((_, flag)) = given.iter().find(|(g, _)| *g) {
        return Err(CliError::usage(format!(
            "error: {flag} does not apply to an arm: the path is in the part frame, which the arm file's [holder] places on the flange\n  = help: give the path (x y z i j k feed laser) and the arm options --config, --spacing, --chunk-points\n"
        )));
    }
    Ok(())
}

/// The path file: its name, text and resampled locations (`spacing` apart at most).
fn read_path(
    arm: &Arm,
    pl: &Placement,
    input: &str,
    spacing: f64,
) -> Result<(String, String, Vec<Sample>), CliError> {
    let name = display_name(input);
    let mut text = String::new();
    crate::io::read_to_string_checked(&mut crate::io::open_input(input)?, &mut text)
        .map_err(|e| CliError::usage(format!("error: cannot read {name}: {e}\n")))?;
    let arm_mm = arm.units == lampost_robot::Units::Mm;
    let k = match pl.units {
        Some(u) if matches!(u, crate::UnitsArg::Mm) != arm_mm => {
            if !pl.convert_units {
                let (from, to) = if arm_mm {
                    ("inches", "millimetres")
                } else {
                    ("millimetres", "inches")
                };
                return Err(CliError::usage(format!(
                    "error: {name}: the points are in {from} (--units), the arm {} works in {to}\n  = help: add --convert-units to scale the points and feeds to {to}\n",
                    arm.name
                )));
            }
            if arm_mm {
                25.4
            } else {
                1.0 / 25.4
            }
        }
        _ => 1.0,
    };
    let samples = read_and_resample(&text, &name, k, spacing)?;
    Ok((name, text, samples))
}

/// The path's rows read ([`lampost_post::pointwise::points`]) on one thread and
/// resampled as they come on this one, in batches: the same samples, and the same
/// error, as reading the whole path and then resampling it (a row's error comes first,
/// as it would when the file is read before it is resampled).
/// The least feed a path for an arm may give (units a minute).
const MIN_FEED: f64 = 1e-3;

fn read_and_resample(
    text: &str,
    name: &str,
    k: f64,
    spacing: f64,
) -> Result<Vec<lampost_robot::plan::Sample>, CliError> {
    use lampost_post::pointwise::points;
    const BATCH: usize = 4096;
    let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<lampost_post::pointwise::PathPoint>>(4);
    let (read, samples) = std::thread::scope(|s| {
        let reader = s.spawn(move || -> Result<(), lampost_post::PostError> {
            let mut batch = Vec::with_capacity(BATCH);
            for p in points(text, name) {
                let p = p?;
                // A feed so slow that its times run past any controller's word (1e-300
                // wrote a `dt` of 300 digits).
                if p.feed * k < MIN_FEED {
                    return Err(lampost_post::PostError::File {
                        file: name.to_string(),
                        line: p.line,
                        column: 1,
                        message: format!(
                            "the feed {} is under {MIN_FEED} a minute: one step of the path would take days, past any controller's time word",
                            lampost_gcode::Readable(p.feed)
                        ),
                    });
                }
                batch.push(p);
                if batch.len() == BATCH {
                    let full = std::mem::replace(&mut batch, Vec::with_capacity(BATCH));
                    // The resampler stopped (its own error): the rest is not needed.
                    if tx.send(full).is_err() {
                        return Ok(());
                    }
                }
            }
            let _ = tx.send(batch);
            Ok(())
        });
        let path = rx.iter().flatten().map(|p| PathPoint {
            tip: p.tip * k,
            axis: p.axis,
            feed: p.feed * k,
            deposit: p.deposit,
            line: p.line,
        });
        let samples = plan::resample_iter(path, spacing);
        drop(rx);
        // A panic of the reader is a fault of lampost's: raised again here.
        let read = reader
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p));
        (read, samples)
    });
    read.map_err(post_error)?;
    match samples {
        Ok(s) => Ok(s),
        Err(e) => {
            // A row the reader did not reach (it stopped with the resampler) may hold
            // an error of its own, which reading the file first would have reported.
            // Scanned, not kept: a path of 40 million rows refused at its two
            // millionth location held them all (3.8 times the file in memory).
            points(text, name)
                .try_for_each(|p| p.map(drop))
                .map_err(post_error)?;
            Err(robot_error(e, Some((name, text))))
        }
    }
}

fn werr(e: std::io::Error) -> CliError {
    CliError::write(&e)
}

/// `lampost post --machine ARM PATH -o DIR`.
pub fn post(
    arm: &Arm,
    a: &PostArgs,
    input: Option<&str>,
    output: Option<&str>,
    max_bytes: Option<usize>,
    json_report: Option<&str>,
) -> Result<(), CliError> {
    let t0 = std::time::Instant::now();
    refuse_placement(&a.place)?;
    let table_only = [
        (!a.set.is_empty(), "--set"),
        (a.head.is_some(), "--head"),
        (a.dialect.is_some(), "--dialect"),
        (a.renumber.is_some(), "--renumber"),
        (a.tolerance.is_some(), "--tolerance"),
    ];
    let machining = a.proc.machining_options();
    let flag = table_only
        .iter()
        .find(|(g, _)| *g)
        .map(|(_, f)| *f)
        .or(machining.first().copied());
    if let Some(flag) = flag {
        return Err(CliError::usage(format!(
            "error: {flag} is for programs of table machines; {} is an arm\n  = help: an arm's settings are in its file (`lampost machines show {}`); the arm options are --config, --spacing, --chunk-points\n",
            arm.name, arm.name
        )));
    }
    if max_bytes.is_some() || json_report.is_some() {
        return Err(CliError::usage("error: --max-bytes and --json-report are for programs: an arm's output is chunked by --chunk-points, and its manifest.json is the report\n".to_string()));
    }
    let Some(dir) = output.filter(|o| *o != "-") else {
        return Err(CliError::usage(
            "error: an arm's output is a folder of location files: give -o DIR\n".to_string(),
        ));
    };
    let input = input.ok_or_else(|| {
        CliError::usage("error: give the PATH (rows x y z i j k [feed] [laser])\n".to_string())
    })?;
    let cfg = match a.config.as_deref() {
        Some(c) => Config::parse(c).ok_or_else(|| {
            CliError::usage(format!(
                "error: --config {c}: give three letters, l or r (shoulder), u or d (elbow), n or f (wrist), e.g. ldn\n"
            ))
        })?,
        None => arm.config,
    };
    let spacing = a.spacing.unwrap_or(arm.spacing);
    let chunk_points = a.chunk_points.unwrap_or(arm.chunk_points);
    let (name, text, samples) = read_path(arm, &a.place, input, spacing)?;
    let located = |e| robot_error(e, Some((&name, &text)));
    let poses = plan::plan(arm, &samples, cfg).map_err(located)?;
    let ranges = chunk::chunk_ranges(&samples, chunk_points).map_err(located)?;
    let total = ranges.len();
    // Each chunk is written, verified as `lampost verify` reads it, and staged beside its
    // target as soon as it is; nothing is renamed into place until every chunk and the
    // manifest are (a failure removes what was staged).
    // A folder this run makes goes again if it fails or is interrupted.
    let made = crate::io::NewDir::create(Path::new(dir))
        .map_err(|e| CliError::usage(format!("error: cannot create the folder {dir}: {e}\n")))?;
    let staged: std::sync::Mutex<Vec<(TempFile, PathBuf)>> = std::sync::Mutex::new(Vec::new());
    let stage = |file: &str, body: &[u8]| -> Result<(), CliError> {
        let target = Path::new(dir).join(file);
        let (t, mut f) = TempFile::beside(Some(&target.to_string_lossy()))?;
        f.write_all(body).map_err(werr)?;
        f.flush().map_err(werr)?;
        staged
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .push((t, target));
        Ok(())
    };
    let posted = chunk::post_chunks(
        arm,
        cfg,
        &samples,
        &poses,
        &ranges,
        arm.tolerance,
        chunk::default_threads(),
        |c, text| stage(&c.name, text),
    );
    let (files, rep) = match posted {
        Ok(p) => p,
        Err(e) => {
            // What was staged goes; so does the folder where this run made it.
            drop(staged);
            drop(made);
            return Err(match e {
                chunk::PostError::Verify(e) => CliError::failed(format!(
                    "error: {e}\n  = help: this is a lampost fault; nothing was written\n"
                )),
                chunk::PostError::Keep(e) => e,
            });
        }
    };
    let seconds: f64 = samples.iter().map(|s| s.dt).sum();
    let laser_s: f64 = samples.iter().filter(|s| s.deposit).map(|s| s.dt).sum();
    let chunks: Vec<Obj> = files
        .iter()
        .zip(&ranges)
        .map(|(f, r)| {
            let secs: f64 = samples[r.start + 1..r.end].iter().map(|s| s.dt).sum();
            obj! {"file": f.name, "first": f.first, "count": f.count, "locations": f.count + 2, "path_s": secs}
        })
        .collect();
    let manifest = obj! {
        "format": chunk::FORMAT,
        "machine": arm.name,
        "input": name,
        "units": if arm.units == lampost_robot::Units::Mm { "mm" } else { "inch" },
        "config": cfg.letters(),
        "spacing": spacing,
        "chunk_points": chunk_points,
        "locations": samples.len(),
        "path_s": seconds,
        "laser_on_s": laser_s,
        "chunks": chunks,
        "safe": arm.safe.map(f64::to_degrees),
        "loading": "each chunk starts and ends at the safe location; a controller that loads chunk k+1 while chunk k runs needs room for two chunks (2 × chunk_points locations) and a handshake at the safe location",
        "verify": obj!{"max_focus_error": rep.max_focus_error, "max_axis_error_deg": rep.max_axis_error_deg},
    };
    let manifest = json::to_string(&manifest)?;
    stage("manifest.json", format!("{manifest}\n").as_bytes())?;
    let mut staged = staged
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    // Renamed into place in chunk order, the manifest last.
    staged.sort_by(|a, b| {
        let last = |p: &PathBuf| p.ends_with("manifest.json");
        (last(&a.1), &a.1).cmp(&(last(&b.1), &b.1))
    });
    // As one step (an interrupt waits for it): the old manifest removed first, so a
    // folder a crash leaves half updated has none; the chunks of an earlier, longer run
    // removed last.
    let manifest_path = Path::new(dir).join("manifest.json");
    crate::io::persist_set(staged, Some(&manifest_path), || {
        for k in total + 1.. {
            let stale = Path::new(dir).join(chunk::file_name(k));
            if std::fs::remove_file(&stale).is_err() {
                break;
            }
            eprintln!("removed {}: a chunk of an earlier run", stale.display());
        }
    })?;
    made.keep();
    if !a.place.quiet {
        let sizes: Vec<String> = files.iter().map(|f| (f.count + 2).to_string()).collect();
        eprintln!(
            "posted {} locations in {total} chunks of at most {chunk_points} ({}) to {dir}, configuration {}; verified: max focus error {:.2e}, max approach error {:.2e}°; {:.2} s",
            samples.len(),
            sizes.join(", "),
            cfg.letters(),
            rep.max_focus_error,
            rep.max_axis_error_deg,
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// `lampost verify --machine ARM DIR --input PATH`.
/// The manifest's figures against what verification found (a controller is loaded by
/// them: `chunk_points` is its memory, `safe` where each chunk starts): every count equal
/// to the chunks' and the path's, `chunk_points` holding every chunk, the units, the
/// safe location and the times those of the arm and the path, and each chunk file's
/// header naming the machine, configuration and units. The first disagreement.
fn manifest_agrees(
    arm: &Arm,
    cfg: Config,
    m: &serde_json::Value,
    samples: &[Sample],
    files: &[ChunkFile],
    list: &[serde_json::Value],
) -> Result<(), String> {
    let units = if arm.units == lampost_robot::Units::Mm {
        "mm"
    } else {
        "inch"
    };
    let num = |v: Option<&serde_json::Value>, what: &str| {
        v.and_then(serde_json::Value::as_f64)
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("`{what}` is not a number"))
    };
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0);
    if m.get("units").and_then(serde_json::Value::as_str) != Some(units) {
        return Err(format!("`units` is not {units}, the arm's"));
    }
    let total = num(m.get("locations"), "locations")?;
    if total != samples.len() as f64 {
        return Err(format!(
            "`locations` is {total}, but the path has {} locations",
            samples.len()
        ));
    }
    let mut largest = 0usize;
    for (k, (c, f)) in list.iter().zip(files).enumerate() {
        let n = num(c.get("locations"), "locations")?;
        if n != (f.count + 2) as f64 {
            return Err(format!(
                "chunk {}: `locations` is {n}, but the chunk holds {} (its {} path locations and the safe location at each end)",
                k + 1,
                f.count + 2,
                f.count
            ));
        }
        largest = largest.max(f.count + 2);
        let secs: f64 = samples
            .get(f.first + 1..f.first + f.count)
            .map_or(0.0, |s| s.iter().map(|s| s.dt).sum());
        if !near(num(c.get("path_s"), "path_s")?, secs) {
            return Err(format!(
                "chunk {}: `path_s` is not the chunk's time along the path ({secs} s)",
                k + 1
            ));
        }
        let header = |key: &str, want: &str| {
            let line = format!("# {key} {want}");
            if f.text
                .lines()
                .take_while(|l| l.starts_with('#'))
                .any(|l| l == line)
            {
                Ok(())
            } else {
                Err(format!(
                    "chunk {} ({}): its header does not say `{line}`",
                    k + 1,
                    f.name
                ))
            }
        };
        header("machine", &arm.name)?;
        header("config", &cfg.letters())?;
        header("units", &format!("{units}, degrees, seconds"))?;
    }
    let room = num(m.get("chunk_points"), "chunk_points")?;
    if room < largest as f64 {
        return Err(format!(
            "`chunk_points` is {room}, but a chunk holds {largest} locations: a controller loaded by it would not hold the chunk"
        ));
    }
    let seconds: f64 = samples.iter().map(|s| s.dt).sum();
    let laser: f64 = samples.iter().filter(|s| s.deposit).map(|s| s.dt).sum();
    if !near(num(m.get("path_s"), "path_s")?, seconds) {
        return Err(format!("`path_s` is not the path's time ({seconds} s)"));
    }
    if !near(num(m.get("laser_on_s"), "laser_on_s")?, laser) {
        return Err(format!(
            "`laser_on_s` is not the path's time with the laser on ({laser} s)"
        ));
    }
    let safe = m
        .get("safe")
        .and_then(serde_json::Value::as_array)
        .filter(|a| a.len() == arm.safe.len())
        .ok_or("`safe` is not the arm's six joints")?;
    for (j, (v, want)) in safe.iter().zip(arm.safe.map(f64::to_degrees)).enumerate() {
        if !v.as_f64().is_some_and(|v| near(v, want)) {
            return Err(format!(
                "`safe` joint {} is not the arm's safe location ({want}°)",
                j + 1
            ));
        }
    }
    Ok(())
}

pub fn verify(
    arm: &Arm,
    place: &Placement,
    input: &str,
    dir: &str,
    tolerance: Option<f64>,
    json_out: bool,
) -> Result<(), CliError> {
    let t0 = std::time::Instant::now();
    refuse_placement(place)?;
    let mpath = Path::new(dir).join("manifest.json");
    let mname = mpath.to_string_lossy().into_owned();
    let bad = |line: usize, msg: String| {
        robot_error(
            RobotError::Verify {
                file: mname.clone(),
                line,
                message: msg,
            },
            None,
        )
    };
    // Files of a folder `post` wrote: a named pipe among them would wait for ever.
    let regular = |p: &Path| {
        if std::fs::metadata(p).is_ok_and(|m| !m.is_file()) {
            return Err(CliError::usage(format!(
                "error: {}: not a regular file (a pipe, a device or a folder)\n  = help: give the folder `lampost post` wrote\n",
                p.display()
            )));
        }
        Ok(())
    };
    regular(&mpath)?;
    let mtext = crate::io::read_file_to_string(&mpath)
        .map_err(|e| CliError::usage(format!("error: cannot read {mname}: {e}\n  = help: give the folder `lampost post --machine {} … -o DIR` wrote\n", arm.name)))?;
    let m: serde_json::Value =
        serde_json::from_str(&mtext).map_err(|e| bad(e.line(), format!("not JSON: {e}")))?;
    let field = |k: &str| m.get(k).ok_or_else(|| bad(0, format!("no `{k}`")));
    let s = |k: &str| -> Result<String, CliError> {
        field(k)?
            .as_str()
            .map(str::to_string)
            .ok_or_else(|| bad(0, format!("`{k}` is not a string")))
    };
    if s("format")? != chunk::FORMAT {
        return Err(bad(0, format!("format is not `{}`", chunk::FORMAT)));
    }
    if s("machine")? != arm.name {
        return Err(bad(
            0,
            format!("posted for {}, not {}", s("machine")?, arm.name),
        ));
    }
    let cfg = Config::parse(&s("config")?).ok_or_else(|| bad(0, "bad `config`".into()))?;
    let spacing = field("spacing")?
        .as_f64()
        .ok_or_else(|| bad(0, "`spacing` is not a number".into()))?;
    let list = field("chunks")?
        .as_array()
        .ok_or_else(|| bad(0, "`chunks` is not a list".into()))?;
    let mut files = Vec::with_capacity(list.len());
    for (k, c) in list.iter().enumerate() {
        let get = |key: &str| {
            c.get(key)
                .ok_or_else(|| bad(0, format!("chunk {}: no `{key}`", k + 1)))
        };
        let file = get("file")?
            .as_str()
            .filter(|f| !f.contains('/') && !f.contains('\\') && !f.starts_with('.'))
            .ok_or_else(|| bad(0, format!("chunk {}: `file` is not a file name", k + 1)))?
            .to_string();
        let num = |key: &str| {
            get(key)?
                .as_u64()
                .and_then(|v| usize::try_from(v).ok())
                .ok_or_else(|| bad(0, format!("chunk {}: `{key}` is not a count", k + 1)))
        };
        let path = Path::new(dir).join(&file);
        regular(&path)?;
        let text = crate::io::read_file_to_string(&path).map_err(|e| {
            bad(
                0,
                format!(
                    "chunk {} of {}: cannot read {}: {e} (a missing chunk)",
                    k + 1,
                    list.len(),
                    path.display()
                ),
            )
        })?;
        files.push(ChunkFile {
            name: path.to_string_lossy().into_owned(),
            first: num("first")?,
            count: num("count")?,
            text,
        });
    }
    let (name, text, samples) = read_path(arm, place, input, spacing)?;
    let _ = (&name, &text);
    let tol = tolerance.unwrap_or(arm.tolerance);
    if !(tol.is_finite() && tol > 0.0) {
        return Err(CliError::usage(format!(
            "error: --tolerance {tol}: must be positive\n"
        )));
    }
    let rep = chunk::verify(arm, &samples, cfg, &files, tol).map_err(|e| robot_error(e, None))?;
    manifest_agrees(arm, cfg, &m, &samples, &files, list).map_err(|msg| bad(0, msg))?;
    let out = if json_out {
        format!(
            "{}\n",
            json::to_string(
                &obj! {"max_focus_error": rep.max_focus_error, "max_axis_error_deg": rep.max_axis_error_deg, "locations": rep.locations, "chunks": rep.chunks, "ok": true}
            )?
        )
    } else {
        format!(
            "ok: {} locations in {} chunks\nmax_focus_error {:.3e}\nmax_axis_error_deg {:.3e}\n",
            rep.locations, rep.chunks, rep.max_focus_error, rep.max_axis_error_deg
        )
    };
    let mut o = crate::io::Output::create(None)?;
    o.writer().write_all(out.as_bytes()).map_err(werr)?;
    o.commit()?;
    if !place.quiet {
        eprintln!(
            "verified {} locations in {} chunks of {dir}: max focus error {:.2e}, max approach error {:.2e}°; {:.2} s",
            rep.locations,
            rep.chunks,
            rep.max_focus_error,
            rep.max_axis_error_deg,
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
