"""What each candidate does to the channels of a set of states: its *signature*.

A candidate's signature is the change of every channel at every state when the effect is
added at its size: ``y(θ_size) − y(θ_neutral)`` (mm or degrees). It is computed once over the
whole pool of configurations (and once over a campaign already measured) with the solvers the
fit uses (:meth:`eodarm.analysis.fit.Problem.evaluate`: the compiled core's batch solve, or
its load sequences when a friction or a sequence is involved).

For the fits that separate two candidates, a candidate's response is needed at other values
of its parameter too:

* an effect whose response is linear in its parameter (springs, bending, the base, gaps: their
  deflection is linear in θ up to the exact closure of the pose, docs/diagnosis.md) is a
  *ray*: its response at θ is ``(θ − θ_neutral)/(θ_size − θ_neutral)`` times its signature,
  so fitting it to data is a projection;
* a friction (its response is piecewise linear with kinks where states start to slip) and a
  user-written effect (whose form is unknown) is a *curve*: its response is solved at sample
  values of its parameter and taken as linear between them.

:func:`reduce` turns the responses into per-configuration dot products under a choice of
channels and noise; every quantity a separation needs is a sum of them over the chosen
configurations (:mod:`eodarm.analysis.plan.separation`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from eodarm.analysis.fit import Problem
from eodarm.analysis.plan.candidates import Candidate
from eodarm.data.measurements import Measurements
from eodarm.model.arm import Arm
from eodarm.model.effects import Slot

__all__ = ["Reduced", "Responses", "StateSet", "reduce"]

FloatArray = npt.NDArray[np.float64]


class StateSet:
    """Predictions of models on a set of states (measurements, their values unused).

    A user-written effect holds no history (docs/custom-effects.md): it is evaluated on the
    same states loaded once each, which the compiled core solves (a sequence with it would
    go through the numpy reference).
    """

    def __init__(self, arm: Arm, meas: Measurements, self_weight: bool) -> None:
        self.meas = meas
        self.prob = Problem(arm, meas, self_weight)
        flat = dataclasses.replace(meas, step=None) if meas.has_sequences else meas
        self.flat = Problem(arm, flat, self_weight) if flat is not meas else self.prob
        # a rotary drive has no length channel: its dlK_mm never has a value (and no response)
        drives = {f"dl{i + 1}_mm" for i, k in enumerate(arm.kinds) if k == "rotary"}
        self.no_channel = np.array([c in drives for c in meas.channels])
        self.y0 = np.where(self.no_channel, 0.0, self.prob.evaluate([])[0])
        self._y0_flat: FloatArray | None = None
        self.solves = 1

    def response(self, slot: Slot, theta: float, nan_on_failure: bool = False) -> FloatArray:
        """(N, C) change of every channel at every state with ``slot`` at θ added (with
        ``nan_on_failure``, NaN at the states the model cannot solve)."""
        self.solves += 1
        if slot.kind.custom and self.flat is not self.prob:
            if self._y0_flat is None:
                self._y0_flat = np.where(self.no_channel, 0.0, self.flat.evaluate([])[0])
            y = self.flat.evaluate([(slot, theta)], nan_on_failure=nan_on_failure)[0]
            return np.where(self.no_channel, 0.0, y - self._y0_flat)
        y = self.prob.evaluate([(slot, theta)], nan_on_failure=nan_on_failure)[0]
        return np.where(self.no_channel, 0.0, y - self.y0)


@dataclass
class Responses:
    """The candidates' responses on a set of states.

    ``curves[c]`` is (G_c, N, C): candidate c's response at its samples
    ``candidates[c].samples`` (the first is its neutral value: zero), N states, C channels;
    a ray has two samples, the neutral value and its size.
    """

    candidates: list[Candidate]
    curves: list[FloatArray]

    @classmethod
    def compute(cls, states: StateSet, candidates: Sequence[Candidate]) -> Responses:
        """The responses at every sample; NaN at a state the model cannot solve there (a
        curve sampled far beyond its size: :meth:`truncated` cuts it)."""
        curves = []
        for cand in candidates:
            n, c = states.y0.shape
            out = np.zeros((len(cand.samples), n, c))
            for k, t in enumerate(cand.samples):
                if k == 0:
                    continue
                out[k] = states.response(cand.slot, cand.neutral + t, nan_on_failure=True)
            curves.append(out)
        return cls(list(candidates), curves)

    def solvable(self) -> list[int]:
        """For each candidate, how many of its samples (from the first) solve at every
        state."""
        out = []
        for u in self.curves:
            bad = ~np.isfinite(u).all(axis=(1, 2))
            out.append(int(np.argmax(bad)) if bad.any() else u.shape[0])
        return out

    def truncated(self, keep: Sequence[int]) -> Responses:
        """Each candidate's curve cut to its first ``keep`` samples (and the candidate's
        samples with it)."""
        cands = [
            dataclasses.replace(c, samples=c.samples[:k])
            for c, k in zip(self.candidates, keep, strict=True)
        ]
        return Responses(cands, [u[:k] for u, k in zip(self.curves, keep, strict=True)])

    def signature(self, c: int) -> FloatArray:
        """(N, C) candidate c's signature: its response at its size."""
        return self.curves[c][self.candidates[c].at_size]

    def rows(self, rows: npt.NDArray[np.intp]) -> Responses:
        """The same responses on a subset of the states."""
        return Responses(self.candidates, [u[:, rows] for u in self.curves])


@dataclass
class Reduced:
    """Per-group dot products of whitened responses (each array's first axis: the group).

    With the responses whitened (divided by σ, zero where a channel is not measured) and
    summed over the rows of each group (a configuration, or a whole campaign):

    * ``gram`` (Q, C, C): signature · signature;
    * ``cross`` (Q, C, K, G): signature of each candidate · response of curve k at sample g;
    * ``norm`` (Q, K, G): |response of curve k at sample g|²;
    * ``adj`` (Q, K, G − 1): response at g · response at g + 1 (the segments between samples);
    * ``slope`` (Q, C): |∂y/∂θ at the size|² (its Fisher information).

    Curves of fewer samples than G are padded with their last sample (a segment of length 0).
    Every quantity is a sum over rows, so a plan's is the sum of its configurations'.
    """

    gram: FloatArray
    cross: FloatArray
    norm: FloatArray
    adj: FloatArray
    slope: FloatArray

    def total(self, groups: npt.NDArray[np.intp] | None = None) -> Reduced:
        """The sum over ``groups`` (all when None), keeping a group axis of length 1."""
        pick = slice(None) if groups is None else np.asarray(groups, dtype=np.intp)
        return Reduced(
            *(
                a[pick].sum(axis=0, keepdims=True)
                for a in (self.gram, self.cross, self.norm, self.adj, self.slope)
            )
        )

    def __add__(self, other: Reduced) -> Reduced:
        return Reduced(
            self.gram + other.gram,
            self.cross + other.cross,
            self.norm + other.norm,
            self.adj + other.adj,
            self.slope + other.slope,
        )

    def take(self, groups: npt.NDArray[np.intp]) -> Reduced:
        """The groups ``groups``, each kept apart."""
        return Reduced(
            *(a[groups] for a in (self.gram, self.cross, self.norm, self.adj, self.slope))
        )

    def zeros_like(self) -> Reduced:
        """Sums of nothing, shaped as one group of these."""
        return Reduced(
            *(
                np.zeros((1, *a.shape[1:]))
                for a in (self.gram, self.cross, self.norm, self.adj, self.slope)
            )
        )


def curve_indices(candidates: Sequence[Candidate]) -> list[int]:
    """The candidates fitted as curves (frictions, user-written effects), in order."""
    return [i for i, c in enumerate(candidates) if c.curve]


def reduce(resp: Responses, weight: FloatArray, starts: npt.NDArray[np.intp]) -> Reduced:
    """Per-group dot products of the whitened responses.

    Parameters
    ----------
    resp : the responses on N states.
    weight : (N, C) 1/σ of each cell, 0 where it is not measured.
    starts : (Q,) the first state of each group; a group's states run to the next start (the
        states are grouped in order: a configuration's rows are consecutive).
    """
    cands = resp.candidates
    n_c = len(cands)
    curves = curve_indices(cands)
    g = max([len(cands[i].samples) for i in curves], default=1)
    n_q = len(starts)

    def per_group(rows: FloatArray) -> FloatArray:
        return np.add.reduceat(rows, starts, axis=0)

    # signatures (N, C, Ch) whitened, and their slopes at the size
    sig = np.stack([resp.signature(i) for i in range(n_c)], axis=1) * weight[:, None, :]
    slope_vec = np.stack([_slope(resp, i) for i in range(n_c)], axis=1) * weight[:, None, :]
    gram = per_group(np.einsum("nac,nbc->nab", sig, sig, optimize=True))
    slope = per_group((slope_vec**2).sum(axis=2))
    k = len(curves)
    cross = np.zeros((n_q, n_c, k, g))
    norm = np.zeros((n_q, k, g))
    adj = np.zeros((n_q, k, max(g - 1, 0)))
    for j, i in enumerate(curves):
        u = resp.curves[i] * weight  # (G_i, N, Ch)
        if u.shape[0] < g:
            u = np.concatenate([u, np.repeat(u[-1:], g - u.shape[0], axis=0)])
        cross[:, :, j, :] = per_group(np.einsum("nac,gnc->nag", sig, u, optimize=True))
        norm[:, j, :] = per_group((u * u).sum(axis=2).T)
        if g > 1:
            adj[:, j, :] = per_group((u[:-1] * u[1:]).sum(axis=2).T)
    return Reduced(gram, cross, norm, adj, slope)


def _slope(resp: Responses, i: int) -> FloatArray:
    """(N, Ch) ∂y/∂θ of candidate i at its size: the ray's signature over its step, or a
    curve's central secant between the samples beside its size."""
    cand = resp.candidates[i]
    u = resp.curves[i]
    if not cand.curve:
        return u[1] / cand.delta
    lo, hi = cand.at_size - 1, cand.at_size + 1
    t = cand.samples
    return (u[hi] - u[lo]) / (t[hi] - t[lo])
