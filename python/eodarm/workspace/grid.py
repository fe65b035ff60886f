"""The grids a sweep walks: joint angles, actuator lengths or effector positions.

A :class:`Grid` knows its axes and makes the poses of any flat range of its cells, so that
no array of the grid's size is ever built; :func:`grid_of` reads a sweep's grid back from its
Dataset.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import EodarmError, InputError
from eodarm.model.arm import Arm
from eodarm.model.kinds import real_array
from eodarm.model.solver import _core_arm

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "Grid",
    "angles_from_lengths_masked",
    "coord_attrs",
    "default_ref",
    "grid_kwargs",
    "grid_of",
    "make_grid",
    "masses_axis",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


# ---------------------------------------------------------------------------- the grid
@dataclass(frozen=True)
class Grid:
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
            alpha, exists = angles_from_lengths_masked(arm, vals, self.ref)
            return alpha, exists
        # The core's inverse kinematics alone: the sweep computes the lengths itself.
        from eodarm.model import native as _core

        alpha, ok = _core.inverse_kinematics(_core_arm(arm), vals, float(self.elbow))
        return np.ascontiguousarray(alpha), np.asarray(ok, dtype=bool)


def coord_attrs(kind: str, name: str) -> dict[str, str]:
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
        a = np.asarray(real_array(values, f"sweep: grid '{name}'"), dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        if isinstance(exc, InputError):
            raise
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


def make_grid(
    arm: Arm,
    alpha_deg: Mapping[str, Any] | None,
    lengths: Mapping[str, Any] | None,
    effector: Mapping[str, Any] | None,
    alpha_ref_deg: npt.ArrayLike | None,
    elbow: int,
) -> Grid:
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
        r = default_ref(n) if alpha_ref_deg is None else alpha_ref_deg
        ref = np.asarray(r, dtype=float).reshape(-1)
        if ref.shape != (n,) or not np.isfinite(ref).all():
            raise InputError(f"sweep: alpha_ref_deg must be {n} finite angles, got {r!r}")
    return Grid(kind, tuple(names), coords, columns, ref, elbow)


def default_ref(n: int) -> FloatArray:
    """The reference pose of a lengths grid: 90°, 10°, …, 0° (the CLI's default pose)."""
    return np.array([90.0] + [10.0] * max(n - 2, 0) + ([0.0] if n >= 2 else []))


def angles_from_lengths_masked(
    arm: Arm, length: FloatArray, ref_deg: FloatArray
) -> tuple[FloatArray, BoolArray]:
    """Angles (k, n) of the rigid arm with these actuator lengths, NaN where it cannot close.

    The core closes each triangle from the base (model §6) on the side of the reference pose,
    in parallel, and marks the rows that cannot close with NaN (``nan_on_failure``).
    """
    from eodarm.model import native as _core

    out = _core.angles_from_lengths(
        _core_arm(arm),
        np.ascontiguousarray(length, dtype=float),
        np.ascontiguousarray(ref_deg, dtype=float).reshape(1, -1),
        nan_on_failure=True,
    )
    exists = np.asarray(~np.isnan(out).any(axis=1), dtype=bool)
    return out, exists


# ---------------------------------------------------------------------------- the sweep
def masses_axis(mass_kg: npt.ArrayLike) -> FloatArray:
    try:
        m = np.asarray(real_array(mass_kg, "sweep: mass_kg"), dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError("sweep: mass_kg cannot be read as numbers") from None
    if m.ndim == 0:
        m = m.reshape(1)
    if m.ndim != 1 or m.size == 0:
        raise InputError(f"sweep: mass_kg must be a non-empty 1-D list of masses, got {m.shape}")
    bad = np.flatnonzero(~np.isfinite(m) | (m < 0))
    if bad.size:
        raise InputError(f"sweep: mass_kg[{bad[0]}] = {m[bad[0]]} must be finite and >= 0")
    return np.ascontiguousarray(m)


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
