//! # lampost-inspect
//!
//! In-line measurement on the machine (paper 003): a laser displacement sensor rides on a
//! head, a measuring plan gives each sampling point the machine position that puts the
//! sensor's zero on it with the beam along the surface normal (the rows of the paper's
//! Figure 7b: X, Y, Z, B, C), the machine visits them and the sensor reads r, and the
//! reading goes back to workpiece coordinates: the surface is at `z_m = z_t − r` along the
//! beam, mapped through the machine's forward kinematics (paper 003's eq. (3) on the NRC
//! cell). Deviations are signed along each point's nominal normal, as CMM software
//! reports vector points.
//!
//! Stages, each its own function: [`plan::plan`] (targets → reachable rows, ordered to keep
//! rotary motion small), [`program::write`] (the rows as a program the controller runs),
//! [`reduce::reduce`] (readings → measured points, every reading accounted for), and
//! [`compare::stats`] (deviation statistics).
//!
//! ```
//! use lampost_inspect::{plan, reduce, Target};
//! let m = lampost_kinematics::Machine::builtin("nrc-lc", &[]).unwrap();
//! let head = m.head("sensor").unwrap();
//! let t = Target { id: "p1".into(), point: [10.0, 5.0, 2.0], normal: [0.0, 0.0, 1.0] };
//! let p = plan::plan(&m, head, plan::Probe::Sensor, &[t], None).unwrap();
//! // A reading of 0.05: the surface is 0.05 below the nominal point, along the beam.
//! let got = reduce::reduce(&m, head, &p.rows, &[("p1".into(), reduce::Reading::Value(0.05), 1)]).unwrap();
//! assert!((got[0].deviation.unwrap() + 0.05).abs() < 1e-12);
//! ```

pub mod compare;
pub mod deposits;
mod error;
pub mod map;
pub mod plan;
pub mod program;
pub mod reduce;
pub mod surface;

pub use error::InspectError;
pub use plan::{Plan, PlanRow, Target};
pub use reduce::{Measured, Reading, Status};
