//! The two friction elements in the block kernel (docs/model.md §9): after the pose stage,
//! each lane's Coulomb elements step from what they held (a fresh memory for `solve`, the
//! sequence's for `solve_sequence`) and the payload case of the block becomes what the springs
//! and pins take: actuator i's force change S of its joint friction, the joint reaction less
//! `δ = (S − ΔF)·e_i`, and for a body friction a further length `(S_joint − S_body)·c_body`
//! that the body's sensor sees. A joint friction's couple bends the links beside it, which
//! the kernel's bending influences do not carry: such sets take the general path.

use crate::arm::Arm;
use crate::effects::{Effect, EffectSet};
use crate::sweep::fast::{PoseBlock, L};

/// The frictions of an effect set, per actuator (a limit of 0 where there is none).
#[derive(Debug, Clone)]
pub(crate) struct Friction<const N: usize> {
    /// Some friction in the set.
    pub(crate) any: bool,
    joint: [Option<f64>; N],
    body: [Option<f64>; N],
    /// Joint i is turned by a rotary drive: its unit load is a couple (limit L itself, no
    /// reaction change).
    rotary: [bool; N],
}

/// What each lane's friction elements hold (N), `[actuator][lane]`.
#[derive(Debug, Clone)]
pub(crate) struct Held<const N: usize> {
    joint: [[f64; L]; N],
    body: [[f64; L]; N],
}

impl<const N: usize> Held<N> {
    /// Nothing held: the reference.
    pub(crate) fn new() -> Self {
        Self {
            joint: [[0.0; L]; N],
            body: [[0.0; L]; N],
        }
    }
}

impl<const N: usize> Friction<N> {
    /// The frictions of `effects`, or `None` when a joint friction sits beside a bent link.
    pub(crate) fn new(arm: &Arm, effects: &EffectSet) -> Option<Self> {
        let mut f = Self {
            any: false,
            joint: [None; N],
            body: [None; N],
            rotary: std::array::from_fn(|i| arm.is_rotary(i)),
        };
        let mut bent = [false; N];
        for e in effects.effects() {
            match e {
                Effect::JointFriction(j) => f.joint[j.joint] = Some(j.torque),
                Effect::ActuatorFriction(a) => f.body[a.actuator] = Some(a.friction),
                Effect::DriveFriction(d) => f.body[d.joint] = Some(d.torque),
                Effect::LinkBending(b) => bent[b.link] = true,
                _ => {}
            }
        }
        for i in 0..N {
            // The couple of joint i acts on link i and on body i−1.
            if f.joint[i].is_some() && (bent[i] || (i > 0 && bent[i - 1])) {
                return None;
            }
        }
        f.any = f.joint.iter().chain(&f.body).any(Option::is_some);
        Some(f)
    }

    /// Steps the first `count` lanes' elements from `held` and rewrites the payload case of
    /// `pb` (`fu`, `ru`) as what the actuators and pins take; `seen[i][k]` is the further
    /// length of actuator i's body that a body friction leaves (mm), `body_c` the bodies'
    /// compliances (mm/N). Inlined into the kernel's instruction-set variant (out of line it
    /// would be compiled for the baseline x86-64).
    #[inline(always)]
    pub(crate) fn step(
        &self,
        pb: &mut PoseBlock<N>,
        held: &mut Held<N>,
        body_c: &[f64; N],
        seen: &mut [[f64; L]; N],
    ) {
        for i in 0..N {
            if let (Some(t), true) = (self.joint[i], self.rotary[i]) {
                // At a drive: a couple in parallel with it, its limit L itself.
                for k in 0..L {
                    let df = pb.fu[i][k];
                    let s = crate::effects::slip(held.joint[i][k], df, t);
                    held.joint[i][k] = s;
                    pb.fu[i][k] = s;
                }
            } else if let Some(t) = self.joint[i] {
                for k in 0..L {
                    let (ex, ey) = (pb.e[0][i][k], pb.e[1][i][k]);
                    // h = (A − O) × e = (B − O) × e, as A − B is along e.
                    let h = pb.d[0][i][k] * ey - pb.d[1][i][k] * ex;
                    let df = pb.fu[i][k];
                    let s = crate::effects::slip(held.joint[i][k], df, t / h.abs());
                    held.joint[i][k] = s;
                    pb.fu[i][k] = s;
                    pb.ru[0][i][k] -= (s - df) * ex;
                    pb.ru[1][i][k] -= (s - df) * ey;
                }
            }
            match self.body[i] {
                Some(lim) => {
                    for k in 0..L {
                        let x = pb.fu[i][k];
                        let s = crate::effects::slip(held.body[i][k], x, lim);
                        held.body[i][k] = s;
                        seen[i][k] = (x - s) * body_c[i];
                    }
                }
                None => seen[i] = [0.0; L],
            }
        }
    }
}
