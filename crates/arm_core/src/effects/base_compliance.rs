//! `base_compliance@base`: the chassis tilts about `[base].pivot` by `Δφ = ΔM/k`, ΔM the
//! counter-clockwise moment of the payload force about the pivot. O_1 and B_0 turn with it.

use super::{check_param, Deformation, EffectContext, Mechanism};
use crate::arm::Arm;
use crate::error::Result;
use crate::geometry::cross;

/// Rotational stiffness of the chassis support (N·mm/rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseCompliance {
    /// Rotational stiffness (N·mm/rad), > 0.
    pub stiffness: f64,
}

impl Mechanism for BaseCompliance {
    fn label(&self) -> String {
        "base_compliance@base".to_owned()
    }
    fn check_site(&self, _arm: &Arm) -> Result<()> {
        Ok(())
    }
    fn check(&self, _arm: &Arm) -> Result<()> {
        check_param(
            &self.label(),
            "stiffness_nmm_per_rad",
            self.stiffness,
            false,
        )
    }
    fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation) {
        let n = ctx.arm.n();
        let dm = cross(ctx.frames.joint[n] - ctx.arm.pivot, ctx.payload);
        def.base_tilt += dm / self.stiffness;
    }
}
