//! Rendering diagnostics for people and for scripts.

use std::fmt::Write as _;

use lampost_gcode::{Diagnostic, Severity};

use crate::json::{obj, Obj};

/// A diagnostic as people read it: message, `file:line:col`, the line, a caret, a hint.
pub fn render(file: &str, d: &Diagnostic) -> String {
    let mut s = String::new();
    let sev = match d.severity {
        Severity::Error => "error",
        Severity::Warning => "warning",
    };
    let _ = writeln!(s, "{sev}: {}", d.kind);
    if d.line == 0 {
        let _ = writeln!(s, "  --> {file}");
    } else if d.column == 0 && d.snippet.text.is_empty() {
        // A line without its text (a cycle's moves, counted after the line was read).
        let _ = writeln!(s, "  --> {file}:{}", d.line);
    } else {
        let num = d.line.to_string();
        let pad = " ".repeat(num.len());
        let _ = writeln!(s, "{pad}--> {file}:{}:{}", d.line, d.column);
        let _ = writeln!(s, "{pad} |");
        let _ = writeln!(s, "{num} | {}", d.snippet.text);
        let _ = writeln!(
            s,
            "{pad} | {}{}",
            " ".repeat(d.snippet.caret),
            "^".repeat(d.snippet.width.max(1))
        );
    }
    let _ = writeln!(s, "  = help: {}", d.hint());
    s
}

/// A diagnostic as JSON (written through [`crate::json`]).
pub fn json(file: &str, d: &Diagnostic) -> Obj {
    obj! {
        "file": file,
        "severity": d.severity,
        "line": d.line,
        "column": d.column,
        "message": d.kind.to_string(),
        "hint": d.hint(),
        "text": d.snippet.text,
        "span": [d.span.start, d.span.end],
    }
}

/// A CLI-level error: what went wrong, where, and what to do.
#[derive(Debug)]
pub struct CliError {
    /// The message, already rendered.
    pub message: String,
    /// Exit code.
    pub code: i32,
}

/// Exit code marker for a closed output pipe: exit quietly.
pub const QUIET_EXIT: i32 = -1;

impl CliError {
    /// A write error: quiet for a closed pipe, else exit code 2.
    pub fn write(e: &std::io::Error) -> Self {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            CliError {
                message: String::new(),
                code: QUIET_EXIT,
            }
        } else if e.kind() == std::io::ErrorKind::StorageFull {
            CliError::usage(format!("error: cannot write output: {e}\n  = help: free some space where the output goes (its temporary file is removed, and an older output at its path is left as it was)\n"))
        } else {
            CliError::usage(format!("error: cannot write output: {e}"))
        }
    }

    /// An error with exit code 2 (bad usage or I/O).
    pub fn usage(message: impl Into<String>) -> Self {
        CliError {
            message: message.into(),
            code: 2,
        }
    }
    /// An error with exit code 1 (the input has errors; already reported).
    pub fn failed(message: impl Into<String>) -> Self {
        CliError {
            message: message.into(),
            code: 1,
        }
    }
}
