"""Bad input gets a clear, one-line ValueError naming the key, row, actuator or effect at fault,
from both backends, and the compiled core never panics across the boundary (CONTRACT §2, §5)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import eodarm

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
EXAMPLE_TEXT = EXAMPLE.read_text(encoding="utf-8")
BACKENDS = ("rust", "numpy")
GOOD_POSE = [80.0, 10.0, 0.0]


def refused(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> str:
    """Call ``fn``; it must raise a ValueError (never a panic) with a one-line message."""
    try:
        fn(*args, **kwargs)
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as exc:  # a PanicException is a BaseException, not an Exception
        assert type(exc).__name__ != "PanicException", f"the core panicked: {exc}"
        assert isinstance(exc, ValueError), f"{type(exc).__name__}: {exc}"
        msg = str(exc)
        assert msg.strip(), "empty message"
        assert "\n" not in msg, f"message is not one line: {msg!r}"
        return msg
    raise AssertionError(f"{getattr(fn, '__name__', fn)} accepted bad input")


@pytest.fixture(scope="module")
def arm() -> eodarm.Arm:
    return eodarm.Arm.from_toml(EXAMPLE)


def write_arm(tmp_path: Path, text: str, name: str = "bad_arm.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def edit(text: str, old: str, new: str, count: int = 1) -> str:
    """Replace the first ``count`` occurrences of ``old``, which must exist."""
    assert text.count(old) >= count, old
    return text.replace(old, new, count)


def singular_angle(arm: eodarm.Arm, alpha: list[float], i: int) -> float:
    """Angle of link i (0-based) that puts O_i, B_{i−1} and A_i on one line, the others fixed."""
    geo = eodarm.forward(arm, [alpha])
    d = geo["B"][0, i] - geo["O"][0, i]
    a = arm.links[i].A
    return math.degrees(math.atan2(d[1], d[0]) - math.atan2(a[1], a[0]))


# ---------------------------------------------------------------------------- arm files
def test_bad_toml_syntax_names_the_file(tmp_path: Path) -> None:
    path = write_arm(tmp_path, edit(EXAMPLE_TEXT, "B0 = [250.0, -40.0]", "B0 = [250.0, -40.0"))
    msg = refused(eodarm.Arm.from_toml, path)
    assert str(path) in msg and "TOML" in msg


def test_missing_file_is_named(tmp_path: Path) -> None:
    path = tmp_path / "no_such_arm.toml"
    msg = refused(eodarm.Arm.from_toml, path)
    assert str(path) in msg


LINK2_C = "C = [170.0, -2.0]\n"
ARM_FILE_FAULTS = {
    # id: (old text, new text, key the message must name, occurrence count)
    "missing-link2-C": (LINK2_C, "", "link[2].C"),
    "missing-base-O1": ("O1 = [0.0, 0.0]", "", "base.O1"),
    "missing-actuator-stiffness": (
        "stiffness_n_per_mm = 2500.0",
        "",
        "actuator[2].stiffness_n_per_mm",
    ),
    "nan-mass": ("mass_kg = 2.2", "mass_kg = nan", "link[2].mass_kg"),
    "inf-stiffness": ("stiffness_n_per_mm = 2000.0", "stiffness_n_per_mm = inf", "actuator[3]"),
    "nan-point": ("A = [85.0, -55.0]", "A = [85.0, nan]", "link[2].A"),
    "negative-link-mass": ("mass_kg = 1.3", "mass_kg = -1.3", "link[3].mass_kg"),
    "negative-actuator-mass": ("mass_kg = 1.5", "mass_kg = -1.5", "actuator[1].mass_kg"),
    "zero-stiffness": (
        "stiffness_n_per_mm = 2500.0",
        "stiffness_n_per_mm = 0.0",
        "actuator[2].stiffness_n_per_mm",
    ),
    "negative-stiffness": (
        "stiffness_n_per_mm = 3000.0",
        "stiffness_n_per_mm = -3000.0",
        "actuator[1].stiffness_n_per_mm",
    ),
    "B0-on-O1": ("B0 = [250.0, -40.0]", "B0 = [0.0, 0.0]", "base.B0"),
    "A-on-joint": ("A = [50.0, -40.0]", "A = [0.0, 0.0]", "link[3].A"),
    "B-on-next-joint": ("B = [-40.0, -50.0]", "B = [480.0, 0.0]", "link[1].B"),
    "zero-length-link": ("next = [380.0, 0.0]", "next = [0.0, 0.0]", "link[2].next"),
    "point-not-a-pair": ("C = [220.0, -3.0]", "C = [220.0]", "link[1].C"),
    "mass-not-a-number": ("mass_kg = 3.0", 'mass_kg = "heavy"', "link[1].mass_kg"),
}


@pytest.mark.parametrize("fault", ARM_FILE_FAULTS, ids=list(ARM_FILE_FAULTS))
def test_bad_arm_file_names_file_and_key(tmp_path: Path, fault: str) -> None:
    old, new, key = ARM_FILE_FAULTS[fault]
    path = write_arm(tmp_path, edit(EXAMPLE_TEXT, old, new))
    msg = refused(eodarm.Arm.from_toml, path)
    assert str(path) in msg
    assert f"'{key}" in msg, msg


def test_wrong_count_of_actuator_tables(tmp_path: Path) -> None:
    cut = EXAMPLE_TEXT.rindex("[[actuator]]")
    path = write_arm(tmp_path, EXAMPLE_TEXT[:cut])
    msg = refused(eodarm.Arm.from_toml, path)
    assert str(path) in msg and "'actuator'" in msg
    assert "2 [[actuator]] tables for 3 [[link]] tables" in msg


def test_arm_dict_errors_name_the_key() -> None:
    d = eodarm.Arm.from_toml(EXAMPLE).to_dict()
    del d["link"][1]["C"]
    msg = refused(eodarm.Arm.from_dict, d)
    assert "'link[2].C'" in msg


# ---------------------------------------------------------------------------- arrays
@pytest.mark.parametrize("backend", BACKENDS)
def test_nan_angle_names_the_row(arm: eodarm.Arm, backend: str) -> None:
    alpha = np.array([GOOD_POSE, GOOD_POSE, [80.0, np.nan, 0.0], GOOD_POSE])
    msg = refused(eodarm.solve, arm, alpha, 2.0, backend=backend)
    assert "pose row 2" in msg and "alpha_deg" in msg
    alpha[2, 1] = np.inf
    assert "pose row 2" in refused(eodarm.solve, arm, alpha, 2.0, backend=backend)
    assert "pose row 2" in refused(eodarm.forward, arm, alpha, backend=backend)
    assert "pose row 2" in refused(eodarm.solve_payload, arm, alpha, [0.0, -10.0], backend=backend)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize(
    "alpha",
    [np.zeros((3, 4)), np.zeros((3, 2)), np.zeros((2, 3, 3)), np.zeros(4), "ninety"],
    ids=["too-many-columns", "too-few-columns", "3-d", "wrong-1-d", "text"],
)
def test_wrong_shape_of_alpha(arm: eodarm.Arm, backend: str, alpha: Any) -> None:
    msg = refused(eodarm.solve, arm, alpha, 1.0, backend=backend)
    assert "alpha_deg" in msg
    if isinstance(alpha, np.ndarray):
        assert str(alpha.shape) in msg


@pytest.mark.parametrize("backend", BACKENDS)
def test_wrong_shape_of_mass(arm: eodarm.Arm, backend: str) -> None:
    alpha = np.array([GOOD_POSE] * 3)
    for mass in (np.ones(2), np.ones((3, 1)), np.ones(4)):
        msg = refused(eodarm.solve, arm, alpha, mass, backend=backend)
        assert "mass_kg" in msg and str(mass.shape) in msg


@pytest.mark.parametrize("backend", BACKENDS)
def test_wrong_shape_of_payload(arm: eodarm.Arm, backend: str) -> None:
    alpha = np.array([GOOD_POSE] * 3)
    msg = refused(eodarm.solve_payload, arm, alpha, np.zeros((2, 2)), backend=backend)
    assert "payload_n" in msg
    msg = refused(eodarm.solve_payload, arm, alpha, np.zeros((3, 3)), backend=backend)
    assert "payload_n" in msg


@pytest.mark.parametrize("backend", BACKENDS)
def test_negative_or_nan_mass_names_the_row(arm: eodarm.Arm, backend: str) -> None:
    alpha = np.array([GOOD_POSE] * 4)
    msg = refused(eodarm.solve, arm, alpha, [1.0, -0.5, 2.0, 1.0], backend=backend)
    assert "pose row 1" in msg and "mass_kg" in msg and "negative" in msg
    msg = refused(eodarm.solve, arm, alpha, [1.0, 1.0, 2.0, np.nan], backend=backend)
    assert "pose row 3" in msg and "mass_kg" in msg


# ---------------------------------------------------------------------------- poses
@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("actuator", [1, 2, 3])
def test_actuator_line_through_its_joint_names_row_and_actuator(
    arm: eodarm.Arm, backend: str, actuator: int
) -> None:
    bad = list(GOOD_POSE)
    bad[actuator - 1] = singular_angle(arm, bad, actuator - 1)
    alpha = np.array([GOOD_POSE, GOOD_POSE, bad, GOOD_POSE])
    for self_weight in (True, False):
        msg = refused(eodarm.solve, arm, alpha, 3.0, backend=backend, self_weight=self_weight)
        assert "pose row 2" in msg, msg
        assert f"actuator {actuator}" in msg and f"O{actuator}" in msg, msg
    # the same pose is also refused without any payload (no finite force holds it)
    assert "pose row 2" in refused(eodarm.solve, arm, alpha, 0.0, backend=backend)


@pytest.mark.parametrize("backend", BACKENDS)
def test_first_bad_row_is_named_in_a_large_parallel_batch(arm: eodarm.Arm, backend: str) -> None:
    """The core splits batches above 2048 poses over threads; the lowest bad row is named."""
    rows = 3500
    alpha = np.tile(GOOD_POSE, (rows, 1))
    bad = list(GOOD_POSE)
    bad[1] = singular_angle(arm, bad, 1)
    alpha[[2300, 3100]] = bad
    msg = refused(eodarm.solve, arm, alpha, 1.0, backend=backend)
    assert "pose row 2300" in msg and "actuator 2" in msg


@pytest.mark.parametrize("backend", BACKENDS)
def test_loaded_triangle_that_cannot_close_names_row_and_actuator(backend: str) -> None:
    d = eodarm.Arm.from_toml(EXAMPLE).to_dict()
    d["actuator"][1]["stiffness_n_per_mm"] = 1e-3  # absurdly soft: shortens by ~1e5 mm
    soft = eodarm.Arm.from_dict(d)
    alpha = np.array([GOOD_POSE] * 3)
    msg = refused(eodarm.solve, soft, alpha, [0.0, 5.0, 0.0], backend=backend)
    assert "pose row 1" in msg and "actuator 2" in msg and "close" in msg
    # the unloaded rows alone are fine: nothing deforms without a payload
    out = eodarm.solve(soft, alpha[[0, 2]], 0.0, backend=backend)
    np.testing.assert_allclose(out["dy_mm"], 0.0, atol=1e-9)


@pytest.mark.parametrize(
    "backend",
    [
        "rust",
        "numpy",
    ],
)
def test_pose_with_coincident_actuator_pins_is_refused(backend: str) -> None:
    one = eodarm.Arm.from_dict(
        {
            "base": {"O1": [0.0, 0.0], "B0": [0.0, 100.0]},
            "link": [{"next": [400.0, 0.0], "A": [0.0, 100.0], "C": [200.0, 0.0], "mass_kg": 1.0}],
            "actuator": [{"stiffness_n_per_mm": 1000.0, "mass_kg": 0.0}],
        }
    )
    # alpha = 0 puts A_1 exactly on B_0: the actuator has zero length
    msg = refused(eodarm.solve, one, [[30.0], [0.0]], 1.0, backend=backend)
    assert "pose row 1" in msg and "actuator 1" in msg
    assert "close" not in msg  # the cause is the pose, not a load


def test_both_backends_refuse_the_same_nearly_singular_pose(arm: eodarm.Arm) -> None:
    bad = list(GOOD_POSE)
    bad[0] = singular_angle(arm, bad, 0) + math.degrees(5e-8)  # |h| ≈ 3e-8·|A1 − O1|
    results = {}
    for backend in BACKENDS:
        try:
            eodarm.solve(arm, [bad], 0.0, backend=backend, self_weight=False)
            results[backend] = "solved"
        except ValueError:
            results[backend] = "refused"
    assert results["rust"] == results["numpy"], results


# ---------------------------------------------------------------------------- effects
def test_unknown_effect_name() -> None:
    msg = refused(eodarm.Effect, "joint_wear", "O2", wear=0.1)
    assert "'joint_wear'" in msg and "joint_clearance" in msg  # lists what is known
    msg = refused(eodarm.Effect.parse, "joint_wear@O2", wear=0.1)
    assert "joint_wear" in msg


@pytest.mark.parametrize("backend", BACKENDS)
def test_effect_beyond_the_arm(arm: eodarm.Arm, backend: str) -> None:
    eff = eodarm.Effect("joint_clearance", "O5", clearance_mm=0.1)
    msg = refused(eodarm.solve, arm, [GOOD_POSE], 1.0, [eff], backend=backend)
    assert "joint_clearance@O5" in msg and "3 links" in msg
    eff = eodarm.Effect("link_bending", "L4", ei_n_mm2=1e9)
    assert "link_bending@L4" in refused(eodarm.solve, arm, [GOOD_POSE], 1.0, [eff], backend=backend)


@pytest.mark.parametrize(
    ("name", "at"),
    [
        ("joint_clearance", "M1"),
        ("actuator_play", "O1"),
        ("base_compliance", "O1"),
        ("link_bending", "L0"),
        ("mount_compliance", "Mx"),
    ],
)
def test_effect_at_a_wrong_kind_of_place(name: str, at: str) -> None:
    param = eodarm.CATALOGUE[name].param
    msg = refused(eodarm.Effect, name, at, **{param: 1.0})
    assert name in msg and f"'{at}'" in msg


@pytest.mark.parametrize("backend", BACKENDS)
def test_duplicate_effect(arm: eodarm.Arm, backend: str) -> None:
    effs = [
        eodarm.Effect("actuator_play", "M2", play_mm=0.1),
        eodarm.Effect("joint_clearance", "O2", clearance_mm=0.1),
        eodarm.Effect("actuator_play", "M2", play_mm=0.2),
    ]
    msg = refused(eodarm.solve, arm, [GOOD_POSE], 1.0, effs, backend=backend)
    assert "actuator_play@M2" in msg and "twice" in msg


@pytest.mark.parametrize(
    ("name", "at", "value"),
    [
        ("actuator_play", "M1", -0.1),
        ("joint_clearance", "O3", float("nan")),
        ("actuator_compliance", "M2", 0.0),
        ("mount_compliance", "M1", -500.0),
        ("link_bending", "L2", float("inf")),
        ("base_compliance", "base", float("nan")),
        ("joint_clearance", "O1", "wide"),
    ],
)
def test_bad_effect_parameter(name: str, at: str, value: Any) -> None:
    param = eodarm.CATALOGUE[name].param
    msg = refused(eodarm.Effect, name, at, **{param: value})
    assert f"{name}@{at}" in msg and param in msg


def test_effect_with_wrong_parameter_name() -> None:
    msg = refused(eodarm.Effect, "joint_clearance", "O2", play_mm=0.1)
    assert "joint_clearance@O2" in msg and "clearance_mm" in msg


@pytest.mark.parametrize("backend", BACKENDS)
def test_bending_of_a_link_with_its_pin_on_the_joint_axis(backend: str) -> None:
    one = eodarm.Arm.from_dict(
        {
            "base": {"O1": [0.0, 0.0], "B0": [200.0, -100.0]},
            "link": [{"next": [500.0, 0.0], "A": [0.0, 60.0], "C": [250.0, 0.0], "mass_kg": 1.0}],
            "actuator": [{"stiffness_n_per_mm": 1000.0, "mass_kg": 0.0}],
        }
    )
    eff = [eodarm.Effect("link_bending", "L1", ei_n_mm2=1e9)]
    msg = refused(eodarm.solve, one, [[30.0]], 1.0, eff, backend=backend)
    assert "link_bending@L1" in msg


def test_effects_must_be_effect_values(arm: eodarm.Arm) -> None:
    msg = refused(eodarm.solve, arm, [GOOD_POSE], 1.0, ["joint_clearance@O2"])
    assert "joint_clearance@O2" in msg


# ---------------------------------------------------------------------------- backends
def test_unknown_backend_in_solve(arm: eodarm.Arm) -> None:
    msg = refused(eodarm.solve, arm, [GOOD_POSE], 1.0, backend="fortran")
    assert "'fortran'" in msg and "backend" in msg
    msg = refused(eodarm.solve_payload, arm, [GOOD_POSE], [0.0, -9.81], backend="Rust")
    assert "'Rust'" in msg


def test_unknown_backend_in_forward(arm: eodarm.Arm) -> None:
    assert "'fortran'" in refused(eodarm.forward, arm, [GOOD_POSE], backend="fortran")


def test_unknown_backend_in_angles_from_lengths(arm: eodarm.Arm) -> None:
    lengths = eodarm.forward(arm, [GOOD_POSE])["length_mm"]
    msg = refused(eodarm.angles_from_lengths, arm, lengths, GOOD_POSE, backend="fortran")
    assert "'fortran'" in msg


def test_unknown_backend_in_inverse_kinematics(arm: eodarm.Arm) -> None:
    msg = refused(eodarm.inverse_kinematics, arm, [[600.0, 500.0, 0.0]], backend="fortran")
    assert "'fortran'" in msg


# ---------------------------------------------------------------------------- kinematics
@pytest.mark.parametrize("backend", BACKENDS)
def test_lengths_that_cannot_close_name_row_and_actuator(arm: eodarm.Arm, backend: str) -> None:
    lengths = eodarm.forward(arm, [GOOD_POSE] * 3)["length_mm"]
    lengths[2, 1] = 5000.0
    msg = refused(eodarm.angles_from_lengths, arm, lengths, GOOD_POSE, backend=backend)
    assert "pose row 2" in msg and "actuator 2" in msg


@pytest.mark.parametrize(
    "backend",
    [
        "rust",
        "numpy",
    ],
)
def test_negative_length_is_refused(arm: eodarm.Arm, backend: str) -> None:
    lengths = eodarm.forward(arm, [GOOD_POSE] * 2)["length_mm"]
    lengths[1, 0] *= -1.0
    msg = refused(eodarm.angles_from_lengths, arm, lengths, GOOD_POSE, backend=backend)
    assert "pose row 1" in msg and "actuator 1" in msg


@pytest.mark.parametrize("backend", BACKENDS)
def test_inverse_kinematics_input_errors(arm: eodarm.Arm, backend: str) -> None:
    msg = refused(
        eodarm.inverse_kinematics, arm, [[600.0, 500.0, 0.0], [np.nan, 0, 0]], backend=backend
    )
    assert "pose row 1" in msg and "target" in msg
    assert "elbow" in refused(
        eodarm.inverse_kinematics, arm, [[600.0, 500.0, 0.0]], 0, backend=backend
    )
    two = eodarm.Arm.from_dict(
        {
            "base": {"O1": [0.0, 0.0], "B0": [200.0, -100.0]},
            "link": [
                {
                    "next": [400.0, 0.0],
                    "A": [90.0, 40.0],
                    "B": [-40.0, -40.0],
                    "C": [200.0, 0.0],
                    "mass_kg": 1.0,
                },
                {"next": [300.0, 0.0], "A": [60.0, -30.0], "C": [150.0, 0.0], "mass_kg": 1.0},
            ],
            "actuator": [{"stiffness_n_per_mm": 1000.0, "mass_kg": 0.0}] * 2,
        }
    )
    msg = refused(eodarm.inverse_kinematics, two, [[600.0, 500.0, 0.0]], backend=backend)
    assert "3-link" in msg and "2 links" in msg
