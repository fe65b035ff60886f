//! Sparse assembly: the pattern once per model, the values once per pose.
//!
//! Each element's stiffness in global DOFs is `K_e = Tᵀ·k·T`, where T maps the DOFs it
//! touches to its local end displacements through the kinematic maps (rotation into the link
//! frame, rigid offsets, joints). The upper triangle of K is stored column by column (CSC, as
//! faer's Cholesky reads it). Where each entry of each K_e lands in the value array is found
//! once, when the model is built; a pose only refills values.

use crate::arm::Arm;
use crate::geometry::V2;
use crate::kinematics::Frames;

use super::element::beam_stiffness;
use super::maps::{Lin, Maps, Rot};
use super::mesh::{LinkKind, LinkMesh, Mesh, NONE};
use super::spec::FemSpec;

/// What an element is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// A beam element of link `link` between stations `s1 < s2`, of length `h` (mm).
    Beam {
        /// 0-based link.
        link: usize,
        /// First station.
        s1: usize,
        /// Second station.
        s2: usize,
        /// Length (mm).
        h: f64,
        /// Both ends in one cluster (an anchor and its relative stations): the element is
        /// strained by the relative stations' departures alone, and T holds only those.
        intra: bool,
    },
    /// Actuator `act`'s bar, of axial stiffness `k` (N/mm).
    Bar {
        /// 0-based actuator.
        act: usize,
        /// Axial stiffness (N/mm).
        k: f64,
    },
    /// The torsional spring of the rotary drive at joint `joint`, of stiffness `k` (N·mm/rad),
    /// between link i's rotation at its joint (the flange) and body i−1's there (the housing).
    Spring {
        /// 0-based joint.
        joint: usize,
        /// Torsional stiffness (N·mm/rad).
        k: f64,
    },
}

/// One element: its kind, its local stiffness and where it goes in K.
#[derive(Debug, Clone)]
pub struct Element {
    /// Beam, bar or torsional spring.
    pub kind: Kind,
    /// Local stiffness, row-major (`rows × rows`).
    pub k: Vec<f64>,
    /// Local DOFs: 6 for a beam, 1 for a bar or a spring.
    pub rows: usize,
    /// The global DOFs it touches (in a fixed order).
    pub dofs: Vec<usize>,
    /// For each (p, q) of `dofs × dofs`: the index of K's stored entry, or [`NONE`] for the
    /// lower triangle.
    pub pos: Vec<usize>,
    /// Start of this element's T (`rows × dofs.len()`, row-major) in the per-pose buffer.
    pub t_at: usize,
}

/// The assembly tables of a model.
#[derive(Debug, Clone)]
pub struct Assembly {
    /// Every element: beams link by link, then one per drive (a bar or a torsional spring).
    pub elements: Vec<Element>,
    /// Stored position of the base spring's diagonal entry.
    pub base_pos: Option<usize>,
    /// Base spring (N·mm/rad).
    pub base_k: f64,
    /// CSC column pointers of the upper triangle.
    pub col_ptr: Vec<usize>,
    /// CSC row indices (sorted within each column).
    pub row_idx: Vec<usize>,
    /// Stored position of each diagonal entry.
    pub diag_pos: Vec<usize>,
    /// Total length of the per-pose T buffer.
    pub t_len: usize,
    /// Largest number of DOFs of one element.
    pub max_dofs: usize,
    /// The penalty stiffness of a rigid actuator (N/mm; see `spec::PENALTY`); a rigid
    /// rotary drive's is this times the arm's reach squared (N·mm/rad).
    pub rigid_k: f64,
}

impl Assembly {
    /// Builds the element list and the sparsity pattern of `mesh`. `maps` must have been
    /// filled once (any pose): only their DOF sets are read.
    pub fn new(arm: &Arm, mesh: &Mesh, spec: &FemSpec, maps: &Maps) -> Self {
        let extent: Vec<f64> = mesh.links.iter().map(|l| l.extent()).collect();
        let rigid_k = super::spec::PENALTY * spec.stiffness_scale(&extent);
        let mut elements = Vec::new();
        let mut t_len = 0;
        for (i, lm) in mesh.links.iter().enumerate() {
            // A rigid direction is a constraint of the maps: its stiffness term sees no strain.
            let sec = spec.sections[i];
            let ei = sec.ei.unwrap_or(0.0);
            let ea = sec.ea.unwrap_or(0.0);
            for (s1, s2) in lm.elements() {
                let h = lm.x[s2] - lm.x[s1];
                let intra = same_cluster(lm, s1, s2);
                let mut dofs = Vec::new();
                if intra {
                    // Only the departures: the anchor's rigid motion strains nothing, and
                    // would leave round-off times a huge stiffness if it stayed in T.
                    for st in [s1, s2] {
                        if lm.anchor[st].is_some() {
                            for &d in &lm.dof[st] {
                                push_dof(&mut dofs, d);
                            }
                        }
                    }
                } else {
                    push_lin(&mut dofs, &maps.station[i][s1]);
                    push_rot(&mut dofs, &maps.rot[i][s1]);
                    push_lin(&mut dofs, &maps.station[i][s2]);
                    push_rot(&mut dofs, &maps.rot[i][s2]);
                }
                let m = dofs.len();
                elements.push(Element {
                    kind: Kind::Beam {
                        link: i,
                        s1,
                        s2,
                        h,
                        intra,
                    },
                    k: beam_stiffness(ei, ea, h).to_vec(),
                    rows: 6,
                    dofs,
                    pos: Vec::new(),
                    t_at: t_len,
                });
                t_len += 6 * m;
            }
        }
        let reach: f64 = extent.iter().sum();
        for i in 0..arm.n() {
            let mut dofs = Vec::new();
            let (kind, k) = if spec.rotary[i] {
                push_rot(&mut dofs, &maps.rot[i][mesh.links[i].origin]);
                push_rot(&mut dofs, &maps.housing[i]);
                let k = spec.bar_stiffness(i, rigid_k * reach * reach);
                (Kind::Spring { joint: i, k }, k)
            } else {
                push_lin(&mut dofs, &maps.a[i]);
                push_lin(&mut dofs, &maps.b[i]);
                let k = spec.bar_stiffness(i, rigid_k);
                (Kind::Bar { act: i, k }, k)
            };
            let m = dofs.len();
            elements.push(Element {
                kind,
                k: vec![k],
                rows: 1,
                dofs,
                pos: Vec::new(),
                t_at: t_len,
            });
            t_len += m;
        }
        // Pattern: every pair an element couples, every diagonal.
        let n = mesh.n_dof;
        let mut cols: Vec<Vec<usize>> = (0..n).map(|j| vec![j]).collect();
        for e in &elements {
            for &p in &e.dofs {
                for &q in &e.dofs {
                    if p <= q {
                        cols[q].push(p);
                    }
                }
            }
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for c in &mut cols {
            c.sort_unstable();
            c.dedup();
            row_idx.extend_from_slice(c);
            col_ptr.push(row_idx.len());
        }
        let at = |r: usize, c: usize| -> usize {
            let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
            match rows.binary_search(&r) {
                Ok(k) => col_ptr[c] + k,
                Err(_) => NONE, // unreachable: every coupled pair was inserted above
            }
        };
        let mut max_dofs = 0;
        for e in &mut elements {
            let m = e.dofs.len();
            max_dofs = max_dofs.max(m);
            e.pos = (0..m * m)
                .map(|pq| {
                    let (p, q) = (e.dofs[pq / m], e.dofs[pq % m]);
                    if p <= q {
                        at(p, q)
                    } else {
                        NONE
                    }
                })
                .collect();
        }
        let diag_pos = (0..n).map(|j| at(j, j)).collect();
        let base_pos = mesh.base_dof.map(|d| at(d, d));
        Self {
            elements,
            base_pos,
            base_k: spec.base_stiffness.unwrap_or(0.0),
            col_ptr,
            row_idx,
            diag_pos,
            t_len,
            max_dofs,
            rigid_k,
        }
    }

    /// Number of stored entries of the upper triangle.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Fills every element's T for the pose (`t` has `t_len` entries).
    pub fn fill_t(&self, maps: &Maps, mesh: &Mesh, fr: &Frames, lines_e: &[V2], t: &mut [f64]) {
        for e in &self.elements {
            let m = e.dofs.len();
            let te = &mut t[e.t_at..e.t_at + e.rows * m];
            te.fill(0.0);
            match e.kind {
                Kind::Beam {
                    link,
                    s1,
                    s2,
                    intra: true,
                    ..
                } => {
                    // The departures of the relative ends, in the link frame; an anchor end
                    // contributes nothing.
                    let (s, c) = (fr.sin[link], fr.cos[link]);
                    let lm = &mesh.links[link];
                    for (end, st) in [(0, s1), (3, s2)] {
                        if lm.anchor[st].is_none() {
                            continue;
                        }
                        let d = lm.dof[st];
                        let mut put = |row: usize, dof: usize, v: f64| {
                            if dof != NONE {
                                te[(end + row) * m + col_of(&e.dofs, dof)] += v;
                            }
                        };
                        match lm.kind {
                            LinkKind::Full => {
                                put(0, d[0], c);
                                put(1, d[0], -s);
                                put(0, d[1], s);
                                put(1, d[1], c);
                                put(2, d[2], 1.0);
                            }
                            LinkKind::Bending => {
                                put(1, d[1], 1.0);
                                put(2, d[2], 1.0);
                            }
                            LinkKind::Axial => put(0, d[0], 1.0),
                            LinkKind::Rigid => {}
                        }
                    }
                }
                Kind::Beam { link, s1, s2, .. } => {
                    let (s, c) = (fr.sin[link], fr.cos[link]);
                    for (end, st) in [(0, s1), (3, s2)] {
                        for &(d, g) in &maps.station[link][st].terms {
                            let col = col_of(&e.dofs, d);
                            te[end * m + col] += c * g.x + s * g.y;
                            te[(end + 1) * m + col] += -s * g.x + c * g.y;
                        }
                        for &(d, g) in &maps.rot[link][st].terms {
                            te[(end + 2) * m + col_of(&e.dofs, d)] += g;
                        }
                    }
                }
                Kind::Bar { act, .. } => {
                    let u = lines_e[act];
                    for &(d, g) in &maps.a[act].terms {
                        te[col_of(&e.dofs, d)] += u.dot(&g);
                    }
                    for &(d, g) in &maps.b[act].terms {
                        te[col_of(&e.dofs, d)] -= u.dot(&g);
                    }
                }
                Kind::Spring { joint, .. } => {
                    // The flange's rotation minus the housing's.
                    let o = mesh.links[joint].origin;
                    for &(d, g) in &maps.rot[joint][o].terms {
                        te[col_of(&e.dofs, d)] += g;
                    }
                    for &(d, g) in &maps.housing[joint].terms {
                        te[col_of(&e.dofs, d)] -= g;
                    }
                }
            }
        }
    }

    /// Assembles the stored upper triangle of K into `values` from the per-pose T.
    /// `scratch` holds at least `6·max_dofs` values.
    ///
    /// T is mostly zeros (a beam end's two translations touch only that end's DOFs, its
    /// rotation one DOF), so both products skip its zero entries.
    pub fn stiffness(&self, t: &[f64], values: &mut [f64], scratch: &mut [f64]) {
        values.fill(0.0);
        for e in &self.elements {
            let m = e.dofs.len();
            let r = e.rows;
            let te = &t[e.t_at..e.t_at + r * m];
            // kt = k·T (r × m), accumulated over T's nonzeros.
            let kt = &mut scratch[..r * m];
            kt.fill(0.0);
            for j in 0..r {
                for q in 0..m {
                    let tjq = te[j * m + q];
                    if tjq != 0.0 {
                        for i in 0..r {
                            kt[i * m + q] += e.k[i * r + j] * tjq;
                        }
                    }
                }
            }
            // ke = Tᵀ·(k·T), upper triangle in global numbering, over T's nonzeros.
            for i in 0..r {
                let row = &te[i * m..(i + 1) * m];
                let ktr = &kt[i * m..(i + 1) * m];
                for (p, &tip) in row.iter().enumerate() {
                    if tip == 0.0 {
                        continue;
                    }
                    let pos = &e.pos[p * m..(p + 1) * m];
                    for (q, &at) in pos.iter().enumerate() {
                        if at != NONE {
                            values[at] += tip * ktr[q];
                        }
                    }
                }
            }
        }
        if let Some(p) = self.base_pos {
            values[p] += self.base_k;
        }
    }

    /// Local end displacements `w = T·u + w₀` of element `e` (w₀: its prescribed part from
    /// the gap offsets, when `offsets`), written into `w[..rows]`.
    pub fn local_displacement(
        &self,
        e: &Element,
        t: &[f64],
        u: &[f64],
        offsets: Option<Prescribed<'_>>,
        w: &mut [f64; 6],
    ) {
        let m = e.dofs.len();
        let te = &t[e.t_at..e.t_at + e.rows * m];
        for (i, wi) in w.iter_mut().enumerate().take(e.rows) {
            *wi = (0..m).map(|q| te[i * m + q] * u[e.dofs[q]]).sum();
        }
        if let Some(p) = offsets {
            let w0 = prescribed(e, p.maps, p.frames, p.lines_e, p.play_dl);
            for (wi, oi) in w.iter_mut().zip(w0).take(e.rows) {
                *wi += oi;
            }
        }
    }

    /// Local end forces `f = k·w` of element `e` (the forces its nodes apply to it).
    pub fn end_forces(e: &Element, w: &[f64; 6]) -> [f64; 6] {
        let r = e.rows;
        let mut f = [0.0; 6];
        for (i, fi) in f.iter_mut().enumerate().take(r) {
            *fi = (0..r).map(|j| e.k[i * r + j] * w[j]).sum();
        }
        f
    }

    /// Adds the equivalent loads of the prescribed gap offsets, `−Σ Tᵀ·k·w₀`, to `rhs`.
    pub fn offset_loads(
        &self,
        t: &[f64],
        maps: &Maps,
        fr: &Frames,
        lines_e: &[V2],
        play_dl: &[f64],
        rhs: &mut [f64],
    ) {
        for e in &self.elements {
            let w0 = prescribed(e, maps, fr, lines_e, play_dl);
            if w0.iter().all(|&v| v == 0.0) {
                continue;
            }
            let f0 = Self::end_forces(e, &w0);
            let m = e.dofs.len();
            let te = &t[e.t_at..e.t_at + e.rows * m];
            for q in 0..m {
                let g: f64 = (0..e.rows).map(|i| te[i * m + q] * f0[i]).sum();
                rhs[e.dofs[q]] -= g;
            }
        }
    }
}

/// What the prescribed (gap) part of the element displacements is made of.
#[derive(Debug, Clone, Copy)]
pub struct Prescribed<'a> {
    /// The maps, whose offsets are the clearance gaps.
    pub maps: &'a Maps,
    /// The pose.
    pub frames: &'a Frames,
    /// Actuator unit vectors.
    pub lines_e: &'a [V2],
    /// Prescribed change of each drive's coordinate from its lost motion: an actuator's
    /// pin-to-pin length from its play (mm), a rotary drive's turn from its backlash (rad).
    pub play_dl: &'a [f64],
}

/// The prescribed part of an element's local displacements: the gap offsets carried by its
/// end maps (clearance) and, for a bar or a drive's spring, minus its lost motion
/// `play_dl[i]` (the spring's elastic turn is the relative turn less the backlash's).
fn prescribed(e: &Element, maps: &Maps, fr: &Frames, lines_e: &[V2], play_dl: &[f64]) -> [f64; 6] {
    let mut w = [0.0; 6];
    match e.kind {
        // A cluster's offsets are one rigid translation: no strain.
        Kind::Beam { intra: true, .. } => {}
        Kind::Beam { link, s1, s2, .. } => {
            let (s, c) = (fr.sin[link], fr.cos[link]);
            for (end, st) in [(0, s1), (3, s2)] {
                let o = maps.station[link][st].off;
                w[end] = c * o.x + s * o.y;
                w[end + 1] = -s * o.x + c * o.y;
            }
        }
        Kind::Bar { act, .. } => {
            w[0] = lines_e[act].dot(&(maps.a[act].off - maps.b[act].off)) - play_dl[act];
        }
        Kind::Spring { joint, .. } => w[0] = -play_dl[joint],
    }
    w
}

/// Whether stations `a` and `b` of a link belong to one cluster (anchor and relatives).
fn same_cluster(lm: &LinkMesh, a: usize, b: usize) -> bool {
    let root = |k: usize| lm.anchor[k].unwrap_or(k);
    (lm.anchor[a].is_some() || lm.anchor[b].is_some()) && root(a) == root(b)
}

fn push_dof(dofs: &mut Vec<usize>, d: usize) {
    if d != NONE && !dofs.contains(&d) {
        dofs.push(d);
    }
}

fn push_rot(dofs: &mut Vec<usize>, rot: &Rot) {
    for &(d, _) in &rot.terms {
        push_dof(dofs, d);
    }
}

fn push_lin(dofs: &mut Vec<usize>, lin: &Lin) {
    for &(d, _) in &lin.terms {
        push_dof(dofs, d);
    }
}

/// Column of DOF `d` in an element's DOF list (always present by construction).
#[inline]
fn col_of(dofs: &[usize], d: usize) -> usize {
    dofs.iter().position(|&x| x == d).unwrap_or(0)
}
