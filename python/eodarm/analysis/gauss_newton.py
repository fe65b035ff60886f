"""The bounded Gauss–Newton iteration of a fit, on compliance-like θ (docs/diagnosis.md).

:func:`iterate` takes a :class:`~eodarm.analysis.problem.Problem` and the effects to fit and
returns the θ where χ² is least within the physical bounds, their covariance and the model's
prediction there (:class:`Solution`). :func:`eodarm.analysis.fit.fit` wraps it into a
:class:`~eodarm.analysis.fit.FitResult`; the held-out folds of
:mod:`eodarm.analysis.crossval` call it directly, so that neither the folds nor what a
fitted model hands over (:mod:`eodarm.analysis.handover`) import the result they serve.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm import text
from eodarm.analysis.problem import Z95, Problem
from eodarm.errors import EodarmError
from eodarm.model.effects import Effect, Slot, theta_from_param

__all__ = ["Solution", "iterate"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class Solution:
    """Where the iteration ended.

    Attributes
    ----------
    slots : the fitted effect@place, in the order given.
    theta : (P,) the fitted θ; ``theta_stderr`` (P,) their standard errors, from the
        covariance ``(JᵀJ)⁻¹`` scaled by ``max(1, χ²/dof)`` (a θ at a bound: its half-normal
        error, how far it could go before χ² rises by 1); ``theta_cov`` (P, P).
    at_bound : whether each θ sits at a physical bound.
    prediction : (N, C) the model's channels at ``theta``; ``chi2`` its χ².
    iterations : Gauss–Newton steps taken.
    notes : one line per parameter stuck at a bound or known only from below (the fit warns
        them).
    lower_only : per parameter, whether the data give it only a lower limit: a friction whose
        χ² with the friction holding every state rises by less than 1.96²·max(1, χ²/dof)
        above the minimum (:func:`holds_everything`), so that its 95 % interval has no
        upper end.
    """

    slots: list[Slot]
    theta: FloatArray
    theta_stderr: FloatArray
    theta_cov: FloatArray
    at_bound: list[bool]
    prediction: FloatArray
    chi2: float
    iterations: int
    notes: list[str]
    lower_only: list[bool] = field(default_factory=list)


def iterate(
    prob: Problem,
    effects: Iterable[Effect | Slot | str],
    start: Sequence[float] | FloatArray | None = None,
    max_iter: int = 30,
) -> Solution:
    """Least-squares θ of ``effects`` on ``prob``, within their physical bounds.

    ``Effect`` values give the starting point; ``Slot`` or ``"effect@place"`` start from the
    arm file's value of the same effect@place, else from the effect being absent. ``start``
    (θ, one per effect) overrides them; where it lies outside the model's domain it is moved
    back towards that default start until every state closes.

    Raises
    ------
    EodarmError
        An effect given twice, a place the arm does not have, or a default start at which the
        model cannot be solved.
    """
    given = list(effects)
    slots = [Slot.of(e) for e in given]
    keys = [s.key for s in slots]
    if len(set(keys)) != len(keys):
        raise EodarmError(f"an effect is given twice: {keys}")
    for s in slots:
        s.index(prob.arm.n)
    in_file = {s.key: th for s, th in prob.fixed}
    theta = np.array(
        [
            theta_from_param(e.name, e.value)
            if isinstance(e, Effect)
            else in_file.get(s.key, prob.start(s))  # a file's effect starts at its value
            for s, e in zip(slots, given, strict=True)
        ],
        dtype=float,
    )
    lo = np.array([prob.bounds(s)[0] for s in slots])
    hi = np.array([prob.bounds(s)[1] for s in slots])
    default = np.clip(theta, lo, hi)
    theta = default if start is None else np.clip(np.asarray(start, dtype=float), lo, hi)

    def at(th: npt.NDArray[np.float64]) -> tuple[Any, Any, float]:
        y, jac = prob.evaluate(list(zip(slots, th, strict=True)), slots)
        r = prob.whiten(y)
        return y, jac, float(r @ r)

    # A given start (e.g. diagnose's linearised estimate) may lie outside the model's domain
    # (a measured state that cannot be closed there): move it back towards the default start
    # (the effects absent, or the file's values) until every state closes.
    for lam in (0.5, 0.25, 0.125, 0.0625, 0.0):
        try:
            y, jac, chi2 = at(theta)
            break
        except EodarmError:
            if start is None:
                raise
            theta = default + lam * (np.clip(np.asarray(start, dtype=float), lo, hi) - default)
    else:
        y, jac, chi2 = at(theta)
    from eodarm.analysis.sequences import has_friction

    # With memory the Jacobian costs a solve of every sequence per probe and side: a trial
    # step is judged by its χ² alone, and the Jacobian taken only where one is accepted.
    judge_by_chi2 = prob.meas.has_sequences or has_friction(slots)

    def chi2_of(th: FloatArray) -> tuple[Any, Any, float]:
        if not judge_by_chi2:
            return at(th)
        y, _ = prob.evaluate(list(zip(slots, th, strict=True)), [])
        r = prob.whiten(y)
        return y, None, float(r @ r)

    def descend(
        theta: FloatArray, y: Any, jac: Any, chi2: float, budget: int
    ) -> tuple[FloatArray, Any, Any, float, int, int]:
        """Bounded Gauss–Newton steps from ``theta``, at most ``budget``; the last values are
        the iterations (the one that found no lower χ² included) and the steps accepted."""
        taken = it = 0
        for it in range(1, budget + 1):  # noqa: B007
            if not slots:
                break
            r = prob.whiten(y)
            a = prob.whiten_jac(jac)
            step = _bounded_step(a, r, lo - theta, hi - theta)
            # Backtrack if the exact model disagrees with the linear one (rare: it is ~linear).
            lam = 1.0
            accepted = False
            for _ in range(8):
                trial = np.clip(theta + lam * step, lo, hi)
                try:
                    y2, jac2, chi2b = chi2_of(trial)
                    if chi2b <= chi2 * (1 + 1e-12) + 1e-12:
                        if jac2 is None:  # judged by χ² alone: the Jacobian's probes now
                            y2, jac2, chi2b = at(trial)
                        accepted = True
                        break
                except EodarmError:
                    # The trial, or a probe of its Jacobian, left the model's domain (a
                    # triangle that cannot close, a singular pose): too long a step, like one
                    # that raises χ²; the current θ and its probes were solvable.
                    pass
                lam *= 0.5
            if not accepted:
                break
            improvement = chi2 - chi2b
            theta, y, jac, chi2 = trial, y2, jac2, chi2b
            taken += 1
            if improvement <= 1e-9 * max(chi2, 1.0):
                break
        return theta, y, jac, chi2, it, taken

    theta, y, jac, chi2, it, _ = descend(theta, y, jac, chi2, max_iter)
    # A friction's χ² is piecewise quadratic in its limit, and the step the wide secant gives
    # (docs: analysis/sequences.py) can stop short of the least χ² where the data sit near a
    # kink (measured: up to 0.4 σ). Each friction's slice is searched directly, and the
    # iteration resumed from a better point.
    for _ in range(3):
        better = _polish_frictions(prob, slots, theta, chi2, lo, hi, prob.whiten_jac(jac))
        if better is None:
            break
        y, jac, chi2 = at(better)
        theta, y, jac, chi2, more, taken = descend(better, y, jac, chi2, max_iter)
        it += more
        if taken == 0:
            break  # the others stay where they were: polishing again finds the same
    # Covariance of θ from the whitened Jacobian at the solution.
    stderr = np.full(len(slots), np.nan)
    theta_cov = np.zeros((len(slots), len(slots)))
    at_bound = [bool(theta[i] <= lo[i] + 1e-15 or theta[i] >= hi[i]) for i in range(len(slots))]
    notes: list[str] = []
    scale = max(1.0, chi2 / max(prob.n_values - len(slots), 1))
    if slots:
        a = prob.whiten_jac(jac)
        free = ~np.array(at_bound)
        if free.any():
            # Scale the columns first: θ of different effects differ by 1e8 (mm vs 1/EI),
            # and an unscaled pseudo-inverse would cut the small directions off.
            af = a[:, free]
            norms = np.linalg.norm(af, axis=0)
            norms[norms == 0] = 1.0
            an = af / norms
            cov_n = np.linalg.pinv(an.T @ an) * scale
            stderr[free] = np.sqrt(np.clip(np.diag(cov_n), 0, None)) / norms
            theta_cov[np.ix_(free, free)] = cov_n / np.outer(norms, norms)
        for i, s in enumerate(slots):
            if at_bound[i]:
                # Half-normal bound: how far θ could go before χ² rises by 1.
                col = a[:, i]
                stderr[i] = math.sqrt(scale) / max(float(np.linalg.norm(col)), 1e-300)
                # (a column of zeros: the data do not see it at all, an infinite variance)
                theta_cov[i, i] = stderr[i] ** 2 if stderr[i] < 1e150 else math.inf
                where = "its upper bound" if theta[i] >= hi[i] else "its lower bound (absent)"
                notes.append(f"{s.key}: parameter stuck at {where}; the data do not want it")
    lower_only = [False] * len(slots)
    level = Z95**2 * scale
    for i in holds_everything(prob, slots, theta, at_bound, chi2, level):
        # χ² is flat above the fitted limit: its 95 % interval is [low, ∞), low where the
        # slice rises by `level` below it (the Jacobian's σ may be 0 there, or one side's).
        lower_only[i] = True
        low = _slice_limit(prob, slots, theta, i, chi2 + level, lo[i])
        stderr[i] = (float(theta[i]) - low) / Z95
        theta_cov[i, :] = 0.0
        theta_cov[:, i] = 0.0
        theta_cov[i, i] = stderr[i] ** 2
        notes.append(
            f"{slots[i].key}: the friction could hold every measured state (χ² rises by less "
            f"than the 95 % level when it does): the data say only that it is at least "
            f"{text.value(low, slots[i].kind.unit)}"
        )
    return Solution(slots, theta, stderr, theta_cov, at_bound, y, chi2, it, notes, lower_only)


#: A friction limit that holds every state of any arm the tool can solve (N or N·mm): no
#: force or torque change reaches it, so every element sticks from the reference on.
HOLDING = 1e15


def _slice_chi2(prob: Problem, slots: Sequence[Slot], theta: FloatArray, i: int, t: float) -> float:
    """χ² with θ_i at ``t``, the other parameters held (∞ outside the model's domain)."""
    trial = theta.copy()
    trial[i] = t
    try:
        y, _ = prob.evaluate(list(zip(slots, trial, strict=True)), [])
    except EodarmError:
        return math.inf
    r = prob.whiten(y)
    return float(r @ r)


def _polish_frictions(
    prob: Problem,
    slots: Sequence[Slot],
    theta: FloatArray,
    chi2: float,
    lo: FloatArray,
    hi: FloatArray,
    a: FloatArray,
) -> FloatArray | None:
    """θ with each friction's limit moved to the least χ² of its slice within its secant
    step (a grid of 7, then golden section to 0.01 σ), or None when no friction
    lowers χ² by more than 10⁻⁴·max(1, χ²/dof) (a move of at most 0.01 σ).

    A friction is searched only where its slice is lower 0.1 σ to either side (σ = 1/|a_i|,
    ``a`` the whitened Jacobian; two solves): a minimum more than 0.05 σ away shows so."""
    from eodarm.analysis.sequences import FRICTIONS, friction_step

    out = theta.copy()
    best = chi2
    for i, s in enumerate(slots):
        if s.name not in FRICTIONS:
            continue
        h = friction_step(s, float(out[i]))
        d = 0.1 / max(float(np.linalg.norm(a[:, i])), 1e-300)
        sides = [float(out[i]) + d, max(float(out[i]) - d, lo[i])]
        if min(_slice_chi2(prob, slots, out, i, t) for t in sides) >= best:
            continue  # (best: χ² at `out`)
        left_end, right_end = max(float(out[i]) - h, lo[i]), min(float(out[i]) + h, hi[i])
        grid = np.linspace(left_end, right_end, 7)
        vals = [_slice_chi2(prob, slots, out, i, float(t)) for t in grid]
        k = int(np.argmin(vals))
        left, right = float(grid[max(k - 1, 0)]), float(grid[min(k + 1, 6)])

        def along(t: float, i: int = i) -> float:
            return _slice_chi2(prob, slots, out, i, t)

        x, fx = _golden(along, left, right, 0.1 * d)
        t, f = min([(float(grid[k]), vals[k]), (x, fx)], key=lambda p: p[1])
        if f < best:
            out[i], best = t, f
    enough = 1e-4 * max(1.0, chi2 / max(prob.n_values - len(slots), 1))
    return out if best < chi2 - enough else None


def _golden(
    f: Callable[[float], float], left: float, right: float, tol: float
) -> tuple[float, float]:
    """The least of ``f`` on [left, right] by golden section, to ``tol``: (x, f(x))."""
    g = (math.sqrt(5) - 1) / 2
    x1, x2 = right - g * (right - left), left + g * (right - left)
    f1, f2 = f(x1), f(x2)
    while right - left > tol:
        if f1 <= f2:
            right, x2, f2 = x2, x1, f1
            x1 = right - g * (right - left)
            f1 = f(x1)
        else:
            left, x1, f1 = x1, x2, f2
            x2 = left + g * (right - left)
            f2 = f(x2)
    return (x1, f1) if f1 <= f2 else (x2, f2)


def _slice_limit(
    prob: Problem, slots: Sequence[Slot], theta: FloatArray, i: int, target: float, bound: float
) -> float:
    """The θ_i below ``theta[i]`` where χ², the other parameters held, reaches ``target``
    (``bound`` when it stays below it down to there): steps down doubling, then bisection to
    10⁻⁴ of the bracket's first step."""

    def chi2_at(t: float) -> float:
        trial = theta.copy()
        trial[i] = t
        try:
            y, _ = prob.evaluate(list(zip(slots, trial, strict=True)), [])
        except EodarmError:
            return math.inf  # outside the model's domain: excluded
        r = prob.whiten(y)
        return float(r @ r)

    top = float(theta[i])
    step = max(1e-3 * abs(top), 1e-9)
    inside, outside = top, max(top - step, bound)
    while chi2_at(outside) < target:
        if outside <= bound:
            return bound
        inside, step = outside, 2 * step
        outside = max(top - step, bound)
    first = inside - outside
    while inside - outside > 1e-4 * first:
        mid = 0.5 * (inside + outside)
        if chi2_at(mid) < target:
            inside = mid
        else:
            outside = mid
    return outside


def holds_everything(
    prob: Problem,
    slots: Sequence[Slot],
    theta: FloatArray,
    at_bound: Sequence[bool],
    chi2: float,
    level: float,
) -> list[int]:
    """The frictions among ``slots`` whose 95 % interval has no upper end (docs/model.md §9,
    "A friction that holds every state").

    Above the largest force change a friction element sees, it holds every state and the
    model no longer depends on its limit: χ² is flat from there to infinity. Where the fitted
    limit lies within ``level`` (1.96²·max(1, χ²/dof)) of that flat χ², the data cannot exclude
    any larger limit. The flat χ² is the model with the friction at :data:`HOLDING`, the other
    parameters held at their fitted values (a slice of the profile, not the profile itself:
    refitting them could only lower it and flag more).
    """
    from eodarm.analysis.sequences import FRICTIONS

    out = []
    for i, s in enumerate(slots):
        if s.name not in FRICTIONS or at_bound[i]:
            continue
        trial = theta.copy()
        trial[i] = max(HOLDING, float(theta[i]))
        try:
            y, _ = prob.evaluate(list(zip(slots, trial, strict=True)), [])
        except EodarmError:
            continue  # the friction holding everything cannot be solved: it is excluded
        r = prob.whiten(y)
        if float(r @ r) - chi2 < level:
            out.append(i)
    return out


def _bounded_step(
    a: npt.NDArray[np.float64],
    r: npt.NDArray[np.float64],
    lo: npt.NDArray[np.float64],
    hi: npt.NDArray[np.float64],
) -> npt.NDArray[np.float64]:
    """argmin ||r − a·d|| subject to lo ≤ d ≤ hi (exact; :mod:`eodarm.analysis.boxlsq`)."""
    from eodarm.analysis.boxlsq import bounded_lstsq

    return bounded_lstsq(a, r, lo, hi)
