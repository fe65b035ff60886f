//! What turns each joint: a linear actuator ([`linear`]) or a rotary drive ([`rotary`]),
//! gathered in one [`Drive`]. A mixed arm is one arm: statics, closure and the effects match
//! on the drive where the physics differs, and nowhere else (docs/model.md §10).
//!
//! Each drive has one *load*, the generalised force of its joint: the axial force F_i (N,
//! compression +) of a linear actuator, the torque T_i (N·mm, counter-clockwise + on link i)
//! of a rotary drive, as a robot's joint-force vector holds a prismatic joint's force beside
//! a revolute joint's torque. [`crate::statics::Forces::f`] holds them, each in its own unit.

pub mod linear;
pub mod rotary;

pub use linear::Actuator;
pub use rotary::RotaryDrive;

/// The drive of one joint.
#[derive(Debug, Clone, PartialEq)]
pub enum Drive {
    /// A linear actuator between B_{i−1} and A_i.
    Linear(Actuator),
    /// A motor and gearbox at O_i.
    Rotary(RotaryDrive),
}

impl Drive {
    /// The drive's mass (kg).
    pub fn mass_kg(&self) -> f64 {
        match self {
            Self::Linear(a) => a.mass_kg,
            Self::Rotary(d) => d.mass_kg,
        }
    }

    /// The stiffness of the drive's own spring: N/mm (linear), N·mm/rad (rotary).
    pub fn stiffness(&self) -> f64 {
        match self {
            Self::Linear(a) => a.stiffness,
            Self::Rotary(d) => d.stiffness,
        }
    }

    /// Whether this is a rotary drive.
    pub fn is_rotary(&self) -> bool {
        matches!(self, Self::Rotary(_))
    }

    /// The linear actuator, if this is one.
    pub fn linear(&self) -> Option<&Actuator> {
        match self {
            Self::Linear(a) => Some(a),
            Self::Rotary(_) => None,
        }
    }

    /// The linear actuator, mutably, if this is one.
    pub fn linear_mut(&mut self) -> Option<&mut Actuator> {
        match self {
            Self::Linear(a) => Some(a),
            Self::Rotary(_) => None,
        }
    }

    /// The rotary drive, if this is one.
    pub fn rotary(&self) -> Option<&RotaryDrive> {
        match self {
            Self::Linear(_) => None,
            Self::Rotary(d) => Some(d),
        }
    }

    /// The kind's name, as the arm file writes it: `"linear"` or `"rotary"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Linear(_) => "linear",
            Self::Rotary(_) => "rotary",
        }
    }

    /// A loaded load above the drive's limit (`max_force`, `max_torque`), either sign.
    pub fn over_limit(&self, load: f64) -> bool {
        match self {
            Self::Linear(a) => a.over_force(load),
            Self::Rotary(d) => d.over_torque(load),
        }
    }
}
