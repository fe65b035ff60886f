"""The numpy reference's friction elements (docs/model.md §9, §10): what each joint's parts
hold at one state of a load sequence, given what they held before it."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

__all__ = ["held_forces", "slip"]


def slip(held: FloatArray, wanted: FloatArray, limit: FloatArray) -> FloatArray:
    """One step of a Coulomb (elastic–perfectly plastic) friction element.

    The spring in parallel with the friction holds ``held``; what it would take without
    friction is now ``wanted``. While the friction can carry the difference,
    ``|wanted − held| ≤ limit``, the spring keeps ``held`` (sticking); otherwise the element
    slips until the friction carries exactly its limit: ``wanted − limit·sign(wanted − held)``.
    A limit of 0 gives ``wanted`` (no friction); from ``held = 0`` one step gives the deadband
    ``sign(wanted)·max(0, |wanted| − limit)``. Forces (N) or torques (N·mm) alike.
    """
    d = wanted - held
    return np.where(np.abs(d) <= limit, held, wanted - limit * np.sign(d))


def held_forces(
    par: dict[str, Any],
    st: dict[str, FloatArray],
    joint_prev: FloatArray,
    body_prev: FloatArray,
) -> dict[str, FloatArray]:
    """What each joint's parts carry at one state, given the friction state before it.

    Parameters
    ----------
    par : the effect parameters (``reference._effect_params``): ``rotary`` (n,) the kind of
        each joint, ``joint_friction`` (N·mm), ``body_friction`` (N for an actuator's body,
        N·mm for a drive's gear).
    st : the state's statics on the undeformed geometry (``reference_statics.solve_statics``):
        ``du`` (N, n) the frictionless change from the reference of each joint's unknown (ΔF_i
        in N at a linear joint, ΔT_i in N·mm at a rotary one); ``h`` the signed moment arm
        h_i = (A_i − O_i) × e_i (mm) of a linear actuator about O_i.
    joint_prev, body_prev : (N, n) what the whole actuator or drive held against the joint
        friction before this state, and what its body or gear spring held against its own
        friction (both 0 at the reference).

    Returns
    -------
    dict: ``joint`` (N, n) S_joint, the change the whole actuator or drive takes: Δu_i filtered
    by the joint friction of O_i, limit T_i/|h_i| at a linear joint (a torque over the
    actuator's moment arm), T_i itself at a rotary one; ``body`` (N, n) S_body, the body's or
    gear's spring: S_joint filtered by the actuator's or drive's own friction; ``couple``
    (N, n) the couple the joint friction holds on link i (N·mm, counter-clockwise +; the
    opposite on body i−1): (ΔF_i − S_joint,i)·h_i at a linear joint, ΔT_i − S_joint,i at a
    rotary one.
    """
    du = st["du"]
    rot = np.asarray(par["rotary"], dtype=bool)
    # the lever of the joint's couple: the actuator's moment arm h_i, a drive's 1 (a torque)
    lever = np.where(rot, 1.0, np.where(rot, 1.0, st["h"]))
    s_joint = slip(joint_prev, du, par["joint_friction"][None, :] / np.abs(lever))
    s_body = slip(body_prev, s_joint, np.broadcast_to(par["body_friction"], du.shape))
    return {"joint": s_joint, "body": s_body, "couple": (du - s_joint) * lever}
