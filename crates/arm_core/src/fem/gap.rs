//! Gap elements: joint clearance, actuator play and drive backlash, and their active-set
//! iteration.
//!
//! A gap is a contact with a free range. A joint pin of radial clearance c in its bore is a
//! 2-D gap: loaded, the pin touches the bore where it presses on it, so the pin centre sits
//! `s = c·u` from the bore centre, u the direction of the force that the distal body presses
//! onto the proximal one (−R_i). An actuator's play p is a 1-D gap along its axis: closed on
//! the side of its force, it changes the pin-to-pin length by `−p·sign(F)`. A rotary drive's
//! backlash b is a 1-D gap in its turn: closed on the side of its torque, it turns link i
//! against body i−1 by `−b·sign(T)`.
//!
//! A closed gap is a prescribed relative displacement (an offset in the kinematic maps or a
//! prescribed bar length or spring turn), so it changes the load vector only, never K: every
//! iteration reuses the factorisation. The active set is the contact state of every gap — its
//! direction u, or its side sign(F) or sign(T) (0: open, centred, for a force below
//! [`FORCE_ZERO_N`] or a torque below [`TORQUE_ZERO_NMM`]). Starting with
//! every gap centred (the unloaded state), each iteration solves, reads the loaded forces,
//! and closes each gap on the side its force now points to, until no contact state changes.

use crate::effects::{FORCE_ZERO_N, TORQUE_ZERO_NMM};
use crate::geometry::V2;

use super::spec::FemSpec;

/// At most this many active-set iterations before giving up.
pub const MAX_ITERATIONS: usize = 50;

/// The contact state of every gap.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GapState {
    /// Offset of each joint's pin centre from its bore centre (global, mm).
    pub offset: Vec<V2>,
    /// Change of each drive's coordinate from its lost motion: an actuator's pin-to-pin
    /// length from its play (mm), a rotary drive's turn of link i against body i−1 from its
    /// backlash (rad).
    pub play_dl: Vec<f64>,
}

impl GapState {
    /// Every gap centred, for `n` joints and actuators.
    pub fn new(n: usize) -> Self {
        Self {
            offset: vec![V2::zeros(); n],
            play_dl: vec![0.0; n],
        }
    }

    /// Back to every gap centred.
    pub fn reset(&mut self) {
        self.offset.fill(V2::zeros());
        self.play_dl.fill(0.0);
    }

    /// Closes every gap on the side of the loaded forces: drive loads `f` (actuator forces,
    /// compression +, N; drive torques, counter-clockwise + on link i, N·mm) and pin forces
    /// `r` (body i−1 on link i). Returns whether any contact state changed (a direction by
    /// more than 1e-12 of its clearance).
    pub fn update(&mut self, spec: &FemSpec, f: &[f64], r: &[V2]) -> bool {
        let (clearance, play) = (&spec.clearance, &spec.play);
        let mut changed = false;
        for i in 0..self.offset.len() {
            let s = if clearance[i] > 0.0 {
                let press = -r[i];
                let m = press.norm();
                if m < FORCE_ZERO_N {
                    V2::zeros()
                } else {
                    press * (clearance[i] / m)
                }
            } else {
                V2::zeros()
            };
            if (s - self.offset[i]).norm() > 1e-12 * clearance[i] {
                changed = true;
            }
            self.offset[i] = s;
            let zero = if spec.rotary[i] {
                TORQUE_ZERO_NMM
            } else {
                FORCE_ZERO_N
            };
            let d = -play[i] * sign0(f[i], zero);
            if d != self.play_dl[i] {
                changed = true;
            }
            self.play_dl[i] = d;
        }
        changed
    }
}

/// `sign(x)`, 0 below the threshold `zero`.
#[inline]
fn sign0(x: f64, zero: f64) -> f64 {
    if x >= zero {
        1.0
    } else if x <= -zero {
        -1.0
    } else {
        0.0
    }
}
