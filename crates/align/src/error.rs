//! The align crate's typed errors.

/// What can go wrong with a fit or an alignment.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum AlignError {
    /// Fewer points than the fit needs.
    #[error("{fit} needs at least {need} points, got {got}")]
    TooFewPoints {
        /// The fit.
        fit: &'static str,
        /// How many it needs.
        need: usize,
        /// How many it got.
        got: usize,
    },
    /// The same point twice.
    #[error("points {first} and {second} are the same point")]
    DuplicatePoints {
        /// 1-based index of the first.
        first: usize,
        /// 1-based index of the second.
        second: usize,
    },
    /// The points do not fix the shape (coplanar, collinear…).
    #[error("{0}")]
    Degenerate(String),
    /// A calibration's poses or runs cannot give what was asked, with what to do about
    /// it (each case its own advice: a pose set is not a point cloud).
    #[error("{what}")]
    Calibration {
        /// What is wrong.
        what: String,
        /// What the user can do about it.
        hint: &'static str,
    },
    /// NaN or infinity in the input.
    #[error("point {0} is not finite")]
    NotFinite(usize),
    /// A coordinate whose magnitude no machine measures (beyond [`crate::fit::MAX_COORD`]).
    #[error("point {index} has a coordinate {value:e}, beyond ±1e9 of the unit")]
    TooLarge {
        /// 1-based index of the point (or the pose's row).
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// The iteration did not settle.
    #[error("the {0} fit did not converge, because {1}")]
    NoConvergence(&'static str, &'static str),
}

impl AlignError {
    /// What the user can do about it.
    pub fn hint(&self) -> &'static str {
        match self {
            AlignError::TooFewPoints { .. } => "probe more points",
            AlignError::DuplicatePoints { .. } => "remove the repeated point, or probe a different place",
            AlignError::Degenerate(_) => "spread the points: a sphere needs points off one plane, a plane points off one line",
            AlignError::Calibration { hint, .. } => hint,
            AlignError::NotFinite(_) => "check the point file",
            AlignError::TooLarge { .. } => "no machine measures that far: check the units and the numbers in the file",
            AlignError::NoConvergence(..) => "check the points for outliers; the shape may not fit them",
        }
    }
}
