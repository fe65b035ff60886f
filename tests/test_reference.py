"""Physics checks of the numpy reference implementation (``eodarm.reference``) on its own.

These tests assert physical facts (equilibrium, hand-derived statics, closed-form beam
deflections, rigid-body motions, reciprocity, kinematic round trips) so that the reference can
be trusted as the yardstick for the compiled core. The core is compared elsewhere.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from eodarm.errors import EffectError, InputError
from eodarm.model import reference as ref
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "example_arm.toml"
STIFF = 1e15  # N/mm: an actuator that does not deform measurably


# ---------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def arm() -> Arm:
    return Arm.from_toml(EXAMPLE)


@pytest.fixture(scope="module")
def stiff_arm(arm: Arm) -> Arm:
    d = arm.to_dict()
    for a in d["actuator"]:
        a["stiffness_n_per_mm"] = STIFF
    return Arm.from_dict(d)


def one_link_dict(**link: Any) -> dict[str, Any]:
    lk = {"next": [500.0, 20.0], "A": [150.0, 30.0], "C": [250.0, -10.0], "mass_kg": 2.0}
    lk.update(link)
    return {
        "name": "one",
        "base": {"O1": [10.0, 5.0], "B0": [210.0, -95.0]},
        "link": [lk],
        "actuator": [{"stiffness_n_per_mm": 1500.0, "mass_kg": 1.2}],
    }


@pytest.fixture(scope="module")
def one_link() -> Arm:
    return Arm.from_dict(one_link_dict())


def example_poses(n_rows: int = 25, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo = np.array([60.0, 0.0, -10.0])
    hi = np.array([110.0, 30.0, 10.0])
    return lo + (hi - lo) * rng.random((n_rows, 3))


def example_masses(n_rows: int = 25, seed: int = 2) -> np.ndarray:
    return 7.0 * np.random.default_rng(seed).random(n_rows)


def all_effects() -> list[Effect]:
    return [
        Effect("actuator_compliance", "M1", stiffness_n_per_mm=1200.0),
        Effect("mount_compliance", "M2", stiffness_n_per_mm=900.0),
        Effect("actuator_play", "M3", play_mm=0.08),
        Effect("joint_clearance", "O2", clearance_mm=0.12),
        Effect("link_bending", "L1", ei_n_mm2=2e9),
        Effect("link_bending", "L3", ei_n_mm2=8e8),
        Effect("base_compliance", "base", stiffness_nmm_per_rad=3e7),
    ]


def rot(theta: float, v: np.ndarray) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


# ---------------------------------------------------------------------------- forward
def test_forward_matches_hand_computation(arm: Arm) -> None:
    alpha = np.array([[75.0, 12.0, -4.0]])
    geo = ref.forward(arm, alpha)
    a = np.radians(alpha[0])
    o1 = np.array(arm.O1)
    o2 = o1 + rot(a[0], np.array(arm.links[0].next))
    o3 = o2 + rot(a[1], np.array(arm.links[1].next))
    load = o3 + rot(a[2], np.array(arm.links[2].next))
    np.testing.assert_allclose(geo["O"][0], [o1, o2, o3, load], atol=1e-12)
    a2 = o2 + rot(a[1], np.array(arm.links[1].A))
    b1 = o1 + rot(a[0], np.array(arm.links[0].B))
    np.testing.assert_allclose(geo["A"][0, 1], a2, atol=1e-12)
    np.testing.assert_allclose(geo["B"][0, 0], arm.B0, atol=1e-12)
    np.testing.assert_allclose(geo["B"][0, 1], b1, atol=1e-12)
    np.testing.assert_allclose(geo["length_mm"][0, 1], np.linalg.norm(a2 - b1), rtol=1e-14)
    meas = o3 + rot(a[2], np.array(arm.measure))
    np.testing.assert_allclose(geo["measure"][0], meas, atol=1e-12)
    assert geo["O"].shape == (1, 4, 2) and geo["C"].shape == (1, 3, 2)


# ---------------------------------------------------------------------------- (a) equilibrium
def body_residuals(
    arm: Arm,
    alpha: np.ndarray,
    payload: np.ndarray,
    force: np.ndarray,
    reaction: np.ndarray,
    self_weight: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Net force (N, n, 2) and net moment about each link's own joint (N, n)."""
    geo = ref.forward(arm, alpha)
    n = arm.n
    g = arm.g if self_weight else 0.0
    o, a, b, c = geo["O"], geo["A"], geo["B"], geo["C"]
    e = (a - b) / np.linalg.norm(a - b, axis=-1)[..., None]
    net_f = np.zeros((alpha.shape[0], n, 2))
    net_m = np.zeros((alpha.shape[0], n))
    for i in range(n):
        loads = [
            (o[:, i], reaction[:, i]),
            (a[:, i], force[:, i, None] * e[:, i]),
            (c[:, i], np.array([0.0, -arm.links[i].mass_kg * g])),
            (a[:, i], np.array([0.0, -0.5 * arm.actuators[i].mass_kg * g])),
        ]
        if i + 1 < n:
            loads += [
                (b[:, i + 1], -force[:, i + 1, None] * e[:, i + 1]),
                (o[:, i + 1], -reaction[:, i + 1]),
                (b[:, i + 1], np.array([0.0, -0.5 * arm.actuators[i + 1].mass_kg * g])),
            ]
        else:
            loads.append((o[:, n], payload))
        for p, f in loads:
            f = np.broadcast_to(f, p.shape)
            net_f[:, i] += f
            net_m[:, i] += cross(p - o[:, i], f)
    return net_f, net_m


@pytest.mark.parametrize("self_weight", [True, False])
def test_every_body_is_in_equilibrium(arm: Arm, self_weight: bool) -> None:
    alpha = example_poses()
    rng = np.random.default_rng(5)
    payload = rng.normal(scale=40.0, size=(alpha.shape[0], 2))
    st = ref.statics(arm, alpha, payload, self_weight=self_weight)
    for force, reaction, pay in (
        (st["force_n"], st["reaction_n"], payload),
        (st["force_unloaded_n"], st["reaction_unloaded_n"], np.zeros_like(payload)),
    ):
        net_f, net_m = body_residuals(arm, alpha, pay, force, reaction, self_weight)
        scale = np.abs(force).max() + np.abs(reaction).max()
        assert np.abs(net_f).max() <= 1e-9 * scale
        assert np.abs(net_m).max() <= 1e-9 * scale * 1000.0  # lever arms ~1 m
    if not self_weight:
        np.testing.assert_array_equal(st["force_unloaded_n"], 0.0)


def test_solve_reports_statics_and_differences(arm: Arm) -> None:
    alpha = example_poses(10)
    mass = example_masses(10)
    out = ref.solve(arm, alpha, mass)
    payload = np.stack([np.zeros(10), -mass * arm.g], axis=-1)
    st = ref.statics(arm, alpha, payload)
    np.testing.assert_allclose(out["force_n"], st["force_n"], rtol=1e-12)
    np.testing.assert_allclose(
        out["dforce_n"], st["force_n"] - st["force_unloaded_n"], rtol=1e-9, atol=1e-9
    )
    np.testing.assert_allclose(out["length_mm"], ref.forward(arm, alpha)["length_mm"])
    # The payload hangs below the arm: every actuator is more compressed when loaded.
    assert (out["dforce_n"] > 0).all()


# ---------------------------------------------------------------------------- (c) one link
@pytest.mark.parametrize("self_weight", [True, False])
def test_one_link_statics_by_hand(one_link: Arm, self_weight: bool) -> None:
    lk, act = one_link.links[0], one_link.actuators[0]
    g = one_link.g if self_weight else 0.0
    rows = [(20.0, (0.0, -30.0)), (47.0, (12.0, -80.0)), (-15.0, (-25.0, 40.0))]
    alpha = np.array([[r[0]] for r in rows])
    payload = np.array([r[1] for r in rows])
    st = ref.statics(one_link, alpha, payload, self_weight=self_weight)
    o1 = np.array(one_link.O1)
    b0 = np.array(one_link.B0)
    for k, (deg, pay) in enumerate(rows):
        t = math.radians(deg)
        a_rel = rot(t, np.array(lk.A))  # A_1 − O_1
        c_rel = rot(t, np.array(lk.C))
        l_rel = rot(t, np.array(lk.next))
        d = o1 + a_rel - b0
        e = d / math.hypot(*d)
        h = a_rel[0] * e[1] - a_rel[1] * e[0]
        w_link = lk.mass_kg * g
        w_half = 0.5 * act.mass_kg * g
        for px, py, f_key, r_key in (
            (pay[0], pay[1], "force_n", "reaction_n"),
            (0.0, 0.0, "force_unloaded_n", "reaction_unloaded_n"),
        ):
            # moments about O_1 of the known loads, counter-clockwise positive
            t_known = -w_link * c_rel[0] - w_half * a_rel[0] + (l_rel[0] * py - l_rel[1] * px)
            f = -t_known / h
            r = -np.array([px, py - w_link - w_half]) - f * e
            assert st[f_key][k, 0] == pytest.approx(f, rel=1e-12, abs=1e-10)
            np.testing.assert_allclose(st[r_key][k, 0], r, rtol=1e-11, atol=1e-10)


# ---------------------------------------------------------------------------- (b) zero payload
@pytest.mark.parametrize("effect", all_effects(), ids=lambda e: e.key)
def test_zero_payload_gives_zero_response(arm: Arm, effect: Effect) -> None:
    alpha = example_poses(8)
    # Without self-weight, "loaded" with no payload carries no load at all: nothing moves.
    for effects in ([effect], all_effects()):
        out = ref.solve(arm, alpha, 0.0, effects=effects, self_weight=False)
        for key in ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "dlength_mm", "dforce_n"):
            np.testing.assert_allclose(out[key], 0.0, atol=1e-10, err_msg=key)
    # With self-weight, the effects that are continuous in the load also give exactly zero.
    if effect.name not in ("actuator_play", "joint_clearance"):
        out = ref.solve(arm, alpha, 0.0, effects=[effect], self_weight=True)
        for key in ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "dlength_mm"):
            np.testing.assert_allclose(out[key], 0.0, atol=1e-10, err_msg=key)


def test_play_and_clearance_follow_loaded_state_even_without_payload(arm: Arm) -> None:
    """model.md §4 as written: play takes −p·sign(F_loaded), clearance c·u(R_loaded).

    With self-weight and zero payload the loaded state still carries load, so these two
    discontinuous effects move the arm; dl (the actuator's own sensor) stays zero.
    """
    alpha = example_poses(6)
    play = Effect("actuator_play", "M2", play_mm=0.1)
    out = ref.solve(arm, alpha, 0.0, effects=[play])
    f = ref.statics(arm, alpha, np.zeros(2))["force_n"]
    np.testing.assert_allclose(out["dlength_mm"][:, 1], -0.1 * np.sign(f[:, 1]), atol=1e-12)
    np.testing.assert_allclose(out["dl_mm"], 0.0, atol=1e-12)


# ---------------------------------------------------------------------------- (d) clearance
@pytest.mark.parametrize("joint", [0, 1, 2])
def test_joint_clearance_is_bounded_and_does_not_grow(stiff_arm: Arm, joint: int) -> None:
    c = 0.2
    alpha = example_poses(12)
    eff = [Effect("joint_clearance", f"O{joint + 1}", clearance_mm=c)]
    geo = ref.forward(stiff_arm, alpha)
    r = geo["A"][:, joint] - geo["O"][:, joint]
    e = geo["A"][:, joint] - geo["B"][:, joint]
    h = np.abs(cross(r, e / np.linalg.norm(e, axis=-1)[:, None]))
    # pin moves by c; the link then turns by at most c/h about the moved pin
    lever = np.linalg.norm(geo["measure"] - geo["O"][:, joint], axis=-1)
    bound = c * (1.0 + lever / h)
    for self_weight in (True, False):
        disp = []
        for mass in (2.0, 4.0, 40.0):
            out = ref.solve(stiff_arm, alpha, mass, effects=eff, self_weight=self_weight)
            d = np.hypot(out["dx_mm"], out["dy_mm"])
            assert (d <= bound * (1.0 + 1e-3)).all()
            assert (d >= 0.5 * c).all()  # the pin offset is not lost
            disp.append(d)
        if not self_weight:
            # the direction of the joint force does not change with the payload's size
            np.testing.assert_allclose(disp[1], disp[0], rtol=1e-9)
            np.testing.assert_allclose(disp[2], disp[0], rtol=1e-9)


def test_clearance_pin_offset_is_along_the_joint_force(stiff_arm: Arm) -> None:
    """Clearance at O1 with rigid actuators: the chassis pin moves by c·u, u = −R1/|R1|."""
    c = 0.3
    alpha = example_poses(6)
    out = ref.solve(stiff_arm, alpha, 3.0, [Effect("joint_clearance", "O1", clearance_mm=c)])
    r1 = out["reaction_n"][:, 0]
    u = -r1 / np.linalg.norm(r1, axis=-1)[:, None]
    # Rebuild the displaced, rigidly closed arm by hand: link 1 pivots about the moved pin.
    geo = ref.forward(stiff_arm, alpha)
    o1 = geo["O"][:, 0] + c * u
    a1 = geo["A"][:, 0]
    dalpha = np.radians(out["dalpha_deg"][:, 0])
    moved_a = o1 + np.stack([rot(t, v) for t, v in zip(dalpha, a1 - geo["O"][:, 0], strict=True)])
    # actuator 1 keeps its length and its chassis pin: |A1' − B0| = l1
    np.testing.assert_allclose(
        np.linalg.norm(moved_a - geo["B"][:, 0], axis=-1), geo["length_mm"][:, 0], rtol=1e-12
    )
    # the whole arm moves rigidly with link 1 (stiff actuators): equal angle changes
    np.testing.assert_allclose(out["dalpha_deg"] - out["dalpha_deg"][:, :1], 0.0, atol=1e-9)


# ---------------------------------------------------------------------------- (e) base tilt
def test_base_compliance_tilts_the_rigid_arm(stiff_arm: Arm) -> None:
    k = 2.5e7
    alpha = example_poses(10)
    mass = example_masses(10) + 0.5
    out = ref.solve(
        stiff_arm, alpha, mass, [Effect("base_compliance", "base", stiffness_nmm_per_rad=k)]
    )
    geo = ref.forward(stiff_arm, alpha)
    pv = np.array(stiff_arm.pivot)
    lever = geo["O"][:, 3] - pv
    d_m = lever[:, 0] * (-mass * stiff_arm.g)  # (L − pivot) × (0, −m g)
    dphi = d_m / k
    np.testing.assert_allclose(out["dalpha_deg"], np.degrees(dphi)[:, None] * np.ones(3), rtol=1e-9)
    # and the measure point turns rigidly about the pivot
    rel = geo["measure"] - pv
    moved = pv + np.stack([rot(t, v) for t, v in zip(dphi, rel, strict=True)])
    np.testing.assert_allclose(out["dx_mm"], moved[:, 0] - geo["measure"][:, 0], atol=1e-9)
    np.testing.assert_allclose(out["dy_mm"], moved[:, 1] - geo["measure"][:, 1], atol=1e-9)
    assert (out["dalpha_deg"] < 0).all()  # a payload in front tips the arm forward/down


# ---------------------------------------------------------------------------- (f) compliance
def test_actuator_compliance_scales_dl(arm: Arm) -> None:
    alpha = example_poses(10)
    mass = example_masses(10)
    base = ref.solve(arm, alpha, mass)
    k = np.array([a.stiffness_n_per_mm for a in arm.actuators])
    np.testing.assert_allclose(base["dl_mm"], -base["dforce_n"] / k, rtol=1e-14)
    np.testing.assert_allclose(base["dlength_mm"], base["dl_mm"], rtol=1e-14)
    one = ref.solve(
        arm, alpha, mass, [Effect("actuator_compliance", "M2", stiffness_n_per_mm=800.0)]
    )
    two = ref.solve(
        arm, alpha, mass, [Effect("actuator_compliance", "M2", stiffness_n_per_mm=400.0)]
    )
    np.testing.assert_allclose(two["dl_mm"][:, 1], 2.0 * one["dl_mm"][:, 1], rtol=1e-12)
    np.testing.assert_allclose(two["dl_mm"][:, [0, 2]], base["dl_mm"][:, [0, 2]], rtol=1e-12)
    # a softer actuator lets the measure point sag further
    assert (two["dy_mm"] < one["dy_mm"]).all() and (one["dy_mm"] < 0).all()


def test_mount_and_play_change_pin_length_but_not_sensor(arm: Arm) -> None:
    alpha = example_poses(10)
    mass = example_masses(10) + 1.0
    base = ref.solve(arm, alpha, mass)
    km, p = 700.0, 0.05
    out = ref.solve(
        arm,
        alpha,
        mass,
        [
            Effect("mount_compliance", "M1", stiffness_n_per_mm=km),
            Effect("actuator_play", "M3", play_mm=p),
        ],
    )
    np.testing.assert_allclose(out["dl_mm"], base["dl_mm"], rtol=1e-14)
    np.testing.assert_allclose(
        out["dlength_mm"][:, 0], base["dl_mm"][:, 0] - base["dforce_n"][:, 0] / km, rtol=1e-12
    )
    np.testing.assert_allclose(
        out["dlength_mm"][:, 2],
        base["dl_mm"][:, 2] - p * np.sign(out["force_n"][:, 2]),
        rtol=1e-12,
    )


def test_small_loads_are_linear_and_reciprocal(arm: Arm) -> None:
    """Maxwell–Betti: with springs, beams and a compliant base only, the 2×2 compliance at the
    load point is symmetric, and the response is linear in a small load."""
    d = arm.to_dict()
    del d["link"][-1]["measure"]  # measure at the load point
    arm_l = Arm.from_dict(d)
    alpha = example_poses(6)
    effects = [
        Effect("mount_compliance", "M2", stiffness_n_per_mm=600.0),
        Effect("link_bending", "L1", ei_n_mm2=1e9),
        Effect("link_bending", "L2", ei_n_mm2=7e8),
        Effect("link_bending", "L3", ei_n_mm2=5e8),
        Effect("base_compliance", "base", stiffness_nmm_per_rad=2e7),
    ]
    eps = 1e-3
    px = ref.solve_payload(arm_l, alpha, [eps, 0.0], effects)
    py = ref.solve_payload(arm_l, alpha, [0.0, eps], effects)
    np.testing.assert_allclose(px["dy_mm"], py["dx_mm"], rtol=1e-5)
    py2 = ref.solve_payload(arm_l, alpha, [0.0, 2 * eps], effects)
    np.testing.assert_allclose(py2["dy_mm"], 2 * py["dy_mm"], rtol=1e-5)
    # the diagonal compliance is positive (work done by a load is positive)
    assert (px["dx_mm"] > 0).all() and (py["dy_mm"] > 0).all()


# ---------------------------------------------------------------------------- link bending
def test_bending_of_an_overhanging_beam_matches_closed_form() -> None:
    """Pins and load on the link axis, rigid actuator: tip deflection f·a²(l + a)/(3EI)."""
    arm1 = Arm.from_dict(
        {
            "base": {"O1": [0.0, 0.0], "B0": [200.0, -100.0]},
            "link": [{"next": [500.0, 0.0], "A": [150.0, 0.0], "C": [250.0, 0.0], "mass_kg": 1.0}],
            "actuator": [{"stiffness_n_per_mm": STIFF, "mass_kg": 0.5}],
        }
    )
    ei = 3e9
    deg = np.array([[0.0], [25.0], [-20.0]])
    payload = np.array([[0.0, -200.0], [30.0, -150.0], [-10.0, 80.0]])
    out = ref.solve_payload(arm1, deg, payload, [Effect("link_bending", "L1", ei_n_mm2=ei)])
    span, over = 150.0, 350.0
    t = np.radians(deg[:, 0])
    f_t = -np.sin(t) * payload[:, 0] + np.cos(t) * payload[:, 1]  # transverse in link frame
    v_tip = f_t * over**2 * (span + over) / (3.0 * ei)
    expect = np.stack([-np.sin(t) * v_tip, np.cos(t) * v_tip], axis=-1)
    got = np.stack([out["dx_mm"], out["dy_mm"]], axis=-1)
    np.testing.assert_allclose(got, expect, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(out["dalpha_deg"], 0.0, atol=1e-9)  # the chord does not turn


def right_loads_field(
    pts: np.ndarray, load_pts: np.ndarray, f_local: np.ndarray, ei: float, x_a: float
) -> np.ndarray:
    """model.md §4 literally: w(x) from the loads to the RIGHT of x."""
    xp, yp = load_pts[:, 0], load_pts[:, 1]
    fy = f_local[..., 1][:, None, :]
    cp = (-yp * f_local[..., 0])[:, None, :]

    def w(x: np.ndarray) -> np.ndarray:
        s = np.maximum(xp[None, :] - x[:, None], 0.0)
        return np.sum(fy * s**3 / 6 + cp * s**2 / 2, axis=-1) / ei

    def dw(x: np.ndarray) -> np.ndarray:
        s = np.maximum(xp[None, :] - x[:, None], 0.0)
        return np.sum(-fy * s**2 / 2 - cp * s, axis=-1) / ei

    w0 = w(np.array([0.0]))
    slope = (w(np.array([x_a])) - w0) / x_a
    v = w(pts[:, 0]) - w0 - slope * pts[:, 0]
    return np.stack([-pts[:, 1] * (dw(pts[:, 0]) - slope), v], axis=-1)


def test_bending_left_and_right_formulations_agree(arm: Arm) -> None:
    alpha = example_poses(8)
    payload = np.random.default_rng(3).normal(scale=60.0, size=(8, 2))
    st = ref.statics(arm, alpha, payload, self_weight=False)  # = the load changes
    geo = ref.forward(arm, alpha)
    e = (geo["A"] - geo["B"]) / geo["length_mm"][..., None]
    f, r = st["force_n"], st["reaction_n"]
    i = 1  # middle link: loads at O2, A2, B2, O3
    arr = arm.arrays()
    pts = np.stack([np.zeros(2), arr["A"][i], arr["B"][i], arr["next"][i]])
    glob = np.stack(
        [r[:, i], f[:, i, None] * e[:, i], -f[:, i + 1, None] * e[:, i + 1], -r[:, i + 1]], axis=1
    )
    t = -np.radians(alpha[:, i])[:, None]
    f_loc = np.stack(
        [
            np.cos(t) * glob[..., 0] - np.sin(t) * glob[..., 1],
            np.sin(t) * glob[..., 0] + np.cos(t) * glob[..., 1],
        ],
        axis=-1,
    )
    # the loads on the link are in equilibrium in its frame
    assert np.abs(f_loc.sum(axis=1)).max() < 1e-9 * np.abs(f_loc).max()
    probe = np.array(
        [[-120.0, 15.0], [0.0, 0.0], [40.0, -20.0], [85.0, -55.0], [380.0, 7.0], [500.0, 30.0]]
    )
    ei, x_a = 1.3e9, float(arr["A"][i, 0])
    mine = ref._bending_displacement(probe, pts, f_loc, ei, x_a)
    doc = right_loads_field(probe, pts, f_loc, ei, x_a)
    assert np.abs(mine - doc).max() <= 1e-12 * np.abs(doc).max()
    np.testing.assert_allclose(mine[:, 1, :], 0.0, atol=1e-15)  # support at O
    np.testing.assert_allclose(mine[:, 3, 1], 0.0, atol=1e-12 * np.abs(doc).max())  # at x_A


def test_cantilever_sign_convention() -> None:
    """A tip load f_y > 0 beyond the supports lifts the tip (v > 0), as model.md states."""
    pts = np.array([[0.0, 0.0], [100.0, 0.0], [300.0, 0.0]])
    f_tip = 10.0
    # reactions of a beam on supports at 0 and 100 with f_tip at 300
    r_a = -f_tip * 300.0 / 100.0
    r_o = -f_tip - r_a
    f_loc = np.array([[[0.0, r_o], [0.0, r_a], [0.0, f_tip]]])
    disp = ref._bending_displacement(np.array([[300.0, 0.0], [50.0, 0.0]]), pts, f_loc, 1e8, 100.0)
    assert disp[0, 0, 1] > 0  # tip up
    assert disp[0, 1, 1] < 0  # between the supports the beam sags the other way


def test_bending_on_link_without_second_support_is_refused() -> None:
    arm0 = Arm.from_dict(one_link_dict(A=[0.0, 60.0]))
    with pytest.raises(EffectError, match="L1"):
        ref.solve(arm0, [[30.0]], 1.0, [Effect("link_bending", "L1", ei_n_mm2=1e9)])
    # without bending the same arm solves fine
    ref.solve(arm0, [[30.0]], 1.0)


# ---------------------------------------------------------------------------- (g), (h) kinematics
def test_angles_from_lengths_round_trip(arm: Arm) -> None:
    alpha = example_poses(30)
    lengths = ref.forward(arm, alpha)["length_mm"]
    back = ref.angles_from_lengths(arm, lengths, alpha + 3.0)
    np.testing.assert_allclose(back, alpha, atol=1e-9)
    single_ref = ref.angles_from_lengths(arm, lengths, np.array([85.0, 15.0, 0.0]))
    np.testing.assert_allclose(single_ref, alpha, atol=1e-9)


def test_angles_from_lengths_unreachable(arm: Arm) -> None:
    lengths = ref.forward(arm, example_poses(3))["length_mm"]
    lengths[2, 1] = 5000.0
    with pytest.raises(InputError, match=r"pose row 2: actuator 2 cannot close"):
        ref.angles_from_lengths(arm, lengths, np.array([85.0, 15.0, 0.0]))


def test_inverse_kinematics_round_trip(arm: Arm) -> None:
    alpha = example_poses(30)
    geo = ref.forward(arm, alpha)
    target = np.column_stack([geo["O"][:, 3], alpha[:, 2]])
    ik = ref.inverse_kinematics(arm, target)
    assert ik["reachable"].all()
    np.testing.assert_allclose(ik["alpha_deg"], alpha, atol=1e-9)
    np.testing.assert_allclose(ik["length_mm"], geo["length_mm"], rtol=1e-12)
    # the other elbow reaches the same load point with another pose
    other = ref.inverse_kinematics(arm, target, elbow=1)
    assert other["reachable"].all()
    np.testing.assert_allclose(
        ref.forward(arm, other["alpha_deg"])["O"][:, 3], geo["O"][:, 3], atol=1e-9
    )
    assert np.abs(other["alpha_deg"][:, 1] - alpha[:, 1]).min() > 1.0


def test_inverse_kinematics_unreachable_and_wrong_arm(arm: Arm, one_link: Arm) -> None:
    ik = ref.inverse_kinematics(arm, [[3000.0, 0.0, 0.0], [500.0, 700.0, 0.0]])
    assert ik["reachable"].tolist() == [False, True]
    assert np.isnan(ik["alpha_deg"][0]).all() and np.isnan(ik["length_mm"][0]).all()
    with pytest.raises(InputError, match="3-link"):
        ref.inverse_kinematics(one_link, [[300.0, 0.0, 0.0]])
    with pytest.raises(InputError, match="elbow"):
        ref.inverse_kinematics(arm, [[500.0, 700.0, 0.0]], elbow=0)


# ---------------------------------------------------------------------------- the loaded pose
def test_loaded_pose_keeps_loaded_lengths(arm: Arm) -> None:
    """Rebuild the loaded rigid arm from dalpha: its pin-to-pin lengths are ℓ + δℓ."""
    alpha = example_poses(12)
    mass = example_masses(12)
    effects = [
        Effect("mount_compliance", "M3", stiffness_n_per_mm=500.0),
        Effect("actuator_play", "M1", play_mm=0.1),
    ]
    out = ref.solve(arm, alpha, mass, effects)
    loaded = ref.forward(arm, alpha + out["dalpha_deg"])
    np.testing.assert_allclose(
        loaded["length_mm"], out["length_mm"] + out["dlength_mm"], rtol=1e-12
    )
    np.testing.assert_allclose(
        out["dx_mm"], loaded["measure"][:, 0] - ref.forward(arm, alpha)["measure"][:, 0], atol=1e-10
    )
    assert (out["dy_mm"] < 0).all()  # a payload makes the arm sag


def test_all_effects_together_run_and_stay_small(arm: Arm) -> None:
    alpha = example_poses(20)
    out = ref.solve(arm, alpha, example_masses(20), all_effects())
    for key in ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "dlength_mm"):
        assert np.isfinite(out[key]).all()
    assert np.abs(out["dy_mm"]).max() < 50.0
    assert out["dalpha_deg"].shape == (20, 3) and out["dx_mm"].shape == (20,)


# ---------------------------------------------------------------------------- validation
def test_input_validation_names_rows(arm: Arm) -> None:
    alpha = example_poses(4)
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        ref.solve(arm, alpha[:, :2], 1.0)
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        ref.forward(arm, alpha[0])
    bad = alpha.copy()
    bad[3, 1] = np.nan
    with pytest.raises(InputError, match="pose row 3: alpha_deg has a non-finite value"):
        ref.solve(arm, bad, 1.0)
    with pytest.raises(InputError, match="pose row 2: mass_kg is negative"):
        ref.solve(arm, alpha, [1.0, 2.0, -0.5, 1.0])
    with pytest.raises(InputError, match="pose row 1: mass_kg has a non-finite value"):
        ref.solve(arm, alpha, [1.0, np.inf, 0.5, 1.0])
    with pytest.raises(InputError, match="mass_kg"):
        ref.solve(arm, alpha, [1.0, 2.0])
    pay = np.zeros((4, 2))
    pay[2, 0] = np.nan
    with pytest.raises(InputError, match="pose row 2: payload_n has a non-finite value"):
        ref.solve_payload(arm, alpha, pay)
    with pytest.raises(InputError, match=r"payload_n must have shape \(4, 2\)"):
        ref.statics(arm, alpha, np.zeros((3, 2)))


def test_singular_pose_is_refused(arm: Arm) -> None:
    # actuator 1's line through O1: A1 on the segment O1–B0
    b0 = np.array(arm.B0) - np.array(arm.O1)
    a_loc = np.array(arm.links[0].A)
    a1 = math.degrees(math.atan2(b0[1], b0[0]) - math.atan2(a_loc[1], a_loc[0]))
    alpha = example_poses(4)
    alpha[2, 0] = a1
    msg = r"pose row 2: actuator 1 passes through joint O1 \(singular pose\)"
    with pytest.raises(InputError, match=msg):
        ref.solve(arm, alpha, 1.0)
    with pytest.raises(InputError, match=msg):
        ref.statics(arm, alpha, np.zeros(2))


def test_triangle_that_cannot_close_is_refused(arm: Arm) -> None:
    alpha = example_poses(3)
    eff = [Effect("mount_compliance", "M2", stiffness_n_per_mm=1e-3)]
    with pytest.raises(InputError, match="pose row 0: actuator 2 cannot close its triangle"):
        ref.solve(arm, alpha, 5.0, eff)


def test_effect_validation(arm: Arm) -> None:
    alpha = example_poses(2)
    dup = [Effect("joint_clearance", "O2", clearance_mm=0.1)] * 2
    with pytest.raises(EffectError, match="twice"):
        ref.solve(arm, alpha, 1.0, dup)
    with pytest.raises(EffectError, match="only 3 links"):
        ref.solve(arm, alpha, 1.0, [Effect("link_bending", "L4", ei_n_mm2=1e9)])
    with pytest.raises(EffectError):
        ref.solve(arm, alpha, 1.0, ["joint_clearance@O1"])


def test_empty_batch(arm: Arm) -> None:
    out = ref.solve(arm, np.zeros((0, 3)), 1.0, all_effects())
    assert out["dx_mm"].shape == (0,) and out["dalpha_deg"].shape == (0, 3)


# ---------------------------------------------------------------------------- doc-literal check
def _doc_literal_pose(
    arm: Arm, alpha_deg: np.ndarray, payload: np.ndarray, effects: list[Effect]
) -> tuple[np.ndarray, np.ndarray]:
    """One pose, written the way model.md states it (not the way the reference computes it):
    tip-to-base statics recursion, arccos triangle closure, bending from the loads to the
    right. Returns (dx, dy) of the measure point and dalpha in degrees."""
    n, arr, g = arm.n, arm.arrays(), arm.g
    al = np.radians(alpha_deg)
    o, a, b = [np.array(arm.O1)], [], [np.array(arm.B0)]
    for i in range(n):
        a.append(o[i] + rot(al[i], arr["A"][i]))
        if i + 1 < n:
            b.append(o[i] + rot(al[i], arr["B"][i]))
        o.append(o[i] + rot(al[i], arr["next"][i]))
    ell = [float(np.linalg.norm(a[i] - b[i])) for i in range(n)]
    e = [(a[i] - b[i]) / ell[i] for i in range(n)]

    def recursion(p: np.ndarray, grav: float) -> tuple[np.ndarray, list[np.ndarray]]:
        f, r = [0.0] * n, [np.zeros(2)] * n
        for i in reversed(range(n)):
            loads = [
                (o[i] + rot(al[i], arr["C"][i]), np.array([0.0, -arm.links[i].mass_kg * grav])),
                (a[i], np.array([0.0, -0.5 * arm.actuators[i].mass_kg * grav])),
            ]
            if i + 1 < n:
                loads += [
                    (b[i + 1], np.array([0.0, -0.5 * arm.actuators[i + 1].mass_kg * grav])),
                    (b[i + 1], -f[i + 1] * e[i + 1]),
                    (o[i + 1], -r[i + 1]),
                ]
            else:
                loads.append((o[n], p))
            q = sum(fv for _, fv in loads)
            t = sum(float(cross(pt - o[i], fv)) for pt, fv in loads)
            f[i] = -t / float(cross(a[i] - o[i], e[i]))
            r[i] = -q - f[i] * e[i]
        return np.array(f), r

    f_loaded, r_loaded = recursion(payload, g)
    df, dr = recursion(payload, 0.0)
    k = np.array([act.stiffness_n_per_mm for act in arm.actuators])
    km, play, clear = np.full(n, np.inf), np.zeros(n), np.zeros(n)
    ei: list[float | None] = [None] * n
    kb = None
    for eff in effects:
        i = eff.index(n)
        if eff.name == "actuator_compliance":
            k[i] = eff.value
        elif eff.name == "mount_compliance":
            km[i] = eff.value
        elif eff.name == "actuator_play":
            play[i] = eff.value
        elif eff.name == "joint_clearance":
            clear[i] = eff.value
        elif eff.name == "link_bending":
            ei[i] = eff.value
        else:
            kb = eff.value
    ell_new = [
        ell[i] - df[i] / k[i] - df[i] / km[i] - play[i] * np.sign(f_loaded[i]) for i in range(n)
    ]

    def bend(i: int, pt: np.ndarray) -> np.ndarray:
        eii = ei[i]
        if eii is None:
            return np.zeros(2)
        pts = [(np.zeros(2), dr[i]), (arr["A"][i], df[i] * e[i])]
        if i + 1 < n:
            pts += [(arr["B"][i], -df[i + 1] * e[i + 1]), (arr["next"][i], -dr[i + 1])]
        else:
            pts.append((arr["next"][i], payload))
        loc = [(q, rot(-al[i], fv)) for q, fv in pts]

        def w(x: float) -> float:
            return (
                sum(
                    fl[1] * max(q[0] - x, 0) ** 3 / 6 - q[1] * fl[0] * max(q[0] - x, 0) ** 2 / 2
                    for q, fl in loc
                )
                / eii
            )

        def wp(x: float) -> float:
            return (
                sum(
                    -fl[1] * max(q[0] - x, 0) ** 2 / 2 + q[1] * fl[0] * max(q[0] - x, 0)
                    for q, fl in loc
                )
                / eii
            )

        xa = arr["A"][i][0]
        s = (w(xa) - w(0.0)) / xa
        return np.array([-pt[1] * (wp(pt[0]) - s), w(pt[0]) - w(0.0) - s * pt[0]])

    u = [-r / np.linalg.norm(r) if np.linalg.norm(r) > 0 else np.zeros(2) for r in r_loaded]
    pv = np.array(arm.pivot)
    dphi = float(cross(o[n] - pv, payload)) / kb if kb else 0.0
    new = [0.0] * n
    op = pv + rot(dphi, np.array(arm.O1) - pv) + clear[0] * u[0]  # global offset (model.md §4)
    bp = pv + rot(dphi, np.array(arm.B0) - pv)
    for i in range(n):
        if i > 0:
            off = clear[i] * u[i]
            nxt, bb = arr["next"][i - 1], arr["B"][i - 1]
            bp = op + rot(new[i - 1], bb + bend(i - 1, bb))
            op = op + rot(new[i - 1], nxt + bend(i - 1, nxt)) + off
        al_pin = arr["A"][i] + bend(i, arr["A"][i])
        rho = float(np.linalg.norm(al_pin))
        d = bp - op
        side = np.sign(float(cross(b[i] - o[i], rot(al[i], al_pin))))
        cos_arg = (rho**2 + d @ d - ell_new[i] ** 2) / (2 * rho * float(np.linalg.norm(d)))
        theta = math.atan2(d[1], d[0]) + side * math.acos(cos_arg)
        new[i] = theta - math.atan2(al_pin[1], al_pin[0])
    m = arr["measure"]
    moved = op + rot(new[n - 1], m + bend(n - 1, m)) - (o[n - 1] + rot(al[n - 1], m))
    dal = [(new[i] - al[i] + math.pi) % (2 * math.pi) - math.pi for i in range(n)]
    return moved, np.degrees(dal)


def test_reference_agrees_with_doc_literal_formulas(arm: Arm) -> None:
    alpha = example_poses(15)
    mass = example_masses(15) + 0.2
    extra = [
        Effect("link_bending", "L2", ei_n_mm2=1.1e9),
        Effect("joint_clearance", "O1", clearance_mm=0.07),
        Effect("joint_clearance", "O3", clearance_mm=0.1),
    ]
    for effects in ([], all_effects() + extra):
        out = ref.solve(arm, alpha, mass, effects)
        for row in range(alpha.shape[0]):
            pay = np.array([0.0, -mass[row] * arm.g])
            moved, dal = _doc_literal_pose(arm, alpha[row], pay, effects)
            got = np.array([out["dx_mm"][row], out["dy_mm"][row]])
            np.testing.assert_allclose(got, moved, rtol=1e-9, atol=1e-10)
            np.testing.assert_allclose(out["dalpha_deg"][row], dal, rtol=1e-9, atol=1e-10)
