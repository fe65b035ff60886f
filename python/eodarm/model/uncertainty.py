"""The uncertainty of a prediction, carried from the fit that made the model (CONTRACT §7).

A fitted arm file keeps the covariance C of its fitted parameters p (the ``[fit]`` table,
:class:`~eodarm.model.arm.FitRecord`). A prediction y(p) — the measure point's displacement
and the links' angle changes — then has the covariance J C Jᵀ to first order, with
J = ∂y/∂p. The compiled core gives ∂y/∂θ in each effect's fitting parameter θ (1/stiffness
for springs, the gap itself for play and clearance), so J = ∂y/∂θ · ∂θ/∂p with
∂θ/∂k = −1/k² for a stiffness k. This is linear propagation: it holds while the parameters'
errors are small against the range over which the deflections are linear in θ (they are
nearly linear in θ by construction; docs/diagnosis.md), and it carries only the fitted
parameters' uncertainty — not the model's missing physics, nor the geometry's.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import InputError
from eodarm.model.arm import Arm
from eodarm.model.effects import CATALOGUE, Effect, Slot, theta_from_param

__all__ = ["SIGMA_KEYS", "prediction_sigma", "require_fit"]

#: The outputs that get a standard deviation, and its key.
SIGMA_KEYS = {"dx_mm": "sigma_dx_mm", "dy_mm": "sigma_dy_mm", "dalpha_deg": "sigma_dalpha_deg"}


def _parameters(arm: Arm) -> tuple[list[Slot], npt.NDArray[np.float64]]:
    """The fitted parameters as slots, and their covariance in θ."""
    rec = arm.fit
    if rec is None:
        raise InputError(
            f"arm '{arm.name}' carries no fit: uncertainty needs an arm file written by "
            "'eodarm fit ... -o FITTED.toml' (its [fit] table holds the covariance)"
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
    return slots, rec.matrix() * np.outer(d, d)


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
    """Standard deviations of ``dx_mm``, ``dy_mm`` (N,) and ``dalpha_deg`` (N, n) from the
    arm's fitted covariance, for the model ``effects`` (the arm's own, merged, included).
    With ``nan_on_failure`` a row the core cannot solve gets NaN instead of an error (the
    sweep's cells that are not ok).

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
    out: dict[str, Any] = {
        "sigma_dx_mm": sd[:, 0].copy(),
        "sigma_dy_mm": sd[:, 1].copy(),
        "sigma_dalpha_deg": sd[:, 2 : 2 + n].copy(),
    }
    if not all(math.isfinite(float(x)) for x in cov.ravel()):
        raise InputError(f"arm '{arm.name}': its [fit] covariance is not finite")
    return out
