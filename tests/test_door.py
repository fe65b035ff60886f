"""Mistakes caught at the door (issue 20 items 4, 5; issue 23 items 1, 3, 5).

* a refusal is exactly one line on stderr, exit 2, even after notes (noise, arm) were due;
* nothing is overwritten without ``--force``;
* a measured state that the arm cannot take is refused naming the file, the 1-based line and
  the column, with what was probably meant (grams, radians, out of stroke);
* misspellings get a "did you mean"; spreadsheet exports (semicolons, empty rows, decimal
  commas) are read or explained; binary and huge files are refused in one line;
* the API refuses numbers of the wrong kind (complex, datetime, bool, strings, huge ints);
* every ``next:`` line carries the flags its command needs, and runs.

The commands run in-process (``eodarm.cli.main``), as a user's shell would run them.
"""

from __future__ import annotations

import io
import json
import math
import shlex
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import eodarm
from eodarm.cli import main
from eodarm.data.datasets import bundled_arm_path
from eodarm.data.measurements import MeasurementFileError, Measurements
from eodarm.data.reader import read_measurements
from eodarm.errors import ArmFileError, EffectError, InputError

SEED_ARM = bundled_arm_path("seed2022")
SEED = SEED_ARM.with_name("measurements.csv")
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"


def no_sigma(path: Path, rows: int | None = None) -> Path:
    """The seed measurements without their sigma_ columns (σ then comes from the defaults or
    the repeats, and the command says so in a note), optionally only the first rows."""
    lines = SEED.read_text(encoding="utf-8").splitlines()
    head = lines[0].split(",")
    keep = [j for j, h in enumerate(head) if not h.startswith("sigma_")]
    body = lines[1:] if rows is None else lines[1 : rows + 1]
    out = [",".join(c.split(",")[j] for j in keep) for c in [lines[0], *body]]
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    return path


def edit_rows(path: Path, out: Path, fn: Callable[[list[str], list[str]], list[str]]) -> Path:
    """A copy of a measurement file with every data row passed through ``fn(header, row)``."""
    lines = path.read_text(encoding="utf-8").splitlines()
    head = lines[0].split(",")
    rows = [",".join(fn(head, r.split(","))) for r in lines[1:]]
    out.write_text("\n".join([lines[0], *rows]) + "\n", encoding="utf-8")
    return out


def cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def one_line(code: int, err: str) -> str:
    """The refusal: exit 2 and exactly one line on stderr."""
    lines = err.splitlines()
    assert code == 2, err
    assert len(lines) == 1, err
    assert lines[0].startswith("eodarm: error: "), err
    return lines[0]


# ---------------------------------------------------------------- one line on exit 2 (23.1)
def _late_failures(tmp: Path) -> dict[str, list[str]]:
    """Each command on input without σ (or without --arm: a note is due) that fails only
    after the work: its figures or output go below a regular file."""
    meas = no_sigma(tmp / "meas.csv")
    blocker = tmp / "not_a_folder"
    blocker.write_text("a file\n")
    below = str(blocker / "out")
    arm = ["--arm", str(SEED_ARM)]
    return {
        "compare": ["compare", meas, *arm, "--plot", below],
        "fit": ["fit", meas, *arm, "--add", "mount_compliance@M2", "--plot", below],
        "diagnose": ["diagnose", meas, *arm, "--max-set", "1", "--plot", below],
        "report": ["report", meas, *arm, "--rounds", "1", "-o", below + ".html"],
        "solve": ["solve", "--model", "fem", "--alpha", "90,10,0", "--plot", below],
        "compensate": ["compensate", "--alpha", "90,10,0", "--mass", "5", "-o", below + ".csv"],
        "sweep": [
            "sweep", "--alpha1", "80:90:2", "--alpha2", "10", "--alpha3", "0", "--mass", "5",
            "--no-progress", "--plot", below,
        ],
        "synth": ["synth", "--configs", "2", "--no-sigma-columns", "-o", below + ".csv"],
        "datasets": ["datasets", "export", "seed2022", below],
        "plan": ["plan", *arm, "--configs", "2", "--pool", "60", "--fixed", meas, "--plot", below],
    }  # fmt: skip


@pytest.mark.parametrize(
    "command",
    [
        "compare", "fit", "diagnose", "report", "solve", "compensate", "sweep", "synth",
        "datasets", "plan",
    ],
)  # fmt: skip
def test_a_late_refusal_is_one_line_without_the_notes_that_were_due(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A command whose notes ("no sigma given …", "no --arm: used …", "swept …") were due
    before it failed prints the one line of its refusal only (issue 23 item 1)."""
    code, _, err = cli(capsys, *_late_failures(tmp_path)[command])
    assert "not_a_folder" in one_line(code, err)


@pytest.mark.parametrize("command", ["compare", "fit", "diagnose", "report"])
def test_a_one_row_file_that_cannot_close_is_one_line_naming_file_line_and_column(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A file without σ whose one state (mass in grams) cannot close under its load: one
    line, exit 2, naming the file, the 1-based line and the mass column (issue 23 items 1
    and 3: before, `pose row 0: actuator 1 cannot close its triangle …` after 3 lines of
    notes)."""
    meas = no_sigma(tmp_path / "grams.csv", rows=1)
    meas = edit_rows(
        meas,
        meas,
        lambda h, r: [
            str(float(c) * 1000) if n == "mass_kg" else c for n, c in zip(h, r, strict=True)
        ],
    )
    extra = ["--add", "mount_compliance@M2"] if command == "fit" else []
    code, _, err = cli(capsys, command, meas, "--arm", SEED_ARM, *extra)
    line = one_line(code, err)
    assert f"{meas} line 2: mass_kg 1500" in line
    assert "cannot close" in line and "in grams? 1.5 kg" in line
    assert "pose row" not in line


# ------------------------------------------------- the states at the door (20.4, 23.3)
def test_masses_in_grams_name_every_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    meas = edit_rows(
        no_sigma(tmp_path / "m.csv"),
        tmp_path / "grams.csv",
        lambda h, r: [
            str(float(c) * 1000) if n == "mass_kg" else c for n, c in zip(h, r, strict=True)
        ],
    )
    code, _, err = cli(capsys, "compare", meas, "--arm", SEED_ARM)
    line = one_line(code, err)
    assert str(meas) in line and "line 2: mass_kg 1500" in line and "grams" in line


def test_angles_in_radians_are_refused_with_what_they_mean(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The seed's angles written in radians: every |alpha| < 2π, and the measured
    deflections fit the radian reading far better: refused, saying the angle in degrees."""

    def to_rad(h: list[str], r: list[str]) -> list[str]:
        return [
            f"{math.radians(float(c)):.5f}" if n.startswith("alpha") else c
            for n, c in zip(h, r, strict=True)
        ]

    meas = edit_rows(SEED, tmp_path / "rad.csv", to_rad)
    code, _, err = cli(capsys, "diagnose", meas, "--arm", SEED_ARM, "--json")
    line = one_line(code, err)
    assert str(meas) in line and "radians" in line and "line 2 alpha1_deg 2.0176 is" in line
    assert "115.6°" in line


def test_a_state_out_of_stroke_unloaded_is_the_datas_problem_not_the_fits(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The example arm's actuator 1 has a stroke of 250…370 mm: a state whose unloaded pose
    is outside it is refused before fitting, naming line and columns (issue 23 item 3: it was
    blamed on the fitted effect)."""
    from eodarm.analysis.synth import synth

    arm = eodarm.Arm.from_toml(EXAMPLE)
    meas = synth(arm, [[80.0, 10.0, 0.0], [95.0, 20.0, -5.0]], [1.5, 5.0], seed=1)
    path = tmp_path / "m.csv"
    meas.to_csv(path)
    lines = path.read_text().splitlines()
    bad = lines[3].split(",")
    bad[1] = "20.0"  # actuator 1 shorter than its 250 mm
    lines[3] = ",".join(bad)
    path.write_text("\n".join(lines) + "\n")
    alpha = [float(c) for c in bad[1:4]]
    assert eodarm.forward(arm, [alpha])["length_mm"][0, 0] < 250.0
    code, _, err = cli(capsys, "fit", path, "--arm", EXAMPLE, "--add", "joint_clearance@O2")
    line = one_line(code, err)
    assert f"{path} line 4: alpha1_deg: actuator 1 is out of stroke unloaded" in line
    assert "[250, 370] mm" in line and "not the model's" in line


def test_a_fit_that_puts_states_outside_validity_names_the_effect_and_the_lines(
    shim: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The fitted shim moves two of the seed's states beyond the model's validity: the
    fit is kept (data made by this very model would be refused otherwise; issue 27 item 3)
    and a note names the fitted effect with its value, the file and the lines."""
    meas = no_sigma(tmp_path / "m.csv")
    argv = ["fit", meas, "--arm", SEED_ARM, "--effects", shim, "--no-self-weight"]
    code, _, err = cli(capsys, *argv, "--add", "door_shim@M2", "--json")
    note = " ".join(err.split())
    assert code == 0
    assert "the fitted door_shim@M2 = " in note and f"of {meas} outside" in note
    assert "line(s) 2, 5" in note and "kept in the fit" in note


def test_states_outside_validity_before_the_fit_are_blamed_on_the_data(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Four times the seed's payloads: under the arm file's model alone 10 of the 15 states
    deflect beyond the model's validity. The note says so as the data's, not as the fitted
    effect's (issue 23 item 3); the fit is kept (issue 27 item 3)."""
    meas = edit_rows(
        no_sigma(tmp_path / "m.csv"),
        tmp_path / "heavy.csv",
        lambda h, r: [
            str(float(c) * 4) if n == "mass_kg" else c for n, c in zip(h, r, strict=True)
        ],
    )
    argv = ["fit", meas, "--arm", SEED_ARM, "--add", "mount_compliance@M2", "--json"]
    code, out, err = cli(capsys, *argv)
    note = " ".join(err.split())
    assert code == 0 and json.loads(out)["outside_validity"]["before_fit"] is True
    assert f"{meas}: 10 of 15 measured states (large_deflection 10; line(s) 3, 4, 6 …)" in note
    assert "outside the model's validity before any effect is fitted" in note
    assert "the fitted" not in note


def test_the_api_names_the_file_line_of_a_state_that_cannot_close(tmp_path: Path) -> None:
    """eodarm.fit and eodarm.diagnose on measurements whose state cannot close name the
    file and the state's line, not `pose row 0` (issue 23 item 3)."""
    meas = no_sigma(tmp_path / "m.csv", rows=2)
    meas = edit_rows(
        meas,
        meas,
        lambda h, r: [
            str(float(c) * 1000) if n == "mass_kg" else c for n, c in zip(h, r, strict=True)
        ],
    )
    arm = eodarm.Arm.from_toml(SEED_ARM)
    data = read_measurements(meas, 3)
    for call in (
        lambda: eodarm.fit(arm, data, ["mount_compliance@M2"]),
        lambda: eodarm.diagnose(arm, data),
    ):
        with pytest.raises(ValueError) as err:
            call()
        assert f"{meas} line 2: actuator 1 cannot close its triangle" in str(err.value)


def test_a_state_that_an_added_effect_cannot_close_names_the_effect(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A mount of 0.01 N/mm stretches actuator 1 by kilometres: the refusal names the file,
    the line and the effect that did it (issue 23 item 3)."""
    meas = no_sigma(tmp_path / "m.csv")
    code, _, err = cli(
        capsys, "compare", meas, "--arm", SEED_ARM, "--add", "mount_compliance@M1=0.01"
    )
    line = one_line(code, err)
    assert f"{meas} line 2: actuator 1 cannot close its triangle" in line
    assert "(with mount_compliance@M1 = 0.01 N/mm)" in line


# ---------------------------------------------------------------- nothing overwritten (20.5)
def test_datasets_export_refuses_a_folder_with_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "seed"
    assert cli(capsys, "datasets", "export", "seed2022", out)[0] == 0
    edited = out / "arm.toml"
    edited.write_text(edited.read_text() + "# my edits\n")
    code, _, err = cli(capsys, "datasets", "export", "seed2022", out)
    assert "--force" in one_line(code, err)
    assert edited.read_text().endswith("# my edits\n")
    assert cli(capsys, "datasets", "export", "seed2022", out, "--force")[0] == 0
    assert not edited.read_text().endswith("# my edits\n")


def test_fit_refuses_to_write_over_its_arm_or_its_data(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    arm = tmp_path / "arm.toml"
    arm.write_text(SEED_ARM.read_text())
    meas = no_sigma(tmp_path / "m.csv")
    before = arm.read_text(), meas.read_text()
    fit = ["fit", meas, "--arm", arm, "--add", "mount_compliance@M2"]
    code, _, err = cli(capsys, *fit, "-o", arm, "--force")  # an input, even with --force
    assert "is the --arm file, an input of this run" in one_line(code, err)
    code, _, err = cli(capsys, *fit, "-o", meas, "--force")
    assert "is the measurement file, an input of this run" in one_line(code, err)
    other = tmp_path / "fitted.toml"
    other.write_text("# the user's\n")
    code, _, err = cli(capsys, *fit, "-o", other)
    assert "--force" in one_line(code, err)
    assert (arm.read_text(), meas.read_text()) == before
    assert other.read_text() == "# the user's\n"
    assert cli(capsys, *fit, "-o", other, "--force")[0] == 0
    assert "[fit]" in other.read_text()  # the fitted arm, not the user's file


SWEEP = ["sweep", "--alpha1", "80:90:2", "--alpha2", "10", "--alpha3", "0", "--mass", "5"]


def test_sweep_refuses_an_existing_result_unless_forced(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s.nc"
    assert cli(capsys, *SWEEP, "--no-progress", "-o", out)[0] == 0
    first = out.read_bytes()
    code, _, err = cli(capsys, *SWEEP, "--mass", "6", "--no-progress", "-o", out)
    assert "--force" in one_line(code, err)
    assert out.read_bytes() == first
    assert cli(capsys, *SWEEP, "--mass", "6", "--no-progress", "-o", out, "--force")[0] == 0
    assert out.read_bytes() != first


def test_resume_of_an_interrupted_overwrite_needs_no_force(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """An overwrite of OUT.zarr that was interrupted left .OUT.zarr.partial beside the old
    OUT.zarr: --resume continues it (the overwrite was asked for when it started)."""
    from eodarm.workspace import store

    out = tmp_path / "s.zarr"
    out.mkdir()
    store.partial_path(out).mkdir()
    called: list[bool] = []

    def fake(path: Any, arm: Any, **kw: Any) -> None:
        called.append(kw["resume"])
        raise store.SweepInterrupted(Path(path), "done", True)

    monkeypatch.setattr(store, "sweep_to_zarr", fake)
    code, _, err = cli(capsys, *SWEEP, "--no-progress", "-o", out, "--resume")
    assert called == [True], err
    code, _, err = cli(capsys, *SWEEP, "--no-progress", "-o", out)
    assert "--force" in one_line(code, err)


# ---------------------------------------------------------------- did you mean (20.4)
def test_a_misspelled_effect_or_place_gets_a_did_you_mean(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(EffectError, match="did you mean 'mount_compliance'"):
        eodarm.Effect("mount_complience", "M2", stiffness_n_per_mm=1e4)
    with pytest.raises(EffectError, match="did you mean 'O3'"):
        eodarm.Effect("joint_clearance", "o3", clearance_mm=0.1)
    with pytest.raises(EffectError, match="did you mean O2, or actuator_compliance"):
        eodarm.Effect("joint_clearance", "M2", clearance_mm=0.1)
    code, _, err = cli(capsys, "solve", "--add", "mount_complience@M2=1e4")
    assert "did you mean 'mount_compliance'" in one_line(code, err)
    code, _, err = cli(capsys, "diagnose", SEED, "--add", "mount_complience@M2")
    assert "did you mean 'mount_compliance'" in one_line(code, err)


@pytest.mark.parametrize(
    ("old", "new", "key", "meant"),
    [
        ("measure = [", "measure_point = [", "link[3].measure_point", "measure"),
        ("stiffness_n_per_mm", "stifness_n_per_mm", "actuator[1].stifness_n_per_mm",
         "stiffness_n_per_mm"),
        ("min_length_mm", "min_lenght_mm", "actuator[1].min_lenght_mm", "min_length_mm"),
    ],
)  # fmt: skip
def test_a_misspelled_arm_key_is_refused_not_left_to_its_default(
    tmp_path: Path, old: str, new: str, key: str, meant: str
) -> None:
    """A misspelled optional key used to be ignored: the measure point fell back to the load
    point, the stroke limit to none. It is refused, naming the key it probably meant."""
    text = EXAMPLE.read_text()
    assert old in text
    path = tmp_path / "arm.toml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(ArmFileError) as err:
        eodarm.Arm.from_toml(path)
    msg = str(err.value)
    assert str(path) in msg and f"'{key}'" in msg and f"did you mean '{meant}'" in msg


def test_a_misspelled_column_gets_a_did_you_mean(tmp_path: Path) -> None:
    src = no_sigma(tmp_path / "m.csv").read_text()
    path = tmp_path / "typo.csv"
    path.write_text(src.replace("dy_mm", "dy_m", 1))
    with pytest.warns(UserWarning, match="'dy_m' \\(did you mean 'dy_mm'\\?\\)"):
        read_measurements(path, 3)
    path.write_text(src.replace("mass_kg", "mass_g", 1))
    with pytest.raises(MeasurementFileError, match="'mass_kg' \\(is it 'mass_g'\\?\\)"):
        read_measurements(path, 3)


# ---------------------------------------------------------------- spreadsheets and odd files
def test_a_semicolon_file_is_read_with_a_note(tmp_path: Path) -> None:
    src = no_sigma(tmp_path / "m.csv")
    path = tmp_path / "semi.csv"
    path.write_text(src.read_text().replace(",", ";"))
    with pytest.warns(UserWarning, match="semicolon-separated"):
        got = read_measurements(path, 3)
    want = read_measurements(src, 3)
    np.testing.assert_array_equal(got.values, want.values)  # the same text, the same parse


def test_a_decimal_comma_is_named_as_such(tmp_path: Path) -> None:
    path = tmp_path / "semi.csv"
    text = no_sigma(tmp_path / "m.csv").read_text().replace(",", ";")
    path.write_text(text.replace("115.6", "115,6", 1))
    with pytest.warns(UserWarning), pytest.raises(MeasurementFileError) as err:
        read_measurements(path, 3)
    assert "line 2: alpha1_deg '115,6': a decimal comma? (write 115.6)" in str(err.value)


def test_spreadsheet_trailing_empty_rows_are_skipped_with_a_note(tmp_path: Path) -> None:
    src = no_sigma(tmp_path / "m.csv")
    path = tmp_path / "excel.csv"
    width = src.read_text().splitlines()[0].count(",")
    path.write_text(src.read_text() + ("," * width + "\n") * 40)
    with pytest.warns(UserWarning, match="skipped 40 row\\(s\\) with every cell empty") as rec:
        got = read_measurements(path, 3)
    assert all(len(str(w.message)) < 200 for w in rec)
    assert got.n_rows == read_measurements(src, 3).n_rows


@pytest.mark.parametrize("name", ["/dev/zero", "binary"])
def test_a_binary_file_is_one_line(tmp_path: Path, name: str) -> None:
    path = Path(name)
    if name == "binary":
        path = tmp_path / "data.csv"
        path.write_bytes(b"config,alpha1_deg\n\x00\x01\x02" * 100)
    if not path.exists():
        pytest.skip(f"no {path} here")
    with pytest.raises(MeasurementFileError, match="binary file") as err:
        read_measurements(path, 3)
    assert "\n" not in str(err.value)


def test_a_measurement_file_has_a_size_limit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The cap is 100 MB; here lowered to the seed file's size, so that a file one row
    longer is refused in one line (and the seed file itself is still read)."""
    from eodarm.data import reader

    src = no_sigma(tmp_path / "m.csv")
    monkeypatch.setattr(reader, "MAX_FILE_BYTES", src.stat().st_size)
    read_measurements(src, 3)
    big = tmp_path / "big.csv"
    text = src.read_text()
    big.write_text(text + text.splitlines()[1] + "\n")
    with pytest.raises(MeasurementFileError, match="larger than") as err:
        read_measurements(big, 3)
    assert str(big) in str(err.value)
    with pytest.raises(MeasurementFileError, match="larger than"):
        read_measurements(io.StringIO(big.read_text()), 3)


# ---------------------------------------------------------------- numbers of the right kind (23.5)
P = [[80.0, 10.0, 0.0]]
GRID = {"alpha1": [80.0], "alpha2": [10.0], "alpha3": [0.0]}


def _arm() -> eodarm.Arm:
    return eodarm.Arm.from_toml(EXAMPLE)


def _synth(**kw: Any) -> Any:
    from eodarm.analysis.synth import synth

    return synth(_arm(), P, [1.0], **kw)


WRONG_KINDS: dict[str, Callable[[], Any]] = {
    "complex angles": lambda: eodarm.solve(_arm(), np.array(P) + 0j, 1.0),
    "complex mass": lambda: eodarm.solve(_arm(), P, np.complex128(1.0)),
    "datetime angles": lambda: eodarm.solve(
        _arm(), np.array([[80, 10, 0]], dtype="datetime64[s]"), 1.0
    ),
    "timedelta mass": lambda: eodarm.solve(_arm(), P, np.timedelta64(1, "s")),
    "bool angles": lambda: eodarm.solve(_arm(), np.array([[True, False, True]]), 1.0),
    "bool mass": lambda: eodarm.solve(_arm(), P, True),
    "string angles": lambda: eodarm.solve(_arm(), [["80", "10", "0"]], 1.0),
    "string mass": lambda: eodarm.solve(_arm(), P, "1.0"),
    "forward complex": lambda: eodarm.forward(_arm(), np.array(P) + 1j),
    "bool clearance": lambda: eodarm.Effect("joint_clearance", "O3", clearance_mm=True),
    "string clearance": lambda: eodarm.Effect("joint_clearance", "O3", clearance_mm="0.1"),
    "numpy complex clearance": lambda: eodarm.Effect(
        "joint_clearance", "O3", clearance_mm=np.complex128(0.1)
    ),
    "max_iter 2**32": lambda: eodarm.compensate(_arm(), P, 1.0, max_iter=2**32),
    "max_iter 2**70": lambda: eodarm.compensate(_arm(), P, 1.0, max_iter=2**70),
    "complex tol": lambda: eodarm.compensate(_arm(), P, 1.0, tol_mm=1e-3 + 0j),
    "bool tol": lambda: eodarm.compensate(_arm(), P, 1.0, tol_mm=True),
    "chunk_size 2**64": lambda: eodarm.sweep(
        _arm(), alpha_deg=GRID, mass_kg=[1.0], chunk_size=2**64
    ),
    "threads 2**64": lambda: eodarm.sweep(_arm(), alpha_deg=GRID, mass_kg=[1.0], threads=2**64),
    "bool sweep mass": lambda: eodarm.sweep(_arm(), alpha_deg=GRID, mass_kg=[True]),
    "datetime grid": lambda: eodarm.sweep(
        _arm(), alpha_deg={**GRID, "alpha1": np.array([80], dtype="datetime64[D]")}, mass_kg=[1.0]
    ),
    "complex measured values": lambda: Measurements.from_arrays(
        "c1", P, 1.0, {"dy_mm": np.array([-1.0 + 1e-3j])}
    ),
    "bool measured mass": lambda: Measurements.from_arrays("c1", P, True, {"dy_mm": [-1.0]}),
    "synth repeats 2**64": lambda: _synth(repeats=2**64),
    "synth complex noise": lambda: _synth(noise=1 + 1j),
    "diagnose max_set 2**64": lambda: eodarm.diagnose(
        eodarm.Arm.from_toml(SEED_ARM), read_measurements(SEED, 3), max_set=2**64
    ),
}  # fmt: skip


@pytest.mark.parametrize("case", list(WRONG_KINDS))
def test_numbers_of_the_wrong_kind_are_refused_in_one_line(case: str) -> None:
    """Before, each of these was taken (the imaginary part dropped, a date read as degrees,
    True as 1.0 mm, "80" as 80) or ended in an OverflowError."""
    with pytest.raises(ValueError) as err:  # InputError / EffectError: ValueError subclasses
        WRONG_KINDS[case]()
    assert isinstance(err.value, (InputError, EffectError, MeasurementFileError)), err.value
    assert "\n" not in str(err.value)


def test_numbers_of_the_right_kind_still_go_through() -> None:
    arm = _arm()
    a = eodarm.solve(arm, np.array(P, dtype=np.float32), np.int64(2))
    b = eodarm.solve(arm, [[80, 10, 0]], 2.0)
    # float32 holds 80, 10 and 0 exactly: the same pose, the same answer to rounding
    np.testing.assert_allclose(a["dy_mm"], b["dy_mm"], rtol=1e-12)
    eodarm.Effect("joint_clearance", "O3", clearance_mm=np.float32(0.1))
    eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=np.int64(3000))


# ---------------------------------------------------------------- next: lines that run (20.4)
SHIM = '''
import numpy as np
import eodarm


@eodarm.custom_effect("door_shim", places="M", parameter="shim_mm", lower=0.0, upper=None,
                      start=0.01, neutral=0.0, unit="mm")
def door_shim(state, i, shim_mm):
    """A shim that the actuator's sensor does not see: the pin-to-pin length grows by it."""
    return {"actuator_unseen_mm": np.full(state.force_n.shape[0], shim_mm)}
'''


def _next_argv(err: str) -> list[str]:
    assert "eodarm: next: eodarm " in err, err
    text = err.split("eodarm: next: eodarm ", 1)[1].replace("\\\n", " ")
    return shlex.split(text)


@pytest.fixture(scope="module")
def shim(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The shim's file; the commands given it register door_shim, forgotten after the
    module (a later test's catalogue must not hold it)."""
    from eodarm.model import custom

    path = tmp_path_factory.mktemp("effects") / "shim.py"
    path.write_text(SHIM)
    yield path
    custom.unregister("door_shim")


def _hinted(tmp: Path, shim: Path) -> dict[str, list[str]]:
    meas = no_sigma(tmp / "meas.csv")
    common = ["--effects", str(shim), "--no-self-weight"]
    return {
        "compare": ["compare", meas, "--arm", SEED_ARM, "--add", "door_shim@M2", *common],
        "fit": ["fit", meas, "--arm", SEED_ARM, "--add", "mount_compliance@M2", *common],
        "fit -o": [
            "fit", meas, "--arm", SEED_ARM, "--add", "mount_compliance@M2", "-o",
            tmp / "fitted.toml", *common,
        ],
        "fit -o, fem": [
            "fit", meas, "--arm", SEED_ARM, "--add", "mount_compliance@M2", "-o",
            tmp / "fitted_fem.toml", "--model", "fem", *common,
        ],
        "compare, fem": [
            "compare", meas, "--arm", SEED_ARM, "--model", "fem", "--elements-per-link", "4",
            *common,
        ],
        "diagnose": ["diagnose", meas, "--arm", SEED_ARM, "--max-set", "1", *common],
        "solve": ["solve", "--add", "door_shim@M2=0.05", "--alpha", "90,10,0", *common],
        "compensate": [
            "compensate", "--add", "door_shim@M2=0.05", "--alpha", "90,10,0", "--mass", "5",
            *common,
        ],
        "synth": ["synth", "--configs", "3", "--hidden", "door_shim@M2=0.05", "-o",
                  tmp / "s.csv", *common],
        "plan": ["plan", "--arm", SEED_ARM, "--configs", "2", "--pool", "60", *common],
    }  # fmt: skip


@pytest.mark.parametrize(
    "command",
    [
        "compare", "compare, fem", "diagnose", "fit", "fit -o", "fit -o, fem", "solve",
        "compensate", "synth", "plan",
    ],
)  # fmt: skip
def test_a_next_line_carries_the_effects_file_and_the_model_and_runs(
    command: str,
    shim: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """After a command run with --effects FILE.py (and --no-self-weight), the next: line
    names the file (its --add of a user-written effect is unknown without it) and the
    model's options, and the pasted command runs (issue 20 item 4)."""
    monkeypatch.chdir(tmp_path)
    code, _, err = cli(capsys, *_hinted(tmp_path, shim)[command])
    assert code == 0, err
    argv = _next_argv(err)
    assert argv[argv.index("--effects") + 1] == str(shim), argv
    assert "--no-self-weight" in argv, argv
    if "fem" in command and "--uncertainty" not in argv:
        assert argv[argv.index("--model") + 1] == "fem", argv
    if command == "compare, fem":
        assert argv[argv.index("--elements-per-link") + 1] == "4", argv
    if argv[0] == "report":
        return  # the whole report is report's own test
    code, _, err = cli(capsys, *argv)
    assert code == 0, (argv, err)


def test_a_proposed_output_is_never_one_that_would_be_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "fitted.toml").write_text("# the user's\n")
    meas = no_sigma(tmp_path / "m.csv")
    _, _, err = cli(capsys, "fit", meas, "--arm", SEED_ARM, "--add", "mount_compliance@M2")
    argv = _next_argv(err)
    out = argv[argv.index("-o") + 1]
    assert out != "fitted.toml" and not Path(out).exists()


def test_compensate_names_the_lines_of_a_pose_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Poses from a file that cannot be compensated are named by their lines in it, not by
    0-based rows (issue 23 item 3); a binary pose file is one line."""
    poses = tmp_path / "poses.csv"
    poses.write_text("config,alpha1_deg,alpha2_deg,alpha3_deg\na,90,10,0\nb,95,15,0\n")
    code, _, err = cli(capsys, "compensate", "--poses", poses, "--mass", "5000")
    line = one_line(code, err)
    assert f"{poses} lines 2, 3:" in line and "rows 0" not in line
    code, _, err = cli(capsys, "compensate", "--poses", "/dev/zero", "--mass", "5")
    assert "binary file" in one_line(code, err)
