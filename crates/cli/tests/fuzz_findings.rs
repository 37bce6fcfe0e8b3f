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
        // The deposit extrudes (a G1 without E is travel under --e-extrusion).
        "G21 G90 G17\nG0 X1 Y1 Z5\nG1 Z0 F20.001e-300\nG1 X10 E1\nG0 Z5\nM30\n",
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

/// An array with more values than its key takes is refused at its line, never cut short
/// silently (`toml` reads `[1, 0, 0, 5]` into three numbers without a word): setup,
/// job and machine files.
#[test]
fn arrays_with_extra_values_are_refused_at_their_line() {
    let dir = tempdir("extra-values");
    let prog = dir.join("p.nc");
    std::fs::write(
        &prog,
        "G20 G90\nG0 X0 Y0 Z0.2\nG1 Z0 F20.\nG1 X1.\nG0 Z0.2\nM30\n",
    )
    .expect("write");
    let prog_s = prog.to_str().expect("utf-8");
    let out = dir.join("o.nc");
    let out_s = out.to_str().expect("utf-8");
    let setup = dir.join("s.toml");
    std::fs::write(
        &setup,
        "origin = [0, 0, 0]\nx_axis = [1, 0, 0, 5]\nz_axis = [0, 0, 1]\n",
    )
    .expect("write");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--setup",
        setup.to_str().expect("utf-8"),
        prog_s,
        "-o",
        out_s,
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("s.toml:2:1: `x_axis` has 4 values; it takes 3"),
        "{}",
        stderr(&o)
    );
    let job = dir.join("j.toml");
    std::fs::write(
        &job,
        format!("[[section]]\nprogram = \"{prog_s}\"\nindex = {{ A = 0, B = 0 }}\norigin = [0, 0, 0, 1]\n"),
    )
    .expect("write");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--job",
        job.to_str().expect("utf-8"),
        "-o",
        out_s,
    ]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("`section[0].origin` has 4 values; it takes 3") && err.contains("j.toml:4:1"),
        "{err}"
    );
    let shown = lampost(&["machines", "show", "fadal-lamp"]);
    let text = String::from_utf8_lossy(&shown.stdout).replacen(
        "direction = [1.0, 0.0, 0.0]",
        "direction = [1.0, 0.0, 0.0, 7.0]",
        1,
    );
    let m = dir.join("m.toml");
    std::fs::write(&m, text).expect("write");
    let o = lampost(&[
        "kin",
        "fk",
        "--machine",
        m.to_str().expect("utf-8"),
        "--joints",
        "X=0,Y=0,Z=0,A=0,B=0",
    ]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("`linear[0].direction` has 4 values; it takes 3") && err.contains("m.toml:"),
        "{err}"
    );
    assert!(!out.exists());
}
