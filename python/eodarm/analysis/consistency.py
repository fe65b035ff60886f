"""Is a model's χ² consistent with the noise? The χ² test, or the F test when σ was estimated.

A model that is right leaves whitened residuals r = (y − ŷ)/σ of unit variance, so its
χ² = Σ r² follows a χ² distribution with ``dof`` = values − fitted parameters degrees of
freedom. That holds when σ is *known* (given in the file, or the documented default). When σ
was itself *estimated*, pooled from ν degrees of freedom of repeated measurements, the
whitened χ² is χ²_dof/(s²/σ²) with s²/σ² ~ χ²_ν/ν, and χ²/dof then follows Fisher's
F(dof, ν): a heavier tail, so that a χ²/dof of 1.5 is no evidence against a model when σ
came from six repeats.

Where several channels carry estimated σ of different ν, the denominators of their cells
are independent; their weighted mean (weights: each channel's share of the values) is
matched to one χ²_ν/ν by its variance (Satterthwaite): ν_eff = 1 / Σ_c w_c²/ν_c. Channels
whose σ is known contribute nothing to that sum (ν_c = ∞), and when every channel's σ is
known ν_eff = ∞: the plain χ² test.

**Lack of fit.** When the repeats that gave s are themselves in the fit (the usual case:
:attr:`Measurements.sigma_pooled`), the model predicts the same value for every repeat of a
state, so a fit's χ² splits exactly into the scatter of the repeats about their state means,
W (which is ν for a channel whose every pooled value is used: s was made from it), and the
misfit of the state means, L = χ² − W, which is all a model can change. L and s² are
independent, so the test of the model is the classical lack-of-fit test
L/(dof − ν_W) against F(dof − ν_W, ν) (:func:`fit_p_value`), with ν_W the degrees of freedom
of W among the used cells; testing χ²/dof against F(dof, ν) instead would count the repeats
twice and be blind to a misfit half the size.

Tail probabilities and quantiles come from :mod:`eodarm.analysis.tails` (the regularized
incomplete gamma and beta functions, checked against scipy to 1e-10 in the tests), not from
:mod:`scipy.special` or :mod:`scipy.stats`, whose imports cost 0.2–2.5 s at the start of a
command.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

__all__ = [
    "P_PASS",
    "chi2_p_value",
    "effective_nu",
    "fit_p_value",
    "lr_threshold",
    "sigma_dof",
    "within_states",
]


class FitLike(Protocol):
    """What the tests read of a fit (an :class:`eodarm.analysis.fit.FitResult`): its problem
    (``problem.meas``, ``problem.use``), its χ² and its degrees of freedom. Named by shape,
    not imported, because the fit itself uses these tests (docs/architecture.md, "No
    cycles")."""

    @property
    def problem(self) -> Any: ...

    @property
    def chi2(self) -> float: ...

    @property
    def dof(self) -> int: ...


#: A model "explains the data within their noise" when the p-value of its χ² is at least this.
P_PASS = 1e-3


def chi2_p_value(chi2: float, dof: float, nu: float = math.inf) -> float:
    """P(a right model leaves a χ² at least this large): the χ² test, or F when σ is estimated.

    Parameters
    ----------
    chi2 : the model's whitened χ² (Σ ((measured − model)/σ)²).
    dof : its degrees of freedom (values − fitted parameters), > 0.
    nu : effective degrees of freedom of the σ estimate (:func:`effective_nu`); ``inf``
        (σ known) gives the χ² test P(χ²_dof ≥ chi2), finite ν gives
        P(F(dof, ν) ≥ chi2/dof).
    """
    from eodarm.analysis.tails import chi2_sf, f_sf

    if not dof > 0:
        raise ValueError(f"chi2_p_value: dof must be > 0, got {dof}")
    if not nu > 0:
        raise ValueError(f"chi2_p_value: nu must be > 0, got {nu}")
    if math.isinf(nu):
        return chi2_sf(chi2, dof)
    return f_sf(chi2 / dof, dof, nu)


def lr_threshold(p: float, nu: float = math.inf) -> float:
    """The Δχ² that one added parameter exceeds with probability ``p`` when it is not there.

    χ²₁'s upper ``p`` point for known σ; with σ estimated from ν degrees of freedom, Δχ²
    follows F(1, ν) and its upper ``p`` point is returned.
    """
    from eodarm.analysis.tails import chi2_isf, f_isf

    if math.isinf(nu):
        return chi2_isf(p, 1)
    return f_isf(p, 1, nu)


def sigma_dof(meas: Any) -> npt.NDArray[np.float64]:
    """Degrees of freedom of each channel's σ, in the order of ``meas.channels``.

    Read from ``meas.sigma_dof`` (per channel: a mapping channel → ν, or a sequence in
    channel order; ``inf`` where σ was given in the file or is the default). Measurements
    without that attribute have every σ known: all ``inf``.
    """
    channels = list(meas.channels)
    given = getattr(meas, "sigma_dof", None)
    out = np.full(len(channels), math.inf)
    if given is None:
        return out
    if isinstance(given, Mapping):
        for c, ch in enumerate(channels):
            if ch in given and given[ch] is not None:
                out[c] = float(given[ch])
        return out
    arr = np.asarray(given, dtype=float).ravel()
    if arr.shape != out.shape:
        raise ValueError(
            f"sigma_dof has {arr.size} entries for {len(channels)} channels {tuple(channels)}"
        )
    return np.where(np.isnan(arr), math.inf, arr)


def effective_nu(meas: Any, use: npt.NDArray[np.bool_] | None = None) -> float:
    """Effective degrees of freedom of the σ of the used cells (Satterthwaite; see above).

    ``use`` is the (N, C) mask of the cells in the χ² (default: every measured cell). Every
    used channel's σ known → ``inf``.
    """
    nu = sigma_dof(meas)
    if use is None:
        use = np.isfinite(np.asarray(meas.values, dtype=float))
    counts = np.asarray(use, dtype=bool).sum(axis=0).astype(float)
    total = counts.sum()
    if total == 0:
        return math.inf
    w = counts / total
    finite = (w > 0) & np.isfinite(nu)
    if not finite.any():
        return math.inf
    return float(1.0 / np.sum(w[finite] ** 2 / nu[finite]))


def within_states(fit: FitLike) -> tuple[float, int]:
    """(W, ν_W): the whitened scatter of the used pooled-σ values about their state means,
    and its degrees of freedom Σ(n_g − 1); (0, 0) when no σ was pooled."""
    prob = fit.problem
    meas = prob.meas
    pooled = getattr(meas, "sigma_pooled", None)
    if pooled is None or not np.asarray(pooled).any():
        return 0.0, 0
    from eodarm.data.noise import state_groups

    groups = state_groups(meas.config, meas.alpha_deg, meas.mass_kg)
    cells = np.asarray(pooled, dtype=bool) & prob.use
    w, nu = 0.0, 0
    for c in np.flatnonzero(cells.any(axis=0)):
        rows = np.flatnonzero(cells[:, c])
        z = meas.values[rows, c] / meas.sigma[rows, c]
        g = groups[rows]
        for k in np.unique(g):
            zk = z[g == k]
            if zk.size >= 2:
                w += float(np.sum((zk - zk.mean()) ** 2))
                nu += zk.size - 1
    return w, nu


def fit_p_value(fit: FitLike) -> float:
    """P-value of a fit's χ² with the ν of the σ of the cells it used: the χ² test for known
    σ, the lack-of-fit F test (module docstring) when σ was pooled from repeats in the fit."""
    prob = fit.problem
    nu = effective_nu(prob.meas, prob.use)
    if math.isinf(nu):
        return chi2_p_value(fit.chi2, fit.dof, nu)
    w, nu_w = within_states(fit)
    if 0 < nu_w < fit.dof:
        return chi2_p_value(max(fit.chi2 - w, 0.0), fit.dof - nu_w, nu)
    return chi2_p_value(fit.chi2, fit.dof, nu)
