//! The batch's inputs and outputs, and the writing of one solved (or failed) row: shared by
//! the batch drivers (`solve.rs`), the block kernel (`solve/fast.rs`) and the status
//! (`solve/status.rs`), below all of them.

use super::general::Workspace;
use crate::arm::Arm;
use crate::error::{ArmError, Result};

/// Inputs of a batch: `N` poses of an `n`-link arm, row-major.
#[derive(Debug, Clone, Copy)]
pub struct BatchInput<'a> {
    /// Unloaded absolute angles (deg), `N × n`.
    pub alpha_deg: &'a [f64],
    /// Payload force at the load point (N, global), `N × 2`.
    pub payload_n: &'a [f64],
}

/// Outputs of a batch, row-major, to be filled in place. A joint's load is in the force
/// arrays (linear actuator) or the torque arrays (rotary drive), NaN in the other; the
/// lengths and `dl_mm` are NaN at rotary drives.
#[derive(Debug)]
pub struct BatchOutput<'a> {
    /// Loaded actuator forces (N), `N × n`.
    pub force_n: &'a mut [f64],
    /// Loaded joint reactions (N), `N × n × 2`.
    pub reaction_n: &'a mut [f64],
    /// Force changes unloaded → loaded (N), `N × n`.
    pub dforce_n: &'a mut [f64],
    /// Loaded drive torques (N·mm, counter-clockwise + on link i), `N × n`.
    pub torque_nmm: &'a mut [f64],
    /// Torque changes unloaded → loaded (N·mm), `N × n`.
    pub dtorque_nmm: &'a mut [f64],
    /// Measurement point displacement x (mm), `N`.
    pub dx_mm: &'a mut [f64],
    /// Measurement point displacement y (mm), `N`.
    pub dy_mm: &'a mut [f64],
    /// Change of absolute link angles (deg), `N × n`.
    pub dalpha_deg: &'a mut [f64],
    /// Actuator body length change seen by its sensor (mm), `N × n`.
    pub dl_mm: &'a mut [f64],
    /// Pin-to-pin length change (mm), `N × n`.
    pub dlength_mm: &'a mut [f64],
    /// Unloaded pin-to-pin length (mm), `N × n`.
    pub length_mm: &'a mut [f64],
}

/// Owned, zeroed output buffers of a batch of `rows` poses of an `n`-link arm, lent to the
/// solver by [`BatchBuffers::out`]; the fields are the [`BatchOutput`] slices' owners. Two
/// are equal when every value is, NaN where both are NaN (a force at a rotary drive, a torque
/// at a linear actuator).
#[derive(Debug, Clone, Default)]
pub struct BatchBuffers {
    /// See [`BatchOutput::force_n`].
    pub force_n: Vec<f64>,
    /// See [`BatchOutput::reaction_n`].
    pub reaction_n: Vec<f64>,
    /// See [`BatchOutput::dforce_n`].
    pub dforce_n: Vec<f64>,
    /// See [`BatchOutput::torque_nmm`].
    pub torque_nmm: Vec<f64>,
    /// See [`BatchOutput::dtorque_nmm`].
    pub dtorque_nmm: Vec<f64>,
    /// See [`BatchOutput::dx_mm`].
    pub dx_mm: Vec<f64>,
    /// See [`BatchOutput::dy_mm`].
    pub dy_mm: Vec<f64>,
    /// See [`BatchOutput::dalpha_deg`].
    pub dalpha_deg: Vec<f64>,
    /// See [`BatchOutput::dl_mm`].
    pub dl_mm: Vec<f64>,
    /// See [`BatchOutput::dlength_mm`].
    pub dlength_mm: Vec<f64>,
    /// See [`BatchOutput::length_mm`].
    pub length_mm: Vec<f64>,
}

impl PartialEq for BatchBuffers {
    fn eq(&self, other: &Self) -> bool {
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
        };
        same(&self.force_n, &other.force_n)
            && same(&self.reaction_n, &other.reaction_n)
            && same(&self.dforce_n, &other.dforce_n)
            && same(&self.torque_nmm, &other.torque_nmm)
            && same(&self.dtorque_nmm, &other.dtorque_nmm)
            && same(&self.dx_mm, &other.dx_mm)
            && same(&self.dy_mm, &other.dy_mm)
            && same(&self.dalpha_deg, &other.dalpha_deg)
            && same(&self.dl_mm, &other.dl_mm)
            && same(&self.dlength_mm, &other.dlength_mm)
            && same(&self.length_mm, &other.length_mm)
    }
}

impl BatchBuffers {
    /// Zeroed buffers for `rows` poses of an `n`-link arm.
    pub fn new(rows: usize, n: usize) -> Self {
        let per_link = || vec![0.0; rows * n];
        Self {
            force_n: per_link(),
            reaction_n: vec![0.0; rows * n * 2],
            dforce_n: per_link(),
            torque_nmm: per_link(),
            dtorque_nmm: per_link(),
            dx_mm: vec![0.0; rows],
            dy_mm: vec![0.0; rows],
            dalpha_deg: per_link(),
            dl_mm: per_link(),
            dlength_mm: per_link(),
            length_mm: per_link(),
        }
    }

    /// The buffers as the solver's output slices.
    pub fn out(&mut self) -> BatchOutput<'_> {
        BatchOutput {
            force_n: &mut self.force_n,
            reaction_n: &mut self.reaction_n,
            dforce_n: &mut self.dforce_n,
            torque_nmm: &mut self.torque_nmm,
            dtorque_nmm: &mut self.dtorque_nmm,
            dx_mm: &mut self.dx_mm,
            dy_mm: &mut self.dy_mm,
            dalpha_deg: &mut self.dalpha_deg,
            dl_mm: &mut self.dl_mm,
            dlength_mm: &mut self.dlength_mm,
            length_mm: &mut self.length_mm,
        }
    }

    /// The first `rows` rows (`n` links) as the solver's output slices: buffers sized once
    /// for the largest of several batches.
    pub(crate) fn first_rows(&mut self, rows: usize, n: usize) -> BatchOutput<'_> {
        BatchOutput {
            force_n: &mut self.force_n[..rows * n],
            reaction_n: &mut self.reaction_n[..2 * rows * n],
            dforce_n: &mut self.dforce_n[..rows * n],
            torque_nmm: &mut self.torque_nmm[..rows * n],
            dtorque_nmm: &mut self.dtorque_nmm[..rows * n],
            dx_mm: &mut self.dx_mm[..rows],
            dy_mm: &mut self.dy_mm[..rows],
            dalpha_deg: &mut self.dalpha_deg[..rows * n],
            dl_mm: &mut self.dl_mm[..rows * n],
            dlength_mm: &mut self.dlength_mm[..rows * n],
            length_mm: &mut self.length_mm[..rows * n],
        }
    }
}

impl BatchOutput<'_> {
    pub(crate) fn check(&self, rows: usize, n: usize) -> Result<()> {
        let want = [
            ("force_n", self.force_n.len(), rows * n),
            ("reaction_n", self.reaction_n.len(), rows * n * 2),
            ("dforce_n", self.dforce_n.len(), rows * n),
            ("torque_nmm", self.torque_nmm.len(), rows * n),
            ("dtorque_nmm", self.dtorque_nmm.len(), rows * n),
            ("dx_mm", self.dx_mm.len(), rows),
            ("dy_mm", self.dy_mm.len(), rows),
            ("dalpha_deg", self.dalpha_deg.len(), rows * n),
            ("dl_mm", self.dl_mm.len(), rows * n),
            ("dlength_mm", self.dlength_mm.len(), rows * n),
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
}

/// Writes the solved pose in `ws` (unloaded angles `alpha`, rad) into output row `p`.
#[allow(clippy::needless_range_loop)] // i indexes six parallel arrays
pub(crate) fn write_row(
    arm: &Arm,
    ws: &Workspace,
    alpha: &[f64],
    out: &mut BatchOutput<'_>,
    p: usize,
    n: usize,
) {
    for i in 0..n {
        let j = p * n + i;
        // Each drive's load in its own arrays (N or N·mm), NaN in the other.
        let nan = f64::NAN;
        let (load, dload) = (ws.loaded.f[i], ws.delta.f[i]);
        let (f, df, t, dt) = if arm.is_rotary(i) {
            (nan, nan, load, dload)
        } else {
            (load, dload, nan, nan)
        };
        out.force_n[j] = f;
        out.dforce_n[j] = df;
        out.torque_nmm[j] = t;
        out.dtorque_nmm[j] = dt;
        out.reaction_n[2 * j] = ws.loaded.r[i].x;
        out.reaction_n[2 * j + 1] = ws.loaded.r[i].y;
        out.dalpha_deg[j] = (ws.new_alpha[i] - alpha[i]).to_degrees();
        out.dl_mm[j] = ws.body_dl[i];
        out.dlength_mm[j] = ws.new_length[i] - ws.lines.length[i];
        out.length_mm[j] = ws.lines.length[i];
    }
    out.dx_mm[p] = ws.dmeasure.x;
    out.dy_mm[p] = ws.dmeasure.y;
}

pub(crate) fn fill_nan(out: &mut BatchOutput<'_>, p: usize, n: usize) {
    for s in [
        &mut *out.force_n,
        &mut *out.dforce_n,
        &mut *out.torque_nmm,
        &mut *out.dtorque_nmm,
        &mut *out.dalpha_deg,
        &mut *out.dl_mm,
        &mut *out.dlength_mm,
        &mut *out.length_mm,
    ] {
        s[p * n..(p + 1) * n].fill(f64::NAN);
    }
    out.reaction_n[2 * p * n..2 * (p + 1) * n].fill(f64::NAN);
    out.dx_mm[p] = f64::NAN;
    out.dy_mm[p] = f64::NAN;
}

/// Inputs of a batch of load sequences, row-major.
#[derive(Debug, Clone, Copy)]
pub struct SequenceInput<'a> {
    /// Unloaded absolute angles (deg) of each sequence, `N × n`.
    pub alpha_deg: &'a [f64],
    /// Payload force at the load point (N, global) of each state after the reference,
    /// `N × S × 2`.
    pub payload_n: &'a [f64],
    /// States per sequence, S ≥ 1.
    pub states: usize,
}
