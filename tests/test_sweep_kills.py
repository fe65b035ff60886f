"""Nothing left behind (issue 23 item 6): a sweep killed with SIGKILL at the dangerous moments
leaves the old output or the new one, whole, and a state that ``--resume`` or a re-run
finishes or cleans by itself; the temporaries of a dead process are removed by the next write
into the folder; Zarr stores carry consolidated metadata (``xr.open_zarr`` does not warn:
the suite turns warnings into errors).

The writer kills itself at a named point (``EODARM_KILL_AT``, ``store._kill_point``): a real
SIGKILL of a real process, at a chosen moment, without timing.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import eodarm
from arms import example_arm

store = importlib.import_module("eodarm.workspace.store")

GRID = {
    "alpha1": np.linspace(60.0, 120.0, 6),
    "alpha2": np.linspace(0.0, 30.0, 4),
    "alpha3": np.linspace(-10.0, 10.0, 3),
}
OTHER = {"alpha1": np.linspace(70.0, 90.0, 2), "alpha2": [5.0], "alpha3": [0.0]}
MASS = [1.5, 5.0]

#: The child: sweep GRID into argv[2] (Zarr in chunks of 12 poses: 6 chunks, or NetCDF).
CHILD = """
import sys
import numpy as np
import eodarm
from eodarm.workspace import store
arm = eodarm.Arm.from_toml(sys.argv[1])
grid = {"alpha1": np.linspace(60.0, 120.0, 6), "alpha2": np.linspace(0.0, 30.0, 4),
        "alpha3": np.linspace(-10.0, 10.0, 3)}
if sys.argv[2].endswith(".zarr"):
    store.sweep_to_zarr(sys.argv[2], arm, alpha_deg=grid, mass_kg=[1.5, 5.0], chunk_size=12,
                        progress=False, resume=sys.argv[3] == "resume")
else:
    store.sweep_to_netcdf(sys.argv[2], arm, alpha_deg=grid, mass_kg=[1.5, 5.0])
"""


@pytest.fixture(scope="module")
def arm() -> eodarm.Arm:
    return example_arm()


@pytest.fixture
def arm_file(arm: eodarm.Arm, tmp_path: Path) -> Path:
    p = tmp_path / "arm.toml"
    p.write_text(arm.to_toml())
    return p


def child(arm_file: Path, out: Path, mode: str = "new", kill_at: str | None = None) -> int:
    env = {k: v for k, v in os.environ.items() if k != store.KILL_AT_ENV}
    if kill_at:
        env[store.KILL_AT_ENV] = kill_at
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(arm_file), str(out), mode],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert "Traceback" not in done.stderr, done.stderr
    return done.returncode


def siblings(path: Path) -> list[str]:
    return sorted(p.name for p in path.parent.iterdir() if p.name != "arm.toml")


def opened(path: Path) -> xr.Dataset:
    """The store as a user opens it, consolidated metadata expected (a warning fails)."""
    return xr.open_zarr(path).load()


@pytest.mark.parametrize(
    ("point", "left_at_out"),
    [
        ("zarr-chunk-3", "old"),  # half the chunks written
        ("zarr-complete", "old"),  # every chunk written, not yet in place
        ("replace-exchanged", "new"),  # in place, the old store not yet removed
        ("zarr-in-place", "new"),  # the old store removed, the record not
    ],
)
def test_a_killed_zarr_overwrite_leaves_one_whole_result_and_resumes_clean(
    arm: eodarm.Arm, arm_file: Path, tmp_path: Path, point: str, left_at_out: str
) -> None:
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    out = tmp_path / "sweep.zarr"
    store.sweep_to_zarr(out, arm, alpha_deg=OTHER, mass_kg=MASS, progress=False)
    old = opened(out)
    new = eodarm.sweep(arm, alpha_deg=GRID, mass_kg=MASS)

    assert child(arm_file, out, kill_at=point) == -9  # SIGKILL
    xr.testing.assert_identical(opened(out), old if left_at_out == "old" else new)
    assert not any(".old-" in s for s in siblings(out))

    assert child(arm_file, out, "resume") == 0
    xr.testing.assert_identical(opened(out), new)
    assert siblings(out) == ["sweep.zarr"]


def test_a_rerun_after_a_kill_once_in_place_starts_afresh_and_cleans(
    arm: eodarm.Arm, arm_file: Path, tmp_path: Path
) -> None:
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    out = tmp_path / "sweep.zarr"
    store.sweep_to_zarr(out, arm, alpha_deg=OTHER, mass_kg=MASS, progress=False)
    assert child(arm_file, out, kill_at="replace-exchanged") == -9
    assert child(arm_file, out) == 0  # no --resume: the left-over directory is not a refusal
    xr.testing.assert_identical(opened(out), eodarm.sweep(arm, alpha_deg=GRID, mass_kg=MASS))
    assert siblings(out) == ["sweep.zarr"]


def test_a_killed_netcdf_write_is_removed_by_the_next_run_into_the_folder(
    arm: eodarm.Arm, arm_file: Path, tmp_path: Path
) -> None:
    out = tmp_path / "sweep.nc"
    store.sweep_to_netcdf(out, arm, alpha_deg=OTHER, mass_kg=MASS)
    old = xr.open_dataset(out, engine="scipy").load()
    assert child(arm_file, out, kill_at="save-written") == -9
    left = [s for s in siblings(out) if s != "sweep.nc"]
    assert len(left) == 1 and left[0].startswith(".sweep.nc.partial-"), left
    xr.testing.assert_identical(xr.open_dataset(out, engine="scipy").load(), old)
    # the next write into the folder, of another output, removes it
    store.sweep_to_netcdf(tmp_path / "other.nc", arm, alpha_deg=OTHER, mass_kg=MASS)
    assert siblings(out) == ["other.nc", "sweep.nc"]


def test_only_the_temporaries_of_dead_processes_are_removed(tmp_path: Path) -> None:
    code = "import os; print(os.getpid())"
    dead = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    pid = int(dead.stdout)  # exited and reaped: no process has this id (reuse is unlikely)
    names = {
        f".a.nc.partial-{pid}": True,  # a dead writer's
        f".b.zarr.old-{pid}": True,
        f".a.nc.partial-{os.getpid()}": False,  # this process's own
        f".a.nc.partial-{os.getppid()}": False,  # a running process's
        ".a.zarr.partial": False,  # a resumable sweep: not a temporary
        f"a.nc.partial-{pid}": False,  # not hidden: not ours
    }
    for name in names:
        (tmp_path / name).mkdir() if "zarr" in name else (tmp_path / name).write_text("x")
    gone = store.clean_leftovers(tmp_path)
    assert sorted(p.name for p in gone) == sorted(n for n, g in names.items() if g)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        n for n, g in names.items() if not g
    )


def test_zarr_outputs_open_without_a_warning(arm: eodarm.Arm, tmp_path: Path) -> None:
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    ds = eodarm.sweep(arm, alpha_deg=OTHER, mass_kg=MASS)
    store.save(ds, tmp_path / "whole.zarr")
    store.sweep_to_zarr(tmp_path / "chunked.zarr", arm, alpha_deg=OTHER, mass_kg=MASS)
    for name in ("whole.zarr", "chunked.zarr"):
        xr.testing.assert_identical(opened(tmp_path / name), ds)
