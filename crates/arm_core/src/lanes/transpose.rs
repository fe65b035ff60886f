//! A block's lanes back into the caller's row-major arrays, and rows into lanes: shared by the
//! sweep and the solve kernel (`solve/fast.rs`), below both (docs/architecture.md).
//!
//! Written as element copies, LLVM moves every value on its own (two instructions each: a
//! scalar load and a scalar store). With AVX2 ([`Shuffles`]) four lanes of each column are
//! turned into four rows in registers instead (permutes, blends and unpacks, then whole
//! 32-byte stores): about a third of the instructions for the same bits.

use super::L;

#[cfg(target_arch = "x86_64")]
use pulp::x86::V3;
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::__m256d;

/// The CPU's shuffles for the transposes: AVX2's where the CPU has them (x86-64 v3, which
/// every CPU with AVX-512 has too), else none and the element copies. Detected once per
/// kernel; a transpose with the shuffles gives exactly the values of the copies.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shuffles {
    #[cfg(target_arch = "x86_64")]
    v3: Option<V3>,
}

impl Shuffles {
    /// This CPU's.
    pub(crate) fn detect() -> Self {
        Self {
            #[cfg(target_arch = "x86_64")]
            v3: V3::try_new(),
        }
    }

    /// The element copies only: for code outside the kernels' instruction-set variants,
    /// where the shuffles would not be inlined (and the tests' reference for them).
    pub(crate) fn copies() -> Self {
        Self {
            #[cfg(target_arch = "x86_64")]
            v3: None,
        }
    }

    /// Writes four rows of `M` values (`out`, 4M long) from M columns of four lanes (`col(i)`:
    /// column i, read where it lies, not copied first), with the shuffles where they cover
    /// `M`; false where they do not (nothing written).
    #[inline(always)]
    fn rows_of_cols<const M: usize>(
        self,
        col: impl Fn(usize) -> [f64; 4],
        out: &mut [f64],
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = self.v3 {
            return avx::rows_of_cols::<M>(v3, col, out);
        }
        let _ = (col, out);
        false
    }

    /// M columns of four lanes from four rows of `M` values (`rows`, 4M long), with the
    /// shuffles where they cover `M`.
    #[inline(always)]
    fn cols_of_rows<const M: usize>(self, rows: &[f64]) -> Option<[[f64; 4]; M]> {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = self.v3 {
            return avx::cols_of_rows(v3, rows);
        }
        let _ = rows;
        None
    }
}

/// Writes the first `out.len() / N` lanes of a `[link][lane]` block as rows of `N`.
#[inline(always)]
pub(crate) fn transpose_into<const N: usize>(sh: Shuffles, block: &[[f64; L]; N], out: &mut [f64]) {
    if out.len() == L * N {
        for (g, rows) in out.chunks_exact_mut(4 * N).enumerate() {
            pack_into::<N>(sh, |i| four(&block[i], 4 * g), rows);
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
pub(crate) fn transpose_xy_into<const N: usize>(
    sh: Shuffles,
    xy: &[[[f64; L]; N]; 2],
    out: &mut [f64],
) {
    if out.len() == 2 * L * N {
        for (g, rows) in out.chunks_exact_mut(8 * N).enumerate() {
            // column 2i is link i's x, 2i + 1 its y
            pairs_into::<N>(sh, |j| four(&xy[j % 2][j / 2], 4 * g), rows);
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

impl Shuffles {
    /// [`Self::rows_of_cols`] of `2P` columns taken as P pairs (`col(2k)`, `col(2k + 1)`).
    #[inline(always)]
    fn rows_of_pairs<const P: usize>(
        self,
        col: impl Fn(usize) -> [f64; 4],
        out: &mut [f64],
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = self.v3 {
            avx::rows_of_pairs::<P>(v3, col, out);
            return true;
        }
        let _ = (col, out);
        false
    }
}

/// Four rows of `N` values (`out`, 4N long) from N columns of four lanes (`col(i)`, column
/// i, read where it lies, not copied first): one pack of [`transpose_into`].
#[inline(always)]
fn pack_into<const N: usize>(sh: Shuffles, col: impl Fn(usize) -> [f64; 4], out: &mut [f64]) {
    if !sh.rows_of_cols::<N>(&col, out) {
        let cols: [[f64; 4]; N] = std::array::from_fn(col);
        let t: [[f64; N]; 4] = std::array::from_fn(|q| std::array::from_fn(|i| cols[i][q]));
        out.copy_from_slice(t.as_flattened());
    }
}

/// [`pack_into`] for N (x, y) pairs per row (`col(2i)` link i's x, `col(2i + 1)` its y):
/// one pack of [`transpose_xy_into`].
#[inline(always)]
fn pairs_into<const N: usize>(sh: Shuffles, col: impl Fn(usize) -> [f64; 4], out: &mut [f64]) {
    if !sh.rows_of_pairs::<N>(&col, out) {
        let cols: [[[f64; 4]; 2]; N] =
            std::array::from_fn(|i| std::array::from_fn(|c| col(2 * i + c)));
        let t: [[[f64; 2]; N]; 4] = std::array::from_fn(|q| {
            std::array::from_fn(|i| std::array::from_fn(|c| cols[i][c][q]))
        });
        out.copy_from_slice(t.as_flattened().as_flattened());
    }
}

/// Lanes `at..at + 4` of a lane array.
#[inline(always)]
fn four(a: &[f64; L], at: usize) -> [f64; 4] {
    let mut v = [0.0; 4];
    v.copy_from_slice(&a[at..at + 4]);
    v
}

/// `count` rows of `M` values (row-major) as `[column][lane]`; the lanes beyond `count`
/// repeat the last row.
#[inline(always)]
pub(crate) fn lanes_of_rows<const M: usize>(
    sh: Shuffles,
    rows: &[f64],
    count: usize,
) -> [[f64; L]; M] {
    let mut x = [[0.0; L]; M];
    if count == L {
        for (g, four) in rows[..L * M].chunks_exact(4 * M).enumerate() {
            let cols = match sh.cols_of_rows::<M>(four) {
                Some(cols) => cols,
                None => std::array::from_fn(|i| std::array::from_fn(|q| four[q * M + i])),
            };
            for i in 0..M {
                x[i][4 * g..4 * g + 4].copy_from_slice(&cols[i]);
            }
        }
        return x;
    }
    for k in 0..L {
        let row = &rows[k.min(count - 1) * M..][..M];
        for i in 0..M {
            x[i][k] = row[i];
        }
    }
    x
}

/// The AVX2 shuffles (inlined into the kernels' AVX2 and AVX-512 variants, which have the
/// features; a `V3` token exists only where the CPU has them).
#[cfg(target_arch = "x86_64")]
mod avx {
    use super::{__m256d, V3};
    use pulp::cast;

    #[inline(always)]
    fn ld(v: [f64; 4]) -> __m256d {
        cast(v)
    }

    #[inline(always)]
    fn put(out: &mut [f64], v: __m256d) {
        let a: [f64; 4] = cast(v);
        out.copy_from_slice(&a);
    }

    /// Lane 0 of `x`, lane 1 of `y`, lane 2 of `z`, lane 3 of `x`. (Functions here, never
    /// closures: a kernel's variant is large, and a closure LLVM leaves out of line is
    /// compiled without the variant's instruction set.)
    #[inline(always)]
    fn blend(v3: V3, x: __m256d, y: __m256d, z: __m256d) -> __m256d {
        let xy = v3.avx._mm256_blend_pd::<0b0010>(x, y);
        v3.avx._mm256_blend_pd::<0b0100>(xy, z)
    }

    /// `[a.lo, b.lo]` (`HIGH` false) or `[a.hi, b.hi]`: 128-bit halves of two registers.
    #[inline(always)]
    fn halves<const HIGH: bool>(v3: V3, a: __m256d, b: __m256d) -> __m256d {
        if HIGH {
            v3.avx._mm256_permute2f128_pd::<0x31>(a, b)
        } else {
            v3.avx._mm256_permute2f128_pd::<0x20>(a, b)
        }
    }

    /// See [`super::Shuffles::rows_of_cols`]: M = 1, 3, or even (pairs); false for 5.
    #[inline(always)]
    pub(super) fn rows_of_cols<const M: usize>(
        v3: V3,
        col: impl Fn(usize) -> [f64; 4],
        out: &mut [f64],
    ) -> bool {
        match M {
            1 => out.copy_from_slice(&col(0)),
            3 => {
                let (a, b, c) = (ld(col(0)), ld(col(1)), ld(col(2)));
                // a0 a3 a2 a1 / b1 b0 b3 b2 / c2 c1 c0 c3: every row's values in place
                let pa = v3.avx2._mm256_permute4x64_pd::<0b01_10_11_00>(a);
                let pb = v3.avx._mm256_permute_pd::<0b0101>(b);
                let pc = v3.avx2._mm256_permute4x64_pd::<0b11_00_01_10>(c);
                put(&mut out[0..4], blend(v3, pa, pb, pc)); // a0 b0 c0 a1
                put(&mut out[4..8], blend(v3, pb, pc, pa)); // b1 c1 a2 b2
                put(&mut out[8..12], blend(v3, pc, pa, pb)); // c2 a3 b3 c3
            }
            m if m % 2 == 0 => match m / 2 {
                1 => rows_of_pairs::<1>(v3, col, out),
                2 => rows_of_pairs::<2>(v3, col, out),
                3 => rows_of_pairs::<3>(v3, col, out),
                4 => rows_of_pairs::<4>(v3, col, out),
                5 => rows_of_pairs::<5>(v3, col, out),
                6 => rows_of_pairs::<6>(v3, col, out),
                _ => return false,
            },
            _ => return false,
        }
        true
    }

    /// Four rows of P (u, v) pairs from the 2P columns `col` (u_k = `col(2k)`, v_k =
    /// `col(2k + 1)`). The unpacks give each pose's pair in a 128-bit half; the rows, 4P
    /// halves in order, are stored two halves to a register (P pairs of two poses are an
    /// even count, so both halves of a register come from the same pair of poses).
    #[inline(always)]
    pub(super) fn rows_of_pairs<const P: usize>(
        v3: V3,
        col: impl Fn(usize) -> [f64; 4],
        out: &mut [f64],
    ) {
        // lo_k: pairs of poses 0 (low half) and 2 (high); hi_k: poses 1 and 3 (plain loops,
        // not `array::from_fn`, which LLVM may leave out of line in a large variant)
        let zero = ld([0.0; 4]);
        let (mut lo, mut hi) = ([zero; P], [zero; P]);
        for k in 0..P {
            let (u, v) = (ld(col(2 * k)), ld(col(2 * k + 1)));
            lo[k] = v3.avx._mm256_unpacklo_pd(u, v);
            hi[k] = v3.avx._mm256_unpackhi_pd(u, v);
        }
        // pair t of the 4P in memory order: pose q = t / P, pair k = t % P
        let reg = |t: usize| {
            let (q, k) = (t / P, t % P);
            if q % 2 == 0 {
                lo[k]
            } else {
                hi[k]
            }
        };
        for j in 0..2 * P {
            let (t, u) = (2 * j, 2 * j + 1);
            let v = if t / P < 2 {
                halves::<false>(v3, reg(t), reg(u))
            } else {
                halves::<true>(v3, reg(t), reg(u))
            };
            put(&mut out[4 * j..4 * j + 4], v);
        }
    }

    /// See [`super::Shuffles::cols_of_rows`]: M = 1, 2 and 3.
    #[inline(always)]
    pub(super) fn cols_of_rows<const M: usize>(v3: V3, rows: &[f64]) -> Option<[[f64; 4]; M]> {
        let r = |k: usize| -> __m256d {
            let mut a = [0.0; 4];
            a.copy_from_slice(&rows[4 * k..4 * k + 4]);
            ld(a)
        };
        let cols: [__m256d; 3] = match M {
            1 => [r(0), r(0), r(0)],
            2 => {
                // x0 y0 x1 y1 / x2 y2 x3 y3 → x0 y0 x2 y2 / x1 y1 x3 y3 → xs / ys
                let (a, b) = (r(0), r(1));
                let (l, h) = (halves::<false>(v3, a, b), halves::<true>(v3, a, b));
                let (xs, ys) = (
                    v3.avx._mm256_unpacklo_pd(l, h),
                    v3.avx._mm256_unpackhi_pd(l, h),
                );
                [xs, ys, ys]
            }
            3 => {
                // rows a0 b0 c0 a1 / b1 c1 a2 b2 / c2 a3 b3 c3: the blends of rows_of_cols
                // undone, then the permutes (each its own inverse)
                let (r0, r1, r2) = (r(0), r(1), r(2));
                let pa = blend(v3, r0, r2, r1); // a0 a3 a2 a1
                let pb = blend(v3, r1, r0, r2); // b1 b0 b3 b2
                let pc = blend(v3, r2, r1, r0); // c2 c1 c0 c3
                [
                    v3.avx2._mm256_permute4x64_pd::<0b01_10_11_00>(pa),
                    v3.avx._mm256_permute_pd::<0b0101>(pb),
                    v3.avx2._mm256_permute4x64_pd::<0b11_00_01_10>(pc),
                ]
            }
            _ => return None,
        };
        Some(std::array::from_fn(|i| cast(cols[i.min(2)])))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block of distinct values: lane k of column i is `100·i + k`.
    fn block<const N: usize>() -> [[f64; L]; N] {
        std::array::from_fn(|i| std::array::from_fn(|k| (100 * i + k) as f64))
    }

    fn check<const N: usize>() {
        let b = block::<N>();
        let (mut with, mut without) = (vec![0.0; L * N], vec![1.0; L * N]);
        transpose_into(Shuffles::detect(), &b, &mut with);
        transpose_into(Shuffles::copies(), &b, &mut without);
        assert_eq!(with, without, "N = {N}");
        for q in 0..L {
            for i in 0..N {
                assert_eq!(with[q * N + i], b[i][q], "N = {N}, row {q}, column {i}");
            }
        }
        let xy = [b, block::<N>().map(|c| c.map(|v| -v))];
        let (mut with, mut without) = (vec![0.0; 2 * L * N], vec![1.0; 2 * L * N]);
        transpose_xy_into(Shuffles::detect(), &xy, &mut with);
        transpose_xy_into(Shuffles::copies(), &xy, &mut without);
        assert_eq!(with, without, "xy, N = {N}");
        // and back: rows into lanes, a full block and a partial one
        let rows: Vec<f64> = (0..L * N).map(|v| v as f64).collect();
        for count in [L, 5] {
            let a = lanes_of_rows::<N>(Shuffles::detect(), &rows, count);
            let b = lanes_of_rows::<N>(Shuffles::copies(), &rows, count);
            assert_eq!(a, b, "lanes, N = {N}, count {count}");
            assert_eq!(a[N - 1][L - 1], rows[(count - 1) * N + N - 1]);
        }
    }

    #[test]
    fn the_shuffles_transpose_as_the_copies_do() {
        check::<1>();
        check::<2>();
        check::<3>();
        check::<4>();
        check::<5>();
        check::<6>();
    }
}
