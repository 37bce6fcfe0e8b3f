//! The post's typed errors.

use lampost_gcode::Diagnostic;
use lampost_kinematics::KinError;

/// Everything that stops a post or a verification.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PostError {
    /// The input program has an error (parse or interpretation).
    #[error("{file}:{}:{}: {}", .diag.line, .diag.column, .diag.kind)]
    Input {
        /// Input name.
        file: String,
        /// The diagnostic.
        diag: Box<Diagnostic>,
    },
    /// Something the post cannot turn into 5-axis motion faithfully.
    #[error("{file}:{line}: {what}")]
    Unsupported {
        /// Input name.
        file: String,
        /// Line.
        line: u32,
        /// What.
        what: String,
    },
    /// A value of the input that no word of the output dialect can hold (a feed beyond
    /// the control's largest F, say): refused, never saturated.
    #[error("{file}:{line}: {what}")]
    OutOfRange {
        /// Input name.
        file: String,
        /// Line.
        line: u32,
        /// The emitter's words: which value, and the dialect's range.
        what: String,
    },
    /// Program units differ from the machine's.
    #[error("{file}:{line}: the program is in {program} but the machine is in {machine}")]
    Units {
        /// Input name.
        file: String,
        /// Line.
        line: u32,
        /// Program units.
        program: &'static str,
        /// Machine units.
        machine: &'static str,
    },
    /// A point beyond travel.
    #[error("{file}:{line}: {axis} = {} is beyond its travel [{lo}, {hi}]", lampost_gcode::Fixed(*.value, 4))]
    Limit {
        /// Input name.
        file: String,
        /// Input line.
        line: u32,
        /// Axis.
        axis: String,
        /// Value.
        value: f64,
        /// Lower limit.
        lo: f64,
        /// Upper limit.
        hi: f64,
    },
    /// The work at a table position stands higher than the head can retract over it.
    #[error("{file}:{line}: at rotaries {:.3}°, {:.3}° the head must retract to Z {height:.4} to clear the work, above the top of its Z travel {limit}", .rot[0], .rot[1])]
    SafeHeight {
        /// Input name (the section).
        file: String,
        /// Input line of the section's first move there.
        line: u32,
        /// The safe height needed.
        height: f64,
        /// The top of the Z travel.
        limit: f64,
        /// The table position.
        rot: [f64; 2],
    },
    /// The program grows beyond the bound on output size.
    #[error("{file}:{line}: the posted program passes {limit} bytes here (the bound on its size)")]
    TooLarge {
        /// Input name.
        file: String,
        /// Input line being written.
        line: u32,
        /// The bound.
        limit: u64,
    },
    /// A kinematic problem (unreachable orientation, bad machine).
    #[error("{context}{err}")]
    Kin {
        /// Where.
        context: String,
        /// What.
        err: KinError,
    },
    /// A bad setup or job file.
    #[error("{file}:{line}:{column}: {message}")]
    File {
        /// File.
        file: String,
        /// 1-based line (0 when unknown).
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// The input has no motion.
    #[error("{0}: the program has no moves")]
    Empty(String),
    /// Reading or writing failed.
    #[error("{0}")]
    Io(String),
    /// The posted path meets the part given as a mesh (`--part`): a rapid's tool tip, or
    /// the head, runs into it. A real collision, not a fault of the post's.
    #[error("the posted path meets the part: {0}")]
    Collision(String),
    /// The posted program does not follow the intended path.
    #[error("verification failed: {0}")]
    Verify(String),
    /// Options that do not fit together.
    #[error("{0}")]
    Options(String),
}

impl PostError {
    /// What the user can do about it.
    pub fn hint(&self) -> &'static str {
        match self {
            PostError::Input { .. } => "fix the input program (`lampost check` lists every problem)",
            PostError::Unsupported { .. } => "change the input as the message says (in the CAM system, or in the slicer's start and end code), then run the command again",
            PostError::OutOfRange { .. } => "the input's value does not fit the controller's word: check the program's feeds and units (a feed written for another machine, or millimetres read as inches); a rotary wound many turns within one run (a spiral path's) needs the run split where the process is off",
            PostError::Units { .. } => "post with --convert-units to scale the program, or output the program in the machine's units",
            PostError::Limit { .. } => "move the part (--origin or the setup), choose another index, or check the machine's limits; a program that gives no G20/G21 is read in the machine's units (a program in mm on an inch machine: --units mm --convert-units)",
            PostError::SafeHeight { .. } => "place the part lower (--origin or the setup), choose an index that keeps it lower, or check clearance_z, safe_margin and the Z limits in the machine file",
            PostError::TooLarge { .. } => "an arc of many turns or a fine chord tolerance at a tilted index makes many lines: raise --max-growth, or keep arcs in the index's plane",
            PostError::Kin { .. } => "choose an orientation within the rotary limits, or re-fixture the part",
            PostError::File { .. } => "fix the file; see docs/post.md for its keys",
            PostError::Empty(_) => "give a program with moves",
            PostError::Io(_) => "check the paths and free space",
            PostError::Collision(_) => "the part (--part) stands in the way of the move named: move the part or the run's start (--origin, the setup), choose another index, or raise the safe height (clearance_z, safe_margin in the machine file); nothing was written",
            PostError::Verify(_) => "INPUT and POSTED do not belong together (verify takes the placement and the process options the program was posted with: --process, --power, --spindle, --coolant, --tool, --work-offset, --length-offset), or POSTED was changed after it was written, or verify's --tolerance is tighter than the post's own check (twice the post's chord --tolerance: 0.001 in or 0.02 mm by default); else it is a lampost fault. A post that fails its own check writes nothing",
            PostError::Options(_) => "see `lampost post --help`",
        }
    }
}

impl From<std::io::Error> for PostError {
    fn from(e: std::io::Error) -> Self {
        let text = e.to_string();
        // The emitter's refusal of a value its dialect cannot hold, met where no input
        // line is at fault (the index, the power, the header): an option's value, or the
        // machine file's. Not a file's trouble.
        if e.kind() == std::io::ErrorKind::InvalidData && text.starts_with("refused to write") {
            return PostError::Options(format!(
                "{text}: the value comes from an option (--index, --power, --spindle, --origin, --renumber, …) or the machine file; give one the control's word holds"
            ));
        }
        PostError::Io(text)
    }
}
