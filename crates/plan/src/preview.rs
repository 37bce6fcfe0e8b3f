//! A picture of a plan as SVG: every layer's loops, its rasters, a tick along each
//! perimeter point's tool axis, and the points over the offset-angle limit in red.
//!
//! The view is oblique: with `d` the first layer's build direction and `e₁`, `e₂` its
//! plane's axes ([`crate::raster::plane_axes`]), a point `p` is drawn at
//! `(p·e₁ + ½ p·e₂, −(p·d) − ½ p·e₂)` (mm; SVG's y grows downwards), so layers stack
//! upwards and the plane recedes to the upper right. One `<g class="layer">` per layer
//! (`data-layer` its index) holds `<polyline class="loop">`, `<line class="raster">`,
//! `<line class="tick">` (from the point one tick length along the axis, `tick` mm), and
//! `<circle class="violation">` at each point over the limit, drawn red.

use std::fmt::Write as _;

use lampost_mesh::P3;

use crate::build::Plan;
use crate::raster::plane_axes;

/// The plan as an SVG document; a tick every `tick_every` perimeter points, `tick` long.
pub fn svg(plan: &Plan, tick: f64, tick_every: usize) -> String {
    let d = plan.layers.first().map_or(P3::z(), |l| l.normal);
    let (e1, e2) = plane_axes(d);
    let at = |p: P3| {
        let (u, v, h) = (p.dot(&e1), p.dot(&e2), p.dot(&d));
        (u + 0.5 * v, -h - 0.5 * v)
    };
    let mut lo = (f64::INFINITY, f64::INFINITY);
    let mut hi = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    let mut grow = |p: P3| {
        let (x, y) = at(p);
        lo = (lo.0.min(x), lo.1.min(y));
        hi = (hi.0.max(x), hi.1.max(y));
    };
    for l in &plan.layers {
        for q in l.loops.iter().flatten() {
            grow(q.p);
            grow(q.p + q.axis * tick);
        }
        for r in &l.runs {
            grow(r.from);
            grow(r.to);
        }
    }
    if !(lo.0.is_finite() && hi.0.is_finite()) {
        lo = (0.0, 0.0);
        hi = (1.0, 1.0);
    }
    let margin = 0.02 * (hi.0 - lo.0).max(hi.1 - lo.1).max(1e-6);
    let (x0, y0) = (lo.0 - margin, lo.1 - margin);
    let (w, h) = (hi.0 - lo.0 + 2.0 * margin, hi.1 - lo.1 + 2.0 * margin);
    let stroke = 0.002 * w.max(h);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="{x0:.4} {y0:.4} {w:.4} {h:.4}" width="1000" height="{:.0}">"#,
        (1000.0 * h / w).clamp(1.0, 100_000.0)
    );
    let _ = writeln!(
        s,
        "<style>.loop{{fill:none;stroke:#1f5fbf;stroke-width:{stroke:.5}}} .raster{{stroke:#999;stroke-width:{:.5}}} .tick{{stroke:#2a2;stroke-width:{:.5}}} .tick.bad{{stroke:#d00}} .violation{{fill:#d00}}</style>",
        stroke * 0.6,
        stroke * 0.6
    );
    let bad: std::collections::HashSet<(usize, usize, usize)> = plan
        .violations
        .iter()
        .map(|v| (v.layer, v.loop_index, v.point))
        .collect();
    let every = tick_every.max(1);
    for l in &plan.layers {
        let _ = writeln!(s, r#"<g class="layer" data-layer="{}">"#, l.index);
        for (li, lp) in l.loops.iter().enumerate() {
            s.push_str(r#"<polyline class="loop" points=""#);
            for q in lp {
                let (x, y) = at(q.p);
                let _ = write!(s, "{x:.4},{y:.4} ");
            }
            s.push_str("\"/>\n");
            for (pi, q) in lp.iter().enumerate() {
                let over = bad.contains(&(l.index, li, pi));
                if pi % every != 0 && !over {
                    continue;
                }
                let (ax, ay) = at(q.p);
                let (bx, by) = at(q.p + q.axis * tick);
                let _ = writeln!(
                    s,
                    r#"<line class="tick{}" x1="{ax:.4}" y1="{ay:.4}" x2="{bx:.4}" y2="{by:.4}"/>"#,
                    if over { " bad" } else { "" }
                );
                if over {
                    let _ = writeln!(
                        s,
                        r#"<circle class="violation" cx="{ax:.4}" cy="{ay:.4}" r="{:.4}" fill="red"/>"#,
                        stroke * 2.0
                    );
                }
            }
        }
        for r in &l.runs {
            let (ax, ay) = at(r.from);
            let (bx, by) = at(r.to);
            let _ = writeln!(
                s,
                r#"<line class="raster" x1="{ax:.4}" y1="{ay:.4}" x2="{bx:.4}" y2="{by:.4}"/>"#
            );
        }
        s.push_str("</g>\n");
    }
    s.push_str("</svg>\n");
    s
}
