//! `mount_compliance@Mi`: a spring in series with actuator i (brackets, pins). It changes the
//! pin-to-pin length by `−ΔF_i/k` but the actuator's own sensor does not see it.

use super::{check_drive, check_param, Deformation, EffectContext, Mechanism};
use crate::arm::Arm;
use crate::error::Result;

/// Series mount stiffness (N/mm) of actuator `actuator` (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MountCompliance {
    /// 0-based actuator index.
    pub actuator: usize,
    /// Axial stiffness (N/mm), > 0.
    pub stiffness: f64,
}

impl Mechanism for MountCompliance {
    fn label(&self) -> String {
        format!("mount_compliance@M{}", self.actuator + 1)
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        // A rotary drive's mount is part of its torsional stiffness.
        let instead = format!("drive_compliance@O{}", self.actuator + 1);
        check_drive(&self.label(), self.actuator, arm, false, &instead)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        self.check_site(arm)?;
        check_param(&self.label(), "stiffness_n_per_mm", self.stiffness, false)
    }
    fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation) {
        let i = self.actuator;
        def.extra_length[i] -= ctx.delta.f[i] / self.stiffness;
    }
}
