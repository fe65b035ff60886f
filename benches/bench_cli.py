"""Time the ``eodarm`` commands as a user runs them: whole processes, start-up included.

Usage: python benches/bench_cli.py [--repeat 5] [--skip report] [--markdown FILE]

Each command runs ``--repeat`` times (after one warm-up run that is not counted) as
``python -m eodarm ...`` on the bundled seed2022 data; the table gives the median, min and max
wall time. Two reference rows time ``python -c pass`` (the interpreter's own start) and
``python -c "import numpy"`` (the floor of any command that computes). Bytecode is cached as
in an installed package (``PYTHONPYCACHEPREFIX`` in a temporary directory, even where
``PYTHONDONTWRITEBYTECODE`` is set). The machine, its load (1-minute load average before and
after) and the commit are printed with the table: on a shared machine the minimum is the best
estimate of the unloaded time, the median what a user waits.

Targets (issue 14): ``--help`` < 0.3 s, ``compare`` and ``diagnose`` < 0.5 s, ``report`` < 4 s.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import eodarm
from eodarm.data.datasets import bundled_arm_path
from machine import cpu_model  # benches/ is the script's directory

SEED = str(bundled_arm_path("seed2022").with_name("measurements.csv"))

#: name → (arguments after ``python``, target in seconds or None)
COMMANDS: dict[str, tuple[list[str], float | None]] = {
    "python -c pass": (["-c", "pass"], None),
    'python -c "import numpy"': (["-c", "import numpy"], None),
    "eodarm --help": (["-m", "eodarm", "--help"], 0.3),
    "eodarm compare SEED": (["-m", "eodarm", "compare", SEED], 0.5),
    "eodarm diagnose SEED": (["-m", "eodarm", "diagnose", SEED], 0.5),
    "eodarm fit SEED (2 effects)": (
        ["-m", "eodarm", "fit", SEED, "--add", "actuator_compliance@M1", "--add",
         "mount_compliance@M3"],
        None,
    ),
    "eodarm solve (3 poses)": (["-m", "eodarm", "solve"], None),
    "eodarm report (seed2022)": (["-m", "eodarm", "report", "-o", "REPORT"], 4.0),
}  # fmt: skip


def commit() -> str:
    root = Path(__file__).resolve().parent.parent
    try:
        out = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            cwd=root,
            capture_output=True,
            text=True,
            check=True,
        )
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        return out.stdout.strip() + (" (uncommitted changes)" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def time_runs(argv: list[str], env: dict[str, str], repeat: int, cwd: str) -> list[float]:
    """Wall times of ``repeat`` runs after one uncounted warm-up run."""
    times = []
    for k in range(repeat + 1):
        t0 = time.perf_counter()
        done = subprocess.run(
            [sys.executable, *argv], env=env, cwd=cwd, capture_output=True, text=True, check=False
        )
        dt = time.perf_counter() - t0
        if done.returncode != 0:
            raise SystemExit(f"{' '.join(argv)} failed: {done.stderr.strip()}")
        if k:
            times.append(dt)
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=5, help="timed runs per command (default 5)")
    ap.add_argument("--skip", action="append", default=[], help="skip commands containing this")
    ap.add_argument("--markdown", type=Path, help="also write the table as Markdown")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        env["PYTHONPYCACHEPREFIX"] = str(Path(tmp) / "pycache")
        env["PYTHONPATH"] = os.pathsep.join(
            [str(Path(eodarm.__file__).resolve().parents[1]), env.get("PYTHONPATH", "")]
        )
        load0 = os.getloadavg()[0]
        rows = []
        for name, (argv, target) in COMMANDS.items():
            if any(s in name for s in args.skip):
                continue
            argv = [str(Path(tmp) / "report.html") if a == "REPORT" else a for a in argv]
            t = time_runs(argv, env, args.repeat, tmp)
            rows.append((name, statistics.median(t), min(t), max(t), target))
            print(f"  {name}: median {statistics.median(t):.3f} s", file=sys.stderr)
        load1 = os.getloadavg()[0]
    head = (
        f"{datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC, commit {commit()}, "
        f"{cpu_model()}, {os.cpu_count()} logical CPUs, Python {platform.python_version()}, "
        f"load average {load0:.2f} before / {load1:.2f} after, {args.repeat} runs each"
    )
    lines = [
        head,
        "",
        "| command | median s | min s | max s | target s |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, med, lo, hi, target in rows:
        tgt = "" if target is None else f"< {target:g}"
        lines.append(f"| `{name}` | {med:.3f} | {lo:.3f} | {hi:.3f} | {tgt} |")
    text = "\n".join(lines)
    print(text)
    if args.markdown:
        args.markdown.write_text(text + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
