"""How often does `diagnose` invent an effect in pure noise? (a statistical check, not a test)

Usage: python benches/false_alarms.py [--sets 200]

For each of the three test arms (tests/arms.py), draws `--sets` data sets of 8 random
configurations x 3 payloads with no hidden effect and default noise, and counts the verdicts
that are not "adequate".
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from arms import ARMS
from eodarm.analysis.diagnose import diagnose
from eodarm.analysis.synth import random_configs, synth


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sets", type=int, default=200)
    args = ap.parse_args()
    total = alarms = 0
    for name, make in ARMS.items():
        arm = make()
        bad = 0
        for seed in range(args.sets):
            cfg = random_configs(arm, 8, np.random.default_rng(1000 + seed))
            meas = synth(arm, cfg, [1.5, 5.0, 6.5], hidden=[], seed=seed)
            bad += diagnose(arm, meas, advise=False, outliers=False).verdict != "adequate"
        print(f"{name}: {bad} of {args.sets} pure-noise data sets called 'missing'")
        total += args.sets
        alarms += bad
    print(f"all: {alarms} of {total} ({100 * alarms / total:.2f} %)")


if __name__ == "__main__":
    main()
