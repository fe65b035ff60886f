//! `link_bending` in the block kernel: the displacement of a bent link's pins in its frame
//! (docs/model.md §4), as the sum of the link's [`BendInfluence`] over the changes of the
//! forces on it (ΔR_i at O_i, ΔF_i·e_i at A_i, −ΔF_{i+1}·e_{i+1} at B_i, −ΔR_{i+1} at next_i,
//! or the payload there on the last link).

use crate::arm::Arm;
use crate::effects::{BendInfluence, Effect, EffectSet};
use crate::sweep::fast::{PoseBlock, L};

/// The bent links of an arm.
#[derive(Debug, Clone)]
pub(crate) struct Bending<const N: usize> {
    /// Influence of each bent link (`None`: rigid).
    links: [Option<BendInfluence>; N],
    /// Some link bends.
    pub(crate) any: bool,
}

/// Pin displacements of every link in its own frame, `[x or y][link][lane]` (mm).
#[derive(Debug, Clone)]
pub(crate) struct Shifts<const N: usize> {
    pub(crate) a: [[[f64; L]; N]; 2],
    pub(crate) b: [[[f64; L]; N]; 2],
    pub(crate) next: [[[f64; L]; N]; 2],
    /// Of the measure point (last link).
    pub(crate) measure: [[f64; L]; 2],
}

impl<const N: usize> Shifts<N> {
    pub(crate) fn new() -> Self {
        let z = [[[0.0; L]; N]; 2];
        Self {
            a: z,
            b: z,
            next: z,
            measure: [[0.0; L]; 2],
        }
    }
}

impl<const N: usize> Bending<N> {
    pub(crate) fn new(arm: &Arm, effects: &EffectSet) -> Self {
        let mut links = [None; N];
        for e in effects.effects() {
            if let Effect::LinkBending(b) = e {
                links[b.link] = Some(b.influence(arm));
            }
        }
        let any = links.iter().any(Option::is_some);
        Self { links, any }
    }

    /// Link `i` bends (its pins move in its frame).
    pub(crate) fn bends(&self, i: usize) -> bool {
        self.links[i].is_some()
    }

    /// Fills `out` with the pin displacements of the bent links (the rigid ones stay zero).
    /// `sn`, `cs`: sin and cos of the unloaded link angles; `pay`: the payload (N, global).
    #[inline(always)]
    pub(crate) fn shifts(
        &self,
        pb: &PoseBlock<N>,
        sn: &[[f64; L]; N],
        cs: &[[f64; L]; N],
        pay: &[[f64; L]; 2],
        out: &mut Shifts<N>,
    ) {
        for i in 0..N {
            let Some(inf) = &self.links[i] else { continue };
            for k in 0..L {
                let (s, c) = (sn[i][k], cs[i][k]);
                // A global force in link i's frame: R(−α_i)·f.
                let local = |x: f64, y: f64| [c * x + s * y, c * y - s * x];
                let (du, e0, e1) = (pb.fu[i][k], pb.e[0][i][k], pb.e[1][i][k]);
                let mut f = [[0.0; 2]; 4];
                f[0] = local(pb.ru[0][i][k], pb.ru[1][i][k]);
                f[1] = local(du * e0, du * e1);
                if i + 1 < N {
                    let dn = pb.fu[i + 1][k];
                    f[2] = local(-dn * pb.e[0][i + 1][k], -dn * pb.e[1][i + 1][k]);
                    f[3] = local(-pb.ru[0][i + 1][k], -pb.ru[1][i + 1][k]);
                } else {
                    f[3] = local(pay[0][k], pay[1][k]);
                }
                let at = |q: usize| {
                    let (mut x, mut y) = (0.0, 0.0);
                    for p in 0..4 {
                        for j in 0..2 {
                            x += inf[q][p][j].x * f[p][j];
                            y += inf[q][p][j].y * f[p][j];
                        }
                    }
                    [x, y]
                };
                let [ax, ay] = at(0);
                let [bx, by] = at(1);
                let [nx, ny] = at(2);
                (out.a[0][i][k], out.a[1][i][k]) = (ax, ay);
                (out.b[0][i][k], out.b[1][i][k]) = (bx, by);
                (out.next[0][i][k], out.next[1][i][k]) = (nx, ny);
                if i + 1 == N {
                    let [mx, my] = at(3);
                    (out.measure[0][k], out.measure[1][k]) = (mx, my);
                }
            }
        }
    }
}
