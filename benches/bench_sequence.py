"""Throughput of ``eodarm.solve_sequence``: compiled core vs a vectorised numpy version.

N sequences × S = 8 states (0 → 1.5 → 5 → 6.5 → 5 → 1.5 → 0 → 3 kg) on the example arm, at
poses scattered ±5° around (90, 10, 0)°, with one effect of every kind: both frictions, the
six of the catalogue (play and clearance centred). The numpy version below does the same work
written for speed (not the package's reference): the statics of one unit payload per
sequence (they are linear in the payload), then per state, vectorised over the sequences, the
two friction recursions, every effect's cause and the exact closure. It is checked against
``eodarm.solve_sequence`` before it is timed. Each figure is the best of k calls, k growing
until the calls took about a second.

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

import numpy as np
import numpy.typing as npt

import eodarm

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


def rot(t: F, v: F) -> F:
    """Rotate (N, 2) (or (2,)) vectors by angles t (N,)."""
    c, s = np.cos(t), np.sin(t)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def cross(a: F, b: F) -> F:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def numpy_sequence(arm: eodarm.Arm, alpha_deg: F, masses: F) -> dict[str, F]:
    """dx, dy (N, S) and dl (N, S, n) of EFFECTS for N sequences of the payloads ``masses``."""
    ar = arm.arrays()
    n, rows, g = arm.n, alpha_deg.shape[0], float(ar["g"])
    alpha = np.radians(alpha_deg)
    # geometry of the unloaded poses
    o = [np.broadcast_to(ar["O1"], (rows, 2))]
    a, b, c = [], [np.broadcast_to(ar["B0"], (rows, 2))], []
    for i in range(n):
        a.append(o[i] + rot(alpha[:, i], ar["A"][i]))
        c.append(o[i] + rot(alpha[:, i], ar["C"][i]))
        b.append(o[i] + rot(alpha[:, i], ar["B"][i]))
        o.append(o[i] + rot(alpha[:, i], ar["next"][i]))
    ell = [np.hypot(*(a[i] - b[i]).T) for i in range(n)]
    e = [(a[i] - b[i]) / ell[i][:, None] for i in range(n)]
    h = [cross(a[i] - o[i], e[i]) for i in range(n)]
    measure0 = o[n - 1] + rot(alpha[:, n - 1], ar["measure"])

    def statics(weights: bool, payload: F) -> tuple[list[F], list[F]]:
        f, r = [None] * n, [None] * n
        down = np.array([0.0, -g]) if weights else np.zeros(2)
        for i in reversed(range(n)):
            loads = [(c[i], ar["link_mass"][i] * down), (a[i], 0.5 * ar["act_mass"][i] * down)]
            if i + 1 < n:
                loads += [
                    (b[i + 1], 0.5 * ar["act_mass"][i + 1] * down + 0.0 * b[i + 1]),
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

    f0, r0 = statics(True, np.zeros((rows, 2)))
    fu, ru = statics(False, np.broadcast_to([0.0, -1.0], (rows, 2)))  # per N of payload
    body_c = 1.0 / ar["stiffness"].astype(float)
    body_c[0] = 1.0 / 1500.0
    mount_c = np.array([0.0, 1.0 / 4000.0, 0.0])
    play, clearance, ei, k_base = 0.05, 0.15, 2.0e10, 5.0e8
    lim_body = 40.0
    lim_joint = 4000.0 / np.abs(h[2])
    # link 1's bending influence: loads at O_1 (x=0), A_1, B_1, next_1; points A_1, B_1, next_1
    lk = arm.links[0]
    pts = np.array([lk.A, lk.B, lk.next], dtype=float)
    at = np.array([[0.0, 0.0], lk.A, lk.B, lk.next], dtype=float)
    xa = lk.A[0]

    def w(x: F, x_p: float, fy: F, cpl: F) -> F:
        d = max(x_p - x, 0.0)
        return fy * d**3 / 6.0 + cpl * d * d / 2.0

    def dw(x: F, x_p: float, fy: F, cpl: F) -> F:
        d = max(x_p - x, 0.0)
        return -(fy * d * d / 2.0 + cpl * d)

    held_j, held_b = np.zeros(rows), np.zeros(rows)
    tilt0 = o[n] - ar["pivot"]
    out = {k: np.empty((rows, masses.size)) for k in ("dx_mm", "dy_mm")}
    out["dl_mm"] = np.empty((rows, masses.size, n))
    for s, m in enumerate(masses):
        p = m * g
        df = [fu[i] * p for i in range(n)]
        dr = [ru[i] * p for i in range(n)]
        # joint friction at O3, then the body friction at M1
        # A Coulomb element keeps S within L of what it sees: S ← clip(S, x − L, x + L).
        x = df[2]
        held_j = np.clip(held_j, x - lim_joint, x + lim_joint)
        dr[2] = dr[2] - (held_j - x)[:, None] * e[2]
        df[2] = held_j
        held_b = np.clip(held_b, df[0] - lim_body, df[0] + lim_body)
        body = [held_b, df[1], df[2]]
        dl = [-body[i] * body_c[i] for i in range(n)]
        f_act = f0[2] + df[2]
        sgn = np.where(np.abs(f_act) < ZERO_N, 0.0, np.sign(f_act))
        new_len = [
            ell[0] + dl[0],
            ell[1] + dl[1] - df[1] * mount_c[1],
            ell[2] + dl[2] - play * sgn,
        ]
        press = -(r0[2] + dr[2])
        pn = np.hypot(*press.T)
        scale = np.where(pn >= ZERO_N, clearance / np.where(pn > 0, pn, 1.0), 0.0)
        off3 = press * scale[:, None]
        # link 1's bending (global loads to its frame); no joint friction touches link 1
        loads = [dr[0], df[0][:, None] * e[0], -df[1][:, None] * e[1], -dr[1]]
        shift = []
        beam_loads = []
        for k, fg in enumerate(loads):
            fl = rot(-alpha[:, 0], fg)
            beam_loads.append((at[k, 0], fl[:, 1], -at[k, 1] * fl[:, 0]))
        w0 = sum(w(0.0, *bl) for bl in beam_loads)
        slope = (sum(w(xa, *bl) for bl in beam_loads) - w0) / xa
        for q in pts:
            v = (sum(w(q[0], *bl) for bl in beam_loads) - w0 - slope * q[0]) / ei
            dv = (sum(dw(q[0], *bl) for bl in beam_loads) - slope) / ei
            shift.append(np.stack([-q[1] * dv, v], axis=-1))
        d_a1, d_b1, d_next1 = shift
        dphi = cross(tilt0, np.broadcast_to([0.0, -p], (rows, 2))) / k_base
        # the exact closure, base to tip
        piv = ar["pivot"]
        o_new = piv + rot(dphi, ar["O1"] - piv)
        b_new = piv + rot(dphi, ar["B0"] - piv)
        a_prev = None
        for i in range(n):
            if i > 0:
                nxt = ar["next"][i - 1] + (d_next1 if i - 1 == 0 else 0.0)
                bb = ar["B"][i - 1] + (d_b1 if i - 1 == 0 else 0.0)
                o_prev = o_new
                o_new = o_prev + rot(a_prev, nxt) + (off3 if i == 2 else 0.0)
                b_new = o_prev + rot(a_prev, bb)
            a_loc = ar["A"][i] + (d_a1 if i == 0 else np.zeros(2))
            rho = np.hypot(*np.broadcast_to(a_loc, (rows, 2)).T)
            dvec = b_new - o_new
            dd = np.hypot(*dvec.T)
            side = np.sign(cross(b[i] - o[i], a[i] - o[i]))
            cos_t = (rho * rho + dd * dd - new_len[i] ** 2) / (2.0 * rho * dd)
            ang = np.arctan2(dvec[:, 1], dvec[:, 0]) + side * np.arccos(cos_t)
            al = ang - np.arctan2(*np.broadcast_to(a_loc, (rows, 2))[:, ::-1].T)
            a_prev = alpha[:, i] + (al - alpha[:, i] + np.pi) % (2 * np.pi) - np.pi
        m_new = o_new + rot(a_prev, ar["measure"])
        out["dx_mm"][:, s], out["dy_mm"][:, s] = (m_new - measure0).T
        out["dl_mm"][:, s] = np.stack(dl, axis=-1)
    return out


def best(fn: Callable[[], object], budget: float = 1.0) -> float:
    times: list[float] = []
    start = time.perf_counter()
    while not times or (time.perf_counter() - start < budget and len(times) < 20):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sequences", type=int, default=100_000)
    args = ap.parse_args()
    arm = eodarm.Arm.from_toml(ARM_FILE)
    rng = np.random.default_rng(7)
    alpha = np.array([90.0, 10.0, 0.0]) + rng.uniform(-5.0, 5.0, (args.sequences, 3))
    check = slice(0, 500)
    core = eodarm.solve_sequence(arm, alpha[check], MASSES, EFFECTS)
    mine = numpy_sequence(arm, alpha[check], MASSES)
    diff = max(float(np.abs(core[k] - mine[k]).max()) for k in ("dx_mm", "dy_mm", "dl_mm"))
    if diff > 1e-9:
        raise SystemExit(f"the numpy version differs from solve_sequence by {diff:.3g} mm")
    states = args.sequences * MASSES.size
    t_rust = best(lambda: eodarm.solve_sequence(arm, alpha, MASSES, EFFECTS))
    t_np = best(lambda: numpy_sequence(arm, alpha, MASSES))
    frictionless = [e for e in EFFECTS if not e.name.endswith("_friction")]
    t_free = best(lambda: eodarm.solve_sequence(arm, alpha, MASSES, frictionless))
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores")
    print(f"{args.sequences:,} sequences × {MASSES.size} states, every effect kind (8)")
    print(f"numpy version agrees with solve_sequence to {diff:.2g} mm")
    print(f"solve_sequence (rust): {t_rust:8.3f} s  {states / t_rust / 1e6:7.2f} M states/s")
    print(f"numpy version:         {t_np:8.3f} s  {states / t_np / 1e6:7.2f} M states/s")
    print(f"speed-up: {t_np / t_rust:.1f}×")
    print(
        f"without the two frictions (block kernel): {t_free:8.3f} s  "
        f"{states / t_free / 1e6:7.2f} M states/s"
    )


if __name__ == "__main__":
    main()
