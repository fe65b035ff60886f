//! The batch's inputs and outputs, and the writing of one solved (or failed) row: shared by
//! the batch drivers (`solve.rs`), the block kernel (`solve/fast.rs`) and the status
//! (`solve/status.rs`), below all of them.

use super::general::{SolveOptions, Workspace};
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
/// lengths and `dl_mm` are NaN at rotary drives. An empty slice is an output not asked for
/// (`outputs=` of `eodarm.solve`): nothing is written there, and the others get the values
/// they get in a batch with every output.
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

    /// Buffers for `rows` poses of an `n`-link arm holding only the outputs `asked` says yes
    /// to (by their field names, `"dx_mm"`, ...); the others are empty: not asked for.
    pub fn with_outputs(rows: usize, n: usize, asked: impl Fn(&str) -> bool) -> Self {
        let size = |key: &str, len: usize| {
            if asked(key) {
                vec![0.0; len]
            } else {
                Vec::new()
            }
        };
        Self {
            force_n: size("force_n", rows * n),
            reaction_n: size("reaction_n", rows * n * 2),
            dforce_n: size("dforce_n", rows * n),
            torque_nmm: size("torque_nmm", rows * n),
            dtorque_nmm: size("dtorque_nmm", rows * n),
            dx_mm: size("dx_mm", rows),
            dy_mm: size("dy_mm", rows),
            dalpha_deg: size("dalpha_deg", rows * n),
            dl_mm: size("dl_mm", rows * n),
            dlength_mm: size("dlength_mm", rows * n),
            length_mm: size("length_mm", rows * n),
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
    /// for the largest of several batches (an empty buffer stays empty: not asked for).
    pub(crate) fn first_rows(&mut self, rows: usize, n: usize) -> BatchOutput<'_> {
        fn first(v: &mut [f64], len: usize) -> &mut [f64] {
            if v.is_empty() {
                v
            } else {
                &mut v[..len]
            }
        }
        BatchOutput {
            force_n: first(&mut self.force_n, rows * n),
            reaction_n: first(&mut self.reaction_n, 2 * rows * n),
            dforce_n: first(&mut self.dforce_n, rows * n),
            torque_nmm: first(&mut self.torque_nmm, rows * n),
            dtorque_nmm: first(&mut self.dtorque_nmm, rows * n),
            dx_mm: first(&mut self.dx_mm, rows),
            dy_mm: first(&mut self.dy_mm, rows),
            dalpha_deg: first(&mut self.dalpha_deg, rows * n),
            dl_mm: first(&mut self.dl_mm, rows * n),
            dlength_mm: first(&mut self.dlength_mm, rows * n),
            length_mm: first(&mut self.length_mm, rows * n),
        }
    }
}

impl BatchOutput<'_> {
    /// Checks that every output asked for (a non-empty slice) holds `rows` rows.
    pub(crate) fn check(&self, rows: usize, n: usize) -> Result<()> {
        self.check_sizes(rows, n, true)
    }

    /// Checks that every output holds `rows` rows (a solver that writes them all).
    pub(crate) fn check_all(&self, rows: usize, n: usize) -> Result<()> {
        self.check_sizes(rows, n, false)
    }

    fn check_sizes(&self, rows: usize, n: usize, absent_ok: bool) -> Result<()> {
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
            if got != expected && !(absent_ok && got == 0) {
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
fn write_row(
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
        // An output not asked for is an empty slice: `set` writes nothing there.
        set(out.force_n, j, f);
        set(out.dforce_n, j, df);
        set(out.torque_nmm, j, t);
        set(out.dtorque_nmm, j, dt);
        set(out.reaction_n, 2 * j, ws.loaded.r[i].x);
        set(out.reaction_n, 2 * j + 1, ws.loaded.r[i].y);
        set(out.dalpha_deg, j, (ws.new_alpha[i] - alpha[i]).to_degrees());
        set(out.dl_mm, j, ws.body_dl[i]);
        set(out.dlength_mm, j, ws.new_length[i] - ws.lines.length[i]);
        set(out.length_mm, j, ws.lines.length[i]);
    }
    set(out.dx_mm, p, ws.dmeasure.x);
    set(out.dy_mm, p, ws.dmeasure.y);
}

/// Writes `v` at `j` of an output asked for; nothing into one that is not (empty).
#[inline(always)]
fn set(out: &mut [f64], j: usize, v: f64) {
    if !out.is_empty() {
        out[j] = v;
    }
}

/// Writes the outcome `solved` of pose `p` into `out`: the pose solved in `ws` from the
/// unloaded angles `alpha` (rad), or NaN for a pose failure when `opts.nan_on_failure`;
/// whether it was solved (its status reads the pose, [`super::status::pose_status`]).
///
/// # Errors
/// Any other error of the pose, as it came.
pub(crate) fn write_outcome(
    arm: &Arm,
    ws: &Workspace,
    alpha: &[f64],
    solved: Result<()>,
    opts: SolveOptions,
    out: &mut BatchOutput<'_>,
    p: usize,
) -> Result<bool> {
    match solved {
        Ok(()) => {
            write_row(arm, ws, alpha, out, p, arm.n());
            Ok(true)
        }
        Err(e) if opts.nan_on_failure && e.is_pose_failure() => {
            fill_nan(out, p, arm.n());
            Ok(false)
        }
        Err(e) => Err(e),
    }
}

/// Fills row `p` of every output asked for with NaN (a pose that cannot be solved).
pub(crate) fn fill_nan(out: &mut BatchOutput<'_>, p: usize, n: usize) {
    for (s, width) in [
        (&mut *out.force_n, n),
        (&mut *out.dforce_n, n),
        (&mut *out.torque_nmm, n),
        (&mut *out.dtorque_nmm, n),
        (&mut *out.dalpha_deg, n),
        (&mut *out.dl_mm, n),
        (&mut *out.dlength_mm, n),
        (&mut *out.length_mm, n),
        (&mut *out.reaction_n, 2 * n),
        (&mut *out.dx_mm, 1),
        (&mut *out.dy_mm, 1),
    ] {
        if !s.is_empty() {
            s[p * width..(p + 1) * width].fill(f64::NAN);
        }
    }
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
