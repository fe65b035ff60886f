//! Many poses through one FE model: the same outputs as [`crate::solve_batch`] plus pin
//! forces, bending moments and the deformed shape, filled in place. Poses run in chunks, each
//! with its own [`FemWorkspace`] (the symbolic factorisation is shared), in parallel above
//! [`PARALLEL_THRESHOLD`] poses.

use rayon::prelude::*;

use crate::error::{ArmError, Result};
use crate::geometry::V2;
use crate::solve::{
    check_input, fill_nan, split_output, BatchBuffers, BatchInput, BatchOutput, SolveOptions,
};

use super::{FemModel, FemWorkspace};

/// Below this many poses the batch runs on the calling thread.
pub const PARALLEL_THRESHOLD: usize = 256;
/// Poses per parallel work item.
pub const CHUNK: usize = 128;

/// Outputs of an FE batch, row-major, filled in place.
#[derive(Debug)]
pub struct FemBatchOutput<'a> {
    /// The outputs of the analytic solver, same shapes and meanings.
    pub base: BatchOutput<'a>,
    /// Loaded pin forces on the links (N), `N × 2n × 2`: first the joints O_i (body i−1 on
    /// link i), then the actuator pins A_i (actuator i on link i; NaN at a rotary drive).
    pub pin_force_n: &'a mut [f64],
    /// Loaded bending moment of each link at `model.moment_x` (N·mm), `N × n × K`.
    pub moment_nmm: &'a mut [f64],
    /// Its change unloaded → loaded (N·mm), `N × n × K`.
    pub dmoment_nmm: &'a mut [f64],
    /// Undeformed node positions (mm), `N × nodes × 2`.
    pub node_xy: &'a mut [f64],
    /// Node displacements loaded − unloaded (mm), `N × nodes × 2`.
    pub node_disp: &'a mut [f64],
}

/// Owned, zeroed output buffers of `rows` poses of `model`, lent to [`fem_solve_batch`] by
/// [`FemBatchBuffers::out`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FemBatchBuffers {
    /// The analytic solver's outputs.
    pub base: BatchBuffers,
    /// See [`FemBatchOutput::pin_force_n`].
    pub pin_force_n: Vec<f64>,
    /// See [`FemBatchOutput::moment_nmm`].
    pub moment_nmm: Vec<f64>,
    /// See [`FemBatchOutput::dmoment_nmm`].
    pub dmoment_nmm: Vec<f64>,
    /// See [`FemBatchOutput::node_xy`].
    pub node_xy: Vec<f64>,
    /// See [`FemBatchOutput::node_disp`].
    pub node_disp: Vec<f64>,
}

impl FemBatchBuffers {
    /// Zeroed buffers for `rows` poses of `model`.
    pub fn new(model: &FemModel, rows: usize) -> Self {
        let (pins, moments, nodes) = extra_sizes(model);
        Self {
            base: BatchBuffers::new(rows, model.arm.n()),
            pin_force_n: vec![0.0; rows * pins],
            moment_nmm: vec![0.0; rows * moments],
            dmoment_nmm: vec![0.0; rows * moments],
            node_xy: vec![0.0; rows * nodes],
            node_disp: vec![0.0; rows * nodes],
        }
    }

    /// The buffers as the solver's output slices.
    pub fn out(&mut self) -> FemBatchOutput<'_> {
        FemBatchOutput {
            base: self.base.out(),
            pin_force_n: &mut self.pin_force_n,
            moment_nmm: &mut self.moment_nmm,
            dmoment_nmm: &mut self.dmoment_nmm,
            node_xy: &mut self.node_xy,
            node_disp: &mut self.node_disp,
        }
    }
}

/// Per-pose sizes of the extra outputs of `model`: (pins×2, moments, nodes×2).
pub fn extra_sizes(model: &FemModel) -> (usize, usize, usize) {
    let n = model.arm.n();
    (
        4 * n,
        n * model.options.moment_samples,
        2 * model.shape.nodes.len(),
    )
}

/// Solves a batch of poses with the FE model, filling `out` in place.
///
/// # Errors
/// The error of the lowest failing row (shape, non-finite, zero length, mechanism, gaps that
/// do not settle); with `opts.nan_on_failure` a pose failure fills its row with NaN instead.
pub fn fem_solve_batch(
    model: &FemModel,
    input: BatchInput<'_>,
    opts: SolveOptions,
    out: FemBatchOutput<'_>,
) -> Result<()> {
    let arm = &model.arm;
    let n = arm.n();
    let rows = check_input(arm, &input)?;
    out.base.check_all(rows, n)?;
    let (pins, moments, nodes) = extra_sizes(model);
    for (what, got, per) in [
        ("pin_force_n", out.pin_force_n.len(), pins),
        ("moment_nmm", out.moment_nmm.len(), moments),
        ("dmoment_nmm", out.dmoment_nmm.len(), moments),
        ("node_xy", out.node_xy.len(), nodes),
        ("node_disp", out.node_disp.len(), nodes),
    ] {
        if got != rows * per {
            return Err(ArmError::Shape {
                what,
                expected: rows * per,
                got,
            });
        }
    }
    if rows < PARALLEL_THRESHOLD {
        return solve_chunk(model, input, opts, out, 0);
    }
    let bases = split_output(out.base, n, CHUNK, rows);
    let chunks: Vec<FemBatchOutput<'_>> = bases
        .into_iter()
        .zip(out.pin_force_n.chunks_mut(CHUNK * pins))
        .zip(out.moment_nmm.chunks_mut(CHUNK * moments))
        .zip(out.dmoment_nmm.chunks_mut(CHUNK * moments))
        .zip(out.node_xy.chunks_mut(CHUNK * nodes))
        .zip(out.node_disp.chunks_mut(CHUNK * nodes))
        .map(
            |(((((base, pin_force_n), moment_nmm), dmoment_nmm), node_xy), node_disp)| {
                FemBatchOutput {
                    base,
                    pin_force_n,
                    moment_nmm,
                    dmoment_nmm,
                    node_xy,
                    node_disp,
                }
            },
        )
        .collect();
    let errors: Vec<ArmError> = chunks
        .into_par_iter()
        .enumerate()
        .filter_map(|(k, chunk)| {
            let start = k * CHUNK;
            let m = chunk.base.dx_mm.len();
            let sub = BatchInput {
                alpha_deg: &input.alpha_deg[start * n..(start + m) * n],
                payload_n: &input.payload_n[2 * start..2 * (start + m)],
            };
            solve_chunk(model, sub, opts, chunk, start).err()
        })
        .collect();
    match errors.into_iter().next() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

fn solve_chunk(
    model: &FemModel,
    input: BatchInput<'_>,
    opts: SolveOptions,
    mut out: FemBatchOutput<'_>,
    first_row: usize,
) -> Result<()> {
    let n = model.arm.n();
    let (pins, moments, nodes) = extra_sizes(model);
    let mut ws = FemWorkspace::new(model);
    let mut alpha = vec![0.0; n];
    for p in 0..out.base.dx_mm.len() {
        let row = first_row + p;
        for (a, d) in alpha.iter_mut().zip(&input.alpha_deg[p * n..(p + 1) * n]) {
            *a = d.to_radians();
        }
        let payload = V2::new(input.payload_n[2 * p], input.payload_n[2 * p + 1]);
        if let Err(e) = ws.solve(model, &alpha, payload, opts.self_weight, row) {
            if !opts.nan_on_failure || !e.is_pose_failure() {
                return Err(e);
            }
            fill_nan(&mut out.base, p, n);
            out.pin_force_n[p * pins..(p + 1) * pins].fill(f64::NAN);
            out.moment_nmm[p * moments..(p + 1) * moments].fill(f64::NAN);
            out.dmoment_nmm[p * moments..(p + 1) * moments].fill(f64::NAN);
            out.node_xy[p * nodes..(p + 1) * nodes].fill(f64::NAN);
            out.node_disp[p * nodes..(p + 1) * nodes].fill(f64::NAN);
            continue;
        }
        let b = &mut out.base;
        for i in 0..n {
            let j = p * n + i;
            // Each drive's load in its own arrays (N or N·mm), NaN in the other.
            let nan = f64::NAN;
            let rotary = model.arm.is_rotary(i);
            let (f, df, t, dt) = if rotary {
                (nan, nan, ws.force[i], ws.dforce[i])
            } else {
                (ws.force[i], ws.dforce[i], nan, nan)
            };
            b.force_n[j] = f;
            b.dforce_n[j] = df;
            b.torque_nmm[j] = t;
            b.dtorque_nmm[j] = dt;
            b.reaction_n[2 * j] = ws.reaction[i].x;
            b.reaction_n[2 * j + 1] = ws.reaction[i].y;
            b.dalpha_deg[j] = ws.dalpha[i].to_degrees();
            b.dl_mm[j] = ws.body_dl[i];
            b.dlength_mm[j] = ws.dlength[i];
            b.length_mm[j] = ws.length[i];
            let pin = &mut out.pin_force_n[p * pins..(p + 1) * pins];
            // A rotary drive has no pin A: NaN there.
            let fa = if rotary {
                V2::repeat(nan)
            } else {
                ws.force[i] * ws.e[i]
            };
            pin[2 * i] = ws.reaction[i].x;
            pin[2 * i + 1] = ws.reaction[i].y;
            pin[2 * (n + i)] = fa.x;
            pin[2 * (n + i) + 1] = fa.y;
        }
        b.dx_mm[p] = ws.dmeasure.x;
        b.dy_mm[p] = ws.dmeasure.y;
        out.moment_nmm[p * moments..(p + 1) * moments].copy_from_slice(&ws.moment);
        out.dmoment_nmm[p * moments..(p + 1) * moments].copy_from_slice(&ws.dmoment);
        for (k, (xy, d)) in ws.node_xy.iter().zip(&ws.node_disp).enumerate() {
            let at = p * nodes + 2 * k;
            out.node_xy[at] = xy.x;
            out.node_xy[at + 1] = xy.y;
            out.node_disp[at] = d.x;
            out.node_disp[at + 1] = d.y;
        }
    }
    Ok(())
}
