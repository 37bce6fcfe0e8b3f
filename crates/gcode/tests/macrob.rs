//! Fanuc Macro B (issue 12 item 4) for the `fanuc` and `haas` flavours: variables,
//! expressions, `IF`/`GOTO`/`WHILE`, `G65` calls, each followed through `ProgramReader` in
//! execution order; programs worked out by hand, and bad input as located errors.

use std::io::Cursor;

use lampost_gcode::{Diagnostic, Event, Flavor, Options, Order, ProgramReader, Stream};

fn run_as(flavor: Flavor, text: &str, max_blocks: Option<u64>) -> (Vec<[f64; 3]>, Vec<Diagnostic>) {
    let mut r = ProgramReader::new(Cursor::new(text.as_bytes()), Order::Execution);
    if let Some(n) = max_blocks {
        r.set_max_blocks(n);
    }
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

/// A program read as Fanuc's. These programs write whole numbers (`X1`) for brevity,
/// meaning units: the warning that a Fanuc reads them in increments
/// (`ErrorKind::IntegerWord`, tested in `crates/cli/tests/gcode_cli.rs`) is left out.
fn run(text: &str) -> (Vec<[f64; 3]>, Vec<Diagnostic>) {
    let (m, mut d) = run_as(Flavor::Fanuc, text, None);
    d.retain(|d| !matches!(d.kind, lampost_gcode::ErrorKind::IntegerWord { .. }));
    (m, d)
}

/// Moves of a program that must run clean.
fn clean(text: &str) -> Vec<[f64; 3]> {
    let (m, d) = run(text);
    assert!(d.is_empty(), "{text}\n{d:?}");
    m
}

fn xs(m: &[[f64; 3]]) -> Vec<f64> {
    m.iter().map(|p| p[0]).collect()
}

/// A bolt-hole circle: a G65 macro whose WHILE loop drills K holes on a circle of radius
/// R about (X, Y), the first at angle A, B apart. Six holes 60° apart on R10 about
/// (50, 20), worked out by hand: (60, 20), (55, 20 ± 5√3), (45, 20 ± 5√3), (40, 20).
pub const BOLT_HOLES: &str = "O1000 (BOLT HOLES)\n\
    G21 G90 G17\n\
    G0 X0 Y0 Z5.\n\
    G65 P9010 X50. Y20. R10. A0 B60. K6. Z-3. F100.\n\
    G0 Z50.\n\
    M30\n\
    O9010 (BOLT HOLE CIRCLE)\n\
    #30 = 0\n\
    WHILE [#30 LT #6] DO1\n\
    #31 = #1 + #30 * #2\n\
    #32 = #24 + #18 * COS[#31]\n\
    #33 = #25 + #18 * SIN[#31]\n\
    G0 X#32 Y#33\n\
    G1 Z#26 F#9\n\
    G0 Z5.\n\
    #30 = #30 + 1\n\
    END1\n\
    M99\n";

#[test]
fn a_bolt_hole_circle_gives_exactly_its_points() {
    for flavor in [Flavor::Fanuc, Flavor::Haas] {
        let (m, d) = run_as(flavor, BOLT_HOLES, None);
        assert!(d.is_empty(), "{d:?}");
        let h = 5.0 * 3f64.sqrt();
        let want = [
            (60.0, 20.0),
            (55.0, 20.0 + h),
            (45.0, 20.0 + h),
            (40.0, 20.0),
            (45.0, 20.0 - h),
            (55.0, 20.0 - h),
        ];
        // The start, then per hole: over it, down, up; then the last lift.
        assert_eq!(m.len(), 1 + 3 * want.len() + 1, "{m:?}");
        for (k, (x, y)) in want.iter().enumerate() {
            let over = m[1 + 3 * k];
            let down = m[2 + 3 * k];
            for p in [over, down] {
                assert!(
                    (p[0] - x).abs() <= 1e-12 && (p[1] - y).abs() <= 1e-12,
                    "hole {k}: {p:?}, want ({x}, {y})"
                );
            }
            assert_eq!((over[2], down[2]), (5.0, -3.0));
        }
        let last = m[m.len() - 1];
        assert!((last[0] - 55.0).abs() <= 1e-12 && (last[1] - (20.0 - h)).abs() <= 1e-12);
        assert_eq!(last[2], 50.0);
    }
}

#[test]
fn g65_arguments_are_the_locals_fanuc_names() {
    // Each argument's value is its local number; the macro moves to X = Y = n for every
    // local that is not vacant (GOTO inside the loop skips the vacant ones).
    let text = "G21 G90 G0 X0 Y0\n\
        G65 P1 A1 B2 C3 I4 J5 K6 D7 E8 F9 H11 M13 Q17 R18 S19 T20 U21 V22 W23 X24 Y25 Z26\n\
        M30\n\
        O1\n\
        #30 = 1\n\
        WHILE [#30 LE 29] DO1\n\
        IF [#[#30] EQ #0] GOTO 20\n\
        G0 X#30 Y#[#30]\n\
        N20 #30 = #30 + 1\n\
        END1\n\
        M99\n";
    let m = clean(text);
    let got: Vec<f64> = m[1..].iter().map(|p| p[0]).collect();
    let want = [
        1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 11.0, 13.0, 17.0, 18.0, 19.0, 20.0, 21.0,
        22.0, 23.0, 24.0, 25.0, 26.0,
    ];
    assert_eq!(got, want);
    assert!(m[1..].iter().all(|p| p[0] == p[1]), "{m:?}");
}

#[test]
fn locals_are_per_level_and_commons_are_shared() {
    let text = "G21 G90 G0 X0 Y0\n\
        #1 = 100\n\
        #100 = 1\n\
        G65 P2 A5\n\
        G0 X#1 Y#100\n\
        M30\n\
        O2\n\
        G0 X#1\n\
        #100 = 7\n\
        #1 = 9\n\
        M99\n";
    let m = clean(text);
    assert_eq!(m, [[0.0; 3], [5.0, 0.0, 0.0], [100.0, 7.0, 0.0]]);
    // M98 subprograms share the caller's locals (no new level).
    let text = "G21 G90 G0 X0 Y0\n#1 = 3\nM98 P5\nG0 X#1\nM30\nO5\n#1 = [#1 * 2]\nM99\n";
    assert_eq!(xs(&clean(text)), [0.0, 6.0]);
}

#[test]
fn goto_if_and_while_follow_fanuc() {
    // A backward GOTO loop, IF … THEN, nested WHILE loops numbered apart.
    let text = "G21 G90 G0 X0 Y0\n\
        #1 = 0\n\
        N10 G0 X#1\n\
        #1 = #1 + 1\n\
        IF [#1 LT 3] GOTO 10\n\
        IF [#1 EQ 3] THEN #2 = 40\n\
        IF [#1 EQ 4] THEN #2 = 50\n\
        G0 X#2\n\
        #3 = 0\n\
        WHILE [#3 LT 2] DO1\n\
        #4 = 0\n\
        WHILE [#4 LT 2] DO2\n\
        G0 X[100 + #3 * 10 + #4]\n\
        #4 = #4 + 1\n\
        END2\n\
        #3 = #3 + 1\n\
        END1\n\
        GOTO 99\n\
        G0 X999\n\
        N99 M30\n";
    assert_eq!(
        xs(&clean(text)),
        [0.0, 0.0, 1.0, 2.0, 40.0, 100.0, 101.0, 110.0, 111.0]
    );
    // A GOTO searches forward first, then from the top of its program.
    let text =
        "G21 G90 G0 X0\n#1 = 0\nN5 #1 = #1 + 1\nIF [#1 GT 2] GOTO 7\nGOTO 5\nN7 G0 X#1\nM30\n";
    assert_eq!(xs(&clean(text)), [0.0, 3.0]);
}

#[test]
fn fanuc_functions_and_operators() {
    let cases: &[(&str, f64)] = &[
        ("[1 + 2 * 3]", 7.0),
        ("[7 MOD 3]", 1.0),
        ("[ABS[-2.5]]", 2.5),
        ("[SQRT[16]]", 4.0),
        ("[ROUND[2.5]]", 3.0),
        ("[ROUND[-2.5]]", -3.0),
        ("[FIX[1.7]]", 1.0),
        ("[FIX[-1.2]]", -1.0),
        ("[FUP[1.2]]", 2.0),
        ("[FUP[-1.2]]", -2.0),
        ("[FUP[3]]", 3.0),
        ("[ATAN[1]/[1]]", 45.0),
        ("[ATAN[1]]", 45.0),
        ("[COS[60]]", 0.5000000000000001),
        ("[SIN[90]]", 1.0),
        ("[TAN[45]]", 0.9999999999999999),
        ("[BCD[59]]", 89.0),
        ("[BIN[89]]", 59.0),
        ("[12 AND 10]", 8.0),
        ("[12 OR 3]", 15.0),
        ("[12 XOR 10]", 6.0),
        // Fanuc's precedence: AND with the products, OR with the sums.
        ("[1 + 6 AND 3]", 3.0),
        ("[2 * 2 OR 1]", 5.0),
        ("[2 EQ 2]", 1.0),
        ("[2 NE 2.00001]", 1.0),
        ("[1 LT 2]", 1.0),
    ];
    for (e, want) in cases {
        let text = format!("G21 G90 G0 X0\n#100 = {e}\nG0 X#100\nM30\n");
        let m = clean(&text);
        assert_eq!(m[1][0], *want, "{e}");
    }
}

#[test]
fn two_argument_atan_is_fanucs_0_to_360() {
    // Each worked by hand: the angle of the point (b, a), 0 ≤ θ < 360.
    let cases: &[(&str, f64)] = &[
        ("[ATAN[1]/[1]]", 45.0),
        ("[ATAN[1,1]]", 45.0),
        ("[ATAN[1]/[-1]]", 135.0),
        ("[ATAN[-1]/[-1]]", 225.0),
        ("[ATAN[-1,-1]]", 225.0),
        ("[ATAN[-1]/[1]]", 315.0),
        ("[ATAN[-1, 1]]", 315.0),
        ("[ATAN[0]/[1]]", 0.0),
        ("[ATAN[-0]/[1]]", 0.0),
        ("[ATAN[0]/[-1]]", 180.0),
        ("[ATAN[-0]/[-1]]", 180.0),
        ("[ATAN[1]/[0]]", 90.0),
        ("[ATAN[-1]/[0]]", 270.0),
        ("[ATAN[-2]]", -63.43494882292201),
        // Expressions in either place: the point (-3, 3) at 135°, (3, -3) at 315°.
        ("[ATAN[3, 2 * -1.5]]", 135.0),
        ("[ATAN[[1 + 2] * -1]/[3]]", 315.0),
    ];
    for (e, want) in cases {
        let text = format!("G21 G90 G0 X0\n#100 = {e}\nG0 X#100\nM30\n");
        let m = clean(&text);
        assert_eq!(m[1][0], *want, "{e}");
        assert!(m[1][0].is_sign_positive() || *want < 0.0, "{e}: -0");
    }
    for (e, col, what) in [
        ("[ATAN[0]/[0]]", 7, "has no angle"),
        ("[ATAN[0,0]]", 7, "has no angle"),
        ("[ATAN[1,2,3]]", 15, "found `,`"),
        ("[ATAN[1]/2]", 7, "ATAN[a]/ takes [b]"),
    ] {
        let text = format!("G0 X0\n#1 = {e}\nM30\n");
        let (_, d) = run(&text);
        let e0 = d.iter().find(|d| d.is_error()).expect("an error");
        assert!(e0.kind.to_string().contains(what), "{e}: {}", e0.kind);
        assert_eq!((e0.line, e0.column), (2, col), "{e}: {}", e0.kind);
    }
}

#[test]
fn system_variables_read_the_traced_state() {
    // Modal information after the block before, the end of the last block (work system)
    // and in the machine frame as traced (G92 shifts the work system by -10 in X here).
    let text = "G21 G90 G17 G94 G40 G49 G54 G98\n\
        G1 X10. Y20. Z-1. F250. S1200 T7\n\
        #100 = #4001\n#101 = #4002\n#102 = #4003\n#103 = #4005\n#104 = #4006\n\
        #105 = #4007\n#106 = #4008\n#107 = #4009\n#108 = #4010\n#109 = #4014\n\
        #110 = #4109\n#111 = #4119\n#112 = #4120\n\
        #113 = #5001\n#114 = #5002\n#115 = #5003\n\
        G92 X0\n\
        #116 = #5001\n#117 = #5021\n\
        G91 G18 G3 X1. Z1. R1.\n\
        #118 = #4001 * 1000 + #4002 * 10 + [#4003 - 90]\n\
        G90 G0 X#100 Y#101 Z#102\nG0 X#103 Y#104 Z#105\nG0 X#106 Y#107 Z#108\n\
        G0 X#109 Y#110 Z#111\nG0 X#112 Y#113 Z#114\nG0 X#115 Y#116 Z#117\nG0 X#118\n\
        M30\n";
    let m = clean(text);
    let n = m.len();
    assert_eq!(
        &m[n - 7..],
        &[
            [1.0, 17.0, 90.0],
            [94.0, 21.0, 40.0],
            [49.0, 80.0, 98.0],
            [54.0, 250.0, 1200.0],
            [7.0, 10.0, 20.0],
            [-1.0, 0.0, 10.0],
            [3181.0, 0.0, 10.0],
        ]
    );
    // Read by a loop's condition, evaluated again at each END.
    let text = "G21 G90 G0 X0\nWHILE [#5001 LT 3] DO1\nG91 G0 X1\nEND1\nG90 M30\n";
    assert_eq!(xs(&clean(text)), [0.0, 1.0, 2.0, 3.0]);
    // #5001 after an incremental move.
    let text = "G21 G90 G0 X5 Y0\nG91 G1 X1 F100\nG90\n#1 = #5001\nG0 Y#1\nM30\n";
    assert_eq!(clean(text).last(), Some(&[6.0, 6.0, 0.0]));
}

#[test]
fn alarms_stop_and_unknown_state_are_located() {
    // #3000: the control's alarm 3000 + n with the comment as its message.
    let text = "G21 G0 X0\n#1 = 2\nIF [#1 NE 1] GOTO 10\nM30\nN10 #3000 = 12 (PART NOT CLAMPED)\nG0 X5\nM30\n";
    let (m, d) = run(text);
    assert_eq!(m.len(), 1, "nothing after the alarm");
    let e = d.iter().find(|d| d.is_error()).expect("the alarm");
    assert_eq!((e.line, e.column), (5, 5));
    let msg = e.kind.to_string();
    assert!(
        msg.contains("alarm 3012") && msg.contains("`PART NOT CLAMPED`"),
        "{msg}"
    );
    // #3006: a stop with a message is a warning; the trace goes on.
    let text = "G21 G0 X0\n#3006 = 1 (TURN PART OVER)\nG0 X5\nM30\n";
    let (m, d) = run(text);
    assert_eq!(m.len(), 2);
    assert_eq!(d.len(), 1, "{d:?}");
    assert!(!d[0].is_error());
    assert_eq!((d[0].line, d[0].column), (2, 1));
    assert!(
        d[0].kind.to_string().contains("`TURN PART OVER`"),
        "{}",
        d[0].kind
    );
    // State the trace does not know, writes to read-only variables, reading #3000.
    for (text, line, col, what) in [
        ("G0 X0\n#1 = #4006\nM30\n", 2, 6, "power-on units"),
        (
            "G21 G0 X0\nG81 X1 Z-1 R1 F10\n#1 = #4001\nM30\n",
            3,
            6,
            "canned cycle",
        ),
        (
            "G21 G0 X0\nG43 H2 Z5\n#1 = #4008\nM30\n",
            3,
            6,
            "G43 from G44",
        ),
        ("G21 G0 X0\n#1 = #4111\nM30\n", 2, 6, "last H"),
        ("G21 G0 X0\n#1 = #4113\nM30\n", 2, 6, "not traced"),
        ("G21 G0 X0\n#5001 = 3\nM30\n", 2, 1, "read only"),
        ("G21 G0 X0\n#4001 = 1\nM30\n", 2, 1, "read only"),
        ("G21 G0 X0\n#1 = #3000\nM30\n", 2, 6, "not read"),
        ("G21 G0 X0\n#3000 = 1.5\nM30\n", 2, 1, "whole number"),
        ("G21 G0 X0\n#1 = #5007\nM30\n", 2, 7, "not evaluated"),
    ] {
        let (_, d) = run(text);
        let e = d
            .iter()
            .find(|d| d.is_error())
            .unwrap_or_else(|| panic!("{text}: {d:?}"));
        assert!(e.kind.to_string().contains(what), "{text}: {}", e.kind);
        assert_eq!((e.line, e.column), (line, col), "{text}: {}", e.kind);
    }
}

#[test]
fn vacant_variables_follow_fanuc_rules() {
    // A word whose value is a vacant variable is left out; in arithmetic vacant is 0;
    // EQ and NE tell vacant from 0; an assignment copies vacancy.
    let text = "G21 G90 G0 X1 Y1 Z1\n\
        G0 X#5 Y2\n\
        G0 X[#5 + 3]\n\
        #2 = #5\n\
        IF [#2 EQ #0] GOTO 10\n\
        G0 X999\n\
        N10 IF [#2 EQ 0] GOTO 20\n\
        G0 Y#2 Z9\n\
        IF [#2 NE 0] THEN #3 = 4\n\
        G0 X#3\n\
        #2 = 0\n\
        IF [#2 EQ #0] GOTO 20\n\
        G0 X8\n\
        N20 M30\n";
    let m = clean(text);
    assert_eq!(
        m,
        [
            [1.0, 1.0, 1.0],
            [1.0, 2.0, 1.0],
            [3.0, 2.0, 1.0],
            [3.0, 2.0, 9.0],
            [4.0, 2.0, 9.0],
            [8.0, 2.0, 9.0],
        ]
    );
}

#[test]
fn bad_macro_b_is_located() {
    type Case = (&'static str, u32, u32, &'static str);
    let cases: &[Case] = &[
        ("G0 X0\nGOTO 50\nM30\n", 2, 6, "no block N50"),
        (
            "G0 X0\nIF [1 EQ 1] GOTO 7\nM30\nO2\nN7 M99\n",
            2,
            18,
            "no block N7",
        ),
        (
            "G0 X0\n#1 = 0\nWHILE [#1 LT 3] DO1\n#1 = #1 + 1\nM30\n",
            3,
            1,
            "DO1 has no END1",
        ),
        ("G0 X0\nEND1\nM30\n", 2, 1, "END1 without DO1"),
        (
            "G0 X0\nWHILE [1 EQ 1] DO1\nWHILE [1 EQ 1] DO1\nEND1\nEND1\nM30\n",
            2,
            1,
            "nested loops need different numbers",
        ),
        ("G0 X0\nDO4\nEND4\nM30\n", 2, 3, "DO and END take 1, 2 or 3"),
        (
            "G0 X0\nWHILE [1 EQ 1] GOTO 3\nM30\n",
            2,
            16,
            "followed by DOm",
        ),
        (
            "G0 X0\nIF [1 EQ 1] X2\nM30\n",
            2,
            13,
            "followed by GOTO n or THEN",
        ),
        (
            "G0 X0\nIF [1 EQ 1] THEN G0 X2\nM30\n",
            2,
            18,
            "THEN takes an assignment",
        ),
        (
            "G0 X0\n#1 = #1000\nM30\n",
            2,
            7,
            "system variables are not evaluated",
        ),
        (
            "G0 X0\n#1 = #<a>\nM30\n",
            2,
            7,
            "Macro B variables are numbered",
        ),
        ("G0 X0\n#1 = 1.5 AND 1\nM30\n", 2, 6, "whole numbers"),
        ("G0 X0\n#1 = 1 / 0\nM30\n", 2, 6, "division by zero"),
        ("G0 X0\nG65 P77 A1\nM30\n", 2, 1, "no program O77"),
        (
            "G0 X0\nG65 A1\nM30\n",
            2,
            1,
            "needs the macro's program number",
        ),
        (
            "G0 X0\nG65 P1 G1\nM30\nO1\nM99\n",
            2,
            8,
            "G1 beside G65: lampost reads a G65 block as the macro call",
        ),
        (
            "G0 X0\nG65 P1 N5 O3\nM30\nO1\nM99\n",
            2,
            11,
            "not an argument",
        ),
        ("G0 X0\n#1 = 3\nM98 P#1\nM30\n", 3, 1, "no program O3"),
        ("G0 X0\nM99\n", 2, 1, "M99 in the main program"),
    ];
    for (text, line, col, what) in cases {
        let (_, d) = run(text);
        let Some(e) = d.iter().find(|d| d.is_error() || d.line == *line) else {
            panic!("{text}: no diagnostic: {d:?}");
        };
        assert!(
            e.kind.to_string().contains(what),
            "{text}: `{what}` not in {}",
            e.kind
        );
        assert_eq!((e.line, e.column), (*line, *col), "{text}: {}", e.kind);
    }
}

#[test]
fn loops_and_calls_are_bounded() {
    // A loop without end stops at the block limit, with its line.
    let (m, d) = run_as(
        Flavor::Fanuc,
        "G0 X0\nWHILE [1 EQ 1] DO1\nG0 X1\nEND1\nM30\n",
        Some(10_000),
    );
    let e = d.iter().find(|d| d.is_error()).expect("an error");
    assert!(
        e.kind.to_string().contains("more than 10000 blocks"),
        "{e:?}"
    );
    assert_eq!(e.line, 4);
    assert!(m.len() < 10_000);
    let (_, d) = run_as(
        Flavor::Fanuc,
        "G0 X0\nN1 G0 X1\nGOTO 1\nM30\n",
        Some(10_000),
    );
    let e = d.iter().find(|d| d.is_error()).expect("an error");
    assert_eq!((e.line, e.kind.to_string().contains("blocks")), (3, true));
    // G65 nests four deep (Fanuc's limit): recursion stops at the fifth level.
    let text = "G21 G90 G0 X0\nG65 P1 A1\nM30\nO1\nG0 X#1\nIF [#1 GE 5] GOTO 9\nG65 P1 A[#1 + 1]\nN9 M99\n";
    let (m, d) = run(text);
    let e = d.iter().find(|d| d.is_error()).expect("an error");
    assert!(e.kind.to_string().contains("more than 4 deep"), "{e:?}");
    assert_eq!((e.line, xs(&m)), (7, vec![0.0, 1.0, 2.0, 3.0, 4.0]));
    // Four levels run.
    let (m, d) = run(&text.replace("GE 5", "GE 4"));
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(xs(&m), [0.0, 1.0, 2.0, 3.0, 4.0]);
}

#[test]
fn plain_flavours_leave_macro_b_alone() {
    // FADAL (and Mach3) do not evaluate Macro B: statement lines are refused or warned,
    // never run.
    let (m, d) = run_as(Flavor::Fadal, "G21 G0 X0\nG65 P9 A1\nM30\n", None);
    assert_eq!(m.len(), 1);
    assert!(d.iter().any(|d| d.line == 2 && !d.is_error()), "{d:?}");
}

/// A loop whose condition (or body) cannot be evaluated, read by a stream that does not
/// stop at errors (`check`): after an error no jump back is taken, so each line is read
/// once more at most (not a million runs of the loop, each with its errors). LinuxCNC's
/// O-word loops alike.
#[test]
fn a_failed_loop_condition_is_not_run_again() {
    for (flavor, text) in [
        (
            Flavor::Fanuc,
            "G21 G0 X0\nWHILE [#2000 LT 1] DO1\nG0 X#3000\nEND1\nG0 X5\nM30\n",
        ),
        (
            Flavor::LinuxCnc,
            "G21 G0 X0\no1 while [#<nope> LT 1]\nG0 X#<nada>\no1 endwhile\nG0 X5\nM30\n",
        ),
        // The condition holds, the body fails before its counter grows.
        (
            Flavor::Haas,
            "G21 G0 X0\n#1 = 0\nWHILE [#1 LT 3] DO1\n#1 = #1 + R2\nEND1\nG0 X5\nM30\n",
        ),
    ] {
        let r = ProgramReader::new(Cursor::new(text.as_bytes()), Order::Execution);
        let opts = flavor.options(Options::default(), None);
        let events: Vec<Event> = Stream::new(r, opts, false)
            .map(|e| e.expect("reads"))
            .collect();
        let errors: Vec<u32> = events
            .iter()
            .filter_map(|e| match e {
                Event::Diagnostic(d) if d.is_error() => Some(d.line),
                _ => None,
            })
            .collect();
        let want: &[u32] = if flavor == Flavor::Haas {
            &[4]
        } else {
            &[2, 3]
        };
        assert_eq!(errors, want, "{flavor:?}: {events:?}");
        let last = events.iter().rev().find_map(|e| match e {
            Event::Move(m) => Some(m.end[0]),
            Event::Diagnostic(_) | Event::Stop(_) => None,
        });
        assert_eq!(last, Some(5.0), "{flavor:?}");
    }
}
