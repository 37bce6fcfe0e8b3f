//! Input from a file or stdin, output to stdout or a file written atomically.

use std::fs::{self, File};
use std::io::{self, BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::report::CliError;

/// Open `path` (`-` is stdin) for buffered reading.
pub fn open_input(path: &str) -> Result<Box<dyn BufRead>, CliError> {
    if path == "-" {
        return Ok(Box::new(BufReader::with_capacity(1 << 16, io::stdin())));
    }
    let f = File::open(path).map_err(|e| {
        CliError::usage(format!(
            "error: cannot open {path}: {e}\n  = help: check the path; use - to read standard input"
        ))
    })?;
    Ok(Box::new(BufReader::with_capacity(1 << 16, f)))
}

/// The name used for `path` in messages.
pub fn display_name(path: &str) -> String {
    if path == "-" {
        "<stdin>".to_string()
    } else {
        path.to_string()
    }
}

/// Where output goes: stdout, or a temporary file beside the target that is renamed
/// over it only on [`Output::commit`]; dropped uncommitted, the temporary file is
/// removed, so a failed run never leaves a half-written file.
pub struct Output {
    writer: Option<BufWriter<Box<dyn Write>>>,
    temp: Option<PathBuf>,
    target: Option<PathBuf>,
}

impl std::fmt::Debug for Output {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Output")
            .field("target", &self.target)
            .finish()
    }
}

impl Output {
    /// Output to `path`, or stdout for `None` or `-`.
    pub fn create(path: Option<&str>) -> Result<Self, CliError> {
        match path {
            None | Some("-") => Ok(Output {
                writer: Some(BufWriter::with_capacity(
                    1 << 16,
                    Box::new(io::stdout().lock()),
                )),
                temp: None,
                target: None,
            }),
            Some(p) => {
                let target = PathBuf::from(p);
                let dir = target
                    .parent()
                    .filter(|d| !d.as_os_str().is_empty())
                    .unwrap_or(Path::new("."));
                let name = target
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "out".into());
                let temp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
                let f = File::create(&temp).map_err(|e| {
                    CliError::usage(format!(
                        "error: cannot write {}: {e}\n  = help: check that the folder exists and is writable",
                        temp.display()
                    ))
                })?;
                Ok(Output {
                    writer: Some(BufWriter::with_capacity(1 << 16, Box::new(f))),
                    temp: Some(temp),
                    target: Some(target),
                })
            }
        }
    }

    /// The writer.
    pub fn writer(&mut self) -> &mut dyn Write {
        match self.writer.as_mut() {
            Some(w) => w,
            None => unreachable_writer(),
        }
    }

    /// Flush and, for a file, rename the temporary file over the target.
    pub fn commit(mut self) -> Result<(), CliError> {
        if let Some(mut w) = self.writer.take() {
            w.flush().map_err(|e| CliError::write(&e))?;
        }
        if let (Some(temp), Some(target)) = (self.temp.take(), self.target.take()) {
            fs::rename(&temp, &target).map_err(|e| {
                let _ = fs::remove_file(&temp);
                CliError::usage(format!("error: cannot write {}: {e}", target.display()))
            })?;
        }
        Ok(())
    }
}

fn unreachable_writer() -> &'static mut dyn Write {
    // After commit the writer is gone; writes then go nowhere.
    Box::leak(Box::new(io::sink()))
}

impl Drop for Output {
    fn drop(&mut self) {
        self.writer.take();
        if let Some(temp) = self.temp.take() {
            let _ = fs::remove_file(temp);
        }
    }
}
