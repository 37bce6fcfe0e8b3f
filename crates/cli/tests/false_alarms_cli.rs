//! Issue 12 item 5: lines of real programs that lampost used to refuse falsely. Codes
//! that set modes are accepted; codes that change the path in ways the post cannot
//! honour are accepted by `check` and `trace` with a located warning and refused by
//! `post` with their line; the arc-end tolerance is LinuxCNC's (rs274 agrees on each
//! case where it is installed).

mod common;

use common::*;

/// `lampost check` of `src` (extra arguments first): exit status and standard error.
fn check(args: &[&str], src: &str) -> (bool, String) {
    let mut a = vec!["check"];
    a.extend_from_slice(args);
    a.push("-");
    let out = lampost_stdin(&a, src.as_bytes());
    (out.status.success(), stderr(&out))
}

/// `lampost post --machine nrc-lc` of `src`: exit status and standard error.
fn post(name: &str, args: &[&str], src: &str) -> (bool, String) {
    let dir = tempdir(name);
    let inp = dir.join(format!("{name}.nc"));
    std::fs::write(&inp, src).expect("writes");
    let out_path = dir.join("out.nc");
    let mut a = vec!["post", "--machine", "nrc-lc"];
    a.extend_from_slice(args);
    a.extend_from_slice(&[
        inp.to_str().expect("utf-8"),
        "-o",
        out_path.to_str().expect("utf-8"),
    ]);
    let out = lampost(&a);
    if !out.status.success() {
        assert!(!out_path.exists(), "no output on a refusal");
    }
    (out.status.success(), stderr(&out))
}

/// Codes of real controls that change the path in ways lampost does not simulate: each
/// is accepted by check with a warning on its own line, and the post refuses that line.
#[test]
fn path_changing_codes_warn_and_the_post_refuses_their_line() {
    let cases = [
        ("G31 Z-1 F10", "G31"), // Fanuc/Mach3 skip after a G0
        ("G54.1 P0 G0 X2", "G54.1"),
        ("G154 P100", "G154"),
        ("G43.4 H1", "G43.4"),
        ("G68.2 X0 Y0 Z0 I0 J45 K0", "G68.2"),
        ("G12 I1 D1 F10", "G12"),
        ("G13 I1 D1 F10", "G13"),
        ("G150 P1 Z-1 Q.1 R.1 F10", "G150"),
        ("G66 P9000 Z-1", "G66"),
        ("G7", "G7"),
        ("G5 X5 Y5 I1 J1 P1 Q1", "G5"),
        ("G5.1 X6 Y6 I1 J1", "G5.1"),
    ];
    for (line, code) in cases {
        let src = format!("G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z1 F100\n{line}\nG1 X10 F100\nM30\n");
        let (ok, err) = check(&[], &src);
        assert!(ok, "{line}: {err}");
        assert!(
            err.contains(&format!("warning: {code} ")) && err.contains("<stdin>:4:1"),
            "{line}: {err}"
        );
        let (ok, err) = post("path", &[], &src);
        assert!(!ok, "{line}: posted");
        assert!(err.contains("path.nc:4:"), "{line}: {err}");
    }
    // An extended work offset is selected as G55 is: no warning, and after the first
    // move the post refuses the line selecting it (the first move in it named), as
    // another work offset (its values are the control's).
    for (line, at) in [("G54.1 P1 G0 X2", 4), ("G154 P3", 4)] {
        let src = format!("G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z1 F100\n{line}\nG1 X10 F100\nM30\n");
        let (ok, err) = check(&[], &src);
        assert!(ok && !err.contains("warning:"), "{line}: {err}");
        let (ok, err) = post("path", &[], &src);
        assert!(!ok, "{line}: posted");
        assert!(
            err.contains(&format!("path.nc:{at}:")) && err.contains("another work offset"),
            "{line}: {err}"
        );
    }
    // A Fanuc macro call: where macros are not evaluated (`--flavor fadal`) warned and
    // refused by the post; under Macro B (`fanuc`, `haas`, and `auto`, which G65 decides)
    // followed, so a call to a program the file does not hold is a located error.
    let src = "G21 G90 G17\nG0 X0 Y0 Z5\nG1 Z1 F100\nG65 P9001 A.125 C.625\nG1 X10 F100\nM30\n";
    let (ok, err) = check(&["--flavor", "fadal"], src);
    assert!(
        ok && err.contains("warning: G65 ") && err.contains("<stdin>:4:1"),
        "{err}"
    );
    let (ok, err) = post("g65", &["--flavor", "fadal"], src);
    assert!(!ok && err.contains("g65.nc:4:"), "{err}");
    for flavor in ["auto", "fanuc", "haas"] {
        let (ok, err) = check(&["--flavor", flavor], src);
        assert!(!ok, "{flavor}: {err}");
        assert!(
            err.contains("G65 P9001: this file holds no program O9001")
                && err.contains("<stdin>:4:1"),
            "{flavor}: {err}"
        );
    }
}

/// Settings of real controls: accepted without a word, their words their own (E, P, Q are
/// not positions or FADAL fixture offsets), and posted.
#[test]
fn settings_codes_are_accepted_and_posted() {
    for line in [
        "G187 P1 E0.01",
        "G103 P1",
        "G5.1 Q1",
        "G05 P10000",
        "G08 P1",
        "G8",
        "G67",
        "M03 $0 S1",
        "N20 M5 '*** REN DEFAULT ***",
    ] {
        let src = format!("G21 G90 G17\nG0 X0 Y0 Z5\n{line}\nG1 Z1 F100\nG1 X10\nM30\n");
        let (ok, err) = check(&[], &src);
        assert!(ok && !err.contains("warning:"), "{line}: {err}");
        let out = lampost_stdin(&["trace", "-"], src.as_bytes());
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains("X10 Y0 Z1"), "{line}: {text}");
        let (ok, err) = post("settings", &[], &src);
        assert!(ok, "{line}: {err}");
    }
}

/// A FADAL apostrophe comment is a comment: `fmt` keeps it as written, and `'` inside it
/// is no word.
#[test]
fn fadal_apostrophe_comments_are_kept() {
    let src = "N10 G0 X1 'first ' quote\nN20 M98 P9724 '*** REN DEFAULT ***\nM30\nO9724\nM99\n";
    let out = lampost_stdin(&["fmt", "-"], src.as_bytes());
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(String::from_utf8_lossy(&out.stdout), src);
    let (ok, err) = check(&[], src);
    assert!(ok, "{err}");
}

/// grbl console lines: settings and queries change nothing; `$H` homes, so it is a
/// warning in check and a refusal in post.
#[test]
fn grbl_console_lines() {
    let quiet =
        "$I ; View build info\n$$\n$G\n$32=1\n?\nG21 G90\nG0 X0 Y0 Z5\nG1 Z1 F100\nG1 X10\nM2\n";
    let (ok, err) = check(&[], quiet);
    assert!(ok && !err.contains("warning:"), "{err}");
    let out = lampost_stdin(&["fmt", "-"], quiet.as_bytes());
    assert_eq!(String::from_utf8_lossy(&out.stdout), quiet);
    let (ok, err) = post("grbl", &[], quiet);
    assert!(ok, "{err}");
    let homing = "$H\nG21 G90\nG0 X0 Y0 Z5\nG1 Z1 F100\nG1 X10\nM2\n";
    let (ok, err) = check(&[], homing);
    assert!(
        ok && err.contains("$H (grbl homing cycle)") && err.contains("<stdin>:1:1"),
        "{err}"
    );
    let (ok, err) = post("grbl", &[], homing);
    assert!(!ok && err.contains("grbl.nc:1:"), "{err}");
}

/// Firmware programs: Bambu and Marlin codes lampost does not know are named in a
/// warning (the post refuses them), large and repeated M-code words are the code's own,
/// and G29 is bed levelling, not a return from the reference point.
#[test]
fn firmware_codes_in_slicer_programs() {
    let e = ["--e-word", "extrusion"];
    let src = "M83\nM9833.2\nM970.3 Q0 A7 B30 C90 Q0 H15 K0\nM900 K0.02 M0.118825\n\
               G29 A X92.4644 Y92.4644 I15.0712 J15.0712\nG380 S2 Z-25 F300\nG1 X1 Y1 Z.2 F600 E.5\n";
    let (ok, err) = check(&e, src);
    assert!(ok, "{err}");
    assert!(
        err.contains("G29 (the printer's bed levelling probe)") && err.contains("<stdin>:5:1"),
        "{err}"
    );
    assert!(
        err.contains("G380 (a firmware code lampost does not know)") && err.contains("<stdin>:6:1"),
        "{err}"
    );
    assert_eq!(err.matches("warning:").count(), 2, "{err}");
    // The same G29 in a CNC program is Fanuc's return from the reference point; G380 is
    // no code of a CNC control.
    let (ok, err) = check(&[], "G21\nG29 X1 Y1\n");
    assert!(
        ok && err.contains("G29 (return from reference point)"),
        "{err}"
    );
    let (ok, err) = check(&[], "G21\nG380 S2 Z-25\n");
    assert!(!ok && err.contains("unknown G-code G380"), "{err}");
}

/// A slicer's bare `G28` homes every axis at the printer's home: the post cannot place
/// that on the part and refuses it with its line (docs/post.md); `G28 Z`-only retracts
/// are kept as retracts.
#[test]
fn bare_g28_in_a_slicer_program_is_refused_by_post_with_its_line() {
    let src = "G21\nG90\nM83\nG28\nG1 Z.2 F600\nG1 X10 Y0 E1\n";
    let (ok, err) = post("home", &["--e-extrusion"], src);
    assert!(!ok, "posted");
    assert!(
        err.contains("home.nc:4:") && err.contains("G28/G30"),
        "{err}"
    );
}

/// The arc-end rule is rs274ngc's: radii may differ by 2·0.001·√2 in (2·0.01·√2 mm), or
/// by up to 100 times that when the difference is at most 0.1 % of the radius.
#[test]
fn arc_end_tolerance_is_linuxcncs() {
    // (units, arc with its start at X0 Y0, accepted?)
    let cases = [
        // A 0.002 in radius difference on a 0.5 in arc (a Fusion 360 post's rounding).
        ("G20", "G2 X1.002 Y0 I.5 J0", true),
        ("G20", "G2 X20.005 Y0 I10 J0", true), // 0.005 in, but 0.05 % of the radius
        ("G20", "G2 X1.007 Y0 I.5 J0", false), // 0.007 in and 0.7 %
        ("G20", "G2 X200.1 Y0 I100 J0", true), // 0.1 in on 100 in: 0.1 %, within 100 ×
        ("G20", "G2 X200.4 Y0 I100 J0", false), // 0.2 %
        ("G21", "G2 X10.028 Y0 I5 J0", true),  // 0.028 mm
        ("G21", "G2 X10.03 Y0 I5 J0", false),  // 0.03 mm and 0.3 %
        ("G21", "G2 X2001 Y0 I1000 J0", true), // 1 mm on 1000 mm: 0.1 %
        ("G21", "G2 X2003 Y0 I1000 J0", false), // 3 mm: beyond 100 × 0.028
        ("G21", "G2 X0.001 Y0 I0.0005 J0", false), // a radius below 0.00127 mm is zero
    ];
    let rs = rs274();
    let work = tempdir("arc-tolerance");
    for (i, (units, arc, accepted)) in cases.into_iter().enumerate() {
        let src = format!("{units} G90 G17\nG0 X0 Y0 Z0\nG1 X0 F10\n{arc}\nM2\n");
        let (ok, err) = check(&[], &src);
        assert_eq!(ok, accepted, "{units} {arc}: {err}");
        if !accepted {
            assert!(err.contains("<stdin>:4:1"), "{err}");
        }
        if rs.is_some() {
            let prog = work.join(format!("arc{i}.ngc"));
            std::fs::write(&prog, &src).expect("writes");
            let theirs = rs274_to_end(&prog, &work).is_ok();
            assert_eq!(theirs, accepted, "rs274 on {units} {arc}");
        }
    }
}

/// LinuxCNC NURBS (`G5.2` … `G5.3`): one warning, the control points are not moves, and
/// the next move starts from the last of them; a motion code ends an unclosed block.
#[test]
fn nurbs_control_points_are_not_traced_as_moves() {
    let src = "G21 G90 G17\nG0 X0 Y0 Z0\nG1 X0 F100\nG5.2 X0 Y1 P1 L3\nX2 Y2 P1\nX3 Y0 P1\nG5.3\nG1 X10\n\
               G5.2 X11 Y1 P1 L3\nX12 Y2 P1\nG1 X20 Y0\nX21\nM2\n";
    let (ok, err) = check(&[], src);
    assert!(ok, "{err}");
    assert_eq!(err.matches("warning:").count(), 2, "{err}");
    let out = lampost_stdin(&["trace", "--json", "-"], src.as_bytes());
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let moves = doc["moves"].as_array().expect("moves");
    let lines: Vec<u64> = moves.iter().filter_map(|m| m["line"].as_u64()).collect();
    assert_eq!(lines, [2, 3, 8, 11, 12], "{doc}");
    assert_eq!(axis(&moves[2]["start"], "X"), 3.0, "{doc}");
    assert_eq!(axis(&moves[4]["end"], "X"), 21.0, "{doc}");
}
