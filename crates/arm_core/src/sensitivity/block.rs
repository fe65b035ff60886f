//! The Jacobian on the block kernel of `solve` (arms of 1–6 links).
//!
//! The batch is cut into chunks of rows; each chunk is solved by the kernel of every one of the
//! 2P + 1 effect sets in turn, into scratch outputs allocated once per rayon work split (a few
//! per thread, reused by every set and chunk the split solves), and its channels
//! and central differences are written from them. The kernel runs with `nan_on_failure`, so a
//! row that fails for some set comes back as NaN; such rows (and every row of a chunk whose
//! kernel returned an error) are solved again by the general path ([`general::Rows`]), which
//! gives them exactly its answer: the error of the first failing set naming the row, or the NaN
//! row with `nan_on_failure`. Rows are redone in increasing order and chunks are reported in
//! order, so the error is the lowest failing row's, as in the general path.

use rayon::prelude::*;

use super::general::Rows;
use super::{first_error, row_chunks, Sets};
use crate::arm::Arm;
use crate::error::{ArmError, Result};
use crate::lanes::L;
use crate::solve::fast::{Ctx, Kernel};
use crate::solve::{
    BatchBuffers, BatchInput, BatchOutput, SolveOptions, KERNEL_CHUNK, KERNEL_PARALLEL_THRESHOLD,
};

/// Solves the batch with `kernels[s]` the kernel of `sets.sets[s]`.
pub(super) fn run(
    arm: &Arm,
    sets: &Sets,
    kernels: &[Kernel],
    input: BatchInput<'_>,
    opts: SolveOptions,
    y: &mut [f64],
    jac: &mut [f64],
) -> Result<()> {
    let (c, p) = (sets.channels, sets.probes());
    let n_sets = sets.sets.len();
    // About KERNEL_CHUNK solves per work item, in whole blocks of L lanes.
    let rows_per = (KERNEL_CHUNK / n_sets / L * L).max(L);
    let simd = pulp::Arch::new();
    let job = Job {
        arm,
        sets,
        kernels,
        input,
        opts,
        simd,
    };
    let chunks = row_chunks(y, jac, rows_per, c, p);
    if chunks.len() == 1 || sets.rows * n_sets < KERNEL_PARALLEL_THRESHOLD {
        let mut scratch = Scratch::new(rows_per, arm.n());
        for (first, yc, jc) in chunks {
            job.chunk(&mut scratch, first, yc, jc)?;
        }
        return Ok(());
    }
    let errors: Vec<ArmError> = chunks
        .into_par_iter()
        .map_init(
            || Scratch::new(rows_per, arm.n()),
            |scratch, (first, yc, jc)| job.chunk(scratch, first, yc, jc).err(),
        )
        .flatten()
        .collect();
    first_error(errors)
}

/// What every chunk shares.
struct Job<'a> {
    arm: &'a Arm,
    sets: &'a Sets,
    kernels: &'a [Kernel],
    input: BatchInput<'a>,
    opts: SolveOptions,
    simd: pulp::Arch,
}

/// A thread's outputs of one chunk: the model's, and a probe's plus and minus sets.
struct Scratch {
    base: BatchBuffers,
    plus: BatchBuffers,
    minus: BatchBuffers,
    status: Vec<u8>,
}

impl Scratch {
    fn new(rows: usize, n: usize) -> Self {
        Self {
            base: BatchBuffers::new(rows, n),
            plus: BatchBuffers::new(rows, n),
            minus: BatchBuffers::new(rows, n),
            status: vec![0; rows],
        }
    }
}

impl Job<'_> {
    /// Solves the chunk of rows from batch row `first` into its rows `y` (m × C) and `jac`
    /// (m × C × P).
    fn chunk(&self, s: &mut Scratch, first: usize, y: &mut [f64], jac: &mut [f64]) -> Result<()> {
        let (c, p) = (self.sets.channels, self.sets.probes());
        let m = y.len() / c;
        if self.kernel_chunk(s, first, m, y, jac).is_err() {
            // An error the kernel cannot turn into NaN: let the general path find which row
            // fails first and how.
            return self.redo(first, m, y, jac, |_| true);
        }
        let bad = |r: usize| {
            y[r * c..(r + 1) * c].iter().any(|v| v.is_nan())
                || jac[r * c * p..(r + 1) * c * p].iter().any(|v| v.is_nan())
        };
        let failed: Vec<bool> = (0..m).map(bad).collect();
        self.redo(first, m, y, jac, |r| failed[r])
    }

    /// Every set's kernel over the chunk's `m` rows, NaN for the rows a set cannot solve.
    fn kernel_chunk(
        &self,
        s: &mut Scratch,
        first: usize,
        m: usize,
        y: &mut [f64],
        jac: &mut [f64],
    ) -> Result<()> {
        let n = self.arm.n();
        let (c, p) = (self.sets.channels, self.sets.probes());
        let sub = BatchInput {
            alpha_deg: &self.input.alpha_deg[first * n..(first + m) * n],
            payload_n: &self.input.payload_n[2 * first..2 * (first + m)],
        };
        let status = &mut s.status[..m];
        let solve = |set: usize, out: &mut BatchBuffers, status: &mut [u8]| {
            let ctx = Ctx {
                arm: self.arm,
                effects: &self.sets.sets[set],
                opts: SolveOptions {
                    nan_on_failure: true,
                    ..self.opts
                },
            };
            let out = head(out, m, n);
            self.kernels[set].chunk(self.simd, &ctx, sub, out, status, first)
        };
        solve(0, &mut s.base, status)?;
        for r in 0..m {
            for (k, v) in y[r * c..(r + 1) * c].iter_mut().enumerate() {
                *v = channel(&s.base, r, k, n);
            }
        }
        for (j, h) in self.sets.steps.iter().enumerate() {
            solve(1 + 2 * j, &mut s.plus, status)?;
            solve(2 + 2 * j, &mut s.minus, status)?;
            for r in 0..m {
                for k in 0..c {
                    let d = channel(&s.plus, r, k, n) - channel(&s.minus, r, k, n);
                    jac[(r * c + k) * p + j] = d / (2.0 * h);
                }
            }
        }
        Ok(())
    }

    /// Solves again, through the general path, the chunk's rows `r` (in increasing order) for
    /// which `again(r)`.
    fn redo(
        &self,
        first: usize,
        m: usize,
        y: &mut [f64],
        jac: &mut [f64],
        again: impl Fn(usize) -> bool,
    ) -> Result<()> {
        let (c, p) = (self.sets.channels, self.sets.probes());
        let mut rows: Option<Rows<'_>> = None;
        for r in (0..m).filter(|&r| again(r)) {
            let g = rows.get_or_insert_with(|| Rows::new(self.arm, self.sets, self.opts));
            let (yr, jr) = (
                &mut y[r * c..(r + 1) * c],
                &mut jac[r * c * p..(r + 1) * c * p],
            );
            g.row(&self.input, first + r, yr, jr)?;
        }
        Ok(())
    }
}

/// Channel `k` of row `r` of a solved chunk: dx, dy, dα (deg), dl (mm), as
/// [`general`](super::general) writes them from a workspace.
fn channel(b: &BatchBuffers, r: usize, k: usize, n: usize) -> f64 {
    match k {
        0 => b.dx_mm[r],
        1 => b.dy_mm[r],
        k if k < 2 + n => b.dalpha_deg[r * n + k - 2],
        k => b.dl_mm[r * n + k - 2 - n],
    }
}

/// The first `m` rows of buffers of an `n`-link arm as solver outputs.
fn head(b: &mut BatchBuffers, m: usize, n: usize) -> BatchOutput<'_> {
    b.first_rows(m, n)
}
