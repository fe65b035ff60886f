"""Regenerate the figures of docs/plan.md and print the outputs the page quotes.

Usage: python scripts/plan_figures.py

* ``docs/figures/plan-twins.png``: four poses of the example arm where actuator 2's moment arm
  about O2 stays at 100–101 mm, measured with a laser tracker alone (dx, dy), and three more
  planned with ``eodarm plan --fixed``;
* ``docs/figures/plan-example.png``: 8 configurations over the whole catalogue of the example
  arm, every channel.

Every command runs through the real CLI; its text output is printed.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
FIGS = ROOT / "docs" / "figures"
ARM = ROOT / "examples" / "example_arm.toml"
#: actuator 2's moment arm about O2 is 100–101 mm at each (tests/test_plan.py checks it)
FOUR = [[53.1, -2.1, 6.8], [67.0, -4.4, 3.2], [88.7, 30.1, -4.4], [110.7, 54.1, -2.9]]


def _env() -> dict[str, str]:
    env = dict(os.environ)
    if env.get("PYTHONPATH"):
        env["PYTHONPATH"] = os.pathsep.join(
            str(Path(p).resolve()) for p in env["PYTHONPATH"].split(os.pathsep) if p
        )
    return env


def run(*argv: str, cwd: Path) -> None:
    print("$ eodarm " + " ".join(argv))
    out = subprocess.run(
        [sys.executable, "-m", "eodarm", *argv],
        cwd=cwd,
        env=_env(),
        capture_output=True,
        text=True,
        check=True,
    )
    print(out.stdout + out.stderr)


def main() -> None:
    import eodarm
    from eodarm.analysis.synth import synth

    arm = eodarm.Arm.from_toml(ARM)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        four = synth(
            arm,
            np.array(FOUR),
            [0, 1.5, 5, 6.5, 5, 1.5, 0],
            [eodarm.Effect("joint_friction", "O2", torque_nmm=4100.0)],
            channels=["dx_mm", "dy_mm"],
            sequence=True,
            seed=1,
        )
        four.to_csv(d / "four.csv")
        run("diagnose", "four.csv", "--arm", str(ARM), cwd=d)
        run("plan", "--arm", str(ARM), "--configs", "3", "--fixed", "four.csv", "--plot",
            "twins", "-o", "more.csv", cwd=d)  # fmt: skip
        shutil.copy(d / "twins" / "plan.png", FIGS / "plan-twins.png")
        run("plan", "--arm", str(ARM), "--configs", "8", "--plot", "example", cwd=d)
        shutil.copy(d / "example" / "plan.png", FIGS / "plan-example.png")
    print(f"wrote {FIGS / 'plan-twins.png'} and {FIGS / 'plan-example.png'}")


if __name__ == "__main__":
    main()
