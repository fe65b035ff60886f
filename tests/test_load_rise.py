"""A rise under load is not ``ok`` (issue 23 item 7, docs/model.md §7): an elastic arm's load
point cannot rise when a downward payload is added (its potential energy forbids it), so a
model answer whose load point rises by more than ``MAX_LOAD_RISE_MM`` (1e-3 mm) under a
downward payload, with no gap effect and no user-written deformation, is ``large_deflection``
in every place the status is computed.

The case: one link hanging 0.3° off the vertical below its joint, a soft actuator. The
payload's moment, taken on the undeformed geometry, does not fall as the link swings towards
the vertical, so the model swings it past the bottom and the load point comes up again; a real
pendulum settles at the bottom. Every other limit is far away (the point moves a few mm of a
300 mm reach, the link turns less than 1°).
"""

from __future__ import annotations

import numpy as np
import pytest

import eodarm
from eodarm.model.validity import (
    MAX_DALPHA_DEG,
    MAX_DEFLECTION_OF_REACH,
    MAX_LOAD_RISE_MM,
    MAX_RISE_OF_REACH,
    STATUS,
)

REACH = 300.0
ALPHA = np.array([[-90.3]])  # the load point 1.6 mm left of the joint, 300 mm below it
SOFT = eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=5.0)
LARGE = STATUS.index("large_deflection")


@pytest.fixture(scope="module")
def pendulum() -> eodarm.Arm:
    return eodarm.Arm.from_dict(
        {
            "name": "pendulum",
            "base": {"O1": [0.0, 0.0], "B0": [120.0, -265.0]},
            "link": [{"next": [REACH, 0.0], "A": [52.0, 78.0], "C": [0.0, 30.0], "mass_kg": 0.0}],
            "actuator": [{"stiffness_n_per_mm": 500.0, "mass_kg": 0.0}],
        }
    )


def _load_rise(arm: eodarm.Arm, out: dict) -> float:
    """The load point's height change (mm): the rigid link at the loaded angle."""
    before = eodarm.forward(arm, ALPHA)["O"][0, -1, 1]
    after = eodarm.forward(arm, ALPHA + out["dalpha_deg"])["O"][0, -1, 1]
    return float(after - before)


@pytest.mark.parametrize("backend", ["rust", "numpy"])
def test_a_load_point_that_rises_is_not_ok(pendulum: eodarm.Arm, backend: str) -> None:
    out = eodarm.solve(pendulum, ALPHA, 24.0, [SOFT], backend=backend)
    assert _load_rise(pendulum, out) > 5 * MAX_LOAD_RISE_MM
    # no other limit is near: only the rise makes it large_deflection
    assert np.hypot(out["dx_mm"][0], out["dy_mm"][0]) < 0.5 * MAX_DEFLECTION_OF_REACH * REACH
    assert abs(out["dalpha_deg"][0, 0]) < 0.1 * MAX_DALPHA_DEG
    assert out["dy_mm"][0] < 0.1 * MAX_RISE_OF_REACH * REACH
    assert out["status"][0] == LARGE


@pytest.mark.parametrize("backend", ["rust", "numpy"])
def test_before_the_swing_passes_the_bottom_the_answer_is_ok(
    pendulum: eodarm.Arm, backend: str
) -> None:
    out = eodarm.solve(pendulum, ALPHA, 8.0, [SOFT], backend=backend)
    assert _load_rise(pendulum, out) < 0  # the load point goes down
    assert out["status"][0] == 0


def test_the_sweep_and_the_general_path_mark_it_alike(pendulum: eodarm.Arm) -> None:
    ds = eodarm.sweep(pendulum, alpha_deg={"alpha1": ALPHA[0]}, mass_kg=[8.0, 24.0], effects=[SOFT])
    assert ds.status.values.ravel().tolist() == [0, LARGE]
    # the general path (user deformations that are zero: no user effect acts)
    zero = {"extra_measure_mm": np.zeros((2, 2))}
    out = eodarm.solve(pendulum, np.vstack([ALPHA, ALPHA]), [8.0, 24.0], [SOFT], extra=zero)
    assert out["status"].tolist() == [0, LARGE]


def test_a_gap_or_a_user_deformation_leaves_the_rule_out(pendulum: eodarm.Arm) -> None:
    """With a gap the unloaded pose is no equilibrium of elastic parts, and a user-written
    deformation may lift the point: the energy argument does not hold, the rule is not
    applied."""
    gap = eodarm.Effect("joint_clearance", "O1", clearance_mm=1e-6)
    assert eodarm.solve(pendulum, ALPHA, 24.0, [SOFT, gap])["status"][0] == 0
    user = {"extra_measure_mm": np.array([[0.0, 1e-9]])}
    for backend in ("rust", "numpy"):
        out = eodarm.solve(pendulum, ALPHA, 24.0, [SOFT], backend=backend, extra=user)
        assert out["status"][0] == 0, backend


@pytest.mark.parametrize("backend", ["rust", "numpy"])
@pytest.mark.parametrize(
    "friction",
    [
        eodarm.Effect("actuator_friction", "M1", friction_n=1e-3),
        eodarm.Effect("joint_friction", "O1", torque_nmm=1e-2),
    ],
    ids=lambda e: e.name,
)
def test_a_friction_keeps_the_rule(pendulum: eodarm.Arm, backend: str, friction: object) -> None:
    """A friction only holds back part of what the load deforms: it dissipates and stores no
    energy that could lift the point, so the rule applies with it, in both backends, for a
    single loading and for a sequence."""
    out = eodarm.solve(pendulum, ALPHA, 24.0, [SOFT, friction], backend=backend)
    assert _load_rise(pendulum, out) > 5 * MAX_LOAD_RISE_MM
    assert out["status"][0] == LARGE
    seq = eodarm.solve_sequence(
        pendulum, ALPHA, [8.0, 24.0, 8.0], [SOFT, friction], backend=backend
    )
    assert seq["status"][0].tolist() == [0, LARGE, 0]
