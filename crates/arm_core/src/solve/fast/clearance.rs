//! `joint_clearance` in the block kernel: the offset of each joint's pin in its bore
//! (docs/model.md §4), from the loaded (and, taken up, the unloaded) joint reaction.

use crate::effects::{Effect, EffectSet, Unloaded, FORCE_ZERO_N};
use crate::sweep::fast::{PoseBlock, L};

/// The clearances of an arm's joints (mm; 0 where none).
#[derive(Debug, Clone)]
pub(crate) struct Clearance<const N: usize> {
    /// Clearance c_i at O_i.
    c: [f64; N],
    /// The part of it taken up by the unloaded forces: offset `c·u − c_up·u0`.
    up: [f64; N],
    /// Some joint has clearance.
    pub(crate) any: bool,
}

/// `c·press/|press|`, zero below [`FORCE_ZERO_N`] (the scalar effect's `offset`).
#[inline(always)]
fn offset(px: f64, py: f64, c: f64) -> (f64, f64) {
    let m = (px * px + py * py).sqrt();
    let q = if m < FORCE_ZERO_N { 0.0 } else { c / m };
    (px * q, py * q)
}

impl<const N: usize> Clearance<N> {
    pub(crate) fn new(effects: &EffectSet) -> Self {
        let mut k = Self {
            c: [0.0; N],
            up: [0.0; N],
            any: false,
        };
        for e in effects.effects() {
            if let Effect::JointClearance(x) = e {
                k.c[x.joint] += x.clearance;
                if x.unloaded == Unloaded::TakenUp {
                    k.up[x.joint] += x.clearance;
                }
            }
        }
        k.any = k.c.iter().any(|&c| c != 0.0);
        k
    }

    /// Joint `i` has a clearance (its pin centre moves).
    pub(crate) fn at(&self, i: usize) -> bool {
        self.c[i] != 0.0
    }

    /// Writes the global offset of the pin of every joint with a clearance into `u`
    /// (`[x or y][joint][lane]`; the other joints' entries are left as they are, zero):
    /// along the force −R_i that link i presses on body i−1 in the loaded state (minus the
    /// unloaded one's, taken up).
    #[inline(always)]
    pub(crate) fn offsets(&self, pb: &PoseBlock<N>, u: &mut [[[f64; L]; N]; 2]) {
        for i in 0..N {
            let (c, up) = (self.c[i], self.up[i]);
            if c == 0.0 {
                continue;
            }
            for k in 0..L {
                let (wx, wy) = (pb.rw[0][i][k], pb.rw[1][i][k]);
                let (lx, ly) = (wx + pb.ru[0][i][k], wy + pb.ru[1][i][k]);
                let (ox, oy) = offset(-lx, -ly, c);
                let (zx, zy) = if up == 0.0 {
                    (0.0, 0.0)
                } else {
                    offset(-wx, -wy, up)
                };
                u[0][i][k] = ox - zx;
                u[1][i][k] = oy - zy;
            }
        }
    }
}
