//! The mesh: stations along each link's axis, the points attached to them, and the numbering
//! of the degrees of freedom. It depends on the arm, the sections and the mesh density, never
//! on the pose, so one sparsity pattern serves every pose of a sweep.
//!
//! Link i's axis is its local x axis. Its stations are the abscissae of its joint (x = 0), of
//! its pins A (when a linear actuator turns it) and B (when one turns the next link), of the
//! next joint, of its centre of mass C and (last link) of the measure point, with every interval cut into elements no longer than `extent / elements_per_link`.
//! A point (x, y) hangs on the station at x by a rigid offset y. Abscissae closer than
//! [`MERGE`] of the extent form a cluster: its anchor is the joint's station if it is in it,
//! else A's, else the first, and the others are *relative* stations whose DOFs measure their
//! departure from the anchor's rigid motion. A beam element a thousandth of the link long is
//! 10⁹ times stiffer in bending than the rest; on absolute DOFs it would ruin K's conditioning,
//! on relative ones its stiffness acts on the departure alone (docs/fem.md). Nothing is
//! approximated.
//!
//! Degrees of freedom. At its joint station a link owns only its rotation θ: the translation
//! there is the pin of the joint, carried by the proximal body (see `maps`). Elsewhere it
//! depends on what the link's section allows ([`LinkKind`]): with EI and EA, (u_x, u_y, θ) in
//! global components; with EI only (axially rigid), the transverse displacement v and θ; with
//! EA only (rigid in bending), the axial displacement u; with neither (a rigid link), nothing.
//! A rigid direction is thus exact (a constraint), not a stiff penalty spring. A compliant base
//! adds the chassis tilt φ.

use crate::arm::Arm;
use crate::error::{ArmError, Result};
use crate::geometry::V2;

use super::spec::FemSpec;

/// "No DOF here": the quantity is carried by another DOF (slaved or rigid).
pub const NONE: usize = usize::MAX;

/// Key abscissae closer than this fraction of the link's extent form a cluster of relative
/// stations around one anchor.
pub const MERGE: f64 = 0.01;

/// A point of a link: the station at its abscissa and its offset from the axis (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attach {
    /// Index of the station at the point's abscissa.
    pub station: usize,
    /// Local y of the point (rigid offset from the axis).
    pub y: f64,
}

/// What a link's section lets it do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkKind {
    /// No section given: one rigid body.
    Rigid,
    /// EI only: bends, does not stretch.
    Bending,
    /// EA only: stretches, does not bend.
    Axial,
    /// EI and EA: bends and stretches.
    Full,
}

impl LinkKind {
    /// Whether the link bends (its stations own their rotations).
    #[inline]
    pub fn bends(self) -> bool {
        matches!(self, Self::Bending | Self::Full)
    }
}

/// The stations and DOFs of one link.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkMesh {
    /// Station abscissae (local x, mm), increasing.
    pub x: Vec<f64>,
    /// Index of the station at x = 0 (the joint O_i).
    pub origin: usize,
    /// What the section allows.
    pub kind: LinkKind,
    /// Per station: its own DOF numbers, [`NONE`] where it has none: `[u_x, u_y, θ]` (Full),
    /// `[NONE, v, θ]` (Bending: v along the link's local y), `[u, NONE, NONE]` (Axial: u
    /// along its local x); at the joint station `[NONE, NONE, θ]`. A relative station's DOFs
    /// are its departure from its anchor's rigid motion.
    pub dof: Vec<[usize; 3]>,
    /// Per station: the anchor of a relative station (see the module notes).
    pub anchor: Vec<Option<usize>>,
    /// The actuator pin A_i (none when a rotary drive turns the link).
    pub a: Option<Attach>,
    /// The next actuator's base pin B_i (none on the last link, or when a rotary drive turns
    /// the next link).
    pub b: Option<Attach>,
    /// The next joint (last link: the load point).
    pub next: Attach,
    /// The centre of mass.
    pub c: Attach,
    /// The measure point (last link only).
    pub measure: Option<Attach>,
    /// Local x of A_i: the second support of the link's chord (NaN when a rotary drive
    /// turns the link).
    pub xa: f64,
    /// A rotary drive turns the link: it is clamped to the drive's flange at its joint, and
    /// its frame is the flange's (docs/model.md §10).
    pub rotary: bool,
}

impl LinkMesh {
    /// The rotation DOF of the joint station (the link's rotation if it does not bend).
    #[inline]
    pub fn theta_origin(&self) -> usize {
        self.dof[self.origin][2]
    }

    /// Extent of the axis (mm).
    pub fn extent(&self) -> f64 {
        self.x[self.x.len() - 1] - self.x[0]
    }

    /// The beam elements: consecutive station pairs (none on a rigid link).
    pub fn elements(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        let m = if self.kind == LinkKind::Rigid {
            0
        } else {
            self.x.len() - 1
        };
        (0..m).map(|k| (k, k + 1))
    }
}

/// The mesh of a whole arm.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// One per link, in chain order.
    pub links: Vec<LinkMesh>,
    /// The chassis tilt DOF (compliant base only).
    pub base_dof: Option<usize>,
    /// Number of DOFs.
    pub n_dof: usize,
}

impl Mesh {
    /// Meshes `arm` with `elements_per_link` elements (at least) along each flexible link.
    ///
    /// # Errors
    /// [`ArmError::OutOfRange`] for `elements_per_link == 0` or above 10 000;
    /// [`ArmError::Unsupported`] for a link whose points all lie at x = 0 (no axis), or a
    /// flexible link turned by a linear actuator whose pin A lies at x = 0 (its chord, hence
    /// its angle, is undefined).
    pub fn new(arm: &Arm, spec: &FemSpec, elements_per_link: usize) -> Result<Self> {
        if elements_per_link == 0 || elements_per_link > 10_000 {
            return Err(ArmError::OutOfRange {
                row: 0,
                what: format!("elements_per_link must be in 1..=10000, got {elements_per_link}"),
            });
        }
        let n = arm.n();
        let mut next_dof = 0;
        let base_dof = spec.base_stiffness.map(|_| {
            next_dof += 1;
            0
        });
        let mut links = Vec::with_capacity(n);
        for (i, link) in arm.links.iter().enumerate() {
            let last = i + 1 == n;
            let rotary = arm.is_rotary(i);
            let b_used = !last && !arm.is_rotary(i + 1);
            let xa = if rotary { f64::NAN } else { link.a.x };
            let mut keys = vec![0.0, link.next.x, link.c.x];
            if !rotary {
                keys.push(link.a.x);
            }
            if b_used {
                keys.push(link.b.x);
            }
            if last {
                keys.push(arm.measure.x);
            }
            let (x, anchor) = stations(&mut keys, elements_per_link, xa);
            let lo = x[0];
            let hi = x[x.len() - 1];
            let scale = 1.0 + hi.abs().max(lo.abs());
            if hi - lo <= 1e-9 * scale {
                return Err(ArmError::Unsupported(format!(
                    "link {}: every point lies at x = 0 of the link, so it has no beam axis",
                    i + 1
                )));
            }
            let sec = spec.sections[i];
            let kind = match (sec.ei.is_some(), sec.ea.is_some()) {
                (false, false) => LinkKind::Rigid,
                (true, false) => LinkKind::Bending,
                (false, true) => LinkKind::Axial,
                (true, true) => LinkKind::Full,
            };
            if !rotary && kind.bends() && link.a.x.abs() <= 1e-9 * (1.0 + link.a.norm()) {
                return Err(ArmError::Unsupported(format!(
                    "link {}: pin A lies at x = 0, so a link that bends has no chord to \
                     measure its angle by",
                    i + 1
                )));
            }
            let at = |p: V2| Attach {
                station: find(&x, p.x),
                y: p.y,
            };
            let origin = find(&x, 0.0);
            let mut dof = vec![[NONE; 3]; x.len()];
            for (k, d) in dof.iter_mut().enumerate() {
                let mut own = |want: [bool; 3]| {
                    for (slot, w) in d.iter_mut().zip(want) {
                        if w {
                            *slot = next_dof;
                            next_dof += 1;
                        }
                    }
                };
                match (k == origin, kind) {
                    (true, _) => own([false, false, true]),
                    (false, LinkKind::Rigid) => {}
                    (false, LinkKind::Bending) => own([false, true, true]),
                    (false, LinkKind::Axial) => own([true, false, false]),
                    (false, LinkKind::Full) => own([true, true, true]),
                }
            }
            links.push(LinkMesh {
                origin,
                kind,
                dof,
                anchor,
                a: (!rotary).then(|| at(link.a)),
                b: b_used.then(|| at(link.b)),
                next: at(link.next),
                c: at(link.c),
                measure: last.then(|| at(arm.measure)),
                xa,
                rotary,
                x,
            });
        }
        Ok(Self {
            links,
            base_dof,
            n_dof: next_dof,
        })
    }
}

impl Mesh {
    /// Renumbers every DOF `d` as `new[d]` (a permutation).
    pub fn renumber(&mut self, new: &[usize]) {
        if let Some(d) = &mut self.base_dof {
            *d = new[*d];
        }
        for lm in &mut self.links {
            for d in lm.dof.iter_mut().flatten() {
                if *d != NONE {
                    *d = new[*d];
                }
            }
        }
    }
}

/// The stations of sorted `keys`: every distinct key, each interval between clusters (keys
/// closer than `MERGE` of the extent) cut into pieces no longer than extent/m; and per
/// station its anchor if it is a relative station (a non-anchor key of a cluster; the anchor
/// is 0, else `xa` (NaN: none), else the cluster's first key).
fn stations(keys: &mut [f64], m: usize, xa: f64) -> (Vec<f64>, Vec<Option<usize>>) {
    keys.sort_by(f64::total_cmp);
    let lo = keys[0];
    let hi = keys[keys.len() - 1];
    let same = 1e-9 * (1.0 + hi.abs().max(lo.abs()));
    let tol = MERGE * (hi - lo);
    let mut distinct: Vec<f64> = Vec::with_capacity(keys.len());
    for &k in keys.iter() {
        if distinct.last().is_none_or(|&l| k - l > same) {
            distinct.push(k);
        }
    }
    // Clusters: (first, last) indices into `distinct`, and their anchor abscissa.
    let mut clusters: Vec<(usize, usize, f64)> = Vec::new();
    let mut start = 0;
    for j in 1..=distinct.len() {
        if j == distinct.len() || distinct[j] - distinct[j - 1] > tol {
            let c = &distinct[start..j];
            let anchor = if c.iter().any(|&v| v.abs() <= same) {
                0.0
            } else if c.iter().any(|&v| (v - xa).abs() <= same) {
                xa
            } else {
                c[0]
            };
            clusters.push((start, j - 1, anchor));
            start = j;
        }
    }
    let h = (hi - lo) / m as f64;
    let mut x: Vec<f64> = Vec::new();
    let mut cluster_of: Vec<Option<usize>> = Vec::new();
    for (ci, &(first, last, _)) in clusters.iter().enumerate() {
        if let Some(&prev) = x.last() {
            let len = distinct[first] - prev;
            let pieces = ((len / h) - 1e-9).ceil().max(1.0) as usize;
            for p in 1..pieces {
                x.push(prev + len * p as f64 / pieces as f64);
                cluster_of.push(None);
            }
        }
        for &k in &distinct[first..=last] {
            x.push(k);
            cluster_of.push(Some(ci));
        }
    }
    let anchor_index: Vec<usize> = clusters
        .iter()
        .enumerate()
        .map(|(ci, &(_, _, a))| {
            (0..x.len())
                .find(|&k| cluster_of[k] == Some(ci) && (x[k] - a).abs() <= same)
                .unwrap_or(0)
        })
        .collect();
    let anchor = (0..x.len())
        .map(|k| match cluster_of[k] {
            Some(ci) if anchor_index[ci] != k => Some(anchor_index[ci]),
            _ => None,
        })
        .collect();
    (x, anchor)
}

/// Index of the station nearest `v` (every key abscissa is a station).
fn find(x: &[f64], v: f64) -> usize {
    let mut best = 0;
    for (k, &xk) in x.iter().enumerate() {
        if (xk - v).abs() < (x[best] - v).abs() {
            best = k;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::stations;

    #[test]
    fn stations_keep_every_key_and_respect_the_length() {
        let mut keys = [0.0, 95.0, 480.0, 220.0, -40.0, 95.0];
        let (x, anchor) = stations(&mut keys, 8, 95.0);
        for k in [0.0, 95.0, 480.0, 220.0, -40.0] {
            assert!(x.contains(&k), "{k} missing from {x:?}");
        }
        let h = 520.0 / 8.0;
        assert!(x.windows(2).all(|w| w[1] > w[0] && w[1] - w[0] <= h + 1e-9));
        assert!(anchor.iter().all(Option::is_none));
    }

    #[test]
    fn close_keys_become_relative_stations_of_the_joint_a_or_the_first() {
        // 299.24 and 300 are 0.25 % of the extent apart: 300 hangs on 299.24.
        let mut keys = [0.0, 44.8, 299.24, 230.1, 300.0, 2.0];
        let (x, anchor) = stations(&mut keys, 1, 44.8);
        assert_eq!(x, vec![0.0, 2.0, 44.8, 230.1, 299.24, 300.0]);
        assert_eq!(anchor, vec![None, Some(0), None, None, None, Some(4)]);
        let mut keys = [-0.5, 0.0, 0.9, 100.0];
        let (x, anchor) = stations(&mut keys, 1, 0.9);
        assert_eq!(x, vec![-0.5, 0.0, 0.9, 100.0]);
        assert_eq!(anchor, vec![Some(1), None, Some(1), None]);
        let mut keys = [0.0, 50.0, 50.5, 100.0];
        let (_, anchor) = stations(&mut keys, 1, 50.5);
        assert_eq!(anchor, vec![None, Some(2), None, None]);
    }
}
