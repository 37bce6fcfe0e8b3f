//! Regressions found by `cargo xtask fuzz` (crates/fuzz): each input as the fuzzer made
//! it (shortened), run through the CLI.

mod common;
use common::*;
use std::path::Path;

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p.to_string_lossy().into_owned()
}

/// `post` target, seed 1, input 1030: a per-point path on the A/C trunnion table turns C
/// while it deposits; the final lift went to the safe height of the first table position
/// (where the path started), below the work at the last one, and the post's own
/// verification refused its program ("a lampost fault"). The lift now goes to the safe
/// height at the table position where the path ends.
#[test]
fn per_point_final_lift_is_safe_where_the_table_stopped() {
    let dir = tempdir("fuzz-per-point-lift");
    let csv = write(
        &dir,
        "turning.csv",
        "25.4 0 0 0.218104 0 0.975926 600\n24.6 6.25 0 0.211384 0.053722 0.975926\n",
    );
    let machine = root()
        .join("fixtures/machines/xyzac-trt.toml")
        .to_string_lossy()
        .into_owned();
    let out = dir.join("turning.nc");
    let o = lampost(&[
        "post",
        "--machine",
        &machine,
        &csv,
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = lampost(&[
        "verify",
        "--machine",
        &machine,
        &csv,
        &out.to_string_lossy(),
    ]);
    assert!(v.status.success(), "{}", stderr(&v));
}
