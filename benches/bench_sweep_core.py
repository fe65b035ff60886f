"""Throughput of the compiled sweep ``eodarm._core.sweep`` against the numpy reference and a
pure-Python loop, measured in the same run (issue 5's yardsticks).

Every call is a user's call of the native function: a (N, 3) float64 array of poses of the
example arm in, one payload mass, the baseline model, every output array allocated fresh and
returned in a dict. ``threads`` 1, 2 (a pool built per call) and the default (``None``: the
calling thread and rayon's global pool, two threads on a 2-CPU machine) are timed. The
numpy reference is ``eodarm.solve(..., backend="numpy")`` on the same poses and the pure-Python
loop is :func:`bench_solve.solve_python` (checked against ``eodarm.solve`` first), timed up to
1e4 poses and extrapolated beyond (marked ``*``). Each figure is the best of k calls, k ≥ 2,
until about a second has been spent.

Run from the repository root, with the package installed::

    python3 benches/bench_sweep_core.py                      # 1e4, 1e5, 1e6 poses
    python3 benches/bench_sweep_core.py --sizes 10000,100000 --no-numpy
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from datetime import UTC, datetime
from functools import partial
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import eodarm
from bench_solve import (
    ARM_FILE,
    PY_MAX,
    PyArm,
    best_time,
    cpu_seconds,
    others,
    poses,
    solve_python,
    verify,
)
from eodarm import _core
from eodarm.model.solver import _core_arm

SIZES = (10_000, 100_000, 1_000_000)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n", 1)[0])
    ap.add_argument("--sizes", help="comma-separated pose counts (default 1e4,1e5,1e6)")
    ap.add_argument("--no-numpy", action="store_true", help="skip the numpy reference")
    args = ap.parse_args(argv)
    sizes = tuple(int(float(s)) for s in args.sizes.split(",")) if args.sizes else SIZES
    arm = eodarm.Arm.from_toml(ARM_FILE)
    parm = PyArm.of(arm)
    print(f"pure-Python loop agrees with eodarm.solve: max |Δdy| = {verify(arm, parm):.1e} mm")
    core_arm = _core_arm(arm)
    empty_i = np.zeros(0, dtype=np.int64)
    empty_f = np.zeros(0)
    mass = np.array([5.0])
    load0, cpu0 = os.getloadavg(), cpu_seconds()
    started = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")

    def sweep(alpha: np.ndarray, threads: int | None) -> object:
        return _core.sweep(core_arm, alpha, mass, empty_i, empty_i, empty_f, True, None, 1, threads)

    # The sweep first, for every size: the numpy reference and the pure-Python loop run
    # afterwards, so that nothing they leave behind (e.g. spinning BLAS threads) slows it.
    threads_cases: dict[str, int | None] = {"1": 1, "2": 2, "default": None}
    rate: dict[int, dict[str, float]] = {}
    for n in sizes:
        alpha = np.ascontiguousarray(poses(n)[0])
        out = sweep(alpha, None)
        ref = eodarm.solve(arm, alpha[:500], 5.0, backend="numpy")
        assert np.allclose(out["dy_mm"][:500, 0], ref["dy_mm"], rtol=0, atol=1e-9)  # type: ignore[index]
        del out
        rate[n] = {
            k: n / best_time(partial(sweep, alpha, t), 1.0, 2) for k, t in threads_cases.items()
        }
        print(f"sweep, {n:>9,} poses: " + ", ".join(f"{k}: {v:,.0f}/s" for k, v in rate[n].items()))
    np_rate: dict[int, float] = {}
    if not args.no_numpy:
        for n in sizes:
            alpha = np.ascontiguousarray(poses(n)[0])
            call = partial(eodarm.solve, arm, alpha, 5.0, backend="numpy")
            np_rate[n] = n / best_time(call, 1.0, 2)
            print(f"numpy reference, {n:>9,} poses: {np_rate[n]:,.0f}/s")
    py_rows = min(PY_MAX, min(sizes))
    a, m = poses(py_rows)
    py_rate = py_rows / best_time(partial(solve_python, parm, a, m), 1.0, 1)
    rows_out = [
        "| poses | 1 thread | 2 threads | default threads | 2 vs 1 | numpy (poses/s) "
        "| default/numpy | default/pure Python |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for n in sizes:
        r = rate[n]
        npr = np_rate.get(n)
        default = r["default"]
        extra = "*" if n > py_rows else ""
        rows_out.append(
            f"| {n:,} | {r['1']:,.0f} | {r['2']:,.0f} | {r['default']:,.0f} "
            f"| {r['2'] / r['1']:.2f}× | {'—' if npr is None else f'{npr:,.0f}'} "
            f"| {'—' if npr is None else f'{default / npr:.1f}×'} "
            f"| {default / py_rate:,.0f}×{extra} |"
        )
    load1 = os.getloadavg()
    print()
    print(f"- run: {started}; pure Python: {py_rate:,.0f} poses/s at {py_rows:,} poses")
    print(f"- load average (1 min) before / after: {load0[0]:.2f} / {load1[0]:.2f}")
    print(others(cpu0, cpu_seconds()))
    print()
    print("\n".join(rows_out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
