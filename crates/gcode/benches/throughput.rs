//! Parse + interpret throughput, against the `gcode` crate (crates.io) parsing the same
//! text in the same run. Run with `cargo xtask bench gcode` (or `cargo bench -p
//! lampost-gcode --bench throughput`). Each figure is the best of several runs.

use std::hint::black_box;
use std::time::{Duration, Instant};

use lampost_gcode::{Event, Flavor, Options, Resolved, Stream};

fn best_of(runs: usize, mut f: impl FnMut() -> usize) -> (Duration, usize) {
    let mut best = Duration::MAX;
    let mut out = 0;
    for _ in 0..runs {
        let t = Instant::now();
        out = black_box(f());
        best = best.min(t.elapsed());
    }
    (best, out)
}

fn ours(text: &[u8]) -> usize {
    let mut moves = 0usize;
    let mut endsum = 0.0f64;
    // As `--flavor auto` reads it: the flavour decided from the head, once per program.
    let flavor = Resolved::new(Flavor::Auto, text).flavor;
    let opts = flavor.options(Options::default(), None);
    for e in Stream::from_bytes(text, opts, false) {
        if let Ok(Event::Move(m)) = e {
            moves += 1;
            endsum += m.end[0];
        }
    }
    black_box(endsum);
    moves
}

fn theirs(text: &str) -> usize {
    match gcode::parse(text) {
        Ok(p) => p.blocks.len(),
        Err(_) => 0,
    }
}

fn report(name: &str, bytes: usize, runs: usize, text: &str) {
    let (t_ours, n_ours) = best_of(runs, || ours(text.as_bytes()));
    let (t_theirs, n_theirs) = best_of(runs, || theirs(text));
    let mbs = |t: Duration| bytes as f64 / 1e6 / t.as_secs_f64();
    println!(
        "{name}: {:.1} MB, parse + interpret with --flavor auto {:.0} MB/s ({} moves, {:.1} ms); gcode crate parse {:.0} MB/s ({} blocks, {:.1} ms); ratio {:.2}x",
        bytes as f64 / 1e6,
        mbs(t_ours),
        n_ours,
        t_ours.as_secs_f64() * 1e3,
        mbs(t_theirs),
        n_theirs,
        t_theirs.as_secs_f64() * 1e3,
        t_theirs.as_secs_f64() / t_ours.as_secs_f64()
    );
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` passes nothing and wants speed.
    let quick = !std::env::args().any(|a| a == "--bench");
    let lines = if quick { 10_000 } else { 1_000_000 };
    let runs = if quick { 1 } else { 5 };
    let text = lampost_gcode::generate::planar_program(lines, 42);
    report(
        &format!("generated {lines}-line 3-axis program"),
        text.len(),
        runs,
        &text,
    );

    let corpus = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/corpus/linuxcnc/LHchips4.ngc");
    match std::fs::read_to_string(&corpus) {
        Ok(one) => {
            // Repeat the file so each run takes long enough to time well.
            let reps = if quick { 1 } else { 50 };
            // Without its end (M2/M30, %), so every copy is interpreted.
            let body: String = one
                .lines()
                .filter(|l| {
                    let t = l.trim().to_ascii_uppercase();
                    !(t == "%" || t.starts_with("M2") || t.starts_with("M30"))
                })
                .map(|l| format!("{l}\n"))
                .collect();
            let text = body.repeat(reps);
            report(
                &format!("LHchips4.ngc (largest corpus file) x{reps}"),
                text.len(),
                runs,
                &text,
            );
        }
        Err(_) => println!("corpus file {} absent: skipped", corpus.display()),
    }
}
