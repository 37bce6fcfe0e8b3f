//! `lampost trace` against LinuxCNC's own interpreter, rs274, on the LinuxCNC corpus.
//!
//! rs274 prints positions with 4 decimals, so each of our end points, rounded the same
//! way, must equal its value (we allow half a unit of the last printed digit plus 1e-9).

mod common;

use common::*;

/// rs274's printed resolution: half of 1e-4, plus rounding slack.
const TOL: f64 = 0.5e-4 + 1e-9;

/// Drop what standalone rs274 cannot run: LinuxCNC's TCP mode switches (M428/M429,
/// which only the machine's kinematics module knows) and HAL pin reads.
fn prepare(text: &str) -> String {
    text.lines()
        .filter(|l| {
            let t = l.trim().to_ascii_lowercase();
            !(t.starts_with("m428") || t.starts_with("m429") || t.contains("_hal["))
        })
        .map(|l| format!("{l}\n"))
        .collect()
}

fn axis(v: &serde_json::Value, a: &str) -> f64 {
    v.get(a).and_then(serde_json::Value::as_f64).unwrap_or(0.0)
}

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
        let moves = doc["moves"].as_array().expect("moves");
        assert_eq!(
            moves.len(),
            canon.len(),
            "{}: {} moves, rs274 {}",
            path.display(),
            moves.len(),
            canon.len()
        );
        for (m, c) in moves.iter().zip(&canon) {
            let end = &m["end"];
            let g = m["g"].as_str().expect("g");
            let (ours, theirs): (Vec<f64>, Vec<f64>) = match c.kind.as_str() {
                "ARC_FEED" => {
                    assert!(
                        g == "G2" || g == "G3",
                        "{}: line {} is {g}, rs274 ARC_FEED",
                        path.display(),
                        m["line"]
                    );
                    let plane = m["kind"]["plane"].as_str().expect("plane");
                    let (u, v, n, ui, vi) = match plane {
                        "XY" => ("X", "Y", "Z", 0, 1),
                        "XZ" => ("Z", "X", "Y", 2, 0),
                        _ => ("Y", "Z", "X", 1, 2),
                    };
                    let center = m["kind"]["center"].as_array().expect("center");
                    let turns = m["kind"]["turns"].as_f64().expect("turns");
                    let rot = if g == "G2" { -turns } else { turns };
                    let ours = vec![
                        axis(end, u),
                        axis(end, v),
                        center[ui].as_f64().expect("c"),
                        center[vi].as_f64().expect("c"),
                        rot,
                        axis(end, n),
                        axis(end, "A"),
                        axis(end, "B"),
                        axis(end, "C"),
                    ];
                    (ours, c.args[..9].to_vec())
                }
                kind => {
                    let want = if kind == "STRAIGHT_TRAVERSE" {
                        "G0"
                    } else {
                        "G1"
                    };
                    assert_eq!(
                        g,
                        want,
                        "{}: our line {} vs rs274 {kind}",
                        path.display(),
                        m["line"]
                    );
                    let ours = ["X", "Y", "Z", "A", "B", "C"]
                        .iter()
                        .map(|a| axis(end, a))
                        .collect();
                    (ours, c.args[..6].to_vec())
                }
            };
            for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
                total += 1;
                if format!("{a:.4}").parse::<f64>().ok() == Some(*b) {
                    exact += 1;
                }
                assert!(
                    (a - b).abs() <= TOL,
                    "{}: source line {}, value {i}: lampost {a} vs rs274 {b} (rs274 output line {})",
                    path.display(), m["line"], c.line
                );
            }
        }
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
                    (a - b).abs() <= TOL,
                    "run {k}, posted line {}: lampost {a} vs rs274 {b}",
                    m["line"]
                );
            }
        }
    }
    eprintln!("posted programs through rs274: {total} joint coordinates agree");
    assert!(total > 100);
}
