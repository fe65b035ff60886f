"""Diagnose and fit on arms with rotary drives (docs/model.md §10, docs/diagnosis.md).

On the rotary and the mixed example arm, a hidden drive compliance, a backlash, a gear
friction in a load cycle and a clearance at a drive's joint are each found by ``diagnose``
(suggested, or named among the suggested effect's look-alikes when the data cannot tell them
apart) and recovered by ``fit`` within its standard error. The data come from two independent
sources: the synthetic bench (``synth``, the compiled core) and an exact per-state simulation
written in the tests (``tests/simulation.py``: the frictions stepped in Python, each state one
solve with what the frictions and gaps do given as deformations).

Seeds are fixed, so each check is deterministic. "Within its standard error" is checked at
3 standard errors (a correct fit lands there with probability 99.7 %): the friction's fit
steps over a deadband by secants, whose estimate scatters a little wider than the linearised
error says; the seeds were not chosen to make it pass.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import eodarm
from eodarm.analysis.synth import random_configs, synth
from eodarm.data.measurements import default_sigma, expand_channels
from simulation import simulate_drives

ROOT = Path(__file__).resolve().parents[1]
ROTARY = ROOT / "examples" / "rotary_arm.toml"
MIXED = ROOT / "examples" / "mixed_arm.toml"
E = eodarm.Effect
CYCLE = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]
MASSES = [1.5, 5.0, 6.5]

#: (arm file, hidden effect, measured in a load cycle). Sizes: each moves the measure point
#: by a few tenths of a mm, some ten times the default noise of dx, dy.
CASES = [
    (ROTARY, E("drive_compliance", "O2", stiffness_nmm_per_rad=8.0e6), False),
    (ROTARY, E("drive_backlash", "O2", backlash_deg=0.05), False),
    (ROTARY, E("drive_friction", "O2", torque_nmm=8000.0), True),
    (ROTARY, E("joint_clearance", "O2", clearance_mm=0.1), False),
    (MIXED, E("drive_compliance", "O1", stiffness_nmm_per_rad=3.0e7), False),
    (MIXED, E("drive_backlash", "O1", backlash_deg=0.05), False),
    (MIXED, E("drive_friction", "O1", torque_nmm=20000.0), True),
    (MIXED, E("joint_clearance", "O1", clearance_mm=0.1), False),
]
IDS = [f"{p.stem}-{e.key}" for p, e, _ in CASES]


def _configs(arm: eodarm.Arm) -> np.ndarray:
    return random_configs(arm, 8, np.random.default_rng(1))


def synth_data(arm: eodarm.Arm, hidden: eodarm.Effect, cycle: bool) -> eodarm.Measurements:
    """The synthetic bench's data: 8 configurations, default noise."""
    return synth(arm, _configs(arm), CYCLE if cycle else MASSES, [hidden], seed=3, sequence=cycle)


def simulated_data(arm: eodarm.Arm, hidden: eodarm.Effect, cycle: bool) -> eodarm.Measurements:
    """The same states measured on the exact per-state simulation, plus default noise on
    every channel the arm has (no length at a drive)."""
    rng = np.random.default_rng(7)
    channels = expand_channels(None, arm.n, arm.kinds)
    rows: dict[str, list[float]] = {c: [] for c in channels}
    config, alpha, mass, step = [], [], [], []
    for k, pose in enumerate(_configs(arm)):
        runs = [np.array(CYCLE[1:])] if cycle else [np.array([m]) for m in MASSES]
        for r, masses in enumerate(runs):
            sim = simulate_drives(arm, pose, masses, [hidden])
            for s, m in enumerate(masses):
                config.append(f"c{k + 1}" if cycle else f"c{k + 1}m{r}")
                alpha.append(pose)
                mass.append(m)
                step.append(s + 1)
                for c in channels:
                    if c in ("dx_mm", "dy_mm"):
                        v = sim[c][s]
                    else:
                        i = int(c[6:-4] if c.startswith("dalpha") else c[2:-3]) - 1
                        v = sim["dalpha_deg" if c.startswith("dalpha") else "dl_mm"][s][i]
                    rows[c].append(float(v) + default_sigma(c) * rng.standard_normal())
    return eodarm.Measurements.from_arrays(
        config,
        np.array(alpha),
        np.array(mass),
        {c: np.array(v) for c, v in rows.items()},
        sigma={c: default_sigma(c) for c in channels},
        step=np.array(step) if cycle else None,
    )


SOURCES = {"synth": synth_data, "simulation": simulated_data}


@pytest.mark.parametrize("source", list(SOURCES))
@pytest.mark.parametrize(("path", "hidden", "cycle"), CASES, ids=IDS)
def test_a_hidden_drive_effect_is_found_and_fitted(
    path: Path, hidden: eodarm.Effect, cycle: bool, source: str
) -> None:
    arm = eodarm.Arm.from_toml(path)
    meas = SOURCES[source](arm, hidden, cycle)
    d = eodarm.diagnose(arm, meas, advise=False)
    assert d.verdict == "missing"
    suggested = [s.key for s in d.suggested]
    found = set(suggested) | {k for s in suggested for k in d.alternatives.get(s, [])}
    assert hidden.key in found, (suggested, d.alternatives)
    assert len(suggested) == 1  # one effect explains it, not a set
    res = eodarm.fit(arm, meas, [hidden.key])
    assert 0.6 < res.chi2_per_dof < 1.5
    est, err = res.estimate(0), res.stderr(0)
    assert abs(est - hidden.value) <= 3.0 * err, (est, err, hidden.value)
    assert err < 0.1 * hidden.value  # determined, not merely not contradicted


@pytest.mark.parametrize("source", list(SOURCES))
@pytest.mark.parametrize("path", [ROTARY, MIXED], ids=["rotary", "mixed"])
def test_a_gear_friction_and_a_joint_friction_at_one_drive_are_named_look_alikes(
    path: Path, source: str
) -> None:
    """Without a backlash the two frictions hold the same torque at the same place: no data
    tell them apart, and diagnose says so instead of picking one as if it knew."""
    arm = eodarm.Arm.from_toml(path)
    hidden = next(h for p, h, c in CASES if p == path and h.name == "drive_friction")
    d = eodarm.diagnose(arm, SOURCES[source](arm, hidden, True), advise=False)
    twin = f"joint_friction@{hidden.at}"
    (lead,) = [s.key for s in d.suggested]
    assert {lead, *d.alternatives[lead]} >= {hidden.key, twin}
    ranked = {c.slot.key: c for c in d.ranking}
    assert twin in ranked[hidden.key].confused_with


#: A two-drive arm whose forearm carries a counterweight behind the elbow: unloaded, drive 2
#: holds it with a negative torque (about −7.8 N·m at α2 = 0); each kg at the tip adds
#: +3.9 N·m, so the torque through drive 2 changes sign between 1.5 and 5 kg.
COUNTERWEIGHTED = {
    "name": "counterweighted",
    "base": {"O1": [0.0, 0.0]},
    "link": [
        {"next": [500.0, 0.0], "C": [250.0, 0.0], "mass_kg": 3.0},
        {"next": [400.0, 0.0], "C": [-100.0, 0.0], "mass_kg": 8.0},
    ],
    "actuator": [
        {"kind": "rotary", "stiffness_nmm_per_rad": 4.0e7, "mass_kg": 2.0},
        {"kind": "rotary", "stiffness_nmm_per_rad": 4.0e6, "mass_kg": 1.0},
    ],
}


def test_a_backlash_tells_the_gear_friction_from_the_joint_friction() -> None:
    """With the drive's backlash known, where the friction sits decides the torque the
    backlash follows (docs/model.md §10): a gear friction leaves the torque through the gear
    as the statics give it, a joint friction holds part of it before the gear. Unloading to
    1.5 kg, the statics' torque is back below zero while the joint friction still holds the
    drive's positive: the backlash sits on the other side, 2b apart, and the data name the
    friction that is there."""
    d = {**COUNTERWEIGHTED, "effect": [E("drive_backlash", "O2", backlash_deg=0.1).to_table()]}
    arm = eodarm.Arm.from_dict(d)
    friction = E("drive_friction", "O2", torque_nmm=3000.0)
    poses = np.array([[a1, a1 + q2] for a1 in (20.0, 40.0) for q2 in (-40.0, -20.0, 0.0)])
    t = eodarm.solve(arm, poses, 1.5, effects=[])["torque_nmm"][:, 1]
    assert (t < 0).all()  # at 1.5 kg the statics' torque through drive 2 is still negative
    meas = synth(arm, poses, CYCLE, [friction], seed=5, sequence=True)
    diag = eodarm.diagnose(arm, meas, advise=False)
    assert [s.key for s in diag.suggested] == [friction.key]
    assert "joint_friction@O2" not in diag.alternatives.get(friction.key, [])
    ranked = {c.slot.key: c for c in diag.ranking}
    assert (
        ranked["joint_friction@O2"].fit.chi2_per_dof > 5.0 * ranked[friction.key].fit.chi2_per_dof
    )
    assert "joint_friction@O2" not in ranked[friction.key].confused_with


@pytest.mark.parametrize("path", [ROTARY, MIXED], ids=["rotary", "mixed"])
def test_each_joint_is_proposed_only_the_effects_of_its_kind(path: Path) -> None:
    from eodarm.analysis.diagnose import all_slots

    arm = eodarm.Arm.from_toml(path)
    cands = {s.key for s in all_slots(arm.n, kinds=arm.kinds)}
    meas = synth_data(arm, E("joint_clearance", "O1", clearance_mm=0.1), False)
    ranked = {c.slot.key for c in eodarm.diagnose(arm, meas, advise=False).ranking}
    assert ranked <= cands
    for i, kind in enumerate(arm.kinds, start=1):
        actuator = {f"{e}@M{i}" for e in ("actuator_compliance", "mount_compliance")}
        actuator |= {f"{e}@M{i}" for e in ("actuator_play", "actuator_friction")}
        drive = {f"{e}@O{i}" for e in ("drive_compliance", "drive_backlash", "drive_friction")}
        mine, other = (drive, actuator) if kind == "rotary" else (actuator, drive)
        assert mine <= cands and not other & cands
        assert {f"joint_clearance@O{i}", f"joint_friction@O{i}"} <= cands
    # the elastic ones of its kind are ranked (the frictions do not help loaded once)
    assert {k for k in cands if "compliance" in k and "@O" in k} <= ranked
