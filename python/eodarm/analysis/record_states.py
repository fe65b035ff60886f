"""The steady states of a raw record (docs/records.md, "The detector").

Every threshold comes from the record's own noise:

1. **Blocks** (:mod:`eodarm.analysis.record_blocks`): blocks of a few correlation times, the
   noise of a block mean from second differences (a steady trend has none) and the
   correlation of neighbouring block means.
2. **Runs.** The chain of blocks breaks where the block means bend on both sides of a
   boundary (:func:`_smooth`: a step, a push, ringing; not a ramp); runs at one level are
   joined again (:func:`_merge`).
3. **Pieces.** A run is split where one straight line per channel fits it worse than two
   (binary segmentation, :func:`_split`): a flat part and a ramp, a slow change between two
   levels, a step too small to break the chain.
4. **States and trends.** A piece whose line moves by more than two breaks over its length
   (:data:`K_TREND`), or a stretch of short runs that a line explains, is a **trend**, never
   a state; a piece that lasts ``min_duration_s`` otherwise is a **steady state**.
5. **Settled part** (:mod:`eodarm.analysis.record_edges`): the groups of blocks at a state's
   edges that are off the line of the rest or louder than a settled block, and half a block
   at each end, are not averaged.
6. **Drift** (:func:`errors`): the standard errors from the noise model of
   :mod:`eodarm.analysis.record_noise`, and the drift tests, one channel at a time and all
   channels together.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from eodarm.analysis.record_blocks import Blocks, block_size, blocks, line, resolution
from eodarm.analysis.record_edges import quiet_blocks, settled
from eodarm.analysis.record_noise import (
    DRIFT_ALARM,
    autocov,
    drift_threshold,
    joint_threshold,
    long_run,
    mean_variance,
    noise_model,
)
from eodarm.analysis.tails import chi2_isf, chi2_sf

__all__ = [
    "K_BREAK",
    "K_TREND",
    "MIN_BLOCKS",
    "MIN_DURATION_S",
    "Detection",
    "State",
    "Trend",
    "detect",
    "errors",
]

FloatArray = npt.NDArray[np.float64]

#: Neighbouring block means further apart than this many standard deviations of their
#: difference break a run.
K_BREAK = 5.0
#: A piece whose line moves by more than this many standard deviations of the difference of
#: two block means over its length (two breaks) is a trend: the arm is being moved.
K_TREND = 2.0 * K_BREAK
#: The false-alarm rate of splitting one run of pure noise in two.
SPLIT_ALARM = 1e-6
#: A steady state spans at least this many blocks.
MIN_BLOCKS = 4
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
    drift : whether a channel's slope is beyond :func:`drift_threshold` (``drift_z`` the
        largest |slope|/standard error, ``drift_limit`` that threshold), or the channels'
        slopes together beyond :func:`joint_threshold` (``joint``, ``joint_limit``).
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
    drift_z: float = 0.0
    drift_limit: float = math.inf
    joint: float = 0.0
    joint_limit: float = math.inf


@dataclass(frozen=True)
class Trend:
    """A part of a record at least ``min_duration_s`` long that moves steadily: its line
    changes by more than a break over its length, so it is no steady state.

    ``slope`` is (C,), channel units per second; ``t0``, ``t1`` in s; ``span`` the samples;
    ``lead`` the channel that moves most, in units of its noise.
    """

    t0: float
    t1: float
    span: tuple[int, int]
    slope: FloatArray
    lead: int = 0


@dataclass
class Detection:
    """What :func:`detect` found: the steady states, the trends and the block size."""

    states: list[State]
    trends: list[Trend]
    block: int


def _split(bk: Blocks, lo: int, hi: int, out: list[tuple[int, int]]) -> None:
    """Binary segmentation of the run ``lo:hi`` with one straight line per channel and piece:
    split where two lines fit the block means (in units of their long-run noise) better than
    one by more
    than the χ² quantile (2 parameters per channel) of :data:`SPLIT_ALARM`, Bonferroni over
    the places; then each side again."""
    side = 2
    n = hi - lo
    if n < 2 * side + 1:
        out.append((lo, hi))
        return
    x = (bk.t[lo:hi] - bk.t[lo]) / max(float(bk.t[hi - 1] - bk.t[lo]), 1e-300) * (n - 1)
    # in units of the block means' long-run noise: correlated neighbours make a line's
    # residuals smoother than independent ones, σ²(1 + ρ)/(1 − ρ) for slow shapes
    unit = bk.noise * np.sqrt((1.0 + bk.rho) / (1.0 - bk.rho))
    y = (bk.mean[lo:hi] - bk.mean[lo:hi].mean(axis=0)) / unit
    one = np.arange(1, n + 1, dtype=float)
    sx, sxx = np.cumsum(x), np.cumsum(x * x)
    sy, sxy, syy = np.cumsum(y, axis=0), np.cumsum(x[:, None] * y, axis=0), np.cumsum(y * y, axis=0)

    def sse(
        k: FloatArray, a: FloatArray, aa: FloatArray, b: FloatArray, ab: FloatArray, bb: FloatArray
    ) -> FloatArray:
        vx = aa - a * a / k
        cxy = ab - a[:, None] * b / k[:, None]
        vy = bb - b * b / k[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            fit = np.where(vx[:, None] > 1e-12, cxy * cxy / vx[:, None], 0.0)
        return np.asarray((vy - fit).sum(axis=1))

    tot = sse(one[-1:], sx[-1:], sxx[-1:], sy[-1:], sxy[-1:], syy[-1:])[0]
    j = np.arange(side, n - side + 1)  # the left piece is [0, j)
    left = sse(one[j - 1], sx[j - 1], sxx[j - 1], sy[j - 1], sxy[j - 1], syy[j - 1])
    right = sse(
        one[-1] - one[j - 1],
        sx[-1] - sx[j - 1],
        sxx[-1] - sxx[j - 1],
        sy[-1] - sy[j - 1],
        sxy[-1] - sxy[j - 1],
        syy[-1] - syy[j - 1],
    )
    gain = tot - left - right
    k = int(np.argmax(gain))
    if gain[k] <= _chi2_split(j.size, y.shape[1]):
        out.append((lo, hi))
        return
    _split(bk, lo, lo + int(j[k]), out)
    _split(bk, lo + int(j[k]), hi, out)


@functools.lru_cache(maxsize=256)
def _chi2_split(places: int, channels: int) -> float:
    """The χ² quantile (2 parameters per channel) of :data:`SPLIT_ALARM` over ``places``."""
    return chi2_isf(SPLIT_ALARM / places, 2.0 * channels)


# ---------------------------------------------------------------------------- the detector
def detect(time_s: FloatArray, values: FloatArray, min_duration_s: float) -> Detection:
    """The steady states and trends of one record (module docstring), with their errors.

    Parameters
    ----------
    time_s : (N,) sample times, s, increasing.
    values : (N, C) readings.
    min_duration_s : shortest steady state, s.
    """
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(values, dtype=float)
    if v.ndim == 1:
        v = v[:, None]
    n = v.shape[0]
    if n < 2 * 8:
        return Detection([], [], max(n, 1))
    dt = float(np.median(np.diff(t)))
    per_state = max(1, int(min_duration_s / dt)) if dt > 0 else n
    b = block_size(v, max(8, per_state // MIN_BLOCKS))
    if n // b < MIN_BLOCKS:
        return Detection([], [], b)
    q = resolution(v)
    bk = blocks(t, v, b, q)
    nb = bk.nb
    sd = math.sqrt(2.0) * bk.noise  # of the difference of two block means
    same = _smooth(bk)
    cuts = np.flatnonzero(~same) + 1
    runs = [[int(a), int(z)] for a, z in zip([0, *cuts], [*cuts, nb], strict=True)]
    runs = _merge(bk, runs)
    min_blocks = max(MIN_BLOCKS, math.ceil(min_duration_s / max(dt * b, 1e-300)))
    pieces: list[tuple[int, int]] = []
    loose: list[tuple[int, int]] = []  # stretches of runs too short to be states
    for r0, r1 in runs:
        if r1 - r0 >= min_blocks:
            _split(bk, r0, r1, pieces)
        elif loose and loose[-1][1] == r0:
            loose[-1] = (loose[-1][0], r1)
        else:
            loose.append((r0, r1))
    trends: list[Trend] = []
    kept: list[tuple[int, int]] = []
    for r0, r1 in sorted(pieces + [x for x in loose if x[1] - x[0] >= 2 * min_blocks]):
        if r1 - r0 < min_blocks:
            continue
        level, slope, t_ref = line(bk, r0, r1)
        change = np.abs(slope) * float(bk.t[r1 - 1] - bk.t[r0])
        lead = int(np.argmax(change / sd))
        last = r1 * b - 1 if r1 < nb else n - 1
        is_piece = (r0, r1) in pieces
        if not is_piece:
            # a stretch of short runs is a trend when a line explains it (a steady motion
            # broken at every block), not when it is pushes and ringing
            fit = level[lead] + (bk.t[r0:r1] - t_ref) * slope[lead]
            resid = bk.mean[r0:r1, lead] - fit
            spread = bk.mean[r0:r1, lead] - level[lead]
            linear = float(resid @ resid) <= 0.01 * float(spread @ spread)
        if (change > K_TREND * sd).any() and (is_piece or linear):
            trends.append(Trend(float(t[r0 * b]), float(t[last]), (r0 * b, last), slope, lead))
        elif is_piece:
            kept.append((r0, r1))
    quiet = quiet_blocks(bk, kept, q)
    states: list[State] = []
    for r0, r1 in kept:
        # the blocks at the edges that are not settled: the tail of what came before, the
        # start of what comes next (a hand reaching for the plate), ringing
        a0, a1 = settled(bk, r0, r1, quiet)
        # and half a block at each end (not at the record's): what the block tests cannot
        # see, the last samples of a transient, the first of the next push
        i0 = a0 * b + (b // 2 if r0 > 0 else 0)
        i1 = a1 * b - (b // 2 if r1 < nb else 0)
        last = r1 * b - 1 if r1 < nb else n - 1
        states.append(
            State(
                start=i0,
                stop=i1,
                span=(r0 * b, last),
                t0=float(t[i0]),
                t1=float(t[i1 - 1]),
                mean=v[i0:i1].mean(axis=0),
            )
        )
    errors(t, v, states, q, b)
    return Detection(states, trends, b)


def _smooth(bk: Blocks) -> npt.NDArray[np.bool_]:
    """Whether each pair of neighbouring blocks belongs to one run: a break where the curve of
    the block means bends on both sides of the boundary (second differences beyond
    :data:`K_BREAK` of their noise on some channel): a step, a push, ringing; not a ramp."""
    nb = bk.nb
    if nb < 3:
        return np.ones(max(nb - 1, 0), dtype=bool)
    d2 = np.abs(np.diff(bk.mean, n=2, axis=0)) > K_BREAK * math.sqrt(6.0) * bk.noise
    bent = d2.any(axis=1)  # (nb - 2,): the bend at block 1 … nb - 2
    # boundary j | j+1 (j = 0 … nb-2) lies between the bends at blocks j and j + 1
    left = np.concatenate([[True], bent])  # bend at block j (block 0: no test, take True)
    right = np.concatenate([bent, [True]])  # bend at block j + 1
    return ~(left & right)


def _merge(bk: Blocks, runs: list[list[int]]) -> list[list[int]]:
    """Neighbouring runs of at least :data:`MIN_BLOCKS` blocks at one level (a break by
    chance) made one."""
    sb = bk.noise
    merged: list[list[int]] = []
    for r in runs:
        if merged:
            prev = merged[-1]
            n1, n2 = prev[1] - prev[0], r[1] - r[0]
            if n1 >= MIN_BLOCKS and n2 >= MIN_BLOCKS:
                m1 = bk.mean[prev[0] : prev[1]].mean(axis=0)
                m2 = bk.mean[r[0] : r[1]].mean(axis=0)
                se = sb * math.sqrt(1.0 / n1 + 1.0 / n2)
                if (np.abs(m1 - m2) <= K_BREAK * se).all():
                    prev[1] = r[1]
                    continue
        merged.append(list(r))
    return merged


def errors(
    t: FloatArray, v: FloatArray, states: list[State], q: FloatArray, block: int = 0
) -> None:
    """Standard errors, drift rates and drift tests of every state.

    The noise model of each channel is fitted to the detrended later halves of all the
    states' settled samples together (the part farthest from the transient before each).
    A state drifts when one channel's slope is beyond :func:`drift_threshold`, or when its
    channels' slopes together are beyond :func:`joint_threshold` (a creep that moves every
    channel a little), each at half the false-alarm rate; the correlation of the channels'
    slopes is that of the residual means of ``block``-sample blocks about the states' lines.
    """
    if not states:
        return
    c = v.shape[1]
    gam = np.zeros((3, c))
    count = 0
    dens = []
    resid: list[FloatArray] = []
    for s in states:
        x = v[s.start : s.stop]
        tt = t[s.start : s.stop]
        tc = tt - tt.mean()
        den = float(tc @ tc)
        s.slope = (tc @ x) / den if den > 0 else np.zeros(c)  # Σ tc = 0: no mean to remove
        dens.append(den)
        # the noise model from the later half: the part farthest from the transient before
        half = (s.start + s.stop) // 2
        r = _detrended(t[half : s.stop], v[half : s.stop])
        gam += autocov(r, 3)
        count += r.shape[0]
        if block > 0 and x.shape[0] >= 3 * block:
            m = x.shape[0] // block
            bm = x[: m * block].reshape(m, block, c).mean(axis=1)
            bt = tc[: m * block].reshape(m, block).mean(axis=1)
            line = s.mean + bt[:, None] * s.slope[None, :]
            resid.append(bm - line)
    g0, a, phi = noise_model(gam, count, len(states))
    lrv = long_run(g0, a, phi)
    inv, dof = _slope_correlation(resid, len(states), c)
    joint = inv is not None
    alarm = DRIFT_ALARM / 2.0 if joint else DRIFT_ALARM
    thr = drift_threshold(len(states) * c, alarm)
    thr_joint = joint_threshold(len(states), c, dof, alarm) if joint else math.inf
    for s, den in zip(states, dens, strict=True):
        # a quantised reading is known to ±q/2 however long it is averaged (q²/12), and a
        # trend of less than a quantum over the state is not seen
        s.stderr = np.sqrt(mean_variance(g0, a, phi, s.stop - s.start) + q * q / 12.0)
        span = max(float(t[s.stop - 1] - t[s.start]), 1e-300)
        s.slope_se = np.sqrt(lrv / den + (q / span) ** 2) if den > 0 else np.full(c, np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.nan_to_num(s.slope / s.slope_se, nan=0.0, posinf=0.0, neginf=0.0)
        s.drift_z = float(np.abs(z).max())
        s.drift_limit = thr
        if inv is not None:
            s.joint = float(z @ inv @ z)
            s.joint_limit = thr_joint
        s.drift = s.drift_z > thr or s.joint > s.joint_limit


def _slope_correlation(
    resid: list[FloatArray], states: int, c: int
) -> tuple[FloatArray | None, int]:
    """The inverse of the correlation of the channels' noise and its degrees of freedom, from
    the residual block means about the states' lines: ``(None, 0)`` with one channel or too
    few blocks (fewer than ten degrees of freedom beyond the channels); the identity and no
    estimation (``dof`` 0) when Bartlett's test does not find the channels correlated at 1 %
    (the usual case: separate sensors), so that the joint test keeps its χ² threshold."""
    if c < 2 or not resid:
        return None, 0
    e = np.concatenate(resid)
    dof = e.shape[0] - 2 * len(resid)
    if dof - c < 10:
        return None, 0
    norm = np.sqrt((e * e).sum(axis=0))
    if not (norm > 0).all():
        return None, 0
    corr = (e.T @ e) / np.outer(norm, norm)
    sign, logdet = np.linalg.slogdet(corr)
    if sign <= 0 or np.linalg.cond(corr) > 1e6:
        return None, 0
    bartlett = -(dof - 1.0 - (2.0 * c + 5.0) / 6.0) * logdet
    if chi2_sf(max(bartlett, 0.0), c * (c - 1) / 2.0) > 0.01:
        return np.eye(c), 0
    return np.asarray(np.linalg.inv(corr), dtype=np.float64), dof


def _detrended(t: FloatArray, x: FloatArray) -> FloatArray:
    """``x`` minus its least-squares line against ``t``, per column (one copy of ``x``)."""
    tc = t - t.mean()
    den = float(tc @ tc)
    out = x - x.mean(axis=0)
    if den > 0:
        slope = (tc @ out) / den
        for j in range(out.shape[1]):
            out[:, j] -= slope[j] * tc
    return out
