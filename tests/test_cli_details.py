"""The small promises of the command line and the package (issue 28, item 4): a negative
angle first in a list is a value, a retired option is out of the help, every CSV written has
LF line ends, Ctrl-C after a sweep's result is in place says the result is whole, counts read
as words, and ``eodarm``'s namespace is its API."""

from __future__ import annotations

from pathlib import Path

import pytest

import eodarm
from eodarm.cli import main
from eodarm.workspace import store

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
SWEEP = ["sweep", "--arm", str(EXAMPLE), "--alpha1", "80:100:3", "--alpha2", "0:10:2"]
SWEEP += ["--alpha3", "0", "--mass", "5", "--no-progress"]


def test_a_list_of_angles_that_starts_negative_is_a_value(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["solve", "--arm", str(EXAMPLE), "--alpha", "-5,10,0", "--mass", "1"]) in (0, 2)
    err = capsys.readouterr().err
    assert "expected one argument" not in err  # parsed: the pose itself may be refused
    assert main(["compensate", "--arm", str(EXAMPLE), "--alpha", "95,-5,10", "--mass", "1"]) == 0
    capsys.readouterr()


def test_an_option_without_its_value_hints_at_the_equals_form(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["solve", "--arm", str(EXAMPLE), "--alpha", "-x", "--mass", "1"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "--alpha=VALUE" in err and len(err.strip().splitlines()) == 1


def test_a_retired_option_is_accepted_but_not_offered(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        main(["sweep", "--help"])
    assert "--mask-unreachable" not in capsys.readouterr().out
    assert main([*SWEEP, "--mask-unreachable"]) == 0
    capsys.readouterr()


def test_every_csv_written_has_lf_line_ends(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "commanded.csv"
    argv = ["compensate", "--arm", str(EXAMPLE), "--alpha", "95,5,10", "--mass", "5"]
    assert main([*argv, "-o", str(out)]) == 0
    data = out.read_bytes()
    assert b"\n" in data and b"\r" not in data
    meas = tmp_path / "meas.csv"
    assert main(["synth", "--arm", str(EXAMPLE), "--configs", "3", "-o", str(meas)]) == 0
    res = tmp_path / "residuals.csv"
    assert main(["compare", str(meas), "--arm", str(EXAMPLE), "--residuals", str(res)]) == 0
    assert b"\r" not in res.read_bytes() and b"\r" not in meas.read_bytes()
    capsys.readouterr()


def test_ctrl_c_once_the_result_is_in_place_says_it_is_whole(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A Ctrl-C that arrives while the result is renamed into place is held until it is
    there (``store.replace``), then raised: the one line must say the file is complete. The
    held signal is stood in for by a KeyboardInterrupt raised as ``replace`` returns (no
    signal is sent, so nothing depends on timing)."""
    real = store.replace

    def replace_then_ctrl_c(new: Path, out: Path) -> None:
        real(new, out)
        raise KeyboardInterrupt

    monkeypatch.setattr(store, "replace", replace_then_ctrl_c)
    out = tmp_path / "sweep.nc"
    assert main([*SWEEP, "-o", str(out)]) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"eodarm: interrupted: {out} was written completely"]
    assert out.exists() and not list(tmp_path.glob(".sweep.nc.*"))


def test_ctrl_c_during_the_summary_says_the_result_is_whole(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from eodarm.cli import sweep as cli_sweep

    def summary(_: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_sweep, "_summary", summary)
    out = tmp_path / "sweep.nc"
    assert main([*SWEEP, "-o", str(out)]) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{out} was written completely" in err[0]


def test_counts_read_as_words(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(SWEEP) == 0
    err = " ".join(capsys.readouterr().err.split())
    assert "× 1 payload in" in err and "1 payloads" not in err


def test_the_package_namespace_is_its_api() -> None:
    assert "ArgumentTypeError" not in eodarm.__all__  # argparse's name; eodarm.errors has it
    shown = set(dir(eodarm))
    assert shown == set(eodarm.__all__)
    for helper in ("Any", "TYPE_CHECKING", "importlib", "annotations", "_PUBLIC"):
        assert helper not in shown
    for name in eodarm.__all__:  # every name exported resolves
        assert getattr(eodarm, name) is not None
