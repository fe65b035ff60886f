//! One pose through the FE model: geometry, maps, assembly, factorisation, the two load
//! cases, the gap iteration and every output. All buffers live here and are reused, so after
//! the first pose a solve allocates nothing (unless the solver redoes its symbolic analysis
//! every pose, `LinearSolver::SparseFresh`).

use crate::error::{ArmError, Result};
use crate::geometry::V2;
use crate::kinematics::Frames;

use super::assemble::{Assembly, Kind, Prescribed};
use super::element::section_moment as element_moment;
use super::forces::{link_forces, pin_forces, section_moment, Applied, PointForce};
use super::gap::{GapState, MAX_ITERATIONS};
use super::maps::Maps;

use super::mechanism;
use super::solve::Numeric;
use super::FemModel;

/// Scratch space and results of one pose.
#[derive(Debug)]
pub struct FemWorkspace {
    /// Undeformed geometry.
    pub frames: Frames,
    /// Actuator unit vectors e_i (B_{i−1} → A_i; zero at a rotary drive).
    pub e: Vec<V2>,
    /// Unloaded pin-to-pin lengths (mm; NaN at a rotary drive).
    pub length: Vec<f64>,
    /// Kinematic maps (offsets: the final gap state).
    pub maps: Maps,
    /// Upper triangle of K in the model's pattern.
    pub values: Vec<f64>,
    t: Vec<f64>,
    scratch: Vec<f64>,
    num: Numeric,
    rhs: Vec<f64>,
    gap_rhs: Vec<f64>,
    /// Displacements of the self-weight case.
    pub u_weight: Vec<f64>,
    /// Displacements of the payload case.
    pub u_payload: Vec<f64>,
    /// Displacements added by the closed gaps.
    pub u_gap: Vec<f64>,
    /// Loaded minus unloaded: `u_payload + u_gap` (with the maps' offsets).
    pub u_inc: Vec<f64>,
    u_loaded: Vec<f64>,
    /// Contact state of the gaps.
    pub gaps: GapState,
    f_weight: Vec<f64>,
    f_payload: Vec<f64>,
    f_gap: Vec<f64>,
    r_weight: Vec<V2>,
    /// Loaded drive loads: actuator forces (N, compression +), drive torques (N·mm,
    /// counter-clockwise + on link i).
    pub force: Vec<f64>,
    /// Their changes unloaded → loaded (N, N·mm).
    pub dforce: Vec<f64>,
    /// Loaded pin forces R_i (body i−1 on link i, N).
    pub reaction: Vec<V2>,
    /// Displacement of the measure point (mm).
    pub dmeasure: V2,
    /// Change of each link's angle (rad): of its chord (linear actuator), of its flange frame
    /// (rotary drive).
    pub dalpha: Vec<f64>,
    /// Actuator body length change seen by its sensor (mm; NaN at a rotary drive).
    pub body_dl: Vec<f64>,
    /// Pin-to-pin length change (mm; NaN at a rotary drive).
    pub dlength: Vec<f64>,
    /// Loaded bending moment at the model's sample abscissae (N·mm), link by link.
    pub moment: Vec<f64>,
    /// Its change unloaded → loaded (N·mm).
    pub dmoment: Vec<f64>,
    /// Undeformed positions of the shape's nodes (mm).
    pub node_xy: Vec<V2>,
    /// Displacements of the shape's nodes, loaded minus unloaded (mm).
    pub node_disp: Vec<V2>,
    /// Per element: local end forces of the loaded state and of the change (moments).
    end_forces: Vec<([f64; 6], [f64; 6])>,
    /// Active-set iterations of the last solve (0 without gaps).
    pub iterations: usize,
}

impl FemWorkspace {
    /// Buffers for `model`.
    pub fn new(model: &FemModel) -> Self {
        let n = model.arm.n();
        let nd = model.mesh.n_dof;
        let k = model.options.moment_samples;
        let nodes = model.shape.nodes.len();
        Self {
            frames: Frames::new(n),
            e: vec![V2::zeros(); n],
            length: vec![0.0; n],
            maps: Maps::new(&model.mesh),
            values: vec![0.0; model.asm.nnz()],
            t: vec![0.0; model.asm.t_len],
            scratch: vec![0.0; 6 * model.asm.max_dofs],
            num: Numeric::new(&model.asm, &model.symbolic, model.options.solver, 2),
            rhs: vec![0.0; 2 * nd],
            gap_rhs: vec![0.0; nd],
            u_weight: vec![0.0; nd],
            u_payload: vec![0.0; nd],
            u_gap: vec![0.0; nd],
            u_inc: vec![0.0; nd],
            u_loaded: vec![0.0; nd],
            gaps: GapState::new(n),
            f_weight: vec![0.0; n],
            f_payload: vec![0.0; n],
            f_gap: vec![0.0; n],
            r_weight: vec![V2::zeros(); n],
            force: vec![0.0; n],
            dforce: vec![0.0; n],
            reaction: vec![V2::zeros(); n],
            dmeasure: V2::zeros(),
            dalpha: vec![0.0; n],
            body_dl: vec![0.0; n],
            dlength: vec![0.0; n],
            moment: vec![0.0; n * k],
            dmoment: vec![0.0; n * k],
            node_xy: vec![V2::zeros(); nodes],
            node_disp: vec![V2::zeros(); nodes],
            end_forces: vec![([0.0; 6], [0.0; 6]); model.asm.elements.len()],
            iterations: 0,
        }
    }

    /// Geometry, maps (gaps centred) and the stiffness values of a pose (angles in rad).
    ///
    /// # Errors
    /// [`ArmError::ZeroLength`] when an actuator's pins coincide.
    pub fn assemble(&mut self, model: &FemModel, alpha: &[f64], row: usize) -> Result<()> {
        let arm = &model.arm;
        self.frames.fill(arm, alpha);
        for i in 0..arm.n() {
            if arm.is_rotary(i) {
                self.e[i] = V2::zeros();
                self.length[i] = f64::NAN;
                continue;
            }
            let v = self.frames.a[i] - self.frames.b[i];
            let l = v.norm();
            let scale = 1.0 + (self.frames.a[i] - self.frames.joint[i]).norm();
            if l.is_nan() || l <= 1e-12 * scale {
                return Err(ArmError::ZeroLength {
                    row,
                    actuator: i + 1,
                });
            }
            self.e[i] = v / l;
            self.length[i] = l;
        }
        self.gaps.reset();
        self.maps
            .fill(arm, &model.mesh, &self.frames, &self.gaps.offset);
        model
            .asm
            .fill_t(&self.maps, &model.mesh, &self.frames, &self.e, &mut self.t);
        model
            .asm
            .stiffness(&self.t, &mut self.values, &mut self.scratch);
        Ok(())
    }

    /// Solves one pose: angles in rad, payload force at the load point (N).
    ///
    /// # Errors
    /// [`ArmError::ZeroLength`], [`ArmError::Mechanism`] or [`ArmError::Unsupported`] when K
    /// is singular (naming what moves), [`ArmError::NoConvergence`] when the gaps do not
    /// settle; all naming `row`.
    pub fn solve(
        &mut self,
        model: &FemModel,
        alpha: &[f64],
        payload: V2,
        self_weight: bool,
        row: usize,
    ) -> Result<()> {
        let arm = &model.arm;
        let n = arm.n();
        let nd = model.mesh.n_dof;
        self.assemble(model, alpha, row)?;
        if let Err(at) = self
            .num
            .factorize(&model.asm, &model.symbolic, &self.values)
        {
            return Err(mechanism::describe(
                arm,
                &model.mesh,
                &model.asm,
                &self.maps,
                &self.frames,
                &self.values,
                at,
                row,
            ));
        }
        // The two load cases in one solve: self-weight | payload.
        self.rhs.fill(0.0);
        {
            let (fw, fp) = self.rhs.split_at_mut(nd);
            if self_weight {
                let g = arm.g;
                let w = |m: f64| V2::new(0.0, -m * g);
                for i in 0..n {
                    self.maps.c[i].load(w(arm.links[i].mass_kg), fw);
                    if arm.is_rotary(i) {
                        // The whole drive at O_i on body i−1 (the chassis takes drive 1).
                        if i > 0 {
                            self.maps.next[i - 1].load(w(arm.drives[i].mass_kg()), fw);
                        }
                        continue;
                    }
                    let half = w(0.5 * arm.drives[i].mass_kg());
                    self.maps.a[i].load(half, fw);
                    if i > 0 {
                        self.maps.b[i].load(half, fw);
                    }
                }
            }
            self.maps.next[n - 1].load(payload, fp);
        }
        self.num.solve(&model.symbolic, &mut self.rhs, 2);
        self.u_weight.copy_from_slice(&self.rhs[..nd]);
        self.u_payload.copy_from_slice(&self.rhs[nd..]);
        self.u_gap.fill(0.0);
        bar_forces(model, &self.t, &self.u_weight, None, &mut self.f_weight);
        bar_forces(model, &self.t, &self.u_payload, None, &mut self.f_payload);
        self.f_gap.fill(0.0);
        let loaded = Applied {
            weights: self_weight,
            payload,
        };
        self.iterations = 0;
        if model.spec.has_gaps() {
            loop {
                for i in 0..n {
                    self.force[i] = self.f_weight[i] + self.f_payload[i] + self.f_gap[i];
                }
                pin_forces(arm, &self.e, &self.force, loaded, &mut self.reaction);
                let changed = self.gaps.update(&model.spec, &self.force, &self.reaction);
                if !changed && self.iterations > 0 {
                    break;
                }
                if self.iterations >= MAX_ITERATIONS {
                    return Err(ArmError::NoConvergence {
                        row,
                        what: format!(
                            "the FE gap elements did not settle in {MAX_ITERATIONS} iterations"
                        ),
                    });
                }
                self.iterations += 1;
                self.maps
                    .fill(arm, &model.mesh, &self.frames, &self.gaps.offset);
                self.gap_rhs.fill(0.0);
                model.asm.offset_loads(
                    &self.t,
                    &self.maps,
                    &self.frames,
                    &self.e,
                    &self.gaps.play_dl,
                    &mut self.gap_rhs,
                );
                self.num.solve(&model.symbolic, &mut self.gap_rhs, 1);
                self.u_gap.copy_from_slice(&self.gap_rhs);
                let pre = Prescribed {
                    maps: &self.maps,
                    frames: &self.frames,
                    lines_e: &self.e,
                    play_dl: &self.gaps.play_dl,
                };
                bar_forces(model, &self.t, &self.u_gap, Some(pre), &mut self.f_gap);
            }
        }
        self.outputs(model, payload, self_weight);
        Ok(())
    }

    fn outputs(&mut self, model: &FemModel, payload: V2, self_weight: bool) {
        let arm = &model.arm;
        let n = arm.n();
        for i in 0..n {
            self.force[i] = self.f_weight[i] + self.f_payload[i] + self.f_gap[i];
            self.dforce[i] = self.force[i] - self.f_weight[i];
        }
        let loaded = Applied {
            weights: self_weight,
            payload,
        };
        let unloaded = Applied {
            weights: self_weight,
            payload: V2::zeros(),
        };
        pin_forces(arm, &self.e, &self.force, loaded, &mut self.reaction);
        pin_forces(arm, &self.e, &self.f_weight, unloaded, &mut self.r_weight);
        for ((inc, p), g) in self.u_inc.iter_mut().zip(&self.u_payload).zip(&self.u_gap) {
            *inc = p + g;
        }
        for ((l, w), inc) in self
            .u_loaded
            .iter_mut()
            .zip(&self.u_weight)
            .zip(&self.u_inc)
        {
            *l = w + inc;
        }
        let maps = &self.maps;
        let u = &self.u_inc;
        self.dmeasure = maps.measure.eval(u);
        for i in 0..n {
            let lm = &model.mesh.links[i];
            self.dalpha[i] = if lm.rotary || !lm.kind.bends() {
                // A rigid link's turn, or the flange frame's of a link clamped to its drive.
                u[lm.theta_origin()]
            } else {
                // The chord through the joint and the axis point under A (docs/model.md §4).
                let (s, c) = (self.frames.sin[i], self.frames.cos[i]);
                let v = |t: V2| -s * t.x + c * t.y;
                let vo = v(maps.station[i][lm.origin].eval(u));
                let a = lm.a.map_or(lm.origin, |a| a.station);
                let va = v(maps.station[i][a].eval(u));
                (va - vo) / lm.xa
            };
            if lm.rotary {
                self.body_dl[i] = f64::NAN;
                self.dlength[i] = f64::NAN;
                continue;
            }
            let k = model.spec.body_stiffness[i];
            self.body_dl[i] = if k.is_infinite() {
                0.0
            } else {
                -self.dforce[i] / k
            };
            self.dlength[i] = self.e[i].dot(&(maps.a[i].eval(u) - maps.b[i].eval(u)));
        }
        self.moments(model, payload, self_weight);
        model
            .shape
            .positions(arm, &model.mesh, &self.frames, &mut self.node_xy);
        model
            .shape
            .displacements(&self.maps, &self.u_inc, &mut self.node_disp);
    }

    fn moments(&mut self, model: &FemModel, payload: V2, self_weight: bool) {
        let arm = &model.arm;
        let k = model.options.moment_samples;
        let loaded = Applied {
            weights: self_weight,
            payload,
        };
        let unloaded = Applied {
            weights: self_weight,
            payload: V2::zeros(),
        };
        let mut pf_l = [PointForce::default(); 5];
        let mut pf_w = [PointForce::default(); 5];
        // The gaps' prescribed parts (none without gaps: skip computing zeros).
        let pre = model.spec.has_gaps().then_some(Prescribed {
            maps: &self.maps,
            frames: &self.frames,
            lines_e: &self.e,
            play_dl: &self.gaps.play_dl,
        });
        for (i, lm) in model.mesh.links.iter().enumerate() {
            let xs = &model.moment_x[i * k..(i + 1) * k];
            let out_l = &mut self.moment[i * k..(i + 1) * k];
            let out_d = &mut self.dmoment[i * k..(i + 1) * k];
            if !lm.kind.bends() {
                // No bending elements: the section method on the link's free body.
                link_forces(
                    arm,
                    i,
                    &self.e,
                    &self.force,
                    &self.reaction,
                    loaded,
                    &mut pf_l,
                );
                link_forces(
                    arm,
                    i,
                    &self.e,
                    &self.f_weight,
                    &self.r_weight,
                    unloaded,
                    &mut pf_w,
                );
                for ((x, ml), md) in xs.iter().zip(out_l.iter_mut()).zip(out_d.iter_mut()) {
                    *ml = section_moment(&self.frames, i, &pf_l, *x);
                    *md = *ml - section_moment(&self.frames, i, &pf_w, *x);
                }
                continue;
            }
            // Each element's end forces once, then every sample inside it.
            let first = model.beam_start[i];
            let count = lm.x.len() - 1;
            for e in first..first + count {
                let el = &model.asm.elements[e];
                let mut w = [0.0; 6];
                model
                    .asm
                    .local_displacement(el, &self.t, &self.u_loaded, pre, &mut w);
                let fl = Assembly::end_forces(el, &w);
                model
                    .asm
                    .local_displacement(el, &self.t, &self.u_inc, pre, &mut w);
                self.end_forces[e] = (fl, Assembly::end_forces(el, &w));
            }
            for ((x, ml), md) in xs.iter().zip(out_l.iter_mut()).zip(out_d.iter_mut()) {
                // The element [x_k, x_{k+1}) holding x (the last one holds its right end).
                let kk = lm.x.partition_point(|&s| s <= *x).clamp(1, count) - 1;
                let Kind::Beam { h, .. } = model.asm.elements[first + kk].kind else {
                    continue;
                };
                let xi = x - lm.x[kk];
                let (fl, fd) = &self.end_forces[first + kk];
                *ml = element_moment(fl, h, xi);
                *md = element_moment(fd, h, xi);
            }
        }
    }

    /// The assembled stiffness as a dense symmetric n×n matrix, row-major (tests, checks).
    pub fn stiffness_dense(&self, model: &FemModel) -> Vec<f64> {
        let n = model.mesh.n_dof;
        let asm = &model.asm;
        let mut k = vec![0.0; n * n];
        for j in 0..n {
            for p in asm.col_ptr[j]..asm.col_ptr[j + 1] {
                let i = asm.row_idx[p];
                k[i * n + j] = self.values[p];
                k[j * n + i] = self.values[p];
            }
        }
        k
    }
}

/// Drive loads for displacements `u`, with the prescribed gap parts when given: the bars'
/// forces (compression +) and the torsional springs' torques on link i (counter-clockwise +),
/// both `−k·(T·u + w₀)`.
fn bar_forces(
    model: &FemModel,
    t: &[f64],
    u: &[f64],
    pre: Option<Prescribed<'_>>,
    out: &mut [f64],
) {
    for e in &model.asm.elements[model.bar_start..] {
        if let Kind::Bar { act: i, k } | Kind::Spring { joint: i, k } = e.kind {
            let mut w = [0.0; 6];
            model.asm.local_displacement(e, t, u, pre, &mut w);
            out[i] = -k * w[0];
        }
    }
}
