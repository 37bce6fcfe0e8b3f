//! Calibrate the FADAL's rotation centre R from gage-ball centres measured at eight A/B
//! poses (paper 000's Method III, least squares over all poses): `cargo run -p
//! lampost-align --example calibrate_r`.

use lampost_align::calib::{method_iii, Pose};
use lampost_align::P3;
use lampost_kinematics::Machine;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The ball centres a table with R = (−4.877, 1.4798, 7.0918) shows at eight poses,
    // the ball at (3, −2, 1.5) at A = B = 0 (fixtures/calibration/fadal-8-poses.txt).
    let rows = [
        (0.0, 0.0, [3.0, -2.0, 1.5]),
        (90.0, 0.0, [6.3972, -8.3568, 1.5]),
        (180.0, 0.0, [12.754, -4.9596, 1.5]),
        (270.0, 0.0, [9.3568, 1.3972, 1.5]),
        (0.0, 45.0, [-0.586219643, -2.0, -4.025699901]),
        (90.0, 45.0, [1.815963514, -8.3568, -1.623516744]),
        (180.0, 45.0, [6.310899901, -4.9596, 2.871419643]),
        (270.0, 45.0, [3.908716744, 1.3972, 0.469236486]),
    ];
    let poses: Vec<Pose> = rows
        .iter()
        .enumerate()
        .map(|(k, (a, b, c))| Pose {
            rotary: [*a, *b],
            center: P3::from(*c),
            row: k + 1,
            sigma: None,
        })
        .collect();
    let m = Machine::builtin("fadal-lamp", &[])?;
    let r = method_iii(&m, &poses)?;
    let rr = r.r.ok_or("the poses do not fix R")?;
    println!(
        "R = ({:.6}, {:.6}, {:.6}), rms {:.1e}",
        rr[0], rr[1], rr[2], r.rms
    );
    for (k, want) in [-4.877, 1.4798, 7.0918].iter().enumerate() {
        assert!((rr[k] - want).abs() < 1e-6);
    }
    Ok(())
}
