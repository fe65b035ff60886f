"""Where the model can be trusted: a status per pose (docs/model.md §7, "Validity").

The model takes its forces from the undeformed geometry and closes the loaded pose exactly:
a small-deflection model. Its answers are sound only where the deflection is small, the
actuators are not close to passing through their joints, the loaded pose stays on the branch
of the unloaded one, the actuators work within their stroke and forces. Every solve returns
a ``status`` per pose (uint8 codes, :data:`STATUS`):

=====  ==================  ===============================================================
code   name                meaning (thresholds below)
=====  ==================  ===============================================================
0      ok                  inside every limit
1      out_of_stroke       an unloaded pin-to-pin length outside [min_length_mm, max_length_mm];
                           a drive's angle q_i, unloaded or loaded, outside [min_angle_deg,
                           max_angle_deg]
2      near_singular       an actuator's moment arm about its joint below 5 % of the pin's
                           distance from the joint (forces amplified more than 20×)
3      branch_flip         a loaded actuator triangle turned over (the exact closure left
                           the branch of the unloaded pose)
4      over_force          a loaded |force| above the actuator's ``max_force_n``, a loaded
                           |torque| above the drive's ``max_torque_nmm``
5      large_deflection    a link turned by more than 10°, the measure point moved by more
                           than 5 % of the arm's length (Σ|next_i|), or rose by more than
                           0.1 % of it under a downward payload (negative work: not an
                           elastic answer); or the *load point* rose by more than
                           :data:`MAX_LOAD_RISE_MM` under a downward payload where no gap
                           effect and no user-written deformation act (an elastic arm's
                           load point cannot rise: docs/model.md §7)
=====  ==================  ===============================================================

When several apply, the first in this order is reported. A rotary drive has no stroke, no
moment arm and no triangle: at its joint only its angle range and its torque are checked.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from eodarm.model.arm import Arm

__all__ = [
    "ANGLE_TOL_DEG",
    "MAX_DALPHA_DEG",
    "MAX_DEFLECTION_OF_REACH",
    "MAX_LOAD_RISE_MM",
    "MAX_RISE_OF_REACH",
    "MIN_MOMENT_ARM",
    "STATUS",
    "arm_reach",
    "checks_load_rise",
    "drive_angles",
    "out_of_angle",
    "quiet_rows",
    "status",
    "status_counts",
]

#: The status names, by code.
STATUS = (
    "ok",
    "out_of_stroke",
    "near_singular",
    "branch_flip",
    "over_force",
    "large_deflection",
)
#: Moment arm of an actuator about its joint, as a fraction of |A_i − O_i|, below which the
#: pose is near singular.
MIN_MOMENT_ARM = 0.05
#: Largest change of a link's angle (degrees) the small-deflection model is trusted for.
MAX_DALPHA_DEG = 10.0
#: Largest displacement of the measure point, as a fraction of the arm's length Σ|next_i|.
MAX_DEFLECTION_OF_REACH = 0.05
#: Largest rise of the measure point under a downward payload, as a fraction of that length.
MAX_RISE_OF_REACH = 1e-3
#: How far (degrees) a drive's angle may pass its limit and still be within its range (the
#: core's ``drive::rotary::ANGLE_TOL_RAD``): a loaded angle computed on its limit lands
#: within rounding of it, on either side, and both backends give it the same status.
ANGLE_TOL_DEG = 1e-9
#: Largest rise (mm) of the load point under a downward payload where no gap effect and no
#: user-written deformation act (the core's ``validity::MAX_LOAD_RISE_MM``): a fraction of
#: any sensor's noise.
MAX_LOAD_RISE_MM = 1e-3


def checks_load_rise(arm: Arm, effects: Any) -> bool:
    """Whether the load point's rise is checked with these effects (the core's
    ``validity::checks_load_rise``): no gap (play, clearance), no user-written effect, the last
    link not bending (the load point is known through the rigid last link). A friction keeps
    the check: it only holds back part of what the load deforms (it dissipates, and stores no
    energy that could lift the point above its reference)."""
    for e in effects:
        name = getattr(e, "name", "")
        if name in ("actuator_play", "joint_clearance"):
            return False
        if name == "link_bending" and getattr(e, "at", "") == f"L{arm.n}":
            return False
        if name == "drive_backlash":
            return False  # a gap
        if name not in (
            "actuator_compliance",
            "mount_compliance",
            "link_bending",
            "base_compliance",
            "actuator_friction",
            "joint_friction",
            "drive_compliance",
            "drive_friction",
        ):
            return False  # a user-written effect
    return True


def quiet_rows(extras: Mapping[str, Any], rows: int) -> npt.NDArray[np.bool_]:
    """(rows,) whether no user-written deformation acts on each row (every extra array absent
    or zero there)."""
    quiet = np.ones(rows, dtype=bool)
    for v in extras.values():
        if v is not None:
            quiet &= ~(np.asarray(v, dtype=float).reshape(rows, -1) != 0).any(axis=1)
    return quiet


def _cross(a: npt.NDArray[np.float64], b: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def status(
    arm: Arm,
    alpha_deg: npt.NDArray[np.float64],
    payload_n: npt.NDArray[np.float64],
    out: Mapping[str, Any],
    load_rise: bool | npt.NDArray[np.bool_] = False,
) -> npt.NDArray[np.uint8]:
    """The status code (N,) of each solved pose (see the module docstring). ``load_rise``
    (a bool, or one per pose): check the load point's rise there (:func:`checks_load_rise`
    and :func:`quiet_rows` say where it applies)."""
    from eodarm.model.kinematics import forward, stroke_violations

    arr = arm.arrays()
    rot = arr["kind"] == 1.0
    lin = ~rot
    # an arm with a drive: the reference's kinematics (its unused pins are NaN)
    backend: Literal["rust", "numpy"] = "numpy" if rot.any() else "rust"
    geo = forward(arm, alpha_deg, backend=backend)
    n = arm.n
    code = np.zeros(alpha_deg.shape[0], dtype=np.uint8)

    def mark(bad: Any, c: int) -> None:
        code[(code == 0) & bad] = c

    dalpha = np.asarray(out["dalpha_deg"], dtype=float)
    off_range = out_of_angle(arm, alpha_deg, dalpha)
    mark(stroke_violations(arm, geo["length_mm"]).any(axis=1) | off_range, 1)
    o, a, b = geo["O"][:, :n], geo["A"], geo["B"]
    line = a - b
    arm_len = np.linalg.norm(a - o, axis=2)
    h = np.abs(_cross(line, o - b)) / np.maximum(np.linalg.norm(line, axis=2), 1e-300)
    mark(((h < MIN_MOMENT_ARM * arm_len) & lin).any(axis=1), 2)
    # a pose that failed (NaN) is judged on what is known of it: its unloaded checks, else
    # too large a deflection (below), as the compiled core judges it
    loaded = forward(arm, alpha_deg + np.where(np.isfinite(dalpha), dalpha, 0.0), backend=backend)
    turn0 = np.sign(_cross(a - b, o - b))
    turn1 = np.sign(_cross(loaded["A"] - loaded["B"], loaded["O"][:, :n] - loaded["B"]))
    mark((turn0 * turn1 < 0).any(axis=1), 3)
    fmax = np.array([getattr(x, "max_force_n", None) or math.inf for x in arm.actuators])
    over = np.abs(np.asarray(out["force_n"], dtype=float)) > fmax
    if "torque_nmm" in out:
        tmax = np.where(np.isnan(arr["max_torque"]), np.inf, arr["max_torque"])
        over |= np.abs(np.asarray(out["torque_nmm"], dtype=float)) > tmax
    mark(over.any(axis=1), 4)
    reach = arm_reach(arm)
    dx, dy = np.asarray(out["dx_mm"], dtype=float), np.asarray(out["dy_mm"], dtype=float)
    moved = np.hypot(dx, dy)
    rise = (dy > MAX_RISE_OF_REACH * reach) & (np.asarray(payload_n)[:, 1] < 0)
    # `~(x <= limit)`: NaN breaks the limit
    big = ~(np.abs(dalpha) <= MAX_DALPHA_DEG).all(axis=1) | ~(
        moved <= MAX_DEFLECTION_OF_REACH * reach
    )
    # the load point: the measure point's displacement plus (R(Δα_n) − I)·R(α_n)·(next − m)
    last = arm.links[-1]
    v = np.asarray(last.next, dtype=float) - np.asarray(last.measure or last.next, dtype=float)
    an = np.radians(alpha_deg[:, -1])
    wx, wy = np.cos(an) * v[0] - np.sin(an) * v[1], np.sin(an) * v[0] + np.cos(an) * v[1]
    dn = np.radians(dalpha[:, -1])
    load_dy = dy + (np.sin(dn) * wx + (np.cos(dn) - 1.0) * wy)
    down = np.asarray(payload_n)[:, 1] < 0
    lift = np.asarray(load_rise) & down & (load_dy > MAX_LOAD_RISE_MM)
    mark(big | rise | lift, 5)
    return code


def out_of_angle(
    arm: Arm, alpha_deg: npt.NDArray[np.float64], dalpha_deg: npt.NDArray[np.float64]
) -> npt.NDArray[np.bool_]:
    """(N,) whether some drive's angle lies outside its ``[min_angle_deg, max_angle_deg]``
    by more than :data:`ANGLE_TOL_DEG`, unloaded (q_i = α_i − α_{i−1}, α_0 = 0) or loaded
    (q_i + Δα_i − Δα_{i−1}; checked where that turn exceeds the tolerance, not where it is
    NaN: a pose that failed).

    The unloaded angle is the turn of q_i nearest the middle of the range (within ±180° of
    it, ``[lo, lo + 360°)`` with only a lower limit, ``(hi − 360°, hi]`` with only an upper
    one): q_i in [−180°, 180°) for a range within ±180°, which docs/model.md §10 asks for.
    Computed in radians with the compiled core's numbers and operations, in its order
    (``validity::out_of_angle``): a pose on a limit gets the same status from both."""
    arr = arm.arrays()
    rot = arr["kind"] == 1.0
    bad = np.zeros(alpha_deg.shape[0], dtype=bool)
    if not rot.any():
        return bad
    a, t = np.radians(alpha_deg), np.radians(dalpha_deg)
    prev_a = np.concatenate([np.zeros((a.shape[0], 1)), a[:, :-1]], axis=1)
    prev_t = np.concatenate([np.zeros((t.shape[0], 1)), t[:, :-1]], axis=1)
    tol = np.radians(ANGLE_TOL_DEG)
    for i in np.flatnonzero(rot):
        lo_deg, hi_deg = arr["min_angle_deg"][i], arr["max_angle_deg"][i]
        if np.isnan(lo_deg) and np.isnan(hi_deg):
            continue
        lo = -math.inf if np.isnan(lo_deg) else float(np.radians(lo_deg))
        hi = math.inf if np.isnan(hi_deg) else float(np.radians(hi_deg))
        if math.isinf(hi):
            mid = lo + math.pi
        elif math.isinf(lo):
            mid = hi - math.pi
        else:
            mid = 0.5 * (lo + hi)
        q = mid + _wrap_pi((a[:, i] - prev_a[:, i]) - mid)
        dq = t[:, i] - prev_t[:, i]
        lo, hi = lo - tol, hi + tol
        # a turn within the tolerance is none: its sign is rounding's (a payload of 1e-55 N)
        loaded = np.where(np.abs(dq) > tol, q + dq, q)
        bad |= (q < lo) | (q > hi) | (loaded < lo) | (loaded > hi)
    return bad


def _wrap_pi(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """x in [−π, π) (the core's ``geometry::wrap_pi``: x itself when already there)."""
    inside = (x >= -math.pi) & (x < math.pi)
    return np.where(inside, x, np.mod(x + math.pi, 2.0 * math.pi) - math.pi)


def drive_angles(
    alpha_deg: npt.NDArray[np.float64], dalpha_deg: npt.NDArray[np.float64]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Each joint's relative angle q_i = α_i − α_{i−1} (α_0 = 0), unloaded and loaded, in
    degrees within [−180, 180): the angle a rotary drive holds (docs/model.md §10).

    **Reading:** the loaded angle is that of the rigid arm at the loaded angles with the
    chassis fixed (as for ``branch_flip``): q_i + Δα_i − Δα_{i−1}, Δα_0 = 0."""

    def rel(a: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        q = np.diff(a, axis=1, prepend=0.0)
        return np.asarray((q + 180.0) % 360.0 - 180.0, dtype=np.float64)

    return rel(alpha_deg), rel(alpha_deg + dalpha_deg)


def status_counts(codes: npt.ArrayLike) -> dict[str, int]:
    """How many poses have each status (only those that occur)."""
    c = np.bincount(np.asarray(codes, dtype=np.int64).ravel(), minlength=len(STATUS))
    return {STATUS[i]: int(k) for i, k in enumerate(c) if k}


def arm_reach(arm: Arm) -> float:
    """The arm's reach Σ|next_i| (mm), floored at 1e-9: the length the deflection limits scale
    by (the core's ``validity::reach``)."""
    return max(sum(math.hypot(*lk.next) for lk in arm.links), 1e-9)
