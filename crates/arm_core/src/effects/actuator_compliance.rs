//! `actuator_compliance@Mi`: the actuator body's own axial stiffness, replacing the arm file's.
//! Its length change `−ΔF_i/k` is what the actuator's displacement sensor (`dlK_mm`) sees.

use super::{check_drive, check_param, Deformation, EffectContext, Mechanism};
use crate::arm::Arm;
use crate::error::Result;

/// Actuator body stiffness (N/mm) of actuator `actuator` (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorCompliance {
    /// 0-based actuator index.
    pub actuator: usize,
    /// Axial stiffness (N/mm), > 0.
    pub stiffness: f64,
}

impl Mechanism for ActuatorCompliance {
    fn label(&self) -> String {
        format!("actuator_compliance@M{}", self.actuator + 1)
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        let instead = format!("drive_compliance@O{}", self.actuator + 1);
        check_drive(&self.label(), self.actuator, arm, false, &instead)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        self.check_site(arm)?;
        check_param(&self.label(), "stiffness_n_per_mm", self.stiffness, false)
    }
    fn apply(&self, _ctx: &EffectContext<'_>, def: &mut Deformation) {
        def.body_compliance[self.actuator] = 1.0 / self.stiffness;
    }
}
