"""Throughput of ``eodarm.compensate`` as a user calls it (input checks, the core, the dict).

Times ``eodarm.compensate`` on the example arm (examples/example_arm.toml) for 1e3, 1e4 and
1e5 poses (α uniform in [60, 110] x [0, 30] x [-10, 10] degrees, payload 0-7 kg, self-weight
on: the poses of the solve benchmark), for the baseline model and for one effect of each
elastic kind plus a joint clearance taken up by the self-weight (the criterion benchmark's
``effects``), with the default Jacobian (quasi-Newton for 3 links) and with finite
differences. Each figure is the best of k calls, k >= 2 and growing until the calls have taken
about a second. Besides the wall time, the CPU time of the process per pose is given: on a
machine shared with other work, CPU time is what a call costs, and wall time on two free cores
is about CPU time / 2.

Run from the repository root (``docs/benchmarks.md`` has the results)::

    python3 benches/bench_compensate.py
    python3 benches/bench_compensate.py --sizes 1000,100000 --markdown results.md
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

import eodarm
from machine import cpu_model  # benches/ is the script's directory

ROOT = Path(__file__).resolve().parent.parent
ARM_FILE = ROOT / "examples" / "example_arm.toml"
SIZES = (1_000, 10_000, 100_000)

EFFECTS = [
    eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=1500.0),
    eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
    eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15, unloaded="taken_up"),
    eodarm.Effect("link_bending", "L2", ei_n_mm2=2.0e10),
    eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=5.0e8),
]
CASES = [
    ("baseline", [], "auto"),
    ("effects", EFFECTS, "auto"),
    ("effects, finite differences", EFFECTS, "finite_difference"),
]


def poses(rows: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    lo, hi = np.array([60.0, 0.0, -10.0]), np.array([110.0, 30.0, 10.0])
    return lo + (hi - lo) * rng.random((rows, 3)), rng.uniform(0.0, 7.0, rows)


def busy_cpus() -> tuple[float, float]:
    """(wall clock, busy CPU ticks of the whole machine) for the load of other processes."""
    try:
        fields = Path("/proc/stat").read_text().splitlines()[0].split()[1:]
        ticks = [int(x) for x in fields]
        idle = ticks[3] + ticks[4]
        return time.perf_counter(), float(sum(ticks) - idle)
    except OSError:
        return time.perf_counter(), float("nan")


def timed(call, budget: float = 1.0) -> tuple[float, float, float]:  # type: ignore[no-untyped-def]
    """Best wall time, CPU time of that call, and the other processes' mean CPU load."""
    best, best_cpu, k, spent = float("inf"), float("nan"), 0, 0.0
    w0, b0 = busy_cpus()
    c_all = time.process_time()
    while k < 2 or spent < budget:
        t0, c0 = time.perf_counter(), time.process_time()
        call()
        dt, dc = time.perf_counter() - t0, time.process_time() - c0
        spent += dt
        k += 1
        if dt < best:
            best, best_cpu = dt, dc
    w1, b1 = busy_cpus()
    hz = os.sysconf("SC_CLK_TCK")
    others = ((b1 - b0) / hz - (time.process_time() - c_all)) / (w1 - w0)
    return best, best_cpu, max(others, 0.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--sizes", default=",".join(str(s) for s in SIZES))
    ap.add_argument("--markdown", type=Path)
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    arm = eodarm.Arm.from_toml(ARM_FILE)
    threads = os.environ.get("RAYON_NUM_THREADS", "unset")
    head = [
        f"# eodarm.compensate, {datetime.now(UTC):%Y-%m-%d %H:%M} UTC",
        f"# {cpu_model()}, {os.cpu_count()} CPUs, RAYON_NUM_THREADS={threads}",
        "",
        "| model | poses | wall (best) | poses/s | CPU per pose | other processes (CPUs) "
        "| steps median / max | not ok |",
        "|---|---:|---:|---:|---:|---:|---|---:|",
    ]
    lines = list(head)
    for name, effects, jac in CASES:
        for rows in sizes:
            alpha, mass = poses(rows)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = eodarm.compensate(arm, alpha, mass, effects, jacobian=jac)

                def call(a=alpha, m=mass, e=effects, j=jac) -> None:  # type: ignore[no-untyped-def]
                    eodarm.compensate(arm, a, m, e, jacobian=j)

                wall, cpu, others = timed(call)
            it = out["iterations"]
            bad = int((out["status"] != "ok").sum())
            lines.append(
                f"| {name} | {rows:.0e} | {1e3 * wall:.1f} ms | {rows / wall / 1e3:.0f} k "
                f"| {1e6 * cpu / rows:.2f} µs | {others:.2f} "
                f"| {int(np.median(it))} / {int(it.max())} | {bad} |"
            )
            print(lines[-1], flush=True)
    text = "\n".join(lines)
    print("\n" + text)
    if args.markdown:
        args.markdown.write_text(text + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
