//! Rotary drives in the block kernel (docs/model.md §10): a link turned by a drive has no
//! triangle to close; it takes body i−1's loaded turn plus its gear's
//! `Δq_i = −S_i/k_i − b·sign T_i (+ b·sign T0_i taken up)` (the sweep kernel's
//! [`FastArm::dlen`] at a drive, with a drive friction's further turn). The turns of a block
//! are known before its closure, so their sines and cosines are taken once, lane by lane
//! ([`sincos_small`]). The drive's angle range is checked unloaded (per pose, from the degrees
//! of the input as the general path reads them) and loaded (per lane, `q_i + Δα_i − Δα_{i−1}`).

use crate::arm::Arm;
use crate::drive::rotary::ANGLE_TOL_RAD;
use crate::drive::RotaryDrive;
use crate::lanes::transpose::{lanes_of_rows, Shuffles};
use crate::lanes::trig::{cos_m1, sincos_small};
use crate::lanes::{Lane, F4, M4};
use crate::sweep::fast::{FastArm, PoseBlock, L};
use crate::validity::Status;
use std::f64::consts::PI;

/// The rotary drives of an arm with an angle range.
#[derive(Debug, Clone)]
pub(crate) struct Ranges<const N: usize> {
    drives: [Option<RotaryDrive>; N],
    /// Some drive has a range.
    pub(crate) any: bool,
}

/// The turns of a block's drives: Δq_i (rad) and its rotation (sin, cos − 1), `[joint][lane]`
/// (zero at linear joints).
#[derive(Debug, Clone)]
pub(crate) struct Turns<const N: usize> {
    pub(crate) q: [[f64; L]; N],
    pub(crate) sin: [[f64; L]; N],
    pub(crate) cos_m1: [[f64; L]; N],
}

impl<const N: usize> Turns<N> {
    /// The turns of joints `fa.rotary` under the loads of `pb` (after the frictions: `seen`
    /// is a drive friction's further turn, rad).
    #[inline(always)]
    pub(crate) fn of<const PLAY: bool, const UP: bool>(
        fa: &FastArm<N>,
        pb: &PoseBlock<N>,
        seen: &[[f64; L]; N],
    ) -> Self {
        let z = [[0.0; L]; N];
        let mut t = Self {
            q: z,
            sin: z,
            cos_m1: z,
        };
        let mut c = [0.0; L];
        for i in 0..N {
            if !fa.rotary[i] {
                continue;
            }
            for k in 0..L {
                let (du, fw) = (pb.fu[i][k], pb.fw[i][k]);
                t.q[i][k] = fa.dlen::<PLAY, UP, f64>(i, du, fw + du, fw) + seen[i][k];
            }
            sincos_small(&t.q[i], &mut t.sin[i], &mut c);
            for k in 0..L {
                t.cos_m1[i][k] = cos_m1(t.sin[i][k], c[k]);
            }
        }
        t
    }
}

impl<const N: usize> Ranges<N> {
    pub(crate) fn new(arm: &Arm) -> Self {
        let drives: [Option<RotaryDrive>; N] = std::array::from_fn(|i| {
            arm.drives[i]
                .rotary()
                .filter(|r| r.min_angle.is_some() || r.max_angle.is_some())
                .cloned()
        });
        let any = drives.iter().any(Option::is_some);
        Self { drives, any }
    }

    /// The unloaded drive angles `q` (rad, [`RotaryDrive::angle_of`]) of a block's `count`
    /// rows of angles (deg); a pose with one outside its range is out of stroke in `pb`.
    /// Inlined into the kernel's instruction-set variant, and written as lane loops without
    /// branches (a block whose angles need a turn's wrapping takes `angle_of` itself), so
    /// that LLVM vectorises them; the angles are `angle_of`'s, bit for bit.
    #[inline(always)]
    pub(crate) fn unloaded(
        &self,
        alpha_deg: &[f64],
        count: usize,
        pb: &mut PoseBlock<N>,
        q: &mut [[f64; L]; N],
    ) {
        let x = lanes_of_rows::<N>(Shuffles::copies(), alpha_deg, count);
        let relative = |i: usize, k: usize| {
            let before = if i == 0 {
                0.0
            } else {
                x[i - 1][k].to_radians()
            };
            x[i][k].to_radians() - before
        };
        for (i, d) in self.drives.iter().enumerate() {
            let Some(d) = d else { continue };
            // `angle_of` is `mid + wrap_pi(q − mid)`, and `wrap_pi` keeps [−π, π) as it is.
            let mid = d.mid_angle();
            let mut inside = true;
            for k in 0..L {
                let y = relative(i, k) - mid;
                q[i][k] = mid + y;
                inside &= (-PI..PI).contains(&y); // a NaN is not inside
            }
            if !inside {
                for k in 0..L {
                    q[i][k] = d.angle_of(relative(i, k));
                }
            }
            // `RotaryDrive::out_of_range`, branch-free.
            let (lo, hi) = d.bounds();
            let code = Status::OutOfStroke.code();
            for k in 0..L {
                let out = q[i][k] < lo || q[i][k] > hi;
                pb.out_of_stroke[k] |= out;
                pb.reachable[k] &= !out;
                pb.code[k] = if out { code } else { pb.code[k] };
            }
        }
    }

    /// Drive `i` has a range.
    pub(crate) fn at(&self, i: usize) -> bool {
        self.drives[i].is_some()
    }

    /// Lanes whose drive `i` (with a range) is out of it loaded, as
    /// [`crate::validity::out_of_angle`] checks it: its unloaded angle `q` (rad) plus the
    /// turn `Δα_i − Δα_{i−1}` of the links (`d`, `before`: deg, as the outputs give them,
    /// zero before link 1), a turn within [`ANGLE_TOL_RAD`] being none.
    #[inline(always)]
    pub(crate) fn loaded_out(&self, i: usize, q: F4, d: F4, before: F4) -> M4 {
        let Some(r) = &self.drives[i] else {
            return M4::FALSE;
        };
        let rad = std::f64::consts::PI / 180.0; // f64::to_radians's factor
        let dq = d * rad - before * rad;
        let a = q + dq;
        let (lo, hi) = r.bounds();
        let turned = Lane::gt(dq.abs(), ANGLE_TOL_RAD) & Lane::lt(dq.abs(), f64::INFINITY);
        turned & (Lane::lt(a, lo) | Lane::gt(a, hi))
    }
}
