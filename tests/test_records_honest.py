"""Records that hold (docs/records.md): on rehearsal records with a hand pressing on the plate
and the arm ringing between the states, the stated standard errors are the scatter of the
written values; a state that creeps by one noise σ per second is refused; a trend is never
a steady state, and the flat part before it is always found.

Each claim is checked on many records drawn with fixed seeds, with a bound chosen from the
sampling spread of the statistic so that a correct implementation fails with a probability
below 10⁻⁶ (each docstring gives the numbers).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter

from arms import ARMS
from eodarm.analysis.record_states import detect
from eodarm.analysis.records import analyse_record
from eodarm.analysis.synth import random_configs
from eodarm.analysis.synth_records import SynthRecord, synth_records
from eodarm.data.records import Record, RecordSpec

SEQUENCE = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]


def analysed(r: SynthRecord) -> object:
    spec = RecordSpec(Path(f"{r.config}.csv"), r.config, r.alpha_deg, r.masses_kg)
    return analyse_record(Record(spec.file, r.time_s, r.channels, r.values), spec)


def rehearsal(
    count: int, seed: int, hold_s: float, rings: tuple[float, ...], drift: float = 0.0
) -> list[SynthRecord]:
    """``count`` rehearsal records of the example arm (8 channels, 7 states), each its own
    configuration and noise; the ringing's time constant cycles through ``rings``; with
    ``drift``, state 1 + (i mod 6) of record i creeps at that many noise σ per second on
    every channel."""
    arm = ARMS["example"]()
    alpha = random_configs(arm, count, np.random.default_rng(seed))
    out = []
    for i in range(count):
        creep = {1 + i % 6: drift} if drift else None
        (r,) = synth_records(
            arm,
            alpha[i : i + 1],
            SEQUENCE,
            seed=seed * 1000 + i,
            hold_s=hold_s,
            ring_s=rings[i % len(rings)],
            drift=creep,
        )
        out.append(r)
    return out


def test_stated_sigma_is_the_scatter_with_pushes_and_ringing() -> None:
    """144 rehearsal records whose arm rings into each state with a time constant of 0.3 or
    0.6 s (amplitudes of tens to hundreds of noise σ), noise AR(1) of 0.05 s plus white:
    per channel, the RMS of (written value − truth) / stated σ over the 864 rows lies within
    0.7–1.43, i.e. the stated σ is within 0.7–1.43 of the scatter and the scatter within
    0.7–1.6 of the stated σ (both readings of "within 0.7–1.6"). Before the ringing was kept
    out of the noise model, dy_mm's stated σ was twice the scatter (RMS 0.45).

    The bound: over 16 batches of 12 such records the RMS had a mean of 0.97–1.04 per channel
    and a spread (standard deviation) of at most 0.148, so at 144 records a spread of 0.043;
    0.7 is 6.3 spreads below the lowest mean and 1.43 nine above the highest: with 8 channels
    and two tails, a correct implementation fails with a probability below 10⁻⁷.

    And these records are noise and transients only: at most 10 of the 144 are refused (of
    2000 records with ringing of 0.1–0.6 s, 0.4 % were refused as drifting: the drift test's
    designed 0.1 % and the noise model's own uncertainty; 11 or more of 144 at 1 % has a
    probability of 3·10⁻⁷).
    """
    recs = rehearsal(144, seed=11, hold_s=5.0, rings=(0.3, 0.6))
    z = []
    refused = []
    for r in recs:
        res = analysed(r)
        if res.refused is not None:  # type: ignore[attr-defined]
            refused.append(res.refused)  # type: ignore[attr-defined]
            continue
        for row in res.rows:  # type: ignore[attr-defined]
            truth = r.truth[row["step"]]
            z.append(
                [(row["values"][c] - truth[j]) / row["sigma"][c] for j, c in enumerate(r.channels)]
            )
    assert len(refused) <= 10, refused
    rms = np.sqrt(np.mean(np.square(z), axis=0))
    assert ((rms > 0.7) & (rms < 1.43)).all(), dict(
        zip(recs[0].channels, rms.round(3), strict=True)
    )


def test_a_creep_of_one_noise_sigma_per_second_over_4_s_is_refused() -> None:
    """60 rehearsal records held 4 s per state (each −10…+20 %), one state of each creeping
    at 1 noise σ per second on every channel (`synth --drift STEP=1`): at least 50 are refused,
    and the line names the file, the state's times and the drift. (Before, most such records
    were refused for the wrong reason or not at all.)

    The bound: of 300 such records 298 were refused (99.3 %); 11 or more misses of 60 at a
    miss rate of 2 % (the upper end of what 2 in 300 allows) has a probability of 6·10⁻⁸."""
    recs = rehearsal(60, seed=23, hold_s=4.0, rings=(0.1,), drift=1.0)
    refused = 0
    for i, r in enumerate(recs):
        why = analysed(r).refused  # type: ignore[attr-defined]
        if why is None:
            continue
        refused += 1
        creeping = 1 + i % 6
        assert why.startswith(f"{r.config}.csv: the steady state at "), why
        assert f"(payload {SEQUENCE[creeping]:g} kg) drifts" in why, why
    assert refused >= 50


def test_noise_alone_is_one_state_and_does_not_drift() -> None:
    """Noise alone, however correlated (AR(1) of φ = 0.95 on 8 channels, 20 s): one steady
    state, and no drift, in all but at most 9 of 200 records. The drift test's false-alarm
    rate is designed at 0.1 % per record and was 0.35 % over 2000 such records (its noise
    model's own uncertainty), never a second state (a false split is designed at 10⁻⁶ per run);
    10 or more of 200 at 1.2 % has a probability of 5·10⁻⁷."""
    rng = np.random.default_rng(9)
    wrong = 0
    for _ in range(200):
        t = np.arange(6000) / 300.0
        e = rng.standard_normal((t.size, 8)) * math.sqrt(1 - 0.95**2)
        x = lfilter([1.0], [1.0, -0.95], e, axis=0, zi=0.95 * rng.standard_normal((1, 8)))[0]
        found = detect(t, x, 2.0)
        wrong += len(found.states) != 1 or found.states[0].drift
    assert wrong <= 9


@pytest.mark.parametrize("sigma_mm", [0.002, 0.02, 0.2])
def test_a_ramp_is_never_a_steady_state_and_the_flat_part_before_it_is_found(
    sigma_mm: float,
) -> None:
    """A flat 10 s reference, then a 30 s ramp at 0.5 mm/s (dx up, dy down at 0.15 mm/s),
    noise AR(1) of 0.05 s plus white, at a tenth of, at, and ten times the default σ of a
    displacement (0.02 mm): in each of 20 records exactly one steady state, the flat part,
    ending before the ramp has risen by 3 noise σ and averaged over at least 4.5 s; the ramp
    is a trend. (Before, the ramp's differences set the noise scale and the whole record was
    one "steady" state on the ramp.)

    The bounds: once the flat part is a piece of its own, at most half of it is trimmed, so
    4.5 s is kept by construction; over 600 such records there was always one state, averaged
    over 6.7–9.9 s, and it never ended more than 1.9 noise σ up the ramp."""
    rng = np.random.default_rng(int(sigma_mm * 1e4))
    phi = math.exp(-1.0 / 15.0)
    for _ in range(20):
        t = np.arange(40 * 300) / 300.0 + rng.uniform(0.0, 1e-3, 40 * 300)
        level = np.where(t < 10.0, 0.0, 0.5 * (t - 10.0))
        e = rng.standard_normal((t.size, 2)) * math.sqrt(1 - phi * phi)
        ar = lfilter([1.0], [1.0, -phi], e, axis=0, zi=phi * rng.standard_normal((1, 2)))[0]
        noise = sigma_mm * (ar + 0.3 * rng.standard_normal((t.size, 2)))
        found = detect(t, np.column_stack([level, -0.3 * level]) + noise, 2.0)
        assert len(found.states) == 1, [(s.t0, s.t1) for s in found.states]
        (s,) = found.states
        assert s.t1 - s.t0 >= 4.5 and s.t1 < 10.0 + 3 * sigma_mm / 0.5, (s.t0, s.t1)
        assert found.trends and found.trends[-1].t1 > 39.0
