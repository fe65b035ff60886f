"""Load sequences and the two friction elements (docs/model.md, "Load sequences and friction").

Physical facts: zero friction is the frictionless model; a monotonic loading is a row of single
loadings; the loading and unloading branches bracket the frictionless curve, 2·L/k apart where
the element slips; a cycle without friction and gap comes back; friction leaves L/k at the
return; every body is in equilibrium with the friction couple. And ``solve_sequence`` equals
an exact simulation of the sequence written here, state by state, through ``eodarm.solve``
with the frictions and gaps expressed as the length changes and pin offsets they cause.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.errors import EodarmError
from eodarm.model.effects import UNLOADED
from eodarm.model.solver import statics
from simulation import MOTION, simulate
from strategies import arm_and_poses, effects_for
from test_physics import residuals

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
POSE = [[90.0, 10.0, 0.0]]
#: The campaign of the seed paper's kind: loaded and unloaded in one go (kg).
CYCLE = np.array([0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0])
#: Both sides close the same pose from the same causes: they differ by rounding of sums of
#: terms of up to ~1e3 mm (1e-13 mm), far below this.
EXACT_MM = 1e-9
FRICTIONS = ("actuator_friction", "joint_friction")
GAPS = ("actuator_play", "joint_clearance")


def example() -> eodarm.Arm:
    return eodarm.Arm.from_toml(EXAMPLE)


@st.composite
def sequence_cases(draw, max_links: int = 4):
    """A plausible arm, one pose per sequence (1–3), S = 1–8 payloads of 0–8 kg, and effects
    with at least one friction (no link bending beside a joint friction, see simulate)."""
    arm, alpha, _ = draw(arm_and_poses(max_links=max_links, max_poses=3))
    states = draw(st.integers(1, 8))
    masses = draw(
        st.lists(
            st.lists(st.floats(0.0, 8.0), min_size=states, max_size=states),
            min_size=alpha.shape[0],
            max_size=alpha.shape[0],
        )
    )
    frictions = draw(effects_for(arm, FRICTIONS, max_size=3, min_size=1))
    kinds = tuple(k for k in eodarm.CATALOGUE if k not in FRICTIONS)
    if any(f.name == "joint_friction" for f in frictions):
        kinds = tuple(k for k in kinds if k != "link_bending")
    others = draw(effects_for(arm, kinds, max_size=4, unloaded=UNLOADED))
    return arm, alpha, np.array(masses, dtype=float), frictions + others


# ---------------------------------------------------------------------------- the simulation
@settings(max_examples=40, deadline=None)
@given(case=sequence_cases(), self_weight=st.booleans())
def test_solve_sequence_equals_an_exact_simulation_of_the_sequence(case, self_weight) -> None:
    arm, alpha, masses, effects = case
    out = eodarm.solve_sequence(arm, alpha, masses, effects, self_weight=self_weight)
    for q in range(alpha.shape[0]):
        sim = simulate(arm, alpha[q], masses[q], effects, self_weight)
        for k in MOTION:
            np.testing.assert_allclose(out[k][q], sim[k], rtol=0, atol=EXACT_MM, err_msg=k)
        # forces: 1e-9 relative to the largest force of the sequence
        scale = max(1.0, float(np.abs(sim["force_n"]).max()))
        for k in ("force_n", "reaction_n"):
            np.testing.assert_allclose(out[k][q], sim[k], rtol=0, atol=1e-9 * scale, err_msg=k)


@settings(max_examples=25, deadline=None)
@given(case=sequence_cases(), self_weight=st.booleans())
def test_every_body_is_in_equilibrium_with_the_friction_couple(case, self_weight) -> None:
    arm, alpha, masses, effects = case
    out = eodarm.solve_sequence(arm, alpha, masses, effects, self_weight=self_weight)
    n, states = arm.n, masses.shape[1]
    pose = np.repeat(alpha, states, axis=0)
    flat = masses.reshape(-1)
    payload = np.column_stack([np.zeros_like(flat), -flat * arm.g])
    force = out["force_n"].reshape(-1, n)
    net_f, net_m, scale = residuals(
        arm, pose, payload, force, out["reaction_n"].reshape(-1, n, 2), self_weight
    )
    # The friction couple of joint i, (ΔF_i − S_i)·h_i, acts on link i (and its opposite on
    # body i−1); ΔF_i is the frictionless change, S_i what the actuator took.
    st_ = statics(arm, pose, flat, "numpy", self_weight)
    geo = eodarm.forward(arm, pose, backend="numpy")
    o, a, b = geo["O"][:, :n], geo["A"], geo["B"]
    e = (a - b) / np.linalg.norm(a - b, axis=-1)[..., None]
    h = (a - o)[..., 0] * e[..., 1] - (a - o)[..., 1] * e[..., 0]
    couple = (st_["force_n"] - force) * h
    net_m = net_m + couple
    net_m[:, :-1] -= couple[:, 1:]
    size = np.abs(geo["O"] - geo["O"][:, :1]).max() + 200.0
    tol = 1e-9 * np.maximum(scale, np.abs(st_["force_n"]).max(axis=1)).clip(1.0)
    assert (np.linalg.norm(net_f, axis=-1) <= tol[:, None]).all()
    assert (np.abs(net_m) <= tol[:, None] * size).all()


# ---------------------------------------------------------------------------- limits
@settings(max_examples=25, deadline=None)
@given(case=sequence_cases(), self_weight=st.booleans())
def test_zero_friction_is_the_frictionless_model(case, self_weight) -> None:
    arm, alpha, masses, effects = case
    zero = [
        eodarm.Effect(f.name, f.at, **{eodarm.CATALOGUE[f.name].param: 0.0})
        if f.name in FRICTIONS
        else f
        for f in effects
    ]
    without = [f for f in effects if f.name not in FRICTIONS]
    a = eodarm.solve_sequence(arm, alpha, masses, zero, self_weight=self_weight)
    b = eodarm.solve_sequence(arm, alpha, masses, without, self_weight=self_weight)
    # each state of a frictionless sequence is a single loading from the reference
    states = masses.shape[1]
    single = eodarm.solve(
        arm, np.repeat(alpha, states, 0), masses.reshape(-1), without, self_weight=self_weight
    )
    for k in (*MOTION, "force_n"):
        # a runs the general path (it has frictions), b the block kernel: equal to rounding
        np.testing.assert_allclose(a[k], b[k], rtol=1e-9, atol=EXACT_MM, err_msg=k)
        np.testing.assert_allclose(
            b[k].reshape(single[k].shape), single[k], rtol=1e-9, atol=EXACT_MM, err_msg=k
        )


@settings(max_examples=25, deadline=None)
@given(case=sequence_cases(), self_weight=st.booleans())
def test_a_monotonic_loading_is_a_row_of_single_loadings(case, self_weight) -> None:
    arm, alpha, masses, effects = case
    masses = np.sort(masses, axis=1)  # every force change grows in size with the payload
    out = eodarm.solve_sequence(arm, alpha, masses, effects, self_weight=self_weight)
    states = masses.shape[1]
    single = eodarm.solve(
        arm, np.repeat(alpha, states, 0), masses.reshape(-1), effects, self_weight=self_weight
    )
    for k in (*MOTION, "force_n"):
        np.testing.assert_allclose(
            out[k].reshape(single[k].shape), single[k], rtol=1e-9, atol=EXACT_MM, err_msg=k
        )


def test_a_cycle_without_friction_or_gap_comes_back() -> None:
    arm = example()
    elastic = [
        eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=1500.0),
        eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
        eodarm.Effect("link_bending", "L2", ei_n_mm2=2e9),
        eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=2e8),
    ]
    out = eodarm.solve_sequence(arm, POSE, CYCLE, elastic)
    assert abs(out["dy_mm"][0, 3]) > 1.0  # the arm did sag
    for k in MOTION:  # the closure of a zero length change is exact: rounding only
        np.testing.assert_allclose(out[k][0, -1], 0.0, rtol=0, atol=1e-12, err_msg=k)


def test_solve_of_a_friction_is_the_deadband() -> None:
    arm = example()
    d_f = np.array([-1.0, 1.0]) @ statics(arm, POSE * 2, [0.0, 5.0])["force_n"]  # (n,)
    k = arm.actuators[1].stiffness_n_per_mm
    for limit in (0.5 * abs(d_f[1]), 2.0 * abs(d_f[1])):
        eff = [eodarm.Effect("actuator_friction", "M2", friction_n=limit)]
        out = eodarm.solve(arm, POSE, 5.0, eff)
        held = math.copysign(max(0.0, abs(d_f[1]) - limit), d_f[1])
        assert out["dl_mm"][0, 1] == pytest.approx(-held / k, abs=1e-12)


# ---------------------------------------------------------------------------- hysteresis
def branches(arm: eodarm.Arm, effects: list[eodarm.Effect]) -> dict[str, np.ndarray]:
    """The CYCLE with ``effects``, and without its frictions."""
    out = eodarm.solve_sequence(arm, POSE, CYCLE, effects)
    free = eodarm.solve_sequence(arm, POSE, CYCLE, [])
    return {"with": out, "free": free}


def sag_per_length(arm: eodarm.Arm, i: int, mass: float, dl: float) -> float:
    """dy (mm) added by lengthening actuator i's body by ``dl`` at payload ``mass``."""
    seen = np.zeros((1, arm.n))
    seen[0, i] = dl
    a = eodarm.solve(arm, POSE, mass, extra={"extra_seen_mm": seen})["dy_mm"][0]
    return float(a - eodarm.solve(arm, POSE, mass)["dy_mm"][0])


@pytest.mark.parametrize(
    ("name", "param", "i", "limit_of"),
    [
        ("actuator_friction", "friction_n", 1, lambda r: 20.0),
        ("joint_friction", "torque_nmm", 1, lambda r: 20.0 * r),
    ],
)
def test_branches_bracket_the_frictionless_curve_2l_over_k_apart(name, param, i, limit_of):
    """Loading 1.5 → 6.5 kg and back with L = 20 N: at 1.5 and 5 kg both branches slip (ΔF_2
    grows by 75 N/kg, so it moves by ≥ 112 N > 2L between the states), so the body's length
    differs between the branches by exactly 2L/k, and the sag by that length's effect."""
    arm = example()
    geo = eodarm.forward(arm, POSE)
    o, a, b = geo["O"][0, i], geo["A"][0, i], geo["B"][0, i]
    u = (a - b) / np.linalg.norm(a - b)
    r = abs((a - o)[0] * u[1] - (a - o)[1] * u[0])
    limit = 20.0
    eff = [eodarm.Effect(name, f"{'M' if name[0] == 'a' else 'O'}{i + 1}", **{param: limit_of(r)})]
    res = branches(arm, eff)
    out, free = res["with"], res["free"]
    k = arm.actuators[i].stiffness_n_per_mm
    for up, down in ((1, 5), (2, 4)):
        mass = CYCLE[up]
        gap = out["dl_mm"][0, down, i] - out["dl_mm"][0, up, i]
        # ΔF_2 > 0 (compression grows with the payload): the body is shorter unloading
        assert gap == pytest.approx(-2.0 * limit / k, rel=1e-9)
        dy_up, dy_down, dy_free = (
            x["dy_mm"][0, s] for x, s in ((out, up), (out, down), (free, up))
        )
        assert min(dy_up, dy_down) < dy_free < max(dy_up, dy_down)
        # The sag gap is the length gap through the closure: to first order, the sag a 2L/k
        # body change causes at this payload. The closure is exact, so the two differ by the
        # second-order terms of the length changes: (gap + loaded deflection)/(lever ~300 mm)
        # relative, a few 1e-4; 2e-3 leaves room and still fails for 1.5× or 0.5× the gap.
        expect = sag_per_length(arm, i, mass, gap)
        assert dy_down - dy_up == pytest.approx(expect, rel=2e-3)


def test_friction_leaves_l_over_k_at_the_return() -> None:
    """0 → 6.5 kg → 0: the element slips both ways (ΔF_2 = 486 N > 2L), so at the return it
    holds L against the body's spring: the body stays L/k short."""
    arm = example()
    limit, i = 60.0, 1
    out = eodarm.solve_sequence(
        arm, POSE, [6.5, 0.0], [eodarm.Effect("actuator_friction", "M2", friction_n=limit)]
    )
    k = arm.actuators[i].stiffness_n_per_mm
    assert out["dl_mm"][0, 1, i] == pytest.approx(-limit / k, rel=1e-9)
    # the sag left is that length's effect on the unloaded arm, to second order (see above)
    assert out["dy_mm"][0, 1] == pytest.approx(sag_per_length(arm, i, 0.0, -limit / k), rel=2e-3)
    assert abs(out["dy_mm"][0, 1]) > 1e-3


def test_a_centred_gap_stays_along_the_self_weight_at_the_return() -> None:
    arm = example()
    play = [eodarm.Effect("actuator_play", "M3", play_mm=0.1)]
    out = eodarm.solve_sequence(arm, POSE, [6.5, 0.0], play)
    once = eodarm.solve(arm, POSE, 0.0, play)
    # The self-weight pushes the same way as at the reference's zeroing: taken up, not centred
    for k in MOTION:
        np.testing.assert_allclose(out[k][0, 1], once[k][0], rtol=0, atol=EXACT_MM)
    assert abs(out["dl_mm"][0, 1, 2]) == 0.0 and abs(out["dy_mm"][0, 1]) > 1e-3


# ---------------------------------------------------------------------------- the API
def test_masses_broadcast_and_bad_input_names_the_state() -> None:
    arm = example()
    two = np.array(POSE * 2)
    a = eodarm.solve_sequence(arm, two, CYCLE)
    b = eodarm.solve_sequence(arm, two, np.tile(CYCLE, (2, 1)))
    np.testing.assert_array_equal(a["dy_mm"], b["dy_mm"])
    assert a["dy_mm"].shape == (2, CYCLE.size) and a["force_n"].shape == (2, CYCLE.size, 3)
    assert a["status"].shape == (2, CYCLE.size)
    with pytest.raises(EodarmError, match=r"sequence 1, state 2"):
        eodarm.solve_sequence(arm, two, [[0.0, 1.0, 2.0], [0.0, 1.0, -2.0]])
    with pytest.raises(EodarmError, match=r"mass_kg: expected shape \(2, S\)"):
        eodarm.solve_sequence(arm, two, np.zeros((3, 4)))
