//! Parse and interpret as one stream: lines in, [`Event`]s out, flat memory.

use std::collections::VecDeque;
use std::io::{self, BufRead};

use crate::ast::{Block, BlockKind, MacroKind};
use crate::diag::{Diagnostic, ErrorKind, Severity};
use crate::expr::Params;
use crate::interp::{Calls, EWord, Event, Interpreter, MoveKind, Options};
use crate::lines::{Line, LineReader, Lines};
use crate::parse::{
    comment_not_utf8, parse_line_lenient, parse_str_with, plain_motion, Reading, MAX_LINE_BYTES,
};
use crate::program::{Order, ProgramReader};

/// Anything that hands out lines one at a time.
/// Count the moves a block (or a lathe profile cycle) made beyond its first: `true`
/// when the program is past [`MAX_EXPANDED`]. Loops and calls cap the blocks run, not
/// what each makes: a `G81 … L9999` inside them would make billions of moves from a few
/// hundred bytes.
fn expanded_past_cap(expanded: &mut u64, moves: usize) -> bool {
    *expanded += moves.saturating_sub(1) as u64;
    *expanded > MAX_EXPANDED
}

/// Moves among `events`.
fn moves_in<'e>(events: impl Iterator<Item = &'e Event>) -> usize {
    events.filter(|e| matches!(e, Event::Move(_))).count()
}

/// The most moves blocks may make beyond one each in a program (canned cycles' holes and
/// their `L` repeats, lathe cycles' passes), however the blocks are repeated by loops and
/// calls: 5,000,000 (a few seconds of tracing; real programs make thousands).
pub const MAX_EXPANDED: u64 = 5_000_000;

pub trait LineSource {
    /// The next line, or `None` at the end.
    fn next_line(&mut self) -> io::Result<Option<Line<'_>>>;

    /// How this source treats subprogram calls (plain sources do not follow them).
    fn calls(&self) -> Calls {
        Calls::NotFollowed
    }

    /// The flavour the program is read in, told before its first line (a source that
    /// follows calls reads FADAL's own subroutines under `fadal`).
    fn set_flavor(&mut self, _flavor: crate::flavor::Flavor) {}

    /// A problem the source found (a call to a missing program, say), reported after the
    /// line it concerns.
    fn take_diagnostic(&mut self) -> Option<Diagnostic> {
        None
    }

    /// Follow a LinuxCNC O-word control line (see `ngc.rs`) that was just handed
    /// out; `None` when this source does not follow them (then the line is warned about).
    fn control(
        &mut self,
        _text: &str,
        _number: u32,
        _offset: usize,
        _params: &mut Params,
    ) -> Option<Result<(), Diagnostic>> {
        None
    }

    /// Run a Fanuc `G65` macro call (program, runs, locals) made by the line just handed
    /// out; `None` when this source does not follow calls.
    fn macro_call(
        &mut self,
        _call: (u32, u32, Option<&[Option<f64>; crate::expr::FANUC_LOCALS]>),
        _number: u32,
        _offset: usize,
        _text: &str,
        _params: &mut Params,
    ) -> Option<Result<(), Diagnostic>> {
        None
    }

    /// The `G65` macro levels the source has left (at their M99) since the last call.
    fn take_returns(&mut self) -> u32 {
        0
    }

    /// A line has failed and the stream goes on: the source should not run loops again.
    fn note_error(&mut self) {}

    /// Call the LinuxCNC O-word subroutine `label` (no arguments) for the lathe profile
    /// cycle of the line just handed out: its lines come next. The call depth before the
    /// call (see [`LineSource::call_depth`]), or why the sub cannot be called; `None`
    /// when this source does not follow calls.
    fn profile_call(
        &mut self,
        _label: &str,
        _params: &mut Params,
    ) -> Option<Result<usize, String>> {
        None
    }

    /// How deep in LinuxCNC O-word subroutine calls the reading is.
    fn call_depth(&self) -> usize {
        0
    }
}

impl LineSource for Lines<'_> {
    fn next_line(&mut self) -> io::Result<Option<Line<'_>>> {
        Ok(self.next())
    }
}

impl<R: BufRead> LineSource for LineReader<R> {
    fn next_line(&mut self) -> io::Result<Option<Line<'_>>> {
        LineReader::next_line(self)
    }
}

/// An iterator of interpreter events over a whole program.
#[derive(Debug)]
pub struct Stream<S> {
    src: S,
    interp: Interpreter,
    queue: VecDeque<Event>,
    stop_on_error: bool,
    stopped: bool,
    finished: bool,
    any_content: bool,
    /// How lines are read: a printer firmware's reading (E is extrusion, numbers may
    /// have exponents), LinuxCNC's polar words (see [`crate::parse_line_with`]).
    reading: Reading,
    /// The parameters, when the flavour evaluates macros (see [`crate::expr`]).
    params: Option<Box<Params>>,
    /// Plain straight moves take the fast lane ([`plain_motion`]); off in the test that
    /// compares the two, and for MakerBot programs (where A and B are the extruder, not
    /// axes, which only the reference path reads).
    fast_lane: bool,
    /// A comment that is not UTF-8 has been reported (once a program).
    warned_comment_utf8: bool,
    /// Text after the program's end has been reported (once a program).
    warned_text_after_end: bool,
    /// The vendor commands (`W221`) warned about: each once.
    warned_vendor: Vec<String>,
    /// The source's call depth (see [`LineSource::call_depth`]) where a lathe profile
    /// cycle called its subroutine: the profile is complete when reading is back there.
    profile_depth: usize,
    /// Moves made by blocks beyond their first so far (see `expanded_past_cap`).
    expanded: u64,
}

impl<S: LineSource> Stream<S> {
    /// A stream over `src`. With `stop_on_error`, the stream ends after the first error
    /// (what follows an error cannot be trusted for motion); without it, every block is
    /// read and every problem reported.
    pub fn new(mut src: S, opts: Options, stop_on_error: bool) -> Self {
        src.set_flavor(opts.flavor);
        let mut interp = Interpreter::new(opts);
        interp.set_calls(src.calls());
        let params = if opts.flavor.macro_b() {
            Some(Box::new(Params::macro_b()))
        } else {
            opts.flavor.evaluates().then(Box::default)
        };
        Stream {
            src,
            interp,
            queue: VecDeque::new(),
            stop_on_error,
            stopped: false,
            finished: false,
            any_content: false,
            reading: Reading::of(opts.flavor, opts.e_word == EWord::Extrusion),
            params,
            fast_lane: !opts.flavor.extruder_is_a_or_b(),
            warned_comment_utf8: false,
            warned_text_after_end: false,
            warned_vendor: Vec::new(),
            profile_depth: 0,
            expanded: 0,
        }
    }

    /// The interpreter, for its final state.
    pub fn interpreter(&self) -> &Interpreter {
        &self.interp
    }

    /// The same stream with every line read the reference way: no fast lane for plain
    /// straight moves. The events are the same (property-tested, and compared by the
    /// fuzz's `gcode` target); for tests and fuzzing that compare the two.
    pub fn reference_only(mut self) -> Self {
        self.fast_lane = false;
        self
    }
}

impl<'a> Stream<Lines<'a>> {
    /// A stream over an in-memory program.
    pub fn from_bytes(input: &'a [u8], opts: Options, stop_on_error: bool) -> Self {
        Stream::new(Lines::new(input), opts, stop_on_error)
    }
}

impl<R: BufRead> Stream<LineReader<R>> {
    /// A stream over a reader, one line in memory at a time.
    pub fn from_reader(reader: R, opts: Options, stop_on_error: bool) -> Self {
        Stream::new(LineReader::new(reader), opts, stop_on_error)
    }
}

impl<S: LineSource> Iterator for Stream<S> {
    type Item = io::Result<Event>;

    fn next(&mut self) -> Option<io::Result<Event>> {
        loop {
            if let Some(e) = self.queue.pop_front() {
                return Some(Ok(e));
            }
            if self.stopped || self.finished {
                return None;
            }
            let line = match self.src.next_line() {
                Err(e) => {
                    self.stopped = true;
                    return Some(Err(e));
                }
                Ok(None) => {
                    self.finished = true;
                    // Moves held by cutter compensation go at the end, as LinuxCNC sends
                    // them when the program ends.
                    let queue = &mut self.queue;
                    self.interp.end_compensation(&mut |e| queue.push_back(e));
                    if let Some(d) = self
                        .interp
                        .cancel_profile("the profile's subroutine never returned")
                    {
                        self.queue.push_back(Event::Diagnostic(d));
                    }
                    while let Some(d) = self.src.take_diagnostic() {
                        self.queue.push_back(Event::Diagnostic(d));
                    }
                    if !self.any_content && self.queue.is_empty() {
                        self.queue.push_back(Event::Diagnostic(Diagnostic::whole(
                            Severity::Error,
                            ErrorKind::EmptyProgram,
                        )));
                    }
                    continue;
                }
                Ok(Some(line)) => line,
            };
            if !self.any_content && line.bytes.iter().any(|b| !b.is_ascii_whitespace()) {
                self.any_content = true;
            }
            let queue = &mut self.queue;
            // The queue is empty here; the block's events go to it in order, then any
            // error, then the source's diagnostics, and the loop hands them out. (Events
            // go straight into the queue: moving a large `Event` through an `Option` on
            // the way out costs more than the queue.)
            let mut control = None;
            let mut call = None;
            // The fast lane: a plain move, read and run without a `Block`. Where nothing
            // follows up its move (no parameters to update, no diagnostic from the
            // source), the move is handed out at once.
            let mut direct = None;
            // A printer program's vendor line (`W221`) is never a move: not fast.
            let vendor = if self.reading.slicer {
                vendor_command(line.bytes)
            } else {
                None
            };
            // Nor is Prusa's tool park (`P0 S1 L2 D0`), which moves as its firmware knows.
            let park = if self.reading.slicer {
                prusa_tool_park(line.bytes)
            } else {
                None
            };
            if self.fast_lane && line.len <= MAX_LINE_BYTES && vendor.is_none() && park.is_none() {
                if let Some(p) = plain_motion(line.bytes) {
                    // A whole-number length word under Fanuc or Haas goes the reference
                    // way, which warns of it (`Interpreter::integer_word`).
                    let integer = self
                        .interp
                        .watching_integers()
                        .is_some_and(|f| crate::interp::has_integer_word(line.bytes, f));
                    if !integer {
                        direct = self.interp.plain_motion(&p, line.number);
                    }
                }
            }
            let plain = direct.is_some();
            if self.params.is_some() {
                // Parameters follow the move up (below): it goes through the queue.
                if let Some(m) = direct.take() {
                    queue.push_back(Event::Move(m));
                }
            }
            let failed = if plain {
                if let Some(params) = self.params.as_deref_mut() {
                    after_moves(params, queue);
                }
                false
            } else {
                let mut scratch = None;
                let mut block = Block::empty(line.number, line.offset);
                let mut parsed = match line.too_long() {
                    Some(d) => Err(d),
                    None => match line.text {
                        Some(text) => {
                            parse_str_with(text, line.number, line.offset, &mut block, self.reading)
                        }
                        None => match parse_line_lenient(
                            line.bytes,
                            line.number,
                            line.offset,
                            &mut block,
                            self.reading,
                            &mut scratch,
                        ) {
                            Ok(lenient) => {
                                if lenient && !self.warned_comment_utf8 {
                                    self.warned_comment_utf8 = true;
                                    queue.push_back(Event::Diagnostic(comment_not_utf8(
                                        line.bytes,
                                        line.number,
                                        line.offset,
                                    )));
                                }
                                Ok(())
                            }
                            Err(d) => Err(d),
                        },
                    },
                };
                // A printer (slicer) program's line whose command letter is none a
                // printer's firmware runs (see [`vendor_command`]): a warning naming it,
                // and an empty block, however its words would read as G-code.
                if let Some(len) = vendor {
                    // Named by its code (`W220`), once for each code.
                    let start = line.bytes.len() - line.bytes.trim_ascii_start().len();
                    let text = &line.bytes[start..len];
                    let code_len = text
                        .iter()
                        .position(|c| c.is_ascii_whitespace())
                        .unwrap_or(text.len());
                    let code = String::from_utf8_lossy(&text[..code_len]).into_owned();
                    if !self.warned_vendor.contains(&code) {
                        let shown = if code_len < text.len() {
                            format!("{code} …")
                        } else {
                            code.clone()
                        };
                        self.warned_vendor.push(code);
                        queue.push_back(Event::Diagnostic(Diagnostic::at(
                            Severity::Warning,
                            ErrorKind::VendorCommand(shown),
                            line.number,
                            line.offset,
                            line.bytes,
                            start,
                            start + code_len,
                        )));
                    }
                    block = Block::empty(line.number, line.offset);
                    parsed = Ok(());
                }
                if let Some(len) = park {
                    let start = line.bytes.len() - line.bytes.trim_ascii_start().len();
                    queue.push_back(Event::Diagnostic(Diagnostic::at(
                        Severity::Warning,
                        ErrorKind::FirmwareMacro(
                            String::from_utf8_lossy(&line.bytes[start..len]).into_owned(),
                        ),
                        line.number,
                        line.offset,
                        line.bytes,
                        start,
                        len,
                    )));
                    block = Block::empty(line.number, line.offset);
                    parsed = Ok(());
                }
                // A printer (slicer) program's line that is no G-code but a firmware's
                // extended command (`slicer`: E is extrusion, the program is a printer's):
                // a warning naming it, and an empty block.
                if parsed.is_err() && self.reading.slicer {
                    if let Some((kind, len)) = firmware_command(line.bytes) {
                        queue.push_back(Event::Diagnostic(Diagnostic::at(
                            Severity::Warning,
                            kind,
                            line.number,
                            line.offset,
                            line.bytes,
                            line.bytes.len() - line.bytes.trim_ascii_start().len(),
                            len,
                        )));
                        block = Block::empty(line.number, line.offset);
                        parsed = Ok(());
                    }
                }
                // Text after the program's end (M2, M30) that is no G-code (a CAM system's
                // note, `Post Process Timed at; 32 Min`): the control never reads it, so
                // one warning, and an empty block (the next `O` program, read in file
                // order, starts afresh).
                if parsed.is_err() && self.interp.ended() {
                    if !self.warned_text_after_end {
                        self.warned_text_after_end = true;
                        queue.push_back(Event::Diagnostic(Diagnostic::at(
                            Severity::Warning,
                            ErrorKind::TextAfterEnd,
                            line.number,
                            line.offset,
                            line.bytes,
                            0,
                            line.bytes.len(),
                        )));
                    }
                    block = Block::empty(line.number, line.offset);
                    parsed = Ok(());
                }
                // Macro lines only: the flavour's evaluation (plain lines never come here;
                // under Macro B also lines the parser refuses and G65 blocks).
                if let Some(params) = self.params.as_deref_mut() {
                    if params.is_macro_b() {
                        if block.kind != BlockKind::Words || parsed.is_err() || has_g65(&block) {
                            // The system variables read the state after the block before.
                            params.after_block(&self.interp);
                            parsed = evaluate_macro_b(
                                &line,
                                &mut block,
                                params,
                                parsed,
                                &mut control,
                                &mut call,
                            );
                        }
                    } else if block.kind != BlockKind::Words && parsed.is_ok() {
                        params.note_modal(&self.interp);
                        parsed = evaluate(&line, &mut block, params, &mut control);
                        machine_reads(params, line.number, line.offset, line.bytes, queue);
                    }
                }
                let offsets = self.interp.offset_changes();
                let failed = match parsed {
                    Ok(()) => match self.interp.block(&block, &mut |e| queue.push_back(e)) {
                        Ok(()) if expanded_past_cap(&mut self.expanded, moves_in(queue.iter())) => {
                            queue.push_back(Event::Diagnostic(Diagnostic::at(
                                Severity::Error,
                                ErrorKind::TooManyExpanded(MAX_EXPANDED),
                                line.number,
                                line.offset,
                                line.bytes,
                                0,
                                line.bytes.len(),
                            )));
                            true
                        }
                        Ok(()) => {
                            if let Some(params) = self.params.as_deref_mut() {
                                // The queue held nothing before this block: its events are
                                // exactly the block's.
                                after_moves(params, queue);
                                // A frame moved (G92, G10 L20, G52, G55…): the position in
                                // it (rs274 sets `#5420`… at once).
                                if ends_with_probe(queue) || self.interp.offset_changes() != offsets
                                {
                                    // A probe may leave the tool off its end (backed off,
                                    // `interp::probe_rest`): the position is the tool's.
                                    params.note_position(&self.interp.program_position());
                                }
                            }
                            false
                        }
                        Err(d) => {
                            queue.push_back(Event::Diagnostic(d));
                            true
                        }
                    },
                    Err(d) => {
                        queue.push_back(Event::Diagnostic(d));
                        true
                    }
                };
                drop(block);
                failed
            };
            let mut failed = failed;
            if let (Some((text, number, offset)), Some(params)) =
                (control, self.params.as_deref_mut())
            {
                let kind = if params.is_macro_b() {
                    params.after_block(&self.interp);
                    MacroKind::FanucMacroB
                } else {
                    params.note_modal(&self.interp);
                    MacroKind::LinuxCncOWord
                };
                let done = match call.take() {
                    Some((n, runs, args)) if !failed => self.src.macro_call(
                        (n, runs, args.as_deref()),
                        number,
                        offset,
                        &text,
                        params,
                    ),
                    Some(_) => Some(Ok(())),
                    None => self.src.control(&text, number, offset, params),
                };
                machine_reads(params, number, offset, text.as_bytes(), &mut self.queue);
                match done {
                    Some(Ok(())) => {}
                    Some(Err(d)) => {
                        failed = true;
                        self.queue.push_back(Event::Diagnostic(d));
                    }
                    None => {
                        let len = text.len();
                        self.queue.push_back(Event::Diagnostic(Diagnostic::at(
                            Severity::Warning,
                            ErrorKind::MacroNotEvaluated(kind.describe()),
                            number,
                            offset,
                            text.as_bytes(),
                            0,
                            len,
                        )));
                    }
                }
            }
            if self.interp.profile_pending() {
                failed |= self.profile_step();
            }
            if let Some(params) = self.params.as_deref_mut() {
                if params.is_macro_b() {
                    for _ in 0..self.src.take_returns() {
                        params.leave_macro();
                    }
                    for d in params.take_stops() {
                        self.queue.push_back(Event::Diagnostic(d));
                    }
                }
            }
            if let Some(m) = direct {
                match self.src.take_diagnostic() {
                    None => return Some(Ok(Event::Move(m))),
                    Some(d) => {
                        failed |= d.is_error();
                        self.queue.push_back(Event::Move(m));
                        self.queue.push_back(Event::Diagnostic(d));
                    }
                }
            }
            while let Some(d) = self.src.take_diagnostic() {
                failed |= d.is_error();
                self.queue.push_back(Event::Diagnostic(d));
            }
            if failed && self.stop_on_error {
                self.stopped = true;
            } else if failed && self.params.is_some() {
                self.src.note_error();
            }
        }
    }
}

impl<S: LineSource> Stream<S> {
    /// A LinuxCNC lathe profile cycle (G70–G72) after a line: the source calls the sub
    /// the cycle's block asks for; while the sub is read its profile's current point is
    /// the position its expressions see; when the sub has returned the cycle's moves go
    /// to the queue. True when the cycle is refused.
    #[inline(never)]
    fn profile_step(&mut self) -> bool {
        if let Some(label) = self.interp.take_profile_call() {
            let called = match self.params.as_deref_mut() {
                Some(params) => self.src.profile_call(&label, params),
                None => None,
            };
            let why = match called {
                Some(Ok(depth)) => {
                    self.profile_depth = depth;
                    None
                }
                Some(Err(why)) => Some(why),
                None => Some("its subroutine cannot be followed here".to_string()),
            };
            if let Some(why) = why {
                if let Some(d) = self.interp.cancel_profile(&why) {
                    self.queue.push_back(Event::Diagnostic(d));
                    return true;
                }
            }
        } else if self.interp.recording_profile() {
            if self.src.call_depth() > self.profile_depth {
                if let (Some(p), Some(params)) =
                    (self.interp.profile_position(), self.params.as_deref_mut())
                {
                    params.note_position(&p);
                }
                return false;
            }
            let start = self.queue.len();
            let queue = &mut self.queue;
            let done = self.interp.finish_profile(&mut |e| queue.push_back(e));
            if let Some(params) = self.params.as_deref_mut() {
                params.after_moves(self.queue.range(start..).filter_map(|e| match e {
                    Event::Move(m) => Some(m),
                    Event::Diagnostic(_) | Event::Stop(_) => None,
                }));
            }
            if let Err(d) = done {
                self.queue.push_back(Event::Diagnostic(d));
                return true;
            }
            if expanded_past_cap(&mut self.expanded, moves_in(self.queue.range(start..))) {
                // At the line of the cycle's last move (the profile's moves carry it).
                let line = self.queue.range(start..).rev().find_map(|e| match e {
                    Event::Move(m) => Some(m.line),
                    Event::Diagnostic(_) | Event::Stop(_) => None,
                });
                let mut d =
                    Diagnostic::whole(Severity::Error, ErrorKind::TooManyExpanded(MAX_EXPANDED));
                d.line = line.unwrap_or(0);
                self.queue.push_back(Event::Diagnostic(d));
                return true;
            }
        }
        false
    }
}

/// A macro line of a flavour that evaluates them: an expression line becomes a word
/// block, an O-word line is noted in `control` for the source to follow.
#[inline(never)]
fn evaluate<'a>(
    line: &Line<'a>,
    block: &mut Block<'a>,
    params: &mut Params,
    control: &mut Option<(String, u32, usize)>,
) -> Result<(), Diagnostic> {
    match block.kind {
        BlockKind::Macro(MacroKind::LinuxCncExpression) => {
            crate::expr::eval_line(line.bytes, line.number, line.offset, block, params)
        }
        BlockKind::Macro(MacroKind::LinuxCncOWord) => {
            *control = Some((block.raw.to_owned(), line.number, line.offset));
            block.kind = BlockKind::Words;
            Ok(())
        }
        _ => Ok(()),
    }
}

/// A block with a `G65` macro call.
fn has_g65(b: &Block<'_>) -> bool {
    b.words()
        .any(|w| w.letter == b'G' && w.register.is_none() && w.code() == Some(650))
}

/// A `G65` call (program, runs, locals), or an `M98` whose words came from variables
/// (no locals).
type MacroCall = (
    u32,
    u32,
    Option<Box<[Option<f64>; crate::expr::FANUC_LOCALS]>>,
);

/// A line of a Macro B flavour (see Macro B (`macrob.rs`)): words for the interpreter, a
/// statement noted in `control` for the source to follow, or a `G65` call noted in
/// `call` (with the line in `control`).
#[inline(never)]
fn evaluate_macro_b<'a>(
    line: &Line<'a>,
    block: &mut Block<'a>,
    params: &mut Params,
    parsed: Result<(), Diagnostic>,
    control: &mut Option<(String, u32, usize)>,
    call: &mut Option<MacroCall>,
) -> Result<(), Diagnostic> {
    let text = || String::from_utf8_lossy(line.bytes).into_owned();
    let was_macro = matches!(block.kind, BlockKind::Macro(_));
    match crate::macrob::eval_line(line.bytes, line.number, line.offset, block, params, parsed)? {
        crate::macrob::Outcome::Words => {
            // The reader follows an M98 as it reads the line; one whose P or L is a
            // variable is known only now.
            if was_macro {
                if let Some((number, repeats)) =
                    crate::macrob::sub_call(block, line.bytes, line.number, line.offset)?
                {
                    *control = Some((text(), line.number, line.offset));
                    *call = Some((number, repeats, None));
                }
            }
        }
        crate::macrob::Outcome::Control => *control = Some((text(), line.number, line.offset)),
        crate::macrob::Outcome::Call {
            number,
            repeats,
            args,
        } => {
            *control = Some((text(), line.number, line.offset));
            *call = Some((number, repeats, Some(args)));
        }
    }
    Ok(())
}

/// Whether a block's last move is a probe.
fn ends_with_probe(events: &VecDeque<Event>) -> bool {
    events
        .iter()
        .rev()
        .find_map(|e| match e {
            Event::Move(m) => Some(m.kind == MoveKind::Probe),
            Event::Diagnostic(_) | Event::Stop(_) => None,
        })
        .unwrap_or(false)
}

/// The system parameters after a block's moves (see [`Params::after_moves`]).
#[inline(never)]
fn after_moves(params: &mut Params, events: &VecDeque<Event>) {
    params.after_moves(events.iter().filter_map(|e| match e {
        Event::Move(m) => Some(m),
        Event::Diagnostic(_) | Event::Stop(_) => None,
    }));
}

/// Every diagnostic of a program (parse and interpretation), in order: every line of
/// every `O` program in the file, and calls to programs the file does not hold (see
/// [`ProgramReader`] in [`Order::File`]).
pub fn check(input: &[u8], opts: Options) -> Vec<Diagnostic> {
    let diags = |e: io::Result<Event>| match e {
        Ok(Event::Diagnostic(d)) => Some(d),
        _ => None,
    };
    let src = ProgramReader::new(io::Cursor::new(input), Order::File);
    Stream::new(src, opts, false).filter_map(diags).collect()
}

/// Klipper's extended commands that set something and move nothing: ignored in a
/// printer program (any other is a macro whose moves are not known).
const FIRMWARE_SETTINGS: &[&str] = &[
    "EXCLUDE_OBJECT_DEFINE",
    "EXCLUDE_OBJECT_END",
    "EXCLUDE_OBJECT_START",
    "RESPOND",
    "SET_EXTRUDER_ROTATION_DISTANCE",
    "SET_FAN_SPEED",
    "SET_GCODE_VARIABLE",
    "SET_HEATER_TEMPERATURE",
    "SET_IDLE_TIMEOUT",
    "SET_INPUT_SHAPER",
    "SET_LED",
    "SET_PIN",
    "SET_PRESSURE_ADVANCE",
    "SET_PRINT_STATS_INFO",
    "SET_RETRACTION",
    "SET_TEMPERATURE_FAN_TARGET",
    "SET_VELOCITY_LIMIT",
    "TEMPERATURE_WAIT",
];

/// A printer program's line whose command letter is none a printer's firmware runs:
/// Marlin, RepRapFirmware and Klipper take a line's command from its first letter, G, M
/// or T (after an N line number), and report any other as an unknown command. Vendors
/// put their own lines there (WEEDO's `W221`, and `W220 ffd8…`, the preview image in
/// hex). A line that starts with a letter other than G, M, T and N, and other than the
/// words X, Y, Z, E, F, S and P (lampost reads a bare axis line as the motion in force,
/// and a bare S or P as the value it sets, as laser programs write them), followed by a
/// number, or a line that starts with `#` (a script's `# 4mm square outline`: no
/// firmware reads parameters): the end of its text (before any `;` comment).
fn vendor_command(line: &[u8]) -> Option<usize> {
    let start = line.len() - line.trim_ascii_start().len();
    let letter = line.get(start)?.to_ascii_uppercase();
    let end = line.iter().position(|&c| c == b';').unwrap_or(line.len());
    if letter == b'#' {
        return Some(start + line[start..end].trim_ascii_end().len());
    }
    let number = line
        .get(start + 1)
        .is_some_and(|c| c.is_ascii_digit() || matches!(c, b'-' | b'+' | b'.'));
    if !letter.is_ascii_uppercase()
        || matches!(
            letter,
            b'G' | b'M' | b'T' | b'N' | b'X' | b'Y' | b'Z' | b'E' | b'F' | b'S' | b'P'
        )
        || !number
    {
        return None;
    }
    Some(start + line[start..end].trim_ascii_end().len())
}

/// Prusa's tool park in a printer program (`P0 S1 L2 D0`, PrusaSlicer's start code for
/// the XL: Prusa's firmware parks the tool in its dock, lifting by L): `P` and a digit
/// first on the line. No other firmware reads a P command. The end of its text (before
/// any `;` comment), at most 60 characters.
fn prusa_tool_park(line: &[u8]) -> Option<usize> {
    let start = line.len() - line.trim_ascii_start().len();
    let rest = &line[start..];
    if !(matches!(rest.first(), Some(b'P' | b'p')) && rest.get(1).is_some_and(u8::is_ascii_digit)) {
        return None;
    }
    let end = rest.iter().position(|&c| c == b';').unwrap_or(rest.len());
    Some(start + rest[..end].trim_ascii_end().len().min(SHOWN_CHARS))
}

/// The most characters of a firmware's command a message names (60).
const SHOWN_CHARS: usize = 60;

/// A firmware's extended command (Klipper: `START_PRINT BED=60`, `SET_PRESSURE_ADVANCE
/// ADVANCE=0.05`, `_ON_LAYER_CHANGE`): a first token of letters, digits and
/// underscores, at least three long, with an underscore or letters only (a word such as
/// `G1` or a typo such as `GOX1` is not one), then the end, a space or a `;` comment.
/// Its kind (a setting, or a macro that may move) and the end of the command's text in
/// the line (before any comment).
fn firmware_command(line: &[u8]) -> Option<(ErrorKind, usize)> {
    let start = line.len() - line.trim_ascii_start().len();
    let rest = &line[start..];
    let n = rest
        .iter()
        .position(|c| !(c.is_ascii_alphanumeric() || *c == b'_'))
        .unwrap_or(rest.len());
    let name = &rest[..n];
    let first_ok = name
        .first()
        .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_');
    let shape = name.contains(&b'_') || name.iter().all(u8::is_ascii_alphabetic);
    let ends = rest.get(n).is_none_or(|c| matches!(c, b' ' | b'\t' | b';'));
    if n < 3 || !first_ok || !shape || !ends {
        return None;
    }
    let name = String::from_utf8_lossy(name).to_ascii_uppercase();
    let end = rest
        .iter()
        .position(|&c| c == b';')
        .map_or(line.len(), |i| start + i);
    let text_end = start + line[start..end].trim_ascii_end().len();
    // Named as written, up to 60 characters (an `EXCLUDE_OBJECT_DEFINE` line with its
    // polygon runs to kilobytes).
    let text = String::from_utf8_lossy(&line[start..text_end]);
    let shown = match text.char_indices().nth(SHOWN_CHARS) {
        Some((cut, _)) => format!("{} …", text[..cut].trim_ascii_end()),
        None => text.into_owned(),
    };
    let kind = if FIRMWARE_SETTINGS.contains(&name.as_str()) {
        ErrorKind::FirmwareSetting(shown)
    } else {
        ErrorKind::FirmwareMacro(shown)
    };
    Some((kind, text_end))
}

/// A warning for each of the machine's parameters the line read before the program set
/// it ([`crate::expr::Params::take_machine_reads`]).
fn machine_reads(
    params: &mut Params,
    number: u32,
    offset: usize,
    bytes: &[u8],
    queue: &mut std::collections::VecDeque<Event>,
) {
    for n in params.take_machine_reads() {
        let what = crate::expr::machine_parameter(n).unwrap_or("a machine setting");
        queue.push_back(Event::Diagnostic(Diagnostic::at(
            Severity::Warning,
            ErrorKind::MachineParameter { number: n, what },
            number,
            offset,
            bytes,
            0,
            bytes.len(),
        )));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flavor::Flavor;
    use proptest::prelude::*;

    #[test]
    fn a_firmware_command_is_named_by_its_first_sixty_characters() {
        let poly = (0..400)
            .map(|k| format!("[{k}.5,{k}.25]"))
            .collect::<Vec<_>>();
        let long = format!(
            "EXCLUDE_OBJECT_DEFINE NAME=part POLYGON=[{}]",
            poly.join(",")
        );
        let Some((ErrorKind::FirmwareSetting(shown), end)) = firmware_command(long.as_bytes())
        else {
            panic!("a setting");
        };
        assert_eq!(end, long.len());
        assert!(
            shown.ends_with(" …") && shown.chars().count() <= SHOWN_CHARS + 2,
            "{shown}"
        );
        assert!(long.starts_with(shown.trim_end_matches(" …")));
        let Some((ErrorKind::FirmwareMacro(shown), _)) =
            firmware_command(b"PRINT_START BED=60 ; x")
        else {
            panic!("a macro");
        };
        assert_eq!(shown, "PRINT_START BED=60");
    }

    /// Every event of `text` read with the fast lane on or off.
    fn events(text: &str, flavor: Flavor, order: Option<Order>, fast_lane: bool) -> Vec<Event> {
        let opts = flavor.options(Options::default(), None);
        fn collect<S: LineSource>(mut s: Stream<S>, fast_lane: bool) -> Vec<Event> {
            s.fast_lane = fast_lane;
            s.map(|e| e.expect("in-memory input")).collect()
        }
        match order {
            None => collect(Stream::from_bytes(text.as_bytes(), opts, false), fast_lane),
            Some(order) => collect(
                Stream::new(
                    ProgramReader::new(io::Cursor::new(text.as_bytes()), order),
                    opts,
                    false,
                ),
                fast_lane,
            ),
        }
    }

    /// A word of a random line: the plain lane's words in every spelling, and the codes,
    /// words and forms around them that change how a plain line runs or send it the
    /// reference way.
    fn token() -> impl Strategy<Value = String> {
        let number = prop_oneof![
            6 => "[+-]?[0-9]{0,3}(\\.[0-9]{0,4})?",
            1 => "[0-9]{14,17}",
            1 => "-?[0-9]\\.[0-9]e[+-]?[0-9]",
            1 => Just("-0".to_string()),
        ];
        prop_oneof![
            8 => ("[XYZABCUVWxyzabc]", number.clone()).prop_map(|(l, n)| format!("{l}{n}")),
            3 => ("[FNfn]", number.clone()).prop_map(|(l, n)| format!("{l}{n}")),
            1 => ("[EIJKRSTHLPQD]", number.clone()).prop_map(|(l, n)| format!("{l}{n}")),
            // LinuxCNC's polar words (an unexpected character in other flavours).
            1 => ("[@^]", number).prop_map(|(l, n)| format!("{l}{n}")),
            4 => prop_oneof![
                Just("G0"), Just("G1"), Just("G00"), Just("G01"), Just("g1"), Just("G1.0"),
                Just("G-0"), Just("G0.1"), Just("G2"), Just("G3"), Just("G90"), Just("G91"),
                Just("G20"), Just("G21"), Just("G93"), Just("G94"), Just("G95"), Just("G80"),
                Just("G81"), Just("G53"), Just("G92"), Just("G54"), Just("G55"), Just("G5.2"),
                Just("G5.3"), Just("G38.2"), Just("G33"), Just("G28"), Just("G4"),
            ].prop_map(str::to_string),
            2 => prop_oneof![
                Just("M2"), Just("M30"), Just("M3"), Just("M5"), Just("M82"), Just("M83"),
                Just("M98"), Just("M99"), Just("O100"), Just("T1"), Just("M6"),
            ].prop_map(str::to_string),
            1 => prop_oneof![
                Just("(c)"), Just(";c"), Just("/"), Just("#1=2"), Just("[1]"), Just("%"),
                Just("X"), Just("\t"), Just("é"), Just("\r"), Just("*"), Just("X#1"),
            ].prop_map(str::to_string),
        ]
    }

    /// A random line, or a few lines that make arcs whose radii agree (random centre
    /// words almost never do), in any plane and distance mode.
    fn line() -> impl Strategy<Value = String> {
        let words = (
            proptest::collection::vec(token(), 0..6),
            proptest::collection::vec(prop_oneof![Just(""), Just(" "), Just("  ")], 6),
        )
            .prop_map(|(tokens, joins)| {
                let mut line = String::new();
                for (t, j) in tokens.iter().zip(&joins) {
                    line.push_str(t);
                    line.push_str(j);
                }
                line
            });
        let arc = (
            prop_oneof![Just(("G17", 'X', 'Y', 'I', 'J')), Just(("G18", 'Z', 'X', 'K', 'I')), Just(("G19", 'Y', 'Z', 'J', 'K'))],
            prop_oneof![Just("G2"), Just("G3"), Just("g02"), Just("")],
            -50i32..50,
            1i32..40,
            prop_oneof![Just(""), Just(" F120"), Just(" F0"), Just(" F-1")],
            prop_oneof![Just(""), Just("G91.1 "), Just("G90.1 ")],
        )
            .prop_map(|((plane, u, v, i, j), g, c, r, f, arc_distance)| {
                // From (c, 0) half way round to (c + 2r, 0) about (c + r, 0), and back.
                let (c, r) = (f64::from(c) / 4.0, f64::from(r) / 8.0);
                format!(
                    "{plane} {arc_distance}G0 {u}{c} {v}0\n{g} {u}{e} {v}0 {i}{r} {j}0{f}\n{u}{c} {v}0 {i}{m} {j}0",
                    e = c + 2.0 * r,
                    m = -r,
                )
            });
        prop_oneof![6 => words, 1 => arc]
    }

    fn program() -> impl Strategy<Value = String> {
        proptest::collection::vec(line(), 0..40).prop_map(|lines| lines.join("\n"))
    }

    fn flavor() -> impl Strategy<Value = Flavor> {
        prop_oneof![
            Just(Flavor::LinuxCnc),
            Just(Flavor::Fanuc),
            Just(Flavor::Haas),
            Just(Flavor::Fadal),
            Just(Flavor::Mach3),
            Just(Flavor::Marlin),
            Just(Flavor::RepRap),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(800))]
        /// The fast lane (`plain_motion`, parser and interpreter) gives exactly the
        /// events of the reference path, whatever comes before and around plain lines.
        #[test]
        fn the_fast_lane_agrees_with_the_reference_path(
            text in program(),
            flavor in flavor(),
            order in prop_oneof![Just(None), Just(Some(Order::File)), Just(Some(Order::Execution))],
        ) {
            let fast = events(&text, flavor, order, true);
            let reference = events(&text, flavor, order, false);
            prop_assert_eq!(fast, reference, "{:?}", text);
        }
    }

    /// Plain lines do take the fast lane, arcs with good radii among them, and lines
    /// it must not run go the reference way (a test that the comparison above compares
    /// something).
    #[test]
    fn plain_lines_take_the_fast_lane() {
        let plain = |text: &str| plain_motion(text.as_bytes()).expect(text);
        for text in [
            "G1 X1 F1",
            "n10 y4.5 z-1.",
            "X5",
            "G2 X0 Y0 I1 J1",
            "G03X1Y2I3K4",
        ] {
            plain(text);
        }
        for text in [
            "G1 X1 E2",
            "G1 X1 (c)",
            "G4 X1",
            "G1 X1 X2",
            "G1 X1 R2",
            "X1 S100",
            "G1 @1 ^30",
            "G0 ^90",
        ] {
            assert_eq!(plain_motion(text.as_bytes()), None, "{text}");
        }
        let mut interp = Interpreter::new(Options::default());
        let mut events = Vec::new();
        let mut block = Block::empty(1, 0);
        parse_str_with("G21 G90 G17 F100", 1, 0, &mut block, false).expect("parses");
        interp.block(&block, &mut |e| events.push(e)).expect("runs");
        let mut run = |text: &str| match interp.plain_motion(&plain(text), 2) {
            Some(m) => {
                events.push(Event::Move(m));
                true
            }
            None => false,
        };
        assert!(run("G0 X1 Y0"));
        assert!(run("G2 X-1 Y0 I-1 J0"));
        // The reference path's: a radius mismatch, a centre word on a straight move, a
        // centre word off the plane, an arc with no centre.
        assert!(!run("G2 X0 Y0 I5 J5"));
        assert!(!run("G1 X1 I1"));
        assert!(!run("G2 X1 Y0 I1 K1"));
        assert!(!run("G2 X3 Y0"));
        assert!(run("G1 X2"));
        assert_eq!(events.len(), 3);
    }
}
