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
//! * the chassis points turn with the base tilt φ about the pivot: `t = φ·(P − pivot)^⊥`;
//! * the housing of a rotary drive at O_i turns with body i−1 there: its rotation is that of
//!   body i−1's station at `next_{i−1}` (its bending slope included), or φ for i = 1.
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

/// A linear map from the DOFs to a (small) rotation: `θ = Σ_k q_k·c_k`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rot {
    /// (DOF, coefficient).
    pub terms: Vec<(usize, f64)>,
}

impl Rot {
    /// The rotation at `u`.
    #[inline]
    pub fn eval(&self, u: &[f64]) -> f64 {
        self.terms.iter().map(|&(d, c)| c * u[d]).sum()
    }

    /// Makes the map the single DOF `dof`.
    #[inline]
    pub fn set(&mut self, dof: usize) {
        self.terms.clear();
        self.terms.push((dof, 1.0));
    }
}

impl Lin {
    /// Adds `θ × lever` for the rotation map `rot`: `Σ q_k·c_k·lever^⊥`.
    #[inline]
    pub fn add_turn(&mut self, rot: &Rot, lever: V2) {
        let p = perp(lever);
        for &(d, c) in &rot.terms {
            self.add(d, p * c);
        }
    }

    /// Adds the component of `other` along the unit vector `dir` (offset included).
    #[inline]
    pub fn add_along(&mut self, other: &Lin, dir: V2) {
        for &(d, g) in &other.terms {
            self.add(d, dir * dir.dot(&g));
        }
        self.off += dir * dir.dot(&other.off);
    }
}

/// The maps of one pose.
#[derive(Debug, Clone, Default)]
pub struct Maps {
    /// Per link, per station: translation of the axis point.
    pub station: Vec<Vec<Lin>>,
    /// Per link, per station: rotation of the axis there.
    pub rot: Vec<Vec<Rot>>,
    /// Per link: pin A_i (empty when a rotary drive turns the link).
    pub a: Vec<Lin>,
    /// Per actuator i: its base pin B_{i−1} (B_0 on the chassis for i = 1; empty at a rotary
    /// drive).
    pub b: Vec<Lin>,
    /// Per joint i: the rotation of body i−1 at O_i (the chassis tilt for i = 1), which turns
    /// the housing of a rotary drive there (empty at a linear joint).
    pub housing: Vec<Rot>,
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
            rot: mesh
                .links
                .iter()
                .map(|l| vec![Rot::default(); l.x.len()])
                .collect(),
            a: vec![Lin::default(); n],
            b: vec![Lin::default(); n],
            housing: vec![Rot::default(); n],
            next: vec![Lin::default(); n],
            c: vec![Lin::default(); n],
            measure: Lin::default(),
            o1: Lin::default(),
            pin: vec![Lin::default(); n],
        }
    }

    /// Fills the maps of the pose `fr`, with the closed-gap offsets `offset` (global, mm) of
    /// each joint's pin from its bore.
    pub fn fill(&mut self, arm: &Arm, mesh: &Mesh, fr: &Frames, offset: &[V2]) {
        let pv = arm.pivot;
        self.o1.clear();
        for (b, h) in self.b.iter_mut().zip(&mut self.housing) {
            b.clear();
            h.terms.clear();
        }
        if let Some(d) = mesh.base_dof {
            self.o1.add(d, perp(arm.o1 - pv));
            if mesh.links[0].rotary {
                self.housing[0].set(d);
            } else {
                self.b[0].add(d, perp(arm.b0 - pv));
            }
        }
        for (i, lm) in mesh.links.iter().enumerate() {
            if i > 0 && lm.rotary {
                let at = mesh.links[i - 1].next.station;
                let (rots, housing) = (&self.rot[i - 1][at], &mut self.housing[i]);
                housing.terms.extend_from_slice(&rots.terms);
            }
            let (s, c) = (fr.sin[i], fr.cos[i]);
            let along = rot_sc(s, c, V2::new(1.0, 0.0));
            let across = rot_sc(s, c, V2::new(0.0, 1.0));
            let o = lm.origin;
            let theta_o = lm.theta_origin();
            // The joint: the proximal body's point, plus the gap offset.
            {
                let bore = if i == 0 { &self.o1 } else { &self.next[i - 1] };
                let t = &mut self.station[i][o];
                t.copy_from(bore);
                t.off += offset[i];
                self.rot[i][o].set(theta_o);
            }
            // Absolute stations first, then the relative ones (their anchors are absolute).
            for pass in [false, true] {
                for k in 0..lm.x.len() {
                    if k == o || lm.anchor[k].is_some() != pass {
                        continue;
                    }
                    let base = lm.anchor[k].unwrap_or(o);
                    let lever = rot_sc(s, c, V2::new(lm.x[k] - lm.x[base], 0.0));
                    let d = lm.dof[k];
                    // Take station k out (no allocation) to read the others while writing it.
                    let mut this = std::mem::take(&mut self.station[i][k]);
                    let mut rthis = std::mem::take(&mut self.rot[i][k]);
                    let (from, rfrom) = (&self.station[i][base], &self.rot[i][base]);
                    let joint = &self.station[i][o];
                    this.clear();
                    rthis.terms.clear();
                    match (lm.kind, pass) {
                        (LinkKind::Rigid, _) => {
                            this.copy_from(from);
                            this.add_turn(rfrom, lever);
                            rthis.terms.push((theta_o, 1.0));
                        }
                        (LinkKind::Axial, _) => {
                            // Rigid in bending: the anchor's (or joint's) motion, plus u·e_x.
                            this.copy_from(from);
                            this.add_turn(rfrom, lever);
                            this.add(d[0], along);
                            rthis.terms.push((theta_o, 1.0));
                        }
                        (LinkKind::Bending, false) => {
                            // Inextensible: the joint's axial displacement, plus v·e_y.
                            this.add_along(joint, along);
                            this.add(d[1], across);
                            rthis.terms.push((d[2], 1.0));
                        }
                        (LinkKind::Bending, true) => {
                            // The joint's axial displacement; the anchor's transverse one
                            // carried rigidly; plus the departures δv, δθ.
                            this.add_along(joint, along);
                            this.add_along(from, across);
                            this.add_turn(rfrom, lever);
                            this.add(d[1], across);
                            rthis.terms.extend_from_slice(&rfrom.terms);
                            rthis.terms.push((d[2], 1.0));
                        }
                        (LinkKind::Full, false) => {
                            this.add(d[0], V2::new(1.0, 0.0));
                            this.add(d[1], V2::new(0.0, 1.0));
                            rthis.terms.push((d[2], 1.0));
                        }
                        (LinkKind::Full, true) => {
                            // The anchor's rigid motion, plus the departures (δx, δy, δθ).
                            this.copy_from(from);
                            this.add_turn(rfrom, lever);
                            this.add(d[0], V2::new(1.0, 0.0));
                            this.add(d[1], V2::new(0.0, 1.0));
                            rthis.terms.extend_from_slice(&rfrom.terms);
                            rthis.terms.push((d[2], 1.0));
                        }
                    }
                    self.station[i][k] = this;
                    self.rot[i][k] = rthis;
                }
            }
            let stations = &self.station[i];
            let rots = &self.rot[i];
            let point = |out: &mut Lin, at: Attach| {
                out.copy_from(&stations[at.station]);
                if at.y != 0.0 {
                    out.add_turn(&rots[at.station], rot_sc(s, c, V2::new(0.0, at.y)));
                }
            };
            match lm.a {
                Some(a) => point(&mut self.a[i], a),
                None => self.a[i].clear(),
            }
            point(&mut self.next[i], lm.next);
            point(&mut self.c[i], lm.c);
            self.pin[i].copy_from(&stations[o]);
            if let Some(b) = lm.b {
                point(&mut self.b[i + 1], b);
            }
            if let Some(m) = lm.measure {
                point(&mut self.measure, m);
            }
        }
    }
}
