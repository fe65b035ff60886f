"""The drive torques of a sweep's cells, for arms with rotary drives (docs/model.md §10).

The sweep's kernels give each cell's actuator forces; a rotary drive's torque is not among
them. It comes from the statics on the undeformed geometry, as every force does (docs/model.md
§1), for every (pose, payload) cell at once: ``torque_nmm`` the loaded torque through the
drive, ``dtorque_nmm`` its change from the unloaded state, exactly as :func:`eodarm.solve`
gives them. A ``joint_friction`` at a drive's joint (in parallel with the whole drive) holds
part of the change: loaded once from the unloaded state it is a deadband, and the drive takes
ΔT − sign(ΔT)·min(|ΔT|, L) (docs/model.md §9). A gear friction (``drive_friction``) sits
inside the drive and does not change the torque through it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.workspace.chunk import _Job

__all__ = ["CHUNK", "add_torque"]

FloatArray = npt.NDArray[np.float64]

#: Poses per call of the statics.
CHUNK = 65_536

_ATTRS = {
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


def add_torque(ds: Any, job: _Job) -> Any:
    """``ds`` (the unreduced sweep of ``job``, an arm with a rotary drive) with
    ``torque_nmm`` and ``dtorque_nmm`` (grid…, mass_kg, actuator), NaN where a cell is not ok
    and at joints turned by linear actuators."""
    from eodarm.model.solver import statics
    from eodarm.workspace.cycle import _poses

    arm, n = job.arm, job.arm.n
    rotary = np.array(arm.kinds) == "rotary"
    dims = list(job.grid.names)
    poses, masses = job.grid.size, int(job.mass.shape[0])
    ok = np.asarray(ds["ok"].transpose(*dims, "mass_kg").values).reshape(poses, masses)
    limit = np.zeros(n)
    for e in job.effects:
        if e.name == "joint_friction" and rotary[e.index(n)]:
            limit[e.index(n)] += e.value
    torque = np.full((poses, masses, n), np.nan)
    dtorque = np.full((poses, masses, n), np.nan)
    idx = np.flatnonzero(ok.any(axis=1))
    for a in range(0, idx.size, CHUNK):
        p = idx[a : a + CHUNK]
        alpha = np.repeat(_poses(ds, job, p), masses, axis=0)
        st = statics(arm, alpha, np.tile(job.mass, p.size), self_weight=job.self_weight)
        t0 = np.asarray(st["torque0_nmm"], dtype=float)
        change = np.asarray(st["torque_nmm"], dtype=float) - t0
        taken = np.sign(change) * np.maximum(np.abs(change) - limit, 0.0)
        torque[p] = (t0 + taken).reshape(p.size, masses, n)
        dtorque[p] = taken.reshape(p.size, masses, n)
    keep = ok[..., None] & rotary
    shape = (*job.grid.shape, masses, n)
    for key, values in (("torque_nmm", torque), ("dtorque_nmm", dtorque)):
        ds[key] = ([*dims, "mass_kg", "actuator"], np.where(keep, values, np.nan).reshape(shape))
        ds[key].attrs.update(_ATTRS[key])
    return ds
