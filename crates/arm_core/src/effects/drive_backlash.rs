//! `drive_backlash@Oi`: lost motion b (degrees) either side of centre in rotary drive i's gear.
//! Loaded, link i turns against body i−1 by a further `−b·sign(T_i)` (the loaded torque) when
//! the backlash is centred in the unloaded state, or by `−b·(sign(T_i) − sign(T0_i))` when the
//! unloaded torque T0_i (self-weight) had already taken it up ([`Unloaded`]); a torque below
//! [`TORQUE_ZERO_NMM`] has no side. The torque is the drive's actual one (what a joint
//! friction lets through included), so in a load sequence the backlash is taken up along
//! each state's own torque. The counterpart of `actuator_play` (docs/model.md §10).

use super::{
    check_drive, check_param, sign_above, Deformation, EffectContext, Mechanism, Unloaded,
    TORQUE_ZERO_NMM,
};
use crate::arm::Arm;
use crate::error::Result;

/// Backlash (degrees, either side of centre) of the rotary drive at joint `joint` (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveBacklash {
    /// 0-based joint index (O_1 is 0).
    pub joint: usize,
    /// Half-range of the free turn (degrees), ≥ 0.
    pub backlash_deg: f64,
    /// Where the backlash sits in the unloaded state.
    pub unloaded: Unloaded,
}

impl Mechanism for DriveBacklash {
    fn label(&self) -> String {
        format!("drive_backlash@O{}", self.joint + 1)
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        let instead = format!("actuator_play@M{}", self.joint + 1);
        check_drive(&self.label(), self.joint, arm, true, &instead)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        self.check_site(arm)?;
        check_param(&self.label(), "backlash_deg", self.backlash_deg, true)
    }
    fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation) {
        let i = self.joint;
        let side = |t: f64| sign_above(t, TORQUE_ZERO_NMM);
        let b = self.backlash_deg.to_radians();
        match self.unloaded {
            Unloaded::Centred => def.turn[i] -= b * side(ctx.loaded.f[i]),
            Unloaded::TakenUp => {
                let turned = side(ctx.loaded.f[i]) - side(ctx.unloaded.f[i]);
                def.turn[i] -= b * turned;
            }
        }
    }
}
