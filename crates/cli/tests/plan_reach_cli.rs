//! Issue 15 item 6's machine reach: `lampost plan path --machine M` solves every point of
//! the path by the machine's inverse kinematics as `lampost post` places it, reports the
//! extent of each axis against its travel (`reach` in the JSON), and refuses a path with
//! a point beyond reach (the first one named by layer, point and path line; nothing
//! written). The verdicts agree with the post's.

mod common;

use std::path::{Path, PathBuf};

use common::*;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf8")
}

/// Paper 001's plate at a quarter scale (150 × 75 × 50 mm), centred on x = 0.
fn plate(dir: &Path) -> PathBuf {
    let stl = dir.join("plate.stl");
    let o = lampost(&[
        "plan",
        "demo",
        "--scale",
        "0.25",
        "--along",
        "60",
        "--across",
        "10",
        "-o",
        s(&stl),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    stl
}

/// The rows of a path file (`x y z i j k feed laser`).
fn rows(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .expect("path")
        .lines()
        .skip(2)
        .map(|l| l.split(' ').filter_map(|t| t.parse().ok()).collect())
        .collect()
}

fn plan_path(stl: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "plan",
        "path",
        s(stl),
        "--layer",
        "2",
        "--approach",
        "build",
        "--max-offset-angle",
        "60",
    ];
    args.extend_from_slice(extra);
    lampost(&args)
}

#[test]
fn a_vertical_build_on_nrc_lc_uses_the_tips_extent_on_x_and_y() {
    let dir = tempdir("plan-reach-ok");
    let stl = plate(&dir);
    let csv = dir.join("p.csv");
    let o = plan_path(&stl, &["--machine", "nrc-lc", "--json", "-o", s(&csv)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let reach = &r["reach"];
    assert_eq!(reach["machine"], "nrc-lc");
    assert_eq!(reach["reachable"], true, "{reach}");
    assert_eq!(reach["unreachable"], 0);
    assert_eq!(reach["points"], r["points"]);
    assert!(reach["first_unreachable"].is_null());
    let rows = rows(&csv);
    assert_eq!(rows.len() as u64, r["points"].as_u64().unwrap_or(0));
    // nrc-lc moves the table in X and Y: at B = 0 (a vertical tool axis, along C, which
    // keeps its starting 0) the tip x sits at X = −x, y at Y = −y, z at Z = z.
    let range = |k: usize| {
        rows.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
                (lo.min(r[k]), hi.max(r[k]))
            })
    };
    let axes = reach["axes"].as_array().expect("axes");
    let names: Vec<&str> = axes.iter().filter_map(|a| a["axis"].as_str()).collect();
    assert_eq!(names, ["X", "Y", "Z", "B", "C"]);
    let used = |k: usize| {
        let u = &axes[k]["used"];
        (
            u[0].as_f64().unwrap_or(f64::NAN),
            u[1].as_f64().unwrap_or(f64::NAN),
        )
    };
    for (k, sign) in [(0, -1.0), (1, -1.0), (2, 1.0)] {
        let (lo, hi) = range(k);
        let want = if sign < 0.0 { (-hi, -lo) } else { (lo, hi) };
        let got = used(k);
        // The file holds the points to 6 decimals.
        assert!(
            (got.0 - want.0).abs() < 2e-6 && (got.1 - want.1).abs() < 2e-6,
            "axis {}: {got:?} vs {want:?}",
            names[k]
        );
        let lim = &axes[k]["limits"];
        assert!(lim[0].as_f64().unwrap_or(0.0) <= got.0 && got.1 <= lim[1].as_f64().unwrap_or(0.0));
    }
    assert_eq!(used(3), (0.0, 0.0));
    // C is continuous: no limits.
    assert!(axes[4]["limits"].is_null());
    // The post agrees: the same path posts on nrc-lc.
    let nc = dir.join("p.ngc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--per-point",
        s(&csv),
        "-o",
        s(&nc),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Without --machine the report says nothing of reach.
    let o = plan_path(&stl, &["--json", "--check-only"]);
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert!(r["reach"].is_null(), "{r}");
    // --check-only prints each axis's extent.
    let o = plan_path(&stl, &["--check-only", "--machine", "nrc-lc"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("reach on nrc-lc: every point"), "{out}");
    assert!(
        out.contains("  X -75.") && out.contains("of -250 .. 250"),
        "{out}"
    );
}

#[test]
fn a_path_moved_beyond_the_travel_is_refused_at_its_first_unreachable_point() {
    let dir = tempdir("plan-reach-far");
    let stl = plate(&dir);
    // Planned without a machine: the path, to find the first point beyond X's travel.
    let free = dir.join("free.csv");
    let o = plan_path(&stl, &["-o", s(&free)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = rows(&free);
    // Moved 201.37 mm along +x, the table's X = −(x + 201.37) passes −250 where
    // x > 48.63 (no point of the path lies within 1e-3 of it).
    let first = rows
        .iter()
        .position(|r| r[0] > 48.63 + 1e-3)
        .expect("a point beyond");
    assert!(rows.iter().take(first).all(|r| r[0] < 48.63 - 1e-3));
    let csv = dir.join("p.csv");
    let svg = dir.join("p.svg");
    let o = plan_path(
        &stl,
        &[
            "--machine",
            "nrc-lc",
            "--origin",
            "201.37,0,0",
            "--json",
            "-o",
            s(&csv),
            "--preview",
            s(&svg),
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    // Nothing written; the error names the layer, the point and its line in the path.
    assert!(!csv.exists() && !svg.exists());
    let err = stderr(&o);
    assert!(
        err.contains(&format!("first: layer 0, point {first} ")),
        "{err}"
    );
    assert!(err.contains(&format!("path line {}", first + 3)), "{err}");
    assert!(err.contains("beyond the reach of nrc-lc"), "{err}");
    assert!(err.contains("X = "), "{err}");
    // The JSON report still says why.
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let reach = &r["reach"];
    assert_eq!(reach["reachable"], false);
    assert_eq!(reach["first_unreachable"]["point"], first as u64);
    assert_eq!(reach["first_unreachable"]["layer"], 0);
    let count = rows.iter().filter(|r| r[0] > 48.63).count() as u64;
    assert_eq!(reach["unreachable"], count);
    let x = &reach["axes"][0];
    assert!(x["used"][0].as_f64().unwrap_or(0.0) >= -250.0 - 1e-9);
    // The post refuses the same placement.
    let nc = dir.join("p.ngc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--per-point",
        s(&free),
        "--origin",
        "201.37,0,0",
        "-o",
        s(&nc),
    ]);
    assert!(!o.status.success());
    assert!(!nc.exists());
}

#[test]
fn the_full_size_plate_is_beyond_nrc_lc_and_the_placing_flags_need_a_machine() {
    let dir = tempdir("plan-reach-full");
    let stl = dir.join("plate.stl");
    let o = lampost(&[
        "plan",
        "demo",
        "--along",
        "60",
        "--across",
        "10",
        "-o",
        s(&stl),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = lampost(&[
        "plan",
        "path",
        s(&stl),
        "--layer",
        "5",
        "--approach",
        "build",
        "--max-offset-angle",
        "60",
        "--hollow",
        "--machine",
        "nrc-lc",
        "--check-only",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    // 600 mm along x against X's ±250 mm of travel. The plate's top edge is at
    // z = 200·cos ψ with ψ = 45°·x/300: beyond |x| = 250 the layers end below
    // 200·cos 37.5° = 158.7 mm, so layers 0 to 31 (2.5 + 5k mm) are out, 32 to 39 are in.
    let layers: Vec<u64> = r["reach"]["unreachable_layers"]
        .as_array()
        .expect("layers")
        .iter()
        .filter_map(serde_json::Value::as_u64)
        .collect();
    assert_eq!(r["layers"], 40);
    assert_eq!(layers, (0..32).collect::<Vec<u64>>());
    assert_eq!(r["reach"]["first_unreachable"]["layer"], 0);
    for flag in [
        ["--origin", "1,2,3"],
        ["--near", "B=0,C=0"],
        ["--head", "laser"],
    ] {
        let o = lampost(&[
            "plan",
            "path",
            s(&stl),
            "--layer",
            "5",
            "--check-only",
            flag[0],
            flag[1],
        ]);
        assert_eq!(o.status.code(), Some(2), "{flag:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("give --machine too"));
    }
    // A machine that is not there.
    let o = lampost(&[
        "plan",
        "path",
        s(&stl),
        "--layer",
        "5",
        "--check-only",
        "--machine",
        "no-such",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
