//! The parser: one line of bytes in, one [`Block`] (or one located error) out.
//!
//! Lexing walks the line byte by byte; the number grammar is a nom parser. Every
//! block and word keeps its byte span, and every number keeps its text, so
//! formatting can reproduce the digits exactly.

use nom::branch::alt;
use nom::bytes::complete::take_while;
use nom::character::complete::{char as nchar, digit0, digit1, one_of};
use nom::combinator::{opt, recognize};
use nom::sequence::{pair, tuple};
use nom::IResult;

use crate::ast::{Block, BlockKind, Comment, CommentStyle, Item, MacroKind, Span, Text, Word};
use crate::diag::{Diagnostic, ErrorKind, Severity};

/// Lines longer than this are refused without being read word by word.
pub const MAX_LINE_BYTES: usize = 64 * 1024;

/// What a flavour adds to the common reading of a line (see [`parse_line_with`]). A
/// plain `bool` is the slicer reading alone (`true`: [`Reading::slicer`]), as the
/// parser's callers have always passed it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Reading {
    /// A printer firmware's reading (slicer programs, E as extrusion): number exponents
    /// and whole-line `(` comments.
    pub slicer: bool,
    /// LinuxCNC's polar coordinates: `@` (radius) and `^` (angle) are words, with the
    /// letters `@` and `^` (elsewhere each is an unexpected character).
    pub polar: bool,
    /// Fanuc's and Haas's tape format: the `:` program number (`:0097`, the O address in
    /// ISO code) and the block skip levels `/1`–`/9` (Fanuc's additional optional block
    /// skip, which Mazak's EIA programs use too).
    pub fanuc_tape: bool,
    /// The FADAL's comments: a `(` with no `)` after it comments to the end of the line
    /// (its manual writes `N1 O1 (START OF PROGRAM`); elsewhere it is an error.
    pub open_comment: bool,
}

impl Reading {
    /// How `flavor` reads lines (`slicer`: a printer firmware's reading, E as
    /// extrusion): the one place the parser's choices are made from a flavour.
    pub fn of(flavor: crate::flavor::Flavor, slicer: bool) -> Reading {
        use crate::flavor::Flavor;
        Reading {
            slicer,
            polar: flavor == Flavor::LinuxCnc,
            fanuc_tape: matches!(flavor, Flavor::Fanuc | Flavor::Haas),
            open_comment: flavor == Flavor::Fadal && !slicer,
        }
    }
}

impl From<bool> for Reading {
    fn from(slicer: bool) -> Self {
        Reading {
            slicer,
            polar: false,
            fanuc_tape: false,
            open_comment: false,
        }
    }
}

/// Bit of a word's letter in a block's set of letters seen (`A` to `Z`, then LinuxCNC's
/// polar `@` and `^`), for the duplicate check.
#[inline]
pub(crate) fn letter_bit(letter: u8) -> u32 {
    match letter {
        b'@' => 1 << 26,
        b'^' => 1 << 27,
        l => 1u32 << (l.wrapping_sub(b'A') & 31),
    }
}

/// A number: optional sign, then digits with an optional decimal part, or a leading dot.
fn number(i: &str) -> IResult<&str, &str> {
    recognize(tuple((
        opt(one_of("+-")),
        take_while(|c: char| c == ' ' || c == '\t'),
        alt((
            recognize(pair(digit1, opt(pair(nchar('.'), digit0)))),
            recognize(pair(nchar('.'), digit1)),
        )),
    )))(i)
}

/// Parse a decimal number text (as accepted by `number`) to `f64`, correctly rounded.
pub fn parse_number(text: &str) -> Option<f64> {
    let bytes = text.as_bytes();
    let mut i = 0;
    let mut negative = false;
    if let Some(&c) = bytes.first() {
        if c == b'+' || c == b'-' {
            negative = c == b'-';
            i = 1;
        }
    }
    let mut mantissa: u64 = 0;
    let mut digits = 0u32;
    let mut decimals = 0u32;
    let mut seen_dot = false;
    let mut simple = true;
    for &c in &bytes[i..] {
        match c {
            b'0'..=b'9' => {
                if digits < 19 {
                    mantissa = mantissa * 10 + u64::from(c - b'0');
                    if mantissa != 0 {
                        digits += 1;
                    }
                    if seen_dot {
                        decimals += 1;
                    }
                } else {
                    simple = false;
                    break;
                }
            }
            b'.' => seen_dot = true,
            b' ' | b'\t' => {}
            _ => return None,
        }
    }
    // Exact fast path: both the integer mantissa and the power of ten are exact
    // doubles, so one correctly rounded division gives the correctly rounded value.
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    if simple && digits <= 15 && (decimals as usize) < POW10.len() {
        let v = mantissa as f64 / POW10[decimals as usize];
        return Some(if negative { -v } else { v });
    }
    let cleaned: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    let cleaned = cleaned.strip_prefix('+').unwrap_or(&cleaned);
    let cleaned = if cleaned.ends_with('.') {
        format!("{cleaned}0")
    } else {
        cleaned.to_string()
    };
    cleaned.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// The common spelling of a number (`[+-]digits[.digits]` or `[+-].digits`, at most 15
/// significant digits, no inner spaces) scanned and valued in one pass. `None` when the
/// text is anything else, which then goes to the nom grammar `number`; the two agree
/// wherever this one answers (property-tested).
pub fn fast_number(b: &[u8]) -> Option<(usize, f64)> {
    scan_number(b)
}

/// [`fast_number`], inlined where the parser's fast path reads every word's number.
#[inline(always)]
fn scan_number(b: &[u8]) -> Option<(usize, f64)> {
    const POW10: [f64; 16] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
    ];
    let (negative, start) = match b.first() {
        Some(b'-') => (true, 1),
        Some(b'+') => (false, 1),
        _ => (false, 0),
    };
    // The digits' value (wrapping: a number of more than 15 digits is refused below,
    // before its value is used).
    let mut mantissa: u64 = 0;
    let mut digits_of = |mut rest: &[u8]| {
        let len = rest.len();
        while let [c, tail @ ..] = rest {
            let d = c.wrapping_sub(b'0');
            if d >= 10 {
                break;
            }
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
            rest = tail;
        }
        len - rest.len()
    };
    let int_digits = digits_of(&b[start..]);
    let mut i = start + int_digits;
    let mut decimals = 0usize;
    if b.get(i) == Some(&b'.') {
        i += 1;
        decimals = digits_of(&b[i..]);
        i += decimals;
    }
    let digits = int_digits + decimals;
    if digits == 0 || digits > 15 {
        return None;
    }
    // At most 15 digits: the mantissa is below 2^53, exact as an `i64` and as an `f64`
    // (the signed conversion is one instruction). Whole numbers (`G1`, `F1200.`) need
    // no division (by 1: the same value). The sign goes on last, so `-0` is -0.0.
    let m = mantissa as i64 as f64;
    let v = match decimals {
        0 => m,
        d => m / POW10[d],
    };
    Some((i, if negative { -v } else { v }))
}

const OWORD_KEYWORDS: [&str; 15] = [
    "sub",
    "endsub",
    "call",
    "if",
    "elseif",
    "else",
    "endif",
    "while",
    "endwhile",
    "do",
    "return",
    "repeat",
    "endrepeat",
    "break",
    "continue",
];

pub(crate) fn is_oword(rest: &str) -> bool {
    let b = rest.as_bytes();
    if b.len() < 2 || !(b[0] == b'o' || b[0] == b'O') {
        return false;
    }
    if b[1] == b'<' {
        return true;
    }
    let digits = rest[1..].bytes().take_while(u8::is_ascii_digit).count();
    if digits == 0 {
        return false;
    }
    let after = rest[1 + digits..].trim_start();
    let word: String = after
        .chars()
        .take_while(|c| c.is_ascii_alphabetic())
        .collect::<String>()
        .to_ascii_lowercase();
    OWORD_KEYWORDS.contains(&word.as_str())
}

/// The end of the string that opens at `open` (a `"`): one past its closing quote, or
/// the end of the line when it is not closed.
fn string_end(bytes: &[u8], open: usize) -> usize {
    memchr::memchr(b'"', &bytes[open + 1..]).map_or(bytes.len(), |rel| open + 2 + rel)
}

/// In a block whose words may be a firmware code's own (after an M-code lampost does
/// not act on, a T word, or a homing code): where the word starting at `start` (its
/// letter) is really verbatim text, the end of that text; `None` when it is an ordinary
/// word. Text is a letter alone (`X` in `G28 X`, `R` in `T0 R`), a letter and a string
/// (`P "MINI"`, `P"Input shaper"`), or a token that is not letters and numbers in turn
/// (`A3DBenchy.stl`, `judge_flag`); a token runs to a blank, `;` or `(` outside quotes.
fn text_token(text: &str, start: usize) -> Option<usize> {
    let bytes = text.as_bytes();
    let mut k = start + 1;
    while k < bytes.len() && !matches!(bytes[k], b' ' | b'\t' | b';' | b'(') {
        k = if bytes[k] == b'"' {
            string_end(bytes, k)
        } else {
            k + 1
        };
    }
    if k == start + 1 {
        // A letter alone: a number or a string may follow after blanks.
        let mut m = k;
        while m < bytes.len() && (bytes[m] == b' ' || bytes[m] == b'\t') {
            m += 1;
        }
        return match bytes.get(m) {
            Some(b'"') => Some(string_end(bytes, m)),
            Some(c) if c.is_ascii_digit() || matches!(c, b'+' | b'-' | b'.') => None,
            _ => Some(k),
        };
    }
    // Letters and numbers in turn (`X4000Y4000`) are words.
    let mut p = start;
    while p < k {
        if !bytes[p].is_ascii_alphabetic() {
            return Some(k);
        }
        p += 1;
        let len = match fast_number(&bytes[p..k]) {
            Some((len, _)) => len,
            None => match number(&text[p..k]) {
                Ok((rest, _)) => k - p - rest.len(),
                Err(_) => return Some(k),
            },
        };
        p += len;
    }
    None
}

/// A value spelled `nan`, `inf` or `infinity` (any case, signed or not) at the start of
/// `rest`, as a script whose arithmetic failed writes it (`G3 X3 Enan Fnan`): the text
/// of it, for a message that says so (finding 46).
fn not_a_number(rest: &str) -> Option<&str> {
    let b = rest.as_bytes();
    let sign = usize::from(matches!(b.first(), Some(b'+' | b'-')));
    let word_end = b[sign..]
        .iter()
        .position(|c| !c.is_ascii_alphabetic())
        .map_or(b.len(), |p| sign + p);
    let word = rest[sign..word_end].to_ascii_lowercase();
    matches!(word.as_str(), "nan" | "inf" | "infinity").then(|| &rest[..word_end])
}

/// The end of a number read from `start` to `end` when digits follow it after blanks:
/// rs274 and Fanuc's controls take the blanks out of a block before reading it, so
/// `X 1 0.5` is X10.5, `G 0 1` is G1 and `X1 .5` is X1.5. The digits after each run of
/// blanks, and one decimal point if the number has none yet, continue it; anything else
/// (a letter, a sign, a second point, a comment) ends it. `end` itself when no blank
/// and digit follow.
fn blank_continued(bytes: &[u8], start: usize, mut end: usize) -> usize {
    // Mostly a blank and then a letter: nothing continues the number.
    let next = bytes[end..]
        .iter()
        .find(|c| !matches!(c, b' ' | b'\t'))
        .copied();
    if end == bytes.len()
        || !matches!(bytes[end], b' ' | b'\t')
        || !next.is_some_and(|c| c.is_ascii_digit() || c == b'.')
    {
        return end;
    }
    let mut point = bytes[start..end].contains(&b'.');
    loop {
        let mut k = end;
        while matches!(bytes.get(k), Some(b' ' | b'\t')) {
            k += 1;
        }
        if k == end {
            return end;
        }
        let mut took = false;
        loop {
            match bytes.get(k) {
                Some(c) if c.is_ascii_digit() => {}
                Some(b'.') if !point => point = true,
                _ => break,
            }
            k += 1;
            took = true;
        }
        if !took {
            return end;
        }
        end = k;
    }
}

/// An exponent right after a number's digits, when exponents are read: a lower-case
/// `e`, an optional sign and at least one digit (`1e-05`, `2.5e3`). The end of the
/// exponent, or `None`.
fn exponent_end(bytes: &[u8], end: usize) -> Option<usize> {
    if bytes.get(end) != Some(&b'e')
        || end == 0
        || !bytes[end - 1].is_ascii_digit() && bytes[end - 1] != b'.'
    {
        return None;
    }
    let mut k = end + 1;
    if matches!(bytes.get(k), Some(b'+' | b'-')) {
        k += 1;
    }
    let digits = bytes[k.min(bytes.len())..]
        .iter()
        .take_while(|c| c.is_ascii_digit())
        .count();
    (digits > 0).then_some(k + digits)
}

/// The number of a polar word (`@` or `^` at `at`, its number from `j`): its end and
/// value, or the error (a bare `@` has no number; a number that cannot be read).
fn polar_number(
    text: &str,
    at: usize,
    j: usize,
) -> Result<(usize, f64), (ErrorKind, usize, usize)> {
    let bytes = text.as_bytes();
    if let Some((len, value)) = fast_number(&bytes[j..]) {
        return Ok((j + len, value));
    }
    match number(&text[j..]) {
        Ok((rest, num)) => {
            let end = bytes.len() - rest.len();
            parse_number(num)
                .map(|v| (end, v))
                .ok_or_else(|| (ErrorKind::BadNumber(num.to_string()), at, end))
        }
        Err(_) => Err((
            ErrorKind::LetterWithoutNumber(char::from(bytes[at])),
            at,
            at + 1,
        )),
    }
}

/// Parse one line (without its line ending) into a block.
///
/// `line_no` is 1-based; `offset` is the byte offset of the line's first byte in the
/// whole input, so spans point into the input. At most one error is reported per line.
pub fn parse_line(line: &[u8], line_no: u32, offset: usize) -> Result<Block<'_>, Diagnostic> {
    let mut block = Block::empty(line_no, offset);
    parse_line_into(line, line_no, offset, &mut block)?;
    Ok(block)
}

/// [`parse_line`] into a caller's block (which is reset first), so the block is built
/// where it will be used instead of being moved there: the streaming path uses this.
pub fn parse_line_into<'a>(
    line: &'a [u8],
    line_no: u32,
    offset: usize,
    block: &mut Block<'a>,
) -> Result<(), Diagnostic> {
    parse_line_with(line, line_no, offset, block, false)
}

/// [`parse_line_into`], with a printer firmware's reading when `slicer` is set (slicer
/// programs, where E is extrusion):
/// - number exponents: a lower-case `e` directly after a number's digits, with an
///   optional sign and digits, is that number's exponent (`X1e-05`). An upper-case `E`
///   always starts a word (`X1E-5` is X1 and E-5), and without `slicer` so does a
///   lower-case one (E is a FADAL fixture offset there: `X1e5` is X1 E5);
/// - a line that starts with `(`, holds a `)` and cannot be read otherwise is one
///   comment, parentheses inside it too (a firmware reads no command from it;
///   Skeinforge's settings lines).
///
/// With [`Reading::polar`] (the `linuxcnc` flavour) `@` and `^` followed by a number (or
/// a parameter or `[…]` expression, which makes the line a macro line) are words.
pub fn parse_line_with<'a>(
    line: &'a [u8],
    line_no: u32,
    offset: usize,
    block: &mut Block<'a>,
    reading: impl Into<Reading>,
) -> Result<(), Diagnostic> {
    let reading = reading.into();
    reset(block, line_no, offset, line.len());
    if line.len() > MAX_LINE_BYTES {
        return Err(too_long(line, line_no, offset));
    }
    if line_no == 1 && line.starts_with(b"GCDE") {
        // Binary G-code: named once, at its magic, rather than as stray bytes or letters.
        return Err(Diagnostic::at(
            Severity::Error,
            ErrorKind::ForeignLanguage(crate::foreign::BINARY_GCODE),
            line_no,
            offset,
            line,
            0,
            4,
        ));
    }
    let text = match std::str::from_utf8(line) {
        Ok(t) => t,
        Err(e) => {
            let at = e.valid_up_to();
            return Err(Diagnostic::at(
                Severity::Error,
                ErrorKind::InvalidUtf8,
                line_no,
                offset,
                line,
                at,
                at + e.error_len().unwrap_or(1),
            ));
        }
    };
    parse_text(text, line_no, offset, block, reading)
}

/// A line that is not UTF-8 only inside its comments (`(…)`, and `;` to the end), as
/// text with each byte of every bad sequence there read as `?`: the same length, so every
/// column stays where it was. `None` when the line is UTF-8, or when a byte outside a
/// comment is not ASCII (then the line is refused as it is). A control skips comments,
/// and older CAM systems write them in Latin-1 or Windows-1252.
pub fn comments_made_utf8(line: &[u8]) -> Option<String> {
    if std::str::from_utf8(line).is_ok() {
        return None;
    }
    let mut text = line.to_vec();
    let mut i = 0;
    while i < text.len() {
        let end = match text[i] {
            b'(' => memchr::memchr(b')', &text[i..]).map_or(text.len(), |r| i + r),
            b';' => text.len(),
            c if c.is_ascii() => {
                i += 1;
                continue;
            }
            _ => return None,
        };
        let mut at = i;
        while let Err(e) = std::str::from_utf8(&text[at..end]) {
            let bad_start = at + e.valid_up_to();
            let bad_end = e.error_len().map_or(end, |n| bad_start + n);
            text[bad_start..bad_end].fill(b'?');
            at = bad_end;
        }
        i = end + 1;
    }
    String::from_utf8(text).ok()
}

/// [`parse_line_with`], except that a line that is not UTF-8 only inside its comments is
/// read with those bytes as `?` ([`comments_made_utf8`], the text kept in `scratch`):
/// `Ok(true)` then, and the caller reports [`comment_not_utf8`] (once a program is enough).
pub fn parse_line_lenient<'a>(
    line: &'a [u8],
    line_no: u32,
    offset: usize,
    block: &mut Block<'a>,
    reading: impl Into<Reading>,
    scratch: &'a mut Option<String>,
) -> Result<bool, Diagnostic> {
    let reading = reading.into();
    match parse_line_with(line, line_no, offset, block, reading) {
        Err(d) if matches!(d.kind, ErrorKind::InvalidUtf8) => match comments_made_utf8(line) {
            Some(text) => {
                let text: &'a str = scratch.insert(text);
                parse_str_with(text, line_no, offset, block, reading).map(|()| true)
            }
            None => Err(d),
        },
        r => r.map(|()| false),
    }
}

/// The warning for a line whose comments are not UTF-8 (see [`parse_line_lenient`]), at
/// its first such byte.
pub fn comment_not_utf8(line: &[u8], line_no: u32, offset: usize) -> Diagnostic {
    let (at, len) = match std::str::from_utf8(line) {
        Ok(_) => (0, line.len()),
        Err(e) => (e.valid_up_to(), e.error_len().unwrap_or(1)),
    };
    Diagnostic::at(
        Severity::Warning,
        ErrorKind::CommentNotUtf8,
        line_no,
        offset,
        line,
        at,
        at + len,
    )
}

/// [`parse_line_with`] of a line its source has already found to be UTF-8 (see
/// [`crate::Line::text`]): the same block or error, without checking the text again.
pub fn parse_str_with<'a>(
    text: &'a str,
    line_no: u32,
    offset: usize,
    block: &mut Block<'a>,
    reading: impl Into<Reading>,
) -> Result<(), Diagnostic> {
    reset(block, line_no, offset, text.len());
    if text.len() > MAX_LINE_BYTES {
        return Err(too_long(text.as_bytes(), line_no, offset));
    }
    parse_text(text, line_no, offset, block, reading.into())
}

/// The block of an empty line at `line_no`, spanning `len` bytes from `offset`.
fn reset(block: &mut Block<'_>, line_no: u32, offset: usize, len: usize) {
    block.line = line_no;
    block.span = Span::new(offset, offset + len);
    block.kind = BlockKind::Words;
    block.block_delete = false;
    block.items.clear();
    block.raw = "";
}

#[cold]
fn too_long(line: &[u8], line_no: u32, offset: usize) -> Diagnostic {
    Diagnostic::at(
        Severity::Error,
        ErrorKind::LineTooLong(line.len()),
        line_no,
        offset,
        line,
        0,
        1,
    )
}

/// A line of text (not over [`MAX_LINE_BYTES`]) into `block` (reset): the common line
/// by [`simple_words`], any other by [`words_reference`].
fn parse_text<'a>(
    text: &'a str,
    line_no: u32,
    offset: usize,
    block: &mut Block<'a>,
    reading: Reading,
) -> Result<(), Diagnostic> {
    block.raw = text;
    if simple_words(text, offset, reading.slicer, &mut block.items) {
        return Ok(());
    }
    block.items.clear();
    words_reference(text, line_no, offset, block, reading)
}

/// The fast path of the parser, for the lines programs are mostly made of: words whose
/// number follows the letter directly in its common spelling (see [`fast_number`]), each
/// letter once (G and M may repeat), blanks, and comments. Their items are pushed to
/// `items` and `true` returned; `false` (items partly pushed) for anything else, from
/// block delete, macros and O-words to a G or M code that makes the rest of the block a
/// firmware code's own (homing, bed levelling, an M-code lampost does not act on, a
/// message) or a T word: [`words_reference`] reads those. Where this answers, the two
/// give the same items (property-tested).
fn simple_words<'a>(
    text: &'a str,
    offset: usize,
    slicer: bool,
    items: &mut smallvec::SmallVec<[Item<'a>; 8]>,
) -> bool {
    let bytes = text.as_bytes();
    let mut seen: u32 = 0;
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        match c {
            b' ' | b'\t' => i += 1,
            b'a'..=b'z' | b'A'..=b'Z' => {
                let letter = c.to_ascii_uppercase();
                // O-word lines and FADAL program numbers, FADAL R registers (`R1+1.`) and
                // T words (the rest of the block may be the firmware's) go the long way.
                if matches!(letter, b'O' | b'T')
                    || letter == b'R'
                        && bytes.get(i + 1).is_some_and(u8::is_ascii_digit)
                        && matches!(bytes.get(i + 2), Some(b'+' | b'-'))
                {
                    return false;
                }
                let Some((len, value)) = scan_number(&bytes[i + 1..]) else {
                    return false;
                };
                let end = i + 1 + len;
                if slicer && bytes.get(end) == Some(&b'e') {
                    return false;
                }
                match letter {
                    b'G' => {
                        if Word::code_of(value)
                            .is_none_or(|c| matches!(c, 280 | 290 | 300 | 1610 | 1620))
                        {
                            return false;
                        }
                    }
                    b'M' => {
                        if Word::m_code_of(value).is_none_or(|c| !crate::modal::m_known(c)) {
                            return false;
                        }
                    }
                    _ => {
                        let bit = 1u32 << (letter - b'A');
                        if seen & bit != 0 {
                            return false;
                        }
                        seen |= bit;
                    }
                }
                items.push(Item::Word(Word {
                    letter,
                    register: None,
                    value,
                    text: &text[i + 1..end],
                    span: Span::new(offset + i, offset + end),
                }));
                i = end;
            }
            b'(' => match memchr::memchr(b')', &bytes[i + 1..]) {
                Some(rel) => {
                    let end = i + 1 + rel;
                    items.push(Item::Comment(Comment {
                        text: &text[i + 1..end],
                        style: CommentStyle::Paren,
                        span: Span::new(offset + i, offset + end + 1),
                    }));
                    i = end + 1;
                }
                None => return false,
            },
            b';' => {
                items.push(Item::Comment(Comment {
                    text: &text[i + 1..],
                    style: CommentStyle::Semicolon,
                    span: Span::new(offset + i, offset + bytes.len()),
                }));
                return true;
            }
            _ => return false,
        }
    }
    true
}

/// A line of plain motion (see [`plain_motion`]): what the interpreter's fast lane
/// needs of it, read straight from the bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PlainMotion {
    /// `G0`, `G1`, `G2` or `G3` (as codes in tenths: 0, 10, 20, 30), when the line
    /// names one.
    pub motion: Option<u16>,
    /// The words given, bit `s` for slot `s` (see [`PLAIN_LETTERS`]).
    words: u16,
    /// The words' values by slot (0 where `words` has no bit): the axes first, by index
    /// in `AXES`, then I, J and K.
    values: [f64; PLAIN_SLOTS],
}

impl PlainMotion {
    /// The axes with a word, bit `i` for `AXES[i]`.
    pub fn axes(&self) -> u16 {
        self.words & ((1 << PLAIN_I) - 1)
    }

    /// Axis `i`'s word (`AXES[i]`), 0 where [`PlainMotion::axes`] has no bit.
    pub fn axis(&self, i: usize) -> f64 {
        self.values[i]
    }

    /// The centre words I, J, K given, bit `i` for `IJK[i]`.
    pub fn centres(&self) -> u8 {
        ((self.words >> PLAIN_I) & 0b111) as u8
    }

    /// Centre word `i` (`IJK[i]`), 0 where [`PlainMotion::centres`] has no bit.
    pub fn centre(&self, i: usize) -> f64 {
        self.values[usize::from(PLAIN_I) + i]
    }

    /// The F word's value.
    pub fn feed(&self) -> Option<f64> {
        (self.words & (1 << PLAIN_F) != 0).then_some(self.values[usize::from(PLAIN_F)])
    }
}

/// The fast lane's reading of a line (see [`crate::stream`]): the common move of CAM
/// output, `[N…] [G0|G1|G2|G3] axis words [I… J… K…] [F…]` in any order, each letter once, every
/// number in its common spelling ([`scan_number`]), blanks between words, nothing else
/// (no comment, no E, no other letter or code). `None` for anything else, which the
/// reference path ([`parse_line_with`], then [`crate::Interpreter::block`]) reads; where
/// this answers, the two give the same events (property-tested in `stream.rs`).
const NOT_PLAIN: u8 = 255;
/// Slots of [`PlainMotion`]'s values: the axes (0 to 8), I, J and K (9 to 11), then
/// G, F and N.
const PLAIN_I: u8 = 9;
const PLAIN_G: u8 = 12;
const PLAIN_F: u8 = 13;
const PLAIN_N: u8 = 14;
const PLAIN_SLOTS: usize = 15;

/// What each letter (`A` first) is to [`plain_motion`]: its slot (an axis by its index
/// in `AXES`, a centre word by `PLAIN_I` + its index in `IJK`, G, F, N), or a letter that
/// sends the line to the reference path.
const PLAIN_LETTERS: [u8; 26] = {
    let mut kinds = [NOT_PLAIN; 26];
    let mut i = 0;
    while i < crate::modal::AXES.len() {
        kinds[(crate::modal::AXES[i] - b'A') as usize] = i as u8;
        i += 1;
    }
    kinds[(b'I' - b'A') as usize] = PLAIN_I;
    kinds[(b'J' - b'A') as usize] = PLAIN_I + 1;
    kinds[(b'K' - b'A') as usize] = PLAIN_I + 2;
    kinds[(b'G' - b'A') as usize] = PLAIN_G;
    kinds[(b'F' - b'A') as usize] = PLAIN_F;
    kinds[(b'N' - b'A') as usize] = PLAIN_N;
    kinds
};

// Not inlined: inlined into `Stream::next` (as fat LTO does) it measured about 10 %
// slower (`cargo xtask bench gcode`).
#[inline(never)]
pub(crate) fn plain_motion(bytes: &[u8]) -> Option<PlainMotion> {
    // Each word's value goes to its letter's slot, with no branch on the letter; what
    // the words mean is read once, after the line.
    let mut values = [0.0; PLAIN_SLOTS];
    let mut words: u16 = 0;
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        if c == b' ' || c == b'\t' {
            i += 1;
            continue;
        }
        // Letters (either case) only, and each once.
        let index = (c | 0x20).wrapping_sub(b'a');
        let slot = *PLAIN_LETTERS.get(usize::from(index))?;
        // `NOT_PLAIN` is no slot.
        let value = values.get_mut(usize::from(slot))?;
        let bit = 1u16 << slot;
        if words & bit != 0 {
            return None;
        }
        words |= bit;
        let (len, v) = scan_number(&bytes[i + 1..])?;
        *value = v;
        i += 1 + len;
    }
    // G0 to G3 exactly (any other spelling `Word::code_of` reads as one of them,
    // `G1.0000001`, goes the reference way).
    let motion = if words & (1 << PLAIN_G) != 0 {
        Some(match values[usize::from(PLAIN_G)] {
            0.0 => 0,
            1.0 => 10,
            2.0 => 20,
            3.0 => 30,
            _ => return None,
        })
    } else {
        None
    };
    Some(PlainMotion {
        motion,
        words,
        values,
    })
}

/// The parser's reference path: every line [`simple_words`] does not take (and, in the
/// tests, every line), into `block` (reset, with its text).
///
/// A line that fails after a `(` comment holding another `(` fails because comments do
/// not nest (`(DRILL 3MM (R))` ends at the first `)`, and the second is left over):
/// that is the error reported, at the inner `(`, rather than what is left over.
fn words_reference<'a>(
    text: &'a str,
    line_no: u32,
    offset: usize,
    block: &mut Block<'a>,
    reading: impl Into<Reading>,
) -> Result<(), Diagnostic> {
    let reading = reading.into();
    let read = words_reference_items(text, line_no, offset, block, reading);
    if read.is_err() && reading.slicer {
        if let Some(c) = whole_line_comment(text, offset) {
            // A printer firmware reads no command from a line that starts with `(`: where
            // the line cannot be read otherwise, it is one comment, parentheses inside it
            // too (Skeinforge writes `(<setting> comb Running_Jump_Space_(mm): 2.0
            // </setting>)`).
            block.items.clear();
            block.items.push(Item::Comment(c));
            return Ok(());
        }
    }
    let Err(e) = read else {
        return Ok(());
    };
    // A `(` inside a comment, before where reading failed: comments do not nest. Said
    // first, so that a comment's words (`(ROUGH CYCLE (PASS 1))`) are never taken for
    // another language's.
    let nested = block.items.iter().find_map(|item| match item {
        Item::Comment(c) if c.style == CommentStyle::Paren && c.span.start < e.span.start => {
            // The comment's text starts one byte after its `(`.
            memchr::memchr(b'(', c.text.as_bytes()).map(|r| c.span.start + 1 + r - offset)
        }
        _ => None,
    });
    if let Some(at) = nested {
        return Err(Diagnostic::at(
            Severity::Error,
            ErrorKind::NestedComment,
            line_no,
            offset,
            text.as_bytes(),
            at,
            at + 1,
        ));
    }
    if let Some(f) = crate::foreign_language(text) {
        // Name the language rather than a stray letter of it.
        let start = text.len() - text.trim_start().len();
        return Err(Diagnostic::at(
            Severity::Error,
            ErrorKind::ForeignLanguage(f),
            line_no,
            offset,
            text.as_bytes(),
            start,
            text.trim_end().len().max(start + 1).min(text.len()),
        ));
    }
    Err(e)
}

/// The whole line as one `(` comment, when it starts (after blanks) with `(` and holds a
/// `)`: the text between the `(` and a `)` that ends the line (or the line's end).
fn whole_line_comment(text: &str, offset: usize) -> Option<Comment<'_>> {
    let start = text.len() - text.trim_start_matches([' ', '\t']).len();
    let rest = &text[start..];
    if !rest.starts_with('(') || !rest.contains(')') {
        return None;
    }
    let body = &rest[1..];
    let body = body.trim_end().strip_suffix(')').unwrap_or(body);
    Some(Comment {
        text: body,
        style: CommentStyle::Paren,
        span: Span::new(offset + start, offset + text.len()),
    })
}

fn words_reference_items<'a>(
    text: &'a str,
    line_no: u32,
    offset: usize,
    block: &mut Block<'a>,
    reading: Reading,
) -> Result<(), Diagnostic> {
    let slicer = reading.slicer;
    let line = text.as_bytes();
    let err = |kind: ErrorKind, start: usize, end: usize| {
        Diagnostic::at(Severity::Error, kind, line_no, offset, line, start, end)
    };
    let bytes = line;
    let mut i = 0;
    // Blanks, and carriage returns at the start of a line: a file whose lines end
    // `\n\r` (a script's) starts every line with one, which rs274 reads as white space.
    // One inside a line stays an error: bare carriage returns as line ends (an old Mac
    // file) would otherwise join lines into one block.
    while i < bytes.len() && matches!(bytes[i], b' ' | b'\t' | b'\r') {
        i += 1;
    }
    if i == bytes.len() {
        return Ok(());
    }
    match bytes[i] {
        b'%' => {
            block.kind = BlockKind::Percent;
            return Ok(());
        }
        b'#' => {
            let next = bytes.get(i + 1).copied().unwrap_or(b' ');
            // `#1 =`, `#<name> =` and the indirect `#[expr] =` (pcb2gcode's autolevel
            // stores each probe so); FADAL statements follow `#` with a letter or `:`,
            // or a blank (`N1 # V1 = V1 + 2.` in the FADAL manual). LinuxCNC reads every
            // `#` line as a parameter setting, blanks skipped (`# 1 = 5` sets #1), and
            // refuses one that is none (rs274's "Equal sign missing in parameter
            // setting").
            block.kind = if reading.polar || next == b'<' || next == b'[' || next.is_ascii_digit() {
                BlockKind::Macro(MacroKind::LinuxCncExpression)
            } else {
                BlockKind::Macro(MacroKind::FadalStatement)
            };
            return Ok(());
        }
        b'/' => {
            block.block_delete = true;
            i += 1;
            // `/2 G0 X10.`: a skip level (one digit, a number of its own) under Fanuc's
            // tape format; the switch is one for every level. rs274 refuses it.
            let digit = |k: usize| bytes.get(k).is_some_and(u8::is_ascii_digit);
            if reading.fanuc_tape
                && bytes.get(i).is_some_and(|c| (b'1'..=b'9').contains(c))
                && !digit(i + 1)
                && bytes.get(i + 1) != Some(&b'.')
            {
                i += 1;
            }
        }
        b'$' if crate::foreign_language(text).is_some() => {
            // Not a grbl console line: another language's header (Okuma's `$O0137.MIN%`).
            if let Some(f) = crate::foreign_language(text) {
                return Err(err(
                    ErrorKind::ForeignLanguage(f),
                    i,
                    text.trim_end().len().max(i + 1),
                ));
            }
        }
        b'$' | b'?' => {
            // A grbl console line (`$H`, `$$`, `$32=1`, `?`), kept verbatim; a `;` or `(`
            // comment after it stays a comment.
            let stop = bytes[i..]
                .iter()
                .position(|&c| c == b';' || c == b'(')
                .map_or(bytes.len(), |r| i + r);
            let cmd = text[i..stop].trim_end();
            block.items.push(Item::Text(Text {
                text: cmd,
                span: Span::new(offset + i, offset + i + cmd.len()),
            }));
            i = stop;
        }
        _ => {}
    }
    if block.block_delete {
        // `/ o100 repeat [2]`: an O-word line may be block-deleted too.
        while i < bytes.len() && matches!(bytes[i], b' ' | b'\t') {
            i += 1;
        }
    }
    if bytes.get(i).is_some_and(|c| matches!(c, b'o' | b'O')) && is_oword(text[i..].trim_start()) {
        block.kind = BlockKind::Macro(MacroKind::LinuxCncOWord);
        return Ok(());
    }
    // Letters seen so far (bit per letter) and FADAL R registers seen.
    let mut seen: u32 = 0;
    let mut seen_reg: u16 = 0;
    // The block's words may be a firmware code's own (see `text_token`).
    let mut lenient = false;
    // The words after a firmware M-code are its own, repeats included (Bambu
    // `M970.3 Q0 A7 B30 C90 Q0 H15 K0`).
    let mut firmware = false;
    // An M3, M4 or M5 outside LinuxCNC: a bare `I` is Marlin's inline-mode flag.
    let mut inline_flag = false;
    while i < bytes.len() {
        let c = bytes[i];
        // Fanuc's and Haas's ISO program number `:0097` is the O address (rs274 refuses
        // it, so only under those flavours), at the start of a block.
        let c = if c == b':'
            && reading.fanuc_tape
            && bytes.get(i + 1).is_some_and(u8::is_ascii_digit)
            && block
                .items
                .iter()
                .all(|it| matches!(it, Item::Word(w) if w.letter == b'N'))
        {
            b'O'
        } else {
            c
        };
        match c {
            b' ' | b'\t' => i += 1,
            b'(' => match memchr::memchr(b')', &bytes[i + 1..]) {
                Some(rel) => {
                    let end = i + 1 + rel;
                    block.items.push(Item::Comment(Comment {
                        text: &text[i + 1..end],
                        style: CommentStyle::Paren,
                        span: Span::new(offset + i, offset + end + 1),
                    }));
                    i = end + 1;
                }
                None if reading.open_comment => {
                    block.items.push(Item::Comment(Comment {
                        text: &text[i + 1..],
                        style: CommentStyle::Paren,
                        span: Span::new(offset + i, offset + bytes.len()),
                    }));
                    i = bytes.len();
                }
                None => return Err(err(ErrorKind::UnterminatedComment, i, bytes.len())),
            },
            b';' | b'\'' => {
                // `'` starts a comment to the end of the line on the FADAL
                // (`N20 M98P9724 '*** REN DEFAULT ***`).
                block.items.push(Item::Comment(Comment {
                    text: &text[i + 1..],
                    style: if c == b';' {
                        CommentStyle::Semicolon
                    } else {
                        CommentStyle::Apostrophe
                    },
                    span: Span::new(offset + i, offset + bytes.len()),
                }));
                i = bytes.len();
            }
            b'$' if bytes
                .get(i + 1)
                .is_some_and(|&d| d.is_ascii_digit() || d == b'-') =>
            {
                // LinuxCNC spindle select (`M3 $0 S1000`): kept verbatim.
                let mut end = i + 2;
                while end < bytes.len() && bytes[end].is_ascii_digit() {
                    end += 1;
                }
                block.items.push(Item::Text(Text {
                    text: &text[i..end],
                    span: Span::new(offset + i, offset + end),
                }));
                i = end;
            }
            b'#' | b'[' => {
                // After an N number alone, `#` followed by a letter or `:` is a FADAL
                // statement (`N80 #:S1`, `N60 #WAIT`), as at the start of a line.
                let numbered_only = block
                    .items
                    .iter()
                    .all(|it| matches!(it, Item::Word(w) if w.letter == b'N'));
                let next = bytes.get(i + 1).copied().unwrap_or(b' ');
                let fadal = c == b'#'
                    && numbered_only
                    && !block.items.is_empty()
                    && (next.is_ascii_alphabetic() || next == b':');
                block.kind = BlockKind::Macro(if fadal {
                    MacroKind::FadalStatement
                } else {
                    MacroKind::LinuxCncExpression
                });
                block.items.clear();
                return Ok(());
            }
            b'@' | b'^' if reading.polar => {
                // LinuxCNC's polar coordinates: `@` the radius, `^` the angle (degrees).
                let mut j = i + 1;
                while j < bytes.len() && (bytes[j] == b' ' || bytes[j] == b'\t') {
                    j += 1;
                }
                let mut k = j;
                while k < bytes.len() && matches!(bytes[k], b'+' | b'-' | b' ' | b'\t') {
                    k += 1;
                }
                if matches!(bytes.get(k), Some(b'#' | b'[')) {
                    block.kind = BlockKind::Macro(MacroKind::LinuxCncExpression);
                    block.items.clear();
                    return Ok(());
                }
                let (end, value) =
                    polar_number(text, i, j).map_err(|(kind, s, e)| err(kind, s, e))?;
                let bit = letter_bit(c);
                if seen & bit != 0 {
                    return Err(err(
                        ErrorKind::DuplicateWord(char::from(c).to_string()),
                        i,
                        end,
                    ));
                }
                seen |= bit;
                block.items.push(Item::Word(Word {
                    letter: c,
                    register: None,
                    value,
                    text: &text[j..end],
                    span: Span::new(offset + i, offset + end),
                }));
                i = end;
            }
            b'"' if lenient => {
                let end = string_end(bytes, i);
                block.items.push(Item::Text(Text {
                    text: &text[i..end],
                    span: Span::new(offset + i, offset + end),
                }));
                i = end;
            }
            b'a'..=b'z' | b'A'..=b'Z' => {
                let letter = c.to_ascii_uppercase();
                let start = i;
                if lenient || inline_flag && letter == b'I' {
                    // A G or M letter among a firmware code's words is one of them
                    // (Bambu `M900 K0.02 M0.118825`), not a code of its own.
                    let own = firmware && matches!(letter, b'G' | b'M');
                    if let Some(end) = text_token(text, start).or_else(|| {
                        own.then(|| {
                            bytes[start..]
                                .iter()
                                .position(|c| matches!(c, b' ' | b'\t' | b';' | b'('))
                                .map_or(bytes.len(), |r| start + r)
                        })
                    }) {
                        block.items.push(Item::Text(Text {
                            text: &text[start..end],
                            span: Span::new(offset + start, offset + end),
                        }));
                        i = end;
                        continue;
                    }
                }
                let mut j = i + 1;
                while j < bytes.len() && (bytes[j] == b' ' || bytes[j] == b'\t') {
                    j += 1;
                }
                // FADAL signed register word: R<digit><sign><number>.
                let mut register = None;
                if letter == b'R'
                    && j + 1 < bytes.len()
                    && bytes[j].is_ascii_digit()
                    && (bytes[j + 1] == b'+' || bytes[j + 1] == b'-')
                {
                    register = Some(bytes[j] - b'0');
                    j += 1;
                }
                // A value taken from a register or expression makes the block a macro line.
                let mut k = j;
                if k < bytes.len() && (bytes[k] == b'+' || bytes[k] == b'-') {
                    k += 1;
                    // Blanks after the sign are nothing, as for a number (`Z - 5`, read
                    // by `number`): `X - [#1 + 2]` and `Y - #1` are expressions too,
                    // as rs274 and Fanuc's controls read them.
                    while k < bytes.len() && (bytes[k] == b' ' || bytes[k] == b'\t') {
                        k += 1;
                    }
                }
                if k < bytes.len() {
                    let v = bytes[k];
                    if v == b'#' || v == b'[' {
                        block.kind = BlockKind::Macro(MacroKind::LinuxCncExpression);
                        block.items.clear();
                        return Ok(());
                    }
                    if (v == b'R' || v == b'r' || v == b'V' || v == b'v')
                        && bytes.get(k + 1).is_some_and(u8::is_ascii_digit)
                    {
                        block.kind = BlockKind::Macro(MacroKind::FadalRegisterWords);
                        block.items.clear();
                        return Ok(());
                    }
                }
                let scanned = match fast_number(&bytes[j..]) {
                    Some((len, value)) => Ok((j + len, value)),
                    None => match number(&text[j..]) {
                        Ok((rest, num)) => {
                            let end = bytes.len() - rest.len();
                            parse_number(num).map(|v| (end, v)).ok_or_else(|| {
                                err(ErrorKind::BadNumber(num.to_string()), start, end)
                            })
                        }
                        Err(_) => Err(match not_a_number(&text[j..]) {
                            Some(n) => err(
                                ErrorKind::NotANumber(char::from(letter), n.to_string()),
                                start,
                                j + n.len(),
                            ),
                            // A line that starts with a run of letters
                            // (`roughing pass`): text written without its
                            // parentheses, not a word.
                            // (Not `GOO`, a G-oh-oh typo; not `OCIRCLE`, a
                            // Fanuc program's name.)
                            None if letter | 0x20 != b'o'
                                && bytes[..start].iter().all(u8::is_ascii_whitespace)
                                && !bytes
                                    .iter()
                                    .take_while(|&&b| b != b'(' && b != b';')
                                    .any(|b| b.is_ascii_digit() || b"[#=".contains(b))
                                && bytes[start..]
                                    .iter()
                                    .take_while(|b| b.is_ascii_alphabetic())
                                    .count()
                                    >= 4 =>
                            {
                                let end = bytes[start..]
                                    .iter()
                                    .position(|&b| b == b'(' || b == b';')
                                    .map_or(bytes.len(), |p| start + p);
                                let shown = text[start..end].trim_end();
                                err(
                                    ErrorKind::TextNotComment(shown.chars().take(40).collect()),
                                    start,
                                    start + shown.len(),
                                )
                            }
                            None => err(
                                ErrorKind::LetterWithoutNumber(char::from(letter)),
                                start,
                                start + 1,
                            ),
                        }),
                    },
                };
                let scanned = match scanned {
                    // Digits after blanks go on with the number (`X 1 0.5` is X10.5), as
                    // rs274 and Fanuc's controls read a block with its blanks taken out;
                    // a printer's firmware does not (finding 33).
                    Ok((end, value)) if !slicer => match blank_continued(bytes, j, end) {
                        e if e == end => Ok((end, value)),
                        e => parse_number(&text[j..e]).map(|v| (e, v)).ok_or_else(|| {
                            err(ErrorKind::BadNumber(text[j..e].to_string()), start, e)
                        }),
                    },
                    Ok((end, value)) if slicer => match exponent_end(bytes, end) {
                        Some(e) => text[j..e]
                            .parse::<f64>()
                            .ok()
                            .filter(|v| v.is_finite())
                            .map(|v| (e, v))
                            .ok_or_else(|| {
                                err(ErrorKind::BadNumber(text[j..e].to_string()), start, e)
                            }),
                        None => Ok((end, value)),
                    },
                    s => s,
                };
                match scanned {
                    Ok((end, value)) => {
                        let num = &text[j..end];
                        // Duplicate check (G and M may repeat).
                        if letter != b'G' && letter != b'M' && !firmware {
                            let dup = match register {
                                Some(r) => {
                                    let bit = 1u16 << r;
                                    let d = seen_reg & bit != 0;
                                    seen_reg |= bit;
                                    d
                                }
                                None => {
                                    let bit = letter_bit(letter);
                                    let d = seen & bit != 0;
                                    seen |= bit;
                                    d
                                }
                            };
                            if dup {
                                let name = match register {
                                    Some(r) => format!("R{r}"),
                                    None => char::from(letter).to_string(),
                                };
                                return Err(err(ErrorKind::DuplicateWord(name), start, end));
                            }
                        }
                        block.items.push(Item::Word(Word {
                            letter,
                            register,
                            value,
                            text: num,
                            span: Span::new(offset + start, offset + end),
                        }));
                        i = end;
                        // Only T, G and M words can make the rest of the block a
                        // firmware code's own (the common axis words skip all this).
                        let code = match letter {
                            b'M' => Word::m_code_of(value),
                            b'G' if !lenient => Word::code_of(value),
                            _ => None,
                        };
                        firmware |=
                            letter == b'M' && code.is_some_and(|c| !crate::modal::m_known(c));
                        // Marlin's inline laser mode: `M3 I`, `M4 I`, `M5 I` (a flag
                        // with no value; rs274 refuses it).
                        inline_flag |=
                            letter == b'M' && matches!(code, Some(30 | 40 | 50)) && !reading.polar;
                        if !lenient && matches!(letter, b'T' | b'G' | b'M') {
                            lenient = match (letter, code) {
                                (b'T', _) => true,
                                // Homing and bed levelling take bare flags (`G28 X`,
                                // Marlin and Bambu `G29 A`).
                                // So do a printer firmware's own G-codes (Marlin's
                                // `G26 C P T` mesh validation pattern).
                                (b'G', Some(c)) => {
                                    matches!(c, 280 | 290 | 300 | 1610 | 1620)
                                        || slicer && crate::modal::g_group(c).is_none()
                                        // Marlin's G61 (return to a saved position)
                                        // takes axis flags: `G61 XY S0`.
                                        || slicer && c == 610
                                }
                                // RepRapFirmware's macro call takes a file name:
                                // `M98 P"/macros/purge.g"`.
                                (b'M', Some(980)) => slicer,
                                (b'M', Some(c)) => !crate::modal::m_known(c),
                                _ => false,
                            };
                        }
                        if letter == b'M' && matches!(code, Some(1170 | 1180)) {
                            // The rest of the line, to a `;` comment, is a message.
                            let mut k = end;
                            while k < bytes.len() && (bytes[k] == b' ' || bytes[k] == b'\t') {
                                k += 1;
                            }
                            let stop =
                                memchr::memchr(b';', &bytes[k..]).map_or(bytes.len(), |r| k + r);
                            let msg = text[k..stop].trim_end();
                            if !msg.is_empty() {
                                block.items.push(Item::Text(Text {
                                    text: msg,
                                    span: Span::new(offset + k, offset + k + msg.len()),
                                }));
                            }
                            i = stop;
                        }
                    }
                    Err(e) => return Err(e),
                }
            }
            _ if lenient && !c.is_ascii_alphabetic() => {
                // A firmware code's own token that is no word (`: 2`, `1`): verbatim.
                let mut end = i + 1;
                while end < bytes.len() && !matches!(bytes[end], b' ' | b'\t' | b';' | b'(') {
                    end = if bytes[end] == b'"' {
                        string_end(bytes, end)
                    } else {
                        end + 1
                    };
                }
                block.items.push(Item::Text(Text {
                    text: &text[i..end],
                    span: Span::new(offset + i, offset + end),
                }));
                i = end;
            }
            b'0'..=b'9' | b'+' | b'-' | b'.' => {
                let end = match number(&text[i..]) {
                    Ok((rest, _)) => bytes.len() - rest.len(),
                    Err(_) => i + 1,
                };
                return Err(err(
                    ErrorKind::NumberWithoutLetter(text[i..end].to_string()),
                    i,
                    end,
                ));
            }
            _ => {
                let ch = text[i..].chars().next().unwrap_or('?');
                return Err(err(
                    ErrorKind::UnexpectedCharacter(ch),
                    i,
                    i + ch.len_utf8(),
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(s: &str) -> Vec<(char, Option<u8>, f64, String)> {
        let b = parse_line(s.as_bytes(), 1, 0).expect("parses");
        b.words()
            .map(|w| (w.letter_char(), w.register, w.value, w.text.to_string()))
            .collect()
    }

    /// A sign with blanks after it (`X - 5`, `Y- 2.5`, `X - [1 + 4]`): rs274 and Fanuc
    /// read the blanks as nothing (finding 37: the expression was refused).
    #[test]
    fn a_sign_with_blanks_after_it_signs_the_number() {
        let w = words("G0 X - 5 Y- 2.5 Z +\t.5 A -1");
        let v: Vec<_> = w.iter().map(|w| (w.0, w.2)).collect();
        assert_eq!(
            v,
            [
                ('G', 0.0),
                ('X', -5.0),
                ('Y', -2.5),
                ('Z', 0.5),
                ('A', -1.0)
            ]
        );
        // An expression or a parameter after the blanks makes a macro line, as without,
        // in every reading.
        for slicer in [false, true] {
            let reading = Reading {
                slicer,
                polar: false,
                fanuc_tape: false,
                open_comment: false,
            };
            for s in ["G0 X - [1 + 4]", "G0 Y - #1", "G0 Z -\t[2]"] {
                let mut b = Block::empty(1, 0);
                parse_line_with(s.as_bytes(), 1, 0, &mut b, reading).expect("parses");
                assert!(matches!(b.kind, BlockKind::Macro(_)), "{s}");
            }
        }
        // A second sign, or nothing after the blanks, is no number.
        for s in ["G0 X - -5", "G0 X - ", "G0 X -", "G0 X - -[1]"] {
            assert!(parse_line(s.as_bytes(), 1, 0).is_err(), "{s}");
        }
    }

    /// A value spelled `nan` or `inf` is named as such, at the word (finding 46).
    #[test]
    fn nan_and_inf_are_named_as_failed_calculations() {
        for (s, col, word) in [
            ("G3 X3 Y3 Z3 Enan Fnan;; Layer 1", 13, "Enan"),
            ("G1 X-inf", 4, "X-inf"),
            ("G1 F INF", 4, "FINF"),
            ("G1 YNaN", 4, "YNaN"),
        ] {
            let e = parse_line(s.as_bytes(), 1, 0).expect_err("refused");
            assert_eq!(e.column, col, "{s}");
            assert!(
                matches!(&e.kind, ErrorKind::NotANumber(..))
                    && e.kind.to_string().starts_with(word)
                    && e.kind.to_string().contains("not a number"),
                "{s}: {}",
                e.kind
            );
        }
        // Other letters after a letter are still a letter without a number.
        let e = parse_line(b"G1 Xnano", 1, 0).expect_err("refused");
        assert!(
            matches!(e.kind, ErrorKind::LetterWithoutNumber('X')),
            "{}",
            e.kind
        );
    }

    /// Blanks between a number's characters are nothing, as rs274 and Fanuc's controls
    /// read them (finding 33): `X 1 0.5` is X10.5; a printer's firmware reads no such
    /// number, and neither reading joins a sign, a second point or a comment.
    #[test]
    fn blanks_inside_a_number_are_nothing() {
        let w = words("G 0 1 X 1 0.5 Y- 2 Z1 .5 A1. 2 B 3 . 2 5 F1 0 0");
        let v: Vec<_> = w.iter().map(|w| (w.0, w.2)).collect();
        assert_eq!(
            v,
            [
                ('G', 1.0),
                ('X', 10.5),
                ('Y', -2.0),
                ('Z', 1.5),
                ('A', 1.2),
                ('B', 3.25),
                ('F', 100.0)
            ]
        );
        // A comment ends the number (rs274: "Bad character '2' used").
        for s in [
            "G0 X1 (a) 2 Y3",
            "G0 X1 -2",
            "G0 X1.5 .5",
            "G0 X1 2 Y3 4 X5",
        ] {
            assert!(parse_line(s.as_bytes(), 1, 0).is_err(), "{s}");
        }
        let mut b = Block::empty(1, 0);
        let slicer = Reading::from(true);
        assert!(parse_line_with(b"G1 X1 0.5", 1, 0, &mut b, slicer).is_err());
    }

    proptest::proptest! {
        /// A line of words with blanks put between any characters of its numbers reads
        /// as the line without them, under the LinuxCNC and the Fanuc reading.
        #[test]
        fn blanks_between_a_number_s_characters_change_nothing(
            ws in proptest::collection::vec(
                ("[XYZABCIJKFSPQR]", "[+-]?[0-9]{1,5}(\\.[0-9]{0,4})?",
                 proptest::collection::vec((0usize..12, "[ \t]{1,3}"), 0..4)),
                1..6,
            )
        ) {
            let mut letters = std::collections::HashSet::new();
            let mut plain = String::from("G1");
            let mut spaced = String::from("G 1");
            for (l, n, blanks) in &ws {
                if !letters.insert(l.clone()) {
                    continue;
                }
                plain.push_str(&format!(" {l}{n}"));
                let mut t = n.clone();
                let mut at: Vec<(usize, &String)> = blanks
                    .iter()
                    .map(|(k, b)| (1 + k % n.len(), b))
                    .filter(|(k, _)| *k < n.len())
                    .collect();
                at.sort_by_key(|b| std::cmp::Reverse(b.0));
                for (k, b) in at {
                    t.insert_str(k, b);
                }
                spaced.push_str(&format!(" {l}{t}"));
            }
            for flavor in [crate::flavor::Flavor::LinuxCnc, crate::flavor::Flavor::Fanuc] {
                let reading = Reading::of(flavor, false);
                let read = |line: &str| {
                    let mut b = Block::empty(1, 0);
                    parse_line_with(line.as_bytes(), 1, 0, &mut b, reading)
                        .map(|()| b.words().map(|w| (w.letter, w.value.to_bits())).collect::<Vec<_>>())
                        .map_err(|e| e.to_string())
                };
                proptest::prop_assert_eq!(read(&spaced), read(&plain), "{} / {}", spaced, plain);
                proptest::prop_assert!(read(&plain).is_ok(), "{}", plain);
            }
        }
    }

    #[test]
    fn numbers_in_every_spelling() {
        let w = words("G1X1Y2");
        assert_eq!(w[0].0, 'G');
        assert_eq!(w[1].2, 1.0);
        assert_eq!(w[2].2, 2.0);
        assert_eq!(words("x-.25")[0].2, -0.25);
        assert_eq!(words("X+.5")[0].2, 0.5);
        assert_eq!(words("X1.")[0].2, 1.0);
        assert_eq!(words("X 12.5")[0].2, 12.5);
        assert_eq!(words("X0.1")[0].2, 0.1);
        assert_eq!(words("X-34.78")[0].2, -34.78);
        assert_eq!(words("F9991300.0")[0].2, 9991300.0);
        assert_eq!(
            words("X12345678901234567890.5")[0].2,
            12345678901234567890.5
        );
    }

    proptest::proptest! {
        #[test]
        fn fast_number_agrees_with_nom_grammar(
            s in "[+-]?[0-9]{0,17}(\\.[0-9]{0,17})?[ XYG/:.\\x7f\\x00é0-9]{0,9}"
        ) {
            if let Some((len, v)) = fast_number(s.as_bytes()) {
                let (rest, text) = number(&s).expect("nom accepts what the fast path accepts");
                proptest::prop_assert_eq!(s.len() - rest.len(), len);
                proptest::prop_assert_eq!(parse_number(text), Some(v));
            }
            // And it answers exactly for the common spelling (at most 15 digits).
            let b = s.as_bytes();
            let sign = usize::from(matches!(b.first(), Some(b'+' | b'-')));
            let run = |from: usize| b[from..].iter().take_while(|c| c.is_ascii_digit()).count();
            let int = run(sign);
            let (end, digits) = match b.get(sign + int) {
                Some(b'.') => {
                    let frac = run(sign + int + 1);
                    (sign + int + 1 + frac, int + frac)
                }
                _ => (sign + int, int),
            };
            let expected = (1..=15)
                .contains(&digits)
                .then(|| (end, s[..end].parse::<f64>().expect("a number")));
            proptest::prop_assert_eq!(fast_number(b), expected);
        }
    }

    /// A token of a random line for the fast-path property: words in every spelling,
    /// comments, macro and firmware forms, and junk.
    fn token() -> impl proptest::strategy::Strategy<Value = String> {
        use proptest::prelude::*;
        prop_oneof![
            4 => ("[A-Za-z]", "[+-]?[0-9]{0,6}(\\.[0-9]{0,4})?").prop_map(|(l, n)| format!("{l}{n}")),
            2 => ("[GgMm]", prop_oneof![
                Just("0"), Just("1"), Just("2"), Just("3"), Just("28"), Just("29"), Just("30"),
                Just("161"), Just("38.2"), Just("3"), Just("104"), Just("117"), Just("118"),
                Just("1.05"), Just("99999"), Just("98"), Just("-1"), Just("6553.6"),
            ]).prop_map(|(l, n)| format!("{l}{n}")),
            1 => "[XYZ][0-9]{16,18}",
            1 => "[XYZEF]-?[0-9]\\.[0-9]e[+-]?[0-9]",
            1 => "[XR][0-9][+-][0-9]\\.",
            1 => prop_oneof![
                Just("(c)"), Just("("), Just(";c"), Just("'c"), Just("/"), Just("#1"),
                Just("[1]"), Just("%"), Just("$H"), Just("$0"), Just("O100 sub"), Just("o<x> call"),
                Just("T1"), Just("X"), Just("\"s\""), Just("@"), Just("."), Just("-1"), Just("X#1"),
                Just("XR1"), Just("X R1"), Just("X 1"), Just("\t"), Just("é"),
            ].prop_map(str::to_string),
        ]
    }

    #[test]
    fn comments_in_another_encoding_read_as_question_marks() {
        let fixed = |b: &[u8]| comments_made_utf8(b);
        assert_eq!(fixed(b"G1 X1 (Fr\xe4ser)"), Some("G1 X1 (Fr?ser)".into()));
        assert_eq!(
            fixed(b"G1 X1 ; H\xf6he \xb1"),
            Some("G1 X1 ; H?he ?".into())
        );
        // Valid UTF-8 in the same comment stays; an unclosed comment runs to the end.
        assert_eq!(fixed("(é \u{e9})".as_bytes()), None);
        assert_eq!(fixed(b"(\xc3\xa9 \xe9)X1 (\xff"), Some("(é ?)X1 (?".into()));
        // A bad byte outside a comment, and a line that is UTF-8: nothing to read leniently.
        assert_eq!(fixed(b"G1 X\xff1 (\xe4)"), None);
        assert_eq!(fixed(b"G1 X1 (ok)"), None);
        let mut scratch = None;
        let mut block = Block::empty(3, 40);
        let line = b"G1 X2 (\xd8 6)";
        assert_eq!(
            parse_line_lenient(line, 3, 40, &mut block, false, &mut scratch),
            Ok(true)
        );
        assert_eq!(block.words().count(), 2);
        let d = comment_not_utf8(line, 3, 40);
        assert_eq!((d.severity, d.line), (Severity::Warning, 3));
    }

    proptest::proptest! {
        /// Only bytes inside comments change, and the length stays.
        #[test]
        fn comments_made_utf8_changes_only_comment_bytes(bytes in proptest::collection::vec(
            proptest::prop_oneof![
                proptest::strategy::Just(b'('), proptest::strategy::Just(b')'),
                proptest::strategy::Just(b';'), proptest::strategy::Just(b'X'),
                proptest::strategy::Just(b'1'), proptest::strategy::Just(b' '),
                0x80u8..=0xff,
            ],
            0..24,
        )) {
            if let Some(text) = comments_made_utf8(&bytes) {
                proptest::prop_assert_eq!(text.len(), bytes.len());
                let mut in_comment = false;
                let mut rest = false;
                for (&a, &b) in bytes.iter().zip(text.as_bytes()) {
                    if !in_comment && !rest {
                        proptest::prop_assert_eq!(a, b);
                        in_comment = a == b'(';
                        rest = a == b';';
                    } else {
                        proptest::prop_assert!(a == b || b == b'?');
                        in_comment &= a != b')';
                    }
                }
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn simple_words_agree_with_the_reference(
            tokens in proptest::collection::vec(token(), 0..8),
            joins in proptest::collection::vec(proptest::prop_oneof![
                proptest::strategy::Just(""), proptest::strategy::Just(" "), proptest::strategy::Just("  ")
            ], 8),
            slicer in proptest::bool::ANY,
        ) {
            let mut line = String::new();
            for (t, j) in tokens.iter().zip(&joins) {
                line.push_str(t);
                line.push_str(j);
            }
            let mut fast = smallvec::SmallVec::new();
            if simple_words(&line, 7, slicer, &mut fast) {
                let mut reference = Block::empty(1, 7);
                reset(&mut reference, 1, 7, line.len());
                reference.raw = &line;
                let r = words_reference(&line, 1, 7, &mut reference, slicer);
                proptest::prop_assert!(r.is_ok(), "{line:?}: {r:?}");
                proptest::prop_assert_eq!(reference.kind, BlockKind::Words);
                proptest::prop_assert!(!reference.block_delete);
                proptest::prop_assert_eq!(&fast[..], &reference.items[..], "{:?}", line);
            }
        }
    }

    #[test]
    fn a_nested_comment_is_named_at_its_inner_parenthesis() {
        // Estlcam writes the tool's name into a comment (`(HSS Twist Drill, 3mm (R))`,
        // a real program in fixtures/real-programs/estlcam): the comment ends at the
        // first `)`, and what is left over is not the fault.
        for (s, col) in [
            ("(HSS Twist Drill, 3mm (R))", 23),
            ("G0 X1 (a (b) c)", 10),
            ("N10 G0 X1 (A) (B (C) D", 18),
        ] {
            let e = parse_line(s.as_bytes(), 7, 100).expect_err(s);
            assert_eq!(e.kind, ErrorKind::NestedComment, "{s}");
            assert_eq!((e.line, e.column), (7, col), "{s}");
            assert_eq!(e.span.end - e.span.start, 1);
        }
        // A `(` inside a comment on a line that parses stays a comment (`(DRILL (3MM)`),
        // and an error with no such comment before it is unchanged.
        assert_eq!(words("G1 X1 (DRILL (3MM) Y2").len(), 3);
        let e = parse_line(b"G1 X1 ) (a (b)", 1, 0).expect_err("stray");
        assert_eq!(e.kind, ErrorKind::UnexpectedCharacter(')'));
    }

    #[test]
    fn simple_words_take_the_common_lines() {
        let mut items = smallvec::SmallVec::new();
        for s in [
            "G1 X-2.958 Y7.109 F1200.",
            "G2X1.Y2I.5J0 (arc) ; end",
            "",
            "M3 S1000",
        ] {
            items.clear();
            assert!(simple_words(s, 0, false, &mut items), "{s}");
        }
        for s in [
            "T1 M6",
            "G28 X",
            "M104 S200",
            "X1 X2",
            "R1+1.",
            "/G1 X1",
            "G1 X1e-5",
            "o100 sub",
        ] {
            items.clear();
            let slicer = s.contains('e');
            assert!(!simple_words(s, 0, slicer, &mut items), "{s}");
        }
    }

    #[test]
    fn fast_path_is_correctly_rounded() {
        for s in [
            "0.1",
            "-34.788",
            "123.4567",
            "0.0001",
            "99999.9999",
            "1.000000000000001",
        ] {
            assert_eq!(parse_number(s), s.parse::<f64>().ok(), "{s}");
        }
    }

    #[test]
    fn fadal_register_words() {
        let w = words("L9101 R1+1. R2+.4 D1");
        assert_eq!(w[1], ('R', Some(1), 1.0, "+1.".into()));
        assert_eq!(w[2], ('R', Some(2), 0.4, "+.4".into()));
        // ISO radius is an ordinary R word.
        assert_eq!(
            words("G2 X1 Y1 R11.605")[3],
            ('R', None, 11.605, "11.605".into())
        );
    }

    #[test]
    fn macro_lines_kept_verbatim() {
        for (s, k) in [
            ("#V10 = 1 'comment", MacroKind::FadalStatement),
            ("#IF (R1 = 3) THEN GOTO:FAULT", MacroKind::FadalStatement),
            ("N80 #:S1", MacroKind::FadalStatement),
            ("N60 #WAIT", MacroKind::FadalStatement),
            ("N60 #<depth> = 1", MacroKind::LinuxCncExpression),
            ("N60 G1 X#1", MacroKind::LinuxCncExpression),
            ("G1 G31 X+R6. Y+R7. F+R4. P1", MacroKind::FadalRegisterWords),
            ("#<depth> = 5", MacroKind::LinuxCncExpression),
            ("#1 = 5", MacroKind::LinuxCncExpression),
            (
                "#[#112 * 4 + #113 + 500] = #5063",
                MacroKind::LinuxCncExpression,
            ),
            ("  #[1 + 1] = 3", MacroKind::LinuxCncExpression),
            ("G1 X[#1 + 2]", MacroKind::LinuxCncExpression),
            ("o100 sub", MacroKind::LinuxCncOWord),
            ("O<probe> call [1]", MacroKind::LinuxCncOWord),
        ] {
            let b = parse_line(s.as_bytes(), 1, 0).expect("parses");
            assert_eq!(b.kind, BlockKind::Macro(k), "{s}");
            assert_eq!(b.raw, s);
        }
        // A FADAL program number is a word, not an O-word line.
        let b = parse_line(b"O9101(ProbeKit)", 1, 0).expect("parses");
        assert_eq!(b.kind, BlockKind::Words);
    }

    #[test]
    fn comments_and_spans() {
        let b = parse_line(b"N10 G0 (go) X1 ; rest", 3, 100).expect("parses");
        assert_eq!(b.comments().count(), 2);
        let x = b.word(b'X').expect("X");
        assert_eq!(x.span, Span::new(112, 114));
        assert_eq!(b.span, Span::new(100, 121));
    }

    #[test]
    fn errors_are_located() {
        let cases: [(&[u8], u32); 7] = [
            (b"G1 X1 (open", 7),
            (b"G1 X Y1", 4),
            (b"G1 (a) 12.5", 8),
            (b"G1 X1 X2", 7),
            (b"G1 X1 @", 7),
            (b"G1 X\xff", 5),
            (b"G1 Y2 R1+1. R1-2.", 13),
        ];
        for (s, col) in cases {
            let e = parse_line(s, 1, 0).expect_err("fails");
            assert_eq!(
                e.column,
                col,
                "{:?}: {}",
                String::from_utf8_lossy(s),
                e.kind
            );
        }
    }

    #[test]
    fn polar_words_are_read_only_when_asked() {
        let polar = Reading {
            slicer: false,
            polar: true,
            fanuc_tape: false,
            open_comment: false,
        };
        let mut b = Block::empty(1, 0);
        parse_line_with(b"G1 @ 1.5 ^-30 (c) F10", 1, 0, &mut b, polar).expect("parses");
        let w: Vec<_> = b.words().map(|w| (w.letter, w.value, w.text)).collect();
        assert_eq!(
            w,
            [
                (b'G', 1.0, "1"),
                (b'@', 1.5, "1.5"),
                (b'^', -30.0, "-30"),
                (b'F', 10.0, "10")
            ]
        );
        assert_eq!(b.words().nth(1).map(Word::display).as_deref(), Some("@1.5"));
        // A value from a parameter or an expression makes a macro line, as for letters.
        for s in ["G0 ^[360/17]", "G0 @#1", "G0 @-[1]"] {
            parse_line_with(s.as_bytes(), 1, 0, &mut b, polar).expect(s);
            assert_eq!(
                b.kind,
                BlockKind::Macro(MacroKind::LinuxCncExpression),
                "{s}"
            );
        }
        // Each once; a number after each (column of the error).
        for (s, col, kind) in [
            ("G0 @1 @2", 7, ErrorKind::DuplicateWord("@".into())),
            ("G0 ^1 X1 ^2", 10, ErrorKind::DuplicateWord("^".into())),
            ("G0 @", 4, ErrorKind::LetterWithoutNumber('@')),
            ("G0 ^X1", 4, ErrorKind::LetterWithoutNumber('^')),
        ] {
            let e = parse_line_with(s.as_bytes(), 1, 0, &mut b, polar).expect_err(s);
            assert_eq!((e.column, e.kind), (col, kind), "{s}");
        }
        // Without the reading (every flavour but LinuxCNC's), an unexpected character.
        for s in ["G0 @1", "G0 ^1", "X1 @ 2"] {
            let e = parse_line_with(s.as_bytes(), 1, 0, &mut b, false).expect_err(s);
            assert!(
                matches!(e.kind, ErrorKind::UnexpectedCharacter('@' | '^')),
                "{s}"
            );
            assert_eq!(
                e.column,
                s.find(['@', '^']).map_or(0, |c| c as u32 + 1),
                "{s}"
            );
        }
    }

    #[test]
    fn a_lone_block_delete_is_an_empty_block() {
        // Found by `cargo xtask fuzz`: `/` alone ran past the end of the line.
        for s in ["/", "  /", "/ "] {
            let b = parse_line(s.as_bytes(), 1, 0).expect("parses");
            assert!(b.block_delete && !b.has_words(), "{s}");
        }
        for s in ["o", "O", "/o"] {
            let e = parse_line(s.as_bytes(), 1, 0).expect_err("a letter alone");
            assert!(
                matches!(e.kind, ErrorKind::LetterWithoutNumber('O')),
                "{s}: {e}"
            );
        }
    }

    #[test]
    fn long_line_refused_quickly() {
        let long = vec![b'X'; MAX_LINE_BYTES + 1];
        let e = parse_line(&long, 1, 0).expect_err("too long");
        assert!(matches!(e.kind, ErrorKind::LineTooLong(_)));
    }
}
