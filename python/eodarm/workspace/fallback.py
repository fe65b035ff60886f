"""The sweep's general path: chunks solved pose by pose by the core (or the FE model).

Used for lengths and effector grids, the finite-element model and Dask schedulers; the
angle grids of the analytic model run in the core's own sweep kernel.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import EodarmError, InputError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, split_effects
from eodarm.model.solver import _core_arm, forward, stroke_violations
from eodarm.model.validity import STATUS, checks_load_rise, quiet_rows, status

if TYPE_CHECKING:
    from eodarm.model.custom import EffectState

__all__ = [
    "REDUCE_OPS",
    "cell_status",
    "group_status",
    "kernel",
    "placeholder",
    "singular",
    "sweep_fallback",
]

#: The reductions of a sweep (per cell, NaN ignored).
REDUCE_OPS = ("max", "min", "argmax", "argmin")

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


# ---------------------------------------------------------------------------- the kernel
def sweep_fallback(
    arm: Arm,
    alpha_deg: FloatArray,
    mass_kg: FloatArray,
    codes: npt.NDArray[np.int64],
    places: npt.NDArray[np.int64],
    values: FloatArray,
    self_weight: bool,
    reduce: str | None = None,
    group: int = 1,
    threads: int | None = None,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
    effects: Sequence[Effect] = (),
) -> dict[str, npt.NDArray[Any]]:
    """The semantics of ``eodarm._core.sweep``, built on ``eodarm._core.solve``.

    With ``model="fem"`` the cells are solved by the finite-element model instead
    (:func:`eodarm.model.fem.fem_solve_payload`, ``effects`` given as Effect values).
    User-written effects (custom-effects.md) among ``effects`` are computed here, once per place
    for the whole chunk, on the statics of its solvable cells, and given to the core as extra
    deformations (``codes``/``places``/``values`` hold the catalogue's effects only).

    Kept as the definition the fast core is tested against, and the kernel of FE sweeps.
    ``threads`` is ignored here (``_core.solve`` uses rayon's global pool).

    Parameters
    ----------
    arm : the arm (the core takes its compiled ``CoreArm``).
    alpha_deg : (N, n) unloaded angles of N poses, degrees, C-contiguous float64.
    mass_kg : (M,) payload masses, kg. Cell (p, j) carries (0, −mass_kg[j]·g) at the load
        point; its flat row is ``r = p·M + j``.
    codes, places, values : the effects (:func:`eodarm.model.effects.effect_arrays`).
    self_weight : include link and actuator weights in both states.
    reduce : None, or ``"max"``, ``"min"``, ``"argmax"``, ``"argmin"`` over consecutive groups
        of ``group`` rows of the flat row index, NaN ignored.

    Returns
    -------
    dict: ``force_n`` (N, M, n), ``dx_mm``, ``dy_mm`` (N, M), ``dalpha_deg``, ``dl_mm``
    (N, M, n), ``status`` (N, M) uint8 (:func:`cell_status`), ``ok`` (N, M) its being 0
    (NaN values where it is not); reduced, these have leading shape (N·M/group,),
    argmax/argmin as int64 (−1 where the group has no ok cell), ``ok`` as "any" and
    ``status`` by :func:`group_status`. Per pose, never reduced:
    ``length_mm`` (N, n) unloaded pin-to-pin, ``reachable`` (N,) (not singular and every
    length within [min_length_mm, max_length_mm]), ``effector_x_mm``, ``effector_y_mm`` (N,)
    the unloaded load point.
    """
    from eodarm.model import native as _core

    alpha = np.ascontiguousarray(alpha_deg, dtype=float)
    mass = np.ascontiguousarray(mass_kg, dtype=float)
    n_pose, n = alpha.shape
    m = mass.shape[0]
    rows = n_pose * m
    if reduce is not None and reduce not in REDUCE_OPS:
        raise InputError(f"reduce must be one of {', '.join(REDUCE_OPS)} or None, got {reduce!r}")
    if reduce is not None and (group < 1 or rows % group):
        raise InputError(f"group {group} does not divide the {rows} rows")
    core = _core_arm(arm)
    payload = np.zeros((rows, 2))
    payload[:, 1] = -np.tile(mass, n_pose) * arm.g
    if model == "fem":
        from eodarm.model import fem

        out = fem.fem_solve_payload(
            arm,
            np.repeat(alpha, m, axis=0),
            payload,
            list(effects),
            self_weight,
            fem_options,
            nan_on_failure=True,
        )
    else:
        cell_alpha = np.repeat(alpha, m, axis=0)
        users = split_effects(effects)[1]
        extras = _user_extras(arm, cell_alpha, payload, users, self_weight) if users else {}
        out = _core.solve(
            core,
            cell_alpha,
            payload,
            codes,
            places,
            values,
            self_weight,
            nan_on_failure=True,
            **extras,
        )
    if model == "fem":
        lift: Any = False
    else:
        lift = checks_load_rise(arm, split_effects(effects)[0]) & quiet_rows(extras, rows)
    code = cell_status(arm, np.repeat(alpha, m, axis=0), payload, out, lift)
    ok = code == 0
    cells: dict[str, npt.NDArray[Any]] = {
        key: np.where(ok.reshape(-1, *[1] * (out[key].ndim - 1)), out[key], np.nan)
        for key in ("force_n", "dx_mm", "dy_mm", "dalpha_deg", "dl_mm")
    }
    res: dict[str, npt.NDArray[Any]] = {}
    if reduce is None:
        for key, val in cells.items():
            res[key] = val.reshape(n_pose, m, *val.shape[1:])
        res["ok"] = ok.reshape(n_pose, m)
        res["status"] = code.reshape(n_pose, m)
    else:
        for key, val in cells.items():
            res[key] = reduce_rows(val, reduce, group)
        res["ok"] = np.asarray(ok.reshape(rows // group, group).any(axis=1))
        res["status"] = group_status(code, group)
    geo = _core.forward(core, alpha)
    length = geo["length_mm"]
    in_stroke = (stroke_violations(arm, length) == 0).all(axis=1)
    res["length_mm"] = length
    res["reachable"] = ~singular(geo, n) & in_stroke
    res["effector_x_mm"] = np.ascontiguousarray(geo["O"][:, n, 0])
    res["effector_y_mm"] = np.ascontiguousarray(geo["O"][:, n, 1])
    return res


def cell_status(
    arm: Arm,
    alpha: FloatArray,
    payload: FloatArray,
    out: Mapping[str, Any],
    load_rise: Any = False,
) -> npt.NDArray[np.uint8]:
    """The status (R,) of solved cells (``out`` with NaN where a cell did not solve), as the
    core's sweep gives it: :func:`eodarm.model.validity.status`, and a cell that did not
    solve although its pose is in stroke and not near singular is a large deflection (its
    loaded triangle cannot close)."""
    code = status(arm, alpha, payload, out, load_rise=load_rise)
    unsolved = ~np.isfinite(np.asarray(out["dy_mm"], dtype=float))
    code[(code == 0) & unsolved] = STATUS.index("large_deflection")
    return code


def group_status(code: npt.NDArray[np.uint8], group: int) -> npt.NDArray[np.uint8]:
    """The status of each group of ``group`` consecutive cells: 0 when every cell is ok, else
    the lowest code among those that are not."""
    g = np.where(code == 0, 255, code).reshape(-1, group).min(axis=1)
    return np.where(g == 255, 0, g).astype(np.uint8)


def _user_extras(
    arm: Arm,
    alpha: FloatArray,
    payload: FloatArray,
    effects: Sequence[Effect],
    self_weight: bool,
) -> dict[str, FloatArray]:
    """The extra deformations of user-written effects for every cell (zero where the pose is
    singular: the core marks those cells not ok anyway)."""
    from eodarm.model import custom

    good = np.flatnonzero(~singular(forward(arm, alpha), arm.n))
    state = _state(arm, alpha[good], payload[good], self_weight)
    part = custom.extras_of(effects, state)
    rows, n = alpha.shape[0], arm.n
    full = {
        "extra_seen_mm": np.zeros((rows, n)),
        "extra_unseen_mm": np.zeros((rows, n)),
        "extra_joint_mm": np.zeros((rows, n, 2)),
        "extra_tilt_rad": np.zeros(rows),
        "extra_measure_mm": np.zeros((rows, 2)),
    }
    for key, a in part.items():
        full[key][good] = a
    return {k: v for k, v in full.items() if k in part}


def _state(arm: Arm, alpha: FloatArray, payload: FloatArray, self_weight: bool) -> EffectState:
    from eodarm.model import custom
    from eodarm.model import native as _core

    core = _core_arm(arm)
    a, p = np.ascontiguousarray(alpha), np.ascontiguousarray(payload)
    return custom.EffectState.from_statics(
        arm, a, p, _core.statics(core, a, p, self_weight), self_weight
    )


def reduce_rows(x: npt.NDArray[Any], op: str, group: int) -> npt.NDArray[Any]:
    """Reduce consecutive groups of ``group`` rows of ``x`` (R, ...), NaN ignored.

    max/min: NaN where the whole group is NaN; argmax/argmin: int64 index within the group
    (the first of equal values), −1 where the whole group is NaN.
    """
    g = x.reshape(x.shape[0] // group, group, *x.shape[1:])
    nan = np.isnan(g)
    empty = nan.all(axis=1)
    fill = -np.inf if op in ("max", "argmax") else np.inf
    filled = np.where(nan, fill, g)
    if op in ("max", "min"):
        r = filled.max(axis=1) if op == "max" else filled.min(axis=1)
        r[empty] = np.nan
        return r
    idx = (filled.argmax(axis=1) if op == "argmax" else filled.argmin(axis=1)).astype(np.int64)
    idx[empty] = -1
    return idx


def singular(geo: Mapping[str, FloatArray], n: int) -> BoolArray:
    """Poses (N,) where an actuator has coincident pins or passes through its joint.

    The core's tests (statics.rs): ℓ ≤ 1e-12·(1 + |A−O|), or |h| < 1e-9·|A−O| with
    h = (A − O) × unit(A − B) the moment arm (compared here squared, without dividing by ℓ).
    """
    a, o, b = geo["A"], geo["O"], geo["B"]
    bad = np.zeros(a.shape[0], dtype=bool)
    for i in range(n):
        rx, ry = a[:, i, 0] - o[:, i, 0], a[:, i, 1] - o[:, i, 1]
        vx, vy = a[:, i, 0] - b[:, i, 0], a[:, i, 1] - b[:, i, 1]
        rn2 = rx * rx + ry * ry
        ell2 = vx * vx + vy * vy
        cross = rx * vy - ry * vx  # = h·ℓ
        bad |= ~(ell2 > 1e-24 * (1.0 + np.sqrt(rn2)) ** 2) | ~(cross * cross >= 1e-18 * rn2 * ell2)
    return bad


def kernel(
    arm: Arm,
    alpha: FloatArray,
    mass: FloatArray,
    codes: npt.NDArray[np.int64],
    places: npt.NDArray[np.int64],
    values: FloatArray,
    self_weight: bool,
    reduce: str | None,
    group: int,
    threads: int | None,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
    effects: Sequence[Effect] = (),
) -> dict[str, npt.NDArray[Any]]:
    """One chunk through the compiled core, or through :func:`sweep_fallback` for the
    finite-element model and for user-written effects (the core's kernel cannot call
    Python)."""
    from eodarm.model import native as _core

    if model == "fem" or split_effects(effects)[1]:
        return sweep_fallback(
            arm,
            alpha,
            mass,
            codes,
            places,
            values,
            self_weight,
            reduce,
            group,
            threads,
            model,
            fem_options,
            effects,
        )
    return dict(
        _core.sweep(
            _core_arm(arm), alpha, mass, codes, places, values, self_weight, reduce, group, threads
        )
    )


@lru_cache(maxsize=64)
def placeholder(arm: Arm) -> FloatArray:
    """A pose in which actuator 1 passes through joint O_1 (singular, so every cell is NaN).

    Grid cells that have no pose (lengths that cannot assemble the arm, unreachable effector
    targets) or that are masked out are solved as this pose, so the kernel marks them not ok
    and every reduction skips them, without the kernel knowing about masks.
    """
    o1, b0 = np.asarray(arm.O1), np.asarray(arm.B0)
    a = np.asarray(arm.links[0].A)
    d = b0 - o1
    alpha1 = math.degrees(math.atan2(d[1], d[0]) - math.atan2(a[1], a[0]) + math.pi)
    pose = np.zeros(arm.n)
    pose[0] = alpha1
    geo = forward(arm, pose[None, :])
    if not singular(geo, arm.n)[0]:  # pragma: no cover - exact collinearity by construction
        raise EodarmError("internal: the placeholder pose is not singular")
    return pose
