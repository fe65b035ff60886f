"""Compensation with user-written effects (docs/compensation.md §2).

The core's batch Newton (:func:`eodarm.compensate`) evaluates the model inside the compiled
iteration, where a user's Python function cannot be called. With user-written effects the
compensation is therefore finished here, in Python, on the full model:

1. the core compensates the poses with the catalogue's effects alone (its quasi-Newton or
   exact Jacobian, fast); that pose is the start (the nominal pose where it failed);
2. Gauss–Newton on the same conditions r(α) = (M′(α) − M⁰, s·(α′_n − α⁰_n)) with the full
   model, every residual from :func:`eodarm.solve` with the user effects, the Jacobian by
   forward differences (step 10⁻⁷ rad), batched: one solve of N·(n + 1) poses per step, so a
   user function is called once per place and step. The step is the minimum-norm one,
   Δ = −J⁺r (least squares for one link), limited to 0.5 rad and halved, at most ten times,
   while it does not reduce |r|;
3. for n > 3, the spare freedom is spent as in the core: steps along the set of solutions
   towards the nominal pose, z = (I − J⁺J)(α⁰ − α), each brought back onto the conditions
   by step 2 and kept only if |α − α⁰| shrank.

Statuses are the core's: ``near_singular`` where the model cannot be solved at an iterate
(the actuator named from the solver's message) or J loses rank, ``out_of_stroke`` for a
converged pose outside a stroke, ``no_convergence`` after ``max_iter`` steps.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import EffectError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect
from eodarm.model.solver import forward, solve, stroke_violations
from eodarm.model.validity import arm_reach

__all__ = ["refine"]

FloatArray = npt.NDArray[np.float64]

#: Forward-difference step of the Jacobian, rad.
FD_STEP_RAD = 1e-7
#: Largest change of any angle in one step, rad (the core's trust region).
MAX_STEP_RAD = 0.5
#: Halvings of a step that does not reduce the miss.
HALVINGS = 10
#: σ_min/σ_max of J below this: a kinematic singularity.
RANK_RATIO = 1e-6
#: Steps of the smallest-change phase (n > 3).
PHASE2_STEPS = 30


class _Model:
    """The conditions r(α) of a set of poses under the full model (user effects included)."""

    def __init__(
        self,
        arm: Arm,
        nominal: FloatArray,
        mass: FloatArray,
        effects: Sequence[Effect],
        self_weight: bool,
    ) -> None:
        self.arm, self.mass, self.effects, self.self_weight = arm, mass, list(effects), self_weight
        self.n = arm.n
        self.target = forward(arm, nominal)["measure"]
        self.last = np.radians(nominal[:, -1])
        self.scale = float(np.hypot(*arm.links[-1].next))
        self.p = 3 if self.n >= 3 else 2  # conditions per pose
        self.actuator = np.zeros(nominal.shape[0], dtype=np.int64)  # of the last failure

    def residual(self, alpha: FloatArray, rows: npt.NDArray[np.intp]) -> FloatArray:
        """r (k, p) of poses ``rows`` at angles ``alpha`` (k, n), degrees; NaN rows where
        the model cannot be solved (the actuator of the solver's message is kept)."""
        try:
            return self._residual(alpha, rows)
        except EffectError:
            raise  # a user function's failure is the user's to see
        except ValueError:
            pass
        out = np.full((rows.size, self.p), np.nan)
        for j, row in enumerate(rows):
            try:
                out[j] = self._residual(alpha[j : j + 1], rows[j : j + 1])[0]
            except EffectError:
                raise
            except ValueError as exc:
                m = re.search(r"actuator (\d+)", str(exc))
                self.actuator[row] = int(m.group(1)) if m else 0
        return out

    def _residual(self, alpha: FloatArray, rows: npt.NDArray[np.intp]) -> FloatArray:
        s = solve(
            self.arm,
            alpha,
            self.mass[rows],
            self.effects,
            self_weight=self.self_weight,
            strict=True,
        )
        point = forward(self.arm, alpha)["measure"] + np.column_stack([s["dx_mm"], s["dy_mm"]])
        r = point - self.target[rows]
        if self.p == 2:
            return r
        turn = np.radians(alpha[:, -1] + s["dalpha_deg"][:, -1]) - self.last[rows]
        return np.column_stack([r, self.scale * turn])

    def jacobian(self, alpha: FloatArray, r: FloatArray, rows: npt.NDArray[np.intp]) -> FloatArray:
        """∂r/∂α (k, p, n) per radian, by forward differences in one batched solve."""
        k, n = alpha.shape
        h = np.degrees(FD_STEP_RAD)
        probe = np.repeat(alpha[:, None, :], n, axis=1) + h * np.eye(n)[None]
        rp = self.residual(probe.reshape(k * n, n), np.repeat(rows, n)).reshape(k, n, self.p)
        return np.transpose((rp - r[:, None, :]) / FD_STEP_RAD, (0, 2, 1))


def _pinv(jac: FloatArray) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
    """Pseudo-inverses (k, n, p) and which Jacobians keep their rank."""
    bad = np.logical_not(np.isfinite(jac).all(axis=(1, 2)))
    safe = np.where(bad[:, None, None], 0.0, jac)
    sv = np.linalg.svd(safe, compute_uv=False)
    full: npt.NDArray[np.bool_] = np.logical_and(~bad, sv[:, -1] > RANK_RATIO * sv[:, 0])
    return np.linalg.pinv(safe), full


def _newton(
    model: _Model,
    alpha: FloatArray,
    rows: npt.NDArray[np.intp],
    max_iter: int,
    tol_mm: float,
    iterations: npt.NDArray[np.int64],
) -> tuple[FloatArray, FloatArray, npt.NDArray[np.int64]]:
    """Gauss–Newton onto the conditions for poses ``rows`` from ``alpha`` (k, n), degrees.

    Returns the angles, |r| of the position (mm; NaN where unsolvable) and a code per pose:
    0 converged, 1 not solvable or rank lost (near_singular), 2 out of steps."""
    alpha = alpha.copy()
    r = model.residual(alpha, rows)
    code = np.where(np.isfinite(r).all(axis=1), 2, 1).astype(np.int64)
    prev = np.full(rows.size, np.inf)
    for _ in range(max_iter):
        norm = np.linalg.norm(r, axis=1)
        done = (norm <= tol_mm) & (code == 2)
        if model.n == 1:  # least squares: converged when a step no longer moves the point
            done |= (prev <= tol_mm + 1e-5 * norm) & (code == 2)
        code[done] = 0
        act = np.flatnonzero(code == 2)
        if act.size == 0:
            break
        iterations[rows[act]] += 1
        jac = model.jacobian(alpha[act], r[act], rows[act])
        pinv, full = _pinv(jac)
        code[act[~full]] = 1
        act, pinv, jac = act[full], pinv[full], jac[full]
        step = -np.einsum("knp,kp->kn", pinv, r[act])
        big = np.abs(step).max(axis=1, initial=0.0)
        step *= np.minimum(1.0, MAX_STEP_RAD / np.maximum(big, 1e-300))[:, None]
        t = np.ones(act.size)
        todo = np.arange(act.size)
        for _half in range(HALVINGS + 1):
            trial = alpha[act[todo]] + np.degrees(t[todo, None] * step[todo])
            rt = model.residual(trial, rows[act[todo]])
            better = np.linalg.norm(rt, axis=1) < norm[act[todo]]  # NaN: not better
            keep = todo[better]
            moved = np.abs(jac[keep] @ (t[keep, None] * step[keep])[..., None])[..., 0]
            prev[act[keep]] = np.linalg.norm(moved[:, :2], axis=1)
            alpha[act[keep]] = trial[better]
            r[act[keep]] = rt[better]
            todo = todo[~better]
            if todo.size == 0:
                break
            t[todo] *= 0.5
        if todo.size:  # no halving reduced the miss: a least-squares optimum, or stuck
            stuck = act[todo]
            if model.n == 1:
                code[stuck] = 0
            else:
                code[stuck] = 3  # no step reduces the miss: no_convergence
    code[code == 3] = 2
    return alpha, np.linalg.norm(r[:, :2], axis=1), code


def _smallest_change(
    model: _Model,
    nominal: FloatArray,
    alpha: FloatArray,
    rows: npt.NDArray[np.intp],
    max_iter: int,
    tol_mm: float,
    iterations: npt.NDArray[np.int64],
) -> FloatArray:
    """For n > 3: move converged poses along the solutions towards the nominal ones."""
    alpha = alpha.copy()
    live = np.arange(rows.size)
    reach = arm_reach(model.arm)
    for _ in range(PHASE2_STEPS):
        if live.size == 0:
            break
        r = model.residual(alpha[live], rows[live])
        jac = model.jacobian(alpha[live], r, rows[live])
        pinv, full = _pinv(jac)
        d = np.radians(nominal[live] - alpha[live])
        proj = np.eye(model.n)[None] - pinv @ np.where(np.isfinite(jac), jac, 0.0)
        z = np.einsum("kij,kj->ki", proj, d)
        small = np.abs(z).max(axis=1) < tol_mm / reach + 1e-5 * np.abs(d).max(axis=1)
        live = live[full & ~small]
        z = z[full & ~small]
        if live.size == 0:
            break
        trial, _, code = _newton(
            model, alpha[live] + np.degrees(z), rows[live], max_iter, tol_mm, iterations
        )
        gain = np.linalg.norm(nominal[live] - trial, axis=1) < np.linalg.norm(
            nominal[live] - alpha[live], axis=1
        )
        ok = (code == 0) & gain
        alpha[live[ok]] = trial[ok]
        live = live[ok]
    return alpha


def refine(
    arm: Arm,
    nominal: FloatArray,
    mass: FloatArray,
    effects: Sequence[Effect],
    self_weight: bool,
    start: dict[str, npt.NDArray[Any]],
    max_iter: int,
    tol_mm: float,
) -> dict[str, npt.NDArray[Any]]:
    """Compensate ``nominal`` (N, n) with the full model ``effects`` (user effects
    included), from ``start`` (the core's compensation with the catalogue's effects); the
    same outputs as :func:`eodarm.compensate`."""
    count = nominal.shape[0]
    model = _Model(arm, nominal, mass, effects, self_weight)
    begin = np.where(np.isfinite(start["alpha_deg"]), start["alpha_deg"], nominal)
    rows = np.arange(count)
    iterations = np.zeros(count, dtype=np.int64)
    alpha, miss, code = _newton(model, begin, rows, max_iter, tol_mm, iterations)
    if arm.n > 3 and (code == 0).any():
        good = np.flatnonzero(code == 0)
        alpha[good] = _smallest_change(
            model, nominal[good], alpha[good], good, max_iter, tol_mm, iterations
        )
        r = model.residual(alpha[good], good)
        miss[good] = np.linalg.norm(r[:, :2], axis=1)
    status = np.array(["ok", "near_singular", "no_convergence"], dtype=object)[code]
    actuator = np.where(code == 1, model.actuator, 0)
    length = np.full((count, arm.n), np.nan)
    good = np.flatnonzero(code == 0)
    if good.size:
        length[good] = forward(arm, alpha[good])["length_mm"]
        out = stroke_violations(arm, length[good]) != 0
        hit = out.any(axis=1)
        status[good[hit]] = "out_of_stroke"
        actuator[good[hit]] = np.argmax(out[hit], axis=1) + 1
    bad = status != "ok"
    alpha[bad] = np.nan
    length[bad] = np.nan
    return {
        "alpha_deg": alpha,
        "length_mm": length,
        "residual_mm": miss,
        "status": status.astype(str),
        "iterations": iterations,
        "actuator": actuator.astype(np.int64),
    }
