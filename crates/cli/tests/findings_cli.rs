//! Wrong readings found by probing real programs from sources not seen before
//! (`fixtures/findings/README.md`), each fixed and checked here against rs274 or the
//! controls' manuals.

mod common;

use common::*;
use std::path::{Path, PathBuf};

fn finding(name: &str) -> PathBuf {
    root().join("fixtures/findings").join(name)
}

fn trace_json(flavor: &str, path: &Path) -> serde_json::Value {
    let o = lampost(&[
        "trace",
        "--json",
        "--flavor",
        flavor,
        path.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{flavor}: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).expect("json")
}

/// Ends of the traced moves, (x, y, z).
fn ends(doc: &serde_json::Value) -> Vec<[f64; 3]> {
    doc["moves"]
        .as_array()
        .expect("moves")
        .iter()
        .map(|m| {
            let e = &m["end"];
            ["X", "Y", "Z"].map(|k| e[k].as_f64().expect("number"))
        })
        .collect()
}

/// A series of drill cycles keeps the level it began at, in every flavour: after G99
/// holes a G98 returns to it (16), G91's R counts from it (17: the fourth hole was
/// drilled 0.9 in too deep), and a cycle started below R (11). Equal to rs274's moves.
#[test]
fn drill_cycles_keep_their_initial_level_in_every_flavour() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("findings-cycles");
    for name in [
        "11-g81-started-below-r.nc",
        "16-g98-after-g99-initial-level.nc",
        "17-g91-cycle-r-from-initial-level.nc",
    ] {
        let path = finding(name);
        let canon = rs274_to_end(&path, &work).expect("rs274 runs it");
        for flavor in ["fadal", "fanuc", "haas", "mach3", "linuxcnc"] {
            let doc = trace_json(flavor, &path);
            compare_with_rs274(&doc, &canon).unwrap_or_else(|e| panic!("{name} as {flavor}: {e}"));
        }
    }
}

/// `G04 X1.5` (Fanuc, Haas, FADAL: X is the dwell in seconds) moves nothing; it was
/// traced as a move to X1.5, and the plunge after it 8.5 mm from where the control
/// plunges. LinuxCNC takes the time in P only and refuses it, as rs274 does.
#[test]
fn a_dwell_s_x_is_a_time_not_a_move() {
    let path = finding("19-g4-dwell-x-moves.nc");
    for flavor in ["fadal", "fanuc", "haas", "mach3"] {
        let e = ends(&trace_json(flavor, &path));
        assert_eq!(
            e,
            vec![[10.0, 10.0, 5.0], [10.0, 10.0, 0.0], [20.0, 10.0, 0.0]],
            "{flavor}"
        );
    }
    let o = lampost(&[
        "check",
        "--flavor",
        "linuxcnc",
        path.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains(":3:1") && stderr(&o).contains("dwell time missing"),
        "{}",
        stderr(&o)
    );
    // A move cannot share a dwell's block.
    let dir = tempdir("findings-dwell");
    let p = dir.join("d.nc");
    std::fs::write(&p, "G21 G90\nG0 X1. Y1.\nG04 X1.5 Y3.\nM30\n").expect("write");
    let o = lampost(&["check", "--flavor", "fanuc", p.to_str().expect("utf8")]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("dwell time"), "{}", stderr(&o));
    if let Some(_rs274) = require_rs274() {
        assert!(
            rs274_to_end(&path, &dir).is_err(),
            "rs274 refuses G4 without P"
        );
    }
}

/// A Fanuc/Haas lathe roughing cycle `G71 P10 Q20 U0.01 W0.005 D0.05 F0.010` read
/// where G71 means millimetres (fadal, fanuc, mach3): named, its words its own, the
/// units unchanged (inch), its F the feed from there on; it switched the program to
/// millimetres and moved U and W as axes, silently. The post refuses it.
#[test]
fn a_lathe_roughing_cycle_is_not_a_units_code() {
    let path = finding("05-haas-lathe-g71-feed.nc");
    for flavor in ["fadal", "fanuc", "mach3", "haas"] {
        let o = lampost(&["trace", "--flavor", flavor, path.to_str().expect("utf8")]);
        assert!(o.status.success(), "{flavor}: {}", stderr(&o));
        assert!(stderr(&o).contains(":5:1"), "{flavor}: {}", stderr(&o));
        let doc = trace_json(flavor, &path);
        let e = ends(&doc);
        assert_eq!(
            e,
            vec![
                [1.6, 0.0, 0.1],
                [0.4, 0.0, 0.1],
                [0.4, 0.0, -0.5],
                [1.0, 0.0, -0.5],
                [1.6, 0.0, -0.5],
                [1.6, 0.0, 0.1]
            ],
            "{flavor}: inch throughout"
        );
        let o = lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            "--convert-units",
            "--flavor",
            flavor,
            path.to_str().expect("utf8"),
            "-o",
            "-",
        ]);
        assert_eq!(o.status.code(), Some(1), "{flavor}: {}", stderr(&o));
        assert!(stderr(&o).contains("lathe"), "{flavor}: {}", stderr(&o));
    }
}

/// A Marlin `G0` along which E grows: slicers write it in their start and end code to
/// prime the nozzle on a lift (Cura's `G0 F10000 Z1.5 E4.5`), which is no deposit, so the
/// post keeps G0 as travel; one that also moves in X or Y (the firmware would extrude
/// along it) is warned of at its line, where it used to pass without a word.
#[test]
fn a_slicer_g0_that_extrudes_is_travel_and_warned() {
    let path = finding("14-marlin-g0-extrudes.gcode");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--e-extrusion",
        path.to_str().expect("utf8"),
        "-o",
        "-",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("14-marlin-g0-extrudes.gcode:8") && e.contains("a G0 that extrudes"),
        "{e}"
    );
    assert_eq!(String::from_utf8_lossy(&o.stdout).matches("M71").count(), 2);
}

/// Fanuc's and Haas's ISO program number `:0097` is the O address (`--flavor fanuc`,
/// `haas`, and what `auto` picks for it); LinuxCNC refuses it, as rs274 does.
#[test]
fn a_colon_program_number_is_fanuc_s_o() {
    let path = finding("02-colon-program-number.nc");
    let p = path.to_str().expect("utf8");
    for flavor in ["auto", "fanuc", "haas"] {
        let o = lampost(&["check", "--flavor", flavor, p]);
        assert!(o.status.success(), "{flavor}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("flavour fanuc") || flavor == "haas",
            "{}",
            stderr(&o)
        );
    }
    let o = lampost(&["check", "--flavor", "linuxcnc", p]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains(":2:1"), "{}", stderr(&o));
}

/// A comment holding parentheses whose words look like another language's
/// (`(ROUGH CYCLE (PASS 1))`) is a nested comment, said at the inner `(`, not
/// "Sinumerik syntax".
#[test]
fn a_nested_comment_is_never_taken_for_another_language() {
    let path = finding("10-nested-comment-named-sinumerik.nc");
    let o = lampost(&["check", path.to_str().expect("utf8")]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("comments do not nest") && e.contains(":2:14"),
        "{e}"
    );
    assert!(!e.contains("Sinumerik"), "{e}");
}

/// A carriage return at the start of a line (a script that ends its lines `\n\r`) is
/// white space, as rs274 reads it; one inside a line is still refused at its column
/// (bare carriage returns as line ends would join lines into one block).
#[test]
fn a_carriage_return_starting_a_line_is_white_space() {
    let path = finding("01-cr-inside-line.nc");
    let o = lampost(&["check", path.to_str().expect("utf8")]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains(":4:7") && !e.contains(":2:1") && !e.contains(":3:1"),
        "{e}"
    );
}

/// Fanuc's packed call `M98 P31234` runs O1234 three times (the digits before the last
/// four are the repeat count) when the file holds no O31234; it was refused as a call
/// of a program not in the file.
#[test]
fn a_packed_m98_repeats_its_program() {
    let path = finding("18-fanuc-m98-packed-repeat.nc");
    let xs: Vec<f64> = ends(&trace_json("fanuc", &path))
        .iter()
        .map(|e| e[0])
        .collect();
    assert_eq!(xs, [0.0, 10.0, 20.0, 30.0]);
}

/// ShopBot's OpenSBP (`SA`, `MS,2,2`, `J3,x,y,z`), which Vectric and Fusion post for
/// ShopBot routers, is named at its first line, where each line was a stray letter or
/// comma (the FabMo sample gave 3,291 errors, none naming the language).
#[test]
fn shopbot_opensbp_is_named() {
    let path = finding("13-shopbot-opensbp.sbp");
    let o = lampost(&["check", path.to_str().expect("utf8")]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("ShopBot OpenSBP") && e.contains(":2:1"), "{e}");
    assert!(!e.contains("has no number"), "{e}");
}

/// Haas's additional work offsets G110–G129 (G154 P1–P20) are warned as G154 is under
/// `--flavor haas`, where G110 was "unknown G-code"; G112 (a Haas lathe's XC
/// interpolation) stays unknown.
#[test]
fn haas_g110_to_g129_are_work_offsets() {
    let path = finding("20-haas-g110-and-arc-l.nc");
    let o = lampost(&["check", "--flavor", "haas", path.to_str().expect("utf8")]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains("G110 (an extended work offset") && e.contains(":4:1"),
        "{e}"
    );
    let dir = tempdir("findings-g112");
    let p = dir.join("g112.nc");
    std::fs::write(&p, "G20 G90\nG112\nG0 X1. Y1.\nM30\n").expect("write");
    let o = lampost(&["check", "--flavor", "haas", p.to_str().expect("utf8")]);
    assert!(stderr(&o).contains("unknown G-code G112"), "{}", stderr(&o));
}

/// A program framed by `%` lines ends at the closing `%` (30): rs274 ends the file there
/// (percent mode), Fanuc, Haas and FADAL read no further (end of record). The moves after
/// it were traced (and posted) with no word; now they are left out with a warning at
/// the first, in every flavour but the slicers'. Equal to rs274's moves; a `%` line rs274
/// cannot read (`% text`, or one in a program that did not open with `%`) is refused
/// under `linuxcnc`, as rs274 refuses it.
#[test]
fn a_closing_percent_ends_the_program() {
    let path = finding("30-closing-percent-ends-the-program.nc");
    let want = vec![[10.0, 10.0, 5.0], [10.0, 10.0, 0.0], [20.0, 10.0, 0.0]];
    for flavor in ["fadal", "fanuc", "haas", "mach3", "linuxcnc"] {
        assert_eq!(ends(&trace_json(flavor, &path)), want, "{flavor}");
        let o = lampost(&["check", "--flavor", flavor, path.to_str().expect("utf8")]);
        let err = stderr(&o);
        assert!(o.status.success(), "{flavor}: {err}");
        assert!(
            err.contains("closing `%`") && err.contains(":8:"),
            "{flavor}: {err}"
        );
    }
    if let Some(_rs274) = require_rs274() {
        let work = tempdir("findings-percent");
        let canon = rs274_to_end(&path, &work).expect("rs274 runs it");
        compare_with_rs274(&trace_json("linuxcnc", &path), &canon).expect("equal to rs274");
    }
    let work = tempdir("findings-percent-refused");
    for (name, text, at) in [
        ("text.nc", "%\nG0 X1\n% vfd enable\nG0 X2\nM2\n", ":3:1"),
        ("unframed.nc", "G0 X1\n%\nG0 X2\nM2\n", ":2:1"),
    ] {
        let p = work.join(name);
        std::fs::write(&p, text).expect("writes");
        let o = lampost(&["check", "--flavor", "linuxcnc", p.to_str().expect("utf8")]);
        let err = stderr(&o);
        assert!(
            !o.status.success() && err.contains("unexpected character `%`") && err.contains(at),
            "{name}: {err}"
        );
        // Other controls end the program there.
        let e = ends(&trace_json("fadal", &p));
        assert_eq!(e, vec![[1.0, 0.0, 0.0]], "{name} as fadal");
    }
}

/// `G43.1 Z2.5` (LinuxCNC's and grbl's dynamic tool length offset, set after a tool
/// change) was refused, "axis words but no motion mode", so a valid program stopped
/// there (31). Its axis words are the offset: traced with a warning, the moves after it
/// equal to rs274's.
#[test]
fn a_dynamic_tool_length_offset_is_not_a_move() {
    let path = finding("31-g43-1-dynamic-tool-length.nc");
    let o = lampost(&[
        "check",
        "--flavor",
        "linuxcnc",
        path.to_str().expect("utf8"),
    ]);
    let err = stderr(&o);
    assert!(
        o.status.success() && err.contains("G43.1") && err.contains(":4:"),
        "{err}"
    );
    let want = vec![
        [10.0, 10.0, 5.0],
        [10.0, 10.0, 3.0],
        [10.0, 10.0, -1.0],
        [20.0, 10.0, -1.0],
        [20.0, 10.0, 5.0],
    ];
    for flavor in ["linuxcnc", "fadal", "mach3"] {
        assert_eq!(ends(&trace_json(flavor, &path)), want, "{flavor}");
    }
    if require_rs274().is_some() {
        let work = tempdir("findings-g43-1");
        let canon = rs274_to_end(&path, &work).expect("rs274 runs it");
        compare_with_rs274(&trace_json("linuxcnc", &path), &canon).expect("equal to rs274");
    }
}

/// A laser program's feed at zero power (`G1 X20 S0`: LightBurn's and LaserGRBL's raster
/// gaps under M4) or with the laser off again (M5, then `G1 X40`) burns nothing, but the
/// post deposited along it: one run of 40 mm where the program burns two of 10 (32).
/// Now such feeds are travel, noted once, as a slicer's G1 that does not extrude; a
/// program that never turns its laser on still deposits along every feed.
#[test]
fn a_laser_feed_at_zero_power_deposits_nothing() {
    let path = finding("32-laser-s0-gaps-deposited.nc");
    let work = tempdir("findings-laser-s0");
    let out = work.join("p.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        path.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains(":7: a feed made with the laser off"), "{err}");
    let (ons, deposited) = posted_deposition(&std::fs::read_to_string(&out).expect("posted"));
    assert_eq!(ons, 2, "laser-on events");
    assert!((deposited - 20.0).abs() < 1e-9, "deposited {deposited}");
    // The same moves without M4/M5/S: every feed deposits, as before.
    let plain = work.join("plain.nc");
    std::fs::write(
        &plain,
        "G21 G90 G17\nG0 X0 Y0 Z0\nG1 X10 F1500\nG1 X20\nG1 X30\nG1 X40\nM2\n",
    )
    .expect("writes");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        plain.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (ons, deposited) = posted_deposition(&std::fs::read_to_string(&out).expect("posted"));
    assert_eq!((ons, deposited), (1, 40.0));
}

/// Cura for QIDI printers writes the extruders as A and B (`G1 X270 Y5 A13`): read as a
/// Marlin program, the A word was traced as a 13° rotation with no word (34). Now the
/// first A, B or C word of a printer's program is warned of, once, at its column (the
/// trace is unchanged; the post refuses the rotation, or the program for not extruding).
#[test]
fn a_printer_s_a_word_is_warned_of() {
    let path = finding("34-qidi-extruder-a.gcode");
    let o = lampost(&["check", path.to_str().expect("utf8")]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(err.matches("in a printer's program").count(), 1, "{err}");
    assert!(
        err.contains(":6:12") && err.contains("flavour marlin"),
        "{err}"
    );
    // A CAM program's A word is an axis, as ever.
    let work = tempdir("findings-printer-axes");
    let p = work.join("rotary.nc");
    std::fs::write(&p, "G21 G90\nG0 X0 Y0 Z5 A0\nG1 A90 F100\nM2\n").expect("writes");
    let o = lampost(&["check", "--flavor", "fadal", p.to_str().expect("utf8")]);
    assert!(
        !stderr(&o).contains("in a printer's program"),
        "{}",
        stderr(&o)
    );
}

/// Centroid CNC12 macros (`IF #50010`, `IF #4201 || #4202 THEN GOTO 1000`) were refused
/// as "the letter I has no number after it" (35); the line is now named as Centroid's.
#[test]
fn centroid_macros_are_named() {
    let path = finding("35-centroid-cnc12.cnc");
    let o = lampost(&["check", path.to_str().expect("utf8")]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("Centroid CNC12") && err.contains(":3:1"),
        "{err}"
    );
}
