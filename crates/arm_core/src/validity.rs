//! Where the small-deflection model can be trusted: a status per pose (docs/model.md §7).
//!
//! The model takes its forces from the undeformed geometry and closes the loaded pose
//! exactly. Its answers are sound only where the deflection is small, the actuators are not
//! close to passing through their joints, the loaded pose stays on the branch of the unloaded
//! one and the actuators work within their stroke and forces. The checks are the same in
//! every kernel (per-pose solve, sweep, numpy reference `eodarm.model.validity`); the kernels
//! compute the quantities their own way and call [`classify`] to pick the reported reason.
//!
//! | code | name               | when                                                            |
//! |------|--------------------|-----------------------------------------------------------------|
//! | 0    | `ok`               | inside every limit                                              |
//! | 1    | `out_of_stroke`    | an unloaded length outside `[min_length, max_length]`, or a rotary drive's angle (unloaded or loaded) outside `[min_angle, max_angle]` |
//! | 2    | `near_singular`    | an actuator's moment arm about its joint < [`MIN_MOMENT_ARM`]·\|A_i − O_i\| |
//! | 3    | `branch_flip`      | a loaded actuator triangle turned over                          |
//! | 4    | `over_force`       | a loaded \|force\| above `max_force`, or \|torque\| above `max_torque` |
//! | 5    | `large_deflection` | a link turned > [`MAX_DALPHA_DEG`], the measure point moved > [`MAX_DEFLECTION_OF_REACH`]·reach, or rose > [`MAX_RISE_OF_REACH`]·reach under a downward payload; or the load point rose > [`MAX_LOAD_RISE_MM`] where [`checks_load_rise`] and no user deformation |
//!
//! When several apply, the first in this order is reported. A joint turned by a rotary drive
//! has no triangle: it is never near singular nor flipped.

// `!(x <= t)` is meant: NaN breaks the limit.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::arm::{Arm, Drive};
use crate::drive::rotary::ANGLE_TOL_RAD;
use crate::geometry::{cross, V2};
use crate::lanes::Lane;

/// Moment arm of an actuator about its joint, as a fraction of |A_i − O_i|, below which the
/// pose is near singular (forces amplified more than 20×).
pub const MIN_MOMENT_ARM: f64 = 0.05;
/// Largest change of a link's angle (degrees) the small-deflection model is trusted for.
pub const MAX_DALPHA_DEG: f64 = 10.0;
/// Largest displacement of the measure point, as a fraction of the arm's reach Σ|next_i|.
pub const MAX_DEFLECTION_OF_REACH: f64 = 0.05;
/// Largest rise of the measure point under a downward payload, as a fraction of the reach.
pub const MAX_RISE_OF_REACH: f64 = 1e-3;
/// Largest rise (mm) of the *load point* under a downward payload, where no gap effect and no
/// user-written deformation act: an elastic arm's load point cannot rise at all (its energy
/// forbids it, docs/model.md §7), so a rise is the model's second-order error showing; 1e-3
/// mm is a fraction of any sensor's noise.
pub const MAX_LOAD_RISE_MM: f64 = 1e-3;

/// The status of one solved pose; the `u8` value is the code shared with Python.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Status {
    /// Inside every limit.
    Ok = 0,
    /// An unloaded pin-to-pin length outside the actuator's stroke.
    OutOfStroke = 1,
    /// An actuator nearly passes through its joint.
    NearSingular = 2,
    /// The loaded actuator triangle turned over.
    BranchFlip = 3,
    /// A loaded actuator force above its `max_force`.
    OverForce = 4,
    /// Too large a deflection for the small-deflection model.
    LargeDeflection = 5,
}

impl Status {
    /// The names by code, as in Python's `eodarm.model.validity.STATUS`.
    pub const NAMES: [&'static str; 6] = [
        "ok",
        "out_of_stroke",
        "near_singular",
        "branch_flip",
        "over_force",
        "large_deflection",
    ];

    /// The code written to status arrays.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The status name.
    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }
}

/// The findings of one pose's checks (each `true` means the limit is broken).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Checks {
    /// Some unloaded length outside its stroke.
    pub out_of_stroke: bool,
    /// Some actuator's moment arm below [`MIN_MOMENT_ARM`] of its pin's distance.
    pub near_singular: bool,
    /// Some loaded triangle on the other side of its unloaded one.
    pub branch_flip: bool,
    /// Some loaded |force| above its actuator's `max_force`.
    pub over_force: bool,
    /// See [`large_deflection`].
    pub large_deflection: bool,
}

/// The reported reason: the first broken limit in code order.
#[inline]
pub fn classify(c: Checks) -> Status {
    if c.out_of_stroke {
        Status::OutOfStroke
    } else if c.near_singular {
        Status::NearSingular
    } else if c.branch_flip {
        Status::BranchFlip
    } else if c.over_force {
        Status::OverForce
    } else if c.large_deflection {
        Status::LargeDeflection
    } else {
        Status::Ok
    }
}

/// [`classify`]'s code, written with selects instead of branches (the same answer), so that
/// the block kernels' lane loops that call it stay vectorised.
#[inline(always)]
pub fn code_of(c: Checks) -> u8 {
    let pick = |broken: bool, code: Status, later: u8| if broken { code.code() } else { later };
    let code = pick(
        c.large_deflection,
        Status::LargeDeflection,
        Status::Ok.code(),
    );
    let code = pick(c.over_force, Status::OverForce, code);
    let code = pick(c.branch_flip, Status::BranchFlip, code);
    let code = pick(c.near_singular, Status::NearSingular, code);
    pick(c.out_of_stroke, Status::OutOfStroke, code)
}

/// The arm's reach Σ|next_i| (mm), floored at 1e-9, the length the deflection limits scale by.
pub fn reach(arm: &Arm) -> f64 {
    arm.links
        .iter()
        .map(|l| l.next.norm())
        .sum::<f64>()
        .max(1e-9)
}

/// The actuator from `b` to `a` is near singular about joint `o`: its line passes closer to
/// `o` than [`MIN_MOMENT_ARM`]·|a − o|. (A zero-length actuator counts as singular.)
pub fn near_singular(o: V2, a: V2, b: V2) -> bool {
    let line = a - b;
    let len = line.norm();
    let h = cross(line, o - b).abs() / len.max(1e-300);
    // `!(h >= t)`: a NaN moment arm is singular too.
    !(h >= MIN_MOMENT_ARM * (a - o).norm())
}

/// The side of the actuator triangle (O_i, A_i, B_i): the sign of (A − B) × (O − B). A loaded
/// triangle whose side differs from the unloaded one's has flipped branch.
pub fn triangle_side(o: V2, a: V2, b: V2) -> f64 {
    cross(a - b, o - b).signum()
}

/// Too large a deflection: some |Δα_i| above [`MAX_DALPHA_DEG`], |(dx, dy)| above
/// [`MAX_DEFLECTION_OF_REACH`]·reach, or a rise `dy` above [`MAX_RISE_OF_REACH`]·reach when
/// the payload pulls down (`payload_down`). NaN inputs count as too large.
pub fn large_deflection(
    max_abs_dalpha_deg: f64,
    dx_mm: f64,
    dy_mm: f64,
    payload_down: bool,
    reach_mm: f64,
) -> bool {
    let moved = dx_mm.hypot(dy_mm);
    !(max_abs_dalpha_deg <= MAX_DALPHA_DEG)
        || !(moved <= MAX_DEFLECTION_OF_REACH * reach_mm)
        || (payload_down && dy_mm > MAX_RISE_OF_REACH * reach_mm)
}

/// [`large_deflection`] with the displacement's length as `√(dx² + dy²)` instead of
/// `hypot` (no libm call, for the lanes of the block kernel): the same answer except where
/// the length is within rounding (≈ 1e-16 relative) of its limit. Per lane for a pack.
#[inline(always)]
pub fn large_deflection_sq<T: Lane>(
    max_abs_dalpha_deg: T,
    dx_mm: T,
    dy_mm: T,
    payload_down: T::Mask,
    reach_mm: f64,
) -> T::Mask {
    let moved = (dx_mm * dx_mm + dy_mm * dy_mm).sqrt();
    !max_abs_dalpha_deg.le(MAX_DALPHA_DEG)
        | !moved.le(MAX_DEFLECTION_OF_REACH * reach_mm)
        | (payload_down & dy_mm.gt(MAX_RISE_OF_REACH * reach_mm))
}

/// The load point's vertical displacement (mm) from the measure point's `dy_mm`, the last
/// link's turn (`sin_d` = sin Δα_n, `cos_m1` = cos Δα_n − 1) and `w` = R(α_n)·(next_n −
/// measure) (global, unloaded, mm): the last link is rigid between the two points, so the
/// load point moves by the measure point's displacement plus (R(Δα_n) − I)·w.
#[inline(always)]
pub fn load_dy<T: Lane>(dy_mm: T, sin_d: T, cos_m1: T, wx: T, wy: T) -> T {
    dy_mm + (sin_d * wx + cos_m1 * wy)
}

/// Whether the load point's rise is checked for these effects: not with a gap (play,
/// backlash or clearance: the unloaded pose is then not an equilibrium of elastic parts) nor with the last
/// link bending (the kernels know the load point through the rigid last link).
pub fn checks_load_rise(arm: &Arm, effects: &crate::effects::EffectSet) -> bool {
    use crate::effects::Effect;
    let last = arm.n() - 1;
    effects.effects().iter().all(|e| match e {
        Effect::ActuatorPlay(_) | Effect::JointClearance(_) | Effect::DriveBacklash(_) => false,
        Effect::LinkBending(b) => b.link != last,
        // A friction only holds back part of a deformation the load makes (it dissipates;
        // it stores no energy that could lift the load point above its reference).
        Effect::ActuatorCompliance(_)
        | Effect::MountCompliance(_)
        | Effect::BaseCompliance(_)
        | Effect::ActuatorFriction(_)
        | Effect::JointFriction(_)
        | Effect::DriveCompliance(_)
        | Effect::DriveFriction(_) => true,
    })
}

/// `R(α_n)·(next_n − measure)` (global, mm) of the last link at unloaded angle `alpha_n`
/// (rad): the lever of [`load_dy`].
pub fn load_lever(arm: &Arm, alpha_n: f64) -> V2 {
    let v = arm.links[arm.n() - 1].next - arm.measure;
    let (s, c) = alpha_n.sin_cos();
    V2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

/// Some drive's loaded load above its limit: |F_i| above an actuator's `max_force`, |T_i|
/// above a rotary drive's `max_torque` (drives without one never are). `load` holds each
/// drive's load in its own unit ([`crate::statics::Forces::f`]).
pub fn over_force(arm: &Arm, load: &[f64]) -> bool {
    arm.drives.iter().zip(load).any(|(d, f)| d.over_limit(*f))
}

/// Some unloaded length outside its actuator's `[min_length, max_length]` (rotary drives,
/// whose length is NaN, never are).
pub fn out_of_stroke(arm: &Arm, length_mm: &[f64]) -> bool {
    arm.drives.iter().zip(length_mm).any(|(d, &l)| match d {
        Drive::Linear(act) => act.out_of_stroke(l),
        Drive::Rotary(_) => false,
    })
}

/// Some rotary drive's angle outside its `[min_angle, max_angle]` in the pose `alpha` (rad):
/// its relative angle `q_i = α_i − α_{i−1}` (α_0 = 0) unloaded, or loaded with the turns
/// `dalpha` (rad) of the links when given, `q_i + Δα_i − Δα_{i−1}` (**Reading**: the rigid arm
/// put at the loaded angles, as for `branch_flip`), when that turn exceeds [`ANGLE_TOL_RAD`].
/// [`crate::drive::RotaryDrive::angle_of`] picks the turn of the drive's angle.
pub fn out_of_angle(arm: &Arm, alpha: &[f64], dalpha: Option<&[f64]>) -> bool {
    let before = |v: &[f64], i: usize| if i == 0 { 0.0 } else { v[i - 1] };
    arm.drives.iter().enumerate().any(|(i, d)| match d {
        Drive::Linear(_) => false,
        Drive::Rotary(r) => {
            let q = r.angle_of(alpha[i] - before(alpha, i));
            let dq = dalpha.map_or(f64::NAN, |t| t[i] - before(t, i));
            // A NaN turn (none given, a pose that failed) leaves the loaded angle unknown; a
            // turn within the tolerance is none (the sign of a turn of 1e-60 rad under a
            // payload of 1e-55 N is rounding's, and must not move a pose on its limit out).
            r.out_of_range(q)
                || (dq.is_finite() && dq.abs() > ANGLE_TOL_RAD && r.out_of_range(q + dq))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classify_reports_the_first_broken_limit() {
        assert_eq!(classify(Checks::default()), Status::Ok);
        for bits in 0..32u8 {
            let c = Checks {
                out_of_stroke: bits & 1 != 0,
                near_singular: bits & 2 != 0,
                branch_flip: bits & 4 != 0,
                over_force: bits & 8 != 0,
                large_deflection: bits & 16 != 0,
            };
            assert_eq!(code_of(c), classify(c).code(), "{c:?}");
        }
        let all = Checks {
            out_of_stroke: true,
            near_singular: true,
            branch_flip: true,
            over_force: true,
            large_deflection: true,
        };
        assert_eq!(classify(all), Status::OutOfStroke);
        let late = Checks {
            over_force: true,
            large_deflection: true,
            ..Checks::default()
        };
        assert_eq!(classify(late), Status::OverForce);
        assert_eq!(Status::LargeDeflection.name(), "large_deflection");
        assert_eq!(Status::BranchFlip.code(), 3);
    }

    #[test]
    fn a_line_through_the_joint_is_singular_and_a_perpendicular_one_is_not() {
        let o = V2::new(0.0, 0.0);
        let a = V2::new(100.0, 0.0);
        assert!(near_singular(o, a, V2::new(300.0, 0.0)));
        assert!(!near_singular(o, a, V2::new(100.0, -200.0)));
        // 4 % of |a − o| is below the 5 % limit, 6 % above it
        assert!(near_singular(o, a, V2::new(300.0, 8.0)));
        assert!(!near_singular(o, a, V2::new(300.0, 12.0)));
    }

    #[test]
    fn the_load_point_moves_with_the_rigid_last_link() {
        // A link hanging 300 mm below its joint, the measure point on the joint (dy = 0),
        // turned by 0.1 rad: the load point comes up by 300·(1 − cos 0.1) = 1.4988 mm.
        let d: f64 = 0.1;
        let up = load_dy(0.0, d.sin(), d.cos() - 1.0, 0.0, -300.0);
        assert!((up - 300.0 * (1.0 - d.cos())).abs() < 1e-12, "{up}");
        assert!(up > MAX_LOAD_RISE_MM);
        // horizontal lever: first order, down for a clockwise turn
        let down = load_dy(0.0, (-d).sin(), (-d).cos() - 1.0, 300.0, 0.0);
        assert!((down - 300.0 * (-d).sin()).abs() < 1e-12, "{down}");
    }

    #[test]
    fn a_rise_under_a_downward_payload_is_not_elastic() {
        let reach = 1000.0;
        assert!(!large_deflection(1.0, 0.0, -20.0, true, reach));
        assert!(large_deflection(1.0, 0.0, 2.0, true, reach));
        assert!(!large_deflection(1.0, 0.0, 2.0, false, reach));
        assert!(large_deflection(11.0, 0.0, -1.0, true, reach));
        assert!(large_deflection(1.0, 0.0, -60.0, true, reach));
        assert!(large_deflection(f64::NAN, 0.0, -1.0, true, reach));
    }
}
