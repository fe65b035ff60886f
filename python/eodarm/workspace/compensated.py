"""The compensated miss of a sweep's cells (docs/compensation.md §6, docs/sweeps.md).

Each solved cell (a nominal pose α⁰ under a payload) is compensated with the fitted model
(:func:`eodarm.compensate`, the core's batch Newton): the commanded angles α_c put the
model's loaded measure point on the nominal one, up to ``compensation_residual_mm``. The real
arm differs from the model by the error of the fitted parameters θ (covariance C, the arm's
``[fit]`` table), so at α_c its measure point misses by δ ≈ J·δθ, J = ∂(dx, dy)/∂θ at α_c,
with covariance Σ = J C Jᵀ (2 × 2). The reported miss is

    compensated_miss_mm = 2·√(trace Σ) = 2·√(σ_dx² + σ_dy²)   at the compensated pose,

which, to first order and for normally distributed parameter errors, bounds |δ| for at least
95.4 % of the arms the fit allows (98.2 % when Σ is isotropic). σ is the total of
:func:`~eodarm.model.uncertainty.prediction_sigma`: where the fitted model did not explain
its data, the model's held-out inadequacy per channel adds to the diagonal of Σ (docs/model.md,
Prediction errors), a miss that compensation with this model cannot remove. It leaves out
the geometry's errors.
"""

from __future__ import annotations

import warnings
from collections.abc import Hashable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.compensate import STATUSES, CompensationWarning, compensate
from eodarm.model.uncertainty import prediction_sigma

if TYPE_CHECKING:
    import xarray as xr

    from eodarm.workspace.chunk import _Job

__all__ = ["NOT_SOLVED", "Outputs", "cells"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: ``compensation_status`` of a cell the sweep could not solve (or masked).
NOT_SOLVED = -1
#: Coverage factor of the compensated miss.
K_SIGMA = 2.0

ATTRS: dict[str, dict[str, Any]] = {
    "compensated_miss_mm": {
        "units": "mm",
        "long_name": "2 sqrt(sigma_dx^2 + sigma_dy^2) of the loaded measure point at the "
        "compensated pose, from the fitted parameters' covariance",
    },
    "compensation_residual_mm": {
        "units": "mm",
        "long_name": "the fitted model's own remaining miss of the nominal point after "
        "compensation (numerical)",
    },
    "compensation_status": {
        "long_name": "compensation of the cell: " + ", ".join(STATUSES) + ", not_solved",
        "flag_values": np.array([*range(len(STATUSES)), NOT_SOLVED], dtype=np.int8),
        "flag_meanings": " ".join([*STATUSES, "not_solved"]),
    },
}


def cells(
    job: _Job, alpha: FloatArray, payload: FloatArray, ok: BoolArray
) -> dict[str, npt.NDArray[Any]]:
    """Compensate the ok cells (angles (c, n), payloads (c, 2)) with the fitted model;
    ``compensated_miss_mm``, ``compensation_residual_mm`` (c,) (NaN where not compensated
    or not solved) and ``compensation_status`` (c,) int8 (:data:`STATUSES` codes, or
    :data:`NOT_SOLVED`)."""
    c = ok.shape[0]
    miss = np.full(c, np.nan)
    resid = np.full(c, np.nan)
    status = np.full(c, NOT_SOLVED, dtype=np.int8)
    rows = np.flatnonzero(ok)
    if rows.size:
        mass = -payload[rows, 1] / job.arm.g
        with warnings.catch_warnings():
            # the sweep counts the failures itself (compensation_status, attrs)
            warnings.simplefilter("ignore", CompensationWarning)
            out = compensate(
                job.arm, alpha[rows], mass, list(job.effects), job.self_weight, strict=False
            )
        for code, name in enumerate(STATUSES):
            status[rows[out["status"] == name]] = code
        resid[rows] = out["residual_mm"]
        good = out["status"] == "ok"
        if good.any():
            sig = prediction_sigma(
                job.arm,
                np.ascontiguousarray(out["alpha_deg"][good]),
                np.ascontiguousarray(payload[rows[good]]),
                list(job.effects),
                job.self_weight,
                nan_on_failure=True,
            )
            miss[rows[good]] = K_SIGMA * np.hypot(sig["sigma_dx_mm"], sig["sigma_dy_mm"])
    return {
        "compensated_miss_mm": miss,
        "compensation_residual_mm": resid,
        "compensation_status": status,
    }


class Outputs:
    """The compensated-miss arrays of a sweep's output cells, filled block by block: per
    cell, or (``per_cell=False``, a reduced sweep) the largest over each group."""

    def __init__(self, rows: int, per_cell: bool) -> None:
        self.per_cell = per_cell
        self.miss = np.full(rows, np.nan)
        self.resid = np.full(rows, np.nan)
        self.status = np.full(rows, NOT_SOLVED, dtype=np.int8) if per_cell else None
        self.counts = np.zeros(len(STATUSES) + 1, dtype=np.int64)  # last: not solved

    def put(self, a: int, b: int, got: dict[str, npt.NDArray[Any]], group: int) -> None:
        st = got["compensation_status"]
        self.counts[: len(STATUSES)] += np.bincount(st[st != NOT_SOLVED], minlength=len(STATUSES))[
            : len(STATUSES)
        ]
        self.counts[-1] += int((st == NOT_SOLVED).sum())
        if self.per_cell:
            assert self.status is not None
            self.miss[a:b], self.resid[a:b], self.status[a:b] = (
                got["compensated_miss_mm"],
                got["compensation_residual_mm"],
                st,
            )
            return
        self.miss[a:b] = _nanmax(got["compensated_miss_mm"].reshape(-1, group))
        self.resid[a:b] = _nanmax(got["compensation_residual_mm"].reshape(-1, group))

    def into(
        self, ds: xr.Dataset, dims: Sequence[Hashable], shape: tuple[int, ...], rdims: list[str]
    ) -> None:
        """Add the variables and the counts (``attrs["compensation"]``) to ``ds``."""
        over = f"largest over ({', '.join(rdims)}) of the " if rdims else ""
        for key, arr in (
            ("compensated_miss_mm", self.miss),
            ("compensation_residual_mm", self.resid),
        ):
            attrs = dict(ATTRS[key])
            attrs["long_name"] = over + attrs["long_name"]
            ds[key] = (list(dims), arr.reshape(shape), attrs)
        if self.status is not None:
            ds["compensation_status"] = (
                list(dims),
                self.status.reshape(shape),
                dict(ATTRS["compensation_status"]),
            )
        ds.attrs["compensation"] = summary(self.counts)


def summary(counts: npt.NDArray[np.int64]) -> str:
    """``"ok 120, no_convergence 3, not_solved 5"``: the cells per status (zeros left out)."""
    names = [*STATUSES, "not_solved"]
    return ", ".join(f"{nm} {int(k)}" for nm, k in zip(names, counts, strict=True) if k)


def _nanmax(v: FloatArray) -> FloatArray:
    """Row-wise max ignoring NaN; NaN where a row has none (no warning)."""
    good = np.isfinite(v)
    top = np.max(np.where(good, v, -np.inf), axis=1)
    return np.where(good.any(axis=1), top, np.nan)
