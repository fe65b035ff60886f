"""Steady states of raw records and the standard errors of their means (docs/records.md).

The detector, in four steps, every threshold from the record's own noise:

1. **Blocks.** The samples are cut into blocks of ``B`` samples, ``B`` a few correlation
   times of the noise (from the lag-1 correlation of the first differences, robust to the
   few steps in the record) and at most a quarter of the shortest steady state.
2. **Runs.** Two neighbouring blocks belong to one run when, on every channel, their means
   differ by at most :data:`K_BREAK` times that channel's typical difference of neighbouring
   block means (1.4826 · median absolute difference: most neighbours lie inside a steady
   state, so the median sees the noise, not the steps). A weight placed by hand, the arm
   ringing, a hand on the plate break the chain.
3. **States.** A run that lasts at least ``min_duration_s`` is a steady state; neighbouring
   states at the same level (a break by chance) are merged. The first and the last block of
   a state (but not at the record's ends), and further leading or trailing blocks off the
   state's median by more than :data:`K_TRIM` block-noise units (at most a third of the
   state at its start, a tenth at its end), are not averaged: the tail of a transient, the
   start of the next.
4. **Drift.** Per channel, the slope of the averaged samples against time with its standard
   error; a slope beyond :func:`drift_threshold` (a family-wise false-alarm rate of 0.1 % per
   record) is a drift: the state is refused unless drift is allowed.

The standard error of a state's mean accounts for the correlation of the noise in time
(:func:`long_run_variance`): the noise is modelled as AR(1) plus white noise, fitted per channel
to the detrended averaged samples of all the record's states together.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.data.records import Campaign, Record, RecordError, RecordSpec, read_record

__all__ = [
    "RecordResult",
    "State",
    "analyse_campaign",
    "analyse_record",
    "check",
    "drift_threshold",
    "long_run_variance",
    "mean_standard_error",
    "steady_states",
]

FloatArray = npt.NDArray[np.float64]

#: Neighbouring block means further apart than this many typical differences break a run.
K_BREAK = 5.0
#: A leading or trailing block further than this many block-noise units from the state's
#: median is not averaged.
K_TRIM = 3.0
#: The family-wise false-alarm rate of the drift test, per record.
DRIFT_ALARM = 0.001
#: A steady state spans at least this many blocks.
MIN_BLOCKS = 4
#: The block size is estimated from at most this many samples (in runs of 1024).
SCALE_SAMPLES = 131072
#: Default shortest steady state, s.
MIN_DURATION_S = 2.0


@dataclass
class State:
    """One steady state of a record.

    Attributes
    ----------
    start, stop : the averaged samples are ``start:stop`` (indices into the record).
    span : (first, last) sample index of the whole state, its unaveraged edges included.
    t0, t1 : time of the first and last averaged sample, s.
    mean : (C,) mean of the averaged samples per channel.
    stderr : (C,) standard error of ``mean``, correlation in time included.
    slope : (C,) drift rate, channel units per second.
    slope_se : (C,) standard error of ``slope``.
    drift : whether a channel's slope is beyond :func:`drift_threshold`.
    """

    start: int
    stop: int
    span: tuple[int, int]
    t0: float
    t1: float
    mean: FloatArray
    stderr: FloatArray = field(default_factory=lambda: np.zeros(0))
    slope: FloatArray = field(default_factory=lambda: np.zeros(0))
    slope_se: FloatArray = field(default_factory=lambda: np.zeros(0))
    drift: bool = False


@dataclass
class RecordResult:
    """The steady states of one record, matched to its payloads.

    ``rows`` holds one dict per state after the reference: ``config``, ``alpha_deg``,
    ``mass_kg``, ``step`` (1, 2, …), ``values`` and ``sigma`` (by channel).
    ``refused`` is the one-line reason when the record was refused (then ``rows`` is empty).
    """

    spec: RecordSpec
    channels: tuple[str, ...]
    states: list[State]
    rows: list[dict[str, Any]]
    block: int
    refused: str | None = None
    refused_states: list[int] = field(default_factory=list)
    n_samples: int = 0

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` entry of the record: per state its times, payload, means, standard
        errors and drift rates."""
        states = []
        masses = self.spec.masses_kg
        for k, s in enumerate(self.states):
            states.append(
                {
                    "step": k,
                    "start_s": s.t0,
                    "end_s": s.t1,
                    "mass_kg": masses[k] if k < len(masses) and self.refused is None else None,
                    "mean": _by(self.channels, s.mean),
                    "stderr": _by(self.channels, s.stderr),
                    "drift_per_s": _by(self.channels, s.slope),
                    "drift": bool(s.drift),
                }
            )
        return {
            "file": str(self.spec.file),
            "config": self.spec.config,
            "samples": self.n_samples,
            "states": states,
            "refused": self.refused,
        }


def _by(channels: Sequence[str], v: FloatArray) -> dict[str, float]:
    return {c: float(x) for c, x in zip(channels, v, strict=True)}


# ---------------------------------------------------------------------------- noise
def _robust_scale(d: FloatArray) -> FloatArray:
    """1.4826 · median absolute value per column (the σ of Gaussian columns centred on 0)."""
    return 1.4826 * np.median(np.abs(d), axis=0)


def _block_size(values: FloatArray, cap: int) -> int:
    """Samples per block: twice the smallest block length ``B`` (a power of 2) at which
    ``B`` times the variance of the difference of neighbouring block means has reached 80 %
    of its largest value, on the channel that needs the longest, clipped to [8, ``cap``].

    For noise without correlation ``B·var`` is the same for every ``B``; for correlated noise
    it grows with ``B`` until the blocks are longer than the correlation (it then equals twice
    the long-run variance), whatever mix of correlated and white noise the channel has. The
    variance is robust (1.4826 · median absolute difference), so that the few differences
    across a step or a transient do not count. At most :data:`SCALE_SAMPLES` samples are used,
    in runs spread over the record."""
    n, c = values.shape
    top = 1 << max(3, math.floor(math.log2(max(cap, 8))))
    w = max(16 * top, 1024)
    if n > max(SCALE_SAMPLES, 2 * w):
        k = max(1, SCALE_SAMPLES // w)
        starts = np.linspace(0, n - w, k).astype(np.int64)
        chunks = [values[s0 : s0 + w] for s0 in starts]
    else:
        chunks = [values]
    sizes = []
    f = []
    b = 1
    while b <= top:
        diffs = []
        for x in chunks:
            m = x.shape[0] // b
            if m >= 3:
                bm = x[: m * b].reshape(m, b, c).mean(axis=1)
                diffs.append(np.diff(bm, axis=0))
        if not diffs or sum(len(d) for d in diffs) < 16:
            break
        f.append(b * _robust_scale(np.concatenate(diffs)) ** 2)
        sizes.append(b)
        b *= 2
    if not f:
        return max(1, min(8, cap))
    fa = np.array(f)  # (len(sizes), C)
    reach = fa >= 0.8 * fa.max(axis=0)
    first = reach.argmax(axis=0)  # per channel, the first size that reaches 80 %
    best = sizes[int(first.max())]
    return int(max(8, min(cap, 2 * best)))


def _autocov(x: FloatArray, lags: int) -> FloatArray:
    """Sums of lagged products of each column of ``x`` (already centred), lags 0…lags−1."""
    n = x.shape[0]
    out = np.zeros((lags, x.shape[1]))
    for k in range(lags):
        if n > k:
            out[k] = (x[k:] * x[: n - k]).sum(axis=0)
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


def _noise_model(
    sums: FloatArray, count: int, segments: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """:func:`long_run_variance` from the lagged sums of ``segments`` detrended runs of
    ``count`` samples in all, corrected for the detrending.

    Removing a run's mean and slope removes its slowest noise too: each measured
    autocovariance is low by about 2·S/n for a run of n samples, S the long-run variance
    (two fitted coefficients). For runs of a few tens of correlation times that is tens of
    per cent of S; the bias is added back, S re-estimated, a few times (a fixed point)."""
    raw = sums / count
    s_lr = np.zeros(raw.shape[1])
    for _ in range(6):
        g0, a, phi = long_run_variance(raw + (2.0 * segments / count) * s_lr[None, :])
        s_lr = g0 + 2.0 * a * np.where(phi > 0, phi / (1.0 - phi), 0.0)
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


def mean_standard_error(x: npt.ArrayLike) -> FloatArray:
    """Standard error of the mean of each column of ``x`` (samples × channels), with the
    noise's correlation in time (AR(1) plus white noise fitted to the detrended samples).

    The same estimate as the records command uses for one steady state on its own."""
    a = np.asarray(x, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    r = _detrend(a)
    g0, aa, phi = _noise_model(_autocov(r, 3), a.shape[0], 1)
    return np.sqrt(mean_variance(g0, aa, phi, a.shape[0]))


def _detrend(x: FloatArray, t: FloatArray | None = None) -> FloatArray:
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


def drift_threshold(tests: int) -> float:
    """|slope| / its standard error beyond which a state drifts: the two-sided normal
    quantile that keeps the family-wise false-alarm rate at :data:`DRIFT_ALARM` over
    ``tests`` tests (Bonferroni)."""
    from statistics import NormalDist  # scipy.stats would add a second of import

    return NormalDist().inv_cdf(1.0 - DRIFT_ALARM / (2.0 * max(tests, 1)))


# ---------------------------------------------------------------------------- detector
def steady_states(
    time_s: npt.ArrayLike,
    values: npt.ArrayLike,
    min_duration_s: float = MIN_DURATION_S,
) -> tuple[list[State], int]:
    """The steady states of one record, their means, standard errors and drift rates.

    Parameters
    ----------
    time_s : (N,) sample times, s, increasing.
    values : (N, C) readings.
    min_duration_s : shortest steady state, s.

    Returns
    -------
    (states, block): the states in time order (``drift`` set where a slope is beyond
    :func:`drift_threshold` over all the record's states and channels) and the block size
    in samples.
    """
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(values, dtype=float)
    if v.ndim == 1:
        v = v[:, None]
    n, c = v.shape
    if n < 2 * 8:
        return [], max(n, 1)
    dt = float(np.median(np.diff(t)))
    per_state = max(1, int(min_duration_s / dt)) if dt > 0 else n
    cap = max(8, per_state // MIN_BLOCKS, 8)
    b = _block_size(v, cap)
    nb = n // b
    if nb < MIN_BLOCKS:
        return [], b
    bm = v[: nb * b].reshape(nb, b, c).mean(axis=1)
    bt = t[: nb * b].reshape(nb, b)
    d = np.diff(bm, axis=0)
    sd = _robust_scale(d)
    tiny = 1e-12 * np.maximum(np.abs(bm).max(axis=0), 1.0)
    q = _resolution(v)
    sd = np.maximum(np.maximum(sd, tiny), q)  # a change of less than a quantum is no break
    same = (np.abs(d) <= K_BREAK * sd).all(axis=1)
    # runs of blocks connected by `same`
    runs: list[list[int]] = []
    start = 0
    for j in range(nb - 1):
        if not same[j]:
            runs.append([start, j + 1])
            start = j + 1
    runs.append([start, nb])
    min_blocks = max(MIN_BLOCKS, math.ceil(min_duration_s / max(dt * b, 1e-300)))
    sb = sd / math.sqrt(2.0)  # noise of one block mean
    # merge neighbouring runs at one level (a break by chance), then keep the long ones
    merged: list[list[int]] = []
    for r in runs:
        if merged and r[0] == merged[-1][1] and r[1] - r[0] >= 1:
            prev = merged[-1]
            m1 = bm[prev[0] : prev[1]].mean(axis=0)
            m2 = bm[r[0] : r[1]].mean(axis=0)
            se = sb * math.sqrt(1.0 / (prev[1] - prev[0]) + 1.0 / (r[1] - r[0]))
            if (
                prev[1] - prev[0] >= MIN_BLOCKS
                and r[1] - r[0] >= MIN_BLOCKS
                and (np.abs(m1 - m2) <= K_BREAK * se).all()
            ):
                prev[1] = r[1]
                continue
        merged.append(list(r))
    states: list[State] = []
    for r0, r1 in merged:
        if r1 - r0 < min_blocks:
            continue
        # guard blocks: the first is the tail of what came before, the last the gentle start
        # of what comes next (a hand reaching the plate), both below the break threshold
        a0 = r0 + 1 if r0 > 0 else r0
        a1 = r1 - 1 if r1 < nb else r1
        med = np.median(bm[a0:a1], axis=0)
        # a transient's tail is short: at most a tenth of the state is trimmed at each end,
        # so that a drift (off the median at both ends) stays in the averaged part and is seen
        lo = a0 + max(1, (a1 - a0) // 3)  # a transient's tail: at most a third at the start
        hi = a1 - max(1, (a1 - a0) // 10)  # what comes next: at most a tenth at the end
        while a0 < lo and a1 - a0 > MIN_BLOCKS and (np.abs(bm[a0] - med) > K_TRIM * sb).any():
            a0 += 1
        while a1 > hi and a1 - a0 > MIN_BLOCKS and (np.abs(bm[a1 - 1] - med) > K_TRIM * sb).any():
            a1 -= 1
        i0, i1 = a0 * b, a1 * b
        last = r1 * b if r1 < nb else n
        states.append(
            State(
                start=i0,
                stop=i1,
                span=(r0 * b, last - 1),
                t0=float(bt[a0, 0]),
                t1=float(bt[a1 - 1, -1]),
                mean=v[i0:i1].mean(axis=0),
            )
        )
    _errors(t, v, states, q)
    return states, b


def _resolution(v: FloatArray) -> FloatArray:
    """Each channel's resolution: the smallest non-zero change between two samples (of the
    first 2¹⁷), 0 for a constant channel. A logger that writes few decimals quantises."""
    d = np.abs(np.diff(v[: SCALE_SAMPLES + 1], axis=0))
    d[d == 0] = np.inf
    q = d.min(axis=0) if d.shape[0] else np.zeros(v.shape[1])
    return np.where(np.isfinite(q), q, 0.0)


def _errors(t: FloatArray, v: FloatArray, states: list[State], q: FloatArray) -> None:
    """Standard errors and drift rates of every state, the noise model of each channel
    fitted to all the states' detrended samples together."""
    if not states:
        return
    c = v.shape[1]
    gam = np.zeros((3, c))
    count = 0
    dens = []
    for s in states:
        x = v[s.start : s.stop]
        tc = t[s.start : s.stop] - t[s.start : s.stop].mean()
        den = float(tc @ tc)
        r = x - s.mean
        s.slope = (tc @ r) / den if den > 0 else np.zeros(c)
        r -= tc[:, None] * s.slope[None, :]
        gam += _autocov(r, 3)
        count += r.shape[0]
        dens.append(den)
    g0, a, phi = _noise_model(gam, count, len(states))
    lrv = g0 + 2.0 * a * np.where(phi > 0, phi / (1.0 - phi), 0.0)  # per-sample long-run var.
    thr = drift_threshold(len(states) * c)
    for s, den in zip(states, dens, strict=True):
        # a quantised reading is known to ±q/2 however long it is averaged (q²/12), and a
        # trend of less than a quantum over the state is not seen
        s.stderr = np.sqrt(mean_variance(g0, a, phi, s.stop - s.start) + q * q / 12.0)
        span = max(float(t[s.stop - 1] - t[s.start]), 1e-300)
        s.slope_se = np.sqrt(lrv / den + (q / span) ** 2) if den > 0 else np.full(c, np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.abs(s.slope) / s.slope_se
        s.drift = bool((np.nan_to_num(z, nan=0.0) > thr).any())


# ---------------------------------------------------------------------------- a record
def analyse_record(
    record: Record,
    spec: RecordSpec,
    allow_drift: bool = False,
    min_duration_s: float = MIN_DURATION_S,
) -> RecordResult:
    """Find the steady states of ``record``, match them in order to ``spec.masses_kg`` and
    make the rows of the measurement file: each state after the reference, minus the
    reference, with the standard error of that difference.

    A record that cannot be matched is not raised on here: ``refused`` holds the one-line
    reason (so that its figure can still be drawn); :func:`check` raises it.
    """
    states, block = steady_states(record.time_s, record.values, min_duration_s)
    res = RecordResult(spec, record.channels, states, [], block, n_samples=record.time_s.size)
    f = record.path
    masses = spec.masses_kg
    if len(states) != len(masses):
        when = ", ".join(f"{s.t0:.1f}–{s.t1:.1f}" for s in states) or "none"
        more = "more" if len(states) > len(masses) else "fewer"
        res.refused = (
            f"{f}: found {len(states)} steady state{'' if len(states) == 1 else 's'} "
            f"(at {when} s), {more} than the "
            f"{len(masses)} payloads of masses_kg"
            + (
                "; a payload skipped or a pause too short?"
                if more == "fewer"
                else "; a pause counted as a state?"
            )
        )
        return res
    drifting = [k for k, s in enumerate(states) if s.drift]
    if drifting and not allow_drift:
        k = drifting[0]
        s = states[k]
        z = np.abs(s.slope) / s.slope_se
        j = int(np.nanargmax(z))
        res.refused = (
            f"{f}: the steady state at {s.t0:.1f}–{s.t1:.1f} s (payload {masses[k]:g} kg) "
            f"drifts: {record.channels[j]} {s.slope[j]:.3g} per s, {z[j]:.1f} times its "
            f"standard error (limit {drift_threshold(len(states) * len(record.channels)):.1f}); "
            "--allow-drift keeps it"
        )
        res.refused_states = drifting
        return res
    ref = states[0]
    for k, s in enumerate(states[1:], start=1):
        diff = s.mean - ref.mean
        sig = np.sqrt(s.stderr**2 + ref.stderr**2)
        res.rows.append(
            {
                "config": spec.config,
                "alpha_deg": spec.alpha_deg,
                "mass_kg": masses[k],
                "step": k,
                "values": _by(record.channels, diff),
                "sigma": _by(record.channels, sig),
                "drift": s.drift or ref.drift,
            }
        )
    return res


def check(result: RecordResult) -> None:
    """Raise the refusal of ``result`` (one line), if any."""
    if result.refused is not None:
        raise RecordError(result.refused)


# ---------------------------------------------------------------------------- a campaign
def analyse_campaign(
    campaign: Campaign,
    allow_drift: bool = False,
    min_duration_s: float = MIN_DURATION_S,
    on_record: Callable[[Record, RecordResult], None] | None = None,
    progress: bool | None = None,
) -> list[RecordResult]:
    """Every record of ``campaign``, one in memory at a time, with a progress bar on stderr
    (:mod:`eodarm.progress`).

    ``on_record(record, result)`` is called while the record is in memory (to draw it), the
    refused one included, before the refusal is raised.

    Raises
    ------
    RecordError
        The first record that is malformed or cannot be matched to its payloads (one line).
    """
    from eodarm.progress import bar

    out: list[RecordResult] = []
    b = bar(len(campaign.records), "eodarm records", progress=progress, unit="record")
    try:
        for spec in campaign.records:
            record = read_record(spec.file, campaign.n)
            res = analyse_record(record, spec, allow_drift, min_duration_s)
            if on_record is not None:
                on_record(record, res)
            del record
            check(res)
            out.append(res)
            if b is not None:
                b.update(1)
    finally:
        if b is not None:
            b.close()
    return out
