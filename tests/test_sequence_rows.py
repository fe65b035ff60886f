"""Long batches of load sequences on the compiled core, row by row against the numpy reference.

The block kernel steps 16 sequences at a time through their states and keeps up to 8 states
before writing them sequence by sequence (docs/architecture.md, "Load sequences"). A batch of
37 sequences × 19 states has two full blocks and a partial one, two full groups of states and
a partial one: a state written to the wrong row, or a group's last states dropped, shows as a
difference here. Every sequence has its own payloads, so no two rows are alike.

Tolerance: 1e-9 mm / deg, and 1e-9 of the largest load for forces and torques, as in
test_friction (the two sides compute the same model with different formulas; they agree to
~1e-12).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import eodarm

E = eodarm.Effect
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SEQUENCES, STATES = 37, 19
#: Per arm: its file, a working range of each joint (deg: the linear arm's absolute link
#: angles, the others' relative joint angles), and a model with two frictions, a gap and an
#: elastic element (at a drive: its gear's compliance).
CASES = {
    "linear": (
        "example_arm.toml",
        [(60.0, 110.0), (0.0, 30.0), (-10.0, 10.0)],
        [
            E("actuator_friction", "M1", friction_n=40.0),
            E("joint_friction", "O3", torque_nmm=4000.0),
            E("joint_clearance", "O3", clearance_mm=0.15),
            E("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
        ],
    ),
    "rotary": (
        "rotary_arm.toml",
        [(0.0, 60.0), (-60.0, 0.0), (-40.0, 20.0)],
        [
            E("drive_friction", "O2", torque_nmm=2000.0),
            E("joint_friction", "O3", torque_nmm=1000.0),
            E("joint_clearance", "O3", clearance_mm=0.15),
            E("drive_compliance", "O2", stiffness_nmm_per_rad=1.0e7),
        ],
    ),
    "mixed": (
        "mixed_arm.toml",
        [(10.0, 80.0), (-110.0, -40.0), (-90.0, -20.0)],
        [
            E("drive_friction", "O1", torque_nmm=4000.0),
            E("joint_friction", "O3", torque_nmm=4000.0),
            E("joint_clearance", "O3", clearance_mm=0.15),
            E("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
        ],
    ),
}
LOADS = ("force_n", "dforce_n", "torque_nmm", "dtorque_nmm", "reaction_n")


def _batch(name: str, seed: int) -> tuple[eodarm.Arm, np.ndarray, np.ndarray, list]:
    """The arm, 37 poses (absolute link angles) and their payloads."""
    file, ranges, effects = CASES[name]
    arm = eodarm.Arm.from_toml(EXAMPLES / file)
    rng = np.random.default_rng(seed)
    lo, hi = np.array(ranges).T
    alpha = rng.uniform(lo, hi, size=(SEQUENCES, arm.n))
    if name != "linear":
        alpha = np.cumsum(alpha, axis=1)
    masses = rng.uniform(0.0, 7.0, size=(SEQUENCES, STATES))
    masses[:, ::5] = 0.0  # returns to no payload: the frictions hold, the gaps stay
    return arm, alpha, masses, effects


@pytest.mark.parametrize("name", sorted(CASES))
def test_every_row_of_a_long_batch_equals_the_reference(name: str) -> None:
    arm, alpha, masses, effects = _batch(name, seed=len(name))
    core = eodarm.solve_sequence(arm, alpha, masses, effects)
    ref = eodarm.solve_sequence(arm, alpha, masses, effects, backend="numpy")
    assert np.isfinite(core["dy_mm"]).all()  # every state solved: the kernel wrote them all
    assert set(core) == set(ref)
    np.testing.assert_array_equal(core["status"], ref["status"])
    for key, value in ref.items():
        if key == "status":
            continue
        assert core[key].shape == value.shape == (SEQUENCES, STATES, *value.shape[2:]), key
        # NaN where the other kind of drive is (forces at a drive, torques at an actuator)
        np.testing.assert_array_equal(np.isnan(core[key]), np.isnan(value), err_msg=key)
        finite = np.abs(value[np.isfinite(value)])  # empty: the arm has no drive of that kind
        scale = max(1.0, float(finite.max())) if key in LOADS and finite.size else 1.0
        np.testing.assert_allclose(core[key], value, rtol=0, atol=1e-9 * scale, err_msg=key)


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_outputs_asked_for_are_those_of_the_whole_batch(name: str) -> None:
    arm, alpha, masses, effects = _batch(name, seed=7)
    whole = eodarm.solve_sequence(arm, alpha, masses, effects)
    asked = ("dalpha_deg", "torque_nmm", "dy_mm")
    part = eodarm.solve_sequence(arm, alpha, masses, effects, outputs=asked)
    assert list(part) == [*asked, "status"]
    for key in part:
        # the same kernel and the same arithmetic: only which arrays are written differs
        np.testing.assert_array_equal(part[key], whole[key], err_msg=key)
