//! `actuator_play@Mi`: axial free play of actuator i. Loaded, the pin-to-pin length changes by
//! `−play·sign(F_i)` (the loaded force) when the play is centred in the unloaded state, or by
//! `−play·(sign(F_i) − sign(F0_i))` when the unloaded force F0_i (self-weight) had already
//! taken it up ([`Unloaded`]). Either way bounded by the play (twice it, taken up) whatever
//! the load.

use super::{check_drive, check_param, sign0, Deformation, EffectContext, Mechanism, Unloaded};
use crate::arm::Arm;
use crate::error::Result;

/// Axial play (mm) of actuator `actuator` (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorPlay {
    /// 0-based actuator index.
    pub actuator: usize,
    /// Half-range of the free axial motion (mm), ≥ 0.
    pub play: f64,
    /// Where the play sits in the unloaded state.
    pub unloaded: Unloaded,
}

impl Mechanism for ActuatorPlay {
    fn label(&self) -> String {
        format!("actuator_play@M{}", self.actuator + 1)
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        let instead = format!("drive_backlash@O{}", self.actuator + 1);
        check_drive(&self.label(), self.actuator, arm, false, &instead)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        self.check_site(arm)?;
        check_param(&self.label(), "play_mm", self.play, true)
    }
    fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation) {
        let i = self.actuator;
        match self.unloaded {
            Unloaded::Centred => def.extra_length[i] -= self.play * sign0(ctx.loaded.f[i]),
            Unloaded::TakenUp => {
                let turned = sign0(ctx.loaded.f[i]) - sign0(ctx.unloaded.f[i]);
                def.extra_length[i] -= self.play * turned;
            }
        }
    }
}
