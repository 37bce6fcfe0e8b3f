//! The kinematics crate's typed errors.

/// Everything that can go wrong with a machine definition or a kinematic request.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum KinError {
    /// The machine file cannot be read as TOML, or holds a value of the wrong kind.
    #[error("{file}:{line}:{column}: {message}")]
    MachineFile {
        /// File name (or `<built-in NAME>`).
        file: String,
        /// 1-based line (0 when unknown).
        line: usize,
        /// 1-based column (0 when unknown).
        column: usize,
        /// What is wrong.
        message: String,
        /// The offending line.
        text: String,
    },
    /// The machine file reads, but describes no machine this model can drive.
    #[error("machine {machine}: {what}")]
    InvalidMachine {
        /// Machine name.
        machine: String,
        /// What is wrong, naming the axis or field.
        what: String,
    },
    /// A name that is not one of the machine's axes.
    #[error("unknown axis `{name}`; this machine's axes are {known}")]
    UnknownAxis {
        /// The name given.
        name: String,
        /// The machine's axis names.
        known: String,
    },
    /// A joint value was not given.
    #[error("no value for axis {0}")]
    MissingJoint(String),
    /// A joint beyond its travel.
    #[error("{axis} = {value} is outside its limits [{lo}, {hi}]")]
    JointOutOfLimit {
        /// Axis name.
        axis: String,
        /// The value.
        value: f64,
        /// Lower limit.
        lo: f64,
        /// Upper limit.
        hi: f64,
    },
    /// A head that the machine does not have.
    #[error("unknown head `{name}`; this machine's heads are {known}")]
    UnknownHead {
        /// The name given.
        name: String,
        /// The machine's heads.
        known: String,
    },
    /// A parameter the machine does not have, or of the wrong shape.
    #[error("parameter {name}: {why}")]
    Parameter {
        /// Parameter name.
        name: String,
        /// What is wrong.
        why: String,
    },
    /// A tool axis of zero length.
    #[error("the tool axis has zero length")]
    ZeroToolAxis,
    /// NaN or infinity where a number belongs.
    #[error("{0} is not a finite number")]
    NotFinite(String),
    /// No joint solution reaches the pose within the machine's limits.
    #[error("{what}")]
    Unreachable {
        /// What blocks it and the nearest reachable orientation.
        what: String,
    },
}

impl KinError {
    /// What the user can do about it.
    pub fn hint(&self) -> &'static str {
        match self {
            KinError::MachineFile { .. } => "fix the machine file; `lampost machines show fadal-lamp` prints a complete example",
            KinError::InvalidMachine { .. } => "fix the machine file; axes must be unit vectors, linear axes orthogonal, rotary axes not parallel",
            KinError::UnknownAxis { .. } => "use the machine's axis names (see `lampost machines show`)",
            KinError::MissingJoint(_) => "give every axis the option names a value, e.g. X=0,Y=0,Z=0,A=0,B=0 for --joints or A=0,B=0 for --index",
            KinError::JointOutOfLimit { .. } => "choose a value within the travel, or correct the limits in the machine file",
            KinError::UnknownHead { .. } => "use one of the machine's heads",
            KinError::Parameter { .. } => "vector parameters take --set NAME=x,y,z, scalars --set NAME=value",
            KinError::ZeroToolAxis => "give a non-zero tool axis i,j,k",
            KinError::NotFinite(_) => "give a finite number",
            KinError::Unreachable { .. } => "tilt less, or re-fixture the part so the orientation lies within the rotary limits",
        }
    }
}
