"""``solve_sequence(..., uncertainty=True)``: the σ of every state of a load sequence, the
fitted parameters' part and the model's inadequacy (docs/model.md §8 and §9,
docs/python.md).

The promises are tested as tests/test_honest_sigma.py and tests/test_fitted_arm.py test
``solve``'s: a sequence of one state is ``solve`` (its σ too), the linear propagation agrees
with models drawn from the fitted covariance through the memory of friction, and held-out
sequences fall inside their 95 % intervals as often as promised.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import eodarm
from arms import example_arm
from eodarm.analysis.fit import FitWarning
from eodarm.analysis.synth import random_configs, synth
from eodarm.data.measurements import Measurements

Z95 = 1.959963984540054
CYCLE = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]
KEYS = ("dx_mm", "dy_mm", "dalpha_deg")


def fitted(meas: Measurements, model: list[str]) -> eodarm.Arm:
    """The fitted arm a script gets from ``eodarm.fit(...).to_arm()``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        return eodarm.fit(example_arm(), meas, model).to_arm()


def test_a_sequence_of_one_state_has_the_sigma_of_solve() -> None:
    # No memory before the only state: the sequence's derivative (solved twice at the core's
    # step) is the core's own central difference, so both σ agree to round-off amplified by
    # 1/step (1e-9 relative; measured 5e-13).
    arm = example_arm()
    hidden = [
        eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=2500.0),
        eodarm.Effect("joint_clearance", "O2", clearance_mm=0.15),
    ]
    meas = synth(arm, random_configs(arm, 8, rng=1), [1.5, 5.0], hidden, seed=2)
    back = fitted(meas, ["mount_compliance@M1", "joint_clearance@O2"])
    poses = random_configs(arm, 6, rng=3)
    one = eodarm.solve(back, poses, 5.0, uncertainty=True)
    seq = eodarm.solve_sequence(back, poses, [5.0], uncertainty=True)
    for part in ("", "_param", "_model"):
        for key in KEYS:
            name = f"sigma{part}_{key}"
            assert seq[name].shape == (6, 1, *one[name].shape[1:])
            np.testing.assert_allclose(seq[name][:, 0], one[name], rtol=1e-9, atol=0, err_msg=name)
    assert np.all(seq["sigma_dy_mm"] > 0)


@pytest.fixture(scope="module")
def friction_file() -> eodarm.Arm:
    """A joint friction and a soft mount fitted to load cycles that hold both (the model
    explains its data)."""
    arm = example_arm()
    hidden = [
        eodarm.Effect("joint_friction", "O2", torque_nmm=6000.0),
        eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=1500.0),
    ]
    meas = synth(arm, random_configs(arm, 8, rng=11), CYCLE, hidden, seed=5, sequence=True)
    return fitted(meas, ["joint_friction@O2", "mount_compliance@M2"])


def test_sequence_sigma_matches_models_drawn_from_the_fitted_covariance(
    friction_file: eodarm.Arm,
) -> None:
    """Linear propagation through the friction's memory against 2000 models drawn from the
    [fit] covariance: within 10 % on every state that moves (the Monte-Carlo estimate of a σ
    scatters by 1/√(2·2000) ≈ 1.6 %; the friction's kinks bend the rest)."""
    back = friction_file
    assert back.fit is not None and back.fit.explained is True
    poses = random_configs(example_arm(), 4, rng=12)
    got = eodarm.solve_sequence(back, poses, CYCLE, uncertainty=True)
    keys = [p.split(":")[0] for p in back.fit.parameters]
    mean = {e.key: e for e in back.effects}
    draws = np.random.default_rng(0).multivariate_normal(
        [mean[k].value for k in keys], back.fit.matrix(), 2000
    )
    dy, da = [], []
    for p in draws:
        model = [mean[k].with_value(v) for k, v in zip(keys, p, strict=True)]
        out = eodarm.solve_sequence(back, poses, CYCLE, model)
        dy.append(out["dy_mm"])
        da.append(out["dalpha_deg"])
    mc = np.std(dy, axis=0)
    moves = mc > 1e-3 * mc.max()  # the reference state (0 kg) does not move
    assert moves.sum() >= 20
    np.testing.assert_allclose(got["sigma_dy_mm"][moves], mc[moves], rtol=0.10)
    mca = np.std(da, axis=0)
    big = mca > 1e-3 * mca.max()
    np.testing.assert_allclose(got["sigma_dalpha_deg"][big], mca[big], rtol=0.10)
    # the model explained its data: no model part, total = parameters' (hypot's rounding)
    assert np.all(got["sigma_model_dy_mm"] == 0.0)
    np.testing.assert_allclose(got["sigma_dy_mm"], got["sigma_param_dy_mm"], rtol=1e-15)


def test_friction_leaves_an_uncertain_return_and_sigma_says_how_uncertain(
    friction_file: eodarm.Arm,
) -> None:
    # What friction leaves at the return to 0 kg depends on the fitted limit: its σ is not 0
    # (the fitted friction's error reaches it), unlike the reference state's.
    out = eodarm.solve_sequence(friction_file, [90.0, 10.0, 0.0], CYCLE, uncertainty=True)
    assert out["sigma_dy_mm"].shape == (1, len(CYCLE))
    assert out["sigma_param_dy_mm"][0, -1] > 0


def unexplained_sequences(k: int) -> Measurements:
    """Load cycles of an arm whose chassis tilts; the fitted model has only the friction."""
    arm = example_arm()
    hidden = [
        eodarm.Effect("joint_friction", "O2", torque_nmm=5000.0),
        eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=2e8),
    ]
    alpha = random_configs(arm, k, rng=7)
    return synth(arm, alpha, CYCLE, hidden, channels=["dx_mm", "dy_mm"], seed=3, sequence=True)


def test_held_out_sequences_fall_inside_their_95_percent_intervals() -> None:
    # Leave one configuration (one load cycle) out, fit the others, predict its states from
    # the fitted arm alone: a measured value is inside prediction ± 1.96·√(σ² + σ_meas²).
    meas = unexplained_sequences(8)
    labels = np.asarray(meas.config)
    inside = total = 0
    for label in meas.configs:
        held = labels == label
        back = fitted(meas.subset(~held), ["joint_friction@O2"])
        assert back.fit is not None and back.fit.explained is False  # the tilt is missing
        rows = np.flatnonzero(held)
        rows = rows[np.argsort(meas.step[rows])]
        out = eodarm.solve_sequence(
            back, meas.alpha_deg[rows[0]], meas.mass_kg[rows], uncertainty=True
        )
        for key in ("dx_mm", "dy_mm"):
            col = meas.channels.index(key)
            y, s = meas.values[rows, col], meas.sigma[rows, col]
            width = Z95 * np.hypot(out[f"sigma_{key}"][0], s)
            inside += int(np.sum(np.abs(y - out[key][0]) <= width))
            total += y.size
    assert total == 8 * 6 * 2
    assert 0.85 <= inside / total <= 0.995, f"{inside} of {total} held-out cells inside"


def test_without_the_model_part_the_held_out_cycles_would_not_be_covered() -> None:
    # Why the model part is there: the parameters' σ alone leaves most held-out cells out.
    meas = unexplained_sequences(8)
    labels = np.asarray(meas.config)
    held = labels == meas.configs[0]
    back = fitted(meas.subset(~held), ["joint_friction@O2"])
    rows = np.flatnonzero(held)
    rows = rows[np.argsort(meas.step[rows])]
    out = eodarm.solve_sequence(back, meas.alpha_deg[rows[0]], meas.mass_kg[rows], uncertainty=True)
    col = meas.channels.index("dy_mm")
    miss = np.abs(meas.values[rows, col] - out["dy_mm"][0])
    assert np.any(miss > Z95 * np.hypot(out["sigma_param_dy_mm"][0], meas.sigma[rows, col]))
    np.testing.assert_allclose(  # total² = param² + model², to rounding
        out["sigma_dy_mm"] ** 2,
        out["sigma_param_dy_mm"] ** 2 + out["sigma_model_dy_mm"] ** 2,
        rtol=1e-12,
    )
    assert np.all(out["sigma_model_dy_mm"] > 0)


def test_sequence_uncertainty_needs_a_fitted_arm_and_says_how_to_get_one() -> None:
    arm = example_arm()
    with pytest.raises(eodarm.InputError, match=r"no fit.*to_arm\(\)") as info:
        eodarm.solve_sequence(arm, [90.0, 10.0, 0.0], CYCLE, uncertainty=True)
    assert "\n" not in str(info.value) and len(str(info.value)) < 300


def test_sequence_uncertainty_refuses_user_written_effects(friction_file: eodarm.Arm) -> None:
    @eodarm.custom_effect("seq_sigma_probe", places="M", parameter="c_mm", lower=0.0)
    def probe(state: eodarm.EffectState, i: int, c_mm: float) -> dict[str, np.ndarray]:
        return {"actuator_unseen_mm": np.full(state.force_n.shape[0], c_mm)}

    from eodarm.model.catalogue import unregister

    try:
        extra = [eodarm.Effect("seq_sigma_probe", "M1", c_mm=0.01)]
        with pytest.raises(eodarm.InputError, match="catalogue's effects only"):
            eodarm.solve_sequence(friction_file, [90.0, 10.0, 0.0], CYCLE, extra, uncertainty=True)
    finally:
        unregister("seq_sigma_probe")
