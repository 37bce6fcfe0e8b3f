//! LinuxCNC's cutter radius compensation (G41/G42, G41.1/G42.1), as its interpreter
//! documents and makes it, worked in the plane's own coordinates (`[a, b]`: X and Y in
//! G17, Z and X in G18, where G18's arcs turn as G17's do).
//!
//! The rules (LinuxCNC's `convert_straight_comp1/2`, `convert_arc_comp2` and its queue):
//! - the first move after compensation is turned on (the entry) ends the tool radius
//!   off the programmed end, square to the line from the tool to that end; it must be
//!   longer than the radius;
//! - every later move ends the radius off its programmed end, square to its own
//!   direction there (an arc's: along its radius, in or out); a move is held until the
//!   next one says where it ends;
//! - an outside (convex) corner is joined by an arc about the programmed corner (a
//!   rapid: a straight traverse to the arc's end);
//! - an inside (concave) corner moves the held move's end back to where the two offset
//!   paths meet (line–line by the half corner, arc–line and line–arc by the circle, arc–arc
//!   by the two circles), refused where the tool cannot reach it (gouging);
//! - G40 (or the end) lets the held move go as it is.
//!
//! A lathe tool's orientation (G41.1/G42.1's L, 1–8) shifts every point sent by the
//! radius, as LinuxCNC's control point is the tool's tip, not its nose centre.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Which side of the path the tool runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// G41, G41.1
    Left,
    /// G42, G42.1
    Right,
}

/// Why compensation cannot go on (LinuxCNC's words).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CompError(pub &'static str);

impl std::fmt::Display for CompError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.0)
    }
}

/// A compensated move sent on, in plane coordinates (the tool's nose centre; see
/// [`Comp::origin`] for the point the machine is told).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece<T> {
    /// Straight (rapid or feed) or an arc.
    pub shape: Shape,
    /// Where it ends.
    pub end: [f64; 2],
    /// The caller's move it stands for.
    pub tag: T,
    /// An arc added about a convex corner (or the rapid that stands for it), not a
    /// programmed move.
    pub corner: bool,
}

/// A piece's shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A straight move (`rapid`: G0).
    Straight {
        /// G0
        rapid: bool,
    },
    /// An arc about `center`, counter-clockwise when `turn` > 0.
    Arc {
        /// Centre (plane coordinates).
        center: [f64; 2],
        /// +1 counter-clockwise, −1 clockwise.
        turn: i32,
    },
}

#[derive(Debug, Clone, Copy)]
struct Held<T> {
    piece: Piece<T>,
    /// A straight move's programmed direction (its end may not be pulled back past its
    /// start).
    dir: [f64; 2],
    /// An arc's programmed sweep (radians, signed; 0: not checked).
    sweep: f64,
}

/// LinuxCNC's angle tolerance for corners (radians).
const SMALL: f64 = 0.05;

/// Compensation in force: side, radius, and the held moves.
#[derive(Debug, Clone)]
pub struct Comp<T> {
    side: Side,
    radius: f64,
    orientation: u8,
    mm: bool,
    first: bool,
    programmed: [f64; 2],
    current: [f64; 2],
    held: Vec<Held<T>>,
    endpoint: Option<[f64; 2]>,
}

impl<T: Copy> Comp<T> {
    /// Compensation turned on with the tool at `current`: `radius` (a negative radius
    /// runs on the other side), `orientation` the lathe tool's (0 or 9: none), `mm`
    /// the program's units.
    pub fn new(side: Side, radius: f64, orientation: u8, mm: bool, current: [f64; 2]) -> Self {
        let side = match (radius < 0.0, side) {
            (false, s) => s,
            (true, Side::Left) => Side::Right,
            (true, Side::Right) => Side::Left,
        };
        Comp {
            side,
            radius: radius.abs(),
            orientation,
            mm,
            first: true,
            programmed: current,
            current,
            held: Vec::new(),
            endpoint: None,
        }
    }

    /// The point the machine is told for the nose centre `p` (LinuxCNC's lathe origin:
    /// a lathe tool's tip, by its orientation; `xz`: the plane is G18).
    pub fn origin(&self, p: [f64; 2], xz: bool) -> [f64; 2] {
        if !xz {
            return p;
        }
        let r = self.radius;
        let [mut z, mut x] = p;
        match self.orientation {
            2 | 6 | 1 => x -= r,
            3 | 8 | 4 => x += r,
            _ => {}
        }
        match self.orientation {
            2 | 7 | 3 => z -= r,
            1 | 5 | 4 => z += r,
            _ => {}
        }
        [z, x]
    }

    /// A straight move to the programmed `p`.
    pub fn straight(
        &mut self,
        rapid: bool,
        p: [f64; 2],
        tag: T,
        out: &mut Vec<Piece<T>>,
    ) -> Result<(), CompError> {
        if self.first {
            return self.entry(rapid, p, tag);
        }
        let (c, op, r) = (self.current, self.programmed, self.radius);
        let mut end = c;
        if p == op {
            // No motion in the plane: the tool stays where it is.
            self.hold(straight(rapid, c, tag, false), [0.0, 0.0], 0.0);
        } else {
            let mut theta = (c[1] - op[1]).atan2(c[0] - op[0]);
            let mut alpha = (p[1] - op[1]).atan2(p[0] - op[0]);
            let (beta, gamma) = match self.side {
                Side::Left => {
                    if theta < alpha {
                        theta += TAU;
                    }
                    (theta - alpha - FRAC_PI_2, FRAC_PI_2)
                }
                Side::Right => {
                    if alpha < theta {
                        alpha += TAU;
                    }
                    (alpha - theta - FRAC_PI_2, -FRAC_PI_2)
                }
            };
            let off = [(alpha + gamma).cos(), (alpha + gamma).sin()];
            end = [p[0] + r * off[0], p[1] + r * off[1]];
            let mid = [op[0] + r * off[0], op[1] + r * off[1]];
            let front_arc = self.front_arc();
            let concave = !(-SMALL..=PI + SMALL).contains(&beta)
                || (beta > PI - SMALL
                    && front_arc.is_some_and(|(_, turn, _)| match self.side {
                        Side::Right => turn > 0,
                        Side::Left => turn < 0,
                    }));
            if !concave && beta > SMALL {
                // Outside corner: an arc about the programmed corner (a rapid's is a
                // straight traverse).
                self.flush_to(c, out)?;
                let piece = if rapid {
                    straight(true, mid, tag, true)
                } else {
                    Piece {
                        shape: Shape::Arc {
                            center: op,
                            turn: self.corner_turn(),
                        },
                        end: mid,
                        tag,
                        corner: true,
                    }
                };
                out.push(piece);
                self.endpoint = Some(mid);
            } else if concave {
                let meet = match front_arc {
                    None => {
                        let half = (beta + PI) / 2.0;
                        if half == 0.0 {
                            return Err(CompError(
                                "Zero degree inside corner is invalid for cutter compensation",
                            ));
                        }
                        let back = r / half.tan();
                        [
                            c[0] + back * (theta + gamma).cos(),
                            c[1] + back * (theta + gamma).sin(),
                        ]
                    }
                    Some((center, turn, prev_end)) => {
                        self.arc_then_line(center, turn, prev_end, op, p)?
                    }
                };
                self.flush_to(meet, out)?;
            } else {
                self.release(out);
                self.endpoint = Some(c);
            }
            self.hold(
                straight(rapid, end, tag, false),
                [p[0] - op[0], p[1] - op[1]],
                0.0,
            );
        }
        self.current = end;
        self.programmed = p;
        Ok(())
    }

    /// An arc to the programmed `p` about the programmed `center` (`ccw`: G3).
    pub fn arc(
        &mut self,
        ccw: bool,
        center: [f64; 2],
        p: [f64; 2],
        tag: T,
        out: &mut Vec<Piece<T>>,
    ) -> Result<(), CompError> {
        if self.first {
            return self.arc_entry(ccw, center, p, tag);
        }
        let (c, op, r) = (self.current, self.programmed, self.radius);
        let turn = if ccw { 1 } else { -1 };
        let arc_radius = (center[0] - p[0]).hypot(center[1] - p[1]);
        let mut theta = (c[1] - op[1]).atan2(c[0] - op[0]);
        theta = match self.side {
            Side::Left => theta - FRAC_PI_2,
            Side::Right => theta + FRAC_PI_2,
        };
        let mut delta = (center[1] - op[1]).atan2(center[0] - op[0]);
        let alpha = if ccw {
            delta - FRAC_PI_2
        } else {
            delta + FRAC_PI_2
        };
        let mut beta = match self.side {
            Side::Left => theta - alpha,
            Side::Right => alpha - theta,
        };
        if beta > 1.5 * PI {
            beta -= TAU;
        } else if beta < -FRAC_PI_2 {
            beta += TAU;
        }
        let inside = self.inside(turn);
        let gamma = if inside {
            if arc_radius <= r {
                return Err(CompError(
                    "Tool radius not less than arc radius with cutter radius compensation",
                ));
            }
            (center[1] - p[1]).atan2(center[0] - p[0])
        } else {
            delta += PI;
            (p[1] - center[1]).atan2(p[0] - center[0])
        };
        let new_end = [p[0] + r * gamma.cos(), p[1] + r * gamma.sin()];
        let sweep = find_turn(op, center, turn, p);
        let main = Piece {
            shape: Shape::Arc { center, turn },
            end: new_end,
            tag,
            corner: false,
        };
        if !(-SMALL..=PI + SMALL).contains(&beta) || ((beta - PI).abs() < SMALL && !inside) {
            let meet = match self.front_arc() {
                None => {
                    let across = arc_radius * (beta - FRAC_PI_2).sin();
                    let (from_center, l) = if inside {
                        let d = arc_radius - r;
                        (d, (across + r) / d)
                    } else {
                        let d = arc_radius + r;
                        (d, (across - r) / d)
                    };
                    if !(-1.0..=1.0).contains(&l) {
                        return Err(CompError(
                            "Arc move in concave corner cannot be reached by the tool without gouging",
                        ));
                    }
                    let angle = match (inside, turn > 0) {
                        (true, true) => theta + l.asin(),
                        (true, false) => theta - l.asin(),
                        (false, true) => theta + PI - l.asin(),
                        (false, false) => theta + PI + l.asin(),
                    };
                    [
                        center[0] + from_center * angle.cos(),
                        center[1] + from_center * angle.sin(),
                    ]
                }
                Some((prev_center, prev_turn, prev_end)) => {
                    let old = (prev_center[0] - prev_end[0]).hypot(prev_center[1] - prev_end[1]);
                    let new = if inside {
                        arc_radius - r
                    } else {
                        arc_radius + r
                    };
                    let cc = (prev_center[0] - center[0]).hypot(prev_center[1] - center[1]);
                    if old == 0.0 || cc == 0.0 {
                        return Err(CompError(
                            "Arc to arc motion is invalid because the arcs have the same center",
                        ));
                    }
                    let a = (old * old + cc * cc - new * new) / (2.0 * old * cc);
                    if !(-1.0..=1.0).contains(&a) {
                        return Err(CompError(
                            "Arc to arc motion makes a corner the compensated tool can't fit in without gouging",
                        ));
                    }
                    let pullback = a.acos();
                    let cc_dir = (center[1] - prev_center[1]).atan2(center[0] - prev_center[0]);
                    let dir = if self.inside(prev_turn) == (turn > 0) {
                        cc_dir + pullback
                    } else {
                        cc_dir - pullback
                    };
                    [
                        prev_center[0] + old * dir.cos(),
                        prev_center[1] + old * dir.sin(),
                    ]
                }
            };
            self.flush_to(meet, out)?;
            self.hold(main, [0.0, 0.0], sweep);
        } else if beta > SMALL {
            // Outside corner: an arc about the programmed corner, then the arc.
            let mid = [op[0] + r * delta.cos(), op[1] + r * delta.sin()];
            self.release(out);
            out.push(Piece {
                shape: Shape::Arc {
                    center: op,
                    turn: self.corner_turn(),
                },
                end: mid,
                tag,
                corner: true,
            });
            self.endpoint = Some(mid);
            self.hold(main, [0.0, 0.0], sweep);
        } else {
            self.release(out);
            self.endpoint = Some(c);
            self.hold(main, [0.0, 0.0], sweep);
        }
        self.programmed = p;
        self.current = new_end;
        Ok(())
    }

    /// Compensation turned off (G40) or the program's end: the held moves go as they are.
    pub fn finish(&mut self, out: &mut Vec<Piece<T>>) -> Result<(), CompError> {
        if self.first {
            return Ok(());
        }
        let c = self.current;
        self.flush_to(c, out)
    }

    /// The programmed point (the path's, not the tool's).
    pub fn programmed(&self) -> [f64; 2] {
        self.programmed
    }

    /// The tool taken to be at `at` with the programmed point unchanged, the held
    /// moves kept: what rs274 does when a G70 reads its profile under compensation (its
    /// position becomes the profile's last point, see `Interpreter::finish_profile`).
    pub fn tool_at(&mut self, at: [f64; 2]) {
        self.current = at;
    }

    /// The entry move: the radius off `p`, square to the line from the tool to `p`.
    fn entry(&mut self, rapid: bool, p: [f64; 2], tag: T) -> Result<(), CompError> {
        let (c, r) = (self.current, self.radius);
        if (p[0] - c[0]).hypot(p[1] - c[1]) <= r {
            return Err(CompError(
                "Length of cutter compensation entry move is not greater than the tool radius",
            ));
        }
        let alpha = (p[1] - c[1]).atan2(p[0] - c[0])
            + match self.side {
                Side::Left => FRAC_PI_2,
                Side::Right => -FRAC_PI_2,
            };
        let end = [p[0] + r * alpha.cos(), p[1] + r * alpha.sin()];
        self.endpoint = Some(c);
        self.hold(
            straight(rapid, end, tag, false),
            [alpha.cos(), alpha.sin()],
            0.0,
        );
        self.first = false;
        self.current = end;
        self.programmed = p;
        Ok(())
    }

    /// An arc as the entry (LinuxCNC's `convert_arc_comp1`): it ends the radius off the
    /// programmed end along the arc's radius (in or out), and runs from the tool about a
    /// centre moved along the line from that end to the programmed centre, so that it
    /// is as far from the tool as from that end.
    fn arc_entry(
        &mut self,
        ccw: bool,
        center: [f64; 2],
        p: [f64; 2],
        tag: T,
    ) -> Result<(), CompError> {
        let (c, r) = (self.current, self.radius);
        if (p[0] - c[0]).hypot(p[1] - c[1]) <= r {
            return Err(CompError(
                "Radius of cutter compensation entry arc is not greater than the tool radius",
            ));
        }
        let turn = if ccw { 1 } else { -1 };
        let inside = self.inside(turn);
        let arc_radius = (center[0] - c[0]).hypot(center[1] - c[1]);
        if inside && arc_radius <= r {
            return Err(CompError(
                "Tool radius not less than arc radius with cutter radius compensation",
            ));
        }
        let gamma = if inside {
            (center[1] - p[1]).atan2(center[0] - p[0])
        } else {
            (p[1] - center[1]).atan2(p[0] - center[0])
        };
        let end = [p[0] + r * gamma.cos(), p[1] + r * gamma.sin()];
        let half = (c[1] - end[1]).hypot(c[0] - end[0]) / 2.0;
        let ab = (center[1] - end[1]).atan2(center[0] - end[0]);
        let a = (c[1] - end[1]).atan2(c[0] - end[0]) - ab;
        if a.cos().abs() < 1e-6 {
            return Err(CompError(
                "Tool radius not less than arc radius with cutter radius compensation",
            ));
        }
        let along = half / a.cos();
        let centre = [end[0] + along * ab.cos(), end[1] + along * ab.sin()];
        // LinuxCNC's default tolerance of an arc's two radii.
        let spiral = 2.0 * std::f64::consts::SQRT_2 * if self.mm { 0.01 } else { 0.001 };
        let r_end = (centre[0] - end[0]).hypot(centre[1] - end[1]);
        let r_start = (centre[0] - c[0]).hypot(centre[1] - c[1]);
        if (r_end - r_start).abs() > spiral {
            return Err(CompError(
                "the compensated entry arc's radii differ (rs274 stops here too)",
            ));
        }
        if !matches!(self.orientation, 0 | 9) {
            // A lathe tool's entry arc is preceded by a move of no length where the tool is.
            self.hold(straight(false, c, tag, false), [0.0, 0.0], 0.0);
            self.endpoint = Some(c);
        }
        let sweep = find_turn(c, centre, turn, end);
        self.hold(
            Piece {
                shape: Shape::Arc {
                    center: centre,
                    turn,
                },
                end,
                tag,
                corner: false,
            },
            [0.0, 0.0],
            sweep,
        );
        self.first = false;
        self.programmed = p;
        self.current = end;
        Ok(())
    }

    /// The tool runs inside an arc turning `turn` ways.
    fn inside(&self, turn: i32) -> bool {
        match self.side {
            Side::Left => turn > 0,
            Side::Right => turn < 0,
        }
    }

    /// A convex corner's arc turns against the side.
    fn corner_turn(&self) -> i32 {
        match self.side {
            Side::Left => -1,
            Side::Right => 1,
        }
    }

    /// The first held move, when an arc: its centre, turn and end.
    fn front_arc(&self) -> Option<([f64; 2], i32, [f64; 2])> {
        match self.held.first()?.piece {
            Piece {
                shape: Shape::Arc { center, turn },
                end,
                ..
            } => Some((center, turn, end)),
            _ => None,
        }
    }

    /// Where an offset arc (held) meets the offset of the line from `op` to `p`.
    fn arc_then_line(
        &self,
        center: [f64; 2],
        turn: i32,
        prev_end: [f64; 2],
        op: [f64; 2],
        p: [f64; 2],
    ) -> Result<[f64; 2], CompError> {
        let r = self.radius;
        let old = (center[1] - prev_end[1]).hypot(center[0] - prev_end[0]);
        let base = (p[1] - op[1]).atan2(p[0] - op[0]);
        let theta = if turn > 0 {
            base + FRAC_PI_2
        } else {
            base - FRAC_PI_2
        };
        let phi = (center[1] - op[1]).atan2(center[0] - op[0]);
        let inside = self.inside(turn);
        let uncomp = if inside { old + r } else { old - r };
        let d = uncomp * (theta - phi).cos();
        let l = (if inside { d - r } else { d + r }) / old;
        if !(-1.0..=1.0).contains(&l) {
            return Err(CompError(
                "Arc to straight motion makes a corner the compensated tool can't fit in without gouging",
            ));
        }
        let angle = if inside == (turn > 0) {
            -l.acos() + theta + PI
        } else {
            l.acos() + theta + PI
        };
        Ok([center[0] + old * angle.cos(), center[1] + old * angle.sin()])
    }

    fn hold(&mut self, piece: Piece<T>, dir: [f64; 2], sweep: f64) {
        self.held.push(Held { piece, dir, sweep });
    }

    /// The held moves go as they are.
    fn release(&mut self, out: &mut Vec<Piece<T>>) {
        out.extend(self.held.drain(..).map(|h| h.piece));
        self.endpoint = None;
    }

    /// The held moves end at `x` and go (LinuxCNC's `move_endpoint_and_flush`): refused
    /// when that turns a straight move back on itself or makes an arc longer than
    /// programmed (the tool cannot reach the corner without gouging).
    fn flush_to(&mut self, x: [f64; 2], out: &mut Vec<Piece<T>>) -> Result<(), CompError> {
        if self.held.is_empty() {
            return Ok(());
        }
        let slack = if self.mm { 0.0254 } else { 0.001 };
        for h in &mut self.held {
            match h.piece.shape {
                Shape::Arc { center, turn } => {
                    let e = h.piece.end;
                    let r1 = (e[0] - center[0]).hypot(e[1] - center[1]);
                    let r2 = (x[0] - center[0]).hypot(x[1] - center[1]);
                    if (r1 - r2).abs() > 0.01 {
                        return Err(CompError(
                            "cutter compensation made an arc whose radii differ (rs274 stops here too)",
                        ));
                    }
                    if let Some(start) = self.endpoint {
                        let l2 = find_turn(start, center, turn, x);
                        if h.sweep != 0.0 && l2.abs() > h.sweep.abs() + slack {
                            return Err(CompError(
                                "Arc move in concave corner cannot be reached by the tool without gouging",
                            ));
                        }
                    }
                }
                Shape::Straight { rapid } => {
                    if let Some(start) = self.endpoint {
                        let dot = h.dir[0] * (x[0] - start[0]) + h.dir[1] * (x[1] - start[1]);
                        if dot < 0.0 {
                            return Err(CompError(if rapid {
                                "Straight traverse in concave corner cannot be reached by the tool without gouging"
                            } else {
                                "Straight feed in concave corner cannot be reached by the tool without gouging"
                            }));
                        }
                    }
                }
            }
            h.piece.end = x;
        }
        self.release(out);
        self.endpoint = Some(x);
        Ok(())
    }
}

fn straight<T>(rapid: bool, end: [f64; 2], tag: T, corner: bool) -> Piece<T> {
    Piece {
        shape: Shape::Straight { rapid },
        end,
        tag,
        corner,
    }
}

/// The signed angle an arc from `s` to `e` about `c` sweeps, `turn` ways (LinuxCNC's
/// `find_turn`: counter-clockwise positive, a start and end at one angle a whole turn).
pub fn find_turn(s: [f64; 2], c: [f64; 2], turn: i32, e: [f64; 2]) -> f64 {
    if turn == 0 {
        return 0.0;
    }
    let mut a = (s[1] - c[1]).atan2(s[0] - c[0]);
    let mut b = (e[1] - c[1]).atan2(e[0] - c[0]);
    if turn > 0 {
        if b <= a {
            b += TAU;
        }
        b - a + f64::from(turn - 1) * TAU
    } else {
        if a <= b {
            a += TAU;
        }
        b - a + f64::from(turn + 1) * TAU
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(side: Side, r: f64, start: [f64; 2], path: &[[f64; 2]]) -> Vec<Piece<usize>> {
        let mut c = Comp::new(side, r, 0, true, start);
        let mut out = Vec::new();
        for (i, p) in path.iter().enumerate() {
            c.straight(false, *p, i, &mut out).expect("comp");
        }
        c.finish(&mut out).expect("finish");
        out
    }

    /// A square traced counter-clockwise with the tool on the left (inside), worked by
    /// hand: the entry ends square to itself, 1 left of (5, 0) at (4, 0); turning along
    /// +X from there is an outside corner (an arc about (5, 0) to (5, 1)); the square's
    /// corners are inside corners, met 1 in from each side.
    #[test]
    fn a_square_inside_by_hand() {
        let out = run(
            Side::Left,
            1.0,
            [5.0, -5.0],
            &[
                [5.0, 0.0],
                [10.0, 0.0],
                [10.0, 10.0],
                [0.0, 10.0],
                [0.0, 0.0],
            ],
        );
        let ends: Vec<_> = out.iter().map(|p| p.end).collect();
        let want = [
            [4.0, 0.0],
            [5.0, 1.0],
            [9.0, 1.0],
            [9.0, 9.0],
            [1.0, 9.0],
            [1.0, 0.0],
        ];
        assert_eq!(ends.len(), want.len(), "{ends:?}");
        for (g, w) in ends.iter().zip(want) {
            assert!(
                (g[0] - w[0]).abs() < 1e-12 && (g[1] - w[1]).abs() < 1e-12,
                "{ends:?}"
            );
        }
        assert_eq!(
            out.iter().map(|p| p.corner).collect::<Vec<_>>(),
            [false, true, false, false, false, false]
        );
        assert_eq!(
            out[1].shape,
            Shape::Arc {
                center: [5.0, 0.0],
                turn: -1
            }
        );
    }

    /// The same square on the right (outside), by hand: the entry ends 1 right of
    /// (5, 0), pulled back to (6, −1) where the offset of the +X side meets it (an inside
    /// corner); the square's corner gets an arc about (10, 0).
    #[test]
    fn a_square_outside_by_hand() {
        let out = run(
            Side::Right,
            1.0,
            [5.0, -5.0],
            &[[5.0, 0.0], [10.0, 0.0], [10.0, 10.0]],
        );
        let ends: Vec<_> = out.iter().map(|p| p.end).collect();
        let want = [[6.0, -1.0], [10.0, -1.0], [11.0, 0.0], [11.0, 10.0]];
        assert_eq!(ends.len(), want.len(), "{ends:?}");
        for (g, w) in ends.iter().zip(want) {
            assert!(
                (g[0] - w[0]).abs() < 1e-12 && (g[1] - w[1]).abs() < 1e-12,
                "{ends:?}"
            );
        }
        assert_eq!(
            out[2].shape,
            Shape::Arc {
                center: [10.0, 0.0],
                turn: 1
            }
        );
    }

    /// Distance from `p` to the segment `a`–`b`.
    fn to_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
        let d = [b[0] - a[0], b[1] - a[1]];
        let t = (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1]))
            .clamp(0.0, 1.0);
        (p[0] - a[0] - t * d[0]).hypot(p[1] - a[1] - t * d[1])
    }

    proptest::proptest! {
        /// Around a convex polygon (counter-clockwise, corners turning by at least 15°),
        /// entered from outside along the first corner's outward bisector, every point
        /// the tool is sent to after the entry lies the radius away from the polygon,
        /// outside it (G42) or inside it (G41) where the radius is small next to the
        /// sides; corner arcs only outside.
        #[test]
        fn compensated_points_are_the_radius_off_a_convex_path(
            n in 3usize..9,
            jitter in proptest::collection::vec(-0.25f64..0.25, 9),
            radii in proptest::collection::vec(20.0f64..40.0, 9),
            r in 0.1f64..2.0,
            outside in proptest::bool::ANY,
        ) {
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|i| {
                    let t = (i as f64 + jitter[i]) * TAU / n as f64;
                    [radii[i] * t.cos(), radii[i] * t.sin()]
                })
                .collect();
            // Convex, with no corner sharper than 15° of turn or flatter than 5°.
            for i in 0..n {
                let (a, b, c) = (pts[i], pts[(i + 1) % n], pts[(i + 2) % n]);
                let cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
                let turn = cross.atan2((b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1]));
                proptest::prop_assume!(turn > 0.09 && turn < 2.9);
            }
            let side = if outside { Side::Right } else { Side::Left };
            let start = [pts[0][0] * 2.0, pts[0][1] * 2.0];
            let mut path: Vec<[f64; 2]> = pts.clone();
            path.push(pts[0]);
            path.push(pts[1]);
            let mut c = Comp::new(side, r, 0, true, start);
            let mut out = Vec::new();
            for (i, p) in path.iter().enumerate() {
                c.straight(false, *p, i, &mut out).expect("convex path");
            }
            c.finish(&mut out).expect("finish");
            // After the entry's corner, and before the last move (let go where the
            // path stops, not met with a next side).
            let last = path.len() - 1;
            for piece in out.iter().filter(|p| p.tag >= 2 && p.tag < last) {
                let d = (0..n)
                    .map(|i| to_segment(piece.end, pts[i], pts[(i + 1) % n]))
                    .fold(f64::INFINITY, f64::min);
                proptest::prop_assert!((d - r).abs() < 1e-9, "{d} vs {r}: {piece:?}");
                proptest::prop_assert!(!piece.corner || outside);
            }
        }
    }

    #[test]
    fn refusals() {
        let mut c: Comp<()> = Comp::new(Side::Left, 1.0, 0, true, [0.0, 0.0]);
        let mut out = Vec::new();
        assert!(c.straight(false, [0.5, 0.0], (), &mut out).is_err());
        // A slot narrower than the tool: in, across 1 and back out gouges.
        let mut c: Comp<()> = Comp::new(Side::Left, 1.0, 0, true, [0.0, -5.0]);
        c.straight(false, [0.0, 0.0], (), &mut out).expect("entry");
        c.straight(false, [0.0, 10.0], (), &mut out).expect("up");
        c.straight(false, [-0.5, 10.0], (), &mut out)
            .expect("across");
        assert!(c.straight(false, [-0.5, 0.0], (), &mut out).is_err());
    }

    #[test]
    fn find_turn_by_hand() {
        let q = find_turn([1.0, 0.0], [0.0, 0.0], 1, [0.0, 1.0]);
        assert!((q - FRAC_PI_2).abs() < 1e-15);
        let q = find_turn([1.0, 0.0], [0.0, 0.0], -1, [0.0, 1.0]);
        assert!((q + 1.5 * PI).abs() < 1e-15);
        assert!((find_turn([1.0, 0.0], [0.0, 0.0], 1, [1.0, 0.0]) - TAU).abs() < 1e-15);
    }
}
