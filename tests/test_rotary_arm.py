"""The arm file with rotary drives (docs/formats.md §1): reading, refusing, warning, writing back,
the arrays the solvers read, and the effects that belong to each kind of joint."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.errors import ArmFileError, EffectError
from eodarm.model.arm import Actuator, Arm, RotaryDrive
from eodarm.model.effects import Effect, candidate_places, check_kinds, effect_arrays
from strategies import arm_dicts

ROOT = Path(__file__).resolve().parents[1]
ROTARY = ROOT / "examples" / "rotary_arm.toml"
MIXED = ROOT / "examples" / "mixed_arm.toml"
LINEAR = ROOT / "examples" / "example_arm.toml"
LINEAR_KEYS = ("stiffness_n_per_mm", "min_length_mm", "max_length_mm", "max_force_n")
ROTARY_KEYS = ("stiffness_nmm_per_rad", "max_torque_nmm", "min_angle_deg", "max_angle_deg")


def mixed_dict() -> dict[str, Any]:
    """Two links: a drive at the shoulder, a linear actuator at the elbow."""
    return {
        "name": "two",
        "base": {"O1": [0.0, 0.0]},
        "link": [
            {"next": [500.0, 0.0], "B": [100.0, 60.0], "C": [250.0, 0.0], "mass_kg": 3.0},
            {"next": [400.0, 0.0], "A": [-80.0, -50.0], "C": [200.0, 0.0], "mass_kg": 2.0},
        ],
        "actuator": [
            {"kind": "rotary", "stiffness_nmm_per_rad": 3e7, "mass_kg": 2.5},
            {"stiffness_n_per_mm": 5000.0, "mass_kg": 1.0},
        ],
    }


def refusal(d: dict[str, Any], key: str) -> str:
    """The one-line message that refuses ``d``, checked to name the source and ``key``."""
    with pytest.raises(ArmFileError) as exc:
        Arm.from_dict(d, source="arm.toml")
    msg = str(exc.value)
    assert msg.startswith("arm.toml: ") and f"'{key}'" in msg, msg
    assert "\n" not in msg and len(msg) < 300, msg
    return msg


# ---------------------------------------------------------------------------- reading
def test_the_rotary_example_reads_as_three_drives() -> None:
    arm = Arm.from_toml(ROTARY)
    assert arm.kinds == ("rotary",) * 3
    assert all(isinstance(a, RotaryDrive) and a.kind == "rotary" for a in arm.actuators)
    assert arm.B0 is None and all(lk.A is None and lk.B is None for lk in arm.links)
    shoulder = arm.actuators[0]
    assert isinstance(shoulder, RotaryDrive)
    assert (shoulder.stiffness_nmm_per_rad, shoulder.mass_kg) == (4.0e7, 3.6)
    assert (shoulder.min_angle_deg, shoulder.max_angle_deg) == (-30.0, 150.0)
    assert arm.is_rotary(2) and not arm.is_linear(2)


def test_the_mixed_example_keeps_the_pins_its_linear_joints_use() -> None:
    arm = Arm.from_toml(MIXED)
    assert arm.kinds == ("rotary", "linear", "linear")
    assert arm.B0 is None
    assert arm.links[0].A is None and arm.links[0].B == (300.0, 120.0)
    assert arm.links[1].A == (-120.0, 80.0) and arm.links[2].B is None
    assert isinstance(arm.actuators[1], Actuator) and arm.actuators[1].kind == "linear"
    assert arm.linear(1).stiffness_n_per_mm == 12000.0
    with pytest.raises(eodarm.InputError, match="joint 1 is turned by a rotary drive"):
        arm.linear(0)


def test_arrays_carry_kind_stiffness_in_its_unit_and_rotary_limits() -> None:
    d = Arm.from_toml(MIXED).arrays()
    np.testing.assert_array_equal(d["kind"], [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(d["stiffness"], [8.0e7, 12000.0, 8000.0])
    np.testing.assert_array_equal(d["max_torque"], [6.0e5, np.nan, np.nan])
    np.testing.assert_array_equal(d["min_angle_deg"], [-20.0, np.nan, np.nan])
    np.testing.assert_array_equal(d["max_angle_deg"], [120.0, np.nan, np.nan])
    # unused pins are zeros (kind says they are unused)
    np.testing.assert_array_equal(d["B0"], [0.0, 0.0])
    np.testing.assert_array_equal(d["A"][0], [0.0, 0.0])
    np.testing.assert_array_equal(d["B"][2], [0.0, 0.0])
    for key in ("kind", "stiffness", "max_torque", "min_angle_deg", "max_angle_deg"):
        assert d[key].dtype == np.float64 and d[key].shape == (3,)


def test_a_linear_arm_is_unchanged() -> None:
    arm = Arm.from_toml(LINEAR)
    assert arm.kinds == ("linear",) * 3
    d = arm.arrays()
    np.testing.assert_array_equal(d["kind"], 0.0)
    assert np.isnan(d["max_torque"]).all() and np.isnan(d["min_angle_deg"]).all()
    np.testing.assert_array_equal(d["B0"], arm.B0)
    # its file is written without a `kind` key, exactly as before
    assert all("kind" not in a for a in arm.to_dict()["actuator"])
    assert 'kind = "rotary"' not in arm.to_toml()


def test_rotary_drive_is_exported() -> None:
    assert eodarm.RotaryDrive is RotaryDrive and "RotaryDrive" in eodarm.__all__
    drive = eodarm.RotaryDrive(2e7, 1.5, max_torque_nmm=5e4)
    assert drive.kind == "rotary" and drive.min_angle_deg is None
    with pytest.raises(TypeError):
        eodarm.RotaryDrive(2e7, 1.5, kind="linear")  # type: ignore[call-arg]


# ---------------------------------------------------------------------------- writing back
@pytest.mark.parametrize("path", [ROTARY, MIXED, LINEAR], ids=lambda p: p.stem)
def test_writing_back_reads_the_same_arm(path: Path) -> None:
    arm = Arm.from_toml(path)
    text = arm.to_toml()
    back = Arm.from_dict(tomllib.loads(text), source=str(path))
    assert back == arm
    assert back.to_toml() == text
    # over its own file as a template, the text is kept whole (comments included)
    original = path.read_text()
    assert arm.to_toml(template=original) == original


@settings(max_examples=150, deadline=None)
@given(d=arm_dicts(st.integers(1, 7), rotary=True))
def test_any_mixed_arm_written_back_reads_the_same(d: dict[str, Any]) -> None:
    arm = Arm.from_dict(d)
    assert arm.kinds == tuple(a.get("kind", "linear") for a in d["actuator"])
    back = Arm.from_dict(tomllib.loads(arm.to_toml()))
    assert back == arm and back.arrays().keys() == arm.arrays().keys()
    for key, value in arm.arrays().items():
        np.testing.assert_array_equal(back.arrays()[key], value, err_msg=key)


def test_effects_written_over_a_rotary_template_keep_its_comments() -> None:
    arm = Arm.from_toml(ROTARY)
    fitted = arm.with_effects([Effect("drive_compliance", "O2", stiffness_nmm_per_rad=9e6)])
    text = fitted.to_toml(template=ROTARY.read_text())
    assert "# drive 2, elbow: mounted on link 1 at O2" in text
    back = Arm.from_dict(tomllib.loads(text))
    assert back.effects == fitted.effects and back.actuators == arm.actuators


# ---------------------------------------------------------------------------- refusals
@pytest.mark.parametrize("key", LINEAR_KEYS)
def test_a_linear_actuators_key_on_a_rotary_drive_is_refused(key: str) -> None:
    d = mixed_dict()
    d["actuator"][0][key] = 100.0
    msg = refusal(d, f"actuator[1].{key}")
    assert "linear actuator's key" in msg and "stiffness_nmm_per_rad" in msg


@pytest.mark.parametrize("key", ROTARY_KEYS)
def test_a_rotary_drives_key_on_a_linear_actuator_is_refused(key: str) -> None:
    d = mixed_dict()
    d["actuator"][1][key] = 100.0
    msg = refusal(d, f"actuator[2].{key}")
    assert "rotary drive's key" in msg and "stiffness_n_per_mm" in msg


def test_a_drive_without_its_stiffness_is_refused() -> None:
    d = mixed_dict()
    del d["actuator"][0]["stiffness_nmm_per_rad"]
    assert "missing" in refusal(d, "actuator[1].stiffness_nmm_per_rad")


@pytest.mark.parametrize(
    ("where", "key", "shown"),
    [
        (("link", 1), "A", "link[2].A"),  # joint 2 is linear: its pin on link 2
        (("link", 0), "B", "link[1].B"),  # joint 2 is linear: its base pin on link 1
    ],
)
def test_a_pin_that_a_linear_joint_needs_is_required(where, key, shown) -> None:
    d = mixed_dict()
    table, i = where
    del d[table][i][key]
    msg = refusal(d, shown)
    assert "missing" in msg and "joint 2 is a linear actuator" in msg


def test_b0_is_required_when_joint_1_is_linear() -> None:
    d = mixed_dict()
    d["actuator"][0] = {"stiffness_n_per_mm": 4000.0, "mass_kg": 1.0}
    d["link"][0]["A"] = [90.0, 50.0]
    assert "joint 1 is a linear actuator" in refusal(d, "base.B0")
    d["base"]["B0"] = [200.0, -60.0]
    assert Arm.from_dict(d).B0 == (200.0, -60.0)


@pytest.mark.parametrize(
    ("change", "key", "why"),
    [
        ({"kind": "revolute"}, "actuator[1].kind", 'must be "linear" or "rotary"'),
        ({"kind": 1}, "actuator[1].kind", 'must be "linear" or "rotary"'),
        ({"stiffness_nmm_per_rad": 0.0}, "actuator[1].stiffness_nmm_per_rad", "> 0"),
        ({"stiffness_nmm_per_rad": math.inf}, "actuator[1].stiffness_nmm_per_rad", "finite"),
        ({"stiffness_nmm_per_rad": 1e21}, "actuator[1].stiffness_nmm_per_rad", "physical range"),
        ({"max_torque_nmm": -5.0}, "actuator[1].max_torque_nmm", "> 0"),
        ({"min_angle_deg": 30.0, "max_angle_deg": 10.0}, "actuator[1].min_angle_deg", "exceeds"),
        ({"max_angle_deg": 270.0}, "actuator[1].max_angle_deg", "physical range"),
        ({"mass_kg": -1.0}, "actuator[1].mass_kg", ">= 0"),
        ({"stiffnes_nmm_per_rad": 1.0}, "actuator[1].stiffnes_nmm_per_rad", "did you mean"),
    ],
)
def test_bad_drive_values_are_refused_naming_the_key(change, key, why) -> None:
    d = mixed_dict()
    d["actuator"][0].update(change)
    assert why in refusal(d, key)


# ---------------------------------------------------------------------------- warnings
@pytest.mark.parametrize(
    ("where", "value", "shown"),
    [
        (("base", None, "B0"), [200.0, -60.0], "base.B0"),
        (("link", 0, "A"), [90.0, 40.0], "link[1].A"),
        (("link", 1, "B"), [90.0, 40.0], None),  # last link: its own warning
    ],
)
def test_a_pin_no_actuator_uses_is_ignored_with_a_warning(where, value, shown) -> None:
    d = mixed_dict()
    table, i, key = where
    (d[table] if i is None else d[table][i])[key] = value
    with pytest.warns(UserWarning) as rec:
        arm = Arm.from_dict(d, source="arm.toml")
    (msg,) = [str(w.message) for w in rec]
    assert msg.startswith("arm.toml: ") and "ignored" in msg and len(msg) < 300
    if shown is not None:
        assert f"'{shown}'" in msg and "rotary drive" in msg
    assert arm == Arm.from_dict(mixed_dict(), source="arm.toml")


def test_a_b_pin_before_a_rotary_joint_is_ignored() -> None:
    d = mixed_dict()
    d["actuator"][1] = {"kind": "rotary", "stiffness_nmm_per_rad": 1e7, "mass_kg": 1.0}
    with pytest.warns(UserWarning, match=r"'link\[1\].B' is ignored: joint 2 is turned by a rot"):
        with pytest.warns(UserWarning, match=r"'link\[2\].A' is ignored"):
            arm = Arm.from_dict(d)
    assert arm.links[0].B is None and arm.links[1].A is None


# ---------------------------------------------------------------------------- effects
def test_drive_effects_are_in_the_catalogue() -> None:
    cat = eodarm.CATALOGUE
    assert cat["drive_compliance"].param == "stiffness_nmm_per_rad"
    assert cat["drive_backlash"].param == "backlash_deg"
    assert cat["drive_friction"].param == "torque_nmm"
    assert all(cat[k].place_letter == "O" for k in ("drive_compliance", "drive_backlash"))
    taken = Effect("drive_backlash", "O2", backlash_deg=0.1, unloaded="taken_up")
    assert (
        taken.spec == "drive_backlash@O2:taken_up"
        and taken.code != Effect("drive_backlash", "O2", backlash_deg=0.1).code
    )
    with pytest.raises(EffectError, match="only actuator_play, joint_clearance, drive_backlash"):
        Effect("drive_friction", "O1", torque_nmm=1.0, unloaded="taken_up")
    with pytest.raises(EffectError, match="sits at O1…On"):
        Effect("drive_compliance", "M1", stiffness_nmm_per_rad=1e7)


@pytest.mark.parametrize(
    ("effect", "there"),
    [
        (Effect("actuator_compliance", "M1", stiffness_n_per_mm=500.0), "drive_compliance@O1"),
        (Effect("mount_compliance", "M1", stiffness_n_per_mm=500.0), "drive_compliance@O1"),
        (Effect("actuator_play", "M1", play_mm=0.1), "drive_backlash@O1"),
        (Effect("actuator_friction", "M1", friction_n=10.0), "drive_friction@O1"),
        (Effect("drive_compliance", "O2", stiffness_nmm_per_rad=1e7), "actuator_compliance@M2"),
        (Effect("drive_backlash", "O2", backlash_deg=0.1), "actuator_play@M2"),
        (Effect("drive_friction", "O2", torque_nmm=100.0), "actuator_friction@M2"),
    ],
    ids=lambda x: x.key if isinstance(x, Effect) else x,
)
def test_an_effect_at_a_joint_of_the_wrong_kind_is_refused(effect: Effect, there: str) -> None:
    arm = Arm.from_dict(mixed_dict())
    with pytest.raises(EffectError) as exc:
        check_kinds([effect], arm.kinds)
    msg = str(exc.value)
    assert effect.key in msg and f"use {there}" in msg and len(msg) < 300
    with pytest.raises(EffectError, match=there):
        effect_arrays([effect], arm.n, arm.kinds)
    # and in an arm file's [[effect]] table, naming the file and the table
    d = mixed_dict() | {"effect": [effect.to_table()]}
    assert there in refusal(d, "effect[1].at")


def test_effects_that_fit_any_joint_and_candidate_places_by_kind() -> None:
    kinds = Arm.from_dict(mixed_dict()).kinds
    check_kinds(
        [
            Effect("joint_clearance", "O1", clearance_mm=0.1),
            Effect("joint_friction", "O2", torque_nmm=100.0),
            Effect("link_bending", "L1", ei_n_mm2=1e10),
            Effect("drive_compliance", "O1", stiffness_nmm_per_rad=1e7),
            Effect("actuator_play", "M2", play_mm=0.1),
        ],
        kinds,
    )
    assert candidate_places("drive_backlash", 2, kinds) == ["O1"]
    assert candidate_places("actuator_play", 2, kinds) == ["M2"]
    assert candidate_places("joint_clearance", 2, kinds) == ["O1", "O2"]
    # without kinds every place (the catalogue's form alone)
    assert candidate_places("drive_backlash", 2) == ["O1", "O2"]
