//! `lampost mesh info` and `lampost plan slice` as a user runs them: figures, the bad
//! edges, located errors, and nothing written on a refusal.

mod common;

use common::*;
use lampost_mesh::{box_mesh, torus, uv_sphere, write_ascii_stl, write_off, P3};

fn json(o: &std::process::Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("json")
}

fn f(v: &serde_json::Value) -> f64 {
    v.as_f64().expect("number")
}

#[test]
fn info_reports_counts_bounds_area_volume_in_mm() {
    let dir = tempdir("mesh-info");
    let p = dir.join("block.obj");
    let obj = "v 0 0 0\nv 2 0 0\nv 2 3 0\nv 0 3 0\nv 0 0 4\nv 2 0 4\nv 2 3 4\nv 0 3 4\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    std::fs::write(&p, obj).expect("write");
    let ps = p.to_str().expect("utf-8");
    let v = json(&lampost(&["mesh", "info", ps, "--json"]));
    assert_eq!(v["triangles"], 12);
    assert_eq!(v["vertices"], 8);
    assert!((f(&v["volume"]) - 24.0).abs() < 1e-12);
    assert!((f(&v["area"]) - 52.0).abs() < 1e-12);
    assert_eq!(v["closed"], true);
    assert_eq!(v["oriented"], true);
    // In inches: every figure scaled to mm.
    let v = json(&lampost(&["mesh", "info", ps, "--json", "--units", "in"]));
    assert_eq!(v["file_units"], "in");
    assert!((f(&v["bounds"]["max"][2]) - 4.0 * 25.4).abs() < 1e-12);
    assert!((f(&v["volume"]) - 24.0 * 25.4f64.powi(3)).abs() < 1e-6);
    // Standard input: the format from the content.
    let v = json(&lampost_stdin(
        &["mesh", "info", "-", "--json"],
        obj.as_bytes(),
    ));
    assert_eq!(v["triangles"], 12);
    let text = lampost(&["mesh", "info", ps]);
    assert!(text.status.success());
    let t = String::from_utf8_lossy(&text.stdout);
    assert!(
        t.contains("triangles 12") && t.contains("closed and oriented"),
        "{t}"
    );
}

#[test]
fn info_names_the_bad_edges_of_an_open_mesh() {
    let dir = tempdir("mesh-open");
    let mut m = box_mesh(P3::zeros(), P3::new(1.0, 1.0, 1.0));
    m.triangles.pop();
    let p = dir.join("open.stl");
    std::fs::write(&p, write_ascii_stl(&m, "open")).expect("write");
    let ps = p.to_str().expect("utf-8");
    let v = json(&lampost(&["mesh", "info", ps, "--json"]));
    assert_eq!(v["closed"], false);
    assert_eq!(v["boundary_edges"], 3);
    assert!(v["volume"].is_null());
    let edges = v["bad_edges"].as_array().expect("edges");
    assert_eq!(edges.len(), 3);
    assert!(edges
        .iter()
        .all(|e| e["problem"] == "boundary" && e["faces"] == 1));
    let t = lampost(&["mesh", "info", ps]);
    let t = String::from_utf8_lossy(&t.stdout);
    assert_eq!(t.matches("edge boundary").count(), 3, "{t}");
}

#[test]
fn bad_files_are_located_errors() {
    let dir = tempdir("mesh-bad");
    let nan = dir.join("nan.obj");
    std::fs::write(&nan, "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n").expect("write");
    let o = lampost(&["mesh", "info", nan.to_str().expect("utf-8")]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("nan.obj:2:7") && e.contains("v 1 0 nan") && e.contains("help:"),
        "{e}"
    );
    // A binary STL one triangle short of its count.
    let m = box_mesh(P3::zeros(), P3::new(1.0, 1.0, 1.0));
    let mut b = vec![b' '; 80];
    b.extend_from_slice(&12u32.to_le_bytes());
    b.extend_from_slice(&vec![0u8; 50 * 11]);
    let short = dir.join("short.stl");
    std::fs::write(&short, &b).expect("write");
    let o = lampost(&["mesh", "info", short.to_str().expect("utf-8")]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("says 12 triangles") && e.contains("byte 80"),
        "{e}"
    );
    // OFF face naming a missing vertex.
    let off = dir.join("bad.off");
    let mut text = write_off(&m);
    text = text.replace("3 0 2 1", "3 0 2 99");
    std::fs::write(&off, text).expect("write");
    let o = lampost(&[
        "plan",
        "slice",
        off.to_str().expect("utf-8"),
        "--layer",
        "0.1",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("bad.off:11:7"), "{}", stderr(&o));
}

#[test]
fn slice_json_and_csv() {
    let dir = tempdir("slice");
    let p = dir.join("torus.off");
    std::fs::write(&p, write_off(&torus(P3::zeros(), 20.0, 5.0, 60, 30))).expect("write");
    let ps = p.to_str().expect("utf-8");
    let v = json(&lampost(&["plan", "slice", ps, "--layer", "1", "--json"]));
    assert_eq!(v["layers"], 10);
    assert_eq!(v["open_chains"], 0);
    for s in v["slices"].as_array().expect("slices") {
        let loops = s["loops"].as_array().expect("loops");
        assert_eq!(loops.len(), 2);
        let mut a: Vec<f64> = loops.iter().map(|l| f(&l["area"])).collect();
        a.sort_by(f64::total_cmp);
        assert!(a[0] < 0.0 && a[1] > 0.0);
    }
    let csv = dir.join("loops.csv");
    let o = lampost(&[
        "plan",
        "slice",
        ps,
        "--layer",
        "1",
        "-o",
        csv.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).expect("csv");
    assert!(text.starts_with("layer,loop,point,x,y,z,face\n"));
    let rows = text.lines().count() - 1;
    let points: u64 = v["slices"]
        .as_array()
        .expect("slices")
        .iter()
        .flat_map(|s| {
            s["loops"]
                .as_array()
                .expect("loops")
                .iter()
                .map(|l| l["points"].as_u64().expect("n"))
        })
        .sum();
    assert_eq!(rows as u64, points);
    // Tilted build direction, inches, a fan: all run.
    let v = json(&lampost(&[
        "plan",
        "slice",
        ps,
        "--layer",
        "0.5",
        "--build-dir",
        "1,0,1",
        "--units",
        "in",
        "--json",
    ]));
    assert!(v["layers"].as_u64().expect("n") > 10);
    let b = dir.join("beside.stl");
    std::fs::write(
        &b,
        write_ascii_stl(
            &box_mesh(P3::new(1.0, 0.0, -1.0), P3::new(3.0, 1.0, 1.0)),
            "b",
        ),
    )
    .expect("write");
    let v = json(&lampost(&[
        "plan",
        "slice",
        b.to_str().expect("utf-8"),
        "--fan-axis",
        "0,0,0,0,-1,0",
        "--fan-step",
        "10",
        "--json",
    ]));
    assert_eq!(v["layers"], 9);
}

#[test]
fn refusals_exit_non_zero_and_write_nothing() {
    let dir = tempdir("slice-bad");
    let p = dir.join("sphere.stl");
    std::fs::write(
        &p,
        write_ascii_stl(&uv_sphere(P3::zeros(), 5.0, 12, 24), "s"),
    )
    .expect("write");
    let ps = p.to_str().expect("utf-8");
    let out = dir.join("loops.csv");
    let os = out.to_str().expect("utf-8");
    for (args, code, says) in [
        (vec!["--layer", "0"], 2, "layer height 0"),
        (vec!["--layer", "-1"], 2, "layer height -1"),
        (vec!["--layer", "11"], 1, "larger than the part"),
        (
            vec!["--layer", "1", "--build-dir", "0,0,0"],
            2,
            "build direction",
        ),
        (vec!["--layer", "1", "--build-dir", "0,1"], 2, "--build-dir"),
        (vec![], 2, "--layer"),
    ] {
        let mut a = vec!["plan", "slice", ps, "-o", os];
        a.extend(args.iter().copied());
        let o = lampost(&a);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{args:?}: {}", stderr(&o));
        assert!(!out.exists(), "{args:?} wrote {os}");
    }
    // An open mesh: the open chains are reported by layer with their ends; no file.
    let mut m = uv_sphere(P3::zeros(), 5.0, 12, 24);
    m.triangles.drain(100..102);
    let open = dir.join("open.stl");
    std::fs::write(&open, write_ascii_stl(&m, "o")).expect("write");
    let o = lampost(&[
        "plan",
        "slice",
        open.to_str().expect("utf-8"),
        "--layer",
        "0.5",
        "-o",
        os,
    ]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("not a closed oriented manifold"), "{e}");
    assert!(e.contains("an open chain") && e.contains("layer "), "{e}");
    assert!(e.contains("nothing written"), "{e}");
    assert!(!out.exists());
}

#[test]
fn three_mf_is_refused_with_the_reason_and_first_places_the_first_plane() {
    let dir = tempdir("mesh-3mf");
    let p = dir.join("part.3mf");
    std::fs::write(&p, b"PK\x03\x04 not really").expect("write");
    let o = lampost(&["mesh", "info", p.to_str().expect("utf-8")]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("no ZIP end-of-central-directory record"),
        "{}",
        stderr(&o)
    );
    // --first 0: the first plane at the bottom face, which counts as above it: no loop.
    let b = dir.join("box.stl");
    std::fs::write(
        &b,
        write_ascii_stl(&box_mesh(P3::zeros(), P3::new(2.0, 3.0, 4.0)), "b"),
    )
    .expect("write");
    let v = json(&lampost(&[
        "plan",
        "slice",
        b.to_str().expect("utf-8"),
        "--layer",
        "1",
        "--first",
        "0",
        "--json",
    ]));
    assert_eq!(v["layers"], 4);
    assert_eq!(v["slices"][0]["loops"].as_array().expect("loops").len(), 0);
    assert!((f(&v["slices"][1]["area"]) - 6.0).abs() < 1e-12);
}
