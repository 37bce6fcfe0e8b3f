//! LinuxCNC's G76 threading cycle (issue 12, `crates/gcode/src/lathe.rs`): its passes
//! against rs274 on random parameter sets (skipped when rs274 is absent, as the other
//! oracle tests), the refusals rs274 makes as located errors, the bound on passes, and
//! the post's refusal.

mod common;

use common::*;

use lampost_testkit::XorShift as Rng;

/// A number as a program writes it: 4 decimals, so rs274 and lampost read the same value.
fn n4(v: f64) -> String {
    format!("{v:.4}")
}

/// One G76 block from its start, with random words (every optional word sometimes
/// absent, sometimes at the values rs274 reads specially: Q-1, R below 1, H-1, E
/// negative, L 0 to 3).
fn random_g76(r: &mut Rng) -> String {
    let x0 = r.range(2.0, 30.0);
    let z0 = r.range(-5.0, 5.0);
    let length = r.range(1.0, 25.0);
    let z1 = if r.chance(0.25) {
        z0 + length
    } else {
        z0 - length
    };
    let j = r.range(0.02, 0.3);
    let k = j * r.range(1.05, 6.0);
    let i = r.range(0.01, 2.0) * if r.chance(0.5) { -1.0 } else { 1.0 };
    let mut g = format!(
        "G0 X{} Z{}\nG76 P{} Z{} I{} J{} K{}",
        n4(x0),
        n4(z0),
        n4(r.range(0.1, 3.0)),
        n4(z1),
        n4(i),
        n4(j),
        n4(k)
    );
    match r.pick(4) {
        0 => {}
        1 => g.push_str(" Q-1"),
        _ => g.push_str(&format!(" Q{}", n4(r.range(0.0, 60.0)))),
    }
    match r.pick(3) {
        0 => {}
        1 => g.push_str(&format!(" R{}", n4(r.range(0.5, 1.0)))),
        _ => g.push_str(&format!(" R{}", n4(r.range(1.0, 2.5)))),
    }
    if r.chance(0.6) {
        g.push_str(&format!(" H{}", r.pick(5) as i64 - 1));
    }
    if r.chance(0.7) {
        g.push_str(&format!(" E{}", n4(r.range(-0.5, 3.0))));
    }
    if r.chance(0.7) {
        g.push_str(&format!(" L{}", r.pick(4)));
    }
    if r.chance(0.3) {
        g.push_str(&format!(" X{}", n4(r.range(2.0, 30.0))));
    }
    g.push('\n');
    g
}

/// A program of `blocks` random G76 blocks in random units, plane, spindle direction,
/// with now and then a G92 shift or incremental distances.
fn random_program(r: &mut Rng, blocks: usize) -> String {
    let mut p = String::new();
    p.push_str(if r.chance(0.5) { "G21" } else { "G20" });
    p.push_str(if r.chance(0.8) { " G18" } else { " G17" });
    p.push_str(" G90 G40\n");
    p.push_str(&format!(
        "{} S{}\n",
        if r.chance(0.7) { "M3" } else { "M4" },
        r.pick(2000) + 50
    ));
    if r.chance(0.3) {
        p.push_str(&format!(
            "G0 X0 Z0\nG92 X{} Z{}\n",
            n4(r.range(-3.0, 3.0)),
            n4(r.range(-3.0, 3.0))
        ));
    }
    for _ in 0..blocks {
        let g = random_g76(r);
        if r.chance(0.15) {
            // Incremental: the end Z (and X) from where the cycle starts.
            let (first, cycle) = g.split_once('\n').unwrap_or((&g, ""));
            p.push_str(&format!("{first}\nG91 {cycle}G90\n"));
        } else {
            p.push_str(&g);
        }
    }
    p.push_str("M2\n");
    p
}

#[test]
fn g76_passes_equal_rs274_on_random_parameter_sets() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("g76-random");
    let mut r = Rng(0x6776_5eed_1234_5678);
    let (mut sets, mut moves, mut coordinates) = (0, 0, 0);
    for n in 0..24 {
        let own = work.join(format!("p{n}"));
        std::fs::create_dir_all(&own).expect("folder");
        let prog = own.join("g76.ngc");
        let text = random_program(&mut r, 10);
        std::fs::write(&prog, &text).expect("write");
        let canon = rs274_to_end(&prog, &own)
            .or_else(|_| rs274_to_end(&prog, &own))
            .unwrap_or_else(|e| panic!("rs274 on\n{text}\n{e}"));
        let out = lampost(&[
            "trace",
            "--json",
            "--flavor",
            "linuxcnc",
            prog.to_str().expect("utf8"),
        ]);
        assert!(out.status.success(), "{text}\n{}", stderr(&out));
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
        let (total, _) = compare_with_rs274(&doc, &canon).unwrap_or_else(|e| panic!("{text}\n{e}"));
        sets += 10;
        moves += canon.len();
        coordinates += total;
    }
    eprintln!(
        "G76: {sets} parameter sets, {moves} moves, {coordinates} coordinates equal to rs274"
    );
    assert!(moves > 5_000, "{moves}");
}

/// Blocks rs274 refuses: each a located error of lampost's, on the word at fault where
/// there is one, with the hint; where rs274 is installed, it refuses each too.
#[test]
fn g76_refusals_are_located_where_rs274_refuses() {
    let head = "G20 G18\nM3 S100\nG0 X0.2 Z0.2\n";
    let cases: [(&str, &str, &str); 15] = [
        (
            "G76 Z-0.5 I-0.075 J0.008 K0.045",
            "P (the pitch) is missing",
            "4:1",
        ),
        (
            "G76 P-1 Z-0.5 I-0.075 J0.008 K0.045",
            "P (the pitch) is missing",
            "4:1",
        ),
        ("G76 P0.05 Z-0.5 J0.008 K0.045", "are all needed", "4:1"),
        // rs274 runs a zero pitch (the carriage would stand still); lampost refuses it.
        (
            "G76 P0 Z-0.5 I-0.075 J0.008 K0.045",
            "greater than 0",
            "4:5",
        ),
        ("G76 P0.05 Z-0.5 I0 J0.008 K0.045", "must not be 0", "4:17"),
        (
            "G76 P0.05 Z-0.5 I-0.075 J0 K0.045",
            "greater than 0",
            "4:25",
        ),
        (
            "G76 P0.05 Z-0.5 I-0.075 J0.008 K0.008",
            "greater than J",
            "4:32",
        ),
        (
            "G76 P0.05 Z-0.5 I-0.075 J0.008 K0.045 H1.5",
            "H must be a whole",
            "4:39",
        ),
        (
            "G76 P0.05 Z-0.5 I-0.075 J0.008 K0.045 H-2",
            "cannot be negative",
            "4:39",
        ),
        (
            "G76 P0.05 Z-0.5 I-0.075 J0.008 K0.045 L-1 E.1",
            "cannot be negative",
            "4:39",
        ),
        (
            "G76 P0.05 Z-0.5 I-0.075 J0.008 K0.045 A1",
            "A moves",
            "4:39",
        ),
        ("G76 P0.05 I-0.075 J0.008 K0.045", "no axis word", "4:1"),
        (
            "M5\nG76 P0.05 Z-0.5 I-0.075 J0.008 K0.045",
            "spindle is not turning",
            "5:1",
        ),
        (
            "T1 M6\nG76 P0.05 Z-0.5 I-0.075 J0.008 K0.045",
            "spindle is not turning",
            "5:1",
        ),
        (
            "G76 P0.05 Z-0.5 I-0.075 J0.008 K0.045\nZ-0.6",
            "P (the pitch) is missing",
            "5:1",
        ),
    ];
    let rs274 = rs274().is_some();
    let work = tempdir("g76-refusals");
    for (n, (block, why, at)) in cases.iter().enumerate() {
        let src = format!("{head}{block}\nM2\n");
        let out = lampost_stdin(&["check", "--flavor", "linuxcnc", "-"], src.as_bytes());
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{block}: {err}");
        assert!(err.contains(why), "{block}: {err}");
        assert!(
            err.contains(&format!("--> <stdin>:{at}\n")),
            "{block}: {err}"
        );
        assert!(err.contains("help: G76 needs P"), "{block}: {err}");
        if rs274 && !block.starts_with("G76 P0 ") {
            let own = work.join(format!("c{n}"));
            std::fs::create_dir_all(&own).expect("folder");
            let prog = own.join("c.ngc");
            std::fs::write(&prog, &src).expect("write");
            assert!(rs274_to_end(&prog, &own).is_err(), "rs274 runs {block}");
        }
    }
    // Cutter compensation on (rs274, with a tool of radius 0, refuses G76 itself).
    let src = format!("{head}T1 M6\nM3\nG41\nG76 P0.05 Z-0.5 I-0.075 J0.008 K0.045\nM2\n");
    let out = lampost_stdin(&["check", "--flavor", "linuxcnc", "-"], src.as_bytes());
    let err = stderr(&out);
    assert!(
        out.status.code() == Some(1)
            && err.contains("compensation is on")
            && err.contains("--> <stdin>:7:1\n"),
        "{err}"
    );
}

/// The column (1-based) of `word` in `line`.
fn col(line: &str, word: &str) -> usize {
    line.find(word).map_or(0, |c| c + 1)
}

/// A tiny J with a large degression would make millions of passes: refused at J, in
/// bounded time, before any move; the spring passes count too. 10,000 passes are made,
/// 10,001 refused.
#[test]
fn g76_passes_are_bounded() {
    let head = "G21 G18\nM3 S100\nG0 X20 Z1\n";
    let refused = |block: &str, word: &str, why: &str| {
        let src = format!("{head}{block}\nM2\n");
        let out = lampost_stdin(&["trace", "--flavor", "linuxcnc", "-"], src.as_bytes());
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{err}");
        let at = format!("--> <stdin>:4:{}\n", col(block, word));
        assert!(err.contains(why) && err.contains(&at), "{block}: {err}");
        assert!(out.stdout.is_empty() || !String::from_utf8_lossy(&out.stdout).contains("Z-10"));
    };
    refused(
        "G76 P1 Z-10 I-1 J0.0001 K2 R3",
        "J",
        "more than 10000 passes",
    );
    refused(
        "G76 P1 Z-10 I-1 J0.1 K2 H2000000000",
        "H",
        "H asks for 2000000000 spring passes",
    );
    // J = 2^-12 and K = 10,000 J, exact in binary: 9,999 cuts and the full depth once.
    let exact = "G76 P1 Z-10 I-1 J0.000244140625 K2.44140625";
    let src = format!("{head}{exact}\nM2\n");
    let out = lampost_stdin(
        &["trace", "--json", "--flavor", "linuxcnc", "-"],
        src.as_bytes(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(
        doc["moves"].as_array().map(Vec::len),
        Some(1 + 4 * 10_000 + 1)
    );
    // One spring pass more is one pass too many.
    refused(
        &format!("{exact} H1"),
        "J",
        "more than 10000 passes (with 2 at the full depth)",
    );
}

/// `auto` reads a G76 with J and K as LinuxCNC's; the cycle's moves are rapids and feeds
/// at the pitch times the spindle speed, with a warning that the synchronisation is not
/// simulated; and the post refuses the block with its line.
#[test]
fn g76_auto_feeds_warning_and_post_refusal() {
    let src =
        "G20 G18\nM3 S800\nG0 X0.2 Z0.2\nG76 P0.05 Z-0.5 I-0.075 J0.008 K0.045 E0.05 L3 H1\nM2\n";
    let metric = "G21 G18\nM3 S800\nG0 X5 Z5\nG76 P1 Z-12 I-2 J0.2 K1.2 E1 L3\nM2\n";
    let out = lampost_stdin(&["trace", "--json", "-"], src.as_bytes());
    assert!(out.status.success(), "{}", stderr(&out));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(doc["flavor"]["flavor"], "linuxcnc");
    let moves = doc["moves"].as_array().expect("moves");
    // 7 passes (one a spring pass) of 6 moves (back, down the entry taper twice, the cut, up the exit taper,
    // out), the move to the start and the one to the block's end.
    assert_eq!(moves.len(), 1 + 7 * 6 + 1);
    // G76's H is its spring passes, never a tool length offset.
    assert!(
        moves[1]["modal"]["tool_length"].is_null(),
        "{}",
        moves[1]["modal"]
    );
    let feeds: Vec<f64> = moves[1..7]
        .iter()
        .map(|m| m["feed"].as_f64().unwrap_or(f64::NAN))
        .collect();
    // The taper's pitch P·hypot(E, K)/E = 0.067268 (rs274's START_SPEED_FEED_SYNC).
    let taper = 0.05 * f64::hypot(0.05, 0.045) / 0.05 * 800.0;
    assert_eq!(feeds, [0.0, taper, taper, 0.05 * 800.0, taper, 0.0]);
    let out = lampost_stdin(&["check", "-"], src.as_bytes());
    let err = stderr(&out);
    assert!(
        out.status.success()
            && err.contains("warning: spindle synchronisation of G76")
            && err.contains("<stdin>:4:1"),
        "{err}"
    );
    let dir = tempdir("g76-post");
    let inp = dir.join("thread.ngc");
    std::fs::write(&inp, metric).expect("write");
    let out_path = dir.join("out.nc");
    let out = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        inp.to_str().expect("utf8"),
        "-o",
        out_path.to_str().expect("utf8"),
    ]);
    let err = stderr(&out);
    assert!(!out.status.success(), "posted: {err}");
    assert!(
        err.contains("thread.ngc:4:") && err.contains("G76"),
        "{err}"
    );
    assert!(!out_path.exists());
}
