"""The rigid arm's pose and stroke, and the input checks and core arm every solver shares.

:func:`forward` (the global points of N poses) and :func:`stroke_violations` are what
:mod:`eodarm.model.validity` needs to judge a pose; :func:`_core_arm`, :func:`_poses` and
:func:`_check_backend` are shared by :mod:`eodarm.model.solver`, :mod:`eodarm.model.fem`
and :mod:`eodarm.model.uncertainty`. They sit here, below all of them, so that no two of
these modules import each other (docs/architecture.md, "No cycles"); the solver re-exports
them under their old names.
"""

from __future__ import annotations

import re
from functools import lru_cache
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from eodarm.errors import InputError
from eodarm.model.arm import Actuator, Arm, check_arm
from eodarm.model.kinds import real_array

__all__ = ["Arrays", "Backend", "forward", "stroke_violations"]

Backend = Literal["rust", "numpy"]
Arrays = dict[str, npt.NDArray[Any]]


def forward(arm: Arm, alpha_deg: npt.ArrayLike, backend: Backend = "rust") -> Arrays:
    """Global points of N poses (seed relation 1).

    Returns ``O`` (N, n+1, 2): joints O_1…O_n and the load point; ``A`` (N, n, 2): actuator
    pins on the links; ``B`` (N, n, 2): base pin of each actuator (B_0 for actuator 1);
    ``C`` (N, n, 2): centres of mass; ``measure`` (N, 2); ``length_mm`` (N, n) pin-to-pin.
    """
    check_arm(arm, "forward")
    alpha = _poses(alpha_deg, arm.n, "alpha_deg")
    _check_backend(backend)
    if backend == "rust":
        from eodarm.model import native as _core

        return _core.forward(_core_arm(arm), alpha)
    from eodarm.model import reference

    return reference.forward(arm, alpha)


def stroke_violations(arm: Arm, length_mm: npt.ArrayLike) -> npt.NDArray[np.int8]:
    """Stroke check of pin-to-pin lengths (N, n): −1 below ``min_length_mm``, +1 above
    ``max_length_mm``, 0 within the stroke (or no limit set, or a rotary drive: its length,
    NaN, is not checked)."""
    check_arm(arm, "stroke_violations")
    length = _lengths(arm, length_mm, strict=False)
    acts = [a if isinstance(a, Actuator) else Actuator(1.0, 0.0) for a in arm.actuators]
    lo = np.array([a.min_length_mm if a.min_length_mm is not None else -np.inf for a in acts])
    hi = np.array([a.max_length_mm if a.max_length_mm is not None else np.inf for a in acts])
    return (np.where(length < lo, -1, 0) + np.where(length > hi, 1, 0)).astype(np.int8)


def _lengths(arm: Arm, values: npt.ArrayLike, strict: bool = True) -> npt.NDArray[np.float64]:
    """Pin-to-pin lengths (N, n) as :func:`_poses` checks them, NaN at the joints turned by
    rotary drives (a drive has no length: its NaN is no bad value). ``strict``: a number
    given at a drive is an InputError naming the row and joint (else it is ignored)."""
    rot = np.array(arm.kinds) == "rotary"
    if not rot.any():
        return _poses(values, arm.n, "length_mm")
    raw = _floats(values, "length_mm", "an array of finite numbers")
    if raw.ndim == 1 and raw.shape[0] == arm.n:
        raw = raw[None, :]
    if raw.ndim == 2 and raw.shape[1] == arm.n and strict:
        given = ~np.isnan(raw[:, rot])
        if given.any():
            row, k = (int(v) for v in np.argwhere(given)[0])
            i = int(np.flatnonzero(rot)[k])
            raise InputError(
                f"pose row {row}: length_mm of joint {i + 1} must be NaN: a rotary drive "
                f"turns it, which has no length (it keeps the reference pose's angle), "
                f"got {raw[row, i]:g}"
            )
    # the drives' columns checked as zeros, then NaN again
    if raw.ndim == 2 and raw.shape[1] == arm.n:
        raw = np.where(rot, 0.0, raw)
    length = _poses(raw, arm.n, "length_mm")
    length[:, rot] = np.nan
    return length


def _check_backend(backend: str) -> None:
    if backend not in ("rust", "numpy"):
        raise InputError(f"backend must be 'rust' or 'numpy', got {backend!r}")


def _floats(values: npt.ArrayLike, name: str, what: str) -> npt.NDArray[np.float64]:
    """``values`` as a float64 array, or an InputError: ``<name>: cannot be read as <what>``
    (or :func:`~eodarm.model.kinds.real_array`'s own refusal of booleans, text …)."""
    try:
        return np.asarray(real_array(values, name), dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(f"{name}: cannot be read as {what}") from None


def _poses(
    values: npt.ArrayLike, n: int, name: str, finite: bool = True
) -> npt.NDArray[np.float64]:
    """(N, n) contiguous float64, or a clear InputError naming the shape or the row (of a
    non-finite value, unless ``finite`` is False: the caller's compiled core refuses it, in
    the same words)."""
    a = _floats(values, name, "an array of finite numbers")
    if a.ndim == 1 and a.shape[0] == n:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != n:
        raise InputError(f"{name}: expected shape (N, {n}), got {a.shape}")
    if not finite:
        return np.ascontiguousarray(a)
    # The sum is finite when every value is (one pass, no temporary); only when it is not
    # (a NaN or ±inf, or an overflow of huge values) are the rows looked at one by one.
    if not np.isfinite(np.sum(a)):
        bad = ~np.isfinite(a).all(axis=1)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise InputError(f"pose row {row}: {name} has a non-finite value")
    return np.ascontiguousarray(a)


@lru_cache(maxsize=64)
def _core_arm(arm: Arm) -> Any:
    from eodarm.model import native as _core

    d = arm.arrays()

    def lim(key: str) -> npt.NDArray[np.float64]:
        return np.array(
            [np.nan if getattr(a, key, None) is None else getattr(a, key) for a in arm.actuators]
        )

    return _core.CoreArm(
        float(d["g"]),
        d["O1"],
        d["B0"],
        d["pivot"],
        d["next"],
        d["A"],
        d["B"],
        d["C"],
        d["link_mass"],
        d["measure"],
        d["stiffness"],
        d["act_mass"],
        lim("min_length_mm"),
        lim("max_length_mm"),
        lim("max_force_n"),
        kind=d["kind"],
        max_torque=d["max_torque"],
        min_angle_deg=d["min_angle_deg"],
        max_angle_deg=d["max_angle_deg"],
    )


def _per_row(values: npt.ArrayLike, rows: int, name: str) -> npt.NDArray[np.float64]:
    """(rows,) finite float64 of a scalar or (rows,) ``values``, or an InputError naming the
    shape or the row."""
    a = _floats(values, name, "finite numbers")
    if a.ndim == 0:
        a = np.full(rows, float(a))
    if a.shape != (rows,):
        raise InputError(f"{name}: expected a scalar or shape ({rows},), got {a.shape}")
    # The sum is finite when every value is (one pass, no temporary), as in _poses.
    if not np.isfinite(np.sum(a)):
        bad = ~np.isfinite(a)
        if bad.any():
            raise InputError(f"pose row {int(np.flatnonzero(bad)[0])}: {name} is not finite")
    return a


def _poses_and_masses(
    alpha_deg: npt.ArrayLike,
    mass_kg: npt.ArrayLike,
    n: int,
    finite: bool = True,
    expand: bool = True,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Poses (R, n) and payload masses (R,), broadcast against each other over the rows as
    numpy broadcasts: one pose ((n,) or (1, n)) with M masses gives M rows, N poses with one
    mass (a scalar or (1,)) N rows, N poses with N masses N rows; anything else is an
    InputError naming both shapes (docs/python.md, "Broadcasting"). ``finite``: as
    :func:`_poses`'s, for the angles (the masses are always checked). ``expand=False``
    leaves one mass for every row as a 0-d array instead of R copies."""
    alpha = _poses(alpha_deg, n, "alpha_deg", finite)
    mass = _floats(mass_kg, "mass_kg", "finite numbers")
    rows = alpha.shape[0]
    if mass.ndim == 1 and mass.shape[0] not in (1, rows) and rows == 1:
        rows = mass.shape[0]
        alpha = np.ascontiguousarray(np.broadcast_to(alpha, (rows, n)))
    if mass.ndim > 1 or (mass.ndim == 1 and mass.shape[0] not in (1, rows)):
        raise InputError(
            f"alpha_deg of shape {np.shape(alpha_deg)} and mass_kg of shape {mass.shape} do "
            "not broadcast: give one pose for M masses, N poses for one mass, or N of each"
        )
    if mass.ndim == 1 and mass.shape[0] == 1:
        mass = mass[0]
    if not expand and np.ndim(mass) == 0:
        if rows and not np.isfinite(mass):  # as _per_row says it of the copies
            raise InputError("pose row 0: mass_kg is not finite")
        return alpha, np.asarray(mass, dtype=np.float64)
    return alpha, _per_row(mass, rows, "mass_kg")


def _refuse_unloaded_singular(
    arm: Arm, alpha: npt.NDArray[np.float64], res: Arrays, row: str = "pose row"
) -> None:
    """Raise for a pose that failed because it is singular unloaded (invalid input, whatever
    ``strict``), naming its row (``row``: how the caller names it, ``sequence`` for
    :func:`solve_sequence`); the poses that failed only under load keep their NaN.

    The failed rows' statics without payload are solved again (numpy reference, few rows):
    they fail only for a pose that is singular on its undeformed geometry."""
    dy = np.asarray(res["dy_mm"])
    if not np.isnan(np.sum(dy)):  # no NaN (a NaN makes the sum NaN): one pass, no temporary
        return
    failed = np.flatnonzero(np.isnan(dy))
    if failed.size == 0:
        return
    from eodarm.model import reference

    try:
        reference.statics(arm, alpha[failed], np.zeros((failed.size, 2)), self_weight=True)
    except InputError as exc:
        # the message names the row among the failed ones: give the caller's row
        text = re.sub(
            r"pose row (\d+)", lambda m: f"{row} {failed[int(m.group(1))]}", str(exc), count=1
        )
        raise InputError(text) from None
