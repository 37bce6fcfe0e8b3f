//! Machine reach of a planned path (issue 15 item 6): whether a table machine can put
//! the tool at every point of the path with its tool axis, the way `lampost post` places
//! and solves a per-point path.
//!
//! Each point (mm, part frame) is moved to the program origin (`origin + p`, the post's
//! `--origin`), scaled to the machine's units, and solved by the kinematics crate's
//! inverse kinematics ([`Machine::inverse`]) and chooser ([`Machine::choose`]) from the
//! rotary position of the point before (the first from `near`), keeping the rotary
//! branch while it can, as the post does: a point is reachable when some solution has
//! every linear axis within its travel and every rotary within its limits. The extents
//! used are those of the chosen joints of the reachable points. (The post also checks the
//! moves between points and the retract heights above the work; a path whose points are
//! all reachable can still be refused there.)

use lampost_kinematics::{Machine, Units};
use lampost_mesh::P3;

use crate::perimeter::PathPoint;

/// Where and how the path is placed on the machine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReachOptions {
    /// The head (index into the machine's heads).
    pub head: usize,
    /// Program origin in the part frame (mm): the path's point `p` is at `origin + p`.
    pub origin: P3,
    /// Rotary position the first point is solved nearest (degrees, file order).
    pub near: [f64; 2],
}

/// One joint's extent over the reachable points, and its travel.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisExtent {
    /// The axis name (machine file).
    pub name: String,
    /// Smallest and largest value used (machine units or degrees); `None` when no point
    /// is reachable.
    pub used: Option<(f64, f64)>,
    /// Its travel; `None` for an unlimited rotary.
    pub limits: Option<(f64, f64)>,
}

/// The first point the machine cannot reach.
#[derive(Debug, Clone, PartialEq)]
pub struct Unreachable {
    /// Index of the point in the path (0 first).
    pub index: usize,
    /// Its layer.
    pub layer: usize,
    /// The point (part frame, mm, before the origin).
    pub p: P3,
    /// Its tool axis.
    pub axis: P3,
    /// Why (the kinematics' reason: which joint is beyond which limit, or no rotation
    /// turns the axis).
    pub why: String,
}

/// The reach of a path on one machine.
#[derive(Debug, Clone, PartialEq)]
pub struct Reach {
    /// The machine's name.
    pub machine: String,
    /// Points checked.
    pub points: usize,
    /// Points no solution reaches.
    pub unreachable: usize,
    /// Layers holding an unreachable point, in order.
    pub unreachable_layers: Vec<usize>,
    /// The first unreachable point.
    pub first: Option<Unreachable>,
    /// Rotary branch flips between consecutive points (the post retracts and re-approaches
    /// at each).
    pub branch_flips: usize,
    /// Per joint (linear axes, then rotary, file order): extent used and travel.
    pub axes: Vec<AxisExtent>,
}

impl Reach {
    /// Every point is reachable.
    pub fn reachable(&self) -> bool {
        self.unreachable == 0
    }
}

/// Check every point of `points` on `m` (see the module documentation).
pub fn reach(m: &Machine, points: &[PathPoint], opts: &ReachOptions) -> Reach {
    let scale = match m.units {
        Units::Mm => 1.0,
        Units::Inch => 1.0 / 25.4,
    };
    let mut used: [Option<(f64, f64)>; 5] = [None; 5];
    let mut out = Reach {
        machine: m.name.clone(),
        points: points.len(),
        unreachable: 0,
        unreachable_layers: Vec::new(),
        first: None,
        branch_flips: 0,
        axes: Vec::new(),
    };
    let mut near = opts.near;
    let mut branch: Option<i8> = None;
    for (i, q) in points.iter().enumerate() {
        let tip = (opts.origin + q.p) * scale;
        let chosen = m
            .inverse(&tip, &q.axis, opts.head, &near)
            .and_then(|sols| m.choose(&sols, branch, &q.axis, opts.head));
        match chosen {
            Ok(c) => {
                let j = c.solution.joints;
                for (u, v) in used.iter_mut().zip(j.values()) {
                    *u = Some(u.map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v))));
                }
                if c.branch_flip && branch.is_some() {
                    out.branch_flips += 1;
                }
                near = j.rotary;
                branch = Some(c.solution.branch);
            }
            Err(e) => {
                out.unreachable += 1;
                if out.unreachable_layers.last() != Some(&q.layer) {
                    out.unreachable_layers.push(q.layer);
                }
                if out.first.is_none() {
                    out.first = Some(Unreachable {
                        index: i,
                        layer: q.layer,
                        p: q.p,
                        axis: q.axis,
                        why: e.to_string(),
                    });
                }
            }
        }
    }
    let names = m.axis_names();
    out.axes = (0..5)
        .map(|k| AxisExtent {
            name: names[k].to_string(),
            used: used[k],
            limits: if k < 3 {
                Some(m.linear[k].limits)
            } else {
                m.rotary[k - 3].limits
            },
        })
        .collect();
    out
}
