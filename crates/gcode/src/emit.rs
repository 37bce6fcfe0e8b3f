//! Writing blocks back out, verbatim or in a controller's dialect.

use std::io::{self, Write};

use crate::ast::{Block, BlockKind, CommentStyle, Item, Word};
use crate::modal::{code_text, Units};

/// Output dialect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Dialect {
    /// FADAL: `%` framing, forced decimal points, XYZ to 4 decimals in inch and 3 in
    /// mm, ABC to 3.
    Fadal,
    /// Plain ISO/RS274: same resolutions, no forced decimal point on whole feeds.
    Iso,
}

/// How to write.
#[derive(Debug, Clone, Copy)]
pub struct EmitOptions {
    /// `None` keeps every number as written; a dialect rewrites numbers in its format.
    pub dialect: Option<Dialect>,
    /// Renumber blocks with N words from `start`, by `step`.
    pub renumber: Option<(u64, u64)>,
    /// Leave out a motion G-code equal to the one in force, and an F equal to the
    /// feed in force (never in G93, where every move takes its F).
    pub suppress_modal: bool,
    /// Units before any G20/G21 (decides decimals).
    pub units: Units,
}

impl Default for EmitOptions {
    fn default() -> Self {
        EmitOptions {
            dialect: None,
            renumber: None,
            suppress_modal: false,
            units: Units::Mm,
        }
    }
}

/// Writes blocks to `out`.
#[derive(Debug)]
pub struct Emitter<W: Write> {
    out: W,
    opts: EmitOptions,
    next_n: u64,
    units: Units,
    motion: Option<u16>,
    feed: Option<f64>,
    inverse_time: bool,
    first: bool,
    last_percent: bool,
    line: String,
}

fn trim_decimals(s: &mut String, keep_point: bool) {
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') && !keep_point {
            s.pop();
        }
    } else if keep_point {
        s.push('.');
    }
    if s == "-0" || s == "-0." {
        s.remove(0);
    }
}

/// Format `value` to `decimals` places; `-0.000` becomes `0.000`.
///
/// Values of ordinary size are rounded once, `round(value·10^d)`, and written as an
/// integer with a decimal point (a fraction of the cost of `format!`); the result is a
/// correct rounding to the last place, and deterministic.
pub fn fixed(value: f64, decimals: usize) -> String {
    let mut s = String::with_capacity(16);
    push_fixed(&mut s, value, decimals);
    s
}

/// [`fixed`] appended to `out`, without allocating for values of ordinary size.
pub fn push_fixed(out: &mut String, value: f64, decimals: usize) {
    const POW: [f64; 10] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];
    if decimals < POW.len() && value.is_finite() && value.abs() < 1e15 / POW[decimals] {
        let n = (value * POW[decimals]).round() as i64;
        let mut digits = [b'0'; 24];
        let mut i = write_digits(&mut digits, n.unsigned_abs());
        // At least one digit before the point (the array is pre-filled with zeros).
        if digits.len() - i <= decimals {
            i = digits.len() - decimals - 1;
        }
        if n < 0 {
            out.push('-');
        }
        let split = digits.len() - decimals;
        for &d in &digits[i..split] {
            out.push(char::from(d));
        }
        if decimals > 0 {
            out.push('.');
            for &d in &digits[split..] {
                out.push(char::from(d));
            }
        }
        return;
    }
    let mut s = format!("{value:.decimals$}");
    if s.starts_with('-') && s[1..].bytes().all(|c| c == b'0' || c == b'.') {
        s.remove(0);
    }
    out.push_str(&s);
}

/// The number text of a word in a dialect.
pub fn format_value(
    dialect: Dialect,
    units: Units,
    letter: u8,
    register: Option<u8>,
    value: f64,
) -> String {
    let mut s = String::with_capacity(16);
    push_value(&mut s, dialect, units, letter, register, value);
    s
}

/// Append a whole number.
fn push_int(out: &mut String, n: i64) {
    let mut digits = [0u8; 24];
    let i = write_digits(&mut digits, n.unsigned_abs());
    if n < 0 {
        out.push('-');
    }
    for &d in &digits[i..] {
        out.push(char::from(d));
    }
}

/// Write `m`'s decimal digits at the end of `buf`; returns where they start.
fn write_digits(buf: &mut [u8; 24], mut m: u64) -> usize {
    let mut i = buf.len();
    loop {
        i -= 1;
        buf[i] = b'0' + (m % 10) as u8;
        m /= 10;
        if m == 0 {
            return i;
        }
    }
}

/// [`format_value`] appended to `out`, without allocating for the common words.
pub fn push_value(
    out: &mut String,
    dialect: Dialect,
    units: Units,
    letter: u8,
    register: Option<u8>,
    value: f64,
) {
    let linear_dec = match units {
        Units::Inch => 4,
        Units::Mm => 3,
    };
    let whole = value.fract() == 0.0 && value.abs() < 9e15;
    match letter {
        _ if register.is_some() => {
            out.push_str(&format_value_slow(dialect, units, letter, register, value))
        }
        b'X' | b'Y' | b'Z' | b'U' | b'V' | b'W' | b'I' | b'J' | b'K' | b'Q' | b'R' => {
            push_fixed(out, value, linear_dec)
        }
        b'A' | b'B' | b'C' => push_fixed(out, value, 3),
        b'G' | b'M' => {
            let t = (value * 10.0).round();
            if (value * 10.0 - t).abs() < 1e-9 && (0.0..6553.5).contains(&t) {
                let c = t as i64;
                push_int(out, c / 10);
                if c % 10 != 0 {
                    out.push('.');
                    push_int(out, c % 10);
                }
            } else {
                out.push_str(&format_value_slow(dialect, units, letter, register, value));
            }
        }
        b'N' | b'O' | b'T' | b'H' | b'D' | b'L' | b'E' if whole => push_int(out, value as i64),
        b'F' | b'S' | b'P' | b'E' => {
            let start = out.len();
            push_fixed(out, value, 5);
            let forced = dialect == Dialect::Fadal && letter != b'S' && letter != b'P';
            // Trim trailing zeros in place (and the point, unless forced).
            while out.len() > start && out.ends_with('0') && out[start..].contains('.') {
                out.pop();
            }
            if out.ends_with('.') && !forced {
                out.pop();
            }
            if &out[start..] == "-0" || &out[start..] == "-0." {
                out.remove(start);
            }
        }
        _ => out.push_str(&format_value_slow(dialect, units, letter, register, value)),
    }
}

fn format_value_slow(
    dialect: Dialect,
    units: Units,
    letter: u8,
    register: Option<u8>,
    value: f64,
) -> String {
    let forced = dialect == Dialect::Fadal;
    let linear_dec = match units {
        Units::Inch => 4,
        Units::Mm => 3,
    };
    let mut s = match letter {
        b'X' | b'Y' | b'Z' | b'U' | b'V' | b'W' | b'I' | b'J' | b'K' | b'Q' => {
            fixed(value, linear_dec)
        }
        b'R' if register.is_none() => fixed(value, linear_dec),
        b'A' | b'B' | b'C' => fixed(value, 3),
        b'G' | b'M' => {
            let t = (value * 10.0).round();
            if (value * 10.0 - t).abs() < 1e-9 && t >= 0.0 {
                return code_text(t as u16);
            }
            let mut s = format!("{value:.4}");
            trim_decimals(&mut s, false);
            return s;
        }
        b'N' | b'O' | b'T' | b'H' | b'D' | b'L' | b'E'
            if value.fract() == 0.0 && register.is_none() =>
        {
            return format!("{}", value as i64);
        }
        b'F' | b'S' | b'P' | b'E' | b'R' => {
            let mut s = fixed(value, 5);
            trim_decimals(&mut s, forced && letter != b'S' && letter != b'P');
            s
        }
        _ => {
            let mut s = format!("{value:.5}");
            trim_decimals(&mut s, false);
            s
        }
    };
    if register.is_some() && !s.starts_with('-') {
        s.insert(0, '+');
    }
    if register.is_some() && !s.contains('.') {
        s.push('.');
    }
    s
}

impl<W: Write> Emitter<W> {
    /// An emitter writing to `out`.
    pub fn new(out: W, opts: EmitOptions) -> Self {
        Emitter {
            out,
            opts,
            next_n: opts.renumber.map_or(0, |r| r.0),
            units: opts.units,
            motion: None,
            feed: None,
            inverse_time: false,
            first: true,
            last_percent: false,
            line: String::with_capacity(128),
        }
    }

    fn frame_start(&mut self, starts_with_percent: bool) -> io::Result<()> {
        if self.first {
            self.first = false;
            if self.opts.dialect == Some(Dialect::Fadal) && !starts_with_percent {
                self.out.write_all(b"%\n")?;
            }
        }
        Ok(())
    }

    /// Write a FADAL/ISO program number line, `O1234 (comment)`.
    pub fn program_number(&mut self, number: u32, comment: Option<&str>) -> io::Result<()> {
        self.frame_start(false)?;
        match comment {
            Some(c) => writeln!(self.out, "O{number} ({})", c.replace([')', '('], "")),
            None => writeln!(self.out, "O{number}"),
        }?;
        self.last_percent = false;
        Ok(())
    }

    fn push_word(&mut self, letter: u8, register: Option<u8>, value: f64, text: Option<&str>) {
        if !self.line.is_empty() && !self.line.ends_with('/') {
            self.line.push(' ');
        }
        self.line.push(char::from(letter));
        if let Some(r) = register {
            self.line.push(char::from(b'0' + r));
        }
        match (self.opts.dialect, text) {
            (None, Some(t)) => self.line.push_str(t),
            (Some(d), _) => push_value(&mut self.line, d, self.units, letter, register, value),
            (None, None) => push_value(
                &mut self.line,
                Dialect::Iso,
                self.units,
                letter,
                register,
                value,
            ),
        }
    }

    fn track(&mut self, letter: u8, value: f64) {
        if letter == b'G' {
            let c = (value * 10.0).round() as i64;
            match c {
                200 | 700 => self.units = Units::Inch,
                210 | 710 => self.units = Units::Mm,
                930 => self.inverse_time = true,
                940 | 950 => self.inverse_time = false,
                _ => {}
            }
        }
    }

    /// Should this word be left out under modal suppression?
    fn suppressed(&self, letter: u8, value: f64) -> bool {
        if !self.opts.suppress_modal {
            return false;
        }
        match letter {
            b'G' => {
                let c = (value * 10.0).round() as i64;
                matches!(c, 0 | 10 | 20 | 30) && self.motion == Some(c as u16)
            }
            b'F' => !self.inverse_time && self.feed == Some(value),
            _ => false,
        }
    }

    fn after(&mut self, letter: u8, value: f64) {
        if letter == b'G' {
            let c = (value * 10.0).round() as i64;
            if matches!(c, 0 | 10 | 20 | 30) {
                self.motion = Some(c as u16);
            } else if (730..=890).contains(&c) {
                self.motion = None;
            }
        } else if letter == b'F' {
            self.feed = Some(value);
        }
    }

    fn flush_line(&mut self) -> io::Result<()> {
        self.out.write_all(self.line.as_bytes())?;
        self.out.write_all(b"\n")?;
        self.line.clear();
        Ok(())
    }

    /// Write one parsed block.
    pub fn block(&mut self, b: &Block<'_>) -> io::Result<()> {
        self.frame_start(b.kind == BlockKind::Percent)?;
        self.line.clear();
        match b.kind {
            BlockKind::Percent => {
                self.line.push_str(b.raw.trim());
                self.last_percent = true;
                return self.flush_line();
            }
            BlockKind::Macro(_) => {
                self.line.push_str(b.raw.trim_end());
                self.last_percent = false;
                return self.flush_line();
            }
            BlockKind::Words => {}
        }
        if b.items.is_empty() && !b.block_delete {
            self.last_percent = false;
            return self.flush_line();
        }
        self.last_percent = false;
        if b.block_delete {
            self.line.push('/');
        }
        let numbered = self.opts.renumber.is_some() && b.has_words() && b.word(b'O').is_none();
        if numbered {
            let n = self.next_n;
            self.push_word(b'N', None, n as f64, None);
            self.next_n = self
                .next_n
                .saturating_add(self.opts.renumber.map_or(1, |r| r.1));
        }
        for item in &b.items {
            match item {
                Item::Word(w) => {
                    if numbered && w.letter == b'N' {
                        continue;
                    }
                    self.track(w.letter, w.value);
                    if self.suppressed(w.letter, w.value) {
                        continue;
                    }
                    self.after(w.letter, w.value);
                    self.push_word(w.letter, w.register, w.value, Some(w.text));
                }
                Item::Comment(c) => {
                    if !self.line.is_empty() && !self.line.ends_with('/') {
                        self.line.push(' ');
                    }
                    match c.style {
                        CommentStyle::Paren => {
                            self.line.push('(');
                            self.line.push_str(c.text);
                            self.line.push(')');
                        }
                        CommentStyle::Semicolon => {
                            self.line.push(';');
                            self.line.push_str(c.text);
                        }
                    }
                }
            }
        }
        self.flush_line()
    }

    /// Write a block made of words (letter, value) and an optional comment, in the
    /// dialect (or ISO spelling when verbatim), numbered when renumbering.
    pub fn words(&mut self, words: &[(u8, f64)], comment: Option<&str>) -> io::Result<()> {
        self.frame_start(false)?;
        self.line.clear();
        self.last_percent = false;
        if self.opts.renumber.is_some() && !words.is_empty() {
            let n = self.next_n;
            self.push_word(b'N', None, n as f64, None);
            self.next_n = self
                .next_n
                .saturating_add(self.opts.renumber.map_or(1, |r| r.1));
        }
        for &(l, v) in words {
            self.track(l, v);
            if self.suppressed(l, v) {
                continue;
            }
            self.after(l, v);
            self.push_word(l, None, v, None);
        }
        if let Some(c) = comment {
            if !self.line.is_empty() {
                self.line.push(' ');
            }
            self.line.push('(');
            self.line.push_str(&c.replace([')', '('], ""));
            self.line.push(')');
        }
        self.flush_line()
    }

    /// The writer underneath.
    pub fn get_ref(&self) -> &W {
        &self.out
    }

    /// Write a line verbatim (a macro statement such as `#PRINT …`, or a comment line).
    pub fn raw_line(&mut self, text: &str) -> io::Result<()> {
        self.frame_start(false)?;
        self.last_percent = false;
        self.out.write_all(text.trim_end().as_bytes())?;
        self.out.write_all(b"\n")
    }

    /// Close the program (FADAL: a final `%` if the last line was not one) and hand
    /// back the writer.
    pub fn finish(mut self) -> io::Result<W> {
        if self.opts.dialect == Some(Dialect::Fadal) && !self.last_percent {
            if self.first {
                self.out.write_all(b"%\n")?;
            }
            self.out.write_all(b"%\n")?;
        }
        self.out.flush()?;
        Ok(self.out)
    }
}

/// The word as the emitter writes it verbatim (letter, register, number text).
pub fn word_text(w: &Word<'_>) -> String {
    w.display()
}

#[cfg(test)]
mod tests {
    use super::fixed;

    #[test]
    fn fixed_point_formatting() {
        assert_eq!(fixed(1.5, 4), "1.5000");
        assert_eq!(fixed(-0.25, 3), "-0.250");
        assert_eq!(fixed(-0.00001, 4), "0.0000");
        assert_eq!(fixed(0.00005001, 4), "0.0001");
        assert_eq!(fixed(12345.678, 0), "12346");
        assert_eq!(fixed(-3.0, 2), "-3.00");
        assert_eq!(fixed(1e20, 3), format!("{:.3}", 1e20));
        for v in [0.1, 2.675, 1.0005, -7.12345, 99.99995, 123.456789] {
            for d in 0..6 {
                let ours: f64 = fixed(v, d).parse().expect("number");
                assert!(
                    (ours - v).abs() <= 0.5 * 10f64.powi(-(d as i32)) + 1e-12 * v.abs().max(1.0),
                    "{v} {d}"
                );
            }
        }
    }
}
