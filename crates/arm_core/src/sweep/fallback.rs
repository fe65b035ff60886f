//! The per-cell path of the sweep, for the effects that the sweep's block kernel does not
//! cover (clearance, bending, base tilt, frictions) and for long arms.
//!
//! The checks of each unloaded pose come first: a cell whose pose is out of stroke or near
//! singular is not solved. The cells of the other poses are solved, for arms of up to six
//! links, by `solve`'s block kernel ([`crate::solve::fast`]: every built-in effect, [`L`]
//! cells at a time, each cell a single loading from its reference), which gives each cell's
//! status in the same pass; otherwise, and for a cell that kernel hands back, by
//! [`Workspace::solve`] with the status [`validity::classify`] of the checks on the unloaded
//! pose and on the solved cell (the loaded triangles' sides from the loaded angles, as
//! `eodarm.model.validity` does). A cell whose triangle cannot close is a large deflection.

use super::cells::PoseOut;
use super::reduce::{n_fields, Sink};
use crate::arm::{Arm, Drive};
use crate::effects::EffectSet;
use crate::kinematics::Frames;
use crate::solve::batch::{BatchBuffers, BatchInput};
use crate::solve::fast::{Ctx, Kernel};
use crate::solve::general::{SolveOptions, Workspace};
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
    /// The links' turns (rad) of the cell solved last.
    turn: Vec<f64>,
    v: Vec<f64>,
    /// `solve`'s block kernel (arms of up to six links) and its rows.
    block: Option<Block>,
}

/// The cells of a chunk's regular poses as rows of `solve`'s block kernel.
struct Block {
    kernel: Kernel,
    simd: pulp::Arch,
    /// Per row: the sweep's row, its pose (index in the chunk) and its mass (kg).
    rows: Vec<(usize, usize, f64)>,
    alpha: Vec<f64>,
    payload: Vec<f64>,
    out: BatchBuffers,
    status: Vec<u8>,
}

impl Scratch {
    pub fn new(arm: &Arm, effects: &EffectSet, self_weight: bool) -> Self {
        let n = arm.n();
        let block = Kernel::new(arm, effects, self_weight).map(|kernel| Block {
            kernel,
            simd: pulp::Arch::new(),
            rows: Vec::new(),
            alpha: Vec::new(),
            payload: Vec::new(),
            out: BatchBuffers::new(0, n),
            status: Vec::new(),
        });
        Self {
            ws: Workspace::new(arm),
            frames: Frames::new(n),
            loaded: Frames::new(n),
            lines: ActuatorLines::new(n),
            rad: vec![0.0; n],
            rad_loaded: vec![0.0; n],
            turn: vec![0.0; n],
            v: vec![0.0; n_fields(n)],
            block,
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
        let regular = s.lines.fill(arm, &s.frames, pose).is_ok();
        let mut within = true;
        let mut near = !regular;
        for (i, d) in arm.drives.iter().enumerate() {
            let l = s.frames.length(i);
            if let Drive::Linear(act) = d {
                within &= act.min_length.is_none_or(|lo| l >= lo);
                within &= act.max_length.is_none_or(|hi| l <= hi);
                let f = &s.frames;
                near |= validity::near_singular(f.joint[i], f.a[i], f.b[i]);
            }
            if !out.length.is_empty() {
                out.length[p * n + i] = l;
            }
        }
        // A rotary drive's angle, unloaded (loaded: per cell, below).
        within &= !validity::out_of_angle(arm, &s.rad, None);
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
        let pose_code = validity::classify(pose_checks);
        if let Some(b) = s.block.as_mut().filter(|_| pose_code == Status::Ok) {
            // solved below, with the chunk's other regular poses
            for (j, &m) in mass.iter().enumerate() {
                b.rows.push((pose * masses + j, p, m));
                b.alpha.extend_from_slice(deg);
                b.payload.extend_from_slice(&[0.0, -m * arm.g]);
            }
            continue;
        }
        for (j, &m) in mass.iter().enumerate() {
            let row = pose * masses + j;
            // Poses out of stroke or near singular are not ok whatever the cell: not solved
            // (so `mask_unreachable` has nothing to add).
            let code = if pose_code == Status::Ok {
                solve_cell(arm, effects, s, pose, m, pose_checks, opts, reach, lift)
            } else {
                pose_code
            };
            sink.cell(row, code.code(), &s.v);
        }
    }
    if s.block.is_some() {
        run_block(
            arm,
            effects,
            self_weight,
            pose0,
            alpha,
            sink,
            s,
            reach,
            lift,
        );
    }
}

/// The status of a regular pose's cell (`pose`, mass `m`) solved by [`Workspace::solve`]
/// into `s.v`.
#[allow(clippy::too_many_arguments)]
fn solve_cell(
    arm: &Arm,
    effects: &EffectSet,
    s: &mut Scratch,
    pose: usize,
    m: f64,
    pose_checks: Checks,
    opts: SolveOptions,
    reach: f64,
    lift: bool,
) -> Status {
    let payload = V2::new(0.0, -m * arm.g);
    if s.ws
        .solve(arm, effects, &s.rad, payload, opts, pose)
        .is_ok()
    {
        cell_status(arm, s, pose_checks, m * arm.g > 0.0, reach, lift)
    } else {
        Status::LargeDeflection // the loaded triangle cannot close
    }
}

/// Solves the cells gathered in `s.block` with `solve`'s block kernel and writes them to
/// `sink`. A cell the kernel could not close is a large deflection; a cell whose status the
/// kernel finds out of stroke or near singular on a pose whose own checks passed (the two
/// computations of a limit can differ in the last bit) is solved again per cell, as is every
/// cell if the kernel returns an error.
#[allow(clippy::too_many_arguments)]
fn run_block(
    arm: &Arm,
    effects: &EffectSet,
    self_weight: bool,
    pose0: usize,
    alpha: &[f64],
    sink: &mut Sink<'_, '_>,
    s: &mut Scratch,
    reach: f64,
    lift: bool,
) {
    let n = arm.n();
    let Some(mut b) = s.block.take() else { return };
    let rows = b.rows.len();
    let opts = SolveOptions {
        self_weight,
        nan_on_failure: true,
    };
    if b.out.dx_mm.len() < rows {
        b.out = BatchBuffers::new(rows, n);
    }
    b.status.clear();
    b.status.resize(rows, 0);
    let ctx = Ctx { arm, effects, opts };
    let input = BatchInput {
        alpha_deg: &b.alpha,
        payload_n: &b.payload,
    };
    let solved = rows > 0
        && b.kernel
            .chunk(
                b.simd,
                &ctx,
                input,
                b.out.first_rows(rows, n),
                &mut b.status,
                pose0,
            )
            .is_ok();
    let per_cell = SolveOptions {
        self_weight,
        nan_on_failure: false,
    };
    let pose_code =
        |code: u8| code == Status::OutOfStroke.code() || code == Status::NearSingular.code();
    for (k, &(row, p, m)) in b.rows.iter().enumerate() {
        let o = &b.out;
        if solved && !pose_code(b.status[k]) {
            let v = &mut s.v;
            v[..n].copy_from_slice(&o.force_n[k * n..(k + 1) * n]);
            v[n] = o.dx_mm[k];
            v[n + 1] = o.dy_mm[k];
            v[n + 2..2 * n + 2].copy_from_slice(&o.dalpha_deg[k * n..(k + 1) * n]);
            v[2 * n + 2..].copy_from_slice(&o.dl_mm[k * n..(k + 1) * n]);
            let code = if o.dx_mm[k].is_nan() {
                Status::LargeDeflection.code() // the loaded triangle cannot close
            } else {
                b.status[k]
            };
            sink.cell(row, code, v);
            continue;
        }
        // per cell, as above
        let deg = &alpha[p * n..(p + 1) * n];
        for (r, d) in s.rad.iter_mut().zip(deg) {
            *r = d.to_radians();
        }
        s.frames.fill(arm, &s.rad);
        let (pose, checks) = (pose0 + p, Checks::default()); // the pose's checks passed
        let code = solve_cell(arm, effects, s, pose, m, checks, per_cell, reach, lift);
        sink.cell(row, code.code(), &s.v);
    }
    b.rows.clear();
    b.alpha.clear();
    b.payload.clear();
    s.block = Some(b);
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
        // An actuator's force (a rotary drive's torque is not a cell field: NaN).
        s.v[i] = if arm.is_rotary(i) {
            f64::NAN
        } else {
            ws.loaded.f[i]
        };
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
        s.turn[i] = turn.to_radians();
        s.rad_loaded[i] = s.rad[i] + s.turn[i];
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
    // A rotary drive's loaded angle (its unloaded one is among the pose's checks).
    let beyond = validity::out_of_angle(arm, &s.rad, Some(&s.turn));
    validity::classify(Checks {
        out_of_stroke: pose.out_of_stroke || beyond,
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
