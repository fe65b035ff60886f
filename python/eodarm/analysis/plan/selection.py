"""Choosing K configurations of the pool: greedy, then exchanges.

The objective, compared lexicographically (largest first):

1. ``min(1, (10 % / largest relative standard error)²)``: every candidate determined, or as
   close to it as the plan gets (capped at 1: once every parameter is determined, the
   separations decide);
2. the weakest separation among the pairs that the pool can separate at all, then the
   second weakest, … (the :data:`LEXIMIN` weakest: a tie at the weakest, common while a
   pair needs two configurations to be told apart, is broken by the next).

Greedy adds, one at a time, the configuration of the pool that improves the objective most;
then each chosen configuration is exchanged for the best one of the pool while that improves
it (Fedorov's exchange, at most :data:`PASSES` passes). Each step scores every configuration
of the pool at once: a plan's sums are the sums of its configurations'
(:class:`~eodarm.analysis.plan.signatures.Reduced`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from eodarm.analysis.plan.candidates import Candidate
from eodarm.analysis.plan.separation import MAX_REL_STDERR, rel_stderr, separations
from eodarm.analysis.plan.signatures import Reduced

__all__ = ["LEXIMIN", "PASSES", "Objective", "exchange", "greedy", "random_plans"]

FloatArray = npt.NDArray[np.float64]

#: How many of the weakest separations the objective compares, in order.
LEXIMIN = 4
#: Passes of exchanges at most.
PASSES = 4


@dataclass
class Objective:
    """The objective of a plan (module notes) over the separable pairs ``(iu, ju)`` and the
    candidates ``det`` that some plan can determine."""

    cands: Sequence[Candidate]
    iu: npt.NDArray[np.intp]
    ju: npt.NDArray[np.intp]
    det: npt.NDArray[np.intp]

    def keys(self, tot: Reduced) -> FloatArray:
        """(B, 1 + LEXIMIN) the objective of every set of states in ``tot``, to be compared
        lexicographically."""
        rel = rel_stderr(tot, self.cands)[:, self.det]
        with np.errstate(divide="ignore"):
            worst = rel.max(axis=1) if self.det.size else np.zeros(rel.shape[0])
            det = np.minimum(1.0, (MAX_REL_STDERR / worst) ** 2)
        b = det.shape[0]
        low = np.full((b, LEXIMIN), np.inf)
        if self.iu.size:
            sep = separations(tot, self.cands)[:, self.iu, self.ju]
            m = min(LEXIMIN, sep.shape[1])
            low[:, :m] = np.sort(sep, axis=1)[:, :m]
        return np.column_stack([det, low])

    def weakest(self, tot: Reduced) -> tuple[FloatArray, FloatArray]:
        """(B,) the weakest separation among the separable pairs and (B,) the largest
        relative standard error."""
        rel = rel_stderr(tot, self.cands).max(axis=1)
        if not self.iu.size:
            return np.full(rel.shape, np.inf), rel
        sep = separations(tot, self.cands)[:, self.iu, self.ju]
        return sep.min(axis=1), rel


def _best(keys: FloatArray) -> int:
    """The row of the lexicographically largest key."""
    order = np.lexsort(keys.T[::-1])
    return int(order[-1])


def _better(a: FloatArray, b: FloatArray) -> bool:
    """Whether key ``a`` beats key ``b`` (lexicographic, beyond rounding: 1e-9 relative)."""
    for x, y in zip(a.tolist(), b.tolist(), strict=True):
        if x == y or abs(x - y) <= 1e-9 * max(abs(x), abs(y)):
            continue
        return x > y
    return False


def greedy(per: Reduced, base: Reduced, k: int, objective: Objective) -> list[int]:
    """``k`` configurations of the pool (indices into ``per``), added one at a time where
    the objective gains most, on top of ``base`` (a campaign already measured)."""
    chosen: list[int] = []
    cur = base
    n = per.gram.shape[0]
    for _ in range(k):
        keys = objective.keys(cur + per)
        keys[chosen] = -np.inf
        i = _best(keys)
        if i in chosen:  # every configuration chosen already (k > pool): cannot happen
            break
        chosen.append(i)
        cur = cur + per.take(np.array([i]))
    assert len(chosen) <= n
    return chosen


def exchange(
    per: Reduced, base: Reduced, chosen: list[int], objective: Objective
) -> tuple[list[int], int]:
    """Exchange each chosen configuration for the best of the pool while the objective
    improves; returns the configurations and the number of exchanges made."""
    chosen = list(chosen)
    current = objective.keys(base + per.total(np.array(chosen)))[0]
    swaps = 0
    for _ in range(PASSES):
        improved = False
        for pos in range(len(chosen)):
            rest = np.array(chosen[:pos] + chosen[pos + 1 :], dtype=np.intp)
            partial = base + per.total(rest) if rest.size else base
            keys = objective.keys(partial + per)
            keys[chosen] = -np.inf
            i = _best(keys)
            if _better(keys[i], current):
                chosen[pos] = i
                current = keys[i]
                swaps += 1
                improved = True
        if not improved:
            break
    return chosen, swaps


def random_plans(
    per: Reduced,
    base: Reduced,
    k: int,
    objective: Objective,
    rng: np.random.Generator,
    draws: int,
) -> tuple[FloatArray, FloatArray, list[npt.NDArray[np.intp]]]:
    """The weakest separation and the largest relative standard error of ``draws`` plans of
    ``k`` configurations drawn at random from the pool (on top of ``base``), and the plans."""
    n = per.gram.shape[0]
    weakest = np.empty(draws)
    worst = np.empty(draws)
    picks = []
    for d in range(draws):
        pick = rng.choice(n, size=k, replace=False)
        w, r = objective.weakest(base + per.total(pick))
        weakest[d], worst[d] = w[0], r[0]
        picks.append(pick)
    return weakest, worst, picks
