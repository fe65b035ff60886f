//! Predicted measurement channels and their sensitivities to effect parameters, for fitting.
//!
//! Every effect is written with a *compliance-like* parameter θ in which its deflection is
//! (nearly) linear: `1/k` for springs (mm/N), `1/EI` for bending (1/(N·mm²)), `1/k` for the
//! base (rad/(N·mm)), and the gap itself for clearance and play (mm). θ = 0 is "absent", except
//! for `actuator_compliance`, whose θ replaces the actuator body's `1/k_i`.
//!
//! The sensitivity `∂y/∂θ_j` of every channel is a central difference of the exact solve,
//! taken inside the core in one pass over the poses. The response is linear in θ up to the
//! geometric nonlinearity of the pose closure, so the central difference is exact to ~1e-9
//! relative, whatever the step.

use rayon::prelude::*;

use crate::arm::Arm;
use crate::effects::{
    ActuatorCompliance, ActuatorPlay, BaseCompliance, Effect, EffectSet, JointClearance,
    LinkBending, MountCompliance, Unloaded, CODE_CLEARANCE_TAKEN_UP, CODE_PLAY_TAKEN_UP,
};
use crate::error::{ArmError, Result};
use crate::geometry::V2;
use crate::solve::{check_input, BatchInput, SolveOptions, Workspace, CHUNK, PARALLEL_THRESHOLD};

/// An effect kind and place, by the catalogue code (as in `Effect::from_code`) and 0-based index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Place {
    /// Catalogue code: 0 actuator_compliance, 1 mount_compliance, 2 actuator_play,
    /// 3 joint_clearance, 4 link_bending, 5 base_compliance; 6 actuator_play and
    /// 7 joint_clearance taken up by the unloaded forces ([`Unloaded::TakenUp`]).
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
            unloaded: gap_mode(place.code),
        }),
        3 | CODE_CLEARANCE_TAKEN_UP => Effect::JointClearance(JointClearance {
            joint: i,
            clearance: theta,
            unloaded: gap_mode(place.code),
        }),
        4 => Effect::LinkBending(LinkBending {
            link: i,
            ei: inv(theta),
        }),
        5 => Effect::BaseCompliance(BaseCompliance {
            stiffness: inv(theta),
        }),
        c => {
            return Err(ArmError::InvalidEffect {
                effect: format!("code {c}"),
                reason: "unknown effect code".into(),
            })
        }
    })
}

/// The gap mode of a play or clearance code.
fn gap_mode(code: i64) -> Unloaded {
    if code == CODE_PLAY_TAKEN_UP || code == CODE_CLEARANCE_TAKEN_UP {
        Unloaded::TakenUp
    } else {
        Unloaded::Centred
    }
}

/// The θ of a place when it is not in the model (absent; the file's `1/k` for an actuator body).
pub fn neutral_theta(arm: &Arm, place: Place) -> f64 {
    if place.code == 0 {
        1.0 / arm.actuators[place.index].stiffness
    } else {
        0.0
    }
}

/// A typical θ of a place, used to size the difference step.
fn typical_theta(arm: &Arm, place: Place) -> f64 {
    match place.code {
        0 | 1 => 1.0 / arm.actuators[place.index].stiffness,
        2 | 3 | CODE_PLAY_TAKEN_UP | CODE_CLEARANCE_TAKEN_UP => 0.1,
        4 => 1e-10,
        _ => 1e-8,
    }
}

/// Number of channels of an `n`-link arm: dx, dy, dα₁…dαₙ, dl₁…dlₙ.
pub fn n_channels(n: usize) -> usize {
    2 + 2 * n
}

/// Model prediction `y` (N × C) and sensitivities `jac` (N × C × P) for `probes`.
///
/// `model` holds the model's effects with their θ; a probe that is in the model is
/// differentiated at its θ, any other at its neutral θ (the model without it).
/// Channels: dx, dy (mm), dα (deg), dl (mm) as the `dlK_mm` sensor sees it.
///
/// # Errors
/// Shape or non-finite input, duplicate or misplaced effects, singular or unreachable poses
/// (naming the lowest failing row).
pub fn jacobian_batch(
    arm: &Arm,
    model: &[(Place, f64)],
    probes: &[Place],
    input: BatchInput<'_>,
    opts: SolveOptions,
    y: &mut [f64],
    jac: &mut [f64],
) -> Result<()> {
    let n = arm.n();
    let rows = check_input(arm, &input)?;
    let c = n_channels(n);
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
    // Effect sets: the model, then for every probe the model with θ_j ± h_j.
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
    let base = build(None)?;
    let mut sets = Vec::with_capacity(2 * p);
    let mut steps = Vec::with_capacity(p);
    for &q in probes {
        if q.index >= arm.n() || !(0..=CODE_CLEARANCE_TAKEN_UP).contains(&q.code) {
            return Err(ArmError::InvalidEffect {
                effect: format!("code {} at index {}", q.code, q.index),
                reason: format!("no such place on a {}-link arm", arm.n()),
            });
        }
        let at = model
            .iter()
            .find(|(pl, _)| *pl == q)
            .map_or_else(|| neutral_theta(arm, q), |m| m.1);
        let h = 1e-3 * at.abs().max(typical_theta(arm, q));
        sets.push(build(Some((q, at + h)))?);
        sets.push(build(Some((q, at - h)))?);
        steps.push(h);
    }
    let work = |first: usize, y: &mut [f64], jac: &mut [f64]| -> Result<()> {
        let m = y.len() / c;
        let mut ws = Workspace::new(arm);
        let mut alpha = vec![0.0; n];
        let mut plus = vec![0.0; c];
        let mut minus = vec![0.0; c];
        for r in 0..m {
            let row = first + r;
            for (a, d) in alpha
                .iter_mut()
                .zip(&input.alpha_deg[row * n..(row + 1) * n])
            {
                *a = d.to_radians();
            }
            let load = V2::new(input.payload_n[2 * row], input.payload_n[2 * row + 1]);
            let solved = (|| -> Result<()> {
                ws.solve(arm, &base, &alpha, load, opts, row)?;
                channels(&ws, &alpha, &mut y[r * c..(r + 1) * c]);
                for (j, h) in steps.iter().enumerate() {
                    ws.solve(arm, &sets[2 * j], &alpha, load, opts, row)?;
                    channels(&ws, &alpha, &mut plus);
                    ws.solve(arm, &sets[2 * j + 1], &alpha, load, opts, row)?;
                    channels(&ws, &alpha, &mut minus);
                    for k in 0..c {
                        jac[(r * c + k) * p + j] = (plus[k] - minus[k]) / (2.0 * h);
                    }
                }
                Ok(())
            })();
            if let Err(e) = solved {
                if !opts.nan_on_failure || !e.is_pose_failure() {
                    return Err(e);
                }
                y[r * c..(r + 1) * c].fill(f64::NAN);
                jac[r * c * p..(r + 1) * c * p].fill(f64::NAN);
            }
        }
        Ok(())
    };
    if rows < PARALLEL_THRESHOLD / (2 * p + 1).max(1) {
        return work(0, y, jac);
    }
    let rows_per = (CHUNK / (2 * p + 1)).max(16);
    // Pair each block of rows of y with its block of the Jacobian (empty when P = 0).
    let mut blocks: Vec<(usize, &mut [f64], &mut [f64])> = Vec::new();
    let mut jac_rest = jac;
    for (k, yc) in y.chunks_mut(rows_per * c).enumerate() {
        let (jc, rest) = std::mem::take(&mut jac_rest).split_at_mut(yc.len() * p);
        jac_rest = rest;
        blocks.push((k * rows_per, yc, jc));
    }
    let errors: Vec<ArmError> = blocks
        .into_par_iter()
        .filter_map(|(first, yc, jc)| work(first, yc, jc).err())
        .collect();
    match errors.into_iter().next() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Writes the channels of a solved workspace: dx, dy, dα (deg), dl (mm).
fn channels(ws: &Workspace, alpha: &[f64], out: &mut [f64]) {
    let n = alpha.len();
    out[0] = ws.dmeasure.x;
    out[1] = ws.dmeasure.y;
    for i in 0..n {
        out[2 + i] = (ws.new_alpha[i] - alpha[i]).to_degrees();
        out[2 + n + i] = ws.body_dl[i];
    }
}
