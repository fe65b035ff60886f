"""Time `compare`, `fit` and `diagnose` against the size of the measurement file.

Usage: python benches/bench_rows.py [--quick] [--rows 1000,10000,100000] [--markdown FILE]

Each size is a file written by ``eodarm synth`` on examples/example_arm.toml (configurations ×
the payloads 1.5, 3 and 5 kg, every channel, two hidden effects: a 0.05 mm clearance at O3 and
a 3000 N/mm mount at M2); each command runs as a user runs it, in a fresh process
(``python -m eodarm ... --json``), so imports and reading the file are included. ``compare``
has nothing fitted, ``fit`` fits the clearance only, so that the data are not explained
(the mount is missing) and the outlier rule works its hardest (issue 23: the old rule
refitted once per left-out cell); ``diagnose`` (sets of up to two) ranks every candidate and
cross-validates the best set over the configurations. The figures are the wall time and the CPU
time of the process (user + system, which a busy machine inflates less than the wall time).
``--quick`` runs 10³ and 3·10³ rows only (under a minute). ``--sequence`` writes load cycles
instead (a ``step`` column: 0 → 1.5 → 5 → 6.5 → 5 → 1.5 → 0 kg, six rows per configuration,
the same hidden effects) and times ``compare`` alone (issue 27: files with ``step`` were read
in quadratic time).
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine import cpu_model  # benches/ is the script's directory

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "example_arm.toml"
MASSES = "1.5,3,5"
HIDDEN = ["joint_clearance@O3=0.05", "mount_compliance@M2=3000"]
COMMANDS = {
    "compare": [],
    "fit": ["--add", "joint_clearance@O3"],
    "diagnose": ["--max-set", "2"],
}


def eodarm(*argv: str) -> tuple[float, float, int]:
    """Run ``python -m eodarm ARGV``; (wall s, CPU s of the child, exit status)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "eodarm", *argv],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode != 0:
        print(f"  {' '.join(argv[:1])}: exit {done.returncode}: {done.stderr.strip()}")
    return wall, cpu, done.returncode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="10³ and 3·10³ rows only")
    ap.add_argument("--rows", default="1000,10000,100000", help="sizes (rows), comma-separated")
    ap.add_argument("--markdown", type=Path, help="append the table to this file")
    ap.add_argument("--sequence", action="store_true", help="load cycles (step), compare only")
    args = ap.parse_args()
    per = 6 if args.sequence else 3  # rows per configuration
    loads = ["--sequence", "0,1.5,5,6.5,5,1.5,0"] if args.sequence else ["--masses", MASSES]
    commands = {"compare": []} if args.sequence else COMMANDS
    sizes = [1000, 3000] if args.quick else [int(s) for s in args.rows.split(",")]
    print(f"machine: {cpu_model()}, {os.cpu_count()} cores; python {platform.python_version()}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            path = Path(tmp) / f"rows{n}.csv"
            configs = max(1, round(n / per))
            hidden = [a for h in HIDDEN for a in ("--hidden", h)]
            eodarm(
                "synth", "--arm", str(EXAMPLE), "--configs", str(configs), *loads,
                *hidden, "--seed", "1", "-o", str(path),
            )  # fmt: skip
            for cmd, extra in commands.items():
                wall, cpu, code = eodarm(cmd, str(path), "--arm", str(EXAMPLE), "--json", *extra)
                rows.append((cmd, per * configs, wall, cpu, code))
                print(f"{cmd:9s} {per * configs:7d} rows  wall {wall:7.2f} s  cpu {cpu:7.2f} s")
    table = ["| command | rows | wall s | CPU s | exit |", "|---|---:|---:|---:|---:|"]
    table += [f"| {c} | {n} | {w:.2f} | {u:.2f} | {e} |" for c, n, w, u, e in rows]
    print("\n".join(table))
    if args.markdown:
        with args.markdown.open("a", encoding="utf-8") as fh:
            fh.write("\n".join(table) + "\n")


if __name__ == "__main__":
    main()
