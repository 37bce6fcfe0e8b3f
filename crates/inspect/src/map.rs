//! Pictures of deviations: a colour per tolerance band, an SVG colour map over the part
//! (top view) with a Tol+/Tol− legend, and a coloured point cloud as ASCII PLY (vertex
//! colours and the deviation as `quality`, which CloudCompare reads as a scalar field and
//! MeshLab as vertex quality).

use lampost_mesh::Mesh;

/// A measured point to draw: where (CAD frame) and its signed deviation.
#[derive(Debug, Clone, PartialEq)]
pub struct MapPoint {
    /// The point's id.
    pub id: String,
    /// Where it is drawn (CAD frame).
    pub point: [f64; 3],
    /// Signed deviation (+ outside: material in excess).
    pub deviation: f64,
}

/// Beyond Tol+ (material in excess).
pub const ABOVE: [u8; 3] = [220, 0, 0];
/// Beyond Tol− (material missing).
pub const BELOW: [u8; 3] = [0, 0, 220];
const ZERO: [u8; 3] = [0, 170, 0];
const LOW: [u8; 3] = [0, 200, 220];
const HIGH: [u8; 3] = [255, 160, 0];

fn lerp(a: [u8; 3], b: [u8; 3], s: f64) -> [u8; 3] {
    let mut out = [0u8; 3];
    for k in 0..3 {
        let v = f64::from(a[k]) + (f64::from(b[k]) - f64::from(a[k])) * s;
        out[k] = v.round().clamp(0.0, 255.0) as u8;
    }
    out
}

/// The colour of a deviation against ±`tol`: [`ABOVE`] beyond +tol, [`BELOW`] beyond
/// −tol, and within it a gradient from cyan (−tol) through green (0) to orange (+tol).
pub fn colour(deviation: f64, tol: f64) -> [u8; 3] {
    if deviation > tol {
        ABOVE
    } else if deviation < -tol {
        BELOW
    } else {
        let s = if tol > 0.0 { deviation / tol } else { 0.0 };
        if s >= 0.0 {
            lerp(ZERO, HIGH, s)
        } else {
            lerp(ZERO, LOW, -s)
        }
    }
}

fn hex(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The most triangles of the mesh drawn under the points (beyond, only the points).
pub const MAX_DRAWN_TRIANGLES: usize = 50_000;

/// An SVG colour map: the part seen from +Z (the mesh's faces in grey when it has at most
/// [`MAX_DRAWN_TRIANGLES`], the upper ones over the lower), each point a disc in its
/// band's colour carrying `data-id` and `data-deviation`, and a legend of the bands
/// labelled Tol+ and Tol−.
pub fn svg(points: &[MapPoint], mesh: Option<&Mesh>, tol: f64, title: &str) -> String {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let mut grow = |p: [f64; 3]| {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    };
    points.iter().for_each(|p| grow(p.point));
    let draw_mesh = mesh.filter(|m| m.triangles.len() <= MAX_DRAWN_TRIANGLES);
    if let Some(m) = draw_mesh {
        m.vertices.iter().for_each(|v| grow([v.x, v.y, v.z]));
    }
    if !(lo[0].is_finite() && hi[0].is_finite()) {
        lo = [0.0; 2];
        hi = [1.0; 2];
    }
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-9);
    let (w, plot) = (800.0, 600.0);
    let scale = plot / span;
    let x = |v: f64| 20.0 + (v - lo[0]) * scale;
    let y = |v: f64| 60.0 + (hi[1] - v) * scale;
    let height = 80.0 + (hi[1] - lo[1]) * scale;
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{:.0}\" viewBox=\"0 0 {w} {:.0}\">\n<title>{}</title>\n<text x=\"20\" y=\"24\" font-family=\"sans-serif\" font-size=\"14\">{} (top view, deviation along the normal)</text>\n",
        height.max(320.0),
        height.max(320.0),
        esc(title),
        esc(title)
    );
    if let Some(m) = draw_mesh {
        let mut faces: Vec<(f64, [usize; 3])> = m
            .triangles
            .iter()
            .map(|t| {
                let t = t.map(|i| i as usize);
                let z = t.iter().map(|&i| m.vertices[i].z).sum::<f64>() / 3.0;
                (z, t)
            })
            .collect();
        faces.sort_by(|a, b| a.0.total_cmp(&b.0));
        s.push_str("<g id=\"part\" fill=\"#dddddd\" stroke=\"#bbbbbb\" stroke-width=\"0.3\">\n");
        for (_, t) in faces {
            let p: Vec<String> = t
                .iter()
                .map(|&i| format!("{:.2},{:.2}", x(m.vertices[i].x), y(m.vertices[i].y)))
                .collect();
            s.push_str(&format!("<polygon points=\"{}\"/>\n", p.join(" ")));
        }
        s.push_str("</g>\n");
    }
    s.push_str("<g id=\"points\">\n");
    let mut order: Vec<&MapPoint> = points.iter().collect();
    order.sort_by(|a, b| a.point[2].total_cmp(&b.point[2]));
    for p in order {
        s.push_str(&format!(
            "<circle cx=\"{:.2}\" cy=\"{:.2}\" r=\"3\" fill=\"{}\" data-id=\"{}\" data-deviation=\"{}\"/>\n",
            x(p.point[0]),
            y(p.point[1]),
            hex(colour(p.deviation, tol)),
            esc(&p.id),
            p.deviation
        ));
    }
    s.push_str("</g>\n<g id=\"legend\" font-family=\"sans-serif\" font-size=\"12\">\n");
    let lx = 650.0;
    let bands: [(String, [u8; 3]); 5] = [
        (format!("above Tol+ (> +{tol})"), ABOVE),
        (format!("Tol+ = +{tol}"), colour(tol, tol)),
        ("0".to_string(), colour(0.0, tol)),
        (format!("Tol− = −{tol}"), colour(-tol, tol)),
        (format!("below Tol− (< −{tol})"), BELOW),
    ];
    for (k, (label, c)) in bands.iter().enumerate() {
        let ty = 60.0 + 24.0 * k as f64;
        s.push_str(&format!(
            "<rect x=\"{lx}\" y=\"{ty}\" width=\"16\" height=\"16\" fill=\"{}\"/><text x=\"{}\" y=\"{}\">{}</text>\n",
            hex(*c),
            lx + 22.0,
            ty + 13.0,
            esc(label)
        ));
    }
    s.push_str("</g>\n</svg>\n");
    s
}

/// A coloured point cloud as ASCII PLY: `x y z` (double), `red green blue` (uchar, the
/// band colours of [`colour`]) and `quality` (float: the deviation), one vertex a point.
pub fn ply(points: &[MapPoint], tol: f64, comment: &str) -> String {
    let mut s = format!(
        "ply\nformat ascii 1.0\ncomment {}\ncomment colours: red above +{tol}, blue below -{tol}, cyan-green-orange within; quality = deviation\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty float quality\nend_header\n",
        comment.replace(['\n', '\r'], " "),
        points.len()
    );
    for p in points {
        let c = colour(p.deviation, tol);
        s.push_str(&format!(
            "{} {} {} {} {} {} {}\n",
            p.point[0], p.point[1], p.point[2], c[0], c[1], c[2], p.deviation as f32
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands() {
        assert_eq!(colour(0.2, 0.1), ABOVE);
        assert_eq!(colour(-0.2, 0.1), BELOW);
        assert_eq!(colour(0.0, 0.1), ZERO);
        assert_eq!(colour(0.1, 0.1), HIGH);
        assert_eq!(colour(-0.1, 0.1), LOW);
        assert_eq!(colour(0.05, 0.1), [128, 165, 0]);
    }
}
