//! `lampost completions` and `lampost man`: shell completions and manual pages, both
//! generated from the one clap definition of the command line, so they cannot drift
//! from it.

use std::io::Write;
use std::path::Path;

use clap::CommandFactory;

use crate::io::TempFile;
use crate::report::CliError;
use crate::{Cli, ShellArg};

/// The completion script for `shell` on standard output.
pub fn completions(shell: ShellArg) -> Result<(), CliError> {
    use clap_complete::Shell;
    let shell = match shell {
        ShellArg::Bash => Shell::Bash,
        ShellArg::Zsh => Shell::Zsh,
        ShellArg::Fish => Shell::Fish,
        ShellArg::Powershell => Shell::PowerShell,
        ShellArg::Elvish => Shell::Elvish,
    };
    let mut cmd = Cli::command();
    let mut text = Vec::new();
    clap_complete::generate(shell, &mut cmd, "lampost", &mut text);
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    out.write_all(&text)
        .and_then(|()| out.flush())
        .map_err(|e| CliError::write(&e))
}

/// The pages of `cmd` and of every subcommand under it, as (file name, roff).
fn pages(
    cmd: &clap::Command,
    prefix: &str,
    out: &mut Vec<(String, Vec<u8>)>,
) -> Result<(), CliError> {
    let name = if prefix.is_empty() {
        cmd.get_name().to_string()
    } else {
        format!("{prefix}-{}", cmd.get_name())
    };
    // A subcommand's page is titled with its full name (`lampost-fit-plane`).
    let titled = cmd.clone().name(name.clone());
    let mut roff = Vec::new();
    clap_mangen::Man::new(titled)
        .render(&mut roff)
        .map_err(|e| {
            CliError::failed(format!("error: cannot render the manual page {name}: {e}"))
        })?;
    out.push((format!("{name}.1"), roff));
    for sub in cmd
        .get_subcommands()
        .filter(|s| !s.is_hide_set() && s.get_name() != "help")
    {
        pages(sub, &name, out)?;
    }
    Ok(())
}

/// Write `lampost.1` and a page per subcommand into `dir`; each file is written whole
/// (a temporary file renamed into place) or not at all.
pub fn man(dir: &str) -> Result<(), CliError> {
    let mut cmd = Cli::command();
    cmd.build();
    let mut all = Vec::new();
    pages(&cmd, "", &mut all)?;
    std::fs::create_dir_all(dir).map_err(|e| {
        CliError::usage(format!(
            "error: cannot create {dir}: {e}\n  = help: give a writable folder with --out-dir"
        ))
    })?;
    for (file, roff) in &all {
        let target = Path::new(dir).join(file);
        let target_text = target.to_string_lossy().into_owned();
        let (temp, mut f) = TempFile::beside(Some(&target_text))?;
        f.write_all(roff)
            .and_then(|()| f.sync_all())
            .map_err(|e| CliError::usage(format!("error: cannot write {target_text}: {e}")))?;
        temp.persist(&target)?;
    }
    eprintln!("lampost man: {} pages written to {dir}", all.len());
    Ok(())
}
