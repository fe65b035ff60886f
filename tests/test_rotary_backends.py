"""The compiled core gives the numbers of the independent numpy reference on arms with rotary
drives: random mixed arms of 1–7 links, any mix of linear actuators and drives, every effect of
the catalogue at the joints of its kind, ``solve``, ``solve_payload`` and ``solve_sequence``.

Both follow docs/model.md §10 written independently (the core recurses the statics from the
tip; the reference solves all 3n equations at once, closes a drive's joint by angles and bends
a clamped link as two cantilevers), so agreement to ~1e-9 on random inputs is strong evidence
that both are right. These tests need the core's rotary drives (the binding that takes an
arm's ``kind``): on a core without them they fail, they are not skipped.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.model.effects import UNLOADED
from strategies import ALL_KINDS, FRICTIONS, effects_for, mixed_arm_and_poses, payload_vectors
from test_backends import FORWARD_KEYS, SOLVE_KEYS  # the keys both backends return, listed once


def assert_same(rust: dict[str, np.ndarray], ref: dict[str, np.ndarray], keys: set[str]) -> None:
    """Every key equal to 1e-9 of the key's magnitude, with a floor of 1 in its unit, and NaN
    exactly where the other has NaN (a joint of the other kind, a pose that failed).

    Why the floor: the displacements are differences of positions and angles of size
    ~1000 mm / ~100°, computed by different formulas, whose rounding is ~1e-13 of those sizes;
    a floor of 1 (mm, N, N·mm, deg) makes the tolerance 1e-9 of the unit for small quantities,
    ~1e-6 of the smallest deflection a sensor could see, and 1e-9 relative for large ones
    (torques of 1e5 N·mm, forces of kN). The status codes are compared exactly.
    """
    assert set(rust) == set(ref) == keys
    for key in sorted(keys):
        r, n = np.asarray(rust[key]), np.asarray(ref[key])
        assert r.shape == n.shape, key
        if key == "status":
            np.testing.assert_array_equal(r, n, err_msg=key)
            continue
        np.testing.assert_array_equal(np.isnan(r), np.isnan(n), err_msg=f"{key}: NaN")
        atol = 1e-9 * max(1.0, float(np.nanmax(np.abs(n), initial=0.0)))
        np.testing.assert_allclose(r, n, rtol=0.0, atol=atol, equal_nan=True, err_msg=key)


@settings(max_examples=400, deadline=None)
@given(case=mixed_arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_solve_of_mixed_arms_rust_equals_numpy(case, self_weight, data) -> None:
    arm, alpha, mass = case
    effects = data.draw(effects_for(arm, ALL_KINDS + FRICTIONS, unloaded=UNLOADED), label="effects")
    rust = eodarm.solve(arm, alpha, mass, effects, backend="rust", self_weight=self_weight)
    ref = eodarm.solve(arm, alpha, mass, effects, backend="numpy", self_weight=self_weight)
    assert_same(rust, ref, SOLVE_KEYS)


@settings(max_examples=200, deadline=None)
@given(case=mixed_arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_solve_payload_of_mixed_arms_any_direction_rust_equals_numpy(case, self_weight, data):
    arm, alpha, _ = case
    payload = data.draw(payload_vectors(alpha.shape[0], g=arm.g), label="payload")
    effects = data.draw(effects_for(arm, ALL_KINDS, unloaded=UNLOADED), label="effects")
    rust = eodarm.solve_payload(arm, alpha, payload, effects, "rust", self_weight)
    ref = eodarm.solve_payload(arm, alpha, payload, effects, "numpy", self_weight)
    assert_same(rust, ref, SOLVE_KEYS)


@settings(max_examples=150, deadline=None)
@given(case=mixed_arm_and_poses(max_poses=3), self_weight=st.booleans(), data=st.data())
def test_solve_sequence_of_mixed_arms_rust_equals_numpy(case, self_weight, data) -> None:
    """Sequences with the frictions' memory and the gaps taken up along each state's force
    and torque: 1–8 states of 0–8 kg after the reference."""
    arm, alpha, _ = case
    states = data.draw(st.integers(1, 8), label="states")
    masses = np.array(
        data.draw(
            st.lists(
                st.lists(st.floats(0.0, 8.0), min_size=states, max_size=states),
                min_size=alpha.shape[0],
                max_size=alpha.shape[0],
            ),
            label="masses",
        )
    )
    effects = data.draw(effects_for(arm, ALL_KINDS + FRICTIONS, unloaded=UNLOADED), label="effects")
    rust = eodarm.solve_sequence(arm, alpha, masses, effects, "rust", self_weight)
    ref = eodarm.solve_sequence(arm, alpha, masses, effects, "numpy", self_weight)
    assert_same(rust, ref, SOLVE_KEYS)


@settings(max_examples=100, deadline=None)
@given(case=mixed_arm_and_poses())
def test_forward_of_mixed_arms_rust_equals_numpy(case) -> None:
    """The pins a drive does not have are NaN on both sides, with the pin-to-pin length."""
    arm, alpha, _ = case
    rust = eodarm.forward(arm, alpha, backend="rust")
    ref = eodarm.forward(arm, alpha, backend="numpy")
    assert_same(rust, ref, FORWARD_KEYS)


@settings(max_examples=100, deadline=None)
@given(case=mixed_arm_and_poses(), self_weight=st.booleans())
def test_statics_of_mixed_arms_rust_equals_numpy(case, self_weight) -> None:
    """What user effects read: the loaded and unloaded forces, torques and reactions."""
    from eodarm.model import reference
    from eodarm.model.solver import statics

    arm, alpha, mass = case
    rust = statics(arm, alpha, mass, backend="rust", self_weight=self_weight)
    payload = np.column_stack([np.zeros_like(mass), -mass * arm.g])
    ref = reference.statics(arm, alpha, payload, self_weight=self_weight)
    keys = ("force_n", "force0_n", "torque_nmm", "torque0_nmm", "reaction_n", "reaction0_n")
    assert_same({k: rust[k] for k in keys}, {k: ref[k] for k in keys}, set(keys))


@settings(max_examples=60, deadline=None)
@given(case=mixed_arm_and_poses(), data=st.data())
def test_a_user_effects_joint_turn_rust_equals_numpy(case, data) -> None:
    """A user effect at every drive turning it by −c·ΔT (joint_turn_rad), read from
    ``EffectState.torque_nmm``: the core takes the turn as its ``extra_turn_rad``."""
    from eodarm.model import custom

    arm, alpha, mass = case
    drives = [i for i, k in enumerate(arm.kinds) if k == "rotary"]
    if not drives:
        return

    @eodarm.custom_effect("gear_wear_both", places="O", parameter="c_rad_per_nmm")
    def gear_wear(state: eodarm.EffectState, i: int, c: float) -> dict[str, np.ndarray]:
        return {"joint_turn_rad": -c * (state.torque_nmm[:, i] - state.torque0_nmm[:, i])}

    try:
        c = data.draw(st.floats(0.0, 1e-8), label="c")
        effects = [eodarm.Effect("gear_wear_both", f"O{i + 1}", c_rad_per_nmm=c) for i in drives]
        rust = eodarm.solve(arm, alpha, mass, effects, backend="rust")
        ref = eodarm.solve(arm, alpha, mass, effects, backend="numpy")
        assert_same(rust, ref, SOLVE_KEYS)
    finally:
        custom.unregister("gear_wear_both")
