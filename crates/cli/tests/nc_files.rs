//! LinuxCNC's own sample programs (`nc_files/` of github.com/LinuxCNC/linuxcnc, commit
//! 5c41560ebb, copied to `fixtures/linuxcnc-nc_files/` with subfolders flattened as
//! `dir__name.ngc`) against rs274, each with its expected verdict in `VERDICTS`:
//!
//! - `equal N`: `lampost trace` gives rs274's N moves, every coordinate within rs274's
//!   printed resolution;
//! - `refused`: `lampost trace` stops with a located error (parametric programs, o-word
//!   subroutines and codes not supported yet, issue 12);
//! - `differs`: both run and the moves differ (the first difference is printed);
//! - `rs274-fails`: rs274 itself does not run the program to its end standalone (it needs
//!   a machine configuration, remaps, or user M-codes, or stops with an error on the way:
//!   NURBS outside the XY plane, a probe move standalone).
//!
//! A verdict that changes fails the test: an improvement is recorded by running it with
//! `LAMPOST_UPDATE_VERDICTS=1` and reviewing the diff of `VERDICTS`.

mod common;

use common::*;
use std::collections::BTreeMap;

#[test]
fn linuxcnc_sample_programs_against_rs274() {
    if require_rs274().is_none() {
        return;
    }
    let dir = root().join("fixtures/linuxcnc-nc_files");
    let verdicts_path = dir.join("VERDICTS");
    let work = tempdir("nc_files");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("fixtures")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "ngc"))
        .collect();
    files.sort();
    assert!(files.len() > 200, "{} programs", files.len());
    let mut got: BTreeMap<String, String> = BTreeMap::new();
    let (mut equal, mut moves) = (0usize, 0usize);
    for path in &files {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let text = String::from_utf8_lossy(&std::fs::read(path).expect("read")).into_owned();
        // rs274 keeps state (its parameter file) in its working folder: each program
        // gets a folder of its own, so no verdict depends on the programs run before.
        let own = work.join(name.replace('.', "_"));
        std::fs::create_dir_all(&own).expect("folder");
        let prog = own.join(&name);
        std::fs::write(&prog, prepare(&text)).expect("write");
        // rs274 now and then writes no output for a program it runs (under load, seen
        // on a few of these): a failure is tried once more before it counts.
        let verdict = match rs274_to_end(&prog, &own).or_else(|_| rs274_to_end(&prog, &own)) {
            Err(_) => "rs274-fails".to_string(),
            Ok(canon) => {
                let out = lampost(&["trace", "--json", prog.to_str().expect("utf8")]);
                if !out.status.success() {
                    "refused".to_string()
                } else {
                    match serde_json::from_slice::<serde_json::Value>(&out.stdout) {
                        Ok(doc) => match compare_with_rs274(&doc, &canon) {
                            Ok(_) => {
                                equal += 1;
                                moves += canon.len();
                                format!("equal {}", canon.len())
                            }
                            Err(e) => {
                                eprintln!("{name}: differs: {e}");
                                "differs".to_string()
                            }
                        },
                        Err(_) => "refused".to_string(),
                    }
                }
            }
        };
        got.insert(name, verdict);
    }
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for v in got.values() {
        *counts.entry(v.split(' ').next().unwrap_or("")).or_default() += 1;
    }
    eprintln!(
        "nc_files: {} programs; {equal} equal to rs274 ({moves} moves); {counts:?}",
        got.len()
    );
    let text: String = got.iter().map(|(k, v)| format!("{k} {v}\n")).collect();
    if std::env::var_os("LAMPOST_UPDATE_VERDICTS").is_some() {
        std::fs::write(&verdicts_path, &text).expect("write VERDICTS");
        return;
    }
    let want = std::fs::read_to_string(&verdicts_path).unwrap_or_default();
    let want: BTreeMap<&str, &str> = want.lines().filter_map(|l| l.split_once(' ')).collect();
    let mut changed = Vec::new();
    for (k, v) in &got {
        if want.get(k.as_str()) != Some(&v.as_str()) {
            changed.push(format!("{k}: expected {:?}, got {v}", want.get(k.as_str())));
        }
    }
    assert!(
        changed.is_empty(),
        "verdicts changed (review, then LAMPOST_UPDATE_VERDICTS=1):\n{}",
        changed.join("\n")
    );
}
