"""The three kinds of sweep grid at 1e6 poses: angles, actuator lengths, effector targets.

``eodarm.sweep`` on the example arm, baseline model, one payload (5 kg), every output, on
100 × 100 × 100 grids of

* **angles** α1 60–110°, α2 0–30°, α3 −10–10° (one call of the core, which walks the grid);
* **lengths** l1 250–330, l2 480–600, l3 480–540 mm (chunks of 65 536 poses from Python:
  ``angles_from_lengths`` in the core, then the sweep kernel, then a copy into the result);
* **effector targets** x 500–900, y 200–700 mm, φ −20–20° (chunks from Python: inverse
  kinematics in the core, then the sweep kernel).

Each figure is the best of k ≥ 3 calls within about two seconds. Run from the repository
root, with the package installed::

    python3 benches/bench_sweep_grids.py
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import eodarm
from bench_solve import best_time
from bench_sweep import ARM_FILE, MASS

GRIDS = {
    "angles": {
        "alpha_deg": {
            "alpha1": np.linspace(60, 110, 100),
            "alpha2": np.linspace(0, 30, 100),
            "alpha3": np.linspace(-10, 10, 100),
        }
    },
    "lengths": {
        "lengths": {
            "l1": np.linspace(250, 330, 100),
            "l2": np.linspace(480, 600, 100),
            "l3": np.linspace(480, 540, 100),
        }
    },
    "effector targets": {
        "effector": {
            "x": np.linspace(500, 900, 100),
            "y": np.linspace(200, 700, 100),
            "phi": np.linspace(-20, 20, 100),
        }
    },
}


def main() -> int:
    arm = eodarm.Arm.from_toml(ARM_FILE)
    print("| grid | poses | time (s) | poses/s | poses solved |")
    print("|---|---:|---:|---:|---:|")
    for name, grid in GRIDS.items():

        def call(grid: dict[str, object] = grid) -> Any:
            return eodarm.sweep(arm, mass_kg=[MASS], progress=False, **grid)

        ds = call()
        t = best_time(call, 2.0, 3)
        print(
            f"| {name} | 1,000,000 | {t:.3f} | {1e6 / t:,.0f} | {float(ds['ok'].mean()):.1%} |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
