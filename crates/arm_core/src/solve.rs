//! The batch solver: statics of both states, effects, exact loaded pose, for many poses.
//!
//! Poses are processed in chunks, in parallel with rayon above [`PARALLEL_THRESHOLD`] poses.
//! Arms of 1–6 links with the built-in effects go through the block kernel (`solve/fast.rs`: 16
//! poses at a time, structure of arrays); user-written deformations ([`ExtraDeformations`])
//! and longer arms go through the general path, one [`Workspace`] per chunk (nothing is
//! allocated per pose). Both give the status of every pose ([`solve_batch_status`]).

pub(crate) mod batch;
pub(crate) mod fast;
pub(crate) mod general;
mod loads;
pub mod sequence;
mod status;

use rayon::prelude::*;

use crate::arm::Arm;
use crate::effects::{EffectSet, ExtraDeformations};
use crate::error::{ArmError, Result};
use crate::geometry::V2;
use crate::kinematics::Frames;
use loads::Loads;

pub(crate) use batch::{fill_nan, write_outcome};
pub use batch::{BatchBuffers, BatchInput, BatchOutput};
pub use general::{SolveOptions, Workspace};

/// Below this many poses the batch runs on the calling thread.
pub const PARALLEL_THRESHOLD: usize = 2048;
/// Poses per parallel work item.
pub const CHUNK: usize = 1024;
/// Below this many poses the block kernel runs on the calling thread (it is ~5× faster per
/// pose than the general path, so it pays to split smaller batches).
pub const KERNEL_PARALLEL_THRESHOLD: usize = 512;
/// Poses per parallel work item of the block kernel (64 blocks).
pub const KERNEL_CHUNK: usize = 1024;

/// Checks shapes and finiteness of a batch; returns the number of poses.
///
/// # Errors
/// [`ArmError::Shape`] or [`ArmError::NonFinite`] naming the first bad row.
pub fn check_input(arm: &Arm, input: &BatchInput<'_>) -> Result<usize> {
    let loads = Loads::Forces(input.payload_n);
    let rows = loads::check_shapes(arm, input.alpha_deg, loads, 1)?;
    loads::check_finite(arm.n(), input.alpha_deg, loads, 1, 0, false)?;
    Ok(rows)
}

/// Payload masses (kg) of a batch's poses.
#[derive(Debug, Clone, Copy)]
pub enum Masses<'a> {
    /// One mass per pose.
    Each(&'a [f64]),
    /// The same mass for every pose.
    All(f64),
}

/// Solves a batch of poses, filling `out` in place.
///
/// # Errors
/// The error of the lowest failing row (shape, non-finite, singular, unreachable).
pub fn solve_batch(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
) -> Result<()> {
    solve_batch_extra(arm, effects, input, ExtraDeformations::none(), opts, out)
}

/// [`solve_batch`] with per-pose deformations from outside the catalogue (user effects,
/// docs/custom-effects.md) added to the built-in effects' before each pose is closed.
///
/// # Errors
/// The error of the lowest failing row (shape, non-finite, singular, unreachable); a wrong
/// size or a non-finite value of an extra array names the array (and the row).
pub fn solve_batch_extra(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    extra: ExtraDeformations<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
) -> Result<()> {
    // the rows from the input (an output not asked for is empty); check_input checks its shape
    let mut status = vec![0u8; input.alpha_deg.len() / arm.n()];
    solve_batch_status(arm, effects, input, extra, opts, out, &mut status)
}

/// [`solve_batch_extra`] that also writes the status code of every pose
/// ([`crate::validity::Status`], docs/model.md §7) into `status` (one per pose), computed in
/// the same pass. A pose that failed (NaN with `nan_on_failure`) gets the status of what is
/// known of it: its unloaded checks, else `large_deflection` (its angles are NaN).
///
/// # Errors
/// As [`solve_batch_extra`]; a `status` of the wrong length is a [`ArmError::Shape`].
#[allow(clippy::too_many_arguments)]
pub fn solve_batch_status(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    extra: ExtraDeformations<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
    status: &mut [u8],
) -> Result<()> {
    let (alpha, loads) = (input.alpha_deg, Loads::Forces(input.payload_n));
    run(arm, effects, alpha, loads, extra, opts, out, status, false)
}

/// [`solve_batch_status`] with payload masses instead of force rows: pose p carries the
/// force (0, −m_p·g) at its load point (`arm.g`), as `eodarm.solve` gives it. The forces
/// are made a chunk at a time, never for the whole batch.
///
/// # Errors
/// As [`solve_batch_status`]; a negative or non-finite mass is an error naming its row.
pub fn solve_batch_masses(
    arm: &Arm,
    effects: &EffectSet,
    alpha_deg: &[f64],
    masses: Masses<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
    status: &mut [u8],
) -> Result<()> {
    let one;
    let loads = match masses {
        Masses::Each(kg) => Loads::Masses { kg, shared: false },
        Masses::All(kg) => {
            one = [kg];
            Loads::Masses {
                kg: &one,
                shared: true,
            }
        }
    };
    let extra = ExtraDeformations::none();
    run(
        arm, effects, alpha_deg, loads, extra, opts, out, status, false,
    )
}

/// [`solve_batch_status`] through the general path only ([`Workspace::solve_extra`] pose by
/// pose), whatever the effects: the reference the block kernel is tested against.
///
/// # Errors
/// As [`solve_batch_status`].
#[allow(clippy::too_many_arguments)]
pub fn solve_batch_general(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    extra: ExtraDeformations<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
    status: &mut [u8],
) -> Result<()> {
    let (alpha, loads) = (input.alpha_deg, Loads::Forces(input.payload_n));
    run(arm, effects, alpha, loads, extra, opts, out, status, true)
}

#[allow(clippy::too_many_arguments)]
fn run(
    arm: &Arm,
    effects: &EffectSet,
    alpha_deg: &[f64],
    loads: Loads<'_>,
    extra: ExtraDeformations<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
    status: &mut [u8],
    general: bool,
) -> Result<()> {
    let n = arm.n();
    let rows = loads::check_shapes(arm, alpha_deg, loads, 1)?;
    extra.check(rows, n)?;
    extra.check_drives(arm)?;
    out.check(rows, n)?;
    if status.len() != rows {
        return Err(ArmError::Shape {
            what: "status",
            expected: rows,
            got: status.len(),
        });
    }
    // The block kernel covers the built-in effects of arms of 1–6 links; user-written
    // deformations and longer arms take the general path.
    let kernel = if extra.is_none() && !general {
        fast::Kernel::new(arm, effects, opts.self_weight)
    } else {
        None
    };
    let simd = pulp::Arch::new();
    let ctx = fast::Ctx { arm, effects, opts };
    // A chunk's rows are its statuses' (every output but the status may be absent). Its
    // input is checked first, by the thread that solves it (the rows are then in its cache);
    // masses become force rows in `buf`, a chunk at a time.
    let run = |start: usize, chunk: BatchOutput<'_>, st: &mut [u8], buf: &mut Vec<f64>| {
        let m = st.len();
        let alpha = &alpha_deg[start * n..(start + m) * n];
        let loads = loads.rows(start, m, 1);
        loads::check_finite(n, alpha, loads, 1, start, false)?;
        let sub = BatchInput {
            alpha_deg: alpha,
            payload_n: loads.forces(m, arm.g, buf),
        };
        match &kernel {
            Some(k) => k.chunk(simd, &ctx, sub, chunk, st, start),
            None => {
                let extra = extra.rows(start, m, n);
                solve_chunk(arm, effects, sub, extra, opts, chunk, st, start)
            }
        }
    };
    let (threshold, chunk_rows) = match kernel {
        Some(_) => (KERNEL_PARALLEL_THRESHOLD, KERNEL_CHUNK),
        None => (PARALLEL_THRESHOLD, CHUNK),
    };
    if rows < threshold {
        return run(0, out, status, &mut Vec::new());
    }
    let chunks = split_output(out, n, chunk_rows, rows);
    let errors = chunks
        .into_par_iter()
        .zip(status.par_chunks_mut(chunk_rows))
        .enumerate()
        .map_init(Vec::new, |buf, (k, (chunk, st))| {
            run(k * chunk_rows, chunk, st, buf).err()
        })
        .flatten()
        .collect();
    // Chunks come back in order: the first error is the lowest failing chunk's.
    loads::first_error(errors)
}

/// `out` (`total` rows of an `n`-link arm) cut into chunks of `rows` rows (the last may be
/// shorter); an output not asked for (empty) is empty in every chunk.
pub(crate) fn split_output<'a>(
    out: BatchOutput<'a>,
    n: usize,
    rows: usize,
    total: usize,
) -> Vec<BatchOutput<'a>> {
    let count = total.div_ceil(rows);
    // the chunks of an output asked for; `count` empty slices for one that is not
    let parts = |s: &'a mut [f64], width: usize| {
        s.chunks_mut(rows * width)
            .chain(std::iter::repeat_with(<&mut [f64]>::default))
            .take(count)
    };
    let mut f = parts(out.force_n, n);
    let mut r = parts(out.reaction_n, 2 * n);
    let mut df = parts(out.dforce_n, n);
    let mut t = parts(out.torque_nmm, n);
    let mut dt = parts(out.dtorque_nmm, n);
    let mut dx = parts(out.dx_mm, 1);
    let mut dy = parts(out.dy_mm, 1);
    let mut da = parts(out.dalpha_deg, n);
    let mut dl = parts(out.dl_mm, n);
    let mut dlen = parts(out.dlength_mm, n);
    let mut len = parts(out.length_mm, n);
    let mut chunks = Vec::with_capacity(count);
    while let (
        Some(force_n),
        Some(reaction_n),
        Some(dforce_n),
        Some(torque_nmm),
        Some(dtorque_nmm),
        Some(dx_mm),
        Some(dy_mm),
        Some(dalpha_deg),
        Some(dl_mm),
        Some(dlength_mm),
        Some(length_mm),
    ) = (
        f.next(),
        r.next(),
        df.next(),
        t.next(),
        dt.next(),
        dx.next(),
        dy.next(),
        da.next(),
        dl.next(),
        dlen.next(),
        len.next(),
    ) {
        chunks.push(BatchOutput {
            force_n,
            reaction_n,
            dforce_n,
            torque_nmm,
            dtorque_nmm,
            dx_mm,
            dy_mm,
            dalpha_deg,
            dl_mm,
            dlength_mm,
            length_mm,
        });
    }
    chunks
}

/// The general path over one chunk: [`Workspace::solve_extra`] pose by pose.
#[allow(clippy::too_many_arguments, clippy::needless_range_loop)] // p indexes the outputs
fn solve_chunk(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    extra: ExtraDeformations<'_>,
    opts: SolveOptions,
    mut out: BatchOutput<'_>,
    status: &mut [u8],
    first_row: usize,
) -> Result<()> {
    let n = arm.n();
    let mut ws = Workspace::new(arm);
    let mut loaded = Frames::new(n);
    let reach = crate::validity::reach(arm);
    let rise_checked = crate::validity::checks_load_rise(arm, effects);
    let mut alpha = vec![0.0; n];
    for p in 0..status.len() {
        let row = first_row + p;
        for (a, d) in alpha.iter_mut().zip(&input.alpha_deg[p * n..(p + 1) * n]) {
            *a = d.to_radians();
        }
        let payload = V2::new(input.payload_n[2 * p], input.payload_n[2 * p + 1]);
        let solved = ws.solve_extra(arm, effects, &alpha, payload, opts, row, (&extra, p));
        let solved = write_outcome(arm, &ws, &alpha, solved, opts, &mut out, p)?;
        let down = payload.y < 0.0;
        // the load point's rise is checked where no user-written deformation acts on the pose
        let lift = rise_checked && status::no_extra(&extra, p, n);
        status[p] = status::pose_status(arm, &ws, &alpha, solved, &mut loaded, down, reach, lift);
    }
    Ok(())
}
