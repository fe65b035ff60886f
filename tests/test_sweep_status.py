"""A status per sweep cell (docs/model.md §7, docs/sweeps.md "Validity").

Promises tested here: the default ``eodarm sweep`` (the CLI with default arguments: the seed
arm on its 46 × 31 × 21 grid under 1.5, 5 and 6.5 kg) has no ok cell that sags by more than
100 mm or rises under its payload, and every such cell (found by ``eodarm.solve``'s core on
the same poses, independently of the sweep) is not ok, with a reason; the chunked Python path
(``sweep_fallback``, ``eodarm.model.validity.status``) gives the core's status; NetCDF and
Zarr keep ``status``; reductions ignore the cells that are not ok even where one of them would
win; the CLI counts each reason in lines of at most 100 columns; the maps count the cells
they shade.
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import eodarm
from arms import example_arm
from eodarm import _core
from eodarm.cli.sweep import DEFAULT_ALPHA, add_parser, parse_range
from eodarm.data import datasets
from eodarm.model.effects import effect_arrays
from eodarm.model.solver import _core_arm
from eodarm.model.validity import STATUS
from eodarm.workspace import store
from eodarm.workspace.fallback import sweep_fallback
from eodarm.workspace.maps import not_ok_points

LARGE = STATUS.index("large_deflection")


def run_cli(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="eodarm")
    add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["sweep", *argv])
    return int(args.func(args))


def solve_cells(arm: eodarm.Arm, poses: np.ndarray, masses: list[float]) -> np.ndarray:
    """dy (N, M) of every pose under every mass by the core's batch solve (NaN where it fails)."""
    codes, places, values = effect_arrays(tuple(arm.effects), arm.n)
    dy = np.empty((poses.shape[0], len(masses)))
    for j, m in enumerate(masses):
        payload = np.zeros((poses.shape[0], 2))
        payload[:, 1] = -m * arm.g
        out = _core.solve(
            _core_arm(arm), poses, payload, codes, places, values, True, nan_on_failure=True
        )
        dy[:, j] = out["dy_mm"]
    return dy


def test_the_default_cli_sweep_marks_every_implausible_cell(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "default.nc"
    assert run_cli(["-o", str(out), "--no-progress"]) == 0
    text = capsys.readouterr().out
    ds = xr.load_dataset(out, engine="scipy")
    arm = datasets.load("seed2022").arm
    axes = [parse_range(a, "alpha") for a in DEFAULT_ALPHA]
    assert [ds.sizes[f"alpha{i + 1}"] for i in range(3)] == [a.size for a in axes]
    masses = [float(m) for m in ds["mass_kg"].values]
    assert masses == [1.5, 5.0, 6.5]
    status = ds["status"].transpose("alpha1", "alpha2", "alpha3", "mass_kg").values
    status = status.reshape(-1, 3)
    dy_sweep = ds["dy_mm"].transpose("alpha1", "alpha2", "alpha3", "mass_kg").values
    dy_sweep = dy_sweep.reshape(-1, 3)
    ok = status == 0
    # No ok cell sags by more than 100 mm or rises under its (downward) payload ...
    assert np.isfinite(dy_sweep[ok]).all()
    assert not (np.abs(dy_sweep[ok]) > 100.0).any()
    assert not (dy_sweep[ok] > 0.0).any()
    assert np.isnan(dy_sweep[~ok]).all()
    # ... and the cells that do, by an independent solve of the same poses, are not ok, with
    # a reason (the probe of issue 15 found 1 263 beyond 100 mm and 20 rising at 5 kg).
    poses = np.array(list(itertools.product(*axes)))
    dy = solve_cells(arm, poses, masses)
    implausible = (np.abs(dy) > 100.0) | (dy > 0.0)
    assert implausible.sum() > 1000
    assert (dy[:, 1] > 0.0).sum() > 0
    assert not ok[implausible].any()
    assert set(np.unique(status[implausible])) <= set(range(1, len(STATUS)))
    # Where the solve agrees that the cell is sound, the sweep has its value (to rounding:
    # the block kernel's trigonometry is within a few ulp of libm's).
    both = ok & np.isfinite(dy)
    np.testing.assert_allclose(dy_sweep[both], dy[both], rtol=1e-9, atol=1e-9)
    # The summary counts each reason that occurs.
    counts = np.bincount(status.ravel(), minlength=len(STATUS))
    lines = [ln for ln in text.splitlines() if "status" in ln or ln.startswith("  ")]
    joined = " ".join(lines)
    for code, k in enumerate(counts):
        if k:
            assert f"{k:,} {STATUS[code]}" in joined
    assert all(len(ln) <= 100 for ln in text.splitlines())


def test_the_fallback_path_gives_the_cores_status() -> None:
    """The Python path (user effects, FE model) and the core agree cell by cell, on an arm
    with strokes and force limits, under payloads from none to far too heavy."""
    arm = example_arm()
    rng = np.random.default_rng(3)
    alpha = np.column_stack(
        [rng.uniform(20, 160, 400), rng.uniform(-60, 90, 400), rng.uniform(-60, 60, 400)]
    )
    mass = np.array([0.0, 2.0, 20.0, 400.0])
    codes, places, values = effect_arrays([], arm.n)
    core = _core.sweep(_core_arm(arm), alpha, mass, codes, places, values, True)
    slow = sweep_fallback(arm, alpha, mass, codes, places, values, True)
    found = set(np.unique(core["status"]))
    assert {0, 1, 4, LARGE} <= found, found  # the test covers several reasons
    np.testing.assert_array_equal(slow["status"], core["status"])
    np.testing.assert_array_equal(slow["ok"], core["ok"])
    for group, op in [(4, "max"), (8, "argmin")]:
        c = _core.sweep(_core_arm(arm), alpha, mass, codes, places, values, True, op, group)
        s = sweep_fallback(arm, alpha, mass, codes, places, values, True, op, group)
        np.testing.assert_array_equal(s["status"], c["status"])
        np.testing.assert_array_equal(s["dy_mm"], c["dy_mm"]) if op == "argmin" else None


def test_reductions_ignore_cells_that_are_not_ok() -> None:
    """Max sag over the payloads: the heaviest payload would win if its cells counted, but
    they are beyond the model's validity; the result is the largest sound sag."""
    arm = example_arm()
    grid = {"alpha1": np.linspace(70, 110, 5), "alpha2": [0.0, 15.0], "alpha3": [0.0]}
    masses = [1.0, 3.0, 500.0]
    red = eodarm.sweep(
        arm, alpha_deg=grid, mass_kg=masses, reduce={"op": "min", "dims": ["mass_kg"]}
    )
    poses = np.array(list(itertools.product(*grid.values())))
    dy = solve_cells(arm, poses, masses)
    full = eodarm.sweep(arm, alpha_deg=grid, mass_kg=masses)
    st = full["status"].values.reshape(-1, 3)
    heavy_bad = st[:, 2] != 0
    assert heavy_bad.all(), "the 500 kg cells must be beyond the model for this test"
    assert (st[:, :2] == 0).all()
    # the unfiltered minimum would be the heavy cell where it solves at all
    solved = np.isfinite(dy[:, 2])
    assert (dy[solved, 2] < dy[solved, :2].min(axis=1)).all()
    got = red["dy_mm"].values.reshape(-1)
    np.testing.assert_allclose(got, dy[:, :2].min(axis=1), rtol=1e-9, atol=1e-9)
    # the group's status: some cell is not ok, the lowest reason among them
    np.testing.assert_array_equal(red["status"].values.reshape(-1), st[:, 2])
    assert red["ok"].values.all()
    arg = eodarm.sweep(
        arm, alpha_deg=grid, mass_kg=masses, reduce={"op": "argmin", "dims": ["mass_kg"]}
    )
    assert (arg["dy_mm"].values.reshape(-1) == 1).all()  # 3 kg, never the 500 kg cell


@pytest.mark.parametrize("kind", ["netcdf", "zarr"])
def test_a_store_round_trip_keeps_status(kind: str, tmp_path: Path) -> None:
    if kind == "zarr":
        pytest.importorskip("zarr")
    arm = example_arm()
    grid = {"alpha1": np.linspace(20, 160, 8), "alpha2": [-60.0, 0.0, 60.0], "alpha3": [0.0]}
    kw = {"alpha_deg": grid, "mass_kg": [0.0, 5.0, 300.0]}
    want = eodarm.sweep(arm, **kw)
    assert len(set(np.unique(want["status"].values))) >= 3
    if kind == "netcdf":
        got = store.sweep_to_netcdf(tmp_path / "s.nc", arm, **kw)
        got = xr.load_dataset(tmp_path / "s.nc", engine="scipy")
    else:
        store.sweep_to_zarr(tmp_path / "s.zarr", arm, **kw, chunk_size=5)
        got = xr.open_zarr(tmp_path / "s.zarr", consolidated=False).load()
    assert got["status"].dtype == np.uint8
    np.testing.assert_array_equal(got["status"].values, want["status"].values)
    assert got["status"].attrs["flag_meanings"].split() == list(STATUS)
    assert list(np.asarray(got["status"].attrs["flag_values"])) == list(range(len(STATUS)))


def test_the_sag_map_shades_and_counts_the_cells_that_are_not_ok() -> None:
    pytest.importorskip("matplotlib")
    from matplotlib.legend import Legend

    from eodarm.viz import maps

    arm = example_arm()
    grid = {"alpha1": np.linspace(20, 160, 12), "alpha2": [-60.0, 0.0, 60.0], "alpha3": [0.0]}
    ds = eodarm.sweep(arm, alpha_deg=grid, mass_kg=[5.0])
    x, _, counts = not_ok_points(ds.isel(mass_kg=0))
    codes = ds["status"].values.ravel()
    assert x.size == int((codes != 0).sum()) > 0
    assert counts == {STATUS[c]: int((codes == c).sum()) for c in set(codes) - {0}}
    fig = maps.sag_map(ds)
    # the key stands outside the maps (a figure legend): never over the data
    assert not [leg for a in fig.axes for leg in a.findobj(Legend)]
    texts = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    grey = [t for t in texts if t.startswith("poses not ok:")]
    assert len(grey) == 1, texts
    assert grey[0].splitlines()[1:] == [f"{k:,} {name}" for name, k in counts.items()]
