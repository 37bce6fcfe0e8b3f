//! LinuxCNC's cutter radius compensation (`crates/gcode/src/comp.rs`) against rs274 on
//! random programs (skipped without rs274; `LAMPOST_REQUIRE_RS274=1` makes that a
//! failure): closed and open profiles of lines and arcs (by R and by centre words), run
//! either way round, under G41.1 and G42.1 with a random diameter, in G17 and G18, in
//! inch and mm, entered by a line or an arc and left by G40. Every program is equal to
//! rs274 (each coordinate within its printed resolution) or refused by both.

mod common;

use common::*;

use lampost_testkit::XorShift as Rng;

fn n4(v: f64) -> String {
    format!("{v:.4}")
}

/// One random compensated program. Points are worked in the plane's own (a, b) (X, Y in
/// G17; Z, X in G18) and written with 4 decimals, each move from the point as written.
fn random_program(r: &mut Rng) -> String {
    let inch = r.chance(0.4);
    let g18 = r.chance(0.5);
    let scale = if inch { 1.0 / 25.4 } else { 1.0 };
    let (pa, pb) = if g18 { ('Z', 'X') } else { ('X', 'Y') };
    let (ca, cb) = if g18 { ('K', 'I') } else { ('I', 'J') };
    let word = |a: f64, b: f64| format!("{pa}{} {pb}{}", n4(a), n4(b));
    let round = |v: f64| format!("{v:.4}").parse::<f64>().unwrap_or(v);
    // A polygon-ish loop around the origin: n points at rising angles, radius varied.
    let n = 3 + (r.next_u64() % 5) as usize;
    let ccw = r.chance(0.5);
    let mut pts = Vec::with_capacity(n);
    let turn0 = r.range(0.0, std::f64::consts::TAU);
    for i in 0..n {
        let t = turn0 + (i as f64 + r.range(-0.3, 0.3)) * std::f64::consts::TAU / n as f64;
        let t = if ccw { t } else { -t };
        let rad = r.range(15.0, 40.0) * scale;
        pts.push([round(rad * t.cos()), round(rad * t.sin())]);
    }
    let closed = r.chance(0.6);
    let d = round(r.range(0.5, 8.0) * scale);
    let side = if r.chance(0.5) { "G41.1" } else { "G42.1" };
    let mut s = format!(
        "{} {} G90 G94 F100\nG0 {}\n",
        if inch { "G20" } else { "G21" },
        if g18 { "G18" } else { "G17" },
        word(pts[0][0] * 2.0, pts[0][1] * 2.0)
    );
    // In G18, now and then a lathe tool's orientation (L 1 to 8).
    let orientation = if g18 && r.chance(0.5) {
        format!(" L{}", 1 + r.next_u64() % 8)
    } else {
        String::new()
    };
    s.push_str(&format!("{side} D{}{orientation}\n", n4(d)));
    // The entry: a line, or now and then an arc by R.
    let lead = [pts[0][0] * 2.0, pts[0][1] * 2.0];
    let chord = (pts[0][0] - lead[0]).hypot(pts[0][1] - lead[1]);
    if r.chance(0.25) {
        let g = if r.chance(0.5) { "G2" } else { "G3" };
        s.push_str(&format!(
            "{g} {} R{}\n",
            word(pts[0][0], pts[0][1]),
            n4(round(chord / 2.0 * r.range(1.05, 2.0)))
        ));
    } else {
        s.push_str(&format!("G1 {}\n", word(pts[0][0], pts[0][1])));
    }
    let mut at = pts[0];
    let last = if closed { n + 1 } else { n };
    for i in 1..last {
        let to = pts[i % n];
        if r.chance(0.45) {
            // An arc: by R (the short or long way) or by its centre words.
            let chord = (to[0] - at[0]).hypot(to[1] - at[1]);
            if chord < 1e-3 {
                continue;
            }
            let g = if r.chance(0.5) { "G2" } else { "G3" };
            let radius = round(chord / 2.0 * r.range(1.05, 3.0));
            if r.chance(0.5) {
                let sign = if r.chance(0.8) { 1.0 } else { -1.0 };
                s.push_str(&format!(
                    "{g} {} R{}\n",
                    word(to[0], to[1]),
                    n4(sign * radius)
                ));
            } else {
                // The centre on the chord's bisector, on either side.
                let h = (radius * radius - chord * chord / 4.0).max(0.0).sqrt();
                let side = if r.chance(0.5) { 1.0 } else { -1.0 };
                let mid = [(at[0] + to[0]) / 2.0, (at[1] + to[1]) / 2.0];
                let nrm = [-(to[1] - at[1]) / chord, (to[0] - at[0]) / chord];
                let c = [
                    round(mid[0] + side * h * nrm[0]),
                    round(mid[1] + side * h * nrm[1]),
                ];
                // The end on the circle through the start about the centre (as written).
                let rr = (at[0] - c[0]).hypot(at[1] - c[1]);
                let ang = (to[1] - c[1]).atan2(to[0] - c[0]);
                let e = [round(c[0] + rr * ang.cos()), round(c[1] + rr * ang.sin())];
                s.push_str(&format!(
                    "{g} {} {ca}{} {cb}{}\n",
                    word(e[0], e[1]),
                    n4(c[0] - at[0]),
                    n4(c[1] - at[1])
                ));
                at = e;
                continue;
            }
        } else {
            s.push_str(&format!("G1 {}\n", word(to[0], to[1])));
        }
        at = to;
    }
    s.push_str(&format!(
        "G40 G0 {}\nM2\n",
        word(at[0] * 2.0 + 5.0 * scale, at[1] * 2.0 + 5.0 * scale)
    ));
    s
}

#[test]
fn cutter_compensation_equals_rs274_on_random_profiles() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("cutter-comp");
    let mut r = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut equal, mut moves, mut values, mut both_refuse) = (0usize, 0usize, 0usize, 0usize);
    let (mut arc_entries, mut oriented) = (0usize, 0usize);
    let mut reasons: std::collections::BTreeMap<String, usize> = Default::default();
    let mut wrong = Vec::new();
    let programs = 160;
    for i in 0..programs {
        let text = random_program(&mut r);
        let prog = work.join(format!("comp{i}.ngc"));
        std::fs::write(&prog, &text).expect("write");
        let theirs = rs274_to_end(&prog, &work);
        let out = lampost(&[
            "trace",
            "--json",
            "--flavor",
            "linuxcnc",
            prog.to_str().expect("utf8"),
        ]);
        match (theirs, out.status.success()) {
            (Err(e), false) => {
                both_refuse += 1;
                let theirs = e.replace("rs274: ", "");
                // The same refusal, in rs274's words (its own "BUG" stop in lampost's).
                let ours = stderr(&out);
                let same = if theirs
                    .starts_with("BUG: cutter compensation has generated an invalid arc")
                {
                    ours.contains("made an arc whose radii differ")
                } else {
                    ours.contains(&theirs)
                };
                if !same {
                    wrong.push(format!(
                        "{text}\n=> both refuse: rs274 {theirs}; lampost {ours}"
                    ));
                }
                *reasons.entry(theirs).or_default() += 1;
            }
            (Ok(canon), true) => {
                let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
                match compare_with_rs274(&doc, &canon) {
                    Ok((n, _)) => {
                        equal += 1;
                        let entry = text.lines().nth(3).unwrap_or("");
                        arc_entries +=
                            usize::from(entry.starts_with("G2") || entry.starts_with("G3"));
                        oriented += usize::from(text.contains(" L"));
                        moves += canon.len();
                        values += n;
                    }
                    Err(e) => wrong.push(format!("{text}\n=> {e}")),
                }
            }
            (Err(e), true) => wrong.push(format!("{text}\n=> rs274 refuses ({e}), lampost runs")),
            (Ok(_), false) => wrong.push(format!(
                "{text}\n=> lampost refuses, rs274 runs: {}",
                stderr(&out)
            )),
        }
    }
    eprintln!(
        "cutter compensation: {programs} programs; {equal} equal to rs274 ({moves} moves, {values} coordinates; {arc_entries} entered by an arc, {oriented} with a lathe tool's orientation), {both_refuse} refused by both, {} different",
        wrong.len()
    );
    eprintln!("refused by both: {reasons:?}");
    assert!(wrong.is_empty(), "{}", wrong.join("\n\n"));
    assert!(equal > programs / 3, "{equal}");
}

/// A compensation refusal is a located error with rs274's words, where rs274 refuses.
#[test]
fn cutter_compensation_refusals_are_located() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("cutter-comp-refusals");
    for (text, at, words) in [
        (
            "G21 G17 F100\nG0 X0 Y0\nG41.1 D4\nG1 X1 Y0\nM2\n",
            "4:1",
            "entry move is not greater than the tool radius",
        ),
        (
            "G21 G17 F100\nG0 X0 Y-10\nG42.1 D4\nG1 X0 Y0\nG1 Y10\nG1 X1\nG1 Y0\nG40 G0 X20\nM2\n",
            "7:1",
            "Straight feed in concave corner cannot be reached by the tool without gouging",
        ),
        (
            "G21 G17 F100\nG0 X-10 Y0\nG42.1 D4\nG1 X0 Y0\nG2 X2 Y0 R1\nG40 G0 X20\nM2\n",
            "5:1",
            "Tool radius not less than arc radius with cutter radius compensation",
        ),
    ]
    .into_iter()
    .chain(
        [
            (
                "G18",
                "Cannot change planes with cutter radius compensation on",
            ),
            ("G41.1 D2", "Cannot turn cutter radius comp on when on"),
            ("G28", "Cannot use G28 or G30 with cutter radius comp"),
            (
                "G81 X1 Y1 Z-1 R1",
                "Cannot use canned cycles with cutter compensation on",
            ),
            ("G38.2 Z-5", "Cannot probe with cutter radius comp on"),
            (
                "G53 G1 X5",
                "Cannot use G53 with cutter radius compensation",
            ),
        ]
        .into_iter()
        .map(|(line, words)| {
            let text: &'static str = Box::leak(
                format!("G21 G17 F100\nG0 X-10 Y0\nG42.1 D4\nG1 X0 Y0\n{line}\nG40\nM2\n")
                    .into_boxed_str(),
            );
            (text, "5:1", words)
        }),
    ) {
        let prog = work.join("refused.ngc");
        std::fs::write(&prog, text).expect("write");
        assert!(rs274_to_end(&prog, &work).is_err(), "rs274 runs {text}");
        let out = lampost(&[
            "trace",
            "--flavor",
            "linuxcnc",
            prog.to_str().expect("utf8"),
        ]);
        let err = stderr(&out);
        assert!(!out.status.success(), "{text}");
        assert!(err.contains(&format!("refused.ngc:{at}")), "{text}\n{err}");
        assert!(err.contains(words), "{text}\n{err}");
    }
}

/// The post writes no compensated path: a program under G41.1/G42.1 is refused, with
/// the compensation named, and nothing is written (the trace shows the tool's centre,
/// the post would need the programmed path).
#[test]
fn post_refuses_compensated_programs() {
    let dir = tempdir("cutter-comp-post");
    let inp = dir.join("comp.ngc");
    std::fs::write(
        &inp,
        "G21 G17 F100\nG0 X-10 Y0 Z5\nG1 Z0\nG42.1 D4\nG1 X0 Y0\nG1 X10\nG40 G0 X20\nM2\n",
    )
    .expect("write");
    let trace = lampost(&["trace", "--flavor", "linuxcnc", inp.to_str().expect("utf8")]);
    assert!(trace.status.success(), "{}", stderr(&trace));
    let out_path = dir.join("out.nc");
    let out = lampost(&[
        "post",
        "--machine",
        "nrc-lc",
        "--flavor",
        "linuxcnc",
        inp.to_str().expect("utf8"),
        "-o",
        out_path.to_str().expect("utf8"),
    ]);
    let err = stderr(&out);
    assert!(!out.status.success(), "posted: {err}");
    assert!(err.contains("cutter radius compensation"), "{err}");
    assert!(!out_path.exists());
}
