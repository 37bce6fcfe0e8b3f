//! # lampost-plan
//!
//! Planning metal deposition from a solid model (paper 001). So far: [`slice()`], the
//! layers of a closed triangle mesh cut by planes normal to a build direction, or by a
//! fan of planes turned about an axis, as closed oriented loops that keep the face each
//! piece came from (perimeters with approach directions and raster fill come next).
//!
//! ## Why these dependencies
//! - `lampost-mesh`: the mesh, its edges and its manifold report;
//! - `nalgebra`: `f64` vectors; `thiserror`: the typed [`PlanError`].

pub mod error;
pub mod perimeter;
pub mod slice;

pub use error::PlanError;
pub use perimeter::{perimeters, PathPoint, PerimeterOptions};
pub use slice::{slice, Gap, Loop, OpenChain, Planes, Slice, SliceOptions, Slicing};
