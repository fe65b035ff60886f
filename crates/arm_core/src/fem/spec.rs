//! The physical properties of the FE model, gathered from the arm file and the effects.
//!
//! Every effect of the catalogue becomes a property of an element: a body or mount stiffness
//! of an actuator's bar, the torsional stiffness of a rotary drive's spring, a gap (play,
//! backlash, clearance), a link's section, the base spring. The analytic core applies the same
//! effects as *causes*; here they are stiffnesses and gaps. Frictions (history-dependent) and
//! gaps taken up by the unloaded forces are refused, naming the effect.

use crate::arm::Arm;
use crate::effects::{Effect, EffectSet, Mechanism, Unloaded};
use crate::error::{ArmError, Result};

/// Penalty factor of a rigid drive (an actuator's body and mount both infinitely stiff, or a
/// rotary drive's gear, e.g. a fit at its bound): its bar or torsional spring is this many
/// times stiffer than the stiffest genuine spring of the model. Rigid links, and the rigid directions of flexible ones, are exact constraints
/// instead (see `mesh`, `docs/fem.md`).
pub const PENALTY: f64 = 1e6;

/// Section properties of one link, as the arm file gives them (`None`: not given, rigid).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LinkSection {
    /// Flexural rigidity EI (N·mm²).
    pub ei: Option<f64>,
    /// Axial rigidity EA (N).
    pub ea: Option<f64>,
}

/// Everything the FE model needs besides geometry, one entry per drive, joint or link. A
/// drive's entries are in its own units: N/mm and mm for a linear actuator, N·mm/rad and rad
/// for a rotary drive.
///
/// An infinite stiffness (the fit's θ = 0) means rigid. Zero stiffnesses are accepted here
/// and found by the factorisation, which names what is then free to move.
#[derive(Debug, Clone, PartialEq)]
pub struct FemSpec {
    /// Whether a rotary drive turns joint i (else a linear actuator).
    pub rotary: Vec<bool>,
    /// Stiffness of each drive's own spring: an actuator body's axial one (N/mm, the file's
    /// or `actuator_compliance`), a rotary drive's torsional one at its output (N·mm/rad,
    /// the file's or `drive_compliance`).
    pub body_stiffness: Vec<f64>,
    /// Series mount stiffness (N/mm), infinite without `mount_compliance` (and at a rotary
    /// drive).
    pub mount_stiffness: Vec<f64>,
    /// Lost motion of each drive either side of centre: an actuator's axial play (mm,
    /// `actuator_play`), a rotary drive's backlash (rad, `drive_backlash`).
    pub play: Vec<f64>,
    /// Radial clearance of each joint O_i (mm), `joint_clearance`.
    pub clearance: Vec<f64>,
    /// Link sections: the file's `ei_n_mm2`/`ea_n`, EI overridden by `link_bending`.
    pub sections: Vec<LinkSection>,
    /// Rotational stiffness of the base about `base.pivot` (N·mm/rad); `None`: rigid base.
    pub base_stiffness: Option<f64>,
}

impl FemSpec {
    /// Gathers the properties of `arm` with `effects`; `sections` are the arm file's link
    /// sections (empty: none given).
    ///
    /// # Errors
    /// [`ArmError::Shape`] when `sections` has neither 0 nor n entries;
    /// [`ArmError::InvalidArm`] for a negative or NaN section value;
    /// [`ArmError::InvalidEffect`] for a friction or a gap taken up by the unloaded forces.
    pub fn new(arm: &Arm, effects: &EffectSet, sections: &[LinkSection]) -> Result<Self> {
        let n = arm.n();
        let mut spec = Self {
            rotary: (0..n).map(|i| arm.is_rotary(i)).collect(),
            body_stiffness: arm.drives.iter().map(|d| d.stiffness()).collect(),
            mount_stiffness: vec![f64::INFINITY; n],
            play: vec![0.0; n],
            clearance: vec![0.0; n],
            sections: if sections.is_empty() {
                vec![LinkSection::default(); n]
            } else if sections.len() == n {
                sections.to_vec()
            } else {
                return Err(ArmError::Shape {
                    what: "link sections",
                    expected: n,
                    got: sections.len(),
                });
            },
            base_stiffness: None,
        };
        for e in effects.effects() {
            if e.unloaded() == Some(Unloaded::TakenUp) {
                return Err(ArmError::InvalidEffect {
                    effect: format!("{}{}", e.label(), Unloaded::TakenUp.suffix()),
                    reason: "the FE model has only gaps centred when unloaded; solve a gap \
                             taken up by the unloaded forces with the analytic model"
                        .into(),
                });
            }
            match e {
                Effect::ActuatorCompliance(x) => spec.body_stiffness[x.actuator] = x.stiffness,
                Effect::MountCompliance(x) => spec.mount_stiffness[x.actuator] = x.stiffness,
                Effect::ActuatorPlay(x) => spec.play[x.actuator] = x.play,
                Effect::JointClearance(x) => spec.clearance[x.joint] = x.clearance,
                Effect::LinkBending(x) => spec.sections[x.link].ei = Some(x.ei),
                Effect::BaseCompliance(x) => spec.base_stiffness = Some(x.stiffness),
                // An effect set has checked that these sit at rotary drives.
                Effect::DriveCompliance(x) => spec.body_stiffness[x.joint] = x.stiffness,
                Effect::DriveBacklash(x) => spec.play[x.joint] = x.backlash_deg.to_radians(),
                Effect::ActuatorFriction(_)
                | Effect::JointFriction(_)
                | Effect::DriveFriction(_) => {
                    return Err(ArmError::InvalidEffect {
                        effect: e.label(),
                        reason: "the FE model has no friction; solve it with the analytic model"
                            .into(),
                    })
                }
            }
        }
        // An infinite section or base stiffness is the same as none given: rigid.
        let finite = |v: &f64| *v != f64::INFINITY;
        for s in &mut spec.sections {
            s.ei = s.ei.filter(finite);
            s.ea = s.ea.filter(finite);
        }
        spec.base_stiffness = spec.base_stiffness.filter(finite);
        spec.validate()?;
        Ok(spec)
    }

    /// Refuses NaN and negative values, naming the arm-file key or effect.
    ///
    /// # Errors
    /// [`ArmError::InvalidArm`] or [`ArmError::InvalidEffect`].
    pub fn validate(&self) -> Result<()> {
        let bad = |v: f64| v.is_nan() || v < 0.0;
        for (i, s) in self.sections.iter().enumerate() {
            for (name, v) in [("ei_n_mm2", s.ei), ("ea_n", s.ea)] {
                if let Some(v) = v {
                    if bad(v) {
                        return Err(ArmError::InvalidArm {
                            key: format!("link[{}].{name}", i + 1),
                            reason: format!("must be >= 0, got {v}"),
                        });
                    }
                }
            }
        }
        // (label at a linear actuator, label at a rotary drive)
        let checks = [
            (
                ("actuator_compliance@M", "drive_compliance@O"),
                &self.body_stiffness,
            ),
            (
                ("mount_compliance@M", "mount_compliance@M"),
                &self.mount_stiffness,
            ),
            (("actuator_play@M", "drive_backlash@O"), &self.play),
            (("joint_clearance@O", "joint_clearance@O"), &self.clearance),
        ];
        for ((linear, rotary), values) in checks {
            if let Some(i) = values.iter().position(|&v| bad(v)) {
                let label = if self.rotary.get(i) == Some(&true) {
                    rotary
                } else {
                    linear
                };
                return Err(ArmError::InvalidEffect {
                    effect: format!("{label}{}", i + 1),
                    reason: format!("value must be >= 0, got {}", values[i]),
                });
            }
        }
        if let Some(k) = self.base_stiffness {
            if bad(k) {
                return Err(ArmError::InvalidEffect {
                    effect: "base_compliance@base".into(),
                    reason: format!("stiffness must be >= 0, got {k}"),
                });
            }
        }
        Ok(())
    }

    /// Whether link `i` is modelled with beam elements (some section given) rather than as
    /// one rigid body.
    #[inline]
    pub fn flexible(&self, i: usize) -> bool {
        self.sections[i].ei.is_some() || self.sections[i].ea.is_some()
    }

    /// Whether any gap (play, backlash or clearance) is open to the active-set iteration.
    pub fn has_gaps(&self) -> bool {
        self.play.iter().chain(&self.clearance).any(|&g| g > 0.0)
    }

    /// The stiffest genuine spring of the model expressed in N/mm, for the penalty values:
    /// actuator bodies and mounts, rotary drives and the base over the arm's reach squared,
    /// the given sections over their link's extent (EI/L³, EA/L).
    pub fn stiffness_scale(&self, extent: &[f64]) -> f64 {
        let reach: f64 = extent.iter().sum();
        let mut k = 0.0_f64;
        for (i, (&body, &mount)) in self
            .body_stiffness
            .iter()
            .zip(&self.mount_stiffness)
            .enumerate()
        {
            let per = if self.rotary[i] { reach * reach } else { 1.0 };
            for v in [body / per, mount] {
                if v.is_finite() {
                    k = k.max(v);
                }
            }
        }
        if let Some(kb) = self.base_stiffness {
            k = k.max(kb / (reach * reach));
        }
        for (s, &l) in self.sections.iter().zip(extent) {
            if let Some(ei) = s.ei {
                k = k.max(ei / (l * l * l));
            }
            if let Some(ea) = s.ea {
                k = k.max(ea / l);
            }
        }
        if k > 0.0 {
            k
        } else {
            1.0
        }
    }

    /// Stiffness of drive `i`'s element: an actuator's bar, body and mount in series (N/mm),
    /// or a rotary drive's torsional spring (N·mm/rad); a rigid one becomes the penalty
    /// stiffness `rigid` (in its own unit).
    pub fn bar_stiffness(&self, i: usize, rigid: f64) -> f64 {
        let compliance = recip(self.body_stiffness[i]) + recip(self.mount_stiffness[i]);
        if compliance > 0.0 {
            1.0 / compliance
        } else {
            rigid
        }
    }
}

/// `1/k` with `1/∞ = 0` and `1/0 = ∞`.
#[inline]
pub(crate) fn recip(k: f64) -> f64 {
    if k.is_infinite() {
        0.0
    } else {
        1.0 / k
    }
}
