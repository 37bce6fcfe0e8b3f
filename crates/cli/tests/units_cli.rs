//! Units the input does not name: the post says what it assumed, `--units` says it, and
//! `--convert-units` scales a program or a per-point path to the machine's units.

mod common;
use common::*;

const NO_UNITS_INCH: &str = "G90\nG0 X0 Y0 Z0.2\nG1 Z0 F20.\nG1 X1.\nG0 Z0.2\nM30\n";
const NO_UNITS_MM: &str = "G90\nG0 X0 Y0 Z5\nG1 Z0 F300\nG1 X25.4\nG0 Z5\nM30\n";

/// The span (max − min) of the values of `letter` words in a posted program.
fn span(text: &str, letter: char) -> f64 {
    let v: Vec<f64> = text
        .lines()
        .filter(|l| !l.starts_with('('))
        .flat_map(|l| l.split_whitespace())
        .filter_map(|w| w.strip_prefix(letter).and_then(|n| n.parse::<f64>().ok()))
        .collect();
    let max = v.iter().copied().fold(f64::MIN, f64::max);
    let min = v.iter().copied().fold(f64::MAX, f64::min);
    max - min
}

/// `lampost post` (or `verify`) with `args`, then INPUT, then `-o OUT` for post or POSTED
/// for verify.
fn run(cmd: &str, args: &[&str], input: &str, out: &str) -> std::process::Output {
    let mut v = vec![cmd];
    v.extend_from_slice(args);
    if cmd == "post" {
        v.extend_from_slice(&[input, "-o", out]);
    } else {
        v.extend_from_slice(&[input, out]);
    }
    lampost(&v)
}

fn write(dir: &std::path::Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p.to_str().expect("utf-8").to_string()
}

#[test]
fn a_program_without_g20_g21_is_read_in_the_machines_units_with_a_warning() {
    let dir = tempdir("units-assumed");
    let f = write(&dir, "inch.nc", NO_UNITS_INCH);
    let out = dir.join("inch.out.nc");
    let out_s = out.to_str().expect("utf-8");
    let index = ["--machine", "fadal-lamp", "--index", "A=0,B=0"];
    let o = run("post", &index, &f, out_s);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("gives no G20/G21") && err.contains("read as inches (the machine's units"),
        "{err}"
    );
    // A program that says its units gets no such warning.
    let g = write(&dir, "said.nc", &format!("G20\n{NO_UNITS_INCH}"));
    let o = run("post", &index, &g, out_s);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("G20/G21"), "{}", stderr(&o));
}

#[test]
fn units_and_convert_units_on_a_program() {
    let dir = tempdir("units-program");
    let f = write(&dir, "mm.nc", NO_UNITS_MM);
    let out = dir.join("mm.out.nc");
    let out_s = out.to_str().expect("utf-8");
    // Said to be millimetres, on the inch FADAL: refused until converted.
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        "--units",
        "mm",
        &f,
        "-o",
        out_s,
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("millimetres but the machine is in inches"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
    let args = [
        "--machine",
        "fadal-lamp",
        "--index",
        "A=0,B=0",
        "--units",
        "mm",
        "--convert-units",
    ];
    let o = run("post", &args, &f, out_s);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("read as millimetres (--units)"),
        "{}",
        stderr(&o)
    );
    let text = std::fs::read_to_string(&out).expect("posted");
    // 25.4 mm is one inch (the laser head's offset moves both ends alike); 300 mm/min
    // is 11.811 in/min.
    assert!((span(&text, 'X') - 1.0).abs() < 1e-9, "{text}");
    assert!(text.contains("F11.81"), "{text}");
    let v = run("verify", &args, &f, out_s);
    assert!(v.status.success(), "{}", stderr(&v));
}

#[test]
fn a_millimetre_per_point_path_posts_on_the_inch_fadal_when_converted() {
    let dir = tempdir("units-points");
    let f = write(
        &dir,
        "path.csv",
        "0 0 0 0 0 1 300\n25.4 0 0 0 0 1 300\n25.4 25.4 0 0 0 1 300\n",
    );
    let out = dir.join("path.nc");
    let out_s = out.to_str().expect("utf-8");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--units",
        "mm",
        &f,
        "-o",
        out_s,
    ]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("the points are in millimetres (--units)") && err.contains("--convert-units"),
        "{err}"
    );
    assert!(!err.contains("orientation"), "{err}");
    let args = [
        "--machine",
        "fadal-lamp",
        "--units",
        "mm",
        "--convert-units",
    ];
    let o = run("post", &args, &f, out_s);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).expect("posted");
    assert!((span(&text, 'X') - 1.0).abs() < 1e-9, "{text}");
    assert!((span(&text, 'Y') - 1.0).abs() < 1e-9, "{text}");
    let v = run("verify", &args, &f, out_s);
    assert!(v.status.success(), "{}", stderr(&v));
    // Inch points on the inch machine need nothing.
    let g = write(&dir, "inch.csv", "0 0 0 0 0 1 20\n1 0 0 0 0 1 20\n");
    let o = lampost(&[
        "post",
        "--machine",
        "fadal-lamp",
        "--units",
        "inch",
        &g,
        "-o",
        out_s,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}
