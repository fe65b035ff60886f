"""The compiled Rust core gives the same numbers as the independent numpy reference.

Both follow docs/model.md with different formulations (tip-to-base recursion vs one 3n×3n
system for the statics; arccos vs circle–circle intersection for the triangles), so agreement
to ~1e-9 on random arms, poses, payloads and effect sets is strong evidence that both are right.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from strategies import (
    arm_and_poses,
    arms,
    effects_for,
    payload_vectors,
    poses_for,
)

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
SOLVE_KEYS = {
    "force_n",
    "torque_nmm",
    "reaction_n",
    "dforce_n",
    "dtorque_nmm",
    "dx_mm",
    "dy_mm",
    "dalpha_deg",
    "dl_mm",
    "dlength_mm",
    "status",
    "length_mm",
}
FORWARD_KEYS = {"O", "A", "B", "C", "measure", "length_mm"}


def assert_same(rust: dict[str, np.ndarray], ref: dict[str, np.ndarray], keys: set[str]) -> None:
    """Every key equal to 1e-9 of the key's magnitude, with a floor of 1 in its unit.

    Why the floor: the displacements (dx, dy, dalpha, dl …) are differences of positions and
    angles of size ~1000 mm / ~100°, computed by different formulas; their rounding error is
    ~1e-13 of those sizes, so a purely relative test on a tiny difference would test rounding,
    not physics. A floor of 1 (mm, N, deg) makes the tolerance 1e-9 mm / 1e-9 N / 1e-9 deg for
    small quantities — still ~1e-6 of the smallest deflection a sensor could see — and 1e-9
    relative for large ones (forces of kN, lengths of hundreds of mm).
    """
    assert set(rust) == set(ref) == keys
    for key in sorted(keys):
        r, n = np.asarray(rust[key]), np.asarray(ref[key])
        assert r.shape == n.shape, key
        atol = 1e-9 * max(1.0, float(np.nanmax(np.abs(n), initial=0.0)))
        np.testing.assert_allclose(r, n, rtol=0.0, atol=atol, err_msg=key)


# ---------------------------------------------------------------------------- solve
@settings(max_examples=500, deadline=None)
@given(case=arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_solve_rust_equals_numpy(case, self_weight, data) -> None:
    arm, alpha, mass = case
    effects = data.draw(effects_for(arm), label="effects")
    rust = eodarm.solve(arm, alpha, mass, effects, backend="rust", self_weight=self_weight)
    ref = eodarm.solve(arm, alpha, mass, effects, backend="numpy", self_weight=self_weight)
    assert_same(rust, ref, SOLVE_KEYS)
    n_rows, n = alpha.shape
    assert rust["force_n"].shape == (n_rows, n) and rust["reaction_n"].shape == (n_rows, n, 2)
    assert rust["dx_mm"].shape == (n_rows,)


@settings(max_examples=250, deadline=None)
@given(case=arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_solve_payload_any_direction_rust_equals_numpy(case, self_weight, data) -> None:
    arm, alpha, _ = case
    payload = data.draw(payload_vectors(alpha.shape[0], g=arm.g), label="payload")
    effects = data.draw(effects_for(arm), label="effects")
    rust = eodarm.solve_payload(arm, alpha, payload, effects, "rust", self_weight)
    ref = eodarm.solve_payload(arm, alpha, payload, effects, "numpy", self_weight)
    assert_same(rust, ref, SOLVE_KEYS)


def test_large_batch_parallel_path_equals_numpy() -> None:
    """Above 2048 poses the core splits the batch over threads; rows must not be mixed up."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    rng = np.random.default_rng(7)
    rows = 2600  # more than two chunks of 1024, with a short last chunk
    alpha = np.array([60.0, 0.0, -10.0]) + np.array([50.0, 30.0, 20.0]) * rng.random((rows, 3))
    mass = 8.0 * rng.random(rows)
    effects = [
        eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=1500.0),
        eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=900.0),
        eodarm.Effect("actuator_play", "M3", play_mm=0.05),
        eodarm.Effect("joint_clearance", "O2", clearance_mm=0.1),
        eodarm.Effect("link_bending", "L2", ei_n_mm2=8e8),
        eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=5e7),
    ]
    rust = eodarm.solve(arm, alpha, mass, effects, backend="rust")
    ref = eodarm.solve(arm, alpha, mass, effects, backend="numpy")
    assert_same(rust, ref, SOLVE_KEYS)
    # and each row is the same as solving that pose alone
    for row in (0, 1023, 1024, 2047, 2048, rows - 1):
        alone = eodarm.solve(arm, alpha[row], mass[row], effects, backend="rust")
        for key in SOLVE_KEYS:
            np.testing.assert_array_equal(alone[key][0], rust[key][row], err_msg=key)


# ---------------------------------------------------------------------------- kinematics
@settings(max_examples=120, deadline=None)
@given(case=arm_and_poses())
def test_forward_rust_equals_numpy(case) -> None:
    arm, alpha, _ = case
    rust = eodarm.forward(arm, alpha, backend="rust")
    ref = eodarm.forward(arm, alpha, backend="numpy")
    assert_same(rust, ref, FORWARD_KEYS)
    n_rows, n = alpha.shape
    assert rust["O"].shape == (n_rows, n + 1, 2)
    # the reported lengths are the pin-to-pin distances of the reported pins
    np.testing.assert_allclose(
        rust["length_mm"], np.linalg.norm(rust["A"] - rust["B"], axis=-1), rtol=1e-12
    )


@settings(max_examples=120, deadline=None)
@given(case=arm_and_poses(), nudge=st.floats(-5.0, 5.0), data=st.data())
def test_angles_from_lengths_round_trip(case, nudge, data) -> None:
    """Lengths of a pose give back that pose (branch from a nearby reference pose)."""
    arm, alpha, _ = case
    lengths = eodarm.forward(arm, alpha)["length_mm"]
    reference_pose = alpha + nudge
    back = {
        b: eodarm.angles_from_lengths(arm, lengths, reference_pose, backend=b)
        for b in ("rust", "numpy")
    }
    for b, got in back.items():
        np.testing.assert_allclose(got, alpha, rtol=0.0, atol=1e-9, err_msg=b)
    np.testing.assert_allclose(back["rust"], back["numpy"], rtol=0.0, atol=1e-9)
    # a single (n,) reference pose is broadcast to every row
    one = eodarm.angles_from_lengths(arm, lengths[:1], reference_pose[0])
    np.testing.assert_allclose(one, alpha[:1], rtol=0.0, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(case=arm_and_poses(), data=st.data())
def test_angles_from_lengths_marks_rows_that_cannot_close(case, data) -> None:
    """The core's ``nan_on_failure`` (what lengths sweeps use) gives NaN exactly for the rows
    the numpy reference refuses, one row at a time, and the reference's angles elsewhere."""
    from eodarm import _core
    from eodarm.model.solver import _core_arm

    arm, alpha, _ = case
    lengths = eodarm.forward(arm, alpha)["length_mm"].copy()
    stretch = data.draw(
        st.lists(
            st.sampled_from([1.0, 1.0, 1.6, 3.0]), min_size=lengths.size, max_size=lengths.size
        )
    )
    lengths *= np.reshape(stretch, lengths.shape)
    got = _core.angles_from_lengths(_core_arm(arm), lengths, alpha[:1], nan_on_failure=True)
    for r in range(lengths.shape[0]):
        try:
            want = eodarm.angles_from_lengths(arm, lengths[r : r + 1], alpha[0], backend="numpy")
        except ValueError:
            assert np.isnan(got[r]).all(), r
            continue
        np.testing.assert_allclose(got[r], want[0], rtol=0.0, atol=1e-9, err_msg=str(r))


def wrap_deg(x: np.ndarray) -> np.ndarray:
    return (np.asarray(x) + 180.0) % 360.0 - 180.0


@st.composite
def three_link_cases(draw):
    arm = draw(arms(st.just(3)))
    return arm, draw(poses_for(arm))


@settings(max_examples=120, deadline=None)
@given(case=three_link_cases())
def test_inverse_kinematics_reaches_target_on_both_elbows(case) -> None:
    arm, alpha = case
    geo = eodarm.forward(arm, alpha)
    target = np.column_stack([geo["O"][:, 3], alpha[:, 2]])
    scale = 1e-9 * max(1.0, float(np.abs(geo["O"]).max()))
    recovered = np.zeros(alpha.shape[0], dtype=bool)
    for elbow in (-1, 1):
        out = {
            b: eodarm.inverse_kinematics(arm, target, elbow, backend=b) for b in ("rust", "numpy")
        }
        for b, ik in out.items():
            assert ik["reachable"].all(), b
            # the returned pose puts the load point on the target with the asked last angle
            reached = eodarm.forward(arm, ik["alpha_deg"])
            np.testing.assert_allclose(reached["O"][:, 3], target[:, :2], rtol=0, atol=scale)
            np.testing.assert_allclose(wrap_deg(ik["alpha_deg"][:, 2] - alpha[:, 2]), 0, atol=1e-9)
            np.testing.assert_allclose(ik["length_mm"], reached["length_mm"], rtol=1e-12)
        # the same angles from both backends, α1 and α2 within [−180°, 180°)
        rust, ref = out["rust"], out["numpy"]
        np.testing.assert_allclose(rust["alpha_deg"], ref["alpha_deg"], rtol=0, atol=1e-9)
        assert (np.abs(rust["alpha_deg"][:, :2]) <= 180.0).all()
        np.testing.assert_allclose(rust["length_mm"], ref["length_mm"], rtol=1e-9)
        np.testing.assert_array_equal(rust["reachable"], ref["reachable"])
        recovered |= (np.abs(wrap_deg(rust["alpha_deg"] - alpha)) < 1e-7).all(axis=1)
    # one of the two elbows is the pose we started from
    assert recovered.all()


def test_inverse_kinematics_unreachable_target_on_both_backends() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    # too far (|O3 − O1| > 480 + 380), reachable, too close (|O3 − O1| = 5 < 480 − 380)
    target = np.array([[3000.0, 0.0, 0.0], [500.0, 400.0, 0.0], [360.0, 5.0, 0.0]])
    for b in ("rust", "numpy"):
        for elbow in (-1, 1):
            ik = eodarm.inverse_kinematics(arm, target, elbow, backend=b)
            np.testing.assert_array_equal(ik["reachable"], [False, True, False])
            assert np.isnan(ik["alpha_deg"][[0, 2]]).all() and np.isnan(ik["length_mm"][0]).all()
            assert np.isfinite(ik["alpha_deg"][1]).all()


def test_inverse_kinematics_backends_return_identical_angles() -> None:
    """Targets behind the arm, where an unwrapped α1 would leave [−180°, 180°)."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    target = np.array([[-600.0, 300.0, 170.0], [600.0, 500.0, 0.0]])
    for elbow in (-1, 1):
        rust = eodarm.inverse_kinematics(arm, target, elbow, backend="rust")["alpha_deg"]
        ref = eodarm.inverse_kinematics(arm, target, elbow, backend="numpy")["alpha_deg"]
        np.testing.assert_allclose(rust, ref, rtol=0, atol=1e-9)
