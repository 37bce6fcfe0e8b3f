//! Slicer programs (issue 12, item 2): each line of "what is wrong today" as a test.

use lampost_gcode::{
    check, parse_line, parse_line_with, Block, EWord, ErrorKind, Event, Item, Move, MoveKind,
    Options, Stream,
};

fn slicer() -> Options {
    Options {
        e_word: EWord::Extrusion,
        ..Options::default()
    }
}

/// Moves and errors of `src` read as a slicer program.
fn run(src: &str) -> (Vec<Move>, Vec<String>) {
    let mut moves = Vec::new();
    let mut errors = Vec::new();
    for ev in Stream::from_bytes(src.as_bytes(), slicer(), false) {
        match ev.expect("in memory") {
            Event::Move(m) => moves.push(m),
            Event::Diagnostic(d) if d.is_error() => errors.push(format!("{}: {}", d.line, d.kind)),
            Event::Diagnostic(_) | Event::Stop(_) => {}
        }
    }
    (moves, errors)
}

fn texts(b: &Block<'_>) -> Vec<String> {
    b.items
        .iter()
        .filter_map(|i| match i {
            Item::Text(t) => Some(t.text.to_string()),
            _ => None,
        })
        .collect()
}

#[test]
fn g92_e_resets_the_extruder_without_motion() {
    let (moves, errors) = run("G92 E0\nG1 X1 Y0 F600 E5\nG92 E0\nG1 X2 E1\n");
    assert!(errors.is_empty(), "{errors:?}");
    assert_eq!(moves.len(), 2);
    assert_eq!(moves[1].extrusion, Some(1.0));
    assert_eq!(moves[1].extruded, Some(1.0), "E grows by 1 after the reset");
    // Fixture-offset E keeps its meaning: G92 with only E is still an error there.
    let d = check(b"G92 E0\n", Options::default());
    assert!(d.iter().any(|d| d.is_error()));
}

#[test]
fn firmware_settings_with_axis_letters_are_not_motion() {
    let src = "M201 X2500 Y2500 Z400 E5000\nM203 X400 Y400 Z12 E80\nM204 P4000 R1250 T4000\n\
               M205 X1.00 Y1.00 Z1.00 E1.00\nM92 X80 Y80 Z400 E93\nM906 X800 Y800\n\
               M907 X1 Y2\nM900 K0.05\nM572 S0.3\nM220 S100\nM221 S95\nM206 X1\nG1 X5 Y5 F600\n";
    let (moves, errors) = run(src);
    assert!(errors.is_empty(), "{errors:?}");
    assert_eq!(moves.len(), 1, "only the G1 moves");
    assert_eq!(
        moves[0].start, [0.0; 9],
        "M205 X1 Y1 Z1 is not a move to (1, 1, 1)"
    );
    assert_eq!(moves[0].axes_named, 0b11, "settings name no axes");
    assert_eq!(moves[0].extruded, Some(0.0), "M205 E1 is not extrusion");
    // The same in a CNC program (E as fixture offset): no motion, no error.
    let d = check(b"M205 X1 Y1 Z1\nM201 X2500\n", Options::default());
    assert!(d.is_empty(), "{d:?}");
}

#[test]
fn homing_with_bare_axis_letters() {
    let (moves, errors) = run("G0 X5 Y6 Z7\nG28 X\nG28 X Y\nG162 X Y F2500\nG161 Z\nM569 S1 X Y\n");
    assert!(errors.is_empty(), "{errors:?}");
    // G28 X homes X alone (home taken as 0, as G28 is read everywhere), with no
    // intermediate point.
    assert_eq!(moves[1].end[..3], [0.0, 6.0, 7.0]);
    assert_eq!(moves[1].block_axes, 0b1);
    assert_eq!(moves[2].end[..3], [0.0, 0.0, 7.0]);
    assert_eq!(moves.len(), 5);
    assert_eq!(moves[4].end[..3], [0.0, 0.0, 0.0]);
    // A bare letter outside homing and settings is still an error.
    let (_, errors) = run("G1 X Y1 F100\n");
    assert_eq!(errors.len(), 1);
    let (_, errors) = run("T1 X\n");
    assert_eq!(errors.len(), 1, "{errors:?}");
    let (_, errors) = run("G28 X judge\n");
    assert_eq!(errors.len(), 1, "{errors:?}");
}

#[test]
fn dwell_in_seconds_or_bare() {
    let (moves, errors) = run("G4 S1\nG4\nG4 P100\n");
    assert!(errors.is_empty(), "{errors:?}");
    assert!(moves.is_empty());
    let (moves, _) = run("S1000\nG4 S1\nG1 X1 F100\n");
    assert_eq!(moves[0].modal.speed, 1000.0, "G4's S is seconds, not speed");
}

#[test]
fn strings_and_bare_tokens_are_kept_verbatim() {
    for (line, kept) in [
        (
            "M862.3 P \"MINI\" ; printer model check",
            vec!["P \"MINI\""],
        ),
        ("M862.6 P\"Input shaper\"", vec!["P\"Input shaper\""]),
        ("M486 A3DBenchy.stl", vec!["A3DBenchy.stl"]),
        ("T0 R", vec!["R"]),
        ("M221 R", vec!["R"]),
        (
            "M1002 judge_flag g29_before_print_flag",
            vec!["judge_flag", "g29_before_print_flag"],
        ),
        (
            "M117 Printing (layer 1) 50%",
            vec!["Printing (layer 1) 50%"],
        ),
        ("M118 E1 hello ; comment", vec!["E1 hello"]),
        ("M569 S1 X Y", vec!["X", "Y"]),
    ] {
        let b = parse_line(line.as_bytes(), 1, 0).unwrap_or_else(|e| panic!("{line}: {e}"));
        assert_eq!(texts(&b), kept, "{line}");
        let (moves, errors) = run(&format!("G1 X1 F100\n{line}\n"));
        assert!(errors.is_empty(), "{line}: {errors:?}");
        assert_eq!(moves.len(), 1, "{line}");
        // Written back as read.
        let mut out = Vec::new();
        let mut em = lampost_gcode::Emitter::new(&mut out, lampost_gcode::EmitOptions::default());
        em.block(&b).expect("emits");
        em.finish().expect("emits");
        let again = parse_line(&out[..out.len() - 1], 1, 0).expect("parses again");
        assert!(
            b.same_content(&again),
            "{line} -> {}",
            String::from_utf8_lossy(&out)
        );
    }
    // Outside those codes a letter without a number is still refused.
    for line in ["G1 X F100", "M3 X", "G1 \"a\"", "G1 I"] {
        assert!(parse_line(line.as_bytes(), 1, 0).is_err(), "{line}");
    }
    // Marlin's inline laser mode flag: `M3 I` (finding 68).
    for line in ["M3 I", "M4 S100 I", "M5 I"] {
        let b = parse_line(line.as_bytes(), 1, 0).unwrap_or_else(|e| panic!("{line}: {e}"));
        assert_eq!(texts(&b), ["I"], "{line}");
    }
}

#[test]
fn relative_and_absolute_extrusion() {
    // M83: each E is the increment; the second E1.0 deposits again.
    let (m, errors) = run("M83\nG1 X1 F600 E1.0\nG1 X2 E1.0\nG1 X3 E-0.5\n");
    assert!(errors.is_empty(), "{errors:?}");
    let grown: Vec<_> = m.iter().map(|m| m.extruded.unwrap_or(f64::NAN)).collect();
    assert_eq!(grown, [1.0, 1.0, -0.5]);
    assert_eq!(m[2].extrusion, Some(1.5));
    // M82: the difference from the last E.
    let (m, _) = run("M82\nG1 X1 F600 E1.0\nG1 X2 E1.0\nG1 X3 E3\n");
    let grown: Vec<_> = m.iter().map(|m| m.extruded.unwrap_or(f64::NAN)).collect();
    assert_eq!(grown, [1.0, 0.0, 2.0]);
}

#[test]
fn e_only_and_f_only_lines_are_not_moves() {
    let (m, errors) = run("G1 X1 F600 E1\nG1 E.2 F2100\nG1 E1 F2400\nG1 F1200\nF600\nG1 X2 E2\n");
    assert!(errors.is_empty(), "{errors:?}");
    assert_eq!(
        m.len(),
        2,
        "retract, unretract and F-only lines move nothing"
    );
    // The unretract's E does not count as growth along the next move.
    assert_eq!(m[1].extruded, Some(1.0));
    // A G1 with no E after a G0 that raised E grows nothing.
    let (m, _) = run("G1 X0 F600\nG0 X1 E5\nG1 X2\n");
    assert_eq!(m[1].kind, MoveKind::Rapid);
    assert_eq!(m[2].extruded, Some(0.0));
}

#[test]
fn exponents_only_where_e_is_extrusion() {
    let (m, errors) = run("G1 X1e-05 Y5 F600 E1.5e1\n");
    assert!(errors.is_empty(), "{errors:?}");
    assert_eq!(m[0].end[0], 1e-5);
    assert_eq!(m[0].end[1], 5.0);
    assert_eq!(m[0].extrusion, Some(15.0));
    // Upper-case E always starts a word.
    let mut b = Block::empty(1, 0);
    parse_line_with(b"G1 X1E-5 Y5", 1, 0, &mut b, true).expect("parses");
    assert_eq!(b.word(b'X').map(|w| w.value), Some(1.0));
    assert_eq!(b.word(b'E').map(|w| w.value), Some(-5.0));
    // Without exponents (E a FADAL fixture offset) `e` is a word too.
    let b = parse_line(b"G0 X1e5", 1, 0).expect("parses");
    assert_eq!(b.word(b'E').map(|w| w.value), Some(5.0));
    let d = check(b"G1 X1e-05 Y5 F600\n", slicer());
    assert!(d.is_empty(), "{d:?}");
    assert!(matches!(
        parse_line(b"G1 X", 1, 0)
            .map(|_| ())
            .expect_err("no number")
            .kind,
        ErrorKind::LetterWithoutNumber('X')
    ));
}

/// Klipper's extended commands in a printer program (a RatOS SuperSlicer program starts
/// with `START_PRINT …`): a setting is a warning and ignored, a macro a warning that says
/// its moves are not known (the post refuses it); never "the letter S has no number".
/// In a machining program, or for a token shaped like a word or a typo, they stay errors.
#[test]
fn klipper_commands_are_named_not_misread() {
    let src = "START_PRINT BED_TEMP=60 EXTRUDER_TEMP=210 ; start\n\
               SET_PRESSURE_ADVANCE ADVANCE=0.04\n\
               EXCLUDE_OBJECT_START NAME=cube\n\
               G1 X5 Y5 F600\n\
               _ON_LAYER_CHANGE\n\
               G1 X6 E0.1\n\
               EXCLUDE_OBJECT_END NAME=cube\n";
    let mut kinds = Vec::new();
    let mut moves = 0;
    for ev in Stream::from_bytes(src.as_bytes(), slicer(), false) {
        match ev.expect("in memory") {
            Event::Move(_) => moves += 1,
            Event::Diagnostic(d) => {
                kinds.push((d.line, d.is_error(), d.kind.clone(), d.snippet.text.clone()))
            }
            Event::Stop(_) => {}
        }
    }
    assert_eq!(moves, 2);
    assert!(kinds.iter().all(|k| !k.1), "{kinds:?}");
    let macros: Vec<u32> = kinds
        .iter()
        .filter(|k| matches!(k.2, ErrorKind::FirmwareMacro(_)))
        .map(|k| k.0)
        .collect();
    let settings: Vec<u32> = kinds
        .iter()
        .filter(|k| matches!(k.2, ErrorKind::FirmwareSetting(_)))
        .map(|k| k.0)
        .collect();
    assert_eq!(macros, [1, 5]);
    assert_eq!(settings, [2, 3, 7]);
    // The command's text, without its comment.
    assert!(
        matches!(&kinds[0].2, ErrorKind::FirmwareMacro(t) if t == "START_PRINT BED_TEMP=60 EXTRUDER_TEMP=210"),
        "{kinds:?}"
    );
    // A machining program, a word-shaped token and a typo of G0 stay errors.
    let d = check(b"START_PRINT\n", Options::default());
    assert!(d.iter().any(|d| d.is_error()), "{d:?}");
    for line in ["GOX1\n", "GO X1\n", "G1X\n"] {
        let (_, errors) = run(line);
        assert!(!errors.is_empty(), "{line}");
    }
}

/// E's mode across G90/G91, where firmwares differ: after `M83` a `G90` keeps E relative
/// (Marlin 1, Prusa, RepRapFirmware), said once in a warning because Marlin 2 reads E as
/// positions there; under `--flavor reprap` G91 never makes E relative (RepRapFirmware:
/// only M82/M83 set it), elsewhere it does (Marlin).
#[test]
fn e_mode_across_g90_and_g91_follows_the_flavour() {
    let extruded = |src: &str, opts: Options| -> (Vec<Option<f64>>, Vec<(u32, ErrorKind)>) {
        let mut e = Vec::new();
        let mut d = Vec::new();
        for ev in Stream::from_bytes(src.as_bytes(), opts, false) {
            match ev.expect("in memory") {
                Event::Move(m) => e.push(m.extruded),
                Event::Diagnostic(x) => d.push((x.line, x.kind)),
                Event::Stop(_) => {}
            }
        }
        (e, d)
    };
    let (e, d) = extruded("M83\nG90\nG1 X1 E1 F600\nG90\nG1 X2 E1\n", slicer());
    assert_eq!(e, [Some(1.0), Some(1.0)], "E stays relative");
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0], (2, ErrorKind::EModeAfterG90));
    // An M82 or M83 before any E settles what E is: nothing to doubt (PrusaSlicer's
    // start code writes `G90` then `M83` on the next line).
    let (e, d) = extruded("M83\nG90\nM83\nG1 X1 E1 F600\nG1 X2 E1\n", slicer());
    assert_eq!(e, [Some(1.0), Some(1.0)]);
    assert!(d.is_empty(), "{d:?}");
    let (e, d) = extruded("M83\nG90\nG1 X1 F600\nM82\nG1 X2 E1\nG1 X3 E3\n", slicer());
    assert_eq!(e, [Some(0.0), Some(1.0), Some(2.0)]);
    assert!(d.is_empty(), "{d:?}");
    // A G92 E does not settle it; the warning still names the G90's line.
    let (_, d) = extruded("M83\nG90\nG92 E0\nG1 X1 E1 F600\n", slicer());
    assert_eq!(d, [(2, ErrorKind::EModeAfterG90)]);
    let reprap = Options {
        flavor: lampost_gcode::Flavor::RepRap,
        ..slicer()
    };
    let (_, d) = extruded("M83\nG90\nG1 X1 E1 F600\n", reprap);
    assert!(d.is_empty(), "RepRapFirmware: no doubt, {d:?}");
    let g91 = "M82\nG91\nG1 X1 E1 F600\nG1 X1 E2\n";
    let (e, _) = extruded(g91, reprap);
    assert_eq!(
        e,
        [Some(1.0), Some(1.0)],
        "RepRapFirmware: E absolute under G91"
    );
    let (e, _) = extruded(g91, slicer());
    assert_eq!(e, [Some(1.0), Some(2.0)], "Marlin: G91 makes E relative");
}

#[test]
fn a_whole_line_paren_comment_may_hold_parentheses_in_a_slicer_program() {
    // Skeinforge 12.01.13's settings lines (fixtures/real-programs/skeinforge).
    let line = b"(<setting> comb Running_Jump_Space_(mm): 2.0 </setting>)";
    let mut b = Block::empty(1, 0);
    parse_line_with(line, 1, 0, &mut b, true).expect("a firmware skips the line");
    let comments: Vec<&str> = b
        .items
        .iter()
        .filter_map(|i| match i {
            Item::Comment(c) => Some(c.text),
            _ => None,
        })
        .collect();
    assert_eq!(
        comments,
        ["<setting> comb Running_Jump_Space_(mm): 2.0 </setting>"]
    );
    assert!(b.word(b'G').is_none() && b.word(b'X').is_none());
    // Elsewhere comments do not nest, as on the controls.
    let e = parse_line(line, 1, 0).map(|_| ()).expect_err("nested");
    assert_eq!(e.kind, ErrorKind::NestedComment);
    // A line that reads as G-code keeps its reading: the comment, then the move.
    let (m, errors) = run("G1 X0 Y0 F600\n(note) G1 X1 E1\n(a (b) c)\nG1 X2 E2\n");
    assert!(errors.is_empty(), "{errors:?}");
    assert_eq!(m.len(), 3);
    assert_eq!(m[1].end[0], 1.0);
    // A `(` that never closes is still refused.
    let (_, errors) = run("(open (comment\n");
    assert_eq!(errors.len(), 1, "{errors:?}");
}

#[test]
fn makerbot_extrudes_with_a_or_b() {
    let opts = lampost_gcode::Flavor::MakerBot.options(Options::default(), None);
    let moves = |src: &str| -> (Vec<Move>, Vec<ErrorKind>) {
        let mut m = Vec::new();
        let mut d = Vec::new();
        for ev in Stream::from_bytes(src.as_bytes(), opts, false) {
            match ev.expect("in memory") {
                Event::Move(mv) => m.push(mv),
                Event::Diagnostic(x) => d.push(x.kind),
                Event::Stop(_) => {}
            }
        }
        (m, d)
    };
    // Miracle-Grue: A is the extruder, absolute; an A-only move (a squirt) moves nothing.
    let (m, d) = moves(
        "G21\nG1 X-15 Y-11 Z0.6 F6000\nG1 F1200 A1 (squirt)\nG1 X15 Y-11 Z0.6 F1800 A7.096 (d: 30)\nG1 X15 Y-13 A7.489\nG92 A0\nG1 X0 Y0 B0.5\n",
    );
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(m.len(), 4, "{m:?}");
    assert_eq!(m[1].extrusion, Some(7.096));
    assert_eq!(m[2].extrusion, Some(7.489));
    assert_eq!(m[3].extrusion, Some(0.5));
    // Every move stays at A = B = 0: they are no axes here.
    assert!(m.iter().all(|mv| mv.end[3] == 0.0 && mv.end[4] == 0.0));
    // Two extruder words in one block are refused.
    let (_, d) = moves("G21\nG1 X1 Y1 F100 A1 B1\n");
    assert!(
        matches!(d.as_slice(), [ErrorKind::DuplicateWord(_)]),
        "{d:?}"
    );
}

#[test]
fn a_reprapfirmware_macro_file_call_is_named_not_refused() {
    let src = "M83\nM98 P\"/macros/purge.g\"\nG1 X10 Y10 E.5 F1800\n";
    let mut d = Vec::new();
    let mut moves = 0;
    for ev in Stream::from_bytes(src.as_bytes(), slicer(), false) {
        match ev.expect("in memory") {
            Event::Move(_) => moves += 1,
            Event::Diagnostic(x) => d.push(x),
            Event::Stop(_) => {}
        }
    }
    assert_eq!(moves, 1);
    assert_eq!(d.len(), 1, "{d:?}");
    assert!(
        matches!(&d[0].kind, ErrorKind::SubprogramNotFollowed(w) if w.contains("/macros/purge.g")),
        "{d:?}"
    );
    assert_eq!(d[0].severity, lampost_gcode::Severity::Warning);
}
