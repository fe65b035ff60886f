"""Rehearsal records: a campaign as a logger would write it (docs/records.md).

Each configuration gets one record of its payload sequence (e.g. 0, 1.5, 5, 6.5, 5, 1.5, 0 kg),
sampled at ``rate_hz`` with a little jitter. What the sensors read:

* each channel's **offset** (the sensors are not zeroed: a constant of a few hundred noise
  units);
* the **model's values** of every state, loaded once from the reference
  (:func:`state_values`, ``eodarm.solve_sequence`` with the hidden effects);
* between two states, a **hand on the plate**: a pressing force of 1–3 kg that rises and
  falls over about a second with a tremor, then the new weight lands and the arm **rings
  into the new level** (a damped 4–8 Hz oscillation of a time constant of about 0.1 s);
* **time-correlated noise**: per channel an AR(1) process of correlation time ``corr_s``
  and standard deviation σ (the channel's noise level), plus white noise of 0.3 σ;
* optional **drift**: a state that creeps at a given rate (σ per second) on every channel,
  and stays where it crept to.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.synth import _sigmas
from eodarm.atomic import atomic_files
from eodarm.data.channels import channel_names, channel_values, expand_channels
from eodarm.data.records import RecordSpec, write_campaign, write_record
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, as_effects
from eodarm.model.solver import solve_sequence

__all__ = ["SynthRecord", "state_values", "synth_records", "write_synth_campaign"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class SynthRecord:
    """One synthetic record: its campaign entry, samples and the truth behind them.

    ``truth`` is (S, C): each state's model values relative to the reference (the first
    state), in the order of ``channels``.
    """

    config: str
    alpha_deg: tuple[float, ...]
    masses_kg: tuple[float, ...]
    time_s: FloatArray
    channels: tuple[str, ...]
    values: FloatArray
    truth: FloatArray
    sigma: FloatArray


def state_values(
    arm: Arm,
    alpha_deg: FloatArray,
    sequence: Sequence[float],
    hidden: Iterable[Effect],
    self_weight: bool = True,
) -> FloatArray:
    """The model's values (K, S, C) of each configuration's states, relative to its
    reference (the first state), every channel of the arm.

    The states are one load sequence from the unloaded reference
    (:func:`eodarm.solve_sequence`), so friction holds what the states before let it hold and
    a gap stays where the last force pushed it (docs/model.md §9). When the sequence starts
    at 0 kg (the usual zeroed reference) that first state *is* the reference; otherwise the
    first state is a loaded one and the others are taken relative to it.
    """
    k = alpha_deg.shape[0]
    names = channel_names(arm.n)
    seq = np.asarray(sequence, dtype=float)
    zero_first = seq[0] == 0.0
    after = seq[1:] if zero_first else seq
    effects = as_effects(hidden)
    if after.size == 0:
        return np.zeros((k, 1, len(names)))
    out = solve_sequence(
        arm, alpha_deg, after, effects=effects, self_weight=self_weight, strict=True
    )
    s = after.size
    flat = {key: a.reshape(k * s, *a.shape[2:]) for key, a in out.items()}
    vals = channel_values(flat, names).reshape(k, s, -1)
    if zero_first:
        return np.concatenate([np.zeros((k, 1, vals.shape[2])), vals], axis=1)
    return vals - vals[:, :1, :]


def synth_records(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    sequence: Sequence[float],
    hidden: Effect | Iterable[Effect] = (),
    channels: str | Iterable[str] | None = None,
    sigma: Mapping[str, float] | None = None,
    noise: float = 1.0,
    seed: int = 0,
    self_weight: bool = True,
    rate_hz: float = 300.0,
    hold_s: float = 8.0,
    corr_s: float = 0.05,
    drift: Mapping[int, float] | None = None,
    ring_s: float = 0.1,
) -> list[SynthRecord]:
    """One rehearsal record per configuration (see the module docstring).

    Parameters
    ----------
    arm : the arm.
    alpha_deg : (K, n) unloaded angles, degrees.
    sequence : the payloads in the order they are applied, kg; the first is the reference.
    hidden : effects present in the synthetic arm.
    channels, sigma, noise : the logged channels and their noise standard deviation per
        sample, as :func:`eodarm.analysis.synth.synth` takes them (mm or degrees).
    seed : random seed.
    self_weight : include link and actuator weights.
    rate_hz : sampling rate, Hz.
    hold_s : how long each state is held, s (each record's holds vary by −10 … +20 %).
    corr_s : correlation time of the noise, s.
    drift : state index (1 = the first state after the reference) → creep rate in noise σ
        per second, on every channel.
    ring_s : time constant of the ringing into a new level, s.

    Raises
    ------
    EodarmError
        On a sequence of fewer than two payloads, a negative payload, a bad rate, hold or
        correlation time, or a drift of a state that is not in the sequence.
    """
    alpha = np.atleast_2d(np.asarray(alpha_deg, dtype=float))
    seq = [float(m) for m in sequence]
    if len(seq) < 2:
        raise EodarmError("--sequence: give the reference and at least one payload")
    if any(not math.isfinite(m) or m < 0 for m in seq):
        raise EodarmError(f"--sequence: payloads must be finite and >= 0, got {seq}")
    checks = (("rate", rate_hz), ("hold", hold_s), ("correlation time", corr_s), ("ring", ring_s))
    for name, val in checks:
        if not (math.isfinite(val) and val > 0):
            raise EodarmError(f"records: the {name} must be > 0, got {val}")
    drift = dict(drift or {})
    for k in drift:
        if not 0 <= k < len(seq):
            raise EodarmError(f"--drift: state {k} is not in the sequence (0…{len(seq) - 1})")
    every = channel_names(arm.n)
    chosen = expand_channels(channels, arm.n, arm.kinds)
    sel = [every.index(c) for c in chosen]
    sig_all = _sigmas(sigma or {}, every, noise)
    truth_all = state_values(arm, alpha, seq, as_effects(hidden), self_weight)
    unit_all = state_values(arm, alpha, [0.0, 1.0], as_effects(hidden), self_weight)[:, 1, :]
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    phi = math.exp(-dt / corr_s)
    out = []
    for i in range(alpha.shape[0]):
        truth = truth_all[i][:, sel]
        unit = unit_all[i][sel]
        sig = sig_all[sel]
        pieces_t: list[npt.NDArray[np.floating[Any]]] = []
        pieces_v: list[npt.NDArray[np.floating[Any]]] = []
        t_now = 0.0
        creep = np.zeros(len(sel))
        for k in range(len(seq)):
            if k > 0:  # the hand on the plate, then the weight lands
                h = round(rng.uniform(0.8, 1.5) * rate_hz) * dt
                tt = np.arange(round(h / dt)) * dt
                press = rng.uniform(1.0, 3.0)
                f = rng.uniform(2.0, 4.0)
                load = press * np.sin(np.pi * tt / h) ** 2 * (1 + 0.3 * np.sin(2 * np.pi * f * tt))
                pieces_t.append(t_now + tt)
                pieces_v.append(truth[k - 1] + creep + load[:, None] * unit[None, :])
                t_now += h
            hold = max(1, round(hold_s * rng.uniform(0.9, 1.2) * rate_hz)) * dt
            tt = np.arange(round(hold / dt)) * dt
            level = truth[k] + creep
            seg = np.broadcast_to(level, (tt.size, len(sel))).copy()
            if k > 0:
                step = truth[k] - truth[k - 1]
                fr = rng.uniform(4.0, 8.0)
                ring = np.exp(-tt / ring_s) * np.cos(2 * np.pi * fr * tt)
                seg += ring[:, None] * (0.4 * step + 0.3 * unit)[None, :]
            if k in drift:
                seg += (drift[k] * sig)[None, :] * tt[:, None]
                creep = creep + drift[k] * sig * (tt[-1] if tt.size else 0.0)
            pieces_t.append(t_now + tt)
            pieces_v.append(seg)
            t_now += hold
        t = np.concatenate(pieces_t)
        t = t + rng.uniform(0.0, 0.3 * dt, t.size)  # irregular sampling, still increasing
        v = np.concatenate(pieces_v)
        m = t.size
        innov = rng.standard_normal((m, len(sel))) * math.sqrt(1 - phi * phi)
        from scipy.signal import lfilter

        z0 = rng.standard_normal(len(sel)) * phi
        ar = lfilter([1.0], [1.0, -phi], innov, axis=0, zi=z0[None, :])[0]
        v = v + sig[None, :] * (ar + 0.3 * rng.standard_normal((m, len(sel))))
        offset = rng.uniform(-300.0, 300.0, len(sel)) * sig
        v = v + offset[None, :]
        out.append(
            SynthRecord(
                config=f"c{i + 1}",
                alpha_deg=tuple(float(a) for a in alpha[i]),
                masses_kg=tuple(seq),
                time_s=t,
                channels=tuple(chosen),
                values=v,
                truth=truth,
                sigma=sig,
            )
        )
    return out


def write_synth_campaign(
    directory: str | Path,
    records: Sequence[SynthRecord],
    name: str = "campaign.toml",
    before: Callable[[list[Path]], None] | None = None,
) -> Path:
    """Write each record as ``<config>.csv`` and the campaign file into ``directory``, all or
    none (each to a temporary sibling, renamed into place when the last is complete:
    eodarm.atomic); return the campaign file's path.

    ``before``, when given, is called with every path to be written before any is (the
    command line refuses there what it must not replace)."""
    d = Path(directory)
    path = d / name
    files = [d / f"{r.config}.csv" for r in records]
    if before is not None:
        before([*files, path])
    d.mkdir(parents=True, exist_ok=True)
    specs = []
    with atomic_files() as batch:
        for f, r in zip(files, records, strict=True):
            write_record(batch.open(f, newline=""), r.time_s, r.channels, r.values)
            specs.append(RecordSpec(f, r.config, r.alpha_deg, r.masses_kg))
        write_campaign(path, specs, out=batch.open(path))
    return path
