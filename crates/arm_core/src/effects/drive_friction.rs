//! `drive_friction@Oi`: Coulomb friction in rotary drive i's gear (N·mm), in parallel with its
//! torsional spring: the spring takes only the part S_i of the torque change that the friction
//! lets through ([`super::SequenceMemory`], limit `torque_nmm`), so the gear yields
//! `−S_i/k_i`. The drive's torque, its reactions and the backlash follow the whole torque
//! through the drive (the friction is inside it). The counterpart of `actuator_friction`
//! (docs/model.md §10); loaded once from the reference, S_i is the deadband
//! `sign(ΔT)·max(0, |ΔT| − L)`.
//!
//! As for the other frictions, [`Mechanism::apply`] moves nothing: what it holds depends on
//! the history, so it acts through the per-sequence memory before the other effects.

use super::{check_drive, check_param, Deformation, EffectContext, Mechanism};
use crate::arm::Arm;
use crate::error::Result;

/// Friction torque (N·mm) of the gear of the rotary drive at joint `joint` (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveFriction {
    /// 0-based joint index (O_1 is 0).
    pub joint: usize,
    /// Friction torque (N·mm), ≥ 0.
    pub torque: f64,
}

impl DriveFriction {
    /// The torque (N·mm) the friction holds at most.
    pub fn limit(&self) -> f64 {
        self.torque
    }
}

impl Mechanism for DriveFriction {
    fn label(&self) -> String {
        format!("drive_friction@O{}", self.joint + 1)
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        let instead = format!("actuator_friction@M{}", self.joint + 1);
        check_drive(&self.label(), self.joint, arm, true, &instead)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        self.check_site(arm)?;
        check_param(&self.label(), "torque_nmm", self.torque, true)
    }
    fn apply(&self, _ctx: &EffectContext<'_>, _def: &mut Deformation) {}
}
