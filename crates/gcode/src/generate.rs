//! Deterministic synthetic programs for benchmarks and memory tests.

/// A 3-axis CAM-like program of `lines` lines: rapids, feeds and arcs in mm with
/// 3-decimal coordinates, as common posts write them. The same `seed` gives the same
/// text.
pub fn planar_program(lines: usize, seed: u64) -> String {
    planar_program_within(lines, seed, 500.0)
}

/// [`planar_program`] with X and Y kept within ±`half_extent` mm.
pub fn planar_program_within(lines: usize, seed: u64, half_extent: f64) -> String {
    let e = half_extent;
    let mut s = String::with_capacity(lines * 32);
    s.push_str("%\n(lampost synthetic 3-axis program)\nG21 G17 G90 G94\nG0 X0 Y0 Z5\n");
    let mut state = seed | 1;
    let mut next = move || {
        // xorshift64*
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        state.wrapping_mul(0x2545_F491_4F6C_DD1D)
    };
    let (mut x, mut y) = (0.0f64, 0.0f64);
    let mut n = 4;
    while n < lines.saturating_sub(1) {
        let r = next();
        let dx = ((r % 20001) as f64 - 10000.0) / 1000.0;
        let dy = (((r >> 20) % 20001) as f64 - 10000.0) / 1000.0;
        let z = -(((r >> 40) % 5000) as f64) / 1000.0;
        match r % 10 {
            1 => {
                // A semicircle from here to a point 2 mm along X, centre half-way.
                let i = if x > e - 10.0 { -1.0 } else { 1.0 };
                x += 2.0 * i;
                s.push_str(&format!("G2 X{x:.3} Y{y:.3} I{i:.3} J0.000 F800.\n"));
            }
            2 => s.push_str(&format!("G1 Z{z:.3} F300.\n")),
            k => {
                // Round to the written resolution so the next arc starts exactly here.
                x = ((x + dx).clamp(-e, e) * 1000.0).round() / 1000.0;
                y = ((y + dy).clamp(-e, e) * 1000.0).round() / 1000.0;
                if k == 0 {
                    s.push_str(&format!("G0 X{x:.3} Y{y:.3} Z5.000\n"));
                } else {
                    s.push_str(&format!("G1 X{x:.3} Y{y:.3} F1200.\n"));
                }
            }
        }
        n += 1;
    }
    s.push_str("M30\n");
    s
}
