//! The machines' kinematics written out from the papers' formulas, for tests that must
//! not share the crate's kinematics (shared by `crates/post/tests/tamper.rs` and
//! `crates/cli/tests/safety_cli.rs`).
#![allow(dead_code)]

/// Paper 000's FADAL (fixtures/machines/fadal-lamp.toml): a part point p sits at
/// M(a, b)·(p + R) − R, M = Ry(−b)·Rz(a); the laser tip is the joints plus L. Returns the
/// tip and the tool axis in the part frame.
pub fn fadal_tip(j: [f64; 3], a: f64, b: f64, laser: bool) -> ([f64; 3], [f64; 3]) {
    let r = [-4.877, 1.4798, 7.0918];
    let l = if laser {
        [-10.10308, 0.03632, -8.72762]
    } else {
        [0.0; 3]
    };
    let (sa, ca) = a.to_radians().sin_cos();
    let (sb, cb) = (-b).to_radians().sin_cos();
    let rz = [[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]];
    let ry = [[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]];
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for k in 0..3 {
            m[i][k] = (0..3).map(|x| ry[i][x] * rz[x][k]).sum();
        }
    }
    let q = [j[0] + l[0] + r[0], j[1] + l[1] + r[1], j[2] + l[2] + r[2]];
    let mut p = [0.0; 3];
    let mut ax = [0.0; 3];
    for k in 0..3 {
        p[k] = (0..3).map(|i| m[i][k] * q[i]).sum::<f64>() - r[k];
        ax[k] = m[2][k];
    }
    (p, ax)
}

/// Paper 003's NRC cell, eq. (3) (fixtures/machines/nrc-lc.toml): the workpiece point
/// under the tool is x_w = Rz(−C)·Ry(−B)·(−X, −Y, Z + H) − (0, 0, H), H = 150 mm; the tool
/// axis is Rz(−C)·Ry(−B)·(0, 0, 1). Returns the tip and the axis in the part frame.
pub fn nrc_tip(j: [f64; 3], b: f64, c: f64) -> ([f64; 3], [f64; 3]) {
    let h = 150.0;
    let (sb, cb) = (-b).to_radians().sin_cos();
    let (sc, cc) = (-c).to_radians().sin_cos();
    let ry = |v: [f64; 3]| [cb * v[0] + sb * v[2], v[1], -sb * v[0] + cb * v[2]];
    let rz = |v: [f64; 3]| [cc * v[0] - sc * v[1], sc * v[0] + cc * v[1], v[2]];
    let t = rz(ry([-j[0], -j[1], j[2] + h]));
    ([t[0], t[1], t[2] - h], rz(ry([0.0, 0.0, 1.0])))
}
