"""The public solvers: loaded pose, kinematics, inverse kinematics (docs/model.md).

Every function takes and returns numpy arrays for many poses at once and dispatches to the
compiled core (``backend="rust"``, the default) or to the numpy reference
(``backend="numpy"``, :mod:`eodarm.reference`). Inputs are checked here once, so both
backends refuse bad input with the same one-line message naming the row.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any, cast

import numpy as np
import numpy.typing as npt

from eodarm.errors import InputError
from eodarm.model.arm import Arm, check_arm
from eodarm.model.effects import Effect, effect_arrays, split_effects, with_arm_effects
from eodarm.model.kinds import real_array
from eodarm.model.kinematics import (
    Arrays,
    Backend,
    _check_backend,
    _core_arm,
    _lengths,
    _poses,
    _poses_and_masses,
    _refuse_unloaded_singular,
    forward,
    stroke_violations,
)
from eodarm.model.outputs import check_outputs, core_outputs, select
from eodarm.model.resources import check_output_memory, solve_output_bytes
from eodarm.model.sequence import cycle_returns, solve_sequence
from eodarm.model.validity import checks_load_rise, quiet_rows, status

__all__ = [
    "angles_from_lengths",
    "cycle_returns",
    "forward",
    "inverse_kinematics",
    "solve",
    "solve_payload",
    "solve_sequence",
    "statics",
    "stroke_violations",
]


def solve(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    mass_kg: npt.ArrayLike = 0.0,
    effects: Effect | list[Effect] | tuple[Effect, ...] | None = None,
    backend: Backend = "rust",
    self_weight: bool = True,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
    extra: Mapping[str, npt.ArrayLike | None] | None = None,
    uncertainty: bool = False,
    out: Mapping[str, npt.NDArray[Any]] | None = None,
    strict: bool = False,
    outputs: Sequence[str] | None = None,
) -> Arrays:
    """Loaded minus unloaded state of N poses under a payload mass at the load point.

    Parameters
    ----------
    arm : the arm.
    alpha_deg : (N, n) unloaded absolute link angles, degrees (a single pose (n,) is N = 1).
    mass_kg : payload mass, kg; scalar or (N,). Its weight ``m·g`` acts downward. One pose
        ((n,) or (1, n)) with (M,) masses is that pose under each payload: M rows (numpy's
        broadcasting over the rows; any other pair of shapes is an
        :class:`~eodarm.errors.InputError` naming both).
    effects : effects added to the baseline model (docs/model.md §4), built-in or user-written
        (:func:`eodarm.custom_effect`; their functions are called once each, on the statics of
        the N poses, and what they return is added to ``extra``).
    backend : ``"rust"`` (compiled core) or ``"numpy"`` (independent reference).
    self_weight : include link and actuator weights in both states.
    model : ``"analytic"`` (closed forms, exact pose) or ``"fem"``: the frame finite-element
        model of :mod:`eodarm.model.fem` (linear, the links' ``ei_n_mm2``/``ea_n`` used), which
        agrees with the analytic model to first order in the load; compiled core only.
    fem_options : with ``model="fem"``: ``elements_per_link`` (default 8) and
        ``moment_samples`` (101).
    extra : deformations of user-written effects (custom-effects.md) added to the effects', each
        optional, global frame: ``extra_seen_mm`` (N, n) pin-to-pin length change that the
        actuator's sensor sees, ``extra_unseen_mm`` (N, n) one it does not see,
        ``extra_joint_mm`` (N, n, 2) offset of link i's pin centre at O_i, ``extra_tilt_rad``
        (N,) chassis tilt about the base pivot, ``extra_measure_mm`` (N, 2) displacement of
        the measure point, ``extra_turn_rad`` (N, n) turn of link i against body i−1 at a
        rotary drive (counter-clockwise +). The lengths are for linear actuators, the turn
        for drives: a nonzero value at a joint of the other kind is an
        :class:`~eodarm.errors.InputError` naming the row and joint. Analytic model only (so
        are user-written effects).
    uncertainty : also return ``sigma_dx_mm``, ``sigma_dy_mm`` (N,) and ``sigma_dalpha_deg``
        (N, n), the total standard deviations of those outputs (mm, deg), and their two parts
        ``sigma_param_*`` (the arm's fitted parameters' covariance, by linear propagation
        through the compiled core's sensitivities) and ``sigma_model_*`` (the fitted model's
        own inadequacy, zero where it explained its data); total² = param² + model². Needs
        an arm file written by ``eodarm fit -o`` (:mod:`eodarm.model.uncertainty`,
        docs/model.md, Prediction errors).
    out : arrays to write the results into, for repeated calls without allocating: a dict
        with every key of the analytic results below (``status`` included; with ``outputs``
        exactly the asked keys and ``status``), each a writeable C-contiguous array of that
        shape and dtype (e.g. ``{k: np.empty_like(v) for k, v in solve(...).items()}``). The
        returned dict holds these arrays. ``backend="rust"``, ``model="analytic"`` only; a
        missing or extra key or a wrong shape, dtype or layout is an
        :class:`~eodarm.errors.InputError` naming the key.
    strict : a pose that cannot be closed under its load (an actuator triangle that the
        loaded lengths cannot close, a loaded pose that will not settle) raises naming the row
        (True), or gets NaN in every output and a non-``ok`` ``status`` while the other poses
        are solved (False, the default; as :func:`eodarm.sweep` marks such a cell). A pose
        that is singular *unloaded* (an actuator through its joint, coincident pins) is
        invalid input and raises either way.
    outputs : the keys to return, e.g. ``("dx_mm", "dy_mm")``; None (the default) is every
        key below. ``status`` is always returned as well: it says which rows of the asked
        arrays can be trusted, and is computed from the solved pose whatever is asked. The
        compiled core allocates and writes only the asked arrays (a caller who needs two
        pays for two); the numpy backend, ``model="fem"`` (whose own keys may be asked) and
        the sigma keys of ``uncertainty`` are computed in full and selected. Each value is
        exactly that of the call without ``outputs``. An unknown or repeated key, an empty
        sequence or a bare string (``outputs="dx_mm"``) is an
        :class:`~eodarm.errors.InputError` listing the valid keys
        (:mod:`eodarm.model.outputs`).

    Returns
    -------
    dict of arrays: ``force_n`` (N, n) loaded actuator forces (compression +, N);
    ``reaction_n`` (N, n, 2) loaded joint reactions (force of body i−1 on link i, N);
    ``dforce_n`` (N, n) force change; ``torque_nmm``, ``dtorque_nmm`` (N, n) loaded drive
    torque on link i about O_i (counter-clockwise +, N·mm) and its change; ``dx_mm``,
    ``dy_mm`` (N,) measure-point displacement; ``dalpha_deg`` (N, n) change of absolute link
    angles (of a drive's link: its flange frame); ``dl_mm`` (N, n) actuator body length
    change as its sensor sees it; ``dlength_mm`` (N, n) pin-to-pin change; ``length_mm`` (N, n)
    unloaded pin-to-pin length. At a joint turned by a rotary drive ``force_n``,
    ``dforce_n``, ``dl_mm``, ``dlength_mm`` and ``length_mm`` are NaN; at a joint turned by a
    linear actuator ``torque_nmm`` and ``dtorque_nmm`` are (docs/model.md §10). ``status``
    (N,) uint8, where the small-deflection model can be trusted (0 ok;
    :data:`eodarm.model.validity.STATUS` names the others). With
    ``model="fem"`` also ``pin_force_n`` (N, 2n, 2), the loaded forces on the links at their
    joints O_i then at their actuator pins A_i;
    ``moment_nmm``, ``dmoment_nmm`` (N, n, K) loaded bending moment along each link and its
    change, at the local abscissae ``moment_x_mm`` (n, K); ``node_xy``, ``node_disp``
    (N, nodes, 2) undeformed nodes and their displacement, drawn by ``segments`` (S, 2) of
    kind ``segment_kind`` (S,) (0 axis, 1 offset, 2 actuator, 3 chassis); ``node_kind``
    (nodes, 2) each node's kind and body (docs/fem.md §1); ``n_dof``.

    Raises
    ------
    ValueError
        (an :class:`~eodarm.errors.EodarmError`) naming the row for a wrong shape, a non-finite
        value, a negative mass, a pose singular unloaded, or (``strict=True``) a pose that
        cannot be closed under its load.
    """
    check_arm(arm, "solve")
    _check_memory(alpha_deg, arm.n, mass_kg)
    # The compiled core's analytic solve refuses a non-finite angle naming its row, in the
    # words of the Python check (_core_refusals): the angles are not read twice for it. It
    # takes the masses themselves (one for all rows, or one per row) and makes the payload
    # forces a chunk at a time: the (N, 2) forces are built here only where another path
    # needs them (:func:`_solve_payload`).
    core = backend == "rust" and model == "analytic"
    alpha, mass = _poses_and_masses(alpha_deg, mass_kg, arm.n, finite=not core, expand=not core)
    _refuse_negative(mass, alpha.shape[0])
    payload = None if core else _payload_of(mass, alpha.shape[0], arm.g)
    return _solve_payload(
        arm,
        alpha,
        payload,
        effects,
        backend,
        self_weight,
        model,
        fem_options,
        extra,
        uncertainty,
        out,
        checked=True,
        strict=strict,
        outputs=outputs,
        mass=mass,
    )


def _refuse_negative(mass: npt.NDArray[np.float64], rows: int) -> None:
    """An InputError naming the row of the first negative mass of ``mass`` (finite: a scalar
    for each of the ``rows`` rows, or one per row)."""
    if rows and not mass.min() >= 0:  # finite masses: the smallest says if any is negative
        row = int(np.flatnonzero(np.atleast_1d(mass) < 0)[0])
        raise InputError(f"pose row {row}: mass_kg is negative ({np.atleast_1d(mass)[row]})")


def _payload_of(mass: npt.NDArray[np.float64], rows: int, g: float) -> npt.NDArray[np.float64]:
    """The (N, 2) payload force (0, −m·g) of the masses ``mass`` (finite and not negative,
    as :func:`_refuse_negative` leaves them: one per row, or a scalar for every row)."""
    payload = np.zeros((rows, 2))  # zeroed by the allocator (calloc): x = 0 costs no pass
    np.multiply(mass, -g, out=payload[:, 1])
    return payload


def _mass_arg(mass: npt.NDArray[np.float64] | None) -> float | npt.NDArray[np.float64]:
    """``mass`` as the compiled core takes it: a float for every row, else (N,) contiguous."""
    if mass is None:
        raise InputError("solve: neither a payload nor masses")  # not reached from solve()
    if mass.ndim == 0:
        return float(mass)
    return np.ascontiguousarray(mass, dtype=np.float64)


@contextmanager
def _core_refusals() -> Iterator[None]:
    """The compiled core's refusals as the :class:`InputError` the docstrings promise, in the
    core's words: a non-finite angle (``check_input``, the check :func:`solve` leaves to it,
    in the Python check's words), a pose singular unloaded, and (``strict=True``) a pose
    that cannot be closed under its load, each naming its row."""
    from eodarm.model import native as _core

    try:
        yield
    except _core.CoreError as exc:
        raise InputError(" ".join(str(exc).split())) from None


def solve_payload(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    payload_n: npt.ArrayLike,
    effects: Effect | list[Effect] | tuple[Effect, ...] | None = None,
    backend: Backend = "rust",
    self_weight: bool = True,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
    extra: Mapping[str, npt.ArrayLike | None] | None = None,
    uncertainty: bool = False,
    out: Mapping[str, npt.NDArray[Any]] | None = None,
    strict: bool = False,
    outputs: Sequence[str] | None = None,
) -> Arrays:
    """Like :func:`solve`, with any payload force vector (N, 2) in N at the load point; one
    pose with (M, 2) payloads is that pose under each (M rows), one payload (2,) or (1, 2)
    goes with every pose."""
    check_arm(arm, "solve_payload")
    _check_memory(alpha_deg, arm.n, payload_n)
    return _solve_payload(
        arm,
        alpha_deg,
        payload_n,
        effects,
        backend,
        self_weight,
        model,
        fem_options,
        extra,
        uncertainty,
        out,
        strict=strict,
        outputs=outputs,
    )


def _solve_payload(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    payload_n: npt.ArrayLike | None,
    effects: Effect | list[Effect] | tuple[Effect, ...] | None,
    backend: Backend,
    self_weight: bool,
    model: str,
    fem_options: Mapping[str, Any] | None,
    extra: Mapping[str, npt.ArrayLike | None] | None,
    uncertainty: bool,
    out: Mapping[str, npt.NDArray[Any]] | None,
    checked: bool = False,
    strict: bool = False,
    outputs: Sequence[str] | None = None,
    mass: npt.NDArray[np.float64] | None = None,
) -> Arrays:
    """:func:`solve_payload` once the arm and the memory the outputs need are checked (the
    memory check reads /proc: once per call, not once per layer). ``checked``: ``alpha_deg``
    and ``payload_n`` are already (N, n) and (N, 2) finite contiguous float64 arrays (the
    angles' finiteness left to the compiled core's analytic solve, which refuses it in the
    same words: :func:`_core_refusals`). ``payload_n`` may be None with ``mass``, the checked
    masses of :func:`solve` (a scalar or (N,)): the compiled core then takes the masses
    themselves, and the forces are built here only for the paths that need them."""
    from eodarm.model import fem

    asked = check_outputs(outputs, model, uncertainty)
    payload: npt.NDArray[np.float64] | None
    if checked and payload_n is None:
        alpha = np.asarray(alpha_deg, dtype=np.float64)
        payload = None
    elif checked:
        alpha = np.asarray(alpha_deg, dtype=np.float64)
        payload = np.asarray(payload_n, dtype=np.float64)
    else:
        alpha = _poses(alpha_deg, arm.n, "alpha_deg")
        payload = _poses(cast(npt.ArrayLike, payload_n), 2, "payload_n")

    def forces() -> npt.NDArray[np.float64]:
        """The (N, 2) payload forces: given, or built from solve's masses for a path that
        reads them (the compiled core's analytic solve takes the masses themselves)."""
        nonlocal payload
        if payload is None:
            payload = _payload_of(np.asarray(mass), alpha.shape[0], arm.g)
        return payload

    if payload is None:
        pass  # solve's masses, broadcast against the poses already
    elif payload.shape[0] == 1 and alpha.shape[0] != 1:
        payload = np.ascontiguousarray(np.broadcast_to(payload, (alpha.shape[0], 2)))
    elif alpha.shape[0] == 1 and payload.shape[0] != 1:  # one pose under M payloads
        alpha = np.ascontiguousarray(np.broadcast_to(alpha, (payload.shape[0], arm.n)))
    if payload is not None and payload.shape[0] != alpha.shape[0]:
        raise InputError(
            f"alpha_deg of shape {np.shape(alpha_deg)} and payload_n of shape "
            f"{np.shape(cast(npt.ArrayLike, payload_n))} do not broadcast: give one pose for M "
            "payloads, N poses for one payload, or N of each"
        )
    effs = with_arm_effects(arm.effects, effects)
    codes, places, values = effect_arrays(effs, arm.n)
    custom_effs = split_effects(effs)[1]
    fem.check_model(model)
    extras = _extras(extra, alpha.shape[0], arm.n)
    from eodarm.model.reference import check_extra_kinds

    # a turn at a linear actuator or a length at a rotary drive would be dropped: refused
    check_extra_kinds(arm.kinds, extras)
    if extras and model == "fem":
        raise InputError("extra deformations are for model='analytic'")
    if custom_effs and model == "fem":
        raise InputError(
            f"custom effect {custom_effs[0].key}: the finite-element model cannot include "
            "user-written effects; use model='analytic'"
        )
    if out is not None:
        if backend != "rust" or model != "analytic" or uncertainty:
            raise InputError("out= is for backend='rust', model='analytic', no uncertainty")
        out = check_out(out, alpha.shape[0], arm.n, asked)
    if model == "fem":
        if uncertainty:
            raise InputError("uncertainty is propagated with model='analytic'")
        _check_backend(backend)
        if backend != "rust":
            raise InputError("model='fem' runs in the compiled core: use backend='rust'")
        fe = fem.fem_solve_payload(arm, alpha, forces(), effs, self_weight, fem_options)
        fe["status"] = status(arm, alpha, forces(), fe)
        return select(fe, asked)
    if fem_options is not None:
        raise InputError("fem_options is for model='fem'")
    if uncertainty and (extras or custom_effs):
        raise InputError("uncertainty is propagated for the catalogue's effects only")
    if backend == "rust":
        from eodarm.model import native as _core

        # the failed rows are read from dy_mm (a pose singular unloaded is refused)
        keys = core_outputs(asked, need_dy=not strict)
        if out is not None and keys is not None and "dy_mm" not in out and not strict:
            out["dy_mm"] = np.empty(alpha.shape[0])  # not the caller's: dropped below
        if custom_effs:
            from eodarm.model import custom

            with _core_refusals():
                st = _core.statics(_core_arm(arm), alpha, forces(), self_weight)
            state = custom.EffectState.from_statics(arm, alpha, forces(), st, self_weight)
            extras = custom.add_extras(extras, custom.extras_of(custom_effs, state))
        with _core_refusals():
            res: Arrays = _core.solve(
                _core_arm(arm),
                alpha,
                forces() if payload is not None or extras else None,
                codes,
                places,
                values,
                self_weight,
                not strict,  # nan_on_failure: a pose that cannot close under load is NaN
                # with extras (also a custom effect's) the core takes force rows
                mass_kg=_mass_arg(mass) if payload is None and not extras else None,
                extra_seen_mm=extras.get("extra_seen_mm"),
                extra_unseen_mm=extras.get("extra_unseen_mm"),
                extra_joint_mm=extras.get("extra_joint_mm"),
                extra_tilt_rad=extras.get("extra_tilt_rad"),
                extra_measure_mm=extras.get("extra_measure_mm"),
                extra_turn_rad=extras.get("extra_turn_rad"),
                out=out,
                outputs=keys,
            )
    else:
        _check_backend(backend)
        from eodarm.model import reference

        res = dict(
            reference.solve_payload(
                arm,
                alpha,
                forces(),
                effs,
                self_weight=self_weight,
                extra=extras,
                nan_on_failure=not strict,
            )
        )
        lift = checks_load_rise(arm, effs)
        res["status"] = status(
            arm, alpha, forces(), res, load_rise=lift & quiet_rows(extras, alpha.shape[0])
        )
    if not strict:
        _refuse_unloaded_singular(arm, alpha, res)
    if uncertainty:
        from eodarm.model.uncertainty import prediction_sigma

        res.update(prediction_sigma(arm, alpha, forces(), effs, self_weight))
    return select(res, asked)


#: The keys :func:`statics` returns, on either backend.
STATICS_KEYS = (
    "force_n",
    "force0_n",
    "torque_nmm",
    "torque0_nmm",
    "reaction_n",
    "reaction0_n",
    "length_mm",
)


def statics(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    mass_kg: npt.ArrayLike = 0.0,
    backend: Backend = "rust",
    self_weight: bool = True,
) -> Arrays:
    """Forces and torques of both states of N poses on the undeformed geometry
    (docs/model.md §1, §10): what a user-written effect reads (:class:`eodarm.EffectState`).

    Returns
    -------
    dict of arrays: ``force_n``, ``force0_n`` (N, n) loaded and unloaded actuator forces
    (compression +, N; NaN at a joint turned by a rotary drive); ``torque_nmm``,
    ``torque0_nmm`` (N, n) loaded and unloaded drive torques (on link i about O_i,
    counter-clockwise +, N·mm; NaN at a joint turned by a linear actuator);
    ``reaction_n``, ``reaction0_n`` (N, n, 2) loaded and unloaded joint reactions (force of
    body i−1 on link i, global, N); ``length_mm`` (N, n) unloaded pin-to-pin lengths (NaN at
    a drive). The unloaded state carries the self-weight (none without it).
    """
    check_arm(arm, "statics")
    alpha, mass = _poses_and_masses(alpha_deg, mass_kg, arm.n)
    _refuse_negative(mass, alpha.shape[0])
    payload = _payload_of(mass, alpha.shape[0], arm.g)
    _check_backend(backend)
    if backend == "rust":
        from eodarm.model import native as _core

        return _core.statics(_core_arm(arm), alpha, payload, self_weight)
    from eodarm.model import reference

    st = reference.statics(arm, alpha, payload, self_weight=self_weight)
    return {k: st[k] for k in STATICS_KEYS}


def angles_from_lengths(
    arm: Arm,
    length_mm: npt.ArrayLike,
    alpha_ref_deg: npt.ArrayLike,
    backend: Backend = "rust",
) -> npt.NDArray[np.float64]:
    """Absolute angles (N, n), degrees, of the rigid arm with the given actuator lengths.

    Each actuator triangle is closed in closed form; of its two solutions the one on the side
    of the reference pose ``alpha_ref_deg`` ((n,) or (N, n)) is taken. A joint turned by a
    rotary drive has no length: its column is NaN (as :func:`forward` gives it), and the
    joint keeps the reference pose's relative angle q_i = α_i − α_{i−1}; a number there is
    an :class:`~eodarm.errors.InputError` naming the row and joint.
    """
    check_arm(arm, "angles_from_lengths")
    length = _lengths(arm, length_mm)
    ref = _poses(alpha_ref_deg, arm.n, "alpha_ref_deg")
    _check_backend(backend)
    if backend == "rust":
        from eodarm.model import native as _core

        return _core.angles_from_lengths(_core_arm(arm), length, ref)  # ref: 1 or N rows
    if ref.shape[0] == 1 and length.shape[0] != 1:
        ref = np.ascontiguousarray(np.broadcast_to(ref, length.shape))
    from eodarm.model import reference

    return reference.angles_from_lengths(arm, length, ref)


def inverse_kinematics(
    arm: Arm,
    target: npt.ArrayLike,
    elbow: int = -1,
    backend: Backend = "rust",
) -> dict[str, npt.NDArray[Any]]:
    """Angles and actuator lengths that put the load point at a target (3-link arms).

    Parameters
    ----------
    target : (N, 3) or (3,): load point x, y (mm, global) and the last link's angle (deg).
    elbow : −1 (α₂ < α₁, the seed's pose) or +1, the branch of the middle joint.

    Returns
    -------
    ``alpha_deg`` (N, 3) (NaN where unreachable), ``length_mm`` (N, 3) and ``reachable`` (N,).
    """
    check_arm(arm, "inverse_kinematics")
    t = _poses(target, 3, "target")
    _check_backend(backend)
    if elbow not in (-1, 1):
        raise InputError(f"elbow must be -1 or +1, got {elbow!r}")
    if arm.n != 3:
        raise InputError(f"inverse kinematics needs a 3-link arm, this one has {arm.n} links")
    if backend == "numpy":
        from eodarm.model import reference

        return reference.inverse_kinematics(arm, t, elbow=elbow)
    from eodarm.model import native as _core

    alpha, ok = _core.inverse_kinematics(_core_arm(arm), t, float(elbow))
    length = np.full_like(alpha, np.nan)
    if ok.any():
        length[ok] = _core.forward(_core_arm(arm), np.ascontiguousarray(alpha[ok]))["length_mm"]
    return {"alpha_deg": alpha, "length_mm": length, "reachable": ok}


# ---------------------------------------------------------------------------- helpers
def _check_memory(alpha_deg: npt.ArrayLike, n: int, load: Any = None) -> None:
    """Refuse, before any array is converted or allocated, a solve whose output cannot fit:
    :func:`~eodarm.model.resources.solve_output_bytes`. N is the rows of the poses, or of the
    masses or payloads ``load`` one pose is broadcast over (arrays only: the shape of a
    list is known only by converting it)."""
    shape = np.shape(alpha_deg) if isinstance(alpha_deg, np.ndarray) else ()
    rows = int(shape[0]) if len(shape) == 2 else 1 if len(shape) == 1 else 0
    if isinstance(load, np.ndarray) and load.ndim in (1, 2) and rows <= 1:
        rows = max(rows, int(load.shape[0]))
    if rows:
        check_output_memory(solve_output_bytes(rows, n), f"solve of {rows:,} poses")


#: The outputs of the analytic solve: dtype and shape in rows N and links n.
_OUT_SHAPES: dict[str, tuple[type, tuple[str, ...]]] = {
    "force_n": (np.float64, ("N", "n")),
    "reaction_n": (np.float64, ("N", "n", "2")),
    "dforce_n": (np.float64, ("N", "n")),
    "torque_nmm": (np.float64, ("N", "n")),
    "dtorque_nmm": (np.float64, ("N", "n")),
    "dx_mm": (np.float64, ("N",)),
    "dy_mm": (np.float64, ("N",)),
    "dalpha_deg": (np.float64, ("N", "n")),
    "dl_mm": (np.float64, ("N", "n")),
    "dlength_mm": (np.float64, ("N", "n")),
    "length_mm": (np.float64, ("N", "n")),
    "status": (np.uint8, ("N",)),
}


def check_out(
    out: Mapping[str, Any], rows: int, n: int, asked: Sequence[str] | None = None
) -> dict[str, npt.NDArray[Any]]:
    """The caller's output arrays of :func:`solve` (``out=``) as a dict, or an InputError
    naming the first missing or unknown key, or the first array of the wrong type, dtype,
    shape or layout (or not writeable, or shared with another key). With ``asked`` (the
    ``outputs=`` of the call) exactly those keys and ``status``."""
    if not isinstance(out, Mapping):
        raise InputError(f"out: expected a dict of arrays, got {type(out).__name__}")
    keys = _OUT_SHAPES if asked is None else {*asked, "status"}
    wanted = {k: v for k, v in _OUT_SHAPES.items() if k in keys}
    unknown = sorted(set(out) - set(wanted))
    if unknown:
        listed = ", ".join(wanted)
        if unknown[0] in _OUT_SHAPES:
            raise InputError(f"out: key {unknown[0]!r} is not in outputs; expected {listed}")
        raise InputError(f"out: unknown key {unknown[0]!r}; expected {listed}")
    checked: dict[str, npt.NDArray[Any]] = {}
    for key, (dtype, dims) in wanted.items():
        if key not in out:
            raise InputError(f"out: missing key {key!r}")
        a = out[key]
        shape = tuple(rows if d == "N" else n if d == "n" else int(d) for d in dims)
        want = f"a writeable C-contiguous {np.dtype(dtype).name} array of shape {shape}"
        if not isinstance(a, np.ndarray):
            raise InputError(f"out[{key!r}]: expected {want}, got {type(a).__name__}")
        if a.dtype != dtype or a.shape != shape:
            raise InputError(f"out[{key!r}]: expected {want}, got {a.dtype} {a.shape}")
        if not a.flags.c_contiguous or not a.flags.writeable:
            raise InputError(f"out[{key!r}]: expected {want}, got a view that is not")
        for other, b in checked.items():
            if np.shares_memory(a, b):
                raise InputError(f"out[{key!r}]: shares memory with out[{other!r}]")
        checked[key] = a
    return checked


def _extras(
    extra: Mapping[str, npt.ArrayLike | None] | None, rows: int, n: int
) -> dict[str, npt.NDArray[np.float64]]:
    """The given extra deformations as contiguous float64 arrays of their shapes (absent or
    None keys left out), or a clear InputError naming the key (and the row)."""
    from eodarm.model.reference import EXTRA_SHAPES

    out: dict[str, npt.NDArray[np.float64]] = {}
    for key, value in (extra or {}).items():
        if key not in EXTRA_SHAPES:
            raise InputError(f"extra: unknown key {key!r}; known: {', '.join(EXTRA_SHAPES)}")
        if value is None:
            continue
        shape = (rows, *(n if d == "n" else int(d) for d in EXTRA_SHAPES[key]))
        try:
            a = np.asarray(real_array(value, key), dtype=float)
        except (TypeError, ValueError, OverflowError) as exc:
            if isinstance(exc, InputError):
                raise
            raise InputError(f"{key}: cannot be read as an array of numbers") from None
        if a.shape != shape:
            raise InputError(f"{key}: expected shape {shape}, got {a.shape}")
        bad = ~np.isfinite(a.reshape(rows, -1)).all(axis=1)
        if bad.any():
            raise InputError(
                f"pose row {int(np.flatnonzero(bad)[0])}: {key} has a non-finite value"
            )
        out[key] = np.ascontiguousarray(a)
    return out
