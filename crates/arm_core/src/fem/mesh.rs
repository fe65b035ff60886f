//! The mesh: stations along each link's axis, the points attached to them, and the numbering
//! of the degrees of freedom. It depends on the arm, the sections and the mesh density, never
//! on the pose, so one sparsity pattern serves every pose of a sweep.
//!
//! Link i's axis is its local x axis. Its stations are the abscissae of its joint (x = 0), of
//! its pins A, B, of the next joint, of its centre of mass C and (last link) of the measure
//! point, with every interval cut into elements no longer than `extent / elements_per_link`.
//! A point (x, y) hangs on the station at x by a rigid offset y. Abscissae closer than
//! [`MERGE`] of the extent share one station (the joint's, else A's, else the first), and the
//! points there hang on it by a rigid offset (dx, y): a beam element a thousandth of the link
//! long would be 10⁹ times stiffer in bending than the rest and ruin K's conditioning
//! (docs/fem.md).
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

/// Key abscissae closer than this fraction of the link's extent share one station.
pub const MERGE: f64 = 0.01;

/// A point of a link: the station it hangs on and its rigid offset from it (mm, link frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attach {
    /// Index of the station at (or merged with) the point's abscissa.
    pub station: usize,
    /// Offset along the axis from the station (0 unless merged).
    pub dx: f64,
    /// Local y of the point (offset from the axis).
    pub y: f64,
}

impl Attach {
    /// The rigid offset (dx, y) in the link frame.
    #[inline]
    pub fn offset(&self) -> V2 {
        V2::new(self.dx, self.y)
    }
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
    /// along its local x); at the joint station `[NONE, NONE, θ]`.
    pub dof: Vec<[usize; 3]>,
    /// The actuator pin A_i.
    pub a: Attach,
    /// The next actuator's base pin B_i (not on the last link).
    pub b: Option<Attach>,
    /// The next joint (last link: the load point).
    pub next: Attach,
    /// The centre of mass.
    pub c: Attach,
    /// The measure point (last link only).
    pub measure: Option<Attach>,
    /// Local x of A_i: the second support of the link's chord.
    pub xa: f64,
}

impl LinkMesh {
    /// The DOF that carries the rotation of station `k`.
    #[inline]
    pub fn rot(&self, k: usize) -> usize {
        if self.kind.bends() {
            self.dof[k][2]
        } else {
            self.dof[self.origin][2]
        }
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
    /// flexible link whose pin A lies at x = 0 (its chord, hence its angle, is undefined).
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
            let mut keys = vec![0.0, link.a.x, link.next.x, link.c.x];
            if !last {
                keys.push(link.b.x);
            } else {
                keys.push(arm.measure.x);
            }
            let x = stations(&mut keys, elements_per_link, link.a.x);
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
            if kind.bends() && link.a.x.abs() <= 1e-9 * (1.0 + link.a.norm()) {
                return Err(ArmError::Unsupported(format!(
                    "link {}: pin A lies at x = 0, so a link that bends has no chord to \
                     measure its angle by",
                    i + 1
                )));
            }
            let at = |p: V2| {
                let station = find(&x, p.x);
                Attach {
                    station,
                    dx: p.x - x[station],
                    y: p.y,
                }
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
                a: at(link.a),
                b: (!last).then(|| at(link.b)),
                next: at(link.next),
                c: at(link.c),
                measure: last.then(|| at(arm.measure)),
                xa: link.a.x,
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

/// Sorted key abscissae, those closer than `MERGE` of the extent merged into one (0 first,
/// then `xa`, then the smallest), each interval cut into pieces no longer than extent/m.
fn stations(keys: &mut [f64], m: usize, xa: f64) -> Vec<f64> {
    keys.sort_by(f64::total_cmp);
    let lo = keys[0];
    let hi = keys[keys.len() - 1];
    let tol = MERGE * (hi - lo);
    // Clusters of keys, each represented by one abscissa.
    let mut reps: Vec<f64> = Vec::new();
    let mut start = 0;
    for j in 1..=keys.len() {
        if j == keys.len() || keys[j] - keys[j - 1] > tol {
            let cluster = &keys[start..j];
            let rep = if cluster.contains(&0.0) {
                0.0
            } else if cluster.contains(&xa) {
                xa
            } else {
                cluster[0]
            };
            reps.push(rep);
            start = j;
        }
    }
    let h = (hi - lo) / m as f64;
    let mut x = vec![reps[0]];
    for &k in reps.iter().skip(1) {
        let last = x[x.len() - 1];
        let len = k - last;
        let pieces = ((len / h) - 1e-9).ceil().max(1.0) as usize;
        for p in 1..pieces {
            x.push(last + len * p as f64 / pieces as f64);
        }
        x.push(k);
    }
    x
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
        let x = stations(&mut keys, 8, 95.0);
        for k in [0.0, 95.0, 480.0, 220.0, -40.0] {
            assert!(x.contains(&k), "{k} missing from {x:?}");
        }
        let h = 520.0 / 8.0;
        assert!(x.windows(2).all(|w| w[1] > w[0] && w[1] - w[0] <= h + 1e-9));
    }

    #[test]
    fn close_keys_share_a_station_keeping_the_joint_and_a() {
        // 299.24 and 300 are 0.25 % of the extent apart: one station, at the first.
        let mut keys = [0.0, 44.8, 299.24, 230.1, 300.0, 2.0];
        let x = stations(&mut keys, 1, 44.8);
        assert_eq!(x, vec![0.0, 44.8, 230.1, 299.24]);
        let mut keys = [0.0, 1.0, 100.0];
        assert_eq!(stations(&mut keys, 1, 1.0), vec![0.0, 100.0]);
        let mut keys = [-0.5, 0.0, 0.9, 100.0];
        assert_eq!(stations(&mut keys, 1, 0.9), vec![0.0, 100.0]);
        let mut keys = [0.0, 50.0, 50.5, 100.0];
        assert_eq!(stations(&mut keys, 1, 50.5), vec![0.0, 50.5, 100.0]);
    }
}
