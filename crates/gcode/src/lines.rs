//! Splitting input into lines: from a byte slice, or streamed from a reader.

use std::io::{self, BufRead, BufReader, Read, Seek};

/// One line of input: 1-based number, byte offset of its first byte, its bytes
/// without `\n` or `\r\n`.
#[derive(Debug, Clone, Copy)]
pub struct Line<'a> {
    /// 1-based line number.
    pub number: u32,
    /// Byte offset of the first byte in the input.
    pub offset: usize,
    /// The bytes, without the line ending.
    pub bytes: &'a [u8],
}

fn strip_eol(mut b: &[u8]) -> &[u8] {
    if let Some(rest) = b.strip_suffix(b"\n") {
        b = rest;
    }
    if let Some(rest) = b.strip_suffix(b"\r") {
        b = rest;
    }
    b
}

/// The lines of an in-memory input.
#[derive(Debug, Clone)]
pub struct Lines<'a> {
    input: &'a [u8],
    pos: usize,
    number: u32,
}

impl<'a> Lines<'a> {
    /// Lines of `input`.
    pub fn new(input: &'a [u8]) -> Self {
        Lines {
            input,
            pos: 0,
            number: 0,
        }
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
        Some(Line {
            number: self.number,
            offset,
            bytes: strip_eol(&rest[..len]),
        })
    }
}

/// Lines read one at a time from a reader into one reused buffer, so memory stays
/// flat however long the program is.
#[derive(Debug)]
pub struct LineReader<R> {
    reader: R,
    buf: Vec<u8>,
    pos: usize,
    number: u32,
}

impl<R: BufRead> LineReader<R> {
    /// Read lines from `reader`.
    pub fn new(reader: R) -> Self {
        LineReader {
            reader,
            buf: Vec::with_capacity(256),
            pos: 0,
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
        let n = self.reader.read_until(b'\n', &mut self.buf)?;
        if n == 0 {
            return Ok(None);
        }
        let offset = self.pos;
        self.pos += n;
        self.number = self.number.saturating_add(1);
        Ok(Some((
            Line {
                number: self.number,
                offset,
                bytes: strip_eol(&self.buf),
            },
            self.pos,
        )))
    }

    /// Bytes read so far.
    pub fn bytes_read(&self) -> usize {
        self.pos
    }

    /// The line the last [`LineReader::next_line`] handed out again (empty after a seek).
    pub(crate) fn last_line(&self) -> Line<'_> {
        Line {
            number: self.number,
            offset: self.pos - self.buf.len(),
            bytes: strip_eol(&self.buf),
        }
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
}
