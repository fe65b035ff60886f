"""Sweeps that never lose a result (issue 15): size checks, atomic writes, resume, Dask loss.

Promises tested here: a sweep whose output cannot fit is refused before anything of its
grid's size is built, in one line with the estimate, and the estimate is the output's real
size; ``eodarm sweep -o`` never leaves a partial result under the output's name and an
interrupted overwrite leaves the previous result as it was (NetCDF and Zarr); Ctrl-C in any
phase exits 130 with one line on stderr and no traceback; an interrupted Zarr sweep resumed
with ``--resume`` gives exactly the store of an uninterrupted run, and a resume with other
inputs is refused; a Dask cluster that loses one worker still gives the exact result, and one
that loses all of them ends in one clear error (exit 2 from the command line). Interrupts are
raised at chosen chunks (no test depends on timing).
"""

from __future__ import annotations

import _thread
import importlib
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

import eodarm
from arms import example_arm
from eodarm import atomic
from eodarm.cli import main
from eodarm.errors import ClusterError, SweepTooLargeError

sweep_mod = importlib.import_module("eodarm.workspace.sweep")
store = importlib.import_module("eodarm.workspace.store")
limits = importlib.import_module("eodarm.workspace.limits")
cluster_mod = importlib.import_module("eodarm.workspace.cluster")

E = eodarm.Effect
GRID = {
    "alpha1": np.linspace(60.0, 120.0, 6),
    "alpha2": np.linspace(0.0, 30.0, 4),
    "alpha3": np.linspace(-10.0, 10.0, 3),
}
ARGV_GRID = ["--alpha1", "60:120:6", "--alpha2", "0:30:4", "--alpha3", "-10:10:3"]
OTHER = ["--alpha1", "70:90:2", "--alpha2", "5", "--alpha3", "0"]  # the previous result's grid
MASS = [1.5, 5.0]
MODEL = [E("joint_clearance", "O3", clearance_mm=0.15)]


@pytest.fixture(scope="module")
def arm() -> eodarm.Arm:
    return example_arm()


@pytest.fixture
def arm_file(arm: eodarm.Arm, tmp_path: Path) -> Path:
    p = tmp_path / "arm.toml"
    p.write_text(arm.to_toml())
    return p


def cli(arm_file: Path, out: Path | None, *extra: str, grid: list[str] = ARGV_GRID) -> int:
    # --force: these tests overwrite on purpose (without it an existing -o is refused)
    argv = ["sweep", "--arm", str(arm_file), *grid, "--mass", "1.5,5", "--no-progress", "--force"]
    argv += ["--add", "joint_clearance@O3=0.15", *(["-o", str(out)] if out else []), *extra]
    return main(argv)


def want(arm: eodarm.Arm, **kw: Any) -> xr.Dataset:
    """The uninterrupted in-memory sweep the command's files must equal."""
    return eodarm.sweep(arm, alpha_deg=GRID, mass_kg=MASS, effects=MODEL, **kw)


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def siblings(path: Path) -> list[str]:
    """What lies beside ``path`` apart from the arm file."""
    return sorted(p.name for p in path.parent.iterdir() if p.name != "arm.toml")


# ---------------------------------------------------------------------------- size checks
def test_a_huge_grid_is_refused_up_front_without_allocating(
    arm: eodarm.Arm, monkeypatch: pytest.MonkeyPatch
) -> None:
    """10¹⁵ cells: refused in one line with the estimate, before any output array or list
    of chunks is made."""
    import tracemalloc

    def forbidden(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("allocated the output of a refused sweep")

    monkeypatch.setattr(sweep_mod, "_allocate", forbidden)
    axis = np.linspace(0.0, 90.0, 100_000)
    huge = {"alpha1": axis, "alpha2": axis, "alpha3": axis}
    tracemalloc.start()
    try:
        for reduce in (None, {"op": "max", "dims": ["alpha3", "mass_kg"]}):
            with pytest.raises(SweepTooLargeError) as info:
                eodarm.sweep(arm, alpha_deg=huge, mass_kg=[1.0], reduce=reduce)
            msg = str(info.value)
            assert "\n" not in msg
            assert msg.startswith("sweep: 1.0e15 cells would need "), msg
            assert "bytes of output; the machine has " in msg and "reduce" in msg
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5_000_000, peak  # the three axes (2.4 MB) and little else


def test_the_estimate_is_the_output_and_the_rule_is_available_memory(
    arm: eodarm.Arm, monkeypatch: pytest.MonkeyPatch
) -> None:
    for reduce in (None, {"op": "argmax", "dims": ["alpha3", "mass_kg"]}):
        ds = want(arm, reduce=reduce)
        nbytes = sum(v.nbytes for v in ds.data_vars.values())
        monkeypatch.setattr(limits, "available_memory", lambda n=nbytes: n)
        xr.testing.assert_identical(want(arm, reduce=reduce), ds)  # exactly fits: runs
        monkeypatch.setattr(limits, "available_memory", lambda n=nbytes: n - 1)
        with pytest.raises(SweepTooLargeError, match=f"{limits.sci(nbytes)} bytes of output"):
            want(arm, reduce=reduce)


def test_the_cli_refuses_a_huge_sweep_in_one_line_with_exit_2(
    arm_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    huge = ["--alpha1", "0:90:100000", "--alpha2", "0:90:100000", "--alpha3", "0:90:100000"]
    for out in (None, tmp_path / "huge.nc"):
        assert cli(arm_file, out, grid=huge) == 2
        line = one_line(capsys.readouterr().err)
        assert line.startswith("eodarm: error: sweep: 2.0e15 cells would need"), line
    assert siblings(tmp_path / "x") == []


def test_a_zarr_sweep_is_checked_against_its_disk(
    arm_file: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    monkeypatch.setattr(limits, "free_disk", lambda path: 1000)
    with pytest.raises(SweepTooLargeError, match=r"bytes in .*; its disk has 1\.0e3 free"):
        store.sweep_to_zarr(tmp_path / "s.zarr", example_arm(), alpha_deg=GRID, mass_kg=MASS)
    assert siblings(tmp_path / "x") == []


def test_netcdf_refuses_a_variable_netcdf3_cannot_hold(
    arm: eodarm.Arm, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(store, "NETCDF3_MAX_VAR_BYTES", 1000)
    with pytest.raises(SweepTooLargeError, match="NetCDF-3 holds no variable over 4 GiB"):
        store.sweep_to_netcdf(tmp_path / "s.nc", arm, alpha_deg=GRID, mass_kg=MASS)
    assert siblings(tmp_path / "x") == []


# ---------------------------------------------------------------------------- NetCDF
def test_an_interrupted_netcdf_overwrite_leaves_the_previous_file(
    arm: eodarm.Arm,
    arm_file: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "sweep.nc"
    assert cli(arm_file, out, grid=OTHER) == 0
    before = out.read_bytes()
    capsys.readouterr()
    tmp_names: list[str] = []

    def truncated(self: xr.Dataset, path: Any, **kwargs: Any) -> None:
        tmp_names.append(Path(path).name)
        Path(path).write_bytes(before[: len(before) // 3])  # a truncated file that opens
        raise KeyboardInterrupt

    monkeypatch.setattr(xr.Dataset, "to_netcdf", truncated)
    assert cli(arm_file, out) == 130
    line = one_line(capsys.readouterr().err)
    assert line == f"eodarm: interrupted while writing {out}: the previous result is untouched"
    assert tmp_names and tmp_names[0].startswith(".sweep.nc.partial-")
    assert out.read_bytes() == before and siblings(out) == ["sweep.nc"]
    # and without a previous file, nothing at all is left
    fresh = tmp_path / "fresh.nc"
    assert cli(arm_file, fresh) == 130
    assert one_line(capsys.readouterr().err).endswith(f"writing {fresh}: nothing written")
    assert siblings(out) == ["sweep.nc"]
    monkeypatch.undo()
    assert cli(arm_file, out) == 0  # an uninterrupted overwrite: the new result, whole
    xr.testing.assert_identical(xr.load_dataset(out, engine="scipy"), want(arm))
    assert siblings(out) == ["sweep.nc"]


def test_ctrl_c_while_solving_or_plotting_exits_130_with_one_line(
    arm_file: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "sweep.nc"
    assert cli(arm_file, out, grid=OTHER) == 0
    before = out.read_bytes()
    capsys.readouterr()

    def interrupted(*args: Any, **kwargs: Any) -> None:
        _thread.interrupt_main()  # a real SIGINT, taken at the next check
        time.sleep(0)  # pragma: no cover - the interrupt is raised before this returns

    monkeypatch.setattr(sweep_mod, "_sweep_grid", interrupted)
    assert cli(arm_file, out) == 130
    line = one_line(capsys.readouterr().err)
    assert (
        line
        == f"eodarm: interrupted while solving: nothing written; the previous {out} is untouched"
    )
    assert out.read_bytes() == before and siblings(out) == ["sweep.nc"]
    monkeypatch.undo()

    from eodarm.viz import maps

    def plot_interrupted(*args: Any, **kwargs: Any) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(maps, "render_all", plot_interrupted)
    figs = tmp_path / "figs"
    assert cli(arm_file, out, "--plot", str(figs)) == 130
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [x for x in err.splitlines() if "interrupted" in x]
    assert lines == [
        f"eodarm: interrupted while plotting into {figs}: {out} is complete, the maps are not"
    ]
    xr.testing.assert_identical(xr.load_dataset(out, engine="scipy"), want(example_arm()))


def test_resume_needs_zarr(
    arm_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli(arm_file, tmp_path / "s.nc", "--resume") == 2
    assert "--resume continues an interrupted Zarr sweep" in one_line(capsys.readouterr().err)


# ---------------------------------------------------------------------------- Zarr, resume
_REAL_SOLVE = store._solve_span


class _StopAfter:
    """Stands in for the chunk solver: raises KeyboardInterrupt when asked for chunk
    ``k + 1`` (so exactly ``k`` chunks are written), and counts the chunks it solves."""

    def __init__(self, k: int | None) -> None:
        self.k, self.calls = k, 0

    def __call__(self, setup: Any, start: int, stop: int) -> Any:
        if self.k is not None and self.calls == self.k:
            raise KeyboardInterrupt
        self.calls += 1
        return _REAL_SOLVE(setup, start, stop)


def test_an_interrupted_zarr_sweep_keeps_the_old_store_and_resumes_to_the_same_result(
    arm: eodarm.Arm,
    arm_file: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    out = tmp_path / "sweep.zarr"
    part = tmp_path / ".sweep.zarr.partial"
    assert cli(arm_file, out, grid=OTHER) == 0
    old = xr.open_zarr(out, consolidated=False).load()
    capsys.readouterr()

    stop = _StopAfter(3)
    monkeypatch.setattr(store, "_solve_span", stop)
    assert cli(arm_file, out, "--chunk-size", "12") == 130  # 72 poses: 6 chunks of 12
    line = one_line(capsys.readouterr().err)
    assert line == (
        f"eodarm: interrupted while sweeping into {out}: 3 of 6 chunks are kept in {part} "
        "(--resume continues); the previous result is untouched"
    )
    xr.testing.assert_identical(xr.open_zarr(out, consolidated=False).load(), old)
    assert siblings(out) == [".sweep.zarr.partial", "sweep.zarr"]

    # without --resume, or with other inputs, the partial store is not touched
    assert cli(arm_file, out, "--chunk-size", "12") == 2
    err = one_line(capsys.readouterr().err)
    assert f"an interrupted sweep of {out} is kept in {part}: resume it" in err
    other_mass = ["sweep", "--arm", str(arm_file), *ARGV_GRID, "--mass", "1.5,6", "-o", str(out)]
    assert main([*other_mass, "--add", "joint_clearance@O3=0.15", "--resume"]) == 2
    assert "started with a different list of payloads" in one_line(capsys.readouterr().err)
    assert cli(arm_file, out, "--resume", "--add", "mount_compliance@M2=4000") == 2
    assert "started with a different set of effects" in one_line(capsys.readouterr().err)

    # --resume solves only the 3 chunks left (its chunk layout is the record's)
    resumed = _StopAfter(None)
    monkeypatch.setattr(store, "_solve_span", resumed)
    assert cli(arm_file, out, "--resume", "--chunk-size", "1000") == 0
    assert resumed.calls == 3
    got = xr.open_zarr(out, consolidated=False).load()
    xr.testing.assert_identical(got, want(arm))
    assert siblings(out) == ["sweep.zarr"]
    # and equals the store of an uninterrupted run
    monkeypatch.undo()
    whole = tmp_path / "whole.zarr"
    assert cli(arm_file, whole, "--chunk-size", "12") == 0
    xr.testing.assert_identical(xr.open_zarr(whole, consolidated=False).load(), got)


def test_ctrl_c_during_a_chunks_write_waits_for_the_chunk_and_its_record(
    arm: eodarm.Arm, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A SIGINT while chunk 3 is being written is taken once it and its record are on disk:
    the three recorded chunks hold their final values."""
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    calls = []
    real = store._bounded

    def interrupting(region: Any, shape: Any) -> Any:
        calls.append(1)
        if len(calls) == 2 * len(store._layout(setup)) + 1:  # chunk 3's first variable
            _thread.interrupt_main()
        return real(region, shape)

    out = tmp_path / "s.zarr"
    kw = dict(alpha_deg=GRID, mass_kg=MASS, effects=MODEL, chunk_size=12)
    setup = sweep_mod._prepare(arm, **{**store._DEFAULTS, **kw})
    monkeypatch.setattr(store, "_bounded", interrupting)
    with pytest.raises(store.SweepInterrupted) as info:
        store.sweep_to_zarr(out, arm, **kw, progress=False)
    assert (info.value.done, info.value.total) == (3, 6) and not out.exists()
    part = store.partial_path(out)
    assert (part / store.DONE).read_text().split() == ["0", "1", "2"]
    partial = xr.open_zarr(part / out.name, consolidated=False)  # readable as it grows
    full = want(arm)
    for i in range(3):  # chunk i: alpha1's value i, all of alpha2 and alpha3
        region = store._Chunks.plan(setup).span(i)[2]
        sel = dict(zip(("alpha1", "alpha2", "alpha3"), region, strict=False))
        assert region[0] == slice(i, i + 1)
        xr.testing.assert_identical(partial.isel(sel).load(), full.isel(sel))


def test_ctrl_c_while_the_result_is_renamed_into_place_is_taken_after_it(
    arm: eodarm.Arm,
    arm_file: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    out = tmp_path / "sweep.zarr"
    assert cli(arm_file, out, grid=OTHER) == 0
    capsys.readouterr()
    real = atomic._remove

    def interrupting(path: Path) -> None:
        # between putting the new store in place and removing the old one (exchanged into
        # the partial directory, or renamed aside where the system cannot exchange)
        if ".partial" in str(path) or ".old-" in path.name:
            _thread.interrupt_main()
        real(path)

    monkeypatch.setattr(atomic, "_remove", interrupting)
    assert cli(arm_file, out) == 130
    assert one_line(capsys.readouterr().err) == f"eodarm: interrupted: {out} was written completely"
    xr.testing.assert_identical(xr.open_zarr(out, consolidated=False).load(), want(arm))
    assert siblings(out) == ["sweep.zarr"]


def test_resume_without_a_partial_store_starts_the_sweep(
    arm: eodarm.Arm, arm_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    out = tmp_path / "s.zarr"
    assert cli(arm_file, out, "--resume", "--reduce", "min:alpha3,mass_kg") == 0
    assert "no interrupted sweep" in capsys.readouterr().err
    got = xr.open_zarr(out, consolidated=False).load()
    xr.testing.assert_identical(got, want(arm, reduce={"op": "min", "dims": ["alpha3", "mass_kg"]}))


# ---------------------------------------------------------------------------- Dask
#: What the stand-in chunk function does: "one" closes the worker running the third chunk,
#: "all" closes every worker then; later chunks wait until their worker is closing.
_LOSS: dict[str, Any] = {}
_LOSS_LOCK = threading.Lock()
_REAL_CHUNK = sweep_mod._chunk


def _losing_chunk(job: Any, start: int, stop: int) -> Any:
    import distributed

    try:
        worker = distributed.get_worker()
    except ValueError:  # not on a worker: the local sweep the result is compared with
        return _REAL_CHUNK(job, start, stop)
    with _LOSS_LOCK:
        _LOSS["n"] += 1
        n = _LOSS["n"]
    if n == 3:
        targets = [worker] if _LOSS["mode"] == "one" else list(_LOSS["cluster"].workers.values())
        for w in targets:
            w.loop.add_callback(w.close)
    if n == 3 or (n > 3 and _LOSS["mode"] == "all"):
        deadline = time.monotonic() + 120  # a bound only: the close comes within ms
        while worker.status.name == "running" and time.monotonic() < deadline:
            time.sleep(0.01)
    return _REAL_CHUNK(job, start, stop)


@pytest.fixture
def losing(monkeypatch: pytest.MonkeyPatch) -> Any:
    distributed = pytest.importorskip("distributed")
    monkeypatch.setattr(sweep_mod, "_chunk", _losing_chunk)
    monkeypatch.setattr(cluster_mod, "NO_WORKERS_GRACE_S", 0.0)
    monkeypatch.setattr(cluster_mod, "CLUSTER_POLL_S", 0.05)
    _LOSS.clear()
    _LOSS["n"] = 0
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        _LOSS["cluster"] = cluster
        yield cluster


def test_a_cluster_that_loses_one_worker_gives_the_exact_result(
    arm: eodarm.Arm, losing: Any
) -> None:
    import distributed

    _LOSS["mode"] = "one"
    g = {"l1": np.linspace(250.0, 330.0, 12), "l2": [480.0, 520.0], "l3": [500.0, 530.0]}
    with distributed.Client(losing) as client:
        got = eodarm.sweep(arm, lengths=g, mass_kg=MASS, chunk_size=2, scheduler=client)
        assert len(client.nthreads()) == 1  # one worker was lost
    assert _LOSS["n"] > 24  # every one of the 24 chunks, and the lost ones again
    xr.testing.assert_identical(got, eodarm.sweep(arm, lengths=g, mass_kg=MASS))


def test_a_cluster_that_loses_all_its_workers_ends_in_one_clear_error(
    arm: eodarm.Arm, losing: Any
) -> None:
    import distributed

    _LOSS["mode"] = "all"
    g = {"l1": np.linspace(250.0, 330.0, 12), "l2": [480.0, 520.0], "l3": [500.0, 530.0]}
    with distributed.Client(losing) as client, pytest.raises(ClusterError) as info:
        eodarm.sweep(arm, lengths=g, mass_kg=MASS, chunk_size=2, scheduler=client)
    msg = str(info.value)
    assert msg.startswith("the Dask cluster lost all its workers: ") and "\n" not in msg
    assert isinstance(info.value, eodarm.EodarmError)


def test_the_cli_exits_2_on_a_lost_cluster_and_keeps_the_zarr_chunks_to_resume(
    arm: eodarm.Arm,
    arm_file: Path,
    tmp_path: Path,
    losing: Any,
    capsys: pytest.CaptureFixture[str],
) -> None:
    pytest.importorskip("zarr")
    _LOSS["mode"] = "all"
    out = tmp_path / "s.zarr"
    code = cli(arm_file, out, "--chunk-size", "4", "--scheduler", losing.scheduler_address)
    assert code == 2
    line = one_line(capsys.readouterr().err)
    assert line.startswith("eodarm: error: the Dask cluster lost all its workers: "), line
    assert f"chunks are kept in {store.partial_path(out)}" in line and not out.exists()
    assert cli(arm_file, out, "--resume") == 0  # here, without the cluster
    xr.testing.assert_identical(xr.open_zarr(out, consolidated=False).load(), want(arm))


def test_a_chunk_whose_workers_keep_dying_is_a_cluster_error(
    arm: eodarm.Arm, monkeypatch: pytest.MonkeyPatch
) -> None:
    distributed = pytest.importorskip("distributed")

    monkeypatch.setattr(sweep_mod, "_chunk", _killed_chunk)
    g = {"l1": [250.0, 300.0], "l2": [520.0], "l3": [500.0]}
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
        pytest.raises(ClusterError, match="workers kept dying on the chunk of poses 0:1"),
    ):
        eodarm.sweep(arm, lengths=g, mass_kg=MASS, chunk_size=1, scheduler=client)


def _killed_chunk(job: Any, start: int, stop: int) -> Any:
    """What the client sees when a chunk's workers died on it too often (Dask's KilledWorker)."""
    from types import SimpleNamespace

    from distributed import KilledWorker

    if start == 0:
        raise KilledWorker(f"chunk-{start}", SimpleNamespace(address="inproc://lost"), 3)
    return _REAL_CHUNK(job, start, stop)
