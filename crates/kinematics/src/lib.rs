//! # lampost-kinematics
//!
//! Machine definitions (TOML) and the kinematics of table-table 5-axis machines: one
//! generic model of which the FADAL A/B table (paper 000) and the NRC B/C table (paper
//! 003, eq. (3)) are instances. See [`machine`] for the model and its formulas.
//!
//! ```
//! use lampost_kinematics::{Joints, Machine};
//! let m = Machine::builtin("fadal-lamp", &[]).unwrap();
//! let pose = m.forward(&Joints { linear: [0.0; 3], rotary: [0.0; 2] }, m.head("spindle").unwrap());
//! assert!(pose.tip.norm() < 1e-12 && (pose.axis.z - 1.0).abs() < 1e-12);
//! ```
//!
//! ## Why these dependencies
//! - `nalgebra`: vectors and small linear algebra, shared with the fitting code;
//! - `serde` + `toml`: machine files users read, copy and edit, with line/column errors;
//! - `thiserror`: the typed [`KinError`];
//! - `pulp`: the batch functions ([`batch`]) run four poses per instruction with AVX2
//!   where the processor has it, chosen at run time (a portable build cannot assume it);
//!   that choice takes `unsafe`, which this workspace forbids and `pulp` keeps inside a
//!   well-used crate.

pub mod batch;
pub mod check;
pub mod def;
pub mod error;
pub mod lanes;
pub mod machine;
pub mod trig;

pub use batch::IkQuery;
pub use def::{
    CalibrationRecord, MachineDef, Moves, ParamValue, ProcessDef, SensorDef, Units, VecExpr,
    BUILTINS,
};
pub use error::KinError;
pub use machine::{
    Affine, Choice, Head, Joints, Linear, Machine, Orientation, Placed, Pose, Rotary, Solution,
    Solutions,
};
pub use nalgebra::Vector3;
