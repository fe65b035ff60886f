//! The loaded pose, closed exactly (docs/model.md §5 and §10): body by body from the chassis,
//! each actuator triangle is closed with its changed length and its moved pins, and each link
//! turned by a rotary drive takes body i−1's loaded angle, plus the turn of the drive's
//! housing with body i−1's bending, plus its drive's relative angle and that angle's change.
//! Nothing is linearised.

use crate::arm::{Arm, Drive};
use crate::effects::Deformation;
use crate::error::{ArmError, Result};
use crate::geometry::{angle, close_triangle, rot, wrap_pi, V2};
use crate::kinematics::Frames;

/// Closes the loaded pose.
///
/// `fr` is the undeformed pose, `def` the deformation causes, `new_length` the loaded
/// pin-to-pin lengths (mm) at linear actuators and `drive_turn` the change Δq_i of the
/// relative angle (rad) at rotary drives (each ignored at the other kind). Writes the loaded
/// absolute angles (rad) into `alpha_out` and returns the loaded global position of the
/// measurement point.
///
/// # Errors
/// [`ArmError::Unreachable`] (naming `row`) when a triangle cannot close.
pub fn close_pose(
    arm: &Arm,
    fr: &Frames,
    def: &Deformation,
    new_length: &[f64],
    drive_turn: &[f64],
    row: usize,
    alpha_out: &mut [f64],
) -> Result<V2> {
    let n = arm.n();
    let pv = arm.pivot;
    let tilt = def.base_tilt;
    let chassis = |p: V2| pv + rot(tilt, p - pv);
    // Joint of link 1 (its clearance offset is global) and actuator 1's chassis pin.
    let mut o = chassis(arm.o1) + def.joint_offset[0];
    let mut base_pin = chassis(arm.b0);
    let mut measure = V2::zeros();
    // Body i−1's turn from its unloaded angle (the chassis: its tilt) and the turn of its
    // axis at O_i where it bends: a rotary drive's housing turns with both.
    let (mut body_turn, mut housing) = (tilt, 0.0);
    for (i, link) in arm.links.iter().enumerate() {
        let shift = &def.pin_shift[i];
        let al = match arm.drives[i] {
            Drive::Linear(_) => {
                let a = link.a + shift.a;
                let side = fr.side(i);
                let theta = close_triangle(base_pin - o, a.norm(), new_length[i], side).ok_or(
                    ArmError::Unreachable {
                        row,
                        actuator: i + 1,
                        length: new_length[i],
                    },
                )?;
                // The solution nearest the unloaded angle, not merely equal to it modulo 2π.
                fr.alpha[i] + wrap_pi(theta - angle(a) - fr.alpha[i])
            }
            Drive::Rotary(_) => fr.alpha[i] + (body_turn + housing + drive_turn[i]),
        };
        alpha_out[i] = al;
        body_turn = al - fr.alpha[i];
        housing = shift.slope_next;
        let (s, c) = al.sin_cos();
        let to_global = |v: V2| V2::new(c * v.x - s * v.y, s * v.x + c * v.y);
        if i + 1 < n {
            base_pin = o + to_global(link.b + shift.b);
            o += to_global(link.next + shift.next) + def.joint_offset[i + 1];
        } else {
            measure = o + to_global(arm.measure + shift.measure);
        }
    }
    Ok(measure)
}
