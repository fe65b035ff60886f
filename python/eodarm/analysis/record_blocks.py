"""Blocks of a raw record (docs/records.md, "The detector", step 1): the block size, the
sums over each block, the noise of a block mean and of neighbouring ones' correlation, a
channel's resolution, and least-squares lines through block means.

The detector (:mod:`eodarm.analysis.record_states`) works on the block means, a few thousand
numbers for a record of 10⁶ samples, and goes back to the samples only to average a state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from eodarm.analysis.record_noise import robust_scale

__all__ = ["SCALE_SAMPLES", "Blocks", "block_noise", "block_size", "blocks", "line", "resolution"]

FloatArray = npt.NDArray[np.float64]

#: The block size is estimated from at most this many samples (in runs spread over the record).
SCALE_SAMPLES = 131072


@dataclass(frozen=True)
class Blocks:
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


def block_noise(bm: FloatArray) -> tuple[FloatArray, FloatArray]:
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


def blocks(t: FloatArray, v: FloatArray, b: int, q: FloatArray) -> Blocks:
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
    sb, rho = block_noise(bm) if nb >= 3 else (np.zeros(c), np.zeros(c))
    tiny = 1e-12 * np.maximum(np.abs(bm).max(axis=0), 1.0)
    # a change of less than a quantum between two blocks is no break
    sb = np.maximum(np.maximum(sb, tiny), q / math.sqrt(2.0))
    return Blocks(b, bt, bm, w, tx, t2, sb, rho)


def resolution(v: FloatArray) -> FloatArray:
    """Each channel's resolution: the smallest non-zero change between two samples (of the
    first 2¹⁷), 0 for a constant channel. A logger that writes few decimals quantises."""
    d = np.abs(np.diff(v[: SCALE_SAMPLES + 1], axis=0))
    d[d == 0] = np.inf
    q = d.min(axis=0) if d.shape[0] else np.zeros(v.shape[1])
    return np.where(np.isfinite(q), q, 0.0)


def line(bk: Blocks, lo: int, hi: int) -> tuple[FloatArray, FloatArray, float]:
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
