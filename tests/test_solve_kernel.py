"""``eodarm.solve`` on the compiled block kernel: it equals the general per-pose path, its
``status`` equals the numpy reference's (:func:`eodarm.model.validity.status`), and it writes
into caller-provided arrays (``out=``).

The general path is reached from Python by passing user deformations (``extra=``) that are
zero: they add nothing, and the core solves every pose with ``Workspace::solve`` when any are
given (docs/architecture.md). Tolerances: 1e-9 mm / 1e-9 deg / 1e-9 N relative, as in
test_backends (both paths compute the same model with different formulas; they agree to
~1e-13).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.errors import InputError
from eodarm.model import native as _core
from eodarm.model.effects import UNLOADED, effect_arrays
from eodarm.model.solver import _core_arm
from eodarm.model.validity import (
    MAX_DALPHA_DEG,
    MAX_DEFLECTION_OF_REACH,
    MAX_LOAD_RISE_MM,
    MAX_RISE_OF_REACH,
    MIN_MOMENT_ARM,
    checks_load_rise,
    status,
)
from strategies import arm_and_poses, effects_for, pose_from_joint_angles

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
FLOAT_KEYS = (
    "force_n",
    "reaction_n",
    "dforce_n",
    "dx_mm",
    "dy_mm",
    "dalpha_deg",
    "dl_mm",
    "dlength_mm",
    "length_mm",
)


def general(arm: eodarm.Arm, alpha: np.ndarray, mass: np.ndarray, **kw) -> dict:
    """``eodarm.solve`` through the general path (zero user deformations)."""
    zero = {"extra_measure_mm": np.zeros((alpha.shape[0], 2))}
    return eodarm.solve(arm, alpha, mass, extra=zero, **kw)


def assert_close(fast: dict, ref: dict) -> None:
    for key in FLOAT_KEYS:
        a, b = np.asarray(fast[key]), np.asarray(ref[key])
        assert a.shape == b.shape, key
        # a pose that cannot be closed under its load is NaN in both, the same poses
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=key)
        a, b = np.nan_to_num(a), np.nan_to_num(b)
        # forces relative (kN scale), lengths and angles absolute (see the module notes)
        scale = np.abs(b) if key.endswith("_n") else 0.0
        np.testing.assert_array_less(np.abs(a - b), 1e-9 * (1.0 + scale) + 1e-300, err_msg=key)


@st.composite
def limited(draw, case):
    """The case's arm with stroke and force limits drawn around the values its poses reach,
    so that every status code can occur (stroke ends 1–20 mm from the lengths reached, so that
    none sits on a length, where two correct programs may round to either side)."""
    arm, alpha, mass = case
    geo = eodarm.forward(arm, alpha)
    d = arm.to_dict()

    def off(label: str) -> float:
        return draw(st.floats(1.0, 20.0), label=label) * draw(st.sampled_from([-1.0, 1.0]))

    for i, act in enumerate(d["actuator"]):
        lengths = geo["length_mm"][:, i]
        if draw(st.booleans(), label=f"stroke {i}"):
            lo = float(lengths.min()) - off("below")
            hi = float(lengths.max()) + off("above")
            if hi - lo < 2.0:
                lo, hi = float(lengths.min()) - 1.0, float(lengths.max()) + 1.0
            act["min_length_mm"], act["max_length_mm"] = lo, hi
        if draw(st.booleans(), label=f"force {i}"):
            act["max_force_n"] = draw(st.floats(1.0, 3000.0))
    return eodarm.Arm.from_dict(d), alpha, mass


@settings(max_examples=120, deadline=None)
@given(case=arm_and_poses(max_links=5), self_weight=st.booleans(), data=st.data())
def test_kernel_equals_the_general_path(case, self_weight, data) -> None:
    arm, alpha, mass = data.draw(limited(case), label="limits")
    effects = data.draw(effects_for(arm, unloaded=UNLOADED), label="effects")
    # a soft actuator now and then, for deflections beyond the model's limits
    if data.draw(st.booleans(), label="soft"):
        effects = [e for e in effects if (e.name, e.at) != ("actuator_compliance", "M1")]
        effects.append(eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=20.0))
    kw = {"effects": effects, "self_weight": self_weight}
    try:
        ref = general(arm, alpha, mass, **kw)
    except ValueError as exc:  # a soft actuator may not close its triangle: same error
        with pytest.raises(ValueError) as fast_exc:
            eodarm.solve(arm, alpha, mass, **kw)
        assert str(fast_exc.value) == str(exc)
        return
    fast = eodarm.solve(arm, alpha, mass, **kw)
    assert_close(fast, ref)
    np.testing.assert_array_equal(fast["status"], ref["status"])


def near_threshold(arm: eodarm.Arm, alpha: np.ndarray, payload: np.ndarray, out: dict):
    """(N,) poses where a quantity the status reads is within 1e-9 relative of its limit
    (there the two implementations may round to either side)."""
    rel = 1e-9
    n = arm.n

    def close(x, limit):
        x, limit = np.asarray(x, dtype=float), np.asarray(limit, dtype=float)
        with np.errstate(invalid="ignore"):
            return np.abs(x - limit) <= rel * np.maximum(np.abs(limit), 1e-300)

    geo = eodarm.forward(arm, alpha)
    o, a, b = geo["O"][:, :n], geo["A"], geo["B"]
    line = a - b
    h = np.abs(line[..., 0] * (o - b)[..., 1] - line[..., 1] * (o - b)[..., 0])
    h = h / np.linalg.norm(line, axis=2)
    near = close(h, MIN_MOMENT_ARM * np.linalg.norm(a - o, axis=2)).any(axis=1)
    for i, act in enumerate(arm.actuators):
        for lim in (act.min_length_mm, act.max_length_mm):
            if lim is not None:
                near |= close(geo["length_mm"][:, i], lim)
        if act.max_force_n is not None:
            near |= close(np.abs(out["force_n"][:, i]), act.max_force_n)
    reach = sum(math.hypot(*lk.next) for lk in arm.links)
    near |= close(np.abs(out["dalpha_deg"]), MAX_DALPHA_DEG).any(axis=1)
    near |= close(np.hypot(out["dx_mm"], out["dy_mm"]), MAX_DEFLECTION_OF_REACH * reach)
    near |= close(out["dy_mm"], MAX_RISE_OF_REACH * reach) & (payload[:, 1] < 0)
    # the load point's height change, as docs/model.md §7 takes it through the last link
    last = arm.links[-1]
    v = np.subtract(last.next, last.measure or last.next)
    an, dn = np.radians(alpha[:, -1]), np.radians(out["dalpha_deg"][:, -1])
    wx, wy = np.cos(an) * v[0] - np.sin(an) * v[1], np.sin(an) * v[0] + np.cos(an) * v[1]
    load_dy = out["dy_mm"] + np.sin(dn) * wx + (np.cos(dn) - 1.0) * wy
    near |= close(load_dy, MAX_LOAD_RISE_MM) & (payload[:, 1] < 0)
    return near


@settings(max_examples=120, deadline=None)
@given(case=arm_and_poses(max_links=5), self_weight=st.booleans(), data=st.data())
def test_status_equals_the_numpy_reference(case, self_weight, data) -> None:
    """The core's status equals the numpy reference's on the same outputs, except where a
    quantity is within a relative 1e-9 of its threshold (none in practice)."""
    arm, alpha, mass = data.draw(limited(case), label="limits")
    effects = data.draw(effects_for(arm, unloaded=UNLOADED), label="effects")
    if data.draw(st.booleans(), label="soft"):
        effects = [e for e in effects if (e.name, e.at) != ("actuator_compliance", "M1")]
        effects.append(eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=30.0))
    try:
        out = eodarm.solve(arm, alpha, mass, effects, self_weight=self_weight)
    except ValueError:
        return  # a triangle that cannot close: no status to compare
    payload = np.zeros((alpha.shape[0], 2))
    payload[:, 1] = -mass * arm.g
    ref = status(arm, alpha, payload, out, load_rise=checks_load_rise(arm, effects))
    keep = ~near_threshold(arm, alpha, payload, out)
    np.testing.assert_array_equal(out["status"][keep], ref[keep])


def test_every_status_occurs_and_matches_on_a_sweep_of_the_example() -> None:
    """Random poses from folded to stretched and poses whose first triangle is nearly flat,
    payloads up to 40 kg, a soft actuator and a soft chassis, limits set: each code shows up,
    and the core's codes equal the numpy reference's on the same outputs."""
    d = eodarm.Arm.from_toml(EXAMPLE).to_dict()
    for act in d["actuator"]:
        act.pop("min_length_mm", None)
        act.pop("max_length_mm", None)
        act["max_force_n"] = 6000.0
    rng = np.random.default_rng(3)
    rows = 3000
    alpha = np.array([0.0, -60.0, -90.0]) + np.array([170.0, 150.0, 180.0]) * rng.random((rows, 3))
    # actuator 2's stroke: the middle 90 % of the lengths the random poses ask of it
    lengths = eodarm.forward(eodarm.Arm.from_dict(d), alpha)["length_mm"][:, 1]
    d["actuator"][1]["min_length_mm"] = float(np.quantile(lengths, 0.05))
    d["actuator"][1]["max_length_mm"] = float(np.quantile(lengths, 0.95))
    arm = eodarm.Arm.from_dict(d)
    # The chassis' tilt turns the rigid loaded triangle of link 1 over near 180° (the exact
    # closure keeps each triangle's side; the rigid pose the status reads has no tilt).
    flat = [
        pose_from_joint_angles(arm, [side, 1.0, 1.0], [phi, 90.0, 90.0])
        for side in (1.0, -1.0)
        for phi in np.linspace(160.0, 179.0, 39)
    ]
    alpha = np.vstack([alpha, flat])
    mass = np.concatenate([40.0 * rng.random(rows), np.full(len(flat), 20.0)])
    soft = [
        eodarm.Effect("actuator_compliance", "M3", stiffness_n_per_mm=40.0),
        eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=5e5),
    ]
    payload = np.column_stack([np.zeros_like(mass), -mass * arm.g])
    out = _core.solve(_core_arm(arm), alpha, payload, *effect_arrays(soft, 3), True, True)
    ok = np.isfinite(out["dy_mm"])
    solved = {k: v[ok] for k, v in out.items()}
    ref = status(arm, alpha[ok], payload[ok], solved, load_rise=checks_load_rise(arm, soft))
    keep = ~near_threshold(arm, alpha[ok], payload[ok], solved)
    np.testing.assert_array_equal(out["status"][ok][keep], ref[keep])
    assert set(np.unique(out["status"])) == {0, 1, 2, 3, 4, 5}


def test_failed_poses_are_nan_with_the_status_of_what_is_known() -> None:
    """A singular pose and a triangle that cannot close: NaN rows (``nan_on_failure``) with
    near_singular and large_deflection; without it, the one-line error names the row."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    o1, b0, a1 = np.array(arm.O1), np.array(arm.B0), np.array(arm.links[0].A)
    away = o1 - b0
    singular = math.degrees(math.atan2(away[1], away[0]) - math.atan2(a1[1], a1[0]))
    alpha = np.array([[80.0, 10.0, 0.0], [singular, 10.0, 0.0], [80.0, 10.0, 0.0]])
    payload = np.array([[0.0, -50.0], [0.0, -50.0], [0.0, -1e9]])
    codes = effect_arrays([], 3)
    out = _core.solve(_core_arm(arm), alpha, payload, *codes, True, True)
    assert np.isfinite(out["dy_mm"][0]) and np.isnan(out["dy_mm"][1:]).all()
    assert list(out["status"]) == [0, 2, 5]
    with pytest.raises(ValueError, match="row 1") as exc:
        _core.solve(_core_arm(arm), alpha, payload, *codes, True, False)
    assert "\n" not in str(exc.value)
    with pytest.raises(ValueError, match="row 1"):
        eodarm.solve(arm, alpha[:2], 1.0)


# ---------------------------------------------------------------------------- out=
def test_out_round_trip() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    rng = np.random.default_rng(5)
    alpha = np.array([60.0, 0.0, -10.0]) + np.array([50.0, 30.0, 20.0]) * rng.random((3000, 3))
    mass = 8.0 * rng.random(3000)
    effects = [eodarm.Effect("joint_clearance", "O2", clearance_mm=0.1)]
    ref = eodarm.solve(arm, alpha, mass, effects)
    out = {k: np.full_like(v, 7) for k, v in ref.items()}
    got = eodarm.solve(arm, alpha, mass, effects, out=out)
    assert set(got) == set(ref)
    for key in ref:
        assert got[key] is out[key], key  # written in place, not copied
        np.testing.assert_array_equal(got[key], ref[key], err_msg=key)
    # a second call overwrites every value
    again = eodarm.solve(arm, alpha[::-1].copy(), mass[::-1].copy(), effects, out=out)
    np.testing.assert_array_equal(again["dy_mm"], ref["dy_mm"][::-1])


def bad_outs(ref: dict) -> list[tuple[str, dict]]:
    """(key the message must name, out dict) for each kind of wrong output."""
    good = {k: np.empty_like(v) for k, v in ref.items()}
    cases = []
    missing = dict(good)
    del missing["dl_mm"]
    cases.append(("dl_mm", missing))
    cases.append(("dx_mm", {**good, "dx_mm": np.empty(len(ref["dx_mm"]) + 1)}))
    cases.append(("force_n", {**good, "force_n": good["force_n"].astype(np.float32)}))
    cases.append(("status", {**good, "status": good["status"].astype(np.int64)}))
    cases.append(("length_mm", {**good, "length_mm": np.asfortranarray(good["length_mm"])}))
    frozen = np.empty_like(good["dy_mm"])
    frozen.flags.writeable = False
    cases.append(("dy_mm", {**good, "dy_mm": frozen}))
    cases.append(("dforce_n", {**good, "dforce_n": good["force_n"]}))
    cases.append(("sigma_dx_mm", {**good, "sigma_dx_mm": np.empty(3)}))
    cases.append(("dalpha_deg", {**good, "dalpha_deg": good["dalpha_deg"].tolist()}))
    return cases


def test_wrong_out_is_a_one_line_input_error_naming_the_key() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = np.array([[80.0, 10.0, 0.0], [85.0, 12.0, 1.0]])
    ref = eodarm.solve(arm, alpha, 2.0)
    for key, out in bad_outs(ref):
        with pytest.raises(InputError) as exc:
            eodarm.solve(arm, alpha, 2.0, out=out)
        msg = str(exc.value)
        assert key in msg and "\n" not in msg, msg
    with pytest.raises(InputError, match="out"):
        eodarm.solve(arm, alpha, 2.0, backend="numpy", out={})
    with pytest.raises(InputError, match="dict"):
        eodarm.solve(arm, alpha, 2.0, out=[1, 2])  # type: ignore[arg-type]


def test_the_binding_refuses_wrong_out_itself() -> None:
    """Called directly, the core checks ``out`` too (a ValueError naming the key, no crash)."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = np.array([[80.0, 10.0, 0.0], [85.0, 12.0, 1.0]])
    ref = eodarm.solve(arm, alpha, 2.0)
    payload = np.array([[0.0, -19.62], [0.0, -19.62]])
    for key, out in bad_outs(ref):
        if key == "sigma_dx_mm":
            continue  # the core ignores keys it does not write
        with pytest.raises(ValueError, match=key):
            _core.solve(_core_arm(arm), alpha, payload, *effect_arrays([], 3), True, out=out)
