//! `cargo xtask fuzz`: runs the fuzz child (`crates/fuzz`, built with `--profile fuzz`:
//! release speed, integer overflow checks on) target by target, round-robin, and watches
//! it. Each child process runs under `ulimit -v` (the memory limit) and reports progress
//! at least every 10 ms of work; when it is silent for longer than the per-input time
//! limit it is killed (a hang), and when it dies (an abort: out of memory, stack
//! overflow, a panic that cannot unwind) the inputs since its last report are run again,
//! one at a time, with each one saved before it runs, to name the input in flight. Then
//! the run goes on after it. Panics and broken promises ("invalid") are caught and saved
//! by the child itself. Findings go to `<target dir>/fuzz-findings/<target>/`: the input
//! (`.bin`) and what happened with how to run it alone (`.txt`).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// The child's targets, in round-robin order.
pub const TARGETS: &[&str] = &[
    "gcode", "fmt", "post", "toml", "points", "stl", "probe", "numeric", "inspect", "robot", "plan",
];

pub const USAGE: &str = "[--target all|gcode|fmt|post|toml|points|stl|probe|numeric|inspect|robot|plan|selftest[,…]] [--seconds N] [--seed S] [--input-ms MS] [--mem-mb MB] [--slice-seconds N]";

/// Options of a run.
#[derive(Debug, Clone)]
pub struct Config {
    pub targets: Vec<String>,
    pub seconds: u64,
    pub seed: u64,
    /// The time limit of one input.
    pub input_ms: u64,
    /// The memory limit of the child (virtual memory, `ulimit -v`).
    pub mem_mb: u64,
    /// How long one target runs before the next takes its turn (default: a third of its
    /// share of the run, between 1 and 20 s).
    pub slice: Option<f64>,
}

impl Config {
    pub fn parse(args: &[&str]) -> Result<Self, String> {
        let mut c = Config {
            targets: TARGETS.iter().map(|t| t.to_string()).collect(),
            seconds: 60,
            // Fixed, so a run (CI's) is the same inputs each time; `--seed` explores.
            seed: 1,
            input_ms: 2000,
            mem_mb: 1024,
            slice: None,
        };
        let mut it = args.iter();
        while let Some(k) = it.next() {
            let v = it
                .next()
                .ok_or_else(|| format!("{k} needs a value; {USAGE}"))?;
            let num = || {
                v.parse::<u64>()
                    .map_err(|_| format!("{k} takes a whole number, not {v}"))
            };
            match *k {
                "--target" => {
                    if *v != "all" {
                        c.targets = v.split(',').map(str::to_string).collect();
                        if let Some(bad) = c
                            .targets
                            .iter()
                            .find(|t| !(TARGETS.contains(&t.as_str()) || *t == "selftest"))
                        {
                            return Err(format!(
                                "--target {bad}: one of all, {}",
                                TARGETS.join(", ")
                            ));
                        }
                    }
                }
                "--seconds" => c.seconds = num()?,
                "--seed" => c.seed = num()?,
                "--input-ms" => c.input_ms = num()?.max(1),
                "--mem-mb" => c.mem_mb = num()?.max(64),
                "--slice-seconds" => c.slice = Some(num()?.max(1) as f64),
                _ => return Err(format!("unknown option {k}; {USAGE}")),
            }
        }
        Ok(c)
    }
}

/// Figures of one target.
#[derive(Debug, Default, Clone)]
struct Stats {
    inputs: u64,
    bytes: u64,
    slowest_us: u64,
    slowest_index: u64,
    panics: u64,
    invalid: u64,
    hangs: u64,
    aborts: u64,
    /// The next input to run.
    next: u64,
    found: Vec<String>,
}

/// What ended a child's run.
enum End {
    /// It finished its slice.
    Done,
    /// It was silent past the per-input limit (and was killed).
    Hang,
    /// It died: its status and the end of what it wrote to standard error.
    Died(String),
}

fn target_dir(root: &Path) -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root.join("target"), PathBuf::from)
}

/// Spawn the child under the memory limit, its standard output read line by line on a
/// thread (so the parent can wait with a timeout).
fn spawn(
    bin: &Path,
    cfg: &Config,
    args: &[String],
    stderr: &Path,
) -> Result<(Child, Receiver<String>), String> {
    let err = std::fs::File::create(stderr).map_err(|e| format!("{}: {e}", stderr.display()))?;
    let mut c = Command::new("sh");
    c.arg("-c")
        .arg(format!(
            "ulimit -v {}; exec \"$0\" \"$@\"",
            cfg.mem_mb * 1024
        ))
        .arg(bin)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(err);
    let mut child = c
        .spawn()
        .map_err(|e| format!("cannot run {}: {e}", bin.display()))?;
    let out = child
        .stdout
        .take()
        .ok_or_else(|| "no pipe from the child".to_string())?;
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines() {
            let Ok(l) = line else { break };
            if tx.send(l).is_err() {
                break;
            }
        }
    });
    Ok((child, rx))
}

/// The first lines the child wrote to standard error (why it died).
fn head(path: &Path) -> String {
    let t = std::fs::read_to_string(path).unwrap_or_default();
    t.lines().take(3).collect::<Vec<_>>().join("\n")
}

/// Wait for the child to end after its output closed: Done or Died.
fn ended(child: &mut Child, stderr: &Path) -> End {
    match child.wait() {
        Ok(st) if st.success() => End::Done,
        Ok(st) => End::Died(format!("{st}; stderr: {}", head(stderr))),
        Err(e) => End::Died(e.to_string()),
    }
}

struct Run<'a> {
    bin: PathBuf,
    root: PathBuf,
    work: PathBuf,
    findings: PathBuf,
    cfg: &'a Config,
}

impl Run<'_> {
    fn base_args(&self, target: &str, start: u64) -> Vec<String> {
        vec![
            "--root".into(),
            self.root.to_string_lossy().into_owned(),
            "--target".into(),
            target.into(),
            "--seed".into(),
            self.cfg.seed.to_string(),
            "--start".into(),
            start.to_string(),
            "--findings".into(),
            self.findings.to_string_lossy().into_owned(),
        ]
    }

    /// One slice of `target`: inputs from `st.next` for `ms` milliseconds.
    fn slice(&self, target: &str, st: &mut Stats, ms: u64) -> Result<(), String> {
        let mut args = self.base_args(target, st.next);
        args.extend(["--ms".into(), ms.to_string()]);
        let stderr = self.work.join(format!("{target}.stderr"));
        let (mut child, rx) = spawn(&self.bin, self.cfg, &args, &stderr)?;
        let limit = Duration::from_millis(self.cfg.input_ms);
        // The first report also waits for the child to read its seeds.
        let mut wait = limit + Duration::from_secs(10);
        let (mut seen_inputs, mut seen_bytes) = (0u64, 0u64);
        let mut reported = false;
        let end = loop {
            match rx.recv_timeout(wait) {
                Ok(line) => {
                    wait = limit;
                    let f: Vec<&str> = line.split_whitespace().collect();
                    match f.as_slice() {
                        ["p", next, inputs, bytes, us, ix] => {
                            reported = true;
                            let n = |s: &str| s.parse::<u64>().unwrap_or(0);
                            st.next = n(next);
                            st.inputs += n(inputs).saturating_sub(seen_inputs);
                            st.bytes += n(bytes).saturating_sub(seen_bytes);
                            seen_inputs = n(inputs);
                            seen_bytes = n(bytes);
                            if n(us) > st.slowest_us {
                                st.slowest_us = n(us);
                                st.slowest_index = n(ix);
                            }
                        }
                        ["f", kind, _, path] => {
                            match *kind {
                                "panic" => st.panics += 1,
                                _ => st.invalid += 1,
                            }
                            st.found.push(format!("{kind}: {path}"));
                        }
                        _ => {}
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    let _ = child.kill();
                    let _ = child.wait();
                    break End::Hang;
                }
                Err(RecvTimeoutError::Disconnected) => break ended(&mut child, &stderr),
            }
        };
        match end {
            End::Done => Ok(()),
            End::Died(why) if !reported => Err(format!(
                "the fuzz child for {target} failed before its first input: {why}"
            )),
            other => self.replay(target, st, other),
        }
    }

    /// Run the child from `start` (at most `count` inputs), each input announced before
    /// it runs (and with `trace`, saved): how it ended and the last input announced.
    fn announced(
        &self,
        target: &str,
        start: u64,
        count: u64,
        trace: Option<&Path>,
    ) -> Result<(End, Option<u64>), String> {
        let mut args = self.base_args(target, start);
        args.extend([
            "--ms".into(),
            "60000".into(),
            "--count".into(),
            count.to_string(),
            "--announce".into(),
            "1".into(),
        ]);
        if let Some(t) = trace {
            args.extend(["--trace".into(), t.to_string_lossy().into_owned()]);
        }
        let stderr = self.work.join(format!("{target}.replay.stderr"));
        let (mut child, rx) = spawn(&self.bin, self.cfg, &args, &stderr)?;
        let limit = Duration::from_millis(self.cfg.input_ms);
        let mut wait = limit + Duration::from_secs(10);
        let mut current: Option<u64> = None;
        let end = loop {
            match rx.recv_timeout(wait) {
                Ok(line) => {
                    wait = limit;
                    if let Some(i) = line.strip_prefix("s ").and_then(|s| s.parse().ok()) {
                        current = Some(i);
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    let _ = child.kill();
                    let _ = child.wait();
                    break End::Hang;
                }
                Err(RecvTimeoutError::Disconnected) => break ended(&mut child, &stderr),
            }
        };
        Ok((end, current))
    }

    /// The child hung or died somewhere after `st.next`: run the inputs from there again,
    /// each announced before it runs, until one does it again; run that one once more
    /// with its bytes saved first; record it and go on after it.
    fn replay(&self, target: &str, st: &mut Stats, first: End) -> Result<(), String> {
        let (end, current) = self.announced(target, st.next, 1_000_000, None)?;
        let index = current.unwrap_or(st.next);
        let trace = self.work.join(format!("{target}.inflight"));
        let _ = std::fs::remove_file(&trace);
        let again = match end {
            End::Done => End::Done,
            _ => self.announced(target, index, 1, Some(&trace))?.0,
        };
        let (kind, what) = match (&end, &first) {
            (End::Hang, _) => ("hang", format!("no progress within {} ms", self.cfg.input_ms)),
            (End::Died(why), _) => ("abort", format!("the process died: {why}")),
            (End::Done, End::Hang) => (
                "hang",
                format!("the child was silent past {} ms but no input does it alone (a slow spell of the machine?)", self.cfg.input_ms),
            ),
            (End::Done, End::Died(why)) => (
                "abort",
                format!("the child died ({why}) but no input does it alone"),
            ),
            (End::Done, End::Done) => return Ok(()),
        };
        let alone = match again {
            End::Done => "; alone it passes",
            _ => "",
        };
        let dir = self.findings.join(target);
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let reproduced = !matches!(end, End::Done);
        let base = dir.join(format!("{kind}-{}-{index}", self.cfg.seed));
        if reproduced {
            let _ = std::fs::copy(&trace, base.with_extension("bin"));
        }
        let note = std::fs::read_to_string(trace.with_extension("txt")).unwrap_or_default();
        let _ = std::fs::write(
            base.with_extension("txt"),
            format!(
                "target {target}, seed {}, input {index}: {kind}\n{what}{alone}\noptions: {note}\nlimits: {} ms, {} MB\nrun it alone: lampost-fuzz --root . --target {target} --seed {} --start {index} --count 1\n",
                self.cfg.seed, self.cfg.input_ms, self.cfg.mem_mb, self.cfg.seed
            ),
        );
        match kind {
            "hang" => st.hangs += 1,
            _ => st.aborts += 1,
        }
        st.found
            .push(format!("{kind}: {}", base.with_extension("txt").display()));
        if reproduced {
            // The inputs before it ran (their last report was lost with the child).
            st.inputs += index + 1 - st.next.min(index);
        }
        st.next = if reproduced { index + 1 } else { st.next + 1 };
        Ok(())
    }
}

/// Build the child, run the targets round-robin for `cfg.seconds`, print the figures;
/// an error when anything was found.
pub fn run(root: &Path, cfg: &Config) -> Result<(), String> {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(root)
        .args(["build", "-q", "--profile", "fuzz", "-p", "lampost-fuzz"])
        .stdin(Stdio::null());
    let st = c.status().map_err(|e| format!("cannot run {c:?}: {e}"))?;
    if !st.success() {
        return Err(format!("{c:?} failed: {st}"));
    }
    let tdir = target_dir(root);
    let work = tdir.join("fuzz-work");
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let run = Run {
        bin: tdir.join("fuzz/lampost-fuzz"),
        root: root.to_path_buf(),
        work,
        findings: tdir.join("fuzz-findings"),
        cfg,
    };
    let n = cfg.targets.len().max(1) as f64;
    let total = Duration::from_secs(cfg.seconds);
    let slice = cfg
        .slice
        .unwrap_or_else(|| (cfg.seconds as f64 / n / 3.0).clamp(1.0, 20.0));
    println!(
        "fuzz: seed {}, {} s over {} target(s), slices of {slice:.1} s; each input ≤ {} ms and ≤ {} MB; overflow checks on (profile fuzz)",
        cfg.seed,
        cfg.seconds,
        cfg.targets.len(),
        cfg.input_ms,
        cfg.mem_mb
    );
    let t0 = Instant::now();
    let mut stats: Vec<Stats> = vec![Stats::default(); cfg.targets.len()];
    'rounds: loop {
        for (t, s) in cfg.targets.iter().zip(stats.iter_mut()) {
            let left = total.saturating_sub(t0.elapsed());
            if left < Duration::from_millis(100) {
                break 'rounds;
            }
            let ms = (slice * 1e3).min(left.as_millis() as f64) as u64;
            run.slice(t, s, ms)?;
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    println!(
        "{:<8} {:>12} {:>9} {:>16} {:>7} {:>8} {:>6} {:>7}",
        "target", "inputs", "MB", "slowest ms (#)", "panics", "invalid", "hangs", "aborts"
    );
    let mut sum = Stats::default();
    for (t, s) in cfg.targets.iter().zip(&stats) {
        println!(
            "{t:<8} {:>12} {:>9.1} {:>16} {:>7} {:>8} {:>6} {:>7}",
            s.inputs,
            s.bytes as f64 / 1e6,
            format!("{:.1} (#{})", s.slowest_us as f64 / 1e3, s.slowest_index),
            s.panics,
            s.invalid,
            s.hangs,
            s.aborts
        );
        sum.inputs += s.inputs;
        sum.bytes += s.bytes;
        sum.panics += s.panics;
        sum.invalid += s.invalid;
        sum.hangs += s.hangs;
        sum.aborts += s.aborts;
        sum.found.extend(s.found.iter().cloned());
    }
    println!(
        "{:<8} {:>12} {:>9.1} {:>16} {:>7} {:>8} {:>6} {:>7}",
        "total",
        sum.inputs,
        sum.bytes as f64 / 1e6,
        "",
        sum.panics,
        sum.invalid,
        sum.hangs,
        sum.aborts
    );
    println!(
        "{:.0} inputs/s over {secs:.0} s (one child at a time)",
        sum.inputs as f64 / secs.max(1e-9)
    );
    if sum.found.is_empty() {
        return Ok(());
    }
    for f in sum.found.iter().take(20) {
        println!("  {f}");
    }
    if sum.found.len() > 20 {
        println!("  … and {} more", sum.found.len() - 20);
    }
    Err(format!(
        "the fuzzer found {} problem(s); inputs in {}",
        sum.found.len(),
        run.findings.display()
    ))
}
