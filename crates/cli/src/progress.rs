//! Progress on standard error while a long command works: a spinner with a count and a
//! rate, drawn only when standard error is a terminal and `-q` was not given (indicatif
//! draws nothing to a pipe or a file, so scripts and logs never see it), and cleared
//! when the work ends, before the summary line.

use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A spinner on standard error (or nothing).
#[derive(Debug)]
pub struct Progress(Option<ProgressBar>);

impl Progress {
    /// `what` with a count of `unit` (e.g. "posting", "moves"); ticks as [`Progress::set`]
    /// is called.
    pub fn counting(what: &str, unit: &'static str, quiet: bool) -> Self {
        Self::make(
            what,
            &format!("{{spinner}} {{msg}}: {{human_pos}} {unit} ({{elapsed}})"),
            quiet,
            false,
        )
    }

    /// `what` with the time elapsed, ticking on its own (work that reports no count).
    pub fn working(what: &str, quiet: bool) -> Self {
        Self::make(what, "{spinner} {msg} ({elapsed})", quiet, true)
    }

    fn make(what: &str, template: &str, quiet: bool, tick: bool) -> Self {
        if quiet {
            return Progress(None);
        }
        let target = ProgressDrawTarget::stderr();
        if target.is_hidden() {
            return Progress(None);
        }
        let bar = ProgressBar::with_draw_target(None, target);
        if let Ok(style) = ProgressStyle::with_template(template) {
            bar.set_style(style);
        }
        bar.set_message(what.to_string());
        if tick {
            bar.enable_steady_tick(Duration::from_millis(120));
        }
        Progress(Some(bar))
    }

    /// The count so far.
    pub fn set(&self, n: u64) {
        if let Some(b) = &self.0 {
            b.set_position(n);
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Some(b) = &self.0 {
            b.finish_and_clear();
        }
    }
}
