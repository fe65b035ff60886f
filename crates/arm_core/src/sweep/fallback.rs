//! The per-cell path of the sweep: [`Workspace::solve`] for every cell, for the effects that
//! the block kernel does not cover (clearance, bending, base tilt) and for long arms.

use super::reduce::{n_fields, Sink};
use super::PoseOut;
use crate::arm::Arm;
use crate::effects::EffectSet;
use crate::kinematics::Frames;
use crate::solve::{SolveOptions, Workspace};
use crate::statics::ActuatorLines;
use crate::V2;

/// Per-thread scratch of the per-cell path.
pub(crate) struct Scratch {
    ws: Workspace,
    frames: Frames,
    lines: ActuatorLines,
    rad: Vec<f64>,
    v: Vec<f64>,
}

impl Scratch {
    pub fn new(arm: &Arm) -> Self {
        let n = arm.n();
        Self {
            ws: Workspace::new(arm),
            frames: Frames::new(n),
            lines: ActuatorLines::new(n),
            rad: vec![0.0; n],
            v: vec![0.0; n_fields(n)],
        }
    }
}

/// Solves the poses `alpha` (first pose `pose0`) under every mass into `out` and `sink`;
/// with `mask_unreachable`, the cells of poses out of stroke are not solved.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run(
    arm: &Arm,
    effects: &EffectSet,
    self_weight: bool,
    mask_unreachable: bool,
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
    for (p, deg) in alpha.chunks_exact(n).enumerate() {
        let pose = pose0 + p;
        for (r, d) in s.rad.iter_mut().zip(deg) {
            *r = d.to_radians();
        }
        s.frames.fill(arm, &s.rad);
        let regular = s.lines.fill(&s.frames, pose).is_ok();
        let mut within = true;
        for (i, act) in arm.actuators.iter().enumerate() {
            let l = s.frames.length(i);
            within &= act.min_length.is_none_or(|lo| l >= lo);
            within &= act.max_length.is_none_or(|hi| l <= hi);
            if !out.length.is_empty() {
                out.length[p * n + i] = l;
            }
        }
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
            let ok = regular
                && (within || !mask_unreachable)
                && s.ws
                    .solve(arm, effects, &s.rad, payload, opts, pose)
                    .is_ok();
            if ok {
                let ws = &s.ws;
                for i in 0..n {
                    s.v[i] = ws.loaded.f[i];
                    s.v[n + 2 + i] = (ws.new_alpha[i] - s.rad[i]).to_degrees();
                    s.v[2 * n + 2 + i] = ws.body_dl[i];
                }
                s.v[n] = ws.dmeasure.x;
                s.v[n + 1] = ws.dmeasure.y;
            }
            sink.cell(row, ok, &s.v);
        }
    }
}
