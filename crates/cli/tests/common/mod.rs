//! Helpers shared by the CLI behaviour tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `../shared` beside the project, if present.
pub fn shared() -> Option<PathBuf> {
    let p = root().join("../shared");
    p.is_dir().then_some(p)
}

/// Run the `lampost` binary.
pub fn lampost(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lampost"))
        .args(args)
        .output()
        .expect("lampost runs")
}

/// Run `lampost` with `input` on stdin.
pub fn lampost_stdin(args: &[&str], input: &[u8]) -> Output {
    use std::io::Write;
    let mut child = Command::new(env!("CARGO_BIN_EXE_lampost"))
        .args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("lampost runs");
    let mut stdin = child.stdin.take().expect("stdin");
    let data = input.to_vec();
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&data);
    });
    let out = child.wait_with_output().expect("lampost finishes");
    let _ = writer.join();
    out
}

/// A fresh temporary folder for one test.
pub fn tempdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lampost-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Where `scripts/install-rs274.sh` puts LinuxCNC's rs274, if it is there.
pub fn rs274() -> Option<(PathBuf, String)> {
    let base = std::env::var_os("LAMPOST_RS274_ROOT")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join(".tools/rs274/root"));
    let bin = base.join("usr/bin/rs274");
    if bin.is_file() {
        let libs = format!(
            "{}:{}",
            base.join("usr/lib").display(),
            base.join("usr/lib/x86_64-linux-gnu").display()
        );
        Some((bin, libs))
    } else {
        None
    }
}

/// rs274, or a skip (a failure when LAMPOST_REQUIRE_RS274 is set, as in CI).
pub fn require_rs274() -> Option<(PathBuf, String)> {
    let found = rs274();
    if found.is_none() {
        if std::env::var_os("LAMPOST_REQUIRE_RS274").is_some() {
            panic!("rs274 is required (LAMPOST_REQUIRE_RS274) but not installed: run scripts/install-rs274.sh");
        }
        eprintln!("SKIPPED: rs274 not installed (run scripts/install-rs274.sh)");
    }
    found
}

/// One canonical motion from rs274's output.
#[derive(Debug, Clone)]
pub struct Canon {
    pub kind: String,
    pub args: Vec<f64>,
    pub line: usize,
}

/// rs274 runs one at a time: it keeps files of its own.
static RS274: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Run rs274 on `program` and return its motion calls.
pub fn rs274_motions(program: &Path, work: &Path) -> Vec<Canon> {
    let _one_at_a_time = RS274
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let (bin, libs) = rs274().expect("rs274 installed");
    let tbl = work.join("tool.tbl");
    let mut t = String::new();
    for i in 1..=99 {
        t.push_str(&format!("T{i} P{i} Z0 D0\n"));
    }
    std::fs::write(&tbl, t).expect("tool table");
    let out_path = work.join("canon.txt");
    // rs274 keeps files in its working folder: give each run its own.
    let out = Command::new(bin)
        .current_dir(work)
        .env("LD_LIBRARY_PATH", libs)
        .arg("-t")
        .arg(&tbl)
        .arg(program)
        .arg(&out_path)
        .stdin(std::process::Stdio::null())
        .output()
        .expect("rs274 runs");
    let text = std::fs::read_to_string(&out_path).unwrap_or_default();
    assert!(
        text.contains("PROGRAM_END") || text.lines().count() > 5,
        "rs274 failed on {} ({}): {}\n{}",
        program.display(),
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let mut v = Vec::new();
    for (i, l) in text.lines().enumerate() {
        for kind in [
            "STRAIGHT_TRAVERSE",
            "STRAIGHT_FEED",
            "ARC_FEED",
            "STRAIGHT_PROBE",
        ] {
            if let Some(pos) = l.find(&format!("{kind}(")) {
                let inner = &l[pos + kind.len() + 1..l.rfind(')').unwrap_or(l.len())];
                let args = inner
                    .split(',')
                    .map(|s| s.trim().parse::<f64>().expect("rs274 prints numbers"))
                    .collect();
                v.push(Canon {
                    kind: kind.to_string(),
                    args,
                    line: i + 1,
                });
            }
        }
    }
    v
}
