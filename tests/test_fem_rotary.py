"""The finite-element model on arms with rotary drives (docs/fem.md): each drive a torsional
spring between its housing (body i−1) and its flange (link i, clamped to it), through the
public API and the command line. It must agree with the analytic model at second order on the
bundled rotary and mixed arms and on random mixed arms, give the analytic statics' torques,
stay linear and reciprocal, recover hidden drive effects in a fit, draw its figures, and run
``solve``/``compare``/``fit``/``diagnose`` with ``--model fem`` on both example arms."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.analysis.fit import compare, fit
from eodarm.cli import main
from eodarm.data.measurements import Measurements
from eodarm.viz import fem_plots
from strategies import ELASTIC, effects_for, measuring_at_load_point, mixed_arm_and_poses

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
ROTARY = EXAMPLES / "rotary_arm.toml"
MIXED = EXAMPLES / "mixed_arm.toml"
ROTARY_POSES = [[45.0, 10.0, -20.0], [80.0, 30.0, 0.0], [20.0, -15.0, -40.0]]
MIXED_POSES = [[60.0, -10.0, -60.0], [40.0, -30.0, -80.0], [75.0, 5.0, -40.0]]
GROUPS = (("dx_mm", "dy_mm"), ("dalpha_deg",), ("dl_mm",), ("dlength_mm",))


def _rel(fe: dict, an: dict) -> float:
    """Largest relative difference over the channel groups dx/dy, dα, dl, dℓ (the channels
    that exist: NaN at the same places in both)."""
    worst = 0.0
    for keys in GROUPS:
        rows = len(an["dx_mm"])
        a = np.column_stack([np.asarray(an[k]).reshape(rows, -1) for k in keys])
        f = np.column_stack([np.asarray(fe[k]).reshape(rows, -1) for k in keys])
        np.testing.assert_array_equal(np.isnan(f), np.isnan(a))
        if np.isnan(a).all():
            continue
        worst = max(worst, float(np.nanmax(np.abs(f - a)) / np.nanmax(np.abs(a))))
    return worst


def _file_bending(arm: eodarm.Arm) -> list[eodarm.Effect]:
    """The arm file's link sections, which only the FE model reads, as link_bending: the same
    physics in both models."""
    return [
        eodarm.Effect("link_bending", f"L{i + 1}", ei_n_mm2=lk.ei_n_mm2)
        for i, lk in enumerate(arm.links)
        if lk.ei_n_mm2 is not None
    ]


@pytest.mark.parametrize(
    ("path", "poses", "mass", "effects"),
    [
        (ROTARY, ROTARY_POSES, 5.0, []),
        (
            ROTARY,
            ROTARY_POSES,
            5.0,
            [
                eodarm.Effect("drive_compliance", "O2", stiffness_nmm_per_rad=6e6),
                eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=4e8),
            ],
        ),
        (MIXED, MIXED_POSES, 20.0, []),
        (
            MIXED,
            MIXED_POSES,
            20.0,
            [
                eodarm.Effect("drive_compliance", "O1", stiffness_nmm_per_rad=3e7),
                eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=6000.0),
                eodarm.Effect("link_bending", "L1", ei_n_mm2=2e10),
                eodarm.Effect("link_bending", "L2", ei_n_mm2=8e9),
            ],
        ),
    ],
)
def test_example_arms_agree_with_the_analytic_model_at_second_order(path, poses, mass, effects):
    """The linear FE solve and the exact pose differ in proportion to the load; the torques,
    forces and pin forces are the same statics; NaN where a drive has no such output."""
    arm = eodarm.Arm.from_toml(path)
    effects = [*effects, *_file_bending(arm)]
    rel = []
    for s in (1.0, 0.1, 0.01, 0.001):
        an = eodarm.solve(arm, poses, mass * s, effects=effects)
        fe = eodarm.solve(arm, poses, mass * s, effects=effects, model="fem")
        for key in ("torque_nmm", "dtorque_nmm", "force_n", "dforce_n", "length_mm"):
            np.testing.assert_allclose(fe[key], an[key], rtol=1e-9, err_msg=key)
        np.testing.assert_allclose(fe["reaction_n"], an["reaction_n"], rtol=1e-9, atol=1e-9)
        rotary = np.array(arm.kinds) == "rotary"
        assert np.isnan(fe["force_n"][:, rotary]).all()
        assert np.isnan(fe["torque_nmm"][:, ~rotary]).all()
        assert np.isnan(fe["pin_force_n"][:, arm.n :][:, rotary]).all()
        rel.append(_rel(fe, an))
    assert rel[-1] < 1e-5, rel
    for big, small in itertools.pairwise(rel):
        assert 6.0 < big / small < 16.0, rel


def test_backlash_and_clearance_at_drives_agree_when_scaled_with_the_load():
    """Gaps closed on the side of the loaded torque and pin force, as the analytic model."""
    arm = eodarm.Arm.from_toml(MIXED)
    rel = []
    for s in (1.0, 0.1, 0.01):
        effects = [
            eodarm.Effect("drive_backlash", "O1", backlash_deg=0.05 * s),
            eodarm.Effect("joint_clearance", "O1", clearance_mm=0.1 * s),
            eodarm.Effect("actuator_play", "M3", play_mm=0.05 * s),
            *_file_bending(arm),
        ]
        an = eodarm.solve(arm, MIXED_POSES, 20.0 * s, effects=effects)
        fe = eodarm.solve(arm, MIXED_POSES, 20.0 * s, effects=effects, model="fem")
        rel.append(_rel(fe, an))
    assert rel[-1] < 1e-4, rel
    assert rel[0] / rel[1] > 6.0 and rel[1] / rel[2] > 6.0, rel


@settings(max_examples=40, deadline=None)
@given(case=mixed_arm_and_poses(max_links=5, max_poses=3), data=st.data())
def test_random_mixed_arms_agree_with_the_analytic_model_at_small_load(case, data):
    """On random arms with any mix of drives and elastic effects, at 1/1000 of the payload:
    the same statics (torques and forces) and deflections within 1e-4, or, on a long soft arm
    beyond it, a difference that falls with the load (second order)."""
    arm, alpha, mass = case
    effects = [*data.draw(effects_for(arm, ELASTIC), label="effects")]
    bent = {e.at for e in effects if e.name == "link_bending"}
    same = effects + [e for e in _file_bending(arm) if e.at not in bent]
    small = mass * 1e-3
    fe = eodarm.solve(arm, alpha, small, effects=effects, model="fem")
    an = eodarm.solve(arm, alpha, small, effects=same)
    # Loads recovered from spring deformations (k·Δu) keep ~eps·κ of round-off of the loads
    # the springs carry (the random arms mix stiff sections with soft springs), so the
    # tolerance is set by the arm's largest load, not by the key's own largest value: a drive
    # that carries nothing in the statics comes back from the FE springs as round-off of the
    # joint reactions (hypothesis found 1.5e-8 N·mm where every drive torque is zero and the
    # pins carry newtons). 1e-5 of the largest pin reaction (N), and of it times the arm's
    # reach (N·mm), still catches any wrong statics, which miss by a whole load.
    pin = float(np.nanmax(np.abs(an["reaction_n"]), initial=0.0))
    reach = float(np.linalg.norm(np.asarray(arm.arrays()["next"]), axis=1).sum())
    for key, load in (("force_n", pin), ("torque_nmm", pin * reach)):
        scale = max(float(np.nanmax(np.abs(an[key]), initial=0.0)), load)
        # + 1e-9 (N, N·mm): an arm with no load at all (1e-9 is a thousandth of the core's own
        # "no torque" threshold, 1e-6 N·mm).
        np.testing.assert_allclose(fe[key], an[key], rtol=1e-6, atol=1e-5 * scale + 1e-9)
    if np.abs(np.column_stack([an["dx_mm"], an["dy_mm"]])).max() > 1e-7:
        rel = _rel(fe, an)
        if rel >= 1e-4:
            fe = eodarm.solve(arm, alpha, small / 10, effects=effects, model="fem")
            an = eodarm.solve(arm, alpha, small / 10, effects=same)
            assert _rel(fe, an) < rel / 6, rel


@settings(max_examples=30, deadline=None)
@given(case=mixed_arm_and_poses(max_links=5, max_poses=3), data=st.data())
def test_the_fem_of_mixed_arms_is_linear_and_reciprocal(case, data):
    """Twice the payload, twice every response; Maxwell–Betti at the load point (K, torsional
    springs included, is symmetric)."""
    arm, alpha, _ = case
    arm = measuring_at_load_point(arm)
    effects = data.draw(effects_for(arm, ELASTIC), label="effects")
    rows = alpha.shape[0]

    def run(p: list[float]) -> dict:
        pay = np.tile(np.asarray(p, dtype=float), (rows, 1))
        return eodarm.solve_payload(arm, alpha, pay, effects, self_weight=False, model="fem")

    one, two = run([3.0, -7.0]), run([6.0, -14.0])
    for key in ("dx_mm", "dy_mm", "dalpha_deg", "dtorque_nmm"):
        np.testing.assert_allclose(two[key], 2.0 * one[key], rtol=1e-9, atol=1e-12)
    h, v = run([1.0, 0.0]), run([0.0, 1.0])
    c = max(np.abs(h["dx_mm"]).max(), np.abs(v["dy_mm"]).max())
    np.testing.assert_allclose(h["dy_mm"], v["dx_mm"], rtol=0, atol=1e-9 * c)


def _fem_truth(arm, alpha, masses, hidden, sigma=1e-4, seed=5) -> Measurements:
    """Synthetic measurements whose truth is the FE model: dx, dy, every dα and the linear
    actuators' dl (a drive has none)."""
    rows_alpha = np.repeat(np.asarray(alpha, dtype=float), len(masses), axis=0)
    rows_mass = np.tile(np.asarray(masses, dtype=float), len(alpha))
    out = eodarm.solve(arm, rows_alpha, rows_mass, effects=hidden, model="fem")
    cols = {"dx_mm": out["dx_mm"], "dy_mm": out["dy_mm"]}
    for i in range(arm.n):
        cols[f"dalpha{i + 1}_deg"] = out["dalpha_deg"][:, i]
        if arm.is_linear(i):
            cols[f"dl{i + 1}_mm"] = out["dl_mm"][:, i]
    rng = np.random.default_rng(seed)
    return Measurements.from_arrays(
        config=np.repeat([f"c{k}" for k in range(len(alpha))], len(masses)),
        alpha_deg=rows_alpha,
        mass_kg=rows_mass,
        values={c: v + sigma * rng.standard_normal(len(v)) for c, v in cols.items()},
        sigma={c: np.full(len(rows_mass), sigma) for c in cols},
        source="<fem synth>",
    )


@pytest.mark.parametrize(
    ("path", "poses", "masses", "hidden"),
    [
        (
            ROTARY,
            ROTARY_POSES,
            [1.0, 3.0, 5.0],
            [
                eodarm.Effect("drive_compliance", "O2", stiffness_nmm_per_rad=8e6),
                eodarm.Effect("drive_backlash", "O3", backlash_deg=0.05),
            ],
        ),
        (
            MIXED,
            MIXED_POSES,
            [5.0, 20.0, 40.0],
            [
                eodarm.Effect("drive_backlash", "O1", backlash_deg=0.04),
                eodarm.Effect("joint_clearance", "O2", clearance_mm=0.1),
            ],
        ),
    ],
)
def test_fem_fit_recovers_hidden_drive_effects(path, poses, masses, hidden):
    arm = eodarm.Arm.from_toml(path)
    meas = _fem_truth(arm, poses, masses, hidden)
    res = fit(arm, meas, [e.key for e in hidden], model="fem")
    for j, e in enumerate(hidden):
        assert res.estimate(j) == pytest.approx(e.value, rel=1e-2), e.key
    assert res.chi2_per_dof < 2.0
    assert compare(arm, meas, [], model="fem").chi2_per_dof > 100 * res.chi2_per_dof


def test_fem_plots_draw_rotary_drives(tmp_path: Path):
    for path, poses in ((ROTARY, ROTARY_POSES), (MIXED, MIXED_POSES)):
        arm = eodarm.Arm.from_toml(path)
        out = eodarm.solve(arm, poses, 5.0, model="fem")
        # No actuator segment or pin A at a drive.
        kinds = np.array(arm.kinds)
        assert int((out["segment_kind"] == 2).sum()) == int((kinds == "linear").sum())
        assert int((out["node_kind"][:, 0] == 5).sum()) == int((kinds == "linear").sum())
        for draw in (fem_plots.deformed_shape, fem_plots.moment_diagrams, fem_plots.pin_forces):
            png = tmp_path / f"{path.stem}-{draw.__name__}.png"
            draw(arm, out, row=1, path=png)
            assert png.stat().st_size > 10_000


def test_refusals_name_the_effect_at_the_drive():
    arm = eodarm.Arm.from_toml(ROTARY)
    for effect, name in (
        (eodarm.Effect("drive_friction", "O2", torque_nmm=500.0), "drive_friction@O2"),
        (
            eodarm.Effect("drive_backlash", "O3", backlash_deg=0.1, unloaded="taken_up"),
            "drive_backlash@O3",
        ),
    ):
        with pytest.raises(ValueError, match=name) as err:
            eodarm.solve(arm, ROTARY_POSES, 2.0, effects=[effect], model="fem")
        assert "\n" not in str(err.value) and len(str(err.value)) < 300


@pytest.mark.parametrize(
    ("path", "alpha", "hidden"),
    [
        (ROTARY, "45,10,-20", eodarm.Effect("drive_compliance", "O2", stiffness_nmm_per_rad=6e6)),
        (MIXED, "60,-10,-60", eodarm.Effect("drive_backlash", "O1", backlash_deg=0.05)),
    ],
)
def test_cli_solve_compare_fit_diagnose_with_the_fem_on_drives(
    path: Path,
    alpha: str,
    hidden: eodarm.Effect,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    arm = eodarm.Arm.from_toml(path)
    args = ["--arm", str(path), "--alpha", alpha, "--mass", "3", "--json"]
    assert main(["solve", *args, "--model", "fem"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["solver_model"] == "fem"
    pose = doc["poses"][0]
    api = eodarm.solve(arm, [[float(a) for a in alpha.split(",")]], 3.0, model="fem")
    assert pose["dy_mm"] == pytest.approx(float(api["dy_mm"][0]), rel=1e-12)
    assert pose["force_n"][0] is None  # joint 1 is a drive on both arms
    poses = ROTARY_POSES if path == ROTARY else MIXED_POSES
    meas = _fem_truth(arm, poses, [2.0, 6.0], [hidden])
    csv = tmp_path / "m.csv"
    meas.to_csv(csv)
    common = [str(csv), "--arm", str(path), "--model", "fem", "--json"]
    assert main(["compare", *common]) == 0
    before = json.loads(capsys.readouterr().out)
    assert before["solver_model"] == "fem" and before["chi2_per_dof"] > 100
    assert main(["fit", *common, "--add", hidden.key]) == 0
    est = json.loads(capsys.readouterr().out)["effects"][0]["estimate"]
    assert est[hidden.param] == pytest.approx(hidden.value, rel=1e-2)
    assert main(["diagnose", *common]) == 0
    assert json.loads(capsys.readouterr().out)["suggested"] == [hidden.key]
