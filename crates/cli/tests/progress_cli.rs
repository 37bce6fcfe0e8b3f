//! Progress on standard error: drawn when it is a terminal (here a pseudo-terminal made
//! by util-linux's `script`), never when it is a pipe or a file, and never with `-q`.

mod common;

use common::*;

fn program(dir: &std::path::Path) -> std::path::PathBuf {
    let mut s = String::from("G21 G90 G17\nG0 X0 Y0 Z1\nG1 Z0 F600\n");
    for k in 0..20_000 {
        s.push_str(&format!("G1 X{} Y{}\n", k % 50, (k / 50) % 40));
    }
    s.push_str("G0 Z5\nM30\n");
    let p = dir.join("long.nc");
    std::fs::write(&p, s).expect("write");
    p
}

#[test]
fn no_progress_into_a_pipe_or_a_file() {
    let dir = tempdir("progress-pipe");
    let p = program(&dir);
    let out = dir.join("out.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        p.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        !e.contains("posting:") && !e.contains('\r') && !e.contains('\u{1b}'),
        "{e}"
    );
    assert!(e.contains("posted 20"), "the summary line stays: {e}");
}

#[test]
fn progress_on_a_terminal_unless_quiet() {
    if std::process::Command::new("script")
        .arg("--version")
        .output()
        .is_err()
    {
        eprintln!("skipped: util-linux `script` is not installed");
        return;
    }
    let dir = tempdir("progress-tty");
    let p = program(&dir);
    let bin = env!("CARGO_BIN_EXE_lampost");
    let run = |quiet: bool| {
        let cmd = format!(
            "{bin} post --machine nrc-lc --index B=0,C=0 {} -o {}{}",
            p.display(),
            dir.join("out.nc").display(),
            if quiet { " -q" } else { "" }
        );
        let o = std::process::Command::new("script")
            .args(["-qec", &cmd, "/dev/null"])
            .stdin(std::process::Stdio::null())
            .output()
            .expect("script");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let shown = run(false);
    assert!(shown.contains("posting: "), "{shown}");
    assert!(shown.contains("moves ("), "{shown}");
    let quiet = run(true);
    assert!(!quiet.contains("posting: "), "{quiet}");
}
