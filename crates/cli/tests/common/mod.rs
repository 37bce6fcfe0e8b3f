//! Helpers shared by the CLI behaviour tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `../shared` beside the project, if present.
pub fn shared() -> Option<PathBuf> {
    let p = root().join("../shared");
    p.is_dir().then_some(p)
}

/// Run the `lampost` binary.
pub fn lampost(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lampost"))
        .args(args)
        .output()
        .expect("lampost runs")
}

/// Run `lampost` with `input` on stdin.
pub fn lampost_stdin(args: &[&str], input: &[u8]) -> Output {
    use std::io::Write;
    let mut child = Command::new(env!("CARGO_BIN_EXE_lampost"))
        .args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("lampost runs");
    let mut stdin = child.stdin.take().expect("stdin");
    let data = input.to_vec();
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&data);
    });
    let out = child.wait_with_output().expect("lampost finishes");
    let _ = writer.join();
    out
}

/// A fresh temporary folder for one test.
pub fn tempdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lampost-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Where `scripts/install-rs274.sh` puts LinuxCNC's rs274, if it is there.
pub fn rs274() -> Option<(PathBuf, String)> {
    let base = std::env::var_os("LAMPOST_RS274_ROOT")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join(".tools/rs274/root"));
    let bin = base.join("usr/bin/rs274");
    if bin.is_file() {
        let libs = format!(
            "{}:{}",
            base.join("usr/lib").display(),
            base.join("usr/lib/x86_64-linux-gnu").display()
        );
        Some((bin, libs))
    } else {
        None
    }
}

/// rs274, or a skip (a failure when LAMPOST_REQUIRE_RS274 is set, as in CI).
pub fn require_rs274() -> Option<(PathBuf, String)> {
    let found = rs274();
    if found.is_none() {
        if std::env::var_os("LAMPOST_REQUIRE_RS274").is_some() {
            panic!("rs274 is required (LAMPOST_REQUIRE_RS274) but not installed: run scripts/install-rs274.sh");
        }
        eprintln!("SKIPPED: rs274 not installed (run scripts/install-rs274.sh)");
    }
    found
}

/// One canonical motion from rs274's output.
#[derive(Debug, Clone)]
pub struct Canon {
    pub kind: String,
    pub args: Vec<f64>,
    pub line: usize,
}

/// rs274 runs one at a time: it keeps files of its own.
static RS274: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Run rs274 on `program` and return its motion calls.
pub fn rs274_motions(program: &Path, work: &Path) -> Vec<Canon> {
    match rs274_try(program, work) {
        Ok(v) => v,
        Err(e) => panic!("{e}"),
    }
}

/// Run rs274 on `program`: its output and the canonical calls it wrote.
pub fn rs274_exec(program: &Path, work: &Path) -> (Output, String) {
    let _one_at_a_time = RS274
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let (bin, libs) = rs274().expect("rs274 installed");
    let tbl = work.join("tool.tbl");
    let mut t = String::new();
    for i in 1..=99 {
        t.push_str(&format!("T{i} P{i} Z0 D0\n"));
    }
    std::fs::write(&tbl, t).expect("tool table");
    let out_path = work.join("canon.txt");
    // Never read an earlier program's output when rs274 writes none.
    let _ = std::fs::remove_file(&out_path);
    // rs274 keeps files in its working folder: give each run its own. Under load it has
    // been seen to end with no output (killed, or its output not written): such a run is
    // made again, up to three times in all, so a verdict never rests on it.
    let mut tries = 0;
    loop {
        let _ = std::fs::remove_file(&out_path);
        let out = Command::new(&bin)
            .current_dir(work)
            .env("LD_LIBRARY_PATH", &libs)
            .arg("-t")
            .arg(&tbl)
            .arg(program)
            .arg(&out_path)
            .stdin(std::process::Stdio::null())
            .output()
            .expect("rs274 runs");
        let text = std::fs::read_to_string(&out_path).unwrap_or_default();
        tries += 1;
        let lost = out.status.code().is_none() || text.trim().is_empty();
        if !lost || tries == 3 {
            return (out, text);
        }
    }
}

/// Run rs274 on `program`: its motion calls, or why it did not run to the end.
pub fn rs274_try(program: &Path, work: &Path) -> Result<Vec<Canon>, String> {
    let (out, text) = rs274_exec(program, work);
    if !(text.contains("PROGRAM_END") || text.lines().count() > 5) {
        return Err(format!(
            "rs274 failed on {} ({}): {}\n{}",
            program.display(),
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    canon_calls(&text)
}

/// Like [`rs274_try`], but an error rs274 reports on the way (after its menu's
/// `executing`) is a failure too, even when it wrote some motion first.
pub fn rs274_to_end(program: &Path, work: &Path) -> Result<Vec<Canon>, String> {
    let (out, text) = rs274_exec(program, work);
    // rs274 prints its menu, then `executing`, then any error, to standard error.
    let printed = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let after = printed.rsplit("executing").next().unwrap_or("").trim();
    if !after.is_empty() {
        return Err(format!("rs274: {}", after.lines().next().unwrap_or("")));
    }
    canon_calls(&text)
}

/// The motion calls of rs274's canonical output.
fn canon_calls(text: &str) -> Result<Vec<Canon>, String> {
    let mut v = Vec::new();
    for (i, l) in text.lines().enumerate() {
        for kind in [
            "STRAIGHT_TRAVERSE",
            "STRAIGHT_FEED",
            "ARC_FEED",
            "STRAIGHT_PROBE",
            "RIGID_TAP",
        ] {
            if let Some(pos) = l.find(&format!("{kind}(")) {
                let inner = &l[pos + kind.len() + 1..l.rfind(')').unwrap_or(l.len())];
                let Ok(args) = inner
                    .split(',')
                    .map(|s| s.trim().parse::<f64>())
                    .collect::<Result<Vec<f64>, _>>()
                else {
                    return Err(format!("rs274 printed `{l}`"));
                };
                v.push(Canon {
                    kind: kind.to_string(),
                    args,
                    line: i + 1,
                });
            }
        }
    }
    Ok(v)
}

/// The program stops rs274 reads in `program` (`PROGRAM_STOP`, `OPTIONAL_PROGRAM_STOP`,
/// `PALLET_SHUTTLE`), in order, each with the last motion call before it.
pub fn rs274_stops(program: &Path, work: &Path) -> Vec<(String, Option<Canon>)> {
    let (_, text) = rs274_exec(program, work);
    let calls = canon_calls(&text).unwrap_or_default();
    let mut stops = Vec::new();
    for (i, l) in text.lines().enumerate() {
        for kind in ["OPTIONAL_PROGRAM_STOP(", "PALLET_SHUTTLE(", "PROGRAM_STOP("] {
            let at = l.find(kind);
            // `PROGRAM_STOP(` is also the tail of `OPTIONAL_PROGRAM_STOP(`.
            if at.is_some_and(|a| !l[..a].ends_with("OPTIONAL_")) {
                let before = calls.iter().rev().find(|c| c.line < i + 1).cloned();
                stops.push((kind.trim_end_matches('(').to_string(), before));
                break;
            }
        }
    }
    stops
}

/// rs274's printed resolution: half of 1e-4, plus rounding slack.
pub const RS274_TOL: f64 = 0.5e-4 + 1e-9;

/// Drop what standalone rs274 cannot run: LinuxCNC's TCP mode switches (M428/M429,
/// which only the machine's kinematics module knows) and HAL pin reads.
pub fn prepare(text: &str) -> String {
    text.lines()
        .filter(|l| {
            let t = l.trim().to_ascii_lowercase();
            !(t.starts_with("m428") || t.starts_with("m429") || t.contains("_hal["))
        })
        .map(|l| format!("{l}\n"))
        .collect()
}

/// A coordinate of a `lampost trace --json` position (0 when absent).
pub fn axis(v: &serde_json::Value, a: &str) -> f64 {
    v.get(a).and_then(serde_json::Value::as_f64).unwrap_or(0.0)
}

/// `lampost trace --json` output against rs274's motion calls: every move of the same
/// kind, every coordinate within rs274's printed resolution. Ok: (coordinates compared,
/// those identical after rounding to 4 decimals); Err: the first difference.
pub fn compare_with_rs274(
    doc: &serde_json::Value,
    canon: &[Canon],
) -> Result<(usize, usize), String> {
    let moves = doc["moves"].as_array().ok_or("no moves")?;
    // A rigid tap (G33.1) is one call of rs274's and two moves of lampost's: down to
    // its end, and back to where it started.
    let taps = canon.iter().filter(|c| c.kind == "RIGID_TAP").count();
    if moves.len() != canon.len() + taps {
        return Err(format!(
            "{} moves, rs274 {} (with {taps} rigid taps, two moves each)",
            moves.len(),
            canon.len()
        ));
    }
    let (mut total, mut exact) = (0, 0);
    let mut ours_iter = moves.iter().enumerate();
    for c in canon {
        let Some((i, m)) = ours_iter.next() else {
            break;
        };
        if c.kind == "RIGID_TAP" {
            let Some((_, back)) = ours_iter.next() else {
                return Err("a rigid tap without its return".into());
            };
            let start = i
                .checked_sub(1)
                .and_then(|p| moves.get(p))
                .map(|p| &p["end"]);
            for (k, a) in ["X", "Y", "Z"].iter().enumerate() {
                let there = axis(&m["end"], a);
                let home = start.map_or(f64::NAN, |s| axis(s, a));
                let returned = axis(&back["end"], a);
                if (there - c.args[k]).abs() > RS274_TOL || (returned - home).abs() > 1e-9 {
                    return Err(format!(
                        "source line {}: rigid tap {a} to {there} and back to {returned}, rs274 to {} from {home}",
                        m["line"], c.args[k]
                    ));
                }
            }
            total += 3;
            continue;
        }
        let end = &m["end"];
        let g = m["g"].as_str().unwrap_or("");
        let (ours, theirs): (Vec<f64>, Vec<f64>) = match c.kind.as_str() {
            "ARC_FEED" => {
                if g != "G2" && g != "G3" {
                    return Err(format!("line {} is {g}, rs274 ARC_FEED", m["line"]));
                }
                let plane = m["kind"]["plane"].as_str().unwrap_or("XY");
                let (u, v, n, ui, vi) = match plane {
                    "XY" => ("X", "Y", "Z", 0, 1),
                    "XZ" => ("Z", "X", "Y", 2, 0),
                    _ => ("Y", "Z", "X", 1, 2),
                };
                let center = m["kind"]["center"].as_array().ok_or("no centre")?;
                let c_at = |i: usize| {
                    center
                        .get(i)
                        .and_then(serde_json::Value::as_f64)
                        .unwrap_or(f64::NAN)
                };
                let turns = m["kind"]["turns"].as_f64().unwrap_or(f64::NAN);
                let rot = if g == "G2" { -turns } else { turns };
                let ours = vec![
                    axis(end, u),
                    axis(end, v),
                    c_at(ui),
                    c_at(vi),
                    rot,
                    axis(end, n),
                    axis(end, "A"),
                    axis(end, "B"),
                    axis(end, "C"),
                ];
                (ours, c.args.iter().take(9).copied().collect())
            }
            kind => {
                let want = if kind == "STRAIGHT_TRAVERSE" {
                    "G0"
                } else {
                    "G1"
                };
                if g != want {
                    return Err(format!("our line {} is {g}, rs274 {kind}", m["line"]));
                }
                let ours = ["X", "Y", "Z", "A", "B", "C"]
                    .iter()
                    .map(|a| axis(end, a))
                    .collect();
                (ours, c.args.iter().take(6).copied().collect())
            }
        };
        for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
            total += 1;
            if format!("{a:.4}").parse::<f64>().ok() == Some(*b) {
                exact += 1;
            }
            if (a - b).abs() > RS274_TOL {
                return Err(format!(
                    "source line {}, value {i}: lampost {a} vs rs274 {b} (rs274 output line {})",
                    m["line"], c.line
                ));
            }
        }
    }
    Ok((total, exact))
}

/// A command's standard error, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A file of `fixtures/post`, as a path argument.
pub fn fx(name: &str) -> String {
    root()
        .join("fixtures/post")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// The words of a slicer line (comment stripped), as (letter, number text).
pub fn slicer_words(line: &str) -> Vec<(char, &str)> {
    let code = line.split(';').next().unwrap_or("");
    // `(…)` comments (MakerBot's `(d: 31.798)`) are dropped.
    let mut depth = 0usize;
    let code: Vec<&str> = code
        .split_inclusive(['(', ')'])
        .filter_map(|piece| {
            let kept = (depth == 0).then(|| piece.trim_end_matches('('));
            if piece.ends_with('(') {
                depth += 1;
            } else if piece.ends_with(')') {
                depth = depth.saturating_sub(1);
            }
            kept
        })
        .collect();
    code.into_iter()
        .flat_map(str::split_whitespace)
        .filter_map(|t| {
            let mut c = t.chars();
            let l = c.next()?.to_ascii_uppercase();
            Some((l, c.as_str()))
        })
        .collect()
}

fn num(s: &str) -> f64 {
    s.parse::<f64>().unwrap_or_else(|_| panic!("number {s}"))
}

/// Length of an XY arc from `s` to `e` about the centre `c` (`cw`: clockwise), with the Z
/// change `dz` along it (a helix); start = end is a full circle.
fn arc_length(s: [f64; 2], e: [f64; 2], c: [f64; 2], cw: bool, dz: f64) -> f64 {
    let r = (s[0] - c[0]).hypot(s[1] - c[1]);
    let a0 = (s[1] - c[1]).atan2(s[0] - c[0]);
    let a1 = (e[1] - c[1]).atan2(e[0] - c[0]);
    let tau = std::f64::consts::TAU;
    let mut sweep = if cw { a0 - a1 } else { a1 - a0 };
    sweep = sweep.rem_euclid(tau);
    if sweep <= 1e-12 {
        sweep = tau;
    }
    (r * sweep).hypot(dz)
}

/// Extruding runs and extruding length of a slicer program, read here on its own (not
/// through lampost): G0/G1/G2/G3 lines with X, Y or Z are moves (arcs in XY with I/J,
/// helical in Z); a G1/G2/G3 move extrudes when its E grows. E is relative under M83,
/// absolute under M82, and G90/G91 set it with the axes (Marlin's rule); G92 E resets it.
/// A run is a longest sequence of extruding moves with no other move between them;
/// lines that are not moves (E-only, F-only, settings) do not end a run.
pub fn extruding_runs(src: &str) -> (usize, f64) {
    extruding_runs_with(src, &['E'])
}

/// [`extruding_runs`] with the extruder named by any of `letters` (MakerBot: A, B).
pub fn extruding_runs_with(src: &str, letters: &[char]) -> (usize, f64) {
    let (mut pos, mut e) = ([0.0f64; 3], 0.0f64);
    let (mut e_relative, mut incremental) = (false, false);
    let (mut runs, mut length, mut in_run) = (0usize, 0.0f64, false);
    let mut motion = 0u8;
    for line in src.lines() {
        let w = slicer_words(line);
        let Some(&(l, code)) = w.first() else {
            continue;
        };
        let code = code.trim_start_matches('0');
        let code = if code.is_empty() { "0" } else { code };
        match (l, code) {
            ('M', "82") => e_relative = false,
            ('M', "83") => e_relative = true,
            ('G', "90") => (incremental, e_relative) = (false, false),
            ('G', "91") => (incremental, e_relative) = (true, true),
            ('G', "92") => {
                for &(l, v) in &w[1..] {
                    match l {
                        // Setting an axis moves nothing (positions here are the
                        // program's own, so the axis simply reads that value).
                        'X' | 'Y' | 'Z' => pos[(l as u8 - b'X') as usize] = num(v),
                        l if letters.contains(&l) => e = num(v),
                        _ => panic!("G92 of {l} is not read by this test: {line}"),
                    }
                }
            }
            ('G', "0" | "1" | "2" | "3") => motion = code.as_bytes()[0] - b'0',
            _ => {}
        }
        if !(l == 'G' && matches!(code, "0" | "1" | "2" | "3")) {
            continue;
        }
        let mut end = pos;
        let (mut grown, mut is_move) = (0.0, false);
        let mut centre = [pos[0], pos[1]];
        for &(l, v) in &w[1..] {
            match l {
                'X' | 'Y' | 'Z' => {
                    let a = (l as u8 - b'X') as usize;
                    end[a] = if incremental { pos[a] + num(v) } else { num(v) };
                    is_move = true;
                }
                'I' => centre[0] = pos[0] + num(v),
                'J' => centre[1] = pos[1] + num(v),
                l if letters.contains(&l) && e_relative => {
                    grown = num(v);
                    e += grown;
                }
                l if letters.contains(&l) => {
                    grown = num(v) - e;
                    e = num(v);
                }
                _ => {}
            }
        }
        if !is_move {
            continue;
        }
        let extrudes = motion != 0 && grown > 0.0;
        if extrudes {
            length += if motion >= 2 {
                arc_length(
                    [pos[0], pos[1]],
                    [end[0], end[1]],
                    centre,
                    motion == 2,
                    end[2] - pos[2],
                )
            } else {
                ((end[0] - pos[0]).powi(2) + (end[1] - pos[1]).powi(2) + (end[2] - pos[2]).powi(2))
                    .sqrt()
            };
            if !in_run {
                runs += 1;
            }
        }
        // A move that goes nowhere and extrudes nothing (a slicer's `G1 Z0.3 F9000` at
        // Z0.3) ends no run: the head stands where it was.
        if extrudes || end != pos {
            in_run = extrudes;
        }
        pos = end;
    }
    (runs, length)
}

/// Laser-on events (`M71`) and the length fed with the laser on, read from a posted
/// NRC program (B and C stay at one index, so X Y Z lengths are tip lengths; arcs are
/// G2/G3 in XY with incremental I/J).
pub fn posted_deposition(nc: &str) -> (usize, f64) {
    let (mut pos, mut on, mut ons, mut length) = ([0.0f64; 3], false, 0usize, 0.0f64);
    let mut motion = 0u8;
    for line in nc.lines() {
        let code = line.split('(').next().unwrap_or("");
        let mut end = pos;
        let mut centre = [pos[0], pos[1]];
        for t in code.split_whitespace() {
            let (l, v) = t.split_at(1);
            match l {
                "M" if v == "71" => {
                    on = true;
                    ons += 1;
                }
                "M" if v == "72" => on = false,
                "G" if matches!(v, "0" | "1" | "2" | "3") => motion = v.as_bytes()[0] - b'0',
                "X" | "Y" | "Z" => end[(l.as_bytes()[0] - b'X') as usize] = num(v),
                "I" => centre[0] = pos[0] + num(v),
                "J" => centre[1] = pos[1] + num(v),
                "B" | "C" => assert_eq!(num(v), 0.0, "one index"),
                _ => {}
            }
        }
        if end != pos {
            assert!(!(on && motion == 0), "a rapid with the laser on: {line}");
            if on {
                length += if motion >= 2 {
                    arc_length(
                        [pos[0], pos[1]],
                        [end[0], end[1]],
                        centre,
                        motion == 2,
                        end[2] - pos[2],
                    )
                } else {
                    ((end[0] - pos[0]).powi(2)
                        + (end[1] - pos[1]).powi(2)
                        + (end[2] - pos[2]).powi(2))
                    .sqrt()
                };
            }
        }
        pos = end;
    }
    (ons, length)
}

/// Run `script` in `sh` with at most `kib` KiB of virtual memory and `secs` seconds;
/// `$LAMPOST` is the binary. Hostile inputs are made by the script's own pipes, so the
/// test holds none of them in memory.
pub fn limited(script: &str, kib: u64, secs: u64) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {kib}; {script}"))
        .env("LAMPOST", env!("CARGO_BIN_EXE_lampost"))
        .env("TIMEOUT", secs.to_string())
        .output()
        .expect("sh runs")
}
