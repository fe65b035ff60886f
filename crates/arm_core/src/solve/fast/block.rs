//! The per-pose results of a block of the solve kernel, read by the writes (`write_block`
//! and a sequence's [`super::group`]).

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
