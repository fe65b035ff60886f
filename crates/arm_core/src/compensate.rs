//! Compensation (CONTRACT §9): the unloaded angles to command instead of a nominal pose, so
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
//! with `s = |next_n|` (mm per rad: the angle row in the same unit as the others). Each step
//! solves the linearised problem `min |α + Δ − α⁰|  s.t.  r + J·Δ = 0`:
//!
//! ```text
//! Δ = −J⁺·r + (I − J⁺J)·(α⁰ − α),     J⁺ = Jᵀ(JJᵀ)⁻¹
//! ```
//!
//! so for n > 3 the fixed point is the commanded pose nearest the nominal (the first-order
//! condition α − α⁰ ∈ row space of J), and for n ≤ 3 the unique solution. A 1-link arm has
//! one unknown for two conditions: the step is the least-squares one, `Δ = −Jᵀr / JᵀJ`.
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

use crate::arm::Arm;
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
/// The null-space part of a step (n > 3) counts as converged below this fraction of the
/// largest change of angle (plus `tol_mm` over the reach): the minimum-norm condition is only
/// as exact as the Jacobian it uses.
pub const NULL_REL: f64 = 1e-6;
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
    /// Convergence: the miss (mm; the angle condition scaled by `|next_n|`) below this, and
    /// for n > 3 the null-space part of the step times the reach below it too.
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
    /// `[min_length_mm, max_length_mm]`.
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
            jac: vec![0.0; 3 * n],
            reach: arm.links.iter().map(|l| l.next.norm()).sum(),
        }
    }

    /// The commanded angles (rad) of the last pose compensated (meaningful when its status
    /// is [`CompensateStatus::Ok`]).
    pub fn alpha(&self) -> &[f64] {
        &self.alpha
    }

    /// Unloaded pin-to-pin lengths (mm) of [`Self::alpha`], valid after a pose whose status
    /// is [`CompensateStatus::Ok`] or [`CompensateStatus::OutOfStroke`].
    pub fn length(&self) -> &[f64] {
        &self.ws.lines.length
    }

    /// Compensates one pose: `nominal` are the unloaded angles (rad) the user would command,
    /// `payload` the force (N, global) at the load point.
    ///
    /// # Errors
    /// [`ArmError::Shape`] when `nominal` does not have `n` angles, [`ArmError::NonFinite`]
    /// for a non-finite angle or payload (naming `row`). A pose the model cannot solve is
    /// not an error but a status.
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
        let sopts = SolveOptions {
            self_weight: opts.self_weight,
            nan_on_failure: false,
        };
        self.ws.frames.fill(arm, nominal);
        let target = Target {
            point: self.ws.frames.measure,
            angle: nominal[n - 1],
            m: if n >= 3 { 3 } else { 2 },
            scale: arm.links[n - 1].next.norm(),
        };
        let mut result = PoseResult {
            status: CompensateStatus::NoConvergence,
            iterations: 0,
            residual_mm: f64::NAN,
            residual_rad: f64::NAN,
            actuator: 0,
        };
        let mut r = [0.0; 3];
        match self.evaluate(arm, effects, nominal, payload, sopts, row, &target, &mut r) {
            Ok(()) => {}
            Err(e) => return pose_failure(e, result),
        }
        note_residual(&mut result, &r, &target, &self.ws, n);
        if let Some(act) = self.tiny_moment_arm(arm, opts.min_moment_ratio) {
            result.status = CompensateStatus::NearSingular;
            result.actuator = act;
            return Ok(result);
        }
        let mut phi = norm2(&r);
        let tol2 = opts.tol_mm * opts.tol_mm;
        let kind = opts.jacobian.resolve(n);
        let mut have_jacobian = false;
        loop {
            if kind == JacobianKind::FiniteDifference || !have_jacobian {
                self.jacobian(arm, effects, payload, sopts, row, &target, &r, kind)?;
                have_jacobian = true;
            }
            let null_part = match self.step(n, &target, &r) {
                Some(p) => p,
                None => {
                    result.status = CompensateStatus::NearSingular;
                    return Ok(result);
                }
            };
            let converged = if n >= target.m {
                // The null-space part can only be as exact as the Jacobian: relative to the
                // change itself.
                let change = max_abs_diff(&self.alpha, &self.nominal);
                phi <= tol2 && null_part <= opts.tol_mm / self.reach + NULL_REL * change
            } else {
                // Least squares: the miss left is of the order of the deflection; a step
                // below 10⁻⁶ of it changes the miss by far less than the tolerance.
                max_abs(&self.step) * self.reach <= opts.tol_mm + NULL_REL * phi.sqrt()
            };
            if converged {
                break;
            }
            if result.iterations >= opts.max_iter {
                return Ok(result);
            }
            // Trust region, then halve until the miss does not grow.
            let big = max_abs(&self.step);
            let mut t = if big > MAX_STEP_RAD {
                MAX_STEP_RAD / big
            } else {
                1.0
            };
            let mut accepted = false;
            let mut r_trial = [0.0; 3];
            for _ in 0..=MAX_HALVINGS {
                for j in 0..n {
                    self.trial[j] = self.alpha[j] + t * self.step[j];
                }
                let trial = std::mem::take(&mut self.trial);
                let ev = self.evaluate(
                    arm,
                    effects,
                    &trial,
                    payload,
                    sopts,
                    row,
                    &target,
                    &mut r_trial,
                );
                self.trial = trial;
                match ev {
                    Ok(()) => {
                        let phi_t = norm2(&r_trial);
                        let better = if n >= target.m {
                            phi_t <= phi || phi_t <= tol2
                        } else {
                            phi_t <= phi * (1.0 + 1e-12) + tol2
                        };
                        if better {
                            accepted = true;
                            break;
                        }
                    }
                    Err(e) if e.is_pose_failure() => {}
                    Err(e) => return Err(e),
                }
                t *= 0.5;
            }
            if !accepted {
                // Re-evaluate the last accepted iterate so that the workspace matches it.
                let alpha = std::mem::take(&mut self.alpha);
                let ev = self.evaluate(arm, effects, &alpha, payload, sopts, row, &target, &mut r);
                self.alpha = alpha;
                if let Err(e) = ev {
                    return pose_failure(e, result);
                }
                return Ok(result);
            }
            if kind == JacobianKind::Rigid {
                self.broyden(n, target.m, t, &r, &r_trial);
            }
            self.alpha.copy_from_slice(&self.trial);
            r = r_trial;
            phi = norm2(&r);
            result.iterations += 1;
            note_residual(&mut result, &r, &target, &self.ws, n);
        }
        // The commanded pose's own geometry: moment arms and stroke.
        self.ws.frames.fill(arm, &self.alpha);
        if let Err(e) = self.ws.lines.fill(&self.ws.frames, row) {
            return pose_failure(e, result);
        }
        if let Some(act) = self.tiny_moment_arm(arm, opts.min_moment_ratio) {
            result.status = CompensateStatus::NearSingular;
            result.actuator = act;
            return Ok(result);
        }
        for (i, (len, a)) in self.ws.lines.length.iter().zip(&arm.actuators).enumerate() {
            let below = a.min_length.is_some_and(|lo| *len < lo);
            let above = a.max_length.is_some_and(|hi| *len > hi);
            if below || above {
                result.status = CompensateStatus::OutOfStroke;
                result.actuator = (i + 1) as u32;
                return Ok(result);
            }
        }
        result.status = CompensateStatus::Ok;
        Ok(result)
    }

    /// Solves the model at `alpha` and writes the residual into `r`.
    #[allow(clippy::too_many_arguments)]
    fn evaluate(
        &mut self,
        arm: &Arm,
        effects: &EffectSet,
        alpha: &[f64],
        payload: V2,
        sopts: SolveOptions,
        row: usize,
        t: &Target,
        r: &mut [f64; 3],
    ) -> Result<()> {
        self.ws.solve(arm, effects, alpha, payload, sopts, row)?;
        let miss = self.ws.frames.measure + self.ws.dmeasure - t.point;
        r[0] = miss.x;
        r[1] = miss.y;
        r[2] = if t.m == 3 {
            t.scale * wrap_pi(self.ws.new_alpha[arm.n() - 1] - t.angle)
        } else {
            0.0
        };
        Ok(())
    }

    /// The first actuator (1-based) whose moment arm ratio in `self.ws.lines` is below `min`.
    fn tiny_moment_arm(&self, arm: &Arm, min: f64) -> Option<u32> {
        (0..arm.n())
            .find(|&i| self.ws.lines.arm[i].abs() < min * arm.links[i].a.norm())
            .map(|i| (i + 1) as u32)
    }

    /// Fills `self.jac` (m × n, row-major) at the current iterate, whose model solution is in
    /// the workspace and whose residual is `r`.
    #[allow(clippy::too_many_arguments)]
    fn jacobian(
        &mut self,
        arm: &Arm,
        effects: &EffectSet,
        payload: V2,
        sopts: SolveOptions,
        row: usize,
        t: &Target,
        r: &[f64; 3],
        kind: JacobianKind,
    ) -> Result<()> {
        let n = arm.n();
        match kind {
            JacobianKind::Auto | JacobianKind::Rigid => {
                // M = O₁ + Σ_{i<n} R(α_i)·next_i + R(α_n)·m: ∂M/∂α_j = R(α_j + π/2)·v_j, at
                // the loaded angles; the angle row is s·δ_jn.
                for j in 0..n {
                    let v = if j + 1 < n {
                        arm.links[j].next
                    } else {
                        arm.measure
                    };
                    let (s, c) = self.ws.new_alpha[j].sin_cos();
                    self.jac[j] = -(s * v.x + c * v.y);
                    self.jac[n + j] = c * v.x - s * v.y;
                    self.jac[2 * n + j] = if t.m == 3 && j + 1 == n { t.scale } else { 0.0 };
                }
            }
            JacobianKind::FiniteDifference => {
                let mut rj = [0.0; 3];
                for j in 0..n {
                    self.trial.copy_from_slice(&self.alpha);
                    self.trial[j] += FD_STEP_RAD;
                    let trial = std::mem::take(&mut self.trial);
                    let ev = self.evaluate(arm, effects, &trial, payload, sopts, row, t, &mut rj);
                    self.trial = trial;
                    match ev {
                        Ok(()) => {
                            for k in 0..3 {
                                self.jac[k * n + j] = (rj[k] - r[k]) / FD_STEP_RAD;
                            }
                        }
                        // A step across the edge of the model: fall back to the rigid column.
                        Err(e) if e.is_pose_failure() => {
                            let v = if j + 1 < n {
                                arm.links[j].next
                            } else {
                                arm.measure
                            };
                            let (s, c) = self.alpha[j].sin_cos();
                            self.jac[j] = -(s * v.x + c * v.y);
                            self.jac[n + j] = c * v.x - s * v.y;
                            self.jac[2 * n + j] =
                                if t.m == 3 && j + 1 == n { t.scale } else { 0.0 };
                        }
                        Err(e) => return Err(e),
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

    /// The Gauss–Newton step into `self.step`; returns the size of its null-space part (rad),
    /// or `None` at a kinematic singularity.
    fn step(&mut self, n: usize, t: &Target, r: &[f64; 3]) -> Option<f64> {
        let m = t.m;
        let jac = &self.jac;
        if n < m {
            // n = 1: least squares, Δ = −Jᵀr / JᵀJ.
            let (mut jtj, mut jtr) = (0.0, 0.0);
            for k in 0..m {
                jtj += jac[k * n] * jac[k * n];
                jtr += jac[k * n] * r[k];
            }
            if !(jtj > 0.0 && jtj.is_finite()) {
                return None;
            }
            self.step[0] = -jtr / jtj;
            return Some(0.0);
        }
        let mut gram = [[0.0; 3]; 3];
        for a in 0..m {
            for b in 0..=a {
                let s: f64 = (0..n).map(|j| jac[a * n + j] * jac[b * n + j]).sum();
                gram[a][b] = s;
                gram[b][a] = s;
            }
        }
        let l = cholesky(&gram, m, KINEMATIC_SINGULAR)?;
        let y = chol_solve(&l, m, r);
        for j in 0..n {
            self.step[j] = -(0..m).map(|k| jac[k * n + j] * y[k]).sum::<f64>();
        }
        if n == m {
            return Some(0.0);
        }
        // Null-space pull towards the nominal: (I − J⁺J)(α⁰ − α).
        let mut jz = [0.0; 3];
        for (k, v) in jz.iter_mut().enumerate().take(m) {
            *v = (0..n)
                .map(|j| jac[k * n + j] * (self.nominal[j] - self.alpha[j]))
                .sum();
        }
        let w = chol_solve(&l, m, &jz);
        let mut size = 0.0f64;
        for j in 0..n {
            let p = (self.nominal[j] - self.alpha[j])
                - (0..m).map(|k| jac[k * n + j] * w[k]).sum::<f64>();
            self.step[j] += p;
            size = size.max(p.abs());
        }
        Some(size)
    }
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
