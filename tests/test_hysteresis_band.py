"""Compensation says its branch (issue 27 item 2; docs/compensation.md §4, "Which branch").

With friction in the model, ``solve`` and ``compensate`` answer on the loading branch; the
hysteresis band is how far the measure point lands from there when the same payload is
reached by unloading from one heavy enough to reverse every friction element. Checked here:

* the band is the distance of ``solve_sequence``'s states [m, M, m], for any M past the
  threshold 2(L_j + L_b)/|a_i| computed here from the numpy reference's statics and
  geometry (ten times past it: the same; below it: not the far side);
* at the reversing payload eodarm chooses, every element ends on its unloading branch: the
  Coulomb rule's S = x(m) + L·sign(a), read from the forces and the sensors;
* a model without friction (gaps and springs) has no band, and indeed unloading to a payload
  lands where loading does;
* ``compensate --json`` says ``"branch": "loading"`` and gives the band at the commanded pose:
  reached by unloading, the compensated point misses the nominal one by exactly it;
  ``solve --uncertainty`` gives it beside σ; the report says it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

import eodarm
from arms import example_arm
from eodarm.cli import main
from eodarm.model import reference
from eodarm.model.hysteresis import band, reversing_mass

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
POSES = np.array([[90.0, 10.0, 0.0], [70.0, 20.0, -10.0], [110.0, 25.0, 10.0]])
MASS = 5.0
JOINT = eodarm.Effect("joint_friction", "O2", torque_nmm=20000.0)
BODY = eodarm.Effect("actuator_friction", "M3", friction_n=60.0)
#: Both sides solve the same state of the same sequence (the far side does not depend on M):
#: rounding of closures of ~1e3 mm, far below this.
EXACT_MM = 1e-9


def per_kg_and_limits(
    arm: eodarm.Arm, alpha: npt.NDArray[np.float64], effects: list[eodarm.Effect]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(a, L) per pose and actuator, from the numpy reference: a the frictionless force change
    per kg of payload (N/kg), L the limit of every friction element of the actuator in series
    (N): T/r for a joint friction (r the actuator's moment arm about its joint), friction_n
    for the body's."""
    n = arm.n
    payload = np.tile([0.0, -arm.g], (alpha.shape[0], 1))
    st = reference.statics(arm, alpha, payload)
    a = st["force_n"] - st["force0_n"]
    geo = reference.forward(arm, alpha)
    o, pin_a, pin_b = geo["O"][:, :n], geo["A"], geo["B"]
    e = (pin_a - pin_b) / np.linalg.norm(pin_a - pin_b, axis=-1, keepdims=True)
    arm_ = pin_a - o
    r = np.abs(arm_[..., 0] * e[..., 1] - arm_[..., 1] * e[..., 0])
    limit = np.zeros_like(a)
    for eff in effects:
        i = int(eff.at[1:]) - 1
        limit[:, i] += eff.value / r[:, i] if eff.name == "joint_friction" else eff.value
    return a, limit


def threshold(a: npt.NDArray[np.float64], limit: npt.NDArray[np.float64], m: float) -> np.ndarray:
    """The payload beyond which unloading to m reverses every element (per pose)."""
    need = np.where(limit > 0, 2 * limit / np.abs(a), 0.0)
    return np.asarray(m + need.max(axis=1))


def landing(seq: dict[str, np.ndarray], k: int) -> npt.NDArray[np.float64]:
    return np.column_stack([seq["dx_mm"][:, k], seq["dy_mm"][:, k]])


def far_side(arm: eodarm.Arm, alpha: np.ndarray, heavy: np.ndarray, effects: list) -> np.ndarray:
    seq = eodarm.solve_sequence(
        arm, alpha, np.column_stack([0 * heavy + MASS, heavy, 0 * heavy + MASS]), effects
    )
    return np.linalg.norm(landing(seq, 2) - landing(seq, 0), axis=1)


def test_the_band_is_the_far_side_of_the_loop_that_solve_sequence_solves() -> None:
    arm, effects = example_arm(), [JOINT, BODY]
    got = band(arm, POSES, MASS, effects)
    a, limit = per_kg_and_limits(arm, POSES, effects)
    star = threshold(a, limit, MASS)
    assert (got > 0.1).all(), got  # these frictions leave tenths of a millimetre
    for past in (1.01, 10.0):  # anywhere past the threshold: the same state at m
        heavy = MASS + past * (star - MASS)
        np.testing.assert_allclose(got, far_side(arm, POSES, heavy, effects), rtol=0, atol=EXACT_MM)
    short = far_side(arm, POSES, MASS + 0.9 * (star - MASS), effects)  # one element sticks
    assert (np.abs(short - got) > 1e-3).all(), (short, got)


def test_at_the_reversing_payload_every_element_ends_on_its_unloading_branch() -> None:
    """The joint friction's S is the actuator's force change (``dforce_n``); the body
    friction's, through its sensor: ``dl = −S/k``. Loading: the deadband; unloading from M:
    S = x(m) + L·sign(a)."""
    arm, effects = example_arm(), [JOINT, BODY]
    a, limit = per_kg_and_limits(arm, POSES, effects)
    heavy = reversing_mass(arm, POSES, MASS, effects)
    seq = eodarm.solve_sequence(
        arm, POSES, np.column_stack([np.full(3, MASS), heavy, np.full(3, MASS)]), effects
    )
    x = a * MASS
    loading = np.sign(x) * np.maximum(0.0, np.abs(x) - limit)
    unloading = x + limit * np.sign(a)
    k3 = arm.actuators[2].stiffness_n_per_mm
    force = {
        "joint (dforce_n)": (seq["dforce_n"][:, :, 1], 1),
        "body (−k·dl)": (-k3 * seq["dl_mm"][:, :, 2], 2),
    }
    for what, (held, i) in force.items():
        scale = 1e-9 * np.abs(x[:, i]).max()
        np.testing.assert_allclose(held[:, 0], loading[:, i], rtol=0, atol=scale, err_msg=what)
        np.testing.assert_allclose(held[:, 2], unloading[:, i], rtol=0, atol=scale, err_msg=what)
        assert (np.abs(held[:, 2] - held[:, 0]) > 1.9 * limit[:, i]).all(), what  # 2L apart


@pytest.mark.parametrize(
    "effects",
    [
        [],
        [eodarm.Effect("joint_clearance", "O2", clearance_mm=0.15)],
        [
            eodarm.Effect("actuator_play", "M1", play_mm=0.1),
            eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=2500.0),
            eodarm.Effect("joint_clearance", "O3", clearance_mm=0.1, unloaded="taken_up"),
        ],
    ],
    ids=["baseline", "clearance", "gaps and springs"],
)
def test_a_model_without_friction_has_no_band(effects: list[eodarm.Effect]) -> None:
    arm = example_arm()
    assert (band(arm, POSES, MASS, effects) == 0.0).all()
    # and rightly so: the gaps keep no memory, unloading to m lands where loading does
    for heavy in (MASS + 1.0, 3 * MASS + 10.0):
        moved = far_side(arm, POSES, np.full(3, heavy), effects)
        assert (moved <= EXACT_MM).all(), moved


def test_compensate_says_its_branch_and_misses_by_the_band_when_unloaded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The issue's case: with a joint friction the 2σ miss covers the loading branch only; the
    same payload reached by unloading misses by the band."""
    arm = example_arm()
    argv = ["compensate", "--arm", str(EXAMPLE), "--add", "joint_friction@O2=20000"]
    argv += ["--alpha", "90,10,0", "--alpha", "70,20,-10", "--mass", str(MASS)]
    capsys.readouterr()
    assert main([*argv, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["branch"] == "loading"
    command = np.array(doc["alpha_deg"])
    nominal = eodarm.forward(arm, POSES[:2])["measure"]
    a, limit = per_kg_and_limits(arm, command, [JOINT])
    heavy = MASS + 2 * (threshold(a, limit, MASS) - MASS)
    seq = eodarm.solve_sequence(
        arm, command, np.column_stack([np.full(2, MASS), heavy, np.full(2, MASS)]), [JOINT]
    )
    at = eodarm.forward(arm, command)["measure"]
    loaded, unloaded = at + landing(seq, 0), at + landing(seq, 2)
    assert np.linalg.norm(loaded - nominal, axis=1).max() < 1e-6  # compensated: loading
    np.testing.assert_allclose(
        doc["hysteresis_mm"], np.linalg.norm(unloaded - nominal, axis=1), rtol=0, atol=1e-6
    )
    assert main(argv) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "band mm" in text and "on the loading branch" in text


def test_compensate_without_friction_has_no_band_and_says_a_gap_has_no_memory(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["compensate", "--arm", str(EXAMPLE), "--alpha", "90,10,0", "--mass", "5"]
    capsys.readouterr()
    assert main([*argv, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert "branch" not in doc and "hysteresis_mm" not in doc  # springs only: one branch
    gap = ["--add", "joint_clearance@O2=0.15"]
    assert main([*argv, *gap, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["branch"] == "loading" and doc["hysteresis_mm"] == [0.0]
    assert main([*argv, *gap]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "on the loading branch" in text and "keep no memory" in text
    assert "band mm" not in text


@pytest.fixture(scope="module")
def fitted(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The issue's case: a joint friction fitted to load cycles (synthetic, hidden 5 N·m at
    O2), written with its [fit] for --uncertainty."""
    d = tmp_path_factory.mktemp("fitted")
    meas, out = d / "meas.csv", d / "fitted.toml"
    synth = ["synth", "--arm", str(EXAMPLE), "--hidden", "joint_friction@O2=5000"]
    synth += ["--sequence", "0,1.5,5,6.5,5,1.5,0", "--configs", "8", "--seed", "1"]
    assert main([*synth, "-o", str(meas)]) == 0
    fit = ["fit", str(meas), "--arm", str(EXAMPLE), "--add", "joint_friction@O2"]
    assert main([*fit, "-o", str(out)]) == 0
    return out


def test_solve_with_uncertainty_gives_the_band_beside_sigma(
    fitted: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    arm = eodarm.Arm.from_toml(fitted)
    poses = np.array([[90.0, 10.0, 0.0], [70.0, 20.0, -10.0]])
    argv = ["solve", "--arm", str(fitted), "--mass", str(MASS)]
    argv += [a for p in poses for a in ("--alpha", ",".join(map(str, p)))]
    capsys.readouterr()
    assert main([*argv, "--uncertainty", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["branch"] == "loading"
    a, limit = per_kg_and_limits(arm, poses, list(arm.effects))
    heavy = MASS + 2 * (threshold(a, limit, MASS) - MASS)
    want = far_side(arm, poses, heavy, [])
    got = [p["hysteresis_mm"] for p in doc["poses"]]
    np.testing.assert_allclose(got, want, rtol=0, atol=EXACT_MM)
    sigma = [2 * np.hypot(p["sigma_dx_mm"], p["sigma_dy_mm"]) for p in doc["poses"]]
    assert min(got) > 10 * max(sigma)  # what the loading branch's σ does not say
    assert main([*argv, "--uncertainty"]) == 0
    assert "band mm" in capsys.readouterr().out


def test_the_report_gives_the_band_of_a_fitted_model_with_friction(fitted: Path) -> None:
    from eodarm.viz.format import value
    from eodarm.viz.report_summary import _branch_paragraph

    arm = eodarm.Arm.from_toml(fitted)
    html = " ".join(_branch_paragraph(arm, POSES[0], MASS, True))
    width = float(band(arm, POSES[:1], MASS)[0])
    assert "<b>loading branch</b>" in html and value(width, "mm", 3) in html
    assert "2σ of" in html  # beside the σ that does not cover it
    assert _branch_paragraph(example_arm(), POSES[0], MASS, True) == []  # no friction
