//! The POSTED argument of `lampost verify`: one file, or the DNC pieces of a split
//! program given in order, read in execution order (FADAL subprograms followed); and
//! the places of verification errors put back into those files.

use std::io::{BufRead, BufReader};

use lampost_gcode::{Order, ProgramReader};
use lampost_post::PostError;

use crate::io::{display_name, open_seekable, Concat, ReadSeek};
use crate::report::CliError;

/// The posted program as one text in execution order: a single file (standard input
/// with `-`) or several files read one after another.
pub fn open(posted: &[String]) -> Result<ProgramReader<Box<dyn ReadSeek>>, CliError> {
    let src: Box<dyn ReadSeek> = match posted {
        [one] => open_seekable(one)?,
        many if many.iter().any(|p| p == "-") => {
            return Err(CliError::usage(
                "error: standard input (-) can only be the one POSTED file\n".to_string(),
            ))
        }
        many => {
            pieces_in_order(many)?;
            Box::new(Concat::open(many)?)
        }
    };
    Ok(ProgramReader::new(src, Order::Execution))
}

/// Whether `path` holds a program end (M2/M30), and on which line.
fn program_end(path: &str) -> Result<Option<u32>, CliError> {
    let f = std::fs::File::open(path)
        .map_err(|e| CliError::usage(format!("error: cannot open {path}: {e}\n")))?;
    let mut lines = lampost_gcode::LineReader::new(BufReader::new(f));
    while let Some(l) = lines
        .next_line()
        .map_err(|e| CliError::usage(format!("error: cannot read {path}: {e}\n")))?
    {
        if !l.bytes.iter().any(|&c| c | 0x20 == b'm') {
            continue;
        }
        if let Ok(b) = lampost_gcode::parse_line(l.bytes, l.number, l.offset) {
            if b.words()
                .any(|w| w.letter == b'M' && matches!(w.code(), Some(20 | 300)))
            {
                return Ok(Some(l.number));
            }
        }
    }
    Ok(None)
}

/// DNC pieces: only the last ends the program. (A piece left out or out of place that
/// holds no feed move would not show in the path; this shows it at the end.)
fn pieces_in_order(posted: &[String]) -> Result<(), CliError> {
    let last = posted.len() - 1;
    for (k, p) in posted.iter().enumerate() {
        match (program_end(p)?, k == last) {
            (Some(line), false) => {
                return Err(CliError::failed(format!(
                    "error: verification failed: {p}:{line}: the program ends in POSTED file {} of {}\n  = help: give the pieces in order, all of them\n",
                    k + 1,
                    posted.len()
                )))
            }
            (None, true) => {
                return Err(CliError::failed(format!(
                    "error: verification failed: the last POSTED file {p} does not end the program (no M2 or M30)\n  = help: give the pieces in order, all of them\n"
                )))
            }
            _ => {}
        }
    }
    Ok(())
}

/// Line `n` of the text as run: its line number in the files read one after another.
fn as_run(posted: &[String], n: u32) -> Option<u32> {
    let mut r = open(posted).ok()?;
    let mut k = 0u32;
    while let Some(l) = r.next_line().ok()? {
        k += 1;
        if k == n {
            return Some(l.number);
        }
    }
    None
}

/// Line `line` of the files read one after another: which file, which line of it.
fn place(posted: &[String], line: u32) -> Option<(String, u32)> {
    if let [one] = posted {
        return Some((display_name(one), line));
    }
    let mut before = 0u32;
    for p in posted {
        let mut r = BufReader::new(std::fs::File::open(p).ok()?);
        let mut count = 0u32;
        let mut buf = Vec::new();
        loop {
            buf.clear();
            if r.read_until(b'\n', &mut buf).ok()? == 0 {
                break;
            }
            count += 1;
        }
        if line <= before + count {
            return Some((p.clone(), line - before));
        }
        before += count;
    }
    None
}

/// The number after `key` in `msg`, and where it ends.
fn number_after(msg: &str, key: &str) -> Option<(usize, usize, u32)> {
    let at = msg.find(key)? + key.len();
    let len = msg[at..].bytes().take_while(u8::is_ascii_digit).count();
    Some((at, at + len, msg[at..at + len].parse().ok()?))
}

/// `e` with the posted lines it names (counted in the text as run) put back into the
/// files. A single file without subprograms is left as it is.
pub fn locate(posted: &[String], e: PostError) -> PostError {
    let several = posted.len() > 1;
    // Execution-order line `n` → (file, line), when that says more than `n`.
    let from_run = |n: u32| {
        let (file, line) = place(posted, as_run(posted, n)?)?;
        (several || line != n).then_some((file, line))
    };
    // "posted line N" of the joined program, as the piece's own line.
    let located = |msg: &str| {
        number_after(msg, "posted line ")
            .and_then(|(a, b, n)| Some((a, b, from_run(n)?)))
            .map(|(a, b, (f, line))| format!("{}{line} of {f}{}", &msg[..a], &msg[b..]))
    };
    match e {
        PostError::Input { file, mut diag } => match from_run(diag.line) {
            Some((f, line)) => {
                diag.line = line;
                PostError::Input { file: f, diag }
            }
            None => PostError::Input { file, diag },
        },
        PostError::Verify(msg) => match located(&msg) {
            Some(msg) => PostError::Verify(msg),
            None => PostError::Verify(msg),
        },
        PostError::Collision(msg) => match located(&msg) {
            Some(msg) => PostError::Collision(msg),
            None => PostError::Collision(msg),
        },
        // A call the reader could not follow: read again to the problem, and show it
        // as any error of the posted program is shown.
        PostError::Io(msg) => match call_problem(posted) {
            Some(mut diag) => {
                let (file, line) = place(posted, diag.line)
                    .unwrap_or_else(|| ("the posted program".into(), diag.line));
                diag.line = line;
                PostError::Input {
                    file,
                    diag: Box::new(diag),
                }
            }
            None => PostError::Io(msg),
        },
        e => e,
    }
}

/// The first error the reader finds with the calls of the posted program.
fn call_problem(posted: &[String]) -> Option<lampost_gcode::Diagnostic> {
    let mut r = open(posted).ok()?;
    loop {
        if let Some(d) = std::iter::from_fn(|| r.take_diagnostic()).find(|d| d.is_error()) {
            return Some(d);
        }
        r.next_line().ok()??;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_found_after_their_key() {
        assert_eq!(
            number_after("posted line 812: off", "posted line "),
            Some((12, 15, 812))
        );
        assert_eq!(number_after("posted line x", "posted line "), None);
    }
}
