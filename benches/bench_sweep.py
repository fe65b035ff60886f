"""Speed and memory of ``eodarm.sweep`` against numpy and pure Python, measured in one run.

Times, on the example arm (``examples/example_arm.toml``), baseline model, self-weight on, one
payload (5 kg), angles α1 ∈ [60, 110]°, α2 ∈ [0, 30]°, α3 ∈ [−10, 10]° on a regular grid:

* **sweep, all outputs**: ``eodarm.sweep`` at 1e4 … 1e7 poses, unreduced (every output of
  every pose into the Dataset), through the compiled core ``eodarm._core.sweep``.
* **sweep, reduced**: the same with ``reduce={"op": "max", "dims": ["alpha3", "mass_kg"]}``
  up to 1e8 poses: the cost per pose when only the reduction is kept.
* **numpy reference**: ``eodarm.model.reference.solve`` on the same poses, flattened (≤ 1e6).
* **vectorised numpy**: an independent baseline-model implementation written below, the way
  a competent numpy programmer would: forward kinematics, the tip-to-base statics recursion
  and the exact triangle closure (law of cosines, ``arccos``), every step vectorised over
  poses. It is checked against ``eodarm.solve`` (to 1e-9 mm and 1e-9 N relative) before it
  is timed; timed at ≤ 1e6 poses (≤ 1e7 with ``--big-numpy``).
* **pure Python**: the per-pose loop of ``bench_solve.py`` (floats and :mod:`math`), timed at
  1e3 and 1e4 poses, its per-pose cost extrapolated beyond (marked ``*``).
* **core alone**: next to each reduced sweep, ``eodarm._core.sweep`` walking the same grid
  with the same reduction into preallocated outputs: the cost per pose without the Dataset.
* **threads**: the sweep at 1e6 poses, all outputs and reduced, with 1 and 2 threads
  (``threads=`` and ``RAYON_NUM_THREADS``, each in a fresh subprocess, best of ≥ 5 calls
  over about a second, after a first one that pays for the process's fresh memory).
* **peak memory**: a reduced sweep of 1e8 poses in a fresh subprocess, started before this
  process grows (a child's ``ru_maxrss`` counts its parent's resident set at the spawn), its
  peak resident set (``resource.getrusage(...).ru_maxrss`` and ``VmHWM`` from /proc), and its
  resident set after the imports, before the sweep.

Run from the repository root (results and the machine in ``docs/benchmarks.md``)::

    python3 benches/bench_sweep.py                       # everything, 1e8 included (minutes)
    python3 benches/bench_sweep.py --quick               # ≤ 1e6, no 1e8 memory run
    python3 benches/bench_sweep.py --markdown results.md
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import numpy.typing as npt

import eodarm
import eodarm.model.reference

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from bench_solve import (  # noqa: E402
    PyArm,
    best_time,
    cpu_seconds,
    machine,
    others,
    solve_python,
)

ARM_FILE = ROOT / "examples" / "example_arm.toml"
MASS = 5.0
REDUCE = {"op": "max", "dims": ["alpha3", "mass_kg"]}
#: Grid shapes (α1, α2, α3) of each size.
SHAPES = {
    10_000: (25, 20, 20),
    100_000: (50, 50, 40),
    1_000_000: (100, 100, 100),
    10_000_000: (250, 200, 200),
    100_000_000: (500, 500, 400),
}
RANGES = ((60.0, 110.0), (0.0, 30.0), (-10.0, 10.0))
FloatArray = npt.NDArray[np.float64]


def grid(size: int) -> dict[str, FloatArray]:
    return {
        f"alpha{i + 1}": np.linspace(lo, hi, k)
        for i, ((lo, hi), k) in enumerate(zip(RANGES, SHAPES[size], strict=True))
    }


def flat(size: int) -> FloatArray:
    g = grid(size)
    return np.stack(np.meshgrid(*g.values(), indexing="ij"), axis=-1).reshape(-1, 3)


# ------------------------------------------------------------------ vectorised numpy baseline
def _rot(c: FloatArray, s: FloatArray, p: Sequence[float]) -> FloatArray:
    return np.stack([c * p[0] - s * p[1], s * p[0] + c * p[1]], axis=-1)


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def numpy_baseline(arm: eodarm.Arm, alpha_deg: FloatArray, mass_kg: float) -> dict[str, FloatArray]:
    """The baseline model of many poses, vectorised: dx, dy (N,), force_n, dalpha_deg, dl_mm (N, n).

    Forward kinematics; statics of the self-weight case and of the payload alone, each from
    the tip to the base (moments about O_i give F_i, force balance gives R_i), on the
    undeformed pose; actuator springs Δℓ = −ΔF/k; every triangle closed exactly from the
    base out (law of cosines), on the side of the unloaded pose.
    """
    n, rows = arm.n, alpha_deg.shape[0]
    d = arm.arrays()
    g = arm.g
    rad = np.radians(alpha_deg)
    cos, sin = np.cos(rad), np.sin(rad)
    o = [np.broadcast_to(d["O1"], (rows, 2))]
    b = [np.broadcast_to(d["B0"], (rows, 2))]
    a, cm = [], []
    for i in range(n):
        c, s = cos[:, i], sin[:, i]
        a.append(o[i] + _rot(c, s, d["A"][i]))
        cm.append(o[i] + _rot(c, s, d["C"][i]))
        b.append(o[i] + _rot(c, s, d["B"][i]))
        o.append(o[i] + _rot(c, s, d["next"][i]))
    meas = o[n - 1] + _rot(cos[:, n - 1], sin[:, n - 1], d["measure"])
    v = [a[i] - b[i] for i in range(n)]
    ell = [np.hypot(x[:, 0], x[:, 1]) for x in v]
    e = [v[i] / ell[i][:, None] for i in range(n)]
    h = [_cross(a[i] - o[i], e[i]) for i in range(n)]

    def statics(weights: bool, payload: FloatArray) -> FloatArray:
        f = np.zeros((rows, n))
        r_next = np.zeros((rows, 2))
        gw = g if weights else 0.0
        for i in range(n - 1, -1, -1):
            loads = [
                (cm[i], np.array([0.0, -d["link_mass"][i] * gw])),
                (a[i], np.array([0.0, -0.5 * d["act_mass"][i] * gw])),
            ]
            if i + 1 < n:
                fb = -f[:, i + 1, None] * e[i + 1]
                fb[:, 1] -= 0.5 * d["act_mass"][i + 1] * gw
                loads += [(b[i + 1], fb), (o[i + 1], -r_next)]
            else:
                loads.append((o[n], payload))
            q = np.zeros((rows, 2))
            t = np.zeros(rows)
            for p, fv in loads:
                fv = np.broadcast_to(fv, (rows, 2))
                q = q + fv
                t = t + _cross(p - o[i], fv)
            f[:, i] = -t / h[i]
            r_next = -q - f[:, i, None] * e[i]
        return f

    fw = statics(True, np.zeros(2))
    fd = statics(False, np.array([0.0, -mass_kg * g]))
    dl = -fd / d["stiffness"]
    side = [np.sign(_cross(b[i] - o[i], a[i] - o[i])) for i in range(n)]
    op, bp = o[0], b[0]
    new = np.empty((rows, n))
    for i in range(n):
        length = ell[i] + dl[:, i]
        dv = bp - op
        rho = math.hypot(*d["A"][i])
        dist = np.hypot(dv[:, 0], dv[:, 1])
        cos_t = (rho * rho + dist * dist - length * length) / (2.0 * rho * dist)
        theta = np.arctan2(dv[:, 1], dv[:, 0]) + side[i] * np.arccos(cos_t)
        new[:, i] = theta - math.atan2(d["A"][i][1], d["A"][i][0])
        c, s = np.cos(new[:, i]), np.sin(new[:, i])
        if i + 1 < n:
            bp = op + _rot(c, s, d["B"][i])
            op = op + _rot(c, s, d["next"][i])
        else:
            meas_new = op + _rot(c, s, d["measure"])
    dalpha = np.degrees((new - rad + np.pi) % (2.0 * np.pi) - np.pi)
    return {
        "dx_mm": meas_new[:, 0] - meas[:, 0],
        "dy_mm": meas_new[:, 1] - meas[:, 1],
        "force_n": fw + fd,
        "dalpha_deg": dalpha,
        "dl_mm": dl,
    }


def verify_numpy(arm: eodarm.Arm) -> float:
    """Check :func:`numpy_baseline` against ``eodarm.solve``; exit if they disagree."""
    rng = np.random.default_rng(5)
    lo, hi = np.array([r[0] for r in RANGES]), np.array([r[1] for r in RANGES])
    alpha = lo + (hi - lo) * rng.random((500, 3))
    got = numpy_baseline(arm, alpha, MASS)
    ref = eodarm.solve(arm, alpha, MASS)
    worst = 0.0
    for key in ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm"):
        err = float(np.max(np.abs(got[key] - ref[key])))
        if err > 1e-9:
            raise SystemExit(f"vectorised numpy disagrees with eodarm.solve on {key}: {err:.3g}")
        worst = max(worst, err)
    f = np.max(np.abs(got["force_n"] - ref["force_n"]) / (1.0 + np.abs(ref["force_n"])))
    if f > 1e-9:
        raise SystemExit(f"vectorised numpy disagrees with eodarm.solve on force_n: {f:.3g}")
    return worst


def core_reduced(arm: eodarm.Arm, g: dict[str, FloatArray]) -> object:
    """The compiled core alone on the same reduced sweep: ``eodarm._core.sweep`` walking the
    grid itself, into preallocated outputs (no Dataset)."""
    from eodarm import _core
    from eodarm.model.solver import _core_arm

    axes = list(g.values())
    shape = [len(a) for a in axes]
    groups = shape[0] * shape[1]
    out = {
        k: np.empty((groups, 3) if k in ("force_n", "dalpha_deg", "dl_mm") else groups)
        for k in ("force_n", "dx_mm", "dy_mm", "dalpha_deg", "dl_mm")
    }
    out["ok"] = np.empty(groups, dtype=bool)
    out["reachable"] = np.empty(groups, dtype=bool)
    empty_i, empty_f = np.zeros(0, dtype=np.int64), np.zeros(0)
    return _core.sweep(
        _core_arm(arm),
        None,
        np.array([MASS]),
        empty_i,
        empty_i,
        empty_f,
        True,
        "max",
        shape[2],
        None,
        grid=(axes, [0, 1, 2], 0, math.prod(shape)),
        out=out,
    )


# ------------------------------------------------------------------ children (fresh processes)
def child(args: argparse.Namespace) -> int:
    """Run one sweep in this (fresh) process and print JSON: time, peak and start RSS (MB)."""
    import resource

    arm = eodarm.Arm.from_toml(ARM_FILE)
    eodarm.sweep(arm, alpha_deg=grid(10_000), mass_kg=[MASS], reduce=REDUCE, progress=False)
    import xarray  # noqa: F401  (imported by the sweep already; counted in the start RSS)

    start = _rss_now_mb()

    def call() -> object:
        return eodarm.sweep(
            arm,
            alpha_deg=grid(args.size),
            mass_kg=[MASS],
            reduce=REDUCE if args.reduced else None,
            progress=False,
            threads=args.threads,
        )

    t0 = time.perf_counter()
    call()
    dt = time.perf_counter() - t0
    if args.repeat > 1:  # best of the further calls (the first paid for fresh memory)
        dt = best_time(call, 1.0, args.repeat)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux
    hwm = _rss_now_mb("VmHWM:")
    print(json.dumps({"seconds": dt, "peak_mb": peak, "hwm_mb": hwm, "start_mb": start}))
    return 0


def _rss_now_mb(key: str = "VmRSS:") -> float:
    """This process's resident set (VmRSS) or its peak (VmHWM) from /proc, MB."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(key):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return math.nan


def run_child(size: int, reduced: bool, threads: int | None, repeat: int = 1) -> dict[str, float]:
    env = dict(os.environ)
    if threads is not None:
        env["RAYON_NUM_THREADS"] = str(threads)
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", "--size", str(size)]
    cmd += ["--repeat", str(repeat)]
    if reduced:
        cmd.append("--reduced")
    if threads is not None:
        cmd += ["--threads", str(threads)]
    out = subprocess.run(cmd, env=env, check=True, capture_output=True, text=True)
    return dict(json.loads(out.stdout.strip().splitlines()[-1]))


# ------------------------------------------------------------------ main
def once(call: Callable[[], object]) -> float:
    gc.collect()
    t0 = time.perf_counter()
    call()
    return time.perf_counter() - t0


def timed(call: Callable[[], object], size: int, budget: float) -> float:
    """Best of k calls within ``budget`` s for small sizes, one call for large ones."""
    return best_time(call, budget, 2) if size <= 1_000_000 else once(call)


def fmt(x: float | None, star: bool = False) -> str:
    return "—" if x is None else f"{x:,.0f}{'*' if star else ''}"


def ratio(a: float | None, b: float | None, star: bool = False) -> str:
    return "—" if a is None or b is None else f"{a / b:,.1f}×{'*' if star else ''}"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n", 1)[0])
    ap.add_argument("--quick", action="store_true", help="≤ 1e6 poses, no 1e8 run")
    ap.add_argument("--max", type=float, default=1e7, help="largest unreduced sweep (1e7)")
    ap.add_argument("--max-reduced", type=float, default=1e8, help="largest reduced sweep (1e8)")
    ap.add_argument("--big-numpy", action="store_true", help="time vectorised numpy at 1e7 too")
    ap.add_argument("--markdown", type=Path, metavar="FILE", help="also write the tables here")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--size", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--reduced", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--threads", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--repeat", type=int, default=1, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        return child(args)
    top = 1_000_000 if args.quick else int(args.max)
    top_red = 1_000_000 if args.quick else int(args.max_reduced)
    budget = 0.3 if args.quick else 1.0

    arm = eodarm.Arm.from_toml(ARM_FILE)
    err = verify_numpy(arm)
    print(f"vectorised numpy agrees with eodarm.solve: max error {err:.1e}", flush=True)
    load0, cpu0 = os.getloadavg(), cpu_seconds()
    started = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")

    # The 1e8 memory run goes first, while this process is small: on Linux a child's
    # ru_maxrss starts from its parent's resident set at the fork (the kernel keeps the
    # high-water mark across exec), so a child of a process that has held 2 GB reports 2 GB.
    # VmHWM (/proc) is the child's own peak; both are reported.
    mem: dict[str, float] = {}
    if top_red >= 100_000_000:
        parent_mb = _rss_now_mb()
        mem = run_child(100_000_000, True, None)
        mem["parent_mb"] = parent_mb
        print(f"reduced 1e8 sweep: {mem}", flush=True)

    parm = PyArm.of(arm)
    py_rate: dict[int, float] = {}
    for rows in (1_000, 10_000):
        alpha = flat(10_000)[:rows]
        py_rate[rows] = rows / best_time(
            lambda a=alpha: solve_python(parm, a, np.full(a.shape[0], MASS)), budget, 1
        )
        print(f"pure Python, {rows:,} poses: {py_rate[rows]:,.0f} poses/s", flush=True)
    py_per = py_rate[10_000]

    sizes = [s for s in SHAPES if s <= top]
    head = (
        "| poses | sweep, all outputs (poses/s) | numpy reference | vectorised numpy "
        "| pure Python | sweep / reference | sweep / vectorised numpy | sweep / pure Python |"
    )
    t1 = [head, "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    rates: dict[int, float] = {}
    for size in sizes:
        g = grid(size)
        t = timed(
            lambda g=g: eodarm.sweep(arm, alpha_deg=g, mass_kg=[MASS], progress=False), size, budget
        )
        rates[size] = size / t
        ref = vec = None
        if size <= 1_000_000:
            alpha = flat(size)
            ref = size / timed(
                lambda a=alpha: eodarm.model.reference.solve(arm, a, MASS), size, budget
            )
        if size <= (10_000_000 if args.big_numpy else 1_000_000):
            alpha = flat(size)
            vec = size / timed(lambda a=alpha: numpy_baseline(arm, a, MASS), size, budget)
        star = size > 10_000
        py = py_per if star else py_rate[size] if size in py_rate else py_per
        row = (
            f"| {size:,} | {fmt(rates[size])} | {fmt(ref)} | {fmt(vec)} | {fmt(py, star)} "
            f"| {ratio(rates[size], ref)} | {ratio(rates[size], vec)} "
            f"| {ratio(rates[size], py, star)} |"
        )
        t1.append(row)
        print(row, flush=True)
        gc.collect()

    t2 = [
        "| poses | reduced sweep (s) | poses/s | ns per pose "
        "| core alone (s) | core, ns per pose |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for size in [s for s in SHAPES if s <= top_red]:
        g = grid(size)
        if size >= 100_000_000:
            t = mem["seconds"]  # the memory run, in its own process
        else:
            t = timed(
                lambda g=g: eodarm.sweep(
                    arm, alpha_deg=g, mass_kg=[MASS], reduce=REDUCE, progress=False
                ),
                size,
                budget,
            )
        tc = timed(lambda g=g: core_reduced(arm, g), size, budget)
        row = (
            f"| {size:,} | {t:.3g} | {size / t:,.0f} | {1e9 * t / size:,.1f} "
            f"| {tc:.3g} | {1e9 * tc / size:,.1f} |"
        )
        t2.append(row)
        print(row, flush=True)

    t3 = [
        "| threads | 1e6 poses, all outputs (s) | poses/s | speed-up "
        "| 1e6 poses, reduced (s) | poses/s | speed-up |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    base: dict[bool, float] = {}
    for k in (1, 2):
        row = f"| {k} "
        for reduced in (False, True):
            sec = run_child(1_000_000, reduced, k, repeat=5)["seconds"]
            base.setdefault(reduced, sec)
            row += f"| {sec:.3g} | {1e6 / sec:,.0f} | {base[reduced] / sec:.2f}× "
        t3.append(row + "|")
        print(t3[-1], flush=True)

    t4: list[str] = []
    if top_red >= 100_000_000:
        t4 = [
            "| reduced sweep | poses | time (s) | peak RSS, ru_maxrss (MB) | peak RSS, VmHWM (MB) "
            "| RSS after imports (MB) | RSS of the parent at the spawn (MB) |",
            "|---|---:|---:|---:|---:|---:|---:|",
            f"| max over (alpha3, mass_kg) | 100,000,000 | {mem['seconds']:.1f} "
            f"| {mem['peak_mb']:.0f} | {mem['hwm_mb']:.0f} | {mem['start_mb']:.0f} "
            f"| {mem['parent_mb']:.0f} |",
        ]
        print(t4[-1], flush=True)

    load1, cpu1 = os.getloadavg(), cpu_seconds()
    notes = [
        f"- run: {started}, `python3 benches/bench_sweep.py{' --quick' if args.quick else ''}`",
        *machine(),
        f"- load average (1 min) before / after: {load0[0]:.2f} / {load1[0]:.2f}",
        others(cpu0, cpu1),
        "- example arm, baseline model, self-weight on, one payload (5 kg), regular angle grid "
        "α1 60–110°, α2 0–30°, α3 −10–10°; poses = grid points (each one solved)",
        "- best of k ≥ 2 calls until ~1 s per figure up to 1e6 poses, one call beyond; "
        "reference and vectorised numpy on the flattened poses",
        "- pure Python: timed at 1,000 and 10,000 poses; * = extrapolated from 10,000",
        f"- reduced: `reduce={REDUCE}`; core alone: `eodarm._core.sweep` on the same grid and "
        "reduction into preallocated outputs (one call at 1e7 and 1e8)",
        "- threads: fresh processes with `threads=K` and `RAYON_NUM_THREADS=K`, best of ≥ 5 "
        "calls (~1 s) after a first one; 1e8: a fresh process, started first, one call, "
        "`ru_maxrss` and VmHWM",
    ]
    text = (
        "\n".join(
            [
                *notes,
                "",
                "Throughput (all outputs):",
                "",
                *t1,
                "",
                "Cost per pose (reduced):",
                "",
                *t2,
                "",
                "Threads:",
                "",
                *t3,
                *(["", "Peak memory:", "", *t4] if t4 else []),
            ]
        )
        + "\n"
    )
    print()
    print(text, end="")
    if args.markdown:
        args.markdown.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
