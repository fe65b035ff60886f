//! The Jacobian through the general path: [`Workspace::solve`] pose by pose, every effect set
//! in turn. Arms beyond 6 links take it, the block path hands it the rows its kernel could not
//! solve, and [`super::jacobian_batch_general`] is it alone (the reference of the tests).

use rayon::prelude::*;

use super::{first_error, row_chunks, Sets};
use crate::arm::Arm;
use crate::error::{ArmError, Result};
use crate::geometry::V2;
use crate::solve::{BatchInput, SolveOptions, Workspace, CHUNK, PARALLEL_THRESHOLD};

/// Solves every row of the batch through [`Rows::row`], in parallel over blocks of rows.
pub(super) fn run(
    arm: &Arm,
    sets: &Sets,
    input: BatchInput<'_>,
    opts: SolveOptions,
    y: &mut [f64],
    jac: &mut [f64],
) -> Result<()> {
    let (c, p) = (sets.channels, sets.probes());
    let work = |first: usize, y: &mut [f64], jac: &mut [f64]| -> Result<()> {
        let mut rows = Rows::new(arm, sets, opts);
        for r in 0..y.len() / c {
            let (yr, jr) = (
                &mut y[r * c..(r + 1) * c],
                &mut jac[r * c * p..(r + 1) * c * p],
            );
            rows.row(&input, first + r, yr, jr)?;
        }
        Ok(())
    };
    let n_sets = sets.sets.len();
    if sets.rows < PARALLEL_THRESHOLD / n_sets {
        return work(0, y, jac);
    }
    let rows_per = (CHUNK / n_sets).max(16);
    let errors: Vec<ArmError> = row_chunks(y, jac, rows_per, c, p)
        .into_par_iter()
        .filter_map(|(first, yc, jc)| work(first, yc, jc).err())
        .collect();
    first_error(errors)
}

/// Scratch space to solve one row for every effect set.
pub(super) struct Rows<'a> {
    arm: &'a Arm,
    sets: &'a Sets,
    opts: SolveOptions,
    ws: Workspace,
    alpha: Vec<f64>,
    plus: Vec<f64>,
    minus: Vec<f64>,
}

impl<'a> Rows<'a> {
    pub(super) fn new(arm: &'a Arm, sets: &'a Sets, opts: SolveOptions) -> Self {
        let c = sets.channels;
        Self {
            arm,
            sets,
            opts,
            ws: Workspace::new(arm),
            alpha: vec![0.0; arm.n()],
            plus: vec![0.0; c],
            minus: vec![0.0; c],
        }
    }

    /// Solves batch row `row` of `input` into its channels `y` (C) and Jacobian `jac` (C × P):
    /// the model, then every probe's θ + h and θ − h. The first set that fails gives the error
    /// naming `row`, or, a pose failure with `nan_on_failure`, NaN in all of `y` and `jac`.
    pub(super) fn row(
        &mut self,
        input: &BatchInput<'_>,
        row: usize,
        y: &mut [f64],
        jac: &mut [f64],
    ) -> Result<()> {
        let (arm, opts) = (self.arm, self.opts);
        let n = arm.n();
        let (c, p) = (self.sets.channels, self.sets.probes());
        for (a, d) in self
            .alpha
            .iter_mut()
            .zip(&input.alpha_deg[row * n..(row + 1) * n])
        {
            *a = d.to_radians();
        }
        let load = V2::new(input.payload_n[2 * row], input.payload_n[2 * row + 1]);
        let (ws, alpha, sets) = (&mut self.ws, &self.alpha, &self.sets.sets);
        let (plus, minus) = (&mut self.plus, &mut self.minus);
        let solved = (|| -> Result<()> {
            ws.solve(arm, &sets[0], alpha, load, opts, row)?;
            channels(ws, alpha, y);
            for (j, h) in self.sets.steps.iter().enumerate() {
                ws.solve(arm, &sets[1 + 2 * j], alpha, load, opts, row)?;
                channels(ws, alpha, plus);
                ws.solve(arm, &sets[2 + 2 * j], alpha, load, opts, row)?;
                channels(ws, alpha, minus);
                for k in 0..c {
                    jac[k * p + j] = (plus[k] - minus[k]) / (2.0 * h);
                }
            }
            Ok(())
        })();
        match solved {
            Err(e) if opts.nan_on_failure && e.is_pose_failure() => {
                y.fill(f64::NAN);
                jac.fill(f64::NAN);
                Ok(())
            }
            other => other,
        }
    }
}

/// Writes the channels of a solved workspace: dx, dy, dα (deg), dl (mm).
fn channels(ws: &Workspace, alpha: &[f64], out: &mut [f64]) {
    let n = alpha.len();
    out[0] = ws.dmeasure.x;
    out[1] = ws.dmeasure.y;
    for i in 0..n {
        out[2 + i] = (ws.new_alpha[i] - alpha[i]).to_degrees();
        out[2 + n + i] = ws.body_dl[i];
    }
}
