//! `joint_friction@Oi`: a Coulomb friction torque T (N·mm) in joint pin O_i. Only drive i
//! turns link i against body i−1, so the friction acts in parallel with the whole of drive i.
//! At a linear actuator its limit as a force along the actuator is `T / r_i`,
//! r_i = |(A_i − O_i) × e_i| the moment arm of actuator i about O_i in the unloaded pose; at a
//! rotary drive it is T itself (no moment arm), and the couple it holds is the part of the
//! torque change the drive does not take (the joint reaction does not change: a couple has no
//! resultant). The actuator (body and mount)
//! takes S_i instead of the frictionless change ΔF_i ([`super::SequenceMemory`]); the
//! friction couple `(ΔF_i − S_i)·h_i` (counter-clockwise +, h_i the signed moment arm) acts
//! on link i and the opposite one on body i−1; the joint reaction R_i changes by
//! `−(S_i − ΔF_i)·e_i`, so the actual actuator force `F_i,ref + S_i` and the actual joint
//! force are what a play and a clearance follow.
//!
//! As for [`super::ActuatorFriction`], [`Mechanism::apply`] moves nothing: the memory changes
//! the forces that every other effect reads.

use super::{check_param, check_place, Deformation, EffectContext, Mechanism};
use crate::arm::Arm;
use crate::error::Result;

/// Friction torque (N·mm) of joint `joint` (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointFriction {
    /// 0-based joint index (O_1 is 0).
    pub joint: usize,
    /// Friction torque (N·mm), ≥ 0.
    pub torque: f64,
}

impl JointFriction {
    /// The load of drive i the friction holds at most, given the moment `h` about O_i of a
    /// unit load (`ActuatorLines::arm`): `T / |h|`, an axial force (N) for an actuator of moment
    /// arm h (mm), the torque T itself (N·mm) for a rotary drive (h = 1).
    pub fn limit(&self, h: f64) -> f64 {
        self.torque / h.abs()
    }
}

impl Mechanism for JointFriction {
    fn label(&self) -> String {
        format!("joint_friction@O{}", self.joint + 1)
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        check_place(&self.label(), self.joint, arm)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        self.check_site(arm)?;
        check_param(&self.label(), "torque_nmm", self.torque, true)
    }
    fn apply(&self, _ctx: &EffectContext<'_>, _def: &mut Deformation) {}
}
