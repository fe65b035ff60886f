"""Render the FE figures of docs/fem.md: the bundled seed arm (configuration 1) and the
rotary example arm, and the comparison of the FE and analytic models on arms with drives.

Usage: python scripts/fem_figures.py [OUT_DIR]   (default: docs/figures)

The seed paper's FEM (its section 5, Figures 14-18) loads configuration 1 with 15 N at the
effector. Here the seed2022 arm is given aluminium-profile sections (so its links bend) and
a mount compliance at M2 (so a mount gives), and solved with model="fem". The rotary example
(examples/rotary_arm.toml: three motor + gearbox drives, its tube sections) is solved at one
pose under 5 kg; the comparison sweeps the payload on it and on examples/mixed_arm.toml.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import eodarm
from eodarm.data import datasets
from eodarm.viz import fem_plots

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "figures"
#: The rotary example at a reaching pose (q = 45°, −35°, −30°) and the mixed one.
ROTARY = ROOT / "examples" / "rotary_arm.toml"
ROTARY_ALPHA = [45.0, 10.0, -20.0]
ROTARY_KG = 5.0
MIXED = ROOT / "examples" / "mixed_arm.toml"
MIXED_ALPHA = [60.0, -10.0, -60.0]

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
    rotary(out)
    comparison(out)


def file_bending(arm: eodarm.Arm) -> list[eodarm.Effect]:
    """The arm file's sections as link_bending: the analytic model's view of them."""
    return [
        eodarm.Effect("link_bending", f"L{i + 1}", ei_n_mm2=lk.ei_n_mm2)
        for i, lk in enumerate(arm.links)
        if lk.ei_n_mm2 is not None
    ]


def rotary(out: Path) -> None:
    """The rotary example's shape, moments and pin forces and torques (FE, 16 elements)."""
    arm = eodarm.Arm.from_toml(ROTARY)
    res = eodarm.solve(
        arm, [ROTARY_ALPHA], ROTARY_KG, model="fem", fem_options={"elements_per_link": 16}
    )
    pose = ", ".join(f"{a:g}" for a in ROTARY_ALPHA).replace("-", "−")
    head = f"rotary example (α = {pose}°), {ROTARY_KG:g} kg"
    fem_plots.deformed_shape(
        arm,
        res,
        title=f"{head}: displacement (FE, {res['n_dof']} DOF)",
        path=out / "fem-rotary-deformed-shape.png",
    )
    fem_plots.moment_diagrams(
        arm, res, title=f"{head}: bending moment (FE)", path=out / "fem-rotary-moments.png"
    )
    fem_plots.pin_forces(
        arm,
        res,
        title=f"{head} + self-weight: pin forces and drive torques on the links",
        path=out / "fem-rotary-pin-forces.png",
    )
    t = ", ".join(f"{v / 1000:.1f}" for v in res["torque_nmm"][0])
    print(f"rotary: dx = {res['dx_mm'][0]:.4f} mm, dy = {res['dy_mm'][0]:.4f} mm, T = {t} N·m")


def comparison(out: Path) -> None:
    """FE against analytic on the rotary and mixed examples as the payload grows: the
    measure point's sag and the relative difference of every channel (second order)."""
    from eodarm.viz.style import PALETTE, figure, finish

    kg = np.geomspace(0.01, 20.0, 23)
    fig = figure(10.0, 4.2)
    sag, rel = fig.subplots(1, 2)
    for colour, (path, alpha) in zip(
        PALETTE, ((ROTARY, ROTARY_ALPHA), (MIXED, MIXED_ALPHA)), strict=False
    ):
        arm = eodarm.Arm.from_toml(path)
        effects = file_bending(arm)
        poses = np.tile(alpha, (kg.size, 1))
        an = eodarm.solve(arm, poses, kg, effects=effects)
        fe = eodarm.solve(arm, poses, kg, effects=effects, model="fem")
        sag.plot(kg, -an["dy_mm"], color=colour, lw=2.0, label=f"{arm.name}: analytic")
        sag.plot(kg, -fe["dy_mm"], color=colour, lw=1.4, ls="--", marker=".", label="FE")
        diff = np.zeros(kg.size)
        for keys in (("dx_mm", "dy_mm"), ("dalpha_deg",), ("dl_mm",)):
            a = np.column_stack([np.asarray(an[k]).reshape(kg.size, -1) for k in keys])
            f = np.column_stack([np.asarray(fe[k]).reshape(kg.size, -1) for k in keys])
            if np.isnan(a).all():
                continue
            # each pose's group difference over that pose's analytic group
            group = np.nanmax(np.abs(f - a), axis=1) / np.nanmax(np.abs(a), axis=1)
            diff = np.maximum(diff, group)
        rel.loglog(kg, diff, color=colour, lw=2.0, marker=".", label=arm.name)
    rel.loglog(kg, 1e-4 * kg, color="0.5", lw=1.0, ls=":", label="∝ payload")
    sag.set_xlabel("payload [kg]")
    sag.set_ylabel("sag −dy of the measure point [mm]")
    sag.legend(fontsize="small")
    sag.grid(True, lw=0.4, alpha=0.4)
    rel.set_xlabel("payload [kg]")
    rel.set_ylabel("largest relative difference FE − analytic")
    rel.legend(fontsize="small")
    rel.grid(True, which="both", lw=0.4, alpha=0.4)
    fig.suptitle(
        "FE (linear, drives as torsional springs) against the analytic model (exact pose)",
        fontsize="medium",
    )
    finish(fig, out / "fem-rotary-comparison.png")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT)
