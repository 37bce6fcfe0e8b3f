//! The syntax tree: blocks, words and comments, each with its byte span.
//!
//! Blocks borrow their text from the line they were parsed from, so parsing
//! allocates nothing for the common block of up to eight words.

use smallvec::SmallVec;

/// A half-open byte range `start..end` into the whole input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct Span {
    /// First byte.
    pub start: usize,
    /// One past the last byte.
    pub end: usize,
}

impl Span {
    /// A span from `start` to `end`.
    pub fn new(start: usize, end: usize) -> Self {
        Span { start, end }
    }
}

/// One address letter and its number: `X-.25`, `G1`, FADAL's `R1+6.`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Word<'a> {
    /// Upper-case ASCII letter.
    pub letter: u8,
    /// FADAL register number of a signed R word (`R1+6.` is register 1, value +6).
    pub register: Option<u8>,
    /// The value.
    pub value: f64,
    /// The number exactly as written (`-.25`, `+6.`, `0010`).
    pub text: &'a str,
    /// From the letter to the end of the number.
    pub span: Span,
}

impl Word<'_> {
    /// The letter as a `char`.
    pub fn letter_char(&self) -> char {
        char::from(self.letter)
    }

    /// The word as written, with the letter upper-cased: `X-.25`, `R1+6.`.
    pub fn display(&self) -> String {
        match self.register {
            Some(r) => format!("{}{}{}", self.letter_char(), r, self.text),
            None => format!("{}{}", self.letter_char(), self.text),
        }
    }

    /// The G or M code number times ten, if the value has at most one decimal
    /// (`G31.1` gives 311, `G1` gives 10).
    pub fn code(&self) -> Option<u16> {
        Self::code_of(self.value)
    }

    /// [`Word::code`] of an M word, where an M-code beyond `M6553.5` (a firmware's own,
    /// such as Bambu's `M9833.2`) is `u16::MAX`: a code lampost does not act on.
    pub fn m_code_of(value: f64) -> Option<u16> {
        Self::code_of(value).or_else(|| {
            let tenths = value * 10.0;
            let whole = (tenths - crate::emit::round_half_away(tenths)).abs() < 1e-6;
            (whole && tenths > 65535.0 && tenths.is_finite()).then_some(u16::MAX)
        })
    }

    /// [`Word::code`] of a value.
    pub fn code_of(value: f64) -> Option<u16> {
        let tenths = value * 10.0;
        // A whole number of tenths (`G1`, `G38.2`) is its own rounding.
        if (0.0..=65535.0).contains(&tenths) && f64::from(tenths as u16) == tenths {
            return Some(tenths as u16);
        }
        Self::code_rounded(value)
    }

    /// [`Word::code_of`] by rounding to tenths (within 1e-6 of a tenth), the reference
    /// the whole-tenths shortcut agrees with.
    fn code_rounded(value: f64) -> Option<u16> {
        let tenths = value * 10.0;
        let rounded = crate::emit::round_half_away(tenths);
        if (tenths - rounded).abs() < 1e-6 && (0.0..=65535.0).contains(&rounded) {
            Some(rounded as u16)
        } else {
            None
        }
    }
}

/// How a comment was written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommentStyle {
    /// `( … )`
    Paren,
    /// `; …` to the end of the line
    Semicolon,
    /// `' …` to the end of the line (FADAL)
    Apostrophe,
}

/// A comment; `text` is what stands between the delimiters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comment<'a> {
    /// Text inside the delimiters, as written.
    pub text: &'a str,
    /// Parentheses or semicolon.
    pub style: CommentStyle,
    /// Including the delimiters.
    pub span: Span,
}

/// Text a control reads but lampost keeps verbatim and does not interpret: a letter
/// with no number (`X` in `G28 X`, `R` in `T0 R`), a letter with a string or a bare
/// token (`P "MINI"`, `A3DBenchy.stl`, `judge_flag`), the message of `M117`/`M118`.
/// Read only where a firmware code may carry such words (see `docs/gcode.md`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Text<'a> {
    /// As written, from its first to its last byte.
    pub text: &'a str,
    /// Where it stands.
    pub span: Span,
}

impl Text<'_> {
    /// The axis letters this text names when it is made of axis letters alone
    /// (`X`, `XY`, `x y` as separate texts): bit `i` for `AXES[i]`; 0 otherwise.
    pub fn bare_axes(&self) -> u16 {
        let mut bits = 0u16;
        for c in self.text.bytes() {
            match crate::modal::axis_index(c.to_ascii_uppercase()) {
                Some(i) => bits |= 1 << i,
                None => return 0,
            }
        }
        bits
    }
}

/// A word or a comment, in the order written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Item<'a> {
    /// An address word.
    Word(Word<'a>),
    /// A comment.
    Comment(Comment<'a>),
    /// Verbatim text that is neither (see [`Text`]).
    Text(Text<'a>),
}

/// The kind of macro line, kept verbatim.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MacroKind {
    /// A FADAL macro statement: a line starting with `#` (`#V10 = 1`, `#IF … THEN GOTO:…`, `#PRINT`).
    FadalStatement,
    /// A FADAL block whose words take register values (`X+R6.`).
    FadalRegisterWords,
    /// A LinuxCNC parameter or expression line (`#<name> = …`, `X[#1+2]`).
    LinuxCncExpression,
    /// A LinuxCNC O-word control line (`o100 sub`, `o<name> call`).
    LinuxCncOWord,
    /// A Fanuc Macro B statement (`IF […] GOTO n`, `WHILE […] DO1`, `END1`, `GOTO n`) or
    /// `G65` call, where no reader follows it.
    FanucMacroB,
}

impl MacroKind {
    /// A short name for messages.
    pub fn describe(self) -> &'static str {
        match self {
            MacroKind::FadalStatement => "FADAL macro statement",
            MacroKind::FadalRegisterWords => "FADAL block with register (R) values",
            MacroKind::LinuxCncExpression => "LinuxCNC parameter expression",
            MacroKind::LinuxCncOWord => "LinuxCNC O-word control line",
            MacroKind::FanucMacroB => "Fanuc Macro B statement",
        }
    }
}

/// What a line holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlockKind {
    /// Words and comments (possibly none: a blank or comment-only line).
    Words,
    /// A `%` tape delimiter line; anything after the `%` is kept in `raw`.
    Percent,
    /// A macro line kept verbatim in `raw`.
    Macro(MacroKind),
}

/// One line of a program.
#[derive(Debug, Clone, PartialEq)]
pub struct Block<'a> {
    /// 1-based line number in the input.
    pub line: u32,
    /// The line's bytes, without the line ending.
    pub span: Span,
    /// What the line holds.
    pub kind: BlockKind,
    /// The line starts with `/` (block delete).
    pub block_delete: bool,
    /// Words and comments in the order written (empty for `Percent` and `Macro`).
    pub items: SmallVec<[Item<'a>; 8]>,
    /// The whole line as written, without the line ending.
    pub raw: &'a str,
    /// The letters (bit `letter - 'A'`) of words left out because their value was a
    /// vacant variable (Fanuc Macro B: `F#650` with `#650` vacant gives no F).
    pub vacant: u32,
}

impl<'a> Block<'a> {
    /// An empty block (a blank line) at `line`, starting at byte `offset`.
    pub fn empty(line: u32, offset: usize) -> Self {
        Block {
            line,
            span: Span::new(offset, offset),
            kind: BlockKind::Words,
            block_delete: false,
            items: SmallVec::new(),
            raw: "",
            vacant: 0,
        }
    }

    /// The words of the block, in order.
    pub fn words(&self) -> impl Iterator<Item = &Word<'a>> + '_ {
        self.items.iter().filter_map(|i| match i {
            Item::Word(w) => Some(w),
            Item::Comment(_) | Item::Text(_) => None,
        })
    }

    /// The comments of the block, in order.
    pub fn comments(&self) -> impl Iterator<Item = &Comment<'a>> + '_ {
        self.items.iter().filter_map(|i| match i {
            Item::Comment(c) => Some(c),
            Item::Word(_) | Item::Text(_) => None,
        })
    }

    /// The verbatim texts of the block (see [`Text`]), in order.
    pub fn texts(&self) -> impl Iterator<Item = &Text<'a>> + '_ {
        self.items.iter().filter_map(|i| match i {
            Item::Text(t) => Some(t),
            Item::Word(_) | Item::Comment(_) => None,
        })
    }

    /// The first word with this letter (and no FADAL register).
    pub fn word(&self, letter: u8) -> Option<&Word<'a>> {
        self.words()
            .find(|w| w.letter == letter && w.register.is_none())
    }

    /// True when the block has no words (blank, comment-only, `%`, or macro).
    pub fn has_words(&self) -> bool {
        self.words().next().is_some()
    }

    /// Equality of content: kind, block delete, and each word's letter, register and
    /// value, each comment's text and style; spans and number spelling are ignored.
    pub fn same_content(&self, other: &Block<'_>) -> bool {
        if self.kind != other.kind || self.block_delete != other.block_delete {
            return false;
        }
        match self.kind {
            BlockKind::Percent | BlockKind::Macro(_) => {
                return self.raw.trim() == other.raw.trim();
            }
            BlockKind::Words => {}
        }
        self.items.len() == other.items.len()
            && self
                .items
                .iter()
                .zip(other.items.iter())
                .all(|(a, b)| match (a, b) {
                    (Item::Word(x), Item::Word(y)) => {
                        x.letter == y.letter
                            && x.register == y.register
                            && x.value.to_bits() == y.value.to_bits()
                    }
                    (Item::Comment(x), Item::Comment(y)) => {
                        x.style == y.style && x.text.trim_end() == y.text.trim_end()
                    }
                    (Item::Text(x), Item::Text(y)) => x.text == y.text,
                    _ => false,
                })
    }
}

#[cfg(test)]
mod tests {
    use super::Word;

    proptest::proptest! {
        #[test]
        fn code_shortcut_agrees_with_rounding(
            whole in 0u32..70_000,
            tenth in 0u32..10,
            wiggle in proptest::prop_oneof![proptest::strategy::Just(0.0), -1e-6..1e-6f64],
            negative in proptest::bool::ANY,
        ) {
            let v = f64::from(whole) + f64::from(tenth) / 10.0 + wiggle;
            let v = if negative { -v } else { v };
            proptest::prop_assert_eq!(Word::code_of(v), Word::code_rounded(v));
        }
    }

    #[test]
    fn code_shortcut_edges() {
        for v in [
            0.0,
            -0.0,
            1.0,
            38.2,
            6553.5,
            6553.6,
            -0.1,
            f64::NAN,
            f64::INFINITY,
        ] {
            assert_eq!(Word::code_of(v), Word::code_rounded(v), "{v}");
        }
    }
}
