"""The loops of load sequences: a channel against payload, loading and unloading.

One panel per sequence (config label of a file with a ``step`` column): the measured states
with ±1σ bars, joined in the order they were applied with arrows for the direction, the model
before (grey, dashed) and after (coloured, solid) the fit, and the value left at the return to
zero payload. Numbers from :func:`eodarm.analysis.sequences.hysteresis`.
"""

from __future__ import annotations

import itertools
import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from matplotlib.collections import LineCollection

from eodarm.analysis.sequences import hysteresis
from eodarm.errors import EodarmError
from eodarm.viz.format import channel_value
from eodarm.viz.style import (
    GREY,
    PALETTE,
    PathLike,
    axes_grid,
    channel_title,
    channel_unit,
    check_fit,
    figure,
    finish,
    main_channel,
    short_channel,
)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from eodarm.analysis.fit import FitResult
    from eodarm.data.measurements import Measurements

__all__ = ["loops"]

FloatArray = npt.NDArray[np.float64]

#: Most panels drawn (the first sequences of the file); the text output has every one.
MAX_PANELS = 12


def _once(m: FloatArray, y: FloatArray) -> list[list[tuple[float, float]]]:
    """The path (m, y) as segments, each drawn once: a model without memory goes back down
    its loading branch, and a dashed line drawn twice over itself, in opposite directions,
    has its dashes fill each other's gaps and reads as solid."""
    seen: list[tuple[float, float, float, float]] = []
    out = []
    span = float(np.nanmax(np.abs(y))) if np.isfinite(y).any() else 1.0
    tol = 1e-9 * max(span, 1e-12)
    for a, b in itertools.pairwise(range(len(m))):
        seg = (float(m[a]), float(y[a]), float(m[b]), float(y[b]))
        if not all(math.isfinite(v) for v in seg):
            continue
        back = (seg[2], seg[3], seg[0], seg[1])
        if any(
            all(abs(u - v) <= tol for u, v in zip(s, t, strict=True))
            for t in seen
            for s in (seg, back)
        ):
            continue
        seen.append(seg)
        out.append([(seg[0], seg[1]), (seg[2], seg[3])])
    return out


def loops(
    meas: Measurements,
    before: FitResult,
    after: FitResult,
    channel: str | None = None,
    path: PathLike | None = None,
    panel_width: float = 3.0,
) -> Figure:
    """The hysteresis loops of one channel (default the sag ``dy_mm``) against payload.

    Parameters
    ----------
    meas : measurements with a ``step`` column.
    before, after : two fits to ``meas`` (the baseline and the fitted model); the same model
        twice draws it once.
    channel : the channel drawn; default :func:`main_channel`.
    path : where to write a PNG; nothing is written when ``None``.
    panel_width : inches per panel (the report draws them larger, 4.2).

    Returns
    -------
    Figure
        One axes per sequence (at most :data:`MAX_PANELS`), payload (kg) on x.

    Raises
    ------
    EodarmError
        When the data have no load sequences or the channel is not measured.
    """
    check_fit(meas, before, "before")
    check_fit(meas, after, "after")
    if not meas.has_sequences:
        raise EodarmError("loops: the measurements have no step column (no load sequences)")
    ch = channel or main_channel(meas, before)
    if ch not in meas.measured_channels:
        raise EodarmError(f"loops: channel '{ch}' is not measured")
    seqs = hysteresis(meas, after.prediction, before.prediction)[:MAX_PANELS]
    same = after is before or np.array_equal(before.prediction, after.prediction, equal_nan=True)
    k = len(seqs)
    ncols = min(4, math.ceil(math.sqrt(k)))
    nrows = math.ceil(k / ncols)
    fig = figure(max(panel_width * ncols, 6.5), 0.87 * panel_width * nrows + 1.3)
    axes = axes_grid(fig, k, ncols, sharex=True)
    unit = channel_unit(ch)
    name = short_channel(ch)
    for ax, h in zip(axes, seqs, strict=True):
        j = list(h["channels"]).index(ch)  # type: ignore[call-overload]
        m = np.concatenate([[0.0], np.asarray(h["mass_kg"], dtype=float)])
        y = np.concatenate([[0.0], np.asarray(h["measured"])[:, j]])  # type: ignore[call-overload]
        s = np.concatenate([[0.0], np.asarray(h["sigma"])[:, j]])  # type: ignore[call-overload]
        ya = np.concatenate([[0.0], np.asarray(h["model"])[:, j]])  # type: ignore[call-overload]
        yb = np.concatenate([[0.0], np.asarray(h["before"])[:, j]])  # type: ignore[call-overload]
        if not same:
            dashed = LineCollection(
                _once(m, yb), linestyles=[(0, (5, 3))], colors=GREY, linewidths=1.3, zorder=3
            )
            dashed.set_gid("before")
            ax.add_collection(dashed)
        ax.plot(m, ya, ls="-", color=PALETTE[0], lw=2.2, alpha=0.85, gid="after", zorder=2)
        ok = np.isfinite(y)
        ax.errorbar(
            m[ok], y[ok], yerr=s[ok], fmt="o", ms=4, color="k", ecolor="k", capsize=2,
            lw=0.8, gid="measured", zorder=3,
        )  # fmt: skip
        # arrows along the measured path, in the order the payloads were applied
        idx = np.flatnonzero(ok)
        for a, b in itertools.pairwise(idx.tolist()):
            ax.annotate(
                "",
                xy=(m[b], y[b]),
                xytext=(m[a], y[a]),
                arrowprops={"arrowstyle": "-|>", "color": "0.15", "lw": 0.7,
                            "shrinkA": 4, "shrinkB": 4, "mutation_scale": 9},
                gid="direction",
                zorder=4,
            )  # fmt: skip
        ax.plot([0.0], [0.0], "s", color="k", ms=4, mfc="white", gid="reference")
        left = h["left"]
        title = str(h["config"])
        if isinstance(left, dict) and ch in left:
            lm, lmod = left[ch]
            title += f": left {channel_value(lm, unit)} (model {channel_value(lmod, unit)})"
        ax.set_title(title, fontsize=9)
        ax.axhline(0.0, color="k", lw=0.5)
    for ax in axes[-ncols:]:
        ax.set_xlabel("payload [kg]")
    for ax in axes[::ncols]:
        ax.set_ylabel(f"{name} [{unit}]")
    more = f" (first {MAX_PANELS} of {len(meas.sequences())})" if k < len(meas.sequences()) else ""
    head = f"{channel_title(ch)} against payload, per load sequence{more}\n"
    head += "measured ±1σ (black; arrows in the order applied), model "
    head += "before (grey, dashed) and after (blue)" if not same else "(blue)"
    fig.suptitle(head, fontsize=10)
    return finish(fig, path)
