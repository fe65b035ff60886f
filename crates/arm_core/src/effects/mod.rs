//! The catalogue of physical effects (docs/model.md §4), one module each.
//!
//! An effect never moves anything itself: it adds its *cause* to a [`Deformation`] (a length
//! change, a pin offset, a pin displacement field, a chassis tilt) computed from the statics
//! of the undeformed pose. [`crate::pose`] then closes the loaded pose exactly with all causes
//! at once. Adding an effect means one new module and one line in [`Effect`].

mod actuator_compliance;
mod actuator_friction;
mod actuator_play;
mod base_compliance;
mod drive_backlash;
mod drive_compliance;
mod drive_friction;
mod extra;
mod joint_clearance;
mod joint_friction;
mod link_bending;
mod memory;
mod mount_compliance;

pub use actuator_compliance::ActuatorCompliance;
pub use actuator_friction::ActuatorFriction;
pub use actuator_play::ActuatorPlay;
pub use base_compliance::BaseCompliance;
pub use drive_backlash::DriveBacklash;
pub use drive_compliance::DriveCompliance;
pub use drive_friction::DriveFriction;
pub use extra::ExtraDeformations;
pub use joint_clearance::JointClearance;
pub use joint_friction::JointFriction;
pub(crate) use link_bending::BendInfluence;
pub use link_bending::LinkBending;
pub use memory::{slip, SequenceMemory};
pub use mount_compliance::MountCompliance;

use crate::arm::{Arm, Drive};
use crate::error::{ArmError, Result};
use crate::geometry::V2;
use crate::kinematics::Frames;
use crate::statics::{ActuatorLines, Forces};

/// What an effect may read: the undeformed pose and its statics.
#[derive(Debug, Clone, Copy)]
pub struct EffectContext<'a> {
    /// The arm.
    pub arm: &'a Arm,
    /// Undeformed global geometry.
    pub frames: &'a Frames,
    /// Actuator directions and moment arms.
    pub lines: &'a ActuatorLines,
    /// Forces in the unloaded state (self-weight, if any; zero without).
    pub unloaded: &'a Forces,
    /// Forces in the loaded state (self-weight, if any, plus payload).
    pub loaded: &'a Forces,
    /// Change of forces from the unloaded to the loaded state (what the drives take, when a
    /// joint friction holds part of it).
    pub delta: &'a Forces,
    /// Payload force at the load point (N, global).
    pub payload: V2,
    /// Friction couple on link i at O_i (N·mm, counter-clockwise +; the opposite one acts on
    /// body i−1): zero without a joint friction ([`SequenceMemory::step`]).
    pub couple: &'a [f64],
}

impl EffectContext<'_> {
    /// The change of the whole couple at O_i on link i (N·mm, counter-clockwise +; the opposite
    /// one acts on body i−1): a joint friction's, plus the torque change of a rotary drive
    /// (together ΔT_i, whatever the friction holds); a linear actuator's force acts at its pins.
    pub fn joint_couple(&self, i: usize) -> f64 {
        match self.arm.drives[i] {
            Drive::Linear(_) => self.couple[i],
            Drive::Rotary(_) => self.couple[i] + self.delta.f[i],
        }
    }
}

/// Displacements of a link's named points, in the link's own frame (mm), and the turn of its
/// axis at its next joint.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PinShift {
    /// Of the actuator pin A_i.
    pub a: V2,
    /// Of the next actuator's base pin B_i.
    pub b: V2,
    /// Of the next joint (or load point).
    pub next: V2,
    /// Of the measurement point (last link only).
    pub measure: V2,
    /// Slope v′ of the bent axis at the next joint (rad, counter-clockwise + in the link's
    /// frame): the housing of a rotary drive there turns with it.
    pub slope_next: f64,
}

/// The causes of deformation of one pose, summed over the effects.
#[derive(Debug, Clone, Default)]
pub struct Deformation {
    /// Compliance of each drive's own spring: of an actuator body (mm/N; the `dlK_mm` sensor
    /// sees `−ΔF·this`), of a rotary drive's gear (rad/(N·mm): `Δq = −ΔT·this`).
    pub body_compliance: Vec<f64>,
    /// Further pin-to-pin length change of each actuator that its sensor sees (mm), on top of
    /// the body's `−ΔF·body_compliance`.
    pub seen_length: Vec<f64>,
    /// Further pin-to-pin length change of each actuator, unseen by its sensor (mm).
    pub extra_length: Vec<f64>,
    /// Further turn of link i against body i−1 at a rotary drive (rad, counter-clockwise +),
    /// on top of the gear's `−ΔT·body_compliance`: backlash, user-written turns.
    pub turn: Vec<f64>,
    /// Offset of link i's joint from its bore in body i−1, global frame (mm).
    pub joint_offset: Vec<V2>,
    /// Bending displacement of each link's pins, in its frame (mm).
    pub pin_shift: Vec<PinShift>,
    /// Counter-clockwise tilt of the chassis about the pivot (rad).
    pub base_tilt: f64,
    /// Further displacement of the measurement point, global frame (mm), added after the pose
    /// is closed (it moves no link).
    pub measure_shift: V2,
}

impl Deformation {
    /// Sized for `arm`, holding the baseline (file stiffness, nothing else).
    pub fn new(arm: &Arm) -> Self {
        let n = arm.n();
        let mut d = Self {
            body_compliance: vec![0.0; n],
            seen_length: vec![0.0; n],
            extra_length: vec![0.0; n],
            turn: vec![0.0; n],
            joint_offset: vec![V2::zeros(); n],
            pin_shift: vec![PinShift::default(); n],
            base_tilt: 0.0,
            measure_shift: V2::zeros(),
        };
        d.reset(arm);
        d
    }

    /// Back to the baseline model.
    pub fn reset(&mut self, arm: &Arm) {
        for (c, d) in self.body_compliance.iter_mut().zip(&arm.drives) {
            *c = 1.0 / d.stiffness();
        }
        self.seen_length.fill(0.0);
        self.extra_length.fill(0.0);
        self.turn.fill(0.0);
        self.joint_offset.fill(V2::zeros());
        self.pin_shift.fill(PinShift::default());
        self.base_tilt = 0.0;
        self.measure_shift = V2::zeros();
    }
}

/// What the unloaded state did to a gap (actuator play, drive backlash, joint clearance):
/// docs/model.md §4.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Unloaded {
    /// The gap is centred in the unloaded state: loaded, the whole offset appears along the
    /// loaded force (even at zero payload when the weights load the joint).
    #[default]
    Centred,
    /// The unloaded forces (self-weight) already closed the gap: loaded, only the change of
    /// the offset shows, loaded offset minus unloaded offset (zero at zero payload).
    TakenUp,
}

impl Unloaded {
    /// The suffix of an effect's label in messages: `""` or `" (taken up)"`.
    pub fn suffix(self) -> &'static str {
        match self {
            Self::Centred => "",
            Self::TakenUp => " (taken up)",
        }
    }
}

/// One physical mechanism at one place.
pub trait Mechanism {
    /// `name@place`, as the CLI writes it.
    fn label(&self) -> String;
    /// Checks the place against `arm`: it exists, and its joint has the kind of drive the
    /// effect acts on.
    ///
    /// # Errors
    /// [`ArmError::InvalidEffect`].
    fn check_site(&self, arm: &Arm) -> Result<()>;
    /// Checks the parameter and the place against `arm`.
    ///
    /// # Errors
    /// [`ArmError::InvalidEffect`].
    fn check(&self, arm: &Arm) -> Result<()>;
    /// Adds this effect's cause to `def`.
    fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation);
}

/// Code of `actuator_play` with [`Unloaded::TakenUp`] (2 is the centred one).
pub const CODE_PLAY_TAKEN_UP: i64 = 6;
/// Code of `joint_clearance` with [`Unloaded::TakenUp`] (3 is the centred one).
pub const CODE_CLEARANCE_TAKEN_UP: i64 = 7;

/// Code of `actuator_friction` (docs/model.md §9).
pub const CODE_ACTUATOR_FRICTION: i64 = 8;
/// Code of `joint_friction` (docs/model.md §9).
pub const CODE_JOINT_FRICTION: i64 = 9;
/// Code of `drive_compliance` (docs/model.md §10).
pub const CODE_DRIVE_COMPLIANCE: i64 = 10;
/// Code of `drive_backlash`, centred when unloaded (docs/model.md §10).
pub const CODE_DRIVE_BACKLASH: i64 = 11;
/// Code of `drive_backlash` with [`Unloaded::TakenUp`].
pub const CODE_BACKLASH_TAKEN_UP: i64 = 12;
/// Code of `drive_friction` (docs/model.md §10).
pub const CODE_DRIVE_FRICTION: i64 = 13;

/// Every effect of the catalogue.
#[derive(Debug, Clone, PartialEq)]
pub enum Effect {
    /// `actuator_compliance@Mi`.
    ActuatorCompliance(ActuatorCompliance),
    /// `mount_compliance@Mi`.
    MountCompliance(MountCompliance),
    /// `actuator_play@Mi`.
    ActuatorPlay(ActuatorPlay),
    /// `joint_clearance@Oi`.
    JointClearance(JointClearance),
    /// `link_bending@Li`.
    LinkBending(LinkBending),
    /// `base_compliance@base`.
    BaseCompliance(BaseCompliance),
    /// `actuator_friction@Mi`.
    ActuatorFriction(ActuatorFriction),
    /// `joint_friction@Oi`.
    JointFriction(JointFriction),
    /// `drive_compliance@Oi`.
    DriveCompliance(DriveCompliance),
    /// `drive_backlash@Oi`.
    DriveBacklash(DriveBacklash),
    /// `drive_friction@Oi`.
    DriveFriction(DriveFriction),
}

impl Effect {
    /// Builds an effect from the binding's code, 0-based place index and parameter value (in
    /// the parameter's own unit: `backlash_deg` in degrees). The codes:
    ///
    /// | code | effect | place | parameter |
    /// |---|---|---|---|
    /// | 0 | `actuator_compliance` | M | `stiffness_n_per_mm` |
    /// | 1 | `mount_compliance` | M | `stiffness_n_per_mm` |
    /// | 2, 6 | `actuator_play` (6: taken up) | M | `play_mm` |
    /// | 3, 7 | `joint_clearance` (7: taken up) | O | `clearance_mm` |
    /// | 4 | `link_bending` | L | `ei_n_mm2` |
    /// | 5 | `base_compliance` | base | `stiffness_nmm_per_rad` |
    /// | 8 | `actuator_friction` | M | `friction_n` |
    /// | 9 | `joint_friction` | O | `torque_nmm` |
    /// | 10 | `drive_compliance` | O | `stiffness_nmm_per_rad` |
    /// | 11, 12 | `drive_backlash` (12: taken up) | O | `backlash_deg` |
    /// | 13 | `drive_friction` | O | `torque_nmm` |
    ///
    /// # Errors
    /// [`ArmError::InvalidEffect`] for an unknown code.
    pub fn from_code(code: i64, index: usize, value: f64) -> Result<Self> {
        Ok(match code {
            0 => Self::ActuatorCompliance(ActuatorCompliance {
                actuator: index,
                stiffness: value,
            }),
            1 => Self::MountCompliance(MountCompliance {
                actuator: index,
                stiffness: value,
            }),
            2 | CODE_PLAY_TAKEN_UP => Self::ActuatorPlay(ActuatorPlay {
                actuator: index,
                play: value,
                unloaded: Self::unloaded_of(code),
            }),
            3 | CODE_CLEARANCE_TAKEN_UP => Self::JointClearance(JointClearance {
                joint: index,
                clearance: value,
                unloaded: Self::unloaded_of(code),
            }),
            4 => Self::LinkBending(LinkBending {
                link: index,
                ei: value,
            }),
            5 => Self::BaseCompliance(BaseCompliance { stiffness: value }),
            CODE_ACTUATOR_FRICTION => Self::ActuatorFriction(ActuatorFriction {
                actuator: index,
                friction: value,
            }),
            CODE_JOINT_FRICTION => Self::JointFriction(JointFriction {
                joint: index,
                torque: value,
            }),
            CODE_DRIVE_COMPLIANCE => Self::DriveCompliance(DriveCompliance {
                joint: index,
                stiffness: value,
            }),
            CODE_DRIVE_BACKLASH | CODE_BACKLASH_TAKEN_UP => Self::DriveBacklash(DriveBacklash {
                joint: index,
                backlash_deg: value,
                unloaded: Self::unloaded_of(code),
            }),
            CODE_DRIVE_FRICTION => Self::DriveFriction(DriveFriction {
                joint: index,
                torque: value,
            }),
            _ => {
                return Err(ArmError::InvalidEffect {
                    effect: format!("code {code}"),
                    reason: "unknown effect code".into(),
                })
            }
        })
    }

    /// The gap mode a code stands for (only 6, 7 and 12 are taken up).
    pub(crate) fn unloaded_of(code: i64) -> Unloaded {
        if matches!(
            code,
            CODE_PLAY_TAKEN_UP | CODE_CLEARANCE_TAKEN_UP | CODE_BACKLASH_TAKEN_UP
        ) {
            Unloaded::TakenUp
        } else {
            Unloaded::Centred
        }
    }

    /// The gap mode of a play, backlash or clearance; `None` for the other effects.
    pub fn unloaded(&self) -> Option<Unloaded> {
        match self {
            Self::ActuatorPlay(e) => Some(e.unloaded),
            Self::JointClearance(e) => Some(e.unloaded),
            Self::DriveBacklash(e) => Some(e.unloaded),
            _ => None,
        }
    }

    fn inner(&self) -> &dyn Mechanism {
        match self {
            Self::ActuatorCompliance(e) => e,
            Self::MountCompliance(e) => e,
            Self::ActuatorPlay(e) => e,
            Self::JointClearance(e) => e,
            Self::LinkBending(e) => e,
            Self::BaseCompliance(e) => e,
            Self::ActuatorFriction(e) => e,
            Self::JointFriction(e) => e,
            Self::DriveCompliance(e) => e,
            Self::DriveBacklash(e) => e,
            Self::DriveFriction(e) => e,
        }
    }
}

impl Mechanism for Effect {
    fn label(&self) -> String {
        self.inner().label()
    }
    fn check_site(&self, arm: &Arm) -> Result<()> {
        self.inner().check_site(arm)
    }
    fn check(&self, arm: &Arm) -> Result<()> {
        self.inner().check(arm)
    }
    fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation) {
        self.inner().apply(ctx, def)
    }
}

/// A validated set of effects for one arm: every place exists, no effect twice at a place.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EffectSet {
    effects: Vec<Effect>,
}

impl EffectSet {
    /// Validates `effects` against `arm`.
    ///
    /// # Errors
    /// [`ArmError::InvalidEffect`] naming the effect.
    pub fn new(arm: &Arm, effects: Vec<Effect>) -> Result<Self> {
        for (i, e) in effects.iter().enumerate() {
            e.check(arm)?;
            if effects[..i].iter().any(|p| p.label() == e.label()) {
                return Err(ArmError::InvalidEffect {
                    effect: e.label(),
                    reason: "given twice".into(),
                });
            }
        }
        Ok(Self { effects })
    }

    /// Builds a set without checking parameters (places, the kinds of drive they need and
    /// duplicates are still checked). Used for finite differences, where a parameter may step
    /// below zero.
    ///
    /// # Errors
    /// [`ArmError::InvalidEffect`] for a place beyond the arm or of the wrong kind, or an
    /// effect given twice.
    pub fn new_unchecked(arm: &Arm, effects: Vec<Effect>) -> Result<Self> {
        for (i, e) in effects.iter().enumerate() {
            e.check_site(arm)?;
            if effects[..i].iter().any(|p| p.label() == e.label()) {
                return Err(ArmError::InvalidEffect {
                    effect: e.label(),
                    reason: "given twice".into(),
                });
            }
        }
        Ok(Self { effects })
    }

    /// The baseline model: no effect.
    pub fn empty() -> Self {
        Self::default()
    }

    /// Whether a friction element (with history) is among the effects.
    pub fn has_friction(&self) -> bool {
        self.effects.iter().any(|e| {
            matches!(
                e,
                Effect::ActuatorFriction(_) | Effect::JointFriction(_) | Effect::DriveFriction(_)
            )
        })
    }

    /// The effects, in the order given.
    pub fn effects(&self) -> &[Effect] {
        &self.effects
    }

    /// Resets `def` to the baseline and applies every effect.
    pub fn apply(&self, ctx: &EffectContext<'_>, def: &mut Deformation) {
        def.reset(ctx.arm);
        for e in &self.effects {
            e.apply(ctx, def);
        }
    }
}

/// Shared parameter/place checks of the effect modules.
pub(crate) fn check_param(label: &str, name: &str, value: f64, allow_zero: bool) -> Result<()> {
    let ok = value.is_finite() && (value > 0.0 || (allow_zero && value == 0.0));
    if ok {
        Ok(())
    } else {
        Err(ArmError::InvalidEffect {
            effect: label.to_owned(),
            reason: format!(
                "{name} must be finite and {}, got {value}",
                if allow_zero { ">= 0" } else { "> 0" }
            ),
        })
    }
}

pub(crate) fn check_place(label: &str, index: usize, arm: &Arm) -> Result<()> {
    if index < arm.n() {
        Ok(())
    } else {
        Err(ArmError::InvalidEffect {
            effect: label.to_owned(),
            reason: format!("the arm has only {} links", arm.n()),
        })
    }
}

/// Checks that joint `index` (0-based, in range) is turned by a rotary drive (`rotary`) or a
/// linear actuator (`!rotary`), the kind the effect `label` acts on; else an error naming the
/// joint's kind and the effect `instead` that applies there (e.g. `drive_compliance@O2`).
pub(crate) fn check_drive(
    label: &str,
    index: usize,
    arm: &Arm,
    rotary: bool,
    instead: &str,
) -> Result<()> {
    check_place(label, index, arm)?;
    if arm.is_rotary(index) == rotary {
        return Ok(());
    }
    let kind = if rotary {
        "a linear actuator"
    } else {
        "a rotary drive"
    };
    Err(ArmError::InvalidEffect {
        effect: label.to_owned(),
        reason: format!(
            "joint {} is turned by {kind}: use {instead} there",
            index + 1
        ),
    })
}

/// A force below this magnitude (N) has no physical direction: play and clearance stay
/// centred rather than follow rounding noise (docs/model.md).
pub const FORCE_ZERO_N: f64 = 1e-9;

/// A torque below this magnitude (N·mm) has no physical direction: a backlash stays centred
/// rather than follow rounding noise. It is [`FORCE_ZERO_N`] at a lever of 1 m: a drive's
/// torque is a force times a lever of the arm's size, so its rounding noise is that much
/// larger than a force's (docs/model.md §10).
pub const TORQUE_ZERO_NMM: f64 = 1e-6;

/// `sign(x)`, 0 for `|x| < FORCE_ZERO_N`.
#[inline]
pub(crate) fn sign0(x: f64) -> f64 {
    sign_above(x, FORCE_ZERO_N)
}

/// `sign(x)`, 0 for `|x| < zero`.
#[inline]
pub(crate) fn sign_above(x: f64, zero: f64) -> f64 {
    if x >= zero {
        1.0
    } else if x <= -zero {
        -1.0
    } else {
        0.0
    }
}
