//! Issue 17: paper 001's demo part at full size (600 × 200 mm), planned by `lampost plan`
//! (not the analytic plate of robot_cli.rs), posted for the puma-lens cell in chunks for a
//! given controller memory, and verified by `lampost verify`. Fewer layers than a build
//! (20 mm apart) keep the test fast; the part, its placement and every pass's shape are
//! the full-size ones.

mod common;

use std::path::Path;

use common::*;

fn s(p: &Path) -> &str {
    p.to_str().unwrap_or_default()
}

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "failed: {}", stderr(o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The controller memory of the test: locations per file, the two safe ones included.
const MEMORY: usize = 4000;

#[test]
fn the_full_size_planned_plate_posts_and_verifies_on_puma_lens() {
    let dir = tempdir("robot-plate-full");
    let stl = dir.join("full.stl");
    ok(&lampost(&["plan", "demo", "-o", s(&stl)]));
    let info: serde_json::Value =
        serde_json::from_str(&ok(&lampost(&["mesh", "info", "--json", s(&stl)])))
            .unwrap_or_default();
    // Full size: 600 mm along the twisting edge, 200 mm across (built upwards).
    let (lo, hi) = (&info["bounds"]["min"], &info["bounds"]["max"]);
    let span = |k: usize| hi[k].as_f64().unwrap_or(0.0) - lo[k].as_f64().unwrap_or(0.0);
    assert!(
        (span(0) - 600.0).abs() < 1e-9 && (span(2) - 200.0).abs() < 1e-9,
        "{info}"
    );
    let csv = dir.join("full.csv");
    ok(&lampost(&[
        "plan",
        "path",
        s(&stl),
        "--layer",
        "20",
        "--approach",
        "build",
        "--hatch",
        "1.5",
        "--spacing",
        "2",
        "-o",
        s(&csv),
    ]));
    let cell = dir.join("cell");
    let memory = MEMORY.to_string();
    let o = lampost(&[
        "post",
        "--machine",
        "puma-lens",
        s(&csv),
        "-o",
        s(&cell),
        "--chunk-points",
        &memory,
    ]);
    ok(&o);
    let said = stderr(&o);
    assert!(
        said.contains(&format!("chunks of at most {MEMORY}")),
        "{said}"
    );
    let manifest: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(cell.join("manifest.json")).unwrap_or_default(),
    )
    .unwrap_or_default();
    let chunks = manifest["chunks"].as_array().cloned().unwrap_or_default();
    let sizes: Vec<usize> = chunks
        .iter()
        .map(|c| c["locations"].as_u64().unwrap_or(0) as usize)
        .collect();
    let locations = manifest["locations"].as_u64().unwrap_or(0) as usize;
    println!(
        "the full-size planned plate (10 layers): {locations} locations, {} chunks for a controller holding {MEMORY} locations: {sizes:?}",
        chunks.len()
    );
    assert!(chunks.len() >= 2, "{manifest}");
    assert!(sizes.iter().all(|&n| n > 2 && n <= MEMORY), "{sizes:?}");
    // Every path location in one chunk; each chunk's first path row reached laser off.
    assert_eq!(sizes.iter().map(|n| n - 2).sum::<usize>(), locations);
    for c in &chunks {
        let text = std::fs::read_to_string(cell.join(c["file"].as_str().unwrap_or("")))
            .unwrap_or_default();
        let first = text
            .lines()
            .filter(|l| !l.starts_with('#'))
            .nth(1)
            .unwrap_or_default();
        assert_eq!(
            first.split_whitespace().nth(10),
            Some("0"),
            "{}: {first}",
            c["file"]
        );
    }
    let v = ok(&lampost(&[
        "verify",
        "--machine",
        "puma-lens",
        s(&cell),
        "--input",
        s(&csv),
    ]));
    assert!(
        v.starts_with(&format!(
            "ok: {locations} locations in {} chunks",
            chunks.len()
        )),
        "{v}"
    );
    // The focus on the path and the approach along the beam, as the arm file asks.
    let num = |key: &str| {
        v.lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|x| x.trim().parse::<f64>().ok())
            .unwrap_or(f64::NAN)
    };
    assert!(num("max_focus_error") < 0.02, "{v}");
    assert!(num("max_axis_error_deg") < 0.01, "{v}");
}
