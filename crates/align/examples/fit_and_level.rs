//! Fit a sphere to probed points, fit a plane to a probed face, and find the rotary
//! positions that level the face on the FADAL: `cargo run -p lampost-align --example
//! fit_and_level`.

use lampost_align::{level, plane, sphere, P3};
use lampost_kinematics::Machine;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Thirty touches on a 0.5-in gage ball centred at (3, −2, 1.5), the stylus centre a
    // 1/16-in stylus radius out: a sphere of radius 0.5625.
    let centre = P3::new(3.0, -2.0, 1.5);
    let touches: Vec<P3> = (0..30)
        .map(|k| {
            let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
            let z = 1.0 - f64::from(k) / 29.0; // the upper half
            let r = (1.0 - z * z).sqrt();
            let a = golden * f64::from(k);
            centre + P3::new(r * a.cos(), r * a.sin(), z) * 0.5625
        })
        .collect();
    let s = sphere(&touches, None)?;
    println!(
        "sphere: centre ({:.6}, {:.6}, {:.6}), radius {:.6}, rms {:.1e}",
        s.center[0], s.center[1], s.center[2], s.radius, s.rms
    );
    assert!((s.radius - 0.5625).abs() < 1e-9);

    // A face tilted by 0.4° about Y, probed on a 4 × 3 grid.
    let tilt = 0.4f64.to_radians();
    let face: Vec<P3> = (0..12)
        .map(|k| {
            let (x, y) = (f64::from(k % 4), f64::from(k / 4));
            P3::new(x, y, 1.0 + x * tilt.tan())
        })
        .collect();
    let p = plane(&face)?;
    println!(
        "plane: normal ({:.6}, {:.6}, {:.6}), flatness {:.1e}",
        p.normal[0], p.normal[1], p.normal[2], p.flatness
    );

    // The rotary positions that make that normal the tool axis, best first.
    let m = Machine::builtin("fadal-lamp", &[])?;
    for l in level(&m, &P3::from(p.normal), &[0.0, 0.0])? {
        println!(
            "level: A={:.4} B={:.4} within limits: {}",
            l.rotary[0], l.rotary[1], l.within_limits
        );
    }
    Ok(())
}
