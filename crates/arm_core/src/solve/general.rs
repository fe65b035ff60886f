//! The general path: one pose at a time, in a [`Workspace`] of scratch space, with libm
//! trigonometry and user-written deformations (docs/architecture.md). Below the batch
//! types, the block kernel and the batch drivers, which all use it.

use crate::arm::{Arm, Drive};
use crate::effects::{Deformation, EffectContext, EffectSet, ExtraDeformations, SequenceMemory};
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
    /// Loaded pin-to-pin lengths (mm); NaN at rotary drives.
    pub new_length: Vec<f64>,
    /// Change Δq_i of each rotary drive's relative angle (rad): the gear's yield, backlash and
    /// user-written turns; 0 at linear actuators.
    pub drive_turn: Vec<f64>,
    /// Loaded angles (rad).
    pub new_alpha: Vec<f64>,
    /// Body length changes seen by the actuator sensors (mm); NaN at rotary drives (no
    /// `dlK_mm` channel).
    pub body_dl: Vec<f64>,
    /// Displacement of the measurement point (mm).
    pub dmeasure: V2,
    /// Load change of each drive's own spring (N, N·mm at a rotary drive): `delta.f` unless
    /// an actuator or drive friction holds part of it.
    pub body_force: Vec<f64>,
    /// Friction couple on link i at O_i (N·mm, counter-clockwise +).
    pub couple: Vec<f64>,
    /// The friction memory of a single loading (reset before each [`Self::solve_extra`]).
    memory: SequenceMemory,
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
            drive_turn: vec![0.0; n],
            new_alpha: vec![0.0; n],
            body_dl: vec![0.0; n],
            dmeasure: V2::zeros(),
            body_force: vec![0.0; n],
            couple: vec![0.0; n],
            memory: SequenceMemory::new(n),
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
        // A single loading is a sequence of one state from the reference.
        let mut memory = std::mem::take(&mut self.memory);
        memory.reset();
        let r = self.solve_state(arm, effects, alpha, payload, opts, row, extra, &mut memory);
        self.memory = memory;
        r
    }

    /// One state of a load sequence: [`Self::solve_extra`] with the frictions' `memory` of the
    /// states before it (fresh at the reference), which it advances to this state. Forces and
    /// outputs are relative to the sequence's reference (self-weight only).
    ///
    /// # Errors
    /// Singular poses and triangles that cannot close, naming `row`.
    #[allow(clippy::too_many_arguments)]
    pub fn solve_state(
        &mut self,
        arm: &Arm,
        effects: &EffectSet,
        alpha: &[f64],
        payload: V2,
        opts: SolveOptions,
        row: usize,
        extra: (&ExtraDeformations<'_>, usize),
        memory: &mut SequenceMemory,
    ) -> Result<()> {
        self.prepare(arm, alpha, opts, row)?;
        self.solve_prepared(arm, effects, payload, row, extra, memory)
    }

    /// The reference of a pose (angles in rad): its geometry, actuator lines and the forces
    /// of the unloaded state, shared by every state of a sequence.
    ///
    /// # Errors
    /// Singular poses, naming `row`.
    pub(crate) fn prepare(
        &mut self,
        arm: &Arm,
        alpha: &[f64],
        opts: SolveOptions,
        row: usize,
    ) -> Result<()> {
        self.frames.fill(arm, alpha);
        self.lines.fill(arm, &self.frames, row)?;
        solve_forces(
            arm,
            &self.frames,
            &self.lines,
            opts.self_weight,
            V2::zeros(),
            &mut self.weight,
        );
        Ok(())
    }

    /// One state of the pose [`Self::prepare`]d last (see [`Self::solve_state`]).
    ///
    /// # Errors
    /// Triangles that cannot close, naming `row`.
    pub(crate) fn solve_prepared(
        &mut self,
        arm: &Arm,
        effects: &EffectSet,
        payload: V2,
        row: usize,
        extra: (&ExtraDeformations<'_>, usize),
        memory: &mut SequenceMemory,
    ) -> Result<()> {
        solve_forces(
            arm,
            &self.frames,
            &self.lines,
            false,
            payload,
            &mut self.delta,
        );
        memory.step(
            effects,
            &self.lines,
            &mut self.delta,
            &mut self.body_force,
            &mut self.couple,
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
            couple: &self.couple,
        };
        effects.apply(&ctx, &mut self.def);
        if !extra.0.is_none() {
            extra.0.add_to(extra.1, &mut self.def);
        }
        for i in 0..arm.n() {
            // The drive's own spring yields with what it takes: an actuator body's length (its
            // sensor sees it), a gear's turn.
            let spring = -self.body_force[i] * self.def.body_compliance[i];
            match arm.drives[i] {
                Drive::Linear(_) => {
                    let body = spring + self.def.seen_length[i];
                    self.body_dl[i] = body;
                    self.new_length[i] = self.lines.length[i] + body + self.def.extra_length[i];
                    self.drive_turn[i] = 0.0;
                }
                Drive::Rotary(_) => {
                    self.body_dl[i] = f64::NAN;
                    self.new_length[i] = f64::NAN;
                    self.drive_turn[i] = spring + self.def.turn[i];
                }
            }
        }
        let m = close_pose(
            arm,
            &self.frames,
            &self.def,
            &self.new_length,
            &self.drive_turn,
            row,
            &mut self.new_alpha,
        )?;
        self.dmeasure = m + self.def.measure_shift - self.frames.measure;
        Ok(())
    }
}
