//! The one error type of the core. Every message names what the user must fix: the arm key,
//! the pose row (0-based, as in the arrays the caller passed) or the effect.

use thiserror::Error;

/// Everything that can go wrong in `arm_core`, as a value; the core never panics on input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ArmError {
    /// The arm description is invalid; `key` names the arm-file key (e.g. `link[2].A`).
    #[error("arm: key '{key}': {reason}")]
    InvalidArm {
        /// Arm-file key at fault.
        key: String,
        /// What is wrong with it.
        reason: String,
    },
    /// An input array has the wrong length.
    #[error("{what}: expected {expected} values, got {got}")]
    Shape {
        /// Name of the array.
        what: &'static str,
        /// Expected number of values.
        expected: usize,
        /// Number of values given.
        got: usize,
    },
    /// An input value is NaN or infinite.
    #[error("pose row {row}: {what} has a non-finite value")]
    NonFinite {
        /// 0-based row.
        row: usize,
        /// Name of the array.
        what: &'static str,
    },
    /// An input value is outside its physical range.
    #[error("pose row {row}: {what}")]
    OutOfRange {
        /// 0-based row.
        row: usize,
        /// What is wrong.
        what: String,
    },
    /// The actuator's line passes through its joint: no finite force holds the pose.
    #[error(
        "pose row {row}: actuator {actuator} passes through joint O{actuator} (singular pose)"
    )]
    Singular {
        /// 0-based row.
        row: usize,
        /// 1-based actuator number.
        actuator: usize,
    },
    /// The actuator's two pins coincide in this pose.
    #[error("pose row {row}: actuator {actuator} has coincident pins (zero length)")]
    ZeroLength {
        /// 0-based row.
        row: usize,
        /// 1-based actuator number.
        actuator: usize,
    },
    /// The actuator triangle cannot be closed with the requested pin-to-pin length.
    #[error(
        "pose row {row}: actuator {actuator} cannot close its triangle with length {} mm",
        fmt_mm(*.length)
    )]
    Unreachable {
        /// 0-based row.
        row: usize,
        /// 1-based actuator number.
        actuator: usize,
        /// The length that could not be reached (mm).
        length: f64,
    },
    /// An effect is malformed or does not fit the arm.
    #[error("effect {effect}: {reason}")]
    InvalidEffect {
        /// `name@place`.
        effect: String,
        /// What is wrong.
        reason: String,
    },
    /// An option of a computation is invalid (e.g. a sweep's reduce group).
    #[error("{0}")]
    InvalidOption(String),
    /// The caller asked to stop (e.g. Ctrl-C during a sweep).
    #[error("cancelled")]
    Cancelled,
    /// A computation is not defined for this arm (e.g. inverse kinematics for n != 3), or
    /// a finite-element model that nothing holds (the chassis free to turn).
    #[error("{0}")]
    Unsupported(String),
    /// The finite-element model of this pose is a mechanism: some part moves without
    /// deforming anything, so no finite displacement answers the load.
    #[error("pose row {row}: the FE model is a mechanism: {what}")]
    Mechanism {
        /// 0-based row.
        row: usize,
        /// What is free to move, and the likely reason.
        what: String,
    },
    /// An iterative solve (the active set of the FE gap elements) did not settle.
    #[error("pose row {row}: {what}")]
    NoConvergence {
        /// 0-based row.
        row: usize,
        /// What did not converge.
        what: String,
    },
}

impl ArmError {
    /// Whether this is a property of one pose (singular, zero length, cannot close) rather
    /// than of the input as a whole.
    pub fn is_pose_failure(&self) -> bool {
        matches!(
            self,
            Self::Singular { .. }
                | Self::ZeroLength { .. }
                | Self::Unreachable { .. }
                | Self::Mechanism { .. }
                | Self::NoConvergence { .. }
        )
    }
}

/// A length for a message: fixed point when sensible, scientific when absurd (1e300 mm).
fn fmt_mm(x: f64) -> String {
    if x.is_finite() && x.abs() < 1e6 {
        format!("{x:.6}")
    } else {
        format!("{x:.3e}")
    }
}

/// Result alias of the core.
pub type Result<T> = std::result::Result<T, ArmError>;
