//! IK + FK pairs per second on one core (`cargo xtask bench kin`). A baseline in the
//! same run: the same poses through nalgebra's general `Rotation3` (matrix) products
//! for FK only, with the C library's sin/cos. Then a breakdown: IK alone, FK alone, the
//! orientation solve alone, and one `atan2_deg` / `sin_cos_deg`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use lampost_kinematics::{Joints, Machine, Vector3};
use nalgebra::Rotation3;

fn best_of(runs: usize, mut f: impl FnMut() -> f64) -> Duration {
    let mut best = Duration::MAX;
    for _ in 0..runs {
        let t = Instant::now();
        black_box(f());
        best = best.min(t.elapsed());
    }
    best
}

fn main() {
    let quick = !std::env::args().any(|a| a == "--bench");
    let n = if quick { 10_000 } else { 2_000_000 };
    let runs = if quick { 1 } else { 5 };
    for name in ["fadal-lamp", "nrc-lc"] {
        let Ok(m) = Machine::builtin(name, &[]) else {
            return;
        };
        // Poses from random joints within limits.
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let poses: Vec<(Vector3<f64>, Vector3<f64>, [f64; 2])> = (0..4096)
            .map(|_| {
                let j = Joints {
                    linear: [rnd() * 10.0 - 5.0, rnd() * 10.0 - 5.0, rnd() * 10.0 - 5.0],
                    rotary: [rnd() * 200.0 - 100.0, rnd() * 200.0 - 100.0],
                };
                let p = m.forward(&j, 0);
                (p.tip, p.axis, j.rotary)
            })
            .collect();
        let t = best_of(runs, || {
            let mut acc = 0.0;
            for i in 0..n {
                let (tip, axis, near) = &poses[i & 4095];
                if let Ok(s) = m.inverse(tip, axis, 0, near) {
                    let best = s.as_slice()[0];
                    acc += m.forward(&best.joints, 0).tip.x;
                }
            }
            acc
        });
        // The same pairs through the batch functions (`inverse_into`, `forward_into`).
        let queries: Vec<lampost_kinematics::IkQuery> = poses
            .iter()
            .map(|(tip, axis, near)| lampost_kinematics::IkQuery {
                tip: *tip,
                axis: *axis,
                near: *near,
            })
            .collect();
        let mut sols = Vec::new();
        let mut best = Vec::new();
        let mut fk = Vec::new();
        let t_batch = best_of(runs, || {
            let mut acc = 0.0;
            let mut done = 0;
            while done < n {
                m.inverse_into(&queries, 0, &mut sols);
                best.clear();
                best.extend(
                    sols.iter()
                        .filter_map(|s| s.as_ref().ok())
                        .map(|s| s.as_slice()[0].joints),
                );
                m.forward_into(&best, 0, &mut fk);
                acc += fk.iter().map(|p| p.tip.x).sum::<f64>();
                done += queries.len();
            }
            acc
        });
        let t_bik = best_of(runs, || {
            let mut acc = 0.0;
            let mut done = 0;
            while done < n {
                m.inverse_into(&queries, 0, &mut sols);
                acc += sols.len() as f64;
                done += queries.len();
            }
            acc
        });
        let t_bfk = best_of(runs, || {
            let mut acc = 0.0;
            let mut done = 0;
            while done < n {
                m.forward_into(&best, 0, &mut fk);
                acc += fk.len() as f64;
                done += best.len();
            }
            acc
        });
        let t_ik = best_of(runs, || {
            let mut acc = 0.0;
            for i in 0..n {
                let (tip, axis, near) = &poses[i & 4095];
                if let Ok(s) = m.inverse(tip, axis, 0, near) {
                    acc += s.as_slice()[0].joints.linear[0];
                }
            }
            acc
        });
        let t_or = best_of(runs, || {
            let mut acc = 0.0;
            for i in 0..n {
                let (_, axis, near) = &poses[i & 4095];
                if let Some((o, _)) = m.orient(axis, near) {
                    acc += o[0].degrees[0];
                }
            }
            acc
        });
        let t_tr = best_of(runs, || {
            let mut acc = 0.0;
            for i in 0..n {
                let (_, axis, _) = &poses[i & 4095];
                acc += lampost_kinematics::trig::atan2_deg(axis.x, axis.y);
            }
            acc
        });
        let t_sc = best_of(runs, || {
            let mut acc = 0.0;
            for i in 0..n {
                let (_, _, near) = &poses[i & 4095];
                acc += lampost_kinematics::trig::sin_cos_deg(near[0]).0;
            }
            acc
        });
        let ns = |t: Duration| t.as_secs_f64() * 1e9 / n as f64;
        println!(
            "  breakdown: orientation (both branches) {:.1} ns, atan2_deg {:.1} ns, sin_cos_deg {:.1} ns",
            ns(t_or),
            ns(t_tr),
            ns(t_sc)
        );
        let t_fk = best_of(runs, || {
            let mut acc = 0.0;
            for i in 0..n {
                let (tip, _, near) = &poses[i & 4095];
                let j = Joints {
                    linear: [tip.x, tip.y, tip.z],
                    rotary: *near,
                };
                acc += m.forward(&j, 0).tip.x;
            }
            acc
        });
        println!(
            "  breakdown: IK alone (every solution, ranked) {:.1} ns, FK alone {:.1} ns",
            ns(t_ik),
            ns(t_fk)
        );
        let t_base = best_of(runs, || {
            let mut acc = 0.0;
            let (ri, ro) = (&m.rotary[m.inner], &m.rotary[m.outer]);
            for i in 0..n {
                let (tip, _, near) = &poses[i & 4095];
                let r = Rotation3::from_axis_angle(
                    &nalgebra::Unit::new_normalize(ro.axis),
                    near[m.outer].to_radians(),
                ) * Rotation3::from_axis_angle(
                    &nalgebra::Unit::new_normalize(ri.axis),
                    near[m.inner].to_radians(),
                );
                acc += (r.transpose() * (tip - ri.pivot)).x;
            }
            acc
        });
        let batch_n = n.div_ceil(queries.len()) * queries.len();
        println!(
            "  breakdown: batched IK alone {:.1} ns, batched FK alone {:.1} ns",
            t_bik.as_secs_f64() * 1e9 / batch_n as f64,
            t_bfk.as_secs_f64() * 1e9 / batch_n as f64
        );
        println!(
            "{name}: batched IK + FK (inverse_into, forward_into; {} poses a call): {:.1} M pairs/s ({:.1} ns a pair)",
            queries.len(),
            batch_n as f64 / t_batch.as_secs_f64() / 1e6,
            t_batch.as_secs_f64() * 1e9 / batch_n as f64
        );
        println!(
            "{name}: IK + FK {:.1} M pairs/s ({:.1} ns a pair); baseline nalgebra Rotation3 FK alone {:.1} M/s; ratio (IK+FK)/FK-baseline time {:.2}",
            n as f64 / t.as_secs_f64() / 1e6,
            t.as_secs_f64() * 1e9 / n as f64,
            n as f64 / t_base.as_secs_f64() / 1e6,
            t.as_secs_f64() / t_base.as_secs_f64()
        );
    }
}
