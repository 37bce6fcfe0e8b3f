//! The CAD mesh in inspection: sampling points with their normals, a simulated sensor
//! reading an "actual" mesh, and signed distances of measured points to the nominal one.
//! All through `lampost-mesh` (its BVH), the geometry the planner and the aligner share.

use lampost_kinematics::{Machine, Vector3};
use lampost_mesh::bvh::MeshBvh;
use lampost_mesh::Mesh;

use crate::error::InspectError;
use crate::plan::{sensor, PlanRow, Target};
use crate::reduce::Reading;

/// The most sampling points one plan takes.
pub const MAX_SAMPLES: usize = 200_000;

/// A sampling point added, within the bound on how many one plan may have.
fn push_target(
    out: &mut Vec<Target>,
    id: String,
    p: &Vector3<f64>,
    n: &Vector3<f64>,
    spacing: f64,
) -> Result<(), InspectError> {
    out.push(Target {
        id,
        point: [p.x, p.y, p.z],
        normal: [n.x, n.y, n.z],
    });
    if out.len() > MAX_SAMPLES {
        return Err(InspectError::Input(format!(
            "--spacing {spacing} gives more than {MAX_SAMPLES} points: sample more coarsely"
        )));
    }
    Ok(())
}

/// Sampling points on every triangle of `mesh`, about `spacing` apart: a triangle is cut
/// into k² similar ones (k its longest edge over the spacing, rounded up) and each
/// upright one's centroid is a point, with the triangle's outward normal (the mesh's
/// winding). Degenerate triangles give none. Ids are `t<triangle>-<n>`.
pub fn sample(mesh: &Mesh, spacing: f64) -> Result<Vec<Target>, InspectError> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(InspectError::Input(format!(
            "--spacing {spacing}: give a positive distance"
        )));
    }
    let mut out = Vec::new();
    for (f, t) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
        let n = (b - a).cross(&(c - a));
        if n.norm() == 0.0 || !n.norm().is_finite() {
            continue;
        }
        let n = n / n.norm();
        let longest = (b - a).norm().max((c - b).norm()).max((a - c).norm());
        let k = (longest / spacing).ceil().max(1.0);
        if k * k > 4.0 * MAX_SAMPLES as f64 {
            return Err(InspectError::Input(format!(
                "--spacing {spacing} gives more than {MAX_SAMPLES} points: sample more coarsely"
            )));
        }
        let k = k as usize;
        let mut count = 0;
        for i in 0..k {
            for j in 0..k - i {
                let (u, v) = (
                    (i as f64 + 1.0 / 3.0) / k as f64,
                    (j as f64 + 1.0 / 3.0) / k as f64,
                );
                let p = a + (b - a) * u + (c - a) * v;
                count += 1;
                push_target(&mut out, format!("t{}-{count}", f + 1), &p, &n, spacing)?;
            }
        }
    }
    Ok(out)
}

/// A section plane: coordinate `axis` (0 x, 1 y, 2 z) equal to `value`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    /// 0, 1, 2 for x, y, z.
    pub axis: usize,
    /// The plane's coordinate.
    pub value: f64,
}

/// The most section planes one plan takes.
pub const MAX_SECTIONS: usize = 10_000;

/// Section planes from `AXIS=LIST`: the axis `x`, `y` or `z`, and a comma-separated list
/// of values and ranges `start:stop:step` (from start up to stop, stop included when a
/// whole number of steps away). `z=5,10,15`, `x=0:100:10`, `y=-5,0:20:2.5`.
pub fn parse_sections(spec: &str) -> Result<Vec<Section>, InspectError> {
    let bad = |why: String| InspectError::Input(format!("--sections {spec}: {why}"));
    let Some((axis, list)) = spec.split_once('=') else {
        return Err(bad("give AXIS=VALUES, e.g. z=5,10,15 or x=0:100:10".into()));
    };
    let axis = match axis.trim() {
        "x" | "X" => 0,
        "y" | "Y" => 1,
        "z" | "Z" => 2,
        other => return Err(bad(format!("`{other}` is not an axis (x, y or z)"))),
    };
    let num = |t: &str| -> Result<f64, InspectError> {
        match t.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(bad(format!("`{}` is not a finite number", t.trim()))),
        }
    };
    let mut out = Vec::new();
    for item in list.split(',') {
        let parts: Vec<&str> = item.split(':').collect();
        match parts.as_slice() {
            [v] => out.push(Section {
                axis,
                value: num(v)?,
            }),
            [a, b, c] => {
                let (start, stop, step) = (num(a)?, num(b)?, num(c)?);
                if step <= 0.0 || stop < start {
                    return Err(bad(format!(
                        "`{}`: give start:stop:step with start ≤ stop and a positive step",
                        item.trim()
                    )));
                }
                let n = ((stop - start) / step * (1.0 + 1e-12)).floor();
                if !(n.is_finite() && n < MAX_SECTIONS as f64) {
                    return Err(bad(format!("more than {MAX_SECTIONS} sections")));
                }
                for k in 0..=(n as usize) {
                    out.push(Section {
                        axis,
                        value: start + k as f64 * step,
                    });
                }
            }
            _ => {
                return Err(bad(format!(
                    "`{}` is neither a value nor start:stop:step",
                    item.trim()
                )))
            }
        }
        if out.len() > MAX_SECTIONS {
            return Err(bad(format!("more than {MAX_SECTIONS} sections")));
        }
    }
    Ok(out)
}

/// Sampling points along section planes, as CMM software scans sections: each plane cuts
/// the mesh into curves (the planner's slicer, `lampost_plan::slice`: closed loops, or open
/// chains where the mesh is open), and along each curve a point every `spacing` of its
/// length from its start (the last gap of a closed curve at most `spacing`), with the
/// outward normal of the triangle it lies on. Ids are `s<section>-<n>`, sections numbered
/// from 1 in the order given. A plane that misses the mesh is an error.
pub fn sample_sections(
    mesh: &Mesh,
    sections: &[Section],
    spacing: f64,
) -> Result<Vec<Target>, InspectError> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(InspectError::Input(format!(
            "--spacing {spacing}: give a positive distance"
        )));
    }
    let normals = lampost_mesh::props::face_normals(mesh);
    let mut out = Vec::new();
    for (k, sec) in sections.iter().enumerate() {
        let name = format!("section {}={}", ["x", "y", "z"][sec.axis.min(2)], sec.value);
        let mut dir = Vector3::zeros();
        dir[sec.axis.min(2)] = 1.0;
        let (lo, hi) = mesh
            .triangles
            .iter()
            .flatten()
            .filter_map(|&i| mesh.vertices.get(i as usize))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v[sec.axis.min(2)]), hi.max(v[sec.axis.min(2)]))
            });
        if !(sec.value > lo && sec.value < hi) {
            return Err(InspectError::Input(format!(
                "{name} misses the mesh (it spans {lo} to {hi} there)"
            )));
        }
        // One plane: the first at the value, the next a whole extent above (beyond).
        let opts = lampost_plan::SliceOptions {
            planes: lampost_plan::Planes::Parallel {
                dir,
                layer: hi - lo,
                first: Some(sec.value - lo),
            },
            stitch: None,
            threads: 1,
        };
        let slicing = lampost_plan::slice(mesh, &opts)
            .map_err(|e| InspectError::Input(format!("{name}: {e}")))?;
        let mut count = 0;
        let curves = slicing.slices.iter().flat_map(|s| {
            s.loops
                .iter()
                .map(|l| (&l.points, &l.faces, true))
                .chain(s.open.iter().map(|c| (&c.points, &c.faces, false)))
        });
        for (points, faces, closed) in curves {
            for (p, f) in along(points, faces, closed, spacing) {
                let n = normals
                    .get(f as usize)
                    .copied()
                    .unwrap_or_else(Vector3::zeros);
                if n.norm() == 0.0 {
                    continue;
                }
                count += 1;
                push_target(&mut out, format!("s{}-{count}", k + 1), &p, &n, spacing)?;
            }
        }
    }
    Ok(out)
}

/// Points every `spacing` of a polyline's length from its start, each with the face of
/// the segment it lies on (`faces[i]`: the segment from point i to point i + 1; a
/// closed polyline's last segment joins its last point to its first).
fn along(
    points: &[Vector3<f64>],
    faces: &[u32],
    closed: bool,
    spacing: f64,
) -> Vec<(Vector3<f64>, u32)> {
    let n = points.len();
    let segments = if closed { n } else { n.saturating_sub(1) };
    let mut out = Vec::new();
    // Arc length at the start of the current segment; the next point wanted is the
    // k-th, at k·spacing.
    let (mut s0, mut k) = (0.0, 0u32);
    let mut total = 0.0;
    for i in 0..segments.min(faces.len()) {
        total += (points[(i + 1) % n] - points[i]).norm();
    }
    for i in 0..segments.min(faces.len()) {
        let (a, b) = (points[i], points[(i + 1) % n]);
        let len = (b - a).norm();
        loop {
            let want = f64::from(k) * spacing;
            let more = if closed {
                want < total - 1e-9 * spacing
            } else {
                want <= total
            };
            if !(more && want <= s0 + len) {
                break;
            }
            let t = if len > 0.0 { (want - s0) / len } else { 0.0 };
            out.push((a + (b - a) * t, faces[i]));
            k += 1;
            if out.len() > MAX_SAMPLES {
                // The caller refuses so many.
                return out;
            }
        }
        s0 += len;
    }
    out
}

/// A simulated sensor: what it reads on `actual`.
#[derive(Debug, Clone, Copy)]
pub struct SimOptions {
    /// Standard deviation of the reading noise (machine units).
    pub noise: f64,
    /// Seed of the noise (the same seed, the same readings).
    pub seed: u64,
}

/// A small deterministic generator (xorshift64*) and Gaussian draws (Box–Muller).
struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        (x.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn gauss(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// The bias a triangulation sensor adds at a tilt between its beam and the surface
/// normal (a maker's figures: 0.1–0.2 % of range at 5–15°, about 0.5 % at 15–30°; here
/// 0.15 % and 0.5 %, nothing under 5°).
pub fn tilt_bias(range: f64, tilt_deg: f64) -> f64 {
    if tilt_deg < 5.0 {
        0.0
    } else if tilt_deg < 15.0 {
        0.0015 * range
    } else {
        0.005 * range
    }
}

/// What the sensor on `head` reads at each plan row on the mesh `actual`: the beam from
/// the row's sensor zero, cast over the sensor's range; no surface within range (or a
/// surface tilted beyond the sensor's limit) is no reading; else the distance, plus the
/// tilt bias and the noise.
pub fn simulate(
    m: &Machine,
    head: usize,
    rows: &[PlanRow],
    actual: &Mesh,
    opts: SimOptions,
) -> Result<Vec<(String, Reading)>, InspectError> {
    let sn = sensor(m, head)?;
    if !(opts.noise.is_finite() && opts.noise >= 0.0) {
        return Err(InspectError::Input(format!(
            "--noise {}: give a standard deviation, 0 or more",
            opts.noise
        )));
    }
    let bvh = MeshBvh::new(actual).map_err(|e| InspectError::Input(e.to_string()))?;
    let normals = lampost_mesh::props::face_normals(actual);
    let mut rng = Rng(opts.seed.max(1));
    let mut out = Vec::with_capacity(rows.len());
    for r in rows {
        let pose = m.forward(&r.joints, head);
        let beam = pose.axis / pose.axis.norm();
        let origin = pose.tip + beam * sn.range;
        let hit = bvh
            .ray_cast(origin, -beam, 2.0 * sn.range)
            .map_err(|e| InspectError::Input(e.to_string()))?;
        let reading = match hit {
            None => Reading::None("none".into()),
            Some(h) => {
                let n: Vector3<f64> = normals
                    .get(h.face as usize)
                    .copied()
                    .unwrap_or_else(Vector3::zeros);
                let tilt = n.dot(&beam).abs().min(1.0).acos().to_degrees();
                if tilt > sn.max_tilt_deg {
                    Reading::None("none".into())
                } else {
                    let r = h.t - sn.range + tilt_bias(sn.range, tilt) + opts.noise * rng.gauss();
                    if r.abs() > sn.range {
                        Reading::None("none".into())
                    } else {
                        Reading::Value(r)
                    }
                }
            }
        };
        out.push((r.id.clone(), reading));
    }
    Ok(out)
}

/// Distances of `points` to `mesh`: signed (negative inside) when the mesh is closed and
/// consistently oriented, else unsigned; the flag says which. On every core the machine
/// offers ([`distances_on`] with `std::thread::available_parallelism`).
pub fn distances(mesh: &Mesh, points: &[[f64; 3]]) -> Result<(Vec<f64>, bool), InspectError> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    distances_on(mesh, points, threads)
}

/// [`distances`] on `threads` threads: the index built (with the manifold report that
/// decides the sign, and the points' spatial order, on their own threads), then the
/// points answered in runs of [`lampost_mesh::dist::RUN`] in Morton order
/// ([`lampost_mesh::dist::morton_order`]), each run started afresh
/// ([`lampost_mesh::dist::DistIndex::answer_run`]) and taken by whichever thread is free; each
/// answer is put back in its place. The same answers whatever the thread count.
pub fn distances_on(
    mesh: &Mesh,
    points: &[[f64; 3]],
    threads: usize,
) -> Result<(Vec<f64>, bool), InspectError> {
    if u32::try_from(points.len()).is_err() {
        return Err(InspectError::Input(format!(
            "{} points: at most {} in one comparison",
            points.len(),
            u32::MAX
        )));
    }
    if let Some(i) = points.iter().position(|q| !q.iter().all(|x| x.is_finite())) {
        return Err(InspectError::Input(format!(
            "point {} of {}: the query point is not finite",
            i + 1,
            points.len()
        )));
    }
    let threads = threads.clamp(1, 64);
    let (idx, signed, order) = if threads == 1 {
        (
            lampost_mesh::dist::DistIndex::new(mesh),
            lampost_mesh::manifold_report(mesh).closed_oriented(),
            spatial(points),
        )
    } else {
        std::thread::scope(|s| {
            let signed = s.spawn(|| lampost_mesh::manifold_report(mesh).closed_oriented());
            let order = s.spawn(|| spatial(points));
            let idx = lampost_mesh::dist::DistIndex::new(mesh);
            let failed = || InspectError::Input("internal: a distance thread failed".into());
            Ok::<_, InspectError>((
                idx,
                signed.join().map_err(|_| failed())?,
                order.join().map_err(|_| failed())?,
            ))
        })?
    };
    let idx =
        idx.ok_or_else(|| InspectError::Input("the mesh cannot be indexed: no triangles".into()))?;
    let (order, in_order) = order;
    let mut sorted = vec![0.0; points.len()];
    let runs = std::sync::Mutex::new(
        in_order
            .chunks(lampost_mesh::dist::RUN)
            .zip(sorted.chunks_mut(lampost_mesh::dist::RUN)),
    );
    let work = || {
        while let Some((run, out)) = runs.lock().ok().and_then(|mut r| r.next()) {
            idx.answer_run(run, signed, out);
        }
    };
    // Below a few thousand points a thread costs more than it saves.
    let helpers = if points.len() < 4096 { 0 } else { threads - 1 };
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..helpers).map(|_| s.spawn(work)).collect();
        work();
        for h in handles {
            h.join()
                .map_err(|_| InspectError::Input("internal: a distance thread failed".into()))?;
        }
        Ok::<_, InspectError>(())
    })?;
    // Every run answered (a lock poisoned would have stopped the threads early).
    if !matches!(runs.into_inner().map(|mut r| r.next().is_none()), Ok(true)) {
        return Err(InspectError::Input(
            "internal: a distance thread stopped early".into(),
        ));
    }
    let mut out = vec![0.0; points.len()];
    for (&i, d) in order.iter().zip(&sorted) {
        out[i as usize] = *d;
    }
    Ok((out, signed))
}

/// The points' Morton order ([`lampost_mesh::dist::morton_order`]), and the points in it (read
/// in one pass: they lie all over memory).
fn spatial(points: &[[f64; 3]]) -> (Vec<u32>, Vec<[f64; 3]>) {
    let order = lampost_mesh::dist::morton_order(points);
    let in_order = order.iter().map(|&i| points[i as usize]).collect();
    (order, in_order)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values and ranges, the stop included when a whole number of steps away (also
    /// when the step is not exact in binary).
    #[test]
    fn section_specifications() {
        let v = |spec: &str| -> Vec<(usize, f64)> {
            parse_sections(spec)
                .expect(spec)
                .iter()
                .map(|s| (s.axis, s.value))
                .collect()
        };
        assert_eq!(v("z=5,10,15"), [(2, 5.0), (2, 10.0), (2, 15.0)]);
        assert_eq!(
            v("x=0:10:2.5"),
            [(0, 0.0), (0, 2.5), (0, 5.0), (0, 7.5), (0, 10.0)]
        );
        assert_eq!(v("Y=-1,0:1:0.5"), [(1, -1.0), (1, 0.0), (1, 0.5), (1, 1.0)]);
        assert_eq!(v("z=0:1:0.1").len(), 11);
        assert_eq!(v("z=0:0.95:0.1").len(), 10);
        for bad in ["z", "q=1", "z=", "z=1:2", "z=inf", "z=2:1:1", "z=0:1:-1"] {
            assert!(parse_sections(bad).is_err(), "{bad}");
        }
    }

    /// Points every `spacing` along a polyline, the last gap of a closed one at most
    /// `spacing`, each on its segment's face.
    #[test]
    fn points_along_a_polyline() {
        let p = |x: f64, y: f64| Vector3::new(x, y, 0.0);
        let square = [p(0.0, 0.0), p(4.0, 0.0), p(4.0, 4.0), p(0.0, 4.0)];
        let got = along(&square, &[10, 11, 12, 13], true, 1.5);
        // Perimeter 16: points at 0, 1.5, …, 15.
        assert_eq!(got.len(), 11);
        for (k, (q, f)) in got.iter().enumerate() {
            let s = 1.5 * k as f64;
            // A point at a corner is on the segment it ends.
            let side = ((s / 4.0).ceil() as usize).max(1) - 1;
            assert_eq!(*f, 10 + side as u32, "{k}");
            let t = s - 4.0 * side as f64;
            let want = square[side] + (square[(side + 1) % 4] - square[side]) * (t / 4.0);
            assert!((q - want).norm() < 1e-12, "{k}: {q:?} vs {want:?}");
        }
        // Open: both ends.
        let got = along(&square[..2], &[7], false, 2.0);
        assert_eq!(got.len(), 3);
        assert!((got[2].0 - p(4.0, 0.0)).norm() < 1e-12);
    }

    /// Threads change nothing: the same distances, bit for bit, on 1 and 3 threads.
    #[test]
    fn distances_on_threads_agree() {
        let m = lampost_mesh::uv_sphere(Vector3::zeros(), 10.0, 12, 24);
        let pts: Vec<[f64; 3]> = (0..5000)
            .map(|k| {
                let t = f64::from(k) * 0.001;
                [
                    12.0 * (7.0 * t).sin(),
                    11.0 * (5.0 * t).cos(),
                    9.0 * (3.0 * t).sin(),
                ]
            })
            .collect();
        let (a, sa) = distances_on(&m, &pts, 1).expect("one");
        let (b, sb) = distances_on(&m, &pts, 3).expect("three");
        assert!(sa && sb);
        assert_eq!(a, b);
        assert!(a.iter().any(|d| *d < 0.0) && a.iter().any(|d| *d > 0.0));
    }
}
