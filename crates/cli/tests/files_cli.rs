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

/// A short program, written to `dir/name`; its path.
fn small_program(dir: &Path, name: &str) -> String {
    let prog = dir.join(name);
    std::fs::write(
        &prog,
        "G21 G90\nG0 X0 Y0 Z5\nG1 Z0 F100\nG1 X10\nG0 Z5\nM2\n",
    )
    .expect("write");
    prog.to_str().expect("utf8").to_string()
}

/// Binary data on standard input (an image, `/dev/urandom`) is refused early, as not a
/// program, instead of being spooled whole and read as G-code; text with a few tape codes
/// is still a program.
#[test]
fn binary_standard_input_is_refused_as_not_a_program() {
    // A splitmix stream: every byte value, about one in eight of them control bytes.
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let bytes: Vec<u8> = (0..200_000)
        .map(|_| {
            x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = x;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            (z ^ (z >> 31)) as u8
        })
        .collect();
    let o = lampost_stdin(&["check", "-"], &bytes);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("binary data, not a program"), "{err}");
    // DC2 ... DC4 around a program (a DNC tape) are not binary.
    let tape = b"\x12%\nG21 G90\nG0 X1 Y1\nG1 X2 F100\nM30\n%\x14\n".repeat(200);
    let o = lampost_stdin(&["trace", "-"], &tape);
    assert!(!stderr(&o).contains("binary data"), "{}", stderr(&o));
}

/// One path named as two outputs of a run (`inspect plan -o x --program x`) is refused
/// before anything is written: the second replaced the first.
#[test]
fn one_path_named_as_two_outputs_is_refused() {
    let dir = tempdir("two-outputs");
    let pts = dir.join("pts.txt");
    std::fs::write(
        &pts,
        "id x y z i j k\n1 0 0 10 0 0 1\n2 5 0 10 0 0 1\n3 0 5 10 0 0 1\n",
    )
    .expect("write");
    let out = dir.join("same.txt");
    let o = out.to_str().expect("utf8");
    let r = lampost(&[
        "inspect",
        "plan",
        "--machine",
        "nrc-lc",
        "--points",
        pts.to_str().expect("utf8"),
        "-o",
        o,
        "--program",
        o,
    ]);
    let err = stderr(&r);
    assert!(!r.status.success(), "{err}");
    assert!(err.contains("named as two outputs"), "{err}");
    assert!(!out.exists(), "an output was written");
    assert!(temps(&dir).is_empty(), "{:?}", temps(&dir));
    // Two paths: both written.
    let prog = dir.join("m.nc");
    let r = lampost(&[
        "inspect",
        "plan",
        "--machine",
        "nrc-lc",
        "--points",
        pts.to_str().expect("utf8"),
        "-o",
        o,
        "--program",
        prog.to_str().expect("utf8"),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(out.exists() && prog.exists());
    let p = small_program(&dir, "in.nc");
    let o = dir.join("out.nc");
    let o = o.to_str().expect("utf8");
    // A split's first piece takes the whole program's name: not two outputs.
    let r = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        &p,
        "-o",
        o,
        "--max-bytes",
        "600",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
}

/// A run killed outright (SIGKILL, a power cut) leaves its temporary file; the next run
/// writing the same output removes it when its process is gone, and never touches a
/// live process's.
#[test]
fn a_dead_runs_temporary_file_is_removed_by_the_next() {
    let dir = tempdir("stale-temp");
    let p = small_program(&dir, "in.nc");
    // Beyond any pid_max (2^22 at most).
    let dead = dir.join(".out.nc.99999999.0.tmp");
    let live = dir.join(format!(".out.nc.{}.0.tmp", std::process::id()));
    let other = dir.join(".other.nc.99999999.0.tmp");
    for f in [&dead, &live, &other] {
        std::fs::write(f, "G0 X9").expect("write");
    }
    let out = dir.join("out.nc");
    let r = lampost(&["fmt", &p, "-o", out.to_str().expect("utf8")]);
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(!dead.exists(), "the dead run's temporary file stayed");
    assert!(live.exists(), "a live process's temporary file was removed");
    assert!(
        other.exists(),
        "another output's temporary file was removed"
    );
}

/// `-o LINK` where the link names a file not there yet makes that file and keeps the
/// link (it made a new file in the link's place).
#[test]
fn a_link_to_a_missing_file_makes_the_file() {
    let dir = tempdir("dangling-link");
    let p = small_program(&dir, "in.nc");
    let link = dir.join("link.nc");
    std::os::unix::fs::symlink("made.nc", &link).expect("symlink");
    let r = lampost(&["fmt", &p, "-o", link.to_str().expect("utf8")]);
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(std::fs::symlink_metadata(&link)
        .expect("link")
        .file_type()
        .is_symlink());
    let made = std::fs::read_to_string(dir.join("made.nc")).expect("the link's file");
    assert!(made.contains("G1 X10"), "{made}");
}

/// `-o FIFO` with nobody reading it is refused at once (a blocking open waited for a
/// reader without end, deaf to SIGINT); with a reader, the output goes through it.
#[test]
fn a_fifo_output_is_written_through_or_refused_at_once() {
    let dir = tempdir("fifo-out");
    let p = small_program(&dir, "in.nc");
    let fifo = dir.join("pipe");
    let made = Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("no mkfifo here: test skipped");
        return;
    }
    let f = fifo.to_str().expect("utf8");
    let o = limited(
        &format!("timeout 20 \"$LAMPOST\" fmt {p} -o {f}"),
        4 << 20,
        20,
    );
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("no process is reading"), "{err}");
    let got = dir.join("got.nc");
    let o = limited(
        &format!(
            "cat {f} > {} & timeout 20 \"$LAMPOST\" fmt {p} -o {f}; s=$?; wait; exit $s",
            got.display()
        ),
        4 << 20,
        20,
    );
    // The reader may not have opened the FIFO yet when lampost does: then it is refused
    // as above and nothing is read; either way it never waits.
    if o.status.success() {
        let text = std::fs::read_to_string(&got).expect("read");
        assert!(text.contains("G1 X10"), "{text}");
    } else {
        assert!(
            stderr(&o).contains("no process is reading"),
            "{}",
            stderr(&o)
        );
    }
    assert!(temps(&dir).is_empty(), "{:?}", temps(&dir));
}

/// `--max-bytes` with `-o /dev/null`: the pieces would be files in /dev; refused.
#[test]
fn a_split_to_a_device_is_refused() {
    let dir = tempdir("split-device");
    let p = small_program(&dir, "in.nc");
    let r = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--index",
        "B=0,C=0",
        &p,
        "-o",
        "/dev/null",
        "--max-bytes",
        "600",
    ]);
    let err = stderr(&r);
    assert!(!r.status.success(), "{err}");
    assert!(err.contains("is a device or a pipe"), "{err}");
}

/// An input written to while the run reads it (a copy still arriving) is not posted as a
/// shorter program: nothing is put in place.
#[test]
fn an_input_changed_while_it_is_read_writes_nothing() {
    let dir = tempdir("input-changed");
    let input = dir.join("long.nc");
    std::fs::write(&input, long_program(300_000)).expect("write");
    let out = dir.join("out.nc");
    let child = Command::new(env!("CARGO_BIN_EXE_lampost"))
        .args(["post", "-q", "--machine", "nrc-lc", "--index", "B=30,C=45"])
        .arg(&input)
        .arg("-o")
        .arg(&out)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn");
    let t0 = std::time::Instant::now();
    while temps(&dir).is_empty() && t0.elapsed().as_secs() < 20 {
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    {
        use std::io::Write;
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&input)
            .expect("open");
        f.write_all(b"G1 X1 Y1\n").expect("append");
    }
    let o = child.wait_with_output().expect("wait");
    let err = stderr(&o);
    assert!(
        !o.status.success(),
        "the post finished before the change: {err}"
    );
    assert!(
        err.contains("the input changed while this run read it"),
        "{err}"
    );
    assert!(!out.exists(), "an output was written");
    assert!(temps(&dir).is_empty(), "{:?}", temps(&dir));
}
