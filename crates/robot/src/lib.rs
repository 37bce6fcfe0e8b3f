//! # lampost-robot
//!
//! Paper 001's robot cell: a six-axis arm (a PUMA 560) holds the part under a fixed LENS
//! deposition head. This crate reads arm files ([`ArmDef`]), does the arm's kinematics
//! ([`Arm`]: classic DH forward kinematics, the closed-form PUMA inverse in all eight
//! configurations, a damped-least-squares inverse for other arms), turns a path into
//! poses that bring each point to the laser's focus with the approach along the beam
//! ([`plan`]), writes them as controller location files in chunks with a manifest and
//! verifies such output ([`chunk`]). See docs/robot.md.
//!
//! ## Why these dependencies
//! - `nalgebra`: small matrices;
//! - `serde` + `toml`: arm files with line/column errors;
//! - `thiserror`: the typed [`RobotError`];
//! - `lampost-kinematics`: the shared `Units`;
//! - `lampost-gcode`: the emitter's fixed-point number writer (`fixed`) for the location
//!   files.

mod arm;
pub mod chunk;
mod def;
mod error;
pub mod plan;

pub use arm::{wrap, Arm, Config, Directions, Frame, NoReach, Turned, Why, Q};
pub use def::{builtin_text, is_arm_text, ArmDef, Units, ARM_BUILTINS};
pub use error::RobotError;
