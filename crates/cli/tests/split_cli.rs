//! Programs split with `lampost post --max-bytes` read back: every piece passes `lampost
//! check`, `lampost trace` follows the FADAL subprogram calls, and `lampost verify` reads
//! the FADAL file, or the DNC pieces given together, as the one program they are.

mod common;

use std::path::{Path, PathBuf};

use common::*;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf8 path")
}

/// The wall built as an arch (a re-index every layer, so many split points).
fn arch(machine: &str) -> Vec<String> {
    let mut v: Vec<String> = [
        "--machine",
        machine,
        "--layer-axis",
        "0,1,0",
        "--layer-angle",
        "3",
    ]
    .iter()
    .map(|x| x.to_string())
    .collect();
    if machine == "nrc-lc" {
        v.push("--convert-units".into());
    }
    v
}

/// `lampost post` with `placement`, `extra` options, `fixtures/post/wall.nc`, to `out`.
fn post(placement: &[String], extra: &[&str], out: &Path) {
    let mut args = vec!["post"];
    args.extend(placement.iter().map(String::as_str));
    args.extend(extra);
    let wall = fx("wall.nc");
    args.extend([wall.as_str(), "-o", s(out)]);
    let o = lampost(&args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
}

/// `lampost verify` of `posted` against the wall with `placement`.
fn verify(placement: &[String], extra: &[&str], posted: &[PathBuf]) -> std::process::Output {
    let mut args = vec!["verify"];
    args.extend(placement.iter().map(String::as_str));
    args.extend(extra);
    let wall = fx("wall.nc");
    args.push(wall.as_str());
    args.extend(posted.iter().map(|p| s(p)));
    args.push("--json");
    lampost(&args)
}

/// `lampost check --json` of `file`: (errors, warnings).
fn check(file: &Path, units: &str) -> (u64, u64) {
    let o = lampost(&["check", s(file), "--units", units, "--json"]);
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let n = |k: &str| doc[k].as_u64().expect("count");
    assert_eq!(o.status.success(), n("errors") == 0, "{doc}");
    (n("errors"), n("warnings"))
}

/// The moves of `lampost trace --json` (kind and end), for comparing programs.
fn trace(file: &Path, units: &str) -> Vec<(String, Vec<f64>)> {
    let o = lampost(&["trace", s(file), "--units", units, "--json"]);
    assert!(o.status.success(), "{}: {}", file.display(), stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    doc["moves"]
        .as_array()
        .expect("moves")
        .iter()
        .map(|m| {
            let end = m["end"].as_object().expect("end");
            (
                m["g"].as_str().unwrap_or_default().to_string(),
                end.values()
                    .map(|v| v.as_f64().unwrap_or(f64::NAN))
                    .collect(),
            )
        })
        .collect()
}

/// The numbered pieces `stem.001.nc`, … beside `out`.
fn pieces(out: &Path) -> Vec<PathBuf> {
    let stem = out
        .file_stem()
        .expect("stem")
        .to_string_lossy()
        .into_owned();
    let dir = out.parent().expect("dir");
    (1..)
        .map(|k| dir.join(format!("{stem}.{k:03}.nc")))
        .take_while(|p| p.exists())
        .collect()
}

#[test]
fn a_split_fadal_file_checks_traces_and_verifies() {
    let dir = tempdir("split-fadal");
    let place = arch("fadal-lamp");
    let whole = dir.join("whole.nc");
    let split = dir.join("split.nc");
    post(&place, &[], &whole);
    post(&place, &["--max-bytes", "700"], &split);
    let text = std::fs::read_to_string(&split).expect("read");
    let parts = text.matches("M99\n").count();
    assert!(parts >= 2, "{text}");
    assert_eq!(text.matches("M98 P").count(), parts);
    // Every line of every program is read, and nothing is wrong or left unread.
    assert_eq!(check(&split, "inch"), (0, 0));
    // The trace follows the calls: the same moves as the program posted whole.
    assert_eq!(trace(&split, "inch"), trace(&whole, "inch"));
    // Standard input too.
    let o = lampost_stdin(&["trace", "-", "--units", "inch"], text.as_bytes());
    assert!(o.status.success(), "{}", stderr(&o));
    let o2 = lampost(&["trace", s(&whole), "--units", "inch"]);
    assert_eq!(o.stdout, o2.stdout);
    // Verification reads it in execution order.
    let o = verify(&place, &[], std::slice::from_ref(&split));
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let w = verify(&place, &[], std::slice::from_ref(&whole));
    let w: serde_json::Value = serde_json::from_slice(&w.stdout).expect("json");
    assert_eq!(v["moves"], w["moves"]);
    assert_eq!(v["compared"], w["compared"]);
    // A part left uncalled, or the calls swapped, fails; a call to a missing part is
    // located.
    let bad = dir.join("bad.nc");
    for (from, to) in [
        ("M98 P1002\n", ""),
        ("M98 P1001\nM98 P1002\n", "M98 P1002\nM98 P1001\n"),
        ("M98 P1002\n", "M98 P1009\n"),
    ] {
        assert!(text.contains(from));
        std::fs::write(&bad, text.replacen(from, to, 1)).expect("write");
        let o = verify(&place, &[], std::slice::from_ref(&bad));
        assert!(!o.status.success(), "{to:?} verified");
        if to == "M98 P1009\n" {
            assert!(
                stderr(&o).contains("this file holds no program O1009")
                    && stderr(&o).contains("bad.nc:"),
                "{}",
                stderr(&o)
            );
            assert_eq!(check(&bad, "inch").0, 1);
        }
    }
}

#[test]
fn dnc_pieces_check_alone_and_verify_together() {
    for (place, extra, max, units) in [
        (arch("nrc-lc"), vec![], "800", "mm"),
        (arch("fadal-lamp"), vec!["--dialect", "iso"], "600", "inch"),
    ] {
        let dir = tempdir(&format!("split-dnc-{units}"));
        let whole = dir.join("whole.nc");
        let out = dir.join("arch.nc");
        post(&place, &extra, &whole);
        let mut opts = extra.clone();
        opts.extend(["--max-bytes", max]);
        post(&place, &opts, &out);
        let files = pieces(&out);
        assert!(files.len() >= 3, "{files:?}");
        let mut joined = Vec::new();
        for f in &files {
            let len = std::fs::metadata(f).expect("meta").len();
            assert!(
                len <= max.parse().expect("max"),
                "{}: {len} bytes",
                f.display()
            );
            // Each piece reads alone: units and modes come first, motion codes explicit.
            assert_eq!(check(f, units), (0, 0), "{}", f.display());
            joined.extend(std::fs::read(f).expect("read"));
        }
        // Together they are the program posted whole.
        let cat = dir.join("joined.nc");
        std::fs::write(&cat, &joined).expect("write");
        assert_eq!(trace(&cat, units), trace(&whole, units));
        let process: Vec<&str> = vec![];
        let o = verify(&place, &process, &files);
        assert!(o.status.success(), "{}", stderr(&o));
        // A piece left out, or two swapped, fails.
        let mut missing = files.clone();
        missing.remove(1);
        let o = verify(&place, &process, &missing);
        assert!(!o.status.success(), "verified without piece 2");
        let mut swapped = files.clone();
        swapped.swap(0, 1);
        let o = verify(&place, &process, &swapped);
        assert!(!o.status.success(), "verified with pieces swapped");
        // The failure names the piece and its own line.
        assert!(stderr(&o).contains(".nc"), "{}", stderr(&o));
        let mut last_out = files.clone();
        last_out.pop();
        let o = verify(&place, &process, &last_out);
        assert!(!o.status.success(), "verified without the last piece");
        assert!(
            stderr(&o).contains("does not end the program"),
            "{}",
            stderr(&o)
        );
    }
}

#[test]
fn verify_errors_in_a_piece_name_the_piece() {
    let dir = tempdir("split-locate");
    let place = arch("nrc-lc");
    let out = dir.join("arch.nc");
    post(&place, &["--max-bytes", "1200"], &out);
    let files = pieces(&out);
    let text = std::fs::read_to_string(&files[1]).expect("read");
    // Move a feed point off the path in piece 2.
    let line = text
        .lines()
        .position(|l| l.contains(" G1 ") && l.contains('Z'))
        .expect("a feed line");
    let bad: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == line {
                format!("{l} X1000")
            } else {
                l.to_string()
            }
        })
        .collect();
    std::fs::write(&files[1], bad.join("\n") + "\n").expect("write");
    let o = verify(&place, &[], &files);
    assert!(!o.status.success());
    let want = format!("posted line {} of {}", line + 1, files[1].to_string_lossy());
    assert!(stderr(&o).contains(&want), "`{want}` not in {}", stderr(&o));
}

/// LinuxCNC's rs274 reads the DNC pieces, one after another, to the same motion as the
/// program posted whole (machining, so only standard M-codes).
#[test]
fn rs274_reads_the_joined_iso_pieces_as_the_whole_program() {
    if require_rs274().is_none() {
        return;
    }
    let dir = tempdir("split-rs274");
    let place = arch("fadal-lamp");
    let extra = ["--dialect", "iso", "--process", "machine"];
    let whole = dir.join("whole.ngc");
    post(&place, &extra, &whole);
    let out = dir.join("arch.nc");
    let mut opts = extra.to_vec();
    opts.extend(["--max-bytes", "600"]);
    post(&place, &opts, &out);
    let files = pieces(&out);
    assert!(files.len() >= 3, "{files:?}");
    let mut joined = Vec::new();
    for f in &files {
        joined.extend(std::fs::read(f).expect("read"));
    }
    let cat = dir.join("joined.ngc");
    std::fs::write(&cat, &joined).expect("write");
    let a = rs274_motions(&whole, &dir);
    let b = rs274_motions(&cat, &dir);
    assert!(a.len() > 50, "{} motions", a.len());
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.kind, y.kind);
        assert_eq!(x.args.len(), y.args.len());
        for (u, v) in x.args.iter().zip(&y.args) {
            assert!((u - v).abs() <= 1e-9, "{x:?} vs {y:?}");
        }
    }
    // And lampost's trace of the pieces is the same motion.
    let ours = trace(&cat, "inch");
    assert_eq!(ours.len(), b.len());
}
