//! Issue 15 item 1's 3MF input through the CLI: a real package (the 3MF Consortium's box,
//! `fixtures/meshes/3mf/`) read in the units it says, sliced and planned; a 3MF with
//! `--units` refused; a cut or corrupt package and a package without its model refused
//! with their place, nothing written (NaN vertices, bad indices, units and transforms:
//! `crates/mesh/src/threemf.rs`'s tests).

mod common;

use std::path::{Path, PathBuf};

use common::*;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf8")
}

fn fixture(name: &str) -> PathBuf {
    root().join("fixtures/meshes/3mf").join(name)
}

#[test]
fn the_consortiums_box_reads_slices_and_plans() {
    let o = lampost(&["mesh", "info", "--json", s(&fixture("box.3mf"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(v["closed"], true, "{v}");
    assert_eq!(v["volume"], 6000.0, "{v}");
    // 30 mm tall at 1 mm layers: 30 layers of one 10 × 20 loop each.
    let o = lampost(&[
        "plan",
        "slice",
        s(&fixture("box.3mf")),
        "--layer",
        "1",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let layers = v["slices"].as_array().expect("slices");
    assert_eq!(layers.len(), 30);
    for l in layers {
        assert_eq!(l["loops"].as_array().map(Vec::len), Some(1), "{l}");
        assert!(
            (l["area"].as_f64().unwrap_or(0.0) - 200.0).abs() < 1e-9,
            "{l}"
        );
    }
    // The whole plan, with the reach on nrc-lc.
    let dir = tempdir("plan-3mf");
    let csv = dir.join("box.csv");
    let o = lampost(&[
        "plan",
        "path",
        s(&fixture("box.3mf")),
        "--layer",
        "1",
        "--machine",
        "nrc-lc",
        "-o",
        s(&csv),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&csv).expect("path").lines().count() > 100);
    // Two placements of one object (build items with transforms, components): the same.
    let a = lampost(&["mesh", "info", "--json", s(&fixture("items-transform.3mf"))]);
    let b = lampost(&["mesh", "info", "--json", s(&fixture("components.3mf"))]);
    assert!(a.status.success() && b.status.success());
    let (a, b): (serde_json::Value, serde_json::Value) = (
        serde_json::from_slice(&a.stdout).expect("json"),
        serde_json::from_slice(&b.stdout).expect("json"),
    );
    assert_eq!(a["volume"], b["volume"]);
    assert_eq!(a["triangles"], b["triangles"]);
}

#[test]
fn bad_3mf_input_is_refused_with_its_place() {
    let dir = tempdir("plan-3mf-bad");
    // --units with a file that says its own.
    let o = lampost(&[
        "plan",
        "slice",
        s(&fixture("box.3mf")),
        "--layer",
        "1",
        "--units",
        "in",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("a 3MF file says its units"),
        "{}",
        stderr(&o)
    );
    // Cut short: no directory at its end.
    let good = std::fs::read(fixture("box.3mf")).expect("box");
    let cut = dir.join("cut.3mf");
    std::fs::write(&cut, &good[..good.len() / 2]).expect("write");
    let out = dir.join("loops.csv");
    let o = lampost(&["plan", "slice", s(&cut), "--layer", "1", "-o", s(&out)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("end-of-central-directory"),
        "{}",
        stderr(&o)
    );
    assert!(
        stderr(&o).contains("= help: export the 3MF again"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
    // A byte of the compressed model changed: caught (CRC or DEFLATE), nothing written.
    let mut bad = good.clone();
    let mid = bad.len() / 3;
    bad[mid] ^= 0x55;
    let p = dir.join("flipped.3mf");
    std::fs::write(&p, &bad).expect("write");
    let o = lampost(&["plan", "slice", s(&p), "--layer", "1", "-o", s(&out)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("3D/3dmodel.model"), "{}", stderr(&o));
    assert!(!out.exists());
    // A ZIP without a model part: named. (A content-sniffed file without extension.)
    let zip = dir.join("nomodel");
    let mut z = good.clone();
    // Rename the model part in both headers: "3D/3dmodel.model" -> "3D/3dmodel.modex".
    let name = b"3D/3dmodel.model";
    let mut i = 0;
    while let Some(at) = z[i..].windows(name.len()).position(|w| w == name) {
        z[i + at + name.len() - 1] = b'x';
        i += at + name.len();
    }
    std::fs::write(&zip, &z).expect("write");
    let o = lampost(&["mesh", "info", s(&zip)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("no 3D model part"), "{}", stderr(&o));
}
