"""The numpy reference's geometry: frames (seed relation 1), triangles, angles from lengths
and inverse kinematics, and the input checks it shares with the reference's statics.

Independent of the compiled core; :mod:`eodarm.model.reference` re-exports the public names.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from eodarm.errors import InputError
from eodarm.model.arm import Arm

__all__ = ["angles_from_lengths", "forward", "inverse_kinematics"]

FloatArray = NDArray[np.float64]


# ---------------------------------------------------------------------------- small helpers
def _rotate(theta: ArrayLike, v: ArrayLike) -> FloatArray:
    """Rotate 2-vectors ``v`` (..., 2) counter-clockwise by ``theta`` (...) radians."""
    c, s = np.cos(theta), np.sin(theta)
    v = np.asarray(v, dtype=float)
    vx, vy = v[..., 0], v[..., 1]
    return np.stack([c * vx - s * vy, s * vx + c * vy], axis=-1)


def _cross(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Planar cross product ``a_x b_y − a_y b_x`` over the last axis."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _angle(v: ArrayLike) -> FloatArray:
    """Angle of 2-vectors (radians, in (−π, π])."""
    v = np.asarray(v, dtype=float)
    return np.arctan2(v[..., 1], v[..., 0])


def _wrap(x: ArrayLike) -> FloatArray:
    """Wrap angles (radians) into [−π, π)."""
    return (np.asarray(x, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def _first_row(mask: NDArray[np.bool_]) -> tuple[int, ...]:
    """Index of the first True entry of ``mask`` (row-major)."""
    return tuple(int(k) for k in np.argwhere(mask)[0])


def _as_float(x: ArrayLike, name: str) -> FloatArray:
    try:
        return np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be an array of numbers") from None


def _check_finite(x: FloatArray, name: str) -> None:
    """Refuse non-finite values, naming the first offending pose row."""
    bad = ~np.isfinite(x)
    if bad.any():
        row = int(np.argmax(bad.reshape(bad.shape[0], -1).any(axis=1)))
        raise InputError(f"pose row {row}: {name} has a non-finite value")


def _as_poses(x: ArrayLike, n: int, name: str) -> FloatArray:
    """A (N, n) array of finite values, or InputError."""
    a = _as_float(x, name)
    if a.ndim != 2 or a.shape[1] != n:
        raise InputError(f"{name} must have shape (N, {n}), got {a.shape}")
    _check_finite(a, name)
    return a


def _as_payload(x: ArrayLike, n_rows: int) -> FloatArray:
    """A (N, 2) force array (a single (2,) vector is broadcast to every row)."""
    p = _as_float(x, "payload_n")
    if p.shape == (2,):
        p = np.broadcast_to(p, (n_rows, 2))
    if p.shape != (n_rows, 2):
        raise InputError(f"payload_n must have shape ({n_rows}, 2), got {p.shape}")
    p = np.array(p, dtype=float)
    _check_finite(p, "payload_n")
    return p


def _as_mass(x: ArrayLike, n_rows: int) -> FloatArray:
    """A (N,) array of finite, non-negative masses (a scalar is broadcast to every row)."""
    m = _as_float(x, "mass_kg")
    if m.ndim == 0:
        m = np.full(n_rows, float(m))
    if m.shape != (n_rows,):
        raise InputError(f"mass_kg must be a scalar or have shape ({n_rows},), got {m.shape}")
    _check_finite(m, "mass_kg")
    neg = m < 0
    if neg.any():
        row = _first_row(neg)[0]
        raise InputError(f"pose row {row}: mass_kg is negative ({m[row]!r})")
    return m


# ---------------------------------------------------------------------------- kinematics
def _forward(arr: dict[str, FloatArray], alpha: FloatArray) -> dict[str, FloatArray]:
    """Global points of every pose; ``alpha`` in radians, (N, n). No validation.

    A pin no actuator uses (a rotary joint's) is the zero point of its frame here, so that
    every array stays finite for the statics; ``length_mm`` is NaN at a rotary joint."""
    n_rows, n = alpha.shape
    o = np.empty((n_rows, n + 1, 2))
    a = np.empty((n_rows, n, 2))
    b = np.empty((n_rows, n, 2))
    c = np.empty((n_rows, n, 2))
    o[:, 0] = arr["O1"]
    b[:, 0] = arr["B0"]
    for i in range(n):
        ai = alpha[:, i]
        o[:, i + 1] = o[:, i] + _rotate(ai, arr["next"][i])
        a[:, i] = o[:, i] + _rotate(ai, arr["A"][i])
        c[:, i] = o[:, i] + _rotate(ai, arr["C"][i])
        if i + 1 < n:
            b[:, i + 1] = o[:, i] + _rotate(ai, arr["B"][i])
    measure = o[:, n - 1] + _rotate(alpha[:, n - 1], arr["measure"])
    length = np.where(arr["kind"] == 1.0, np.nan, np.linalg.norm(a - b, axis=-1))
    return {"O": o, "A": a, "B": b, "C": c, "measure": measure, "length_mm": length}


def forward(arm: Arm, alpha_deg: ArrayLike) -> dict[str, FloatArray]:
    """Forward kinematics of the rigid arm (model §1, seed relation 1).

    Parameters
    ----------
    arm : Arm
        The arm (points in mm).
    alpha_deg : array_like, shape (N, n)
        Absolute link angles in degrees (counter-clockwise from global x).

    Returns
    -------
    dict of str to ndarray
        Global points in mm:

        ``"O"`` (N, n+1, 2)
            Joints O_1…O_n followed by the load point.
        ``"A"`` (N, n, 2)
            Pin A_i of actuator i on link i (NaN where a rotary drive turns link i).
        ``"B"`` (N, n, 2)
            Base pin of actuator i: row 0 is the chassis pin B_0, row i is link i's B point
            (NaN where joint i is turned by a rotary drive).
        ``"C"`` (N, n, 2)
            Centre of mass of each link.
        ``"measure"`` (N, 2)
            The measurement point.
        ``"length_mm"`` (N, n)
            Pin-to-pin length |A_i − B_{i−1}| of every actuator, mm (NaN at a rotary joint).

    Raises
    ------
    InputError
        On a wrong shape or a non-finite angle (the row is named).
    """
    alpha = _as_poses(alpha_deg, arm.n, "alpha_deg")
    arr = arm.arrays()
    geo = _forward(arr, np.radians(alpha))
    unused = (arr["kind"] == 1.0)[None, :, None]
    geo["A"] = np.where(unused, np.nan, geo["A"])
    geo["B"] = np.where(unused, np.nan, geo["B"])
    return geo


def _circle_intersection(
    c0: FloatArray, r0: FloatArray, c1: FloatArray, r1: FloatArray, side: FloatArray
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Intersection of circle (c0, r0) with circle (c1, r1), on ``side`` of the line c0→c1.

    ``side = +1`` picks the point P with ``(c1 − c0) × (P − c0) > 0``, ``−1`` the other one,
    ``0`` the foot on the line. Returns the points (N, 2) and a mask of rows where the circles
    meet.
    """
    dvec = c1 - c0
    d = np.linalg.norm(dvec, axis=-1)
    u = dvec / d[:, None]
    along = (r0**2 - r1**2 + d**2) / (2.0 * d)
    h2 = (r0 - along) * (r0 + along)
    ok = np.isfinite(h2) & (h2 >= 0.0)
    h = np.sqrt(np.where(ok, h2, 0.0))
    perp = np.stack([-u[:, 1], u[:, 0]], axis=-1)
    pt = c0 + along[:, None] * u + (side * h)[:, None] * perp
    return pt, ok


# ---------------------------------------------------------------------------- kinematics
def angles_from_lengths(arm: Arm, length_mm: ArrayLike, alpha_ref_deg: ArrayLike) -> FloatArray:
    """Link angles of the rigid arm from its actuators' pin-to-pin lengths (model §6).

    Each triangle (O_i, B_{i−1}, A_i) is closed link by link from the base, choosing the
    branch of the reference pose; each angle is returned within 180° of the reference. A
    joint turned by a rotary drive has no length (its column is NaN): it keeps the reference
    pose's relative angle, α_i = α_i,ref + (α_{i−1} − α_{i−1,ref}) (docs/model.md §10).

    Parameters
    ----------
    arm : Arm
        The arm.
    length_mm : array_like, shape (N, n)
        Pin-to-pin actuator lengths |A_i − B_{i−1}|, mm (> 0); NaN at a rotary drive.
    alpha_ref_deg : array_like, shape (N, n) or (n,)
        Reference pose(s), degrees, that fix the branch of every triangle.

    Returns
    -------
    ndarray, shape (N, n)
        Absolute link angles, degrees.

    Raises
    ------
    InputError
        Wrong shape, non-finite or non-positive lengths at a linear actuator, a number at a
        rotary drive, or a triangle that cannot close (row and joint named).
    """
    n = arm.n
    arr = arm.arrays()
    rot = arr["kind"] == 1.0
    ell = _as_float(length_mm, "length_mm")
    if ell.ndim != 2 or ell.shape[1] != n:
        raise InputError(f"length_mm must have shape (N, {n}), got {ell.shape}")
    n_rows = ell.shape[0]
    given = ~np.isnan(ell[:, rot])
    if given.any():
        row, k = _first_row(given)
        i = int(np.flatnonzero(rot)[k])
        raise InputError(
            f"pose row {row}: length_mm of joint {i + 1} must be NaN: a rotary drive turns "
            f"it, which has no length (it keeps the reference pose's angle), got {ell[row, i]}"
        )
    _check_finite(ell[:, ~rot], "length_mm")
    nonpos = (ell <= 0.0) & ~rot
    if nonpos.any():
        row, i = _first_row(nonpos)
        raise InputError(f"pose row {row}: length_mm of actuator {i + 1} must be > 0")
    ref = _as_float(alpha_ref_deg, "alpha_ref_deg")
    if ref.shape == (n,):
        ref = np.broadcast_to(ref, (n_rows, n))
    ref = _as_poses(ref, n, "alpha_ref_deg")
    if ref.shape[0] != n_rows:
        raise InputError(
            f"alpha_ref_deg must have shape ({n_rows}, {n}) or ({n},), got {ref.shape}"
        )
    ref_rad = np.radians(ref)
    geo = _forward(arr, ref_rad)
    side = np.sign(_cross(geo["B"] - geo["O"][:, :n], geo["A"] - geo["O"][:, :n]))
    alpha = np.empty((n_rows, n))
    o = np.broadcast_to(arr["O1"], (n_rows, 2))
    b = np.broadcast_to(arr["B0"], (n_rows, 2))
    for i in range(n):
        if rot[i]:
            before = alpha[:, i - 1] - ref_rad[:, i - 1] if i else 0.0
            alpha[:, i] = ref_rad[:, i] + before
        else:
            rho = np.full(n_rows, np.hypot(*arr["A"][i]))
            a_new, ok = _circle_intersection(o, rho, b, ell[:, i], side[:, i])
            if not ok.all():
                row = _first_row(~ok)[0]
                raise InputError(
                    f"pose row {row}: actuator {i + 1} cannot close its triangle with the "
                    "given length"
                )
            turn = _angle(a_new - o) - _angle(arr["A"][i]) - ref_rad[:, i]
            alpha[:, i] = ref_rad[:, i] + _wrap(turn)
        if i + 1 < n:
            b = o + _rotate(alpha[:, i], arr["B"][i])
            o = o + _rotate(alpha[:, i], arr["next"][i])
    return np.degrees(alpha)


def inverse_kinematics(arm: Arm, target: ArrayLike, elbow: int = -1) -> dict[str, FloatArray]:
    """Closed-form inverse kinematics of a 3-link arm (model §6).

    From the load point L and the last angle α_3: ``O_3 = L − R(α_3)·next_3``, then the
    two-link chain O_1 → O_3 with ``β = α_2 − α_1``:
    ``|next_1 + R(β)·next_2| = |O_3 − O_1|`` gives
    ``β = ∠next_1 − ∠next_2 + elbow·arccos(...)`` and
    ``α_1 = ∠(O_3 − O_1) − ∠(next_1 + R(β)·next_2)``.

    Parameters
    ----------
    arm : Arm
        A 3-link arm.
    target : array_like, shape (N, 3)
        Load point x, y (global, mm) and the last link's angle α_3 (degrees).
    elbow : {-1, 1}, default -1
        Branch of the arccos (−1: α_2 < α_1 for links along their x axes).

    Returns
    -------
    dict of str to ndarray
        ``"alpha_deg"`` (N, 3)
            Absolute link angles, degrees (α_1, α_2 in [−180°, 180°); NaN where unreachable).
        ``"length_mm"`` (N, 3)
            Pin-to-pin actuator lengths of that pose, mm (NaN where unreachable, and at a
            joint turned by a rotary drive).
        ``"reachable"`` (N,)
            Whether the arccos argument lies within [−1, 1].

    Raises
    ------
    InputError
        If the arm does not have 3 links, ``elbow`` is not ±1, or the target has a wrong shape
        or a non-finite value (row named).
    """
    if arm.n != 3:
        raise InputError(f"inverse_kinematics needs a 3-link arm, this one has {arm.n} links")
    if elbow not in (-1, 1):
        raise InputError(f"elbow must be -1 or 1, got {elbow!r}")
    arr = arm.arrays()
    tgt = _as_poses(target, 3, "target")
    n1, n2, n3 = arr["next"]
    a3 = np.radians(tgt[:, 2])
    o3 = tgt[:, :2] - _rotate(a3, n3)
    d = o3 - arr["O1"]
    l1, l2 = np.hypot(*n1), np.hypot(*n2)
    cos_arg = (np.sum(d**2, axis=-1) - l1**2 - l2**2) / (2.0 * l1 * l2)
    reachable = np.abs(cos_arg) <= 1.0
    beta = _angle(n1) - _angle(n2) + elbow * np.arccos(np.where(reachable, cos_arg, np.nan))
    chain = n1 + _rotate(beta, n2)  # (N, 2)
    a1 = _wrap(_angle(d) - _angle(chain))
    a2 = _wrap(a1 + beta)
    alpha = np.degrees(np.stack([a1, a2, np.where(reachable, a3, np.nan)], axis=-1))
    length = _forward(arr, np.radians(alpha))["length_mm"]
    return {"alpha_deg": alpha, "length_mm": length, "reachable": reachable}
