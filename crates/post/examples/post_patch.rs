//! Post paper 002's 1-in repair patch on the FADAL, the table indexed to A = 0, B = −20°,
//! the program's origin 1 in above the part's, then verify the posted text against the
//! intended path: `cargo run -p lampost-post --example post_patch`.

use lampost_kinematics::Machine;
use lampost_post::{post, verify, Frame, Orient, PostConfig, Process, Section, Source};
use nalgebra::Vector3;

const PATCH: &str = "G20 G90\nG0 X0 Y0 Z0.2\nG1 Z0 F20.\nG1 X1.\nG1 Y0.5\nG2 X0.5 Y1. I-0.5 J0\nG1 X0\nG1 Y0\nG0 Z0.2\nM30\n";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let m = Machine::builtin("fadal-lamp", &[])?;
    let sections = [Section {
        name: "patch.nc".into(),
        source: Source::Bytes(PATCH.as_bytes().to_vec()),
        frame: Frame::translation(Vector3::new(0.0, 0.0, 1.0)),
        orient: Orient::Index([0.0, -20.0]),
        layers: None,
    }];
    let cfg = PostConfig::new(&m, Process::Deposit { power: 1000.0 });
    let mut out = Vec::new();
    let report = post(&m, &sections, &cfg, &mut out, |_| {})?;
    print!("{}", String::from_utf8_lossy(&out));
    // The posted text read back on its own: every feed point on the intended path.
    let v = verify(
        &m,
        &sections,
        cfg.head,
        &cfg.process,
        cfg.intended,
        out.as_slice(),
        cfg.verify_tolerance,
        None,
        None,
    )?;
    eprintln!(
        "{} moves posted; verified {} feed points, max tip error {:.1e} in",
        report.moves, v.compared, v.max_position_error
    );
    Ok(())
}
