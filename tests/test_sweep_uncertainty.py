"""A sweep's σ from the fitted covariance, and the compensated miss (issue 12 items 3–4)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import eodarm
from eodarm.analysis.compensate import STATUSES

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
HIDDEN = [
    eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1512.0),
    eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15),
]
GRID = {
    "alpha1": np.array([70.0, 90.0, 110.0]),
    "alpha2": np.array([0.0, 15.0]),
    "alpha3": np.array([-10.0, 0.0, 10.0]),
}
MASSES = [1.5, 6.5]


@pytest.fixture(scope="module")
def fitted() -> eodarm.Arm:
    """The example arm fitted to synthetic data with two hidden effects (16 poses × 3
    payloads): its [fit] table carries the covariance of both parameters."""
    from eodarm.analysis.fit import fit
    from eodarm.analysis.synth import random_configs, synth

    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = random_configs(arm, 16, np.random.default_rng(8))
    meas = synth(arm, alpha, [1.5, 5.0, 6.5], hidden=HIDDEN, seed=8)
    res = fit(arm, meas, ["mount_compliance@M2", "joint_clearance@O3"])
    from eodarm.analysis.handover import fitted_arm

    return fitted_arm(res, data="synthetic.csv")


def _poses() -> np.ndarray:
    return np.stack(np.meshgrid(*GRID.values(), indexing="ij"), -1).reshape(-1, 3)


def _draws(arm: eodarm.Arm, k: int, seed: int) -> list[list[eodarm.Effect]]:
    """k models drawn from the fit's covariance (normal parameters)."""
    assert arm.fit is not None
    keys = [p.split(":")[0] for p in arm.fit.parameters]
    mean = {e.key: e for e in arm.effects}
    rng = np.random.default_rng(seed)
    draws = rng.multivariate_normal([mean[k].value for k in keys], arm.fit.matrix(), k)
    return [[mean[q].with_value(v) for q, v in zip(keys, p, strict=True)] for p in draws]


def test_sweep_sigma_matches_monte_carlo_sampling_of_the_parameters(fitted: eodarm.Arm) -> None:
    """σ of every cell against 2000 models drawn from the covariance: within 10 % (the
    Monte-Carlo estimate of a σ itself scatters by 1/√(2·2000) ≈ 1.6 %)."""
    ds = eodarm.sweep(fitted, alpha_deg=GRID, mass_kg=MASSES, uncertainty=True)
    alpha = _poses()
    for mass in MASSES:
        got = ds.sel(mass_kg=mass)
        samples = {"dx_mm": [], "dy_mm": [], "dalpha_deg": []}
        for model in _draws(fitted, 2000, seed=1):
            out = eodarm.solve(fitted, alpha, mass, model)
            for key, acc in samples.items():
                acc.append(out[key])
        for key in ("dx_mm", "dy_mm"):
            mc = np.std(samples[key], axis=0)
            np.testing.assert_allclose(got[f"sigma_{key}"].values.reshape(-1), mc, rtol=0.10)
        mc = np.std(samples["dalpha_deg"], axis=0)
        big = mc > 1e-3 * mc.max()  # a link the parameters hardly move: relative noise
        pred = got["sigma_dalpha_deg"].values.reshape(-1, 3)
        np.testing.assert_allclose(pred[big], mc[big], rtol=0.10)


def test_a_lengths_grid_gives_the_sigma_of_solve_at_its_poses(fitted: eodarm.Arm) -> None:
    """The chunked path (a lengths grid) gives solve(uncertainty=True)'s σ at the grid's
    poses; the same propagation, so to round-off (1e-12 relative)."""
    lengths = {"l1": [320.0, 340.0], "l2": [480.0, 500.0], "l3": [520.0, 540.0]}
    ds = eodarm.sweep(fitted, lengths=lengths, mass_kg=[5.0], uncertainty=True)
    alpha = ds["alpha_deg"].values.reshape(-1, 3)
    want = eodarm.solve(fitted, alpha, 5.0, uncertainty=True)
    got = ds.isel(mass_kg=0)
    np.testing.assert_allclose(got["sigma_dy_mm"].values.reshape(-1), want["sigma_dy_mm"], 1e-12)
    np.testing.assert_allclose(
        got["sigma_dalpha_deg"].values.reshape(-1, 3), want["sigma_dalpha_deg"], 1e-12
    )


@pytest.mark.parametrize("op", ["min", "argmax"])
def test_a_reduced_sweep_gives_the_sigma_of_the_cell_the_reduction_chose(
    fitted: eodarm.Arm, op: str
) -> None:
    """σ of a reduced variable is the unreduced σ at the cell of its max/min (numpy's arg
    over the full result, the same cells: exact)."""
    full = eodarm.sweep(fitted, alpha_deg=GRID, mass_kg=MASSES, uncertainty=True)
    red = eodarm.sweep(
        fitted,
        alpha_deg=GRID,
        mass_kg=MASSES,
        uncertainty=True,
        reduce={"op": op, "dims": ["alpha3", "mass_kg"]},
    )
    dy = full["dy_mm"].values.reshape(3, 2, -1)
    sd = full["sigma_dy_mm"].values.reshape(3, 2, -1)
    pick = np.argmin(dy, axis=-1) if op == "min" else np.argmax(dy, axis=-1)
    want = np.take_along_axis(sd, pick[..., None], axis=-1)[..., 0]
    np.testing.assert_array_equal(red["sigma_dy_mm"].values, want)
    da = full["dalpha_deg"].values.reshape(3, 2, -1, 3)
    sa = full["sigma_dalpha_deg"].values.reshape(3, 2, -1, 3)
    pick = np.argmin(da, axis=2) if op == "min" else np.argmax(da, axis=2)
    want = np.take_along_axis(sa, pick[:, :, None, :], axis=2)[:, :, 0, :]
    np.testing.assert_array_equal(red["sigma_dalpha_deg"].values, want)
    assert "chose" in red["sigma_dy_mm"].attrs["long_name"]


def test_cells_that_are_not_solved_have_no_sigma(fitted: eodarm.Arm) -> None:
    grid = {"alpha1": [90.0], "alpha2": [10.0], "alpha3": np.linspace(-120, 120, 25)}
    ds = eodarm.sweep(
        fitted, alpha_deg=grid, mass_kg=[5.0], uncertainty=True, mask_unreachable=True
    )
    ok = ds["ok"].values
    assert (~ok).any() and ok.any()
    assert np.isnan(ds["sigma_dy_mm"].values[~ok]).all()
    assert np.isfinite(ds["sigma_dy_mm"].values[ok]).all()


def test_uncertainty_needs_a_fitted_arm_and_the_analytic_catalogue_model() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    with pytest.raises(eodarm.InputError, match=r"no fit.*eodarm fit .* -o") as info:
        eodarm.sweep(arm, alpha_deg=GRID, mass_kg=MASSES, uncertainty=True)
    assert "\n" not in str(info.value)
    with pytest.raises(eodarm.InputError, match="no fit"):
        eodarm.sweep(arm, alpha_deg=GRID, mass_kg=MASSES, compensated_miss=True)


def test_uncertainty_is_refused_for_the_fem_model(fitted: eodarm.Arm) -> None:
    with pytest.raises(eodarm.InputError, match="model='analytic'"):
        eodarm.sweep(fitted, alpha_deg=GRID, mass_kg=MASSES, uncertainty=True, model="fem")


# ---------------------------------------------------------------------------- compensated miss
def test_compensated_miss_is_twice_the_rms_miss_of_arms_drawn_from_the_fit(
    fitted: eodarm.Arm,
) -> None:
    """Compensate with the fitted model; arms drawn from the fit's covariance, commanded to
    those angles, miss the nominal point by δ; 2·√(mean |δ|²) over 2000 draws is the
    compensated miss within 10 %. The model's own residual is ≤ 1e-6 mm."""
    ds = eodarm.sweep(fitted, alpha_deg=GRID, mass_kg=[6.5], compensated_miss=True)
    cell = ds.isel(mass_kg=0)
    status = cell["compensation_status"].values.reshape(-1)
    assert (status == 0).all(), ds.attrs["compensation"]
    assert (cell["compensation_residual_mm"].values <= 1e-6).all()
    nominal = _poses()
    comp = eodarm.compensate(fitted, nominal, 6.5)  # the commanded angles
    target = eodarm.forward(fitted, nominal)["measure"]
    rigid = eodarm.forward(fitted, comp["alpha_deg"])["measure"]
    sq = []
    for model in _draws(fitted, 2000, seed=2):
        out = eodarm.solve(fitted, comp["alpha_deg"], 6.5, model)
        miss = rigid + np.column_stack([out["dx_mm"], out["dy_mm"]]) - target
        sq.append(np.sum(miss**2, axis=1))
    mc = 2.0 * np.sqrt(np.mean(sq, axis=0))
    np.testing.assert_allclose(cell["compensated_miss_mm"].values.reshape(-1), mc, rtol=0.10)
    # and it is far below the miss without compensation (the point of compensating)
    assert (cell["compensated_miss_mm"] < 0.05 * np.hypot(cell["dx_mm"], cell["dy_mm"])).all()


def test_cells_that_cannot_be_compensated_are_named_by_status(fitted: eodarm.Arm) -> None:
    """The status of every cell is compensate()'s; a cell not compensated has NaN miss."""
    # wide enough that some poses the model trusts (status ok) still cannot be compensated
    grid = {
        "alpha1": np.linspace(40, 140, 11),
        "alpha2": np.linspace(-60, 60, 9),
        "alpha3": np.linspace(-60, 60, 9),
    }
    ds = eodarm.sweep(fitted, alpha_deg=grid, mass_kg=[6.5], compensated_miss=True)
    alpha = np.stack(np.meshgrid(*grid.values(), indexing="ij"), -1).reshape(-1, 3)
    ok = ds["ok"].values.reshape(-1)
    with pytest.warns(eodarm.analysis.compensate.CompensationWarning):
        want = eodarm.compensate(fitted, alpha[ok], 6.5)
    codes = ds["compensation_status"].values.reshape(-1)
    names = np.array([*STATUSES, "not_solved"])[codes]
    assert names[ok].tolist() == want["status"].tolist()
    assert (names[~ok] == "not_solved").all()
    assert (names[ok] != "ok").any()  # the case the test is about occurs
    miss = ds["compensated_miss_mm"].values.reshape(-1)
    assert np.isnan(miss[names != "ok"]).all() and np.isfinite(miss[names == "ok"]).all()
    assert "ok" in ds.attrs["compensation"]


def test_the_uncertainty_maps_draw_a_fitted_sweep_and_refuse_a_plain_one(
    fitted: eodarm.Arm, tmp_path: Path
) -> None:
    from eodarm.errors import EodarmError
    from eodarm.viz import uncertainty_maps

    kw = {"alpha_deg": GRID, "mass_kg": MASSES}
    ds = eodarm.sweep(fitted, **kw, uncertainty=True, compensated_miss=True)
    fig = uncertainty_maps.sag_uncertainty_map(ds, 6.5, path=tmp_path / "s.png")
    assert (tmp_path / "s.png").stat().st_size > 10_000
    titles = [ax.get_title() for ax in fig.axes]
    assert any("2σ" in t for t in titles)
    uncertainty_maps.compensated_miss_map(ds, 6.5, path=tmp_path / "c.png")
    assert (tmp_path / "c.png").stat().st_size > 10_000
    plain = eodarm.sweep(fitted, **kw)
    with pytest.raises(EodarmError, match="uncertainty=True"):
        uncertainty_maps.sag_uncertainty_map(plain)


def test_the_command_line_writes_sigma_and_the_compensated_miss(
    fitted: eodarm.Arm, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import xarray as xr

    from eodarm.cli import main

    (tmp_path / "fitted.toml").write_text(fitted.to_toml())
    args = ["sweep", "--arm", str(tmp_path / "fitted.toml"), "--alpha1", "70:110:3"]
    args += ["--alpha2", "0,15", "--alpha3", "-10:10:3", "--mass", "1.5,6.5", "--no-progress"]
    out = tmp_path / "s.nc"
    assert main([*args, "--uncertainty", "--compensated-miss", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "2σ of dy" in text and "compensation of the cells: ok 36" in text
    back = xr.load_dataset(out)
    want = eodarm.sweep(fitted, alpha_deg=GRID, mass_kg=MASSES, compensated_miss=True)
    np.testing.assert_array_equal(back["compensation_status"], want["compensation_status"])
    assert "sigma_dalpha_deg" in back
    # a Zarr sweep is written chunk by chunk: these outputs are refused in one line
    assert main([*args, "--uncertainty", "-o", str(tmp_path / "s.zarr")]) == 2
    assert "computed in memory" in capsys.readouterr().err
