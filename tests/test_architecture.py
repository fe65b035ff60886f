"""The package's layers (docs/architecture.md), checked by import-linter.

The contracts live in pyproject.toml: model → data → analysis → workspace → viz → cli, each
importing only from the layers below it; the command modules independent of each other; and
argparse nowhere but in the command line. These tests run them on the package as it is, and
once on a copy with an upward import planted, to show that the check can fail.

Within a layer too, no module may import one that imports it back, anywhere in the
repository: the package's import graph (grimp, import-linter's graph builder; imports inside
functions and under ``TYPE_CHECKING`` count), the module graph of every crate of the Cargo
workspace (``module_graph.rust_module_graph``) and the import graph of each folder of scripts
(``module_graph.script_graph``; their docstrings state what a use is) have no cycle. Each
check is also run with cycles planted.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import eodarm
from module_graph import cycles, rust_module_graph, script_graph

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
#: The ``src`` of every member of the Cargo workspace (the core, the binding, the benchmarks).
CRATES = [
    ROOT / member / "src"
    for member in tomllib.loads((ROOT / "Cargo.toml").read_text(encoding="utf-8"))["workspace"][
        "members"
    ]
]


def test_no_core_module_uses_one_that_uses_it_back() -> None:
    graph = rust_module_graph(CORE_SRC)
    assert "solve::fast" in graph and "sweep::fallback" in graph  # the parser found the modules
    assert "sweep::fast" in graph["solve::fast"]  # and the uses: the kernels share lanes
    # what the two kernels share sits below both: the block kernel takes it from there, and
    # the sweep's per-cell path takes the batch buffers and the general path where they live
    assert {"lanes", "lanes::trig", "lanes::transpose"} <= graph["solve::fast"]
    assert "sweep" not in graph["solve::fast"] and "solve" not in graph["sweep::fallback"]
    assert cycles(graph) == []


@pytest.mark.parametrize("src", CRATES, ids=lambda s: s.parent.name)
def test_no_module_of_any_crate_uses_one_that_uses_it_back(src: Path) -> None:
    graph = rust_module_graph(src)
    assert graph, f"no Rust sources under {src}"
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
        # the block kernel taking a shared piece through the sweep's re-export, which closed
        # solve.rs -> solve/fast.rs -> sweep.rs -> sweep/fallback.rs -> solve.rs
        ("solve/fast.rs", "use crate::sweep::L as _;", {"sweep", "sweep::fallback", "solve::fast"}),
        # a child naming its parent's re-export of a sibling's item, while the parent calls it
        ("solve/status.rs", "use super::BatchOutput as _;", {"solve", "solve::status"}),
    ],
)
def test_a_core_cycle_is_caught(tmp_path: Path, module: str, planted: str, cycle: set[str]) -> None:
    copy = tmp_path / "src"
    shutil.copytree(CORE_SRC, copy)
    target = copy / module
    target.write_text(target.read_text(encoding="utf-8") + f"\n{planted}\n")
    found = cycles(rust_module_graph(copy))
    assert any(cycle <= set(c) for c in found), found


# ------------------------------------------------------------------- folders of scripts
#: The folders of Python files run as scripts, which import each other by their bare names.
SCRIPT_FOLDERS = ["scripts", "benches", "tests", "examples"]


@pytest.mark.parametrize("folder", SCRIPT_FOLDERS)
def test_no_script_imports_one_that_imports_it_back(folder: str) -> None:
    graph = script_graph(ROOT / folder)
    assert graph, f"no Python files in {folder}/"
    assert cycles(graph) == []


def test_the_scripts_graph_sees_their_imports() -> None:
    # what the seed scripts share lives in a third module, which both import
    assert script_graph(ROOT / "scripts")["seed_investigation"] == {"seed_verdicts"}
    assert script_graph(ROOT / "scripts")["seed_reproduction"] >= {
        "seed_verdicts",
        "seed_investigation",  # lazily, in main(): §6 is that script's
    }
    assert "bench_solve" in script_graph(ROOT / "benches")["bench_sweep"]


@pytest.mark.parametrize(
    ("folder", "module", "planted", "cycle"),
    [
        # the investigation taking the page's sentences from the reproduction, lazily, in a
        # function (what seed_investigation.py once did)
        (
            "scripts",
            "seed_investigation.py",
            "def _planted():\n    from seed_reproduction import refusal",
            ["seed_investigation", "seed_reproduction"],
        ),
        # a shared module importing one of its users, under TYPE_CHECKING
        (
            "scripts",
            "seed_verdicts.py",
            "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import seed_investigation",
            ["seed_investigation", "seed_verdicts"],
        ),
        # one benchmark importing another that imports it (by importlib, by name)
        (
            "benches",
            "bench_solve.py",
            "import importlib\nimportlib.import_module('bench_sweep')",
            ["bench_solve", "bench_sweep"],
        ),
    ],
)
def test_a_script_cycle_is_caught(
    tmp_path: Path, folder: str, module: str, planted: str, cycle: list[str]
) -> None:
    copy = tmp_path / folder
    shutil.copytree(ROOT / folder, copy, ignore=shutil.ignore_patterns("__pycache__"))
    target = copy / module
    target.write_text(target.read_text(encoding="utf-8") + f"\n{planted}  # noqa\n")
    found = cycles(script_graph(copy))
    assert any(set(cycle) <= set(c) for c in found), found
