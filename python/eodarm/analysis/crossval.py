"""Leave one configuration out: how a model predicts the configurations it was not fitted on
(docs/diagnosis.md, "Held-out error")."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.gauss_newton import iterate
from eodarm.analysis.problem import Problem, _rms
from eodarm.data.measurements import Measurements
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, Slot

__all__ = ["CV_EXACT_CONFIGS", "cross_validate"]


def cross_validate(
    arm: Arm,
    meas: Measurements,
    effects: Sequence[Effect | Slot | str],
    self_weight: bool = True,
    by: str = "config",
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
    exclude: npt.NDArray[np.bool_] | None = None,
    start: Sequence[float] | npt.NDArray[np.float64] | None = None,
    exact: bool | None = None,
) -> dict[str, Any]:
    """Leave one configuration out: fit without it, predict it.

    ``exclude`` is an (N, C) mask of cells left out everywhere (outliers): they are neither
    fitted nor predicted. ``start`` is a starting θ for every fold (e.g. the fit on all the
    data, which makes each fold converge in a step or two).

    ``exact``: refit every fold to convergence (True), or take each fold's θ one bounded
    Gauss–Newton step from the fit on all the data, with that fold's rows taken out of the
    normal equations (False; the cost of one fit, whatever the number of configurations).
    The default (None) refits exactly up to :data:`CV_EXACT_CONFIGS` configurations
    (docs/diagnosis.md, "Held-out error of many configurations").

    Returns ``{"rms": {channel: rms over every held-out cell}, "per_config": {label: rms},
    "residual": (N, C) held-out residuals (NaN where not used)}``.
    """
    if by != "config":
        raise EodarmError(f"--cv {by}: only 'config' is supported")
    configs = list(meas.configs)
    if len(configs) < 2:
        raise EodarmError("cross-validation needs at least two configurations")
    slots = [Slot.of(e) for e in effects]
    kw: dict[str, Any] = {"model": model, "fem_options": fem_options}
    full = Problem(arm, meas, self_weight=self_weight, exclude=exclude, **kw)
    resid = np.full_like(meas.values, np.nan)
    labels = np.asarray(meas.config)
    if exact is None:
        exact = len(configs) <= CV_EXACT_CONFIGS
    if not slots:
        # Nothing is fitted: every configuration is predicted by the same model.
        y, _ = full.evaluate([])
        resid = np.where(full.use, meas.values - y, np.nan)
    elif not exact:
        resid = _linearised_folds(arm, meas, slots, full, labels, start)
    else:
        for label in configs:
            held = labels == label
            gone = np.broadcast_to(held[:, None], meas.values.shape)
            train = Problem(
                arm,
                meas,
                self_weight=self_weight,
                exclude=gone if exclude is None else gone | exclude,
                **kw,
            )
            res = iterate(train, slots, start=start)
            # the fit's prediction covers every row, the held-out ones included
            rows = np.flatnonzero(held)
            y = res.prediction[rows]
            resid[rows] = np.where(full.use[rows], meas.values[rows] - y, np.nan)
    per = _rms_by_label(resid, full.use, meas.channels, labels, configs)
    return {"rms": _rms(resid, full.use, meas.channels), "per_config": per, "residual": resid}


#: Up to this many configurations, leave-one-configuration-out refits every fold to
#: convergence; above, each fold is one linearised step from the fit on all the data.
CV_EXACT_CONFIGS = 40


def _linearised_folds(
    arm: Arm,
    meas: Measurements,
    slots: list[Slot],
    full: Problem,
    labels: npt.NDArray[Any],
    start: Sequence[float] | npt.NDArray[np.float64] | None,
) -> npt.NDArray[np.float64]:
    """Held-out residuals (N, C) of every configuration, its fold's θ one bounded Gauss–Newton
    step from the fit on all the data: with A the whitened Jacobian and r the whitened residual
    there, fold k minimises ‖r − A d‖² over the other configurations' cells, i.e. with
    G − G_k = Aᵀ A − A_kᵀ A_k and b − b_k = Aᵀ r − A_kᵀ r_k, within the bounds of θ + d; its
    rows are then predicted as y_k + J_k d. Exact for a model linear in θ (the compliance-like
    θ are nearly so). Costs one fit and (P × P) work per configuration."""
    base = iterate(full, slots, start=start)
    theta = base.theta
    y, jac = full.evaluate(list(zip(slots, theta, strict=True)), slots)
    use = full.use
    sig = np.where(use, meas.sigma, 1.0)
    r = np.where(use, (meas.values - y) / sig, 0.0)  # (N, C)
    a = np.where(use[..., None], jac / sig[..., None], 0.0)  # (N, C, P)
    keys, group = np.unique(labels, return_inverse=True)
    k, p = len(keys), len(slots)
    gk = np.zeros((k, p, p))
    bk = np.zeros((k, p))
    np.add.at(gk, group, np.einsum("ncp,ncq->npq", a, a))
    np.add.at(bk, group, np.einsum("ncp,nc->np", a, r))
    g_all, b_all = gk.sum(axis=0), bk.sum(axis=0)
    lo = np.array([full.bounds(s)[0] for s in slots]) - theta
    hi = np.array([full.bounds(s)[1] for s in slots]) - theta
    d = _box_steps(g_all[None] - gk, b_all[None] - bk, lo, hi)
    pred = y + np.einsum("ncp,np->nc", jac, d[group])
    return np.where(use, meas.values - pred, np.nan)


def _box_steps(
    g: npt.NDArray[np.float64],
    b: npt.NDArray[np.float64],
    lo: npt.NDArray[np.float64],
    hi: npt.NDArray[np.float64],
) -> npt.NDArray[np.float64]:
    """argmin dᵀ G_k d − 2 dᵀ b_k subject to lo ≤ d ≤ hi, for K problems at once ((K, P, P),
    (K, P)); G_k positive semi-definite. As :mod:`eodarm.analysis.boxlsq`: the minimiser is
    the unconstrained one of the unknowns not at a bound, so every assignment of each unknown
    to {free, lower, upper} (finite bounds only) is solved for all K at once and the feasible
    one of least cost kept. Unknowns are scaled by √diag(ΣG) first (θ differ by 1e8)."""
    import itertools

    k, p = b.shape
    scale = np.sqrt(np.abs(np.einsum("kii->i", g)))  # Σ over the K problems of diag G_k
    scale[~(scale > 0)] = 1.0
    gn = g / np.outer(scale, scale)
    bn = b / scale
    lon, hin = lo * scale, hi * scale
    best = np.zeros((k, p))
    cost = np.full(k, np.inf)
    choices = [
        [c for c, v in (("free", 0.0), ("lo", lon[j]), ("hi", hin[j])) if np.isfinite(v)]
        for j in range(p)
    ]
    for pattern in itertools.product(*choices):
        free = np.array([c == "free" for c in pattern])
        x = np.zeros((k, p))
        x[:, ~free] = np.where([c == "hi" for c in pattern], hin, lon)[~free]
        if free.any():
            rhs = bn[:, free] - np.einsum("kij,kj->ki", gn[:, free][:, :, ~free], x[:, ~free])
            inv = np.linalg.pinv(gn[:, free][:, :, free], rcond=1e-12, hermitian=True)
            x[:, free] = np.einsum("kij,kj->ki", inv, rhs)
        tol = 1e-9 * (1.0 + np.abs(x))
        ok = np.all((x >= lon - tol) & (x <= hin + tol), axis=1)
        c = np.einsum("ki,kij,kj->k", x, gn, x) - 2 * np.einsum("ki,ki->k", x, bn)
        better = ok & (c < cost)
        best[better], cost[better] = x[better], c[better]
    return np.clip(best / scale, lo, hi)


def _rms_by_label(
    resid: npt.NDArray[np.float64],
    use: npt.NDArray[np.bool_],
    channels: Sequence[str],
    labels: npt.NDArray[Any],
    order: Sequence[str],
) -> dict[str, dict[str, float]]:
    """:func:`_rms` of each label's rows, in one pass over the cells."""
    keys, group = np.unique(labels, return_inverse=True)
    ok = use
    sq = np.where(use, resid, 0.0) ** 2
    out: dict[str, dict[str, float]] = {}
    count = [
        np.bincount(group, weights=ok[:, c], minlength=len(keys)) for c in range(len(channels))
    ]
    total = [
        np.bincount(group, weights=sq[:, c], minlength=len(keys)) for c in range(len(channels))
    ]
    at = {str(lab): g for g, lab in enumerate(keys.tolist())}
    for label in order:
        g = at[str(label)]
        out[label] = {
            ch: float(np.sqrt(total[c][g] / count[c][g]))
            for c, ch in enumerate(channels)
            if count[c][g] > 0
        }
    return out
