"""Independent numpy reference implementation of the eodarm model.

Everything here is derived from ``docs/model.md`` (and ``docs/formats.md``) alone; it is the
yardstick the compiled core is tested against, so where the document allows it, it uses a
*different but equivalent* formulation:

* statics: all 3n equilibrium equations (Σx, Σy, ΣM about the global origin, per link) as one
  3n×3n linear system per pose, solved batched, with each joint's unknown the force of its
  linear actuator or the torque of its rotary drive (the core recurses from tip to base);
* triangle closure: circle–circle intersection (the core uses an arccos formula);
* link bending: the bending moment of a pinned link from the loads to the *left* of a section
  (the document writes it with the loads to the right; both agree because every link is in
  equilibrium), a clamped link as two cantilevers from its flange.

The modules: :mod:`~eodarm.model.reference_geometry` (frames, triangles, kinematics),
:mod:`~eodarm.model.reference_statics` (the linear system), :mod:`~eodarm.model.reference_pose`
(the causes of every effect and the exact closure), :mod:`~eodarm.model.reference_friction`
(the Coulomb elements), and this one (the effects' parameters, user deformations, the public
functions).

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
    _as_float,
    _as_mass,
    _as_payload,
    _as_poses,
    _check_finite,
    _forward,
    angles_from_lengths,
    forward,
    inverse_kinematics,
)
from eodarm.model.reference_pose import FORCE_ZERO_N, TORQUE_ZERO_NMM, respond
from eodarm.model.reference_pose import _bending_displacement as _bending_displacement
from eodarm.model.reference_statics import SINGULAR_RTOL, rotary_mask, solve_statics

__all__ = [
    "EXTRA_SHAPES",
    "FORCE_ZERO_N",
    "SINGULAR_RTOL",
    "TORQUE_ZERO_NMM",
    "angles_from_lengths",
    "check_extra_kinds",
    "forward",
    "inverse_kinematics",
    "solve",
    "solve_payload",
    "solve_sequence",
    "statics",
]

FloatArray = NDArray[np.float64]


# ---------------------------------------------------------------------------- statics
def statics(
    arm: Arm,
    alpha_deg: ArrayLike,
    payload_n: ArrayLike,
    self_weight: bool = True,
) -> dict[str, FloatArray]:
    """Actuator forces, drive torques and joint reactions on the undeformed arm (model §2–§3).

    All 3n equilibrium equations (Σx, Σy, ΣM about the global origin for every link) are
    solved as one 3n×3n linear system per pose, batched over poses; joint i's unknown is its
    linear actuator's force or its rotary drive's torque.

    Parameters
    ----------
    arm : Arm
        The arm.
    alpha_deg : array_like, shape (N, n)
        Unloaded absolute link angles, degrees.
    payload_n : array_like, shape (N, 2) or (2,)
        Payload force vector (N) applied at the load point, global frame.
    self_weight : bool, default True
        Include link weights (at C) and drive weights: a linear actuator's half at each pin, a
        rotary drive's whole at its joint on the proximal body (what acts on the chassis is
        lost into it). ``g = arm.g`` in m/s², masses in kg → N.

    Returns
    -------
    dict of str to ndarray
        ``"force_n"`` (N, n)
            Loaded actuator forces in N, compression positive; NaN at a rotary joint.
        ``"torque_nmm"`` (N, n)
            Loaded drive torques on link i in N·mm, counter-clockwise positive; NaN at a
            linear joint.
        ``"reaction_n"`` (N, n, 2)
            Loaded joint reactions in N: the force body i−1 exerts on link i at O_i (global).
        ``"force_unloaded_n"``, ``"torque_unloaded_nmm"``, ``"reaction_unloaded_n"``
            The same for the unloaded state (self-weight only).
        ``"force0_n"``, ``"torque0_nmm"``, ``"reaction0_n"``
            The same unloaded arrays under the compiled core's names (``_core.statics``).
        ``"length_mm"`` (N, n)
            Unloaded pin-to-pin actuator lengths, mm; NaN at a rotary joint.

    Raises
    ------
    InputError
        Wrong shape or non-finite input, or a singular pose (a linear actuator's line through
        its joint); the message names the row.
    """
    arr = arm.arrays()
    alpha = _as_poses(alpha_deg, arm.n, "alpha_deg")
    payload = _as_payload(payload_n, alpha.shape[0])
    geo = _forward(arr, np.radians(alpha))
    st = solve_statics(arr, geo, payload, bool(self_weight))
    return _statics_out(st, geo)


def _statics_out(st: dict[str, FloatArray], geo: dict[str, FloatArray]) -> dict[str, FloatArray]:
    keys = (
        "force_n",
        "torque_nmm",
        "reaction_n",
        "force_unloaded_n",
        "torque_unloaded_nmm",
        "reaction_unloaded_n",
    )
    out = {key: st[key] for key in keys}
    out["force0_n"] = st["force_unloaded_n"]
    out["torque0_nmm"] = st["torque_unloaded_nmm"]
    out["reaction0_n"] = st["reaction_unloaded_n"]
    out["length_mm"] = geo["length_mm"]
    return out


# ---------------------------------------------------------------------------- effects
def _effect_params(arm: Arm, effects: Any) -> dict[str, Any]:
    """Per-joint parameters of the effects (validated), defaults meaning "absent".

    ``k`` is each joint's spring: the actuator body's (N/mm) or the drive gear's (N·mm/rad);
    ``body_friction`` the friction in parallel with it (N or N·mm); ``gap_up`` whether the
    joint's play or backlash was taken up by the unloaded forces."""
    effs: list[Effect] = with_arm_effects(arm.effects, effects)
    n = arm.n
    # refuses non-Effects, places beyond n, duplicates, effects at the wrong kind of joint
    effect_arrays(effs, n, arm.kinds)
    arr = arm.arrays()
    p: dict[str, Any] = {
        "rotary": rotary_mask(arr),
        "k": np.array(arr["stiffness"], dtype=float),
        "k_mount": np.full(n, np.inf),
        "play": np.zeros(n),
        "backlash_deg": np.zeros(n),
        "gap_up": np.zeros(n, dtype=bool),
        "clearance": np.zeros(n),
        "clearance_up": np.zeros(n, dtype=bool),
        "ei": [None] * n,
        "k_base": None,
        # Coulomb friction limits (docs/model.md): N·mm in joint O_i; N in actuator i's body
        # or N·mm in drive i's gear.
        "joint_friction": np.zeros(n),
        "body_friction": np.zeros(n),
    }
    for e in effs:
        i = e.index(n)
        if e.name in ("actuator_compliance", "drive_compliance"):
            p["k"][i] = e.value
        elif e.name == "mount_compliance":
            p["k_mount"][i] = e.value
        elif e.name in ("actuator_play", "drive_backlash"):
            p["play" if e.name == "actuator_play" else "backlash_deg"][i] = e.value
            p["gap_up"][i] = e.unloaded == "taken_up"
        elif e.name == "joint_clearance":
            p["clearance"][i] = e.value
            p["clearance_up"][i] = e.unloaded == "taken_up"
        elif e.name == "link_bending":
            pin = arm.links[i].A
            if pin is not None and pin[0] == 0.0:
                raise EffectError(
                    f"effect {e.key}: link {i + 1} has its pin A at x = 0, so the beam has "
                    "only one support"
                )
            p["ei"][i] = e.value
        elif e.name == "base_compliance":
            p["k_base"] = e.value
        elif e.name == "joint_friction":
            p["joint_friction"][i] = e.value
        elif e.name in ("actuator_friction", "drive_friction"):
            p["body_friction"][i] = e.value
        else:  # pragma: no cover - the catalogue and this list must agree
            raise EffectError(f"effect {e.key}: not implemented by the numpy reference")
    return p


# ---------------------------------------------------------------------------- extras
#: The extra deformations of user effects (custom-effects.md) as whole-arm arrays: name → the shape
#: of one pose's values ("n" the number of links). The same names as ``_core.solve``'s.
EXTRA_SHAPES: dict[str, tuple[str | int, ...]] = {
    "extra_seen_mm": ("n",),
    "extra_unseen_mm": ("n",),
    "extra_joint_mm": ("n", 2),
    "extra_tilt_rad": (),
    "extra_measure_mm": (2,),
    "extra_turn_rad": ("n",),
}
#: The extra deformations that belong to one kind of joint: a length change to a linear
#: actuator, a turn to a rotary drive.
_EXTRA_KIND = {
    "extra_seen_mm": "linear",
    "extra_unseen_mm": "linear",
    "extra_turn_rad": "rotary",
}


def check_extra_kinds(kinds: tuple[str, ...], extras: Any) -> None:
    """Refuse an extra deformation at a joint of the other kind (a nonzero length change at a
    rotary drive, a nonzero turn at a linear actuator), naming the key, the row and the joint:
    it would otherwise be dropped.

    Raises
    ------
    InputError
        On the first such value.
    """
    for key, kind in _EXTRA_KIND.items():
        value = None if extras is None else extras.get(key)
        if value is None:
            continue
        other = np.array([k != kind for k in kinds])
        bad = (np.asarray(value, dtype=float) != 0.0) & other[None, :]
        if bad.any():
            row, i = (int(v[0]) for v in np.nonzero(bad))
            have, need = (
                ("a linear actuator", "a rotary drive")
                if kind == "rotary"
                else ("a rotary drive", "a linear actuator")
            )
            raise InputError(
                f"pose row {row}: {key} is nonzero at joint {i + 1}, which is turned by {have} "
                f"({key} is for a joint with {need})"
            )


def _extras(extra: Any, n_rows: int, kinds: tuple[str, ...]) -> dict[str, FloatArray]:
    """The extra deformations, every key present (zeros when absent), checked.

    ``extra_seen_mm`` (N, n) pin-to-pin length change each actuator's sensor sees,
    ``extra_unseen_mm`` (N, n) one it does not see, ``extra_joint_mm`` (N, n, 2) offset of link
    i's pin centre at O_i (global), ``extra_tilt_rad`` (N,) chassis tilt about the pivot,
    ``extra_measure_mm`` (N, 2) global displacement of the measure point, ``extra_turn_rad``
    (N, n) turn of link i relative to body i−1 at a rotary joint (counter-clockwise +).
    """
    n = len(kinds)
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
    check_extra_kinds(kinds, out)
    return out


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

    state = custom.EffectState.from_statics(
        arm, alpha_d, payload, _statics_out(st, geo), self_weight
    )
    return custom.add_extras(ext, custom.extras_of(custom_effs, state))


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
    """Loaded minus unloaded response of the arm to a payload force (model §4–§5, §10).

    Forces and torques of both states come from statics on the undeformed geometry; the
    loaded pose is then closed exactly, link by link from the base, with every effect's cause
    applied at once (length changes, drive turns, joint-pin offsets, bending displacements,
    chassis tilt). Each linear actuator's triangle is closed as a circle–circle intersection
    (centre O′_i radius |a|, centre B′_{i−1} radius ℓ′_i) on the same side as in the unloaded
    pose; a rotary drive sets link i's angle from body i−1's.

    Parameters
    ----------
    arm : Arm
        The arm.
    alpha_deg : array_like, shape (N, n)
        Unloaded absolute link angles, degrees.
    payload_n : array_like, shape (N, 2) or (2,)
        Payload force (N) at the load point, global frame.
    effects : iterable of Effect, optional
        The effects added to the baseline model (at most one per name and place, each at a
        joint of its kind).
    self_weight : bool, default True
        Whether both states carry the link and drive weights.
    extra : dict of str to array_like, optional
        Deformations of user-written effects added to the effects' (docs/custom-effects.md), each
        optional: ``extra_seen_mm`` (N, n), ``extra_unseen_mm`` (N, n), ``extra_joint_mm``
        (N, n, 2), ``extra_tilt_rad`` (N,), ``extra_measure_mm`` (N, 2), ``extra_turn_rad``
        (N, n) (see ``_extras``); a length change at a rotary joint or a turn at a linear one
        is refused.
    nan_on_failure : bool, default False
        A pose whose loaded triangle cannot close gets NaN in its loaded-pose outputs instead
        of an error naming its row (as the compiled core's ``nan_on_failure``).

    Returns
    -------
    dict of str to ndarray
        ``"force_n"``, ``"dforce_n"`` (N, n)
            Loaded actuator forces and their change from the unloaded state, N (compression
            positive); NaN at a rotary joint.
        ``"torque_nmm"``, ``"dtorque_nmm"`` (N, n)
            Loaded drive torques on link i and their change, N·mm (counter-clockwise
            positive); NaN at a linear joint.
        ``"reaction_n"`` (N, n, 2)
            Loaded joint reactions (body i−1 on link i at O_i), N, global.
        ``"dx_mm"``, ``"dy_mm"`` (N,)
            Displacement of the measure point, mm, global.
        ``"dalpha_deg"`` (N, n)
            Change of each link's absolute angle (of the chord of a bent link turned by a
            linear actuator, of the flange frame of a link turned by a drive), degrees.
        ``"dl_mm"`` (N, n)
            Change of each actuator body's length as its own sensor sees it, −ΔF/k_body (plus
            ``extra_seen_mm``), mm; NaN at a rotary joint.
        ``"dlength_mm"`` (N, n)
            Total pin-to-pin length change (body, mount and play), mm; NaN at a rotary joint.
        ``"length_mm"`` (N, n)
            Unloaded pin-to-pin length, mm; NaN at a rotary joint.

    Raises
    ------
    InputError
        Wrong shape, non-finite input, a singular pose or a loaded triangle that cannot close
        (the row and actuator are named).
    EffectError
        Unknown, duplicated or misplaced effects (an effect at a joint of the wrong kind), or
        link bending on a link with A at x = 0.
    """
    n = arm.n
    arr = arm.arrays()
    alpha_d = _as_poses(alpha_deg, n, "alpha_deg")
    n_rows = alpha_d.shape[0]
    payload = _as_payload(payload_n, n_rows)
    effs = as_effects(effects)
    effect_arrays(effs, n, arm.kinds)  # types, places, duplicates and kinds over all of them
    builtin, custom_effs = split_effects(effs)
    par = _effect_params(arm, builtin)
    alpha = np.radians(alpha_d)
    geo = _forward(arr, alpha)
    st = solve_statics(arr, geo, payload, bool(self_weight))
    ext = _extras(extra, n_rows, arm.kinds)
    if custom_effs:
        ext = _custom_extras(arm, alpha_d, payload, geo, st, custom_effs, self_weight, ext)
    # Loaded once from the reference: every friction element starts with S = 0 (the deadband).
    held = held_forces(par, st, np.zeros((n_rows, n)), np.zeros((n_rows, n)))
    return respond(arr, par, geo, alpha, st, payload, ext, held, nan_on_failure=nan_on_failure)


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
        Whether both states carry the link and drive weights.
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
    """Response of N arms to sequences of S payloads, with memory (docs/model.md §9, §10).

    Each sequence starts at its *reference*: the unloaded pose (self-weight only) in which the
    sensors were zeroed, no friction holding anything and the gaps centred (or taken up with
    ``unloaded="taken_up"``). Its S states are then applied in order. At each state:

    * Δu_i, ΔR_i: the frictionless changes from the reference of each joint's force or torque
      and reaction (statics on the undeformed geometry, as :func:`solve_payload`);
    * ``joint_friction`` at O_i: the whole actuator or drive holds S_joint, updated from the
      previous state by the Coulomb rule of ``reference_friction.slip`` with input Δu_i and
      limit T/|h_i| at a linear joint (h_i = (A_i − O_i) × e_i the moment arm of actuator i
      about O_i in the unloaded pose), T at a rotary one; the joint holds the rest as a couple
      on link i (its opposite on body i−1);
    * ``actuator_friction`` at M_i (limit in N) or ``drive_friction`` at O_i (limit in N·mm):
      the body's or gear's spring holds S_body, the same rule with input S_joint; the mount,
      the play or backlash take S_joint, the actual force or torque is the reference's plus
      S_joint;
    * gaps are taken up along that state's actual forces and torques (a centred gap does not
      re-centre when the payload comes off);
    * the pose is closed exactly from the undeformed geometry (``reference_pose.respond``).

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
        Whether every state and the reference carry the link and drive weights.
    nan_on_failure : bool, default False
        Give a state whose loaded pose cannot be closed NaN instead of an error; what the
        frictions hold still steps through it (their forces come from the undeformed
        geometry), so the states after it are solved (as the compiled core's).

    Returns
    -------
    dict of str to ndarray
        The keys of :func:`solve_payload`, each with shape (N, S, ...), relative to each
        sequence's reference. ``force_n`` (``torque_nmm``) is the actual force (torque), the
        reference's plus S_joint, ``reaction_n`` the actual joint reaction, ``dforce_n``
        (``dtorque_nmm``) S_joint, ``dl_mm`` −S_body/k_i.

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
    effect_arrays(effs, n, arm.kinds)
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
            st = solve_statics(arr, geo, payload, bool(self_weight))
            ext = _extras(None, n_rows, arm.kinds)
            if custom_effs:
                ext = _custom_extras(arm, alpha_d, payload, geo, st, custom_effs, self_weight, ext)
            held = held_forces(par, st, joint, body)
            states.append(
                respond(arr, par, geo, alpha, st, payload, ext, held, nan_on_failure=nan_on_failure)
            )
        except InputError as exc:
            raise InputError(f"{exc} (state {s + 1} of the sequence)") from None
        joint, body = held["joint"], held["body"]
    return {key: np.stack([out[key] for out in states], axis=1) for key in states[0]}
