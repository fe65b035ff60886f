"""Raw records to measurement rows (docs/records.md): each record's steady states
(:mod:`eodarm.analysis.record_states`), matched in order to its payloads, each state after the
reference minus the reference with the standard error of that difference
(:mod:`eodarm.analysis.record_noise`), and the refusals, in one line each.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.record_noise import drift_threshold, long_run_variance, mean_standard_error
from eodarm.analysis.record_states import MIN_DURATION_S, State, Trend, detect
from eodarm.data.channels import default_sigma
from eodarm.data.measurements import MAX_DALPHA_DEG, MAX_DISPLACEMENT_MM, MIN_SIGMA_FRACTION
from eodarm.data.record_text import few, shown
from eodarm.data.records import Campaign, Record, RecordError, RecordSpec, read_record

__all__ = [
    "RecordResult",
    "State",
    "Trend",
    "analyse_campaign",
    "analyse_record",
    "check",
    "drift_threshold",
    "long_run_variance",
    "mean_standard_error",
    "steady_states",
]

FloatArray = npt.NDArray[np.float64]


@dataclass
class RecordResult:
    """The steady states of one record, matched to its payloads.

    ``rows`` holds one dict per state after the reference: ``config``, ``alpha_deg``,
    ``mass_kg``, ``step`` (1, 2, …), ``values`` and ``sigma`` (by channel).
    ``refused`` is the one-line reason when the record was refused (then ``rows`` is empty).
    """

    spec: RecordSpec
    channels: tuple[str, ...]
    states: list[State]
    rows: list[dict[str, Any]]
    block: int
    refused: str | None = None
    refused_states: list[int] = field(default_factory=list)
    n_samples: int = 0
    trends: list[Trend] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` entry of the record: per state its times, payload, means, standard
        errors and drift rates; per trend its times and rates."""
        states = []
        masses = self.spec.masses_kg
        for k, s in enumerate(self.states):
            states.append(
                {
                    "step": k,
                    "start_s": s.t0,
                    "end_s": s.t1,
                    "mass_kg": masses[k] if k < len(masses) and self.refused is None else None,
                    "mean": _by(self.channels, s.mean),
                    "stderr": _by(self.channels, s.stderr),
                    "drift_per_s": _by(self.channels, s.slope),
                    "drift": bool(s.drift),
                }
            )
        trends = [
            {"start_s": tr.t0, "end_s": tr.t1, "rate_per_s": _by(self.channels, tr.slope)}
            for tr in self.trends
        ]
        return {
            "file": str(self.spec.file),
            "config": self.spec.config,
            "samples": self.n_samples,
            "states": states,
            "trends": trends,
            "refused": self.refused,
        }


def _by(channels: Sequence[str], v: FloatArray) -> dict[str, float]:
    return {c: float(x) for c, x in zip(channels, v, strict=True)}


def steady_states(
    time_s: npt.ArrayLike,
    values: npt.ArrayLike,
    min_duration_s: float = MIN_DURATION_S,
) -> tuple[list[State], int]:
    """The steady states of one record, their means, standard errors and drift rates.

    Parameters
    ----------
    time_s : (N,) sample times, s, increasing.
    values : (N, C) readings.
    min_duration_s : shortest steady state, s.

    Returns
    -------
    (states, block): the states in time order (``drift`` set where a slope is beyond
    :func:`drift_threshold` over all the record's states and channels) and the block size
    in samples. :func:`eodarm.analysis.record_states.detect` gives the trends too.
    """
    found = detect(np.asarray(time_s, dtype=float), np.asarray(values, dtype=float), min_duration_s)
    return found.states, found.block


# ---------------------------------------------------------------------------- a record
def analyse_record(
    record: Record,
    spec: RecordSpec,
    allow_drift: bool = False,
    min_duration_s: float = MIN_DURATION_S,
) -> RecordResult:
    """Find the steady states of ``record``, match them in order to ``spec.masses_kg`` and
    make the rows of the measurement file: each state after the reference, minus the
    reference, with the standard error of that difference.

    A record that cannot be matched is not raised on here: ``refused`` holds the one-line
    reason (so that its figure can still be drawn); :func:`check` raises it.
    """
    found = detect(record.time_s, record.values, min_duration_s)
    states = found.states
    res = RecordResult(
        spec,
        record.channels,
        states,
        [],
        found.block,
        n_samples=record.time_s.size,
        trends=found.trends,
    )
    f = shown(record.path)
    masses = spec.masses_kg
    if len(states) != len(masses):
        res.refused = _unmatched(f, states, found.trends, record.channels, len(masses))
        return res
    drifting = [k for k, s in enumerate(states) if s.drift]
    if drifting and not allow_drift:
        k = drifting[0]
        s = states[k]
        z = np.abs(s.slope) / s.slope_se
        j = int(np.nanargmax(z))
        rate = f"{record.channels[j]} {s.slope[j]:.3g} per s, {z[j]:.1f} times its standard error"
        if s.drift_z > s.drift_limit:
            why = f"{rate} (limit {s.drift_limit:.1f})"
        else:
            why = (
                f"its {len(record.channels)} channels together, χ² {s.joint:.0f} (limit "
                f"{s.joint_limit:.0f}); the most, {rate}"
            )
        res.refused = (
            f"{f}: the steady state at {s.t0:.1f}–{s.t1:.1f} s (payload {masses[k]:g} kg) "
            f"drifts: {why}; --allow-drift keeps it"
        )
        res.refused_states = drifting
        return res
    ref = states[0]
    for k, s in enumerate(states[1:], start=1):
        diff = s.mean - ref.mean
        sig = np.sqrt(s.stderr**2 + ref.stderr**2)
        wrong = _out_of_range(record.channels, diff, sig)
        if wrong:
            res.refused = (
                f"{f}: the steady state at {s.t0:.1f}–{s.t1:.1f} s (payload {masses[k]:g} kg): "
                f"{wrong}"
            )
            res.refused_states = [k]
            return res
        res.rows.append(
            {
                "config": spec.config,
                "alpha_deg": spec.alpha_deg,
                "mass_kg": masses[k],
                "step": k,
                "values": _by(record.channels, diff),
                "sigma": _by(record.channels, sig),
                "drift": s.drift or ref.drift,
            }
        )
    return res


def _unmatched(
    f: str, states: list[State], trends: list[Trend], channels: Sequence[str], payloads: int
) -> str:
    """The one line of a record whose steady states are not as many as its payloads: the
    first three states and any trend, and the count."""
    n = len(states)
    when = few([f"{s.t0:.1f}–{s.t1:.1f}" for s in states], n) or "none"
    more = "more" if n > payloads else "fewer"
    moving = ""
    if trends:
        tr = trends[0]
        others = f" (and {len(trends) - 1} more)" if len(trends) > 1 else ""
        moving = (
            f"; {tr.t0:.1f}–{tr.t1:.1f} s is a trend ({channels[tr.lead]} "
            f"{tr.slope[tr.lead]:.3g} per s){others}, not a steady state"
        )
    hint = (
        "a payload skipped or a pause too short?"
        if more == "fewer"
        else "a pause counted as a state?"
    )
    return (
        f"{f}: found {n} steady state{'' if n == 1 else 's'} (at {when} s), {more} than the "
        f"{payloads} payloads of masses_kg{moving}; {hint}"
    )


def _out_of_range(channels: Sequence[str], diff: FloatArray, sig: FloatArray) -> str:
    """What in a row would make the measurement file unreadable (its range, docs/formats.md
    §3), or ""."""
    for c, v, e in zip(channels, diff, sig, strict=True):
        limit = MAX_DALPHA_DEG if c.startswith("dalpha") else MAX_DISPLACEMENT_MM
        if not (math.isfinite(v) and abs(v) <= limit):
            return f"{c} changed by {v:.6g}, beyond ±{limit:g} (a sensor's reading wrong?)"
        low = MIN_SIGMA_FRACTION * default_sigma(c)
        if not (math.isfinite(e) and low <= e <= limit):
            return (
                f"{c}'s standard error {e:.3g} is outside [{low:g}, {limit:g}] (a channel that "
                "barely changes, or a sensor's reading wrong?)"
            )
    return ""


def check(result: RecordResult) -> None:
    """Raise the refusal of ``result`` (one line), if any."""
    if result.refused is not None:
        raise RecordError(result.refused)


# ---------------------------------------------------------------------------- a campaign
def analyse_campaign(
    campaign: Campaign,
    allow_drift: bool = False,
    min_duration_s: float = MIN_DURATION_S,
    on_record: Callable[[Record, RecordResult], None] | None = None,
    progress: bool | None = None,
) -> list[RecordResult]:
    """Every record of ``campaign``, one in memory at a time, with a progress bar on stderr
    (:mod:`eodarm.progress`).

    ``on_record(record, result)`` is called while the record is in memory (to draw it), the
    refused one included, before the refusal is raised.

    Raises
    ------
    RecordError
        The first record that is malformed or cannot be matched to its payloads (one line).
    """
    from eodarm.progress import bar

    out: list[RecordResult] = []
    b = bar(len(campaign.records), "eodarm records", progress=progress, unit="record")
    try:
        for spec in campaign.records:
            record = read_record(spec.file, campaign.n)
            res = analyse_record(record, spec, allow_drift, min_duration_s)
            if on_record is not None:
                on_record(record, res)
            del record
            check(res)
            out.append(res)
            if b is not None:
                b.update(1)
    finally:
        if b is not None:
            b.close()
    return out
