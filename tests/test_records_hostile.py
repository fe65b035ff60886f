"""Hostile records and campaign files (docs/records.md, "What is refused"): each is refused in
one line under 300 characters that names the file and the record, key, line (1-based, blank
lines counted) or time; the bytes that are not printable are escaped; the exit status is 2;
no traceback, no measurement file, and no memory that grows with a file that never ends."""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable
from pathlib import Path

import pytest

from eodarm.cli import main
from eodarm.data.record_text import MAX_LINE

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "example_arm.toml"


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A good campaign of one rehearsal record (c1.csv), to be spoilt by each test."""
    d = tmp_path_factory.mktemp("base")
    argv = ["synth", "--arm", str(EXAMPLE), "--records", str(d), "--configs", "1", "--seed", "4"]
    assert main(argv) == 0
    return d / "campaign.toml"


def spoil(base: Path, where: Path, campaign: Callable[[str], str] | None = None) -> Path:
    """A copy of the base campaign in ``where``, its campaign text edited by ``campaign``."""
    where.mkdir(parents=True, exist_ok=True)
    for f in base.parent.iterdir():
        (where / f.name).write_bytes(f.read_bytes())
    c = where / base.name
    if campaign is not None:
        c.write_text(campaign(c.read_text()))
    return c


def edit_lines(path: Path, edit: Callable[[list[str]], list[str]]) -> None:
    lines = path.read_text().split("\n")
    path.write_text("\n".join(edit(lines)))


def set_cell(line: str, col: int, text: str) -> str:
    cells = line.split(",")
    cells[col] = text
    return ",".join(cells)


def refused(campaign: Path, capsys: pytest.CaptureFixture[str]) -> str:
    """Run ``records`` on a campaign that must be refused: exit 2, one line under 300
    characters, every character printable, no output file; return the message."""
    out = campaign.parent / "meas.csv"
    capsys.readouterr()
    assert main(["records", str(campaign), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.endswith("\n"), err
    line = err[:-1]
    assert len(line) < 300, len(line)
    assert line.isprintable(), repr(line)
    assert "Traceback" not in err
    assert not out.exists()
    return line


# ---------------------------------------------------------------------- the campaign file
def test_an_absurd_payload_is_refused_naming_campaign_record_and_key(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(
        base, tmp_path, lambda t: t.replace("masses_kg = [0.0, 1.5", "masses_kg = [0.0, 1e300")
    )
    err = refused(c, capsys)
    assert "campaign.toml: record 1: 'masses_kg' 1e+300 is beyond" in err


def test_an_absurd_angle_is_refused_naming_campaign_record_and_key(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(base, tmp_path, lambda t: re.sub(r"alpha_deg = \[[^,]*,", "alpha_deg = [1e300,", t))
    err = refused(c, capsys)
    assert "campaign.toml: record 1: 'alpha_deg' 1e+300 is beyond" in err


def test_labels_equal_but_for_spaces_are_refused(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two records labelled 'c1' and 'c1 ' would be read back as one sequence from two
    poses."""
    second = '\n[[record]]\nfile = "c2.csv"\nconfig = "c1 "\nalpha_deg = [80.0, 40.0, 20.0]\n'
    second += "masses_kg = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]\n"
    c = spoil(base, tmp_path, lambda t: t + second)
    (tmp_path / "c2.csv").write_bytes((tmp_path / "c1.csv").read_bytes())
    err = refused(c, capsys)
    assert "record 2: config 'c1 ' is record 1's 'c1' but for spaces" in err


def test_a_record_name_with_a_nul_byte_is_refused_naming_the_record(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(base, tmp_path, lambda t: t.replace('file = "c1.csv"', 'file = "c1\\u0000.csv"'))
    err = refused(c, capsys)
    assert "campaign.toml: record 1: 'file' 'c1\\x00.csv'" in err


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_a_campaign_file_that_never_ends_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = tmp_path / "campaign.toml"
    c.symlink_to("/dev/zero")
    err = refused(c, capsys)
    assert "campaign.toml: not a regular file" in err


# ---------------------------------------------------------------------- the record's bytes
@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_a_record_at_dev_zero_is_refused_before_it_is_read(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(base, tmp_path)
    (tmp_path / "c1.csv").unlink()
    (tmp_path / "c1.csv").symlink_to("/dev/zero")
    err = refused(c, capsys)
    assert "c1.csv: not a regular file" in err


def test_a_record_without_newlines_is_refused_at_its_first_line(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(base, tmp_path)
    (tmp_path / "c1.csv").write_text("time_s,dy_mm" + ",1.5" * (MAX_LINE // 2))
    err = refused(c, capsys)
    assert f"c1.csv line 1: longer than {MAX_LINE} characters" in err and "whole file" in err


def test_a_cell_of_131073_characters_is_refused_in_one_line(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Beyond the csv module's field limit (131072) it used to end in a traceback."""
    c = spoil(base, tmp_path)
    edit_lines(
        tmp_path / "c1.csv", lambda L: [*L[:700], set_cell(L[700], 2, "1" * 131073), *L[701:]]
    )
    err = refused(c, capsys)
    assert f"c1.csv line 701: longer than {MAX_LINE} characters" in err


def test_a_long_cell_is_shown_shortened(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(base, tmp_path)
    edit_lines(tmp_path / "c1.csv", lambda L: [*L[:700], set_cell(L[700], 2, "x" * 5000), *L[701:]])
    err = refused(c, capsys)
    assert "c1.csv line 701 (time " in err and "dy_mm 'xxxx" in err and "is not a number" in err


def test_a_symlink_loop_is_refused_in_one_line(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The second record's file is a link that loops (checking that it is not the first
    record's file used to end in a traceback)."""
    second = '\n[[record]]\nfile = "loop_a.csv"\nconfig = "c2"\nalpha_deg = [80.0, 40.0, 20.0]\n'
    second += "masses_kg = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]\n"
    c = spoil(base, tmp_path, lambda t: t + second)
    (tmp_path / "loop_a.csv").symlink_to(tmp_path / "loop_b.csv")
    (tmp_path / "loop_b.csv").symlink_to(tmp_path / "loop_a.csv")
    err = refused(c, capsys)
    assert "loop_a.csv: cannot read record" in err


def test_a_campaign_file_that_loops_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "a.toml").symlink_to(tmp_path / "b.toml")
    (tmp_path / "b.toml").symlink_to(tmp_path / "a.toml")
    err = refused(tmp_path / "a.toml", capsys)
    assert "a.toml: cannot read campaign file" in err


def test_a_leading_unnamed_field_is_refused_not_taken_for_an_index(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(base, tmp_path)
    edit_lines(
        tmp_path / "c1.csv",
        lambda L: [L[0]] + [f"{i},{line}" if line else line for i, line in enumerate(L[1:])],
    )
    err = refused(c, capsys)
    assert "c1.csv: every line has 10 fields, the header 9" in err
    assert "leading unnamed field" in err


@pytest.mark.parametrize(
    ("header", "why"),
    [
        (lambda h: "," + h, "column 1 has no name (an index column, as pandas writes one?"),
        (lambda h: h + ",", "column 10 has no name (a trailing comma?)"),
        (lambda h: h.replace(",", ",,", 1), "column 2 has no name (two commas in a row?)"),
    ],
)
def test_a_column_without_a_name_says_what_it_looks_like(
    base: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    header: Callable[[str], str],
    why: str,
) -> None:
    """A record written by pandas with its index (``df.to_csv(path)``): the header starts
    with an empty name and every line with the row number. It was called "a trailing
    comma?"."""
    c = spoil(base, tmp_path)
    edit_lines(
        tmp_path / "c1.csv",
        lambda L: (
            [header(L[0])] + [f"{i},{line}" if line else line for i, line in enumerate(L[1:])]
        ),
    )
    err = refused(c, capsys)
    assert f"c1.csv line 1: {why}" in err


def test_a_stray_field_names_its_lines(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(base, tmp_path)
    edit_lines(tmp_path / "c1.csv", lambda L: [*L[:900], L[900] + ",7", *L[901:]])
    err = refused(c, capsys)
    assert "c1.csv: 1 line with other than the header's 9 fields: line 901 (time " in err


@pytest.mark.parametrize(
    ("bad", "says"),
    [
        ("\x1b[31mred\x07", "dy_mm '\\x1b[31mred\\x07' is not a number"),
        ("4.2\x00", "line 701: a NUL byte"),
    ],
    ids=["escape", "nul"],
)
def test_bytes_that_are_not_printable_are_escaped(
    bad: str, says: str, base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(base, tmp_path)
    edit_lines(tmp_path / "c1.csv", lambda L: [*L[:700], set_cell(L[700], 2, bad), *L[701:]])
    err = refused(c, capsys)
    assert says in err and "\x1b" not in err and "\x00" not in err


def test_a_header_of_100_kB_is_refused_without_being_echoed(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(base, tmp_path)
    edit_lines(tmp_path / "c1.csv", lambda L: [L[0] + ",d" + "z" * 100_000, *L[1:]])
    err = refused(c, capsys)
    assert "c1.csv line 1: longer than" in err


def test_a_long_unknown_column_is_shown_shortened(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    c = spoil(base, tmp_path)
    edit_lines(tmp_path / "c1.csv", lambda L: [L[0].replace("dy_mm", "q" * 20_000), *L[1:]])
    err = refused(c, capsys)
    assert "c1.csv line 1: unknown channel 'qqqq" in err


# ---------------------------------------------------------------------- true line numbers
def test_blank_lines_are_counted_in_the_line_numbers(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Five blank lines after line 10: the bad cell on the file's line 706 is called line 706,
    and the time that goes back on line 906 is called line 906."""

    def edit(L: list[str]) -> list[str]:
        L = [*L[:10], "", "  ", "", "\t", "", *L[10:]]
        L[705] = set_cell(L[705], 2, "abc")
        return L

    c = spoil(base, tmp_path)
    edit_lines(tmp_path / "c1.csv", edit)
    err = refused(c, capsys)
    assert "c1.csv line 706 (time " in err and "dy_mm 'abc' is not a number" in err

    def swap(L: list[str]) -> list[str]:
        L = [*L[:10], "", "", "", "", "", *L[10:]]
        L[904], L[905] = L[905], L[904]
        return L

    spoil(base, tmp_path)
    edit_lines(tmp_path / "c1.csv", swap)
    err = refused(c, capsys)
    assert "c1.csv: time does not increase at 1 place: line 906: time_s" in err


def test_many_bad_cells_give_the_first_three_and_the_count(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    def edit(L: list[str]) -> list[str]:
        for i in range(700, 800):
            L[i] = set_cell(L[i], 3, "x" * 200)
        return L

    c = spoil(base, tmp_path)
    edit_lines(tmp_path / "c1.csv", edit)
    err = refused(c, capsys)
    assert "c1.csv: 100 bad cells: " in err and "line 701 (time " in err and "…and 97 more" in err
    assert err.count("dalpha1_deg") == 3


# ---------------------------------------------------------------------- what it holds
def test_a_constant_channel_is_refused_naming_the_record_and_the_channel(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A channel that never changes would be written with σ = 0, which compare refuses."""
    c = spoil(base, tmp_path)
    edit_lines(
        tmp_path / "c1.csv", lambda L: [L[0]] + [set_cell(x, 2, "1.5") if x else x for x in L[1:]]
    )
    err = refused(c, capsys)
    assert "c1.csv: dy_mm is constant (1.5 in all" in err


def test_an_absurd_reading_is_refused_not_written(
    base: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A sensor whose reading jumps by 10⁶ mm between the reference and the first payload: the
    later states' difference from the reference is beyond a measurement file's range (10⁵
    mm), so no file is written that compare would refuse."""
    capsys.readouterr()
    assert main(["records", str(base), "--json"]) == 0
    states = json.loads(capsys.readouterr().out)["records"][0]["states"]
    between = (states[0]["end_s"] + states[1]["start_s"]) / 2
    c = spoil(base, tmp_path)

    def jump(x: str) -> str:
        cells = x.split(",")
        if not x or float(cells[0]) < between:
            return x
        return set_cell(x, 1, f"{float(cells[1]) + 1e6:.12g}")

    edit_lines(tmp_path / "c1.csv", lambda L: [L[0]] + [jump(x) for x in L[1:]])
    err = refused(c, capsys)
    assert "c1.csv: the steady state at" in err and "dx_mm changed by 1e+06" in err
    assert "beyond ±100000" in err
