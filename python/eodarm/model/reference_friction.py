"""The numpy reference's friction elements (docs/model.md §9): what each actuator's parts
hold at one state of a load sequence, given what they held before it."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

__all__ = ["held_forces", "slip"]


def slip(held: FloatArray, wanted: FloatArray, limit: FloatArray) -> FloatArray:
    """One step of a Coulomb (elastic–perfectly plastic) friction element.

    The spring in parallel with the friction holds ``held`` (N); the force it would take
    without friction is now ``wanted``. While the friction can carry the difference,
    ``|wanted − held| ≤ limit``, the spring keeps ``held`` (sticking); otherwise the element
    slips until the friction carries exactly its limit: ``wanted − limit·sign(wanted − held)``.
    A limit of 0 gives ``wanted`` (no friction); from ``held = 0`` one step gives the deadband
    ``sign(wanted)·max(0, |wanted| − limit)``.
    """
    d = wanted - held
    return np.where(np.abs(d) <= limit, held, wanted - limit * np.sign(d))


def held_forces(
    par: dict[str, Any],
    st: dict[str, FloatArray],
    joint_prev: FloatArray,
    body_prev: FloatArray,
) -> dict[str, FloatArray]:
    """What each actuator's parts carry at one state, given the friction state before it.

    Parameters
    ----------
    par : the effect parameters (``_effect_params``).
    st : the state's statics on the undeformed geometry (``_statics``): ``dforce_n`` ΔF_i (N)
        is the frictionless force change from the reference, ``h`` the signed moment arm
        h_i = (A_i − O_i) × e_i (mm) of actuator i about O_i.
    joint_prev, body_prev : (N, n) the force change held before this state by the whole
        actuator against the joint friction, and by the body spring against the actuator
        friction (both 0 at the reference).

    Returns
    -------
    dict: ``joint`` (N, n) S_joint, the actuator's force change (mount, play, and the input of
    the body's friction): ΔF_i filtered by the joint friction of O_i, limit T_i/|h_i|;
    ``body`` (N, n) S_body, the body spring's force change: S_joint filtered by the actuator
    friction; ``couple`` (N, n) the friction couple (ΔF_i − S_joint,i)·h_i (N·mm, counter-
    clockwise +) on link i, the opposite one acting on body i−1.
    """
    df = st["dforce_n"]
    h = st["h"]
    joint_limit = par["joint_friction"][None, :] / np.abs(h)
    s_joint = slip(joint_prev, df, joint_limit)
    s_body = slip(body_prev, s_joint, np.broadcast_to(par["actuator_friction"], df.shape))
    return {"joint": s_joint, "body": s_body, "couple": (df - s_joint) * h}
