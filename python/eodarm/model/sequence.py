"""Load sequences: each pose loaded and unloaded through payloads from one reference, with
the memory of friction and gaps (docs/model.md §9), on the compiled core or the numpy
reference; :func:`cycle_returns`, where each sweep cell's load cycle ends.

``eodarm.solve_sequence`` is :func:`solve_sequence`; :mod:`eodarm.model.solver` re-exports
it and :func:`cycle_returns` under their old names.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

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
    _poses,
    _refuse_unloaded_singular,
)
from eodarm.model.outputs import check_outputs, core_outputs, select
from eodarm.model.resources import check_output_memory, solve_output_bytes
from eodarm.model.validity import checks_load_rise, status

__all__ = ["cycle_returns", "solve_sequence"]


def solve_sequence(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    mass_kg: npt.ArrayLike,
    effects: Effect | list[Effect] | tuple[Effect, ...] | None = None,
    backend: Backend = "rust",
    self_weight: bool = True,
    *,
    strict: bool = False,
    nan_on_failure: bool | None = None,
    uncertainty: bool = False,
    outputs: Sequence[str] | None = None,
) -> Arrays:
    """N load sequences: each pose loaded and unloaded through S payloads from one reference.

    The reference of a sequence is its pose unloaded (self-weight only), in which the sensors
    were zeroed; every state is relative to it, not to "this state unloaded". The friction
    elements (``actuator_friction``, ``joint_friction``) hold what the states before let them
    hold, and the gaps (``actuator_play``, ``joint_clearance``) are taken up along each
    state's actual force (docs/model.md, "Load sequences and friction"); at a rotary drive
    ``drive_friction`` and ``joint_friction`` hold torques and ``drive_backlash`` is taken up
    along the drive's actual torque (docs/model.md §10). :func:`solve` is
    the case S = 1.

    Parameters
    ----------
    arm : the arm.
    alpha_deg : (N, n) unloaded absolute link angles of the N sequences, degrees (a single
        pose (n,) is N = 1).
    mass_kg : (N, S) payload masses (kg, ≥ 0; 0 is the return to no payload) of the S states
        after each reference, in the order they are applied; (S,) or (1, S) gives every
        sequence the same payloads, and one pose with (M, S) is M sequences of that pose.
    effects : effects added to the arm's. A user-written effect holds no history: each state
        sees it loaded once from the sequence's reference, and such a model is solved by the
        numpy reference whatever ``backend`` says (the compiled core takes no user
        deformations in sequences).
    backend : ``"rust"`` (compiled core) or ``"numpy"`` (the independent reference,
        ``eodarm.reference.solve_sequence``).
    self_weight : include link and actuator weights in the reference and every state.
    strict : as :func:`solve`'s, per state. False (the default): a state whose loaded pose
        cannot be closed (an actuator triangle the loaded lengths cannot close, a pose that
        will not settle) gets NaN in every output and a non-``ok`` ``status``, while the
        other states, those after it included, are solved (what the frictions hold comes
        from the forces on the undeformed geometry and steps through it). True: such a state
        raises, naming its sequence and state. A pose singular *unloaded* is invalid input
        and raises either way.
    nan_on_failure : the older name of ``not strict`` (given, it wins).
    uncertainty : also return the standard deviations of every state, with :func:`solve`'s
        keys and shapes (N, S) and (N, S, n): ``sigma_dx_mm``, ``sigma_dy_mm``,
        ``sigma_dalpha_deg`` and their parts ``sigma_param_*`` (the arm's fitted parameters,
        propagated linearly through the sequence) and ``sigma_model_*`` (the fitted model's
        inadequacy). Needs a fitted arm (``eodarm fit -o``, ``FitResult.to_arm()``);
        catalogue effects only (:func:`eodarm.model.uncertainty.sequence_sigma`).
    outputs : the keys to return, as :func:`solve`'s (``status`` always with them); None
        (the default) is every key. The compiled core allocates and writes only the asked
        arrays; the numpy backend, a model with a user-written effect and ``uncertainty``
        compute every output and select. An unknown or repeated key, an empty sequence or a
        bare string is an :class:`~eodarm.errors.InputError` listing the valid keys.

    Returns
    -------
    dict of arrays, the keys of :func:`solve` with a state axis: ``force_n`` (N, S, n) actual
    actuator forces (compression +, N), ``torque_nmm`` (N, S, n) actual drive torques (on
    link i about O_i, counter-clockwise +, N·mm), ``dx_mm``, ``dy_mm`` (N, S) measure-point
    displacement from the reference (mm), ``dalpha_deg`` (N, S, n), ``dl_mm`` (N, S, n) body
    length change as the actuator's sensor sees it (mm), ``status`` (N, S) uint8 (docs/model.md
    §7), ``reaction_n`` (N, S, n, 2), ``dforce_n``, ``dtorque_nmm``, ``dlength_mm``,
    ``length_mm`` (N, S, n). The forces and lengths are NaN at a joint turned by a rotary
    drive, the torques at one turned by a linear actuator (docs/model.md §10).

    Raises
    ------
    InputError
        (an :class:`~eodarm.errors.EodarmError`, a ``ValueError``) in one line naming the
        sequence (and state) for a wrong shape, a non-finite or negative mass, a pose singular
        unloaded, or (``strict=True``) a state that cannot be closed under its load.
    OutOfMemoryError
        When the outputs cannot fit in memory: refused from the shapes, before any input is
        copied.
    """
    check_arm(arm, "solve_sequence")
    _check_backend(backend)
    asked = check_outputs(outputs, uncertainty=uncertainty)
    if nan_on_failure is not None:
        strict = not nan_on_failure
    _check_sequence_memory(alpha_deg, mass_kg, arm.n)
    alpha = _poses(alpha_deg, arm.n, "alpha_deg")
    rows = alpha.shape[0]
    many = (
        np.shape(mass_kg)
        if isinstance(mass_kg, np.ndarray)
        else np.shape(np.asarray(mass_kg, dtype=object))
    )
    if rows == 1 and len(many) == 2 and many[0] > 1:  # one pose, M sequences of payloads
        rows = int(many[0])
        alpha = np.ascontiguousarray(np.broadcast_to(alpha, (rows, arm.n)))
    mass = _sequence_masses(mass_kg, rows)
    check_output_memory(
        solve_output_bytes(mass.size, arm.n), f"solve_sequence of {mass.size:,} states"
    )
    effs = with_arm_effects(arm.effects, effects)
    if uncertainty:
        from eodarm.model.uncertainty import require_fit, sequence_sigma

        require_fit(arm)  # before any work
        if split_effects(effs)[1]:
            raise InputError("uncertainty is propagated for the catalogue's effects only")
    # the sigmas are propagated from every output; the failed rows are read from dy_mm
    keys = None if uncertainty else core_outputs(asked, need_dy=not strict)
    res = _sequences(arm, alpha, mass, effs, backend, self_weight, strict, keys)
    dy = np.asarray(res["dy_mm"]) if not strict else None
    if dy is not None and np.isnan(np.sum(dy)):  # some state failed (one pass, no temporary)
        failed = np.isnan(dy).any(axis=1)
        _refuse_unloaded_singular(arm, alpha, {"dy_mm": np.where(failed, np.nan, 0.0)}, "sequence")
    if uncertainty:

        def run(model: list[Effect]) -> Arrays:
            return _sequences(arm, alpha, mass, model, backend, self_weight, strict=False)

        res.update(sequence_sigma(arm, effs, run, res))
    return select(res, asked)


def _sequences(
    arm: Arm,
    alpha: npt.NDArray[np.float64],
    mass: npt.NDArray[np.float64],
    effs: list[Effect],
    backend: Backend,
    self_weight: bool,
    strict: bool,
    keys: list[str] | None = None,
) -> Arrays:
    """:func:`solve_sequence` of checked inputs on the backend asked for, or on the numpy
    reference for a model with user-written effects; ``keys``: the outputs the compiled core
    writes (None: every one; the numpy reference computes every one)."""
    if split_effects(effs)[1]:
        # A user-written effect holds no history: each state sees it loaded once from the
        # sequence's reference. Its deformations are computed in Python, state by state,
        # which the numpy reference does (the compiled core takes no extras in sequences).
        backend = "numpy"
    if backend != "numpy":
        return _core_sequence(arm, alpha, mass, effs, self_weight, strict, keys)
    from eodarm.model import reference

    # The numpy reference solves sequences too (eodarm.reference.solve_sequence).
    try:
        res = dict(
            reference.solve_sequence(
                arm, alpha, mass, effs, self_weight=self_weight, nan_on_failure=not strict
            )
        )
    except InputError as exc:  # named as the compiled core's are
        found = re.fullmatch(r"pose row (\d+): (.*) \(state (\d+) of the sequence\)", str(exc))
        if found is None:
            raise
        q, s = int(found.group(1)), int(found.group(3)) - 1
        raise InputError(f"{_state_words(q, s, mass)}: {found.group(2)}") from None
    n_seq, n_states = mass.shape
    flat_alpha = np.repeat(alpha, n_states, axis=0)
    flat_payload = np.stack([np.zeros(mass.size), -mass.ravel() * arm.g], axis=-1)
    flat = {k: v.reshape(n_seq * n_states, *v.shape[2:]) for k, v in res.items()}
    code = status(arm, flat_alpha, flat_payload, flat, load_rise=checks_load_rise(arm, effs))
    res["status"] = code.reshape(n_seq, n_states)  # type: ignore[assignment]
    return res


def _core_sequence(
    arm: Arm,
    alpha: npt.NDArray[np.float64],
    mass: npt.NDArray[np.float64],
    effs: list[Effect],
    self_weight: bool,
    strict: bool,
    keys: list[str] | None = None,
) -> Arrays:
    """:func:`solve_sequence` on the compiled core (the outputs ``keys``, None: every one);
    its refusals as :class:`InputError`
    naming the sequence and, for a state that cannot be closed, the state."""
    from eodarm.model import native as _core

    codes, places, values = effect_arrays(effs, arm.n)

    def run(
        a: npt.NDArray[np.float64], m: npt.NDArray[np.float64], nan: bool, keys: list[str] | None
    ) -> Arrays:
        out: Arrays = _core.solve_sequence(
            _core_arm(arm),
            a,
            _core_masses(m),
            codes,
            places,
            values,
            self_weight,
            nan,
            outputs=keys,
        )
        return out

    try:
        return run(alpha, mass, not strict, keys)
    except _core.CoreError as exc:
        text = " ".join(str(exc).split())
        found = re.match(r"pose row (\d+)[:,]?\s*(.*)", text)
        if found is None:
            raise InputError(f"solve_sequence: {text}") from None
        q, reason = int(found.group(1)), found.group(2)
        state = None
        if q < alpha.shape[0]:  # which state: the sequence again, each failed state NaN
            try:
                one = run(alpha[q : q + 1], mass[q : q + 1], True, ["dy_mm"])
                bad = np.flatnonzero(np.isnan(np.asarray(one["dy_mm"])[0]))
                state = int(bad[0]) if bad.size else None
            except _core.CoreError:
                pass  # singular unloaded: every state fails alike, the sequence says it
        raise InputError(f"{_state_words(q, state, mass)}: {reason}") from None


def _core_masses(mass: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The (N, S) masses as the compiled core takes them: the S of every sequence once, when
    ``mass`` repeats one row (a broadcast view, as :func:`_sequence_masses` leaves (S,) and
    (1, S)), else the (N, S) rows, contiguous."""
    if mass.shape[0] > 1 and mass.strides[0] == 0:
        return np.ascontiguousarray(mass[0])
    return np.ascontiguousarray(mass)


def _state_words(q: int, s: int | None, mass: npt.NDArray[np.float64]) -> str:
    """``sequence 3, state 1 (mass_kg[3, 1] = 90 kg)``: where a sequence failed."""
    if s is None:
        return f"sequence {q}"
    return f"sequence {q}, state {s} (mass_kg[{q}, {s}] = {mass[q, s]:g} kg)"


def cycle_returns(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    mass_kg: npt.ArrayLike,
    effects: Effect | list[Effect] | tuple[Effect, ...] | None = None,
    self_weight: bool = True,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Where the measure point comes back to after each cell's load cycle, on the compiled
    core: for every pose p and payload mass m_j, the sequence reference → m_j → 0 and the
    measure point at its end relative to the reference, ``dx``, ``dy`` (P, M) in mm, NaN where
    the cycle cannot be solved. The same numbers as the last state of
    :func:`solve_sequence` with the states ``[m_j, 0]``, without its other outputs (what
    ``sweep(..., cycle=True)`` needs). Built-in effects only (a user-written effect is an
    :class:`~eodarm.errors.InputError`: :func:`solve_sequence` solves those).

    Parameters
    ----------
    arm : the arm.
    alpha_deg : (P, n) unloaded absolute link angles, degrees.
    mass_kg : (M,) payload masses, kg (≥ 0).
    effects : effects added to the arm's.
    self_weight : include link and actuator weights.
    """
    check_arm(arm, "cycle_returns")
    alpha = _poses(alpha_deg, arm.n, "alpha_deg")
    mass = _sequence_masses(np.atleast_1d(np.asarray(mass_kg, dtype=float)), 1)[0]
    effs = with_arm_effects(arm.effects, effects)
    users = split_effects(effs)[1]
    if users:
        raise InputError(
            f"custom effect {users[0].key}: cycle_returns takes built-in effects only "
            "(solve_sequence solves user-written ones)"
        )
    from eodarm.model import native as _core

    codes, places, values = effect_arrays(effs, arm.n)
    dx, dy = _core.cycle_returns(
        _core_arm(arm), alpha, np.ascontiguousarray(mass), codes, places, values, self_weight
    )
    return np.asarray(dx), np.asarray(dy)


def _check_sequence_memory(alpha_deg: npt.ArrayLike, mass_kg: npt.ArrayLike, n: int) -> None:
    """Refuse, from the shapes alone and before any input is copied or checked, sequences
    whose outputs cannot fit: as :func:`_check_memory`, per state (N·S of them). Arrays only
    (the shape of a list is known only by converting it)."""
    a = np.shape(alpha_deg) if isinstance(alpha_deg, np.ndarray) else None
    m = np.shape(mass_kg) if isinstance(mass_kg, np.ndarray) else None
    if m is None or len(m) not in (1, 2):
        return
    rows = max(m[0] if len(m) == 2 else 1, a[0] if a is not None and len(a) == 2 else 1)
    states = int(rows) * int(m[-1])
    check_output_memory(solve_output_bytes(states, n), f"solve_sequence of {states:,} states")


def _sequence_masses(mass_kg: npt.ArrayLike, rows: int) -> npt.NDArray[np.float64]:
    """The (N, S) payload masses of N sequences, from (N, S), (1, S) or (S,), or an InputError
    naming the shape, or the sequence and state of a non-finite or negative mass."""
    try:
        mass = np.asarray(real_array(mass_kg, "mass_kg"), dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError("mass_kg: cannot be read as an array of finite numbers") from None
    if mass.ndim == 1 or (mass.ndim == 2 and mass.shape[0] == 1):
        mass = np.broadcast_to(mass, (rows, mass.shape[-1]))
    if mass.ndim != 2 or mass.shape[0] != rows or mass.shape[1] == 0:
        raise InputError(
            f"mass_kg: expected shape ({rows}, S) or (S,) with S >= 1, got {np.shape(mass_kg)}"
        )
    # One row repeated (a broadcast view) is checked once: its own values are all there is.
    rows_of = mass[:1] if mass.shape[0] > 1 and mass.strides[0] == 0 else mass
    if not (np.isfinite(np.sum(rows_of)) and rows_of.min() >= 0):  # one pass each, no copy
        bad = ~np.isfinite(rows_of) | (rows_of < 0)
        q, s = (int(v) for v in np.argwhere(bad)[0])
        raise InputError(
            f"mass_kg: sequence {q}, state {s}: expected a finite mass >= 0, got {mass[q, s]}"
        )
    # a repeated row stays a (read-only) view: the compiled core takes its S masses once
    return mass if rows_of is not mass else np.ascontiguousarray(mass, dtype=np.float64)
