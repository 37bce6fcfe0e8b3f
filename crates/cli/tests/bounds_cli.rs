//! Issue 13's bounded-input cases: each hostile input runs in a child with little
//! memory (`ulimit -v`) and a time limit, and must end with a located error.

mod common;

use common::*;

/// 60 MB of address space: a few times what a streaming command needs, a fraction of
/// what buffering any of these inputs would take.
const MEM_KIB: u64 = 60_000;

#[test]
fn a_peck_that_cannot_deepen_is_refused_at_once() {
    let o = limited(
        "printf 'G0 X0 Y0 Z0\\nF10 G83 X1 R10000000000 Z9999999999.99 Q0.0000001\\nG80\\n' | timeout $TIMEOUT \"$LAMPOST\" check -",
        MEM_KIB,
        30,
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("<stdin>:2:40") && e.contains("more than 10000 pecks"),
        "{e}"
    );
    // The same in a trace: no move of the cycle is written.
    let o = limited(
        "printf 'F10 G73 X1 R0 Z-1000 Q0.001 L10\\n' | timeout $TIMEOUT \"$LAMPOST\" trace -",
        MEM_KIB,
        30,
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("<stdin>:1:"), "{}", stderr(&o));
    assert!(o.stdout.is_empty());
}

#[test]
fn a_line_of_hundreds_of_megabytes_is_read_past_in_little_memory() {
    // 300 MB on one line, from a pipe (check spools standard input to a file; fmt
    // streams it); the lines after it are read as usual.
    let gen = "{ printf 'G0 X1\\n'; head -c 300000000 /dev/zero | tr '\\0' X; printf '\\nG1 X2 F10\\nG1 X Y\\n'; }";
    for cmd in ["check -", "fmt -", "trace -"] {
        let o = limited(
            &format!("{gen} | timeout $TIMEOUT \"$LAMPOST\" {cmd}"),
            MEM_KIB,
            120,
        );
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{cmd}: {e}");
        assert!(
            e.contains("<stdin>:2:1") && e.contains("the line is 300000000 bytes long"),
            "{cmd}: {e}"
        );
        if cmd == "check -" {
            // The next lines are still read: their error is found too.
            assert!(e.contains("<stdin>:4:"), "{e}");
        }
        assert!(e.len() < 4000, "the snippet is cut to a window");
    }
}

#[test]
fn nul_bytes_without_end_stop_reading() {
    for (cmd, name) in [
        ("check /dev/zero", "/dev/zero"),
        ("trace /dev/zero", "/dev/zero"),
        ("fmt /dev/zero", "/dev/zero"),
        ("check - < /dev/zero", "<stdin>"),
        ("fmt - < /dev/zero", "<stdin>"),
    ] {
        let o = limited(&format!("timeout $TIMEOUT \"$LAMPOST\" {cmd}"), MEM_KIB, 30);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {e}");
        assert!(
            e.contains(&format!("cannot read {name}"))
                && e.contains("65536 NUL bytes in a row (byte 0 on): binary data"),
            "{cmd}: {e}"
        );
    }
    // Fewer NUL bytes than that are an ordinary bad line, located.
    let o = limited(
        "{ printf 'G0 X1\\n'; head -c 1000 /dev/zero; printf '\\n'; } | \"$LAMPOST\" check -",
        MEM_KIB,
        30,
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("<stdin>:2:"), "{}", stderr(&o));
}

#[test]
fn check_json_streams_a_capped_list_in_little_memory() {
    // 200,000 lines with one error each.
    let o = limited(
        "yes 'G1 X Y1' | head -n 200000 | timeout $TIMEOUT \"$LAMPOST\" check --json -",
        MEM_KIB,
        120,
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON document");
    assert_eq!(v["errors"], 200_000);
    assert_eq!(v["warnings"], 0);
    assert_eq!(v["ok"], false);
    assert_eq!(v["not_shown"], 190_000);
    let list = v["diagnostics"].as_array().expect("a list");
    assert_eq!(list.len(), 10_000);
    assert_eq!(list[9_999]["line"], 10_000);
    // One diagnostic a line, as written.
    let text = String::from_utf8_lossy(&o.stdout);
    assert_eq!(text.lines().count(), 10_002);
    // A clean program: an empty list, nothing not shown.
    let o = lampost_stdin(&["check", "--json", "-"], b"G0 X1\n");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(
        (v["ok"].clone(), v["not_shown"].clone()),
        (true.into(), 0.into())
    );
    assert_eq!(v["diagnostics"], serde_json::json!([]));
}

#[test]
fn fmt_refuses_values_the_dialect_cannot_hold() {
    let dir = tempdir("ranges");
    let out = dir.join("out.nc");
    let src = b"G0 X1 Y2\nG65536\nM3 S100000\nN100000 X1\nT1 H100\nO10000\nL99999\nX123456.7\nG1 X1 F-5\n";
    let o = lampost_stdin(
        &[
            "fmt",
            "-",
            "--dialect",
            "fadal",
            "--units",
            "mm",
            "-o",
            &out.to_string_lossy(),
        ],
        src,
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    for (at, what) in [
        (
            "<stdin>:2:1",
            "G65536 is out of range for FADAL: 0 to 999.9",
        ),
        (
            "<stdin>:3:4",
            "S100000 is out of range for FADAL: 0 to 99999",
        ),
        (
            "<stdin>:4:1",
            "N100000 is out of range for FADAL: N0 to N99999",
        ),
        ("<stdin>:5:4", "H100 is out of range for FADAL: 0 to 99"),
        (
            "<stdin>:6:1",
            "O10000 is out of range for FADAL: O0 to O9999",
        ),
        ("<stdin>:7:1", "L99999 is out of range for FADAL: 0 to 9999"),
        (
            "<stdin>:8:1",
            "X123456.7 is out of range for FADAL: ±99999.999 in mm",
        ),
        ("<stdin>:9:7", "F-5 is out of range for FADAL: 0 to 99999"),
    ] {
        assert!(e.contains(at) && e.contains(what), "{at} {what}: {e}");
    }
    assert!(e.contains("8 error(s)"), "{e}");
    assert!(!out.exists(), "nothing written");
    // In inch, four whole digits; what rounds into range is written.
    let o = lampost_stdin(
        &["fmt", "-", "--dialect", "iso", "--units", "inch"],
        b"G0 X9999.99994 Y-12345\n",
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("Y-12345 is out of range for ISO: ±9999.9999 in inch"));
    let o = lampost_stdin(
        &["fmt", "-", "--dialect", "iso", "--units", "inch"],
        b"G0 X9999.99994\n",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(String::from_utf8_lossy(&o.stdout), "G0 X9999.9999\n");
}

#[test]
fn renumbering_refuses_to_pass_the_largest_n() {
    let src = b"G0 X1\nX2\nX3\n";
    let o = lampost_stdin(
        &[
            "fmt",
            "-",
            "--dialect",
            "fadal",
            "--units",
            "mm",
            "--renumber",
            "99990,5",
        ],
        src,
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("<stdin>:3:1")
            && e.contains("renumbering reaches N100000 here, past the largest N of FADAL, N99999"),
        "{e}"
    );
    assert!(e.contains("1 error(s)"), "one error, not one per line: {e}");
    let o = lampost_stdin(&["fmt", "-", "--renumber", "18446744073709551614,1"], src);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("<stdin>:1:1") && e.contains("N999999999"), "{e}");
    assert!(!String::from_utf8_lossy(&o.stdout).contains("N9223372036854775807"));
    // A step that overflows u64 after a number in range: refused at the next block.
    let o = lampost_stdin(
        &["fmt", "-", "--renumber", "999999999,18446744073709551615"],
        src,
    );
    let e = stderr(&o);
    assert!(
        e.contains("<stdin>:2:1") && e.contains("N18446744073709551615"),
        "{e}"
    );
    // In range: numbered as asked.
    let o = lampost_stdin(
        &[
            "fmt",
            "-",
            "--dialect",
            "fadal",
            "--units",
            "mm",
            "--renumber",
            "99985,5",
        ],
        src,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("N99995 X3.000"));
}

#[test]
fn post_and_verify_spool_a_program_from_a_pipe_instead_of_holding_it() {
    // 150 MB through a pipe under 100 MB of address space: the post reads its input
    // twice (posting, then verifying what it wrote), so standard input goes to a
    // temporary file, never into memory (it was read whole: "out of memory").
    let dir = tempdir("spool-stdin");
    let out = dir.join("o.nc");
    let tmp = dir.join("tmp");
    std::fs::create_dir_all(&tmp).expect("temp dir");
    let gen = "{ printf 'G21 G90\\nG0 X0 Y0 Z5\\nG1 Z0 F500\\nG1 X10\\nG1 Y10\\nM30\\n'; yes '(a comment line that pads the program to many megabytes)' | head -n 2600000; }";
    let o = limited(
        &format!(
            "{gen} | TMPDIR={} timeout $TIMEOUT \"$LAMPOST\" post --machine nrc-lc --index B=30,C=45 - -o {}",
            tmp.display(),
            out.display()
        ),
        100_000,
        // A bound against a hang, not a speed test: 150 MB through the debug build
        // takes 20–30 s alone and over 60 s beside other builds.
        240,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let posted = std::fs::read_to_string(&out).expect("posted");
    assert!(
        posted.contains("B30.") && posted.contains("C45."),
        "{posted}"
    );
    let o = limited(
        &format!(
            "{gen} | TMPDIR={} timeout $TIMEOUT \"$LAMPOST\" verify --machine nrc-lc --index B=30,C=45 - {}",
            tmp.display(),
            out.display()
        ),
        100_000,
        240,
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // The spooled copy is gone once the command ends.
    let left: Vec<_> = std::fs::read_dir(&tmp)
        .expect("temp dir")
        .flatten()
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// Every input that is read whole (meshes, per-point paths, point files, logs, machine,
/// setup and job files) stops at once on an endless device (`/dev/zero`: a run of NUL
/// bytes is binary data) with an error naming the file, exit 2, and nothing written;
/// before, each of these commands read on until the memory ran out.
#[test]
fn an_endless_device_as_any_input_stops_at_once() {
    let dir = tempdir("endless");
    let nc = dir.join("t.nc");
    std::fs::write(&nc, "G0 X0 Y0 Z1\nM30\n").unwrap_or_default();
    let path = dir.join("p.txt");
    std::fs::write(
        &path,
        "x y z i j k feed laser\n0 0 0 0 0 1 600 0\n10 0 0 0 0 1 600 1\n",
    )
    .unwrap_or_default();
    let cell = dir.join("cell");
    let posted = lampost(&[
        "post",
        "--machine",
        "puma-lens",
        &path.display().to_string(),
        "-o",
        &cell.display().to_string(),
    ]);
    assert!(posted.status.success(), "{}", stderr(&posted));
    let out = dir.join("out");
    let (nc, out, cell) = (nc.display(), out.display(), cell.display());
    let z = "/dev/zero";
    for cmd in [
        format!("post --machine puma-lens {z} -o {out}"),
        format!("post --machine {z} {nc} -o {out}"),
        format!("post --machine nrc-lc --job {z} {nc} -o {out}"),
        format!("post --machine nrc-lc --part {z} {nc} -o {out}"),
        format!("plan path {z} --layer 1 -o {out}"),
        format!("plan slice {z} --layer 1"),
        format!("mesh info {z}"),
        format!("fit sphere {z}"),
        format!("probe read {z}"),
        format!("align angle {z}"),
        format!("align level --machine nrc-lc {z}"),
        format!("align register --mesh {z} {z}"),
        format!("calibrate pivot --machine fadal-lamp {z}"),
        format!("calibrate laser {z}"),
        format!("inspect compare {z}"),
        format!("verify --machine puma-lens {cell} --input {z}"),
    ] {
        let o = limited(&format!("timeout $TIMEOUT \"$LAMPOST\" {cmd}"), 400_000, 20);
        let e = stderr(&o);
        assert!(
            o.status.code() == Some(2),
            "{cmd}: {:?} {e}",
            o.status.code()
        );
        // A device as the machine file is refused before it is read.
        assert!(
            e.contains("NUL bytes in a row")
                || cmd.contains(&format!("--machine {z}")) && e.contains("not a regular file"),
            "{cmd}: {e}"
        );
        assert!(!dir.join("out").exists(), "{cmd}: an output was written");
    }
}

/// A place on the command line beyond any machine (`--origin 1e300,0,0`) is refused
/// with the option's name; it had been taken, and the header comment written with the
/// origin's 300 digits.
#[test]
fn an_origin_beyond_any_machine_is_refused() {
    let dir = tempdir("far-origin");
    let nc = dir.join("t.nc");
    std::fs::write(&nc, "G21 G90\nG0 X0 Y0 Z1\nG1 Z0 F100\nG1 X10\nM30\n").unwrap_or_default();
    let out = dir.join("t.out.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--origin",
        "1e300,0,0",
        &nc.display().to_string(),
        "-o",
        &out.display().to_string(),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--origin") && e.contains("more than 1e9"), "{e}");
    assert!(!out.exists());
}
