"""Time `eodarm diagnose` work: every candidate of a 3-link arm on 64 states x 8 channels.

Usage: python benches/bench_diagnose.py [--repeat 5] [--markdown FILE]

The target of issue 3 is under 2 s for the whole diagnosis (ranking, every set of up to three
candidates, confusions, next-measurement advice); issue 11's is under 0.2 s with the
catalogue's candidates alone (16, and the 6 gaps taken up when unloaded) and under 1 s more
with one user-written effect type registered (examples/contact_mount.py: 3 more candidates,
whose columns are forward differences). Timings are the best and the median of the repeats, in one
process after a warm-up run (imports and first calls excluded). The cases run first with no
user effect registered, then again with the contact mount registered, plus one with it hidden.
"""

from __future__ import annotations

import argparse
import os
import platform
import runpy
import statistics
import time
from pathlib import Path

import numpy as np

import eodarm
from eodarm.analysis.diagnose import diagnose
from eodarm.analysis.synth import random_configs, synth
from machine import cpu_model  # benches/ is the script's directory

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "example_arm.toml"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--markdown", type=Path)
    args = ap.parse_args()
    arm = eodarm.Arm.from_toml(EXAMPLE)
    cfg = random_configs(arm, 16, np.random.default_rng(0))
    hidden = [
        eodarm.Effect("joint_clearance", "O2", clearance_mm=0.15),
        eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=2500.0),
    ]
    cases = {
        "2 hidden, 8 channels": synth(arm, cfg, [1.5, 3.0, 5.0, 6.5], hidden=hidden, seed=1),
        "2 hidden, no dl (confusions + advice)": synth(
            arm, cfg, [1.5, 3.0, 5.0, 6.5], hidden=hidden, channels=["dx", "dy", "dalpha"], seed=1
        ),
        "3 hidden (every set of up to 3 searched)": synth(
            arm,
            cfg,
            [1.5, 3.0, 5.0, 6.5],
            hidden=[*hidden, eodarm.Effect("link_bending", "L2", ei_n_mm2=2e9)],
            seed=1,
        ),
        "nothing hidden": synth(arm, cfg, [1.5, 3.0, 5.0, 6.5], hidden=[], seed=1),
    }
    rows = []
    run(cases, args.repeat, rows, arm)
    runpy.run_path(str(EXAMPLE.parent / "contact_mount.py"))  # registers contact_mount
    contact = [eodarm.Effect("contact_mount", "M2", c_mm_per_n23=1e-3)]
    cases = {f"{k}, contact registered": v for k, v in cases.items()}
    cases["contact hidden, contact registered"] = synth(
        arm, cfg, [1.5, 3.0, 5.0, 6.5], hidden=contact, seed=1
    )
    run(cases, args.repeat, rows, arm)
    lines = [
        f"machine: {os.cpu_count()} cores, {cpu_model()}, Python {platform.python_version()}, "
        f"numpy {np.__version__}",
        "",
        "| case | states | channels | candidates | sets searched | best s | median s | verdict |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]} | {r[5]:.3f} | {r[6]:.3f} | {r[7]} |"
        )
    text = "\n".join(lines)
    print(text)
    if args.markdown:
        args.markdown.write_text(text + "\n")


def run(cases: dict, repeat: int, rows: list, arm: eodarm.Arm) -> None:
    for label, meas in cases.items():
        diagnose(arm, meas)  # warm-up
        times = []
        for _ in range(repeat):
            t = time.perf_counter()
            d = diagnose(arm, meas)
            times.append(time.perf_counter() - t)
        rows.append(
            (
                label,
                meas.n_rows,
                len(meas.measured_channels),
                len(d.ranking),
                d.sets_searched,
                min(times),
                statistics.median(times),
                d.verdict + "".join(f" {s.spec}" for s in d.suggested),
            )
        )


if __name__ == "__main__":
    main()
