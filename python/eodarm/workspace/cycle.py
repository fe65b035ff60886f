"""What a load cycle leaves behind, per sweep cell (docs/model.md §9, docs/sweeps.md).

Each cell (pose, payload m) is the sequence reference → m → 0: the arm zeroed unloaded,
loaded with m, unloaded again. ``return_dx_mm``, ``return_dy_mm`` are the measure point at the
return relative to the reference: zero for an elastic arm, what the frictions hold (and where
the gaps sit after the payload pushed them) otherwise.

Four cases, from the cheapest:

* nothing holds anything and no gap can be left off-centre: the return is exactly zero;
* gaps without friction (catalogue effects only): nothing remembers the payload, so the
  return of every cell of a pose is that pose loaded with 0 kg, the gaps taken up along the
  self-weight's force. That is the plain sweep's answer at a payload of 0 kg (a single
  loading is a sequence of one state), so the grid is swept again by the compiled core at
  ``mass_kg = [0]`` and its (dx, dy) broadcast over the payloads;
* a friction (built-in effects only): every cell's cycle (m, 0) on the compiled core, which
  keeps only where it ends (:func:`eodarm.model.solver.cycle_returns`);
* a user-written effect: :func:`eodarm.solve_sequence` of each cell's states (m, 0), or of
  the single state (0) per pose when no friction is involved.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.model.effects import split_effects
from eodarm.workspace.chunk import _chunk, _core_grid_sweep, _Job

__all__ = ["CHUNK", "add_return", "worst_return"]

FloatArray = npt.NDArray[np.float64]

#: Sequences (or poses) per call of the core (bounds the temporary outputs: ~1 kB each).
CHUNK = 65_536
#: The effects that remember the payload after it came off.
FRICTIONS = frozenset({"actuator_friction", "joint_friction", "drive_friction"})
#: The effects that leave the arm off its reference after a cycle: the frictions (what they
#: hold) and the gaps (a centred gap stays where the self-weight pushes it).
MEMORY = FRICTIONS | {"actuator_play", "joint_clearance", "drive_backlash"}

_ATTRS = {
    "return_dx_mm": {
        "units": "mm",
        "long_name": "measure point x at the return to zero payload (reference -> payload -> 0)",
    },
    "return_dy_mm": {
        "units": "mm",
        "long_name": "measure point y at the return to zero payload (reference -> payload -> 0)",
    },
}


def add_return(ds: Any, job: _Job) -> Any:
    """``ds`` (the unreduced sweep of ``job``) with ``return_dx_mm`` and ``return_dy_mm`` per
    cell (mm), NaN where the cell is not ok or its cycle cannot be solved."""
    dims = list(job.grid.names)
    poses, masses = job.grid.size, int(job.mass.shape[0])
    ok = np.asarray(ds["ok"].transpose(*dims, "mass_kg").values).reshape(poses, masses)
    kinds = {e.name for e in job.effects}
    users = split_effects(job.effects)[1]
    if not kinds & MEMORY and not users:
        # Nothing holds anything and no gap is left off-centre: an elastic arm unloaded is
        # its reference, so every cell comes back exactly (docs/model.md §9).
        zero = np.zeros(poses)
        return _store(ds, job, ok, {k: zero for k in _ATTRS})
    if not kinds & FRICTIONS and not users:
        # Gaps alone: every cell of a pose returns to the pose loaded with 0 kg, which the
        # sweep's own kernel solves, for the whole grid at once.
        return _store(ds, job, ok, _rest(ds, job, ok))
    out = {k: np.full((poses, masses), np.nan) for k in _ATTRS}
    if not kinds & FRICTIONS:
        # Nothing remembers the payload: the return is the pose loaded with nothing, the same
        # for every payload: one state per pose (of the poses with a cell to fill).
        p = np.flatnonzero(ok.any(axis=1))
        dx, dy = _solve_rows(ds, job, p, np.zeros((p.size, 1)))
        out["return_dx_mm"][p] = dx[:, None]
        out["return_dy_mm"][p] = dy[:, None]
        return _store(ds, job, ok, out)
    if not users:
        # Frictions, built-in effects: every cycle (pose, m) → (m, 0) on the compiled core,
        # which keeps only where each one ends (of the poses with a cell to fill).
        from eodarm.model.solver import cycle_returns

        p = np.flatnonzero(ok.any(axis=1))
        dx, dy = cycle_returns(
            job.arm, _poses(ds, job, p), job.mass, list(job.effects), job.self_weight
        )
        out["return_dx_mm"][p], out["return_dy_mm"][p] = dx, dy
        return _store(ds, job, ok, out)
    # one sequence per ok cell: (pose, m) → states (m, 0)
    cells = np.flatnonzero(ok.ravel())
    p, m = cells // masses, cells % masses
    states = np.column_stack([job.mass[m], np.zeros(cells.size)])
    dx, dy = _solve_rows(ds, job, p, states)
    out["return_dx_mm"][p, m] = dx
    out["return_dy_mm"][p, m] = dy
    return _store(ds, job, ok, out)


def _rest(ds: Any, job: _Job, ok: npt.NDArray[np.bool_]) -> dict[str, FloatArray]:
    """Every pose's (dx, dy) loaded with 0 kg, as the plain sweep solves it (mm, (poses,)).

    The sweep's own path at ``mass_kg = [0]``: the core walks an angle grid itself; other
    grids go through :func:`_chunk`. Where that cell is not ok (NaN) but a loaded cell of
    the pose is, the return is solved as before, by :func:`eodarm.solve_sequence`, so that
    the validity limits of the unloaded state never hide a return.
    """
    size, n = job.grid.size, job.arm.n
    job0 = dataclasses.replace(job, mass=np.zeros(1), op=None, block=1)
    dx, dy, ok0 = np.empty(size), np.empty(size), np.empty(size, dtype=bool)
    if job.grid.kind == "alpha":
        # the outputs that are not needed go to one scratch buffer, reused chunk by chunk
        step = min(CHUNK, size)
        scratch = np.empty(3 * step * n)
        for a in range(0, size, step):
            b = min(a + step, size)
            k = (b - a) * n
            out = {
                "force_n": scratch[:k],
                "dx_mm": dx[a:b],
                "dy_mm": dy[a:b],
                "dalpha_deg": scratch[step * n : step * n + k],
                "dl_mm": scratch[2 * step * n : 2 * step * n + k],
                "ok": ok0[a:b],
            }
            _core_grid_sweep(job0, a, b - a, out)
    else:
        for a in range(0, size, CHUNK):
            b = min(a + CHUNK, size)
            res = _chunk(job0, a, b)
            dx[a:b] = res["dx_mm"][:, 0]
            dy[a:b] = res["dy_mm"][:, 0]
            ok0[a:b] = res["ok"][:, 0]
    redo = np.flatnonzero(~ok0)
    redo = redo[ok[redo].any(axis=1)]
    if redo.size:
        dx[redo], dy[redo] = _solve_rows(ds, job, redo, np.zeros((redo.size, 1)))
    return {"return_dx_mm": dx, "return_dy_mm": dy}


def _poses(ds: Any, job: _Job, idx: npt.NDArray[np.intp]) -> FloatArray:
    """The unloaded angles (k, n) of the flat poses ``idx`` of the sweep's grid, degrees."""
    grid, n = job.grid, job.arm.n
    if grid.kind != "alpha":
        alpha = ds["alpha_deg"].transpose(*grid.names, "link").values.reshape(-1, n)
        return np.ascontiguousarray(alpha[idx], dtype=float)
    out = np.empty((idx.size, n))
    for col, coord, ix in zip(
        grid.columns, grid.coords, np.unravel_index(idx, grid.shape), strict=True
    ):
        out[:, col] = coord[ix]
    return out


def _solve_rows(
    ds: Any, job: _Job, idx: npt.NDArray[np.intp], states: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """(dx, dy) in mm at the last of ``states`` (k, S) of the sequences of the poses ``idx``,
    NaN where a sequence cannot be solved; ``CHUNK`` sequences per call."""
    dx, dy = np.empty(idx.size), np.empty(idx.size)
    for a in range(0, idx.size, CHUNK):
        b = min(a + CHUNK, idx.size)
        dx[a:b], dy[a:b] = _solve_sequences(job, _poses(ds, job, idx[a:b]), states[a:b])
    return dx, dy


def _solve_sequences(
    job: _Job, alpha: FloatArray, states: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """(dx, dy) at the last state of each sequence, NaN where it cannot be solved (a state
    that cannot be closed is NaN on either backend, :func:`eodarm.solve_sequence`'s default;
    an error of a user's function is not caught)."""
    from eodarm.model.solver import solve_sequence

    if not alpha.shape[0]:
        return np.empty(0), np.empty(0)
    res = solve_sequence(job.arm, alpha, states, list(job.effects), self_weight=job.self_weight)
    return np.asarray(res["dx_mm"][:, -1]), np.asarray(res["dy_mm"][:, -1])


def _store(ds: Any, job: _Job, ok: npt.NDArray[np.bool_], out: dict[str, FloatArray]) -> Any:
    """``ds`` with the returns ``out`` (poses × masses, or per pose for every payload),
    NaN where a cell is not ok."""
    dims = list(job.grid.names)
    shape = (*job.grid.shape, ok.shape[1])
    for key, attrs in _ATTRS.items():
        v = out[key]
        values = np.where(ok, v if v.ndim == 2 else v[:, None], np.nan).reshape(shape)
        ds[key] = ([*dims, "mass_kg"], values, attrs)
    return ds


def worst_return(ds: Any) -> dict[str, Any] | None:
    """Where a ``cycle=True`` sweep's arm comes back worst, and by how much.

    Returns None without ``return_dx_mm`` (or no ok cell), else ``distance_mm`` (the largest
    |(return_dx, return_dy)| over the ok cells), its ``dx_mm``, ``dy_mm``, ``mass_kg`` (the
    cycle's payload), ``alpha_deg`` (the pose's unloaded angles), ``x_mm``, ``y_mm`` (its
    load point unloaded, when the sweep has them), ``median_mm`` over the ok cells, ``cells``
    their count, and ``memory``: whether the model holds anything after a cycle (False: an
    elastic model, whose every return is 0 by construction).
    """
    if "return_dx_mm" not in ds:
        return None
    dx = ds["return_dx_mm"]
    dims = list(dx.dims)
    dist = np.hypot(np.asarray(dx.values, dtype=float), ds["return_dy_mm"].transpose(*dims).values)
    ok = np.isfinite(dist)
    if not ok.any():
        return None
    flat = int(np.nanargmax(np.where(ok, dist, -1.0)))
    at = dict(zip(dims, np.unravel_index(flat, dist.shape), strict=True))
    pose = {d: i for d, i in at.items() if d != "mass_kg"}
    if "alpha_deg" in ds:
        alpha = np.asarray(ds["alpha_deg"].isel(pose).values, dtype=float)
    else:
        n = sum(1 for d in ds.coords if str(d).startswith("alpha"))
        alpha = np.array([float(ds[f"alpha{k + 1}"][pose[f"alpha{k + 1}"]]) for k in range(n)])
    out: dict[str, Any] = {
        "distance_mm": float(dist.flat[flat]),
        "dx_mm": float(dx.values.flat[flat]),
        "dy_mm": float(ds["return_dy_mm"].transpose(*dims).values.flat[flat]),
        "mass_kg": float(ds["mass_kg"][at["mass_kg"]]),
        "alpha_deg": [float(a) for a in alpha],
        "median_mm": float(np.median(dist[ok])),
        "cells": int(ok.sum()),
        "memory": bool(set(str(ds.attrs.get("effects", "")).replace("@", " ").split()) & MEMORY)
        or bool(np.any(dist[ok] > 0)),
    }
    for key in ("effector_x_mm", "effector_y_mm"):
        if key in ds:
            out[key.replace("effector_", "")] = float(ds[key].isel(pose).values)
    return out
