//! The modal interpreter: blocks in, resolved absolute moves out.
//!
//! Positions are absolute *program* coordinates, in the program's units: the
//! coordinates of the work coordinate system in force (G54…, FADAL E…) at the time of
//! the move, as LinuxCNC's canonical interface reports them. Offsets the program sets
//! itself (G10 L2/L20, G92, G52) are tracked, so switching systems or shifting with G92
//! moves the reported coordinates exactly as on the machine; offsets held only in the
//! controller are unknown here and taken as zero (that matters only for G53 moves).
//! Tool length offsets are recorded, not applied: the trace is of the controlled point
//! the program names.

use serde::Serialize;

use crate::ast::{Block, BlockKind, CommentStyle, Item, Word};
use crate::diag::{Diagnostic, ErrorKind, Severity};
use crate::modal::*;
use crate::parse::PlainMotion;
use crate::polar::Polar;

/// What the E word means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EWord {
    /// FADAL fixture offset E0 … E48.
    FixtureOffset,
    /// An extruder position from a slicer (recorded with each move).
    Extrusion,
}

/// LinuxCNC's arc tolerances (rs274ngc, `interp_internal.hh` and `interp_arc.cc`), as
/// (inch, millimetre) values. The start and end radii of an I/J/K arc may differ by
/// [`ARC_SPIRAL_TOLERANCE`], or by up to 100 times that when the difference is at most
/// [`ARC_SPIRAL_RELATIVE`] of the larger radius (LinuxCNC then moves along a spiral to the
/// programmed end). A radius below [`ARC_RADIUS_TOLERANCE`] is zero, and an R arc may be
/// short of half its chord by as much.
pub const ARC_SPIRAL_TOLERANCE: (f64, f64) = (
    2.0 * 0.001 * std::f64::consts::SQRT_2,
    2.0 * 0.01 * std::f64::consts::SQRT_2,
);
/// See [`ARC_SPIRAL_TOLERANCE`]: 0.1 %.
pub const ARC_SPIRAL_RELATIVE: f64 = 0.001;
/// See [`ARC_SPIRAL_TOLERANCE`]: 0.00005 in, 0.00127 mm.
pub const ARC_RADIUS_TOLERANCE: (f64, f64) = (0.00005, 0.00005 * 25.4);

/// Interpreter settings.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Units before any G20/G21.
    pub units: Units,
    /// What E means.
    pub e_word: EWord,
    /// Skip blocks starting with `/`.
    pub block_delete: bool,
    /// The control the program was written for (resolved: see `flavor.rs`).
    pub flavor: crate::flavor::Flavor,
    /// Warn of what a post of the program changes, for the post: every dwell it leaves
    /// out ([`ErrorKind::DwellLeftOut`]: `G4`, a canned cycle's `P` at the bottom of a
    /// hole), every block-delete line it runs and writes without its `/`
    /// ([`ErrorKind::BlockDeletePosted`]), every M-code it does not act on
    /// ([`ErrorKind::MCodeLeftOut`]: a firmware's or control's setting, a code of the
    /// machine's own).
    pub post_notes: bool,
    /// Report the program's stops (`M0`, `M1`, `M60`) as [`Event::Stop`], after the
    /// block's motion, for a reader that carries them on (the post, and `verify` reading
    /// what it wrote). Off, they move nothing and say nothing.
    pub stops: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            units: Units::Mm,
            e_word: EWord::FixtureOffset,
            block_delete: false,
            flavor: crate::flavor::Flavor::Fadal,
            post_notes: false,
            stops: false,
        }
    }
}

/// How the interpreter treats subprogram calls (`M98 P… L…`); the line source decides
/// (see [`crate::program::ProgramReader`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Calls {
    /// Calls are not followed: the interpreter warns and goes on after the call (a plain
    /// line source).
    #[default]
    NotFollowed,
    /// The file is read in file order, each program in turn; the source checks that each
    /// called program is there. An `O` line after M2/M30 starts the next program.
    Checked,
    /// The source hands over the called program's lines after the call (execution
    /// order).
    Followed,
}

/// The kind of a resolved move.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "type")]
pub enum MoveKind {
    /// G0
    Rapid,
    /// G1 (and canned-cycle feeds, G33)
    Linear,
    /// A probing move (FADAL G31, LinuxCNC G38.x): straight, stops on touch.
    Probe,
    /// G2/G3
    Arc {
        /// G2.
        clockwise: bool,
        /// The centre, absolute (the normal axis holds the start's value).
        center: [f64; 3],
        /// Plane.
        plane: Plane,
        /// Number of turns (1 for an ordinary arc; a full circle is 1).
        turns: u32,
    },
}

/// Why a move exists.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Origin {
    /// Written in the block.
    Block,
    /// Expanded from a canned cycle.
    CannedCycle,
    /// The intermediate or home move of G28/G30.
    Home,
    /// A G53 move, in machine coordinates.
    MachineCoords,
}

/// One resolved move.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Move {
    /// Straight, arc or probe.
    pub kind: MoveKind,
    /// Where it starts.
    pub start: Position,
    /// Where it ends.
    pub end: Position,
    /// Feed (units/min, or 1/min in inverse time); 0 for rapids.
    pub feed: f64,
    /// Extruder E at the end (slicer programs), when E means extrusion: the extruder's
    /// position as the program counts it (G92 E sets it; under M83 each E adds to it).
    pub extrusion: Option<f64>,
    /// How much E grew along this move (negative: a retract), when E means extrusion:
    /// the E word itself under M83 (or G91), its difference from the last E under M82;
    /// 0 for a move with no E word, and for the second and later moves of one block.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extruded: Option<f64>,
    /// Modal state in force.
    pub modal: Modal,
    /// Source line.
    pub line: u32,
    /// Why the move exists.
    pub origin: Origin,
    /// Axes the program has named so far (bit `i` for `AXES[i]`).
    pub axes_named: u16,
    /// Axes named in the move's own block (bit `i` for `AXES[i]`).
    #[serde(skip)]
    pub block_axes: u16,
}

/// What the interpreter reports.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A move.
    Move(Move),
    /// A warning or error.
    Diagnostic(Diagnostic),
    /// A program stop, where [`Options::stops`] asks for them.
    Stop(Stop),
}

/// A program stop: the control halts until the operator starts it again.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Stop {
    /// Which stop.
    pub kind: StopKind,
    /// Source line.
    pub line: u32,
}

/// The stops a program can make.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum StopKind {
    /// `M0`, and `M1` on a printer (Marlin and RepRapFirmware stop on both).
    Program,
    /// `M1` on a machine control: the operator's optional-stop switch decides.
    Optional,
    /// `M60`: a pallet change and a stop (LinuxCNC, Fanuc).
    Pallet,
}

impl StopKind {
    /// The code as a program writes it.
    pub fn code(self) -> &'static str {
        match self {
            StopKind::Program => "M0",
            StopKind::Optional => "M1",
            StopKind::Pallet => "M60",
        }
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct CannedParams {
    z: Option<f64>,
    r: Option<f64>,
    q: Option<f64>,
    p: f64,
    /// The Z the tool was at when this series of cycles began (rs274's `cycle_il`, the
    /// "initial level", Fanuc's initial point; machine frame), kept until a motion other
    /// than a cycle: G91's R counts from it, and G98 retracts to it.
    initial_z: Option<f64>,
}

/// The interpreter. Feed it blocks in order with [`Interpreter::block`].
#[derive(Debug, Clone)]
pub struct Interpreter {
    /// Whether the program has given its units (G20/G21, FADAL G70/G71).
    units_given: bool,
    opts: Options,
    modal: Modal,
    pos: Position,
    g5x: [Position; 10],
    fixture: [Position; 49],
    g92: Position,
    g52: Position,
    home28: Position,
    home30: Position,
    canned: CannedParams,
    extrusion: f64,
    /// The E change of the block being run, not yet given to a move.
    pending_e: f64,
    /// M83 in force (relative extrusion).
    e_relative: bool,
    ended: bool,
    /// The program ended at its closing `%` (not at M2/M30): named in the warning.
    ended_at_percent: bool,
    /// A `%` line with text after it was read past and said so (once).
    warned_percent_text: bool,
    warned_after_end: bool,
    /// A line that starts the program has been read (`linuxcnc`: any line that is not
    /// blank, as rs274 takes its first; others: a line with words or a macro statement).
    /// Until then a `%` line opens the program; after it, one ends the program.
    started: bool,
    /// The program opened with a `%` line (rs274's percent mode: the next bare `%` line
    /// ends the file).
    percent_framed: bool,
    /// A printer's program (E as extrusion, not MakerBot's A/B extruder) whose A, B or C
    /// word has not been warned of yet: the fast lane stands aside for such a line.
    watch_printer_axes: bool,
    calls: Calls,
    /// `O` programs started and not yet closed by an M99 (calls nest: in execution
    /// order the called program's `O` line comes inside the caller).
    open_programs: u32,
    axes_named: u16,
    /// Axes named in the block being run.
    block_axes: u16,
    warned_macro: bool,
    /// A length word with no decimal point has been warned about under a Fanuc or Haas
    /// flavour ([`Interpreter::integer_word`]): once a program.
    warned_integer: bool,
    /// A zero centre word off the active plane (`K0` in G17) has been warned about: once
    /// a program, as a post writes one on every arc.
    warned_normal_centre: bool,
    /// G90 under M83 has been warned about (see [`ErrorKind::EModeAfterG90`]).
    warned_e_mode: bool,
    /// The warning of a G90 under M83, held until an E word is read by it: an M82 or
    /// M83 before then says what E is, and drops it.
    e_mode_doubt: Option<Diagnostic>,
    /// The thread motion in force is LinuxCNC's rigid tap `G33.1` (it returns to its start).
    rigid_tap: bool,
    /// The group-01 motion (G0–G3) in force when a canned cycle began: under Fanuc, Haas
    /// and FADAL (their cycles are group 09, apart from motion) G80 returns to it (see
    /// [`crate::flavor::Flavor::cycles_apart_from_motion`]).
    motion_before_cycle: Motion,
    /// Inside a LinuxCNC `G5.2` … `G5.3` NURBS block (control points, not moves).
    nurbs: bool,
    /// A skipped macro block set the feed rate from a value lampost does not know: later
    /// feed moves are not blamed for a missing F.
    feed_from_macro: bool,
    /// An F word has been read (`F0` included): a feed move at feed rate zero is then
    /// refused as such, not as a missing F.
    feed_given: bool,
    offset_cache: Position,
    /// Every offset is zero (the common case): positions need no shifting.
    offset_zero: bool,
    /// A LinuxCNC lathe profile cycle (G70–G72) reading its subroutine's profile
    /// (`lathe.rs`): the sub's blocks make the profile and move nothing.
    profile: Option<Box<crate::lathe::Recording>>,
    /// The O-word sub a profile cycle asks the line source to call (taken by the stream).
    profile_call: Option<String>,
    /// LinuxCNC's G41.1/G42.1 in force with its diameter D: the side, the radius (D/2)
    /// and the lathe tool's orientation (L; 0 when none), for the moves lampost
    /// compensates (`comp.rs`: a G70's).
    comp_tool: Option<(crate::comp::Side, f64, u8)>,
    /// A compensated G70's rapid to its start, made (compensated) with its moves.
    comp_entry: Option<Position>,
    /// Cutter compensation being simulated (`comp.rs`): its state and held moves.
    comp: Option<Box<crate::comp::Comp<CompTag>>>,
    /// Under simulated compensation, where the tool was last drawn; the position
    /// ([`Interpreter::position`]) stays on the programmed path, as rs274 reads the next
    /// block from it.
    comp_drawn: Position,
    /// The signs of a lathe program seen so far (`turning.rs`).
    lathe: crate::turning::LatheSigns,
    /// The line of the last block that changed the offsets ([`Interpreter::offset_line`]).
    offset_line: u32,
    /// How many blocks changed them ([`Interpreter::offset_changes`]).
    offset_changes: u64,
    /// After `G40`: where the compensated tool was left, the start of the next move
    /// (the position is the programmed point, from which its words are read).
    comp_exit: Option<Position>,
}

/// What a compensated move keeps of its block: line, end (for the axes off the plane),
/// feed and origin.
#[derive(Debug, Clone, Copy)]
struct CompTag {
    line: u32,
    to: Position,
    feed: f64,
    origin: Origin,
}

/// Words of one block, looked up by letter.
struct Words<'b, 'a> {
    by_letter: [Option<&'b Word<'a>>; 26],
    registers: [Option<&'b Word<'a>>; 10],
    gs: smallvec::SmallVec<[(&'b Word<'a>, u16, GGroup); 4]>,
    /// Per group, 1 + the index in `gs` of its code (0: none); a line of 64 KiB holds
    /// fewer than 65,535 G words.
    by_group: [u16; GROUPS],
    ms: smallvec::SmallVec<[(&'b Word<'a>, u16); 4]>,
    /// Axes named by bare letters (`G28 X`), bit `i` for `AXES[i]`.
    bare: u16,
    /// Axes with a word (`by_letter`), bit `i` for `AXES[i]`.
    axes: u16,
    /// The first verbatim text of the block, if any.
    first_text: Option<&'b crate::ast::Text<'a>>,
    /// A verbatim text that is not bare axis letters.
    odd_text: bool,
    /// LinuxCNC's polar words: `@` (radius) and `^` (angle).
    radius: Option<&'b Word<'a>>,
    angle: Option<&'b Word<'a>>,
}

impl<'b, 'a> Words<'b, 'a> {
    fn get(&self, letter: u8) -> Option<f64> {
        self.by_letter[usize::from(letter - b'A')].map(|w| w.value)
    }
    fn word(&self, letter: u8) -> Option<&'b Word<'a>> {
        self.by_letter[usize::from(letter - b'A')]
    }
    fn has_g(&self, code: u16) -> bool {
        self.gs.iter().any(|g| g.1 == code)
    }
    fn g_in(&self, group: GGroup) -> Option<(&'b Word<'a>, u16)> {
        match self.by_group[group as usize] {
            0 => None,
            i => self.gs.get(usize::from(i - 1)).map(|g| (g.0, g.1)),
        }
    }
    fn has_axes(&self) -> bool {
        self.axes != 0
    }
    /// The block's polar point, when it has `@` or `^`.
    fn polar(&self) -> Option<Polar> {
        (self.radius.is_some() || self.angle.is_some()).then(|| Polar {
            radius: self.radius.map(|w| w.value),
            angle: self.angle.map(|w| w.value),
        })
    }
    /// Where the block's first polar word stands (for its errors).
    fn polar_span(&self) -> Option<crate::ast::Span> {
        match (self.radius, self.angle) {
            (Some(r), Some(a)) => Some(if r.span.start < a.span.start {
                r.span
            } else {
                a.span
            }),
            (r, a) => r.or(a).map(|w| w.span),
        }
    }
}

/// The C axis's bit (see [`AXIS_BITS`]).
const C_AXIS: u16 = AXIS_BITS[(b'C' - b'A') as usize];

/// Bit `i` for the letter `AXES[i]`, by letter (`A` first); 0 for the other letters.
const AXIS_BITS: [u16; 26] = {
    let mut bits = [0u16; 26];
    let mut i = 0;
    while i < AXES.len() {
        bits[(AXES[i] - b'A') as usize] = 1 << i;
        i += 1;
    }
    bits
};

type Res<T> = Result<T, Diagnostic>;

/// The most canned-cycle repeats (L) or arc turns (P) one block may ask for.
const MAX_REPEATS: u32 = 10_000;

/// The most pecks (feeds of Q) of a G73/G83 block, all repeats together: a block's
/// moves are held until the next line is read, so their number must stay bounded.
pub const MAX_PECKS: u32 = 10_000;

/// Number of [`GGroup`] variants.
const GROUPS: usize = 19;

/// The runs of a Haas `M97 P… L…` call (L, default 1; the reader refuses a bad L).
#[cold]
#[inline(never)]
fn m97_runs(w: &Words<'_, '_>) -> u32 {
    match w.get(b'L') {
        Some(l) if l >= 0.0 && l.fract() == 0.0 => l.min(10_000.0) as u32,
        _ => 1,
    }
}

/// A word that reads differently as least input increments and as whole units (see
/// [`Interpreter::integer_word`]): a length, angle or centre word (F too on a Haas)
/// written as a plain whole number other than zero, no point, no exponent, no
/// expression.
fn integer_dimension(w: &Word<'_>, with_feed: bool) -> bool {
    dimension_letter(w.letter, with_feed)
        && w.register.is_none()
        && whole_number_text(w.text.as_bytes())
}

/// A length, angle, centre or radius letter (F too with `with_feed`): see
/// [`Interpreter::integer_word`]. Not Q, which is a code as often as a length (G268's
/// order, G76's chamfer angle).
fn dimension_letter(l: u8, with_feed: bool) -> bool {
    matches!(
        l,
        b'X' | b'Y'
            | b'Z'
            | b'A'
            | b'B'
            | b'C'
            | b'U'
            | b'V'
            | b'W'
            | b'I'
            | b'J'
            | b'K'
            | b'R'
            | b'Q'
    ) || (with_feed && l == b'F')
}

/// A number written as a whole number other than zero: an optional sign, then digits
/// only, one of them not 0 (blanks between them skipped, as the parser skips them).
fn whole_number_text(text: &[u8]) -> bool {
    let mut chars = text.iter().filter(|c| !c.is_ascii_whitespace()).peekable();
    chars.next_if(|c| matches!(c, b'+' | b'-'));
    let (mut digits, mut nonzero) = (false, false);
    for &c in chars {
        if !c.is_ascii_digit() {
            return false;
        }
        digits = true;
        nonzero |= c != b'0';
    }
    digits && nonzero
}

/// Whether a fast-lane line (letters, plain numbers and blanks: see
/// [`crate::parse`]'s `plain_motion`) holds a word [`Interpreter::integer_word`] would
/// warn of; the stream then sends it down the reference path, which warns.
pub(crate) fn has_integer_word(bytes: &[u8], with_feed: bool) -> bool {
    let mut i = 0;
    while i < bytes.len() {
        let letter = bytes[i].to_ascii_uppercase();
        i += 1;
        if !letter.is_ascii_uppercase() {
            continue;
        }
        let start = i;
        while i < bytes.len() && !bytes[i].is_ascii_alphabetic() {
            i += 1;
        }
        if dimension_letter(letter, with_feed) && whole_number_text(&bytes[start..i]) {
            return true;
        }
    }
    false
}

/// A position a block's words reach that is beyond any number (an incremental move added
/// to one near the largest `f64`, `G91 G0 Z1.7e308` twice in a slicer's reading, which
/// takes exponents): refused at the block's first axis word.
fn beyond_any_number(b: &Block<'_>, w: &Words<'_, '_>, p: &Position) -> Res<()> {
    if p.iter().all(|v| v.is_finite()) {
        return Ok(());
    }
    let word = AXES.iter().find_map(|&l| w.word(l));
    Err(diag(
        b,
        Severity::Error,
        ErrorKind::BadValue {
            word: word.map_or_else(String::new, |w| w.display()),
            why: "the position it reaches is beyond any number",
        },
        word.map(|w| w.span),
    ))
}

/// Under `linuxcnc`, the words a block's codes need and rs274 refuses the block
/// without: an axis letter with no number (`G28 X`: "No characters found in reading
/// real value"), G10 with no L, G52 with no axis word (G92's is said where it is
/// read), G5 or G5.1 with none
/// ("All axes missing"), G96 with no S. (`settings`: the block's words are a setting
/// code's own, bare letters among them.)
fn linuxcnc_code_words(b: &Block<'_>, w: &Words<'_, '_>, settings: bool) -> Res<()> {
    if w.bare != 0 && !settings {
        if let Some(t) = w.first_text {
            let letter = t.text.chars().next().unwrap_or('?').to_ascii_uppercase();
            return Err(diag(
                b,
                Severity::Error,
                ErrorKind::LetterWithoutNumber(letter),
                Some(t.span),
            ));
        }
    }
    for &(gw, code, _) in &w.gs {
        let why = match code {
            100 if w.word(b'L').is_none() => {
                "G10 with no L (LinuxCNC's G10 is L1, L10, L11, L2 or L20; rs274 refuses it)"
            }
            520 if !w.has_axes() => {
                "G52 needs at least one axis word (rs274 refuses it: \"All axes missing with g52 or g92\")"
            }
            50 | 51 if !w.has_axes() => {
                "no axis word (rs274 refuses a spline with none: \"All axes missing with motion code\")"
            }
            960 if w.word(b'S').is_none() => {
                "G96 with no S (the surface speed; rs274 refuses it)"
            }
            _ => continue,
        };
        return Err(diag(
            b,
            Severity::Error,
            ErrorKind::BadValue {
                word: gw.display_code(),
                why,
            },
            Some(gw.span),
        ));
    }
    Ok(())
}

fn diag(
    b: &Block<'_>,
    sev: Severity,
    kind: ErrorKind,
    span: Option<crate::ast::Span>,
) -> Diagnostic {
    let (s, e) = match span {
        Some(sp) => (sp.start - b.span.start, sp.end - b.span.start),
        None => (0, b.raw.len()),
    };
    Diagnostic::at(sev, kind, b.line, b.span.start, b.raw.as_bytes(), s, e)
}

impl Interpreter {
    /// A fresh interpreter.
    pub fn new(opts: Options) -> Self {
        Interpreter {
            opts,
            units_given: false,
            modal: Modal {
                // LinuxCNC starts in G99 (canned cycles retract to R), others in G98.
                retract: if opts.flavor == crate::flavor::Flavor::LinuxCnc {
                    crate::modal::Retract::RPlane
                } else {
                    crate::modal::Retract::InitialZ
                },
                ..Modal::new(opts.units)
            },
            pos: [0.0; 9],
            g5x: [[0.0; 9]; 10],
            fixture: [[0.0; 9]; 49],
            g92: [0.0; 9],
            g52: [0.0; 9],
            home28: [0.0; 9],
            home30: [0.0; 9],
            canned: CannedParams::default(),
            extrusion: 0.0,
            pending_e: 0.0,
            e_relative: false,
            ended: false,
            ended_at_percent: false,
            warned_percent_text: false,
            warned_after_end: false,
            started: false,
            percent_framed: false,
            watch_printer_axes: opts.e_word == EWord::Extrusion
                && !opts.flavor.extruder_is_a_or_b(),
            calls: Calls::NotFollowed,
            open_programs: 0,
            axes_named: 0,
            block_axes: 0,
            warned_macro: false,
            warned_integer: false,
            warned_normal_centre: false,
            warned_e_mode: false,
            e_mode_doubt: None,
            rigid_tap: false,
            motion_before_cycle: Motion::None,
            nurbs: false,
            feed_from_macro: false,
            feed_given: false,
            profile: None,
            profile_call: None,
            comp_tool: None,
            comp_entry: None,
            comp: None,
            comp_drawn: [0.0; 9],
            lathe: crate::turning::LatheSigns::default(),
            offset_line: 0,
            offset_changes: 0,
            comp_exit: None,
            offset_cache: [0.0; 9],
            offset_zero: true,
        }
    }

    /// Whether the program has said its units (a G20/G21 or G70/G71 read so far); when
    /// not, its numbers are in [`Options::units`], an assumption worth a word.
    pub fn units_given(&self) -> bool {
        self.units_given
    }

    /// The modal state now.
    pub fn modal(&self) -> &Modal {
        &self.modal
    }

    /// The position now.
    pub fn position(&self) -> &Position {
        &self.pos
    }

    /// The position now in the work system in force (program coordinates, as moves
    /// report them); [`Interpreter::position`] is in the machine frame as traced.
    pub fn program_position(&self) -> Position {
        self.to_program(self.pos)
    }

    /// True after M2/M30 (or an M99 outside any `O` program).
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// How subprogram calls are treated (the line source knows; [`crate::Stream`] sets
    /// it from [`crate::LineSource::calls`]).
    pub fn set_calls(&mut self, calls: Calls) {
        self.calls = calls;
    }

    fn offset(&self) -> Position {
        self.offset_cache
    }

    /// Recompute the cached effective offset after any offset or work system change.
    fn refresh_offset(&mut self) {
        self.offset_cache = self.compute_offset();
        self.offset_zero = self.offset_cache.iter().all(|&v| v == 0.0);
    }

    fn compute_offset(&self) -> Position {
        let base = match self.modal.work_offset {
            WorkOffset::G5x(i) => self.g5x[usize::from(i)],
            WorkOffset::Fixture(i) => self.fixture[usize::from(i)],
            // Set on the control only: program coordinates.
            WorkOffset::Extended(_) => [0.0; 9],
        };
        let mut o = [0.0; 9];
        for a in 0..9 {
            o[a] = base[a] + self.g92[a] + self.g52[a];
        }
        o
    }

    /// Interpret one block, sending moves and warnings to `out`. An error is returned
    /// (and nothing of the block's motion is sent) when the block cannot be
    /// interpreted; the state may then be partly updated, so callers that need the
    /// motion stop there.
    pub fn block(&mut self, b: &Block<'_>, out: &mut impl FnMut(Event)) -> Res<()> {
        let before = (self.offset_cache, self.modal.work_offset);
        let done = self.block_inner(b, out);
        if (self.offset_cache, self.modal.work_offset) != before {
            self.offset_line = b.line;
            self.offset_changes += 1;
        }
        done
    }

    /// How many blocks have changed the offsets so far (see [`Interpreter::offset_line`]).
    pub fn offset_changes(&self) -> u64 {
        self.offset_changes
    }

    /// The line of the last block that changed the offsets from program to machine
    /// coordinates (`G92`, `G52`, a `G10` of the work offset in force, another work
    /// offset selected); 0 before any.
    pub fn offset_line(&self) -> u32 {
        self.offset_line
    }

    fn block_inner(&mut self, b: &Block<'_>, out: &mut impl FnMut(Event)) -> Res<()> {
        if b.block_delete && self.opts.block_delete {
            return Ok(());
        }
        if self.opts.flavor == crate::flavor::Flavor::LinuxCnc {
            // `(ABORT, message)`: rs274 stops the program there, with the message.
            if let Some(c) = b.items.iter().find_map(|it| match it {
                Item::Comment(c) if c.style == CommentStyle::Paren => {
                    let t = c.text.trim_start();
                    t.get(..6)
                        .filter(|k| k.eq_ignore_ascii_case("abort,"))
                        .map(|_| (t[6..].trim(), c.span))
                }
                _ => None,
            }) {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::Abort(c.0.to_string()),
                    Some(c.1),
                ));
            }
        }
        if b.block_delete && self.opts.post_notes && b.has_words() {
            self.warn(b, out, ErrorKind::BlockDeletePosted, None);
        }
        if self.profile.is_some() {
            return self.record_profile(b);
        }
        if b.kind == BlockKind::Percent {
            return self.percent_line(b, out);
        }
        if !self.started
            && (b.has_words()
                || matches!(b.kind, BlockKind::Macro(_))
                || self.opts.flavor == crate::flavor::Flavor::LinuxCnc && !b.items.is_empty())
        {
            self.started = true;
        }
        match b.kind {
            BlockKind::Percent => return Ok(()),
            BlockKind::Macro(k) => {
                // Statement lines (`#…`) are reported once; lines whose motion or flow
                // depends on macro values each time.
                let statement = b.raw.trim_start().starts_with('#');
                self.feed_from_macro |= crate::expr::sets_feed(b.raw);
                if !(self.ended || statement && self.warned_macro) {
                    self.warned_macro |= statement;
                    out(Event::Diagnostic(diag(
                        b,
                        Severity::Warning,
                        ErrorKind::MacroNotEvaluated(k.describe()),
                        None,
                    )));
                }
                return Ok(());
            }
            BlockKind::Words => {}
        }
        if !b.has_words() {
            if !self.ended {
                self.console_line(b, out);
            }
            return Ok(());
        }
        if self.ended && self.calls == Calls::Checked && crate::program::program_number(b).is_some()
        {
            // Read in file order, the next program of the file starts here.
            self.ended = false;
            self.ended_at_percent = false;
            self.warned_after_end = false;
        }
        if self.ended {
            if !self.warned_after_end {
                self.warned_after_end = true;
                let after = if self.ended_at_percent {
                    "a block after the program's closing `%` (the end of the tape: the control reads no further)"
                } else {
                    "a block after M2/M30"
                };
                out(Event::Diagnostic(diag(
                    b,
                    Severity::Warning,
                    ErrorKind::NotSimulated(after.into()),
                    None,
                )));
            }
            return Ok(());
        }
        let mut w = Words {
            by_letter: [None; 26],
            registers: [None; 10],
            gs: smallvec::SmallVec::new(),
            by_group: [0; GROUPS],
            ms: smallvec::SmallVec::new(),
            bare: 0,
            axes: 0,
            first_text: None,
            odd_text: false,
            radius: None,
            angle: None,
        };
        self.collect(b, &mut w)?;
        if self.opts.post_notes {
            // FADAL's M17 ends a subroutine, where the source follows them.
            let fadal_return = self.opts.flavor == crate::flavor::Flavor::Fadal
                && self.calls != Calls::NotFollowed;
            for &(mw, c) in &w.ms {
                if !(m_known(c) || c == 170 && fadal_return) {
                    self.warn(
                        b,
                        out,
                        ErrorKind::MCodeLeftOut(mw.display_code()),
                        Some(mw.span),
                    );
                }
            }
        }
        if !self.lathe.recognised() {
            self.lathe_signs(b, &w, out);
        }
        // A block of an M-code lampost does not act on (a firmware or control setting:
        // `M201 X4000 Y4000`, `M205 X1 Y1 Z1 E1`) and no G-code: its words are its own.
        let levelling = self.bed_levelling(b, &w, out);
        let settings = w.gs.is_empty() && w.ms.iter().any(|&(_, c)| !m_known(c))
            || w.gs
                .iter()
                .any(|g| g.2 == GGroup::Other && self.own_words(&w, g.1))
            || Self::transform_words(&w)
            || levelling;
        let lathe_cycle = self.lathe_units_cycle(&w);
        let settings = settings || lathe_cycle.is_some();
        if let Some(gw) = lathe_cycle {
            self.warn(
                b,
                out,
                ErrorKind::NotSimulated(format!(
                    "{} with P, Q, U, W, D or R (a Fanuc or Haas lathe's finishing or roughing cycle over the profile blocks P to Q; its words are its own, not units and moves)",
                    gw.display_code()
                )),
                Some(gw.span),
            );
        }
        if !settings && !self.warned_integer {
            self.integer_word(b, &w, out);
        }
        if w.polar().is_some() {
            self.polar_allowed(b, &w, settings)?;
        }
        if let Some(t) = w.first_text {
            // Marlin's G61 (return to a saved position) takes axis flags as homing does.
            let slicer = self.opts.flavor.is_slicer();
            let homing =
                w.gs.iter()
                    .any(|g| matches!(g.1, 280 | 300 | 1610 | 1620) || slicer && g.1 == 610);
            // Verbatim text stands only where a code may carry it (the parser reads it
            // after a setting M-code, a T word or a homing code); a bare letter is an axis
            // only for homing.
            let misplaced = if homing {
                w.odd_text
            } else {
                w.bare != 0 || !w.gs.is_empty()
            };
            if !settings && misplaced {
                let letter = t.text.chars().next().unwrap_or('?').to_ascii_uppercase();
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::LetterWithoutNumber(letter),
                    Some(t.span),
                ));
            }
        }
        if self.opts.flavor == crate::flavor::Flavor::LinuxCnc {
            linuxcnc_code_words(b, &w, settings)?;
        }
        self.block_axes = 0;
        if !settings {
            self.block_axes = w.axes | w.bare;
        }
        self.axes_named |= self.block_axes;
        if w.g_in(GGroup::Motion).is_some() {
            // A motion code ends a NURBS block left open (LinuxCNC wants G5.3).
            self.nurbs = false;
        }
        if self.nurbs && w.gs.is_empty() && w.has_axes() {
            // A NURBS control point: the curve is not traced; its last point is its end.
            self.pos = self.target(&w, false);
            return Ok(());
        }
        if self.other_codes(b, &w, out) {
            return Ok(());
        }
        match self.profile_cycle(&w) {
            None => self.execute(b, &w, settings, out),
            Some(cycle) => {
                self.execute(b, &w, settings, out)?;
                self.start_profile(b, &w, cycle, out)
            }
        }
    }

    /// Whether the lines still need looking at for [`Interpreter::integer_word`] (a
    /// Fanuc or Haas flavour, not warned yet), and whether F counts (Haas).
    pub(crate) fn watching_integers(&self) -> Option<bool> {
        match self.opts.flavor {
            _ if self.warned_integer => None,
            crate::flavor::Flavor::Fanuc => Some(false),
            crate::flavor::Flavor::Haas => Some(true),
            _ => None,
        }
    }

    /// Under a Fanuc or Haas flavour, warn (once a program) of a length, angle or
    /// centre word written without a decimal point (`X10`): those controls read it in
    /// least input increments by default (Fanuc: parameter 3401#0 DPI = 0; Haas: setting
    /// 162 "Default to Float" off, and for F setting 77 "Scale Integer F" off), so `X10`
    /// is 0.010 mm or 0.0010 in there, where lampost (like LinuxCNC, grbl and Mach3)
    /// reads whole units. CAM posts for these controls write every such number with its
    /// point (`X10.`), so a word without one is a hand edit or a program meant for
    /// another control: which reading is meant cannot be told, and a factor of 1,000 or
    /// 10,000 rides on it. Zero reads the same either way; macro calls (G65, G66) pass
    /// arguments, and G4's X is a time. The post refuses the program (`intended.rs`).
    fn integer_word(&mut self, b: &Block<'_>, w: &Words<'_, '_>, out: &mut impl FnMut(Event)) {
        let (control, setting, haas) = match self.opts.flavor {
            crate::flavor::Flavor::Fanuc => (
                "a Fanuc control",
                "parameter 3401#0 DPI = 0, its default",
                false,
            ),
            crate::flavor::Flavor::Haas => (
                "a Haas control",
                "setting 162 Default to Float off, its default",
                true,
            ),
            _ => return,
        };
        if w.gs.iter().any(|g| matches!(g.1, 40 | 650 | 660 | 661)) {
            return;
        }
        let Some(word) = b.words().find(|wd| integer_dimension(wd, haas)) else {
            return;
        };
        self.warned_integer = true;
        let mm = self.modal.units == Units::Mm;
        let letter = word.letter;
        let (step, unit) = match letter {
            b'A' | b'B' | b'C' => (0.001, "°"),
            b'F' if mm => (0.001, " mm/min"),
            b'F' => (0.0001, " in/min"),
            _ if mm => (0.001, " mm"),
            _ => (0.0001, " in"),
        };
        let places = if step < 0.001 { 4 } else { 3 };
        let (setting, increments) = if letter == b'F' {
            (
                "setting 77 Scale Integer F off, its default",
                format!("{:.*}{unit}", places, word.value * step),
            )
        } else {
            (setting, format!("{:.*}{unit}", places, word.value * step))
        };
        out(Event::Diagnostic(diag(
            b,
            Severity::Warning,
            ErrorKind::IntegerWord {
                word: word.display(),
                control,
                setting,
                increments,
                units: format!("{}{unit}", word.value),
            },
            Some(word.span),
        )));
    }

    /// The fast lane's interpreter (see [`crate::stream`]): a plain move
    /// ([`PlainMotion`]) run as [`Interpreter::block`] runs it, when the state lets it
    /// run the common way (a program not ended, no NURBS block open, G0 to G3 in force
    /// or named, feed per minute with a feed rate for a feed move, F not negative), it
    /// has an axis word, centre words only on an arc and in its plane, and an arc passes
    /// the checks of its radius. Then its move is returned; otherwise nothing changes
    /// and `None` sends the line to the reference path, which also gives any error or
    /// warning. The two agree (property-tested in
    /// `stream.rs`, and compared by the fuzz's `gcode` target).
    // Not inlined, like `parse::plain_motion` (see there).
    #[inline(never)]
    pub(crate) fn plain_motion(&mut self, p: &PlainMotion, line: u32) -> Option<Move> {
        if self.profile.is_some() || self.comp.is_some() || self.comp_exit.is_some() {
            // Compensated moves are held (`comp.rs`), and the one after starts where
            // the tool was drawn: the reference path makes them.
            return None;
        }
        if self.lathe.recognised() && p.axes() & C_AXIS != 0 {
            // A lathe's C may be a chamfer (`corner_words`).
            return None;
        }
        let motion = match p.motion {
            Some(0) => Motion::Rapid,
            Some(10) => Motion::Linear,
            Some(20) => Motion::ArcCw,
            Some(_) => Motion::ArcCcw,
            None => self.modal.motion,
        };
        let modal_feed = p.feed().unwrap_or(self.modal.feed);
        // The program's first line (a `%` after it ends the program) and a printer's A, B,
        // C, U or V word not yet warned of take the reference path.
        if !self.started || self.watch_printer_axes && p.axes() & 0b1111_1000 != 0 {
            return None;
        }
        let runs_plainly = !self.ended
            && !self.nurbs
            && p.axes() != 0
            && self.modal.feed_mode != FeedMode::InverseTime
            && p.feed().is_none_or(|f| f >= 0.0)
            && match motion {
                Motion::Rapid => p.centres() == 0,
                Motion::Linear => p.centres() == 0 && (modal_feed > 0.0 || self.feed_from_macro),
                Motion::ArcCw | Motion::ArcCcw => modal_feed > 0.0 || self.feed_from_macro,
                _ => false,
            };
        if !runs_plainly {
            return None;
        }
        let axes = p.axes();
        let target = self.target_of(|a| (axes & (1 << a) != 0).then_some(p.axis(a)), false);
        if !target.iter().all(|v| v.is_finite()) {
            // The reference path refuses it (`beyond_any_number`).
            return None;
        }
        let (kind, feed) = match motion {
            Motion::Rapid => (MoveKind::Rapid, 0.0),
            Motion::Linear => (MoveKind::Linear, modal_feed),
            _ => {
                let plane = self.modal.plane;
                let (u, v, n) = plane.axes();
                // Centre words in the plane only, one at least.
                let centres = p.centres();
                if centres & (1 << n) != 0 || centres & (1 << u | 1 << v) == 0 {
                    return None;
                }
                let Ok((cu, cv)) =
                    self.centre_of(p.centre(u), p.centre(v), &target, self.modal.arc_distance)
                else {
                    return None;
                };
                let mut center = [self.pos[0], self.pos[1], self.pos[2]];
                center[u] = cu;
                center[v] = cv;
                let arc = MoveKind::Arc {
                    clockwise: motion == Motion::ArcCw,
                    center,
                    plane,
                    turns: 1,
                };
                (arc, modal_feed)
            }
        };
        // As `block` and `execute` run it: the block's axes, E unchanged, F, the motion
        // mode (a named one ends any canned cycle's parameters), then the move.
        self.block_axes = axes;
        self.axes_named |= axes;
        self.pending_e = 0.0;
        self.modal.feed = modal_feed;
        self.feed_given |= p.feed().is_some();
        if p.motion.is_some() {
            self.modal.motion = motion;
            self.canned = CannedParams::default();
        }
        Some(self.make_move(line, kind, target, feed, Origin::Block))
    }

    /// A line that is no G-code block: a grbl console command (`$H`, `$$`, `$32=1`, `?`).
    /// Homing (`$H`) and jogging (`$J=…`) move the machine: a warning says so, and the
    /// post refuses them; settings and queries change no path.
    /// A `%` line. Before the program starts it opens the tape (rs274's percent mode when
    /// it is the first line, bare); after, it ends the program as M2/M30 do: Fanuc, Haas
    /// and FADAL controls read no further than the closing `%` (end of record), and rs274
    /// ends the file at a bare `%` line in percent mode and refuses any other `%` line
    /// ("Bad character '%' used"), as `linuxcnc` does. Slicer flavours skip the line as a
    /// printer's firmware does (an unknown command).
    #[inline(never)]
    fn percent_line(&mut self, b: &Block<'_>, out: &mut impl FnMut(Event)) -> Res<()> {
        use crate::flavor::Flavor;
        let f = self.opts.flavor;
        if f.is_slicer() {
            return Ok(());
        }
        let bare = b.raw.trim_matches([' ', '\t', '\r']) == "%";
        if !self.started {
            self.started = true;
            if f != Flavor::LinuxCnc || bare {
                self.percent_framed = true;
                return Ok(());
            }
        } else if self.ended {
            return Ok(());
        } else if f != Flavor::LinuxCnc && !bare {
            // `% vfd enable`: a line a post wrote for its own firmware (Fusion's MPCNC
            // post), not the end-of-record mark, which stands alone. Read past, once said:
            // ending the program here would drop everything after it without a move.
            if !self.warned_percent_text {
                self.warned_percent_text = true;
                out(Event::Diagnostic(diag(
                    b,
                    Severity::Warning,
                    ErrorKind::NotSimulated(
                        "a `%` line with text after it, read past as a comment (a Fanuc, Haas or FADAL control stops reading at any `%`: a program for one must end at its closing `%`)".into(),
                    ),
                    None,
                )));
            }
            return Ok(());
        } else if f != Flavor::LinuxCnc || bare && self.percent_framed {
            if let Some(c) = self.comp.take() {
                self.comp_release(*c, out)
                    .map_err(|e| comp_diag(b, e, None))?;
            }
            self.ended = true;
            self.ended_at_percent = true;
            self.open_programs = 0;
            return Ok(());
        }
        let at = b.raw.find('%').unwrap_or(0);
        Err(diag(
            b,
            Severity::Error,
            ErrorKind::UnexpectedCharacter('%'),
            Some(crate::ast::Span::new(
                b.span.start + at,
                b.span.start + at + 1,
            )),
        ))
    }

    fn console_line(&self, b: &Block<'_>, out: &mut impl FnMut(Event)) {
        let Some(Item::Text(t)) = b.items.first() else {
            return;
        };
        let upper = t.text.to_ascii_uppercase();
        let what = if upper.starts_with("$H") {
            "grbl homing cycle"
        } else if upper.starts_with("$J") {
            "grbl jog"
        } else {
            return;
        };
        let name = t.text.split(['=', ' ']).next().unwrap_or(t.text);
        self.warn(
            b,
            out,
            ErrorKind::NotSimulated(format!("{name} ({what})")),
            Some(t.span),
        );
    }

    /// Under `linuxcnc`, what rs274 refuses of a block's motion code (`c`, ten times the
    /// number) with the words and codes beside it: a G10, G28, G30, G52 or G92 in the
    /// block (both would use the axis words: `G0 G28 G91 Z0.`, which Fanuc reads); a Q
    /// that no code of the block reads (`G84 … Q3.`, a Fanuc post's), or a P (`G81 … P0.5`);
    /// G82, G86, G88 or G89 begun without its dwell P.
    fn linuxcnc_motion_words(
        &self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        gw: &Word<'_>,
        c: u16,
    ) -> Res<()> {
        let refuse = |word: String, why: &'static str, span| {
            Err(diag(
                b,
                Severity::Error,
                ErrorKind::BadValue { word, why },
                Some(span),
            ))
        };
        if c == 800 {
            return Ok(());
        }
        if let Some(&(g0, _, _)) =
            w.gs.iter()
                .find(|g| matches!(g.1, 100 | 280 | 300 | 520 | 920))
        {
            return refuse(
                format!("{} {}", gw.display_code(), g0.display_code()),
                "two G-codes in one block that both use the axis words (rs274 refuses it); write the motion and the other code on blocks of their own",
                g0.span,
            );
        }
        // The canned cycles: every motion code but these (see `motion_of_code`).
        let cycle = !matches!(c, 0 | 10 | 20 | 30 | 330 | 331 | 382..=385 | 800);
        if let Some(q) = w.word(b'Q') {
            let q_read = matches!(c, 730 | 830 | 760)
                || w.gs.iter().any(|g| matches!(g.1, 50 | 100 | 640))
                || w.ms
                    .iter()
                    .any(|&(_, m)| matches!(m, 190 | 660 | 670 | 680));
            if cycle && !q_read {
                return refuse(
                    q.display(),
                    "no code of the block reads Q (rs274 refuses it: LinuxCNC's cycles take a peck depth Q only in G73 and G83)",
                    q.span,
                );
            }
        }
        if let Some(p) = w.word(b'P') {
            // rs274: "P word with no G2 G3 G4 G10 G64 G5 G5.2 G76 G82 G86 G88 G89 to use
            // it" (M-codes that read P are left to it).
            let p_read = matches!(c, 740 | 760 | 820 | 840 | 860 | 880 | 890)
                || w.gs.iter().any(|g| matches!(g.1, 40 | 100 | 640))
                || !w.ms.is_empty();
            if cycle && !p_read {
                return refuse(
                    p.display(),
                    "no code of the block reads P (rs274 refuses it: of LinuxCNC's cycles only G74, G76, G82, G84, G86, G88 and G89 read a P)",
                    p.span,
                );
            }
        }
        if matches!(c, 820 | 860 | 880 | 890)
            && self.modal.motion != Motion::Canned(c)
            && w.word(b'P').is_none()
        {
            return refuse(
                gw.display_code(),
                "dwell time P missing (LinuxCNC's G82, G86, G88 and G89 take their dwell in P when they begin; rs274 refuses it)",
                gw.span,
            );
        }
        Ok(())
    }

    /// In a firmware (slicer) program `G29` is the printer's bed levelling probe
    /// (`G29`, `G29 A X92 Y92 I15 J15`), and `G80` Prusa firmware's mesh bed levelling
    /// (PrusaSlicer's MK2/MK3 start code: `G80`, `G80 X109.7 Y89.7 W30.5 H30.5`, the area
    /// probed; slicers write no canned cycles to cancel): a warning names it, and its
    /// words are its own.
    fn bed_levelling(&self, b: &Block<'_>, w: &Words<'_, '_>, out: &mut impl FnMut(Event)) -> bool {
        if self.opts.e_word != EWord::Extrusion {
            return false;
        }
        let Some(&(gw, c, _)) = w.gs.iter().find(|g| matches!(g.1, 290 | 800)) else {
            return false;
        };
        let what = if c == 800 {
            "Prusa firmware's mesh bed levelling: the head probes the bed"
        } else {
            "the printer's bed levelling probe"
        };
        self.warn(
            b,
            out,
            ErrorKind::NotSimulated(format!("{} ({what})", gw.display_code())),
            Some(gw.span),
        );
        true
    }

    /// A G70 or G71 read as inch/mm (every flavour but `haas`, which reads them as its
    /// own cycles, and `linuxcnc`, where they are unknown) whose block carries P, Q, U,
    /// W, D or R: units codes take no words, so this is a Fanuc or Haas lathe's
    /// finishing or roughing cycle (`G71 P10 Q20 U0.01 W0.005 D0.05 F0.01`), which used
    /// to switch the program to millimetres and move U and W as two more axes, silently.
    /// Its code word, when it is one.
    fn lathe_units_cycle<'w>(&self, w: &'w Words<'_, '_>) -> Option<&'w Word<'w>> {
        if matches!(
            self.opts.flavor,
            crate::flavor::Flavor::Haas | crate::flavor::Flavor::LinuxCnc
        ) {
            return None;
        }
        let (gw, c) = w.g_in(GGroup::Units)?;
        (matches!(c, 700 | 710)
            && [b'P', b'Q', b'U', b'W', b'D', b'R']
                .iter()
                .any(|&l| w.word(l).is_some()))
        .then_some(gw)
    }

    /// G4's words. Fanuc, Haas and FADAL give the dwell time as X (U on a lathe) in
    /// seconds, or P in milliseconds: `G04 X1.5` dwells, it moves nothing (it used to be
    /// traced as a move of the motion in force to X1.5), and no other axis may share the
    /// block. With P, the time is P and the axis words are a move (`G04 P.001 G0 X1.0`).
    /// LinuxCNC takes the time in P only and refuses G4 without it, as rs274 does.
    /// True when the block's axis words were the dwell's.
    fn dwell_words(&self, b: &Block<'_>, w: &Words<'_, '_>, gw: &Word<'_>) -> Res<bool> {
        let refuse = |why: &'static str| {
            Err(diag(
                b,
                Severity::Error,
                ErrorKind::BadValue {
                    word: gw.display_code(),
                    why,
                },
                Some(gw.span),
            ))
        };
        if self.opts.flavor == crate::flavor::Flavor::LinuxCnc {
            return if w.word(b'P').is_none() {
                refuse("dwell time missing: LinuxCNC's G4 takes the seconds in P (rs274 refuses it too)")
            } else {
                Ok(false)
            };
        }
        // With P the time is P, and the block's axis words are a move, as rs274 reads
        // `G04 P.001 G0 X1.0` (LinuxCNC's own sample programs write it).
        if w.word(b'P').is_some() || (w.get(b'X').is_none() && w.get(b'U').is_none()) {
            return Ok(false);
        }
        if AXES
            .iter()
            .any(|&l| l != b'X' && l != b'U' && w.get(l).is_some())
        {
            return refuse(
                "G4's X (or U) is the dwell time in seconds; a move cannot share its block",
            );
        }
        Ok(true)
    }

    /// True when the block's words belong to a code of [`GGroup::Other`] (its arguments,
    /// never positions): settings, macro calls, pocket cycles, firmware codes.
    fn own_words(&self, w: &Words<'_, '_>, code: u16) -> bool {
        match other_code(code) {
            None | Some(OtherCode::Unsimulated(_)) => true,
            // A setting's arguments are its own (`G187 P1 E.002`), but a move in its
            // block is a move (`G103 P1 G1 X1 F100`).
            // LinuxCNC's G8 (lathe radius mode) has none: a feed beside it is the
            // program's (`G18 G21 G90 G8 F100`).
            Some(OtherCode::Setting)
                if code == 80 && self.opts.flavor == crate::flavor::Flavor::LinuxCnc =>
            {
                false
            }
            Some(OtherCode::Setting) => w.g_in(GGroup::Motion).is_none() && !w.has_axes(),
            // Fanuc `G05 P10000` and `G05.1 Q1` are settings; LinuxCNC's splines have
            // axis or I/J words.
            Some(OtherCode::Spline) => !Self::is_spline(w),
            Some(_) => false,
        }
    }

    /// True when the block's axis words are the arguments of a coordinate transform
    /// (Fanuc, Haas, FADAL): the centre of a rotation `G68 X Y R`, of a scaling `G51 X Y
    /// Z P` (or I J K), the mirror axes of `G51.1 X Y` and `G50.1 X` (cancel for those
    /// axes), never a move. A block that also holds a motion code is read as before.
    fn transform_words(w: &Words<'_, '_>) -> bool {
        w.g_in(GGroup::Motion).is_none()
            && [GGroup::Rotation, GGroup::Scaling, GGroup::Mirror]
                .into_iter()
                .any(|g| w.g_in(g).is_some())
    }

    fn is_spline(w: &Words<'_, '_>) -> bool {
        w.has_axes() || w.word(b'I').is_some() || w.word(b'J').is_some()
    }

    /// Warnings for the codes of [`GGroup::Other`]; true when the block is done (a
    /// spline or NURBS code: its end point is taken, no move is traced).
    fn other_codes(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        out: &mut impl FnMut(Event),
    ) -> bool {
        let mut done = false;
        for &(gw, c, g) in &w.gs {
            if c == 600 && self.opts.flavor.is_slicer() {
                // Marlin's G60 saves the position for a G61: it moves nothing.
                continue;
            }
            if c == 610 && self.opts.flavor.is_slicer() {
                // Marlin's G61 returns to the position G60 saved (its axis letters are
                // flags): a move to a place the trace does not hold.
                done = true;
                self.warn(
                    b,
                    out,
                    ErrorKind::NotSimulated(format!(
                        "{} (a printer's return to the position G60 saved: it moves the head)",
                        gw.display_code()
                    )),
                    Some(gw.span),
                );
                continue;
            }
            if g != GGroup::Other {
                continue;
            }
            let name = gw.display_code();
            let with_p = || match w.word(b'P') {
                Some(p) => format!("{name} {}", p.display()),
                None => name.clone(),
            };
            if self.profile_cycle(w).is_some_and(|(_, pc)| pc == c) {
                continue;
            }
            let kind = match other_code(c) {
                Some(_) if c == 120 && self.opts.flavor.is_slicer() => ErrorKind::NotSimulated(
                    format!("{name} (the printer's nozzle cleaning: it moves the nozzle)"),
                ),
                _ if self.opts.flavor == crate::flavor::Flavor::Haas
                    && crate::modal::haas_pattern(c).is_some() =>
                {
                    ErrorKind::NotSimulated(format!(
                        "{name} ({})",
                        crate::modal::haas_pattern(c).unwrap_or_default()
                    ))
                }
                None => ErrorKind::NotSimulated(format!(
                    "{name} (a firmware code lampost does not know)"
                )),
                Some(OtherCode::Setting) => continue,
                Some(OtherCode::Unsimulated(_)) if c == 650 => {
                    ErrorKind::SubprogramNotFollowed(format!("{} (macro call)", with_p()))
                }
                Some(OtherCode::Unsimulated(what)) => {
                    ErrorKind::NotSimulated(format!("{name} ({what})"))
                }
                Some(OtherCode::ExtendedOffset) => {
                    // Selected as G55 is (its values live on the control); a P that
                    // names none is warned of, the work system left as it was.
                    let p = w.word(b'P').map(|p| p.value);
                    let linuxcnc = self.opts.flavor == crate::flavor::Flavor::LinuxCnc;
                    match crate::modal::extended_offset(c, p) {
                        Some(n) if !linuxcnc => {
                            self.modal.work_offset = WorkOffset::Extended(n);
                            self.refresh_offset();
                            continue;
                        }
                        _ => ErrorKind::NotSimulated(format!(
                            "{} ({}; the trace stays in the active work system)",
                            with_p(),
                            if linuxcnc {
                                "LinuxCNC has no extended work offsets"
                            } else {
                                "no extended work offset: G54.1 takes P1 to P300, G154 P1 to P99"
                            }
                        )),
                    }
                }
                Some(OtherCode::DiameterMode) => ErrorKind::NotSimulated(format!(
                    "{name} (lathe diameter mode; X is traced as a radius)"
                )),
                Some(OtherCode::Spline) if !Self::is_spline(w) => continue,
                Some(OtherCode::Spline) | Some(OtherCode::Nurbs(true)) => {
                    self.nurbs = c == 52;
                    if let Some(f) = w.word(b'F').filter(|f| f.value >= 0.0) {
                        self.modal.feed = f.value;
                    }
                    self.pos = self.target(w, false);
                    done = true;
                    ErrorKind::NotSimulated(format!(
                        "{name} (spline; the trace takes its end point and draws no move)"
                    ))
                }
                Some(OtherCode::Nurbs(false)) => {
                    self.nurbs = false;
                    done = true;
                    continue;
                }
            };
            self.warn(b, out, kind, Some(gw.span));
        }
        done
    }

    fn collect<'b, 'a>(&self, b: &'b Block<'a>, w: &mut Words<'b, 'a>) -> Res<()> {
        for item in &b.items {
            let word = match item {
                Item::Word(word) => word,
                Item::Comment(_) => continue,
                // LinuxCNC spindle select (`M3 $0 S1000`): one spindle is traced.
                Item::Text(t) if t.text.starts_with('$') => continue,
                Item::Text(t) => {
                    let axes = t.bare_axes();
                    w.bare |= axes;
                    w.odd_text |= axes == 0;
                    if w.first_text.is_none() || axes == 0 {
                        w.first_text = Some(t);
                    }
                    continue;
                }
            };
            match word.letter {
                b'G' => {
                    let code = word.code().ok_or_else(|| {
                        diag(
                            b,
                            Severity::Error,
                            ErrorKind::BadCodeNumber(word.display()),
                            Some(word.span),
                        )
                    })?;
                    if self.opts.flavor == crate::flavor::Flavor::LinuxCnc
                        && !crate::modal::linuxcnc_knows(code)
                    {
                        // Another control's code (it has a group), or no control's.
                        let kind = if g_group(code).is_some() {
                            ErrorKind::NotLinuxCncCode(code_text(code))
                        } else {
                            ErrorKind::UnknownGCode(code_text(code))
                        };
                        return Err(diag(b, Severity::Error, kind, Some(word.span)));
                    }
                    let group = match g_group(code) {
                        // LinuxCNC's lathe roughing and finishing cycles (elsewhere
                        // G70/G71 are units).
                        _ if self.opts.flavor == crate::flavor::Flavor::LinuxCnc
                            && crate::modal::is_lathe_cycle(code) =>
                        {
                            GGroup::Other
                        }
                        // Haas's bolt hole patterns on a mill, its finishing and
                        // roughing cycles on a lathe (never units: Haas uses G20/G21).
                        _ if self.opts.flavor == crate::flavor::Flavor::Haas
                            && (crate::modal::haas_pattern(code).is_some()
                                || crate::modal::haas_work_offset(code)) =>
                        {
                            GGroup::Other
                        }
                        // A Fanuc or Haas lathe's grooving cycle, in a program
                        // recognised as a lathe's (on a mill G75 is no code).
                        None if code == 750
                            && self.lathe.recognised()
                            && self.opts.flavor != crate::flavor::Flavor::LinuxCnc =>
                        {
                            GGroup::Other
                        }
                        Some(g) => g,
                        // In a firmware (slicer) program an unknown G-code is the
                        // firmware's own (Bambu `G380`, `G392`): named in a warning.
                        None if self.opts.e_word == EWord::Extrusion => GGroup::Other,
                        None => {
                            return Err(diag(
                                b,
                                Severity::Error,
                                ErrorKind::UnknownGCode(code_text(code)),
                                Some(word.span),
                            ))
                        }
                    };
                    for &(other, oc, og) in &w.gs {
                        let conflict = og == group
                            && match group {
                                // G80 may share a block with the motion that follows it.
                                GGroup::Motion => oc != 800 && code != 800,
                                GGroup::Modifier => oc == code,
                                GGroup::Other => false,
                                _ => true,
                            };
                        if conflict {
                            return Err(diag(
                                b,
                                Severity::Error,
                                ErrorKind::ModalGroupConflict {
                                    group: group.name(),
                                    first: other.display_code(),
                                    second: word.display_code(),
                                },
                                Some(word.span),
                            ));
                        }
                    }
                    w.gs.push((word, code, group));
                    let slot = &mut w.by_group[group as usize];
                    if *slot == 0 || (group == GGroup::Motion && code != 800) {
                        *slot = u16::try_from(w.gs.len()).unwrap_or(u16::MAX);
                    }
                }
                b'M' => {
                    let code = Word::m_code_of(word.value).ok_or_else(|| {
                        diag(
                            b,
                            Severity::Error,
                            ErrorKind::BadCodeNumber(word.display()),
                            Some(word.span),
                        )
                    })?;
                    if let Some(g) = m_group(code) {
                        if let Some(&(other, _)) =
                            w.ms.iter().find(|(_, oc)| m_group(*oc) == Some(g))
                        {
                            return Err(diag(
                                b,
                                Severity::Error,
                                ErrorKind::ModalGroupConflict {
                                    group: g,
                                    first: other.display_code(),
                                    second: word.display_code(),
                                },
                                Some(word.span),
                            ));
                        }
                    }
                    w.ms.push((word, code));
                }
                b'@' | b'^' => {
                    // LinuxCNC's polar words: only its reading gives them (see
                    // `parse::Reading`); anywhere else the character stays unexpected.
                    if self.opts.flavor != crate::flavor::Flavor::LinuxCnc {
                        let at = word.span.start;
                        return Err(diag(
                            b,
                            Severity::Error,
                            ErrorKind::UnexpectedCharacter(word.letter_char()),
                            Some(crate::ast::Span::new(at, at + 1)),
                        ));
                    }
                    let slot = if word.letter == b'@' {
                        &mut w.radius
                    } else {
                        &mut w.angle
                    };
                    *slot = Some(word);
                    // They give the point's X and Y.
                    w.axes |=
                        AXIS_BITS[usize::from(b'X' - b'A')] | AXIS_BITS[usize::from(b'Y' - b'A')];
                }
                l => match word.register {
                    Some(r) => w.registers[usize::from(r)] = Some(word),
                    None => {
                        // MakerBot: the A or B word is the extruder, read as E.
                        let extruder = self.opts.flavor.extruder_is_a_or_b()
                            && matches!(l, b'A' | b'B' | b'E');
                        let l = if extruder { b'E' } else { l };
                        let i = usize::from(l - b'A');
                        if extruder {
                            if let Some(first) = w.by_letter[i] {
                                return Err(diag(
                                    b,
                                    Severity::Error,
                                    ErrorKind::DuplicateWord(format!(
                                        "the extruder ({} and {}: MakerBot's A, B and E all drive it; lampost follows one head)",
                                        first.display(),
                                        word.display()
                                    )),
                                    Some(word.span),
                                ));
                            }
                        }
                        w.by_letter[i] = Some(word);
                        w.axes |= AXIS_BITS[i];
                    }
                },
            }
        }
        Ok(())
    }

    /// LinuxCNC's polar words (`@`, `^`) stand only where rs274 reads them (its
    /// `enhance_block` and `find_ends`): in G17 (the plane before the block), without X
    /// or Y, on motion (not with G53, nor with G10, G28, G30, G52 or G92). Where lampost
    /// would have to guess (a setting code's block, splines and NURBS, cycles it does not
    /// trace, G76, a canned cycle outside G17) they are refused too.
    #[cold]
    fn polar_allowed(&self, b: &Block<'_>, w: &Words<'_, '_>, settings: bool) -> Res<()> {
        let refuse = |why: &'static str, span: Option<crate::ast::Span>| {
            Err(diag(
                b,
                Severity::Error,
                ErrorKind::Polar(why),
                span.or(w.polar_span()),
            ))
        };
        if self.modal.plane != Plane::XY {
            return refuse(
                "LinuxCNC reads them in the XY plane only (G17 in force before the block)",
                None,
            );
        }
        if let Some(xy) = w.word(b'X').or(w.word(b'Y')) {
            return refuse(
                "they give the point's X and Y, so a block with them cannot have X or Y",
                Some(xy.span),
            );
        }
        if settings {
            return refuse(
                "in the block of a setting code, whose words are its own: give the move a block of its own",
                None,
            );
        }
        for &(gw, c, g) in &w.gs {
            let why = match (g, c) {
                (_, 530) => "not with G53 (machine coordinates)",
                (GGroup::NonModal, 100 | 280 | 290 | 300 | 520 | 920 | 1610 | 1620) => {
                    "they are read on motion only: G10, G28, G30, G52 and G92 do not take them"
                }
                (GGroup::Motion, 760) => "not with G76 (threading reads no polar point)",
                (GGroup::Other, _)
                    if !matches!(
                        other_code(c),
                        Some(
                            OtherCode::Setting
                                | OtherCode::DiameterMode
                                | OtherCode::ExtendedOffset
                        )
                    ) =>
                {
                    "not with splines, NURBS or a cycle lampost does not trace"
                }
                _ => continue,
            };
            return refuse(why, Some(gw.span));
        }
        if self.nurbs && w.gs.is_empty() {
            return refuse("not as NURBS control points", None);
        }
        let canned = match w.g_in(GGroup::Motion) {
            Some((_, c)) => matches!(c, 730 | 740) || crate::modal::is_drill_cycle(c),
            None => matches!(self.modal.motion, Motion::Canned(_)),
        };
        let plane_after = w
            .g_in(GGroup::Plane)
            .map_or(self.modal.plane == Plane::XY, |(_, c)| c == 170);
        if canned && !plane_after {
            return refuse("a canned cycle takes them in G17 only", None);
        }
        if matches!(self.modal.motion, Motion::Canned(760)) && w.g_in(GGroup::Motion).is_none() {
            return refuse("not with G76 (threading reads no polar point)", None);
        }
        Ok(())
    }

    fn warn(
        &self,
        b: &Block<'_>,
        out: &mut impl FnMut(Event),
        kind: ErrorKind,
        span: Option<crate::ast::Span>,
    ) {
        out(Event::Diagnostic(diag(b, Severity::Warning, kind, span)));
    }

    /// Change units, scaling every length held; `false` (nothing changed) when a length
    /// would not fit in the new units (1e308 inches is beyond the largest `f64` in mm).
    fn set_units(&mut self, units: Units) -> bool {
        self.units_given = true;
        if units == self.modal.units {
            return true;
        }
        let f = self.modal.units.mm() / units.mm();
        let fits = |p: &Position| {
            p.iter()
                .enumerate()
                .all(|(a, v)| is_rotary(a) || (v * f).is_finite())
        };
        let canned = [
            self.canned.z,
            self.canned.r,
            self.canned.q,
            self.canned.initial_z,
        ];
        if !(fits(&self.pos)
            && self.g5x.iter().chain(self.fixture.iter()).all(fits)
            && [self.g92, self.g52, self.home28, self.home30]
                .iter()
                .all(fits)
            && canned.into_iter().flatten().all(|v| (v * f).is_finite()))
        {
            return false;
        }
        let scale = |p: &mut Position| {
            for (a, v) in p.iter_mut().enumerate() {
                if !is_rotary(a) {
                    *v *= f;
                }
            }
        };
        scale(&mut self.pos);
        for p in self.g5x.iter_mut().chain(self.fixture.iter_mut()) {
            scale(p);
        }
        scale(&mut self.g92);
        scale(&mut self.g52);
        scale(&mut self.home28);
        scale(&mut self.home30);
        for v in [
            &mut self.canned.z,
            &mut self.canned.r,
            &mut self.canned.q,
            &mut self.canned.initial_z,
        ]
        .into_iter()
        .flatten()
        {
            *v *= f;
        }
        self.modal.units = units;
        true
    }

    fn execute(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        settings: bool,
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        self.pending_e = 0.0;
        if settings {
            // The words are the setting codes' own, but the block's other G-codes still
            // set their modes (`G18 G8`: the plane; `G90 G67`: absolute distances).
            if let Some((_, c)) = w.g_in(GGroup::FeedMode) {
                self.modal.feed_mode = match c {
                    930 => FeedMode::InverseTime,
                    950 => FeedMode::PerRevolution,
                    _ => FeedMode::PerMinute,
                };
            }
            self.modal_groups(b, w, out)?;
            let haas_lathe_cycle = self.opts.flavor == crate::flavor::Flavor::Haas
                && w.gs.iter().any(|g| matches!(g.1, 700 | 710 | 720))
                && w.word(b'P').is_some()
                && w.word(b'Q').is_some();
            if self.lathe_units_cycle(w).is_some() || haas_lathe_cycle {
                // The cycle's F is the feed from here on (Fanuc, Haas: F is modal).
                if let Some(f) = w.word(b'F').filter(|f| f.value >= 0.0) {
                    self.modal.feed = f.value;
                }
            }
            return self.settings(w);
        }
        if w.word(b'O').is_some() && crate::program::program_number(b).is_some() {
            self.open_programs = self.open_programs.saturating_add(1);
        }
        let threading = self.is_threading(w);
        let m = &mut self.modal;
        // Feed mode, F, S, T.
        if let Some((_, c)) = w.g_in(GGroup::FeedMode) {
            m.feed_mode = match c {
                930 => FeedMode::InverseTime,
                950 => FeedMode::PerRevolution,
                _ => FeedMode::PerMinute,
            };
        }
        if let Some(f) = w.word(b'F') {
            self.feed_given = true;
            if f.value < 0.0 {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::BadValue {
                        word: f.display(),
                        why: "feed rate cannot be negative",
                    },
                    Some(f.span),
                ));
            }
            m.feed = f.value;
        }
        if let Some(s) = w.get(b'S') {
            // With G4, S is the dwell in seconds (Marlin, RepRap).
            if !w.has_g(40) {
                m.speed = s;
            }
        }
        if let Some(t) = w.word(b'T') {
            if t.value < 0.0 || t.value.fract() != 0.0 {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::BadValue {
                        word: t.display(),
                        why: "tool numbers are whole and not negative",
                    },
                    Some(t.span),
                ));
            }
            // Bambu's T1000 and T1100 (its start code's "change to nozzle space", and the
            // lidar's) are coordinate spaces of the firmware, not extruders: the moves
            // after them are offset as only the firmware knows.
            if self.opts.e_word == EWord::Extrusion && t.value >= 1000.0 {
                out(Event::Diagnostic(diag(
                    b,
                    Severity::Warning,
                    ErrorKind::NotSimulated(format!(
                        "{} (Bambu's nozzle or lidar coordinate space, not an extruder: the moves after it are offset as only the firmware knows)",
                        t.display()
                    )),
                    Some(t.span),
                )));
            } else {
                m.selected_tool = t.value as u32;
                // A printer changes tools (extruders) on a bare T (Marlin's "T0–T7:
                // select or switch hotend", RepRapFirmware, Klipper): no M6 follows.
                if self.opts.e_word == EWord::Extrusion {
                    m.tool = m.selected_tool;
                }
            }
        }
        // M-codes that change state before motion.
        let mut stop_after = false;
        for &(mw, code) in &w.ms {
            match code {
                // LinuxCNC stops the spindle for a tool change (as rs274 does, and a
                // machine unless its TOOL_CHANGE_WITH_SPINDLE_ON is set); M3/M4 in the
                // block start it after the change.
                60 if self.opts.flavor == crate::flavor::Flavor::LinuxCnc => {
                    m.tool = m.selected_tool;
                    if !w.ms.iter().any(|&(_, c)| c == 30 || c == 40) {
                        m.spindle = Spindle::Off;
                    }
                }
                60 => m.tool = m.selected_tool,
                610 => {
                    if let Some(q) = w.get(b'Q') {
                        m.tool = q.max(0.0) as u32;
                        m.selected_tool = m.tool;
                    }
                }
                30 => m.spindle = Spindle::Cw,
                40 => m.spindle = Spindle::Ccw,
                50 => m.spindle = Spindle::Off,
                70 => m.mist = true,
                80 => m.flood = true,
                90 => {
                    m.mist = false;
                    m.flood = false;
                }
                20 | 300 => stop_after = true,
                820 | 830 => {
                    self.e_relative = code == 830;
                    self.e_mode_doubt = None;
                }
                // Haas M97: the reader runs the labelled block to its M99, which then
                // returns like a subprogram's, once for each of the L runs.
                970 if self.calls == Calls::Followed => {
                    self.open_programs = self.open_programs.saturating_add(m97_runs(w));
                }
                // RepRapFirmware's macro file (`M98 P"/macros/purge.g"`): not followed.
                980 if w.word(b'P').is_none() && w.first_text.is_some() => {
                    let file = w.first_text.map_or("", |t| t.text);
                    out(Event::Diagnostic(diag(
                        b,
                        Severity::Warning,
                        ErrorKind::SubprogramNotFollowed(format!(
                            "{} {file} (a macro file)",
                            mw.display_code()
                        )),
                        Some(mw.span),
                    )));
                }
                970 | 980 if self.calls == Calls::NotFollowed => {
                    let mut what = mw.display_code();
                    for word in [w.word(b'P'), w.word(b'L')].into_iter().flatten() {
                        what.push(' ');
                        what.push_str(&word.display());
                    }
                    out(Event::Diagnostic(diag(
                        b,
                        Severity::Warning,
                        ErrorKind::SubprogramNotFollowed(what.trim().to_string()),
                        Some(mw.span),
                    )));
                }
                _ => {}
            }
        }
        // LinuxCNC's I/O codes take E as the input's or output's number (`M67 E2 Q25`:
        // analog output 2, synchronised with the move; `M68`, `M66`).
        let io_number = self.opts.flavor == crate::flavor::Flavor::LinuxCnc
            && w.ms.iter().any(|&(_, c)| matches!(c, 660 | 670 | 680));
        let m = &mut self.modal;
        // E word.
        if let Some(e) = w.word(b'E').filter(|_| !io_number) {
            match self.opts.e_word {
                // LinuxCNC: E is G76's taper, nothing else (no fixture offsets).
                EWord::FixtureOffset if self.opts.flavor == crate::flavor::Flavor::LinuxCnc => {
                    if !threading {
                        return Err(diag(
                            b,
                            Severity::Error,
                            ErrorKind::StrayWord {
                                word: e.display(),
                                letter: 'E',
                                with: "G76 (a thread's taper)",
                            },
                            Some(e.span),
                        ));
                    }
                }
                EWord::FixtureOffset => {
                    if e.value < 0.0 || e.value > 48.0 || e.value.fract() != 0.0 {
                        return Err(diag(
                            b,
                            Severity::Error,
                            ErrorKind::BadValue {
                                word: e.display(),
                                why: "FADAL fixture offsets are E0 to E48",
                            },
                            Some(e.span),
                        ));
                    }
                    m.work_offset = WorkOffset::Fixture(e.value as u8);
                }
                // Read below, once the block's distance mode is known.
                EWord::Extrusion => {}
            }
        }
        // FADAL L words outside canned cycles call subroutines (with M98, L is the
        // call's repeat count). A printer's L is an option of its command (Prusa's
        // tool pick `T0 S1 L0 D0`: the Z lift).
        if let Some(l) = w.word(b'L').filter(|_| {
            !w.ms.iter().any(|&(_, c)| c == 980 || c == 970) && self.opts.e_word != EWord::Extrusion
        }) {
            let canned_block = w
                .g_in(GGroup::Motion)
                .map_or(matches!(m.motion, Motion::Canned(_)), |(_, c)| {
                    matches!(c, 730 | 740 | 760) || crate::modal::is_drill_cycle(c)
                });
            // A FADAL subroutine's heading or call, where the source follows them.
            let followed = self.opts.flavor == crate::flavor::Flavor::Fadal
                && self.calls != Calls::NotFollowed
                && crate::program::fadal_sub_line(b).is_some();
            if !canned_block && !w.has_g(100) && !followed {
                if self.opts.flavor == crate::flavor::Flavor::LinuxCnc {
                    // G41.1/G42.1's L is a lathe tool's orientation.
                    if !w.has_g(411) && !w.has_g(421) {
                        // RS274NGC has no L outside G10, canned cycles and M98's count:
                        // rs274 refuses the block.
                        return Err(diag(
                            b,
                            Severity::Error,
                            ErrorKind::StrayWord {
                                word: l.display(),
                                letter: 'L',
                                with: "G10, a canned cycle, G41.1/G42.1 or a call's repeat count",
                            },
                            Some(l.span),
                        ));
                    }
                } else {
                    self.warn(
                        b,
                        out,
                        ErrorKind::SubprogramNotFollowed(l.display()),
                        Some(l.span),
                    );
                }
            }
        }
        let m = &mut self.modal;
        if let Some((_, c)) = w.g_in(GGroup::ToolLength) {
            m.tool_length = if c == 490 {
                None
            } else {
                Some(w.get(b'H').map_or(m.tool, |h| h.max(0.0) as u32))
            };
        } else if let Some(h) = w.get(b'H').filter(|_| !threading) {
            // FADAL: an H word alone applies that length offset (G76's H is its spring
            // passes).
            m.tool_length = if h == 0.0 {
                None
            } else {
                Some(h.max(0.0) as u32)
            };
        }
        // Plane, units, cutter comp, coordinate system, distance, retract and the codes
        // not simulated: only a block with a G-code besides motion has any.
        if !w.gs.iter().all(|g| g.2 == GGroup::Motion) {
            self.modal_groups(b, w, out)?;
        }
        // Motion mode change: the block's motion code other than G80 (at most one: see
        // `collect`), else its G80.
        if let Some((gw, c)) = w.g_in(GGroup::Motion) {
            if self.opts.flavor == crate::flavor::Flavor::LinuxCnc {
                self.linuxcnc_motion_words(b, w, gw, c)?;
            }
            self.rigid_tap = c == 331;
            self.modal.motion = self.motion_of_code(c);
            if matches!(c, 330 | 331) {
                self.warn(
                    b,
                    out,
                    ErrorKind::NotSimulated(format!(
                        "spindle synchronisation of {}",
                        gw.display_code()
                    )),
                    Some(gw.span),
                );
            }
            if !(matches!(c, 730 | 740 | 760) || crate::modal::is_drill_cycle(c)) {
                self.canned = CannedParams::default();
            }
        }
        if self.opts.e_word == EWord::Extrusion {
            if let Some(e) = w.word(b'E') {
                if w.has_g(920) {
                    // G92 E: the extruder's position is set; nothing moves.
                    self.extrusion = e.value;
                } else {
                    // The first E read after a G90 under M83: the doubt is said now.
                    if let Some(d) = self.e_mode_doubt.take() {
                        self.warned_e_mode = true;
                        out(Event::Diagnostic(d));
                    }
                    if self.e_relative
                        || (self.modal.distance == Distance::Incremental
                            && self.opts.flavor != crate::flavor::Flavor::RepRap)
                    {
                        self.extrusion += e.value;
                        self.pending_e = e.value;
                    } else {
                        self.pending_e = e.value - self.extrusion;
                        self.extrusion = e.value;
                    }
                }
            }
        }
        // Offsets change only through E, G54…, units and the non-modal codes.
        let offsets_may_change = w.word(b'E').is_some()
            || w.by_group[GGroup::CoordSystem as usize] != 0
            || w.by_group[GGroup::Units as usize] != 0
            || w.by_group[GGroup::NonModal as usize] != 0;
        if offsets_may_change {
            self.refresh_offset();
        }
        let g53 = w.has_g(530);
        // Non-modal codes.
        let mut axes_used = false;
        let non_modal = if w.by_group[GGroup::NonModal as usize] == 0 {
            &[][..]
        } else {
            &w.gs[..]
        };
        for &(gw, c, g) in non_modal {
            if g != GGroup::NonModal {
                continue;
            }
            match c {
                40 => {
                    axes_used |= self.dwell_words(b, w, gw)?;
                    if self.opts.post_notes {
                        let time = w.word(b'P').or(w.word(b'X')).or(w.word(b'U'));
                        let what = match time {
                            Some(t) => format!("{} {}", gw.display_code(), t.display()),
                            None => gw.display_code(),
                        };
                        self.warn(b, out, ErrorKind::DwellLeftOut(what), Some(gw.span));
                    }
                }
                100 => {
                    axes_used = true;
                    self.g10(b, w, gw)?;
                }
                280 | 300 | 1610 | 1620 => {
                    axes_used = true;
                    self.home(b, w, c, out)?;
                }
                281 => self.home28 = self.pos,
                301 => self.home30 = self.pos,
                520 => {
                    axes_used = true;
                    for (a, &l) in AXES.iter().enumerate() {
                        if let Some(v) = w.get(l) {
                            self.g52[a] = v;
                        }
                    }
                }
                920 => {
                    axes_used = true;
                    let extruder_only =
                        self.opts.e_word == EWord::Extrusion && w.word(b'E').is_some();
                    if !w.has_axes() && !extruder_only && !self.spindle_limit(w) {
                        return Err(diag(
                            b,
                            Severity::Error,
                            ErrorKind::BadValue {
                                word: gw.display_code(),
                                why: "G92 needs at least one axis word",
                            },
                            Some(gw.span),
                        ));
                    }
                    let off = self.offset();
                    for (a, &l) in AXES.iter().enumerate() {
                        if let Some(v) = w.get(l) {
                            // New g92 so that pos reads v: pos = v + base + g92_new + g52.
                            self.g92[a] = self.pos[a] - v - (off[a] - self.g92[a]);
                        }
                    }
                }
                921 | 922 => self.g92 = [0.0; 9],
                923 => self.warn(
                    b,
                    out,
                    ErrorKind::NotSimulated("G92.3 (restore saved G92 offsets)".into()),
                    Some(gw.span),
                ),
                290 => {
                    axes_used = true;
                    self.warn(
                        b,
                        out,
                        ErrorKind::NotSimulated("G29 (return from reference point)".into()),
                        Some(gw.span),
                    );
                }
                450..=480 => self.warn(
                    b,
                    out,
                    ErrorKind::NotSimulated(format!("{} (tool offset adjust)", gw.display_code())),
                    Some(gw.span),
                ),
                // G31 (skip) is a feed move of its own whatever motion mode is in force
                // (Fanuc, Mach3, FADAL); only another motion code in its block is wrong.
                310 | 311 if w.g_in(GGroup::Motion).is_some_and(|(_, c)| c != 10) => {
                    return Err(diag(
                        b,
                        Severity::Error,
                        ErrorKind::BadValue {
                            word: gw.display_code(),
                            why: "a probe move must be a G1 move",
                        },
                        Some(gw.span),
                    ));
                }
                _ => {}
            }
        }
        // G43.1 (LinuxCNC's and grbl's dynamic tool length offset): its axis words are
        // the offset, not a move (`G43.1 Z2.5` after a tool change). The offset shifts
        // where a later move without that axis word goes, which the trace does not follow:
        // it is named. With a motion code in the block the words are the move's too.
        if let Some((gw, 431)) = w.g_in(GGroup::ToolLength) {
            self.warn(
                b,
                out,
                ErrorKind::NotSimulated(
                    "G43.1 (dynamic tool length offset: its axis words are the offset, not a move)"
                        .into(),
                ),
                Some(gw.span),
            );
            axes_used |= w.g_in(GGroup::Motion).is_none();
        }
        // An explicit motion code with no axis words still runs its motion, to where
        // the tool already is (as LinuxCNC does: `G0` alone is a zero-length rapid).
        let explicit_motion = w.g_in(GGroup::Motion).is_some_and(|(_, c)| c != 800);
        if offsets_may_change {
            self.refresh_offset();
        }
        // In slicer programs (E is extrusion) a motion code with no axis words moves
        // nothing: `G1 E.8 F2400` (unretract) and `G1 F1200` set E and F only. An arc
        // with its centre words is a full circle there too (Marlin's, Klipper's and
        // RepRapFirmware's `G2 I5 J0 E3`).
        let full_circle = w
            .g_in(GGroup::Motion)
            .is_some_and(|(_, c)| c == 20 || c == 30)
            && [b'I', b'J', b'K'].iter().any(|&l| w.word(l).is_some());
        let explicit_motion =
            explicit_motion && (self.opts.e_word != EWord::Extrusion || full_circle);
        if self.watch_printer_axes && !axes_used {
            if let Some(word) = [b'A', b'B', b'C', b'U', b'V']
                .iter()
                .find_map(|&l| w.word(l))
            {
                self.watch_printer_axes = false;
                self.warn(
                    b,
                    out,
                    ErrorKind::PrinterRotaryAxis(word.display()),
                    Some(word.span),
                );
            }
        }
        if !axes_used && (w.has_axes() || explicit_motion) {
            let probe = w.has_g(310) || w.has_g(311);
            self.motion(b, w, g53, probe, out)?;
        }
        if self.opts.stops {
            self.report_stop(b, w, out);
        }
        if stop_after {
            if let Some(c) = self.comp.take() {
                self.comp_release(*c, out)
                    .map_err(|e| comp_diag(b, e, None))?;
            }
            self.ended = true;
            self.open_programs = 0;
        }
        if w.ms.iter().any(|&(_, c)| c == 990) {
            if self.open_programs > 0 {
                // M99 closes the `O` program it is in: a subprogram returns. Read in file
                // order the next program follows; in execution order, the caller.
                self.open_programs -= 1;
            } else {
                self.main_program_m99(b, w, out)?;
            }
        }
        Ok(())
    }

    /// The motion mode a block's group-1 code `c` (the code times ten) sets. G80 ends a
    /// canned cycle: under LinuxCNC (rs274) and the printer firmwares no motion mode is left;
    /// under Fanuc, Haas and FADAL, whose cycles are group 09 apart from the group-01 motion
    /// (Fanuc 0i-MF's and the Haas mill manual's G-code tables), the G0–G3 in force before
    /// the cycle is in force again (Mastercam's Haas post writes `A0.` after `G80`: a G0
    /// move there).
    fn motion_of_code(&mut self, c: u16) -> Motion {
        let now = self.modal.motion;
        match c {
            0 => Motion::Rapid,
            10 => Motion::Linear,
            20 => Motion::ArcCw,
            30 => Motion::ArcCcw,
            330 | 331 => Motion::Thread,
            382..=385 => Motion::Probe,
            800 if self.opts.flavor.cycles_apart_from_motion() => match now {
                Motion::Canned(_) => self.motion_before_cycle,
                other => other,
            },
            800 => Motion::None,
            c => {
                if !matches!(now, Motion::Canned(_)) {
                    self.motion_before_cycle = now;
                }
                Motion::Canned(c)
            }
        }
    }

    /// The modal groups of a block's G-codes other than motion, feed mode and tool
    /// length (see [`Interpreter::execute`]).
    fn modal_groups(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        if self.comp.is_some() {
            comp_conflicts(b, w, self.modal.plane, self.modal.units)?;
        }
        // G90 while M83 holds: firmwares differ on what E is next. lampost keeps it
        // relative, as Marlin 1, Prusa's firmware and RepRapFirmware do; Marlin 2 makes
        // it absolute again. Said once, at the G90, when an E word is read by it (an M82
        // or M83 first settles it: see `extrude`).
        if let Some((gw, 900)) = w.g_in(GGroup::Distance) {
            if self.e_relative
                && self.opts.e_word == EWord::Extrusion
                && self.opts.flavor != crate::flavor::Flavor::RepRap
                && !self.warned_e_mode
            {
                self.e_mode_doubt = Some(diag(
                    b,
                    Severity::Warning,
                    ErrorKind::EModeAfterG90,
                    Some(gw.span),
                ));
            }
        }
        let m = &mut self.modal;
        if let Some((_, c)) = w.g_in(GGroup::Plane) {
            m.plane = match c {
                180 => Plane::XZ,
                190 => Plane::YZ,
                _ => Plane::XY,
            };
        }
        if let Some((gw, c)) = w
            .g_in(GGroup::Units)
            .filter(|_| self.lathe_units_cycle(w).is_none())
        {
            let units = if c == 200 || c == 700 {
                Units::Inch
            } else {
                Units::Mm
            };
            if !self.set_units(units) {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::BadValue {
                        word: gw.display_code(),
                        why: "a position or offset held is too large to hold in the new units",
                    },
                    Some(gw.span),
                ));
            }
            // G70/G71 as units take no words; with I, J or L the block is a Haas mill's
            // bolt hole pattern (G70 I radius J angle L holes, G71 with K): its holes
            // would be missing from the trace, so it is named, and the post refuses it.
            if matches!(c, 700 | 710) && [b'I', b'J', b'L'].iter().any(|&l| w.word(l).is_some()) {
                self.warn(
                    b,
                    out,
                    ErrorKind::NotSimulated(format!(
                        "{} with I, J or L (a Haas mill's bolt hole pattern; read with --flavor haas) is read as units here, and",
                        gw.display_code()
                    )),
                    Some(gw.span),
                );
            }
        }
        let m = &mut self.modal;
        if let Some((gw, c)) = w.g_in(GGroup::CutterComp) {
            let before = m.cutter_comp;
            m.cutter_comp = match c {
                410 | 411 => CutterComp::Left,
                420 | 421 => CutterComp::Right,
                _ => CutterComp::Off,
            };
            self.comp_tool = match (c, w.get(b'D')) {
                (411 | 421, Some(d))
                    if self.opts.flavor == crate::flavor::Flavor::LinuxCnc && d.is_finite() =>
                {
                    let side = if c == 411 {
                        crate::comp::Side::Left
                    } else {
                        crate::comp::Side::Right
                    };
                    let orientation = w
                        .get(b'L')
                        .filter(|l| l.fract() == 0.0 && (0.0..=9.0).contains(l))
                        .map_or(0, |l| l as u8);
                    Some((side, d / 2.0, orientation))
                }
                _ => None,
            };
            if let Some(c) = self.comp.take() {
                // G40 (or a new G41/G42): the held moves go as they are.
                let programmed = self.pos;
                self.comp_release(*c, out)
                    .map_err(|e| comp_diag(b, e, Some(gw.span)))?;
                if self.modal.cutter_comp == CutterComp::Off {
                    // The next move starts where the tool was drawn, but goes to its
                    // words from the programmed point (rs274: after `G40`, `G0 Z5`
                    // rises to the programmed X and Y, not the compensated ones).
                    self.comp_exit = Some(self.pos);
                    self.pos = programmed;
                }
            }
            let plane = self.modal.plane;
            if let (Some((side, radius, orientation)), true) =
                (self.comp_tool, matches!(plane, Plane::XY | Plane::XZ))
            {
                if radius != 0.0 {
                    let mm = self.modal.units == Units::Mm;
                    let at = plane_point(plane, &self.pos);
                    let orientation = if plane == Plane::XZ { orientation } else { 0 };
                    self.comp = Some(Box::new(crate::comp::Comp::new(
                        side,
                        radius,
                        orientation,
                        mm,
                        at,
                    )));
                    self.comp_drawn = self.pos;
                }
            }
            if self.comp.is_some() {
                self.warn(
                    b,
                    out,
                    ErrorKind::CutterCompTraced(gw.display_code()),
                    Some(gw.span),
                );
            }
            let m = &mut self.modal;
            if m.cutter_comp != CutterComp::Off && before == CutterComp::Off && self.comp.is_none()
            {
                self.warn(
                    b,
                    out,
                    ErrorKind::NotSimulated(format!(
                        "cutter radius compensation {}",
                        gw.display_code()
                    )),
                    Some(gw.span),
                );
            }
        }
        let m = &mut self.modal;
        if let Some(o) = w
            .g_in(GGroup::CoordSystem)
            .and_then(|(_, c)| WorkOffset::of_code(c))
        {
            m.work_offset = o;
        }
        if let Some((_, c)) = w.g_in(GGroup::Distance) {
            m.distance = if c == 910 {
                Distance::Incremental
            } else {
                Distance::Absolute
            };
        }
        if let Some((_, c)) = w.g_in(GGroup::ArcDistance) {
            m.arc_distance = if c == 911 {
                Distance::Incremental
            } else {
                Distance::Absolute
            };
        }
        if let Some((_, c)) = w.g_in(GGroup::Retract) {
            m.retract = if c == 990 {
                Retract::RPlane
            } else {
                Retract::InitialZ
            };
        }
        for group in [
            GGroup::Polar,
            GGroup::Scaling,
            GGroup::Mirror,
            GGroup::Rotation,
        ] {
            if let Some((gw, c)) = w.g_in(group) {
                if c == 500 && w.has_axes() {
                    // Fanuc's lathe G50 X Z sets the coordinate system (like G92).
                    self.warn(
                        b,
                        out,
                        ErrorKind::NotSimulated(format!(
                            "{} with axis words (a lathe's coordinate system setting)",
                            gw.display_code()
                        )),
                        Some(gw.span),
                    );
                } else if !matches!(c, 150 | 500 | 501 | 690) {
                    self.warn(
                        b,
                        out,
                        ErrorKind::NotSimulated(format!(
                            "{} ({})",
                            gw.display_code(),
                            group.name()
                        )),
                        Some(gw.span),
                    );
                }
            }
        }
        Ok(())
    }

    /// M99 with no `O` program open: the main program's M99. Controls with M98/M99
    /// subprograms start the main program again (Fanuc, Haas, FADAL, Mach3, LinuxCNC):
    /// one pass is traced, with a warning; printer firmware has no such M99 (an error).
    /// The rest is not reached from here.
    #[cold]
    #[inline(never)]
    fn main_program_m99(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        self.ended = true;
        let f = self.opts.flavor;
        let (sev, kind) = if f.is_slicer() {
            (Severity::Error, ErrorKind::ReturnOutsideSubprogram)
        } else {
            (Severity::Warning, ErrorKind::MainProgramLoops(f.name()))
        };
        let span = w.ms.iter().find(|&&(_, c)| c == 990).map(|&(m, _)| m.span);
        let d = diag(b, sev, kind, span);
        if sev == Severity::Error {
            return Err(d);
        }
        out(Event::Diagnostic(d));
        Ok(())
    }

    fn g10(&mut self, b: &Block<'_>, w: &Words<'_, '_>, gw: &Word<'_>) -> Res<()> {
        let l = w.get(b'L').unwrap_or(-1.0);
        if l != 2.0 && l != 20.0 {
            // G10 L1/L10/L11 set tool data: no effect on the programmed path.
            return Ok(());
        }
        let p = w.get(b'P').unwrap_or(0.0);
        if !(0.0..=9.0).contains(&p) || p.fract() != 0.0 {
            let pw = w
                .word(b'P')
                .map_or_else(|| gw.display_code(), |p| p.display());
            return Err(diag(
                b,
                Severity::Error,
                ErrorKind::BadValue {
                    word: pw,
                    why: "G10 L2/L20 takes P0 to P9",
                },
                w.word(b'P').map(|p| p.span),
            ));
        }
        let idx = if p == 0.0 {
            match self.modal.work_offset {
                WorkOffset::G5x(i) => usize::from(i),
                WorkOffset::Fixture(_) | WorkOffset::Extended(_) => 1,
            }
        } else {
            p as usize
        };
        for (a, &letter) in AXES.iter().enumerate() {
            if let Some(v) = w.get(letter) {
                self.g5x[idx][a] = if l == 2.0 {
                    v
                } else {
                    // L20: the current position reads v in that system.
                    self.pos[a] - v - self.g92[a] - self.g52[a]
                };
            }
        }
        Ok(())
    }

    fn home(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        code: u16,
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        let home = if code == 300 {
            self.home30
        } else {
            self.home28
        };
        // G161/G162 (home to the minimum or maximum stops) name axes without an
        // intermediate point; their home is taken as G28's.
        let via = matches!(code, 280 | 300);
        let start = self.pos;
        let mut inter = self.pos;
        let mut target = self.pos;
        let numbered = w.has_axes();
        // In a printer's program a bare W is Prusa firmware's flag (`G28 W`: home every
        // axis without mesh bed levelling), not an axis: printers have none.
        let bare = if self.opts.e_word == EWord::Extrusion {
            w.bare & !(1 << 8)
        } else {
            w.bare
        };
        let any = numbered || bare != 0;
        let off = self.offset();
        for (a, &l) in AXES.iter().enumerate() {
            match w.get(l) {
                _ if bare & (1 << a) != 0 => target[a] = home[a],
                Some(_) if !via => target[a] = home[a],
                Some(v) => {
                    inter[a] = match self.modal.distance {
                        Distance::Absolute => v + off[a],
                        Distance::Incremental => self.pos[a] + v,
                    };
                    target[a] = home[a];
                }
                None if !any => target[a] = home[a],
                None => {}
            }
        }
        beyond_any_number(b, w, &inter)?;
        let mut mv = |s: Position, e: Position, this: &mut Self| {
            out(Event::Move(Move {
                kind: MoveKind::Rapid,
                start: this.to_program(s),
                end: this.to_program(e),
                feed: 0.0,
                extrusion: this.extrusion_now(),
                extruded: this.extruded_now(),
                modal: this.modal,
                line: b.line,
                origin: Origin::Home,
                axes_named: this.axes_named,
                block_axes: this.block_axes,
            }));
        };
        // G28/G30 go through their intermediate point even when the block names no axis
        // (a zero-length move, as LinuxCNC's rs274 reports it); a slicer's bare `G28`
        // (the firmware's homing) has none.
        if via && (numbered || (!any && self.opts.e_word != EWord::Extrusion)) {
            mv(start, inter, self);
        }
        mv(inter, target, self);
        self.pos = target;
        Ok(())
    }

    fn extrusion_now(&self) -> Option<f64> {
        (self.opts.e_word == EWord::Extrusion).then_some(self.extrusion)
    }

    /// The block's E change for the move being sent (the first of the block gets it).
    fn extruded_now(&mut self) -> Option<f64> {
        let e = std::mem::take(&mut self.pending_e);
        (self.opts.e_word == EWord::Extrusion).then_some(e)
    }

    /// The block's stop, if it makes one (after its motion): [`Event::Stop`].
    fn report_stop(&self, b: &Block<'_>, w: &Words<'_, '_>, out: &mut impl FnMut(Event)) {
        let printer = self.opts.e_word == EWord::Extrusion;
        let kind = w.ms.iter().find_map(|&(_, c)| match c {
            0 => Some(StopKind::Program),
            10 if printer => Some(StopKind::Program),
            10 => Some(StopKind::Optional),
            600 => Some(StopKind::Pallet),
            _ => None,
        });
        if let Some(kind) = kind {
            out(Event::Stop(Stop { kind, line: b.line }));
        }
    }

    /// A block of setting M-codes (see [`m_known`]): the known codes among them act,
    /// the words are the settings' own. Nothing moves.
    fn settings(&mut self, w: &Words<'_, '_>) -> Res<()> {
        for &(_, code) in &w.ms {
            match code {
                820 | 830 => {
                    self.e_relative = code == 830;
                    self.e_mode_doubt = None;
                }
                20 | 300 => {
                    self.ended = true;
                    self.open_programs = 0;
                }
                _ => {}
            }
        }
        Ok(())
    }

    fn target(&self, w: &Words<'_, '_>, g53: bool) -> Position {
        self.target_of(|a| w.get(AXES[a]), g53)
    }

    /// Where a block's axis words (`value(i)` for `AXES[i]`) take the tool.
    #[inline]
    fn target_of(&self, value: impl Fn(usize) -> Option<f64>, g53: bool) -> Position {
        let mut t = self.pos;
        let off = self.offset();
        for a in 0..AXES.len() {
            if let Some(v) = value(a) {
                t[a] = if g53 {
                    v
                } else {
                    match self.modal.distance {
                        Distance::Absolute => v + off[a],
                        Distance::Incremental => self.pos[a] + v,
                    }
                };
            }
        }
        t
    }

    /// The feed of a feed move. Before any F, a printer's firmware moves at its initial
    /// feed rate: that becomes the feed in force, with a warning; any other control
    /// refuses the move.
    fn feed_for(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        out: &mut impl FnMut(Event),
    ) -> Res<f64> {
        match self.modal.feed_mode {
            FeedMode::InverseTime => match w.get(b'F') {
                Some(f) if f > 0.0 => Ok(f),
                _ => Err(diag(b, Severity::Error, ErrorKind::InverseTimeNeedsF, None)),
            },
            _ if self.modal.feed <= 0.0 && !self.feed_from_macro => {
                match self.opts.flavor.initial_feed_mm_min() {
                    // (Marlin ignores an F0, so it too leaves the initial feed rate.)
                    Some((firmware, mm_min)) if self.modal.feed == 0.0 => {
                        let kind = ErrorKind::FirmwareInitialFeed { firmware, mm_min };
                        self.warn(b, out, kind, None);
                        self.modal.feed = match self.modal.units {
                            Units::Mm => mm_min,
                            Units::Inch => mm_min / 25.4,
                        };
                        Ok(self.modal.feed)
                    }
                    _ if self.feed_given && self.modal.feed == 0.0 => {
                        Err(diag(b, Severity::Error, ErrorKind::ZeroFeedRate, None))
                    }
                    _ if b.vacant & crate::parse::letter_bit(b'F') != 0 => {
                        Err(diag(b, Severity::Error, ErrorKind::FeedVacant, None))
                    }
                    _ => Err(diag(b, Severity::Error, ErrorKind::NoFeedRate, None)),
                }
            }
            _ => Ok(self.modal.feed),
        }
    }

    /// The tool's X and Y in the coordinates of the work system in force (where polar
    /// points are measured from).
    fn program_xy(&self) -> [f64; 2] {
        let off = self.offset();
        [self.pos[0] - off[0], self.pos[1] - off[1]]
    }

    /// A point of the work system in force (X, Y) in the machine frame; as it is when
    /// every offset is zero (a polar point's `-0.0` stays: rs274 takes the angle of
    /// `(-0.0, 0.0)` as 180°).
    fn machine_xy(&self, p: [f64; 2]) -> [f64; 2] {
        if self.offset_zero {
            return p;
        }
        let off = self.offset();
        [p[0] + off[0], p[1] + off[1]]
    }

    /// `p` (machine frame) in the coordinates of the work system in force.
    fn to_program(&self, p: Position) -> Position {
        if self.offset_zero {
            return p;
        }
        let off = self.offset();
        let mut q = p;
        for a in 0..9 {
            q[a] -= off[a];
        }
        q
    }

    fn emit(
        &mut self,
        line: u32,
        kind: MoveKind,
        end: Position,
        feed: f64,
        origin: Origin,
        out: &mut impl FnMut(Event),
    ) {
        if let Some(drawn) = self.comp_exit.take() {
            // The first move after `G40`: from where the tool was drawn.
            self.pos = drawn;
        }
        out(Event::Move(self.make_move(line, kind, end, feed, origin)));
    }

    /// The move from the tool's position to `end` (machine frame), reported in the work
    /// system in force; the tool is then at `end`.
    #[inline(always)]
    fn make_move(
        &mut self,
        line: u32,
        kind: MoveKind,
        end: Position,
        feed: f64,
        origin: Origin,
    ) -> Move {
        let kind = match kind {
            MoveKind::Arc {
                clockwise,
                center,
                plane,
                turns,
            } => {
                let off = self.offset();
                MoveKind::Arc {
                    clockwise,
                    center: [center[0] - off[0], center[1] - off[1], center[2] - off[2]],
                    plane,
                    turns,
                }
            }
            k => k,
        };
        let m = Move {
            kind,
            start: self.to_program(self.pos),
            end: self.to_program(end),
            feed,
            extrusion: self.extrusion_now(),
            extruded: self.extruded_now(),
            modal: self.modal,
            line,
            origin,
            axes_named: self.axes_named,
            block_axes: self.block_axes,
        };
        self.pos = end;
        m
    }

    fn motion(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        g53: bool,
        probe: bool,
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        let mut target = self.target(w, g53);
        if let Some(p) = w.polar() {
            // A canned cycle places its holes itself (`canned_cycle`).
            if probe || !matches!(self.modal.motion, Motion::Canned(_)) {
                let incremental = self.modal.distance == Distance::Incremental;
                let end = p.end(self.program_xy(), incremental).map_err(|why| {
                    diag(b, Severity::Error, ErrorKind::Polar(why), w.polar_span())
                })?;
                [target[0], target[1]] = self.machine_xy(end);
            }
        }
        beyond_any_number(b, w, &target)?;
        let origin = if g53 {
            Origin::MachineCoords
        } else {
            Origin::Block
        };
        if self.comp.is_some() {
            let why = if probe || self.modal.motion == Motion::Probe {
                Some("Cannot probe with cutter radius comp on")
            } else if matches!(self.modal.motion, Motion::Canned(_)) {
                Some("Cannot use canned cycles with cutter compensation on")
            } else if self.modal.motion == Motion::Thread {
                Some("a spindle-synchronised move under cutter compensation (lampost does not simulate it)")
            } else {
                None
            };
            if let Some(why) = why {
                return Err(comp_diag(b, crate::comp::CompError(why), None));
            }
        }
        if probe || self.modal.motion == Motion::Probe {
            // A probe move stops where the probe touches: traced to its programmed end,
            // with a warning (the post cannot place a contact it does not know).
            let feed = self.feed_for(b, w, out)?;
            let code =
                w.gs.iter()
                    .find(|g| matches!(g.1, 310 | 311 | 382..=385))
                    .map_or_else(|| "a probe move".to_string(), |g| g.0.display_code());
            // LinuxCNC's G38.x: traced as its standalone rs274 simulates it (see
            // `probe_rest`); other controls' probes stay at their programmed end.
            let backs_off = !probe && self.opts.flavor == crate::flavor::Flavor::LinuxCnc;
            let rest = if backs_off {
                "; the trace goes to its programmed end and backs off 0.01 in (0.254 mm) towards its start, as LinuxCNC's simulator does"
            } else {
                "; the trace goes to its programmed end"
            };
            self.warn(
                b,
                out,
                ErrorKind::NotSimulated(format!(
                    "{code} (a probe move stops where the probe touches{rest})"
                )),
                None,
            );
            let start = self.pos;
            if backs_off {
                probe_must_move(b, w, &start, &target)?;
            }
            self.emit(b.line, MoveKind::Probe, target, feed, origin, out);
            if backs_off {
                self.pos = probe_rest(&start, &target, self.modal.units);
            }
            return Ok(());
        }
        match self.modal.motion {
            Motion::None => Err(diag(
                b,
                Severity::Error,
                ErrorKind::NoMotionMode,
                w.gs.first()
                    .map(|g| g.0.span)
                    .or(b.words().next().map(|x| x.span)),
            )),
            Motion::Rapid => {
                self.centre_words_unused(b, w, out)?;
                self.corner_words(b, w, false)?;
                self.endstop_move(b, w, out);
                self.emit_comp(b, MoveKind::Rapid, target, 0.0, origin, out)
            }
            Motion::Thread => {
                // Spindle-synchronised (G33, rigid tap G33.1): the feed is the pitch K
                // times the spindle speed, no F needed; a rigid tap returns to where it
                // started (the spindle reverses out), as LinuxCNC runs it.
                let feed = match w.get(b'K') {
                    Some(k) if k != 0.0 && self.modal.speed > 0.0 => {
                        let feed = k.abs() * self.modal.speed;
                        if !feed.is_finite() {
                            return Err(diag(
                                b,
                                Severity::Error,
                                ErrorKind::BadValue {
                                    word: w.word(b'K').map_or_else(String::new, |k| k.display()),
                                    why: "the pitch times the spindle speed is beyond any number",
                                },
                                w.word(b'K').map(|k| k.span),
                            ));
                        }
                        feed
                    }
                    _ => self.feed_for(b, w, out)?,
                };
                let start = self.pos;
                self.emit(b.line, MoveKind::Linear, target, feed, origin, out);
                if self.rigid_tap {
                    self.emit(b.line, MoveKind::Linear, start, feed, origin, out);
                }
                Ok(())
            }
            Motion::Linear | Motion::Probe => {
                if self.modal.motion == Motion::Linear {
                    self.corner_words(b, w, true)?;
                    self.centre_words_unused(b, w, out)?;
                    self.endstop_move(b, w, out);
                }
                let feed = match self.feed_for(b, w, out) {
                    Ok(feed) => feed,
                    Err(e) => {
                        // As a refused arc: the next block is read from where this one
                        // was programmed to end (an arc after a refused F0 feed was
                        // blamed for a start it did not have).
                        self.pos = target;
                        return Err(e);
                    }
                };
                self.emit_comp(b, MoveKind::Linear, target, feed, origin, out)
            }
            Motion::ArcCw | Motion::ArcCcw => {
                let arc = self.arc(b, w, target, out);
                if arc.is_err() {
                    // A refused arc still ends where it was programmed to: the next
                    // block is read from there and not blamed for this one's fault.
                    self.pos = target;
                }
                arc
            }
            Motion::Canned(760) if self.opts.flavor == crate::flavor::Flavor::LinuxCnc => {
                self.threading(b, w, target, out)
            }
            Motion::Canned(760) if w.word(b'D').is_some() => {
                // A Fanuc or Haas lathe's one-block threading cycle `G76 X Z K D F` (D:
                // the first pass's depth; a mill's fine boring has none): named, not
                // read as fine boring; it ends where it started.
                let code = w.g_in(GGroup::Motion).map(|(gw, _)| gw);
                self.warn(
                    b,
                    out,
                    ErrorKind::NotSimulated(format!(
                        "{} with D (a Fanuc or Haas lathe's threading cycle; the trace stays where it started)",
                        code.map_or_else(|| "G76".to_string(), |gw| gw.display_code())
                    )),
                    code.map(|gw| gw.span),
                );
                Ok(())
            }
            Motion::Canned(c) => self.canned_cycle(b, w, c, out),
        }
    }

    /// True when the block runs LinuxCNC's G76 threading cycle (named in the block, or
    /// in force with no motion code in it): its E, H, I, J, K, L, P, Q and R are the
    /// cycle's.
    fn is_threading(&self, w: &Words<'_, '_>) -> bool {
        self.opts.flavor == crate::flavor::Flavor::LinuxCnc
            && w.g_in(GGroup::Motion)
                .map_or(self.modal.motion == Motion::Canned(760), |(_, c)| c == 760)
    }

    /// LinuxCNC's G76 threading cycle (`lathe.rs`): the block refused where rs274 refuses
    /// it, else its passes as moves, rapids and spindle-synchronised feeds (traced as G1
    /// moves at the pitch times the spindle speed, as G33 is) ending at the block's X, Y
    /// and Z.
    fn threading(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        target: Position,
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        let code = w.g_in(GGroup::Motion).map(|(gw, _)| gw);
        let fail = |letter: Option<u8>, why: String| {
            let span = letter
                .and_then(|l| w.word(l))
                .or(code)
                .map(|word| word.span);
            diag(b, Severity::Error, ErrorKind::ThreadingCycle(why), span)
        };
        if !w.has_axes() {
            return Err(fail(None, "no axis word: Z gives the thread's end".into()));
        }
        if !matches!(self.modal.spindle, Spindle::Cw | Spindle::Ccw) {
            return Err(fail(
                None,
                "the spindle is not turning (M3 or M4 before G76; a tool change M6 stops it)"
                    .into(),
            ));
        }
        if let Some(a) = (3..AXES.len()).find(|&a| target[a] != self.pos[a]) {
            return Err(fail(
                Some(AXES[a]),
                format!("{} moves: G76 moves X and Z only", char::from(AXES[a])),
            ));
        }
        if self.modal.cutter_comp != CutterComp::Off {
            return Err(fail(
                None,
                "cutter radius compensation is on (G40 before G76)".into(),
            ));
        }
        let thread = crate::lathe::Thread {
            p: w.get(b'P'),
            i: w.get(b'I'),
            j: w.get(b'J'),
            k: w.get(b'K'),
            q: w.get(b'Q'),
            r: w.get(b'R'),
            h: w.get(b'H'),
            e: w.get(b'E'),
            l: w.get(b'L'),
        };
        let xyz = |p: &Position| [p[0], p[1], p[2]];
        let moves = thread
            .moves(xyz(&self.pos), xyz(&target))
            .map_err(|e| fail(e.letter, e.why))?;
        let speed = self.modal.speed.abs();
        if moves
            .iter()
            .any(|m| m.pitch.is_some_and(|p| !(p * speed).is_finite()))
        {
            return Err(fail(
                Some(b'P'),
                "the pitch times the spindle speed is beyond any number".into(),
            ));
        }
        self.warn(
            b,
            out,
            ErrorKind::NotSimulated(format!(
                "spindle synchronisation of {} (threading cycle)",
                code.map_or_else(|| "G76".to_string(), |c| c.display_code())
            )),
            code.map(|c| c.span),
        );
        for m in moves {
            let mut to = self.pos;
            to[..3].copy_from_slice(&m.to);
            let (kind, feed) = match m.pitch {
                None => (MoveKind::Rapid, 0.0),
                Some(p) => (MoveKind::Linear, p * speed),
            };
            self.emit(b.line, kind, to, feed, Origin::CannedCycle, out);
        }
        Ok(())
    }

    /// The LinuxCNC lathe profile cycle (G70–G72 and their .1/.2) of the block that
    /// lampost expands: its code word and code. Only where the line source follows calls
    /// (the cycle runs its Q subroutine), and not a G70 under compensation lampost does
    /// not simulate (G41/G42: the radius unknown): those keep their warning. A G70 under
    /// simulated compensation (G41.1/G42.1 with D) is compensated (`comp.rs`).
    fn profile_cycle<'b, 'a>(&self, w: &Words<'b, 'a>) -> Option<(&'b Word<'a>, u16)> {
        if self.opts.flavor != crate::flavor::Flavor::LinuxCnc
            || self.calls != Calls::Followed
            || self.profile.is_some()
        {
            return None;
        }
        let &(gw, c, _) =
            w.gs.iter()
                .find(|g| g.2 == GGroup::Other && crate::modal::is_lathe_cycle(g.1))?;
        if c == 700 && self.modal.cutter_comp != CutterComp::Off && self.comp.is_none() {
            return None;
        }
        Some((gw, c))
    }

    /// Start a lathe profile cycle (`lathe.rs`): refused where rs274 refuses its block,
    /// else a rapid to its X and Z, and its Q subroutine is asked for (the stream has the
    /// source call it; its blocks make the profile, [`Interpreter::finish_profile`] its
    /// moves when it returns).
    fn start_profile(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        (gw, code): (&Word<'_>, u16),
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        let name = gw.display_code();
        let fail = |letter: Option<u8>, why: String| {
            let span = letter.and_then(|l| w.word(l)).unwrap_or(gw).span;
            diag(
                b,
                Severity::Error,
                ErrorKind::ProfileCycle(format!("{name}: {why}")),
                Some(span),
            )
        };
        let Some(q) = w.word(b'Q') else {
            return Err(fail(
                None,
                "Q (the profile's O-word subroutine) is missing".into(),
            ));
        };
        if code != 700 && self.modal.cutter_comp != CutterComp::Off {
            return Err(fail(
                None,
                "cutter radius compensation is on (G40 before G71/G72)".into(),
            ));
        }
        if self.modal.plane != Plane::XZ {
            return Err(fail(None, "only in the XZ plane (G18)".into()));
        }
        if !(q.value >= 0.0 && q.value.fract() == 0.0 && q.value < 1e15) {
            return Err(fail(
                Some(b'Q'),
                "Q must be the number of an O-word subroutine".into(),
            ));
        }
        if self.modal.feed_mode == FeedMode::InverseTime {
            return Err(fail(None, "inverse time feed (G93): use G94".into()));
        }
        // The block's own F is the cuts' feed (`G71 Q100 … F100`), as rs274 sets it
        // before the cycle.
        if let Some(f) = w
            .word(b'F')
            .filter(|f| f.value > 0.0 && f.value.is_finite())
        {
            self.modal.feed = f.value;
        }
        // The cycle's start: X and Z of the block, from the position in G91; the rapid
        // there reads them as absolute (rs274 switches to G90 before it).
        let here = self.program_position();
        let incremental = self.modal.distance == Distance::Incremental;
        let along = |a: usize, v: Option<f64>| match v {
            Some(v) if incremental => here[a] + v,
            Some(v) => v,
            None => here[a],
        };
        let start = crate::lathe::Pt::new(along(2, w.get(b'Z')), along(0, w.get(b'X')));
        let off = self.offset();
        let mut to = self.pos;
        for (a, &l) in AXES.iter().enumerate() {
            if let Some(v) = w.get(l) {
                to[a] = v + off[a];
            }
        }
        if self.comp.is_some() {
            // Compensated (a G70): the rapid goes through compensation with the cycle's
            // moves.
            self.comp_entry = Some(to);
        } else {
            self.comp_entry = None;
            self.emit(b.line, MoveKind::Rapid, to, 0.0, Origin::CannedCycle, out);
        }
        self.modal.motion = Motion::Rapid;
        let cycle = crate::lathe::ProfileCycle {
            cycle: code / 10,
            sub: code % 10,
            start,
            d: w.get(b'D').unwrap_or(0.0),
            e: w.get(b'E').unwrap_or(0.0),
            i: w.get(b'I').unwrap_or(1.0),
            p: w.get(b'P').unwrap_or(1.0),
            r: w.get(b'R').unwrap_or(0.5),
            u: w.get(b'U').unwrap_or(0.0),
            w: w.get(b'W').unwrap_or(0.0),
        };
        let (s, e) = (gw.span.start - b.span.start, gw.span.end - b.span.start);
        self.profile = Some(Box::new(crate::lathe::Recording {
            cycle,
            profile: crate::lathe::Profile::default(),
            at: start,
            motion: 0,
            incremental,
            arc_incremental: self.modal.arc_distance == Distance::Incremental,
            name,
            line: b.line,
            offset: b.span.start,
            raw: b.raw.to_string(),
            span: (s, e),
        }));
        self.profile_call = Some(format!("{}", q.value as u64));
        Ok(())
    }

    /// The O-word subroutine a lathe profile cycle has just asked for (its label), once.
    pub(crate) fn take_profile_call(&mut self) -> Option<String> {
        self.profile_call.take()
    }

    /// True when a lathe profile cycle has asked for its subroutine or is reading it (the
    /// stream's one check per line).
    #[inline]
    pub(crate) fn profile_pending(&self) -> bool {
        self.profile.is_some() || self.profile_call.is_some()
    }

    /// True while a lathe profile cycle reads its subroutine.
    pub(crate) fn recording_profile(&self) -> bool {
        self.profile.is_some()
    }

    /// The end of the input: moves held by cutter compensation are sent as they are.
    pub(crate) fn end_compensation(&mut self, out: &mut impl FnMut(Event)) {
        if let Some(c) = self.comp.take() {
            // Letting held moves go as they are cannot be refused (no end moves).
            let _ = self.comp_release(*c, out);
        }
    }

    /// The position a profile's subroutine sees (LinuxCNC's `#5420`…: the profile's
    /// current point in X and Z), while one is read.
    pub(crate) fn profile_position(&self) -> Option<Position> {
        let rec = self.profile.as_ref()?;
        let mut p = self.program_position();
        p[0] = rec.at.im;
        p[2] = rec.at.re;
        Some(p)
    }

    /// A block of a profile's subroutine (see [`crate::lathe::Recording::record`]).
    fn record_profile(&mut self, b: &Block<'_>) -> Res<()> {
        if b.kind != BlockKind::Words {
            return Ok(());
        }
        let mut pw = crate::lathe::ProfileWords::default();
        for word in b.words() {
            let v = Some(word.value);
            match word.letter {
                b'G' => {
                    if let Some(c) = word.code() {
                        if g_group(c) == Some(GGroup::Motion) || crate::modal::is_lathe_cycle(c) {
                            pw.motion = Some(c);
                        }
                    }
                }
                b'X' => pw.x = v,
                b'Z' => pw.z = v,
                b'U' => pw.u = v,
                b'W' => pw.w = v,
                b'I' => pw.i = v,
                b'K' => pw.k = v,
                b'R' => pw.r = v,
                b'A' => pw.a = v,
                b'C' => pw.c = v,
                _ => {}
            }
        }
        let Some(rec) = self.profile.as_mut() else {
            return Ok(());
        };
        rec.record(&pw).map_err(|e| {
            diag(
                b,
                Severity::Error,
                ErrorKind::ProfileCycle(format!("{} profile: {}", rec.name, e.0)),
                None,
            )
        })
    }

    /// A profile cycle's subroutine could not be called: the cycle is refused at its block.
    pub(crate) fn cancel_profile(&mut self, why: &str) -> Option<Diagnostic> {
        self.profile_call = None;
        let rec = self.profile.take()?;
        Some(rec.error(why))
    }

    /// The profile's subroutine has returned: the cycle's moves (rapids, feeds and arcs
    /// as rs274 makes them), or its refusal located at the cycle's block.
    pub(crate) fn finish_profile(&mut self, out: &mut impl FnMut(Event)) -> Res<()> {
        let Some(rec) = self.profile.take() else {
            return Ok(());
        };
        let moves = rec
            .profile
            .clone()
            .moves(&rec.cycle)
            .map_err(|e| rec.error(&e.0))?;
        let feed = self.modal.feed;
        if moves
            .iter()
            .any(|m| !matches!(m, crate::lathe::ProfileMove::Rapid(_)))
            && feed <= 0.0
            && !self.feed_from_macro
        {
            return Err(rec.error("no feed rate (F) for the cycle's cuts"));
        }
        let off = self.offset();
        let (radius_tol, spiral_tol) = match self.modal.units {
            Units::Inch => (ARC_RADIUS_TOLERANCE.0, ARC_SPIRAL_TOLERANCE.0),
            Units::Mm => (ARC_RADIUS_TOLERANCE.1, ARC_SPIRAL_TOLERANCE.1),
        };
        let at = |p: crate::lathe::Pt, pos: &Position| {
            let mut t = *pos;
            t[0] = p.im + off[0];
            t[2] = p.re + off[2];
            t
        };
        // The moves are checked whole before any is sent: a refused cycle moves nothing.
        let mut planned = Vec::with_capacity(moves.len());
        let mut pos = self.comp_entry.unwrap_or(self.pos);
        let mut last = None;
        for m in moves {
            let (kind, to, f) = match m {
                crate::lathe::ProfileMove::Rapid(p) => (MoveKind::Rapid, at(p, &pos), 0.0),
                crate::lathe::ProfileMove::Feed(p) => (MoveKind::Linear, at(p, &pos), feed),
                crate::lathe::ProfileMove::Arc { ccw, center, to } => {
                    let t = at(to, &pos);
                    // rs274 makes no arc to where the tool already is (within 0.0001).
                    if (t[0] - pos[0]).abs() < 1e-4 && (t[2] - pos[2]).abs() < 1e-4 {
                        continue;
                    }
                    let c = at(center, &pos);
                    let r1 = (pos[0] - c[0]).hypot(pos[2] - c[2]);
                    let r2 = (t[0] - c[0]).hypot(t[2] - c[2]);
                    let diff = (r1 - r2).abs();
                    if r1 < radius_tol
                        || r2 < radius_tol
                        || diff > 100.0 * spiral_tol
                        || (diff / r1.max(r2) > ARC_SPIRAL_RELATIVE && diff > spiral_tol)
                    {
                        return Err(rec.error(&format!(
                            "an arc of the offset profile has radii {r1:.6} at its start and {r2:.6} at its end"
                        )));
                    }
                    (
                        MoveKind::Arc {
                            clockwise: !ccw,
                            center: [c[0], c[1], c[2]],
                            plane: Plane::XZ,
                            turns: 1,
                        },
                        t,
                        feed,
                    )
                }
            };
            pos = to;
            last = Some(match kind {
                MoveKind::Rapid => Motion::Rapid,
                MoveKind::Arc {
                    clockwise: true, ..
                } => Motion::ArcCw,
                MoveKind::Arc { .. } => Motion::ArcCcw,
                _ => Motion::Linear,
            });
            planned.push((kind, to, f));
        }
        let kept = rec.line;
        if let (Some(comp), Some(entry)) = (self.comp.as_deref(), self.comp_entry.take()) {
            // Under cutter compensation (a G70): the rapid to its start and its moves go
            // through the compensation in force, all checked before any is sent.
            let mut trial = comp.clone();
            let mut pieces = Vec::new();
            let plane = self.modal.plane;
            let tag = |to: Position, feed: f64| CompTag {
                line: kept,
                to,
                feed,
                origin: Origin::CannedCycle,
            };
            trial
                .straight(
                    true,
                    plane_point(plane, &entry),
                    tag(entry, 0.0),
                    &mut pieces,
                )
                .map_err(|e| rec.error(&format!("cutter compensation: {e}")))?;
            // rs274 reads the profile's subroutine after that rapid, and its reading
            // leaves its tool position at the profile's last point (the programmed
            // point stays the cycle's start): found against rs274, which starts the
            // first pass from there.
            let off = self.offset();
            let mut last_read = entry;
            last_read[0] = rec.at.im + off[0];
            last_read[2] = rec.at.re + off[2];
            trial.tool_at(plane_point(plane, &last_read));
            for (kind, to, f) in &planned {
                let p = plane_point(plane, to);
                let done = match *kind {
                    MoveKind::Arc {
                        clockwise, center, ..
                    } => {
                        let c = plane_centre(plane, center);
                        trial.arc(!clockwise, c, p, tag(*to, *f), &mut pieces)
                    }
                    MoveKind::Rapid => trial.straight(true, p, tag(*to, *f), &mut pieces),
                    _ => trial.straight(false, p, tag(*to, *f), &mut pieces),
                };
                done.map_err(|e| rec.error(&format!("cutter compensation: {e}")))?;
            }
            finite(&pieces).map_err(|e| rec.error(&format!("cutter compensation: {e}")))?;
            let b_warn = rec.warning();
            out(Event::Diagnostic(b_warn));
            self.send_pieces(&trial, pieces, out);
            self.pos = planned.last().map_or(entry, |m| m.1);
            self.comp = Some(Box::new(trial));
            self.modal.motion = last.unwrap_or(self.modal.motion);
            return Ok(());
        }
        let b_warn = rec.warning();
        out(Event::Diagnostic(b_warn));
        for (kind, to, f) in planned {
            self.emit(kept, kind, to, f, Origin::CannedCycle, out);
        }
        self.modal.motion = match last {
            Some(m) => m,
            None => match rec.motion {
                0 => Motion::Rapid,
                10 => Motion::Linear,
                20 => Motion::ArcCw,
                30 => Motion::ArcCcw,
                _ => self.modal.motion,
            },
        };
        Ok(())
    }

    /// An arc centre word (I, J, K) on a straight move: a missing G2/G3, most likely.
    /// LinuxCNC refuses it (as rs274 and grbl do); elsewhere a warning (Haas lathes
    /// chamfer with I/K on G01, and printers ignore them).
    /// An R word on a straight move (G0, G1), which no code of the block reads: rs274
    /// refuses the block ("R word with no g code that uses it"), and a lathe control
    /// (Haas; Fanuc without the comma) rounds the corner at the move's end with it, so
    /// dropping it would move the tool where no control does: refused in every flavour
    /// but a printer's. In a recognised lathe program, a C (or I, K) on a G1 (`feed`)
    /// that moves X or Z alone is the lathe's chamfer at the move's end, not a C-axis
    /// turn (nor an arc's centre): refused too, by name.
    fn corner_words(&self, b: &Block<'_>, w: &Words<'_, '_>, feed: bool) -> Res<()> {
        let refuse = |word: &Word<'_>, what: &'static str| {
            Err(diag(
                b,
                Severity::Error,
                ErrorKind::CornerWord {
                    word: word.display(),
                    what,
                },
                Some(word.span),
            ))
        };
        if let Some(r) = w.word(b'R') {
            if !self.opts.flavor.is_slicer() && self.opts.e_word != EWord::Extrusion {
                return refuse(
                    r,
                    "no code of the block reads R (rs274 refuses it: \"R word with no g code that uses it\"); a lathe control rounds the corner at the end of the move with radius R, which lampost does not simulate",
                );
            }
        }
        let chamfer = [b'C', b'I', b'K'].into_iter().find_map(|l| w.word(l));
        if let Some(c) = chamfer.filter(|_| feed && self.lathe.recognised()) {
            let along = |l: u8| w.word(l).is_some();
            let xz = [b'X', b'Z', b'U', b'W']
                .into_iter()
                .filter(|&l| along(l))
                .count();
            let others = [b'Y', b'A', b'B', b'V'].into_iter().any(along);
            if xz == 1 && !others {
                return refuse(
                    c,
                    "in a lathe program a C, I or K on a G1 that moves X or Z alone is a chamfer at the end of the move (Haas lathe; Fanuc's chamfering), not a turn of the C axis or an arc's centre; lampost does not simulate it",
                );
            }
        }
        Ok(())
    }

    /// RepRapFirmware's `G1 H1 X-1000` (H1, H3, H4: the move stops where an endstop
    /// triggers, as homing macros write it; H2: each motor moved on its own): where the
    /// head ends is not known, so the move is warned of (traced to its programmed end),
    /// and the post refuses it. It used to be traced to X-1000 with no word.
    fn endstop_move(&self, b: &Block<'_>, w: &Words<'_, '_>, out: &mut impl FnMut(Event)) {
        if self.opts.flavor != crate::flavor::Flavor::RepRap {
            return;
        }
        let Some(h) = w.word(b'H').filter(|h| h.value != 0.0) else {
            return;
        };
        let code = w
            .g_in(GGroup::Motion)
            .map_or_else(|| "a move".to_string(), |(gw, _)| gw.display_code());
        self.warn(
            b,
            out,
            ErrorKind::NotSimulated(format!(
                "{code} {} (RepRapFirmware: the move stops where an endstop triggers, or moves the motors one by one; the trace goes to its programmed end)",
                h.display()
            )),
            Some(h.span),
        );
    }

    /// A lathe's spindle speed limit `G92 S…` with no axis word (Fanuc lathe G-code
    /// systems B and C), outside LinuxCNC and printers: nothing moves, and the block is
    /// one of the signs of a lathe program (said by `lathe_signs`).
    fn spindle_limit(&self, w: &Words<'_, '_>) -> bool {
        self.reads_lathe_signs() && !w.has_axes() && w.word(b'S').is_some()
    }

    /// Whether the flavour's programs may be a Fanuc or Haas lathe's (not LinuxCNC's,
    /// whose lathe programs rs274 reads as lampost does, nor a printer's).
    fn reads_lathe_signs(&self) -> bool {
        self.opts.flavor != crate::flavor::Flavor::LinuxCnc
            && !self.opts.flavor.is_slicer()
            && self.opts.e_word != EWord::Extrusion
    }

    /// The signs of a lathe program in a block (`turning.rs`), said once, at the block
    /// that completes them, as a warning at the word that showed it.
    fn lathe_signs(&mut self, b: &Block<'_>, w: &Words<'_, '_>, out: &mut impl FnMut(Event)) {
        if !self.reads_lathe_signs() {
            return;
        }
        for (sign, words, span) in self.signs_of(w) {
            if let Some(evidence) = self.lathe.observe(b.line, sign, &words) {
                self.warn(b, out, ErrorKind::LatheProgram(evidence), Some(span));
                return;
            }
        }
    }

    /// A block's signs of a lathe program, with the words that show each and where.
    fn signs_of(
        &self,
        w: &Words<'_, '_>,
    ) -> smallvec::SmallVec<[(crate::turning::Sign, String, crate::ast::Span); 2]> {
        use crate::turning::Sign;
        let mut signs = smallvec::SmallVec::new();
        let with = |code: &Word<'_>, letters: &[u8]| {
            let mut text = code.display_code();
            for word in letters.iter().filter_map(|&l| w.word(l)) {
                text.push(' ');
                text.push_str(&word.display());
            }
            text
        };
        for &(gw, c, _) in &w.gs {
            let sign = match c {
                500 if w.word(b'S').is_some() && !w.has_axes() => {
                    Sign::Sure("a lathe's spindle speed limit")
                }
                500 if w.word(b'X').is_some() || w.word(b'Z').is_some() => {
                    Sign::Sure("a lathe's coordinate system setting")
                }
                920 if self.spindle_limit(w) => {
                    Sign::Sure("a lathe's spindle speed limit, G-code systems B and C")
                }
                700 | 710 | 720 if w.word(b'P').is_some() && w.word(b'Q').is_some() => {
                    Sign::Sure("a lathe's finishing or roughing cycle over the blocks P to Q")
                }
                760 if w.word(b'D').is_some() => Sign::Sure("a lathe's threading cycle"),
                180 => Sign::PlaneXz,
                960 => Sign::SurfaceSpeed,
                280 | 300 if w.word(b'U').is_some() || w.word(b'W').is_some() => {
                    Sign::IncrementalXz
                }
                _ => continue,
            };
            let words = match sign {
                Sign::Sure(_) => with(gw, b"XZSPQD"),
                Sign::IncrementalXz => with(gw, b"UW"),
                _ => gw.display_code(),
            };
            signs.push((sign, words, gw.span));
        }
        if let Some(t) = w.word(b'T') {
            if crate::turning::tool_and_offset(t.text) {
                signs.push((Sign::ToolAndOffset, t.display(), t.span));
            }
        }
        if let Some(r) = w.word(b'R') {
            let straight = match w.g_in(GGroup::Motion) {
                Some((_, c)) => matches!(c, 0 | 10),
                None => w.has_axes() && matches!(self.modal.motion, Motion::Rapid | Motion::Linear),
            };
            if straight && w.gs.iter().all(|g| g.2 != GGroup::NonModal) {
                signs.push((Sign::CornerRadius, r.display(), r.span));
            }
        }
        signs
    }

    fn centre_words_unused(
        &self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        let Some(word) = [b'I', b'J', b'K'].iter().find_map(|&l| w.word(l)) else {
            return Ok(());
        };
        let kind = ErrorKind::CentreWordWithoutArc(word.letter_char());
        if self.opts.flavor == crate::flavor::Flavor::LinuxCnc {
            return Err(diag(b, Severity::Error, kind, Some(word.span)));
        }
        self.warn(b, out, kind, Some(word.span));
        Ok(())
    }

    fn arc(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        target: Position,
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        let cw = self.modal.motion == Motion::ArcCw;
        let plane = self.modal.plane;
        let (u, v, n) = plane.axes();
        let centre_letter = |axis: usize| [b'I', b'J', b'K'][axis];
        // A centre word of the plane's normal axis is a mistake; a zero one changes
        // nothing (FreeCAD's grbl post writes `K0.000` on every G17 arc, and grbl takes
        // it): warned, and refused only for LinuxCNC, as rs274 refuses it.
        if let Some(word) = w.word(centre_letter(n)) {
            if word.value == 0.0 && self.opts.flavor != crate::flavor::Flavor::LinuxCnc {
                if !self.warned_normal_centre {
                    self.warned_normal_centre = true;
                    self.warn(
                        b,
                        out,
                        ErrorKind::ArcNormalCentreZero(word.letter_char()),
                        Some(word.span),
                    );
                }
            } else {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::ArcWrongPlaneWord(word.letter_char()),
                    Some(word.span),
                ));
            }
        }
        let radius_word = w.word(b'R').or(w.registers[0]);
        let has_ijk = w.word(centre_letter(u)).is_some() || w.word(centre_letter(v)).is_some();
        let turns = match w.word(b'P') {
            // A printer's firmware reads an arc's P its own way, or not at all (h62): P0
            // and P1 are the arc itself on every reading of the files slicers write
            // (BambuStudio's and Creality Print's lifts say `P1`); more turns are refused.
            Some(p) if self.opts.flavor.is_slicer() && (p.value == 0.0 || p.value == 1.0) => 1,
            Some(p) if self.opts.flavor.is_slicer() => {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::BadValue {
                        word: p.display(),
                        why: "an arc's P of 2 or more means other turns on each printer firmware (Marlin built with ARC_P_CIRCLES makes P whole circles before the arc, other Marlin builds, Klipper and RepRapFirmware ignore it): write each circle as an arc of its own",
                    },
                    Some(p.span),
                ))
            }
            Some(p) if p.value > f64::from(MAX_REPEATS) => {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::BadValue {
                        word: p.display(),
                        why: "more than 10000 turns",
                    },
                    Some(p.span),
                ))
            }
            Some(p) if p.value >= 1.0 && p.value.fract() == 0.0 => p.value as u32,
            Some(p) => {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::BadValue {
                        word: p.display(),
                        why: "the number of turns P is a whole number of at least 1",
                    },
                    Some(p.span),
                ))
            }
            None => 1,
        };
        let radius_tol = match self.modal.units {
            Units::Inch => ARC_RADIUS_TOLERANCE.0,
            Units::Mm => ARC_RADIUS_TOLERANCE.1,
        };
        // In a lathe's diameters (see [`Interpreter::diameter_scale`]).
        let (ku, kv) = (self.diameter_scale(u), self.diameter_scale(v));
        let (su, sv) = (self.pos[u] * ku, self.pos[v] * kv);
        let (eu, ev) = (target[u] * ku, target[v] * kv);
        let (cu, cv) = match (has_ijk, radius_word) {
            (true, Some(r)) => {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::ArcBothForms,
                    Some(r.span),
                ))
            }
            (false, None) => {
                return Err(diag(b, Severity::Error, ErrorKind::ArcWithoutCenter, None))
            }
            (true, None) => {
                let iu = w.get(centre_letter(u)).unwrap_or(0.0);
                let iv = w.get(centre_letter(v)).unwrap_or(0.0);
                self.centre_of(iu, iv, &target, self.modal.arc_distance)
                    .map_err(|kind| {
                        let kind = self.centre_looks_absolute(iu, iv, &target, kind);
                        diag(b, Severity::Error, kind, None)
                    })?
            }
            (false, Some(rw)) => {
                let r = rw.value;
                let (du, dv) = (eu - su, ev - sv);
                let d = du.hypot(dv);
                if r == 0.0 {
                    return Err(diag(
                        b,
                        Severity::Error,
                        ErrorKind::ArcZeroRadius,
                        Some(rw.span),
                    ));
                }
                if d <= 1e-12 {
                    return Err(diag(
                        b,
                        Severity::Error,
                        ErrorKind::ArcRadiusFullCircle,
                        Some(rw.span),
                    ));
                }
                let half = d / 2.0;
                let h2 = r * r - half * half;
                let h = if h2 >= 0.0 {
                    h2.sqrt()
                } else if half - r.abs() <= radius_tol {
                    0.0
                } else {
                    return Err(diag(
                        b,
                        Severity::Error,
                        ErrorKind::ArcRadiusTooSmall {
                            radius: r.abs(),
                            half_chord: half,
                        },
                        Some(rw.span),
                    ));
                };
                // Left normal of the chord; a short CCW arc has its centre on the left.
                let (lu, lv) = (-dv / d, du / d);
                let side = if cw == (r < 0.0) { 1.0 } else { -1.0 };
                let c = (su + du / 2.0 + side * h * lu, sv + dv / 2.0 + side * h * lv);
                if !(c.0.is_finite() && c.1.is_finite()) {
                    // R near the largest number: its square, and the centre, are beyond.
                    return Err(diag(
                        b,
                        Severity::Error,
                        ErrorKind::BadValue {
                            word: rw.display(),
                            why: "the arc's centre at this radius is beyond any number",
                        },
                        Some(rw.span),
                    ));
                }
                (c.0 / ku, c.1 / kv)
            }
        };
        let feed = self.feed_for(b, w, out)?;
        let mut center = [self.pos[0], self.pos[1], self.pos[2]];
        center[u] = cu;
        center[v] = cv;
        self.emit_comp(
            b,
            MoveKind::Arc {
                clockwise: cw,
                center,
                plane,
                turns,
            },
            target,
            feed,
            Origin::Block,
            out,
        )
    }

    /// A block's move, through cutter compensation when it is simulated (`comp.rs`):
    /// held until the next move says where it ends; a refusal is located at the block.
    fn emit_comp(
        &mut self,
        b: &Block<'_>,
        kind: MoveKind,
        to: Position,
        feed: f64,
        origin: Origin,
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        if self.comp.is_none() {
            self.emit(b.line, kind, to, feed, origin, out);
            return Ok(());
        }
        if origin == Origin::MachineCoords {
            return Err(comp_diag(
                b,
                crate::comp::CompError("Cannot use G53 with cutter radius compensation"),
                None,
            ));
        }
        let tag = CompTag {
            line: b.line,
            to,
            feed,
            origin,
        };
        self.comp_move(kind, tag, out)
            .map_err(|e| comp_diag(b, e, None))
    }

    /// One programmed move into the compensation in force; what it lets go is sent.
    fn comp_move(
        &mut self,
        kind: MoveKind,
        tag: CompTag,
        out: &mut impl FnMut(Event),
    ) -> Result<(), crate::comp::CompError> {
        let plane = self.modal.plane;
        let Some(mut comp) = self.comp.take() else {
            self.emit(tag.line, kind, tag.to, tag.feed, tag.origin, out);
            return Ok(());
        };
        let mut pieces = Vec::new();
        let p = plane_point(plane, &tag.to);
        let done = match kind {
            MoveKind::Arc {
                clockwise,
                center,
                turns,
                ..
            } => {
                if turns != 1 {
                    Err(crate::comp::CompError(
                        "an arc of more than one turn under cutter compensation (lampost does not simulate it)",
                    ))
                } else {
                    comp.arc(
                        !clockwise,
                        plane_centre(plane, center),
                        p,
                        tag,
                        &mut pieces,
                    )
                }
            }
            MoveKind::Rapid => comp.straight(true, p, tag, &mut pieces),
            _ => comp.straight(false, p, tag, &mut pieces),
        }
        .and_then(|()| finite(&pieces));
        self.send_pieces(&comp, pieces, out);
        if done.is_ok() {
            self.pos = tag.to;
        }
        self.comp = Some(comp);
        done
    }

    /// Compensation ends (G40, the program's end): the held moves go as they are.
    fn comp_release(
        &mut self,
        mut comp: crate::comp::Comp<CompTag>,
        out: &mut impl FnMut(Event),
    ) -> Result<(), crate::comp::CompError> {
        let mut pieces = Vec::new();
        let done = comp.finish(&mut pieces);
        self.send_pieces(&comp, pieces, out);
        // The tool stays where it was drawn.
        self.pos = self.comp_drawn;
        done
    }

    /// Compensated pieces as moves (machine frame), the lathe tool's origin applied.
    fn send_pieces(
        &mut self,
        comp: &crate::comp::Comp<CompTag>,
        pieces: Vec<crate::comp::Piece<CompTag>>,
        out: &mut impl FnMut(Event),
    ) {
        use crate::comp::Shape;
        let plane = self.modal.plane;
        let xz = plane == Plane::XZ;
        let (u, v, _) = plane.axes();
        let programmed = self.pos;
        self.pos = self.comp_drawn;
        for piece in pieces {
            let t = piece.tag;
            let mut end = if piece.corner { self.pos } else { t.to };
            let q = comp.origin(piece.end, xz);
            end[u] = q[0];
            end[v] = q[1];
            let kind = match piece.shape {
                Shape::Straight { rapid: true } => MoveKind::Rapid,
                Shape::Straight { rapid: false } => MoveKind::Linear,
                Shape::Arc { center, turn } => {
                    let c = comp.origin(center, xz);
                    let mut centre = [end[0], end[1], end[2]];
                    centre[u] = c[0];
                    centre[v] = c[1];
                    MoveKind::Arc {
                        clockwise: turn < 0,
                        center: centre,
                        plane,
                        turns: 1,
                    }
                }
            };
            let feed = if kind == MoveKind::Rapid { 0.0 } else { t.feed };
            if end.iter().all(|x| x.is_finite()) {
                self.emit(t.line, kind, end, feed, t.origin, out);
            }
        }
        self.comp_drawn = self.pos;
        self.pos = programmed;
    }

    /// What turns a position along `axis` into a distance from the turning axis: ½ for
    /// X in a program recognised as a Fanuc or Haas lathe's, which gives X as a
    /// diameter and its arcs' I and R as radii (a turned arc from X0.32 to X0.36 with
    /// K-0.02 is a 0.02 radius at both ends); else 1. Arcs are checked, and their
    /// centres found, in such distances, the centre then given back in the program's X.
    fn diameter_scale(&self, axis: usize) -> f64 {
        if axis == 0
            && self.lathe.recognised()
            && self.opts.flavor != crate::flavor::Flavor::LinuxCnc
        {
            0.5
        } else {
            1.0
        }
    }

    /// The centre (in the plane's axes) of an arc from the tool's position to `target`
    /// given by its centre words `iu`, `iv`, with LinuxCNC's checks: not a zero radius,
    /// and the radii at the two ends within the spiral tolerance.
    fn centre_of(
        &self,
        iu: f64,
        iv: f64,
        target: &Position,
        arc_distance: Distance,
    ) -> Result<(f64, f64), ErrorKind> {
        let (u, v, _) = self.modal.plane.axes();
        let (spiral_tol, radius_tol) = match self.modal.units {
            Units::Inch => (ARC_SPIRAL_TOLERANCE.0, ARC_RADIUS_TOLERANCE.0),
            Units::Mm => (ARC_SPIRAL_TOLERANCE.1, ARC_RADIUS_TOLERANCE.1),
        };
        let (ku, kv) = (self.diameter_scale(u), self.diameter_scale(v));
        let (su, sv) = (self.pos[u] * ku, self.pos[v] * kv);
        let (eu, ev) = (target[u] * ku, target[v] * kv);
        let (cu, cv) = match arc_distance {
            Distance::Incremental => (su + iu, sv + iv),
            Distance::Absolute => {
                let off = self.offset();
                ((iu + off[u]) * ku, (iv + off[v]) * kv)
            }
        };
        let r1 = (su - cu).hypot(sv - cv);
        let r2 = (eu - cu).hypot(ev - cv);
        if r1 < radius_tol || r2 < radius_tol {
            return Err(ErrorKind::ArcZeroRadius);
        }
        let diff = (r1 - r2).abs();
        let relative = diff / r1.max(r2);
        if diff > 100.0 * spiral_tol || (relative > ARC_SPIRAL_RELATIVE && diff > spiral_tol) {
            return Err(ErrorKind::ArcRadiusMismatch {
                start: r1,
                end: r2,
                diff,
                tolerance: spiral_tol,
            });
        }
        Ok((cu / ku, cv / kv))
    }

    /// An arc refused under incremental centres (`kind`) that its centre words, read as
    /// the centre's position, make whole: said as [`ErrorKind::ArcCentreLooksAbsolute`]
    /// (a program written for absolute arc centres, with no G90.1). Any other refusal
    /// is `kind` itself.
    fn centre_looks_absolute(
        &self,
        iu: f64,
        iv: f64,
        target: &Position,
        kind: ErrorKind,
    ) -> ErrorKind {
        if self.modal.arc_distance != Distance::Incremental {
            return kind;
        }
        let Ok((cu, cv)) = self.centre_of(iu, iv, target, Distance::Absolute) else {
            return kind;
        };
        let (u, v, _) = self.modal.plane.axes();
        let radius = (self.pos[u] - cu).hypot(self.pos[v] - cv);
        ErrorKind::ArcCentreLooksAbsolute {
            why: kind.to_string(),
            radius,
        }
    }

    fn canned_cycle(
        &mut self,
        b: &Block<'_>,
        w: &Words<'_, '_>,
        code: u16,
        out: &mut impl FnMut(Event),
    ) -> Res<()> {
        let name = code_text(code);
        // The holes are placed in the plane, and drilled along its normal axis (Z in
        // G17, Y in G18, X in G19), as rs274 drills them: `canned.z` holds the depth
        // along that axis.
        let (u, v, n) = self.modal.plane.axes();
        let depth_letter = AXES[n];
        if let Some(depth) = w.get(depth_letter) {
            self.canned.z = Some(depth);
        }
        if let Some(r) = w.get(b'R').or(w.registers[0].map(|r| r.value)) {
            self.canned.r = Some(r);
        }
        if let Some(q) = w.get(b'Q') {
            self.canned.q = Some(q);
        }
        if let Some(p) = w.get(b'P') {
            self.canned.p = p;
        }
        if self.opts.flavor == crate::flavor::Flavor::Fadal
            && matches!(code, 742 | 842)
            && !w.has_axes()
            && w.get(b'R').is_none()
        {
            // Fusion's FADAL post: `G84.2` (`G74.2`) alone selects rigid tapping for the
            // `G84.1` (`G74.1`) after it; nothing moves.
            return Ok(());
        }
        let (Some(zv), Some(rv)) = (self.canned.z, self.canned.r) else {
            return Err(diag(
                b,
                Severity::Error,
                ErrorKind::CannedCycleIncomplete {
                    code: name,
                    // The words missing, and only those (rs274: "R clearance plane
                    // unspecified in cycle").
                    what: match (n, self.canned.z.is_none(), self.canned.r.is_none()) {
                        (_, false, _) => "R (the retract plane)",
                        (2, true, false) => "Z (the depth)",
                        (2, true, true) => "Z (the depth) and R (the retract plane)",
                        (1, true, false) => "Y (the depth, along the normal of the G18 plane)",
                        (1, true, true) => {
                            "Y (the depth, along the normal of the G18 plane) and R (the retract plane)"
                        }
                        (_, true, false) => "X (the depth, along the normal of the G19 plane)",
                        (_, true, true) => {
                            "X (the depth, along the normal of the G19 plane) and R (the retract plane)"
                        }
                    },
                },
                None,
            ));
        };
        if self.opts.post_notes && self.canned.p > 0.0 {
            let what = format!(
                "G{name}'s P{} (a dwell at the bottom of each hole)",
                crate::decimal::Readable(self.canned.p)
            );
            self.warn(b, out, ErrorKind::DwellLeftOut(what), None);
        }
        let passthrough = matches!(code, 740..=742 | 760 | 870 | 880);
        let needs_q = matches!(code, 730 | 830);
        let q = self.canned.q.unwrap_or(0.0);
        if needs_q && q <= 0.0 && self.opts.flavor == crate::flavor::Flavor::Fadal {
            if let Some(i) = w.word(b'I') {
                // Fusion's FADAL post writes a peck that shrinks as I (first peck), J
                // (reduction) and K (least peck) instead of Q.
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::BadValue {
                        word: format!("G{name} {}", i.display()),
                        why: "a FADAL peck given by I, J and K (the first peck, its reduction, the least peck) is not simulated; post the operation with a constant peck (Q), without peck reduction",
                    },
                    Some(i.span),
                ));
            }
        }
        if needs_q && q <= 0.0 {
            return Err(diag(
                b,
                Severity::Error,
                ErrorKind::CannedCycleIncomplete {
                    code: name,
                    what: "a positive peck depth Q",
                },
                None,
            ));
        }
        let repeats = match w.word(b'L') {
            Some(l) if l.value > f64::from(MAX_REPEATS) => {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::BadValue {
                        word: l.display(),
                        why: "more than 10000 repeats; split the pattern",
                    },
                    Some(l.span),
                ))
            }
            Some(l) if l.value >= 1.0 && l.value.fract() == 0.0 => l.value as u32,
            Some(l) if l.value == 0.0 => 0,
            Some(l) => {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::BadValue {
                        word: l.display(),
                        why: "the repeat count L is a whole number",
                    },
                    Some(l.span),
                ))
            }
            None => 1,
        };
        let off = self.offset();
        let fadal = self.opts.flavor == crate::flavor::Flavor::Fadal;
        let incremental = self.modal.distance == Distance::Incremental;
        if fadal && incremental && (w.get(depth_letter).is_some() || w.get(b'R').is_some()) {
            // The FADAL takes a cycle's Z and R0 in absolute only ("BAD Z OR R0 IN
            // CANNED CYCLE … canned cycle not stated in absolute as required").
            return Err(diag(
                b,
                Severity::Error,
                ErrorKind::BadValue {
                    word: format!("G{name} under G91"),
                    why: "a FADAL takes a canned cycle's Z and R0 in absolute only (its error BAD Z OR R0 IN CANNED CYCLE); state the cycle under G90, then G91 may step the holes (for a program written for another control, give its --flavor)",
                },
                None,
            ));
        }
        // A FADAL keeps the Z and R0 stated (in absolute) for the holes after, G91
        // stepping X and Y only (its manual: `G81 G98 Z-.1 R0+.1 … M45`, then `G91 X.5
        // L20` "drills twenty holes in the X axis .5 apart"); elsewhere G91 reads them
        // as distances, as Fanuc, Haas and rs274 do.
        let depth_incremental = incremental && !fadal;
        // The initial level: where Z was when this series of cycles began (rs274's
        // `cycle_il`; Fanuc's and Haas's "initial point", the Z before the cycle was
        // first given), in every flavour: after a G99 hole the tool is at R, and a later
        // G98 still returns to that level, and G91's R still counts from it.
        let initial = *self.canned.initial_z.get_or_insert(self.pos[n]);
        let (r_abs, bottom) = if depth_incremental {
            let r = initial + rv;
            (r, r + zv)
        } else {
            (rv + off[n], zv + off[n])
        };
        // Fanuc's and Haas's G87 bores back, upward: from R below the part to Z above it
        // (the Fanuc 0i-MF and Haas mill manuals; Fusion's Fanuc post writes it so), so
        // there Z above R is the cycle's shape. LinuxCNC's G87 (and Mach3's) gives the
        // bottom in Z and the top of the bore in K.
        let back_bore = code == 870
            && matches!(
                self.opts.flavor,
                crate::flavor::Flavor::Fanuc | crate::flavor::Flavor::Haas
            );
        if bottom > r_abs && !back_bore {
            return Err(diag(
                b,
                Severity::Error,
                ErrorKind::BadValue {
                    word: format!("G{name} {}", char::from(depth_letter)),
                    why: match n {
                        2 => "the hole bottom Z is above the R plane",
                        1 => "the hole bottom Y (the depth in G18) is above the R plane",
                        _ => "the hole bottom X (the depth in G19) is above the R plane",
                    },
                },
                w.word(depth_letter).map(|d| d.span),
            ));
        }
        // Pecks per hole, counted before any is made, as rs274 makes them: feeds to
        // R − Q, then Q deeper than the last (each worked out from the last, so rounding
        // decides as it does there) while above the bottom, then one to the bottom. A Q
        // below the spacing of numbers at the depth (`depth - q == depth`) never gets
        // deeper: LinuxCNC would loop without end; here it is over the bound.
        let pecks = if needs_q && !passthrough {
            let mut per_hole = 1.0;
            let mut depth = r_abs - q;
            while depth > bottom && per_hole <= f64::from(MAX_PECKS) {
                per_hole += 1.0;
                let next = depth - q;
                if next >= depth {
                    per_hole = f64::INFINITY;
                    break;
                }
                depth = next;
            }
            let total = per_hole * f64::from(repeats);
            if total.is_nan() || total > f64::from(MAX_PECKS) {
                return Err(diag(
                    b,
                    Severity::Error,
                    ErrorKind::BadValue {
                        word: w
                            .word(b'Q')
                            .map_or_else(|| format!("G{name} Q{q}"), |q| q.display()),
                        why:
                            "more than 10000 pecks in one block; make Q larger or split the pattern",
                    },
                    w.word(b'Q').map(|q| q.span),
                ));
            }
            per_hole as u32
        } else {
            0
        };
        let feed = if passthrough {
            0.0
        } else {
            self.feed_for(b, w, out)?
        };
        // The holes of polar words (program XY): every repeat's, found before any move
        // is made, so a step that fails refuses the block whole.
        let polar = w.polar();
        let mut hole = self.program_xy();
        if let Some(p) = polar {
            let refused = |why| diag(b, Severity::Error, ErrorKind::Polar(why), w.polar_span());
            if incremental {
                let mut at = hole;
                for _ in 0..repeats {
                    at = p.cycle_step(at).map_err(refused)?;
                }
            } else {
                hole = p.cycle_hole(hole).map_err(refused)?;
            }
        }
        // A point of `p` at the level `z` along the plane's normal axis.
        let at = |p: Position, z: f64| {
            let mut q = p;
            q[n] = z;
            q
        };
        // As rs274's `CYCLE_MACRO`: below the initial level's R plane, up to it first;
        // the clearance level is R (G99) or the initial level, raised to R (G98).
        let mut level = initial;
        let mut first_z = self.pos[n];
        if level < r_abs && !passthrough {
            let t = at(self.pos, r_abs);
            self.emit(b.line, MoveKind::Rapid, t, 0.0, Origin::CannedCycle, out);
            level = r_abs;
            first_z = r_abs;
        }
        let clear = match self.modal.retract {
            Retract::InitialZ => level.max(r_abs),
            Retract::RPlane => r_abs,
        };
        let delta = 0.010 * 25.4 / self.modal.units.mm();
        if passthrough {
            self.warn(b, out, ErrorKind::CannedCyclePassedThrough(name), None);
        }
        for k in 0..repeats {
            let mut xy = self.pos;
            if let Some(p) = polar {
                if incremental {
                    // Checked above: the same steps succeed again.
                    hole = p.cycle_step(hole).unwrap_or(hole);
                }
                [xy[0], xy[1]] = self.machine_xy(hole);
            }
            for a in [u, v] {
                if let Some(value) = w.get(AXES[a]) {
                    xy[a] = if incremental {
                        self.pos[a] + value
                    } else {
                        value + off[a]
                    };
                }
            }
            if passthrough {
                xy[n] = clear;
                self.pos = xy;
                continue;
            }
            // Over the hole: the first at the tool's height when it is above R, else at
            // the clearance level; then down to R.
            let over = if k == 0 && first_z > r_abs {
                first_z
            } else {
                clear
            };
            let t = at(xy, over);
            self.emit(b.line, MoveKind::Rapid, t, 0.0, Origin::CannedCycle, out);
            if over > r_abs {
                let t = at(self.pos, r_abs);
                self.emit(b.line, MoveKind::Rapid, t, 0.0, Origin::CannedCycle, out);
            }
            match code {
                730 | 830 => {
                    let mut depth = r_abs;
                    for k in 1..=pecks {
                        if depth <= bottom {
                            break;
                        }
                        // The last peck reaches the bottom whatever the rounding did.
                        let next = if k == pecks {
                            bottom
                        } else {
                            (depth - q).max(bottom)
                        };
                        if code == 830 && depth < r_abs {
                            let t = at(self.pos, depth + delta);
                            self.emit(b.line, MoveKind::Rapid, t, 0.0, Origin::CannedCycle, out);
                        }
                        let t = at(self.pos, next);
                        self.emit(b.line, MoveKind::Linear, t, feed, Origin::CannedCycle, out);
                        depth = next;
                        if depth > bottom {
                            let up = if code == 830 { r_abs } else { depth + delta };
                            let t = at(self.pos, up);
                            self.emit(b.line, MoveKind::Rapid, t, 0.0, Origin::CannedCycle, out);
                        }
                    }
                    let t = at(self.pos, clear);
                    self.emit(b.line, MoveKind::Rapid, t, 0.0, Origin::CannedCycle, out);
                }
                840 if self.opts.flavor == crate::flavor::Flavor::LinuxCnc => {
                    // LinuxCNC's tapping: feed in, then feed all the way out to the
                    // clearance level (rs274 makes no rapid).
                    let t = at(self.pos, bottom);
                    self.emit(b.line, MoveKind::Linear, t, feed, Origin::CannedCycle, out);
                    let t = at(self.pos, clear);
                    self.emit(b.line, MoveKind::Linear, t, feed, Origin::CannedCycle, out);
                }
                840..=843 | 850 => {
                    // Feed in, feed out to R, then rapid to the clearance level (a
                    // rigid tap too: the spindle reverses at the bottom).
                    let t = at(self.pos, bottom);
                    self.emit(b.line, MoveKind::Linear, t, feed, Origin::CannedCycle, out);
                    let t = at(self.pos, r_abs);
                    self.emit(b.line, MoveKind::Linear, t, feed, Origin::CannedCycle, out);
                    let t = at(self.pos, clear);
                    self.emit(b.line, MoveKind::Rapid, t, 0.0, Origin::CannedCycle, out);
                }
                890 => {
                    // Feed in, dwell, feed all the way out to the clearance level.
                    let t = at(self.pos, bottom);
                    self.emit(b.line, MoveKind::Linear, t, feed, Origin::CannedCycle, out);
                    let t = at(self.pos, clear);
                    self.emit(b.line, MoveKind::Linear, t, feed, Origin::CannedCycle, out);
                }
                _ => {
                    // 81, 82 (dwell at the bottom), 86 (spindle stops at the bottom).
                    let t = at(self.pos, bottom);
                    self.emit(b.line, MoveKind::Linear, t, feed, Origin::CannedCycle, out);
                    let t = at(self.pos, clear);
                    self.emit(b.line, MoveKind::Rapid, t, 0.0, Origin::CannedCycle, out);
                }
            }
            // Absolute repeats drill the same hole again; incremental ones step on.
        }
        Ok(())
    }
}

trait DisplayCode {
    fn display_code(&self) -> String;
}

impl DisplayCode for Word<'_> {
    fn display_code(&self) -> String {
        match self.code() {
            Some(c) => format!("{}{}", self.letter_char(), code_text(c)),
            None => self.display(),
        }
    }
}

/// A position's coordinates in the plane's own order (X, Y in G17; Z, X in G18), as
/// cutter compensation works in them (`comp.rs`).
fn plane_point(plane: Plane, p: &Position) -> [f64; 2] {
    let (u, v, _) = plane.axes();
    [p[u], p[v]]
}

/// An arc centre (X, Y, Z) in the plane's own order (see [`plane_point`]).
fn plane_centre(plane: Plane, c: [f64; 3]) -> [f64; 2] {
    let (u, v, _) = plane.axes();
    [c[u], c[v]]
}

/// What rs274 refuses while cutter compensation is on (simulated): another plane, turning
/// it on again, G28/G30; each located at its code.
fn comp_conflicts(b: &Block<'_>, w: &Words<'_, '_>, plane: Plane, units: Units) -> Res<()> {
    for &(gw, c, _) in &w.gs {
        let why = match c {
            170 if plane != Plane::XY => {
                "a change to the XY plane under compensation in the XZ plane (lampost does not simulate it)"
            }
            180 | 190 => "Cannot change planes with cutter radius compensation on",
            200 if units != Units::Inch => {
                "a change of units under cutter compensation (lampost does not simulate it)"
            }
            210 if units != Units::Mm => {
                "a change of units under cutter compensation (lampost does not simulate it)"
            }
            410 | 411 | 420 | 421 => "Cannot turn cutter radius comp on when on",
            280 | 300 => "Cannot use G28 or G30 with cutter radius comp",
            _ => continue,
        };
        return Err(comp_diag(b, crate::comp::CompError(why), Some(gw.span)));
    }
    Ok(())
}

/// Compensated points must be numbers (a path at the edge of `f64` may not offset).
fn finite<T>(pieces: &[crate::comp::Piece<T>]) -> Result<(), crate::comp::CompError> {
    let ok = pieces.iter().all(|p| {
        p.end.iter().all(|v| v.is_finite())
            && match p.shape {
                crate::comp::Shape::Arc { center, .. } => center.iter().all(|v| v.is_finite()),
                crate::comp::Shape::Straight { .. } => true,
            }
    });
    if ok {
        Ok(())
    } else {
        Err(crate::comp::CompError(
            "a compensated point is beyond any number",
        ))
    }
}

/// A cutter compensation refusal, located at its block.
fn comp_diag(
    b: &Block<'_>,
    e: crate::comp::CompError,
    span: Option<crate::ast::Span>,
) -> Diagnostic {
    diag(
        b,
        Severity::Error,
        ErrorKind::CutterComp(e.0),
        span.or(b.words().next().map(|w| w.span)),
    )
}

/// LinuxCNC's rs274 refuses a G38.2 or G38.4 (the probes that must trip) that does not
/// move at all ("Start point too close to probe point"); G38.3 and G38.5 may, and a probe
/// that turns only a rotary is run.
fn probe_must_move(b: &Block<'_>, w: &Words<'_, '_>, start: &Position, end: &Position) -> Res<()> {
    let Some(g) = w.gs.iter().find(|g| matches!(g.1, 382 | 384)) else {
        return Ok(());
    };
    if start == end {
        return Err(diag(
            b,
            Severity::Error,
            ErrorKind::BadValue {
                word: g.0.display_code(),
                why: "the probe does not move (LinuxCNC: start point too close to probe point)",
            },
            Some(g.0.span),
        ));
    }
    Ok(())
}

/// Where LinuxCNC's standalone rs274 leaves the tool after a straight probe (G38.x) that
/// no contact stops: its simulator lets the probe trip at the programmed `end` and backs
/// it off 0.01 in (0.254 mm) along the move towards its `start` (X, Y and Z only; a
/// probe of no length stays at its end). This models a simulator: a real probe stops
/// where it touches, which no trace knows. The probe's results (`#5061`…) hold `end`.
pub fn probe_rest(start: &Position, end: &Position, units: Units) -> Position {
    let back = match units {
        Units::Inch => 0.01,
        Units::Mm => 0.254,
    };
    let d = [start[0] - end[0], start[1] - end[1], start[2] - end[2]];
    let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let mut rest = *end;
    if length > 0.0 && length.is_finite() {
        for (r, di) in rest.iter_mut().zip(d) {
            *r += back * (di / length);
        }
    }
    rest
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    proptest! {
        /// A probe with no contact rests on its line, the back-off from its end towards
        /// its start (0.01 in, 0.254 mm), rotaries untouched; worked out here from the
        /// direction alone (no division by the length).
        #[test]
        fn probe_rest_backs_off_along_the_move(
            s in proptest::array::uniform9(-100.0f64..100.0),
            e in proptest::array::uniform9(-100.0f64..100.0),
            inch in any::<bool>(),
        ) {
            let units = if inch { Units::Inch } else { Units::Mm };
            let back = if inch { 0.01 } else { 0.254 };
            let r = probe_rest(&s, &e, units);
            let len = (0..3).map(|i| (s[i] - e[i]).powi(2)).sum::<f64>().sqrt();
            prop_assume!(len > 1e-6);
            let moved = (0..3).map(|i| (r[i] - e[i]).powi(2)).sum::<f64>().sqrt();
            prop_assert!((moved - back).abs() < 1e-9);
            for i in 0..3 {
                // Towards the start: each axis moves the start's way, in proportion.
                prop_assert!(((r[i] - e[i]) * len - back * (s[i] - e[i])).abs() < 1e-9 * (1.0 + len));
            }
            prop_assert_eq!(&r[3..], &e[3..]);
        }
    }

    #[test]
    fn probe_rest_of_a_probe_that_stands_still_is_its_end() {
        let p = [1.0, 2.0, 3.0, 4.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut q = p;
        q[3] = 9.0;
        assert_eq!(probe_rest(&q, &p, Units::Mm), p);
        // Worked by hand: straight down 2 in from Z1 to Z-1, backed off to Z-0.99.
        let s = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let e = [0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert!((probe_rest(&s, &e, Units::Inch)[2] + 0.99).abs() < 1e-15);
    }

    use super::*;
    use crate::stream::Stream;

    /// A spindle-synchronised move whose pitch times the spindle speed overflows is
    /// refused at its K, never moved at an infinite feed (fuzz, seed 20261128, input
    /// 905313: `G33.1 Z-0.95 K1.7976931348623157e308` at S200).
    #[test]
    fn a_thread_whose_feed_overflows_is_refused_at_its_pitch() {
        // K1 followed by 308 zeros: 1e308 (the default reading, FADAL's, has no
        // exponents), times S200.
        let k = format!("1{}.", "0".repeat(308));
        let (moves, diags) = run(&format!(
            "G21 G90\nS200 M3\nG0 X0 Y0 Z1\nG33.1 Z-0.95 K{k}\n"
        ));
        assert!(moves.iter().all(|m| m.feed.is_finite()), "{moves:?}");
        let e = diags.iter().find(|d| d.is_error()).expect("refused");
        assert_eq!((e.line, e.column), (4, 14), "{e}");
        assert!(e.to_string().contains("beyond any number"), "{e}");
    }

    /// Stops are reported where asked (`Options::stops`), after the block's motion: `M0`
    /// and `M60` stop, `M1` is the optional stop on a machine control and a stop on a
    /// printer (Marlin and RepRapFirmware stop on both). Not asked, there are none.
    #[test]
    fn stops_are_reported_after_the_block_s_motion_when_asked() {
        let text = "G21 G90\nG1 X1 F100 M0\nM1\nM60\nM3 S1\nM30\n";
        let events = |opts: Options| -> Vec<String> {
            Stream::from_bytes(text.as_bytes(), opts, false)
                .map(|e| match e.expect("in memory") {
                    Event::Move(m) => format!("move {}", m.line),
                    Event::Stop(s) => format!("{} {}", s.kind.code(), s.line),
                    Event::Diagnostic(d) => format!("{d}"),
                })
                .collect()
        };
        let asked = Options {
            stops: true,
            ..Options::default()
        };
        assert_eq!(events(asked), ["move 2", "M0 2", "M1 3", "M60 4"]);
        assert_eq!(events(Options::default()), ["move 2"]);
        let printer = Options {
            stops: true,
            e_word: EWord::Extrusion,
            flavor: crate::flavor::Flavor::Marlin,
            ..Options::default()
        };
        assert_eq!(events(printer), ["move 2", "M0 2", "M0 3", "M60 4"]);
    }

    /// Moves and diagnostics of `text`, every line read.
    fn run(text: &str) -> (Vec<Move>, Vec<Diagnostic>) {
        run_as(text, Options::default())
    }

    /// [`run`] read as a LinuxCNC program (G91 cycles, which a FADAL refuses).
    fn run_linuxcnc(text: &str) -> (Vec<Move>, Vec<Diagnostic>) {
        run_as(
            text,
            Options {
                flavor: crate::flavor::Flavor::LinuxCnc,
                ..Options::default()
            },
        )
    }

    fn run_as(text: &str, opts: Options) -> (Vec<Move>, Vec<Diagnostic>) {
        let (mut moves, mut diags) = (Vec::new(), Vec::new());
        for e in Stream::from_bytes(text.as_bytes(), opts, false) {
            match e.expect("in memory") {
                Event::Move(m) => moves.push(m),
                Event::Diagnostic(d) => diags.push(d),
                Event::Stop(_) => {}
            }
        }
        (moves, diags)
    }

    #[test]
    fn a_zero_centre_word_off_the_plane_is_ignored_but_for_linuxcnc() {
        // FreeCAD's grbl post: `K0.000` on every G17 arc (FreeCAD Path, real program in
        // fixtures/real-programs/freecad). Warned once, the arcs traced as without it.
        let text = "G17 G21 G90 G0 X0 Y0\nG2 X10 Y0 I5 J0 K0.000 F100\nG2 X0 Y0 I-5 J0 K0\n";
        let (moves, diags) = run(text);
        assert_eq!(diags.len(), 1, "{diags:?}");
        assert_eq!(diags[0].severity, Severity::Warning);
        assert_eq!((diags[0].line, diags[0].column), (2, 17));
        assert!(diags[0].to_string().contains("K0 is not a centre word"));
        let arcs: Vec<&Move> = moves
            .iter()
            .filter(|m| matches!(m.kind, MoveKind::Arc { .. }))
            .collect();
        assert_eq!(arcs.len(), 2);
        let (plain, _) = run("G17 G21 G90 G0 X0 Y0\nG2 X10 Y0 I5 J0 F100\nG2 X0 Y0 I-5 J0\n");
        assert_eq!(moves, plain);
        // Not zero: still refused, at the word; in G18 the normal word is J.
        let (_, diags) = run("G17 G0 X0 Y0\nG2 X10 Y0 I5 J0 K0.5 F100\n");
        assert_eq!(diags[0].severity, Severity::Error);
        assert!(diags[0].to_string().contains("K is not a centre word"));
        let (_, diags) = run("G18 G0 X0 Z0\nG2 X10 Z0 I5 K0 J0 F100\n");
        assert_eq!(diags[0].severity, Severity::Warning, "{diags:?}");
        assert!(diags[0].to_string().contains("J0 is not a centre word"));
        // LinuxCNC refuses it, as rs274 does ("K word given for arc in xy plane").
        let opts = Options {
            flavor: crate::flavor::Flavor::LinuxCnc,
            ..Options::default()
        };
        let diags: Vec<Diagnostic> = Stream::from_bytes(text.as_bytes(), opts, false)
            .filter_map(|e| match e.expect("in memory") {
                Event::Diagnostic(d) => Some(d),
                Event::Move(_) | Event::Stop(_) => None,
            })
            .collect();
        assert_eq!(diags[0].severity, Severity::Error);
        assert_eq!((diags[0].line, diags[0].column), (2, 17));
    }

    /// Found by the real-program corpus (h12cam): `G1 X1 I5` passed `check` silently;
    /// rs274 refuses it ("I word with no G2, G3, G87 to use it"), and so does grbl.
    #[test]
    fn a_centre_word_on_a_straight_move_is_named() {
        let text = "G17 G21 G90 G0 X0 Y0\nG1 X10 Y0 I5 F100\nG0 X0 J2\n";
        let (moves, diags) = run(text);
        assert_eq!(moves.len(), 3);
        assert_eq!(diags.len(), 2, "{diags:?}");
        assert!(diags.iter().all(|d| d.severity == Severity::Warning));
        assert_eq!((diags[0].line, diags[0].column), (2, 11));
        assert!(diags[0].to_string().contains("I word with no G2 or G3"));
        assert_eq!((diags[1].line, diags[1].column), (3, 7));
        let opts = Options {
            flavor: crate::flavor::Flavor::LinuxCnc,
            ..Options::default()
        };
        let first = Stream::from_bytes(text.as_bytes(), opts, false)
            .find_map(|e| match e.expect("in memory") {
                Event::Diagnostic(d) => Some(d),
                Event::Move(_) | Event::Stop(_) => None,
            })
            .expect("refused");
        assert_eq!(first.severity, Severity::Error);
        assert_eq!((first.line, first.column), (2, 11));
        // On an arc they are its centre; in a canned cycle or a thread they are its own.
        let (_, diags) = run("G17 G0 X0 Y0\nG2 X10 Y0 I5 J0 F100\n");
        assert!(diags.is_empty(), "{diags:?}");
    }

    #[test]
    fn peck_counts_are_bounded_and_end_at_the_bottom() {
        // `depth - q == depth`: the peck never gets deeper; refused, located at Q.
        for q in ["Q0.0000001", "Q0.000000000000000000001"] {
            let text = format!("G0 X0 Y0 Z0\nF10 G83 X1 R10000000000 Z9999999999.99 {q}\nG0 X5\n");
            let (moves, diags) = run(&text);
            assert_eq!(diags.len(), 1, "{diags:?}");
            assert_eq!((diags[0].line, diags[0].column), (2, 40));
            assert!(diags[0].to_string().contains("more than 10000 pecks"));
            assert_eq!(moves.len(), 2, "the next line is read");
        }
        // Repeats count: 10 deep in 0.1 pecks is 101 feeds a hole (the hundredth peck
        // lands a hair above the bottom, so a last short one goes to it, as rs274 makes
        // them); 99 holes are 9,999 feeds, and one more hole is refused.
        let (moves, diags) = run_linuxcnc("G91 F10 G83 X1 R0 Z-10 Q0.1 L99\n");
        assert!(diags.is_empty(), "{diags:?}");
        let feeds = moves.iter().filter(|m| m.kind == MoveKind::Linear).count();
        assert_eq!(feeds, 9_999);
        let (_, diags) = run_linuxcnc("G91 F10 G73 X1 R0 Z-10 Q0.1 L100\n");
        assert!(diags[0].to_string().contains("more than 10000 pecks"));
        // A peck smaller than the spacing of floats at the depth never gets deeper (rs274
        // would loop without end): refused.
        let (_, diags) = run("F10 G73 X0 R1000000000 Z999999999.9999995 Q0.00000001\n");
        assert!(
            diags[0].to_string().contains("more than 10000 pecks"),
            "{diags:?}"
        );
        // The pecks are rs274's: each Q below the last, rounding and all. From Z-0.604,
        // G91 R0.281 Z-0.4 in 0.2 pecks: R is -0.323 (as rounded), the bottom -0.723, and
        // the second peck lands a hair above the bottom, so a third feed goes to it (as
        // rs274 writes them; 0.4 / 0.2 would say two).
        let (moves, diags) = run_linuxcnc("F10 G0 X1 Y1 Z-0.604\nG91 G83 Q.2 X0.5 R0.281 Z-0.4\n");
        assert!(diags.is_empty(), "{diags:?}");
        let feeds: Vec<f64> = moves
            .iter()
            .filter(|m| m.kind == MoveKind::Linear)
            .map(|m| m.end[2])
            .collect();
        let r = -0.604 + 0.281;
        let bottom = r + -0.4;
        let mut want = vec![];
        let mut d = r - 0.2;
        while d > bottom {
            want.push(d);
            d -= 0.2;
        }
        want.push(bottom);
        assert_eq!(want.len(), 3);
        assert_eq!(feeds, want);
        // 0.3 deep in 0.1 pecks: the third peck lands at 0.20000000000000004, above the
        // bottom, so a fourth short feed goes to 0.2, as rs274 writes them (its
        // canon: feeds to 0.4, 0.3, 0.2, 0.2, with the rapids to R and 0.01 in above
        // each between).
        let (moves, _) = run("F10 G0 Z1\nG83 X0 R0.5 Z0.2 Q0.1\n");
        let feeds: Vec<f64> = moves
            .iter()
            .filter(|m| m.kind == MoveKind::Linear)
            .map(|m| m.end[2])
            .collect();
        assert_eq!(
            feeds,
            [0.5 - 0.1, 0.5 - 0.1 - 0.1, 0.5 - 0.1 - 0.1 - 0.1, 0.2]
        );
    }

    #[test]
    fn units_that_would_overflow_a_position_are_refused() {
        // Found by `cargo xtask fuzz` (seed 4242): Z 1e308 inches is beyond the largest
        // f64 in millimetres; G21 used to make it infinite. Refused at G21, and no move
        // after it (the stream reads on) carries a number that is not finite.
        let big = format!("1{}", "0".repeat(308));
        let text = format!("G20 G90\nG0 X0 Y0 Z{big}\nG21\nG0 X1\n");
        let (moves, diags) = run(&text);
        let e = diags.iter().find(|d| d.is_error()).expect("refused");
        assert_eq!((e.line, e.column), (3, 1), "{}", e.kind);
        assert!(e.kind.to_string().contains("too large"), "{}", e.kind);
        for m in &moves {
            assert!(m.start.iter().chain(&m.end).all(|v| v.is_finite()), "{m:?}");
        }
        // Converting a position that fits stays exact.
        let (moves, diags) = run("G20 G90\nG0 X1 Y0 Z0\nG21\nG0 Y1\n");
        assert!(diags.is_empty(), "{diags:?}");
        assert_eq!(moves[1].start[0], 25.4);
    }
}
