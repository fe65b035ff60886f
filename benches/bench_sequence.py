"""Throughput of ``eodarm.solve_sequence``: compiled core vs a vectorised numpy version.

N sequences × S = 8 states (0 → 1.5 → 5 → 6.5 → 5 → 1.5 → 0 → 3 kg) on the example arm, at
poses scattered ±5° around (90, 10, 0)°, with one effect of every kind: both frictions, the
six of the catalogue (play and clearance centred). The numpy version below does the same work
written for speed (not the package's reference). Once per sequence: the reference geometry,
the statics of the reference and of a unit payload (the payload's are linear in it), link 1's
bending under a unit payload (no friction touches link 1's loads here) and the checks of the
unloaded pose. Then per state, vectorised over the sequences: the two Coulomb steps
(``np.clip``), every effect's cause, the exact closure (each actuator triangle closed by
circle intersection, link i's rotation as cos/sin from the vectors: no trigonometry but the
base tilt's, and one arctan2 per link for ``dalpha_deg``) and the state's validity checks,
filling every output of ``solve_sequence`` (forces, their changes, joint reactions, angle and
length changes, the unloaded lengths, the displacements, the status codes) in arrays
allocated once, 8192 sequences at a time (the temporaries then stay in the cache: about 1.3×
faster than all at once here). Its light variant computes only ``dx_mm``, ``dy_mm`` and
``dl_mm`` (no angle, force or status output); both are timed, and the speed-up is quoted
against each.

Before timing, the numpy version is checked against ``eodarm.solve_sequence`` on every key:
floats to 1e-9 in their units (N, mm, degrees) plus 1e-13 of the value (the two compute the
same formulas in a different order, which leaves ~1e-12 here and ~1e-14 relative on the
status check's forces of up to ~1e6 N), ``status`` exactly. The bench's poses are all ``ok``,
so the status is also checked on a second input that breaks limits: the example arm with
narrower strokes, at wide poses (out of stroke at either end, near singular) under payloads up
to 150 kg (over force, large deflection). No branch flip occurs there, nor a rise of the
measure point that decides a status: those checks are computed as the core computes them, but
only the four other codes are exercised. Each figure is the best of k calls, k growing until
the calls took about a second.

Run from the repository root (``docs/benchmarks.md`` has the results)::

    python3 benches/bench_sequence.py                  # 1e5 sequences × 8 states
    python3 benches/bench_sequence.py --sequences 2000 # quick
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

import eodarm
from eodarm.model.validity import (
    MAX_DALPHA_DEG,
    MAX_DEFLECTION_OF_REACH,
    MAX_RISE_OF_REACH,
    MIN_MOMENT_ARM,
    STATUS,
)

ROOT = Path(__file__).resolve().parent.parent
ARM_FILE = ROOT / "examples" / "example_arm.toml"
MASSES = np.array([0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0, 3.0])
EFFECTS = [
    eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=1500.0),
    eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
    eodarm.Effect("actuator_play", "M3", play_mm=0.05),
    eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15),
    eodarm.Effect("link_bending", "L1", ei_n_mm2=2.0e10),
    eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=5.0e8),
    eodarm.Effect("actuator_friction", "M1", friction_n=40.0),
    eodarm.Effect("joint_friction", "O3", torque_nmm=4000.0),
]
F = npt.NDArray[np.float64]
ZERO_N = 1e-9
#: Agreement asked of every float output, in its unit (N, mm or degrees) ...
TOLERANCE = 1e-9
#: ... plus this fraction of the value: near singular poses of the status check carry forces
#: up to ~1e6 N, which float64 itself resolves only to ~1e-10 N.
REL_TOLERANCE = 1e-13
#: The status check's payloads (kg): past the actuators' max_force and back.
HEAVY = np.array([0.0, 15.0, 60.0, 150.0, 60.0, 0.0])
#: Sequences the numpy version solves at a time (the outputs are allocated for all at once).
BLOCK = 8192


def rot(c: F, s: F, v: F) -> F:
    """R(t)·v for (N,) cos t and sin t, v (2,) or (N, 2): (N, 2)."""
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def cross(a: F, b: F) -> F:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _w(x: float, x_p: float, fy: F, cpl: F) -> F:
    """Deflection (× EI, mm) at x of a cantilever under a force fy and couple cpl at x_p."""
    d = max(x_p - x, 0.0)
    return fy * (d**3 / 6.0) + cpl * (d * d / 2.0)


def _dw(x: float, x_p: float, fy: F, cpl: F) -> F:
    """Slope (× EI) at x of the cantilever of :func:`_w`."""
    d = max(x_p - x, 0.0)
    return -(fy * (d * d / 2.0) + cpl * d)


def numpy_sequence(
    arm: eodarm.Arm, alpha_deg: F, masses: F, full: bool = True, block: int = BLOCK
) -> dict[str, npt.NDArray[Any]]:
    """``solve_sequence`` of EFFECTS for N sequences of the payloads ``masses`` (kg, (S,)).

    ``full``: every output of ``eodarm.solve_sequence``, the same keys, shapes and dtypes
    (``force_n``, ``dforce_n``, ``dalpha_deg``, ``dl_mm``, ``dlength_mm``, ``length_mm`` (N,
    S, n), ``reaction_n`` (N, S, n, 2), ``dx_mm``, ``dy_mm`` (N, S), ``status`` (N, S)
    uint8). Otherwise the light version: ``dx_mm``, ``dy_mm`` and ``dl_mm`` only. The
    outputs are allocated once; ``block`` sequences at a time fill their rows, so that the
    temporaries of a state stay in the cache.
    """
    if arm.n != 3:
        raise ValueError("the numpy version places EFFECTS on a 3-link arm")
    n, rows, states = arm.n, alpha_deg.shape[0], masses.size
    out: dict[str, npt.NDArray[Any]] = {
        "dx_mm": np.empty((rows, states)),
        "dy_mm": np.empty((rows, states)),
        "dl_mm": np.empty((rows, states, n)),
    }
    if full:
        for key in ("force_n", "dforce_n", "dalpha_deg", "dlength_mm", "length_mm"):
            out[key] = np.empty((rows, states, n))
        out["reaction_n"] = np.empty((rows, states, n, 2))
        out["status"] = np.empty((rows, states), dtype=np.uint8)
    for start in range(0, rows, block):
        rows_of = slice(start, start + block)
        _fill(arm, alpha_deg[rows_of], masses, {k: v[rows_of] for k, v in out.items()})
    return out


def _fill(arm: eodarm.Arm, alpha_deg: F, masses: F, out: dict[str, npt.NDArray[Any]]) -> None:
    """Fills the rows ``out`` (views of :func:`numpy_sequence`'s outputs) of the sequences
    at ``alpha_deg``."""
    full = "status" in out
    ar = arm.arrays()
    n, rows, g = arm.n, alpha_deg.shape[0], float(ar["g"])
    alpha = np.radians(alpha_deg)
    ca, sa = np.cos(alpha), np.sin(alpha)
    # --- once per sequence: the reference (unloaded) geometry and forces
    o = [np.broadcast_to(ar["O1"], (rows, 2))]
    a, b, c = [], [np.broadcast_to(ar["B0"], (rows, 2))], []
    for i in range(n):
        a.append(o[i] + rot(ca[:, i], sa[:, i], ar["A"][i]))
        c.append(o[i] + rot(ca[:, i], sa[:, i], ar["C"][i]))
        b.append(o[i] + rot(ca[:, i], sa[:, i], ar["B"][i]))
        o.append(o[i] + rot(ca[:, i], sa[:, i], ar["next"][i]))
    ell = np.stack([np.hypot(*(a[i] - b[i]).T) for i in range(n)])  # (n, N)
    e = [(a[i] - b[i]) / ell[i][:, None] for i in range(n)]
    h = [cross(a[i] - o[i], e[i]) for i in range(n)]
    # the side of each actuator triangle, sign((A − O) × (O − B)), which the closure keeps
    side = [np.sign(cross(b[i] - o[i], a[i] - o[i])) for i in range(n)]
    measure0 = o[n - 1] + rot(ca[:, n - 1], sa[:, n - 1], ar["measure"])

    def statics(weights: bool, payload: F) -> tuple[list[F], list[F]]:
        f: list[F] = [np.empty(0)] * n
        r: list[F] = [np.empty(0)] * n
        down = np.array([0.0, -g]) if weights else np.zeros(2)
        for i in reversed(range(n)):
            loads = [(c[i], ar["link_mass"][i] * down), (a[i], 0.5 * ar["act_mass"][i] * down)]
            if i + 1 < n:
                loads += [
                    (b[i + 1], 0.5 * ar["act_mass"][i + 1] * down),
                    (b[i + 1], -f[i + 1][:, None] * e[i + 1]),
                    (o[i + 1], -r[i + 1]),
                ]
            else:
                loads.append((o[n], payload))
            q = sum(np.broadcast_to(p, (rows, 2)) for _, p in loads)
            t = sum(cross(x - o[i], np.broadcast_to(p, (rows, 2))) for x, p in loads)
            f[i] = -t / h[i]
            r[i] = -q - f[i][:, None] * e[i]
        return f, r

    f0l, r0l = statics(True, np.zeros((rows, 2)))
    ful, rul = statics(False, np.broadcast_to([0.0, -1.0], (rows, 2)))  # per N of payload
    f0, fu = np.stack(f0l), np.stack(ful)  # (n, N)
    r0x, r0y = np.stack([r[:, 0] for r in r0l]), np.stack([r[:, 1] for r in r0l])
    rux, ruy = np.stack([r[:, 0] for r in rul]), np.stack([r[:, 1] for r in rul])
    ex, ey = np.stack([v[:, 0] for v in e]), np.stack([v[:, 1] for v in e])
    # --- the effects' constants
    body_c = 1.0 / ar["stiffness"].astype(float)
    body_c[0] = 1.0 / 1500.0
    mount_c1 = 1.0 / 4000.0
    play, clearance, ei, k_base = 0.05, 0.15, 2.0e10, 5.0e8
    lim_body = 40.0
    lim_joint = 4000.0 / np.abs(h[2])
    # Link 1's bending. No friction touches the forces on link 1 here (the joint friction is
    # at O3), so its loads, and the shifts of its points A_1, B_1 and next_1 (in its frame),
    # are the payload p (N) times those of a unit payload: computed once. Loads at O_1 (x=0),
    # A_1, B_1 and next_1 (global, then in link 1's frame).
    lk = arm.links[0]
    pts = np.array([lk.A, lk.B, lk.next], dtype=float)
    at = np.array([[0.0, 0.0], lk.A, lk.B, lk.next], dtype=float)
    xa = float(lk.A[0])
    unit_loads = [rul[0], ful[0][:, None] * e[0], -ful[1][:, None] * e[1], -rul[1]]
    beam = []
    for k, fg in enumerate(unit_loads):
        fl = rot(ca[:, 0], -sa[:, 0], fg)
        beam.append((float(at[k, 0]), fl[:, 1], -at[k, 1] * fl[:, 0]))
    w0 = sum(_w(0.0, *bl) for bl in beam)
    slope = (sum(_w(xa, *bl) for bl in beam) - w0) / xa
    unit_shift = []
    for q in pts:
        v = (sum(_w(float(q[0]), *bl) for bl in beam) - w0 - slope * q[0]) / ei
        dv = (sum(_dw(float(q[0]), *bl) for bl in beam) - slope) / ei
        unit_shift.append((-q[1] * dv, v))
    (ua1x, ua1y), (ub1x, ub1y), (un1x, un1y) = unit_shift
    # the base tilt per N of payload: the couple of −p·ŷ at the load point about the pivot
    piv = ar["pivot"]
    dphi_u = -(o[n][:, 0] - piv[0]) / k_base
    uo, ub = ar["O1"] - piv, ar["B0"] - piv
    # the closure's constant |a_i|² (link 1's changes as it bends)
    rho2_c = (ar["A"] ** 2).sum(axis=1)
    nxt, bpin, meas = ar["next"], ar["B"], ar["measure"]
    m0x, m0y = measure0[:, 0], measure0[:, 1]

    if full:
        out["length_mm"][:] = ell.T[:, None, :]
        # the validity checks of the unloaded pose (docs/model.md §7), once per sequence:
        # out of stroke (code 1) before near singular (code 2)
        stroke = np.zeros(rows, dtype=bool)
        for i, act in enumerate(arm.actuators):
            if act.min_length_mm is not None:
                stroke |= ell[i] < act.min_length_mm
            if act.max_length_mm is not None:
                stroke |= ell[i] > act.max_length_mm
        near = np.zeros(rows, dtype=bool)
        for i in range(n):
            near |= ~(np.abs(h[i]) >= MIN_MOMENT_ARM * np.sqrt(rho2_c[i]))
        base_code = np.where(stroke, np.uint8(1), np.where(near, np.uint8(2), np.uint8(0)))
        fmax = np.array(
            [np.inf if act.max_force_n is None else act.max_force_n for act in arm.actuators]
        )[:, None]
        reach = float(np.hypot(nxt[:, 0], nxt[:, 1]).sum())
        # (A_i × v_i, A_i · v_i), v_i = O_i − B_{i−1} in body i−1's frame (global for i = 1):
        # the rigid loaded triangle's side is sign(cos θ·(A × v) − sin θ·(A · v)), θ link
        # i's angle relative to body i−1. (The load point's rise is not checked: EFFECTS
        # has gaps, docs/model.md §7.)
        v_tri = np.vstack([ar["O1"] - ar["B0"], nxt[:-1] - bpin[:-1]])
        tri_k = cross(ar["A"], v_tri)
        tri_d = (ar["A"] * v_tri).sum(axis=1)

    held_j, held_b = np.zeros(rows), np.zeros(rows)
    for s, m in enumerate(masses):
        p = float(m) * g
        df = fu * p
        drx, dry = rux * p, ruy * p
        # joint friction at O3, then the body friction at M1
        # A Coulomb element keeps S within L of what it sees: S ← clip(S, x − L, x + L).
        x = df[2]  # a view: read (clip, slip) before df[2] is overwritten
        held_j = np.clip(held_j, x - lim_joint, x + lim_joint)
        slip = held_j - x
        drx[2] -= slip * ex[2]
        dry[2] -= slip * ey[2]
        df[2] = held_j
        held_b = np.clip(held_b, df[0] - lim_body, df[0] + lim_body)
        body = (held_b, df[1], df[2])
        dl_view = out["dl_mm"][:, s]
        for i in range(n):
            np.multiply(body[i], -body_c[i], out=dl_view[:, i])
        force = f0 + df if full else None
        f_act = force[2] if force is not None else f0[2] + df[2]
        sgn = np.where(np.abs(f_act) < ZERO_N, 0.0, np.sign(f_act))
        dlen = (
            dl_view[:, 0],
            dl_view[:, 1] - df[1] * mount_c1,
            dl_view[:, 2] - play * sgn,
        )
        # clearance at O3 taken up along the pin's actual reaction
        px, py = -(r0x[2] + drx[2]), -(r0y[2] + dry[2])
        pn = np.hypot(px, py)
        scale = np.where(pn >= ZERO_N, clearance / np.where(pn > 0, pn, 1.0), 0.0)
        off_x, off_y = px * scale, py * scale
        # the exact closure, base to tip, after the base tilt
        dphi = dphi_u * p
        cph, sph = np.cos(dphi), np.sin(dphi)
        ox, oy = piv[0] + cph * uo[0] - sph * uo[1], piv[1] + sph * uo[0] + cph * uo[1]
        bx, by = piv[0] + cph * ub[0] - sph * ub[1], piv[1] + sph * ub[0] + cph * ub[1]
        cp: Any = 1.0  # cos and sin of the previous body's loaded angle
        sp: Any = 0.0
        flip = np.zeros(rows, dtype=bool)
        big = np.zeros(rows, dtype=bool)
        for i in range(n):
            if i > 0:
                nx, ny = nxt[i - 1]
                bbx, bby = bpin[i - 1]
                if i == 1:
                    nx, ny = nx + p * un1x, ny + p * un1y
                    bbx, bby = bbx + p * ub1x, bby + p * ub1y
                opx, opy = ox, oy
                ox, oy = opx + (cp * nx - sp * ny), opy + (sp * nx + cp * ny)
                if i == 2:
                    ox, oy = ox + off_x, oy + off_y
                bx, by = opx + (cp * bbx - sp * bby), opy + (sp * bbx + cp * bby)
            # A_i on the circle of radius ρ = |a_i| about O_i at the new length from B_{i−1},
            # on the unloaded side: A − O = k1·D + k2·D⊥ with D = B − O, k1 = ρ·cos t/|D|,
            # k2 = ±ρ·sin t/|D|; then link i's rotation is the one that maps a_i to A − O.
            if i == 0:
                alx, aly = ar["A"][0, 0] + p * ua1x, ar["A"][0, 1] + p * ua1y
                rho2 = alx * alx + aly * aly
            else:
                (alx, aly), rho2 = ar["A"][i], rho2_c[i]
            dvx, dvy = bx - ox, by - oy
            dd2 = dvx * dvx + dvy * dvy
            new_len = ell[i] + dlen[i]
            k1 = (rho2 + dd2 - new_len * new_len) / (2.0 * dd2)
            k2 = side[i] * np.sqrt(rho2 / dd2 - k1 * k1)
            ax, ay = k1 * dvx - k2 * dvy, k1 * dvy + k2 * dvx
            cn, sn = (alx * ax + aly * ay) / rho2, (alx * ay - aly * ax) / rho2
            if full:
                # the turn from the unloaded angle, in (−180°, 180°]
                d = np.arctan2(sn * ca[:, i] - cn * sa[:, i], cn * ca[:, i] + sn * sa[:, i])
                dalpha = np.degrees(d)
                out["dalpha_deg"][:, s, i] = dalpha
                out["dlength_mm"][:, s, i] = dlen[i]
                big |= ~(np.abs(dalpha) <= MAX_DALPHA_DEG)
                cos_rel, sin_rel = cn * cp + sn * sp, sn * cp - cn * sp
                loaded_side = np.sign(cos_rel * tri_k[i] - sin_rel * tri_d[i])
                flip |= side[i] * loaded_side < 0
            cp, sp = cn, sn
        dx = ox + (cp * meas[0] - sp * meas[1]) - m0x
        dy = oy + (sp * meas[0] + cp * meas[1]) - m0y
        out["dx_mm"][:, s], out["dy_mm"][:, s] = dx, dy
        if force is not None:
            out["force_n"][:, s] = force.T
            out["dforce_n"][:, s] = df.T
            out["reaction_n"][:, s, :, 0] = (r0x + drx).T
            out["reaction_n"][:, s, :, 1] = (r0y + dry).T
            # this state's checks, and the first broken limit by code
            over = (np.abs(force) > fmax).any(axis=0)
            big |= ~(np.hypot(dx, dy) <= MAX_DEFLECTION_OF_REACH * reach)
            if p > 0.0:  # a downward payload: the measure point must not rise
                big |= dy > MAX_RISE_OF_REACH * reach
            code = np.where(flip, np.uint8(3), np.where(over, np.uint8(4), np.uint8(5) * big))
            out["status"][:, s] = np.where(base_code != 0, base_code, code)


def best(fn: Callable[[], object], budget: float = 1.0) -> float:
    times: list[float] = []
    start = time.perf_counter()
    while not times or (time.perf_counter() - start < budget and len(times) < 20):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def compare(arm: eodarm.Arm, alpha: F, masses: F) -> tuple[dict[str, float], Any]:
    """The largest difference of each float output between the numpy version and
    ``solve_sequence`` (exits if one is above TOLERANCE, or a status, key, shape or dtype
    differs), and the core's status codes."""
    core = eodarm.solve_sequence(arm, alpha, masses, EFFECTS)
    mine = numpy_sequence(arm, alpha, masses, block=700)  # blocks, a partial last one
    if set(core) != set(mine):
        raise SystemExit(f"keys differ: core {sorted(core)}, numpy {sorted(mine)}")
    diffs: dict[str, float] = {}
    for key, want in core.items():
        got = mine[key]
        if got.shape != want.shape or got.dtype != want.dtype:
            raise SystemExit(
                f"{key}: numpy {got.shape} {got.dtype}, core {want.shape} {want.dtype}"
            )
        if key == "status":
            bad = np.flatnonzero(got != want)
            if bad.size:
                q, s = np.unravel_index(bad[0], want.shape)
                raise SystemExit(
                    f"status differs in {bad.size} states, first sequence {q} state {s}: "
                    f"numpy {STATUS[got[q, s]]}, core {STATUS[want[q, s]]}"
                )
            continue
        gap = np.abs(got - want)
        diffs[key] = float(gap.max())
        if not (gap <= TOLERANCE + REL_TOLERANCE * np.abs(want)).all():
            raise SystemExit(f"{key}: the numpy version differs by {diffs[key]:.3g}")
    return diffs, core["status"]


def narrow_strokes(arm: eodarm.Arm) -> eodarm.Arm:
    """The arm with the strokes of actuators 2 and 3 ending at 600 and 540 mm: the example
    arm's cannot reach their max_length_mm, this one's can (both ends of a stroke checked)."""
    d = arm.to_dict()
    d["actuator"][1]["max_length_mm"] = 600.0
    d["actuator"][2]["max_length_mm"] = 540.0
    return eodarm.Arm.from_dict(d, source=f"{arm.source} (strokes narrowed)")


def limit_breaking_poses(arm: eodarm.Arm, count: int) -> F:
    """``count`` drawn wide poses (out of stroke, near singular ones among them) whose
    sequences of HEAVY payloads the core can solve in every state."""
    rng = np.random.default_rng(11)
    alpha = rng.uniform([-30.0, -120.0, -150.0], [150.0, 90.0, 90.0], (count, 3))
    res = eodarm.solve_sequence(arm, alpha, HEAVY, EFFECTS, nan_on_failure=True)
    ok = np.isfinite(res["dx_mm"]).all(axis=1) & np.isfinite(res["dalpha_deg"]).all(axis=(1, 2))
    return alpha[ok]


def counts(codes: Any) -> str:
    c = np.bincount(np.asarray(codes).ravel(), minlength=len(STATUS))
    return ", ".join(f"{STATUS[i]} {k:,}" for i, k in enumerate(c) if k)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sequences", type=int, default=100_000)
    args = ap.parse_args()
    arm = eodarm.Arm.from_toml(ARM_FILE)
    rng = np.random.default_rng(7)
    alpha = np.array([90.0, 10.0, 0.0]) + rng.uniform(-5.0, 5.0, (args.sequences, 3))
    states = args.sequences * MASSES.size
    diffs, _ = compare(arm, alpha[:2000], MASSES)
    narrow = narrow_strokes(arm)
    wide = limit_breaking_poses(narrow, 3000)
    wide_diffs, wide_status = compare(narrow, wide, HEAVY)
    wide_force = float(np.abs(numpy_sequence(narrow, wide, HEAVY)["force_n"]).max())
    light = numpy_sequence(arm, alpha[:2000], MASSES, full=False)
    full = numpy_sequence(arm, alpha[:2000], MASSES)
    if set(light) != {"dx_mm", "dy_mm", "dl_mm"} or any(
        not np.array_equal(light[k], full[k]) for k in light
    ):
        raise SystemExit("the light numpy version differs from the full one")
    bench_status = eodarm.solve_sequence(arm, alpha, MASSES, EFFECTS)["status"]
    t_rust = best(lambda: eodarm.solve_sequence(arm, alpha, MASSES, EFFECTS))
    t_np = best(lambda: numpy_sequence(arm, alpha, MASSES))
    t_light = best(lambda: numpy_sequence(arm, alpha, MASSES, full=False))
    frictionless = [e for e in EFFECTS if not e.name.endswith("_friction")]
    t_free = best(lambda: eodarm.solve_sequence(arm, alpha, MASSES, frictionless))
    # The floor of any implementation that returns fresh arrays: allocating the outputs and
    # writing every element once, nothing computed.
    shapes = {k: (v.shape[2:], v.dtype) for k, v in full.items()}
    shapes["status"] = ((), np.dtype(np.uint8))
    n_seq = args.sequences

    def outputs_only() -> list[F]:
        return [np.ones((n_seq, MASSES.size, *sh), dtype=dt) for sh, dt in shapes.values()]

    t_floor = best(outputs_only)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores")
    print(f"{args.sequences:,} sequences × {MASSES.size} states, every effect kind (8)")
    worst = max(diffs.values())
    print(
        f"numpy version agrees with solve_sequence on every key ({len(diffs) + 1}): floats to "
        f"{worst:.2g} (N, mm, deg; tolerance {TOLERANCE:g}), status exactly"
    )
    print(f"  bench states by status: {counts(bench_status)}")
    print(
        f"  status check, the strokes narrowed, on {wide.shape[0]:,} wide poses × "
        f"{HEAVY.size} states "
        f"({', '.join(f'{m:g}' for m in HEAVY)} kg): floats to "
        f"{max(wide_diffs.values()):.2g} (|force| up to {wide_force:.2g} N), status exactly; "
        f"{counts(wide_status)}"
    )
    print(f"solve_sequence (rust):    {t_rust:8.3f} s  {states / t_rust / 1e6:7.2f} M states/s")
    print(f"numpy, every output:      {t_np:8.3f} s  {states / t_np / 1e6:7.2f} M states/s")
    print(f"numpy, dx, dy, dl only:   {t_light:8.3f} s  {states / t_light / 1e6:7.2f} M states/s")
    print(
        f"speed-up: {t_np / t_rust:.1f}× the same work (every output), "
        f"{t_light / t_rust:.1f}× the light version"
    )
    print(
        f"without the two frictions (block kernel): {t_free:8.3f} s  "
        f"{states / t_free / 1e6:7.2f} M states/s"
    )
    mb = sum(np.prod(sh, dtype=int) * dt.itemsize for sh, dt in shapes.values()) * states / 1e6
    print(
        f"allocating and writing the {len(shapes)} outputs alone ({mb:.0f} MB, nothing "
        f"computed, numpy, one thread): {t_floor:8.3f} s, 1/{t_np / t_floor:.0f} of the numpy "
        "version's time"
    )


if __name__ == "__main__":
    main()
