//! `base_compliance` in the block kernel: the chassis tilt Δφ = ΔM/k_b about the pivot
//! (docs/model.md §4), ΔM the payload's moment about the pivot at the unloaded load point.

use crate::arm::Arm;
use crate::effects::{Effect, EffectSet};
use crate::lanes::trig::{cos_m1, sincos_deg};
use crate::sweep::fast::{PoseBlock, L};

/// The chassis compliance of an arm.
#[derive(Debug, Clone)]
pub(crate) struct Base {
    /// 1/k_b (rad per N·mm; 0 without the effect).
    compliance: f64,
    pivot: [f64; 2],
    /// O_1 − pivot (mm).
    lever: [f64; 2],
}

impl Base {
    pub(crate) fn new(arm: &Arm, effects: &EffectSet) -> Self {
        let compliance = effects
            .effects()
            .iter()
            .map(|e| match e {
                Effect::BaseCompliance(b) => 1.0 / b.stiffness,
                _ => 0.0,
            })
            .sum();
        Self {
            compliance,
            pivot: [arm.pivot.x, arm.pivot.y],
            lever: [arm.o1.x - arm.pivot.x, arm.o1.y - arm.pivot.y],
        }
    }

    /// The chassis tilts.
    pub(crate) fn on(&self) -> bool {
        self.compliance != 0.0
    }

    /// The tilt of every lane: its angle `phi` (rad), its rotation (sin, cos − 1) in `sr`,
    /// `cm`, and the displacement of O_1 it causes, (R(Δφ) − I)·(O_1 − pivot), in `dx`, `dy`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)] // five lane arrays out
    pub(crate) fn tilt<const N: usize>(
        &self,
        pb: &PoseBlock<N>,
        pay: &[[f64; L]; 2],
        phi: &mut [f64; L],
        sr: &mut [f64; L],
        cm: &mut [f64; L],
        dx: &mut [f64; L],
        dy: &mut [f64; L],
    ) {
        let deg = 180.0 / std::f64::consts::PI;
        let mut phi_deg = [0.0; L];
        for k in 0..L {
            let (lx, ly) = (pb.ex[k] - self.pivot[0], pb.ey[k] - self.pivot[1]);
            phi[k] = (lx * pay[1][k] - ly * pay[0][k]) * self.compliance;
            phi_deg[k] = phi[k] * deg;
        }
        let mut cs = [0.0; L];
        sincos_deg(&phi_deg, sr, &mut cs);
        for k in 0..L {
            cm[k] = cos_m1(sr[k], cs[k]);
            let [qx, qy] = self.lever;
            dx[k] = cm[k] * qx - sr[k] * qy;
            dy[k] = sr[k] * qx + cm[k] * qy;
        }
    }
}
