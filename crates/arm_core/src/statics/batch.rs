//! The statics of both states for many poses at once, without solving the loaded pose: what
//! user-written effects read (docs/custom-effects.md, `EffectState`). The numbers are those of
//! [`crate::solve_batch`] (same recursion, same order of operations).

use rayon::prelude::*;

use super::{solve_forces, ActuatorLines, Forces};
use crate::arm::Arm;
use crate::error::{ArmError, Result};
use crate::geometry::V2;
use crate::kinematics::Frames;
use crate::solve::{check_input, BatchInput, CHUNK, PARALLEL_THRESHOLD};

/// Outputs of [`statics_batch`], row-major, filled in place. Each joint's load is in the
/// force arrays (linear actuator) or the torque arrays (rotary drive), NaN in the other.
#[derive(Debug)]
pub struct StaticsOutput<'a> {
    /// Loaded actuator forces (N, compression +), `N × n`; NaN at rotary drives.
    pub force_n: &'a mut [f64],
    /// Unloaded actuator forces (self-weight only; zero without), `N × n`; NaN at rotary
    /// drives.
    pub force0_n: &'a mut [f64],
    /// Loaded drive torques (N·mm, counter-clockwise + on link i), `N × n`; NaN at linear
    /// actuators.
    pub torque_nmm: &'a mut [f64],
    /// Unloaded drive torques (N·mm), `N × n`; NaN at linear actuators.
    pub torque0_nmm: &'a mut [f64],
    /// Loaded joint reactions, force of body i−1 on link i (N, global), `N × n × 2`.
    pub reaction_n: &'a mut [f64],
    /// Unloaded joint reactions, `N × n × 2`.
    pub reaction0_n: &'a mut [f64],
    /// Unloaded pin-to-pin actuator lengths (mm), `N × n`; NaN at rotary drives.
    pub length_mm: &'a mut [f64],
}

/// Owned, zeroed buffers of [`StaticsOutput`] for `rows` poses of an `n`-link arm.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StaticsBuffers {
    /// See [`StaticsOutput::force_n`].
    pub force_n: Vec<f64>,
    /// See [`StaticsOutput::force0_n`].
    pub force0_n: Vec<f64>,
    /// See [`StaticsOutput::torque_nmm`].
    pub torque_nmm: Vec<f64>,
    /// See [`StaticsOutput::torque0_nmm`].
    pub torque0_nmm: Vec<f64>,
    /// See [`StaticsOutput::reaction_n`].
    pub reaction_n: Vec<f64>,
    /// See [`StaticsOutput::reaction0_n`].
    pub reaction0_n: Vec<f64>,
    /// See [`StaticsOutput::length_mm`].
    pub length_mm: Vec<f64>,
}

impl StaticsBuffers {
    /// Zeroed buffers for `rows` poses of an `n`-link arm.
    pub fn new(rows: usize, n: usize) -> Self {
        Self {
            force_n: vec![0.0; rows * n],
            force0_n: vec![0.0; rows * n],
            torque_nmm: vec![0.0; rows * n],
            torque0_nmm: vec![0.0; rows * n],
            reaction_n: vec![0.0; rows * n * 2],
            reaction0_n: vec![0.0; rows * n * 2],
            length_mm: vec![0.0; rows * n],
        }
    }

    /// The buffers as the output slices.
    pub fn out(&mut self) -> StaticsOutput<'_> {
        StaticsOutput {
            force_n: &mut self.force_n,
            force0_n: &mut self.force0_n,
            torque_nmm: &mut self.torque_nmm,
            torque0_nmm: &mut self.torque0_nmm,
            reaction_n: &mut self.reaction_n,
            reaction0_n: &mut self.reaction0_n,
            length_mm: &mut self.length_mm,
        }
    }
}

impl<'a> StaticsOutput<'a> {
    fn check(&self, rows: usize, n: usize) -> Result<()> {
        let want = [
            ("force_n", self.force_n.len(), rows * n),
            ("force0_n", self.force0_n.len(), rows * n),
            ("torque_nmm", self.torque_nmm.len(), rows * n),
            ("torque0_nmm", self.torque0_nmm.len(), rows * n),
            ("reaction_n", self.reaction_n.len(), rows * n * 2),
            ("reaction0_n", self.reaction0_n.len(), rows * n * 2),
            ("length_mm", self.length_mm.len(), rows * n),
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

    /// Splits into chunks of `rows` poses.
    fn split(self, n: usize, rows: usize) -> Vec<StaticsOutput<'a>> {
        let per_link = rows * n;
        self.force_n
            .chunks_mut(per_link)
            .zip(self.force0_n.chunks_mut(per_link))
            .zip(self.torque_nmm.chunks_mut(per_link))
            .zip(self.torque0_nmm.chunks_mut(per_link))
            .zip(self.reaction_n.chunks_mut(2 * per_link))
            .zip(self.reaction0_n.chunks_mut(2 * per_link))
            .zip(self.length_mm.chunks_mut(per_link))
            .map(
                |(
                    (((((force_n, force0_n), torque_nmm), torque0_nmm), reaction_n), reaction0_n),
                    length_mm,
                )| {
                    StaticsOutput {
                        force_n,
                        force0_n,
                        torque_nmm,
                        torque0_nmm,
                        reaction_n,
                        reaction0_n,
                        length_mm,
                    }
                },
            )
            .collect()
    }
}

/// Drive loads (forces, torques) and reactions of the unloaded (self-weight, when
/// `self_weight`) and the loaded (plus the payload) state of every pose, on the undeformed
/// geometry, and the unloaded actuator lengths.
///
/// # Errors
/// Shape or non-finite input; singular poses and coincident pins (the lowest failing row).
pub fn statics_batch(
    arm: &Arm,
    input: BatchInput<'_>,
    self_weight: bool,
    out: StaticsOutput<'_>,
) -> Result<()> {
    let n = arm.n();
    let rows = check_input(arm, &input)?;
    out.check(rows, n)?;
    if rows < PARALLEL_THRESHOLD {
        return chunk(arm, input, self_weight, out, 0);
    }
    let errors: Vec<ArmError> = out
        .split(n, CHUNK)
        .into_par_iter()
        .enumerate()
        .filter_map(|(k, part)| {
            let start = k * CHUNK;
            let m = part.length_mm.len() / n;
            let sub = BatchInput {
                alpha_deg: &input.alpha_deg[start * n..(start + m) * n],
                payload_n: &input.payload_n[2 * start..2 * (start + m)],
            };
            chunk(arm, sub, self_weight, part, start).err()
        })
        .collect();
    match errors.into_iter().next() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

fn chunk(
    arm: &Arm,
    input: BatchInput<'_>,
    self_weight: bool,
    out: StaticsOutput<'_>,
    first_row: usize,
) -> Result<()> {
    let n = arm.n();
    let mut frames = Frames::new(n);
    let mut lines = ActuatorLines::new(n);
    let (mut weight, mut delta, mut loaded) = (Forces::new(n), Forces::new(n), Forces::new(n));
    let mut alpha = vec![0.0; n];
    for p in 0..out.length_mm.len() / n {
        for (a, d) in alpha.iter_mut().zip(&input.alpha_deg[p * n..(p + 1) * n]) {
            *a = d.to_radians();
        }
        let payload = V2::new(input.payload_n[2 * p], input.payload_n[2 * p + 1]);
        frames.fill(arm, &alpha);
        lines.fill(arm, &frames, first_row + p)?;
        solve_forces(arm, &frames, &lines, self_weight, V2::zeros(), &mut weight);
        solve_forces(arm, &frames, &lines, false, payload, &mut delta);
        loaded.set_sum(&weight, &delta);
        for i in 0..n {
            let j = p * n + i;
            // Each drive's load in its own array (N or N·mm), NaN in the other.
            let nan = f64::NAN;
            let (load, load0) = (loaded.f[i], weight.f[i]);
            let (f, f0, t, t0) = if arm.is_rotary(i) {
                (nan, nan, load, load0)
            } else {
                (load, load0, nan, nan)
            };
            out.force_n[j] = f;
            out.force0_n[j] = f0;
            out.torque_nmm[j] = t;
            out.torque0_nmm[j] = t0;
            out.reaction_n[2 * j] = loaded.r[i].x;
            out.reaction_n[2 * j + 1] = loaded.r[i].y;
            out.reaction0_n[2 * j] = weight.r[i].x;
            out.reaction0_n[2 * j + 1] = weight.r[i].y;
            out.length_mm[j] = lines.length[i];
        }
    }
    Ok(())
}
