"""The finite-element model behind the public API: ``model="fem"`` in solve, fit, compare,
diagnose and the CLI. It must agree with the analytic model at second order, recover hidden
effects, draw its figures, and refuse bad input clearly."""

from __future__ import annotations

import itertools
import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from arms import example_arm, seed_like_arm, two_link_arm
from eodarm.analysis.crossval import cross_validate
from eodarm.analysis.fit import FitWarning, compare, fit
from eodarm.analysis.synth import synth
from eodarm.cli import main
from eodarm.data import datasets
from eodarm.data.measurements import Measurements, channel_names
from eodarm.viz import fem_plots, plots
from strategies import (
    ELASTIC,
    arm_and_poses,
    effects_for,
    measuring_at_load_point,
    payload_vectors,
)

SEED_POSES = [[115.6, 15.4, 0.2], [104.7, 15.7, 0.0], [89.9, 5.6, 0.1]]
EXAMPLE_POSES = [[90.0, 10.0, 0.0], [70.0, 25.0, -8.0]]
KEYS = {"force_n", "reaction_n", "dforce_n", "dx_mm", "dy_mm"}
KEYS |= {"dalpha_deg", "dl_mm", "dlength_mm", "length_mm"}


def _seed() -> eodarm.Arm:
    return datasets.load("seed2022").arm


def _with_sections(arm: eodarm.Arm, ei: float = 7.1e9, ea: float | None = 3.1e7) -> eodarm.Arm:
    d = arm.to_dict()
    for link in d["link"]:
        link["ei_n_mm2"] = ei
        if ea is not None:
            link["ea_n"] = ea
    return eodarm.Arm.from_dict(d)


def _rel(fe: dict, an: dict) -> float:
    """Largest relative difference over the channel groups dx/dy, dα, dl, dℓ."""
    worst = 0.0
    for keys in (("dx_mm", "dy_mm"), ("dalpha_deg",), ("dl_mm",), ("dlength_mm",)):
        a = np.column_stack([np.asarray(an[k]).reshape(len(an["dx_mm"]), -1) for k in keys])
        f = np.column_stack([np.asarray(fe[k]).reshape(len(fe["dx_mm"]), -1) for k in keys])
        worst = max(worst, float(np.max(np.abs(f - a)) / np.max(np.abs(a))))
    return worst


@pytest.mark.parametrize(
    ("arm", "poses", "effects"),
    [
        (_seed(), SEED_POSES, []),
        (
            example_arm(),
            EXAMPLE_POSES,
            [
                eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1500.0),
                eodarm.Effect("link_bending", "L2", ei_n_mm2=3e9),
                eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=4e8),
            ],
        ),
        (two_link_arm(), [[60.0, 5.0], [80.0, -10.0]], []),
    ],
)
def test_fem_and_analytic_agree_at_second_order(arm, poses, effects):
    """The linear FE solve and the exact pose differ in proportion to the load."""
    rel = []
    for mass in (5.0, 0.5, 0.05, 0.005):
        an = eodarm.solve(arm, poses, mass, effects=effects)
        fe = eodarm.solve(arm, poses, mass, effects=effects, model="fem")
        assert KEYS <= set(fe)
        np.testing.assert_allclose(fe["force_n"], an["force_n"], rtol=1e-9)
        np.testing.assert_allclose(fe["reaction_n"], an["reaction_n"], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(fe["length_mm"], an["length_mm"], rtol=1e-12)
        rel.append(_rel(fe, an))
    assert rel[-1] < 1e-4, rel
    for big, small in itertools.pairwise(rel):
        assert 6.0 < big / small < 16.0, rel


def _same_physics(arm: eodarm.Arm, effects: list[eodarm.Effect]) -> list[eodarm.Effect]:
    """The analytic model's effects for the FE model's physics: the arm file's link sections
    (which only the FE model reads) as link_bending, unless one is given."""
    bent = {e.at for e in effects if e.name == "link_bending"}
    extra = [
        eodarm.Effect("link_bending", f"L{i + 1}", ei_n_mm2=lk.ei_n_mm2)
        for i, lk in enumerate(arm.links)
        if lk.ei_n_mm2 is not None and f"L{i + 1}" not in bent
    ]
    return [*effects, *extra]


@settings(max_examples=60, deadline=None)
@given(case=arm_and_poses(max_poses=4), self_weight=st.booleans(), data=st.data())
def test_random_arms_agree_with_the_analytic_model_at_small_load(case, self_weight, data):
    """On random plausible arms, poses, payload directions and elastic effects: at 1/1000 of
    the payload the linear FE solve and the exact pose agree to 1e-4, and where a long soft
    arm exceeds that, the difference falls with the load (it is second order)."""
    arm, alpha, _ = case
    payload = data.draw(payload_vectors(alpha.shape[0], g=arm.g), label="payload") * 1e-3
    effects = data.draw(effects_for(arm, ELASTIC), label="effects")
    fe = eodarm.solve_payload(arm, alpha, payload, effects, self_weight=self_weight, model="fem")
    an = eodarm.solve_payload(
        arm, alpha, payload, _same_physics(arm, effects), self_weight=self_weight
    )
    # The same statics; the FE forces come from displacements (k·Δu), with their round-off:
    # the random arms mix near-rigid parts (1e18) with springs, and a force recovered from the
    # difference of two pin displacements keeps ~eps·κ of it. Seen: 1.8e-6 of the largest
    # force on a pose whose forces are 5 mN; 1e-5 of it still catches any wrong statics.
    fmax = float(np.abs(an["force_n"]).max())
    np.testing.assert_allclose(fe["force_n"], an["force_n"], rtol=1e-6, atol=1e-5 * fmax + 1e-12)
    # The exact pose subtracts coordinates of ~100 mm: below 1e-7 mm of deflection its
    # round-off (~1e-14 mm) is what differs.
    if np.abs(np.column_stack([an["dx_mm"], an["dy_mm"]])).max() > 1e-7:
        rel = _rel(fe, an)
        if rel >= 1e-4:
            # A long, soft arm (seen: a 558 mm link on a 40 mm actuator lever, EI 5e8 N·mm²,
            # 1.0017e-4): the difference must still be second order, falling with the load.
            small = payload / 10
            fe = eodarm.solve_payload(
                arm, alpha, small, effects, self_weight=self_weight, model="fem"
            )
            an = eodarm.solve_payload(
                arm, alpha, small, _same_physics(arm, effects), self_weight=self_weight
            )
            assert _rel(fe, an) < rel / 6, rel


@settings(max_examples=60, deadline=None)
@given(case=arm_and_poses(max_poses=4), data=st.data())
def test_the_fem_is_linear_and_reciprocal(case, data):
    """Twice the payload, twice every elastic response; and Maxwell–Betti: the load point's
    horizontal displacement under a vertical unit load equals its vertical displacement under
    a horizontal one (K is symmetric)."""
    arm, alpha, _ = case
    arm = measuring_at_load_point(arm)
    effects = data.draw(effects_for(arm, ELASTIC), label="effects")
    rows = alpha.shape[0]

    def run(p: list[float]) -> dict:
        pay = np.tile(np.asarray(p, dtype=float), (rows, 1))
        return eodarm.solve_payload(arm, alpha, pay, effects, self_weight=False, model="fem")

    one, two = run([3.0, -7.0]), run([6.0, -14.0])
    for key in ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm"):
        np.testing.assert_allclose(two[key], 2.0 * one[key], rtol=1e-9, atol=1e-12)
    h, v = run([1.0, 0.0]), run([0.0, 1.0])
    c = max(np.abs(h["dx_mm"]).max(), np.abs(v["dy_mm"]).max())
    np.testing.assert_allclose(h["dy_mm"], v["dx_mm"], rtol=0, atol=1e-9 * c)


def test_gaps_agree_when_scaled_with_the_load():
    arm = seed_like_arm()
    rel = []
    for s in (1.0, 0.1, 0.01):
        effects = [
            eodarm.Effect("joint_clearance", "O2", clearance_mm=0.15 * s),
            eodarm.Effect("actuator_play", "M3", play_mm=0.05 * s),
        ]
        an = eodarm.solve(arm, [[100.0, 10.0, 0.0]], 5.0 * s, effects=effects)
        fe = eodarm.solve(arm, [[100.0, 10.0, 0.0]], 5.0 * s, effects=effects, model="fem")
        rel.append(_rel(fe, an))
    assert rel[-1] < 1e-4 and 6 < rel[0] / rel[1] < 16 and 6 < rel[1] / rel[2] < 16, rel


def test_fem_extras_have_their_shapes_and_meanings():
    arm = _with_sections(_seed())
    out = eodarm.solve(
        arm,
        SEED_POSES,
        1.5,
        model="fem",
        fem_options={"elements_per_link": 6, "moment_samples": 21},
    )
    n, rows = arm.n, len(SEED_POSES)
    assert out["pin_force_n"].shape == (rows, 2 * n, 2)
    np.testing.assert_allclose(out["pin_force_n"][:, :n], out["reaction_n"], rtol=1e-12)
    assert out["moment_nmm"].shape == (rows, n, 21) == out["dmoment_nmm"].shape
    assert out["moment_x_mm"].shape == (n, 21)
    nodes = out["node_xy"].shape[1]
    assert out["node_disp"].shape == (rows, nodes, 2)
    assert out["segments"].max() < nodes and out["segment_kind"].shape == (len(out["segments"]),)
    assert out["n_dof"] > 3 * 3 * 6
    # At a link's far end only the couple of a load sitting off the axis remains (the seed's
    # load point is 0.81 mm below link 3's axis): next to nothing.
    tip = np.abs(out["moment_nmm"][:, :, -1])
    assert np.all(tip < 1e-3 * np.abs(out["moment_nmm"]).max())
    # The actuator pin forces are the actuators' forces along their lines.
    geo = eodarm.forward(arm, SEED_POSES)
    e = (geo["A"] - geo["B"]) / geo["length_mm"][..., None]
    np.testing.assert_allclose(out["pin_force_n"][:, n:], out["force_n"][..., None] * e, atol=1e-9)


def test_mesh_density_changes_the_dofs_not_the_answer():
    arm = _with_sections(example_arm())
    coarse = eodarm.solve(
        arm, EXAMPLE_POSES, 4.0, model="fem", fem_options={"elements_per_link": 2}
    )
    fine = eodarm.solve(arm, EXAMPLE_POSES, 4.0, model="fem", fem_options={"elements_per_link": 20})
    assert fine["n_dof"] > 2 * coarse["n_dof"]
    assert _rel(fine, coarse) < 1e-7


def test_arm_file_sections_make_the_fem_softer_and_link_bending_overrides_them():
    arm = example_arm()
    soft = _with_sections(arm, ei=2e9, ea=None)
    rigid = eodarm.solve(arm, EXAMPLE_POSES, 5.0, model="fem")["dy_mm"]
    bent = eodarm.solve(soft, EXAMPLE_POSES, 5.0, model="fem")["dy_mm"]
    assert np.all(bent < rigid)  # more sag with flexible links
    # link_bending's EI replaces the file's: the analytic model with the same EI agrees.
    eff = [eodarm.Effect("link_bending", f"L{i}", ei_n_mm2=5e9) for i in (1, 2, 3)]
    fe = eodarm.solve(soft, EXAMPLE_POSES, 0.005, effects=eff, model="fem")
    an = eodarm.solve(arm, EXAMPLE_POSES, 0.005, effects=eff)
    assert _rel(fe, an) < 1e-5


def _fem_truth(arm, alpha, masses, hidden, noise_sigma=1e-4, seed=3):
    """Synthetic measurements whose truth is the FE model itself."""
    rows_alpha = np.repeat(np.asarray(alpha, dtype=float), len(masses), axis=0)
    rows_mass = np.tile(np.asarray(masses, dtype=float), len(alpha))
    out = eodarm.solve(arm, rows_alpha, rows_mass, effects=hidden, model="fem")
    chans = channel_names(arm.n)
    cols = {
        "dx_mm": out["dx_mm"],
        "dy_mm": out["dy_mm"],
        **{f"dalpha{i + 1}_deg": out["dalpha_deg"][:, i] for i in range(arm.n)},
        **{f"dl{i + 1}_mm": out["dl_mm"][:, i] for i in range(arm.n)},
    }
    rng = np.random.default_rng(seed)
    values = {c: cols[c] + noise_sigma * rng.standard_normal(len(rows_mass)) for c in chans}
    return Measurements.from_arrays(
        config=np.repeat([f"c{k}" for k in range(len(alpha))], len(masses)),
        alpha_deg=rows_alpha,
        mass_kg=rows_mass,
        values=values,
        sigma={c: np.full(len(rows_mass), noise_sigma) for c in chans},
        source="<fem synth>",
    )


def test_fem_fit_recovers_a_hidden_effect():
    arm = _seed()
    hidden = [
        eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1200.0),
        eodarm.Effect("joint_clearance", "O3", clearance_mm=0.1),
    ]
    meas = _fem_truth(arm, SEED_POSES, [1.5, 5.0, 6.5], hidden)
    res = fit(arm, meas, ["mount_compliance@M2", "joint_clearance@O3"], model="fem")
    assert res.problem.model == "fem"
    assert res.estimate(0) == pytest.approx(1200.0, rel=1e-3)
    assert res.estimate(1) == pytest.approx(0.1, rel=1e-3)
    assert res.chi2_per_dof < 2.0
    before = compare(arm, meas, [], model="fem")
    assert before.chi2_per_dof > 100 * res.chi2_per_dof


def test_fem_fit_of_analytic_data_is_biased_at_second_order_only():
    """Data from the exact pose, fitted with the linear FE: the mount stiffness comes out
    biased by the models' second-order difference, which shrinks in proportion to the load
    (the seed's soft 500 N/mm springs sag ~20 mm at 6.5 kg: a 12 % bias there)."""
    arm = _seed()
    bias = []
    for s in (1.0, 0.1, 0.01):
        meas = synth(
            arm,
            SEED_POSES,
            [1.5 * s, 5.0 * s, 6.5 * s],
            hidden=[eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=900.0)],
            noise=1e-9,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)
            res = fit(arm, meas, ["mount_compliance@M1"], model="fem")
        bias.append(abs(res.estimate(0) / 900.0 - 1.0))
    assert bias[2] < 2e-3, bias
    assert 7 < bias[0] / bias[1] < 14 and 7 < bias[1] / bias[2] < 14, bias


def test_fem_jacobian_matches_the_analytic_one_at_small_load():
    arm = example_arm()
    from eodarm.analysis.fit import Problem
    from eodarm.model.effects import Slot

    meas = _fem_truth(arm, EXAMPLE_POSES, [0.01], [])
    probes = [Slot.parse(s) for s in ("mount_compliance@M1", "link_bending@L2", "actuator_play@M3")]
    model = [(Slot.parse("base_compliance@base"), 1e-9)]
    ya, ja = Problem(arm, meas).evaluate(model, probes)
    yf, jf = Problem(arm, meas, model="fem").evaluate(model, probes)
    np.testing.assert_allclose(yf, ya, rtol=1e-4, atol=1e-9)
    scale = np.abs(ja).max(axis=(0, 1))
    assert np.all(np.abs(jf - ja).max(axis=(0, 1)) < 1e-3 * scale)


def test_fem_diagnose_finds_the_hidden_effect():
    arm = _seed()
    meas = _fem_truth(
        arm,
        SEED_POSES,
        [1.5, 6.5],
        [eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=3e8)],
        noise_sigma=1e-3,
    )
    cands = ["base_compliance@base", "mount_compliance@M1", "joint_clearance@O2"]
    d = eodarm.diagnose(
        arm, meas, candidates=cands, max_set=1, solver_model="fem", advise=False, outliers=False
    )
    assert d.ranking[0].slot.key == "base_compliance@base"
    assert d.suggested == ["base_compliance@base"] or d.verdict == "missing"


def test_cross_validate_runs_with_the_fem():
    arm = _seed()
    meas = _fem_truth(
        arm,
        SEED_POSES,
        [1.5, 6.5],
        [eodarm.Effect("mount_compliance", "M3", stiffness_n_per_mm=1500.0)],
    )
    cv = cross_validate(arm, meas, ["mount_compliance@M3"], model="fem")
    assert max(cv["rms"].values()) < 1e-3


def test_bad_input_is_refused_clearly():
    arm = example_arm()
    with pytest.raises(ValueError, match="model must be 'analytic' or 'fem'"):
        eodarm.solve(arm, EXAMPLE_POSES, 1.0, model="ansys")
    with pytest.raises(ValueError, match="backend='rust'"):
        eodarm.solve(arm, EXAMPLE_POSES, 1.0, model="fem", backend="numpy")
    with pytest.raises(ValueError, match="unknown key 'elements'"):
        eodarm.solve(arm, EXAMPLE_POSES, 1.0, model="fem", fem_options={"elements": 3})
    with pytest.raises(ValueError, match="elements_per_link must be in"):
        eodarm.solve(arm, EXAMPLE_POSES, 1.0, model="fem", fem_options={"elements_per_link": 0})
    with pytest.raises(ValueError, match="fem_options is for model='fem'"):
        eodarm.solve(arm, EXAMPLE_POSES, 1.0, fem_options={"elements_per_link": 3})
    with pytest.raises(ValueError, match="model must be"):
        fit(arm, _fem_truth(arm, EXAMPLE_POSES, [1.0], []), ["mount_compliance@M1"], model="x")
    with pytest.raises(ValueError, match="pose row 1: alpha_deg has a non-finite"):
        eodarm.solve(arm, [[90.0, 10.0, 0.0], [np.nan, 0.0, 0.0]], 1.0, model="fem")
    # A pose where actuator 2's line passes through joint O2: a mechanism, named.
    geo = eodarm.forward(arm, [[90.0, 0.0, 0.0]])
    d = geo["O"][0, 1] - geo["B"][0, 1]
    a2 = np.degrees(np.arctan2(d[1], d[0]) - np.arctan2(-55.0, 85.0))
    with pytest.raises(ValueError, match=r"pose row 1: the FE model is a mechanism: link 2"):
        eodarm.solve(arm, [[90.0, 10.0, 0.0], [90.0, a2, 0.0]], 1.0, model="fem")


def test_plots_draw_the_fem(tmp_path: Path):
    arm = _with_sections(_seed())
    out = eodarm.solve(arm, SEED_POSES, 1.5, model="fem")
    fig = fem_plots.deformed_shape(arm, out, row=1, path=tmp_path / "shape.png")
    assert (tmp_path / "shape.png").stat().st_size > 10_000
    assert "exaggerated" in fig.texts[0].get_text()
    fem_plots.moment_diagrams(arm, out, path=tmp_path / "m.png")
    fem_plots.pin_forces(arm, out, row=2, path=tmp_path / "p.png")
    assert (tmp_path / "m.png").exists() and (tmp_path / "p.png").exists()
    with pytest.raises(ValueError, match="solve with model='fem'"):
        fem_plots.deformed_shape(arm, eodarm.solve(arm, SEED_POSES, 1.5))
    with pytest.raises(ValueError, match="row 5 is out of range"):
        fem_plots.moment_diagrams(arm, out, row=5)
    assert fem_plots.nice_scale(73.0) == 50.0 and fem_plots.nice_scale(0.3) == 1.0


def test_cli_solve_and_fit_with_the_fem(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    example = ["--arm", str(Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml")]
    code = main(
        ["solve", *example, "--model", "fem", "--alpha", "90,10,0", "--mass", "5", "--json"]
    )
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["solver_model"] == "fem" and "pin_force_n" in doc["poses"][0]
    an = main(["solve", *example, "--alpha", "90,10,0", "--mass", "5", "--json"])
    assert an == 0
    ref = json.loads(capsys.readouterr().out)["poses"][0]
    assert doc["poses"][0]["dy_mm"] == pytest.approx(ref["dy_mm"], rel=2e-3)
    arm = _seed()
    meas = _fem_truth(
        arm,
        SEED_POSES,
        [1.5, 6.5],
        [eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1000.0)],
    )
    csv = tmp_path / "m.csv"
    meas.to_csv(csv)
    toml = tmp_path / "arm.toml"
    toml.write_text(arm.to_toml())
    args = ["fit", str(csv), "--arm", str(toml), "--add", "mount_compliance@M2", "--json"]
    assert main([*args, "--model", "fem", "--elements-per-link", "4"]) == 0
    est = json.loads(capsys.readouterr().out)["effects"][0]["estimate"]["stiffness_n_per_mm"]
    assert est == pytest.approx(1000.0, rel=1e-3)
    assert main(["compare", str(csv), "--arm", str(toml), "--model", "fem", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["solver_model"] == "fem"
    assert main(["solve", "--elements-per-link", "4"]) == 2
    assert "--elements-per-link needs --model fem" in capsys.readouterr().err
    figs = tmp_path / "figs"
    assert main(["solve", "--model", "fem", "--mass", "1.5", "--plot", str(figs)]) == 0
    assert sorted(p.name for p in figs.iterdir()) == [
        "fem-deformed-shape.png",
        "fem-moments.png",
        "fem-pin-forces.png",
    ]
    assert main(["solve", "--plot", str(figs)]) == 2
    assert "add --model fem" in capsys.readouterr().err
    # A command's figures solve with the command's model (the deflection shares).
    seen: list[str] = []
    real = plots.deflection_share

    def spy(*a: Any, **kw: Any) -> Any:
        seen.append(kw.get("model", "analytic"))
        return real(*a, **kw)

    monkeypatch.setattr(plots, "deflection_share", spy)
    shares = tmp_path / "shares"
    args = ["fit", str(csv), "--arm", str(toml), "--add", "mount_compliance@M2"]
    assert main([*args, "--model", "fem", "--elements-per-link", "4", "--plot", str(shares)]) == 0
    assert main([*args, "--plot", str(shares)]) == 0
    assert seen == ["fem", "analytic"]
    assert (shares / "deflection_share.png").exists()
