"""Compensation (docs/compensation.md): the angles to command so that the payload does not
move the point.

A user commands a nominal pose (unloaded angles α⁰); under the payload the arm deflects and
its measure point misses where the nominal pose puts it. :func:`compensate` returns the
unloaded angles to command instead, so that the model's loaded measure point lands on the
nominal one and, with three links or more, the last link keeps its nominal absolute angle;
with more than three links the spare freedom goes to the smallest change of angles. The
conditions are solved by the compiled core on the exact model (``arm_core::compensate``;
docs/compensation.md has the equations, the statuses and the limits).

>>> import eodarm
>>> arm = eodarm.Arm.from_toml("examples/example_arm.toml")              # doctest: +SKIP
>>> out = eodarm.compensate(arm, [[90.0, 10.0, 0.0]], 5.0)                # doctest: +SKIP
>>> out["alpha_deg"], out["residual_mm"], out["status"]                  # doctest: +SKIP
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import EodarmError, InputError
from eodarm.model.arm import Arm, check_arm
from eodarm.model.effects import Effect, effect_arrays, split_effects, with_arm_effects
from eodarm.model.kinds import integer, real_number
from eodarm.model.kinematics import _core_arm, _poses_and_masses

__all__ = [
    "JACOBIANS",
    "STATUSES",
    "CompensationError",
    "CompensationWarning",
    "compensate",
    "failure_summary",
]

#: The status of a pose, in the order of the core's codes (``_core.COMPENSATE_STATUSES``):
#: ``ok``; ``out_of_stroke`` (a commanded actuator length outside its stroke);
#: ``near_singular`` (an actuator's moment arm is tiny, or the point cannot move in some
#: direction); ``no_convergence``.
STATUSES = ("ok", "out_of_stroke", "near_singular", "no_convergence")
#: The Jacobians the iteration can use (docs/compensation.md §3).
JACOBIANS = ("auto", "rigid", "finite_difference")
#: Rows named per reason in a summary before the rest are counted.
MAX_ROWS_NAMED = 8
#: A 1-link arm's least-squares miss above this (mm) is reported.
ONE_LINK_REPORT_MM = 1e-6


class CompensationWarning(UserWarning):
    """Some poses could not be compensated (their rows are NaN), or a 1-link arm could not
    hold the point exactly; the message names the rows and the reasons."""


class CompensationError(EodarmError):
    """With ``strict=True``: some poses could not be compensated (rows and reasons named)."""


def compensate(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    mass_kg: npt.ArrayLike,
    effects: Effect | list[Effect] | tuple[Effect, ...] | None = None,
    self_weight: bool = True,
    *,
    strict: bool = False,
    jacobian: str = "auto",
    max_iter: int = 50,
    tol_mm: float = 1e-9,
) -> dict[str, npt.NDArray[Any]]:
    """The unloaded angles to command so that, under the payload, the model's measure point
    lands where the nominal pose puts it (and, n ≥ 3, the last link keeps its angle).

    With a friction in the model (``actuator_friction``, ``joint_friction``) this compensates
    the loading branch: the payload reached by loading from the unloaded pose, the frictions
    holding nothing before (docs/model.md §9). After an unloading the arm sits elsewhere.

    Parameters
    ----------
    arm : the arm. Its own effects (``[[effect]]`` tables, :attr:`Arm.effects`) are part of
        the model.
    alpha_deg : (N, n) nominal unloaded absolute angles, degrees: the poses a user would
        command without compensation (a single pose (n,) is N = 1).
    mass_kg : payload mass, kg; scalar or (N,), or (M,) with a single pose: that pose under
        each of M payloads (M rows; docs/python.md, "Broadcasting").
    effects : effects on top of the arm's (the same ``effect@place`` replaces the arm's),
        built-in or user-written (:func:`eodarm.custom_effect`): with user-written effects
        the core's compensation with the built-in ones is the start of a Gauss–Newton
        iteration on the full model in Python (:mod:`eodarm.analysis.compensate_custom`;
        a finite-difference Jacobian, one batched :func:`eodarm.solve` per step).
    self_weight : include link and actuator weights in both states (as :func:`eodarm.solve`).
    strict : raise :class:`CompensationError` when a pose cannot be compensated, instead of
        warning.
    jacobian : ``"auto"`` (default: quasi-Newton for 2 and 3 links, exact finite differences
        for 1 and more than 3), ``"rigid"`` (quasi-Newton; 2 or 3 links only) or
        ``"finite_difference"`` (the core's; with user-written effects the Python iteration
        always uses finite differences).
    max_iter : most Gauss–Newton steps per pose.
    tol_mm : the miss (mm; the last angle's scaled by the last link's length) at which a pose
        has converged.

    Returns
    -------
    dict of arrays:
        ``alpha_deg`` (N, n) the angles to command, degrees; ``length_mm`` (N, n) the unloaded
        pin-to-pin actuator lengths that realise them; ``residual_mm`` (N,) the model's
        remaining miss of the nominal point, mm (the least-squares miss for a 1-link arm);
        ``status`` (N,) one of :data:`STATUSES`; ``iterations`` (N,) Gauss–Newton steps;
        ``actuator`` (N,) the actuator a status concerns (1-based; 0 for none). Where the
        status is not ``ok``, ``alpha_deg`` and ``length_mm`` are NaN (never a pose that is
        not one) and ``residual_mm`` is the miss of the last iterate (NaN where the model
        could not be solved).

    Warns
    -----
    CompensationWarning
        When a pose could not be compensated (unless ``strict``): one message naming the rows
        and the reasons (:func:`failure_summary`); and for a 1-link arm whose least-squares
        miss exceeds 10⁻⁶ mm.

    Raises
    ------
    CompensationError
        With ``strict=True``, when a pose could not be compensated.
    InputError
        For a wrong shape, a non-finite angle or mass, a negative mass (row named), a bad
        option; :class:`~eodarm.errors.EffectError` for a bad effect.
    """
    check_arm(arm, "compensate")
    alpha, mass = _poses_and_masses(alpha_deg, mass_kg, arm.n)
    bad = np.flatnonzero(mass < 0)
    if bad.size:
        raise InputError(f"pose row {bad[0]}: mass_kg is negative ({mass[bad[0]]})")
    if jacobian not in JACOBIANS:
        raise InputError(f"jacobian must be one of {', '.join(JACOBIANS)}, got {jacobian!r}")
    max_iter = integer(max_iter, "max_iter", 1, 2**31 - 1)
    tol_mm = real_number(tol_mm, "tol_mm")
    if not (np.isfinite(tol_mm) and tol_mm > 0):
        raise InputError(f"tol_mm must be finite and > 0, got {tol_mm!r}")
    effs = with_arm_effects(arm.effects, effects)
    codes, places, values = effect_arrays(effs, arm.n)  # the catalogue's effects
    payload = np.zeros((alpha.shape[0], 2))
    payload[:, 1] = -mass * arm.g

    from eodarm.model import native as _core

    raw = _core.compensate(
        _core_arm(arm),
        alpha,
        payload,
        codes,
        places,
        values,
        bool(self_weight),
        jacobian=jacobian,
        max_iter=int(max_iter),
        tol_mm=float(tol_mm),
    )
    status = np.asarray(STATUSES)[raw["status"]]
    out: dict[str, npt.NDArray[Any]] = {
        "alpha_deg": raw["alpha_deg"],
        "length_mm": raw["length_mm"],
        "residual_mm": raw["residual_mm"],
        "status": status,
        "iterations": raw["iterations"].astype(np.int64),
        "actuator": raw["actuator"].astype(np.int64),
    }
    if split_effects(effs)[1]:  # user-written effects: finished in Python on the full model
        from eodarm.analysis.compensate_custom import refine

        out = refine(arm, alpha, mass, effs, bool(self_weight), out, int(max_iter), float(tol_mm))
    summary = failure_summary(out)
    if summary:
        if strict:
            raise CompensationError(summary)
        warnings.warn(
            summary + "; their alpha_deg and length_mm are NaN", CompensationWarning, stacklevel=2
        )
    if arm.n == 1:
        ok = status == "ok"
        worst = float(out["residual_mm"][ok].max()) if ok.any() else 0.0
        if worst > ONE_LINK_REPORT_MM:
            warnings.warn(
                "compensate: a 1-link arm turns but cannot hold a point: the angles are the "
                f"least-squares ones and the point still misses by up to {worst:.3g} mm "
                "(residual_mm)",
                CompensationWarning,
                stacklevel=2,
            )
    return out


def failure_summary(
    out: dict[str, npt.NDArray[Any]],
    source: str | None = None,
    lines: Sequence[int] | None = None,
) -> str:
    """One line naming the poses of a :func:`compensate` result that are not ``ok``, grouped
    by reason (``""`` when all are ok): by their 0-based row, or, for poses read from a file
    ``source``, by their 1-based ``lines`` in it."""
    status = np.asarray(out["status"])
    actuator = np.asarray(out["actuator"])
    failed = np.flatnonzero(status != "ok")
    if failed.size == 0:
        return ""
    groups: dict[tuple[str, int], list[int]] = {}
    for row in failed.tolist():
        groups.setdefault((str(status[row]), int(actuator[row])), []).append(row)
    parts = []
    for (reason, act), rows in groups.items():
        shown = (
            rows[:MAX_ROWS_NAMED] if lines is None else [lines[r] for r in rows[:MAX_ROWS_NAMED]]
        )
        named = ", ".join(str(r) for r in shown)
        more = f" and {len(rows) - MAX_ROWS_NAMED} more" if len(rows) > MAX_ROWS_NAMED else ""
        word = "row" if len(rows) == 1 else "rows"
        if lines is not None:
            word = f"{source} line" + ("" if len(rows) == 1 else "s")
        parts.append(f"{word} {named}{more}: {_reason(reason, act)}")
    return (
        f"compensate: {failed.size} of {status.size} poses could not be compensated: "
        + "; ".join(parts)
    )


def _reason(status: str, actuator: int) -> str:
    if status == "out_of_stroke":
        return f"actuator {actuator} would leave its stroke (out_of_stroke)"
    if status == "near_singular":
        if actuator:
            return (
                f"actuator {actuator} is at or near its dead point: its line passes (nearly) "
                f"through joint O{actuator}, or its triangle cannot close under the load "
                "(near_singular)"
            )
        return "the point cannot move in some direction: a kinematic singularity (near_singular)"
    return (
        "no commanded pose near the nominal one was found that puts the loaded point there "
        "(no_convergence: the deflection grows as fast as the command near an actuator's dead "
        "point, or a play or clearance changes side between steps)"
    )
