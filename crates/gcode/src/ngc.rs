//! LinuxCNC O-word control lines, followed by [`crate::ProgramReader`] in execution order
//! for the `linuxcnc` flavour: `sub`/`endsub`/`call`/`return`, `if`/`elseif`/`else`/`endif`,
//! `while`/`endwhile`, `do`/`while`, `repeat`/`endrepeat`, `break`, `continue`.
//!
//! The file's O-word lines are indexed once (offsets, line numbers, label and keyword;
//! never the text), when the first one is met. A control line then tells the reader where
//! to go on. A subroutine body is never read where it is defined; a call runs it with its
//! arguments in `#1`… and its own named locals; `return [v]` leaves `v` in `#<_value>`.
//!
//! Bounds: calls nest at most [`MAX_SUB_DEPTH`] deep (LinuxCNC's limit; recursion is
//! allowed to that depth), and the blocks run again by loops and calls are counted:
//! beyond [`MAX_BLOCKS`] (or [`MAX_LOOP_BYTES`] of them) the run stops with an error at
//! the line that would go on. A
//! `repeat` count over [`MAX_BLOCKS`] is refused at once.

use std::collections::HashMap;

use crate::expr::{Eval, EvalError, Params};

/// Subroutine calls nest at most this deep (LinuxCNC's `INTERP_SUB_ROUTINE_LEVELS`).
pub const MAX_SUB_DEPTH: usize = 10;
/// The most blocks run again through loops and subroutine calls in one program.
pub const MAX_BLOCKS: u64 = 1_000_000;

/// The most bytes of blocks run again through loops and calls (64 MiB, about a second
/// of evaluation): 10⁶ blocks of a long expression each would take minutes.
pub const MAX_LOOP_BYTES: u64 = 64 << 20;
/// The most O-word lines indexed in one file.
const MAX_ENTRIES: usize = 1_000_000;

/// An O-word keyword.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kw {
    Sub,
    EndSub,
    Call,
    Return,
    If,
    ElseIf,
    Else,
    EndIf,
    While,
    EndWhile,
    Do,
    Repeat,
    EndRepeat,
    Break,
    Continue,
}

/// The label (a number as digits without leading zeros, or a lower-case name), the
/// keyword and where the rest of the line starts, of an O-word line.
pub(crate) fn parse_oword(text: &str) -> Option<(String, Kw, usize)> {
    let b = text.as_bytes();
    let mut i = 0;
    let skip = |i: &mut usize| {
        while *i < b.len() && matches!(b[*i], b' ' | b'\t') {
            *i += 1;
        }
    };
    skip(&mut i);
    if b.get(i) == Some(&b'/') {
        i += 1;
        skip(&mut i);
    }
    if b.get(i).is_some_and(|c| matches!(c, b'n' | b'N')) {
        i += 1;
        skip(&mut i);
        while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
            i += 1;
        }
        skip(&mut i);
    }
    if !b.get(i).is_some_and(|c| matches!(c, b'o' | b'O')) {
        return None;
    }
    i += 1;
    skip(&mut i);
    let label = if b.get(i) == Some(&b'<') {
        let close = i + memchr::memchr(b'>', &b[i..])?;
        let name: String = text[i + 1..close]
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect::<String>()
            .to_ascii_lowercase();
        i = close + 1;
        name
    } else {
        let s = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        if i == s {
            return None;
        }
        let digits = text[s..i].trim_start_matches('0');
        if digits.is_empty() {
            "0".into()
        } else {
            digits.into()
        }
    };
    skip(&mut i);
    let s = i;
    while i < b.len() && b[i].is_ascii_alphabetic() {
        i += 1;
    }
    let mut word = text[s..i].to_ascii_lowercase();
    // rs274 reads a line with its blanks taken out: `else if` is `elseif`, `end sub`
    // is `endsub` (probe-screen-ng's and linuxcnc-features' macros write them so).
    let mut j = i;
    skip(&mut j);
    let t = j;
    while j < b.len() && b[j].is_ascii_alphabetic() {
        j += 1;
    }
    if j > t {
        let joined = format!("{word}{}", text[t..j].to_ascii_lowercase());
        if matches!(
            joined.as_str(),
            "elseif" | "endsub" | "endif" | "endwhile" | "endrepeat"
        ) {
            word = joined;
            i = j;
        }
    }
    let kw = match word.as_str() {
        "sub" => Kw::Sub,
        "endsub" => Kw::EndSub,
        "call" => Kw::Call,
        "return" => Kw::Return,
        "if" => Kw::If,
        "elseif" => Kw::ElseIf,
        "else" => Kw::Else,
        "endif" => Kw::EndIf,
        "while" => Kw::While,
        "endwhile" => Kw::EndWhile,
        "do" => Kw::Do,
        "repeat" => Kw::Repeat,
        "endrepeat" => Kw::EndRepeat,
        "break" => Kw::Break,
        "continue" => Kw::Continue,
        _ => return None,
    };
    Some((label, kw, i))
}

/// One O-word line of the file.
#[derive(Debug, Clone)]
struct Entry {
    label: Box<str>,
    kw: Kw,
    /// Offset and line number of the line, and of the line after it.
    at: (usize, u32),
    next: (usize, u32),
    /// A `while` that closes a `do`.
    do_while: bool,
}

#[derive(Debug, Clone, Copy)]
struct Frame {
    back: (usize, u32),
    repeats_base: usize,
}

/// A control error: message and byte range in the line.
pub(crate) type CtlError = (String, usize, usize);

/// The index of a file's O-word lines and the state of the control flow.
#[derive(Debug, Default)]
pub(crate) struct Control {
    entries: Vec<Entry>,
    by_label: HashMap<Box<str>, Vec<usize>>,
    frames: Vec<Frame>,
    /// Running `repeat` loops: (entry, runs left).
    repeats: Vec<(usize, u64)>,
    /// The `elseif`/`else` line jumped to, to be taken as a branch.
    branch: Option<usize>,
    blocks: u64,
    pub(crate) max_blocks: u64,
    /// Bytes of blocks run again so far (see [`MAX_LOOP_BYTES`]).
    bytes: u64,
}

impl Control {
    /// An empty index, to be filled by [`Control::add`] in file order.
    pub(crate) fn new() -> Self {
        Control {
            max_blocks: MAX_BLOCKS,
            bytes: 0,
            ..Control::default()
        }
    }

    /// Note an O-word line (in file order); false when the index is full.
    pub(crate) fn add(&mut self, text: &str, at: (usize, u32), next: (usize, u32)) -> bool {
        let Some((label, kw, _)) = parse_oword(text) else {
            return true;
        };
        if self.entries.len() >= MAX_ENTRIES {
            return false;
        }
        let label: Box<str> = label.into();
        let list = self.by_label.entry(label.clone()).or_default();
        // A `while` closes a `do` when the nearest loop line of its label before it is one.
        let do_while = kw == Kw::While
            && list
                .iter()
                .rev()
                .map(|&j| self.entries[j].kw)
                .find(|k| matches!(k, Kw::Do | Kw::While | Kw::EndWhile))
                == Some(Kw::Do);
        list.push(self.entries.len());
        self.entries.push(Entry {
            label,
            kw,
            at,
            next,
            do_while,
        });
        true
    }

    fn list(&self, label: &str) -> &[usize] {
        self.by_label.get(label).map_or(&[], Vec::as_slice)
    }

    /// The first entry after `k` (a position in `list`) that `want` accepts.
    fn after(&self, list: &[usize], k: usize, want: impl Fn(&Entry) -> bool) -> Option<usize> {
        list[k + 1..]
            .iter()
            .copied()
            .find(|&j| want(&self.entries[j]))
    }

    /// The last entry before `k` that `want` accepts.
    fn before(&self, list: &[usize], k: usize, want: impl Fn(&Entry) -> bool) -> Option<usize> {
        list[..k]
            .iter()
            .rev()
            .copied()
            .find(|&j| want(&self.entries[j]))
    }

    /// A jump back from `from` to `to` (offset, line): the blocks (and bytes) it runs
    /// again, counted against [`MAX_BLOCKS`] (and [`MAX_LOOP_BYTES`]).
    fn count(
        &mut self,
        (from, to): ((usize, u32), (usize, u32)),
        len: usize,
    ) -> Result<(), CtlError> {
        self.blocks += u64::from(from.1.saturating_sub(to.1)) + 1;
        self.bytes += from.0.saturating_sub(to.0) as u64;
        if self.bytes > MAX_LOOP_BYTES {
            return Err((
                format!("more than {MAX_LOOP_BYTES} bytes of blocks run again through loops and subroutine calls (long lines in a loop that runs long?)"),
                0,
                len,
            ));
        }
        if self.blocks > self.max_blocks {
            return Err((
                format!(
                    "more than {} blocks run through loops and subroutine calls (a loop that never ends?)",
                    self.max_blocks
                ),
                0,
                len,
            ));
        }
        Ok(())
    }

    /// Follow the control line `text` (at offset `offset`): where reading goes on, or
    /// `None` for the next line.
    pub(crate) fn step(
        &mut self,
        text: &str,
        offset: usize,
        params: &mut Params,
    ) -> Result<Option<(usize, u32)>, CtlError> {
        let len = text.len();
        let Some((label, kw, rest)) = parse_oword(text) else {
            return Err(("not an O-word control line".into(), 0, len));
        };
        let i = match self.entries.binary_search_by_key(&offset, |e| e.at.0) {
            Ok(i) => i,
            Err(_) => return Err(("this O-word line is not in the file's index".into(), 0, len)),
        };
        let branch = self.branch.take();
        let list = self.list(&label).to_vec();
        let k = list.iter().position(|&j| j == i).unwrap_or(0);
        let e = self.entries[i].clone();
        let name = |kw: &str| format!("o{} {kw}", fmt_label(&label));
        let cond = |params: &Params| -> Result<bool, CtlError> {
            let mut ev = Eval::new(text, rest, params);
            let v = ev.value().map_err(|(m, s, e): EvalError| (m, s, e))?;
            Ok(v != 0.0)
        };
        match kw {
            Kw::Sub => {
                let end = self
                    .after(&list, k, |x| x.kw == Kw::EndSub)
                    .ok_or_else(|| (format!("{} has no endsub", name("sub")), 0, len))?;
                Ok(Some(self.entries[end].next))
            }
            Kw::EndSub | Kw::Return => {
                // `return [v]` and `endsub [v]` both give the call a value (rs274 sets
                // `#<_value>` from either).
                let value = {
                    let mut ev = Eval::new(text, rest, params);
                    match ev.peek_value() {
                        true => Some(ev.value()?),
                        false => None,
                    }
                };
                let Some(f) = self.frames.pop() else {
                    return Err((
                        format!(
                            "{} outside a subroutine call",
                            name(if kw == Kw::Return { "return" } else { "endsub" })
                        ),
                        0,
                        len,
                    ));
                };
                params.leave(value);
                self.repeats.truncate(f.repeats_base);
                Ok(Some(f.back))
            }
            Kw::Call => {
                let mut args = Vec::new();
                let mut ev = Eval::new(text, rest, params);
                while ev.peek_value() {
                    if args.len() >= crate::expr::SUB_PARAMS {
                        return Err(("more than 30 arguments".into(), ev.pos, len));
                    }
                    args.push(ev.value()?);
                }
                self.call(&label, &args, e.next, params)
                    .map(Some)
                    .map_err(|m| (m, 0, len))
            }
            Kw::If => {
                if cond(params)? {
                    Ok(None)
                } else {
                    self.next_branch(&list, k, &label, len)
                }
            }
            Kw::ElseIf => {
                if branch == Some(i) {
                    if cond(params)? {
                        Ok(None)
                    } else {
                        self.next_branch(&list, k, &label, len)
                    }
                } else {
                    self.past_endif(&list, k, &label, len)
                }
            }
            Kw::Else => {
                if branch == Some(i) {
                    Ok(None)
                } else {
                    self.past_endif(&list, k, &label, len)
                }
            }
            Kw::EndIf | Kw::Do => Ok(None),
            Kw::While if e.do_while => {
                if cond(params)? {
                    let d = self
                        .before(&list, k, |x| x.kw == Kw::Do)
                        .ok_or_else(|| (format!("{} has no do", name("while")), 0, len))?;
                    self.count((e.at, self.entries[d].at), len)?;
                    Ok(Some(self.entries[d].next))
                } else {
                    Ok(None)
                }
            }
            Kw::While => {
                if cond(params)? {
                    Ok(None)
                } else {
                    let end = self
                        .after(&list, k, |x| x.kw == Kw::EndWhile)
                        .ok_or_else(|| (format!("{} has no endwhile", name("while")), 0, len))?;
                    Ok(Some(self.entries[end].next))
                }
            }
            Kw::EndWhile => {
                let w = self
                    .before(&list, k, |x| x.kw == Kw::While && !x.do_while)
                    .ok_or_else(|| (format!("{} has no while", name("endwhile")), 0, len))?;
                self.count((e.at, self.entries[w].at), len)?;
                Ok(Some(self.entries[w].at))
            }
            Kw::Repeat => {
                let mut ev = Eval::new(text, rest, params);
                let n = ev.value()?;
                let n = crate::emit::round_half_away(n);
                if n > self.max_blocks as f64 {
                    return Err((
                        format!(
                            "repeat count {n} is over the limit of {} blocks",
                            self.max_blocks
                        ),
                        rest + (text[rest..].len() - text[rest..].trim_start().len()),
                        ev.pos,
                    ));
                }
                if n >= 1.0 {
                    self.repeats.push((i, n as u64));
                    Ok(None)
                } else {
                    let end = self
                        .after(&list, k, |x| x.kw == Kw::EndRepeat)
                        .ok_or_else(|| (format!("{} has no endrepeat", name("repeat")), 0, len))?;
                    Ok(Some(self.entries[end].next))
                }
            }
            Kw::EndRepeat => {
                let pos = self
                    .repeats
                    .iter()
                    .rposition(|&(j, _)| *self.entries[j].label == *label)
                    .ok_or_else(|| (format!("{} outside its repeat", name("endrepeat")), 0, len))?;
                let (r, left) = self.repeats[pos];
                if left > 1 {
                    self.count((e.at, self.entries[r].at), len)?;
                    self.repeats[pos].1 = left - 1;
                    Ok(Some(self.entries[r].next))
                } else {
                    self.repeats.truncate(pos);
                    Ok(None)
                }
            }
            Kw::Break | Kw::Continue => {
                let what = if kw == Kw::Break { "break" } else { "continue" };
                let open = self
                    .before(&list, k, |x| {
                        matches!(x.kw, Kw::Do | Kw::Repeat) || x.kw == Kw::While && !x.do_while
                    })
                    .ok_or_else(|| (format!("{} outside a loop", name(what)), 0, len))?;
                let ok = self.entries[open].kw;
                let close = self
                    .after(&list, k, |x| match ok {
                        Kw::Do => x.kw == Kw::While && x.do_while,
                        Kw::Repeat => x.kw == Kw::EndRepeat,
                        _ => x.kw == Kw::EndWhile,
                    })
                    .ok_or_else(|| (format!("{}: its loop is not closed", name(what)), 0, len))?;
                if kw == Kw::Break {
                    if ok == Kw::Repeat {
                        if let Some(p) = self.repeats.iter().rposition(|&(j, _)| j == open) {
                            self.repeats.truncate(p);
                        }
                    }
                    Ok(Some(self.entries[close].next))
                } else if ok == Kw::While {
                    self.count((e.at, self.entries[open].at), len)?;
                    Ok(Some(self.entries[open].at))
                } else {
                    Ok(Some(self.entries[close].at))
                }
            }
        }
    }

    /// Call the subroutine `label` with `args`, reading on at `back` after it returns:
    /// where its body starts.
    pub(crate) fn call(
        &mut self,
        label: &str,
        args: &[f64],
        back: (usize, u32),
        params: &mut Params,
    ) -> Result<(usize, u32), String> {
        let list = self.list(label).to_vec();
        let name = |kw: &str| format!("o{} {kw}", fmt_label(label));
        let sub = list
            .iter()
            .copied()
            .find(|&j| self.entries[j].kw == Kw::Sub)
            .ok_or_else(|| format!("no subroutine {} in this file", name("sub")))?;
        let sk = list.iter().position(|&j| j == sub).unwrap_or(0);
        let end = self
            .after(&list, sk, |x| x.kw == Kw::EndSub)
            .ok_or_else(|| format!("{} has no endsub", name("sub")))?;
        if self.frames.len() >= MAX_SUB_DEPTH {
            return Err(format!(
                "subroutine calls nest more than {MAX_SUB_DEPTH} deep (recursion without end?)"
            ));
        }
        self.count((self.entries[end].at, self.entries[sub].at), 0)
            .map_err(|(m, _, _)| m)?;
        self.frames.push(Frame {
            back,
            repeats_base: self.repeats.len(),
        });
        params.enter(args);
        Ok(self.entries[sub].next)
    }

    /// How deep in subroutine calls the reading is.
    pub(crate) fn depth(&self) -> usize {
        self.frames.len()
    }

    /// After a false `if`/`elseif`: the next `elseif`/`else` (to be taken as a branch) or
    /// past the `endif`.
    fn next_branch(
        &mut self,
        list: &[usize],
        k: usize,
        label: &str,
        len: usize,
    ) -> Result<Option<(usize, u32)>, CtlError> {
        let j = self
            .after(list, k, |x| {
                matches!(x.kw, Kw::ElseIf | Kw::Else | Kw::EndIf)
            })
            .ok_or_else(|| (format!("o{} if has no endif", fmt_label(label)), 0, len))?;
        if self.entries[j].kw == Kw::EndIf {
            Ok(Some(self.entries[j].next))
        } else {
            self.branch = Some(j);
            Ok(Some(self.entries[j].at))
        }
    }

    fn past_endif(
        &mut self,
        list: &[usize],
        k: usize,
        label: &str,
        len: usize,
    ) -> Result<Option<(usize, u32)>, CtlError> {
        let j = self
            .after(list, k, |x| x.kw == Kw::EndIf)
            .ok_or_else(|| (format!("o{} if has no endif", fmt_label(label)), 0, len))?;
        Ok(Some(self.entries[j].next))
    }
}

fn fmt_label(label: &str) -> String {
    if label.bytes().all(|c| c.is_ascii_digit()) {
        label.to_string()
    } else {
        format!("<{label}>")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn o_word_lines_are_recognised() {
        for (s, label, kw) in [
            ("o100 sub", "100", Kw::Sub),
            ("O0100 CALL [1] [2]", "100", Kw::Call),
            ("  o<My Sub> endsub", "mysub", Kw::EndSub),
            ("N10 o5 while [#1 LT 3]", "5", Kw::While),
            ("/o7 endrepeat", "7", Kw::EndRepeat),
        ] {
            let (l, k, _) = parse_oword(s).expect(s);
            assert_eq!((l.as_str(), k), (label, kw), "{s}");
        }
        for s in ["O1000", "G1 X1", "o100", "o100 foo"] {
            assert!(parse_oword(s).is_none(), "{s}");
        }
    }
}
