//! Where the cells of a chunk go: stored row by row, or reduced over groups of consecutive
//! rows as they come (nothing per cell is kept).
//!
//! The reductions ignore NaN and do not depend on the order in which the cells arrive (so
//! neither on the chunk size nor on the thread count): `Max`/`Min` prefer +0 over −0 (resp.
//! −0 over +0) on a tie, `ArgMax`/`ArgMin` the lowest offset within the group.
//!
//! A cell takes part only when its status (docs/model.md §7) is ok; the others are NaN. A
//! group's status is 0 when every cell of it is ok, else the lowest code among its cells
//! that are not ([`fold_status`]): like the reductions, independent of the order.

use super::cells::{CellFields, Cells, ReduceOp};

/// The cell fields in the order the sinks use: force (n), dx, dy, dalpha (n), dl (n).
#[inline]
pub(crate) fn n_fields(n: usize) -> usize {
    3 * n + 2
}

/// Folds value `v` at offset `off` into the accumulator `(acc, at)`.
#[inline(always)]
pub(crate) fn fold(op: ReduceOp, acc: &mut f64, at: &mut i64, v: f64, off: i64) {
    match op {
        ReduceOp::Max => fold_op::<MAX>(acc, at, v, off),
        ReduceOp::Min => fold_op::<MIN>(acc, at, v, off),
        ReduceOp::ArgMax => fold_op::<ARGMAX>(acc, at, v, off),
        ReduceOp::ArgMin => fold_op::<ARGMIN>(acc, at, v, off),
    }
}

/// [`ReduceOp`] as a const parameter of [`fold_op`].
pub(crate) const MAX: u8 = 0;
/// See [`MAX`].
pub(crate) const MIN: u8 = 1;
/// See [`MAX`].
pub(crate) const ARGMAX: u8 = 2;
/// See [`MAX`].
pub(crate) const ARGMIN: u8 = 3;

/// [`fold`] for one reduction known at compile time. Branch-free (`&`, `|` and selects):
/// the comparisons of random values would be mispredicted.
#[inline(always)]
pub(crate) fn fold_op<const OP: u8>(acc: &mut f64, at: &mut i64, v: f64, off: i64) {
    let (a, t) = (*acc, *at);
    let empty = a.is_nan() & !v.is_nan();
    let zeros = (v == 0.0) & (a == 0.0);
    let take = match OP {
        MAX => (v > a) | empty | (zeros & v.is_sign_positive()),
        MIN => (v < a) | empty | (zeros & v.is_sign_negative()),
        ARGMAX => (v > a) | empty | ((v == a) & (off < t)),
        _ => (v < a) | empty | ((v == a) & (off < t)),
    };
    *acc = if take { v } else { a };
    if OP >= ARGMAX {
        *at = if take { off } else { t };
    }
}

/// Folds a cell's status code into a group's: 0 while every cell is ok, else the lowest
/// code of a cell that is not.
#[inline(always)]
pub(crate) fn fold_status(acc: &mut u8, code: u8) {
    let a = *acc;
    *acc = if code != 0 && (a == 0 || code < a) {
        code
    } else {
        a
    };
}

/// Accumulators of the groups one chunk touches (per-thread scratch, reused across chunks).
#[derive(Debug, Default)]
pub(crate) struct Acc {
    /// First group touched.
    pub g0: usize,
    /// Fields per cell.
    pub nf: usize,
    /// `groups × nf` reduced values (NaN while no value).
    pub vals: Vec<f64>,
    /// `groups × nf` offsets of the reduced values within their group (−1 while none).
    pub at: Vec<i64>,
    /// Any cell of the group ok.
    pub ok: Vec<bool>,
    /// The group's status so far ([`fold_status`]).
    pub status: Vec<u8>,
    /// Any pose of the group reachable (when reachability is reduced per group).
    pub reach: Vec<bool>,
}

impl Acc {
    /// Empties the accumulators for groups `g0 .. g0 + groups`.
    pub fn reset(&mut self, g0: usize, groups: usize, nf: usize) {
        self.g0 = g0;
        self.nf = nf;
        self.vals.clear();
        self.vals.resize(groups * nf, f64::NAN);
        self.at.clear();
        self.at.resize(groups * nf, -1);
        self.ok.clear();
        self.ok.resize(groups, false);
        self.status.clear();
        self.status.resize(groups, 0);
        self.reach.clear();
        self.reach.resize(groups, false);
    }
}

/// Where a chunk's cells go.
pub(crate) enum Sink<'s, 'a> {
    /// Row by row, rows `row0 ..` of the chunk's slices.
    Store {
        /// Global row of the first row of the slices.
        row0: usize,
        /// Links.
        n: usize,
        /// The chunk's cell slices.
        cells: &'s mut CellFields<'a, f64>,
        /// The chunk's ok slice.
        ok: &'s mut [bool],
        /// The chunk's status slice (empty: not wanted).
        status: &'s mut [u8],
    },
    /// Folded into groups of `group` consecutive rows.
    Reduce {
        /// Rows per group.
        group: usize,
        /// The reduction.
        op: ReduceOp,
        /// Accumulators.
        acc: &'s mut Acc,
    },
}

impl Sink<'_, '_> {
    /// One cell at global row `row` of status `code` (ok when 0); `v` holds the fields in
    /// [`n_fields`] order (used only when ok).
    #[inline]
    pub fn cell(&mut self, row: usize, code: u8, v: &[f64]) {
        let ok = code == 0;
        match self {
            Sink::Store {
                row0,
                n,
                cells,
                ok: oks,
                status,
            } => {
                let n = *n;
                let r = row - *row0;
                oks[r] = ok;
                if let Some(s) = status.get_mut(r) {
                    *s = code;
                }
                let f = &mut cells.force_n[r * n..(r + 1) * n];
                let a = &mut cells.dalpha_deg[r * n..(r + 1) * n];
                let l = &mut cells.dl_mm[r * n..(r + 1) * n];
                if ok {
                    f.copy_from_slice(&v[..n]);
                    cells.dx_mm[r] = v[n];
                    cells.dy_mm[r] = v[n + 1];
                    a.copy_from_slice(&v[n + 2..2 * n + 2]);
                    l.copy_from_slice(&v[2 * n + 2..3 * n + 2]);
                } else {
                    f.fill(f64::NAN);
                    a.fill(f64::NAN);
                    l.fill(f64::NAN);
                    cells.dx_mm[r] = f64::NAN;
                    cells.dy_mm[r] = f64::NAN;
                }
            }
            Sink::Reduce { group, op, acc } => {
                let g = row / *group;
                let gi = g - acc.g0;
                fold_status(&mut acc.status[gi], code);
                if !ok {
                    return; // a cell that is not ok is all NaN: nothing to fold
                }
                let off = (row - g * *group) as i64;
                let nf = acc.nf;
                acc.ok[gi] = true;
                let vals = &mut acc.vals[gi * nf..(gi + 1) * nf];
                let at = &mut acc.at[gi * nf..(gi + 1) * nf];
                for ((a, t), &x) in vals.iter_mut().zip(at.iter_mut()).zip(v) {
                    fold(*op, a, t, x, off);
                }
            }
        }
    }
}

/// Writes one reduced group at output index `o` (`status` may be empty: not wanted).
#[allow(clippy::too_many_arguments)]
pub(crate) fn write_group(
    cells: &mut Cells<'_>,
    oks: &mut [bool],
    status: &mut [u8],
    o: usize,
    n: usize,
    vals: &[f64],
    at: &[i64],
    (ok, code): (bool, u8),
) {
    oks[o] = ok;
    if let Some(s) = status.get_mut(o) {
        *s = code;
    }
    fn put<T: Copy>(c: &mut CellFields<'_, T>, o: usize, n: usize, v: &[T]) {
        c.force_n[o * n..(o + 1) * n].copy_from_slice(&v[..n]);
        c.dx_mm[o] = v[n];
        c.dy_mm[o] = v[n + 1];
        c.dalpha_deg[o * n..(o + 1) * n].copy_from_slice(&v[n + 2..2 * n + 2]);
        c.dl_mm[o * n..(o + 1) * n].copy_from_slice(&v[2 * n + 2..3 * n + 2]);
    }
    match cells {
        Cells::Values(c) => put(c, o, n, vals),
        Cells::Indices(c) => put(c, o, n, at),
    }
}
