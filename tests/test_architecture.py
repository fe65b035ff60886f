"""The package's layers (docs/architecture.md), checked by import-linter.

The contracts live in pyproject.toml: model → data → analysis → workspace → viz → cli, each
importing only from the layers below it; the command modules independent of each other; and
argparse nowhere but in the command line. These tests run them on the package as it is, and
once on a copy with an upward import planted, to show that the check can fail.

Within a layer too, no module may import one that imports it back: the package's import graph
(grimp, import-linter's graph builder; imports inside functions and under ``TYPE_CHECKING``
count) and the Rust core's module graph (``module_graph.rust_module_graph``, whose docstring
states what a use is) have no cycle. Each check is also run once with a cycle planted.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import eodarm
from module_graph import cycles, rust_module_graph

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = Path(eodarm.__file__).resolve().parent


def _lint_imports(pythonpath: Path) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` with the project's contracts on the package found on ``pythonpath``."""
    exe = Path(sys.executable).with_name("lint-imports")
    if not exe.exists():
        pytest.fail("import-linter is not installed: pip install '.[test]'")
    env = {**os.environ, "PYTHONPATH": str(pythonpath)}
    return subprocess.run(
        [str(exe), "--config", str(ROOT / "pyproject.toml"), "--no-cache"],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        timeout=300,
    )


def test_the_layers_are_kept() -> None:
    res = _lint_imports(PACKAGE.parent)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "3 kept, 0 broken" in res.stdout


@pytest.mark.parametrize(
    ("module", "planted", "broken"),
    [
        # the model reaching up into the analysis (what fem.py once did with Slot)
        ("model/fem.py", "from eodarm.analysis.fit import FitResult", "eodarm.model"),
        # a library module reaching into the command line (what sweep.py once did)
        ("workspace/sweep.py", "from eodarm.cli._common import _valued_effect", "eodarm.workspace"),
        # a library module parsing arguments
        ("analysis/synth.py", "import argparse", "argparse"),
    ],
)
def test_an_upward_import_is_caught(tmp_path: Path, module: str, planted: str, broken: str) -> None:
    copy = tmp_path / "eodarm"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "*.so", "*.pyd"))
    target = copy / module
    target.write_text(target.read_text(encoding="utf-8") + f"\n{planted}  # noqa\n")
    res = _lint_imports(tmp_path)
    assert res.returncode != 0, res.stdout
    assert "BROKEN" in res.stdout.upper() and broken in res.stdout


# ---------------------------------------------------------------------------- no cycles
_PY_GRAPH = """
import json, grimp
g = grimp.build_graph("eodarm", cache_dir=None)
graph = {m: sorted(g.find_modules_directly_imported_by(m)) for m in g.modules}
# the compiled core's importer, read as importing the package root (pyproject.toml)
graph["eodarm.model.native"] = [m for m in graph["eodarm.model.native"] if m != "eodarm"]
print(json.dumps(graph))
"""


def _python_cycles(pythonpath: Path) -> list[list[str]]:
    """The import cycles of the package ``eodarm`` found on ``pythonpath``."""
    res = subprocess.run(
        [sys.executable, "-c", _PY_GRAPH],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(pythonpath)},
        cwd=pythonpath,
        timeout=300,
        check=False,
    )
    assert res.returncode == 0, res.stderr
    return cycles(json.loads(res.stdout))


def test_no_module_imports_one_that_imports_it_back() -> None:
    assert _python_cycles(PACKAGE.parent) == []


@pytest.mark.parametrize(
    ("module", "planted", "cycle"),
    [
        # the effects asking the custom effects for a registered kind (what effects.py once did)
        (
            "model/effects.py",
            "def _planted():\n    from eodarm.model import custom",
            "eodarm.model.custom",
        ),
        # one chunk of a sweep reaching back into the sweep
        (
            "workspace/chunk.py",
            "from eodarm.workspace.sweep import sweep",
            "eodarm.workspace.sweep",
        ),
    ],
)
def test_an_import_cycle_is_caught(tmp_path: Path, module: str, planted: str, cycle: str) -> None:
    copy = tmp_path / "eodarm"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "*.so", "*.pyd"))
    target = copy / module
    target.write_text(target.read_text(encoding="utf-8") + f"\n{planted}  # noqa\n")
    found = _python_cycles(tmp_path)
    assert any(cycle in c and module.replace("/", ".")[:-3] in " ".join(c) for c in found), found


CORE_SRC = ROOT / "crates" / "arm_core" / "src"


def test_no_core_module_uses_one_that_uses_it_back() -> None:
    graph = rust_module_graph(CORE_SRC)
    assert "solve::fast" in graph and "sweep::fallback" in graph  # the parser found the modules
    assert "sweep::fast" in graph["solve::fast"]  # and the uses: the kernels share lanes
    assert cycles(graph) == []


@pytest.mark.parametrize(
    ("module", "planted", "cycle"),
    [
        # the general path reaching back into the batch drivers (what sweep/fallback.rs's
        # use of solve::{SolveOptions, Workspace} once closed through solve.rs)
        ("solve/general.rs", "use crate::solve::solve_batch;", {"solve", "solve::general"}),
        # a kernel's effect module calling a helper of its parent inline (what
        # solve/fast/base.rs's super::cos_m1 once did)
        (
            "solve/fast/clearance.rs",
            "fn planted() { let _ = super::SolveKernel::<1>::new; }",
            {"solve::fast", "solve::fast::clearance"},
        ),
        # a shared piece using the module it serves, through a re-export of the parent
        ("sweep/cells.rs", "use super::SweepOptions;", {"sweep", "sweep::cells"}),
    ],
)
def test_a_core_cycle_is_caught(tmp_path: Path, module: str, planted: str, cycle: set[str]) -> None:
    copy = tmp_path / "src"
    shutil.copytree(CORE_SRC, copy)
    target = copy / module
    target.write_text(target.read_text(encoding="utf-8") + f"\n{planted}\n")
    found = cycles(rust_module_graph(copy))
    assert any(cycle <= set(c) for c in found), found
