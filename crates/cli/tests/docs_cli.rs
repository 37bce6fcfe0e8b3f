//! `lampost completions` and `lampost man`: generated from the command line's one
//! definition, for every shell and every subcommand.

mod common;
use common::*;

/// Every subcommand users type, as the completion scripts and pages must know them.
const SUBCOMMANDS: [&str; 16] = [
    "post",
    "preview",
    "inspect",
    "mesh",
    "plan",
    "verify",
    "check",
    "fmt",
    "trace",
    "fit",
    "align",
    "calibrate",
    "probe",
    "kin",
    "machines",
    "completions",
];

#[test]
fn completions_for_every_shell_name_every_subcommand() {
    for shell in ["bash", "zsh", "fish", "powershell", "elvish"] {
        let out = lampost(&["completions", shell]);
        assert!(out.status.success(), "{shell}: {out:?}");
        let text = String::from_utf8_lossy(&out.stdout);
        for sub in SUBCOMMANDS {
            assert!(text.contains(sub), "{shell} completion lacks `{sub}`");
        }
        // Options of a nested subcommand are completed too.
        assert!(
            text.contains("--index"),
            "{shell} completion lacks post's --index"
        );
    }
    // The bash script is valid bash.
    let out = lampost(&["completions", "bash"]);
    let dir = tempdir("completions");
    let script = dir.join("lampost.bash");
    std::fs::write(&script, &out.stdout).expect("write");
    if let Ok(st) = std::process::Command::new("bash")
        .arg("-n")
        .arg(&script)
        .status()
    {
        assert!(st.success(), "bash -n rejects the completion script");
    }
}

#[test]
fn unknown_shell_is_refused() {
    let out = lampost(&["completions", "tcsh"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("possible values"));
}

#[test]
fn man_pages_cover_every_subcommand() {
    let dir = tempdir("man");
    let out_dir = dir.join("pages");
    let out = lampost(&["man", "--out-dir", out_dir.to_str().expect("utf-8 path")]);
    assert!(out.status.success(), "{out:?}");
    let page = |name: &str| {
        std::fs::read_to_string(out_dir.join(format!("{name}.1")))
            .unwrap_or_else(|e| panic!("{name}.1: {e}"))
    };
    let top = page("lampost");
    assert!(top.contains(".TH lampost 1"), "{top}");
    for sub in SUBCOMMANDS {
        let p = page(&format!("lampost-{sub}"));
        assert!(
            p.contains(&format!(".TH lampost-{sub} 1")),
            "lampost-{sub}.1"
        );
    }
    // Nested subcommands get their own pages, with their options.
    let plane = page("lampost-fit");
    assert!(plane.contains("radius"));
    let post = page("lampost-post");
    assert!(post.contains("index") && post.contains("machine"));
    assert!(page("lampost-probe-plane").contains(".TH lampost-probe-plane 1"));
    // No page for clap's own `help` subcommand, and no temporary files left.
    for e in std::fs::read_dir(&out_dir).expect("dir") {
        let name = e.expect("entry").file_name().to_string_lossy().into_owned();
        assert!(name.ends_with(".1") && !name.contains("-help"), "{name}");
    }
}

#[test]
fn man_into_an_unwritable_place_fails_cleanly() {
    let dir = tempdir("man-bad");
    let file = dir.join("a-file");
    std::fs::write(&file, "x").expect("write");
    let out = lampost(&[
        "man",
        "--out-dir",
        file.join("sub").to_str().expect("utf-8"),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cannot create") && err.contains("help:"),
        "{err}"
    );
}

/// After `post` and `verify`: one line on stderr saying what happened (moves, errors
/// with their units, time, where the output went), none with `--quiet`.
#[test]
fn post_and_verify_say_what_happened() {
    let job = root().join("fixtures/post/bearing-seat/job.toml");
    let job = job.to_str().expect("utf-8");
    let dir = tempdir("summary");
    let out = dir.join("seat.nc");
    let out_s = out.to_str().expect("utf-8");
    let o = lampost(&["post", "--machine", "fadal-lamp", "--job", job, "-o", out_s]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let line = err
        .lines()
        .find(|l| l.starts_with("posted "))
        .unwrap_or_else(|| panic!("no summary: {err}"));
    assert!(line.contains(" moves, ") && line.contains(out_s), "{line}");
    assert!(
        line.contains("max tip error") && line.contains(" in,"),
        "{line}"
    );
    assert!(
        line.contains("max axis error") && line.ends_with(" s"),
        "{line}"
    );
    let o = lampost(&["verify", "--machine", "fadal-lamp", "--job", job, out_s]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o)
            .lines()
            .any(|l| l.starts_with("verified ") && l.contains(out_s)),
        "{}",
        stderr(&o)
    );
    for cmd in [
        vec![
            "post",
            "--quiet",
            "--machine",
            "fadal-lamp",
            "--job",
            job,
            "-o",
            out_s,
        ],
        vec![
            "verify",
            "-q",
            "--machine",
            "fadal-lamp",
            "--job",
            job,
            out_s,
        ],
    ] {
        let o = lampost(&cmd);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).trim().is_empty(), "{cmd:?}: {}", stderr(&o));
    }
}
