"""Where each channel's σ comes from: the file, the repeats, or the default levels.

A value whose ``sigma_<channel>`` cell is given keeps that σ. The values of a channel that
have no σ (no ``sigma_`` column for the channel, or an empty cell in it) all get one σ for the
channel:

1. **pooled from the repeats**, when states were measured more than once. A *state* is a
   configuration label with its unloaded angles and its payload mass, all exactly equal
   (:func:`state_groups`). The pooled variance of the channel is

   .. math:: s^2 = \\frac{\\sum_g \\sum_{i \\in g} (x_i - \\bar x_g)^2}{\\sum_g (n_g - 1)}

   over the states g, with ``n_g`` the number of values of the channel (measured, σ not given)
   in state g; states measured once contribute nothing. ``ν = Σ_g (n_g − 1)`` is its number of
   degrees of freedom. It is used when ``ν ≥`` :data:`MIN_DOF` (5) and ``s > 0``;
2. otherwise **the default level** of the channel (:func:`~eodarm.data.channels.default_sigma`),
   and :attr:`ChannelNoise.reason` says why the repeats were not used.

Pooling across states is what makes a handful of repeats per state enough: the instrument is
the same for every state and its noise does not depend on the pose. docs/diagnosis.md ("Noise
from repeats") gives the reasoning and the limits.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from eodarm.data.channels import default_sigma
from eodarm.data.sequences import sequence_rows
from eodarm.errors import EodarmError

__all__ = [
    "MIN_DOF",
    "ChannelNoise",
    "Pooled",
    "assign_sigma",
    "check_noise",
    "pooled_sigma",
    "sequence_state_groups",
    "state_groups",
]

#: Fewest degrees of freedom Σ(n_g − 1) with which a σ pooled from repeats is used. With ν
#: degrees of freedom σ itself is uncertain by about 1/√(2ν): 32 % at ν = 5.
MIN_DOF = 5

Source = Literal["given", "repeats", "default"]
FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class ChannelNoise:
    """Where the σ of one measured channel came from.

    Attributes
    ----------
    channel : the channel.
    source : ``"given"`` when every measured value of the channel has its σ in the file;
        otherwise where the σ of the values without one came from: ``"repeats"`` (pooled
        standard deviation of the repeated states) or ``"default"`` (the documented level).
    sigma : that σ (mm or degrees) for ``"repeats"`` and ``"default"``; ``NaN`` for
        ``"given"`` (each value has its own).
    states : repeated states found for the channel (states with ≥ 2 values without a σ).
    rows : values in those states.
    repeat_dof : Σ(n_g − 1) over those states, the degrees of freedom the repeats offer
        (also when they were too few and the default was used).
    reason : for ``"default"``, why the repeats were not used; ``""`` otherwise.
    """

    channel: str
    source: Source
    sigma: float
    states: int = 0
    rows: int = 0
    repeat_dof: int = 0
    reason: str = ""

    @property
    def dof(self) -> float:
        """Degrees of freedom of the σ used: ``repeat_dof`` for a σ pooled from repeats,
        ``math.inf`` for a given or default σ (treated as known exactly)."""
        return float(self.repeat_dof) if self.source == "repeats" else math.inf

    def to_json(self) -> dict[str, Any]:
        """``{"sigma", "source", "dof"}`` (+ ``"states"``, ``"rows"`` for repeats, ``"reason"``
        for a default); ``None`` stands for a σ per value (given) and an infinite dof."""
        out: dict[str, Any] = {
            "sigma": None if math.isnan(self.sigma) else self.sigma,
            "source": self.source,
            "dof": None if math.isinf(self.dof) else int(self.repeat_dof),
        }
        if self.source == "repeats":
            out["states"], out["rows"] = self.states, self.rows
        if self.reason:
            out["reason"] = self.reason
        return out


@dataclass(frozen=True)
class Pooled:
    """The pooled standard deviation of repeated values (:func:`pooled_sigma`)."""

    sigma: float  # NaN when dof == 0
    dof: int  # Σ(n_g − 1)
    states: int  # groups with ≥ 2 values
    rows: int  # values in those groups


def state_groups(
    config: Sequence[str] | npt.ArrayLike, alpha_deg: npt.ArrayLike, mass_kg: npt.ArrayLike
) -> npt.NDArray[np.int64]:
    """(N,) state index of each row: rows with the same configuration label and exactly the
    same unloaded angles and payload mass share one (numbered in order of first appearance)."""
    labels = [str(c) for c in np.asarray(config, dtype=object).ravel()]
    alpha = np.asarray(alpha_deg, dtype=float).reshape(len(labels), -1)
    mass = np.asarray(mass_kg, dtype=float).reshape(len(labels))
    ids: dict[tuple[Any, ...], int] = {}
    # + 0.0 makes -0.0 and 0.0 the same key
    out = [
        ids.setdefault((lab, *(a + 0.0).tolist(), float(m) + 0.0), len(ids))
        for lab, a, m in zip(labels, alpha, mass, strict=True)
    ]
    return np.array(out, dtype=np.int64)


def sequence_state_groups(
    config: Sequence[str] | npt.ArrayLike,
    alpha_deg: npt.ArrayLike,
    mass_kg: npt.ArrayLike,
    step: npt.ArrayLike,
    reference: npt.ArrayLike,
) -> npt.NDArray[np.int64]:
    """(N,) state index of each row of a file of load sequences (a ``step`` column).

    With memory, a state is its angles, its payload *and the payloads before it* in its
    sequence (a friction holds what the history let it hold): two rows are repeats only when
    all of these are equal, whatever their labels (a cycle repeated is written under another
    label). Written reference rows are not states of the history; they get groups of their
    own.
    """
    labels = np.array([str(c) for c in np.asarray(config, dtype=object).ravel()], dtype=str)
    rows = labels.size
    alpha = np.asarray(alpha_deg, dtype=float).reshape(rows, -1) + 0.0  # -0.0 is 0.0
    mass = np.asarray(mass_kg, dtype=float).reshape(rows) + 0.0
    steps = np.asarray(step, dtype=np.int64).reshape(rows)
    refs = np.asarray(reference, dtype=bool).reshape(rows)
    # A history is numbered by a trie: (the number of the payloads before, this payload) →
    # a number, so that a row's key is built in constant time (a tuple of every payload
    # before it would cost the square of a sequence's length).
    history = np.full(rows, -1, dtype=np.int64)
    trie: dict[tuple[int, float], int] = {}
    masses = mass.tolist()
    for seq in sequence_rows(labels, steps, refs):
        past = -1
        for r in seq.tolist():
            past = trie.setdefault((past, masses[r]), len(trie))
            history[r] = past
    ids: dict[tuple[Any, ...], int] = {}
    out = []
    rows_of = zip(alpha.tolist(), history.tolist(), refs.tolist(), strict=True)
    for r, (a, h, ref) in enumerate(rows_of):
        key: tuple[Any, ...] = ("reference", r) if ref else (*a, h)
        out.append(ids.setdefault(key, len(ids)))
    return np.array(out, dtype=np.int64)


def pooled_sigma(values: npt.ArrayLike, groups: npt.ArrayLike) -> Pooled:
    """Pooled standard deviation of ``values`` within ``groups``; ``NaN`` values are skipped.

    ``s² = Σ_g Σ_i (x_i − x̄_g)² / Σ_g (n_g − 1)``. Deviations are taken from each group's
    first value before averaging, so that identical repeats give exactly ``s = 0``.
    """
    x = np.asarray(values, dtype=float).ravel()
    g = np.asarray(groups).ravel()
    keep = ~np.isnan(x)
    x, g = x[keep], g[keep]
    if x.size == 0:
        return Pooled(math.nan, 0, 0, 0)
    _, first, inv, counts = np.unique(g, return_index=True, return_inverse=True, return_counts=True)
    d = x - x[first][inv]
    mean = np.bincount(inv, weights=d) / counts
    ss = float(np.sum((d - mean[inv]) ** 2))
    dof = int(np.sum(counts - 1))
    rep = counts >= 2
    sigma = math.sqrt(ss / dof) if dof > 0 else math.nan
    return Pooled(sigma, dof, int(rep.sum()), int(counts[rep].sum()))


def assign_sigma(
    channels: Sequence[str],
    values: FloatArray,
    sigma: FloatArray,
    given: BoolArray,
    groups: npt.NDArray[np.int64],
) -> tuple[FloatArray, BoolArray, BoolArray, dict[str, ChannelNoise]]:
    """The σ of every measured value: given, pooled from the repeats, or the default.

    Parameters
    ----------
    channels : the C channel names (columns of the arrays).
    values : (N, C) measured values, ``NaN`` where not measured.
    sigma : (N, C) σ where ``given`` (other cells are ignored).
    given : (N, C) bool, where the source gave a σ.
    groups : (N,) state index of each row (:func:`state_groups`).

    Returns
    -------
    sigma : (N, C) σ of every measured value, ``NaN`` elsewhere.
    default : (N, C) bool, values that got the default level.
    pooled : (N, C) bool, values that got the σ pooled from the repeats.
    noise : for every measured channel, its :class:`ChannelNoise`.
    """
    measured = ~np.isnan(values)
    given = given & measured
    need = measured & ~given
    out = np.where(given, sigma, np.nan)
    dflt = np.zeros(values.shape, dtype=bool)
    pooled = np.zeros(values.shape, dtype=bool)
    noise: dict[str, ChannelNoise] = {}
    for j, ch in enumerate(channels):
        if not measured[:, j].any():
            continue
        if not need[:, j].any():
            noise[ch] = ChannelNoise(ch, "given", math.nan)
            continue
        p = pooled_sigma(np.where(need[:, j], values[:, j], np.nan), groups)
        if p.dof >= MIN_DOF and p.sigma > 0:
            out[need[:, j], j] = p.sigma
            pooled[:, j] = need[:, j]
            noise[ch] = ChannelNoise(ch, "repeats", p.sigma, p.states, p.rows, p.dof)
            continue
        if p.dof == 0:
            why = "no state was measured more than once"
        elif p.dof < MIN_DOF:
            dof = f"{p.dof} degree{'s' if p.dof > 1 else ''}"
            why = f"the repeats give only {dof} of freedom (fewer than {MIN_DOF})"
        else:
            why = "the repeated values are identical (spread 0, e.g. rounded data)"
        s = default_sigma(ch)
        out[need[:, j], j] = s
        dflt[:, j] = need[:, j]
        noise[ch] = ChannelNoise(ch, "default", s, p.states, p.rows, p.dof, why)
    return out, dflt, pooled, noise


def check_noise(
    channels: Sequence[str],
    measured: BoolArray,
    default: BoolArray,
    pooled: BoolArray,
    noise: Mapping[str, ChannelNoise] | None,
    source: str,
) -> dict[str, ChannelNoise]:
    """The :class:`ChannelNoise` of every measured channel, consistent with the cell flags.

    A record of ``noise`` is kept where it matches (a subset keeps the estimate made on the
    whole file); a channel whose values all have a given σ is ``"given"``; defaults without a
    record get one. Pooled values without their ``"repeats"`` record are an error.
    """
    given = dict(noise or {})
    out: dict[str, ChannelNoise] = {}
    for j, ch in enumerate(channels):
        if not measured[:, j].any():
            continue
        rec = given.get(ch)
        if pooled[:, j].any():
            if rec is None or rec.source != "repeats":
                raise EodarmError(f"{source}: {ch} has pooled sigmas but no record of the pool")
        elif default[:, j].any():
            if rec is None or rec.source != "default":
                rec = ChannelNoise(ch, "default", default_sigma(ch))
        else:
            rec = ChannelNoise(ch, "given", math.nan)
        out[ch] = rec
    return out
