//! A lathe (turning) program read as a mill's: Fanuc and Haas turning programs give X
//! as a diameter, U and W as incremental X and Z, and cycles and words of their own
//! (`G50 S`, `G71 P Q`, `G76 X Z K D`, a corner radius `R` and chamfer `C` on G1), which
//! a mill's reading takes for other things, silently. The interpreter gathers the signs
//! of one ([`Sign`], read from each block's words) and says once, at the block that
//! completes them, that the program is a lathe's (`ErrorKind::LatheProgram`); the post
//! refuses such a program.
//!
//! Conservative: one sign only a lathe's program shows ([`Sign::Sure`]) is enough; the
//! others are each found in some mill programs (G18 for arcs in XZ, a four-digit T, a
//! stray R), so two different ones are needed. Feed per revolution (G95) is no sign: mills
//! tap with it.

/// One sign of a lathe program.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Sign {
    /// Shown by a lathe's program alone; what it is.
    Sure(&'static str),
    /// A four-digit T word whose two halves are a tool and an offset (`T0101`).
    ToolAndOffset,
    /// The XZ plane (G18).
    PlaneXz,
    /// Constant surface speed (G96).
    SurfaceSpeed,
    /// U or W on a return to the reference point (`G28 U0 W0`: incremental X and Z).
    IncrementalXz,
    /// An R word on a straight move (a lathe's corner radius).
    CornerRadius,
}

impl Sign {
    /// What the sign is, as the diagnostic says it.
    fn meaning(self) -> &'static str {
        match self {
            Sign::Sure(what) => what,
            Sign::ToolAndOffset => "a lathe's tool and offset number",
            Sign::PlaneXz => "the XZ plane of a lathe",
            Sign::SurfaceSpeed => "constant surface speed",
            Sign::IncrementalXz => "a lathe's incremental X and Z",
            Sign::CornerRadius => "a lathe's corner radius on a straight move",
        }
    }
}

/// The signs seen so far.
#[derive(Debug, Clone, Default)]
pub(crate) struct LatheSigns {
    /// The first sign that is not enough alone: what it was, its words and its line.
    first: Option<(Sign, String, u32)>,
    recognised: bool,
}

impl LatheSigns {
    /// True once the program has been recognised as a lathe's.
    pub(crate) fn recognised(&self) -> bool {
        self.recognised
    }

    /// A sign shown by `words` at `line`: the evidence, as the diagnostic gives it, when
    /// this sign completes the recognition (once a program).
    pub(crate) fn observe(&mut self, line: u32, sign: Sign, words: &str) -> Option<String> {
        if self.recognised {
            return None;
        }
        let evidence = match &self.first {
            _ if matches!(sign, Sign::Sure(_)) => format!("`{words}` ({})", sign.meaning()),
            Some((first, text, at)) if *first != sign => format!(
                "`{words}` ({}) after `{text}` ({}) at line {at}",
                sign.meaning(),
                first.meaning()
            ),
            Some(_) => return None,
            None => {
                self.first = Some((sign, words.to_string(), line));
                return None;
            }
        };
        self.recognised = true;
        Some(evidence)
    }
}

/// A T word written as four digits whose first two (the tool) and last two (the offset)
/// are both other than zero: `T0101`, `T1212` (a Fanuc or Haas lathe's tool and
/// offset; `T0100` cancels an offset and says nothing).
pub(crate) fn tool_and_offset(text: &str) -> bool {
    let digits = text.trim().as_bytes();
    digits.len() == 4
        && digits.iter().all(u8::is_ascii_digit)
        && digits[..2] != *b"00"
        && digits[2..] != *b"00"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_sure_sign_or_two_different_ones() {
        let mut s = LatheSigns::default();
        assert_eq!(s.observe(1, Sign::PlaneXz, "G18"), None);
        assert_eq!(
            s.observe(2, Sign::PlaneXz, "G18"),
            None,
            "the same sign again"
        );
        let e = s
            .observe(3, Sign::ToolAndOffset, "T0101")
            .expect("two signs");
        assert!(
            e.contains("`T0101`") && e.contains("`G18`") && e.contains("line 1"),
            "{e}"
        );
        assert!(s.recognised());
        assert_eq!(
            s.observe(4, Sign::Sure("x"), "G50 S2500"),
            None,
            "said once"
        );
        let mut s = LatheSigns::default();
        let e = s
            .observe(7, Sign::Sure("a lathe's spindle speed limit"), "G50 S2500")
            .expect("sure");
        assert_eq!(e, "`G50 S2500` (a lathe's spindle speed limit)");
    }

    #[test]
    fn tool_and_offset_words() {
        for t in ["0101", "0303", "1212", "0110"] {
            assert!(tool_and_offset(t), "{t}");
        }
        for t in ["1", "01", "101", "0100", "0001", "01.01", "-0101", "10101"] {
            assert!(!tool_and_offset(t), "{t}");
        }
    }
}
