"""An exact simulation of load sequences written in the tests, state by state, independent of
the compiled core's sequence kernel and of ``eodarm.reference``'s sequences: the friction
elements are stepped here in Python and each state is one ``eodarm.solve`` with what the
frictions and gaps do given as user deformations (docs/custom-effects.md, ``extra=``).

``tests/test_friction.py`` checks ``solve_sequence`` against it; the plan's tests
(``tests/test_plan.py``) simulate the data measured at planned poses with it.
:func:`simulate_drives` does the same on arms with rotary drives (docs/model.md §10):
``tests/test_rotary_sequences.py`` checks ``solve_sequence`` against it and
``tests/test_rotary_diagnose.py`` measures with it.
"""

from __future__ import annotations

import math

import numpy as np

import eodarm
from eodarm.model import reference as ref
from eodarm.model.solver import statics

#: Below this force (N) a gap has no preferred side (docs/model.md §4).
FORCE_ZERO_N = 1e-9
#: Below this torque (N·mm) a backlash has no preferred side (docs/model.md §10).
TORQUE_ZERO_NMM = 1e-6
MOTION = ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm")


def slip(held: float, x: float, limit: float) -> float:
    """A Coulomb element of limit ``limit`` holding ``held`` that sees ``x`` (docs/model.md)."""
    if abs(x - held) <= limit:
        return held
    return x - limit * math.copysign(1.0, x - held)


def sign0(x: float) -> float:
    return 0.0 if abs(x) < FORCE_ZERO_N else math.copysign(1.0, x)


def sign_below(x: float, zero: float) -> float:
    """The sign of ``x``, 0 below ``zero`` in magnitude."""
    return 0.0 if abs(x) < zero else math.copysign(1.0, x)


def unit0(v: np.ndarray) -> np.ndarray:
    m = float(np.hypot(*v))
    return np.zeros(2) if m < FORCE_ZERO_N else v / m


def simulate(
    arm: eodarm.Arm,
    alpha: np.ndarray,
    masses: np.ndarray,
    effects: list[eodarm.Effect],
    self_weight: bool = True,
) -> dict[str, np.ndarray]:
    """One sequence (pose ``alpha`` (n,), payloads ``masses`` (S,)), state by state.

    The forces are the numpy reference's statics; the friction elements are stepped here;
    each state is then one ``eodarm.solve`` of the frictionless elastic effects, with what
    the frictions and gaps do given as user deformations: a body that takes S instead of ΔF
    lengthens by (ΔF − S)/k against the frictionless −ΔF/k (seen by its sensor), a mount by
    (ΔF − S)/k_m (unseen), a play closes along the actual force (unseen) and a clearance
    along the actual joint force (a pin offset). Not valid with a link's bending beside a
    joint friction (the friction couple bends the link: no user deformation expresses that).
    """
    n = arm.n
    geo = eodarm.forward(arm, alpha[None], backend="numpy")
    o, a, b = geo["O"][0, :n], geo["A"][0], geo["B"][0]
    e = (a - b) / np.linalg.norm(a - b, axis=1)[:, None]
    h = (a - o)[:, 0] * e[:, 1] - (a - o)[:, 1] * e[:, 0]
    k_body = np.array([act.stiffness_n_per_mm for act in arm.actuators], dtype=float)
    c_mount = np.zeros(n)
    body_limit: dict[int, float] = {}
    joint_limit: dict[int, float] = {}
    plays, clearances, elastic = [], [], []
    for eff in effects:
        i = int(eff.at[1:]) - 1 if eff.at != "base" else 0
        if eff.name == "actuator_compliance":
            k_body[i] = eff.value
        elif eff.name == "mount_compliance":
            c_mount[i] = 1.0 / eff.value
        if eff.name == "actuator_friction":
            body_limit[i] = eff.value
        elif eff.name == "joint_friction":
            joint_limit[i] = eff.value / abs(h[i])
        elif eff.name == "actuator_play":
            plays.append((i, eff.value, eff.unloaded))
        elif eff.name == "joint_clearance":
            clearances.append((i, eff.value, eff.unloaded))
        else:
            elastic.append(eff)
    s_count = masses.shape[0]
    st_ = statics(arm, np.repeat(alpha[None], s_count, 0), masses, "numpy", self_weight)
    held_joint, held_body = np.zeros(n), np.zeros(n)
    out: dict[str, list[np.ndarray]] = {k: [] for k in (*MOTION, "force_n", "reaction_n")}
    for s in range(s_count):
        f0, r0 = st_["force0_n"][s], st_["reaction0_n"][s]
        d_f = st_["force_n"][s] - f0
        actuator = d_f.copy()  # what the whole actuator takes
        for i, lim in joint_limit.items():
            held_joint[i] = slip(held_joint[i], d_f[i], lim)
            actuator[i] = held_joint[i]
        body = actuator.copy()  # what the body spring takes
        for i, lim in body_limit.items():
            held_body[i] = slip(held_body[i], actuator[i], lim)
            body[i] = held_body[i]
        force = f0 + actuator
        reaction = st_["reaction_n"][s] - (actuator - d_f)[:, None] * e
        unseen = (d_f - actuator) * c_mount
        for i, p, mode in plays:
            turned = sign0(force[i]) - (sign0(f0[i]) if mode == "taken_up" else 0.0)
            unseen[i] -= p * turned
        joint = np.zeros((n, 2))
        for i, c, mode in clearances:
            joint[i] += c * unit0(-reaction[i])
            if mode == "taken_up":
                joint[i] -= c * unit0(-r0[i])
        extra = {
            "extra_seen_mm": ((d_f - body) / k_body)[None],
            "extra_unseen_mm": unseen[None],
            "extra_joint_mm": joint[None],
        }
        res = eodarm.solve(
            arm, alpha[None], masses[s], elastic, self_weight=self_weight, extra=extra
        )
        for k in MOTION:
            out[k].append(res[k][0])
        out["force_n"].append(force)
        out["reaction_n"].append(reaction)
    return {k: np.array(v) for k, v in out.items()}


def simulate_drives(
    arm: eodarm.Arm,
    alpha: np.ndarray,
    masses: np.ndarray,
    effects: list[eodarm.Effect],
    self_weight: bool = True,
) -> dict[str, np.ndarray]:
    """One sequence (pose ``alpha`` (n,), payloads ``masses`` (S,)), state by state.

    The forces and torques are the reference's statics; the friction elements are stepped
    here; each state is then one ``eodarm.solve`` of the frictionless elastic effects with what
    the frictions and gaps do as user deformations. At a drive: a gear that takes S instead of
    ΔT turns by (ΔT − S)/k against the frictionless −ΔT/k, a backlash by −b along the actual
    torque T_ref + S_joint (less the reference's side when taken up); at an actuator: its body
    lengthens by (ΔF − S)/k (seen by its sensor), its mount by (ΔF − S)/k_m, a play closes
    along the actual force; a clearance along the actual joint force. Not valid with a link's
    bending beside a *linear* joint's friction (its couple bends the link: no user deformation
    expresses that); beside a drive's joint friction it is, as the joint's couple and the
    drive's add up to ΔT_i whatever the friction holds (docs/model.md §10).
    """
    n, kinds = arm.n, arm.kinds
    geo = eodarm.forward(arm, alpha[None], backend="numpy")
    o, a, b = geo["O"][0, :n], geo["A"][0], geo["B"][0]
    with np.errstate(invalid="ignore"):
        e = (a - b) / np.linalg.norm(a - b, axis=1)[:, None]  # NaN at a drive
    h = (a - o)[:, 0] * e[:, 1] - (a - o)[:, 1] * e[:, 0]
    k = np.array(arm.arrays()["stiffness"], dtype=float)
    c_mount = np.zeros(n)
    body_limit: dict[int, float] = {}
    joint_limit: dict[int, float] = {}
    gaps, clearances, elastic = [], [], []
    for eff in effects:
        i = int(eff.at[1:]) - 1 if eff.at != "base" else 0
        if eff.name in ("actuator_compliance", "drive_compliance"):
            k[i] = eff.value
        if eff.name == "mount_compliance":
            c_mount[i] = 1.0 / eff.value
        if eff.name in ("actuator_friction", "drive_friction"):
            body_limit[i] = eff.value
        elif eff.name == "joint_friction":
            joint_limit[i] = eff.value / (abs(h[i]) if kinds[i] == "linear" else 1.0)
        elif eff.name in ("actuator_play", "drive_backlash"):
            gaps.append((i, eff.value, eff.unloaded))
        elif eff.name == "joint_clearance":
            clearances.append((i, eff.value, eff.unloaded))
        else:
            elastic.append(eff)
    s_count = masses.shape[0]
    payload = np.column_stack([np.zeros(s_count), -masses * arm.g])
    st_ = ref.statics(arm, np.repeat(alpha[None], s_count, 0), payload, self_weight)
    rot = np.array(kinds) == "rotary"
    u_all = np.where(rot, st_["torque_nmm"], st_["force_n"])
    u0_all = np.where(rot, st_["torque0_nmm"], st_["force0_n"])
    held_joint, held_body = np.zeros(n), np.zeros(n)
    out: dict[str, list[np.ndarray]] = {k_: [] for k_ in (*MOTION, "u", "reaction_n")}
    for s in range(s_count):
        u0, r0 = u0_all[s], st_["reaction0_n"][s]
        d_u = u_all[s] - u0
        whole = d_u.copy()  # what the whole actuator or drive takes
        for i, lim in joint_limit.items():
            held_joint[i] = slip(held_joint[i], d_u[i], lim)
            whole[i] = held_joint[i]
        spring = whole.copy()  # what the body's or gear's spring takes
        for i, lim in body_limit.items():
            held_body[i] = slip(held_body[i], whole[i], lim)
            spring[i] = held_body[i]
        actual = u0 + whole
        # a linear joint's reaction follows the actuator's actual force; a drive's does not move
        shift = np.where(rot, 0.0, whole - d_u)
        reaction = st_["reaction_n"][s] - shift[:, None] * np.nan_to_num(e)
        seen = np.where(rot, 0.0, (d_u - spring) / k)
        unseen = np.where(rot, 0.0, (d_u - whole) * c_mount)
        turn = np.where(rot, (d_u - spring) / k, 0.0)
        for i, gap, mode in gaps:
            zero = TORQUE_ZERO_NMM if rot[i] else FORCE_ZERO_N
            side = sign_below(actual[i], zero) - (
                sign_below(u0[i], zero) if mode == "taken_up" else 0.0
            )
            if rot[i]:
                turn[i] -= math.radians(gap) * side
            else:
                unseen[i] -= gap * side
        joint = np.zeros((n, 2))
        for i, c, mode in clearances:
            joint[i] += c * unit0(-reaction[i])
            if mode == "taken_up":
                joint[i] -= c * unit0(-r0[i])
        extra = {
            "extra_seen_mm": seen[None],
            "extra_unseen_mm": unseen[None],
            "extra_joint_mm": joint[None],
            "extra_turn_rad": turn[None],
        }
        res = eodarm.solve(
            arm, alpha[None], masses[s], elastic, "numpy", self_weight=self_weight, extra=extra
        )
        for key in MOTION:
            out[key].append(res[key][0])
        out["u"].append(actual)
        out["reaction_n"].append(reaction)
    return {key: np.array(v) for key, v in out.items()}
