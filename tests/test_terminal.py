"""What the commands say in a terminal (issue 13 item 4, issue 14 item 2): within 100
columns, numbers and names one way, the non-helping candidates on one line, a ``next:`` command
that runs, one default arm said aloud, and no heavy import on the fast paths.

Each command runs once as a user runs it (a subprocess, stderr not a terminal) on the bundled
seed2022 data; no assertion is timed (speed is measured in benches/bench_cli.py).
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

import eodarm
from eodarm.data.datasets import bundled_arm_path

SEED_ARM = str(bundled_arm_path("seed2022"))
SEED = str(Path(SEED_ARM).with_name("measurements.csv"))
WIDTH = 100

#: Every command on the bundled data (report is left to its own tests: 10 s).
COMMANDS = {
    "help": ["--help"],
    "solve": ["solve"],
    "compare": ["compare", SEED],
    "diagnose": ["diagnose", SEED],
    "fit": [
        "fit", SEED, "--add", "actuator_compliance@M1", "--add", "mount_compliance@M1",
        "--add", "actuator_compliance@M3", "--add", "mount_compliance@M3", "--cv", "config",
    ],
    "compensate": ["compensate", "--alpha", "90,10,0", "--alpha", "70,25,-8", "--mass", "5"],
    "synth": ["synth", "--configs", "3", "--masses", "1.5,6.5"],
    "plan": ["plan", "--configs", "3", "--pool", "100"],
    "datasets": ["datasets", "list"],
    "sweep": [
        "sweep", "--alpha1", "60:120:3", "--alpha2", "0:20:2", "--alpha3", "0", "--mass", "5",
        "--no-progress",
    ],
}  # fmt: skip

#: The commands that end with a next: line.
WITH_NEXT = ("compare", "diagnose", "fit", "synth", "plan", "solve", "compensate")


#: The eodarm under test, for subprocesses that run in another directory.
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(eodarm.__file__).parents[1])])}


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "eodarm", *args],
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
        env=ENV,
    )


@pytest.fixture(scope="module")
def outputs(
    tmp_path_factory: pytest.TempPathFactory,
) -> dict[str, subprocess.CompletedProcess[str]]:
    cwd = tmp_path_factory.mktemp("terminal")
    done = {}
    for name, argv in COMMANDS.items():
        if name == "synth":
            argv = [*argv, "-o", str(cwd / "synth.csv")]
        if name == "sweep":
            argv = [*argv, "-o", str(cwd / "sweep.nc")]
        done[name] = run(*argv, cwd=cwd)
        assert done[name].returncode == 0, (name, done[name].stderr)
    return done


def _next_line(stderr: str) -> list[str]:
    """The command of the next: line (wrapped as a shell continues a line)."""
    text = stderr.split("eodarm: next: ", 1)[1].replace("\\\n", " ")
    return shlex.split(text)


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_line_fits_100_columns(
    outputs: dict[str, subprocess.CompletedProcess[str]], name: str
) -> None:
    out = outputs[name]
    for stream in (out.stdout, out.stderr):
        wide = [ln for ln in stream.splitlines() if len(ln) > WIDTH]
        assert not wide, f"{name}: {len(wide[0])} columns: {wide[0]!r}"
    assert "\r" not in out.stderr  # no progress bar when stderr is not a terminal


def test_numbers_and_names_read_one_way(
    outputs: dict[str, subprocess.CompletedProcess[str]],
) -> None:
    text = "".join(outputs[n].stdout for n in ("compare", "diagnose", "fit"))
    # a p-value that underflows reads "p < 1e-300", never "(p = 0)"
    assert "p < 1e-300" in outputs["diagnose"].stdout and "p = 0)" not in text
    # parameters by name with the identifier alongside; never identifier = value unit
    assert "actuator 3 body stiffness (actuator_compliance@M3)" in outputs["diagnose"].stdout
    assert "actuator 1 mount stiffness (mount_compliance@M1)" in outputs["fit"].stdout
    assert "stiffness_n_per_mm" not in text and "_mm [mm]" not in text and "nan" not in text
    # a channel's unit once: "dy 7.84 mm", not "dy_mm 7.84"
    assert "RMS dy\u00a07.84\u00a0mm" in outputs["compare"].stdout
    assert "dy_mm 7.84" not in text


def test_diagnose_folds_the_candidates_that_do_not_help(
    outputs: dict[str, subprocess.CompletedProcess[str]],
) -> None:
    """On the seed data 19 of 22 candidates leave χ² where it was: one wrapped message names
    them, each candidate is named exactly once in the ranking."""
    out = outputs["diagnose"].stdout
    ranking = out.split("ranking (each candidate added alone", 1)[1]
    doc = json.loads(run("diagnose", SEED, "--json").stdout)
    baseline_chi2 = doc["baseline"]["chi2_per_dof"]
    idle = [c for c in doc["ranking"] if c["chi2_per_dof"] >= baseline_chi2]
    assert len(idle) >= 10
    assert ranking.count("do not help") == 1
    folded = " ".join(ranking.split("do not help", 1)[1].split())
    names = {x.strip() for x in folded.split("): ", 1)[1].split(", ")}
    for c in doc["ranking"]:
        label = f"{c['effect']}@{c['at']}" + (f":{c['unloaded']}" if c.get("unloaded") else "")
        assert (label in names) == (c in idle), label
        assert (label in names) != (f"({label})" in ranking)  # folded, or a row of the table


@pytest.mark.parametrize("name", WITH_NEXT)
def test_a_next_line_ends_stderr_and_its_command_runs(
    outputs: dict[str, subprocess.CompletedProcess[str]], name: str, tmp_path: Path
) -> None:
    err = outputs[name].stderr
    assert "eodarm: next: eodarm " in err
    assert err.rstrip().splitlines()[-1].startswith(("eodarm: next:", "  "))
    argv = _next_line(err)
    assert argv[0] == "eodarm"
    if argv[1] in ("report", "fit") and name == "diagnose":
        return  # the whole report is report's own test; its arguments were checked above
    if argv[1] == "diagnose" and name == "synth":
        argv = [a.replace("synth.csv", str(tmp_path.parent / "synth.csv")) for a in argv]
        synth = outputs["synth"]
        assert "--arm" in argv, synth.stderr  # a synthetic file has no bundled arm
        return
    done = run(*argv[1:], cwd=tmp_path)
    assert done.returncode == 0, (argv, done.stderr)


def test_json_stdout_stays_pure_with_a_next_line() -> None:
    out = run("compare", SEED, "--json")
    assert out.returncode == 0
    json.loads(out.stdout)  # the whole of stdout is one JSON object
    assert "eodarm: next: eodarm diagnose" in out.stderr


def test_one_default_arm_said_on_stderr(tmp_path: Path) -> None:
    """Without --arm: the bundled data's own arm for the bundled data (the file or an exported
    copy), the same seed2022 arm for commands without data; another file is refused."""
    given = run("compare", SEED, "--arm", SEED_ARM, "--json")
    implicit = run("compare", SEED, "--json")
    assert json.loads(implicit.stdout) == json.loads(given.stdout)
    assert "used their arm 'seed2022'" in implicit.stderr
    assert "no --arm" not in given.stderr
    assert json.loads(given.stdout)["chi2_per_dof"] > 1000  # the seed arm, not the example's
    assert run("datasets", "export", "seed2022", str(tmp_path / "ds")).returncode == 0
    copy = run("compare", str(tmp_path / "ds" / "measurements.csv"), "--json")
    assert json.loads(copy.stdout) == json.loads(given.stdout)
    # a user's file: its arm is unknown, refused in one line that names the file and --arm
    lines = Path(SEED).read_text(encoding="utf-8").splitlines()
    mine = tmp_path / "mine.csv"
    mine.write_text("\n".join(lines[:-1]) + "\n", encoding="utf-8")
    out = run("diagnose", str(mine))
    assert out.returncode == 2 and out.stdout == ""
    err = out.stderr.strip().splitlines()
    assert len(err) == 1 and "mine.csv" in err[0] and "--arm" in err[0]
    # commands without data: the seed2022 arm, said
    solved = run("solve", "--json", "--mass", "5")
    assert json.loads(solved.stdout) == json.loads(
        run("solve", "--json", "--mass", "5", "--arm", SEED_ARM).stdout
    )
    assert json.loads(solved.stdout)["arm"] == "seed2022"
    assert "no --arm: used the bundled seed2022 arm" in solved.stderr


def test_a_failure_is_still_one_line_without_arm() -> None:
    out = run("solve", "--alpha", "90,x,0")
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1


def test_the_fast_commands_import_no_heavy_module() -> None:
    """compare and diagnose on the seed data, and --help, import none of scipy, pandas,
    xarray or matplotlib (together 0.5–3 s of start-up)."""
    heavy = ("scipy", "pandas", "xarray", "matplotlib")
    code = (
        "import sys, io, contextlib\n"
        "from eodarm.cli import main\n"
        "quiet = io.StringIO()\n"
        "with contextlib.redirect_stdout(quiet), contextlib.redirect_stderr(quiet):\n"
        "    try:\n"
        "        main(sys.argv[1:])\n"
        "    except SystemExit:\n"
        "        pass\n"
        f"print(sorted({{m.split('.')[0] for m in sys.modules}} & set({heavy!r})))\n"
    )
    for argv in (["--help"], ["compare", SEED], ["diagnose", SEED]):
        out = subprocess.run(
            [sys.executable, "-c", code, *argv], capture_output=True, text=True, check=True, env=ENV
        )
        assert out.stdout.strip() == "[]", (argv, out.stdout)
