//! `lampost-fuzz`: the child process of `cargo xtask fuzz` (xtask/src/main.rs runs it,
//! watches it and restarts it). It runs inputs `start, start + 1, …` of one target until
//! its time or count is up; input `i` is a function of (seed, target, i) alone, so the
//! parent can run any input again by its index.
//!
//! Protocol on standard output, one line each:
//! - `p NEXT INPUTS BYTES SLOWEST_US SLOWEST_INDEX`: progress (at least every 10 ms of
//!   work, and at the end); NEXT is the first index not yet run.
//! - `f KIND INDEX PATH`: a finding saved at PATH (KIND `panic` or `invalid`).
//! - with `--announce 1`, `s INDEX` before each input (the parent's way to name the input
//!   in flight when the process hangs or dies); with `--trace FILE` too, and each input's
//!   bytes are written to FILE before it runs (and what was chosen to FILE.txt).
//!
//! Built with `--profile fuzz` (integer overflow checks on); memory is limited by the
//! parent (`ulimit -v`).

#![forbid(unsafe_code)]

mod gen;
mod targets;

// The CLI's own point-file reader and diagnostic rendering, compiled here as they are
// (they are modules of the `lampost` binary, not of a library).
#[allow(dead_code, unused_imports, unused_macros)]
#[path = "../../cli/src/json.rs"]
mod json;
#[allow(dead_code)]
#[path = "../../cli/src/points.rs"]
mod points;
#[allow(dead_code)]
#[path = "../../cli/src/report.rs"]
mod report;

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

#[derive(Debug)]
struct Args {
    root: PathBuf,
    target: String,
    seed: u64,
    start: u64,
    count: u64,
    ms: u64,
    findings: PathBuf,
    trace: Option<PathBuf>,
    announce: bool,
}

fn args() -> Result<Args, String> {
    let mut a = Args {
        root: PathBuf::from("."),
        target: String::new(),
        seed: 1,
        start: 0,
        count: u64::MAX,
        ms: 1000,
        findings: PathBuf::from("fuzz-findings"),
        trace: None,
        announce: false,
    };
    let v: Vec<String> = std::env::args().skip(1).collect();
    let mut it = v.iter();
    while let Some(k) = it.next() {
        let val = it.next().ok_or_else(|| format!("{k} needs a value"))?;
        let num = || {
            val.parse::<u64>()
                .map_err(|_| format!("{k} takes a whole number, not {val}"))
        };
        match k.as_str() {
            "--root" => a.root = PathBuf::from(val),
            "--target" => a.target.clone_from(val),
            "--seed" => a.seed = num()?,
            "--start" => a.start = num()?,
            "--count" => a.count = num()?,
            "--ms" => a.ms = num()?,
            "--findings" => a.findings = PathBuf::from(val),
            "--trace" => a.trace = Some(PathBuf::from(val)),
            "--announce" => a.announce = val == "1",
            _ => return Err(format!("unknown option {k}")),
        }
    }
    if !(targets::TARGETS.contains(&a.target.as_str()) || a.target == "selftest") {
        return Err(format!(
            "--target {}: one of {}",
            a.target,
            targets::TARGETS.join(", ")
        ));
    }
    Ok(a)
}

fn save(a: &Args, kind: &str, index: u64, input: &[u8], what: &str) -> PathBuf {
    let dir = a.findings.join(&a.target);
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(format!("{kind}-{}-{index}.bin", a.seed));
    let _ = std::fs::write(&path, input);
    let _ = std::fs::write(
        path.with_extension("txt"),
        format!(
            "target {}, seed {}, input {index}: {kind}\n{what}\nrun it alone: lampost-fuzz --root . --target {} --seed {} --start {index} --count 1\n",
            a.target, a.seed, a.target, a.seed
        ),
    );
    path
}

fn run() -> Result<(), String> {
    let a = args()?;
    let ctx = targets::Ctx::new(&a.root, a.trace.clone())?;
    // Panics are caught and reported as findings, not printed.
    std::panic::set_hook(Box::new(|_| {}));
    let out = std::io::stdout();
    let mut out = out.lock();
    let mut say = |s: String| -> Result<(), String> {
        out.write_all(s.as_bytes())
            .and_then(|()| out.flush())
            .map_err(|e| format!("cannot report: {e}"))
    };
    let t0 = Instant::now();
    let budget = Duration::from_millis(a.ms);
    let (mut inputs, mut bytes, mut slow_us, mut slow_ix) = (0u64, 0u64, 0u64, a.start);
    let mut last_report = Instant::now();
    let mut i = a.start;
    let end = a.start.saturating_add(a.count);
    let mut input = Vec::with_capacity(1 << 16);
    let mut note = String::new();
    // Ready: the parent's per-input clock starts here.
    say(format!("p {i} 0 0 0 {i}\n"))?;
    while i < end && t0.elapsed() < budget {
        let mut r = gen::Rng::for_input(a.seed, &a.target, i);
        if a.trace.is_some() || a.announce {
            say(format!("s {i}\n"))?;
        }
        input.clear();
        note.clear();
        let t = Instant::now();
        let res = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            ctx.run(&a.target, &mut r, &mut input, &mut note)
        }));
        let us = t.elapsed().as_micros() as u64;
        if us > slow_us {
            slow_us = us;
            slow_ix = i;
        }
        inputs += 1;
        bytes += input.len() as u64;
        match res {
            Ok(Ok(())) => {}
            Ok(Err(why)) => {
                let p = save(&a, "invalid", i, &input, &format!("{why}\noptions: {note}"));
                say(format!("f invalid {i} {}\n", p.display()))?;
            }
            Err(payload) => {
                let msg = payload
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| payload.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "a panic".into());
                let p = save(
                    &a,
                    "panic",
                    i,
                    &input,
                    &format!("panic: {msg}\noptions: {note}"),
                );
                say(format!("f panic {i} {}\n", p.display()))?;
            }
        }
        i += 1;
        if last_report.elapsed() >= Duration::from_millis(10) {
            last_report = Instant::now();
            say(format!("p {i} {inputs} {bytes} {slow_us} {slow_ix}\n"))?;
        }
    }
    say(format!("p {i} {inputs} {bytes} {slow_us} {slow_ix}\n"))
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let _ = writeln!(std::io::stderr(), "lampost-fuzz: {e}");
            ExitCode::from(3)
        }
    }
}
