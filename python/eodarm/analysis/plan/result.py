"""The result of a plan: the configurations, every candidate's determination and every pair's
separation with them, the pairs no configuration separates, and the random plans' figures
(docs/plan.md, "Output"; ``to_json`` is docs/formats.md's ``eodarm plan --json``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.plan.candidates import Candidate
from eodarm.analysis.plan.pool import Payloads
from eodarm.model.arm import Arm

__all__ = ["Plan"]

FloatArray = npt.NDArray[np.float64]


@dataclass
class Plan:
    """The result of :func:`plan` (``to_json()`` is ``eodarm plan --json``, docs/formats.md).

    Attributes
    ----------
    configs : (K, n) the planned configurations, unloaded absolute angles (deg).
    labels : their labels (``c1`` …, after a fixed campaign's own).
    payloads : the payloads of every planned configuration.
    channels, sigma : the planned channels and their noise (mm or deg).
    candidates : every candidate at its size.
    rel_stderr : (C,) each candidate's relative standard error with the plan.
    separation : (C, C) the separation of every pair with the plan (+inf on the diagonal).
    imitated : (C, C) χ²(a → b) with the plan: what remains of a's signature when b imitates
        it.
    inseparable : (a, b, channel) the pairs that no configuration of the pool separates on
        the planned channels, with the channel that would (None if none).
    random_weakest, random_max_rel : the weakest separable pair's separation and the largest
        relative standard error of each random plan (:attr:`random_median`: the median plan's).
    fixed : (F, n) the configurations of the campaign already measured (``fixed``).
    pool : (P, n) the reachable configurations the plan chose from.
    before_separation, before_rel_stderr : the same figures with the fixed campaign alone
        (None without one).
    random_separation : (C, C) the separations of the median random plan (by its weakest).
    unseen : the candidates that no reachable configuration shows on the planned channels
        (their signature over the whole pool is below the separable χ²): the data could not
        show them, so they are not planned for.
    """

    arm: Arm
    configs: FloatArray
    labels: list[str]
    payloads: Payloads
    channels: list[str]
    sigma: dict[str, float]
    candidates: list[Candidate]
    rel_stderr: FloatArray
    separation: FloatArray
    imitated: FloatArray
    inseparable: list[tuple[int, int, str | None]]
    random_weakest: FloatArray
    random_max_rel: FloatArray
    fixed: FloatArray
    pool: FloatArray
    random_separation: FloatArray | None = None
    before_separation: FloatArray | None = None
    before_rel_stderr: FloatArray | None = None
    unseen: list[Candidate] = field(default_factory=list)

    # ------------------------------------------------------------------ figures
    @property
    def separable(self) -> npt.NDArray[np.bool_]:
        """(C, C) the pairs some plan can separate (not named apart as inseparable)."""
        c = len(self.candidates)
        out = np.ones((c, c), dtype=bool)
        np.fill_diagonal(out, False)
        for a, b, _ in self.inseparable:
            out[a, b] = out[b, a] = False
        return out

    def pairs(self) -> list[tuple[int, int, float]]:
        """Every pair (a, b, separation), weakest first; ``a`` is the one whose data ``b``
        imitates in the weaker direction."""
        c = len(self.candidates)
        out = []
        for i in range(c):
            for j in range(i + 1, c):
                a, b = (i, j) if self.imitated[i, j] <= self.imitated[j, i] else (j, i)
                out.append((a, b, float(self.separation[i, j])))
        out.sort(key=lambda t: t[2])
        return out

    @property
    def weakest(self) -> float:
        """The weakest separation among the separable pairs (inf if there is none)."""
        sep = self.separation[self.separable]
        return float(sep.min()) if sep.size else math.inf

    @property
    def max_rel_stderr(self) -> float:
        return float(np.max(self.rel_stderr))

    @property
    def random_median(self) -> tuple[float, float]:
        """The median random plan's weakest separation and its largest relative standard
        error: of the draws ordered by their weakest separation, the middle one (the upper
        of the two middle ones of an even number)."""
        mid = int(np.argsort(self.random_weakest, kind="stable")[self.random_weakest.size // 2])
        return float(self.random_weakest[mid]), float(self.random_max_rel[mid])

    def to_json(self) -> dict[str, Any]:
        """``eodarm plan --json`` (docs/formats.md, "plan")."""
        names = [c.spec for c in self.candidates]
        weak, worst = self.random_median
        return {
            "configs": [[float(x) for x in row] for row in self.configs],
            "masses_kg": [float(m) for m in self.payloads.masses_kg],
            "sequence": self.payloads.sequence,
            "channels": list(self.channels),
            "candidates": [
                {
                    "effect": c.slot.name,
                    "at": c.slot.at,
                    **({"unloaded": c.slot.unloaded} if c.slot.unloaded != "centred" else {}),
                    "size": {c.slot.kind.param: _num(c.value)},
                    "rel_stderr": _num(float(r)),
                }
                for c, r in zip(self.candidates, self.rel_stderr, strict=True)
            ],
            "separations": [
                {"a": names[a], "b": names[b], "chi2": _num(s)} for a, b, s in self.pairs()
            ],
            "inseparable": [
                {"a": names[a], "b": names[b], "channel": ch} for a, b, ch in self.inseparable
            ],
            "random": {"weakest_chi2": _num(weak), "max_rel_stderr": _num(worst)},
            "weakest_chi2": _num(self.weakest),
            "max_rel_stderr": _num(self.max_rel_stderr),
            "labels": list(self.labels),
            "fixed": [[float(x) for x in row] for row in self.fixed],
            "sigma": dict(self.sigma),
            "pool": int(self.pool.shape[0]),
            "unseen": [c.spec for c in self.unseen],
        }


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None
