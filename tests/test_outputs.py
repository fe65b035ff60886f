"""Nothing lost (issue 27 item 1): every command that writes a file

* refuses an existing output in one line unless ``--force``, and replaces it with ``--force``;
* never writes over one of its own inputs, even with ``--force``, however the path is spelled
  (the same string, ``./x``, absolute, a symlink, a hard link);
* writes whole or not at all: a write that fails half-way (the disk full, Ctrl-C, simulated
  deterministically by a writer that raises after some bytes) leaves the previous file
  byte-identical and no temporary behind; a writer killed between its complete temporary
  and the rename leaves the previous file too, and the next write removes the leftover;
* proposes on its ``next:`` line only an output that does not exist.

The commands run in-process (``eodarm.cli.main``), as a user's shell would run them.
"""

from __future__ import annotations

import errno
import os
import shutil
import stat
import subprocess
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from eodarm import atomic
from eodarm.cli import main
from eodarm.data.datasets import bundled_arm_path
from eodarm.errors import MAX_MESSAGE
from test_door import cli, one_line

SEED_ARM = bundled_arm_path("seed2022")
SEED = SEED_ARM.with_name("measurements.csv")
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
PREVIOUS = "the previous result, which must survive\n" * 40


def leftovers(folder: Path) -> list[str]:
    """Temporaries of eodarm.atomic left in ``folder``."""
    return sorted(p.name for p in folder.iterdir() if ".partial-" in p.name or ".old-" in p.name)


# ---------------------------------------------------------------------------- the bench
@pytest.fixture(scope="module")
def bench(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Inputs every command can read: the seed arm and measurements, a campaign of raw
    records, a pose file. Copied per test (:func:`work`) so that each may write over them."""
    d = tmp_path_factory.mktemp("bench")
    (d / "arm.toml").write_bytes(SEED_ARM.read_bytes())
    (d / "meas.csv").write_bytes(SEED.read_bytes())
    (d / "poses.csv").write_text("alpha1_deg,alpha2_deg,alpha3_deg\n90,10,0\n80,15,-5\n")
    rec = d / "rec"
    code = main(
        [
            *("synth", "--arm", str(EXAMPLE), "--records", str(rec)),
            *"--alpha 90,10,0 --sequence 0,5,0 --hold 4 --seed 3".split(),
        ]
    )
    assert code == 0
    return d


@pytest.fixture
def work(bench: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A fresh copy of the bench, the current folder (so that ``./x`` and relative paths
    name its files)."""
    for p in bench.rglob("*"):
        if p.is_file():
            q = tmp_path / p.relative_to(bench)
            q.parent.mkdir(parents=True, exist_ok=True)
            q.write_bytes(p.read_bytes())
    monkeypatch.chdir(tmp_path)
    return tmp_path


@dataclass(frozen=True)
class Command:
    """A writing command: its argv for an output, the option that names the output, and
    the inputs it reads (relative to the bench)."""

    name: str
    argv: Callable[[str], list[str]]
    flag: str
    inputs: tuple[str, ...]


COMMANDS = [
    Command(
        "report",
        lambda out: [*"report meas.csv --arm arm.toml --rounds 1 -o".split(), out],
        "-o",
        ("meas.csv", "arm.toml"),
    ),
    Command(
        "records",
        lambda out: [*"records rec/campaign.toml -o".split(), out],
        "-o",
        ("rec/campaign.toml", "rec/c1.csv"),
    ),
    Command(
        "synth",
        lambda out: [*"synth --arm arm.toml --alpha 90,10,0 --masses 5 -o".split(), out],
        "-o",
        ("arm.toml",),
    ),
    Command(
        "compare",
        lambda out: [*"compare meas.csv --arm arm.toml --residuals".split(), out],
        "--residuals",
        ("meas.csv", "arm.toml"),
    ),
    Command(
        "compensate",
        lambda out: [*"compensate --arm arm.toml --poses poses.csv --mass 5 -o".split(), out],
        "-o",
        ("poses.csv", "arm.toml"),
    ),
    Command(
        "fit",
        lambda out: [*"fit meas.csv --arm arm.toml --add mount_compliance@M2 -o".split(), out],
        "-o",
        ("meas.csv", "arm.toml"),
    ),
    Command(
        "plan",
        lambda out: [
            *"plan --arm arm.toml --configs 2 --pool 40 --fixed meas.csv -o".split(),
            out,
        ],
        "-o",
        ("meas.csv", "arm.toml"),
    ),
    Command(  # a campaign as --fixed: its records are inputs too
        "plan (campaign)",
        lambda out: [
            *"plan --arm arm.toml --configs 1 --pool 40 --fixed rec/campaign.toml -o".split(),
            out,
        ],
        "-o",
        ("rec/campaign.toml", "rec/c1.csv"),
    ),
]
IDS = [c.name for c in COMMANDS]
#: The outputs' names, by command (a report is HTML, the others CSV or TOML).
OUT = {"report": "out.html", "fit": "fitted.toml"}


def out_name(c: Command) -> str:
    return OUT.get(c.name, "out.csv")


# ---------------------------------------------------------------------------- the rule
@pytest.mark.parametrize("c", COMMANDS, ids=IDS)
def test_an_existing_output_is_refused_without_force_and_replaced_with_it(
    c: Command, work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = work / out_name(c)
    out.write_text(PREVIOUS)
    out.chmod(0o640)
    code, _, err = cli(capsys, *c.argv(out.name))
    line = one_line(code, err)
    assert f"{c.flag} {out.name}: exists; give --force" in line
    assert out.read_text() == PREVIOUS
    code, _, err = cli(capsys, *c.argv(out.name), "--force")
    assert code == 0, err
    assert out.read_text() != PREVIOUS and out.stat().st_size > 0
    assert stat.S_IMODE(out.stat().st_mode) == 0o640  # the previous file's permissions
    assert leftovers(work) == []


def spellings(work: Path, name: str) -> Iterator[tuple[str, str]]:
    """Other ways to name the file ``name`` of the current folder ``work``."""
    yield "same", name
    yield "dot", f"./{name}"
    yield "absolute", str(work / name)
    yield "through another folder", f"rec/../{name}"
    link = work / f"link-to-{Path(name).name}"
    link.symlink_to(work / name)
    yield "symlink", link.name
    hard = work / f"hard-{Path(name).name}"
    os.link(work / name, hard)
    yield "hard link", hard.name


@pytest.mark.parametrize("c", COMMANDS, ids=IDS)
def test_an_input_is_never_an_output_even_with_force(
    c: Command, work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The issue's cases among them: ``report victim.csv -o victim.csv`` replaced the
    measurements with HTML; ``records -o rec/c1.csv`` overwrote the record it had read."""
    before = {p: (work / p).read_bytes() for p in c.inputs}
    for name in c.inputs:
        for how, spelled in spellings(work, name):
            code, _, err = cli(capsys, *c.argv(spelled), "--force")
            line = one_line(code, err)
            assert "an input of this run" in line, (how, line)
            assert "--force never replaces an input" in line
        for p in work.iterdir():  # the links of this input, before the next one's
            if p.name.startswith(("link-to-", "hard-")):
                p.unlink()
    assert {p: (work / p).read_bytes() for p in c.inputs} == before
    assert leftovers(work) == [] and leftovers(work / "rec") == []


class Breaking:
    """A file that accepts ``after`` characters (or bytes), writes them, then fails as a
    full disk does: the writer is interrupted half-way through, deterministically."""

    def __init__(self, f: Any, after: int, error: BaseException) -> None:
        self._f, self._left, self._error = f, after, error

    def write(self, data: Any) -> int:
        if len(data) >= self._left:
            self._f.write(data[: self._left])
            self._f.flush()
            raise self._error
        self._left -= len(data)
        return int(self._f.write(data))

    def __getattr__(self, name: str) -> Any:
        return getattr(self._f, name)


@pytest.fixture
def interrupt(monkeypatch: pytest.MonkeyPatch) -> Callable[[BaseException], None]:
    """Make every file eodarm writes fail after 100 characters with ``error``."""

    def arm(error: BaseException) -> None:
        real = atomic._open_temp

        def opening(tmp: Path, mode: str, encoding: str | None, newline: str | None) -> Any:
            return Breaking(real(tmp, mode, encoding, newline), 100, error)

        monkeypatch.setattr(atomic, "_open_temp", opening)

    return arm


@pytest.mark.parametrize("c", COMMANDS, ids=IDS)
def test_a_write_interrupted_half_way_leaves_the_previous_file_whole(
    c: Command,
    work: Path,
    capsys: pytest.CaptureFixture[str],
    interrupt: Callable[[BaseException], None],
) -> None:
    out = work / out_name(c)
    out.write_text(PREVIOUS)
    interrupt(OSError(errno.ENOSPC, "No space left on device"))
    code, _, err = cli(capsys, *c.argv(out.name), "--force")
    assert "No space left on device" in one_line(code, err)
    assert out.read_text() == PREVIOUS
    assert leftovers(work) == []


def test_ctrl_c_half_way_through_records_leaves_the_previous_result(
    work: Path, capsys: pytest.CaptureFixture[str], interrupt: Callable[[BaseException], None]
) -> None:
    """The issue's case: ``records -o`` emptied its output before writing, and an interrupted
    run left 0 bytes of the previous result."""
    out = work / "meas-records.csv"
    out.write_text(PREVIOUS)
    interrupt(KeyboardInterrupt())
    code, _, err = cli(capsys, "records", "rec/campaign.toml", "-o", out.name, "--force")
    assert code == 130 and err.strip() == "eodarm: interrupted"
    assert out.read_text() == PREVIOUS
    assert leftovers(work) == []


def test_a_writer_killed_before_its_rename_leaves_the_previous_file(work: Path) -> None:
    """A real kill (SIGKILL at the point where the temporary is complete and not yet renamed:
    ``EODARM_KILL_AT``, no timing): the previous file is whole; the temporary it left is
    removed by the next write into that folder."""
    out = work / "meas-records.csv"
    out.write_text(PREVIOUS)
    argv = [sys.executable, "-m", "eodarm", "records", "rec/campaign.toml", "-o", out.name]
    env = {**os.environ, atomic.KILL_AT_ENV: "atomic-written"}
    env["PYTHONPATH"] = os.pathsep.join([str(Path(atomic.__file__).parents[1]), *sys.path])
    done = subprocess.run([*argv, "--force"], env=env, capture_output=True, check=False)
    assert done.returncode == -9, done.stderr
    assert out.read_text() == PREVIOUS
    assert len(leftovers(work)) == 1
    env.pop(atomic.KILL_AT_ENV)
    done = subprocess.run([*argv, "--force"], env=env, capture_output=True, check=False)
    assert done.returncode == 0, done.stderr
    assert out.read_text().startswith("config,") and leftovers(work) == []


# ---------------------------------------------------------------------------- folders
def test_synth_records_into_a_folder_with_files_needs_force_and_spares_the_inputs(
    work: Path, capsys: pytest.CaptureFixture[str], interrupt: Callable[[BaseException], None]
) -> None:
    d = work / "rec"
    synth = ["synth", "--arm", "arm.toml", "--records", "rec", "--alpha", "90,10,0"]
    synth += ["--sequence", "0,5,0", "--hold", "4"]
    before = {p.name: p.read_bytes() for p in d.iterdir()}
    code, _, err = cli(capsys, *synth)
    assert "--records rec: the folder is not empty; give --force" in one_line(code, err)
    interrupt(OSError(errno.ENOSPC, "No space left on device"))
    code, _, err = cli(capsys, *synth, "--force")
    assert "No space left on device" in one_line(code, err)
    assert {p.name: p.read_bytes() for p in d.iterdir()} == before  # all or none
    # the arm read from inside the folder, under a name the campaign would take
    (d / "campaign.toml").write_bytes((work / "arm.toml").read_bytes())
    code, _, err = cli(capsys, *[("rec/campaign.toml" if a == "arm.toml" else a) for a in synth])
    assert "not empty" in one_line(code, err)
    argv = [("rec/./campaign.toml" if a == "arm.toml" else a) for a in synth]
    code, _, err = cli(capsys, *argv, "--force")
    assert "is the --arm file" in one_line(code, err)
    assert (d / "campaign.toml").read_bytes() == (work / "arm.toml").read_bytes()


def test_synth_records_with_force_replaces_the_campaign_and_proposes_a_free_name(
    work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The issue's case: after ``synth --records`` the ``next:`` line proposed ``-o
    meas.csv`` over an existing file."""
    old = (work / "rec" / "campaign.toml").read_text()
    synth = ["synth", "--arm", "arm.toml", "--records", "rec", "--alpha", "80,20,0"]
    code, _, err = cli(capsys, *synth, "--sequence", "0,5,0", "--hold", "4", "--force")
    assert code == 0, err
    assert (work / "rec" / "campaign.toml").read_text() != old
    assert "next: eodarm records rec/campaign.toml -o meas-2.csv" in err
    assert (work / "meas.csv").exists() and not (work / "meas-2.csv").exists()


def test_datasets_export_writes_all_or_nothing(
    work: Path, capsys: pytest.CaptureFixture[str], interrupt: Callable[[BaseException], None]
) -> None:
    out = work / "seed"
    assert cli(capsys, "datasets", "export", "seed2022", out)[0] == 0
    edited = out / "arm.toml"
    edited.write_text(PREVIOUS)
    code, _, err = cli(capsys, "datasets", "export", "seed2022", out)
    assert "--force" in one_line(code, err)
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    interrupt(OSError(errno.ENOSPC, "No space left on device"))
    code, _, err = cli(capsys, "datasets", "export", "seed2022", out, "--force")
    assert "No space left on device" in one_line(code, err)
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert edited.read_text() == PREVIOUS


def test_sweep_never_writes_over_its_arm_through_a_symlink(
    work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (work / "s.nc").symlink_to(work / "arm.toml")
    before = (work / "arm.toml").read_bytes()
    sweep = ["sweep", "--arm", "arm.toml", "--alpha1", "80:90:2", "--alpha2", "10"]
    code, _, err = cli(capsys, *sweep, "--alpha3", "0", "--mass", "5", "-o", "s.nc", "--force")
    assert "is the --arm file (arm.toml), an input of this run" in one_line(code, err)
    assert (work / "arm.toml").read_bytes() == before


def test_a_folder_result_replaced_whole_never_holds_an_input(
    work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``sweep -o out.zarr --force`` replaces the folder whole: an arm file kept in it was
    deleted with it (``--arm out.zarr/arm.toml``)."""
    (work / "out.zarr").mkdir()
    arm = work / "out.zarr" / "arm.toml"
    arm.write_bytes((work / "arm.toml").read_bytes())
    sweep = ["sweep", "--arm", "out.zarr/arm.toml", "--alpha1", "80:90:2", "--alpha2", "10"]
    code, _, err = cli(capsys, *sweep, "--alpha3", "0", "--mass", "5", "-o", "out.zarr", "--force")
    line = one_line(code, err)
    assert "-o out.zarr: holds the --arm file (out.zarr/arm.toml), an input of this run" in line
    assert arm.read_bytes() == (work / "arm.toml").read_bytes()


@pytest.fixture
def bundled(work: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A copy of the bundled seed2022 data set that the package reads instead of its own
    (a test that fails must not write over the repository's data)."""
    from eodarm.data import datasets

    root = work / "site-packages" / "eodarm" / "data" / "seed2022"
    shutil.copytree(SEED_ARM.parent, root)
    monkeypatch.setattr(datasets, "_root", lambda name: root)
    return root


@pytest.mark.parametrize(
    ("argv", "name"),
    [
        (["synth", "--alpha", "90,10,0", "--masses", "5"], "arm.toml"),
        (["compensate", "--alpha", "90,10,0", "--mass", "5"], "arm.toml"),
        (["report", "--rounds", "1"], "measurements.csv"),
        (["report", "--rounds", "1"], "arm.toml"),
    ],
)
def test_the_bundled_data_a_command_reads_by_default_are_never_an_output(
    bundled: Path, capsys: pytest.CaptureFixture[str], argv: list[str], name: str
) -> None:
    """Without ``--arm`` (or without data) a command reads the bundled data set: ``synth -o
    …/seed2022/arm.toml --force`` replaced the package's arm with a measurement file, and
    ``report -o …/seed2022/measurements.csv --force`` its data with HTML."""
    before = {p.name: p.read_bytes() for p in bundled.iterdir()}
    code, _, err = cli(capsys, *argv, "-o", bundled / name, "--force")
    line = one_line(code, err)
    assert f"is the bundled seed2022 data set's {name}, an input of this run" in line
    assert {p.name: p.read_bytes() for p in bundled.iterdir()} == before


def test_a_refused_output_with_a_long_name_is_one_short_line(
    work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A 400-character path gave a 487-character line: the names are cut in the middle."""
    deep = work / ("x" * 200) / ("y" * 200)
    deep.mkdir(parents=True)
    (deep / "out.csv").write_text(PREVIOUS)
    out = deep.relative_to(work) / "out.csv"
    code, _, err = cli(capsys, "synth", "--arm", "arm.toml", "-o", out)
    line = one_line(code, err)
    assert len(line) < MAX_MESSAGE and "exists; give --force" in line and "/out.csv" in line
    code, _, err = cli(capsys, "synth", "--arm", out, "-o", out, "--force")
    line = one_line(code, err)
    assert len(line) < MAX_MESSAGE and "is the --arm file" in line


def test_the_report_diagnose_proposes_is_never_refused(
    work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The seed data are unexplained by the catalogue: ``diagnose`` proposes the report's
    rounds. Its default output ``eodarm-report.html`` existing, the proposed command was
    refused (``exists; give --force``); it now names a free file."""
    (work / "eodarm-report.html").write_text(PREVIOUS)
    code, _, err = cli(capsys, "diagnose", "meas.csv", "--arm", "arm.toml")
    assert code == 0, err
    said = " ".join(err.replace("\\\n", "").split())
    assert "next: eodarm report meas.csv --arm arm.toml" in said
    assert "-o eodarm-report-2.html" in said


@pytest.mark.parametrize("c", COMMANDS, ids=IDS)
def test_a_folder_is_never_replaced_by_a_file_even_with_force(
    c: Command, work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``-o data --force`` for ``-o data/meas.csv``: the output was renamed over the folder,
    which was deleted with everything in it (a folder named as the output would be here)."""
    folder = work / out_name(c)
    (folder / "sub").mkdir(parents=True)
    (folder / "notes.txt").write_text(PREVIOUS)
    code, _, err = cli(capsys, *c.argv(folder.name), "--force")
    line = one_line(code, err)
    assert f"{c.flag} {folder.name}: is a folder; give the name of a file" in line
    assert (folder / "notes.txt").read_text() == PREVIOUS and (folder / "sub").is_dir()


def test_a_zarr_sweep_replaces_a_previous_result_not_a_users_folder(
    work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sweep = ["sweep", "--arm", "arm.toml", "--alpha1", "80:90:2", "--alpha2", "10"]
    sweep += ["--alpha3", "0", "--mass", "5", "-o", "out.zarr", "--force"]
    (work / "out.zarr").mkdir()
    (work / "out.zarr" / "notes.txt").write_text(PREVIOUS)
    code, _, err = cli(capsys, *sweep)
    assert "-o out.zarr: is a folder that holds files but no Zarr result" in one_line(code, err)
    assert (work / "out.zarr" / "notes.txt").read_text() == PREVIOUS
    (work / "out.zarr" / "notes.txt").unlink()  # an empty folder, then a previous result
    for _ in range(2):
        code, _, err = cli(capsys, *sweep)
        assert code == 0, err
        assert (work / "out.zarr" / "zarr.json").is_file()
