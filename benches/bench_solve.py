"""Throughput of ``eodarm.solve``: compiled core vs numpy reference vs independent versions.

Times ``eodarm.solve`` as a user calls it (all outputs, ``status`` included) with
``backend="rust"`` and ``backend="numpy"`` on the example arm, for the baseline model and for
all six effect kinds at once, in the same run as two independent implementations of the
baseline model written below and checked against ``eodarm.solve`` before they are timed: a
vectorised numpy version (whole arrays, one loop over the links) and a plain-Python per-pose
loop (floats and :mod:`math`). Every figure is the best of k calls, k growing until the calls
have taken about a second. The pure-Python loop is timed at 1e3 and 1e4 poses only; larger
sizes use its per-pose cost at the largest timed size (marked as extrapolated). ``--parts``
also splits one call at 1e6 poses into its parts (input checks, allocation, kernel). The
``out=`` column times the same call writing into arrays allocated once by the caller (what a
loop of repeated calls does).

Run from the repository root (``docs/benchmarks.md`` has the results)::

    python3 benches/bench_solve.py                     # 1e3 … 1e6 poses
    python3 benches/bench_solve.py --quick             # 1e3 … 1e5, shorter timing
    python3 benches/bench_solve.py --sizes 1000,100000 --markdown results.md
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from functools import partial
from pathlib import Path

import numpy as np
import numpy.typing as npt

import eodarm

ROOT = Path(__file__).resolve().parent.parent
ARM_FILE = ROOT / "examples" / "example_arm.toml"
SIZES = (1_000, 10_000, 100_000, 1_000_000)
PY_MAX = 10_000  # the pure-Python loop is timed up to this many poses, extrapolated beyond

#: One effect of each kind, at the places and values of the criterion benchmark.
ALL_EFFECTS = [
    eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=1500.0),
    eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
    eodarm.Effect("actuator_play", "M3", play_mm=0.05),
    eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15),
    eodarm.Effect("link_bending", "L2", ei_n_mm2=2.0e10),
    eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=5.0e8),
]
MODELS: dict[str, list[eodarm.Effect]] = {"baseline": [], "all effects": ALL_EFFECTS}

FloatArray = npt.NDArray[np.float64]
Vec = tuple[float, float]


# ------------------------------------------------------------------ the pure-Python baseline
@dataclass(frozen=True)
class PyArm:
    """The arm as plain floats: per link (next, A, B, C, link mass), per actuator (k, mass)."""

    g: float
    o1: Vec
    b0: Vec
    links: tuple[tuple[Vec, Vec, Vec, Vec, float], ...]
    acts: tuple[tuple[float, float], ...]
    measure: Vec

    @classmethod
    def of(cls, arm: eodarm.Arm) -> PyArm:
        links = tuple((lk.next, lk.A, lk.B or (0.0, 0.0), lk.C, lk.mass_kg) for lk in arm.links)
        acts = tuple((a.stiffness_n_per_mm, a.mass_kg) for a in arm.actuators)
        return cls(arm.g, arm.O1, arm.B0, links, acts, arm.measure)


def _rot(s: float, c: float, p: Vec) -> Vec:
    return (c * p[0] - s * p[1], s * p[0] + c * p[1])


def _forces(
    arm: PyArm,
    o: list[Vec],
    a: list[Vec],
    b: list[Vec],
    cm: list[Vec],
    e: list[Vec],
    h: list[float],
    weights: bool,
    payload: Vec,
) -> tuple[list[float], list[Vec]]:
    """Statics from the tip to the base: moments about O_i give F_i, force balance R_i."""
    n = len(arm.links)
    g = arm.g if weights else 0.0
    f = [0.0] * n
    r = [(0.0, 0.0)] * n
    for i in range(n - 1, -1, -1):
        ox, oy = o[i]
        loads = [(cm[i], (0.0, -arm.links[i][4] * g)), (a[i], (0.0, -0.5 * arm.acts[i][1] * g))]
        if i + 1 < n:
            fi, ej, rj = f[i + 1], e[i + 1], r[i + 1]
            loads.append((b[i + 1], (-fi * ej[0], -0.5 * arm.acts[i + 1][1] * g - fi * ej[1])))
            loads.append((o[i + 1], (-rj[0], -rj[1])))
        else:
            loads.append((o[n], payload))
        qx = qy = t = 0.0
        for (px, py), (fx, fy) in loads:
            qx += fx
            qy += fy
            t += (px - ox) * fy - (py - oy) * fx
        f[i] = -t / h[i]
        r[i] = (-qx - f[i] * e[i][0], -qy - f[i] * e[i][1])
    return f, r


def solve_pose_python(arm: PyArm, alpha_deg: Sequence[float], mass_kg: float) -> tuple[float, ...]:
    """Baseline model of one pose in plain Python: (dx_mm, dy_mm, loaded forces F_1…F_n).

    Forward kinematics, statics of the self-weight and the payload cases on the undeformed
    pose, actuator springs ``Δℓ_i = −ΔF_i/k_i``, then every actuator triangle closed exactly
    from the base out (law of cosines), on the side of the unloaded pose.
    """
    n = len(arm.links)
    sc = [(math.sin(x), math.cos(x)) for x in map(math.radians, alpha_deg)]
    o: list[Vec] = [arm.o1]  # joints O_1…O_n, then the load point
    b: list[Vec] = [arm.b0]  # base pins B_0…B_{n−1} (one spare entry from the last link)
    a: list[Vec] = []
    cm: list[Vec] = []
    for (s, c), (nxt, pa, pb, pc, _) in zip(sc, arm.links, strict=True):
        ox, oy = o[-1]
        for out, p in ((a, pa), (cm, pc), (b, pb), (o, nxt)):
            x, y = _rot(s, c, p)
            out.append((ox + x, oy + y))
    x, y = _rot(*sc[-1], arm.measure)
    meas = (o[n - 1][0] + x, o[n - 1][1] + y)
    e: list[Vec] = []
    ell: list[float] = []
    h: list[float] = []
    side: list[float] = []
    for i in range(n):
        vx, vy = a[i][0] - b[i][0], a[i][1] - b[i][1]
        ln = math.hypot(vx, vy)
        rx, ry = a[i][0] - o[i][0], a[i][1] - o[i][1]
        e.append((vx / ln, vy / ln))
        ell.append(ln)
        h.append(rx * vy / ln - ry * vx / ln)
        side.append(math.copysign(1.0, (b[i][0] - o[i][0]) * ry - (b[i][1] - o[i][1]) * rx))
    fw, _ = _forces(arm, o, a, b, cm, e, h, True, (0.0, 0.0))
    fd, _ = _forces(arm, o, a, b, cm, e, h, False, (0.0, -mass_kg * arm.g))
    (ox, oy), (bx, by) = arm.o1, arm.b0
    for i, (nxt, pa, pb, _, _) in enumerate(arm.links):
        length = ell[i] - fd[i] / arm.acts[i][0]
        dx, dy = bx - ox, by - oy
        rho, d = math.hypot(*pa), math.hypot(dx, dy)
        cos_t = (rho * rho + d * d - length * length) / (2.0 * rho * d)
        if not -1.0 <= cos_t <= 1.0:
            raise ValueError(f"actuator {i + 1} cannot close its triangle")
        al = math.atan2(dy, dx) + side[i] * math.acos(cos_t) - math.atan2(pa[1], pa[0])
        s, c = math.sin(al), math.cos(al)
        x, y = _rot(s, c, pb if i + 1 < n else arm.measure)
        bx, by = ox + x, oy + y  # the next base pin, or the measurement point on the last link
        x, y = _rot(s, c, nxt)
        ox, oy = ox + x, oy + y
    return (bx - meas[0], by - meas[1], *(w + d for w, d in zip(fw, fd, strict=True)))


def solve_python(arm: PyArm, alpha_deg: FloatArray, mass_kg: FloatArray) -> list[tuple[float, ...]]:
    """The per-pose loop over a batch (inputs converted to lists of floats first)."""
    return [
        solve_pose_python(arm, row, m)
        for row, m in zip(alpha_deg.tolist(), mass_kg.tolist(), strict=True)
    ]


# ------------------------------------------------------------------ the vectorised baseline
def _rot_np(s: FloatArray, c: FloatArray, p: Vec) -> tuple[FloatArray, FloatArray]:
    return c * p[0] - s * p[1], s * p[0] + c * p[1]


def solve_numpy(arm: PyArm, alpha_deg: FloatArray, mass_kg: FloatArray) -> dict[str, FloatArray]:
    """Baseline model of N poses with whole numpy arrays: ``dx_mm``, ``dy_mm`` (N,) and the
    loaded forces ``force_n`` (N, n); the same steps as :func:`solve_pose_python`."""
    n = len(arm.links)
    rad = np.radians(alpha_deg)
    sn, cs = np.sin(rad), np.cos(rad)
    rows = alpha_deg.shape[0]
    ox, oy = np.full(rows, arm.o1[0]), np.full(rows, arm.o1[1])
    bx, by = np.full(rows, arm.b0[0]), np.full(rows, arm.b0[1])
    o, a, b, cm = [], [], [], []
    for i, (nxt, pa, pb, pc, _) in enumerate(arm.links):
        s, c = sn[:, i], cs[:, i]
        o.append((ox, oy))
        b.append((bx, by))
        x, y = _rot_np(s, c, pa)
        a.append((ox + x, oy + y))
        x, y = _rot_np(s, c, pc)
        cm.append((ox + x, oy + y))
        x, y = _rot_np(s, c, pb)
        bx, by = ox + x, oy + y
        x, y = _rot_np(s, c, nxt)
        ox, oy = ox + x, oy + y
    o.append((ox, oy))
    x, y = _rot_np(sn[:, -1], cs[:, -1], arm.measure)
    meas = (o[n - 1][0] + x, o[n - 1][1] + y)
    e, ell, h, side = [], [], [], []
    for i in range(n):
        vx, vy = a[i][0] - b[i][0], a[i][1] - b[i][1]
        ln = np.hypot(vx, vy)
        rx, ry = a[i][0] - o[i][0], a[i][1] - o[i][1]
        e.append((vx / ln, vy / ln))
        ell.append(ln)
        h.append((rx * vy - ry * vx) / ln)
        side.append(np.sign((b[i][0] - o[i][0]) * ry - (b[i][1] - o[i][1]) * rx))

    def forces(g: float, px: FloatArray, py: FloatArray) -> list[FloatArray]:
        f: list[FloatArray] = [np.zeros(rows)] * n
        rx, ry = -px, -py  # the "reaction" beyond the tip is minus the payload
        for i in range(n - 1, -1, -1):
            w_c = -arm.links[i][4] * g
            w_a = -0.5 * arm.acts[i][1] * g
            qx = -rx
            qy = w_c + w_a - ry
            t = (cm[i][0] - o[i][0]) * w_c + (a[i][0] - o[i][0]) * w_a
            t += (o[i + 1][0] - o[i][0]) * (-ry) - (o[i + 1][1] - o[i][1]) * (-rx)
            if i + 1 < n:
                w_b = -0.5 * arm.acts[i + 1][1] * g
                fx, fy = -f[i + 1] * e[i + 1][0], w_b - f[i + 1] * e[i + 1][1]
                qx, qy = qx + fx, qy + fy
                t += (b[i + 1][0] - o[i][0]) * fy - (b[i + 1][1] - o[i][1]) * fx
            f[i] = -t / h[i]
            rx, ry = -qx - f[i] * e[i][0], -qy - f[i] * e[i][1]
        return f

    zero = np.zeros(rows)
    fw = forces(arm.g, zero, zero)
    fd = forces(0.0, zero, -mass_kg * arm.g)
    ox, oy = np.full(rows, arm.o1[0]), np.full(rows, arm.o1[1])
    bx, by = np.full(rows, arm.b0[0]), np.full(rows, arm.b0[1])
    for i, (nxt, pa, pb, _, _) in enumerate(arm.links):
        length = ell[i] - fd[i] / arm.acts[i][0]
        dx, dy = bx - ox, by - oy
        rho, d = math.hypot(*pa), np.hypot(dx, dy)
        cos_t = (rho * rho + d * d - length * length) / (2.0 * rho * d)
        al = np.arctan2(dy, dx) + side[i] * np.arccos(cos_t) - math.atan2(pa[1], pa[0])
        s, c = np.sin(al), np.cos(al)
        x, y = _rot_np(s, c, pb if i + 1 < n else arm.measure)
        bx, by = ox + x, oy + y  # next base pin, or the measure point on the last link
        x, y = _rot_np(s, c, nxt)
        ox, oy = ox + x, oy + y
    return {
        "dx_mm": bx - meas[0],
        "dy_mm": by - meas[1],
        "force_n": np.column_stack([w + d for w, d in zip(fw, fd, strict=True)]),
    }


# ------------------------------------------------------------------ timing
def poses(rows: int, seed: int = 7) -> tuple[FloatArray, FloatArray]:
    """Reproducible poses α ∈ [60, 110] × [0, 30] × [−10, 10]° and masses 0…7 kg."""
    rng = np.random.default_rng(seed)
    lo, hi = np.array([60.0, 0.0, -10.0]), np.array([110.0, 30.0, 10.0])
    return lo + (hi - lo) * rng.random((rows, 3)), 7.0 * rng.random(rows)


def best_time(call: Callable[[], object], budget_s: float, min_repeats: int) -> float:
    """Best wall time of ``call`` over k ≥ ``min_repeats`` calls, until ``budget_s`` is spent."""
    best, spent, k = math.inf, 0.0, 0
    while k < min_repeats or (spent < budget_s and k < 1000):
        gc.collect()
        gc.disable()
        t0 = time.perf_counter()
        call()
        dt = time.perf_counter() - t0
        gc.enable()
        best, spent, k = min(best, dt), spent + dt, k + 1
    return best


def verify(arm: eodarm.Arm, parm: PyArm) -> float:
    """Check the pure-Python loop and the vectorised version against both backends of
    ``eodarm.solve`` on 2000 poses.

    Exits when ``dx_mm``/``dy_mm`` differ by more than 1e-9 mm or a loaded force by more than
    1e-10 relative; returns the largest |Δ dy_mm| (mm).
    """
    alpha, mass = poses(2000, seed=11)
    loop = np.array(solve_python(parm, alpha, mass))
    vec = solve_numpy(parm, alpha, mass)
    mine = {
        "pure-Python loop": (loop[:, 0], loop[:, 1], loop[:, 2:]),
        "vectorised numpy": (vec["dx_mm"], vec["dy_mm"], vec["force_n"]),
    }
    worst = 0.0
    for name, (dx, dy, force) in mine.items():
        for backend in ("rust", "numpy"):
            ref = eodarm.solve(arm, alpha, mass, backend=backend)
            err_dy = float(np.max(np.abs(dy - ref["dy_mm"])))
            err_dx = float(np.max(np.abs(dx - ref["dx_mm"])))
            err_f = float(np.max(np.abs(force - ref["force_n"]) / (1.0 + np.abs(ref["force_n"]))))
            if max(err_dy, err_dx) > 1e-9 or err_f > 1e-10:
                raise SystemExit(
                    f"{name} disagrees with backend={backend}: |Δdy| = {err_dy:.3g} mm, "
                    f"|Δdx| = {err_dx:.3g} mm, relative |ΔF| = {err_f:.3g}"
                )
            worst = max(worst, err_dy)
    return worst


def machine() -> list[str]:
    info: dict[str, str] = {}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, sep, value = line.partition(":")
            if sep and key.strip() not in info:
                info[key.strip()] = value.strip()
    except OSError:
        pass
    cpu = info.get("model name", "unknown CPU")
    if "cpu family" in info:
        cpu += f" (family {info['cpu family']}, model {info.get('model', '?')})"
    if "hypervisor" in info.get("flags", "").split():
        cpu += ", virtual machine"
    ncpu = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    rayon = os.environ.get("RAYON_NUM_THREADS")
    threads = f"{rayon} (RAYON_NUM_THREADS)" if rayon else f"{ncpu} (rayon default: one per CPU)"
    return [
        f"- machine: {platform.machine()}, {ncpu} CPUs (nproc), {cpu}",
        f"- python {platform.python_version()}, numpy {np.__version__}, "
        f"eodarm {eodarm.__version__}",
        f"- rayon threads: {threads}; the block kernel goes parallel from 512 poses",
    ]


def cpu_seconds() -> tuple[float, float, float, float]:
    """(wall clock, CPU-s of this process, busy and steal CPU-s of the machine) now.

    Busy and steal come from the first line of Linux's /proc/stat (NaN elsewhere); steal is
    time the hypervisor gave our virtual CPUs to someone else.
    """
    busy = steal = math.nan
    try:
        f = [int(x) for x in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
        hz = os.sysconf("SC_CLK_TCK")
        busy = (f[0] + f[1] + f[2] + f[5] + f[6]) / hz  # user nice system irq softirq
        steal = f[7] / hz
    except (OSError, ValueError, IndexError):
        pass
    return time.perf_counter(), time.process_time(), busy, steal


def others(start: tuple[float, ...], end: tuple[float, ...]) -> str:
    """How much CPU the rest of the machine used between two :func:`cpu_seconds`."""
    wall = end[0] - start[0]
    other = (end[2] - start[2]) - (end[1] - start[1])
    steal = (end[3] - start[3]) / wall
    if math.isnan(other):
        return "- CPU used by other processes: unknown (no /proc/stat)"
    return (
        f"- CPU used by other processes during the run: {max(other, 0.0) / wall:.2f} CPUs on "
        f"average (machine busy time minus this process); hypervisor steal {steal:.2f} CPUs"
    )


#: The parts of one ``eodarm.solve`` call that ``--parts`` times, each alone.
PARTS = (
    "eodarm.solve (all of it)",
    "eodarm.solve(out=...) (no allocation)",
    "core only: _core.solve(out=...)",
    "core with allocation: _core.solve",
    "input checks and conversion (Python)",
)


def parts(arm: eodarm.Arm, budget: float, min_repeats: int) -> list[str]:
    """Where the time of one call at 1e6 poses goes (baseline model): the table's rows."""
    from eodarm.model import native as _core
    from eodarm.model.effects import effect_arrays
    from eodarm.model.solver import _core_arm, _per_row, _poses

    rows = 1_000_000
    alpha, mass = poses(rows)
    payload = np.column_stack([np.zeros(rows), -mass * arm.g])
    core, codes = _core_arm(arm), effect_arrays([], arm.n)
    out = {k: np.empty_like(v) for k, v in eodarm.solve(arm, alpha, mass).items()}

    def checks() -> None:
        a = _poses(alpha, arm.n, "alpha_deg")
        m = _per_row(mass, a.shape[0], "mass_kg")
        p = np.zeros((a.shape[0], 2))
        p[:, 1] = -m * arm.g

    calls = (
        partial(eodarm.solve, arm, alpha, mass),
        partial(eodarm.solve, arm, alpha, mass, out=out),
        partial(_core.solve, core, alpha, payload, *codes, True, out=out),
        partial(_core.solve, core, alpha, payload, *codes, True),
        checks,
    )
    lines = ["| part (baseline, 1,000,000 poses) | ms | ns/pose |", "|---|---:|---:|"]
    for name, call in zip(PARTS, calls, strict=True):
        t = best_time(call, budget, min_repeats)
        lines.append(f"| {name} | {t * 1e3:,.1f} | {t / rows * 1e9:,.1f} |")
    return lines


def fmt_rate(x: float | None, extrapolated: bool = False) -> str:
    if x is None:
        return "—"
    return f"{x:,.0f}{'*' if extrapolated else ''}"


def fmt_ratio(x: float | None, extrapolated: bool = False) -> str:
    if x is None:
        return "—"
    return f"{x:,.1f}×{'*' if extrapolated else ''}"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n", 1)[0])
    ap.add_argument("--sizes", help="comma-separated pose counts (default 1e3,1e4,1e5,1e6)")
    ap.add_argument("--quick", action="store_true", help="1e3…1e5 poses, ~0.2 s per figure")
    ap.add_argument("--markdown", type=Path, metavar="FILE", help="also write the table here")
    ap.add_argument("--parts", action="store_true", help="split a 1e6-pose call into parts")
    args = ap.parse_args(argv)
    sizes = tuple(int(float(s)) for s in args.sizes.split(",")) if args.sizes else SIZES
    if args.quick and not args.sizes:
        sizes = SIZES[:3]
    budget, min_repeats = (0.2, 1) if args.quick else (1.0, 2)

    arm = eodarm.Arm.from_toml(ARM_FILE)
    parm = PyArm.of(arm)
    err = verify(arm, parm)
    load0, cpu0 = os.getloadavg(), cpu_seconds()
    started = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    print(
        "pure-Python loop and vectorised numpy agree with eodarm.solve (rust, numpy): "
        f"max |Δdy| = {err:.1e} mm"
    )

    py_rate: dict[int, float] = {}  # poses/s of the pure-Python loop at each timed size
    py_sizes = sorted({s for s in sizes if s <= PY_MAX} or {min(PY_MAX, min(sizes))})
    for rows in py_sizes:
        alpha, mass = poses(rows)
        py_rate[rows] = rows / best_time(partial(solve_python, parm, alpha, mass), budget, 1)
        print(f"pure Python, {rows:>9,} poses: {py_rate[rows]:>12,.0f} poses/s")

    header = (
        "| model | poses | rust (poses/s) | rust, out= (poses/s) | numpy reference (poses/s) "
        "| vectorised numpy (poses/s) | pure Python (poses/s) "
        "| rust/numpy ref. | rust/vectorised | rust/pure Python |"
    )
    table = [header, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for model, effects in MODELS.items():
        eodarm.solve(arm, poses(10)[0], 1.0, effects=effects)  # build the cached core arm
        for rows in sizes:
            alpha, mass = poses(rows)
            rate: dict[str, float] = {}
            for backend in ("rust", "numpy"):
                call = partial(eodarm.solve, arm, alpha, mass, effects=effects, backend=backend)
                t = best_time(call, budget, min_repeats)
                rate[backend] = rows / t
            # Repeated calls into the caller's arrays (no allocation): the rate of a sweep
            # that reuses its outputs.
            out = {k: np.empty_like(v) for k, v in eodarm.solve(arm, alpha, mass).items()}
            call = partial(eodarm.solve, arm, alpha, mass, effects=effects, out=out)
            rate["out"] = rows / best_time(call, budget, min_repeats)
            del out
            vec = None
            if not effects:
                call = partial(solve_numpy, parm, alpha, mass)
                vec = rows / best_time(call, budget, min_repeats)
            extra = rows not in py_rate  # extrapolated from the largest timed size
            py = None if effects else py_rate.get(rows, py_rate[py_sizes[-1]])
            row = (
                f"| {model} | {rows:,} | {fmt_rate(rate['rust'])} | {fmt_rate(rate['out'])} "
                f"| {fmt_rate(rate['numpy'])} "
                f"| {fmt_rate(vec)} | {fmt_rate(py, extra)} "
                f"| {fmt_ratio(rate['rust'] / rate['numpy'])} "
                f"| {fmt_ratio(rate['rust'] / vec if vec else None)} "
                f"| {fmt_ratio(rate['rust'] / py if py else None, extra)} |"
            )
            table.append(row)
            print(row, flush=True)

    if args.parts:
        table += ["", *parts(arm, budget, min_repeats)]
        print("\n".join(table[-len(PARTS) - 3 :]), flush=True)
    load1, cpu1 = os.getloadavg(), cpu_seconds()
    notes = [
        f"- run: {started}, `python3 benches/bench_solve.py"
        f"{' --quick' if args.quick else ''}{' --sizes ' + args.sizes if args.sizes else ''}`",
        *machine(),
        f"- load average (1 min) before / after: {load0[0]:.2f} / {load1[0]:.2f} "
        "(it counts this run too)",
        others(cpu0, cpu1),
        f"- best of k calls, k ≥ {min_repeats}, until ~{budget:g} s per figure; "
        "each call is `eodarm.solve` (input checks, effects, output dict included); "
        "`out=`: the same call writing into arrays the caller allocated once",
        f"- pure Python: baseline model only, timed at {', '.join(f'{s:,}' for s in py_sizes)} "
        "poses; * = extrapolated from the per-pose cost at the largest timed size",
    ]
    text = "\n".join([*notes, "", *table]) + "\n"
    print()
    print(text, end="")
    if args.markdown:
        args.markdown.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
