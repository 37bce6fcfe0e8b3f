//! LinuxCNC's lathe profile cycles G70, G71 and G72 (and G71.1/.2, G72.1/.2; issue 12,
//! `crates/gcode/src/lathe.rs`): their moves against rs274 on random profiles (skipped
//! when rs274 is absent, as the other oracle tests), the refusals rs274 makes as located
//! errors, the bounds on the work, a G70 under cutter compensation, and the post's
//! refusal.

mod common;

use common::*;

use lampost_testkit::XorShift as Rng;

/// A number as a program writes it: 4 decimals, so rs274 and lampost read the same value.
fn n4(v: f64) -> String {
    format!("{v:.4}")
}

/// A program of one random profile cycle. The profile runs steadily one way along its
/// cutting axis (Z for G71, X for G72) and up and down the other (so it has pockets),
/// by lines (some with an A fillet or C chamfer at their end) and arcs (by R, or by I
/// and K as rs274 works the centre out from R); it is mirrored into any quadrant, and
/// the cycle starts outside it. G70 finishes it in P passes from D to E.
fn random_cycle(r: &mut Rng) -> String {
    let rotated = r.chance(0.4);
    let (sa, sb) = (r.sign(), r.sign());
    let (oa, ob) = (r.range(-5.0, 5.0), r.range(-3.0, 3.0));
    // (along, across) to (X, Z).
    let xz = |a: f64, b: f64| {
        let (a, b) = (oa + sa * a, ob + sb * b);
        if rotated {
            (a, b)
        } else {
            (b, a)
        }
    };
    let mut a = 0.0;
    let mut b = r.range(2.0, 10.0);
    let mut top = b;
    let (x0, z0) = xz(a, b);
    let mut sub = format!("O100 SUB\nG0 X{} Z{}\n", n4(x0), n4(z0));
    let mut prev = (x0, z0);
    for _ in 0..2 + r.pick(5) {
        a -= r.range(1.0, 5.0);
        b = (b + r.range(-4.0, 4.0)).clamp(0.5, 12.0);
        top = top.max(b);
        let (x, z) = xz(a, b);
        if r.chance(0.6) {
            let corner = match r.pick(6) {
                0 => format!(" A{}", n4(r.range(0.1, 0.5))),
                1 => format!(" C{}", n4(r.range(0.1, 0.5))),
                _ => String::new(),
            };
            sub.push_str(&format!("G1 X{} Z{}{corner}\n", n4(x), n4(z)));
        } else {
            let g = if r.chance(0.5) { "G2" } else { "G3" };
            let (dz, dx) = (z - prev.1, x - prev.0);
            let chord2 = dz * dz + dx * dx;
            let radius = chord2.sqrt() / 2.0 * r.range(1.05, 3.0);
            if r.chance(0.5) {
                sub.push_str(&format!("{g} X{} Z{} R{}\n", n4(x), n4(z), n4(radius)));
            } else {
                // rs274's centre for R (Z real, X imaginary), as incremental I and K.
                let h = ((radius * radius - chord2 / 4.0) / chord2).sqrt();
                let (cz, cx) = if g == "G3" {
                    (-dx * h, dz * h)
                } else {
                    (dx * h, -dz * h)
                };
                let (cz, cx) = (prev.1 + dz / 2.0 + cz, prev.0 + dx / 2.0 + cx);
                sub.push_str(&format!(
                    "{g} X{} Z{} I{} K{}\n",
                    n4(x),
                    n4(z),
                    n4(cx - prev.0),
                    n4(cz - prev.1)
                ));
            }
        }
        prev = (x, z);
    }
    sub.push_str("O100 ENDSUB\n");
    let (sx, sz) = xz(r.range(0.5, 3.0), top + r.range(0.5, 3.0));
    let cycles: [&str; 4] = if rotated {
        ["G72", "G72.1", "G72.2", "G70"]
    } else {
        ["G71", "G71.1", "G71.2", "G70"]
    };
    let cycle = cycles[r.pick(4) as usize];
    let mut block = format!(
        "{cycle} Q100 X{} Z{} D{}",
        n4(sx),
        n4(sz),
        n4(r.range(0.0, 1.0))
    );
    if cycle == "G70" {
        block.push_str(&format!(" E{} P{}", n4(r.range(0.0, 0.3)), 1 + r.pick(3)));
    } else {
        block.push_str(&format!(
            " I{} R{}",
            n4(r.range(0.2, 2.0)),
            n4(r.range(0.1, 1.0))
        ));
    }
    let units = if r.chance(0.5) { "G21" } else { "G20" };
    format!(
        "G18 {units} G90 G40\nF{}\n{sub}{block}\nG1 X{} Z{}\nM2\n",
        50 + r.pick(450),
        n4(sx),
        n4(sz + 1.0)
    )
}

/// Random profiles: every cycle lampost runs equals rs274's moves; rs274 refuses the
/// cycles lampost refuses. A cycle lampost stops at its bound on the work is not run
/// by rs274 (on those, G71.2 and G72.2 with some pockets, rs274 never ends).
#[test]
fn g7x_moves_equal_rs274_on_random_profiles() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("g7x-random");
    let mut r = Rng(0x6737_7865_0a11_c0de);
    let (mut equal, mut refused, mut crashed, mut bounded) = (0, 0, 0, 0);
    let (mut moves, mut coordinates) = (0, 0);
    for n in 0..120 {
        let own = work.join(format!("p{n}"));
        std::fs::create_dir_all(&own).expect("folder");
        let prog = own.join("g7x.ngc");
        let text = random_cycle(&mut r);
        std::fs::write(&prog, &text).expect("write");
        let out = lampost(&[
            "trace",
            "--json",
            "--flavor",
            "linuxcnc",
            prog.to_str().expect("utf8"),
        ]);
        let err = stderr(&out);
        if !out.status.success() {
            assert!(
                err.contains("more than") || err.contains("G7"),
                "{text}\n{err}"
            );
            if err.contains("more than") {
                bounded += 1;
                continue;
            }
        }
        // rs274 always writes the rapid to the cycle's start: no move at all is a crash
        // (on some offsets that turn back at the profile's first piece rs274 reads past
        // its list and dies; lampost refuses them as not monotonic).
        let canon = rs274_to_end(&prog, &own)
            .or_else(|_| rs274_to_end(&prog, &own))
            .and_then(|c| {
                if c.is_empty() {
                    crashed += 1;
                    Err("rs274 wrote no move (it crashed)".to_string())
                } else {
                    Ok(c)
                }
            });
        match canon {
            Err(e) => {
                assert!(
                    !out.status.success() && err.contains("--> ") && err.contains("help: "),
                    "rs274 refuses\n{text}\n{e}\n{err}"
                );
                refused += 1;
            }
            Ok(canon) => {
                assert!(out.status.success(), "rs274 runs\n{text}\n{err}");
                let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
                let (total, _) =
                    compare_with_rs274(&doc, &canon).unwrap_or_else(|e| panic!("{text}\n{e}"));
                equal += 1;
                moves += canon.len();
                coordinates += total;
            }
        }
    }
    eprintln!(
        "G70-G72: {equal} random profile cycles equal to rs274 ({moves} moves, {coordinates} coordinates), {refused} refused by both ({crashed} of them rs274 crashes on), {bounded} stopped at lampost's bound"
    );
    assert!(equal >= 85 && moves > 2_000, "{equal} {moves}");
}

const PROFILE: &str = "O100 SUB\nG0 X5 Z0\nG1 Z-10\nX10 Z-15\nO100 ENDSUB\n";

/// Blocks rs274 refuses: each a located error of lampost's, at the cycle's code (or the
/// word at fault), with the hint; where rs274 is installed, it refuses each too.
#[test]
fn g7x_refusals_are_located_where_rs274_refuses() {
    let head = format!("G21 G18\nF100\n{PROFILE}");
    // (lines after the profile, what lampost says, where: line:column)
    let cases: [(&str, &str, &str); 10] = [
        (
            "G71 X12 Z2 D0.5 I1 R0.3",
            "Q (the profile's O-word subroutine) is missing",
            "8:1",
        ),
        (
            "G17\nG71 Q100 X12 Z2 D0.5 I1 R0.3",
            "only in the XZ plane (G18)",
            "9:1",
        ),
        (
            "T1 M6\nG41\nG72 Q100 X12 Z2 D0.5 I1 R0.3",
            "cutter radius compensation is on",
            "10:1",
        ),
        (
            "G71 Q100 X12 Z2 D0.5 I0 R0.3",
            "I must be greater than zero",
            "8:1",
        ),
        (
            "G71 Q200 X12 Z2 D0.5 I1 R0.3",
            "no subroutine o200 sub in this file",
            "8:1",
        ),
        // A profile that turns back along Z.
        (
            "O101 SUB\nG0 X5 Z0\nG1 Z-10\nX8 Z-5\nO101 ENDSUB\nG71 Q101 X12 Z2",
            "G71: Not monotonic",
            "13:1",
        ),
        // Two pieces in one line: their offsets never meet (rs274's words).
        (
            "O101 SUB\nG0 X5 Z0\nG1 Z-5\nG1 Z-10\nO101 ENDSUB\nG71 Q101 X12 Z2 D0.5",
            "G71: Cannot intersect parallel lines",
            "13:1",
        ),
        (
            "O101 SUB\nG0 X5 Z0\nG1 X6 U1 Z-10\nO101 ENDSUB\nG71 Q101 X12 Z2",
            "Cannot use U and X in the same block",
            "10:1",
        ),
        (
            "O101 SUB\nG0 X5 Z0\nG2 X6 Z-10 R7 I1\nO101 ENDSUB\nG70 Q101 X12 Z2",
            "both R and I or K flag used for arc",
            "10:1",
        ),
        (
            "O101 SUB\nG0 X5 Z0\nG1 Z-10 A1 C1\nO101 ENDSUB\nG70 Q101 X12 Z2",
            "Both A and C parameters on a corner",
            "10:1",
        ),
    ];
    let rs274 = rs274().is_some();
    let work = tempdir("g7x-refusals");
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
        assert!(err.contains("help: G70/G71/G72 need Q"), "{block}: {err}");
        if rs274 {
            let own = work.join(format!("c{n}"));
            std::fs::create_dir_all(&own).expect("folder");
            let prog = own.join("c.ngc");
            std::fs::write(&prog, &src).expect("write");
            assert!(rs274_to_end(&prog, &own).is_err(), "rs274 runs {block}");
        }
    }
}

/// The work is bounded: 10,000 roughing passes (a depth of cut I far too small for the
/// profile), 10,000 finishing passes (P), 100,000 moves a block; each refused at the
/// cycle's code, in bounded time, before any of its cuts. 10,000 passes are made.
#[test]
fn g7x_passes_are_bounded() {
    let head = format!("G21 G18\nF100\n{PROFILE}");
    let run = |block: &str| {
        let src = format!("{head}{block}\nM2\n");
        lampost_stdin(
            &["trace", "--json", "--flavor", "linuxcnc", "-"],
            src.as_bytes(),
        )
    };
    for (block, why) in [
        (
            "G71 Q100 X12 Z2 D0.5 I0.0001 R0.3",
            "more than 10000 roughing passes",
        ),
        ("G70 Q100 X12 Z2 D0.5 P10001", "more than 10000 finishing passes"),
        (
            "O101 SUB\nG0 X5 Z0\nG1 Z-1 X6\nZ-2 X5\nZ-3 X6\nZ-4 X5\nZ-5 X6\nZ-6 X5\nZ-7 X6\nZ-8 X5\nZ-9 X6\nZ-10 X5\nO101 ENDSUB\nG70 Q101 X12 Z2 P9000",
            "more than 100000 moves",
        ),
        ("G70 Q100 X12 Z2 D0.5 P10000\nG70 Q100 X12 Z2 D0.5 P9000", ""),
    ] {
        let out = run(block);
        let err = stderr(&out);
        if why.is_empty() {
            // 10,000 passes of 4 moves (to the start, to the offset profile, its two
            // pieces) after the rapid to the start; the next block's 9,000 too.
            assert!(out.status.success(), "{err}");
            let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
            assert_eq!(
                doc["moves"].as_array().map(Vec::len),
                Some(1 + 4 * 10_000 + 1 + 4 * 9_000)
            );
            continue;
        }
        assert_eq!(out.status.code(), Some(1), "{err}");
        let at = 8 + block.lines().count() - 1;
        assert!(
            err.contains(why) && err.contains(&format!("--> <stdin>:{at}:1\n")),
            "{block}: {err}"
        );
        // None of the refused block's cuts is written.
        assert!(
            !String::from_utf8_lossy(&out.stdout).contains("\"G1\""),
            "{block}"
        );
    }
}

/// `auto` reads G70–G72 with a Q as LinuxCNC's cycles: the moves are rapids, feeds at F
/// and arcs in G18, with a warning that the cycle is a lathe's; the post refuses the
/// block with its line. A G70 with cutter compensation on (rs274 compensates it,
/// lampost does not) keeps its warning and draws no move.
#[test]
fn g7x_auto_warning_post_refusal_and_compensated_g70() {
    let src = format!("G21 G18\nF250\n{PROFILE}G71 Q100 X12 Z2 D0.5 I1 R0.3\nM2\n");
    let out = lampost_stdin(&["trace", "--json", "-"], src.as_bytes());
    assert!(out.status.success(), "{}", stderr(&out));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(doc["flavor"]["flavor"], "linuxcnc");
    let moves = doc["moves"].as_array().expect("moves");
    assert!(moves.len() > 20, "{}", moves.len());
    // The rapid to the start, then the first pass: down to X 12 - 1 along the
    // profile's first piece (offset 0.5 outward: X 11 is above it), the cut along -Z
    // to the offset profile, the retract (R 0.3 in X and Z) and back.
    assert_eq!(moves[0]["g"], "G0");
    assert!(moves.iter().all(|m| m["line"] == 8));
    assert!(moves
        .iter()
        .all(|m| m["g"] == "G0" || m["feed"].as_f64() == Some(250.0)));
    let out = lampost_stdin(&["check", "-"], src.as_bytes());
    let err = stderr(&out);
    assert!(
        out.status.success()
            && err.contains("warning: G71 is a lathe cycle")
            && err.contains("<stdin>:8:1"),
        "{err}"
    );
    let dir = tempdir("g7x-post");
    let inp = dir.join("rough.ngc");
    std::fs::write(&inp, &src).expect("write");
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
        err.contains("rough.ngc:8") && err.contains("G71") && err.contains("lathe"),
        "{err}"
    );
    assert!(!out_path.exists());
    // G70 under cutter compensation (G42.1 with its diameter): traced compensated, as
    // rs274 makes it (`cutter_comp_cli.rs` holds it to rs274), with its warning; the
    // post refuses the compensated path (and, first, the lathe cycle).
    let comp = format!(
        "G21 G18\nF250\n{PROFILE}G0 X14 Z4\nG42.1 D0.3 L2\nG70 Q100 X12 Z2 D0.5\nG40\nM2\n"
    );
    // From where the cycle starts, the entry move has no length: refused (rs274 too).
    let still = comp.replace("G0 X14 Z4", "G0 X12 Z2");
    let out = lampost_stdin(&["trace", "--flavor", "linuxcnc", "-"], still.as_bytes());
    let err = stderr(&out);
    assert!(
        !out.status.success()
            && err.contains("<stdin>:10:1")
            && err.contains("entry move is not greater than the tool radius"),
        "{err}"
    );
    let out = lampost_stdin(
        &["trace", "--json", "--flavor", "linuxcnc", "-"],
        comp.as_bytes(),
    );
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("G42.1: cutter radius compensation traced as LinuxCNC makes it")
            && !err.contains("not simulated"),
        "{err}"
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert!(doc["moves"].as_array().map_or(0, Vec::len) > 4, "{doc}");
    let inp = dir.join("comp.ngc");
    std::fs::write(&inp, &comp).expect("write");
    let out = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        inp.to_str().expect("utf8"),
        "-o",
        out_path.to_str().expect("utf8"),
    ]);
    assert!(!out.status.success());
    assert!(!out_path.exists());
}
