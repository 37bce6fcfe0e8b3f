//! `lampost check`, `fmt` and `trace`.

use std::io::Write;

use lampost_gcode::fixed;
use lampost_gcode::DETECT_BYTES;
use lampost_gcode::{
    comment_not_utf8, parse_line_lenient, Block, Diagnostic, Dialect, EWord, EmitOptions, Emitter,
    ErrorKind, Event, Flavor, LineReader, Move, MoveKind, Options, Order, ProgramReader, Reading,
    Resolved, Severity, Stream, Units, AXES,
};

use crate::io::{display_name, open_seekable, Output};
use crate::json::{self, obj, Obj};
use crate::report::{self, CliError};
use crate::{DialectArg, EWordArg, FlavorArg, InterpArgs, UnitsArg};

/// At most this many diagnostics are printed for people.
const MAX_PRINTED: usize = 200;

/// At most this many diagnostics are written as JSON by `check --json` and `trace
/// --json` (each as it is found); the rest are counted (`not_shown`).
pub const MAX_JSON_DIAGNOSTICS: usize = 10_000;

fn units(u: UnitsArg) -> Units {
    match u {
        UnitsArg::Inch => Units::Inch,
        UnitsArg::Mm => Units::Mm,
    }
}

/// The interpreter's options for a program of flavour `flavor` (resolved).
pub fn options(a: InterpArgs, flavor: Flavor) -> Options {
    let e_word = a.e_word.map(|e| match e {
        EWordArg::Fixture => EWord::FixtureOffset,
        EWordArg::Extrusion => EWord::Extrusion,
    });
    flavor.options(
        Options {
            units: units(a.units),
            block_delete: a.block_delete,
            ..Options::default()
        },
        e_word,
    )
}

/// The flavour of the program `r` holds (its first bytes are looked at for `auto`;
/// `r` is left where it was).
pub fn resolve<R: std::io::Read + std::io::Seek + ?Sized>(
    given: FlavorArg,
    r: &mut R,
) -> std::io::Result<Resolved> {
    use std::io::{Read, SeekFrom};
    let given = given.flavor();
    if given != Flavor::Auto {
        return Ok(Resolved::new(given, b""));
    }
    let at = r.stream_position()?;
    let mut head = Vec::with_capacity(DETECT_BYTES);
    r.take(DETECT_BYTES as u64).read_to_end(&mut head)?;
    r.seek(SeekFrom::Start(at))?;
    Ok(Resolved::new(given, &head))
}

fn io_err(name: &str, e: std::io::Error) -> CliError {
    CliError::usage(format!("error: cannot read {name}: {e}"))
}

/// `file`'s lines in `order` (every program in turn, or the main program with its calls
/// followed; a flavour that evaluates macros is always read in execution order), and
/// its flavour.
fn program(
    file: &str,
    order: Order,
    flavor: FlavorArg,
) -> Result<(ProgramReader<Box<dyn crate::io::ReadSeek>>, Resolved), CliError> {
    let mut src = open_seekable(file)?;
    let resolved = resolve(flavor, &mut src).map_err(|e| io_err(&display_name(file), e))?;
    let order = if resolved.flavor.evaluates() {
        Order::Execution
    } else {
        order
    };
    Ok((ProgramReader::new(src, order), resolved))
}

/// `check`: every diagnostic for people on standard error (the first
/// [`MAX_PRINTED`]), or with `--json` one JSON document on standard output, streamed:
/// `{"file": …, "diagnostics": [` then each diagnostic as it is found, one a line (the
/// first [`MAX_JSON_DIAGNOSTICS`]), then `], "not_shown": …, "errors": …, "warnings": …,
/// "ok": …}`. Memory does not grow with the number of diagnostics.
pub fn check(file: &str, json: bool, interp: InterpArgs) -> Result<(), CliError> {
    let name = display_name(file);
    let (input, flavor) = program(file, Order::File, interp.flavor)?;
    let mut errors = 0usize;
    let mut warnings = 0usize;
    let mut shown = 0usize;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let werr = |e: std::io::Error| CliError::write(&e);
    if json {
        write!(
            out,
            "{{\"file\":{},\"diagnostics\":[",
            json::to_string(&name)?
        )
        .map_err(werr)?;
    }
    let stderr = std::io::stderr();
    for ev in Stream::new(input, options(interp, flavor.flavor), false) {
        let Event::Diagnostic(d) = ev.map_err(|e| io_err(&name, e))? else {
            continue;
        };
        match d.severity {
            Severity::Error => errors += 1,
            Severity::Warning => warnings += 1,
        }
        if json {
            if shown < MAX_JSON_DIAGNOSTICS {
                out.write_all(if shown == 0 { b"\n" } else { b",\n" })
                    .map_err(werr)?;
                json::to_writer(&mut out, &report::json(&name, &d))?;
                shown += 1;
            }
        } else if shown < MAX_PRINTED {
            shown += 1;
            let _ = writeln!(stderr.lock(), "{}", report::render(&name, &d));
        }
    }
    let not_shown = errors + warnings - shown;
    if json {
        writeln!(
            out,
            "{}],\"not_shown\":{not_shown},\"errors\":{errors},\"warnings\":{warnings},\"flavor\":{},\"ok\":{}}}",
            if shown > 0 { "\n" } else { "" },
            json::to_string(&flavor)?,
            errors == 0
        )
        .map_err(werr)?;
        out.flush().map_err(werr)?;
    } else {
        if not_shown > 0 {
            eprintln!(
                "… and {not_shown} more not shown (--json lists up to {MAX_JSON_DIAGNOSTICS})"
            );
        }
        eprintln!(
            "{name}: {errors} error(s), {warnings} warning(s); {}",
            flavor.describe()
        );
    }
    if errors > 0 {
        Err(CliError::failed(""))
    } else {
        Ok(())
    }
}

fn parse_renumber(s: &str) -> Result<(u64, u64), CliError> {
    let bad = || {
        CliError::usage(format!(
            "error: --renumber {s}: expected START,STEP with whole numbers, e.g. 10,10"
        ))
    };
    let (a, b) = s.split_once(',').ok_or_else(bad)?;
    let start = a.trim().parse::<u64>().map_err(|_| bad())?;
    let step = b.trim().parse::<u64>().map_err(|_| bad())?;
    if step == 0 {
        return Err(bad());
    }
    Ok((start, step))
}

pub fn fmt(
    file: &str,
    output: Option<&str>,
    dialect: Option<DialectArg>,
    renumber: Option<&str>,
    suppress_modal: bool,
    (start_units, flavor): (Option<UnitsArg>, FlavorArg),
) -> Result<(), CliError> {
    let name = display_name(file);
    let renumber = renumber.map(parse_renumber).transpose()?;
    let opts = EmitOptions {
        dialect: dialect.map(|d| match d {
            DialectArg::Fadal => Dialect::Fadal,
            DialectArg::Iso => Dialect::Iso,
        }),
        renumber,
        suppress_modal,
        units: units(start_units.unwrap_or(UnitsArg::Mm)),
        units_given: start_units.is_some(),
    };
    let mut src = open_seekable(file)?;
    let flavor = resolve(flavor, &mut src).map_err(|e| io_err(&name, e))?;
    // A slicer's numbers may have exponents; LinuxCNC reads its polar words `@` and `^`;
    // Fanuc and Haas their `:` program numbers.
    let reading = Reading::of(flavor.flavor, flavor.flavor.is_slicer());
    let mut reader = LineReader::new(std::io::BufReader::with_capacity(1 << 16, src));
    let mut out = Output::create(output)?;
    let werr = |e: std::io::Error| CliError::write(&e);
    let mut errors = 0usize;
    let mut warned_comment_utf8 = false;
    {
        let mut em = Emitter::new(out.writer(), opts);
        while let Some(line) = reader.next_line().map_err(|e| io_err(&name, e))? {
            let mut scratch = None;
            let mut b = Block::empty(line.number, line.offset);
            // A Fanuc or Haas Macro B statement (`IF [#1 LT 3] GOTO 2`, `WHILE […] DO1`,
            // `END1`) is copied as it stands, as macro lines are.
            let statement = flavor
                .flavor
                .macro_b()
                .then(|| lampost_gcode::macro_b_statement(line.bytes, line.number, line.offset))
                .flatten();
            let parsed = match (line.too_long(), statement) {
                (Some(d), _) => Err(d),
                (None, Some(st)) => {
                    b = st;
                    Ok(())
                }
                (None, None) => parse_line_lenient(
                    line.bytes,
                    line.number,
                    line.offset,
                    &mut b,
                    reading,
                    &mut scratch,
                )
                .map(|lenient| {
                    if lenient && !warned_comment_utf8 {
                        warned_comment_utf8 = true;
                        let d = comment_not_utf8(line.bytes, line.number, line.offset);
                        eprint!("{}", report::render(&name, &d));
                    }
                }),
            };
            // Renumbering moves the blocks' numbers, not the jumps to them: a jump by
            // block number (`GOTO N3`, `GOTO 5`, `M97 P30`, `M99 P30`) would be left
            // pointing at a number no block has.
            let jump = opts.renumber.is_some()
                && parsed.is_ok()
                && (line
                    .bytes
                    .windows(4)
                    .any(|w| w.eq_ignore_ascii_case(b"GOTO"))
                    || b.words()
                        .any(|w| w.letter == b'M' && matches!(w.code(), Some(970 | 990)))
                        && b.word(b'P').is_some());
            let parsed = if jump {
                Err(Diagnostic::at(
                    lampost_gcode::Severity::Error,
                    ErrorKind::RenumberJump,
                    line.number,
                    line.offset,
                    line.bytes,
                    0,
                    line.bytes.len(),
                ))
            } else {
                parsed
            };
            let refused = match parsed {
                // To standard output nothing is written after the first error line (the
                // lines after it are still read, for their errors).
                Ok(()) if errors > 0 && output.is_none() => None,
                Ok(()) => match em.block(&b) {
                    Ok(()) => None,
                    // A word the dialect cannot hold, or renumbering past its largest N:
                    // a located error (the emitter wrote nothing of the block).
                    Err(e) => match e.get_ref().and_then(|i| i.downcast_ref::<Diagnostic>()) {
                        Some(d) => Some(d.clone()),
                        None => return Err(werr(e)),
                    },
                },
                Err(d) => Some(d),
            };
            if let Some(d) = refused {
                errors += 1;
                if errors <= MAX_PRINTED {
                    eprint!("{}", report::render(&name, &d));
                }
                if matches!(d.kind, ErrorKind::RenumberOverflow { .. }) {
                    // Every later block would be past it too.
                    break;
                }
            }
        }
        if errors > 0 {
            em.finish_cut().map_err(werr)?;
        } else {
            em.finish().map_err(werr)?;
        }
    }
    if errors > 0 {
        // Dropping `out` removes the temporary file: no half-written output.
        return Err(CliError::failed(format!(
            "{name}: {errors} error(s); nothing written{}",
            if output.is_some() {
                ""
            } else {
                " after the first error line"
            }
        )));
    }
    out.commit()
}

fn num(v: f64) -> String {
    // Beyond 1e15 in exponent form (a 300-digit X is not shown as 300 digits).
    if v.is_finite() && v.abs() >= 1e15 {
        return format!("{v:e}");
    }
    let mut s = fixed(v, 6);
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

fn move_text(m: &Move) -> String {
    let mut s = String::with_capacity(80);
    s.push_str(match m.kind {
        MoveKind::Rapid => "G0",
        MoveKind::Linear | MoveKind::Probe => "G1",
        MoveKind::Arc {
            clockwise: true, ..
        } => "G2",
        MoveKind::Arc {
            clockwise: false, ..
        } => "G3",
    });
    for (i, &l) in AXES.iter().enumerate() {
        if i < 3 || m.axes_named & (1 << i) != 0 {
            s.push(' ');
            s.push(char::from(l));
            s.push_str(&num(m.end[i]));
        }
    }
    if !matches!(m.kind, MoveKind::Rapid) {
        s.push_str(" F");
        s.push_str(&num(m.feed));
    }
    if let Some(e) = m.extrusion {
        s.push_str(" E");
        s.push_str(&num(e));
    }
    match m.kind {
        MoveKind::Arc {
            center,
            plane,
            turns,
            ..
        } => {
            let (u, v, _) = plane.axes();
            let (a, b) = if u < v { (u, v) } else { (v, u) };
            s.push_str(&format!(
                " (centre {}{} {}{}",
                char::from(AXES[a]),
                num(center[a]),
                char::from(AXES[b]),
                num(center[b])
            ));
            if turns > 1 {
                s.push_str(&format!(", {turns} turns"));
            }
            s.push(')');
        }
        MoveKind::Probe => s.push_str(" (probe)"),
        _ => {}
    }
    s
}

fn move_json(m: &Move) -> Obj {
    let pos = |p: &[f64; 9]| {
        let mut o = Obj::new();
        for (i, &l) in AXES.iter().enumerate() {
            if i < 3 || m.axes_named & (1 << i) != 0 {
                o.set(char::from(l).encode_utf8(&mut [0; 4]), &p[i]);
            }
        }
        o
    };
    let mut v = obj! {
        "line": m.line,
        "g": match m.kind {
            MoveKind::Rapid => "G0",
            MoveKind::Linear => "G1",
            MoveKind::Probe => "G1",
            MoveKind::Arc { clockwise: true, .. } => "G2",
            MoveKind::Arc { clockwise: false, .. } => "G3",
        },
        "kind": m.kind,
        "start": pos(&m.start),
        "end": pos(&m.end),
        "feed": m.feed,
        "feed_mode": m.modal.feed_mode,
        "units": m.modal.units,
        "origin": m.origin,
    };
    if let Some(e) = m.extrusion {
        v.set("extrusion", &e);
    }
    if let Some(e) = m.extruded {
        v.set("extruded", &e);
    }
    v
}

pub fn trace(
    file: &str,
    output: Option<&str>,
    json: bool,
    interp: InterpArgs,
) -> Result<(), CliError> {
    let name = display_name(file);
    let (input, flavor) = program(file, Order::Execution, interp.flavor)?;
    if !json {
        eprintln!("{name}: {}", flavor.describe());
    }
    let mut out = Output::create(output)?;
    let werr = |e: std::io::Error| CliError::write(&e);
    let mut diags = Vec::new();
    let mut not_shown = 0usize;
    let mut errors = 0usize;
    let mut moves = 0usize;
    {
        let w = out.writer();
        if json {
            w.write_all(b"{\"moves\":[").map_err(werr)?;
        }
        for ev in Stream::new(input, options(interp, flavor.flavor), true) {
            match ev.map_err(|e| io_err(&name, e))? {
                Event::Move(m) => {
                    if json {
                        if moves > 0 {
                            w.write_all(b",").map_err(werr)?;
                        }
                        json::to_writer(&mut *w, &move_json(&m))?;
                    } else {
                        writeln!(w, "{}", move_text(&m)).map_err(werr)?;
                    }
                    moves += 1;
                }
                Event::Diagnostic(d) => {
                    if d.is_error() {
                        errors += 1;
                    }
                    eprint!("{}", report::render(&name, &d));
                    if diags.len() < MAX_JSON_DIAGNOSTICS {
                        diags.push(report::json(&name, &d));
                    } else {
                        not_shown += 1;
                    }
                }
                // Not asked for (`options`): a trace shows moves.
                Event::Stop(_) => {}
            }
        }
        if json {
            write!(
                w,
                "],\"diagnostics\":{},\"diagnostics_not_shown\":{not_shown},\"flavor\":{},\"ok\":{}}}",
                json::to_string(&diags)?,
                json::to_string(&flavor)?,
                errors == 0
            )
            .map_err(werr)?;
            writeln!(w).map_err(werr)?;
        }
    }
    if errors > 0 {
        return Err(CliError::failed(format!(
            "{name}: trace stopped at the first error after {moves} move(s)"
        )));
    }
    out.commit()
}
