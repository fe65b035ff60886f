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


# ---------------------------------------------------------------------------- records
@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two rehearsal records of the example arm and their campaign file."""
    d = tmp_path_factory.mktemp("records")
    argv = ["synth", "--arm", str(EXAMPLE), "--records", str(d / "rec"), "--configs", "2"]
    assert main([*argv, "--hidden", "joint_friction@O2=3000"]) == 0
    return d / "rec" / "campaign.toml"


def test_synth_records_then_records_hand_the_arm_on(
    campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """No ``--arm ARM.toml`` placeholder in a next: line: synth hands its arm to records,
    records to diagnose; without the arm, records says what the next command needs."""
    argv = ["synth", "--arm", str(EXAMPLE), "--records", str(tmp_path / "rec"), "--configs", "1"]
    assert main(argv) == 0
    said = capsys.readouterr().err.replace("\\\n", " ")
    assert f"--arm {EXAMPLE}" in " ".join(said.split())
    out = tmp_path / "meas.csv"
    assert main(["records", str(campaign), "-o", str(out), "--arm", str(EXAMPLE)]) == 0
    err = " ".join(capsys.readouterr().err.replace("\\\n", " ").split())
    assert f"next: eodarm diagnose {out} --arm {EXAMPLE}" in err
    assert "ARM.toml" not in err
    assert main(["records", str(campaign), "-o", str(tmp_path / "m2.csv")]) == 0
    err = capsys.readouterr().err
    assert "eodarm: next:" not in err and "give the arm the records were taken on" in err


def test_records_refuses_an_arm_of_other_links(
    campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from arms import four_link_arm

    arm = tmp_path / "four.toml"
    arm.write_text(four_link_arm().to_toml(), encoding="utf-8")
    argv = ["records", str(campaign), "-o", str(tmp_path / "m.csv"), "--arm", str(arm)]
    assert main(argv) == 2
    [line] = capsys.readouterr().err.strip().splitlines()
    assert "3 angles (alpha_deg)" in line and "4 links" in line
    assert not (tmp_path / "m.csv").exists()


def test_a_misspelled_campaign_table_or_key_is_named(
    campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A [[recrd]] table would drop its records with only a note: refused, with the word
    meant; ``mass_kg`` for ``masses_kg`` is named in the missing key's message."""
    text = campaign.read_text(encoding="utf-8")
    second = text.index("[[record]]", text.index("[[record]]") + 1)
    bad = campaign.with_name("typo_table.toml")
    bad.write_text(text[:second] + text[second:].replace("[[record]]", "[[recrd]]", 1))
    assert main(["records", str(bad), "-o", str(tmp_path / "a.csv")]) == 2
    [line] = capsys.readouterr().err.strip().splitlines()
    assert "[[recrd]]" in line and "did you mean [[record]]?" in line
    bad = campaign.with_name("typo_key.toml")
    bad.write_text(text.replace("masses_kg", "mass_kg", 1))
    assert main(["records", str(bad), "-o", str(tmp_path / "b.csv")]) == 2
    [line] = capsys.readouterr().err.strip().splitlines()
    assert line.endswith("record 1: missing key 'masses_kg' (is it 'mass_kg'?)")
