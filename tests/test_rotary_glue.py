"""The Python API carries arms with rotary drives to the compiled core and back
(docs/model.md §10): ``angles_from_lengths`` with a drive's NaN length, ``solve(out=...)``
with the torque outputs, the fitted uncertainty of a drive's gear, and θ = 0 of a gear's
compliance (rigid, not absent) in the models the fits build.

Tolerances as in test_rotary_backends: 1e-9 of each output's magnitude with a floor of 1 in
its unit (both backends compute the same rigid geometry or the same model by different
formulas; their rounding is ~1e-13 of the sizes involved).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.errors import InputError
from eodarm.model.arm_parts import FitRecord
from eodarm.model.effects import Slot
from eodarm.model.solver import angles_from_lengths
from strategies import mixed_arm_and_poses

ROOT = Path(__file__).resolve().parents[1]
MIXED = ROOT / "examples" / "mixed_arm.toml"
ROTARY = ROOT / "examples" / "rotary_arm.toml"
POSES = np.array([[90.0, 10.0, 0.0], [60.0, 20.0, -10.0]])


def close(a: np.ndarray, b: np.ndarray) -> None:
    """Equal to 1e-9 of the magnitude (floor 1 in the unit), NaN where the other has NaN."""
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
    atol = 1e-9 * max(1.0, float(np.nanmax(np.abs(b), initial=0.0)))
    np.testing.assert_allclose(a, b, rtol=0.0, atol=atol, equal_nan=True)


# ---------------------------------------------------------------------------- lengths → angles
@settings(max_examples=100, deadline=None)
@given(case=mixed_arm_and_poses(), shift=st.floats(-3.0, 3.0))
def test_angles_from_lengths_of_mixed_arms_round_trip_on_both_backends(case, shift) -> None:
    """The lengths ``forward`` gives (NaN at the drives) closed again: from the pose itself
    as reference, the pose comes back; from a reference turned by ``shift`` at every joint,
    both backends give the same angles, and a drive keeps that reference's relative angle."""
    arm, alpha, _ = case
    length = eodarm.forward(arm, alpha)["length_mm"]
    for backend in ("rust", "numpy"):
        back = angles_from_lengths(arm, length, alpha, backend=backend)
        close(back, alpha)
    ref = alpha + shift
    try:
        rust = angles_from_lengths(arm, length, ref, backend="rust")
    except InputError:  # a triangle that the shifted reference's branch cannot close
        with pytest.raises(InputError):
            angles_from_lengths(arm, length, ref, backend="numpy")
        return
    ref_numpy = angles_from_lengths(arm, length, ref, backend="numpy")
    close(rust, ref_numpy)
    q = np.diff(rust, axis=1, prepend=0.0)
    q_ref = np.diff(ref, axis=1, prepend=0.0)
    drives = np.array(arm.kinds) == "rotary"
    np.testing.assert_allclose(q[:, drives], q_ref[:, drives], rtol=0.0, atol=1e-9)


@pytest.mark.parametrize("backend", ["rust", "numpy"])
def test_a_length_given_at_a_drive_is_refused_naming_row_and_joint(backend: str) -> None:
    arm = eodarm.Arm.from_toml(MIXED)  # joint 1 a drive
    length = eodarm.forward(arm, POSES)["length_mm"].copy()
    length[1, 0] = 250.0
    with pytest.raises(InputError, match=r"^pose row 1: length_mm of joint 1 must be NaN") as e:
        angles_from_lengths(arm, length, POSES, backend=backend)
    assert "\n" not in str(e.value) and len(str(e.value)) < 300
    length[1, 0] = np.nan
    length[0, 2] = np.nan  # a linear actuator's length is still required
    with pytest.raises(InputError, match=r"pose row 0: length_mm has a non-finite value"):
        angles_from_lengths(arm, length, POSES, backend=backend)


# ---------------------------------------------------------------------------- out=
def test_out_buffers_take_a_mixed_arms_torques_and_nans() -> None:
    """``out=`` holds what a fresh solve returns, the torques included, with NaN by kind;
    filled twice, no value of the first call is left behind."""
    arm = eodarm.Arm.from_toml(MIXED)
    fresh = eodarm.solve(arm, POSES, [5.0, 10.0])
    out = {k: np.full_like(v, 7.0) for k, v in fresh.items()}
    eodarm.solve(arm, POSES[::-1], [10.0, 5.0], out=out)
    got = eodarm.solve(arm, POSES, [5.0, 10.0], out=out)
    assert got.keys() == fresh.keys()
    for key, want in fresh.items():
        assert got[key] is out[key]
        np.testing.assert_array_equal(got[key], want, err_msg=key)
    drive = np.array(arm.kinds) == "rotary"
    assert np.isnan(out["force_n"][:, drive]).all() and np.isnan(out["torque_nmm"][:, ~drive]).all()
    assert np.isfinite(out["torque_nmm"][:, drive]).all()


# ---------------------------------------------------------------------------- uncertainty
def test_the_fitted_sigma_of_a_gears_stiffness_reaches_its_links_angle() -> None:
    """Drive 1 turns link 1 against the chassis: Δα₁ = −ΔT₁/k₁, so a stiffness known to
    ±σ_k gives σ(Δα₁) = |ΔT₁|/k₁² · σ_k (first order), for a single loading and for each
    state of a sequence alike (no memory in the model)."""
    k, sigma_k = 4.0e7, 2.0e6
    base = eodarm.Arm.from_toml(ROTARY)
    gear = eodarm.Effect("drive_compliance", "O1", stiffness_nmm_per_rad=k)
    fit = FitRecord(
        parameters=("drive_compliance@O1:stiffness_nmm_per_rad",),
        covariance=((sigma_k**2,),),
        explained=True,
    )
    arm = dataclasses.replace(base.with_effects([gear]), fit=fit)
    masses = np.array([5.0, 12.0])
    out = eodarm.solve(arm, POSES, masses, uncertainty=True)
    want = np.degrees(np.abs(out["dtorque_nmm"][:, 0]) / k**2 * sigma_k)
    np.testing.assert_allclose(out["sigma_dalpha_deg"][:, 0], want, rtol=1e-6)
    np.testing.assert_array_equal(out["sigma_model_dalpha_deg"], 0.0)
    seq = eodarm.solve_sequence(arm, POSES, masses[:, None], uncertainty=True)
    np.testing.assert_allclose(seq["sigma_dalpha_deg"][:, 0, 0], want, rtol=1e-6)


def test_theta_zero_of_a_gears_compliance_is_a_rigid_gear_not_the_files_gear() -> None:
    """θ = 1/k = 0 of ``drive_compliance`` (a fit at its bound) is a rigid gear: drive 1,
    on the chassis, then does not turn its link at all; absent, the arm file's gear would."""
    from eodarm.analysis.sequences import effects_of
    from eodarm.model.uncertainty import _effect_at

    arm = eodarm.Arm.from_toml(ROTARY)
    slot = Slot.of(eodarm.Effect("drive_compliance", "O1", stiffness_nmm_per_rad=1e7))
    files_gear = eodarm.solve(arm, POSES, 10.0)["dalpha_deg"][:, 0]
    assert (np.abs(files_gear) > 1e-3).all()
    for model in (effects_of([(slot, 0.0)]), _effect_at(slot, 0.0)):
        assert [e.name for e in model] == ["drive_compliance"]
        rigid = eodarm.solve(arm, POSES, 10.0, model)["dalpha_deg"][:, 0]
        assert (np.abs(rigid) < 1e-9 * np.abs(files_gear)).all()
    assert math.isfinite(model[0].value)


# ---------------------------------------------------------------------------- load cycles
@pytest.mark.parametrize("path", [MIXED, ROTARY])
def test_cycle_returns_of_arms_with_drives_are_where_each_cycle_ends(path: Path) -> None:
    """``cycle_returns`` gives the last state of ``solve_sequence(..., [m, 0])`` on arms with
    drives too (the same compiled path: 1e-12 mm), and a gear's friction that holds leaves
    the arm off its reference after the cycle; a backlash alone, taken up in the reference
    along the self-weight's torque, which no payload here reverses, does not."""
    from eodarm.model.solver import cycle_returns

    arm = eodarm.Arm.from_toml(path)
    held = [
        eodarm.Effect("drive_friction", "O1", torque_nmm=2.0e4),
        eodarm.Effect("drive_backlash", "O1", backlash_deg=0.1),
    ]
    mass = np.array([0.0, 4.0, 12.0])
    dx, dy = cycle_returns(arm, POSES, mass, held)
    assert dx.shape == dy.shape == (2, 3)
    for j, m in enumerate(mass):
        seq = eodarm.solve_sequence(arm, POSES, [m, 0.0], held)
        np.testing.assert_allclose(dx[:, j], seq["dx_mm"][:, 1], rtol=0, atol=1e-12)
        np.testing.assert_allclose(dy[:, j], seq["dy_mm"][:, 1], rtol=0, atol=1e-12)
    assert np.abs(dy[:, 2]).max() > 1e-3
    gap = eodarm.Effect("drive_backlash", "O1", backlash_deg=0.1, unloaded="taken_up")
    _, dy_free = cycle_returns(arm, POSES, mass, [gap])
    np.testing.assert_allclose(dy_free, 0.0, atol=1e-9)
