"""The numpy reference's loaded pose (docs/model.md §4–§5, §10): the causes of every effect
(length changes, drive turns, pin offsets, bent links, chassis tilt) and the exact closure of
the loaded pose, link by link from the base, for any mix of linear actuators and rotary drives.

Independent of the compiled core: a linear joint's triangle is closed as a circle–circle
intersection (the core uses an arccos formula); a pinned link's bending moment is taken from
the loads to the *left* of a section (the document writes it with those to the right).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from eodarm.errors import InputError
from eodarm.model.reference_geometry import (
    _angle,
    _circle_intersection,
    _cross,
    _first_row,
    _rotate,
    _wrap,
)
from eodarm.model.reference_statics import by_kind, rotary_mask

FloatArray = NDArray[np.float64]

#: A force below this (N) has no direction: play and clearance stay centred (docs/model.md).
FORCE_ZERO_N = 1e-9
#: A drive torque below this (N·mm) has no sign: the backlash stays centred (docs/model.md §10);
#: the force threshold on a lever of 1 m, as the compiled core has it.
TORQUE_ZERO_NMM = 1e-6


# ---------------------------------------------------------------------------- link bending
def bending_field(
    points: FloatArray,
    load_points: FloatArray,
    f_local: FloatArray,
    ei: float,
    x_a: float | None,
    couples: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Bending of a link: displacement (−y·v′(x), v(x)) and slope v′(x) at local points.

    Every force change on the link, ``(f_x, f_y)`` in its frame at ``(x_p, y_p)``, is carried to
    the axis at x_p as the transverse force f_y and the couple ``C_p = −y_p·f_x`` (plus any pure
    couple given). Two supports:

    * ``x_a`` given (a link turned by a linear actuator): v = 0 at x = 0 and at x = x_a. The
      bending moment is taken from the loads to the *left* of a section,
      ``M(x) = Σ_{x_p < x} [f_y,p·(x − x_p) − C_p]``, equal to the document's "loads to the
      right" because the loads are in equilibrium. With
      ``W(x) = (1/EI)·Σ_p [f_y,p·(x − x_p)₊³/6 − C_p·(x − x_p)₊²/2]``,
      ``v = W(x) − W(0) − (W(x_a) − W(0))·x/x_a``.
    * ``x_a = None`` (a link turned by a rotary drive): clamped at the flange, v(0) = v′(0) = 0.
      Each side of x = 0 is a cantilever carrying the loads on that side: for x ≥ 0,
      ``M(x) = Σ_{x_p > x} [f_y,p·(x_p − x) + C_p]``, for x ≤ 0,
      ``M(x) = Σ_{x_p < x} [f_y,p·(x − x_p) − C_p]``; integrated in closed form from the
      clamp (loads at x_p = 0 act on the clamp and bend nothing).

    Parameters
    ----------
    points : (m, 2) local points (mm) whose displacement is wanted.
    load_points : (k, 2) local points (mm) where the force changes act.
    f_local : (N, k, 2) force changes (N) in the link frame.
    ei : flexural rigidity, N·mm².
    x_a : local abscissa of the second support (pin A), mm, nonzero; None for a clamp at 0.
    couples : (N, k) pure couples (N·mm, counter-clockwise +) at the load points, optional.

    Returns
    -------
    (N, m, 2) displacements in the link frame (mm) and (N, m) slopes v′ (rad).
    """
    xp = load_points[:, 0]
    yp = load_points[:, 1]
    fy = f_local[..., 1][:, None, :]  # (N, 1, k)
    c_all = -yp * f_local[..., 0]
    if couples is not None:
        c_all = c_all + couples
    cp = c_all[:, None, :]  # (N, 1, k)
    x = points[:, 0]
    y = points[:, 1]

    def left(at: FloatArray, mask: NDArray[np.bool_]) -> tuple[FloatArray, FloatArray]:
        """W and W′ from the loads of ``mask`` to the left of ``at``."""
        t = np.maximum(at[:, None] - xp[None, :], 0.0) * mask  # (m, k)
        w = np.sum(fy * t**3 / 6.0 - cp * t**2 / 2.0, axis=-1) / ei
        dw = np.sum(fy * t**2 / 2.0 - cp * t, axis=-1) / ei
        return w, dw  # (N, m)

    every = np.ones(xp.shape, dtype=bool)
    if x_a is not None:
        ends = left(np.array([0.0, x_a]), every)[0]  # (N, 2)
        w0 = ends[:, 0:1]
        chord = (ends[:, 1:2] - w0) / x_a  # (N, 1)
        w, dw = left(x, every)
        v = w - w0 - chord * x[None, :]
        dv = dw - chord
    else:
        zero = np.zeros(1)
        # x ≥ 0: the loads to the right, W(x) = (1/EI)·Σ [f_y (x_p − x)₊³/6 + C (x_p − x)₊²/2]
        right = xp > 0.0
        s = np.maximum(xp[None, :] - x[:, None], 0.0) * right
        s0 = np.maximum(xp[None, :] - zero[:, None], 0.0) * right
        w_r = np.sum(fy * s**3 / 6.0 + cp * s**2 / 2.0, axis=-1) / ei
        dw_r = np.sum(-fy * s**2 / 2.0 - cp * s, axis=-1) / ei
        w_r0 = np.sum(fy * s0**3 / 6.0 + cp * s0**2 / 2.0, axis=-1) / ei
        dw_r0 = np.sum(-fy * s0**2 / 2.0 - cp * s0, axis=-1) / ei
        v_r = w_r - w_r0 - dw_r0 * x[None, :]
        dv_r = dw_r - dw_r0
        # x ≤ 0: the loads to the left
        w_l, dw_l = left(x, xp < 0.0)
        w_l0, dw_l0 = left(zero, xp < 0.0)
        v_l = w_l - w_l0 - dw_l0 * x[None, :]
        dv_l = dw_l - dw_l0
        v = np.where(x[None, :] >= 0.0, v_r, v_l)
        dv = np.where(x[None, :] >= 0.0, dv_r, dv_l)
    return np.stack([-y[None, :] * dv, v], axis=-1), dv


def _bending_displacement(
    points: FloatArray,
    load_points: FloatArray,
    f_local: FloatArray,
    ei: float,
    x_a: float | None,
    couples: FloatArray | None = None,
) -> FloatArray:
    """The displacements of :func:`bending_field` alone, (N, m, 2)."""
    return bending_field(points, load_points, f_local, ei, x_a, couples)[0]


# ---------------------------------------------------------------------------- the pose
def _sign0(x: FloatArray, zero: float) -> FloatArray:
    """sign(x), 0 below ``zero`` in magnitude (no preferred side)."""
    return np.where(np.abs(x) < zero, 0.0, np.sign(x))


def _press_dir(r: FloatArray) -> FloatArray:
    """Direction of −r (N, n, 2), zero below :data:`FORCE_ZERO_N`."""
    r_norm = np.linalg.norm(r, axis=-1)
    pressed = r_norm >= FORCE_ZERO_N
    safe = np.where(pressed, r_norm, 1.0)
    return np.where(pressed[..., None], -r / safe[..., None], 0.0)


def respond(
    arr: dict[str, Any],
    par: dict[str, Any],
    geo: dict[str, FloatArray],
    alpha: FloatArray,
    st: dict[str, FloatArray],
    payload: FloatArray,
    ext: dict[str, FloatArray],
    held: dict[str, FloatArray],
    *,
    nan_on_failure: bool = False,
) -> dict[str, FloatArray]:
    """The loaded pose of one state from its statics and what the frictions hold.

    ``st`` is the state's statics (``reference_statics.solve_statics``, relative to the
    sequence's reference), ``held`` what each joint's parts take (``reference_friction``): the
    whole drive or actuator S_joint, its body or gear spring S_body, the joint friction's couple.

    Linear joint i (docs/model.md §4, §9): the actuator's actual force is the reference's plus
    S_joint; the body deforms with S_body, the mount with S_joint, a play sits on the side of
    the actual force; the reaction changes by −δ_i, δ_i = (S_joint − ΔF_i)·e_i; the triangle
    is closed with the new length. Rotary joint i (§10): the drive's actual torque is the
    reference's plus S_joint; the gear yields Δq_i = −S_body/k_i, a backlash −b·sign(actual
    torque) (less the reference's side when taken up), a user's turn adds; the reaction is the
    frictionless one (a couple does not move it); link i's loaded angle is body i−1's, plus
    the housing's turn with body i−1's bending slope at O_i, plus q_i + Δq_i. A bent link
    carries at O_i the whole ΔT_i of a drive (drive and joint friction together), the joint
    friction's couple of a linear joint; it is pinned at O_i and x_A (linear joint, chord
    frame) or clamped at O_i (rotary joint, flange frame).
    """
    n_rows, n = alpha.shape
    rot = rotary_mask(arr)
    lin = ~rot
    e = st["e"]
    du = st["du"]
    s_joint, s_body, couple = held["joint"], held["body"], held["couple"]
    delta = np.where(lin, s_joint - du, 0.0)[..., None] * e  # (N, n, 2)
    # the reference's unknown plus S_joint, written as the frictionless loaded one plus what
    # the joint holds back (exactly the frictionless numbers when nothing is held)
    u_actual = st["u"] + (s_joint - du)
    r_actual = st["reaction_n"] - delta
    dr = st["dreaction_n"] - delta

    # --- linear joints: actuator lengths
    k = par["k"]
    k_lin = np.where(lin, k, 1.0)
    ell = geo["length_mm"]
    d_body = np.where(lin, -s_body / k_lin + ext["extra_seen_mm"], np.nan)
    d_mount = -s_joint / par["k_mount"] + ext["extra_unseen_mm"]
    turned = _sign0(u_actual, FORCE_ZERO_N) - np.where(
        par["gap_up"], _sign0(st["u0"], FORCE_ZERO_N), 0.0
    )
    d_length = np.where(lin, d_body + d_mount - par["play"] * turned, np.nan)
    ell_new = ell + d_length

    # --- rotary joints: the drive's turn Δq (rad)
    k_rot = np.where(rot, k, 1.0)
    lost = _sign0(u_actual, TORQUE_ZERO_NMM) - np.where(
        par["gap_up"], _sign0(st["u0"], TORQUE_ZERO_NMM), 0.0
    )
    dq = np.where(
        rot, -s_body / k_rot - np.radians(par["backlash_deg"]) * lost + ext["extra_turn_rad"], 0.0
    )

    # --- joint clearance: offset c·u (global), taken up: c·(u − u0)
    u = _press_dir(r_actual) - np.where(
        par["clearance_up"][None, :, None], _press_dir(st["reaction_unloaded_n"]), 0.0
    )
    clear = par["clearance"][None, :, None] * u + ext["extra_joint_mm"]

    # --- link bending
    bent = _bend(arr, par, alpha, e, du, dr, s_joint, couple, payload)

    # --- base compliance: the chassis turns about the pivot (only the payload changes)
    pivot = arr["pivot"]
    if par["k_base"] is None:
        dphi = np.zeros(n_rows)
    else:
        dphi = _cross(geo["O"][:, n] - pivot, payload) / par["k_base"]
    dphi = dphi + ext["extra_tilt_rad"]

    # --- close the loaded pose from the base to the tip
    side = np.sign(_cross(geo["B"] - geo["O"][:, :n], geo["A"] - geo["O"][:, :n]))  # (N, n)
    alpha_new = np.empty_like(alpha)
    o_new = pivot + _rotate(dphi, arr["O1"] - pivot) + clear[:, 0]
    b_new = pivot + _rotate(dphi, arr["B0"] - pivot)
    turn_prev = dphi  # body i−1's loaded angle minus its unloaded one (chassis: Δφ)
    for i in range(n):
        if i > 0:
            prev_o, prev_a = o_new, alpha_new[:, i - 1]
            o_new = prev_o + _rotate(prev_a, arr["next"][i - 1] + bent["next"][i - 1]) + clear[:, i]
            b_new = prev_o + _rotate(prev_a, arr["B"][i - 1] + bent["B"][i - 1])
        if rot[i]:
            # α′_i = α′_{i−1} + housing + q_i + Δq_i, q_i = α_i − α_{i−1}: the drive keeps
            # its angle and adds its own turn to body i−1's
            housing = bent["slope_next"][i - 1] if i > 0 else 0.0
            alpha_new[:, i] = alpha[:, i] + _wrap(turn_prev + housing + dq[:, i])
        else:
            a_loc = arr["A"][i] + bent["A"][i]  # (N, 2)
            rho = np.linalg.norm(a_loc, axis=-1)
            a_new, ok = _circle_intersection(o_new, rho, b_new, ell_new[:, i], side[:, i])
            if not ok.all() and not nan_on_failure:
                row = _first_row(~ok)[0]
                raise InputError(
                    f"pose row {row}: actuator {i + 1} cannot close its triangle with the "
                    "loaded length"
                )
            a_new[~ok] = np.nan  # the pose failed: NaN from here on
            turn = _angle(a_new - o_new) - _angle(a_loc) - alpha[:, i]
            alpha_new[:, i] = alpha[:, i] + _wrap(turn)
        turn_prev = alpha_new[:, i] - alpha[:, i]

    m_new = o_new + _rotate(alpha_new[:, n - 1], arr["measure"] + bent["measure"])
    dm = m_new - geo["measure"] + ext["extra_measure_mm"]
    out = {
        "reaction_n": r_actual,
        "dx_mm": dm[:, 0],
        "dy_mm": dm[:, 1],
        "dalpha_deg": np.degrees(alpha_new - alpha),
        "dl_mm": d_body,
        "dlength_mm": d_length,
        "length_mm": ell,
    }
    out.update(by_kind(rot, "force_n", "torque_nmm", u_actual))
    out.update(by_kind(rot, "dforce_n", "dtorque_nmm", s_joint))
    failed = np.isnan(alpha_new).any(axis=1)
    if failed.any():  # a failed pose is NaN in every output, as the compiled core fills it
        out = {
            key: np.where(failed.reshape((-1,) + (1,) * (v.ndim - 1)), np.nan, v)
            for key, v in out.items()
        }
    return out


def _bend(
    arr: dict[str, Any],
    par: dict[str, Any],
    alpha: FloatArray,
    e: FloatArray,
    du: FloatArray,
    dr: FloatArray,
    s_joint: FloatArray,
    couple: FloatArray,
    payload: FloatArray,
) -> dict[str, Any]:
    """Displacements (link frame) of each link's A, B, next and (last link) measure points,
    and the slope v′ at next (the turn of a drive housed there), from its bending.

    The force changes on link i: ΔR_i at O_i (the actual one), the actuator's S_joint·e_i at
    A_i, the next actuator's −S_joint·e at B_i, −ΔR_{i+1} at O_{i+1}, the payload at the last
    link's next point; couples: at O_i the whole ΔT_i of a drive (or a linear joint friction's
    couple), at O_{i+1} the opposite of joint i+1's. Weights do not change."""
    n_rows, n = alpha.shape
    rot = rotary_mask(arr)
    zero = np.zeros((n_rows, 2))
    out: dict[str, Any] = {
        "next": [zero] * n,
        "A": [zero] * n,
        "B": [zero] * n,
        "slope_next": [np.zeros(n_rows)] * n,
        "measure": zero,
    }
    # the couple at O_i acting on link i: a drive's whole torque change, a friction's couple
    at_joint = np.where(rot, du, couple)
    for i in range(n):
        ei = par["ei"][i]
        if ei is None:
            continue
        last = i == n - 1
        pts = [np.zeros(2), arr["next"][i]]
        forces = [dr[:, i], payload if last else -dr[:, i + 1]]
        couples = [at_joint[:, i], np.zeros(n_rows) if last else -at_joint[:, i + 1]]
        if not rot[i]:
            pts.append(arr["A"][i])
            forces.append(s_joint[:, i, None] * e[:, i])
            couples.append(np.zeros(n_rows))
        if not last and not rot[i + 1]:
            pts.append(arr["B"][i])
            forces.append(-s_joint[:, i + 1, None] * e[:, i + 1])
            couples.append(np.zeros(n_rows))
        f_local = _rotate(-alpha[:, i, None], np.stack(forces, axis=1))  # (N, k, 2)
        wanted = np.stack([arr["A"][i], arr["next"][i], arr["B"][i], arr["measure"]])
        x_a = None if rot[i] else float(arr["A"][i, 0])
        disp, slope = bending_field(
            wanted, np.stack(pts), f_local, float(ei), x_a, np.stack(couples, axis=1)
        )
        out["A"][i], out["next"][i], out["slope_next"][i] = disp[:, 0], disp[:, 1], slope[:, 1]
        if not last:
            out["B"][i] = disp[:, 2]
        else:
            out["measure"] = disp[:, 3]
    return out
