"""Physics of arms turned by rotary drives, on the numpy reference (docs/model.md §10).

Facts checked on random mixed arms (1–7 links, any mix of linear actuators and drives):
every body is in equilibrium with the drive couples; a drive's torque is minus the moment of
everything beyond its joint; no load moves nothing; the compliance at the load point is
symmetric (Maxwell–Betti); a backlash moves its joint by exactly b; a drive of stiffness k·r²
deflects the arm as a linear actuator of stiffness k with moment arm r, to first order. And
closed forms: a link clamped at its drive's flange bends as a cantilever on either side, and
the next drive's housing turns with its slope.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.model import reference as ref
from strategies import (
    ELASTIC,
    arm_and_poses,
    effects_for,
    measuring_at_load_point,
    mixed_arm_and_poses,
    payload_vectors,
    rigid_copy,
)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def rot(theta: float, v: Any) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def joint_unknowns(st_: dict[str, np.ndarray], loaded: bool) -> np.ndarray:
    """Each joint's force (linear) or torque (rotary), from the statics' two arrays."""
    f, t = (st_["force_n"], st_["torque_nmm"]) if loaded else (st_["force0_n"], st_["torque0_nmm"])
    assert not (np.isfinite(f) & np.isfinite(t)).any()  # one of the two, never both
    return np.where(np.isnan(f), t, f)


def loads_on_bodies(
    arm: eodarm.Arm,
    alpha: np.ndarray,
    payload: np.ndarray,
    u: np.ndarray,
    react: np.ndarray,
    g: float,
) -> tuple[list[list[tuple[np.ndarray, np.ndarray]]], np.ndarray]:
    """Every force (point, vector) on each link, and the net couple on each (N, n), from the
    statics' unknowns u (force or torque per joint) and reactions, written from docs/model.md
    §1, §10: a linear actuator pushes link i with +F e at A_i and body i−1 with −F e at
    B_{i−1}, half its weight at each pin; a drive turns link i with +T and body i−1 with −T,
    its whole weight at O_i on body i−1."""
    geo = eodarm.forward(arm, alpha, backend="numpy")
    n = arm.n
    o, a, b, c = geo["O"], geo["A"], geo["B"], geo["C"]
    kinds = arm.kinds
    forces: list[list[tuple[np.ndarray, np.ndarray]]] = [[] for _ in range(n)]
    couples = np.zeros(u.shape)
    for i in range(n):
        forces[i].append((o[:, i], react[:, i]))
        forces[i].append((c[:, i], np.array([0.0, -arm.links[i].mass_kg * g])))
        w = arm.actuators[i].mass_kg * g
        if kinds[i] == "linear":
            e = (a[:, i] - b[:, i]) / np.linalg.norm(a[:, i] - b[:, i], axis=-1)[:, None]
            forces[i].append((a[:, i], u[:, i, None] * e))
            forces[i].append((a[:, i], np.array([0.0, -0.5 * w])))
            if i > 0:
                forces[i - 1].append((b[:, i], -u[:, i, None] * e))
                forces[i - 1].append((b[:, i], np.array([0.0, -0.5 * w])))
        else:
            couples[:, i] += u[:, i]
            if i > 0:
                couples[:, i - 1] -= u[:, i]
                forces[i - 1].append((o[:, i], np.array([0.0, -w])))
        if i > 0:
            forces[i - 1].append((o[:, i], -react[:, i]))
    forces[n - 1].append((o[:, n], payload))
    return forces, couples


# ---------------------------------------------------------------------------- equilibrium
@settings(max_examples=150, deadline=None)
@given(case=mixed_arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_every_body_is_in_equilibrium_with_the_drive_couples(case, self_weight, data) -> None:
    arm, alpha, _ = case
    payload = data.draw(payload_vectors(alpha.shape[0], g=arm.g), label="payload")
    st_ = ref.statics(arm, alpha, payload, self_weight=self_weight)
    g = arm.g if self_weight else 0.0
    geo = eodarm.forward(arm, alpha, backend="numpy")
    for loaded, pay in ((True, payload), (False, np.zeros_like(payload))):
        u = joint_unknowns(st_, loaded)
        react = st_["reaction_n"] if loaded else st_["reaction0_n"]
        forces, couples = loads_on_bodies(arm, alpha, pay, u, react, g)
        # scale: the largest force (N) and the largest moment (N·mm) in play
        f_scale = max(
            1.0, float(np.abs(react).max()), float(np.nanmax(np.abs(st_["force_n"]), initial=0))
        )
        m_scale = f_scale * (float(np.abs(geo["O"]).max()) + 200.0)
        m_scale = max(m_scale, float(np.nanmax(np.abs(st_["torque_nmm"]), initial=0.0)))
        for i in range(arm.n):
            net_f = sum(np.broadcast_to(f, p.shape) for p, f in forces[i])
            net_m = couples[:, i] + sum(
                cross(p - geo["O"][:, i], np.broadcast_to(f, p.shape)) for p, f in forces[i]
            )
            assert np.abs(net_f).max() <= 1e-9 * f_scale, (i, loaded)
            assert np.abs(net_m).max() <= 1e-9 * m_scale, (i, loaded)


@settings(max_examples=150, deadline=None)
@given(case=mixed_arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_a_joints_torque_is_minus_the_moment_of_everything_beyond(case, self_weight, data) -> None:
    """Cut the arm at joint i: the bodies beyond (links i…n) are held only by the reaction at
    O_i (no moment about O_i) and joint i's drive (T_i) or actuator (F_i·h_i), so T_i (F_i·h_i)
    is minus the moment about O_i of every external load on them: their weights, the weights of
    the drives and actuators they carry, and the payload."""
    arm, alpha, _ = case
    payload = data.draw(payload_vectors(alpha.shape[0], g=arm.g), label="payload")
    st_ = ref.statics(arm, alpha, payload, self_weight=self_weight)
    g = arm.g if self_weight else 0.0
    geo = eodarm.forward(arm, alpha, backend="numpy")
    n, kinds = arm.n, arm.kinds
    o, a, b, c = geo["O"], geo["A"], geo["B"], geo["C"]
    u = joint_unknowns(st_, True)
    for i in range(n):
        loads = [(o[:, n], payload)]
        for j in range(i, n):
            loads.append((c[:, j], np.array([0.0, -arm.links[j].mass_kg * g])))
            w = arm.actuators[j].mass_kg * g
            if kinds[j] == "linear":
                loads.append((a[:, j], np.array([0.0, -0.5 * w])))
                if j > i:  # its other pin sits on body j−1, also beyond the cut
                    loads.append((b[:, j], np.array([0.0, -0.5 * w])))
            elif j > i:  # a drive beyond the cut weighs on body j−1 at O_j
                loads.append((o[:, j], np.array([0.0, -w])))
        moment = sum(cross(p - o[:, i], np.broadcast_to(f, p.shape)) for p, f in loads)
        if kinds[i] == "rotary":
            held = u[:, i]
        else:
            e = (a[:, i] - b[:, i]) / np.linalg.norm(a[:, i] - b[:, i], axis=-1)[:, None]
            held = u[:, i] * cross(a[:, i] - o[:, i], e)
        scale = 1e-9 * max(1.0, float(np.abs(moment).max()))
        np.testing.assert_allclose(held, -moment, rtol=0, atol=scale, err_msg=str(i))
    # A drive holding the arm out against gravity has T > 0: the one-link arm reaching forward
    one = eodarm.Arm.from_dict(
        {
            "base": {"O1": [0.0, 0.0]},
            "link": [{"next": [500.0, 0.0], "C": [200.0, 0.0], "mass_kg": 2.0}],
            "actuator": [{"kind": "rotary", "stiffness_nmm_per_rad": 1e7, "mass_kg": 1.0}],
        }
    )
    t = ref.statics(one, [[10.0], [-30.0]], [0.0, -9.81])["torque_nmm"][:, 0]
    assert (t > 0).all()


# ---------------------------------------------------------------------------- no load
@settings(max_examples=100, deadline=None)
@given(case=mixed_arm_and_poses(), data=st.data())
def test_no_load_moves_nothing(case, data) -> None:
    """Without weights and payload nothing moves, whatever the effects; with the weights and
    no payload, every effect but the centred gaps (and the frictions holding nothing) leaves
    the arm where it was zeroed."""
    arm, alpha, _ = case
    kinds = tuple(eodarm.CATALOGUE)
    effects = data.draw(effects_for(arm, kinds, unloaded=("centred", "taken_up")), label="effects")
    motion = ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "dlength_mm", "dforce_n", "dtorque_nmm")
    out = ref.solve(arm, alpha, 0.0, effects, self_weight=False)
    for key in motion:
        np.testing.assert_allclose(np.nan_to_num(out[key]), 0.0, atol=1e-10, err_msg=key)
    centred = [e for e in effects if e.kind.taken_up_code is not None and e.unloaded == "centred"]
    out = ref.solve(arm, alpha, 0.0, [e for e in effects if e not in centred], self_weight=True)
    for key in motion:
        np.testing.assert_allclose(np.nan_to_num(out[key]), 0.0, atol=1e-10, err_msg=key)


# ---------------------------------------------------------------------------- reciprocity
@settings(max_examples=100, deadline=None)
@given(case=mixed_arm_and_poses(), data=st.data())
def test_the_compliance_at_the_load_point_is_symmetric(case, data) -> None:
    """Maxwell–Betti: with springs (actuators, mounts, drives), beams (pinned or clamped) and a
    compliant chassis, the displacement along x under a small load along y equals the one along
    y under the same load along x. The compliance is taken by central differences of ±0.01 N:
    the closure's second-order terms (relative δ/lever, up to ~1e-5 on soft 7-link arms) cancel,
    the third-order ones stay ~1e-10; 1e-6 relative still fails for a drive's housing turned
    against its body's slope, or a bent link that misses the next drive's couple."""
    arm, alpha, _ = case
    arm = measuring_at_load_point(arm)
    effects = data.draw(effects_for(arm, ELASTIC, max_size=8), label="effects")
    eps = 1e-2

    def compliance(direction: list[float]) -> tuple[np.ndarray, np.ndarray]:
        p = np.array(direction) * eps
        up = ref.solve_payload(arm, alpha, p, effects, self_weight=False)
        down = ref.solve_payload(arm, alpha, -p, effects, self_weight=False)
        return tuple(0.5 * (up[k] - down[k]) / eps for k in ("dx_mm", "dy_mm"))  # type: ignore[return-value]

    cxx, cyx = compliance([1.0, 0.0])
    cxy, cyy = compliance([0.0, 1.0])
    scale = max(np.abs(cxx).max(), np.abs(cyy).max())
    np.testing.assert_allclose(cyx, cxy, rtol=0, atol=1e-6 * scale + 1e-12)
    assert (cxx >= -1e-12).all() and (cyy >= -1e-12).all()  # work ≥ 0


# ---------------------------------------------------------------------------- backlash
@settings(max_examples=100, deadline=None)
@given(case=mixed_arm_and_poses(), data=st.data())
def test_a_backlash_turns_its_joint_by_b_against_the_torque(case, data) -> None:
    """Rigid drives and actuators, one backlash b: the drive's joint turns by exactly
    −b·sign(T) (centred) or −b·(sign T − sign T0) (taken up), the others by nothing."""
    arm, alpha, _ = case
    assume("rotary" in arm.kinds)
    arm = rigid_copy(arm)
    j = data.draw(st.sampled_from([i for i, k in enumerate(arm.kinds) if k == "rotary"]))
    mode = data.draw(st.sampled_from(["centred", "taken_up"]))
    b = data.draw(st.floats(0.01, 0.5))
    payload = data.draw(payload_vectors(alpha.shape[0], g=arm.g), label="payload")
    eff = eodarm.Effect("drive_backlash", f"O{j + 1}", backlash_deg=b, unloaded=mode)
    out = ref.solve_payload(arm, alpha, payload, [eff])
    dq = np.diff(np.radians(out["dalpha_deg"]), axis=1, prepend=0.0)  # chassis fixed
    st_ = ref.statics(arm, alpha, payload)

    def sign0(t: np.ndarray) -> np.ndarray:
        return np.where(np.abs(t) < 1e-6, 0.0, np.sign(t))  # below 1e-6 N·mm: no side

    side = sign0(st_["torque_nmm"][:, j])
    if mode == "taken_up":
        side = side - sign0(st_["torque0_nmm"][:, j])
    expect = np.zeros_like(dq)
    expect[:, j] = -math.radians(b) * side
    # rigid parts (1e18) move by ~1e-15 rad; the closure adds rounding of ~1e-16
    np.testing.assert_allclose(dq, expect, rtol=0, atol=1e-12)
    assert (np.abs(dq[:, j]) <= math.radians(b) * (2 if mode == "taken_up" else 1) + 1e-12).all()


# ---------------------------------------------------------------------------- drive ≈ actuator
def _twin(arm: eodarm.Arm, j: int, k: float) -> eodarm.Arm:
    """``arm`` with joint j turned by a drive of stiffness k (its pins left out)."""
    d = arm.to_dict()
    d["actuator"][j] = {"kind": "rotary", "stiffness_nmm_per_rad": k, "mass_kg": 0.0}
    d["link"][j].pop("A")
    if j == 0:
        d["base"].pop("B0")
    else:
        d["link"][j - 1].pop("B")
    return eodarm.Arm.from_dict(d)


@settings(max_examples=100, deadline=None)
@given(case=arm_and_poses(max_links=5, max_poses=1), data=st.data())
def test_a_drive_of_stiffness_k_r2_is_a_linear_actuator_of_stiffness_k(case, data) -> None:
    """Actuator j of stiffness k and moment arm r about O_j turns its joint by
    −ΔF/(k·r)·sign = −ΔT/(k·r²) (ΔT = ΔF·h the torque it exerts): a drive of stiffness k·r²
    does the same, to first order in the load. At 0.05 kg the joints turn by ≲ 1e-4 rad and the
    exact closures of a triangle and of an angle differ by second-order terms, ≲ 1e-3 of the
    deflection; a wrong power of r fails by a factor r."""
    arm, alpha, _ = case
    d = arm.to_dict()
    for a in d["actuator"]:
        a["mass_kg"] = 0.0  # an actuator's weight sits at its pins, a drive's at the joint
    arm = eodarm.Arm.from_dict(d)
    j = data.draw(st.integers(0, arm.n - 1), label="joint")
    geo = eodarm.forward(arm, alpha, backend="numpy")
    o, a, b = geo["O"][0, j], geo["A"][0, j], geo["B"][0, j]
    r = abs(float(cross(a - o, (a - b) / np.linalg.norm(a - b))))
    twin = _twin(arm, j, arm.linear(j).stiffness_n_per_mm * r * r)
    lin = ref.solve(arm, alpha, 0.05, self_weight=False)
    drv = ref.solve(twin, alpha, 0.05, self_weight=False)
    size = max(float(np.abs(lin["dy_mm"]).max()), float(np.abs(lin["dx_mm"]).max()))
    for key in ("dx_mm", "dy_mm"):
        np.testing.assert_allclose(drv[key], lin[key], rtol=0, atol=1e-3 * size, err_msg=key)
    dq_lin = np.diff(lin["dalpha_deg"], axis=1, prepend=0.0)[0, j]
    dq_drv = np.diff(drv["dalpha_deg"], axis=1, prepend=0.0)[0, j]
    dq_all = np.abs(np.diff(lin["dalpha_deg"], axis=1, prepend=0.0)).max()
    assert dq_drv == pytest.approx(dq_lin, rel=1e-3, abs=1e-3 * dq_all)
    # the torque the drive holds is the moment the actuator exerted about O_j
    h = cross(a - o, (a - b) / np.linalg.norm(a - b))
    assert drv["dtorque_nmm"][0, j] == pytest.approx(lin["dforce_n"][0, j] * h, rel=1e-9)


# ---------------------------------------------------------------------------- clamped bending
def one_drive_arm(next_x: float, ei: float | None = None) -> eodarm.Arm:
    link: dict[str, Any] = {"next": [next_x, 0.0], "C": [0.5 * next_x, 0.0], "mass_kg": 1.0}
    if ei is not None:
        link["ei_n_mm2"] = ei
    return eodarm.Arm.from_dict(
        {
            "base": {"O1": [20.0, 40.0]},
            "link": [link],
            "actuator": [{"kind": "rotary", "stiffness_nmm_per_rad": 1e18, "mass_kg": 1.0}],
        }
    )


@pytest.mark.parametrize("length", [500.0, -400.0], ids=["forward", "backward"])
def test_a_link_clamped_at_its_drive_bends_as_a_cantilever(length: float) -> None:
    """A rigid drive, a bent link of length L (its load point ahead of the flange or behind
    it, a cantilever either way): the tip moves by P_t·|L|³/(3EI) across the link and the
    flange frame does not turn (dalpha = 0); the measure point at x moves by
    P_t·x²·(3|L| − |x|)/(6EI)."""
    ei = 2e9
    arm = one_drive_arm(length)
    d = arm.to_dict()
    x = 0.6 * length
    d["link"][0]["measure"] = [x, 0.0]
    with_measure = eodarm.Arm.from_dict(d)
    deg = np.array([[0.0], [35.0], [-60.0]])
    payload = np.array([[0.0, -40.0], [25.0, -10.0], [-15.0, 30.0]])
    eff = [eodarm.Effect("link_bending", "L1", ei_n_mm2=ei)]
    t = np.radians(deg[:, 0])
    p_t = -np.sin(t) * payload[:, 0] + np.cos(t) * payload[:, 1]  # across the link
    normal = np.stack([-np.sin(t), np.cos(t)], axis=-1)
    for a, at, v in (
        (arm, length, p_t * abs(length) ** 3 / (3 * ei)),
        (with_measure, x, p_t * x**2 * (3 * abs(length) - abs(x)) / (6 * ei)),
    ):
        out = ref.solve_payload(a, deg, payload, eff)
        got = np.stack([out["dx_mm"], out["dy_mm"]], axis=-1)
        np.testing.assert_allclose(got, v[:, None] * normal, rtol=1e-9, atol=1e-12, err_msg=at)
        # the rigid drive (1e18 N·mm/rad) turns by ~1e-14 rad
        np.testing.assert_allclose(out["dalpha_deg"], 0.0, atol=1e-9)


def test_the_next_drives_housing_turns_with_the_bent_links_slope() -> None:
    """Two rigid drives, link 1 bent: the payload reaches link 1 at O2 as a force P and the
    couple of P about O2, a cantilever with tip force and tip couple: v = P_t·L³/(3EI) +
    M·L²/(2EI), v′ = P_t·L²/(2EI) + M·L/EI. Link 2 (rigid) turns with the housing by v′, and
    the pose is closed exactly: O2′ = O1 + R(α1)·(L, v), α2′ = α2 + v′."""
    ei, l1 = 1.5e9, 450.0
    nxt2 = np.array([380.0, -30.0])
    arm = eodarm.Arm.from_dict(
        {
            "base": {"O1": [0.0, 0.0]},
            "link": [
                {"next": [l1, 0.0], "C": [200.0, 0.0], "mass_kg": 2.0},
                {"next": nxt2.tolist(), "C": [150.0, 0.0], "mass_kg": 1.0},
            ],
            "actuator": [
                {"kind": "rotary", "stiffness_nmm_per_rad": 1e18, "mass_kg": 2.0},
                {"kind": "rotary", "stiffness_nmm_per_rad": 1e18, "mass_kg": 1.0},
            ],
        }
    )
    eff = [eodarm.Effect("link_bending", "L1", ei_n_mm2=ei)]
    for a1, a2, pay in ((20.0, -15.0, (0.0, -60.0)), (-10.0, 40.0, (30.0, 20.0))):
        payload = np.array(pay)
        out = ref.solve_payload(arm, [[a1, a2]], payload, eff)
        t1, t2 = math.radians(a1), math.radians(a2)
        tip = rot(t2, nxt2)  # load point relative to O2
        p_loc = rot(-t1, payload)  # the payload in link 1's frame
        couple = float(cross(tip, payload))  # its moment about O2, on link 1 through drive 2
        v = p_loc[1] * l1**3 / (3 * ei) + couple * l1**2 / (2 * ei)
        slope = p_loc[1] * l1**2 / (2 * ei) + couple * l1 / ei
        o2 = rot(t1, [l1, v])
        moved = o2 + rot(t2 + slope, nxt2) - (rot(t1, [l1, 0.0]) + tip)
        np.testing.assert_allclose([out["dx_mm"][0], out["dy_mm"][0]], moved, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(out["dalpha_deg"][0], [0.0, math.degrees(slope)], atol=1e-9)
