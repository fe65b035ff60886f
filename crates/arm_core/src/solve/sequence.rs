//! Load sequences (docs/model.md, "Load sequences and friction"): N sequences of S states
//! each, every state relative to its sequence's reference (the unloaded pose, self-weight
//! only, in which the sensors were zeroed).
//!
//! Each state is one [`Workspace::solve_state`] with the sequence's [`SequenceMemory`], handed
//! from one state to the next: the frictions hold what the states before let them hold, and
//! the gaps are taken up along each state's own actual force. Sequences are independent and
//! run in parallel (rayon over chunks of sequences); the states of one sequence run in order.
//! A single loading (`solve`) is the case S = 1.

use rayon::prelude::*;

pub use super::batch::SequenceInput;
use super::loads::{self, Loads};
use super::status::pose_status;
use super::{split_output, write_outcome, BatchBuffers, BatchOutput, SolveOptions, Workspace};
use crate::arm::Arm;
use crate::effects::{EffectSet, ExtraDeformations, SequenceMemory};
use crate::error::{ArmError, Result};
use crate::geometry::V2;
use crate::kinematics::Frames;

/// States per parallel work item (whole sequences of about this many states).
const CHUNK_STATES: usize = 1024;

/// Solves N load sequences of S states, filling `out` (N·S rows, sequence-major: row
/// `q·S + s` is state s of sequence q) and `status` (N·S) in place. Every output is that
/// state's: `force_n`, `reaction_n` the actual forces (the reference's plus what the springs
/// and pins take), `dforce_n`, the displacements and length changes relative to the reference.
///
/// # Errors
/// Wrong shapes or non-finite input naming the sequence; otherwise the error of the lowest
/// failing sequence (singular, a triangle that cannot close: its row is the sequence's
/// index), unless `opts.nan_on_failure` fills that state with NaN.
pub fn solve_sequence(
    arm: &Arm,
    effects: &EffectSet,
    input: SequenceInput<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
    status: &mut [u8],
) -> Result<()> {
    let loads = Loads::Forces(input.payload_n);
    let (alpha, s) = (input.alpha_deg, input.states);
    run_sequences(arm, effects, alpha, loads, s, opts, out, status)
}

/// [`solve_sequence`] with the payload masses (kg) of the states instead of their forces:
/// state s of sequence q carries (0, −m·g) at the load point (`arm.g`), as
/// `eodarm.solve_sequence` gives it. `mass_kg` holds N·S masses (sequence-major), or S that
/// every sequence goes through; the forces are made a chunk of sequences at a time.
///
/// # Errors
/// As [`solve_sequence`]; a negative or non-finite mass names its sequence.
#[allow(clippy::too_many_arguments)]
pub fn solve_sequence_masses(
    arm: &Arm,
    effects: &EffectSet,
    alpha_deg: &[f64],
    mass_kg: &[f64],
    states: usize,
    opts: SolveOptions,
    out: BatchOutput<'_>,
    status: &mut [u8],
) -> Result<()> {
    // one sequence's S masses are the same either way
    let shared = states > 0 && mass_kg.len() == states;
    let loads = Loads::Masses {
        kg: mass_kg,
        shared,
    };
    run_sequences(arm, effects, alpha_deg, loads, states, opts, out, status)
}

/// [`solve_sequence`] of either kind of payloads.
#[allow(clippy::too_many_arguments)]
fn run_sequences(
    arm: &Arm,
    effects: &EffectSet,
    alpha_deg: &[f64],
    loads: Loads<'_>,
    s: usize,
    opts: SolveOptions,
    out: BatchOutput<'_>,
    status: &mut [u8],
) -> Result<()> {
    let n = arm.n();
    let seqs = loads::check_shapes(arm, alpha_deg, loads, s)?;
    out.check(seqs * s, n)?;
    if status.len() != seqs * s {
        return Err(ArmError::Shape {
            what: "status",
            expected: seqs * s,
            got: status.len(),
        });
    }
    if seqs == 0 || s == 0 {
        return Ok(());
    }
    // The block kernel, 16 sequences at a time; the general path for what it lacks. A chunk's
    // input is checked first, by the thread that solves it; masses become force rows in
    // `buf`, a chunk at a time.
    let kernel = super::fast::Kernel::new(arm, effects, opts.self_weight);
    let simd = pulp::Arch::new();
    let run = |first: usize, chunk: BatchOutput<'_>, st: &mut [u8], buf: &mut Vec<f64>| {
        let m = st.len() / s; // an output not asked for is empty: the statuses count
        let alpha = &alpha_deg[first * n..(first + m) * n];
        let loads = loads.rows(first, m, s);
        loads::check_finite(n, alpha, loads, s, first, true)?;
        let sub = SequenceInput {
            alpha_deg: alpha,
            payload_n: loads.forces(m, arm.g, buf),
            states: s,
        };
        match &kernel {
            Some(k) => run_kernel(k, simd, arm, effects, sub, opts, chunk, st, first),
            None => run_chunk(arm, effects, sub, opts, chunk, st, first),
        }
    };
    let per_chunk = (CHUNK_STATES / s).max(1);
    if seqs <= per_chunk {
        return run(0, out, status, &mut Vec::new());
    }
    let chunks = split_output(out, n, per_chunk * s, seqs * s);
    let errors = chunks
        .into_par_iter()
        .zip(status.par_chunks_mut(per_chunk * s))
        .enumerate()
        .map_init(Vec::new, |buf, (k, (chunk, st))| {
            run(k * per_chunk, chunk, st, buf).err()
        })
        .flatten()
        .collect();
    // Chunks come back in order: the first error is the lowest failing chunk's.
    loads::first_error(errors)
}

/// The sequences of one chunk on the block kernel; a sequence with a state the kernel could
/// not solve is solved again by the general path (its error, or its NaN rows).
#[allow(clippy::too_many_arguments)]
fn run_kernel(
    kernel: &super::fast::Kernel,
    simd: pulp::Arch,
    arm: &Arm,
    effects: &EffectSet,
    input: SequenceInput<'_>,
    opts: SolveOptions,
    mut out: BatchOutput<'_>,
    status: &mut [u8],
    first: usize,
) -> Result<()> {
    let failed = kernel.sequences(simd, input, &mut out, status, false);
    solve_again(
        arm, effects, input, opts, failed, &mut out, status, first, false,
    )
}

/// Solves the sequences `again` of `input` (chunk-local; `first` is the index of its first
/// sequence) on the general path, one at a time, and writes their rows of `out` and
/// `status`: every state (rows `q·S + s`), or with `last_only` the last one (row `q`).
#[allow(clippy::too_many_arguments)]
fn solve_again(
    arm: &Arm,
    effects: &EffectSet,
    input: SequenceInput<'_>,
    opts: SolveOptions,
    again: impl IntoIterator<Item = usize>,
    out: &mut BatchOutput<'_>,
    status: &mut [u8],
    first: usize,
    last_only: bool,
) -> Result<()> {
    let n = arm.n();
    let s = input.states;
    let mut one = BatchBuffers::new(s, n);
    let mut st = vec![0u8; s];
    for q in again {
        let sub = SequenceInput {
            alpha_deg: &input.alpha_deg[q * n..(q + 1) * n],
            payload_n: &input.payload_n[2 * s * q..2 * s * (q + 1)],
            states: s,
        };
        run_chunk(arm, effects, sub, opts, one.out(), &mut st, first + q)?;
        if last_only {
            super::fast::copy_row(&one, s - 1, out, q, n);
            status[q] = st[s - 1];
        } else {
            for k in 0..s {
                super::fast::copy_row(&one, k, out, q * s + k, n);
            }
            status[q * s..(q + 1) * s].copy_from_slice(&st);
        }
    }
    Ok(())
}

/// The sequences of one chunk, in order; `first` is the index of its first sequence.
fn run_chunk(
    arm: &Arm,
    effects: &EffectSet,
    input: SequenceInput<'_>,
    opts: SolveOptions,
    mut out: BatchOutput<'_>,
    status: &mut [u8],
    first: usize,
) -> Result<()> {
    let n = arm.n();
    let s = input.states;
    let mut ws = Workspace::new(arm);
    let mut memory = SequenceMemory::new(n);
    let mut loaded = Frames::new(n);
    let reach = crate::validity::reach(arm);
    let lift = crate::validity::checks_load_rise(arm, effects);
    let mut alpha = vec![0.0; n];
    let none = ExtraDeformations::none();
    for q in 0..status.len() / s {
        let row = first + q;
        for (a, d) in alpha.iter_mut().zip(&input.alpha_deg[q * n..(q + 1) * n]) {
            *a = d.to_radians();
        }
        memory.reset();
        // The reference's geometry and forces are the same for every state.
        let prepared = ws.prepare(arm, &alpha, opts, row);
        for k in 0..s {
            let p = q * s + k;
            let payload = V2::new(input.payload_n[2 * p], input.payload_n[2 * p + 1]);
            let solved = match &prepared {
                Ok(()) => ws.solve_prepared(arm, effects, payload, row, (&none, 0), &mut memory),
                Err(e) => Err(e.clone()),
            };
            let solved = write_outcome(arm, &ws, &alpha, solved, opts, &mut out, p)?;
            let down = payload.y < 0.0;
            status[p] = pose_status(arm, &ws, &alpha, solved, &mut loaded, down, reach, lift);
        }
    }
    Ok(())
}

/// Cells per parallel work item of [`cycle_returns`] (whole poses).
const CYCLE_CELLS: usize = 4096;

/// Where the measure point comes back to after each cell's load cycle (docs/model.md, "Load
/// sequences and friction"): for pose p (`alpha_deg` row, degrees) and payload mass m_j
/// (`mass_kg`, kg, downward), the sequence reference → m_j → 0, and `dx[p·M + j]`,
/// `dy[p·M + j]` (mm) the measure point at its last state relative to the reference; NaN
/// where the cycle cannot be solved (a singular pose, a triangle that cannot close). The same
/// as the last state of [`solve_sequence`] with states `[m_j, 0]`, without the other outputs.
///
/// # Errors
/// Wrong shapes or a non-finite angle or mass (naming the pose, or the mass's index).
pub fn cycle_returns(
    arm: &Arm,
    effects: &EffectSet,
    alpha_deg: &[f64],
    mass_kg: &[f64],
    self_weight: bool,
    dx: &mut [f64],
    dy: &mut [f64],
) -> Result<()> {
    let n = arm.n();
    let m = mass_kg.len();
    let poses = arm.pose_rows(alpha_deg)?;
    for (what, got) in [("dx", dx.len()), ("dy", dy.len())] {
        if got != poses * m {
            return Err(ArmError::Shape {
                what,
                expected: poses * m,
                got,
            });
        }
    }
    if let Some(p) =
        (0..poses).find(|p| !alpha_deg[p * n..(p + 1) * n].iter().all(|v| v.is_finite()))
    {
        return Err(ArmError::NonFinite {
            row: p,
            what: "alpha_deg",
        });
    }
    if let Some(j) = mass_kg.iter().position(|v| !v.is_finite()) {
        return Err(ArmError::NonFinite {
            row: j,
            what: "mass_kg",
        });
    }
    if poses == 0 || m == 0 {
        return Ok(());
    }
    let kernel = super::fast::Kernel::new(arm, effects, self_weight);
    let simd = pulp::Arch::new();
    let opts = SolveOptions {
        self_weight,
        nan_on_failure: true,
    };
    let per_chunk = (CYCLE_CELLS / m).max(1) * m;
    // Per thread: the chunk's sequences, and the outputs of their last states (only the
    // measure point's: nothing else is written).
    let scratch = || {
        let out = BatchBuffers::with_outputs(per_chunk, n, |k| k == "dx_mm" || k == "dy_mm");
        (Vec::new(), Vec::new(), out, vec![0u8; per_chunk])
    };
    dx.par_chunks_mut(per_chunk)
        .zip(dy.par_chunks_mut(per_chunk))
        .enumerate()
        .try_for_each_init(scratch, |(alpha, payload, last, status), (k, (dx, dy))| {
            let (p0, cells) = (k * per_chunk / m, dx.len());
            alpha.clear();
            payload.clear();
            for p in p0..p0 + cells / m {
                for &mass in mass_kg {
                    alpha.extend_from_slice(&alpha_deg[p * n..(p + 1) * n]);
                    payload.extend_from_slice(&[0.0, -mass * arm.g, 0.0, 0.0]);
                }
            }
            let input = SequenceInput {
                alpha_deg: alpha,
                payload_n: payload,
                states: 2,
            };
            let mut out = last.first_rows(cells, n);
            let status = &mut status[..cells];
            let again: Vec<usize> = match &kernel {
                Some(kern) => kern.sequences(simd, input, &mut out, status, true),
                None => (0..cells).collect(),
            };
            // sequence q of the chunk is pose p0 + q / M: errors name the sequence p0·M + q
            solve_again(
                arm,
                effects,
                input,
                opts,
                again,
                &mut out,
                status,
                p0 * m,
                true,
            )?;
            dx.copy_from_slice(out.dx_mm);
            dy.copy_from_slice(out.dy_mm);
            Ok(())
        })
}
