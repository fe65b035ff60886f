//! Compensation (docs/compensation.md): the unloaded angles to command instead of a nominal pose, so
//! that under the payload the model's measure point lands where the nominal pose puts it and,
//! for n ≥ 3, the last link keeps its nominal absolute angle.
//!
//! The conditions are solved on the **exact** model ([`Workspace::solve`]: statics of both
//! states, every effect, the loaded pose closed exactly) by Gauss–Newton from the nominal
//! pose. With α⁰ the nominal angles, M⁰ the nominal (rigid, unloaded) position of the measure
//! point and, at the commanded angles α, M′(α) its loaded position and α′_n(α) the last link's
//! loaded angle, the residual is
//!
//! ```text
//! r(α) = ( M′(α) − M⁰ ,  s·(α′_n(α) − α⁰_n) )      (the angle row only for n ≥ 3)
//! ```
//!
//! with `s = |next_n|` (mm per rad: the angle row in the same unit as the others).
//!
//! **Phase 1**, onto the conditions: Gauss–Newton from the nominal pose with the minimum-norm
//! step `Δ = −J⁺·r`, `J⁺ = Jᵀ(JJᵀ)⁻¹`; for n ≤ 3 its fixed point is the (locally unique)
//! solution. A 1-link arm has one unknown for two conditions: the step is the least-squares
//! one, `Δ = −Jᵀr / JᵀJ`, and the answer the angle of the smallest miss.
//!
//! **Phase 2** (n > 3), the smallest change: the conditions leave an (n − 3)-dimensional set
//! of solutions, and the one nearest α⁰ satisfies `α − α⁰ ∈ row space of J` (the first-order
//! condition of `min |α − α⁰|` subject to `r = 0`). From a solution, step along the tangent
//! space by `z = (I − J⁺J)(α⁰ − α)` (scaled by a secant estimate of the set's curvature), go
//! back onto the conditions with phase 1, and keep the new point if it is nearer α⁰ (else
//! halve the step); stop when `z` vanishes.
//!
//! Where the solution is unique (n = 2, 3) J only sets the speed, and the default
//! ([`JacobianKind::Auto`]) is quasi-Newton ([`JacobianKind::Rigid`]): the rigid-kinematic
//! Jacobian of (M, α_n) at the nominal pose's loaded angles, then Broyden's rank-one update
//! after every step, one model solve per step. The rigid Jacobian alone is off by the
//! deflection's own sensitivity to the pose (a relative 10⁻³–10⁻², more where an actuator's
//! moment arm changes fast) and would converge only linearly at that rate; the updates make it
//! superlinear. Where J defines the answer (n > 3: the smallest change; n = 1: the
//! least-squares optimum) it is the exact Jacobian, by forward differences of the full model
//! ([`JacobianKind::FiniteDifference`], n more solves per step). A step that increases the
//! miss is halved (at most ten times). See `docs/compensation.md` for the iteration counts.

pub mod batch;

pub use batch::{compensate_batch, CompensateBuffers, CompensateOutput};

use crate::arm::{Arm, Drive};
use crate::effects::EffectSet;
use crate::error::{ArmError, Result};
use crate::geometry::{wrap_pi, V2};
use crate::solve::{SolveOptions, Workspace};

/// Largest change of any angle in one step (rad): a trust region against wild steps near a
/// kinematic singularity.
pub const MAX_STEP_RAD: f64 = 0.5;
/// A Gram matrix `JJᵀ` whose Cholesky pivot falls below this fraction of its largest
/// diagonal is singular (σ_min/σ_max ≲ 10⁻⁶): the point cannot move in some direction.
pub const KINEMATIC_SINGULAR: f64 = 1e-12;
/// Step of the finite-difference Jacobian (rad).
pub const FD_STEP_RAD: f64 = 1e-7;
/// Relative precision of what only the Jacobian's accuracy bounds: for n > 3 the tangent
/// step is negligible below this fraction of the largest change of angle (plus `tol_mm` over
/// the reach); for n = 1 a step is negligible when it moves the point by less than `tol_mm`
/// plus this fraction of the miss left.
pub const NULL_REL: f64 = 1e-5;
/// Halvings of a step that increases the residual before the pose is given up.
pub const MAX_HALVINGS: u32 = 10;

/// Which Jacobian drives the Gauss–Newton steps.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum JacobianKind {
    /// [`Self::Rigid`] where the solution is unique (n = 2, 3: the Jacobian only sets the
    /// speed), [`Self::FiniteDifference`] where the Jacobian defines the answer (n > 3: the
    /// smallest change; n = 1: the least-squares optimum).
    #[default]
    Auto,
    /// Quasi-Newton: the rigid-kinematic Jacobian at the nominal pose's loaded angles, then
    /// Broyden's rank-one update after every step (one solve per step). Refused for n ≠ 2, 3,
    /// whose answer an approximate Jacobian would shift.
    Rigid,
    /// Forward differences of the full model (`n` extra solves per step).
    FiniteDifference,
}

impl JacobianKind {
    /// The kind used for an `n`-link arm ([`Self::Auto`] resolved).
    pub fn resolve(self, n: usize) -> Self {
        match self {
            Self::Auto if n == 2 || n == 3 => Self::Rigid,
            Self::Auto => Self::FiniteDifference,
            other => other,
        }
    }
}

/// Options of a compensation.
#[derive(Debug, Clone, Copy)]
pub struct CompensateOptions {
    /// Include link and actuator weights in both states (as [`SolveOptions::self_weight`]).
    pub self_weight: bool,
    /// The Jacobian of the steps.
    pub jacobian: JacobianKind,
    /// Most Gauss–Newton steps per pose.
    pub max_iter: u32,
    /// Convergence: the miss (mm; the angle condition scaled by `|next_n|`) below this
    /// (n = 2, 3, and every pose of phase 2 for n > 3); see [`NULL_REL`] for the rest.
    pub tol_mm: f64,
    /// An actuator whose moment arm about its joint is below this fraction of `|A_i − O_i|`
    /// (the sine of the angle at its pin) makes the pose near-singular.
    pub min_moment_ratio: f64,
}

impl Default for CompensateOptions {
    fn default() -> Self {
        Self {
            self_weight: true,
            jacobian: JacobianKind::Auto,
            max_iter: 50,
            tol_mm: 1e-9,
            min_moment_ratio: 1e-2,
        }
    }
}

impl CompensateOptions {
    /// Checks the options for an `n`-link arm.
    ///
    /// # Errors
    /// [`ArmError::InvalidOption`] naming the option.
    pub fn check(&self, n: usize) -> Result<()> {
        let bad = |what: String| Err(ArmError::InvalidOption(what));
        if self.jacobian == JacobianKind::Rigid && !(n == 2 || n == 3) {
            return bad(format!(
                "compensate: the quasi-Newton (rigid) Jacobian needs 2 or 3 links, this arm has \
                 {n}: its answer (the smallest change, or the least-squares optimum) depends \
                 on the exact Jacobian; use finite differences (the default)"
            ));
        }
        if self.max_iter == 0 {
            return bad("compensate: max_iter must be >= 1".into());
        }
        if !(self.tol_mm.is_finite() && self.tol_mm > 0.0) {
            return bad(format!(
                "compensate: tol_mm must be finite and > 0, got {}",
                self.tol_mm
            ));
        }
        if !(self.min_moment_ratio.is_finite() && (0.0..1.0).contains(&self.min_moment_ratio)) {
            return bad(format!(
                "compensate: min_moment_ratio must be in [0, 1), got {}",
                self.min_moment_ratio
            ));
        }
        Ok(())
    }
}

/// What became of one pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum CompensateStatus {
    /// Converged; the commanded pose is within every stroke.
    Ok = 0,
    /// Converged, but a commanded (unloaded) pin-to-pin length is outside its actuator's
    /// `[min_length_mm, max_length_mm]`, or a rotary drive's commanded angle outside its
    /// `[min_angle_deg, max_angle_deg]`.
    OutOfStroke = 1,
    /// An actuator's moment arm is tiny (below `min_moment_ratio`, or its line passes through
    /// its joint, or its triangle cannot close under the load) at the nominal or the
    /// compensated pose, or the arm is at a kinematic singularity (the point cannot move in
    /// some direction).
    NearSingular = 2,
    /// No convergence within `max_iter` steps, or no step reduced the miss (e.g. a play or a
    /// clearance flipping side between steps).
    NoConvergence = 3,
}

impl CompensateStatus {
    /// Every status, in code order.
    pub const ALL: [Self; 4] = [
        Self::Ok,
        Self::OutOfStroke,
        Self::NearSingular,
        Self::NoConvergence,
    ];

    /// The status's code (its index in [`Self::ALL`]).
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The name used by the Python API and the command line.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Ok => "ok",
            Self::OutOfStroke => "out_of_stroke",
            Self::NearSingular => "near_singular",
            Self::NoConvergence => "no_convergence",
        }
    }
}

/// The outcome of one pose (the angles themselves: [`Compensator::alpha`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseResult {
    /// What became of the pose.
    pub status: CompensateStatus,
    /// Gauss–Newton steps taken (0 when the nominal pose already meets the conditions).
    pub iterations: u32,
    /// Distance of the loaded measure point from the nominal point (mm) at the last accepted
    /// iterate; NaN when the model could not be solved there.
    pub residual_mm: f64,
    /// Loaded minus nominal angle of the last link (rad) at the last accepted iterate (a
    /// condition only for n ≥ 3); NaN when the model could not be solved there.
    pub residual_rad: f64,
    /// The actuator concerned (1-based) for [`CompensateStatus::OutOfStroke`] and for a tiny
    /// moment arm; 0 otherwise.
    pub actuator: u32,
}

/// The nominal target of one pose.
#[derive(Debug, Clone, Copy)]
struct Target {
    point: V2,
    angle: f64,
    /// Conditions: 2 (the point) or 3 (point and last angle, n ≥ 3).
    m: usize,
    /// mm per rad of the angle condition: `|next_n|`.
    scale: f64,
}

/// Per-thread state for compensating one pose at a time (nothing is allocated per pose).
#[derive(Debug, Clone)]
pub struct Compensator {
    ws: Workspace,
    alpha: Vec<f64>,
    trial: Vec<f64>,
    step: Vec<f64>,
    nominal: Vec<f64>,
    tangent: Vec<f64>,
    prev_tangent: Vec<f64>,
    best: Vec<f64>,
    jac: Vec<f64>,
    /// A length per rad for the null-space test: the arm's reach Σ|next_i| (mm).
    reach: f64,
}

impl Compensator {
    /// Scratch space for `arm`.
    pub fn new(arm: &Arm) -> Self {
        let n = arm.n();
        Self {
            ws: Workspace::new(arm),
            alpha: vec![0.0; n],
            trial: vec![0.0; n],
            step: vec![0.0; n],
            nominal: vec![0.0; n],
            tangent: vec![0.0; n],
            prev_tangent: vec![0.0; n],
            best: vec![0.0; n],
            jac: vec![0.0; 3 * n],
            reach: arm.links.iter().map(|l| l.next.norm()).sum(),
        }
    }

    /// The commanded angles (rad) of the last pose compensated (meaningful when its status
    /// is [`CompensateStatus::Ok`]).
    pub fn alpha(&self) -> &[f64] {
        &self.alpha
    }

    /// Unloaded pin-to-pin lengths (mm) of [`Self::alpha`] (NaN at rotary drives), valid
    /// after a pose whose status is [`CompensateStatus::Ok`] or
    /// [`CompensateStatus::OutOfStroke`].
    pub fn length(&self) -> &[f64] {
        &self.ws.lines.length
    }

    /// Compensates one pose: `nominal` are the unloaded angles (rad) the user would command,
    /// `payload` the force (N, global) at the load point.
    ///
    /// # Errors
    /// [`ArmError::Shape`] when `nominal` does not have `n` angles, [`ArmError::NonFinite`]
    /// for a non-finite angle or payload (naming `row`), [`ArmError::InvalidOption`] for bad
    /// options. A pose that cannot be compensated is not an error but a status.
    pub fn compensate(
        &mut self,
        arm: &Arm,
        effects: &EffectSet,
        nominal: &[f64],
        payload: V2,
        opts: &CompensateOptions,
        row: usize,
    ) -> Result<PoseResult> {
        let n = arm.n();
        opts.check(n)?;
        if nominal.len() != n {
            return Err(ArmError::Shape {
                what: "alpha",
                expected: n,
                got: nominal.len(),
            });
        }
        if !nominal.iter().all(|a| a.is_finite()) {
            return Err(ArmError::NonFinite {
                row,
                what: "alpha_deg",
            });
        }
        if !(payload.x.is_finite() && payload.y.is_finite()) {
            return Err(ArmError::NonFinite {
                row,
                what: "payload",
            });
        }
        self.nominal.copy_from_slice(nominal);
        self.alpha.copy_from_slice(nominal);
        self.ws.frames.fill(arm, nominal);
        let p = Problem {
            arm,
            effects,
            payload,
            sopts: SolveOptions {
                self_weight: opts.self_weight,
                nan_on_failure: false,
            },
            row,
            target: Target {
                point: self.ws.frames.measure,
                angle: nominal[n - 1],
                m: if n >= 3 { 3 } else { 2 },
                scale: arm.links[n - 1].next.norm(),
            },
            kind: opts.jacobian.resolve(n),
            tol_mm: opts.tol_mm,
            max_iter: opts.max_iter,
        };
        let mut result = PoseResult {
            status: CompensateStatus::NoConvergence,
            iterations: 0,
            residual_mm: f64::NAN,
            residual_rad: f64::NAN,
            actuator: 0,
        };
        let mut r = [0.0; 3];
        if let Err(e) = self.evaluate_alpha(&p, &mut r) {
            return pose_failure(e, result);
        }
        note_residual(&mut result, &r, &p.target, &self.ws, n);
        if let Some(act) = self.tiny_moment_arm(arm, opts.min_moment_ratio) {
            result.status = CompensateStatus::NearSingular;
            result.actuator = act;
            return Ok(result);
        }
        let mut outcome = self.onto_conditions(&p, &mut r, &mut result)?;
        if outcome == Outcome::Converged && n > p.target.m {
            outcome = self.nearest(&p, &mut r, &mut result)?;
        }
        match outcome {
            Outcome::Converged => {}
            Outcome::Stalled => return Ok(result),
            Outcome::Singular => {
                result.status = CompensateStatus::NearSingular;
                return Ok(result);
            }
        }
        // The commanded pose's own geometry: moment arms and stroke.
        self.ws.frames.fill(arm, &self.alpha);
        if let Err(e) = self.ws.lines.fill(arm, &self.ws.frames, row) {
            return pose_failure(e, result);
        }
        if let Some(act) = self.tiny_moment_arm(arm, opts.min_moment_ratio) {
            result.status = CompensateStatus::NearSingular;
            result.actuator = act;
            return Ok(result);
        }
        for (i, d) in arm.drives.iter().enumerate() {
            let outside = match d {
                Drive::Linear(a) => a.out_of_stroke(self.ws.lines.length[i]),
                Drive::Rotary(r) => {
                    let before = if i == 0 { 0.0 } else { self.alpha[i - 1] };
                    r.out_of_range(r.angle_of(self.alpha[i] - before))
                }
            };
            if outside {
                result.status = CompensateStatus::OutOfStroke;
                result.actuator = (i + 1) as u32;
                return Ok(result);
            }
        }
        result.status = CompensateStatus::Ok;
        Ok(result)
    }

    /// Phase 1: Gauss–Newton from `self.alpha` (residual `r`, its solution in the workspace)
    /// onto the conditions, with minimum-norm steps (least-squares ones for n = 1). On
    /// return `self.alpha`, `r` and the workspace agree.
    fn onto_conditions(
        &mut self,
        p: &Problem<'_>,
        r: &mut [f64; 3],
        result: &mut PoseResult,
    ) -> Result<Outcome> {
        let n = p.arm.n();
        let m = p.target.m;
        let tol2 = p.tol_mm * p.tol_mm;
        let mut phi = norm2(r);
        let mut have_jacobian = false;
        loop {
            if p.kind == JacobianKind::FiniteDifference || !have_jacobian {
                self.jacobian(p, r)?;
                have_jacobian = true;
            }
            if !self.step(n, m, r) {
                return Ok(Outcome::Singular);
            }
            let converged = if n >= m {
                phi <= tol2
            } else {
                // Least squares: the miss left is of the order of the deflection; a step
                // below 10⁻⁶ of it changes the miss by far less than the tolerance.
                max_abs(&self.step) * self.reach <= p.tol_mm + NULL_REL * phi.sqrt()
            };
            if converged {
                return Ok(Outcome::Converged);
            }
            if result.iterations >= p.max_iter {
                return Ok(Outcome::Stalled);
            }
            // Trust region, then halve until the miss does not grow.
            let big = max_abs(&self.step);
            let mut t = if big > MAX_STEP_RAD {
                MAX_STEP_RAD / big
            } else {
                1.0
            };
            let mut r_trial = [0.0; 3];
            let mut accepted = false;
            for _ in 0..=MAX_HALVINGS {
                for j in 0..n {
                    self.trial[j] = self.alpha[j] + t * self.step[j];
                }
                if let Some(phi_t) = self.try_trial(p, &mut r_trial)? {
                    accepted = if n >= m {
                        phi_t <= phi || phi_t <= tol2
                    } else {
                        phi_t <= phi * (1.0 + 1e-12) + tol2
                    };
                }
                if accepted {
                    break;
                }
                t *= 0.5;
            }
            if !accepted {
                // No step helps (a gap changing side, an actuator near its dead point): back
                // to the last iterate, so that the workspace matches it.
                return match self.evaluate_alpha(p, r) {
                    Ok(()) => Ok(Outcome::Stalled),
                    Err(e) if e.is_pose_failure() => Ok(Outcome::Singular),
                    Err(e) => Err(e),
                };
            }
            if p.kind == JacobianKind::Rigid {
                self.broyden(n, m, t, r, &r_trial);
            }
            self.alpha.copy_from_slice(&self.trial);
            *r = r_trial;
            phi = norm2(r);
            result.iterations += 1;
            note_residual(result, r, &p.target, &self.ws, n);
        }
    }

    /// Phase 2 (n > m): along the solution set towards the nominal. From a pose that meets
    /// the conditions, step along the tangent space by `z = (I − J⁺J)(α⁰ − α)` (exact
    /// Jacobian), back onto the conditions (phase 1), and keep the result if the change
    /// `|α − α⁰|` shrank (else halve the step); converged when `z` vanishes — `α − α⁰` in
    /// the row space of J, the first-order condition of the smallest change — or when no
    /// step shrinks the change any more.
    fn nearest(
        &mut self,
        p: &Problem<'_>,
        r: &mut [f64; 3],
        result: &mut PoseResult,
    ) -> Result<Outcome> {
        let n = p.arm.n();
        // Secant estimate of the solution set's curvature along the tangent: the step's scale.
        let mut gain = 1.0;
        let mut last_step: Option<f64> = None;
        loop {
            self.jacobian(p, r)?;
            let Some(size) = self.tangent(n, p.target.m) else {
                return Ok(Outcome::Singular);
            };
            if let Some(s_used) = last_step {
                // Along the last direction u the tangent shrank from |z₀| to z·u over a move
                // of s·|z₀|: curvature h = (|z₀| − z·u)/(s·|z₀|), 1 on a flat solution set.
                let z0 = norm(&self.prev_tangent);
                let along: f64 = self
                    .tangent
                    .iter()
                    .zip(&self.prev_tangent)
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
                    / z0;
                let h = (z0 - along) / (s_used * z0);
                gain = if h.is_finite() && h > 0.0 {
                    (1.0 / h).clamp(0.25, 4.0)
                } else {
                    1.0
                };
            }
            let change = max_abs_diff(&self.alpha, &self.nominal);
            // Only as exact as the Jacobian: relative to the change itself.
            if size <= p.tol_mm / self.reach + NULL_REL * change {
                return self.settle(p, r);
            }
            if result.iterations >= p.max_iter {
                return Ok(Outcome::Stalled);
            }
            let d2 = dist2(&self.alpha, &self.nominal);
            self.best.copy_from_slice(&self.alpha);
            let r_best = *r;
            let residual_best = (result.residual_mm, result.residual_rad);
            let mut s = gain;
            let mut accepted = false;
            for _ in 0..=MAX_HALVINGS {
                for j in 0..n {
                    self.alpha[j] = self.best[j] + s * self.tangent[j];
                }
                let ev = self.evaluate_alpha(p, r);
                if ev.is_ok()
                    && self.onto_conditions(p, r, result)? == Outcome::Converged
                    && dist2(&self.alpha, &self.nominal) < d2
                {
                    accepted = true;
                    break;
                }
                if let Err(e) = ev {
                    if !e.is_pose_failure() {
                        return Err(e);
                    }
                }
                if result.iterations >= p.max_iter {
                    break;
                }
                s *= 0.5;
            }
            if !accepted {
                self.alpha.copy_from_slice(&self.best);
                *r = r_best;
                (result.residual_mm, result.residual_rad) = residual_best;
                if result.iterations >= p.max_iter {
                    return Ok(Outcome::Stalled);
                }
                // No step along the solution set shrinks the change: the nearest pose to
                // the precision the model allows.
                return self.settle(p, r);
            }
            self.prev_tangent.copy_from_slice(&self.tangent);
            last_step = Some(s);
            result.iterations += 1;
        }
    }

    /// Re-solves `self.alpha` so that the workspace matches it (after finite differences or
    /// rejected trials), and calls it converged.
    fn settle(&mut self, p: &Problem<'_>, r: &mut [f64; 3]) -> Result<Outcome> {
        match self.evaluate_alpha(p, r) {
            Ok(()) => Ok(Outcome::Converged),
            Err(e) if e.is_pose_failure() => Ok(Outcome::Singular),
            Err(e) => Err(e),
        }
    }

    /// Solves the model at `self.trial` into `r`: `Some(|r|²)`, or `None` when the model
    /// cannot solve that pose.
    fn try_trial(&mut self, p: &Problem<'_>, r: &mut [f64; 3]) -> Result<Option<f64>> {
        let trial = std::mem::take(&mut self.trial);
        let ev = self.evaluate(p, &trial, r);
        self.trial = trial;
        match ev {
            Ok(()) => Ok(Some(norm2(r))),
            Err(e) if e.is_pose_failure() => Ok(None),
            Err(e) => Err(e),
        }
    }

    /// Solves the model at `self.alpha` into `r`.
    fn evaluate_alpha(&mut self, p: &Problem<'_>, r: &mut [f64; 3]) -> Result<()> {
        let alpha = std::mem::take(&mut self.alpha);
        let ev = self.evaluate(p, &alpha, r);
        self.alpha = alpha;
        ev
    }

    /// Solves the model at `alpha` and writes the residual into `r`.
    fn evaluate(&mut self, p: &Problem<'_>, alpha: &[f64], r: &mut [f64; 3]) -> Result<()> {
        self.ws
            .solve(p.arm, p.effects, alpha, p.payload, p.sopts, p.row)?;
        let t = &p.target;
        let miss = self.ws.frames.measure + self.ws.dmeasure - t.point;
        r[0] = miss.x;
        r[1] = miss.y;
        r[2] = if t.m == 3 {
            t.scale * wrap_pi(self.ws.new_alpha[p.arm.n() - 1] - t.angle)
        } else {
            0.0
        };
        Ok(())
    }

    /// The first actuator (1-based) whose moment arm ratio in `self.ws.lines` is below `min`
    /// (a rotary drive has no moment arm to lose).
    fn tiny_moment_arm(&self, arm: &Arm, min: f64) -> Option<u32> {
        (0..arm.n())
            .filter(|&i| !arm.is_rotary(i))
            .find(|&i| self.ws.lines.arm[i].abs() < min * arm.links[i].a.norm())
            .map(|i| (i + 1) as u32)
    }

    /// Fills `self.jac` (m × n, row-major) at `self.alpha`, whose model solution is in the
    /// workspace and whose residual is `r` (finite differences leave the workspace at the
    /// last perturbed pose).
    fn jacobian(&mut self, p: &Problem<'_>, r: &[f64; 3]) -> Result<()> {
        let n = p.arm.n();
        match p.kind {
            JacobianKind::Auto | JacobianKind::Rigid => {
                for j in 0..n {
                    let (c0, c1, c2) = rigid_column(p, j, self.ws.new_alpha[j]);
                    self.jac[j] = c0;
                    self.jac[n + j] = c1;
                    self.jac[2 * n + j] = c2;
                }
            }
            JacobianKind::FiniteDifference => {
                let mut rj = [0.0; 3];
                for j in 0..n {
                    self.trial.copy_from_slice(&self.alpha);
                    self.trial[j] += FD_STEP_RAD;
                    if self.try_trial(p, &mut rj)?.is_some() {
                        for k in 0..3 {
                            self.jac[k * n + j] = (rj[k] - r[k]) / FD_STEP_RAD;
                        }
                    } else {
                        // A step across the edge of the model: the rigid column instead.
                        let (c0, c1, c2) = rigid_column(p, j, self.alpha[j]);
                        self.jac[j] = c0;
                        self.jac[n + j] = c1;
                        self.jac[2 * n + j] = c2;
                    }
                }
            }
        }
        Ok(())
    }

    /// Broyden's rank-one update of `self.jac` after the step `t·self.step` changed the
    /// residual from `r` to `r_new`: `J += (Δr − J·s)·sᵀ / sᵀs`.
    fn broyden(&mut self, n: usize, m: usize, t: f64, r: &[f64; 3], r_new: &[f64; 3]) {
        let ss: f64 = self.step.iter().map(|x| t * t * x * x).sum();
        if ss.is_nan() || ss <= 0.0 {
            return;
        }
        for k in 0..m {
            let js: f64 = (0..n).map(|j| self.jac[k * n + j] * t * self.step[j]).sum();
            let u = (r_new[k] - r[k] - js) / ss;
            for j in 0..n {
                self.jac[k * n + j] += u * t * self.step[j];
            }
        }
    }

    /// The Gauss–Newton step `−J⁺·r` (minimum-norm; least squares for n < m) into
    /// `self.step`; `false` at a kinematic singularity.
    fn step(&mut self, n: usize, m: usize, r: &[f64; 3]) -> bool {
        let jac = &self.jac;
        if n < m {
            // n = 1: least squares, Δ = −Jᵀr / JᵀJ.
            let (mut jtj, mut jtr) = (0.0, 0.0);
            for k in 0..m {
                jtj += jac[k * n] * jac[k * n];
                jtr += jac[k * n] * r[k];
            }
            if !(jtj > 0.0 && jtj.is_finite()) {
                return false;
            }
            self.step[0] = -jtr / jtj;
            return true;
        }
        let Some(l) = cholesky(&gram(jac, n, m), m, KINEMATIC_SINGULAR) else {
            return false;
        };
        let y = chol_solve(&l, m, r);
        for j in 0..n {
            self.step[j] = -(0..m).map(|k| jac[k * n + j] * y[k]).sum::<f64>();
        }
        true
    }

    /// The tangent step `z = (I − J⁺J)(α⁰ − α)` into `self.tangent`; its largest entry
    /// (rad), or `None` at a kinematic singularity.
    fn tangent(&mut self, n: usize, m: usize) -> Option<f64> {
        let jac = &self.jac;
        let l = cholesky(&gram(jac, n, m), m, KINEMATIC_SINGULAR)?;
        let mut jz = [0.0; 3];
        for (k, v) in jz.iter_mut().enumerate().take(m) {
            *v = (0..n)
                .map(|j| jac[k * n + j] * (self.nominal[j] - self.alpha[j]))
                .sum();
        }
        let w = chol_solve(&l, m, &jz);
        let mut size = 0.0f64;
        for j in 0..n {
            let z = (self.nominal[j] - self.alpha[j])
                - (0..m).map(|k| jac[k * n + j] * w[k]).sum::<f64>();
            self.tangent[j] = z;
            size = size.max(z.abs());
        }
        Some(size)
    }
}

/// One pose's problem: what every step reads.
#[derive(Debug, Clone, Copy)]
struct Problem<'a> {
    arm: &'a Arm,
    effects: &'a EffectSet,
    payload: V2,
    sopts: SolveOptions,
    row: usize,
    target: Target,
    /// Resolved: never [`JacobianKind::Auto`].
    kind: JacobianKind,
    tol_mm: f64,
    max_iter: u32,
}

/// How a phase ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    Converged,
    /// Out of steps, or no step reduced the miss.
    Stalled,
    /// A kinematic singularity: the point cannot move in some direction.
    Singular,
}

/// Column j of the rigid-kinematic Jacobian at angle `alpha_j`: with
/// M = O₁ + Σ_{i<n} R(α_i)·next_i + R(α_n)·m, ∂M/∂α_j = R(α_j + π/2)·v_j; the angle row is
/// s·δ_jn.
fn rigid_column(p: &Problem<'_>, j: usize, alpha_j: f64) -> (f64, f64, f64) {
    let n = p.arm.n();
    let v = if j + 1 < n {
        p.arm.links[j].next
    } else {
        p.arm.measure
    };
    let (s, c) = alpha_j.sin_cos();
    let angle = if p.target.m == 3 && j + 1 == n {
        p.target.scale
    } else {
        0.0
    };
    (-(s * v.x + c * v.y), c * v.x - s * v.y, angle)
}

/// `J·Jᵀ` of the m × n row-major `jac`, in the leading block of a 3 × 3.
fn gram(jac: &[f64], n: usize, m: usize) -> [[f64; 3]; 3] {
    let mut g = [[0.0; 3]; 3];
    for a in 0..m {
        for b in 0..=a {
            let s: f64 = (0..n).map(|j| jac[a * n + j] * jac[b * n + j]).sum();
            g[a][b] = s;
            g[b][a] = s;
        }
    }
    g
}

#[inline]
fn norm(a: &[f64]) -> f64 {
    a.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[inline]
fn dist2(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// The status of a pose whose model fails (singular, zero length, a triangle that cannot
/// close: all a tiny moment arm), or the error itself when it is not about the pose.
fn pose_failure(e: ArmError, mut result: PoseResult) -> Result<PoseResult> {
    let actuator = match e {
        ArmError::Singular { actuator, .. }
        | ArmError::ZeroLength { actuator, .. }
        | ArmError::Unreachable { actuator, .. } => actuator,
        ref other if other.is_pose_failure() => 0,
        other => return Err(other),
    };
    result.status = CompensateStatus::NearSingular;
    result.actuator = actuator as u32;
    Ok(result)
}

fn note_residual(result: &mut PoseResult, r: &[f64; 3], t: &Target, ws: &Workspace, n: usize) {
    result.residual_mm = r[0].hypot(r[1]);
    result.residual_rad = wrap_pi(ws.new_alpha[n - 1] - t.angle);
}

#[inline]
fn norm2(r: &[f64; 3]) -> f64 {
    r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
}

#[inline]
fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

#[inline]
fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Cholesky factor of the leading m×m block (m ≤ 3) of a symmetric matrix; `None` when a
/// pivot is not above `rel` times the largest diagonal (or anything is not finite).
fn cholesky(a: &[[f64; 3]; 3], m: usize, rel: f64) -> Option<[[f64; 3]; 3]> {
    let dmax = (0..m).map(|i| a[i][i]).fold(0.0f64, f64::max);
    if !(dmax > 0.0 && dmax.is_finite()) {
        return None;
    }
    let mut l = [[0.0; 3]; 3];
    for j in 0..m {
        let d = a[j][j] - (0..j).map(|k| l[j][k] * l[j][k]).sum::<f64>();
        // NaN included: not above the threshold.
        if d.is_nan() || d <= rel * dmax {
            return None;
        }
        let djj = d.sqrt();
        l[j][j] = djj;
        for i in j + 1..m {
            let s = a[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            l[i][j] = s / djj;
        }
    }
    Some(l)
}

/// Solves `L·Lᵀ·x = b` for the leading m entries.
fn chol_solve(l: &[[f64; 3]; 3], m: usize, b: &[f64; 3]) -> [f64; 3] {
    let mut y = [0.0; 3];
    for i in 0..m {
        y[i] = (b[i] - (0..i).map(|k| l[i][k] * y[k]).sum::<f64>()) / l[i][i];
    }
    let mut x = [0.0; 3];
    for i in (0..m).rev() {
        x[i] = (y[i] - (i + 1..m).map(|k| l[k][i] * x[k]).sum::<f64>()) / l[i][i];
    }
    x
}
