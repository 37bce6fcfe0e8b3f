//! # lampost-plan
//!
//! Planning metal deposition from a solid model (paper 001): [`slice()`], the layers of a
//! closed triangle mesh cut by planes normal to a build direction, or by a fan of planes
//! turned about an axis, as closed oriented loops that keep the face each piece came
//! from; [`perimeters()`] with their tool axes; [`raster`] fill clipped exactly to the
//! inset region; [`plan()`], the whole plan per layer with the offset-angle check and
//! tilting; [`demo`], paper 001's twisted plate; [`reach()`], whether a machine reaches
//! every point of the path.
//!
//! ## Why these dependencies
//! - `lampost-mesh`: the mesh, its edges and its manifold report;
//! - `lampost-kinematics`: the machines' inverse kinematics, for [`reach()`];
//! - `nalgebra`: `f64` vectors; `thiserror`: the typed [`PlanError`].

pub mod build;
pub mod demo;
mod error;
pub mod perimeter;
pub mod preview;
pub mod raster;
pub mod reach;
pub mod slice;

pub use build::{plan, Approach, LayerPlan, Plan, PlanOptions, Violation};
pub use error::PlanError;
pub use perimeter::{perimeters, PathPoint, PerimeterOptions};
pub use raster::{RasterOptions, Run};
pub use reach::{reach, AxisExtent, Reach, ReachOptions, Unreachable};
pub use slice::{slice, Gap, Loop, OpenChain, Planes, Slice, SliceOptions, Slicing};
