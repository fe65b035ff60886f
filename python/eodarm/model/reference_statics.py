"""The numpy reference's statics (docs/model.md §3, §10): all 3n equilibrium equations of an
arm whose joints are turned by linear actuators or rotary drives, as one linear system.

Independent of the compiled core, which recurses from the tip to the base:
:mod:`eodarm.model.reference` re-exports what is public.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from eodarm.errors import InputError
from eodarm.model.reference_geometry import _cross, _first_row

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: Relative threshold on the actuator moment arm below which a pose is singular (model §3).
SINGULAR_RTOL = 1e-9


def rotary_mask(arr: dict[str, Any]) -> BoolArray:
    """(n,) whether each joint is turned by a rotary drive (``Arm.arrays()["kind"] == 1``)."""
    return np.asarray(arr["kind"]) == 1.0


def unit_and_check(geo: dict[str, FloatArray], rot: BoolArray) -> tuple[FloatArray, FloatArray]:
    """Actuator unit vectors e_i (N, n, 2) and signed moment arms h_i (N, n); refuse a singular
    pose of a linear actuator. A rotary joint has no actuator line: e_i = 0, h_i = NaN."""
    n = rot.shape[0]
    lin = ~rot
    d = geo["A"] - geo["B"]
    ell = np.linalg.norm(d, axis=-1)
    r = geo["A"] - geo["O"][:, :n]
    r_norm = np.linalg.norm(r, axis=-1)
    zero = ~(ell > 1e-12 * (1.0 + r_norm)) & lin
    if zero.any():
        row, i = _first_row(zero)
        raise InputError(f"pose row {row}: actuator {i + 1} has coincident pins (zero length)")
    e = np.where(lin[:, None], d, 0.0) / np.where(lin, ell, 1.0)[..., None]
    h = _cross(r, e)
    # |h| is a length (mm): compared with the pin's distance |A − O|, a dimensionless test.
    bad = ~(np.abs(h) >= SINGULAR_RTOL * r_norm) & lin
    if bad.any():
        row, i = _first_row(bad)
        raise InputError(
            f"pose row {row}: actuator {i + 1} passes through joint O{i + 1} (singular pose)"
        )
    return e, np.where(lin, h, np.nan)


def statics_system(
    arr: dict[str, Any],
    geo: dict[str, FloatArray],
    e: FloatArray,
    self_weight: bool,
) -> tuple[FloatArray, FloatArray]:
    """The batched 3n×3n equilibrium matrix and the self-weight right-hand side.

    Unknowns per joint i (0-based), at columns 3i, 3i+1, 3i+2: u_i, R_i,x, R_i,y, where u_i is
    the axial force F_i of a linear actuator (N, compression +) or the torque T_i of a rotary
    drive (N·mm, on link i, counter-clockwise +). Equations at rows 3i, 3i+1, 3i+2: Σ F_x,
    Σ F_y and Σ M about the global origin on link i.

    Loads: a linear actuator pushes link i with +F_i·e_i at A_i and body i−1 with −F_i·e_i at
    B_{i−1}, half its weight at each pin; a rotary drive turns link i with the couple T_i and
    body i−1 with −T_i, its whole weight at O_i on body i−1. For i = 1 the chassis takes what
    acts on body 0.
    """
    o, a, b, c = geo["O"], geo["A"], geo["B"], geo["C"]
    n_rows, n = geo["A"].shape[:2]
    rot = rotary_mask(arr)
    k = np.zeros((n_rows, 3 * n, 3 * n))
    rhs = np.zeros((n_rows, 3 * n))
    g = float(arr["g"])
    link_w = arr["link_mass"] * g if self_weight else np.zeros(n)
    act_w = arr["act_mass"] * g if self_weight else np.zeros(n)
    for i in range(n):
        r = 3 * i
        if rot[i]:
            k[:, r + 2, r] = 1.0  # the couple T_i on link i
            own_w = 0.0  # the drive's weight sits on body i−1
        else:
            k[:, r, r] = e[:, i, 0]  # +F_i e_i at A_i
            k[:, r + 1, r] = e[:, i, 1]
            k[:, r + 2, r] = _cross(a[:, i], e[:, i])
            own_w = 0.5 * act_w[i]
        # proximal reaction R_i at O_i
        k[:, r, r + 1] = 1.0
        k[:, r + 1, r + 2] = 1.0
        k[:, r + 2, r + 1] = -o[:, i, 1]
        k[:, r + 2, r + 2] = o[:, i, 0]
        # known loads: the link's weight at C_i, half of actuator i's at A_i
        fy = -link_w[i] - own_w
        mz = -link_w[i] * c[:, i, 0] - own_w * a[:, i, 0]
        if i + 1 < n:
            j = 3 * (i + 1)
            if rot[i + 1]:
                k[:, r + 2, j] = -1.0  # the couple −T_{i+1} on link i
                fy = fy - act_w[i + 1]  # drive i+1's weight at O_{i+1}
                mz = mz - act_w[i + 1] * o[:, i + 1, 0]
            else:
                # −F_{i+1} e_{i+1} and half of actuator (i+1)'s weight at B_i
                k[:, r, j] = -e[:, i + 1, 0]
                k[:, r + 1, j] = -e[:, i + 1, 1]
                k[:, r + 2, j] = -_cross(b[:, i + 1], e[:, i + 1])
                fy = fy - 0.5 * act_w[i + 1]
                mz = mz - 0.5 * act_w[i + 1] * b[:, i + 1, 0]
            # distal reaction −R_{i+1} at O_{i+1}
            k[:, r, j + 1] = -1.0
            k[:, r + 1, j + 2] = -1.0
            k[:, r + 2, j + 1] = o[:, i + 1, 1]
            k[:, r + 2, j + 2] = -o[:, i + 1, 0]
        rhs[:, r + 1] = -fy
        rhs[:, r + 2] = -mz
    return k, rhs


def payload_rhs(geo: dict[str, FloatArray], payload: FloatArray) -> FloatArray:
    """Right-hand side of the payload P at the load point (last link only)."""
    n_rows, n = geo["A"].shape[:2]
    rhs = np.zeros((n_rows, 3 * n))
    r = 3 * (n - 1)
    load_pt = geo["O"][:, n]
    rhs[:, r] = -payload[:, 0]
    rhs[:, r + 1] = -payload[:, 1]
    rhs[:, r + 2] = -_cross(load_pt, payload)
    return rhs


def _split(x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Solution vectors (N, 3n) → joint unknowns u (N, n) and reactions (N, n, 2)."""
    return x[:, 0::3], np.stack([x[:, 1::3], x[:, 2::3]], axis=-1)


def solve_statics(
    arr: dict[str, Any],
    geo: dict[str, FloatArray],
    payload: FloatArray,
    self_weight: bool,
) -> dict[str, FloatArray]:
    """Unloaded, loaded and payload-only statics on the undeformed geometry.

    Returns the joint unknowns ``u0`` (unloaded), ``u`` (loaded), ``du`` (the payload's part)
    (N, n), a force (N) at a linear joint and a torque (N·mm) at a rotary one; the reactions
    ``reaction_unloaded_n``, ``reaction_n``, ``dreaction_n`` (N, n, 2); ``e`` and ``h`` of
    :func:`unit_and_check`; and the outputs by kind: ``force_n``, ``force_unloaded_n``,
    ``dforce_n`` NaN at rotary joints, ``torque_nmm``, ``torque_unloaded_nmm``,
    ``dtorque_nmm`` NaN at linear joints.
    """
    rot = rotary_mask(arr)
    e, h = unit_and_check(geo, rot)
    k, rhs_w = statics_system(arr, geo, e, self_weight)
    rhs_p = payload_rhs(geo, payload)
    cols = np.stack([rhs_w, rhs_w + rhs_p, rhs_p], axis=-1)  # (N, 3n, 3)
    x = np.asarray(np.linalg.solve(k, cols), dtype=np.float64)
    u0, r0 = _split(x[..., 0])
    u1, r1 = _split(x[..., 1])
    du, dr = _split(x[..., 2])
    out = {
        "e": e,
        "h": h,
        "u0": u0,
        "u": u1,
        "du": du,
        "reaction_unloaded_n": r0,
        "reaction_n": r1,
        "dreaction_n": dr,
    }
    out.update(by_kind(rot, "force_unloaded_n", "torque_unloaded_nmm", u0))
    out.update(by_kind(rot, "force_n", "torque_nmm", u1))
    out.update(by_kind(rot, "dforce_n", "dtorque_nmm", du))
    return out


def by_kind(rot: BoolArray, force: str, torque: str, u: FloatArray) -> dict[str, FloatArray]:
    """Joint unknowns (N, n) as a force array (NaN at rotary joints) and a torque array (NaN
    at linear joints), under the names ``force`` and ``torque``."""
    return {force: np.where(rot, np.nan, u), torque: np.where(rot, u, np.nan)}
