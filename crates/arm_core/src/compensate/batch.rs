//! Compensation of many poses at once: output buffers, checks, the parallel batch.

use rayon::prelude::*;

use super::{CompensateOptions, CompensateStatus, Compensator};
use crate::arm::Arm;
use crate::effects::EffectSet;
use crate::error::{ArmError, Result};
use crate::geometry::V2;
use crate::solve::{check_input, BatchInput};

/// Below this many poses a batch runs on the calling thread.
pub const PARALLEL_THRESHOLD: usize = 512;
/// Poses per parallel work item.
pub const CHUNK: usize = 256;

/// Outputs of a compensation batch, row-major, filled in place.
#[derive(Debug)]
pub struct CompensateOutput<'a> {
    /// Commanded unloaded angles (deg), `N × n`; NaN where the status is not ok.
    pub alpha_deg: &'a mut [f64],
    /// Unloaded pin-to-pin actuator lengths of the commanded pose (mm), `N × n`; NaN where
    /// the status is not ok.
    pub length_mm: &'a mut [f64],
    /// The model's remaining miss of the measure point (mm), `N` (see
    /// [`super::PoseResult::residual_mm`]).
    pub residual_mm: &'a mut [f64],
    /// [`CompensateStatus::code`], `N`.
    pub status: &'a mut [u8],
    /// Gauss–Newton steps taken, `N`.
    pub iterations: &'a mut [u32],
    /// The actuator concerned (1-based, 0 for none), `N` (see [`super::PoseResult::actuator`]).
    pub actuator: &'a mut [u32],
}

/// Owned output buffers of a batch, lent by [`CompensateBuffers::out`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CompensateBuffers {
    /// See [`CompensateOutput::alpha_deg`].
    pub alpha_deg: Vec<f64>,
    /// See [`CompensateOutput::length_mm`].
    pub length_mm: Vec<f64>,
    /// See [`CompensateOutput::residual_mm`].
    pub residual_mm: Vec<f64>,
    /// See [`CompensateOutput::status`].
    pub status: Vec<u8>,
    /// See [`CompensateOutput::iterations`].
    pub iterations: Vec<u32>,
    /// See [`CompensateOutput::actuator`].
    pub actuator: Vec<u32>,
}

impl CompensateBuffers {
    /// Buffers for `rows` poses of an `n`-link arm.
    pub fn new(rows: usize, n: usize) -> Self {
        Self {
            alpha_deg: vec![0.0; rows * n],
            length_mm: vec![0.0; rows * n],
            residual_mm: vec![0.0; rows],
            status: vec![0; rows],
            iterations: vec![0; rows],
            actuator: vec![0; rows],
        }
    }

    /// The buffers as the output slices.
    pub fn out(&mut self) -> CompensateOutput<'_> {
        CompensateOutput {
            alpha_deg: &mut self.alpha_deg,
            length_mm: &mut self.length_mm,
            residual_mm: &mut self.residual_mm,
            status: &mut self.status,
            iterations: &mut self.iterations,
            actuator: &mut self.actuator,
        }
    }
}

impl<'a> CompensateOutput<'a> {
    fn check(&self, rows: usize, n: usize) -> Result<()> {
        let want = [
            ("alpha_deg", self.alpha_deg.len(), rows * n),
            ("length_mm", self.length_mm.len(), rows * n),
            ("residual_mm", self.residual_mm.len(), rows),
            ("status", self.status.len(), rows),
            ("iterations", self.iterations.len(), rows),
            ("actuator", self.actuator.len(), rows),
        ];
        for (what, got, expected) in want {
            if got != expected {
                return Err(ArmError::Shape {
                    what,
                    expected,
                    got,
                });
            }
        }
        Ok(())
    }

    fn split(self, n: usize, rows: usize) -> Vec<CompensateOutput<'a>> {
        let mut a = self.alpha_deg.chunks_mut(rows * n);
        let mut l = self.length_mm.chunks_mut(rows * n);
        let mut r = self.residual_mm.chunks_mut(rows);
        let mut s = self.status.chunks_mut(rows);
        let mut it = self.iterations.chunks_mut(rows);
        let mut ac = self.actuator.chunks_mut(rows);
        let mut out = Vec::new();
        while let (Some(alpha_deg), Some(length_mm), Some(residual_mm), Some(status)) =
            (a.next(), l.next(), r.next(), s.next())
        {
            let (Some(iterations), Some(actuator)) = (it.next(), ac.next()) else {
                break;
            };
            out.push(CompensateOutput {
                alpha_deg,
                length_mm,
                residual_mm,
                status,
                iterations,
                actuator,
            });
        }
        out
    }
}

/// Compensates N poses: `input.alpha_deg` (N × n) the nominal unloaded angles (deg),
/// `input.payload_n` (N × 2) the payload force at the load point (N, global). In parallel
/// (rayon) from [`PARALLEL_THRESHOLD`] poses.
///
/// A pose that cannot be compensated gets its status (and NaN angles and lengths); it does
/// not fail the batch.
///
/// # Errors
/// [`ArmError::Shape`] for arrays of the wrong size, [`ArmError::NonFinite`] naming the first
/// row with a non-finite angle or payload, [`ArmError::InvalidOption`] for a bad option.
pub fn compensate_batch(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    opts: CompensateOptions,
    out: CompensateOutput<'_>,
) -> Result<()> {
    let n = arm.n();
    opts.check(n)?;
    let rows = check_input(arm, &input)?;
    out.check(rows, n)?;
    if rows < PARALLEL_THRESHOLD {
        return compensate_chunk(arm, effects, input, &opts, out, 0);
    }
    let errors: Vec<ArmError> = out
        .split(n, CHUNK)
        .into_par_iter()
        .enumerate()
        .filter_map(|(k, chunk)| {
            let start = k * CHUNK;
            let m = chunk.residual_mm.len();
            let sub = BatchInput {
                alpha_deg: &input.alpha_deg[start * n..(start + m) * n],
                payload_n: &input.payload_n[2 * start..2 * (start + m)],
            };
            compensate_chunk(arm, effects, sub, &opts, chunk, start).err()
        })
        .collect();
    match errors.into_iter().next() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

fn compensate_chunk(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    opts: &CompensateOptions,
    out: CompensateOutput<'_>,
    first_row: usize,
) -> Result<()> {
    let n = arm.n();
    let mut c = Compensator::new(arm);
    let mut nominal = vec![0.0; n];
    for p in 0..out.residual_mm.len() {
        let src = &input.alpha_deg[p * n..(p + 1) * n];
        for (a, d) in nominal.iter_mut().zip(src) {
            *a = d.to_radians();
        }
        let payload = V2::new(input.payload_n[2 * p], input.payload_n[2 * p + 1]);
        let res = c.compensate(arm, effects, &nominal, payload, opts, first_row + p)?;
        let dst_a = &mut out.alpha_deg[p * n..(p + 1) * n];
        let dst_l = &mut out.length_mm[p * n..(p + 1) * n];
        if res.status == CompensateStatus::Ok {
            // The change in degrees added to the given degrees: no round trip of the nominal.
            for j in 0..n {
                dst_a[j] = src[j] + (c.alpha()[j] - nominal[j]).to_degrees();
            }
            dst_l.copy_from_slice(c.length());
        } else {
            dst_a.fill(f64::NAN);
            dst_l.fill(f64::NAN);
        }
        out.residual_mm[p] = res.residual_mm;
        out.status[p] = res.status.code();
        out.iterations[p] = res.iterations;
        out.actuator[p] = res.actuator;
    }
    Ok(())
}
