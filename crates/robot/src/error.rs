//! The robot crate's typed errors.

/// Everything that can go wrong with an arm file, a pose, a path or robot output.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RobotError {
    /// The arm file cannot be read, or holds a value that makes no arm.
    #[error("{file}:{line}:{column}: {message}")]
    MachineFile {
        /// File name (or `<built-in NAME>`).
        file: String,
        /// 1-based line (0 when unknown).
        line: usize,
        /// 1-based column (0 when unknown).
        column: usize,
        /// What is wrong.
        message: String,
        /// The offending line.
        text: String,
    },
    /// A pose no joint values reach within the limits; names the joint and the point.
    #[error("{what}")]
    Unreachable {
        /// Input line of the path point (0: not from a file).
        line: usize,
        /// The limiting joint.
        joint: String,
        /// The whole message.
        what: String,
    },
    /// A segment that asks a joint to turn faster than it can at the given feed.
    #[error("{what}")]
    TooFast {
        /// Input line of the point the segment ends at.
        line: usize,
        /// The joint.
        joint: String,
        /// The whole message.
        what: String,
    },
    /// A laser-on run longer than a chunk can hold.
    #[error("{what}")]
    ChunkTooSmall {
        /// Input line where the run starts.
        line: usize,
        /// The whole message.
        what: String,
    },
    /// A bad option value (chunk size, spacing, configuration letters).
    #[error("{0}")]
    Option(String),
    /// Robot output that does not do what its path asks (`lampost verify`).
    #[error("{file}:{line}: {message}")]
    Verify {
        /// The location file or manifest.
        file: String,
        /// 1-based line (0: the file as a whole).
        line: usize,
        /// What is wrong.
        message: String,
    },
}

impl RobotError {
    /// What the user can do about it.
    pub fn hint(&self) -> &'static str {
        match self {
            RobotError::MachineFile { .. } => "fix the arm file; `lampost machines show puma-lens` prints a complete example",
            RobotError::Unreachable { .. } => "move the part on its holder ([holder] in the arm file), choose another configuration (--config), or shorten the path",
            RobotError::TooFast { .. } => "lower the feed (the whole path's: the laser deposits per unit time, so slowing only this segment would deposit more here), smooth the approach directions, or raise the joint's max_speed if the arm allows it",
            RobotError::ChunkTooSmall { .. } => "give a larger --chunk-points (the controller's memory in locations), or split the run with a laser-off point",
            RobotError::Option(_) => "see `lampost post --help` and docs/robot.md",
            RobotError::Verify { .. } => "post the path again; edited or missing location files are not trusted",
        }
    }

    /// Input line of the path point the error is about, if any.
    pub fn point_line(&self) -> Option<usize> {
        match self {
            RobotError::Unreachable { line, .. }
            | RobotError::TooFast { line, .. }
            | RobotError::ChunkTooSmall { line, .. } => Some(*line),
            _ => None,
        }
    }
}
