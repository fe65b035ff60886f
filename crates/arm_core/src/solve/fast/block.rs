//! The per-pose results of a block of the solve kernel, read by the writes (`write_block`
//! and a sequence's [`super::group`]).

use super::bending::Shifts;
use crate::sweep::fast::L;

/// Per-pose results of a block (`[link][lane]`).
#[derive(Debug, Clone)]
pub(super) struct SolveBlock<const N: usize> {
    pub(super) force: [[f64; L]; N],
    pub(super) dforce: [[f64; L]; N],
    /// Loaded joint reactions, x and y.
    pub(super) reaction: [[[f64; L]; N]; 2],
    /// Change of absolute angles (deg).
    pub(super) dalpha: [[f64; L]; N],
    pub(super) dl: [[f64; L]; N],
    pub(super) dlength: [[f64; L]; N],
    pub(super) dx: [f64; L],
    pub(super) dy: [f64; L],
    /// Singular or a triangle that cannot close.
    pub(super) fail: [bool; L],
    /// Status codes (docs/model.md §7).
    pub(super) status: [u8; L],
    /// Further body length a body friction leaves (mm; zero without one), a further turn
    /// at a rotary drive (rad).
    pub(super) seen: [[f64; L]; N],
    /// Unloaded angles of the rotary drives with a range (rad).
    pub(super) q: [[f64; L]; N],
}

impl<const N: usize> SolveBlock<N> {
    pub(super) fn new() -> Self {
        let z = [[0.0; L]; N];
        Self {
            force: z,
            dforce: z,
            reaction: [z; 2],
            dalpha: z,
            dl: z,
            dlength: z,
            dx: [0.0; L],
            dy: [0.0; L],
            fail: [false; L],
            status: [0; L],
            seen: z,
            q: z,
        }
    }
}

/// What the geometric effects move in a block, read by its closure: the base tilt (angle
/// (rad), rotation (sin, cos − 1), and the displacement of O_1), the offsets of the joints'
/// pins in their bores (`[x or y][joint][lane]`) and the bending shifts of the links' pins.
/// Zeroed once, when made: each effect of the arm overwrites its own entries in every block
/// and every state, and the entries of the effects it does not have stay zero.
pub(super) struct Moves<const N: usize> {
    pub(super) tilt: [[f64; L]; 5],
    pub(super) u: [[[f64; L]; N]; 2],
    pub(super) sh: Shifts<N>,
}

impl<const N: usize> Moves<N> {
    pub(super) fn new() -> Self {
        Self {
            tilt: [[0.0; L]; 5],
            u: [[[0.0; L]; N]; 2],
            sh: Shifts::new(),
        }
    }
}
