"""The hysteresis band of a model with friction: how far from the loading branch the loaded
measure point lands when the same payload is reached by unloading (docs/compensation.md §4,
docs/model.md §9).

``solve`` and ``compensate`` answer on the **loading branch**: the payload put on from the
unloaded pose, nothing held by the frictions. A real arm may reach the same payload from a
heavier one; its frictions then hold the other way. The far side of the band is the payload m
reached by unloading from M, heavy enough that every friction element slips back: the
sequence reference → M → m of :func:`eodarm.solve_sequence`. The band is the distance between
where the measure point lands there and where it lands on the loading branch (the sequence
reference → m).

**The reversing payload.** The force change x_i that a friction element of actuator i sees is
linear in the payload (forces on the undeformed geometry): x_i = a_i·m, a_i the frictionless
force change of actuator i per kg. On the way up to M the element slips forward (its spring
takes S = x − L·sign a_i); coming down to m it slips back, to S = x(m) + L·sign a_i (the
unloading branch), once the force has come down by more than 2L: |a_i|·(M − m) > 2L. A joint
friction (limit L_j = T/r_i) and a body friction (limit L_b) of one actuator act in series
(the body's element sees what the joint's passes), which takes |a_i|·(M − m) > 2(L_j + L_b).
So

    M = m + 1.5 · max_i 2(L_j,i + L_b,i) / |a_i|

over the actuators whose elements hold anything and whose force changes with the payload
(|a_i| > :data:`MIN_FORCE_PER_KG`). At a rotary drive (docs/model.md §10) x_i is the drive's
torque change, a_i its change per kg (N·mm/kg), and the joint friction (limit T itself, no
moment arm) and the gear's friction (``drive_friction``, limit L_g) act in series likewise:
|a_i|·(M − m) > 2(T + L_g); the factor 1.5 keeps every element clear of the
threshold. Beyond it the state at m no longer depends on M: every element sits on its
unloading branch, the far side of the band. M may be more than the arm can carry (its state
may not close): what the elements hold at m comes from the forces on the undeformed geometry,
and only the state at m is used.

Gaps (``actuator_play``, ``joint_clearance``, ``drive_backlash``) keep no memory of their own:
at every state they are taken up along that state's force (docs/model.md §9), so they widen
the band only where a friction changes an actual force's sign. A model without friction has
a band of 0.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, with_arm_effects

__all__ = ["FRICTIONS", "MIN_FORCE_PER_KG", "REVERSE_MARGIN", "band", "reversing_mass"]

#: The effects that hold part of a deformation (the elements with memory).
FRICTIONS = ("joint_friction", "actuator_friction", "drive_friction")
#: An actuator whose force changes by less than this per kg of payload (N/kg) moves no
#: friction element (the force of docs/model.md §4 below which a gap has no side, per kg).
MIN_FORCE_PER_KG = 1e-9
#: How far beyond the threshold 2(L_j + L_b)/|a_i| the reversing payload goes.
REVERSE_MARGIN = 1.5

FloatArray = npt.NDArray[np.float64]


def has_memory(arm: Arm, effects: Effect | list[Effect] | tuple[Effect, ...] | None) -> bool:
    """Whether the model (the arm's effects and ``effects``) holds a friction: its answers
    depend on the way the payload came."""
    return any(e.name in FRICTIONS and e.value > 0 for e in with_arm_effects(arm.effects, effects))


def has_branch(arm: Arm, effects: Effect | list[Effect] | tuple[Effect, ...] | None) -> bool:
    """Whether the model holds a friction or a gap (play, clearance): where its answers say
    which branch they are on (the loading one)."""
    gaps = ("actuator_play", "joint_clearance", "drive_backlash")
    return any(
        e.name in (*FRICTIONS, *gaps) and e.value > 0
        for e in with_arm_effects(arm.effects, effects)
    )


def reversing_mass(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    mass_kg: npt.ArrayLike,
    effects: Effect | list[Effect] | tuple[Effect, ...] | None = None,
    self_weight: bool = True,
) -> FloatArray:
    """The payload M (kg, per pose) from which unloading to ``mass_kg`` leaves every friction
    element of the model on its unloading branch (module notes): ``mass_kg`` itself where no
    element holds anything.

    Parameters
    ----------
    arm : the arm (its own effects included).
    alpha_deg : (N, n) unloaded absolute link angles, degrees.
    mass_kg : scalar or (N,) the payload, kg.
    effects : effects added to the arm's.
    self_weight : as :func:`eodarm.solve` (the force per kg does not depend on it).
    """
    from eodarm.model.kinematics import forward
    from eodarm.model.solver import statics

    alpha = np.atleast_2d(np.asarray(alpha_deg, dtype=float))
    mass = np.broadcast_to(np.asarray(mass_kg, dtype=float), (alpha.shape[0],)).copy()
    n = arm.n
    joint_t, body_l = np.zeros(n), np.zeros(n)
    for e in with_arm_effects(arm.effects, effects):
        if e.name == "joint_friction":
            joint_t[int(e.at[1:]) - 1] += e.value
        elif e.name in ("actuator_friction", "drive_friction"):
            body_l[int(e.at[1:]) - 1] += e.value
    if not (joint_t > 0).any() and not (body_l > 0).any():
        return mass
    rotary = np.array(arm.kinds) == "rotary"
    st = statics(arm, alpha, 1.0, self_weight=self_weight)
    per_kg = np.asarray(st["force_n"]) - np.asarray(st["force0_n"])  # (N, n), N/kg
    if rotary.any():  # a drive's torque change per kg, N·mm/kg
        per_kg = np.where(rotary, np.asarray(st["torque_nmm"]) - st["torque0_nmm"], per_kg)
    geo = forward(arm, alpha, backend="numpy" if rotary.any() else "rust")
    o, a, b = geo["O"][:, :n], geo["A"], geo["B"]
    line = a - b
    with np.errstate(divide="ignore", invalid="ignore"):
        e_hat = line / np.linalg.norm(line, axis=-1, keepdims=True)
        h = np.abs((a - o)[..., 0] * e_hat[..., 1] - (a - o)[..., 1] * e_hat[..., 0])  # r_i, mm
        # at a drive the joint friction's limit is its torque itself (no moment arm)
        limit = np.where(rotary, joint_t + body_l, joint_t / h + body_l)  # L_j + L_b (N, N·mm)
        need = np.where(
            (limit > 0) & (np.abs(per_kg) > MIN_FORCE_PER_KG), 2 * limit / np.abs(per_kg), 0.0
        )
    return mass + REVERSE_MARGIN * need.max(axis=1)


def band(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    mass_kg: npt.ArrayLike,
    effects: Effect | list[Effect] | tuple[Effect, ...] | None = None,
    self_weight: bool = True,
) -> FloatArray:
    """The hysteresis band (mm, per pose): the distance between the measure point under
    ``mass_kg`` on the loading branch (reference → m, what :func:`eodarm.solve` gives) and
    under the same payload reached by unloading from :func:`reversing_mass` (reference → M →
    m), both by :func:`eodarm.solve_sequence`. 0 for a model without friction; NaN where a
    branch cannot be solved.

    Parameters
    ----------
    arm : the arm (its own effects included).
    alpha_deg : (N, n) unloaded absolute link angles, degrees.
    mass_kg : scalar or (N,) the payload, kg.
    effects : effects added to the arm's.
    self_weight : include link and actuator weights.
    """
    from eodarm.model.solver import solve_sequence

    alpha = np.atleast_2d(np.asarray(alpha_deg, dtype=float))
    mass = np.broadcast_to(np.asarray(mass_kg, dtype=float), (alpha.shape[0],))
    if not has_memory(arm, effects):
        return np.zeros(alpha.shape[0])
    big = reversing_mass(arm, alpha, mass, effects, self_weight)
    seq = solve_sequence(
        arm, alpha, np.column_stack([mass, big, mass]), effects, self_weight=self_weight
    )
    dx, dy = np.asarray(seq["dx_mm"]), np.asarray(seq["dy_mm"])
    return np.asarray(np.hypot(dx[:, 2] - dx[:, 0], dy[:, 2] - dy[:, 0]))
