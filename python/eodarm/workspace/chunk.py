"""One chunk of a sweep: the job every chunk carries, the checked plan, and the chunk's solve.

:mod:`eodarm.workspace.sweep` (which runs the chunks), :mod:`eodarm.workspace.uncertainty`
and :mod:`eodarm.workspace.compensated` (which add the σ and the compensated miss to a
sweep's cells, solving chunks again unreduced) and :mod:`eodarm.workspace.cycle` (which
sweeps the grid again at no payload) all need :class:`_Job`, :class:`_Setup`, :func:`_chunk`
and :func:`_core_grid_sweep`; they sit here, below them, so that none of them imports another
that imports it back (docs/architecture.md, "No cycles"). The sweep re-exports them under
their old names.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, effect_arrays
from eodarm.model.solver import _core_arm
from eodarm.model.validity import STATUS
from eodarm.workspace.fallback import kernel, placeholder
from eodarm.workspace.grid import Grid

__all__ = ["CELL_VARS"]

FloatArray = npt.NDArray[np.float64]

#: Outputs per (pose, payload) cell, reduced by a reduction.
CELL_VARS = ("force_n", "dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "ok", "status")


# ---------------------------------------------------------------------------- one chunk
@dataclass(frozen=True)
class _Job:
    """Everything a chunk needs; picklable, so it can travel to a Dask worker."""

    arm: Arm
    grid: Grid
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
    # (`mask_unreachable` has nothing to do: cells of poses out of stroke are never ok.)
    pose_alpha = alpha  # the poses themselves (NaN where none), before any placeholder
    if exists is not None and not exists.all():
        alpha = np.where(exists[:, None], alpha, placeholder(arm))
    codes, places, values = effect_arrays(job.effects, n)
    m = job.mass.shape[0]
    out = kernel(
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
    if exists is not None:
        length[~exists], ex[~exists], ey[~exists] = np.nan, np.nan, np.nan
        reach[~exists] = False
        # A grid point without a pose is out of stroke (not the placeholder's near_singular);
        # a reduced group with one has that lowest code.
        missing = ~exists if not job.op else ~exists.reshape(-1, job.block).all(axis=1)
        res["status"] = np.array(res["status"])
        res["status"][missing] = STATUS.index("out_of_stroke")
    if job.block > 1:
        res["reachable"] = np.asarray(reach.reshape(-1, job.block).any(axis=1))
    else:
        res["reachable"] = reach
        res["length_mm"], res["effector_x_mm"], res["effector_y_mm"] = length, ex, ey
        if job.grid.kind != "alpha":
            res["alpha_deg"] = np.asarray(pose_alpha, dtype=float)
    return res


def _core_grid_sweep(
    job: _Job,
    start: int,
    count: int,
    out: dict[str, npt.NDArray[Any]],
    progress: Any = None,
    chunk_rows: int | None = None,
) -> None:
    """Poses [start, start + count) of the job's angle grid, solved by the core into ``out``."""
    from eodarm.model import native as _core

    codes, places, values = effect_arrays(job.effects, job.arm.n)
    m = job.mass.shape[0]
    axes = [np.ascontiguousarray(c, dtype=float) for c in job.grid.coords]
    _core.sweep(
        _core_arm(job.arm),
        None,
        job.mass,
        codes,
        places,
        values,
        job.self_weight,
        job.op,
        m * job.block if job.op else 1,
        job.threads,
        grid=(axes, list(job.grid.columns), start, count),
        out=out,
        mask_unreachable=job.mask_unreachable,
        progress=progress,
        chunk_rows=chunk_rows,
    )


@dataclass(frozen=True)
class _Setup:
    """A checked sweep: its job, the reduced dims, the chunk step and the output's arrays."""

    job: _Job
    rdims: list[str]
    step: int  # poses per chunk (a whole number of reduction groups)
    shapes: dict[str, tuple[int, ...]]  # output arrays, flat over the poses (or groups)
    dtypes: dict[str, Any]

    @property
    def size(self) -> int:
        """Poses of the grid."""
        return self.job.grid.size

    @property
    def cells(self) -> int:
        """Poses × payloads."""
        return self.job.grid.size * int(self.job.mass.shape[0])

    @property
    def nbytes(self) -> int:
        """Bytes of the output arrays."""
        return sum(math.prod(s) * np.dtype(self.dtypes[k]).itemsize for k, s in self.shapes.items())
