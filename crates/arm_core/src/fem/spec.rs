//! The physical properties of the FE model, gathered from the arm file and the effects.
//!
//! Every effect of the catalogue becomes a property of an element: a body or mount stiffness
//! of an actuator's bar, a gap (play, clearance), a link's section, the base spring. The
//! analytic core applies the same effects as *causes*; here they are stiffnesses and gaps.

use crate::arm::Arm;
use crate::effects::{Effect, EffectSet, Mechanism, Unloaded};
use crate::error::{ArmError, Result};

/// Penalty factor of a rigid actuator (body and mount both infinitely stiff, e.g. a fit at
/// its bound): its bar is this many times stiffer than the stiffest genuine spring of the
/// model. Rigid links, and the rigid directions of flexible ones, are exact constraints
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

/// Everything the FE model needs besides geometry, one entry per actuator, joint or link.
///
/// An infinite stiffness (the fit's θ = 0) means rigid. Zero stiffnesses are accepted here
/// and found by the factorisation, which names what is then free to move.
#[derive(Debug, Clone, PartialEq)]
pub struct FemSpec {
    /// Axial stiffness of each actuator body (N/mm): the file's, or `actuator_compliance`.
    pub body_stiffness: Vec<f64>,
    /// Series mount stiffness (N/mm), infinite without `mount_compliance`.
    pub mount_stiffness: Vec<f64>,
    /// Axial play of each actuator (mm), `actuator_play`.
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
    /// [`ArmError::Unsupported`] for an arm with a rotary drive.
    pub fn new(arm: &Arm, effects: &EffectSet, sections: &[LinkSection]) -> Result<Self> {
        let n = arm.n();
        if let Some(i) = (0..n).find(|&i| arm.is_rotary(i)) {
            return Err(ArmError::Unsupported(format!(
                "the finite-element model has no rotary drives yet (joint {} is turned by \
                 one): solve this arm with the analytic model",
                i + 1
            )));
        }
        let mut spec = Self {
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
                // An effect set refuses these at a linear actuator, and the arm has no other.
                Effect::DriveCompliance(_) | Effect::DriveBacklash(_) => {
                    return Err(ArmError::InvalidEffect {
                        effect: e.label(),
                        reason: "the FE model has no rotary drives".into(),
                    })
                }
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
        let checks = [
            ("actuator_compliance@M", &self.body_stiffness),
            ("mount_compliance@M", &self.mount_stiffness),
            ("actuator_play@M", &self.play),
            ("joint_clearance@O", &self.clearance),
        ];
        for (label, values) in checks {
            if let Some(i) = values.iter().position(|&v| bad(v)) {
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

    /// Whether any gap (play or clearance) is open to the active-set iteration.
    pub fn has_gaps(&self) -> bool {
        self.play.iter().chain(&self.clearance).any(|&g| g > 0.0)
    }

    /// The stiffest genuine spring of the model expressed in N/mm, for the penalty values:
    /// actuator bodies and mounts, the base over the arm's reach squared, the given sections
    /// over their link's extent (EI/L³, EA/L).
    pub fn stiffness_scale(&self, extent: &[f64]) -> f64 {
        let reach: f64 = extent.iter().sum();
        let mut k = 0.0_f64;
        for &v in self.body_stiffness.iter().chain(&self.mount_stiffness) {
            if v.is_finite() {
                k = k.max(v);
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

    /// Axial stiffness of actuator `i`'s bar: body and mount in series (N/mm); a rigid pair
    /// becomes the penalty stiffness `rigid`.
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
