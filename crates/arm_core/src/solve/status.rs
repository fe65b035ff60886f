//! The status of one pose solved by the general path (docs/model.md §7), from its unloaded
//! frames and the solved pose in its [`Workspace`] (the values its output row gets, whether
//! or not those outputs were asked for); the block kernel computes the same checks in its
//! lanes.

use super::general::Workspace;
use crate::arm::Arm;
use crate::effects::ExtraDeformations;
use crate::kinematics::Frames;
use crate::validity::{self, Checks};

/// The status code of a pose whose unloaded frames are `ws.frames`: solved in `ws` from the
/// unloaded angles `alpha` (rad) when `solved`, else failed (its outputs NaN). `loaded` is
/// scratch space for the rigid loaded pose (the unloaded angles plus the turns). `load_rise`:
/// check the load point's rise ([`validity::checks_load_rise`], no user-written deformation).
#[allow(clippy::too_many_arguments)]
pub(crate) fn pose_status(
    arm: &Arm,
    ws: &Workspace,
    alpha: &[f64],
    solved: bool,
    loaded: &mut Frames,
    payload_down: bool,
    reach: f64,
    load_rise: bool,
) -> u8 {
    let n = arm.n();
    let fr = &ws.frames;
    // The row's values as `write_row` writes them (`fill_nan` for a failed pose): the same
    // expressions, so the status is that of the outputs.
    let nan = f64::NAN;
    let dalpha: Vec<f64> = (0..n)
        .map(|i| {
            if solved {
                (ws.new_alpha[i] - alpha[i]).to_degrees()
            } else {
                nan
            }
        })
        .collect();
    let (dx, dy) = if solved {
        (ws.dmeasure.x, ws.dmeasure.y)
    } else {
        (nan, nan)
    };
    // Triangles only where a linear actuator turns the link.
    let linear: Vec<usize> = (0..n).filter(|&i| !arm.is_rotary(i)).collect();
    let near = linear
        .iter()
        .any(|&i| validity::near_singular(fr.joint[i], fr.a[i], fr.b[i]));
    let mut flip = false;
    let turns: Vec<f64> = dalpha.iter().map(|d| d.to_radians()).collect();
    if dalpha.iter().all(|d| d.is_finite()) {
        let alpha: Vec<f64> = fr.alpha.iter().zip(&turns).map(|(a, d)| a + d).collect();
        loaded.fill(arm, &alpha);
        flip = linear.iter().any(|&i| {
            let before = validity::triangle_side(fr.joint[i], fr.a[i], fr.b[i]);
            let after = validity::triangle_side(loaded.joint[i], loaded.a[i], loaded.b[i]);
            before * after < 0.0
        });
    }
    let max_da = if dalpha.iter().any(|d| d.is_nan()) {
        f64::NAN
    } else {
        dalpha.iter().fold(0.0f64, |m, d| m.max(d.abs()))
    };
    let lengths: Vec<f64> = (0..n).map(|i| fr.length(i)).collect();
    // Each drive's loaded load: a force or a torque.
    let load: Vec<f64> = (0..n)
        .map(|i| if solved { ws.loaded.f[i] } else { nan })
        .collect();
    let lift = load_rise && payload_down && {
        let w = validity::load_lever(arm, fr.alpha[n - 1]);
        let (s, c) = dalpha[n - 1].to_radians().sin_cos();
        validity::load_dy(dy, s, c - 1.0, w.x, w.y) > validity::MAX_LOAD_RISE_MM
    };
    let checks = Checks {
        out_of_stroke: validity::out_of_stroke(arm, &lengths)
            || validity::out_of_angle(arm, &fr.alpha, Some(&turns)),
        near_singular: near,
        branch_flip: flip,
        over_force: validity::over_force(arm, &load),
        large_deflection: validity::large_deflection(max_da, dx, dy, payload_down, reach) || lift,
    };
    validity::classify(checks).code()
}

/// Whether no user-written deformation acts on pose `p` (every extra array absent or zero in
/// its row): only then is the load point's rise an error of the model.
pub(crate) fn no_extra(extra: &ExtraDeformations<'_>, p: usize, n: usize) -> bool {
    let zero = |a: Option<&[f64]>, width: usize| {
        a.is_none_or(|v| v[p * width..(p + 1) * width].iter().all(|x| *x == 0.0))
    };
    zero(extra.seen_mm, n)
        && zero(extra.unseen_mm, n)
        && zero(extra.turn_rad, n)
        && zero(extra.joint_mm, 2 * n)
        && zero(extra.tilt_rad, 1)
        && zero(extra.measure_mm, 2)
}
