//! Predicted measurement channels and their sensitivities to effect parameters, for fitting.
//!
//! Every effect is written with a *compliance-like* parameter θ in which its deflection is
//! (nearly) linear: `1/k` for springs (mm/N; rad/(N·mm) for a rotary drive's gear and the
//! base), `1/EI` for bending (1/(N·mm²)), and the gap itself for clearance and play (mm) and
//! backlash (degrees); a friction's limit itself (N, N·mm). θ = 0 is "absent", except for
//! `actuator_compliance` and `drive_compliance`, whose θ replaces the drive's own `1/k_i`.
//!
//! The sensitivity `∂y/∂θ_j` of every channel is a central difference of the exact solve,
//! taken inside the core in one pass over the poses. The response is linear in θ up to the
//! geometric nonlinearity of the pose closure, so the central difference is exact to ~1e-9
//! relative, whatever the step.
//!
//! The 2P + 1 effect sets (the model, then the model with θ_j ± h_j for every probe) are solved
//! by the block kernel of `solve` for arms of 1–6 links ([`block`]), chunk by chunk in
//! parallel; longer arms, and the rows the kernel cannot solve, go through the general path
//! pose by pose ([`general`], also the reference [`jacobian_batch_general`]).

mod block;
mod general;
mod jacobian;

pub use jacobian::{jacobian_batch, jacobian_batch_general};

use crate::arm::Arm;
use crate::effects::{
    ActuatorCompliance, ActuatorFriction, ActuatorPlay, BaseCompliance, DriveBacklash,
    DriveCompliance, DriveFriction, Effect, EffectSet, JointClearance, JointFriction, LinkBending,
    MountCompliance, CODE_ACTUATOR_FRICTION, CODE_BACKLASH_TAKEN_UP, CODE_CLEARANCE_TAKEN_UP,
    CODE_DRIVE_BACKLASH, CODE_DRIVE_COMPLIANCE, CODE_DRIVE_FRICTION, CODE_JOINT_FRICTION,
    CODE_PLAY_TAKEN_UP,
};
use crate::error::{ArmError, Result};
use crate::solve::{check_input, BatchInput};

/// An effect kind and place, by the catalogue code (as in `Effect::from_code`) and 0-based index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Place {
    /// Catalogue code: 0 actuator_compliance, 1 mount_compliance, 2 actuator_play,
    /// 3 joint_clearance, 4 link_bending, 5 base_compliance; 6 actuator_play and
    /// 7 joint_clearance taken up by the unloaded forces (`Unloaded::TakenUp`); 8
    /// actuator_friction and 9 joint_friction (θ the limit itself, N or N·mm); 10
    /// drive_compliance, 11 drive_backlash (12 taken up; θ in degrees), 13 drive_friction
    /// (θ in N·mm).
    pub code: i64,
    /// 0-based place index (0 for the base).
    pub index: usize,
}

/// Builds an effect from its compliance-like parameter θ, without range checks: negative θ
/// is allowed so that central differences can straddle θ = 0.
///
/// # Errors
/// [`ArmError::InvalidEffect`] for an unknown code.
pub fn effect_from_theta(place: Place, theta: f64) -> Result<Effect> {
    let inv = |t: f64| if t == 0.0 { f64::INFINITY } else { 1.0 / t };
    let i = place.index;
    Ok(match place.code {
        0 => Effect::ActuatorCompliance(ActuatorCompliance {
            actuator: i,
            stiffness: inv(theta),
        }),
        1 => Effect::MountCompliance(MountCompliance {
            actuator: i,
            stiffness: inv(theta),
        }),
        2 | CODE_PLAY_TAKEN_UP => Effect::ActuatorPlay(ActuatorPlay {
            actuator: i,
            play: theta,
            unloaded: Effect::unloaded_of(place.code),
        }),
        3 | CODE_CLEARANCE_TAKEN_UP => Effect::JointClearance(JointClearance {
            joint: i,
            clearance: theta,
            unloaded: Effect::unloaded_of(place.code),
        }),
        4 => Effect::LinkBending(LinkBending {
            link: i,
            ei: inv(theta),
        }),
        5 => Effect::BaseCompliance(BaseCompliance {
            stiffness: inv(theta),
        }),
        CODE_ACTUATOR_FRICTION => Effect::ActuatorFriction(ActuatorFriction {
            actuator: i,
            friction: theta,
        }),
        CODE_JOINT_FRICTION => Effect::JointFriction(JointFriction {
            joint: i,
            torque: theta,
        }),
        CODE_DRIVE_COMPLIANCE => Effect::DriveCompliance(DriveCompliance {
            joint: i,
            stiffness: inv(theta),
        }),
        CODE_DRIVE_BACKLASH | CODE_BACKLASH_TAKEN_UP => Effect::DriveBacklash(DriveBacklash {
            joint: i,
            backlash_deg: theta,
            unloaded: Effect::unloaded_of(place.code),
        }),
        CODE_DRIVE_FRICTION => Effect::DriveFriction(DriveFriction {
            joint: i,
            torque: theta,
        }),
        c => {
            return Err(ArmError::InvalidEffect {
                effect: format!("code {c}"),
                reason: "unknown effect code".into(),
            })
        }
    })
}

/// `1/k` (mm/N, rad/(N·mm)) of the drive at a place, 0 beyond the arm.
fn drive_compliance(arm: &Arm, place: Place) -> f64 {
    arm.drives
        .get(place.index)
        .map_or(0.0, |d| 1.0 / d.stiffness())
}

/// The θ of a place when it is not in the model (absent; the file's `1/k` for an actuator body
/// or a rotary drive's gear).
pub fn neutral_theta(arm: &Arm, place: Place) -> f64 {
    if place.code == 0 || place.code == CODE_DRIVE_COMPLIANCE {
        drive_compliance(arm, place)
    } else {
        0.0
    }
}

/// A typical θ of a place, used to size the difference step.
fn typical_theta(arm: &Arm, place: Place) -> f64 {
    match place.code {
        0 | 1 | CODE_DRIVE_COMPLIANCE => drive_compliance(arm, place),
        2 | 3 | CODE_PLAY_TAKEN_UP | CODE_CLEARANCE_TAKEN_UP => 0.1,
        // A backlash of 0.1°: a step of 10⁻⁴°.
        CODE_DRIVE_BACKLASH | CODE_BACKLASH_TAKEN_UP => 0.1,
        4 => 1e-10,
        // A friction's θ is its limit: a step of 0.01 N or 1 N·mm.
        CODE_ACTUATOR_FRICTION => 10.0,
        CODE_JOINT_FRICTION | CODE_DRIVE_FRICTION => 1000.0,
        _ => 1e-8,
    }
}

/// The θ at which `probe` is differentiated (its θ in `model`, else its neutral θ) and the
/// step h of the central difference: 10⁻³ of the larger of |θ| and a typical θ of the place.
pub fn step(arm: &Arm, model: &[(Place, f64)], probe: Place) -> (f64, f64) {
    let at = model
        .iter()
        .find(|(pl, _)| *pl == probe)
        .map_or_else(|| neutral_theta(arm, probe), |m| m.1);
    (at, 1e-3 * at.abs().max(typical_theta(arm, probe)))
}

/// Number of channels of an `n`-link arm: dx, dy, dα₁…dαₙ, dl₁…dlₙ.
pub fn n_channels(n: usize) -> usize {
    2 + 2 * n
}

/// Cuts `y` (N × C) and `jac` (N × C × P) into chunks of `rows` rows: (first row, its rows of
/// `y`, its rows of `jac`, empty when P = 0).
fn row_chunks<'a>(
    y: &'a mut [f64],
    jac: &'a mut [f64],
    rows: usize,
    c: usize,
    p: usize,
) -> Vec<(usize, &'a mut [f64], &'a mut [f64])> {
    let mut chunks = Vec::new();
    let mut jac_rest = jac;
    for (k, yc) in y.chunks_mut(rows * c).enumerate() {
        let (jc, rest) = std::mem::take(&mut jac_rest).split_at_mut(yc.len() * p);
        jac_rest = rest;
        chunks.push((k * rows, yc, jc));
    }
    chunks
}

/// The first of the chunks' errors, which come back in order: the lowest failing row's.
fn first_error(errors: Vec<ArmError>) -> Result<()> {
    errors.into_iter().next().map_or(Ok(()), Err)
}

/// The checked batch and its effect sets: the model, then for every probe the model with
/// θ_j + h_j and with θ_j − h_j.
struct Sets {
    /// `N`, the rows of the batch.
    rows: usize,
    /// `C`, the channels.
    channels: usize,
    /// `[model, plus_0, minus_0, plus_1, …]`: 2P + 1 sets.
    sets: Vec<EffectSet>,
    /// The step h_j of every probe.
    steps: Vec<f64>,
}

impl Sets {
    fn new(
        arm: &Arm,
        model: &[(Place, f64)],
        probes: &[Place],
        input: &BatchInput<'_>,
        y: &[f64],
        jac: &[f64],
    ) -> Result<Self> {
        let rows = check_input(arm, input)?;
        let c = n_channels(arm.n());
        let p = probes.len();
        if y.len() != rows * c {
            return Err(ArmError::Shape {
                what: "y",
                expected: rows * c,
                got: y.len(),
            });
        }
        if jac.len() != rows * c * p {
            return Err(ArmError::Shape {
                what: "jac",
                expected: rows * c * p,
                got: jac.len(),
            });
        }
        let build = |over: Option<(Place, f64)>| -> Result<EffectSet> {
            let mut effects = Vec::with_capacity(model.len() + 1);
            let mut seen = false;
            for &(pl, th) in model {
                let th = match over {
                    Some((q, t)) if q == pl => {
                        seen = true;
                        t
                    }
                    _ => th,
                };
                effects.push(effect_from_theta(pl, th)?);
            }
            if let (Some((q, t)), false) = (over, seen) {
                effects.push(effect_from_theta(q, t)?);
            }
            EffectSet::new_unchecked(arm, effects)
        };
        let mut sets = Vec::with_capacity(2 * p + 1);
        sets.push(build(None)?);
        let mut steps = Vec::with_capacity(p);
        for &q in probes {
            let known = (0..=CODE_DRIVE_FRICTION).contains(&q.code);
            if q.index >= arm.n() || !known {
                return Err(ArmError::InvalidEffect {
                    effect: format!("code {} at index {}", q.code, q.index),
                    reason: format!("no such place on a {}-link arm", arm.n()),
                });
            }
            let (at, h) = step(arm, model, q);
            sets.push(build(Some((q, at + h)))?);
            sets.push(build(Some((q, at - h)))?);
            steps.push(h);
        }
        Ok(Self {
            rows,
            channels: c,
            sets,
            steps,
        })
    }

    /// `P`, the probes.
    fn probes(&self) -> usize {
        self.steps.len()
    }
}
