"""A sweep's predictions with their uncertainty, and the miss left after compensation.

Two optional outputs of :func:`eodarm.sweep`, both from the covariance of the arm's fitted
parameters (its ``[fit]`` table, written by ``eodarm fit -o``), computed in a pass over the
grid after the sweep itself (docs/sweeps.md, "Uncertainty and the compensated miss"):

* ``uncertainty=True``: ``sigma_dx_mm``, ``sigma_dy_mm`` and ``sigma_dalpha_deg``, the
  standard deviations of ``dx_mm``, ``dy_mm`` and ``dalpha_deg`` of every cell, as
  :func:`eodarm.solve` gives them (:func:`eodarm.model.uncertainty.prediction_sigma`): the
  total, with its two parts ``sigma_param_*`` (linear propagation of the fitted parameters'
  covariance) and ``sigma_model_*`` (the model's inadequacy; docs/model.md).
  A reduced sweep gives, for each reduced variable, the σ **of the cell the reduction chose**
  (the cell of the maximum or minimum; arg-reductions the same cell as max/min).
* ``compensated_miss=True``: every solved cell is compensated with the fitted model
  (:func:`eodarm.compensate`); ``compensation_residual_mm`` is the model's own remaining miss
  (numerical), ``compensated_miss_mm`` = 2·√(σ_dx² + σ_dy²) (the total σ) at the compensated
  pose: how far the real arm's loaded measure point may still miss the nominal one because
  the fitted parameters are uncertain and the model does not explain everything
  (:mod:`eodarm.workspace.compensated`). A reduced sweep gives the largest of each over the
  group.

Cells that are not ok (not solved, or masked as unreachable) are NaN.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import InputError
from eodarm.model.effects import split_effects
from eodarm.model.uncertainty import prediction_sigma, require_fit
from eodarm.workspace import compensated

if TYPE_CHECKING:
    import xarray as xr

    from eodarm.workspace.chunk import _Job, _Setup

__all__ = ["SIGMA_ATTRS", "add_outputs", "check", "extra_nbytes"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: Cells per block of the pass (poses × payloads, rounded to whole reduction groups).
CELLS_PER_BLOCK = 2**15


def _attrs() -> dict[str, dict[str, str]]:
    """Units and long names of the σ variables: the total and its two parts."""
    what = {
        "": "standard deviation of {out}: the fitted parameters' part and the model's "
        "inadequacy together",
        "_param": "standard deviation of {out} from the fitted parameters' covariance",
        "_model": "standard deviation of {out} from the model's own inadequacy (its held-out "
        "residuals beyond the noise; 0 where the model explained its data)",
    }
    return {
        f"sigma{part}_{out}": {
            "units": "deg" if out.endswith("deg") else "mm",
            "long_name": text.format(out=out),
        }
        for part, text in what.items()
        for out in ("dx_mm", "dy_mm", "dalpha_deg")
    }


#: The σ variables of a sweep with ``uncertainty=True`` (docs/model.md, Prediction errors).
SIGMA_ATTRS = _attrs()


def check(job: _Job, uncertainty: bool, compensated_miss: bool) -> None:
    """Refuse, before anything is solved, what the pass cannot do (one line each)."""
    if not (uncertainty or compensated_miss):
        return
    what = "uncertainty" if uncertainty else "compensated_miss"
    if job.model != "analytic":
        raise InputError(f"sweep: {what} is propagated with model='analytic'")
    users = split_effects(job.effects)[1]
    if users:
        raise InputError(
            f"sweep: {what} is propagated for the catalogue's effects only; custom effect "
            f"{users[0].key} cannot be part of the propagation"
        )
    require_fit(job.arm)


def extra_nbytes(setup: _Setup, uncertainty: bool, compensated_miss: bool) -> int:
    """Bytes the pass adds to the sweep's output."""
    cells = setup.shapes["dy_mm"][0] * (1 if setup.job.op else setup.job.mass.shape[0])
    per = 0
    if uncertainty:
        per += 3 * 8 * (2 + setup.job.arm.n)
    if compensated_miss:
        per += 16 + (0 if setup.job.op else 1)
    return cells * per


def _blocks(setup: _Setup) -> Iterator[tuple[int, int]]:
    """Spans of whole reduction groups, about CELLS_PER_BLOCK cells each."""
    job = setup.job
    group = job.block * job.mass.shape[0]
    step = job.block * max(1, CELLS_PER_BLOCK // group)
    for a in range(0, setup.size, step):
        yield a, min(a + step, setup.size)


def _cells(
    setup: _Setup, result: dict[str, npt.NDArray[Any]], start: int, stop: int
) -> tuple[FloatArray, FloatArray, dict[str, npt.NDArray[Any]]]:
    """Angles (c, n), payloads (c, 2) and the unreduced outputs (ok, dx, dy, dalpha; flat
    over the cells, payload fastest) of poses [start, stop)."""
    job = setup.job
    m = job.mass.shape[0]
    alpha, _ = job.grid.poses(job.arm, start, stop)
    if job.op is None:  # the sweep's own cells
        out = {k: result[k][start:stop] for k in ("ok", "dx_mm", "dy_mm", "dalpha_deg")}
    else:  # solved again unreduced, exactly as the reduction saw them
        from eodarm.workspace.chunk import _chunk

        out = _chunk(replace(job, op=None, block=1), start, stop)
    flat = {k: np.asarray(out[k]).reshape(-1, *np.shape(out[k])[2:]) for k in out}
    cells_alpha = np.repeat(np.asarray(alpha, dtype=float), m, axis=0)
    payload = np.zeros((cells_alpha.shape[0], 2))
    payload[:, 1] = -np.tile(job.mass, stop - start) * job.arm.g
    return cells_alpha, payload, flat


def _sigma(
    setup: _Setup, alpha: FloatArray, payload: FloatArray, ok: BoolArray
) -> dict[str, FloatArray]:
    """σ of dx, dy (c,) and dalpha (c, n) of the ok cells; NaN elsewhere."""
    job = setup.job
    n = job.arm.n
    out = _empty(ok.shape[0], n)
    if ok.any():
        got = prediction_sigma(
            job.arm,
            np.ascontiguousarray(alpha[ok]),
            np.ascontiguousarray(payload[ok]),
            list(job.effects),
            job.self_weight,
            nan_on_failure=True,
        )
        for k, v in got.items():
            out[k][ok] = v
    return out


def _empty(rows: int, n: int) -> dict[str, FloatArray]:
    """NaN arrays of every σ variable: (rows,) for dx and dy, (rows, n) for dalpha."""
    return {
        k: np.full((rows, n) if k.endswith("dalpha_deg") else rows, np.nan) for k in SIGMA_ATTRS
    }


def _pick(value: FloatArray, sigma: FloatArray, ok: BoolArray, op: str, group: int) -> FloatArray:
    """σ at the cell each group's reduction chose: its max (argmax) or min (argmin) among
    the ok cells, the first of equal values; NaN where no cell is ok."""
    v = value.reshape(-1, group)
    good = ok.reshape(-1, group) & np.isfinite(v)
    if op in ("max", "argmax"):
        idx = np.argmax(np.where(good, v, -np.inf), axis=1)
    else:
        idx = np.argmin(np.where(good, v, np.inf), axis=1)
    got = np.take_along_axis(sigma.reshape(-1, group), idx[:, None], axis=1)[:, 0]
    return np.where(good.any(axis=1), got, np.nan)


def add_outputs(
    ds: xr.Dataset,
    setup: _Setup,
    result: dict[str, npt.NDArray[Any]],
    uncertainty: bool,
    compensated_miss: bool,
) -> xr.Dataset:
    """The sweep's Dataset with the σ and compensated-miss variables added (see module)."""
    if not (uncertainty or compensated_miss):
        return ds
    job = setup.job
    n, m, op = job.arm.n, job.mass.shape[0], job.op
    group = job.block * m if op else 1
    rows = setup.shapes["dy_mm"][0] * (1 if op else m)  # output cells, flat
    sig = _empty(rows, n)
    comp = compensated.Outputs(rows, per_cell=op is None)
    for start, stop in _blocks(setup):
        alpha, payload, cells = _cells(setup, result, start, stop)
        ok = np.asarray(cells["ok"], dtype=bool)
        a, b = start * m // group, stop * m // group
        if uncertainty:
            got = _sigma(setup, alpha, payload, ok)
            if op is None:
                for k, v in got.items():
                    sig[k][a:b] = v
            else:
                for k in SIGMA_ATTRS:
                    key = "_".join(k.split("_")[-2:])  # the output it is the σ of
                    if key == "dalpha_deg":
                        for i in range(n):
                            sig[k][a:b, i] = _pick(cells[key][:, i], got[k][:, i], ok, op, group)
                    else:
                        sig[k][a:b] = _pick(cells[key], got[k], ok, op, group)
        if compensated_miss:
            comp.put(a, b, compensated.cells(job, alpha, payload, ok), group)
    dims = ds["dy_mm"].dims
    shape = tuple(ds.sizes[d] for d in dims)
    out = ds.copy()
    if uncertainty:
        for key in SIGMA_ATTRS:
            if key.endswith("dalpha_deg"):
                out[key] = (
                    ds["dalpha_deg"].dims,
                    sig[key].reshape(*shape, n),
                    dict(SIGMA_ATTRS[key]),
                )
            else:
                out[key] = (dims, sig[key].reshape(shape), dict(SIGMA_ATTRS[key]))
        if op:
            over = ", ".join(d for d in setup.rdims)
            for key in SIGMA_ATTRS:
                chosen = "_".join(key.split("_")[-2:])
                out[key].attrs["long_name"] += (
                    f", at the cell over ({over}) that the {op} of {chosen} chose"
                )
        out.attrs["uncertainty"] = _provenance(job)
    if compensated_miss:
        comp.into(out, dims, shape, setup.rdims if op else [])
    return out


def _provenance(job: _Job) -> str:
    """Where the σ came from, one short line (a figure's title shows it)."""
    rec = job.arm.fit
    assert rec is not None  # check() made sure
    k, b = len(rec.parameters), len(job.arm.bounded())
    parts = [
        f"σ: linear propagation of the [fit] covariance of {k} parameter{'s' * (k != 1)}"
        + (f" and {b} bound{'s' * (b != 1)}" if b else "")
    ]
    if rec.data:
        parts.append(f"fitted to {rec.data}")
    if rec.date:
        parts.append(rec.date[:10])
    if rec.explained is False:
        dy = dict(rec.sigma_model).get("dy_mm")
        parts.append(
            f"plus the model's inadequacy (χ²/dof {rec.chi2_per_dof:.3g}"
            + (f", dy {dy:.2g} mm" if dy is not None else "")
            + ")"
        )
    return "; ".join(parts)


def summary_lines(ds: xr.Dataset) -> list[str]:
    """A line or two for ``eodarm sweep``'s summary: the range of 2σ of dy, the compensated
    miss and the cells per compensation status."""
    lines = []
    for key, what in (
        ("sigma_dy_mm", "2σ of dy"),
        ("compensated_miss_mm", "compensated miss (2σ)"),
    ):
        if key not in ds:
            continue
        v = np.asarray(ds[key].values, dtype=float)
        v = (2.0 * v if key == "sigma_dy_mm" else v)[np.isfinite(v)]
        if v.size:
            med = float(np.median(v))
            lines.append(f"{what}: {v.min():.3g} … {v.max():.3g} mm (median {med:.3g} mm)")
    if "compensation" in ds.attrs:
        lines.append(f"compensation of the cells: {ds.attrs['compensation']}")
    return lines
