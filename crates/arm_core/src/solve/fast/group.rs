//! The outputs of a group of a sequence block's states, kept until the group is complete and
//! then written sequence by sequence.
//!
//! The L sequences of a block have their rows `S` apart (row `q·S + s`): written state by
//! state, each output of a state would be L short writes `S` rows apart, every one on
//! another cache line, and each line of the block filled over several states. Kept for up
//! to [`GROUP`] states, a sequence's rows are consecutive: each output of the block is
//! written in one forward pass, as `solve` writes its rows.

use super::block::SolveBlock;
use crate::solve::batch::BatchOutput;
use crate::sweep::fast::L;

/// States kept before they are written (8 states of a 6-link arm keep about 45 kB).
pub(super) const GROUP: usize = 8;

/// A group's outputs by state (`[state][link][lane]`); only the outputs asked for are kept.
pub(super) struct Group<const N: usize> {
    force: Vec<[[f64; L]; N]>,
    dforce: Vec<[[f64; L]; N]>,
    reaction: Vec<[[[f64; L]; N]; 2]>,
    dalpha: Vec<[[f64; L]; N]>,
    dl: Vec<[[f64; L]; N]>,
    dlength: Vec<[[f64; L]; N]>,
    dx: Vec<[f64; L]>,
    dy: Vec<[f64; L]>,
    status: Vec<[u8; L]>,
}

impl<const N: usize> Group<N> {
    pub(super) fn new() -> Self {
        let z = [[0.0; L]; N];
        Self {
            force: vec![z; GROUP],
            dforce: vec![z; GROUP],
            reaction: vec![[z; 2]; GROUP],
            dalpha: vec![z; GROUP],
            dl: vec![z; GROUP],
            dlength: vec![z; GROUP],
            dx: vec![[0.0; L]; GROUP],
            dy: vec![[0.0; L]; GROUP],
            status: vec![[0; L]; GROUP],
        }
    }

    /// Keeps state `k < GROUP` of the group: what `out` asks for of `sb`.
    #[inline(always)]
    pub(super) fn keep(&mut self, k: usize, sb: &SolveBlock<N>, out: &BatchOutput<'_>) {
        if !(out.force_n.is_empty() && out.torque_nmm.is_empty()) {
            self.force[k] = sb.force;
        }
        if !(out.dforce_n.is_empty() && out.dtorque_nmm.is_empty()) {
            self.dforce[k] = sb.dforce;
        }
        if !out.reaction_n.is_empty() {
            self.reaction[k] = sb.reaction;
        }
        if !out.dalpha_deg.is_empty() {
            self.dalpha[k] = sb.dalpha;
        }
        if !out.dl_mm.is_empty() {
            self.dl[k] = sb.dl;
        }
        if !out.dlength_mm.is_empty() {
            self.dlength[k] = sb.dlength;
        }
        if !out.dx_mm.is_empty() {
            self.dx[k] = sb.dx;
        }
        if !out.dy_mm.is_empty() {
            self.dy[k] = sb.dy;
        }
        self.status[k] = sb.status;
    }

    /// Writes the first `g` states kept: lane j's to the `g` consecutive rows from
    /// `first[j]` (`len`: the bodies' lengths, the same in every state of a block). An
    /// output not asked for is empty: nothing is written there.
    #[inline(always)]
    pub(super) fn write(
        &self,
        g: usize,
        len: &[[f64; L]; N],
        rotary: &[bool; N],
        out: &mut BatchOutput<'_>,
        status: &mut [u8],
        first: &[usize],
    ) {
        let all = [true; N];
        let linear: [bool; N] = std::array::from_fn(|i| !rotary[i]);
        // Each drive's load in its own arrays, NaN at the links of the other kind.
        put(&self.force[..g], linear, out.force_n, first);
        put(&self.dforce[..g], linear, out.dforce_n, first);
        put(&self.force[..g], *rotary, out.torque_nmm, first);
        put(&self.dforce[..g], *rotary, out.dtorque_nmm, first);
        put(&self.dalpha[..g], all, out.dalpha_deg, first);
        put(&self.dl[..g], all, out.dl_mm, first);
        put(&self.dlength[..g], all, out.dlength_mm, first);
        put_same(len, g, out.length_mm, first);
        if !out.reaction_n.is_empty() {
            for (j, &r) in first.iter().enumerate() {
                let dst = &mut out.reaction_n[2 * r * N..2 * (r + g) * N];
                for (b, d) in self.reaction[..g].iter().zip(dst.chunks_exact_mut(2 * N)) {
                    for i in 0..N {
                        d[2 * i] = b[0][i][j];
                        d[2 * i + 1] = b[1][i][j];
                    }
                }
            }
        }
        put_one(&self.dx[..g], out.dx_mm, first);
        put_one(&self.dy[..g], out.dy_mm, first);
        put_one(&self.status[..g], status, first);
    }
}

/// Lane j of `blocks` (one per state) to the rows from `first[j]`, NaN at the links where
/// `keep` is false.
#[inline(always)]
fn put<const N: usize>(blocks: &[[[f64; L]; N]], keep: [bool; N], o: &mut [f64], first: &[usize]) {
    if o.is_empty() {
        return;
    }
    let g = blocks.len();
    for (j, &r) in first.iter().enumerate() {
        let dst = &mut o[r * N..(r + g) * N];
        for (b, d) in blocks.iter().zip(dst.chunks_exact_mut(N)) {
            for i in 0..N {
                d[i] = if keep[i] { b[i][j] } else { f64::NAN };
            }
        }
    }
}

/// Lane j of `block` to each of the `g` rows from `first[j]`.
#[inline(always)]
fn put_same<const N: usize>(block: &[[f64; L]; N], g: usize, o: &mut [f64], first: &[usize]) {
    if o.is_empty() {
        return;
    }
    for (j, &r) in first.iter().enumerate() {
        for d in o[r * N..(r + g) * N].chunks_exact_mut(N) {
            for i in 0..N {
                d[i] = block[i][j];
            }
        }
    }
}

/// Lane j of `lanes` (one per state) to the entries from `first[j]`.
#[inline(always)]
fn put_one<T: Copy>(lanes: &[[T; L]], o: &mut [T], first: &[usize]) {
    if o.is_empty() {
        return;
    }
    let g = lanes.len();
    for (j, &r) in first.iter().enumerate() {
        for (v, d) in lanes.iter().zip(&mut o[r..r + g]) {
            *d = v[j];
        }
    }
}
