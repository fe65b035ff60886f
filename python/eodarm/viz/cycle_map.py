"""The map of ``sweep(..., cycle=True)``: where in the workspace the arm does not come back
after reference → payload → 0 (docs/model.md §9), and by how much."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.colors import ListedColormap, Normalize

from eodarm.errors import EodarmError
from eodarm.viz.format import RESOLUTION, channel_value
from eodarm.viz.maps import _Canvas, _points, _select_mass, _title
from eodarm.viz.style import PathLike, figure, finish
from eodarm.workspace.maps import arm_of, not_ok_points

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure

__all__ = ["return_map"]


def return_map(
    ds: xr.Dataset, mass: float | None = None, *, path: PathLike | None = None
) -> Figure:
    """How far the measure point sits from the reference after a cycle to ``mass`` and back.

    Parameters
    ----------
    ds : a sweep with ``cycle=True`` (:func:`eodarm.sweep`), not reduced.
    mass : the cycle's payload, kg, one of ``ds.mass_kg`` (default: the largest).
    path : where to write a PNG (120 dpi).

    Returns
    -------
    Figure
        The reachable load points binned into pixels, each coloured by the largest return
        error |(return_dx, return_dy)| (µm) of the poses that reach it: zero where nothing
        remembers the load (elastic parts, frictions that never slipped). Where every cell
        comes back (a model without friction or gap), the reachable pixels are drawn in one
        pale colour and a note says so, instead of a scale of zeros.
    """
    if "return_dx_mm" not in ds:
        raise EodarmError("the return map needs a sweep with cycle=True (eodarm sweep --cycle)")
    arm = arm_of(ds)
    sel, m = _select_mass(ds, mass)
    err = 1e3 * (sel["return_dx_mm"] ** 2 + sel["return_dy_mm"] ** 2) ** 0.5
    x, y, v = _points(sel, err)
    bad = not_ok_points(sel)
    cv = _Canvas.of(arm, ds)
    fig = figure(8.4, 7.0 * cv.aspect + 1.6)
    ax = fig.add_subplot()
    cv.shade(ax, bad)
    back = v.size and float(v.max()) < RESOLUTION["µm"]
    summary: str | None = None  # the range of the return errors, over the note
    if back:
        # a model without memory: every cell comes back; an all-zero map would look empty
        cv.draw(ax, x, y, v, v, cmap=ListedColormap(["#d9ead3"]), norm=Normalize(0.0, 1.0))
        ax.text(
            0.5,
            0.5,
            "the arm comes back to its reference in every ok cell:\n"
            "nothing in this model (no friction, no gap) holds it off after the payload "
            "comes off",
            transform=ax.transAxes,
            ha="center",
            va="center",
            fontsize=9,
            wrap=True,
            bbox={"fc": "white", "ec": "0.5", "alpha": 0.9, "pad": 4.0},
        )
    elif v.size:
        hi = float(v.max()) if v.max() > 0 else 1.0
        mesh = cv.draw(ax, x, y, v, v, cmap="magma_r", norm=Normalize(0.0, hi))
        cb = fig.colorbar(mesh, ax=ax, shrink=0.9)
        cb.set_label("measure point off the reference after the cycle (µm)")
        summary = (
            f"return error from {channel_value(float(v.min()), 'µm')} to "
            f"{channel_value(float(v.max()), 'µm')}, median "
            f"{channel_value(float(np.median(v)), 'µm')}"
        )
    else:
        cv.frame(ax)
    cv.legend(ax)
    cv.note(
        ax,
        sel,
        v.size,
        "largest return error",
        m,
        "the others' cycle cannot be solved",
        above=summary,
    )
    title = f"Where the arm does not come back: 0 → {m:g} kg → 0"
    fig.suptitle(_title(ds, title, m, width=7.0), fontsize=10)
    return finish(fig, path)
