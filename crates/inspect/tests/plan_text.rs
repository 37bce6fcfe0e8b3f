//! The plan as text (`lampost inspect plan` writes it, `reduce` reads it back): what is
//! written reads back to the same rows, and a row whose normal is not a unit vector, or
//! whose machine position is beyond travel, is refused at its line (found by the
//! `inspect` fuzz target's reading of what a deviation means: it is measured along the
//! normal, so a normal of length 2 would double every deviation, and one of length 0
//! would make every point read as on the surface).

use lampost_inspect::plan::{plan, read_text, to_text, Probe};
use lampost_inspect::{InspectError, Target};
use lampost_kinematics::Machine;

fn planned() -> (Machine, usize, String) {
    let m = Machine::builtin("nrc-lc", &[]).expect("machine");
    let head = m.head("sensor").expect("sensor head");
    let targets: Vec<Target> = (0..6)
        .map(|k| {
            let a = k as f64 * 0.5;
            Target {
                id: format!("p{k}"),
                point: [20.0 * a.cos(), 20.0 * a.sin(), 5.0],
                normal: [0.6 * a.cos(), 0.6 * a.sin(), 0.8],
            }
        })
        .collect();
    let p = plan(&m, head, Probe::Sensor, &targets, None).expect("plan");
    assert_eq!(p.rows.len(), 6);
    let text = to_text(&m, head, Probe::Sensor, &p.rows);
    (m, head, text)
}

#[test]
fn a_plan_reads_back_as_written() {
    let (m, head, text) = planned();
    let (probe, rows) = read_text(&m, head, &text).expect("reads");
    assert_eq!(probe, Probe::Sensor);
    assert_eq!(to_text(&m, head, probe, &rows), text);
}

#[test]
fn a_normal_that_is_not_a_unit_vector_is_refused_at_its_line() {
    let (m, head, text) = planned();
    for (from, to) in [
        ("0.800000000 ", "1.600000000 "),
        ("0.800000000 ", "0.000000000 "),
    ] {
        let lines: Vec<&str> = text.lines().collect();
        let bad_line = 4; // the second row
        let edited: Vec<String> = lines
            .iter()
            .enumerate()
            .map(|(i, l)| {
                if i + 1 == bad_line {
                    l.replacen(from, to, 1)
                } else {
                    l.to_string()
                }
            })
            .collect();
        assert_ne!(
            edited[bad_line - 1],
            lines[bad_line - 1],
            "the row has {from}"
        );
        match read_text(&m, head, &edited.join("\n")) {
            Err(InspectError::At { line, what }) => {
                assert_eq!(line, bad_line, "{what}");
                assert!(what.contains("not 1"), "{what}");
            }
            other => panic!("{to}: not refused at its line: {other:?}"),
        }
    }
}

#[test]
fn a_row_beyond_travel_is_refused_at_its_line() {
    let (m, head, text) = planned();
    // The third row's Z moved 10 m away.
    let edited: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 4 {
                let mut f: Vec<String> = l.split(' ').map(str::to_string).collect();
                f[3] = "10000.000000".into();
                f.join(" ")
            } else {
                l.to_string()
            }
        })
        .collect();
    match read_text(&m, head, &edited.join("\n")) {
        Err(InspectError::At { line, what }) => assert_eq!(line, 5, "{what}"),
        other => panic!("not refused at its line: {other:?}"),
    }
}
