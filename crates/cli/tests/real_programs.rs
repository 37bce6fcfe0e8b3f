//! Real programs from public repositories (`fixtures/real-programs/<generator>/`, sources
//! in its `SOURCES.md`), each with its expected verdict in `VERDICTS`:
//!
//! - `equal N`: `lampost trace` gives rs274's N moves, every coordinate within rs274's
//!   printed resolution (programs rs274 runs to the end);
//! - `differs N`: both run and the moves differ (the first difference is printed);
//! - `traced N`: `lampost trace` gives N moves and rs274 does not run the program (slicer
//!   programs, FADAL and Haas dialects, programs that need a machine configuration);
//! - `refused L:C message`: `lampost trace` stops with a located error, the first one
//!   `lampost check` reports (each was read by hand: see `SOURCES.md`).
//!
//! Slicer programs (prusaslicer, cura, bambustudio, slic3r, kisslicer, simplify3d,
//! superslicer, icesl, mattercontrol, orcaslicer, snapmaker-luban, ideamaker, skeinforge,
//! miracle-grue, arcwelder, marlin-kfactor, kcalibrator, weedo, creality-print, fullcontrol)
//! are traced with `--e-word extrusion` and posted with `post --machine nrc-lc --e-extrusion`; the
//! verdict then says `post R runs` when the post deposits the extruding length (relative
//! difference ≤ 1e-9) with one laser-on per extruding run, or `post refused L: …`. Their
//! start code's homing (`G28`) and bed levelling (`G29`) lines are left out of the posted
//! input: a move to the printer's home cannot be placed on the part (the post refuses it,
//! see docs/post.md), and nothing else is changed. Each must also be read as a slicer's
//! program by `--flavor auto` (`marlin`, `reprap` or `makerbot` in `check --json`).
//!
//! A program `lampost check` says is a lathe's (Fanuc or Haas turning, read as a mill's)
//! has `; lathe L` after its verdict, L the line where it is said: a mill program
//! taken for a lathe's would change its verdict.
//!
//! A verdict that changes fails the test: an improvement is recorded by running it with
//! `LAMPOST_UPDATE_VERDICTS=1` and reviewing the diff of `VERDICTS`.

mod common;

use common::*;
use std::collections::BTreeMap;
use std::path::Path;

const SLICERS: [&str; 20] = [
    "prusaslicer",
    "cura",
    "bambustudio",
    "slic3r",
    "kisslicer",
    "simplify3d",
    "superslicer",
    "icesl",
    "mattercontrol",
    "orcaslicer",
    "snapmaker-luban",
    "ideamaker",
    "skeinforge",
    "miracle-grue",
    "arcwelder",
    "marlin-kfactor",
    "kcalibrator",
    "weedo",
    "creality-print",
    "fullcontrol",
];

/// `lampost check --json` of a program (with `e_word`'s options): the report and the run.
fn check_json(path: &Path, e_word: &[&str]) -> (serde_json::Value, std::process::Output) {
    let p = path.to_str().expect("utf-8 path");
    let mut args = vec!["check", "--json"];
    args.extend_from_slice(e_word);
    args.push(p);
    let out = lampost(&args);
    let doc = serde_json::from_slice(&out.stdout).unwrap_or_default();
    (doc, out)
}

/// The first error `lampost check` reports, as `L:C message`.
fn first_error(path: &Path, e_word: &[&str]) -> String {
    let (doc, out) = check_json(path, e_word);
    doc["diagnostics"]
        .as_array()
        .and_then(|d| d.iter().find(|d| d["severity"] == "error"))
        .map_or_else(
            || {
                format!(
                    "(no located error) {}",
                    stderr(&out).lines().next().unwrap_or("")
                )
            },
            |d| {
                format!(
                    "{}:{} {}",
                    d["line"],
                    d["column"],
                    d["message"].as_str().unwrap_or("")
                )
            },
        )
}

/// The line at which `lampost check` says the program is a lathe's (`; lathe L` in its
/// verdict), if it does: every other program must be read as a mill's or a printer's.
fn lathe_line(path: &Path, e_word: &[&str]) -> Option<u64> {
    let (doc, _) = check_json(path, e_word);
    doc["diagnostics"].as_array()?.iter().find_map(|d| {
        d["message"]
            .as_str()
            .filter(|m| m.contains("this is a lathe (turning) program"))
            .and(d["line"].as_u64())
    })
}

/// The flavour `--flavor auto` finds for a program, as `check --json` reports it.
fn auto_flavor(path: &Path) -> String {
    let p = path.to_str().expect("utf-8 path");
    let out = lampost(&["check", "--json", "--flavor", "auto", p]);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    doc["flavor"]["flavor"]
        .as_str()
        .unwrap_or("(no flavour reported)")
        .to_string()
}

/// Post a slicer program (homing and levelling lines left out) and compare its deposition
/// with the extruding runs and length read from the program.
fn post_verdict(path: &Path, work: &Path) -> String {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("?");
    let src = String::from_utf8_lossy(&std::fs::read(path).expect("reads")).into_owned();
    let input: String = src
        .lines()
        .filter(|l| !(l.starts_with("G28") || l.starts_with("G29")))
        .map(|l| format!("{l}\n"))
        .collect();
    let inp = work.join(name);
    std::fs::write(&inp, &input).expect("writes");
    let out_path = work.join(format!("{name}.nc"));
    let out = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--e-extrusion",
        "--convert-units",
        inp.to_str().expect("utf-8"),
        "-o",
        out_path.to_str().expect("utf-8"),
    ]);
    if !out.status.success() {
        // `error: FILE:LINE: what` (lines of the posted input, which keeps the lines of
        // the program but those left out above).
        let err = stderr(&out);
        let first = err.lines().next().unwrap_or("");
        let first = first.strip_prefix("error: ").unwrap_or(first);
        let inp_text = format!("{}:", inp.to_string_lossy());
        return match first.strip_prefix(&inp_text) {
            Some(rest) if rest.starts_with(|c: char| c.is_ascii_digit()) => {
                format!("post refused line {rest}")
            }
            Some(rest) => format!("post refused{rest}"),
            None => format!("post refused {first}"),
        };
    }
    let nc = std::fs::read_to_string(&out_path).expect("posted");
    // MakerBot programs name the extruder A (or B).
    let makerbot = path.to_string_lossy().contains("miracle-grue");
    let (runs, extruding) = if makerbot {
        extruding_runs_with(&input, &['A', 'B', 'E'])
    } else {
        extruding_runs(&input)
    };
    let (ons, deposited) = posted_deposition(&nc);
    assert_eq!(ons, runs, "{name}: laser-on events vs extruding runs");
    let rel = (deposited - extruding).abs() / extruding.max(f64::MIN_POSITIVE);
    assert!(
        rel <= 1e-9,
        "{name}: deposited {deposited} vs extruding {extruding} (relative {rel:e})"
    );
    format!("post {runs} runs")
}

#[test]
fn real_programs_against_their_verdicts() {
    if require_rs274().is_none() {
        return;
    }
    let dir = root().join("fixtures/real-programs");
    let verdicts_path = dir.join("VERDICTS");
    let work = tempdir("real-programs");
    let mut files = Vec::new();
    for gen in std::fs::read_dir(&dir).expect("fixtures").flatten() {
        if gen.path().is_dir() {
            for f in std::fs::read_dir(gen.path()).expect("generator").flatten() {
                files.push(f.path());
            }
        }
    }
    files.sort();
    assert!(files.len() >= 60, "{} programs", files.len());
    let want_text = std::fs::read_to_string(&verdicts_path).unwrap_or_default();
    let want: BTreeMap<&str, &str> = want_text
        .lines()
        .filter_map(|l| l.split_once(' '))
        .collect();
    let mut got: BTreeMap<String, String> = BTreeMap::new();
    let (mut equal, mut moves, mut deposits) = (0usize, 0usize, 0usize);
    let mut generators = std::collections::BTreeSet::new();
    // Slicer programs `--flavor auto` does not read as a slicer's (marlin or reprap).
    let mut misread = Vec::new();
    for path in &files {
        let gen = path
            .parent()
            .and_then(Path::file_name)
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        generators.insert(gen.clone());
        let slicer = SLICERS.contains(&gen.as_str());
        let e_word: &[&str] = if slicer {
            &["--e-word", "extrusion"]
        } else {
            &[]
        };
        let p = path.to_str().expect("utf-8 path");
        let mut args = vec!["trace", "--json"];
        args.extend_from_slice(e_word);
        args.push(p);
        let out = lampost(&args);
        let doc = out
            .status
            .success()
            .then(|| serde_json::from_slice::<serde_json::Value>(&out.stdout).ok())
            .flatten();
        let mut verdict = match &doc {
            None => format!("refused {}", first_error(path, e_word)),
            Some(doc) => {
                let n = doc["moves"].as_array().map_or(0, Vec::len);
                let canon = if slicer {
                    None
                } else {
                    let text =
                        String::from_utf8_lossy(&std::fs::read(path).expect("read")).into_owned();
                    let prog = work.join(format!("{gen}-{name}"));
                    std::fs::write(&prog, prepare(&text)).expect("write");
                    let key = format!("{gen}/{name}");
                    let runs_to_end = want
                        .get(key.as_str())
                        .is_some_and(|v| v.starts_with("equal") || v.starts_with("differs"));
                    match rs274_to_end(&prog, &work) {
                        Ok(c) => Some(c),
                        // rs274 is an outside program: on a loaded machine it has ended
                        // a run early once (CI, `dxf2gcode/erin7-b02.ngc`, which it runs
                        // to the end otherwise). A program the verdicts say it runs to
                        // the end is run once more, said, before its verdict changes.
                        Err(e) if runs_to_end => {
                            eprintln!("{key}: rs274 stopped early ({e}); running it once more");
                            rs274_to_end(&prog, &work).ok()
                        }
                        Err(_) => None,
                    }
                };
                match canon {
                    None => format!("traced {n}"),
                    Some(canon) => match compare_with_rs274(doc, &canon) {
                        Ok(_) => {
                            equal += 1;
                            moves += canon.len();
                            format!("equal {n}")
                        }
                        Err(e) => {
                            eprintln!("{gen}/{name}: differs from rs274: {e}");
                            format!("differs {n}")
                        }
                    },
                }
            }
        };
        if slicer {
            let f = auto_flavor(path);
            if !matches!(f.as_str(), "marlin" | "reprap" | "makerbot") {
                misread.push(format!("{gen}/{name}: {f}"));
            }
        }
        if slicer && doc.is_some() {
            let v = post_verdict(path, &work);
            deposits += usize::from(!v.contains("refused"));
            verdict = format!("{verdict}; {v}");
        }
        if let Some(line) = lathe_line(path, e_word) {
            verdict = format!("{verdict}; lathe {line}");
        }
        got.insert(format!("{gen}/{name}"), verdict);
    }
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for v in got.values() {
        *counts.entry(v.split(' ').next().unwrap_or("")).or_default() += 1;
    }
    eprintln!(
        "real programs: {} programs from {} generators; {equal} equal to rs274 ({moves} moves); \
         {deposits} slicer programs posted with their extruding length deposited; {counts:?}",
        got.len(),
        generators.len()
    );
    assert!(generators.len() >= 8, "{generators:?}");
    assert!(
        misread.is_empty(),
        "slicer programs --flavor auto does not read as a slicer's:\n{}",
        misread.join("\n")
    );
    let text: String = got.iter().map(|(k, v)| format!("{k} {v}\n")).collect();
    if std::env::var_os("LAMPOST_UPDATE_VERDICTS").is_some() {
        std::fs::write(&verdicts_path, &text).expect("write VERDICTS");
        return;
    }
    let mut changed = Vec::new();
    for (k, v) in &got {
        if want.get(k.as_str()) != Some(&v.as_str()) {
            changed.push(format!("{k}: expected {:?}, got {v}", want.get(k.as_str())));
        }
    }
    for k in want.keys() {
        if !got.contains_key(*k) {
            changed.push(format!("{k}: in VERDICTS but not in fixtures"));
        }
    }
    assert!(
        changed.is_empty(),
        "verdicts changed (review, then LAMPOST_UPDATE_VERDICTS=1):\n{}",
        changed.join("\n")
    );
}
