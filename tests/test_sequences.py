"""Physics of load sequences in the numpy reference (docs/model.md, "Load sequences").

Every test runs ``eodarm.model.reference.solve_sequence`` (backend numpy), so it holds with or
without the compiled core's sequences. Tolerances: 1e-9 mm / N where two computations follow
the same arithmetic in a different order (rounding only); looser ones are explained where used.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

import eodarm
from arms import example_arm, four_link_arm, two_link_arm
from eodarm.analysis.synth import random_configs
from eodarm.model import reference
from eodarm.model.effects import UNLOADED
from strategies import ALL_KINDS, arm_and_poses, effects_for
from strategies import FRICTIONS as FRICTION_KINDS

E = eodarm.Effect
POSES3 = np.array([[90.0, 10.0, 0.0], [70.0, 20.0, -10.0], [110.0, -5.0, -20.0]])
CYCLE = [1.5, 5.0, 6.5, 5.0, 1.5, 0.0]

ELASTIC = [
    E("mount_compliance", "M3", stiffness_n_per_mm=900.0),
    E("link_bending", "L2", ei_n_mm2=5e9),
    E("base_compliance", "base", stiffness_nmm_per_rad=4e8),
]
FRICTIONS = [
    E("actuator_friction", "M2", friction_n=80.0),
    E("joint_friction", "O3", torque_nmm=3000.0),
    E("joint_friction", "O1", torque_nmm=20000.0),
    E("actuator_friction", "M1", friction_n=50.0),
]
GAPS = [
    E("joint_clearance", "O2", clearance_mm=0.1),
    E("actuator_play", "M1", play_mm=0.05, unloaded="taken_up"),
]
KEYS = ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "dlength_mm", "force_n", "reaction_n")


def _close(a: np.ndarray, b: np.ndarray, tol: float = 1e-9) -> None:
    np.testing.assert_allclose(a, b, rtol=0, atol=tol)


def test_monotonic_loading_equals_single_loadings() -> None:
    """Loading only up, every friction slips in the direction it was loaded from the start,
    so each state is the single loading from the reference (the deadband)."""
    arm = example_arm()
    masses = np.array([0.5, 1.5, 3.0, 5.0, 6.5, 9.0])
    effs = ELASTIC + FRICTIONS + GAPS
    seq = reference.solve_sequence(arm, POSES3, masses, effects=effs)
    for s, m in enumerate(masses):
        one = reference.solve(arm, POSES3, np.full(3, m), effects=effs)
        for key in KEYS:
            _close(seq[key][:, s], one[key])


def test_zero_friction_is_frictionless_whatever_the_order() -> None:
    """With zero limits nothing is held: every state of a cycle (up, down, up again) equals
    the frictionless single loading, gaps included (they follow each state's force)."""
    arm = example_arm()
    masses = np.array([5.0, 1.0, 6.5, 0.0, 3.0])
    zero = [e.with_value(0.0) for e in FRICTIONS]
    seq = reference.solve_sequence(arm, POSES3, masses, effects=ELASTIC + GAPS + zero)
    for s, m in enumerate(masses):
        one = reference.solve(arm, POSES3, np.full(3, m), effects=ELASTIC + GAPS)
        for key in KEYS:
            _close(seq[key][:, s], one[key])


def test_single_loading_with_friction_is_the_deadband() -> None:
    """``solve`` (one loading) with an actuator friction: the body's sensor sees
    −sign(ΔF)·max(0, |ΔF| − L)/k, ΔF the frictionless force change."""
    arm = example_arm()
    masses = np.array([0.2, 1.0, 6.5])
    free = reference.solve(arm, POSES3, masses)
    limit = 60.0
    fr = reference.solve(
        arm, POSES3, masses, effects=[E("actuator_friction", "M2", friction_n=limit)]
    )
    df = free["dforce_n"][:, 1]
    k = arm.actuators[1].stiffness_n_per_mm
    _close(fr["dl_mm"][:, 1], -np.sign(df) * np.maximum(0.0, np.abs(df) - limit) / k, 1e-12)
    assert abs(df[0]) < limit  # the smallest payload sticks: nothing seen
    _close(fr["dl_mm"][:, 1][0], 0.0, 0.0)


def test_cycle_without_friction_or_centred_gap_returns_to_zero() -> None:
    arm = example_arm()
    seq = reference.solve_sequence(arm, POSES3, CYCLE, effects=ELASTIC + GAPS[1:])
    for key in ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "dlength_mm"):
        # closing the pose of a ~1000 mm arm rounds at ~1e-12 mm
        _close(seq[key][:, -1], np.zeros_like(seq[key][:, -1]), 1e-9)


def test_centred_gap_stays_where_the_last_force_pushed_it() -> None:
    """A centred clearance closed by the first load does not re-centre at the return: the
    return equals the zero-payload single loading (the gap along the self-weight force)."""
    arm = example_arm()
    gap = [E("joint_clearance", "O2", clearance_mm=0.1)]
    seq = reference.solve_sequence(arm, POSES3, CYCLE, effects=gap)
    zero = reference.solve(arm, POSES3, np.zeros(3), effects=gap)
    _close(seq["dy_mm"][:, -1], zero["dy_mm"])
    assert np.all(np.abs(seq["dy_mm"][:, -1]) > 1e-3)  # 0.1 mm of clearance shows


def test_return_residue_is_limit_over_stiffness() -> None:
    """After a load that slipped both ways, what stays at the return is the limit: the body's
    sensor of an actuator friction reads L/k_i; a joint friction leaves L·(1/k_i + 1/k_m) in
    the actuator's pin-to-pin length, L = T/r_i."""
    arm = example_arm()
    k = np.array([a.stiffness_n_per_mm for a in arm.actuators])
    big = [0.0, 9.0, 0.0]  # 9 kg: force changes well beyond twice the limits
    free = reference.solve(arm, POSES3, np.full(3, 9.0))
    limit = 40.0
    seq = reference.solve_sequence(
        arm, POSES3, big[1:], effects=[E("actuator_friction", "M2", friction_n=limit)]
    )
    assert np.all(np.abs(free["dforce_n"][:, 1]) > 2 * limit)
    _close(np.abs(seq["dl_mm"][:, -1, 1]), np.full(3, limit / k[1]), 1e-12)
    # The residue has the sign of the loading's: the body stays compressed if it was.
    assert np.all(np.sign(seq["dl_mm"][:, -1, 1]) == np.sign(seq["dl_mm"][:, 0, 1]))

    geo = eodarm.forward(arm, POSES3, backend="numpy")
    a, b, o = geo["A"][:, 2], geo["B"][:, 2], geo["O"][:, 2]
    u = (a - b) / np.linalg.norm(a - b, axis=-1, keepdims=True)
    r = np.abs((a - o)[:, 0] * u[:, 1] - (a - o)[:, 1] * u[:, 0])
    torque = 1500.0
    km = 800.0
    effs = [
        E("joint_friction", "O3", torque_nmm=torque),
        E("mount_compliance", "M3", stiffness_n_per_mm=km),
    ]
    assert np.all(np.abs(free["dforce_n"][:, 2]) > 2 * torque / r)
    seq = reference.solve_sequence(arm, POSES3, big[1:], effects=effs)
    expect = torque / r * (1 / k[2] + 1 / km)
    _close(np.abs(seq["dlength_mm"][:, -1, 2]), expect, 1e-12)
    _close(np.abs(seq["dl_mm"][:, -1, 2]), torque / r / k[2], 1e-12)
    # and the measure point does not come back: the return sag is of the order of the residue
    assert np.all(np.abs(seq["dy_mm"][:, -1]) > 1e-3)


def test_branches_bracket_the_frictionless_curve_with_gap_two_limits() -> None:
    """Up 0→10 kg and back: at each payload the loading and unloading branches of the body's
    sensor lie on either side of the frictionless value, 2L/k apart where both slipped."""
    arm = example_arm()
    up = [1.0, 2.0, 4.0, 6.0, 8.0]
    masses = [*up, 10.0, *up[::-1]]
    limit = 30.0
    k = arm.actuators[1].stiffness_n_per_mm
    seq = reference.solve_sequence(
        arm, POSES3, masses, effects=[E("actuator_friction", "M2", friction_n=limit)]
    )
    free = reference.solve(arm, POSES3[:, None].repeat(5, 1).reshape(-1, 3), np.tile(up, 3))
    f_dl = free["dl_mm"][:, 1].reshape(3, 5)
    f_df = free["dforce_n"][:, 1].reshape(3, 5)
    f_top = reference.solve(arm, POSES3, np.full(3, 10.0))["dforce_n"][:, 1]
    load = seq["dl_mm"][:, :5, 1]
    unload = seq["dl_mm"][:, 6:, 1][:, ::-1]
    lo, hi = np.minimum(load, unload), np.maximum(load, unload)
    assert np.all(lo <= f_dl + 1e-12) and np.all(f_dl <= hi + 1e-12)
    slipped = (np.abs(f_df) > limit) & (np.abs(f_top[:, None] - f_df) > 2 * limit)
    assert slipped.sum() >= 6  # the test means something
    _close(np.abs(unload - load)[slipped], np.full(slipped.sum(), 2 * limit / k), 1e-12)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@pytest.mark.parametrize("make_arm", [example_arm, two_link_arm, four_link_arm])
def test_every_body_is_in_equilibrium_with_the_friction_couple(make_arm) -> None:  # type: ignore[no-untyped-def]
    """At every state of a cycle with joint frictions, each link balances its weights, the
    payload, the actual actuator forces and joint reactions returned, and the friction
    couples (ΔF_i − S_i)·h_i on link i, −(ΔF_{i+1} − S_{i+1})·h_{i+1} from the next joint;
    S_i is the returned force change, ΔF_i the frictionless one."""
    arm = make_arm()
    n = arm.n
    alpha = random_configs(arm, 1, np.random.default_rng(3))
    effs = [E("joint_friction", f"O{i + 1}", torque_nmm=800.0 * (i + 1)) for i in range(n)]
    masses = np.array([2.0, 5.0, 2.0, 0.0])
    seq = reference.solve_sequence(arm, alpha, masses, effects=effs)
    geo = eodarm.forward(arm, alpha, backend="numpy")
    o, a, b, c = geo["O"][0], geo["A"][0], geo["B"][0], geo["C"][0]
    u = (a - b) / np.linalg.norm(a - b, axis=-1, keepdims=True)
    h = _cross(a - o[:n], u)
    g = arm.g
    for s, m in enumerate(masses):
        free = reference.solve(arm, alpha, [m])
        f = seq["force_n"][0, s]
        r = seq["reaction_n"][0, s]
        couple = (free["dforce_n"][0] - seq["dforce_n"][0, s]) * h
        for i in range(n):
            loads = [(a[i], f[i] * u[i]), (o[i], r[i])]
            loads.append((c[i], np.array([0.0, -arm.links[i].mass_kg * g])))
            loads.append((a[i], np.array([0.0, -0.5 * arm.actuators[i].mass_kg * g])))
            mz = couple[i]
            if i + 1 < n:
                loads += [(b[i + 1], -f[i + 1] * u[i + 1]), (o[i + 1], -r[i + 1])]
                loads.append((b[i + 1], np.array([0.0, -0.5 * arm.actuators[i + 1].mass_kg * g])))
                mz -= couple[i + 1]
            else:
                loads.append((o[n], np.array([0.0, -m * g])))
            fsum = sum(v for _, v in loads)
            mz += sum(_cross(p, v) for p, v in loads)
            # N and N·mm: sums of forces up to ~1e3 N over lever arms up to ~1e3 mm.
            _close(fsum, np.zeros(2), 1e-8)
            _close(mz, 0.0, 1e-5)
    assert (
        np.abs(seq["dforce_n"] - reference.solve_sequence(arm, alpha, masses)["dforce_n"]).max()
        > 1.0
    )


@settings(max_examples=25, deadline=None)
@given(case=arm_and_poses(max_poses=4), data=st.data())
def test_monotonic_loading_is_single_loadings_on_random_arms(case, data) -> None:  # type: ignore[no-untyped-def]
    """On hypothesis arms with random effects (frictions, gaps taken up or centred, springs),
    a sequence of rising payloads equals the single loadings state by state, and the same
    payloads in any order equal them when every friction limit is 0."""
    arm, alpha, _ = case
    effs = data.draw(
        effects_for(arm, kinds=(*ALL_KINDS, *FRICTION_KINDS), max_size=4, unloaded=UNLOADED),
        label="effects",
    )
    rising = np.sort(data.draw(st.lists(st.floats(0.0, 8.0), min_size=1, max_size=4)))
    try:
        seq = reference.solve_sequence(arm, alpha, rising, effects=effs)
    except eodarm.EodarmError:
        event("not closable")
        return  # a pose the loaded model cannot close: nothing to compare
    for s, m in enumerate(rising):
        one = reference.solve(arm, alpha, np.full(alpha.shape[0], m), effects=effs)
        for key in KEYS:
            # same arithmetic, another order of the states: rounding of ~1000 mm coordinates
            _close(seq[key][:, s], one[key], 1e-8)
    free = [e.with_value(0.0) if e.name in FRICTION_KINDS else e for e in effs]
    order = np.array(data.draw(st.permutations(rising.tolist())))
    seq = reference.solve_sequence(arm, alpha, order, effects=free)
    for s, m in enumerate(order):
        one = reference.solve(arm, alpha, np.full(alpha.shape[0], m), effects=free)
        for key in KEYS:
            _close(seq[key][:, s], one[key], 1e-8)


@pytest.mark.parametrize("make_arm", [two_link_arm, example_arm, four_link_arm])
def test_cycle_returns_are_where_each_cycle_ends(make_arm) -> None:  # type: ignore[no-untyped-def]
    """``cycle_returns`` (what ``sweep(..., cycle=True)`` uses with frictions) gives, for
    every pose and mass, the last state of ``solve_sequence(..., [m, 0])``: the same numbers
    (the same compiled path, 1e-12 mm allows the rounding of nothing else), and a friction
    that holds leaves the arm off its reference."""
    from eodarm.model.solver import cycle_returns

    arm = make_arm()
    n = arm.n
    effects = [
        eodarm.Effect("actuator_friction", f"M{n}", friction_n=60.0),
        eodarm.Effect("joint_friction", "O1", torque_nmm=4000.0),
        eodarm.Effect("joint_clearance", f"O{n}", clearance_mm=0.1),
    ]
    alpha = random_configs(arm, 6, np.random.default_rng(n))
    mass = np.array([0.0, 1.5, 6.5])
    dx, dy = cycle_returns(arm, alpha, mass, effects)
    assert dx.shape == dy.shape == (6, 3)
    for j, m in enumerate(mass):
        seq = eodarm.solve_sequence(arm, alpha, [m, 0.0], effects)
        np.testing.assert_allclose(dx[:, j], seq["dx_mm"][:, 1], rtol=0, atol=1e-12)
        np.testing.assert_allclose(dy[:, j], seq["dy_mm"][:, 1], rtol=0, atol=1e-12)
    assert np.abs(dy[:, 2]).max() > 1e-3


def test_cycle_returns_refuses_what_it_cannot_take() -> None:
    from eodarm.errors import InputError
    from eodarm.model.solver import cycle_returns

    arm = example_arm()
    fric = eodarm.Effect("actuator_friction", "M2", friction_n=60.0)
    with pytest.raises(InputError, match="row 1"):
        cycle_returns(arm, [[90.0, 10.0, 0.0], [90.0, np.nan, 0.0]], [1.5], [fric])
    with pytest.raises(InputError, match="mass_kg"):
        cycle_returns(arm, [[90.0, 10.0, 0.0]], [-1.0], [fric])
    from eodarm.model import custom

    def nudge(state: eodarm.EffectState, i: int, mm: float) -> dict:
        return {"unseen_mm": np.full(state.force_n.shape[0], mm)}

    eodarm.custom_effect("nudge", places="M", parameter="mm")(nudge)
    try:
        user = eodarm.Effect("nudge", "M2", mm=0.1)
        with pytest.raises(InputError, match="custom effect nudge@M2"):
            cycle_returns(arm, [[90.0, 10.0, 0.0]], [1.5], [fric, user])
    finally:
        custom.unregister("nudge")
