"""The noise of a raw record and the standard errors it gives (docs/records.md, "The
standard error").

N samples at 300 Hz are not N independent readings. Each channel's noise is modelled as
AR(1) plus white noise: autocovariances γ₀ = a + w and γₖ = a φᵏ for k ≥ 1 (a the correlated
part, w the white part), fitted to the lags 0, 1, 2 of the detrended settled samples. The
variance of the mean of n consecutive samples is then the exact sum for that model
(:func:`mean_variance`), and the standard error of a slope uses the model's long-run
variance (:func:`long_run_variance`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = [
    "DRIFT_ALARM",
    "autocov",
    "drift_threshold",
    "joint_threshold",
    "long_run",
    "long_run_variance",
    "mean_standard_error",
    "mean_variance",
    "noise_model",
    "robust_scale",
]

FloatArray = npt.NDArray[np.float64]

#: The family-wise false-alarm rate of the drift test, per record.
DRIFT_ALARM = 0.001


def robust_scale(d: FloatArray) -> FloatArray:
    """1.4826 · median absolute value per column (the σ of Gaussian columns centred on 0)."""
    return 1.4826 * np.median(np.abs(d), axis=0)


def autocov(x: FloatArray, lags: int) -> FloatArray:
    """Sums of lagged products of each column of ``x`` (already centred), lags 0…lags−1."""
    n = x.shape[0]
    out = np.zeros((lags, x.shape[1]))
    for k in range(lags):
        if n > k:
            out[k] = np.einsum("ij,ij->j", x[k:], x[: n - k])
    return out


def long_run_variance(gamma: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The noise model of each channel from its autocovariances γ₀, γ₁, γ₂ (rows of ``gamma``).

    Model: AR(1) plus white noise, γ_k = a·φ^k for k ≥ 1 and γ₀ = a + w; then φ = γ₂/γ₁ and
    a = γ₁/φ. Where γ₁ ≤ 0 or φ ≤ 0 the noise is taken as white (a = 0).

    Returns
    -------
    (gamma0, a, phi) per channel.
    """
    g0, g1, g2 = gamma[0], gamma[1], gamma[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = np.where(g1 > 0, g2 / np.where(g1 > 0, g1, 1.0), 0.0)
    phi = np.clip(phi, 0.0, 0.9995)
    a = np.where(phi > 0, g1 / np.where(phi > 0, phi, 1.0), 0.0)
    a = np.minimum(a, g0)  # the correlated part cannot exceed the whole variance
    return g0, a, phi


def long_run(g0: FloatArray, a: FloatArray, phi: FloatArray) -> FloatArray:
    """The long-run variance per sample, γ₀ + 2 Σₖ γₖ = γ₀ + 2aφ/(1 − φ): n times the variance
    of the mean of n samples for large n."""
    return g0 + 2.0 * a * np.where(phi > 0, phi / (1.0 - phi), 0.0)


def noise_model(
    sums: FloatArray, count: int, segments: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """:func:`long_run_variance` from the lagged sums of ``segments`` detrended runs of
    ``count`` samples in all, corrected for the detrending.

    Removing a run's mean and slope removes its slowest noise too: each measured
    autocovariance is low by about 2·S/n for a run of n samples, S the long-run variance
    (two fitted coefficients). For runs of a few tens of correlation times that is tens of
    per cent of S; the bias is added back, S re-estimated, a few times (a fixed point)."""
    raw = sums / max(count, 1)
    s_lr = np.zeros(raw.shape[1])
    g0, a, phi = long_run_variance(raw)
    for _ in range(6):
        g0, a, phi = long_run_variance(raw + (2.0 * segments / max(count, 1)) * s_lr[None, :])
        s_lr = long_run(g0, a, phi)
    return g0, a, phi


def mean_variance(g0: FloatArray, a: FloatArray, phi: FloatArray, n: int) -> FloatArray:
    """Variance of the mean of ``n`` consecutive samples of the noise model of
    :func:`long_run_variance`: (γ₀ + 2 Σ_{k=1}^{n−1} (1 − k/n) a φ^k) / n."""
    if n < 1:
        return np.full_like(g0, np.inf)
    one = 1.0 - phi
    with np.errstate(divide="ignore", invalid="ignore"):
        s = phi / one - phi * (1.0 - phi**n) / (n * one * one)
    s = np.where(phi > 0, s, 0.0)
    return np.maximum((g0 + 2.0 * a * s) / n, g0 / n * 1e-3)


def detrend(x: FloatArray, t: FloatArray | None = None) -> FloatArray:
    """``x`` minus its least-squares line against ``t`` (default: the sample index)."""
    n = x.shape[0]
    tt = np.arange(n, dtype=float) if t is None else np.asarray(t, dtype=float)
    tc = tt - tt.mean()
    xc = x - x.mean(axis=0)
    den = float((tc * tc).sum())
    if den <= 0:
        return xc
    b = (tc @ xc) / den
    return xc - tc[:, None] * b[None, :]


def mean_standard_error(x: npt.ArrayLike) -> FloatArray:
    """Standard error of the mean of each column of ``x`` (samples × channels), with the
    noise's correlation in time (AR(1) plus white noise fitted to the detrended samples).

    The same estimate as the records command uses for one steady state on its own."""
    a = np.asarray(x, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    r = detrend(a)
    g0, aa, phi = noise_model(autocov(r, 3), a.shape[0], 1)
    return np.sqrt(mean_variance(g0, aa, phi, a.shape[0]))


def drift_threshold(tests: int, alarm: float = DRIFT_ALARM) -> float:
    """|slope| / its standard error beyond which a state drifts: the two-sided normal
    quantile that keeps the family-wise false-alarm rate at ``alarm`` over ``tests`` tests
    (Bonferroni)."""
    from statistics import NormalDist  # scipy.stats would add a second of import

    return NormalDist().inv_cdf(1.0 - alarm / (2.0 * max(tests, 1)))


def joint_threshold(states: int, channels: int, dof: int, alarm: float = DRIFT_ALARM) -> float:
    """z′ R⁻¹ z beyond which the slopes of a state's ``channels`` channels together drift
    (z the slopes over their standard errors, R their correlation) at the false-alarm rate
    ``alarm`` over ``states`` states (Bonferroni): the χ² quantile of ``channels`` degrees of
    freedom when R is known (``dof`` 0), Hotelling's T² quantile C(m − 1)/(m − C) ·
    F(C, m − C) when it was estimated with m = ``dof`` degrees of freedom."""
    from eodarm.analysis.tails import chi2_isf, f_isf

    p = alarm / max(states, 1)
    if dof <= 0:
        return chi2_isf(p, float(channels))
    c, m = float(channels), float(dof)
    return c * (m - 1.0) / (m - c) * f_isf(p, c, m - c)
