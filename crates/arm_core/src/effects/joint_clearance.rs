//! `joint_clearance@Oi`: radial clearance c of joint pin O_i. Loaded, link i's pin centre sits
//! c away from the bore centre of body i−1, along the force that link i presses onto body i−1
//! (−R_i). That force comes from the statics of the undeformed pose, a global vector, so the
//! offset is global too (see docs/model.md).
//!
//! With the pin concentric in the unloaded state ([`Unloaded::Centred`]) the whole offset
//! `c·û(−R_i)` appears under load; when the unloaded force (self-weight) had already pressed the
//! pin against the bore ([`Unloaded::TakenUp`]), only the change `c·(û(−R_i) − û(−R0_i))` does.

use super::{
    check_param, check_place, Deformation, EffectContext, Mechanism, Unloaded, FORCE_ZERO_N,
};
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
    /// Where the pin sits in the unloaded state.
    pub unloaded: Unloaded,
}

impl Mechanism for JointClearance {
    fn label(&self) -> String {
        format!("joint_clearance@O{}", self.joint + 1)
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        check_place(&self.label(), self.joint, arm)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        self.check_site(arm)?;
        check_param(&self.label(), "clearance_mm", self.clearance, true)
    }
    fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation) {
        let i = self.joint;
        let loaded = offset(-ctx.loaded.r[i], self.clearance);
        def.joint_offset[i] += match self.unloaded {
            Unloaded::Centred => loaded,
            Unloaded::TakenUp => loaded - offset(-ctx.unloaded.r[i], self.clearance),
        };
    }
}

/// The pin's offset `c·press/|press|` under the force `press`; none below [`FORCE_ZERO_N`]
/// (no force, no preferred side of the clearance).
fn offset(press: V2, c: f64) -> V2 {
    let m = press.norm();
    if m < FORCE_ZERO_N {
        V2::zeros()
    } else {
        press * (c / m)
    }
}
