//! Typed diagnostics with their place in the source.

use crate::ast::Span;

/// How serious a diagnostic is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Severity {
    /// The program runs, but something deserves a look.
    Warning,
    /// The program (or this block) cannot be read or interpreted safely.
    Error,
}

/// Everything that can be wrong with a program, as far as this crate can tell.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ErrorKind {
    /// Bytes that are not UTF-8.
    #[error("the line holds bytes that are not UTF-8")]
    InvalidUtf8,
    /// A `(` comment with no `)` on the same line.
    #[error("comment is not closed")]
    UnterminatedComment,
    /// An address letter with no number after it.
    #[error("the letter {0} has no number after it")]
    LetterWithoutNumber(char),
    /// Words of text written without their comment's parentheses (`roughing pass`).
    #[error("`{0}` is text, not G-code words: the control reads its letters as addresses without numbers")]
    TextNotComment(String),
    /// A number with no address letter in front of it.
    #[error("number `{0}` has no address letter")]
    NumberWithoutLetter(String),
    /// A character that cannot start a word or comment.
    #[error("unexpected character {}", shown_char(*.0))]
    UnexpectedCharacter(char),
    /// A `(` inside a `(` comment: comments do not nest.
    #[error("a comment holds `(`: comments do not nest, so it ends at the first `)`")]
    NestedComment,
    /// A number that cannot be read (too long, or not finite).
    #[error("cannot read the number `{0}`")]
    BadNumber(String),
    /// A word whose value is spelled `nan` or `inf` (`Enan`, `F-inf`): what a generating
    /// script writes when its calculation failed.
    #[error(
        "{0}{1}: `{1}` is not a number (a calculation that failed in the program that wrote it)"
    )]
    NotANumber(char, String),
    /// The same word letter twice in one block.
    #[error("{0} appears twice in this block")]
    DuplicateWord(String),
    /// Two codes of one modal group in a block.
    #[error("{first} and {second} are both in the {group} group")]
    ModalGroupConflict {
        /// The group's name.
        group: &'static str,
        /// The first code.
        first: String,
        /// The second code.
        second: String,
    },
    /// A G-code this interpreter does not know.
    #[error("unknown G-code G{0}")]
    UnknownGCode(String),
    /// A G-code LinuxCNC does not have, which other controls do (`G12`, a Haas or
    /// FADAL circular pocket), in a program read as LinuxCNC's.
    #[error("unknown G-code G{0}: LinuxCNC has none, which other controls have (the program is read as LinuxCNC's)")]
    NotLinuxCncCode(String),
    /// A G or M number with more than one decimal.
    #[error("{0} is not a valid code number")]
    BadCodeNumber(String),
    /// An arc whose start and end radii differ beyond tolerance.
    #[error("arc radius at the start ({start:.6}) and at the end ({end:.6}) differ by {diff:.6}: more than {tolerance:.6} and 0.1 % of the radius, or more than {:.6} (the limits LinuxCNC holds arcs to, and lampost every program: a control that runs the arc draws a spiral to its end)", .tolerance * 100.0)]
    ArcRadiusMismatch {
        /// Radius from the centre to the start.
        start: f64,
        /// Radius from the centre to the end.
        end: f64,
        /// The difference.
        diff: f64,
        /// The absolute tolerance in program units (LinuxCNC's, see
        /// [`crate::interp::ARC_SPIRAL_TOLERANCE`]).
        tolerance: f64,
    },
    /// G2/G3 with neither centre offsets nor a radius.
    #[error("arc has neither I/J/K centre words nor an R radius")]
    ArcWithoutCenter,
    /// A radius arc whose end point is its start point.
    #[error("an R-form arc cannot end where it starts (use I/J/K for a full circle)")]
    ArcRadiusFullCircle,
    /// A radius arc whose radius is less than half the chord.
    #[error("arc radius {radius} is less than half the distance between start and end ({half_chord:.6})")]
    ArcRadiusTooSmall {
        /// |R|
        radius: f64,
        /// Half the chord.
        half_chord: f64,
    },
    /// An arc with a zero radius.
    #[error("arc has zero radius")]
    ArcZeroRadius,
    /// An arc whose centre words, read as offsets from the start (G91.1), make no arc
    /// but read as the centre's position (G90.1) make one of this radius.
    #[error("arc's I/J/K read as offsets from the start give no arc ({why}); read as the centre's position (absolute, G90.1) they give an arc of radius {radius:.6}")]
    ArcCentreLooksAbsolute {
        /// What is wrong with the incremental reading.
        why: String,
        /// The radius of the absolute reading.
        radius: f64,
    },
    /// Both centre words and a radius.
    #[error("arc has both I/J/K and R")]
    ArcBothForms,
    /// A centre word outside the active plane.
    #[error("{0} is not a centre word of the active plane")]
    ArcWrongPlaneWord(char),
    /// A zero centre word along the active plane's normal (`K0` in G17, as FreeCAD's
    /// grbl post writes): ignored outside LinuxCNC, which refuses it.
    #[error("{0}0 is not a centre word of the active plane; zero, it changes nothing and is ignored (here and on later arcs)")]
    ArcNormalCentreZero(char),
    /// In a printer program, `G90` while `M83` holds: E stays relative here (Marlin 1,
    /// Prusa's firmware, RepRapFirmware); Marlin 2 reads the E words after it as
    /// positions.
    #[error("G90 while M83 holds: E is read as relative from here on, as Marlin 1, Prusa's firmware and RepRapFirmware read it; Marlin 2 reads E as positions after G90")]
    EModeAfterG90,
    /// Text after the program's end (M2, M30) that is no G-code: never read by the
    /// control.
    #[error("text after the program's end (M2/M30) that is no G-code is not read, as the control stops there (reported once)")]
    TextAfterEnd,
    /// Bytes that are not UTF-8 inside comments only (Latin-1 or Windows-1252 text from
    /// an older CAM system): read as `?`, since a control skips comments.
    #[error("a comment holds bytes that are not UTF-8 (another encoding, such as Latin-1); they are read as `?` (reported once)")]
    CommentNotUtf8,
    /// An arc centre word (I, J, K) on a straight move (G0, G1): no G2/G3 uses it.
    #[error("{0} word with no G2 or G3 to use it: the straight move ignores it")]
    CentreWordWithoutArc(char),
    /// Axis words with no motion mode.
    #[error("axis words but no motion mode is active (after G80 or at program start)")]
    NoMotionMode,
    /// A feed move with no feed rate.
    #[error("feed move with no feed rate (F) set")]
    NoFeedRate,
    /// The block's F word read a vacant variable (Fanuc: the word is left out), and no
    /// feed was set before.
    #[error("feed move with no feed rate: the block's F reads a vacant variable, so the control leaves the F out, and no F was set before")]
    FeedVacant,
    /// A feed move at the feed rate F0 (LinuxCNC: "Cannot do G1 with zero feed rate").
    #[error("feed move at feed rate zero (the F in force is F0): the move would never end")]
    ZeroFeedRate,
    /// A feed move before any F in a printer's program: the firmware moves it at its
    /// initial feed rate ([`crate::flavor::Flavor::initial_feed_mm_min`]), taken from
    /// here on until an F.
    #[error("feed move with no feed rate (F) set: {firmware} moves it at its initial feed rate, taken as {mm_min} mm/min until an F")]
    FirmwareInitialFeed {
        /// The firmware (its flavour's name).
        firmware: &'static str,
        /// Its initial feed rate, mm/min.
        mm_min: f64,
    },
    /// G93 inverse-time move without F in the block.
    #[error("inverse-time (G93) feed move without F in the block")]
    InverseTimeNeedsF,
    /// A canned cycle without the words it needs.
    #[error("canned cycle G{code} needs {what}")]
    CannedCycleIncomplete {
        /// The cycle (81, 83, …).
        code: String,
        /// What is missing.
        what: &'static str,
    },
    /// A word whose value makes no sense.
    #[error("{word}: {why}")]
    BadValue {
        /// The word as written.
        word: String,
        /// Why it is wrong.
        why: &'static str,
    },
    /// A feature that is read but not simulated.
    #[error("{0} is not simulated: the trace shows the programmed path without it")]
    NotSimulated(String),
    /// A dwell, where the reader is asked to name them (`Options::post_notes`: the
    /// post, which writes none).
    #[error("{0}: the dwell is left out of the posted program (the post writes no dwells: with the laser on, the head would stand over one spot)")]
    DwellLeftOut(String),
    /// A block-delete line run and posted without its `/` (`Options::post_notes`).
    #[error("a block-delete line (`/`) is posted as run, without its `/`: the posted program has no switch for it")]
    BlockDeletePosted,
    /// An M-code the interpreter does not act on (a setting of the firmware or control,
    /// or a code of the machine's own), where the reader is asked to name what the post
    /// leaves out (`Options::post_notes`).
    #[error("{0}: an M-code lampost does not act on (a setting of the firmware or control, or a code of the machine's own) is left out of the posted program")]
    MCodeLeftOut(String),
    /// A LinuxCNC G76 threading cycle that cannot run (rs274 refuses it too), or one
    /// with more passes than lampost expands (`lathe.rs`).
    #[error("G76 threading cycle: {0}")]
    ThreadingCycle(String),
    /// A LinuxCNC lathe profile cycle (G70, G71, G72 and their .1/.2) that cannot run
    /// (rs274 refuses it too), or one with more passes than lampost expands (`lathe.rs`).
    #[error("{0}")]
    ProfileCycle(String),
    /// LinuxCNC's cutter radius compensation cannot go on (its words: gouging, a tool
    /// too large for an arc or an entry move, `comp.rs`).
    #[error("cutter radius compensation: {0}")]
    CutterComp(&'static str),
    /// LinuxCNC's cutter radius compensation with its radius known (G41.1/G42.1 D…):
    /// traced as rs274 compensates (`comp.rs`); the post refuses it.
    #[error("{0}: cutter radius compensation traced as LinuxCNC makes it (the tool's centre path, not the programmed one)")]
    CutterCompTraced(String),
    /// A LinuxCNC lathe profile cycle expanded into the moves rs274 makes of it: a
    /// lathe's cycle, which the post refuses.
    #[error("{0} is a lathe cycle: traced as the moves LinuxCNC makes of it on a lathe")]
    LatheCycle(String),
    /// A Fanuc or Haas lathe (turning) program, recognised by its words (`G50 S`,
    /// `T0101` with G18, …: see `turning.rs`), read here as a mill's: said once, at the
    /// block that shows it; the post refuses it.
    #[error("{0}: this is a lathe (turning) program, read here as a mill's: a lathe's X is a diameter (traced as a radius, twice as far from the axis), U and W are its incremental X and Z, and its cycles and corner words are not simulated (said once)")]
    LatheProgram(String),
    /// An R word on a straight move (G0, G1), which no code of the block reads (rs274
    /// refuses the block), or, in a lathe program, a C on a G1 that moves X or Z alone: a
    /// lathe's corner radius or chamfer at the move's end, not simulated.
    #[error("{word} on a straight move: {what}")]
    CornerWord {
        /// The word as written.
        word: String,
        /// What it would be, and why it is not taken.
        what: &'static str,
    },
    /// A canned cycle passed through, not expanded.
    #[error("canned cycle G{0} is passed through, not expanded into moves")]
    CannedCyclePassedThrough(String),
    /// In a printer (slicer) program, an A, B or C word: an axis most printers do not
    /// have; QIDI's and MakerBot's firmware drive an extruder with it (reported once).
    #[error("{0} in a printer's program: most printers have no such axis, and some drive an extruder with it (QIDI's and MakerBot's firmware with A and B, a paste or food printer with U); traced as an axis, not extrusion (reported once)")]
    PrinterRotaryAxis(String),
    /// In a printer (slicer) program, a firmware's extended command that is a setting
    /// and moves nothing (Klipper's `SET_PRESSURE_ADVANCE ADVANCE=0.05`,
    /// `EXCLUDE_OBJECT_START NAME=part`): ignored.
    #[error("{0} is a firmware setting (Klipper): no motion, ignored")]
    FirmwareSetting(String),
    /// In a printer (slicer) program, a line whose command letter is none a printer's
    /// firmware runs (G, M, T): a vendor's line such as WEEDO's `W221`; ignored, as the
    /// firmwares do.
    #[error("{0} is no command a printer's firmware runs (its letter is not G, M or T): a vendor's line, no motion, ignored")]
    VendorCommand(String),
    /// In a printer (slicer) program, a firmware's macro or extended command that may
    /// move (Klipper's `START_PRINT`, `PRINT_END`, `SET_GCODE_OFFSET`): not simulated.
    #[error("{0} is a printer firmware's own macro or command: its moves, if any, are not known and not simulated")]
    FirmwareMacro(String),
    /// A macro line whose value a later stage would need.
    #[error("{0} is not evaluated: macros are kept verbatim, not run (statement lines are reported once)")]
    MacroNotEvaluated(&'static str),
    /// A subprogram call not followed.
    #[error("{0}: subprogram calls are not followed; the trace continues after the call")]
    SubprogramNotFollowed(String),
    /// A word LinuxCNC reads only with certain codes, in a block without them (rs274
    /// refuses the block): L outside G10, canned cycles and G41.1/G42.1 (FADAL calls a
    /// subroutine with L), E outside G76 (FADAL's fixture offset).
    #[error("{word}: LinuxCNC reads {letter} only with {with}")]
    StrayWord {
        /// The word as written.
        word: String,
        /// Its letter.
        letter: char,
        /// The codes that read it.
        with: &'static str,
    },
    /// LinuxCNC's polar coordinates (`@` radius, `^` angle) where LinuxCNC refuses them
    /// (rs274's own conditions), or where lampost would have to guess.
    #[error("polar coordinates (`@` radius, `^` angle): {0}")]
    Polar(&'static str),
    /// A call to a program number the file does not hold.
    #[error("M98 P{0}: this file holds no program O{0}")]
    UnknownProgram(u32),
    /// More moves made by cycles and their repeats than lampost follows.
    #[error("more than {0} moves made by canned or lathe cycles and their repeats (L) in one program: a repeat inside loops or calls that multiplies without end?")]
    TooManyExpanded(u64),
    /// A FADAL subroutine section (`L0100` … `M17`, closed by `M30`) or call (`L0101`)
    /// the control refuses.
    #[error("{0}")]
    FadalSubroutine(String),
    /// A call to a program that is in the file more than once.
    #[error(
        "M98 P{number}: O{number} is in this file more than once (lines {first} and {second})"
    )]
    DuplicateProgram {
        /// The program number.
        number: u32,
        /// Line of the first `O` line.
        first: u32,
        /// Line of the second.
        second: u32,
    },
    /// A call to a program that does not return.
    #[error("M98 P{number}: O{number} (line {line}) has no M99, so it cannot be called")]
    NotASubprogram {
        /// The program number.
        number: u32,
        /// Line of its `O` line.
        line: u32,
    },
    /// A subprogram that calls itself, directly or through others.
    #[error("M98 P{number}: O{number} is already running ({chain}): recursion")]
    RecursiveCall {
        /// The program number.
        number: u32,
        /// The calls in force, outermost first (`O1001 → O1002 → O1001`).
        chain: String,
    },
    /// Calls nested deeper than lampost follows.
    #[error("subprogram calls nested more than {0} deep")]
    CallsTooDeep(usize),
    /// More work through calls than lampost follows.
    #[error("more than {limit} {what} through subprogram calls")]
    TooManyCalls {
        /// The limit.
        limit: u64,
        /// What was counted.
        what: &'static str,
    },
    /// A parameter or expression that cannot be evaluated (LinuxCNC flavour).
    #[error("{0}")]
    Expression(String),
    /// An O-word control line that cannot be followed (LinuxCNC flavour), or the block
    /// limit of loops and subroutines reached.
    #[error("{0}")]
    Control(String),
    /// M99 in the main program (no `O` program open): the control starts the program
    /// again (from its top, or from the block `N…` that P names), without end.
    #[error("M99 in the main program: a {0} control runs the program again from its start (or the N block P names), without end; the trace shows one pass")]
    MainProgramLoops(&'static str),
    /// M99 where the flavour has no main-program loop and no subprogram is running.
    #[error("M99 outside a subprogram: there is no call to return from")]
    ReturnOutsideSubprogram,
    /// A length or angle word written without a decimal point in a Fanuc or Haas
    /// program (`X10`): those controls read it in least input increments by default,
    /// lampost reads whole units (see `interp.rs`, `integer_word`).
    #[error("`{word}` has no decimal point: {control} reads it as {increments} ({setting}); lampost reads it as {units}")]
    IntegerWord {
        /// The word as written.
        word: String,
        /// `a Fanuc control` or `a Haas control`.
        control: &'static str,
        /// The control's setting that decides it, at its default.
        setting: &'static str,
        /// The value in least input increments, with its unit.
        increments: String,
        /// The value in whole units, with its unit.
        units: String,
    },
    /// A LinuxCNC numbered parameter only the machine knows (its tool table, offsets,
    /// homes: `expr::machine_parameter`) read before the program set it.
    #[error("#{number} ({what}) is read as 0: lampost holds none of the machine's tool table, stored offsets and homes (LinuxCNC's standalone rs274 starts them at 0 too)")]
    MachineParameter { number: usize, what: &'static str },
    /// A coordinate written in a dialect before the program said its units, with none
    /// given (`fmt --units`).
    #[error("{0}: the program has not said its units (G20/G21, FADAL G70/G71) before it, and the dialect's decimals depend on them")]
    UnitsNotSaid(String),
    /// `fmt --renumber` on a program that jumps to a block by its number.
    #[error("a jump to a block by its number (GOTO, M97 P, M99 P): renumbering would move the block's number and leave the jump pointing at a number no block has")]
    RenumberJump,
    /// A Fanuc Macro B statement or `G65` call that cannot be followed.
    #[error("{0}")]
    MacroB(String),
    /// More `O` programs in one file than lampost indexes.
    #[error("more than {0} programs (O numbers) in one file")]
    TooManyPrograms(usize),
    /// A program with no blocks at all.
    #[error("the program is empty")]
    EmptyProgram,
    /// A word value the output dialect cannot write (fmt, post): never saturated.
    #[error("{word} is out of range for {dialect}: {range}")]
    OutOfRange {
        /// The word as it would be written (or as read).
        word: String,
        /// The dialect (`FADAL`, `ISO`).
        dialect: &'static str,
        /// What the dialect takes.
        range: &'static str,
    },
    /// Renumbering would pass the largest N of the dialect.
    #[error("renumbering reaches N{next} here, past the largest N of {dialect}, N{max}")]
    RenumberOverflow {
        /// The number this block would get.
        next: u64,
        /// The dialect.
        dialect: &'static str,
        /// Its largest N.
        max: u64,
    },
    /// A line far longer than any controller accepts.
    #[error("the line is {0} bytes long")]
    LineTooLong(usize),
    /// A Fanuc Macro B alarm (`#3000 = n (MESSAGE)`): the control stops with alarm
    /// 3000 + n.
    #[error("the program raises alarm {number} (#3000){}: the control stops here", if .message.is_empty() { String::new() } else { format!(" `{}`", .message) })]
    MacroAlarm {
        /// The alarm's number (3000 + n).
        number: u32,
        /// Its message (the comment after the assignment).
        message: String,
    },
    /// LinuxCNC's `(ABORT, message)` comment: rs274 stops the program with the message.
    #[error("the program aborts here (`(ABORT, …)`){}: LinuxCNC stops it", if .0.is_empty() { String::new() } else { format!(" with `{}`", .0) })]
    Abort(String),
    /// A Fanuc Macro B stop with a message (`#3006 = n (MESSAGE)`): the control stops
    /// until cycle start.
    #[error("the program stops here with the message `{0}` (#3006) until cycle start; the trace goes on")]
    MacroStop(String),
    /// E is read as extrusion, but no move of the program extrudes: posted, it would be
    /// travel alone (reported at its first feed move, or its first move).
    #[error("E is read as extrusion ({0}), but no move of the program extrudes: E never grows along a move, so the post would write travel alone")]
    NoExtrusion(String),
    /// A line that is not G-code but has the shape of another language's (Heidenhain
    /// Klartext, Sinumerik, APT CL data, a robot language): see [`crate::foreign_language`].
    #[error("this line is {}, not G-code", .0.name)]
    ForeignLanguage(crate::Foreign),
}

impl ErrorKind {
    /// What the user can do about it.
    pub fn hint(&self) -> &'static str {
        match self {
            ErrorKind::InvalidUtf8 => "save the file as UTF-8 or ASCII; controllers read ASCII only",
            ErrorKind::UnterminatedComment => "add `)` at the end of the comment",
            ErrorKind::LetterWithoutNumber(_) => "give the word a value, e.g. `X0`, or remove the letter",
            ErrorKind::TextNotComment(_) => "put the text inside a comment `( … )`, or remove it",
            ErrorKind::NumberWithoutLetter(_) => "put the address letter in front of the number, e.g. `X1.5`",
            ErrorKind::UnexpectedCharacter('\r') => "the file's line ends are a bare carriage return (old Mac): convert them to LF or CR LF",
            ErrorKind::UnexpectedCharacter(c) if c.is_control() || *c == '\u{feff}' => "remove the invisible character (an editor that shows control characters finds it)",
            ErrorKind::UnexpectedCharacter('@' | '^') => "`@` (radius) and `^` (angle) are LinuxCNC's polar coordinates, read with --flavor linuxcnc only (or auto choosing it): read the program as LinuxCNC's, or give the point's X and Y",
            ErrorKind::UnexpectedCharacter(',') => "`,R`, `,C` and `,A` after a G1 are Fanuc/Haas corner rounding, chamfering and angle words, which lampost does not simulate (leaving them out changes the path): write the corner as an arc (G2/G3) or as lines; a decimal comma (`X1,5`) must be a point",
            ErrorKind::UnexpectedCharacter('*') => "`*NN` at the end of a block is a host's line checksum (RepRap/Marlin serial protocol), which a program file does not hold: save the program as the slicer wrote it, or strip the `*NN` endings; a `*` elsewhere is an expression, read with --flavor linuxcnc inside `[ ]`",
            ErrorKind::UnexpectedCharacter(_) => "remove it, or put it inside a comment `( … )`",
            ErrorKind::NestedComment => "remove the inner parentheses or write `[ ]` instead (LinuxCNC refuses nested comments too)",
            ErrorKind::BadNumber(_) => "write a plain decimal number such as `-12.5`",
            ErrorKind::NotANumber(..) => "generate the program again once the tool that wrote it computes this value; no machine reads it",
            ErrorKind::DuplicateWord(_) => "keep one value per letter in a block",
            ErrorKind::ModalGroupConflict { .. } => "keep one code of each modal group per block",
            ErrorKind::UnknownGCode(_) => "check the code against the controller's manual, or remove it",
            ErrorKind::NotLinuxCncCode(_) => "if the program is for a Fanuc, Haas, Mach3 or FADAL control, read it with --flavor fanuc, haas, mach3 or fadal (--flavor auto takes a `;` comment or a parameter for LinuxCNC's); if it is for LinuxCNC, remove the code",
            ErrorKind::BadCodeNumber(_) => "G and M codes have at most one decimal, e.g. G31.1",
            ErrorKind::ArcRadiusMismatch { .. } => "check the arc's end point and I/J/K (incremental from the start unless G90.1)",
            ErrorKind::ArcWithoutCenter => "add I/J/K (centre offset) or R (radius)",
            ErrorKind::ArcRadiusFullCircle => "write a full circle with I/J/K",
            ErrorKind::ArcRadiusTooSmall { .. } => "the radius must be at least half the chord; check R and the end point",
            ErrorKind::ArcZeroRadius => "check I/J/K or R",
            ErrorKind::ArcCentreLooksAbsolute { .. } => "the program was written for absolute arc centres (Mach3's and some posts' `IJ absolute`): put G90.1 before its first arc, or post it again from the CAM system with incremental arc centres",
            ErrorKind::ArcBothForms => "use either I/J/K or R, not both",
            ErrorKind::ArcNormalCentreZero(_) => "remove it: LinuxCNC (`--flavor linuxcnc`) refuses a centre word off the active plane",
            ErrorKind::TextAfterEnd => "nothing to do for the motion; remove the text, or put it in a comment, to keep the file clean",
            ErrorKind::CommentNotUtf8 => "nothing to do for the motion; save the file as UTF-8 to keep the comments' text",
            ErrorKind::EModeAfterG90 => "for Marlin 2, put M83 after the G90 (or post with --flavor reprap for RepRapFirmware, where G90 and G91 never change E)",
            ErrorKind::CentreWordWithoutArc(_) => "a missing G2/G3? give the arc's code, or remove the word (LinuxCNC and grbl refuse it; `--flavor linuxcnc` does too)",
            ErrorKind::ArcWrongPlaneWord(_) => "select the plane with G17/G18/G19 or use its centre words (XY: I J, XZ: I K, YZ: J K)",
            ErrorKind::NoMotionMode => "add G0 or G1 to the block",
            ErrorKind::NoFeedRate => "set a feed rate with F before the first feed move",
            ErrorKind::FeedVacant => "a common variable (#100–#199, #500–#999) keeps its value on the control from earlier programs, and lampost runs this one alone (a local one, #1–#33, comes from the macro call's arguments): set the variable before this line (`#650 = 2000.`) to trace it",
            ErrorKind::ZeroFeedRate => "give the move a feed rate above zero (a CAM job whose tool controller has no feed writes `F0`, as FreeCAD Path does)",
            ErrorKind::FirmwareInitialFeed { .. } => "set a feed rate with F before the first feed move to be sure: a firmware's configuration may change its initial feed rate",
            ErrorKind::InverseTimeNeedsF => "in G93 every feed move needs its own F",
            ErrorKind::CannedCycleIncomplete { .. } => "give the cycle its depth (Z in G17, Y in G18, X in G19) and R plane (and Q for peck cycles)",
            ErrorKind::BadValue { .. } => "correct the value",
            ErrorKind::NotSimulated(_) => "check this part of the program on the machine's own graphics",
            ErrorKind::BlockDeletePosted => "if the control's block-delete switch was meant to be on, remove the line before posting",
            ErrorKind::MCodeLeftOut(_) => "where the machine needs what the code does (a filament change, a park, an output, a macro), program it on the control or in the machine file's process codes (`verify` refuses an M-code the post does not write)",
            ErrorKind::DwellLeftOut(_) => "the program runs without the pause: where the process needs it (a spot face's finish), program it on the control (`verify` refuses a dwell in a posted program)",
            ErrorKind::ThreadingCycle(_) => "G76 needs P (pitch, > 0), an axis word (Z: the thread's end), I (the peaks' offset from the drive line, not 0), J (first cut depth, > 0) and K (full thread depth, > J); H and L are whole numbers; the spindle turning (M3/M4, again after M6), cutter compensation off (G40) and no rotary axis word",
            ErrorKind::CutterCompTraced(_) => "the trace shows where the tool's centre goes; the post writes no compensated path (program the centre path with G40)",
            ErrorKind::CutterComp(_) => "the tool does not fit the path on this side: check the radius (D), the side (G41/G42) and the entry move, or lead in and out with room to spare",
            ErrorKind::ProfileCycle(_) => "G70/G71/G72 need Q (the O-word subroutine of the profile, in this file), G18 (the XZ plane), cutter compensation off for G71/G72 (G40), I (the depth of cut) above 0, and a profile that runs one way in X and in Z",
            ErrorKind::LatheCycle(_) => "a lathe cycle cannot be posted to these machines; write its moves out as G0/G1/G2/G3",
            ErrorKind::LatheProgram(_) => "lampost traces and posts mill programs only: check a lathe program on the lathe's own graphics (the post refuses it)",
            ErrorKind::CornerWord { .. } => "write the corner as moves of its own (a radius as a G2/G3 arc, a chamfer as a G1 line), or remove the word; LinuxCNC refuses an R on a straight move too",
            ErrorKind::CannedCyclePassedThrough(_) => "check the cycle on the controller; lampost does not trace it",
            ErrorKind::PrinterRotaryAxis(_) => "if A and B are the printer's extruders (QIDI, MakerBot), --flavor makerbot reads them as E (one head: a block naming both is refused); otherwise check that the printer was built with that axis",
            ErrorKind::FirmwareSetting(_) => "nothing to do: the printer's setting does not apply to the machine",
            ErrorKind::VendorCommand(_) => "nothing to do: a vendor's line (WEEDO's W221 and W220 carry the preview image) moves nothing",
            ErrorKind::FirmwareMacro(_) => "remove the printer's macros before posting: the slicer's custom G-code settings hold them (the start and end code, with its homing and purge line, and the per-layer code: before and after the layer change, a timelapse frame)",
            ErrorKind::MacroNotEvaluated(_) => "post the program after the macros have been resolved, or check this part by hand",
            ErrorKind::SubprogramNotFollowed(_) => "trace the subprogram on its own",
            ErrorKind::StrayWord { .. } => "remove the word (a typo, most likely), or read the program with --flavor fadal if it was written for a FADAL (L: a subroutine call, E: a fixture offset)",
            ErrorKind::Polar(_) => "LinuxCNC reads `@` and `^` in place of X and Y on moves (G0-G3, G33, G38.x) and canned cycles in G17, about the origin of the work system in force; give the point's X and Y where that does not hold",
            ErrorKind::UnknownProgram(_) => "put the subprogram (O number … M99) in the same file, or correct P",
            ErrorKind::TooManyExpanded(_) => "check the cycles' L repeat counts and the loops and calls around them; lampost follows at most 5,000,000 such moves",
            ErrorKind::FadalSubroutine(_) => "write the subroutines first, each from its heading (L0100 for subroutine 1) to the next heading or M17, then M30 on a line of its own, then the main program; call subroutine n k times with Lnnkk (L0103: subroutine 1, three times)",
            ErrorKind::DuplicateProgram { .. } => "give every program in the file its own O number",
            ErrorKind::NotASubprogram { .. } => "end the subprogram with M99, or correct P",
            ErrorKind::RecursiveCall { .. } => "a subprogram may not call itself, directly or through others",
            ErrorKind::CallsTooDeep(_) => "flatten the calls: lampost follows calls 8 deep",
            ErrorKind::TooManyCalls { .. } => "check the L repeats of nested calls; split the program",
            ErrorKind::TooManyPrograms(_) => "split the file",
            ErrorKind::IntegerWord { .. } => "write the decimal point where whole units are meant (`X10.`; CAM posts for these controls always do); a program written for least increments has every such number that many times too large here. The post refuses the program until each has its point",
            ErrorKind::MachineParameter { .. } => "on the machine the value is its own, and the moves computed from it may differ from the trace: check them on the machine's preview, or write the value in the parameter's place",
            ErrorKind::RenumberJump => "leave out --renumber for a program with jumps (its block numbers are labels)",
            ErrorKind::UnitsNotSaid(_) => "give --units inch or --units mm (the units the program is written in), or write G20 or G21 at its start",
            ErrorKind::MacroB(_) => "check the Macro B structure: each WHILE [..] DOm closed by its ENDm (nested loops numbered apart), each GOTO n to a block Nn of the same program, each G65 P.. to a program of this file that ends in M99",
            ErrorKind::MainProgramLoops(_) => "end the program with M30; to run its body several times, make it a subprogram and call it with M98 P… L…",
            ErrorKind::ReturnOutsideSubprogram => "end the program with M30 (M99 returns from a subprogram called with M98)",
            ErrorKind::Expression(what) if what.contains("is a HAL pin") || what.contains("predefined parameters whose value depends on the machine") => "write the value the machine would give in its place (lampost, like rs274, runs the program without the machine)",
            ErrorKind::Expression(_) => "check the expression and that every parameter it reads is set before (RS274NGC: parameters are set after the line's words are read)",
            ErrorKind::Control(_) => "check the O-word structure: each sub, if, while, do and repeat is closed with the same O number, and loops end",
            ErrorKind::EmptyProgram => "give a file that holds a program",
            ErrorKind::OutOfRange { .. } => "correct the value; the controller refuses a number it cannot hold, and lampost never writes a cut-off one",
            ErrorKind::RenumberOverflow { .. } => "renumber with a smaller start or step, or split the program",
            ErrorKind::LineTooLong(_) => "split the line; controllers take lines of a few hundred characters",
            ErrorKind::MacroAlarm { .. } => "the program stops itself here on purpose: check the condition that raises the alarm (its IF) and the values it reads",
            ErrorKind::Abort(_) => "the program stops itself here on purpose (a probing macro's guard, typically): check the condition that leads to this line and the values it reads",
            ErrorKind::MacroStop(_) => "the operator must act on the message before cycle start; check the program's intent at this line",
            ErrorKind::ForeignLanguage(f) => f.hint,
            ErrorKind::NoExtrusion(_) => "when E is not extrusion here (a laser or machining program; a FADAL fixture offset), post with --flavor set to the control the program was written for (not marlin, reprap or makerbot) and without --e-extrusion; for a slicer program, check that it writes E on its printing moves (relative E needs M83); extruder on/off codes without E (M101/M103 of old RepRap \"3D\" firmware, KISSlicer's and Skeinforge's option) are not read as deposition: slice with E values; an extruder driven as an axis (U or V words on the printing moves, a paste or food printer's; A or B: --flavor makerbot) is not E: write those words as E",
        }
    }
}

/// A short piece of the source line, for showing the user where the problem is.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Snippet {
    /// The text shown (the whole line, or a window of it for a long line).
    pub text: String,
    /// Where the caret starts, in characters from the start of `text`.
    pub caret: usize,
    /// How many characters the caret covers (at least 1).
    pub width: usize,
}

/// A located diagnostic.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{line}:{column}: {kind}")]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// What is wrong.
    pub kind: ErrorKind,
    /// 1-based line.
    pub line: u32,
    /// 1-based column, in characters.
    pub column: u32,
    /// The offending bytes.
    pub span: Span,
    /// The source around it.
    pub snippet: Snippet,
}

/// The most characters of a line a snippet shows.
const SNIPPET_WINDOW: usize = 100;

impl Diagnostic {
    /// A diagnostic for the bytes `start..end` (offsets within `line_text`) of a line that
    /// starts at byte `line_offset` of the input.
    pub fn at(
        severity: Severity,
        kind: ErrorKind,
        line: u32,
        line_offset: usize,
        line_text: &[u8],
        start: usize,
        end: usize,
    ) -> Self {
        let start = start.min(line_text.len());
        let end = end.clamp(start, line_text.len());
        let before = String::from_utf8_lossy(&line_text[..start]);
        let column = before.chars().count() + 1;
        let snippet = make_snippet(line_text, start, end);
        Diagnostic {
            severity,
            kind,
            line,
            column: u32::try_from(column).unwrap_or(u32::MAX),
            span: Span::new(line_offset + start, line_offset + end),
            snippet,
        }
    }

    /// A diagnostic that concerns the whole input, not one place in it.
    pub fn whole(severity: Severity, kind: ErrorKind) -> Self {
        Diagnostic {
            severity,
            kind,
            line: 0,
            column: 0,
            span: Span::default(),
            snippet: Snippet {
                text: String::new(),
                caret: 0,
                width: 0,
            },
        }
    }

    /// The hint for the user.
    pub fn hint(&self) -> &'static str {
        self.kind.hint()
    }

    /// True for errors.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

fn make_snippet(line: &[u8], start: usize, end: usize) -> Snippet {
    // Window of at most SNIPPET_WINDOW bytes around the span, on char boundaries.
    let lo = start.saturating_sub(SNIPPET_WINDOW / 2);
    let hi = (lo + SNIPPET_WINDOW)
        .max(end.min(start + SNIPPET_WINDOW / 2))
        .min(line.len());
    let text_full = String::from_utf8_lossy(&line[lo..hi]);
    let prefix = String::from_utf8_lossy(&line[lo..start]).chars().count();
    let width = String::from_utf8_lossy(&line[start..end.min(hi).max(start)])
        .chars()
        .count()
        .max(1);
    let mut text: String = text_full
        .chars()
        .map(|c| if c == '\t' { ' ' } else { c })
        .collect();
    let mut caret = prefix;
    if lo > 0 {
        text.insert(0, '…');
        caret += 1;
    }
    if hi < line.len() {
        text.push('…');
    }
    Snippet { text, caret, width }
}

/// A character as an error message shows it: printable ones between backquotes, control
/// and invisible ones by name and code point (a carriage return, a byte-order mark).
fn shown_char(c: char) -> String {
    match c {
        '\r' => "`\\r` (a carriage return, U+000D)".to_string(),
        '\u{feff}' => "U+FEFF (a byte-order mark)".to_string(),
        c if c.is_control() || c.is_whitespace() && c != ' ' => {
            format!("U+{:04X} (an invisible character)", u32::from(c))
        }
        c => format!("`{c}`"),
    }
}
