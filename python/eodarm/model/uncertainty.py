"""The uncertainty of a prediction, carried from the fit that made the model (docs/model.md,
"Prediction errors").

A prediction's standard deviation has two parts, added in quadrature:

* the **parameters' part**. A fitted arm file keeps the covariance C of its fitted
  parameters p (the ``[fit]`` table, :class:`~eodarm.model.arm.FitRecord`). A prediction
  y(p) — the measure point's displacement and the links' angle changes — then has the
  covariance J C Jᵀ to first order, with J = ∂y/∂p. The compiled core gives ∂y/∂θ in each
  effect's fitting parameter θ (1/stiffness for springs, the gap itself for play and
  clearance), so J = ∂y/∂θ · ∂θ/∂p with ∂θ/∂k = −1/k² for a stiffness k. A parameter the
  data gave only a bound for (an ``[[effect]]`` with ``bound``, fixed at its physical end)
  adds (∂y/∂θ · θ₉₅/1.96)², θ₉₅ the θ of its 95 % limit. Linear propagation holds while the
  parameters' errors are small against the range over which the deflections are linear in
  θ (they are nearly linear in θ by construction; docs/diagnosis.md).
* the **model's part**: where the fitted model did not explain its data, the inadequacy
  σ_model of each channel stored in ``[fit].sigma_model`` (from the leave-one-configuration-
  out residuals), the same for every prediction; zero where the model explained its data.

Neither part covers the noise of a future measurement: an interval for a measured value
adds that measurement's own σ.

Load sequences (:func:`sequence_sigma`, ``solve_sequence(..., uncertainty=True)``) have the
same two parts per state. The core's sensitivities are for single loadings, so ∂y/∂θ of each
state is taken by solving the sequences again with each θ moved by the core's own step
(:func:`eodarm.model.steps.core_step`): a central difference, one-sided where θ ± h would
cross a bound (a gap fixed at 0). A state with no memory before it (no friction, no gap)
thus gets the σ :func:`prediction_sigma` gives. A friction's response is piecewise linear in
its limit (docs/model.md §9): the derivative is the slope of the piece the state sits on.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import InputError
from eodarm.model.arm import Arm
from eodarm.model.effects import CATALOGUE, Effect, Slot, theta_from_param

#: z of a two-sided 95 % normal interval.
Z95 = 1.959963984540054

__all__ = [
    "PART_KEYS",
    "SIGMA_KEYS",
    "inadequacy_note",
    "prediction_sigma",
    "require_fit",
    "sequence_sigma",
]

#: The outputs that get a standard deviation, and its key.
SIGMA_KEYS = {"dx_mm": "sigma_dx_mm", "dy_mm": "sigma_dy_mm", "dalpha_deg": "sigma_dalpha_deg"}
#: Every key :func:`prediction_sigma` returns: the totals, then the parameters' and the
#: model's parts of each.
PART_KEYS = tuple(f"sigma{part}_{out}" for part in ("", "_param", "_model") for out in SIGMA_KEYS)


def _parameters(arm: Arm) -> tuple[list[Slot], npt.NDArray[np.float64]]:
    """The fitted parameters as slots, and their covariance in θ; the parameters known only
    by a bound come last, with the variance (θ₉₅/1.96)² and no correlation."""
    rec = arm.fit
    if rec is None:
        raise InputError(
            f"arm '{arm.name}' carries no fit: uncertainty needs the [fit] covariance of an "
            "arm file written by 'eodarm fit ... -o FITTED.toml', or in Python fit.to_arm() "
            "(arm.with_effects(fit.effects) carries the values without it)"
        )
    by_key = {e.key: e for e in arm.effects}
    slots, dtheta = [], []
    for name in rec.parameters:
        key = name.partition(":")[0]
        e = by_key[key]  # the arm file's reader checked that it is there
        slots.append(Slot.of(e))
        kind = CATALOGUE[e.name]
        dtheta.append(-1.0 / (e.value * e.value) if kind.compliance_like else 1.0)
    d = np.array(dtheta)
    cov = rec.matrix() * np.outer(d, d)
    extra = []
    for e, mark in arm.bounded():
        assert mark.limit is not None  # the reader pairs bound and limit
        slots.append(Slot.of(e))
        extra.append((theta_from_param(e.name, mark.limit) / Z95) ** 2)
    if extra:
        k = cov.shape[0]
        full = np.zeros((k + len(extra), k + len(extra)))
        full[:k, :k] = cov
        full[k:, k:] = np.diag(extra)
        cov = full
    return slots, cov


def inadequacy_note(arm: Arm) -> str | None:
    """One line when the arm's fitted model did not explain its data: its χ²/dof and the
    model part of the σ of the sag (or the first measured channel); ``None`` otherwise."""
    rec = arm.fit
    if rec is None or rec.explained is not False:
        return None
    known = dict(rec.sigma_model)
    ch = next((c for c in ("dy_mm", "dx_mm") if c in known), next(iter(known), None))
    part = "" if ch is None else f", {ch.rsplit('_', 1)[0]} {known[ch]:.2g} {ch.rsplit('_', 1)[1]}"
    # short enough for one terminal line after "eodarm: " (the CLI wraps at 100 columns)
    return (
        f"the fitted model does not explain its data (χ²/dof {rec.chi2_per_dof:.2g}): "
        f"σ adds its held-out miss{part}"
    )


def require_fit(arm: Arm) -> None:
    """Refuse (one line) an arm that carries no fitted covariance, before any work."""
    _parameters(arm)


def prediction_sigma(
    arm: Arm,
    alpha: npt.NDArray[np.float64],
    payload: npt.NDArray[np.float64],
    effects: list[Effect],
    self_weight: bool,
    nan_on_failure: bool = False,
) -> dict[str, npt.NDArray[np.float64]]:
    """Standard deviations of ``dx_mm``, ``dy_mm`` (N,) and ``dalpha_deg`` (N, n), for the
    model ``effects`` (the arm's own, merged, included): ``sigma_<out>`` the total,
    ``sigma_param_<out>`` from the fitted parameters' covariance and ``sigma_model_<out>``
    the model's inadequacy (module docstring); total² = param² + model². A channel the fit
    never measured has a NaN model part (and total) when the model did not explain its
    data. With ``nan_on_failure`` a row the core cannot solve gets NaN instead of an error
    (the sweep's cells that are not ok).

    Raises
    ------
    InputError
        When the arm carries no ``[fit]`` table.
    """
    from eodarm.model import native as _core
    from eodarm.model.kinematics import _core_arm

    slots, cov = _parameters(arm)
    n = arm.n
    codes = np.array([e.code for e in effects], dtype=np.int64)
    places = np.array([e.index(n) for e in effects], dtype=np.int64)
    thetas = np.array([theta_from_param(e.name, e.value) for e in effects], dtype=float)
    probes = np.array([s.code for s in slots], dtype=np.int64)
    where = np.array([s.index(n) for s in slots], dtype=np.int64)
    _, jac = _core.jacobian(
        _core_arm(arm),
        alpha,
        payload,
        codes,
        places,
        thetas,
        probes,
        where,
        self_weight,
        nan_on_failure=nan_on_failure,
    )
    # var_k = Σ_ij J_ki C_ij J_kj for every row and channel, without forming J C Jᵀ
    var = np.einsum("rci,ij,rcj->rc", jac, cov, jac)
    sd = np.sqrt(np.clip(var, 0.0, None))  # NaN rows stay NaN
    if not all(math.isfinite(float(x)) for x in cov.ravel()):
        raise InputError(f"arm '{arm.name}': its [fit] covariance is not finite")
    return _parts(arm, sd[:, : 2 + n])


def _parts(arm: Arm, sp: npt.NDArray[np.float64]) -> dict[str, npt.NDArray[np.float64]]:
    """The totals and both parts of ``sp`` (..., 2 + n), the parameters' σ of dx, dy and
    dα₁…dαₙ: the model's part is the same for every solved state; an unsolved one (NaN)
    stays NaN."""
    rec = arm.fit
    assert rec is not None  # _parameters made sure
    channels = ["dx_mm", "dy_mm", *(f"dalpha{k + 1}_deg" for k in range(arm.n))]
    model = np.array([rec.model_sigma(ch) for ch in channels])
    sm = np.where(np.isfinite(sp), model, np.nan)
    total = np.hypot(sp, sm)
    out: dict[str, Any] = {}
    for part, arr in (("", total), ("_param", sp), ("_model", sm)):
        out[f"sigma{part}_dx_mm"] = arr[..., 0].copy()
        out[f"sigma{part}_dy_mm"] = arr[..., 1].copy()
        out[f"sigma{part}_dalpha_deg"] = arr[..., 2:].copy()
    return out


def sequence_sigma(
    arm: Arm,
    effects: list[Effect],
    run: Callable[[list[Effect]], dict[str, npt.NDArray[Any]]],
    base: dict[str, npt.NDArray[Any]],
) -> dict[str, npt.NDArray[np.float64]]:
    """Standard deviations of :func:`eodarm.solve_sequence`'s ``dx_mm``, ``dy_mm`` (N, S)
    and ``dalpha_deg`` (N, S, n), with the keys of :func:`prediction_sigma` (module notes).

    Parameters
    ----------
    arm : the fitted arm (its ``[fit]`` covariance).
    effects : the model (the arm's own effects merged with the caller's).
    run : solves the same sequences under a list of effects (NaN where a state cannot be
        closed), as :func:`eodarm.solve_sequence` did for ``base``.
    base : the sequences solved under ``effects``.

    Raises
    ------
    InputError
        When the arm carries no ``[fit]`` table, or its covariance is not finite.
    """
    from eodarm.model.steps import core_step

    slots, cov = _parameters(arm)
    if not all(math.isfinite(float(x)) for x in cov.ravel()):
        raise InputError(f"arm '{arm.name}': its [fit] covariance is not finite")
    y0 = _sequence_channels(base)
    jac = np.zeros((*y0.shape, len(slots)))
    by_key = {e.key: e for e in effects}
    for j, s in enumerate(slots):
        if cov[j, j] == 0:
            continue  # a parameter known exactly moves nothing
        t0 = theta_from_param(s.name, by_key[s.key].value) if s.key in by_key else 0.0
        h = core_step(arm, s, t0)
        lo, hi = s.kind.theta_bounds
        rest = [e for e in effects if e.key != s.key]

        def at(theta: float, s: Slot = s, rest: list[Effect] = rest) -> npt.NDArray[Any]:
            return _sequence_channels(run([*rest, *_effect_at(s, theta)]))

        if t0 - h >= lo and t0 + h <= hi:
            jac[..., j] = (at(t0 + h) - at(t0 - h)) / (2 * h)
        elif t0 + h <= hi:
            jac[..., j] = (at(t0 + h) - y0) / h
        else:
            jac[..., j] = (y0 - at(t0 - h)) / h
    var = np.einsum("...i,ij,...j->...", jac, cov, jac)
    return _parts(arm, np.sqrt(np.clip(var, 0.0, None)))


def _effect_at(slot: Slot, theta: float) -> list[Effect]:
    """The effect of ``slot`` with fitting parameter ``theta`` (none where that is the
    effect absent; an actuator body or a drive's gear at θ = 0 is rigid, the arm file's
    10²⁰ N/mm or N·mm/rad)."""
    from eodarm.model.arm import MAX_STIFFNESS
    from eodarm.model.catalogue import OWN_SPRINGS
    from eodarm.model.effects import param_from_theta

    value = param_from_theta(slot.name, theta)
    if math.isinf(value):
        return [slot.effect(MAX_STIFFNESS)] if slot.name in OWN_SPRINGS else []
    if value == 0 and not slot.kind.allow_zero:
        return []
    return [slot.effect(value)]


def _sequence_channels(out: dict[str, npt.NDArray[Any]]) -> npt.NDArray[np.float64]:
    """(N, S, 2 + n): dx, dy and dα₁…dαₙ of each state of a sequence solve."""
    return np.concatenate(
        [out["dx_mm"][..., None], out["dy_mm"][..., None], out["dalpha_deg"]], axis=-1
    )
