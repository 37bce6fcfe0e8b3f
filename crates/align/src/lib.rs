//! # lampost-align
//!
//! The measuring half of the repair workflow (papers 000 and 002): fits of probed points
//! (sphere, plane, circle), levelling, CAD alignment.
//!
//! ## Why these dependencies
//! - `nalgebra`: SVD, Cholesky and small dense algebra for the fits;
//! - `lampost-kinematics`: the machines for levelling;
//! - `lampost-gcode`: the FADAL emitter for probing programs;
//! - `parry3d-f64`: closest points on a triangle mesh (BVH) for registration, in f64;
//! - `lampost-mesh`: the CAD mesh registration aligns to;
//! - `serde`: fit results serialise to JSON for `lampost fit --json`;
//! - `thiserror`: the typed [`AlignError`].

pub mod calib;
mod error;
pub mod fit;
mod machine_file;
pub mod probe;
pub mod register;
mod setup;
pub mod study;

pub use error::AlignError;
pub use fit::{
    circle3d, plane, residual_warning, sphere, sphere4, spread, CircleFit, PlaneFit, SphereFit,
    MAX_COORD, MAX_ITERATIONS, MAX_RESIDUAL_OF_SPREAD, P3,
};
pub use machine_file::calibrated_text;
pub use setup::{level, plane_angle, Level, PlaneAngle, Setup};
