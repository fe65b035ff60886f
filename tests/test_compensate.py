"""Compensation: the commanded pose, solved under the payload, puts the measure
point on the nominal one (and keeps the last angle, n >= 3), checked with both solvers; the
arm file's effects are part of the model; poses that cannot be compensated are named, never
returned; bad input gets one clear error; the command line; and the independent check of
issue 12 (fit on data, compensate unseen poses, miss far less under the true arm)."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import eodarm
from arms import example_arm, four_link_core_arm, two_link_arm
from eodarm.analysis.compensate import (
    STATUSES,
    CompensationError,
    CompensationWarning,
    compensate,
)
from eodarm.analysis.synth import random_configs, synth
from eodarm.cli import main
from eodarm.errors import EffectError, InputError
from eodarm.model.effects import Slot

E = eodarm.Effect
ARM_FILE = Path(__file__).resolve().parent.parent / "examples" / "example_arm.toml"

#: Per arm: effects, and nominal poses.
CASES = {
    "two-link": (
        two_link_arm,
        [
            E("mount_compliance", "M2", stiffness_n_per_mm=1500.0),
            E("link_bending", "L1", ei_n_mm2=2e10),
        ],
        [[60.0, 5.0], [80.0, -10.0], [45.0, 20.0]],
    ),
    "example": (
        example_arm,
        [
            E("mount_compliance", "M1", stiffness_n_per_mm=2500.0),
            E("joint_clearance", "O2", clearance_mm=0.15),
            E("base_compliance", "base", stiffness_nmm_per_rad=2e8),
        ],
        [[90.0, 10.0, 0.0], [70.0, 20.0, -10.0], [100.0, -5.0, 5.0]],
    ),
    "four-link": (
        four_link_core_arm,
        [
            E("actuator_compliance", "M3", stiffness_n_per_mm=2500.0),
            E("joint_clearance", "O4", clearance_mm=0.1, unloaded="taken_up"),
        ],
        [[80.0, 20.0, -5.0, -15.0], [70.0, 30.0, 0.0, -10.0]],
    ),
}


def loaded_point(
    arm: eodarm.Arm,
    alpha: np.ndarray,
    mass: np.ndarray | float,
    effects: list[eodarm.Effect],
    backend: str = "rust",
) -> tuple[np.ndarray, np.ndarray]:
    """(loaded measure point (N, 2), loaded last angle (N,)) of unloaded angles ``alpha``."""
    out = eodarm.solve(arm, alpha, mass, effects=effects, backend=backend)
    point = eodarm.forward(arm, alpha)["measure"] + np.column_stack([out["dx_mm"], out["dy_mm"]])
    return point, np.asarray(alpha)[:, -1] + out["dalpha_deg"][:, -1]


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("self_weight", [True, False])
def test_the_compensated_pose_lands_on_the_nominal_point(name: str, self_weight: bool) -> None:
    make, effects, poses = CASES[name]
    arm = make()
    alpha = np.array(poses)
    mass = np.array([6.5, 3.0, 5.0][: len(poses)])
    out = compensate(arm, alpha, mass, effects, self_weight=self_weight)
    assert (out["status"] == "ok").all()
    nominal = eodarm.forward(arm, alpha)["measure"]
    # Checked with both solvers: the numpy reference is an independent implementation.
    for backend in ("rust", "numpy"):
        sol = eodarm.solve(
            arm, out["alpha_deg"], mass, effects=effects, backend=backend, self_weight=self_weight
        )
        point = eodarm.forward(arm, out["alpha_deg"])["measure"]
        point = point + np.column_stack([sol["dx_mm"], sol["dy_mm"]])
        assert np.abs(point - nominal).max() < 1e-6, backend
        if arm.n >= 3:
            last = out["alpha_deg"][:, -1] + sol["dalpha_deg"][:, -1]
            assert np.abs(last - alpha[:, -1]).max() < 1e-7
    # What it removed was worth removing, and the lengths are those of the commanded pose.
    before = eodarm.solve(arm, alpha, mass, effects=effects, self_weight=self_weight)
    assert np.hypot(before["dx_mm"], before["dy_mm"]).min() > 0.1
    assert out["residual_mm"].max() < 1e-6
    np.testing.assert_allclose(
        out["length_mm"], eodarm.forward(arm, out["alpha_deg"])["length_mm"], rtol=0, atol=1e-9
    )
    assert out["iterations"].min() >= 1


def test_four_links_change_the_angles_least() -> None:
    """With a joint to spare, any other commanded pose that also lands is farther away."""
    make, effects, poses = CASES["four-link"]
    arm = make()
    alpha = np.array(poses[:1])
    out = compensate(arm, alpha, 5.0, effects)
    best = np.linalg.norm(out["alpha_deg"][0] - alpha[0])
    # Other solutions: hold joint 1 at a shifted angle and solve the remaining square system
    # (3 conditions, 3 angles) by Newton on the model with finite differences.
    target = eodarm.forward(arm, alpha)["measure"][0]

    def conditions(a: np.ndarray) -> np.ndarray:
        p, last = loaded_point(arm, a[None, :], 5.0, effects)
        return np.r_[p[0] - target, 250.0 * np.radians(last[0] - alpha[0, -1])]

    for shift in (-0.05, -0.01, 0.01, 0.05):
        a = out["alpha_deg"][0].copy()
        a[0] += shift
        for _ in range(20):
            r = conditions(a)
            if np.abs(r).max() < 1e-9:
                break
            jac = np.column_stack(
                [(conditions(a + 1e-6 * np.eye(4)[j]) - r) / 1e-6 for j in (1, 2, 3)]
            )
            a[1:] -= np.linalg.solve(jac, r)
        assert np.abs(conditions(a)).max() < 1e-8
        assert np.linalg.norm(a - alpha[0]) > best


def test_no_payload_without_self_weight_changes_nothing() -> None:
    for make, effects, poses in CASES.values():
        arm = make()
        out = compensate(arm, poses, 0.0, effects, self_weight=False)
        np.testing.assert_array_equal(out["alpha_deg"], np.array(poses))
        np.testing.assert_array_equal(out["iterations"], 0)


def test_the_arm_files_effects_are_part_of_the_model() -> None:
    _, effects, poses = CASES["example"]
    arm = example_arm()
    given = compensate(arm, poses, 5.0, effects)
    fitted = arm.with_effects(effects)
    from_file = compensate(eodarm.Arm.from_dict(fitted.to_dict()), poses, 5.0)
    np.testing.assert_array_equal(from_file["alpha_deg"], given["alpha_deg"])
    # The argument wins over the file's effect at the same place.
    softer = E("mount_compliance", "M1", stiffness_n_per_mm=1000.0)
    over = compensate(fitted, poses, 5.0, [softer])
    want = compensate(arm, poses, 5.0, [softer, *effects[1:]])
    np.testing.assert_array_equal(over["alpha_deg"], want["alpha_deg"])
    assert np.abs(over["alpha_deg"] - given["alpha_deg"]).max() > 1e-3


def test_a_pose_beyond_the_stroke_is_named_and_not_returned() -> None:
    arm = example_arm()
    poses = np.array([[90.0, 10.0, 0.0], [90.0, 10.0, 0.0]])
    length = float(eodarm.forward(arm, poses[:1])["length_mm"][0, 1])
    # Actuator 2 may not move from the nominal length: compensating the payload would leave
    # the stroke; the same pose without payload (nor self-weight) needs no change.
    d = arm.to_dict()
    d["actuator"][1]["min_length_mm"] = length - 1e-6
    d["actuator"][1]["max_length_mm"] = length + 1e-6
    tight = eodarm.Arm.from_dict(d)
    mass = [6.0, 0.0]
    with pytest.warns(CompensationWarning, match=r"1 of 2 poses .* row 0: actuator 2 .* stroke"):
        out = compensate(tight, poses, mass, self_weight=False)
    assert list(out["status"]) == ["out_of_stroke", "ok"]
    assert np.isnan(out["alpha_deg"][0]).all() and np.isnan(out["length_mm"][0]).all()
    np.testing.assert_array_equal(out["alpha_deg"][1], poses[1])
    assert out["actuator"][0] == 2
    with pytest.raises(CompensationError, match="row 0"):
        compensate(tight, poses, mass, self_weight=False, strict=True)


def test_a_near_singular_pose_is_named() -> None:
    arm = example_arm()
    geo = arm.arrays()
    # Actuator 1's line through O1: pin A1 diametrically opposite B0 about O1.
    b0 = np.asarray(geo["B0"]) - np.asarray(geo["O1"])
    a1 = np.asarray(geo["A"][0])
    through = math.degrees(math.atan2(b0[1], b0[0]) - math.atan2(a1[1], a1[0])) + 180.0
    with pytest.warns(CompensationWarning, match=r"row 0: actuator 1 .*dead point.*near_singular"):
        out = compensate(arm, [[through + 0.05, 10.0, 0.0]], 5.0)
    assert out["status"][0] == "near_singular"


def test_statuses_are_the_cores() -> None:
    from eodarm.model import native

    assert tuple(native.COMPENSATE_STATUSES) == STATUSES


def test_one_link_is_reported_as_least_squares() -> None:
    arm = eodarm.Arm.from_dict(
        {
            "name": "boom",
            "base": {"O1": [0.0, 0.0], "B0": [200.0, -60.0]},
            "link": [
                {"next": [700.0, 0.0], "A": [150.0, 40.0], "C": [320.0, -5.0], "mass_kg": 6.0}
            ],
            "actuator": [{"stiffness_n_per_mm": 4000.0, "mass_kg": 2.0}],
        }
    )
    bend = [E("link_bending", "L1", ei_n_mm2=5e9)]
    with pytest.warns(CompensationWarning, match="least-squares"):
        out = compensate(arm, [[20.0]], 10.0, bend)
    before = eodarm.solve(arm, [[20.0]], 10.0, effects=bend)
    assert 1e-3 < out["residual_mm"][0] < np.hypot(before["dx_mm"], before["dy_mm"])[0]


@pytest.mark.parametrize(
    ("alpha", "mass", "effects", "error", "match"),
    [
        ([[90.0, 10.0]], 5.0, None, InputError, r"expected shape \(N, 3\)"),
        ([[90.0, np.nan, 0.0]], 5.0, None, InputError, "pose row 0: alpha_deg"),
        ([[90.0, 10.0, 0.0], [90.0, 10.0, 0.0]], [5.0, -1.0], None, InputError, "row 1"),
        ([[90.0, 10.0, 0.0]], np.inf, None, InputError, "row 0: mass_kg"),
        (
            [[90.0, 10.0, 0.0]],
            5.0,
            [E("joint_clearance", "O5", clearance_mm=0.1)],
            EffectError,
            "O5",
        ),
    ],
)
def test_bad_input_is_one_clear_error(
    alpha: object, mass: object, effects: object, error: type, match: str
) -> None:
    with pytest.raises(error, match=match):
        compensate(example_arm(), alpha, mass, effects)  # type: ignore[arg-type]


def test_bad_options_are_refused() -> None:
    with pytest.raises(InputError, match="jacobian"):
        compensate(example_arm(), [[90.0, 10.0, 0.0]], 5.0, jacobian="exact")
    with pytest.raises(ValueError, match="2 or 3 links"):
        compensate(four_link_core_arm(), [[80.0, 20.0, -5.0, -15.0]], 5.0, jacobian="rigid")


# ------------------------------------------------------------------------- the CLI
def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_json_is_exactly_the_contract(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(
        capsys,
        "compensate",
        "--arm",
        str(ARM_FILE),
        "--alpha",
        "90,10,0",
        "--alpha",
        "70,20,-10",
        "--mass",
        "5",
        "--add",
        "joint_clearance@O2=0.15",
        "--json",
    )
    assert code == 0, err
    doc = json.loads(out)
    # a gap in the model: the answer says its branch (docs/compensation.md §4)
    assert set(doc) == {
        "alpha_deg",
        "length_mm",
        "residual_mm",
        "status",
        "branch",
        "hysteresis_mm",
    }
    arm = eodarm.Arm.from_toml(ARM_FILE)
    want = compensate(
        arm, [[90, 10, 0], [70, 20, -10]], 5.0, [E("joint_clearance", "O2", clearance_mm=0.15)]
    )
    np.testing.assert_allclose(doc["alpha_deg"], want["alpha_deg"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(doc["length_mm"], want["length_mm"], rtol=0, atol=1e-12)
    assert len(doc["residual_mm"]) == 2 and max(doc["residual_mm"]) < 1e-6
    assert doc["status"] == ["ok", "ok"]


def test_cli_reads_a_pose_file_and_writes_the_commands(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    poses = tmp_path / "poses.csv"
    poses.write_text(
        "config,alpha1_deg,alpha2_deg,alpha3_deg,mass_kg,note\na,90,10,0,5,x\nb,70,20,-10,6.5,y\n",
        encoding="utf-8",
    )
    target = tmp_path / "out.csv"
    code, out, err = run(
        capsys, "compensate", "--arm", str(ARM_FILE), "--poses", str(poses), "-o", str(target)
    )
    assert code == 0, err
    assert "wrote" in err and "miss mm" in out
    import csv

    with target.open(encoding="utf-8", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["config"] for r in rows] == ["a", "b"]
    arm = eodarm.Arm.from_toml(ARM_FILE)
    want = compensate(arm, [[90, 10, 0], [70, 20, -10]], [5.0, 6.5])
    got = np.array([[float(r[f"alpha{k}_deg"]) for k in (1, 2, 3)] for r in rows])
    np.testing.assert_array_equal(got, want["alpha_deg"])
    assert [r["status"] for r in rows] == ["ok", "ok"]
    assert float(rows[1]["nominal_alpha3_deg"]) == -10.0


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--alpha", "90,nan,0", "--mass", "5"], "non-finite"),
        (["--alpha", "90,10", "--mass", "5"], "expected 3 angles"),
        (["--alpha", "90,10,0", "--mass", "5", "--add", "bogus@M1=3"], "bogus"),
        (["--alpha", "90,10,0", "--mass", "5", "--add", "joint_clearance@O9=0.1"], "O9"),
        (["--alpha", "90,10,0"], "--mass"),
        (["--mass", "5"], "--alpha"),
        # out of reach: actuator 1's line through O1 (and far outside its stroke)
        (["--alpha=-8.69,10,0", "--mass", "5"], "near_singular|stroke"),
        # commanding the last link past its dead point under a heavy payload
        (["--alpha", "90,10,0", "--mass", "5e4"], "could not be compensated"),
    ],
)
def test_cli_bad_input_exits_2_with_one_line(
    capsys: pytest.CaptureFixture[str], args: list[str], match: str
) -> None:
    code, out, err = run(capsys, "compensate", "--arm", str(ARM_FILE), *args)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("eodarm: error:"), err
    import re

    assert re.search(match, lines[0]), lines[0]


def test_cli_partial_keeps_the_good_poses(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(
        capsys,
        "compensate",
        "--arm",
        str(ARM_FILE),
        "--alpha",
        "90,10,0",
        "--alpha=-8.69,10,0",
        "--mass",
        "5",
        "--json",
        "--partial",
    )
    assert code == 0, err
    doc = json.loads(out)
    assert doc["status"][0] == "ok" and doc["status"][1] != "ok"
    assert doc["alpha_deg"][1] == [None, None, None]
    assert "row 1" in err and "note" in err


# ----------------------------------------------------------- the independent check
def test_compensation_with_a_fitted_model_removes_most_of_the_true_miss() -> None:
    """Issue 12's "done when" on one case (benches/compensation_check.py runs them all, with
    the 2 % target): fit two hidden effects from 16 configurations x 4 payloads, compensate
    60 poses the fit never saw with the FITTED model, solve them with the TRUE arm."""
    arm = example_arm()
    hidden = [
        E("mount_compliance", "M1", stiffness_n_per_mm=2500.0),
        E("joint_clearance", "O2", clearance_mm=0.15),
    ]
    rng = np.random.default_rng(7)
    meas = synth(arm, random_configs(arm, 16, rng), [1.5, 3.0, 5.0, 6.5], hidden=hidden, seed=8)
    fitted = eodarm.fit(arm, meas, [Slot.of(e) for e in hidden]).effects
    alpha = random_configs(arm, 60, rng)
    mass = rng.uniform(0.5, 7.0, 60)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CompensationWarning)  # a pose may not converge
        out = compensate(arm, alpha, mass, fitted)
    ok = out["status"] == "ok"
    assert ok.sum() >= 55
    nominal = eodarm.forward(arm, alpha[ok])["measure"]
    landed, _ = loaded_point(arm, out["alpha_deg"][ok], mass[ok], hidden)
    miss = np.linalg.norm(landed - nominal, axis=1)
    before = eodarm.solve(arm, alpha[ok], mass[ok], effects=hidden)
    miss0 = np.hypot(before["dx_mm"], before["dy_mm"])
    assert np.sqrt(np.mean(miss**2)) <= 0.10 * np.sqrt(np.mean(miss0**2))
    assert miss.max() <= 0.10 * miss0.max()
    # The fit mattered: the baseline model alone (no effects) leaves far more.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CompensationWarning)
        plain = compensate(arm, alpha[ok], mass[ok])
    landed0, _ = loaded_point(arm, plain["alpha_deg"], mass[ok], hidden)
    assert np.linalg.norm(landed0 - nominal, axis=1).max() > 5 * miss.max()
