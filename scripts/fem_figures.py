"""Render the FE figures of docs/fem.md for the bundled seed arm (configuration 1).

Usage: python scripts/fem_figures.py [OUT_DIR]   (default: docs/figures)

The seed paper's FEM (its section 5, Figures 14-18) loads configuration 1 with 15 N at the
effector. Here the seed2022 arm is given aluminium-profile sections (so its links bend) and
a mount compliance at M2 (so a mount gives), and solved with model="fem".
"""

from __future__ import annotations

import sys
from pathlib import Path

import eodarm
from eodarm.data import datasets
from eodarm.viz import fem_plots

OUT = Path(__file__).resolve().parent.parent / "docs" / "figures"

#: Configuration 1 of the seed (Table 2, unloaded angles) and the paper's 15 N.
ALPHA = [115.6, 15.4, 0.2]
PAYLOAD_N = 15.0
#: A 40 x 40 x 3 mm aluminium box section: E = 70 GPa, I = 1.02e5 mm^4, A = 444 mm^2.
EI, EA = 7.1e9, 3.1e7


def seed_with_sections() -> eodarm.Arm:
    d = datasets.load("seed2022").arm.to_dict()
    for link in d["link"]:
        link["ei_n_mm2"] = EI
        link["ea_n"] = EA
    return eodarm.Arm.from_dict(d, source="seed2022 + sections")


def main(out: Path) -> None:
    arm = seed_with_sections()
    effects = [eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=2000.0)]
    res = eodarm.solve(
        arm,
        [ALPHA],
        PAYLOAD_N / arm.g,
        effects=effects,
        model="fem",
        fem_options={"elements_per_link": 16},
    )
    out.mkdir(parents=True, exist_ok=True)
    pose = ", ".join(f"{a:g}" for a in ALPHA)
    fem_plots.deformed_shape(
        arm,
        res,
        title=f"seed2022, configuration 1 (α = {pose}°), 15 N at the effector: "
        f"displacement (FE, {res['n_dof']} DOF)",
        path=out / "fem-deformed-shape.png",
    )
    fem_plots.moment_diagrams(
        arm,
        res,
        title="seed2022, configuration 1, 15 N: bending moment along the links (FE)",
        path=out / "fem-moments.png",
    )
    fem_plots.pin_forces(
        arm,
        res,
        title="seed2022, configuration 1, 15 N + self-weight: forces on the links at their pins",
        path=out / "fem-pin-forces.png",
    )
    print(f"dx = {res['dx_mm'][0]:.4f} mm, dy = {res['dy_mm'][0]:.4f} mm, {res['n_dof']} DOF")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT)
