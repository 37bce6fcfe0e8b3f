//! Splitting a posted program into pieces that fit controller memory (paper 001's
//! problem): FADAL subprograms called from a main program, or numbered files for DNC.

use std::io::{Read, Seek, SeekFrom};

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
    let mut prefix = read_range(f, 0, b0)?;
    let mut suffix = read_range(f, b1, total)?;
    if dialect == PostDialect::Fadal {
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
    cuts.push(b1);
    let overhead = if dialect == PostDialect::Fadal { 32 } else { 0 };
    let mut pieces_ranges: Vec<(u64, u64)> = Vec::new();
    let mut start = b0;
    while start < b1 {
        let budget = max_bytes.saturating_sub(overhead) as u64
            - if pieces_ranges.is_empty() && dialect != PostDialect::Fadal {
                prefix.len() as u64
            } else {
                0
            }
            .min(max_bytes as u64);
        let mut best = None;
        for &c in &cuts {
            if c <= start {
                continue;
            }
            let extra = if c == b1 && dialect != PostDialect::Fadal {
                suffix.len() as u64
            } else {
                0
            };
            if c - start + extra <= budget {
                best = Some(c);
            } else {
                break;
            }
        }
        let Some(end) = best else {
            let next = cuts.iter().copied().find(|&c| c > start).unwrap_or(b1);
            return Err(PostError::Options(format!(
                "a stretch of {} bytes has no point where the head travels with the process off, more than --max-bytes {max_bytes}; raise the limit",
                next - start
            )));
        };
        pieces_ranges.push((start, end));
        start = end;
    }
    let mut out = Vec::new();
    match dialect {
        PostDialect::Fadal => {
            let mut text = b"%\n".to_vec();
            let mut calls = Vec::new();
            for (k, &(s, e)) in pieces_ranges.iter().enumerate() {
                let n = program_number + 1 + k as u32;
                text.extend_from_slice(
                    format!("O{n} (PART {} OF {})\n", k + 1, pieces_ranges.len()).as_bytes(),
                );
                text.extend(read_range(f, s, e)?);
                text.extend_from_slice(b"M99\n");
                calls.extend_from_slice(format!("M98 P{n}\n").as_bytes());
            }
            text.extend(prefix);
            text.extend(calls);
            text.extend(suffix);
            text.extend_from_slice(b"%\n");
            out.push(Piece { number: 0, text });
        }
        _ => {
            let last = pieces_ranges.len().saturating_sub(1);
            for (k, &(s, e)) in pieces_ranges.iter().enumerate() {
                let mut text = Vec::new();
                if k == 0 {
                    text.extend(prefix.iter());
                }
                text.extend(read_range(f, s, e)?);
                if k == last {
                    text.extend(suffix.iter());
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
