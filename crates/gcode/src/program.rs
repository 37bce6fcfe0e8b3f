//! Files that hold several programs: `O` numbers, subprograms that end in M99, and calls
//! `M98 P… [L…]` (FADAL, Fanuc-style ISO).
//!
//! A [`ProgramReader`] hands out the lines, each with its own line number and byte offset.
//! When the first `M98` (or, in execution order, the first `O` line) comes, it reads the
//! file once and notes where each `O` program starts and where its last M99 ends (byte
//! offsets and line numbers, never the text); a file with neither is read once, as it
//! stands. The orders:
//!
//! - in file order ([`Order::File`], for `check`): every line of every program; a call
//!   is checked against the index (the program is there, once, and ends in M99);
//! - in execution order ([`Order::Execution`], for `trace` and verification): the main
//!   program, and at each `M98 Pn Lk` line the body of `On` (its `O` line up to the
//!   first M99 met, which returns) `k` times, calls inside it followed in turn.
//!
//! Calls made by evaluated lines come from the stream: LinuxCNC O-word lines and Fanuc
//! Macro B statements through [`ProgramReader::control`], Fanuc `G65` macros (their own
//! level of locals) and `M98` with variable words through [`ProgramReader::macro_call`].
//!
//! A *subprogram body* runs from an `O` line to the last M99 before the next `O` line (or
//! the end of the file). The *main program* is every line outside the bodies, in file
//! order; a file whose lines outside the bodies hold no words (a subprogram on its own)
//! is its own main program, read from the top. A file without `O` lines or M98 reads
//! exactly as a plain [`crate::LineReader`] reads it.
//!
//! FADAL's own subroutines (read under the `fadal` flavour, [`LineSource::set_flavor`]):
//! the program starts with its subroutine section, each subroutine from its heading
//! (`L0100`, subroutine 1; the heading's line is not run) to the next heading or its
//! `M17`, the section closed by an `M30` that separates it from the main program; `Lnnkk`
//! (a line of `N` and `L` alone) runs subroutine `nn` `kk` times. In execution order
//! the main program skips the section; in file order every line is handed out but the
//! separating `M30`. (FADAL manual, section 10: MAIN PROG. NOT FOUND, SUBR. NESTING
//! ERROR; section 18's slot example.) Fixed subroutines (`L91nn`…`L99nn`: probing,
//! engraving, bolt holes, pockets) and `L` words with other words (`L0101 G66`, a modal
//! call) are left to the interpreter, which warns.
//!
//! Hostile input cannot hang or exhaust memory: an `L` repeat is at most 10,000, calls
//! nest at most [`MAX_NESTING`] deep, recursion is refused, and at most [`MAX_RUNS`]
//! subprogram runs and [`MAX_CALL_LINES`] lines are read through calls in all; the index
//! holds at most [`MAX_PROGRAMS`] programs. A called body is reached by a relative seek,
//! so a short subprogram called often is served from the read buffer.

use std::collections::VecDeque;
use std::io::{self, BufRead, BufReader, Read, Seek};

use crate::ast::{Block, BlockKind};
use crate::diag::{Diagnostic, ErrorKind, Severity};
use crate::interp::Calls;
use crate::lines::{Line, LineReader};
use crate::parse::{parse_line_with, Reading, MAX_LINE_BYTES};
use crate::stream::LineSource;

/// The deepest calls are followed (the main program is depth 0).
pub const MAX_NESTING: usize = 8;
/// The most subprogram runs (each `L` repeat is a run) followed in one program.
pub const MAX_RUNS: u64 = 1_000_000;
/// The most lines read through calls in one program.
pub const MAX_CALL_LINES: u64 = 100_000_000;
/// The most `O` programs indexed in one file.
pub const MAX_PROGRAMS: usize = 100_000;
/// The largest `L` repeat of one call (as for canned cycles).
const MAX_REPEATS: u32 = 10_000;

/// The order in which a [`ProgramReader`] hands out lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// Every line of the file in turn; calls are checked, not followed.
    File,
    /// The main program with every call followed.
    Execution,
}

/// The program number of a block that starts an `O` program (`O1001`, `N1 O800`): an `O`
/// word with a whole value.
pub(crate) fn program_number(b: &Block<'_>) -> Option<u32> {
    if b.kind != BlockKind::Words {
        return None;
    }
    let w = b.word(b'O')?;
    (w.value >= 0.0 && w.value <= f64::from(u32::MAX) && w.value.fract() == 0.0)
        .then_some(w.value as u32)
}

/// One `O` program of the file.
#[derive(Debug, Clone, Copy)]
struct Program {
    number: u32,
    /// Offset and line number of its `O` line.
    start: usize,
    line: u32,
    /// Just past its last M99 line (offset, number of the next line): a subprogram.
    end: Option<(usize, u32)>,
}

/// A call being run.
#[derive(Debug, Clone, Copy)]
struct Frame {
    /// Index into `programs`.
    prog: usize,
    /// Where the caller goes on (offset, line number).
    back: (usize, u32),
    /// Runs still to come after this one.
    repeats_left: u32,
    /// A Haas `M97` call: `prog` indexes `locals`, the body runs to the first M99.
    local: bool,
    /// A Fanuc `G65` macro call: its own level of local variables.
    macro_call: bool,
    /// A FADAL subroutine: `prog` indexes `subs`.
    fadal: bool,
}

/// What a line asks of the reader.
#[derive(Debug)]
enum Action {
    Nothing,
    /// The file must be indexed first.
    Index,
    Call {
        prog: usize,
        repeats: u32,
        /// A FADAL subroutine (`prog` indexes `subs`).
        fadal: bool,
    },
    /// Haas `M97 P…`: the block labelled `N…` of this file, to its first M99.
    Local {
        label: u32,
        repeats: u32,
        span: crate::ast::Span,
    },
    Return,
    Error(Diagnostic),
}

/// Lines of a file of programs in file or execution order (see the module
/// documentation). It is a [`LineSource`] for [`crate::Stream`], and a [`BufRead`] whose
/// bytes are the lines in its order (for readers that take text, such as the post's
/// verification); there a call error is an [`io::Error`] naming the line.
#[derive(Debug)]
pub struct ProgramReader<R> {
    lines: LineReader<BufReader<R>>,
    order: Order,
    /// The programs have been indexed.
    indexed: bool,
    /// In file order.
    programs: Vec<Program>,
    /// Indexes into `programs`, by number (then file order).
    by_number: Vec<u32>,
    /// Execution order and the main program is not the whole file: skip the bodies.
    skip_bodies: bool,
    /// The next body (index into `programs`) the main program may meet.
    next_body: usize,
    /// Where the next line is read: offset and line number.
    pos: usize,
    line: u32,
    stack: Vec<Frame>,
    runs: u64,
    call_lines: u64,
    /// [`MAX_RUNS`] and [`MAX_CALL_LINES`] (smaller in tests).
    max_runs: u64,
    max_call_lines: u64,
    pending: VecDeque<Diagnostic>,
    halted: bool,
    /// The current line as bytes, for `BufRead`.
    out: Vec<u8>,
    out_pos: usize,
    /// LinuxCNC O-word lines and their control flow (indexed at the first one followed).
    ngc: Option<Box<crate::ngc::Control>>,
    /// The `N` labels of the file (number, offset, line), sorted, for `M97`.
    labels: Option<Vec<(u32, usize, u32)>>,
    /// Where each followed `M97` body starts (offset, line).
    locals: Vec<(usize, u32)>,
    /// [`crate::MAX_BLOCKS`] (smaller in tests).
    max_blocks: u64,
    /// Fanuc Macro B labels and loops (indexed at the first statement followed).
    macrob: Option<Box<crate::macrob::Control>>,
    /// `G65` macro levels left since the stream last asked (see `take_returns`).
    macro_returns: u32,
    /// A line has failed (see `note_error`): loops are not run again from here.
    after_error: bool,
    /// FADAL subroutines are read (the `fadal` flavour).
    fadal: bool,
    /// FADAL subroutines: `number` the subroutine, `start` where a call starts (after its
    /// heading), `end` where it returns (past its M17, or at the next heading or M30).
    subs: Vec<Program>,
    /// The FADAL subroutine section.
    section: Option<SubSection>,
}

/// Where the FADAL subroutine section lies (offset of a line, and its number).
#[derive(Debug, Clone, Copy)]
struct SubSection {
    /// Its first heading.
    first: usize,
    /// The `M30` line that closes it.
    close: usize,
    /// The line after that `M30`: the main program.
    after: (usize, u32),
}

fn may_matter(bytes: &[u8], fadal: bool) -> bool {
    // An `O` word or an M98/M99 needs the letter, a FADAL subroutine line an L; most
    // motion lines have neither. A line the parser refuses for its length is not scanned.
    // (One loop a flavour: a test of `fadal` inside it measured slower on every line.)
    bytes.len() <= MAX_LINE_BYTES
        && if fadal {
            bytes
                .iter()
                .any(|&c| matches!(c | 0x20, b'o' | b'm' | b'l'))
        } else {
            bytes.iter().any(|&c| matches!(c | 0x20, b'o' | b'm'))
        }
}

/// The largest FADAL user subroutine (the `L91nn`…`L99nn` are the fixed subroutines).
const FADAL_SUBS: u32 = 90;

/// A FADAL subroutine line: a block of `N` and one whole `L` word alone, naming a user
/// subroutine (`L0100`…`L9099`): the subroutine and its runs (0: its heading).
pub(crate) fn fadal_sub_line(b: &Block<'_>) -> Option<(u32, u32)> {
    if b.kind != BlockKind::Words {
        return None;
    }
    let mut l = None;
    for w in b.words() {
        match w.letter {
            b'N' if w.register.is_none() => {}
            b'L' if w.register.is_none() && l.is_none() => l = Some(w.value),
            _ => return None,
        }
    }
    let v = l?;
    let whole = v.fract() == 0.0 && v >= 100.0 && v < f64::from((FADAL_SUBS + 1) * 100);
    whole.then_some((v as u32 / 100, v as u32 % 100))
}

/// A line parsed as the reader's flavour reads it (FADAL: a `(` left open comments to the
/// end of the line, as its manual writes them).
fn parse_as(
    bytes: &[u8],
    number: u32,
    offset: usize,
    fadal: bool,
) -> Result<Block<'_>, Diagnostic> {
    let mut b = Block::empty(number, offset);
    let reading = if fadal {
        Reading::of(crate::flavor::Flavor::Fadal, false)
    } else {
        Reading::from(false)
    };
    parse_line_with(bytes, number, offset, &mut b, reading)?;
    Ok(b)
}

fn has_m(b: &Block<'_>, code: u16) -> bool {
    b.words()
        .any(|w| w.letter == b'M' && w.register.is_none() && w.code() == Some(code))
}

fn err_at(line: &Line<'_>, kind: ErrorKind, span: Option<crate::ast::Span>) -> Diagnostic {
    let (s, e) = span.map_or((0, line.bytes.len()), |sp| {
        (
            sp.start.saturating_sub(line.offset),
            sp.end.saturating_sub(line.offset),
        )
    });
    Diagnostic::at(
        Severity::Error,
        kind,
        line.number,
        line.offset,
        line.bytes,
        s,
        e,
    )
}

impl<R: Read + Seek> ProgramReader<R> {
    /// Lines of `reader` (from its current position) in `order`. Nothing is read yet;
    /// the file is indexed when the first line that needs it comes: an `M98` call, or in
    /// execution order an `O` line. A file with neither is read once, as it stands.
    pub fn new(reader: R, order: Order) -> Self {
        ProgramReader {
            lines: LineReader::new(BufReader::with_capacity(1 << 16, reader)),
            order,
            indexed: false,
            programs: Vec::new(),
            by_number: Vec::new(),
            skip_bodies: false,
            next_body: 0,
            pos: 0,
            line: 1,
            stack: Vec::new(),
            runs: 0,
            call_lines: 0,
            max_runs: MAX_RUNS,
            max_call_lines: MAX_CALL_LINES,
            pending: VecDeque::new(),
            halted: false,
            out: Vec::new(),
            out_pos: 0,
            ngc: None,
            labels: None,
            locals: Vec::new(),
            max_blocks: crate::ngc::MAX_BLOCKS,
            macrob: None,
            macro_returns: 0,
            after_error: false,
            fadal: false,
            subs: Vec::new(),
            section: None,
        }
    }

    /// Read FADAL subroutines (see the module documentation) when `fadal`; before the
    /// first line is read.
    pub fn fadal_subroutines(&mut self, fadal: bool) {
        self.fadal = fadal;
    }

    /// At most `n` blocks are run again by loops and subroutine calls (default
    /// [`crate::MAX_BLOCKS`]).
    pub fn set_max_blocks(&mut self, n: u64) {
        self.max_blocks = n;
    }

    /// Read the whole file once and note its `N` labels (for Haas `M97`).
    fn index_labels(&mut self) -> io::Result<Vec<(u32, usize, u32)>> {
        let mut v = Vec::new();
        self.lines.seek_line(0, 1)?;
        while let Some((line, _)) = self.lines.next_line_end()? {
            let b = line.bytes;
            let mut i = 0;
            while i < b.len() && matches!(b[i], b' ' | b'\t' | b'/') {
                i += 1;
            }
            if !b.get(i).is_some_and(|c| matches!(c, b'n' | b'N')) {
                continue;
            }
            let digits = b[i + 1..].iter().take_while(|c| c.is_ascii_digit()).count();
            if digits == 0 || digits > 9 || v.len() >= MAX_PROGRAMS {
                continue;
            }
            let n = b[i + 1..i + 1 + digits]
                .iter()
                .fold(0u32, |a, c| a * 10 + u32::from(c - b'0'));
            v.push((n, line.offset, line.number));
        }
        // The first block with a label wins.
        v.sort_by_key(|x| (x.0, x.1));
        v.dedup_by_key(|x| x.0);
        Ok(v)
    }

    /// Read the whole file once and note its LinuxCNC O-word lines.
    fn index_owords(&mut self) -> io::Result<crate::ngc::Control> {
        let mut c = crate::ngc::Control::new();
        c.max_blocks = self.max_blocks;
        self.lines.seek_line(0, 1)?;
        while let Some((line, end)) = self.lines.next_line_end()? {
            let b = line.bytes;
            let first = b.iter().position(|c| !matches!(c, b' ' | b'\t' | b'/'));
            let maybe = first.is_some_and(|i| matches!(b[i] | 0x20, b'o' | b'n'));
            if !maybe || b.len() > MAX_LINE_BYTES {
                continue;
            }
            let Ok(text) = std::str::from_utf8(b) else {
                continue;
            };
            let next = (end, line.number.saturating_add(1));
            if !c.add(text, (line.offset, line.number), next) {
                break;
            }
        }
        Ok(c)
    }

    /// Read the whole file once and note its Fanuc Macro B labels, loops and programs.
    fn index_macrob(&mut self) -> io::Result<crate::macrob::Control> {
        let mut c = crate::macrob::Control::new(self.max_blocks);
        self.lines.seek_line(0, 1)?;
        while let Some((line, end)) = self.lines.next_line_end()? {
            let b = line.bytes;
            let first = b.iter().position(|c| !matches!(c, b' ' | b'\t'));
            let maybe = first.is_some_and(|i| {
                matches!(
                    b[i] | 0x20,
                    b'o' | b'n' | b'/' | b'i' | b'w' | b'g' | b'd' | b'e'
                )
            });
            if !maybe || b.len() > MAX_LINE_BYTES {
                continue;
            }
            let Ok(text) = std::str::from_utf8(b) else {
                continue;
            };
            let next = (end, line.number.saturating_add(1));
            if !c.add(text, (line.offset, line.number), next) {
                break;
            }
        }
        Ok(c)
    }

    /// Follow the Fanuc Macro B statement `text` (see [`Self::control`]).
    fn control_macrob(
        &mut self,
        text: &str,
        number: u32,
        offset: usize,
        params: &crate::expr::Params,
    ) -> Result<(), Diagnostic> {
        let at_err = |msg: String, s: usize, e: usize| {
            Diagnostic::at(
                Severity::Error,
                ErrorKind::MacroB(msg),
                number,
                offset,
                text.as_bytes(),
                s,
                e,
            )
        };
        if self.macrob.is_none() {
            let at = (self.pos, self.line);
            let c = self.index_macrob().map_err(|e| {
                at_err(
                    format!("cannot index the Macro B lines: {e}"),
                    0,
                    text.len(),
                )
            })?;
            self.macrob = Some(Box::new(c));
            (self.pos, self.line) = at;
        }
        let Some(ctl) = self.macrob.as_mut() else {
            return Ok(());
        };
        match ctl.step(text, offset, number, params) {
            Ok(None) => Ok(()),
            Ok(Some((pos, line))) => {
                self.pos = pos;
                self.line = line;
                Ok(())
            }
            Err((msg, s, e)) => Err(at_err(msg, s, e)),
        }
    }

    /// Run the Fanuc macro `O{number}` `repeats` times with `args` as its locals (a `G65`
    /// call on line `line_no` at `offset`, just handed out), or without `args` the
    /// subprogram of an `M98` whose P or L came from a variable (a plain M98 is followed
    /// as the line is read); `None` when this reader does not follow calls (file order).
    pub fn macro_call(
        &mut self,
        call: (u32, u32, Option<&[Option<f64>; crate::expr::FANUC_LOCALS]>),
        line_no: u32,
        offset: usize,
        text: &str,
        params: &mut crate::expr::Params,
    ) -> Option<Result<(), Diagnostic>> {
        if self.order != Order::Execution {
            return None;
        }
        let (number, repeats, args) = call;
        let what = if args.is_some() { "G65" } else { "M98" };
        let err = |kind: ErrorKind| {
            Diagnostic::at(
                Severity::Error,
                kind,
                line_no,
                offset,
                text.as_bytes(),
                0,
                text.len(),
            )
        };
        if !self.indexed {
            let at = (self.pos, self.line);
            if let Err(e) = self.index() {
                return Some(Err(err(ErrorKind::MacroB(format!(
                    "cannot index the programs: {e}"
                )))));
            }
            (self.pos, self.line) = at;
        }
        let from = self
            .by_number
            .partition_point(|&i| self.programs[i as usize].number < number);
        let mut found = self.by_number[from..]
            .iter()
            .map(|&i| i as usize)
            .take_while(|&i| self.programs[i].number == number);
        let Some(prog) = found.next() else {
            return Some(Err(err(ErrorKind::MacroB(format!(
                "{what} P{number}: this file holds no program O{number}"
            )))));
        };
        if found.next().is_some() || self.programs[prog].end.is_none() {
            return Some(Err(err(ErrorKind::MacroB(format!(
                "{what} P{number}: O{number} must be in this file once and end with M99"
            )))));
        }
        if repeats == 0 {
            return Some(Ok(()));
        }
        let depth = self.stack.iter().filter(|f| f.macro_call).count();
        if args.is_none() && self.stack.iter().any(|f| !f.local && f.prog == prog) {
            return Some(Err(err(ErrorKind::RecursiveCall {
                number,
                chain: format!("O{number} → O{number}"),
            })));
        }
        if args.is_some() && depth >= crate::macrob::MAX_MACRO_DEPTH {
            return Some(Err(err(ErrorKind::MacroB(format!(
                "G65 macro calls nest more than {} deep (Fanuc's limit)",
                crate::macrob::MAX_MACRO_DEPTH
            )))));
        }
        if self.stack.len() >= MAX_NESTING {
            return Some(Err(err(ErrorKind::CallsTooDeep(MAX_NESTING))));
        }
        if self.runs + u64::from(repeats) > self.max_runs {
            return Some(Err(err(ErrorKind::TooManyCalls {
                limit: self.max_runs,
                what: "subprogram runs",
            })));
        }
        self.runs += u64::from(repeats);
        self.stack.push(Frame {
            prog,
            back: (self.pos, self.line),
            repeats_left: repeats - 1,
            local: false,
            macro_call: args.is_some(),
            fadal: false,
        });
        let p = self.programs[prog];
        self.pos = p.start;
        self.line = p.line;
        if let Some(args) = args {
            params.enter_macro(*args);
        }
        Some(Ok(()))
    }

    /// The `G65` macro levels left (by their M99) since the last call.
    pub fn take_returns(&mut self) -> u32 {
        std::mem::take(&mut self.macro_returns)
    }

    /// Follow the LinuxCNC O-word control line `text` (line `number` at `offset`, just
    /// handed out) with `params`, or with Macro B variables ([`crate::Params::macro_b`])
    /// the Fanuc statement (`IF … GOTO`, `GOTO`, `WHILE … DOm`, `DOm`, `ENDm`); `None`
    /// when this reader does not follow control lines (file order).
    pub fn control(
        &mut self,
        text: &str,
        number: u32,
        offset: usize,
        params: &mut crate::expr::Params,
    ) -> Option<Result<(), Diagnostic>> {
        if self.order != Order::Execution {
            return None;
        }
        let before = (self.pos, self.line);
        let r = if params.is_macro_b() {
            self.control_macrob(text, number, offset, params)
        } else {
            self.control_ngc(text, number, offset, params)?
        };
        if self.after_error && self.pos <= offset && !calls_or_returns(text, params) {
            // After an error a stream that goes on (check) reads straight on: a loop
            // whose condition or body fails is not run again and again.
            (self.pos, self.line) = before;
        }
        Some(r)
    }

    /// A line read through this reader has failed (a stream that does not stop at
    /// errors tells it): from now on loops are not run again, jumps back are not taken.
    pub fn note_error(&mut self) {
        self.after_error = true;
    }

    /// Call the LinuxCNC O-word subroutine `label` for a lathe profile cycle (G70–G72,
    /// `lathe.rs`) in the line just handed out: the sub's lines come next, and reading
    /// goes on after that line when it returns. The call depth before the call, or why
    /// the sub cannot be called; `None` when this reader does not follow calls.
    pub fn profile_call(
        &mut self,
        label: &str,
        params: &mut crate::expr::Params,
    ) -> Option<Result<usize, String>> {
        if self.order != Order::Execution || params.is_macro_b() {
            return None;
        }
        if self.ngc.is_none() {
            let at = (self.pos, self.line);
            match self.index_owords() {
                Ok(c) => self.ngc = Some(Box::new(c)),
                Err(e) => return Some(Err(format!("cannot index the O-word lines: {e}"))),
            }
            (self.pos, self.line) = at;
        }
        let ctl = self.ngc.as_mut()?;
        let depth = ctl.depth();
        Some(
            ctl.call(label, &[], (self.pos, self.line), params)
                .map(|(pos, line)| {
                    self.pos = pos;
                    self.line = line;
                    depth
                }),
        )
    }

    /// Follow the LinuxCNC O-word line `text` (see [`Self::control`]).
    fn control_ngc(
        &mut self,
        text: &str,
        number: u32,
        offset: usize,
        params: &mut crate::expr::Params,
    ) -> Option<Result<(), Diagnostic>> {
        if self.ngc.is_none() {
            let at = (self.pos, self.line);
            match self.index_owords() {
                Ok(c) => self.ngc = Some(Box::new(c)),
                Err(e) => {
                    return Some(Err(Diagnostic::at(
                        Severity::Error,
                        ErrorKind::Control(format!("cannot index the O-word lines: {e}")),
                        number,
                        offset,
                        text.as_bytes(),
                        0,
                        text.len(),
                    )))
                }
            }
            (self.pos, self.line) = at;
        }
        let ctl = self.ngc.as_mut()?;
        Some(match ctl.step(text, offset, params) {
            Ok(None) => Ok(()),
            Ok(Some((pos, line))) => {
                self.pos = pos;
                self.line = line;
                Ok(())
            }
            Err((msg, s, e)) => Err(Diagnostic::at(
                Severity::Error,
                ErrorKind::Control(msg),
                number,
                offset,
                text.as_bytes(),
                s,
                e,
            )),
        })
    }

    /// Read the whole file once and note its programs.
    fn index(&mut self) -> io::Result<()> {
        self.indexed = true;
        self.lines.seek_line(0, 1)?;
        let mut programs: Vec<Program> = Vec::new();
        // Whether lines outside the bodies hold words, and whether the current region
        // (the lines before the first `O`, or an `O` program) has words since its last M99.
        let mut main_words = false;
        let mut words_after = false;
        let mut in_program = false;
        let mut m99_before = false;
        let mut last = (0usize, 0u32);
        while let Some((line, end)) = self.lines.next_line_end()? {
            last = (end, line.number);
            if m99_before {
                m99_before = false;
                if let Some(p) = programs.last_mut() {
                    p.end = Some((line.offset, line.number));
                }
            }
            let need_words = !main_words && !words_after;
            if !need_words && !may_matter(line.bytes, self.fadal) {
                continue;
            }
            let (number, words, m99) =
                match parse_as(line.bytes, line.number, line.offset, self.fadal) {
                    Ok(b) => (
                        program_number(&b),
                        b.has_words() || matches!(b.kind, BlockKind::Macro(_)),
                        has_m(&b, 990),
                    ),
                    Err(_) => (None, true, false),
                };
            if let Some(n) = number {
                main_words |= words_after;
                if programs.len() >= MAX_PROGRAMS {
                    self.pending.push_back(err_at(
                        &line,
                        ErrorKind::TooManyPrograms(MAX_PROGRAMS),
                        None,
                    ));
                    break;
                }
                programs.push(Program {
                    number: n,
                    start: line.offset,
                    line: line.number,
                    end: None,
                });
                in_program = true;
            }
            words_after |= words;
            if m99 && in_program {
                m99_before = true;
                words_after = false;
            }
        }
        if m99_before {
            if let Some(p) = programs.last_mut() {
                p.end = Some((last.0, last.1.saturating_add(1)));
            }
        }
        main_words |= words_after;
        let mut by_number: Vec<u32> = (0..programs.len())
            .map(|i| u32::try_from(i).unwrap_or(u32::MAX))
            .collect();
        by_number.sort_by_key(|&i| (programs[i as usize].number, i));
        self.skip_bodies = self.order == Order::Execution && main_words;
        self.programs = programs;
        self.by_number = by_number;
        self.next_body = 0;
        if self.fadal {
            self.index_fadal()?;
        }
        Ok(())
    }

    /// Read the whole file once more and note its FADAL subroutines and their section.
    fn index_fadal(&mut self) -> io::Result<()> {
        self.lines.seek_line(0, 1)?;
        let mut subs: Vec<Program> = Vec::new();
        // The last subroutine has not ended yet.
        let mut open = false;
        let mut first: Option<(usize, Diagnostic)> = None;
        let mut close: Option<(usize, (usize, u32))> = None;
        while let Some((line, end)) = self.lines.next_line_end()? {
            if !may_matter(line.bytes, true) {
                continue;
            }
            let Ok(b) = parse_as(line.bytes, line.number, line.offset, self.fadal) else {
                continue;
            };
            let next = (end, line.number.saturating_add(1));
            if let Some((n, 0)) = fadal_sub_line(&b) {
                let span = b.word(b'L').map(|w| w.span);
                let refuse = |why: String| err_at(&line, ErrorKind::FadalSubroutine(why), span);
                if close.is_some() {
                    self.pending.push_back(refuse(format!(
                        "L{:04}: a subroutine heading after the M30 that ends the subroutine section (the control stops: SUBR. NESTING ERROR)",
                        n * 100
                    )));
                    continue;
                }
                if let Some(p) = subs.iter().find(|p| p.number == n) {
                    self.pending.push_back(refuse(format!(
                        "L{:04}: subroutine {n} is defined twice (its first heading is on line {})",
                        n * 100,
                        p.line.saturating_sub(1)
                    )));
                    continue;
                }
                if open {
                    if let Some(p) = subs.last_mut() {
                        p.end = Some((line.offset, line.number));
                    }
                }
                if first.is_none() {
                    first = Some((line.offset, refuse(format!(
                        "L{:04}: the subroutines at the start of the program are not closed by an M30 before the main program (the control stops: MAIN PROG. NOT FOUND)",
                        n * 100
                    ))));
                }
                subs.push(Program {
                    number: n,
                    start: next.0,
                    line: next.1,
                    end: None,
                });
                open = true;
            } else if first.is_some() && close.is_none() {
                if has_m(&b, 300) {
                    if open {
                        if let Some(p) = subs.last_mut() {
                            p.end = Some((line.offset, line.number));
                        }
                    }
                    open = false;
                    close = Some((line.offset, next));
                } else if has_m(&b, 170) && open {
                    if let Some(p) = subs.last_mut() {
                        p.end = Some(next);
                    }
                    open = false;
                }
            }
        }
        match (first, close) {
            (Some((first, _)), Some((close, after))) => {
                self.subs = subs;
                self.section = Some(SubSection {
                    first,
                    close,
                    after,
                });
            }
            (Some((_, not_closed)), None) => self.pending.push_back(not_closed),
            _ => {}
        }
        Ok(())
    }

    /// The next line in this reader's order, or `None` at the end.
    pub fn next_line(&mut self) -> io::Result<Option<Line<'_>>> {
        if self.halted {
            return Ok(None);
        }
        // A body ends at its last M99, which returns; this is only a guard.
        while let Some(f) = self.stack.last() {
            if f.local {
                break;
            }
            let p = if f.fadal {
                self.subs[f.prog]
            } else {
                self.programs[f.prog]
            };
            match p.end {
                Some((end, _)) if self.pos < end => break,
                _ => self.ret(),
            }
        }
        // The FADAL subroutine section: the main program (execution order) steps over
        // it; read in file order, only its closing M30 is left out.
        if let Some(sec) = self.section.filter(|_| self.stack.is_empty()) {
            let from = match self.order {
                Order::Execution => sec.first,
                Order::File => sec.close,
            };
            if self.pos == from {
                (self.pos, self.line) = sec.after;
            }
        }
        if self.stack.is_empty() && self.skip_bodies {
            // The main program steps over the subprogram bodies.
            while let Some(p) = self.programs.get(self.next_body) {
                match p.end {
                    Some(_) if p.start > self.pos => break,
                    Some((end, line)) if p.start == self.pos => {
                        self.pos = end;
                        self.line = line;
                    }
                    _ => {}
                }
                self.next_body += 1;
            }
        }
        if self.lines.bytes_read() != self.pos {
            self.lines.seek_line(self.pos, self.line)?;
        }
        let Some((offset, number, end)) = self
            .lines
            .next_line_end()?
            .map(|(l, end)| (l.offset, l.number, end))
        else {
            return Ok(None);
        };
        self.pos = end;
        self.line = number.saturating_add(1);
        if !self.stack.is_empty() {
            self.call_lines += 1;
            if self.call_lines > self.max_call_lines {
                let d = err_at(
                    &self.lines.last_line(),
                    ErrorKind::TooManyCalls {
                        limit: self.max_call_lines,
                        what: "lines",
                    },
                    None,
                );
                self.pending.push_back(d);
                self.halted = true;
                return Ok(None);
            }
        }
        let action = {
            let line = self.lines.last_line();
            let parsed = if may_matter(line.bytes, self.fadal) {
                parse_as(line.bytes, line.number, line.offset, self.fadal).ok()
            } else {
                None
            };
            match parsed {
                None => Action::Nothing,
                Some(b) if !self.indexed => {
                    let needs_index = has_m(&b, 980)
                        || has_m(&b, 970)
                        || (self.order == Order::Execution && program_number(&b).is_some())
                        || (self.fadal && fadal_sub_line(&b).is_some());
                    if needs_index {
                        Action::Index
                    } else {
                        Action::Nothing
                    }
                }
                Some(b) => self
                    .fadal
                    .then(|| {
                        fadal_action(
                            &line,
                            &b,
                            self.order,
                            &self.subs,
                            &self.stack,
                            (self.runs, self.max_runs),
                        )
                    })
                    .flatten()
                    .unwrap_or_else(|| {
                        action(
                            &line,
                            &b,
                            self.order,
                            &self.programs,
                            &self.by_number,
                            &self.stack,
                            (self.runs, self.max_runs),
                        )
                    }),
            }
        };
        match action {
            Action::Nothing => {}
            Action::Index => {
                // Index, then read this line again knowing the programs.
                self.index()?;
                self.pos = offset;
                self.line = number;
                return self.next_line();
            }
            Action::Error(d) => self.pending.push_back(d),
            Action::Call {
                prog,
                repeats,
                fadal,
            } => {
                self.runs += u64::from(repeats);
                self.stack.push(Frame {
                    prog,
                    back: (self.pos, self.line),
                    repeats_left: repeats - 1,
                    local: false,
                    macro_call: false,
                    fadal,
                });
                let p = if fadal {
                    self.subs[prog]
                } else {
                    self.programs[prog]
                };
                self.pos = p.start;
                self.line = p.line;
            }
            Action::Return => self.ret(),
            Action::Local {
                label,
                repeats,
                span,
            } => {
                if self.labels.is_none() {
                    self.labels = Some(self.index_labels()?);
                }
                let found = self.labels.as_ref().and_then(|l| {
                    let i = l.partition_point(|x| x.0 < label);
                    l.get(i).filter(|x| x.0 == label).map(|x| (x.1, x.2))
                });
                // Read the line again for the diagnostics: the index moved the reader.
                self.lines.seek_line(offset, number)?;
                self.lines.next_line_end()?;
                let line = self.lines.last_line();
                let Some(start) = found else {
                    let d = err_at(
                        &line,
                        ErrorKind::Control(format!(
                            "M97 P{label}: this file holds no block N{label}"
                        )),
                        Some(span),
                    );
                    self.pending.push_back(d);
                    return Ok(Some(self.lines.last_line()));
                };
                let error = if self.order == Order::File || repeats == 0 {
                    None
                } else if self
                    .stack
                    .iter()
                    .any(|f| f.local && self.locals[f.prog] == start)
                {
                    Some(ErrorKind::RecursiveCall {
                        number: label,
                        chain: format!("N{label} → N{label}"),
                    })
                } else if self.stack.len() >= MAX_NESTING {
                    Some(ErrorKind::CallsTooDeep(MAX_NESTING))
                } else if self.runs + u64::from(repeats) > self.max_runs {
                    Some(ErrorKind::TooManyCalls {
                        limit: self.max_runs,
                        what: "subprogram runs",
                    })
                } else {
                    self.runs += u64::from(repeats);
                    self.locals.push(start);
                    self.stack.push(Frame {
                        prog: self.locals.len() - 1,
                        back: (self.pos, self.line),
                        repeats_left: repeats - 1,
                        local: true,
                        macro_call: false,
                        fadal: false,
                    });
                    (self.pos, self.line) = start;
                    None
                };
                if let Some(kind) = error {
                    let d = err_at(&line, kind, Some(span));
                    self.pending.push_back(d);
                }
                return Ok(Some(self.lines.last_line()));
            }
        }
        Ok(Some(self.lines.last_line()))
    }

    /// Return from the innermost call: run it again while repeats are left, else go
    /// back to the caller.
    fn ret(&mut self) {
        if let Some(f) = self.stack.last_mut() {
            if f.repeats_left > 0 {
                f.repeats_left -= 1;
                (self.pos, self.line) = if f.local {
                    self.locals[f.prog]
                } else {
                    let p = if f.fadal {
                        self.subs[f.prog]
                    } else {
                        self.programs[f.prog]
                    };
                    (p.start, p.line)
                };
            } else {
                (self.pos, self.line) = f.back;
                if f.local {
                    self.locals.pop();
                }
                if f.macro_call {
                    self.macro_returns += 1;
                }
                self.stack.pop();
            }
        }
    }

    /// The next problem found with the calls (the line it concerns has been handed out).
    pub fn take_diagnostic(&mut self) -> Option<Diagnostic> {
        self.pending.pop_front()
    }
}

/// What `b` (the block of `line`) asks of the reader as a FADAL subroutine line (a call
/// `Lnnkk`, a heading, the M17 that returns), or `None` when it is none.
fn fadal_action(
    line: &Line<'_>,
    b: &Block<'_>,
    order: Order,
    subs: &[Program],
    stack: &[Frame],
    (runs, max_runs): (u64, u64),
) -> Option<Action> {
    if has_m(b, 170) && order == Order::Execution && stack.last().is_some_and(|f| f.fadal) {
        return Some(Action::Return);
    }
    let (n, runs_asked) = fadal_sub_line(b)?;
    if runs_asked == 0 {
        // A heading: the main program skips the section; read in file order, it is
        // a line like another (one after the section was refused when indexed).
        return Some(Action::Nothing);
    }
    let span = b.word(b'L').map(|w| w.span);
    let word = format!("L{:04}", n * 100 + runs_asked);
    let refuse = |why: String| {
        Some(Action::Error(err_at(
            line,
            ErrorKind::FadalSubroutine(why),
            span,
        )))
    };
    let Some(prog) = subs.iter().position(|p| p.number == n) else {
        return refuse(format!(
            "{word}: this program has no subroutine {n} (a heading L{:04} before the M30 that ends its subroutines; the control stops: SUBR. DOES NOT EXIST)",
            n * 100
        ));
    };
    if order == Order::File {
        return Some(Action::Nothing);
    }
    if stack.iter().any(|f| f.fadal && f.prog == prog) {
        return refuse(format!(
            "{word}: subroutine {n} is already running: a subroutine may not call itself, directly or through others"
        ));
    }
    if stack.len() >= MAX_NESTING {
        return Some(Action::Error(err_at(
            line,
            ErrorKind::CallsTooDeep(MAX_NESTING),
            span,
        )));
    }
    if runs + u64::from(runs_asked) > max_runs {
        return Some(Action::Error(err_at(
            line,
            ErrorKind::TooManyCalls {
                limit: max_runs,
                what: "subprogram runs",
            },
            span,
        )));
    }
    Some(Action::Call {
        prog,
        repeats: runs_asked,
        fadal: true,
    })
}

/// What `b` (the block of `line`) asks of the reader.
fn action(
    line: &Line<'_>,
    b: &Block<'_>,
    order: Order,
    programs: &[Program],
    by_number: &[u32],
    stack: &[Frame],
    (runs, max_runs): (u64, u64),
) -> Action {
    if has_m(b, 990) && !stack.is_empty() && order == Order::Execution {
        return Action::Return;
    }
    if let Some(m97) = b
        .words()
        .find(|w| w.letter == b'M' && w.register.is_none() && w.code() == Some(970))
    {
        let bad = |word: String, why: &'static str, span| {
            Action::Error(err_at(line, ErrorKind::BadValue { word, why }, Some(span)))
        };
        let Some(p) = b.word(b'P') else {
            return bad(
                "M97".into(),
                "the call needs the block number in P",
                m97.span,
            );
        };
        if !(p.value >= 0.0 && p.value <= 999_999_999.0 && p.value.fract() == 0.0) {
            return bad(p.display(), "the block number P is a whole number", p.span);
        }
        let repeats = match b.word(b'L') {
            None => 1,
            Some(l) if l.value > f64::from(MAX_REPEATS) => {
                return bad(l.display(), "more than 10000 repeats", l.span)
            }
            Some(l) if l.value >= 0.0 && l.value.fract() == 0.0 => l.value as u32,
            Some(l) => return bad(l.display(), "the repeat count L is a whole number", l.span),
        };
        return Action::Local {
            label: p.value as u32,
            repeats,
            span: p.span,
        };
    }
    let Some(m98) = b
        .words()
        .find(|w| w.letter == b'M' && w.register.is_none() && w.code() == Some(980))
    else {
        return Action::Nothing;
    };
    let bad = |word: String, why: &'static str, span| {
        Action::Error(err_at(line, ErrorKind::BadValue { word, why }, Some(span)))
    };
    let Some(p) = b.word(b'P') else {
        return bad(
            "M98".into(),
            "the call needs the program number in P",
            m98.span,
        );
    };
    if !(p.value >= 0.0 && p.value <= f64::from(u32::MAX) && p.value.fract() == 0.0) {
        return bad(
            p.display(),
            "the program number P is a whole number",
            p.span,
        );
    }
    let mut number = p.value as u32;
    let mut repeats = match b.word(b'L') {
        None => 1,
        Some(l) if l.value > f64::from(MAX_REPEATS) => {
            return bad(l.display(), "more than 10000 repeats", l.span)
        }
        Some(l) if l.value >= 0.0 && l.value.fract() == 0.0 => l.value as u32,
        Some(l) => return bad(l.display(), "the repeat count L is a whole number", l.span),
    };
    let held = |n: u32| {
        let from = by_number.partition_point(|&i| programs[i as usize].number < n);
        by_number
            .get(from)
            .is_some_and(|&i| programs[i as usize].number == n)
    };
    // Fanuc's packed call `M98 P31234`: the last four digits the program, the ones
    // before them the repeat count (Fanuc 0i: M98 P△△△△□□□□), taken when the file holds
    // no program of the whole number, no L is given, and it holds the four digits' one.
    if number > 9999 && b.word(b'L').is_none() && !held(number) && held(number % 10_000) {
        repeats = (number / 10_000).min(MAX_REPEATS);
        number %= 10_000;
    }
    let from = by_number.partition_point(|&i| programs[i as usize].number < number);
    let mut found = by_number[from..]
        .iter()
        .map(|&i| i as usize)
        .take_while(|&i| programs[i].number == number);
    let Some(prog) = found.next() else {
        return Action::Error(err_at(
            line,
            ErrorKind::UnknownProgram(number),
            Some(p.span),
        ));
    };
    if let Some(other) = found.next() {
        return Action::Error(err_at(
            line,
            ErrorKind::DuplicateProgram {
                number,
                first: programs[prog].line,
                second: programs[other].line,
            },
            Some(p.span),
        ));
    }
    if programs[prog].end.is_none() {
        return Action::Error(err_at(
            line,
            ErrorKind::NotASubprogram {
                number,
                line: programs[prog].line,
            },
            Some(p.span),
        ));
    }
    if order == Order::File || repeats == 0 {
        return Action::Nothing;
    }
    if stack.iter().any(|f| f.prog == prog && !f.local && !f.fadal) {
        let mut chain: Vec<String> = stack
            .iter()
            .map(|f| format!("O{}", programs[f.prog].number))
            .collect();
        chain.push(format!("O{number}"));
        return Action::Error(err_at(
            line,
            ErrorKind::RecursiveCall {
                number,
                chain: chain.join(" → "),
            },
            Some(p.span),
        ));
    }
    if stack.len() >= MAX_NESTING {
        return Action::Error(err_at(
            line,
            ErrorKind::CallsTooDeep(MAX_NESTING),
            Some(m98.span),
        ));
    }
    if runs + u64::from(repeats) > max_runs {
        return Action::Error(err_at(
            line,
            ErrorKind::TooManyCalls {
                limit: max_runs,
                what: "subprogram runs",
            },
            Some(m98.span),
        ));
    }
    Action::Call {
        prog,
        repeats,
        fadal: false,
    }
}

impl<R: Read + Seek> LineSource for ProgramReader<R> {
    fn next_line(&mut self) -> io::Result<Option<Line<'_>>> {
        ProgramReader::next_line(self)
    }

    fn set_flavor(&mut self, flavor: crate::flavor::Flavor) {
        self.fadal_subroutines(flavor == crate::flavor::Flavor::Fadal);
    }

    fn calls(&self) -> Calls {
        match self.order {
            Order::File => Calls::Checked,
            Order::Execution => Calls::Followed,
        }
    }

    fn take_diagnostic(&mut self) -> Option<Diagnostic> {
        ProgramReader::take_diagnostic(self)
    }

    fn control(
        &mut self,
        text: &str,
        number: u32,
        offset: usize,
        params: &mut crate::expr::Params,
    ) -> Option<Result<(), Diagnostic>> {
        ProgramReader::control(self, text, number, offset, params)
    }

    fn macro_call(
        &mut self,
        call: (u32, u32, Option<&[Option<f64>; crate::expr::FANUC_LOCALS]>),
        number: u32,
        offset: usize,
        text: &str,
        params: &mut crate::expr::Params,
    ) -> Option<Result<(), Diagnostic>> {
        ProgramReader::macro_call(self, call, number, offset, text, params)
    }

    fn take_returns(&mut self) -> u32 {
        ProgramReader::take_returns(self)
    }

    fn note_error(&mut self) {
        ProgramReader::note_error(self);
    }

    fn profile_call(
        &mut self,
        label: &str,
        params: &mut crate::expr::Params,
    ) -> Option<Result<usize, String>> {
        ProgramReader::profile_call(self, label, params)
    }

    fn call_depth(&self) -> usize {
        self.ngc.as_ref().map_or(0, |c| c.depth())
    }
}

/// Whether a control line is a LinuxCNC call or return (its jump back is no loop).
fn calls_or_returns(text: &str, params: &crate::expr::Params) -> bool {
    use crate::ngc::Kw;
    !params.is_macro_b()
        && crate::ngc::parse_oword(text)
            .is_some_and(|(_, kw, _)| matches!(kw, Kw::Call | Kw::Return | Kw::EndSub))
}

fn io_error(d: &Diagnostic) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("line {}: {}", d.line, d.kind),
    )
}

impl<R: Read + Seek> BufRead for ProgramReader<R> {
    fn fill_buf(&mut self) -> io::Result<&[u8]> {
        while self.out_pos >= self.out.len() {
            if let Some(d) = self.pending.pop_front() {
                if d.is_error() {
                    return Err(io_error(&d));
                }
                continue;
            }
            let mut out = std::mem::take(&mut self.out);
            out.clear();
            self.out_pos = 0;
            let more = match ProgramReader::next_line(self)? {
                Some(line) => {
                    out.extend_from_slice(line.bytes);
                    out.push(b'\n');
                    true
                }
                None => false,
            };
            self.out = out;
            if !more && self.pending.is_empty() {
                break;
            }
        }
        Ok(&self.out[self.out_pos..])
    }

    fn consume(&mut self, amt: usize) {
        self.out_pos = (self.out_pos + amt).min(self.out.len());
    }
}

impl<R: Read + Seek> Read for ProgramReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let avail = self.fill_buf()?;
        let n = avail.len().min(buf.len());
        buf[..n].copy_from_slice(&avail[..n]);
        self.consume(n);
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interp::{Event, Move, Options};
    use crate::stream::Stream;
    use crate::Units;

    fn opts() -> Options {
        Options {
            units: Units::Inch,
            ..Options::default()
        }
    }

    /// Moves and diagnostics of `text` in `order`.
    fn run(text: &str, order: Order) -> (Vec<Move>, Vec<Diagnostic>) {
        run_with(text, order, |_| {})
    }

    fn run_with(
        text: &str,
        order: Order,
        setup: impl FnOnce(&mut ProgramReader<io::Cursor<&[u8]>>),
    ) -> (Vec<Move>, Vec<Diagnostic>) {
        let mut r = ProgramReader::new(io::Cursor::new(text.as_bytes()), order);
        setup(&mut r);
        let mut moves = Vec::new();
        let mut diags = Vec::new();
        for e in Stream::new(r, opts(), order == Order::Execution) {
            match e.expect("reads") {
                Event::Move(m) => moves.push(m),
                Event::Diagnostic(d) => diags.push(d),
                Event::Stop(_) => {}
            }
        }
        (moves, diags)
    }

    fn errors(d: &[Diagnostic]) -> Vec<&Diagnostic> {
        d.iter().filter(|d| d.is_error()).collect()
    }

    /// Lines (number, offset, text) a reader hands out.
    fn lines_of(text: &str, order: Order) -> Vec<(u32, usize, String)> {
        let mut r = ProgramReader::new(io::Cursor::new(text.as_bytes()), order);
        let mut v = Vec::new();
        while let Some(l) = r.next_line().expect("reads") {
            v.push((
                l.number,
                l.offset,
                String::from_utf8_lossy(l.bytes).into_owned(),
            ));
        }
        v
    }

    /// What `lampost post --max-bytes` writes for the FADAL.
    const SPLIT: &str = "%\n\
        O1001 (PART 1 OF 2)\n\
        G0 Z1.\n\
        X1. Y0\n\
        G1 Z0 F10.\n\
        G0 Z1.\n\
        M99\n\
        O1002 (PART 2 OF 2)\n\
        X2.\n\
        G1 Z0\n\
        G0 Z1.\n\
        M99\n\
        O1000 (MAIN)\n\
        G70 G90 G94 G17 G40 G80\n\
        M98 P1001\n\
        M98 P1002\n\
        G0 Z2.\n\
        M30\n\
        %\n";

    #[test]
    fn a_split_fadal_file_runs_its_parts_in_call_order() {
        let (moves, diags) = run(SPLIT, Order::Execution);
        assert!(errors(&diags).is_empty(), "{diags:?}");
        assert!(diags.is_empty(), "no warnings either: {diags:?}");
        let lines: Vec<u32> = moves.iter().map(|m| m.line).collect();
        // Original line numbers, in execution order.
        assert_eq!(lines, [3, 4, 5, 6, 9, 10, 11, 17]);
        assert_eq!(moves[4].end[0], 2.0);
        assert_eq!(moves[7].end[2], 2.0);
        // The lines themselves: the main program's, with each body where it is called.
        let l = lines_of(SPLIT, Order::Execution);
        let numbers: Vec<u32> = l.iter().map(|x| x.0).collect();
        assert_eq!(
            numbers,
            [1, 13, 14, 15, 2, 3, 4, 5, 6, 7, 16, 8, 9, 10, 11, 12, 17, 18, 19]
        );
        for (n, off, text) in &l {
            let at = SPLIT.lines().nth(*n as usize - 1).expect("the line exists");
            assert_eq!(at, text);
            assert_eq!(&SPLIT[*off..*off + text.len()], text.as_str());
        }
    }

    #[test]
    fn check_reads_every_line_of_every_program() {
        // File order: an M99 ends only its subprogram, so the error in the second part and
        // the one in the main program are both found.
        let text = SPLIT
            .replace("X2.\n", "X2. Q\n")
            .replace("G0 Z2.\n", "G1 Z2. G0\n");
        let (_, diags) = run(&text, Order::File);
        let e = errors(&diags);
        assert_eq!(e.len(), 2, "{diags:?}");
        assert_eq!((e[0].line, e[1].line), (9, 17));
        assert!(!diags
            .iter()
            .any(|d| matches!(d.kind, ErrorKind::NotSimulated(_))));
        // The library's `check` is the same.
        let e2: Vec<u32> = crate::check(text.as_bytes(), opts())
            .iter()
            .filter(|d| d.is_error())
            .map(|d| d.line)
            .collect();
        assert_eq!(e2, [9, 17]);
        // And a clean split file checks clean.
        let d = crate::check(SPLIT.as_bytes(), opts());
        assert!(d.is_empty(), "{d:?}");
        // Check also finds calls to programs the file does not hold.
        let text = SPLIT.replace("M98 P1002", "M98 P1003");
        let d = crate::check(text.as_bytes(), opts());
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(d[0].kind, ErrorKind::UnknownProgram(1003));
        assert_eq!((d[0].line, d[0].column), (16, 5));
    }

    #[test]
    fn main_program_first_and_subprograms_after_m30() {
        let text = "O1 (MAIN)\nG20 G90 G0 X0 Y0 Z0\nM98 P800\nG0 X5\nM98 P800 L2\nM30\n\
                    O800 (SUB)\nG91 G1 X1 F10\nG90\nM99\n";
        let (moves, diags) = run(text, Order::Execution);
        assert!(diags.is_empty(), "{diags:?}");
        let xs: Vec<f64> = moves.iter().map(|m| m.end[0]).collect();
        assert_eq!(xs, [0.0, 1.0, 5.0, 6.0, 7.0]);
        // Read in file order, the subprogram after M30 is checked too.
        let bad = text.replace("G91 G1 X1", "G91 G1 X1 Y");
        let d = crate::check(bad.as_bytes(), opts());
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(d[0].line, 8);
    }

    #[test]
    fn repeats_nest_and_zero_repeats_skip() {
        let text = "G20 G91 G0 X0\nM98 P1 L3\nM98 P1 L0\nM30\n\
                    O1\nM98 P2 L2\nM99\nO2\nX1\nM99\n";
        let (moves, diags) = run(text, Order::Execution);
        assert!(diags.is_empty(), "{diags:?}");
        assert_eq!(moves.len(), 1 + 6);
        assert_eq!(moves.last().map(|m| m.end[0]), Some(6.0));
        // L without M98 is a FADAL subroutine call: to a subroutine the program does
        // not hold, refused; a fixed subroutine (L9101, probing) is not followed.
        let (_, d) = run("G20 G0 X0\nL105\n", Order::Execution);
        assert!(matches!(d[0].kind, ErrorKind::FadalSubroutine(_)), "{d:?}");
        let (_, d) = run("G20 G0 X0\nL9101 R1+1.\n", Order::Execution);
        assert!(
            d.iter()
                .any(|d| matches!(d.kind, ErrorKind::SubprogramNotFollowed(_))),
            "{d:?}"
        );
    }

    /// The FADAL manual's layout (section 10, MAIN PROG. NOT FOUND; section 18's slot
    /// program): subroutines first, each from its heading to the next heading or M17,
    /// the section closed by M30, then the main program; `Lnnkk` runs subroutine nn kk
    /// times, subroutines calling others; comments left open as the manual writes them.
    #[test]
    fn fadal_subroutines_run_where_called() {
        let text = "N1 O1 (FADAL PART\nN2 L100 (SUB 1\nN3 G91 G1 X1. F20.\nN4 L201\n\
                    N5 L200 (SUB 2\nN6 Y1.\nN7 Y-1.\nN8 M17\nN9 (\nN10 M30\n\
                    N11 (MAIN PROGRAM\nN12 G70 G90 G0 X0 Y0 Z0\nN13 L102\nN14 G90 G0 X5.\nN15 M2\n";
        let (moves, d) = run(text, Order::Execution);
        assert!(d.is_empty(), "{d:?}");
        let ends: Vec<[f64; 2]> = moves.iter().map(|m| [m.end[0], m.end[1]]).collect();
        assert_eq!(
            ends,
            [
                [0.0, 0.0],
                [1.0, 0.0],
                [1.0, 1.0],
                [1.0, 0.0],
                [2.0, 0.0],
                [2.0, 1.0],
                [2.0, 0.0],
                [5.0, 0.0]
            ]
        );
        // Every line read in file order but the M30 that closes the section: no
        // "after the program's end", no call refused.
        let mut r = ProgramReader::new(io::Cursor::new(text.as_bytes()), Order::File);
        r.fadal_subroutines(true);
        let mut lines = Vec::new();
        while let Some(l) = r.next_line().expect("reads") {
            lines.push(l.number);
        }
        assert_eq!(lines, [1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14, 15]);
        let (_, d) = run(text, Order::File);
        assert!(d.is_empty(), "{d:?}");
        // Outside the `fadal` flavour an L word is no call.
        let mut o = opts();
        o.flavor = crate::flavor::Flavor::Fanuc;
        let r = ProgramReader::new(io::Cursor::new(text.as_bytes()), Order::Execution);
        let n = Stream::new(r, o, false)
            .filter_map(|e| match e {
                Ok(Event::Move(_)) => Some(()),
                _ => None,
            })
            .count();
        assert_ne!(n, 8);
    }

    /// What the control refuses is refused at the line: no M30 before the main program
    /// (MAIN PROG. NOT FOUND), a heading after it (SUBR. NESTING ERROR), a call to a
    /// subroutine not there (SUBR. DOES NOT EXIST), a subroutine defined twice,
    /// recursion.
    #[test]
    fn fadal_subroutine_errors_are_located() {
        for (text, line, says) in [
            (
                "N1 L100\nN2 G1 X1. F20.\nN3 M17\nN4 G70 G0 X0\nN5 L101\nN6 M2\n",
                1,
                "MAIN PROG. NOT FOUND",
            ),
            (
                "N1 L100\nN2 G1 X1. F20.\nN3 M17\nN4 M30\nN5 G70 G0 X0\nN6 L200\nN7 M2\n",
                6,
                "NESTING",
            ),
            (
                "N1 L100\nN2 G1 X1. F20.\nN3 M17\nN4 M30\nN5 G70 G0 X0\nN6 L301\nN7 M2\n",
                6,
                "no subroutine 3",
            ),
            (
                "N1 L100\nN2 X1.\nN3 L100\nN4 M17\nN5 M30\nN6 G70 G0 X0\nN7 M2\n",
                3,
                "twice",
            ),
            (
                "N1 L100\nN2 G1 X1. F20.\nN3 L101\nN4 M17\nN5 M30\nN6 G70 G0 X0\nN7 L101\nN8 M2\n",
                3,
                "already running",
            ),
        ] {
            let (_, d) = run(text, Order::Execution);
            let e = d
                .iter()
                .find(|d| d.severity == Severity::Error)
                .unwrap_or_else(|| panic!("{text}: no error in {d:?}"));
            assert_eq!(e.line, line, "{text}: {e:?}");
            assert!(e.kind.to_string().contains(says), "{text}: {e:?}");
        }
    }

    /// A FADAL subroutine that calls an `O` subprogram (the probe manual's layout, O101
    /// before the program): each call is its own level.
    #[test]
    fn fadal_subroutines_and_subprograms_mix() {
        let text = "%\nN1O101 (SUB FOR PART\nN2G1G90X0F250.\nN4X1.\nN8M99\nN1O9110 (MAIN\n\
                    N2L100 (SUB\nN4M98P101\nN5M17\nN6M30\nN7 G70 G90 G0 X0 Y0 Z0\nN8L102\nN9 M2\n%\n";
        let (moves, d) = run(text, Order::Execution);
        assert!(d.is_empty(), "{d:?}");
        let xs: Vec<f64> = moves.iter().map(|m| m.end[0]).collect();
        assert_eq!(xs, [0.0, 0.0, 1.0, 0.0, 1.0]);
    }

    #[test]
    fn bad_calls_are_located_errors() {
        type Want = fn(&ErrorKind) -> bool;
        let cases: &[(&str, u32, u32, Want)] = &[
            ("G20 G0 X0\nM98 P77\nM30\n", 2, 5, |k| {
                *k == ErrorKind::UnknownProgram(77)
            }),
            (
                "G20 G0 X0\nM98 P5\nM30\nO5\nM98 P5\nM99\n",
                5,
                5,
                |k| matches!(k, ErrorKind::RecursiveCall { number: 5, chain } if chain == "O5 → O5"),
            ),
            (
                "G20 G0 X0\nM98 P5\nM30\nO5\nM98 P6\nM99\nO6\nX1 M98 P5\nM99\n",
                8,
                8,
                |k| matches!(k, ErrorKind::RecursiveCall { number: 5, chain } if chain == "O5 → O6 → O5"),
            ),
            (
                "G20 G0 X0\nM98 P5\nM30\nO5\nX1\nM99\nO5\nX2\nM99\n",
                2,
                5,
                |k| {
                    matches!(
                        k,
                        ErrorKind::DuplicateProgram {
                            number: 5,
                            first: 4,
                            second: 7
                        }
                    )
                },
            ),
            ("O1\nG20 G0 X0\nM98 P2\nM30\nO2\nX1\nM30\n", 3, 5, |k| {
                matches!(k, ErrorKind::NotASubprogram { number: 2, line: 5 })
            }),
            ("G20 G0 X0\nM98 P5 L10001\nM30\nO5\nM99\n", 2, 8, |k| {
                matches!(k, ErrorKind::BadValue { .. })
            }),
            ("G20 G0 X0\nM98 P5 L1.5\nM30\nO5\nM99\n", 2, 8, |k| {
                matches!(k, ErrorKind::BadValue { .. })
            }),
            ("G20 G0 X0\nM98\nM30\n", 2, 1, |k| {
                matches!(k, ErrorKind::BadValue { .. })
            }),
        ];
        for (text, line, column, want) in cases {
            let (_, diags) = run(text, Order::Execution);
            let e = errors(&diags);
            assert_eq!(e.len(), 1, "{text}: {diags:?}");
            assert!(want(&e[0].kind), "{text}: {:?}", e[0].kind);
            assert_eq!((e[0].line, e[0].column), (*line, *column), "{text}");
        }
    }

    #[test]
    fn nesting_is_capped() {
        // O1 calls O2 … calls O10: nine levels, one more than followed.
        let mut text = String::from("G20 G91 G0 X0\nM98 P1\nM30\n");
        for k in 1..=10 {
            text.push_str(&format!("O{k}\nX1\nM98 P{}\nM99\n", k + 1));
        }
        text.push_str("O11\nM99\n");
        let (moves, diags) = run(&text, Order::Execution);
        let e = errors(&diags);
        assert_eq!(e.len(), 1, "{diags:?}");
        assert_eq!(e[0].kind, ErrorKind::CallsTooDeep(MAX_NESTING));
        // The call from O8 (depth 8) is refused, on O8's M98 line.
        assert_eq!(e[0].line, 3 + 7 * 4 + 3);
        assert_eq!(moves.len(), 1 + MAX_NESTING);
        // Eight deep is followed.
        let text = text.replace("M98 P9\n", "\n");
        let (moves, diags) = run(&text, Order::Execution);
        assert!(diags.is_empty(), "{diags:?}");
        assert_eq!(moves.len(), 1 + MAX_NESTING);
    }

    #[test]
    fn hostile_repeats_stop_at_the_caps() {
        // 10,000 × 10,000 × … runs: stopped by the run count, quickly.
        let mut text = String::from("G20 G91 G0 X0\nM98 P1 L10000\nM30\n");
        for k in 1..=7 {
            text.push_str(&format!("O{k}\nM98 P{} L10000\nM99\n", k + 1));
        }
        text.push_str("O8\nX1\nM99\n");
        let (_, diags) = run_with(&text, Order::Execution, |r| r.max_runs = 50_000);
        let e = errors(&diags);
        assert_eq!(e.len(), 1, "{diags:?}");
        assert!(matches!(
            e[0].kind,
            ErrorKind::TooManyCalls {
                limit: 50_000,
                what: "subprogram runs"
            }
        ));
        let (moves, diags) = run_with(&text, Order::Execution, |r| r.max_call_lines = 3_000);
        let e = errors(&diags);
        assert_eq!(e.len(), 1, "{diags:?}");
        assert!(
            matches!(e[0].kind, ErrorKind::TooManyCalls { what: "lines", .. }),
            "{e:?}"
        );
        assert!(moves.len() < 3_000);
    }

    #[test]
    fn without_o_numbers_the_lines_are_the_plain_lines() {
        let texts = [
            "G21 G90\nG0 X1\n\nG1 Y2 F100\r\nM30\nG0 X9\n",
            "%\nO1000 (ONE PROGRAM)\nG70 G0 X1\nM30\n%\n",
            "G20\nG0 X1\nM99\nG0 X2\n",
            "",
            "no newline at the end",
        ];
        for text in texts {
            let plain: Vec<(u32, usize, String)> = crate::Lines::new(text.as_bytes())
                .map(|l| {
                    (
                        l.number,
                        l.offset,
                        String::from_utf8_lossy(l.bytes).into_owned(),
                    )
                })
                .collect();
            assert_eq!(lines_of(text, Order::File), plain, "{text}");
            assert_eq!(lines_of(text, Order::Execution), plain, "{text}");
            let a: Vec<_> = Stream::from_bytes(text.as_bytes(), opts(), false)
                .map(|e| e.expect("reads"))
                .collect();
            let r = ProgramReader::new(io::Cursor::new(text.as_bytes()), Order::Execution);
            let b: Vec<_> = Stream::new(r, opts(), false)
                .map(|e| e.expect("reads"))
                .collect();
            assert_eq!(a, b, "{text}");
        }
    }

    #[test]
    fn a_subprogram_on_its_own_runs_from_the_top() {
        let text = "O800 (SUB)\nG20 G0 X1\nM99\n";
        let (moves, diags) = run(text, Order::Execution);
        assert!(diags.is_empty(), "{diags:?}");
        assert_eq!(moves.len(), 1);
        // M99 with no O program open ends the trace after one pass, with a warning at
        // the M99: the control would run the main program again without end.
        let (moves, diags) = run("G20 G0 X1\nN5 M99\nG0 X2\n", Order::Execution);
        assert_eq!(moves.len(), 1);
        assert_eq!(diags[0].kind, ErrorKind::MainProgramLoops("fadal"));
        assert_eq!(diags[0].severity, Severity::Warning);
        assert_eq!((diags[0].line, diags[0].column), (2, 4));
        assert!(matches!(diags[1].kind, ErrorKind::NotSimulated(_)));
        // Printer firmware has no M99: an error there.
        let marlin = Options {
            flavor: crate::Flavor::Marlin,
            ..opts()
        };
        let r = ProgramReader::new(io::Cursor::new(&b"G20 G0 X1\nM99\n"[..]), Order::Execution);
        let d: Vec<Diagnostic> = Stream::new(r, marlin, true)
            .filter_map(|e| match e {
                Ok(Event::Diagnostic(d)) => Some(d),
                _ => None,
            })
            .collect();
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(d[0].kind, ErrorKind::ReturnOutsideSubprogram);
        assert!(d[0].is_error());
        assert_eq!((d[0].line, d[0].column), (2, 1));
    }

    #[test]
    fn the_bytes_in_execution_order() {
        let mut r = ProgramReader::new(io::Cursor::new(SPLIT.as_bytes()), Order::Execution);
        let mut s = String::new();
        r.read_to_string(&mut s).expect("reads");
        assert!(s.starts_with("%\nO1000 (MAIN)\nG70 G90 G94 G17 G40 G80\nM98 P1001\nO1001"));
        assert_eq!(s.lines().count(), 19);
        // A bad call is an I/O error naming the line.
        let text = SPLIT.replace("M98 P1002", "M98 P9");
        let mut r = ProgramReader::new(io::Cursor::new(text.as_bytes()), Order::Execution);
        let e = r.read_to_string(&mut String::new()).expect_err("fails");
        assert_eq!(
            e.to_string(),
            "line 16: M98 P9: this file holds no program O9"
        );
    }

    #[test]
    fn a_short_subprogram_called_often_stays_in_the_buffer() {
        let text = "G20 G91 G0 X0\nM98 P1 L10000\nM30\nO1\nX1\nM99\n";
        let (moves, diags) = run(text, Order::Execution);
        assert!(diags.is_empty());
        assert_eq!(moves.last().map(|m| m.end[0]), Some(10_000.0));
    }
}
