"""The drive torques of a sweep's cells, for arms with rotary drives (docs/model.md §10).

The sweep's kernels give each cell's actuator forces; a rotary drive's torque is not among
them. It comes from the statics on the undeformed geometry, as every force does (docs/model.md
§1), for every (pose, payload) cell of a chunk at once: ``torque_nmm`` the loaded torque
through the drive, ``dtorque_nmm`` its change from the unloaded state, exactly as
:func:`eodarm.solve` gives them. A ``joint_friction`` at a drive's joint (in parallel with the
whole drive) holds part of the change: loaded once from the unloaded state it is a deadband,
and the drive takes ΔT − sign(ΔT)·min(|ΔT|, L) (docs/model.md §9). A gear friction
(``drive_friction``) sits inside the drive and does not change the torque through it.

The torques are made chunk by chunk, beside the chunk's other outputs, so that every way of
walking a sweep carries them: in memory or into Zarr, here or on a Dask worker, per cell or
reduced. A reduced sweep's torques are reduced as its other cell outputs are (over the ok
cells of each group; docs/sweeps.md, "Reductions"): the group's cells are solved again
unreduced for their status, since the reduction keeps no cell's.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.workspace.chunk import _chunk, _Job

__all__ = ["ATTRS", "CHUNK", "TORQUE_VARS", "chunk", "fill", "span", "wanted"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: Poses per call of the statics.
CHUNK = 65_536
#: The torque outputs of a sweep of an arm with a rotary drive, per cell and actuator.
TORQUE_VARS = ("torque_nmm", "dtorque_nmm")

ATTRS = {
    "torque_nmm": {
        "units": "N mm",
        "long_name": "loaded drive torque on link i about O_i (counter-clockwise positive); "
        "NaN at linear actuators",
    },
    "dtorque_nmm": {
        "units": "N mm",
        "long_name": "drive torque change, loaded minus unloaded; NaN at linear actuators",
    },
}


def wanted(job: _Job) -> bool:
    """Whether the sweep of ``job`` carries the torque outputs: its arm has a rotary drive."""
    return "rotary" in job.arm.kinds


def _cells(job: _Job, alpha: FloatArray, ok: BoolArray) -> tuple[FloatArray, FloatArray]:
    """(torque, dtorque) (poses, masses, n), N·mm, of poses ``alpha`` (poses, n) under every
    payload of the job; NaN where a cell is not ok (``ok`` (poses, masses)) and at joints
    turned by linear actuators."""
    from eodarm.model.solver import statics

    arm, n = job.arm, job.arm.n
    rotary = np.array(arm.kinds) == "rotary"
    masses = int(job.mass.shape[0])
    limit = np.zeros(n)
    for e in job.effects:
        if e.name == "joint_friction" and rotary[e.index(n)]:
            limit[e.index(n)] += e.value
    torque = np.full((alpha.shape[0], masses, n), np.nan)
    dtorque = np.full((alpha.shape[0], masses, n), np.nan)
    idx = np.flatnonzero(ok.any(axis=1))
    for a in range(0, idx.size, CHUNK):
        p = idx[a : a + CHUNK]
        cell_alpha = np.repeat(np.ascontiguousarray(alpha[p], dtype=float), masses, axis=0)
        st = statics(arm, cell_alpha, np.tile(job.mass, p.size), self_weight=job.self_weight)
        t0 = np.asarray(st["torque0_nmm"], dtype=float)
        change = np.asarray(st["torque_nmm"], dtype=float) - t0
        taken = np.sign(change) * np.maximum(np.abs(change) - limit, 0.0)
        torque[p] = (t0 + taken).reshape(p.size, masses, n)
        dtorque[p] = taken.reshape(p.size, masses, n)
    keep = ok[..., None] & rotary
    return np.where(keep, torque, np.nan), np.where(keep, dtorque, np.nan)


def _reduce(values: FloatArray, op: str, group: int) -> npt.NDArray[Any]:
    """``values`` (cells, n), NaN where not counted, reduced over consecutive groups of
    ``group`` cells as the core reduces (NaN ignored; max/min NaN and argmax/argmin −1 where a
    group has no value; of equal values the first)."""
    v = values.reshape(-1, group, values.shape[-1])
    some = np.isfinite(v).any(axis=1)
    if op in ("max", "argmax"):
        at = np.argmax(np.where(np.isnan(v), -np.inf, v), axis=1)
    else:
        at = np.argmin(np.where(np.isnan(v), np.inf, v), axis=1)
    if op.startswith("arg"):
        return np.where(some, at, -1).astype(np.int64)
    got = np.take_along_axis(v, at[:, None, :], axis=1)[:, 0, :]
    return np.where(some, got, np.nan)


def span(
    job: _Job, start: int, stop: int, ok: BoolArray | None = None
) -> dict[str, npt.NDArray[Any]]:
    """``torque_nmm`` and ``dtorque_nmm`` of the flat poses [start, stop) of the job's grid:
    per cell (stop − start, masses, n), or reduced by the job's reduction ((stop − start) /
    block, n).

    ``ok`` (stop − start, masses): the cells' own ``ok``, of an unreduced sweep; without it
    (a reduced sweep) the poses are solved again unreduced for it, exactly as the reduction
    saw them.
    """
    alpha, _ = job.grid.poses(job.arm, start, stop)
    if ok is None:
        ok = _chunk(dataclasses.replace(job, op=None, block=1), start, stop)["ok"]
    ok = np.asarray(ok, dtype=bool).reshape(stop - start, -1)
    torque, dtorque = _cells(job, np.asarray(alpha, dtype=float), ok)
    out = {"torque_nmm": torque, "dtorque_nmm": dtorque}
    if job.op is None:
        return out
    group = job.block * int(job.mass.shape[0])
    return {k: _reduce(v.reshape(-1, job.arm.n), job.op, group) for k, v in out.items()}


def chunk(job: _Job, start: int, stop: int) -> dict[str, npt.NDArray[Any]]:
    """:func:`eodarm.workspace.chunk._chunk` with the torque outputs added when the job's arm
    has a rotary drive: what a chunk of a sweep gives, here or on a Dask worker."""
    res = _chunk(job, start, stop)
    if wanted(job):
        res.update(span(job, start, stop, None if job.op else res["ok"]))
    return res


def fill(job: _Job, result: dict[str, npt.NDArray[Any]], start: int, stop: int) -> None:
    """Write the torque outputs of the flat poses [start, stop) into ``result`` (the sweep's
    arrays of those poses, flat over the poses or reduction groups, ``ok`` already solved),
    ``CHUNK`` poses (whole reduction groups) at a time."""
    step = job.block * max(1, CHUNK // job.block)
    for a in range(start, stop, step):
        b = min(a + step, stop)
        lo, hi = (a - start) // job.block, (b - start) // job.block
        got = span(job, a, b, None if job.op else result["ok"][lo:hi])
        for key, value in got.items():
            result[key][lo:hi] = value
