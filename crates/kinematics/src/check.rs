//! Machine files are validated as data: every value the post writes into a program as
//! text (process codes, the laser power word, axis names, head and machine names) may
//! hold only what the post means it to, so a machine file cannot put motion, feeds, block
//! numbers, comments or macros into a posted program.
//!
//! The rules:
//! - a process code (`laser_on`, `spindle_off`, `program_end`, … every code string under
//!   `[process]`) holds only M, S, P and Q words, each a letter and a plain decimal
//!   number, separated by spaces; empty for none;
//! - `laser_power_word` is one letter: S, P or Q;
//! - linear axes are named X, Y, Z, U, V or W, rotary axes A, B or C, all five distinct;
//! - head names and the machine name hold no parentheses and no control characters (line
//!   breaks, tabs): they are written into program comments. They are refused, not
//!   stripped, so the name a user types is the name in the file.
//!
//! Letters may be lower case; they are stored upper case (and a code's words joined by
//! single spaces).
//!
//! [`MachineDef::from_toml`] reports a refusal at the file, line and column of the
//! offending text; [`MachineDef::check`] (which [`crate::Machine::new`] runs) reports it
//! without a place, for definitions built in code.

use std::collections::BTreeMap;

use serde::Deserialize;
use toml::Spanned;

use crate::def::{MachineDef, ProcessDef};
use crate::error::KinError;

/// The letters a process code may hold.
pub const CODE_LETTERS: [u8; 4] = *b"MSPQ";
/// The letters `laser_power_word` may be.
pub const POWER_LETTERS: [u8; 3] = *b"SPQ";
/// The names a linear axis may have.
pub const LINEAR_NAMES: [u8; 6] = *b"XYZUVW";
/// The names a rotary axis may have.
pub const ROTARY_NAMES: [u8; 3] = *b"ABC";

const CODE_RULE: &str = "a process code holds only M, S, P and Q words, each a letter and a \
     plain number, separated by spaces (e.g. \"M71\", \"M3\", \"M98 P10\"; \"\" for none)";

/// A refused value: the byte offset of the offending text in the value, and a message
/// naming it and saying what to do.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Refusal {
    pub(crate) at: usize,
    pub(crate) message: String,
}

/// Which value of the file was refused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Place {
    /// The machine's `name`.
    Name,
    /// `name` of the i-th `[[linear]]`.
    Linear(usize),
    /// `name` of the i-th `[[rotary]]`.
    Rotary(usize),
    /// `name` of the i-th `[[head]]`.
    Head(usize),
    /// A key of the i-th `[[head]]`'s `sensor` table.
    Sensor(usize, &'static str),
    /// A key of `[process]`.
    Process(&'static str),
}

fn refuse(at: usize, message: String) -> Refusal {
    Refusal { at, message }
}

/// What a character is, for messages.
fn describe(c: char) -> &'static str {
    match c {
        '(' | ')' | ';' => " (a comment)",
        '#' => " (a macro variable)",
        '[' | ']' => " (an expression)",
        '%' => " (a program delimiter)",
        '\n' | '\r' => " (a line break)",
        '\t' => " (a tab)",
        '/' => " (block delete)",
        _ => "",
    }
}

/// What a word of the letter `l` (upper case) does, for messages.
fn word_kind(l: u8) -> &'static str {
    match l {
        b'G' => "a G word (motion or modes)",
        b'X' | b'Y' | b'Z' | b'A' | b'B' | b'C' | b'U' | b'V' | b'W' | b'I' | b'J' | b'K'
        | b'R' | b'E' => "an axis or motion word",
        b'N' => "a block number",
        b'F' => "a feed",
        b'O' => "a program number",
        b'T' => "a tool number (the post writes T itself)",
        b'H' | b'D' => "an offset number",
        _ => "a word the post does not expect",
    }
}

/// Length of a plain decimal number (`[+-]digits[.digits]`, at least one digit) at the
/// start of `s`, and whether it has a digit.
fn number_len(s: &[u8]) -> (usize, bool) {
    let mut i = 0;
    if matches!(s.first(), Some(b'+' | b'-')) {
        i += 1;
    }
    let mut digits = false;
    while s.get(i).is_some_and(u8::is_ascii_digit) {
        i += 1;
        digits = true;
    }
    if s.get(i) == Some(&b'.') {
        i += 1;
        while s.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
            digits = true;
        }
    }
    (i, digits)
}

/// A process code: M, S, P and Q words separated by spaces. Returns it upper case, the
/// words joined by single spaces.
pub(crate) fn process_code(key: &str, value: &str) -> Result<String, Refusal> {
    // `key` is the value's dotted name as the file spells it (`process.laser_on`).
    let mut words: Vec<String> = Vec::new();
    let mut start = 0;
    for token in value.split(' ') {
        let at = start;
        start += token.len() + 1;
        if token.is_empty() {
            continue;
        }
        let b = token.as_bytes();
        let Some(&first) = b.first() else {
            continue;
        };
        if !first.is_ascii_alphabetic() {
            let c = token.chars().next().unwrap_or(' ');
            return Err(refuse(
                at,
                format!(
                    "`{key}` holds `{}`{}: {CODE_RULE}; remove it",
                    c.escape_debug(),
                    describe(c)
                ),
            ));
        }
        let letter = first.to_ascii_uppercase();
        if !CODE_LETTERS.contains(&letter) {
            return Err(refuse(
                at,
                format!(
                    "`{key}` holds `{}`, {}: {CODE_RULE}; remove it (the post writes \
                     motion, feeds, tools and block numbers itself)",
                    token.escape_debug(),
                    word_kind(letter)
                ),
            ));
        }
        let (len, digits) = number_len(&b[1..]);
        let end = 1 + len;
        if let Some(c) = token[end..].chars().next() {
            let why = if c.is_ascii_alphabetic() {
                format!(
                    "`{}` has no space before `{c}`: separate words with a space",
                    token.escape_debug()
                )
            } else if c.is_ascii_digit() || matches!(c, '.' | '+' | '-') {
                format!(
                    "`{}` is not a letter and a plain number",
                    token.escape_debug()
                )
            } else {
                format!("`{}`{} is not allowed", c.escape_debug(), describe(c))
            };
            return Err(refuse(
                at + end,
                format!(
                    "`{key}` holds `{}`: {why}; {CODE_RULE}",
                    token.escape_debug()
                ),
            ));
        }
        if !digits {
            return Err(refuse(
                at,
                format!(
                    "`{key}` holds `{}` without a number: {CODE_RULE}",
                    token.escape_debug()
                ),
            ));
        }
        let mut w = String::with_capacity(token.len());
        w.push(char::from(letter));
        w.push_str(&token[1..]);
        words.push(w);
    }
    Ok(words.join(" "))
}

/// `laser_power_word`: one letter of S, P, Q; returned upper case.
pub(crate) fn power_word(value: &str) -> Result<String, Refusal> {
    match value.as_bytes() {
        [c] if POWER_LETTERS.contains(&c.to_ascii_uppercase()) => {
            Ok(char::from(c.to_ascii_uppercase()).to_string())
        }
        _ => Err(refuse(
            0,
            format!(
                "`process.laser_power_word` is \"{}\": it must be one letter, S, P or Q (the \
                 word that carries the laser power, e.g. \"S\"), never an axis or another word",
                value.escape_debug()
            ),
        )),
    }
}

/// An axis name: one letter of `allowed`, not in `taken`; returned upper case.
fn axis_name(kind: &str, value: &str, allowed: &[u8], taken: &[String]) -> Result<String, Refusal> {
    let letters: Vec<String> = allowed.iter().map(|&c| char::from(c).to_string()).collect();
    let name = match value.as_bytes() {
        [c] if allowed.contains(&c.to_ascii_uppercase()) => {
            char::from(c.to_ascii_uppercase()).to_string()
        }
        _ => {
            return Err(refuse(
                0,
                format!(
                    "{kind} axis name \"{}\": a {kind} axis is named with one letter of {} (the \
                     name is the axis word of posted programs)",
                    value.escape_debug(),
                    letters.join(", ")
                ),
            ))
        }
    };
    if taken.contains(&name) {
        return Err(refuse(
            0,
            format!("axis name \"{name}\" is used twice: give the five axes five different names"),
        ));
    }
    Ok(name)
}

/// A name written into program comments: no parentheses, no control characters.
fn label(what: &str, value: &str) -> Result<(), Refusal> {
    match value
        .char_indices()
        .find(|&(_, c)| c == '(' || c == ')' || c.is_control())
    {
        Some((at, c)) => Err(refuse(
            at,
            format!(
                "{what} \"{}\" holds `{}`{}: names are written into program comments; use no \
                 parentheses, line breaks or other control characters",
                value.escape_debug(),
                c.escape_debug(),
                describe(c)
            ),
        )),
        None => Ok(()),
    }
}

/// The M codes (whole numbers) of a checked code string.
fn m_codes(code: &str) -> impl Iterator<Item = f64> + '_ {
    code.split(' ')
        .filter_map(|w| w.strip_prefix('M'))
        .filter_map(|n| n.parse::<f64>().ok())
}

/// The process codes as a set: each switch that goes on goes off (an empty `laser_off`
/// left the laser on over every traverse), on and off differ, no code stops, ends or
/// calls the program but `program_end` (which ends it: M2 or M30), no code changes the
/// tool but `tool_change`, and `laser_on` leaves the power word to the post (which
/// writes `--power` with it: `M71 S500 S1000`).
fn process_codes_together(p: &crate::def::ProcessDef) -> Result<(), (Place, Refusal)> {
    let at = |key: &'static str, message: String| (Place::Process(key), refuse(0, message));
    for (on_key, on, off_key, off) in [
        ("laser_on", &p.laser_on, "laser_off", &p.laser_off),
        ("powder_on", &p.powder_on, "powder_off", &p.powder_off),
        ("spindle_on", &p.spindle_on, "spindle_off", &p.spindle_off),
        ("coolant_on", &p.coolant_on, "coolant_off", &p.coolant_off),
    ] {
        if !on.is_empty() && off.is_empty() {
            return Err(at(
                off_key,
                format!(
                    "`process.{off_key}` is empty while `process.{on_key}` is \"{on}\": the post could never turn it off (before travel, at a stop, at the end); give the machine's code, or leave both empty"
                ),
            ));
        }
        if on.is_empty() && !off.is_empty() {
            return Err(at(
                on_key,
                format!(
                    "`process.{on_key}` is empty while `process.{off_key}` is \"{off}\": the post could never turn it on; give the machine's code, or leave both empty"
                ),
            ));
        }
        if !on.is_empty() && on == off {
            return Err(at(
                off_key,
                format!("`process.{off_key}` is \"{off}\", the same as `process.{on_key}`: a switch needs two codes"),
            ));
        }
    }
    for (key, code) in p.codes() {
        for m in m_codes(code) {
            let why = match m {
                _ if m == 0.0 || m == 1.0 || m == 60.0 => "stops the program",
                // A tool change may be a control's macro (`M98 P9000`).
                _ if m == 98.0 && key == "tool_change" => continue,
                _ if m == 98.0 || m == 99.0 => "calls or returns from a subprogram",
                _ if (m == 2.0 || m == 30.0) && key != "program_end" => "ends the program",
                _ if m == 6.0 && key != "tool_change" => "changes the tool",
                _ => continue,
            };
            return Err(at(
                key,
                format!(
                    "`process.{key}` holds M{m}, which {why}: the post writes stops, ends, calls and tool changes itself where the input has them; remove it"
                ),
            ));
        }
    }
    if !m_codes(&p.program_end).any(|m| m == 2.0 || m == 30.0) {
        return Err(at(
            "program_end",
            format!(
                "`process.program_end` is \"{}\": it must end the program with M2 or M30 (verify holds a posted program to ending)",
                p.program_end
            ),
        ));
    }
    let power = p.laser_power_word.as_str();
    if p.laser_on
        .split(' ')
        .any(|w| !power.is_empty() && w.starts_with(power))
    {
        return Err(at(
            "laser_on",
            format!(
                "`process.laser_on` is \"{}\", with a {power} word: the post writes the power itself in `laser_power_word` ({power}, from --power); remove it",
                p.laser_on
            ),
        ));
    }
    Ok(())
}

/// The longest head the post takes (radius or length, in machine units): beyond any
/// machine, and far within what the collision checks compute with.
const MAX_HEAD: f64 = 1e6;

/// An optional length: finite and at least (or above) 0.
fn length(key: &str, value: Option<f64>, zero_ok: bool, default: &str) -> Result<(), Refusal> {
    match value {
        Some(v) if v.is_finite() && v > MAX_HEAD => Err(refuse(
            0,
            format!("`process.{key}` = {v:e}: it must be at most {MAX_HEAD} in machine units"),
        )),
        Some(v) if v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0)) => Ok(()),
        Some(v) => Err(refuse(
            0,
            format!(
                "`process.{key}` = {v}: it must be a finite number {} in machine units, or \
                 left out for the default ({default})",
                if zero_ok { "≥ 0" } else { "> 0" }
            ),
        )),
        None => Ok(()),
    }
}

impl MachineDef {
    /// Check every value the post writes as text (see the crate's docs, *What a machine file may hold*) and the optional
    /// process lengths, storing letters upper case. A definition from
    /// [`MachineDef::from_toml`] has passed already; [`crate::Machine::new`] runs it again
    /// for definitions built or changed in code. The error names the value and the
    /// offending text, without a file place.
    pub fn check(&mut self) -> Result<(), KinError> {
        self.check_values()
            .map_err(|(_, r)| KinError::InvalidMachine {
                machine: self.name.clone(),
                what: r.message,
            })
    }

    pub(crate) fn check_values(&mut self) -> Result<(), (Place, Refusal)> {
        label("machine name", &self.name).map_err(|r| (Place::Name, r))?;
        let mut taken: Vec<String> = Vec::with_capacity(5);
        for (i, l) in self.linear.iter_mut().enumerate() {
            l.name = axis_name("linear", &l.name, &LINEAR_NAMES, &taken)
                .map_err(|r| (Place::Linear(i), r))?;
            taken.push(l.name.clone());
        }
        for (i, r) in self.rotary.iter_mut().enumerate() {
            r.name = axis_name("rotary", &r.name, &ROTARY_NAMES, &taken)
                .map_err(|e| (Place::Rotary(i), e))?;
            taken.push(r.name.clone());
        }
        for (i, h) in self.heads.iter_mut().enumerate() {
            label("head name", &h.name).map_err(|r| (Place::Head(i), r))?;
            if let Some(sn) = &mut h.sensor {
                let positive = |what: &'static str, v: f64, hi: f64| {
                    if v.is_finite() && v > 0.0 && v <= hi {
                        Ok(())
                    } else {
                        Err((
                            Place::Sensor(i, what),
                            Refusal {
                                message: format!(
                                    "head `{}`: sensor.{what} = {v}: it must be a finite number > 0 and at most {hi}",
                                    h.name
                                ),
                                at: 0,
                            },
                        ))
                    }
                };
                positive("reference", sn.reference, 1e6)?;
                positive("range", sn.range, 1e6)?;
                positive("max_tilt_deg", sn.max_tilt_deg, 90.0)?;
                sn.trigger = process_code("head.sensor.trigger", &sn.trigger)
                    .map_err(|r| (Place::Sensor(i, "trigger"), r))?;
            }
        }
        let p = &mut self.process;
        for (key, code) in p.codes_mut() {
            *code = process_code(&format!("process.{key}"), code)
                .map_err(|r| (Place::Process(key), r))?;
        }
        p.laser_power_word =
            power_word(&p.laser_power_word).map_err(|r| (Place::Process("laser_power_word"), r))?;
        process_codes_together(p)?;
        let at = Place::Process;
        length("safe_margin", p.safe_margin, true, "0.2 in, 5 mm")
            .map_err(|r| (at("safe_margin"), r))?;
        length("head_radius", p.head_radius, false, "1 in, 25 mm")
            .map_err(|r| (at("head_radius"), r))?;
        length("head_length", p.head_length, false, "6 in, 150 mm")
            .map_err(|r| (at("head_length"), r))?;
        Ok(())
    }
}

/// The places of the values [`MachineDef::check_values`] looks at, read from the same
/// text a second time.
#[derive(Deserialize)]
struct Located {
    #[serde(default)]
    name: Option<Spanned<String>>,
    #[serde(default)]
    linear: Vec<LocatedName>,
    #[serde(default)]
    rotary: Vec<LocatedName>,
    #[serde(default, rename = "head")]
    heads: Vec<LocatedHead>,
    #[serde(default)]
    process: BTreeMap<String, Spanned<toml::Value>>,
}

#[derive(Deserialize)]
struct LocatedName {
    #[serde(default)]
    name: Option<Spanned<String>>,
}

#[derive(Deserialize)]
struct LocatedHead {
    #[serde(default)]
    name: Option<Spanned<String>>,
    #[serde(default)]
    sensor: BTreeMap<String, Spanned<toml::Value>>,
}

/// The byte offset in `text` of a refusal: at the offending text where the value is
/// written as it reads (no escapes), else at the value's start. `None` when the value is
/// not in the text (it cannot be: only written values are refused).
pub(crate) fn locate(text: &str, place: Place, at: usize) -> Option<usize> {
    let doc: Located = toml::from_str(text).ok()?;
    let named = |v: &[LocatedName], i: usize| {
        v.get(i)
            .and_then(|n| n.name.as_ref())
            .map(|s| (s.span(), Some(s.get_ref().clone())))
    };
    let (span, value) = match place {
        Place::Name => doc
            .name
            .as_ref()
            .map(|s| (s.span(), Some(s.get_ref().clone())))?,
        Place::Linear(i) => named(&doc.linear, i)?,
        Place::Rotary(i) => named(&doc.rotary, i)?,
        Place::Head(i) => doc
            .heads
            .get(i)
            .and_then(|h| h.name.as_ref())
            .map(|s| (s.span(), Some(s.get_ref().clone())))?,
        Place::Sensor(i, key) => {
            let v = doc.heads.get(i)?.sensor.get(key)?;
            (v.span(), v.get_ref().as_str().map(str::to_string))
        }
        Place::Process(key) => {
            let v = doc.process.get(key)?;
            (v.span(), v.get_ref().as_str().map(str::to_string))
        }
    };
    let raw = text.get(span.clone())?;
    let inner = value.and_then(|value| {
        ["\"\"\"", "'''", "\"", "'"].iter().find_map(|d| {
            let n = d.len();
            (raw.len() >= 2 * n && raw.starts_with(d) && raw.ends_with(d))
                .then(|| (n, &raw[n..raw.len() - n] == value.as_str()))
        })
    });
    Some(match inner {
        Some((n, true)) => span.start + n + at,
        _ => span.start,
    })
}

impl ProcessDef {
    /// Every process code string with its key: what [`MachineDef::check`] holds to M, S,
    /// P and Q words. A code string added to [`ProcessDef`] belongs here (a test checks).
    pub fn codes(&self) -> [(&'static str, &str); 10] {
        [
            ("laser_on", &self.laser_on),
            ("laser_off", &self.laser_off),
            ("powder_on", &self.powder_on),
            ("powder_off", &self.powder_off),
            ("spindle_on", &self.spindle_on),
            ("spindle_off", &self.spindle_off),
            ("coolant_on", &self.coolant_on),
            ("coolant_off", &self.coolant_off),
            ("tool_change", &self.tool_change),
            ("program_end", &self.program_end),
        ]
    }

    fn codes_mut(&mut self) -> [(&'static str, &mut String); 10] {
        [
            ("laser_on", &mut self.laser_on),
            ("laser_off", &mut self.laser_off),
            ("powder_on", &mut self.powder_on),
            ("powder_off", &mut self.powder_off),
            ("spindle_on", &mut self.spindle_on),
            ("spindle_off", &mut self.spindle_off),
            ("coolant_on", &mut self.coolant_on),
            ("coolant_off", &mut self.coolant_off),
            ("tool_change", &mut self.tool_change),
            ("program_end", &mut self.program_end),
        ]
    }
}

/// Arrays a typed reading dropped elements of. `toml` reads `[1, 0, 0, 5]` into a
/// `[f64; 3]` without a word; comparing the document as written with the typed value
/// written back finds it. The first such array: its dotted key, its byte offset in
/// `text` (the line that sets it, where that can be found), and the lengths written and
/// read. `None` when nothing was dropped (or the typed value cannot be written back).
pub fn dropped_elements<T: serde::Serialize>(
    text: &str,
    typed: &T,
) -> Option<(String, Option<usize>, usize, usize)> {
    let original: toml::Table = text.parse().ok()?;
    let back = toml::Table::try_from(typed).ok()?;
    let (key, written, read) = dropped_in_table(&original, &back, "")?;
    let last = key
        .rsplit(['.', ']'])
        .find(|k| !k.is_empty() && !k.starts_with('['));
    let at = last.and_then(|k| key_offset(text, k.trim_start_matches('[')));
    Some((key, at, written, read))
}

fn dropped_in_table(
    original: &toml::Table,
    typed: &toml::Table,
    path: &str,
) -> Option<(String, usize, usize)> {
    for (k, v) in original {
        let p = if path.is_empty() {
            k.clone()
        } else {
            format!("{path}.{k}")
        };
        if let Some(t) = typed.get(k) {
            if let Some(found) = dropped_in_value(v, t, &p) {
                return Some(found);
            }
        }
    }
    None
}

fn dropped_in_value(
    original: &toml::Value,
    typed: &toml::Value,
    path: &str,
) -> Option<(String, usize, usize)> {
    match (original, typed) {
        (toml::Value::Array(a), toml::Value::Array(b)) => {
            if a.len() > b.len() {
                return Some((path.to_string(), a.len(), b.len()));
            }
            a.iter()
                .zip(b)
                .enumerate()
                .find_map(|(i, (x, y))| dropped_in_value(x, y, &format!("{path}[{i}]")))
        }
        (toml::Value::Table(a), toml::Value::Table(b)) => dropped_in_table(a, b, path),
        _ => None,
    }
}

/// The byte offset of the first line that sets `key` (`key = …`).
pub fn key_offset(text: &str, key: &str) -> Option<usize> {
    let mut at = 0;
    for line in text.split_inclusive('\n') {
        let t = line.trim_start();
        if let Some(rest) = t.strip_prefix(key) {
            if rest.trim_start().starts_with('=') {
                return Some(at + (line.len() - t.len()));
            }
        }
        at += line.len();
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::def::builtin_text;
    use crate::Machine;

    fn fadal() -> &'static str {
        builtin_text("fadal-lamp").unwrap_or_default()
    }

    /// The file with the first line starting `key = ` replaced by `new`.
    fn with_line(text: &str, key: &str, new: &str) -> String {
        let mut done = false;
        let mut out = String::new();
        for l in text.split_inclusive('\n') {
            if !done && l.starts_with(&format!("{key} = ")) {
                out.push_str(new);
                out.push('\n');
                done = true;
            } else {
                out.push_str(l);
            }
        }
        assert!(done, "no line `{key} = ` in the file");
        out
    }

    /// 1-based line and column of byte `offset` of `text`.
    fn place(text: &str, offset: usize) -> (usize, usize) {
        let before = &text[..offset];
        let line = before.matches('\n').count() + 1;
        let start = before.rfind('\n').map_or(0, |i| i + 1);
        (line, text[start..offset].chars().count() + 1)
    }

    /// Reads `text`, expects a refusal at the first occurrence of `offending` in the first
    /// line `line_text` of the file, and a message that names `named`.
    #[track_caller]
    fn refused_at(text: &str, line_text: &str, offending: &str, named: &str) {
        let within = line_text
            .find(offending)
            .unwrap_or_else(|| panic!("`{offending}` is not in `{line_text}`"));
        refused_at_byte(text, line_text, within, named);
    }

    /// Reads `text`, expects a refusal at byte `within` of the first line `line_text` of
    /// the file, and a message that names `named`.
    #[track_caller]
    fn refused_at_byte(text: &str, line_text: &str, within: usize, named: &str) {
        refused_after(text, "", line_text, within, named);
    }

    /// As [`refused_at_byte`], for the first line `line_text` after the first `after`.
    #[track_caller]
    fn refused_after(text: &str, after: &str, line_text: &str, within: usize, named: &str) {
        let from = text
            .find(after)
            .unwrap_or_else(|| panic!("`{after}` is not in the file"));
        let line_at = text[from..]
            .find(&format!("{line_text}\n"))
            .map(|i| from + i)
            .unwrap_or_else(|| panic!("`{line_text}` is not a line of the file"));
        let want = place(text, line_at + within);
        match MachineDef::from_toml(text, "m.toml") {
            Err(e) => {
                let shown = e.to_string();
                let KinError::MachineFile {
                    file,
                    line,
                    column,
                    message,
                    text: snippet,
                } = e
                else {
                    panic!("`{line_text}` was not refused with a place: {shown}");
                };
                assert_eq!(file, "m.toml");
                assert_eq!(
                    (line, column),
                    want,
                    "`{line_text}`: refused at the wrong place: {message}"
                );
                assert!(
                    message.contains(named),
                    "`{line_text}`: the message does not name `{named}`: {message}"
                );
                assert!(line_text.starts_with(&snippet), "shown line `{snippet}`");
                // It prints as file:line:col.
                assert!(
                    shown.starts_with(&format!("m.toml:{line}:{column}: ")),
                    "{shown}"
                );
            }
            Ok(_) => panic!("`{line_text}` was not refused"),
        }
    }

    #[test]
    fn motion_and_other_words_in_process_codes_are_refused_where_they_stand() {
        // (value as written in the file, offending text, what the message names)
        let cases = [
            ("\"G0 X900\"", "G0", "`G0`, a G word"),
            ("\"M71 X900\"", "X900", "`X900`, an axis"),
            ("\"M71 Y1\"", "Y1", "`Y1`"),
            ("\"M71 A90\"", "A90", "`A90`"),
            ("\"N10 M71\"", "N10", "`N10`, a block number"),
            ("\"M71 F100\"", "F100", "`F100`, a feed"),
            ("\"O100\"", "O100", "`O100`, a program number"),
            ("\"T1 M6\"", "T1", "`T1`, a tool number"),
            ("\"g0 x900\"", "g0", "`g0`"),
            ("\"M71 (LASER ON)\"", "(", "`(` (a comment)"),
            ("\"M71(ON)\"", "(", "`(` (a comment)"),
            ("\"M71 ;ON\"", ";", "`;` (a comment)"),
            ("\"#1\"", "#", "`#` (a macro variable)"),
            ("\"M[1+2]\"", "[", "`[` (an expression)"),
            ("\"%\"", "%", "`%` (a program delimiter)"),
            ("\"/M71\"", "/", "`/` (block delete)"),
            ("\"M\"", "M", "`M` without a number"),
            ("\"M71 S\"", "S", "`S` without a number"),
            (
                "\"M3.2.1\"",
                ".1",
                "`M3.2.1` is not a letter and a plain number",
            ),
            ("\"M3S1200\"", "S1200", "no space before `S`"),
            ("\"M71 *\"", "*", "`*`"),
            ("\"M71 ü\"", "ü", "`ü`"),
            // A literal string takes a tab as written.
            ("'M71\tM73'", "\t", "`\\t` (a tab)"),
            // A multi-line literal string: the line break is in the value as written.
            ("'''M71\nG0 X900'''", "\n", "`\\n` (a line break)"),
        ];
        for (value, offending, named) in cases {
            let line = format!("laser_on = {value}");
            let text = with_line(fadal(), "laser_on", &line);
            let first = line.split('\n').next().unwrap_or_default();
            if offending == "\n" {
                // Points just past `M71`, at the line break.
                let at = text.find(&line).unwrap_or_default() + first.len();
                let want = place(&text, at);
                match MachineDef::from_toml(&text, "m.toml") {
                    Err(KinError::MachineFile {
                        line,
                        column,
                        message,
                        ..
                    }) => {
                        assert_eq!((line, column), want, "{message}");
                        assert!(message.contains(named), "{message}");
                    }
                    other => panic!("not refused: {other:?}"),
                }
            } else {
                refused_at(&text, &line, offending, named);
            }
        }
    }

    #[test]
    fn an_escaped_line_break_is_refused_at_the_value() {
        // With an escape the value does not read as written: the place is its quote.
        let line = "laser_on = \"M71\\nG0 X900\"";
        let text = with_line(fadal(), "laser_on", line);
        refused_at(&text, line, "\"", "`\\n` (a line break)");
    }

    /// Fuzz run seed 2028 (input 464801): a sensor's refused trigger was placed at the
    /// head's name (a multi-byte one there), not at the `trigger` it refuses.
    #[test]
    fn a_sensor_value_is_refused_where_it_stands() {
        let nrc = crate::def::builtin_text("nrc-lc").unwrap_or_default();
        let named = nrc.replace("name = \"sensor\"", "name = \"s😀nsor\"");
        let line = "sensor = { reference = 30.0, range = 5.0, max_tilt_deg = 30.0, trigger = \"M76 G0 X9\" }";
        let text = with_line(&named, "sensor", line);
        refused_at(&text, line, "G0", "`head.sensor.trigger` holds `G0`");
        let line =
            "sensor = { reference = 30.0, range = -5.0, max_tilt_deg = 30.0, trigger = \"M76\" }";
        let text = with_line(&named, "sensor", line);
        refused_at(&text, line, "-5.0", "sensor.range = -5");
    }

    #[test]
    fn every_process_code_is_checked() {
        for (key, _) in ProcessDef::default().codes() {
            let line = format!("{key} = \"M5 G0 X900\"");
            let text = with_line(fadal(), key, &line);
            refused_at(&text, &line, "G0", &format!("`process.{key}` holds `G0`"));
        }
    }

    #[test]
    fn every_code_string_of_the_process_table_is_in_codes() {
        let table = toml::Table::try_from(ProcessDef::default()).unwrap_or_default();
        let codes = ProcessDef::default().codes().map(|(k, _)| k);
        let mut strings = 0;
        for (key, v) in &table {
            if v.is_str() && key != "laser_power_word" {
                strings += 1;
                assert!(codes.contains(&key.as_str()), "{key} is not checked");
            }
        }
        assert_eq!(strings, codes.len());
    }

    #[test]
    fn the_laser_power_word_is_s_p_or_q() {
        for bad in ["X", "Z", "G", "N", "F", "SS", "S1", " S", "", "(", "1"] {
            let line = format!("laser_power_word = \"{bad}\"");
            let text = with_line(fadal(), "laser_power_word", &line);
            // At the value's first character (the closing quote when it is empty).
            let at = "laser_power_word = \"".len();
            let named = format!("`process.laser_power_word` is \"{bad}\"");
            refused_at_byte(&text, &line, at, &named);
        }
        for (good, stored) in [("S", "S"), ("p", "P"), ("Q", "Q")] {
            let line = format!("laser_power_word = \"{good}\"");
            let text = with_line(fadal(), "laser_power_word", &line);
            let d = MachineDef::from_toml(&text, "m.toml");
            assert_eq!(
                d.map(|d| d.process.laser_power_word).ok().as_deref(),
                Some(stored)
            );
        }
    }

    #[test]
    fn axis_names_are_single_axis_letters() {
        // At the value's first character.
        let at = "name = \"".len();
        for bad in [
            "G", "N", "F", "(", "B2", "A", "XX", "", "T", "x(", "I", "Y ",
        ] {
            // The second linear axis (Y).
            let line = format!("name = \"{bad}\"");
            let text = fadal().replacen("name = \"Y\"", &line, 1);
            refused_at_byte(&text, &line, at, &format!("linear axis name \"{bad}\""));
        }
        for bad in ["G", "N", "F", "(", "B2", "X", "U", "D", "", "AA"] {
            let line = format!("name = \"{bad}\"");
            let text = fadal().replacen("name = \"A\"", &line, 1);
            let named = format!("rotary axis name \"{bad}\"");
            refused_after(&text, "[[rotary]]", &line, at, &named);
        }
    }

    #[test]
    fn axis_names_are_distinct_ignoring_case() {
        // Y named x: refused at Y's name, the second use.
        let text = fadal().replacen("name = \"Y\"", "name = \"x\"", 1);
        refused_at(&text, "name = \"x\"", "x", "axis name \"X\" is used twice");
        // A named b: refused at B, the second use.
        let text = fadal().replacen("name = \"A\"", "name = \"b\"", 1);
        refused_at(&text, "name = \"B\"", "B", "axis name \"B\" is used twice");
    }

    #[test]
    fn lower_case_axis_names_are_stored_upper_case() {
        let mut text = fadal().to_string();
        for n in ["X", "Y", "Z", "A", "B"] {
            text = text.replacen(
                &format!("name = \"{n}\""),
                &format!("name = \"{}\"", n.to_lowercase()),
                1,
            );
        }
        let m = MachineDef::from_toml(&text, "m.toml").and_then(|d| Machine::new(d, &[]));
        let m = m.unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.axis_names(), ["X", "Y", "Z", "A", "B"]);
    }

    #[test]
    fn head_and_machine_names_hold_no_parentheses_or_line_breaks() {
        for (bad, offending, shown) in [
            ("laser (main)", "(", "`(` (a comment)"),
            ("laser)", ")", "`)` (a comment)"),
        ] {
            let line = format!("name = \"{bad}\"");
            let text = fadal().replacen("name = \"laser\"", &line, 1);
            refused_at(
                &text,
                &line,
                offending,
                &format!("head name \"{bad}\" holds {shown}"),
            );
        }
        // An escaped line break: at the value's quote.
        let line = "name = \"laser\\nG0 X900\"";
        let text = fadal().replacen("name = \"laser\"", line, 1);
        refused_at(&text, line, "\"", "`\\n` (a line break)");
        // The machine name goes into the program's header comment too.
        let line = "name = \"fadal\\nG0 X900\"";
        let text = fadal().replacen("name = \"fadal-lamp\"", line, 1);
        refused_at(&text, line, "\"", "machine name \"fadal\\nG0 X900\"");
        let line = "name = \"fadal (lamp)\"";
        let text = fadal().replacen("name = \"fadal-lamp\"", line, 1);
        refused_at(&text, line, "(", "machine name");
    }

    #[test]
    fn process_lengths_are_finite_and_not_negative() {
        for (line, offending, named) in [
            ("safe_margin = -0.1", "-0.1", "`process.safe_margin` = -0.1"),
            ("head_radius = 0.0", "0.0", "`process.head_radius` = 0"),
            ("head_radius = -1", "-1", "`process.head_radius` = -1"),
            ("head_length = 0", "0", "`process.head_length` = 0"),
            ("head_length = -6.0", "-6.0", "`process.head_length` = -6"),
        ] {
            let text = format!("{}{line}\n", fadal());
            refused_at(&text, line, offending, named);
        }
        // Non-finite values are refused by the NaN/inf scan, at the value.
        let line = "safe_margin = inf";
        let text = format!("{}{line}\n", fadal());
        refused_at(&text, line, "inf", "NaN or infinity");
        // A zero margin is allowed.
        let text = format!("{}safe_margin = 0.0\n", fadal());
        let m = MachineDef::from_toml(&text, "m.toml").and_then(|d| Machine::new(d, &[]));
        assert_eq!(m.map(|m| m.safe_margin()).ok(), Some(0.0));
    }

    #[test]
    fn good_process_codes_are_accepted() {
        for (value, stored) in [
            ("M71", "M71"),
            ("M3", "M3"),
            ("m3 s1200", "M3 S1200"),
            (" M3  P10 Q2.5 ", "M3 P10 Q2.5"),
            ("S-1 M3", "S-1 M3"),
            ("M3 S.5", "M3 S.5"),
        ] {
            let text = with_line(fadal(), "spindle_on", &format!("spindle_on = \"{value}\""));
            let d =
                MachineDef::from_toml(&text, "m.toml").unwrap_or_else(|e| panic!("{value}: {e}"));
            assert_eq!(d.process.spindle_on, stored);
        }
    }

    #[test]
    fn built_ins_and_the_test_machine_load() {
        for (name, _) in crate::def::BUILTINS {
            let m = Machine::builtin(name, &[]).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(
                m.def,
                MachineDef::builtin(name).unwrap_or_else(|| panic!("{name}"))
            );
        }
        let trt = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../fixtures/machines/xyzac-trt.toml"
        ))
        .unwrap_or_default();
        let m = MachineDef::from_toml(&trt, "xyzac-trt.toml").and_then(|d| Machine::new(d, &[]));
        assert!(m.is_ok(), "{m:?}");
    }

    #[test]
    fn process_lengths_default_by_units() {
        let f = Machine::builtin("fadal-lamp", &[]).unwrap_or_else(|e| panic!("{e}"));
        let nrc = Machine::builtin("nrc-lc", &[]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            (f.safe_margin(), f.head_radius(), f.head_length()),
            (0.2, 1.0, 6.0)
        );
        assert_eq!(
            (nrc.safe_margin(), nrc.head_radius(), nrc.head_length()),
            (5.0, 25.0, 150.0)
        );
        let text = format!(
            "{}safe_margin = 0.5\nhead_radius = 2.0\nhead_length = 8.0\n",
            fadal()
        );
        let m = MachineDef::from_toml(&text, "m.toml").and_then(|d| Machine::new(d, &[]));
        let m = m.unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            (m.safe_margin(), m.head_radius(), m.head_length()),
            (0.5, 2.0, 8.0)
        );
        // Written back, they read the same.
        let again = MachineDef::from_toml(&m.def.to_toml(), "again.toml");
        assert_eq!(again.ok().as_ref(), Some(&m.def));
    }

    #[test]
    fn definitions_built_in_code_are_checked_too() {
        let mut d = MachineDef::builtin("fadal-lamp").unwrap_or_else(|| panic!("built-in"));
        d.process.laser_on = "G0 X900".into();
        let e = Machine::new(d.clone(), &[]).err().map(|e| e.to_string());
        assert!(
            e.as_deref()
                .is_some_and(|e| e.contains("`process.laser_on` holds `G0`")),
            "{e:?}"
        );
        d.process.laser_on = "M71".into();
        d.process.laser_power_word = "X".into();
        assert!(Machine::new(d.clone(), &[]).is_err());
        d.process.laser_power_word = "S".into();
        d.rotary[0].name = "G".into();
        assert!(Machine::new(d.clone(), &[]).is_err());
        d.rotary[0].name = "A".into();
        d.process.safe_margin = Some(f64::NAN);
        assert!(Machine::new(d.clone(), &[]).is_err());
        d.process.safe_margin = None;
        assert!(Machine::new(d, &[]).is_ok());
    }
}
