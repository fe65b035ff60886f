"""Throughput of ``eodarm.solve`` and ``eodarm.solve_sequence`` against the machine's floor.

The floor of a call is the time numpy takes to allocate and write the arrays the call returns
(the same keys, shapes and dtypes), in the same process: a call cannot return its outputs
faster than it can write them. The floor's arrays are all allocated first and held together
until the timing ends, as the call's outputs are (allocating, filling and freeing one array
after another would recycle the same pages and skip the page faults that fresh outputs cost),
then written by as many threads as the core uses (``np.copyto`` releases the GIL; each thread
writes its share of the rows of every array). The one-thread floor is printed too. Each
figure is printed beside its floor and the ratio call time / floor time (1 would be a core
that costs nothing). Every figure is the best of 5 calls, the call and its floor timed
alternately.

``solve`` is also timed writing into arrays that already exist (``out=``), beside numpy
filling those same arrays: no allocation, no page fault, so the ratio is the core's compute
against the machine's write bandwidth.

Workloads, on the linear example arm (``examples/example_arm.toml``), the rotary arm
(``examples/rotary_arm.toml``) and the mixed arm (``examples/mixed_arm.toml``):

* ``solve``: 10⁶ poses (uniform in each arm's working range), payload 0–7 kg, self-weight on,
  no effect (``baseline``);
* ``solve_sequence``: 10⁵ sequences × 8 states (0 → 1.5 → 5 → 6.5 → 5 → 1.5 → 0 → 3 kg), with
  no effect and with two frictions, a clearance and a mount (at a drive: its gear's
  compliance), see ``SEQUENCE_EFFECTS``;
* the same with ``outputs=("dx_mm", "dy_mm")`` where the installed package has ``outputs=``;
  its floor is that of the two arrays.

Run from the repository root (``docs/benchmarks.md`` has the results)::

    python3 benches/bench_floor.py                # 1e6 poses, 1e5 × 8 states, ~15 s quiet
    python3 benches/bench_floor.py --scale 0.1    # a tenth of each workload
    python3 benches/bench_floor.py --markdown floor.md
    python3 benches/bench_floor.py --runs 6       # six runs in fresh processes: medians

One run cannot separate 3.0× from 3.3×: the floor's best of 5 depends on whether glibc hands
back heap pages that are already mapped, and varies by up to 3× from one process to the next
on a quiet machine. ``--runs N`` runs the whole benchmark N times, each in its own process,
and prints per row the median rate, the median floor, and the median and range of the N
ratios (each ratio is the call against the floor measured beside it in the same run).
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

import eodarm
from machine import cpu_model  # benches/ is the script's directory

ROOT = Path(__file__).resolve().parent.parent
ARMS = {
    "linear": ROOT / "examples" / "example_arm.toml",
    "rotary": ROOT / "examples" / "rotary_arm.toml",
    "mixed": ROOT / "examples" / "mixed_arm.toml",
}
#: Each arm's working range: per joint (low, high) of the relative angle q_i (deg); the
#: linear arm's are absolute angles (bench_solve.py's), as its file's poses are given.
RANGES = {
    "linear": [(60.0, 110.0), (0.0, 30.0), (-10.0, 10.0)],
    "rotary": [(0.0, 60.0), (-60.0, 0.0), (-40.0, 20.0)],
    "mixed": [(10.0, 80.0), (-110.0, -40.0), (-90.0, -20.0)],
}
MASSES = np.array([0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0, 3.0])
SEQUENCE_EFFECTS = {
    "linear": [
        eodarm.Effect("actuator_friction", "M1", friction_n=40.0),
        eodarm.Effect("joint_friction", "O3", torque_nmm=4000.0),
        eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15),
        eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
    ],
    "rotary": [
        eodarm.Effect("drive_friction", "O2", torque_nmm=2000.0),
        eodarm.Effect("joint_friction", "O3", torque_nmm=1000.0),
        eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15),
        eodarm.Effect("drive_compliance", "O2", stiffness_nmm_per_rad=1.0e7),
    ],
    "mixed": [
        eodarm.Effect("drive_friction", "O1", torque_nmm=4000.0),
        eodarm.Effect("joint_friction", "O3", torque_nmm=4000.0),
        eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15),
        eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
    ],
}
REPEATS = 5
TWO = ("dx_mm", "dy_mm")


def poses(kind: str, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` poses (deg) uniform in the arm's working range."""
    lo, hi = np.array(RANGES[kind]).T
    q = rng.uniform(lo, hi, size=(count, len(lo)))
    return q if kind == "linear" else np.cumsum(q, axis=1)


def _threads() -> int:
    """The threads the core uses (rayon: RAYON_NUM_THREADS, else one per CPU)."""
    env = os.environ.get("RAYON_NUM_THREADS", "")
    return int(env) if env.isdigit() and int(env) > 0 else os.cpu_count() or 1


POOL = ThreadPoolExecutor(_threads())


def fill(arrays: list[np.ndarray], threads: int) -> None:
    """Writes 1 into every element of ``arrays``, each thread its share of every array's
    rows."""

    def share(t: int) -> None:
        for a in arrays:
            rows = a.shape[0]
            np.copyto(a[rows * t // threads : rows * (t + 1) // threads], 1)

    if threads == 1:
        share(0)
    else:
        list(POOL.map(share, range(threads)))


def floor_of(result: dict[str, Any], threads: int) -> Callable[[], list[np.ndarray]]:
    """Allocating arrays of the keys, shapes and dtypes of ``result``, all held together, and
    writing them with ``threads`` threads; returns them (the caller drops them after timing,
    as it drops the call's outputs)."""
    specs = [(np.shape(v), np.asarray(v).dtype) for v in result.values()]

    def write() -> list[np.ndarray]:
        arrays = [np.empty(shape, dtype) for shape, dtype in specs]
        fill(arrays, threads)
        return arrays

    return write


def best(*calls: Callable[[], Any]) -> list[float]:
    """Best of ``REPEATS`` times of each call, timed in turn (round-robin); each call's result
    is dropped after its time is taken."""
    times: list[list[float]] = [[] for _ in calls]
    for _ in range(REPEATS):
        for call, ts in zip(calls, times, strict=True):
            t0 = time.perf_counter()
            result = call()
            ts.append(time.perf_counter() - t0)
            del result
    return [min(ts) for ts in times]


def load() -> float:
    return os.getloadavg()[0]


Row = tuple[str, str, str, int, float, float, float]


def timed(kind: str, what: str, unit: str, count: int, call: Callable[[], Any]) -> Row:
    """One figure: ``call`` beside its floors (the floors' arrays are the call's own): all
    threads, and one thread."""
    result = call()
    many, one = floor_of(result, _threads()), floor_of(result, 1)
    del result
    tc, tf, t1 = best(call, many, one)
    print(
        f"{kind:7s} {what:38s} {count / tc / 1e6:7.2f} M {unit}/s  floor "
        f"{count / tf / 1e6:7.2f} M/s ({count / t1 / 1e6:6.2f} on 1 thread)  ratio {tc / tf:5.2f}",
        flush=True,
    )
    return (kind, what, unit, count, tc, tf, t1)


def timed_into(kind: str, count: int, arm: eodarm.Arm, alpha: np.ndarray, mass: np.ndarray) -> Row:
    """``solve`` writing into arrays that exist already (``out=``) beside numpy filling the
    same arrays: the core's compute against the write bandwidth, no page fault in either."""
    out = {k: np.empty_like(v) for k, v in eodarm.solve(arm, alpha, mass).items()}
    arrays = list(out.values())
    tc, tf, t1 = best(
        lambda: eodarm.solve(arm, alpha, mass, out=out),
        lambda: fill(arrays, _threads()),
        lambda: fill(arrays, 1),
    )
    what = "solve, baseline, into existing arrays"
    print(
        f"{kind:7s} {what:38s} {count / tc / 1e6:7.2f} M poses/s  fill "
        f"{count / tf / 1e6:7.2f} M/s ({count / t1 / 1e6:6.2f} on 1 thread)  ratio {tc / tf:5.2f}",
        flush=True,
    )
    return (kind, what, "poses", count, tc, tf, t1)


def bench_arm(
    kind: str, n_poses: int, n_seq: int, rng: np.random.Generator, outputs: tuple[bool, bool]
) -> list[Row]:
    """Every figure of one arm."""
    arm = eodarm.Arm.from_toml(ARMS[kind])
    alpha = poses(kind, n_poses, rng)
    mass = rng.uniform(0.0, 7.0, n_poses)
    rows = [
        timed(kind, "solve, baseline", "poses", n_poses, lambda: eodarm.solve(arm, alpha, mass)),
        timed_into(kind, n_poses, arm, alpha, mass),
    ]
    if outputs[0]:
        two = lambda: eodarm.solve(arm, alpha, mass, outputs=TWO)  # noqa: E731
        rows.append(timed(kind, "solve, baseline, outputs=dx,dy", "poses", n_poses, two))
    seq_alpha = poses(kind, n_seq, rng)
    seq_mass = np.broadcast_to(MASSES, (n_seq, MASSES.size))
    states = n_seq * MASSES.size
    eff = SEQUENCE_EFFECTS[kind]
    plain = lambda: eodarm.solve_sequence(arm, seq_alpha, seq_mass)  # noqa: E731
    rows.append(timed(kind, "solve_sequence, no effect", "states", states, plain))
    full = lambda: eodarm.solve_sequence(arm, seq_alpha, seq_mass, eff)  # noqa: E731
    rows.append(timed(kind, "solve_sequence, 2 frictions+gap+mount", "states", states, full))
    if outputs[1]:
        part = lambda: eodarm.solve_sequence(arm, seq_alpha, seq_mass, eff, outputs=TWO)  # noqa: E731
        rows.append(timed(kind, "solve_sequence, effects, outputs=dx,dy", "states", states, part))
    return rows


def runs(n: int, scale: float) -> list[str]:
    """The table of ``n`` whole runs, each in a fresh process: per row the medians of the
    rates and floors, and the median and range of the ratios."""
    per_run: list[list[Row]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(n):
            dump = Path(tmp) / f"run{i}.json"
            cmd = [sys.executable, __file__, "--scale", str(scale), "--rows-json", str(dump)]
            print(f"run {i + 1} of {n}", file=sys.stderr, flush=True)
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            rows = json.loads(dump.read_text())
            per_run.append([(k, w, u, int(c), a, b, d) for k, w, u, c, a, b, d in rows])
    table = [
        f"| arm | call | items | rate, median (M/s) | floor, median (M/s) "
        f"| call / floor, median of {n} | range |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for same in zip(*per_run, strict=True):
        kind, what, unit, count = same[0][:4]
        med = statistics.median
        ratios = [r[4] / r[5] for r in same]
        table.append(
            f"| {kind} | {what} | {count:,} {unit} | {med(count / r[4] for r in same) / 1e6:.2f} | "
            f"{med(count / r[5] for r in same) / 1e6:.2f} | {med(ratios):.2f} | "
            f"{min(ratios):.2f}–{max(ratios):.2f} |"
        )
    return table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scale", type=float, default=1.0, help="fraction of each workload")
    ap.add_argument("--markdown", type=Path, help="also write the table here")
    ap.add_argument(
        "--runs", type=int, default=1, help="whole runs, each in a fresh process (medians)"
    )
    ap.add_argument("--force", action="store_true", help="replace an existing --markdown file")
    ap.add_argument("--rows-json", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.runs < 1:
        ap.error(f"--runs: expected at least 1, got {args.runs}")
    if args.markdown is not None and args.markdown.exists() and not args.force:
        ap.error(f"--markdown {args.markdown}: the file exists; add --force to replace it")
    if args.runs > 1:
        before = load()
        table = runs(args.runs, args.scale)
        head = [
            f"- run: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
            f"`python3 benches/bench_floor.py --runs {args.runs}"
            + (f" --scale {args.scale}`" if args.scale != 1 else "`"),
            f"- machine: {platform.machine()}, {os.cpu_count()} CPUs, {cpu_model()}",
            f"- load average (1 min) before / after: {before:.2f} / {load():.2f}",
            f"- each run: the best of {REPEATS} calls beside the best of {REPEATS} floors "
            "(numpy allocating and writing the same arrays, as in a single run)",
        ]
        print("\n".join([*head, "", *table]))
        if args.markdown:
            args.markdown.write_text("\n".join([*head, "", *table]) + "\n")
        return
    rng = np.random.default_rng(31)
    n_poses = max(16, int(1_000_000 * args.scale))
    n_seq = max(16, int(100_000 * args.scale))
    has_outputs = "outputs" in inspect.signature(eodarm.solve).parameters
    has_seq_outputs = "outputs" in inspect.signature(eodarm.solve_sequence).parameters
    before = load()
    rows: list[Row] = []
    for kind in ARMS:
        rows += bench_arm(kind, n_poses, n_seq, rng, (has_outputs, has_seq_outputs))
    after = load()
    scale = f" --scale {args.scale}" if args.scale != 1 else ""
    threads = os.environ.get("RAYON_NUM_THREADS", f"unset ({os.cpu_count()} CPUs)")
    head = [
        f"- run: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
        f"`python3 benches/bench_floor.py{scale}`",
        f"- machine: {platform.machine()}, {os.cpu_count()} CPUs, {cpu_model()}",
        f"- python {platform.python_version()}, numpy {np.__version__}, "
        f"RAYON_NUM_THREADS {threads}",
        f"- load average (1 min) before / after: {before:.2f} / {after:.2f}",
        f"- best of {REPEATS} calls; floor = numpy allocating the call's output arrays "
        f"(`np.empty`, all held together) and writing them (`np.copyto(..., 1)`) on "
        f"{_threads()} threads (on 1 thread in its own column), best of {REPEATS}, timed in "
        "turn with the call; for `into existing arrays` the floor is the filling alone",
        f"- `outputs=`: {'timed' if has_outputs else 'not in this build'}",
    ]
    table = [
        "| arm | call | items | rate (M/s) | floor (M/s) | floor, 1 thread (M/s) | call / floor |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for kind, what, unit, count, tc, tf, t1 in rows:
        table.append(
            f"| {kind} | {what} | {count:,} {unit} | {count / tc / 1e6:.2f} | "
            f"{count / tf / 1e6:.2f} | {count / t1 / 1e6:.2f} | {tc / tf:.2f} |"
        )
    print("\n".join([*head, "", *table]))
    if args.markdown:
        args.markdown.write_text("\n".join([*head, "", *table]) + "\n")
    if args.rows_json:
        args.rows_json.write_text(json.dumps(rows))


if __name__ == "__main__":
    main()
