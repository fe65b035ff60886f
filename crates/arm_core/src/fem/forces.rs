//! Forces out of a solution: pin forces and bending moments.
//!
//! * Actuator forces are the bars' element forces, drive torques the torsional springs' (see
//!   `workspace`).
//! * The pin force R_i (body i−1 on link i at O_i) follows from link i as a free body, with
//!   the bars' forces, the drives' couples and the applied loads, from the tip inwards. Differencing the end forces
//!   of near-rigid (penalty) elements would lose digits; the free body does not.
//! * The bending moment along a link that bends comes from its beam elements' end forces,
//!   `M(x) = V₂·(x₂ − x) + M₂`; along a link rigid in bending from the same free body, by
//!   the section method `M(x) = Σ_{x_p > x} [f_y·(x_p − x) − y_p·f_x + C_p]` (link frame,
//!   C_p a drive's couple at x_p: T_i at O_i, −T_{i+1} at the next joint). Both give
//!   the moment of the loads beyond the section, counter-clockwise positive, so `EI·v″ = M`.

use crate::arm::Arm;
use crate::geometry::V2;
use crate::kinematics::Frames;

/// The loads that act on the links besides the pins and bars.
#[derive(Debug, Clone, Copy)]
pub struct Applied {
    /// Include link and actuator weights.
    pub weights: bool,
    /// Payload force at the load point (N).
    pub payload: V2,
}

impl Applied {
    fn w(&self, arm: &Arm, m: f64) -> V2 {
        if self.weights {
            V2::new(0.0, -m * arm.g)
        } else {
            V2::zeros()
        }
    }
}

/// One force (and couple) on a link: where (link frame, mm) and how much (global, N;
/// counter-clockwise N·mm).
#[derive(Debug, Clone, Copy, Default)]
pub struct PointForce {
    /// Local position.
    pub at: V2,
    /// Force (global components).
    pub f: V2,
    /// Couple (N·mm, counter-clockwise +): a rotary drive's torque.
    pub c: f64,
}

/// Every load on link `i` (5 points): pin O_i (with drive i's torque T_i when rotary), pin
/// A_i (zero when rotary), C_i, B_i (zero when joint i+1 is rotary), the next joint (with
/// −T_{i+1} and drive i+1's weight when rotary) or the load point. `f` are the drive loads
/// (actuator forces, compression +, N; drive torques, N·mm), `r` the pin forces, `e` the
/// actuator units (unused at a rotary drive).
pub fn link_forces(
    arm: &Arm,
    i: usize,
    e: &[V2],
    f: &[f64],
    r: &[V2],
    load: Applied,
    out: &mut [PointForce; 5],
) {
    let n = arm.n();
    let link = &arm.links[i];
    let half = |k: usize| load.w(arm, 0.5 * arm.drives[k].mass_kg());
    let rotary = arm.is_rotary(i);
    out[0] = PointForce {
        at: V2::zeros(),
        f: r[i],
        c: if rotary { f[i] } else { 0.0 },
    };
    out[1] = if rotary {
        PointForce::default()
    } else {
        PointForce {
            at: link.a,
            f: f[i] * e[i] + half(i),
            c: 0.0,
        }
    };
    out[2] = PointForce {
        at: link.c,
        f: load.w(arm, link.mass_kg),
        c: 0.0,
    };
    if i + 1 < n && arm.is_rotary(i + 1) {
        // The drive's housing: its weight and the reaction −T_{i+1} of its torque, at O_{i+1}.
        out[3] = PointForce::default();
        out[4] = PointForce {
            at: link.next,
            f: -r[i + 1] + load.w(arm, arm.drives[i + 1].mass_kg()),
            c: -f[i + 1],
        };
    } else if i + 1 < n {
        out[3] = PointForce {
            at: link.b,
            f: -f[i + 1] * e[i + 1] + half(i + 1),
            c: 0.0,
        };
        out[4] = PointForce {
            at: link.next,
            f: -r[i + 1],
            c: 0.0,
        };
    } else {
        out[3] = PointForce::default();
        out[4] = PointForce {
            at: link.next,
            f: load.payload,
            c: 0.0,
        };
    }
}

/// Pin forces R_i from the drive loads `f`, link by link from the tip (free bodies; a drive's
/// couple changes no pin force).
pub fn pin_forces(arm: &Arm, e: &[V2], f: &[f64], load: Applied, r: &mut [V2]) {
    let n = arm.n();
    let mut pf = [PointForce::default(); 5];
    for i in (0..n).rev() {
        r[i] = V2::zeros();
        link_forces(arm, i, e, f, r, load, &mut pf);
        let others: V2 = pf[1..].iter().map(|p| p.f).sum();
        r[i] = -others;
    }
}

/// Bending moment at local abscissa `x` of link `i` by the section method.
pub fn section_moment(fr: &Frames, i: usize, forces: &[PointForce; 5], x: f64) -> f64 {
    let mut m = 0.0;
    for p in forces {
        if p.at.x > x {
            let fl = fr.to_local(i, p.f);
            m += fl.y * (p.at.x - x) - p.at.y * fl.x + p.c;
        }
    }
    m
}
