//! A block's lanes back into the caller's row-major arrays: shared by the sweep and the
//! solve kernel (`solve/fast.rs`), below both (docs/architecture.md).

use super::L;

/// Writes the first `out.len() / N` lanes of a `[link][lane]` block as rows of `N`.
#[inline(always)]
pub(crate) fn transpose_into<const N: usize>(block: &[[f64; L]; N], out: &mut [f64]) {
    if out.len() == L * N {
        for (g, rows) in out.chunks_exact_mut(4 * N).enumerate() {
            let cols: [[f64; 4]; N] =
                std::array::from_fn(|i| std::array::from_fn(|q| block[i][4 * g + q]));
            let t: [[f64; N]; 4] = std::array::from_fn(|q| std::array::from_fn(|i| cols[i][q]));
            rows.copy_from_slice(t.as_flattened());
        }
        return;
    }
    for (q, row) in out.chunks_exact_mut(N).enumerate() {
        for i in 0..N {
            row[i] = block[i][q];
        }
    }
}

/// [`transpose_into`] for the x and y parts of a vector per link: the first
/// `out.len() / (2N)` lanes as rows of `N` (x, y) pairs.
#[inline(always)]
pub(crate) fn transpose_xy_into<const N: usize>(xy: &[[[f64; L]; N]; 2], out: &mut [f64]) {
    if out.len() == 2 * L * N {
        for (g, rows) in out.chunks_exact_mut(8 * N).enumerate() {
            let cols: [[[f64; 4]; N]; 2] = std::array::from_fn(|c| {
                std::array::from_fn(|i| std::array::from_fn(|q| xy[c][i][4 * g + q]))
            });
            let t: [[[f64; 2]; N]; 4] = std::array::from_fn(|q| {
                std::array::from_fn(|i| std::array::from_fn(|c| cols[c][i][q]))
            });
            rows.copy_from_slice(t.as_flattened().as_flattened());
        }
        return;
    }
    for (q, row) in out.chunks_exact_mut(2 * N).enumerate() {
        for i in 0..N {
            row[2 * i] = xy[0][i][q];
            row[2 * i + 1] = xy[1][i][q];
        }
    }
}
