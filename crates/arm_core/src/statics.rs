//! Static equilibrium on the undeformed geometry (seed relations 2–8, for n links).
//!
//! Solved from the tip to the base: the moment of every known load on link i about O_i fixes
//! the load of drive i (the actuator force F_i, or the drive torque T_i of a rotary drive),
//! and the force balance then gives the joint reaction R_i.

pub mod batch;

pub use batch::{statics_batch, StaticsBuffers, StaticsOutput};

use crate::arm::{Arm, Drive};
use crate::error::{ArmError, Result};
use crate::geometry::{cross, V2};
use crate::kinematics::Frames;

/// Relative tolerance below which an actuator's moment arm about its joint counts as zero.
pub const SINGULAR_TOL: f64 = 1e-9;

/// How a unit of each drive's load acts on its link, in one pose: a linear actuator's force
/// along its line, with its moment arm about the joint; a rotary drive's torque as a couple.
#[derive(Debug, Clone, Default)]
pub struct ActuatorLines {
    /// Unit vector e_i from B_{i−1} to A_i: the force of a unit load on link i at A_i (zero
    /// for a rotary drive: a couple has no resultant).
    pub e: Vec<V2>,
    /// Pin-to-pin length ℓ_i (mm); NaN for a rotary drive, which has none.
    pub length: Vec<f64>,
    /// The moment about O_i of a unit load on link i: the moment arm h_i = (A_i − O_i) × e_i
    /// (mm) of an actuator's force, 1 for a drive's torque. A joint friction's limit and couple
    /// scale by it (`effects::SequenceMemory`).
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

    /// Fills the lines of a pose of `arm`.
    ///
    /// # Errors
    /// [`ArmError::ZeroLength`] or [`ArmError::Singular`] (naming `row`).
    pub fn fill(&mut self, arm: &Arm, fr: &Frames, row: usize) -> Result<()> {
        for i in 0..self.e.len() {
            if arm.is_rotary(i) {
                self.e[i] = V2::zeros();
                self.length[i] = f64::NAN;
                self.arm[i] = 1.0;
                continue;
            }
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

/// The drives' loads and the joint reactions (N; force of body i−1 on link i).
#[derive(Debug, Clone, Default)]
pub struct Forces {
    /// The load of each drive, in its own unit ([`crate::drive`]): the axial force F_i (N,
    /// compression +) of a linear actuator, the torque T_i (N·mm, counter-clockwise + on
    /// link i) of a rotary drive.
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
///
/// Link by link from the tip, Q_i and T_i collect the known loads on link i and their moment
/// about O_i: its weight; half of actuator i's weight at A_i; from a linear joint i + 1 half
/// of its weight and its force `−F_{i+1}·e_{i+1}` at B_i, from a rotary one its drive's
/// weight at O_{i+1} and the couple `−T_{i+1}`; the reaction `−R_{i+1}` at O_{i+1} (the
/// payload at the load point on the last link). Then `F_i = −T_i/h_i`,
/// `R_i = −Q_i − F_i·e_i` (linear) or `T_i = −T_i`, `R_i = −Q_i` (rotary).
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
        // The couple of a rotary drive i + 1 on this link (its housing): −T_{i+1}.
        let mut couple = 0.0;
        let mut add = |p: V2, f: V2| {
            q += f;
            t += cross(p - o, f);
        };
        add(fr.c[i], w(arm.links[i].mass_kg));
        if let Drive::Linear(a) = &arm.drives[i] {
            add(fr.a[i], w(0.5 * a.mass_kg));
        }
        if i + 1 < n {
            match &arm.drives[i + 1] {
                Drive::Linear(a) => {
                    add(fr.b[i + 1], w(0.5 * a.mass_kg));
                    add(fr.b[i + 1], -out.f[i + 1] * lines.e[i + 1]);
                }
                Drive::Rotary(d) => {
                    add(fr.joint[i + 1], w(d.mass_kg));
                    couple = -out.f[i + 1];
                }
            }
            add(fr.joint[i + 1], -out.r[i + 1]);
        } else {
            add(fr.joint[n], payload);
        }
        t += couple;
        match arm.drives[i] {
            Drive::Linear(_) => {
                let f = -t / lines.arm[i];
                out.f[i] = f;
                out.r[i] = -q - f * lines.e[i];
            }
            Drive::Rotary(_) => {
                out.f[i] = -t;
                out.r[i] = -q;
            }
        }
    }
}
