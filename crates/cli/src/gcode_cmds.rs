//! `lampost check`, `fmt` and `trace`.

use std::io::Write;

use lampost_gcode::emit::fixed;
use lampost_gcode::{
    parse_line, Diagnostic, Dialect, EWord, EmitOptions, Emitter, ErrorKind, Event, LineReader,
    Move, MoveKind, Options, Order, ProgramReader, Severity, Stream, Units, AXES,
};

use crate::io::{display_name, open_input, open_seekable, Output};
use crate::json::{self, obj, Obj};
use crate::report::{self, CliError};
use crate::{DialectArg, EWordArg, InterpArgs, UnitsArg};

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

pub fn options(a: InterpArgs) -> Options {
    Options {
        units: units(a.units),
        e_word: match a.e_word {
            EWordArg::Fixture => EWord::FixtureOffset,
            EWordArg::Extrusion => EWord::Extrusion,
        },
        block_delete: a.block_delete,
    }
}

fn io_err(name: &str, e: std::io::Error) -> CliError {
    CliError::usage(format!("error: cannot read {name}: {e}"))
}

/// `file`'s lines in `order` (every program in turn, or the main program with its calls
/// followed).
fn program(
    file: &str,
    order: Order,
) -> Result<ProgramReader<Box<dyn crate::io::ReadSeek>>, CliError> {
    Ok(ProgramReader::new(open_seekable(file)?, order))
}

/// `check`: every diagnostic for people on standard error (the first
/// [`MAX_PRINTED`]), or with `--json` one JSON document on standard output, streamed:
/// `{"file": …, "diagnostics": [` then each diagnostic as it is found, one a line (the
/// first [`MAX_JSON_DIAGNOSTICS`]), then `], "not_shown": …, "errors": …, "warnings": …,
/// "ok": …}`. Memory does not grow with the number of diagnostics.
pub fn check(file: &str, json: bool, interp: InterpArgs) -> Result<(), CliError> {
    let name = display_name(file);
    let input = program(file, Order::File)?;
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
    for ev in Stream::new(input, options(interp), false) {
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
            "{}],\"not_shown\":{not_shown},\"errors\":{errors},\"warnings\":{warnings},\"ok\":{}}}",
            if shown > 0 { "\n" } else { "" },
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
        eprintln!("{name}: {errors} error(s), {warnings} warning(s)");
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
    start_units: UnitsArg,
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
        units: units(start_units),
    };
    let mut reader = LineReader::new(open_input(file)?);
    let mut out = Output::create(output)?;
    let werr = |e: std::io::Error| CliError::write(&e);
    let mut errors = 0usize;
    {
        let mut em = Emitter::new(out.writer(), opts);
        while let Some(line) = reader.next_line().map_err(|e| io_err(&name, e))? {
            let parsed = match line.too_long() {
                Some(d) => Err(d),
                None => parse_line(line.bytes, line.number, line.offset),
            };
            let refused = match parsed {
                Ok(b) => match em.block(&b) {
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
        em.finish().map_err(werr)?;
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
    let input = program(file, Order::Execution)?;
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
        for ev in Stream::new(input, options(interp), true) {
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
            }
        }
        if json {
            write!(
                w,
                "],\"diagnostics\":{},\"diagnostics_not_shown\":{not_shown},\"ok\":{}}}",
                json::to_string(&diags)?,
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
