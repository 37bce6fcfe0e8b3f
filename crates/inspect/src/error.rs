//! The inspect crate's typed errors.

/// What can go wrong in planning, reading a plan or a log, or reducing.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InspectError {
    /// The head has no sensor table in the machine file.
    #[error("head `{head}` of machine {machine} has no sensor (a `sensor = {{ reference, range, max_tilt_deg, trigger }}` table)")]
    NoSensor {
        /// Machine name.
        machine: String,
        /// Head name.
        head: String,
    },
    /// A target the machine cannot measure, and why.
    #[error("point {id}: {why}")]
    Unreachable {
        /// The point's id.
        id: String,
        /// Why (limits, tilt).
        why: String,
    },
    /// Bad input at a line of a file.
    #[error("line {line}: {what}")]
    At {
        /// 1-based line.
        line: usize,
        /// What is wrong.
        what: String,
    },
    /// Bad input with no place.
    #[error("{0}")]
    Input(String),
}
