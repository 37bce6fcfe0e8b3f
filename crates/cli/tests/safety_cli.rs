//! Post safety (issue 11): safe heights derived from the work, machine-coordinate moves,
//! and a verify that catches wrong programs. Heights are checked here with FADAL's
//! kinematics written out from the machine file's comment (paper 000), not the crate's.

mod common;
#[path = "../../post/tests/papers/mod.rs"]
mod papers;

use common::*;
use papers::fadal_tip;
use std::path::Path;

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p.to_string_lossy().into_owned()
}

/// The posted rapids and feeds as (g, X, Y, Z, A, B), via `lampost trace`.
fn moves(posted: &str) -> Vec<(String, [f64; 5])> {
    let t = lampost_stdin(
        &["trace", "-", "--json", "--units", "inch"],
        posted.as_bytes(),
    );
    assert!(t.status.success(), "{}", stderr(&t));
    let doc: serde_json::Value = serde_json::from_slice(&t.stdout).expect("json");
    doc["moves"]
        .as_array()
        .expect("moves")
        .iter()
        .map(|m| {
            let e = &m["end"];
            let g = |k: &str| e[k].as_f64().unwrap_or(0.0);
            (
                m["g"].as_str().unwrap_or("").to_string(),
                [g("X"), g("Y"), g("Z"), g("A"), g("B")],
            )
        })
        .collect()
}

/// Issue 11, case 1: with the laser head at B = −20 and the part 1 in up, the head
/// used to retract to Z10 and traverse below the deposit (which runs at Z 10.9–11.3).
/// Every non-vertical rapid must now be above every feed tip along the tool axis, by
/// the margin, in the part frame, by the paper's formulas.
#[test]
fn retract_clears_the_work_at_a_tilted_index() {
    for (index, origin) in [
        ("A=0,B=-20", "0,0,1"),
        ("A=0,B=0", "0,0,1"),
        ("A=30,B=45", "0,0,0.5"),
    ] {
        let o = lampost(&[
            "post",
            "--machine",
            "fadal-lamp",
            "--index",
            index,
            "--origin",
            origin,
            &fx("issue11-patch.nc"),
        ]);
        assert!(o.status.success(), "{index}: {}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let mv = moves(&text);
        let tips: Vec<([f64; 3], [f64; 3])> = mv
            .iter()
            .filter(|(g, _)| g != "G0")
            .map(|(_, j)| fadal_tip([j[0], j[1], j[2]], j[3], j[4], true))
            .collect();
        assert!(!tips.is_empty());
        let mut prev: Option<[f64; 5]> = None;
        for (g, j) in &mv {
            if g == "G0" {
                if let Some(p) = prev {
                    let vertical = p[0] == j[0] && p[1] == j[1] && p[3] == j[3] && p[4] == j[4];
                    if !vertical {
                        for q in [p, *j] {
                            let (tip, ax) = fadal_tip([q[0], q[1], q[2]], q[3], q[4], true);
                            let h = |x: [f64; 3]| x[0] * ax[0] + x[1] * ax[1] + x[2] * ax[2];
                            let top = tips.iter().map(|(t, _)| h(*t)).fold(f64::MIN, f64::max);
                            assert!(
                                h(tip) >= top + 0.2 - 1e-4,
                                "{index}: a rapid at {q:?} is {:.4} above the work's top (margin 0.2)\n{text}",
                                h(tip) - top
                            );
                            assert!(q[2] >= 10.0 - 1e-4, "{index}: below clearance_z");
                        }
                    }
                }
            }
            prev = Some(*j);
        }
        let v = lampost_stdin(
            &[
                "verify",
                "--machine",
                "fadal-lamp",
                "--index",
                index,
                "--origin",
                origin,
                &fx("issue11-patch.nc"),
                "-",
            ],
            text.as_bytes(),
        );
        assert!(v.status.success(), "{index}: {}", stderr(&v));
    }
}

/// The work within the Z travel but its safe height not: refused, naming the section,
/// nothing written.
#[test]
fn safe_height_beyond_travel_is_refused() {
    let dir = tempdir("safety-refuse");
    let out = dir.join("out.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=-20",
        "--origin",
        "0,0,1.8",
        &fx("issue11-patch.nc"),
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("issue11-patch.nc:") && e.contains("Z travel"),
        "{e}"
    );
    assert!(!out.exists());
}

/// Issue 11, case 2: G53 and G28/G30 Z-only moves become retracts to the safe height
/// (with a note); any other machine-coordinate move is refused with its line, and so is
/// a feed that leaves the height such a retract left (one across at it is travel:
/// `findings_cli::positioning_feeds_at_a_retract_s_height_are_travel`).
#[test]
fn machine_coordinate_moves() {
    let dir = tempdir("safety-g53");
    let ok = write(
        &dir,
        "g53.nc",
        "G20 G90\nG0 X0 Y0 Z0.2\nG1 Z0 F20.\nG1 X1.\nG0 G53 Z-10.\nG0 X0 Y1\nG0 Z0.1\nG1 Z0\nG1 X1\nG28 G91 Z0.\nG30 G91 Z0.\nM30\n",
    );
    let o = lampost(&["post", "--machine", "fadal-lamp", "--index", "A=0,B=0", &ok]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("g53.nc:5:") && e.contains("g53.nc:10:") && e.contains("g53.nc:11:"),
        "{e}"
    );
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        !text.contains("Z-10.0000") && !text.contains("Z0.0000\n"),
        "{text}"
    );
    for (name, body, line) in [
        (
            "g53xy.nc",
            "G20 G90\nG0 X0 Y0 Z0.2\nG1 Z0 F20.\nG53 G0 X-5. Z-1.\nM30\n",
            4,
        ),
        (
            "g28xy.nc",
            "G20 G90\nG0 X0 Y0 Z0.2\nG1 Z0 F20.\nG28 G91 X0. Y0.\nM30\n",
            4,
        ),
        (
            "g28all.nc",
            "G20 G90\nG0 X1 Y0 Z0.2\nG1 Z0 F20.\nG28\nM30\n",
            4,
        ),
        (
            "g53feed.nc",
            "G20 G90\nG0 X0 Y0 Z0.2\nG1 Z0 F20.\nG53 G0 Z0\nG1 X1. Z-0.1 F10\nM30\n",
            5,
        ),
    ] {
        let p = write(&dir, name, body);
        let out = dir.join(format!("{name}.out"));
        let o = lampost(&[
            "post",
            "--machine",
            "fadal-lamp",
            "--index",
            "A=0,B=0",
            &p,
            "-o",
            &out.to_string_lossy(),
        ]);
        assert!(!o.status.success(), "{name}");
        let e = stderr(&o);
        assert!(e.contains(&format!("{name}:{line}:")), "{name}: {e}");
        if name == "g28all.nc" {
            // A slicer's start code homes this way: the message says what to remove.
            assert!(e.contains("remove its homing"), "{name}: {e}");
        }
        if name == "g28xy.nc" {
            // A mill program's park: named as one, with what to do.
            assert!(
                e.contains("parks the table") && e.contains("remove the line"),
                "{name}: {e}"
            );
        }
        assert!(!out.exists(), "{name}");
    }
}

fn post_patch(dir: &Path, index: &str) -> String {
    let out = dir.join("patch.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--index",
        index,
        &fx("issue11-patch.nc"),
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::read_to_string(&out).expect("posted")
}

fn verify(dir: &Path, index: &str, posted: &str, extra: &[&str]) -> std::process::Output {
    let p = write(dir, "check.nc", posted);
    let input = fx("issue11-patch.nc");
    let mut args = vec![
        "verify",
        "--machine",
        "fadal-lamp",
        "--index",
        index,
        input.as_str(),
        p.as_str(),
    ];
    args.extend_from_slice(extra);
    lampost(&args)
}

/// Issue 11, case 3: verify rejects a wrong index, added travel, a rapid through the
/// work, truncation and non-finite tolerances; it passes the program as posted.
#[test]
fn verify_rejects_wrong_programs() {
    let dir = tempdir("safety-verify");
    let posted = post_patch(&dir, "A=0,B=-30");
    let good = verify(&dir, "A=0,B=-30", &posted, &[]);
    assert!(good.status.success(), "{}", stderr(&good));
    let wrong = verify(&dir, "A=45,B=30", &posted, &[]);
    assert!(!wrong.status.success());
    assert!(
        stderr(&wrong).contains("tool axis") || stderr(&wrong).contains("from the intended path"),
        "{}",
        stderr(&wrong)
    );
    // An added rapid far beyond X travel, before the program end.
    let added = posted.replace("M30\n", "G0 X900.\nM30\n");
    let o = verify(&dir, "A=0,B=-30", &added, &[]);
    assert!(
        !o.status.success() && stderr(&o).contains("beyond its travel"),
        "{}",
        stderr(&o)
    );
    // A rapid down through the work just after the laser turns off.
    let lines: Vec<&str> = posted.lines().collect();
    let k = lines.iter().position(|l| *l == "M72").expect("laser off");
    let mut through = lines.clone();
    through.insert(k + 1, "G0 X13.0 Y0.5 Z5.0");
    let o = verify(&dir, "A=0,B=-30", &(through.join("\n") + "\n"), &[]);
    assert!(
        !o.status.success() && stderr(&o).contains("below the safe height"),
        "{}",
        stderr(&o)
    );
    // Truncated: the last lines gone (lift, program end).
    let cut = lines[..lines.len() - 4].join("\n") + "\n";
    let o = verify(&dir, "A=0,B=-30", &cut, &[]);
    assert!(!o.status.success(), "truncated program passed");
    // Truncated inside the body.
    let cut = lines[..lines.len() / 2].join("\n") + "\n";
    let o = verify(&dir, "A=0,B=-30", &cut, &[]);
    assert!(!o.status.success(), "truncated program passed");
    for t in ["inf", "nan", "0", "-1"] {
        let o = verify(&dir, "A=0,B=-30", &posted, &["--tolerance", t]);
        assert!(!o.status.success(), "--tolerance {t} accepted");
    }
}

/// The post's report and verify count the same moves.
#[test]
fn move_counts_agree() {
    let dir = tempdir("safety-count");
    let out = dir.join("p.nc");
    let rep = dir.join("r.json");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--job",
        &fx("bearing-seat/job.toml"),
        "-o",
        &out.to_string_lossy(),
        "--json-report",
        &rep.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&rep).expect("report")).expect("json");
    let v = lampost(&[
        "verify",
        "--machine",
        "fadal-lamp",
        "--job",
        &fx("bearing-seat/job.toml"),
        &out.to_string_lossy(),
        "--json",
    ]);
    assert!(v.status.success(), "{}", stderr(&v));
    let vj: serde_json::Value = serde_json::from_slice(&v.stdout).expect("json");
    assert_eq!(r["moves"], vj["moves"]);
}

/// Issue 11, case 4: a line break in the input file's name cannot write a block into
/// the header comment.
#[test]
fn file_names_stay_inside_the_header_comment() {
    let dir = tempdir("safety-name");
    let p = write(
        &dir,
        "a\nG0 X900 (.nc",
        "G20 G90\nG0 X0 Y0 Z0.1\nG1 Z0 F20.\nG1 X1.\nM30\n",
    );
    let o = lampost(&["post", "--machine", "fadal-lamp", "--index", "A=0,B=0", &p]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    for l in text.lines() {
        assert_eq!(
            l.matches('(').count(),
            l.matches(')').count(),
            "a broken comment line: {l:?}\n{text}"
        );
        assert!(!l.starts_with("G0 X900"), "{text}");
    }
    assert!(!moves(&text).iter().any(|(_, j)| j[0] > 100.0), "{text}");
}

/// The per-point post retracts over its own tips too (not to a fixed clearance): on
/// the NRC cell with the part raised 140 mm, the first retract is above every feed.
#[test]
fn per_point_retract_clears_the_path() {
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--origin",
        "0,0,140",
        &fx("tilted-arc.csv"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let t = lampost_stdin(&["trace", "-", "--json", "--units", "mm"], text.as_bytes());
    assert!(t.status.success(), "{}", stderr(&t));
    let doc: serde_json::Value = serde_json::from_slice(&t.stdout).expect("json");
    let mv = doc["moves"].as_array().expect("moves");
    let z = |m: &serde_json::Value| m["end"]["Z"].as_f64().unwrap_or(f64::NAN);
    let top = mv
        .iter()
        .filter(|m| m["g"] != "G0")
        .map(z)
        .fold(f64::MIN, f64::max);
    let first = mv.iter().find(|m| m["g"] == "G0").map(z);
    assert!(
        first.is_some_and(|f| f >= top + 5.0 - 1e-3),
        "{first:?} vs {top}\n{text}"
    );
}

/// Issue 11, case 7: valid input once refused as "a lampost fault" now posts and
/// verifies: a multi-turn helix (`G2 … P2`) flat and tilted, and a tool axis turning
/// about a standing tip (per-point path: rotaries move, linear axes compensate, G93).
#[test]
fn multi_turn_helix_and_pivot_post_and_verify() {
    let dir = tempdir("safety-case7");
    let helix = write(
        &dir,
        "helix.nc",
        "G20 G90\nG0 X0 Y0 Z0.1\nG1 Z0 F20.\nG2 X0 Y0 I0.5 J0 Z0.2 P2\nM30\n",
    );
    for index in ["A=0,B=0", "A=0,B=-30"] {
        let out = dir.join("helix.out");
        let o = lampost(&[
            "post",
            "--machine",
            "fadal-lamp",
            "--index",
            index,
            &helix,
            "-o",
            &out.to_string_lossy(),
        ]);
        assert!(o.status.success(), "{index}: {}", stderr(&o));
        let v = lampost(&[
            "verify",
            "--machine",
            "fadal-lamp",
            "--index",
            index,
            &helix,
            &out.to_string_lossy(),
        ]);
        assert!(v.status.success(), "{index}: {}", stderr(&v));
    }
    let pivot = write(
        &dir,
        "pivot.csv",
        "x y z i j k feed laser\n0 0 0 0 0 1 10 0\n0 0 0 0.5 0 0.866 10 1\n0 0 0 0 0.5 0.866 10 1\n1 0 0 0 0 1 10 1\n",
    );
    let out = dir.join("pivot.out");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--head",
        "spindle",
        &pivot,
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).expect("posted");
    assert!(text.contains("G93"), "{text}");
    let v = lampost(&[
        "verify",
        "--machine",
        "fadal-lamp",
        "--head",
        "spindle",
        &pivot,
        &out.to_string_lossy(),
    ]);
    assert!(v.status.success(), "{}", stderr(&v));
}

/// Issue 11, case 6: the per-point post goes through the same writer: machining options,
/// --max-bytes, and refusals of a work offset that is not one.
#[test]
fn per_point_honours_every_option() {
    let dir = tempdir("safety-perpoint-opts");
    let out = dir.join("pp.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--head",
        "spindle",
        "--process",
        "machine",
        "--tool",
        "3",
        "--coolant",
        "--work-offset",
        "G55",
        "--length-offset",
        "3",
        "--origin",
        "0,0,0.5",
        &fx("tilted-arc.csv"),
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).expect("posted");
    for want in ["T3 M6", "G55", "G43 H3", "M8", "M9"] {
        assert!(text.contains(want), "{want} missing:\n{text}");
    }
    // Split into DNC pieces (ISO) under a small size.
    let out = dir.join("split.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--head",
        "spindle",
        "--origin",
        "0,0,0.5",
        "--dialect",
        "iso",
        &fx("tilted-arc.csv"),
        "-o",
        &out.to_string_lossy(),
        "--max-bytes",
        "9500",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("split.001.nc").exists() && dir.join("split.002.nc").exists());
    for bad in ["G0 X900", "G54 X1", "E49", "T1"] {
        let out = dir.join("bad.nc");
        let o = lampost(&[
            "post",
            "--machine",
            "fadal-lamp",
            "--head",
            "spindle",
            "--process",
            "machine",
            "--work-offset",
            bad,
            "--origin",
            "0,0,0.5",
            &fx("tilted-arc.csv"),
            "-o",
            &out.to_string_lossy(),
        ]);
        assert!(!o.status.success(), "--work-offset {bad} accepted");
        assert!(stderr(&o).contains("--work-offset"), "{}", stderr(&o));
        assert!(!out.exists());
    }
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        &fx("tilted-arc.csv"),
        "-o",
        &dir.join("x.nc").to_string_lossy(),
        "--max-bytes",
        "100",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("the minimum is 256"),
        "{}",
        stderr(&o)
    );
}

/// Real CAM programs from `../shared/corpus` (see its SOURCES.md), posted for the FADAL
/// spindle at two indexes, each with its expected verdict: posted and verified, or
/// refused at the named line (Cereal.ngc parks in machine X/Y with `G53` at its end;
/// LHchips4.ngc feeds at F9991300 mm/min, 393,358 in/min for the FADAL, beyond its
/// largest F word, 99999).
#[test]
fn real_programs_post_and_verify_or_are_refused_where_expected() {
    let Some(shared) = shared() else {
        eprintln!("../shared not found: real-program test skipped");
        return;
    };
    let dir = tempdir("safety-corpus");
    let cases: [(&str, Option<&str>); 3] = [
        ("cam/fusion360-generic-mm-bore-tests.nc", None),
        // Its ball nose cuts turning counter-clockwise (`S6000 M4`), and the FADAL's
        // spindle_on is M3 (its F9991300 is out of FADAL's range too, further on).
        (
            "linuxcnc/LHchips4.ngc",
            Some("LHchips4.ngc:28: a cut with the spindle turning counter-clockwise (M4)"),
        ),
        ("linuxcnc/Cereal.ngc", Some("Cereal.ngc:2270: G53")),
    ];
    for (rel, refusal) in cases {
        let f = shared
            .join("corpus")
            .join(rel)
            .to_string_lossy()
            .into_owned();
        for index in ["A=0,B=0", "A=30,B=-20"] {
            let out = dir.join("out.nc");
            let _ = std::fs::remove_file(&out);
            let args = [
                "--machine",
                "fadal-lamp",
                "--index",
                index,
                "--convert-units",
                "--process",
                "machine",
                "--head",
                "spindle",
            ];
            let mut post = vec!["post"];
            post.extend_from_slice(&args);
            let o_s = out.to_string_lossy().into_owned();
            post.extend_from_slice(&[f.as_str(), "-o", o_s.as_str()]);
            let o = lampost(&post);
            match refusal {
                Some(what) => {
                    assert!(!o.status.success(), "{rel} {index} posted");
                    assert!(stderr(&o).contains(what), "{rel}: {}", stderr(&o));
                    assert!(!out.exists());
                }
                None => {
                    assert!(o.status.success(), "{rel} {index}: {}", stderr(&o));
                    let mut verify = vec!["verify"];
                    verify.extend_from_slice(&args);
                    verify.extend_from_slice(&[f.as_str(), o_s.as_str()]);
                    let v = lampost(&verify);
                    assert!(v.status.success(), "{rel} {index}: {}", stderr(&v));
                }
            }
        }
    }
    // LHchips4 turning clockwise: refused further on, at its feed out of FADAL's range.
    let chips = std::fs::read_to_string(shared.join("corpus/linuxcnc/LHchips4.ngc"))
        .expect("LHchips4")
        .replace("S6000 M4", "S6000 M3");
    let input = write(&dir, "LHchips4-m3.ngc", &chips);
    let out = dir.join("out.nc").to_string_lossy().into_owned();
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--convert-units",
        "--process",
        "machine",
        "--head",
        "spindle",
        &input,
        "-o",
        &out,
    ]);
    assert!(
        stderr(&o).contains(
            "LHchips4-m3.ngc:28: refused to write F393358.2677165354: out of range for FADAL"
        ),
        "{}",
        stderr(&o)
    );
}

/// `--stock` (a box in the part frame) raises the retracts over it, and verify, given the
/// same stock, rejects the program posted without it.
#[test]
fn stock_box_raises_the_retracts() {
    let dir = tempdir("safety-stock");
    let with = dir.join("with.nc");
    let without = dir.join("without.nc");
    let input = fx("issue11-patch.nc");
    for (out, extra) in [(&with, Some("-1,-1,-1,2,2,11")), (&without, None)] {
        let o_s = out.to_string_lossy().into_owned();
        let mut args = vec![
            "post",
            "--machine",
            "fadal-lamp",
            "--index",
            "A=0,B=0",
            "--head",
            "spindle",
            input.as_str(),
            "-o",
            o_s.as_str(),
        ];
        if let Some(s) = extra {
            args.extend_from_slice(&["--stock", s]);
        }
        let o = lampost(&args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let text = std::fs::read_to_string(&with).expect("posted");
    let first_z = moves(&text)
        .iter()
        .find(|(g, _)| g == "G0")
        .map(|(_, j)| j[2])
        .unwrap_or(f64::NAN);
    // FADAL spindle at A = B = 0: the tip is at the joints; the stock's top is Z 11.
    assert!(first_z >= 11.0 + 0.2 - 1e-4, "{first_z}\n{text}");
    let v = |posted: &std::path::Path, stock: bool| {
        let p_s = posted.to_string_lossy().into_owned();
        let mut args = vec![
            "verify",
            "--machine",
            "fadal-lamp",
            "--index",
            "A=0,B=0",
            "--head",
            "spindle",
            input.as_str(),
            p_s.as_str(),
        ];
        if stock {
            args.extend_from_slice(&["--stock", "-1,-1,-1,2,2,12"]);
        }
        lampost(&args)
    };
    assert!(v(&with, false).status.success());
    // A stock up to Z 12 cannot be cleared at the clearance height 10: verify says so.
    let o = v(&without, true);
    assert!(
        !o.status.success() && stderr(&o).contains("safe height"),
        "{}",
        stderr(&o)
    );
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        "--head",
        "spindle",
        input.as_str(),
        "--stock",
        "0,0,0,1,1",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("--stock"),
        "{}",
        stderr(&o)
    );
}

/// An ASCII STL box from `lo` to `hi`; without its top face when `open`.
fn box_stl(lo: [f64; 3], hi: [f64; 3], open: bool) -> String {
    let c = |i: usize| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    // Faces as corner quads, outward by the right-hand rule.
    let mut faces = vec![
        [0, 2, 3, 1], // bottom (z = lo)
        [0, 1, 5, 4], // y = lo
        [2, 6, 7, 3], // y = hi
        [0, 4, 6, 2], // x = lo
        [1, 3, 7, 5], // x = hi
    ];
    if !open {
        faces.push([4, 5, 7, 6]); // top
    }
    let mut s = String::from("solid box\n");
    for f in faces {
        for t in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            s += "facet normal 0 0 0\nouter loop\n";
            for v in t {
                let p = c(v);
                s += &format!("vertex {} {} {}\n", p[0], p[1], p[2]);
            }
            s += "endloop\nendfacet\n";
        }
    }
    s + "endsolid box\n"
}

/// `--part`: the part's hull raises the safe heights; a vertical approach through an
/// overhang of the part is refused by the post and by verify; an open mesh is warned
/// about and still checked; a mesh in other units, and `--part` with a per-point path,
/// are refused with what to do.
#[test]
fn part_mesh_collisions() {
    let dir = tempdir("safety-part");
    let input = fx("issue11-patch.nc");
    let base = write(
        &dir,
        "base.stl",
        &box_stl([-1.0, -1.0, -2.0], [2.0, 2.0, 0.0], false),
    );
    let post = |part: &str, out: &Path, extra: &[&str]| {
        let o_s = out.to_string_lossy().into_owned();
        let mut args = vec![
            "post",
            "--machine",
            "fadal-lamp",
            "--index",
            "A=0,B=0",
            "--head",
            "spindle",
            input.as_str(),
            "-o",
            o_s.as_str(),
            "--part",
            part,
        ];
        args.extend_from_slice(extra);
        lampost(&args)
    };
    let verify = |part: &str, out: &Path| {
        let o_s = out.to_string_lossy().into_owned();
        lampost(&[
            "verify",
            "--machine",
            "fadal-lamp",
            "--index",
            "A=0,B=0",
            "--head",
            "spindle",
            input.as_str(),
            o_s.as_str(),
            "--part",
            part,
        ])
    };
    // The patch deposited on top of a block: posts, verifies.
    let out = dir.join("on-block.nc");
    let o = post(&base, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = verify(&base, &out);
    assert!(v.status.success(), "{}", stderr(&v));
    // An overhang above the patch's start: the vertical approach would pass through it.
    let over = write(
        &dir,
        "overhang.stl",
        &box_stl([-0.5, -0.5, 1.0], [0.5, 0.5, 1.5], false),
    );
    let out2 = dir.join("overhang.nc");
    let o = post(&over, &out2, &[]);
    assert!(!o.status.success(), "posted through an overhang");
    assert!(
        stderr(&o).contains("meets the part") || stderr(&o).contains("against the part"),
        "{}",
        stderr(&o)
    );
    assert!(!out2.exists());
    // The program posted without the part fails verify with it.
    let plain = dir.join("plain.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        "--head",
        "spindle",
        input.as_str(),
        "-o",
        &plain.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = verify(&over, &plain);
    assert!(
        !v.status.success(),
        "verify passed a rapid through the part"
    );
    // An open mesh: a warning, still checked.
    let open = write(
        &dir,
        "open.stl",
        &box_stl([-0.5, -0.5, 1.0], [0.5, 0.5, 1.5], true),
    );
    let o = post(&open, &dir.join("open.nc"), &[]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("not a closed manifold"),
        "{}",
        stderr(&o)
    );
    // A block given in mm to the inch FADAL without --part-units: refused; with it, posts.
    let mm = write(
        &dir,
        "mm.stl",
        &box_stl([-25.4, -25.4, -500.0], [1000.0, 1000.0, 0.0], false),
    );
    let o = post(&mm, &dir.join("mm.nc"), &[]);
    assert!(
        !o.status.success() && stderr(&o).contains("--part-units"),
        "{}",
        stderr(&o)
    );
    let o = post(&mm, &dir.join("mm.nc"), &["--part-units", "mm"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A per-point path with --part.
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        &fx("tilted-arc.csv"),
        "--part",
        &base,
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("--part"),
        "{}",
        stderr(&o)
    );
}

/// The machine file's resolution is honoured: on a FADAL whose linear axes step 0.001 in
/// and rotaries 0.01°, every word written lies on those grids, and the program verifies.
#[test]
fn machine_resolution_is_honoured() {
    let dir = tempdir("safety-resolution");
    let o = lampost(&["machines", "show", "fadal-lamp"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let mut parts: Vec<String> = text.split("[[rotary]]").map(str::to_string).collect();
    parts[0] = parts[0].replace("resolution = 0.0001", "resolution = 0.001");
    for p in parts.iter_mut().skip(1) {
        *p = p.replacen("resolution = 0.001", "resolution = 0.01", 1);
    }
    let coarse = write(&dir, "coarse.toml", &parts.join("[[rotary]]"));
    let out = dir.join("coarse.nc");
    let input = fx("issue11-patch.nc");
    let args = [
        "--machine",
        coarse.as_str(),
        "--index",
        "A=10.123,B=-20.127",
        "--head",
        "spindle",
    ];
    let mut post = vec!["post"];
    post.extend_from_slice(&args);
    let o_s = out.to_string_lossy().into_owned();
    post.extend_from_slice(&[input.as_str(), "-o", o_s.as_str()]);
    let o = lampost(&post);
    assert!(o.status.success(), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    let on = |v: f64, step: f64| ((v / step).round() * step - v).abs() < 1e-9;
    for (_, j) in moves(&posted) {
        for k in 0..3 {
            assert!(on(j[k], 0.001), "{j:?} off the 0.001 grid\n{posted}");
        }
        for k in 3..5 {
            assert!(on(j[k], 0.01), "{j:?} off the 0.01° grid\n{posted}");
        }
    }
    let mut verify = vec!["verify"];
    verify.extend_from_slice(&args);
    verify.extend_from_slice(&[input.as_str(), o_s.as_str()]);
    let v = lampost(&verify);
    assert!(v.status.success(), "{}", stderr(&v));
}

/// Audit of verify's independence (2026-11-24): edits of a posted program that change
/// where the control puts the head while every feed point verify used to compare still
/// lies on the path. Each passed verify before; each must fail now, and the program as
/// posted still passes.
#[test]
fn verify_rejects_deviations_the_moves_alone_hide() {
    let dir = tempdir("safety-hidden");
    let posted = post_patch(&dir, "A=0,B=0");
    let good = verify(&dir, "A=0,B=0", &posted, &[]);
    assert!(good.status.success(), "{}", stderr(&good));
    let lines: Vec<String> = posted.lines().map(str::to_string).collect();
    let at = |want: &str| {
        lines
            .iter()
            .position(|l| l == want)
            .unwrap_or_else(|| panic!("no line {want}"))
    };
    // `f` edits the lines; the result must fail with `why` in the message.
    let check = |name: &str, f: &dyn Fn(&mut Vec<String>), why: &str| {
        let mut t = lines.clone();
        f(&mut t);
        let o = verify(&dir, "A=0,B=0", &(t.join("\n") + "\n"), &[]);
        assert!(
            !o.status.success() && stderr(&o).contains(why),
            "{name}: {}",
            stderr(&o)
        );
    };
    let after =
        |k: usize, text: &'static str| move |t: &mut Vec<String>| t.insert(k + 1, text.into());
    let header = at("G70 G90 G94 G17 G40 G80");
    let on = at("M73");
    let off = at("M74");
    // A is continuous about the tool axis at B = 0: two turns during a feed end where
    // they began, and the feed's middle and end are on the path; between, the table
    // sweeps the work under the head.
    check(
        "A720 on a feed",
        &|t| t[on + 2] = format!("{} A720.", t[on + 2]),
        "a feed turns the table",
    );
    // A rapid straight down into the work and back up: both vertical.
    check("plunge and back", &after(off, "G0 Z5."), "goes back up");
    // The approach comes down half an inch beside the start; the feed-in crosses over.
    let feed_in = lines
        .iter()
        .position(|l| l.starts_with("G1 Z"))
        .expect("feed-in");
    check(
        "approach beside the start",
        &|t| {
            let x: f64 = t[feed_in - 2][1..8].parse().expect("traverse X");
            t[feed_in - 2] =
                t[feed_in - 2].replacen(&t[feed_in - 2][..8], &format!("X{:.4}", x + 0.5), 1);
            t[feed_in] = t[feed_in].replacen("G1 ", &format!("G1 X{x:.4} "), 1);
        },
        "not straight down onto the start",
    );
    // Codes that move the frame: the reader starts from zero, so a G92 at the top
    // changes nothing it sees; the control makes wherever it stands the origin.
    check("G92 at the top", &after(header, "G92 X0 Y0 Z0"), "G92");
    check("G52", &after(header, "G52 X1."), "G52");
    check(
        "G10 L2 and G54",
        &|t| {
            t.insert(header + 1, "G54".into());
            t.insert(header + 1, "G10 L2 P1 X1.".into());
        },
        "G10",
    );
    check("G44", &after(header, "G44 H1"), "G44");
    // Codes the reader warns it does not simulate: the control would run them.
    check("G68 rotation", &after(on, "G68 X0 Y0 R90."), "G68");
    check("G51 scaling", &after(on, "G51 X0 Y0 Z0 P2."), "G51");
    check("G16 polar", &after(header, "G16"), "G16");
    check("G41 compensation", &after(on, "G41 D1"), "G41");
    // State the moves carry: tool length and work offsets, machine coordinates.
    check(
        "G43 H5 mid-program",
        &after(on, "G43 H5"),
        "a move with tool length offset H5, and the program was posted with none",
    );
    check(
        "E2 mid-program",
        &after(on, "E2"),
        "a move in work offset E2, and the program was posted with none",
    );
    check(
        "G53 plunge",
        &after(at("M72"), "G53 G0 Z-5."),
        "machine coordinates",
    );
    // The laser left on over the lift (its M72 moved after it): deposits along travel.
    check(
        "laser off after the lift",
        &|t| {
            let k = t.iter().position(|l| l == "M72").expect("M72");
            let m72 = t.remove(k);
            let lift = t[k..]
                .iter()
                .position(|l| l.starts_with("G0 Z"))
                .expect("lift");
            t.insert(k + lift + 1, m72);
        },
        "a rapid with the laser on",
    );
    // A FADAL `L` call (subroutine 1, twice), which lampost's reader does not follow.
    check("FADAL L call", &after(on, "L0102"), "L0102");
    // Back along a straight feed and on (X10.1031 to X11.1031): every point and middle
    // on the path, the stretch between deposited three times.
    assert_eq!(lines[on + 2], "X11.1031");
    check(
        "back along a feed",
        &|t| {
            t[on + 2] = "X10.8531".into();
            t.insert(on + 3, "X10.6031".into());
            t.insert(on + 4, "X11.1031".into());
        },
        "goes back along the intended move",
    );
    // The head standing still with the laser on: a dwell, a program stop.
    check("G4 dwell", &after(on + 2, "G4 P2."), "a dwell (G4)");
    check(
        "M0 with the laser on",
        &after(on + 2, "M0"),
        "a program stop",
    );
    check(
        "M1 with the laser on",
        &after(on + 2, "M01"),
        "a program stop",
    );
    // A stop with the laser off (after M74, the last), where the input makes none: the program
    // stops where its author did not ask it to (the input's own stops are posted and
    // held to theirs: `a_program_stop_in_the_input_is_posted_where_it_stands`).
    let mut stopped = lines.clone();
    stopped.insert(off + 1, "M1".into());
    let o = verify(&dir, "A=0,B=0", &(stopped.join("\n") + "\n"), &[]);
    assert!(!o.status.success(), "M1 with the laser off passed");
    assert!(
        stderr(&o).contains("a program stop (M1) after the intended path has ended"),
        "{}",
        stderr(&o)
    );
    // The program's end and block delete.
    check(
        "M99 for M30",
        &|t| {
            let k = t.iter().position(|l| l == "M30").expect("M30");
            t[k] = "M99".into();
        },
        "ends with M99",
    );
    check(
        "block delete",
        &|t| t[on + 2] = format!("/{}", t[on + 2]),
        "block-delete",
    );
    // A kept full circle: run twice (P2), or the other way round.
    let input = write(
        &dir,
        "circle.nc",
        "G20 G90 G17\nG0 X0.5 Y0 Z0.1\nG1 Z0 F10.\nG2 X0.5 Y0 I-0.5 J0\nG0 Z0.2\nM30\n",
    );
    let out = dir.join("circle.out");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        &input,
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let circle = std::fs::read_to_string(&out).expect("posted");
    assert!(circle.lines().any(|l| l.starts_with("G2 ")), "{circle}");
    for (name, bad, why) in [
        (
            "P2",
            circle.replace("J0.0000\n", "J0.0000 P2\n"),
            "more than one turn",
        ),
        (
            "G3 for G2",
            circle.replace("\nG2 ", "\nG3 "),
            "other way round",
        ),
    ] {
        let p = write(&dir, "circle-bad.nc", &bad);
        let o = lampost(&[
            "verify",
            "--machine",
            "fadal-lamp",
            "--index",
            "A=0,B=0",
            &input,
            &p,
        ]);
        assert!(
            !o.status.success() && stderr(&o).contains(why),
            "{name}: {}",
            stderr(&o)
        );
    }
    let o = lampost(&[
        "verify",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        &input,
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// The post refuses a program whose frame moves after its first move (G92, G52, G10
/// on the work offset in force, another work offset): LinuxCNC's rs274 reports the later
/// moves in the moved frame (its SET_G92_OFFSET / SET_G5X_OFFSET lines), so the same
/// numbers land elsewhere on the machine, and posting them where the first frame puts
/// them deposits over what was deposited (the post used to do that). The refusal is
/// located at the line that moves the frame, and names the first move made in the moved
/// frame. A G92 before the first move places the frame and is accepted. Nothing is
/// written on refusal.
#[test]
fn a_frame_moved_after_the_first_move_is_refused() {
    let dir = tempdir("safety-frame");
    let out = dir.join("out.nc");
    for (name, body, line, first) in [
        ("G92", "G92 X0", 5, 6),
        ("G52", "G52 X5", 5, 6),
        ("G10 L20", "G10 L20 P1 X0", 5, 6),
        ("G10 L2, G55", "G10 L2 P2 X5\nG55", 6, 7),
        ("G55", "G55", 5, 6),
    ] {
        let input = write(
            &dir,
            "frame.ngc",
            &format!(
                "G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z0 F100\nG1 X10 Y0\n{body}\nG1 X20\nG0 Z5\nM2\n"
            ),
        );
        let o = lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            "--index",
            "B=0,C=0",
            &input,
            "-o",
            &out.to_string_lossy(),
        ]);
        assert!(!o.status.success(), "{name}: posted");
        assert!(
            stderr(&o).contains(&format!("frame.ngc:{line}:"))
                && stderr(&o).contains(&format!("(the first at line {first})")),
            "{name}: {}",
            stderr(&o)
        );
        assert!(!out.exists(), "{name}: written");
    }
    // Before the first move: the frame the program is placed by.
    let input = write(
        &dir,
        "top.ngc",
        "G21 G90 G17\nG92 X5 Y0 Z0\nG0 X0 Y0 Z5\nG1 Z0 F100\nG1 X10 Y0\nG0 Z5\nM2\n",
    );
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        &input,
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A per-point program whose continuous C is turned a whole turn (or two) more at one
/// point: its end poses are those intended, but between them the table spins under the
/// head. verify compared only each move's end, and passed it; now the points between
/// (every 45° of rotary turn, in a move that turns more than that) must be on the path
/// too.
#[test]
fn per_point_verify_follows_the_table_between_points() {
    let dir = tempdir("safety-spin");
    let out = dir.join("p.nc");
    let csv = fx("tilted-arc.csv");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        &csv,
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    let lines: Vec<&str> = posted.lines().collect();
    // A G93 feed in the middle of the run, its C word.
    let k = lines
        .iter()
        .position(|l| l.contains(" C-11.250 "))
        .expect("a point at C-11.25");
    for spin in [360.0, 720.0, -360.0] {
        let mut t: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        t[k] = t[k].replace(" C-11.250 ", &format!(" C{:.3} ", -11.25 + spin));
        let p = write(&dir, "spun.nc", &(t.join("\n") + "\n"));
        let o = lampost(&["verify", "--machine", "nrc-lc", &csv, &p]);
        assert!(
            !o.status.success() && stderr(&o).contains("of the way along the move"),
            "C turned {spin} more: {}",
            stderr(&o)
        );
    }
    let o = lampost(&[
        "verify",
        "--machine",
        "nrc-lc",
        &csv,
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A per-point path of two points 40° apart on a circle of 20 mm about C, the axis
/// leaning 30° outward, posted for nrc-lc and verified: (the directory, the input, the
/// posted text).
fn chord_posted(name: &str) -> (std::path::PathBuf, String, String) {
    let dir = tempdir(name);
    let (s, c) = 30f64.to_radians().sin_cos();
    let mut csv = String::from("x y z i j k feed laser\n");
    for a in [0.0f64, 40.0] {
        let (sa, ca) = a.to_radians().sin_cos();
        csv += &format!(
            "{:.6} {:.6} 0 {:.6} {:.6} {c:.6} 600 1\n",
            20.0 * ca,
            20.0 * sa,
            s * ca,
            s * sa
        );
    }
    let input = write(&dir, "chord.csv", &csv);
    let out = dir.join("chord.nc");
    let out = out.to_string_lossy();
    let o = lampost(&["post", "--machine", "nrc-lc", &input, "-o", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    let ok = lampost(&["verify", "--machine", "nrc-lc", &input, &out]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    let posted = std::fs::read_to_string(&*out).expect("posted");
    (dir, input, posted)
}

/// One segment of a per-point path whose straight joint move is off the path (the table
/// turns C by 40° under a tip 20 mm from its axis: the joints' straight line is an arc,
/// 1.2 mm from the chord at its middle): the post splits it into 15 pieces. With all but
/// the last piece deleted, the one feed left has both ends on the path, and verify,
/// comparing ends only, passed it; now the middle of every feed that turns a rotary is
/// on the path too.
#[test]
fn a_feed_whose_middle_leaves_the_path_fails_verify() {
    let (dir, input, posted) = chord_posted("safety-middle");
    // The segment's feeds: every G93 line (the first names G93, the others follow it).
    let lines: Vec<&str> = posted.lines().collect();
    let feeds: Vec<usize> = (0..lines.len())
        .filter(|&i| {
            lines[i].contains("G93")
                || (i > 0 && lines[i].contains(" C") && lines[i].contains(" F"))
        })
        .collect();
    assert!(feeds.len() >= 4, "the segment is split: {posted}");
    let (first, last) = (feeds[0], feeds[feeds.len() - 1]);
    let mut kept: Vec<String> = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        if i == last {
            // The last piece, now the segment's only feed, in inverse time.
            let (n, rest) = l.split_once(' ').expect("a numbered line");
            kept.push(format!("{n} G93 {rest}"));
        } else if !(first..last).contains(&i) {
            kept.push(l.to_string());
        }
    }
    let tampered = write(&dir, "one-feed.nc", &(kept.join("\n") + "\n"));
    let o = lampost(&["verify", "--machine", "nrc-lc", &input, &tampered]);
    assert!(
        !o.status.success() && stderr(&o).contains("50 % of the way along the move"),
        "one feed for the whole segment: {}",
        stderr(&o)
    );
}

/// The lines of a posted per-point program with every rotary feed's F (inverse time)
/// multiplied by `k`.
fn inverse_time_scaled(posted: &str, k: f64) -> Vec<String> {
    posted
        .lines()
        .map(|l| match l.rsplit_once(" F") {
            Some((head, f)) if l.contains(" C") => {
                let v: f64 = f.parse().expect("an F value");
                format!("{head} F{:.5}", v * k)
            }
            _ => l.to_string(),
        })
        .collect()
}

/// The same segment's pieces with their inverse-time feeds ten times what the post wrote:
/// every end and middle on the path, the tool ten times faster than the path's F600.
/// verify did not look at per-point feeds; now no move is faster than its point's feed.
#[test]
fn a_per_point_move_faster_than_its_feed_fails_verify() {
    let (dir, input, posted) = chord_posted("safety-fast");
    let fast = inverse_time_scaled(&posted, 10.0).join("\n") + "\n";
    assert_ne!(fast, posted);
    let tampered = write(&dir, "fast.nc", &fast);
    let o = lampost(&["verify", "--machine", "nrc-lc", &input, &tampered]);
    assert!(
        !o.status.success() && stderr(&o).contains("faster than the feed F600"),
        "ten times the feed: {}",
        stderr(&o)
    );
}

/// The same segment's pieces, every inverse-time feed halved (slower than asked, which
/// passes), then two pieces swapped: every end and middle on the path, no move too fast,
/// but the tool goes forward two pieces, back one, and on (the stretch between deposited
/// three times). verify took each move on its own; now the tool may not go back along
/// the path by more than the tolerance.
#[test]
fn a_per_point_move_back_along_the_path_fails_verify() {
    let (dir, input, posted) = chord_posted("safety-back");
    let slow = inverse_time_scaled(&posted, 0.5);
    let text = |t: &[String]| t.join("\n") + "\n";
    let o = lampost(&[
        "verify",
        "--machine",
        "nrc-lc",
        &input,
        &write(&dir, "slow.nc", &text(&slow)),
    ]);
    assert!(o.status.success(), "half the feed: {}", stderr(&o));
    // The second and third pieces (the first names G93), swapped.
    let g93 = slow.iter().position(|l| l.contains("G93")).expect("G93");
    let mut swapped = slow.clone();
    swapped.swap(g93 + 1, g93 + 2);
    let o = lampost(&[
        "verify",
        "--machine",
        "nrc-lc",
        &input,
        &write(&dir, "back.nc", &text(&swapped)),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("goes back along the path"),
        "two pieces swapped: {}",
        stderr(&o)
    );
}

/// The work offset and tool length offset place a program on the table: a program moved
/// onto another work offset runs elsewhere, whatever its moves say. `verify` holds the
/// posted text to the process options it was posted with (`--work-offset`,
/// `--length-offset`, `--tool`, `--spindle`, `--power`, as `post` takes them): a program
/// posted with G55 and H2 passes only when told so; one edited to G56, to select `G54` or
/// `E3` where none was posted, to apply `G43 H4`, to change tools or the spindle speed,
/// fails at that line; `G54.1 P3` (an extended offset) is read as one. The laser goes on
/// at the power posted, and stays at it. The per-point post checks its own output the
/// same way.
/// `lampost CMD` (`post` or `verify`) of issue 11's patch indexed `A=0,B=-20` on
/// `fadal-lamp` at origin 0,0,1, with the options `extra`, then `files`.
fn patch_tilted(cmd: &str, extra: &[&str], files: &[&str]) -> std::process::Output {
    let input = fx("issue11-patch.nc");
    let mut args = vec![
        cmd,
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=-20",
        "--origin",
        "0,0,1",
    ];
    args.extend_from_slice(extra);
    args.push(input.as_str());
    args.extend_from_slice(files);
    lampost(&args)
}

#[test]
fn verify_holds_the_program_to_the_process_it_was_posted_with() {
    let dir = tempdir("safety-offsets");
    let run = patch_tilted;
    let dep = |name: &str, extra: &[&str]| -> String {
        let out = dir.join(name).to_string_lossy().into_owned();
        let o = run("post", extra, &["-o", &out]);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read_to_string(&out).expect("posted")
    };
    let vdep = |text: &str, extra: &[&str]| -> std::process::Output {
        let p = write(&dir, "check.nc", text);
        run("verify", extra, &[&p])
    };
    let post = |name: &str, extra: &[&str]| {
        let mut a = vec!["--process", "machine"];
        a.extend_from_slice(extra);
        dep(name, &a)
    };
    let check = |text: &str, extra: &[&str]| {
        let mut a = vec!["--process", "machine"];
        a.extend_from_slice(extra);
        vdep(text, &a)
    };
    let fails_at = |o: &std::process::Output, what: &str| {
        let e = stderr(o);
        assert!(!o.status.success(), "passed, expected `{what}`");
        assert!(e.contains(what), "expected `{what}`:\n{e}");
    };
    let g55 = post("g55.nc", &["--work-offset", "G55", "--length-offset", "2"]);
    assert!(g55.contains("G55") && g55.contains("G43 H2"), "{g55}");
    let told = ["--work-offset", "G55", "--length-offset", "2"];
    let o = check(&g55, &told);
    assert!(o.status.success(), "{}", stderr(&o));
    let line = |text: &str, code: &str| {
        1 + text
            .lines()
            .position(|l| l.starts_with(code))
            .expect("the code")
    };
    fails_at(
        &check(&g55, &[]),
        &format!(
            "posted line {}: G55 selects a work offset, and the program was posted with none",
            line(&g55, "G55")
        ),
    );
    fails_at(
        &check(&g55, &["--work-offset", "G56", "--length-offset", "2"]),
        "a move in work offset G55, and the program was posted for G56",
    );
    fails_at(
        &check(&g55, &["--work-offset", "G55"]),
        "a move with tool length offset H2, and the program was posted with none",
    );
    fails_at(
        &check(&g55.replacen("G55", "G56", 1), &told),
        "a move in work offset G56, and the program was posted for G55",
    );
    fails_at(
        &check(&g55.replacen("G43 H2", "G43 H5", 1), &told),
        "a move with tool length offset H5, and the program was posted with H2",
    );
    // Posted with no offsets: selecting one, even G54, or applying a length offset fails.
    let none = post("none.nc", &[]);
    let o = check(&none, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let at = line(&none, "S3000");
    let with = |extra: &str| {
        let mut l: Vec<&str> = none.lines().collect();
        l.insert(at, extra);
        l.join("\n") + "\n"
    };
    fails_at(
        &check(&with("G54"), &[]),
        &format!("posted line {}: G54 selects a work offset", at + 1),
    );
    fails_at(&check(&with("E3"), &[]), "a move in work offset E3");
    fails_at(
        &check(&with("G43 H4"), &[]),
        "a move with tool length offset H4, and the program was posted with none",
    );
    // An extended work offset is one: P3 passes as P3, not as P4.
    let ext = post("ext.nc", &["--work-offset", "G54.1 P3"]);
    let o = check(&ext, &["--work-offset", "G54.1 P3"]);
    assert!(o.status.success(), "{}", stderr(&o));
    fails_at(
        &check(&ext, &["--work-offset", "G54.1 P4"]),
        "a move in work offset G54.1 P3, and the program was posted for G54.1 P4",
    );
    fails_at(
        &check(&ext, &["--work-offset", "G54.1 P0"]),
        "--work-offset `G54.1 P0`",
    );
    // The per-point post: posted with G55 and H3, verified with them, not without.
    let out = dir.join("pp.nc");
    let pp_args = |extra: &[&str]| -> Vec<String> {
        let mut a: Vec<String> = [
            "--machine",
            "fadal-lamp",
            "--head",
            "spindle",
            "--process",
            "machine",
            "--origin",
            "0,0,0.5",
        ]
        .map(String::from)
        .to_vec();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let mut a = vec!["post".to_string()];
    a.extend(pp_args(&["--work-offset", "G55", "--length-offset", "3"]));
    a.extend([
        fx("tilted-arc.csv"),
        "-o".into(),
        out.to_string_lossy().into(),
    ]);
    let o = lampost(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    for (extra, ok) in [
        (&["--work-offset", "G55", "--length-offset", "3"][..], true),
        (&[][..], false),
    ] {
        let mut a = vec!["verify".to_string()];
        a.extend(pp_args(extra));
        a.extend([fx("tilted-arc.csv"), out.to_string_lossy().into()]);
        let o = lampost(&a.iter().map(String::as_str).collect::<Vec<_>>());
        assert_eq!(o.status.success(), ok, "{extra:?}: {}", stderr(&o));
    }
    // The tool and the spindle speed.
    let t3 = post("t3.nc", &["--tool", "3", "--spindle", "5000"]);
    let o = check(&t3, &["--tool", "3", "--spindle", "5000"]);
    assert!(o.status.success(), "{}", stderr(&o));
    fails_at(
        &check(&t3, &["--spindle", "5000"]),
        "a move with tool T3 in the spindle, and the program was posted with none",
    );
    fails_at(
        &check(&t3, &["--tool", "3"]),
        "a move with S5000 in force, and the program was posted with the spindle speed S3000",
    );
    // The laser's power: on at the power posted, and kept there.
    let p500 = dep("p500.nc", &["--power", "500"]);
    let on = line(&p500, "M71 S500");
    let o = vdep(&p500, &["--power", "500"]);
    assert!(o.status.success(), "{}", stderr(&o));
    fails_at(
        &vdep(&p500, &[]),
        &format!("posted line {on}: the laser goes on, or its power is set, at another power than the program was posted with (S1000"),
    );
    fails_at(
        &vdep(
            &p500.replacen("M71 S500", "M71 S5000", 1),
            &["--power", "500"],
        ),
        &format!("posted line {on}: the laser goes on, or its power is set, at another power"),
    );
    let mut l: Vec<&str> = p500.lines().collect();
    l.insert(on + 2, "S900");
    fails_at(
        &vdep(&(l.join("\n") + "\n"), &["--power", "500"]),
        "its power is set, at another power than the program was posted with (S500",
    );
    // A power or speed that is no usable number is refused, as `post` refuses it.
    fails_at(
        &vdep(&p500, &["--power", "NaN"]),
        "--power NaN: the laser power must be a finite number, 0 or more",
    );
    fails_at(
        &check(&t3, &["--tool", "3", "--spindle=-1"]),
        "--spindle -1: the spindle speed must be a finite number, 0 or more",
    );
    // An arm's program has no machining options to hold.
    let o = lampost(&[
        "verify",
        "--machine",
        "puma-lens",
        "--work-offset",
        "G55",
        dir.to_string_lossy().as_ref(),
        "--input",
        &fx("tilted-arc.csv"),
    ]);
    fails_at(&o, "--work-offset is for table machines' programs");
}

/// The post writes no dwells (a standing laser deposits on one spot): a `G4` and a
/// drilling cycle's `P` at the bottom of each hole are left out, and the user is told at
/// the line (they were dropped without a word: the helper's probe of pcb-gcode's drill
/// files). A block-delete line is run and written without its `/`, with a warning.
/// `check` and `trace` say nothing of them.
#[test]
fn a_dwell_left_out_of_a_posted_program_is_named() {
    let dir = tempdir("safety-dwell");
    let input = write(
        &dir,
        "dwell.nc",
        "G21 G90 G17\nG0 X0 Y0 Z5\nM3 S1000\nG82 X10 Y0 Z-2 R1 P0.5 F100\nG80\nG1 Z1 F100\nG4 P2\nG1 X5\nM5\nM2\n",
    );
    let out = dir.join("dwell.out.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--process",
        "machine",
        "--head",
        "laser",
        "--index",
        "B=0,C=0",
        &input,
        "-o",
        &out.to_string_lossy(),
    ]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains("dwell.nc:4: G82's P0.5 (a dwell at the bottom of each hole): the dwell is left out of the posted program"),
        "{e}"
    );
    assert!(e.contains("1 more warning(s) like that of line 4"), "{e}");
    let text = std::fs::read_to_string(&out).expect("posted");
    let words = || text.lines().flat_map(str::split_whitespace);
    assert!(
        !words().any(|w| w == "G4" || w == "G04" || w.starts_with('P')),
        "{text}"
    );
    let o = lampost(&["check", &input]);
    assert!(
        o.status.success() && !stderr(&o).contains("left out"),
        "{}",
        stderr(&o)
    );
    // The G4 alone is named at its line, and a block-delete line posted as run.
    let input = write(
        &dir,
        "g4.nc",
        "G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z1 F100\nG4 P2\nG1 X5\n/ G1 Y5\nM2\n",
    );
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        &input,
        "-o",
        &dir.join("g4.out.nc").to_string_lossy(),
    ]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains("g4.nc:4: G4 P2: the dwell is left out of the posted program"),
        "{e}"
    );
    assert!(
        e.contains("g4.nc:6: a block-delete line (`/`) is posted as run"),
        "{e}"
    );
    let text = std::fs::read_to_string(dir.join("g4.out.nc")).expect("posted");
    // nrc-lc's Y runs the other way at B0 C0: the part's Y5 is the table's Y-5.
    assert!(
        text.lines().any(|l| l.ends_with("Y-5.000"))
            && !text.lines().any(|l| l.trim_start().starts_with('/')),
        "{text}"
    );
}

/// `verify` follows the process switches the posted text makes (the machine's laser,
/// powder, spindle and coolant codes) and holds every move to the process posted: an
/// edit that stops the spindle in a cut, reverses or orients it, takes the coolant away
/// or adds it, fires the laser in a machining program, turns the laser or its powder
/// off in a deposit, or turns the spindle or coolant on in one, fails at the first move
/// it changes.
#[test]
fn verify_holds_every_move_to_the_process_switches_posted() {
    let dir = tempdir("safety-switches");
    let run = patch_tilted;
    let post = |name: &str, extra: &[&str]| -> String {
        let out = dir.join(name).to_string_lossy().into_owned();
        let o = run("post", extra, &["-o", &out]);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read_to_string(&out).expect("posted")
    };
    let verify = |text: &str, extra: &[&str]| -> std::process::Output {
        let p = write(&dir, "check.nc", text);
        run("verify", extra, &[&p])
    };
    let fails_at = |o: &std::process::Output, what: &str| {
        let e = stderr(o);
        assert!(!o.status.success(), "passed, expected `{what}`");
        assert!(e.contains(what), "expected `{what}`:\n{e}");
    };
    let line = |text: &str, code: &str| {
        1 + text
            .lines()
            .position(|l| l.starts_with(code))
            .expect("the code")
    };
    // `text` with `code` as a line of its own before line `at` (1-based).
    let with = |text: &str, at: usize, code: &str| {
        let mut l: Vec<&str> = text.lines().collect();
        l.insert(at - 1, code);
        l.join("\n") + "\n"
    };
    // Machining with coolant: S3000 M3, M8, then the cut.
    let mach = ["--process", "machine", "--coolant"];
    let m = post("m.nc", &mach);
    let o = verify(&m, &mach);
    assert!(o.status.success(), "{}", stderr(&o));
    // A line well inside the cut (three feeds after its first).
    let cut = line(&m, "G1") + 3;
    fails_at(
        &verify(&with(&m, cut, "M5"), &mach),
        &format!("posted line {}: a feed with the spindle stopped", cut + 1),
    );
    fails_at(
        &verify(&m.replacen("S3000 M3", "S3000 M4", 1), &mach),
        &format!(
            "a feed with the spindle switched otherwise than posted (posted line {}",
            line(&m, "S3000")
        ),
    );
    fails_at(
        &verify(&with(&m, cut, "M19"), &mach),
        "a feed with the spindle switched otherwise than posted",
    );
    fails_at(
        &verify(&with(&m, cut, "M9"), &mach),
        &format!(
            "posted line {}: a feed without coolant, and the program was posted with it",
            cut + 1
        ),
    );
    fails_at(
        &verify(&m, &["--process", "machine"]),
        &format!(
            "coolant on (posted line {}), and the program was posted without it",
            line(&m, "M8")
        ),
    );
    fails_at(
        &verify(&with(&m, cut, "M71"), &mach),
        &format!(
            "posted line {}: the laser on (posted line {cut}) in a program posted for machining",
            cut + 1
        ),
    );
    // Deposition: M71 S1000 and M73 after the approach, M72 and M74 before travel.
    let d = post("d.nc", &[]);
    let o = verify(&d, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let on = line(&d, "M71");
    let run_at = on + 4;
    let no_laser: String = d
        .lines()
        .filter(|l| !l.starts_with("M71"))
        .map(|l| format!("{l}\n"))
        .collect();
    fails_at(
        &verify(&no_laser, &[]),
        "a feed with the laser off along the deposition move of input line 4",
    );
    fails_at(
        &verify(&with(&d, run_at, "M72"), &[]),
        &format!(
            "posted line {}: a feed with the laser off along the deposition move",
            run_at + 1
        ),
    );
    fails_at(
        &verify(&with(&d, run_at, "M74"), &[]),
        &format!(
            "posted line {}: a feed with the laser on (posted line {on}) and no powder",
            run_at + 1
        ),
    );
    fails_at(
        &verify(&with(&d, run_at, "M3"), &[]),
        &format!("the spindle turning (posted line {run_at}) in a program posted for deposition"),
    );
    fails_at(
        &verify(&with(&d, run_at, "M8"), &[]),
        &format!("coolant on (posted line {run_at}) in a program posted for deposition"),
    );
    // The laser on before the approach onto the run (which it would weld on the way).
    fails_at(
        &verify(&with(&d, line(&d, "G1"), "M71 S1000"), &[]),
        "a feed with the laser on",
    );
    // Codes the post never writes whose effect verify cannot see: a user M code (a
    // LinuxCNC M100 runs a program), a digital output (a laser may hang on one), a wait
    // on an input, a pallet change; path blending.
    for code in ["M100", "M62 P0", "M66 P0 L3 Q5", "M60"] {
        let m_word = code.split(' ').next().expect("a word");
        fails_at(
            &verify(&with(&m, cut, code), &mach),
            &format!(
                "posted line {cut}: {m_word}, a code the post does not write for this machine"
            ),
        );
    }
    fails_at(
        &verify(&with(&d, run_at, "G64 P0.1"), &[]),
        &format!("posted line {run_at}: G64 (path blending)"),
    );
    // A per-point path with points that deposit nothing (travel between them, each
    // approached with the laser off): the laser turned on for such an approach fails.
    let csv_text: String = std::fs::read_to_string(fx("tilted-arc.csv"))
        .expect("csv")
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if (9..14).contains(&i) {
                let mut f: Vec<&str> = l.split(' ').collect();
                f[7] = "0";
                f.join(" ") + "\n"
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    // A per-point path posted for the NRC cell (`name`.csv): the posted text, which
    // verifies, and `verify` of any text against that path.
    let post_points = |name: &str, csv_text: &str| {
        let csv = write(&dir, &format!("{name}.csv"), csv_text);
        let out = dir
            .join(format!("{name}.nc"))
            .to_string_lossy()
            .into_owned();
        let o = lampost(&["post", "--machine", "nrc-lc", &csv, "-o", &out]);
        assert!(o.status.success(), "{}", stderr(&o));
        let posted = std::fs::read_to_string(&out).expect("posted");
        let check = write(&dir, &format!("{name}-check.nc"), "");
        let verify = move |text: &str| {
            std::fs::write(&check, text).expect("writes");
            lampost(&["verify", "--machine", "nrc-lc", &csv, &check])
        };
        let o = verify(&posted);
        assert!(o.status.success(), "{}", stderr(&o));
        (posted, verify)
    };
    let (gap, vpp) = post_points("gap", &csv_text);
    // The second approach of the travel (a G1 straight down after an index).
    let approach = 1 + gap
        .lines()
        .enumerate()
        .filter(|(_, l)| l.contains(" G1 ") && !l.contains(" X"))
        .nth(1)
        .expect("an approach")
        .0;
    let mut l: Vec<&str> = gap.lines().collect();
    l.insert(approach, "M74");
    l.insert(approach, "M72");
    l.insert(approach - 1, "M73");
    l.insert(approach - 1, "M71 S1000");
    fails_at(
        &vpp(&(l.join("\n") + "\n")),
        &format!(
            "posted line {}: a feed with the laser on (posted line {approach}) where the path deposits nothing",
            approach + 2
        ),
    );
    // The laser left off along a depositing segment: its laser-on line deleted, or
    // switched off within a run (the head would run the path and deposit nothing).
    let whole = std::fs::read_to_string(fx("tilted-arc.csv")).expect("csv");
    let (posted, vw) = post_points("whole", &whole);
    let on = 1 + posted
        .lines()
        .position(|l| l.contains(" M71"))
        .expect("the laser's line");
    let no_laser: String = posted
        .lines()
        .filter(|l| !l.contains("M71"))
        .map(|l| format!("{l}\n"))
        .collect();
    fails_at(
        &vw(&no_laser),
        &format!(
            "posted line {}: a feed with the laser off along the path between points on lines 4 and 5, which deposits",
            on + 1
        ),
    );
    let mid = on + 10;
    fails_at(
        &vw(&with(&posted, mid, "M72")),
        &format!(
            "posted line {}: a feed with the laser off along the path",
            mid + 1
        ),
    );
}

/// A program stop of the input (`M0`, `M1`, `M60`: an operator's stop to turn the part,
/// change a tool or look) is posted where it stands: the head lifts off the run with the
/// laser and powder off, the control stops (`M60` as `M0`, with a warning: no pallet is
/// changed), and the next run is approached again. A machining program turns the
/// spindle and coolant on again after it (a Haas stops them at M0). `verify` holds the
/// posted stops to the input's: one left out, one of the other kind, one within a move
/// or after the path fails; a path of points has none. (They were left out of the
/// posted program without a word, and the machine ran on where the program stopped.)
#[test]
fn a_program_stop_in_the_input_is_posted_where_it_stands() {
    let dir = tempdir("safety-stops");
    let input = write(
        &dir,
        "stops.nc",
        "G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z0 F300\nG1 X10\nM0 (turn the part)\nG1 Y10\nM1\nG1 X0\nG0 Z5\nM60\nM30\n",
    );
    let post = |name: &str, extra: &[&str]| -> (String, String) {
        let out = dir.join(name).to_string_lossy().into_owned();
        let mut args = vec!["post", "--machine", "nrc-lc", "--index", "B=0,C=0"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&[&input, "-o", &out]);
        let o = lampost(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        (std::fs::read_to_string(&out).expect("posted"), stderr(&o))
    };
    let verify = |text: &str, extra: &[&str]| -> std::process::Output {
        let p = write(&dir, "check.nc", text);
        let mut args = vec!["verify", "--machine", "nrc-lc", "--index", "B=0,C=0"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&[&input, &p]);
        lampost(&args)
    };
    let fails_at = |o: &std::process::Output, what: &str| {
        let e = stderr(o);
        assert!(!o.status.success(), "passed, expected `{what}`");
        assert!(e.contains(what), "expected `{what}`:\n{e}");
    };
    // The blocks without their sequence numbers.
    let blocks = |text: &str| -> Vec<String> {
        text.lines()
            .map(|l| match l.split_once(' ') {
                Some((n, rest)) if n.starts_with('N') => rest.to_string(),
                _ => l.to_string(),
            })
            .collect()
    };
    let (d, warned) = post("d.nc", &[]);
    assert!(
        warned.contains("stops.nc:10: M60 (pallet change and stop) is posted as M0"),
        "{warned}"
    );
    let b = blocks(&d);
    let stops: Vec<usize> = (0..b.len())
        .filter(|&k| b[k] == "M0" || b[k] == "M1")
        .collect();
    let kinds: Vec<&str> = stops.iter().map(|&k| b[k].as_str()).collect();
    assert_eq!(kinds, ["M0", "M1", "M0"], "{d}");
    for &k in &stops {
        // Laser and powder off, lifted to the clearance, then the stop.
        assert_eq!(b[k - 3..k], ["M72", "M74", "G0 Z150.000"], "{d}");
    }
    // After the first two, the head comes down onto the next run and deposits again.
    for &k in &stops[..2] {
        assert!(b[k + 1..].iter().take(5).any(|l| l == "M71 S1000"), "{d}");
    }
    let o = verify(&d, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let edit = |from: usize, to: Option<&str>| -> String {
        let mut l: Vec<&str> = d.lines().collect();
        match to {
            Some(t) => l[from] = t,
            None => {
                l.remove(from);
            }
        }
        l.join("\n") + "\n"
    };
    fails_at(
        &verify(&edit(stops[0], None), &[]),
        "the input stops here (M0 at input line 5), and the posted program goes on without stopping",
    );
    fails_at(
        &verify(&edit(stops[1], Some("M0")), &[]),
        "a program stop (M0) where the input makes another (the next on the intended path is input line 7's M1)",
    );
    fails_at(
        &verify(&edit(stops[2], None), &[]),
        "the posted program ends before the stop of input line 10 (M60)",
    );
    // A stop (laser off about it) between two points of one move.
    let feed = b
        .iter()
        .position(|l| l == "X-10.000")
        .expect("the feed to X10");
    assert_eq!(b[feed - 2], "M73", "{d}");
    let mut l: Vec<&str> = d.lines().collect();
    l.splice(
        feed..=feed,
        [
            "X-5.000",
            "M72",
            "M74",
            "M0",
            "M71 S1000",
            "M73",
            "X-10.000",
        ],
    );
    fails_at(
        &verify(&(l.join("\n") + "\n"), &[]),
        "a program stop (M0) within the move of input line 4",
    );
    // Machining: the spindle and coolant on again after each stop, before the next
    // approach; after the last (no cut after it) the program ends.
    let mach = ["--process", "machine", "--head", "laser", "--coolant"];
    let (m, _) = post("m.nc", &mach);
    let b = blocks(&m);
    let stops: Vec<usize> = (0..b.len())
        .filter(|&k| b[k] == "M0" || b[k] == "M1")
        .collect();
    assert_eq!(stops.len(), 3, "{m}");
    for &k in &stops[..2] {
        assert_eq!(b[k + 1..k + 3], ["S3000 M3", "M8"], "{m}");
    }
    assert_eq!(b[stops[2] + 1..stops[2] + 3], ["M9", "M5"], "{m}");
    let o = verify(&m, &mach);
    assert!(o.status.success(), "{}", stderr(&o));
    // A path of points has no stops.
    let csv = fx("tilted-arc.csv");
    let out = dir.join("points.nc").to_string_lossy().into_owned();
    let o = lampost(&["post", "--machine", "nrc-lc", &csv, "-o", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    let b = blocks(&posted);
    let off = b.iter().position(|l| l == "M74").expect("powder off");
    let mut l: Vec<&str> = posted.lines().collect();
    l.insert(off + 1, "M0");
    let check = write(&dir, "points-check.nc", &(l.join("\n") + "\n"));
    fails_at(
        &lampost(&["verify", "--machine", "nrc-lc", &csv, &check]),
        "a program stop (M0): a path of points has none",
    );
    // A stop after an arc shorter than the tolerance, written as chords at a tilted
    // index: the chords after the one that ends the arc are the arc's, then the stop.
    let tiny = write(
        &dir,
        "tiny.nc",
        "G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z0 F300\nG1 X10\nG2 X10.004 Y-0.004 I0.004 J0\nM0\nG1 Y10\nG0 Z5\nM30\n",
    );
    let out = dir.join("tiny.out.nc").to_string_lossy().into_owned();
    let tilted = ["--machine", "nrc-lc", "--index", "B=30,C=45"];
    let mut args = vec!["post"];
    args.extend_from_slice(&tilted);
    args.extend_from_slice(&[&tiny, "-o", &out]);
    let o = lampost(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    let mut args = vec!["verify"];
    args.extend_from_slice(&tilted);
    args.extend_from_slice(&[&tiny, &out]);
    let o = lampost(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let no_stop: String = posted
        .lines()
        .filter(|l| !l.ends_with(" M0"))
        .map(|l| format!("{l}\n"))
        .collect();
    let check = write(&dir, "tiny-check.nc", &no_stop);
    let mut args = vec!["verify"];
    args.extend_from_slice(&tilted);
    args.extend_from_slice(&[&tiny, &check]);
    fails_at(&lampost(&args), "the input stops here (M0 at input line 6)");
}

/// h52 (findings 86, 87): tampering verify let through. A posted program whose index line
/// (or one rotary word of it) is deleted was verified as if the table stood at 0: on the
/// machine it stands wherever the last program left it. Powder left on over travel, or
/// never turned off, passed too. Each now fails, and the program as posted passes.
#[test]
fn verify_catches_an_index_or_powder_tampered_with() {
    let dir = tempdir("safety-h52-tamper");
    let posted = post_patch(&dir, "A=0,B=0");
    assert!(verify(&dir, "A=0,B=0", &posted, &[]).status.success());
    let index = posted
        .lines()
        .find(|l| l.contains("(INDEX)"))
        .expect("an index line")
        .to_string();
    // The index line gone; then only its B word.
    let no_index: String = posted
        .lines()
        .filter(|l| *l != index)
        .collect::<Vec<_>>()
        .join("\n")
        + "\n";
    let o = verify(&dir, "A=0,B=0", &no_index, &[]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("a move before the program sets A and B"),
        "{}",
        stderr(&o)
    );
    let no_b = posted.replacen(
        &index,
        &index
            .split(' ')
            .filter(|w| !w.starts_with('B'))
            .collect::<Vec<_>>()
            .join(" "),
        1,
    );
    let o = verify(&dir, "A=0,B=0", &no_b, &[]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("a move before the program sets B"),
        "{}",
        stderr(&o)
    );
    // Powder: never off, and on over travel.
    let powder_off = posted
        .lines()
        .find(|l| *l == "M74" || l.ends_with(" M74"))
        .expect("powder off")
        .to_string();
    let never_off: String = posted
        .lines()
        .filter(|l| *l != powder_off)
        .collect::<Vec<_>>()
        .join("\n")
        + "\n";
    let o = verify(&dir, "A=0,B=0", &never_off, &[]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("with the powder on"), "{}", stderr(&o));
    let on_in_travel = posted.replacen(&powder_off, &powder_off.replace("M74", "M73"), 1);
    let o = verify(&dir, "A=0,B=0", &on_in_travel, &[]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("powder on"), "{}", stderr(&o));
}

/// h52 (finding 88): process codes that make a program verify refuses (or worse) were
/// written without a word: an empty `laser_off` left the laser on over every traverse;
/// `M30`, `M2`, `M99`, `M98 P…` as process codes; an empty or non-ending `program_end`;
/// the same code on and off; `laser_on` holding the power word (`M71 S500 S1000`). Each
/// is refused in the machine file, located, and nothing is written.
#[test]
fn process_codes_that_break_a_program_are_refused_in_the_machine_file() {
    let dir = tempdir("safety-h52-codes");
    let o = lampost(&["machines", "show", "fadal-lamp"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let out = dir.join("out.nc");
    for (key, from, to, says) in [
        (
            "laser_off",
            "laser_off = \"M72\"",
            "laser_off = \"\"",
            "could never turn it off",
        ),
        (
            "powder_on",
            "powder_on = \"M73\"",
            "powder_on = \"\"",
            "could never turn it on",
        ),
        (
            "laser_on",
            "laser_on = \"M71\"",
            "laser_on = \"M30\"",
            "ends the program",
        ),
        (
            "laser_off",
            "laser_off = \"M72\"",
            "laser_off = \"M2\"",
            "ends the program",
        ),
        (
            "laser_on",
            "laser_on = \"M71\"",
            "laser_on = \"M98 P1000\"",
            "subprogram",
        ),
        (
            "program_end",
            "program_end = \"M30\"",
            "program_end = \"\"",
            "M2 or M30",
        ),
        (
            "program_end",
            "program_end = \"M30\"",
            "program_end = \"M99\"",
            "subprogram",
        ),
        (
            "laser_off",
            "laser_off = \"M72\"",
            "laser_off = \"M71\"",
            "the same as",
        ),
        (
            "laser_on",
            "laser_on = \"M71\"",
            "laser_on = \"M71 S500\"",
            "writes the power itself",
        ),
        (
            "spindle_on",
            "spindle_on = \"M3\"",
            "spindle_on = \"M3 M0\"",
            "stops the program",
        ),
    ] {
        assert!(text.contains(from), "{from}");
        let bad = write(&dir, "bad.toml", &text.replacen(from, to, 1));
        let o = lampost(&[
            "post",
            "--machine",
            bad.as_str(),
            "--index",
            "A=0,B=0",
            &fx("issue11-patch.nc"),
            "-o",
            &out.to_string_lossy(),
        ]);
        assert!(!o.status.success(), "{to}: posted");
        let e = stderr(&o);
        assert!(
            e.contains(&format!("`process.{key}`")) && e.contains(says) && e.contains("bad.toml:"),
            "{to}: {e}"
        );
        assert!(!out.exists(), "{to}: written");
    }
    // A head beyond any machine (parry panicked on 1e200 with --part).
    let huge = write(
        &dir,
        "huge.toml",
        &text.replacen("\n[process]\n", "\n[process]\nhead_radius = 1e200\n", 1),
    );
    let o = lampost(&[
        "post",
        "--machine",
        huge.as_str(),
        "--index",
        "A=0,B=0",
        &fx("issue11-patch.nc"),
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("head_radius` = 1e200"),
        "{}",
        stderr(&o)
    );
}

/// h52 (finding 89): an output at another output's path, or at an input's, replaced it
/// (`--json-report` at `-o`'s path left JSON where the program was; `-o` at the input's
/// replaced the input); a named pipe as `--machine` waited for ever. Each is refused
/// before anything is read or written.
#[test]
fn outputs_never_overwrite_each_other_or_an_input() {
    let dir = tempdir("safety-h52-outputs");
    let input = write(
        &dir,
        "in.nc",
        &std::fs::read_to_string(fx("issue11-patch.nc")).expect("fixture"),
    );
    let before = std::fs::read(&input).expect("input");
    let out = dir.join("out.nc").to_string_lossy().into_owned();
    for (args, says) in [
        (
            vec!["-o", out.as_str(), "--json-report", out.as_str()],
            "the same file as -o's",
        ),
        (vec!["-o", input.as_str()], "the same file as the input"),
        (
            vec!["-o", out.as_str(), "--preview", input.as_str()],
            "the same file as the input",
        ),
    ] {
        let mut a = vec![
            "post",
            "--machine",
            "fadal-lamp",
            "--index",
            "A=0,B=0",
            &input,
        ];
        a.extend(args.iter().copied());
        let o = lampost(&a);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{args:?}: {}", stderr(&o));
        assert_eq!(std::fs::read(&input).expect("input"), before, "{args:?}");
        assert!(!Path::new(&out).exists(), "{args:?}");
    }
    let fifo = dir.join("machine.toml");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success());
    if made {
        let o = limited(
            &format!(
                "\"$LAMPOST\" post --machine {} {} -o {}",
                fifo.display(),
                input,
                out
            ),
            1 << 20,
            20,
        );
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("not a regular file"), "{}", stderr(&o));
    }
}

/// h52 (finding 90): a split piece began `G0 Z150.` then `Y-51.`, its X left where the
/// last piece wrote it: read alone (`lampost check`, rs274) it started from X0 and its
/// first arc's radii differed. Each piece's first move now says every axis the last
/// piece left (where the machine already is), and every piece checks alone; the size
/// refusal gives the `--max-bytes` that works. FADAL program numbers stay within O9999.
#[test]
fn split_pieces_read_alone_and_program_numbers_stay_in_range() {
    let dir = tempdir("safety-h52-split");
    let input = root()
        .join("fixtures/real-programs/hand-python/2_heatsink_milling.gcode")
        .to_string_lossy()
        .into_owned();
    let out = dir.join("out.nc");
    let base = [
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        "--process",
        "machine",
        "--head",
        "laser",
        "--tool",
        "1",
        "--length-offset",
        "1",
    ];
    let post = |max: &str| {
        let mut a = base.to_vec();
        a.extend(["--max-bytes", max, input.as_str(), "-o"]);
        a.push(out.to_str().expect("utf8"));
        lampost(&a)
    };
    let o = post("300");
    assert!(!o.status.success());
    let e = stderr(&o);
    let need: String = e
        .split("it needs --max-bytes ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .unwrap_or_else(|| panic!("{e}"))
        .to_string();
    let o = post(&need);
    assert!(o.status.success(), "--max-bytes {need}: {}", stderr(&o));
    let mut pieces: Vec<_> = std::fs::read_dir(&dir)
        .expect("dir")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().contains("out.0"))
        .collect();
    pieces.sort();
    assert!(pieces.len() > 2, "{pieces:?}");
    for p in &pieces {
        let o = lampost(&["check", p.to_str().expect("utf8")]);
        assert!(o.status.success(), "{}: {}", p.display(), stderr(&o));
    }
    let mut v = vec!["verify", "--machine", "nrc-lc", "--index", "B=0,C=0"];
    v.extend([
        "--process",
        "machine",
        "--head",
        "laser",
        "--tool",
        "1",
        "--length-offset",
        "1",
    ]);
    v.push(input.as_str());
    for p in &pieces {
        v.push(p.to_str().expect("utf8"));
    }
    let o = lampost(&v);
    assert!(o.status.success(), "{}", stderr(&o));
    for (n, says) in [("10000", "O0 to O9999"), ("9999", "would pass O9999")] {
        let fout = dir.join(format!("f{n}.nc"));
        let o = lampost(&[
            "post",
            "--machine",
            "fadal-lamp",
            "--convert-units",
            "--index",
            "A=0,B=0",
            "--process",
            "machine",
            "--head",
            "laser",
            "--tool",
            "1",
            "--length-offset",
            "1",
            "--program-number",
            n,
            "--max-bytes",
            "4000",
            input.as_str(),
            "-o",
            fout.to_str().expect("utf8"),
        ]);
        assert!(!o.status.success(), "{n}");
        assert!(stderr(&o).contains(says), "{n}: {}", stderr(&o));
        assert!(!fout.exists());
    }
}

/// h52 (finding 91): an option's value the control's word cannot hold (`--index
/// C=1e6`, `--power 1e308`) was refused with "check the paths and free space", and a
/// `--tolerance` finer than the written grid was called a lampost fault by the in-process
/// check. Each names the option now, and nothing is written.
#[test]
fn option_values_the_program_cannot_hold_are_the_option_s_errors() {
    let dir = tempdir("safety-h52-options");
    let out = dir.join("out.nc");
    let input = fx("patch-20mm.nc");
    for (extra, says) in [
        (
            // (Refused first as more than a turn, since finding 100.)
            vec!["--index", "B=0,C=1e6"],
            "--index C=1000000: more than a turn",
        ),
        (
            vec!["--index", "B=0,C=0", "--power", "1e9"],
            "the value comes from an option (--index, --power",
        ),
        (
            vec!["--index", "B=0,C=0", "--tolerance", "1e-300"],
            "--tolerance 1e-300: finer than the program can be written (its linear words are on a grid of 0.001); give at least 0.0005",
        ),
    ] {
        let mut a = vec!["post", "--machine", "nrc-lc"];
        a.extend(extra.iter().copied());
        a.extend([input.as_str(), "-o", out.to_str().expect("utf8")]);
        let o = lampost(&a);
        assert!(!o.status.success(), "{extra:?}");
        let e = stderr(&o);
        assert!(e.contains(says), "{extra:?}: {e}");
        assert!(!e.contains("free space") && !e.contains("lampost fault"), "{e}");
        assert!(!out.exists(), "{extra:?}");
    }
}

/// Finding 99: the laser's power word set inside a run (an `S0` line: the laser on at
/// power 0, nothing deposited) fails verify; the untouched program passes.
#[test]
fn a_power_word_set_inside_a_run_fails_verify() {
    let dir = tempdir("safety-s0");
    let input = root().join("fixtures/findings/99-ded-probe/verify-s0-input.nc");
    let input = input.to_str().expect("utf8");
    let posted = dir.join("posted.nc");
    let args = [
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        "--power",
        "500",
    ];
    let mut post = vec!["post"];
    post.extend_from_slice(&args);
    post.extend_from_slice(&[input, "-o", posted.to_str().expect("utf8")]);
    let o = lampost(&post);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&posted).expect("read");
    let verify = |p: &Path| {
        let mut v = vec!["verify"];
        v.extend_from_slice(&args);
        v.extend_from_slice(&[input, p.to_str().expect("utf8")]);
        lampost(&v)
    };
    assert!(verify(&posted).status.success());
    let lines: Vec<&str> = text.lines().collect();
    let on = lines
        .iter()
        .position(|l| l.contains("M73"))
        .expect("the powder goes on");
    for tamper in ["S0", "S250", "N85 S0"] {
        let mut t = lines.clone();
        t.insert(on + 1, tamper);
        let bad = dir.join("tampered.nc");
        std::fs::write(&bad, t.join("\n") + "\n").expect("write");
        let o = verify(&bad);
        assert_eq!(o.status.code(), Some(1), "{tamper}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(&format!("posted line {}", on + 2))
                && stderr(&o).contains("another power"),
            "{tamper}: {}",
            stderr(&o)
        );
    }
}
