//! The general path: one pose at a time, in a [`Workspace`] of scratch space, with libm
//! trigonometry and user-written deformations (docs/architecture.md). Below the batch
//! types, the block kernel and the batch drivers, which all use it.

use crate::arm::Arm;
use crate::effects::{Deformation, EffectContext, EffectSet, ExtraDeformations};
use crate::error::Result;
use crate::geometry::V2;
use crate::kinematics::Frames;
use crate::pose::close_pose;
use crate::statics::{solve_forces, ActuatorLines, Forces};

/// Options of a solve.
#[derive(Debug, Clone, Copy)]
pub struct SolveOptions {
    /// Include link and actuator weights in both states (the seed's Table 5 did not).
    pub self_weight: bool,
    /// Fill a pose that cannot be solved (singular, or a triangle that cannot close) with
    /// NaN instead of failing the batch: a sweep's workspace mask.
    pub nan_on_failure: bool,
}

impl Default for SolveOptions {
    fn default() -> Self {
        Self {
            self_weight: true,
            nan_on_failure: false,
        }
    }
}

/// Per-thread scratch space for one pose at a time.
#[derive(Debug, Clone)]
pub struct Workspace {
    /// Undeformed geometry.
    pub frames: Frames,
    /// Actuator lines of the undeformed pose.
    pub lines: ActuatorLines,
    /// Forces of the self-weight case.
    pub weight: Forces,
    /// Forces of the payload case = the change from unloaded to loaded.
    pub delta: Forces,
    /// Forces of the loaded state.
    pub loaded: Forces,
    /// Deformation causes.
    pub def: Deformation,
    /// Loaded pin-to-pin lengths (mm).
    pub new_length: Vec<f64>,
    /// Loaded angles (rad).
    pub new_alpha: Vec<f64>,
    /// Body length changes seen by the actuator sensors (mm).
    pub body_dl: Vec<f64>,
    /// Displacement of the measurement point (mm).
    pub dmeasure: V2,
}

impl Workspace {
    /// Scratch space for `arm`.
    pub fn new(arm: &Arm) -> Self {
        let n = arm.n();
        Self {
            frames: Frames::new(n),
            lines: ActuatorLines::new(n),
            weight: Forces::new(n),
            delta: Forces::new(n),
            loaded: Forces::new(n),
            def: Deformation::new(arm),
            new_length: vec![0.0; n],
            new_alpha: vec![0.0; n],
            body_dl: vec![0.0; n],
            dmeasure: V2::zeros(),
        }
    }

    /// Solves one pose (angles in rad, payload force in N at the load point).
    ///
    /// # Errors
    /// Singular poses and triangles that cannot close, naming `row`.
    pub fn solve(
        &mut self,
        arm: &Arm,
        effects: &EffectSet,
        alpha: &[f64],
        payload: V2,
        opts: SolveOptions,
        row: usize,
    ) -> Result<()> {
        self.solve_extra(
            arm,
            effects,
            alpha,
            payload,
            opts,
            row,
            (&ExtraDeformations::none(), 0),
        )
    }

    /// [`Self::solve`] with the extra deformations `extra.0` of its row `extra.1` added to the
    /// effects' (a checked batch, see [`ExtraDeformations::check`]).
    ///
    /// # Errors
    /// Singular poses and triangles that cannot close, naming `row`.
    #[allow(clippy::too_many_arguments)]
    pub fn solve_extra(
        &mut self,
        arm: &Arm,
        effects: &EffectSet,
        alpha: &[f64],
        payload: V2,
        opts: SolveOptions,
        row: usize,
        extra: (&ExtraDeformations<'_>, usize),
    ) -> Result<()> {
        self.frames.fill(arm, alpha);
        self.lines.fill(&self.frames, row)?;
        solve_forces(
            arm,
            &self.frames,
            &self.lines,
            opts.self_weight,
            V2::zeros(),
            &mut self.weight,
        );
        solve_forces(
            arm,
            &self.frames,
            &self.lines,
            false,
            payload,
            &mut self.delta,
        );
        self.loaded.set_sum(&self.weight, &self.delta);
        let ctx = EffectContext {
            arm,
            frames: &self.frames,
            lines: &self.lines,
            unloaded: &self.weight,
            loaded: &self.loaded,
            delta: &self.delta,
            payload,
        };
        effects.apply(&ctx, &mut self.def);
        if !extra.0.is_none() {
            extra.0.add_to(extra.1, &mut self.def);
        }
        for i in 0..arm.n() {
            let body = -self.delta.f[i] * self.def.body_compliance[i] + self.def.seen_length[i];
            self.body_dl[i] = body;
            self.new_length[i] = self.lines.length[i] + body + self.def.extra_length[i];
        }
        let m = close_pose(
            arm,
            &self.frames,
            &self.def,
            &self.new_length,
            row,
            &mut self.new_alpha,
        )?;
        self.dmeasure = m + self.def.measure_shift - self.frames.measure;
        Ok(())
    }
}
