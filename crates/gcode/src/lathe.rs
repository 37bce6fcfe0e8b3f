//! LinuxCNC's lathe threading cycle G76, expanded into the moves rs274 makes of it.
//!
//! The cycle cuts a thread in passes along Z, each pass one spindle-synchronised feed
//! at a depth (in X) measured from the *drive line*, the X where the tool stands when
//! the cycle starts. As rs274ngc's `convert_threading_cycle` runs it (LinuxCNC 2.9):
//!
//! - the thread peaks are at `|I|` from the drive line (I < 0: an outside thread,
//!   cut towards −X; I > 0: an inside one, towards +X); the first pass cuts at depth
//!   `|I| + |J|`, pass `n` (from 2) at `|I| + |J| · n^(1/R)` (R, the degression, at
//!   least 1: R 1 keeps each pass's depth the same, R 2 its area), while the depth is
//!   less than `|I| + |K|`; then the full depth once, plus `H` spring passes;
//! - with a compound angle `Q` (degrees; rs274 reads `Q-1`, its mark for "no Q", as 0),
//!   pass `n` starts `(depth − |I|) · tan Q` back along Z, and every pass ends at
//!   `Z + |K| · tan Q` less that (the angle's sign flips when the thread runs towards
//!   +Z);
//! - a pass: a rapid out to the retract depth (the drive line, `|K|` outside the full
//!   depth's X) at its start Z, a rapid in to its depth, the synchronised cut to its
//!   end Z, a rapid out to the retract depth; with a taper `E` (> 0) at the entry
//!   (L 1 or 3) the way in is instead two synchronised moves, from the thread's crest
//!   down to the depth over `E` along Z, and at the exit (L 2 or 3) the cut ends with
//!   the mirror of that; tapered moves run at the pitch `P · hypot(E, |K|) / E`;
//! - the cycle ends with a rapid to the block's X, Y and Z.
//!
//! The number of passes is counted before any move is made, and bounded by
//! [`MAX_THREAD_PASSES`].

/// The most passes (cutting and spring passes together) one G76 block may make.
pub const MAX_THREAD_PASSES: u32 = 10_000;

/// The words of a G76 block, as read (absent words `None`).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Thread {
    /// P: the pitch (distance per spindle turn).
    pub p: Option<f64>,
    /// I: the thread peaks' offset from the drive line.
    pub i: Option<f64>,
    /// J: the first cut's depth beyond the peaks.
    pub j: Option<f64>,
    /// K: the full thread depth beyond the peaks.
    pub k: Option<f64>,
    /// Q: the compound slide angle, in degrees.
    pub q: Option<f64>,
    /// R: the depth degression.
    pub r: Option<f64>,
    /// H: the spring passes.
    pub h: Option<f64>,
    /// E: the taper's length along Z.
    pub e: Option<f64>,
    /// L: which ends are tapered (bit 0 the entry, bit 1 the exit).
    pub l: Option<f64>,
}

/// Why a G76 block cannot be expanded: the letter of the word at fault (`None`: the
/// block as a whole) and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ThreadError {
    pub letter: Option<u8>,
    pub why: String,
}

fn fault(letter: Option<u8>, why: impl Into<String>) -> ThreadError {
    ThreadError {
        letter,
        why: why.into(),
    }
}

/// One move of the expanded cycle: to `to` (X, Y, Z), a rapid (`pitch` `None`) or a
/// spindle-synchronised feed moving `pitch` along its path per spindle turn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ThreadMove {
    pub to: [f64; 3],
    pub pitch: Option<f64>,
}

/// RS274NGC's reading of an integer word (`read_integer_value`): within 0.0001 of a
/// whole number, which it is then taken as.
fn integer(letter: u8, v: f64) -> Result<f64, ThreadError> {
    let down = v.floor();
    if v - down > 0.9999 {
        Ok(v.ceil())
    } else if v - down > 0.0001 {
        Err(fault(
            Some(letter),
            format!("{} must be a whole number", char::from(letter)),
        ))
    } else {
        Ok(down)
    }
}

impl Thread {
    /// The moves of the cycle from `start` to the block's end `end` (X, Y, Z, in one
    /// frame), checked as rs274 checks the block, every coordinate finite.
    pub(crate) fn moves(
        &self,
        start: [f64; 3],
        end: [f64; 3],
    ) -> Result<Vec<ThreadMove>, ThreadError> {
        // rs274 marks a missing P with -1, so `P-1` reads as no P at all.
        let pitch = match self.p {
            Some(p) if p != -1.0 => p,
            _ => return Err(fault(None, "P (the pitch) is missing")),
        };
        if pitch <= 0.0 {
            return Err(fault(Some(b'P'), "the pitch P must be greater than 0"));
        }
        let (Some(i), Some(j), Some(k)) = (self.i, self.j, self.k) else {
            return Err(fault(
                None,
                "I (thread peak offset), J (first cut depth) and K (full thread depth) are all needed",
            ));
        };
        let spring = match self.h {
            Some(h) => integer(b'H', h)?,
            None => 0.0,
        };
        if spring < -1.0 {
            return Err(fault(Some(b'H'), "the spring passes H cannot be negative"));
        }
        let flags = match self.l {
            Some(l) => integer(b'L', l)?,
            None => 0.0,
        };
        if flags < 0.0 {
            return Err(fault(Some(b'L'), "the taper ends L cannot be negative"));
        }
        if i == 0.0 {
            return Err(fault(
                Some(b'I'),
                "I (the thread peaks' offset) must not be 0",
            ));
        }
        if j <= 0.0 {
            return Err(fault(
                Some(b'J'),
                "J (the first cut's depth) must be greater than 0",
            ));
        }
        if k <= j {
            return Err(fault(
                Some(b'K'),
                "K (the full thread depth) must be greater than J",
            ));
        }
        let boring = i > 0.0;
        let safe_x = start[0];
        let full_dia_depth = i.abs();
        let start_depth = i.abs() + j.abs();
        let cut_increment = j.abs();
        let full_thread = k.abs();
        let end_depth = k.abs() + i.abs();
        let mut angle = match self.q {
            Some(q) if q != -1.0 => q,
            _ => 0.0,
        };
        angle *= std::f64::consts::PI / 180.0;
        let forward = end[2] > start[2];
        if forward {
            angle = -angle;
        }
        let degression = match self.r {
            Some(r) if r >= 1.0 => r,
            _ => 1.0,
        };
        let mut taper = self.e.unwrap_or(0.0).max(0.0);
        let taper_pitch = if taper > 0.0 {
            pitch * taper.hypot(full_thread) / taper
        } else {
            pitch
        };
        if forward {
            taper = -taper;
        }
        // Bits of a whole number below 2^53; the flags' other bits do nothing.
        let entry = taper != 0.0 && flags % 2.0 == 1.0;
        let exit = taper != 0.0 && (flags / 2.0).floor() % 2.0 == 1.0;
        let tan = angle.tan();
        let target_z = end[2] + k.abs() * tan;

        // The passes at the full depth (H spring passes after the first; none for
        // H-1), then the cutting passes' depths, counted before any move is made.
        let spring_runs = spring + 1.0;
        if spring_runs > f64::from(MAX_THREAD_PASSES) {
            return Err(fault(
                Some(b'H'),
                format!("more than {MAX_THREAD_PASSES} passes: H asks for {spring} spring passes"),
            ));
        }
        let spring_runs = spring_runs as usize;
        let room = MAX_THREAD_PASSES as usize - spring_runs;
        let mut depths = Vec::new();
        let mut depth = start_depth;
        let mut pass = 1u32;
        while depth < end_depth {
            if depths.len() >= room {
                return Err(fault(
                    Some(b'J'),
                    format!(
                        "more than {MAX_THREAD_PASSES} passes (with {spring_runs} at the full depth): make J (the first cut) larger or R (the degression) smaller"
                    ),
                ));
            }
            depths.push(depth);
            pass += 1;
            depth = full_dia_depth + cut_increment * f64::from(pass).powf(1.0 / degression);
        }
        depths.extend(std::iter::repeat_n(end_depth, spring_runs));

        let [_, y, start_z] = start;
        let mut out = Vec::with_capacity(depths.len() * 6 + 1);
        let rapid = |out: &mut Vec<ThreadMove>, x: f64, z: f64| {
            out.push(ThreadMove {
                to: [x, y, z],
                pitch: None,
            })
        };
        let feed = |out: &mut Vec<ThreadMove>, x: f64, z: f64, p: f64| {
            out.push(ThreadMove {
                to: [x, y, z],
                pitch: Some(p),
            })
        };
        for depth in depths {
            let zoff = (depth - full_dia_depth) * tan;
            let (x_out, x_in, x_crest) = if boring {
                (
                    safe_x + depth - end_depth,
                    safe_x + depth,
                    safe_x + depth - full_thread,
                )
            } else {
                (
                    safe_x - depth + end_depth,
                    safe_x - depth,
                    safe_x - depth + full_thread,
                )
            };
            rapid(&mut out, x_out, start_z - zoff);
            if entry {
                feed(&mut out, x_crest, start_z - zoff, taper_pitch);
                feed(&mut out, x_in, start_z - zoff - taper, taper_pitch);
            } else {
                rapid(&mut out, x_in, start_z - zoff);
            }
            if exit {
                feed(&mut out, x_in, target_z - zoff + taper, pitch);
                feed(&mut out, x_crest, target_z - zoff, taper_pitch);
            } else {
                feed(&mut out, x_in, target_z - zoff, pitch);
            }
            rapid(&mut out, x_out, target_z - zoff);
        }
        out.push(ThreadMove {
            to: end,
            pitch: None,
        });
        let finite = |m: &ThreadMove| {
            m.to.iter().all(|v| v.is_finite()) && m.pitch.is_none_or(f64::is_finite)
        };
        if !out.iter().all(finite) {
            return Err(fault(
                None,
                "a pass would reach a position or pitch beyond any number (check Q, K and E)",
            ));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn thread(p: f64, i: f64, j: f64, k: f64) -> Thread {
        Thread {
            p: Some(p),
            i: Some(i),
            j: Some(j),
            k: Some(k),
            ..Thread::default()
        }
    }

    /// Within half a unit of rs274's fourth decimal.
    fn near(got: [f64; 2], want: [f64; 2]) -> bool {
        (got[0] - want[0]).abs() <= 0.5e-4 + 1e-12 && (got[1] - want[1]).abs() <= 0.5e-4 + 1e-12
    }

    #[test]
    fn constant_depth_passes() {
        // R 1: every pass J deeper (0.083, 0.091, … 0.115), then the full depth 0.12.
        let t = thread(0.05, -0.075, 0.008, 0.045);
        let m = t.moves([0.2, 0.0, 0.2], [0.2, 0.0, -0.5]).expect("runs");
        assert_eq!(m.len(), 6 * 4 + 1);
        let cuts: Vec<f64> = m
            .iter()
            .filter(|s| s.pitch.is_some())
            .map(|s| s.to[0])
            .collect();
        let want = [0.117, 0.109, 0.101, 0.093, 0.085, 0.08];
        for (c, w) in cuts.iter().zip(want) {
            assert!((c - w).abs() < 1e-12, "{cuts:?}");
        }
    }

    /// LinuxCNC's `nc_files/g76.ngc` (a 1/4-20 thread), as rs274 prints it: constant
    /// area (R2), a 29.5° compound angle, 3 spring passes, the exit tapered.
    #[test]
    fn g76_ngc_as_rs274_runs_it() {
        let t = Thread {
            q: Some(29.5),
            r: Some(2.0),
            h: Some(3.0),
            e: Some(0.05),
            l: Some(2.0),
            ..thread(0.05, -0.075, 0.008, 0.045)
        };
        let m = t.moves([0.2, 0.0, 0.2], [0.2, 0.0, -0.5]).expect("runs");
        // 31 cuts (0.075 + 0.008·√n below 0.12) and 4 at the full depth, 5 moves each.
        assert_eq!(m.len(), 35 * 5 + 1);
        let taper = 0.05 * 0.05f64.hypot(0.045) / 0.05;
        let want: [([f64; 2], Option<f64>); 10] = [
            ([0.2370, 0.1955], None),
            ([0.1170, 0.1955], None),
            ([0.1170, -0.4291], Some(0.05)),
            ([0.1620, -0.4791], Some(taper)),
            ([0.2370, -0.4791], None),
            ([0.2337, 0.1936], None),
            ([0.1137, 0.1936], None),
            ([0.1137, -0.4309], Some(0.05)),
            ([0.1587, -0.4809], Some(taper)),
            ([0.2337, -0.4809], None),
        ];
        for (got, (xz, pitch)) in m.iter().zip(want) {
            assert!(near([got.to[0], got.to[2]], xz), "{got:?} vs {xz:?}");
            assert_eq!(got.pitch, pitch);
        }
        assert!((taper - 0.067268).abs() < 0.5e-6);
        // The last pass's exit and the end.
        let tail: Vec<[f64; 2]> = m[m.len() - 3..]
            .iter()
            .map(|s| [s.to[0], s.to[2]])
            .collect();
        for (got, want) in tail.iter().zip([[0.1250, -0.5], [0.2, -0.5], [0.2, -0.5]]) {
            assert!(near(*got, want), "{tail:?}");
        }
    }

    /// An inside thread (I > 0) cut towards +Z with both ends tapered: depths go +X, the
    /// compound angle and the taper turn with the direction (rs274's numbers).
    #[test]
    fn inside_thread_towards_plus_z() {
        let t = Thread {
            q: Some(30.0),
            e: Some(1.0),
            l: Some(3.0),
            ..thread(1.5, 0.5, 0.3, 0.9)
        };
        let m = t.moves([10.0, 0.0, -20.0], [10.0, 0.0, 0.0]).expect("runs");
        // Depths 0.8, 0.5 + 0.3·2 = 1.1, then 1.4 (the full depth): 3 passes of 6.
        assert_eq!(m.len(), 3 * 6 + 1);
        let tan30 = (30.0f64).to_radians().tan();
        let first: Vec<[f64; 2]> = m[..6].iter().map(|s| [s.to[0], s.to[2]]).collect();
        // Back to 10 + 0.8 − 1.4, the crest 10 + 0.8 − 0.9, down the taper to the depth
        // 1 mm further (+Z), the cut to Z 0 − 0.9·tan 30° less the pass's offset, up.
        let zoff = -0.3 * tan30;
        let target = 0.0 - 0.9 * tan30;
        let want = [
            [9.4, -20.0 - zoff],
            [9.9, -20.0 - zoff],
            [10.8, -20.0 - zoff + 1.0],
            [10.8, target - zoff - 1.0],
            [9.9, target - zoff],
            [9.4, target - zoff],
        ];
        for (g, w) in first.iter().zip(want) {
            assert!(
                (g[0] - w[0]).abs() < 1e-12 && (g[1] - w[1]).abs() < 1e-12,
                "{first:?}"
            );
        }
    }

    /// The profile of the examples: from the start X12 Z2 to X5 Z0, along Z to Z-10, up
    /// to X10 Z-15 (points are Z, X).
    fn steps() -> Profile {
        let mut p = Profile::default();
        let pts = [(2.0, 12.0), (0.0, 5.0), (-10.0, 5.0), (-15.0, 10.0)];
        for w in pts.windows(2) {
            let (a, b) = (Pt::new(w[0].0, w[0].1), Pt::new(w[1].0, w[1].1));
            p.push_line(a, b).expect("room");
        }
        p
    }

    fn cycle(cycle: u16, sub: u16) -> ProfileCycle {
        ProfileCycle {
            cycle,
            sub,
            start: Pt::new(2.0, 12.0),
            d: 0.0,
            e: 0.0,
            i: 1.0,
            p: 1.0,
            r: 0.5,
            u: 0.0,
            w: 0.0,
        }
    }

    fn at(m: &ProfileMove) -> (bool, [f64; 2]) {
        match *m {
            ProfileMove::Rapid(p) => (true, [p.re, p.im]),
            ProfileMove::Feed(p) => (false, [p.re, p.im]),
            ProfileMove::Arc { to, .. } => (false, [to.re, to.im]),
        }
    }

    /// G70 P2 D1: a pass 0.5 out (X 5.5 along Z, the slope moved 0.5 along its normal:
    /// X + Z = -5 + 0.5·√2 meets X 5.5 at Z -9.7929), then the profile itself; each pass
    /// a rapid to the start and one to the profile's first point (rs274's numbers).
    #[test]
    fn g70_passes_hand_worked() {
        let c = ProfileCycle {
            d: 1.0,
            p: 2.0,
            ..cycle(70, 0)
        };
        let m = steps().moves(&c).expect("runs");
        let h = 0.5 / 2f64.sqrt();
        let want = [
            (true, [2.0, 12.0]),
            (true, [0.0, 5.5]),
            (false, [-10.5 + 2.0 * h, 5.5]),
            (false, [-15.0 + h, 10.0 + h]),
            (true, [2.0, 12.0]),
            (true, [0.0, 5.0]),
            (false, [-10.0, 5.0]),
            (false, [-15.0, 10.0]),
        ];
        assert_eq!(m.len(), want.len());
        for (got, (rapid, xz)) in m.iter().map(at).zip(want) {
            assert_eq!(got.0, rapid, "{m:?}");
            assert!(
                (got.1[0] - xz[0]).abs() < 1e-9 && (got.1[1] - xz[1]).abs() < 1e-9,
                "{m:?}"
            );
        }
        assert!((-10.5 + 2.0 * h + 9.7929).abs() < 0.5e-4);
    }

    /// G71 D0.5 I1 R0.3 (rs274's numbers): the first pass at X 12 feeds along -Z to the
    /// offset slope, retracts 0.3 in X and Z, goes back to the start Z less 0.3 and to
    /// the start; the next pass goes down the lead-in to X 11.
    #[test]
    fn g71_first_passes_as_rs274() {
        let c = ProfileCycle {
            d: 0.5,
            r: 0.3,
            ..cycle(71, 0)
        };
        let m = steps().moves(&c).expect("runs");
        let want = [
            (true, [2.0, 12.0]),
            (true, [2.0, 12.0]),
            (false, [-14.6464, 12.0]),
            (true, [-14.3464, 12.3]),
            (true, [1.7, 12.3]),
            (true, [2.0, 12.0]),
            (true, [1.6923, 11.0]),
            (false, [-14.6464, 11.0]),
        ];
        for (got, (rapid, xz)) in m.iter().map(at).zip(want) {
            assert_eq!(got.0, rapid, "{m:?}");
            assert!(
                (got.1[0] - xz[0]).abs() <= 0.5e-4 && (got.1[1] - xz[1]).abs() <= 0.5e-4,
                "{got:?} vs {xz:?}"
            );
        }
        // rs274 makes 40 moves of it (after its own rapid to the start), ending up the
        // offset slope and along it to the start's X.
        assert_eq!(m.len(), 40);
        let last = at(&m[m.len() - 1]).1;
        assert!((last[0] + 14.6464).abs() <= 0.5e-4 && (last[1] - 12.0).abs() < 1e-9);
    }

    #[test]
    fn profile_refusals() {
        let run = |p: Profile, c: ProfileCycle| p.moves(&c).err().map(|e| e.0);
        // Back along Z.
        let mut back = steps();
        back.push_line(Pt::new(-15.0, 10.0), Pt::new(-12.0, 11.0))
            .expect("room");
        assert_eq!(run(back, cycle(71, 0)).as_deref(), Some("Not monotonic"));
        // Two pieces in one line: their offsets never meet.
        let mut p = Profile::default();
        for (a, b) in [
            ((2.0, 12.0), (0.0, 5.0)),
            ((0.0, 5.0), (-5.0, 5.0)),
            ((-5.0, 5.0), (-10.0, 5.0)),
        ] {
            p.push_line(Pt::new(a.0, a.1), Pt::new(b.0, b.1))
                .expect("room");
        }
        let c = ProfileCycle {
            d: 0.5,
            ..cycle(71, 0)
        };
        assert_eq!(
            run(p, c).as_deref(),
            Some("Cannot intersect parallel lines")
        );
        let c = ProfileCycle {
            i: 0.0,
            ..cycle(71, 0)
        };
        assert_eq!(
            run(steps(), c).as_deref(),
            Some("I must be greater than zero.")
        );
        // A lone lead-in: nothing to cut, no move (as rs274).
        let mut lone = Profile::default();
        lone.push_line(Pt::new(2.0, 12.0), Pt::new(0.0, 5.0))
            .expect("room");
        assert_eq!(lone.moves(&cycle(70, 0)).map(|m| m.len()), Ok(0));
    }

    #[test]
    fn refusals_name_their_word() {
        let ok = thread(1.0, -1.0, 0.1, 0.5);
        let at = |t: Thread| {
            t.moves([5.0, 0.0, 0.0], [5.0, 0.0, -10.0])
                .err()
                .map(|e| e.letter)
        };
        assert_eq!(at(ok), None);
        assert_eq!(at(Thread { p: None, ..ok }), Some(None));
        assert_eq!(
            at(Thread {
                p: Some(-1.0),
                ..ok
            }),
            Some(None)
        );
        assert_eq!(at(Thread { p: Some(0.0), ..ok }), Some(Some(b'P')));
        assert_eq!(at(Thread { k: None, ..ok }), Some(None));
        assert_eq!(at(Thread { i: Some(0.0), ..ok }), Some(Some(b'I')));
        assert_eq!(
            at(Thread {
                j: Some(-0.1),
                ..ok
            }),
            Some(Some(b'J'))
        );
        assert_eq!(at(Thread { k: Some(0.1), ..ok }), Some(Some(b'K')));
        assert_eq!(at(Thread { h: Some(0.5), ..ok }), Some(Some(b'H')));
        assert_eq!(
            at(Thread {
                h: Some(-2.0),
                ..ok
            }),
            Some(Some(b'H'))
        );
        assert_eq!(
            at(Thread {
                l: Some(-1.0),
                ..ok
            }),
            Some(Some(b'L'))
        );
        // Within 0.0001 of a whole number is that number (rs274's integer words).
        assert_eq!(
            at(Thread {
                h: Some(2.99995),
                l: Some(1.00004),
                ..ok
            }),
            None
        );
        // A compound angle whose tangent is beyond any number leaves no finite position.
        let huge = Thread {
            q: Some(89.999_999_999),
            j: Some(5e299),
            k: Some(1e300),
            ..ok
        };
        assert_eq!(at(huge), Some(None));
    }
}

// ---------------------------------------------------------------------------------------
// G70, G71, G72: LinuxCNC's lathe finishing and roughing cycles along a profile.
// ---------------------------------------------------------------------------------------

/// The most passes one G70 block (its P), or one G71/G72 block (roughing steps of I down
/// the profile), may make.
pub const MAX_PROFILE_PASSES: u64 = 10_000;

/// The most segments a profile may hold (its subroutine's moves, fillets and chamfers).
pub const MAX_PROFILE_SEGMENTS: usize = 10_000;

/// The most moves one G70, G71 or G72 block may make (all its passes together): the
/// block's moves are held until the next line is read.
pub const MAX_PROFILE_MOVES: usize = 100_000;

/// Steps of the offset and pocket searches one block may take before it is refused (a
/// bound on the work, far above what the passes above need).
const MAX_PROFILE_STEPS: u64 = 10_000_000;

/// rs274's closeness for points on the profile.
const TOL: f64 = 1e-6;

/// A point of the XZ plane as rs274's cycles hold it: `re` is Z, `im` is X.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Pt {
    pub re: f64,
    pub im: f64,
}

impl Pt {
    pub(crate) const fn new(re: f64, im: f64) -> Pt {
        Pt { re, im }
    }
    fn add(self, o: Pt) -> Pt {
        Pt::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: Pt) -> Pt {
        Pt::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: Pt) -> Pt {
        Pt::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    /// Complex division as rs274's build does it (libgcc's `__divdc3`, Smith's method),
    /// so that nearly tangent intersections round as rs274's do.
    fn div(self, o: Pt) -> Pt {
        let (a, b, c, d) = (self.re, self.im, o.re, o.im);
        if c.abs() < d.abs() {
            let ratio = c / d;
            let denom = c * ratio + d;
            Pt::new((a * ratio + b) / denom, (b * ratio - a) / denom)
        } else {
            let ratio = d / c;
            let denom = d * ratio + c;
            Pt::new((b * ratio + a) / denom, (b - a * ratio) / denom)
        }
    }
    /// Each part divided by `k`.
    fn divr(self, k: f64) -> Pt {
        Pt::new(self.re / k, self.im / k)
    }
    fn scale(self, k: f64) -> Pt {
        Pt::new(self.re * k, self.im * k)
    }
    fn conj(self) -> Pt {
        Pt::new(self.re, -self.im)
    }
    fn neg(self) -> Pt {
        Pt::new(-self.re, -self.im)
    }
    /// Times i.
    fn turn(self) -> Pt {
        Pt::new(-self.im, self.re)
    }
    fn norm(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }
    fn finite(self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
}

/// What a profile's piece is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Shape {
    Line,
    /// An arc about `center`, counter-clockwise (G3 in Z-X as rs274 reads it) or not.
    Arc {
        ccw: bool,
        center: Pt,
    },
}

/// What a corner piece (A: a fillet, C: a chamfer) still has to become.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Corner {
    None,
    Fillet,
    Chamfer,
}

/// One piece of a profile.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Seg {
    shape: Shape,
    start: Pt,
    end: Pt,
    /// A corner's size (fillet radius, chamfer length) until it is made.
    finish: f64,
    corner: Corner,
}

/// A move of an expanded profile cycle: to `to` (Z, X as [`Pt`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ProfileMove {
    Rapid(Pt),
    Feed(Pt),
    Arc { ccw: bool, center: Pt, to: Pt },
}

/// Why a profile cycle cannot be expanded (rs274's words where it has them).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ProfileError(pub String);

fn perr(why: impl Into<String>) -> ProfileError {
    ProfileError(why.into())
}

fn too_many_moves() -> ProfileError {
    perr(format!(
        "more than {MAX_PROFILE_MOVES} moves: fewer passes (P), a larger depth of cut (I), or a simpler profile"
    ))
}

impl Seg {
    fn line(start: Pt, end: Pt) -> Seg {
        Seg {
            shape: Shape::Line,
            start,
            end,
            finish: 0.0,
            corner: Corner::None,
        }
    }
    fn arc(ccw: bool, start: Pt, center: Pt, end: Pt) -> Seg {
        Seg {
            shape: Shape::Arc { ccw, center },
            start,
            end,
            finish: 0.0,
            corner: Corner::None,
        }
    }

    fn radius(&self) -> f64 {
        match self.shape {
            Shape::Line => self.start.sub(self.end).abs(),
            Shape::Arc { center, .. } => self
                .start
                .sub(self.end)
                .abs()
                .min(self.start.sub(center).abs()),
        }
    }

    fn monotonic(&self) -> bool {
        match self.shape {
            Shape::Line => self.end.re - self.start.re <= 1e-3,
            Shape::Arc { ccw, center } => {
                if self.finish != 0.0 {
                    return true;
                }
                let entry = self.start.im - center.im;
                let exit = self.end.im - center.im;
                let dz = self.end.re - self.start.re;
                if ccw {
                    entry >= -1e-3 && exit >= -1e-3 && dz <= -1e-3
                } else {
                    entry <= 1e-3 && exit <= 1e-3 && dz <= -1e-3
                }
            }
        }
    }

    /// Apply `f` to every point; `mirror` when it reverses the sense of arcs.
    fn map(&mut self, f: impl Fn(Pt) -> Pt, mirror: bool) {
        self.start = f(self.start);
        self.end = f(self.end);
        if let Shape::Arc { ccw, center } = self.shape {
            self.shape = Shape::Arc {
                ccw: ccw != mirror,
                center: f(center),
            };
        }
    }
    fn flip_imag(&mut self) {
        self.map(Pt::conj, true);
    }
    fn flip_real(&mut self) {
        self.map(|p| p.conj().neg(), true);
    }
    fn rotate(&mut self) {
        self.map(|p| p.turn().neg(), false);
    }
    fn shift(&mut self, d: Pt) {
        self.map(|p| p.add(d), false);
    }

    fn offset(&mut self, distance: f64) {
        match self.shape {
            Shape::Line => {
                let v = self.start.sub(self.end);
                let d = Pt::new(-(distance * v.im), distance * v.re).divr(v.abs());
                self.start = self.start.add(d);
                self.end = self.end.add(d);
            }
            Shape::Arc { ccw, center } => {
                let r = self.start.sub(center).abs();
                let factor = (r + if ccw { distance } else { -distance }) / r;
                self.start = self.start.sub(center).scale(factor).add(center);
                self.end = self.end.sub(center).scale(factor).add(center);
            }
        }
    }

    fn on_arc(&self, ccw: bool, center: Pt, p: Pt) -> bool {
        let a = self.start.sub(center).conj().mul(p.sub(center)).im;
        let b = self.end.sub(center).conj().mul(p.sub(center)).im;
        if ccw {
            a >= -TOL && b <= TOL
        } else {
            a <= TOL && b >= -TOL
        }
    }

    /// The Z of the points where the piece meets the line X = `x`.
    fn intersection_z(&self, x: f64, is: &mut Vec<f64>) {
        is.clear();
        match self.shape {
            Shape::Line => {
                let (s, e) = (self.start, self.end);
                if s.im.min(e.im) > x + TOL || s.im.max(e.im) < x - TOL {
                    return;
                }
                if (s.im - e.im).abs() < TOL {
                    is.push(s.re);
                    is.push(e.re);
                } else {
                    is.push((x - s.im) / (e.im - s.im) * (e.re - s.re) + s.re);
                }
            }
            Shape::Arc { ccw, center } => {
                let r = self.start.sub(center).abs();
                let mut s = -(x - r - center.im) * (x + r - center.im);
                if s < -TOL {
                    return;
                }
                if s < 0.0 {
                    s = 0.0;
                }
                let s = s.sqrt();
                let p1 = Pt::new(center.re + s, x);
                if self.on_arc(ccw, center, p1) {
                    is.push(p1.re);
                }
                let p2 = Pt::new(center.re - s, x);
                if self.on_arc(ccw, center, p2) {
                    is.push(p2.re);
                }
            }
        }
    }

    fn draw(&self, out: &mut Sink) {
        match self.shape {
            Shape::Line => out.feed(self.end),
            Shape::Arc { ccw, center } => out.arc(ccw, center, self.end),
        }
    }

    /// Follow the piece up from `loc` when it climbs; true when it does not.
    fn climb(&self, loc: &mut Pt, out: &mut Sink) -> Result<bool, ProfileError> {
        match self.shape {
            Shape::Line => {
                if self.end.im + TOL < self.start.im {
                    return Ok(true);
                }
                if loc.sub(self.start).abs() > TOL {
                    return Err(perr("How did we get here?"));
                }
                out.feed(self.end);
                *loc = self.end;
                Ok(false)
            }
            Shape::Arc { ccw: false, center } => {
                if loc.re > center.re {
                    return Ok(true);
                }
                if loc.sub(self.end).abs() > 1e-3 {
                    out.arc(false, center, self.end);
                }
                *loc = self.end;
                Ok(false)
            }
            Shape::Arc { ccw: true, center } => {
                if loc.re < center.re {
                    return Ok(true);
                }
                let ep = self.top(center);
                if loc.sub(ep).abs() > 1e-3 {
                    out.arc(true, center, ep);
                }
                *loc = ep;
                Ok(true)
            }
        }
    }

    /// A G3 piece's end, or its top when it goes on over it.
    fn top(&self, center: Pt) -> Pt {
        if self.end.re < center.re {
            Pt::new(center.re, center.im + self.start.sub(center).abs())
        } else {
            self.end
        }
    }

    /// The climbing part of the piece from the height of `loc`, after the last pass.
    fn climb_only(&self, loc: &mut Pt, out: &mut Sink, is: &mut Vec<f64>) {
        match self.shape {
            Shape::Line => {
                if self.end.im < self.start.im {
                    return;
                }
                self.intersection_z(loc.im, is);
                let Some(&z) = is.first() else {
                    return;
                };
                loc.re = z;
                out.feed(*loc);
                out.feed(self.end);
                *loc = self.end;
            }
            Shape::Arc { ccw, center } => {
                self.intersection_z(loc.im, is);
                if is.is_empty() {
                    return;
                }
                if !ccw {
                    let z = is[is.len() - 1];
                    if z > center.re {
                        return;
                    }
                    loc.re = z;
                    out.feed(*loc);
                    if loc.sub(self.end).abs() > 1e-3 {
                        out.arc(false, center, self.end);
                    }
                    *loc = self.end;
                } else {
                    let z = is[0];
                    if z < center.re {
                        return;
                    }
                    loc.re = z;
                    out.feed(*loc);
                    let ep = self.top(center);
                    if loc.sub(ep).abs() > 1e-3 {
                        out.arc(true, center, ep);
                    }
                    *loc = ep;
                }
            }
        }
    }

    /// Follow the piece down from `loc` to the height `x`; true when it does not dive.
    fn dive(
        &self,
        loc: &mut Pt,
        x: f64,
        out: &mut Sink,
        fast: bool,
        is: &mut Vec<f64>,
    ) -> Result<bool, ProfileError> {
        match self.shape {
            Shape::Line => {
                if self.start.im <= self.end.im + TOL {
                    return Ok(true);
                }
                let ep = if x < self.end.im {
                    self.end
                } else {
                    self.intersection_z(x, is);
                    let Some(&z) = is.first() else {
                        return Err(perr("x too large in straight dive"));
                    };
                    Pt::new(z, x)
                };
                if fast {
                    out.rapid(ep);
                } else {
                    out.feed(ep);
                }
                *loc = ep;
                Ok(false)
            }
            Shape::Arc { ccw, center } => {
                if loc.sub(self.end).abs() < TOL || loc.re - self.end.re <= TOL {
                    *loc = self.end;
                    return Ok(false);
                }
                self.intersection_z(x, is);
                if is.is_empty() {
                    self.intersection_z(x - TOL, is);
                }
                if ccw {
                    if loc.re - TOL > center.re {
                        return Ok(true);
                    }
                    match is.last() {
                        Some(&z) if z <= center.re => {
                            let ep = Pt::new(z, x);
                            out.arc(true, center, ep);
                            *loc = ep;
                        }
                        _ => {
                            out.arc(true, center, self.end);
                            *loc = self.end;
                        }
                    }
                    Ok(false)
                } else {
                    if loc.re <= center.re {
                        return Ok(true);
                    }
                    match is.first() {
                        None => {
                            out.arc(false, center, self.end);
                            *loc = self.end;
                        }
                        Some(&z) if z < center.re => {}
                        Some(&z) => {
                            let ep = Pt::new(z, x);
                            out.arc(false, center, ep);
                            *loc = ep;
                        }
                    }
                    Ok(false)
                }
            }
        }
    }
}

/// Where the end of `p` meets the start of `n` (both moved there), as rs274 finds it.
fn intersect(p: &mut Seg, n: &mut Seg) -> Result<(), ProfileError> {
    match (p.shape, n.shape) {
        (Shape::Line, Shape::Line) => {
            let d = n.start.sub(n.end);
            let rot = d.conj().divr(d.abs());
            let ps = p.start.sub(n.end).mul(rot);
            let pe = p.end.sub(n.end).mul(rot);
            if ps.sub(pe).im == 0.0 {
                return Err(perr("Cannot intersect parallel lines"));
            }
            let f = ps.im / ps.sub(pe).im;
            let is = ps.add(pe.sub(ps).scale(f)).div(rot).add(n.end);
            n.start = is;
            p.end = is;
        }
        (Shape::Arc { center, .. }, Shape::Line) => {
            if n.start.sub(p.end).abs() < TOL {
                return Ok(());
            }
            let d = n.start.sub(n.end);
            let rot = d.conj().divr(d.abs());
            let pe = p.end.sub(n.end).mul(rot);
            let pc = center.sub(n.end).mul(rot);
            let is = closer(n.start, pc, pe, rot, n.end);
            n.start = is;
            p.end = is;
        }
        (Shape::Line, Shape::Arc { center, .. }) => {
            if n.start.sub(p.end).abs() < TOL {
                return Ok(());
            }
            let d = p.start.sub(p.end);
            let rot = d.conj().divr(d.abs());
            let pe = n.end.sub(p.end).mul(rot);
            let pc = center.sub(p.end).mul(rot);
            let is = closer(n.start, pc, pe, rot, p.end);
            n.start = is;
            p.end = is;
        }
        (Shape::Arc { center: pcen, .. }, Shape::Arc { center: ncen, .. }) => {
            let a = n.start.sub(ncen).abs();
            let b = p.start.sub(pcen).abs();
            let c = ncen.sub(pcen).abs();
            let cos_b = (c * c + a * a - b * b) / 2.0 / a / c;
            let cos_b2 = (cos_b * cos_b).min(1.0);
            let rot = Pt::new(cos_b, (1.0 - cos_b2).sqrt());
            let is = rot.mul(pcen.sub(ncen)).divr(c).scale(a).add(ncen);
            p.end = is;
            n.start = is;
        }
    }
    Ok(())
}

/// Of the two points where a line (rotated onto the real axis by `rot` about `origin`)
/// meets a circle (centre `pc`, through `pe`, both rotated), the one closer to `near`.
fn closer(near: Pt, pc: Pt, pe: Pt, rot: Pt, origin: Pt) -> Pt {
    let b = pc.sub(pe).norm() - pc.im * pc.im;
    let b = if b < 0.0 { 0.0 } else { b.sqrt() };
    let s1 = Pt::new(pc.re + b, 0.0).div(rot).add(origin);
    let s2 = Pt::new(pc.re - b, 0.0).div(rot).add(origin);
    if near.sub(s1).abs() < near.sub(s2).abs() {
        s1
    } else {
        s2
    }
}

/// The moves of a cycle, turned back from the profile's working orientation.
struct Sink {
    flip: u8,
    moves: Vec<ProfileMove>,
}

impl Sink {
    fn back(&self, p: Pt) -> Pt {
        match self.flip {
            0 => p,
            1 => p.conj().neg(),
            2 => p.conj(),
            3 => p.neg(),
            4 => p.turn(),
            5 => p.turn().conj(),
            6 => p.turn().conj().neg(),
            _ => p.turn().neg(),
        }
    }
    fn mirrors(&self) -> bool {
        matches!(self.flip, 1 | 2 | 5 | 6)
    }
    fn rapid(&mut self, p: Pt) {
        let p = self.back(p);
        self.moves.push(ProfileMove::Rapid(p));
    }
    fn feed(&mut self, p: Pt) {
        let p = self.back(p);
        self.moves.push(ProfileMove::Feed(p));
    }
    fn arc(&mut self, ccw: bool, center: Pt, to: Pt) {
        let m = ProfileMove::Arc {
            ccw: ccw != self.mirrors(),
            center: self.back(center),
            to: self.back(to),
        };
        self.moves.push(m);
    }
}

/// A profile recorded from a cycle's subroutine: the segment from the cycle's start to
/// the sub's first point, then the sub's moves, fillets and chamfers.
#[derive(Debug, Clone, Default)]
pub(crate) struct Profile {
    segs: Vec<Seg>,
    flip: u8,
    steps: u64,
}

/// Which cycle, and its words (rs274's defaults where absent).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ProfileCycle {
    /// 70 (finishing), 71 or 72 (roughing along Z or X).
    pub cycle: u16,
    /// 0: the whole roughing; 1: no pockets; 2: only the pockets after the first.
    pub sub: u16,
    /// The cycle's start (the block's Z and X).
    pub start: Pt,
    pub d: f64,
    pub e: f64,
    pub i: f64,
    pub p: f64,
    pub r: f64,
    pub u: f64,
    pub w: f64,
}

impl Profile {
    /// Add a straight piece (nothing when it has no length).
    pub(crate) fn push_line(&mut self, start: Pt, end: Pt) -> Result<(), ProfileError> {
        self.room()?;
        self.segs.push(Seg::line(start, end));
        Ok(())
    }

    /// Add an arc about `center`.
    pub(crate) fn push_arc(
        &mut self,
        ccw: bool,
        start: Pt,
        center: Pt,
        end: Pt,
    ) -> Result<(), ProfileError> {
        self.room()?;
        self.segs.push(Seg::arc(ccw, start, center, end));
        Ok(())
    }

    /// Add a corner at `at`: a fillet of radius `size` (A) or a chamfer (C).
    pub(crate) fn push_corner(
        &mut self,
        fillet: bool,
        size: f64,
        at: Pt,
    ) -> Result<(), ProfileError> {
        self.room()?;
        let mut s = if fillet {
            Seg::arc(false, at, at, at)
        } else {
            Seg::line(at, at)
        };
        s.finish = size;
        s.corner = if fillet {
            Corner::Fillet
        } else {
            Corner::Chamfer
        };
        self.segs.push(s);
        Ok(())
    }

    fn room(&self) -> Result<(), ProfileError> {
        if self.segs.len() >= MAX_PROFILE_SEGMENTS {
            return Err(perr(format!(
                "the profile has more than {MAX_PROFILE_SEGMENTS} pieces"
            )));
        }
        Ok(())
    }

    fn step(&mut self) -> Result<(), ProfileError> {
        self.steps += 1;
        if self.steps > MAX_PROFILE_STEPS {
            return Err(perr(format!(
                "more than {MAX_PROFILE_STEPS} steps working out the passes (a profile or an offset D far too fine for its size?)"
            )));
        }
        Ok(())
    }

    /// A step of the pocket search, with the moves made so far bounded.
    fn guard(&mut self, out: &Sink) -> Result<(), ProfileError> {
        if out.moves.len() > MAX_PROFILE_MOVES {
            return Err(too_many_moves());
        }
        self.step()
    }

    fn rotate(&mut self) {
        for s in &mut self.segs {
            s.rotate();
        }
        self.flip ^= 4;
    }

    /// Turn the profile so that X and Z both decrease along it.
    fn swap(&mut self) {
        let (Some(f), Some(b)) = (self.segs.first(), self.segs.last()) else {
            return;
        };
        let dir = f.end.sub(b.end);
        if dir.im > 0.0 {
            for s in &mut self.segs {
                s.flip_imag();
            }
            self.flip ^= 2;
        }
        if dir.re < 0.0 {
            for s in &mut self.segs {
                s.flip_real();
            }
            self.flip ^= 1;
        }
    }

    fn monotonic(&mut self) -> Result<(), ProfileError> {
        if let Some(f) = self.segs.first_mut() {
            if f.end.re - f.start.re > 0.0 {
                f.start.re = f.end.re;
            }
        }
        if self.segs.iter().all(Seg::monotonic) {
            Ok(())
        } else {
            Err(perr("Not monotonic"))
        }
    }

    /// Make the fillets and chamfers at their corners; drop pieces shorter than 1e-3.
    fn do_finish(&mut self) -> Result<(), ProfileError> {
        let n = self.segs.len();
        for h in 1..n.saturating_sub(1) {
            let corner = self.segs[h].corner;
            if corner == Corner::None || self.segs[h].finish == 0.0 {
                continue;
            }
            let (prev, next) = (self.segs[h - 1], self.segs[h + 1]);
            let mut finish = self.segs[h].finish;
            let shifted = |f: f64| -> (Seg, Seg) {
                let (mut p, mut n) = (prev, next);
                p.offset(f);
                n.offset(f);
                (p, n)
            };
            let (mut p, mut q) = shifted(finish);
            if p.end.re - q.start.re > 1e-2 {
                finish = -finish;
                (p, q) = shifted(finish);
            }
            if p.end.re - q.start.re > 1e-2 {
                return Err(perr(format!(
                    "Corner finish failed at ({},{})",
                    prev.end.re, prev.end.im
                )));
            }
            intersect(&mut p, &mut q)?;
            let center = p.end.add(q.start).scale(0.5);
            p.offset(-finish);
            q.offset(-finish);
            self.segs[h - 1].end = p.end;
            self.segs[h + 1].start = q.start;
            let s = &mut self.segs[h];
            s.start = p.end;
            s.end = q.start;
            match corner {
                Corner::Fillet => {
                    let ccw = s.start.im - center.im > 0.0 || s.end.im - center.im > 0.0;
                    s.shape = Shape::Arc { ccw, center };
                    s.finish = 0.0;
                }
                _ => s.finish = finish,
            }
            s.corner = Corner::None;
        }
        self.segs.retain(|s| s.radius() >= 1e-3);
        Ok(())
    }

    /// Offset the profile by `distance` (away from the stock side), arcs added at the
    /// corners that open up, in steps of at most half the shortest piece.
    fn add_distance(&mut self, distance: f64) -> Result<(), ProfileError> {
        if self.segs.len() < 2 {
            return Err(perr("the profile is too short to offset"));
        }
        let first = self.segs[0];
        let last = self.segs[self.segs.len() - 1];
        let v1 = first.end.sub(first.start);
        let v2 = last.start.sub(first.start);
        let mut distance = distance;
        if v1.div(v2).im < 0.0 {
            distance = -distance;
        }
        let lead = self.segs.remove(0);
        let mut current = 0.0;
        while current != distance {
            self.step()?;
            if self.segs.is_empty() {
                return Err(perr("the offset profile vanished"));
            }
            let mut step = self
                .segs
                .iter()
                .map(|s| s.radius() / 2.0)
                .fold(1e9, f64::min);
            step = step.min((distance - current).abs());
            if distance < 0.0 {
                step = -step;
            }
            if !step.is_finite() || step == 0.0 && current != distance {
                return Err(perr("the offset does not progress"));
            }
            let mut k = 0;
            while k < self.segs.len() {
                self.step()?;
                self.segs[k].offset(step);
                if self.segs[k].radius() < 1e-3 {
                    self.segs.remove(k);
                } else {
                    k += 1;
                }
            }
            let mut k = 0;
            while k + 1 < self.segs.len() {
                let (p, n) = (self.segs[k], self.segs[k + 1]);
                if p.end.re - n.start.re > 1e-2 {
                    self.room()?;
                    let (mut s, mut e) = (p, n);
                    s.offset(-step);
                    e.offset(-step);
                    let center = s.end.add(e.start).scale(0.5);
                    self.segs
                        .insert(k + 1, Seg::arc(distance > 0.0, p.end, center, n.start));
                    k += 1;
                }
                k += 1;
            }
            let mut k = 0;
            while k + 1 < self.segs.len() {
                self.step()?;
                if !self.segs[k].monotonic() {
                    if k == 0 {
                        // rs274 reads before its list here (and dies).
                        return Err(perr(
                            "Not monotonic (the offset profile turns back at its first piece)",
                        ));
                    }
                    if self.segs[k].radius() < self.segs[k - 1].radius() {
                        self.segs.remove(k);
                    } else {
                        self.segs.remove(k - 1);
                    }
                    k = 0;
                    if self.segs.len() < 2 {
                        break;
                    }
                }
                if self.segs[k].radius() < 1e-3 {
                    self.segs.remove(k);
                    k = 0;
                } else {
                    let (a, b) = self.segs.split_at_mut(k + 1);
                    intersect(&mut a[k], &mut b[0])?;
                }
                k += 1;
            }
            current += step;
        }
        for k in 0..self.segs.len().saturating_sub(1) {
            let mid = self.segs[k].end.add(self.segs[k + 1].start).scale(0.5);
            self.segs[k].end = mid;
            self.segs[k + 1].start = mid;
        }
        let mut lead = lead;
        match self.segs.first() {
            Some(f) => lead.end = f.start,
            None => return Err(perr("the offset profile vanished")),
        }
        self.segs.insert(0, lead);
        Ok(())
    }

    /// The moves of the cycle (Z, X as [`Pt`]), every coordinate finite.
    pub(crate) fn moves(mut self, c: &ProfileCycle) -> Result<Vec<ProfileMove>, ProfileError> {
        if self.segs.len() <= 1 {
            return Ok(Vec::new());
        }
        if c.i.is_nan() || c.i <= 0.0 {
            return Err(perr("I must be greater than zero."));
        }
        let moves = match c.cycle {
            70 => self.finishing(c)?,
            _ => self.roughing(c)?,
        };
        let finite = |m: &ProfileMove| match *m {
            ProfileMove::Rapid(p) | ProfileMove::Feed(p) => p.finite(),
            ProfileMove::Arc { center, to, .. } => center.finite() && to.finite(),
        };
        if !moves.iter().all(finite) {
            return Err(perr("a pass would reach a position beyond any number"));
        }
        Ok(moves)
    }

    fn finishing(&mut self, c: &ProfileCycle) -> Result<Vec<ProfileMove>, ProfileError> {
        self.segs[0].start = c.start;
        let mut path = self.clone();
        path.segs.remove(0);
        path.swap();
        if !path.segs.iter().all(Seg::monotonic) {
            path.rotate();
            path.swap();
        }
        path.monotonic()?;
        if path.flip & 4 != 0 {
            self.rotate();
        }
        self.swap();
        self.do_finish()?;
        self.monotonic()?;
        // rs274 counts the passes as a whole number (P truncated), spreads them by P.
        let passes = c.p.trunc();
        if passes > MAX_PROFILE_PASSES as f64 {
            return Err(perr(format!(
                "more than {MAX_PROFILE_PASSES} finishing passes (P)"
            )));
        }
        let passes = if passes >= 1.0 { passes as u64 } else { 0 };
        let mut out = Sink {
            flip: self.flip,
            moves: Vec::new(),
        };
        for pass in (1..=passes).rev() {
            let distance = (pass as f64 - 1.0) * (c.d - c.e) / c.p + c.e;
            let mut path = self.clone();
            path.add_distance(distance)?;
            self.steps = path.steps;
            if out.moves.len() + path.segs.len() + 1 > MAX_PROFILE_MOVES {
                return Err(too_many_moves());
            }
            out.rapid(path.segs[0].start);
            out.rapid(path.segs[0].end);
            for s in &path.segs[1..] {
                s.draw(&mut out);
            }
        }
        Ok(out.moves)
    }

    fn roughing(&mut self, c: &ProfileCycle) -> Result<Vec<ProfileMove>, ProfileError> {
        self.segs[0].start = c.start;
        if c.cycle == 72 {
            self.rotate();
        }
        self.swap();
        self.do_finish()?;
        self.monotonic()?;
        self.add_distance(c.d)?;
        let shift = Pt::new(c.w, c.u);
        for s in &mut self.segs {
            s.shift(shift);
        }
        let mut out = Sink {
            flip: self.flip,
            moves: Vec::new(),
        };
        let delta = c.i.max(2.0 * TOL);
        let escape = Pt::new(c.r, c.r);
        let start = self.segs[0].start;
        out.rapid(start);
        let last_end = self.segs[self.segs.len() - 1].end;
        if last_end.im < start.im {
            self.segs
                .push(Seg::line(last_end, Pt::new(last_end.re, start.im)));
        }
        self.pocket(c.sub, start, delta, escape, &mut out)?;
        Ok(out.moves)
    }

    /// The roughing passes, pocket after pocket.
    fn pocket(
        &mut self,
        sub: u16,
        start: Pt,
        delta: f64,
        escape: Pt,
        out: &mut Sink,
    ) -> Result<(), ProfileError> {
        let mut pocket_starts = vec![start];
        let mut loc = start;
        let mut p = 0usize;
        let mut cycle = sub;
        let mut passes = 0u64;
        let mut is = Vec::new();
        let mut is2 = Vec::new();
        let segs = std::mem::take(&mut self.segs);
        let n = segs.len();
        'pocket: loop {
            let mut x = pocket_starts[pocket_starts.len() - 1].im;
            if cycle == 2 {
                while p < n {
                    self.guard(out)?;
                    if segs[p].dive(&mut loc, -1e9, out, p == 0, &mut is)? {
                        break;
                    }
                    p += 1;
                }
                cycle = 3;
            }
            while p < n {
                self.guard(out)?;
                while x - TOL > loc.im {
                    self.guard(out)?;
                    x -= delta;
                }
                if segs[p].dive(&mut loc, x, out, p == 0, &mut is)? {
                    if cycle == 1 {
                        while p < n {
                            segs[p].climb_only(&mut loc, out, &mut is);
                            p += 1;
                        }
                    } else {
                        while p < n {
                            self.guard(out)?;
                            if segs[p].climb(&mut loc, out)? {
                                if cycle == 3 {
                                    let last = pocket_starts[pocket_starts.len() - 1];
                                    if loc.im > last.im && pocket_starts.len() > 1 {
                                        pocket_starts.pop();
                                    }
                                    if pocket_starts.len() == 1 {
                                        pocket_starts.push(loc);
                                    }
                                }
                                continue 'pocket;
                            }
                            p += 1;
                        }
                    }
                    break 'pocket;
                }
                if (loc.im - x).abs() > TOL {
                    p += 1;
                    continue;
                }
                for (ip, seg) in segs.iter().enumerate().skip(p) {
                    self.guard(out)?;
                    seg.intersection_z(loc.im, &mut is2);
                    if is2.is_empty() {
                        continue;
                    }
                    let dest_z = if ip != p { is2[0] } else { is2[is2.len() - 1] };
                    let distance = (dest_z - loc.re).abs();
                    if dest_z - TOL > loc.re {
                        continue;
                    }
                    if distance < TOL {
                        if p == ip {
                            continue;
                        } else if loc.sub(seg.start).abs() < TOL {
                            p = ip;
                            break;
                        } else {
                            x -= delta;
                            break;
                        }
                    }
                    passes += 1;
                    if passes > MAX_PROFILE_PASSES {
                        return Err(perr(format!(
                            "more than {MAX_PROFILE_PASSES} roughing passes: make I (the depth of cut) larger"
                        )));
                    }
                    let mut dest = Pt::new(dest_z, loc.im);
                    out.feed(dest);
                    let k = (distance / 2.0 / escape.re).min(1.0);
                    dest = dest.add(escape.scale(k));
                    out.rapid(dest);
                    out.rapid(loc.sub(escape.scale(k).conj()));
                    if p == 0 {
                        out.rapid(loc);
                    } else {
                        out.feed(loc);
                    }
                    x -= delta;
                    break;
                }
            }
            break;
        }
        self.segs = segs;
        Ok(())
    }
}

/// The words of one block of a profile's subroutine that make the profile (rs274 reads
/// no others there: feeds, speeds and other codes in the sub do nothing).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct ProfileWords {
    /// The motion code named (ten times its number), if any.
    pub motion: Option<u16>,
    pub x: Option<f64>,
    pub z: Option<f64>,
    pub u: Option<f64>,
    pub w: Option<f64>,
    pub i: Option<f64>,
    pub k: Option<f64>,
    pub r: Option<f64>,
    pub a: Option<f64>,
    pub c: Option<f64>,
}

/// A profile cycle between its block and its subroutine's return: the profile so far.
#[derive(Debug, Clone)]
pub(crate) struct Recording {
    pub cycle: ProfileCycle,
    pub profile: Profile,
    /// The profile's current point (program coordinates).
    pub at: Pt,
    /// The motion mode in force in the sub (ten times the G number).
    pub motion: u16,
    /// G91 and G91.1 in force at the cycle's block.
    pub incremental: bool,
    pub arc_incremental: bool,
    /// The cycle's code as written (`G71.1`), its block's line, offset and text, and
    /// the code word's place in it, for the diagnostics made when the sub returns.
    pub name: String,
    pub line: u32,
    pub offset: usize,
    pub raw: String,
    pub span: (usize, usize),
}

impl Recording {
    /// One block of the sub, as rs274's cycles read it: a move from the current point
    /// adds a piece (a line for G0/G1, an arc for G2/G3 by I/K or R), then A a fillet
    /// or C a chamfer at its end.
    pub(crate) fn record(&mut self, b: &ProfileWords) -> Result<(), ProfileError> {
        let start = self.at;
        let mut end = if self.incremental {
            Pt::default()
        } else {
            start
        };
        let mut center = Pt::default();
        if let Some(u) = b.u {
            if self.incremental {
                return Err(perr("Cannot use U in incremental mode (G91)"));
            }
            if b.x.is_some() {
                return Err(perr("Cannot use U and X in the same block"));
            }
            end.im += u;
        } else if let Some(x) = b.x {
            end.im = x;
        }
        if let Some(w) = b.w {
            if self.incremental {
                return Err(perr("Cannot use W in incremental mode (G91)"));
            }
            if b.z.is_some() {
                return Err(perr("Cannot use W and Z in the same block"));
            }
            end.re += w;
        } else if let Some(z) = b.z {
            end.re = z;
        }
        if let Some(i) = b.i {
            center.im = i;
        }
        if let Some(k) = b.k {
            center.re = k;
        }
        if self.incremental {
            end = end.add(start);
        }
        if let Some(m) = b.motion {
            self.motion = m;
        }
        if start == end {
            return Ok(());
        }
        match self.motion {
            0 | 10 => self.profile.push_line(start, end)?,
            20 | 30 => {
                let ccw = self.motion == 30;
                if let Some(r) = b.r {
                    if b.i.is_some() || b.k.is_some() {
                        return Err(perr("both R and I or K flag used for arc"));
                    }
                    let chord = end.sub(start);
                    let n = chord.norm();
                    let d = chord.turn().scale(((r * r - n / 4.0) / n).sqrt());
                    let mid = start.add(end).scale(0.5);
                    center = if ccw { mid.add(d) } else { mid.sub(d) };
                } else {
                    if b.i.is_none() && b.k.is_none() {
                        return Err(perr("either I or K must be present for arc"));
                    }
                    if self.arc_incremental {
                        center = center.add(start);
                    }
                }
                self.profile.push_arc(ccw, start, center, end)?;
            }
            _ => {}
        }
        if matches!(self.motion, 0 | 10 | 20 | 30) {
            if b.a.is_some() && b.c.is_some() {
                return Err(perr("Both A and C parameters on a corner"));
            }
            if let Some(a) = b.a {
                self.profile.push_corner(true, a, end)?;
            }
            if let Some(c) = b.c {
                self.profile.push_corner(false, c, end)?;
            }
        }
        self.at = end;
        Ok(())
    }
}

impl Recording {
    /// The cycle refused, located at its block's code word.
    pub(crate) fn error(&self, why: &str) -> crate::diag::Diagnostic {
        crate::diag::Diagnostic::at(
            crate::diag::Severity::Error,
            crate::diag::ErrorKind::ProfileCycle(format!("{}: {why}", self.name)),
            self.line,
            self.offset,
            self.raw.as_bytes(),
            self.span.0,
            self.span.1,
        )
    }

    /// The warning that the cycle, a lathe's, is traced as rs274 runs it.
    pub(crate) fn warning(&self) -> crate::diag::Diagnostic {
        crate::diag::Diagnostic::at(
            crate::diag::Severity::Warning,
            crate::diag::ErrorKind::LatheCycle(self.name.clone()),
            self.line,
            self.offset,
            self.raw.as_bytes(),
            self.span.0,
            self.span.1,
        )
    }
}
