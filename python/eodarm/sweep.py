"""Whole-workspace sweeps: a grid of poses × payloads, solved in chunks, as an xarray Dataset.

:func:`sweep` solves every pose of a grid (of joint angles, of actuator lengths, or of
effector positions through inverse kinematics) under every payload of a list, with any
effects, and returns an :class:`xarray.Dataset` with named dimensions, coordinates and units::

    >>> import eodarm, eodarm.datasets, numpy as np
    >>> arm = eodarm.datasets.load("seed2022").arm                       # doctest: +SKIP
    >>> ds = eodarm.sweep(arm, alpha_deg={"alpha1": np.linspace(40, 130, 46),
    ...                                   "alpha2": np.linspace(-20, 40, 31),
    ...                                   "alpha3": np.linspace(-20, 20, 21)},
    ...                   mass_kg=[1.5, 5.0, 6.5])                       # doctest: +SKIP
    >>> ds.dy_mm.sel(alpha1=90, alpha2=10, alpha3=0, mass_kg=5.0)        # doctest: +SKIP

A local sweep of an angle grid is one call of the compiled core (``eodarm._core.sweep`` with
``grid=``): the core makes each chunk's poses from the grid's axes, solves, masks and reduces
them in parallel and writes straight into the result arrays. Other grids (lengths, effector
targets), the finite-element model and Dask schedulers walk the grid in chunks of
``chunk_size`` poses from Python; each chunk's poses are made from the flat pose index, solved
by the compiled core (the FE model by :func:`_sweep_fallback`) and, for a reduced sweep,
reduced at once. Either way nothing of the grid's size is built for a reduced sweep, so memory
stays bounded by the chunk and the reduced output. The layout, the mask and the reductions
are described in ``docs/sweeps.md``.

Command line (registered by :func:`add_parser`)::

    eodarm sweep [--arm ARM.toml] [--alpha1 LO:HI:N ...] [--mass 1.5,5,6.5]
                 [--add EFFECT@PLACE=VALUE ...] [--reduce max:mass_kg] [-o OUT.nc | OUT.zarr]
                 [--plot DIR] [--threads K] [--no-progress]
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import time
import uuid
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from .arm import Arm
from .effects import Effect, as_effects, effect_arrays
from .errors import EodarmError, InputError
from .solver import _core_arm, forward, stroke_violations

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "CELL_VARS",
    "REDUCE_OPS",
    "add_parser",
    "cmd_sweep",
    "grid_of",
    "parse_range",
    "sweep",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: The reductions of a sweep (per cell, NaN ignored).
REDUCE_OPS = ("max", "min", "argmax", "argmin")
#: Outputs per (pose, payload) cell, reduced by a reduction.
CELL_VARS = ("force_n", "dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "ok")
#: Outputs per pose (no payload dimension).
POSE_VARS = ("reachable", "length_mm", "effector_x_mm", "effector_y_mm")
#: Default number of poses per chunk.
CHUNK_SIZE = 2**16
#: A progress bar shows at once for more chunks than this, else after 2 s.
PROGRESS_CHUNKS = 50

_ATTRS: dict[str, dict[str, str]] = {
    "force_n": {"units": "N", "long_name": "loaded actuator force (compression positive)"},
    "dx_mm": {"units": "mm", "long_name": "horizontal displacement of the measure point"},
    "dy_mm": {
        "units": "mm",
        "long_name": "vertical displacement of the measure point (sag is negative)",
    },
    "dalpha_deg": {"units": "deg", "long_name": "change of the absolute link angle"},
    "dl_mm": {
        "units": "mm",
        "long_name": "change of actuator body length as its sensor sees it",
    },
    "ok": {
        "long_name": "solved: the pose exists, is not singular and the loaded pose closes",
    },
    "reachable": {
        "long_name": "pose exists, is not singular and every actuator is within its stroke",
    },
    "length_mm": {"units": "mm", "long_name": "unloaded pin-to-pin actuator length"},
    "effector_x_mm": {"units": "mm", "long_name": "x of the unloaded load point (global)"},
    "effector_y_mm": {"units": "mm", "long_name": "y of the unloaded load point (global)"},
    "alpha_deg": {"units": "deg", "long_name": "unloaded absolute link angle of the pose"},
}


# ---------------------------------------------------------------------------- the kernel
def _sweep_fallback(
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
    (:func:`eodarm.fem.fem_solve_payload`, ``effects`` given as Effect values).

    Kept as the definition the fast core is tested against, and the kernel of FE sweeps.
    ``threads`` is ignored here (``_core.solve`` uses rayon's global pool).

    Parameters
    ----------
    arm : the arm (the core takes its compiled ``CoreArm``).
    alpha_deg : (N, n) unloaded angles of N poses, degrees, C-contiguous float64.
    mass_kg : (M,) payload masses, kg. Cell (p, j) carries (0, −mass_kg[j]·g) at the load
        point; its flat row is ``r = p·M + j``.
    codes, places, values : the effects (:func:`eodarm.effects.effect_arrays`).
    self_weight : include link and actuator weights in both states.
    reduce : None, or ``"max"``, ``"min"``, ``"argmax"``, ``"argmin"`` over consecutive groups
        of ``group`` rows of the flat row index, NaN ignored.

    Returns
    -------
    dict: ``force_n`` (N, M, n), ``dx_mm``, ``dy_mm`` (N, M), ``dalpha_deg``, ``dl_mm``
    (N, M, n), ``ok`` (N, M) (False, and NaN values, where the pose is singular or the loaded
    triangle cannot close); reduced, these have leading shape (N·M/group,), argmax/argmin as
    int64 (−1 where the whole group is NaN) and ``ok`` as "any". Per pose, never reduced:
    ``length_mm`` (N, n) unloaded pin-to-pin, ``reachable`` (N,) (not singular and every
    length within [min_length_mm, max_length_mm]), ``effector_x_mm``, ``effector_y_mm`` (N,)
    the unloaded load point.
    """
    from . import _core

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
        from . import fem

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
        out = _core.solve(
            core,
            np.repeat(alpha, m, axis=0),
            payload,
            codes,
            places,
            values,
            self_weight,
            nan_on_failure=True,
        )
    ok = np.isfinite(out["dy_mm"])
    cells: dict[str, npt.NDArray[Any]] = {
        "force_n": out["force_n"],
        "dx_mm": out["dx_mm"],
        "dy_mm": out["dy_mm"],
        "dalpha_deg": out["dalpha_deg"],
        "dl_mm": out["dl_mm"],
    }
    res: dict[str, npt.NDArray[Any]] = {}
    if reduce is None:
        for key, val in cells.items():
            res[key] = val.reshape(n_pose, m, *val.shape[1:])
        res["ok"] = ok.reshape(n_pose, m)
    else:
        for key, val in cells.items():
            res[key] = _reduce_rows(val, reduce, group)
        res["ok"] = np.asarray(ok.reshape(rows // group, group).any(axis=1))
    geo = _core.forward(core, alpha)
    length = geo["length_mm"]
    in_stroke = (stroke_violations(arm, length) == 0).all(axis=1)
    res["length_mm"] = length
    res["reachable"] = ~_singular(geo, n) & in_stroke
    res["effector_x_mm"] = np.ascontiguousarray(geo["O"][:, n, 0])
    res["effector_y_mm"] = np.ascontiguousarray(geo["O"][:, n, 1])
    return res


def _reduce_rows(x: npt.NDArray[Any], op: str, group: int) -> npt.NDArray[Any]:
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


def _singular(geo: Mapping[str, FloatArray], n: int) -> BoolArray:
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


def _kernel(
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
    """One chunk through the compiled core, or through :func:`_sweep_fallback` for the
    finite-element model."""
    from . import _core

    if model == "fem":
        return _sweep_fallback(
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
def _placeholder(arm: Arm) -> FloatArray:
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
    if not _singular(geo, arm.n)[0]:  # pragma: no cover - exact collinearity by construction
        raise EodarmError("internal: the placeholder pose is not singular")
    return pose


# ---------------------------------------------------------------------------- the grid
@dataclass(frozen=True)
class _Grid:
    """A grid of poses: its kind, dimension names (in order), coordinates and how to pose it."""

    kind: str  # "alpha", "lengths" or "effector"
    names: tuple[str, ...]
    coords: tuple[FloatArray, ...]
    columns: tuple[int, ...]  # the column of each dim in alpha / lengths / (x, y, phi)
    ref: FloatArray | None = None  # reference pose of a lengths grid
    elbow: int = -1

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(c.shape[0] for c in self.coords)

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    def values(self, start: int, stop: int) -> FloatArray:
        """The grid values (stop − start, len(names)) of flat poses [start, stop), in columns."""
        idx = np.unravel_index(np.arange(start, stop), self.shape)
        out = np.empty((stop - start, len(self.names)))
        for col, coord, ix in zip(self.columns, self.coords, idx, strict=True):
            out[:, col] = coord[ix]
        return out

    def poses(self, arm: Arm, start: int, stop: int) -> tuple[FloatArray, BoolArray | None]:
        """Angles (k, n) of the flat poses [start, stop) and which exist (None: all exist).

        Poses that do not exist (a lengths grid's triangle that cannot close, an effector
        target out of reach) have NaN angles.
        """
        vals = self.values(start, stop)
        if self.kind == "alpha":
            return vals, None
        if self.kind == "lengths":
            assert self.ref is not None
            alpha, exists = _angles_from_lengths_masked(arm, vals, self.ref)
            return alpha, exists
        # The core's inverse kinematics alone: the sweep computes the lengths itself.
        from . import _core

        alpha, ok = _core.inverse_kinematics(_core_arm(arm), vals, float(self.elbow))
        return np.ascontiguousarray(alpha), np.asarray(ok, dtype=bool)


def _coord_attrs(kind: str, name: str) -> dict[str, str]:
    if kind == "alpha":
        return {"units": "deg", "long_name": f"unloaded absolute angle of link {name[5:]}"}
    if kind == "lengths":
        return {"units": "mm", "long_name": f"unloaded pin-to-pin length of actuator {name[1:]}"}
    return {
        "x": {"units": "mm", "long_name": "x of the load point (global)"},
        "y": {"units": "mm", "long_name": "y of the load point (global)"},
        "phi": {"units": "deg", "long_name": "absolute angle of the last link"},
    }[name]


def _axis(values: Any, name: str, positive: bool = False) -> FloatArray:
    try:
        a = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"sweep: grid '{name}' cannot be read as numbers") from None
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1:
        raise InputError(f"sweep: grid '{name}' must be 1-D, got shape {a.shape}")
    if a.size == 0:
        raise InputError(f"sweep: grid '{name}' is empty")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise InputError(f"sweep: grid '{name}' has a non-finite value at index {bad[0]}")
    if positive and (a <= 0).any():
        raise InputError(f"sweep: grid '{name}' must be > 0 (actuator lengths, mm)")
    return np.ascontiguousarray(a)


def _make_grid(
    arm: Arm,
    alpha_deg: Mapping[str, Any] | None,
    lengths: Mapping[str, Any] | None,
    effector: Mapping[str, Any] | None,
    alpha_ref_deg: npt.ArrayLike | None,
    elbow: int,
) -> _Grid:
    given = [
        (k, g)
        for k, g in (("alpha", alpha_deg), ("lengths", lengths), ("effector", effector))
        if g is not None
    ]
    if len(given) != 1:
        raise InputError(
            "sweep: give exactly one grid: alpha_deg=, lengths= or effector= "
            "(a dict of 1-D coordinate arrays)"
        )
    kind, grid = given[0]
    if not isinstance(grid, Mapping):
        raise InputError(f"sweep: the {kind} grid must be a dict of 1-D arrays, got {grid!r}")
    n = arm.n
    if kind == "alpha":
        want = [f"alpha{i + 1}" for i in range(n)]
    elif kind == "lengths":
        want = [f"l{i + 1}" for i in range(n)]
    else:
        if n != 3:
            raise InputError(f"sweep: an effector grid needs a 3-link arm, this one has {n}")
        if elbow not in (-1, 1):
            raise InputError(f"sweep: elbow must be -1 or +1, got {elbow!r}")
        want = ["x", "y", "phi"]
    names = [str(k) for k in grid]
    unknown = [k for k in names if k not in want]
    if unknown:
        raise InputError(
            f"sweep: unknown {kind} grid name '{unknown[0]}'; the names are {', '.join(want)}"
        )
    missing = [k for k in want if k not in names]
    if missing:
        raise InputError(
            f"sweep: the {kind} grid misses '{missing[0]}'; give every one of {', '.join(want)} "
            "(a single value for a fixed one)"
        )
    coords = tuple(_axis(grid[k], k, positive=kind == "lengths") for k in names)
    columns = tuple(want.index(k) for k in names)
    ref = None
    if kind == "lengths":
        r = _default_ref(n) if alpha_ref_deg is None else alpha_ref_deg
        ref = np.asarray(r, dtype=float).reshape(-1)
        if ref.shape != (n,) or not np.isfinite(ref).all():
            raise InputError(f"sweep: alpha_ref_deg must be {n} finite angles, got {r!r}")
    return _Grid(kind, tuple(names), coords, columns, ref, elbow)


def _default_ref(n: int) -> FloatArray:
    """The reference pose of a lengths grid: 90°, 10°, …, 0° (the CLI's default pose)."""
    return np.array([90.0] + [10.0] * max(n - 2, 0) + ([0.0] if n >= 2 else []))


def _angles_from_lengths_masked(
    arm: Arm, length: FloatArray, ref_deg: FloatArray
) -> tuple[FloatArray, BoolArray]:
    """Angles (k, n) of the rigid arm with these actuator lengths, NaN where it cannot close.

    The core closes each triangle from the base (model §6) on the side of the reference pose,
    in parallel, and marks the rows that cannot close with NaN (``nan_on_failure``).
    """
    from . import _core

    out = _core.angles_from_lengths(
        _core_arm(arm),
        np.ascontiguousarray(length, dtype=float),
        np.ascontiguousarray(ref_deg, dtype=float).reshape(1, -1),
        nan_on_failure=True,
    )
    exists = np.asarray(~np.isnan(out).any(axis=1), dtype=bool)
    return out, exists


# ---------------------------------------------------------------------------- one chunk
@dataclass(frozen=True)
class _Job:
    """Everything a chunk needs; picklable, so it can travel to a Dask worker."""

    arm: Arm
    grid: _Grid
    mass: FloatArray
    effects: tuple[Effect, ...]
    self_weight: bool
    op: str | None
    block: int  # poses per reduction group (1 unless an angle is reduced)
    mask_unreachable: bool
    threads: int | None
    model: str = "analytic"
    fem_options: tuple[tuple[str, Any], ...] | None = None  # hashable, like the rest


def _chunk(job: _Job, start: int, stop: int) -> dict[str, npt.NDArray[Any]]:
    """Solve flat poses [start, stop) of the grid (a whole number of reduction blocks)."""
    arm, n = job.arm, job.arm.n
    alpha, exists = job.grid.poses(arm, start, stop)
    keep = np.ones(stop - start, dtype=bool) if exists is None else exists.copy()
    geo_len: FloatArray | None = None
    geo_eff: FloatArray | None = None
    if job.mask_unreachable:
        run = np.where(keep[:, None], alpha, _placeholder(arm))
        geo = forward(arm, run)
        geo_len, geo_eff = geo["length_mm"], geo["O"][:, n]
        keep &= (stroke_violations(arm, geo_len) == 0).all(axis=1) & ~_singular(geo, n)
    pose_alpha = alpha  # the poses themselves (NaN where none), before any placeholder
    if not keep.all():
        alpha = np.where(keep[:, None], alpha, _placeholder(arm))
    codes, places, values = effect_arrays(job.effects, n)
    m = job.mass.shape[0]
    out = _kernel(
        arm,
        np.ascontiguousarray(alpha, dtype=float),
        job.mass,
        codes,
        places,
        values,
        job.self_weight,
        job.op,
        m * job.block if job.op else 1,
        job.threads,
        job.model,
        dict(job.fem_options) if job.fem_options is not None else None,
        job.effects,
    )
    res = {k: np.asarray(out[k]) for k in CELL_VARS}
    length = np.array(out["length_mm"], dtype=float)
    ex = np.array(out["effector_x_mm"], dtype=float)
    ey = np.array(out["effector_y_mm"], dtype=float)
    reach = np.array(out["reachable"], dtype=bool)
    if geo_len is not None and geo_eff is not None:  # masked poses that exist: their geometry
        put = ~keep if exists is None else exists & ~keep
        length[put], ex[put], ey[put] = geo_len[put], geo_eff[put, 0], geo_eff[put, 1]
        reach[put] = False
    if exists is not None:
        length[~exists], ex[~exists], ey[~exists] = np.nan, np.nan, np.nan
        reach[~exists] = False
    if job.block > 1:
        res["reachable"] = np.asarray(reach.reshape(-1, job.block).any(axis=1))
    else:
        res["reachable"] = reach
        res["length_mm"], res["effector_x_mm"], res["effector_y_mm"] = length, ex, ey
        if job.grid.kind != "alpha":
            res["alpha_deg"] = np.asarray(pose_alpha, dtype=float)
    return res


# ---------------------------------------------------------------------------- the sweep
def _masses(mass_kg: npt.ArrayLike) -> FloatArray:
    try:
        m = np.asarray(mass_kg, dtype=float)
    except (TypeError, ValueError):
        raise InputError("sweep: mass_kg cannot be read as numbers") from None
    if m.ndim == 0:
        m = m.reshape(1)
    if m.ndim != 1 or m.size == 0:
        raise InputError(f"sweep: mass_kg must be a non-empty 1-D list of masses, got {m.shape}")
    bad = np.flatnonzero(~np.isfinite(m) | (m < 0))
    if bad.size:
        raise InputError(f"sweep: mass_kg[{bad[0]}] = {m[bad[0]]} must be finite and >= 0")
    return np.ascontiguousarray(m)


def _plan(grid: _Grid, reduce: Mapping[str, Any] | None) -> tuple[str | None, list[str], int]:
    """(op, reduced dims, poses per reduction block) of a reduce spec."""
    if reduce is None:
        return None, [], 1
    if not isinstance(reduce, Mapping) or set(reduce) - {"op", "dims"}:
        raise InputError(
            "sweep: reduce must be a dict {'op': 'max'|'min'|'argmax'|'argmin', 'dims': [...]}"
        )
    op = reduce.get("op")
    if op not in REDUCE_OPS:
        raise InputError(f"sweep: reduce op {op!r} is not one of {', '.join(REDUCE_OPS)}")
    dims_raw = reduce.get("dims", ["mass_kg"])
    dims = [dims_raw] if isinstance(dims_raw, str) else [str(d) for d in dims_raw]
    all_dims = [*grid.names, "mass_kg"]
    for d in dims:
        if d not in all_dims:
            raise InputError(
                f"sweep: reduce over unknown dimension '{d}'; the dimensions are "
                f"{', '.join(all_dims)}"
            )
    if not dims or len(set(dims)) != len(dims):
        raise InputError(f"sweep: reduce dims must be distinct and non-empty, got {dims}")
    suffix = all_dims[len(all_dims) - len(dims) :]
    if set(dims) != set(suffix):
        inner = next(d for d in dims if d not in suffix)
        raise InputError(
            f"sweep: cannot reduce over '{inner}': reduced dimensions must be the innermost of "
            f"({', '.join(all_dims)}), e.g. ['mass_kg'] or ['{grid.names[-1]}', 'mass_kg']; "
            "order the grid dict so that the reduced angles come last"
        )
    block = math.prod(grid.shape[len(grid.names) - (len(dims) - 1) :])
    return str(op), suffix, block


def sweep(
    arm: Arm,
    *,
    alpha_deg: Mapping[str, npt.ArrayLike] | None = None,
    lengths: Mapping[str, npt.ArrayLike] | None = None,
    effector: Mapping[str, npt.ArrayLike] | None = None,
    mass_kg: npt.ArrayLike,
    effects: Effect | Iterable[Effect] | None = (),
    self_weight: bool = True,
    reduce: Mapping[str, Any] | None = None,
    chunk_size: int = CHUNK_SIZE,
    progress: bool | None = None,
    scheduler: Any = None,
    threads: int | None = None,
    alpha_ref_deg: npt.ArrayLike | None = None,
    elbow: int = -1,
    mask_unreachable: bool = False,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """Solve every pose of a grid under every payload, in chunks; an xarray Dataset.

    Parameters
    ----------
    arm : the arm.
    alpha_deg : a grid of unloaded absolute angles: ``{"alpha1": [...], …, "alphaN": [...]}``
        (degrees; 1-D arrays, a scalar for a fixed angle). The dict's order is the order of
        the dimensions (the last varies fastest).
    lengths : or a grid of unloaded pin-to-pin actuator lengths ``{"l1": …, "lN": …}`` (mm),
        turned into angles by :func:`eodarm.angles_from_lengths` on the side of
        ``alpha_ref_deg`` (default 90°, 10°, …, 0°). Lengths with which the arm cannot be
        assembled give cells that are not ok and not reachable; out-of-stroke lengths give
        poses that are not reachable.
    effector : or a grid of load-point targets ``{"x": mm, "y": mm, "phi": deg}`` (the last
        link's absolute angle), through :func:`eodarm.inverse_kinematics` with ``elbow``
        (3-link arms). Targets out of reach are not ok and not reachable.
    mass_kg : payload masses, kg (1-D); each pose is solved under each.
    effects : effects added to the baseline model (CONTRACT §4).
    self_weight : include link and actuator weights in both states.
    reduce : ``{"op": "max"|"min"|"argmax"|"argmin", "dims": [...]}``: reduce the per-cell
        outputs over the innermost dims (``["mass_kg"]``, or ``["alpha3", "mass_kg"]`` …),
        ignoring cells that are not ok. arg-reductions give int64 indices into the reduced
        dims in C order (``np.unravel_index``), −1 where no cell is ok. The reduced dims'
        coordinates are kept in ``attrs["reduced_<dim>"]``. Per-pose outputs other than
        ``reachable`` (which becomes "any pose of the group") are dropped when an angle is
        reduced.
    chunk_size : poses per chunk (rounded up to whole reduction groups). Memory of a reduced
        sweep is bounded by the chunk and the reduced output. A local angle-grid sweep runs
        in the core's own chunks (about 16 384 cells) unless this is given.
    progress : show a progress bar on stderr: None (auto: at once for more than 50 chunks, or
        more than 50 × 65 536 poses for a local angle grid; else after 2 s), True or False.
    scheduler : None (run here), a ``distributed.Client`` (chunks are submitted to its cluster
        and gathered as they finish) or any Dask scheduler name/callable for
        ``dask.compute`` (``"threads"``, ``"processes"``, ``"synchronous"``).
    threads : threads of the compiled core per chunk (None: its default).
    alpha_ref_deg, elbow : the branch of a lengths grid, of an effector grid.
    mask_unreachable : treat cells of unreachable poses (out of stroke) as not ok: NaN, and
        skipped by reductions.
    model : ``"analytic"`` (the exact-pose model of docs/model.md, the fast core) or
        ``"fem"`` (the frame finite-element model of docs/fem.md, solved cell by cell; linear,
        so it agrees with the analytic model to first order in the load).
    fem_options : with ``model="fem"``, e.g. ``{"elements_per_link": 8}``.

    Returns
    -------
    xarray.Dataset
        dims (grid dims…, ``mass_kg``[, ``actuator`` | ``link``]) minus reduced ones, with
        ``force_n``, ``dx_mm``, ``dy_mm``, ``dalpha_deg`` (…, link), ``dl_mm`` (…, actuator),
        ``ok`` per cell; ``reachable``, ``length_mm`` (…, actuator), ``effector_x_mm``,
        ``effector_y_mm`` (and ``alpha_deg`` for lengths and effector grids) per pose. Every
        variable and coordinate has ``units`` and ``long_name`` attrs; the dataset's attrs
        name the arm (and carry its TOML), the model, self-weight, the grid kind and the
        reduction.

    Raises
    ------
    ValueError
        (:class:`~eodarm.errors.InputError`) with one line naming the problem: no or several
        grids, an unknown or missing grid name, an empty or non-finite grid, a bad mass,
        an unknown reduce dimension or one that is not innermost.
    KeyboardInterrupt
        On Ctrl-C, between chunks; nothing is returned.
    """
    import xarray as xr

    if not isinstance(arm, Arm):
        raise InputError(f"sweep: arm must be an eodarm.Arm, got {type(arm).__name__}")
    grid = _make_grid(arm, alpha_deg, lengths, effector, alpha_ref_deg, elbow)
    mass = _masses(mass_kg)
    effs = tuple(as_effects(effects))
    effect_arrays(effs, arm.n)  # validates places and duplicates now
    op, rdims, block = _plan(grid, reduce)
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, (int, np.integer)):
        raise InputError(f"sweep: chunk_size must be an integer, got {chunk_size!r}")
    if chunk_size < 1:
        raise InputError(f"sweep: chunk_size must be >= 1, got {chunk_size}")
    if threads is not None and (
        isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1
    ):
        raise InputError(f"sweep: threads must be an integer >= 1, got {threads!r}")
    n, m, size = arm.n, mass.shape[0], grid.size
    step = block * max(1, int(chunk_size) // block)
    spans = [(s, min(s + step, size)) for s in range(0, size, step)]
    from .fem import check_model

    check_model(model)
    job = _Job(
        arm,
        grid,
        mass,
        effs,
        bool(self_weight),
        op,
        block,
        mask_unreachable,
        threads,
        model,
        tuple(sorted(fem_options.items())) if fem_options is not None else None,
    )

    out_poses = size // block  # poses (or reduction groups) in the output
    shapes: dict[str, tuple[int, ...]] = {}
    for key in CELL_VARS:
        per = (n,) if key in ("force_n", "dalpha_deg", "dl_mm") else ()
        shapes[key] = (out_poses, *per) if op else (out_poses, m, *per)
    shapes["reachable"] = (out_poses,)
    if block == 1:
        shapes.update(length_mm=(size, n), effector_x_mm=(size,), effector_y_mm=(size,))
        if grid.kind != "alpha":
            shapes["alpha_deg"] = (size, n)
    arg = op in ("argmax", "argmin")
    dtypes = {
        key: (
            np.bool_
            if key in ("ok", "reachable")
            else np.int64
            if arg and key in CELL_VARS
            else np.float64
        )
        for key in shapes
    }
    result = _allocate(shapes, dtypes)

    def place(span: tuple[int, int], res: Mapping[str, npt.NDArray[Any]]) -> None:
        a, b = span[0] // block, span[1] // block
        for key, arr in result.items():
            arr[a:b] = res[key]

    if scheduler is None and model == "analytic" and grid.kind == "alpha":
        # One call: the core walks the grid itself, in parallel, straight into `result`.
        _sweep_grid(job, result, None if chunk_size == CHUNK_SIZE else step, progress)
    else:
        bar = _progress_bar(len(spans), progress)
        try:
            for span, res in _run(job, spans, scheduler):
                place(span, res)
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()

    # --------------------------------------------------------------- the Dataset
    kept = list(grid.names[: len(grid.names) - (len(rdims) - 1)] if op else grid.names)
    kept_shape = [grid.shape[grid.names.index(d)] for d in kept]
    cell_dims = kept if op else [*kept, "mass_kg"]
    cell_shape = kept_shape if op else [*kept_shape, m]
    pose_dims = kept if block > 1 else list(grid.names)
    coords: dict[str, Any] = {
        name: (name, c, _coord_attrs(grid.kind, name))
        for name, c in zip(grid.names, grid.coords, strict=True)
        if name in kept
    }
    if not op:
        coords["mass_kg"] = ("mass_kg", mass, {"units": "kg", "long_name": "payload mass"})
    coords["actuator"] = ("actuator", np.arange(1, n + 1), {"long_name": "actuator number"})
    coords["link"] = ("link", np.arange(1, n + 1), {"long_name": "link number"})
    variables: dict[str, Any] = {}
    over = ", ".join(rdims)
    for key, arr in result.items():
        inner = ["actuator"] if key in ("force_n", "dl_mm", "length_mm") else []
        inner = ["link"] if key in ("dalpha_deg", "alpha_deg") else inner
        if key in CELL_VARS:
            dims, shape = [*cell_dims, *inner], [*cell_shape, *([n] if inner else [])]
        else:
            dims = [*pose_dims, *inner]
            shape = [*(grid.shape if block == 1 else kept_shape), *([n] if inner else [])]
        vattrs = dict(_ATTRS[key])
        if op and key in CELL_VARS:
            if key == "ok":
                vattrs["long_name"] = f"some cell over ({over}) is solved"
            elif arg:
                vattrs = {
                    "units": "1",
                    "long_name": f"{op} of {key} over ({over}): flat index in C order, "
                    "-1 where no cell is solved",
                }
            else:
                vattrs["long_name"] = f"{op} over ({over}) of the {vattrs['long_name']}"
        if key == "reachable" and block > 1:
            vattrs["long_name"] = f"some pose over ({', '.join(rdims[:-1])}) is reachable"
        variables[key] = (dims, arr.reshape(shape), vattrs)
    model = " + ".join(["baseline", *(f"{e.key}={e.value:g}" for e in effs)])
    attrs: dict[str, Any] = {
        "title": f"eodarm sweep of arm '{arm.name}'",
        "arm": arm.name,
        "arm_toml": arm.to_toml(),
        "model": model,
        "effects": " ".join(e.key for e in effs),
        "self_weight": int(bool(self_weight)),
        "mask_unreachable": int(bool(mask_unreachable)),
        "grid": grid.kind,
        "g": arm.g,
        "reduce": f"{op} over {over}" if op else "none",
        "Conventions": "eodarm CONTRACT: mm, N, kg, deg; y up; force compression positive",
    }
    if grid.kind == "lengths":
        assert grid.ref is not None
        attrs["alpha_ref_deg"] = grid.ref
    if grid.kind == "effector":
        attrs["elbow"] = grid.elbow
    for d in rdims:
        attrs[f"reduced_{d}"] = mass if d == "mass_kg" else grid.coords[grid.names.index(d)]
    return xr.Dataset(variables, coords=coords, attrs=attrs)


# ---------------------------------------------------------------------------- running
def _allocate(
    shapes: Mapping[str, tuple[int, ...]], dtypes: Mapping[str, Any]
) -> dict[str, npt.NDArray[Any]]:
    """Uninitialised result arrays, those of one dtype as views of one buffer.

    One large allocation instead of ten: numpy asks the kernel for transparent huge pages
    for it, and only its two ends fall on ordinary pages. Ten separate arrays, none aligned
    to 2 MB, leave tens of MB on 4 kB pages, whose page faults cost a sweep of 10⁶ poses
    with all outputs about a quarter of its time (docs/benchmarks.md).
    """
    out: dict[str, npt.NDArray[Any]] = {}
    for dtype in dict.fromkeys(dtypes.values()):
        keys = [k for k in shapes if dtypes[k] == dtype]
        sizes = [math.prod(shapes[k]) for k in keys]
        buf = np.empty(sum(sizes), dtype=dtype)
        at = 0
        for key, size in zip(keys, sizes, strict=True):
            out[key] = buf[at : at + size].reshape(shapes[key])
            at += size
    return {k: out[k] for k in shapes}


def _sweep_grid(
    job: _Job,
    result: dict[str, npt.NDArray[Any]],
    chunk_poses: int | None,
    progress: bool | None,
) -> None:
    """Sweep a whole angle grid in one call of the compiled core, into ``result``.

    The core makes each chunk's poses from the grid's axes, solves and (if asked) masks and
    reduces them, and writes straight into the result arrays (a reduction's ``reachable`` as
    "any pose of the group"); it checks for Ctrl-C and reports progress between chunks.
    """
    from . import _core

    arm, grid, m = job.arm, job.grid, job.mass.shape[0]
    codes, places, values = effect_arrays(job.effects, arm.n)
    axes = [np.ascontiguousarray(c, dtype=float) for c in grid.coords]
    size = grid.size
    bar = _progress_bar(size, progress, unit="pose", auto_at=PROGRESS_CHUNKS * CHUNK_SIZE)

    def report(done: int) -> None:
        bar.update(done - bar.n)

    try:
        _core.sweep(
            _core_arm(arm),
            None,
            job.mass,
            codes,
            places,
            values,
            job.self_weight,
            job.op,
            m * job.block if job.op else 1,
            job.threads,
            grid=(axes, list(grid.columns), 0, size),
            out=result,
            mask_unreachable=job.mask_unreachable,
            progress=report if bar is not None else None,
            chunk_rows=None if chunk_poses is None else chunk_poses * m,
        )
        if bar is not None:
            bar.update(size - bar.n)
    finally:
        if bar is not None:
            bar.close()


def _run(
    job: _Job, spans: list[tuple[int, int]], scheduler: Any
) -> Iterator[tuple[tuple[int, int], dict[str, npt.NDArray[Any]]]]:
    """Yield (span, chunk result) for every span, here or on a Dask scheduler."""
    if scheduler is None:
        for span in spans:
            yield span, _chunk(job, *span)
        return
    if hasattr(scheduler, "submit") and hasattr(scheduler, "scatter"):  # distributed.Client
        from distributed import as_completed

        client = scheduler
        [remote_job] = client.scatter([job], broadcast=True)
        tag = uuid.uuid4().hex  # task keys unique to this sweep
        futures = {
            client.submit(_chunk, remote_job, a, b, pure=False, key=f"eodarm-sweep-{tag}-{a}"): (
                a,
                b,
            )
            for a, b in spans
        }
        try:
            for fut, res in as_completed(list(futures), with_results=True):
                yield futures[fut], res
                fut.release()
        finally:
            client.cancel(list(futures))
        return
    import dask

    wave = 64
    for i in range(0, len(spans), wave):
        part = spans[i : i + wave]
        tasks = [dask.delayed(_chunk, pure=False)(job, a, b) for a, b in part]
        results = dask.compute(*tasks, scheduler=scheduler)
        yield from zip(part, results, strict=True)


def _progress_bar(
    total: int, progress: bool | None, unit: str = "chunk", auto_at: int = PROGRESS_CHUNKS
) -> Any:
    """A tqdm bar on stderr over ``total`` units: shown at once when asked or when ``total``
    exceeds ``auto_at``, after 2 s when ``progress`` is None, never when it is False."""
    if progress is False or (progress is None and total <= 1):
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is a dependency
        return None
    delay = 0.0 if progress or total > auto_at else 2.0
    return tqdm(
        total=total,
        desc="eodarm sweep",
        unit=unit,
        unit_scale=unit == "pose",
        file=sys.stderr,
        delay=delay,
        leave=False,
    )


# ---------------------------------------------------------------------------- helpers
def grid_of(ds: xr.Dataset) -> dict[str, Any]:
    """The :func:`sweep` keyword arguments of the grid a Dataset was made from.

    ``{"alpha_deg": {...}}``, ``{"lengths": {...}, "alpha_ref_deg": ...}`` or
    ``{"effector": {...}, "elbow": ...}``, with the grid dims in their order.

    Raises
    ------
    EodarmError
        If an angle of the grid was reduced (its coordinates are gone).
    """
    kind = ds.attrs.get("grid", "alpha")
    names = {"alpha": "alpha", "lengths": "l", "effector": ""}[kind]
    dims = [d for d in ds.dims if d not in ("mass_kg", "actuator", "link")]
    if kind == "effector":
        dims = [d for d in dims if d in ("x", "y", "phi")]
    else:
        dims = [d for d in dims if str(d).startswith(names)]
    reduced = [k[len("reduced_") :] for k in ds.attrs if k.startswith("reduced_")]
    if any(r != "mass_kg" for r in reduced):
        raise EodarmError(
            f"the sweep was reduced over {', '.join(reduced)}: its grid is not in the Dataset"
        )
    grid = {str(d): np.asarray(ds[d].values) for d in dims}
    key = {"alpha": "alpha_deg", "lengths": "lengths", "effector": "effector"}[kind]
    out: dict[str, Any] = {key: grid}
    if kind == "lengths":
        out["alpha_ref_deg"] = np.asarray(ds.attrs["alpha_ref_deg"], dtype=float)
    if kind == "effector":
        out["elbow"] = int(ds.attrs.get("elbow", -1))
    return out


def grid_kwargs(grid: Mapping[str, Any]) -> dict[str, Any]:
    """``{"alpha1": …}`` → ``{"alpha_deg": {…}}`` (or lengths / effector), by its names."""
    names = list(grid)
    if names and all(str(k).startswith("alpha") for k in names):
        return {"alpha_deg": dict(grid)}
    if names and all(str(k)[:1] == "l" and str(k)[1:].isdigit() for k in names):
        return {"lengths": dict(grid)}
    if set(names) == {"x", "y", "phi"}:
        return {"effector": dict(grid)}
    raise InputError(
        f"a grid's names are alpha1…alphaN, l1…lN, or x, y, phi; got {', '.join(map(str, names))}"
    )


def parse_range(text: str, what: str) -> FloatArray:
    """``LO:HI:N`` → N values from LO to HI; ``V`` → [V]; ``a,b,c`` → [a, b, c]."""
    t = text.strip()
    try:
        if ":" in t:
            parts = t.split(":")
            if len(parts) != 3:
                raise ValueError
            lo, hi, k = float(parts[0]), float(parts[1]), int(parts[2])
            if k < 1 or not (math.isfinite(lo) and math.isfinite(hi)):
                raise ValueError
            vals = np.linspace(lo, hi, k)
        else:
            vals = np.array([float(v) for v in t.replace(";", ",").split(",") if v.strip()])
    except ValueError:
        raise EodarmError(
            f"{what} '{text}': expected LO:HI:N (N values from LO to HI), one value, or a "
            "comma-separated list"
        ) from None
    if vals.size == 0 or not np.isfinite(vals).all():
        raise EodarmError(f"{what} '{text}': give finite numbers")
    return vals


#: The CLI's default angle grid (degrees): link 1, link 2, and every further link. It spans
#: the seed arm's measured configurations with a margin.
DEFAULT_ALPHA = ("40:130:46", "-20:40:31", "-20:20:21")
#: Force limit (N) assumed by the CLI's capacity map for actuators without ``max_force_n``.
ASSUMED_MAX_FORCE_N = 1000.0
_MAX_LINKS = 9


# ---------------------------------------------------------------------------- command line
def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``eodarm sweep`` on an argparse sub-parser collection."""
    p = subparsers.add_parser(
        "sweep",
        help="solve a whole grid of poses × payloads; write NetCDF/Zarr and the four maps",
        description="Sweep a grid of joint angles (--alphaK), actuator lengths (--lK) or "
        "effector positions (--x --y --phi) under payloads (--mass), write the result as "
        "NetCDF (.nc) or Zarr (.zarr) and, with --plot, the four maps: sag, actuator forces, "
        "payload capacity and the dominant effect. Without --arm: the bundled seed2022 arm; "
        "without a grid: alpha1 40:130:46, alpha2 -20:40:31, alpha3 -20:20:21 (degrees).",
    )
    # let "--alpha3 -20:20:21" read the range as a value, not as an option (argparse only
    # knows plain negative numbers); "--alpha3=-20:20:21" works regardless
    p._negative_number_matcher = re.compile(r"^-\d+$|^-\d*\.\d+$|^-[\d.]+(:[-\d.]+)+$|^-[\d.]+,")
    p.add_argument("--arm", metavar="ARM.toml", help="arm file (default: the bundled seed arm)")
    for k in range(1, _MAX_LINKS + 1):
        p.add_argument(
            f"--alpha{k}",
            metavar="LO:HI:N",
            help="grid of link K's absolute angle, degrees (LO:HI:N, a value or a list)"
            if k == 1
            else argparse.SUPPRESS,
        )
    for k in range(1, _MAX_LINKS + 1):
        p.add_argument(
            f"--l{k}",
            metavar="LO:HI:N",
            help="or a grid of actuator K's pin-to-pin length, mm" if k == 1 else argparse.SUPPRESS,
        )
    p.add_argument("--x", metavar="LO:HI:N", help="or an effector grid: load point x, mm")
    p.add_argument("--y", metavar="LO:HI:N", help="load point y, mm")
    p.add_argument("--phi", metavar="LO:HI:N", help="last link's absolute angle, degrees")
    p.add_argument("--elbow", type=int, choices=(-1, 1), default=-1, help="IK branch (-1)")
    p.add_argument(
        "--mass",
        default="1.5,5,6.5",
        metavar="M1,M2,...",
        help="payload masses, kg (default 1.5,5,6.5; also LO:HI:N)",
    )
    p.add_argument(
        "--add",
        action="append",
        metavar="EFFECT@PLACE=VALUE",
        help="add an effect to the model, e.g. mount_compliance@M2=580 (repeatable)",
    )
    p.add_argument(
        "--reduce",
        metavar="OP:DIM[,DIM]",
        help="reduce in the core, e.g. max:mass_kg or min:alpha3,mass_kg "
        "(OP: max, min, argmax, argmin)",
    )
    p.add_argument(
        "--mask-unreachable",
        action="store_true",
        help="treat out-of-stroke poses as not solved (NaN, skipped by --reduce)",
    )
    p.add_argument("--no-self-weight", action="store_true", help="drop link/actuator weights")
    p.add_argument("-o", "--output", metavar="OUT.nc|OUT.zarr", help="write the Dataset")
    p.add_argument("--plot", metavar="DIR", help="write the four maps as PNGs into DIR")
    p.add_argument(
        "--plot-prefix",
        default="",
        metavar="TEXT",
        help="prefix of the map file names (sag.png, forces.png, capacity.png, "
        "dominant_effect.png)",
    )
    p.add_argument(
        "--plot-mass",
        type=float,
        metavar="KG",
        help="payload of the sag, force and dominant-effect maps (default: the largest --mass)",
    )
    p.add_argument(
        "--max-force",
        type=float,
        default=ASSUMED_MAX_FORCE_N,
        metavar="N",
        help="force limit assumed for actuators without max_force_n in the capacity map "
        f"(default {ASSUMED_MAX_FORCE_N:g} N)",
    )
    p.add_argument(
        "--max-payload",
        type=float,
        default=100.0,
        metavar="KG",
        help="cap of the capacity map, kg (default 100)",
    )
    p.add_argument("--chunk-size", type=int, default=CHUNK_SIZE, help="poses per chunk")
    p.add_argument("--threads", type=int, metavar="K", help="threads of the core")
    p.add_argument(
        "--model",
        choices=("analytic", "fem"),
        default="analytic",
        help="the exact-pose analytic model (default) or the finite-element model",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="Dask scheduler address (tcp://host:8786) to run the chunks on (eodarm[dask])",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)
    return p


def _note(msg: str) -> None:
    print(f"eodarm: {msg}", file=sys.stderr)


def _cli_grid(args: argparse.Namespace, n: int) -> dict[str, Any]:
    alphas = {k: getattr(args, f"alpha{k}", None) for k in range(1, _MAX_LINKS + 1)}
    lens = {k: getattr(args, f"l{k}", None) for k in range(1, _MAX_LINKS + 1)}
    eff = {"x": args.x, "y": args.y, "phi": args.phi}
    kinds = [
        name
        for name, d in (("alpha", alphas), ("lengths", lens), ("effector", eff))
        if any(v is not None for v in d.values())
    ]
    if len(kinds) > 1:
        raise EodarmError("sweep: give one kind of grid: --alphaK, --lK, or --x --y --phi")
    for d, flag in ((alphas, "alpha"), (lens, "l")):
        beyond = [k for k, v in d.items() if v is not None and k > n]
        if beyond:
            raise EodarmError(f"--{flag}{beyond[0]}: the arm has only {n} links")
    if kinds == ["lengths"]:
        missing = [k for k in range(1, n + 1) if lens[k] is None]
        if missing:
            raise EodarmError(
                f"sweep: a lengths grid needs --l1 … --l{n} (missing --l{missing[0]})"
            )
        return {"lengths": {f"l{k}": parse_range(str(lens[k]), f"--l{k}") for k in range(1, n + 1)}}
    if kinds == ["effector"]:
        missing_e = [k for k, v in eff.items() if v is None]
        if missing_e:
            raise EodarmError(
                f"sweep: an effector grid needs --x, --y and --phi (missing --{missing_e[0]})"
            )
        return {
            "effector": {k: parse_range(v, f"--{k}") for k, v in eff.items() if v is not None},
            "elbow": args.elbow,
        }
    grid = {}
    for k in range(1, n + 1):
        text = alphas[k] or DEFAULT_ALPHA[min(k - 1, len(DEFAULT_ALPHA) - 1)]
        grid[f"alpha{k}"] = parse_range(text, f"--alpha{k}")
    return {"alpha_deg": grid}


def _cli_reduce(text: str | None) -> dict[str, Any] | None:
    if not text:
        return None
    op, sep, dims = text.partition(":")
    if not sep or op not in REDUCE_OPS or not dims.strip():
        raise EodarmError(
            f"--reduce '{text}': expected OP:DIM[,DIM] with OP one of {', '.join(REDUCE_OPS)}, "
            "e.g. max:mass_kg"
        )
    return {"op": op, "dims": [d.strip() for d in dims.split(",") if d.strip()]}


def _write(ds: xr.Dataset, path: str) -> None:
    p = Path(path)
    if p.suffix == ".zarr":
        try:
            import zarr  # noqa: F401
        except ImportError:
            raise EodarmError("writing Zarr needs the zarr package: pip install zarr") from None
        ds.to_zarr(p, mode="w", consolidated=False)
    elif p.suffix in (".nc", ".nc4", ".netcdf"):
        ds.to_netcdf(p, engine="scipy")
    else:
        raise EodarmError(f"-o '{path}': the file must end in .nc (NetCDF) or .zarr (Zarr)")


def cmd_sweep(args: argparse.Namespace) -> int:
    """Run ``eodarm sweep``: sweep, write the Dataset and the maps, summarise on stdout.

    Returns 0, or 130 when interrupted with Ctrl-C.

    Raises
    ------
    EodarmError
        With a one-line reason (the main CLI prints it and exits with status 2).
    """
    from .cli import _valued_effect  # late: cli imports the subcommands

    if args.arm is None:
        from . import datasets

        arm = datasets.load("seed2022").arm
        _note("no --arm: sweeping the bundled seed2022 arm")
    else:
        arm = Arm.from_toml(args.arm)
    grid = _cli_grid(args, arm.n)
    mass = parse_range(args.mass, "--mass")
    effects = [_valued_effect(s) for s in args.add or []]
    reduce = _cli_reduce(args.reduce)
    scheduler: Any = None
    client = None
    if args.scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise EodarmError("--scheduler needs Dask: pip install 'eodarm[dask]'") from None
        client = Client(args.scheduler)
        scheduler = client
    import xarray  # noqa: F401  (imported here so that the time below is the sweep's)

    t0 = time.perf_counter()
    try:
        ds = sweep(
            arm,
            **grid,
            mass_kg=mass,
            effects=effects,
            self_weight=not args.no_self_weight,
            reduce=reduce,
            chunk_size=args.chunk_size,
            progress=False if args.no_progress else None,
            scheduler=scheduler,
            model=args.model,
            threads=args.threads,
            mask_unreachable=args.mask_unreachable,
        )
    except KeyboardInterrupt:
        _note("interrupted: nothing written")
        return 130
    finally:
        if client is not None:
            client.close()
    dt = time.perf_counter() - t0
    size = math.prod(len(v) for v in next(v for v in grid.values() if isinstance(v, dict)).values())
    _note(
        f"swept {size:,} poses × {len(mass)} payloads in {dt:.2f} s "
        f"({size * len(mass) / max(dt, 1e-9):,.0f} cells/s, {args.model} model)"
    )
    _summary(ds)
    if args.output:
        _write(ds, args.output)
        _note(f"wrote {args.output}")
    if args.plot:
        from . import maps

        plot_mass = args.plot_mass if args.plot_mass is not None else float(np.max(mass))
        written = maps.render_all(
            arm,
            grid,
            effects,
            plot_mass,
            args.plot,
            self_weight=not args.no_self_weight,
            assumed_max_force_n=args.max_force,
            max_payload_kg=args.max_payload,
            ds=ds if reduce is None and plot_mass in mass else None,
            note=_note,
            prefix=args.plot_prefix,
        )
        _note("wrote " + ", ".join(str(w) for w in written))
    return 0


def _summary(ds: xr.Dataset) -> None:
    """A few lines on stdout: the sweep's shape, reachable share, extreme sag and forces."""
    dims = ", ".join(f"{d} {s}" for d, s in ds.sizes.items())
    print(f"arm '{ds.attrs['arm']}', model {ds.attrs['model']}, reduce: {ds.attrs['reduce']}")
    print(f"dimensions: {dims}")
    reach = float(ds["reachable"].mean())
    ok = float(ds["ok"].mean())
    print(f"reachable poses: {100 * reach:.1f} %   solved cells: {100 * ok:.1f} %")
    if ds.attrs["reduce"] == "none" or ds.attrs["reduce"].split()[0] in ("max", "min"):
        dy = ds["dy_mm"].where(ds["reachable"]).values
        dy = dy[np.isfinite(dy)]
        if dy.size:
            q = np.quantile(dy, [0.02, 0.5, 0.98])
            print(
                f"dy over reachable poses: {dy.min():.4g} … {dy.max():.4g} mm "
                f"(2 %, 50 %, 98 %: {q[0]:.4g}, {q[1]:.4g}, {q[2]:.4g} mm)"
            )
        f = abs(ds["force_n"].where(ds["reachable"]))
        for i in ds["actuator"].values:
            fi = f.sel(actuator=i)
            if bool(np.isfinite(fi).any()):
                print(f"|F{i}| up to {float(fi.max()):.4g} N")
