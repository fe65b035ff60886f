"""Three different arms for the diagnosis tests: the contract's example arm, an arm with the
seed paper's Table 1 geometry (B0 assumed), and a 2-link arm; and a 4-link arm (not in
``ARMS``) for what needs a joint more than the conditions, such as compensation."""

from __future__ import annotations

from pathlib import Path

import eodarm

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def example_arm() -> eodarm.Arm:
    return eodarm.Arm.from_toml(EXAMPLES / "example_arm.toml")


def seed_like_arm() -> eodarm.Arm:
    """Table 1 of the seed paper as printed (B2 read as (-128, 0)); B0 and masses assumed."""
    return eodarm.Arm.from_dict(
        {
            "name": "seed-like",
            "base": {"O1": [0.0, 0.0], "B0": [-120.0, -130.0]},
            "link": [
                {
                    "next": [500.0, 0.0],
                    "A": [80.94, 65.0],
                    "B": [-50.0, -44.0],
                    "C": [230.12, -2.4],
                    "mass_kg": 4.0,
                },
                {
                    "next": [400.0, 0.0],
                    "A": [90.5, -51.0],
                    "B": [-128.0, 0.0],
                    "C": [165.5, -1.3],
                    "mass_kg": 3.0,
                },
                {
                    "next": [400.0, 0.0],
                    "A": [44.8, -31.4],
                    "C": [230.12, -2.4],
                    "measure": [300.0, -44.0],
                    "mass_kg": 2.0,
                },
            ],
            "actuator": [
                {"stiffness_n_per_mm": 4000.0, "mass_kg": 1.5},
                {"stiffness_n_per_mm": 3500.0, "mass_kg": 1.2},
                {"stiffness_n_per_mm": 3000.0, "mass_kg": 1.0},
            ],
        },
        source="seed-like",
    )


def two_link_arm() -> eodarm.Arm:
    return eodarm.Arm.from_dict(
        {
            "name": "two-link",
            "base": {"O1": [0.0, 0.0], "B0": [180.0, -60.0], "pivot": [-150.0, -200.0]},
            "link": [
                {
                    "next": [600.0, 20.0],
                    "A": [120.0, 50.0],
                    "B": [-60.0, -40.0],
                    "C": [280.0, 0.0],
                    "mass_kg": 5.0,
                },
                {
                    "next": [450.0, 0.0],
                    "A": [100.0, -45.0],
                    "C": [200.0, -5.0],
                    "measure": [420.0, -30.0],
                    "mass_kg": 2.5,
                },
            ],
            "actuator": [
                {"stiffness_n_per_mm": 5000.0, "mass_kg": 2.0},
                {"stiffness_n_per_mm": 2500.0, "mass_kg": 1.0},
            ],
        },
        source="two-link",
    )


def four_link_core_arm() -> eodarm.Arm:
    """Four links: one more than a point and an angle need (the core's compensation tests use
    the same; ``four_link_arm`` below is the diagnosis tests' 4-link arm)."""
    return eodarm.Arm.from_dict(
        {
            "name": "four-link",
            "base": {"O1": [0.0, 0.0], "B0": [220.0, -50.0], "pivot": [-200.0, -250.0]},
            "link": [
                {
                    "next": [450.0, 0.0],
                    "A": [100.0, 50.0],
                    "B": [-50.0, -45.0],
                    "C": [200.0, -3.0],
                    "mass_kg": 4.0,
                },
                {
                    "next": [350.0, 0.0],
                    "A": [90.0, -50.0],
                    "B": [-100.0, 10.0],
                    "C": [160.0, -2.0],
                    "mass_kg": 2.5,
                },
                {
                    "next": [300.0, 0.0],
                    "A": [70.0, -45.0],
                    "B": [-80.0, 15.0],
                    "C": [140.0, -2.0],
                    "mass_kg": 1.8,
                },
                {
                    "next": [250.0, 0.0],
                    "A": [50.0, -35.0],
                    "C": [120.0, -2.0],
                    "measure": [220.0, -30.0],
                    "mass_kg": 1.0,
                },
            ],
            "actuator": [
                {"stiffness_n_per_mm": 3000.0, "mass_kg": 1.5},
                {"stiffness_n_per_mm": 2500.0, "mass_kg": 1.2},
                {"stiffness_n_per_mm": 2000.0, "mass_kg": 0.9},
                {"stiffness_n_per_mm": 1500.0, "mass_kg": 0.7},
            ],
        },
        source="four-link",
    )


ARMS = {"example": example_arm, "seed-like": seed_like_arm, "two-link": two_link_arm}


def four_link_arm() -> eodarm.Arm:
    """A 4-link arm (not in ARMS: the catalogue's diagnosis tests run on the three above)."""
    return eodarm.Arm.from_dict(
        {
            "name": "four-link",
            "base": {"O1": [0.0, 0.0], "B0": [200.0, -60.0]},
            "link": [
                {
                    "next": [450.0, 0.0],
                    "A": [100.0, 50.0],
                    "B": [-50.0, -40.0],
                    "C": [200.0, 0.0],
                    "mass_kg": 4.0,
                },
                {
                    "next": [380.0, 0.0],
                    "A": [90.0, -50.0],
                    "B": [-100.0, 10.0],
                    "C": [170.0, 0.0],
                    "mass_kg": 3.0,
                },
                {
                    "next": [300.0, 0.0],
                    "A": [70.0, -40.0],
                    "B": [-80.0, 10.0],
                    "C": [150.0, 0.0],
                    "mass_kg": 2.0,
                },
                {
                    "next": [250.0, 0.0],
                    "A": [50.0, -35.0],
                    "C": [120.0, -2.0],
                    "mass_kg": 1.2,
                },
            ],
            "actuator": [
                {"stiffness_n_per_mm": 5000.0, "mass_kg": 1.5},
                {"stiffness_n_per_mm": 4000.0, "mass_kg": 1.2},
                {"stiffness_n_per_mm": 3000.0, "mass_kg": 1.0},
                {"stiffness_n_per_mm": 2000.0, "mass_kg": 0.8},
            ],
        },
        source="four-link",
    )
