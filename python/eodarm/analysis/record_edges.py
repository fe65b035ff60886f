"""The settled part of a steady state (docs/records.md, "The detector", step 5): the groups
of blocks at a state's edges that are off the line of the rest, or louder than a settled
block, are not averaged.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from eodarm.analysis.record_blocks import Blocks, line
from eodarm.analysis.record_noise import robust_scale
from eodarm.analysis.tails import chi2_isf

__all__ = ["K_TRIM", "MIN_KEPT", "Quiet", "quiet_blocks", "settled"]

FloatArray = npt.NDArray[np.float64]

#: Leading or trailing blocks this many standard deviations off the line of the rest of their
#: state, or as many above the inner variance of a settled block, are not averaged.
K_TRIM = 4.0
#: A state keeps at least this many blocks.
MIN_KEPT = 4
#: The scales (in blocks) at which a state's edges are tested.
_SCALES = (1, 2, 4, 8)


@dataclass(frozen=True)
class Quiet:
    """What a settled block looks like on this record: the median and the spread of the log
    of a block's inner variance (about its own mean), per channel."""

    centre: FloatArray
    spread: FloatArray
    floor: FloatArray


def quiet_blocks(bk: Blocks, pieces: list[tuple[int, int]], q: FloatArray) -> Quiet:
    """:class:`Quiet` from the blocks of the record's states (``pieces``, block ranges);
    ``q`` the channels' resolution (a quantised channel's inner variance is at least its
    quantum's)."""
    floor = q * q / 12.0 * bk.b + 1e-300
    if not pieces:
        c = bk.mean.shape[1]
        return Quiet(np.zeros(c), np.ones(c), floor)
    logw = np.log(np.concatenate([bk.w[a:z] for a, z in pieces]) + floor)
    centre = np.median(logw, axis=0)
    spread = np.maximum(robust_scale(logw - centre), 1e-3)
    return Quiet(centre, spread, floor)


def _edge_alarm(bk: Blocks, a0: int, a1: int, m: int, lead: bool, quiet: Quiet) -> bool:
    """Whether the ``m`` blocks at the start (``lead``) or end of ``a0:a1`` are unsettled,
    on any channel: their means off the line of the rest (their mean offset, or the sum of
    squares of their offsets), or their inner variance above the record's settled blocks."""
    edge = np.arange(a0, a0 + m) if lead else np.arange(a1 - m, a1)
    lo, hi = (a0 + m, a1) if lead else (a0, a1 - m)
    t = bk.t[lo:hi]
    t_ref = float(t.mean())
    sxx = float(((t - t_ref) ** 2).sum())
    level, slope, _ = line(bk, lo, hi)
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


def settled(bk: Blocks, a0: int, a1: int, quiet: Quiet) -> tuple[int, int]:
    """The settled blocks of the state ``a0:a1``: leading (then trailing) groups of 1, 2, 4 or
    8 blocks that :func:`_edge_alarm` finds unsettled are dropped, at most half the state in
    all, and at least :data:`MIN_KEPT` blocks kept."""
    keep = max(MIN_KEPT, (a1 - a0 + 1) // 2)
    for lead in (True, False):
        while True:
            m = next(
                (
                    m
                    for m in _SCALES
                    if a1 - a0 - m >= keep and _edge_alarm(bk, a0, a1, m, lead, quiet)
                ),
                0,
            )
            if m == 0:
                break
            a0, a1 = (a0 + m, a1) if lead else (a0, a1 - m)
    return a0, a1
