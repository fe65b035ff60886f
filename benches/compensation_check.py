"""The independent check of compensation (issue 12): fit, compensate unseen poses, miss less.

Usage: python benches/compensation_check.py [--diagnose] [--held 200] [--seed 0]
                                            [--markdown FILE]

For arms of 2, 3 and 4 links (tests/arms.py) with one or two hidden effects, each case:

1. measures 16 random configurations x 4 payloads (1.5, 3, 5, 6.5 kg) of the TRUE arm (the
   hidden effects; ``eodarm.analysis.synth.synth``, default noise: 0.02 mm, 0.02 deg,
   0.002 mm);
2. fits the model: ``eodarm.fit`` with the hidden effects' slots (or, with ``--diagnose``,
   with the set ``eodarm.diagnose`` suggests, so the check does not know the truth);
3. draws 200 held-out poses that the fit never saw, each with a payload uniform in
   0.5-7 kg, and compensates them with the FITTED model (``eodarm.compensate``);
4. solves the compensated poses with the TRUE arm and measures how far the loaded measure
   point misses the nominal one; the uncompensated miss is that of the nominal poses under
   the true arm. For comparison, the poses are also compensated with the model before the
   fit (the arm file alone: the hidden effects unknown).

Target: compensated miss <= 2 % of the uncompensated miss, as RMS and as maximum over the
held-out poses. Poses that cannot be compensated (status not ok) are counted and left out.
Exit status 1 when a case misses the target.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

import eodarm
from arms import example_arm, four_link_arm, two_link_arm
from eodarm.analysis.synth import random_configs, synth
from eodarm.model.effects import Slot

MASSES = (1.5, 3.0, 5.0, 6.5)
TARGET = 0.02

E = eodarm.Effect
#: (arm, hidden effects) of each case.
CASES: list[tuple[str, Any, list[eodarm.Effect]]] = [
    ("2 links", two_link_arm, [E("mount_compliance", "M2", stiffness_n_per_mm=1200.0)]),
    (
        "2 links",
        two_link_arm,
        [
            E("link_bending", "L1", ei_n_mm2=2e10),
            E("joint_clearance", "O2", clearance_mm=0.1, unloaded="taken_up"),
        ],
    ),
    ("3 links", example_arm, [E("joint_clearance", "O3", clearance_mm=0.15)]),
    (
        "3 links",
        example_arm,
        [
            E("mount_compliance", "M1", stiffness_n_per_mm=2500.0),
            E("joint_clearance", "O2", clearance_mm=0.15),
        ],
    ),
    (
        "3 links",
        example_arm,
        [
            E("base_compliance", "base", stiffness_nmm_per_rad=2e8),
            E("link_bending", "L2", ei_n_mm2=5e9),
        ],
    ),
    ("4 links", four_link_arm, [E("actuator_compliance", "M3", stiffness_n_per_mm=900.0)]),
    (
        "4 links",
        four_link_arm,
        [
            E("mount_compliance", "M2", stiffness_n_per_mm=1500.0),
            E("actuator_play", "M4", play_mm=0.05, unloaded="taken_up"),
        ],
    ),
]


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def held_out_miss(
    arm: eodarm.Arm,
    hidden: list[eodarm.Effect],
    fitted: list[eodarm.Effect],
    alpha: np.ndarray,
    mass: np.ndarray,
) -> dict[str, Any]:
    """Compensate ``alpha`` with the fitted model, solve with the true one, measure."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        comp = eodarm.compensate(arm, alpha, mass, effects=fitted)
    ok = comp["status"] == "ok"
    nominal = eodarm.forward(arm, alpha)["measure"]
    before = eodarm.solve(arm, alpha, mass, effects=hidden)
    miss0 = np.hypot(before["dx_mm"], before["dy_mm"])
    after = eodarm.solve(arm, comp["alpha_deg"][ok], mass[ok], effects=hidden)
    landed = eodarm.forward(arm, comp["alpha_deg"][ok])["measure"]
    landed = landed + np.column_stack([after["dx_mm"], after["dy_mm"]])
    miss = np.linalg.norm(landed - nominal[ok], axis=1)
    return {
        "miss0": miss0[ok],
        "miss": miss,
        "failed": int((~ok).sum()),
        "iterations": comp["iterations"][ok],
        "notes": [str(w.message) for w in caught],
    }


def run_case(
    arm: eodarm.Arm, hidden: list[eodarm.Effect], held: int, seed: int, use_diagnose: bool
) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    configs = random_configs(arm, 16, rng)
    meas = synth(arm, configs, MASSES, hidden=hidden, seed=seed + 1)
    if use_diagnose:
        d = eodarm.diagnose(arm, meas, advise=False)
        slots = list(d.suggested)
    else:
        slots = [Slot.of(e) for e in hidden]
    res = eodarm.fit(arm, meas, slots)
    fitted = res.effects
    alpha = random_configs(arm, held, rng)
    mass = rng.uniform(0.5, 7.0, held)
    out = held_out_miss(arm, hidden, fitted, alpha, mass)
    # What compensating with the model before the fit (the arm file alone) would leave.
    out["plain"] = held_out_miss(arm, hidden, [], alpha, mass)["miss"]
    out["fitted"] = fitted
    out["slots"] = slots
    return out


def fmt_effects(effects: list[eodarm.Effect]) -> str:
    parts = []
    for e in effects:
        mode = ", taken up" if e.unloaded == "taken_up" else ""
        parts.append(f"{e.key} {e.value:.4g}{mode}")
    return "; ".join(parts)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--diagnose", action="store_true", help="fit the diagnosed set")
    ap.add_argument("--held", type=int, default=200, help="held-out poses per case")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--markdown", type=Path, help="also write the table to FILE")
    args = ap.parse_args()
    head = (
        "| arm | hidden (true value) | fitted | uncompensated RMS / max (mm) "
        "| compensated, unfitted model: RMS / max (mm) "
        "| compensated, fitted model: RMS / max (mm) | ratio RMS / max | steps (median / max) "
        "| not ok |"
    )
    lines = [head, "|" + "---|" * 9]
    worst = 0.0
    t0 = time.perf_counter()
    for k, (label, make, hidden) in enumerate(CASES):
        arm = make()
        r = run_case(arm, hidden, args.held, args.seed + 100 * k, args.diagnose)
        m0, m = r["miss0"], r["miss"]
        ratio_rms = rms(m) / rms(m0)
        ratio_max = float(m.max() / m0.max())
        worst = max(worst, ratio_rms, ratio_max)
        it = r["iterations"]
        lines.append(
            f"| {label} | {fmt_effects(hidden)} | {fmt_effects(r['fitted'])} "
            f"| {rms(m0):.3f} / {m0.max():.3f} "
            f"| {rms(r['plain']):.3f} / {r['plain'].max():.3f} "
            f"| {rms(m):.4f} / {m.max():.4f} "
            f"| {100 * ratio_rms:.2f} % / {100 * ratio_max:.2f} % "
            f"| {int(np.median(it))} / {int(it.max())} | {r['failed']} |"
        )
        for note in r["notes"]:
            print(f"  note ({label}): {note}", file=sys.stderr)
    elapsed = time.perf_counter() - t0
    text = "\n".join(lines)
    print(text)
    verdict = "PASS" if worst <= TARGET else "FAIL"
    mode = "diagnosed set" if args.diagnose else "hidden effects' slots"
    print(
        f"\n{verdict}: worst ratio {100 * worst:.2f} % (target {100 * TARGET:g} %), fit on the "
        f"{mode}, {args.held} held-out poses per case, seed {args.seed}, {elapsed:.1f} s"
    )
    if args.markdown:
        args.markdown.write_text(text + "\n", encoding="utf-8")
    return 0 if worst <= TARGET else 1


if __name__ == "__main__":
    sys.exit(main())
