"""The Python API as good as the command line (docs/python.md): short reprs and notebook
tables, a fit's parameters by name, the fitted arm that predicts with uncertainty (the σ of
``eodarm solve --uncertainty`` on the file ``eodarm fit -o`` writes), the bundled data as
``eodarm.datasets``, ``read_measurements(path, arm)`` and one pose broadcast over payloads.
"""

from __future__ import annotations

import json
import math
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from arms import example_arm
from eodarm.analysis.fit import FitWarning, compare
from eodarm.analysis.synth import random_configs, synth
from eodarm.data.measurements import Measurements
from strategies import arm_and_poses, masses

MOUNT = eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=2500.0)
CLEAR = eodarm.Effect("joint_clearance", "O2", clearance_mm=0.15)
MODEL = ["mount_compliance@M1", "joint_clearance@O2"]
POSES = np.array([[90.0, 10.0, 0.0], [70.0, 20.0, -10.0], [110.0, 25.0, 10.0]])
#: A repr is a few lines: far below what the arrays of a fit or a diagnosis take.
MAX_REPR = 2000


@pytest.fixture(scope="module")
def data() -> Measurements:
    arm = example_arm()
    return synth(
        arm, random_configs(arm, 12, rng=300), [1.5, 3.0, 5.0, 6.5], [MOUNT, CLEAR], seed=301
    )


@pytest.fixture(scope="module")
def fitted(data: Measurements) -> eodarm.FitResult:
    return eodarm.fit(example_arm(), data, MODEL)


def parses(html: str) -> ET.Element:
    """The notebook table is well-formed markup (parsed strictly, as XHTML)."""
    return ET.fromstring(f"<div>{html}</div>")


# ---------------------------------------------------------------------------- reprs
def test_a_fits_repr_is_short_and_names_its_parameters(fitted: eodarm.FitResult) -> None:
    text = repr(fitted)
    assert len(text) < MAX_REPR and text.count("\n") < 12
    assert "joint_clearance@O2:clearance_mm" in text and "mount_compliance@M1" in text
    assert "χ²/dof" in text and "object at 0x" not in text and "array(" not in text
    assert "±" in text and "N/mm" in text
    table = parses(fitted._repr_html_())
    cells = [td.text or "" for td in table.iter("td")]
    assert "joint_clearance@O2:clearance_mm" in cells
    assert any(c.endswith(" mm") and "±" in c for c in cells)


def test_a_comparison_says_nothing_was_fitted(data: Measurements) -> None:
    res = compare(example_arm(), data, [MOUNT])
    text = repr(res)
    assert len(text) < MAX_REPR and "nothing fitted" in text and "mount_compliance@M1" in text
    parses(res._repr_html_())


def test_a_diagnosis_repr_is_short_and_says_the_verdict(data: Measurements) -> None:
    diag = eodarm.diagnose(example_arm(), data)
    text = repr(diag)
    assert len(text) < MAX_REPR, len(text)
    assert text.startswith("<Diagnosis: missing: ")
    for spec in MODEL:
        assert spec in text.splitlines()[0]
    assert "FitResult(" not in text and "Problem object" not in text
    assert len(repr(diag.ranking)) < 200 * len(diag.ranking)  # one line per candidate
    assert len(repr(diag.examined)) < 300 * max(len(diag.examined), 1)
    table = parses(diag._repr_html_())
    assert "missing" in (table.find("table/caption").text or "")  # type: ignore[union-attr]
    assert len(table.findall("table/tr")) <= 12  # header, 10 candidates, "… and k more"


def test_measurements_arm_and_dataset_print_in_a_few_lines() -> None:
    ds = eodarm.datasets.load("seed2022")
    for obj, words in [
        (ds, ["seed2022", "15 states", "table5"]),
        (ds.measurements, ["15 states", "3-link", "dy_mm", "given"]),
        (ds.arm, ["seed2022", "3 links", "no effects"]),
    ]:
        text = repr(obj)
        assert len(text) < MAX_REPR and "array(" not in text, text
        for w in words:
            assert w in text, (w, text)
    parses(ds.measurements._repr_html_())
    parses(ds.arm._repr_html_())


def test_a_fitted_arms_repr_carries_its_effects_and_fit(fitted: eodarm.FitResult) -> None:
    arm = fitted.to_arm()
    text = repr(arm)
    assert len(text) < MAX_REPR
    assert "mount_compliance@M1 = " in text and "±" in text and "explains its data" in text
    assert "covariance=" not in repr(arm.fit)  # the FitRecord too: parameters, not matrices
    caption = parses(arm._repr_html_()).find("table/caption")
    assert caption is not None and "joint_clearance@O2" in (caption.text or "")


# ---------------------------------------------------------------------------- params
def test_params_map_names_to_values_errors_and_intervals(fitted: eodarm.FitResult) -> None:
    params = fitted.params
    assert list(params) == [
        "mount_compliance@M1:stiffness_n_per_mm",
        "joint_clearance@O2:clearance_mm",
    ]
    clear = params["joint_clearance@O2:clearance_mm"]
    assert clear.unit == "mm" and clear.determined and clear.bound is None
    lo, hi = clear.interval
    # the hidden 0.15 mm inside the 95 % interval, which is ±1.96 standard errors wide
    assert lo < 0.15 < hi
    assert hi - lo == pytest.approx(2 * 1.959963984540054 * clear.stderr, rel=1e-9)
    assert params.valuesdict() == {k: p.value for k, p in params.items()}
    mount = params["mount_compliance@M1:stiffness_n_per_mm"]
    assert mount.unit == "N/mm" and abs(mount.value - 2500.0) < 3 * mount.stderr
    with pytest.raises(KeyError, match="fitted: mount_compliance@M1"):
        params["joint_clearance@O3:clearance_mm"]
    assert len(repr(params)) < MAX_REPR and "0.15" in repr(params)
    parses(params._repr_html_())


def test_values_are_properties_and_rms_is_still_callable(fitted: eodarm.FitResult) -> None:
    rms = fitted.rms
    assert isinstance(rms, dict) and set(rms) == set(fitted.problem.meas.measured_channels)
    # synthetic noise of 0.02 mm: a fit that found the hidden effects leaves about that
    assert 0.01 < rms["dy_mm"] < 0.03
    assert fitted.rms() == rms  # the older spelling
    first = np.asarray(fitted.problem.meas.config) == "c1"
    assert fitted.rms(first) != rms  # over a mask of rows
    assert fitted.chi2_per_dof == pytest.approx(fitted.chi2 / fitted.dof)
    assert 0.7 < fitted.chi2_per_dof < 1.3


def test_a_parameter_the_data_only_bound_says_so() -> None:
    # The seed's actuator bodies 2 and 3: only "stiffer than …" (docs/seed-reproduction.md)
    ds = eodarm.datasets.load("seed2022", tables=False)
    model = [f"{e}@M{i}" for e in ("actuator_compliance", "mount_compliance") for i in (1, 2, 3)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        res = eodarm.fit(ds.arm, ds.measurements, model)
    bounded = {k: p for k, p in res.params.items() if p.bound is not None}
    assert set(bounded) >= {
        "actuator_compliance@M2:stiffness_n_per_mm",
        "actuator_compliance@M3:stiffness_n_per_mm",
    }
    for p in bounded.values():
        assert p.bound == "lower" and not p.determined
        assert p.interval[1] == math.inf and p.interval[0] > 5000.0  # N/mm
        assert "only a bound" in repr(p)
    # the fitted arm writes the same bound (settled at rigid, marked)
    marks = {e.key: m for e, m in res.to_arm().bounded()}
    for name, p in bounded.items():
        mark = marks[name.split(":")[0]]
        assert mark.bound == p.bound and mark.limit == pytest.approx(p.interval[0], rel=0.2)


# ---------------------------------------------------------------------------- to_arm
def test_to_arm_predicts_with_the_sigma_of_the_cli_on_the_written_file(
    tmp_path: Path, data: Measurements, capsys: pytest.CaptureFixture[str]
) -> None:
    from eodarm.cli import main

    (tmp_path / "arm.toml").write_text(example_arm().to_toml(), encoding="utf-8")
    data.to_csv(tmp_path / "m.csv")
    arm = eodarm.Arm.from_toml(tmp_path / "arm.toml")
    res = eodarm.fit(arm, eodarm.read_measurements(tmp_path / "m.csv", arm), MODEL)
    mine = res.to_arm()
    adds = [a for spec in MODEL for a in ("--add", spec)]
    cmd = ["fit", str(tmp_path / "m.csv"), "--arm", str(tmp_path / "arm.toml"), *adds]
    assert main([*cmd, "-o", str(tmp_path / "fitted.toml")]) == 0
    capsys.readouterr()
    alphas = [a for p in POSES for a in ("--alpha", ",".join(f"{x:g}" for x in p))]
    solve = ["solve", "--arm", str(tmp_path / "fitted.toml"), *alphas, "--mass", "5"]
    assert main([*solve, "--uncertainty", "--json"]) == 0
    poses = json.loads(capsys.readouterr().out)["poses"]
    out = eodarm.solve(mine, POSES, 5.0, uncertainty=True)
    # the file holds every number to repr's 17 digits: the same σ, to rounding (1e-12)
    for key in ("sigma_dy_mm", "sigma_dx_mm", "sigma_param_dy_mm", "sigma_dalpha_deg"):
        cli = np.array([p[key] for p in poses])
        np.testing.assert_allclose(out[key], cli, rtol=1e-12, atol=0, err_msg=key)
    # and the same arm: effects, errors, covariance, data and its hash (not the date)
    back = eodarm.Arm.from_toml(tmp_path / "fitted.toml")
    assert back.effects == mine.effects and back.effect_stderr == mine.effect_stderr
    assert back.fit is not None and mine.fit is not None
    np.testing.assert_allclose(back.fit.matrix(), mine.fit.matrix(), rtol=1e-15)
    assert (back.fit.data, back.fit.data_sha256) == (mine.fit.data, mine.fit.data_sha256)
    assert mine.fit.data == "m.csv" and len(mine.fit.data_sha256) == 64


def test_with_effects_carries_values_and_points_to_to_arm_for_sigma(
    fitted: eodarm.FitResult,
) -> None:
    plain = example_arm().with_effects(fitted.effects)
    # the values: the fitted model's predictions
    np.testing.assert_array_equal(
        eodarm.solve(plain, POSES, 5.0)["dy_mm"], eodarm.solve(fitted.to_arm(), POSES, 5.0)["dy_mm"]
    )
    with pytest.raises(eodarm.InputError, match=r"fit\.to_arm\(\)") as info:
        eodarm.solve(plain, POSES, 5.0, uncertainty=True)
    assert "\n" not in str(info.value) and len(str(info.value)) < 300


def test_to_arm_of_data_in_memory_names_no_file(fitted: eodarm.FitResult) -> None:
    arm = fitted.to_arm()
    assert arm.fit is not None and arm.fit.data == "" and arm.fit.data_sha256 == ""
    assert "data" not in arm.fit.to_dict()


# ---------------------------------------------------------------------------- data
def test_the_bundled_data_are_eodarm_datasets() -> None:
    assert "datasets" in dir(eodarm)
    ds = eodarm.datasets.load("seed2022", tables=False)
    assert ds.measurements.n_rows == 15 and ds.arm.n == 3
    from eodarm.data import datasets as inner

    assert eodarm.datasets.load is inner.load
    assert eodarm.datasets.names() == ["seed2022"]


def test_read_measurements_takes_the_arm_or_its_link_count(tmp_path: Path) -> None:
    ds = eodarm.datasets.load("seed2022", tables=False)
    eodarm.datasets.export("seed2022", tmp_path)
    path = tmp_path / "measurements.csv"
    by_arm = eodarm.read_measurements(path, ds.arm)
    by_n = eodarm.read_measurements(path, 3)
    np.testing.assert_array_equal(by_arm.values, by_n.values)
    import hashlib

    assert by_arm.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert by_arm.subset([0, 1]).sha256 == ""  # a subset is not the file's data
    with pytest.raises(TypeError, match=r"read_measurements: arm must be an eodarm.Arm"):
        eodarm.read_measurements(path, "arm.toml")  # type: ignore[arg-type]
    with pytest.raises(eodarm.EodarmError, match="links must be an integer >= 1"):
        eodarm.read_measurements(path, 0)


def test_from_dataframe_takes_the_arm_too() -> None:
    from eodarm.data.reader import from_dataframe

    ds = eodarm.datasets.load("seed2022", tables=False)
    df = ds.measurements.to_dataframe()
    np.testing.assert_array_equal(from_dataframe(df, ds.arm).values, from_dataframe(df, 3).values)


# ---------------------------------------------------------------------------- broadcasting
@settings(max_examples=40, deadline=None)
@given(case=arm_and_poses(max_poses=1), data=st.data())
def test_one_pose_under_many_payloads_is_that_pose_repeated(case, data) -> None:  # type: ignore[no-untyped-def]
    arm, alpha, _ = case
    mass = data.draw(masses(data.draw(st.integers(1, 20))))
    want = eodarm.solve(arm, np.repeat(alpha, mass.size, axis=0), mass)
    for pose in (alpha, alpha[0]):  # (1, n) and (n,)
        got = eodarm.solve(arm, pose, mass)
        for key, value in want.items():
            # the same rows in, the same kernel: the same bits
            np.testing.assert_array_equal(got[key], value, err_msg=key)
    ref = eodarm.solve(arm, alpha[0], mass, backend="numpy")
    np.testing.assert_allclose(ref["dy_mm"], want["dy_mm"], rtol=1e-9, atol=1e-9)


def test_broadcasting_follows_numpy_over_the_rows() -> None:
    arm = example_arm()
    three = eodarm.solve(arm, POSES, [5.0])  # (N, n) with (1,): every pose under 5 kg
    np.testing.assert_array_equal(three["dy_mm"], eodarm.solve(arm, POSES, 5.0)["dy_mm"])
    payload = eodarm.solve_payload(arm, POSES[0], [[0.0, -10.0], [5.0, -20.0]])
    assert payload["dy_mm"].shape == (2,)
    from eodarm.model.solver import statics

    st_ = statics(arm, POSES[0], [1.5, 5.0])
    assert st_["force_n"].shape == (2, 3)
    seq = eodarm.solve_sequence(arm, POSES[0], [[0.0, 1.5, 0.0], [0.0, 5.0, 0.0]])
    assert seq["dy_mm"].shape == (2, 3)
    np.testing.assert_array_equal(
        seq["dy_mm"][1], eodarm.solve_sequence(arm, POSES[0], [0.0, 5.0, 0.0])["dy_mm"][0]
    )
    comp = eodarm.compensate(arm, POSES[0], [1.5, 6.5])
    np.testing.assert_array_equal(
        comp["alpha_deg"], eodarm.compensate(arm, POSES[[0, 0]], [1.5, 6.5])["alpha_deg"]
    )


@pytest.mark.parametrize(
    ("call", "shapes"),
    [
        (lambda arm: eodarm.solve(arm, POSES[:2], [1.5, 5.0, 6.5]), ("(2, 3)", "(3,)")),
        (lambda arm: eodarm.solve(arm, POSES, np.ones((3, 1))), ("(3, 3)", "(3, 1)")),
        (lambda arm: eodarm.compensate(arm, POSES[:2], [1.5, 5.0, 6.5]), ("(2, 3)", "(3,)")),
        (
            lambda arm: eodarm.solve_payload(arm, POSES[:2], np.zeros((3, 2))),
            ("(2, 3)", "(3, 2)"),
        ),
    ],
)
def test_shapes_that_do_not_broadcast_are_refused_naming_both(call, shapes) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(eodarm.InputError) as info:
        call(example_arm())
    msg = str(info.value)
    assert "\n" not in msg and len(msg) < 300
    for shape in shapes:
        assert shape in msg, msg


def dl1_in_metres() -> tuple[Measurements, Measurements]:
    """Honest actuator-sensor data of the example arm, and the same with dl1 in metres."""
    arm = example_arm()
    meas = synth(arm, random_configs(arm, 8, 11), [1.5, 5.0, 6.5], channels="dl", seed=3)
    values = meas.values.copy()
    values[:, meas.index("dl1_mm")] *= 1e-3
    chans = meas.measured_channels
    slipped = Measurements.from_arrays(
        meas.config,
        meas.alpha_deg,
        meas.mass_kg,
        {ch: values[:, meas.index(ch)] for ch in chans},
        {ch: meas.sigma[:, meas.index(ch)] for ch in chans},
    )
    return meas, slipped


def test_to_arm_never_calls_data_that_look_mistaken_explained() -> None:
    # dl1 in metres: a rigid body "explains" them (χ²/dof < 2), but the data checks of
    # eodarm fit find the unit slip, and to_arm, like fit -o, does not write explained = true
    arm = example_arm()
    meas, slipped = dl1_in_metres()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        res = eodarm.fit(arm, slipped, ["actuator_compliance@M1"])
    assert res.chi2_per_dof < 2.0
    fitted = res.to_arm()
    assert fitted.fit is not None and fitted.fit.explained is False
    honest = eodarm.fit(arm, meas, ["actuator_compliance@M1"]).to_arm()
    assert honest.fit is not None and honest.fit.explained is True
    # told that the data are trusted, it writes what the χ² test says
    told = res.to_arm(trusted=True)
    assert told.fit is not None and told.fit.explained is True


def test_a_diagnosis_of_mistaken_data_says_to_check_them() -> None:
    arm = example_arm()
    _, slipped = dl1_in_metres()
    diag = eodarm.diagnose(arm, slipped)
    text = repr(diag)
    assert diag.verdict == "check_data" and len(text) < MAX_REPR
    assert text.startswith("<Diagnosis: check_data: the data look mistaken")
    assert "dl1_mm looks like metres" in " ".join(text.split())
    assert "explains its data" not in text
    parses(diag._repr_html_())
