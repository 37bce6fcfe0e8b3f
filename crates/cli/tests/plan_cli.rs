//! Issue 15 items 4–7 through the CLI: `lampost plan demo` (paper 001's twisted plate),
//! `lampost plan path` with rasters, the offset-angle check (`--check-only`), the JSON
//! report and the SVG preview; the plate planned, posted on nrc-lc (through a pipe),
//! fadal-lamp and the puma-lens robot cell, verified, and the ISO program read by rs274.

mod common;

use std::path::{Path, PathBuf};

use common::*;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf8")
}

/// `plan demo` of the plate at a quarter scale (150 × 50 mm) into `stl`, in `units`.
fn write_plate(stl: &Path, units: &str) {
    let o = lampost(&[
        "plan",
        "demo",
        "--scale",
        "0.25",
        "--thickness",
        "3",
        "--along",
        "60",
        "--across",
        "10",
        "--units",
        units,
        "-o",
        s(stl),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// The quarter-scale plate in millimetres, written once for all the tests of this file
/// (a closed mesh; the tests only read it).
fn plate() -> PathBuf {
    static PLATE: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    PLATE
        .get_or_init(|| {
            let stl = tempdir("plan-plate-fixture").join("plate.stl");
            write_plate(&stl, "mm");
            let o = lampost(&["mesh", "info", "--json", s(&stl)]);
            let info: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
            assert_eq!(info["closed"], true, "{info}");
            stl
        })
        .clone()
}

#[test]
fn the_report_and_the_preview_say_what_the_path_holds() {
    let dir = tempdir("plan-report");
    let stl = plate();
    let (csv, svg) = (dir.join("p.csv"), dir.join("p.svg"));
    let o = lampost(&[
        "plan",
        "path",
        s(&stl),
        "--layer",
        "2",
        "--approach",
        "build",
        "--max-offset-angle",
        "30",
        "--feed",
        "500",
        "--json",
        "-o",
        s(&csv),
        "--preview",
        s(&svg),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let layers = r["slices"].as_array().expect("slices");
    assert_eq!(r["layers"], 25);
    assert_eq!(layers.len(), 25);
    // Lengths add up, and the path file holds them: laser-on length = perimeters +
    // rasters; the time is every move at the feed.
    let per: f64 = layers
        .iter()
        .map(|l| l["perimeter_length"].as_f64().unwrap_or(f64::NAN))
        .sum();
    let ras: f64 = layers
        .iter()
        .map(|l| l["raster_length"].as_f64().unwrap_or(f64::NAN))
        .sum();
    assert!((per - r["perimeter_length"].as_f64().unwrap_or(0.0)).abs() < 1e-6);
    let text = std::fs::read_to_string(&csv).expect("path");
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(2)
        .map(|l| l.split(' ').filter_map(|t| t.parse().ok()).collect())
        .collect();
    assert_eq!(rows.len() as u64, r["points"].as_u64().unwrap_or(0));
    let (mut on, mut off) = (0.0, 0.0);
    for w in rows.windows(2) {
        let d = ((w[1][0] - w[0][0]).powi(2)
            + (w[1][1] - w[0][1]).powi(2)
            + (w[1][2] - w[0][2]).powi(2))
        .sqrt();
        if w[1][7] == 1.0 {
            on += d;
        } else {
            off += d;
        }
    }
    assert!((on - per - ras).abs() < 1e-3, "{on} vs {}", per + ras);
    let t = r["time_s"].as_f64().unwrap_or(0.0);
    assert!((t - (on + off) / 500.0 * 60.0).abs() < 1e-3, "{t}");
    // The vertical approach on a wall leaning 45°: over the 30° limit.
    let worst = r["worst_offset_angle"].as_f64().unwrap_or(0.0);
    assert!(worst > 44.0, "{worst}");
    let count = r["violation_count"].as_u64().unwrap_or(0);
    assert!(count > 0);
    // The preview: one group per layer, a polyline per loop, a line per raster run, a red
    // mark per violation.
    let svg_text = std::fs::read_to_string(&svg).expect("svg");
    let doc = roxmltree::Document::parse(&svg_text).expect("svg parses");
    let groups: Vec<_> = doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("layer"))
        .collect();
    assert_eq!(groups.len(), 25);
    for (g, l) in groups.iter().zip(layers) {
        assert_eq!(
            g.attribute("data-layer")
                .and_then(|v| v.parse::<u64>().ok()),
            l["index"].as_u64()
        );
        let class_count = |c: &str| {
            g.descendants()
                .filter(|n| n.attribute("class") == Some(c))
                .count()
        };
        assert_eq!(class_count("loop") as u64, l["loops"].as_u64().unwrap_or(0));
        assert_eq!(
            class_count("raster") as u64,
            l["runs"].as_u64().unwrap_or(0)
        );
        assert!(class_count("tick") > 0);
        // Every drawn loop has its points.
        for pl in g
            .descendants()
            .filter(|n| n.attribute("class") == Some("loop"))
        {
            let pts = pl.attribute("points").unwrap_or("");
            assert!(pts.split_whitespace().count() > 10);
            for xy in pts.split_whitespace() {
                assert!(xy
                    .split(',')
                    .all(|v| v.parse::<f64>().is_ok_and(f64::is_finite)));
            }
        }
    }
    let red = doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("violation"))
        .count();
    assert_eq!(red as u64, count);
    assert!(doc
        .descendants()
        .any(|n| n.attribute("class") == Some("tick bad")));
}

#[test]
fn check_only_reports_the_layers_over_the_offset_angle() {
    let stl = plate();
    let o = lampost(&[
        "plan",
        "path",
        s(&stl),
        "--layer",
        "2",
        "--approach",
        "build",
        "--max-offset-angle",
        "30",
        "--check-only",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("layer 1: worst offset angle 4"), "{out}");
    assert!(stderr(&o).contains("over the offset angle of 30°"));
    assert!(
        stderr(&o).contains("warning: layer 1 loop 0 point "),
        "{}",
        stderr(&o)
    );
    // The tangent approach: nothing stays over (corners are tilted); no file written.
    let o = lampost(&[
        "plan",
        "path",
        s(&stl),
        "--layer",
        "2",
        "--max-offset-angle",
        "30",
        "--check-only",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(r["violation_count"], 0);
    assert!(r["worst_offset_angle"].as_f64().unwrap_or(99.0) <= 30.0);
    assert!(r["tilted"].as_u64().unwrap_or(0) > 0);
}

/// `plan demo --units in` writes the same plate in inches: planned with `--units in` it
/// gives the same report as the millimetre file.
#[test]
fn the_demo_in_inches_plans_like_the_demo_in_millimetres() {
    let dir = tempdir("plan-inch");
    let mm = plate();
    let inch = dir.join("plate-in.stl");
    write_plate(&inch, "in");
    let o = lampost(&["mesh", "info", "--json", s(&inch)]);
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    // Read without --units, the file's numbers: 75 mm is 2.9528 in.
    let hi = info["bounds"]["max"][0].as_f64().unwrap_or(0.0);
    assert!((hi - 75.0 / 25.4).abs() < 1e-9, "{info}");
    let report = |file: &Path, units: &[&str]| {
        let mut args = vec![
            "plan",
            "path",
            s(file),
            "--layer",
            "2",
            "--check-only",
            "--json",
        ];
        args.extend_from_slice(units);
        let o = lampost(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).expect("json")
    };
    let (a, b) = (report(&mm, &[]), report(&inch, &["--units", "in"]));
    // The same plate, to the STL's printed digits (a point more or less where a chord's
    // length over the spacing is a whole number).
    assert_eq!(a["layers"], b["layers"]);
    for k in [
        "points",
        "perimeter_length",
        "raster_length",
        "worst_offset_angle",
    ] {
        let (x, y) = (a[k].as_f64().unwrap_or(0.0), b[k].as_f64().unwrap_or(1.0));
        assert!((x - y).abs() <= 1e-3 * x.abs().max(1.0), "{k}: {x} vs {y}");
    }
}

#[test]
fn bad_plan_arguments_write_nothing() {
    let dir = tempdir("plan-bad");
    let stl = plate();
    let out = dir.join("out.csv");
    for extra in [
        &["--hatch", "0"][..],
        &["--bead", "-1"],
        &["--max-offset-angle", "0"],
        &["--max-offset-angle", "120"],
        &["--raster-angle", "nan"],
        &["--spacing", "0"],
        &["--hatch", "1e-7"],
        &["--spacing", "1e-9"],
        &["--max-turn", "0.0001"],
    ] {
        let mut args = vec!["plan", "path", s(&stl), "--layer", "2", "-o", s(&out)];
        args.extend_from_slice(extra);
        let o = lampost(&args);
        assert!(!o.status.success(), "{extra:?}");
        assert!(stderr(&o).contains("error"), "{extra:?}: {}", stderr(&o));
        assert!(!out.exists(), "{extra:?}");
    }
    // The report and the path cannot both go to standard output.
    let o = lampost(&["plan", "path", s(&stl), "--layer", "2", "--json"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(o.stdout.is_empty());
    for bad in [["--scale", "0"], ["--thickness", "-3"], ["--along", "0"]] {
        let stl2 = dir.join("bad.stl");
        let mut args = vec!["plan", "demo", "-o", s(&stl2)];
        args.extend_from_slice(&bad);
        let o = lampost(&args);
        assert!(!o.status.success() && !stl2.exists(), "{bad:?}");
    }
}

/// The posted program with the laser's M-codes (which LinuxCNC reads as its own modal
/// state codes M70–M73, or does not know) made comments, for rs274 and `trace` alike.
fn without_laser_codes(text: &str) -> String {
    text.lines()
        .map(|l| {
            let mut out = String::new();
            let mut words = l.split(' ').peekable();
            while let Some(w) = words.next() {
                if ["M71", "M72", "M73", "M74"].contains(&w) {
                    out.push_str(&format!("({w}"));
                    if words.peek().is_some_and(|n| n.starts_with('S')) {
                        out.push_str(&format!(" {}", words.next().unwrap_or("")));
                    }
                    out.push_str(") ");
                } else {
                    out.push_str(w);
                    out.push(' ');
                }
            }
            format!("{}\n", out.trim_end())
        })
        .collect()
}

/// Paper 001's plate, quarter scale, planned with rasters, posted on nrc-lc through a
/// pipe (`plan path … -o - | post --per-point -`), on fadal-lamp (the path in mm, the
/// machine in inches) and on puma-lens (chunked location files), each verified; rs274
/// reads the ISO program to the same moves as `lampost trace`.
///
/// The perimeters are planned with `--approach build` here, so that the same path also
/// reaches on the FADAL and the PUMA: with the tangent approach the FADAL needs X beyond
/// its travel where the axis leaves B's axis, and the PUMA's wrist refuses it (J4 turning
/// half a turn where the axis passes its singularity). The tangent approach on nrc-lc is
/// the next test.
#[test]
fn the_twisted_plate_is_planned_posted_and_verified_on_both_machines() {
    let dir = tempdir("plan-plate");
    let stl = plate();
    let plan_args = [
        "plan",
        "path",
        s(&stl),
        "--layer",
        "2",
        "--approach",
        "build",
        "--raster-angle",
        "90",
        "--raster-turn",
        "0",
        "--hatch",
        "1.5",
        "--spacing",
        "2",
    ];
    let mut to_stdout = plan_args.to_vec();
    to_stdout.extend_from_slice(&["-o", "-"]);
    let planned = lampost(&to_stdout);
    assert!(planned.status.success(), "{}", stderr(&planned));
    let csv = dir.join("plate.csv");
    std::fs::write(&csv, &planned.stdout).expect("path");
    let nrc = dir.join("plate-nrc.ngc");
    let o = lampost_stdin(
        &[
            "post",
            "--machine",
            "nrc-lc",
            "--per-point",
            "-",
            "-o",
            s(&nrc),
        ],
        &planned.stdout,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = lampost(&["verify", "--machine", "nrc-lc", s(&csv), s(&nrc)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("ok: "));
    let fadal = dir.join("plate-fadal.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--units",
        "mm",
        "--convert-units",
        s(&csv),
        "-o",
        s(&fadal),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = lampost(&[
        "verify",
        "--machine",
        "fadal-lamp",
        "--units",
        "mm",
        "--convert-units",
        s(&csv),
        s(&fadal),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("ok: "));
    // Issue 17's last item: the same path on the robot cell, in chunks, verified.
    let cell = dir.join("plate-puma");
    let o = lampost(&["post", "--machine", "puma-lens", s(&csv), "-o", s(&cell)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = lampost(&[
        "verify",
        "--machine",
        "puma-lens",
        s(&cell),
        "--input",
        s(&csv),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("ok: "));
    // Every raster run of the path is deposited: laser-on moves in the program.
    let posted = std::fs::read_to_string(&nrc).expect("posted");
    let ons = posted.matches("M73").count();
    let runs = String::from_utf8_lossy(&planned.stdout)
        .lines()
        .skip(2)
        .filter(|l| l.ends_with(" 0"))
        .count();
    assert_eq!(ons, runs, "one laser-on per run and loop");
    if require_rs274().is_none() {
        return;
    }
    let readable = dir.join("plate-rs274.ngc");
    std::fs::write(&readable, without_laser_codes(&posted)).expect("write");
    let canon = rs274_to_end(&readable, &dir).expect("rs274 reads the posted program");
    let o = lampost(&["trace", "--json", "--units", "mm", s(&readable)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let (total, _) = compare_with_rs274(&doc, &canon).expect("the same moves");
    assert!(total > 6 * 1000, "{total}");
}

/// The plate with paper 001's tangent approach on nrc-lc: the tool axis passes through
/// the C axis (vertical) mid-loop, where C's angle is free; the post turns C in place
/// there with the process off (a warning names the line) instead of one five-axis feed
/// that swept the table half a turn (its inverse-time F overflowed the word).
#[test]
fn the_plate_with_the_tangent_approach_posts_on_nrc_lc() {
    let dir = tempdir("plan-plate-tangent");
    let stl = plate();
    let csv = dir.join("plate.csv");
    let o = lampost(&[
        "plan",
        "path",
        s(&stl),
        "--layer",
        "2",
        "--spacing",
        "2",
        "--hatch",
        "1.5",
        "--raster-angle",
        "90",
        "--raster-turn",
        "0",
        "-o",
        s(&csv),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let nc = dir.join("plate.nc");
    let o = lampost(&["post", "--machine", "nrc-lc", s(&csv), "-o", s(&nc)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("turns") && stderr(&o).contains("in place with the process off"),
        "{}",
        stderr(&o)
    );
    let o = lampost(&["verify", "--machine", "nrc-lc", s(&csv), s(&nc)]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Every inverse-time F is within the ISO word and no block is given under 1 ms.
    let posted = std::fs::read_to_string(&nc).expect("posted");
    let mut inverse = false;
    for l in posted.lines() {
        inverse = (inverse || l.contains("G93")) && !l.contains("G94");
        if let (true, Some(f)) = (
            inverse,
            l.split_whitespace().find_map(|w| w.strip_prefix('F')),
        ) {
            let f: f64 = f.parse().expect("F");
            assert!(f > 0.0 && f <= 60_000.0 + 1e-6, "{l}");
        }
    }
}
