//! `cargo xtask`: benchmarks and fuzzing for lampost.
//!
//! - `cargo xtask bench gcode`: parse + interpret throughput against the `gcode` crate
//!   (criterion-free harness in `crates/gcode/benches/throughput.rs`, best of 5 runs,
//!   both measured in the same process), then `lampost fmt` on a generated 1,000,000-line
//!   program: time and peak resident memory (VmHWM of the child process).
//! - `cargo xtask bench kin`: IK + FK pairs per second on both built-in machines.
//! - `cargo xtask bench post`: `lampost post` on a generated 1,000,000-line program
//!   against `lampost fmt` and a numpy script (`xtask/post_baseline.py`), same run.
//! - `cargo xtask bench plan`: slicing a 75k-triangle mesh at 0.1 mm layers against
//!   trimesh's `section_multiplane` (same run), a 1M-triangle mesh at 1,000 layers, and
//!   the whole plan of paper 001's twisted plate (`plan.rs`; `bench plan-plate` alone).
//! - `cargo xtask bench robot`: paper 001's twisted plate at full size planned (`--layer
//!   20` and `--layer 2`, `--approach build`) and posted for puma-lens in this process
//!   (wall and CPU, and both split by stage: path planning, resampling, poses, chunks and
//!   text, verification); then `lampost post --machine puma-lens` and `lampost verify` on the
//!   `--layer 20` path, `lampost plan path` then `lampost post` at `--layer 2` as a user
//!   runs them, and the Robotics Toolbox's `ikine_a` solving the same poses
//!   (`.tools/py-rtb`), same run.
//! - `cargo xtask accuracy`: the four-point sphere method against the N-point fit, then
//!   the calibration table (`cargo xtask calibration` alone).
//! - `cargo xtask fuzz [--target T] [--seconds N] …`: every reader fuzzed in a child
//!   process (`crates/fuzz`) under a time and memory limit per input; see `fuzz.rs`.

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

use lampost_testkit::root;

fn cargo() -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(root());
    c
}

fn run(mut c: Command) -> Result<(), String> {
    let status = c.status().map_err(|e| format!("cannot run {c:?}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{c:?} failed: {status}"))
    }
}

/// Run `cmd`, polling its peak resident set size (VmHWM) until it exits.
fn peak_memory(mut cmd: Command) -> Result<(Duration, u64), String> {
    let t = Instant::now();
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot run {cmd:?}: {e}"))?;
    let status_path = format!("/proc/{}/status", child.id());
    let mut peak_kb = 0u64;
    loop {
        if let Ok(s) = std::fs::read_to_string(&status_path) {
            if let Some(l) = s.lines().find(|l| l.starts_with("VmHWM:")) {
                let kb = l
                    .split_whitespace()
                    .nth(1)
                    .and_then(|v| v.parse().ok())
                    .unwrap_or(0);
                peak_kb = peak_kb.max(kb);
            }
        }
        match child.try_wait() {
            Ok(Some(st)) if st.success() => break,
            Ok(Some(st)) => return Err(format!("{cmd:?} failed: {st}")),
            Ok(None) => std::thread::sleep(Duration::from_millis(2)),
            Err(e) => return Err(e.to_string()),
        }
    }
    Ok((t.elapsed(), peak_kb))
}

fn bench_gcode() -> Result<(), String> {
    println!("== parse + interpret throughput (one core), against the gcode crate, same run");
    let mut c = cargo();
    c.args(["bench", "-p", "lampost-gcode", "--bench", "throughput"]);
    run(c)?;
    println!("\n== lampost fmt on a generated 1,000,000-line program (streaming)");
    let mut c = cargo();
    c.args(["build", "--release", "-q", "-p", "lampost-cli"]);
    run(c)?;
    let dir = root().join("target/xtask");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let input = dir.join("planar-1m.nc");
    let text = lampost_gcode::generate::planar_program(1_000_000, 42);
    std::fs::write(&input, &text).map_err(|e| e.to_string())?;
    // Where `cargo build` put it (CARGO_TARGET_DIR honoured, as in `bench robot`).
    let bin = std::env::var_os("CARGO_TARGET_DIR")
        .map_or_else(|| root().join("target"), PathBuf::from)
        .join("release/lampost");
    for extra in [&[][..], &["--dialect", "fadal"][..]] {
        let out = dir.join("planar-1m.out.nc");
        let mut cmd = Command::new(&bin);
        cmd.arg("fmt").arg(&input).arg("-o").arg(&out).args(extra);
        let (t, kb) = peak_memory(cmd)?;
        println!(
            "lampost fmt {}: {:.1} MB in {:.0} ms ({:.0} MB/s), peak memory {:.1} MB (target < 50 MB)",
            extra.join(" "),
            text.len() as f64 / 1e6,
            t.as_secs_f64() * 1e3,
            text.len() as f64 / 1e6 / t.as_secs_f64(),
            kb as f64 / 1024.0
        );
    }
    let mut cmd = Command::new(&bin);
    cmd.arg("trace")
        .arg(&input)
        .arg("-o")
        .arg(dir.join("planar-1m.trace"));
    let (t, kb) = peak_memory(cmd)?;
    println!(
        "lampost trace: {:.0} ms, peak memory {:.1} MB",
        t.as_secs_f64() * 1e3,
        kb as f64 / 1024.0
    );
    Ok(())
}

fn bench_post() -> Result<(), String> {
    println!("== lampost post --index on a generated 1,000,000-line planar program (NRC cell, mm), against fmt and a numpy script, same run");
    let mut c = cargo();
    c.args(["build", "--release", "-q", "-p", "lampost-cli"]);
    run(c)?;
    let dir = root().join("target/xtask");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let input = dir.join("planar-1m-100.nc");
    let text = lampost_gcode::generate::planar_program_within(1_000_000, 7, 100.0);
    std::fs::write(&input, &text).map_err(|e| e.to_string())?;
    let mb = text.len() as f64 / 1e6;
    // Where `cargo build` put it (CARGO_TARGET_DIR honoured, as in `bench gcode`).
    let bin = std::env::var_os("CARGO_TARGET_DIR")
        .map_or_else(|| root().join("target"), PathBuf::from)
        .join("release/lampost");
    let out = dir.join("planar-1m-100.posted.nc");
    // Time: the best of 7 plain runs of each command, the commands taken in turn (a
    // round runs each once), so a slow spell of this shared machine falls on all of them
    // alike; nothing polls beside them (post uses both cores). Peak memory: one more run
    // of each, watched through /proc.
    let run_once = |make: &dyn Fn() -> Command| -> Result<Duration, String> {
        let mut c = make();
        c.stderr(std::process::Stdio::null());
        let t = Instant::now();
        let st = c.status().map_err(|e| format!("cannot run {c:?}: {e}"))?;
        let e = t.elapsed();
        if !st.success() {
            return Err(format!("{c:?} failed: {st}"));
        }
        Ok(e)
    };
    let post_cmd = || {
        let mut c = Command::new(&bin);
        c.args(["post", "--machine", "nrc-lc", "--index", "B=30,C=45"])
            .arg(&input)
            .arg("-o")
            .arg(&out);
        c
    };
    let fmt_cmd = || {
        let mut c = Command::new(&bin);
        c.arg("fmt").arg(&input).arg("-o").arg(dir.join("fmt.nc"));
        c
    };
    let fmt_iso_cmd = || {
        let mut c = Command::new(&bin);
        c.arg("fmt")
            .arg(&input)
            .args(["--dialect", "iso"])
            .arg("-o")
            .arg(dir.join("fmt-iso.nc"));
        c
    };
    let post_flat = || {
        let mut c = Command::new(&bin);
        c.args(["post", "--machine", "nrc-lc", "--index", "B=0,C=30"])
            .arg(&input)
            .arg("-o")
            .arg(dir.join("posted-flat.nc"));
        c
    };
    let commands: [&dyn Fn() -> Command; 4] = [&post_flat, &post_cmd, &fmt_cmd, &fmt_iso_cmd];
    let mut times = [Duration::MAX; 4];
    for _round in 0..7 {
        for (t, make) in times.iter_mut().zip(commands) {
            *t = (*t).min(run_once(make)?);
        }
    }
    let [tflat, tp, tf, tfi] = times;
    let (_, kflat) = peak_memory(post_flat())?;
    let (_, kp) = peak_memory(post_cmd())?;
    println!(
        "lampost post --index B=0,C=30 (arcs stay arcs): {:.0} ms ({:.0} MB/s), peak memory {:.1} MB",
        tflat.as_secs_f64() * 1e3,
        mb / tflat.as_secs_f64(),
        kflat as f64 / 1024.0
    );
    println!("lampost post --index B=30,C=45 (arcs linearised, incl. its verification pass): {:.0} ms ({:.0} MB/s), peak memory {:.1} MB (target < 50 MB)", tp.as_secs_f64() * 1e3, mb / tp.as_secs_f64(), kp as f64 / 1024.0);
    println!(
        "lampost fmt (verbatim):        {:.0} ms; post / fmt = {:.2} tilted, {:.2} arcs kept (target ≤ 2)",
        tf.as_secs_f64() * 1e3,
        tp.as_secs_f64() / tf.as_secs_f64(),
        tflat.as_secs_f64() / tf.as_secs_f64()
    );
    println!(
        "lampost fmt --dialect iso:     {:.0} ms; post / fmt --dialect iso = {:.2}",
        tfi.as_secs_f64() * 1e3,
        tp.as_secs_f64() / tfi.as_secs_f64()
    );
    // The numpy script, as a user would write it.
    let have_numpy = Command::new("python3")
        .args(["-c", "import numpy"])
        .status()
        .is_ok_and(|s| s.success());
    if !have_numpy {
        println!("installing numpy for the baseline script (pip)…");
        let _ = Command::new("python3")
            .args(["-m", "pip", "install", "--quiet", "numpy"])
            .status();
    }
    let script = root().join("xtask/post_baseline.py");
    // The script for each case, then its output checked by `lampost verify` against the
    // same intended path (with the index it assumes written first): it must be the same
    // transform, not just the same speed.
    for (b, c, t_post, what) in [("30", "45", tp, "tilted"), ("0", "30", tflat, "arcs kept")] {
        let script_out = dir.join(format!("numpy-b{b}.nc"));
        let mut py = Command::new("python3");
        py.arg(&script)
            .arg(&input)
            .arg(&script_out)
            .args([b, c, "150"]);
        match peak_memory(py) {
            Ok((t, _)) => {
                let checked = dir.join(format!("numpy-b{b}-indexed.nc"));
                let verdict = std::fs::read(&script_out)
                    .and_then(|body| {
                        let mut text = format!("G21 G90 G94\nG0 Z150\nG0 B{b} C{c}\n").into_bytes();
                        text.extend_from_slice(&body);
                        std::fs::write(&checked, text)
                    })
                    .map_err(|e| e.to_string())
                    .and_then(|()| {
                        Command::new(&bin)
                            .args(["verify", "--machine", "nrc-lc", "--index"])
                            .arg(format!("B={b},C={c}"))
                            .arg(&input)
                            .arg(&checked)
                            .output()
                            .map_err(|e| e.to_string())
                    })
                    .map_or_else(
                        |e| format!("not verified: {e}"),
                        |o| {
                            if o.status.success() {
                                "its output passes lampost verify".to_string()
                            } else {
                                "its output FAILS lampost verify".to_string()
                            }
                        },
                    );
                println!(
                    "numpy script, B={b} C={c}:      {:.0} ms; script / post = {:.1} {what} (target ≥ 20); {verdict}",
                    t.as_secs_f64() * 1e3,
                    t.as_secs_f64() / t_post.as_secs_f64(),
                );
            }
            Err(e) => println!("numpy script could not run: {e}"),
        }
    }
    Ok(())
}

/// The controller memory the robot bench posts for (locations per file): the planned
/// plate's longest laser-on run (a layer's perimeter, 1,763 locations at 1 mm) fits.
const ROBOT_CHUNK: usize = 4000;

/// Paper 001's twisted plate at full size, as `lampost plan demo` writes it, planned as
/// `lampost plan path --layer LAYER --approach build --hatch 1.5 --spacing 2` plans it,
/// and posted for puma-lens as `lampost post --machine puma-lens --chunk-points 4000`
/// posts it (resampling, poses, chunks, the location files' text, the in-process
/// verification of each chunk as it is written), all in this process and without files. Returns (path points,
/// locations, chunk sizes).
fn robot_plate(
    mesh: &lampost_mesh::Mesh,
    layer: f64,
    split: &mut RobotSplit,
) -> Result<(usize, usize, Vec<usize>), String> {
    use lampost_robot::{chunk, plan};
    let mut t = (Instant::now(), crate::plan::cpu_seconds());
    let mut lap = |slot: &mut (Duration, f64)| {
        let cpu = crate::plan::cpu_seconds();
        slot.0 += t.0.elapsed();
        slot.1 += cpu - t.1;
        t = (Instant::now(), cpu);
    };
    let s = lampost_plan::slice(
        mesh,
        &lampost_plan::SliceOptions {
            planes: lampost_plan::Planes::Parallel {
                dir: lampost_mesh::P3::z(),
                layer,
                first: None,
            },
            stitch: None,
            threads: 2,
        },
    )
    .map_err(|e| e.to_string())?;
    let opts = lampost_plan::PlanOptions {
        perimeter: lampost_plan::PerimeterOptions {
            spacing: 2.0,
            max_turn_deg: 2.0,
        },
        raster: Some(lampost_plan::RasterOptions {
            hatch: 1.5,
            inset: 0.5,
            angle_deg: 0.0,
            turn_deg: 90.0,
        }),
        approach: lampost_plan::Approach::Build,
        max_offset_deg: 45.0,
        max_tilt_deg: 90.0,
        threads: 2,
    };
    let p = lampost_plan::plan(mesh, &s, &opts).map_err(|e| e.to_string())?;
    // The path points as `lampost plan path` writes them (line 3 on), read as they come.
    let path = p.iter().enumerate().map(|(i, q)| plan::PathPoint {
        tip: q.p,
        axis: q.axis,
        feed: 600.0,
        deposit: q.laser,
        line: i + 3,
    });
    let points = p.iter().count();
    let arm = lampost_robot::Arm::builtin("puma-lens").ok_or("puma-lens")?;
    lap(&mut split.path);
    let samples = plan::resample_iter(path, arm.spacing).map_err(|e| e.to_string())?;
    lap(&mut split.resample);
    let poses = plan::plan(&arm, &samples, arm.config).map_err(|e| e.to_string())?;
    lap(&mut split.poses);
    let ranges = chunk::chunk_ranges(&samples, ROBOT_CHUNK).map_err(|e| e.to_string())?;
    // As `lampost post` does, less the files: each chunk written, verified and handed on.
    let (files, _) = chunk::post_chunks(
        &arm,
        arm.config,
        &samples,
        &poses,
        &ranges,
        arm.tolerance,
        chunk::default_threads(),
        |_, _| Ok::<(), String>(()),
    )
    .map_err(|e| match e {
        chunk::PostError::Verify(e) => e.to_string(),
        chunk::PostError::Keep(e) => e,
    })?;
    lap(&mut split.chunks);
    Ok((
        points,
        samples.len(),
        files.iter().map(|f| f.count + 2).collect(),
    ))
}

/// Wall and CPU time (seconds) of each stage of [`robot_plate`], summed over runs.
#[derive(Debug, Default)]
struct RobotSplit {
    /// Slicing and `lampost_plan::plan` (perimeters, rasters).
    path: (Duration, f64),
    /// Resampling to the arm's spacing.
    resample: (Duration, f64),
    /// Poses: the turn about the beam, IK, the first turn's look-ahead.
    poses: (Duration, f64),
    /// Chunk cuts, the location files' text and its in-process verification (each chunk
    /// read back, FK, as it is written).
    chunks: (Duration, f64),
}

impl RobotSplit {
    fn show(&self, runs: usize) -> String {
        let ms = |d: &(Duration, f64)| {
            let n = runs.max(1) as f64;
            format!("{:.0}/{:.0}", d.0.as_secs_f64() * 1e3 / n, d.1 * 1e3 / n)
        };
        format!(
            "split, ms wall/CPU (mean): path planning {}, resampling {}, poses (IK, turn about the beam, look-ahead) {}, chunks (text, and verification as each is written) {}",
            ms(&self.path),
            ms(&self.resample),
            ms(&self.poses),
            ms(&self.chunks)
        )
    }
}

fn bench_robot() -> Result<(), String> {
    println!("== paper 001's twisted plate at full size (600 x 200 mm), planned and posted for puma-lens in this process (slicing, plan, resampling, poses, chunks of {ROBOT_CHUNK}, location text, in-process verification; no files)");
    let mesh = lampost_plan::demo::twisted_plate(1.0, 3.0, 120, 20).ok_or("plate")?;
    for (layer, runs) in [(20.0, 5), (2.0, 3)] {
        let mut wall = Duration::MAX;
        let c0 = crate::plan::cpu_seconds();
        let mut last = None;
        let mut split = RobotSplit::default();
        for _ in 0..runs {
            let t = Instant::now();
            last = Some(robot_plate(&mesh, layer, &mut split)?);
            wall = wall.min(t.elapsed());
        }
        let cpu = (crate::plan::cpu_seconds() - c0) / runs as f64;
        let (points, locations, sizes) = last.ok_or("no run")?;
        println!(
            "--layer {layer}: {} layers, {points} path points, {locations} locations in {} chunks: {:.0} ms wall (best of {runs}), {:.0} ms CPU (mean), {:.1} µs CPU a location ({})",
            (200.0 / layer) as usize,
            sizes.len(),
            wall.as_secs_f64() * 1e3,
            cpu * 1e3,
            cpu * 1e6 / locations.max(1) as f64,
            if layer >= 20.0 {
                "target: the plate under 500 ms; its path runs 50 min, the paper's 45"
            } else {
                "ten times the paper's path: a stress case"
            }
        );
        println!("  {}", split.show(runs));
    }
    println!("\n== lampost post/verify --machine puma-lens (the binary, files written) on the plate planned at --layer 20 (and plan then post at --layer 2), against the Robotics Toolbox's ikine_a on the same poses, same run");
    let mut c = cargo();
    c.args(["build", "--release", "-q", "-p", "lampost-cli"]);
    run(c)?;
    let dir = root().join("target/xtask");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let stl = dir.join("twisted-plate.stl");
    let input = dir.join("twisted-plate.csv");
    let bin = std::env::var_os("CARGO_TARGET_DIR")
        .map_or_else(|| root().join("target"), PathBuf::from)
        .join("release/lampost");
    // `lampost plan path` of the plate at a layer height, as the tests and docs plan it.
    let plan_path = |layer: &'static str, to: &PathBuf| -> Vec<std::ffi::OsString> {
        let mut a: Vec<std::ffi::OsString> = ["plan", "path"].map(Into::into).to_vec();
        a.push(stl.clone().into_os_string());
        a.extend(
            [
                "--layer",
                layer,
                "--approach",
                "build",
                "--hatch",
                "1.5",
                "--spacing",
                "2",
                "-o",
            ]
            .map(Into::into),
        );
        a.push(to.clone().into_os_string());
        a
    };
    let demo: Vec<std::ffi::OsString> = vec![
        "plan".into(),
        "demo".into(),
        "-o".into(),
        stl.clone().into_os_string(),
    ];
    for args in [demo, plan_path("20", &input)] {
        let o = Command::new(&bin)
            .args(&args)
            .output()
            .map_err(|e| e.to_string())?;
        if !o.status.success() {
            return Err(String::from_utf8_lossy(&o.stderr).into_owned());
        }
    }
    let out = dir.join("twisted-plate.robot");
    let best = |args: &[&std::ffi::OsStr]| -> Result<(Duration, String), String> {
        let mut t = Duration::MAX;
        let mut said = String::new();
        for _ in 0..5 {
            let start = Instant::now();
            let o = Command::new(&bin)
                .args(args)
                .output()
                .map_err(|e| e.to_string())?;
            t = t.min(start.elapsed());
            if !o.status.success() {
                return Err(String::from_utf8_lossy(&o.stderr).into_owned());
            }
            said = String::from_utf8_lossy(&o.stderr).into_owned();
        }
        Ok((t, said))
    };
    let (tp, said) = best(&[
        "post".as_ref(),
        "--machine".as_ref(),
        "puma-lens".as_ref(),
        input.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--chunk-points".as_ref(),
        "4000".as_ref(),
    ])?;
    print!("{said}");
    let (tv, _) = best(&[
        "verify".as_ref(),
        "--machine".as_ref(),
        "puma-lens".as_ref(),
        out.as_os_str(),
        "--input".as_ref(),
        input.as_os_str(),
        "-q".as_ref(),
    ])?;
    let manifest = std::fs::read_to_string(out.join("manifest.json")).map_err(|e| e.to_string())?;
    let locations: f64 = manifest
        .split("\"locations\":")
        .nth(1)
        .and_then(|r| r.split([',', '}']).next())
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(0.0);
    println!(
        "lampost post (plan: IK and the turn about the beam per location, chunks, in-process verify, write): {:.0} ms wall for {locations} locations, {:.1} µs each",
        tp.as_secs_f64() * 1e3,
        tp.as_secs_f64() * 1e6 / locations.max(1.0)
    );
    println!("lampost verify: {:.0} ms", tv.as_secs_f64() * 1e3);
    // The plate as a user plans and posts it, one command after the other; the path's
    // time from the manifest puts it beside the paper's build (deposition 45 minutes).
    let plan20 = plan_path("20", &input);
    let (tplan20, _) = best(&plan20.iter().map(|a| a.as_os_str()).collect::<Vec<_>>())?;
    let path_s = |m: &str| -> f64 {
        m.split("\"path_s\":")
            .nth(1)
            .and_then(|r| r.split([',', '}']).next())
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or(0.0)
    };
    let laser_s = |m: &str| -> f64 {
        m.split("\"laser_on_s\":")
            .nth(1)
            .and_then(|r| r.split([',', '}']).next())
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or(0.0)
    };
    println!(
        "the binary at --layer 20 (files written, best of 5 each): lampost plan path {:.0} ms, then lampost post {:.0} ms: {:.0} ms in all (target: under 500 ms); the path runs {:.0} min, {:.0} of them depositing (the paper's plate: 45 min of deposition)",
        tplan20.as_secs_f64() * 1e3,
        tp.as_secs_f64() * 1e3,
        (tplan20 + tp).as_secs_f64() * 1e3,
        path_s(&manifest) / 60.0,
        laser_s(&manifest) / 60.0
    );
    // The same two commands at --layer 2, as a user runs them one after the other (each
    // the best of 5, files written): the issue's "planned and posted under 0.5 s" read
    // through the binary rather than in one process.
    let input2 = dir.join("twisted-plate-2.csv");
    let out2 = dir.join("twisted-plate-2.robot");
    let plan2 = plan_path("2", &input2);
    let (tplan2, _) = best(&plan2.iter().map(|a| a.as_os_str()).collect::<Vec<_>>())?;
    let (tpost2, _) = best(&[
        "post".as_ref(),
        "--machine".as_ref(),
        "puma-lens".as_ref(),
        input2.as_os_str(),
        "-o".as_ref(),
        out2.as_os_str(),
        "--chunk-points".as_ref(),
        "4000".as_ref(),
    ])?;
    let manifest2 =
        std::fs::read_to_string(out2.join("manifest.json")).map_err(|e| e.to_string())?;
    println!(
        "the binary at --layer 2 (files written, best of 5 each): lampost plan path {:.0} ms, then lampost post {:.0} ms: {:.0} ms in all; the path runs {:.0} min, {:.0} of them depositing (ten times the paper's build: a stress case)",
        tplan2.as_secs_f64() * 1e3,
        tpost2.as_secs_f64() * 1e3,
        (tplan2 + tpost2).as_secs_f64() * 1e3,
        path_s(&manifest2) / 60.0,
        laser_s(&manifest2) / 60.0
    );
    let py = root().join(".tools/py-rtb/bin/python");
    if !py.exists() {
        println!("Robotics Toolbox baseline skipped: run scripts/install-robotics.sh");
        return Ok(());
    }
    // The toolbox solves the flange poses lampost wrote (joints → fkine → ikine_a): the
    // closed-form inverse alone, without the search about the beam or any file work.
    let script = r##"
import sys, glob, time
import numpy as np
import roboticstoolbox as rtb
rows = []
for f in sorted(glob.glob(sys.argv[1] + "/chunk-*.loc")):
    for l in open(f):
        w = l.split()
        if l.startswith("#") or w[1] != "path":
            continue
        rows.append([float(x) for x in w[11:17]])
q = np.radians(np.array(rows))
p = rtb.models.DH.Puma560()
T = p.fkine(q)
t = time.perf_counter()
s = p.ikine_a(T, config=sys.argv[2])
dt = time.perf_counter() - t
print(len(q), dt, int(s.success))
"##;
    let o = Command::new(&py)
        .args(["-c", script])
        .arg(&out)
        .arg("rdf")
        .output()
        .map_err(|e| e.to_string())?;
    let text = String::from_utf8_lossy(&o.stdout);
    let w: Vec<f64> = text
        .split_whitespace()
        .filter_map(|v| v.parse().ok())
        .collect();
    if let [n, secs, ok] = w[..] {
        println!(
            "Robotics Toolbox ikine_a on the same {n} poses: {:.0} ms ({}), {:.1} µs each; toolbox IK alone / lampost whole post = {:.1}",
            secs * 1e3,
            if ok == 1.0 { "all solved" } else { "NOT all solved" },
            secs * 1e6 / n.max(1.0),
            secs / tp.as_secs_f64()
        );
    } else {
        println!(
            "Robotics Toolbox baseline failed: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    Ok(())
}

fn bench_kin() -> Result<(), String> {
    println!("== IK + FK pairs per second (one core)");
    let mut c = cargo();
    c.args(["bench", "-p", "lampost-kinematics", "--bench", "ikfk"]);
    run(c)
}

fn calibration(trials: usize) -> Result<(), String> {
    // One micrometre in inches.
    let um = 1e-3 / 25.4;
    for (offset_um, tilt) in [(0.0, 0.0), (5.0, 0.005)] {
        println!(
            "\n== Rotary-centre calibration, simulated FADAL (inch), σ = 1 µm per touch coordinate, 30 touches per ball, {trials} trials; B line {offset_um} µm off A, A tilted {tilt}°"
        );
        println!(
            "{:<38} {:>5} {:>8} {:>14} {:>12} {:>14}",
            "method", "poses", "R fixed", "RMS |ΔR| µm", "max µm", "2u coverage"
        );
        for c in lampost_align::study::calibration_table(
            trials,
            0.001 / 25.4,
            offset_um * 1e-3 / 25.4,
            tilt,
            99,
        ) {
            let cell = |v: f64| {
                if c.solved == 0 {
                    "not fixed".to_string()
                } else {
                    format!("{:.3}", v / um)
                }
            };
            println!(
                "{:<38} {:>5} {:>8} {:>14} {:>12} {:>14}",
                c.method,
                c.poses,
                format!("{}/{}", c.solved, c.trials),
                cell(c.rms_error),
                cell(c.max_error),
                c.coverage_2u
                    .map_or("n/a".into(), |v| format!("{:.1} %", v * 100.0))
            );
        }
    }
    Ok(())
}

fn accuracy() -> Result<(), String> {
    println!("== Sphere fits: 25 mm ball, 120° cap, σ = 1 µm per coordinate, 1000 trials");
    let (f4, fnp) = lampost_align::study::four_vs_n(1000, 30, 12.5, 60.0, 0.001, 2026);
    for (name, s) in [
        ("four-point (eqs. 1-7)", f4),
        ("30-point geometric LS", fnp),
    ] {
        println!(
            "{name:<24} centre std x/y/z {:.2}/{:.2}/{:.2} µm, RMS error {:.2} µm, max {:.2} µm, radius std {:.2} µm{}",
            s.std_center[0] * 1e3, s.std_center[1] * 1e3, s.std_center[2] * 1e3,
            s.rms_center_error * 1e3, s.max_center_error * 1e3, s.std_radius * 1e3,
            s.coverage_2u.map_or(String::new(), |c| format!(", 2u covers the true error in {:.1} % of coordinates", c * 100.0))
        );
    }
    println!(
        "ratio of RMS centre errors (four-point / N-point): {:.1}",
        f4.rms_center_error / fnp.rms_center_error
    );
    Ok(())
}

mod fuzz;
mod inspect;
mod plan;

/// The manual pages, from the command line's definition, into `target/man`.
fn man() -> Result<(), String> {
    let mut c = cargo();
    c.args(["run", "-q", "-p", "lampost-cli", "--", "man", "--out-dir"])
        .arg(root().join("target/man"));
    run(c)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    let r = match a.as_slice() {
        ["bench", "gcode"] => bench_gcode(),
        ["bench", "kin"] => bench_kin(),
        ["bench", "post"] => bench_post(),
        ["bench", "plan"] => plan::bench(&root()),
        ["bench", "plan-plate"] => plan::plate(),
        ["bench", "robot"] => bench_robot(),
        ["bench", "inspect"] => inspect::bench(&root()),
        ["bench"] => bench_gcode().and_then(|()| bench_kin()).and_then(|()| bench_post()),
        ["accuracy"] => accuracy().and_then(|()| calibration(200)),
        ["calibration"] => calibration(200),
        ["man"] => man(),
        ["fuzz", rest @ ..] => fuzz::Config::parse(rest).and_then(|c| fuzz::run(&root(), &c)),
        _ => Err(format!("usage: cargo xtask bench [gcode|kin|post|plan|plan-plate|robot|inspect] | cargo xtask accuracy | cargo xtask calibration | cargo xtask man | cargo xtask fuzz {}", fuzz::USAGE)),
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let _ = writeln!(std::io::stderr(), "xtask: {e}");
            ExitCode::FAILURE
        }
    }
}
