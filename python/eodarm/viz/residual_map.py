"""The residual pattern a model leaves, as heat maps: configuration × payload, per channel.

When no effect of the catalogue explains the data, this is the picture of what is missing:
each panel is one measured channel, each cell the mean of (measured − model)/σ over the
states of that configuration and payload. Red: the arm went further (more positive) than the
model says; blue: less far. A pattern that grows with payload in some poses and not others,
or flips sign between them, is the shape a missing mechanism would have to have.
"""

from __future__ import annotations

import math

import numpy as np

try:
    from matplotlib.colors import SymLogNorm
    from matplotlib.figure import Figure
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "eodarm.plots needs matplotlib: pip install 'eodarm[plot]' (or matplotlib>=3.8)"
    ) from exc

from eodarm.analysis.fit import FitResult
from eodarm.analysis.residuals import ResidualPattern, residual_pattern
from eodarm.viz.style import PathLike, axes_grid, figure, finish, num, short_channel

__all__ = ["residual_map"]

#: Below this many σ a cell is noise: the colour scale is linear within it, logarithmic
#: beyond, so that a 3σ pattern and a 300σ one are both visible on one scale.
LINEAR_Z = 2.0

#: Background of a cell without used values (not measured, or left out as an outlier).
NOT_MEASURED = "0.82"


def _cell(v: float) -> str:
    if not math.isfinite(v):
        return ""
    if abs(v) < 9.95:
        return f"{v:+.1f}".replace("-", "−")
    return num(v, 2)


def residual_map(
    fit: FitResult | ResidualPattern,
    title: str | None = None,
    path: PathLike | None = None,
) -> Figure:
    """Mean residual/σ per configuration (rows) × payload (columns), one panel per channel.

    Parameters
    ----------
    fit : the fit whose residuals are shown, or its :func:`residual_pattern`.
    title : the figure's title; default names what is shown.
    path : where to write a PNG (120 dpi); nothing is written when ``None``.

    Returns
    -------
    Figure
        One heat map per channel with used cells (``gid`` = the channel name), sharing one
        diverging colour scale in units of σ (linear within ±2σ, logarithmic beyond) and a
        colour bar; cells are annotated with their value when the grid is small enough to
        read; cells without a used value are grey. Each panel's title gives the channel's RMS
        residual/σ.
    """
    pat = fit if isinstance(fit, ResidualPattern) else residual_pattern(fit)
    k = len(pat.channels)
    ncols = min(4, max(k, 1))
    nconf, npay = len(pat.configs), len(pat.payloads)
    cell_h = min(0.32, 5.0 / max(nconf, 1))
    panel_h = 0.9 + cell_h * nconf
    panel_w = max(1.9, 0.55 * npay + 1.2)
    nrows = max(math.ceil(k / ncols), 1)
    fig = figure(max(panel_w * ncols + 1.2, 6.5), panel_h * nrows + 1.1)
    if k == 0:
        fig.suptitle("no measured channel: nothing is left to show")
        return finish(fig, path)
    axes = axes_grid(fig, k, ncols, sharex=True, sharey=True)
    finite = np.abs(pat.mean_z[np.isfinite(pat.mean_z)])
    vmax = max(float(finite.max(initial=0.0)), 3.0)
    norm = SymLogNorm(linthresh=LINEAR_Z, linscale=1.0, vmin=-vmax, vmax=vmax, base=10)
    annotate = nconf * npay <= 60
    image = None
    for j, (ax, ch) in enumerate(zip(axes, pat.channels, strict=True)):
        grid = pat.mean_z[:, :, j]
        image = ax.imshow(
            np.ma.masked_invalid(grid),
            cmap="RdBu_r",
            norm=norm,
            aspect="auto",
            interpolation="nearest",
        )
        image.set_gid(ch)
        ax.set_facecolor(NOT_MEASURED)
        if annotate:
            for r in range(nconf):
                for c in range(npay):
                    v = float(grid[r, c])
                    if not math.isfinite(v):
                        continue
                    strong = abs(v) > 0.35 * vmax and abs(v) > 3 * LINEAR_Z
                    ax.text(
                        c,
                        r,
                        _cell(v),
                        ha="center",
                        va="center",
                        fontsize="x-small",
                        color="white" if strong else "0.15",
                    )
        ax.set_title(f"{short_channel(ch)}: RMS {num(float(pat.rms_z[j]), 2)}σ", fontsize="small")
        ax.set_xticks(range(npay), [num(m, 3) for m in pat.payloads])
        ax.set_yticks(range(nconf), list(pat.configs))
        ax.tick_params(labelsize="x-small", length=2)
        if j % ncols == 0:
            ax.set_ylabel("configuration", fontsize="small")
        if j + ncols >= k:
            ax.set_xlabel("payload [kg]", fontsize="small")
    if image is not None:
        bar = fig.colorbar(image, ax=axes, shrink=0.9, pad=0.02)
        ticks = [0.0]
        t = LINEAR_Z
        while t <= vmax * 1.0001:
            ticks += [t, -t]
            t = 10.0 ** (math.floor(math.log10(t)) + 1)
        bar.set_ticks(sorted(ticks), labels=[num(v, 3) for v in sorted(ticks)])
        bar.minorticks_off()
        bar.set_label("mean (measured − model)/σ", fontsize="small")
        bar.ax.tick_params(labelsize="x-small")
    fig.suptitle(
        title
        or "What the model leaves: mean residual/σ per configuration × payload, per channel\n"
        f"(colour linear within ±{LINEAR_Z:g}σ, logarithmic beyond; red: measured above the "
        "model; grey: no value)",
        fontsize="medium",
    )
    return finish(fig, path)
