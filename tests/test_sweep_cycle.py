"""``sweep(..., cycle=True)``: where each cell's measure point sits after reference → payload
→ 0 (docs/model.md §9)."""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
import pytest

import eodarm
from arms import example_arm, four_link_core_arm, two_link_arm
from eodarm.errors import EodarmError
from eodarm.model import custom
from eodarm.model.solver import statics
from eodarm.model.validity import STATUS

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
GRID = {"alpha1": [80.0, 90.0, 100.0], "alpha2": [0.0, 15.0], "alpha3": [0.0, 5.0]}
RETURNS = ("return_dx_mm", "return_dy_mm")


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


# ---------------------------------------------------------------------------- gaps alone
def _limited_two_link() -> eodarm.Arm:
    """The two-link arm with actuator 1 limited to 500 N: at alpha1 = 120° its self-weight
    force (≈ 510 N at alpha2 = −40°) is over the limit and a 5 kg payload brings it back
    under, so a cell there is ok while the same pose with no payload is not."""
    d = two_link_arm().to_dict()
    d["actuator"][0]["max_force_n"] = 500.0
    return eodarm.Arm.from_dict(d, source="two-link, limited")


def _press(r: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(r, axis=-1, keepdims=True)
    return np.where(norm >= 1e-9, -r / np.where(norm > 0, norm, 1.0), 0.0)


def _user_clearance(state: eodarm.EffectState, i: int, c: float) -> dict:
    """A centred joint clearance written by a user: the pin sits c along the reaction."""
    return {"joint_offset_mm": c * _press(state.reaction_n[:, i])}


GAP_CASES = {
    "3 links, play": (
        example_arm,
        {
            "alpha_deg": {
                "alpha1": [80.0, 110.0, 135.0],
                "alpha2": [-30.0, 15.0],
                "alpha3": [0.0, 5.0],
            }
        },
        [("actuator_play", "M2", {"play_mm": 0.05})],
    ),
    "3 links, both gaps and a compliance": (
        example_arm,
        {
            "alpha_deg": {
                "alpha1": [80.0, 110.0, 135.0],
                "alpha2": [-30.0, 15.0],
                "alpha3": [0.0, 5.0],
            }
        },
        [
            ("joint_clearance", "O2", {"clearance_mm": 0.1}),
            ("actuator_play", "M3", {"play_mm": 0.1}),
            ("mount_compliance", "M1", {"stiffness_n_per_mm": 3000.0}),
        ],
    ),
    "3 links, lengths grid": (
        example_arm,
        {"lengths": {"l1": [240.0, 300.0, 360.0], "l2": [450.0, 480.0], "l3": [535.0]}},
        [
            ("joint_clearance", "O3", {"clearance_mm": 0.1}),
            ("actuator_play", "M1", {"play_mm": 0.05}),
        ],
    ),
    "2 links, clearance and compliance": (
        _limited_two_link,
        {"alpha_deg": {"alpha1": [60.0, 90.0, 120.0], "alpha2": [-40.0, 0.0, 30.0]}},
        [
            ("joint_clearance", "O1", {"clearance_mm": 0.08}),
            ("actuator_compliance", "M2", {"stiffness_n_per_mm": 2000.0}),
        ],
    ),
    "4 links, play, clearance and bending": (
        four_link_core_arm,
        {
            "alpha_deg": {
                "alpha1": [70.0, 100.0],
                "alpha2": [-20.0, 10.0],
                "alpha3": [-10.0, 0.0],
                "alpha4": [0.0, 10.0],
            }
        },
        [
            ("actuator_play", "M4", {"play_mm": 0.05}),
            ("joint_clearance", "O3", {"clearance_mm": 0.1}),
            ("link_bending", "L2", {"ei_n_mm2": 2e9}),
        ],
    ),
    "3 links, a user-written clearance and a play": (
        example_arm,
        {"alpha_deg": {"alpha1": [80.0, 110.0, 135.0], "alpha2": [-30.0, 15.0], "alpha3": [0.0]}},
        [
            ("user_clearance", "O2", {"clearance_mm": 0.1}),
            ("actuator_play", "M2", {"play_mm": 0.05}),
        ],
    ),
}


@pytest.mark.parametrize("case", list(GAP_CASES))
def test_a_gap_cycle_is_each_cell_loaded_then_unloaded(case: str) -> None:
    """Without friction a sweep's return is found without solving each cell's cycle (the
    pose at no payload, docs/sweeps.md); it must still be that cycle, reference → m → 0,
    solved: for every cell that is ok, NaN for the others. 1e-9 mm: the sweep's kernel and
    the sequence kernel close the pose by separate iterations, which agree to ~1e-10 mm
    (tests/test_sweep.py holds the sweep to solve by the same 1e-9 mm)."""
    make, grid, specs = GAP_CASES[case]
    arm = make()
    mass = [1.5, 5.0, 20.0]
    with contextlib.ExitStack() as stack:
        if any(name == "user_clearance" for name, _, _ in specs):
            eodarm.custom_effect("user_clearance", places="O", parameter="clearance_mm")(
                _user_clearance
            )
            stack.callback(custom.unregister, "user_clearance")
        effects = [eodarm.Effect(name, place, **kw) for name, place, kw in specs]
        ds = eodarm.sweep(arm, **grid, mass_kg=mass, effects=effects, cycle=True, progress=False)
        n, dims = arm.n, [d for d in ds["ok"].dims if d != "mass_kg"]
        if "alpha_deg" in ds:
            poses = ds["alpha_deg"].transpose(*dims, "link").values.reshape(-1, n)
        else:
            poses = np.stack(np.meshgrid(*grid["alpha_deg"].values(), indexing="ij"), -1)
            poses = poses.reshape(-1, n)
        ok = ds["ok"].transpose(*dims, "mass_kg").values.reshape(-1, len(mass))
        assert ok.any() and not ok.all()  # the grid has cells of both kinds
        got = {k: ds[k].transpose(*dims, "mass_kg").values.reshape(ok.shape) for k in RETURNS}
        for j, m in enumerate(mass):
            rows = ok[:, j]
            seq = eodarm.solve_sequence(arm, poses[rows], [m, 0.0], effects=effects)
            for key, out in got.items():
                np.testing.assert_allclose(
                    out[rows, j], seq[key[len("return_") :]][:, 1], rtol=0, atol=1e-9, err_msg=key
                )
                assert np.isnan(out[~rows, j]).all(), key
    assert np.hypot(got["return_dx_mm"], got["return_dy_mm"])[ok].max() > 1e-3  # a gap moved it


def test_a_return_is_solved_where_only_the_unloaded_pose_is_over_a_limit() -> None:
    """The return of a cell is defined by its cycle, not by the validity of the pose at no
    payload: where the self-weight alone is over an actuator's force limit but the loaded
    cell is ok, the return is still given (solved as a sequence)."""
    arm = _limited_two_link()
    grid = {"alpha1": [120.0], "alpha2": [-40.0]}
    play = [eodarm.Effect("actuator_play", "M2", play_mm=0.05)]
    rest = eodarm.sweep(arm, alpha_deg=grid, mass_kg=[0.0], effects=play, progress=False)
    assert STATUS[int(rest["status"].values.ravel()[0])] == "over_force"
    ds = eodarm.sweep(arm, alpha_deg=grid, mass_kg=[5.0], effects=play, cycle=True)
    assert bool(ds["ok"].values.ravel()[0])
    seq = eodarm.solve_sequence(arm, [[120.0, -40.0]], [5.0, 0.0], effects=play)
    np.testing.assert_allclose(
        ds["return_dy_mm"].values.ravel(), seq["dy_mm"][:, 1], rtol=0, atol=1e-9
    )


def _slack_at_rest(state: eodarm.EffectState, i: int, slack_mm: float) -> dict:
    """A user effect that lengthens a compressed actuator by ``slack_mm`` when its force is
    back at the reference's, and does nothing under load: the return cannot close."""
    rest = np.abs(state.force_n[:, i] - state.force0_n[:, i]) < 1e-6
    return {"actuator_unseen_mm": np.where(rest & (state.force0_n[:, i] > 0), slack_mm, 0.0)}


def test_a_user_effect_whose_return_cannot_close_gives_nan_there() -> None:
    """With a user-written effect the cycles are solved by the numpy reference, which raises
    on a pose it cannot close: the sweep gives NaN for those cells (as for any cell whose
    cycle cannot be solved) and the return everywhere else, instead of failing."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    grid = {"alpha1": [80.0, 100.0, 120.0], "alpha2": [-30.0, 0.0, 15.0, 40.0], "alpha3": [0.0]}
    eodarm.custom_effect("slack_at_rest", places="M", parameter="slack_mm")(_slack_at_rest)
    try:
        effects = [eodarm.Effect("slack_at_rest", "M2", slack_mm=5000.0)]
        ds = eodarm.sweep(arm, alpha_deg=grid, mass_kg=[1.5, 6.5], effects=effects, cycle=True)
    finally:
        custom.unregister("slack_at_rest")
    poses = np.stack(np.meshgrid(*grid.values(), indexing="ij"), -1).reshape(-1, 3)
    pushed = statics(arm, poses, np.zeros(len(poses)))["force0_n"][:, 1] > 0
    ok = ds["ok"].values.reshape(-1, 2)
    back = ds["return_dy_mm"].values.reshape(-1, 2)
    assert ok[pushed].any() and ok[~pushed].any()
    assert np.isnan(back[ok & pushed[:, None]]).all()  # 5 m longer: the triangle cannot close
    assert np.isfinite(back[ok & ~pushed[:, None]]).all()
