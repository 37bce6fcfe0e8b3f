//! `lampost check`, `fmt` and `trace` as a user runs them.

mod common;

use common::*;

/// Each bad input: exit 1, and a message naming the file, line and column.
#[test]
fn bad_input_gets_located_errors() {
    let dir = tempdir("bad");
    let cases: Vec<(&str, Vec<u8>, &str, &str)> = vec![
        (
            // (A `;` comment: not a FADAL program, whose comments may stay open.)
            "unterminated",
            b"G0 X1 ; start\nG1 X2 (oops\n".to_vec(),
            ":2:7",
            "comment is not closed",
        ),
        (
            "letter",
            b"G1 X Y2 F10\n".to_vec(),
            ":1:4",
            "the letter X has no number",
        ),
        (
            // (`G1 X1 12.5` is X112.5, as rs274 reads it: finding 33.)
            "number",
            b"G1 X1 (c) 12.5\n".to_vec(),
            ":1:11",
            "has no address letter",
        ),
        (
            "axis-twice",
            b"G0 X1 Y2 X3\n".to_vec(),
            ":1:10",
            "X appears twice",
        ),
        (
            "group",
            b"G0 G1 X1\n".to_vec(),
            ":1:4",
            "G0 and G1 are both in the motion group",
        ),
        (
            "unknown-g",
            b"G0 X0\nG7.5 X1\n".to_vec(),
            ":2:1",
            "unknown G-code",
        ),
        (
            "radii",
            b"G0 X0 Y0\nG2 X10 Y0 I4 J0 F100\n".to_vec(),
            ":2:1",
            "differ by",
        ),
        (
            "no-centre",
            b"G0 X0 Y0\nG2 X10 Y0 F100\n".to_vec(),
            ":2:1",
            "neither I/J/K",
        ),
        (
            "utf8",
            b"G0 X1\nG1 X\xff\xfe2\n".to_vec(),
            ":2:5",
            "not UTF-8",
        ),
        ("empty", Vec::new(), "", "the program is empty"),
        ("blank", b"\n   \n".to_vec(), "", "the program is empty"),
    ];
    for (name, text, at, msg) in cases {
        let p = dir.join(format!("{name}.nc"));
        std::fs::write(&p, &text).expect("write");
        let ps = p.to_str().expect("utf8");
        for cmd in ["check", "trace"] {
            let o = lampost(&[cmd, ps]);
            let e = stderr(&o);
            assert_eq!(o.status.code(), Some(1), "{cmd} {name}: {e}");
            assert!(
                e.contains(&format!("{ps}{at}")),
                "{cmd} {name}: no location {at} in\n{e}"
            );
            assert!(e.contains(msg), "{cmd} {name}: no `{msg}` in\n{e}");
            assert!(e.contains("help:"), "{cmd} {name}: no hint");
            assert!(!e.contains("panicked"), "{name}");
        }
    }
}

#[test]
fn check_json_lists_every_problem() {
    let o = lampost_stdin(
        &["check", "--json", "-"],
        b"G1 X Y1\nG0 G1 X1\nG0 X1\n#V1 = 2\n",
    );
    assert_eq!(o.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(v["errors"], 2);
    assert_eq!(v["warnings"], 1);
    let d = &v["diagnostics"][0];
    assert_eq!(d["line"], 1);
    assert_eq!(d["column"], 4);
    assert_eq!(d["file"], "<stdin>");
    assert!(d["hint"].as_str().expect("hint").len() > 5);
}

#[test]
fn a_single_hundred_megabyte_line_is_refused_not_read() {
    let mut text = b"G0 X1\n".to_vec();
    text.extend(std::iter::repeat_n(b'X', 100 * 1024 * 1024));
    text.push(b'\n');
    let o = lampost_stdin(&["check", "-"], &text);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("<stdin>:2:1") && e.contains("bytes long"), "{e}");
    assert!(e.len() < 4000, "the snippet is cut to a window");
}

#[test]
fn fmt_writes_nothing_when_input_has_errors() {
    let dir = tempdir("atomic");
    let out = dir.join("out.nc");
    std::fs::write(&out, "old content\n").expect("write");
    let o = lampost_stdin(
        &["fmt", "-", "-o", out.to_str().expect("utf8")],
        b"G0 X1\nG1 X\n",
    );
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        std::fs::read_to_string(&out).expect("read"),
        "old content\n"
    );
    let left: Vec<_> = std::fs::read_dir(&dir).expect("dir").flatten().collect();
    assert_eq!(left.len(), 1, "no temporary file left behind");
    let o = lampost_stdin(
        &[
            "fmt",
            "-",
            "-o",
            out.to_str().expect("utf8"),
            "--renumber",
            "10,5",
        ],
        b"G0 X1\nN7 G1 X2 F3\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(&out).expect("read"),
        "N10 G0 X1\nN15 G1 X2 F3\n"
    );
}

#[test]
fn fmt_keeps_digits_and_normalises_only_when_asked() {
    let src = b"g1x-.25 Y1.50000 f100\nG0 X+1. (keep)\n";
    let o = lampost_stdin(&["fmt", "-"], src);
    assert_eq!(
        String::from_utf8_lossy(&o.stdout),
        "G1 X-.25 Y1.50000 F100\nG0 X+1. (keep)\n"
    );
    let o = lampost_stdin(&["fmt", "-", "--dialect", "fadal", "--units", "inch"], src);
    assert_eq!(
        String::from_utf8_lossy(&o.stdout),
        "%\nG1 X-0.2500 Y1.5000 F100.\nG0 X1.0000 (keep)\n%\n"
    );
    let o = lampost_stdin(&["fmt", "-", "--renumber", "10,x"], src);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("START,STEP"));
}

#[test]
fn trace_reads_stdin_and_reports_macros() {
    let o = lampost_stdin(
        &["trace", "-"],
        b"G21 G0 X1 Y2 Z3\nG1 G31 X+R6. F+R4. P1\nG1 X4 F50\n",
    );
    assert!(o.status.success());
    assert_eq!(
        String::from_utf8_lossy(&o.stdout),
        "G0 X1 Y2 Z3\nG1 X4 Y2 Z3 F50\n"
    );
    assert!(stderr(&o).contains("register (R) values is not evaluated"));
}

fn fixture(name: &str) -> String {
    root()
        .join("fixtures/programs")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

#[test]
fn snapshot_trace_of_feature_fixture() {
    let o = lampost(&["trace", &fixture("features.ngc")]);
    assert!(o.status.success(), "{}", stderr(&o));
    insta::assert_snapshot!("trace_features", String::from_utf8_lossy(&o.stdout));
}

#[test]
fn snapshot_fmt_fadal_of_probe_fixture() {
    let o = lampost(&[
        "fmt",
        &fixture("fadal-probe-touch.nc"),
        "--dialect",
        "fadal",
        "--units",
        "inch",
        "--renumber",
        "10,10",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    insta::assert_snapshot!("fmt_fadal_probe", String::from_utf8_lossy(&o.stdout));
}

/// Comments in another encoding (Latin-1 from an older CAM system: `(Ø 6 mm Fräser)`) are
/// no reason to refuse a program a control runs: check, trace, fmt and post read it with
/// one warning, the bytes as `?`; a byte outside a comment is still refused, located.
#[test]
fn latin1_comments_are_read_with_one_warning() {
    let dir = tempdir("latin1");
    let p = dir.join("latin1.nc");
    std::fs::write(
        &p,
        b"%\n(\xd8 6 mm Fr\xe4ser)\nG21 G90 G17\nG0 X0 Y0 Z5 ; Sicherheitsh\xf6he\nG1 Z-1 F100 (Tiefe \xb1 0.1)\nG1 X10\nG2 X20 Y0 I5 J0\nM30\n%\n",
    )
    .expect("write");
    let ps = p.to_str().expect("utf8");
    let o = lampost(&["check", ps]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(err.matches("not UTF-8").count(), 1, "{err}");
    assert!(err.contains(":2:2"), "{err}");
    let o = lampost(&["trace", "--json", ps]);
    assert!(o.status.success(), "{}", stderr(&o));
    let trace: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let moves = trace["moves"].as_array().expect("moves");
    assert_eq!(moves.len(), 4);
    assert_eq!(axis(&moves[3]["end"], "X"), 20.0);
    let o = lampost(&["fmt", ps]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).expect("fmt writes UTF-8");
    assert!(text.contains("(? 6 mm Fr?ser)"), "{text}");
    let out = dir.join("latin1.posted.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        ps,
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.exists());
    // Outside a comment the byte is refused where it stands.
    let bad = dir.join("bad.nc");
    std::fs::write(&bad, b"G0 X0 Y0 (\xe4)\nG1 X1 F\xb110\n").expect("write");
    let o = lampost(&["check", bad.to_str().expect("utf8")]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains(":2:8") && err.contains("not UTF-8"), "{err}");
}

/// Line ends as Windows tools write them (`\r\r\n`, PyCAM through a Windows editor), a
/// byte-order mark, and text after M30 (a CAM system's timing note) are read as the
/// controls read them; bare CR line ends are refused by name.
#[test]
fn stray_carriage_returns_byte_order_marks_and_text_after_the_end() {
    let dir = tempdir("crlf");
    let crcr = dir.join("crcr.nc");
    std::fs::write(
        &crcr,
        b"\xef\xbb\xbf(PyCAM)\r\r\nG21 G90\r\r\nG0 X0 Y0 Z5\r\r\nG1 Z-1 F100\r\r\nG1 X10\r\r\nM30\r\r\nPost Process Timed at; 32 Min, 50.0 sec\r\r\n",
    )
    .expect("write");
    let s = crcr.to_str().expect("utf8");
    let o = lampost(&["check", s]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains(":7:1") && err.contains("after the program's end"),
        "{err}"
    );
    let o = lampost(&["trace", "--json", s]);
    assert!(o.status.success(), "{}", stderr(&o));
    let trace: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(trace["moves"].as_array().map(Vec::len), Some(3));
    // Streamed (standard input) the same.
    let bytes = std::fs::read(&crcr).expect("read");
    let o = lampost_stdin(&["trace", "--json", "-"], &bytes);
    assert!(o.status.success(), "{}", stderr(&o));
    let piped: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(piped["moves"], trace["moves"]);
    // Bare CRs: one line, refused at the first CR, by name.
    let cr = dir.join("cr.nc");
    std::fs::write(&cr, b"G21\rG0 X1\rM2\r").expect("write");
    let o = lampost(&["check", cr.to_str().expect("utf8")]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains(":1:4") && err.contains("carriage return"),
        "{err}"
    );
    // Before the end, unreadable text is an error as ever.
    let mid = dir.join("mid.nc");
    std::fs::write(&mid, "G21\nPost Process\nG0 X1\nM30\n").expect("write");
    assert!(!lampost(&["check", mid.to_str().expect("utf8")])
        .status
        .success());
}

/// Programs in other languages (a Heidenhain or Sinumerik program, APT CL data, a KUKA
/// robot program) are refused at their first line that is not G-code, naming the
/// language, and nothing is posted.
#[test]
fn programs_in_other_languages_are_named() {
    let dir = tempdir("foreign");
    for (name, text, line, language) in [
        (
            "part.h",
            "0 BEGIN PGM 1001 MM\n1 BLK FORM 0.1 Z X+0 Y+0 Z-20\n2 TOOL CALL 1 Z S3000\n3 L X+10 Y+5 R0 FMAX M3\n4 END PGM 1001 MM\n",
            1,
            "Heidenhain",
        ),
        (
            "part.mpf",
            "; Sinumerik\nN10 G17 G90 G54 G71\nN20 T=\"MILL_10\" D1\nN30 M6\nN40 G0 X0 Y0 Z5\nN50 G1 Z-1 F200\nN60 CYCLE81(10,0,1,-5)\nN70 M30\n",
            3,
            "Sinumerik",
        ),
        (
            "part.cl",
            "PARTNO TEST\nCUTTER/10.0\nGOTO/1.0,2.0,3.0\nFINI\n",
            1,
            "APT",
        ),
        (
            "part.src",
            "&ACCESS RVP\nDEF part()\nPTP {A1 0,A2 -90,A3 90,A4 0,A5 0,A6 0}\nLIN {X 100,Y 0,Z 50}\nEND\n",
            1,
            "KUKA",
        ),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).expect("write");
        let s = p.to_str().expect("utf8");
        let o = lampost(&["check", s]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{name}: {err}");
        let first = err
            .lines()
            .find(|l| l.starts_with("error:"))
            .unwrap_or("");
        assert!(
            first.contains(language) && first.contains("not G-code"),
            "{name}: {err}"
        );
        assert!(err.contains(&format!("{name}:{line}:")), "{name}: {err}");
        let out = dir.join(format!("{name}.posted.nc"));
        let o = lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            s,
            "-o",
            out.to_str().expect("utf8"),
        ]);
        assert_eq!(o.status.code(), Some(1), "{name}: {}", stderr(&o));
        assert!(stderr(&o).contains(language), "{name}: {}", stderr(&o));
        assert!(!out.exists(), "{name}: nothing written");
    }
}

/// Fanuc/Haas corner words (`,R`, `,C`) and a host's line checksums (`*NN`) are not
/// read: each is a located error whose hint says what it is, never "remove it" (leaving
/// `,R` out would cut a sharp corner where a round one was programmed). Nothing posts.
#[test]
fn corner_words_and_line_checksums_are_named_not_dropped() {
    let dir = tempdir("corner-words");
    let haas = dir.join("haas.nc");
    std::fs::write(
        &haas,
        "%\nO0001\nG20 G90 G17\nG0 X0. Y0. Z.1\nG1 Z-.1 F10.\nG1 X1. ,R.1\nY1.\nG0 Z.1\nM30\n%\n",
    )
    .expect("write");
    let checksums = dir.join("sent.gcode");
    std::fs::write(
        &checksums,
        "G21 G90\nN1 G0 X10 Y20 Z1*45\nN2 G1 X11 Y20 F100*12\nM30\n",
    )
    .expect("write");
    for (file, at, what) in [
        (&haas, ":6:8", "corner rounding"),
        (&checksums, ":2:17", "checksum"),
    ] {
        let s = file.to_str().expect("utf8");
        for flavor in ["auto", "haas", "fanuc", "marlin"] {
            let o = lampost(&["check", "--flavor", flavor, s]);
            let e = stderr(&o);
            assert_eq!(o.status.code(), Some(1), "{flavor}: {e}");
            assert!(e.contains(at) && e.contains(what), "{flavor}: {e}");
            assert!(!e.contains("remove it"), "{flavor}: {e}");
        }
        let out = dir.join("posted.nc");
        let o = lampost(&[
            "post",
            "--machine",
            "fadal-lamp",
            s,
            "-o",
            out.to_str().expect("utf8"),
        ]);
        assert_ne!(o.status.code(), Some(0), "{}", stderr(&o));
        assert!(!out.exists());
    }
}

/// Fanuc/Haas/FADAL coordinate transforms own their axis words (the centre of `G68 X Y
/// R`, of `G51 X Y P`, the mirror axes of `G51.1 X` and `G50.1 X`): no move, no "no
/// motion mode" error, a warning that the transform is not simulated. A Haas mill's bolt
/// hole pattern (`G70 I J L` under a canned cycle) is named, in the haas flavour and where
/// G70 reads as inch; the post refuses both, as their holes are not traced.
#[test]
fn transform_words_are_arguments_and_bolt_hole_patterns_are_named() {
    let dir = tempdir("transforms");
    let prog = dir.join("haas.nc");
    std::fs::write(
        &prog,
        "%\nO01234\nG20 G90 G17 G40 G80\nG0 G54 X0 Y0 Z1.\nG68 X0 Y0 R45.\nG1 X1. Y0 F10.\nG69\nG51 X0 Y0 P2.\nG1 X1. Y1.\nG50\nG51.1 X0\nG1 X2.\nG50.1 X0\nG0 Z1.\nM30\n%\n",
    )
    .expect("write");
    let s = prog.to_str().expect("utf8");
    for flavor in ["fadal", "haas", "fanuc"] {
        let o = lampost(&["trace", "--json", "--flavor", flavor, s]);
        let e = stderr(&o);
        assert!(o.status.success(), "{flavor}: {e}");
        assert!(
            e.contains("G68 (coordinate rotation) is not simulated")
                && e.contains("G51 (scaling)")
                && e.contains("G51.1 (mirroring)"),
            "{flavor}: {e}"
        );
        let trace: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
        // The G0, three G1 and the last G0: no move to a transform's centre.
        assert_eq!(trace["moves"].as_array().map(Vec::len), Some(5), "{flavor}");
    }
    let bolt = dir.join("bolt.nc");
    std::fs::write(
        &bolt,
        "%\nO01235\nG20 G90 G17 G40 G80\nG0 G54 X0 Y0 Z1.\nG81 G98 Z-.5 R.1 F10. L0\nG70 I1. J0. L6\nG80\nG0 Z1.\nM30\n%\n",
    )
    .expect("write");
    let s = bolt.to_str().expect("utf8");
    for (flavor, says) in [
        ("haas", "a bolt hole pattern"),
        ("auto", "bolt hole pattern; read with --flavor haas"),
    ] {
        let o = lampost(&["check", "--flavor", flavor, s]);
        let e = stderr(&o);
        assert!(
            o.status.success() && e.contains(":6:1") && e.contains(says),
            "{flavor}: {e}"
        );
        let out = dir.join("posted.nc");
        let o = lampost(&[
            "post",
            "--machine",
            "fadal-lamp",
            "--flavor",
            flavor,
            s,
            "-o",
            out.to_str().expect("utf8"),
        ]);
        assert_eq!(o.status.code(), Some(1), "{flavor}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("bolt hole") && !out.exists(),
            "{}",
            stderr(&o)
        );
    }
    // Haas text engraving: its X Y Z are where and how deep the text is cut, not a rapid
    // down to Z-.005.
    let engrave = dir.join("engrave.nc");
    std::fs::write(
        &engrave,
        "G20 G90 G17\nG0 X0 Y0 Z1\nG47 P0 (LAMPOST) X0 Y0 I0 J.5 R.05 Z-.005 F15. E10.\nG0 Z1\nM30\n",
    )
    .expect("write");
    let o = lampost(&[
        "trace",
        "--json",
        "--flavor",
        "haas",
        engrave.to_str().expect("utf8"),
    ]);
    let e = stderr(&o);
    assert!(
        o.status.success() && e.contains("Haas text engraving"),
        "{e}"
    );
    let trace: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let moves = trace["moves"].as_array().cloned().unwrap_or_default();
    assert!(
        !moves.is_empty() && moves.iter().all(|m| axis(&m["end"], "Z") > 0.5),
        "{moves:?}"
    );
}

/// Fusion 360's Haas 5-axis output: TCPC (G234), dynamic work offset (G254/G255) and
/// feature coordinates (G268/G269) are named, not "unknown"; the post refuses them.
#[test]
fn haas_five_axis_codes_are_named() {
    let dir = tempdir("haas-5x");
    let prog = dir.join("umc.nc");
    std::fs::write(
        &prog,
        "%\nO1001\nG90 G94 G17\nG20\nG254\nG0 X0 Y0 Z1.\nG234 H1\nG268 X0 Y0 Z0 I0 J45. K0 Q123\nG1 X1 F10.\nG269\nG255\nM30\n%\n",
    )
    .expect("write");
    let s = prog.to_str().expect("utf8");
    let o = lampost(&["check", "--flavor", "haas", s]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    for (at, what) in [
        (":5:1", "DWO"),
        (":7:1", "TCPC"),
        (":8:1", "feature coordinates"),
    ] {
        assert!(e.contains(at) && e.contains(what), "{e}");
    }
    assert!(!e.contains("unknown G-code"), "{e}");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--flavor",
        "haas",
        s,
        "-o",
        "-",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(":5: G254") && o.stdout.is_empty(),
        "{}",
        stderr(&o)
    );
}

/// Marlin's own G-codes in a slicer program: `G26 C P T` (mesh validation pattern, bare
/// flags) and `G12 P0 S1 T3` (nozzle cleaning) move the nozzle: each is named at its line
/// (no "letter without number" error), and the post refuses them.
#[test]
fn marlin_firmware_moves_are_named() {
    let dir = tempdir("marlin-own");
    let prog = dir.join("m.gcode");
    std::fs::write(
        &prog,
        ";FLAVOR:Marlin\nG21\nG90\nM82\nG92 E0\nG1 Z0.2 F600\nG1 X10 Y10 F3000\nG12 P0 S1 T3\nG1 X30 Y10 E2.0\nG26 C P T\nM30\n",
    )
    .expect("write");
    let s = prog.to_str().expect("utf8");
    let o = lampost(&["check", s]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(e.contains(":8:1") && e.contains("nozzle cleaning"), "{e}");
    assert!(e.contains(":10:1") && e.contains("G26"), "{e}");
    let o = lampost(&["post", "--machine", "nrc-lc", "--e-extrusion", s, "-o", "-"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(":8: G12") && o.stdout.is_empty(),
        "{}",
        stderr(&o)
    );
}

/// A length word with no decimal point under `--flavor fanuc` or `haas` (`X30`): those
/// controls read it in least input increments by default (0.030 mm), lampost in whole
/// units. Warned once, located, on a fast-lane line too; never for zero, a word with its
/// point, a macro call's arguments or under another flavour; F counts on a Haas only.
/// The post refuses the program and writes nothing.
#[test]
fn whole_number_lengths_under_fanuc_and_haas_are_warned_and_not_posted() {
    let dir = tempdir("integer-words");
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).expect("write");
        p.to_str().expect("utf8").to_string()
    };
    let fanuc = write(
        "fanuc.nc",
        "O1000\nG21 G90 G54\nG0 X10. Y0\nG1 Z-5. F100\nG1 X30\nG1 Y40\nM30\n",
    );
    let o = lampost(&["check", "--flavor", "fanuc", &fanuc]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains("`X30` has no decimal point")
            && e.contains("0.030 mm")
            && e.contains("3401#0")
            && e.contains("fanuc.nc:5:4"),
        "{e}"
    );
    assert_eq!(e.matches("has no decimal point").count(), 1, "once: {e}");
    // The same program as LinuxCNC reads it: whole units, nothing to say.
    let o = lampost(&["check", "--flavor", "linuxcnc", &fanuc]);
    assert!(!stderr(&o).contains("decimal point"), "{}", stderr(&o));
    // F without a point: a Haas (setting 77), not a Fanuc.
    let haas = write(
        "haas.nc",
        "O1000\nG20 G90 G54\nG0 X1.5 Y0.\nG65 P9000 A1 B2\nG1 Z-.1 F20\nM30\n",
    );
    let o = lampost(&["check", "--flavor", "haas", &haas]);
    let e = stderr(&o);
    assert!(
        e.contains("`F20` has no decimal point")
            && e.contains("0.0020 in/min")
            && e.contains("setting 77")
            && e.contains("haas.nc:5:"),
        "{e}"
    );
    let fanuc_feed = write("ff.nc", "G21 G90\nG1 X1. F100\nM30\n");
    let o = lampost(&["check", "--flavor", "fanuc", &fanuc_feed]);
    assert!(!stderr(&o).contains("decimal point"), "{}", stderr(&o));
    // The post does not guess.
    let out = dir.join("out.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--flavor",
        "fanuc",
        &fanuc,
        "-o",
        out.to_str().expect("utf8"),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("fanuc.nc:5") && e.contains("`X30.`"), "{e}");
    assert!(!out.exists(), "nothing is written");
    // With every point written, it posts.
    let pointed = write(
        "pointed.nc",
        "O1000\nG21 G90 G54\nG0 X10. Y0\nG1 Z-5. F100\nG1 X30.\nG1 Y40.\nM30\n",
    );
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--flavor",
        "fanuc",
        &pointed,
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}
