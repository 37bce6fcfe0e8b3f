//! Nothing stale or partial (issue 13, item 3): temporary files beside their target and
//! removed on an interrupt; a split written as a set, with stale pieces of an earlier
//! split removed; `-o` and `--json-report` committed together or not at all.

mod common;

use common::*;
use std::path::Path;
use std::process::Command;

fn temps(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".tmp"))
                .collect()
        })
        .unwrap_or_default()
}

/// A long planar program (to interrupt a post of it).
fn long_program(lines: usize) -> String {
    let mut s = String::from("G21 G90\nG0 X0 Y0 Z1\nG1 Z0 F600\n");
    for i in 0..lines {
        let x = (i % 200) as f64 * 0.1;
        let y = ((i / 200) % 200) as f64 * 0.1;
        s += &format!("G1 X{x:.3} Y{y:.3}\n");
    }
    s + "G0 Z5\nM30\n"
}

#[test]
fn an_interrupted_post_leaves_no_temporary_file() {
    let dir = tempdir("files-signal");
    let input = dir.join("long.nc");
    std::fs::write(&input, long_program(400_000)).expect("write");
    let out = dir.join("out.nc");
    for signal in ["-TERM", "-INT"] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_lampost"))
            .args(["post", "--machine", "nrc-lc", "--index", "B=30,C=45"])
            .arg(&input)
            .arg("-o")
            .arg(&out)
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("spawn");
        // Wait until the temporary file exists, then interrupt.
        let t0 = std::time::Instant::now();
        while temps(&dir).is_empty() && t0.elapsed().as_secs() < 20 {
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        assert!(!temps(&dir).is_empty(), "no temporary file seen");
        let killed = Command::new("kill")
            .arg(signal)
            .arg(child.id().to_string())
            .status()
            .expect("kill");
        assert!(killed.success());
        let status = child.wait().expect("wait");
        assert!(
            !status.success(),
            "{signal}: the post finished before the signal"
        );
        assert!(temps(&dir).is_empty(), "{signal}: left {:?}", temps(&dir));
        assert!(!out.exists(), "{signal}: a partial output");
    }
}

#[test]
fn a_bare_output_name_is_written_beside_itself() {
    let dir = tempdir("files-bare");
    // The temporary folder does not exist: the temporary file must not go there.
    let o = Command::new(env!("CARGO_BIN_EXE_lampost"))
        .current_dir(&dir)
        .env("TMPDIR", dir.join("no-such-folder"))
        .args([
            "post",
            "--machine",
            "nrc-lc",
            &fx("patch-20mm.nc"),
            "-o",
            "out.nc",
        ])
        .output()
        .expect("run");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("out.nc").exists());
    assert!(temps(&dir).is_empty());
}

#[test]
fn a_split_is_one_runs_set_and_the_report_commits_with_it() {
    let dir = tempdir("files-split");
    let out = dir.join("arc.nc");
    let o_s = out.to_string_lossy().into_owned();
    let post = |max: &str| {
        lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            "--index",
            "B=30,C=45",
            "--convert-units",
            &fx("wall.nc"),
            "-o",
            &o_s,
            "--max-bytes",
            max,
        ])
    };
    let pieces = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .expect("dir")
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with("arc.0"))
            .collect();
        v.sort();
        v
    };
    let o = post("600");
    assert!(o.status.success(), "{}", stderr(&o));
    let many = pieces(&dir);
    assert!(many.len() >= 3, "{many:?}");
    let o = post("1500");
    assert!(o.status.success(), "{}", stderr(&o));
    let fewer = pieces(&dir);
    assert!(fewer.len() < many.len(), "stale pieces left: {fewer:?}");
    // Unsplit: no piece of the earlier split remains.
    let o = post("100000000");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(pieces(&dir).is_empty(), "{:?}", pieces(&dir));
    assert!(out.exists());
    // A report that cannot be written: nothing is renamed into place.
    let out2 = dir.join("second.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        &fx("patch-20mm.nc"),
        "-o",
        &out2.to_string_lossy(),
        "--json-report",
        &dir.join("no-such-folder/r.json").to_string_lossy(),
    ]);
    assert!(!o.status.success());
    assert!(
        !out2.exists(),
        "-o renamed into place although the report failed"
    );
    assert!(temps(&dir).is_empty(), "{:?}", temps(&dir));
}

/// Output growth is bounded (issue 13): 100 blocks of a 300-turn helix at a tilted index
/// would be linearised into about 1.5 million lines; the post stops at its bound (50×
/// the input, at least 16 MiB) with the line, and writes nothing.
#[test]
fn output_growth_is_bounded() {
    let dir = tempdir("files-growth");
    let mut text = String::from("G21 G90\nG0 X-10 Y0 Z1\nG1 Z0 F100\n");
    for _ in 0..100 {
        text += "G2 X-10 Y0 I5 J0 P300\n";
    }
    text += "G0 Z5\nM30\n";
    let input = dir.join("helix.nc");
    std::fs::write(&input, text).expect("write");
    let out = dir.join("out.nc");
    let t0 = std::time::Instant::now();
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=30,C=45",
        &input.to_string_lossy(),
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(!o.status.success(), "posted a helix of 30,000 turns");
    assert!(
        stderr(&o).contains("bytes") && stderr(&o).contains("--max-growth"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists() && temps(&dir).is_empty());
    // A bound against a hang, not a speed test (the debug build beside other builds
    // took 67 s once).
    assert!(t0.elapsed().as_secs() < 240);
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        &input.to_string_lossy(),
        "--max-growth",
        "0.5",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("--max-growth"),
        "{}",
        stderr(&o)
    );
}

/// `-o /dev/null` (any device, FIFO or socket) is written through, never renamed over:
/// the atomic rename of a temporary file would replace the device with a regular file
/// (and every later reader of /dev/null would read what was written there).
#[cfg(unix)]
#[test]
fn output_to_a_device_is_written_through_not_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let is_device = || std::fs::metadata("/dev/null").is_ok_and(|m| m.file_type().is_char_device());
    if !is_device() {
        eprintln!("/dev/null is not a device here: test skipped");
        return;
    }
    let dir = tempdir("devnull");
    let prog = dir.join("p.nc");
    std::fs::write(&prog, "G21 G90\nG0 X1 Y2\nG1 X2 F100\nM30\n").expect("write");
    let p = prog.to_str().expect("utf-8");
    for args in [
        vec!["fmt", p, "-o", "/dev/null"],
        vec!["trace", p, "-o", "/dev/null"],
        vec![
            "post",
            "-q",
            "--machine",
            "nrc-lc",
            "--index",
            "B=0,C=0",
            p,
            "-o",
            "/dev/null",
        ],
    ] {
        let o = lampost(&args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        assert!(is_device(), "{args:?} replaced /dev/null with a file");
    }
    assert!(
        std::fs::read_dir("/dev").expect("/dev").all(|e| !e
            .expect("entry")
            .file_name()
            .to_string_lossy()
            .ends_with(".tmp")),
        "a temporary file was left in /dev"
    );
}

/// A path for the robot cell: a pass to and fro along x under the focus, the approach
/// +z, laser off on each pass's first point.
fn robot_path(passes: usize, n: usize, y: f64) -> String {
    let mut s = String::from("x y z i j k feed laser\n");
    for k in 0..passes {
        for i in 0..n {
            let u = -60.0 + 120.0 * i as f64 / (n - 1) as f64;
            let x = if k % 2 == 0 { u } else { -u };
            s += &format!(
                "{x:.4} {:.4} 0 0 0 1 600 {}\n",
                y + k as f64,
                u8::from(i > 0)
            );
        }
    }
    s
}

/// A robot post writes a folder of chunks and a manifest; interrupted at any moment it
/// leaves no temporary file, no folder of its own making unless complete, and over an
/// earlier run's folder either that folder whole or the new one whole (never new chunks
/// with the old manifest).
#[test]
fn an_interrupted_robot_post_leaves_the_folder_old_or_new() {
    let dir = tempdir("files-robot-signal");
    std::fs::write(dir.join("old.csv"), robot_path(4, 100, 0.0)).expect("write");
    std::fs::write(dir.join("new.csv"), robot_path(120, 100, 5.0)).expect("write");
    let out = dir.join("K");
    let post = |path: &str, pause_ms: u32| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_lampost"));
        c.args([
            "post",
            "--machine",
            "puma-lens",
            "--chunk-points",
            "250",
            "-q",
        ])
        .arg(dir.join(path))
        .arg("-o")
        .arg(&out)
        .env("LAMPOST_TEST_COMMIT_PAUSE_MS", pause_ms.to_string())
        .stderr(std::process::Stdio::null());
        c
    };
    let verifies = |path: &str| {
        lampost(&[
            "verify",
            "--machine",
            "puma-lens",
            "-q",
            &out.to_string_lossy(),
            "--input",
            &dir.join(path).to_string_lossy(),
        ])
        .status
        .success()
    };
    let kill = |child: &std::process::Child| {
        let _ = Command::new("kill")
            .arg("-TERM")
            .arg(child.id().to_string())
            .status();
    };
    // Interrupted in the middle of putting the chunks in place (slowed down to 10 ms a
    // file, the signal sent once some are): the set is finished, then the run exits.
    assert!(post("old.csv", 0).status().expect("run").success());
    let mut child = post("new.csv", 10).spawn().expect("spawn");
    let t0 = std::time::Instant::now();
    let mut most = 0;
    loop {
        let n = temps(&out).len();
        most = most.max(n);
        if (most > 100 && n < most - 5) || t0.elapsed().as_secs() > 60 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    kill(&child);
    let status = child.wait().expect("wait");
    assert!(temps(&out).is_empty(), "left {:?}", temps(&out));
    assert!(
        verifies("new.csv"),
        "after {status}: interrupted while renaming, the folder is not the new output"
    );
    // Interrupted at other moments, over an earlier output or into a new folder.
    let t0 = std::time::Instant::now();
    assert!(post("new.csv", 0).status().expect("run").success());
    let whole = t0.elapsed();
    let mut outcomes = [0usize; 3];
    for k in 1..=8 {
        let fresh = k % 4 == 0;
        let _ = std::fs::remove_dir_all(&out);
        if !fresh {
            assert!(post("old.csv", 0).status().expect("run").success());
        }
        let mut child = post("new.csv", 0).spawn().expect("spawn");
        std::thread::sleep(whole.mul_f64(0.3 + 0.12 * k as f64));
        kill(&child);
        let status = child.wait().expect("wait");
        assert!(temps(&out).is_empty(), "left {:?}", temps(&out));
        let (old, new) = (!fresh && verifies("old.csv"), verifies("new.csv"));
        if fresh && !new {
            assert!(
                !out.exists(),
                "a folder of its own making left half written"
            );
        } else {
            assert!(
                old || new,
                "after {status}: neither the old nor the new output"
            );
        }
        outcomes[usize::from(status.success()) + usize::from(new)] += 1;
    }
    eprintln!("outcomes (interrupted and old, interrupted and new, finished): {outcomes:?}");
}

/// Finding 107 (h58): only `post` refused an output at its input's path; `trace in.nc -o
/// in.nc`, `plan slice m.stl -o m.stl` and a dozen others replaced their input and exited
/// 0, and `post` itself missed a job's section program. An output over any file the run
/// read is now refused, and the input is left as it was. A machine file may still be
/// rewritten in place (`calibrate pivot --machine m.toml --write m.toml`).
#[test]
fn no_output_replaces_an_input_of_the_run() {
    let dir = tempdir("output-over-input");
    let prog = dir.join("in.nc");
    let text = "G21 G90\nG0 X0 Y0 Z5\nG1 Z0 F100\nG1 X10\nG0 Z5\nM2\n";
    std::fs::write(&prog, text).expect("write");
    let p = prog.to_str().expect("utf8");
    let o = lampost(&["trace", p, "-o", p]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("the same file as an input"), "{err}");
    assert_eq!(std::fs::read_to_string(&prog).expect("read"), text);
    let job = dir.join("job.toml");
    std::fs::write(
        &job,
        "[[section]]\nprogram = \"in.nc\"\nindex = { B = 0.0, C = 0.0 }\n",
    )
    .expect("write");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--job",
        job.to_str().expect("utf8"),
        "-o",
        p,
    ]);
    assert!(!o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&prog).expect("read"), text);
    let mesh = dir.join("m.stl");
    let m = mesh.to_str().expect("utf8");
    assert!(lampost(&["plan", "demo", "--scale", "0.1", "-o", m])
        .status
        .success());
    let before = std::fs::read(&mesh).expect("mesh");
    let o = lampost(&["plan", "slice", "--layer", "1", m, "-o", m]);
    assert!(!o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&mesh).expect("mesh"), before);
    assert!(temps(&dir).is_empty(), "{:?}", temps(&dir));
}

/// Finding 107 (h58): `-o LINK` replaced the symbolic link with a new file (as root,
/// `-o /dev/stdout` with standard output sent to a file replaced `/dev/stdout` itself,
/// and the file got nothing). The output now goes where the link leads; the link stays.
#[test]
fn an_output_through_a_symbolic_link_writes_its_target() {
    let dir = tempdir("output-symlink");
    let prog = dir.join("in.nc");
    std::fs::write(&prog, "G21 G90\nG0 X1\nM2\n").expect("write");
    let target = dir.join("target.nc");
    std::fs::write(&target, "old\n").expect("write");
    let link = dir.join("link.nc");
    std::os::unix::fs::symlink(&target, &link).expect("symlink");
    let o = lampost(&[
        "fmt",
        prog.to_str().expect("utf8"),
        "-o",
        link.to_str().expect("utf8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::symlink_metadata(&link)
        .expect("link")
        .file_type()
        .is_symlink());
    assert!(std::fs::read_to_string(&target)
        .expect("target")
        .contains("G0 X1"));
    assert!(temps(&dir).is_empty(), "{:?}", temps(&dir));
}
