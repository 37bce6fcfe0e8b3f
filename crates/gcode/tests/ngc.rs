//! LinuxCNC parameters, expressions and O-word control flow (issue 12 items 3 and 4),
//! followed through `ProgramReader` in execution order with the `linuxcnc` flavour.

use std::io::Cursor;

use lampost_gcode::{Diagnostic, Event, Flavor, Options, Order, ProgramReader, Stream};

fn run_with(text: &str, max_blocks: Option<u64>) -> (Vec<[f64; 3]>, Vec<Diagnostic>) {
    let mut r = ProgramReader::new(Cursor::new(text.as_bytes()), Order::Execution);
    if let Some(n) = max_blocks {
        r.set_max_blocks(n);
    }
    let opts = Flavor::LinuxCnc.options(Options::default(), None);
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
    run_with(text, None)
}

fn xs(m: &[[f64; 3]]) -> Vec<f64> {
    m.iter().map(|p| p[0]).collect()
}

#[test]
fn subroutines_are_called_never_traced_in_place() {
    let text = "G21 G90\n\
        o100 sub\n\
        G0 X[#1 * 10] Y#2\n\
        o100 endsub\n\
        o<twice> sub\n\
        o100 call [#1] [#1 + 1]\n\
        o100 call [#1 + 1]\n\
        o<twice> return [#1 * 2]\n\
        o<twice> endsub\n\
        o<twice> call [1]\n\
        G0 X#<_value>\n\
        M2\n";
    let (m, d) = run(text);
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(m, [[10.0, 2.0, 0.0], [20.0, 0.0, 0.0], [2.0, 0.0, 0.0]]);
}

#[test]
fn loops_and_branches() {
    let text = "G21 G90 G0 X0\n\
        #1 = 0\n\
        o1 while [#1 LT 5]\n\
        #1 = [#1 + 1]\n\
        o2 if [#1 EQ 2]\n\
        o1 continue\n\
        o2 elseif [#1 EQ 4]\n\
        G0 Y4\n\
        o2 else\n\
        G0 X#1\n\
        o2 endif\n\
        o3 if [#1 GE 5]\n\
        o1 break\n\
        o3 endif\n\
        o1 endwhile\n\
        o4 repeat [3]\n\
        G91 G0 Z1\n\
        o4 endrepeat\n\
        G90\n\
        o5 do\n\
        #1 = [#1 - 2]\n\
        o5 while [#1 GT 0]\n\
        G0 X#1\n\
        M2\n";
    let (m, d) = run(text);
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(
        m,
        [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [3.0, 0.0, 0.0],
            [3.0, 4.0, 0.0],
            [5.0, 4.0, 0.0],
            [5.0, 4.0, 1.0],
            [5.0, 4.0, 2.0],
            [5.0, 4.0, 3.0],
            [-1.0, 4.0, 3.0],
        ]
    );
}

#[test]
fn indirect_parameters_are_set_and_read() {
    // `#[expr] = value` at the start of a line sets the parameter the expression names
    // (pcb2gcode's autolevel stores each probe so): it was read as a FADAL statement.
    let (m, d) = run("G21 G0 X0\n#1 = 2\n#[#1 * 4 + 500] = 7.5\n  #[#1 + 1] = 3\nG0 X#508 Y#3\n");
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(m.last().map(|p| (p[0], p[1])), Some((7.5, 3.0)));
}

#[test]
fn parameters_are_set_after_the_line_is_read() {
    // RS274NGC: `#1 = 2 G0 X#1` moves to the old #1.
    let (m, d) = run("G21 G0 X0\n#1 = 5\n#1 = 2 G0 X#1\nG0 X#1\n");
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(xs(&m), [0.0, 5.0, 2.0]);
}

#[test]
fn feed_from_a_parameter_is_not_lost() {
    // LinuxCNC's mmount.ngc pattern: a feed from a parameter, then plain G1 lines.
    let (m, d) = run("G21 G0 X0\n#1 = 100\nG1 X10 F#1\nG1 X20\nG1 X30\n");
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(xs(&m), [0.0, 10.0, 20.0, 30.0]);
}

/// The first error of `text`: (line, column, message).
fn first_error(text: &str, max_blocks: Option<u64>) -> (u32, u32, String) {
    let (_, d) = run_with(text, max_blocks);
    let e = d
        .iter()
        .find(|d| d.is_error())
        .unwrap_or_else(|| panic!("no error in {text}: {d:?}"));
    (e.line, e.column, e.kind.to_string())
}

#[test]
fn bad_input_is_a_located_error() {
    for (text, line, col, what) in [
        // A while that never ends.
        (
            "G0 X0\no1 while [1]\nG0 X1\no1 endwhile\n",
            4,
            1,
            "more than 1000 blocks",
        ),
        // Recursion without end.
        (
            "o1 sub\no1 call\no1 endsub\no1 call\n",
            2,
            1,
            "nest more than 10 deep",
        ),
        // A call to a missing sub.
        (
            "G0 X0\no<nowhere> call [1]\n",
            2,
            1,
            "no subroutine o<nowhere> sub",
        ),
        // An undefined parameter.
        ("G0 X#<nope>\n", 1, 5, "#<nope> is not set"),
        // Division by zero.
        ("G0 X[1 / [2 - 2]]\n", 1, 6, "division by zero"),
        // A 1e9 repeat count.
        ("o1 repeat [1e9]\n", 1, 13, "expected an operator"),
        (
            "o1 repeat [1000000000]\nG0 X1\no1 endrepeat\n",
            1,
            11,
            "over the limit",
        ),
        // Control lines out of place.
        ("o1 endsub\n", 1, 1, "outside a subroutine"),
        ("o1 return\n", 1, 1, "outside a subroutine"),
        ("o1 break\n", 1, 1, "outside a loop"),
        ("o1 while [0]\nG0 X1\n", 1, 1, "no endwhile"),
        ("o1 if [0]\nG0 X1\n", 1, 1, "no endif"),
        ("o1 sub\nG0 X1\n", 1, 1, "no endsub"),
    ] {
        let (l, c, m) = first_error(text, Some(1000));
        assert_eq!((l, c), (line, col), "{text}: {m}");
        assert!(m.contains(what), "{text}: {m}");
    }
}

#[test]
fn other_flavours_leave_macros_verbatim() {
    let text = "G21 G0 X0\n#1 = 5\nG0 X#1\no1 if [1]\nG0 X2\no1 endif\n";
    let r = ProgramReader::new(Cursor::new(text.as_bytes()), Order::Execution);
    let opts = Flavor::Fadal.options(Options::default(), None);
    let moves = Stream::new(r, opts, true)
        .filter(|e| matches!(e, Ok(Event::Move(_))))
        .count();
    // X0 and X2: the macro lines are warned about, not evaluated.
    assert_eq!(moves, 2);
}

#[test]
fn system_parameters_after_moves_and_probes() {
    // As LinuxCNC's standalone rs274: #5420… the position (a probe backed off), #5061… a probe's end and
    // #5070 0 (no probe trips), so a `while [#5070 NE 0]` retry loop ends.
    let text = "G20 F10\nG0 X1 Y1 Z1\nG38.3 Z-1\nG0 X#5070 Y#5063 Z#5061\n\
        #5070 = 1\no4 while [#5070 NE 0]\nG38.3 Z-2\no4 endwhile\nG0 X#5420 Y#5421\n";
    let (m, d) = run(text);
    // Only the probe moves' own warning (the trace goes to their programmed end).
    assert!(
        d.iter()
            .all(|x| !x.is_error() && x.to_string().contains("G38.3")),
        "{d:?}"
    );
    assert_eq!(d.len(), 2);
    assert_eq!(m[2], [0.0, -1.0, 1.0]);
    assert_eq!(m.len(), 5);
    // #5420… the tool's position: the probe backed off 0.01 in from its end (the
    // trace models rs274's simulator, `interp::probe_rest`).
    assert_eq!(m[4], [0.0, -1.0, -1.99]);
}

/// `#<_x>` … `#<_w>` are the position (LinuxCNC's names of `#5420`…); inside a lathe
/// profile cycle's sub they are the profile's current point, which moves nothing (as in
/// LinuxCNC's `lathe_g7x_face_boring.ngc`): each step of the profile below is 1 up in X
/// and 2 along -Z from the last, so G70 follows X 3, 4, 5 at Z 0, -2, -4.
#[test]
fn position_names_and_a_profile_that_reads_them() {
    let (m, d) = run("G21 G18 F100\nG0 X3 Y2 Z4\nG0 X[#<_x> + #<_Y>] Z#<_z>\nM2\n");
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(m[1], [5.0, 2.0, 4.0]);
    let text = "G21 G18 F100\n\
        o100 sub\nG0 X3 Z0\no101 repeat [2]\nG1 X[#<_x> + 1] Z[#<_z> - 2]\no101 endrepeat\no100 endsub\n\
        G70 Q100 X8 Z2\nG1 X[#<_x>] Z[#<_z> + 1]\nM2\n";
    let (m, d) = run(text);
    assert!(
        d.iter()
            .all(|x| !x.is_error() && x.to_string().contains("lathe cycle")),
        "{d:?}"
    );
    let xz: Vec<[f64; 2]> = m.iter().map(|p| [p[0], p[2]]).collect();
    // The rapid to the start (twice: the block's, the pass's), to the profile's first
    // point, the profile, then the next block from where the cycle left the tool.
    assert_eq!(
        xz,
        [
            [8.0, 2.0],
            [8.0, 2.0],
            [3.0, 0.0],
            [4.0, -2.0],
            [5.0, -4.0],
            [5.0, -3.0]
        ]
    );
}

#[test]
fn an_unevaluated_feed_blames_no_later_block() {
    // FADAL flavour: `F#1` is not evaluated; the block is skipped with one warning and
    // the later G1 lines are not "feed move with no feed rate".
    for text in [
        "G21 G0 X0\nG1 X10 F#1\nG1 X20\nG1 X30\n",
        "G21 G0 X0\nG1 X10 F+R4.\nG1 X20\nG1 X30\n",
    ] {
        let r = ProgramReader::new(Cursor::new(text.as_bytes()), Order::Execution);
        let opts = Flavor::Fadal.options(Options::default(), None);
        let events: Vec<Event> = Stream::new(r, opts, false)
            .map(|e| e.expect("reads"))
            .collect();
        let diags: Vec<&Diagnostic> = events
            .iter()
            .filter_map(|e| match e {
                Event::Diagnostic(d) => Some(d),
                Event::Move(_) | Event::Stop(_) => None,
            })
            .collect();
        assert_eq!(diags.len(), 1, "{text}: {diags:?}");
        assert!(!diags[0].is_error() && diags[0].line == 2, "{diags:?}");
        let moves = events
            .iter()
            .filter(|e| matches!(e, Event::Move(_)))
            .count();
        assert_eq!(moves, 3, "{text}");
    }
    assert!(!lampost_gcode::sets_feed("#F = 2"));
    assert!(!lampost_gcode::sets_feed("G1 X#1 (F#2)"));
    assert!(lampost_gcode::sets_feed("G1 X1 f [#2 * 2]"));
}

/// Moves and diagnostics of a Haas program read in `order`.
fn haas(text: &str, order: Order) -> (Vec<[f64; 3]>, Vec<Diagnostic>) {
    let r = ProgramReader::new(Cursor::new(text.as_bytes()), order);
    let opts = Flavor::Haas.options(Options::default(), None);
    let mut moves = Vec::new();
    let mut diags = Vec::new();
    for e in Stream::new(r, opts, order == Order::Execution) {
        match e.expect("reads") {
            Event::Move(m) => moves.push([m.end[0], m.end[1], m.end[2]]),
            Event::Diagnostic(d) => diags.push(d),
            Event::Stop(_) => {}
        }
    }
    (moves, diags)
}

#[test]
fn haas_m97_calls_a_local_subprogram_by_its_n_label() {
    let text = "O1000\nG20 G90 G0 X0 Y0\nM97 P100 L2\nG0 X5.\nM97 P200\nM30\n\
        N100 G91 G0 Y1.\nG90\nM99\nN200 G0 Z-1.\nM97 P100\nM99\n";
    let (m, d) = haas(text, Order::Execution);
    // Only the bodies after M30, read on after the main program, are warned about.
    assert_eq!(d.len(), 1, "{d:?}");
    assert!(!d[0].is_error() && d[0].line == 7, "{d:?}");
    assert_eq!(
        m,
        [
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 2.0, 0.0],
            [5.0, 2.0, 0.0],
            [5.0, 2.0, -1.0],
            [5.0, 3.0, -1.0],
        ]
    );
    // Without an `O` line, each of the L runs returns at its M99 and the main program
    // goes on after the call (not ended at the second M99).
    let (m, d) = haas(
        "G20 G90 G0 X0 Y0\nM97 P100 L2\nG0 X5\nM30\nN100 G91 G0 Y1\nG90\nM99\n",
        Order::Execution,
    );
    assert_eq!(m.last(), Some(&[5.0, 2.0, 0.0]), "{d:?}");
    assert!(d.iter().all(|d| d.line == 5), "{d:?}");
    // A missing label, and recursion, are located errors; check reads in file order.
    for (text, line, col, what) in [
        (
            "G20 G0 X0\nM97 P300\nM30\nN100 X1\nM99\n",
            2,
            5,
            "no block N300",
        ),
        (
            "G20 G0 X0\nM97 P100\nM30\nN100 M97 P100\nM99\n",
            4,
            10,
            "N100 → N100",
        ),
    ] {
        let (_, d) = haas(text, Order::Execution);
        let e = d.iter().find(|d| d.is_error()).expect("an error");
        assert_eq!((e.line, e.column), (line, col), "{text}: {e:?}");
        assert!(e.kind.to_string().contains(what), "{text}: {}", e.kind);
    }
    let (_, d) = haas("G20 G0 X0\nM97 P300\nM30\n", Order::File);
    assert_eq!(d.iter().filter(|d| d.is_error()).count(), 1, "{d:?}");
    // Without a reader that follows calls, M97 is warned about, not ignored.
    let opts = Flavor::Haas.options(Options::default(), None);
    let d: Vec<Event> = Stream::from_bytes(b"G20 G0 X0\nM97 P100\nM30\n", opts, false)
        .map(|e| e.expect("reads"))
        .collect();
    assert!(
        d.iter()
            .any(|e| matches!(e, Event::Diagnostic(d) if d.line == 2)),
        "{d:?}"
    );
}

#[test]
fn a_stray_l_word_is_refused_as_rs274_refuses_it() {
    use lampost_gcode::{check, ErrorKind, Flavor, Options};
    let opts = Flavor::LinuxCnc.options(Options::default(), None);
    let d = check(b"G21\nG1 X1 F100\ng1 l20\n", opts);
    assert_eq!(d.len(), 1, "{d:?}");
    assert!(matches!(d[0].kind, ErrorKind::StrayWord { .. }), "{d:?}");
    assert_eq!((d[0].line, d[0].column), (3, 4));
    // L where LinuxCNC reads it: G10, a canned cycle's repeat count, G76.
    let d = check(
        b"G21\nG10 L2 P1 X0\nG0 X0 Y0 Z5\nG91 G81 X1 Z-1 R1 L3 F100\nG80 G90\n",
        opts,
    );
    assert!(
        d.iter()
            .all(|x| !matches!(x.kind, ErrorKind::StrayWord { .. })),
        "{d:?}"
    );
    // FADAL's reading: a subroutine call, warned.
    let opts = Flavor::Fadal.options(Options::default(), None);
    let d = check(b"G1 X1 F100\nG1 L20\n", opts);
    assert!(
        matches!(d[0].kind, ErrorKind::SubprogramNotFollowed(_)),
        "{d:?}"
    );
}

/// A block whose words belong to a setting code (LinuxCNC's G8, Fanuc's G67) still sets
/// the modes of its other G-codes: the plane of `G18 G8` (LinuxCNC's `lathe_pawn.ngc`),
/// the absolute distances of `G90 G67`.
#[test]
fn a_setting_code_does_not_drop_the_other_codes_of_its_block() {
    use lampost_gcode::{check, Event, Flavor, Options, Stream};
    let opts = Flavor::LinuxCnc.options(Options::default(), None);
    let d = check(b"G21\nG18 G8\nG0 X1 Z0\nG3 X0 Z1 I-1 K0 F10\nM2\n", opts);
    assert!(d.is_empty(), "{d:?}");
    let opts = Flavor::Fanuc.options(Options::default(), None);
    let ends: Vec<f64> = Stream::from_bytes(b"G21 G91\nG90 G67\nG0 X1\nG0 X2\n", opts, false)
        .filter_map(|e| match e.expect("in memory") {
            Event::Move(m) => Some(m.end[0]),
            _ => None,
        })
        .collect();
    assert_eq!(ends, [1.0, 2.0]);
    // A move in a setting code's block is a move (Haas `G103 P1 G1 X1 F100` was dropped
    // with its feed); the setting's own arguments stay its own (`G187 P1 E.002`).
    let opts = Flavor::Haas.options(Options::default(), None);
    let src = b"G21 G90\nG0 X0 Y0\nG103 P1 G1 X1. F100.\nG187 P1 E.002\nG1 X2. Y1. G187 P2\nM30\n";
    let mut ends = Vec::new();
    for e in Stream::from_bytes(src, opts, false) {
        match e.expect("in memory") {
            Event::Move(m) => ends.push([m.end[0], m.end[1], m.feed]),
            Event::Diagnostic(d) => panic!("{d:?}"),
            Event::Stop(_) => {}
        }
    }
    assert_eq!(
        ends,
        [[0.0, 0.0, 0.0], [1.0, 0.0, 100.0], [2.0, 1.0, 100.0]]
    );
}

/// LinuxCNC's lathe cycles G70–G72 (not units there), read in file order (`check`, where
/// their subs are not run), are warned about and draw no move (in execution order they
/// are expanded: `crates/cli/tests/g7x_cli.rs`);
/// G76 is expanded; E is G76's taper, and a stray E is refused, as rs274 refuses it.
#[test]
fn linuxcnc_lathe_cycles_and_e() {
    use lampost_gcode::{check, ErrorKind, Flavor, Options, Severity};
    let opts = Flavor::LinuxCnc.options(Options::default(), None);
    let d = check(
        b"G21 G18\nG0 X15 Z4\nG71 Q100 X15 Z4 D1 I1 R0.3\nG70 Q100 X15 Z4 D1 P1\nG1 X1 F100\nM2\n",
        opts,
    );
    assert_eq!(d.len(), 2, "{d:?}");
    assert!(d.iter().all(|x| x.severity == Severity::Warning
        && matches!(&x.kind, ErrorKind::NotSimulated(w) if w.contains("lathe"))));
    // G76 is expanded (`lathe.rs`); its spindle synchronisation is warned about, as
    // G33's is. Without the spindle turning rs274 refuses it, and so does lampost.
    let g76 = b"G0 X1 Z1\nG76 P0.05 Z-1 I-.075 J0.008 R1 K0.045 Q29.5 H2 L2 E0.045\nM2\n";
    let d = check(&[&b"G21 G18\nM3 S500\n"[..], g76].concat(), opts);
    assert!(
        d.len() == 1
            && matches!(&d[0].kind, ErrorKind::NotSimulated(w) if w.contains("spindle synchronisation of G76")),
        "{d:?}"
    );
    let d = check(&[&b"G21 G18\n"[..], g76].concat(), opts);
    assert!(
        d.len() == 1 && matches!(&d[0].kind, ErrorKind::ThreadingCycle(w) if w.contains("spindle")),
        "{d:?}"
    );
    let d = check(b"G21\nG0 X1 E0.5\n", opts);
    assert!(
        matches!(d[0].kind, ErrorKind::StrayWord { letter: 'E', .. }),
        "{d:?}"
    );
    // Elsewhere G70/G71 are still units (FADAL).
    let opts = Flavor::Fadal.options(Options::default(), None);
    assert!(check(b"G70\nG0 X1\nG71\nG0 X2\n", opts).is_empty());
}

/// A refused arc ends where it was programmed to: the next arc is judged from there
/// (gcode-preview's `mach3.gcode`: the second R arc was blamed for the first's fault).
#[test]
fn a_refused_arc_does_not_blame_the_next() {
    use lampost_gcode::{check, ErrorKind, Options};
    let d = check(
        b"G20 G90\nG0 X3.59 Y1.745\nG02 X4.1 Y2.255 R0.255 F10\nG02 X3.59 Y1.745 R0.255\n",
        Options::default(),
    );
    assert_eq!(d.len(), 2, "{d:?}");
    assert!(
        d.iter()
            .all(|x| matches!(x.kind, ErrorKind::ArcRadiusTooSmall { .. })),
        "{d:?}"
    );
}
