//! `joint_clearance@Oi`: radial clearance c of joint pin O_i, concentric when unloaded.
//! Loaded, link i's pin centre sits c away from the bore centre of body i−1, along the force
//! that link i presses onto body i−1 (−R_i). That force comes from the statics of the
//! undeformed pose, a global vector, so the offset is global too (see docs/model.md).

use super::{check_param, check_place, Deformation, EffectContext, Mechanism, FORCE_ZERO_N};
use crate::arm::Arm;
use crate::error::Result;
use crate::geometry::V2;

/// Radial clearance (mm) of joint `joint` (0-based: 0 is O_1 on the chassis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointClearance {
    /// 0-based joint index.
    pub joint: usize,
    /// Radial clearance (mm), ≥ 0.
    pub clearance: f64,
}

impl Mechanism for JointClearance {
    fn label(&self) -> String {
        format!("joint_clearance@O{}", self.joint + 1)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        check_place(&self.label(), self.joint, arm)?;
        check_param(&self.label(), "clearance_mm", self.clearance, true)
    }
    fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation) {
        let i = self.joint;
        let press = -ctx.loaded.r[i];
        let m = press.norm();
        if m < FORCE_ZERO_N {
            return; // no force, no preferred side of the clearance
        }
        let u: V2 = press * (self.clearance / m);
        def.joint_offset[i] += u;
    }
}
