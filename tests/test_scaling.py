"""The work of compare, fit and diagnose grows with the file, not with its square (issue 23
item 2), stated as counts of fits, not as times:

* outliers are left out in a few rounds: every cell beyond 4σ goes at once, the work is
  redone, and the cells are judged again (on a file of 100 configurations the old rule, one
  cell per refit up to 2 % of the values, refitted 48 times);
* leave-one-configuration-out on many configurations costs one fit, each fold one linearised
  step from it, and gives the held-out error of refitting every fold.
"""

from __future__ import annotations

import numpy as np
import pytest

import eodarm
from arms import example_arm
from eodarm.analysis import crossval as crossval_module
from eodarm.analysis.crossval import CV_EXACT_CONFIGS, cross_validate
from eodarm.analysis.fit import FitResult, fit
from eodarm.analysis.gauss_newton import Solution
from eodarm.analysis.outliers import PEEL_ROUNDS, peel_outliers
from eodarm.analysis.synth import random_configs, synth

MASSES = [1.5, 5.0, 6.5]


def _measurements(hidden: list[eodarm.Effect], k: int, seed: int = 3) -> eodarm.Measurements:
    arm = example_arm()
    alpha = random_configs(arm, k, np.random.default_rng(seed))
    return synth(arm, alpha, MASSES, hidden=hidden, seed=seed)


def _with(meas: eodarm.Measurements, values: np.ndarray) -> eodarm.Measurements:
    return eodarm.Measurements.from_arrays(
        config=meas.config,
        alpha_deg=meas.alpha_deg,
        mass_kg=meas.mass_kg,
        values={ch: values[:, j] for j, ch in enumerate(meas.channels)},
        sigma={ch: meas.sigma[:, j] for j, ch in enumerate(meas.channels)},
    )


def _peel(meas: eodarm.Measurements, slots: list[str]) -> tuple[FitResult, np.ndarray, int]:
    """peel_outliers on a fit of ``slots``, counting the refits it asks for."""
    arm = example_arm()
    calls = []

    def refit(mask: np.ndarray) -> FitResult:
        calls.append(int(mask.sum()))
        return fit(arm, meas, slots, exclude=mask)

    res, mask = peel_outliers(fit(arm, meas, slots), refit, lambda r: r)
    return res, mask, len(calls)


def test_a_model_wrong_everywhere_costs_a_few_refits_and_is_not_cleaned() -> None:
    # a clearance the model does not have: most cells are far beyond 4σ
    meas = _measurements([eodarm.Effect("joint_clearance", "O2", clearance_mm=0.3)], k=100)
    assert int(0.02 * np.isfinite(meas.values).sum()) >= 40  # the old rule's refits
    res, mask, refits = _peel(meas, [])
    assert refits <= PEEL_ROUNDS
    assert not mask.any()  # nothing is named: the model is wrong, not the data
    assert res.chi2_per_dof > 10


def test_every_typo_is_named_in_one_round_and_the_fit_is_clean() -> None:
    true = 0.15
    meas = _measurements([eodarm.Effect("joint_clearance", "O3", clearance_mm=true)], k=40)
    values = np.array(meas.values)
    dy = meas.channels.index("dy_mm")
    rows = [3, 17, 58, 90, 111]
    values[rows, dy] *= 10  # misplaced decimal points
    bad = _with(meas, values)
    res, mask, refits = _peel(bad, ["joint_clearance@O3"])
    assert sorted(zip(*np.nonzero(mask), strict=True)) == [(r, dy) for r in rows]
    # one refit without them, one more round that finds nothing new
    assert refits <= 2
    assert res.estimate(0) == pytest.approx(true, rel=0.05)
    assert res.chi2_per_dof < 1.4


def test_a_cell_dragged_by_a_typo_comes_back() -> None:
    # a small file: one huge typo drags the fit, so that good cells are beyond 4σ at first;
    # judged again against the fit without the typo, they return
    meas = _measurements([eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15)], k=4)
    values = np.array(meas.values)
    dy = meas.channels.index("dy_mm")
    values[5, dy] = values[5, dy] * 60 + 40.0
    bad = _with(meas, values)
    first = fit(example_arm(), bad, ["joint_clearance@O3"])
    dragged = np.abs(np.nan_to_num(first.z)) > 4
    dragged[5, dy] = False
    _, mask, _ = _peel(bad, ["joint_clearance@O3"])
    assert list(zip(*np.nonzero(mask), strict=True)) == [(5, dy)]
    assert dragged.any(), "the typo no longer drags any good cell: make it larger"


@pytest.mark.parametrize(
    ("hidden", "fitted"),
    [
        # the model explains the data: the folds are the refits to rounding
        ([eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15)], ["joint_clearance@O3"]),
        # it does not (a mount is missing), and two of three parameters sit at their bound
        (
            [
                eodarm.Effect("joint_clearance", "O3", clearance_mm=0.05),
                eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=3000.0),
            ],
            ["actuator_play@M1", "joint_clearance@O2", "link_bending@L2"],
        ),
    ],
)
def test_many_configurations_are_held_out_at_the_cost_of_one_fit(
    monkeypatch: pytest.MonkeyPatch, hidden: list[eodarm.Effect], fitted: list[str]
) -> None:
    meas = _measurements(hidden, k=CV_EXACT_CONFIGS + 20, seed=4)
    arm = example_arm()
    exact = cross_validate(arm, meas, fitted, exact=True)
    calls = []
    real_iterate = crossval_module.iterate

    def counting(*args: object, **kw: object) -> Solution:
        calls.append(1)
        return real_iterate(*args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(crossval_module, "iterate", counting)
    quick = cross_validate(arm, meas, fitted)  # above CV_EXACT_CONFIGS: linearised
    assert len(calls) == 1
    # One Gauss–Newton step from the fit on all the data: the held-out RMS of each channel
    # within 2 % of the refits' (1e-8 where the model explains the data; ≈1 % where not).
    for ch, v in exact["rms"].items():
        assert quick["rms"][ch] == pytest.approx(v, rel=0.02), ch
    for label, per in exact["per_config"].items():
        assert set(quick["per_config"][label]) == set(per)
