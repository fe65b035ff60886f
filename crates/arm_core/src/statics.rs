//! Static equilibrium on the undeformed geometry (seed relations 2–8, for n links).
//!
//! Solved from the tip to the base: the moment of every known load on link i about O_i fixes
//! the actuator force F_i, and the force balance then gives the joint reaction R_i.

pub mod batch;

pub use batch::{statics_batch, StaticsBuffers, StaticsOutput};

use crate::arm::Arm;
use crate::error::{ArmError, Result};
use crate::geometry::{cross, V2};
use crate::kinematics::Frames;

/// Relative tolerance below which an actuator's moment arm about its joint counts as zero.
pub const SINGULAR_TOL: f64 = 1e-9;

/// Actuator directions, lengths and moment arms of one pose.
#[derive(Debug, Clone, Default)]
pub struct ActuatorLines {
    /// Unit vector e_i from B_{i−1} to A_i.
    pub e: Vec<V2>,
    /// Pin-to-pin length ℓ_i (mm).
    pub length: Vec<f64>,
    /// Moment arm h_i = (A_i − O_i) × e_i (mm).
    pub arm: Vec<f64>,
}

impl ActuatorLines {
    /// Sized for `n` actuators.
    pub fn new(n: usize) -> Self {
        Self {
            e: vec![V2::zeros(); n],
            length: vec![0.0; n],
            arm: vec![0.0; n],
        }
    }

    /// Fills the lines of a pose.
    ///
    /// # Errors
    /// [`ArmError::ZeroLength`] or [`ArmError::Singular`] (naming `row`).
    pub fn fill(&mut self, fr: &Frames, row: usize) -> Result<()> {
        for i in 0..self.e.len() {
            let v = fr.a[i] - fr.b[i];
            let l = v.norm();
            let ra = fr.a[i] - fr.joint[i];
            if l.is_nan() || l <= 1e-12 * (1.0 + ra.norm()) {
                return Err(ArmError::ZeroLength {
                    row,
                    actuator: i + 1,
                });
            }
            let e = v / l;
            let h = cross(ra, e);
            if h.is_nan() || h.abs() < SINGULAR_TOL * ra.norm() {
                return Err(ArmError::Singular {
                    row,
                    actuator: i + 1,
                });
            }
            self.e[i] = e;
            self.length[i] = l;
            self.arm[i] = h;
        }
        Ok(())
    }
}

/// Actuator forces (N, compression +) and joint reactions (N; force of body i−1 on link i).
#[derive(Debug, Clone, Default)]
pub struct Forces {
    /// Axial actuator forces F_i.
    pub f: Vec<f64>,
    /// Joint reactions R_i at O_i.
    pub r: Vec<V2>,
}

impl Forces {
    /// Zero forces for `n` links.
    pub fn new(n: usize) -> Self {
        Self {
            f: vec![0.0; n],
            r: vec![V2::zeros(); n],
        }
    }

    /// `self = a + b`, element-wise.
    pub fn set_sum(&mut self, a: &Forces, b: &Forces) {
        for i in 0..self.f.len() {
            self.f[i] = a.f[i] + b.f[i];
            self.r[i] = a.r[i] + b.r[i];
        }
    }
}

/// Solves one load case on a pose: self-weight when `weights` is true, plus a force
/// `payload` (N) at the load point.
pub fn solve_forces(
    arm: &Arm,
    fr: &Frames,
    lines: &ActuatorLines,
    weights: bool,
    payload: V2,
    out: &mut Forces,
) {
    let n = arm.n();
    let g = arm.g;
    let w = |m: f64| {
        if weights {
            V2::new(0.0, -m * g)
        } else {
            V2::zeros()
        }
    };
    for i in (0..n).rev() {
        let o = fr.joint[i];
        let mut q = V2::zeros();
        let mut t = 0.0;
        let mut add = |p: V2, f: V2| {
            q += f;
            t += cross(p - o, f);
        };
        add(fr.c[i], w(arm.links[i].mass_kg));
        add(fr.a[i], w(0.5 * arm.actuators[i].mass_kg));
        if i + 1 < n {
            add(fr.b[i + 1], w(0.5 * arm.actuators[i + 1].mass_kg));
            add(fr.b[i + 1], -out.f[i + 1] * lines.e[i + 1]);
            add(fr.joint[i + 1], -out.r[i + 1]);
        } else {
            add(fr.joint[n], payload);
        }
        let f = -t / lines.arm[i];
        out.f[i] = f;
        out.r[i] = -q - f * lines.e[i];
    }
}
