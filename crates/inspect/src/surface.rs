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
                out.push(Target {
                    id: format!("t{}-{count}", f + 1),
                    point: [p.x, p.y, p.z],
                    normal: [n.x, n.y, n.z],
                });
                if out.len() > MAX_SAMPLES {
                    return Err(InspectError::Input(format!(
                        "--spacing {spacing} gives more than {MAX_SAMPLES} points: sample more coarsely"
                    )));
                }
            }
        }
    }
    Ok(out)
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

/// [`distances`] on `threads` threads: the points cut into as many runs, each answered
/// by its own thread against the one index ([`crate::dist::DistIndex`]; the same answers
/// whatever the count).
pub fn distances_on(
    mesh: &Mesh,
    points: &[[f64; 3]],
    threads: usize,
) -> Result<(Vec<f64>, bool), InspectError> {
    let idx = crate::dist::DistIndex::new(mesh)
        .ok_or_else(|| InspectError::Input("the mesh cannot be indexed: no triangles".into()))?;
    let signed = lampost_mesh::manifold_report(mesh).closed_oriented();
    let one = |q: &[f64; 3]| {
        if !q.iter().all(|x| x.is_finite()) {
            return Err(InspectError::Input("the query point is not finite".into()));
        }
        Ok(if signed {
            idx.signed_distance(*q)
        } else {
            idx.distance(*q)
        })
    };
    if u32::try_from(points.len()).is_err() {
        return Err(InspectError::Input(format!(
            "{} points: at most {} in one comparison",
            points.len(),
            u32::MAX
        )));
    }
    let threads = threads.clamp(1, 64);
    // Below a few thousand points a thread costs more than it saves.
    if threads == 1 || points.len() < 4096 {
        let out = points.iter().map(one).collect::<Result<Vec<f64>, _>>()?;
        return Ok((out, signed));
    }
    // The points are answered in a spatial order (Morton codes over their box), so
    // neighbours share the index's cache lines; each answer is put back in its place.
    let order = morton_order(points);
    let chunk = order.len().div_ceil(threads);
    let parts: Vec<Vec<f64>> = std::thread::scope(|s| {
        let handles: Vec<_> = order
            .chunks(chunk)
            .map(|ids| {
                s.spawn(move || {
                    ids.iter()
                        .map(|&i| one(&points[i as usize]))
                        .collect::<Result<Vec<f64>, InspectError>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .map_err(|_| InspectError::Input("internal: a distance thread failed".into()))?
            })
            .collect::<Result<Vec<_>, InspectError>>()
    })?;
    let mut out = vec![0.0; points.len()];
    for (&i, d) in order.iter().zip(parts.iter().flatten()) {
        out[i as usize] = *d;
    }
    Ok((out, signed))
}

/// The points' indices in Morton (Z-curve) order over their bounding box, 21 bits an
/// axis; points that are not finite go last (their answer is an error anyway).
fn morton_order(points: &[[f64; 3]]) -> Vec<u32> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points.iter().filter(|p| p.iter().all(|x| x.is_finite())) {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let spread = |mut x: u64| {
        x &= 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    };
    let mut keyed: Vec<(u64, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if !p.iter().all(|x| x.is_finite()) {
                return (u64::MAX, i as u32);
            }
            let q = |k: usize| {
                let w = hi[k] - lo[k];
                let t = if w > 0.0 { (p[k] - lo[k]) / w } else { 0.0 };
                (t * 2_097_151.0) as u64
            };
            (
                spread(q(0)) | spread(q(1)) << 1 | spread(q(2)) << 2,
                i as u32,
            )
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
