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

/// `post` target, seed 11: a feed that rounds to `F0` at the 5 decimals feeds are written
/// with (`F20.001e-300` read with exponents under `--e-extrusion`; a per-point row's feed
/// of 1e-300, written as an inverse-time F0) made a program that `verify` refused as
/// having no feed. It is refused before it is written, saying why.
#[test]
fn a_feed_that_rounds_to_zero_is_refused() {
    let dir = tempdir("fuzz-feed-zero");
    let nc = write(
        &dir,
        "tiny.nc",
        "G21 G90 G17\nG0 X1 Y1 Z5\nG1 Z0 F20.001e-300\nG1 X10\nG0 Z5\nM30\n",
    );
    let csv = write(
        &dir,
        "tiny.csv",
        "0 0 0 0 0 1 1e-300\n1 0 0 0 0.1 1\n2 0 0 0 0.2 1\n",
    );
    for (args, name) in [
        (
            vec!["--index", "B=0,C=0", "--e-extrusion", nc.as_str()],
            "tiny.nc",
        ),
        (vec![csv.as_str()], "tiny.csv"),
    ] {
        let out = dir.join(format!("{name}.out"));
        let out_s = out.to_string_lossy().into_owned();
        let mut a = vec!["post", "--machine", "nrc-lc"];
        a.extend(args.iter().copied());
        a.extend(["-o", out_s.as_str()]);
        let o = lampost(&a);
        assert!(!o.status.success(), "{name}");
        assert!(
            stderr(&o).contains("would be written as F0"),
            "{name}: {}",
            stderr(&o)
        );
        assert!(!out.exists(), "{name}: nothing written");
    }
}
