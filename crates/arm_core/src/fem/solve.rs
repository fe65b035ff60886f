//! The linear solve `K·u = f` with faer: sparse Cholesky (LLᵀ) with a fill-reducing (AMD)
//! ordering, its symbolic analysis done once per model and shared by every pose and thread;
//! a pose refills the numeric factor in place (no allocation). The model numbers its DOFs in
//! the AMD order, so the factorisation runs in the natural order and K is never permuted. Two alternatives exist for
//! comparison (benchmarks, tests): the sparse factorisation with its symbolic analysis redone
//! every pose, and a dense Cholesky of the same matrix.
//!
//! A matrix that is not positive definite, or whose pivot falls below [`PIVOT_TOL`] of its
//! diagonal entry, is reported with the DOF where it happened; `mechanism` then finds out
//! what is free to move.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::{
    cholesky_in_place, cholesky_in_place_scratch, LltParams, LltRegularization,
};
use faer::linalg::cholesky::llt::solve::solve_in_place_with_conj;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, MatMut, Par, Side, Spec};

use crate::error::{ArmError, Result};

use super::assemble::Assembly;

/// A pivot whose square is below this fraction of its diagonal entry of K marks a singular
/// (mechanism) matrix. Rounding leaves pivots of about 1e-16 of the diagonal in an exactly
/// singular matrix; the seed arm's sound poses stay above 1e-9 even at 300 DOFs (docs/fem.md).
pub const PIVOT_TOL: f64 = 1e-13;

/// How the linear system is solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LinearSolver {
    /// Sparse Cholesky, symbolic analysis once per model, numeric refill per pose.
    #[default]
    Sparse,
    /// Sparse Cholesky with the symbolic analysis redone every pose (for comparison).
    SparseFresh,
    /// Dense Cholesky of the same matrix (for comparison).
    Dense,
}

/// The factorisation failed: K is singular at (or close to) this DOF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SingularAt {
    /// The DOF whose pivot failed (model numbering).
    pub dof: usize,
}

/// The symbolic Cholesky analysis of an assembly's pattern (simplicial), with a fill-reducing
/// AMD ordering when `amd`, else in the DOFs' own order (the model numbers its DOFs in AMD
/// order once, so that no pose pays for permuting K).
///
/// # Errors
/// [`ArmError::Unsupported`] if faer cannot allocate or analyse the pattern.
pub fn analyse(asm: &Assembly, amd: bool) -> Result<SymbolicCholesky<usize>> {
    let n = asm.diag_pos.len();
    let pattern = SymbolicSparseColMatRef::new_checked(n, n, &asm.col_ptr, None, &asm.row_idx);
    factorize_symbolic_cholesky(
        pattern,
        Side::Upper,
        if amd {
            SymmetricOrdering::Amd
        } else {
            SymmetricOrdering::Identity
        },
        CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        },
    )
    .map_err(|e| ArmError::Unsupported(format!("FE symbolic factorisation failed: {e:?}")))
}

/// Per-thread numeric state of the linear solve.
pub struct Numeric {
    solver: LinearSolver,
    n: usize,
    l: Vec<f64>,
    mem: MemBuffer,
    fresh: Option<SymbolicCholesky<usize>>,
    dense: Mat<f64>,
}

impl std::fmt::Debug for Numeric {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Numeric")
            .field("solver", &self.solver)
            .field("n", &self.n)
            .field("l_len", &self.l.len())
            .finish_non_exhaustive()
    }
}

impl Numeric {
    /// Buffers for `asm` solved by `solver`, for up to `max_rhs` right-hand sides at once.
    pub fn new(
        asm: &Assembly,
        shared: &SymbolicCholesky<usize>,
        solver: LinearSolver,
        max_rhs: usize,
    ) -> Self {
        let n = asm.diag_pos.len();
        let params: Spec<LltParams, f64> = Default::default();
        let req = match solver {
            LinearSolver::Dense => StackReq::any_of(&[
                cholesky_in_place_scratch::<f64>(n, Par::Seq, params),
                faer::linalg::cholesky::llt::solve::solve_in_place_scratch::<f64>(
                    n,
                    max_rhs,
                    Par::Seq,
                ),
            ]),
            _ => StackReq::any_of(&[
                shared.factorize_numeric_llt_scratch::<f64>(Par::Seq, params),
                shared.solve_in_place_scratch::<f64>(max_rhs, Par::Seq),
            ]),
        };
        Self {
            solver,
            n,
            l: vec![
                0.0;
                if solver == LinearSolver::Dense {
                    0
                } else {
                    shared.len_val()
                }
            ],
            mem: MemBuffer::new(req),
            fresh: None,
            dense: if solver == LinearSolver::Dense {
                Mat::zeros(n, n)
            } else {
                Mat::zeros(0, 0)
            },
        }
    }

    /// Factorises K (upper triangle `values` in `asm`'s pattern).
    ///
    /// # Errors
    /// [`SingularAt`] when K is not (numerically) positive definite.
    #[allow(clippy::needless_range_loop)] // k indexes the factor, the permutation and K
    pub fn factorize(
        &mut self,
        asm: &Assembly,
        shared: &SymbolicCholesky<usize>,
        values: &[f64],
    ) -> std::result::Result<(), SingularAt> {
        let n = self.n;
        if self.solver == LinearSolver::Dense {
            return self.factorize_dense(asm, values);
        }
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &asm.col_ptr, None, &asm.row_idx);
        if self.solver == LinearSolver::SparseFresh {
            // The whole symbolic analysis, ordering included, as if nothing were reused.
            let sym = analyse(asm, true).map_err(|_| SingularAt { dof: 0 })?;
            self.l.resize(sym.len_val(), 0.0);
            let params: Spec<LltParams, f64> = Default::default();
            self.mem = MemBuffer::new(StackReq::any_of(&[
                sym.factorize_numeric_llt_scratch::<f64>(Par::Seq, params),
                sym.solve_in_place_scratch::<f64>(2, Par::Seq),
            ]));
            self.fresh = Some(sym);
        }
        let sym = match (&self.fresh, self.solver) {
            (Some(s), LinearSolver::SparseFresh) => s,
            _ => shared,
        };
        let a = SparseColMatRef::new(pattern, values);
        let stack = MemStack::new(&mut self.mem);
        let r = sym.factorize_numeric_llt(
            &mut self.l,
            a,
            Side::Upper,
            LltRegularization::default(),
            Par::Seq,
            stack,
            Default::default(),
        );
        let perm_fwd = |k: usize| sym.perm().map_or(k, |p| p.arrays().0[k]);
        if let Err(e) = r {
            let k = match e {
                faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                    index.saturating_sub(1).min(n.saturating_sub(1))
                }
            };
            return Err(SingularAt { dof: perm_fwd(k) });
        }
        if let SymbolicCholeskyRaw::Simplicial(s) = sym.raw() {
            let col_ptr = s.col_ptr();
            for k in 0..n {
                let lkk = self.l[col_ptr[k]];
                let dof = perm_fwd(k);
                if lkk * lkk < PIVOT_TOL * values[asm.diag_pos[dof]] {
                    return Err(SingularAt { dof });
                }
            }
        }
        Ok(())
    }

    #[allow(clippy::needless_range_loop)] // CSC walk: p indexes row_idx and values
    fn factorize_dense(
        &mut self,
        asm: &Assembly,
        values: &[f64],
    ) -> std::result::Result<(), SingularAt> {
        let n = self.n;
        let a = &mut self.dense;
        // The previous factor filled the lower triangle: start from zero.
        a.fill(0.0);
        for j in 0..n {
            for p in asm.col_ptr[j]..asm.col_ptr[j + 1] {
                let i = asm.row_idx[p];
                a[(j, i)] = values[p];
                a[(i, j)] = values[p];
            }
        }
        let stack = MemStack::new(&mut self.mem);
        let r = cholesky_in_place(
            a.as_mut(),
            LltRegularization::default(),
            Par::Seq,
            stack,
            Default::default(),
        );
        if let Err(faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index }) = r {
            return Err(SingularAt {
                dof: index.min(n.saturating_sub(1)),
            });
        }
        for k in 0..n {
            let lkk = a[(k, k)];
            if lkk * lkk < PIVOT_TOL * values[asm.diag_pos[k]] {
                return Err(SingularAt { dof: k });
            }
        }
        Ok(())
    }

    /// Solves `K·X = B` in place for the `ncols` columns of `rhs` (column-major, n rows).
    pub fn solve(&mut self, shared: &SymbolicCholesky<usize>, rhs: &mut [f64], ncols: usize) {
        let n = self.n;
        let x = MatMut::from_column_major_slice_mut(&mut rhs[..n * ncols], n, ncols);
        let stack = MemStack::new(&mut self.mem);
        match self.solver {
            LinearSolver::Dense => {
                solve_in_place_with_conj(self.dense.as_ref(), Conj::No, x, Par::Seq, stack);
            }
            _ => {
                let sym = match &self.fresh {
                    Some(s) if self.solver == LinearSolver::SparseFresh => s,
                    _ => shared,
                };
                LltRef::new(sym, &self.l).solve_in_place_with_conj(Conj::No, x, Par::Seq, stack);
            }
        }
    }
}
