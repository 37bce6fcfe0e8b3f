//! LinuxCNC's polar coordinates against rs274 on generated programs: absolute and
//! incremental `@`/`^` moves, R arcs, canned cycles with L repeats, modal polar blocks,
//! G92 and G10 L2 offsets, work systems and expressions, in random order (a fixed seed).
//! Where rs274 runs a program to its end, `lampost trace --flavor linuxcnc` gives its
//! moves to rs274's printed precision; where rs274 stops with an error, lampost refuses
//! the program with a located error.

mod common;

use common::*;

/// A small deterministic generator (xorshift64*), so the programs are the same on every
/// run without a dependency.
struct Gen(u64);

impl Gen {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// A number in [a, b) written with `dec` decimals.
    fn num(&mut self, a: f64, b: f64, dec: usize) -> String {
        format!("{:.*}", dec, a + (b - a) * self.unit())
    }
    fn pick<'a>(&mut self, of: &[&'a str]) -> &'a str {
        of[(self.next() % of.len() as u64) as usize]
    }
}

fn program(g: &mut Gen) -> String {
    let mut lines = vec![
        "G20 G90 G17 G94 F10 S1000 M3".to_string(),
        format!("G0 X{} Y{} Z1", g.num(-3.0, 3.0, 3), g.num(-3.0, 3.0, 3)),
    ];
    let blocks = 3 + g.next() % 8;
    for _ in 0..blocks {
        let dist = g.pick(&["G90", "G91"]);
        let mut polar = Vec::new();
        if g.unit() < 0.8 {
            let r = if dist == "G91" {
                g.num(-1.0, 3.0, 3)
            } else {
                g.num(0.1, 3.0, 3)
            };
            // Not `@0`: an incremental R arc to where it starts, moved by the rounding
            // of the polar point, is refused by lampost (rs274 makes a tiny arc).
            let r = if r.parse::<f64>() == Ok(0.0) {
                "0.25".into()
            } else {
                r
            };
            polar.push(format!("@{r}"));
        }
        if g.unit() < 0.8 || polar.is_empty() {
            polar.push(format!("^{}", g.num(-400.0, 400.0, 2)));
        }
        let polar = polar.join(" ");
        let c = g.unit();
        let line = if c < 0.35 {
            let z = if g.unit() < 0.3 {
                format!(" Z{}", g.num(-1.0, 1.0, 3))
            } else {
                String::new()
            };
            format!("{dist} {} {polar}{z}", g.pick(&["G0", "G1"]))
        } else if c < 0.5 {
            format!(
                "{dist} {} {polar} R{}",
                g.pick(&["G2", "G3"]),
                g.num(2.0, 6.0, 3)
            )
        } else if c < 0.75 {
            let cycle = g.pick(&[
                "G81", "G82 P0.1", "G73 Q.17", "G83 Q.13", "G85", "G89 P.1", "G86 P.1",
            ]);
            let repeats = if g.unit() < 0.6 {
                format!(" L{}", 1 + g.next() % 5)
            } else {
                String::new()
            };
            format!(
                "{dist} {} {cycle} {polar} R{} Z{}{repeats}",
                g.pick(&["G98", "G99", ""]),
                g.num(0.05, 0.3, 3),
                g.num(-0.8, -0.1, 3)
            )
        } else if c < 0.85 {
            // The motion in force takes the polar point.
            polar
        } else if c < 0.88 {
            format!("G92 X{} Y{}", g.num(-1.0, 1.0, 3), g.num(-1.0, 1.0, 3))
        } else if c < 0.9 {
            format!(
                "G10 L2 P{} X{} Y{}",
                1 + g.next() % 2,
                g.num(-1.0, 1.0, 3),
                g.num(-1.0, 1.0, 3)
            )
        } else if c < 0.93 {
            let a = g.num(-90.0, 90.0, 3);
            format!("#1 = {a}\n{dist} G1 ^[#1 * 2] @[ABS[#1] / 30 + 0.1]")
        } else if c < 0.96 {
            g.pick(&["G54", "G55", "G92.1", "G91 G0 X0.5", "G90 G0 X0 Y0"])
                .to_string()
        } else {
            format!(
                "G90 G0 X{} Y{} Z{}",
                g.num(-3.0, 3.0, 3),
                g.num(-3.0, 3.0, 3),
                g.num(0.5, 1.5, 3)
            )
        };
        lines.push(line);
    }
    lines.push("M2".into());
    lines.join("\n") + "\n"
}

#[test]
fn generated_polar_programs_equal_rs274_or_are_refused_as_it_refuses_them() {
    if require_rs274().is_none() {
        return;
    }
    let work = tempdir("polar-rs274");
    let mut g = Gen(0x005E_ED0F_1A5E_u64);
    let (mut equal, mut refused, mut moves) = (0, 0, 0);
    for i in 0..150 {
        let text = program(&mut g);
        let own = work.join(format!("p{i}"));
        std::fs::create_dir_all(&own).expect("folder");
        let prog = own.join("p.ngc");
        std::fs::write(&prog, &text).expect("write");
        let ran = rs274_to_end(&prog, &own).or_else(|_| rs274_to_end(&prog, &own));
        let out = lampost(&[
            "trace",
            "--flavor",
            "linuxcnc",
            "--json",
            prog.to_str().expect("utf8"),
        ]);
        match ran {
            Ok(canon) => {
                assert!(out.status.success(), "{text}\n{}", stderr(&out));
                let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
                if let Err(e) = compare_with_rs274(&doc, &canon) {
                    panic!("{text}\n{e}");
                }
                equal += 1;
                moves += canon.len();
            }
            Err(why) => {
                let e = stderr(&out);
                assert!(
                    !out.status.success(),
                    "rs274 refuses ({why}), lampost runs:\n{text}"
                );
                assert!(e.contains("p.ngc:") && e.contains("help:"), "{text}\n{e}");
                refused += 1;
            }
        }
    }
    eprintln!("polar programs: {equal} equal to rs274 ({moves} moves), {refused} refused by both");
    assert!(
        equal >= 30 && refused >= 5,
        "{equal} equal, {refused} refused"
    );
}
