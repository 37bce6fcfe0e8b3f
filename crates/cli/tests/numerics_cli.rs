//! Issue 13's numeric and probe cases: every risky command runs under a 10 s limit (a
//! hang fails the test instead of blocking it), and none prints a non-finite number.

mod common;

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{root, tempdir};

struct Run {
    code: i32,
    stdout: String,
    stderr: String,
}

/// Run `lampost`, killing it after 10 s (then the test fails: a hang).
fn limited(args: &[&str]) -> Run {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lampost"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("lampost runs");
    let mut out = child.stdout.take().expect("stdout");
    let mut err = child.stderr.take().expect("stderr");
    let o = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let e = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("waits") {
            break s;
        }
        if start.elapsed() > Duration::from_secs(10) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("lampost {args:?} did not return within 10 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Run {
        code: status.code().unwrap_or(-1),
        stdout: o.join().expect("stdout thread"),
        stderr: e.join().expect("stderr thread"),
    }
}

fn no_non_finite(r: &Run) {
    for text in [&r.stdout, &r.stderr] {
        let lower = text.to_ascii_lowercase();
        assert!(
            !lower.contains("nan") && !lower.contains("inf "),
            "a non-finite number printed:\n{text}"
        );
        assert!(
            !text.split_whitespace().any(|w| {
                let w = w.trim_matches(|c: char| c == ',' || c == '[' || c == ']');
                w == "inf" || w == "-inf"
            }),
            "{text}"
        );
    }
}

fn refused(r: &Run, needle: &str) {
    assert_ne!(r.code, 0, "accepted:\n{}", r.stdout);
    assert!(r.stderr.contains(needle), "{}", r.stderr);
    no_non_finite(r);
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("writes");
    p.to_string_lossy().into_owned()
}

#[test]
fn fits_on_points_at_1_7e308_are_refused_quickly_with_the_line() {
    let d = tempdir("num_fit_huge");
    let f = write(
        &d,
        "huge.txt",
        "x y z\n1.7e308 0 0\n-1.7e308 0 0\n0 1.7e308 0\n0 -1.7e308 0\n0 0 1.7e308\n",
    );
    for kind in ["sphere", "plane", "circle", "sphere4"] {
        let r = limited(&["fit", kind, &f]);
        refused(&r, "huge.txt:2:1");
        assert!(r.stderr.contains("beyond ±1e9"), "{}", r.stderr);
        assert!(r.stderr.contains("help:"), "{}", r.stderr);
    }
}

#[test]
fn fit_plane_near_1e155_is_refused_not_rms_inf() {
    let d = tempdir("num_fit_155");
    let f = write(
        &d,
        "p.txt",
        "1e155 0 0\n0 1e155 0\n0 0 1e155\n1e155 1e155 1\n",
    );
    let r = limited(&["fit", "plane", &f]);
    refused(&r, "p.txt:1:1");
    assert!(!r.stdout.contains("rms"), "{}", r.stdout);
}

#[test]
fn calibrate_pivot_with_a_1e200_coordinate_returns_with_the_row() {
    let d = tempdir("num_pivot_huge");
    let text = std::fs::read_to_string(root().join("fixtures/calibration/fadal-8-poses.txt"))
        .expect("fixture");
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let i = lines
        .iter()
        .position(|l| l.starts_with("0 0 "))
        .expect("a home row");
    lines[i] = "0 0 1e200 -2 1.5".into();
    let f = write(&d, "poses.txt", &(lines.join("\n") + "\n"));
    let r = limited(&["calibrate", "pivot", "--machine", "fadal-lamp", &f]);
    refused(&r, &format!("poses.txt:{}", i + 1));
    assert!(r.stderr.contains("beyond ±1e9"), "{}", r.stderr);
}

#[test]
fn calibrate_factorial_at_1e308_is_refused_not_inf() {
    let r = limited(&[
        "calibrate",
        "factorial",
        "--start",
        "1e308,0,0",
        "--step",
        "1e308",
    ]);
    refused(&r, "at most 1e9");
    let r = limited(&[
        "calibrate",
        "factorial",
        "--start",
        "1e308,0,0",
        "--step",
        "1",
    ]);
    refused(&r, "beyond ±1e9");
}

#[test]
fn probe_poses_that_fix_nothing_are_refused() {
    let d = tempdir("num_poses_nothing");
    let out = d.join("cal.nc");
    let o = out.to_string_lossy().into_owned();
    let base = [
        "probe",
        "poses",
        "--machine",
        "fadal-lamp",
        "--ball",
        "3,-2,1.5",
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.1",
        "-o",
        &o,
    ];
    for poses in [";;", "A=10,B=0;A=10,B=0;A=10,B=0;A=10,B=0"] {
        let mut args = base.to_vec();
        args.extend(["--poses", poses]);
        let r = limited(&args);
        refused(&r, "fixes nothing");
        assert!(!r.stderr.contains("are fixed"), "{}", r.stderr);
        assert!(!out.exists(), "a program was written for {poses}");
    }
}

#[test]
fn probe_poses_beyond_the_travel_are_refused_naming_the_axis() {
    let d = tempdir("num_poses_travel");
    let out = d.join("cal.nc");
    let o = out.to_string_lossy().into_owned();
    let r = limited(&[
        "probe",
        "poses",
        "--machine",
        "fadal-lamp",
        "--ball",
        "100,0,0",
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.1",
        "-o",
        &o,
    ]);
    refused(&r, "would move X to 100.");
    assert!(r.stderr.contains("[-20, 20]"), "{}", r.stderr);
    assert!(!out.exists());
    // In travel, the same set is written.
    let r = limited(&[
        "probe",
        "poses",
        "--machine",
        "fadal-lamp",
        "--ball",
        "3,-2,1.5",
        "--radius",
        "0.5",
        "--stylus-radius",
        "0.1",
        "-o",
        &o,
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(out.exists());
}

#[test]
fn probe_plane_grid_product_does_not_wrap() {
    let r = limited(&[
        "probe",
        "plane",
        "--corner",
        "0,0,0",
        "--size",
        "1,1",
        "--grid",
        "9223372036854775813,2",
    ]);
    refused(&r, "at most 10000");
    assert_eq!(r.stdout, "");
}

#[test]
fn probe_sphere_points_are_capped() {
    let r = limited(&[
        "probe",
        "sphere",
        "--center",
        "0,0,0",
        "--radius",
        "1",
        "--stylus-radius",
        "0.1",
        "--points",
        "1000000000",
    ]);
    refused(&r, "at most 10000 touches");
    assert_eq!(r.stdout, "");
}

fn huge_offset_machine(dir: &Path) -> String {
    let text =
        std::fs::read_to_string(root().join("fixtures/machines/fadal-lamp.toml")).expect("fixture");
    let mut done = false;
    let lines: Vec<String> = text
        .lines()
        .map(|l| {
            if !done && l.trim() == "offset = [0.0, 0.0, 0.0]" {
                done = true;
                "offset = { param = \"L\", scale = 1e308 }".to_string()
            } else {
                l.to_string()
            }
        })
        .collect();
    assert!(done, "the spindle offset line");
    write(dir, "huge-offset.toml", &(lines.join("\n") + "\n"))
}

#[test]
fn kin_fk_with_a_1e308_offset_scale_is_refused_not_nan() {
    let d = tempdir("num_fk_scale");
    let m = huge_offset_machine(&d);
    let r = limited(&[
        "kin",
        "fk",
        "--machine",
        &m,
        "--joints",
        "X=0,Y=0,Z=0,A=0,B=0",
    ]);
    refused(&r, "offset");
    assert!(r.stderr.contains("scale"), "{}", r.stderr);
    assert_eq!(r.stdout, "");
}

#[test]
fn kin_rotate_with_a_1e308_offset_scale_has_no_nan_rows() {
    let d = tempdir("num_rotate_scale");
    let m = huge_offset_machine(&d);
    let pts = write(&d, "pts.txt", "0 0 0\n1 1 1\n");
    let r = limited(&[
        "kin",
        "rotate",
        "--machine",
        &m,
        "--joints",
        "A=10,B=20",
        &pts,
    ]);
    refused(&r, "offset");
    assert_eq!(r.stdout, "");
}

#[test]
fn kin_ik_axis_at_1e300_is_its_direction() {
    let big = limited(&[
        "kin",
        "ik",
        "--machine",
        "fadal-lamp",
        "--position",
        "0,0,0",
        "--axis",
        "1e300,1e300,1e300",
    ]);
    let unit = limited(&[
        "kin",
        "ik",
        "--machine",
        "fadal-lamp",
        "--position",
        "0,0,0",
        "--axis",
        "1,1,1",
    ]);
    assert_eq!(big.code, 0, "{}", big.stderr);
    assert_eq!(big.stdout, unit.stdout);
    no_non_finite(&big);
    assert!(big.stdout.contains("B=54.735610"), "{}", big.stdout);
}

#[test]
fn align_angle_to_a_1e300_normal_is_its_direction() {
    let d = tempdir("num_angle_big");
    let f = write(&d, "pl.txt", "0 0 0\n1 0 0\n0 1 0\n1 1 0.001\n");
    let big = limited(&["align", "angle", &f, "--to-normal", "1e300,1e300,0"]);
    let unit = limited(&["align", "angle", &f, "--to-normal", "1,1,0"]);
    assert_eq!(big.code, 0, "{}", big.stderr);
    assert_eq!(big.stdout, unit.stdout);
    no_non_finite(&big);
    let zero = limited(&["align", "angle", &f, "--to-normal", "0,0,0"]);
    refused(&zero, "zero length");
}

#[test]
fn align_level_outward_zero_is_refused() {
    let d = tempdir("num_level_zero");
    let f = write(&d, "pl.txt", "0 0 0\n1 0 0\n0 1 0\n1 1 0.001\n");
    let r = limited(&[
        "align",
        "level",
        &f,
        "--machine",
        "fadal-lamp",
        "--outward",
        "0,0,0",
    ]);
    refused(&r, "--outward");
    assert!(r.stderr.contains("zero length"), "{}", r.stderr);
    assert_eq!(r.stdout, "");
}

#[test]
fn negative_zero_and_zero_are_the_same_point() {
    let d = tempdir("num_neg_zero");
    // The repeat is not adjacent to its twin in sorted order unless −0 sorts as +0.
    let f = write(&d, "z.txt", "0 0 1\n-0 5 0\n-0 0 1\n1 0 0\n");
    let r = limited(&["fit", "plane", &f]);
    refused(&r, "are the same point");
    assert!(r.stderr.contains("z.txt:1 and"), "{}", r.stderr);
    assert!(r.stderr.contains("z.txt:3"), "{}", r.stderr);
}
