"""Workspace sweeps (eodarm.sweep) and their command line.

Promises tested here: every cell of a sweep is what ``eodarm.solve`` gives for that pose and
payload (every output; and the numpy reference agrees); a cell is not ok exactly where
``eodarm.solve`` refuses the pose; ``reachable`` is the stroke check of the unloaded pose and
its non-singularity; reductions are the numpy reductions of the full result; chunk sizes
change nothing; a lengths grid puts the actuators at the asked lengths and an effector grid
puts the load point where asked; a Dask cluster gives exactly the local result; memory is
bounded by the chunk (no chunk larger than asked, nothing of the grid's size built for a
reduced sweep); bad input gets a one-line ValueError naming the problem; the CLI writes a
NetCDF/Zarr file that reads back equal, and Ctrl-C stops it cleanly.
"""

from __future__ import annotations

import argparse
import importlib
import itertools
import math
import signal
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

import eodarm
from arms import example_arm
from eodarm import _core
from eodarm import sweep as sweep_fn
from eodarm.cli.sweep import add_parser
from eodarm.model.effects import effect_arrays
from eodarm.model.solver import _core_arm
from eodarm.workspace.fallback import placeholder, sweep_fallback

E = eodarm.Effect
#: The module (``eodarm.sweep`` is the function).
sweep_mod = importlib.import_module("eodarm.workspace.sweep")
MASSES = [0.0, 1.5, 6.5]
#: A soft actuator body, so that some loaded triangles cannot close (those cells are not ok).
SOFT = [E("actuator_compliance", "M1", stiffness_n_per_mm=2.0)]
MODEL = [
    E("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
    E("actuator_play", "M3", play_mm=0.05),
    E("joint_clearance", "O3", clearance_mm=0.15),
    E("link_bending", "L2", ei_n_mm2=2.0e10),
    E("base_compliance", "base", stiffness_nmm_per_rad=5.0e8),
]


@pytest.fixture(scope="module")
def arm() -> eodarm.Arm:
    return example_arm()  # stroke limits and force limits set


@pytest.fixture(scope="module")
def grid(arm: eodarm.Arm) -> dict[str, np.ndarray]:
    """Angles that reach outside the strokes, with one α1 at which actuator 1 is singular."""
    a1 = np.sort(np.r_[np.linspace(20.0, 160.0, 6), placeholder(arm)[0] % 360.0 - 360.0])
    return {
        "alpha1": a1,
        "alpha2": np.linspace(-60.0, 90.0, 5),
        "alpha3": np.linspace(-60.0, 60.0, 4),
    }


def poses_of(ds: xr.Dataset, names: list[str]) -> np.ndarray:
    """The (N, n) angles of a sweep's grid in C order (angle grids)."""
    mesh = np.meshgrid(*(ds[k].values for k in names), indexing="ij")
    order = [names.index(f"alpha{i + 1}") for i in range(len(names))]
    return np.stack([mesh[j].ravel() for j in order], axis=-1)


def cells(ds: xr.Dataset, key: str, grid_dims: list[str]) -> np.ndarray:
    """A per-cell variable as (N·M, …) rows in sweep order."""
    v = ds[key]
    inner = [d for d in v.dims if d in ("actuator", "link")]
    v = v.transpose(*grid_dims, "mass_kg", *inner).values
    return v.reshape(-1, *v.shape[len(grid_dims) + 1 :])


@pytest.fixture(scope="module")
def full(arm: eodarm.Arm, grid: dict[str, np.ndarray]) -> xr.Dataset:
    return sweep_fn(arm, alpha_deg=grid, mass_kg=MASSES, effects=SOFT, chunk_size=37)


# ---------------------------------------------------------------------------- = solve
def test_every_cell_is_what_solve_gives(arm: eodarm.Arm, full: xr.Dataset) -> None:
    names = ["alpha1", "alpha2", "alpha3"]
    alpha = poses_of(full, names)
    rows_alpha = np.repeat(alpha, len(MASSES), axis=0)
    rows_mass = np.tile(MASSES, alpha.shape[0])
    ok = cells(full, "ok", names)
    assert ok.any() and not ok.all()  # the grid has solvable and failing cells
    want = eodarm.solve(arm, rows_alpha[ok], rows_mass[ok], effects=SOFT)
    for key in ("force_n", "dx_mm", "dy_mm", "dalpha_deg", "dl_mm"):
        got = cells(full, key, names)
        np.testing.assert_allclose(got[ok], want[key], rtol=1e-12, atol=1e-9, err_msg=key)
        assert np.isnan(got[~ok]).all(), key
    geo = eodarm.forward(arm, alpha)
    np.testing.assert_allclose(full["length_mm"].values.reshape(-1, 3), geo["length_mm"])
    np.testing.assert_allclose(full["effector_x_mm"].values.ravel(), geo["O"][:, 3, 0])
    np.testing.assert_allclose(full["effector_y_mm"].values.ravel(), geo["O"][:, 3, 1])


def test_a_cell_is_ok_exactly_where_solve_gives_status_ok(
    arm: eodarm.Arm, full: xr.Dataset
) -> None:
    """Not ok where solve refuses the pose, else the status solve gives (docs/model.md §7)."""
    names = ["alpha1", "alpha2", "alpha3"]
    alpha = poses_of(full, names)
    ok = cells(full, "ok", names).reshape(alpha.shape[0], len(MASSES))
    status = cells(full, "status", names).reshape(alpha.shape[0], len(MASSES))
    refused = np.zeros_like(ok)
    for p in range(alpha.shape[0]):
        for j, m in enumerate(MASSES):
            try:
                out = eodarm.solve(arm, alpha[p], m, effects=SOFT, strict=True)
            except ValueError as exc:
                assert "singular" in str(exc) or "cannot close" in str(exc), str(exc)
                refused[p, j] = True
                assert status[p, j] != 0
                continue
            assert status[p, j] == out["status"][0], (p, j)
    np.testing.assert_array_equal(ok, status == 0)
    assert not ok[refused].any() and ok.any()
    # both kinds occur: the singular α1 for every payload, soft-spring closures only loaded
    singular = np.isclose(alpha[:, 0], full["alpha1"].values[0])
    assert refused[singular].all() and refused[~singular].any()


def test_the_numpy_reference_agrees_with_the_sweep(arm: eodarm.Arm) -> None:
    g = {"alpha1": [70.0, 95.0], "alpha2": [0.0, 25.0], "alpha3": [-10.0, 5.0]}
    ds = sweep_fn(arm, alpha_deg=g, mass_kg=[1.5, 6.5], effects=MODEL)
    names = list(g)
    alpha = poses_of(ds, names)
    ref = eodarm.solve(
        arm, np.repeat(alpha, 2, axis=0), np.tile([1.5, 6.5], 8), effects=MODEL, backend="numpy"
    )
    for key in ("force_n", "dx_mm", "dy_mm", "dalpha_deg", "dl_mm"):
        np.testing.assert_allclose(cells(ds, key, names), ref[key], rtol=1e-8, atol=1e-8)


def test_reachable_is_the_stroke_check_of_a_non_singular_pose(
    arm: eodarm.Arm, full: xr.Dataset
) -> None:
    alpha = poses_of(full, ["alpha1", "alpha2", "alpha3"])
    length = eodarm.forward(arm, alpha)["length_mm"]
    in_stroke = (eodarm.stroke_violations(arm, length) == 0).all(axis=1)
    singular = np.isclose(alpha[:, 0], full["alpha1"].values[0])
    reach = full["reachable"].values.ravel()
    np.testing.assert_array_equal(reach, in_stroke & ~singular)
    assert reach.any() and (~reach & ~singular).any()  # some poses are out of stroke


# ---------------------------------------------------------------------------- the Dataset
def test_the_dataset_has_named_dims_units_and_the_model(full: xr.Dataset) -> None:
    assert full["force_n"].dims == ("alpha1", "alpha2", "alpha3", "mass_kg", "actuator")
    assert full["dalpha_deg"].dims == ("alpha1", "alpha2", "alpha3", "mass_kg", "link")
    assert full["dy_mm"].dims == ("alpha1", "alpha2", "alpha3", "mass_kg")
    assert full["reachable"].dims == ("alpha1", "alpha2", "alpha3")
    units = {"force_n": "N", "dy_mm": "mm", "dalpha_deg": "deg", "length_mm": "mm"}
    for key, unit in units.items():
        assert full[key].attrs["units"] == unit and full[key].attrs["long_name"]
    assert full["alpha1"].attrs["units"] == "deg" and full["mass_kg"].attrs["units"] == "kg"
    assert full.attrs["arm"] == "example-arm"
    assert full.attrs["model"] == "baseline + actuator_compliance@M1=2"
    assert full.attrs["self_weight"] == 1
    # users pick poses with .sel
    cell = full.sel(alpha1=full["alpha1"].values[3], alpha2=15.0, alpha3=-20.0, mass_kg=6.5)
    assert cell["force_n"].shape == (3,)


def test_dims_follow_the_order_of_the_grid_dict(arm: eodarm.Arm) -> None:
    g = {"alpha3": [-5.0, 5.0], "alpha1": [80.0, 90.0, 100.0], "alpha2": [10.0]}
    ds = sweep_fn(arm, alpha_deg=g, mass_kg=[2.0])
    assert ds["dy_mm"].dims == ("alpha3", "alpha1", "alpha2", "mass_kg")
    want = eodarm.solve(arm, [90.0, 10.0, 5.0], 2.0)
    got = ds.sel(alpha3=5.0, alpha1=90.0, alpha2=10.0, mass_kg=2.0)
    assert float(got["dy_mm"]) == pytest.approx(float(want["dy_mm"][0]), abs=1e-12)


# ---------------------------------------------------------------------------- reductions
def _nan_reduce(x: np.ndarray, op: str, axes: tuple[int, ...]) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN groups
        return (np.nanmax if op == "max" else np.nanmin)(x, axis=axes)


@pytest.mark.parametrize(
    "dims", [["mass_kg"], ["alpha3", "mass_kg"], ["alpha2", "alpha3", "mass_kg"]]
)
@pytest.mark.parametrize("op", ["max", "min", "argmax", "argmin"])
def test_reductions_are_the_numpy_reductions_of_the_full_result(
    arm: eodarm.Arm, grid: dict[str, np.ndarray], full: xr.Dataset, op: str, dims: list[str]
) -> None:
    red = sweep_fn(
        arm,
        alpha_deg=grid,
        mass_kg=MASSES,
        effects=SOFT,
        reduce={"op": op, "dims": dims},
        chunk_size=11,
    )
    k = len(dims)
    kept = [d for d in ("alpha1", "alpha2", "alpha3") if d not in dims]
    assert red["dy_mm"].dims == tuple(kept)
    assert red["force_n"].dims == (*kept, "actuator")
    for key in ("force_n", "dx_mm", "dy_mm", "dalpha_deg", "dl_mm"):
        x = full[key].values  # (a1, a2, a3, mass[, n])
        axes = tuple(range(4 - k, 4))
        got = red[key].values
        if op in ("max", "min"):
            np.testing.assert_array_equal(got, _nan_reduce(x, op, axes), err_msg=key)
            continue
        assert got.dtype == np.int64
        # flat index over the reduced dims in C order: the value there is the extreme, and
        # no earlier index holds it; -1 where every cell is NaN
        flat = x.reshape(*x.shape[: 4 - k], -1, *x.shape[4:])  # reduced dims are contiguous
        ext = _nan_reduce(flat, op[3:], (4 - k,))
        allnan = np.isnan(flat).all(axis=4 - k)
        np.testing.assert_array_equal(got == -1, allnan, err_msg=key)
        idx = np.where(got < 0, 0, got)
        at = np.take_along_axis(flat, np.expand_dims(idx, 4 - k), axis=4 - k).squeeze(4 - k)
        np.testing.assert_array_equal(at[~allnan], ext[~allnan], err_msg=key)
        first = np.argmax(flat == np.expand_dims(ext, 4 - k), axis=4 - k)
        np.testing.assert_array_equal(got[~allnan], first[~allnan], err_msg=key)
    np.testing.assert_array_equal(
        red["ok"].values, full["ok"].values.any(axis=tuple(range(4 - k, 4)))
    )
    reach = full["reachable"].values
    if k > 1:
        reach = reach.any(axis=tuple(range(4 - k, 3)))
        assert "length_mm" not in red and "effector_x_mm" not in red
    np.testing.assert_array_equal(red["reachable"].values, reach)
    np.testing.assert_array_equal(red.attrs["reduced_mass_kg"], MASSES)


def test_mask_unreachable_drops_out_of_stroke_poses_from_cells_and_reductions(
    arm: eodarm.Arm, grid: dict[str, np.ndarray], full: xr.Dataset
) -> None:
    masked = sweep_fn(arm, alpha_deg=grid, mass_kg=MASSES, effects=SOFT, mask_unreachable=True)
    want = full.where(full["reachable"])
    for key in ("force_n", "dy_mm", "dl_mm"):
        np.testing.assert_array_equal(masked[key].values, want[key].values, err_msg=key)
    np.testing.assert_array_equal(
        masked["ok"].values, full["ok"].values & full["reachable"].values[..., None]
    )
    np.testing.assert_array_equal(masked["reachable"].values, full["reachable"].values)
    for key in ("length_mm", "effector_x_mm"):  # the poses themselves are kept
        # to round-off: the two sweeps may take different (equally exact) paths in the core
        np.testing.assert_allclose(
            masked[key].values, full[key].values, rtol=0, atol=1e-9, err_msg=key
        )
    red = sweep_fn(
        arm,
        alpha_deg=grid,
        mass_kg=MASSES,
        effects=SOFT,
        mask_unreachable=True,
        reduce={"op": "max", "dims": ["alpha3", "mass_kg"]},
    )
    np.testing.assert_array_equal(
        red["dy_mm"].values, _nan_reduce(want["dy_mm"].values, "max", (2, 3))
    )


# ---------------------------------------------------------------------------- chunks
@pytest.mark.parametrize("reduce", [None, {"op": "argmin", "dims": ["alpha3", "mass_kg"]}])
def test_chunk_boundaries_change_nothing(
    arm: eodarm.Arm, grid: dict[str, np.ndarray], reduce: dict[str, Any] | None
) -> None:
    runs = [
        sweep_fn(arm, alpha_deg=grid, mass_kg=MASSES, effects=SOFT, reduce=reduce, chunk_size=c)
        for c in (1, 7, 1000)
    ]
    for other in runs[1:]:
        xr.testing.assert_identical(runs[0], other)


def test_no_chunk_is_larger_than_asked_and_reduced_output_is_small(
    arm: eodarm.Arm, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Chunked grids (here of lengths) make their poses per chunk and keep only the
    reduction."""
    spans: list[int] = []
    real = sweep_mod.Grid.values

    def spy(self: Any, start: int, stop: int) -> np.ndarray:
        spans.append(stop - start)
        return real(self, start, stop)

    monkeypatch.setattr(sweep_mod.Grid, "values", spy)
    g = {
        "l1": np.linspace(250, 330, 30),
        "l2": np.linspace(480, 600, 20),
        "l3": np.linspace(480, 540, 10),
    }
    ds = sweep_fn(
        arm,
        lengths=g,
        mass_kg=[1.0, 2.0],
        chunk_size=250,
        reduce={"op": "max", "dims": ["l3", "mass_kg"]},
    )
    assert sum(spans) == 6000 and max(spans) <= 250 and len(spans) == 24
    assert ds["dy_mm"].shape == (30, 20) and ds.nbytes < 30 * 20 * 200


def test_an_angle_grid_is_never_built_in_python_and_a_reduced_sweep_stays_small(
    arm: eodarm.Arm, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An angle grid goes to the core whole: no per-pose array is made in Python, and the
    memory numpy allocates for a reduced sweep of 480 000 poses is about its output."""
    import tracemalloc

    def forbidden(self: Any, start: int, stop: int) -> np.ndarray:
        raise AssertionError("an angle grid was built in Python")

    monkeypatch.setattr(sweep_mod.Grid, "values", forbidden)
    g = {
        "alpha1": np.linspace(60, 110, 80),
        "alpha2": np.linspace(0, 30, 60),
        "alpha3": np.linspace(-10, 10, 100),
    }
    sweep_fn(arm, alpha_deg=g, mass_kg=[1.0], reduce={"op": "max", "dims": ["mass_kg"]})
    tracemalloc.start()
    try:
        ds = sweep_fn(
            arm,
            alpha_deg=g,
            mass_kg=[1.0, 2.0],
            reduce={"op": "max", "dims": ["alpha3", "mass_kg"]},
        )
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert ds["dy_mm"].shape == (80, 60) and bool(ds["ok"].all())
    # The output is 4800 groups × 12 values; all outputs of every cell would be 130 MB.
    assert peak < 2_000_000, peak


# ---------------------------------------------------------------------------- other grids
def test_a_lengths_grid_puts_the_actuators_at_the_asked_lengths(arm: eodarm.Arm) -> None:
    g = {"l1": [200.0, 280.0, 330.0], "l2": [450.0, 520.0, 640.0], "l3": [470.0, 530.0]}
    ds = sweep_fn(arm, lengths=g, mass_kg=[2.0], alpha_ref_deg=[90.0, 10.0, 0.0])
    assert ds["dy_mm"].dims == ("l1", "l2", "l3", "mass_kg")
    assert ds["l1"].attrs["units"] == "mm" and ds.attrs["grid"] == "lengths"
    alpha = ds["alpha_deg"].values.reshape(-1, 3)
    exists = np.isfinite(alpha).all(axis=1)
    assert exists.any()
    want = np.stack(np.meshgrid(*g.values(), indexing="ij"), axis=-1).reshape(-1, 3)
    got = eodarm.forward(arm, alpha[exists])["length_mm"]
    np.testing.assert_allclose(got, want[exists], atol=1e-9)
    np.testing.assert_allclose(
        ds["length_mm"].values.reshape(-1, 3)[exists], want[exists], atol=1e-9
    )
    # out of stroke (l1 = 200 < 250, l2 = 640 > 630) is not reachable and not ok; a grid
    # point without a pose is out of stroke too
    out = (want[:, 0] < 250) | (want[:, 1] > 630)
    reach = ds["reachable"].values.ravel()
    assert not reach[out].any() and reach[exists & ~out].all()
    ok = ds["ok"].values.ravel()
    status = ds["status"].values.ravel()
    assert (status[out | ~exists] == 1).all() and not ok[out | ~exists].any()
    # the same poses through an angle sweep give the same cells and status
    sol = eodarm.solve(arm, alpha[exists], 2.0)
    np.testing.assert_array_equal(status[exists], sol["status"])
    assert ok[exists].any()
    # the sweep's fast kernel and solve agree to round-off of mm-sized coordinates
    dy = ds["dy_mm"].values.ravel()[exists]
    good = ok[exists]
    np.testing.assert_allclose(dy[good], sol["dy_mm"][good], rtol=1e-9, atol=1e-9)


def test_masking_a_lengths_grid_keeps_its_poses_and_drops_their_cells(arm: eodarm.Arm) -> None:
    g = {"l1": [1.0, 200.0, 300.0], "l2": [500.0], "l3": [500.0]}  # no pose, out of stroke, ok
    plain = sweep_fn(arm, lengths=g, mass_kg=[1.0])
    masked = sweep_fn(arm, lengths=g, mass_kg=[1.0], mask_unreachable=True)
    np.testing.assert_array_equal(masked["reachable"].values, plain["reachable"].values)
    for key in ("alpha_deg", "length_mm", "effector_x_mm"):  # to round-off (core paths differ)
        np.testing.assert_allclose(
            masked[key].values, plain[key].values, rtol=0, atol=1e-9, err_msg=key
        )
    # out of stroke is never ok: the mask changes nothing
    assert plain["ok"].values.ravel().tolist() == [False, False, True]
    assert masked["ok"].values.ravel().tolist() == [False, False, True]
    assert plain["status"].values.ravel().tolist() == [1, 1, 0]
    np.testing.assert_array_equal(masked["status"].values, plain["status"].values)
    assert np.isnan(masked["dy_mm"].values.ravel()[:2]).all()
    assert np.isfinite(masked["alpha_deg"].values[1]).all()


def test_lengths_that_cannot_assemble_the_arm_are_not_ok(arm: eodarm.Arm) -> None:
    ds = sweep_fn(arm, lengths={"l1": [1.0, 300.0], "l2": [500.0], "l3": [500.0]}, mass_kg=[1.0])
    assert ds["ok"].values.ravel().tolist() == [False, True]
    assert ds["reachable"].values.ravel().tolist() == [False, True]
    assert np.isnan(ds["alpha_deg"].values[0]).all() and np.isnan(ds["dy_mm"].values[0]).all()


def test_an_effector_grid_puts_the_load_point_where_asked(arm: eodarm.Arm) -> None:
    g = {"x": [600.0, 800.0, 5000.0], "y": [300.0, 500.0], "phi": [-10.0, 0.0]}
    ds = sweep_fn(arm, effector=g, mass_kg=[1.0, 3.0], elbow=-1)
    assert ds["dy_mm"].dims == ("x", "y", "phi", "mass_kg")
    tgt = np.stack(np.meshgrid(*g.values(), indexing="ij"), axis=-1).reshape(-1, 3)
    alpha = ds["alpha_deg"].values.reshape(-1, 3)
    exists = np.isfinite(alpha).all(axis=1)
    np.testing.assert_array_equal(exists, tgt[:, 0] < 5000)
    load = eodarm.forward(arm, alpha[exists])["O"][:, 3]
    np.testing.assert_allclose(load, tgt[exists, :2], atol=1e-9)
    np.testing.assert_allclose(alpha[exists, 2], tgt[exists, 2], atol=1e-12)
    np.testing.assert_allclose(
        ds["effector_x_mm"].values.ravel()[exists], tgt[exists, 0], atol=1e-9
    )
    assert not ds["ok"].values.reshape(-1, 2)[~exists].any()
    red = sweep_fn(
        arm, effector=g, mass_kg=[1.0, 3.0], reduce={"op": "min", "dims": ["phi", "mass_kg"]}
    )
    want = _nan_reduce(ds["dy_mm"].values, "min", (2, 3))
    np.testing.assert_array_equal(red["dy_mm"].values, want)


# ---------------------------------------------------------------------------- Dask
def test_a_dask_cluster_gives_exactly_the_local_result(
    arm: eodarm.Arm, grid: dict[str, np.ndarray], full: xr.Dataset
) -> None:
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        remote = sweep_fn(
            arm, alpha_deg=grid, mass_kg=MASSES, effects=SOFT, chunk_size=37, scheduler=client
        )
        reduced = sweep_fn(
            arm,
            alpha_deg=grid,
            mass_kg=MASSES,
            effects=SOFT,
            chunk_size=20,
            scheduler=client,
            reduce={"op": "argmax", "dims": ["alpha3", "mass_kg"]},
        )
    xr.testing.assert_identical(remote, full)
    local = sweep_fn(
        arm,
        alpha_deg=grid,
        mass_kg=MASSES,
        effects=SOFT,
        chunk_size=20,
        reduce={"op": "argmax", "dims": ["alpha3", "mass_kg"]},
    )
    xr.testing.assert_identical(reduced, local)


def test_a_dask_scheduler_name_gives_exactly_the_local_result(
    arm: eodarm.Arm, grid: dict[str, np.ndarray], full: xr.Dataset
) -> None:
    pytest.importorskip("dask")
    got = sweep_fn(
        arm, alpha_deg=grid, mass_kg=MASSES, effects=SOFT, chunk_size=37, scheduler="threads"
    )
    xr.testing.assert_identical(got, full)


# ---------------------------------------------------------------------------- the kernel
def test_the_fallback_kernel_reduces_like_numpy_and_keeps_per_pose_outputs(arm: eodarm.Arm) -> None:
    alpha = np.array([[90.0, 10.0, 0.0], [placeholder(arm)[0], 0.0, 0.0], [70.0, 20.0, -5.0]])
    mass = np.array([1.0, 4.0])
    codes, places, values = effect_arrays(MODEL, 3)
    full = sweep_fallback(arm, alpha, mass, codes, places, values, True)
    red = sweep_fallback(arm, alpha, mass, codes, places, values, True, "argmax", 2)
    assert full["force_n"].shape == (3, 2, 3) and full["ok"].tolist() == [
        [True] * 2,
        [False] * 2,
        [True] * 2,
    ]
    assert red["dy_mm"].tolist() == [
        int(np.argmax(full["dy_mm"][0])),
        -1,
        int(np.argmax(full["dy_mm"][2])),
    ]
    assert red["length_mm"].shape == (3, 3) and red["reachable"].tolist() == [True, False, True]


@pytest.mark.parametrize(
    "reduce,group", [(None, 1), ("max", 3), ("min", 6), ("argmax", 3), ("argmin", 1)]
)
def test_the_core_sweep_equals_the_fallback(
    arm: eodarm.Arm, grid: dict[str, np.ndarray], reduce: str | None, group: int
) -> None:
    from eodarm.model.solver import _core_arm

    alpha = np.stack(np.meshgrid(*grid.values(), indexing="ij"), axis=-1).reshape(-1, 3)
    mass = np.array(MASSES)
    codes, places, values = effect_arrays([*SOFT, *MODEL[1:]], 3)
    want = sweep_fallback(arm, alpha, mass, codes, places, values, True, reduce, group)
    got = _core.sweep(_core_arm(arm), alpha, mass, codes, places, values, True, reduce, group, None)
    assert set(got) >= set(want)
    for key, w in want.items():
        g = np.asarray(got[key])
        assert g.shape == w.shape and g.dtype == w.dtype, key
        if g.dtype.kind == "f":
            np.testing.assert_allclose(g, w, rtol=1e-12, atol=1e-9, err_msg=key)
        else:
            np.testing.assert_array_equal(g, w, err_msg=key)


# ---------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "kwargs,message",
    [
        ({"reduce": {"op": "max", "dims": ["alpha9"]}}, r"unknown dimension 'alpha9'"),
        (
            {"reduce": {"op": "max", "dims": ["alpha2", "mass_kg"]}},
            r"cannot reduce over 'alpha2'.*innermost",
        ),
        ({"reduce": {"op": "max", "dims": ["alpha3"]}}, r"cannot reduce over 'alpha3'.*innermost"),
        ({"reduce": {"op": "mean", "dims": ["mass_kg"]}}, r"reduce op 'mean' is not one of"),
        (
            {"alpha_deg": {"alpha1": [], "alpha2": [0.0], "alpha3": [0.0]}},
            r"grid 'alpha1' is empty",
        ),
        (
            {"alpha_deg": {"alpha1": [90.0], "alpha2": [0.0, np.nan], "alpha3": [0.0]}},
            r"grid 'alpha2' has a non-finite value at index 1",
        ),
        ({"alpha_deg": {"alpha1": [90.0], "alpha2": [0.0]}}, r"misses 'alpha3'"),
        (
            {"alpha_deg": {"alpha1": [90.0], "alpha2": [0.0], "alpha3": [0.0], "alpha4": [1.0]}},
            r"unknown alpha grid name 'alpha4'",
        ),
        ({"lengths": {"l1": [300.0], "l2": [500.0], "l3": [500.0]}}, r"exactly one grid"),
        ({"mass_kg": [1.0, -2.0]}, r"mass_kg\[1\] = -2.0 must be finite and >= 0"),
        ({"mass_kg": []}, r"mass_kg must be a non-empty"),
        ({"chunk_size": 0}, r"chunk_size must be >= 1"),
        ({"effects": [E("joint_clearance", "O5", clearance_mm=0.1)]}, r"only 3 links"),
    ],
)
def test_bad_input_gets_one_line_naming_the_problem(
    arm: eodarm.Arm, kwargs: dict[str, Any], message: str
) -> None:
    args: dict[str, Any] = {
        "alpha_deg": {"alpha1": [90.0], "alpha2": [0.0], "alpha3": [0.0]},
        "mass_kg": [1.0],
    }
    args.update(kwargs)
    with pytest.raises(ValueError, match=message) as info:
        sweep_fn(arm, **args)
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------------------- progress, Ctrl-C
def test_a_progress_bar_shows_on_stderr_when_asked(
    arm: eodarm.Arm, capsys: pytest.CaptureFixture[str]
) -> None:
    g = {"alpha1": [80.0, 90.0], "alpha2": [0.0, 10.0], "alpha3": [0.0]}
    sweep_fn(arm, alpha_deg=g, mass_kg=[1.0], chunk_size=1, progress=True)
    assert "eodarm sweep" in capsys.readouterr().err
    sweep_fn(arm, alpha_deg=g, mass_kg=[1.0], chunk_size=1, progress=False)
    sweep_fn(arm, alpha_deg=g, mass_kg=[1.0], chunk_size=1)  # 4 chunks in well under 2 s
    assert capsys.readouterr().err == ""


def test_ctrl_c_between_chunks_stops_a_chunked_sweep(
    arm: eodarm.Arm, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = []
    real = sweep_mod._chunk

    def interrupted(job: Any, start: int, stop: int) -> Any:
        calls.append(start)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(job, start, stop)

    monkeypatch.setattr(sweep_mod, "_chunk", interrupted)
    g = {"l1": np.linspace(250, 330, 10), "l2": [520.0], "l3": [500.0]}
    with pytest.raises(KeyboardInterrupt):
        sweep_fn(arm, lengths=g, mass_kg=[1.0], chunk_size=2)
    assert len(calls) == 3  # no chunk after the interrupt


class _InterruptingBar:
    """A stand-in progress bar that records the progress and sends SIGINT (as Ctrl-C does)
    at its first update."""

    def __init__(self, total: int) -> None:
        self.total, self.n, self.seen = total, 0, []

    def update(self, k: int) -> None:
        self.n += k
        self.seen.append(self.n)
        if len(self.seen) == 1:
            signal.raise_signal(signal.SIGINT)

    def close(self) -> None:
        pass


def test_ctrl_c_stops_the_core_between_its_chunks(
    arm: eodarm.Arm, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A real SIGINT during a one-call angle-grid sweep raises KeyboardInterrupt.

    Independent of timing and of the tests before it: the core checks in (signals, then the
    progress report) before each chunk of the calling thread, the first included, so the
    progress bar's first update comes before any pose is solved; it sends the SIGINT itself,
    synchronously, on the main thread that runs Python's handler (tests/conftest.py puts
    Python's own in place), which raises KeyboardInterrupt out of that update, however the
    threads share the chunks.
    """
    bars: list[_InterruptingBar] = []

    def fake_bar(total: int, progress: Any, **kwargs: Any) -> _InterruptingBar:
        bars.append(_InterruptingBar(total))
        return bars[-1]

    monkeypatch.setattr(sweep_mod, "_progress_bar", fake_bar)
    g = {
        "alpha1": np.linspace(60, 110, 200),
        "alpha2": np.linspace(0, 30, 100),
        "alpha3": np.linspace(-10, 10, 100),
    }
    for threads in (1, 2):
        with pytest.raises(KeyboardInterrupt):
            sweep_fn(
                arm,
                alpha_deg=g,
                mass_kg=[1.0],
                reduce={"op": "max", "dims": ["mass_kg"]},
                threads=threads,
                progress=True,
            )
        bar = bars.pop()
        assert bar.total == 2_000_000
        assert bar.seen == [0], "one report, before the first chunk, and no report after it"


def test_ctrl_c_leaves_the_chunks_after_it_unsolved(arm: eodarm.Arm) -> None:
    """On one thread the core stops at its first check after the interrupt (inside the
    progress callback that sent it, or before the next chunk): at most the first chunk is
    written, every later pose keeps what the caller's arrays held."""
    axes = [np.linspace(60, 110, 50), np.linspace(0, 30, 40), np.linspace(-10, 10, 30)]
    size = 50 * 40 * 30
    mass = np.array([1.0])
    codes, places, values = effect_arrays([], arm.n)
    out = {
        "force_n": np.full((size, 1, 3), np.nan),
        "dx_mm": np.full((size, 1), np.nan),
        "dy_mm": np.full((size, 1), np.nan),
        "dalpha_deg": np.full((size, 1, 3), np.nan),
        "dl_mm": np.full((size, 1, 3), np.nan),
        "ok": np.zeros((size, 1), dtype=bool),
        "reachable": np.zeros(size, dtype=bool),
        "length_mm": np.full((size, 3), np.nan),
        "effector_x_mm": np.full(size, np.nan),
        "effector_y_mm": np.full(size, np.nan),
    }
    reports: list[int] = []

    def progress(done: int) -> None:
        reports.append(done)
        if len(reports) == 1:
            signal.raise_signal(signal.SIGINT)  # synchronously: no timer races the work

    with pytest.raises(KeyboardInterrupt):
        _core.sweep(
            _core_arm(arm),
            None,
            mass,
            codes,
            places,
            values,
            True,
            None,
            1,
            1,
            grid=(axes, [0, 1, 2], 0, size),
            out=out,
            progress=progress,
            chunk_rows=1000,
        )
    assert reports == [0]
    assert not np.isfinite(out["length_mm"][1000:]).any(), "nothing after it"


def test_ctrl_c_in_the_cli_exits_130_without_writing(
    arm: eodarm.Arm,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    def interrupted(*args: Any, **kwargs: Any) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep_mod, "_sweep_grid", interrupted)
    out = tmp_path / "never.nc"
    arm_file = tmp_path / "arm.toml"
    arm_file.write_text(arm.to_toml())
    code = run_cli(
        [
            "--arm",
            str(arm_file),
            "--alpha1",
            "60:120:10",
            "--alpha2",
            "0",
            "--alpha3",
            "0",
            "--chunk-size",
            "2",
            "-o",
            str(out),
            "--no-progress",
        ]
    )
    assert code == 130 and not out.exists()
    assert "interrupted" in capsys.readouterr().err


# ---------------------------------------------------------------------------- CLI
def run_cli(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="eodarm")
    add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["sweep", *argv])
    return int(args.func(args))


def test_cli_writes_a_netcdf_that_reads_back_equal(
    arm: eodarm.Arm, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    arm_file = tmp_path / "arm.toml"
    arm_file.write_text(arm.to_toml())
    out = tmp_path / "sweep.nc"
    argv = [
        "--arm",
        str(arm_file),
        "--alpha1",
        "60:120:4",
        "--alpha2",
        "0,20",
        "--alpha3",
        "-10:10:3",
    ]
    argv += ["--mass", "1.5,5", "--add", "joint_clearance@O3=0.15", "-o", str(out), "--no-progress"]
    assert run_cli(argv) == 0
    captured = capsys.readouterr()
    assert "reachable poses" in captured.out and str(out) in captured.err
    got = xr.load_dataset(out, engine="scipy")
    want = sweep_fn(
        arm,
        alpha_deg={
            "alpha1": np.linspace(60, 120, 4),
            "alpha2": [0.0, 20.0],
            "alpha3": [-10.0, 0.0, 10.0],
        },
        mass_kg=[1.5, 5.0],
        effects=[E("joint_clearance", "O3", clearance_mm=0.15)],
    )
    xr.testing.assert_identical(got, want)


def test_cli_reduces_and_writes_zarr(arm: eodarm.Arm, tmp_path: Path) -> None:
    pytest.importorskip("zarr")
    arm_file = tmp_path / "arm.toml"
    arm_file.write_text(arm.to_toml())
    out = tmp_path / "sweep.zarr"
    argv = [
        "--arm",
        str(arm_file),
        "--alpha1",
        "60:120:4",
        "--alpha2",
        "0,20",
        "--alpha3",
        "-10:10:3",
    ]
    argv += ["--mass", "1.5,5", "--reduce", "max:alpha3,mass_kg", "-o", str(out), "--no-progress"]
    assert run_cli(argv) == 0
    got = xr.open_zarr(out, consolidated=False).load()
    want = sweep_fn(
        arm,
        alpha_deg={
            "alpha1": np.linspace(60, 120, 4),
            "alpha2": [0.0, 20.0],
            "alpha3": [-10.0, 0.0, 10.0],
        },
        mass_kg=[1.5, 5.0],
        reduce={"op": "max", "dims": ["alpha3", "mass_kg"]},
    )
    xr.testing.assert_equal(got, want)
    assert got["dy_mm"].dims == ("alpha1", "alpha2")


def test_cli_without_an_arm_sweeps_the_seed_arm_and_plots_the_four_maps(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    figs = tmp_path / "figs"
    argv = ["--alpha1", "60:120:7", "--alpha2", "0:20:3", "--alpha3", "-10:10:3", "--mass", "6.5"]
    argv += ["--add", "mount_compliance@M2=580", "--add", "mount_compliance@M3=916"]
    argv += ["--plot", str(figs), "--no-progress"]
    assert run_cli(argv) == 0
    err = capsys.readouterr().err
    assert "seed2022" in err and "assuming 1000 N" in err
    names = sorted(p.name for p in figs.iterdir())
    assert names == ["capacity.png", "dominant_effect.png", "forces.png", "sag.png"]
    for p in figs.iterdir():
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "argv,message",
    [
        (["--alpha4", "0:1:2"], r"--alpha4: the arm has only 3 links"),
        (["--alpha1", "1:2"], r"--alpha1 '1:2': expected LO:HI:N"),
        (["--reduce", "mean:mass_kg"], r"--reduce 'mean:mass_kg': expected OP:DIM"),
        (["--alpha1", "90", "--x", "1:2:2"], r"one kind of grid"),
        (["-o", "out.csv"], r"must end in .nc"),
    ],
)
def test_cli_bad_input_gets_one_line(argv: list[str], message: str, tmp_path: Path) -> None:
    argv = [a.replace("out.csv", str(tmp_path / "out.csv")) for a in argv]
    base = ["--alpha2", "0", "--alpha3", "0", "--mass", "1", "--no-progress"]
    if not any(a.startswith("--alpha1") or a == "--x" for a in argv):
        base += ["--alpha1", "90"]
    with pytest.raises(eodarm.EodarmError, match=message) as info:
        run_cli([*argv, *base])
    assert "\n" not in str(info.value)


def test_parse_range_is_linspace() -> None:
    from eodarm.cli.sweep import parse_range

    np.testing.assert_array_equal(parse_range("40:130:46", "x"), np.linspace(40, 130, 46))
    np.testing.assert_array_equal(parse_range("1.5,5,6.5", "x"), [1.5, 5.0, 6.5])
    assert parse_range("7", "x").tolist() == [7.0]
    assert math.isclose(parse_range("-20:20:21", "x")[1], -18.0)


def test_a_sweep_with_the_finite_element_model_equals_solve_with_it() -> None:
    """Issue 6: the FE model is selected in sweeps the same way as in solve."""
    arm = eodarm.Arm.from_toml(Path(__file__).resolve().parent.parent / "examples/example_arm.toml")
    grid = {"alpha1": [70.0, 95.0], "alpha2": [5.0, 20.0], "alpha3": [0.0]}
    effects = [eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1500.0)]
    ds = sweep_fn(arm, alpha_deg=grid, mass_kg=[2.0, 5.0], effects=effects, model="fem")
    alpha = np.array(list(itertools.product(*grid.values())))
    for j, m in enumerate((2.0, 5.0)):
        want = eodarm.solve(arm, alpha, m, effects, model="fem")
        got = ds["dy_mm"].values.reshape(-1, 2)[:, j]
        np.testing.assert_allclose(got, want["dy_mm"], rtol=1e-12, atol=1e-12)
    analytic = sweep_fn(arm, alpha_deg=grid, mass_kg=[2.0, 5.0], effects=effects)
    # linear FE vs exact pose: equal to first order in the load (a few % at these loads)
    np.testing.assert_allclose(ds["dy_mm"].values, analytic["dy_mm"].values, rtol=0.05)
    with pytest.raises(ValueError, match="model"):
        sweep_fn(arm, alpha_deg=grid, mass_kg=[2.0], model="ansys")
