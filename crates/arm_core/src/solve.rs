//! The batch solver: statics of both states, effects, exact loaded pose, for many poses.
//!
//! Poses are processed in chunks, in parallel with rayon above [`PARALLEL_THRESHOLD`] poses.
//! Arms of 1–6 links with the built-in effects go through the block kernel (`solve/fast.rs`: 16
//! poses at a time, structure of arrays); user-written deformations ([`ExtraDeformations`])
//! and longer arms go through the general path, one [`Workspace`] per chunk (nothing is
//! allocated per pose). Both give the status of every pose ([`solve_batch_status`]).

pub(crate) mod fast;
pub mod sequence;
mod status;

use rayon::prelude::*;

use crate::arm::Arm;
use crate::effects::{Deformation, EffectContext, EffectSet, ExtraDeformations, SequenceMemory};
use crate::error::{ArmError, Result};
use crate::geometry::V2;
use crate::kinematics::Frames;
use crate::pose::close_pose;
use crate::statics::{solve_forces, ActuatorLines, Forces};

/// Below this many poses the batch runs on the calling thread.
pub const PARALLEL_THRESHOLD: usize = 2048;
/// Poses per parallel work item.
pub const CHUNK: usize = 1024;
/// Below this many poses the block kernel runs on the calling thread (it is ~5× faster per
/// pose than the general path, so it pays to split smaller batches).
pub const KERNEL_PARALLEL_THRESHOLD: usize = 512;
/// Poses per parallel work item of the block kernel (64 blocks).
pub const KERNEL_CHUNK: usize = 1024;

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
    /// Force change of each actuator's body spring (N): `delta.f` unless an actuator
    /// friction holds part of it.
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
        self.lines.fill(&self.frames, row)?;
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
            let body = -self.body_force[i] * self.def.body_compliance[i] + self.def.seen_length[i];
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

/// Inputs of a batch: `N` poses of an `n`-link arm, row-major.
#[derive(Debug, Clone, Copy)]
pub struct BatchInput<'a> {
    /// Unloaded absolute angles (deg), `N × n`.
    pub alpha_deg: &'a [f64],
    /// Payload force at the load point (N, global), `N × 2`.
    pub payload_n: &'a [f64],
}

/// Outputs of a batch, row-major, to be filled in place.
#[derive(Debug)]
pub struct BatchOutput<'a> {
    /// Loaded actuator forces (N), `N × n`.
    pub force_n: &'a mut [f64],
    /// Loaded joint reactions (N), `N × n × 2`.
    pub reaction_n: &'a mut [f64],
    /// Force changes unloaded → loaded (N), `N × n`.
    pub dforce_n: &'a mut [f64],
    /// Measurement point displacement x (mm), `N`.
    pub dx_mm: &'a mut [f64],
    /// Measurement point displacement y (mm), `N`.
    pub dy_mm: &'a mut [f64],
    /// Change of absolute link angles (deg), `N × n`.
    pub dalpha_deg: &'a mut [f64],
    /// Actuator body length change seen by its sensor (mm), `N × n`.
    pub dl_mm: &'a mut [f64],
    /// Pin-to-pin length change (mm), `N × n`.
    pub dlength_mm: &'a mut [f64],
    /// Unloaded pin-to-pin length (mm), `N × n`.
    pub length_mm: &'a mut [f64],
}

/// Owned, zeroed output buffers of a batch of `rows` poses of an `n`-link arm, lent to the
/// solver by [`BatchBuffers::out`]; the fields are the [`BatchOutput`] slices' owners.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BatchBuffers {
    /// See [`BatchOutput::force_n`].
    pub force_n: Vec<f64>,
    /// See [`BatchOutput::reaction_n`].
    pub reaction_n: Vec<f64>,
    /// See [`BatchOutput::dforce_n`].
    pub dforce_n: Vec<f64>,
    /// See [`BatchOutput::dx_mm`].
    pub dx_mm: Vec<f64>,
    /// See [`BatchOutput::dy_mm`].
    pub dy_mm: Vec<f64>,
    /// See [`BatchOutput::dalpha_deg`].
    pub dalpha_deg: Vec<f64>,
    /// See [`BatchOutput::dl_mm`].
    pub dl_mm: Vec<f64>,
    /// See [`BatchOutput::dlength_mm`].
    pub dlength_mm: Vec<f64>,
    /// See [`BatchOutput::length_mm`].
    pub length_mm: Vec<f64>,
}

impl BatchBuffers {
    /// Zeroed buffers for `rows` poses of an `n`-link arm.
    pub fn new(rows: usize, n: usize) -> Self {
        let per_link = || vec![0.0; rows * n];
        Self {
            force_n: per_link(),
            reaction_n: vec![0.0; rows * n * 2],
            dforce_n: per_link(),
            dx_mm: vec![0.0; rows],
            dy_mm: vec![0.0; rows],
            dalpha_deg: per_link(),
            dl_mm: per_link(),
            dlength_mm: per_link(),
            length_mm: per_link(),
        }
    }

    /// The buffers as the solver's output slices.
    pub fn out(&mut self) -> BatchOutput<'_> {
        BatchOutput {
            force_n: &mut self.force_n,
            reaction_n: &mut self.reaction_n,
            dforce_n: &mut self.dforce_n,
            dx_mm: &mut self.dx_mm,
            dy_mm: &mut self.dy_mm,
            dalpha_deg: &mut self.dalpha_deg,
            dl_mm: &mut self.dl_mm,
            dlength_mm: &mut self.dlength_mm,
            length_mm: &mut self.length_mm,
        }
    }
}

impl BatchOutput<'_> {
    pub(crate) fn check(&self, rows: usize, n: usize) -> Result<()> {
        let want = [
            ("force_n", self.force_n.len(), rows * n),
            ("reaction_n", self.reaction_n.len(), rows * n * 2),
            ("dforce_n", self.dforce_n.len(), rows * n),
            ("dx_mm", self.dx_mm.len(), rows),
            ("dy_mm", self.dy_mm.len(), rows),
            ("dalpha_deg", self.dalpha_deg.len(), rows * n),
            ("dl_mm", self.dl_mm.len(), rows * n),
            ("dlength_mm", self.dlength_mm.len(), rows * n),
            ("length_mm", self.length_mm.len(), rows * n),
        ];
        for (what, got, expected) in want {
            if got != expected {
                return Err(ArmError::Shape {
                    what,
                    expected,
                    got,
                });
            }
        }
        Ok(())
    }
}

/// Checks shapes and finiteness of a batch; returns the number of poses.
///
/// # Errors
/// [`ArmError::Shape`] or [`ArmError::NonFinite`] naming the first bad row.
pub fn check_input(arm: &Arm, input: &BatchInput<'_>) -> Result<usize> {
    let n = arm.n();
    if !input.alpha_deg.len().is_multiple_of(n) {
        return Err(ArmError::Shape {
            what: "alpha_deg",
            expected: (input.alpha_deg.len() / n + 1) * n,
            got: input.alpha_deg.len(),
        });
    }
    let rows = input.alpha_deg.len() / n;
    if input.payload_n.len() != 2 * rows {
        return Err(ArmError::Shape {
            what: "payload_n",
            expected: 2 * rows,
            got: input.payload_n.len(),
        });
    }
    // One branch-free pass (vectorised) over each array; the rows only when it finds one.
    let finite = |v: &[f64]| {
        let exp = f64::INFINITY.to_bits();
        v.iter()
            .fold(0u64, |bad, x| bad | u64::from(x.to_bits() & exp == exp))
            == 0
    };
    if finite(input.alpha_deg) && finite(input.payload_n) {
        return Ok(rows);
    }
    for row in 0..rows {
        if !input.alpha_deg[row * n..(row + 1) * n]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(ArmError::NonFinite {
                row,
                what: "alpha_deg",
            });
        }
        if !input.payload_n[2 * row..2 * row + 2]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(ArmError::NonFinite {
                row,
                what: "payload",
            });
        }
    }
    Ok(rows)
}

/// Solves a batch of poses, filling `out` in place.
///
/// # Errors
/// The error of the lowest failing row (shape, non-finite, singular, unreachable).
pub fn solve_batch(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
) -> Result<()> {
    solve_batch_extra(arm, effects, input, ExtraDeformations::none(), opts, out)
}

/// [`solve_batch`] with per-pose deformations from outside the catalogue (user effects,
/// CONTRACT §8) added to the built-in effects' before each pose is closed.
///
/// # Errors
/// The error of the lowest failing row (shape, non-finite, singular, unreachable); a wrong
/// size or a non-finite value of an extra array names the array (and the row).
pub fn solve_batch_extra(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    extra: ExtraDeformations<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
) -> Result<()> {
    let mut status = vec![0u8; out.dx_mm.len()];
    solve_batch_status(arm, effects, input, extra, opts, out, &mut status)
}

/// [`solve_batch_extra`] that also writes the status code of every pose
/// ([`crate::validity::Status`], docs/model.md §7) into `status` (one per pose), computed in
/// the same pass. A pose that failed (NaN with `nan_on_failure`) gets the status of what is
/// known of it: its unloaded checks, else `large_deflection` (its angles are NaN).
///
/// # Errors
/// As [`solve_batch_extra`]; a `status` of the wrong length is a [`ArmError::Shape`].
#[allow(clippy::too_many_arguments)]
pub fn solve_batch_status(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    extra: ExtraDeformations<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
    status: &mut [u8],
) -> Result<()> {
    run(arm, effects, input, extra, opts, out, status, false)
}

/// [`solve_batch_status`] through the general path only ([`Workspace::solve_extra`] pose by
/// pose), whatever the effects: the reference the block kernel is tested against.
///
/// # Errors
/// As [`solve_batch_status`].
#[allow(clippy::too_many_arguments)]
pub fn solve_batch_general(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    extra: ExtraDeformations<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
    status: &mut [u8],
) -> Result<()> {
    run(arm, effects, input, extra, opts, out, status, true)
}

#[allow(clippy::too_many_arguments)]
fn run(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    extra: ExtraDeformations<'_>,
    opts: SolveOptions,
    out: BatchOutput<'_>,
    status: &mut [u8],
    general: bool,
) -> Result<()> {
    let n = arm.n();
    let rows = check_input(arm, &input)?;
    extra.check(rows, n)?;
    out.check(rows, n)?;
    if status.len() != rows {
        return Err(ArmError::Shape {
            what: "status",
            expected: rows,
            got: status.len(),
        });
    }
    // The block kernel covers the built-in effects of arms of 1–6 links; user-written
    // deformations and longer arms take the general path.
    let kernel = if extra.is_none() && !general {
        fast::Kernel::new(arm, effects, opts.self_weight)
    } else {
        None
    };
    let simd = pulp::Arch::new();
    let ctx = fast::Ctx { arm, effects, opts };
    let run = |sub: BatchInput<'_>, chunk: BatchOutput<'_>, st: &mut [u8], start: usize| {
        let m = chunk.dx_mm.len();
        match &kernel {
            Some(k) => k.chunk(simd, &ctx, sub, chunk, st, start),
            None => {
                let extra = extra.rows(start, m, n);
                solve_chunk(arm, effects, sub, extra, opts, chunk, st, start)
            }
        }
    };
    let (threshold, chunk_rows) = match kernel {
        Some(_) => (KERNEL_PARALLEL_THRESHOLD, KERNEL_CHUNK),
        None => (PARALLEL_THRESHOLD, CHUNK),
    };
    if rows < threshold {
        return run(input, out, status, 0);
    }
    let chunks = split_output(out, n, chunk_rows);
    let errors: Vec<ArmError> = chunks
        .into_par_iter()
        .zip(status.par_chunks_mut(chunk_rows))
        .enumerate()
        .filter_map(|(k, (chunk, st))| {
            let start = k * chunk_rows;
            let m = chunk.dx_mm.len();
            let sub = BatchInput {
                alpha_deg: &input.alpha_deg[start * n..(start + m) * n],
                payload_n: &input.payload_n[2 * start..2 * (start + m)],
            };
            run(sub, chunk, st, start).err()
        })
        .collect();
    // Chunks come back in order, so the first error is the lowest failing chunk's.
    match errors.into_iter().next() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

pub(crate) fn split_output<'a>(
    out: BatchOutput<'a>,
    n: usize,
    rows: usize,
) -> Vec<BatchOutput<'a>> {
    let mut f = out.force_n.chunks_mut(rows * n);
    let mut r = out.reaction_n.chunks_mut(rows * n * 2);
    let mut df = out.dforce_n.chunks_mut(rows * n);
    let mut dx = out.dx_mm.chunks_mut(rows);
    let mut dy = out.dy_mm.chunks_mut(rows);
    let mut da = out.dalpha_deg.chunks_mut(rows * n);
    let mut dl = out.dl_mm.chunks_mut(rows * n);
    let mut dlen = out.dlength_mm.chunks_mut(rows * n);
    let mut len = out.length_mm.chunks_mut(rows * n);
    let mut chunks = Vec::new();
    while let (
        Some(force_n),
        Some(reaction_n),
        Some(dforce_n),
        Some(dx_mm),
        Some(dy_mm),
        Some(dalpha_deg),
        Some(dl_mm),
        Some(dlength_mm),
        Some(length_mm),
    ) = (
        f.next(),
        r.next(),
        df.next(),
        dx.next(),
        dy.next(),
        da.next(),
        dl.next(),
        dlen.next(),
        len.next(),
    ) {
        chunks.push(BatchOutput {
            force_n,
            reaction_n,
            dforce_n,
            dx_mm,
            dy_mm,
            dalpha_deg,
            dl_mm,
            dlength_mm,
            length_mm,
        });
    }
    chunks
}

/// The general path over one chunk: [`Workspace::solve_extra`] pose by pose.
#[allow(clippy::too_many_arguments, clippy::needless_range_loop)] // p indexes the outputs
fn solve_chunk(
    arm: &Arm,
    effects: &EffectSet,
    input: BatchInput<'_>,
    extra: ExtraDeformations<'_>,
    opts: SolveOptions,
    mut out: BatchOutput<'_>,
    status: &mut [u8],
    first_row: usize,
) -> Result<()> {
    let n = arm.n();
    let mut ws = Workspace::new(arm);
    let mut loaded = Frames::new(n);
    let reach = crate::validity::reach(arm);
    let mut alpha = vec![0.0; n];
    for p in 0..out.dx_mm.len() {
        let row = first_row + p;
        for (a, d) in alpha.iter_mut().zip(&input.alpha_deg[p * n..(p + 1) * n]) {
            *a = d.to_radians();
        }
        let payload = V2::new(input.payload_n[2 * p], input.payload_n[2 * p + 1]);
        match ws.solve_extra(arm, effects, &alpha, payload, opts, row, (&extra, p)) {
            Ok(()) => write_row(&ws, &alpha, &mut out, p, n),
            Err(e) if opts.nan_on_failure && e.is_pose_failure() => fill_nan(&mut out, p, n),
            Err(e) => return Err(e),
        }
        let down = payload.y < 0.0;
        status[p] = status::pose_status(arm, &ws.frames, &mut loaded, &out, p, down, reach);
    }
    Ok(())
}

/// Writes the solved pose in `ws` (unloaded angles `alpha`, rad) into output row `p`.
#[allow(clippy::needless_range_loop)] // i indexes six parallel arrays
pub(crate) fn write_row(
    ws: &Workspace,
    alpha: &[f64],
    out: &mut BatchOutput<'_>,
    p: usize,
    n: usize,
) {
    for i in 0..n {
        let j = p * n + i;
        out.force_n[j] = ws.loaded.f[i];
        out.reaction_n[2 * j] = ws.loaded.r[i].x;
        out.reaction_n[2 * j + 1] = ws.loaded.r[i].y;
        out.dforce_n[j] = ws.delta.f[i];
        out.dalpha_deg[j] = (ws.new_alpha[i] - alpha[i]).to_degrees();
        out.dl_mm[j] = ws.body_dl[i];
        out.dlength_mm[j] = ws.new_length[i] - ws.lines.length[i];
        out.length_mm[j] = ws.lines.length[i];
    }
    out.dx_mm[p] = ws.dmeasure.x;
    out.dy_mm[p] = ws.dmeasure.y;
}

pub(crate) fn fill_nan(out: &mut BatchOutput<'_>, p: usize, n: usize) {
    for s in [
        &mut *out.force_n,
        &mut *out.dforce_n,
        &mut *out.dalpha_deg,
        &mut *out.dl_mm,
        &mut *out.dlength_mm,
        &mut *out.length_mm,
    ] {
        s[p * n..(p + 1) * n].fill(f64::NAN);
    }
    out.reaction_n[2 * p * n..2 * (p + 1) * n].fill(f64::NAN);
    out.dx_mm[p] = f64::NAN;
    out.dy_mm[p] = f64::NAN;
}
