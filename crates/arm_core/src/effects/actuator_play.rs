//! `actuator_play@Mi`: axial free play, centred when unloaded. Loaded, the pin-to-pin length
//! changes by `−play·sign(F_i)` (the loaded force); bounded by the play whatever the load.

use super::{check_param, check_place, sign0, Deformation, EffectContext, Mechanism};
use crate::arm::Arm;
use crate::error::Result;

/// Axial play (mm) of actuator `actuator` (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorPlay {
    /// 0-based actuator index.
    pub actuator: usize,
    /// Half-range of the free axial motion (mm), ≥ 0.
    pub play: f64,
}

impl Mechanism for ActuatorPlay {
    fn label(&self) -> String {
        format!("actuator_play@M{}", self.actuator + 1)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        check_place(&self.label(), self.actuator, arm)?;
        check_param(&self.label(), "play_mm", self.play, true)
    }
    fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation) {
        let i = self.actuator;
        def.extra_length[i] -= self.play * sign0(ctx.loaded.f[i]);
    }
}
