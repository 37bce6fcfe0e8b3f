//! The post reads its input as `trace` does (issue 12 leftovers): LinuxCNC O-word
//! subroutines and loops, parameters, FADAL/Haas calls followed by the one reader; M99 in a
//! main program; slicer moves that do not extrude posted as travel.

mod common;

use common::*;
use std::path::Path;

/// Post `input` for the FADAL in the ISO dialect, machining, at A0 B0, with `extra`
/// arguments; the output's path.
fn post_iso(dir: &Path, input: &Path, extra: &[&str]) -> std::path::PathBuf {
    let out = dir.join(format!(
        "{}.out.ngc",
        input.file_name().and_then(|n| n.to_str()).unwrap_or("in")
    ));
    let mut args = vec![
        "post",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        "--dialect",
        "iso",
        "--process",
        "machine",
        input.to_str().expect("utf-8"),
        "-o",
        out.to_str().expect("utf-8"),
    ];
    args.extend_from_slice(extra);
    let o = lampost(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    out
}

/// The feed moves (straight and arc) of rs274's canonical output.
fn feeds(canon: &[Canon]) -> Vec<&Canon> {
    canon
        .iter()
        .filter(|c| c.kind != "STRAIGHT_TRAVERSE")
        .collect()
}

/// rs274 reads the posted program to the input's feed path: every feed of the input, in
/// order and to rs274's printed precision, and nothing else fed but the post's vertical
/// approaches (travel is rebuilt, so rapids are not compared).
fn same_feed_path(input: &[Canon], posted: &[Canon]) {
    let a = feeds(input);
    let mut k = 0;
    let mut at: Option<&[f64]> = None;
    for p in posted {
        if p.kind == "STRAIGHT_TRAVERSE" {
            at = Some(&p.args);
            continue;
        }
        let same = a.get(k).is_some_and(|q| {
            q.kind == p.kind
                && q.args.len() == p.args.len()
                && q.args
                    .iter()
                    .zip(&p.args)
                    .all(|(u, v)| (u - v).abs() <= RS274_TOL)
        });
        if same {
            k += 1;
        } else {
            // An approach: straight down (or up) onto the next start, X and Y unchanged.
            let from = at.expect("an approach follows a feed or a rapid");
            assert_eq!(p.kind, "STRAIGHT_FEED", "posted {p:?} is not in the input");
            assert!(
                (p.args[0] - from[0]).abs() <= RS274_TOL
                    && (p.args[1] - from[1]).abs() <= RS274_TOL,
                "posted {p:?} is not in the input and not a vertical approach"
            );
        }
        at = Some(&p.args);
    }
    assert_eq!(k, a.len(), "input feeds matched: {k} of {}", a.len());
}

#[test]
fn a_linuxcnc_sub_called_in_a_loop_posts_to_the_same_path_in_rs274() {
    if require_rs274().is_none() {
        return;
    }
    let dir = tempdir("post-control-sub");
    let input = root().join("fixtures/programs/sub-loop.ngc");
    // `auto` finds the O-words (and so does --flavor linuxcnc).
    let out = post_iso(&dir, &input, &[]);
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert!(!posted.to_ascii_lowercase().contains("o100"), "{posted}");
    assert!(!posted.contains('#'), "{posted}");
    let a = rs274_to_end(&input, &dir).expect("rs274 runs the input");
    let b = rs274_to_end(&out, &dir).expect("rs274 runs the posted program");
    assert_eq!(feeds(&a).len(), 3 * 5, "three calls of five feeds");
    same_feed_path(&a, &b);
    // The feeds the arguments set are there, each once per call.
    for f in ["F20", "F21", "F22"] {
        assert_eq!(posted.matches(f).count(), 1, "{f} in {posted}");
    }
    // verify reads the input the same way.
    let o = lampost(&[
        "verify",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        "--process",
        "machine",
        input.to_str().expect("utf-8"),
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn fadal_and_haas_calls_are_followed_by_the_post() {
    let dir = tempdir("post-control-calls");
    for (name, text) in [
        (
            "m98.nc",
            "O1 (MAIN)\nG20 G90 G0 X0 Y0 Z1.\nM98 P800 L2\nG0 Z1.\nM30\n\
             O800 (SUB)\nG91 G1 Z-1.1 F10.\nX1.\nZ1.1\nG90\nM99\n",
        ),
        (
            "m97.nc",
            "G20 G90 G0 X0 Y0 Z1.\nM97 P100 L2\nG0 Z1.\nM30\nN100 G91 G1 Z-1.1 F10.\nX1.\nZ1.1\nG90\nM99\n",
        ),
    ] {
        let input = dir.join(name);
        std::fs::write(&input, text).expect("write");
        let out = post_iso(&dir, &input, &["--flavor", "haas"]);
        let posted = std::fs::read_to_string(&out).expect("posted");
        // Both runs of the body are cut: to X1 then to X2 (G91 in the body), each at
        // Z-0.1.
        assert!(posted.contains("X1.0000"), "{name}: {posted}");
        assert!(posted.contains("X2.0000"), "{name}: {posted}");
        assert_eq!(posted.matches("Z-0.1000").count(), 2, "{name}: {posted}");
        assert!(!posted.contains("M98") && !posted.contains("M97"), "{posted}");
    }
}

#[test]
fn m99_in_a_main_program_is_refused_by_the_post_and_warned_by_trace() {
    let dir = tempdir("post-control-m99");
    let input = dir.join("loop.nc");
    // (Every length with its point, as Fanuc and Haas programs are written.)
    let text = "G20 G90 G0 X0 Y0 Z1.\nG1 Z-0.1 F10.\nX1.\nG0 Z1.\nM99\n";
    std::fs::write(&input, text).expect("write");
    let p = input.to_str().expect("utf-8");
    for flavor in ["fanuc", "haas", "fadal", "linuxcnc"] {
        let o = lampost(&["trace", "--flavor", flavor, p]);
        assert!(o.status.success(), "{flavor}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains(&format!("{p}:5:1"))
                && e.contains(&format!("a {flavor} control runs the program again")),
            "{flavor}: {e}"
        );
        let out = dir.join(format!("{flavor}.nc"));
        let o = lampost(&[
            "post",
            "--machine",
            "fadal-lamp",
            "--index",
            "A=0,B=0",
            "--process",
            "machine",
            "--flavor",
            flavor,
            p,
            "-o",
            out.to_str().expect("utf-8"),
        ]);
        assert!(
            !o.status.success(),
            "{flavor}: posted one pass of an endless loop"
        );
        let e = stderr(&o);
        assert!(
            e.contains(&format!("{p}:5:")) && e.contains("runs it again without end"),
            "{flavor}: {e}"
        );
        assert!(!out.exists());
    }
    // Printer firmware has no main-program loop: a located error.
    let o = lampost(&["check", "--flavor", "marlin", p]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains(&format!("{p}:5:1")) && stderr(&o).contains("M99 outside a subprogram"),
        "{}",
        stderr(&o)
    );
    // Ended with M30, the same program posts.
    std::fs::write(&input, text.replace("M99", "M30")).expect("write");
    post_iso(&dir, &input, &["--flavor", "fanuc"]);
}

/// A slicer program whose travel is written as G1 without E and whose end code lifts the
/// head with `G1 Z200`: the non-extruding moves are travel (laser off, not work), so the
/// lift does not raise the safe height above the machine's Z travel.
#[test]
fn non_extruding_g1_moves_are_travel() {
    let dir = tempdir("post-control-dry");
    let input = dir.join("lift.gcode");
    let text = "M83\nG21 G90\nG0 X10 Y10 Z0.3 F6000\nG1 X30 E1.5 F1200\nG1 Y30 E1.5\n\
                G1 E-0.8 F2400\nG1 X50 Y50 F6000\nG1 E0.8 F2400\nG1 X70 E1.5 F1200\n\
                G1 Z0.6 F600\nG1 X40 Y40\nG1 Z200\nM84\n";
    std::fs::write(&input, text).expect("write");
    let out = dir.join("lift.nc");
    let report = dir.join("lift.json");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--flavor",
        "marlin",
        input.to_str().expect("utf-8"),
        "-o",
        out.to_str().expect("utf-8"),
        "--json-report",
        report.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let nc = std::fs::read_to_string(&out).expect("posted");
    let (runs, extruding) = extruding_runs(text);
    assert_eq!((runs, extruding), (2, 60.0));
    let (ons, deposited) = posted_deposition(&nc);
    assert_eq!(ons, runs, "{nc}");
    assert!((deposited - extruding).abs() <= 1e-9 * extruding, "{nc}");
    // No feed goes to the lift's height or the dry travel's end with the laser on
    // (posted_deposition refuses rapids with the laser on; feeds are counted above), and
    // the lift is not written as a feed to Z200.
    assert!(
        !nc.lines()
            .any(|l| l.starts_with("G1") && l.contains("Z200")),
        "{nc}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    // The safe height is over the deposited work (Z 0.3), far below the lift.
    assert!(r["verify"]["max_position_error"].as_f64().is_some(), "{r}");
}

/// A Fanuc Macro B program (a G65 bolt-hole macro with a WHILE loop): `auto` decides
/// Fanuc from the G65, trace follows it, and the post writes its expansion.
#[test]
fn a_macro_b_bolt_hole_circle_traces_and_posts() {
    let dir = tempdir("post-control-macrob");
    let input = root().join("fixtures/programs/bolt-holes-macro-b.nc");
    let p = input.to_str().expect("utf-8");
    let o = lampost(&["trace", "--json", p]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(doc["flavor"]["flavor"], "fanuc");
    let h = 5.0 * 3f64.sqrt();
    let holes: Vec<(f64, f64)> = doc["moves"]
        .as_array()
        .expect("moves")
        .iter()
        .filter(|m| m["g"] == "G1")
        .map(|m| (axis(&m["end"], "X"), axis(&m["end"], "Y")))
        .collect();
    let want = [
        (60.0, 20.0),
        (55.0, 20.0 + h),
        (45.0, 20.0 + h),
        (40.0, 20.0),
        (45.0, 20.0 - h),
        (55.0, 20.0 - h),
    ];
    assert_eq!(holes.len(), want.len(), "{holes:?}");
    for ((x, y), (a, b)) in holes.iter().zip(want) {
        assert!(
            (x - a).abs() <= 1e-12 && (y - b).abs() <= 1e-12,
            "({x}, {y}) vs ({a}, {b})"
        );
    }
    // Posted on the NRC (millimetres), machining: the six holes, no macro left.
    let out = dir.join("bolt.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        "--process",
        "machine",
        "--head",
        "laser",
        p,
        "-o",
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert!(!posted.contains('#') && !posted.contains("G65") && !posted.contains("WHILE"));
    assert_eq!(posted.matches("Z-3.").count(), 6, "{posted}");
}

/// LinuxCNC's polar coordinates (`@`, `^`; absolute and incremental, arcs, a spiral in a
/// repeat loop): the trace equals rs274's, the post writes plain X and Y that rs274 reads
/// to the same feed path, and verify passes.
#[test]
fn a_polar_program_traces_posts_and_verifies() {
    if require_rs274().is_none() {
        return;
    }
    let dir = tempdir("post-control-polar");
    let input = root().join("fixtures/programs/polar.ngc");
    let p = input.to_str().expect("utf-8");
    let o = lampost(&["trace", "--json", p]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(doc["flavor"]["flavor"], "linuxcnc");
    let a = rs274_to_end(&input, &dir).expect("rs274 runs the input");
    compare_with_rs274(&doc, &a).expect("the trace equals rs274");
    assert_eq!(feeds(&a).len(), 1 + 2 + 1 + 36 + 1, "{a:?}");
    let out = post_iso(&dir, &input, &[]);
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert!(!posted.contains(['@', '^']), "{posted}");
    let b = rs274_to_end(&out, &dir).expect("rs274 runs the posted program");
    same_feed_path(&a, &b);
    let o = lampost(&[
        "verify",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        "--process",
        "machine",
        p,
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}
