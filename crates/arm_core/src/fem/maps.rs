//! Kinematic maps of one pose: the translation of every station and named point as an affine
//! combination of the DOFs, `t = Σ_k q_k·c_k + t₀`.
//!
//! This is how the joints, the rigid offsets and the rigid links enter the model exactly
//! (by elimination, so the stiffness matrix stays symmetric positive definite):
//!
//! * a point (x, y) on link i hangs on the station at x: `t = t_s + θ_s·(R(α_i)·(0, y)ᵀ)^⊥`
//!   (a small rotation θ moves a lever r by θ·r^⊥, r^⊥ = (−r_y, r_x)); a point merged with
//!   a nearby station hangs on it by the lever (dx, y);
//! * link i's joint station carries no translation of its own: it *is* the pin, which sits
//!   on the proximal body's point `next_{i−1}` (the chassis point O1 for i = 1), plus the
//!   clearance offset s_i of a closed gap: `t_{O_i} = t_{next_{i−1}} + s_i`;
//! * a rigid link's stations all follow its joint, by the same lever rule with the station's
//!   local position: `t = t_{O_i} + θ_i·(R(α_i)·(x, 0)ᵀ)^⊥` (plus `u·e_x` along the link when
//!   it stretches but does not bend); an inextensible link's stations keep the joint's axial
//!   displacement and add their own transverse one, `t = e_x·(e_x·t_{O_i}) + v·e_y`;
//! * the chassis points turn with the base tilt φ about the pivot: `t = φ·(P − pivot)^⊥`.
//!
//! The set of DOFs in each map depends on the arm only, never on the pose (a coefficient may
//! be zero), so every pose has the same sparsity pattern. Buffers keep their capacity: after
//! the first pose nothing is allocated.

use crate::arm::Arm;
use crate::geometry::{rot_sc, V2};
use crate::kinematics::Frames;

use super::mesh::{Attach, LinkKind, Mesh};

/// `θ × r` for a small rotation θ = 1: r turned by +90°.
#[inline]
pub fn perp(r: V2) -> V2 {
    V2::new(-r.y, r.x)
}

/// An affine map from the DOFs to a 2-D translation.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Lin {
    /// (DOF, coefficient): the translation gains `q[dof]·coefficient`.
    pub terms: Vec<(usize, V2)>,
    /// Prescribed part (a closed gap's offset), mm.
    pub off: V2,
}

impl Lin {
    /// Empties the map, keeping its capacity.
    #[inline]
    pub fn clear(&mut self) {
        self.terms.clear();
        self.off = V2::zeros();
    }

    /// Adds `q[dof]·c`, merging with an existing term of the same DOF.
    #[inline]
    pub fn add(&mut self, dof: usize, c: V2) {
        if let Some(t) = self.terms.iter_mut().find(|t| t.0 == dof) {
            t.1 += c;
        } else {
            self.terms.push((dof, c));
        }
    }

    /// Makes `self` a copy of `other`, keeping its own capacity.
    #[inline]
    pub fn copy_from(&mut self, other: &Lin) {
        self.terms.clear();
        self.terms.extend_from_slice(&other.terms);
        self.off = other.off;
    }

    /// The linear part at `u` (no offset).
    #[inline]
    pub fn linear(&self, u: &[f64]) -> V2 {
        let mut t = V2::zeros();
        for &(d, c) in &self.terms {
            t += c * u[d];
        }
        t
    }

    /// The translation at `u`, offset included.
    #[inline]
    pub fn eval(&self, u: &[f64]) -> V2 {
        self.linear(u) + self.off
    }

    /// Adds the generalised forces of a force `f` acting at this point to `rhs`.
    #[inline]
    pub fn load(&self, f: V2, rhs: &mut [f64]) {
        for &(d, c) in &self.terms {
            rhs[d] += c.dot(&f);
        }
    }
}

/// The maps of one pose.
#[derive(Debug, Clone, Default)]
pub struct Maps {
    /// Per link, per station: translation of the axis point.
    pub station: Vec<Vec<Lin>>,
    /// Per link: pin A_i.
    pub a: Vec<Lin>,
    /// Per actuator i: its base pin B_{i−1} (B_0 on the chassis for i = 1).
    pub b: Vec<Lin>,
    /// Per link: the next joint (last link: load point), on this link.
    pub next: Vec<Lin>,
    /// Per link: centre of mass.
    pub c: Vec<Lin>,
    /// The measure point on the last link.
    pub measure: Lin,
    /// The chassis point O1 (the bore of joint 1).
    pub o1: Lin,
    /// Per link: the pin of its joint O_i as this link carries it (= `station[origin]`).
    pub pin: Vec<Lin>,
}

impl Maps {
    /// Buffers sized for `mesh`.
    pub fn new(mesh: &Mesh) -> Self {
        let n = mesh.links.len();
        Self {
            station: mesh
                .links
                .iter()
                .map(|l| vec![Lin::default(); l.x.len()])
                .collect(),
            a: vec![Lin::default(); n],
            b: vec![Lin::default(); n],
            next: vec![Lin::default(); n],
            c: vec![Lin::default(); n],
            measure: Lin::default(),
            o1: Lin::default(),
            pin: vec![Lin::default(); n],
        }
    }

    /// Fills the maps of the pose `fr`, with the closed-gap offsets `offset` (global, mm) of
    /// each joint's pin from its bore.
    #[allow(clippy::needless_range_loop)] // i indexes the links, their maps and offsets
    pub fn fill(&mut self, arm: &Arm, mesh: &Mesh, fr: &Frames, offset: &[V2]) {
        let n = arm.n();
        let pv = arm.pivot;
        self.o1.clear();
        self.b[0].clear();
        if let Some(d) = mesh.base_dof {
            self.o1.add(d, perp(arm.o1 - pv));
            self.b[0].add(d, perp(arm.b0 - pv));
        }
        for i in 0..n {
            let lm = &mesh.links[i];
            let (s, c) = (fr.sin[i], fr.cos[i]);
            let stations = &mut self.station[i];
            // The joint: the proximal body's point, plus the gap offset.
            {
                let bore = if i == 0 { &self.o1 } else { &self.next[i - 1] };
                let o = &mut stations[lm.origin];
                o.copy_from(bore);
                o.off += offset[i];
            }
            let theta_o = lm.dof[lm.origin][2];
            let along = rot_sc(s, c, V2::new(1.0, 0.0));
            let across = rot_sc(s, c, V2::new(0.0, 1.0));
            for k in 0..lm.x.len() {
                if k == lm.origin {
                    continue;
                }
                let (head, tail) = stations.split_at_mut(k.max(lm.origin));
                let (origin, this) = if k > lm.origin {
                    (&head[lm.origin], &mut tail[0])
                } else {
                    (&tail[0], &mut head[k])
                };
                let lever = perp(rot_sc(s, c, V2::new(lm.x[k], 0.0)));
                match lm.kind {
                    LinkKind::Rigid => {
                        this.copy_from(origin);
                        this.add(theta_o, lever);
                    }
                    LinkKind::Axial => {
                        this.copy_from(origin);
                        this.add(theta_o, lever);
                        this.add(lm.dof[k][0], along);
                    }
                    LinkKind::Bending => {
                        // Inextensible: the axial displacement is the joint's.
                        this.clear();
                        for &(d, g) in &origin.terms {
                            this.add(d, along * along.dot(&g));
                        }
                        this.off = along * along.dot(&origin.off);
                        this.add(lm.dof[k][1], across);
                    }
                    LinkKind::Full => {
                        this.clear();
                        this.add(lm.dof[k][0], V2::new(1.0, 0.0));
                        this.add(lm.dof[k][1], V2::new(0.0, 1.0));
                    }
                }
            }
            let stations = &self.station[i];
            let point = |out: &mut Lin, at: Attach| {
                out.copy_from(&stations[at.station]);
                if at.y != 0.0 || at.dx != 0.0 {
                    out.add(lm.rot(at.station), perp(rot_sc(s, c, at.offset())));
                }
            };
            point(&mut self.a[i], lm.a);
            point(&mut self.next[i], lm.next);
            point(&mut self.c[i], lm.c);
            self.pin[i].copy_from(&stations[lm.origin]);
            if let Some(b) = lm.b {
                point(&mut self.b[i + 1], b);
            }
            if let Some(m) = lm.measure {
                point(&mut self.measure, m);
            }
        }
    }
}
