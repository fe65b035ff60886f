//! The per-cell path of the sweep: [`Workspace::solve`] for every cell, for the effects that
//! the block kernel does not cover (clearance, bending, base tilt) and for long arms.
//!
//! The status of each cell is [`validity::classify`] of the checks on the unloaded pose and
//! on the solved cell (the loaded triangles' sides from the loaded angles, as
//! `eodarm.model.validity` does); a cell whose pose is out of stroke or near singular is not
//! solved, and one whose triangle cannot close is a large deflection.

use super::cells::PoseOut;
use super::reduce::{n_fields, Sink};
use crate::arm::Arm;
use crate::effects::EffectSet;
use crate::kinematics::Frames;
use crate::solve::{SolveOptions, Workspace};
use crate::statics::ActuatorLines;
use crate::validity::{self, Checks, Status};
use crate::V2;

/// Per-thread scratch of the per-cell path.
pub(crate) struct Scratch {
    ws: Workspace,
    frames: Frames,
    /// The loaded pose's frames (for the branch check).
    loaded: Frames,
    lines: ActuatorLines,
    rad: Vec<f64>,
    rad_loaded: Vec<f64>,
    v: Vec<f64>,
}

impl Scratch {
    pub fn new(arm: &Arm) -> Self {
        let n = arm.n();
        Self {
            ws: Workspace::new(arm),
            frames: Frames::new(n),
            loaded: Frames::new(n),
            lines: ActuatorLines::new(n),
            rad: vec![0.0; n],
            rad_loaded: vec![0.0; n],
            v: vec![0.0; n_fields(n)],
        }
    }
}

/// Solves the poses `alpha` (first pose `pose0`) under every mass into `out` and `sink`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run(
    arm: &Arm,
    effects: &EffectSet,
    self_weight: bool,
    mass: &[f64],
    pose0: usize,
    alpha: &[f64],
    out: PoseOut<'_>,
    sink: &mut Sink<'_, '_>,
    s: &mut Scratch,
) {
    let n = arm.n();
    let masses = mass.len();
    let opts = SolveOptions {
        self_weight,
        nan_on_failure: false,
    };
    let reach = validity::reach(arm);
    let lift = validity::checks_load_rise(arm, effects);
    for (p, deg) in alpha.chunks_exact(n).enumerate() {
        let pose = pose0 + p;
        for (r, d) in s.rad.iter_mut().zip(deg) {
            *r = d.to_radians();
        }
        s.frames.fill(arm, &s.rad);
        let regular = s.lines.fill(&s.frames, pose).is_ok();
        let mut within = true;
        let mut near = !regular;
        for (i, act) in arm.actuators.iter().enumerate() {
            let l = s.frames.length(i);
            within &= act.min_length.is_none_or(|lo| l >= lo);
            within &= act.max_length.is_none_or(|hi| l <= hi);
            let f = &s.frames;
            near |= validity::near_singular(f.joint[i], f.a[i], f.b[i]);
            if !out.length.is_empty() {
                out.length[p * n + i] = l;
            }
        }
        let pose_checks = Checks {
            out_of_stroke: !within,
            near_singular: near,
            ..Checks::default()
        };
        if !out.reachable.is_empty() {
            out.reachable[p] = regular && within;
        }
        if !out.ex.is_empty() {
            out.ex[p] = s.frames.joint[n].x;
        }
        if !out.ey.is_empty() {
            out.ey[p] = s.frames.joint[n].y;
        }
        for (j, &m) in mass.iter().enumerate() {
            let row = pose * masses + j;
            let payload = V2::new(0.0, -m * arm.g);
            // Poses out of stroke or near singular are not ok whatever the cell: not solved
            // (so `mask_unreachable` has nothing to add).
            let mut code = validity::classify(pose_checks);
            if code == Status::Ok {
                code = if s
                    .ws
                    .solve(arm, effects, &s.rad, payload, opts, pose)
                    .is_ok()
                {
                    cell_status(arm, s, pose_checks, m * arm.g > 0.0, reach, lift)
                } else {
                    Status::LargeDeflection // the loaded triangle cannot close
                };
            }
            sink.cell(row, code.code(), &s.v);
        }
    }
}

/// The status of the cell just solved in `s.ws` (its values written into `s.v`).
fn cell_status(
    arm: &Arm,
    s: &mut Scratch,
    pose: Checks,
    down: bool,
    reach: f64,
    load_rise: bool,
) -> Status {
    let n = arm.n();
    let ws = &s.ws;
    let mut max_turn = 0.0f64;
    for i in 0..n {
        s.v[i] = ws.loaded.f[i];
        let turn = (ws.new_alpha[i] - s.rad[i]).to_degrees();
        s.v[n + 2 + i] = turn;
        // A NaN turn stays NaN (it breaks the limit).
        max_turn = if turn.abs() > max_turn || turn.is_nan() {
            turn.abs()
        } else {
            max_turn
        };
        s.v[2 * n + 2 + i] = ws.body_dl[i];
        // The loaded angles as the outputs give them (unloaded + Δα), as the numpy checks do.
        s.rad_loaded[i] = s.rad[i] + turn.to_radians();
    }
    s.v[n] = ws.dmeasure.x;
    s.v[n + 1] = ws.dmeasure.y;
    s.loaded.fill(arm, &s.rad_loaded);
    let flip = (0..n).any(|i| s.frames.side(i) * s.loaded.side(i) < 0.0);
    // the load point rising (validity::MAX_LOAD_RISE_MM): not an elastic answer
    let lift = load_rise && down && {
        let w = validity::load_lever(arm, s.rad[n - 1]);
        let (sn, cs) = (s.rad_loaded[n - 1] - s.rad[n - 1]).sin_cos();
        validity::load_dy(ws.dmeasure.y, sn, cs - 1.0, w.x, w.y) > validity::MAX_LOAD_RISE_MM
    };
    validity::classify(Checks {
        branch_flip: flip,
        over_force: validity::over_force(arm, &ws.loaded.f),
        large_deflection: validity::large_deflection(
            max_turn,
            ws.dmeasure.x,
            ws.dmeasure.y,
            down,
            reach,
        ) || lift,
        ..pose
    })
}
