"""Independent numpy reference implementation of the eodarm model.

Everything here is derived from ``docs/model.md`` (and ``docs/formats.md``) alone; it is the
yardstick the compiled core is tested against, so where the document allows it, it uses a
*different but equivalent* formulation:

* statics: all 3n equilibrium equations (Σx, Σy, ΣM about the global origin, per link) as one
  3n×3n linear system per pose, solved batched (the core recurses from tip to base);
* triangle closure: circle–circle intersection (the core uses an arccos formula);
* link bending: the bending moment from the loads to the *left* of a section (the document
  writes it with the loads to the right; both agree because every link is in equilibrium).

Units everywhere: mm, N, kg, N·mm, degrees at the interface (radians inside). Global frame:
x forward, y up, angles counter-clockwise positive. Arrays are batched over poses (first axis
N); there is no Python loop over poses, only over the n links.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from eodarm.errors import EffectError, InputError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, as_effects, effect_arrays, split_effects, with_arm_effects
from eodarm.model.reference_friction import held_forces
from eodarm.model.reference_geometry import (
    _angle,
    _as_float,
    _as_mass,
    _as_payload,
    _as_poses,
    _check_finite,
    _circle_intersection,
    _cross,
    _first_row,
    _forward,
    _rotate,
    _wrap,
    angles_from_lengths,
    forward,
    inverse_kinematics,
)

__all__ = [
    "angles_from_lengths",
    "forward",
    "inverse_kinematics",
    "solve",
    "solve_payload",
    "solve_sequence",
    "statics",
]

FloatArray = NDArray[np.float64]

#: Relative threshold on the actuator moment arm below which a pose is singular (model §3).
SINGULAR_RTOL = 1e-9
# A force below this (N) has no direction: play and clearance stay centred (docs/model.md).
FORCE_ZERO_N = 1e-9


# ---------------------------------------------------------------------------- statics
def _unit_and_check(
    geo: dict[str, FloatArray],
) -> tuple[FloatArray, FloatArray]:
    """Actuator unit vectors e_i (N, n, 2) and moment arms h_i (N, n); refuse singular poses."""
    n = geo["A"].shape[1]
    d = geo["A"] - geo["B"]
    ell = geo["length_mm"]
    r = geo["A"] - geo["O"][:, :n]
    r_norm = np.linalg.norm(r, axis=-1)
    zero = ~(ell > 1e-12 * (1.0 + r_norm))
    if zero.any():
        row, i = _first_row(zero)
        raise InputError(f"pose row {row}: actuator {i + 1} has coincident pins (zero length)")
    e = d / ell[..., None]
    h = _cross(r, e)
    # |h| is a length (mm): compared with the pin's distance |A − O|, a dimensionless test.
    bad = ~(np.abs(h) >= SINGULAR_RTOL * r_norm)
    if bad.any():
        row, i = _first_row(bad)
        raise InputError(
            f"pose row {row}: actuator {i + 1} passes through joint O{i + 1} (singular pose)"
        )
    return e, h


def _statics_system(
    arr: dict[str, FloatArray],
    geo: dict[str, FloatArray],
    e: FloatArray,
    self_weight: bool,
) -> tuple[FloatArray, FloatArray]:
    """The batched 3n×3n equilibrium matrix and the self-weight right-hand side.

    Unknowns per link i (0-based), at columns 3i, 3i+1, 3i+2: F_i, R_i,x, R_i,y. Equations at
    rows 3i, 3i+1, 3i+2: Σ F_x, Σ F_y and Σ M about the global origin on link i.
    """
    o, a, b, c = geo["O"], geo["A"], geo["B"], geo["C"]
    n_rows, n = geo["length_mm"].shape
    k = np.zeros((n_rows, 3 * n, 3 * n))
    rhs = np.zeros((n_rows, 3 * n))
    g = float(arr["g"])
    link_w = arr["link_mass"] * g if self_weight else np.zeros(n)
    act_w = arr["act_mass"] * g if self_weight else np.zeros(n)
    for i in range(n):
        r = 3 * i
        # own actuator force +F_i e_i at A_i
        k[:, r, r] = e[:, i, 0]
        k[:, r + 1, r] = e[:, i, 1]
        k[:, r + 2, r] = _cross(a[:, i], e[:, i])
        # proximal reaction R_i at O_i
        k[:, r, r + 1] = 1.0
        k[:, r + 1, r + 2] = 1.0
        k[:, r + 2, r + 1] = -o[:, i, 1]
        k[:, r + 2, r + 2] = o[:, i, 0]
        # known loads: weights (downward) at C_i, half actuator i at A_i
        fy = -link_w[i] - 0.5 * act_w[i]
        mz = -link_w[i] * c[:, i, 0] - 0.5 * act_w[i] * a[:, i, 0]
        if i + 1 < n:
            j = 3 * (i + 1)
            # next actuator's reaction −F_{i+1} e_{i+1} at B_i (global row i+1 of "B")
            k[:, r, j] = -e[:, i + 1, 0]
            k[:, r + 1, j] = -e[:, i + 1, 1]
            k[:, r + 2, j] = -_cross(b[:, i + 1], e[:, i + 1])
            # distal reaction −R_{i+1} at O_{i+1}
            k[:, r, j + 1] = -1.0
            k[:, r + 1, j + 2] = -1.0
            k[:, r + 2, j + 1] = o[:, i + 1, 1]
            k[:, r + 2, j + 2] = -o[:, i + 1, 0]
            # half of actuator (i+1)'s weight at B_i
            fy = fy - 0.5 * act_w[i + 1]
            mz = mz - 0.5 * act_w[i + 1] * b[:, i + 1, 0]
        rhs[:, r + 1] = -fy
        rhs[:, r + 2] = -mz
    return k, rhs


def _payload_rhs(geo: dict[str, FloatArray], payload: FloatArray) -> FloatArray:
    """Right-hand side of the payload P at the load point (last link only)."""
    n_rows, n = geo["length_mm"].shape
    rhs = np.zeros((n_rows, 3 * n))
    r = 3 * (n - 1)
    load_pt = geo["O"][:, n]
    rhs[:, r] = -payload[:, 0]
    rhs[:, r + 1] = -payload[:, 1]
    rhs[:, r + 2] = -_cross(load_pt, payload)
    return rhs


def _split(x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Solution vectors (N, 3n) → forces (N, n) and reactions (N, n, 2)."""
    return x[:, 0::3], np.stack([x[:, 1::3], x[:, 2::3]], axis=-1)


def _statics(
    arr: dict[str, FloatArray],
    geo: dict[str, FloatArray],
    payload: FloatArray,
    self_weight: bool,
) -> dict[str, FloatArray]:
    """Unloaded, loaded and payload-only statics on the undeformed geometry."""
    e, h = _unit_and_check(geo)
    k, rhs_w = _statics_system(arr, geo, e, self_weight)
    rhs_p = _payload_rhs(geo, payload)
    cols = np.stack([rhs_w, rhs_w + rhs_p, rhs_p], axis=-1)  # (N, 3n, 3)
    x = np.asarray(np.linalg.solve(k, cols), dtype=np.float64)
    f0, r0 = _split(x[..., 0])
    f1, r1 = _split(x[..., 1])
    df, dr = _split(x[..., 2])
    return {
        "e": e,
        "h": h,
        "force_unloaded_n": f0,
        "reaction_unloaded_n": r0,
        "force_n": f1,
        "reaction_n": r1,
        "dforce_n": df,
        "dreaction_n": dr,
    }


def statics(
    arm: Arm,
    alpha_deg: ArrayLike,
    payload_n: ArrayLike,
    self_weight: bool = True,
) -> dict[str, FloatArray]:
    """Actuator forces and joint reactions on the undeformed arm (model §2–§3).

    All 3n equilibrium equations (Σx, Σy, ΣM about the global origin for every link) are
    solved as one 3n×3n linear system per pose, batched over poses.

    Parameters
    ----------
    arm : Arm
        The arm.
    alpha_deg : array_like, shape (N, n)
        Unloaded absolute link angles, degrees.
    payload_n : array_like, shape (N, 2) or (2,)
        Payload force vector (N) applied at the load point, global frame.
    self_weight : bool, default True
        Include link weights (at C) and actuator weights (half at each pin; the chassis half of
        actuator 1 is lost into the chassis). ``g = arm.g`` in m/s², masses in kg → N.

    Returns
    -------
    dict of str to ndarray
        ``"force_n"`` (N, n)
            Loaded actuator forces in N, compression positive.
        ``"reaction_n"`` (N, n, 2)
            Loaded joint reactions in N: the force body i−1 exerts on link i at O_i (global).
        ``"force_unloaded_n"``, ``"reaction_unloaded_n"``
            The same for the unloaded state (self-weight only).
        ``"force0_n"``, ``"reaction0_n"``
            The same unloaded arrays under the compiled core's names (``_core.statics``).
        ``"length_mm"`` (N, n)
            Unloaded pin-to-pin actuator lengths, mm.

    Raises
    ------
    InputError
        Wrong shape or non-finite input, or a singular pose (an actuator's line through its
        joint); the message names the row.
    """
    arr = arm.arrays()
    alpha = _as_poses(alpha_deg, arm.n, "alpha_deg")
    payload = _as_payload(payload_n, alpha.shape[0])
    geo = _forward(arr, np.radians(alpha))
    st = _statics(arr, geo, payload, bool(self_weight))
    out = {
        key: st[key] for key in ("force_n", "reaction_n", "force_unloaded_n", "reaction_unloaded_n")
    }
    out["force0_n"] = st["force_unloaded_n"]
    out["reaction0_n"] = st["reaction_unloaded_n"]
    out["length_mm"] = geo["length_mm"]
    return out


# ---------------------------------------------------------------------------- effects
def _effect_params(arm: Arm, effects: Any) -> dict[str, Any]:
    """Per-place parameters of the effects (validated), defaults meaning "absent"."""
    effs: list[Effect] = with_arm_effects(arm.effects, effects)
    effect_arrays(effs, arm.n)  # refuses non-Effects, places beyond n and duplicates
    n = arm.n
    p: dict[str, Any] = {
        "k_body": np.array([a.stiffness_n_per_mm for a in arm.actuators], dtype=float),
        "k_mount": np.full(n, np.inf),
        "play": np.zeros(n),
        "clearance": np.zeros(n),
        # Gaps taken up by the unloaded forces (Effect.unloaded == "taken_up").
        "play_up": np.zeros(n, dtype=bool),
        "clearance_up": np.zeros(n, dtype=bool),
        "ei": [None] * n,
        "k_base": None,
        # Coulomb friction limits (docs/model.md): N in actuator i's body, N·mm in joint O_i.
        "actuator_friction": np.zeros(n),
        "joint_friction": np.zeros(n),
    }
    for e in effs:
        i = e.index(n)
        if e.name == "actuator_compliance":
            p["k_body"][i] = e.value
        elif e.name == "mount_compliance":
            p["k_mount"][i] = e.value
        elif e.name == "actuator_play":
            p["play"][i] = e.value
            p["play_up"][i] = e.unloaded == "taken_up"
        elif e.name == "joint_clearance":
            p["clearance"][i] = e.value
            p["clearance_up"][i] = e.unloaded == "taken_up"
        elif e.name == "link_bending":
            if arm.links[i].A[0] == 0.0:
                raise EffectError(
                    f"effect {e.key}: link {i + 1} has its pin A at x = 0, so the beam has "
                    "only one support"
                )
            p["ei"][i] = e.value
        elif e.name == "base_compliance":
            p["k_base"] = e.value
        elif e.name in ("actuator_friction", "joint_friction"):
            p[e.name][i] = e.value
        else:  # pragma: no cover - the catalogue and this list must agree
            raise EffectError(f"effect {e.key}: not implemented by the numpy reference")
    return p


def _bending_displacement(
    points: FloatArray,
    load_points: FloatArray,
    f_local: FloatArray,
    ei: float,
    x_a: float,
    couples: FloatArray | None = None,
) -> FloatArray:
    """Displacement (−y·v′(x), v(x)) of local points of a bent link (model §4, link bending).

    The bending moment is taken from the loads to the *left* of a section,
    ``M(x) = Σ_{x_p < x} [f_y,p·(x − x_p) − C_p]`` with ``C_p = −y_p·f_x,p``, which equals the
    document's "loads to the right" form because the loads on the link are in equilibrium
    (Σ f_y = 0 and Σ (x_p f_y,p + C_p) = 0). Integrating ``EI·v″ = M`` twice in closed form:
    ``W(x) = (1/EI)·Σ_p [f_y,p·(x − x_p)₊³/6 − C_p·(x − x_p)₊²/2]``, and
    ``v = W(x) − W(0) − (W(x_A) − W(0))·x/x_A`` meets the supports v(0) = v(x_A) = 0.

    Parameters
    ----------
    points : ndarray, shape (m, 2)
        Local points (mm) whose displacement is wanted.
    load_points : ndarray, shape (k, 2)
        Local points (mm) where the force changes act.
    f_local : ndarray, shape (N, k, 2)
        Force changes (N) in the link frame.
    ei : float
        Flexural rigidity, N·mm².
    x_a : float
        Local abscissa of the second support (pin A), mm, nonzero.
    couples : ndarray, shape (N, k), optional
        Pure couples (N·mm, counter-clockwise +) acting at the load points besides the forces
        (the friction couples of ``joint_friction``); they add to C_p.

    Returns
    -------
    ndarray, shape (N, m, 2)
        Displacements in the link frame, mm.
    """
    xp = load_points[:, 0]
    yp = load_points[:, 1]
    fy = f_local[..., 1][:, None, :]  # (N, 1, k)
    c_all = -yp * f_local[..., 0]
    if couples is not None:
        c_all = c_all + couples
    cp = c_all[:, None, :]  # (N, 1, k)

    def w(x: FloatArray) -> FloatArray:
        s = np.maximum(x[:, None] - xp[None, :], 0.0)  # (m, k)
        return np.sum(fy * s**3 / 6.0 - cp * s**2 / 2.0, axis=-1) / ei  # (N, m)

    def dw(x: FloatArray) -> FloatArray:
        s = np.maximum(x[:, None] - xp[None, :], 0.0)
        return np.sum(fy * s**2 / 2.0 - cp * s, axis=-1) / ei

    ends = w(np.array([0.0, x_a]))  # (N, 2)
    w0 = ends[:, 0:1]
    slope = (ends[:, 1:2] - w0) / x_a  # (N, 1)
    x = points[:, 0]
    y = points[:, 1]
    v = w(x) - w0 - slope * x[None, :]
    dv = dw(x) - slope
    return np.stack([-y[None, :] * dv, v], axis=-1)


# ---------------------------------------------------------------------------- extras
#: The extra deformations of user effects (custom-effects.md) as whole-arm arrays: name → the shape
#: of one pose's values ("n" the number of links). The same names as ``_core.solve``'s.
EXTRA_SHAPES: dict[str, tuple[str | int, ...]] = {
    "extra_seen_mm": ("n",),
    "extra_unseen_mm": ("n",),
    "extra_joint_mm": ("n", 2),
    "extra_tilt_rad": (),
    "extra_measure_mm": (2,),
}


def _extras(extra: Any, n_rows: int, n: int) -> dict[str, FloatArray]:
    """The extra deformations, every key present (zeros when absent), checked.

    ``extra_seen_mm`` (N, n) pin-to-pin length change each actuator's sensor sees,
    ``extra_unseen_mm`` (N, n) one it does not see, ``extra_joint_mm`` (N, n, 2) offset of link
    i's pin centre at O_i (global), ``extra_tilt_rad`` (N,) chassis tilt about the pivot,
    ``extra_measure_mm`` (N, 2) global displacement of the measure point.
    """
    given = {} if extra is None else dict(extra)
    unknown = sorted(set(given) - set(EXTRA_SHAPES))
    if unknown:
        raise InputError(f"extra: unknown key {unknown[0]!r}; known: {', '.join(EXTRA_SHAPES)}")
    out: dict[str, FloatArray] = {}
    for key, per_row in EXTRA_SHAPES.items():
        shape = (n_rows, *(n if d == "n" else int(d) for d in per_row))
        if key not in given or given[key] is None:
            out[key] = np.zeros(shape)
            continue
        a = _as_float(given[key], key)
        if a.shape != shape:
            raise InputError(f"{key} must have shape {shape}, got {a.shape}")
        _check_finite(a, key)
        out[key] = a
    return out


# ---------------------------------------------------------------------------- the solver
def solve_payload(
    arm: Arm,
    alpha_deg: ArrayLike,
    payload_n: ArrayLike,
    effects: Any = (),
    self_weight: bool = True,
    extra: Any = None,
    nan_on_failure: bool = False,
) -> dict[str, FloatArray]:
    """Loaded minus unloaded response of the arm to a payload force (model §4–§5).

    Forces of both states come from statics on the undeformed geometry; the loaded pose is
    then closed exactly, link by link from the base, with every effect's cause applied at once
    (length changes, joint-pin offsets, bending displacements, chassis tilt). Each actuator
    triangle is closed as a circle–circle intersection (centre O′_i radius |a|, centre B′_{i−1}
    radius ℓ′_i) on the same side as in the unloaded pose.

    Parameters
    ----------
    arm : Arm
        The arm.
    alpha_deg : array_like, shape (N, n)
        Unloaded absolute link angles, degrees.
    payload_n : array_like, shape (N, 2) or (2,)
        Payload force (N) at the load point, global frame.
    effects : iterable of Effect, optional
        The effects added to the baseline model (at most one per name and place).
    self_weight : bool, default True
        Whether both states carry the link and actuator weights.
    extra : dict of str to array_like, optional
        Deformations of user-written effects added to the effects' (docs/custom-effects.md), each
        optional: ``extra_seen_mm`` (N, n), ``extra_unseen_mm`` (N, n), ``extra_joint_mm``
        (N, n, 2), ``extra_tilt_rad`` (N,), ``extra_measure_mm`` (N, 2) (see ``_extras``).
    nan_on_failure : bool, default False
        A pose whose loaded triangle cannot close gets NaN in its loaded-pose outputs instead
        of an error naming its row (as the compiled core's ``nan_on_failure``).

    Returns
    -------
    dict of str to ndarray
        ``"force_n"`` (N, n)
            Loaded actuator forces, N (compression positive).
        ``"reaction_n"`` (N, n, 2)
            Loaded joint reactions (body i−1 on link i at O_i), N, global.
        ``"dforce_n"`` (N, n)
            Loaded minus unloaded actuator force, N.
        ``"dx_mm"``, ``"dy_mm"`` (N,)
            Displacement of the measure point, mm, global.
        ``"dalpha_deg"`` (N, n)
            Change of each link's absolute angle (the chord angle of a bent link), degrees.
        ``"dl_mm"`` (N, n)
            Change of each actuator body's length as its own sensor sees it, −ΔF/k_body (plus
            ``extra_seen_mm``), mm.
        ``"dlength_mm"`` (N, n)
            Total pin-to-pin length change (body, mount and play), mm.
        ``"length_mm"`` (N, n)
            Unloaded pin-to-pin length, mm.

    Raises
    ------
    InputError
        Wrong shape, non-finite input, a singular pose or a loaded triangle that cannot close
        (the row and actuator are named).
    EffectError
        Unknown, duplicated or misplaced effects, or link bending on a link with A at x = 0.
    """
    n = arm.n
    arr = arm.arrays()
    alpha_d = _as_poses(alpha_deg, n, "alpha_deg")
    n_rows = alpha_d.shape[0]
    payload = _as_payload(payload_n, n_rows)
    effs = as_effects(effects)
    effect_arrays(effs, n)  # types, places and duplicates over all of them
    builtin, custom_effs = split_effects(effs)
    par = _effect_params(arm, builtin)
    alpha = np.radians(alpha_d)
    geo = _forward(arr, alpha)
    st = _statics(arr, geo, payload, bool(self_weight))
    ext = _extras(extra, n_rows, n)
    if custom_effs:
        ext = _custom_extras(arm, alpha_d, payload, geo, st, custom_effs, self_weight, ext)
    # Loaded once from the reference: every friction element starts with S = 0 (the deadband).
    held = held_forces(par, st, np.zeros((n_rows, n)), np.zeros((n_rows, n)))
    return _respond(arr, par, geo, alpha, st, payload, ext, held, nan_on_failure=nan_on_failure)


def _custom_extras(
    arm: Arm,
    alpha_d: FloatArray,
    payload: FloatArray,
    geo: dict[str, FloatArray],
    st: dict[str, FloatArray],
    custom_effs: list[Effect],
    self_weight: bool,
    ext: dict[str, FloatArray],
) -> dict[str, FloatArray]:
    """The extra deformations with those of user-written effects added
    (docs/custom-effects.md): their functions read this reference's own statics of both
    states (in a sequence: the state and its reference, loaded once, without history)."""
    from eodarm.model import custom

    statics_out = {
        "force_n": st["force_n"],
        "force0_n": st["force_unloaded_n"],
        "reaction_n": st["reaction_n"],
        "reaction0_n": st["reaction_unloaded_n"],
        "length_mm": geo["length_mm"],
    }
    state = custom.EffectState.from_statics(arm, alpha_d, payload, statics_out, self_weight)
    return custom.add_extras(ext, custom.extras_of(custom_effs, state))


def _respond(
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
    """The loaded pose of one state from its statics and what the frictions hold (model §4–§5).

    ``held`` comes from ``reference_friction.held_forces``. The actuator's actual force is the
    reference's plus S_joint; the body spring deforms with S_body, the mount with S_joint, a
    play sits on the side of the actual force. The joint reaction R_i changes by −δ_i with δ_i =
    (S_joint,i − ΔF_i)·e_i (the change of the actuator's force on link i), so a clearance sits
    along the actual reaction; link bending sees the actual force changes and the friction
    couples. Without friction every one of these is the frictionless value.
    """
    n_rows, n = geo["length_mm"].shape
    e = st["e"]
    s_joint, s_body, couple = held["joint"], held["body"], held["couple"]
    delta = (s_joint - st["dforce_n"])[..., None] * e  # (N, n, 2)
    # F_ref + S_joint, written as the frictionless loaded force plus what the joint holds
    # back (exactly the frictionless numbers when nothing is held)
    f_actual = st["force_n"] + (s_joint - st["dforce_n"])
    r_actual = st["reaction_n"] - delta
    df = s_joint
    dr = st["dreaction_n"] - delta

    # --- actuator lengths
    ell = geo["length_mm"]
    d_body = -s_body / par["k_body"] + ext["extra_seen_mm"]
    d_mount = -s_joint / par["k_mount"] + ext["extra_unseen_mm"]

    def sign0(f: FloatArray) -> FloatArray:
        return np.where(np.abs(f) < FORCE_ZERO_N, 0.0, np.sign(f))

    # Play: the side of the state's actual force, less the reference's side where the weights
    # took the play up.
    turned = sign0(f_actual) - np.where(par["play_up"], sign0(st["force_unloaded_n"]), 0.0)
    d_play = -par["play"] * turned
    d_length = d_body + d_mount + d_play
    ell_new = ell + d_length

    # --- joint clearance: offset c_i u_i, a global vector (the force of the undeformed statics);
    # taken up: c_i (u_i − u0_i), u0_i the direction of the unloaded state's force
    def press_dir(r: FloatArray) -> FloatArray:
        r_norm = np.linalg.norm(r, axis=-1)
        pressed = r_norm >= FORCE_ZERO_N
        safe = np.where(pressed, r_norm, 1.0)
        return np.where(pressed[..., None], -r / safe[..., None], 0.0)  # (N, n, 2)

    u = press_dir(r_actual) - np.where(
        par["clearance_up"][None, :, None], press_dir(st["reaction_unloaded_n"]), 0.0
    )
    clear = par["clearance"][None, :, None] * u + ext["extra_joint_mm"]  # (N, n, 2), global

    # --- link bending: displacement fields of the local points that matter
    zero = np.zeros((n_rows, 2))
    d_next = [zero] * n
    d_a = [zero] * n
    d_b = [zero] * n
    d_meas = zero
    for i in range(n):
        ei = par["ei"][i]
        if ei is None:
            continue
        last = i == n - 1
        pts = [np.zeros(2), arr["A"][i], arr["next"][i]]
        forces = [dr[:, i], df[:, i, None] * e[:, i], payload if last else -dr[:, i + 1]]
        # Friction couples: +C_i at O_i on link i, −C_{i+1} at O_{i+1} (link i is body i of
        # joint i+1's friction).
        couples = [couple[:, i], np.zeros(n_rows), -couple[:, i + 1] if not last else zero[:, 0]]
        if not last:
            pts.append(arr["B"][i])
            forces.append(-df[:, i + 1, None] * e[:, i + 1])
            couples.append(np.zeros(n_rows))
        f_local = _rotate(-alpha[:, i, None], np.stack(forces, axis=1))  # (N, k, 2)
        wanted = np.stack([arr["A"][i], arr["next"][i], arr["B"][i], arr["measure"]])
        disp = _bending_displacement(
            wanted,
            np.stack(pts),
            f_local,
            float(ei),
            float(arr["A"][i, 0]),
            np.stack(couples, axis=1),
        )
        d_a[i], d_next[i] = disp[:, 0], disp[:, 1]
        if not last:
            d_b[i] = disp[:, 2]
        else:
            d_meas = disp[:, 3]

    # --- base compliance: chassis tilt about the pivot (the payload is the only external
    # load that changes; internal friction does not tilt the chassis)
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
    for i in range(n):
        if i > 0:
            prev_o, prev_a = o_new, alpha_new[:, i - 1]
            o_new = prev_o + _rotate(prev_a, arr["next"][i - 1] + d_next[i - 1]) + clear[:, i]
            b_new = prev_o + _rotate(prev_a, arr["B"][i - 1] + d_b[i - 1])
        a_loc = arr["A"][i] + d_a[i]  # (N, 2)
        rho = np.linalg.norm(a_loc, axis=-1)
        a_new, ok = _circle_intersection(o_new, rho, b_new, ell_new[:, i], side[:, i])
        if not ok.all() and not nan_on_failure:
            row = _first_row(~ok)[0]
            raise InputError(
                f"pose row {row}: actuator {i + 1} cannot close its triangle with the loaded length"
            )
        a_new[~ok] = np.nan  # the pose failed: NaN from here on
        turn = _angle(a_new - o_new) - _angle(a_loc) - alpha[:, i]
        alpha_new[:, i] = alpha[:, i] + _wrap(turn)

    m_new = o_new + _rotate(alpha_new[:, n - 1], arr["measure"] + d_meas)
    dm = m_new - geo["measure"] + ext["extra_measure_mm"]
    out = {
        "force_n": f_actual,
        "reaction_n": r_actual,
        "dforce_n": df,
        "dx_mm": dm[:, 0],
        "dy_mm": dm[:, 1],
        "dalpha_deg": np.degrees(alpha_new - alpha),
        "dl_mm": d_body,
        "dlength_mm": d_length,
        "length_mm": ell,
    }
    failed = np.isnan(alpha_new).any(axis=1)
    if failed.any():  # a failed pose is NaN in every output, as the compiled core fills it
        out = {
            k: np.where(failed.reshape((-1,) + (1,) * (v.ndim - 1)), np.nan, v)
            for k, v in out.items()
        }
    return out


def solve(
    arm: Arm,
    alpha_deg: ArrayLike,
    mass_kg: ArrayLike,
    effects: Any = (),
    self_weight: bool = True,
    extra: Any = None,
) -> dict[str, FloatArray]:
    """Response of the arm to a payload mass at the load point (numpy backend of ``solve``).

    Parameters
    ----------
    arm : Arm
        The arm.
    alpha_deg : array_like, shape (N, n)
        Unloaded absolute link angles, degrees.
    mass_kg : float or array_like, shape (N,)
        Payload mass, kg (≥ 0); the payload force is ``(0, −m·g)`` N with ``g = arm.g``.
    effects : iterable of Effect, optional
        The effects added to the baseline model.
    self_weight : bool, default True
        Whether both states carry the link and actuator weights.
    extra : dict of str to array_like, optional
        Deformations of user-written effects, as :func:`solve_payload` takes them.

    Returns
    -------
    dict of str to ndarray
        As :func:`solve_payload`.

    Raises
    ------
    InputError, EffectError
        As :func:`solve_payload`; also a non-finite or negative mass (row named).
    """
    alpha = _as_poses(alpha_deg, arm.n, "alpha_deg")
    mass = _as_mass(mass_kg, alpha.shape[0])
    payload = np.stack([np.zeros_like(mass), -mass * arm.g], axis=-1)
    return solve_payload(arm, alpha, payload, effects=effects, self_weight=self_weight, extra=extra)


def solve_sequence(
    arm: Arm,
    alpha_deg: ArrayLike,
    mass_kg: ArrayLike,
    effects: Any = (),
    self_weight: bool = True,
    nan_on_failure: bool = False,
) -> dict[str, FloatArray]:
    """Response of N arms to sequences of S payloads, with memory (docs/model.md §4, sequences).

    Each sequence starts at its *reference*: the unloaded pose (self-weight only) in which the
    sensors were zeroed, no friction holding any force and the gaps centred (or taken up with
    ``unloaded="taken_up"``). Its S states are then applied in order. At each state:

    * ΔF_i, ΔR_i: the frictionless force and reaction changes from the reference (statics on the
      undeformed geometry, as :func:`solve_payload`);
    * ``joint_friction`` at O_i (limit L = T_i/|h_i|, h_i = (A_i − O_i) × e_i the moment arm
      of actuator i about O_i in the unloaded pose): the whole actuator holds S_joint, updated
      from the previous state by the Coulomb rule of ``reference_friction.slip`` with input
      ΔF_i; the friction couple (ΔF_i − S_joint)·h_i acts on link i and its opposite on body i−1;
    * ``actuator_friction`` at M_i (limit ``friction_n``): the body spring holds S_body, the
      same rule with input S_joint (ΔF_i without joint friction); the mount and the play
      take S_joint, the actual force is F_i,ref + S_joint;
    * gaps are taken up along that state's actual forces (a centred gap does not re-centre
      when the payload comes off);
    * the pose is closed exactly from the undeformed geometry (:func:`_respond`).

    Parameters
    ----------
    arm : Arm
        The arm.
    alpha_deg : array_like, shape (N, n)
        Unloaded absolute link angles of each sequence, degrees.
    mass_kg : array_like, shape (N, S) or (S,)
        Payload masses (kg, ≥ 0) of the S states after each reference, in the order applied;
        (S,) is the same sequence for every pose. The payload force is ``(0, −m·g)``.
    effects : iterable of Effect, optional
        The whole model (the arm's own effects are *not* added here: the public wrapper does).
        User-written effects see each state loaded once from the reference (no history).
    self_weight : bool, default True
        Whether every state and the reference carry the link and actuator weights.
    nan_on_failure : bool, default False
        Give a state whose loaded pose cannot be closed NaN instead of an error; what the
        frictions hold still steps through it (their forces come from the undeformed
        geometry), so the states after it are solved (as the compiled core's).

    Returns
    -------
    dict of str to ndarray
        The keys of :func:`solve_payload`, each with shape (N, S, ...), relative to each
        sequence's reference. ``force_n`` is the actuator's actual force F_i,ref + S_joint,
        ``reaction_n`` the actual joint reaction, ``dforce_n`` S_joint, ``dl_mm`` −S_body/k_i.

    Raises
    ------
    InputError
        Wrong shape, non-finite input, a negative mass, a singular pose or a triangle that
        cannot close (the row and the state are named).
    EffectError
        As :func:`solve_payload`.
    """
    n = arm.n
    arr = arm.arrays()
    alpha_d = _as_poses(alpha_deg, n, "alpha_deg")
    n_rows = alpha_d.shape[0]
    mass = _as_float(mass_kg, "mass_kg")
    if mass.ndim == 1:
        mass = np.broadcast_to(mass, (n_rows, mass.shape[0]))
    if mass.ndim != 2 or mass.shape[0] != n_rows or mass.shape[1] < 1:
        raise InputError(f"mass_kg must have shape ({n_rows}, S) or (S,), S ≥ 1; got {mass.shape}")
    _check_finite(mass, "mass_kg")
    if (mass < 0).any():
        row, state = (int(v[0]) for v in np.nonzero(mass < 0))
        raise InputError(f"pose row {row}, state {state + 1}: mass_kg is negative")
    effs = as_effects(effects)
    effect_arrays(effs, n)
    builtin, custom_effs = split_effects(effs)
    par = _effect_params(arm, builtin)
    alpha = np.radians(alpha_d)
    geo = _forward(arr, alpha)
    joint = np.zeros((n_rows, n))
    body = np.zeros((n_rows, n))
    states: list[dict[str, FloatArray]] = []
    for s in range(mass.shape[1]):
        payload = np.stack([np.zeros(n_rows), -mass[:, s] * arm.g], axis=-1)
        try:
            st = _statics(arr, geo, payload, bool(self_weight))
            ext = _extras(None, n_rows, n)
            if custom_effs:
                ext = _custom_extras(arm, alpha_d, payload, geo, st, custom_effs, self_weight, ext)
            held = held_forces(par, st, joint, body)
            states.append(
                _respond(
                    arr, par, geo, alpha, st, payload, ext, held, nan_on_failure=nan_on_failure
                )
            )
        except InputError as exc:
            raise InputError(f"{exc} (state {s + 1} of the sequence)") from None
        joint, body = held["joint"], held["body"]
    return {key: np.stack([out[key] for out in states], axis=1) for key in states[0]}
