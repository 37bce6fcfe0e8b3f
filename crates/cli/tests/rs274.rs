//! `lampost trace` against LinuxCNC's own interpreter, rs274, on the LinuxCNC corpus.
//!
//! rs274 prints positions with 4 decimals, so each of our end points, rounded the same
//! way, must equal its value (we allow half a unit of the last printed digit plus 1e-9).

mod common;

use common::*;

#[test]
fn trace_matches_rs274_on_linuxcnc_corpus() {
    let Some(shared) = shared() else {
        eprintln!("SKIPPED: ../shared not present");
        return;
    };
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("rs274");
    let mut total = 0usize;
    let mut exact = 0usize;
    let dir = shared.join("corpus/linuxcnc");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("corpus")
        .flatten()
        .map(|e| e.path())
        .collect();
    files.sort();
    files.push(root().join("fixtures/programs/features.ngc"));
    assert!(!files.is_empty());
    for path in files {
        let text = std::fs::read_to_string(&path).expect("read");
        let prog = work.join(path.file_name().expect("name"));
        std::fs::write(&prog, prepare(&text)).expect("write");
        let canon = rs274_motions(&prog, &work);
        let out = lampost(&["trace", "--json", prog.to_str().expect("utf8")]);
        assert!(
            out.status.success(),
            "trace failed on {}: {}",
            path.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
        let (n, same) =
            compare_with_rs274(&doc, &canon).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        total += n;
        exact += same;
    }
    eprintln!(
        "rs274 comparison: {total} coordinates, {exact} identical after rounding to 4 decimals"
    );
    assert!(total > 10_000);
}

/// A posted ISO program (machining, so only standard M-codes) read by rs274 gives the same
/// joint trace as `lampost trace` of it.
#[test]
fn posted_iso_output_reads_the_same_in_rs274() {
    if shared().is_none() || require_rs274().is_none() {
        return;
    }
    let work = tempdir("rs274-post");
    let fx = |n: &str| {
        root()
            .join("fixtures/post")
            .join(n)
            .to_string_lossy()
            .into_owned()
    };
    let runs: Vec<Vec<String>> = vec![
        vec![
            "--machine".into(),
            "fadal-lamp".into(),
            "--index".into(),
            "A=30,B=-20".into(),
            "--process".into(),
            "machine".into(),
            "--tool".into(),
            "2".into(),
            "--length-offset".into(),
            "2".into(),
            fx("facing.nc"),
        ],
        vec![
            "--machine".into(),
            "fadal-lamp".into(),
            "--process".into(),
            "machine".into(),
            "--layer-axis".into(),
            "0,1,0".into(),
            "--layer-angle".into(),
            "3".into(),
            fx("wall.nc"),
        ],
        vec![
            "--machine".into(),
            "fadal-lamp".into(),
            "--process".into(),
            "machine".into(),
            "--job".into(),
            fx("bearing-seat/job.toml"),
        ],
    ];
    let mut total = 0;
    for (k, extra) in runs.iter().enumerate() {
        let out = work.join(format!("posted-{k}.ngc"));
        let mut args: Vec<&str> = vec![
            "post",
            "--dialect",
            "iso",
            "-o",
            out.to_str().expect("utf8"),
        ];
        args.extend(extra.iter().map(String::as_str));
        let o = lampost(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let canon = rs274_motions(&out, &work);
        let o = lampost(&[
            "trace",
            "--json",
            "--units",
            "inch",
            out.to_str().expect("utf8"),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
        let moves = doc["moves"].as_array().expect("moves");
        assert_eq!(
            moves.len(),
            canon.len(),
            "run {k}: {} moves, rs274 {}",
            moves.len(),
            canon.len()
        );
        for (m, c) in moves.iter().zip(&canon) {
            let end = &m["end"];
            let ours: Vec<f64> = if c.kind == "ARC_FEED" {
                vec![
                    axis(end, "X"),
                    axis(end, "Y"),
                    axis(end, "Z"),
                    axis(end, "A"),
                    axis(end, "B"),
                ]
            } else {
                ["X", "Y", "Z", "A", "B"]
                    .iter()
                    .map(|a| axis(end, a))
                    .collect()
            };
            let theirs: Vec<f64> = if c.kind == "ARC_FEED" {
                vec![c.args[0], c.args[1], c.args[5], c.args[6], c.args[7]]
            } else {
                c.args[..5].to_vec()
            };
            for (a, b) in ours.iter().zip(&theirs) {
                total += 1;
                assert!(
                    (a - b).abs() <= RS274_TOL,
                    "run {k}, posted line {}: lampost {a} vs rs274 {b}",
                    m["line"]
                );
            }
        }
    }
    eprintln!("posted programs through rs274: {total} joint coordinates agree");
    assert!(total > 100);
}

/// Canned cycles where LinuxCNC's reading was not lampost's (found by random programs
/// against rs274): G84 feeds out all the way to the clearance level (G98: the initial Z)
/// with no rapid; G83 and G73 pecks are each Q below the last in floating point while
/// above the bottom, so rounding can add a last short feed. Both equal rs274.
#[test]
fn tapping_and_peck_rounding_equal_rs274() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("rs274-cycles");
    let prog = work.join("cycles.ngc");
    let text = "G21 G17 G90 G94\nF100 S500 M3\nG0 X0 Y0 Z10\n\
                G98 G84 X1 Y1 R2 Z-5\nG99 G84 X3 Y1 R2 Z-5\nG80\n\
                G20\nG0 X0 Y0 Z1\nG98 G83 X0 R0.5 Z0.2 Q0.1\nG80\n\
                G0 X1 Y1 Z-0.604\nG91 G83 Q.2 X0.5 R0.281 Z-0.4\nG90 G80\n\
                G0 Z1\nG73 X2 Y2 R0.5 Z0.2 Q0.1\nG80\nM2\n";
    std::fs::write(&prog, text).expect("write");
    let canon = rs274_motions(&prog, &work);
    let o = lampost(&[
        "trace",
        "--json",
        "--flavor",
        "linuxcnc",
        prog.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let (moves, _) = compare_with_rs274(&doc, &canon).expect("equal to rs274");
    assert!(moves > 30, "{moves}");
}

/// Straight probes (G38.x) with no contact: rs274's simulator trips them at their
/// programmed end and backs the tool off 0.01 in (0.254 mm) towards the start, while
/// `#5061`… hold the programmed end and `#5420`… the backed-off position. Probes in
/// several directions (diagonal, with a rotary, under G92 and G55), then incremental
/// moves and moves to the parameters, in mm and inch, equal rs274.
#[test]
fn probes_back_off_as_rs274_simulates() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("rs274-probes");
    let prog = work.join("probes.ngc");
    let text = "G21 G17 G90 G94 F100\nG0 X0 Y0 Z10\n\
                G38.2 Z-5\nG91 G1 X1\nG90 G1 X[#5420+2] Y#5061 Z#5063\n\
                G38.3 X7 Y-3 Z1 A30\nG1 X#5420 Y#5421 Z[#5422+1]\n\
                G92 X0 Y0\nG38.4 X-4 Y4\nG91 G1 Y1\nG90 G92.1\n\
                G55 G38.5 Z20\nG1 X#5061 Y#5062\nG54\n\
                G38.5 Z#5422\nG1 Z[#5422+3]\nG38.2 A45\n\
                G20\nG0 X0 Y0 Z1\nG38.2 Z-0.3\nG91 G38.3 X-0.5 Y0.25\nG90\n\
                G1 X[#5420+#5061] Y#5421 Z#5422\nM2\n";
    std::fs::write(&prog, text).expect("write");
    let canon = rs274_motions(&prog, &work);
    let o = lampost(&[
        "trace",
        "--json",
        "--flavor",
        "linuxcnc",
        prog.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let (values, _) = compare_with_rs274(&doc, &canon).expect("equal to rs274");
    assert!(values > 90, "{values}");
    // The G0 after the first probe starts backed off: 0.254 mm above Z-5.
    let moves = doc["moves"].as_array().expect("moves");
    assert!((axis(&moves[3]["start"], "Z") - (-5.0 + 0.254)).abs() < 1e-9);
    // A G38.2 or G38.4 that does not move is refused, by rs274 and by lampost, at its
    // code; G38.3 and G38.5 may stand still, and one that turns only A is run (above).
    for code in ["G38.2", "G38.4"] {
        let text = format!("G21 F100\nG0 X1 Y2 Z3\n{code} Z3\nM2\n");
        let prog = work.join("still.ngc");
        std::fs::write(&prog, &text).expect("write");
        assert!(rs274_to_end(&prog, &work).is_err(), "rs274 runs {code}");
        let o = lampost(&[
            "trace",
            "--flavor",
            "linuxcnc",
            prog.to_str().expect("utf8"),
        ]);
        assert!(!o.status.success());
        assert!(
            stderr(&o).contains("3:1") || stderr(&o).contains("line 3"),
            "{}",
            stderr(&o)
        );
        assert!(stderr(&o).contains("start point too close to probe point"));
    }
}
