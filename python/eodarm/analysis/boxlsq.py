"""Least squares with bounds on each unknown, exact, for the few parameters of a fit.

    minimize ‖A x − r‖²  subject to  lo ≤ x ≤ hi        (A: m × n, n small)

The fits of :mod:`eodarm.analysis.fit` take one such step per Gauss–Newton iteration, with n
the number of fitted effects (1–3 in a diagnosis, rarely more than 8). scipy's
``lsq_linear`` solves it, but importing :mod:`scipy.optimize` costs about 0.5 s at the start
of a command, several times the whole diagnosis of a small data set.

The problem is a convex quadratic programme, so its minimizer x* is the unconstrained
least-squares solution of the unknowns *not* at a bound, with the others held at theirs.
Hence:

1. solve without bounds; a feasible solution is the answer (the common case);
2. otherwise try every assignment of each unknown to {free, lower bound, upper bound}
   (bounds that are infinite are skipped), solve the free unknowns by least squares, keep the
   feasible solutions and return the one of least ‖A x − r‖². The assignment of x* is among
   them, and every other feasible point costs at least as much: the result is exact.

The enumeration has at most 3ⁿ cases; beyond :data:`MAX_ENUMERATED` unknowns scipy's bounded
variable least squares is used instead.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import numpy.typing as npt

__all__ = ["MAX_ENUMERATED", "bounded_lstsq"]

#: Up to this many unknowns the enumeration above is used (3⁶ = 729 small solves at most).
MAX_ENUMERATED = 6

Array = npt.NDArray[np.float64]


def _lstsq(a: Array, r: Array) -> Array:
    if a.shape[1] == 0:
        return np.zeros(0)
    return np.asarray(np.linalg.lstsq(a, r, rcond=None)[0])


def bounded_lstsq(a: Array, r: Array, lo: Array, hi: Array) -> Array:
    """argmin ‖a x − r‖ subject to lo ≤ x ≤ hi (lo ≤ hi; ±inf for no bound).

    Columns are scaled to unit norm first (a zero column stays zero: that unknown is
    undetermined, and the minimum-norm solution leaves it at 0 when 0 is allowed).
    """
    a = np.asarray(a, dtype=float)
    r = np.asarray(r, dtype=float)
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    n = a.shape[1]
    norms = np.linalg.norm(a, axis=0)
    norms[norms == 0] = 1.0
    an = a / norms
    lo_n, hi_n = lo * norms, hi * norms
    if n > MAX_ENUMERATED:
        from scipy.optimize import lsq_linear

        res = lsq_linear(an, r, bounds=(lo_n, hi_n), method="bvls")
        return np.clip(np.asarray(res.x) / norms, lo, hi)
    return np.clip(_enumerate(an, r, lo_n, hi_n) / norms, lo, hi)


def _feasible(x: Array, lo: Array, hi: Array) -> bool:
    tol = 1e-12 * (1.0 + np.abs(x))
    return bool(np.all(x >= lo - tol) and np.all(x <= hi + tol))


def _enumerate(a: Array, r: Array, lo: Array, hi: Array) -> Array:
    n = a.shape[1]
    x = _lstsq(a, r)
    if _feasible(x, lo, hi):
        return np.clip(x, lo, hi)
    choices = [
        [c for c, bound in (("free", 0.0), ("lo", lo[j]), ("hi", hi[j])) if math.isfinite(bound)]
        for j in range(n)
    ]
    best, best_cost = np.clip(np.zeros(n), lo, hi), math.inf
    for pattern in itertools.product(*choices):
        if all(p == "free" for p in pattern):
            continue  # tried above
        free = np.array([p == "free" for p in pattern])
        xk = np.where(np.array([p == "hi" for p in pattern]), hi, lo)
        xk = np.where(free, 0.0, xk)
        rk = r - a[:, ~free] @ xk[~free]
        xk[free] = _lstsq(a[:, free], rk)
        if not _feasible(xk, lo, hi):
            continue
        res = a @ xk - r
        cost = float(res @ res)
        if cost < best_cost:
            best, best_cost = np.clip(xk, lo, hi), cost
    return best
