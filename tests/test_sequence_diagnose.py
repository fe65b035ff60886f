"""Diagnose and fit with memory: load-cycle files of 2-, 3- and 4-link arms.

Runs with either backend of ``solve_sequence`` (the numpy reference until the compiled core
has sequences). The data are synthetic with default noise; seeds are fixed, so each check is
deterministic. "Within its standard error" is checked at 2 standard errors: a correct fit
lands there with probability 95 %, and the seeds were not chosen to make it pass.
"""

from __future__ import annotations

import dataclasses
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import eodarm
from arms import example_arm, four_link_arm, two_link_arm
from eodarm.analysis.fit import FitWarning, compare
from eodarm.analysis.synth import random_configs, synth
from eodarm.cli import main

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"

E = eodarm.Effect
CYCLE = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]
ARMS = {"two": two_link_arm, "three": example_arm, "four": four_link_arm}

CASES = [
    ("two", [E("actuator_friction", "M2", friction_n=40.0)]),
    ("three", [E("joint_friction", "O2", torque_nmm=5000.0)]),
    ("three", [E("actuator_friction", "M2", friction_n=60.0)]),
    ("three", [E("joint_clearance", "O3", clearance_mm=0.1)]),
    (
        "three",
        [
            E("joint_friction", "O2", torque_nmm=5000.0),
            E("joint_clearance", "O3", clearance_mm=0.1),
        ],
    ),
    (
        "four",
        [
            E("joint_friction", "O3", torque_nmm=3000.0),
            E("actuator_friction", "M1", friction_n=80.0),
        ],
    ),
]


def _cycle_data(arm: eodarm.Arm, hidden: list[eodarm.Effect], seed: int = 3) -> eodarm.Measurements:
    cfg = random_configs(arm, 8, np.random.default_rng(1))
    return synth(arm, cfg, CYCLE, hidden, seed=seed, sequence=True)


@pytest.mark.parametrize(("arm_name", "hidden"), CASES, ids=lambda x: str(x))
def test_hidden_effect_in_a_load_cycle_is_found_and_fitted(
    arm_name: str, hidden: list[eodarm.Effect]
) -> None:
    arm = ARMS[arm_name]()
    meas = _cycle_data(arm, hidden)
    assert meas.has_sequences
    d = eodarm.diagnose(arm, meas, advise=False)
    every = {
        f"{name}@{p}{i + 1}"
        for name, p in (("actuator_friction", "M"), ("joint_friction", "O"))
        for i in range(arm.n)
    }
    assert {c.slot.key for c in d.ranking} >= every  # frictions ranked at every place
    assert d.verdict == "missing"
    assert {s.key for s in d.suggested} == {e.key for e in hidden}
    with warnings.catch_warnings():
        warnings.simplefilter("error", FitWarning)
        res = eodarm.fit(arm, meas, [e.key for e in hidden])
    assert 0.7 < res.chi2_per_dof < 1.4
    for e in hidden:
        i = [s.key for s in res.slots].index(e.key)
        est, err = res.estimate(i), res.stderr(i)
        assert abs(est - e.value) < 2 * err, (e, est, err)


def test_a_cycle_with_nothing_hidden_is_adequate() -> None:
    arm = example_arm()
    d = eodarm.diagnose(arm, _cycle_data(arm, []), advise=False)
    assert d.verdict == "adequate"
    assert d.suggested == []


def test_friction_is_found_in_single_loadings_without_step() -> None:
    """Without ``step`` each row is loaded once: a friction is a deadband, still found."""
    arm = example_arm()
    cfg = random_configs(arm, 10, np.random.default_rng(7))
    hidden = [E("actuator_friction", "M2", friction_n=30.0)]
    meas = synth(arm, cfg, [1.5, 5.0, 6.5], hidden, seed=11)
    assert not meas.has_sequences
    d = eodarm.diagnose(arm, meas, advise=False)
    assert d.verdict == "missing"
    assert [s.key for s in d.suggested] == ["actuator_friction@M2"]
    assert 0.7 < d.ranking[0].fit.chi2_per_dof < 1.4


def test_the_order_of_states_matters() -> None:
    """The true model fits the cycle read as a sequence; the same rows read as single
    loadings (no ``step``: each state loaded once from its reference) it cannot fit, because
    the unloading branch and the return are what the history left."""
    arm = example_arm()
    hidden = [E("joint_friction", "O2", torque_nmm=5000.0)]
    meas = _cycle_data(arm, hidden)
    assert compare(arm, meas, hidden).chi2_per_dof < 1.5
    single = dataclasses.replace(meas, step=None)
    assert compare(arm, single, hidden).chi2_per_dof > 5.0


def test_compare_shows_each_sequence_loading_unloading_and_what_is_left(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`eodarm compare` of a load cycle: per sequence, every channel against payload on both
    branches, measured and model, and the value left at the return to zero payload; the
    model with the hidden friction leaves what the data leave."""
    arm = example_arm()
    hidden = [E("joint_friction", "O2", torque_nmm=5000.0)]
    meas = _cycle_data(arm, hidden)
    csv = tmp_path / "cycle.csv"
    meas.to_csv(csv)
    args = ["compare", str(csv), "--arm", str(EXAMPLE), "--add", "joint_friction@O2=5000"]
    assert main([*args, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    loops = doc["hysteresis"]
    assert [h["config"] for h in loops] == list(meas.configs)
    first = loops[0]
    assert first["mass_kg"] == CYCLE[1:]
    assert first["branch"] == ["loading"] * 3 + ["unloading"] * 3
    last = meas.sequences()[0][-1]
    left = first["left_at_return"]
    for ch in meas.channels:
        assert left[ch]["measured"] == meas.values[last, meas.index(ch)]
    # the friction leaves the sag short of the reference, and the model says the same
    sig = meas.sigma[last, meas.index("dy_mm")]
    assert abs(left["dy_mm"]["model"]) > 5 * sig
    assert abs(left["dy_mm"]["model"] - left["dy_mm"]["measured"]) < 4 * sig
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "load sequence c1" in text and "unloading" in text
    assert "left at the return to zero: dx " in " ".join(text.split())
    assert max(len(line) for line in text.splitlines()) <= 100


def test_the_loops_figure_and_the_report_section(tmp_path: Path) -> None:
    """One panel per sequence: the measured states with σ bars joined by one arrow per step
    in the order applied, the model before and after; the report holds the figure and the
    return values of every sequence."""
    from eodarm.viz.hysteresis import loops
    from eodarm.viz.report import write_report

    arm = example_arm()
    cfg = random_configs(arm, 3, np.random.default_rng(1))
    hidden = [E("joint_friction", "O2", torque_nmm=5000.0)]
    meas = synth(arm, cfg, CYCLE, hidden, seed=3, sequence=True)
    before = compare(arm, meas, [])
    after = eodarm.fit(arm, meas, ["joint_friction@O2"])
    png = tmp_path / "loops.png"
    fig = loops(meas, before, after, path=png)
    assert png.stat().st_size > 10_000
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 3
    for ax in axes:
        gids = [a.get_gid() for a in ax.get_children()]
        # the reference and the 6 states after it: one arrow per step, 6
        assert gids.count("direction") == 6
        assert "before" in gids and "after" in gids
        assert "left" in ax.get_title()
    d = eodarm.diagnose(arm, meas, advise=False)
    html = write_report(tmp_path / "r.html", arm, meas, d).read_text(encoding="utf-8")
    # the return of every sequence on the first screen, with the loops
    first = html.split("<h2>The answer</h2>", 1)[1].split("<h3>What is left</h3>", 1)[0]
    assert "The return to zero load" in first and 'alt="hysteresis loops"' in first
    assert all(f"<td>{label}</td>" in first for label in meas.configs)
    assert "Load cycles: every channel" in html
    section = html[html.index("Load cycles: every channel") :]
    # every channel of every sequence, measured and model, folded per sequence
    assert section.count("<details><summary>sequence ") == 3
    for ch in meas.channels:
        name = ch.removesuffix("_mm").removesuffix("_deg").replace("alpha", "α")
        unit = "deg" if ch.endswith("_deg") else "mm"
        assert f"{name} [{unit}] measured / model" in section


def test_frictions_of_one_actuator_at_one_pose_are_confused_and_the_tool_says_what_separates(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """At one pose the actuator's moment arm is fixed, so a joint friction T at O2 and an
    actuator friction T/r at M2 are the same deadband: the data cannot tell them apart, and
    the advice names the measurement that would (a pose with another moment arm)."""
    arm = example_arm()
    pose = np.repeat(random_configs(arm, 1, np.random.default_rng(2)), 2, axis=0)
    hidden = [E("actuator_friction", "M2", friction_n=60.0)]
    meas = synth(arm, pose, CYCLE, hidden, seed=3, sequence=True)
    d = eodarm.diagnose(arm, meas)
    first, second = d.ranking[0], d.ranking[1]
    assert {first.slot.key, second.slot.key} == {"actuator_friction@M2", "joint_friction@O2"}
    assert second.slot.key in first.confused_with
    assert abs(first.fit.chi2 - second.fit.chi2) < 1e-6 * first.fit.chi2
    [advice] = [a for a in d.advice if set(a["pair"]) == {first.slot.key, second.slot.key}]
    assert "moment arm of actuator 2 about O2" in advice["memory"]
    assert advice["pose"]["chi2_separation"] > 3.84  # another pose does separate them
    csv = tmp_path / "one_pose.csv"
    meas.to_csv(csv)
    assert main(["diagnose", str(csv), "--arm", str(EXAMPLE)]) == 0
    said = " ".join(capsys.readouterr().out.split())
    assert "what separates them: poses with a different moment arm of actuator 2" in said
