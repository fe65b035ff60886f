"""The capacity map's drive-angle limit (docs/sweeps.md, "Arms with rotary drives"): a drive's
range is on its relative angle q_i = α_i − α_{i−1} (docs/model.md §10), which the turn of its
housing moves as much as its gear does — the bending slope of body i−1 at O_i
(``link_bending``), for drive 1 the chassis' tilt (``base_compliance``). The capacity is
where the solver's own status turns ``out_of_stroke``: checked by solving just below and just
above it, with the housing's turn a large part of the drive's loaded turn.

Tolerances: the capacity is a root of an affine function of the payload (the statics on the
undeformed geometry, docs/model.md §1), so the solver's angle at ±10⁻⁴ of it is on either
side of the limit by ~10⁻⁴ of the payload's turn (~10⁻⁵°), far beyond its 10⁻⁹° tolerance
and its rounding.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import eodarm
from eodarm.model.validity import STATUS
from eodarm.workspace.maps import payload_capacity

ROOT = Path(__file__).resolve().parents[1]
OUT_OF_STROKE = STATUS.index("out_of_stroke")

#: (arm, the drive whose range binds (0-based), the effect that turns its housing, the pose
#: about which the grid is laid, how far (deg) below its unloaded q_i the range ends there).
CASES = {
    "bending": (
        "rotary",
        1,
        eodarm.Effect("link_bending", "L1", ei_n_mm2=1.0e10),
        (60.0, -30.0, -20.0),
        0.25,
    ),
    "tilt": (
        "mixed",
        0,
        eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=2.0e8),
        (60.0, -60.0, -100.0),
        0.25,
    ),
}


def _case(name: str) -> tuple[eodarm.Arm, int, eodarm.Effect, dict[str, list[float]]]:
    kind, drive, effect, pose, margin = CASES[name]
    d = eodarm.Arm.from_toml(ROOT / "examples" / f"{kind}_arm.toml").to_dict()
    q = np.diff(pose, prepend=0.0)
    d["actuator"][drive]["min_angle_deg"] = float(q[drive]) - margin
    arm = eodarm.Arm.from_dict(d)
    grid = {f"alpha{i + 1}": [a - 1.0, a, a + 1.0] for i, a in enumerate(pose)}
    return arm, drive, effect, grid


@pytest.mark.parametrize("name", list(CASES))
def test_a_drives_range_binds_where_its_housings_turn_takes_it_out(name: str) -> None:
    arm, drive, effect, grid = _case(name)
    cap = payload_capacity(arm, grid, effects=[effect], max_payload_kg=200.0)
    labels = cap.attrs["limit_labels"].split(", ")
    code = labels.index(f"q{drive + 1} range")
    c = cap["capacity_kg"].values.reshape(-1)
    lim = cap["limit"].values.reshape(-1)
    alpha = np.array(np.meshgrid(*grid.values(), indexing="ij")).reshape(3, -1).T
    bound = np.flatnonzero(lim == code)
    assert bound.size >= 9, (labels, lim)  # the range binds over much of the grid
    rigid_housing = eodarm.Effect(
        effect.name, effect.at, **{effect.kind.param: 1e30}
    )  # the same effect, stiff: only the gear turns
    for p in bound:
        at = [alpha[p : p + 1], alpha[p : p + 1]]
        below = eodarm.solve(arm, at[0], c[p] * (1 - 1e-4), [effect])
        above = eodarm.solve(arm, at[1], c[p] * (1 + 1e-4), [effect])
        assert int(below["status"][0]) == 0, (p, c[p])
        assert int(above["status"][0]) == OUT_OF_STROKE, (p, c[p])
        # the housing's turn is a large part: with it stiff the drive is still inside
        stiff = eodarm.solve(arm, at[1], c[p] * 1.1, [rigid_housing])
        assert int(stiff["status"][0]) == 0, (p, c[p])


def test_the_arm_files_effects_count_and_frictions_at_a_drive_are_left_out() -> None:
    """The map's model is the arm file's effects, then the given ones (as every command's);
    a friction at a drive only holds part of a load change back, and the map gives the
    frictionless drive's limits: the same capacity as without it."""
    arm, drive, effect, grid = _case("bending")
    want = payload_capacity(arm, grid, effects=[effect])
    carried = eodarm.Arm.from_dict({**arm.to_dict(), "effect": [effect.to_table()]})
    frictions = [
        eodarm.Effect("joint_friction", f"O{drive + 1}", torque_nmm=3000.0),
        eodarm.Effect("drive_friction", f"O{drive + 1}", torque_nmm=2000.0),
    ]
    for got in (
        payload_capacity(carried, grid),
        payload_capacity(arm, grid, effects=[effect, *frictions]),
    ):
        np.testing.assert_array_equal(got["capacity_kg"].values, want["capacity_kg"].values)
        np.testing.assert_array_equal(got["limit"].values, want["limit"].values)
    # the map's title says what its drives' limits leave out
    assert got.attrs["model"].endswith(
        "(joint_friction@O2, drive_friction@O2: left out of the drives' limits)"
    )
