"""Time ``eodarm report`` on the bundled seed data, start to finish, as a user runs it.

Usage: python benches/bench_report.py [--runs 5] [--pythonpath DIR ...]

Each run is a fresh process (imports included) writing the report to a temporary file; the
table gives the median and the range of the wall time, the median CPU time (user + system of
the process and its children: the report draws half its figures in a forked child) and the
1-minute load average before each run, for every tree given with ``--pythonpath`` (default:
this tree's ``python/``). Trees are run in turn, run by run, so that they share the load.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def one_run(pythonpath: str, out: Path) -> tuple[float, float]:
    """(wall s, CPU s) of one ``eodarm report`` process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "eodarm", "report", "-o", str(out)],
        env={**os.environ, "PYTHONPATH": pythonpath},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        check=True,
    )
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--pythonpath", action="append", help="a tree's python/ directory")
    args = ap.parse_args()
    trees = args.pythonpath or [str(ROOT / "python")]
    walls: dict[str, list[float]] = {t: [] for t in trees}
    cpus: dict[str, list[float]] = {t: [] for t in trees}
    loads: dict[str, list[float]] = {t: [] for t in trees}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.runs):
            for t in trees:
                loads[t].append(os.getloadavg()[0])
                w, c = one_run(t, Path(tmp) / "r.html")
                walls[t].append(w)
                cpus[t].append(c)
    print(f"eodarm report (seed2022), {args.runs} runs each, {os.cpu_count()} CPUs")
    print(
        f"{'tree':40s} {'wall median':>12s} {'wall range':>14s} {'CPU median':>11s} {'load':>10s}"
    )
    for t in trees:
        w = walls[t]
        print(
            f"{t[-40:]:40s} {statistics.median(w):10.2f} s {min(w):6.2f}–{max(w):5.2f} s "
            f"{statistics.median(cpus[t]):9.2f} s {min(loads[t]):4.1f}–{max(loads[t]):4.1f}"
        )


if __name__ == "__main__":
    main()
