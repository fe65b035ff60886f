"""Diagnosis and fitting on synthetic data: hidden effects are found, parameters recovered,
nothing is invented, sets beat greedy choices, confusions are named, outliers are caught."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import eodarm
from arms import ARMS, example_arm
from eodarm.analysis.diagnose import all_slots, diagnose
from eodarm.analysis.fit import FitWarning, cross_validate, fit
from eodarm.analysis.synth import random_configs, synth
from eodarm.model.effects import Slot

MASSES = [1.5, 3.0, 5.0, 6.5]
ARMS_FILE = Path(__file__).resolve().parent.parent / "examples" / "example_arm.toml"


def hidden_value(arm: eodarm.Arm, slot: Slot) -> float:
    """A size of each effect that a real arm could have and the data can see."""
    i = slot.index(arm.n)
    return {
        "actuator_compliance": arm.actuators[i].stiffness_n_per_mm / 2.5,
        "mount_compliance": arm.actuators[i].stiffness_n_per_mm * 0.8,
        "actuator_play": 0.08,
        "joint_clearance": 0.12,
        "link_bending": 2e9,
        "base_compliance": 4e7,
    }[slot.name]


def configs(arm: eodarm.Arm, k: int = 12, seed: int = 7) -> np.ndarray:
    return random_configs(arm, k, np.random.default_rng(seed))


# the catalogue's effects as the contract states them (gaps centred when unloaded)
CASES = [
    (name, s.key)
    for name, mk in ARMS.items()
    for s in all_slots(mk().n, taken_up=False, custom=False)
]


@pytest.mark.parametrize(("arm_name", "key"), CASES)
def test_hidden_effect_is_found_first_and_recovered(arm_name: str, key: str) -> None:
    arm = ARMS[arm_name]()
    slot = Slot.parse(key)
    value = hidden_value(arm, slot)
    hidden = eodarm.Effect(slot.name, slot.at, **{slot.kind.param: value})
    meas = synth(arm, configs(arm), MASSES, hidden=[hidden], seed=11)
    d = diagnose(arm, meas, advise=False)
    assert d.verdict == "missing"
    top = d.ranking[0]
    assert top.slot == slot, f"{key} hidden, {top.slot.key} ranked first"
    assert top.fit.estimate(0) == pytest.approx(value, rel=0.10)
    assert 0.7 < top.fit.chi2_per_dof < 1.4
    assert d.baseline.chi2_per_dof > 3.0  # the effect was visible at all
    assert [s.key for s in d.suggested] == [key]


@pytest.mark.parametrize("arm_name", list(ARMS))
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_nothing_missing_gives_adequate(arm_name: str, seed: int) -> None:
    arm = ARMS[arm_name]()
    meas = synth(arm, configs(arm, seed=seed), MASSES, hidden=[], seed=seed)
    d = diagnose(arm, meas, advise=False)
    assert d.verdict == "adequate"
    assert d.suggested == []
    assert d.to_json()["suggested"] == []


def test_model_with_the_effect_already_in_is_adequate() -> None:
    arm = example_arm()
    hidden = eodarm.Effect("joint_clearance", "O2", clearance_mm=0.15)
    meas = synth(arm, configs(arm), MASSES, hidden=[hidden], seed=3)
    d = diagnose(arm, meas, model=["joint_clearance@O2"], advise=False)
    assert d.verdict == "adequate"
    assert d.baseline.estimate(0) == pytest.approx(0.15, rel=0.05)
    assert "joint_clearance@O2" not in {c.slot.key for c in d.ranking}
    # every candidate but the model's own clearance, centred or taken up
    assert len(d.ranking) == len(all_slots(3)) - 2


def test_two_hidden_effects_found_together_although_a_third_is_best_alone() -> None:
    arm = example_arm()
    hidden = [
        eodarm.Effect("actuator_play", "M2", play_mm=0.08),
        eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=6e7),
    ]
    cfg = random_configs(arm, 16, np.random.default_rng(1))
    meas = synth(arm, cfg, MASSES, hidden=hidden, channels=["dx_mm", "dy_mm", "dalpha"], seed=5)
    d = diagnose(arm, meas, advise=False)
    keys = {e.key for e in hidden}
    assert d.verdict == "missing"
    assert d.ranking[0].slot.key not in keys, "the premise: a third effect is best alone"
    assert {s.key for s in d.suggested} == keys
    f = d.suggested_fit
    assert f is not None
    est = {s.key: f.estimate(i) for i, s in enumerate(f.slots)}
    assert est["actuator_play@M2"] == pytest.approx(0.08, rel=0.1)
    assert est["base_compliance@base"] == pytest.approx(6e7, rel=0.1)
    assert f.chi2_per_dof < 1.4


def test_soft_mount_and_soft_actuator_are_confused_without_dl() -> None:
    arm = example_arm()
    hidden = [eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1500.0)]
    cfg = random_configs(arm, 16, np.random.default_rng(1))
    meas = synth(arm, cfg, MASSES, hidden=hidden, channels=["dx_mm", "dy_mm", "dalpha"], seed=3)
    d = diagnose(arm, meas)
    first, second = d.ranking[0], d.ranking[1]
    assert {first.slot.key, second.slot.key} == {"mount_compliance@M2", "actuator_compliance@M2"}
    assert second.slot.key in first.confused_with
    assert first.slot.key in second.confused_with
    # Ties go to the effect that does not overrule the arm file's actuator stiffness.
    assert first.slot.key == "mount_compliance@M2"
    # The advice names the channel that separates them: actuator 2's own sensor.
    assert d.advice and d.advice[0]["channel"]["channel"] == "dl2_mm"
    # With that channel measured the confusion is gone and the right one wins.
    meas_dl = synth(arm, cfg, MASSES, hidden=hidden, seed=3)
    d2 = diagnose(arm, meas_dl, advise=False)
    assert d2.ranking[0].slot.key == "mount_compliance@M2"
    assert d2.ranking[0].confused_with == []


def test_a_typo_is_named_as_outlier_and_does_not_drag_the_fit() -> None:
    arm = example_arm()
    hidden = [eodarm.Effect("joint_clearance", "O3", clearance_mm=0.2)]
    meas = synth(arm, configs(arm), MASSES, hidden=hidden, seed=9)
    values = np.array(meas.values)
    r, c = 17, meas.channels.index("dy_mm")
    values[r, c] *= 10  # a misplaced decimal point
    bad = eodarm.Measurements.from_arrays(
        config=meas.config,
        alpha_deg=meas.alpha_deg,
        mass_kg=meas.mass_kg,
        values={ch: values[:, j] for j, ch in enumerate(meas.channels)},
        sigma={ch: meas.sigma[:, j] for j, ch in enumerate(meas.channels)},
    )
    d = diagnose(arm, bad, advise=False)
    assert [o["line"] for o in d.outliers] == [int(bad.line[r])]
    assert d.outliers[0]["channel"] == "dy_mm"
    assert [s.key for s in d.suggested] == ["joint_clearance@O3"]
    assert d.suggested_fit is not None
    assert d.suggested_fit.estimate(0) == pytest.approx(0.2, rel=0.05)
    assert d.suggested_fit.chi2_per_dof < 1.4


def test_standard_errors_match_the_scatter_of_estimates() -> None:
    arm = example_arm()
    cfg = configs(arm, k=6)
    true = 0.1
    hidden = [eodarm.Effect("joint_clearance", "O2", clearance_mm=true)]
    z = []
    for seed in range(30):
        meas = synth(arm, cfg, MASSES, hidden=hidden, seed=seed, noise=4.0)
        res = fit(arm, meas, ["joint_clearance@O2"])
        z.append((res.estimate(0) - true) / res.stderr(0))
    z = np.array(z)
    assert abs(z.mean()) < 0.8
    assert 0.6 < z.std() < 1.5


def test_parameter_stuck_at_bound_warns() -> None:
    arm = example_arm()
    meas = synth(arm, configs(arm), MASSES, hidden=[], seed=2)
    with pytest.warns(FitWarning, match="stuck at"):
        res = fit(arm, meas, ["joint_clearance@O1", "joint_clearance@O2", "link_bending@L3"])
    assert any(res.at_bound)


def test_cross_validation_predicts_held_out_configurations() -> None:
    arm = example_arm()
    hidden = [eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=2000.0)]
    meas = synth(arm, configs(arm, k=8), MASSES, hidden=hidden, seed=4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        base = cross_validate(arm, meas, [])
        good = cross_validate(arm, meas, ["mount_compliance@M1"])
    assert set(good["per_config"]) == set(meas.configs)
    # Held-out error falls to the noise level (σ = 0.02 mm) with the right effect.
    assert good["rms"]["dy_mm"] < 0.03 < base["rms"]["dy_mm"]


def test_error_falls_when_the_effect_is_added() -> None:
    arm = ARMS["seed-like"]()
    hidden = [eodarm.Effect("joint_clearance", "O3", clearance_mm=0.25)]
    meas = synth(arm, configs(arm), MASSES, hidden=hidden, seed=1)
    before = fit(arm, meas, [])
    after = fit(arm, meas, ["joint_clearance@O3"])
    assert after.rms()["dy_mm"] < 0.1 * before.rms()["dy_mm"]
    assert after.chi2_per_dof < 1.4 < before.chi2_per_dof


# ------------------------------------------------------------------------- the CLI
def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", "import sys; from eodarm.cli import main; sys.exit(main())", *args],
        capture_output=True,
        text=True,
        check=False,
    )


@pytest.fixture(scope="module")
def two_hidden_csv(tmp_path_factory: pytest.TempPathFactory) -> str:
    arm = example_arm()
    hidden = [
        eodarm.Effect("joint_clearance", "O2", clearance_mm=0.15),
        eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=2500.0),
    ]
    meas = synth(arm, configs(arm), MASSES, hidden=hidden, seed=4)
    path = tmp_path_factory.mktemp("cli") / "meas.csv"
    meas.to_csv(path)
    return str(path)


def test_cli_diagnose_json_is_exactly_the_contract(two_hidden_csv: str) -> None:
    out = run_cli("diagnose", two_hidden_csv, "--arm", str(ARMS_FILE), "--json")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    # every key of the contract, plus "noise" (where each channel's sigma came from)
    assert set(doc) == {"model", "baseline", "verdict", "suggested", "ranking", "noise"}
    assert doc["noise"]["dy_mm"] == {"sigma": None, "source": "given", "dof": None}
    assert set(doc["baseline"]) == {"rms", "chi2_per_dof"}
    assert doc["verdict"] == "missing"
    assert set(doc["suggested"]) == {"joint_clearance@O2", "mount_compliance@M1"}
    # 16 effects × places, and the 6 gaps (play, clearance) taken up when unloaded
    assert len(doc["ranking"]) == 22
    for entry in doc["ranking"]:
        keys = {"effect", "at", "estimate", "rms", "chi2_per_dof", "confused_with"}
        if entry.get("unloaded") == "taken_up":
            keys.add("unloaded")
        assert set(entry) == keys
    chi = [e["chi2_per_dof"] for e in doc["ranking"]]
    assert chi == sorted(chi)


def test_cli_fit_json_with_cv(two_hidden_csv: str) -> None:
    out = run_cli(
        "fit",
        two_hidden_csv,
        "--arm",
        str(ARMS_FILE),
        "--add",
        "joint_clearance@O2",
        "--add",
        "mount_compliance@M1",
        "--cv",
        "config",
        "--json",
    )
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert set(doc) == {"effects", "before", "after", "cv"}
    est = {e["effect"] + "@" + e["at"]: e for e in doc["effects"]}
    assert est["joint_clearance@O2"]["estimate"]["clearance_mm"] == pytest.approx(0.15, rel=0.05)
    assert est["mount_compliance@M1"]["estimate"]["stiffness_n_per_mm"] == pytest.approx(
        2500, rel=0.1
    )
    assert doc["after"]["chi2_per_dof"] < 1.4 < doc["before"]["chi2_per_dof"]
    assert doc["cv"]["rms"]["dy_mm"] < 0.05


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("diagnose", "missing.csv"), "missing.csv"),
        (("fit", "{csv}", "--add", "joint_clearance@O9"), "O9"),
        (("fit", "{csv}", "--add", "spring@M1"), "spring@M1"),
        (("diagnose", "{csv}", "--arm", "nope.toml"), "nope.toml"),
    ],
)
def test_cli_bad_input_exits_2_with_one_line(
    two_hidden_csv: str, args: tuple[str, ...], needle: str
) -> None:
    out = run_cli(*(a.format(csv=two_hidden_csv) for a in args))
    assert out.returncode == 2
    assert out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0]


def test_standard_errors_of_parameters_of_very_different_scale() -> None:
    """θ of play (mm) and of bending (1/EI ~ 1e-9) fitted together: each error is right."""
    arm = example_arm()
    hidden = [
        eodarm.Effect("actuator_play", "M3", play_mm=0.05),
        eodarm.Effect("link_bending", "L2", ei_n_mm2=5e8),
    ]
    meas = synth(arm, configs(arm), MASSES, hidden=hidden, seed=8)
    both = fit(arm, meas, ["actuator_play@M3", "link_bending@L2"])
    se_play, se_bend = both.stderr(0), both.stderr(1)
    # An unscaled covariance once reported ±1e-20 mm here; the truth is ~1e-4 mm.
    assert 1e-5 < se_play < 1e-2, se_play
    assert 0 < se_bend < 0.2 * 5e8
    assert abs(both.estimate(0) - 0.05) < 5 * se_play
    assert abs(both.estimate(1) - 5e8) < 5 * se_bend


def test_cli_compare_writes_every_residual(two_hidden_csv: str, tmp_path: Path) -> None:
    res = tmp_path / "res.csv"
    out = run_cli(
        "compare",
        two_hidden_csv,
        "--arm",
        str(ARMS_FILE),
        "--add",
        "joint_clearance@O2",
        "--add",
        "mount_compliance@M1",
        "--residuals",
        str(res),
        "--json",
    )
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    table = np.genfromtxt(res, delimiter=",", names=True, dtype=None, encoding="utf-8")
    meas = eodarm.read_measurements(two_hidden_csv, 3)
    assert len(table) == meas.n_rows
    # each residual is measured minus model, and their RMS is the one reported
    np.testing.assert_allclose(table["residual_dy_mm"], table["dy_mm"] - table["model_dy_mm"])
    rms = float(np.sqrt(np.mean(table["residual_dy_mm"] ** 2)))
    assert rms == pytest.approx(doc["rms"]["dy_mm"], rel=1e-9)
