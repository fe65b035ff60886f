"""sweep(..., cycle=True) against the plain sweep on the same grid (docs/benchmarks.md).

The example arm, 121 × 141 × 11 poses × 4 payloads (750 684 cells), best of 3, for four
models: the baseline, an elastic one, one with a gap and one with both frictions.

    python benches/bench_cycle.py
"""

import time
from pathlib import Path

import numpy as np

import eodarm

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
arm = eodarm.Arm.from_toml(EXAMPLE)
grid = {
    "alpha1": np.linspace(60, 120, 121),
    "alpha2": np.linspace(-30, 40, 141),
    "alpha3": np.linspace(-5, 5, 11),
}
mass = [1.5, 3.0, 5.0, 6.5]
for label, eff in [
    ("baseline", None),
    ("elastic", [eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=4000.0)]),
    ("play", [eodarm.Effect("actuator_play", "M2", play_mm=0.05)]),
    (
        "frictions",
        [
            eodarm.Effect("actuator_friction", "M2", friction_n=60.0),
            eodarm.Effect("joint_friction", "O3", torque_nmm=4000.0),
        ],
    ),
]:
    best = {}
    for cyc in (False, True):
        ts = []
        for _ in range(3):
            t = time.perf_counter()
            ds = eodarm.sweep(
                arm, alpha_deg=grid, mass_kg=mass, effects=eff, cycle=cyc, progress=False
            )
            ts.append(time.perf_counter() - t)
        best[cyc] = min(ts)
    cells = 121 * 141 * 11 * 4
    plain, cyc = cells / best[False] / 1e6, cells / best[True] / 1e6
    print(f"{label:10s} plain {plain:6.1f} M cells/s  cycle {cyc:6.1f} M cells/s", end="")
    print(f"  ratio {best[False] / best[True]:.2f}")
