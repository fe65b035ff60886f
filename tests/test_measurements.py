"""Measurement files (docs/formats.md §3) and the virtual test bench (eodarm.synth).

Promises tested here: a file written by eodarm reads back exactly; empty cells mean "not
measured"; missing sigmas fall back to documented defaults and say so; every kind of bad input
is refused with one one-line message naming the file, the line and the column, listing every
bad row; synthetic data are the model plus noise of exactly the stated size; random
configurations are non-singular and within the stroke.
"""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import eodarm
from eodarm.analysis.synth import moment_arm_ratio, random_configs, synth
from eodarm.cli.synth import add_parser
from eodarm.data.channels import (
    DEFAULT_SIGMA,
    channel_names,
    channel_values,
    default_sigma,
    expand_channels,
)
from eodarm.data.datasets import example_arm
from eodarm.data.measurements import MeasurementFileError, Measurements
from eodarm.data.reader import from_dataframe, read_measurements

HEAD = "config,alpha1_deg,alpha2_deg,alpha3_deg,mass_kg"
#: Stroke limits (mm) that the bundled arm's actuators reach over the default angle ranges,
#: tight enough that some drawn poses fall outside them.
STROKES = ((270.0, 350.0), (440.0, 600.0), (460.0, 550.0))


@pytest.fixture(scope="module")
def arm() -> eodarm.Arm:
    d = example_arm().to_dict()
    for act, (lo, hi) in zip(d["actuator"], STROKES, strict=True):
        act["min_length_mm"], act["max_length_mm"] = lo, hi
    return eodarm.Arm.from_dict(d, source="<test arm>")


@pytest.fixture(scope="module")
def poses(arm: eodarm.Arm) -> np.ndarray:
    return random_configs(arm, 6, np.random.default_rng(1))


def write(tmp_path: Path, text: str, name: str = "meas.csv") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def assert_same_data(a: Measurements, b: Measurements) -> None:
    """Bit-for-bit equal states, values and sigmas (NaN where not measured)."""
    assert a.n == b.n and a.channels == b.channels
    assert a.config.tolist() == b.config.tolist()
    np.testing.assert_array_equal(a.alpha_deg, b.alpha_deg)
    np.testing.assert_array_equal(a.mass_kg, b.mass_kg)
    np.testing.assert_array_equal(a.values, b.values)  # NaN == NaN here
    np.testing.assert_array_equal(a.sigma, b.sigma)
    assert a.defaulted == b.defaulted


# ---------------------------------------------------------------------------- channels
def test_channels_of_an_arm_come_in_the_contract_order() -> None:
    assert channel_names(3) == [
        "dx_mm",
        "dy_mm",
        "dalpha1_deg",
        "dalpha2_deg",
        "dalpha3_deg",
        "dl1_mm",
        "dl2_mm",
        "dl3_mm",
    ]
    assert expand_channels("dl,dx_mm", 2) == ["dx_mm", "dl1_mm", "dl2_mm"]
    with pytest.raises(eodarm.EodarmError, match="dalpha4_deg"):
        expand_channels(["dalpha4_deg"], 3)


def test_default_noise_levels_are_those_documented() -> None:
    assert DEFAULT_SIGMA == {"dx_mm": 0.02, "dy_mm": 0.02, "dalpha_deg": 0.02, "dl_mm": 0.002}
    assert default_sigma("dalpha3_deg") == 0.02
    assert default_sigma("dl2_mm") == 0.002
    assert default_sigma("dy_mm") == 0.02


# ---------------------------------------------------------------------------- round trip
@pytest.mark.parametrize("channels", [None, "dy_mm,dalpha", "dl"])
def test_synth_to_csv_reads_back_exactly(
    arm: eodarm.Arm, poses: np.ndarray, tmp_path: Path, channels: str | None
) -> None:
    hidden = [eodarm.Effect("joint_clearance", "O2", clearance_mm=0.1)]
    m = synth(arm, poses, [0.0, 1.5, 6.5], hidden=hidden, channels=channels, seed=3)
    path = tmp_path / "rt.csv"
    m.to_csv(path)
    back = read_measurements(path, arm.n)
    assert_same_data(m, back)
    assert back.defaulted == ()
    assert back.source == str(path)
    assert back.line.tolist() == list(range(2, m.n_rows + 2))
    assert back.measured_channels == tuple(expand_channels(channels, arm.n))


def test_round_trip_keeps_which_sigmas_were_defaulted(tmp_path: Path) -> None:
    text = (
        f"{HEAD},dy_mm,dl1_mm,sigma_dy_mm\n"
        "a,90,10,0,5,-1.25,-0.1,0.05\n"
        "a,90,10,0,6.5,-1.5,,\n"
        "b,80,0,5,5,,0.25,0.03\n"
    )
    first = read_measurements(write(tmp_path, text), 3)
    first.to_csv(tmp_path / "again.csv")
    again = read_measurements(tmp_path / "again.csv", 3)
    assert_same_data(first, again)
    assert again.defaulted == ("dy_mm", "dl1_mm")


def test_dataframe_round_trip(arm: eodarm.Arm, poses: np.ndarray) -> None:
    m = synth(arm, poses, [1.5, 5.0], channels="dx_mm,dy_mm", seed=5)
    df = m.to_dataframe()
    assert list(df.columns[:5]) == ["config", "alpha1_deg", "alpha2_deg", "alpha3_deg", "mass_kg"]
    assert list(df.columns[5:]) == ["dx_mm", "sigma_dx_mm", "dy_mm", "sigma_dy_mm", "line"]
    assert_same_data(m, from_dataframe(df, arm.n))
    # a frame as pandas reads the file: empty cells are NaN, labels may look like numbers
    raw = pd.read_csv(io.StringIO(f"{HEAD},dy_mm\n1,90,10,0,5,-1.5\n2,90,10,0,5,\n"))
    got = from_dataframe(raw, 3, source="frame")
    assert got.configs == ("1", "2")
    assert np.isnan(got.values[1]).all()


def test_data_are_read_only(arm: eodarm.Arm, poses: np.ndarray) -> None:
    m = synth(arm, poses, [5.0])
    with pytest.raises(ValueError, match="read-only"):
        m.values[0, 0] = 0.0


# ---------------------------------------------------------------------------- content
def test_empty_cells_mean_not_measured_and_rows_are_never_dropped(tmp_path: Path) -> None:
    text = (
        f"{HEAD},dx_mm,dy_mm,dalpha3_deg\n"
        "p1,90,10,0,1.5,0.5,-1.0,\n"
        "p1,90,10,0,5,,-3.0,-0.2\n"
        "p2,60,20,-10,5,,,\n"  # nothing measured: kept, contributes nothing
    )
    m = read_measurements(write(tmp_path, text), 3)
    assert m.n_rows == 3
    assert m.n_values == 4
    assert m.measured_channels == ("dx_mm", "dy_mm", "dalpha3_deg")
    assert np.isnan(m.values[2]).all() and np.isnan(m.sigma[2]).all()
    assert np.isnan(m.values[0, m.index("dalpha3_deg")])
    assert np.isnan(m.values[:, m.index("dl1_mm")]).all()
    assert m.values[1, m.index("dalpha3_deg")] == -0.2
    assert m.configs == ("p1", "p2")
    assert m.line.tolist() == [2, 3, 4]
    assert m.subset(m.config == "p1").n_values == 4
    assert m.subset([2, 0]).line.tolist() == [4, 2]


def test_defaults_are_used_and_recorded_without_sigma_columns(tmp_path: Path) -> None:
    text = (
        f"{HEAD},dx_mm,dy_mm,dl2_mm,sigma_dx_mm\na,90,10,0,5,0.5,-1.0,-0.01,\nb,90,10,0,5,,,,0.5\n"
    )
    m = read_measurements(write(tmp_path, text), 3)
    assert m.defaulted == ("dx_mm", "dy_mm", "dl2_mm")
    assert m.sigma[0, m.index("dx_mm")] == DEFAULT_SIGMA["dx_mm"]
    assert m.sigma[0, m.index("dl2_mm")] == DEFAULT_SIGMA["dl_mm"]
    # a given sigma next to a measured value is used, and the channel is then not defaulted
    ok = read_measurements(write(tmp_path, f"{HEAD},dx_mm,sigma_dx_mm\na,90,0,0,5,0.5,0.1\n"), 3)
    assert ok.defaulted == () and ok.sigma[0, 0] == 0.1
    # defaults are per value: the flag follows the rows kept by subset
    assert m.subset([1]).defaulted == ()


def test_same_label_with_different_angles_is_allowed(tmp_path: Path) -> None:
    text = f"{HEAD},dy_mm\nc1,90,10,0,5,-1\nc1,91,10,0,5,-1.1\n"
    m = read_measurements(write(tmp_path, text), 3)
    assert m.configs == ("c1",) and m.n_rows == 2


def test_unknown_columns_warn_once_and_are_ignored(tmp_path: Path) -> None:
    text = f"{HEAD},dy_mm,temperature_c,operator\nc1,90,10,0,5,-1,21.5,kim\n"
    with pytest.warns(UserWarning, match="'temperature_c', 'operator'") as rec:
        m = read_measurements(write(tmp_path, text), 3)
    assert len(rec) == 1
    assert m.measured_channels == ("dy_mm",) and m.values[0, 1] == -1.0


# ---------------------------------------------------------------------------- bad input
BAD_ROWS = [
    # (file body after the header, line, column named in the message, reason)
    ("c1,90,10,0,abc,-1,0.02", 2, "mass_kg", "not a number"),
    ("c1,90,,0,5,-1,0.02", 2, "alpha2_deg", "empty"),
    ("c1,90,10,nan,5,-1,0.02", 2, "alpha3_deg", "not finite"),
    ("c1,90,10,inf,5,-1,0.02", 2, "alpha3_deg", "not finite"),
    ("c1,90,10,0,-5,-1,0.02", 2, "mass_kg", "negative"),
    ("c1,90,10,0,,-1,0.02", 2, "mass_kg", "empty"),
    ("c1,90,10,0,5,-1,0", 2, "sigma_dy_mm", "> 0"),
    ("c1,90,10,0,5,-1,-0.1", 2, "sigma_dy_mm", "> 0"),
    ("c1,90,10,0,5,-1,inf", 2, "sigma_dy_mm", "not finite"),
    ("c1,90,10,0,5,1.2.3,0.02", 2, "dy_mm", "not a number"),
    ("c1,90,10,0,5,-1e,0.02", 2, "dy_mm", "not a number"),
    ("c1,90,10,0,5,-1,0.02\nc2,90,10,0,5,nan,0.02", 3, "dy_mm", "not finite"),
    ("c1,90,10,0,5,-1,0.02\n,80,10,0,5,-1,0.02", 3, "config", "empty"),
]


@pytest.mark.parametrize(("body", "line", "column", "why"), BAD_ROWS)
def test_bad_rows_are_refused_naming_file_line_and_column(
    tmp_path: Path, body: str, line: int, column: str, why: str
) -> None:
    path = write(tmp_path, f"{HEAD},dy_mm,sigma_dy_mm\n{body}\n")
    with pytest.raises(eodarm.EodarmError) as info:
        read_measurements(path, 3)
    msg = str(info.value)
    assert isinstance(info.value, MeasurementFileError)
    assert "\n" not in msg
    assert msg.startswith(f"{path}: 1 bad row(s): line {line}: {column} ")
    assert why in msg


@pytest.mark.parametrize(
    ("text", "line", "column"),
    [
        (f"{HEAD},dy_mm\nc1,90,10,0,5,-1,7\n", 2, "7 cells"),
        (f"{HEAD},dy_mm\nc1,90,10,0,5\n", 2, "5 cells"),
        ("config,alpha1_deg,alpha3_deg,mass_kg\nc1,90,0,5\n", 1, "'alpha2_deg'"),
        ("config,alpha1_deg,alpha2_deg,alpha3_deg\nc1,90,10,0\n", 1, "'mass_kg'"),
        (f"{HEAD},sigma_dx_mm\nc1,90,10,0,5,0.02\n", 1, "'sigma_dx_mm'"),
        (f"{HEAD},dy_mm,dy_mm\nc1,90,10,0,5,1,1\n", 1, "'dy_mm' appears twice"),
        (f"{HEAD},dy_mm\n", 1, "no data rows"),
        ("", 1, "empty"),
    ],
)
def test_bad_files_are_refused_naming_file_and_line(
    tmp_path: Path, text: str, line: int, column: str
) -> None:
    path = write(tmp_path, text)
    with pytest.raises(MeasurementFileError) as info:
        read_measurements(path, 3)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{path}: ")
    assert f"line {line}" in msg and column in msg


def test_bad_rows_are_counted_and_the_first_three_cells_named(tmp_path: Path) -> None:
    """Every bad row is found; the message names the first three bad cells, each with its
    line and column, and counts the rest (a message stays one short line)."""
    text = (
        f"{HEAD},dy_mm\n"
        "c1,90,10,0,5,-1\n"
        "c1,90,10,0,abc,-1\n"  # line 3
        "c2,90,10,0,5,-1\n"
        "c2,90,,0,5,x\n"  # line 5: two problems, one row
        "c3,90,10,0,-1,-1\n"  # line 6
    )
    with pytest.raises(MeasurementFileError) as info:
        read_measurements(write(tmp_path, text), 3)
    msg = str(info.value)
    assert "3 bad row(s), 4 bad cells" in msg
    assert "line 3: mass_kg 'abc' is not a number" in msg
    assert "line 5: alpha2_deg is empty (unknown config angle); line 5: dy_mm 'x' is not" in msg
    assert msg.endswith("…and 1 more") and "line 6" not in msg
    assert "line 2" not in msg and "line 4" not in msg

    many = HEAD + "\n" + "".join(f"c{i},90,10,0,heavy\n" for i in range(25))
    with pytest.raises(MeasurementFileError) as info:
        read_measurements(write(tmp_path, many, "many.csv"), 3)
    msg = str(info.value)
    assert "25 bad row(s)" in msg and "line 4:" in msg and "line 5:" not in msg
    assert msg.endswith("…and 22 more")


@pytest.mark.parametrize(
    ("n", "column"),
    [(3, "dalpha4_deg"), (3, "dl4_mm"), (2, "dl3_mm"), (2, "sigma_dalpha3_deg")],
)
def test_a_channel_for_a_link_beyond_the_arm_is_refused(
    tmp_path: Path, n: int, column: str
) -> None:
    head = ["config", *(f"alpha{i + 1}_deg" for i in range(n)), "mass_kg", column]
    cells = ["c1", *(["10"] * n), "5", "1"]
    if column.startswith("sigma_"):
        head.append(column.removeprefix("sigma_"))
        cells.append("1")
    path = write(tmp_path, ",".join(head) + "\n" + ",".join(cells) + "\n")
    with pytest.raises(MeasurementFileError, match="another arm") as info:
        read_measurements(path, n)
    assert str(path) in str(info.value) and f"'{column}'" in str(info.value)


def test_from_arrays_is_validated_like_a_file() -> None:
    good = Measurements.from_arrays(
        ["a", "a"], [[90, 10, 0], [90, 10, 0]], [1.5, 5.0], {"dy_mm": [-1.0, np.nan]}
    )
    assert good.n_values == 1 and good.defaulted == ("dy_mm",)
    with pytest.raises(MeasurementFileError, match=r"<arrays>: 1 bad row\(s\): line 3: mass_kg"):
        Measurements.from_arrays("a", [[90, 10, 0], [90, 10, 0]], [1.5, -5.0], {"dy_mm": [1, 2]})
    with pytest.raises(MeasurementFileError, match="'dz_mm'"):
        Measurements.from_arrays("a", [[90, 10, 0]], 5.0, {"dz_mm": [1.0]})


# ---------------------------------------------------------------------------- synth
def test_synth_without_noise_is_the_model(arm: eodarm.Arm, poses: np.ndarray) -> None:
    hidden = [
        eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=5e7),
        eodarm.Effect("actuator_play", "M2", play_mm=0.05),
    ]
    masses = [0.0, 1.5, 6.5]
    m = synth(arm, poses, masses, hidden=hidden, noise=1e-300, configs=list("ABCDEF"))
    rows_alpha = np.repeat(poses, 3, axis=0)
    rows_mass = np.tile(masses, len(poses))
    out = eodarm.solve(arm, rows_alpha, rows_mass, effects=hidden)
    # bit-for-bit wherever the truth is not 0 (1e-300 of a sigma vanishes in rounding); where
    # it is 0 (body length changes at zero payload) the noise is ~1e-303
    np.testing.assert_allclose(m.values, channel_values(out, m.channels), rtol=0, atol=1e-290)
    np.testing.assert_array_equal(m.alpha_deg, rows_alpha)
    np.testing.assert_array_equal(m.mass_kg, rows_mass)
    assert m.config.tolist() == [c for c in "ABCDEF" for _ in masses]
    # without self-weight the states differ, and synth follows
    bare = synth(arm, poses, masses, hidden=hidden, noise=1e-300, self_weight=False)
    out = eodarm.solve(arm, rows_alpha, rows_mass, effects=hidden, self_weight=False)
    np.testing.assert_allclose(bare.values, channel_values(out, m.channels), rtol=0, atol=1e-290)


@pytest.mark.parametrize("noise", [1.0, 3.0])
def test_synth_noise_has_the_stated_size_and_no_bias(arm: eodarm.Arm, noise: float) -> None:
    alpha = random_configs(arm, 1000, np.random.default_rng(7))
    masses = [1.5, 5.0, 6.5, 8.0]
    m = synth(arm, alpha, masses, noise=noise, sigma={"dl2_mm": 0.004}, seed=11)
    truth = synth(arm, alpha, masses, noise=1e-300).values
    z = (m.values - truth) / m.sigma
    rows = m.n_rows  # 4000 per channel
    for j, ch in enumerate(m.channels):
        want = 0.004 if ch == "dl2_mm" else default_sigma(ch) * noise
        assert np.all(m.sigma[:, j] == want), ch
        # mean of 4000 standard normals: sd 0.016; sample sd: sd 0.011 (5-sigma bounds)
        assert abs(z[:, j].mean()) < 5 / np.sqrt(rows), ch
        assert abs(z[:, j].std(ddof=1) - 1.0) < 5 / np.sqrt(2 * rows), ch
    # channels are independent of each other
    corr = np.corrcoef(z.T)
    assert np.abs(corr - np.eye(len(m.channels))).max() < 5 / np.sqrt(rows)


def test_synth_noise_of_a_channel_does_not_depend_on_the_selection(
    arm: eodarm.Arm, poses: np.ndarray
) -> None:
    every = synth(arm, poses, [5.0], seed=4)
    some = synth(arm, poses, [5.0], channels=["dy_mm", "dl3_mm"], seed=4)
    for ch in some.measured_channels:
        j = every.index(ch)
        np.testing.assert_array_equal(every.values[:, j], some.values[:, j])
    assert some.measured_channels == ("dy_mm", "dl3_mm")
    assert np.isnan(some.values[:, some.index("dx_mm")]).all()


def test_without_sigma_columns_readers_fall_back_to_defaults(
    arm: eodarm.Arm, poses: np.ndarray, tmp_path: Path
) -> None:
    m = synth(arm, poses, [5.0], noise=2.0, sigma_columns=False)
    m.to_csv(tmp_path / "nosig.csv")
    header = (tmp_path / "nosig.csv").read_text().splitlines()[0]
    assert "sigma_" not in header
    back = read_measurements(tmp_path / "nosig.csv", arm.n)
    np.testing.assert_array_equal(back.values, m.values)
    assert back.defaulted == tuple(m.channels)
    np.testing.assert_array_equal(back.sigma, m.sigma / 2.0)


def test_random_configs_are_well_conditioned_and_within_stroke(arm: eodarm.Arm) -> None:
    alpha = random_configs(arm, 200, np.random.default_rng(3))
    assert alpha.shape == (200, 3)
    assert np.all((alpha[:, 0] >= 40) & (alpha[:, 0] <= 130))
    assert np.all((alpha[:, 1] >= -40) & (alpha[:, 1] <= 60))
    assert np.all((alpha[:, 2] >= -30) & (alpha[:, 2] <= 30))
    geo = eodarm.forward(arm, alpha)
    assert np.all(eodarm.stroke_violations(arm, geo["length_mm"]) == 0)
    assert np.all(moment_arm_ratio(arm, alpha) >= 0.2)
    assert np.all(geo["O"][:, -1, 0] > arm.O1[0])
    # non-singular: finite forces that hold the largest payload
    out = eodarm.solve(arm, alpha, 8.0)
    assert np.isfinite(out["force_n"]).all()
    # the stroke limits did reject poses: without them other poses come out
    free = eodarm.Arm.from_dict(
        {**arm.to_dict(), "actuator": [{"stiffness_n_per_mm": 2e3, "mass_kg": 1.0}] * 3}
    )
    loose = random_configs(free, 200, np.random.default_rng(3))
    assert np.any(eodarm.stroke_violations(arm, eodarm.forward(arm, loose)["length_mm"]) != 0)


def test_random_configs_say_why_when_no_pose_fits(arm: eodarm.Arm) -> None:
    d = arm.to_dict()
    d["actuator"][1]["max_length_mm"] = 300.0  # actuator 2 spans > 400 mm in any pose
    d["actuator"][1]["min_length_mm"] = 200.0
    tight = eodarm.Arm.from_dict(d)
    with pytest.raises(eodarm.EodarmError, match=r"actuator 2 spans .* stroke is 200\.0–300\.0"):
        random_configs(tight, 3, 0, max_draws=2000)


def test_random_configs_keep_a_drive_within_the_angle_tolerance_of_its_limit() -> None:
    """An angle within 10⁻⁹° of a drive's limit is inside its range (docs/model.md §10), the
    same as the solver's status says: a pose 5·10⁻¹⁰° past drive 1's ``min_angle_deg`` is drawn
    and solves ok, one 2·10⁻⁹° past it is refused and solves out_of_stroke."""
    from eodarm.model.validity import STATUS

    arm = eodarm.Arm.from_toml(Path(__file__).resolve().parents[1] / "examples/rotary_arm.toml")
    lo = arm.actuators[0].min_angle_deg
    for past, inside in ((5e-10, True), (2e-9, False)):
        a1 = lo - past  # q1 = α1; q2 = q3 = 0, well inside their ranges
        code = int(np.asarray(eodarm.solve(arm, [[a1, a1, a1]], 0.0)["status"])[0])
        assert (code == 0) is inside and (code == STATUS.index("out_of_stroke")) is not inside
        ranges = [(a1, a1)] * 3
        if inside:
            np.testing.assert_array_equal(random_configs(arm, 2, 0, ranges), [[a1, a1, a1]] * 2)
        else:
            with pytest.raises(eodarm.EodarmError, match=r"a drive's range in 500\b"):
                random_configs(arm, 2, 0, ranges, max_draws=500)


# ---------------------------------------------------------------------------- CLI
def run_synth(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="eodarm")
    add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["synth", *argv])
    return int(args.func(args))


def test_cli_synth_writes_the_file_synth_would_make(
    arm: eodarm.Arm, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    arm_file = write(tmp_path, arm.to_toml(), "arm.toml")
    out = tmp_path / "out.csv"
    argv = ["--arm", str(arm_file), "--alpha", "90,10,0", "--alpha", "70,20,-10"]
    argv += ["--masses", "1.5,5", "--hidden", "joint_clearance@O3=0.15"]
    argv += ["--channels", "dy_mm,dl", "--sigma", "dl=0.001", "--seed", "9", "-o", str(out)]
    assert run_synth(argv) == 0
    err = capsys.readouterr().err
    assert "wrote 4 states (2 configs × 2 payloads, 4 channels" in err and str(out) in err
    got = read_measurements(out, 3)
    want = synth(
        arm,
        [[90, 10, 0], [70, 20, -10]],
        [1.5, 5],
        hidden=[eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15)],
        channels="dy_mm,dl",
        sigma={"dl": 0.001},
        seed=9,
    )
    assert_same_data(want, got)


def test_cli_synth_random_configs_to_stdout(
    arm: eodarm.Arm, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    arm_file = write(tmp_path, arm.to_toml(), "arm.toml")
    argv = ["--arm", str(arm_file), "--configs", "5", "--no-sigma-columns", "--noise", "0.5"]
    assert run_synth(argv) == 0
    cap = capsys.readouterr()
    assert "wrote 15 states (5 configs × 3 payloads, 8 channels" in cap.err
    got = read_measurements(io.StringIO(cap.out), 3)
    assert got.n_rows == 15 and len(got.configs) == 5
    assert got.defaulted == tuple(channel_names(3))
    assert np.all(
        eodarm.stroke_violations(arm, eodarm.forward(arm, got.alpha_deg)["length_mm"]) == 0
    )


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--alpha", "90,10"], "expected 3 angles"),
        (["--alpha", "90,10,0", "--hidden", "joint_clearance@O3"], "EFFECT@PLACE=VALUE"),
        (["--alpha", "90,10,0", "--hidden", "joint_clearance@O9=0.1"], "O9"),
        (["--alpha", "90,10,0", "--hidden", "warp@O1=0.1"], "warp"),
        (["--alpha", "90,10,0", "--channels", "dalpha4_deg"], "dalpha4_deg"),
        (["--alpha", "90,10,0", "--sigma", "dy_mm"], "CHANNEL=VALUE"),
        (["--alpha", "90,10,0", "--sigma", "dy_mm=-1"], "> 0"),
        (["--alpha", "90,10,0", "--masses", "1,x"], "--masses"),
        (["--alpha", "90,10,0", "--noise", "0"], "noise"),
    ],
)
def test_cli_synth_bad_arguments_give_a_one_line_reason(argv: list[str], match: str) -> None:
    with pytest.raises(eodarm.EodarmError, match=match) as info:
        run_synth(argv)  # the bundled example arm
    assert "\n" not in str(info.value)
