//! `--flavor` (issue 12 item 1) and LinuxCNC parameters, expressions and O-word
//! subroutines through the CLI (items 3 and 4): what `auto` chooses and says, each
//! flavour's reading, and bad input as located errors.

mod common;

use common::*;

fn trace_json(args: &[&str], text: &str) -> serde_json::Value {
    let mut a = vec!["trace", "--json"];
    a.extend_from_slice(args);
    a.push("-");
    let o = lampost_stdin(&a, text.as_bytes());
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_slice(&o.stdout).expect("json")
}

fn xs(doc: &serde_json::Value) -> Vec<f64> {
    doc["moves"]
        .as_array()
        .expect("moves")
        .iter()
        .map(|m| axis(&m["end"], "X"))
        .collect()
}

const SUBS: &str = "G21 G90\n\
    o100 sub\n\
    G0 X[#1 * 10]\n\
    o100 endsub\n\
    o<loop> sub\n\
    o1 repeat [#1]\n\
    o100 call [#2]\n\
    #2 = [#2 + 1]\n\
    o1 endrepeat\n\
    o<loop> endsub\n\
    o<loop> call [3] [1]\n\
    M2\n";

#[test]
fn auto_says_what_it_chose() {
    let doc = trace_json(&[], SUBS);
    assert_eq!(doc["flavor"]["flavor"], "linuxcnc");
    assert_eq!(doc["flavor"]["auto"], true);
    assert!(doc["flavor"]["reason"]
        .as_str()
        .is_some_and(|r| r.contains("O-word line on line 2")));
    // The subroutines are followed, never traced where they stand.
    assert_eq!(xs(&doc), [10.0, 20.0, 30.0]);
    // Text trace: the flavour on standard error; check says it too.
    let o = lampost_stdin(&["trace", "-"], SUBS.as_bytes());
    assert!(stderr(&o).contains("flavour linuxcnc (auto: an O-word line"));
    let o = lampost_stdin(&["check", "--json", "-"], SUBS.as_bytes());
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(
        (doc["flavor"]["flavor"].as_str(), doc["errors"].as_u64()),
        (Some("linuxcnc"), Some(0))
    );
    // Given, it is not decided.
    let doc = trace_json(&["--flavor", "linuxcnc"], SUBS);
    assert_eq!(doc["flavor"]["auto"], false);
}

/// A printer program's vendor lines (WEEDO's preview image: `W221`, `W220 <hex>`) are no
/// commands printer firmware runs: a warning once per code, no move (after a G1, `W221`
/// was traced as a W-axis move), and the post takes the program. In a CNC flavour W
/// stays an axis.
#[test]
fn vendor_lines_in_printer_programs_move_nothing() {
    let text = ";FLAVOR:Marlin\nG21 G90\nM82\nG92 E0\nG1 X1 Y1 E1 F600\nW221\nW220 ffd8ffe000104a46\nW220 0a28a2800a28\nW222\nG1 X2 Y2 E2\n";
    let doc = trace_json(&[], text);
    assert_eq!(doc["flavor"]["flavor"], "marlin");
    let m = doc["moves"].as_array().expect("moves");
    assert_eq!(m.len(), 2, "{doc}");
    assert_eq!(axis(&m[1]["end"], "X"), 2.0);
    assert!(
        m.iter()
            .all(|mv| mv["end"].get("W").is_none_or(|w| w == 0.0)),
        "{doc}"
    );
    let o = lampost_stdin(&["check", "-"], text.as_bytes());
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(
        err.matches("is no command a printer's firmware runs")
            .count(),
        3,
        "{err}"
    );
    assert!(err.contains("W220 …"), "{err}");
    // The post deposits the program's one extruding run.
    let dir = tempdir("vendor-lines");
    let input = dir.join("weedo.gcode");
    std::fs::write(&input, text).expect("write");
    let out = dir.join("weedo.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--e-extrusion",
        input.to_str().expect("utf-8"),
        "-o",
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // LinuxCNC: W is an axis.
    let doc = trace_json(&["--flavor", "linuxcnc"], "G21 G90 G1 X1 F600\nW2\n");
    assert_eq!(axis(&doc["moves"][1]["end"], "W"), 2.0);
}

#[test]
fn slicer_flavours_read_e_as_extrusion() {
    let text = ";FLAVOR:Marlin\nG21 G90\nM83\nG1 X1e-05 Y5 E.5 F1200\nG1 X10 E1\n";
    let doc = trace_json(&[], text);
    assert_eq!(doc["flavor"]["flavor"], "marlin");
    let m = doc["moves"].as_array().expect("moves");
    assert_eq!(m.len(), 2);
    assert_eq!(axis(&m[0]["end"], "X"), 0.00001);
    assert_eq!(m[1]["extruded"], 1.0);
    // `--e-word` still decides when given.
    let doc = trace_json(&["--e-word", "fixture"], "M83\nG21 G90 G0 X1\n");
    assert!(doc["moves"][0].get("extrusion").is_none());
    // fmt reads the exponents of a slicer's program.
    let o = lampost_stdin(&["fmt", "--flavor", "marlin", "-"], b"G1 X1e-05 E2\n");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(String::from_utf8_lossy(&o.stdout), "G1 X1e-05 E2\n");
}

#[test]
fn fadal_flavour_leaves_macros_verbatim() {
    let text = "G21 G90 G0 X0\n#1 = 5\nG0 X#1\nG0 X2\n";
    let doc = trace_json(&["--flavor", "fadal"], text);
    assert_eq!(xs(&doc), [0.0, 2.0]);
    let warned = doc["diagnostics"].as_array().expect("diagnostics").len();
    assert!(warned >= 1);
    // The same program read as LinuxCNC's.
    let doc = trace_json(&[], text);
    assert_eq!(xs(&doc), [0.0, 5.0, 2.0]);
}

#[test]
fn mmount_feed_from_a_parameter_cascades_no_more() {
    // LinuxCNC's mmount.ngc pattern: `F#102` is evaluated, later G1s keep the feed.
    let text = "G20 G90\n#102 = 3.0\nG0 X0 Y0 Z.1\nG1 Z-.1 F#102\nG1 X1\nG2 X2 Y0 I.5 J0\n";
    let doc = trace_json(&[], text);
    assert_eq!(xs(&doc), [0.0, 0.0, 1.0, 2.0]);
    assert_eq!(doc["moves"][3]["feed"], 3.0);
}

#[test]
fn bad_input_is_a_located_error() {
    for (text, at, what) in [
        (
            "o1 sub\no1 call\no1 endsub\no1 call\n",
            ":2:1",
            "nest more than 10 deep",
        ),
        (
            "G0 X0\no<nowhere> call [1]\n",
            ":2:1",
            "no subroutine o<nowhere> sub",
        ),
        ("G0 X#<nope>\n", ":1:5", "#<nope> is not set"),
        ("G0 X[1 / 0]\n", ":1:6", "division by zero"),
        (
            "o1 repeat [1000000000]\nG0 X1\no1 endrepeat\n",
            ":1:11",
            "over the limit",
        ),
        ("o1 endsub\n", ":1:1", "outside a subroutine"),
    ] {
        for cmd in ["trace", "check"] {
            let o = lampost_stdin(&[cmd, "--flavor", "linuxcnc", "-"], text.as_bytes());
            let e = stderr(&o);
            assert!(!o.status.success(), "{cmd} {text}: {e}");
            assert!(
                e.contains(&format!("<stdin>{at}")) && e.contains(what),
                "{cmd} {text}: {e}"
            );
            assert!(e.contains("help:"), "{e}");
        }
    }
}

#[test]
fn polar_coordinates_are_linuxcnc_only_and_refused_where_rs274_refuses_them() {
    // `auto` takes `@` and `^` as LinuxCNC's.
    let doc = trace_json(&[], "G20 G0 X2 Y0\nG0 @1 ^90\nG91 G0 ^90\n");
    assert_eq!(doc["flavor"]["flavor"], "linuxcnc", "{doc}");
    let ys: Vec<f64> = doc["moves"]
        .as_array()
        .expect("moves")
        .iter()
        .map(|m| axis(&m["end"], "Y"))
        .collect();
    assert!(
        (xs(&doc)[2] + 1.0).abs() < 1e-12 && (ys[1] - 1.0).abs() < 1e-12,
        "{doc}"
    );
    // Every other flavour: the character, located, with a hint naming the flavour.
    for flavor in ["fadal", "fanuc", "haas", "mach3", "marlin"] {
        for cmd in ["trace", "check"] {
            let o = lampost_stdin(&[cmd, "--flavor", flavor, "-"], b"G0 X1 Y0\nG0 @1 ^90\n");
            let e = stderr(&o);
            assert!(!o.status.success(), "{cmd} {flavor}: {e}");
            assert!(
                e.contains("<stdin>:2:4") && e.contains("unexpected character `@`"),
                "{cmd} {flavor}: {e}"
            );
            assert!(
                e.contains("G0 @1 ^90") && e.contains("--flavor linuxcnc"),
                "{e}"
            );
        }
    }
    // fmt writes them back as read with the LinuxCNC flavour, and refuses them in others.
    let src = b"G20 G0 X2 Y0\nG0 @1 ^90\nG91 G81 R.1 Z-.5 ^[360/17] L17 F10\n";
    let o = lampost_stdin(&["fmt", "--flavor", "linuxcnc", "-"], src);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(o.stdout, src);
    let o = lampost_stdin(&["fmt", "--flavor", "fadal", "-"], src);
    assert!(
        !o.status.success() && stderr(&o).contains("<stdin>:2:4"),
        "{}",
        stderr(&o)
    );
    // LinuxCNC's refusals, located at the word that makes the block wrong.
    for (text, at, what) in [
        ("G20 G0 X0 Y0\nG0 @1\n", ":2:4", "the angle is unknown"),
        ("G20 G0 X0 Y0\nG91 G0 ^30\n", ":2:8", "has no direction"),
        ("G20 G0 X1 Y1\nG0 @1 Y2\n", ":2:7", "cannot have X or Y"),
        ("G20 G18 G0 X1 Y1\nG17 G0 @1\n", ":2:8", "XY plane only"),
        ("G20 G0 X1 Y1\nG53 G0 @1\n", ":2:1", "G53"),
        ("G20 G0 X1 Y1\nG92 @1\n", ":2:1", "motion only"),
    ] {
        for cmd in ["trace", "check"] {
            let o = lampost_stdin(&[cmd, "--flavor", "linuxcnc", "-"], text.as_bytes());
            let e = stderr(&o);
            assert!(!o.status.success(), "{cmd} {text}: {e}");
            assert!(
                e.contains(&format!("<stdin>{at}")) && e.contains(what),
                "{cmd} {text}: {e}"
            );
            assert!(
                e.contains("polar coordinates") && e.contains("help:"),
                "{e}"
            );
        }
    }
}

#[test]
fn pcb2gcode_autolevel_subroutines_equal_rs274() {
    // The example: 39 moves traced in place before; rs274 runs every call.
    let Some(shared) = shared() else {
        eprintln!("SKIPPED: ../shared not present");
        return;
    };
    if require_rs274().is_none() {
        return;
    }
    let src = shared.join("corpus/cam/pcb2gcode-2.5.0-tiled-outline-osub.ngc");
    let work = tempdir("flavor-pcb2gcode");
    let prog = work.join("osub.ngc");
    let text = std::fs::read_to_string(&src).expect("read");
    std::fs::write(&prog, prepare(&text)).expect("write");
    let canon = rs274_motions(&prog, &work);
    let o = lampost(&["trace", "--json", prog.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(doc["flavor"]["flavor"], "linuxcnc");
    compare_with_rs274(&doc, &canon).expect("equal to rs274");
    assert!(canon.len() > 300, "{}", canon.len());
}

#[test]
fn post_reports_the_flavour() {
    let dir = tempdir("flavor-post");
    let prog = dir.join("in.ngc");
    std::fs::write(
        &prog,
        "G21 G90\n#<z> = 1\nG0 X0 Y0 Z[#<z> + 4]\nG1 Z#<z> F100\nG1 X10\nG0 Z5\nM2\n",
    )
    .expect("write");
    let out = dir.join("out.nc");
    let report = dir.join("r.json");
    let o = lampost(&[
        "post",
        prog.to_str().expect("utf8"),
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        "--process",
        "machine",
        "--head",
        "laser",
        "-o",
        out.to_str().expect("utf8"),
        "--json-report",
        report.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    assert_eq!(r["flavor"], "linuxcnc");
    // The expressions were evaluated: the cut at Z1 is in the posted program.
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert!(posted.contains("Z1."), "{posted}");
}
