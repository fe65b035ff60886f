"""A fitted model in the arm file (docs/formats.md §2): ``[[effect]]`` and ``[fit]`` tables."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

import eodarm
from eodarm.errors import ArmFileError
from eodarm.model.arm import FitRecord

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
MOUNT = eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1512.0)
CLEAR = eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15)


@pytest.fixture(scope="module")
def arm() -> eodarm.Arm:
    return eodarm.Arm.from_toml(EXAMPLE)


def test_effect_tables_are_read_into_arm_effects(arm: eodarm.Arm, tmp_path: Path) -> None:
    text = arm.to_toml() + (
        '\n[[effect]]\neffect = "mount_compliance"\nat = "M2"\nstiffness_n_per_mm = 1512.0\n'
        "stderr = 35.0\n"
        '\n[[effect]]\neffect = "joint_clearance"\nat = "O3"\nclearance_mm = 0.15\n'
    )
    path = tmp_path / "fitted.toml"
    path.write_text(text)
    fitted = eodarm.Arm.from_toml(path)
    assert fitted.effects == (MOUNT, CLEAR)
    assert fitted.effect_stderr == (35.0, None)
    assert fitted.fit is None


def test_to_toml_keeps_effects_errors_and_the_fit_record(arm: eodarm.Arm) -> None:
    rec = FitRecord(
        parameters=("mount_compliance@M2:stiffness_n_per_mm", "joint_clearance@O3:clearance_mm"),
        covariance=((1225.0, -0.02), (-0.02, 4e-6)),
        data="meas.csv",
        data_sha256="ab" * 32,
        chi2_per_dof=1.04,
        n_values=96,
        date="2026-11-23T21:00:00+00:00",
    )
    fitted = arm.with_effects([MOUNT, CLEAR], [35.0, 0.002], fit=rec)
    back = eodarm.Arm.from_dict(tomllib.loads(fitted.to_toml()))
    assert back == fitted  # effects, errors and the fit record, to the last digit
    assert back.fit is not None
    np.testing.assert_array_equal(back.fit.matrix(), np.array(rec.covariance))


def test_with_effects_replaces_the_same_place_and_drops_a_stale_fit(arm: eodarm.Arm) -> None:
    rec = FitRecord(("mount_compliance@M2:stiffness_n_per_mm",), ((1.0,),))
    first = arm.with_effects([MOUNT], [35.0], fit=rec)
    softer = MOUNT.with_value(900.0)
    second = first.with_effects([softer, CLEAR])
    assert second.effects == (softer, CLEAR)
    assert second.effect_stderr == (None, None)
    assert second.fit is None, "a covariance of other values must not travel with new ones"


@pytest.mark.parametrize(
    ("table", "key", "why"),
    [
        ('effect = "mount"\nat = "M1"\nstiffness_n_per_mm = 1.0', "effect[1].effect", "unknown"),
        ("at = 'M1'\nstiffness_n_per_mm = 1.0", "effect[1].effect", "missing"),
        ('effect = "mount_compliance"\nat = "O1"\nstiffness_n_per_mm = 1.0', "effect[1].at", ""),
        ('effect = "mount_compliance"\nat = "M7"\nstiffness_n_per_mm = 1.0', "effect[1].at", "3"),
        ('effect = "mount_compliance"\nat = "M1"\nstiffness = 1.0', "effect[1].stiffness", ""),
        ('effect = "mount_compliance"\nat = "M1"', "effect[1].stiffness_n_per_mm", "missing"),
        (
            'effect = "mount_compliance"\nat = "M1"\nstiffness_n_per_mm = -1.0',
            "effect[1].stiffness_n_per_mm",
            "> 0",
        ),
        (
            'effect = "mount_compliance"\nat = "M1"\nstiffness_n_per_mm = "stiff"',
            "effect[1].stiffness_n_per_mm",
            "number",
        ),
        (
            'effect = "joint_clearance"\nat = "O1"\nclearance_mm = 0.1\nstderr = -1.0',
            "effect[1].stderr",
            ">= 0",
        ),
    ],
)
def test_a_wrong_effect_table_is_refused_naming_its_index_and_key(
    arm: eodarm.Arm, table: str, key: str, why: str
) -> None:
    text = arm.to_toml() + "\n[[effect]]\n" + table + "\n"
    with pytest.raises(ArmFileError, match=rf"fitted\.toml: key .{re.escape(key)}.: .*{why}"):
        eodarm.Arm.from_dict(tomllib.loads(text), source="fitted.toml")


def test_the_same_effect_twice_is_refused(arm: eodarm.Arm) -> None:
    text = arm.to_toml() + "".join(
        f'\n[[effect]]\neffect = "joint_clearance"\nat = "O3"\nclearance_mm = {c}\n'
        for c in (0.1, 0.2)
    )
    with pytest.raises(ArmFileError, match=r"key 'effect\[2\]\.at'.*twice"):
        eodarm.Arm.from_dict(tomllib.loads(text), source="fitted.toml")


@pytest.mark.parametrize(
    ("fit", "key"),
    [
        ('parameters = ["mount_compliance@M1:stiffness_n_per_mm"]\ncovariance = [[1.0]]', "fit"),
        (
            'parameters = ["mount_compliance@M2:stiffness_n_per_mm"]\ncovariance = [[1.0, 2.0]]',
            "fit",
        ),
        ('parameters = ["mount_compliance@M2:stiffness_n_per_mm"]\ncovariance = [[-1.0]]', "fit"),
        ('parameters = ["mount_compliance@M2:stiffness_n_per_mm"]\ncovariance = [["a"]]', "fit"),
    ],
)
def test_a_wrong_fit_table_is_refused(arm: eodarm.Arm, fit: str, key: str) -> None:
    text = arm.with_effects([MOUNT]).to_toml() + "\n[fit]\n" + fit + "\n"
    with pytest.raises(ArmFileError, match=rf"key '{key}"):
        eodarm.Arm.from_dict(tomllib.loads(text), source="fitted.toml")


POSES = np.array([[90.0, 10.0, 0.0], [70.0, 20.0, -5.0], [100.0, 0.0, 5.0]])


@pytest.mark.parametrize("backend", ["rust", "numpy"])
def test_every_solver_includes_the_files_effects(arm: eodarm.Arm, backend: str) -> None:
    fitted = arm.with_effects([MOUNT, CLEAR])
    got = eodarm.solve(fitted, POSES, 5.0, backend=backend)
    want = eodarm.solve(arm, POSES, 5.0, [MOUNT, CLEAR], backend=backend)
    for key in ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "force_n"):
        np.testing.assert_array_equal(got[key], want[key], err_msg=key)
    # effects= come on top; the same effect@place replaces the file's value
    softer = MOUNT.with_value(400.0)
    over = eodarm.solve(fitted, POSES, 5.0, [softer], backend=backend)
    ref = eodarm.solve(arm, POSES, 5.0, [CLEAR, softer], backend=backend)
    np.testing.assert_allclose(over["dy_mm"], ref["dy_mm"], rtol=0, atol=1e-12)
    assert not np.allclose(over["dy_mm"], got["dy_mm"])


def test_a_sweep_includes_the_files_effects(arm: eodarm.Arm) -> None:
    grid = {"alpha1": [80.0, 90.0], "alpha2": [10.0], "alpha3": [0.0, 5.0]}
    got = eodarm.sweep(arm.with_effects([MOUNT]), alpha_deg=grid, mass_kg=[5.0], progress=False)
    want = eodarm.sweep(arm, alpha_deg=grid, mass_kg=[5.0], effects=[MOUNT], progress=False)
    np.testing.assert_allclose(got["dy_mm"].values, want["dy_mm"].values, rtol=0, atol=1e-12)


def test_fit_and_compare_hold_the_files_effects_and_refit_them_when_asked(
    arm: eodarm.Arm,
) -> None:
    from eodarm.analysis.fit import compare, fit
    from eodarm.analysis.synth import random_configs, synth

    alpha = random_configs(arm, 12, np.random.default_rng(5))
    meas = synth(arm, alpha, [1.5, 5.0, 6.5], hidden=[MOUNT, CLEAR], seed=5)
    # the file carries the clearance: fitting only the mount then explains the data
    with_clear = arm.with_effects([CLEAR])
    res = fit(with_clear, meas, ["mount_compliance@M2"])
    assert res.chi2_per_dof < 2.0
    assert abs(res.estimate(0) - 1512.0) < 3 * res.stderr(0)
    # compare of the file's full model is as good, with nothing fitted
    full = arm.with_effects([MOUNT, CLEAR])
    assert compare(full, meas).chi2_per_dof < 2.0
    assert compare(arm, meas).chi2_per_dof > 10.0
    # --add of an effect the file has refits it, starting from the file's value
    wrong = arm.with_effects([CLEAR.with_value(0.4), MOUNT])
    again = fit(wrong, meas, ["joint_clearance@O3"])
    assert abs(again.estimate(0) - 0.15) < 3 * again.stderr(0)


# ---------------------------------------------------------------------------- fit → -o → use
@pytest.fixture(scope="module")
def fitted(arm: eodarm.Arm, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A fit of two hidden effects, written with ``eodarm fit -o``."""
    from eodarm.analysis.synth import random_configs, synth
    from eodarm.cli import main

    d = tmp_path_factory.mktemp("fitted")
    alpha = random_configs(arm, 16, np.random.default_rng(8))
    meas = synth(arm, alpha, [1.5, 5.0, 6.5], hidden=[MOUNT, CLEAR], seed=8)
    meas.to_csv(d / "m.csv")
    (d / "arm.toml").write_text(arm.to_toml())
    args = ["fit", str(d / "m.csv"), "--arm", str(d / "arm.toml")]
    args += ["--add", "mount_compliance@M2", "--add", "joint_clearance@O3"]
    assert main([*args, "-o", str(d / "fitted.toml")]) == 0
    return {"dir": d, "args": args, "meas": meas}


def test_a_fitted_file_solves_to_exactly_the_fits_model(arm: eodarm.Arm, fitted: dict) -> None:
    from eodarm.analysis.fit import compare, fit

    res = fit(arm, fitted["meas"], ["mount_compliance@M2", "joint_clearance@O3"])
    back = eodarm.Arm.from_toml(fitted["dir"] / "fitted.toml")
    assert back.effects == tuple(res.effects)  # the values, to the last digit
    assert back.fit is not None and back.fit.data == "m.csv"
    assert back.fit.chi2_per_dof == pytest.approx(res.chi2_per_dof, rel=1e-12)
    # its predictions are the fit's (the fit's come from the sensitivity path of the core,
    # the file's from the solver: the same physics, round-off apart)
    np.testing.assert_allclose(
        compare(back, fitted["meas"]).prediction, res.prediction, rtol=0, atol=1e-9
    )
    # the same numbers through solve, sweep and the CLI
    want = eodarm.solve(arm, POSES, 5.0, list(res.effects))
    np.testing.assert_array_equal(eodarm.solve(back, POSES, 5.0)["dy_mm"], want["dy_mm"])


def test_fit_json_carries_the_covariance_and_correlation(
    fitted: dict, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    from eodarm.cli import main

    assert main([*fitted["args"], "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["parameters"] == [
        "mount_compliance@M2:stiffness_n_per_mm",
        "joint_clearance@O3:clearance_mm",
    ]
    cov = np.array(doc["covariance"])
    corr = np.array(doc["correlation"])
    np.testing.assert_allclose(cov, cov.T, rtol=1e-12)
    np.testing.assert_allclose(np.diag(corr), 1.0)
    sd = [
        e["stderr"][p.split(":")[1]] for e, p in zip(doc["effects"], doc["parameters"], strict=True)
    ]
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), sd, rtol=1e-9)
    assert doc["undetermined"] == []


def test_predicted_sigma_matches_monte_carlo_sampling_of_the_parameters(fitted: dict) -> None:
    """Linear propagation of the fitted covariance against 3000 models drawn from it: within
    10 % (the Monte-Carlo estimate of a σ itself scatters by 1/√(2·3000) ≈ 1.3 %)."""
    back = eodarm.Arm.from_toml(fitted["dir"] / "fitted.toml")
    got = eodarm.solve(back, POSES, 6.5, uncertainty=True)
    assert back.fit is not None
    keys = [p.split(":")[0] for p in back.fit.parameters]
    mean = {e.key: e for e in back.effects}
    rng = np.random.default_rng(0)
    draws = rng.multivariate_normal([mean[k].value for k in keys], back.fit.matrix(), 3000)
    dy, dx, da = [], [], []
    for p in draws:
        out = eodarm.solve(
            back, POSES, 6.5, [mean[k].with_value(v) for k, v in zip(keys, p, strict=True)]
        )
        dy.append(out["dy_mm"])
        dx.append(out["dx_mm"])
        da.append(out["dalpha_deg"])
    np.testing.assert_allclose(got["sigma_dy_mm"], np.std(dy, axis=0), rtol=0.10)
    np.testing.assert_allclose(got["sigma_dx_mm"], np.std(dx, axis=0), rtol=0.10)
    mc = np.std(da, axis=0)
    big = mc > 1e-3 * mc.max()
    np.testing.assert_allclose(got["sigma_dalpha_deg"][big], mc[big], rtol=0.10)


def test_uncertainty_needs_a_fitted_file(arm: eodarm.Arm) -> None:
    with pytest.raises(eodarm.InputError, match=r"no fit.*eodarm fit .* -o"):
        eodarm.solve(arm, POSES, 5.0, uncertainty=True)


@pytest.mark.parametrize(
    ("keys", "where"),
    [
        ('determined = false\nbound = "sideways"\nlimit = 100.0\n', "effect[1].bound"),
        ('determined = false\nbound = "lower"\n', "effect[1].limit"),
        ('bound = "lower"\nlimit = 100.0\n', "effect[1].determined"),
        ("determined = 0\n", "effect[1].determined"),
    ],
)
def test_a_bad_mark_of_an_undetermined_effect_is_refused_naming_the_key(
    arm: eodarm.Arm, tmp_path: Path, keys: str, where: str
) -> None:
    path = tmp_path / "fitted.toml"
    path.write_text(
        arm.to_toml()
        + '\n[[effect]]\neffect = "mount_compliance"\nat = "M2"\nstiffness_n_per_mm = 1e20\n'
        + keys
    )
    with pytest.raises(ArmFileError, match=re.escape(f"key '{where}'")):
        eodarm.Arm.from_toml(path)


def test_a_bounded_effect_reads_back_marked_and_round_trips(arm: eodarm.Arm) -> None:
    from eodarm.model.arm import EffectMark

    rigid = MOUNT.with_value(1e20)
    mark = EffectMark(determined=False, bound="lower", limit=20000.0)
    fitted = arm.with_effects([rigid, CLEAR], [None, 0.002], marks=[mark, None])
    back = eodarm.Arm.from_dict(tomllib.loads(fitted.to_toml()))
    assert back == fitted
    assert back.bounded() == [(rigid, mark)]


def test_a_template_of_another_arm_is_not_used(arm: eodarm.Arm) -> None:
    # the comments of an arm file are kept only when the file describes the same arm
    other = "# another arm\n" + arm.replace(B0=(240.0, -35.0)).to_toml()
    fitted = arm.with_effects([MOUNT], [35.0])
    assert fitted.to_toml(other) == fitted.to_toml()
    same = "# Masses are ASSUMED\n" + arm.to_toml()
    kept = fitted.to_toml(same)
    assert kept.startswith("# Masses are ASSUMED\n")
    assert eodarm.Arm.from_dict(tomllib.loads(kept)) == fitted
