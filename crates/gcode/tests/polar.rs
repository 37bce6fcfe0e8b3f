//! LinuxCNC's polar coordinates (`@` radius, `^` angle in degrees from +X): each rule
//! against what LinuxCNC's rs274 prints for the same program (the values in the comments
//! are rs274's, to its 4 decimals), each refusal located.

use std::io::Cursor;

use lampost_gcode::{
    Diagnostic, ErrorKind, Event, Flavor, Options, Order, ProgramReader, Severity, Stream,
};

fn run_as(flavor: Flavor, text: &str) -> (Vec<[f64; 3]>, Vec<Diagnostic>) {
    let r = ProgramReader::new(Cursor::new(text.as_bytes()), Order::Execution);
    let opts = flavor.options(Options::default(), None);
    let mut moves = Vec::new();
    let mut diags = Vec::new();
    for e in Stream::new(r, opts, true) {
        match e.expect("reads") {
            Event::Move(m) => moves.push([m.end[0], m.end[1], m.end[2]]),
            Event::Diagnostic(d) => diags.push(d),
            Event::Stop(_) => {}
        }
    }
    (moves, diags)
}

fn run(text: &str) -> (Vec<[f64; 3]>, Vec<Diagnostic>) {
    run_as(Flavor::LinuxCnc, text)
}

/// The moves' X and Y, to rs274's printed resolution.
fn xy(moves: &[[f64; 3]]) -> Vec<[f64; 2]> {
    let r = |v: f64| (v * 1e4).round() / 1e4 + 0.0;
    moves.iter().map(|m| [r(m[0]), r(m[1])]).collect()
}

/// The program's one error: its line, column and kind.
fn error(text: &str) -> (u32, u32, ErrorKind) {
    let (_, d) = run(text);
    let e: Vec<_> = d.iter().filter(|d| d.severity == Severity::Error).collect();
    assert_eq!(e.len(), 1, "{text}: {d:?}");
    (e[0].line, e[0].column, e[0].kind.clone())
}

#[test]
fn absolute_words_give_the_point_and_an_omitted_one_is_kept() {
    let (m, d) = run("G20 G90 G0 X2.5 Y0\nG0 @1 ^90\nG0 ^180\nG0 @2\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    // rs274: (2.5, 0), (0, 1), (-1, 0), (-2, 0).
    assert_eq!(xy(&m), [[2.5, 0.0], [0.0, 1.0], [-1.0, 0.0], [-2.0, 0.0]]);
    // `^` alone at the origin: radius 0, the tool stays there.
    let (m, d) = run("G20 G90 G0 X0 Y0\nG0 ^30\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(xy(&m), [[0.0, 0.0], [0.0, 0.0]]);
}

#[test]
fn incremental_words_add_to_the_radius_and_the_angle() {
    let (m, d) = run("G20 G90 G0 X-2 Y0\nG91 G0 @1\nG0 ^45\nG0 @1 ^-45\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    // rs274: (-3, 0), (-2.1213, -2.1213), then radius 4 turned on to -180°: (-4, 0).
    assert_eq!(
        xy(&m),
        [[-2.0, 0.0], [-3.0, 0.0], [-2.1213, -2.1213], [-4.0, 0.0]]
    );
}

#[test]
fn points_are_about_the_origin_of_the_work_system() {
    // G92 and G10 L2 offsets: the angle and radius are the program's (rs274 prints the
    // same program coordinates).
    let (m, d) = run("G20 G90 G0 X1 Y0\nG92 X0 Y0\nG0 @1 ^90\nG0 X2\nG0 ^90\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(xy(&m), [[1.0, 0.0], [0.0, 1.0], [2.0, 1.0], [0.0, 2.2361]]);
    let (m, d) = run("G20 G90 G0 X1 Y0\nG10 L2 P1 X1 Y1\nG54 G0 @1 ^90\nG0 ^180\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(xy(&m), [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]]);
}

#[test]
fn values_may_be_expressions_and_parameters() {
    let (m, d) = run("G20 G90 G0 X1 Y0\n#1=30\nG0 @[1+1] ^#1\nG0 @ 3 ^ -45\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    // rs274: (1.7321, 1), (2.1213, -2.1213).
    assert_eq!(xy(&m), [[1.0, 0.0], [1.7321, 1.0], [2.1213, -2.1213]]);
}

#[test]
fn arcs_probes_and_feed_moves_end_at_the_polar_point() {
    let (m, d) = run(
        "G20 G90 G0 X1 Y0 F10\nG3 @1 ^90 I-1 J0\nG3 ^180 R1\nG91 G2 ^-90 R1\nG90 G1 @1 ^0 Z-1\nG38.2 @2 ^0\nM2\n",
    );
    // The probe move is warned about (it stops where the probe touches).
    assert!(d.iter().all(|d| d.severity == Severity::Warning), "{d:?}");
    // rs274: arcs to (0, 1), (-1, 0), (0, 1); a feed to (1, 0, -1); a probe to (2, 0).
    assert_eq!(
        xy(&m),
        [
            [1.0, 0.0],
            [0.0, 1.0],
            [-1.0, 0.0],
            [0.0, 1.0],
            [1.0, 0.0],
            [2.0, 0.0]
        ]
    );
    assert_eq!(m[4][2], -1.0);
    // A rigid tap to the polar point and back (rs274: RIGID_TAP(0, 1, -1)), a thread.
    let (m, _) = run("G20 G90 G0 X1 Y0 F10 S100 M3\nG33.1 @1 ^90 Z-1 K.1\nG33 @2 ^0 Z-1 K.1\nM2\n");
    assert_eq!(xy(&m), [[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [2.0, 0.0]]);
}

#[test]
fn canned_cycles_place_their_holes_by_polar_words() {
    // LinuxCNC's hole-circle.ngc: six holes 60° apart on a radius of 1.5, incremental.
    let (m, d) = run("G20 G17 G90\nG0 X1.5 Y0 Z0\nG91 G81 R.1 Z-.5 ^60 L6 F10\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    let holes: Vec<_> = xy(&m).into_iter().skip(2).step_by(3).collect();
    assert_eq!(
        holes,
        [
            [0.75, 1.299],
            [-0.75, 1.299],
            [-1.5, 0.0],
            [-0.75, -1.299],
            [0.75, -1.299],
            [1.5, 0.0]
        ]
    );
    // Absolute: `^` alone keeps the radius, and the repeats drill the same hole; `@`
    // alone at the origin is a radius at angle 0 (no error in a cycle).
    let (m, d) =
        run("G20 G90 G0 X0 Y0 Z1\nG81 @2 R.1 Z-.5 F60\nG0 X0 Y0\nG81 ^45 R.1 Z-.5 L2\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(xy(&m)[1], [2.0, 0.0]);
    assert!(xy(&m)[6..].iter().all(|p| *p == [0.0, 0.0]), "{m:?}");
    // `@0` at 153°: the point is (-0, 0), whose angle rs274 takes as 180°.
    let (m, d) = run("G20 G90 G0 X-1 Y0.5 Z1\nG1 @0 F10\nG81 @2 R.1 Z-.5\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(xy(&m)[2], [-2.0, 0.0]);
    // A zero increment is no step, even at the origin (rs274 skips it).
    let (m, d) = run("G20 G90 G0 X0 Y0 Z1\nG91 G81 @0 R.1 Z-.5 F60 L2\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    assert!(xy(&m).iter().all(|p| *p == [0.0, 0.0]));
}

#[test]
fn incremental_cycles_count_r_from_the_initial_level() {
    // LinuxCNC's polar.ngc: the G91 cycle's R counts from the Z where the series of
    // cycles began (0), not from the R plane the G99 cycles left the tool at (0.1).
    let (m, d) =
        run("G20 G90 G0 X2.5 Y0 Z0\nG81 R.1 Z-0.5 F60\nG90 @1 ^33\nG91 G81 @1 R.1 Z-0.5 L2\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    // rs274: holes at radius 2 and 3 along 33°, drilled from 0.1 to -0.4.
    let last = &m[m.len() - 3..];
    assert_eq!(xy(last)[0], [2.516, 1.6339]);
    assert_eq!(
        last.iter()
            .map(|p| (p[2] * 1e4).round() / 1e4)
            .collect::<Vec<_>>(),
        [0.1, -0.4, 0.1]
    );
    // After a G99 cycle, a G98 one in the same series retracts to the initial level
    // (rs274 goes over the next hole at Z1 first).
    let (m, d) = run("G20 G90 G0 X1 Y0 Z1 F10\nG99 G81 R.1 Z-.5\nG98 G81 X2 R.1 Z-.5\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    let z: Vec<f64> = m.iter().map(|p| p[2]).collect();
    assert_eq!(z, [1.0, 1.0, 0.1, -0.5, 0.1, 1.0, 0.1, -0.5, 1.0]);
}

#[test]
fn each_refusal_is_located() {
    let polar = |(line, column, kind): (u32, u32, ErrorKind)| {
        assert!(matches!(kind, ErrorKind::Polar(_)), "{kind:?}");
        (line, column)
    };
    // `@` alone at the origin (G90), any step from the origin (G91).
    assert_eq!(polar(error("G20 G90 G0 X0 Y0\nG0 @1\nM2\n")), (2, 4));
    assert_eq!(polar(error("G20 G91 G0 X0 Y0\nG0 ^1\nM2\n")), (2, 4));
    assert_eq!(
        polar(error("G20 G90 G0 X1 Y0\nG91 G0 @-1 ^30\nM2\n")),
        (2, 8)
    );
    // X or Y in the block: at the X word.
    assert_eq!(polar(error("G20 G90 G0 X1 Y1\nG0 @1 X2\nM2\n")), (2, 7));
    // Outside G17 (the plane before the block), with G53, G92, G28.
    assert_eq!(
        polar(error("G20 G90 G18 G0 X1 Y1\nG17 G0 @1\nM2\n")),
        (2, 8)
    );
    assert_eq!(polar(error("G20 G90 G0 X1 Y1\nG53 G0 @1\nM2\n")), (2, 1));
    assert_eq!(polar(error("G20 G90 G0 X1 Y1\nG92 @1\nM2\n")), (2, 1));
    assert_eq!(polar(error("G20 G90 G0 X1 Y1\nG28 @1\nM2\n")), (2, 1));
    // A cycle whose later repeat steps from the origin: the block is refused whole.
    let text = "G20 G90 G0 X1 Y0 Z1\nG91 G81 @-1 R.1 Z-.5 F60 L2\nM2\n";
    assert_eq!(polar(error(text)), (2, 9));
    let (m, _) = run(text);
    assert_eq!(m.len(), 1, "no move of the refused block: {m:?}");
    // A canned cycle outside G17, splines.
    assert_eq!(
        polar(error("G20 G90 G0 X1 Y0 Z1\nG18 G81 @2 R.1 Z-.5 F10\nM2\n")),
        (2, 9)
    );
    assert_eq!(
        polar(error("G20 G90 G0 X1 Y0 F10\nG5 @1 ^90 I0 J1 P1 Q-1\nM2\n")),
        (2, 1)
    );
    // No motion mode (after G80): as for axis words.
    let (_, _, kind) = error("G20 G90 G0 X1 Y1\nG80\n@1\nM2\n");
    assert_eq!(kind, ErrorKind::NoMotionMode);
    // A word repeated, a number missing, an expression that fails.
    let (_, column, kind) = error("G20 G0 X1 Y0\nG0 @1 @2\nM2\n");
    assert_eq!((column, kind), (7, ErrorKind::DuplicateWord("@".into())));
    let (_, column, kind) = error("G20 G0 X1 Y0\nG0 ^ X1\nM2\n");
    assert_eq!((column, kind), (4, ErrorKind::LetterWithoutNumber('^')));
    let (_, _, kind) = error("G20 G0 X1 Y0\nG0 @[1/0]\nM2\n");
    assert!(matches!(kind, ErrorKind::Expression(_)), "{kind:?}");
}

#[test]
fn other_flavours_refuse_the_characters() {
    for flavor in [
        Flavor::Fadal,
        Flavor::Fanuc,
        Flavor::Haas,
        Flavor::Mach3,
        Flavor::Marlin,
    ] {
        // (`X1.` with its point: Fanuc and Haas warn of `X1`.)
        for (text, ch) in [
            ("G0 X1. Y0\nG0 @1 ^90\n", '@'),
            ("G0 X1. Y0\nG0 ^90\n", '^'),
        ] {
            let (m, d) = run_as(flavor, text);
            assert_eq!(m.len(), 1, "{flavor:?}");
            assert_eq!(d.len(), 1, "{flavor:?}: {d:?}");
            assert_eq!(d[0].kind, ErrorKind::UnexpectedCharacter(ch), "{flavor:?}");
            assert_eq!((d[0].line, d[0].column), (2, 4), "{flavor:?}");
        }
    }
}
