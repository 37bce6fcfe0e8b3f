//! parse(emit(p)) == p, and fmt keeps the trace, on generated programs and the corpus.

use lampost_gcode::{
    parse_line, Dialect, EmitOptions, Emitter, Event, Lines, Move, Options, Order, ProgramReader,
    Stream, Units,
};
use proptest::prelude::*;

fn blocks_equal(a: &[u8], b: &[u8]) -> Result<(), String> {
    let pa: Vec<_> = Lines::new(a)
        .map(|l| parse_line(l.bytes, l.number, l.offset))
        .collect();
    let pb: Vec<_> = Lines::new(b)
        .map(|l| parse_line(l.bytes, l.number, l.offset))
        .collect();
    if pa.len() != pb.len() {
        return Err(format!("{} blocks vs {}", pa.len(), pb.len()));
    }
    for (x, y) in pa.iter().zip(&pb) {
        match (x, y) {
            (Ok(x), Ok(y)) if x.same_content(y) => {}
            _ => return Err(format!("differ: {x:?}\n vs {y:?}")),
        }
    }
    Ok(())
}

fn emit(text: &[u8], opts: EmitOptions) -> Vec<u8> {
    try_emit(text, opts).expect("writes")
}

fn try_emit(text: &[u8], opts: EmitOptions) -> std::io::Result<Vec<u8>> {
    let mut em = Emitter::new(Vec::new(), opts);
    for l in Lines::new(text) {
        let b = parse_line(l.bytes, l.number, l.offset).expect("parses");
        em.block(&b)?;
    }
    em.finish()
}

/// Whether a word of `text` is outside what `opts`' dialect writes.
fn out_of_range(text: &[u8], opts: EmitOptions) -> bool {
    let Some(d) = opts.dialect else { return false };
    Lines::new(text).any(|l| {
        parse_line(l.bytes, 1, 0).is_ok_and(|b| {
            b.words().any(|w| {
                lampost_gcode::out_of_range(d, opts.units, w.letter, w.register, w.value).is_some()
            })
        })
    })
}

/// The moves of `text` read as `flavor` (`features.ngc` is LinuxCNC's: a FADAL refuses
/// its G91 cycle).
fn moves(text: &[u8], flavor: lampost_gcode::Flavor) -> Vec<Move> {
    let opts = Options {
        flavor,
        ..Options::default()
    };
    Stream::from_bytes(text, opts, true)
        .filter_map(|e| match e.expect("in memory") {
            Event::Move(m) => Some(m),
            Event::Diagnostic(d) => {
                assert!(!d.is_error(), "{d}");
                None
            }
            Event::Stop(_) => None,
        })
        .collect()
}

/// A word as a CAM post or a FADAL programmer might write it, in the range both
/// dialects write (coordinates of at most four whole digits; feeds, speeds, tools and
/// offsets not negative and at most 99).
fn word() -> impl Strategy<Value = String> {
    let coord = prop_oneof![
        (-9999i64..9999).prop_map(|v| v.to_string()),
        (-9999i64..9999, 0u32..5).prop_map(|(v, d)| {
            let s = format!("{:.*}", d as usize, v as f64 / 10f64.powi(d as i32));
            s
        }),
        (0u32..10000).prop_map(|v| format!(".{v}")),
        (0u32..10000).prop_map(|v| format!("-.{v}")),
        (0i64..999).prop_map(|v| format!("{v}.")),
    ];
    let whole = prop_oneof![
        (0i64..99).prop_map(|v| v.to_string()),
        (0u32..10000).prop_map(|v| format!(".{v}")),
        (0i64..99).prop_map(|v| format!("{v}.")),
    ];
    let coords = (prop::sample::select(b"XYZABCIJKQ".to_vec()), coord);
    let others = (prop::sample::select(b"FSTHDP".to_vec()), whole);
    (prop_oneof![coords, others], any::<bool>()).prop_map(|((l, n), lower)| {
        let c = char::from(l);
        format!("{}{}", if lower { c.to_ascii_lowercase() } else { c }, n)
    })
}

fn line() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => (prop::collection::vec(word(), 1..6), prop::sample::select(vec!["G0", "G1", "g01", "G90", "M3", "M8", ""]), any::<bool>(), any::<bool>())
            .prop_map(|(ws, g, comment, spaces)| {
                // One word per letter, as a valid block has.
                let mut seen = std::collections::HashSet::new();
                let ws: Vec<_> = ws.into_iter().filter(|w| seen.insert(w.as_bytes()[0].to_ascii_uppercase())).collect();
                let sep = if spaces { " " } else { "" };
                let mut s = String::new();
                if !g.is_empty() { s.push_str(g); s.push_str(sep); }
                s.push_str(&ws.join(sep));
                if comment { s.push_str(" (a comment)"); }
                s
            }),
        1 => Just("%".to_string()),
        1 => Just("#V10 = 1 'macro".to_string()),
        1 => Just("G1 G31 X+R6. Y+R7. F+R4. P1".to_string()),
        1 => Just("L9101 R1+1. R2-.4".to_string()),
        1 => Just("; semicolon comment".to_string()),
        1 => Just("/N20 G0 X1".to_string()),
        1 => Just(String::new()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Verbatim emission gives back the same blocks, exactly.
    #[test]
    fn verbatim_round_trip(lines in prop::collection::vec(line(), 1..30)) {
        let text = lines.join("\n");
        let out = emit(text.as_bytes(), EmitOptions::default());
        prop_assert!(blocks_equal(text.as_bytes(), &out).is_ok(), "{:?}", blocks_equal(text.as_bytes(), &out));
    }

    /// In a dialect, emission is a fixed point after one pass, and values move by at
    /// most half the dialect's resolution.
    #[test]
    fn dialect_round_trip(lines in prop::collection::vec(line(), 1..30), fadal in any::<bool>(), inch in any::<bool>()) {
        let text = lines.join("\n");
        let opts = EmitOptions {
            dialect: Some(if fadal { Dialect::Fadal } else { Dialect::Iso }),
            units: if inch { Units::Inch } else { Units::Mm },
            ..EmitOptions::default()
        };
        // A value the dialect cannot hold is refused, located, never written cut off.
        if out_of_range(text.as_bytes(), opts) {
            let e = try_emit(text.as_bytes(), opts).expect_err("refused");
            let d = e.get_ref().and_then(|i| i.downcast_ref::<lampost_gcode::Diagnostic>());
            prop_assert!(matches!(d.map(|d| &d.kind), Some(lampost_gcode::ErrorKind::OutOfRange { .. })), "{e}");
            return Ok(());
        }
        let once = emit(text.as_bytes(), opts);
        let twice = emit(&once, opts);
        prop_assert_eq!(String::from_utf8_lossy(&once), String::from_utf8_lossy(&twice));
        let a: Vec<_> = Lines::new(text.as_bytes()).filter_map(|l| parse_line(l.bytes, 1, 0).ok()).flat_map(|b| b.words().map(|w| (w.letter, w.value)).collect::<Vec<_>>()).collect();
        let b: Vec<_> = Lines::new(&once).filter_map(|l| parse_line(l.bytes, 1, 0).ok()).flat_map(|b| b.words().map(|w| (w.letter, w.value)).collect::<Vec<_>>()).collect();
        prop_assert_eq!(a.len(), b.len());
        for ((la, va), (lb, vb)) in a.iter().zip(&b) {
            prop_assert_eq!(la, lb);
            prop_assert!((va - vb).abs() <= 0.5e-3 + 1e-9, "{} {} -> {}", char::from(*la), va, vb);
        }
    }

    /// A value past the dialect's range is refused with its place, in either dialect
    /// and either unit, never written cut off or saturated.
    #[test]
    fn out_of_range_values_are_refused(
        letter in prop::sample::select(b"XYZABCIJKQRFSTHDPNOLGME".to_vec()),
        value in prop_oneof![100_000i64..1_000_000_000_000, 100_000i64..1_000_000_000, -1_000_000_000_000i64..-1],
        fadal in any::<bool>(),
        inch in any::<bool>(),
    ) {
        let opts = EmitOptions {
            dialect: Some(if fadal { Dialect::Fadal } else { Dialect::Iso }),
            units: if inch { Units::Inch } else { Units::Mm },
            ..EmitOptions::default()
        };
        let text = format!("G0 X1\n{}{value}\n", char::from(letter));
        let expect = out_of_range(text.as_bytes(), opts);
        match try_emit(text.as_bytes(), opts) {
            Ok(out) => {
                prop_assert!(!expect);
                // What is written is the value, not a cut-off one.
                let mut lines = out.split(|&c| c == b'\n').filter(|l| !l.is_empty() && *l != b"%");
                let b = parse_line(lines.nth(1).unwrap_or_default(), 1, 0).expect("parses");
                prop_assert_eq!(b.word(letter).map(|w| w.value), Some(value as f64));
            }
            Err(e) => {
                prop_assert!(expect);
                let d = e.get_ref().and_then(|i| i.downcast_ref::<lampost_gcode::Diagnostic>()).expect("located");
                prop_assert_eq!((d.line, d.column), (2, 1));
            }
        }
        // Values of twelve digits and more, and negatives of the unsigned words, are
        // always out.
        if value >= 100_000_000_000 || (value < 0 && b"FSTHDPNOLGM".contains(&letter)) {
            prop_assert!(expect);
        }
    }

    /// No input makes the parser or the interpreter panic or loop.
    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let n = Stream::from_bytes(&bytes, Options::default(), false).count();
        prop_assert!(n <= bytes.len() * 8 + 2);
    }

    /// Nor does any sequence of plausible tokens.
    #[test]
    fn token_soup_never_panics(tokens in prop::collection::vec(prop::sample::select(vec![
        "G0", "G1", "G2", "G3", "G81", "G83", "G73", "G80", "G91", "G90", "G20", "G21", "G18", "G19",
        "G17", "G28", "G92", "G10", "L2", "L20", "P1", "P0", "Q1", "Q-1", "R1", "R-1", "R0+1.", "Z-1",
        "X1", "Y1", "I1", "J1", "K1", "F100", "F0", "E1", "E99", "H1", "G43", "M6", "T1", "M30", "G93",
        "(c)", "(", ")", ";", "#", "[", "%", "\n", " ", "-", ".", "1e5", "G4", "G53", "G31", "A90", "B-45",
    ]), 0..80)) {
        let text = tokens.concat();
        let _ = Stream::from_bytes(text.as_bytes(), Options::default(), false).count();
    }

    /// Programs, calls and returns in any order: read in both orders, nothing panics or
    /// runs away (every call is followed under the nesting and repeat caps).
    #[test]
    fn call_soup_never_panics(tokens in prop::collection::vec(prop::sample::select(vec![
        "O1", "O2", "O3", "O1.5", "O-1", "M98", "M99", "M30", "P1", "P2", "P3", "P4", "P-1", "L2",
        "L3", "L10001", "L0", "L1.5", "G0", "X1", "G91", "N5", "%", "(c)", "\n", "\n", " ",
    ]), 0..80)) {
        let text = tokens.concat();
        for order in [Order::File, Order::Execution] {
            let r = ProgramReader::new(std::io::Cursor::new(text.as_bytes()), order);
            let _ = Stream::new(r, Options::default(), false).count();
        }
    }
}

fn corpus_files() -> Vec<std::path::PathBuf> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/corpus");
    let mut v = Vec::new();
    for sub in ["linuxcnc", "fadal-probekit"] {
        if let Ok(rd) = std::fs::read_dir(dir.join(sub)) {
            v.extend(rd.flatten().map(|e| e.path()));
        }
    }
    v.push(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../fixtures/programs/features.ngc"),
    );
    v.sort();
    v
}

#[test]
fn corpus_parses_and_fmt_keeps_the_trace() {
    let files = corpus_files();
    if files.len() < 2 {
        eprintln!("SKIPPED: ../shared/corpus not present");
    }
    for path in files {
        let text = std::fs::read(&path).expect("read");
        for l in Lines::new(&text) {
            if let Err(d) = parse_line(l.bytes, l.number, l.offset) {
                panic!("{}: {d}", path.display());
            }
        }
        let flavor = if path.ends_with("features.ngc") {
            lampost_gcode::Flavor::LinuxCnc
        } else {
            Options::default().flavor
        };
        let before = moves(&text, flavor);
        for opts in [
            EmitOptions::default(),
            EmitOptions {
                renumber: Some((10, 10)),
                ..EmitOptions::default()
            },
            EmitOptions {
                dialect: Some(Dialect::Iso),
                ..EmitOptions::default()
            },
        ] {
            let out = emit(&text, opts);
            if opts.renumber.is_none() && opts.dialect.is_none() {
                blocks_equal(&text, &out).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            }
            let after = moves(&out, flavor);
            assert_eq!(before.len(), after.len(), "{}", path.display());
            for (a, b) in before.iter().zip(&after) {
                for i in 0..9 {
                    // 3 decimals in mm: the dialect rounds to 0.0005 at most.
                    assert!(
                        (a.end[i] - b.end[i]).abs() <= 5e-4 + 1e-9,
                        "{}: line {}",
                        path.display(),
                        a.line
                    );
                }
                if opts.dialect.is_none() {
                    assert_eq!(a.end, b.end, "{}: line {}", path.display(), a.line);
                    assert_eq!(a.kind, b.kind);
                }
            }
        }
    }
}
