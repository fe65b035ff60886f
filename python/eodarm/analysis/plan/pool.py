"""The configurations a plan chooses from, and the states measured at each of them.

A *configuration* is a pose (unloaded angles); at each one the same *payloads* are applied:
a load cycle from a zeroed reference (docs/diagnosis.md, "Load sequences"), or single
loadings each from its own reference. The *pool* is a few hundred configurations the arm can
reach: drawn uniformly within the angle ranges, kept when the actuators are well away from
their joints and within their strokes (:func:`eodarm.analysis.synth.random_configs`), and when
every planned state solves with status ``ok`` under the baseline and under every candidate
at its size (docs/model.md §7).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from eodarm.analysis.synth import DEFAULT_RANGES, random_configs
from eodarm.data.channels import channel_names
from eodarm.data.measurements import Measurements
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect

__all__ = ["DEFAULT_CYCLE", "Payloads", "angle_ranges", "draw_pool", "reachable", "states_of"]

FloatArray = npt.NDArray[np.float64]

#: The default payloads: the seed paper's load cycle, from the zeroed reference (kg).
DEFAULT_CYCLE = (0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0)


@dataclass(frozen=True)
class Payloads:
    """The payloads applied at every planned configuration.

    ``masses_kg`` as the user gave them: with ``sequence`` a load cycle whose leading 0 is
    the zeroed reference (not a measured state), otherwise single loadings, each from its
    own reference.
    """

    masses_kg: tuple[float, ...]
    sequence: bool

    @classmethod
    def of(cls, masses_kg: Sequence[float], sequence: bool) -> Payloads:
        """Checked payloads.

        Raises
        ------
        EodarmError
            For an empty list, a negative or non-finite mass, or a cycle with no state after
            its reference.
        """
        flag = "--sequence" if sequence else "--masses"
        m = [float(x) for x in masses_kg]
        if not m:
            raise EodarmError(f"{flag}: give at least one payload mass")
        if not all(math.isfinite(x) and x >= 0 for x in m):
            raise EodarmError(f"{flag} {','.join(f'{x:g}' for x in m)}: masses must be >= 0 kg")
        out = cls(tuple(m), bool(sequence))
        if out.states.size == 0 or not (out.states > 0).any():
            raise EodarmError(f"{flag} {','.join(f'{x:g}' for x in m)}: no payload to measure")
        return out

    @property
    def states(self) -> FloatArray:
        """The payload of each measured state of one configuration (kg), in order."""
        m = np.array(self.masses_kg, dtype=float)
        if self.sequence and m.size > 1 and m[0] == 0.0:
            return m[1:]
        return m

    @property
    def heaviest(self) -> float:
        """The largest payload (kg)."""
        return float(self.states.max())


def states_of(
    arm: Arm,
    alpha: FloatArray,
    payloads: Payloads,
    labels: Sequence[str] | None = None,
    sequence: bool | None = None,
) -> Measurements:
    """The planned states of configurations ``alpha`` (K, n) as measurements to fill: one row
    per configuration × state, configuration-major, every channel not measured (NaN).

    With a load cycle each configuration is one sequence (``step`` 1, 2, …); ``sequence``
    overrides that (False: each state loaded once from its reference, what a model without
    memory predicts alike).
    """
    alpha = np.atleast_2d(np.asarray(alpha, dtype=float))
    k = alpha.shape[0]
    states = payloads.states
    s = states.size
    names = [f"c{i + 1}" for i in range(k)] if labels is None else list(labels)
    seq = payloads.sequence if sequence is None else sequence
    chans = channel_names(arm.n)
    rows = k * s
    empty = np.full((rows, len(chans)), np.nan)
    return Measurements(  # nothing measured: no file's checks to run
        source="<plan>",
        n=arm.n,
        config=np.repeat(np.array(names, dtype=str), s),
        alpha_deg=np.repeat(alpha, s, axis=0),
        mass_kg=np.tile(states, k),
        channels=tuple(chans),
        values=empty,
        sigma=empty,
        line=np.arange(2, rows + 2),
        step=np.tile(np.arange(1, s + 1), k) if seq else None,
    )


def angle_ranges(
    arm: Arm, ranges: Mapping[int, tuple[float, float]] | None
) -> list[tuple[float, float]]:
    """The angle range of every link (degrees): ``ranges`` (1-based link → (lo, hi)) where
    given, else the default ranges of :func:`~eodarm.analysis.synth.random_configs`.

    Raises
    ------
    EodarmError
        For a link the arm does not have, or a range that is not finite with lo < hi.
    """
    out = [DEFAULT_RANGES[min(i, len(DEFAULT_RANGES) - 1)] for i in range(arm.n)]
    for link, (lo, hi) in (ranges or {}).items():
        if not 1 <= int(link) <= arm.n:
            raise EodarmError(f"--range alpha{link}: the arm '{arm.name}' has links 1–{arm.n}")
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise EodarmError(f"--range alpha{link}={lo:g}:{hi:g}: need finite LO < HI (degrees)")
        out[int(link) - 1] = (float(lo), float(hi))
    return out


def draw_pool(
    arm: Arm,
    size: int,
    ranges: Sequence[tuple[float, float]],
    rng: np.random.Generator,
) -> FloatArray:
    """Up to ``size`` well-conditioned configurations within ``ranges`` (K, n), degrees.

    Raises
    ------
    EodarmError
        When none can be found (an impossible range), naming why they were rejected.
    """
    try:
        return random_configs(arm, size, rng, alpha_ranges=ranges, partial=True, max_draws=50_000)
    except EodarmError as exc:
        text = str(exc)
        stroke = text.split("; actuator", 1)
        why = "actuator" + stroke[1] if len(stroke) == 2 else text.split("rejected: ", 1)[-1]
        within = ", ".join(f"alpha{i + 1} {lo:g}:{hi:g}" for i, (lo, hi) in enumerate(ranges))
        raise EodarmError(
            f"--range: no configuration the arm can reach within {within} deg: {why}"
        ) from None


def reachable(
    arm: Arm,
    alpha: FloatArray,
    payloads: Payloads,
    effects: Sequence[Effect],
    self_weight: bool,
) -> tuple[npt.NDArray[np.bool_], dict[str, npt.NDArray[np.bool_]]]:
    """Which configurations have every planned state ``ok`` (docs/model.md §7).

    Returns
    -------
    ok : (K,) every state ``ok`` under the baseline and under each effect.
    under : effect key → (K,) every state ``ok`` with that effect alone added.

    A friction is solved as the planned load sequence (its memory matters); the other
    effects as single loadings, which is what a state of a sequence is without friction.
    """
    from eodarm.analysis.sequences import FRICTIONS
    from eodarm.model.solver import solve, solve_sequence

    states = payloads.states
    s = states.size
    k = alpha.shape[0]
    rows_alpha = np.repeat(alpha, s, axis=0)
    rows_mass = np.tile(states, k)

    def flat(effs: list[Effect]) -> npt.NDArray[np.bool_]:
        out = solve(arm, rows_alpha, rows_mass, effects=effs, self_weight=self_weight)
        return np.asarray((out["status"] == 0).reshape(k, s).all(axis=1), dtype=bool)

    ok = flat([])
    under: dict[str, npt.NDArray[np.bool_]] = {}
    for e in effects:
        if e.name in FRICTIONS and payloads.sequence:
            out = solve_sequence(
                arm, alpha, states, effects=[e], self_weight=self_weight, nan_on_failure=True
            )
            good = np.asarray((out["status"] == 0).reshape(k, s).all(axis=1), dtype=bool)
        else:
            good = flat([e])
        under[e.spec] = good
        ok = ok & good
    return ok, under


def combined(
    parts: Sequence[Measurements],
    values: Sequence[FloatArray],
    weights: Sequence[FloatArray],
) -> Measurements:
    """One set of measurements of several sets of states (the planned configurations and a
    campaign already measured), holding ``values`` (N_i, C) where ``weights`` (1/σ) are > 0.

    When any part is a load sequence, a part of single loadings becomes sequences of one
    state each (which is what a row without ``step`` means).
    """
    seq = any(m.has_sequences for m in parts)
    labels: list[str] = []
    alpha, mass, steps, vals, sigs = [], [], [], [], []
    for i, (m, v, w) in enumerate(zip(parts, values, weights, strict=True)):
        use = w > 0
        vals.append(np.where(use, v, np.nan))
        sigs.append(np.where(use, 1.0 / np.where(use, w, 1.0), np.nan))
        alpha.append(np.asarray(m.alpha_deg, dtype=float))
        mass.append(np.asarray(m.mass_kg, dtype=float))
        if m.has_sequences:
            labels += [f"{i}:{c}" for c in m.config.tolist()]
            steps.append(np.asarray(m.step))
        else:
            labels += [f"{i}:{c}#{r}" for r, c in enumerate(m.config.tolist())]
            steps.append(np.ones(m.n_rows, dtype=np.int64))
    v_all = np.concatenate(vals)
    s_all = np.concatenate(sigs)
    chans = channel_names(parts[0].n)
    return Measurements.from_arrays(
        config=np.array(labels, dtype=object),
        alpha_deg=np.concatenate(alpha),
        mass_kg=np.concatenate(mass),
        values={ch: v_all[:, j] for j, ch in enumerate(chans)},
        sigma={ch: s_all[:, j] for j, ch in enumerate(chans)},
        source="<plan>",
        step=np.concatenate(steps) if seq else None,
    )


def payloads_of(meas: Measurements) -> Payloads:
    """The payloads a measured campaign applied, to continue it alike: the load cycle of its
    first sequence (from a zeroed reference) when it has a ``step`` column, else its payloads
    in the order they first appear, as single loadings."""
    if meas.has_sequences:
        rows = meas.sequences()[0]
        masses = np.asarray(meas.mass_kg[rows], dtype=float)
        masses = masses[~np.asarray(meas.reference)[rows]]
        return Payloads.of([0.0, *masses.tolist()], sequence=True)
    seen = dict.fromkeys(float(m) for m in np.asarray(meas.mass_kg, dtype=float))
    return Payloads.of(list(seen), sequence=False)
