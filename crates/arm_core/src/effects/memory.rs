//! The per-sequence memory of the effects with history (docs/model.md, "Friction").
//!
//! A friction element keeps S_i, the part of drive i's load change (from the sequence's
//! reference: an actuator's force, a rotary drive's torque) that the springs take; it starts
//! at 0 at the reference. From one state to the next S_i stays while `|x_i − S_i| ≤ L`, else
//! `S_i = x_i − L·sign(x_i − S_i)`, with x_i the load change the element sees. A joint
//! friction sees the frictionless ΔF_i (ΔT_i); an actuator's or a drive's own friction sees
//! what the whole drive takes (S of the joint friction when there is one).
//! The solve of one state is a pure function of its inputs and this memory, so a single
//! loading is a sequence of one state from a fresh memory (the deadband).
//!
//! The gaps need no memory: after the reference each state takes them up along its own actual
//! force, which the state's statics (with the frictions' S) give.

use super::{Effect, EffectSet};
use crate::statics::{ActuatorLines, Forces};

/// What the friction elements of one sequence hold, per joint, in the unit of its drive's
/// load (N for an actuator, N·mm for a rotary drive).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SequenceMemory {
    /// S of the joint friction at O_i: the load change the whole drive i takes.
    pub joint: Vec<f64>,
    /// S of the actuator friction at M_i (the drive friction at O_i): the load change drive
    /// i's own spring (the actuator's body, the gear's torsional spring) takes.
    pub body: Vec<f64>,
}

/// One step of a Coulomb element of limit `limit` holding `held`, seeing the force change `x`.
#[inline]
pub fn slip(held: f64, x: f64, limit: f64) -> f64 {
    let d = x - held;
    if d > limit {
        x - limit
    } else if d < -limit {
        x + limit
    } else {
        held
    }
}

impl SequenceMemory {
    /// The memory at a reference (nothing held) of an arm of `n` actuators.
    pub fn new(n: usize) -> Self {
        Self {
            joint: vec![0.0; n],
            body: vec![0.0; n],
        }
    }

    /// Back to the reference.
    pub fn reset(&mut self) {
        self.joint.fill(0.0);
        self.body.fill(0.0);
    }

    /// Advances the frictions of `effects` to the next state and turns its frictionless load
    /// changes `delta` (from the reference) into what the springs and pins take: the drive's
    /// load change `delta.f[i]` becomes S of the joint friction, the joint reaction `delta.r[i]`
    /// changes by `−(S − ΔF)·e_i` (not at all for a rotary drive: e_i = 0), `couple[i]` is the
    /// friction couple on link i at O_i (N·mm, counter-clockwise +: `(ΔF − S)·h_i`, or
    /// `ΔT − S`) and `body_force[i]` the load change of drive i's own spring. Without friction
    /// these are ΔF, ΔR, 0 and ΔF. `lines` ([`ActuatorLines`]) gives every drive's unit load
    /// as a force e_i of moment h_i (a rotary drive's as a couple: e_i = 0, h_i = 1).
    pub fn step(
        &mut self,
        effects: &EffectSet,
        lines: &ActuatorLines,
        delta: &mut Forces,
        body_force: &mut [f64],
        couple: &mut [f64],
    ) {
        body_force.copy_from_slice(&delta.f);
        couple.fill(0.0);
        // The joint frictions first: an actuator friction filters what the actuator takes.
        for e in effects.effects() {
            if let Effect::JointFriction(j) = e {
                let i = j.joint;
                let df = delta.f[i];
                let s = slip(self.joint[i], df, j.limit(lines.arm[i]));
                self.joint[i] = s;
                delta.f[i] = s;
                delta.r[i] -= (s - df) * lines.e[i];
                couple[i] = (df - s) * lines.arm[i];
                body_force[i] = s;
            }
        }
        for e in effects.effects() {
            let (i, limit) = match e {
                Effect::ActuatorFriction(a) => (a.actuator, a.limit()),
                Effect::DriveFriction(d) => (d.joint, d.limit()),
                _ => continue,
            };
            let s = slip(self.body[i], delta.f[i], limit);
            self.body[i] = s;
            body_force[i] = s;
        }
    }
}
