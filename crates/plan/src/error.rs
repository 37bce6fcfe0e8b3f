//! [`PlanError`]: why a plan was refused.

/// Why slicing (or planning) was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    /// The mesh has no triangles.
    #[error("the mesh has no triangles")]
    Empty,
    /// A vertex that is not finite, or a triangle naming a vertex that is not there.
    #[error("the mesh is not usable: {0}")]
    Mesh(String),
    /// The build direction (or fan axis) is zero or not finite.
    #[error("the {what} {v:?} is zero or not finite")]
    Direction {
        /// Which vector.
        what: &'static str,
        /// Its components.
        v: [f64; 3],
    },
    /// A layer height or fan step that is zero, negative, not finite or too small.
    #[error("the {what} {} is {why}", lampost_gcode::Readable(*.value))]
    Layer {
        /// `layer height` or `fan step`.
        what: &'static str,
        /// The value given.
        value: f64,
        /// What is wrong.
        why: String,
    },
    /// A layer height larger than the part along the build direction.
    #[error(
        "the layer height {} is larger than the part ({} along the build direction)",
        lampost_gcode::Readable(*.layer),
        lampost_gcode::Readable(*.extent)
    )]
    LayerTooLarge {
        /// The layer height.
        layer: f64,
        /// The part's extent along the build direction.
        extent: f64,
    },
    /// The fan's planes cannot cut the part on one side of their axis.
    #[error("fan: {0}")]
    Fan(String),
}
