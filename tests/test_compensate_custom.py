"""Compensation with user-written effects (docs/compensation.md): finished in Python on the full
model, from the core's compensation with the catalogue's effects."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

import eodarm
from arms import EXAMPLES, example_arm, four_link_arm, two_link_arm
from eodarm.analysis.compensate import CompensationWarning
from eodarm.model import custom

#: Lands on the nominal point to this (mm): the brief's bar; the iteration stops at 1e-9.
LAND_MM = 1e-6


def mount_like(state: eodarm.EffectState, i: int, k: float) -> dict[str, Any]:
    """``mount_compliance`` written by a user: a spring in series that the sensor misses."""
    return {"actuator_unseen_mm": -(state.force_n[:, i] - state.force0_n[:, i]) / k}


def hook_drop(state: eodarm.EffectState, i: int, mm_per_kg: float) -> dict[str, Any]:
    """A known deflection: the measure point (a hook on a rope) drops by mm_per_kg per kg of
    payload, moving no link."""
    drop = np.zeros((state.n_states, 2))
    drop[:, 1] = -mm_per_kg * state.mass_kg
    return {"measure_mm": drop}


@pytest.fixture(autouse=True)
def _registered() -> Iterator[None]:
    eodarm.custom_effect(
        "mount_like", places="M", parameter="stiffness_n_per_mm", lower=1.0, start=1000.0
    )(mount_like)
    eodarm.custom_effect("hook_drop", places="base", parameter="mm_per_kg", start=0.1)(hook_drop)
    try:
        yield
    finally:
        custom.unregister("mount_like")
        custom.unregister("hook_drop")


def _nominal(n: int, count: int, seed: int) -> np.ndarray:
    base = {2: [80.0, 20.0], 3: [90.0, 10.0, 0.0], 4: [80.0, 20.0, 0.0, -10.0]}[n]
    return np.array(base) + np.random.default_rng(seed).uniform(-10, 10, (count, n))


def _loaded(arm: eodarm.Arm, alpha: np.ndarray, mass: float, effects: list) -> dict:
    """The model's loaded measure point and last absolute angle at commanded angles."""
    s = eodarm.solve(arm, alpha, mass, effects)
    point = eodarm.forward(arm, alpha)["measure"] + np.column_stack([s["dx_mm"], s["dy_mm"]])
    return {"point": point, "last_deg": alpha[:, -1] + s["dalpha_deg"][:, -1]}


@pytest.mark.parametrize("make", [two_link_arm, example_arm, four_link_arm])
def test_a_user_effect_is_compensated_onto_the_nominal_point(make: Any) -> None:
    """Under the model with the user effects, the compensated pose's loaded measure point is
    the nominal one to 1e-6 mm, the last link keeps its nominal angle (n ≥ 3), and the
    user effect moved it by millimetres before (the compensation did something)."""
    arm = make()
    nominal = _nominal(arm.n, 12, seed=arm.n)
    effects = [
        eodarm.Effect("mount_like", "M2", stiffness_n_per_mm=800.0),
        eodarm.Effect("hook_drop", "base", mm_per_kg=0.4),
    ]
    out = eodarm.compensate(arm, nominal, 5.0, effects=effects)
    assert (out["status"] == "ok").all()
    target = eodarm.forward(arm, nominal)["measure"]
    got = _loaded(arm, out["alpha_deg"], 5.0, effects)
    miss = np.linalg.norm(got["point"] - target, axis=1)
    assert miss.max() < LAND_MM
    np.testing.assert_allclose(out["residual_mm"], miss, rtol=0, atol=1e-9)
    if arm.n >= 3:  # 1e-6 mm at the last link's length ~ 1e-9 rad
        np.testing.assert_allclose(got["last_deg"], nominal[:, -1], rtol=0, atol=1e-7)
    before = _loaded(arm, nominal, 5.0, effects)
    assert (np.linalg.norm(before["point"] - target, axis=1) > 2.0).all()


@pytest.mark.parametrize("make", [example_arm, four_link_arm])
def test_a_user_spring_compensates_like_the_built_in_one(make: Any) -> None:
    """``mount_like`` is ``mount_compliance`` written by a user: the Python iteration and the
    core's compensation find the same commanded angles: 3 links have one answer, found by
    both to ~1e-10° (1e-8° allowed); for 4 links both stop the smallest-change phase when its
    step is below 1e-5 of the largest change of angle (a few degrees here), so 1e-4°."""
    arm = make()
    nominal = _nominal(arm.n, 10, seed=7)
    user = eodarm.compensate(
        arm, nominal, 6.0, [eodarm.Effect("mount_like", "M1", stiffness_n_per_mm=1200.0)]
    )
    core = eodarm.compensate(
        arm, nominal, 6.0, [eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=1200.0)]
    )
    tol = 1e-8 if arm.n == 3 else 1e-4
    np.testing.assert_allclose(user["alpha_deg"], core["alpha_deg"], rtol=0, atol=tol)
    if arm.n > 3:  # the spare freedom went to the smallest change, as the core's did
        change = np.linalg.norm(user["alpha_deg"] - nominal, axis=1)
        least = np.linalg.norm(core["alpha_deg"] - nominal, axis=1)
        assert (change <= least * (1 + 1e-5)).all()


def test_poses_that_cannot_be_compensated_are_named() -> None:
    """A pose at actuator 3's dead point is named by row and reason, its angles NaN; the
    others are compensated."""
    arm = example_arm()
    nominal = np.array([[90.0, 10.0, 0.0], [90.0, 10.0, 50.0], [80.0, 15.0, 5.0]])
    effects = [eodarm.Effect("hook_drop", "base", mm_per_kg=0.4)]
    with pytest.warns(CompensationWarning, match=r"row 1: ") as rec:
        out = eodarm.compensate(arm, nominal, 5.0, effects=effects)
    assert len(rec) == 1
    assert out["status"][1] != "ok" and np.isnan(out["alpha_deg"][1]).all()
    assert (out["status"][[0, 2]] == "ok").all()
    with pytest.raises(eodarm.analysis.compensate.CompensationError, match="row 1"):
        eodarm.compensate(arm, nominal, 5.0, effects=effects, strict=True)


def test_a_user_function_that_fails_is_an_error_not_a_status() -> None:
    def broken(state: eodarm.EffectState, i: int, x: float) -> dict[str, Any]:
        raise RuntimeError("boom")

    eodarm.custom_effect("broken_eff", places="base", parameter="x", start=1.0)(broken)
    try:
        with pytest.raises(eodarm.errors.CustomEffectError, match="broken_eff"):
            eodarm.compensate(
                example_arm(), [[90.0, 10.0, 0.0]], 5.0, [eodarm.Effect("broken_eff", "base", x=1)]
            )
    finally:
        custom.unregister("broken_eff")


def _hook_command(tmp_path: Any) -> list[str]:
    """``eodarm compensate`` on the example arm with a user-written effect file that drops the
    measure point by ``mm_per_kg`` per kg of payload, up to ``--add`` (the caller adds the
    effect and the poses)."""
    custom.unregister("hook_drop")  # the file registers it again
    (tmp_path / "hook.py").write_text(
        "import numpy as np\nimport eodarm\n\n"
        '@eodarm.custom_effect("hook_drop", places="base", parameter="mm_per_kg", start=0.1)\n'
        "def hook_drop(state, i, mm_per_kg):\n"
        "    drop = np.zeros((state.n_states, 2))\n"
        "    drop[:, 1] = -mm_per_kg * state.mass_kg\n"
        '    return {"measure_mm": drop}\n'
    )
    args = ["compensate", "--arm", str(EXAMPLES / "example_arm.toml")]
    return [*args, "--effects", str(tmp_path / "hook.py"), "--add"]


def test_the_command_line_compensates_with_an_effects_file(
    tmp_path: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    from eodarm.cli import main

    args = _hook_command(tmp_path)
    args += ["hook_drop@base=0.4", "--alpha", "90,10,0", "--mass", "5", "--json"]
    assert main(args) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["status"] == ["ok"] and doc["residual_mm"][0] < LAND_MM
    want = eodarm.compensate(
        example_arm(), [[90.0, 10.0, 0.0]], 5.0, [eodarm.Effect("hook_drop", "base", mm_per_kg=0.4)]
    )
    np.testing.assert_allclose(doc["alpha_deg"], want["alpha_deg"], rtol=0, atol=1e-12)


def test_the_table_s_uncompensated_miss_includes_the_user_effect(
    tmp_path: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    """The terminal's "miss" column is what the payload does to the model with the user's
    effect (here it adds 0.4 mm/kg · 5 kg downward), not to the catalogue part alone."""
    from eodarm.cli import main

    args = _hook_command(tmp_path)
    args += ["hook_drop@base=0.4", "--alpha", "90,10,0", "--mass", "5"]
    assert main(args) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "miss mm" in lines[1]
    # pose, kg, nominal, command, length, miss, left, status
    shown = float(lines[2].split()[5])
    out = eodarm.solve(
        example_arm(), [[90.0, 10.0, 0.0]], 5.0, [eodarm.Effect("hook_drop", "base", mm_per_kg=0.4)]
    )
    assert shown == pytest.approx(float(np.hypot(out["dx_mm"], out["dy_mm"])[0]), abs=1e-3)
