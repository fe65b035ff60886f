//! What a sweep writes: the cell fields (values or indices), the reduction that fills them,
//! and a chunk's per-pose slices. Shared by the sweep (`sweep.rs`), its reductions
//! (`sweep/reduce.rs`) and its per-cell path (`sweep/fallback.rs`), below all of them
//! (docs/architecture.md).

/// A reduction over groups of consecutive rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReduceOp {
    /// Largest value (NaN ignored).
    Max,
    /// Smallest value (NaN ignored).
    Min,
    /// Offset within the group of the first largest value; −1 when the group has none.
    ArgMax,
    /// Offset within the group of the first smallest value; −1 when the group has none.
    ArgMin,
}

impl ReduceOp {
    /// Whether the reduction yields indices (written to [`Cells::Indices`]).
    pub fn is_arg(self) -> bool {
        matches!(self, Self::ArgMax | Self::ArgMin)
    }
}

/// The cell fields, row-major, for `R` output rows (cells, or groups when reduced).
#[derive(Debug)]
pub struct CellFields<'a, T> {
    /// Loaded actuator forces (N, compression +), `R × n`.
    pub force_n: &'a mut [T],
    /// Displacement of the measure point, x (mm), `R`.
    pub dx_mm: &'a mut [T],
    /// Displacement of the measure point, y (mm), `R`.
    pub dy_mm: &'a mut [T],
    /// Change of absolute link angles (deg), `R × n`.
    pub dalpha_deg: &'a mut [T],
    /// Actuator body length change as its sensor sees it (mm), `R × n`.
    pub dl_mm: &'a mut [T],
}

impl<'a, T> CellFields<'a, T> {
    pub(super) fn lens(&self, n: usize) -> [(&'static str, usize, usize); 5] {
        [
            ("force_n", self.force_n.len(), n),
            ("dx_mm", self.dx_mm.len(), 1),
            ("dy_mm", self.dy_mm.len(), 1),
            ("dalpha_deg", self.dalpha_deg.len(), n),
            ("dl_mm", self.dl_mm.len(), n),
        ]
    }

    /// Splits off output rows `[skip, skip + take)` of what is left, dropping the first `skip`.
    pub(super) fn split(&mut self, skip: usize, take: usize, n: usize) -> CellFields<'a, T> {
        CellFields {
            force_n: cut(&mut self.force_n, skip * n, take * n),
            dx_mm: cut(&mut self.dx_mm, skip, take),
            dy_mm: cut(&mut self.dy_mm, skip, take),
            dalpha_deg: cut(&mut self.dalpha_deg, skip * n, take * n),
            dl_mm: cut(&mut self.dl_mm, skip * n, take * n),
        }
    }
}

/// Cell outputs: values (per cell, or `Max`/`Min` per group) or indices (`ArgMax`/`ArgMin`).
#[derive(Debug)]
pub enum Cells<'a> {
    /// Values (N, mm, deg).
    Values(CellFields<'a, f64>),
    /// Offsets within each group of the selected cell, −1 where the group has no value.
    Indices(CellFields<'a, i64>),
}

impl<'a> Cells<'a> {
    pub(super) fn split(&mut self, skip: usize, take: usize, n: usize) -> Cells<'a> {
        match self {
            Cells::Values(c) => Cells::Values(c.split(skip, take, n)),
            Cells::Indices(c) => Cells::Indices(c.split(skip, take, n)),
        }
    }
}

pub(super) fn cut<'a, T>(s: &mut &'a mut [T], skip: usize, take: usize) -> &'a mut [T] {
    let rest = std::mem::take(s);
    let (_, rest) = rest.split_at_mut(skip.min(rest.len()));
    let (head, tail) = rest.split_at_mut(take.min(rest.len()));
    *s = tail;
    head
}

/// A chunk's per-pose output slices (each may be empty: not wanted).
pub(super) struct PoseOut<'s> {
    pub(super) length: &'s mut [f64],
    pub(super) reachable: &'s mut [bool],
    pub(super) ex: &'s mut [f64],
    pub(super) ey: &'s mut [f64],
}
