"""The house style of every figure: colours, units and titles of channels, a new Agg
figure, saving it, and small layout helpers shared by the plots, maps and FE figures.
"""

from __future__ import annotations

import math
import os
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

try:
    from matplotlib.axes import Axes
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "eodarm.plots needs matplotlib: pip install 'eodarm[plot]' (or matplotlib>=3.8)"
    ) from exc

from eodarm.analysis.fit import FitResult
from eodarm.data.measurements import Measurements, channel_family, channel_link
from eodarm.errors import EodarmError
from eodarm.model.effects import Effect

__all__ = [
    "DPI",
    "GREY",
    "LABEL_BOX",
    "MARKERS",
    "PALETTE",
    "PathLike",
    "angles_text",
    "axes_grid",
    "channel_title",
    "channel_unit",
    "check_fit",
    "config_rows",
    "effect_label",
    "figure",
    "finish",
    "free_corner",
    "main_channel",
    "num",
    "short_channel",
    "source_label",
]

#: Resolution of saved PNGs (dots per inch).
DPI = 120


#: matplotlib's "tab10" colours (colour-blind friendly), in order.
PALETTE: tuple[str, ...] = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
)


#: Colour of "before"/baseline curves.
GREY = "0.45"


LABEL_BOX = {"fc": "white", "ec": "none", "alpha": 0.75, "pad": 0.5}


MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")


PathLike = str | os.PathLike[str]


# ---------------------------------------------------------------------------- helpers
def channel_unit(channel: str) -> str:
    """Unit of a channel for axis labels: ``"mm"`` or ``"deg"``."""
    return "deg" if channel_family(channel) == "dalpha_deg" else "mm"


def channel_title(channel: str) -> str:
    """Short description of a channel, e.g. ``"dy: measure point, vertical"``."""
    fam, k = channel_family(channel), channel_link(channel)
    return {
        "dx_mm": "dx: measure point, horizontal",
        "dy_mm": "dy: measure point, vertical",
        "dalpha_deg": f"dα{k}: angle of link {k}",
        "dl_mm": f"dl{k}: body of actuator {k}",
    }[fam]


def source_label(meas: Measurements) -> str:
    """The data's source, shortened to its last two path parts for titles."""
    parts = str(meas.source).replace("\\", "/").split("/")
    return "/".join(parts[-2:])


def short_channel(channel: str) -> str:
    """``dy_mm`` → ``dy``, ``dalpha2_deg`` → ``dα2``, ``dl1_mm`` → ``dl1``."""
    fam, k = channel_family(channel), channel_link(channel)
    return {"dx_mm": "dx", "dy_mm": "dy", "dalpha_deg": f"dα{k}", "dl_mm": f"dl{k}"}[fam]


def num(x: float, digits: int = 3) -> str:
    """A number for a label: ``digits`` significant figures, ``∞`` for infinity."""
    if not math.isfinite(x):
        return "∞" if x > 0 else ("−∞" if x < 0 else "n/a")
    if 10**digits <= abs(x) < 1e6:
        return f"{x:.0f}".replace("-", "−")
    return f"{x:.{digits}g}".replace("-", "−")


def effect_label(effect: Effect) -> str:
    """``"joint_clearance@O2 (clearance_mm = 0.1 mm)"``: an effect with its value and unit."""
    return f"{effect.label} ({effect.param} = {num(effect.value, 4)} {effect.kind.unit})"


def main_channel(meas: Measurements, before: FitResult | None = None) -> str:
    """The channel a one-channel view should show.

    ``dy_mm`` (the sag) when it is measured; otherwise the measured channel on which ``before``
    (usually the baseline) is worst in units of σ (largest RMS of the residual/σ); without
    ``before``, the first measured channel.

    Raises
    ------
    EodarmError
        If nothing is measured.
    """
    chans = meas.measured_channels
    if not chans:
        raise EodarmError(f"{meas.source}: no channel is measured")
    if "dy_mm" in chans:
        return "dy_mm"
    if before is None:
        return chans[0]
    z = before.z
    use = before.problem.use

    def score(ch: str) -> float:
        c = meas.index(ch)
        m = use[:, c]
        return float(np.sqrt(np.mean(z[m, c] ** 2))) if m.any() else -1.0

    return max(chans, key=score)


def figure(width: float, height: float) -> Figure:
    """A new figure on its own Agg canvas (no pyplot, no global state), laid out tightly."""
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def finish(fig: Figure, path: PathLike | None) -> Figure:
    """Save ``fig`` as PNG at :data:`DPI` when ``path`` is given; return it."""
    if path is not None:
        fig.savefig(os.fspath(path), format="png", dpi=DPI)
    return fig


def axes_grid(fig: Figure, count: int, ncols: int, **kw: Any) -> list[Axes]:
    """``count`` axes on a grid of ``ncols`` columns; the unused cells are removed.

    Where a removed cell leaves the axes above it at the bottom of their column, those
    get back their x tick labels (shared axes hide them otherwise).
    """
    nrows = math.ceil(count / ncols)
    grid = fig.subplots(nrows, ncols, squeeze=False, **kw)
    flat = list(grid.flat)
    for ax in flat[count:]:
        fig.delaxes(ax)
    if kw.get("sharex") and count < nrows * ncols and nrows > 1:
        for col in range(count % ncols, ncols):
            grid[nrows - 2, col].xaxis.set_tick_params(labelbottom=True)
    return flat[:count]


def check_fit(meas: Measurements, fit: FitResult, label: str) -> None:
    if fit.prediction.shape != meas.values.shape:
        raise EodarmError(
            f"fit '{label}' has predictions for {fit.prediction.shape[0]} rows, "
            f"the measurements have {meas.n_rows}: it was fitted to other data"
        )


def config_rows(meas: Measurements) -> list[npt.NDArray[np.intp]]:
    return [np.flatnonzero(np.asarray(meas.config) == c) for c in meas.configs]


def angles_text(alpha: npt.ArrayLike, digits: int = 0) -> str:
    """Angles as ``"86, 55, −21°"``."""
    a = np.round(np.asarray(alpha, dtype=float), digits) + 0.0  # no "−0"
    return ", ".join(f"{v:.{digits}f}".replace("-", "−") for v in a) + "°"


def free_corner(
    x: npt.ArrayLike, y: npt.ArrayLike, lim: tuple[float, float]
) -> Literal["upper left", "lower right"]:
    """``"upper left"`` or ``"lower right"``: the corner of a square panel with fewer points."""
    span = lim[1] - lim[0] or 1.0
    u = (np.asarray(x, dtype=float) - lim[0]) / span
    v = (np.asarray(y, dtype=float) - lim[0]) / span
    upper_left = int(np.sum((u < 0.55) & (v > 0.6)))
    lower_right = int(np.sum((u > 0.45) & (v < 0.4)))
    return "upper left" if upper_left <= lower_right else "lower right"
