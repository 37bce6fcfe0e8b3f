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
