//! # lampost-post
//!
//! Planar toolpaths (3-axis programs from any CAM system or slicer) placed on the part and
//! turned into 5-axis programs for the FADAL A/B table and the NRC B/C table, and the
//! verification that replays a posted program through forward kinematics.
//!
//! Pipeline (each stage streams): text → [`lampost_gcode::Stream`] (moves in the program
//! frame) → the intended path (placed in the part frame by a [`Frame`], with
//! the tool axis each move should have) → [`post()`] (rotaries per section or layer
//! by inverse kinematics, retract before every re-index, joint positions, process codes,
//! limits on every point) → dialect text. [`verify()`] reads a posted program back
//! and compares every feed point with the same intended path.
//!
//! Every block is written by one writer (`writer.rs`), whichever path made it: planar
//! programs and per-point paths ([`pointwise`]). Safe heights over the work
//! ([`safety`]) decide every retract; with a part mesh ([`collide`]) every rapid is
//! checked against it.
//!
//! ## Why these dependencies
//! - `lampost-gcode`, `lampost-kinematics`: reading programs, writing them, the machines;
//! - `lampost-align`: the setup file format `lampost align` writes;
//! - `lampost-mesh`: the part mesh (STL) and its manifold report;
//! - `parry3d-f64`: the part mesh's collision queries;
//! - `toml`: setup and job files; `nalgebra`: frames; `thiserror`: [`PostError`].

mod check;
mod chords;
pub mod collide;
mod error;
mod frame;
mod intended;
mod job;
mod orient;
mod pipeline;
pub mod pointwise;
mod post;
pub mod preview;
pub mod safety;
pub mod split;
mod verify;
mod writer;

pub use error::PostError;
pub use frame::{read_setup, Frame};
pub use intended::{IntendedOptions, LayerSchedule, Orient, Section, Source, LASER_LOOK};
pub use job::{parse as read_job, JobFile, JobSection};
pub use pipeline::{post, Rewind};
pub use post::{default_head, process_head, PostConfig, PostDialect, PostReport, Process};
pub use verify::{verify, verify_traced, VerifyReport};
