//! `drive_compliance@Oi`: the torsional stiffness k (N·mm/rad) of rotary drive i at its output
//! (gear, shafts, motor held), replacing the arm file's. The gear yields `Δq_i = −ΔT_i/k`:
//! link i turns against body i−1 by that much (docs/model.md §10).

use super::{check_drive, check_param, Deformation, EffectContext, Mechanism};
use crate::arm::Arm;
use crate::error::Result;

/// Torsional stiffness (N·mm/rad) of the rotary drive at joint `joint` (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveCompliance {
    /// 0-based joint index (O_1 is 0).
    pub joint: usize,
    /// Torsional stiffness (N·mm/rad), > 0.
    pub stiffness: f64,
}

impl Mechanism for DriveCompliance {
    fn label(&self) -> String {
        format!("drive_compliance@O{}", self.joint + 1)
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        let instead = format!("actuator_compliance@M{}", self.joint + 1);
        check_drive(&self.label(), self.joint, arm, true, &instead)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        self.check_site(arm)?;
        check_param(
            &self.label(),
            "stiffness_nmm_per_rad",
            self.stiffness,
            false,
        )
    }
    fn apply(&self, _ctx: &EffectContext<'_>, def: &mut Deformation) {
        def.body_compliance[self.joint] = 1.0 / self.stiffness;
    }
}
