"""Workspace maps of a fitted model's uncertainty: the sag ± 2σ and the compensated miss.

Drawn like the maps of :mod:`eodarm.viz.maps` (every reachable, solved pose a pixel at its
unloaded load point; where poses overlap the worst is on top), from a sweep made with
``uncertainty=True`` or ``compensated_miss=True`` (:mod:`eodarm.workspace.uncertainty`).

* :func:`sag_uncertainty_map`: 2σ of the sag dy, and 2σ relative to |dy|: the band
  dy ± 2σ_dy in which the fitted model puts the real arm's sag.
* :func:`compensated_miss_map`: the miss without compensation, |(dx, dy)|, beside the miss
  left after compensating with the fitted model, ``compensated_miss_mm``.

:func:`render` writes them (``eodarm sweep --plot DIR --uncertainty --compensated-miss``).
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure

from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect
from eodarm.viz.format import value
from eodarm.viz.maps import _Canvas, _points, _robust, _select_mass, _title, log_ticks
from eodarm.viz.style import PathLike, figure, finish
from eodarm.workspace.maps import arm_of
from eodarm.workspace.sweep import sweep

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["compensated_miss_map", "render", "sag_uncertainty_map"]


#: Colour bars under the panels.
_CBAR: dict[str, Any] = {"orientation": "horizontal", "shrink": 0.8, "pad": 0.07, "aspect": 30}


def _need(ds: xr.Dataset, key: str, option: str) -> None:
    if key not in ds:
        raise EodarmError(f"this map needs {key}: a sweep made with {option}=True")


def _panel(
    fig: Figure,
    ax: Axes,
    cv: _Canvas,
    pts: tuple[Any, Any, Any],
    label: str,
    log: bool,
    unit: str = "mm",
) -> None:
    """One panel: the values coloured (largest on top), log scale when they span decades."""
    x, y, v = pts
    if not v.size:
        cv.frame(ax)
        return
    if log and v.min() > 0 and v.max() > 10 * v.min():
        mesh = cv.draw(ax, x, y, v, v, cmap="magma_r", norm=LogNorm(v.min(), v.max()))
        cb = fig.colorbar(mesh, ax=ax, **_CBAR)
        cb.set_label(label + "; log scale", fontsize=8)
        log_ticks(cb, float(v.min()), float(v.max()))  # round numbers that never collide
    else:
        lo, hi, extend = _robust(v, 0.0, 0.98)
        mesh = cv.draw(ax, x, y, v, v, cmap="magma_r", norm=Normalize(min(lo, 0.0), hi))
        cb = fig.colorbar(mesh, ax=ax, extend=extend, **_CBAR)
        more = "; colours up to 98 % of the poses" if extend != "neither" else ""
        cb.set_label(label + more, fontsize=8)
    ax.text(
        0.99,
        0.06,
        f"from {value(float(v.min()), unit, 3)} to {value(float(v.max()), unit, 3)}, median "
        f"{value(float(np.median(v)), unit, 3)}",
        transform=ax.transAxes,
        ha="right",
        va="bottom",
        fontsize=8,
        bbox={"fc": "white", "ec": "none", "alpha": 0.8, "pad": 1.0},
    )


def sag_uncertainty_map(
    ds: xr.Dataset, mass: float | None = None, *, path: PathLike | None = None
) -> Figure:
    """The sag's 2σ band over the reachable workspace, at one payload.

    Two panels: 2σ of dy (mm), the total σ (the fitted parameters' part and, where the
    fitted model did not explain its data, its held-out inadequacy; docs/model.md), so that
    the real arm's sag lies in dy ± 2σ; and 2σ / |dy| (%), where the prediction is
    relatively sure or not. ``ds``: a sweep with ``uncertainty=True``, not reduced.
    """
    _need(ds, "sigma_dy_mm", "uncertainty")
    arm = arm_of(ds)
    sel, m = _select_mass(ds, mass)
    two = 2.0 * sel["sigma_dy_mm"]
    band = _points(sel, two)
    rel = _points(sel, 100.0 * two / abs(sel["dy_mm"]).where(abs(sel["dy_mm"]) > 0))
    cv = _Canvas.of(arm, ds)
    fig = figure(13.6, 5.4 * cv.aspect + 2.4)
    ax1, ax2 = fig.subplots(1, 2)
    _panel(fig, ax1, cv, band, "2σ of dy (mm)", log=True)
    _panel(fig, ax2, cv, rel, "2σ of dy / |dy| (%)", log=True, unit="%")
    model = float(np.nanmax(sel["sigma_model_dy_mm"])) if "sigma_model_dy_mm" in sel else 0.0
    ax1.set_title(
        "sag ± 2σ: the band's half-width 2σ_dy (mm)"
        + (f"\nincl. the model's inadequacy σ = {model:.2g} mm" if model > 0 else ""),
        fontsize=10,
    )
    ax2.set_title("relative to the sag: 2σ_dy / |dy| (%)", fontsize=10)
    cv.legend(ax1)
    cv.note(fig, sel, band[2].size, "most uncertain", m, "the others have no σ")
    src = ds.attrs.get("uncertainty", "")  # it counts the parameters: the model names them
    title = _title(ds, "Uncertainty of the predicted sag", m, width=13.6)
    src = "\n".join(textwrap.wrap(str(src), int(11 * 13.6)))  # as _title wraps the model
    fig.suptitle(title + (f"\n{src}" if src else ""), fontsize=10)
    return finish(fig, path)


def compensated_miss_map(
    ds: xr.Dataset, mass: float | None = None, *, path: PathLike | None = None
) -> Figure:
    """The miss without compensation beside the miss left after compensating with the
    fitted model (``compensated_miss_mm``, 2σ), at one payload. Poses that could not be
    compensated are left out and counted. ``ds``: a sweep with ``compensated_miss=True``."""
    _need(ds, "compensated_miss_mm", "compensated_miss")
    arm = arm_of(ds)
    sel, m = _select_mass(ds, mass)
    before = _points(sel, (sel["dx_mm"] ** 2 + sel["dy_mm"] ** 2) ** 0.5)
    after = _points(sel, sel["compensated_miss_mm"])
    cv = _Canvas.of(arm, ds)
    fig = figure(13.6, 5.4 * cv.aspect + 2.4)
    ax1, ax2 = fig.subplots(1, 2)
    _panel(fig, ax1, cv, before, "|(dx, dy)| (mm)", log=True)
    _panel(fig, ax2, cv, after, "2√(σ_dx² + σ_dy²) at the compensated pose (mm)", log=True)
    ax1.set_title("miss without compensation: |(dx, dy)| (mm)", fontsize=10)
    left = before[2].size - after[2].size
    ax2.set_title(
        "miss left after compensating with the fitted model (2σ, mm)"
        + (f"\n{left:,} poses could not be compensated (not drawn)" if left else ""),
        fontsize=10,
    )
    cv.legend(ax1)
    cv.note(fig, sel, before[2].size, "largest-miss", m)
    fig.suptitle(_title(ds, "Compensation under the fit's uncertainty", m, width=13.6), fontsize=10)
    return finish(fig, path)


def render(
    arm: Arm,
    grid: Mapping[str, Any],
    effects: Sequence[Effect],
    mass: float,
    directory: PathLike,
    *,
    ds: xr.Dataset | None,
    uncertainty: bool,
    compensated_miss: bool,
    self_weight: bool = True,
    prefix: str = "",
) -> list[Path]:
    """Write ``sag_uncertainty.png`` and/or ``compensated_miss.png`` into ``directory``, from
    ``ds`` when it holds ``mass`` unreduced with the variables, else from a sweep at ``mass``."""
    if not (uncertainty or compensated_miss):
        return []
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    have = ds is not None and "mass_kg" in ds.dims and "effector_x_mm" in ds
    have = have and all(
        k in ds  # type: ignore[operator]
        for k, on in (("sigma_dy_mm", uncertainty), ("compensated_miss_mm", compensated_miss))
        if on
    )
    if not have:
        ds = sweep(
            arm,
            **grid,
            mass_kg=[mass],
            effects=effects,
            self_weight=self_weight,
            uncertainty=uncertainty,
            compensated_miss=compensated_miss,
        )
    assert ds is not None
    written = []
    if uncertainty:
        p = out / f"{prefix}sag_uncertainty.png"
        sag_uncertainty_map(ds, mass, path=p)
        written.append(p)
    if compensated_miss:
        p = out / f"{prefix}compensated_miss.png"
        compensated_miss_map(ds, mass, path=p)
        written.append(p)
    return written
