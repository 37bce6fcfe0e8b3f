//! For random setups and indexes, the posted program verifies within tolerance, and a
//! program that leaves the travel is refused.

use lampost_kinematics::{Machine, Vector3};
use lampost_post::{post, verify, Frame, Orient, PostConfig, PostError, Process, Section, Source};
use proptest::prelude::*;

const PROGRAM: &str = "G20 G90 G17\nG0 X0 Y0 Z0.1\nG1 Z0 F20.\nG1 X0.8 F30.\nG2 X1.0 Y0.2 I0 J0.2\nG1 Y0.6\nG3 X0.6 Y1.0 I-0.4 J0\nG1 X0 Y0.5\nG1 X0 Y0\nG0 Z0.2\nM30\n";

fn section(frame: Frame, orient: Orient, program: &str) -> Section {
    Section {
        name: "prop.nc".into(),
        source: Source::Bytes(program.as_bytes().to_vec()),
        frame,
        orient,
        layers: None,
    }
}

fn config(m: &Machine, process: Process) -> PostConfig {
    let mut cfg = PostConfig::new(m, process);
    cfg.head = m.head("spindle").unwrap_or(0);
    cfg.verify_tolerance = 0.001;
    cfg.header = vec!["prop".into()];
    cfg
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(60))]

    #[test]
    fn posted_programs_verify(a in -180.0f64..180.0, b in -60.0f64..60.0, ox in -2.0f64..2.0, oy in -2.0f64..2.0, oz in -1.0f64..1.0,
                              zx in -0.5f64..0.5, zy in -0.5f64..0.5, use_index in any::<bool>()) {
        let m = Machine::builtin("fadal-lamp", &[]).expect("machine");
        let (frame, orient) = if use_index {
            (Frame::translation(Vector3::new(ox, oy, oz)), Orient::Index([a, b]))
        } else {
            let f = Frame::from_axes(Vector3::new(ox, oy, oz), Vector3::new(1.0, 0.0, 0.0), Vector3::new(zx, zy, 1.0)).expect("frame");
            (f, Orient::ToolAxis)
        };
        let secs = vec![section(frame, orient, PROGRAM)];
        let cfg = config(&m, Process::Machine { tool: None, length_offset: None, work_offset: None, spindle: 1000.0, coolant: false });
        let mut out = Vec::new();
        match post(&m, &secs, &cfg, &mut out, |_| {}) {
            Ok(_) => {
                let v = verify(&m, &secs, cfg.head, &cfg.process, cfg.intended, &out[..], 0.001, None, None).expect("verifies");
                // Chord midpoints are compared too: up to the chord tolerance, plus rounding.
                prop_assert!(v.max_position_error < cfg.tolerance + 2e-4, "{v:?}");
                prop_assert!(v.max_axis_error_deg < 1e-3, "{v:?}");
                prop_assert!(v.compared >= 7);
            }
            // Some random placements leave the travel: that must be the reason.
            Err(PostError::Limit { .. }) => {}
            Err(e) => prop_assert!(false, "unexpected: {e}"),
        }
    }
}

#[test]
fn a_program_beyond_travel_is_refused() {
    let m = Machine::builtin("fadal-lamp", &[]).expect("machine");
    let far = "G20 G90\nG0 X0 Y0 Z0.1\nG1 X25 F10\n";
    let secs = vec![section(
        Frame::translation(Vector3::zeros()),
        Orient::Index([0.0, 0.0]),
        far,
    )];
    let cfg = config(&m, Process::Deposit { power: 500.0 });
    let e = post(&m, &secs, &cfg, Vec::new(), |_| {}).expect_err("beyond travel");
    assert!(
        matches!(e, PostError::Limit { ref axis, line: 3, .. } if axis == "X"),
        "{e}"
    );
}

#[test]
fn a_grid_of_indexes_all_post_and_verify() {
    let m = Machine::builtin("fadal-lamp", &[]).expect("machine");
    let cfg = config(&m, Process::Deposit { power: 500.0 });
    let mut n = 0;
    for a in (0..8).map(|k| f64::from(k) * 45.0 - 180.0) {
        for b in [-60.0, -30.0, 0.0, 30.0, 60.0] {
            let secs = vec![section(
                Frame::translation(Vector3::new(0.5, -0.5, 0.25)),
                Orient::Index([a, b]),
                PROGRAM,
            )];
            let mut out = Vec::new();
            post(&m, &secs, &cfg, &mut out, |_| {}).unwrap_or_else(|e| panic!("A={a} B={b}: {e}"));
            let v = verify(
                &m,
                &secs,
                cfg.head,
                &cfg.process,
                cfg.intended,
                &out[..],
                0.001,
                None,
                None,
            )
            .expect("verifies");
            assert!(
                v.max_position_error < cfg.tolerance + 2e-4 && v.compared >= 7,
                "A={a} B={b}: {v:?}"
            );
            n += 1;
        }
    }
    assert_eq!(n, 40);
}
