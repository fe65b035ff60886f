"""The steady states of a raw record (docs/records.md, "The detector").

Every threshold comes from the record's own noise:

1. **Blocks.** The samples are cut into blocks of ``B`` samples, ``B`` a few correlation
   times of the noise (:func:`block_size`); each block's mean, and the noise of a block mean
   from the second differences of neighbouring block means (a steady trend has none).
2. **Runs.** Neighbouring blocks whose means differ by at most :data:`K_BREAK` block-noise
   units of their difference on every channel are one run; runs at one level are merged.
3. **Pieces.** A run is split where one straight line per channel fits it worse than two
   (binary segmentation, :func:`_split`): a flat part and a ramp, a step too small to break
   the chain. A piece whose line moves by more than two breaks over its length
   (:data:`K_TREND`) is a **trend**, never a state; one that lasts ``min_duration_s``
   otherwise is a **steady state**, whose drift is then tested.
4. **Settled part.** A state's edges are not averaged: a guard block at each end, then any
   leading or trailing blocks whose energy about the line of the rest is beyond the noise
   (:func:`_settled`): the tail of a transient, ringing, the start of the next push.

The standard errors and drift rates of the states are :func:`errors`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from eodarm.analysis.record_noise import (
    DRIFT_ALARM,
    autocov,
    drift_threshold,
    joint_threshold,
    long_run,
    mean_variance,
    noise_model,
    robust_scale,
)
from eodarm.analysis.tails import chi2_isf, chi2_sf

__all__ = [
    "K_BREAK",
    "K_TREND",
    "K_TRIM",
    "MIN_BLOCKS",
    "MIN_DURATION_S",
    "Detection",
    "State",
    "Trend",
    "block_size",
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
#: Leading or trailing blocks this many standard deviations off the line of the rest of their
#: state, or as many above the inner variance of a settled block, are not averaged.
K_TRIM = 4.0
#: The false-alarm rate of splitting one run of pure noise in two.
SPLIT_ALARM = 1e-6
#: A steady state spans at least this many blocks.
MIN_BLOCKS = 4
#: The block size is estimated from at most this many samples (in runs spread over the record).
SCALE_SAMPLES = 131072
#: Default shortest steady state, s.
MIN_DURATION_S = 2.0
#: The scales (in blocks) at which a state's edges are tested.
_SCALES = (1, 2, 4, 8)


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


@dataclass(frozen=True)
class _Blocks:
    """Sums over the blocks of a record (``nb`` blocks of ``b`` samples, ``c`` channels).

    ``t`` the mean time of each block; ``mean`` (nb, c) the block means; ``w`` Σ(x − mean)²,
    ``tx`` Σ(t − t̄)(x − mean) and ``tt`` Σ(t − t̄)² within each block; ``noise`` (c,) the
    standard deviation of one block mean, ``rho`` (c,) the correlation of neighbouring block
    means (blocks a few correlation times long are not quite independent)."""

    b: int
    t: FloatArray
    mean: FloatArray
    w: FloatArray
    tx: FloatArray
    tt: FloatArray
    noise: FloatArray
    rho: FloatArray

    @property
    def nb(self) -> int:
        return self.t.size


# ---------------------------------------------------------------------------- blocks
def _block_noise(bm: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The standard deviation of one block mean and the correlation ρ of neighbouring ones,
    robustly from the first and second differences of the block means: for block means
    correlated with their neighbours only, var(d₁) = 2σ²(1 − ρ) and var(d₂) = σ²(6 − 8ρ). The
    second differences carry no steady trend, and a step or a transient gives a few
    outliers; ρ is clipped to [0, 0.5] (a ramp over much of the record would inflate it)."""
    v1 = robust_scale(np.diff(bm, axis=0)) ** 2
    v2 = robust_scale(np.diff(bm, n=2, axis=0)) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(v2 > 0, v1 / np.where(v2 > 0, v2, 1.0), 1.0 / 3.0)
        rho = np.clip((6.0 * r - 2.0) / (8.0 * r - 2.0), 0.0, 0.5)
    return np.sqrt(v2 / (6.0 - 8.0 * rho)), rho


def block_size(values: FloatArray, cap: int) -> int:
    """Samples per block: twice the smallest block length ``B`` (a power of 2) at which
    ``B`` times the variance of a block mean has reached 80 % of its largest value, on the
    channel that needs the longest, clipped to [8, ``cap``].

    For noise without correlation ``B·var`` is the same for every ``B``; for correlated noise
    it grows with ``B`` until the blocks outlast the correlation (it then equals the long-run
    variance), whatever mix of correlated and white noise the channel has. The variance is
    taken robustly from second differences of neighbouring block means, so that steps,
    transients and ramps do not count. At most :data:`SCALE_SAMPLES` samples are used, in runs
    spread over the record."""
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
            if m >= 4:
                bm = x[: m * b].reshape(m, b, c).mean(axis=1)
                diffs.append(np.diff(bm, n=2, axis=0))
        if not diffs or sum(len(d) for d in diffs) < 16:
            break
        f.append(b * robust_scale(np.concatenate(diffs)) ** 2)
        sizes.append(b)
        b *= 2
    if not f:
        return max(1, min(8, cap))
    fa = np.array(f)  # (len(sizes), C)
    reach = fa >= 0.8 * fa.max(axis=0)
    first = reach.argmax(axis=0)  # per channel, the first size that reaches 80 %
    best = sizes[int(first.max())]
    return int(max(8, min(cap, 2 * best)))


def _blocks(t: FloatArray, v: FloatArray, b: int, q: FloatArray) -> _Blocks:
    nb = t.size // b
    c = v.shape[1]
    x = v[: nb * b].reshape(nb, b, c)
    tt = t[: nb * b].reshape(nb, b)
    bm = x.mean(axis=1)
    bt = tt.mean(axis=1)
    xc = x - bm[:, None, :]
    tc = tt - bt[:, None]
    w = np.einsum("ijk,ijk->ik", xc, xc)
    tx = np.einsum("ij,ijk->ik", tc, xc)
    t2 = np.einsum("ij,ij->i", tc, tc)
    sb, rho = _block_noise(bm) if nb >= 3 else (np.zeros(c), np.zeros(c))
    tiny = 1e-12 * np.maximum(np.abs(bm).max(axis=0), 1.0)
    # a change of less than a quantum between two blocks is no break
    sb = np.maximum(np.maximum(sb, tiny), q / math.sqrt(2.0))
    return _Blocks(b, bt, bm, w, tx, t2, sb, rho)


def _resolution(v: FloatArray) -> FloatArray:
    """Each channel's resolution: the smallest non-zero change between two samples (of the
    first 2¹⁷), 0 for a constant channel. A logger that writes few decimals quantises."""
    d = np.abs(np.diff(v[: SCALE_SAMPLES + 1], axis=0))
    d[d == 0] = np.inf
    q = d.min(axis=0) if d.shape[0] else np.zeros(v.shape[1])
    return np.where(np.isfinite(q), q, 0.0)


# ---------------------------------------------------------------------------- lines
def _line(bk: _Blocks, lo: int, hi: int) -> tuple[FloatArray, FloatArray, float]:
    """Least-squares line of the block means ``lo:hi`` against time: (level at ``t_ref``,
    slope per s, ``t_ref``), per channel."""
    t = bk.t[lo:hi]
    y = bk.mean[lo:hi]
    t_ref = float(t.mean())
    tc = t - t_ref
    den = float(tc @ tc)
    level = y.mean(axis=0)
    slope = (tc @ (y - level)) / den if den > 0 else np.zeros(y.shape[1])
    return level, slope, t_ref


def _split(bk: _Blocks, lo: int, hi: int, out: list[tuple[int, int]]) -> None:
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


# ---------------------------------------------------------------------------- settled part
@dataclass(frozen=True)
class _Quiet:
    """What a settled block looks like on this record: the median and the spread of the log
    of a block's inner variance (about its own mean), per channel."""

    centre: FloatArray
    spread: FloatArray
    floor: FloatArray


def _quiet(bk: _Blocks, pieces: list[tuple[int, int]], q: FloatArray) -> _Quiet:
    floor = q * q / 12.0 * bk.b + 1e-300
    if not pieces:
        c = bk.mean.shape[1]
        return _Quiet(np.zeros(c), np.ones(c), floor)
    logw = np.log(np.concatenate([bk.w[a:z] for a, z in pieces]) + floor)
    centre = np.median(logw, axis=0)
    spread = np.maximum(robust_scale(logw - centre), 1e-3)
    return _Quiet(centre, spread, floor)


def _edge_alarm(bk: _Blocks, a0: int, a1: int, m: int, lead: bool, quiet: _Quiet) -> bool:
    """Whether the ``m`` blocks at the start (``lead``) or end of ``a0:a1`` are unsettled,
    on any channel: their means off the line of the rest (their mean offset, or the sum of
    squares of their offsets), or their inner variance above the record's settled blocks."""
    edge = np.arange(a0, a0 + m) if lead else np.arange(a1 - m, a1)
    lo, hi = (a0 + m, a1) if lead else (a0, a1 - m)
    t = bk.t[lo:hi]
    t_ref = float(t.mean())
    sxx = float(((t - t_ref) ** 2).sum())
    level, slope, _ = _line(bk, lo, hi)
    x = bk.t[edge] - t_ref
    off = (bk.mean[edge] - level - x[:, None] * slope) / bk.noise  # (m, c) in block noise
    # their covariance: each block's own noise and the line's error at its time, shared
    cov = np.eye(m) + 1.0 / (hi - lo) + (np.outer(x, x) / sxx if sxx > 0 else 0.0)
    z_mean = np.abs(off.sum(axis=0)) / math.sqrt(float(cov.sum()))
    chi2 = np.einsum("ij,ij->j", off, np.linalg.solve(cov, off))
    loud = (np.log(bk.w[edge] + quiet.floor).mean(axis=0) - quiet.centre) * math.sqrt(m)
    return bool(
        (z_mean > K_TRIM).any()
        or (m > 1 and (chi2 > _chi2_trim(m)).any())
        or (loud > K_TRIM * quiet.spread).any()
    )


@functools.lru_cache(maxsize=64)
def _chi2_trim(m: int) -> float:
    """The χ²_m quantile of the two-sided normal tail of :data:`K_TRIM`."""
    from statistics import NormalDist

    return chi2_isf(2.0 * (1.0 - NormalDist().cdf(K_TRIM)), float(m))


def _settled(bk: _Blocks, a0: int, a1: int, quiet: _Quiet) -> tuple[int, int]:
    """The settled blocks of the state ``a0:a1``: leading (then trailing) groups of 1, 2, 4 or
    8 blocks that :func:`_edge_alarm` finds unsettled are dropped, at most half the state in
    all, and at least :data:`MIN_BLOCKS` blocks kept."""
    keep = max(MIN_BLOCKS, (a1 - a0 + 1) // 2)
    for lead in (True, False):
        while a1 - a0 > keep:
            for m in _SCALES:
                if a1 - a0 - m < keep:
                    m = 0
                    break
                if _edge_alarm(bk, a0, a1, m, lead, quiet):
                    break
            else:
                m = 0
            if m == 0:
                break
            if lead:
                a0 += m
            else:
                a1 -= m
    return a0, a1


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
    q = _resolution(v)
    bk = _blocks(t, v, b, q)
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
        level, slope, t_ref = _line(bk, r0, r1)
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
    quiet = _quiet(bk, kept, q)
    states: list[State] = []
    for r0, r1 in kept:
        # the blocks at the edges that are not settled: the tail of what came before, the
        # start of what comes next (a hand reaching for the plate), ringing
        a0, a1 = _settled(bk, r0, r1, quiet)
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


def _smooth(bk: _Blocks) -> npt.NDArray[np.bool_]:
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


def _merge(bk: _Blocks, runs: list[list[int]]) -> list[list[int]]:
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
