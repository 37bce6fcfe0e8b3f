//! Splitting a posted program into pieces that fit controller memory (paper 001's
//! problem): FADAL subprograms called from a main program, or numbered files for DNC.
//!
//! Every piece reads on its own: a DNC piece after the first starts with the modal
//! preamble copied from the program's head (units, G90, G94, G17, G40, G80), and in every
//! piece (and in the FADAL main program's postamble, which follows the calls) the first
//! block with axis words carries its motion code and the first feed move its feed, copied
//! from the text before the cut where the block leaves them to the modal state. Nothing
//! is invented: the words are the ones in force where the piece begins.

use std::io::{BufReader, Read, Seek, SeekFrom};

use lampost_gcode::{parse_line, Block, BlockKind, LineReader, AXES};

use crate::error::PostError;
use crate::post::{PostDialect, PostReport};

/// One output piece: a name suffix (empty for the single FADAL file) and its text.
#[derive(Debug, Clone, PartialEq)]
pub struct Piece {
    /// 1-based piece number (FADAL: 0 for the one file holding everything).
    pub number: usize,
    /// The text.
    pub text: Vec<u8>,
}

fn read_range<F: Read + Seek>(f: &mut F, from: u64, to: u64) -> Result<Vec<u8>, PostError> {
    f.seek(SeekFrom::Start(from))?;
    let mut v = vec![
        0u8;
        usize::try_from(to.saturating_sub(from))
            .map_err(|_| PostError::Io("program too large".into()))?
    ];
    f.read_exact(&mut v)?;
    Ok(v)
}

/// Each line of `f` from `from` to `to` (both line starts): its offset and bytes.
fn each_line<F: Read + Seek>(
    f: &mut F,
    from: u64,
    to: u64,
    mut on_line: impl FnMut(u64, &[u8]) -> Result<(), PostError>,
) -> Result<(), PostError> {
    f.seek(SeekFrom::Start(from))?;
    let mut lines = LineReader::new(BufReader::new(f.by_ref().take(to.saturating_sub(from))));
    while let Some(l) = lines.next_line()? {
        on_line(from + l.offset as u64, l.bytes)?;
    }
    Ok(())
}

/// The modal words in force after the text so far, as written.
#[derive(Debug, Clone, Default)]
struct Modal {
    /// The motion code (times ten, as [`lampost_gcode::Word::code`]) and its word
    /// (`G0`, `G1`, …); `None` after G80 or before any.
    motion: Option<(u16, String)>,
    /// The feed word (`F508`).
    feed: Option<String>,
    /// The last word written of each axis (`X-81.500`), by [`AXES`] index.
    axes: [Option<String>; 9],
    inverse_time: bool,
}

fn motion_code(code: u16) -> bool {
    matches!(code, 0 | 10 | 20 | 30 | 800 | 730 | 740 | 760 | 810..=890)
}

fn has_axes(b: &Block<'_>) -> bool {
    b.words()
        .any(|w| w.register.is_none() && AXES.contains(&w.letter))
}

impl Modal {
    fn update(&mut self, b: &Block<'_>) {
        for w in b.words() {
            match (w.letter, w.code()) {
                (b'G', Some(800)) => self.motion = None,
                (b'G', Some(c)) if motion_code(c) => self.motion = Some((c, w.display())),
                (b'G', Some(930)) => self.inverse_time = true,
                (b'G', Some(940 | 950)) => self.inverse_time = false,
                (b'F', _) => self.feed = Some(w.display()),
                (l, _) if w.register.is_none() => {
                    if let Some(i) = AXES.iter().position(|&a| a == l) {
                        self.axes[i] = Some(w.display());
                    }
                }
                _ => {}
            }
        }
    }
}

/// The start of a piece: what its first blocks still have to say.
#[derive(Debug, Clone)]
struct Opening {
    at: Modal,
    need_motion: bool,
    need_feed: bool,
}

impl Opening {
    fn new(at: &Modal) -> Self {
        Opening {
            at: at.clone(),
            need_motion: true,
            need_feed: true,
        }
    }

    fn done(&self) -> bool {
        !self.need_motion && !self.need_feed
    }

    /// Words to insert into `b` (parsed at offset 0, so spans index the line):
    /// `(position, text)`, in order; `modal` is the state before `b`.
    fn fix(&mut self, b: &Block<'_>, modal: &Modal) -> Vec<(usize, String)> {
        let mut ins = Vec::new();
        if b.kind != BlockKind::Words || !b.has_words() {
            return ins;
        }
        let axes = has_axes(b);
        let own_motion = b
            .words()
            .find(|w| w.letter == b'G' && w.code().is_some_and(motion_code));
        if self.need_motion && axes {
            self.need_motion = false;
            if own_motion.is_none() {
                if let Some((_, g)) = &self.at.motion {
                    let mut words = b.words();
                    ins.push(match words.next() {
                        Some(n) if n.letter == b'N' => (n.span.end, format!(" {g}")),
                        Some(first) => (first.span.start, format!("{g} ")),
                        None => (0, String::new()),
                    });
                }
            }
            // The axes the block leaves out, where the last piece left them (the
            // machine is there already: no motion), so that the piece read alone
            // starts where it runs (a lift `G0 Z150.` then `Y-51.` left X at 0).
            let missing: String = AXES
                .iter()
                .zip(&self.at.axes)
                .filter(|(&l, v)| v.is_some() && b.word(l).is_none())
                .filter_map(|(_, v)| v.as_ref().map(|v| format!(" {v}")))
                .collect();
            if let (false, Some(last)) = (missing.is_empty(), b.words().last()) {
                ins.push((last.span.end, missing));
            }
        }
        if self.need_feed {
            if b.word(b'F').is_some() {
                self.need_feed = false;
            } else {
                let motion = own_motion
                    .and_then(|w| w.code())
                    .or(modal.motion.as_ref().map(|m| m.0));
                let feeds = matches!(motion, Some(10 | 20 | 30));
                if axes && feeds {
                    self.need_feed = false;
                    if let (false, Some(fw), Some(last)) =
                        (modal.inverse_time, &self.at.feed, b.words().last())
                    {
                        ins.push((last.span.end, format!(" {fw}")));
                    }
                }
            }
        }
        ins
    }
}

/// `line` with `ins` inserted, and its line ending.
fn with_inserts(line: &[u8], ins: &[(usize, String)]) -> Vec<u8> {
    let mut v = Vec::with_capacity(line.len() + 16);
    let mut at = 0;
    for (pos, text) in ins {
        let pos = (*pos).clamp(at, line.len());
        v.extend_from_slice(&line[at..pos]);
        v.extend_from_slice(text.as_bytes());
        at = pos;
    }
    v.extend_from_slice(&line[at..]);
    v.push(b'\n');
    v
}

/// Walks text, keeping the modal state and fixing the blocks after each opening.
#[derive(Debug, Default)]
struct Walker {
    modal: Modal,
    opening: Option<Opening>,
}

impl Walker {
    /// Start a piece here.
    fn open(&mut self) {
        self.opening = Some(Opening::new(&self.modal));
    }

    /// The line as it goes into the piece (with its line ending).
    fn line(&mut self, bytes: &[u8]) -> Vec<u8> {
        let Ok(b) = parse_line(bytes, 1, 0) else {
            let mut v = bytes.to_vec();
            v.push(b'\n');
            return v;
        };
        let ins = match self.opening.as_mut() {
            Some(o) => {
                let ins = o.fix(&b, &self.modal);
                if o.done() {
                    self.opening = None;
                }
                ins
            }
            None => Vec::new(),
        };
        self.modal.update(&b);
        with_inserts(bytes, &ins)
    }
}

/// The modal preamble of the program's head: its line with the units code.
fn preamble(prefix: &[u8]) -> Option<Vec<u8>> {
    prefix.split(|&c| c == b'\n').find_map(|l| {
        let b = parse_line(l, 1, 0).ok()?;
        let units = b
            .words()
            .any(|w| w.letter == b'G' && matches!(w.code(), Some(200 | 210 | 700 | 710)));
        units.then(|| {
            let mut v = l.to_vec();
            v.push(b'\n');
            v
        })
    })
}

/// Cut the posted program `f` (as `post` wrote it, with `report`'s offsets) into pieces of
/// at most `max_bytes`, at points where the head travels with the process off.
pub fn split<F: Read + Seek>(
    f: &mut F,
    total: u64,
    report: &PostReport,
    dialect: PostDialect,
    program_number: u32,
    max_bytes: usize,
) -> Result<Vec<Piece>, PostError> {
    let (b0, b1) = report.body;
    let fadal = dialect == PostDialect::Fadal;
    let mut prefix = read_range(f, 0, b0)?;
    let mut suffix = read_range(f, b1, total)?;
    if fadal {
        if prefix.starts_with(b"%\n") {
            prefix.drain(..2);
        }
        if suffix.ends_with(b"%\n") {
            suffix.truncate(suffix.len() - 2);
        }
    }
    // Cut points inside the body, and its end.
    let mut cuts: Vec<u64> = report
        .split_points
        .iter()
        .copied()
        .filter(|&c| c > b0 && c < b1)
        .collect();
    cuts.sort_unstable();
    cuts.dedup();
    cuts.push(b1);
    // What a piece starting at each cut adds to fix its first blocks, found by walking the
    // body once with an opening at every cut (few are open at a time: each closes at the
    // next feed move).
    let mut extra = vec![0u64; cuts.len()];
    {
        let mut modal = Modal::default();
        for l in prefix.split(|&c| c == b'\n') {
            if let Ok(b) = parse_line(l, 1, 0) {
                modal.update(&b);
            }
        }
        let mut open: Vec<(usize, Opening)> = Vec::new();
        let mut next_cut = 0usize;
        each_line(f, b0, b1, |off, bytes| {
            while next_cut < cuts.len() && cuts[next_cut] <= off {
                open.push((next_cut, Opening::new(&modal)));
                next_cut += 1;
            }
            if let Ok(b) = parse_line(bytes, 1, 0) {
                open.retain_mut(|(k, o)| {
                    let ins = o.fix(&b, &modal);
                    extra[*k] += ins.iter().map(|(_, t)| t.len() as u64).sum::<u64>();
                    !o.done()
                });
                modal.update(&b);
            }
            Ok(())
        })?;
    }
    let preamble = if fadal {
        Vec::new()
    } else {
        preamble(&prefix).unwrap_or_default()
    };
    let overhead = if fadal { 32 } else { 0 };
    let extra_at = |c: u64| {
        cuts.binary_search(&c)
            .map_or(0, |k| extra.get(k).copied().unwrap_or(0))
    };
    let mut pieces_ranges: Vec<(u64, u64)> = Vec::new();
    let mut start = b0;
    while start < b1 {
        let head = if pieces_ranges.is_empty() {
            if fadal {
                0
            } else {
                prefix.len() as u64
            }
        } else {
            preamble.len() as u64 + extra_at(start)
        };
        let budget = (max_bytes.saturating_sub(overhead) as u64).saturating_sub(head);
        let mut best = None;
        for &c in &cuts {
            if c <= start {
                continue;
            }
            let tail = if c == b1 && !fadal {
                suffix.len() as u64
            } else {
                0
            };
            if c - start + tail <= budget {
                best = Some(c);
            } else {
                break;
            }
        }
        let Some(end) = best else {
            let next = cuts.iter().copied().find(|&c| c > start).unwrap_or(b1);
            let tail = if next == b1 && !fadal {
                suffix.len() as u64
            } else {
                0
            };
            let need = next - start + tail + head + overhead as u64;
            return Err(PostError::Options(format!(
                "a stretch of {} bytes has no point where the head travels with the process off: with the {} bytes its piece starts{} with, it needs --max-bytes {need} or more (given {max_bytes}); raise the limit",
                next - start,
                head + overhead as u64,
                if tail > 0 { " and ends" } else { "" }
            )));
        };
        pieces_ranges.push((start, end));
        start = end;
    }
    if !fadal && pieces_ranges.len() > 1 && preamble.is_empty() {
        return Err(PostError::Options(
            "internal: the program head has no modal preamble to start each piece with".into(),
        ));
    }
    // Write the pieces, walking the body again with the state in force at each start.
    let mut walker = Walker::default();
    for l in prefix.split(|&c| c == b'\n') {
        if let Ok(b) = parse_line(l, 1, 0) {
            walker.modal.update(&b);
        }
    }
    let mut out = Vec::new();
    let count = pieces_ranges.len();
    let mut bodies: Vec<Vec<u8>> = Vec::with_capacity(count);
    for (k, &(s, e)) in pieces_ranges.iter().enumerate() {
        let mut text = Vec::new();
        if !fadal {
            text.extend_from_slice(if k == 0 { &prefix } else { &preamble });
        }
        walker.open();
        each_line(f, s, e, |_, bytes| {
            text.extend(walker.line(bytes));
            Ok(())
        })?;
        bodies.push(text);
    }
    match dialect {
        PostDialect::Fadal => {
            let mut text = b"%\n".to_vec();
            let mut calls = Vec::new();
            for (k, body) in bodies.into_iter().enumerate() {
                let n = u32::try_from(k)
                    .ok()
                    .and_then(|k| program_number.checked_add(1 + k))
                    .filter(|&n| n <= crate::post::MAX_PROGRAM_NUMBER)
                    .ok_or_else(|| {
                        PostError::Options(format!(
                            "--program-number {program_number}: the {count} subprograms after it would pass O{}; give a number of at most {}",
                            crate::post::MAX_PROGRAM_NUMBER,
                            crate::post::MAX_PROGRAM_NUMBER.saturating_sub(count as u32)
                        ))
                    })?;
                let head = format!("O{n} (PART {} OF {count})\n", k + 1);
                if head.len() + body.len() + 4 > max_bytes {
                    return Err(PostError::Options(format!(
                        "internal: subprogram O{n} came to {} bytes, more than --max-bytes {max_bytes}",
                        head.len() + body.len() + 4
                    )));
                }
                text.extend_from_slice(head.as_bytes());
                text.extend(body);
                text.extend_from_slice(b"M99\n");
                calls.extend_from_slice(format!("M98 P{n}\n").as_bytes());
            }
            text.extend(prefix);
            text.extend(calls);
            // The postamble follows the calls: it starts from the state the last part
            // left, so it says its motion code again (in file order the main program's
            // preamble, G80 included, stands between).
            walker.open();
            for l in suffix.split_inclusive(|&c| c == b'\n') {
                text.extend(walker.line(l.strip_suffix(b"\n").unwrap_or(l)));
            }
            text.extend_from_slice(b"%\n");
            out.push(Piece { number: 0, text });
        }
        _ => {
            for (k, mut text) in bodies.into_iter().enumerate() {
                if k + 1 == count {
                    text.extend(suffix.iter());
                }
                if text.len() > max_bytes {
                    return Err(PostError::Options(format!(
                        "internal: piece {} came to {} bytes, more than --max-bytes {max_bytes}",
                        k + 1,
                        text.len()
                    )));
                }
                out.push(Piece {
                    number: k + 1,
                    text,
                });
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn walk(before: &str, piece: &str) -> String {
        let mut w = Walker::default();
        for l in before.lines() {
            w.line(l.as_bytes());
        }
        w.open();
        let mut out = Vec::new();
        for l in piece.lines() {
            out.extend(w.line(l.as_bytes()));
        }
        String::from_utf8(out).expect("utf8")
    }

    #[test]
    fn a_piece_says_its_motion_and_feed_again() {
        let before =
            "N10 G21 G90 G94 G17 G40 G80\nN20 G0 Z5\nN30 G1 Z0 F508\nN40 X1 F381\nN50 G0 Z5\n";
        // The motion code after the N word, the axes the last piece left at the end of
        // the first move (X1: the machine is there), the feed at the end of the first
        // feed move.
        assert_eq!(
            walk(before, "N60 Z150 (UP)\nN70 X2\nN80 G1 Z0\nN90 X3\n"),
            "N60 G0 Z150 X1 (UP)\nN70 X2\nN80 G1 Z0 F381\nN90 X3\n"
        );
        // Blocks that say it themselves are left alone (but for the axes); so is a
        // piece with no N words.
        assert_eq!(
            walk(before, "G0 Z150\nG1 X2 F10\n"),
            "G0 Z150 X1\nG1 X2 F10\n"
        );
        assert_eq!(walk(before, "M72\nZ150\n"), "M72\nG0 Z150 X1\n");
        // A feed piece start (machining) gets its feed; G80 leaves nothing to repeat.
        assert_eq!(walk("G1 X0 F10.\n", "Y1\nX1\n"), "G1 Y1 X0 F10.\nX1\n");
        assert_eq!(walk("G0 X0\nG80\n", "Z1\n"), "Z1 X0\n");
        assert_eq!(walk("G0 X0 Y1 Z2 B30\n", "X5\n"), "G0 X5 Y1 Z2 B30\n");
    }

    #[test]
    fn the_preamble_is_the_head_line_with_the_units() {
        let head = b"(lampost post)\n(head laser)\nN10 G21 G90 G94 G17 G40 G80\n";
        assert_eq!(
            preamble(head).as_deref(),
            Some(&b"N10 G21 G90 G94 G17 G40 G80\n"[..])
        );
        assert_eq!(preamble(b"(no units)\nG90\n"), None);
    }
}
