"""How well a set of states tells two candidates apart, and how well it determines each.

**Separation.** Candidate b *imitates* candidate a when b, its parameter fitted, is fitted to
a's noise-free predicted data (a's signature, whitened by the planned noise); what remains is
χ²(a → b). The separation of the pair is the smaller of χ²(a → b) and χ²(b → a); 25 or more
counts as separable (docs/plan.md). With the quantities of
:class:`~eodarm.analysis.plan.signatures.Reduced` summed over the chosen states:

* b a ray (its response μ times its signature s_b, μ within its bounds):
  χ² = |s_a|² − 2μ* s_a·s_b + μ*² |s_b|², μ* = s_a·s_b / |s_b|² clipped to the bounds;
* b a curve (its response u_b(t) linear between samples u_g, u_{g+1}): on each segment,
  u = u_g + λ(u_{g+1} − u_g) with λ in [0, 1], χ² is a quadratic in λ, minimised exactly; the
  least over the segments.

**Determination.** Fitted alone to data that hold it at its size, a candidate's parameter has
the standard error σ_θ = 1/|∂y/∂θ| (whitened), and its relative standard error at its size is
σ_θ/|θ| (also for a stiffness k = 1/θ: σ_k/k = σ_θ/θ). ≤ 10 % is *determined*.

Every function takes totals with a leading batch axis (one row per set of states) and returns
one row per set, so that a selection scores every configuration of the pool at once.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from eodarm.analysis.plan.candidates import Candidate
from eodarm.analysis.plan.signatures import Reduced, curve_indices

__all__ = ["MAX_REL_STDERR", "SEPARABLE", "directed", "rel_stderr", "separations"]

FloatArray = npt.NDArray[np.float64]

#: A separation of at least this χ² counts as separable.
SEPARABLE = 25.0
#: A relative standard error of at most this at the candidate's size counts as determined.
MAX_REL_STDERR = 0.10


def directed(tot: Reduced, cands: Sequence[Candidate]) -> FloatArray:
    """(B, C, C) χ²(a → b): what remains of a's signature (row a) when b (column b), its
    parameter fitted, imitates it."""
    gram = tot.gram
    b_n, c_n, _ = gram.shape
    own = np.einsum("baa->ba", gram)  # |s_a|²
    out = np.empty((b_n, c_n, c_n))
    rays = [i for i, c in enumerate(cands) if not c.curve]
    if rays:
        r = np.array(rays)
        lo = np.empty(len(rays))
        hi = np.empty(len(rays))
        for j, i in enumerate(rays):
            a, b = (x / cands[i].delta for x in cands[i].bounds)
            lo[j], hi[j] = min(a, b), max(a, b)
        ab = gram[:, :, r]  # (B, C, R): s_a · s_b
        bb = own[:, None, r]
        with np.errstate(divide="ignore", invalid="ignore"):
            mu = np.where(bb > 0, ab / bb, 0.0)
        mu = np.clip(mu, lo, hi)
        out[:, :, r] = own[:, :, None] - 2 * mu * ab + mu * mu * bb
    curves = curve_indices(cands)
    if curves:
        out[:, :, curves] = _curve_fit(tot, own)
    out = np.maximum(out, 0.0)
    idx = np.arange(c_n)
    out[:, idx, idx] = 0.0
    return out


def _curve_fit(tot: Reduced, own: FloatArray) -> FloatArray:
    """(B, C, K) least χ² of each curve imitating each signature (module notes)."""
    cross, norm, adj = tot.cross, tot.norm, tot.adj
    if cross.shape[-1] < 2:
        return np.broadcast_to(own[:, :, None], cross.shape[:3]).copy()
    r0 = cross[..., :-1]
    n0 = norm[:, None, :, :-1]
    m = adj[:, None]
    a2 = n0 - 2.0 * m + norm[:, None, :, 1:]  # |u_{g+1} − u_g|², (B, 1, K, G − 1)
    inv = np.divide(1.0, a2, out=np.zeros_like(a2), where=a2 > 0)
    # b1 = (m − n0) − (r1 − r0): the slope of χ²/2 along the segment at its start
    b1 = r0 - cross[..., 1:]
    b1 += m - n0
    lam = np.multiply(b1, -inv)
    np.clip(lam, 0.0, 1.0, out=lam)
    # χ² = |s|² − 2 r0 + n0 + λ (2 b1 + λ a2)
    b1 *= 2.0
    b1 += lam * a2
    b1 *= lam
    b1 -= 2.0 * r0
    b1 += n0
    return b1.min(axis=-1) + own[:, :, None]


def separations(tot: Reduced, cands: Sequence[Candidate]) -> FloatArray:
    """(B, C, C) the separation of every pair (symmetric; +inf on the diagonal)."""
    d = directed(tot, cands)
    sep = np.minimum(d, d.transpose(0, 2, 1))
    idx = np.arange(d.shape[1])
    sep[:, idx, idx] = np.inf
    return sep


def rel_stderr(tot: Reduced, cands: Sequence[Candidate]) -> FloatArray:
    """(B, C) relative standard error of each candidate's parameter at its size, fitted
    alone (inf where the states do not see it)."""
    theta = np.array([abs(c.theta) for c in cands])
    with np.errstate(divide="ignore"):
        return 1.0 / (theta * np.sqrt(tot.slope))


def fitted_curve_value(tot: Reduced, cands: Sequence[Candidate], a: int, b: int) -> float:
    """θ − neutral of curve b where it imitates a's signature best (for an exact refit's
    start)."""
    curves = curve_indices(cands)
    j = curves.index(b)
    cross, norm, adj = tot.cross[0, a, j], tot.norm[0, j], tot.adj[0, j]
    own = float(tot.gram[0, a, a])
    samples = cands[b].samples
    best, where = np.inf, 0.0
    for g in range(len(samples) - 1):
        a2 = norm[g] - 2 * adj[g] + norm[g + 1]
        b1 = (adj[g] - norm[g]) - (cross[g + 1] - cross[g])
        lam = float(np.clip(-b1 / a2, 0.0, 1.0)) if a2 > 0 else 0.0
        chi = own - 2 * cross[g] + norm[g] + lam * (2 * b1 + lam * a2)
        if chi < best:
            best, where = chi, samples[g] + lam * (samples[g + 1] - samples[g])
    return where
