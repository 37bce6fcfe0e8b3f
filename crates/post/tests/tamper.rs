//! Issue 11's differential test: random planar programs (rapids, G53/G28 retracts,
//! lines, arcs, helices; in machining, sometimes a tool of its own for each run, its
//! change posted) at random placements, indexes, layer schedules and second sections on
//! three machines and both FADAL heads. Every posted program must pass
//! `verify`; on the FADAL and the NRC cell, a checker written here from papers 000's and
//! 003's formulas (not the crate's kinematics) confirms that no rapid but a vertical one
//! goes below the work's top plus the margin. Then each posted program is tampered with
//! (a feed or rotary value moved beyond tolerance, a rapid added to a point of the work,
//! a feed's F word changed, the process changed before a feed (a work offset, a tool
//! length offset, a tool change, another S), a process switched within a run (the laser
//! or powder off, the spindle or coolant on in a deposition; the spindle stopped,
//! reversed or oriented, coolant or the laser on in a machining), a motion block
//! removed, a posted tool change left out or changed) and `verify` must
//! catch at least 99 % of the tampered
//! programs. Seeded, so a failure reproduces.

mod papers;
use lampost_gcode::{Event, MoveKind, Options, Stream, Units};
use lampost_kinematics::{Machine, MachineDef, Vector3};
use lampost_post::{
    post, verify, Frame, LayerSchedule, Orient, PostConfig, PostDialect, PostError, Process,
    Section, Source,
};
use papers::{fadal_tip, nrc_tip};

use lampost_testkit::XorShift as Rng;

/// A random planar program in `k` units per inch (1 or 25.4), within a 1-in square.
fn program(r: &mut Rng, k: f64) -> String {
    let units = if k == 1.0 { "G20" } else { "G21" };
    let f = |v: f64| format!("{:.4}", v * k);
    let mut s = format!("{units} G90 G17\n");
    let runs = 1 + r.below(3);
    for run in 0..runs {
        let (mut x, mut y) = (r.range(0.0, 1.0), r.range(0.0, 1.0));
        let z0 = 0.02 * run as f64;
        s += &format!("G0 X{} Y{} Z{}\n", f(x), f(y), f(z0 + 0.1));
        s += &format!("G1 Z{} F{}\n", f(z0), f(20.0));
        let mut z = z0;
        for _ in 0..2 + r.below(5) {
            match r.below(4) {
                0 | 1 => {
                    x = r.range(0.0, 1.0);
                    y = r.range(0.0, 1.0);
                    s += &format!("G1 X{} Y{}\n", f(x), f(y));
                }
                _ => {
                    // An arc about a centre at 0.1–0.4 in, sometimes a helix or a full turn.
                    let rad = r.range(0.1, 0.4);
                    let a0 = r.range(0.0, std::f64::consts::TAU);
                    let (cx, cy) = (x - rad * a0.cos(), y - rad * a0.sin());
                    let a1 = a0 + r.range(-3.0, 3.0);
                    let (ex, ey) = (cx + rad * a1.cos(), cy + rad * a1.sin());
                    let g = if r.below(2) == 0 { "G2" } else { "G3" };
                    let helix = r.below(4) == 0;
                    let ez = if helix { z + 0.01 } else { z };
                    let full = r.below(6) == 0;
                    let (ex, ey) = if full { (x, y) } else { (ex, ey) };
                    s += &format!(
                        "{g} X{} Y{} Z{} I{} J{}\n",
                        f(ex),
                        f(ey),
                        f(ez),
                        f(cx - x),
                        f(cy - y)
                    );
                    x = ex;
                    y = ey;
                    z = ez;
                }
            }
        }
        match r.below(3) {
            0 => s += "G53 G0 Z-1.\n",
            1 => s += "G28 G91 Z0.\nG90\n",
            _ => s += &format!("G0 Z{}\n", f(z + 0.2)),
        }
    }
    s + "M30\n"
}

/// `text` cut by a tool of its own for each run: `T<n> M6`, `G43 H<n>` and
/// `S<1000 + 100(n - 1)> M3` before run n's first move (T1 at S1000, as [`config`] posts
/// the first tool with `tools`).
fn with_tools(text: &str) -> String {
    let mut n = 0;
    let mut out = String::new();
    for l in text.lines() {
        if l.starts_with("G0 X") {
            n += 1;
            out += &format!("T{n} M6\nG43 H{n}\nS{} M3\n", 1000 + 100 * (n - 1));
        }
        out += l;
        out.push('\n');
    }
    out
}

fn trt() -> Machine {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fixtures/machines/xyzac-trt.toml"
    ))
    .expect("fixture");
    Machine::new(
        MachineDef::from_toml(&text, "xyzac-trt.toml").expect("parses"),
        &[],
    )
    .expect("valid")
}

fn config(m: &Machine, head: usize, deposit: bool, tools: bool) -> PostConfig {
    let process = if deposit {
        Process::Deposit { power: 500.0 }
    } else {
        Process::Machine {
            tool: tools.then_some(1),
            length_offset: tools.then_some(1),
            work_offset: None,
            spindle: 1000.0,
            coolant: false,
        }
    };
    let mut cfg = PostConfig::new(m, process);
    cfg.head = head;
    cfg.dialect = PostDialect::Iso;
    if m.units == lampost_kinematics::Units::Mm {
        cfg.tolerance = 0.0125;
        cfg.verify_tolerance = 0.025;
    }
    cfg.header = vec!["tamper".into()];
    cfg
}

/// (line, kind, start, end) of every move of a posted program (X Y Z A B C of AXES).
type Mv = (u32, MoveKind, [f64; 9], [f64; 9]);

fn moves(text: &str, units: Units) -> Vec<Mv> {
    Stream::from_bytes(
        text.as_bytes(),
        Options {
            units,
            ..Options::default()
        },
        true,
    )
    .filter_map(|e| match e {
        Ok(Event::Move(m)) => Some((m.line, m.kind, m.start, m.end)),
        _ => None,
    })
    .collect()
}

/// The check from the papers' formulas (`tip` maps joints X Y Z and the two rotaries to
/// the tip and tool axis in the part frame): every rapid that is not vertical keeps the
/// tip at least `margin` above every feed tip, along the tool axis.
fn rapids_clear_the_work(
    mv: &[Mv],
    tip: impl Fn(&[f64; 9]) -> ([f64; 3], [f64; 3]),
    margin: f64,
    eps: f64,
) -> Result<(), String> {
    let tips: Vec<[f64; 3]> = mv
        .iter()
        .filter(|m| !matches!(m.1, MoveKind::Rapid))
        .map(|m| tip(&m.3).0)
        .collect();
    for m in mv.iter().filter(|m| matches!(m.1, MoveKind::Rapid)) {
        let (s, e) = (m.2, m.3);
        if s[0] == e[0] && s[1] == e[1] && s[3] == e[3] && s[4] == e[4] && s[5] == e[5] {
            continue;
        }
        for q in [s, e] {
            let (t, ax) = tip(&q);
            let h = |x: &[f64; 3]| x[0] * ax[0] + x[1] * ax[1] + x[2] * ax[2];
            let top = tips.iter().map(h).fold(f64::MIN, f64::max);
            if h(&t) < top + margin - eps {
                return Err(format!(
                    "line {}: a rapid {:.4} above the work (margin {margin})",
                    m.0,
                    h(&t) - top
                ));
            }
        }
    }
    Ok(())
}

/// A tampered copy of `text`, or `None` when the chosen change does not apply.
fn tamper(
    r: &mut Rng,
    text: &str,
    mv: &[Mv],
    mm: bool,
    deposit: bool,
    tools: bool,
) -> Option<(String, &'static str)> {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let fmt = |v: f64| {
        if mm {
            format!("{v:.3}")
        } else {
            format!("{v:.4}")
        }
    };
    let tol = if mm { 0.025 } else { 0.001 };
    let feeds: Vec<&Mv> = mv
        .iter()
        .filter(|m| !matches!(m.1, MoveKind::Rapid))
        .collect();
    match r.below(if tools { 7 } else { 6 }) {
        6 => {
            // A posted tool change (after the first tool's) left out, to another tool,
            // with another length offset, or with the last tool's speed.
            let at: Vec<usize> = (0..lines.len())
                .filter(|&k| lines[k].starts_with('T') && lines[k].ends_with(" M6"))
                .skip(1)
                .collect();
            if at.is_empty() {
                return None;
            }
            let k = at[r.below(at.len())];
            match r.below(4) {
                0 => {
                    lines.remove(k);
                }
                1 => lines[k] = "T9 M6".into(),
                2 => lines[k + 1] = "G43 H9".into(),
                _ => lines[k + 2] = "S9000 M3".into(),
            }
            Some((lines.join("\n") + "\n", "tool change tampered"))
        }
        0 => {
            // One value moved beyond tolerance: an axis word of a feed, or a rotary.
            let m = feeds[r.below(feeds.len())];
            let idx = (m.0 - 1) as usize;
            let words: Vec<String> = lines[idx].split(' ').map(str::to_string).collect();
            let cand: Vec<usize> = (0..words.len())
                .filter(|&k| {
                    words[k]
                        .bytes()
                        .next()
                        .is_some_and(|c| b"XYZABC".contains(&c))
                })
                .collect();
            if cand.is_empty() {
                return None;
            }
            let k = cand[r.below(cand.len())];
            let letter = words[k].as_bytes()[0];
            let v: f64 = words[k][1..].parse().ok()?;
            let sign = if r.below(2) == 0 { -1.0 } else { 1.0 };
            let nv = if b"ABC".contains(&letter) {
                format!("{:.3}", v + sign * r.range(0.05, 2.0))
            } else {
                fmt(v + sign * tol * r.range(3.0, 50.0))
            };
            let mut w = words;
            w[k] = format!("{}{nv}", letter as char);
            lines[idx] = w.join(" ");
            Some((lines.join("\n") + "\n", "value moved"))
        }
        1 => {
            // A rapid added to a point of the work (another feed's end), after a feed.
            let at = feeds[r.below(feeds.len())];
            let to = feeds[r.below(feeds.len())];
            if (0..3).all(|k| (at.3[k] - to.3[k]).abs() < 1e-3) {
                return None;
            }
            let e = to.3;
            lines.insert(
                at.0 as usize,
                format!("G0 X{} Y{} Z{}", fmt(e[0]), fmt(e[1]), fmt(e[2])),
            );
            Some((lines.join("\n") + "\n", "rapid through the work"))
        }
        2 => {
            // A feed changed: the F word of a feed block (per minute) scaled by 0.1-0.9
            // or 1.1-10, or an F word given to a feed block without one.
            let m = feeds[r.below(feeds.len())];
            let idx = (m.0 - 1) as usize;
            if text.contains("G93") {
                return None;
            }
            let factor = if r.below(2) == 0 {
                r.range(0.1, 0.9)
            } else {
                r.range(1.1, 10.0)
            };
            let mut words: Vec<String> = lines[idx].split(' ').map(str::to_string).collect();
            match words.iter().position(|w| w.starts_with('F')) {
                Some(k) => {
                    let v: f64 = words[k][1..].parse().ok()?;
                    words[k] = format!("F{:.1}", v * factor);
                }
                None => {
                    // The feed in force: the last F word before this line.
                    let v: f64 = lines[..idx].iter().rev().find_map(|l| {
                        l.split(' ')
                            .find(|w| w.starts_with('F'))
                            .and_then(|w| w[1..].parse().ok())
                    })?;
                    words.push(format!("F{:.1}", v * factor));
                }
            }
            lines[idx] = words.join(" ");
            Some((lines.join("\n") + "\n", "feed changed"))
        }
        3 => {
            // The process changed before a feed: another work offset, a tool length
            // offset, a tool change, or another S (the programs are posted with no
            // offsets or tool, S1000 for the spindle, the laser at 500).
            let m = feeds[r.below(feeds.len())];
            let code = ["G55", "E2", "G43 H7", "T4 M6", "S2500"][r.below(5)];
            lines.insert((m.0 - 1) as usize, code.to_string());
            Some((lines.join("\n") + "\n", "process changed"))
        }
        4 => {
            // A process switch before a feed within a run (not the approach onto it,
            // made with the laser still off): the laser or its powder off, the spindle
            // or coolant on in a deposition; the spindle stopped, reversed or oriented,
            // coolant (posted without) or the laser on in a machining.
            let runs: Vec<&Mv> = mv
                .windows(2)
                .filter(|w| {
                    !matches!(w[0].1, MoveKind::Rapid) && !matches!(w[1].1, MoveKind::Rapid)
                })
                .map(|w| &w[1])
                .collect();
            if runs.is_empty() {
                return None;
            }
            let m = runs[r.below(runs.len())];
            let codes: &[&str] = if deposit {
                &["M72", "M74", "M3", "M8"]
            } else {
                &["M5", "M4", "M19", "M8", "M71"]
            };
            lines.insert((m.0 - 1) as usize, codes[r.below(codes.len())].to_string());
            Some((lines.join("\n") + "\n", "process switched"))
        }
        _ => {
            // A motion block removed.
            let m = &mv[r.below(mv.len())];
            lines.remove((m.0 - 1) as usize);
            Some((lines.join("\n") + "\n", "block removed"))
        }
    }
}

/// The lines that differ between two texts (first difference and its neighbours).
fn diff_lines(a: &str, b: &str) -> Vec<String> {
    let (la, lb): (Vec<&str>, Vec<&str>) = (a.lines().collect(), b.lines().collect());
    let k = la.iter().zip(&lb).take_while(|(x, y)| x == y).count();
    let from = k.saturating_sub(1);
    vec![
        format!("was {:?}", &la[from..(k + 2).min(la.len())]),
        format!("now {:?}", &lb[from..(k + 2).min(lb.len())]),
    ]
}

#[test]
fn random_programs_post_verify_and_tampering_is_caught() {
    let machines = [
        (Machine::builtin("fadal-lamp", &[]).expect("fadal"), "fadal"),
        (Machine::builtin("nrc-lc", &[]).expect("nrc"), "nrc"),
        (trt(), "trt"),
    ];
    let mut r = Rng(0x1A3B_5C7D_9E0F_1234);
    let (mut posted, mut refused, mut tampered, mut caught) = (0, 0, 0, 0);
    // Per kind of change: (tampered, caught).
    let mut kinds: std::collections::BTreeMap<&str, (usize, usize)> = Default::default();
    let mut missed: Vec<String> = Vec::new();
    for case in 0..240 {
        let (m, name) = &machines[case % 3];
        let mm = m.units == lampost_kinematics::Units::Mm;
        let k = if mm { 25.4 } else { 1.0 };
        let laser = *name == "fadal" && r.below(2) == 0;
        let head = if laser {
            m.head("laser").expect("laser")
        } else {
            0
        };
        let text = program(&mut r, k);
        let origin = Vector3::new(r.range(-2.0, 2.0), r.range(-2.0, 2.0), r.range(0.0, 1.0)) * k;
        let (frame, orient) = if r.below(3) == 0 {
            let f = Frame::from_axes(
                origin,
                Vector3::new(1.0, 0.0, 0.0),
                Vector3::new(r.range(-0.5, 0.5), r.range(-0.5, 0.5), 1.0),
            )
            .expect("frame");
            (f, Orient::ToolAxis)
        } else {
            let lim = m.rotary[1].limits.map_or(60.0, |l| l.1.min(-l.0).min(60.0));
            let (a, b) = match *name {
                "fadal" => (r.range(-180.0, 180.0), r.range(-lim, lim)),
                "nrc" => (r.range(-lim, lim), r.range(-180.0, 180.0)),
                _ => (r.range(-60.0, 60.0), r.range(-180.0, 180.0)),
            };
            (Frame::translation(origin), Orient::Index([a, b]))
        };
        // Sometimes a layer schedule (each Z level turned a little more), sometimes a
        // second section at another index.
        let layers = (r.below(4) == 0).then(|| LayerSchedule {
            axis: Vector3::new(0.0, 1.0, 0.0),
            point: origin,
            deg_per_layer: r.range(-5.0, 5.0),
        });
        let mut secs = vec![Section {
            name: format!("case{case}.nc"),
            source: Source::Bytes(text.clone().into_bytes()),
            frame,
            orient,
            layers,
        }];
        if r.below(3) == 0 {
            let text2 = program(&mut r, k);
            let rot2 = match orient {
                Orient::Index([a, b]) => Orient::Index([a, b * 0.5]),
                o => o,
            };
            secs.push(Section {
                name: format!("case{case}b.nc"),
                source: Source::Bytes(text2.into_bytes()),
                frame: Frame::translation(origin + Vector3::new(0.5, 0.5, 0.0) * k),
                orient: rot2,
                layers: None,
            });
        }
        let deposit = r.below(2) == 0;
        // Sometimes a machining program with a tool of its own for each run.
        let tools = !deposit && r.below(2) == 0;
        if tools {
            for sec in &mut secs {
                if let Source::Bytes(b) = &sec.source {
                    let t = with_tools(&String::from_utf8_lossy(b));
                    sec.source = Source::Bytes(t.into_bytes());
                }
            }
        }
        let cfg = config(m, head, deposit, tools);
        let mut out = Vec::new();
        match post(m, &secs, &cfg, &mut out, |_| {}) {
            Ok(_) => {}
            Err(PostError::Limit { .. } | PostError::SafeHeight { .. } | PostError::Kin { .. }) => {
                refused += 1;
                continue;
            }
            Err(e) => panic!("case {case} ({name}): {e}\n{text}"),
        }
        posted += 1;
        let out = String::from_utf8(out).expect("ascii");
        let v = |t: &str| {
            verify(
                m,
                &secs,
                cfg.head,
                &cfg.process,
                cfg.intended,
                t.as_bytes(),
                cfg.verify_tolerance,
                None,
                None,
            )
        };
        if let Err(e) = v(&out) {
            panic!("case {case} ({name}): the posted program fails verify: {e}\n{text}\n{out}");
        }
        let units = if mm { Units::Mm } else { Units::Inch };
        let mv = moves(&out, units);
        // AXES order: X Y Z A B C.
        let checked = match *name {
            "fadal" => rapids_clear_the_work(
                &mv,
                |p| fadal_tip([p[0], p[1], p[2]], p[3], p[4], laser),
                0.2,
                1e-4,
            ),
            "nrc" => {
                rapids_clear_the_work(&mv, |p| nrc_tip([p[0], p[1], p[2]], p[4], p[5]), 5.0, 1e-3)
            }
            _ => Ok(()),
        };
        if let Err(e) = checked {
            panic!("case {case} ({name}): {e}\n{out}");
        }
        for _ in 0..6 {
            let Some((bad, what)) = tamper(&mut r, &out, &mv, mm, deposit, tools) else {
                continue;
            };
            if bad == out {
                continue;
            }
            tampered += 1;
            let kind = kinds.entry(what).or_default();
            kind.0 += 1;
            if v(&bad).is_err() {
                caught += 1;
                kind.1 += 1;
            } else {
                let changed: Vec<String> = diff_lines(&out, &bad);
                missed.push(format!(
                    "case {case} ({name}): {what}: {}",
                    changed.join(" | ")
                ));
            }
        }
    }
    let rate = caught as f64 / tampered as f64;
    eprintln!(
        "posted {posted}, refused {refused} (travel, safe height, reach); tampered {tampered}, caught {caught} ({:.2} %)",
        100.0 * rate
    );
    for (what, (t, c)) in &kinds {
        eprintln!("  {what}: {c} of {t} caught");
    }
    for m in missed.iter().take(20) {
        eprintln!("missed: {m}");
    }
    // A feed 10 % or more off is never within anything, nor is a program moved to
    // another offset, tool or S, or its laser, powder, spindle or coolant switched
    // otherwise: every one is caught.
    for what in ["feed changed", "process changed", "process switched"] {
        let (t, c) = kinds.get(what).copied().unwrap_or_default();
        assert!(t > 0 && c == t, "{what}: caught {c} of {t}");
    }
    assert!(posted >= 100, "too few programs posted: {posted}");
    assert!(
        rate >= 0.99,
        "verify caught {:.2} % of tampered programs",
        100.0 * rate
    );
}
