//! Real slicer programs (`../shared/corpus/slicers/`, sources in its SOURCES.md) as
//! deposition input: `check` passes, `trace` gives moves, `post --e-extrusion` posts them
//! with one laser-on per extruding run and the extruding length deposited.

mod common;

use std::path::PathBuf;

use common::{extruding_runs, lampost, posted_deposition, shared, stderr, tempdir};

/// The corpus programs, or `None` (with a note) where `../shared` is absent.
fn corpus() -> Option<Vec<PathBuf>> {
    let Some(dir) = shared() else {
        eprintln!("../shared is absent: slicer corpus tests skipped");
        return None;
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("corpus/slicers"))
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "gcode"))
        .collect();
    files.sort();
    assert!(files.len() >= 2, "PrusaSlicer and Cura programs expected");
    Some(files)
}

#[test]
fn slicer_programs_check_and_trace() {
    let Some(files) = corpus() else { return };
    for f in files {
        let p = f.to_str().expect("utf-8 path");
        let out = lampost(&["check", "--e-word", "extrusion", p]);
        assert!(
            out.status.success(),
            "{p}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let out = lampost(&["trace", "--e-word", "extrusion", "--json", p]);
        assert!(out.status.success(), "{p}");
        let text = String::from_utf8_lossy(&out.stdout);
        let moves = text.matches("\"extruded\"").count();
        assert!(moves > 100, "{p}: {moves} moves");
    }
}

#[test]
fn slicer_programs_post_one_laser_on_per_extruding_run() {
    let Some(files) = corpus() else { return };
    let dir = tempdir("slicer-post");
    for f in files {
        let name = f
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("?")
            .to_string();
        let src = std::fs::read_to_string(&f).expect("reads");
        // PrusaSlicer's start code homes every axis (G28) and levels the bed (G29): a
        // move to machine home cannot be placed on the part and G29 is not simulated,
        // so the post refuses them (travel, not deposition). They are left out here;
        // nothing else in the program is changed.
        let input: String = src
            .lines()
            .filter(|l| !(l.starts_with("G28") || l.starts_with("G29")))
            .map(|l| format!("{l}\n"))
            .collect();
        let inp = dir.join(&name);
        std::fs::write(&inp, &input).expect("writes");
        let out_path = dir.join(format!("{name}.nc"));
        let out = lampost(&[
            "post",
            "--machine",
            "nrc-lc",
            "--e-extrusion",
            "--convert-units",
            inp.to_str().expect("utf-8"),
            "-o",
            out_path.to_str().expect("utf-8"),
        ]);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let nc = std::fs::read_to_string(&out_path).expect("posted");
        let (runs, extruding) = extruding_runs(&input);
        let (ons, deposited) = posted_deposition(&nc);
        assert!(runs > 0 && extruding > 0.0, "{name}");
        assert_eq!(ons, runs, "{name}: laser-on events vs extruding runs");
        // The inputs' coordinates are on the posted 0.001 mm grid, so the posted text
        // carries them exactly.
        let rel = (deposited - extruding).abs() / extruding;
        assert!(
            rel <= 1e-9,
            "{name}: deposited {deposited} vs extruding {extruding} (relative {rel:e})"
        );
    }
}

#[test]
fn relative_extrusion_deposits_every_segment() {
    // M83: the second E1.0 deposits again; the E-only unretract and the F-only line
    // switch nothing; a G1 with no E after a G0 that raised E does not deposit.
    let src = "G21\nG90\nM83\nG0 X0 Y0 Z1\nG1 Z0.2 F600\nG1 X10 E1.0\nG1 X20 E1.0\n\
               G1 E-.8 F2100\nG1 F1200\nG1 E.8 F2400\nG1 Y10 E1.0 F600\nG0 X30 E5\nG1 X40\n\
               G1 X50 E0.5\n";
    let dir = tempdir("slicer-m83");
    let inp = dir.join("m83.gcode");
    std::fs::write(&inp, src).expect("writes");
    let out_path = dir.join("m83.nc");
    let out = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--e-extrusion",
        inp.to_str().expect("utf-8"),
        "-o",
        out_path.to_str().expect("utf-8"),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let nc = std::fs::read_to_string(&out_path).expect("posted");
    let (runs, extruding) = extruding_runs(src);
    assert_eq!((runs, extruding), (2, 40.0));
    let (ons, deposited) = posted_deposition(&nc);
    assert_eq!(ons, 2, "{nc}");
    assert!((deposited - 40.0).abs() <= 40.0 * 1e-9, "{deposited}\n{nc}");
}

#[test]
fn e_extrusion_without_any_extruding_move_is_refused() {
    // E words only on a G0, a retract and an unretract, a G92 reset: no move extrudes, so
    // the post would write travel alone. Refused at the first feed move (line 5), nothing
    // written.
    let src = "G21\nG90\nG0 X0 Y0 Z1 E2\nG92 E0\nG1 Z0.2 F600\nG1 X10 F1200\nG1 E-.8\n\
               G1 E0\nG1 X20 Y5 E0\n";
    let dir = tempdir("slicer-dry");
    let inp = dir.join("dry.gcode");
    std::fs::write(&inp, src).expect("writes");
    let out_path = dir.join("dry.nc");
    let post = |extra: &[&str]| {
        let mut args = vec!["post", "--machine", "nrc-lc"];
        args.extend_from_slice(extra);
        args.extend([
            inp.to_str().expect("utf-8"),
            "-o",
            out_path.to_str().expect("utf-8"),
        ]);
        lampost(&args)
    };
    for extra in [&["--e-extrusion"][..], &["--flavor", "marlin"][..]] {
        let out = post(extra);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{extra:?}: {err}");
        assert!(err.contains("no move of the program extrudes"), "{err}");
        assert!(err.contains("dry.gcode:5:1"), "{err}");
        assert!(err.contains("5 | G1 Z0.2 F600"), "{err}");
        assert!(
            err.contains("= help: when E is not extrusion here")
                && err.contains("without --e-extrusion"),
            "{err}"
        );
        let why = if extra[0] == "--e-extrusion" {
            "(--e-extrusion)"
        } else {
            "(implied by --flavor marlin)"
        };
        assert!(err.contains(why), "{err}");
        assert!(!out_path.exists(), "{extra:?}: nothing is written");
    }
    // One extruding move is enough.
    let one = src.replace("G1 X10 F1200", "G1 X10 E0.4 F1200");
    std::fs::write(&inp, one).expect("writes");
    let out = post(&["--e-extrusion"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(out_path.exists());
}

#[test]
fn minimal_slicer_lines_check_clean() {
    let src = "G92 E0\nM201 X2500 Y2500 Z400 E5000\nM205 X1.00 Y1.00 Z1.00 E1.00\nG28 X\n\
               G162 X Y\nM569 S1 X Y\nG4 S1\nG4\nM862.3 P \"MINI\"\nM486 A3DBenchy.stl\nT0 R\n\
               M221 R\nM1002 judge_flag 1\nM117 Layer 1\nM83\nG1 X1e-05 Y5 F600 E.5\n";
    let out = common::lampost_stdin(&["check", "--e-word", "extrusion", "-"], src.as_bytes());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = common::lampost_stdin(&["trace", "--e-word", "extrusion", "-"], src.as_bytes());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(!text.contains("X1 Y1 Z1"), "M205 traced as a move:\n{text}");
    assert!(text.contains("Y5"), "{text}");
}

/// A printer program with Klipper commands: the post ignores the settings and says so
/// once (with a count), refuses a macro at its line, and posts what is left.
#[test]
fn klipper_settings_are_reported_once_and_macros_refused() {
    let dir = tempdir("slicer-klipper");
    let body = "; generated by PrusaSlicer 2.6.1\nG21\nM83\nG90\n\
                SET_PRESSURE_ADVANCE ADVANCE=0.04\n\
                EXCLUDE_OBJECT_START NAME=cube\nG1 Z0.3 F600\nG1 X0 Y0 F3000\n\
                G1 X10 Y0 E0.5 F1200\nG1 X10 Y10 E0.5\nEXCLUDE_OBJECT_END NAME=cube\n\
                EXCLUDE_OBJECT_START NAME=cube\nG1 Z0.6 F600\nG1 X0 Y10 E0.5 F1200\n\
                EXCLUDE_OBJECT_END NAME=cube\n";
    let ok = dir.join("settings.gcode");
    std::fs::write(&ok, body).expect("write");
    let out = dir.join("settings.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--e-extrusion",
        ok.to_str().expect("utf8"),
        "-o",
        out.to_str().expect("utf8"),
    ]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert_eq!(e.matches("firmware setting (Klipper)").count(), 1, "{e}");
    assert!(e.contains("settings.gcode:5: SET_PRESSURE_ADVANCE"), "{e}");
    assert!(e.contains("4 more warning(s) like that of line 5"), "{e}");
    let macro_prog = dir.join("macro.gcode");
    std::fs::write(
        &macro_prog,
        body.replace("G90\n", "G90\nSTART_PRINT BED_TEMP=60\n"),
    )
    .expect("write");
    let out2 = dir.join("macro.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--e-extrusion",
        macro_prog.to_str().expect("utf8"),
        "-o",
        out2.to_str().expect("utf8"),
    ]);
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(
        e.contains("macro.gcode:5:") && e.contains("START_PRINT"),
        "{e}"
    );
    assert!(!out2.exists());
}

/// Firmware retraction (Cura's, PrusaSlicer's and OrcaSlicer's option, standard with
/// Klipper and RepRapFirmware): `G10` retracts and `G11` unretracts the filament inside
/// the firmware; neither moves the head nor switches deposition, and the post takes them
/// (it refused the unknown `G11` before).
#[test]
fn firmware_retraction_moves_nothing_and_posts() {
    let src = ";FLAVOR:Marlin\nG21\nG90\nM82\nG92 E0\nG0 X0 Y0 Z0.3 F1200\nG1 X10 E1\nG10\n\
               G0 X20 Y20\nG11\nG1 X30 Y20 E2\nG10\nG0 X0 Y0\nM30\n";
    let dir = tempdir("slicer-g10-g11");
    let inp = dir.join("fw-retract.gcode");
    std::fs::write(&inp, src).expect("writes");
    let inp_s = inp.to_str().expect("utf-8");
    let o = lampost(&["check", inp_s]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("0 warning(s)"), "{}", stderr(&o));
    let out_path = dir.join("fw-retract.nc");
    let o = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--e-extrusion",
        inp_s,
        "-o",
        out_path.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let nc = std::fs::read_to_string(&out_path).expect("posted");
    let (runs, extruding) = extruding_runs(src);
    assert_eq!((runs, extruding), (2, 20.0));
    let (ons, deposited) = posted_deposition(&nc);
    assert_eq!(ons, 2, "{nc}");
    assert!((deposited - 20.0).abs() <= 20.0 * 1e-9, "{deposited}\n{nc}");
    // Outside a printer program G11 is no G-code.
    let mill = dir.join("mill.nc");
    std::fs::write(&mill, "G21 G90\nG0 X0 Y0\nG11\nM30\n").expect("writes");
    let o = lampost(&[
        "check",
        "--flavor",
        "linuxcnc",
        mill.to_str().expect("utf-8"),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains(":3:1"), "{}", stderr(&o));
}
