"""A refusal stays one short line (issue 27 item 4).

Under 300 characters whatever the file: the first three offending cells and the count of
the rest; bytes that are not printable escaped; the file always named; true line numbers
(blank lines and cells that span lines counted). Every CSV and TOML reader of ``data/`` and
the arm file are held to it, and figure names made of labels are safe file names.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import eodarm
from eodarm.cli import main
from eodarm.data.poses import read_poses
from eodarm.data.reader import read_measurements
from eodarm.errors import MAX_MESSAGE, EodarmError, listing, show, show_source

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
HEAD = "config,alpha1_deg,alpha2_deg,alpha3_deg,mass_kg"


def refusal(call: object) -> str:
    """The message of the EodarmError that ``call()`` raises, checked to be one short line
    of printable characters."""
    with pytest.raises(EodarmError) as info:
        call()  # type: ignore[operator]
    msg = str(info.value)
    assert "\n" not in msg and msg.isprintable(), repr(msg)
    assert len("eodarm: error: " + msg) < MAX_MESSAGE, (len(msg), msg)
    return msg


def test_a_decimal_comma_export_is_one_short_line_with_three_cells_and_the_count(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A spreadsheet's export in a decimal-comma locale: every number of 500 rows is bad.
    It was refused in one line of 8 000-16 000 characters; now the first three cells, with
    their lines and columns, and the count."""
    monkeypatch.chdir(tmp_path)
    path = Path("export.csv")
    rows = [HEAD.replace(",", ";") + ";dy_mm"]
    rows += [f"c{i};90,5;10,25;0,5;1,5;-1,234" for i in range(500)]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    with pytest.warns(UserWarning, match="semicolon-separated"):
        msg = refusal(lambda: read_measurements(path, 3))
    assert msg.startswith(f"{path}: 500 bad row(s), 2500 bad cells: ")
    assert "line 2: alpha1_deg '90,5': a decimal comma? (write 90.5)" in msg
    assert "line 2: alpha2_deg" in msg and "line 2: alpha3_deg" in msg
    assert "mass_kg" not in msg and msg.endswith("…and 2497 more")
    capsys.readouterr()
    assert main(["compare", str(path), "--arm", str(EXAMPLE)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and len(err[0]) < MAX_MESSAGE


def test_control_bytes_in_cells_and_names_are_escaped(tmp_path: Path) -> None:
    """An escape sequence in a cell, a bell in a label, a carriage return in a column name:
    shown as their escapes, never sent to the terminal."""
    path = tmp_path / "ctrl.csv"
    path.write_text(
        f"{HEAD},dy_mm\nc\a1,90,10,0,\x1b[31m5,-1\nc2,90,10,0,5,-1\x1b]0;x\a\n", encoding="utf-8"
    )
    msg = refusal(lambda: read_measurements(path, 3))
    assert "'\\x1b[31m5' is not a number" in msg and "'-1\\x1b]0;x\\x07'" in msg
    path.write_text(f"{HEAD},dy\x1b_mm,dy\x1b_mm\nc1,90,10,0,5,-1,-1\n", encoding="utf-8")
    msg = refusal(lambda: read_measurements(path, 3))
    assert "column 'dy\\x1b_mm' appears twice" in msg


def test_a_100_kB_header_is_not_echoed(tmp_path: Path) -> None:
    """A column name of 100 kB (a file that is not a measurement file, or a header glued to
    its data) is cut in the message, which stays short (the did-you-mean does not compare
    it either: difflib's time grows with the square of its length)."""
    huge = "x" * 100_000
    path = tmp_path / "huge.csv"
    path.write_text(f"config,{huge},{huge}\nc1,1,2\n", encoding="utf-8")
    msg = refusal(lambda: read_measurements(path, 3))
    assert f"{path}: line 1 (header)" in msg and "appears twice" in msg


@pytest.mark.parametrize("reader", ["measurements", "poses", "arm"])
def test_a_name_with_a_nul_byte_is_named(reader: str) -> None:
    """open() refuses a name with a NUL byte as "embedded null byte", naming no file."""
    name = "da\0ta.csv"
    call = {
        "measurements": lambda: read_measurements(name, 3),
        "poses": lambda: read_poses(name, 3),
        "arm": lambda: eodarm.Arm.from_toml(name),
    }[reader]
    msg = refusal(call)
    assert msg.startswith("da\\x00ta.csv: ") and "NUL byte" in msg


def test_an_unknown_data_set_is_named_printable_and_short() -> None:
    """The data set's name was echoed raw: a NUL, an escape, 10 kB in the message."""
    import eodarm.datasets

    msg = refusal(lambda: eodarm.datasets.load("x\0\x1b[31m" + "y" * 10_000))
    assert msg.startswith("unknown data set 'x\\x00\\x1b[31my") and msg.isprintable()
    assert len(msg) < MAX_MESSAGE and "bundled: seed2022" in msg


def test_a_long_file_name_is_shortened_in_the_middle() -> None:
    name = "/data/" + "campaign-" * 40 + "/meas.csv"
    shown = show_source(name)
    assert len(shown) <= 120 and shown.endswith("/meas.csv") and shown.startswith("/data/")


def test_listing_names_three_and_counts_the_rest_within_the_limit() -> None:
    items = [f"line {k}: {'a' * 200}" for k in range(2, 10)]
    msg = listing("f.csv: 8 bad row(s)", items)
    assert len(msg) <= MAX_MESSAGE and msg.endswith("…and 5 more")
    assert all(f"line {k}: " in msg for k in (2, 3, 4)) and "line 5" not in msg
    assert listing("f.csv: 1 bad row(s)", ["line 2: x"]) == "f.csv: 1 bad row(s): line 2: x"
    assert show("a\0b\x1bc" + "d" * 100, 12) == "a\\x00b\\x1bc…"


def test_blank_lines_and_multiline_cells_keep_the_true_line_numbers(tmp_path: Path) -> None:
    """Blank lines are skipped, and a quoted cell that spans two lines counts both: the
    line named is the line an editor shows."""
    path = tmp_path / "blank.csv"
    path.write_text(
        f'{HEAD},dy_mm\n\nc1,90,10,0,1.5,-1\n"c\n2",90,10,0,1.5,-1\n\n\nc3,90,10,0,x,-1\n',
        encoding="utf-8",
    )
    msg = refusal(lambda: read_measurements(path, 3))
    assert "line 8: mass_kg 'x'" in msg
    poses = tmp_path / "poses.csv"
    poses.write_text(
        'config,alpha1_deg,alpha2_deg,alpha3_deg\n\n"a\nb",90,10,0\n\nc,90,x,0\n', encoding="utf-8"
    )
    msg = refusal(lambda: read_poses(poses, 3))
    assert "line 6 alpha2_deg 'x'" in msg


def test_a_pose_file_names_three_bad_cells_and_counts_the_rest(tmp_path: Path) -> None:
    poses = tmp_path / "poses.csv"
    rows = "".join(f"{k},bad,0\n" for k in range(40))
    poses.write_text(f"alpha1_deg,alpha2_deg,alpha3_deg\n{rows}", encoding="utf-8")
    msg = refusal(lambda: read_poses(poses, 3))
    assert msg.startswith(f"{poses}: 40 bad cells in 40 row(s): line 2 alpha2_deg 'bad'")
    assert "line 4 alpha2_deg" in msg and "line 5" not in msg and msg.endswith("…and 37 more")


def test_an_arm_file_key_with_control_bytes_is_escaped_and_cut(tmp_path: Path) -> None:
    """A key of 5 000 characters with an escape sequence in it: the warning that ignores it
    and the refusal of the key it left missing are short, printable lines."""
    text = EXAMPLE.read_text(encoding="utf-8")
    bad = tmp_path / "arm.toml"
    key = '"mass\\u001b[2J' + "k" * 5000 + '"'
    bad.write_text(text.replace("mass_kg = 3.0", f"{key} = 3.0", 1), encoding="utf-8")
    with pytest.warns(UserWarning) as caught:
        msg = refusal(lambda: eodarm.Arm.from_toml(bad))
    assert msg == f"{bad}: key 'link[1].mass_kg': missing"
    (note,) = [str(w.message) for w in caught]
    assert note.startswith(f"{bad}: key 'link[1].mass\\x1b[2Jkkk") and note.isprintable()
    assert len(note) < MAX_MESSAGE


def test_a_config_label_with_a_slash_makes_a_safe_figure_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``records --plot`` names each record's figure after its configuration: a label
    ``left/up`` gave a bare ``[Errno 2]``; it is now ``record_left_up.png``, and two labels
    that differ only in such characters give two files."""
    rec = tmp_path / "rec"
    assert main(["synth", "--records", str(rec), "--configs", "3", "--arm", str(EXAMPLE)]) == 0
    camp = rec / "campaign.toml"
    text = camp.read_text(encoding="utf-8")
    text = text.replace('config = "c1"', 'config = "left/up"')
    camp.write_text(text.replace('config = "c2"', 'config = "left?up"'), encoding="utf-8")
    figs = tmp_path / "figs"
    capsys.readouterr()
    code = main(["records", str(camp), "-o", str(tmp_path / "m.csv"), "--plot", str(figs)])
    assert code == 0, capsys.readouterr().err
    names = sorted(p.name for p in figs.iterdir())
    assert names == ["record_c3.png", "record_left_up-2.png", "record_left_up.png"]
