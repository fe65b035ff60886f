"""``eodarm.solve`` and ``eodarm.solve_sequence`` hand the payload masses to the compiled core
(which makes the forces (0, −m·g) a chunk at a time) instead of building (N, 2) forces in
Python: the results are those of the forces they stand for, bit for bit, whatever form the
masses take (a scalar, one per row, a broadcast view), and bad masses are refused in the
same words as before, naming the row or the sequence and state."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.errors import InputError

ROOT = Path(__file__).resolve().parent.parent
ARMS = {k: ROOT / "examples" / f"{k}_arm.toml" for k in ("example", "rotary", "mixed")}
RANGES = {
    "example": [(60.0, 110.0), (0.0, 30.0), (-10.0, 10.0)],
    "rotary": [(0.0, 60.0), (-60.0, 0.0), (-40.0, 20.0)],
    "mixed": [(10.0, 80.0), (-110.0, -40.0), (-90.0, -20.0)],
}
EFFECTS = [
    eodarm.Effect("joint_friction", "O3", torque_nmm=4000.0),
    eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15),
]


def poses(kind: str, rows: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = np.column_stack([rng.uniform(lo, hi, rows) for lo, hi in RANGES[kind]])
    return q if kind == "example" else np.cumsum(q, axis=1)


def same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert sorted(a) == sorted(b)
    for key in a:
        # the same forces reach the same kernel: the same bits (NaN where NaN)
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


@pytest.mark.parametrize("kind", list(ARMS))
@settings(max_examples=15, deadline=None)
@given(rows=st.sampled_from([1, 7, 600, 2100, 5000]), seed=st.integers(0, 2**16))
def test_solve_with_masses_is_solve_with_their_forces(kind: str, rows: int, seed: int) -> None:
    arm = eodarm.Arm.from_toml(ARMS[kind])
    alpha = poses(kind, rows, seed)
    mass = np.random.default_rng(seed + 1).uniform(0.0, 7.0, rows)
    forces = np.column_stack([np.zeros(rows), -mass * arm.g])
    same(eodarm.solve(arm, alpha, mass), eodarm.solve_payload(arm, alpha, forces))
    # one mass for every row (not copied N times on the way)
    one = np.column_stack([np.zeros(rows), np.full(rows, -2.5 * arm.g)])
    same(eodarm.solve(arm, alpha, 2.5), eodarm.solve_payload(arm, alpha, one))
    with_effects = eodarm.solve(arm, alpha, mass, EFFECTS, outputs=("dx_mm", "dy_mm"))
    same(
        with_effects, eodarm.solve_payload(arm, alpha, forces, EFFECTS, outputs=("dx_mm", "dy_mm"))
    )


def test_masses_and_forces_agree_with_the_numpy_reference() -> None:
    # the masses' path against the independent reference, not only against itself
    arm = eodarm.Arm.from_toml(ARMS["example"])
    alpha = poses("example", 3000, 5)
    mass = np.random.default_rng(6).uniform(0.0, 7.0, 3000)
    rust = eodarm.solve(arm, alpha, mass)
    ref = eodarm.solve(arm, alpha, mass, backend="numpy")
    # 1e-9 mm: both solve the same closed forms; their roundings differ by ~1e-13 mm
    np.testing.assert_allclose(rust["dy_mm"], ref["dy_mm"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(rust["force_n"], ref["force_n"], rtol=1e-10, atol=1e-9)
    np.testing.assert_array_equal(rust["status"], ref["status"])


@pytest.mark.parametrize(
    ("mass", "says"),
    [
        ([1.0, 2.0, -0.5, 1.0], "pose row 2: mass_kg is negative (-0.5)"),
        ([1.0, np.inf, 0.5, 1.0], "pose row 1: mass_kg is not finite"),
        (-1.0, "pose row 0: mass_kg is negative (-1.0)"),
        (np.nan, "pose row 0: mass_kg is not finite"),
    ],
)
def test_a_bad_mass_is_refused_naming_its_row(mass: object, says: str) -> None:
    arm = eodarm.Arm.from_toml(ARMS["example"])
    alpha = poses("example", 4, 1)
    with pytest.raises(InputError) as err:
        eodarm.solve(arm, alpha, mass)  # type: ignore[arg-type]
    assert str(err.value) == says


def test_a_nan_angle_is_named_before_a_pose_that_cannot_be_solved() -> None:
    # the angles are checked chunk by chunk in parallel now: a non-finite angle in a late
    # chunk is still what is reported, before a pose of an early chunk that will not close
    arm = eodarm.Arm.from_toml(ARMS["example"])
    alpha = poses("example", 5000, 2)
    mass = np.full(5000, 2.0)
    mass[3] = 1e9  # this pose cannot close under its load
    alpha[4800, 1] = np.nan
    with pytest.raises(InputError, match=r"^pose row 4800: alpha_deg has a non-finite value$"):
        eodarm.solve(arm, alpha, mass, strict=True)
    alpha[4800, 1] = 10.0
    with pytest.raises(ValueError, match=r"^pose row 3: actuator 1 cannot close"):
        eodarm.solve(arm, alpha, mass, strict=True)


@pytest.mark.parametrize("kind", list(ARMS))
def test_shared_state_masses_are_the_same_as_one_row_each(kind: str) -> None:
    arm = eodarm.Arm.from_toml(ARMS[kind])
    alpha = poses(kind, 700, 3)
    states = np.array([0.0, 1.5, 5.0, 6.5, 0.0, 3.0])
    each = np.tile(states, (700, 1))  # (N, S), contiguous
    full = eodarm.solve_sequence(arm, alpha, each, EFFECTS[:1])
    for shared in (states, states[None, :], np.broadcast_to(states, (700, states.size))):
        same(eodarm.solve_sequence(arm, alpha, shared, EFFECTS[:1]), full)


def test_a_bad_shared_state_mass_names_the_first_sequence_and_its_state() -> None:
    arm = eodarm.Arm.from_toml(ARMS["example"])
    alpha = poses("example", 50, 4)
    states = np.array([0.0, 1.5, -5.0, 0.0])
    with pytest.raises(InputError) as err:
        eodarm.solve_sequence(arm, alpha, np.broadcast_to(states, (50, 4)))
    assert str(err.value) == "mass_kg: sequence 0, state 2: expected a finite mass >= 0, got -5.0"
    each = np.tile(np.abs(states), (50, 1))
    each[31, 3] = np.nan
    with pytest.raises(InputError, match=r"^mass_kg: sequence 31, state 3: expected a finite"):
        eodarm.solve_sequence(arm, alpha, each)
