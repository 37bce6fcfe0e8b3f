//! FK∘IK is the identity for every configuration of the PUMA closed form and for the
//! numerical inverse; the configuration of joint values is the one they were solved in;
//! arm files with degenerate or bad values are refused at their line.

use lampost_robot::{wrap, Arm, Config, Frame, Q};
use lampost_robot::{ArmDef, RobotError};
use proptest::prelude::*;

fn puma() -> Arm {
    Arm::builtin("puma-lens").unwrap_or_else(|| panic!("built-in puma-lens"))
}

fn close(a: &Frame, b: &Frame, tol: f64) -> bool {
    (a.t - b.t).norm() < tol && (a.r - b.r).abs().max() < tol
}

fn joints() -> impl Strategy<Value = Q> {
    // Within the PUMA 560's limits (degrees), kept 0.5° from singular wrist poses.
    (
        -160.0..160.0f64,
        -45.0..225.0f64,
        -225.0..45.0f64,
        -110.0..170.0f64,
        (0.5..100.0f64, any::<bool>()),
        -266.0..266.0f64,
    )
        .prop_map(|(a, b, c, d, (e, neg), f)| {
            [a, b, c, d, if neg { -e } else { e }, f].map(f64::to_radians)
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// Every configuration that has a solution reaches the pose to 1e-9; the joints'
    /// own configuration gives back the joints (mod 2π).
    #[test]
    fn fk_of_ik_is_identity(q in joints()) {
        let arm = puma();
        let t = arm.flange(&q);
        let own = arm.config_of(&q).unwrap_or_else(|| panic!("closed form"));
        let mut solved = 0;
        for c in Config::ALL {
            let Ok(s) = arm.inverse_closed(&t, c, 0.0) else { continue };
            solved += 1;
            let back = arm.flange(&s);
            prop_assert!(close(&back, &t, 1e-9), "config {}: {:?} vs {:?}", c.letters(), back, t);
            let co = arm.config_of(&s).unwrap_or_else(|| panic!("closed form"));
            prop_assert!(co.fits(c), "config {} solved into {:?}", c.letters(), co);
            if own.fits(c) && own.right.is_some() && own.up.is_some() && own.flip.is_some() {
                for j in 0..6 {
                    prop_assert!(wrap(s[j] - q[j]).abs() < 1e-7, "joint {j}: {} vs {}", s[j], q[j]);
                }
            }
        }
        // Away from singular poses the four arm solutions exist, each with two wrists.
        prop_assert!(solved == 8 || solved == 0 || solved % 2 == 0);
    }

    /// The fast closed form (planning's) gives the reference's joints to 1e-12 rad in
    /// every configuration, or refuses naming the same joint; from the part frame in the
    /// working frame likewise, and from a location's shared part (`at_site`) turned about
    /// the beam (`inverse_turned`, planning's search). Wrists at the singularity (θ5 = 0)
    /// included.
    #[test]
    fn the_fast_closed_form_agrees_with_the_reference(
        q in joints(),
        singular in any::<bool>(),
        wrist in -3.0..3.0f64,
        reach in prop_oneof![Just(1.0), 0.3..1.7f64],
        turn in -7.0..7.0f64,
    ) {
        let arm = puma();
        let mut q = q;
        if singular {
            q[4] = 0.0;
        }
        let mut t = arm.flange(&q);
        // Now and then moved, maybe beyond reach (or inside the shoulder offset).
        t.t *= reach;
        let part = arm.head.inverse().mul(&arm.base.mul(&t).mul(&arm.holder));
        // The part frame as Rz(turn) · (m, −m·tip), as planning builds it.
        let m = Frame::rot_z(-turn) * part.r;
        let tip = -(part.r.transpose() * part.t);
        let site = arm.at_site(&m, &tip);
        for c in Config::ALL {
            let reference = arm.inverse_closed(&t, c, wrist);
            for fast in [
                arm.inverse_closed_fast(&t, c, wrist),
                arm.inverse_in_work(&part, c, wrist),
                arm.inverse_turned(&site, turn, c, wrist),
            ] {
                match (&reference, &fast) {
                    (Ok(r), Ok(f)) => {
                        // The two forms round differently where the elbow's triangle is
                        // ill-conditioned (the forearm nearly stretched or folded: ψ from
                        // acos against from its sine): 1e-12 rad scaled by 1/sin of the
                        // elbow's distance from its stretch, at most 1e-7 (at the stretch
                        // itself ψ is known only to √ε, 1.5e-8).
                        let l = &arm.links;
                        let w = wrap(r[2] + l[2].offset + l[3].d.atan2(l[2].a)).abs();
                        let tol = (1e-12 / w.sin().abs()).clamp(1e-12, 1e-7);
                        // Likewise θ1 where the wrist centre nears the cylinder of the
                        // shoulder offset d3 (the shoulder singularity): the arm's lever
                        // x = √(r² − d3²) goes to 0, and θ1 moves by ε·d3/x. Scaled by
                        // 1/sin of the centre's angle off that cylinder; where that is below
                        // 1e-6 the joints are not defined to rounding and only the poses the
                        // two forms reach are compared.
                        let p = arm.chain(r)[4].t;
                        let shoulder = (1.0 - l[2].d * l[2].d / (p.x * p.x + p.y * p.y)).max(0.0).sqrt();
                        if shoulder < 1e-6 {
                            let (a, b) = (arm.flange(r), arm.flange(f));
                            prop_assert!(close(&a, &b, 1e-9), "config {}: {:?} vs {:?}", c.letters(), a, b);
                            continue;
                        }
                        let tol = tol / shoulder.min(1.0);
                        // Likewise θ4 and θ6 near the wrist singularity: each is the
                        // direction of a column of the wrist's matrix of length sin θ5, so
                        // rounding moves them by ε / sin θ5 (their sum stays put). Scaled by
                        // it; below 1e-6 only the poses are compared.
                        let sb = (r[4] + l[4].offset).sin().abs();
                        if sb < 1e-6 {
                            let (a, b) = (arm.flange(r), arm.flange(f));
                            prop_assert!(close(&a, &b, 1e-9), "config {}: {:?} vs {:?}", c.letters(), a, b);
                            continue;
                        }
                        for j in 0..6 {
                            let tol = if j == 3 || j == 5 { tol / sb.min(1.0) } else { tol };
                            prop_assert!(wrap(r[j] - f[j]).abs() < tol, "config {} joint {j}: {} vs {} (tolerance {tol:e})", c.letters(), r[j], f[j]);
                        }
                    }
                    (Err(r), Err(f)) => prop_assert_eq!(r.joint, f.joint),
                    _ => prop_assert!(false, "config {}: {:?} vs {:?}", c.letters(), reference, fast),
                }
            }
        }
    }

    /// A joint change by directions (`change_turned`: planning's cost a step to each side,
    /// and of the last turn from the last location) is the full solve's joints, fitted
    /// near the first solve's, minus those, to 1e-14 rad, in every configuration; it
    /// declines (`None`) only where the full solve is needed. Turns up to ±2° apart, at
    /// the same location or at one moved by joint changes up to 0.01 rad; wrists near the
    /// singularity included.
    #[test]
    fn joint_changes_by_directions_agree_with_full_solves(
        q in joints(),
        near_singular in any::<bool>(),
        turn in -7.0..7.0f64,
        step in -0.035..0.035f64,
        moved in any::<bool>(),
        shift in proptest::array::uniform6(-0.01..0.01f64),
    ) {
        let arm = puma();
        let mut q = q;
        if near_singular {
            q[4] = 0.01;
        }
        let part = arm.head.inverse().mul(&arm.base.mul(&arm.flange(&q)).mul(&arm.holder));
        let m = Frame::rot_z(-turn) * part.r;
        let tip = -(part.r.transpose() * part.t);
        let site = arm.at_site(&m, &tip);
        // The next location: the part where joints `q + shift` put it, the same turn.
        let next = if moved {
            let q2: Q = std::array::from_fn(|j| q[j] + shift[j]);
            let part = arm.head.inverse().mul(&arm.base.mul(&arm.flange(&q2)).mul(&arm.holder));
            arm.at_site(&(Frame::rot_z(-turn) * part.r), &-(part.r.transpose() * part.t))
        } else {
            site
        };
        for c in Config::ALL {
            let Ok((raw0, dirs)) = arm.inverse_turned_with(&site, turn, c, q[3]) else {
                continue;
            };
            let Ok(q0) = arm.fit_limits(&raw0, &raw0) else {
                continue;
            };
            // The joints and directions of the same solve.
            prop_assert_eq!(arm.inverse_turned(&site, turn, c, q[3]).ok(), Some(raw0));
            let Some(dirs) = dirs else {
                continue;
            };
            let Some((dq, to)) = arm.change_turned(&next, turn + step, c, &q0, &dirs) else {
                continue;
            };
            let raw1 = arm.inverse_turned_with(&next, turn + step, c, q0[3]);
            prop_assert!(raw1.as_ref().is_ok_and(|r| r.1 == Some(to)), "config {}: directions", c.letters());
            let raw1 = raw1.map(|r| r.0);
            prop_assert!(raw1.is_ok(), "config {}: {raw1:?}", c.letters());
            let Ok(raw1) = raw1 else { continue };
            let q1 = arm.fit_limits(&raw1, &q0);
            prop_assert!(q1.is_ok(), "config {}", c.letters());
            let Ok(q1) = q1 else { continue };
            for j in 0..6 {
                let full = q1[j] - q0[j];
                prop_assert!((full - dq[j]).abs() < 1e-14, "config {} joint {j}: {full} vs {}", c.letters(), dq[j]);
            }
        }
    }

    /// The numerical inverse from a nearby seed on the same side of the wrist singularity
    /// (θ5 = 0, where the wrist flips) reaches the pose to 1e-9.
    #[test]
    fn dls_reaches_the_pose(q in joints(), d in prop::array::uniform6(-0.2..0.2f64)) {
        let arm = puma();
        let t = arm.flange(&q);
        let seed: Q = std::array::from_fn(|i| q[i] + d[i]);
        // A seed across the singularity starts in the other wrist configuration.
        prop_assume!(seed[4] * q[4] > 0.0);
        if let Some(s) = arm.inverse_dls(&t, &seed) {
            prop_assert!(close(&arm.flange(&s), &t, 1e-9));
        } else {
            // Only a seed across a singularity may fail; the wrist is kept 0.5° away.
            prop_assert!(false, "no convergence from {:?} to {:?}", seed, q);
        }
    }
}

#[test]
fn singular_wrist_keeps_the_last_wrist_angle() {
    let arm = puma();
    let q: Q = [0.3, 0.8, -1.2, 0.7, 0.0, -0.4].map(|x: f64| x);
    let t = arm.flange(&q);
    let s = arm
        .inverse_closed(&t, Config::parse("lun").unwrap_or_else(|| panic!()), 1.1)
        .or_else(|_| arm.inverse_closed(&t, Config::parse("rdn").unwrap_or_else(|| panic!()), 1.1));
    let c = arm.config_of(&q).unwrap_or_else(|| panic!());
    let cfg = Config {
        right: c.right.unwrap_or(false),
        up: c.up.unwrap_or(false),
        flip: false,
    };
    let s2 = arm
        .inverse_closed(&t, cfg, 1.1)
        .unwrap_or_else(|e| panic!("{e:?}"));
    assert!((s2[3] - 1.1).abs() < 1e-12, "J4 kept: {}", s2[3]);
    assert!(close(&arm.flange(&s2), &t, 1e-9));
    let _ = s;
}

#[test]
fn a_pose_beyond_reach_names_the_elbow() {
    let arm = puma();
    let mut t = arm.flange(&[0.0, 0.5, -0.5, 0.0, -0.5, 0.0]);
    t.t *= 10.0;
    for c in Config::ALL {
        let e = arm
            .inverse_closed(&t, c, 0.0)
            .err()
            .unwrap_or_else(|| panic!("reached"));
        assert_eq!(e.joint, 2, "{}", e.why);
    }
}

#[test]
fn a_non_puma_arm_uses_the_numerical_inverse() {
    let text = lampost_robot::builtin_text("puma-lens")
        .unwrap_or_default()
        .replacen(
            "d = 0.0\na = 0.0\nalpha = -90.0",
            "d = 35.0\na = 12.0\nalpha = -90.0",
            1,
        );
    let arm = Arm::from_toml(&text, "offset-wrist.toml").unwrap_or_else(|e| panic!("{e}"));
    assert!(!arm.closed_form);
    let q: Q = [0.2, 1.0, -1.4, 0.3, -0.6, 0.9];
    let t = arm.flange(&q);
    let s = arm
        .inverse_dls(&t, &[0.25, 0.9, -1.3, 0.35, -0.5, 0.8])
        .unwrap_or_else(|| panic!("no convergence"));
    assert!(close(&arm.flange(&s), &t, 1e-9));
}

fn refusal(text: &str) -> (usize, String) {
    match ArmDef::from_toml(text, "arm.toml") {
        Err(RobotError::MachineFile { line, message, .. }) => (line, message),
        other => panic!("not refused: {other:?}"),
    }
}

fn line_of(text: &str, needle: &str, nth: usize) -> usize {
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.starts_with(needle))
        .nth(nth)
        .map(|(i, _)| i + 1)
        .unwrap_or_else(|| panic!("{needle}"))
}

#[test]
fn bad_arm_files_are_refused_at_their_line() {
    let base = lampost_robot::builtin_text("puma-lens").unwrap_or_default();
    // A zero-length arm: every a and d zero.
    let zero = base
        .lines()
        .map(|l| {
            if l.starts_with("d = ") {
                "d = 0.0".to_string()
            } else if l.starts_with("a = ") {
                "a = 0.0".to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let (line, msg) = refusal(&zero);
    assert!(msg.contains("no length"), "{msg}");
    assert_eq!(line, line_of(&zero, "d = ", 0));
    // NaN and infinity.
    let nan = base.replacen("a = 431.8", "a = nan", 1);
    let (line, msg) = refusal(&nan);
    assert!(msg.contains("not a finite number"), "{msg}");
    assert_eq!(line, line_of(&nan, "a = nan", 0));
    let inf = base.replacen("d = 431.8", "d = inf", 1);
    assert_eq!(refusal(&inf).0, line_of(&inf, "d = inf", 0));
    // Limits reversed, and too wide.
    let rev = base.replacen("limits = [-100.0, 100.0]", "limits = [100.0, -100.0]", 1);
    let (line, msg) = refusal(&rev);
    assert!(msg.contains("J5") && msg.contains("min < max"), "{msg}");
    assert_eq!(line, line_of(&rev, "limits = [100.0, -100.0]", 0));
    let wide = base.replacen("limits = [-266.0, 266.0]", "limits = [-400.0, 400.0]", 1);
    assert_eq!(
        refusal(&wide).0,
        line_of(&wide, "limits = [-400.0, 400.0]", 0)
    );
    // Five joints.
    let five = base.replacen("[[joint]]\nname = \"J6\"", "[unused]\nname = \"J6\"", 1);
    assert!(ArmDef::from_toml(&five, "arm.toml").is_err());
    // A non-positive speed; a safe location beyond the limits; a modified-DH file.
    let slow = base.replacen("max_speed = 120.0", "max_speed = 0.0", 1);
    assert_eq!(refusal(&slow).0, line_of(&slow, "max_speed = 0.0", 0));
    let safe = base.replacen("safe = [0.0, 90.0", "safe = [170.0, 90.0", 1);
    let (line, msg) = refusal(&safe);
    assert!(msg.contains("J1"), "{msg}");
    assert_eq!(line, line_of(&safe, "safe = ", 0));
    let craig = base.replacen("convention = \"classic\"", "convention = \"modified\"", 1);
    assert_eq!(refusal(&craig).0, line_of(&craig, "convention", 0));
    let cfg = base.replacen("config = \"rdf\"", "config = \"lx\"", 1);
    assert_eq!(refusal(&cfg).0, line_of(&cfg, "config", 0));
    let par = base.replacen(
        "z_axis = [0.0, 0.0, 1.0]\n\n[cell]",
        "z_axis = [1.0, 0.0, 0.0]\n\n[cell]",
        1,
    );
    let (_, msg) = refusal(&par);
    assert!(msg.contains("[head]") && msg.contains("parallel"), "{msg}");
    // An unknown key (a typo) is refused too.
    let typo = base.replacen("max_speed = 60.0", "max_sped = 60.0", 1);
    assert_eq!(refusal(&typo).0, line_of(&typo, "max_sped", 0));
}

/// The PUMA with one link given a general twist and offsets (α = −37°, d = 35, a = 12):
/// every entry of a DH product is non-trivial.
fn twisted() -> Arm {
    let text = lampost_robot::builtin_text("puma-lens")
        .unwrap_or_default()
        .replacen(
            "d = 0.0\na = 0.0\nalpha = -90.0",
            "d = 35.0\na = 12.0\nalpha = -37.0",
            1,
        );
    Arm::from_toml(&text, "twisted.toml").unwrap_or_else(|e| panic!("{e}"))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// The DH product multiplied out (verification's chain) gives the generic product's
    /// frames to 1e-12 (rotations) and 1e-12 of the arm's size (positions), on the PUMA
    /// and on an arm with a general twist; and the same configuration from either.
    #[test]
    fn the_multiplied_out_chain_is_the_products(q in joints(), wide in proptest::array::uniform6(-7.0..7.0f64)) {
        let arm = puma();
        let other = twisted();
        for (a, q) in [(&arm, q), (&other, q), (&arm, wide), (&other, wide)] {
            let (fast, reference) = (a.chain_dh(&q), a.chain(&q));
            for (f, r) in fast.iter().zip(&reference) {
                prop_assert!((f.r - r.r).abs().max() < 1e-12, "{:?} vs {:?}", f, r);
                prop_assert!((f.t - r.t).norm() < 1e-12 * 1000.0, "{:?} vs {:?}", f, r);
            }
        }
        prop_assert_eq!(arm.config_of_chain(&q, &arm.chain_dh(&q)), arm.config_of(&q));
    }
}
