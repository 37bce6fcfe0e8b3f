//! Slices against an independent slicer: trimesh's `section_multiplane` on the same mesh
//! file at the same plane heights (`slice_oracle.py`, run with the interpreter
//! `scripts/install-python.sh` puts in `.tools/py`). Per layer, the number of closed
//! loops must be equal and the total area (outer loops minus holes) equal to 1e-6
//! relative.
//!
//! Meshes: a UV sphere and a torus generated here, and the real meshes
//! `scripts/install-meshes.sh` puts in `.tools/meshes` (CGAL's bunny, fandisk, elephant,
//! armadillo, …, from Debian's libcgal-demo), along z and along a tilted direction.
//!
//! Skipped (with a message) when `.tools/py` or `.tools/meshes` is missing, unless
//! `LAMPOST_REQUIRE_PY=1`.

use std::path::{Path, PathBuf};
use std::process::Command;

use lampost_mesh::{read_off, torus, uv_sphere, write_off, P3};
use lampost_plan::{slice, Planes, SliceOptions};

fn root() -> PathBuf {
    let r = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    r.canonicalize().unwrap_or(r)
}

/// Layers per mesh along each direction.
const LAYERS: f64 = 60.0;

#[test]
fn loop_count_and_area_per_layer_equal_trimesh() {
    let root = root();
    let py = root.join(".tools/py/bin/python");
    let meshes_dir = root.join(".tools/meshes");
    let required = std::env::var("LAMPOST_REQUIRE_PY").is_ok_and(|v| v == "1");
    for (what, path, script) in [
        ("python", &py, "scripts/install-python.sh"),
        ("meshes", &meshes_dir, "scripts/install-meshes.sh"),
    ] {
        if !path.exists() {
            assert!(
                !required,
                "LAMPOST_REQUIRE_PY=1 but the {what} ({}) are missing: run {script}",
                path.display()
            );
            eprintln!("SKIPPED: {} is missing (run {script})", path.display());
            return;
        }
    }
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("slice-oracle");
    std::fs::create_dir_all(&work).expect("work dir");
    let mut files: Vec<PathBuf> = Vec::new();
    for (name, m) in [
        ("sphere", uv_sphere(P3::new(1.0, -2.0, 3.0), 10.0, 40, 80)),
        ("torus", torus(P3::new(0.5, 0.0, -1.0), 20.0, 5.0, 80, 40)),
    ] {
        let p = work.join(format!("{name}.off"));
        std::fs::write(&p, write_off(&m)).expect("write off");
        files.push(p);
    }
    let mut real: Vec<PathBuf> = std::fs::read_dir(&meshes_dir)
        .expect("meshes dir")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "off"))
        .collect();
    real.sort();
    assert!(
        !real.is_empty() || !required,
        "no meshes in {}",
        meshes_dir.display()
    );
    files.extend(real);

    let dirs = [P3::new(0.0, 0.0, 1.0), P3::new(0.3, -0.5, 1.0).normalize()];
    let mut jobs = Vec::new();
    let mut ours = Vec::new();
    for f in &files {
        let mesh = read_off(&std::fs::read(f).expect("read")).expect("off");
        for d in dirs {
            let hs: Vec<f64> = mesh.vertices.iter().map(|v| d.dot(v)).collect();
            let lo = hs.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = hs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let s = slice(
                &mesh,
                &SliceOptions {
                    planes: Planes::Parallel {
                        dir: d,
                        layer: (hi - lo) / LAYERS,
                        first: None,
                    },
                    stitch: Some(0.0),
                    threads: 2,
                },
            )
            .expect("slices");
            let heights: Vec<f64> = s.slices.iter().map(|sl| sl.height).collect();
            jobs.push(format!(
                "{{\"file\": {:?}, \"normal\": [{:?}, {:?}, {:?}], \"heights\": {:?}}}",
                f.display().to_string(),
                d.x,
                d.y,
                d.z,
                heights
            ));
            ours.push((f.clone(), d, s));
        }
    }
    let jobs_path = work.join("jobs.json");
    let out_path = work.join("out.json");
    std::fs::write(&jobs_path, format!("[{}]", jobs.join(",\n"))).expect("jobs");
    let run = Command::new(&py)
        .arg(root.join("crates/plan/tests/slice_oracle.py"))
        .arg(&jobs_path)
        .arg(&out_path)
        .output()
        .expect("run the python oracle");
    assert!(
        run.status.success(),
        "oracle failed: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = std::fs::read_to_string(&out_path).expect("oracle output");
    let theirs = parse(&text);
    assert_eq!(theirs.len(), ours.len());
    let mut layers = 0;
    let mut open_layers = 0;
    let mut worst: f64 = 0.0;
    for ((file, d, s), t) in ours.iter().zip(&theirs) {
        assert_eq!(s.slices.len(), t.len());
        for (sl, &(loops, area)) in s.slices.iter().zip(t) {
            let name = file
                .file_name()
                .map(|n| n.to_string_lossy().to_string())
                .unwrap_or_default();
            let a: f64 = sl.loops.iter().map(|l| l.area).sum();
            assert_eq!(
                sl.loops.len(),
                loops,
                "{name} along {d:?}, layer {} at {}: loops",
                sl.index,
                sl.height
            );
            if !sl.open.is_empty() {
                // An open mesh (CGAL's mushroom): the closed loops are compared, the
                // open chains are not polygons to measure.
                open_layers += 1;
                continue;
            }
            let rel = (a - area).abs() / area.abs().max(f64::MIN_POSITIVE);
            worst = worst.max(rel);
            assert!(
                rel <= 1e-6,
                "{name} along {d:?}, layer {} at {}: area {a} vs trimesh {area}",
                sl.index,
                sl.height
            );
            layers += 1;
        }
    }
    eprintln!(
        "{} meshes, {} directions, {layers} layers (+{open_layers} with open chains, loops compared): loop counts equal, worst relative area difference {worst:.2e}",
        files.len(),
        dirs.len()
    );
}

/// `[[[loops, area], …], …]` from the oracle.
fn parse(text: &str) -> Vec<Vec<(usize, f64)>> {
    serde_json::from_str(text).expect("oracle JSON")
}
