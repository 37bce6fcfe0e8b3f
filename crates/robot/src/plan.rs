//! From a path to joint values: each path point brought to the laser's focus with its
//! approach direction along the beam, the free turn about the beam chosen for the
//! smallest joint motion from the previous location; points resampled to equal spacing,
//! each segment timed from its feed; every location within the joint limits, in one
//! configuration, and no joint asked to turn faster than it can.

use nalgebra::{Matrix3, Vector3};

use crate::arm::{Arm, Config, Directions, Frame, NoReach, Turned, Why, Q};
use crate::error::RobotError;

/// A path point (part frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// The point to bring to the focus.
    pub tip: Vector3<f64>,
    /// Unit direction from the point into the laser head (the approach reversed).
    pub axis: Vector3<f64>,
    /// Feed to this point, units per minute.
    pub feed: f64,
    /// Laser on during the move to this point.
    pub deposit: bool,
    /// Input line (0: not from a file).
    pub line: usize,
}

/// A resampled location on the path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// The point (part frame).
    pub tip: Vector3<f64>,
    /// Unit axis (part frame).
    pub axis: Vector3<f64>,
    /// The reference perpendicular (unit, ⟂ `axis`) the turn about the beam is measured
    /// from: the first location's [`perpendicular`], then carried along the path by the
    /// smallest turn of the axis ([`carry`]).
    pub u: Vector3<f64>,
    /// Laser on during the move to here.
    pub deposit: bool,
    /// Seconds allowed for the move to here (0 for the first).
    pub dt: f64,
    /// Input line of the point the segment ends at.
    pub line: usize,
}

/// The most locations a path may become.
pub const MAX_SAMPLES: f64 = 2_000_000.0;

/// Largest turn of the axis between two locations, radians (1°).
pub const MAX_TURN: f64 = std::f64::consts::PI / 180.0;

/// Resample: each input segment cut into equal pieces no longer than `spacing` and
/// turning the axis by at most 1° (the axis turned at constant rate on the great circle);
/// every input point kept; a repeated point (same place and axis) dropped.
pub fn resample(path: &[PathPoint], spacing: f64) -> Result<Vec<Sample>, RobotError> {
    resample_iter(path.iter().copied(), spacing)
}

/// [`resample`] for a path read as it comes (no copy of the whole path held).
pub fn resample_iter(
    path: impl IntoIterator<Item = PathPoint>,
    spacing: f64,
) -> Result<Vec<Sample>, RobotError> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(RobotError::Option(format!(
            "spacing {spacing}: must be a positive number"
        )));
    }
    let mut path = path.into_iter();
    let Some(first) = path.next() else {
        return Err(RobotError::Option("the path has no points".into()));
    };
    let axis = first.axis.normalize();
    let mut out = vec![Sample {
        tip: first.tip,
        axis,
        u: perpendicular(&axis),
        deposit: first.deposit,
        dt: 0.0,
        line: first.line,
    }];
    // The last location's axis and reference perpendicular.
    let (mut a_prev, mut u) = (axis, perpendicular(&axis));
    let mut total = 1.0;
    let mut last = first;
    for b in path {
        let a = std::mem::replace(&mut last, b);
        let (a, b) = (&a, &b);
        let (ua, ub) = (a.axis.normalize(), b.axis.normalize());
        let len = (b.tip - a.tip).norm();
        let turn = ua.cross(&ub).norm().atan2(ua.dot(&ub));
        if !(len.is_finite() && turn.is_finite()) {
            return Err(RobotError::Option(format!(
                "line {}: the segment's length is not a finite number",
                b.line
            )));
        }
        if len == 0.0 && turn < 1e-12 {
            continue;
        }
        let n = (len / spacing)
            .ceil()
            .max((turn / MAX_TURN).ceil())
            .max(1.0);
        total += n;
        if total > MAX_SAMPLES {
            return Err(RobotError::Option(format!(
                "the path would become more than {MAX_SAMPLES} locations at spacing {} (line {}): give a larger --spacing, or check the points around that line",
                lampost_gcode::Readable(spacing),
                b.line
            )));
        }
        let n = n as usize;
        let dt = len / n as f64 / b.feed * 60.0;
        if !dt.is_finite() {
            return Err(RobotError::Option(format!(
                "line {}: the time for the segment at feed {} is not a finite number",
                b.line, b.feed
            )));
        }
        for k in 1..=n {
            let f = k as f64 / n as f64;
            let (tip, axis) = if k == n {
                (b.tip, ub)
            } else {
                (a.tip + (b.tip - a.tip) * f, slerp(&ua, &ub, turn, f))
            };
            u = carry(&u, &a_prev, &axis);
            a_prev = axis;
            out.push(Sample {
                tip,
                axis,
                u,
                deposit: b.deposit,
                dt,
                line: b.line,
            });
        }
    }
    Ok(out)
}

/// The unit vector a fraction `f` of the way from `a` to `b` on the great circle.
fn slerp(a: &Vector3<f64>, b: &Vector3<f64>, turn: f64, f: f64) -> Vector3<f64> {
    if turn < 1e-9 {
        return (a + (b - a) * f).normalize();
    }
    // A half turn has no single great circle: any perpendicular turns it.
    let k = a.cross(b);
    let k = if k.norm() > 1e-12 {
        k.normalize()
    } else {
        perpendicular(a)
    };
    let ang = turn * f;
    (a * ang.cos() + k.cross(a) * ang.sin() + k * k.dot(a) * (1.0 - ang.cos())).normalize()
}

/// A unit vector perpendicular to `a`.
pub fn perpendicular(a: &Vector3<f64>) -> Vector3<f64> {
    let m = a.abs();
    let e = if m.x <= m.y && m.x <= m.z {
        Vector3::x()
    } else if m.y <= m.z {
        Vector3::y()
    } else {
        Vector3::z()
    };
    (e - a * a.dot(&e)).normalize()
}

/// A planned location.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Located {
    /// Joint values, radians.
    pub q: Q,
    /// The chosen turn about the beam, radians (against the sample's reference
    /// perpendicular [`Sample::u`]).
    pub psi: f64,
}

impl Located {
    /// The part frame in the working frame at this location of sample `s` (the pose the
    /// joints were solved for): [`part_in_work`] at the chosen turn.
    pub fn part(&self, s: &Sample) -> Frame {
        part_in_work(&s.tip, &s.axis, &s.u, self.psi)
    }
}

/// The part frame in the working frame that puts `tip` at the focus with `axis` along
/// +z, turned `psi` about the beam from the reference `u` (a unit vector ⟂ `axis`).
pub fn part_in_work(tip: &Vector3<f64>, axis: &Vector3<f64>, u: &Vector3<f64>, psi: f64) -> Frame {
    part_turned(tip, axis, u, psi.sin_cos())
}

/// [`part_in_work`] given the turn's sine and cosine.
fn part_turned(tip: &Vector3<f64>, axis: &Vector3<f64>, u: &Vector3<f64>, sc: (f64, f64)) -> Frame {
    let v = axis.cross(u);
    let m = Matrix3::from_rows(&[u.transpose(), v.transpose(), axis.transpose()]);
    let (s, c) = sc;
    let r = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0) * m;
    Frame { r, t: -(r * tip) }
}

/// The sine and cosine of `ψ + x` from those of `ψ`, for a small turn `x` (at most 8°,
/// 0.14 rad, here: the series to x¹³ and x¹⁴ leave less than 1e-24).
fn turned_by(sc: (f64, f64), x: f64) -> (f64, f64) {
    let u = x * x;
    // sin x = x (1 − u/3! + u²/5! − …), cos x = 1 − u/2! + u²/4! − …
    let sin = x
        * (1.0
            - u / 6.0
                * (1.0
                    - u / 20.0
                        * (1.0
                            - u / 42.0
                                * (1.0 - u / 72.0 * (1.0 - u / 110.0 * (1.0 - u / 156.0))))));
    let cos = 1.0
        - u / 2.0
            * (1.0
                - u / 12.0
                    * (1.0
                        - u / 30.0
                            * (1.0
                                - u / 56.0
                                    * (1.0 - u / 90.0 * (1.0 - u / 132.0 * (1.0 - u / 182.0))))));
    let (s, c) = sc;
    (s * cos + c * sin, c * cos - s * sin)
}

/// The reference perpendicular `u` (of the last location, whose axis was `a_prev`)
/// carried to a location whose axis is `axis`: turned by the smallest turn of the axis,
/// then made perpendicular to `axis` again ([`perpendicular`] where it vanishes).
pub fn carry(u: &Vector3<f64>, a_prev: &Vector3<f64>, axis: &Vector3<f64>) -> Vector3<f64> {
    let k = a_prev.cross(axis);
    let c = a_prev.dot(axis);
    let turned = if k.norm() <= 1e-15 {
        *u
    } else if c > 0.0 {
        // Rodrigues' rotation by the unnormalised axis k = a × b (|k| = sin, c = cos):
        // u c + k × u + k (k·u) / (1 + c), without trigonometry.
        u * c + k.cross(u) + k * (k.dot(u) / (1.0 + c))
    } else {
        let ang = k.norm().atan2(c);
        let k = k.normalize();
        u * ang.cos() + k.cross(u) * ang.sin() + k * k.dot(u) * (1.0 - ang.cos())
    };
    let t = turned - axis * axis.dot(&turned);
    if t.norm() > 1e-6 {
        t.normalize()
    } else {
        perpendicular(axis)
    }
}

/// Locations the look-ahead of the first turn about the beam visits (evenly spread over
/// the path, the first and last included).
pub const LOOK_AHEAD: usize = 128;

/// Candidate turns about the beam at the first location (5° apart).
const TURNS: u32 = 72;

/// One location with the turn about the beam left free: the sample and, for an arm with
/// the closed form, what every solve there shares ([`Arm::at_site`]).
struct Site<'a> {
    s: &'a Sample,
    closed: Option<Turned>,
}

impl<'a> Site<'a> {
    fn new(arm: &Arm, s: &'a Sample) -> Site<'a> {
        let closed = arm.closed_form.then(|| {
            let m = Matrix3::from_rows(&[
                s.u.transpose(),
                s.axis.cross(&s.u).transpose(),
                s.axis.transpose(),
            ]);
            arm.at_site(&m, &s.tip)
        });
        Site { s, closed }
    }
}

/// The inverse at one location turned about the beam by the angle whose sine and cosine
/// are `sc`: joints within the limits nearest `prev`, in `cfg`. (The part frame,
/// [`part_in_work`], is worked out where it is written only.)
fn solve_at(
    arm: &Arm,
    site: &Site,
    sc: (f64, f64),
    cfg: Config,
    prev: &Q,
    fresh: bool,
) -> Result<(Q, Option<Directions>), NoReach> {
    let (raw, dirs) = if let Some(t) = &site.closed {
        arm.inverse_turned_sc(t, sc, cfg, prev[3])?
    } else {
        let part = part_turned(&site.s.tip, &site.s.axis, &site.s.u, sc);
        let world = arm.head.mul(&part);
        let flange = arm.flange_for(&world);
        // The first location (or one after a blocked turn) starts from the near-PUMA
        // closed form in the asked configuration where there is one; then each location
        // from the last.
        let seed = match (&arm.approx, fresh) {
            (Some(ap), true) => ap
                .inverse_closed(&ap.flange_for(&world), cfg, prev[3])
                .ok()
                .and_then(|q| ap.fit_limits(&q, prev).ok())
                .unwrap_or(*prev),
            _ => *prev,
        };
        let q = arm.inverse_dls(&flange, &seed).ok_or_else(|| NoReach {
            joint: 2,
            why: Why::Words("the numerical inverse does not converge (out of reach?)".into()),
        })?;
        (q, None)
    };
    let q = arm.fit_limits(&raw, prev).map_err(|j| NoReach {
        joint: j,
        why: Why::Outside {
            value: raw[j],
            lo: arm.links[j].lo,
            hi: arm.links[j].hi,
        },
    })?;
    Ok((q, dirs))
}

/// A margin counts up to this much (30°): beyond it the next criterion decides.
const ENOUGH: f64 = std::f64::consts::PI / 6.0;

/// Joint speeds up to this fraction of the fastest count as equal in the look-ahead.
const EASY: f64 = 0.5;

/// The turns about the beam at the first location, best first, judged for the whole path
/// as a robot programmer turns a part on its holder: each of 72 turns (5° apart) is tried
/// at up to [`LOOK_AHEAD`] locations (a quarter as many for an arm without the closed
/// form) spread over the path and the location after each, the part keeping that turn
/// against the transported reference. Better asks less of the joints' speeds at the feed
/// (in twentieths of the fastest, up to half of it counting as equal), then keeps the
/// worst location farther from the joint limits and the elbow's stretch ([`Arm::margin`],
/// in whole degrees, 30° or more counting as equal), then lies nearer the safe location.
/// Turns that miss a location visited are left out.
pub fn first_turns(arm: &Arm, samples: &[Sample], cfg: Config) -> Vec<f64> {
    let n = samples.len();
    if n == 0 {
        return Vec::new();
    }
    // A numerical inverse from a location far along the path may take its 500 steps: an
    // arm without the closed form visits fewer.
    let visits = if arm.closed_form {
        LOOK_AHEAD
    } else {
        LOOK_AHEAD / 4
    };
    let m = n.min(visits);
    let visits: Vec<usize> = if m <= 1 {
        vec![0]
    } else {
        (0..m).map(|k| k * (n - 1) / (m - 1)).collect()
    };
    // (speed, margin, -distance from safe) and the turn, for every turn that reaches.
    let mut ranked: Vec<((f64, f64, f64), f64)> = Vec::new();
    for k in 0..TURNS {
        let psi = f64::from(k) * std::f64::consts::TAU / f64::from(TURNS);
        let mut prev = arm.safe;
        let (mut speed, mut worst) = (0.0f64, f64::INFINITY);
        let mut from_safe = 0.0;
        let mut reached = true;
        'visits: for (v, &i) in visits.iter().enumerate() {
            let mut at = |i: usize, prev: &Q, fresh: bool| {
                let site = Site::new(arm, &samples[i]);
                let (q, _) = solve_at(arm, &site, psi.sin_cos(), cfg, prev, fresh).ok()?;
                worst = worst.min(arm.margin(&q));
                Some(q)
            };
            let Some(q) = at(i, &prev, v == 0) else {
                reached = false;
                break 'visits;
            };
            if v == 0 {
                from_safe = q
                    .iter()
                    .zip(&arm.safe)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum();
            }
            prev = q;
            if i + 1 < n && samples[i + 1].dt > 0.0 {
                let Some(next) = at(i + 1, &q, false) else {
                    reached = false;
                    break 'visits;
                };
                for (j, l) in arm.links.iter().enumerate() {
                    speed = speed.max((next[j] - q[j]).abs() / (l.max_speed * samples[i + 1].dt));
                }
            }
        }
        if !reached {
            continue;
        }
        let deg = |m: f64| m.min(ENOUGH).to_degrees().floor();
        let key = (-(speed.max(EASY) * 20.0).ceil(), deg(worst), -from_safe);
        ranked.push((key, psi));
    }
    ranked.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap_or(std::cmp::Ordering::Equal));
    ranked.into_iter().map(|r| r.1).collect()
}

/// Planning keeps every location this far (10°) from the joint limits and the elbow's
/// stretch when it can.
pub const CLEAR: f64 = std::f64::consts::PI / 18.0;

/// At most this many first turns are tried after the one nearest the safe location.
const TRIES: usize = 4;

/// Plan every sample: joint values in configuration `cfg`, starting from the safe
/// location; each location after the first turns about the beam to move the joints least
/// from the last. The first location's turn is the one nearest the safe location; when
/// that plan fails or brings a location within [`CLEAR`] of a joint limit or the elbow's
/// stretch, up to four more are tried in [`first_turns`]'s order, and the plan that keeps
/// farthest from trouble is taken (the first clear one); on a path longer than
/// [`MEET_AT`] locations, tries whose tracks have met there count as one plan (the one
/// keeping farthest from trouble so far is planned on). Errors (the nearest turn's) name
/// the input line and the joint. The tried turns are planned on up to two threads
/// ([`plan_threads`]); the result is the same on any number.
pub fn plan(arm: &Arm, samples: &[Sample], cfg: Config) -> Result<Vec<Located>, RobotError> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get().min(2));
    plan_threads(arm, samples, cfg, threads)
}

/// A finished plan and how far it keeps from trouble, in the order the plans are tried
/// (0: from the turn nearest the safe location).
struct Tried {
    order: usize,
    margin: f64,
    located: Vec<Located>,
}

impl Tried {
    /// Whether `self` is taken over `other` when both are planned: one clear of trouble
    /// over one not, the first of two clear ones (planning stops there), else the one
    /// keeping farther from trouble, the first of equals.
    fn beats(&self, other: &Tried) -> bool {
        match (self.margin >= CLEAR, other.margin >= CLEAR) {
            (true, true) => self.order < other.order,
            (true, false) => true,
            (false, true) => false,
            (false, false) => {
                self.margin > other.margin
                    || (self.margin == other.margin && self.order < other.order)
            }
        }
    }
}

/// [`plan`] with the tried first turns planned on `threads` threads (1: one after the
/// other, stopping at the first clear plan). Each try is a whole plan, independent of the
/// others; the one taken is the one the sequential rule takes (the first clear one, else
/// the first keeping farthest from trouble), so the result does not depend on `threads`.
pub fn plan_threads(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    threads: usize,
) -> Result<Vec<Located>, RobotError> {
    plan_tries(arm, samples, cfg, threads, true, true).map(|p| p.0)
}

/// [`plan_threads`] with every try planned to its end (no try stops early where it can no
/// longer be taken): the reference the early stop is tested against.
#[doc(hidden)]
pub fn plan_every_try_to_its_end(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    threads: usize,
) -> Result<Vec<Located>, RobotError> {
    plan_tries(arm, samples, cfg, threads, false, true).map(|p| p.0)
}

/// The rule before tries that meet were dropped ([`MEET_AT`]): every try planned to its
/// end, none dropped; and the least margin of the plan taken. The reference the meeting
/// rule is tested against.
#[doc(hidden)]
pub fn plan_every_try_in_full(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    threads: usize,
) -> Result<(Vec<Located>, f64), RobotError> {
    plan_tries(arm, samples, cfg, threads, false, false).map(|p| {
        let m =
            p.0.iter()
                .map(|x| arm.margin(&x.q))
                .fold(f64::INFINITY, f64::min);
        (p.0, m)
    })
}

/// [`plan_threads`], and the orders (1: the first try) of the tries dropped because their
/// track met an earlier one's ([`MEET_AT`]).
#[doc(hidden)]
pub fn plan_and_tries_met(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    threads: usize,
) -> Result<(Vec<Located>, Vec<usize>), RobotError> {
    plan_tries(arm, samples, cfg, threads, true, true)
}

/// Where the tried first turns' tracks are compared: after this many locations (on a
/// longer path), by when tracks in one valley of the joint-change cost have met (the
/// plate's three tries 5° apart come within 1.5e-5 rad by location 1,024 at `--layer 2`,
/// 1.5e-4 rad at `--layer 20`, from 0.1 rad at location 512).
pub const MEET_AT: usize = 2048;

/// Tracks meet when every joint and the turn about the beam lie this close (1e-3 rad,
/// 0.06°) at [`MEET_AT`]; tracks in different valleys lie radians apart.
pub const MEET: f64 = 1e-3;

/// Whether two tracks (planned to the same location) meet: every joint and the turn
/// about the beam within [`MEET`].
fn meets(a: &Track, b: &Track) -> bool {
    crate::arm::wrap(a.psi_prev - b.psi_prev).abs() <= MEET
        && a.prev
            .iter()
            .zip(&b.prev)
            .all(|(x, y)| (x - y).abs() <= MEET)
}

/// The tries (each planned to the same location, `None` where it failed) that are kept
/// when tracks that meet count as one plan: of tries that meet, the one whose locations so
/// far keep farthest from trouble (the first of equals); `true` where a try is dropped.
fn met(tries: &[Option<Track>]) -> Vec<bool> {
    let least: Vec<f64> = tries
        .iter()
        .map(|t| t.as_ref().map_or(f64::NEG_INFINITY, |t| t.least()))
        .collect();
    let mut dropped = vec![false; tries.len()];
    let mut kept: Vec<usize> = Vec::new();
    for (k, tk) in tries.iter().enumerate() {
        let Some(tk) = tk else {
            continue;
        };
        let with = kept
            .iter()
            .position(|&j| tries[j].as_ref().is_some_and(|tj| meets(tj, tk)));
        match with {
            None => kept.push(k),
            Some(p) if least[k] > least[kept[p]] => {
                dropped[kept[p]] = true;
                kept[p] = k;
            }
            Some(_) => dropped[k] = true,
        }
    }
    dropped
}

fn plan_tries(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    threads: usize,
    stop_early: bool,
    meet: bool,
) -> Result<(Vec<Located>, Vec<usize>), RobotError> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Mutex;
    let worst = |l: &[Located]| {
        l.iter()
            .map(|x| arm.margin(&x.q))
            .fold(f64::INFINITY, f64::min)
    };
    // Without a floor a plan is never dropped: `None` cannot come back.
    let nearest = track(arm, samples, cfg, None, None).map(|l| {
        let l = l.unwrap_or_default();
        Tried {
            order: 0,
            margin: worst(&l),
            located: l,
        }
    });
    if let Ok(n) = &nearest {
        if n.margin >= CLEAR {
            return nearest.map(|n| (n.located, Vec::new()));
        }
    }
    let turns: Vec<f64> = first_turns(arm, samples, cfg)
        .into_iter()
        .take(TRIES)
        .collect();
    // Every try's first MEET_AT locations; on a longer path, tries whose tracks have met
    // there are one plan (the rest of the path takes them along one valley of the
    // joint-change cost), so only one of them is planned on.
    let heads = crate::chunk::par_map(turns.len(), threads, |k| {
        let mut t = Track::new(arm, Some(turns[k]), samples.len());
        let end = MEET_AT.min(samples.len());
        advance(arm, samples, cfg, Some(turns[k]), None, &mut t, end)
            .ok()
            .map(|_| t)
    });
    let dropped = if meet && samples.len() > MEET_AT {
        met(&heads)
    } else {
        vec![false; heads.len()]
    };
    let tries_met: Vec<usize> = (0..heads.len())
        .filter(|&k| dropped[k])
        .map(|k| k + 1)
        .collect();
    let heads: Vec<Mutex<Option<Track>>> = heads
        .into_iter()
        .zip(&dropped)
        .map(|(t, &d)| Mutex::new(t.filter(|_| !d)))
        .collect();
    // A try whose locations come nearer trouble than the plan taken so far (or than
    // CLEAR, while a clear plan of a lower order may still come) cannot be taken: it
    // stops there. This saves work only; the plan taken is the same.
    let floor = Floor::new(nearest.as_ref().map_or(f64::NEG_INFINITY, |n| n.margin));
    // The order of the first clear plan found (planning stops there: a later try is not
    // needed), the next try to take, and the plan taken so far.
    let clear_at = AtomicUsize::new(usize::MAX);
    let next = AtomicUsize::new(0);
    let best: Mutex<Option<Tried>> = Mutex::new(None);
    let work = || loop {
        let k = next.fetch_add(1, Ordering::Relaxed);
        let Some(head) = heads.get(k) else {
            break;
        };
        let order = k + 1;
        if clear_at.load(Ordering::Relaxed) < order {
            break;
        }
        let head = head
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .take();
        let Some(mut t) = head else {
            continue;
        };
        let stop_below = stop_early.then_some(&floor);
        if stop_below.is_some_and(|f| t.least() < f.get()) {
            continue;
        }
        let start = Some(turns[k]);
        let n = samples.len();
        let Ok(true) = advance(arm, samples, cfg, start, stop_below, &mut t, n) else {
            continue;
        };
        let tried = Tried {
            order,
            margin: t.least(),
            located: t.out,
        };
        if tried.margin >= CLEAR {
            clear_at.fetch_min(order, Ordering::Relaxed);
        }
        let mut b = best
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if b.as_ref().is_none_or(|b| tried.beats(b)) {
            floor.raise(tried.margin.min(CLEAR));
            *b = Some(tried);
        }
    };
    let threads = threads.clamp(1, turns.len().max(1));
    if threads == 1 {
        work();
    } else {
        std::thread::scope(|s| {
            for _ in 1..threads {
                s.spawn(work);
            }
            work();
        });
    }
    let tried = best
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let taken = match (nearest, tried) {
        (Ok(n), Some(t)) => Ok(if t.beats(&n) { t } else { n }.located),
        (Ok(n), None) => Ok(n.located),
        (Err(_), Some(t)) => Ok(t.located),
        (Err(e), None) => Err(e),
    };
    taken.map(|l| (l, tries_met))
}

/// The least margin ([`Arm::margin`]) a try must keep all along to be taken over the plan
/// taken so far: an `f64` shared by the threads, only ever raised.
struct Floor(std::sync::atomic::AtomicU64);

impl Floor {
    fn new(v: f64) -> Floor {
        Floor(std::sync::atomic::AtomicU64::new(v.to_bits()))
    }

    fn get(&self) -> f64 {
        f64::from_bits(self.0.load(std::sync::atomic::Ordering::Relaxed))
    }

    fn raise(&self, v: f64) {
        use std::sync::atomic::Ordering::Relaxed;
        let _ = self.0.fetch_update(Relaxed, Relaxed, |b| {
            (v > f64::from_bits(b)).then_some(v.to_bits())
        });
    }
}

/// A plan under way: the locations planned so far and the state the next one starts
/// from (the last joints and turn about the beam).
struct Track {
    out: Vec<Located>,
    prev: Q,
    psi_prev: f64,
    /// The sine and cosine of `psi_prev`.
    sc_prev: (f64, f64),
    /// The directions of the last location's angles ([`Arm::change_turned`]).
    dirs: Option<Directions>,
    /// How many locations in a row up to the last kept joints found by changes (see
    /// [`RESYNC`]).
    drift: usize,
    /// The least margin ([`Arm::margin`]) of the locations planned so far.
    least: f64,
}

impl Track {
    /// Nothing planned yet: from the safe location, with the first turn `start` (`None`:
    /// the one nearest the safe location).
    fn new(arm: &Arm, start: Option<f64>, capacity: usize) -> Track {
        let psi = start.unwrap_or(0.0);
        Track {
            out: Vec::with_capacity(capacity),
            prev: arm.safe,
            psi_prev: psi,
            sc_prev: psi.sin_cos(),
            dirs: None,
            drift: 0,
            least: f64::INFINITY,
        }
    }

    /// The least margin ([`Arm::margin`]) of the locations planned so far.
    fn least(&self) -> f64 {
        self.least
    }
}

/// The plan from a first turn about the beam (`None`: the one nearest the safe location).
/// With a floor, `Ok(None)` when a location's margin falls below it: the plan cannot be
/// taken and is left unfinished.
fn track(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    start: Option<f64>,
    floor: Option<&Floor>,
) -> Result<Option<Vec<Located>>, RobotError> {
    let mut t = Track::new(arm, start, samples.len());
    let done = advance(arm, samples, cfg, start, floor, &mut t, samples.len())?;
    Ok(done.then_some(t.out))
}

/// A turn about the beam priced at one location.
#[derive(Debug, Clone, Copy)]
struct Priced {
    /// The joint change from the last location (sum of squares, rad²).
    cost: f64,
    /// The turn, and its sine and cosine.
    psi: f64,
    sc: (f64, f64),
    /// The joints there and their directions ([`Arm::change_turned`]).
    q: Q,
    dirs: Option<Directions>,
    /// Solved in full; else the joints are another turn's plus changes measured by
    /// directions ([`Arm::changes_lanes`]).
    full: bool,
}

/// At most this many locations in a row (64) keep joints found by changes from the last
/// ([`Arm::change_turned`], each within 1e-14 rad of the full solve's); the next is solved
/// in full, so rounding cannot pile up along the path.
const RESYNC: usize = 64;

/// Joint changes by [`Arm::change_turned`] are used below this (π − 0.5 rad): nearer a
/// half turn the full solve picks the turn.
const NO_WRAP: f64 = std::f64::consts::PI - 0.5;

/// The refining step from the last turn (0.5°).
const NARROW_DEG: f64 = 0.5;

/// The refining step after a scan (2°).
const WIDE_DEG: f64 = 2.0;

/// One location's search for its turn about the beam: what every pricing there shares.
struct Step<'a> {
    arm: &'a Arm,
    cfg: Config,
    site: Site<'a>,
    /// The location's place on the path (the first seeds a numerical inverse afresh).
    i: usize,
    /// The last location's joints and turn (with its sine and cosine).
    prev: Q,
    psi_prev: f64,
    sc_prev: (f64, f64),
}

impl Step<'_> {
    /// The joint change from the last location.
    fn cost(&self, q: &Q) -> f64 {
        q.iter()
            .zip(&self.prev)
            .map(|(a, b)| (a - b) * (a - b))
            .sum()
    }

    /// Turn `psi` solved in full (`fresh`: a numerical inverse seeded afresh).
    fn solved(&self, psi: f64, sc: (f64, f64), fresh: bool) -> Result<Priced, NoReach> {
        let (q, dirs) = solve_at(self.arm, &self.site, sc, self.cfg, &self.prev, fresh)?;
        Ok(Priced {
            cost: self.cost(&q),
            psi,
            sc,
            q,
            dirs,
            full: true,
        })
    }

    /// Turn `psi` priced from `b`: its joints as `b`'s plus the changes measured from
    /// `b`'s directions where it can ([`Arm::changes_lanes`]), else solved in full.
    fn from(&self, psi: f64, sc: (f64, f64), b: &Priced) -> Result<Priced, NoReach> {
        if let (Some(t), Some(d)) = (&self.site.closed, &b.dirs) {
            if let [Some((dq, to))] = self.arm.changes_lanes(t, &[sc], self.cfg, &b.q, d) {
                let ch: Q = std::array::from_fn(|j| (b.q[j] - self.prev[j]) + dq[j]);
                if ch.iter().all(|c| c.abs() < NO_WRAP) {
                    return Ok(Priced {
                        cost: ch.iter().map(|c| c * c).sum(),
                        psi,
                        sc,
                        q: std::array::from_fn(|j| b.q[j] + dq[j]),
                        dirs: Some(to),
                        full: false,
                    });
                }
            }
        }
        self.solved(psi, sc, self.i == 0)
    }

    /// The last turn and a narrow step to each side of it, priced at once from the last
    /// location's joints and directions `dirs` where they can be (one four-lane
    /// [`Arm::changes_lanes`]; the sides' sines and cosines by the angle sum, to an ulp).
    fn last_and_sides(&self, dirs: &Directions, narrow_sc: (f64, f64)) -> [Option<Priced>; 3] {
        let Some(st) = &self.site.closed else {
            return [None; 3];
        };
        let narrow = NARROW_DEG.to_radians();
        let psis = [
            self.psi_prev,
            self.psi_prev - narrow,
            self.psi_prev + narrow,
        ];
        let ((s0, c0), (sh, ch)) = (self.sc_prev, narrow_sc);
        let sc = [
            (s0, c0),
            (s0 * ch - c0 * sh, c0 * ch + s0 * sh),
            (s0 * ch + c0 * sh, c0 * ch - s0 * sh),
        ];
        let lanes = self.arm.changes_lanes(
            st,
            &[sc[0], sc[1], sc[2], sc[0]],
            self.cfg,
            &self.prev,
            dirs,
        );
        std::array::from_fn(|k| {
            let (dq, to) = lanes[k]?;
            dq.iter().all(|c| c.abs() < NO_WRAP).then(|| Priced {
                cost: dq.iter().map(|c| c * c).sum(),
                psi: psis[k],
                sc: sc[k],
                q: std::array::from_fn(|j| self.prev[j] + dq[j]),
                dirs: Some(to),
                full: false,
            })
        })
    }

    /// The whole turn scanned (72 turns 5° apart from the last), the cheapest kept:
    /// at the first location, or where the last turn is blocked.
    fn scan(&self, s: &Sample) -> Result<Priced, RobotError> {
        let mut best: Option<Priced> = None;
        let mut fails: Vec<NoReach> = Vec::new();
        for k in 0..TURNS {
            let psi = self.psi_prev + f64::from(k) * std::f64::consts::TAU / f64::from(TURNS);
            match self.solved(psi, psi.sin_cos(), true) {
                Ok(p) if best.as_ref().is_none_or(|b| p.cost < b.cost) => best = Some(p),
                Ok(_) => {}
                Err(e) => fails.push(e),
            }
        }
        best.ok_or_else(|| unreachable(self.arm, s, self.i, &fails))
    }

    /// Parabolic steps on the cost from `b`: after a scan (`wide`) four steps of
    /// shrinking width from 2°; from the last turn, steps 0.5° wide until the parabola's
    /// least lies within its reach (one step, mostly: the cost is smooth and the turn
    /// moves little), four at most. `priced`: [`Step::last_and_sides`]'s, used for the
    /// first narrow step from the last turn.
    fn refine(&self, mut b: Priced, wide: bool, priced: &[Option<Priced>; 3]) -> Priced {
        let narrow = NARROW_DEG.to_radians();
        let mut h = if wide { WIDE_DEG } else { NARROW_DEG }.to_radians();
        let side = |k: usize, psi: f64, b: &Priced, h: f64| match priced[k] {
            Some(p) if b.psi == self.psi_prev && h == narrow => Ok(p),
            _ => self.from(psi, psi.sin_cos(), b),
        };
        for _ in 0..4 {
            let (Ok(lo), Ok(hi)) = (side(1, b.psi - h, &b, h), side(2, b.psi + h, &b, h)) else {
                h /= 4.0;
                continue;
            };
            let denom = lo.cost - 2.0 * b.cost + hi.cost;
            let mut cand = if lo.cost < b.cost {
                Some(lo)
            } else if hi.cost < b.cost {
                Some(hi)
            } else {
                None
            };
            let mut reached = false;
            if denom > 0.0 {
                let raw = -h * (hi.cost - lo.cost) / (2.0 * denom);
                reached = raw.abs() < 4.0 * h;
                let step = raw.clamp(-4.0 * h, 4.0 * h);
                let psi = b.psi + step;
                // The parabola's turn from its centre's sine and cosine by the series.
                let sc = turned_by(b.sc, step);
                if let Ok(p) = self.from(psi, sc, &b) {
                    if cand.as_ref().is_none_or(|x| p.cost < x.cost) {
                        cand = Some(p);
                    }
                }
            }
            if let Some(c) = cand.filter(|c| c.cost < b.cost) {
                b = c;
            }
            if wide {
                h /= 4.0;
            } else if reached {
                break;
            }
        }
        b
    }
}

/// Plans locations `t.out.len()..end` of the plan from first turn `start` (`None`: the
/// one nearest the safe location), each from the last; `Ok(false)` when a location's
/// margin falls below the floor (left unfinished: the plan cannot be taken). At each
/// location: the last turn and its narrow sides priced ([`Step::last_and_sides`]); where
/// the last turn is blocked, the whole turn scanned ([`Step::scan`]); then refined
/// ([`Step::refine`]; not at a first turn chosen for the whole path: drawing it towards
/// the safe location would undo the choice); then kept ([`keep`]).
#[allow(clippy::too_many_arguments)]
fn advance(
    arm: &Arm,
    samples: &[Sample],
    cfg: Config,
    start: Option<f64>,
    floor: Option<&Floor>,
    t: &mut Track,
    end: usize,
) -> Result<bool, RobotError> {
    let from = t.out.len();
    let narrow_sc = NARROW_DEG.to_radians().sin_cos();
    for (i, s) in samples.iter().enumerate().take(end).skip(from) {
        let step = Step {
            arm,
            cfg,
            site: Site::new(arm, s),
            i,
            prev: t.prev,
            psi_prev: t.psi_prev,
            sc_prev: t.sc_prev,
        };
        let priced = match &t.dirs {
            Some(d) if i > 0 => step.last_and_sides(d, narrow_sc),
            _ => [None; 3],
        };
        let last = priced[0].or_else(|| {
            (i > 0 || start.is_some())
                .then(|| step.solved(t.psi_prev, t.sc_prev, i == 0).ok())
                .flatten()
        });
        let best = match last {
            // A first turn chosen for the whole path is kept as it is.
            Some(b) if i == 0 => b,
            Some(b) => step.refine(b, false, &priced),
            None => step.refine(step.scan(s)?, true, &priced),
        };
        if !keep(&step, s, best, floor, t)? {
            return Ok(false);
        }
    }
    Ok(true)
}

/// The location priced `best` appended to the track: solved in full where RESYNC
/// locations in a row kept joints found by changes, checked for joint speed, and
/// `Ok(false)` where its margin falls below the floor.
fn keep(
    step: &Step,
    s: &Sample,
    best: Priced,
    floor: Option<&Floor>,
    t: &mut Track,
) -> Result<bool, RobotError> {
    let (arm, i) = (step.arm, step.i);
    // Solved in full afresh (the turn's sine and cosine too, which the angle sums and
    // series carry from location to location otherwise).
    let resync = !best.full && t.drift + 1 >= RESYNC;
    let b = if resync {
        step.solved(best.psi, best.psi.sin_cos(), i == 0)
            .map_err(|e| unreachable(arm, s, i, &[e]))?
    } else {
        best
    };
    if i > 0 {
        check_speed(arm, s, &step.prev, &b.q)?;
    }
    let margin = arm.margin(&b.q);
    if floor.is_some_and(|f| margin < f.get()) {
        return Ok(false);
    }
    t.out.push(Located { q: b.q, psi: b.psi });
    t.least = t.least.min(margin);
    t.prev = b.q;
    t.psi_prev = b.psi;
    t.sc_prev = b.sc;
    t.dirs = b.dirs;
    t.drift = if best.full || resync { 0 } else { t.drift + 1 };
    Ok(true)
}

/// The joint speeds of the move from `from` to `to` in `s.dt` seconds.
pub fn check_speed(arm: &Arm, s: &Sample, from: &Q, to: &Q) -> Result<(), RobotError> {
    for j in 0..6 {
        let dq = (to[j] - from[j]).abs();
        let max = arm.links[j].max_speed;
        if dq > max * s.dt + 1e-9 {
            let name = arm.joint_name(j);
            let what = if s.dt > 0.0 {
                format!(
                    "the path point at line {}: {name} must turn {:.3}° in {:.4} s ({:.1}°/s) but turns at most {:.1}°/s: the approach turns faster than the arm can follow at this feed",
                    s.line,
                    dq.to_degrees(),
                    s.dt,
                    dq.to_degrees() / s.dt,
                    max.to_degrees()
                )
            } else {
                format!(
                    "the path point at line {}: {name} must turn {:.3}° with no travel (the approach turns in place): the arm cannot follow at any feed",
                    s.line,
                    dq.to_degrees()
                )
            };
            return Err(RobotError::TooFast {
                line: s.line,
                joint: name.to_string(),
                what,
            });
        }
    }
    Ok(())
}

fn unreachable(arm: &Arm, s: &Sample, i: usize, fails: &[NoReach]) -> RobotError {
    // The joint that blocks most turns about the beam.
    let mut count = [0usize; 6];
    for f in fails {
        count[f.joint.min(5)] += 1;
    }
    let j = (0..6).max_by_key(|&j| count[j]).unwrap_or(2);
    let why = fails
        .iter()
        .find(|f| f.joint == j)
        .map_or("no solution".to_string(), |f| match &f.why {
            Why::Words(w) => w.clone(),
            o @ Why::Outside { .. } => format!("{} {o}", arm.joint_name(j)),
        });
    let name = arm.joint_name(j).to_string();
    RobotError::Unreachable {
        line: s.line,
        joint: name.clone(),
        what: format!(
            "the path point at line {} (location {}, at {:.3} {:.3} {:.3}) is beyond reach at every turn about the beam: {name} limits it ({why})",
            s.line,
            i + 1,
            s.tip.x,
            s.tip.y,
            s.tip.z
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sequential rule of [`plan_threads`] on one thread: the nearest plan, then the
    /// tries in order, a later one taken when it keeps strictly farther from trouble,
    /// stopping at the first clear one.
    fn sequential(margins: &[Option<f64>]) -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        for (order, m) in margins.iter().enumerate() {
            let Some(m) = *m else {
                continue;
            };
            if order == 0 && m >= CLEAR {
                return Some(0);
            }
            if best.is_none_or(|b| m > b.1) {
                best = Some((order, m));
            }
            if order > 0 && m >= CLEAR {
                break;
            }
        }
        best.map(|b| b.0)
    }

    /// [`Tried::beats`] takes, in any order of finishing, the plan the sequential rule
    /// takes (ties, clear plans after the first clear one and failed tries included).
    #[test]
    fn the_plan_taken_does_not_depend_on_the_order_of_finishing() {
        let picks = [
            None,
            Some(0.01),
            Some(0.05),
            Some(0.05),
            Some(CLEAR),
            Some(0.3),
        ];
        let mut seed = 12345u64;
        for _ in 0..20_000 {
            let mut next = || {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                seed
            };
            let n = 1 + (next() % 5) as usize;
            let margins: Vec<Option<f64>> = (0..n).map(|_| picks[(next() % 6) as usize]).collect();
            let mut order: Vec<usize> = (0..n).collect();
            for i in (1..n).rev() {
                order.swap(i, (next() % (i as u64 + 1)) as usize);
            }
            let mut best: Option<Tried> = None;
            for &k in &order {
                let Some(margin) = margins[k] else {
                    continue;
                };
                let t = Tried {
                    order: k,
                    margin,
                    located: Vec::new(),
                };
                if best.as_ref().is_none_or(|b| t.beats(b)) {
                    best = Some(t);
                }
            }
            assert_eq!(
                best.map(|b| b.order),
                sequential(&margins),
                "{margins:?} {order:?}"
            );
        }
    }
    /// [`carry`] turns the reference by the smallest turn of the axis, as Rodrigues'
    /// formula with the turn's angle (`atan2`, `sin`, `cos`) turns it, to 1e-14, for
    /// turns up to 170°; the result is a unit vector perpendicular to the new axis.
    #[test]
    fn the_reference_is_carried_by_the_smallest_turn() {
        let mut rng = lampost_testkit::XorShift(5);
        let mut next = || rng.unit() - 0.5;
        for trial in 0..50_000 {
            let a = Vector3::new(next(), next(), next()).normalize();
            let kick = if trial % 2 == 0 { 0.05 } else { 3.0 };
            let b = (a + Vector3::new(next(), next(), next()) * kick).normalize();
            if a.dot(&b) < (170f64).to_radians().cos() {
                continue;
            }
            let u = perpendicular(&a);
            let k = a.cross(&b);
            let ang = k.norm().atan2(a.dot(&b));
            let k = k.normalize();
            let turned =
                u * ang.cos() + k.cross(&u) * ang.sin() + k * k.dot(&u) * (1.0 - ang.cos());
            let want = (turned - b * b.dot(&turned)).normalize();
            let got = carry(&u, &a, &b);
            assert!((got - want).norm() < 1e-14, "{a:?} {b:?}");
            assert!((got.norm() - 1.0).abs() < 1e-15 && got.dot(&b).abs() < 1e-15);
        }
    }

    /// [`turned_by`] is `sin_cos` of the sum to 1e-15 for turns up to 8° from anywhere.
    #[test]
    fn a_small_turn_by_the_angle_sum_is_the_sum_turned() {
        let mut rng = lampost_testkit::XorShift(99);
        let mut next = || rng.unit();
        for _ in 0..100_000 {
            let psi = (next() - 0.5) * 40.0;
            let x = (next() - 0.5) * 2.0 * 8f64.to_radians();
            let (s, c) = turned_by(psi.sin_cos(), x);
            let (s1, c1) = (psi + x).sin_cos();
            // The sum itself is rounded: |ψ| ≤ 20 puts an ulp of it near 4e-15.
            assert!(
                (s - s1).abs() < 1e-14 && (c - c1).abs() < 1e-14,
                "{psi} {x}"
            );
        }
    }

    /// A track ending at joints `q` and turn `psi`, its one earlier location at `q0`.
    fn ended(q0: Q, q: Q, psi: f64) -> Track {
        let at = |q: Q| Located { q, psi };
        let Some(arm) = Arm::builtin("puma-lens") else {
            panic!("built-in");
        };
        Track {
            out: vec![at(q0), at(q)],
            prev: q,
            psi_prev: psi,
            sc_prev: psi.sin_cos(),
            dirs: None,
            drift: 0,
            least: arm.margin(&q0).min(arm.margin(&q)),
        }
    }

    /// [`met`]: of tracks within [`MEET`] of one another (every joint and the turn, half
    /// turns of the turn apart the same), the one keeping farthest from trouble so far is
    /// kept, the first of equals; tracks farther apart and failed tries are left alone.
    #[test]
    fn tracks_that_meet_keep_the_one_farthest_from_trouble() {
        let q = [0.1, 0.5, -0.5, 0.2, 0.4, 0.3];
        // J1 moved (far from its limits: the margins stay q's).
        let (mut near, mut far) = (q, q);
        near[0] += 0.9 * MEET;
        far[0] += 2.0 * MEET;
        let tau = std::f64::consts::TAU;
        // J5 near its limit (100°) at the start: nearer trouble.
        let mut worse = q;
        worse[4] = 1.7;
        let tries = [
            Some(ended(worse, q, 1.0)),
            None,
            Some(ended(q, near, 1.0 + tau)),
            Some(ended(q, q, 1.0 + 1.1 * MEET)),
            Some(ended(q, far, 1.0)),
            Some(ended(q, q, 1.0)),
        ];
        // 0 and 2 meet: 2 kept (0 nearer trouble); 3's turn is too far, 4's joints; 5
        // meets 2 and keeps as far from trouble: the first of equals (2) kept.
        assert_eq!(met(&tries), [true, false, false, false, false, true]);
        // Equal so far: the first kept.
        let tries = [Some(ended(q, q, 1.0)), Some(ended(q, near, 1.0))];
        assert_eq!(met(&tries), [false, true]);
    }
}
