//! `actuator_friction@Mi`: Coulomb friction in parallel with actuator i's body (seals, guides,
//! the screw), limit `friction_n` (N). The body spring takes only the part S_i of the force
//! change that the friction lets through ([`super::SequenceMemory`]); the body's sensor
//! (`dlK_mm`) sees `−S_i/k_i`. A mount in series and a play still take the whole actuator
//! force. Loaded once from the reference, S_i is the deadband `sign(ΔF)·max(0, |ΔF| − L)`.
//!
//! The effect moves nothing through [`Mechanism::apply`]: what it holds depends on the
//! history, so it acts through the per-sequence memory before the other effects are applied.

use super::{check_drive, check_param, Deformation, EffectContext, Mechanism};
use crate::arm::Arm;
use crate::error::Result;

/// Friction limit (N) of actuator `actuator`'s body (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorFriction {
    /// 0-based actuator index.
    pub actuator: usize,
    /// Friction limit (N), ≥ 0.
    pub friction: f64,
}

impl ActuatorFriction {
    /// The force (N) the friction holds at most.
    pub fn limit(&self) -> f64 {
        self.friction
    }
}

impl Mechanism for ActuatorFriction {
    fn label(&self) -> String {
        format!("actuator_friction@M{}", self.actuator + 1)
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        let instead = format!("drive_friction@O{}", self.actuator + 1);
        check_drive(&self.label(), self.actuator, arm, false, &instead)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        self.check_site(arm)?;
        check_param(&self.label(), "friction_n", self.friction, true)
    }
    fn apply(&self, _ctx: &EffectContext<'_>, _def: &mut Deformation) {}
}
