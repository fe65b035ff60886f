"""How the cost of the analysis grows, and where the time goes at each size.

Usage: python benches/bench_scaling.py [--quick] [--only links|states|jacobian|candidates]
       [--markdown FILE]

(``OPENBLAS_NUM_THREADS=1`` as the command line sets it; unset, numpy's BLAS uses every core.)

Four studies, each a table (wall time of one call, the median of ``--repeat`` runs after a
warm-up; in all but the Jacobian's, then one run under cProfile whose own time is split by
where it is spent):

1. **links**: arms of 1–6 links (:func:`chain_arm`, a regular chain in the proportions of
   the seed arm), 16 configurations × 4 payloads with a mount spring hidden in actuator 1,
   all channels: one ``solve`` of the 64 states, a ``fit`` of that one effect, and the whole
   ``diagnose`` (every candidate, sets of up to three);
2. **states**: ``diagnose`` of the seed2022 arm on 15, 150, 1 500 and 10 000 synthetic states
   (7 channels as the seed's, two effects hidden): configurations × 3 payloads up to
   :data:`MAX_CONFIGS` configurations, then more payloads per configuration. The judgement of
   a set fits it once per left-out configuration, so with configurations growing as the states
   the cost would grow as their square (1 500 states in 500 configurations: 78 s, 87 % of it
   in that cross-validation);
3. **jacobian**: on the states of study 2, the core's Jacobian alone (``Problem.evaluate``
   with the 6 body and mount springs as probes, what ``fit`` and ``diagnose`` call), in µs
   per state, and a ``fit`` of the two hidden effects;
4. **candidates**: ``diagnose`` of the seed2022 arm on 48 states with the first 4, 8, 16 and
   all 22 catalogue candidates, then the 22 plus the 3 of a user-written effect
   (``examples/contact_mount.py``, whose Jacobian columns are forward differences).

The profile splits the call's own time into: the compiled core (``eodarm._core``: the model
and its Jacobian), numpy's linear algebra, the rest of numpy, eodarm's Python, and the rest.
cProfile inflates Python-heavy parts (each Python call costs more under it), so the shares are
an upper bound for Python and a lower bound for the core.
"""

from __future__ import annotations

import argparse
import cProfile
import datetime
import os
import platform
import pstats
import runpy
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import eodarm
from eodarm.analysis.diagnose import all_slots, diagnose
from eodarm.analysis.fit import Problem, fit
from eodarm.analysis.synth import random_configs, synth
from eodarm.data.datasets import bundled_arm
from machine import cpu_model  # benches/ is the script's directory

ROOT = Path(__file__).resolve().parent.parent
MASSES = [1.5, 3.0, 5.0, 6.5]
#: At most this many configurations in the states study (payloads grow beyond).
MAX_CONFIGS = 100
#: Hidden in the seed arm's synthetic states: two effects, so that the search goes on to sets.
HIDDEN = [
    eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=2000.0),
    eodarm.Effect("joint_clearance", "O2", clearance_mm=0.15),
]
HIDDEN_KEYS = ["mount_compliance@M1", "joint_clearance@O2"]


def chain_arm(n: int) -> eodarm.Arm:
    """An n-link arm: link k of length 500·0.85ᵏ mm, each actuator from the previous link's
    pin B (the chassis' B0 for the first) to this link's pin A; masses and springs falling
    along the chain. The geometry of the seed arm, repeated."""
    links: list[dict[str, Any]] = []
    for k in range(n):
        s = 0.85**k
        link: dict[str, Any] = {
            "next": [500.0 * s, 0.0],
            "A": [90.0 * s, 55.0 * s if k == 0 else -50.0 * s],
            "C": [220.0 * s, -2.0],
            "mass_kg": 4.0 * s,
        }
        if k < n - 1:
            link["B"] = [-70.0 * s, 20.0 * s if k else -44.0]
        else:
            link["measure"] = [300.0 * s, -40.0 * s]
        links.append(link)
    actuators = [
        {"stiffness_n_per_mm": 4000.0 * 0.85**k, "mass_kg": 1.5 * 0.85**k} for k in range(n)
    ]
    return eodarm.Arm.from_dict(
        {
            "name": f"chain-{n}",
            "base": {"O1": [0.0, 0.0], "B0": [-120.0, -130.0]},
            "link": links,
            "actuator": actuators,
        },
        source=f"chain-{n}",
    )


def configs(arm: eodarm.Arm, k: int, seed: int) -> Any:
    """Random configurations with moment arms ≥ 35 % (not the default 20 %): near a
    triangle's edge the seed arm's soft springs (and, with 6 links, a candidate's trial value)
    push a loaded state past it, and the solve stops there."""
    return random_configs(arm, k, np.random.default_rng(seed), min_moment_ratio=0.35)


def timed(call: Callable[[], Any], repeat: int) -> float:
    call()  # warm-up
    return statistics.median(_once(call) for _ in range(repeat))


def _once(call: Callable[[], Any]) -> float:
    t0 = time.perf_counter()
    call()
    return time.perf_counter() - t0


def where(call: Callable[[], Any]) -> dict[str, float]:
    """Shares of the call's time (under cProfile) by where it is spent."""
    prof = cProfile.Profile()
    prof.enable()
    call()
    prof.disable()
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    parts = {"core": 0.0, "numpy.linalg": 0.0, "numpy": 0.0, "eodarm py": 0.0, "other": 0.0}
    for (file, _line, func), (_cc, _nc, tt, _ct, _callers) in stats.items():
        if "eodarm._core" in func:  # the compiled core's functions (built-ins)
            parts["core"] += tt
        elif "linalg" in file or "linalg" in func:
            parts["numpy.linalg"] += tt
        elif "numpy" in file or "numpy" in func:
            parts["numpy"] += tt
        elif "eodarm" in file:
            parts["eodarm py"] += tt
        else:
            parts["other"] += tt
    total = sum(parts.values()) or 1.0
    py = [
        (tt, func) for (file, _l, func), (_c, _n, tt, _ct, _cl) in stats.items() if "eodarm" in file
    ]
    top = max(py, default=(0.0, "—"))
    out = {k: v / total for k, v in parts.items()}
    out["top"] = top[0] / total
    TOP[0] = f"{top[1]} {100 * top[0] / total:.0f} %"
    return out


#: The eodarm Python function with the most own time in the last profile.
TOP = ["—"]


def shares(p: dict[str, float]) -> str:
    cells = [f"{100 * v:.0f} %" for k, v in p.items() if k != "top"]
    return " | ".join([*cells, f"`{TOP[0]}`"])


SHARE_HEAD = "core | np.linalg | numpy | eodarm py | other | largest eodarm function"


def study_links(repeat: int, quick: bool) -> list[str]:
    out = [
        "| links | candidates | solve 64 states ms | fit 1 effect ms | diagnose s | "
        + SHARE_HEAD
        + " |",
        "|---:|---:|---:|---:|---:|" + "---:|" * 5 + "---|",
    ]
    for n in range(1, 7) if not quick else (1, 3, 6):
        arm = chain_arm(n)
        cfg = configs(arm, 16, n)
        hidden = [eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=2500.0)]
        meas = synth(arm, cfg, MASSES, hidden=hidden, seed=n)
        alpha = np.repeat(cfg, len(MASSES), axis=0)
        mass = np.tile(MASSES, len(cfg))
        t_solve = timed(lambda: eodarm.solve(arm, alpha, mass), repeat)  # noqa: B023
        t_fit = timed(lambda: fit(arm, meas, ["mount_compliance@M1"]), repeat)  # noqa: B023
        t_diag = timed(lambda: diagnose(arm, meas), max(1, repeat // 2))  # noqa: B023
        p = where(lambda: diagnose(arm, meas))  # noqa: B023
        out.append(
            f"| {n} | {len(all_slots(n))} | {1e3 * t_solve:.2f} | {1e3 * t_fit:.1f} | "
            f"{t_diag:.3f} | {shares(p)} |"
        )
        print(out[-1], flush=True)
    return out


def study_states(repeat: int, quick: bool) -> list[str]:
    arm = bundled_arm("seed2022")
    out = [
        "| states | values | diagnose s | per state ms | " + SHARE_HEAD + " |",
        "|---:|---:|---:|---:|" + "---:|" * 5 + "---|",
    ]
    for states in (15, 150, 1500) if quick else (15, 150, 1500, 10_000):
        meas = seed_states(arm, states)
        reps = repeat if states <= 1500 else 1
        t = timed(lambda: diagnose(arm, meas), reps)  # noqa: B023
        p = where(lambda: diagnose(arm, meas))  # noqa: B023
        out.append(
            f"| {meas.n_rows} | {meas.n_values} | {t:.3f} | {1e3 * t / meas.n_rows:.2f} | "
            f"{shares(p)} |"
        )
        print(out[-1], flush=True)
    return out


def seed_states(arm: eodarm.Arm, states: int) -> Any:
    """Synthetic states of the seed arm with :data:`HIDDEN`, the seed's 7 channels:
    configurations × 3 payloads up to :data:`MAX_CONFIGS` configurations, then more
    payloads per configuration (see the docstring)."""
    k = min(-(-states // 3), MAX_CONFIGS)
    masses = np.linspace(1.0, 7.0, -(-states // k)) if states > 3 * k else [1.5, 5.0, 6.5]
    cfg = configs(arm, k, states)
    meas = synth(arm, cfg, masses, hidden=HIDDEN, channels=["dy", "dalpha", "dl"], seed=1)
    if meas.n_rows > states:
        meas = meas.subset(np.arange(meas.n_rows) < states)
    print(f"  {meas.n_rows} states in {k} configurations × {len(masses)} payloads", flush=True)
    return meas


def study_jacobian(repeat: int, quick: bool) -> list[str]:
    """The Jacobian alone and a fit, on the states of :func:`study_states`."""
    arm = bundled_arm("seed2022")
    probes = all_slots(arm.n, custom=False)[:6]  # body and mount springs of the 3 actuators
    out = [
        "| states | Jacobian, 6 probes, µs per state | fit of the 2 hidden effects s |",
        "|---:|---:|---:|",
    ]
    for states in (15, 150, 1500) if quick else (15, 150, 1500, 10_000):
        meas = seed_states(arm, states)
        prob = Problem(arm, meas)
        reps = max(repeat, 3 if states >= 1500 else 20)
        t_jac = timed(lambda: prob.evaluate([], probes), reps)  # noqa: B023
        t_fit = timed(lambda: fit(arm, meas, HIDDEN_KEYS), repeat)  # noqa: B023
        out.append(f"| {meas.n_rows} | {1e6 * t_jac / meas.n_rows:.2f} | {t_fit:.3f} |")
        print(out[-1], flush=True)
    return out


def study_candidates(repeat: int) -> list[str]:
    arm = bundled_arm("seed2022")
    cfg = configs(arm, 16, 7)
    meas = synth(arm, cfg, [1.5, 5.0, 6.5], hidden=HIDDEN, channels=["dy", "dalpha", "dl"], seed=2)
    out = [
        "| candidates | sets of ≤ 3 | diagnose s | " + SHARE_HEAD + " |",
        "|---:|---:|---:|" + "---:|" * 5 + "---|",
    ]
    catalogue = all_slots(arm.n, custom=False)
    cases: list[tuple[str, list[Any]]] = [
        (str(k), catalogue[:k]) for k in (4, 8, 16) if k < len(catalogue)
    ]
    cases.append((f"{len(catalogue)} (catalogue)", catalogue))
    runpy.run_path(str(ROOT / "examples" / "contact_mount.py"), run_name="contact")
    every = all_slots(arm.n)
    cases.append((f"{len(every)} (+ user-written contact mount)", every))
    for label, cands in cases:
        c = len(cands)
        sets = c + c * (c - 1) // 2 + c * (c - 1) * (c - 2) // 6
        t = timed(lambda: diagnose(arm, meas, candidates=cands), repeat)  # noqa: B023
        p = where(lambda: diagnose(arm, meas, candidates=cands))  # noqa: B023
        out.append(f"| {label} | {sets} | {t:.3f} | {shares(p)} |")
        print(out[-1], flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="fewer sizes")
    ap.add_argument("--markdown", type=Path)
    ap.add_argument(
        "--only", choices=("links", "states", "jacobian", "candidates"), help="one study"
    )
    args = ap.parse_args()
    load0 = os.getloadavg()[0]
    parts: list[str] = []
    if args.only in (None, "links"):
        parts += ["### Links", *study_links(args.repeat, args.quick), ""]
    if args.only in (None, "states"):
        parts += ["### States", *study_states(args.repeat, args.quick), ""]
    if args.only in (None, "jacobian"):
        parts += ["### Jacobian and fit", *study_jacobian(args.repeat, args.quick), ""]
    if args.only in (None, "candidates"):
        parts += ["### Candidates", *study_candidates(args.repeat)]
    head = (
        f"{datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC, {cpu_model()}, "
        f"{os.cpu_count()} logical CPUs, Python {platform.python_version()}, load average "
        f"{load0:.2f} before / {os.getloadavg()[0]:.2f} after, median of {args.repeat}, "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}"
    )
    text = "\n".join([head, "", *parts])
    print(text)
    if args.markdown:
        args.markdown.write_text(text + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
