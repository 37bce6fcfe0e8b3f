//! Flavours: which control a program was written for, and how that changes its reading.
//!
//! A [`Flavor`] is resolved once per program (for `auto`, from the program's first
//! [`DETECT_BYTES`] bytes: see [`crate::detect`]) and feeds [`crate::Options`]:
//!
//! - `marlin`, `reprap`: E is the extruder (slicer reading, number exponents);
//! - `makerbot`: the slicer reading with the extruder as the A or B word (MakerBot and
//!   Sailfish firmware; Miracle-Grue, MakerWare);
//! - `linuxcnc`: parameters, `[…]` expressions and O-word control lines are evaluated
//!   (see [`crate::expr`]);
//! - `fanuc`, `haas`: Fanuc Macro B is evaluated (see Macro B (`macrob.rs`));
//! - `mach3`, `fadal`: macros stay verbatim; Haas `M97 P…` calls a local subprogram by its
//!   N label (followed by [`crate::ProgramReader`] in every flavour).

use serde::Serialize;

use crate::interp::{EWord, Options};

/// How much of a program `auto` looks at.
pub const DETECT_BYTES: usize = 64 * 1024;

/// The control a program was written for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Flavor {
    /// Decide from the program's content ([`crate::detect`]).
    Auto,
    /// LinuxCNC (RS274NGC): parameters, expressions and O-words evaluated.
    #[serde(rename = "linuxcnc")]
    LinuxCnc,
    /// Fanuc (Macro B evaluated).
    Fanuc,
    /// Haas (Fanuc-like, Macro B evaluated; `M97` local subprograms).
    Haas,
    /// FADAL (macros and register words left verbatim). What lampost reads without a flavour.
    #[default]
    Fadal,
    /// Mach3.
    Mach3,
    /// Marlin firmware: a slicer's program, E is extrusion.
    Marlin,
    /// RepRapFirmware: a slicer's program, E is extrusion.
    #[serde(rename = "reprap")]
    RepRap,
    /// MakerBot and Sailfish firmware: a slicer's program whose extruder is the A word
    /// (the right one) or the B word (the left one), read as E.
    #[serde(rename = "makerbot")]
    MakerBot,
}

impl Flavor {
    /// Every flavour's name, as the CLI spells it.
    pub const NAMES: [&'static str; 9] = [
        "auto", "linuxcnc", "fanuc", "haas", "fadal", "mach3", "marlin", "reprap", "makerbot",
    ];

    /// The name as the CLI spells it.
    pub fn name(self) -> &'static str {
        match self {
            Flavor::Auto => "auto",
            Flavor::LinuxCnc => "linuxcnc",
            Flavor::Fanuc => "fanuc",
            Flavor::Haas => "haas",
            Flavor::Fadal => "fadal",
            Flavor::Mach3 => "mach3",
            Flavor::Marlin => "marlin",
            Flavor::RepRap => "reprap",
            Flavor::MakerBot => "makerbot",
        }
    }

    /// The feed rate (mm/min) a printer firmware moves a feed move at before any F has
    /// been given: its initial requested feed rate after a reset. Marlin's
    /// `feedrate_mm_s` starts at 1500 mm/min (and Klipper's `speed` at 25 mm/s, the
    /// same); RepRapFirmware's `DefaultFeedRate` is 3000 mm/min. `None` where a feed
    /// move without F is refused (the machine controls, and MakerBot, whose default is
    /// not known here).
    /// The firmware's name is given with it.
    pub fn initial_feed_mm_min(self) -> Option<(&'static str, f64)> {
        match self {
            Flavor::Marlin => Some(("Marlin (and Klipper)", 1500.0)),
            Flavor::RepRap => Some(("RepRapFirmware", 3000.0)),
            _ => None,
        }
    }

    /// A printer firmware: E is the extruder.
    pub fn is_slicer(self) -> bool {
        matches!(self, Flavor::Marlin | Flavor::RepRap | Flavor::MakerBot)
    }

    /// The extruder is the A or B word, read as E (MakerBot).
    pub fn extruder_is_a_or_b(self) -> bool {
        self == Flavor::MakerBot
    }

    /// Macros are evaluated: LinuxCNC parameters, expressions and O-words, or Fanuc
    /// Macro B ([`Flavor::macro_b`]).
    pub fn evaluates(self) -> bool {
        self == Flavor::LinuxCnc || self.macro_b()
    }

    /// Canned cycles are a modal group of their own (Fanuc's group 09), apart from the
    /// group-01 motion G0–G3: G80 leaves the motion that was in force before the cycle
    /// (Fanuc, Haas; FADAL read as the Fanuc family it follows). LinuxCNC (rs274) and grbl
    /// put the cycles in the motion group, so G80 leaves none.
    pub fn cycles_apart_from_motion(self) -> bool {
        matches!(self, Flavor::Fanuc | Flavor::Haas | Flavor::Fadal)
    }

    /// Fanuc Macro B is evaluated (see Macro B (`macrob.rs`)).
    pub fn macro_b(self) -> bool {
        matches!(self, Flavor::Fanuc | Flavor::Haas)
    }

    /// `opts` with this (resolved) flavour's reading: the flavour recorded, and E as
    /// extrusion for printer firmwares unless `e_word` says otherwise.
    pub fn options(self, opts: Options, e_word: Option<EWord>) -> Options {
        Options {
            flavor: self,
            e_word: e_word.unwrap_or(if self.is_slicer() {
                EWord::Extrusion
            } else {
                EWord::FixtureOffset
            }),
            ..opts
        }
    }
}

/// A flavour resolved for one program, with why it was chosen.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Resolved {
    /// The flavour in force.
    pub flavor: Flavor,
    /// It was decided from the content (`--flavor auto`).
    pub auto: bool,
    /// What decided it: the evidence `auto` found, or "given".
    pub reason: String,
}

impl Resolved {
    /// `given` itself, or for [`Flavor::Auto`] what [`crate::detect`] finds in `head` (the
    /// program's first bytes).
    pub fn new(given: Flavor, head: &[u8]) -> Self {
        if given == Flavor::Auto {
            let (flavor, reason) = detect(head);
            Resolved {
                flavor,
                auto: true,
                reason,
            }
        } else {
            Resolved {
                flavor: given,
                auto: false,
                reason: "given".into(),
            }
        }
    }

    /// One line for people: `flavour linuxcnc (auto: O-word line 3: o100 sub)`.
    pub fn describe(&self) -> String {
        if self.auto {
            format!("flavour {} (auto: {})", self.flavor.name(), self.reason)
        } else {
            format!("flavour {}", self.flavor.name())
        }
    }
}

fn contains_ci(hay: &str, needle: &str) -> bool {
    hay.as_bytes()
        .windows(needle.len())
        .any(|w| w.eq_ignore_ascii_case(needle.as_bytes()))
}

/// Whether `code` (a line's code, before any comment) reads or sets a parameter as
/// LinuxCNC writes one: `#` then a digit, `<` or `[` (`#1=5`, `X#<x>`, `#[1+2]`). A
/// `#` and a blank is a FADAL statement's (`# V1 = 2.`) or a script's note (`# 4mm
/// square`), no sign of LinuxCNC.
/// A numbered parameter set to an expression written without brackets (`#4= 7. / 2.`,
/// `#1=#2+1`): Fanuc's Macro B; LinuxCNC refuses it (its expressions are in `[…]`). A
/// sign before the value is no operator (`#1=-5`), nor one in an exponent.
fn unbracketed_assignment(code: &str) -> bool {
    let t: Vec<u8> = code.bytes().filter(|c| !c.is_ascii_whitespace()).collect();
    let Some(rest) = t.strip_prefix(b"#") else {
        return false;
    };
    let digits = rest.iter().take_while(|c| c.is_ascii_digit()).count();
    let Some(value) = rest[digits..].strip_prefix(b"=").filter(|_| digits > 0) else {
        return false;
    };
    let mut depth = 0i32;
    let mut operand = false;
    for (i, &c) in value.iter().enumerate() {
        match c {
            b'[' => depth += 1,
            // (After a bracket, `#17=[#2607-54]*5`, the line may be another control's
            // (DDCS): not counted.)
            b']' => {
                depth -= 1;
                operand = false;
            }
            b'+' | b'-' | b'*' | b'/' if depth == 0 => {
                let exponent = i > 0 && matches!(value[i - 1], b'E' | b'e');
                if operand && !exponent {
                    return true;
                }
            }
            c if c.is_ascii_alphanumeric() || c == b'.' || c == b'#' => operand = true,
            _ => {}
        }
    }
    false
}

fn parameter_read(code: &str) -> bool {
    let b = code.as_bytes();
    b.iter().enumerate().any(|(i, &c)| {
        c == b'#'
            && b.get(i + 1)
                .is_some_and(|n| n.is_ascii_digit() || matches!(n, b'<' | b'['))
    })
}

/// The first word of a line (after an optional block delete and `N` number): its
/// upper-cased letter and the rest of the line from there.
fn first_word(line: &str) -> &str {
    let mut s = line.trim_start().trim_start_matches('/').trim_start();
    let b = s.as_bytes();
    if b.first().is_some_and(|c| matches!(c, b'N' | b'n'))
        && b.get(1).is_some_and(u8::is_ascii_digit)
    {
        let digits = s[1..].bytes().take_while(u8::is_ascii_digit).count();
        s = s[1 + digits..].trim_start();
    }
    s
}

/// The words of one upper-cased line (before its comments) that tell flavours apart, in
/// one pass: each letter that does not follow a letter, with the whole number
/// after it (leading zeros dropped).
#[derive(Default)]
struct Codes {
    g65: bool,
    g92: bool,
    e0: bool,
    m82_83: bool,
    m97: bool,
    /// `G0` or `G1`.
    g0_1: bool,
    /// An E word whose number has digits after its point (`E.0234`, `E-0.8`): a
    /// slicer's extrusion (FADAL's fixture offsets are whole).
    e_fraction: bool,
    /// `G76`.
    g76: bool,
    /// A J word and a K word: with G76, LinuxCNC's threading cycle (a mill's G76 is
    /// fine boring, with no J or K; Fanuc's lathe G76 has no J).
    j: bool,
    k: bool,
    /// `M104`, `M109`, `M140` or `M190`: a printer's hot end or bed temperature (with an
    /// S word; Haas's `M109 P…` is its interactive input, with no S).
    heater: bool,
    /// An S word with a number.
    s: bool,
    /// `G4`, and a P word with a number.
    g4: bool,
    p: bool,
    /// `M66`, `M67` or `M68`, and an E word with a number: LinuxCNC's inputs and analog
    /// outputs (`M67 E2 Q25`).
    m66_68: bool,
    e: bool,
}

impl Codes {
    /// A G0 or G1 with a fractional E: a slicer's extruding move.
    fn e_move(&self) -> bool {
        self.g0_1 && self.e_fraction
    }

    /// A printer's temperature code with its S (`M104 S210`, `M190 S60`).
    fn heater_temperature(&self) -> bool {
        self.heater && self.s
    }

    /// A dwell in seconds by S and no P (`G4 S1`): Marlin's, RepRapFirmware's and
    /// Klipper's; LinuxCNC, Fanuc, Haas, FADAL, Mach3 and grbl dwell by P (or X).
    fn printer_dwell(&self) -> bool {
        self.g4 && self.s && !self.p
    }
}

impl Codes {
    fn of(code: &str) -> Self {
        let b = code.as_bytes();
        let mut c = Codes::default();
        let mut i = 0;
        while i < b.len() {
            let letter = b[i];
            if !letter.is_ascii_alphabetic() || i > 0 && b[i - 1].is_ascii_alphabetic() {
                i += 1;
                continue;
            }
            let numeric = b
                .get(i + 1)
                .is_some_and(|d| d.is_ascii_digit() || matches!(d, b'.' | b'-' | b'+'));
            c.j |= letter == b'J' && numeric;
            c.k |= letter == b'K' && numeric;
            c.s |= letter == b'S' && numeric;
            c.p |= letter == b'P' && numeric;
            c.e |= letter == b'E' && numeric;
            if letter == b'E' {
                let num = b[i + 1..].strip_prefix(b"-").unwrap_or(&b[i + 1..]);
                let int = num.iter().take_while(|d| d.is_ascii_digit()).count();
                c.e_fraction |=
                    num.get(int) == Some(&b'.') && num.get(int + 1).is_some_and(u8::is_ascii_digit);
            }
            let mut j = i + 1;
            let mut n: u32 = 0;
            while j < b.len() && b[j].is_ascii_digit() && n < 100_000 {
                n = n * 10 + u32::from(b[j] - b'0');
                j += 1;
            }
            let whole = j > i + 1 && !b.get(j).is_some_and(|d| d.is_ascii_digit() || *d == b'.');
            if whole {
                match (letter, n) {
                    (b'G', 65) => c.g65 = true,
                    (b'G', 92) => c.g92 = true,
                    (b'E', 0) => c.e0 = true,
                    (b'M', 82 | 83) => c.m82_83 = true,
                    (b'M', 97) => c.m97 = true,
                    (b'G', 0 | 1) => c.g0_1 = true,
                    (b'G', 76) => c.g76 = true,
                    (b'M', 104 | 109 | 140 | 190) => c.heater = true,
                    (b'G', 4) => c.g4 = true,
                    (b'M', 66..=68) => c.m66_68 = true,
                    _ => {}
                }
            }
            i = j.max(i + 1);
        }
        c
    }
}

/// Decide the flavour of a program from its first bytes (at most [`DETECT_BYTES`] are
/// looked at, whole lines only): the first decisive evidence wins, line by line, and a
/// program with none is [`Flavor::Fadal`] (lampost's reading without a flavour). The
/// evidence, strongest first within a line:
///
/// - comments naming a slicer or firmware (`;FLAVOR:Marlin`, `; generated by PrusaSlicer`,
///   Cura, Bambu/Orca, SuperSlicer, Simplify3D, KISSlicer, Skeinforge, RepRapFirmware),
///   `M82`/`M83`, (MakerBot when a comment names MakerBot Industries, Miracle-Grue,
///   MakerWare or Sailfish),
///   `G92 E…`:
///   Marlin (RepRap when the comment says so);
/// - LinuxCNC O-word lines (`o100 sub`, `o<name> call`) and named parameters `#<…>`;
/// - Fanuc Macro B words: `IF [`, `WHILE [`, `GOTO`, `DOn`, `ENDn`, `G65`;
/// - Haas: a comment naming Haas, or `M97`; Mach3: a comment naming Mach3;
/// - FADAL: macro statements (`#V10 = …`, `#IF`, `#PRINT`, `#:LABEL`), a comment naming
///   FADAL;
/// - Skeinforge's `(<setting> …)` header comments: Marlin;
/// - PrusaSlicer's binary G-code (the magic `GCDE` at the start): Marlin.
///
/// Without any of those, weaker evidence decides, the strongest kind found first: a G0
/// or G1 with a fractional E word (a slicer's extrusion), or a printer's temperature code
/// with its S (`M104`, `M109`, `M140`, `M190`), or a dwell in seconds by S (`G4 S1`, no
/// P): Marlin; numbered parameters
/// (`#1 = …`), `[…]` expressions, polar coordinates (`@`, `^`) or an input or analog
/// output code with its E (`M67 E2 Q25`): LinuxCNC; a `;` comment, which FADAL programs do not
/// hold (grbl, Mach3 and hobby CAM write them): LinuxCNC, whose reading is ISO's.
pub fn detect(head: &[u8]) -> (Flavor, String) {
    if head.starts_with(b"GCDE") {
        // PrusaSlicer's binary G-code, for Prusa's (Marlin) firmware; the reading
        // refuses it at its first line, naming it.
        return (
            Flavor::Marlin,
            "binary G-code (PrusaSlicer's .bgcode) on line 1".into(),
        );
    }
    let mut head = &head[..head.len().min(DETECT_BYTES)];
    if head.len() == DETECT_BYTES {
        // Whole lines only.
        if let Some(nl) = memchr::memrchr(b'\n', head) {
            head = &head[..nl];
        }
    }
    let text = String::from_utf8_lossy(head);
    let mut weak: Option<(u8, Flavor, String)> = None;
    // A slicer named (Marlin's reading) before the firmware is: a later line naming
    // RepRapFirmware still decides (PrusaSlicer names itself on line 1, Cura its flavour
    // on line 1 or 2).
    let mut slicer: Option<(Flavor, String)> = None;
    for (n, raw) in text.lines().enumerate() {
        let line = raw.trim_start_matches('\u{feff}').trim();
        if line.is_empty() {
            continue;
        }
        let at = |what: &str| format!("{what} on line {}: {}", n + 1, clip(line));
        if slicer.is_some() {
            if let Some(p) = line.find([';', '(']) {
                for needle in REPRAP {
                    if contains_ci(&line[p..], needle) {
                        return (Flavor::RepRap, at(&format!("a comment naming {needle}")));
                    }
                }
            }
            continue;
        }
        // A slicer's preview image (`; thumbnail begin 300x300 …`, `; png begin …`):
        // printers' programs only. Large ones fill the whole head (Creality Print's three
        // PNGs, over 100 KiB before `;FLAVOR`), so the block decides as a slicer's name
        // does (a later line naming RepRapFirmware still wins).
        if thumbnail_begin(line) {
            slicer = Some((Flavor::Marlin, at("a slicer's thumbnail image block")));
            continue;
        }
        // Comments that name their source.
        if let Some(p) = line.find([';', '(']) {
            let c = &line[p..];
            for (needle, f) in [
                ("FLAVOR:RepRap", Flavor::RepRap),
                ("RepRapFirmware", Flavor::RepRap),
                ("gcode_flavor = reprap", Flavor::RepRap),
                ("FLAVOR:Marlin", Flavor::Marlin),
                ("PrusaSlicer", Flavor::Marlin),
                ("SuperSlicer", Flavor::Marlin),
                ("Slic3r", Flavor::Marlin),
                ("BambuStudio", Flavor::Marlin),
                ("Bambu Studio", Flavor::Marlin),
                ("OrcaSlicer", Flavor::Marlin),
                ("Cura_SteamEngine", Flavor::Marlin),
                ("Simplify3D", Flavor::Marlin),
                ("KISSlicer", Flavor::Marlin),
                ("Skeinforge", Flavor::Marlin),
                ("Makerbot Industries", Flavor::MakerBot),
                ("Miracle-Grue", Flavor::MakerBot),
                ("MakerWare", Flavor::MakerBot),
                ("Sailfish", Flavor::MakerBot),
                ("<setting>", Flavor::Marlin),
                ("FLAVOR:", Flavor::Marlin),
                ("Mach3", Flavor::Mach3),
                ("Haas", Flavor::Haas),
                ("LinuxCNC", Flavor::LinuxCnc),
                ("FADAL", Flavor::Fadal),
            ] {
                if contains_ci(c, needle) {
                    let why = at(&format!("a comment naming {needle}"));
                    if f == Flavor::Marlin && !needle.starts_with("FLAVOR:") {
                        slicer = Some((f, why));
                        break;
                    }
                    return (f, why);
                }
            }
            if slicer.is_some() {
                continue;
            }
        }
        // A line of another language (Heidenhain, Sinumerik, APT, a robot's): no flavour
        // reads it; FADAL's reading keeps the codes such programs share with it (G70/G71
        // as units), so the first error is that line, named.
        let code_part = line.split([';', '(']).next().unwrap_or("");
        if let Some(f) = crate::foreign_language(code_part) {
            return (
                Flavor::Fadal,
                at(&format!("a line of {}, not G-code", f.name)),
            );
        }
        let w = first_word(line);
        let wb = w.as_bytes();
        if wb.first().is_some_and(|c| matches!(c, b'o' | b'O'))
            && (wb.get(1) == Some(&b'<') || crate::parse::is_oword(w))
        {
            return (Flavor::LinuxCnc, at("an O-word line"));
        }
        if w.contains("#<") {
            return (Flavor::LinuxCnc, at("a named parameter"));
        }
        if wb.first() == Some(&b'#')
            && wb
                .get(1)
                .is_some_and(|c| c.is_ascii_alphabetic() || *c == b':')
        {
            return (Flavor::Fadal, at("a FADAL macro statement"));
        }
        let upper = w.to_ascii_uppercase();
        let code = upper.split(['(', ';']).next().unwrap_or("");
        let c = Codes::of(code);
        if code.starts_with("IF") && code[2..].trim_start().starts_with('[')
            || code.starts_with("WHILE") && code[5..].trim_start().starts_with('[')
            || code.contains("GOTO")
            || c.g65
            || (code.starts_with("END")
                && code[3..]
                    .trim_start()
                    .starts_with(|c: char| c.is_ascii_digit()))
        {
            return (Flavor::Fanuc, at("a Fanuc Macro B word"));
        }
        if unbracketed_assignment(code) {
            return (
                Flavor::Fanuc,
                at("a Macro B assignment with an operator outside brackets (LinuxCNC needs `[…]`)"),
            );
        }
        if c.m82_83 {
            return (Flavor::Marlin, at("an extruder mode code"));
        }
        if c.g92 && c.e0 {
            return (Flavor::Marlin, at("G92 E (extruder position)"));
        }
        if c.m97 {
            return (Flavor::Haas, at("an M97 local subprogram call"));
        }
        if c.g76 && c.j && c.k {
            return (
                Flavor::LinuxCnc,
                at("a G76 threading cycle with J and K (LinuxCNC's)"),
            );
        }
        // Weak evidence: the first of the strongest kind decides, when nothing decisive
        // comes in the head.
        let found = if c.e_move() {
            Some((3, Flavor::Marlin, "a move with a fractional E (extrusion)"))
        } else if c.heater_temperature() {
            Some((
                3,
                Flavor::Marlin,
                "a printer's temperature code (M104/M109/M140/M190 with S)",
            ))
        } else if c.printer_dwell() {
            Some((
                3,
                Flavor::Marlin,
                "a dwell in seconds by S (`G4 S…`: a printer firmware's)",
            ))
        } else if parameter_read(code) || code.contains('[') {
            Some((2, Flavor::LinuxCnc, "a parameter or expression"))
        } else if code
            .trim_start()
            .strip_prefix(':')
            .is_some_and(|r| r.starts_with(|c: char| c.is_ascii_digit()))
        {
            Some((
                2,
                Flavor::Fanuc,
                "a `:` program number (Fanuc's O address in ISO code)",
            ))
        } else if c.m66_68 && c.e {
            Some((
                2,
                Flavor::LinuxCnc,
                "an input or analog output code with its E (`M66`/`M67`/`M68 E…`: LinuxCNC's)",
            ))
        } else if polar_word(code) {
            Some((2, Flavor::LinuxCnc, "a polar coordinate (`@`, `^`)"))
        } else if semicolon_block_end(line) {
            // Fanuc's and Haas's manuals (and programs typed from them) end each block
            // with `;`, the end-of-block character as ISO code prints it; a `;` comment
            // of LinuxCNC's, grbl's or a hobby CAM system's has its text after it.
            Some((
                1,
                Flavor::Fanuc,
                "a bare `;` ending a block (the end of block as Fanuc's and Haas's manuals print programs)",
            ))
        } else if semicolon_comment(line) {
            // FADAL's comments are `(…)` and, in macros, `'…`; a `;` comment is ISO's
            // (grbl, LinuxCNC, Mach3, most hobby CAM).
            Some((1, Flavor::LinuxCnc, "a `;` comment (FADAL writes none)"))
        } else {
            None
        };
        if let Some((rank, flavor, what)) = found {
            if weak.as_ref().is_none_or(|w| rank > w.0) {
                weak = Some((rank, flavor, at(what)));
            }
        }
    }
    if let Some(s) = slicer {
        return s;
    }
    weak.map_or(
        (Flavor::Fadal, "no evidence of another control".into()),
        |w| (w.1, w.2),
    )
}

/// Comments that name RepRapFirmware (Cura's `;FLAVOR:RepRap`, PrusaSlicer's config
/// block `; gcode_flavor = reprapfirmware`).
const REPRAP: [&str; 3] = ["FLAVOR:RepRap", "RepRapFirmware", "gcode_flavor = reprap"];

/// An `@` or `^` with a value after it (a number, a parameter or an expression; blanks
/// allowed): LinuxCNC's polar coordinates (`@1.5`, `^ -30`, `^[360/17]`), not a character
/// of a message (`M117 Hi @ home`).
fn polar_word(code: &str) -> bool {
    let b = code.as_bytes();
    b.iter().enumerate().any(|(i, c)| {
        matches!(c, b'@' | b'^')
            && b[i + 1..]
                .iter()
                .find(|c| !matches!(c, b' ' | b'\t'))
                .is_some_and(|c| {
                    c.is_ascii_digit() || matches!(c, b'.' | b'+' | b'-' | b'[' | b'#')
                })
    })
}

/// The first line of a slicer's embedded preview image: `; thumbnail begin 220x124 5788`
/// (PrusaSlicer, Cura, Orca), `; thumbnail_QOI begin …`, `; thumbnail_JPG begin …`,
/// `; png begin 96*96 …` and `; jpg begin …` (Creality Print).
fn thumbnail_begin(line: &str) -> bool {
    let Some(rest) = line.strip_prefix(';') else {
        return false;
    };
    let mut words = rest.split_ascii_whitespace();
    let (Some(kind), Some(begin)) = (words.next(), words.next()) else {
        return false;
    };
    let kind = kind.to_ascii_lowercase();
    begin.eq_ignore_ascii_case("begin")
        && (kind == "thumbnail"
            || kind.starts_with("thumbnail_")
            || matches!(kind.as_str(), "png" | "jpg" | "jpeg" | "qoi"))
}

/// A `;` outside `(…)` comments: a `;` comment.
/// A block of code ended by a `;` with nothing after it (`G00 X0 Y0 ;`), outside
/// parentheses.
fn semicolon_block_end(line: &str) -> bool {
    let Some(code) = line.trim_end().strip_suffix(';') else {
        return false;
    };
    !code.contains(';')
        && !semicolon_comment(code)
        && code.bytes().filter(|&b| b == b'(').count()
            == code.bytes().filter(|&b| b == b')').count()
        && code.as_bytes().windows(2).any(|w| {
            w[0].is_ascii_alphabetic() && (w[1].is_ascii_digit() || w[1] == b'-' || w[1] == b'.')
        })
}

fn semicolon_comment(line: &str) -> bool {
    let mut in_paren = false;
    for c in line.bytes() {
        match c {
            b'(' => in_paren = true,
            b')' => in_paren = false,
            b';' if !in_paren => return true,
            _ => {}
        }
    }
    false
}

fn clip(line: &str) -> String {
    let mut s: String = line.chars().take(40).collect();
    if s.len() < line.len() {
        s.push('…');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slicer_s_thumbnail_block_decides_though_it_fills_the_head() {
        // Creality Print: three PNGs (over 100 KiB) before `;FLAVOR:Creality OS`; every
        // line of the head is a `;` comment, which alone would read as LinuxCNC.
        let mut big = String::from("; png begin 96*96 7757 0 95 192\n");
        while big.len() < 2 * DETECT_BYTES {
            big.push_str("; iVBORw0KGgoAAAANSUhEUgAAAGAAAABgCAYAAADimHc4AAAACXBIWXMAABJ0AAA\n");
        }
        big.push_str("; png end\n;FLAVOR:Creality OS\nG1 X1 E.2\n");
        let (f, why) = detect(big.as_bytes());
        assert_eq!(f, Flavor::Marlin, "{why}");
        assert!(why.contains("thumbnail"), "{why}");
        for (text, want) in [
            ("; thumbnail begin 16x16 100\n; abc\n", Flavor::Marlin),
            ("; thumbnail_QOI begin 16x16 100\n", Flavor::Marlin),
            (";thumbnail_JPG begin 16x16 100\n", Flavor::Marlin),
            // The firmware named after the image still decides.
            (
                "; thumbnail begin 16x16 100\n; thumbnail end\n;FLAVOR:RepRap\n",
                Flavor::RepRap,
            ),
            // Not an image block: a comment that merely says so, or a `(…)` comment.
            ("; png of the part begins here\nG0 X1\n", Flavor::LinuxCnc),
            ("(thumbnail begin)\nG0 X1\n", Flavor::Fadal),
        ] {
            assert_eq!(detect(text.as_bytes()).0, want, "{text:?}");
        }
    }

    /// A Macro B assignment with its operator outside brackets (h59: `#4= 7. / 2.` from a
    /// Fanuc program) decides Fanuc: LinuxCNC refuses it, and it was read as LinuxCNC's
    /// for its `#` and refused at the `/`. A bracketed one, a sign or an exponent does not.
    #[test]
    fn an_unbracketed_assignment_is_fanuc_s() {
        for (text, want) in [
            (
                "%\nO00068\nG52 X [ 0. ]\n#4= 7. / 2.\nG0 Y#4\n",
                Flavor::Fanuc,
            ),
            ("#1=#2+1\n", Flavor::Fanuc),
            ("#1 = [#2 + 1]\n", Flavor::LinuxCnc),
            ("#1=-5\n", Flavor::LinuxCnc),
            ("#1=1E-5\n", Flavor::LinuxCnc),
            ("#<a> = [1] \n#1=#2+1\n", Flavor::LinuxCnc),
        ] {
            assert_eq!(detect(text.as_bytes()).0, want, "{text:?}");
        }
    }

    /// Blocks ended by a bare `;` (h59: a Haas G12 sample typed from the manual, read as
    /// LinuxCNC's for its `;` and refused at G12) are Fanuc's; a `;` with text after it,
    /// a `;` alone, or one inside a comment are not.
    #[test]
    fn a_bare_semicolon_ending_blocks_is_fanuc_s() {
        for (text, want) in [
            (
                "%\n(SAMPLE G12)\nT1 M06 ;\nG00 G90 G40 G49 G54 ;\nG12 I0.75 F10. Z-1.2 D01 ;\nM30 ;\n%\n",
                Flavor::Fanuc,
            ),
            ("G0 X1 Y2;\n", Flavor::Fanuc),
            ("G0 X1 ; rapid\nG1 X2 ;\n", Flavor::LinuxCnc),
            (";\nG0 X1\n", Flavor::LinuxCnc),
            ("(a;\nG0 X1\n", Flavor::Fadal),
            ("; only text ;\nG0 X1\n", Flavor::LinuxCnc),
        ] {
            let (f, why) = detect(text.as_bytes());
            assert_eq!(f, want, "{text:?}: {why}");
        }
    }

    #[test]
    fn auto_finds_each_flavour() {
        for (text, want) in [
            (";FLAVOR:Marlin\nG1 X1\n", Flavor::Marlin),
            ("; generated by PrusaSlicer 2.6\nG1 X1 E1\n", Flavor::Marlin),
            (";FLAVOR:RepRap\nG1 X1\n", Flavor::RepRap),
            // The slicer named first, the firmware after it.
            (
                "; generated by PrusaSlicer 2.7.1\n;FLAVOR:RepRap\nG1 X1\n",
                Flavor::RepRap,
            ),
            (
                "; generated by PrusaSlicer 2.7.1\n; gcode_flavor = reprapfirmware\n",
                Flavor::RepRap,
            ),
            (
                "; generated by PrusaSlicer 2.7.1\no100 sub\nG1 X1\n",
                Flavor::Marlin,
            ),
            ("\n(Makerbot Industries)\nG1 X1 A1\n", Flavor::MakerBot),
            (
                "(* Generated by Miracle-Grue v 0.04 alpha)\n",
                Flavor::MakerBot,
            ),
            ("G21\nM83\nG1 X1 E.2\n", Flavor::Marlin),
            ("G92 E0\n", Flavor::Marlin),
            ("G1X1\nG92E0\n", Flavor::Marlin),
            ("G0 X1\nM830\nM8.3 G650\n", Flavor::Fadal),
            ("G20\no100 sub\nG0 X1\no100 endsub\n", Flavor::LinuxCnc),
            (
                "G18\nM3 S800\nN20 G76 P.05 Z-.5 I-.075 J.008 K.045\n",
                Flavor::LinuxCnc,
            ),
            // A mill's fine boring G76 (FADAL, Haas) has no J and K.
            ("G0 X1 Y1\nG76 Z-1 R.1 Q.01 I1 J0 F10\n", Flavor::Fadal),
            ("O<probe> call\n", Flavor::LinuxCnc),
            ("#<depth> = 2\nG1 Z-#<depth>\n", Flavor::LinuxCnc),
            ("G0 X0\n#1 = 2\nG1 X#1\n", Flavor::LinuxCnc),
            ("#100=1\nWHILE [#100 LE 3] DO1\nEND1\n", Flavor::Fanuc),
            ("N10 G65 P9001 A.125\n", Flavor::Fanuc),
            ("IF [#1 GT 2] GOTO 20\n", Flavor::Fanuc),
            ("(HAAS VF2)\nG0 X1\n", Flavor::Haas),
            ("G0 X0\nM97 P100\nM30\nN100 G1 X1\nM99\n", Flavor::Haas),
            ("(Mach3 post)\nG0 X1\n", Flavor::Mach3),
            ("#V1 = 2 'A\n", Flavor::Fadal),
            ("N80 #:S1\n", Flavor::Fadal),
            ("G0 X1\nG1 Y2 F10\n", Flavor::Fadal),
            // A printer's start code in a pen-plotter program (Inkscape gcodetools for a
            // Marlin printer): no extrusion, a `;` comment first, temperatures after it.
            (
                "G1 Z5.5 F1200; S0\nM104 S210\nM109 S210\nG28\nG90 E0\n",
                Flavor::Marlin,
            ),
            ("M140 S60\nM190 S60\nG1 X1\n", Flavor::Marlin),
            // Haas's M109 (interactive user input) has a P, no S.
            ("G0 X1 ; note\nM109 P501\n", Flavor::LinuxCnc),
            // A dwell in seconds by S: a printer firmware's (FABtotum's laser jobs, which
            // name no slicer and open with a `;` comment); by P, anyone's.
            (
                ";FABtotum laser engraving\nG4 S1 ;pause\nG90\nG1 X1 F800\n",
                Flavor::Marlin,
            ),
            ("G0 X1 ; note\nG4 P1\n", Flavor::LinuxCnc),
            ("G0 X1\nG4 P1 S1\n", Flavor::Fadal),
            // LinuxCNC's analog output sets a laser's power (`M68 E0 Q0`).
            ("G21 G90\nM68 E0 Q0\nG1 X1 F100\n", Flavor::LinuxCnc),
            ("O1000\nM104\nG0 X1\nM30\n", Flavor::Fadal),
            ("O1000\nG0 X1\nM30\n", Flavor::Fadal),
            ("", Flavor::Fadal),
        ] {
            assert_eq!(detect(text.as_bytes()).0, want, "{text}");
        }
    }

    #[test]
    fn auto_names_the_slicer_from_its_header() {
        // The first lines of real programs (fixtures/real-programs), followed by lines
        // that alone would not say "slicer": the header decides, whatever bytes follow
        // (Simplify3D 3.0.2 wrote a model name in a single-byte code page).
        let cases: [(&[u8], &str); 4] = [
            (
                b"; G-Code generated by Simplify3D(R) Version 4.1.2\n; Sep 4, 2019\nG1 X1 Y1\n",
                "Simplify3D",
            ),
            (
                b"; G-Code generated by Simplify3D(R) Version 3.0.2\n;   applyToModels,ukazov\xe1tko\n",
                "Simplify3D",
            ),
            (
                b"; generated by SuperSlicer 2.5.60.0 on 2024-10-31 at 04:00:41 UTC\n\n;\nG1 X1\n",
                "SuperSlicer",
            ),
            (b"; KISSlicer - FREE\n; Linux\n; version 1.1.0.5\nG1 X1\n", "KISSlicer"),
        ];
        for (text, slicer) in cases {
            let (flavor, why) = detect(text);
            assert_eq!(flavor, Flavor::Marlin, "{slicer}");
            assert!(why.contains(slicer) && why.contains("line 1"), "{why}");
        }
        // Without the header the same body is no slicer's (a `;` comment: ISO's reading).
        assert_eq!(detect(b"; Sep 4, 2019\nG1 X1 Y1\n").0, Flavor::LinuxCnc);
    }

    #[test]
    fn weak_evidence_decides_by_kind() {
        for (text, want, why) in [
            // grbl and hobby CAM: `;` comments, which FADAL programs never hold.
            (
                "G21\nG0 X1 ; rapid\nG1 Y2 F10\n",
                Flavor::LinuxCnc,
                "a `;` comment",
            ),
            // A slicer nobody named: fractional E on moves, over the `;` seen first.
            (
                "; my slicer\nG1 X1 Y1 E.0234\n",
                Flavor::Marlin,
                "fractional E",
            ),
            ("G1 X1 E-0.8 F2400\n", Flavor::Marlin, "fractional E"),
            // A FADAL fixture offset is whole, and no move.
            ("G0 E1 X1\nG1 X2 E2. F10\n", Flavor::Fadal, "no evidence"),
            ("(SET X; Y)\nG0 X1\n", Flavor::Fadal, "no evidence"),
            // A parameter outranks a `;` comment.
            ("G0 X1 ;a\nG1 X#1\n", Flavor::LinuxCnc, "a parameter"),
            // LinuxCNC's polar coordinates, in a program with no other evidence.
            (
                "G20 G0 X2 Y0\nG0 @1 ^90\n",
                Flavor::LinuxCnc,
                "a polar coordinate",
            ),
            (
                "(HOLES)\nG81 R.1 Z-.5 ^60 L6\n",
                Flavor::LinuxCnc,
                "a polar coordinate",
            ),
            ("G0 ^ -30\n", Flavor::LinuxCnc, "a polar coordinate"),
            // A character of a message is none.
            ("M117 Hi @ home ^_^\nG0 X1\n", Flavor::Fadal, "no evidence"),
            // Skeinforge's header.
            (
                "(<setting> comb Running_Jump_Space_(mm): 2.0 </setting>)\nG1 X1\n",
                Flavor::Marlin,
                "<setting>",
            ),
        ] {
            let (f, reason) = detect(text.as_bytes());
            assert_eq!(f, want, "{text}: {reason}");
            assert!(reason.contains(why), "{text}: {reason}");
        }
    }

    #[test]
    fn auto_looks_at_the_head_only() {
        let mut text = "G0 X1\n".repeat(DETECT_BYTES / 6 + 10);
        text.push_str("o100 sub\n");
        assert_eq!(detect(text.as_bytes()).0, Flavor::Fadal);
        let r = Resolved::new(Flavor::Auto, b"M83\n");
        assert_eq!(
            r.describe(),
            "flavour marlin (auto: an extruder mode code on line 1: M83)"
        );
        assert_eq!(Resolved::new(Flavor::Haas, b"M83\n").flavor, Flavor::Haas);
    }

    #[test]
    fn options_follow_the_flavour() {
        let o = Flavor::Marlin.options(Options::default(), None);
        assert_eq!(o.e_word, EWord::Extrusion);
        let o = Flavor::Marlin.options(Options::default(), Some(EWord::FixtureOffset));
        assert_eq!(o.e_word, EWord::FixtureOffset);
        let o = Flavor::LinuxCnc.options(Options::default(), None);
        assert!(o.flavor.evaluates());
        assert_eq!(o.e_word, EWord::FixtureOffset);
    }
}
