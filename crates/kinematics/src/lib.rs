//! # lampost-kinematics
//!
//! Machine definitions (TOML) and the kinematics of table-table 5-axis machines: one
//! generic model of which the FADAL A/B table (paper 000) and the NRC B/C table (paper
//! 003, eq. (3)) are instances. The model and its formulas are below.
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
//! - `pulp`: the batch functions ([`Machine::inverse_into`], [`Machine::forward_into`]; see *Batches* below) run four poses per instruction with AVX2
//!   where the processor has it, chosen at run time (a portable build cannot assume it);
//!   that choice takes `unsafe`, which this workspace forbids and `pulp` keeps inside a
//!   well-used crate.
//!
//! ## The model
//! Model: three orthogonal linear axes place the head in the *machine frame* (the frame
//! of the rotary table's base: fixed for a moving-column machine, carried by the table
//! axes when they move the table); two rotary axes, each a direction and a point, turn
//! the part about them, the inner one (order 1) riding on the outer one. A part point `p`
//! sits in the machine frame at `T(p) = R₂(θ₂)·(R₁(θ₁)·(p − c₁) + c₁ − c₂) + c₂`; the
//! head's tool point sits at `q = h + Σ sₖ·Xₖ·dₖ` (sₖ = −1 when + moves the table).
//! Forward: tip = T⁻¹(q), axis = (R₂R₁)⁻¹·t. Inverse: solve R₁(θ₁)·v = R₂(−θ₂)·t for the
//! two cones' intersections (two branches), then X from `T(tip)`.
//!
//! ## Batches
//! Inverse and forward kinematics for many poses at once: the same answers as
//! [`Machine::inverse`] and [`Machine::forward`], bit for bit, several poses per
//! instruction.
//!
//! How: each pose of a chunk goes through a *branch-free* copy of the regular path (no
//! singularity, two distinct branches, finite input, angles of ordinary size), so the
//! compiler can turn the loop over the chunk into vector code; a pose that leaves the
//! regular path is only flagged there, and solved again by the scalar functions
//! afterwards. The branch-free path performs the very operations of the scalar one in
//! the same order (no fused multiply-add: Rust never contracts `a·b + c`), which is why
//! the results are identical (property-tested against the scalar functions, edge cases
//! included).
//!
//! Why the `pulp` crate: vector instructions wider than the x86-64 baseline (AVX2, four
//! `f64` per instruction) must be chosen at run time, since a shop's PC may lack them;
//! that choice needs `unsafe` code, which this workspace forbids and `pulp` keeps inside
//! a well-used crate. `Arch::dispatch` compiles the closure for each instruction set and
//! runs the best one the processor has (plain SSE2 on an old one).
//!
//! ## What a machine file may hold
//! Machine files are validated as data: every value the post writes into a program as
//! text (process codes, the laser power word, axis names, head and machine names) may
//! hold only what the post means it to, so a machine file cannot put motion, feeds, block
//! numbers, comments or macros into a posted program.
//!
//! The rules:
//! - a process code (`laser_on`, `spindle_off`, `program_end`, … every code string under
//!   `[process]`) holds only M, S, P and Q words, each a letter and a plain decimal
//!   number, separated by spaces; empty for none;
//! - `laser_power_word` is one letter: S, P or Q;
//! - linear axes are named X, Y, Z, U, V or W, rotary axes A, B or C, all five distinct;
//! - head names and the machine name hold no parentheses and no control characters (line
//!   breaks, tabs): they are written into program comments. They are refused, not
//!   stripped, so the name a user types is the name in the file.
//!
//! Letters may be lower case; they are stored upper case (and a code's words joined by
//! single spaces).
//!
//! [`MachineDef::from_toml`] reports a refusal at the file, line and column of the
//! offending text; [`MachineDef::check`] (which [`Machine::new`] runs) reports it
//! without a place, for definitions built in code.

mod batch;
mod check;
mod def;
mod error;
// The four-pose lanes are shared with the post's chord planning (`lampost-post`), which
// must do the very operations in the same order: public for that crate, not API.
#[doc(hidden)]
pub mod lanes;
mod machine;
pub mod trig;

pub use batch::IkQuery;
pub use check::{dropped_elements, key_offset};
pub use def::builtin_text;
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
