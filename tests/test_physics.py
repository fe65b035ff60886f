"""Physical facts that the solver (Rust backend, through the public API) must respect.

Equilibrium of every body, hand statics, zero load → zero deflection, linearity to second order,
bounded clearance and play, rigid chassis tilt, Maxwell–Betti reciprocity, sign conventions and
what each actuator channel sees.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from strategies import (
    ELASTIC,
    MAX_PAYLOAD_KG,
    arm_and_poses,
    arms,
    effect_at,
    effects_for,
    measuring_at_load_point,
    payload_vectors,
    poses_for,
    rigid_copy,
)

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
#: Below this force (N) play and clearance have no preferred side (docs/model.md §4).
FORCE_ZERO_N = 1e-9
MOTION_KEYS = ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "dlength_mm")


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def rot(theta: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate rows of v (N, 2) by theta (N,) radians."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=-1)


def mass_payload(arm: eodarm.Arm, mass: np.ndarray) -> np.ndarray:
    m = np.broadcast_to(np.asarray(mass, dtype=float), (np.size(mass),))
    return np.column_stack([np.zeros_like(m), -m * arm.g])


# ---------------------------------------------------------------------------- equilibrium
def residuals(
    arm: eodarm.Arm,
    alpha: np.ndarray,
    payload: np.ndarray,
    force: np.ndarray,
    reaction: np.ndarray,
    self_weight: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Net force (N, n, 2) and net moment about O_i (N, n) on every link, and the load scale.

    Loads on link i (docs/model.md §1–§2): R_i at O_i; +F_i e_i at A_i; −F_{i+1} e_{i+1} at
    B_i; −R_{i+1} at O_{i+1}; its weight at C_i; half of actuator i's weight at A_i and half of
    actuator i+1's at B_i; on the last link the payload at the load point.
    """
    geo = eodarm.forward(arm, alpha)
    o, a, b, c = geo["O"], geo["A"], geo["B"], geo["C"]
    e = (a - b) / np.linalg.norm(a - b, axis=-1)[..., None]
    g = arm.g if self_weight else 0.0
    n = arm.n
    rows = alpha.shape[0]
    net_f = np.zeros((rows, n, 2))
    net_m = np.zeros((rows, n))
    scale = np.zeros(rows)
    down = np.array([0.0, -1.0])
    for i in range(n):
        loads = [
            (o[:, i], reaction[:, i]),
            (a[:, i], force[:, i, None] * e[:, i]),
            (c[:, i], np.broadcast_to(arm.links[i].mass_kg * g * down, (rows, 2))),
            (a[:, i], np.broadcast_to(0.5 * arm.actuators[i].mass_kg * g * down, (rows, 2))),
        ]
        if i + 1 < n:
            w_half = 0.5 * arm.actuators[i + 1].mass_kg * g * down
            loads += [
                (b[:, i + 1], -force[:, i + 1, None] * e[:, i + 1]),
                (o[:, i + 1], -reaction[:, i + 1]),
                (b[:, i + 1], np.broadcast_to(w_half, (rows, 2))),
            ]
        else:
            loads.append((o[:, n], payload))
        for p, f in loads:
            net_f[:, i] += f
            net_m[:, i] += cross(p - o[:, i], f)
            scale = np.maximum(scale, np.linalg.norm(f, axis=-1))
    return net_f, net_m, scale


@settings(max_examples=150, deadline=None)
@given(case=arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_every_link_is_in_equilibrium(case, self_weight, data) -> None:
    arm, alpha, _ = case
    payload = data.draw(payload_vectors(alpha.shape[0], g=arm.g), label="payload")
    # A joint friction takes part of the force change, and a friction's solve runs on the
    # general path (equal to rounding, not bits): test_friction.py checks their balance.
    kinds = tuple(k for k in eodarm.CATALOGUE if not k.endswith("_friction"))
    effects = data.draw(effects_for(arm, kinds), label="effects")
    out = eodarm.solve_payload(arm, alpha, payload, effects, self_weight=self_weight)
    net_f, net_m, scale = residuals(
        arm, alpha, payload, out["force_n"], out["reaction_n"], self_weight
    )
    # 1e-9 of the largest load on the body; moments with the arm's size (mm) as lever
    geo = eodarm.forward(arm, alpha)
    size = np.abs(geo["O"] - geo["O"][:, :1]).max() + 200.0
    tol = 1e-9 * np.maximum(scale, 1.0)
    assert (np.linalg.norm(net_f, axis=-1) <= tol[:, None]).all()
    assert (np.abs(net_m) <= tol[:, None] * size).all()
    # the forces come from the undeformed geometry: no effect changes them
    bare = eodarm.solve_payload(arm, alpha, payload, [], self_weight=self_weight)
    for key in ("force_n", "reaction_n", "dforce_n"):
        np.testing.assert_array_equal(out[key], bare[key], err_msg=key)
    # the loads are linear: the change of force is the response to the payload alone
    alone = eodarm.solve_payload(arm, alpha, payload, [], self_weight=False)
    np.testing.assert_allclose(
        out["dforce_n"],
        alone["force_n"],
        rtol=0,
        atol=1e-9 * max(1.0, np.abs(out["force_n"]).max()),
    )


@st.composite
def one_link_cases(draw):
    arm = draw(arms(st.just(1)))
    alpha = draw(poses_for(arm))
    return arm, alpha, draw(payload_vectors(alpha.shape[0], g=arm.g))


@settings(max_examples=100, deadline=None)
@given(case=one_link_cases(), self_weight=st.booleans())
def test_one_link_forces_match_hand_statics(case, self_weight) -> None:
    """Moments about O1: F·h + (L − O1) × P + weights = 0, then R = −(P + W) − F e."""
    arm, alpha, payload = case
    out = eodarm.solve_payload(arm, alpha, payload, self_weight=self_weight)
    lk, act = arm.links[0], arm.actuators[0]
    g = arm.g if self_weight else 0.0
    t = np.radians(alpha[:, 0])
    a_rel = rot(t, np.tile(lk.A, (len(t), 1)))
    c_rel = rot(t, np.tile(lk.C, (len(t), 1)))
    l_rel = rot(t, np.tile(lk.next, (len(t), 1)))
    d = np.asarray(arm.O1) + a_rel - np.asarray(arm.B0)
    e = d / np.linalg.norm(d, axis=-1)[:, None]
    h = cross(a_rel, e)
    w_link, w_half = lk.mass_kg * g, 0.5 * act.mass_kg * g
    moment = cross(l_rel, payload) - w_link * c_rel[:, 0] - w_half * a_rel[:, 0]
    f = -moment / h
    r = -(payload + np.array([0.0, -w_link - w_half])) - f[:, None] * e
    scale = 1e-10 * max(1.0, float(np.abs(f).max()))
    np.testing.assert_allclose(out["force_n"][:, 0], f, rtol=1e-9, atol=scale)
    np.testing.assert_allclose(out["reaction_n"][:, 0], r, rtol=1e-9, atol=scale)


# ---------------------------------------------------------------------------- zero load
@settings(max_examples=100, deadline=None)
@given(case=arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_zero_payload_gives_zero_deflection_for_elastic_effects(case, self_weight, data) -> None:
    arm, alpha, _ = case
    effects = data.draw(effects_for(arm, ELASTIC), label="effects")
    out = eodarm.solve(arm, alpha, 0.0, effects, self_weight=self_weight)
    np.testing.assert_array_equal(out["dforce_n"], 0.0)
    for key in MOTION_KEYS:
        np.testing.assert_allclose(out[key], 0.0, rtol=0, atol=1e-9, err_msg=key)


@settings(max_examples=100, deadline=None)
@given(case=arm_and_poses(), data=st.data())
def test_nothing_moves_without_any_load(case, data) -> None:
    """No payload and no self-weight: the loaded state carries no force, so neither the elastic
    effects nor play or clearance (no preferred side) move anything."""
    arm, alpha, _ = case
    effects = data.draw(effects_for(arm), label="effects")
    out = eodarm.solve(arm, alpha, 0.0, effects, self_weight=False)
    np.testing.assert_array_equal(out["force_n"], 0.0)
    np.testing.assert_array_equal(out["reaction_n"], 0.0)
    for key in MOTION_KEYS:
        np.testing.assert_allclose(out[key], 0.0, rtol=0, atol=1e-9, err_msg=key)


# ---------------------------------------------------------------------------- linearity
@settings(max_examples=80, deadline=None)
@given(case=arm_and_poses(max_poses=4), self_weight=st.booleans(), data=st.data())
def test_elastic_response_is_linear_to_second_order(case, self_weight, data) -> None:
    """d(2m) − 2·d(m) = O(m²): the forces are linear in the load and only the exact closure of
    the triangles adds curvature. Shrinking m tenfold shrinks that defect a hundredfold."""
    arm, alpha, _ = case
    effects = data.draw(effects_for(arm, ELASTIC), label="effects")

    def response(m: float) -> np.ndarray:
        o = eodarm.solve(arm, alpha, m, effects, self_weight=self_weight)
        # displacements in mm, link turns as mm of arc at 1 m
        return np.column_stack([o["dx_mm"], o["dy_mm"], 1000.0 * np.radians(o["dalpha_deg"])])

    m = MAX_PAYLOAD_KG / 4
    big = np.linalg.norm(response(2 * m) - 2 * response(m), axis=1)
    small = np.linalg.norm(response(0.2 * m) - 2 * response(0.1 * m), axis=1)
    # a pose whose payload line passes through every joint (a link hanging straight down
    # from its actuated joint) does not move at all: no defect to compare there
    moves = np.linalg.norm(response(2 * m), axis=1) > 1e-9
    ratio = big[moves] / small[moves]
    assert ((ratio > 100.0 / 3.0) & (ratio < 100.0 * 3.0)).all(), ratio


# ---------------------------------------------------------------------------- clearance, play
@settings(max_examples=100, deadline=None)
@given(
    case=arm_and_poses(),
    self_weight=st.booleans(),
    c=st.floats(0.01, 0.3),
    m=st.floats(0.5, MAX_PAYLOAD_KG),
    data=st.data(),
)
def test_joint_clearance_moves_the_joint_by_c_along_the_joint_force(
    case, self_weight, c, m, data
) -> None:
    arm, alpha, _ = case
    stiff = rigid_copy(arm)
    j = data.draw(st.integers(0, arm.n - 1), label="joint index")
    eff = [eodarm.Effect("joint_clearance", f"O{j + 1}", clearance_mm=c)]
    out = eodarm.solve(stiff, alpha, m, eff, self_weight=self_weight)
    # links before the joint do not move; the links after it turn together about it
    dalpha = out["dalpha_deg"]
    np.testing.assert_allclose(dalpha[:, :j], 0.0, atol=1e-9)
    np.testing.assert_allclose(dalpha[:, j:] - dalpha[:, j : j + 1], 0.0, atol=1e-9)
    # reconstruct the joint's displacement from the measure point's motion
    geo = eodarm.forward(stiff, alpha)
    lever = geo["measure"] - geo["O"][:, j]
    turn = np.radians(dalpha[:, j])
    moved = np.column_stack([out["dx_mm"], out["dy_mm"]]) - (rot(turn, lever) - lever)
    assert (np.linalg.norm(moved, axis=-1) <= c * (1 + 1e-9) + 1e-9).all()
    r = out["reaction_n"][:, j]
    r_norm = np.linalg.norm(r, axis=-1)
    pressed = r_norm >= FORCE_ZERO_N  # below 1e-9 N a force has no direction (docs/model.md §4)
    u = np.where(pressed[:, None], -r / np.where(pressed, r_norm, 1.0)[:, None], 0.0)
    np.testing.assert_allclose(moved, c * u, rtol=0, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(case=arm_and_poses(), m=st.floats(0.5, MAX_PAYLOAD_KG / 3), data=st.data())
def test_clearance_and_play_do_not_grow_with_load(case, m, data) -> None:
    arm, alpha, _ = case
    stiff = rigid_copy(arm)
    effects = data.draw(
        effects_for(stiff, ("joint_clearance", "actuator_play"), max_size=4), label="effects"
    )
    part = []
    for mass in (m, 3 * m):
        with_effects = eodarm.solve(stiff, alpha, mass, effects, self_weight=False)
        without = eodarm.solve(stiff, alpha, mass, [], self_weight=False)
        part.append({k: with_effects[k] - without[k] for k in MOTION_KEYS})
    for key in MOTION_KEYS:
        np.testing.assert_allclose(part[1][key], part[0][key], rtol=0, atol=1e-9, err_msg=key)


@settings(max_examples=100, deadline=None)
@given(
    case=arm_and_poses(),
    self_weight=st.booleans(),
    p=st.floats(0.0, 0.3),
    data=st.data(),
)
def test_actuator_play_changes_pin_length_by_at_most_p(case, self_weight, p, data) -> None:
    arm, alpha, mass = case
    j = data.draw(st.integers(0, arm.n - 1), label="actuator index")
    out = eodarm.solve(
        arm,
        alpha,
        mass,
        [eodarm.Effect("actuator_play", f"M{j + 1}", play_mm=p)],
        self_weight=self_weight,
    )
    bare = eodarm.solve(arm, alpha, mass, [], self_weight=self_weight)
    # the actuator's own sensor does not see the play
    np.testing.assert_allclose(out["dl_mm"], bare["dl_mm"], rtol=0, atol=1e-12)
    extra = out["dlength_mm"] - out["dl_mm"]
    atol = 1e-12 * out["length_mm"].max()  # dlength is ℓ′ − ℓ, rounded at ~1e-14 of ℓ
    assert (np.abs(extra) <= p + atol).all()
    # −p·sign(F_j, loaded); an actuator without load (|F| < 1e-9 N, docs/model.md §4) has no
    # preferred side of its play
    f = out["force_n"][:, j]
    expect = -p * np.where(np.abs(f) < FORCE_ZERO_N, 0.0, np.sign(f))
    np.testing.assert_allclose(extra[:, j], expect, rtol=0, atol=atol)
    others = [i for i in range(arm.n) if i != j]
    np.testing.assert_allclose(extra[:, others], 0.0, atol=atol)


# ---------------------------------------------------------------------------- base tilt
@settings(max_examples=100, deadline=None)
@given(
    case=arm_and_poses(),
    self_weight=st.booleans(),
    k_base=st.floats(1e7, 1e9),
    data=st.data(),
)
def test_base_compliance_tilts_the_rigid_arm_by_moment_over_stiffness(
    case, self_weight, k_base, data
) -> None:
    arm, alpha, _ = case
    stiff = rigid_copy(arm)
    payload = data.draw(payload_vectors(alpha.shape[0], g=arm.g), label="payload")
    eff = [eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=k_base)]
    out = eodarm.solve_payload(stiff, alpha, payload, eff, self_weight=self_weight)
    geo = eodarm.forward(stiff, alpha)
    pivot = np.asarray(stiff.pivot)
    dphi = cross(geo["O"][:, -1] - pivot, payload) / k_base  # ΔM = (L − pivot) × P
    expect = np.degrees(dphi)[:, None] * np.ones(arm.n)
    np.testing.assert_allclose(out["dalpha_deg"], expect, rtol=1e-9, atol=1e-12)
    # the whole arm turns rigidly about the pivot
    rel = geo["measure"] - pivot
    moved = rot(dphi, rel) - rel
    np.testing.assert_allclose(out["dx_mm"], moved[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["dy_mm"], moved[:, 1], rtol=0, atol=1e-9)


# ---------------------------------------------------------------------------- reciprocity
@settings(max_examples=100, deadline=None)
@given(case=arm_and_poses(max_poses=4), data=st.data())
def test_compliance_at_the_load_point_is_symmetric(case, data) -> None:
    """Maxwell–Betti: with springs, beams and a compliant base only, the 2×2 compliance
    ∂(dx, dy)/∂(Px, Py) at the load point is symmetric and positive semi-definite."""
    arm0, alpha, _ = case
    arm = measuring_at_load_point(arm0)
    effects = data.draw(effects_for(arm, ELASTIC), label="effects")
    rows = alpha.shape[0]

    def disp(p: tuple[float, float]) -> np.ndarray:
        o = eodarm.solve_payload(arm, alpha, np.tile(p, (rows, 1)), effects, self_weight=False)
        return np.column_stack([o["dx_mm"], o["dy_mm"]])

    # Central differences of ±0.1 N: the closure's quadratic term cancels, the cubic one is
    # ~1e-8 of the compliance and rounding ~1e-10, both far below the 1e-6 asked.
    eps = 0.1
    col_x = (disp((eps, 0.0)) - disp((-eps, 0.0))) / (2 * eps)  # mm/N
    col_y = (disp((0.0, eps)) - disp((0.0, -eps))) / (2 * eps)
    c = np.stack([col_x, col_y], axis=-1)  # (N, 2, 2): c[:, a, b] = ∂d_a/∂P_b
    size = np.linalg.norm(c, axis=(1, 2))
    assert (np.abs(c[:, 0, 1] - c[:, 1, 0]) <= 1e-6 * size).all()
    sym = 0.5 * (c + np.swapaxes(c, 1, 2))
    eig = np.linalg.eigvalsh(sym)
    assert (eig[:, 0] >= -1e-6 * eig[:, 1]).all() and (eig[:, 1] > 0).all()


# ---------------------------------------------------------------------------- signs, channels
def test_downward_payload_on_a_forward_reaching_arm_sags() -> None:
    """Seed-like poses of the example arm: a payload makes the measure point go down (dy < 0),
    compresses every actuator more (ΔF > 0) and shortens them (dl < 0)."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    rng = np.random.default_rng(11)
    alpha = np.array([60.0, 0.0, -10.0]) + np.array([50.0, 30.0, 20.0]) * rng.random((20, 3))
    geo = eodarm.forward(arm, alpha)
    assert (geo["O"][:, 3, 0] > arm.O1[0]).all()  # the arm reaches forward
    for effects in ([], [eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=3e7)]):
        for self_weight in (True, False):
            out = eodarm.solve(arm, alpha, 4.0, effects, self_weight=self_weight)
            assert (out["dy_mm"] < 0).all()
            assert (out["dforce_n"] > 0).all()
            assert (out["dl_mm"] < 0).all()


@settings(max_examples=100, deadline=None)
@given(case=arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_a_payload_does_positive_work_on_the_arm(case, self_weight, data) -> None:
    """The compliance is positive: the load point moves with the payload, P·d > 0."""
    arm0, alpha, _ = case
    arm = measuring_at_load_point(arm0)
    payload = data.draw(payload_vectors(alpha.shape[0], g=arm.g), label="payload")
    payload = payload[np.linalg.norm(payload, axis=-1) > 1.0]
    if payload.shape[0] == 0:
        payload = np.array([[0.0, -9.81]])
    alpha = alpha[: payload.shape[0]]
    payload = payload[: alpha.shape[0]]
    effects = data.draw(effects_for(arm, ELASTIC), label="effects")
    out = eodarm.solve_payload(arm, alpha, payload, effects, self_weight=self_weight)
    work = payload[:, 0] * out["dx_mm"] + payload[:, 1] * out["dy_mm"]
    assert (work > 0).all()


@settings(max_examples=100, deadline=None)
@given(case=arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_sensor_sees_the_actuator_body_only(case, self_weight, data) -> None:
    """dl = −ΔF/k_body (actuator_compliance replaces k); the mount adds −ΔF/k_m to the
    pin-to-pin length only."""
    arm, alpha, mass = case
    j = data.draw(st.integers(0, arm.n - 1), label="actuator index")
    effects = [
        data.draw(effect_at(arm, "actuator_compliance", f"M{j + 1}"), label="body"),
        data.draw(effect_at(arm, "mount_compliance", f"M{j + 1}"), label="mount"),
    ]
    k_body, k_mount = effects[0].value, effects[1].value
    out = eodarm.solve(arm, alpha, mass, effects, self_weight=self_weight)
    k = np.array([a.stiffness_n_per_mm for a in arm.actuators])
    k[j] = k_body
    df = out["dforce_n"]
    np.testing.assert_allclose(out["dl_mm"], -df / k, rtol=1e-12, atol=1e-15)
    mount = np.zeros_like(df)
    mount[:, j] = -df[:, j] / k_mount
    # dlength is ℓ′ − ℓ of lengths ~100 mm: rounding ~1e-14 of ℓ
    atol = 1e-12 * out["length_mm"].max()
    np.testing.assert_allclose(out["dlength_mm"], out["dl_mm"] + mount, rtol=1e-12, atol=atol)


def test_softer_actuator_sags_more_in_proportion_to_its_compliance() -> None:
    """Halving an actuator's stiffness doubles its body's length change."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = np.array([[80.0, 10.0, 0.0], [95.0, 25.0, -5.0]])
    one = eodarm.solve(
        arm, alpha, 5.0, [eodarm.Effect("actuator_compliance", "M2", stiffness_n_per_mm=800.0)]
    )
    two = eodarm.solve(
        arm, alpha, 5.0, [eodarm.Effect("actuator_compliance", "M2", stiffness_n_per_mm=400.0)]
    )
    np.testing.assert_allclose(two["dl_mm"][:, 1], 2.0 * one["dl_mm"][:, 1], rtol=1e-12)
    assert (two["dy_mm"] < one["dy_mm"]).all() and (one["dy_mm"] < 0).all()
    assert math.isclose(float(two["dl_mm"][0, 0]), float(one["dl_mm"][0, 0]), rel_tol=1e-12)
