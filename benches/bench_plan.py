"""Time ``eodarm plan``: 8 configurations over the whole catalogue of a 3-link arm.

Usage: python benches/bench_plan.py [--repeat 3] [--markdown FILE]

The target of issue 30 is under 30 s on two cores for 8 configurations over the whole
catalogue (every candidate ``diagnose`` ranks, at typical sizes, a pool of 500 reachable
configurations, the default load cycle and every channel). Each case is one whole
:func:`eodarm.analysis.plan.plan` call (pool, sizes, signatures, choice, random plans, refits,
the inseparable pairs' channels), after a warm-up run; the stages are timed in the last run.
Timings are wall time (what a user waits), with the process's CPU time beside them: on a
machine shared with other work the wall time grows while the CPU time does not.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import statistics
import time
from pathlib import Path

import numpy as np

import eodarm
from eodarm.analysis.plan import plan
from eodarm.data.datasets import bundled_arm_path
from machine import cpu_model  # benches/ is the script's directory

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "example_arm.toml"


def cpu_time() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--markdown", type=Path)
    args = ap.parse_args()
    cases = {
        "example arm, every channel": (eodarm.Arm.from_toml(EXAMPLE), None),
        "example arm, dx and dy": (eodarm.Arm.from_toml(EXAMPLE), "dx,dy"),
        "seed2022 arm, every channel": (eodarm.Arm.from_toml(bundled_arm_path("seed2022")), None),
    }
    lines = [
        f"machine: {os.cpu_count()} cores, {cpu_model()}, Python {platform.python_version()}, "
        f"numpy {np.__version__}; load average {os.getloadavg()[0]:.1f} at the start",
        "",
        "| case | candidates | pool | wall best s | wall median s | CPU s (best run) | "
        "weakest χ² plan / random | stages of the last run (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, (arm, channels) in cases.items():
        plan(arm, 8, channels=channels)  # warm-up: imports, first calls
        walls, cpus = [], []
        stages: dict[str, float] = {}
        result = None
        for _ in range(args.repeat):
            stages.clear()
            last = [time.perf_counter(), ""]

            def step(stage: str, last: list = last, stages: dict = stages) -> None:
                now = time.perf_counter()
                if last[1]:
                    stages[last[1]] = now - last[0]
                last[0], last[1] = now, stage

            t0, c0 = time.perf_counter(), cpu_time()
            result = plan(arm, 8, channels=channels, progress=step)
            walls.append(time.perf_counter() - t0)
            cpus.append(cpu_time() - c0)
            step("")
        assert result is not None
        best = int(np.argmin(walls))
        stage_text = ", ".join(f"{k} {v:.2f}" for k, v in stages.items())
        lines.append(
            f"| {name} | {len(result.candidates)} | {result.pool.shape[0]} | {min(walls):.2f} | "
            f"{statistics.median(walls):.2f} | {cpus[best]:.2f} | "
            f"{result.weakest:.3g} / {result.random_median[0]:.3g} | {stage_text} |"
        )
        print(lines[-1], flush=True)
    lines.append("")
    lines.append(f"load average {os.getloadavg()[0]:.1f} at the end")
    text = "\n".join(lines)
    print(text)
    if args.markdown:
        args.markdown.write_text(text + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
