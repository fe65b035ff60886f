"""Hostile input gets one clear line, never a traceback (issue 15's reproducers).

Through the command line: exit status 2 with exactly one line on stderr, or exit 0 with the
data on stdout and notes on stderr. Through the API: a ValueError or TypeError subclass of
eodarm's with a one-line message, never OverflowError, AttributeError or a bare int() error.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import eodarm
from eodarm.errors import ArgumentTypeError, EffectError, EodarmError, InputError

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
TEXT = EXAMPLE.read_text(encoding="utf-8")


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "eodarm", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


def one_error_line(res: subprocess.CompletedProcess[str]) -> str:
    assert res.returncode == 2, res.stderr
    lines = res.stderr.splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("eodarm: error: "), lines[0]
    assert "Traceback" not in res.stderr
    return lines[0]


@pytest.mark.parametrize(
    ("old", "new", "says"),
    [
        ("mass_kg = 3.0", "mass_kg = 1" + "0" * 309, "too large"),
        ("mass_kg = 3.0", "mass_kg = 1e200", "physical range"),
        ("O1 = [0.0, 0.0]", "O1 = [0.0, 1e300]", "physical range"),
        ("stiffness_n_per_mm = 3000.0", "stiffness_n_per_mm = 1e300", "physical range"),
    ],
)
def test_numbers_an_arm_cannot_have_are_refused_in_one_line(
    tmp_path: Path, old: str, new: str, says: str
) -> None:
    assert old in TEXT
    path = tmp_path / "arm.toml"
    path.write_text(TEXT.replace(old, new, 1), encoding="utf-8")
    line = one_error_line(cli("solve", "--arm", str(path)))
    assert str(path) in line and says in line


def test_a_deeply_nested_array_is_refused_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * 2000 + "]" * 2000 + "\n" + TEXT, encoding="utf-8")
    assert "nested too deeply" in one_error_line(cli("solve", "--arm", str(path)))


def test_a_byte_order_mark_is_accepted(tmp_path: Path) -> None:
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + TEXT.encode("utf-8"))
    assert eodarm.Arm.from_toml(path) == eodarm.Arm.from_toml(EXAMPLE)


def test_an_unknown_key_is_a_note_after_success_and_silent_on_failure(tmp_path: Path) -> None:
    path = tmp_path / "serial.toml"
    path.write_text(TEXT.replace("mass_kg = 3.0", 'mass_kg = 3.0\nserial = "A17"', 1))
    ok = cli("solve", "--arm", str(path), "--json")
    assert ok.returncode == 0, ok.stderr
    notes = ok.stderr.split("eodarm: next:")[0]  # then the command to run next
    assert " ".join(notes.split()) == (
        f"eodarm: note: {path}: key 'link[1].serial' is not an arm-file key and is ignored"
    )
    # a misspelled key is refused (its default would be used silently): see test_door.py
    typo = tmp_path / "typo.toml"
    typo.write_text(TEXT.replace("mass_kg = 3.0", "mass_kg = 3.0\nmas_kg = 3.0", 1))
    assert "did you mean 'mass_kg'" in one_error_line(cli("solve", "--arm", str(typo)))
    bad = tmp_path / "serial_and_error.toml"
    bad.write_text(path.read_text().replace("stiffness_n_per_mm = 3000.0", "", 1))
    assert "actuator[1].stiffness_n_per_mm" in one_error_line(cli("solve", "--arm", str(bad)))


@pytest.mark.parametrize(
    ("call", "error"),
    [
        (lambda: eodarm.Effect("joint_clearance", "O3", clearance_mm=10**400), EffectError),
        (lambda: eodarm.Effect("joint_clearance", "O³", clearance_mm=0.1), EffectError),
        (lambda: eodarm.Effect("joint_clearance", 3, clearance_mm=0.1), EffectError),
        (lambda: eodarm.solve(_arm(), [[90, 10, 0]], mass_kg=10**400), InputError),
        (lambda: eodarm.solve(_arm(), [[10**400, 10, 0]], mass_kg=1.0), InputError),
        (lambda: eodarm.solve(str(EXAMPLE), [[90, 10, 0]], 1.0), ArgumentTypeError),
        (lambda: eodarm.forward(None, [[90, 10, 0]]), ArgumentTypeError),  # type: ignore[arg-type]
    ],
)
def test_hostile_api_arguments_get_eodarm_errors(call: object, error: type) -> None:
    with pytest.raises(error) as info:
        call()  # type: ignore[operator]
    assert isinstance(info.value, (EodarmError, TypeError))
    msg = str(info.value)
    assert "\n" not in msg and len(msg) < 300, msg


def _arm() -> eodarm.Arm:
    return eodarm.Arm.from_toml(EXAMPLE)


def _campaign(tmp_path: Path) -> tuple[Path, str]:
    import numpy as np

    from eodarm.analysis.synth import random_configs, synth

    arm = _arm()
    meas = synth(arm, random_configs(arm, 4, np.random.default_rng(1)), [1.5, 6.5], seed=1)
    path = tmp_path / "m.csv"
    meas.to_csv(path)
    return path, path.read_text()


@pytest.mark.parametrize("command", ["compare", "diagnose"])
@pytest.mark.parametrize(
    ("column", "value", "says"),
    [
        ("dy_mm", "1e200", "beyond"),
        ("sigma_dy_mm", "1e-300", "not a measurement's noise"),
        ("dy_mm", '"1\n2"', "not a number"),
        ("mass_kg", "1e300", "beyond"),
    ],
)
def test_absurd_measurements_are_refused_at_read_time(
    tmp_path: Path, command: str, column: str, value: str, says: str
) -> None:
    path, text = _campaign(tmp_path)
    head, first, *rest = text.splitlines()
    cells = first.split(",")
    cells[head.split(",").index(column)] = value
    path.write_text("\n".join([head, ",".join(cells), *rest]) + "\n")
    line = one_error_line(cli(command, str(path), "--arm", str(EXAMPLE), "--json"))
    assert "line 2" in line and says in line


def test_solve_of_more_poses_than_memory_holds_raises_memory_error() -> None:
    """10⁸ poses under an address-space limit: refused before anything is allocated, as a
    MemoryError (and an eodarm error: one line), never an abort of the interpreter."""
    code = (
        "import resource, numpy as np, eodarm\n"
        "resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, resource.RLIM_INFINITY))\n"
        f"arm = eodarm.Arm.from_toml({str(EXAMPLE)!r})\n"
        "alpha = np.broadcast_to(np.array([90.0, 10.0, 0.0]), (10**8, 3))\n"
        "try:\n"
        "    eodarm.solve(arm, alpha, 1.0)\n"
        "except MemoryError as exc:\n"
        "    assert isinstance(exc, eodarm.EodarmError)\n"
        "    print('MemoryError:', exc)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.startswith("MemoryError: solve of 100,000,000 poses would need"), res.stdout
