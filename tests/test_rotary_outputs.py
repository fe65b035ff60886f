"""What a solve of an arm with rotary drives returns (docs/model.md §10), on the numpy
reference: torques where there are drives and NaN where there are none (and the reverse for
the actuators' outputs), the statuses of a drive (its angle range and torque limit), and what
user-written effects read (``EffectState.torque_nmm``) and return (``joint_turn_rad``)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.errors import CustomEffectError, InputError
from eodarm.model import custom
from eodarm.model import reference as ref
from eodarm.model.solver import statics
from eodarm.model.validity import STATUS
from strategies import effects_for, mixed_arm_and_poses

ROOT = Path(__file__).resolve().parents[1]
ROTARY = ROOT / "examples" / "rotary_arm.toml"
MIXED = ROOT / "examples" / "mixed_arm.toml"
LINEAR = ROOT / "examples" / "example_arm.toml"
POSE = [[30.0, 0.0, -20.0]]
BY_KIND = {
    "linear": ("force_n", "dforce_n", "dl_mm", "dlength_mm", "length_mm"),
    "rotary": ("torque_nmm", "dtorque_nmm"),
}


# ---------------------------------------------------------------------------- NaN by kind
@settings(max_examples=80, deadline=None)
@given(case=mixed_arm_and_poses(), data=st.data())
def test_each_joint_reports_the_outputs_of_its_kind_and_nan_for_the_other(case, data) -> None:
    arm, alpha, mass = case
    effects = data.draw(effects_for(arm, tuple(eodarm.CATALOGUE)), label="effects")
    out = eodarm.solve(arm, alpha, mass, effects, backend="numpy")
    assert set(out) == {*BY_KIND["linear"], *BY_KIND["rotary"]} | {
        "reaction_n",
        "dx_mm",
        "dy_mm",
        "dalpha_deg",
        "status",
    }
    for i, kind in enumerate(arm.kinds):
        other = "rotary" if kind == "linear" else "linear"
        for key in BY_KIND[kind]:
            assert np.isfinite(out[key][:, i]).all(), (key, i)
        for key in BY_KIND[other]:
            assert np.isnan(out[key][:, i]).all(), (key, i)
    assert np.isfinite(out["reaction_n"]).all() and np.isfinite(out["dalpha_deg"]).all()
    # without frictions, the change is loaded minus unloaded
    if not any(e.name.endswith("_friction") for e in effects):
        st_ = eodarm.solve(arm, alpha, 0.0, effects, backend="numpy", self_weight=True)
        payload = np.column_stack([np.zeros_like(mass), -mass * arm.g])
        t = ref.statics(arm, alpha, payload)
        np.testing.assert_allclose(
            out["dtorque_nmm"], t["torque_nmm"] - t["torque0_nmm"], rtol=1e-9, atol=1e-6
        )
        assert st_["dtorque_nmm"].shape == out["torque_nmm"].shape


def test_a_linear_arm_has_nan_torques() -> None:
    arm = eodarm.Arm.from_toml(LINEAR)
    out = eodarm.solve(arm, [[90.0, 10.0, 0.0]], 5.0, backend="numpy")
    assert np.isnan(out["torque_nmm"]).all() and np.isnan(out["dtorque_nmm"]).all()
    assert np.isfinite(out["force_n"]).all()
    fwd = ref.forward(eodarm.Arm.from_toml(MIXED), POSE)
    assert np.isnan(fwd["A"][0, 0]).all() and np.isnan(fwd["B"][0, 0]).all()
    assert np.isnan(fwd["length_mm"][0, 0]) and np.isfinite(fwd["length_mm"][0, 1:]).all()


# ---------------------------------------------------------------------------- statuses
def status_of(arm: eodarm.Arm, alpha: Any, mass: Any, **kw: Any) -> list[str]:
    out = eodarm.solve(arm, alpha, mass, backend="numpy", **kw)
    return [STATUS[c] for c in out["status"]]


def with_drive(path: Path, j: int, **keys: float) -> eodarm.Arm:
    d = eodarm.Arm.from_toml(path).to_dict()
    d["actuator"][j].update(keys)
    return eodarm.Arm.from_dict(d)


def test_a_torque_above_the_drives_limit_is_over_force_either_sign() -> None:
    arm = eodarm.Arm.from_toml(ROTARY)
    t = eodarm.solve(arm, POSE * 2, [5.0, 20.0], backend="numpy")["torque_nmm"][:, 0]
    limit = 0.5 * (t[0] + t[1])  # between the two loaded torques
    capped = with_drive(ROTARY, 0, max_torque_nmm=limit)
    assert status_of(capped, POSE * 2, [5.0, 20.0]) == ["ok", "over_force"]
    # reaching back over the chassis the shoulder holds the arm with a negative torque
    back = [[150.0, 0.0, 0.0]]
    t_back = eodarm.solve(arm, back, 5.0, backend="numpy")["torque_nmm"][0, 0]
    assert t_back < 0
    assert status_of(with_drive(ROTARY, 0, max_torque_nmm=-0.9 * t_back), back, 5.0) == [
        "over_force"
    ]


def test_a_drive_outside_its_angle_range_is_out_of_stroke_unloaded_or_loaded() -> None:
    """Drive 1's range starts at −30°: a pose at −40° is out unloaded; at −29.99° it is in
    unloaded but the payload turns it below −30°; without any load it stays in."""
    arm = eodarm.Arm.from_toml(ROTARY)
    poses = [[-40.0, -40.0, -40.0], [-29.99, -29.99, -29.99], [-29.99, -29.99, -29.99]]
    got = status_of(arm, poses, [1.0, 5.0, 0.0], self_weight=False)
    assert got == ["out_of_stroke", "out_of_stroke", "ok"]
    dq = eodarm.solve(arm, poses[1:2], 5.0, backend="numpy")["dalpha_deg"][0, 0]
    assert dq < -0.01  # the loaded angle is below the range
    # q2 = α2 − α1 is taken in [−180°, 180°): 120° then −160° is q2 = 80°, inside ±160°
    assert status_of(arm, [[120.0, -160.0, -160.0]], 1.0) == ["ok"]
    assert status_of(arm, [[10.0, -165.0, -165.0]], 1.0) == ["out_of_stroke"]


@pytest.mark.parametrize("backend", ["rust", "numpy"])
def test_a_drive_on_its_limit_is_in_range_and_just_past_it_is_out(backend: str) -> None:
    """A range closed to one angle, q2 ∈ [14°, 14°], with q2 = 100.45° − 86.45° (14° to
    rounding, ~1e-14° either side): inside, unloaded and with no load to turn it, on both
    backends (ANGLE_TOL_DEG = 1e-9°); 1e-6° past the limit, out."""
    arm = with_drive(ROTARY, 1, min_angle_deg=14.0, max_angle_deg=14.0)
    on = [[86.44997272, 100.44997272, 100.44997272]]
    past = [[86.44997272, 100.44997372, 100.44997372]]
    out = eodarm.solve(arm, on + past, 0.0, backend=backend, self_weight=False)
    assert not np.asarray(out["dalpha_deg"]).any()  # no load: nothing turns
    assert [STATUS[c] for c in out["status"]] == ["ok", "out_of_stroke"]


def test_a_drive_has_no_moment_arm_to_be_near_singular() -> None:
    """The mixed example's drive at any angle is fine; its linear joints are judged as
    before (actuator 2's line brought through O2 is near singular; strokes unlimited)."""
    d = eodarm.Arm.from_toml(MIXED).to_dict()
    for a in d["actuator"][1:]:
        del a["min_length_mm"], a["max_length_mm"]
    arm = eodarm.Arm.from_dict(d)
    assert (
        status_of(arm, [[q, q - 20.0, q - 40.0] for q in (-10.0, 45.0, 100.0)], 2.0) == ["ok"] * 3
    )
    geo = ref.forward(arm, [[30.0, 0.0, 0.0]])
    b1 = geo["B"][0, 1] - geo["O"][0, 1]  # actuator 2's base pin, from O2
    pin = np.array(arm.links[1].A)
    a2 = math.degrees(math.atan2(b1[1], b1[0]) - math.atan2(pin[1], pin[0])) + 180.0
    assert status_of(arm, [[30.0, a2 + 1.0, a2 - 20.0]], 2.0) == ["near_singular"]


# ---------------------------------------------------------------------------- user effects
@pytest.fixture
def registered() -> Iterator[list[str]]:
    names: list[str] = []
    yield names
    for name in names:
        custom.unregister(name)


def test_a_user_effect_reads_torques_and_turns_the_joint(registered: list[str]) -> None:
    """A user's extra gear compliance c (rad per N·mm) returning joint_turn_rad = −c·ΔT is the
    drive's compliance 1/k + c: the same arm as drive_compliance with k′ = 1/(1/k + c)."""
    seen: dict[str, np.ndarray] = {}

    @eodarm.custom_effect("gear_wear", places="O", parameter="c_rad_per_nmm", start=1e-8)
    def gear_wear(state: eodarm.EffectState, i: int, c: float) -> dict[str, Any]:
        seen["torque"], seen["force"] = state.torque_nmm, state.force_n
        return {"joint_turn_rad": -c * (state.torque_nmm[:, i] - state.torque0_nmm[:, i])}

    registered.append("gear_wear")
    arm = eodarm.Arm.from_toml(MIXED)
    alpha, mass, c = [[30.0, 0.0, -20.0], [60.0, 20.0, 0.0]], [3.0, 6.0], 2e-8
    user = eodarm.solve(
        arm, alpha, mass, [eodarm.Effect("gear_wear", "O1", c_rad_per_nmm=c)], backend="numpy"
    )
    k = arm.actuators[0].stiffness_nmm_per_rad  # type: ignore[union-attr]
    both = eodarm.Effect("drive_compliance", "O1", stiffness_nmm_per_rad=1.0 / (1.0 / k + c))
    built = eodarm.solve(arm, alpha, mass, [both], backend="numpy")
    for key in ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm"):
        np.testing.assert_allclose(user[key], built[key], rtol=0, atol=1e-9, err_msg=key)
    st_ = ref.statics(arm, alpha, np.column_stack([np.zeros(2), -np.array(mass) * arm.g]))
    np.testing.assert_array_equal(seen["torque"], st_["torque_nmm"])
    assert np.isnan(seen["torque"][:, 1:]).all() and np.isnan(seen["force"][:, 0]).all()


@pytest.mark.parametrize(
    ("key", "place", "value"),
    [("actuator_mm", "O1", 0.1), ("actuator_unseen_mm", "O1", 0.0), ("joint_turn_rad", "O2", 1e-4)],
)
def test_a_user_key_of_the_other_kind_is_refused(registered: list[str], key, place, value):
    """actuator_mm at the drive (joint 1 of the mixed arm), joint_turn_rad at an actuator
    (joint 2): one line naming the effect, its place and the key, even for a zero value."""
    name = f"wrong_{key}"

    @eodarm.custom_effect(name, places="O", parameter="x")
    def wrong(state: eodarm.EffectState, i: int, x: float) -> dict[str, Any]:
        return {key: np.full(state.n_states, value)}

    registered.append(name)
    arm = eodarm.Arm.from_toml(MIXED)
    with pytest.raises(CustomEffectError) as exc:
        eodarm.solve(arm, POSE, 2.0, [eodarm.Effect(name, place, x=1.0)], backend="numpy")
    msg = str(exc.value)
    assert f"{name}@{place}" in msg and repr(key) in msg and "\n" not in msg and len(msg) < 300


def test_extra_deformations_of_the_other_kind_are_refused() -> None:
    arm = eodarm.Arm.from_toml(MIXED)
    turn = np.zeros((1, 3))
    turn[0, 2] = 1e-4
    with pytest.raises(InputError, match=r"pose row 0: extra_turn_rad is nonzero at joint 3"):
        eodarm.solve(arm, POSE, 2.0, backend="numpy", extra={"extra_turn_rad": turn})
    seen = np.zeros((1, 3))
    seen[0, 0] = 0.1
    with pytest.raises(
        InputError, match=r"extra_seen_mm is nonzero at joint 1, which is turned by a rotary"
    ):
        eodarm.solve(arm, POSE, 2.0, backend="numpy", extra={"extra_seen_mm": seen})
    # a turn at the drive turns link 1 and everything beyond it rigidly about O1
    turn = np.array([[1e-3, 0.0, 0.0]])
    base = eodarm.solve(arm, POSE, 2.0, backend="numpy")
    moved = eodarm.solve(arm, POSE, 2.0, backend="numpy", extra={"extra_turn_rad": turn})
    np.testing.assert_allclose(
        moved["dalpha_deg"] - base["dalpha_deg"], math.degrees(1e-3), rtol=1e-6
    )


def test_effect_state_of_a_linear_arm_has_nan_torques() -> None:
    arm = eodarm.Arm.from_toml(LINEAR)
    alpha = [[90.0, 10.0, 0.0]] * 2
    st_ = statics(arm, alpha, [1.0, 2.0], backend="numpy")
    state = custom.EffectState.from_statics(arm, alpha, [[0.0, -9.81], [0.0, -19.62]], st_)
    assert state.torque_nmm.shape == (2, 3) and np.isnan(state.torque_nmm).all()
    assert np.isnan(state.rows(np.array([1])).torque0_nmm).all()
    assert not state.torque_nmm.flags.writeable


def test_a_turn_at_a_linear_actuator_is_refused_on_either_backend() -> None:
    """The compiled core of a linear arm has no drive to turn: the solver refuses the turn
    rather than drop it."""
    arm = eodarm.Arm.from_toml(LINEAR)
    turn = np.array([[0.0, 1e-4, 0.0]])
    for backend in ("rust", "numpy"):
        with pytest.raises(InputError, match=r"extra_turn_rad is nonzero at joint 2"):
            eodarm.solve(
                arm, [[90.0, 10.0, 0.0]], 1.0, backend=backend, extra={"extra_turn_rad": turn}
            )
