//! `docs/guide.md` run as a test: every `console` block's `$ …` commands run in order, in
//! one fresh directory holding a link to the project's `fixtures/`, with the `lampost`
//! under test first on PATH; each must exit 0 and print what the guide shows after it
//! (standard output, then standard error). In the expected text `[..]` matches any text
//! within a line and a line `...` any number of lines.

mod common;

use common::*;

/// One command of the guide and what it must print.
struct Step {
    line: usize,
    command: String,
    expected: Vec<String>,
}

/// The `$ ` commands of the guide's `console` blocks, each with the lines after it.
fn steps(text: &str) -> Vec<Step> {
    let mut out: Vec<Step> = Vec::new();
    let mut in_console = false;
    for (i, line) in text.lines().enumerate() {
        if let Some(info) = line.strip_prefix("```") {
            in_console = !in_console && info.trim() == "console";
            continue;
        }
        if !in_console {
            continue;
        }
        if let Some(cmd) = line.strip_prefix("$ ") {
            out.push(Step {
                line: i + 1,
                command: cmd.to_string(),
                expected: Vec::new(),
            });
        } else if let Some(s) = out.last_mut() {
            s.expected.push(line.to_string());
        }
    }
    out
}

/// `pattern` with `[..]` wildcards matches the whole of `line`.
fn line_matches(pattern: &str, line: &str) -> bool {
    let parts: Vec<&str> = pattern.split("[..]").collect();
    if parts.len() == 1 {
        return pattern == line;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !line.starts_with(first) || !line[first.len()..].ends_with(last) {
        return false;
    }
    let mut rest = &line[first.len()..line.len() - last.len()];
    for p in &parts[1..parts.len() - 1] {
        match rest.find(p) {
            Some(at) => rest = &rest[at + p.len()..],
            None => return false,
        }
    }
    true
}

/// The expected lines (with `...`) match all of the actual ones.
fn lines_match(expected: &[String], actual: &[&str]) -> bool {
    match expected.split_first() {
        None => actual.is_empty(),
        Some((e, rest)) if e == "..." => {
            (0..=actual.len()).any(|k| lines_match(rest, &actual[k..]))
        }
        Some((e, rest)) => {
            !actual.is_empty() && line_matches(e, actual[0]) && lines_match(rest, &actual[1..])
        }
    }
}

#[test]
fn the_guide_runs_as_written() {
    let guide = root().join("docs/guide.md");
    let text = std::fs::read_to_string(&guide).expect("docs/guide.md");
    let steps = steps(&text);
    assert!(steps.len() >= 15, "the guide's commands were not found");
    let dir = tempdir("guide");
    let link = dir.join("fixtures");
    if !link.exists() {
        std::os::unix::fs::symlink(root().join("fixtures"), &link).expect("link fixtures");
    }
    let bin = std::path::Path::new(env!("CARGO_BIN_EXE_lampost"))
        .parent()
        .expect("bin dir")
        .to_path_buf();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    for s in &steps {
        let o = std::process::Command::new("sh")
            .arg("-c")
            .arg(&s.command)
            .current_dir(&dir)
            .env("PATH", &path)
            .stdin(std::process::Stdio::null())
            .output()
            .expect("run sh");
        let actual = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        let lines: Vec<&str> = actual.lines().collect();
        assert!(
            o.status.success(),
            "docs/guide.md:{}: `{}` failed ({}):\n{actual}",
            s.line,
            s.command,
            o.status
        );
        assert!(
            lines_match(&s.expected, &lines),
            "docs/guide.md:{}: `{}` printed\n{actual}\nbut the guide shows\n{}",
            s.line,
            s.command,
            s.expected.join("\n")
        );
    }
}

#[test]
fn the_matcher_can_fail() {
    let e = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert!(lines_match(&e(&["a [..] c", "..."]), &["a b c", "d"]));
    assert!(!lines_match(&e(&["a [..] c"]), &["a b d"]));
    assert!(!lines_match(&e(&["a"]), &["a", "b"]));
    assert!(lines_match(&e(&["...", "z"]), &["x", "y", "z"]));
    assert!(!lines_match(&e(&["...", "z"]), &["x", "y"]));
    assert!(!line_matches("[..]x[..]", "abc"));
}
