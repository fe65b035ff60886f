"""Every way of walking a sweep carries the drives' torques (docs/sweeps.md, "Arms with rotary
drives"): a reduced sweep reduces ``torque_nmm`` and ``dtorque_nmm`` as it reduces the forces,
a sweep walked chunk by chunk from Python (a Dask scheduler) and one written chunk by chunk
into Zarr give the in-memory sweep's torques, on the rotary and the mixed example arms, NaN
(or −1 for an arg-reduction) at the joints turned by linear actuators.

Tolerances: the torques of every path come from the same statics (``eodarm.model.solver.
statics``) of the same poses, in other batches; the core computes each pose alone, so they
agree to the last bit, and the tests ask for that (``assert_array_equal``). A Zarr store holds
float64 as it is, so its round trip is exact too.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

import eodarm
from eodarm.cli import main

ROOT = Path(__file__).resolve().parents[1]
ARMS = {name: ROOT / "examples" / f"{name}_arm.toml" for name in ("rotary", "mixed")}
#: A pose of each arm inside every drive's range and every stroke; the grid spans it ±10°.
POSE = {"rotary": (60.0, -30.0, -20.0), "mixed": (60.0, -60.0, -100.0)}
#: Payloads (kg): the largest takes the rotary arm over its wrist drive's torque limit (not ok).
MASSES = [0.5, 3.0, 12.0]
TORQUES = ("torque_nmm", "dtorque_nmm")


def _grid(name: str) -> dict[str, np.ndarray]:
    a = POSE[name]
    return {
        "alpha1": np.linspace(a[0] - 10, a[0] + 10, 4),
        "alpha2": np.linspace(a[1] - 10, a[1] + 10, 3),
        "alpha3": np.linspace(a[2] - 10, a[2] + 10, 5),
    }


def _effects(name: str) -> list[eodarm.Effect]:
    """Drive 1 is rotary on both arms: a joint friction there makes the torque through the
    drive differ from the statics' torque."""
    return [eodarm.Effect("joint_friction", "O1", torque_nmm=4000.0)]


@pytest.fixture(scope="module", params=list(ARMS))
def case(request: pytest.FixtureRequest) -> tuple[str, eodarm.Arm, xr.Dataset]:
    name = request.param
    arm = eodarm.Arm.from_toml(ARMS[name])
    full = eodarm.sweep(arm, alpha_deg=_grid(name), mass_kg=MASSES, effects=_effects(name))
    return name, arm, full


def _nan_reduce(x: np.ndarray, op: str, axis: int) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN groups
        return (np.nanmax if op == "max" else np.nanmin)(x, axis=axis)


def test_the_in_memory_sweep_has_torques_of_the_solve_and_nan_at_linear_joints(
    case: tuple[str, eodarm.Arm, xr.Dataset],
) -> None:
    name, arm, full = case
    rotary = np.array(arm.kinds) == "rotary"
    ok = full["ok"].values
    assert ok.any() and not ok.all()  # both kinds of cell are in the grid
    alpha = np.array(np.meshgrid(*_grid(name).values(), indexing="ij")).reshape(3, -1).T
    for j, m in enumerate(MASSES):
        ref = eodarm.solve(arm, alpha, m, _effects(name))
        for key in TORQUES:
            t = full[key].isel(mass_kg=j).values.reshape(-1, 3)
            good = ok[..., j].reshape(-1)
            np.testing.assert_allclose(t[good][:, rotary], ref[key][good][:, rotary], rtol=1e-12)
            assert np.isnan(t[~good]).all() and np.isnan(t[:, ~rotary]).all()


@pytest.mark.parametrize("dims", [["mass_kg"], ["alpha3", "mass_kg"]])
@pytest.mark.parametrize("op", ["max", "min", "argmax", "argmin"])
def test_a_reduced_sweep_reduces_the_torques_of_the_full_one(
    case: tuple[str, eodarm.Arm, xr.Dataset], op: str, dims: list[str]
) -> None:
    name, arm, full = case
    rotary = np.array(arm.kinds) == "rotary"
    red = eodarm.sweep(
        arm,
        alpha_deg=_grid(name),
        mass_kg=MASSES,
        effects=_effects(name),
        reduce={"op": op, "dims": dims},
        chunk_size=7,
    )
    k = len(dims)
    kept = [d for d in ("alpha1", "alpha2", "alpha3") if d not in dims]
    for key in TORQUES:
        assert red[key].dims == (*kept, "actuator")
        assert red[key].attrs["units"] == ("1" if op.startswith("arg") else "N mm")
        x = full[key].values  # (a1, a2, a3, mass, actuator), NaN where not ok
        flat = x.reshape(*x.shape[: 4 - k], -1, x.shape[-1])  # reduced dims are contiguous
        got = red[key].values
        if op in ("max", "min"):
            np.testing.assert_array_equal(got, _nan_reduce(flat, op, 4 - k), err_msg=key)
            assert np.isnan(got[..., ~rotary]).all()
            assert np.isfinite(got[..., rotary]).any()
            continue
        assert got.dtype == np.int64
        ext = _nan_reduce(flat, op[3:], 4 - k)
        allnan = np.isnan(flat).all(axis=4 - k)
        np.testing.assert_array_equal(got == -1, allnan, err_msg=key)
        assert (got[..., ~rotary] == -1).all()
        first = np.argmax(flat == np.expand_dims(ext, 4 - k), axis=4 - k)
        np.testing.assert_array_equal(got[~allnan], first[~allnan], err_msg=key)


def test_a_sweep_walked_in_chunks_from_python_has_the_same_torques(
    case: tuple[str, eodarm.Arm, xr.Dataset],
) -> None:
    pytest.importorskip("dask")
    name, arm, full = case
    kw: dict[str, Any] = {"alpha_deg": _grid(name), "mass_kg": MASSES, "effects": _effects(name)}
    got = eodarm.sweep(arm, **kw, scheduler="synchronous", chunk_size=5)
    xr.testing.assert_identical(got, full)
    red = {"op": "min", "dims": ["alpha3", "mass_kg"]}
    here = eodarm.sweep(arm, **kw, reduce=red, chunk_size=5)
    xr.testing.assert_identical(eodarm.sweep(arm, **kw, reduce=red, scheduler="synchronous"), here)


@pytest.mark.parametrize("reduce", [None, {"op": "max", "dims": ["alpha3", "mass_kg"]}])
def test_a_zarr_sweep_stores_the_torques_of_the_in_memory_one(
    case: tuple[str, eodarm.Arm, xr.Dataset], reduce: dict[str, Any] | None, tmp_path: Path
) -> None:
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    from eodarm.workspace import store

    name, arm, full = case
    kw: dict[str, Any] = {"alpha_deg": _grid(name), "mass_kg": MASSES, "effects": _effects(name)}
    want = full if reduce is None else eodarm.sweep(arm, **kw, reduce=reduce)
    out = store.sweep_to_zarr(tmp_path / "s.zarr", arm, **kw, reduce=reduce, chunk_size=6)
    with xr.open_zarr(out) as got:
        xr.testing.assert_identical(got.load(), want)
        assert set(TORQUES) <= set(got.data_vars)


@pytest.mark.parametrize("name", list(ARMS))
def test_the_cli_writes_the_torques_into_zarr_and_maps_them_from_it(
    name: str, tmp_path: Path
) -> None:
    """``-o OUT.zarr --plot``: the maps are drawn from the store, whose drives' torques the
    force map needs; ``--reduce`` stores the reduced torques."""
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    arm = eodarm.Arm.from_toml(ARMS[name])
    axes = {f"alpha{i + 1}": np.linspace(a - 10, a + 10, 3) for i, a in enumerate(POSE[name])}
    grid = [f"--alpha{i + 1}={a - 10}:{a + 10}:3" for i, a in enumerate(POSE[name])]
    argv = ["sweep", "--arm", str(ARMS[name]), *grid, "--mass", "1.5,5", "--no-progress"]
    whole, maps = tmp_path / "s.zarr", tmp_path / "maps"
    assert main([*argv, "-o", str(whole), "--plot", str(maps)]) == 0
    assert (maps / "forces.png").stat().st_size > 0
    red = tmp_path / "r.zarr"
    assert main([*argv, "--reduce", "max:alpha3,mass_kg", "-o", str(red)]) == 0
    reduce = {"op": "max", "dims": ["alpha3", "mass_kg"]}
    want = eodarm.sweep(arm, alpha_deg=axes, mass_kg=[1.5, 5.0], reduce=reduce)
    rotary = np.array(arm.kinds) == "rotary"
    with xr.open_zarr(red) as got:
        for key in TORQUES:
            np.testing.assert_array_equal(got[key].values, want[key].values)
        t = got["torque_nmm"].values
        assert np.isfinite(t[..., rotary]).any() and np.isnan(t[..., ~rotary]).all()


def test_a_zarr_sweep_begun_without_the_torques_is_not_resumed_with_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A partial store of a rotary arm's sweep started by an eodarm that wrote no torques
    (simulated) is refused in one line, not filled with holes or ended in a traceback."""
    pytest.importorskip("zarr")
    pytest.importorskip("dask")
    from eodarm.workspace import store, torque

    grid = [f"--alpha{i + 1}={a - 10}:{a + 10}:3" for i, a in enumerate(POSE["rotary"])]
    out = tmp_path / "s.zarr"
    argv = ["sweep", "--arm", str(ARMS["rotary"]), *grid, "--mass", "1.5", "--no-progress"]
    real = store._solve_span
    calls: list[int] = []

    def stop_after_one(setup: Any, start: int, stop: int) -> Any:
        if calls:
            raise KeyboardInterrupt
        calls.append(start)
        return real(setup, start, stop)

    with monkeypatch.context() as m:
        m.setattr(torque, "wanted", lambda job: False)
        m.setattr(store, "_solve_span", stop_after_one)
        assert main([*argv, "--chunk-size", "3", "-o", str(out)]) == 130
    capsys.readouterr()
    assert main([*argv, "-o", str(out), "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and len(err) < 300
    assert "has no torque_nmm (an older eodarm started it); remove it" in err
