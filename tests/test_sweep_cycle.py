"""``sweep(..., cycle=True)``: where each cell's measure point sits after reference → payload
→ 0 (docs/model.md §9)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import eodarm
from eodarm.errors import EodarmError
from eodarm.model.solver import statics

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
GRID = {"alpha1": [80.0, 90.0, 100.0], "alpha2": [0.0, 15.0], "alpha3": [0.0, 5.0]}


def test_an_elastic_arm_comes_back_everywhere() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    elastic = [
        eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
        eodarm.Effect("link_bending", "L2", ei_n_mm2=2e9),
        eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=2e8),
    ]
    ds = eodarm.sweep(arm, alpha_deg=GRID, mass_kg=[1.0, 6.0], effects=elastic, cycle=True)
    assert np.abs(ds["dy_mm"]).min() > 0.1  # the payload did move it
    # the sweep takes the elastic return as exact (nothing to solve); the whole cycle
    # solved state by state agrees to rounding
    for k in ("return_dx_mm", "return_dy_mm"):
        assert ds[k].dims == ds["dy_mm"].dims
        np.testing.assert_array_equal(ds[k], 0.0)
    alpha = np.array(np.meshgrid(*GRID.values(), indexing="ij")).reshape(3, -1).T
    for m in (1.0, 6.0):
        seq = eodarm.solve_sequence(arm, alpha, [m, 0.0], effects=elastic)
        assert np.abs(seq["dy_mm"][:, 0]).min() > 0.1
        np.testing.assert_allclose(seq["dx_mm"][:, 1], 0.0, atol=1e-12)
        np.testing.assert_allclose(seq["dy_mm"][:, 1], 0.0, atol=1e-12)


def test_friction_leaves_the_arm_off_only_where_it_slipped() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    limit = 60.0
    fric = [eodarm.Effect("actuator_friction", "M2", friction_n=limit)]
    mass = [0.3, 6.0]
    ds = eodarm.sweep(arm, alpha_deg=GRID, mass_kg=mass, effects=fric, cycle=True)
    poses = np.stack(np.meshgrid(*GRID.values(), indexing="ij"), axis=-1).reshape(-1, 3)
    back = np.hypot(ds["return_dx_mm"], ds["return_dy_mm"]).values.reshape(-1, 2)
    for j, m in enumerate(mass):
        st = statics(arm, poses, np.full(len(poses), m))
        slipped = np.abs(st["force_n"][:, 1] - st["force0_n"][:, 1]) > limit
        # never slipped: the element held everything and lets go of it at the return
        assert (back[~slipped, j] < 1e-12).all()
        # slipped: the body stays up to L/k short, which moves the point by ~0.1 mm here
        assert (back[slipped, j] > 1e-3).all()
    assert (~np.isnan(back)).all()


def test_a_cycle_needs_every_cell() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    with pytest.raises(EodarmError, match="cycle=True"):
        reduce = {"op": "max", "dims": ["mass_kg"]}
        eodarm.sweep(arm, alpha_deg=GRID, mass_kg=[1.0], cycle=True, reduce=reduce)


def test_cli_cycle_writes_the_return_and_its_map(tmp_path: Path) -> None:
    import argparse

    import xarray as xr

    from eodarm.cli.sweep import add_parser

    parser = argparse.ArgumentParser(prog="eodarm")
    add_parser(parser.add_subparsers(dest="command"))
    out, plots = tmp_path / "cycle.nc", tmp_path / "maps"
    argv = ["sweep", "--arm", str(EXAMPLE), "--alpha1", "80:100:5", "--alpha2", "0:20:5"]
    argv += ["--alpha3", "0", "--mass", "1,6.5", "--add", "actuator_friction@M2=60"]
    argv += ["--cycle", "-o", str(out), "--plot", str(plots), "--no-progress"]
    args = parser.parse_args(argv)
    assert args.func(args) == 0
    with xr.open_dataset(out) as ds:
        assert ds["return_dy_mm"].attrs["units"] == "mm"
        assert float(np.abs(ds["return_dy_mm"].sel(mass_kg=6.5)).min()) > 1e-3
    assert (plots / "return_error.png").stat().st_size > 10_000


def test_a_centred_gap_stays_along_the_self_weight_at_the_return() -> None:
    """Without friction the return is the pose with no payload: a centred play closes along
    the self-weight's force and stays there, whatever payload the cycle went to."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    play = [eodarm.Effect("actuator_play", "M3", play_mm=0.1)]
    ds = eodarm.sweep(arm, alpha_deg=GRID, mass_kg=[1.0, 6.0], effects=play, cycle=True)
    poses = np.stack(np.meshgrid(*GRID.values(), indexing="ij"), axis=-1).reshape(-1, 3)
    rest = eodarm.solve(arm, poses, 0.0, play)
    back = ds["return_dy_mm"].values.reshape(-1, 2)
    for j in range(2):
        np.testing.assert_allclose(back[:, j], rest["dy_mm"], rtol=0, atol=1e-9)
    assert np.abs(back).min() > 1e-3
