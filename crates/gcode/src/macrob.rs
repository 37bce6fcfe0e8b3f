//! Fanuc Macro B, evaluated for the `fanuc` and `haas` flavours: `#` variables,
//! `[…]` arithmetic with Fanuc's functions, `IF […] GOTO n`, `IF […] THEN #i = …`,
//! `WHILE […] DOm … ENDm`, `GOTO n` and `G65 P… L… A… B…` macro calls.
//!
//! The values and expressions are [`crate::expr`]'s evaluator in its Macro B mode
//! ([`Params::macro_b`]): variables are vacant until set, `#1`–`#33` are local to each
//! macro level and common `#100`–`#199`, `#500`–`#999` are shared; EQ and NE tell vacant
//! from 0 and compare exactly; AND, OR, XOR work bit by bit on whole numbers with Fanuc's
//! precedence; FIX and FUP round toward and away from zero; BIN and BCD convert. A word
//! whose value is a vacant variable is left out of its block (Fanuc's rule: `X#24` with
//! `#24` vacant moves no X).
//!
//! Only lines that are not plain words come here (the parser's macro lines, and lines it
//! refuses, which `IF`, `WHILE`, `GOTO`, `DO` and `END` lines are), plus blocks with G65:
//! a program without macros keeps the parser's fast path. Jumps are followed by
//! [`crate::ProgramReader`] (see `Control`): the file's `N` labels, `WHILE`/`DO`/`END`
//! lines and `O` lines are indexed once, offsets only, at the first control line.
//!
//! Bounds: `G65` calls nest at most [`MAX_MACRO_DEPTH`] deep (Fanuc's four levels);
//! blocks run again through loops and backward jumps are counted against
//! [`crate::MAX_BLOCKS`], as LinuxCNC's O-word loops are. Every bad input (a `GOTO`
//! to a label the program does not hold, `WHILE` without its `END`, `END` without its
//! `DO`, a loop number reused inside its own loop, a loop number other than 1–3) is a
//! located error.

use crate::ast::{Block, BlockKind};
use crate::diag::{Diagnostic, ErrorKind, Severity};
use crate::expr::{Eval, EvalError, Params, FANUC_LOCALS};
use crate::parse::MAX_LINE_BYTES;

/// `G65` macro calls nest at most this deep (Fanuc's four levels).
pub const MAX_MACRO_DEPTH: usize = 4;
/// The most statement lines and labels indexed in one file.
const MAX_ENTRIES: usize = 1_000_000;

/// A Macro B control statement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Stmt {
    /// `IF [cond] GOTO n` or `IF [cond] THEN …`.
    If,
    /// `WHILE [cond] DOm`.
    While,
    /// `GOTO n`.
    Goto,
    /// `DOm` alone: a loop without a condition.
    Do,
    /// `ENDm`.
    End,
}

/// Skip blanks from `i`.
fn blanks(b: &[u8], mut i: usize) -> usize {
    while i < b.len() && matches!(b[i], b' ' | b'\t') {
        i += 1;
    }
    i
}

/// Whether `b[i..]` starts with the keyword `kw` (any case).
fn keyword(b: &[u8], i: usize, kw: &str) -> bool {
    b.len() >= i + kw.len() && b[i..i + kw.len()].eq_ignore_ascii_case(kw.as_bytes())
}

/// The statement a line holds (after an optional `/` and `N` number), with where the
/// rest of the line starts (after the keyword) and the `N` label, if any.
pub(crate) fn statement(text: &str) -> Option<(Stmt, usize, Option<u32>)> {
    let b = text.as_bytes();
    let mut i = blanks(b, 0);
    if b.get(i) == Some(&b'/') {
        i = blanks(b, i + 1);
    }
    let mut label = None;
    if b.get(i).is_some_and(|c| matches!(c, b'n' | b'N')) {
        let s = blanks(b, i + 1);
        let e = s + b[s..].iter().take_while(|c| c.is_ascii_digit()).count();
        if e == s || e - s > 9 {
            return None;
        }
        label = text[s..e].parse::<u32>().ok();
        i = blanks(b, e);
    }
    for (kw, st) in [
        ("IF", Stmt::If),
        ("WHILE", Stmt::While),
        ("GOTO", Stmt::Goto),
        ("DO", Stmt::Do),
        ("END", Stmt::End),
    ] {
        if keyword(b, i, kw) {
            let rest = i + kw.len();
            let next = b.get(blanks(b, rest)).copied();
            let ok = match st {
                Stmt::If | Stmt::While => next == Some(b'['),
                Stmt::Goto => next.is_some_and(|c| c.is_ascii_digit() || matches!(c, b'#' | b'[')),
                // `DO1`, `END1` (a digit right after, or after blanks).
                Stmt::Do | Stmt::End => next.is_some_and(|c| c.is_ascii_digit()),
            };
            return ok.then_some((st, rest, label));
        }
    }
    None
}

/// A Fanuc Macro B statement line (`IF […] GOTO n`, `IF […] THEN …`, `WHILE […] DOm`,
/// `DOm`, `ENDm`, `GOTO n`; after an optional `/` and `N` number) as a block kept
/// verbatim ([`crate::MacroKind::FanucMacroB`]), for a writer that copies what it does not
/// run (`lampost fmt`); `None` for any other line (read it as words).
pub fn statement_block(line: &[u8], number: u32, offset: usize) -> Option<crate::Block<'_>> {
    let text = std::str::from_utf8(line).ok()?;
    statement(text)?;
    let mut b = crate::Block::empty(number, offset);
    b.kind = crate::BlockKind::Macro(crate::MacroKind::FanucMacroB);
    b.span = crate::Span::new(offset, offset + line.len());
    b.raw = text;
    Some(b)
}

/// The loop number after `DO` or `END` at `i` (blanks allowed): 1 to 3 on Fanuc.
fn loop_number(text: &str, i: usize) -> Result<(u8, usize), EvalError> {
    let b = text.as_bytes();
    let s = blanks(b, i);
    let e = s + b[s..].iter().take_while(|c| c.is_ascii_digit()).count();
    match text[s..e].parse::<u8>() {
        Ok(m @ 1..=3) => Ok((m, e)),
        _ => Err((
            format!("loop number `{}`: DO and END take 1, 2 or 3", &text[s..e]),
            s,
            e.max(s + 1),
        )),
    }
}

/// The `DO` number of a `WHILE [cond] DOm` line (`rest` just after `WHILE`).
fn while_number(text: &str, rest: usize) -> Option<u8> {
    // The condition's brackets, then DO.
    let b = text.as_bytes();
    let mut depth = 0usize;
    let mut i = blanks(b, rest);
    while i < b.len() {
        match b[i] {
            b'[' => depth += 1,
            b']' => {
                depth = depth.saturating_sub(1);
                if depth == 0 {
                    i += 1;
                    break;
                }
            }
            _ => {}
        }
        i += 1;
    }
    let i = blanks(b, i);
    keyword(b, i, "DO")
        .then(|| loop_number(text, i + 2).ok().map(|(m, _)| m))
        .flatten()
}

/// What a Macro B line asks of the reader, after [`eval_line`].
#[derive(Debug)]
pub enum Outcome {
    /// A block of words (possibly none) for the interpreter.
    Words,
    /// A control statement (`IF … GOTO`, `GOTO`, `WHILE`, `DO`, `END`) for the line
    /// source to follow ([`crate::LineSource::control`]).
    Control,
    /// A `G65` macro call: program `number`, `repeats` runs, arguments `#1`–`#33`.
    Call {
        /// The program called (`P`).
        number: u32,
        /// Its runs (`L`, default 1).
        repeats: u32,
        /// The locals of the macro: `A` is `#1`, `B` `#2`, … (vacant where not given).
        args: Box<[Option<f64>; FANUC_LOCALS]>,
    },
}

/// The local variable an argument letter of `G65` sets (Fanuc's argument
/// specification I); `None` for letters that are no argument (G, L, N, O, P).
pub fn argument(letter: u8) -> Option<usize> {
    Some(match letter {
        b'A' => 1,
        b'B' => 2,
        b'C' => 3,
        b'I' => 4,
        b'J' => 5,
        b'K' => 6,
        b'D' => 7,
        b'E' => 8,
        b'F' => 9,
        b'H' => 11,
        b'M' => 13,
        b'Q' => 17,
        b'R' => 18,
        b'S' => 19,
        b'T' => 20,
        b'U' => 21,
        b'V' => 22,
        b'W' => 23,
        b'X' => 24,
        b'Y' => 25,
        b'Z' => 26,
        _ => return None,
    })
}

fn located(line: &[u8], line_no: u32, offset: usize, (msg, s, e): EvalError) -> Diagnostic {
    Diagnostic::at(
        Severity::Error,
        ErrorKind::Expression(msg),
        line_no,
        offset,
        line,
        s,
        e,
    )
}

/// Evaluate a Macro B line into `block` (see the module documentation). `parsed` is
/// what the plain parser made of it: kept when the line is plain words after all.
pub fn eval_line<'a>(
    line: &'a [u8],
    line_no: u32,
    offset: usize,
    block: &mut Block<'a>,
    params: &mut Params,
    parsed: Result<(), Diagnostic>,
) -> Result<Outcome, Diagnostic> {
    let err = |e: EvalError| located(line, line_no, offset, e);
    if line.len() > MAX_LINE_BYTES {
        return parsed.map(|()| Outcome::Words);
    }
    let Ok(text) = std::str::from_utf8(line) else {
        return parsed.map(|()| Outcome::Words);
    };
    match statement(text) {
        Some((Stmt::If, rest, _)) => {
            block.kind = BlockKind::Words;
            block.items.clear();
            let mut ev = Eval::new(text, rest, params);
            let cond = ev.value().map_err(err)?;
            let at = blanks(line, ev.pos);
            if keyword(line, at, "GOTO") {
                // The reader evaluates the condition again and jumps.
                return Ok(Outcome::Control);
            }
            if !keyword(line, at, "THEN") {
                return Err(err((
                    "IF [condition] is followed by GOTO n or THEN".into(),
                    at,
                    line.len().max(at + 1),
                )));
            }
            if cond == 0.0 {
                return Ok(Outcome::Words);
            }
            // The statement after THEN, read as a line of its own (its columns kept).
            let then = blanks(line, at + 4);
            if !text[then..].starts_with('#') {
                return Err(err((
                    "THEN takes an assignment `#i = …`".into(),
                    then,
                    line.len().max(then + 1),
                )));
            }
            let mut padded = vec![b' '; then];
            padded.extend_from_slice(&line[then..]);
            let mut scratch = Block::empty(line_no, offset);
            crate::expr::eval_line(&padded, line_no, offset, &mut scratch, params).map_err(
                |d| {
                    let (s, e) = (d.column.saturating_sub(1) as usize, line.len());
                    located(line, line_no, offset, (d.kind.to_string(), s.min(e), e))
                },
            )?;
            if scratch.words().next().is_some() {
                return Err(err((
                    "THEN takes an assignment `#i = …`, not words".into(),
                    then,
                    line.len(),
                )));
            }
            Ok(Outcome::Words)
        }
        Some((Stmt::While | Stmt::Goto | Stmt::Do | Stmt::End, _, _)) => {
            block.kind = BlockKind::Words;
            block.items.clear();
            Ok(Outcome::Control)
        }
        None if block.kind == BlockKind::Percent => parsed.map(|()| Outcome::Words),
        None => {
            if block.kind == BlockKind::Words {
                // A line the parser refused and that is no statement: its error stands.
                parsed?;
                return call(block, line, line_no, offset);
            }
            crate::expr::eval_line(line, line_no, offset, block, params)?;
            call(block, line, line_no, offset)
        }
    }
}

/// A `G65 P… L…` block's call (its other words are the arguments), or plain words.
pub fn call(
    block: &mut Block<'_>,
    line: &[u8],
    line_no: u32,
    offset: usize,
) -> Result<Outcome, Diagnostic> {
    let Some(g65) = block
        .words()
        .find(|w| w.letter == b'G' && w.register.is_none() && w.code() == Some(650))
        .map(|w| w.span)
    else {
        return Ok(Outcome::Words);
    };
    let rel = |sp: crate::ast::Span| {
        (
            sp.start.saturating_sub(offset),
            sp.end.saturating_sub(offset),
        )
    };
    let bad = |msg: String, sp: crate::ast::Span| {
        let (s, e) = rel(sp);
        Diagnostic::at(
            Severity::Error,
            ErrorKind::MacroB(msg),
            line_no,
            offset,
            line,
            s,
            e,
        )
    };
    let mut number = None;
    let mut repeats = 1u32;
    let mut args = Box::new([None; FANUC_LOCALS]);
    for w in block.words() {
        match w.letter {
            b'G' if w.span == g65 => {}
            b'N' => {}
            b'P' => {
                if !(w.value >= 0.0 && w.value <= 99_999_999.0 && w.value.fract() == 0.0) {
                    return Err(bad(
                        format!(
                            "{}: the macro's program number is a whole number",
                            w.display()
                        ),
                        w.span,
                    ));
                }
                number = Some(w.value as u32);
            }
            b'L' => {
                if !(w.value >= 0.0 && w.value <= 10_000.0 && w.value.fract() == 0.0) {
                    return Err(bad(
                        format!(
                            "{}: the repeat count L is a whole number 0 to 10000",
                            w.display()
                        ),
                        w.span,
                    ));
                }
                repeats = w.value as u32;
            }
            b'G' => {
                return Err(bad(
                    format!(
                        "{} beside G65: lampost reads a G65 block as the macro call and its arguments (A–F, H, I–K, M, Q–Z) only; write {} on a line of its own before the call",
                        w.display(),
                        w.display()
                    ),
                    w.span,
                ))
            }
            l => match argument(l) {
                Some(n) => args[n - 1] = Some(w.value),
                None => {
                    return Err(bad(
                        format!(
                            "{}: not an argument of G65 (A–F, H, I–K, M, Q–Z)",
                            w.display()
                        ),
                        w.span,
                    ))
                }
            },
        }
    }
    let Some(number) = number else {
        return Err(bad("G65 needs the macro's program number in P".into(), g65));
    };
    block.items.clear();
    Ok(Outcome::Call {
        number,
        repeats,
        args,
    })
}

/// An evaluated block's `M98 P… [L…]` (program, runs), whose P or L came from a
/// variable; an `M97` with such values is refused (its label must be a number).
pub fn sub_call(
    block: &Block<'_>,
    line: &[u8],
    line_no: u32,
    offset: usize,
) -> Result<Option<(u32, u32)>, Diagnostic> {
    let m = |code| {
        block
            .words()
            .find(|w| w.letter == b'M' && w.register.is_none() && w.code() == Some(code))
    };
    let bad = |msg: String, sp: crate::ast::Span| {
        located(
            line,
            line_no,
            offset,
            (
                msg,
                sp.start.saturating_sub(offset),
                sp.end.saturating_sub(offset),
            ),
        )
    };
    if let Some(w) = m(970) {
        return Err(bad(
            "M97 with a value from a variable is not followed: write P and L as numbers".into(),
            w.span,
        ));
    }
    let Some(m98) = m(980) else {
        return Ok(None);
    };
    let Some(p) = block.word(b'P') else {
        return Err(bad("M98 needs the program number in P".into(), m98.span));
    };
    if !(p.value >= 0.0 && p.value <= 99_999_999.0 && p.value.fract() == 0.0) {
        return Err(bad(
            format!("{}: the program number P is a whole number", p.display()),
            p.span,
        ));
    }
    let repeats = match block.word(b'L') {
        None => 1,
        Some(l) if l.value >= 0.0 && l.value <= 10_000.0 && l.value.fract() == 0.0 => {
            l.value as u32
        }
        Some(l) => {
            return Err(bad(
                format!(
                    "{}: the repeat count L is a whole number 0 to 10000",
                    l.display()
                ),
                l.span,
            ))
        }
    };
    Ok(Some((p.value as u32, repeats)))
}

/// One indexed line of the file.
#[derive(Debug, Clone, Copy)]
enum Entry {
    /// An `O` line: a program starts.
    Program,
    /// `WHILE … DOm` or `DOm`.
    Do { m: u8, while_: bool },
    /// `ENDm`.
    End { m: u8 },
}

/// A control error: message and byte range in the line.
pub(crate) type CtlError = (String, usize, usize);

/// The index of a file's Macro B lines and labels, and the count of blocks run again.
#[derive(Debug, Default)]
pub(crate) struct Control {
    /// (offset, line, next line (offset, number), what), in file order.
    entries: Vec<(usize, u32, (usize, u32), Entry)>,
    /// (label, offset, line), in file order; sorted by label then offset at the first
    /// jump.
    labels: Vec<(u32, usize, u32)>,
    labels_sorted: bool,
    /// Offsets of the `O` lines, in file order.
    programs: Vec<usize>,
    blocks: u64,
    /// Bytes of blocks run again so far.
    bytes: u64,
    pub(crate) max_blocks: u64,
}

impl Control {
    pub(crate) fn new(max_blocks: u64) -> Self {
        Control {
            max_blocks,
            ..Control::default()
        }
    }

    /// Note a line of the file (in file order); false when the index is full.
    pub(crate) fn add(&mut self, text: &str, at: (usize, u32), next: (usize, u32)) -> bool {
        if self.entries.len() + self.labels.len() >= MAX_ENTRIES {
            return false;
        }
        let b = text.as_bytes();
        let i = blanks(b, 0);
        if b.get(i).is_some_and(|c| matches!(c, b'o' | b'O'))
            && b.get(i + 1).is_some_and(u8::is_ascii_digit)
        {
            self.entries.push((at.0, at.1, next, Entry::Program));
            self.programs.push(at.0);
        }
        let stmt = statement(text);
        if let Some((st, rest, label)) = stmt {
            if let Some(n) = label {
                self.labels.push((n, at.0, at.1));
            }
            let e = match st {
                Stmt::While => while_number(text, rest).map(|m| Entry::Do { m, while_: true }),
                Stmt::Do => loop_number(text, rest)
                    .ok()
                    .map(|(m, _)| Entry::Do { m, while_: false }),
                Stmt::End => loop_number(text, rest).ok().map(|(m, _)| Entry::End { m }),
                _ => None,
            };
            if let Some(e) = e {
                self.entries.push((at.0, at.1, next, e));
            }
            return true;
        }
        // A label: `N` and digits at the start of the line.
        let mut j = i;
        if b.get(j) == Some(&b'/') {
            j = blanks(b, j + 1);
        }
        if b.get(j).is_some_and(|c| matches!(c, b'n' | b'N')) {
            let s = blanks(b, j + 1);
            let e = s + b[s..].iter().take_while(|c| c.is_ascii_digit()).count();
            if e > s && e - s <= 9 {
                if let Ok(n) = text[s..e].parse::<u32>() {
                    self.labels.push((n, at.0, at.1));
                }
            }
        }
        true
    }

    /// The program (`O` line to the next one) holding `offset`: its byte range.
    fn program_of(&self, offset: usize) -> (usize, usize) {
        let k = self.programs.partition_point(|&o| o <= offset);
        let start = if k == 0 { 0 } else { self.programs[k - 1] };
        let end = self.programs.get(k).copied().unwrap_or(usize::MAX);
        (start, end)
    }

    /// A jump back from `from` to `to` (offset, line): the blocks (and bytes) it runs
    /// again, counted against the caps ([`crate::ngc::MAX_LOOP_BYTES`] for bytes).
    fn count(&mut self, from: (usize, u32), to: (usize, u32), len: usize) -> Result<(), CtlError> {
        self.blocks += u64::from(from.1.saturating_sub(to.1)) + 1;
        self.bytes += from.0.saturating_sub(to.0) as u64;
        if self.bytes > crate::ngc::MAX_LOOP_BYTES {
            return Err((
                format!(
                    "more than {} bytes of blocks run again through loops and jumps (long lines in a loop that runs long?)",
                    crate::ngc::MAX_LOOP_BYTES
                ),
                0,
                len,
            ));
        }
        if self.blocks > self.max_blocks {
            return Err((
                format!(
                    "more than {} blocks run through loops and jumps (a loop that never ends?)",
                    self.max_blocks
                ),
                0,
                len,
            ));
        }
        Ok(())
    }

    /// Follow the statement `text` (at `offset`, line `number`): where reading goes on,
    /// or `None` for the next line.
    pub(crate) fn step(
        &mut self,
        text: &str,
        offset: usize,
        number: u32,
        params: &Params,
    ) -> Result<Option<(usize, u32)>, CtlError> {
        let len = text.len();
        let Some((st, rest, _)) = statement(text) else {
            return Err(("not a Macro B statement".into(), 0, len));
        };
        let b = text.as_bytes();
        let cond = |from: usize| -> Result<(bool, usize), CtlError> {
            let mut ev = Eval::new(text, from, params);
            let v = ev.value()?;
            Ok((v != 0.0, ev.pos))
        };
        match st {
            Stmt::If => {
                let (yes, at) = cond(rest)?;
                let at = blanks(b, at);
                if !keyword(b, at, "GOTO") {
                    return Err((
                        "IF [condition] is followed by GOTO n or THEN".into(),
                        at.min(len),
                        len,
                    ));
                }
                if yes {
                    self.goto(text, at + 4, offset, number, params)
                } else {
                    Ok(None)
                }
            }
            Stmt::Goto => self.goto(text, rest, offset, number, params),
            Stmt::While | Stmt::Do => {
                let m = if st == Stmt::While {
                    let (yes, at) = cond(rest)?;
                    let at = blanks(b, at);
                    if !keyword(b, at, "DO") {
                        return Err((
                            "WHILE [condition] is followed by DOm".into(),
                            at,
                            len.max(at + 1),
                        ));
                    }
                    let (m, _) = loop_number(text, at + 2)?;
                    if yes {
                        None
                    } else {
                        Some(m)
                    }
                } else {
                    loop_number(text, rest)?;
                    None
                };
                let i = self.entry_at(offset, len)?;
                let (mm, _) = match self.entries[i].3 {
                    Entry::Do { m, while_ } => (m, while_),
                    _ => return Err(("this line is not in the file's index".into(), 0, len)),
                };
                let end = self.matching_end(i, mm, len)?;
                Ok(m.map(|_| self.entries[end].2))
            }
            Stmt::End => {
                let (m, _) = loop_number(text, rest)?;
                let i = self.entry_at(offset, len)?;
                let (lo, _) = self.program_of(offset);
                let open = self.entries[..i]
                    .iter()
                    .rposition(|&(o, _, _, e)| {
                        o >= lo && matches!(e, Entry::Do { m: k, .. } if k == m)
                    })
                    .ok_or_else(|| (format!("END{m} without DO{m} before it"), 0, len))?;
                // The loop this END closes must close here (not at an earlier END).
                let end = self.matching_end(open, m, len)?;
                if end != i {
                    return Err((format!("END{m} without DO{m} before it"), 0, len));
                }
                let (o, line, next, e) = self.entries[open];
                self.count((offset, number), (o, line), len)?;
                Ok(Some(match e {
                    // Back to the WHILE, whose condition is read again.
                    Entry::Do { while_: true, .. } => (o, line),
                    _ => next,
                }))
            }
        }
    }

    fn entry_at(&self, offset: usize, len: usize) -> Result<usize, CtlError> {
        self.entries
            .binary_search_by_key(&offset, |e| e.0)
            .ok()
            .and_then(|i| {
                // An `O` line and a statement cannot share a line, but be exact.
                (i..self.entries.len())
                    .take_while(|&k| self.entries[k].0 == offset)
                    .find(|&k| !matches!(self.entries[k].3, Entry::Program))
            })
            .ok_or_else(|| ("this line is not in the file's index".into(), 0, len))
    }

    /// The `ENDm` closing the loop opened at entry `i`: the first `ENDm` after it in its
    /// program; another `DOm` before it is a reused loop number.
    fn matching_end(&self, i: usize, m: u8, len: usize) -> Result<usize, CtlError> {
        let (_, hi) = self.program_of(self.entries[i].0);
        for (k, &(o, line, _, e)) in self.entries.iter().enumerate().skip(i + 1) {
            if o >= hi {
                break;
            }
            match e {
                Entry::End { m: k2 } if k2 == m => return Ok(k),
                Entry::Do { m: k2, .. } if k2 == m => {
                    return Err((
                        format!(
                            "DO{m} inside DO{m} (line {line}): nested loops need different numbers"
                        ),
                        0,
                        len,
                    ))
                }
                _ => {}
            }
        }
        Err((format!("DO{m} has no END{m}"), 0, len))
    }

    /// `GOTO n` with `n` at `from` in `text`: the block labelled `Nn` in this program,
    /// searched forward from here, then from the program's start (Fanuc's order).
    fn goto(
        &mut self,
        text: &str,
        from: usize,
        offset: usize,
        number: u32,
        params: &Params,
    ) -> Result<Option<(usize, u32)>, CtlError> {
        let b = text.as_bytes();
        let at = blanks(b, from);
        let mut ev = Eval::new(text, at, params);
        let v = ev.value()?;
        let end = ev.pos;
        let n = crate::emit::round_half_away(v);
        if !(0.0..=99_999.0).contains(&n) {
            return Err((
                format!("GOTO {v}: the sequence number is 0 to 99999"),
                at,
                end,
            ));
        }
        let n = n as u32;
        let (lo, hi) = self.program_of(offset);
        if !self.labels_sorted {
            self.labels.sort_by_key(|&(l, o, _)| (l, o));
            self.labels_sorted = true;
        }
        let first = self.labels.partition_point(|&(l, _, _)| l < n);
        let same = &self.labels[first..];
        let same = &same[..same.partition_point(|&(l, _, _)| l == n)];
        let found = same
            .get(same.partition_point(|&(_, o, _)| o <= offset))
            .filter(|&&(_, o, _)| o < hi)
            .or_else(|| {
                same.get(same.partition_point(|&(_, o, _)| o < lo))
                    .filter(|&&(_, o, _)| o <= offset)
            })
            .copied();
        let Some((_, o, line)) = found else {
            return Err((
                format!("GOTO {n}: this program holds no block N{n}"),
                at,
                end,
            ));
        };
        if o <= offset {
            self.count((offset, number), (o, line), text.len())?;
        }
        Ok(Some((o, line)))
    }
}
