"""An exact simulation of load sequences written in the tests, state by state, independent of
the compiled core's sequence kernel and of ``eodarm.reference``'s sequences: the friction
elements are stepped here in Python and each state is one ``eodarm.solve`` with what the
frictions and gaps do given as user deformations (docs/custom-effects.md, ``extra=``).

``tests/test_friction.py`` checks ``solve_sequence`` against it; the plan's tests
(``tests/test_plan.py``) simulate the data measured at planned poses with it.
"""

from __future__ import annotations

import math

import numpy as np

import eodarm
from eodarm.model.solver import statics

#: Below this force (N) a gap has no preferred side (docs/model.md §4).
FORCE_ZERO_N = 1e-9
MOTION = ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm")


def slip(held: float, x: float, limit: float) -> float:
    """A Coulomb element of limit ``limit`` holding ``held`` that sees ``x`` (docs/model.md)."""
    if abs(x - held) <= limit:
        return held
    return x - limit * math.copysign(1.0, x - held)


def sign0(x: float) -> float:
    return 0.0 if abs(x) < FORCE_ZERO_N else math.copysign(1.0, x)


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
