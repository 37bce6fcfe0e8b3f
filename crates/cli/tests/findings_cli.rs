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

/// rs274's moves of `path` (run in `work` to the program's end), after checking that
/// `lampost trace` under each of `flavors` gives the same moves.
fn equal_to_rs274(path: &Path, work: &Path, flavors: &[&str]) -> Vec<Canon> {
    let canon = rs274_to_end(path, work).expect("rs274 runs it");
    for flavor in flavors {
        let doc = trace_json(flavor, path);
        compare_with_rs274(&doc, &canon)
            .unwrap_or_else(|e| panic!("{} as {flavor}: {e}", path.display()));
    }
    canon
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
        // A FADAL takes a cycle stated under G91 for an error (finding 98).
        let flavors: &[&str] = if name.starts_with("17-") {
            &["fanuc", "haas", "mach3", "linuxcnc"]
        } else {
            &["fadal", "fanuc", "haas", "mach3", "linuxcnc"]
        };
        equal_to_rs274(&path, &work, flavors);
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

/// Fanuc's additional optional block skip `/1`–`/9` (a shop's Mazak EIA macros use
/// `/1`; the h23 probe): read as block delete under `--flavor fanuc` and `haas` (one
/// switch for every level; the lines run, as with `/`), refused where it stands under
/// `linuxcnc`, as rs274 refuses it ("Bad character '1' used"). `/12` and `/1.5` are no
/// levels.
#[test]
fn block_skip_levels_are_fanuc_s_block_delete() {
    let dir = tempdir("findings-skip-levels");
    let p = dir.join("skip.nc");
    std::fs::write(
        &p,
        "O1000\nG21 G90 G17\nG0 X0. Y0. Z5.\n/2 G0 X10.\n/1G0 Y4.\n/9 G1 Z-1. F100.\nM30\n",
    )
    .expect("write");
    let p = p.to_str().expect("utf8");
    for flavor in ["fanuc", "haas"] {
        let o = lampost(&["check", "--flavor", flavor, p]);
        assert!(o.status.success(), "{flavor}: {}", stderr(&o));
        let t = lampost(&["trace", "--flavor", flavor, p]);
        assert!(t.status.success(), "{flavor}: {}", stderr(&t));
        let text = String::from_utf8_lossy(&t.stdout);
        assert!(
            text.contains("G0 X10 Y4 Z5") && text.contains("G1 X10 Y4 Z-1"),
            "{text}"
        );
    }
    let o = lampost(&["check", "--flavor", "linuxcnc", p]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains(":4:2"), "{}", stderr(&o));
    let q = dir.join("not-levels.nc");
    std::fs::write(&q, "G21 G90\n/12 G0 X1.\nM30\n").expect("write");
    let o = lampost(&["check", "--flavor", "fanuc", q.to_str().expect("utf8")]);
    assert!(
        !o.status.success() && stderr(&o).contains(":2:2"),
        "{}",
        stderr(&o)
    );
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

/// Haas's additional work offsets G110–G129 (G154 P1–P20) are selected as G154 is under
/// `--flavor haas` (a work offset like G55, with no warning), where G110 was "unknown
/// G-code"; G154 with a P that names no offset is warned of; G112 (a Haas lathe's XC
/// interpolation) stays unknown.
#[test]
fn haas_g110_to_g129_are_work_offsets() {
    let path = finding("20-haas-g110-and-arc-l.nc");
    let o = lampost(&["check", "--flavor", "haas", path.to_str().expect("utf8")]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(!e.contains("G110") && !e.contains(":4:1"), "{e}");
    let dir = tempdir("findings-g154");
    let p = dir.join("g154.nc");
    std::fs::write(&p, "G20 G90\nG154 P7\nG0 X1. Y1.\nG154 P100\nM30\n").expect("write");
    let o = lampost(&["check", "--flavor", "haas", p.to_str().expect("utf8")]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(!e.contains(":2:1"), "{e}");
    assert!(
        e.contains("G154 P100 (no extended work offset") && e.contains(":4:1"),
        "{e}"
    );
    let dir = tempdir("findings-g112");
    let p = dir.join("g112.nc");
    std::fs::write(&p, "G20 G90\nG112\nG0 X1. Y1.\nM30\n").expect("write");
    let o = lampost(&["check", "--flavor", "haas", p.to_str().expect("utf8")]);
    assert!(stderr(&o).contains("unknown G-code G112"), "{}", stderr(&o));
}

/// A lathe's corner radius and chamfer on G1 without the comma (`G01 Z-0.5 R0.05`,
/// `X1.5 C0.02`; Haas lathe, Fanuc): the R was dropped with no word in every flavour and
/// the C traced as a C-axis turn of 0.02°. An R on a straight move is refused where it
/// stands in every flavour, as rs274 refuses it ("R word with no g code that uses it");
/// in a program recognised as a lathe's, the C of a G1 that moves X or Z alone is named
/// as a chamfer. rs274 itself (and `linuxcnc`) moves the C axis.
#[test]
fn a_lathe_s_corner_words_on_g1_are_named_not_dropped() {
    let path = finding("23-lathe-g01-r-and-c.nc");
    let p = path.to_str().expect("utf8");
    for flavor in ["auto", "fadal", "fanuc", "haas", "mach3", "linuxcnc"] {
        let o = lampost(&["check", "--flavor", flavor, p]);
        assert_eq!(o.status.code(), Some(1), "{flavor}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("error: R0.05 on a straight move") && e.contains(":3:11"),
            "{flavor}: {e}"
        );
        let lathe = flavor != "linuxcnc";
        assert_eq!(
            e.contains("C0.02 on a straight move") && e.contains(":4:6") && e.contains("chamfer"),
            lathe,
            "{flavor}: {e}"
        );
        assert_eq!(
            e.matches("this is a lathe (turning) program").count(),
            usize::from(lathe)
        );
        let o = lampost(&["trace", "--flavor", flavor, p]);
        assert_eq!(o.status.code(), Some(1), "{flavor}: trace stops at 3:11");
    }
    let dir = tempdir("findings-corner");
    // A G0's R too, and the C of a G1 in LinuxCNC: a C-axis move, as rs274 makes it.
    let g0 = dir.join("g0-r.nc");
    std::fs::write(&g0, "G20 G90\nG0 X1.0 Z0.1 R0.05\nM30\n").expect("write");
    let o = lampost(&["check", "--flavor", "linuxcnc", g0.to_str().expect("utf8")]);
    assert!(stderr(&o).contains(":2:14"), "{}", stderr(&o));
    let c_axis = dir.join("c-axis.nc");
    std::fs::write(
        &c_axis,
        "G20 G90 G18\nG0 X1.0 Z0.1\nG01 Z-0.5 F0.01\nX1.5 C0.02\nM30\n",
    )
    .expect("write");
    if require_rs274().is_some() {
        let refused = rs274_to_end(&path, &dir).expect_err("rs274 refuses the R");
        assert!(
            refused.contains("R word with no g code that uses it"),
            "{refused}"
        );
        let refused = rs274_to_end(&g0, &dir).expect_err("rs274 refuses the R");
        assert!(
            refused.contains("R word with no g code that uses it"),
            "{refused}"
        );
        let canon = rs274_to_end(&c_axis, &dir).expect("rs274 runs it");
        compare_with_rs274(&trace_json("linuxcnc", &c_axis), &canon).expect("equal to rs274");
    }
    // Haas lathes chamfer with I or K too: named in a lathe program, warned (a missing
    // G2/G3) in a mill's.
    let ik = dir.join("ik.nc");
    std::fs::write(
        &ik,
        "G18 G20\nT0101\nG0 X1. Z0.1\nG1 Z-0.5 F0.01\nX1.5 K-0.02\nM30\n",
    )
    .expect("write");
    let o = lampost(&["check", "--flavor", "haas", ik.to_str().expect("utf8")]);
    assert!(
        stderr(&o).contains("error: K-0.02 on a straight move") && stderr(&o).contains(":5:6"),
        "{}",
        stderr(&o)
    );
    // A mill program's C: G18 alone is no lathe program, so the C stays an axis.
    let o = lampost(&["check", "--flavor", "fanuc", c_axis.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("lathe"), "{}", stderr(&o));
}

/// Fanuc and Haas lathe programs (X a diameter, `T0101`, `G50 S`, `G96`, G18) were read
/// as a mill's with no word. Recognised (one sign only a lathe's program shows, or two
/// different ones) and said once, at the block that shows it, by `check` and `trace`;
/// the post refuses them and writes nothing. `G92 S500` (a lathe's spindle limit in
/// G-code systems B and C) is no longer "G92 needs at least one axis word" outside
/// LinuxCNC, which refuses it as rs274 does.
#[test]
fn a_lathe_program_is_said_once_and_not_posted() {
    for (name, line) in [
        ("03-lathe-diameter-arc.nc", ":2:1"),
        ("04-lathe-g76-one-block.nc", ":2:1"),
    ] {
        let path = finding(name);
        let o = lampost(&["check", path.to_str().expect("utf8")]);
        let e = stderr(&o);
        assert!(
            e.contains(&format!("{name}{line}")) && e.contains("`T0101`") == name.starts_with("03"),
            "{e}"
        );
        assert_eq!(
            e.matches("this is a lathe (turning) program").count(),
            1,
            "{e}"
        );
    }
    let t = root().join("fixtures/real-programs/fanuc/FANUC0T.nc");
    let tp = t.to_str().expect("utf8");
    let o = lampost(&["trace", tp]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("FANUC0T.nc:4:4") && e.contains("`G50 S0600` (a lathe's spindle speed limit)"),
        "{e}"
    );
    assert_eq!(
        e.matches("this is a lathe (turning) program").count(),
        1,
        "{e}"
    );
    let dir = tempdir("findings-lathe-post");
    let posted = dir.join("out.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--convert-units",
        tp,
        "-o",
        posted.to_str().expect("utf8"),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("FANUC0T.nc:4:") && stderr(&o).contains("posts mill programs only"),
        "{}",
        stderr(&o)
    );
    assert!(!posted.exists(), "a refused post writes nothing");
    let g92 = dir.join("g92-s.nc");
    std::fs::write(&g92, "G21 G90 G95\nG92 S500\nG0 X160. Z7.\nM30\n").expect("write");
    let g = g92.to_str().expect("utf8");
    let o = lampost(&["check", "--flavor", "fanuc", g]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(":2:1") && stderr(&o).contains("`G92 S500`"),
        "{}",
        stderr(&o)
    );
    let o = lampost(&["check", "--flavor", "linuxcnc", g]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("G92 needs at least one axis word"),
        "{}",
        stderr(&o)
    );
    if require_rs274().is_some() {
        assert!(rs274_to_end(&g92, &dir).is_err(), "rs274 refuses G92 S");
    }
    // Feed per revolution is no sign (mills tap with it), so G18 with G95 is a mill's.
    let mill = dir.join("g18-g95.nc");
    std::fs::write(
        &mill,
        "G20 G90 G18\nG95 S500 M3\nG0 X1. Z1.\nG1 Z0. F.01\nM30\n",
    )
    .expect("write");
    let o = lampost(&["check", "--flavor", "fanuc", mill.to_str().expect("utf8")]);
    assert!(
        o.status.success() && !stderr(&o).contains("lathe (turning)"),
        "{}",
        stderr(&o)
    );
    // One sign that mill programs show too is not enough: G18 (finding 21) alone.
    let o = lampost(&[
        "check",
        finding("21-g18-cycle-z-read-as-depth.nc")
            .to_str()
            .expect("utf8"),
    ]);
    assert!(!stderr(&o).contains("lathe"), "{}", stderr(&o));
}

/// A drill cycle in the XZ or YZ plane (`G18 G81 Z3 X4 R0.2 Y-1.1`) drills along the
/// plane's normal axis (Y in G18, X in G19), its hole placed by the plane's two axes, as
/// rs274 drills it; it was refused "the hole bottom Z is above the R plane" (Z taken as
/// the depth), in every flavour. Equal to rs274: the finding's program (`linuxcnc`, where
/// G99 is the default), G81 and G83 in G18 and G19 with G98/G99 said (every flavour), and
/// NIST's cycle test without its G87/G88 (passed through, warned) and its G84s outside
/// G17 (which rs274 gets wrong); a bottom above R is refused at the depth word by both.
#[test]
fn a_drill_cycle_outside_g17_drills_along_the_plane_s_normal() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("findings-g18-cycles");
    let path = finding("21-g18-cycle-z-read-as-depth.nc");
    equal_to_rs274(&path, &work, &["linuxcnc"]);
    let both = work.join("g18-g19.nc");
    std::fs::write(
        &both,
        "G20 G90\nG0 X0 Y2 Z0\nG18 G99 G81 Z3 X4 R0.2 Y-1.1 F16\nX5 Z4\nG91 Z1 X0 R0 L2\n\
         G90 G80\nG0 X6\nG19 G98 G83 Y1 Z2 X-0.5 R0.5 Q0.5\nG80\nG0 Y3\nM2\n",
    )
    .expect("write");
    let canon = rs274_to_end(&both, &work).expect("rs274 runs it");
    // (Not `fadal`: its cycles are stated in absolute only, finding 98.)
    for flavor in ["fanuc", "haas", "mach3", "linuxcnc"] {
        let doc = trace_json(flavor, &both);
        compare_with_rs274(&doc, &canon).unwrap_or_else(|e| panic!("{flavor}: {e}"));
    }
    let nist = root().join("fixtures/real-programs/nist-rs274ngc/cycle-test.gcode");
    let text = std::fs::read_to_string(&nist).expect("read");
    let kept: String = text
        .lines()
        .filter(|l| !(l.contains("g87") || l.contains("g88") || l.contains("i-0 j-3")))
        .filter(|l| !(l.contains("j-0 k-3") || l.contains("k-0 i-3")))
        // rs274's G84 outside G17 feeds to its coordinates in the wrong order
        // (`n0300 g84 z6 x7 r0.2 y-1.1` in G18: a feed to X-1.1 Y6 Z7).
        .filter(|l| !(l.starts_with("n0300 g84") || l.starts_with("n0500 g84")))
        .map(|l| format!("{l}\n"))
        .collect();
    let cut = work.join("cycle-test-no-g87-g88.ngc");
    std::fs::write(&cut, kept).expect("write");
    let canon = rs274_to_end(&cut, &work).expect("rs274 runs it");
    compare_with_rs274(&trace_json("linuxcnc", &cut), &canon).expect("equal to rs274");
    eprintln!(
        "NIST cycle test without G87/G88 (and G84 outside G17): {} moves equal to rs274",
        canon.len()
    );
    let bad = work.join("bad.nc");
    std::fs::write(
        &bad,
        "G20 G90\nG0 X0 Y2 Z0\nG18 G81 Z3 X4 R0.2 Y1 F16\nM2\n",
    )
    .expect("write");
    let refused = rs274_to_end(&bad, &work).expect_err("rs274 refuses it");
    assert!(refused.contains("R less than y"), "{refused}");
    let o = lampost(&["check", "--flavor", "linuxcnc", bad.to_str().expect("utf8")]);
    assert!(
        stderr(&o).contains(":3:20") && stderr(&o).contains("hole bottom Y"),
        "{}",
        stderr(&o)
    );
}

/// RepRapFirmware's endstop move `G1 H1 X-1000` (a homing macro's: the move stops where
/// the endstop triggers) was traced to X-1000 and posted with no word. Under `reprap`
/// (what `auto` picks for RepRapFirmware's macros) it is warned of at its H, each time,
/// and the post refuses it, writing nothing.
#[test]
fn a_reprap_endstop_move_is_named_and_not_posted() {
    let path = finding("07-rrf-h1-endstop-move.g");
    let o = lampost(&["check", "--flavor", "reprap", path.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(":2:4") && stderr(&o).contains("G1 H1 (RepRapFirmware"),
        "{}",
        stderr(&o)
    );
    let homex = root().join("fixtures/real-programs/rrf-macros/printnc-homex.g");
    let h = homex.to_str().expect("utf8");
    let o = lampost(&["check", h]);
    let e = stderr(&o);
    assert!(
        e.contains("flavour reprap") && e.contains(":6:4") && e.contains(":8:4"),
        "{e}"
    );
    let dir = tempdir("findings-rrf-h1");
    // Posted (it used to be: the endstop move as a traverse to X-100).
    let prog = dir.join("h1.g");
    std::fs::write(
        &prog,
        "; generated by RepRapFirmware\nG21 G90\nM83\nG1 H1 X-100 F1800\nG1 X10 Y10 Z0.2 F1200\nG1 X20 Y10 E1\nG1 X20 Y20 E1\n",
    )
    .expect("write");
    let posted = dir.join("out.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        prog.to_str().expect("utf8"),
        "-o",
        posted.to_str().expect("utf8"),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("h1.g:4: G1 H1 (RepRapFirmware"),
        "{}",
        stderr(&o)
    );
    assert!(!posted.exists(), "a refused post writes nothing");
    // H0 is an ordinary move.
    let plain = dir.join("h0.g");
    std::fs::write(&plain, "; RepRapFirmware\nG21 G91\nG1 H0 X5 F600\nG90\n").expect("write");
    let o = lampost(&["check", "--flavor", "reprap", plain.to_str().expect("utf8")]);
    assert!(
        !stderr(&o).contains("RepRapFirmware: the move stops"),
        "{}",
        stderr(&o)
    );
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
        equal_to_rs274(&path, &work, &["linuxcnc"]);
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
        // Under other flavours a bare `%` ends the program; a `%` line with text after
        // it (Fusion's MPCNC post writes `% vfd enable` in its start code) is read past
        // with a warning, so the program's moves are not all dropped.
        let e = ends(&trace_json("fadal", &p));
        if name == "text.nc" {
            assert_eq!(e, vec![[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], "{name} as fadal");
            let o = lampost(&["check", "--flavor", "fadal", p.to_str().expect("utf8")]);
            let err = stderr(&o);
            assert!(
                o.status.success()
                    && err.contains("read past as a comment")
                    && err.contains(":3:1"),
                "{name}: {err}"
            );
            // The post cannot tell where the program ends: refused, saying so (it said
            // the line "changes the path").
            let cut = work.join("cut.nc");
            std::fs::write(
                &cut,
                "%
G1 X1 F10
% vfd enable
G1 X2
M2
",
            )
            .expect("writes");
            let out = work.join("posted.nc");
            let c = cut.to_str().expect("utf8");
            let o = lampost(&[
                "post",
                "--machine",
                "nrc-lc",
                c,
                "-o",
                out.to_str().expect("utf8"),
            ]);
            let err = stderr(&o);
            assert!(
                !o.status.success()
                    && err.contains("cut.nc:3: a `%` line with text after it")
                    && err.contains("where the program ends cannot be told")
                    && !err.contains("changes the path"),
                "{err}"
            );
            assert!(!out.exists());
        } else {
            assert_eq!(e, vec![[1.0, 0.0, 0.0]], "{name} as fadal");
        }
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
        equal_to_rs274(&path, &work, &["linuxcnc"]);
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

/// A laser job whose paths start with a feed to their start, laser off (jscut: `G1
/// X10 F1500`, then `M3 S80`), was posted with that first feed deposited: the laser
/// went on before it, a first run of 20 mm where the program burns 10 (38). A program
/// that turns its laser on (looked for ahead, on a reader of its own) burns nothing
/// along a feed made with it off, before its first M3 as after an M5: travel, noted.
/// One that never turns it on still deposits along every feed (the test of 32); one
/// that first does after `LASER_LOOK` moves fed with it off is refused at that line,
/// nothing written.
#[test]
fn a_feed_before_the_first_laser_on_deposits_nothing() {
    let path = finding("38-feed-before-first-laser-on.nc");
    let work = tempdir("findings-laser-first");
    let out = work.join("p.nc");
    let post = |input: &Path| {
        lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            input.to_str().expect("utf8"),
            "-o",
            out.to_str().expect("utf8"),
        ])
    };
    let o = post(&path);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(":4: a feed made with the laser off (before the program's first M3/M4"),
        "{err}"
    );
    let nc = std::fs::read_to_string(&out).expect("posted");
    let (ons, deposited) = posted_deposition(&nc);
    assert_eq!(ons, 2, "laser-on events");
    assert!((deposited - 20.0).abs() < 1e-9, "deposited {deposited}");
    let v = lampost(&[
        "verify",
        "--machine",
        "nrc-lc",
        path.to_str().expect("utf8"),
        out.to_str().expect("utf8"),
    ]);
    assert!(v.status.success(), "{}", stderr(&v));
    // Fed with the laser off for longer than the look ahead, then turned on: refused at
    // the M3's move, naming the first of those feeds; nothing written.
    let mut long = String::from("G21 G90 G17\nG0 X0 Y0 Z0\n");
    let n = lampost_post::LASER_LOOK + 10;
    for k in 0..n {
        long += &format!("G1 X{} F1500\n", if k % 2 == 0 { 1 } else { 0 });
    }
    long += "M3 S80\nG1 X5\nM5\nM2\n";
    let input = work.join("long.nc");
    std::fs::write(&input, long).expect("writes");
    std::fs::remove_file(&out).expect("removes");
    let o = post(&input);
    let err = stderr(&o);
    let m3_move = n + 4;
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(&format!("long.nc:{m3_move}"))
            && err.contains("first on here")
            && err.contains("from line 3"),
        "{err}"
    );
    assert!(!out.exists(), "nothing written");
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

/// Sinumerik R parameters (`R20=200`, `R101=R101+1`) were "unexpected character `=`"
/// (11), and Okuma OSP programs were never named: `VC1=20` and `IF [VC1 EQ 20] NDTM8`
/// gave "the letter V has no number", the `$O0137.MIN%` header was read as a grbl
/// console line (12). Both languages are now named at their first line.
#[test]
fn sinumerik_r_parameters_and_okuma_programs_are_named() {
    for (name, language, at) in [
        (
            "08-sinumerik-r-parameters.nc",
            "Siemens Sinumerik syntax",
            ":1:1",
        ),
        ("09-okuma-osp.nc", "Okuma OSP syntax", ":1:1"),
    ] {
        let path = finding(name);
        let o = lampost(&["check", path.to_str().expect("utf8")]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{name}: {err}");
        assert!(err.contains(language) && err.contains(at), "{name}: {err}");
    }
}

/// A pen or laser program for a 3D printer (Inkscape gcodetools with a Marlin start
/// code: `M104 S210`, `M109 S210`, `G28`, `G90 E0`) extrudes nothing and names no slicer:
/// `auto` took its first `;` comment for LinuxCNC and refused `G90 E0` at 5:5 ("E0:
/// LinuxCNC reads E only with G76"), pointing at `--flavor fadal` (36). A printer's
/// temperature code with its S now reads it as Marlin's, as the firmware runs it; a
/// Haas `M109 P…` (its interactive input) does not.
#[test]
fn a_printer_s_start_code_reads_as_a_printer_s() {
    let path = finding("36-printer-start-code-pen-plotter.gcode");
    let doc = trace_json("auto", &path);
    assert_eq!(doc["flavor"]["flavor"], "marlin", "{}", doc["flavor"]);
    assert!(
        doc["flavor"]["reason"]
            .as_str()
            .is_some_and(|r| r.contains("temperature code") && r.contains("line 2")),
        "{}",
        doc["flavor"]
    );
    // The first lift, G28's move home, the lift, the approach, the plunge, the arc, the
    // last lift.
    let e = ends(&doc);
    assert_eq!(e.len(), 7, "{e:?}");
    let arc_end = e[5];
    assert!(
        (arc_end[0] - 82.1721).abs() < 1e-9 && (arc_end[1] - 148.2757).abs() < 1e-9,
        "{e:?}"
    );
    // Read as LinuxCNC's (what `auto` chose before), the program is refused at `G90 E0`.
    let o = lampost(&[
        "check",
        "--flavor",
        "linuxcnc",
        path.to_str().expect("utf8"),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains(":5:5"),
        "{}",
        stderr(&o)
    );
    // A Haas program's M109 (interactive input, a P and no S) is not a printer's.
    let work = tempdir("findings-haas-m109");
    let p = work.join("m109.nc");
    std::fs::write(&p, "O1000 (HAAS)\nG0 X1\nM109 P501\nM30\n").expect("writes");
    let doc = trace_json("auto", &p);
    assert_eq!(doc["flavor"]["flavor"], "haas", "{}", doc["flavor"]);
}

/// A sign with blanks before an expression (`Y - [10. - #4]`, a hand-written Macro B
/// program's spelling) was refused "the letter Y has no number after it" in every
/// flavour (a number after them, `Z - 1.`, was read); rs274 reads the blanks as
/// nothing, as Fanuc's controls do (37). Equal to rs274 under `linuxcnc`, `fanuc` and
/// `haas`.
#[test]
fn a_sign_with_blanks_after_it_signs_its_value() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("findings-sign-blanks");
    let path = finding("37-sign-then-blanks.nc");
    let canon = equal_to_rs274(&path, &work, &["linuxcnc", "fanuc", "haas"]);
    assert_eq!(canon.len(), 5);
    // The same lines with their expressions worked out by hand trace the same path.
    let p = work.join("by-hand.nc");
    std::fs::write(
        &p,
        "G21 G90 G17\nG0 X50 Y-6 Z5\nG1 Z-1 F100\nX-50\nY-7\nG0 Z5\nM30\n",
    )
    .expect("writes");
    assert_eq!(
        ends(&trace_json("fanuc", &p)),
        ends(&trace_json("fanuc", &path))
    );
}

/// A slicer's preview images can fill the first 64 KiB that `auto` looks at (Creality
/// Print 4.3.8: three PNGs, `;FLAVOR:Creality OS` at byte 104,467): every line there is a
/// `;` comment, so the program was read as LinuxCNC's and refused at its first E word
/// (42). The image block is a slicer's mark: the program now reads as a printer's, and
/// traces as it does without its images.
#[test]
fn a_slicer_s_thumbnails_filling_the_head_read_as_a_printer_s() {
    let work = tempdir("findings-thumbnail-head");
    let body = ";FLAVOR:Creality OS\nG21\nG90\nM83\nG1 Z0.2 F600\nG1 X10 Y0 E0.5 F1200\n\
                G2 X20 Y10 I0 J10 E0.6\nG1 X0 E0.8\nM84\n";
    let mut big = String::from("; png begin 300*300 104000 0 95 192\n");
    while big.len() < 100 * 1024 {
        big.push_str("; iVBORw0KGgoAAAANSUhEUgAAASwAAAEsCAYAAAB5fY51AAAACXBIWXMAAA7EAAAR\n");
    }
    big.push_str("; png end\n");
    let with = work.join("with-thumbnail.gcode");
    let without = work.join("without.gcode");
    std::fs::write(&with, format!("{big}{body}")).expect("writes");
    std::fs::write(&without, body).expect("writes");
    let doc = trace_json("auto", &with);
    assert_eq!(doc["flavor"]["flavor"], "marlin", "{}", doc["flavor"]);
    assert!(
        doc["flavor"]["reason"]
            .as_str()
            .is_some_and(|r| r.contains("thumbnail") && r.contains("line 1")),
        "{}",
        doc["flavor"]
    );
    assert_eq!(ends(&doc), ends(&trace_json("auto", &without)));
    assert_eq!(ends(&doc).len(), 4);
    // Read as LinuxCNC's (what `auto` chose before), it is refused at the first E.
    let o = lampost(&[
        "check",
        "--flavor",
        "linuxcnc",
        with.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success(), "{}", stderr(&o));
    // The real program: found, and traced to the end of the part kept.
    let real = root().join("fixtures/real-programs/creality-print/benchy-k1se-4.3.8.gcode");
    let o = lampost(&["check", "--json", real.to_str().expect("utf8")]);
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(doc["flavor"]["flavor"], "marlin", "{}", doc["flavor"]);
}

/// Mastercam's Haas post writes `A0.` alone after `G80` (and CAM posts for Fanuc-style
/// controls may start the next positioning without G0): on Fanuc and Haas the canned
/// cycles are group 09, apart from the group-01 motion, so G80 leaves the G0 (or G1) in
/// force before the cycle, and the line is a move. lampost refused it "axis words but no
/// motion mode" in every flavour (43). Under `fanuc`, `haas` and `fadal` it now moves in
/// that mode: the same moves as rs274 gives for the program with the codes written out
/// (`G0 A0.`, `G1 Y1.`). Under `linuxcnc` both still refuse the line, where rs274's G80
/// leaves no motion.
#[test]
fn axis_words_after_g80_move_in_the_motion_before_the_cycle() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("findings-after-g80");
    let path = finding("43-axis-words-after-g80-fanuc.nc");
    let text = std::fs::read_to_string(&path).expect("reads");
    let explicit: String = text
        .lines()
        .map(|l| match l {
            "A0." => "G0 A0.\n".to_string(),
            "Y1." => "G1 Y1.\n".to_string(),
            l => format!("{l}\n"),
        })
        .collect();
    assert_ne!(explicit, text);
    let p = work.join("explicit.nc");
    std::fs::write(&p, &explicit).expect("writes");
    let canon = rs274_to_end(&p, &work).expect("rs274 runs the explicit program");
    for flavor in ["fanuc", "haas", "fadal"] {
        let doc = trace_json(flavor, &path);
        compare_with_rs274(&doc, &canon).unwrap_or_else(|e| panic!("{flavor}: {e}"));
        // The line after the second G80 is a feed (G1 was in force before that cycle).
        let moves = doc["moves"].as_array().expect("moves");
        let y1 = moves
            .iter()
            .find(|m| m["line"] == 16)
            .unwrap_or_else(|| panic!("{flavor}: no move at line 16"));
        assert_eq!(y1["kind"]["type"], "linear", "{flavor}: {y1}");
    }
    // LinuxCNC: refused at the same line as rs274 refuses it.
    let err = rs274_to_end(&path, &work).expect_err("rs274 refuses `A0.` after G80");
    assert!(err.contains("Cannot use axis values"), "{err}");
    let o = lampost(&[
        "check",
        "--flavor",
        "linuxcnc",
        path.to_str().expect("utf8"),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains(":10:1"),
        "{}",
        stderr(&o)
    );
}

/// Blanks between a number's characters are nothing to rs274, which takes them out of a
/// block before reading it (`X 1 0.5` is X10.5, `Y- 2` is Y−2), as Fanuc's controls
/// ignore spaces: lampost refused the line, "number `0.5` has no address letter" (33).
/// Now equal to rs274 under every CAM flavour; a printer's firmware joins nothing, and
/// the slicer reading still refuses it.
#[test]
fn blanks_inside_a_number_are_nothing_as_in_rs274() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("findings-blank-digits");
    let path = finding("33-space-inside-number.nc");
    let canon = rs274_to_end(&path, &work).expect("rs274 runs it");
    assert_eq!(canon.len(), 1);
    for flavor in ["linuxcnc", "fanuc", "haas", "fadal", "mach3"] {
        let doc = trace_json(flavor, &path);
        compare_with_rs274(&doc, &canon).unwrap_or_else(|e| panic!("{flavor}: {e}"));
        assert_eq!(ends(&doc), [[10.5, -2.0, 0.0]], "{flavor}");
    }
    let o = lampost(&["check", "--flavor", "marlin", path.to_str().expect("utf8")]);
    assert!(!o.status.success(), "{}", stderr(&o));
    // More spellings, each against rs274: blanks around a point, in a G-code, in a feed.
    let p = work.join("spellings.nc");
    std::fs::write(
        &p,
        "G 2 1 G9 0\nG 0 X1 .5 Y 2 . 2 5 Z- 0 .1\nG 1 X 1 0 F1 0 0\nY1. 5\nM 2\n",
    )
    .expect("writes");
    let canon = rs274_to_end(&p, &work).expect("rs274 runs it");
    assert_eq!(canon.len(), 3);
    for flavor in ["linuxcnc", "fanuc"] {
        let doc = trace_json(flavor, &p);
        compare_with_rs274(&doc, &canon).unwrap_or_else(|e| panic!("{flavor}: {e}"));
    }
}

/// A printer moves a feed move given before any F at its firmware's initial feed rate
/// (Marlin's and Klipper's 1500 mm/min, RepRapFirmware's 3000); FullControl's test
/// output and hand-written scripts start so. It was refused "feed move with no feed rate"
/// in every flavour. Now, under `marlin` and `reprap`, it is traced at that rate, in
/// force until an F, with one warning at the move; every other flavour refuses it.
#[test]
fn a_printer_s_feed_before_any_f_moves_at_the_firmware_s_initial_rate() {
    let work = tempdir("findings-initial-feed");
    let body = "G28\nG90\nM83\nG1 X10 Y10 Z0.3\nG1 X20 E1\nG1 X30 E1 F1200\nG1 X40 E1\n";
    let path = work.join("no-f.gcode");
    std::fs::write(&path, body).expect("writes");
    let feeds = |doc: &serde_json::Value| -> Vec<f64> {
        doc["moves"]
            .as_array()
            .expect("moves")
            .iter()
            .map(|m| m["feed"].as_f64().expect("feed"))
            .collect()
    };
    for (flavor, rate) in [("marlin", 1500.0), ("reprap", 3000.0)] {
        let o = lampost(&["check", "--flavor", flavor, path.to_str().expect("utf8")]);
        let e = stderr(&o);
        assert!(o.status.success(), "{flavor}: {e}");
        assert!(
            e.contains(&format!("taken as {rate} mm/min")),
            "{flavor}: {e}"
        );
        assert!(
            e.contains("no-f.gcode:4:1") && e.contains("1 warning(s)"),
            "{e}"
        );
        // G28's move, then the two at the initial rate, then F1200's two.
        assert_eq!(
            feeds(&trace_json(flavor, &path)),
            [0.0, rate, rate, 1200.0, 1200.0],
            "{flavor}"
        );
    }
    // In inches, the same rate in inches a minute.
    let inch = work.join("no-f-inch.gcode");
    std::fs::write(&inch, format!("G20\n{body}")).expect("writes");
    let f = feeds(&trace_json("marlin", &inch));
    assert!((f[1] - 1500.0 / 25.4).abs() < 1e-12, "{f:?}");
    // Posted and verified as the trace reads it (the homing left out, as the post asks).
    let posted = work.join("no-f-posted.gcode");
    std::fs::write(&posted, body.replace("G28\n", "")).expect("writes");
    let out = work.join("no-f.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--e-extrusion",
        "--flavor",
        "marlin",
        posted.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).expect("posted");
    assert!(text.contains("F1500"), "{text}");
    // The machine controls (and MakerBot, whose initial rate is not known) refuse it.
    for flavor in ["linuxcnc", "fanuc", "haas", "fadal", "mach3", "makerbot"] {
        let o = lampost(&["check", "--flavor", flavor, path.to_str().expect("utf8")]);
        let e = stderr(&o);
        assert!(!o.status.success(), "{flavor}: {e}");
        assert!(
            e.contains("no feed rate (F) set") && e.contains(":4:1"),
            "{flavor}: {e}"
        );
    }
}

/// Two controllers' macro languages were refused with a stray character or named as
/// another control's (48, 49): Eding CNC's macro.cnc (`sub zero_z`, `msg "…"`,
/// `IF [#5380 == 0]` … `ENDIF`) at its `sub` line as "the letter S has no number after
/// it", and a DDCS controller's macro (`//` comments, `IF #50==1 GOTO20`) as "unexpected
/// character `/`" or, at its condition, as Centroid CNC12's syntax. Each is now named at
/// its first line that is not G-code.
#[test]
fn eding_and_ddcs_macros_are_named() {
    for (name, language, at, not) in [
        (
            "48-eding-cnc-macro.cnc",
            "Eding CNC macro syntax",
            ":2:1",
            "has no number",
        ),
        (
            "49-ddcs-macro.nc",
            "a `//` comment (DDCS, Syntec, LNC and MillMaster Pro",
            ":1:1",
            "Centroid",
        ),
    ] {
        let path = finding(name);
        let o = lampost(&["check", path.to_str().expect("utf8")]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{name}: {err}");
        let first = err
            .lines()
            .find(|l| l.starts_with("error"))
            .unwrap_or_default();
        assert!(first.contains(language), "{name}: {err}");
        assert!(err.contains(at), "{name}: {err}");
        assert!(!first.contains(not), "{name}: {err}");
    }
}

/// FreeCAD Path writes `F0.000000` on every move when the tool controller has no feed
/// (50). rs274 stops at the first G1 ("Cannot do g1 with zero feed rate"); lampost
/// stopped there too but said "feed move with no feed rate (F) set", which sends the user
/// looking for a missing F. The F0 is now named.
#[test]
fn a_feed_move_at_f0_is_named_as_zero_feed() {
    let path = finding("50-freecad-f0-feed.nc");
    let o = lampost(&["check", path.to_str().expect("utf8")]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("feed rate zero") && err.contains(":5:1"),
        "{err}"
    );
    assert!(!err.contains("no feed rate (F) set"), "{err}");
    // The oracle stops at the same line: the two traverses, then no feed move.
    if require_rs274().is_some() {
        let work = tempdir("f0-feed");
        let calls = rs274_try(&path, &work).unwrap_or_default();
        let kinds: Vec<&str> = calls.iter().map(|c| c.kind.as_str()).collect();
        assert_eq!(
            kinds,
            ["STRAIGHT_TRAVERSE", "STRAIGHT_TRAVERSE"],
            "{calls:?}"
        );
    }
}

/// Finding 51: an input's program stops are posted where they stand (they were left
/// out without a word). The oracle is rs274 on both programs: the input's stops
/// (`PROGRAM_STOP`, `OPTIONAL_PROGRAM_STOP`, and for `M60` `PALLET_SHUTTLE` and
/// `PROGRAM_STOP`; `M30` shuttles the pallets too) and
/// the posted program's (`M60` posted as `M0`: no pallet is changed) come in the same
/// order, each of the posted ones right after a rapid up to the clearance, with the
/// spindle turned on again after it.
#[test]
fn program_stops_are_posted_where_they_stand() {
    let path = finding("51-program-stops-posted.nc");
    let work = tempdir("program-stops");
    let out = work.join("posted.ngc");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--process",
        "machine",
        "--dialect",
        "iso",
        "--convert-units",
        path.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("M60 (pallet change and stop) is posted as M0"),
        "{err}"
    );
    let text = std::fs::read_to_string(&out).expect("posted");
    let stops: Vec<&str> = text.lines().filter(|l| matches!(*l, "M0" | "M1")).collect();
    assert_eq!(stops, ["M0", "M1", "M0"], "{text}");
    if require_rs274().is_none() {
        return;
    }
    let input = rs274_stops(&path, &work);
    let kinds: Vec<&str> = input.iter().map(|s| s.0.as_str()).collect();
    assert_eq!(
        kinds,
        [
            "PROGRAM_STOP",
            "OPTIONAL_PROGRAM_STOP",
            "PALLET_SHUTTLE",
            "PROGRAM_STOP",
            "PALLET_SHUTTLE"
        ],
        "{input:?}"
    );
    // The posted program's M30 shuttles the pallets, as the input's does.
    let posted = rs274_stops(&out, &work);
    let kinds: Vec<&str> = posted.iter().map(|s| s.0.as_str()).collect();
    assert_eq!(
        kinds,
        [
            "PROGRAM_STOP",
            "OPTIONAL_PROGRAM_STOP",
            "PROGRAM_STOP",
            "PALLET_SHUTTLE"
        ],
        "{posted:?}"
    );
    let posted: Vec<_> = posted
        .into_iter()
        .filter(|s| s.0 != "PALLET_SHUTTLE")
        .collect();
    for (kind, before) in &posted {
        let before = before.as_ref().expect("a move before the stop");
        assert_eq!(before.kind, "STRAIGHT_TRAVERSE", "{kind}: {before:?}");
        // FADAL's clearance, 10 in (rs274 reads the posted G20 program in inches).
        assert!(
            (before.args[2] - 10.0).abs() < RS274_TOL,
            "{kind}: {before:?}"
        );
    }
    // The spindle on again after each stop, before the next feed; after the last (the
    // program's M60, with no feed after it) the program ends.
    let lines: Vec<&str> = text.lines().collect();
    let stops: Vec<usize> = (0..lines.len())
        .filter(|&k| matches!(lines[k], "M0" | "M1"))
        .collect();
    assert_eq!(stops.len(), 3, "{text}");
    for &k in &stops[..2] {
        assert!(lines[k + 1].ends_with("M3"), "{text}");
    }
    assert_eq!(lines[stops[2] + 1], "M5", "{text}");
}

/// Finding 52: a tool change between operations (`T2 M6`) was left out of the posted
/// program without a word, and the machine went on with the first tool. Since 54 a
/// machining program's tool changes are posted, each with its tool's length offset: this
/// program gives T2 none (no `G43 H`), so it is refused at T2's first cut, posted with
/// or without `--length-offset`, and nothing is written. rs274 reads the change
/// (`CHANGE_TOOL`) where lampost's trace does.
#[test]
fn a_tool_change_without_its_length_offset_is_refused_at_its_first_cut() {
    let path = finding("52-tool-change-between-operations.nc");
    let p = path.to_str().expect("utf8");
    let work = tempdir("tool-change");
    let out = work.join("posted.nc");
    let post = |extra: &[&str]| {
        let mut a = vec!["post", "--machine", "fadal-lamp", "--process", "machine"];
        a.extend_from_slice(extra);
        a.extend([p, "-o", out.to_str().expect("utf8")]);
        lampost(&a)
    };
    for (extra, what) in [
        (
            &["--tool", "1"][..],
            "a tool change from T1 to T2 (its M6 before this line, the first cut with the new tool), and neither the options nor the input give tool length offsets (no --length-offset, no G43 H for T2 by this cut)",
        ),
        (
            &["--tool", "1", "--length-offset", "1"][..],
            "T2's first cut (after its tool change from T1) is made without a tool length offset",
        ),
    ] {
        let o = post(extra);
        let err = stderr(&o);
        assert!(!o.status.success(), "{err}");
        assert!(
            err.contains("52-tool-change-between-operations.nc:14") && err.contains(what),
            "{extra:?}: {err}"
        );
        assert!(!out.exists(), "nothing is written");
    }
    // One tool throughout posts.
    let one: String = std::fs::read_to_string(&path)
        .expect("fixture")
        .lines()
        .filter(|l| *l != "T2 M6")
        .map(|l| format!("{l}\n"))
        .collect();
    let one_path = work.join("one-tool.nc");
    std::fs::write(&one_path, one).expect("writes");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--process",
        "machine",
        "--tool",
        "1",
        one_path.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    if require_rs274().is_none() {
        return;
    }
    let (_, text) = rs274_exec(&path, &work);
    let changes = text.lines().filter(|l| l.contains("CHANGE_TOOL(")).count();
    assert_eq!(changes, 2, "{text}");
}

/// What the tool and spindle are at each cut of rs274's reading of a program, in order,
/// runs of equal ones as one: (tool, spindle speed, spindle turning clockwise, flood
/// coolant on).
fn rs274_cutting_states(
    program: &std::path::Path,
    work: &std::path::Path,
) -> Vec<(u32, f64, bool, bool)> {
    let (_, text) = rs274_exec(program, work);
    let arg = |l: &str, call: &str| -> Option<String> {
        let at = l.find(call)? + call.len();
        Some(l[at..].trim_end().trim_end_matches(')').to_string())
    };
    let (mut tool, mut speed, mut cw, mut flood) = (0u32, 0.0f64, false, false);
    let mut out: Vec<(u32, f64, bool, bool)> = Vec::new();
    for l in text.lines() {
        if let Some(a) = arg(l, "CHANGE_TOOL(") {
            tool = a.trim().parse().expect("tool number");
        } else if let Some(a) = arg(l, "SET_SPINDLE_SPEED(") {
            speed = a
                .rsplit(',')
                .next()
                .and_then(|v| v.trim().parse().ok())
                .expect("speed");
        } else if l.contains("START_SPINDLE_CLOCKWISE(") {
            cw = true;
        } else if l.contains("STOP_SPINDLE_TURNING(")
            || l.contains("START_SPINDLE_COUNTERCLOCKWISE(")
        {
            cw = false;
        } else if l.contains("FLOOD_ON(") {
            flood = true;
        } else if l.contains("FLOOD_OFF(") {
            flood = false;
        } else if l.contains("STRAIGHT_FEED(") || l.contains("ARC_FEED(") {
            let s = (tool, speed, cw, flood);
            if out.last() != Some(&s) {
                out.push(s);
            }
        }
    }
    out
}

/// Finding 54: a machining program's tool changes are posted where they stand (they were
/// left out without a word, then refused: 52). Fusion 360's Fanuc output with two
/// tools, each with its `G43 H`, S and coolant, an `M1` before the change: posted for
/// the FADAL with the first tool's options, the change comes after a lift to the
/// clearance, the spindle and coolant off; then `T2 M6`, `G43 H2`, T2's S3000 and the
/// coolant, and the next run is approached from above. `verify` holds the change to the
/// input's; rs274, reading both programs, cuts with the same tool, speed, spindle and
/// coolant, in the same order, and changes tools the same number of times.
#[test]
fn tool_changes_are_posted_where_they_stand() {
    let path = finding("54-tool-changes-posted.nc");
    let p = path.to_str().expect("utf8");
    let work = tempdir("tool-changes-posted");
    let out = work.join("posted.ngc");
    let opts = [
        "--process",
        "machine",
        "--tool",
        "1",
        "--length-offset",
        "1",
        "--spindle",
        "5000",
        "--coolant",
    ];
    let mut a = vec!["post", "--machine", "fadal-lamp", "--dialect", "iso"];
    a.extend_from_slice(&opts);
    a.extend([p, "-o", out.to_str().expect("utf8")]);
    let o = lampost(&a);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).expect("posted");
    let lines: Vec<&str> = text.lines().collect();
    let at = lines
        .iter()
        .position(|l| *l == "T2 M6")
        .expect("the change posted");
    assert_eq!(
        lines[at - 4..at + 5],
        [
            "G0 Z10.0000",
            "M1",
            "M9",
            "M5",
            "T2 M6",
            "G43 H2",
            "S3000 M3",
            "M8",
            "X0.5000 Y0.2500 Z10.0000"
        ],
        "{text}"
    );
    let verify = |posted: &std::path::Path| {
        let mut v = vec!["verify", "--machine", "fadal-lamp"];
        v.extend_from_slice(&opts);
        v.extend([p, posted.to_str().expect("utf8")]);
        lampost(&v)
    };
    let o = verify(&out);
    assert!(o.status.success(), "{}", stderr(&o));
    // Each tampering with the change fails.
    let tampered = work.join("tampered.ngc");
    let feed_before = lines[..at]
        .iter()
        .rposition(|l| l.starts_with("G1 X0.0000"))
        .expect("the last cut of T1");
    for (what, edit) in [
        ("the change left out", vec![(at, None)]),
        ("another tool", vec![(at, Some("T3 M6"))]),
        ("another length offset", vec![(at + 1, Some("G43 H1"))]),
        ("the first tool's speed", vec![(at + 2, Some("S5000 M3"))]),
        ("the spindle left off", vec![(at + 2, None)]),
        (
            "the change within T1's run",
            vec![(at, None), (feed_before, Some("T2 M6"))],
        ),
    ] {
        let mut l: Vec<Option<String>> = lines.iter().map(|l| Some((*l).to_string())).collect();
        for (k, new) in &edit {
            l[*k] = match (k, new) {
                (k, Some(n)) if *k == feed_before => Some(format!("{n}\n{}", lines[*k])),
                (_, n) => n.map(str::to_string),
            };
        }
        let t: String = l.into_iter().flatten().map(|l| format!("{l}\n")).collect();
        std::fs::write(&tampered, t).expect("writes");
        let o = verify(&tampered);
        assert!(!o.status.success(), "{what}: passed");
    }
    if require_rs274().is_none() {
        return;
    }
    let input = rs274_cutting_states(&path, &work);
    assert_eq!(
        input,
        [
            (1, 5000.0, true, true),
            (2, 3000.0, true, true),
            (3, 4000.0, true, true)
        ],
        "the input's cuts"
    );
    assert_eq!(rs274_cutting_states(&out, &work), input);
    let (_, posted) = rs274_exec(&out, &work);
    let changes: Vec<&str> = posted
        .lines()
        .filter_map(|l| l.split("CHANGE_TOOL(").nth(1))
        .collect();
    assert_eq!(changes, ["1)", "2)", "3)"], "{posted}");
}

/// Finding 54 on a real program: Fusion's Haas-style output of six tool changes
/// (`hand-haas/slot_assembly_12.nc`, enier290188/cnc: T10, T1, T5 drilling by `G81`
/// alone, T22 by `G73` alone, T16, T10 again). Two things in it are refused for their
/// own reasons, and are edited out here as a user would post it: its `G41` wear
/// compensation dropped (the path is the tool's centre), its closing park
/// `G53 G0 X0. Y0.` dropped. Its positioning feeds (`G1 X… Y… F650.` after a
/// `G53 G0 Z0.` retract) are travel (finding 55). The posted program changes tools
/// as the input does, in the same order (the two drills' changes were missed by the
/// first version of 54: their cuts are a canned cycle's alone), each change with the
/// input's `G43 H` and S, and verifies.
#[test]
fn a_real_program_s_six_tool_changes_are_posted() {
    let path = root().join("fixtures/real-programs/hand-haas/slot_assembly_12.nc");
    let text = std::fs::read_to_string(&path).expect("fixture");
    let edited: String = text
        .lines()
        .filter(|l| !l.contains("G53 G0 X0. Y0."))
        .map(|l| format!("{}\n", l.replace("G41 ", "").replace("G42 ", "")))
        .collect();
    let work = tempdir("real-tool-changes");
    let input = work.join("slot_assembly_12-edited.nc");
    std::fs::write(&input, &edited).expect("writes");
    let out = work.join("posted.nc");
    let opts = [
        "--machine",
        "fadal-lamp",
        "--process",
        "machine",
        "--tool",
        "10",
        "--length-offset",
        "10",
        "--spindle",
        "7000",
        "--coolant",
    ];
    let i = input.to_str().expect("utf8");
    let mut a = vec!["post"];
    a.extend_from_slice(&opts);
    a.extend([i, "-o", out.to_str().expect("utf8")]);
    let o = lampost(&a);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(":22: a feed across at the height a machine-coordinate retract"),
        "{}",
        stderr(&o)
    );
    let posted = std::fs::read_to_string(&out).expect("posted");
    let changes: Vec<&str> = posted.lines().filter(|l| l.ends_with(" M6")).collect();
    assert_eq!(
        changes,
        ["T10 M6", "T1 M6", "T5 M6", "T22 M6", "T16 M6", "T10 M6"],
        "{posted}"
    );
    for (t, s) in [(1, 10000), (5, 7563), (22, 3450), (16, 2292)] {
        let at = posted
            .lines()
            .position(|l| l == format!("T{t} M6"))
            .expect("its change");
        let next: Vec<&str> = posted.lines().skip(at + 1).take(2).collect();
        assert_eq!(next, [format!("G43 H{t}"), format!("S{s} M3")], "T{t}");
    }
    let mut v = vec!["verify"];
    v.extend_from_slice(&opts);
    v.extend([i, out.to_str().expect("utf8")]);
    let o = lampost(&v);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Finding 55: Fusion's Haas-style output positions each new tool with a feed at the
/// height its `G53 G0 Z0.` retract left (`G1 X1. Y1. F650.` after `T1 M6`, before
/// `G0 G43 Z0.6 H1`); it was refused as a feed from a height not known on the part. Such
/// a feed, moving only across, is a rapid written as a feed: posted as travel at the
/// safe height, noted at its line; the tool's change comes before its first real cut. A
/// feed that leaves the retract height stays refused. rs274 is the oracle for which
/// feeds run at the retract's height, and reads the posted program with no feed above
/// the input's own program Z and every other feed's end kept.
#[test]
fn positioning_feeds_at_a_retract_s_height_are_travel() {
    let path = finding("55-positioning-feed-at-retract.nc");
    let p = path.to_str().expect("utf8");
    let work = tempdir("positioning-feeds");
    let out = work.join("posted.ngc");
    let opts = [
        "--machine",
        "fadal-lamp",
        "--process",
        "machine",
        "--tool",
        "1",
        "--length-offset",
        "1",
        "--spindle",
        "5000",
        "--coolant",
    ];
    let post = |input: &str| {
        let mut a = vec!["post", "--dialect", "iso"];
        a.extend_from_slice(&opts);
        a.extend([input, "-o", out.to_str().expect("utf8")]);
        lampost(&a)
    };
    let o = post(p);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(":11: a feed across at the height a machine-coordinate retract (G53/G28/G30) left the head at is positioning"),
        "{}",
        stderr(&o)
    );
    let text = std::fs::read_to_string(&out).expect("posted");
    let lines: Vec<&str> = text.lines().collect();
    let at = lines
        .iter()
        .position(|l| *l == "T2 M6")
        .expect("T2's change");
    assert_eq!(
        lines[at..at + 5],
        [
            "T2 M6",
            "G43 H2",
            "S8000 M3",
            "M8",
            "X1.0000 Y2.0000 Z10.0000"
        ],
        "{text}"
    );
    let mut v = vec!["verify"];
    v.extend_from_slice(&opts);
    v.extend([p, out.to_str().expect("utf8")]);
    let o = lampost(&v);
    assert!(o.status.success(), "{}", stderr(&o));
    // The travel made of the positioning feed, written back as a feed at the safe
    // height, is caught.
    let tampered = work.join("tampered.ngc");
    let back = text.replacen("\nX1.0000 Y1.0000\n", "\nG1 X1.0000 Y1.0000 F650.\n", 1);
    assert_ne!(back, text, "the positioning travel is where it is expected");
    std::fs::write(&tampered, back).expect("writes");
    let mut v = vec!["verify"];
    v.extend_from_slice(&opts);
    v.extend([p, tampered.to_str().expect("utf8")]);
    let o = lampost(&v);
    assert!(!o.status.success(), "a feed at the safe height passed");
    // A feed that leaves the retract's height (down toward the part) stays refused.
    let text_in = std::fs::read_to_string(&path).expect("fixture");
    let down = work.join("down.nc");
    std::fs::write(
        &down,
        text_in.replace("N45 G1 X1. Y1. F650.", "N45 G1 X1. Y1. Z0.5 F650."),
    )
    .expect("writes");
    std::fs::remove_file(&out).ok();
    let o = post(down.to_str().expect("utf8"));
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains(":11: a feed starts at the height a machine-coordinate retract"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists(), "nothing written");
    if require_rs274().is_none() {
        return;
    }
    let o = post(p);
    assert!(o.status.success(), "{}", stderr(&o));
    // The oracle's reading of the input: the feeds of N45 and N125 run at the Z the
    // G53 retracts before them (N20, N100) leave, the input's other feeds below Z0.6.
    let (_, input) = rs274_exec(&path, &work);
    let call = |l: &str, kind: &str| -> Option<Vec<f64>> {
        let inner = l.split(&format!("{kind}(")).nth(1)?;
        Some(
            inner
                .trim_end()
                .trim_end_matches(')')
                .split(',')
                .map(|x| x.trim().parse().expect("a number"))
                .collect(),
        )
    };
    let z_of = |n: &str, kind: &str| -> f64 {
        input
            .lines()
            .find(|l| l.contains(&format!(" {n} ")) && l.contains(kind))
            .and_then(|l| call(l, kind))
            .map(|a| a[2])
            .unwrap_or_else(|| panic!("rs274's {kind} of {n}: {input}"))
    };
    for (retract, feed) in [("N20", "N45"), ("N100", "N125")] {
        assert_eq!(
            z_of(retract, "STRAIGHT_TRAVERSE"),
            z_of(feed, "STRAIGHT_FEED")
        );
    }
    let feeds = |text: &str| -> Vec<(String, Vec<f64>)> {
        text.lines()
            .filter_map(|l| {
                let n = l.split_whitespace().nth(1)?.to_string();
                call(l, "STRAIGHT_FEED").map(|a| (n, a))
            })
            .collect()
    };
    let cuts: Vec<Vec<f64>> = feeds(&input)
        .into_iter()
        .filter(|(n, _)| n != "N45" && n != "N125")
        .map(|(_, a)| a)
        .collect();
    assert!(cuts.iter().all(|a| a[2] <= 0.6), "{cuts:?}");
    let (_, posted) = rs274_exec(&out, &work);
    let posted_feeds: Vec<Vec<f64>> = feeds(&posted).into_iter().map(|(_, a)| a).collect();
    assert!(
        posted_feeds.iter().all(|a| a[2] <= 0.6 + 1e-9),
        "a feed above the input's program Z: {posted}"
    );
    for c in &cuts {
        assert!(
            posted_feeds
                .iter()
                .any(|a| (0..3).all(|k| (a[k] - c[k]).abs() < 1e-4)),
            "the input's feed to {c:?} is not in the posted program: {posted}"
        );
    }
}

/// Finding 44, for the post: an M-code lampost does not act on (Rotrics Studio's DexArm
/// header `M2000` and `M888 P0`, Marlin's filament change `M600`) was left out of the
/// posted program without a word. The post now names the first at its line, with a
/// count of the others; `check` and `trace`, which move nothing for them, stay silent.
#[test]
fn m_codes_the_post_leaves_out_are_named() {
    let real =
        std::fs::read_to_string(root().join("fixtures/real-programs/dexarm-rotrics/quote.gcode"))
            .expect("the DexArm program");
    // Its header as written, then a short path of its own.
    let head: String = real.lines().take(5).map(|l| format!("{l}\n")).collect();
    assert!(head.contains("M2000;custom:line mode"), "{head}");
    let work = tempdir("m-codes-left-out");
    let input = work.join("dexarm-head.gcode");
    std::fs::write(
        &input,
        format!("{head}G21\nM600\nG0 X0 Y0 Z5\nG1 Z0 F300\nG1 X10\nG1 Y10\nM30\n"),
    )
    .expect("writes");
    let out = work.join("posted.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        input.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("dexarm-head.gcode:3: M2000: an M-code lampost does not act on")
            && err.contains("left out of the posted program")
            && err.contains("2 more warning(s) like that of line 3"),
        "{err}"
    );
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert!(
        !posted.contains("M2000") && !posted.contains("M600"),
        "{posted}"
    );
    let o = lampost(&["check", input.to_str().expect("utf8")]);
    assert!(
        o.status.success() && !stderr(&o).contains("left out"),
        "{}",
        stderr(&o)
    );
}

/// Finding 53: a machining program's spindle and coolant were replaced without a word:
/// `S5000 M4` with `M8` was posted as `S3000 M3` with no coolant (the machine's
/// `spindle_on`, `--spindle`'s default, no `--coolant`), so a tool cutting
/// counter-clockwise would be driven backwards. A cut turning the other way than the
/// machine's `spindle_on` is now refused at its line (by `post` and by `verify`); with
/// the direction right, another speed, coolant left off, and another tool or tool length
/// offset than `--tool` and `--length-offset` are warned of.
#[test]
fn a_spindle_turning_the_other_way_is_refused_and_speed_and_coolant_named() {
    let path = finding("53-spindle-reversed-and-coolant.nc");
    let p = path.to_str().expect("utf8");
    let work = tempdir("spindle-way");
    let out = work.join("posted.nc");
    let o_arg = out.to_str().expect("utf8");
    // A machine with a spindle (the NRC cell has none: finding 110).
    let machine = root().join("fixtures/machines/xyzac-trt.toml");
    let machine = machine.to_str().expect("utf8");
    let post = |input: &str, extra: &[&str]| {
        let mut args = vec!["post", "--machine", machine, "--process", "machine"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&[input, "-o", o_arg]);
        lampost(&args)
    };
    let o = post(p, &[]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("53-spindle-reversed-and-coolant.nc:6: a cut with the spindle turning counter-clockwise (M4)"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written");
    // Clockwise: posted, with the speed and the coolant named.
    let cw = work.join("cw.nc");
    std::fs::write(
        &cw,
        std::fs::read_to_string(&path)
            .expect("fixture")
            .replace("S5000 M4", "S5000 M3"),
    )
    .expect("writes");
    let cw = cw.to_str().expect("utf8");
    let o = post(cw, &[]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("cw.nc:6: the input cuts at S5000; the posted program turns the spindle at S3000 (--spindle)")
            && err.contains("cw.nc:6: the input cuts with coolant on (M8); the posted program has none (post with --coolant)"),
        "{err}"
    );
    let o = post(cw, &["--spindle", "5000", "--coolant"]);
    let err = stderr(&o);
    assert!(
        o.status.success() && !err.contains("the input cuts"),
        "{err}"
    );
    // verify holds the input to the same rule: the posted program against the
    // counter-clockwise input is refused.
    let o = lampost(&[
        "verify",
        "--machine",
        machine,
        "--process",
        "machine",
        "--spindle",
        "5000",
        "--coolant",
        p,
        o_arg,
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("counter-clockwise (M4)"), "{err}");
    // The tool and its length offset, likewise.
    let tl = work.join("tool.nc");
    std::fs::write(
        &tl,
        "G21 G90 G17\nT1 M6\nS3000 M3\nG0 G43 H1 X0 Y0 Z5\nG1 Z0 F300\nG1 X10\nG0 Z5\nM30\n",
    )
    .expect("writes");
    let tl = tl.to_str().expect("utf8");
    let o = post(tl, &[]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("tool.nc:5: the input cuts with tool T1; the posted program makes no tool change (--tool)")
            && err.contains("tool.nc:5: the input cuts with tool length offset H1 (G43); the posted program applies none (--length-offset)"),
        "{err}"
    );
    let o = post(tl, &["--tool", "1", "--length-offset", "1"]);
    let err = stderr(&o);
    assert!(
        o.status.success() && !err.contains("the input cuts"),
        "{err}"
    );
}

/// Findings 51 and 52 on a real program: pcb2gcode's drill file moves with no tool (T0)
/// to its tool-change height, then `M6` and `M0 (Temporary machine stop.)`. Loading the
/// first tool is no tool change: it posts, its stop posted after a lift, and verifies.
/// (The tool rule first refused it as a change from T0 to T1.)
#[test]
fn pcb2gcode_s_first_tool_and_stop_post_and_verify() {
    let path = root().join("fixtures/real-programs/pcb2gcode/multivibrator-milldrill.ngc");
    let p = path.to_str().expect("utf8");
    let work = tempdir("pcb2gcode-stop");
    let out = work.join("posted.nc");
    let o_arg = out.to_str().expect("utf8");
    let args = [
        "--machine",
        "nrc-lc",
        "--process",
        "machine",
        "--head",
        "laser",
        "--convert-units",
    ];
    let mut post = vec!["post"];
    post.extend_from_slice(&args);
    post.extend_from_slice(&[p, "-o", o_arg]);
    let o = lampost(&post);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).expect("posted");
    let lines: Vec<&str> = text.lines().collect();
    let stops: Vec<usize> = (0..lines.len())
        .filter(|&k| lines[k].ends_with(" M0"))
        .collect();
    assert_eq!(stops.len(), 1, "{text}");
    // Before any cut (the stop is the program's first: its drill is changed there), at
    // the clearance after the index, and the spindle on again after it.
    let first_cut = lines
        .iter()
        .position(|l| l.contains(" G1 "))
        .expect("a cut");
    assert!(stops[0] < first_cut, "{text}");
    assert!(lines[stops[0] + 1].ends_with("S3000 M3"), "{text}");
    let mut verify = vec!["verify"];
    verify.extend_from_slice(&args);
    verify.extend_from_slice(&[p, o_arg]);
    let o = lampost(&verify);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// The sixth probe (every mill, router and laser program of `fixtures/real-programs`
/// posted as a user would, 172 of them): refusals that sent the user the wrong way.
/// Each is refused, located, with nothing written, and the message says what to do:
/// - a tool change whose new tool has a `G43 H` in the input, posted without
///   `--length-offset`: named as posted without offsets (the input's H is not enough);
/// - neither the options nor the input giving offsets (pcb-gcode's drills): one message
///   saying both, not two sending the user from one to the other;
/// - a tool's H beyond FADAL's H0–H99 (Mastercam's `T110`, `G43 H110`): at the new
///   tool's first cut for a later tool, as the option's error for `--length-offset`
///   (it was an I/O error without a line, "check the paths and free space");
/// - a program of rapids alone (a script that never left G0, plunging at `Z-2 F2`): it
///   posted as a lift and nothing else, and verified;
/// - a bare `G28` (every axis home) at a mill program's end: named as such, not only as
///   a slicer's homing.
#[test]
fn refusals_of_the_sixth_probe_say_what_to_do() {
    let work = tempdir("sixth-probe");
    let out = work.join("posted.nc");
    let post = |name: &str, body: &str, extra: &[&str]| {
        let input = work.join(name);
        std::fs::write(&input, body).expect("writes");
        let mut a = vec!["post", "--machine", "fadal-lamp", "--process", "machine"];
        a.extend_from_slice(extra);
        let i = input.to_str().expect("utf8").to_string();
        let o = work.join("posted.nc");
        let mut owned: Vec<String> = a.iter().map(|s| s.to_string()).collect();
        owned.extend([i, "-o".into(), o.to_str().expect("utf8").into()]);
        let refs: Vec<&str> = owned.iter().map(String::as_str).collect();
        lampost(&refs)
    };
    let two_tools = |h2: &str| {
        format!(
            "G20 G90 G17\nT1 M6\nS3000 M3\nG0 G43 H1 Z1.\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F10.\nX1.\nG0 Z1.\nT2 M6\nS4000 M3\n{h2}G0 X2. Y0 Z0.1\nG1 Z-0.1 F10.\nX3.\nG0 Z1.\nM30\n"
        )
    };
    for (name, body, extra, at, what) in [
        (
            "t2-h2.nc",
            two_tools("G0 G43 H2 Z1.\n"),
            &["--tool", "1", "--spindle", "3000"][..],
            ":13:",
            "the program is posted without tool length offsets",
        ),
        (
            "t2-none.nc",
            two_tools("").replace("G0 G43 H1 Z1.\n", ""),
            &["--tool", "1", "--spindle", "3000"][..],
            ":11:",
            "neither the options nor the input give tool length offsets",
        ),
        (
            "t2-h110.nc",
            two_tools("G0 G43 H110 Z1.\n"),
            &["--tool", "1", "--length-offset", "1", "--spindle", "3000"][..],
            ":13:",
            "refused to write H110: out of range for FADAL: 0 to 99",
        ),
        (
            "t1-h110.nc",
            two_tools("G0 G43 H2 Z1.\n"),
            &["--tool", "1", "--length-offset", "110", "--spindle", "3000"][..],
            "--length-offset: ",
            "refused to write H110: out of range for FADAL: 0 to 99",
        ),
        (
            "rapids.nc",
            "G21 G90\nT1 M6\nG0 X0 Y0 Z10 S3000 M3\nX61.045 Y67.745\nZ1\nZ-2 F2\nZ10\nM5\nM30\n"
                .to_string(),
            &["--tool", "1", "--spindle", "3000", "--convert-units"][..],
            ":3:",
            "the program has no feed moves",
        ),
        (
            "g28-end.nc",
            "G20 G90\nT1 M6\nS3000 M3\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F10.\nX1.\nG0 Z1.\nG28\nM30\n"
                .to_string(),
            &["--tool", "1", "--spindle", "3000"][..],
            ":8:",
            "with no axes named (every axis sent home) cannot be placed on the part: keep only Z retracts in machine coordinates; remove the line (a mill program homes this way",
        ),
    ] {
        std::fs::remove_file(&out).ok();
        let o = post(name, &body, extra);
        let err = stderr(&o);
        assert!(!o.status.success(), "{name}: {err}");
        assert!(err.contains(at) && err.contains(what), "{name}: {err}");
        assert!(!err.contains("check the paths and free space"), "{name}: {err}");
        assert!(!out.exists(), "{name}: nothing is written");
    }
    // Each posts once the named thing is mended.
    for (name, body, extra) in [
        (
            "t2-h2-ok.nc",
            two_tools("G0 G43 H2 Z1.\n"),
            &["--tool", "1", "--length-offset", "1", "--spindle", "3000"][..],
        ),
        (
            "g28-removed.nc",
            "G20 G90\nT1 M6\nS3000 M3\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F10.\nX1.\nG0 Z1.\nM30\n"
                .to_string(),
            &["--tool", "1", "--spindle", "3000"][..],
        ),
    ] {
        let o = post(name, &body, extra);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
    }
    // A machining program's feed before its M3 (GrblGru's `G1 F200 Z25` start) is
    // travel, said in a spindle's words (it was "made with the laser off").
    let o = post(
        "feed-before-m3.nc",
        "G20 G90\nG1 Z1. F20.\nT1 M6\nS3000 M3\nG0 X0 Y0 Z0.1\nG1 Z-0.1 F10.\nX1.\nG0 Z1.\nM30\n",
        &["--tool", "1", "--spindle", "3000"],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(":2: a feed made with the spindle stopped") && !err.contains("laser"),
        "{err}"
    );
}

/// Finding 56: a printer's program that gives no G20/G21 (Cura never writes G21) was
/// posted for an inch machine as inches, 25.4 times its size, with one warning at the
/// end; a firmware reads it in millimetres (Marlin's `INCH_MODE_SUPPORT` is off by
/// default; RepRapFirmware, Klipper and Sailfish work in mm). Under a printer's flavour
/// such a program is now read in mm: refused on the inch machine without
/// `--convert-units` (located, nothing written), and with it the 10 mm square is posted
/// 10/25.4 in on a side, and verifies.
#[test]
fn a_printer_s_program_without_units_is_read_in_millimetres() {
    let path = finding("56-printer-program-without-units.gcode");
    let p = path.to_str().expect("utf8");
    let work = tempdir("printer-units");
    let out = work.join("posted.nc");
    let o_ = out.to_str().expect("utf8");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--e-extrusion",
        p,
        "-o",
        o_,
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("56-printer-program-without-units.gcode:11: the program is in millimetres but the machine is in inches"),
        "{err}"
    );
    assert!(!out.exists());
    let opts = [
        "--machine",
        "fadal-lamp",
        "--e-extrusion",
        "--convert-units",
    ];
    let mut a = vec!["post"];
    a.extend_from_slice(&opts);
    a.extend([p, "-o", o_]);
    let o = lampost(&a);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("read as millimetres (a printer's firmware works in mm"),
        "{}",
        stderr(&o)
    );
    // The deposit's X and Y words (between laser on and off) span 10 mm in inches.
    let text = std::fs::read_to_string(&out).expect("posted");
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    let mut on = false;
    for l in text.lines() {
        on = (on || l.starts_with("M71")) && !l.starts_with("M72");
        for w in l.split_whitespace() {
            let v = |s: &str| s.parse::<f64>().ok();
            match (on, w.split_at(1)) {
                (true, ("X", n)) => xs.extend(v(n)),
                (true, ("Y", n)) => ys.extend(v(n)),
                _ => {}
            }
        }
    }
    let span = |v: &[f64]| {
        v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
    };
    assert!((span(&xs) - 10.0 / 25.4).abs() < 2e-4, "{xs:?}\n{text}");
    assert!((span(&ys) - 10.0 / 25.4).abs() < 2e-4, "{ys:?}\n{text}");
    let mut v = vec!["verify"];
    v.extend_from_slice(&opts);
    v.extend([p, o_]);
    let o = lampost(&v);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Finding 58: Fanuc's and Haas's G87 bores back, upward, from R below the part to Z
/// above it (Fusion's Fanuc post writes `G87 … Z-15.8 R-16. Q0.01`); lampost refused it
/// in every flavour, "the hole bottom Z is above the R plane", and the trace stopped.
/// Under `fanuc` and `haas` it is now passed through with the cycle's warning (as every
/// G87 is: not simulated), and the post refuses it as a cycle it cannot write;
/// LinuxCNC's G87 gives the bottom in Z, so `linuxcnc` still refuses Z above R.
#[test]
fn fanuc_s_back_boring_cycle_bores_upward_from_r() {
    let path = finding("58-fanuc-g87-back-boring.nc");
    let p = path.to_str().expect("utf8");
    for flavor in ["fanuc", "haas"] {
        let o = lampost(&["check", "--flavor", flavor, p]);
        assert!(o.status.success(), "{flavor}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("0 error(s)"),
            "{flavor}: {}",
            stderr(&o)
        );
    }
    // (Its Q and P, which no LinuxCNC code of the block reads, are refused first, as
    // rs274 refuses them.)
    let o = lampost(&["check", "--flavor", "linuxcnc", p]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains(":13:"), "{}", stderr(&o));
    let no_q = std::fs::read_to_string(&path)
        .expect("fixture")
        .replace(" Q0.01", "")
        .replace(" P0 ", " ");
    let work = tempdir("g87-no-q");
    let f = work.join("no-q.nc");
    std::fs::write(&f, no_q).expect("writes");
    let o = lampost(&["check", "--flavor", "linuxcnc", f.to_str().expect("utf8")]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("above the R plane"), "{}", stderr(&o));
    let work = tempdir("g87");
    let out = work.join("posted.nc");
    let o = lampost(&[
        "post",
        "--flavor",
        "fanuc",
        "--machine",
        "fadal-lamp",
        "--process",
        "machine",
        "--tool",
        "4",
        "--length-offset",
        "4",
        "--spindle",
        "5000",
        "--convert-units",
        p,
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains(":13: canned cycle G87 cannot be posted"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

/// Finding 59: LinuxCNC's analog output sets a laser's power along the moves
/// (`G1 X5 M67 E2 Q25`, LinuxCNC's laser examples); E there is the output's number.
/// Under `linuxcnc` it was refused, "LinuxCNC reads E only with G76", and `auto` (which
/// took the program for FADAL's) read it as a fixture offset. The E of `M66`, `M67` and
/// `M68` is now theirs under `linuxcnc`, and such a code with its E is evidence of
/// LinuxCNC for `auto`; the moves equal rs274's.
#[test]
fn linuxcnc_s_analog_output_e_is_its_number() {
    let path = finding("59-linuxcnc-analog-output-e.ngc");
    let o = lampost(&["check", path.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("flavour linuxcnc (auto: an input or analog output code"),
        "{}",
        stderr(&o)
    );
    let work = tempdir("m67");
    let moves = equal_to_rs274(&path, &work, &["linuxcnc", "auto"]);
    assert_eq!(moves.len(), 6, "{moves:?}");
}

/// Finding 60: PrusaSlicer's MK3 start code (Prusa firmware) was refused at its
/// `G80 X109.746 Y89.7458 W30.5083 H30.5083` ("axis words but no motion mode is active",
/// "add G0 or G1"): on a printer G80 is Prusa's mesh bed levelling, its words the area
/// probed; and `G28 W` (home every axis without levelling) was traced as homing a W axis,
/// X, Y and Z left where they were. Now, in a printer's program, G80 is named as the
/// levelling (not simulated; the post refuses it, as G29), and `G28 W` homes every axis.
#[test]
fn prusa_s_mesh_levelling_and_homing_are_read_as_prusa_s() {
    let path = finding("60-prusa-g80-and-g28-w.gcode");
    let p = path.to_str().expect("utf8");
    let o = lampost(&["check", p]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("G80 (Prusa firmware's mesh bed levelling"),
        "{}",
        stderr(&o)
    );
    let doc = trace_json("auto", &path);
    let e = ends(&doc);
    assert_eq!(
        e[..3],
        [[10.0, 10.0, 5.0], [0.0, 0.0, 0.0], [0.0, -3.0, 0.0]],
        "{e:?}"
    );
    let work = tempdir("prusa-g80");
    let out = work.join("posted.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        p,
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains(":12:"), "{}", stderr(&o));
    assert!(!out.exists());
}

/// Finding 61: under `linuxcnc`, blocks rs274 refuses were read without a word (a Fanuc
/// post's output read as LinuxCNC's): a Q no code of the block reads (`G84 … Q3.`),
/// G86 begun without its dwell P, and a motion code beside G28 (`G0 G28 G91 Z0.`,
/// which Fanuc reads). Each is now refused where rs274 refuses it, at the same line;
/// the other flavours read them as before.
#[test]
fn linuxcnc_refuses_what_rs274_refuses_of_a_block_s_codes() {
    let work = tempdir("linuxcnc-parity");
    for (name, line, what) in [
        (
            "G98 G84 X25. Y10. Z-16. R4. P0 Q3. F800.",
            4,
            "no code of the block reads Q",
        ),
        ("G86 X-25. Y10. Z-16. R4. F400.", 4, "dwell time P missing"),
        (
            "G0 G28 G91 Z0.",
            4,
            "two G-codes in one block that both use the axis words",
        ),
    ] {
        let f = work.join("p.ngc");
        let text = format!("G21 G90 G17 G94\nS1000 M3\nG0 X0 Y0 Z10\n{name}\nG80\nG90\nM2\n");
        std::fs::write(&f, &text).expect("writes");
        let p = f.to_str().expect("utf8");
        let o = lampost(&["check", "--flavor", "linuxcnc", p]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{name}: {err}");
        assert!(
            err.contains(&format!("p.ngc:{line}:")) && err.contains(what),
            "{name}: {err}"
        );
        for flavor in ["fanuc", "haas"] {
            let o = lampost(&["check", "--flavor", flavor, p]);
            assert!(o.status.success(), "{name} as {flavor}: {}", stderr(&o));
        }
        if require_rs274().is_some() {
            let (out, _) = rs274_exec(&f, &work);
            let said = format!(
                "{}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            let after = said.rsplit("executing").next().unwrap_or("");
            assert!(after.contains(name), "rs274 on {name}: {said}");
        }
    }
}

/// The length a GRBL laser burns along `text` (laser mode, `$32=1`): feeds (G1, modal)
/// made with M3 or M4 in force at a power S above 0 (S modal), in G90 or G91; written
/// here from GRBL's documented rules, apart from lampost's reading.
fn grbl_burn_length(text: &str) -> f64 {
    let (mut pos, mut abs, mut feed, mut on, mut s) = ([0.0f64; 3], true, false, false, 0.0);
    let mut burnt = 0.0;
    for raw in text.lines() {
        let line = raw.split(';').next().unwrap_or("").to_ascii_uppercase();
        let mut words = Vec::new();
        let b = line.as_bytes();
        let mut i = 0;
        while i < b.len() {
            if b[i].is_ascii_alphabetic() {
                let mut j = i + 1;
                while j < b.len() && (b[j].is_ascii_digit() || matches!(b[j], b'.' | b'-' | b'+')) {
                    j += 1;
                }
                if let Ok(v) = line[i + 1..j].parse::<f64>() {
                    words.push((b[i], v));
                }
                i = j;
            } else {
                i += 1;
            }
        }
        let mut to = pos;
        let mut moved = false;
        for &(l, v) in &words {
            match (l, v) {
                (b'G', 0.0) => feed = false,
                (b'G', 1.0) => feed = true,
                (b'G', 90.0) => abs = true,
                (b'G', 91.0) => abs = false,
                (b'M', 3.0 | 4.0) => on = true,
                (b'M', 5.0) => on = false,
                (b'S', v) => s = v,
                _ => {}
            }
        }
        for &(l, v) in &words {
            if let Some(k) = b"XYZ".iter().position(|&a| a == l) {
                to[k] = if abs { v } else { pos[k] + v };
                moved = true;
            }
        }
        if moved {
            let d =
                ((to[0] - pos[0]).powi(2) + (to[1] - pos[1]).powi(2) + (to[2] - pos[2]).powi(2))
                    .sqrt();
            if feed && on && s > 0.0 {
                burnt += d;
            }
            pos = to;
        }
    }
    burnt
}

/// The length a posted program (nrc-lc: ISO words, `M71` laser on, `M72` off, absolute
/// X, Y, Z) deposits along.
fn posted_deposit_length(text: &str) -> f64 {
    let (mut pos, mut on, mut total) = ([0.0f64; 3], false, 0.0);
    for line in text.lines() {
        if line.contains('(') {
            continue;
        }
        let mut to = pos;
        for w in line.split_whitespace() {
            let (l, v) = w.split_at(1);
            match (l, v.parse::<f64>()) {
                ("M", Ok(71.0)) => on = true,
                ("M", Ok(72.0)) => on = false,
                ("X", Ok(v)) => to[0] = v,
                ("Y", Ok(v)) => to[1] = v,
                ("Z", Ok(v)) => to[2] = v,
                _ => {}
            }
        }
        let d =
            ((to[0] - pos[0]).powi(2) + (to[1] - pos[1]).powi(2) + (to[2] - pos[2]).powi(2)).sqrt();
        if on {
            total += d;
        }
        pos = to;
    }
    total
}

/// Finding 62: a laser program's feeds at `S0` before its first power above S0 were
/// deposited (LightBurn's image rows and overscans at `S0`, which GRBL burns nothing
/// along; every recent LightBurn raster starts so): the S0 rule held only after the
/// program had run at a power. The post now reads ahead for the first power, as it does
/// for the first M3/M4: a program that runs its laser at a power deposits nothing at S0;
/// one that never gives S deposits along every feed made with it on, as before. The
/// oracle is GRBL's laser mode written out in the test: the posted program deposits
/// exactly the length GRBL burns, on the fixture (5 mm, not 25.2) and on LightBurn
/// 0.9.09's real image (`lightburn/laser_love-0.9.09.nc`), and verifies.
#[test]
fn a_laser_s_feeds_at_s0_before_its_first_power_burn_nothing() {
    let work = tempdir("s0-before-power");
    for path in [
        finding("62-laser-s0-before-first-power.nc"),
        root().join("fixtures/real-programs/lightburn/laser_love-0.9.09.nc"),
    ] {
        let p = path.to_str().expect("utf8");
        let out = work.join("posted.nc");
        let o_ = out.to_str().expect("utf8");
        let o = lampost(&["post", "--machine", "nrc-lc", p, "-o", o_]);
        assert!(o.status.success(), "{p}: {}", stderr(&o));
        let input = std::fs::read_to_string(&path).expect("input");
        let posted = std::fs::read_to_string(&out).expect("posted");
        let (want, got) = (grbl_burn_length(&input), posted_deposit_length(&posted));
        assert!(want > 0.0, "{p}");
        assert!(
            (want - got).abs() < 1e-6 * want.max(1.0) + 1e-3,
            "{p}: GRBL burns {want} mm, posted {got} mm"
        );
        let o = lampost(&["verify", "--machine", "nrc-lc", p, o_]);
        assert!(o.status.success(), "{p}: {}", stderr(&o));
    }
    // A deposit run stretched over the fixture's S0 row (X5 to X10 at Y0.2) is caught.
    let path = finding("62-laser-s0-before-first-power.nc");
    let p = path.to_str().expect("utf8");
    let out = work.join("posted.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        p,
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).expect("posted");
    let stretched = text.replacen(" X-5.000\n", " X-10.000\n", 1);
    assert_ne!(stretched, text, "the deposit run is where it is expected");
    let tampered = work.join("tampered.nc");
    std::fs::write(&tampered, stretched).expect("writes");
    let o = lampost(&[
        "verify",
        "--machine",
        "nrc-lc",
        p,
        tampered.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success(), "a deposit along the S0 row passed");
    // M3 with no S at all: a bare path, deposited along every feed, as before.
    let bare = work.join("bare.nc");
    std::fs::write(
        &bare,
        "G21 G90\nM3\nG0 X0 Y0\nG1 X10 F3000\nG1 Y10\nM5\nM2\n",
    )
    .expect("writes");
    let out = work.join("bare-posted.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        bare.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let got = posted_deposit_length(&std::fs::read_to_string(&out).expect("posted"));
    assert!((got - 20.0).abs() < 1e-6, "{got}");
}

/// Finding 63: a slicer's extruder change (`T0` … `T1`: PrusaSlicer's MMU, Cura's dual
/// extrusion, Orca's and Bambu's filament changes; Marlin, RepRapFirmware and Klipper
/// change tools on a bare T) was posted as one material, with no word: the interpreter
/// changed tools only on M6, and T0 counted as no tool. In a printer's program a bare T
/// now changes the tool, T0 is the first extruder, and a deposit made with another
/// extruder than the section's first is refused at its line, nothing written. A program
/// printing with one extruder (T1 alone, travel with any) still posts.
#[test]
fn a_slicer_s_extruder_change_is_refused_not_merged() {
    let path = finding("63-slicer-extruder-change.gcode");
    let p = path.to_str().expect("utf8");
    let work = tempdir("extruder-change");
    let out = work.join("posted.nc");
    let o_ = out.to_str().expect("utf8");
    let o = lampost(&["post", "--machine", "nrc-lc", p, "-o", o_]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("63-slicer-extruder-change.gcode:16: a deposit made with extruder T1, after deposits made with T0"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
    let one = work.join("one.gcode");
    let text = std::fs::read_to_string(&path)
        .expect("fixture")
        .replace("\nT0\n", "\n");
    let text = text.replace("G1 X10 E1 F1200", "G1 X10 F1200");
    std::fs::write(&one, text).expect("writes");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        one.to_str().expect("utf8"),
        "-o",
        o_,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Finding 64: a greyscale image's powers (LightBurn's `S4` to `S949`) were posted at one
/// power without a word. The post deposits at the machine's power (`--power`); it now
/// says so once a section, naming the input's range and the first line that differs.
#[test]
fn a_laser_s_varying_power_is_named() {
    let path = finding("64-laser-greyscale-power.nc");
    let p = path.to_str().expect("utf8");
    let work = tempdir("greyscale");
    let out = work.join("posted.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        p,
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(":7: the input's laser power varies (S4 to S949"),
        "{}",
        stderr(&o)
    );
}

/// Two messages the sixth probe found misleading. A `G90` under `M83` was warned of
/// ("Marlin 2 reads E as positions") even where the slicer's next line is `M83`
/// (PrusaSlicer's start code); the doubt is now said only when an E word is read by it.
/// A Klipper macro after the first deposit (a timelapse frame in the layer-change code)
/// was sent to the start and end code; it is now sent to the per-layer code.
#[test]
fn printer_messages_of_the_sixth_probe_point_the_right_way() {
    let work = tempdir("sixth-probe-printer");
    let out = work.join("posted.nc");
    let o_ = out.to_str().expect("utf8");
    let write = |name: &str, body: &str| {
        let p = work.join(name);
        std::fs::write(&p, body).expect("writes");
        p
    };
    let head = "; generated by PrusaSlicer 2.6.0\nG21\nM83\nG90\n";
    let settled = write(
        "settled.gcode",
        &format!("{head}M83\nG1 Z0.2 F600\nG1 X10 Y0 E1 F1200\nG1 X0 E1\n"),
    );
    let doubted = write(
        "doubted.gcode",
        &format!("{head}G1 Z0.2 F600\nG1 X10 Y0 E1 F1200\nG1 X0 E1\n"),
    );
    let check = |p: &Path| lampost(&["check", "--flavor", "marlin", p.to_str().expect("utf8")]);
    let o = check(&settled);
    assert!(!stderr(&o).contains("G90 while M83"), "{}", stderr(&o));
    let o = check(&doubted);
    assert!(stderr(&o).contains(":4:"), "{}", stderr(&o));
    assert!(stderr(&o).contains("G90 while M83 holds"), "{}", stderr(&o));
    for (name, at, mac, hint) in [
        (
            "start.gcode",
            ":6:",
            "PRINT_START",
            "remove the printer's start and end code",
        ),
        (
            "layer.gcode",
            ":7:",
            "TIMELAPSE_TAKE_FRAME",
            "per-layer custom G-code",
        ),
    ] {
        let body = if name == "start.gcode" {
            format!("{head}M83\n{mac}\nG1 Z0.2 F600\nG1 X10 Y0 E1 F1200\n")
        } else {
            format!("{head}M83\nG1 X10 Y0 Z0.2 E1 F1200\n{mac}\nG1 Z0.4\nG1 X0 E1\n")
        };
        let input = write(name, &body);
        let o = lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            input.to_str().expect("utf8"),
            "-o",
            o_,
        ]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{name}: {err}");
        assert!(
            err.contains(at) && err.contains(mac) && err.contains(hint),
            "{name}: {err}"
        );
        assert!(!out.exists(), "{name}: nothing is written");
    }
}

/// Finding 45: a line starting `# ` (a laser rig's `# 4mm x 4mm square outline`) was
/// named a FADAL macro statement under every flavour. LinuxCNC reads blanks after a `#`
/// as nothing (`# 1 = 5` sets #1: it was traced as X0, not X5) and refuses a `#` line
/// that sets no parameter, as rs274 does; a printer's firmware ignores the line as an
/// unknown command.
#[test]
fn a_hash_line_is_read_as_each_control_reads_it() {
    let work = tempdir("hash-line");
    let set = work.join("set.ngc");
    std::fs::write(&set, "# 1 = 5\nG0 X#1\nM2\n").expect("writes");
    let note = work.join("note.ngc");
    std::fs::write(&note, "# 4mm x 4mm square outline\nG21 G90\nG0 X1\nM2\n").expect("writes");
    let doc = trace_json("linuxcnc", &set);
    assert_eq!(ends(&doc), [[5.0, 0.0, 0.0]]);
    let o = lampost(&[
        "check",
        "--flavor",
        "linuxcnc",
        note.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("note.ngc:1:1"), "{}", stderr(&o));
    if require_rs274().is_some() {
        equal_to_rs274(&set, &work, &["linuxcnc"]);
        let e = rs274_to_end(&note, &work).expect_err("rs274 refuses it");
        assert!(e.contains("Equal sign missing"), "{e}");
    }
    let o = lampost(&["check", "--flavor", "marlin", note.to_str().expect("utf8")]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("no command a printer's firmware runs") && !err.contains("FADAL"),
        "{err}"
    );
}

/// Finding 65: a laser-DED program for LinuxCNC switches its laser with its own M-code
/// (`M201 (EMON)`, `M201 (SDC 36.7)`, `M201 (SDC 0)`) and never with M3/M4. Taken for a
/// bare path, every feed was deposited without a word: its 20 mm `G1 Z20` lift as a
/// wall, its opening `G1 Z5` as a pillar at the origin. An M-code the post leaves out,
/// met between the feeds of such a program, is now refused at its line (nothing
/// written); written as M3/M5, the program posts its track alone.
#[test]
fn a_laser_switched_by_the_machine_s_own_m_code_is_refused_not_deposited() {
    let path = finding("65-ded-laser-m-code.gcode");
    let work = tempdir("ded-m-code");
    let out = work.join("posted.nc");
    let o_ = out.to_str().expect("utf8");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        path.to_str().expect("utf8"),
        "-o",
        o_,
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("65-ded-laser-m-code.gcode:4: M201 between the feeds")
            && err.contains("write M3"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written");
    // As the message says: the switch written as M3 (with its power) and M5.
    let text = std::fs::read_to_string(&path).expect("fixture");
    let mended = text
        .replace("M201 (EMON)", "")
        .replace("M201 (SDC 36.7)", "M3 S367")
        .replace("M201 (SDC 0)", "M5");
    let input = work.join("mended.gcode");
    std::fs::write(&input, mended).expect("writes");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        input.to_str().expect("utf8"),
        "-o",
        o_,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    // One run: the track from X-15.5 to X-5.5 (mirrored by the cell's C=0 frame).
    assert_eq!(posted.matches("M73").count(), 1, "{posted}");
    let run: Vec<&str> = posted
        .lines()
        .skip_while(|l| !l.contains("M73"))
        .take_while(|l| !l.contains("M72"))
        .collect();
    assert!(
        run.iter().any(|l| l.contains("X5.500")) && !run.iter().any(|l| l.contains('Z')),
        "{run:?}"
    );
}

/// Finding 66: a straight feed of no length after travel (the DED program's `G1 Z20
/// F2000` to where the head already is, a CAM system's point repeated after a rapid)
/// was posted as a run of its own: the laser turned on and off over one spot. It is now
/// travel; one inside a run stays part of the run (no lift, no second laser-on).
#[test]
fn a_feed_of_no_length_after_travel_burns_nothing() {
    let path = finding("66-zero-length-feed.nc");
    let work = tempdir("zero-length-feed");
    let out = work.join("posted.nc");
    let o_ = out.to_str().expect("utf8");
    let post = |input: &Path| {
        lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            input.to_str().expect("utf8"),
            "-o",
            o_,
        ])
    };
    let o = post(&path);
    assert!(o.status.success(), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert_eq!(posted.matches("M73").count(), 1, "{posted}");
    let o = lampost(&[
        "verify",
        "--machine",
        "nrc-lc",
        path.to_str().expect("utf8"),
        o_,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Tampered: the laser turned on and off over the first point again.
    let tampered = posted.replacen(
        "N40 X-10.000 Y0.000",
        "N40 X0.000 Y0.000\nG1 Z20.000 F2000\nM71 S1000\nM73\nX0.000\nM72\nM74\nG0 Z150.000\nX-10.000 Y0.000",
        1,
    );
    assert_ne!(tampered, posted);
    let bad = work.join("tampered.nc");
    std::fs::write(&bad, tampered).expect("writes");
    let o = lampost(&[
        "verify",
        "--machine",
        "nrc-lc",
        path.to_str().expect("utf8"),
        bad.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success(), "the blob is caught: {}", stderr(&o));
    // Inside a run a repeated point changes nothing.
    let inside = work.join("inside.nc");
    std::fs::write(
        &inside,
        "G21 G90\nG0 X0 Y0 Z1\nM3 S500\nG1 Z0 F600\nG1 X10\nG1 X10\nG1 X20\nG0 Z5\nM5\nM2\n",
    )
    .expect("writes");
    let o = post(&inside);
    assert!(o.status.success(), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert_eq!(posted.matches("M73").count(), 1, "{posted}");
}

/// Findings 67–70 (the eighth probe's slicer, laser and LinuxCNC programs). 67: Prusa's
/// XL start code picks its tool with `T0 S1 L0 D0` and parks it with `P0 S1 L2 D0`; the
/// L was read as a subprogram call in every flavour and the post refused ("inline
/// them"). A printer's L is now its command's option, and `P0` is named as Prusa's tool
/// park, whose moves only the firmware knows (refused by the post at its line). 68:
/// Marlin's inline laser mode `M3 I` / `M5 I` was refused ("the letter I has no number");
/// it is now read as M3/M5, as Marlin reads it, outside `linuxcnc` (rs274 refuses it).
/// 69: Bambu's `T1000` (its nozzle coordinate space) was taken for an extruder, and a
/// one-filament print refused at its first wall as two materials; it is now named at its
/// line as a coordinate space only the firmware knows. 70: a QtPlasmaC feed read from a
/// HAL pin (`F#<_hal[plasmac.cut-feed-rate]>`) read 0 and was blamed on FreeCAD's F0; it
/// is refused at the read, as rs274 refuses it.
#[test]
fn codes_of_the_eighth_probe_are_read_as_their_controls_read_them() {
    let work = tempdir("eighth-probe");
    let out = work.join("posted.nc");
    let o_ = out.to_str().expect("utf8");
    let post = |p: &Path| {
        lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            p.to_str().expect("utf8"),
            "-o",
            o_,
        ])
    };
    // 67: refused at the park alone; without it the tool picks post.
    let xl = finding("67-prusa-xl-tool-pick.gcode");
    let o = lampost(&["check", xl.to_str().expect("utf8")]);
    assert!(
        o.status.success() && !stderr(&o).contains("subprogram"),
        "{}",
        stderr(&o)
    );
    let o = post(&xl);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(":9: `P0 S1 L2 D0`") && err.contains("own macro or command"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written");
    let picks = work.join("xl-picks.gcode");
    let text = std::fs::read_to_string(&xl).expect("fixture");
    std::fs::write(&picks, text.replace("P0 S1 L2 D0 ; park the tool\n", "")).expect("writes");
    let o = post(&picks);
    assert!(o.status.success(), "{}", stderr(&o));
    // 68: two burns, at S100 and at S200, as Marlin's laser mode makes them.
    let inline = finding("68-marlin-inline-laser.gcode");
    let o = post(&inline);
    assert!(o.status.success(), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert_eq!(posted.matches("M73").count(), 2, "{posted}");
    let o = lampost(&[
        "check",
        "--flavor",
        "linuxcnc",
        inline.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success(), "rs274 refuses `M3 I`: {}", stderr(&o));
    // 69: named at the T1000.
    std::fs::remove_file(&out).ok();
    let bambu = finding("69-bambu-t1000-nozzle-space.gcode");
    let o = post(&bambu);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(":8: T1000") && err.contains("coordinate space"),
        "{err}"
    );
    assert!(!err.contains("two materials"), "{err}");
    assert!(!out.exists(), "nothing is written");
    // 70: refused at the read, as rs274 refuses it.
    let hal = finding("70-hal-pin-feed.ngc");
    let o = lampost(&["check", hal.to_str().expect("utf8")]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("70-hal-pin-feed.ngc:2:2") && err.contains("HAL pin"),
        "{err}"
    );
    assert!(!err.contains("FreeCAD"), "{err}");
    if require_rs274().is_some() {
        let e = rs274_to_end(&hal, &work).expect_err("rs274 refuses it");
        assert!(e.contains("not defined"), "{e}");
    }
}

/// Findings of h47 under `linuxcnc` (what `auto` picks on a `;` comment): a laser-DED
/// program's `G90 G54 G64 G50 G17 …` was read with no word, and so were G9, G15, G50.1,
/// G67, G69, G187, G255 and the codes warned as not simulated (G12, G16, G51, G68, G65),
/// which rs274 refuses ("Unknown g code used", from G100 "G-code out of range"); and
/// G10 with no L, G52/G92 and G5/G5.1 with no axis word, G96 with no S and `G28 X` (a
/// letter with no number). Each is now refused at its word. The codes lampost takes are
/// those rs274 takes, on every G0–G199.9 (G17.1, G18.1 and G19.1, the U/V/W planes,
/// aside: lampost refuses them), rs274 run on every seventh code and each named here.
#[test]
fn linuxcnc_refuses_the_g_codes_it_does_not_have() {
    let work = tempdir("linuxcnc-g-codes");
    let prog = work.join("g.ngc");
    let mut codes: Vec<String> = Vec::new();
    for n in 0..200 {
        codes.push(format!("{n}"));
        if n < 100 {
            codes.extend((1..10).map(|d| format!("{n}.{d}")));
        }
    }
    let named = [
        "9", "15", "50", "50.1", "67", "69", "187", "255", "12", "16", "51", "68", "65",
    ];
    let rs274 = require_rs274().is_some();
    for (k, code) in codes.iter().map(String::as_str).chain(named).enumerate() {
        std::fs::write(&prog, format!("G21 G90 G17\nF100\nG{code}\nM2\n")).expect("writes");
        let o = lampost(&[
            "check",
            "--flavor",
            "linuxcnc",
            prog.to_str().expect("utf8"),
        ]);
        let unknown = stderr(&o).contains(&format!("unknown G-code G{code}"));
        assert!(!unknown || !o.status.success(), "G{code}: {}", stderr(&o));
        let uvw = matches!(code, "17.1" | "18.1" | "19.1");
        if rs274 && !uvw && (k % 7 == 0 || k >= codes.len()) {
            let refused = match rs274_to_end(&prog, &work) {
                Err(e) => e.contains("Unknown g code") || e.contains("out of range"),
                Ok(_) => false,
            };
            assert_eq!(unknown, refused, "G{code}: lampost and rs274 differ");
        }
    }
    for block in ["G10 P1 X0", "G52", "G92", "G5", "G5.1", "G96", "G28 X"] {
        std::fs::write(&prog, format!("G21 G90 G17\nF100\n{block}\nM2\n")).expect("writes");
        let o = lampost(&[
            "check",
            "--flavor",
            "linuxcnc",
            prog.to_str().expect("utf8"),
        ]);
        assert!(!o.status.success(), "{block}: {}", stderr(&o));
        assert!(stderr(&o).contains("g.ngc:3:"), "{block}: {}", stderr(&o));
        if rs274 {
            assert!(rs274_to_end(&prog, &work).is_err(), "rs274 refuses {block}");
        }
    }
}

/// h47: a machining program's dwell after M3 (EagleCAD's `stepcraft.ulp` writes `G04
/// P4000` after `S19500 M03`, the spindle's spin-up) was left out with a laser's reason
/// ("with the laser on, the head would stand over one spot"). It is now said in a
/// spindle's words.
#[test]
fn a_machining_dwell_is_explained_in_a_spindle_s_words() {
    let work = tempdir("machining-dwell");
    let input = work.join("spin-up.nc");
    std::fs::write(
        &input,
        "G21 G90\nG0 X0 Y0 Z5\nS19500 M03\nG04 P4000\nG1 Z-0.5 F100\nG1 X10\nG0 Z5\nM05\nM30\n",
    )
    .expect("writes");
    let out = work.join("posted.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--convert-units",
        "--process",
        "machine",
        "--head",
        "spindle",
        "--spindle",
        "19500",
        input.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(":4: G4 P4000: the dwell is left out")
            && err.contains("spindle reach its speed"),
        "{err}"
    );
    assert!(!err.contains("laser"), "{err}");
}

/// Finding 71 (h49): a tall part with sloped walls (a 150 mm frustum at 0.5 mm layers)
/// turns the tool axis a full turn about C each layer; the per-point post kept C
/// continuous across every laser-off move, so C wound past the ISO word (C-100001.25 at
/// layer 278) and the post was refused, its help blaming feeds and units. An unlimited
/// rotary wound past ten turns is now unwound on the next laser-off move, at the safe
/// height: C stays within ±(3600 + 360)°, and the program verifies (planned here at 4 mm
/// layers, 37 of them: 13,000° of C unwound).
#[test]
fn a_rotary_wound_by_a_tall_part_is_unwound_between_runs() {
    let work = tempdir("frustum-unwind");
    let path = work.join("frustum.csv");
    let stl = finding("71-frustum-150.stl");
    let o = lampost(&[
        "plan",
        "path",
        stl.to_str().expect("utf8"),
        "--layer",
        "4",
        "--bead",
        "1",
        "-o",
        path.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = work.join("posted.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        path.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    let cs: Vec<f64> = posted
        .lines()
        .filter_map(|l| l.split_whitespace().find_map(|w| w.strip_prefix('C')))
        .filter_map(|v| v.parse().ok())
        .collect();
    let wound = cs.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    assert!(cs.len() > 1000 && wound <= 3960.0, "C reaches {wound}°");
    // Unwound at an index (the safe height), never along a run.
    let unwinds = posted.lines().filter(|l| l.contains("(INDEX)")).count();
    assert!(unwinds >= 2, "{unwinds} indexes");
    let o = lampost(&[
        "verify",
        "--machine",
        "nrc-lc",
        path.to_str().expect("utf8"),
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Finding 72 (h49): `post --part` found a real collision (the approach onto a run under
/// a ring comes down through it) and reported it as a failed self-verification, whose
/// help says "this is a lampost fault, or INPUT and POSTED do not belong together". A
/// collision with the part is now an error of its own, with what to do.
#[test]
fn a_collision_with_the_part_is_no_lampost_fault() {
    let work = tempdir("part-collision");
    let out = work.join("posted.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        finding("72-under-ring.ngc").to_str().expect("utf8"),
        "--part",
        finding("72-ring.stl").to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("the posted path meets the part: ") && err.contains("72-under-ring.ngc:5:"),
        "{err}"
    );
    assert!(
        !err.contains("lampost fault") && err.contains("stands in the way"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written");
}

/// h47: `check` after a refused feed (`F0` then `G1 X10`) read the next arc from where
/// the refused move began, and reported the arc's radii as differing ("check the arc's
/// end point and I/J/K"), though the arc is right from X10: 4 of the 14 errors on
/// QtPlasmaC's `metric_wrench.ngc`. A refused feed now ends where it was programmed to,
/// as a refused arc already did.
#[test]
fn a_refused_feed_does_not_make_the_next_arc_wrong() {
    let work = tempdir("refused-feed");
    let p = work.join("f0.ngc");
    std::fs::write(&p, "G21 G90\nG0 X0 Y0\nF0\nG1 X10\nG3 X10 Y20 I0 J10\nM2\n").expect("writes");
    let o = lampost(&["check", p.to_str().expect("utf8")]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("f0.ngc:4:"), "{err}");
    assert!(!err.contains("radius at the start"), "{err}");
}

/// Finding 73 (h49): a closed cube with one face wound inwards (flipped normals) made
/// slicing refuse with "repair the mesh … or widen --stitch"; a wider stitch then planned
/// a loop of no area along the flipped face, deposited with the tool axis down. The help
/// now names the flipped faces and says why a stitch is no cure.
#[test]
fn flipped_faces_are_named_not_stitched() {
    let mesh = finding("73-cube-one-face-flipped.obj");
    let m = mesh.to_str().expect("utf8");
    for args in [
        vec!["plan", "slice", m, "--layer", "2"],
        vec!["plan", "path", m, "--layer", "2", "--check-only"],
    ] {
        let o = lampost(&args);
        let err = stderr(&o);
        assert!(!o.status.success(), "{args:?}: {err}");
        assert!(
            err.contains("4 edges join faces wound against each other (flipped faces)")
                && !err.contains("or widen --stitch"),
            "{args:?}: {err}"
        );
    }
}

/// Finding 74 (h49): a mesh in metres (Blender's, a robot's CAD: trimesh's
/// `ADIS16480.STL`) got no word of its units: `mesh info` printed a volume of 0.000004,
/// and slicing told the user to make the layer smaller. `--units m` now reads it (also
/// `post --part-units m`), `mesh info` notes a part under 1 mm across, and the slicing
/// error's help names `--units m`.
#[test]
fn a_mesh_in_metres_is_named_and_read() {
    let mesh = finding("74-box-in-metres.stl");
    let m = mesh.to_str().expect("utf8");
    let o = lampost(&["mesh", "info", m]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("--units m"), "{}", stderr(&o));
    let o = lampost(&["plan", "slice", m, "--layer", "0.5"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("read it with --units m"),
        "{}",
        stderr(&o)
    );
    let o = lampost(&["mesh", "info", m, "--units", "m"]);
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        out.contains("bounds -10.000000 -10.000000 0.000000 .. 10.000000 10.000000 10.000000"),
        "{out}"
    );
    assert!(!stderr(&o).contains("--units m"), "{}", stderr(&o));
    let o = lampost(&["plan", "slice", m, "--layer", "0.5", "--units", "m"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("layers 20"));
}

/// Finding 75 (h49): a UV sphere whose pole quads have coincident corners (as exporters
/// write them; trimesh's `capsule.obj`) was "open", its volume withheld, and slicing
/// warned of "0 boundary, 0 non-manifold, 0 inconsistent edges". Triangles with a
/// repeated vertex bound nothing: the sphere is closed, and its volume is the
/// divergence-theorem sum written out here over the file's faces.
#[test]
fn collapsed_pole_quads_leave_a_sphere_closed() {
    let path = finding("75-uvsphere-pole-quads.obj");
    let text = std::fs::read_to_string(&path).expect("fixture");
    let mut v: Vec<[f64; 3]> = Vec::new();
    let mut six_v = 0.0;
    for l in text.lines() {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.first() {
            Some(&"v") => v.push([1, 2, 3].map(|k| w[k].parse::<f64>().expect("number"))),
            Some(&"f") => {
                let ix: Vec<usize> = w[1..]
                    .iter()
                    .map(|t| {
                        t.split('/')
                            .next()
                            .expect("index")
                            .parse::<usize>()
                            .expect("index")
                            - 1
                    })
                    .collect();
                for k in 1..ix.len() - 1 {
                    let (a, b, c) = (v[ix[0]], v[ix[k]], v[ix[k + 1]]);
                    six_v += a[0] * (b[1] * c[2] - b[2] * c[1])
                        - a[1] * (b[0] * c[2] - b[2] * c[0])
                        + a[2] * (b[0] * c[1] - b[1] * c[0]);
                }
            }
            _ => {}
        }
    }
    let want = six_v / 6.0;
    let o = lampost(&["mesh", "info", "--json", path.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(doc["closed"], true, "{doc}");
    assert!(doc["degenerate_triangles"].as_u64() > Some(0), "{doc}");
    let got = doc["volume"].as_f64().expect("a volume");
    assert!(
        (got - want).abs() < 1e-9 * want.abs(),
        "{got} against {want}"
    );
    let o = lampost(&[
        "plan",
        "slice",
        path.to_str().expect("utf8"),
        "--layer",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("not a closed"), "{}", stderr(&o));
}

/// The session's fuzz findings. A machining program with no M3 and a machine's own
/// M-code between its feeds posted, and `verify` then refused it: verify's pass over the
/// input for the work's bounds read it as a deposition program (finding 65's refusal),
/// not for the process posted. And a position or arc centre beyond any number (a
/// slicer's reading takes exponents: `G91 G0 Z1.7e308` twice, G28's intermediate point,
/// `R1.7e308`) was traced as `inf`/`NaN`; each is now refused at its word.
#[test]
fn fuzz_findings_of_the_eighth_probe_session() {
    let work = tempdir("fuzz-findings-8");
    let input = work.join("no-m3.nc");
    std::fs::write(
        &input,
        "G21 G90\nG0 X0 Y0 Z5\nG1 Z-1 F100\nM71\nG1 X10\nG0 Z5\nM30\n",
    )
    .expect("writes");
    let out = work.join("posted.nc");
    let args = |cmd: &str| -> Vec<String> {
        let mut a: Vec<String> = [
            cmd,
            "--machine",
            "fadal-lamp",
            "--convert-units",
            "--process",
            "machine",
            "--head",
            "spindle",
            "--tool",
            "1",
            "--spindle",
            "3000",
        ]
        .map(String::from)
        .to_vec();
        a.push(input.to_str().expect("utf8").into());
        a
    };
    let mut post = args("post");
    post.extend(["-o".into(), out.to_str().expect("utf8").into()]);
    let o = lampost(&post.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    let mut verify = args("verify");
    verify.push(out.to_str().expect("utf8").into());
    let o = lampost(&verify.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    let big = "1.7976931348623157e308";
    for (name, body, at) in [
        (
            "g91",
            format!("G21 G90\nG0 X1 Y1 Z{big}\nG91 G0 Z{big}\nM30\n"),
            ":3:",
        ),
        (
            "g28",
            format!("G21 G90\nG0 X1 Y1 Z{big}\nG28 G91 Z{big}\nM30\n"),
            ":3:",
        ),
        (
            "r",
            format!("G21 G90\nG0 X1 Y1\nG1 X0 F100\nG3 X2 Y3 R{big}\nM30\n"),
            ":4:",
        ),
    ] {
        let p = work.join(format!("{name}.gcode"));
        std::fs::write(&p, body).expect("writes");
        let o = lampost(&["trace", "--flavor", "marlin", p.to_str().expect("utf8")]);
        let all = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
        assert!(!o.status.success(), "{name}: {all}");
        assert!(
            all.contains(at) && all.contains("beyond any number"),
            "{name}: {all}"
        );
        assert!(
            !all.contains("inf") && !all.contains("NaN"),
            "{name}: {all}"
        );
    }
}

/// Finding 76 (h48): a Slic3r program for a food printer drives its extruder as the U axis
/// (`G92 U0`, `G1 X30 Y10 U2.0014`); `check` said nothing and the post refused with "no
/// move extrudes" without naming U. A printer's U or V word is now warned of as A, B and
/// C are (finding 34), and the refusal's help names an extruder driven as an axis.
#[test]
fn a_printer_s_u_axis_extruder_is_named() {
    let path = finding("76-slic3r-u-axis-extruder.gcode");
    let p = path.to_str().expect("utf8");
    let o = lampost(&["check", p]);
    assert!(
        stderr(&o).contains(":7:12") && stderr(&o).contains("a paste or food printer with U"),
        "{}",
        stderr(&o)
    );
    let work = tempdir("u-axis-extruder");
    let out = work.join("posted.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        p,
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("U or V words on the printing moves"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

/// Finding 77: a double-sided export (every face of the block also there wound the other
/// way) sliced to no loop at all, and `plan slice` wrote an empty file with exit 0. The
/// twins are counted by `mesh info`, and slicing is refused, naming them.
#[test]
fn a_double_sided_mesh_is_named_and_not_sliced_to_nothing() {
    let path = finding("77-block-double-sided.stl");
    let p = path.to_str().expect("utf8");
    let o = lampost(&["mesh", "info", "--json", p]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(doc["triangles"], 24, "{doc}");
    assert_eq!(doc["twin_faces"], 24, "{doc}");
    let text = String::from_utf8_lossy(&lampost(&["mesh", "info", p]).stdout).into_owned();
    assert!(text.contains("twin faces 24"), "{text}");
    // The block itself has none.
    let block = root().join("fixtures/meshes/block.stl");
    let o = lampost(&["mesh", "info", "--json", block.to_str().expect("utf8")]);
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(doc["twin_faces"], 0, "{doc}");
    let dir = tempdir("finding-77");
    for cmd in ["slice", "path"] {
        let out = dir.join(format!("{cmd}.csv"));
        let o = lampost(&[
            "plan",
            cmd,
            p,
            "--layer",
            "10",
            "-o",
            out.to_str().expect("utf8"),
        ]);
        assert_eq!(o.status.code(), Some(1), "{cmd}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("the slices hold no loop; nothing written")
                && e.contains("24 of the 24 faces come twice")
                && e.contains("single-sided"),
            "{cmd}: {e}"
        );
        assert!(!out.exists(), "{cmd} wrote {}", out.display());
    }
    // Planes that miss a part say so.
    let o = lampost(&[
        "plan",
        "slice",
        block.to_str().expect("utf8"),
        "--layer",
        "10",
        "--first",
        "80",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the planes miss the part"),
        "{}",
        stderr(&o)
    );
}

/// Finding 78: `OFF8 6 12`, the vertex count written against the keyword (as ModelNet's
/// files have it), was refused as not starting with `OFF`. It is the cube it says.
#[test]
fn an_off_count_against_its_keyword_is_read() {
    let path = finding("78-off-count-after-keyword.off");
    let o = lampost(&["mesh", "info", "--json", path.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(doc["triangles"], 12, "{doc}");
    assert_eq!(doc["vertices"], 8, "{doc}");
    assert_eq!(doc["closed"], true, "{doc}");
    assert!(
        (doc["volume"].as_f64().expect("volume") - 1.0).abs() < 1e-12,
        "{doc}"
    );
    // A keyword with letters after it is still not OFF.
    let dir = tempdir("finding-78");
    let bad = dir.join("bad.off");
    std::fs::write(&bad, "OFFX 8 6 12\n").expect("write");
    let o = lampost(&["mesh", "info", bad.to_str().expect("utf8")]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("an OFF file starts with `OFF`"),
        "{}",
        stderr(&o)
    );
}

/// Finding 79 (h50): one `G4 S1` makes `auto` read a program as Marlin's, which implies
/// E as extrusion. A program with no E was refused as "no move extrudes" even when
/// machined, and the help said to leave out an option the user never gave. Machining now
/// cuts along the feeds (E has no say there); deposition still refuses, naming the
/// flavour `auto` chose and why, and what to give instead.
#[test]
fn a_printer_flavour_chosen_by_a_dwell_implies_no_extrusion_for_machining() {
    let path = finding("79-g4-s-program-without-e.nc");
    let p = path.to_str().expect("utf8");
    let dir = tempdir("finding-79");
    let out = dir.join("out.nc");
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
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let nc = std::fs::read_to_string(&out).expect("posted");
    // The cut along X (the table's X is the part's -X on nrc-lc at B0 C0) is there.
    assert!(nc.contains("Z-1.000") && nc.contains("X-10.000"), "{nc}");
    let o = lampost(&[
        "verify",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        "--process",
        "machine",
        "--head",
        "laser",
        p,
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::remove_file(&out).expect("rm");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        p,
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("implied by the printer flavour marlin, which --flavor auto chose from")
            && e.contains("G4 S1")
            && e.contains("give --flavor for the control"),
        "{e}"
    );
    assert!(!e.contains("post without --e-extrusion"), "{e}");
    assert!(!out.exists());
}

/// Finding 80 (h50): a laser program burning at S500 throughout (LaserBurn's) was posted
/// at `--power` 1000 without a word, where a machining program's other spindle speed is
/// warned of. It is said once a section, at the first deposit.
#[test]
fn a_laser_program_s_one_power_is_said_when_the_post_s_differs() {
    let path = finding("80-laser-at-s500.nc");
    let p = path.to_str().expect("utf8");
    let dir = tempdir("finding-80");
    let out = dir.join("out.nc");
    let post = |power: &str| {
        lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            "--power",
            power,
            p,
            "-o",
            out.to_str().expect("utf8"),
        ])
    };
    let o = post("1000");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "80-laser-at-s500.nc:4: the input deposits at S500; the posted program deposits at power 1000 (--power"
        ),
        "{}",
        stderr(&o)
    );
    let o = post("500");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        !stderr(&o).contains("the input deposits at"),
        "{}",
        stderr(&o)
    );
}

/// Finding 81: a program written for absolute arc centres with no G90.1 was refused arc
/// by arc as "zero radius" or "radii differ", with no word of why. Where the centre words
/// read as the centre's position make a good arc, the error says so and names G90.1;
/// with G90.1 the program traces as rs274 does.
#[test]
fn arc_centres_written_absolute_are_named() {
    let path = finding("81-absolute-arc-centres.nc");
    let o = lampost(&["check", path.to_str().expect("utf8")]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert_eq!(
        e.matches(
            "read as the centre's position (absolute, G90.1) they give an arc of radius 10.000000"
        )
        .count(),
        4,
        "{e}"
    );
    assert!(e.contains("put G90.1 before its first arc"), "{e}");
    let dir = tempdir("finding-81");
    let fixed = dir.join("g90-1.ngc");
    let text = std::fs::read_to_string(&path).expect("fixture");
    std::fs::write(&fixed, text.replacen("G21 G90", "G21 G90 G90.1", 1)).expect("write");
    let o = lampost(&["check", fixed.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    if require_rs274().is_some() {
        equal_to_rs274(&fixed, &dir, &["linuxcnc", "fadal"]);
    }
    // An arc whose end is off its circle names the limits it is held to, in any flavour.
    let off = dir.join("off.gcode");
    std::fs::write(
        &off,
        "G21 G90\nG0 X0 Y0 Z10\nG2 X15 Y20 I30 J40 Z20 F8000\n",
    )
    .expect("w");
    let o = lampost(&["check", "--flavor", "marlin", off.to_str().expect("utf8")]);
    assert!(
        stderr(&o).contains("the limits LinuxCNC holds arcs to, and lampost every program"),
        "{}",
        stderr(&o)
    );
}

/// Finding 82 (h51): under a printer's flavour a `G2 I5 J0 E3` (no X, Y or Z: a full
/// circle, in Marlin's, Klipper's and RepRapFirmware's arc code) was read as moving
/// nothing, like an unretract's `G1 E.8`: the circle was not deposited, its E went to the
/// next move, and verify passed. It is a full circle, deposited.
#[test]
fn a_printer_s_full_circle_by_centre_words_alone_is_deposited() {
    let path = finding("82-marlin-full-circle-ij-only.gcode");
    let p = path.to_str().expect("utf8");
    for flavor in ["auto", "marlin", "reprap"] {
        let doc = trace_json(flavor, &path);
        let moves = doc["moves"].as_array().expect("moves");
        let arc = moves
            .iter()
            .find(|m| m["line"] == 7)
            .unwrap_or_else(|| panic!("{flavor}: no move for line 7: {doc}"));
        assert_eq!(arc["kind"]["type"], "arc", "{arc}");
        assert_eq!(arc["kind"]["turns"], 1, "{arc}");
        assert_eq!(arc["kind"]["center"][0], 15.0, "{arc}");
        assert_eq!(arc["start"], arc["end"], "{arc}");
        assert_eq!(arc["extruded"], 3.0, "{arc}");
    }
    let dir = tempdir("finding-82");
    let out = dir.join("out.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        p,
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let nc = std::fs::read_to_string(&out).expect("posted");
    // One run: on, the line to the circle, the circle (back where it began), on along X.
    let on = nc.find("M71").expect("laser on");
    let circle = nc
        .find("G2 X-10.000 Y0.000 Z0.200 I-5.000 J0.000")
        .expect("the circle");
    let off = nc.find("M72").expect("laser off");
    assert!(on < circle && circle < off, "{nc}");
    assert_eq!(nc.matches("M71").count(), 1, "{nc}");
    let o = lampost(&[
        "verify",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        p,
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A G1 with E alone still moves nothing (an unretract).
    let doc = trace_json("marlin", &finding("82-marlin-full-circle-ij-only.gcode"));
    assert_eq!(doc["moves"].as_array().map(Vec::len), Some(4), "{doc}");
}

/// Finding 83 (h51): a belt printer's start code shifts Z with `G92 Z0 E0` after its
/// purge lines (Kiri:Moto's CR-30 profile); the post's refusal named the next move, 12
/// lines on in the real file. It names the G92's line, and the first move made shifted.
#[test]
fn a_frame_moved_mid_program_is_refused_where_it_moves() {
    let path = finding("83-belt-printer-g92-z.gcode");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        path.to_str().expect("utf8"),
        "-o",
        "-",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains(
            "83-belt-printer-g92-z.gcode:10: the program's frame moves here, after the first move"
        ) && e.contains("(the first at line 11)"),
        "{e}"
    );
}

/// Finding 84 (h51): Marlin's `G61 XY S0` (return to the position `G60 S0` saved; its
/// axis letters are flags) was "the letter X has no number after it", and G61 was read
/// as exact-stop mode. Under a printer's flavour G60 saves (nothing moves) and G61 is
/// named as the move it is: not simulated, and the post refuses it there.
#[test]
fn marlin_s_saved_position_codes_are_named() {
    let path = finding("84-marlin-g60-g61.gcode");
    let p = path.to_str().expect("utf8");
    let o = lampost(&["check", p]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("G61 (a printer's return to the position G60 saved: it moves the head) is not simulated"),
        "{e}"
    );
    assert!(!e.contains("G60 ("), "{e}");
    let o = lampost(&["post", "--machine", "nrc-lc", p, "-o", "-"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("84-marlin-g60-g61.gcode:9: G61 (a printer's return"),
        "{}",
        stderr(&o)
    );
    // Outside a printer's flavour G61 is exact-stop mode, as before.
    let o = lampost(&["check", "--flavor", "fadal", p]);
    assert!(
        stderr(&o).contains("the letter X has no number after it"),
        "{}",
        stderr(&o)
    );
}

/// Finding 85 (h50): a drilling cycle with its depth but no R plane was "needs Z (depth)
/// and R" (a Haas class program's 33 errors); it names the missing word only, as rs274
/// does ("R clearance plane unspecified in cycle").
#[test]
fn a_cycle_without_r_names_r_only() {
    let path = finding("85-cycle-without-r.nc");
    let o = lampost(&["check", path.to_str().expect("utf8")]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("canned cycle G82 needs R (the retract plane)"),
        "{e}"
    );
    assert!(!e.contains("needs Z"), "{e}");
    let dir = tempdir("finding-85");
    let no_z = dir.join("no-z.nc");
    std::fs::write(
        &no_z,
        "G20 G90 G17 G98\nG0 X0 Y0 Z1.\nG81 X1. Y1. R0.1 F10.\nG80\nM30\n",
    )
    .expect("w");
    let o = lampost(&["check", no_z.to_str().expect("utf8")]);
    assert!(
        stderr(&o).contains("canned cycle G81 needs Z (the depth)\n"),
        "{}",
        stderr(&o)
    );
}

/// Finding 90 (h53: LinuxCNC programs against rs274). Each of these read other moves
/// than rs274's, or refused what it runs, or ran what it refuses: `else if` with a blank
/// (cnc-club/linuxcnc-features and probe-screen-ng write it: every branch after it was
/// taken), `endsub [value]`, `(ABORT, …)`, the predefined named parameters
/// (`#<_metric>`, `#<_feed>`…) and setting them, `#<_x>` after a G92, block-deleted
/// O-word lines, an F beside G8, a G71's own F. Each is now as rs274 has it.
#[test]
fn linuxcnc_programs_of_the_tenth_probe_are_read_as_rs274_reads_them() {
    let dir = root().join("fixtures/findings/90-linuxcnc");
    let work = tempdir("finding-90");
    // Moves equal to rs274's.
    for (name, moves) in [
        ("A-else-space-if.ngc", 1),
        ("E-endsub-value.ngc", 2),
        ("D-predefined-named-params.ngc", 2),
        ("F-stale-x-after-g92.ngc", 2),
        ("B-block-delete-oword.ngc", 3),
        ("L1-g8-f-dropped.ngc", 1),
        ("L2-g71-block-f-ignored.ngc", 76),
        ("features-circle-elseif.ngc", 0),
    ] {
        let path = dir.join(name);
        let doc = trace_json("linuxcnc", &path);
        assert_eq!(doc["ok"], true, "{name}: {doc}");
        let n = doc["moves"].as_array().map_or(0, Vec::len);
        if moves > 0 {
            assert_eq!(n, moves, "{name}");
        }
        if require_rs274().is_some() {
            equal_to_rs274(&path, &work, &["linuxcnc"]);
        }
    }
    // The values themselves, without rs274.
    let ends_of = |name: &str| ends(&trace_json("linuxcnc", &dir.join(name)));
    assert_eq!(ends_of("A-else-space-if.ngc"), vec![[0.0, -6.0, 0.0]]);
    assert_eq!(ends_of("E-endsub-value.ngc")[1], [5.0, 1.0, 1.0]);
    assert_eq!(
        ends_of("D-predefined-named-params.ngc")[1],
        [1.0, 1.0, 100.0]
    );
    assert_eq!(ends_of("F-stale-x-after-g92.ngc")[1], [0.0, 0.0, 0.0]);
    // Refused where rs274 refuses.
    for (name, at, says) in [
        ("C-abort-comment.ngc", ":3:", "the program aborts here"),
        ("K-readonly-assign.ngc", ":2:", "#<_metric> is read only"),
    ] {
        let o = lampost(&[
            "check",
            "--flavor",
            "linuxcnc",
            dir.join(name).to_str().expect("utf8"),
        ]);
        assert_eq!(o.status.code(), Some(1), "{name}");
        assert!(
            stderr(&o).contains(at) && stderr(&o).contains(says),
            "{name}: {}",
            stderr(&o)
        );
    }
}

/// Finding 94: the first move after `G40` starts where the compensated tool was left and
/// reads its words from the programmed point (rs274), so `G40` then `G0 Z5` rises over
/// the programmed corner, and `G91 G0 X-10` goes 10 from it.
#[test]
fn the_move_after_g40_goes_from_the_programmed_point() {
    let dir = root().join("fixtures/findings/94-g40-exit");
    let work = tempdir("finding-94");
    for (name, last_two) in [
        ("omitted-axes.ngc", [[20.0, 20.0, 5.0], [-10.0, 20.0, 5.0]]),
        ("incremental.ngc", [[10.0, 20.0, -1.0], [10.0, 20.0, 5.0]]),
        (
            "compensation-again.ngc",
            [[31.0, 30.0, -1.0], [40.0, 30.0, -1.0]],
        ),
    ] {
        let path = dir.join(name);
        let doc = trace_json("linuxcnc", &path);
        assert_eq!(doc["ok"], true, "{name}: {doc}");
        let e = ends(&doc);
        assert_eq!(e[e.len() - 2..], last_two, "{name}");
        // The lift starts where the tool was drawn (X18, on the compensated path).
        if name == "omitted-axes.ngc" {
            let start = &doc["moves"][e.len() - 2]["start"];
            assert_eq!(start["X"].as_f64(), Some(18.0), "{doc}");
        }
        if require_rs274().is_some() {
            equal_to_rs274(&path, &work, &["linuxcnc"]);
        }
    }
}

/// Finding 96: a recognised lathe program's arcs checked with X as a diameter, its G75
/// named; `G81 … P` refused under `linuxcnc` as rs274 refuses it; a vacant `F#650` and
/// a G-code beside G65 named for what they are.
#[test]
fn lathe_arcs_cycles_and_vacant_feeds_of_the_cam_probe() {
    let dir = root().join("fixtures/findings/96-cam-probe");
    let check = |flavor: &str, name: &str| {
        lampost(&[
            "check",
            "--flavor",
            flavor,
            dir.join(name).to_str().expect("utf8"),
        ])
    };
    for name in [
        "lathe-diameter-arc.nc",
        "lathe-diameter-r-arc.nc",
        "lathe-g75.nc",
    ] {
        for flavor in ["haas", "fanuc", "auto"] {
            let o = check(flavor, name);
            assert!(o.status.success(), "{name} {flavor}: {}", stderr(&o));
        }
    }
    let o = check("haas", "lathe-g75.nc");
    assert!(
        stderr(&o).contains("G75 (a lathe's grooving or cut-off cycle) is not simulated"),
        "{}",
        stderr(&o)
    );
    // The arc's centre is given as a diameter, as X is: X0.32 (a 0.16 radius, I0).
    let doc = trace_json("haas", &dir.join("lathe-diameter-arc.nc"));
    let arc = doc["moves"]
        .as_array()
        .expect("moves")
        .iter()
        .find(|m| m["g"] == "G3")
        .expect("the arc");
    assert_eq!(arc["kind"]["center"][0].as_f64(), Some(0.32), "{arc}");
    // A mill program's arc of the same words is still a spiral.
    let work = tempdir("finding-96");
    let mill = work.join("mill.nc");
    std::fs::write(
        &mill,
        "G18 G20\nG00 X0.32 Z-0.468\nG01 F4.\nG03 X0.36 Z-0.488 I0.0 K-0.02\nM30\n",
    )
    .expect("write");
    let o = lampost(&["check", "--flavor", "haas", mill.to_str().expect("utf8")]);
    assert!(stderr(&o).contains("differ by 0.020000"), "{}", stderr(&o));
    for (flavor, name, at, says) in [
        (
            "linuxcnc",
            "g81-p-linuxcnc.ngc",
            ":3:",
            "no code of the block reads P",
        ),
        (
            "fanuc",
            "F-vacant-common.nc",
            ":4:",
            "the block's F reads a vacant variable",
        ),
        (
            "fanuc",
            "g54-g65.nc",
            ":4:",
            "write G54 on a line of its own before the call",
        ),
    ] {
        let o = check(flavor, name);
        assert_eq!(o.status.code(), Some(1), "{name}");
        assert!(
            stderr(&o).contains(at) && stderr(&o).contains(says),
            "{name}: {}",
            stderr(&o)
        );
    }
    if require_rs274().is_some() {
        let (o, _) = rs274_exec(&dir.join("g81-p-linuxcnc.ngc"), &work);
        let said =
            String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
        assert!(said.contains("P word with no"), "{said}");
    }
}

/// Finding 97: LinuxCNC's `#5220` (the coordinate system) and `#5400` (the tool) are
/// read from the modal state; the machine's own parameters (tool table, stored offsets,
/// homes) are read as 0 as rs274 starts them, with a warning, once a parameter.
#[test]
fn linuxcnc_system_parameters_are_read_or_named() {
    let work = tempdir("finding-97");
    let prog = work.join("system.ngc");
    std::fs::write(
        &prog,
        "G20 G90 F10\nT7 M6\nG56\nG0 X#5220 Y#5400\nG0 Z#5410\nG0 Z[#5410 + 1]\n#5181 = 2\nG0 X#5181\nM2\n",
    )
    .expect("write");
    let o = lampost(&[
        "trace",
        "--flavor",
        "linuxcnc",
        prog.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let said = stderr(&o);
    let warned: Vec<&str> = said
        .lines()
        .filter(|l| l.contains("is read as 0"))
        .collect();
    assert_eq!(warned.len(), 1, "{}", stderr(&o));
    assert!(
        warned[0].contains("#5410 (the tool's diameter"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains(":5:"), "{}", stderr(&o));
    let e = ends(&trace_json("linuxcnc", &prog));
    assert_eq!(e[0][..2], [3.0, 7.0]);
    assert_eq!(e[3][0], 2.0);
    if require_rs274().is_some() {
        equal_to_rs274(&prog, &work, &["linuxcnc"]);
    }
}

/// Finding 98: only G81–G89 and the rigid taps are cycles (G85.1 is no G81); a rigid
/// tap feeds out; FADAL's G84.2 alone moves nothing; a FADAL keeps a cycle's Z and R0
/// absolute under G91, and refuses a cycle stated under G91.
#[test]
fn fadal_cycles_are_the_control_s() {
    let dir = root().join("fixtures/findings/98-fadal-cycles");
    let tap = ends(&trace_json("fadal", &dir.join("g84.1-rigid-tap.nc")));
    assert_eq!(
        tap[1..5],
        [
            [1.0, 1.0, 1.0],
            [1.0, 1.0, 0.1],
            [1.0, 1.0, -0.5],
            [1.0, 1.0, 0.1]
        ]
    );
    let doc = trace_json("fadal", &dir.join("g84.1-rigid-tap.nc"));
    // The feed out of the hole is a feed, not a rapid.
    assert_eq!(doc["moves"][4]["origin"], "canned_cycle", "{doc}");
    assert_eq!(doc["moves"][4]["kind"]["type"], "linear", "{doc}");
    let mode = ends(&trace_json("fadal", &dir.join("g84.2-mode.nc")));
    assert_eq!(mode[3], [1.0, 1.0, -0.5]);
    for flavor in ["fadal", "fanuc", "haas", "mach3"] {
        let o = lampost(&[
            "check",
            "--flavor",
            flavor,
            dir.join("g85.1.nc").to_str().expect("utf8"),
        ]);
        assert!(
            stderr(&o).contains(":3:9") && stderr(&o).contains("unknown G-code G85.1"),
            "{flavor}: {}",
            stderr(&o)
        );
    }
    // Twenty-one holes, every one to Z-0.1 from R0.1, 0.5 apart.
    let holes: Vec<[f64; 3]> = ends(&trace_json("fadal", &dir.join("g91-repeat.nc")))
        .into_iter()
        .filter(|e| e[2] == -0.1)
        .collect();
    assert_eq!(holes.len(), 21);
    assert!((holes[20][0] - 10.0).abs() < 1e-9, "{holes:?}");
    let work = tempdir("finding-98");
    let stated = work.join("g91-stated.nc");
    std::fs::write(
        &stated,
        "G90 G20 G0 X0 Y0 Z1.\nS1000 M3\nG91 G81 G98 Z-.2 R0-.9 F50.\nG80 G90\nM30\n",
    )
    .expect("write");
    let o = lampost(&["check", "--flavor", "fadal", stated.to_str().expect("utf8")]);
    assert!(
        stderr(&o).contains(":3:") && stderr(&o).contains("BAD Z OR R0 IN CANNED CYCLE"),
        "{}",
        stderr(&o)
    );
    // Fusion's shrinking FADAL peck is named, at its I, not asked for a Q.
    let o = lampost(&[
        "check",
        "--flavor",
        "fadal",
        dir.join("g83-ijk-peck.nc").to_str().expect("utf8"),
    ]);
    assert!(
        stderr(&o).contains(":4:34") && stderr(&o).contains("a FADAL peck given by I, J and K"),
        "{}",
        stderr(&o)
    );
    // Posted: the tap's way out is a feed, and verify holds the post to it.
    let out = work.join("tap.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--process",
        "machine",
        "--index",
        "A=0,B=0",
        dir.join("g84.1-rigid-tap.nc").to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Finding 99: a bare path whose coolant codes switch between its feeds (a WAAM torch's
/// `M08`/`M09`) is refused, not deposited along its travel.
#[test]
fn a_torch_switched_by_coolant_codes_is_refused() {
    let path = root().join("fixtures/findings/99-ded-probe/m08-welder.nc");
    let work = tempdir("finding-99");
    let out = work.join("o.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        path.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("m08-welder.nc:6:")
            && stderr(&o).contains("the coolant is turned on (M7/M8/M9) between the feeds"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
    // Mended as the message says (M3 S… on, M5 off), it posts.
    let text = std::fs::read_to_string(&path)
        .expect("read")
        .replace("M08", "M3 S500")
        .replace("M09", "M5");
    let mended = work.join("mended.nc");
    std::fs::write(&mended, text).expect("write");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        "--power",
        "500",
        mended.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Finding 100: a FADAL comment open to the end of its line is a comment; `fmt` with a
/// dialect refuses to guess a program's units; `fmt --renumber` refuses a program whose
/// jumps name block numbers.
#[test]
fn fadal_comments_and_fmt_s_units_and_jumps() {
    let dir = root().join("fixtures/findings/100-fadal-fmt");
    let p = |n: &str| dir.join(n).to_str().expect("utf8").to_string();
    let o = lampost(&["check", &p("open-comment.nc")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("0 error(s)"), "{}", stderr(&o));
    // Elsewhere it is still an error, as rs274 has it.
    let o = lampost(&["check", "--flavor", "linuxcnc", &p("open-comment.nc")]);
    assert!(
        stderr(&o).contains("comment is not closed"),
        "{}",
        stderr(&o)
    );
    let o = lampost(&["fmt", "--dialect", "fadal", &p("inch-no-units.nc")]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains(":2:11") && stderr(&o).contains("has not said its units"),
        "{}",
        stderr(&o)
    );
    let o = lampost(&[
        "fmt",
        "--dialect",
        "fadal",
        "--units",
        "inch",
        &p("inch-no-units.nc"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("X1.0625 Y0.3125"));
    // Verbatim, nothing is rounded and nothing is asked.
    assert!(lampost(&["fmt", &p("inch-no-units.nc")]).status.success());
    for (name, at) in [("renumber-goto.nc", ":5:"), ("renumber-m97.nc", ":3:")] {
        let o = lampost(&["fmt", "--renumber", "10,10", &p(name)]);
        assert_eq!(o.status.code(), Some(1), "{name}");
        assert!(
            stderr(&o).contains(at) && stderr(&o).contains("a jump to a block by its number"),
            "{name}: {}",
            stderr(&o)
        );
    }
}

/// Finding 100: an index of a continuous rotary past a turn is refused, naming the same
/// orientation within one.
#[test]
fn an_index_past_a_turn_is_refused() {
    let input = root().join("fixtures/findings/100-fadal-fmt/index-a1500.nc");
    let work = tempdir("finding-100-index");
    let out = work.join("o.nc");
    let post = |index: &str| {
        lampost(&[
            "post",
            "--machine",
            "fadal-lamp",
            "--index",
            index,
            input.to_str().expect("utf8"),
            "-o",
            out.to_str().expect("utf8"),
        ])
    };
    let o = post("A=1500,B=0");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--index A=1500: more than a turn; the same orientation is A=60"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
    assert!(post("A=60,B=0").status.success());
}

/// Finding 101 (h57): a FADAL program's own subroutines (the manual's layout: `L0100`
/// headings, `M17`, the `M30` that separates them from the main program, `Lnnkk` calls)
/// were traced as the main program, and the real main program after that M30 was dropped
/// (warned only as "not followed"). Now each call runs its subroutine where it stands,
/// subroutines calling others, in trace, post and verify alike; what the control refuses
/// is refused at the line.
#[test]
fn fadal_subroutines_run_where_they_are_called() {
    let slots = finding("101-fadal-subroutines/slots.nc");
    let doc = trace_json("fadal", &slots);
    let xy: Vec<[f64; 2]> = ends(&doc).iter().map(|e| [e[0], e[1]]).collect();
    // L102: sub 1 twice (X+1, sub 2: Y+.5 and back, X-1); then L101 once at X3.
    let slot = |x: f64| [[x + 1.0, 1.0], [x + 1.0, 1.5], [x + 1.0, 1.0], [x, 1.0]];
    let mut want = vec![[1.0, 1.0], [1.0, 1.0]];
    want.extend(slot(1.0));
    want.extend(slot(1.0));
    want.extend([[1.0, 1.0], [3.0, 1.0], [3.0, 1.0]]);
    want.extend(slot(3.0));
    want.push([3.0, 1.0]);
    assert_eq!(xy, want);
    let o = lampost(&["check", slots.to_str().expect("utf8")]);
    let err = stderr(&o);
    assert!(
        o.status.success() && err.contains("0 error(s), 0 warning(s)"),
        "{err}"
    );
    // Posted with every call followed, and verified against the same reading.
    let work = tempdir("fadal-subroutines");
    let out = work.join("slots.post.nc");
    let args = [
        "--machine",
        "fadal-lamp",
        "--process",
        "machine",
        "--index",
        "A=0,B=0",
    ];
    let mut post = vec!["post"];
    post.extend_from_slice(&args);
    post.extend_from_slice(&[
        slots.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    let o = lampost(&post);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        !err.contains("M17"),
        "M17 is the subroutine's return: {err}"
    );
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert_eq!(posted.matches("Y1.5000").count(), 3, "{posted}");
    let mut verify = vec!["verify"];
    verify.extend_from_slice(&args);
    verify.extend_from_slice(&[slots.to_str().expect("utf8"), out.to_str().expect("utf8")]);
    let o = lampost(&verify);
    assert!(o.status.success(), "{}", stderr(&o));
    // A posted program that runs the subroutine once too few times fails.
    let short = work.join("short.nc");
    let cut = posted.replacen("Y1.5000", "Y1.0000", 1);
    std::fs::write(&short, cut).expect("write");
    let mut verify = vec!["verify"];
    verify.extend_from_slice(&args);
    verify.extend_from_slice(&[slots.to_str().expect("utf8"), short.to_str().expect("utf8")]);
    assert!(!lampost(&verify).status.success());
    for (file, at, says) in [
        ("no-m30.nc", ":1:4", "MAIN PROG. NOT FOUND"),
        ("no-such-sub.nc", ":6:4", "SUBR. DOES NOT EXIST"),
    ] {
        let o = lampost(&[
            "trace",
            finding(&format!("101-fadal-subroutines/{file}"))
                .to_str()
                .expect("utf8"),
        ]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{file}: {err}");
        assert!(err.contains(at) && err.contains(says), "{file}: {err}");
    }
}

/// Finding 102 (h59): a shift the program states before its first move (`G52 X10. Y5.`)
/// placed the posted moves 10 and 5 away from the program's work zero without a word; and
/// the Fanuc safety line `G00 G17 G40 G49 G80` (a traverse to where the tool stands) was
/// taken for the first move, so such a shift after it was refused. Now the shift is said,
/// with what --origin then places, and a move that goes nowhere is no first move.
#[test]
fn a_shift_before_the_first_move_is_said() {
    let work = tempdir("g52-first");
    let out = work.join("g52.nc");
    let input = finding("102-frame-and-chords/g52-after-bare-g00.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--process",
        "machine",
        "--index",
        "A=0,B=0",
        "--flavor",
        "fanuc",
        "--convert-units",
        input.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("shifted by (10, 5, 0)")
            && err.contains("at line 5")
            && err.contains("--origin"),
        "{err}"
    );
}

/// Finding 103 (h59): the post's own check looked at the written chord points of a
/// linearised arc, `verify` at the middle of every written segment too: the post said
/// 5.9e-5 where verify found 5.1e-4 on the same file, and on a coarse grid a chord's
/// middle could pass the post and fail verify. Now each chord point's check carries the
/// chord's sagitta (the middle is within it plus the larger end distance), the chord
/// count leaves room for the grid's rounding, and the post's figure is never below
/// verify's.
#[test]
fn the_post_s_check_of_chords_is_never_weaker_than_verify() {
    let work = tempdir("chord-middles");
    let input = finding("102-frame-and-chords/tilted-circle.nc");
    let figure = |text: &str, key: &str| -> f64 {
        text.split(key)
            .nth(1)
            .and_then(|r| r.split_whitespace().next())
            .and_then(|v| v.trim_end_matches(',').parse().ok())
            .unwrap_or_else(|| panic!("no `{key}` in {text}"))
    };
    for tolerance in [None, Some("0.0001")] {
        let out = work.join("circle.nc");
        let mut args = vec![
            "--machine",
            "fadal-lamp",
            "--process",
            "machine",
            "--index",
            "A=0,B=-20",
            "--convert-units",
        ];
        let mut post = vec!["post"];
        post.extend_from_slice(&args);
        if let Some(t) = tolerance {
            post.extend_from_slice(&["--tolerance", t]);
        }
        post.extend_from_slice(&[
            input.to_str().expect("utf8"),
            "-o",
            out.to_str().expect("utf8"),
        ]);
        let o = lampost(&post);
        let perr = stderr(&o);
        assert!(o.status.success(), "{perr}");
        let posted = figure(&perr, "max tip error ");
        // verify at the tolerance the post checked at (twice its chord tolerance).
        let vt = tolerance.map(|t| format!("{}", 2.0 * t.parse::<f64>().expect("number")));
        if let Some(t) = &vt {
            args.extend_from_slice(&["--tolerance", t.as_str()]);
        }
        let mut verify = vec!["verify"];
        verify.extend_from_slice(&args);
        verify.extend_from_slice(&[input.to_str().expect("utf8"), out.to_str().expect("utf8")]);
        let o = lampost(&verify);
        let verr = stderr(&o);
        assert!(o.status.success(), "{verr}");
        let verified = figure(&verr, "max tip error ");
        assert!(
            posted >= verified,
            "post {posted} < verify {verified}: {perr}\n{verr}"
        );
    }
}

/// Finding 104 (h59): a line of text written without parentheses (`roughing pass`) was
/// "the letter R has no number after it … give the word a value, e.g. `X0`". It is named
/// as text, with the parentheses to add.
#[test]
fn a_line_of_text_is_named_as_text() {
    let o = lampost(&[
        "check",
        finding("102-frame-and-chords/text-line.nc")
            .to_str()
            .expect("utf8"),
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("`roughing pass` is text")
            && err.contains(":3:1")
            && err.contains("inside a comment"),
        "{err}"
    );
}

/// Finding 105 (h57, h59): `fmt` refused a Fanuc Macro B program's statements (`IF [#1 LT
/// 3] GOTO 2` was "the letter I has no number after it") that `check` and `trace`
/// evaluate; and `--flavor auto` read a Fanuc program's `#4= 7. / 2.` (an expression
/// without brackets, which LinuxCNC refuses) as LinuxCNC's for its `#`, and refused it at
/// the `/`. The statements are now copied as they stand, with or without a dialect; the
/// unbracketed assignment decides Fanuc.
#[test]
fn macro_b_statements_are_copied_and_an_unbracketed_assignment_is_fanuc() {
    let loops = finding("105-macro-b/loops.nc");
    let text = std::fs::read_to_string(&loops).expect("fixture");
    for extra in [&[][..], &["--dialect", "fadal", "--units", "inch"][..]] {
        let mut args = vec!["fmt", "--flavor", "fanuc"];
        args.extend_from_slice(extra);
        args.push(loops.to_str().expect("utf8"));
        let o = lampost(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        for st in [
            "IF [#1 LT 3] GOTO 2",
            "WHILE [#1 LT 5] DO1",
            "END1",
            "GOTO 9",
        ] {
            assert!(
                out.lines().any(|l| l == st),
                "{extra:?}: {st} missing:\n{out}"
            );
        }
        if extra.is_empty() {
            assert_eq!(out, text);
        }
    }
    let o = lampost(&[
        "check",
        finding("105-macro-b/unbracketed.nc")
            .to_str()
            .expect("utf8"),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("flavour fanuc (auto: a Macro B assignment"),
        "{err}"
    );
}

/// Finding 106 (h58): a few hundred bytes ran without bound. Loops and calls capped the
/// blocks run, not the moves each made: a `G81 … L9999` in a subprogram called 10⁶ times
/// traced 3.6 GB in a minute, and zero-depth holes (no text written, so `--max-bytes`
/// never stopped it) held `post` for an hour and a half. The moves blocks make beyond
/// one each are now capped at 5,000,000 a program, refused at the line. The demo plate
/// (`--along 100000 --across 100000` asked 480 GB and aborted) and `probe poses`
/// (`--points 4294967296`, 412 GB) are bounded too; `fmt` to standard output writes
/// nothing after its first error line, as it says, and no closing `%` after a cut.
#[test]
fn hostile_sizes_are_refused_not_run() {
    for (args, says) in [
        (
            vec![
                "trace",
                "106-hostile/cycle-repeats-in-calls.nc",
                "-o",
                "OUT",
            ],
            "more than 5000000 moves made by canned or lathe cycles",
        ),
        (
            vec![
                "post",
                "--machine",
                "nrc-lc",
                "106-hostile/zero-depth-cycle-in-repeat.ngc",
                "-o",
                "OUT",
            ],
            "more than 5000000 moves made by canned or lathe cycles",
        ),
    ] {
        let work = tempdir("hostile");
        let out = work.join("out.nc");
        let args: Vec<String> = args
            .iter()
            .map(|a| {
                if a.starts_with("106-") {
                    finding(a).to_string_lossy().into_owned()
                } else if *a == "OUT" {
                    out.to_string_lossy().into_owned()
                } else {
                    (*a).to_string()
                }
            })
            .collect();
        let argv: Vec<&str> = args.iter().map(String::as_str).collect();
        let t = std::time::Instant::now();
        let o = lampost(&argv);
        let err = stderr(&o);
        assert!(!o.status.success() && err.contains(says), "{args:?}: {err}");
        assert!(!out.exists());
        // (A bound on the work, not a timing test: unbounded, these ran for hours.)
        assert!(t.elapsed().as_secs() < 120, "{args:?}");
    }
    let work = tempdir("hostile-sizes");
    let stl = work.join("d.stl");
    let o = lampost(&[
        "plan",
        "demo",
        "--along",
        "100000",
        "--across",
        "100000",
        "-o",
        stl.to_str().expect("utf8"),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("at most 250000 in all"),
        "{}",
        stderr(&o)
    );
    let o = lampost(&[
        "probe",
        "poses",
        "--machine",
        "fadal-lamp",
        "--ball",
        "3,-2,1.5",
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.1",
        "--points",
        "4294967296",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("more than 10000 touches"),
        "{}",
        stderr(&o)
    );
    let prog = work.join("big.nc");
    std::fs::write(&prog, "G21\nG1 X1 F100\nG1 X123456789\nG1 X3\nM2\n").expect("write");
    let o = lampost(&["fmt", "--dialect", "fadal", prog.to_str().expect("utf8")]);
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(!o.status.success());
    assert_eq!(out, "%\nG21\nG1 X1.000 F100.\n", "{}", stderr(&o));
}

/// Finding 106 (h58), loops: the cap of 10⁶ blocks run again held for short blocks only;
/// a 60 KB expression line in a loop ran for about 4 minutes. Blocks run again are now
/// capped at 64 MiB too. And a LinuxCNC G70 roughing a profile inside `o… repeat` made
/// 77,000 moves a pass, at the end of its profile, where the cycles' cap did not look:
/// it is counted there too.
#[test]
fn long_lines_in_loops_and_profile_cycles_in_repeats_are_bounded() {
    let work = tempdir("hostile-loops");
    let long = work.join("long.ngc");
    let terms = vec!["1"; 30_000].join("+");
    std::fs::write(
        &long,
        format!("G21 G90\n#1=0\no1 while [#1 LT 999999]\n#2=[{terms}]\n#1=[#1+1]\no1 endwhile\nG0 X1\nM2\n"),
    )
    .expect("write");
    for (file, says) in [
        (long, "bytes of blocks run again"),
        (
            finding("106-hostile/g70-in-repeat.ngc"),
            "moves made by canned or lathe cycles",
        ),
    ] {
        let out = work.join("out.trace");
        let o = lampost(&[
            "trace",
            "--flavor",
            "linuxcnc",
            file.to_str().expect("utf8"),
            "-o",
            out.to_str().expect("utf8"),
        ]);
        let err = stderr(&o);
        assert!(
            !o.status.success() && err.contains(says),
            "{}: {err}",
            file.display()
        );
        assert!(!out.exists());
    }
}

/// Finding 108 (h59): a Haas program typed from the manual, each block ended by a bare
/// `;`, was read as LinuxCNC's (for its "`;` comments") and refused at its `G12` as an
/// unknown G-code, with no word of the flavour. A bare `;` ending a block now decides
/// Fanuc, where G12 is named (circular pocket, not simulated); under LinuxCNC's reading
/// the refusal says the code is other controls' and which `--flavor` to give.
#[test]
fn a_bare_semicolon_ending_blocks_reads_as_fanuc() {
    let f = finding("108-haas-eob/g12-semicolon-ends.nc");
    let f = f.to_str().expect("utf8");
    let o = lampost(&["check", f]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("flavour fanuc (auto: a bare `;` ending a block")
            && err.contains("G12 (circular pocket milling) is not simulated"),
        "{err}"
    );
    let o = lampost(&["check", "--flavor", "linuxcnc", f]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("unknown G-code G12: LinuxCNC has none")
            && err.contains(":6:1")
            && err.contains("--flavor fanuc, haas, mach3 or fadal"),
        "{err}"
    );
    // A code no control has is unknown as before.
    let p = tempdir("finding-108").join("g999.nc");
    std::fs::write(&p, "G21 G90\nG0 X1 ; go\nG99.9 X2\nM2\n").expect("writes");
    let o = lampost(&["check", p.to_str().expect("utf8")]);
    let err = stderr(&o);
    assert!(
        !o.status.success() && err.contains("G99.9") && !err.contains("LinuxCNC has none"),
        "{err}"
    );
}

/// Finding 109 (h58): `preview` held every point and the whole SVG in memory; 6.4 KB of
/// cycle repeats made a 618 MB SVG in 1.4 GB. A picture now holds at most 4,000,000
/// points, refused at the move that passes the bound, nothing written.
#[test]
fn a_preview_is_bounded() {
    let work = tempdir("finding-109");
    let svg = work.join("p.svg");
    let o = lampost(&[
        "preview",
        "--machine",
        "nrc-lc",
        finding("109-preview-bound/cycle-repeats.nc")
            .to_str()
            .expect("utf8"),
        "-o",
        svg.to_str().expect("utf8"),
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("the posted program:84")
            && err.contains("more than 4000000 points")
            && err.contains("preview a smaller program"),
        "{err}"
    );
    assert!(!svg.exists());
}

/// Finding 110 (h60): `post --machine nrc-lc --process machine` machined with the NRC
/// cell's laser head, turning a spindle the cell does not have on and off (`S3000 M3`,
/// `M5`) without a word. Machining on a machine with no spindle is now refused unless a
/// head is named, by `post`, `verify` and `preview` alike.
#[test]
fn machining_without_a_spindle_is_refused() {
    let work = tempdir("finding-110");
    let input = work.join("cut.nc");
    std::fs::write(
        &input,
        "G21 G90\nS3000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F300\nG1 X-10 Y-5\nG0 Z5\nM5\nM2\n",
    )
    .expect("writes");
    let input = input.to_str().expect("utf8");
    let out = work.join("posted.nc");
    let o_arg = out.to_str().expect("utf8");
    for args in [
        vec![
            "post",
            "--machine",
            "nrc-lc",
            "--process",
            "machine",
            input,
            "-o",
            o_arg,
        ],
        vec![
            "verify",
            "--machine",
            "nrc-lc",
            "--process",
            "machine",
            input,
            input,
        ],
        vec![
            "preview",
            "--machine",
            "nrc-lc",
            "--process",
            "machine",
            input,
            "-o",
            o_arg,
        ],
    ] {
        let o = lampost(&args);
        let err = stderr(&o);
        assert!(!o.status.success(), "{args:?}: {err}");
        assert!(
            err.contains(
                "nrc-lc has no spindle (no head named `spindle`; its heads: laser, sensor)"
            ) && err.contains("--head NAME"),
            "{args:?}: {err}"
        );
        assert!(!out.exists(), "{args:?}");
    }
    // Named, the head machines (the user's choice), and the spindle-equipped FADAL
    // machines as before.
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--process",
        "machine",
        "--head",
        "laser",
        input,
        "-o",
        o_arg,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Finding 111 (h60): a program whose first cut comes before it gives X and Y (`G1 Z-1`
/// first thing, as the Shapeoko calibration program starts) was posted from X0 Y0 of the
/// part without a word, where the machine would cut wherever the head stands. It is
/// warned of at its line (once a section); a lift written as a feed (`G1 Z3.81` first,
/// as Easel writes) is not.
#[test]
fn a_cut_from_a_start_never_given_is_warned() {
    let f = finding("111-unplaced-start/first-feed-no-xy.ngc");
    let work = tempdir("finding-111");
    let out = work.join("p.nc");
    let post = |input: &str| {
        lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            "--process",
            "machine",
            "--head",
            "laser",
            input,
            "-o",
            out.to_str().expect("utf8"),
        ])
    };
    let o = post(f.to_str().expect("utf8"));
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("first-feed-no-xy.ngc:3: this feed starts before the program gives X and Y"),
        "{err}"
    );
    assert_eq!(err.matches("this feed starts before").count(), 1, "{err}");
    let lift = work.join("lift.nc");
    std::fs::write(
        &lift,
        "G21\nG90\nG1 Z3.810 F228.6\nG0 X110.050 Y8.413\nG1 Z-1.600 F228.6\nG1 X110.804 Y8.631 F1016.0\nG0 Z5\nM2\n",
    )
    .expect("writes");
    let o = post(lift.to_str().expect("utf8"));
    let err = stderr(&o);
    assert!(
        o.status.success() && !err.contains("this feed starts before"),
        "{err}"
    );
    // Only Y never given: named.
    let y = work.join("y.nc");
    std::fs::write(&y, "G21 G90\nG0 X5 Z2\nG1 Z-1 F100\nG1 X10\nG0 Z5\nM2\n").expect("writes");
    let o = post(y.to_str().expect("utf8"));
    let err = stderr(&o);
    assert!(
        err.contains("y.nc:3: this feed starts before the program gives Y:"),
        "{err}"
    );
}

/// Finding 112 (h60): `verify` on a posted program changed after posting (an arc's
/// centre moved) said "fix the input program", and at the same tolerance as the post's
/// `--tolerance` called a passing post's program "a lampost fault". An error of the
/// posted text now says the program was changed or is not lampost's, and a failed check
/// names the tolerance the post checked to.
#[test]
fn verify_names_the_posted_program_and_the_tolerances() {
    let work = tempdir("finding-112");
    let input = work.join("circle.nc");
    std::fs::write(
        &input,
        "G20 G90 G17\nG0 X0.4 Y0 Z0.1\nG1 Z0 F20.\nG3 X-0.4 Y0 I-0.4 J0\nG0 Z0.1\nM30\n",
    )
    .expect("writes");
    let posted = work.join("posted.nc");
    let (i, p) = (
        input.to_str().expect("utf8"),
        posted.to_str().expect("utf8"),
    );
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        i,
        "-o",
        p,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&posted).expect("posted");
    let arc = text
        .lines()
        .find(|l| l.contains(" I") && l.contains(" J"))
        .expect("an arc")
        .to_string();
    let bad = arc.replace(" I-0.4000", " I-0.1000");
    assert_ne!(bad, arc, "{arc}");
    std::fs::write(&posted, text.replace(&arc, &bad)).expect("writes");
    let o = lampost(&[
        "verify",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        i,
        p,
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("it was changed after it was posted")
            && !err.contains("fix the input program"),
        "{err}"
    );
    // Posted tilted at a chord tolerance of 0.0005 in (checked to 0.001 in), verified at
    // 0.0005 in: the chords and the output rounding are past it, and the help says so.
    let circle = finding("112-verify-messages/circle.nc");
    let c = circle.to_str().expect("utf8");
    let idx = [
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=-20",
        "--process",
        "machine",
    ];
    let mut args = vec!["post", "--tolerance", "0.0005"];
    args.extend_from_slice(&idx);
    args.extend_from_slice(&[c, "-o", p]);
    let o = lampost(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut args = vec!["verify", "--tolerance", "0.0005"];
    args.extend_from_slice(&idx);
    args.extend_from_slice(&[c, p]);
    let o = lampost(&args);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("verify's --tolerance is tighter than the post's own check (twice the post's chord --tolerance"),
        "{err}"
    );
}

/// Finding 113 (h60): verify passed a posted program whose last `M5` was changed to
/// `M3` (the spindle left turning at the end; a control's program end may not stop
/// it), as it did coolant left on; the laser and the powder were held to it already.
#[test]
fn a_program_ending_with_the_spindle_or_coolant_on_fails_verify() {
    let work = tempdir("finding-113");
    let input = work.join("cut.nc");
    std::fs::write(
        &input,
        "G20 G90\nS3000 M3\nM8\nG0 X0 Y0 Z0.1\nG1 Z-0.05 F10.\nG1 X1.\nG0 Z0.1\nM9\nM5\nM30\n",
    )
    .expect("writes");
    let posted = work.join("posted.nc");
    let (i, p) = (
        input.to_str().expect("utf8"),
        posted.to_str().expect("utf8"),
    );
    let opts = [
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        "--process",
        "machine",
        "--coolant",
    ];
    let mut args = vec!["post"];
    args.extend_from_slice(&opts);
    args.extend_from_slice(&[i, "-o", p]);
    let o = lampost(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&posted).expect("posted");
    let verify = || {
        let mut args = vec!["verify"];
        args.extend_from_slice(&opts);
        args.extend_from_slice(&[i, p]);
        lampost(&args)
    };
    let o = verify();
    assert!(o.status.success(), "{}", stderr(&o));
    for (from, to, says) in [
        ("M5", "M3", "ends with the spindle turning"),
        ("M9", "M8", "ends with the coolant on"),
    ] {
        let at = text.rfind(from).expect(from);
        let mut bad = text.clone();
        bad.replace_range(at..at + from.len(), to);
        std::fs::write(&posted, &bad).expect("writes");
        let o = verify();
        let err = stderr(&o);
        assert!(
            !o.status.success() && err.contains(says),
            "{from}→{to}: {err}"
        );
    }
}

/// h58: a 300-digit coordinate was shown as 300 digits by `trace` and in the post's
/// travel refusal; beyond 1e15 a number is now shown in exponent form.
#[test]
fn a_huge_number_is_shown_in_exponent_form() {
    let dir = tempdir("huge-number");
    let prog = dir.join("big.nc");
    let nines = "9".repeat(300);
    std::fs::write(
        &prog,
        format!("G21 G90\nG0 X0 Y0 Z5\nG1 X{nines} F100\nM30\n"),
    )
    .expect("write");
    let p = prog.to_str().expect("utf8");
    let long_digits = |t: &str| {
        t.split(|c: char| !c.is_ascii_digit())
            .any(|run| run.len() > 20)
    };
    let o = lampost(&["trace", p]);
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(out.contains("X1e300"), "{out}");
    assert!(!long_digits(&out), "{out}");
    let o = lampost(&["post", "--machine", "nrc-lc", "--index", "B=0,C=0", p]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("e300 is beyond its travel"), "{err}");
    assert!(!long_digits(&err), "{err}");
}

/// h61: a Fusion/HSM program saved with classic Mac line ends (CR alone; TinyG's
/// `MAGNET_HOLES.txt`) was refused as Siemens Sinumerik syntax, its tool comment's `CR=0.`
/// read as Sinumerik's radius word; it is refused at its first bare CR, as documented.
#[test]
fn a_tool_comment_with_cr_is_not_sinumerik() {
    let dir = tempdir("cr-comment");
    let prog = dir.join("cr.nc");
    std::fs::write(
        &prog,
        "(T2 D=1.587 CR=0. - ZMIN=-8.427 - FLAT END MILL)\rG90 G94 G17\rG21\rG0 X1 Y1\rM30\r",
    )
    .expect("write");
    let o = lampost(&["check", prog.to_str().expect("utf8")]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(!err.contains("Sinumerik"), "{err}");
    assert!(err.contains("carriage return"), "{err}");
    // With line feeds it is a program.
    let lf = dir.join("lf.nc");
    std::fs::write(
        &lf,
        "(T2 D=1.587 CR=0. - ZMIN=-8.427 - FLAT END MILL)\nG90 G94 G17\nG21\nG0 X1 Y1\nM30\n",
    )
    .expect("write");
    let o = lampost(&["check", lf.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// h62: under a printer's flavour an arc's `P2` was read as LinuxCNC's two turns (Marlin
/// with `ARC_P_CIRCLES`: three; Klipper, RepRapFirmware: one) and posted so; it is
/// refused at the word. `P1`, which BambuStudio's spiral lifts write, is the arc itself.
#[test]
fn a_printers_arc_p_is_refused() {
    let dir = tempdir("printer-arc-p");
    let prog = dir.join("p2.gcode");
    let head = ";FLAVOR:Marlin\nG21\nG90\nM83\nG0 X10 Y10 Z0.3 F3000\nG1 X20 E1 F600\n";
    std::fs::write(&prog, format!("{head}G2 X20 Y10 I5 J0 E10 P2\nM2\n")).expect("write");
    let p = prog.to_str().expect("utf8");
    let o = lampost(&["post", "--machine", "nrc-lc", "--index", "B=0,C=0", p]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(":7:") && err.contains("P of 2 or more"),
        "{err}"
    );
    let o = lampost(&["check", p]);
    assert!(!o.status.success(), "{}", stderr(&o));
    let one = dir.join("p1.gcode");
    std::fs::write(&one, format!("{head}G2 X20 Y10 I5 J0 E10 P1\nM2\n")).expect("write");
    let o = lampost(&["trace", "--json", one.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("\"turns\":1"), "{text}");
}

/// h62: an arc fitted by a slicer (radius 2 m over 1.5 mm, as BambuStudio and OrcaSlicer
/// write) counted as its whole 4 m circle in the work's height, so the tilted post asked
/// for a retract far above the NRC cell's travel and refused; it now posts and verifies,
/// its retract where the same path written with G1 has it.
#[test]
fn a_fitted_near_straight_arc_posts_tilted() {
    let dir = tempdir("fitted-arc");
    let head = ";FLAVOR:Marlin\nG21\nG90\nM83\nG0 X0 Y0 Z0.2 F3000\nG1 X10 E0.5 F1200\n";
    let arc = dir.join("arc.gcode");
    std::fs::write(
        &arc,
        format!("{head}G2 X11.5 Y0 I0.75 J-2000 E0.05\nG1 X20 E0.5\nM2\n"),
    )
    .expect("write");
    let line = dir.join("line.gcode");
    std::fs::write(&line, format!("{head}G1 X11.5 Y0 E0.05\nG1 X20 E0.5\nM2\n")).expect("write");
    let retract = |input: &Path| -> String {
        let out = input.with_extension("nc");
        let o = lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            "--index",
            "B=30,C=45",
            input.to_str().expect("utf8"),
            "-o",
            out.to_str().expect("utf8"),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let v = lampost(&[
            "verify",
            "--machine",
            "nrc-lc",
            "--index",
            "B=30,C=45",
            input.to_str().expect("utf8"),
            out.to_str().expect("utf8"),
        ]);
        assert!(v.status.success(), "{}", stderr(&v));
        let text = std::fs::read_to_string(&out).expect("posted");
        text.lines()
            .find_map(|l| l.split_once("G0 Z").map(|(_, z)| z.to_string()))
            .expect("a retract")
    };
    assert_eq!(retract(&arc), retract(&line));
}

/// h62: a travel that goes nowhere in the middle of a deposit (PrusaSlicer's spiral vase
/// writes `G1 Z4.800 F9000` at Z4.8 at every layer) split the run: laser off, a lift to
/// the safe height and down again over the same point. The run now goes on.
#[test]
fn a_travel_to_where_the_head_stands_keeps_the_run() {
    let dir = tempdir("standing-travel");
    let prog = dir.join("vase.gcode");
    std::fs::write(
        &prog,
        ";FLAVOR:Marlin\nG21\nG90\nM83\nG0 X10 Y10 Z0.3 F3000\nG1 X20 E1 F600\nG1 Z0.3 F9000\nG1 X30 E1 F600\nG1 Z0.6 F9000\nG1 X40 E1\nM2\n",
    )
    .expect("write");
    let p = prog.to_str().expect("utf8");
    let out = dir.join("vase.nc");
    let o = out.to_str().expect("utf8");
    let r = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        p,
        "-o",
        o,
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let text = std::fs::read_to_string(&out).expect("posted");
    // One run up to the lift to Z0.6 (a move: travel, the laser off), then another.
    assert_eq!(text.matches("M71").count(), 2, "{text}");
    let v = lampost(&["verify", "--machine", "nrc-lc", "--index", "B=0,C=0", p, o]);
    assert!(v.status.success(), "{}", stderr(&v));
    // The first run holds both deposits: no M72 between X-20 and X-30.
    let a = text.find("X-20.000").expect("first deposit");
    let b = text.find("X-30.000").expect("second deposit");
    assert!(!text[a..b].contains("M72"), "{text}");
}
