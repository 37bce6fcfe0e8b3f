//! Splitting input into lines: from a byte slice, or streamed from a reader.
//!
//! A streamed line longer than [`crate::MAX_LINE_BYTES`] is not held: its first bytes are kept
//! (for the error's snippet), the rest is read past and only counted, so one line of any
//! length takes at most 64 KiB of memory. [`MAX_NUL_RUN`] NUL bytes in a row (binary
//! data, or a device such as `/dev/zero`) stop the reading with an error.

use std::io::{self, BufRead, BufReader, Read, Seek};

use crate::diag::{Diagnostic, ErrorKind, Severity};
use crate::parse::MAX_LINE_BYTES;

/// The most NUL bytes in a row a reader reads past: more is binary data, not a program
/// (and `/dev/zero` would never end), so reading stops with an error.
pub const MAX_NUL_RUN: usize = 64 * 1024;

/// One line of input: 1-based number, byte offset of its first byte, its bytes
/// without `\n` or `\r\n`.
#[derive(Debug, Clone, Copy)]
pub struct Line<'a> {
    /// 1-based line number.
    pub number: u32,
    /// Byte offset of the first byte in the input.
    pub offset: usize,
    /// The bytes, without the line ending (only the first bytes of a streamed line over
    /// [`crate::MAX_LINE_BYTES`]).
    pub bytes: &'a [u8],
    /// The whole line's length without its ending: more than `bytes.len()` for a
    /// streamed line over [`crate::MAX_LINE_BYTES`], whose rest was read past unheld.
    pub len: usize,
    /// The bytes as text, when the source has already found them to be UTF-8 (in-memory
    /// input, checked [`crate::CHECKED_CHUNK`] bytes at a time); `None` when it has not (the
    /// parser checks them: see [`crate::parse::parse_str_with`]).
    pub text: Option<&'a str>,
}

/// How many bytes of in-memory input [`Lines`] finds to be UTF-8 at a time (whole lines;
/// a longer line alone).
pub const CHECKED_CHUNK: usize = 64 * 1024;

impl Line<'_> {
    /// The error for a line over [`crate::MAX_LINE_BYTES`] (with its whole length), if it is
    /// one; such a line is refused unscanned.
    pub fn too_long(&self) -> Option<Diagnostic> {
        (self.len > MAX_LINE_BYTES).then(|| {
            Diagnostic::at(
                Severity::Error,
                ErrorKind::LineTooLong(self.len),
                self.number,
                self.offset,
                self.bytes,
                0,
                1,
            )
        })
    }
}

/// A line without its ending: a final `\n` and every `\r` before it (`\r\r\n`, as some
/// Windows tools write, is one line end; rs274 and grbl read it so). A `\r` inside a line
/// (a file whose line ends are bare CRs) stays, and the parser refuses it by name.
fn strip_eol(mut b: &[u8]) -> &[u8] {
    if let Some(rest) = b.strip_suffix(b"\n") {
        b = rest;
    }
    while let Some(rest) = b.strip_suffix(b"\r") {
        b = rest;
    }
    b
}

/// The UTF-8 byte-order mark some Windows editors put at the start of a file: skipped.
const BOM: &[u8] = b"\xef\xbb\xbf";

/// The lines of an in-memory input.
#[derive(Debug, Clone)]
pub struct Lines<'a> {
    input: &'a [u8],
    pos: usize,
    number: u32,
    /// The input from `checked_start` to `checked_end`, whole lines, checked for UTF-8
    /// in one go: the text when it is UTF-8 (`None`: its lines are left to the parser).
    checked: Option<&'a str>,
    checked_start: usize,
    checked_end: usize,
}

impl<'a> Lines<'a> {
    /// Lines of `input`.
    pub fn new(input: &'a [u8]) -> Self {
        Lines {
            input,
            pos: if input.starts_with(BOM) { BOM.len() } else { 0 },
            number: 0,
            checked: None,
            checked_start: 0,
            checked_end: 0,
        }
    }

    /// The text of the line at `start..end` (its ending excluded), checking the next
    /// whole lines of up to [`crate::CHECKED_CHUNK`] bytes from `start` (a line that starts a
    /// chunk) once its line is past the last checked.
    fn text(&mut self, start: usize, end: usize) -> Option<&'a str> {
        if end - start > MAX_LINE_BYTES {
            // Refused unread.
            return None;
        }
        if end > self.checked_end || start < self.checked_start {
            let limit = start.saturating_add(CHECKED_CHUNK).min(self.input.len());
            let chunk_end = if limit == self.input.len() {
                limit
            } else {
                memchr::memrchr(b'\n', &self.input[start..limit]).map_or(end, |i| start + i + 1)
            }
            .max(end);
            self.checked = std::str::from_utf8(&self.input[start..chunk_end]).ok();
            self.checked_start = start;
            self.checked_end = chunk_end;
        }
        self.checked?
            .get(start - self.checked_start..end - self.checked_start)
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = Line<'a>;

    fn next(&mut self) -> Option<Line<'a>> {
        if self.pos >= self.input.len() {
            return None;
        }
        let rest = &self.input[self.pos..];
        let len = memchr::memchr(b'\n', rest).map_or(rest.len(), |i| i + 1);
        let offset = self.pos;
        self.pos += len;
        self.number = self.number.saturating_add(1);
        let bytes = strip_eol(&rest[..len]);
        let text = self.text(offset, offset + bytes.len());
        Some(Line {
            number: self.number,
            offset,
            bytes,
            len: bytes.len(),
            text,
        })
    }
}

/// Lines read one at a time from a reader into one reused buffer, so memory stays
/// flat however long the program is: a line over [`crate::MAX_LINE_BYTES`] is read past, only
/// its first bytes held (see the module documentation).
#[derive(Debug)]
pub struct LineReader<R> {
    reader: R,
    buf: Vec<u8>,
    /// Offset just past the last line read.
    pos: usize,
    /// Offset and whole length (without ending) of the last line read.
    start: usize,
    len: usize,
    number: u32,
}

/// The most bytes of one line held: a line of [`crate::MAX_LINE_BYTES`] with `\r\n`.
const KEEP: usize = MAX_LINE_BYTES + 2;

impl<R: BufRead> LineReader<R> {
    /// Read lines from `reader`.
    pub fn new(reader: R) -> Self {
        LineReader {
            reader,
            buf: Vec::with_capacity(256),
            pos: 0,
            start: 0,
            len: 0,
            number: 0,
        }
    }

    /// The next line, or `None` at the end of input.
    pub fn next_line(&mut self) -> io::Result<Option<Line<'_>>> {
        Ok(self.next_line_end()?.map(|(line, _)| line))
    }

    /// The next line and the offset just past it (its line ending included).
    pub(crate) fn next_line_end(&mut self) -> io::Result<Option<(Line<'_>, usize)>> {
        self.buf.clear();
        // Bytes of the line read (ending included), whether it ended in `\n`, the byte
        // before the last one read, and the NUL bytes in a row at the end.
        let mut total = 0usize;
        let mut newline = false;
        let mut prev = 0u8;
        let mut last = 0u8;
        let mut nul_run = 0usize;
        let mut skipping = false;
        loop {
            let avail = match self.reader.fill_buf() {
                Ok(a) => a,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if avail.is_empty() {
                break;
            }
            let (take, done) =
                memchr::memchr(b'\n', avail).map_or((avail.len(), false), |i| (i + 1, true));
            let chunk = &avail[..take];
            if total + take <= KEEP {
                self.buf.extend_from_slice(chunk);
            } else {
                // Over the limit: hold the first bytes only, count the rest.
                if !skipping {
                    skipping = true;
                    nul_run = self.buf.iter().rev().take_while(|&&c| c == 0).count();
                }
                let room = KEEP.saturating_sub(self.buf.len());
                self.buf.extend_from_slice(&chunk[..room.min(take)]);
                nul_run = match chunk.iter().rposition(|&c| c != 0) {
                    Some(i) => take - 1 - i,
                    None => nul_run.saturating_add(take),
                };
                if nul_run >= MAX_NUL_RUN {
                    return Err(io::Error::new(
                        io::ErrorKind::InvalidData,
                        format!(
                            "line {}: {MAX_NUL_RUN} NUL bytes in a row (byte {} on): binary data, not a program; reading stopped",
                            self.number.saturating_add(1),
                            (self.pos + total + take).saturating_sub(nul_run),
                        ),
                    ));
                }
            }
            if take >= 2 {
                prev = chunk[take - 2];
            } else {
                prev = last;
            }
            last = chunk[take - 1];
            self.reader.consume(take);
            total += take;
            if done {
                newline = true;
                break;
            }
        }
        if total == 0 {
            return Ok(None);
        }
        // As `strip_eol`: a final `\n`, then a `\r` before it (and any more `\r`s the
        // held bytes show before that).
        let mut len = total;
        let mut cr = last;
        if newline {
            len -= 1;
            cr = prev;
        }
        if len > 0 && cr == b'\r' {
            len -= 1;
            while len > 0 && len <= self.buf.len() && self.buf[len - 1] == b'\r' {
                len -= 1;
            }
        }
        // A byte-order mark at the start of the input is skipped.
        let bom = if self.pos == 0 && len >= BOM.len() && self.buf.starts_with(BOM) {
            self.buf.drain(..BOM.len());
            BOM.len()
        } else {
            0
        };
        self.start = self.pos + bom;
        let len = len - bom;
        self.len = len;
        self.pos += total;
        self.number = self.number.saturating_add(1);
        Ok(Some((self.line(), self.pos)))
    }

    fn line(&self) -> Line<'_> {
        let held = self.len.min(self.buf.len()).min(MAX_LINE_BYTES + 1);
        Line {
            number: self.number,
            offset: self.start,
            bytes: &self.buf[..held],
            len: self.len,
            text: None,
        }
    }

    /// Bytes read so far.
    pub fn bytes_read(&self) -> usize {
        self.pos
    }

    /// The line the last [`LineReader::next_line`] handed out again (empty after a seek).
    pub(crate) fn last_line(&self) -> Line<'_> {
        self.line()
    }
}

impl<R: Read + Seek> LineReader<BufReader<R>> {
    /// Go on reading at byte `offset`, whose line is numbered `number`. A jump that
    /// lands inside the buffer reuses it (a short subprogram called many times is not
    /// read from the source again each time).
    pub(crate) fn seek_line(&mut self, offset: usize, number: u32) -> io::Result<()> {
        let delta = i64::try_from(offset as i128 - self.pos as i128)
            .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "seek out of range"))?;
        self.reader.seek_relative(delta)?;
        self.buf.clear();
        self.pos = offset;
        self.start = offset;
        self.len = 0;
        self.number = number.saturating_sub(1);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_splitters_agree() {
        let text = b"G0 X1\r\nG1 Y2\n\nM30";
        let a: Vec<_> = Lines::new(text)
            .map(|l| (l.number, l.offset, l.bytes.to_vec()))
            .collect();
        let mut r = LineReader::new(&text[..]);
        let mut b = Vec::new();
        while let Some(l) = r.next_line().expect("reads") {
            b.push((l.number, l.offset, l.bytes.to_vec()));
        }
        assert_eq!(a, b);
        assert_eq!(a.len(), 4);
        assert_eq!(a[1], (2, 7, b"G1 Y2".to_vec()));
    }

    /// A byte-order mark at the start is skipped and `\r\r\n` is one line end, the
    /// same way by both splitters at every buffer size; a bare `\r` inside a line stays.
    #[test]
    fn byte_order_marks_and_doubled_carriage_returns() {
        let text = b"\xef\xbb\xbfG21\r\r\nG0 X1\r\r\r\n\r\nX2\rY3\n\xef\xbb\xbfM2";
        let a: Vec<_> = Lines::new(text)
            .map(|l| (l.number, l.offset, l.len, l.bytes.to_vec()))
            .collect();
        assert_eq!(
            a,
            vec![
                (1, 3, 3, b"G21".to_vec()),
                (2, 9, 5, b"G0 X1".to_vec()),
                (3, 18, 0, Vec::new()),
                (4, 20, 5, b"X2\rY3".to_vec()),
                // Only at the start of the input.
                (5, 26, 5, b"\xef\xbb\xbfM2".to_vec()),
            ]
        );
        for cap in [1, 2, 3, 5, 64] {
            assert_eq!(streamed(text, cap), a, "buffer of {cap}");
        }
        assert_eq!(Lines::new(b"\xef\xbb\xbf").count(), 0);
    }

    /// Every line of `text` read through a reader of `cap` bytes at a time.
    fn streamed(text: &[u8], cap: usize) -> Vec<(u32, usize, usize, Vec<u8>)> {
        let mut r = LineReader::new(BufReader::with_capacity(cap, text));
        let mut v = Vec::new();
        while let Some(l) = r.next_line().expect("reads") {
            v.push((l.number, l.offset, l.len, l.bytes.to_vec()));
        }
        assert!(r.buf.capacity() <= 2 * KEEP, "one line held at most");
        v
    }

    #[test]
    fn a_line_over_the_limit_is_counted_not_held() {
        for (cap, eol) in [
            (7, &b"\r\n"[..]),
            (4096, b"\n"),
            (1 << 16, b"\r\n"),
            (3, b""),
        ] {
            let long = MAX_LINE_BYTES * 3 + 5;
            let mut text = b"G0 X1\n".to_vec();
            text.extend(std::iter::repeat_n(b'X', long));
            text.extend_from_slice(b"\r\nG1 Y2\n");
            text.extend(std::iter::repeat_n(b'Y', MAX_LINE_BYTES));
            text.extend_from_slice(eol);
            let v = streamed(&text, cap);
            assert_eq!(v.len(), 4);
            assert_eq!((v[1].0, v[1].1, v[1].2), (2, 6, long));
            assert_eq!(v[1].3.len(), MAX_LINE_BYTES + 1);
            assert_eq!((v[2].0, v[2].1, v[2].2), (3, 6 + long + 2, 5));
            assert_eq!(v[2].3, b"G1 Y2");
            assert_eq!((v[3].2, v[3].3.len()), (MAX_LINE_BYTES, MAX_LINE_BYTES));
            let mut r = LineReader::new(BufReader::with_capacity(cap, &text[..]));
            let _ = r.next_line();
            let l = r.next_line().expect("reads").expect("a line");
            let d = l.too_long().expect("refused");
            assert_eq!(d.kind, ErrorKind::LineTooLong(long));
            assert_eq!((d.line, d.column), (2, 1));
        }
        // The in-memory splitter gives the same lengths.
        let text = b"ab\r\n\r\nc";
        let a: Vec<_> = Lines::new(text)
            .map(|l| (l.number, l.offset, l.len))
            .collect();
        let b: Vec<_> = streamed(text, 1)
            .into_iter()
            .map(|l| (l.0, l.1, l.2))
            .collect();
        assert_eq!(a, b);
    }

    #[test]
    fn a_run_of_nul_bytes_stops_reading() {
        // Under the run limit: an over-long line like any other.
        let mut text = b"G0 X1\n".to_vec();
        text.extend(std::iter::repeat_n(0u8, MAX_NUL_RUN - 1));
        text.extend_from_slice(b"X\nG1 Y2\n");
        assert_eq!(streamed(&text, 4096).len(), 3);
        // A run of the limit, part of it held and part read past: an error, the line
        // and the byte where the run begins named.
        for cap in [1, 100, 1 << 16] {
            let mut text = b"G0 X1\nG1 ".to_vec();
            text.extend(std::iter::repeat_n(0u8, MAX_NUL_RUN + 10));
            let mut r = LineReader::new(BufReader::with_capacity(cap, &text[..]));
            assert!(r.next_line().expect("line 1").is_some());
            let e = r.next_line().expect_err("binary");
            assert_eq!(e.kind(), io::ErrorKind::InvalidData);
            let m = e.to_string();
            assert!(
                m.starts_with("line 2: 65536 NUL bytes in a row (byte 9 on)"),
                "{m}"
            );
        }
        // An endless source stops after the run limit.
        let mut r = LineReader::new(BufReader::new(io::repeat(0)));
        assert!(r.next_line().is_err());
    }

    proptest::proptest! {
        #[test]
        fn checked_text_is_the_lines_text(
            lines in proptest::collection::vec(
                (0usize..90_000, proptest::prop_oneof![
                    proptest::strategy::Just(b"G1 X1\n".to_vec()),
                    proptest::strategy::Just("(é)\r\n".as_bytes().to_vec()),
                    proptest::strategy::Just(b"\xff\n".to_vec()),
                    proptest::strategy::Just(b"\n".to_vec()),
                    proptest::strategy::Just(b"".to_vec()),
                ]),
                0..12,
            ),
        ) {
            let mut input = Vec::new();
            for (pad, end) in &lines {
                input.extend(std::iter::repeat_n(b'X', *pad));
                input.extend_from_slice(end);
            }
            let valid = std::str::from_utf8(&input).is_ok();
            for l in Lines::new(&input) {
                let own = std::str::from_utf8(l.bytes).ok();
                match l.text {
                    Some(t) => proptest::prop_assert_eq!(Some(t), own),
                    // Lines of a chunk with an invalid byte are left to the parser, as
                    // are lines too long to read.
                    None => proptest::prop_assert!(!valid || l.bytes.len() > MAX_LINE_BYTES),
                }
            }
        }
    }
}
