"""How often does `diagnose` invent an effect in pure noise? (a statistical check, not a test)

Usage:
    python benches/false_alarms.py [--sets 200]
    python benches/false_alarms.py --campaign [--sets 50] [--repeats 3] [--noise 2.5]
                                   [--channels all] [--configs 8]

Default mode: for each of the three test arms (tests/arms.py), draws `--sets` data sets of 8
random configurations x 3 payloads with no hidden effect and default noise, sigma given, and
counts the verdicts that are not "adequate".

`--campaign` (issue 11, "noise from repeats"): data sets as real campaigns make them: each
state (`--configs` random configurations x 3 payloads) measured `--repeats` times, NO sigma columns,
real noise `--noise` times the default levels. Each set is written to CSV and read back, so
the reader pools sigma from the repeats (docs/formats.md §3), and `eodarm.diagnose` (with its
outlier pass, without the advice that does not change the verdict) decides. Arms: the bundled
example arm, the seed2022 arm and the 2-link arm of tests/arms.py. Besides the verdict, it
reports on the same sets:

* "defaults": the verdict if sigma came from the default levels (the tool before the pool);
* "F": the verdict with F-based thresholds that treat the pooled sigma as an estimate with
  `Measurements.sigma_dof` degrees of freedom (what a verdict aware of `sigma_dof` could do;
  see `f_verdict`), from the diagnosis without the outlier pass.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from arms import ARMS, two_link_arm
from eodarm.analysis.diagnose import Diagnosis, diagnose
from eodarm.analysis.synth import random_configs, synth
from eodarm.data.channels import default_sigma
from eodarm.data.datasets import example_arm, load
from eodarm.data.measurements import Measurements
from eodarm.data.reader import read_measurements
from eodarm.model.arm import Arm

MASSES = [1.5, 5.0, 6.5]


def pure_noise() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sets", type=int, default=200)
    args = ap.parse_args()
    total = alarms = 0
    for name, make in ARMS.items():
        arm = make()
        bad = 0
        for seed in range(args.sets):
            cfg = random_configs(arm, 8, np.random.default_rng(1000 + seed))
            meas = synth(arm, cfg, MASSES, hidden=[], seed=seed)
            bad += diagnose(arm, meas, advise=False, outliers=False).verdict != "adequate"
        print(f"{name}: {bad} of {args.sets} pure-noise data sets called 'missing'")
        total += args.sets
        alarms += bad
    print(f"all: {alarms} of {total} ({100 * alarms / total:.2f} %)")


# ---------------------------------------------------------------------------- campaigns
def as_read(meas: Measurements) -> Measurements:
    """The measurements as the reader sees their file (sigma pooled from the repeats)."""
    buf = io.StringIO()
    meas.to_csv(buf)
    buf.seek(0)
    return read_measurements(buf, meas.n)


def with_defaults(meas: Measurements) -> Measurements:
    """The same values with the default sigma everywhere (what the tool did before)."""
    sig = np.array([default_sigma(ch) for ch in meas.channels])
    sigma = np.where(meas.measured, sig, np.nan)
    return dataclasses.replace(
        meas, sigma=sigma, sigma_default=meas.measured, sigma_pooled=None, noise=None
    )


def f_verdict(d: Diagnosis, meas: Measurements, p_pass: float = 1e-3) -> str:
    """The verdict with F-based thresholds for a pooled sigma (diagnosis without outliers).

    The within-state part of χ² of a pooled channel is exactly its ν (the model predicts the
    same for every repeat of a state), so the lack of fit is the rest: χ² − Σν on dof − Σν
    degrees of freedom, compared with the pure error on ν: F(dof − Σν, ν). A candidate's Δχ²
    is compared with F(1, ν) at the Bonferroni-corrected level. ν is the smallest of the
    measured channels' (conservative when several channels are pooled independently).
    """
    from scipy.stats import chi2, f

    dof_c = [meas.sigma_dof[ch] for ch in meas.measured_channels]
    finite = [v for v in dof_c if math.isfinite(v)]
    base = d.baseline
    k = len(d.ranking)
    n_val = base.problem.n_values
    if not finite:
        p = float(chi2.sf(base.chi2, base.dof))
        lrt = float(chi2.isf(1e-3 / max(k, 1), 1))
    else:
        nu = min(finite)
        within = sum(finite)
        df1 = base.dof - within
        p = float(f.sf((base.chi2 - within) / df1, df1, nu)) if df1 > 0 else 1.0
        lrt = float(f.isf(1e-3 / max(k, 1), 1, nu))
    best = d.ranking[0].delta_chi2 if d.ranking else 0.0
    return "missing" if p < p_pass or best > max(lrt, math.log(n_val)) else "adequate"


def campaign_arms() -> dict[str, tuple[Arm, list[tuple[float, float]] | None]]:
    """The arms and the ranges of their drawn angles (None: random_configs' defaults).

    The seed2022 arm (soft 500 N/mm actuators) is measured around the paper's poses: α1 over
    the paper's 59–116°, α2 and α3 near the paper's 6–16° and 0°; elsewhere its triangles
    do not close under the payloads."""
    seed_ranges = [(55.0, 120.0), (0.0, 20.0), (-5.0, 5.0)]
    return {
        "example": (example_arm(), None),
        "seed2022": (load("seed2022").arm, seed_ranges),
        "two-link": (two_link_arm(), None),
    }


def campaign() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--campaign", action="store_true")
    ap.add_argument("--sets", type=int, default=50)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--noise", type=float, default=2.5)
    ap.add_argument("--channels", default="all")
    ap.add_argument("--configs", type=int, default=8)
    args = ap.parse_args()
    print(
        f"pure noise x{args.noise:g} the defaults, {args.configs} configurations x "
        f"{len(MASSES)} payloads "
        f"x {args.repeats} repeats, channels {args.channels}, no sigma columns, "
        f"{args.sets} sets per arm"
    )
    tally = {"pooled": 0, "pooled, no outlier pass": 0, "F": 0, "defaults": 0}
    total = 0
    t0 = time.perf_counter()
    for a, (name, (arm, ranges)) in enumerate(campaign_arms().items()):
        count = dict.fromkeys(tally, 0)
        why = {"chi2": 0, "candidate": 0}  # what made the plain pooled verdict "missing"
        sig_ratio = []
        for s in range(args.sets):
            # each arm its own noise draws (and poses)
            seed = 1000 * a + s
            cfg = random_configs(arm, args.configs, np.random.default_rng(1000 + seed), ranges)
            made = synth(
                arm,
                cfg,
                MASSES,
                channels=args.channels,
                noise=args.noise,
                seed=seed,
                repeats=args.repeats,
                sigma_columns=False,
            )
            meas = as_read(made)
            sig_ratio += [
                meas.noise[ch].sigma / (args.noise * default_sigma(ch)) for ch in meas.pooled
            ]
            adequate = {
                "pooled": diagnose(arm, meas, advise=False).verdict == "adequate",
                "defaults": diagnose(arm, with_defaults(meas), advise=False).verdict == "adequate",
            }
            plain = diagnose(arm, meas, advise=False, outliers=False)
            adequate["pooled, no outlier pass"] = plain.verdict == "adequate"
            if plain.verdict != "adequate":
                why["chi2" if plain.p_baseline < 1e-3 else "candidate"] += 1
            adequate["F"] = f_verdict(plain, meas) == "adequate"
            for key, ok in adequate.items():
                count[key] += ok
        dof = meas.sigma_dof[meas.measured_channels[0]]
        print(
            f"{name}: adequate "
            + ", ".join(f"{key} {count[key]}/{args.sets}" for key in tally)
            + f"  (pooled sigma / true: mean {np.mean(sig_ratio):.3f}, "
            f"sd {np.std(sig_ratio):.3f}; {dof:g} dof; plain 'missing' by chi2 p "
            f"{why['chi2']}, by a candidate {why['candidate']})"
        )
        for key in tally:
            tally[key] += count[key]
        total += args.sets
    print(
        "all: adequate "
        + ", ".join(
            f"{key} {tally[key]}/{total} ({100 * tally[key] / total:.1f} %)" for key in tally
        )
        + f"  [{time.perf_counter() - t0:.0f} s]"
    )


if __name__ == "__main__":
    campaign() if "--campaign" in sys.argv else pure_noise()
