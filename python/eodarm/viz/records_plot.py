"""The figure of one raw record: every channel against time, the steady states found, the
payload matched to each and the samples averaged (docs/records.md).

Each channel has its own panel. The record is drawn in grey (as the band between each time
bin's lowest and highest sample when there are more samples than pixels); each steady state is
shaded, its averaged samples drawn in colour with their mean as a black line, its payload
written above it. A refused state (one that drifts) is shaded red; when the states could not
be matched to the payloads at all, every state is shaded orange and the reason is the title.
A trend (a part that moves steadily, never a state) is hatched grey and labelled "trend".
"""

from __future__ import annotations

import textwrap

import numpy as np
import numpy.typing as npt

from eodarm.analysis.records import RecordResult
from eodarm.data.records import Record
from eodarm.viz.style import PALETTE, PathLike, channel_unit, figure, finish, short_channel

try:
    from matplotlib.figure import Figure
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError("eodarm's figures need matplotlib>=3.8") from exc

__all__ = ["record_figure"]

#: Most points drawn per line: beyond it, each time bin is drawn as its min–max band.
MAX_POINTS = 3000

GOOD = "#2ca02c"
REFUSED = "#d62728"
UNMATCHED = "#ff7f0e"
TREND = "#7f7f7f"


def _envelope(
    t: npt.NDArray[np.float64], y: npt.NDArray[np.float64]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]] | None:
    """(bin times, lowest, highest) of ``y`` in :data:`MAX_POINTS` bins, or None when the
    samples are few enough to draw one by one."""
    n = y.size
    if n <= MAX_POINTS:
        return None
    b = n // MAX_POINTS
    m = (n // b) * b
    yy = y[:m].reshape(-1, b)
    return t[:m].reshape(-1, b)[:, 0], yy.min(axis=1), yy.max(axis=1)


def _line(ax: object, t: npt.NDArray[np.float64], y: npt.NDArray[np.float64], **kw: object) -> None:
    env = _envelope(t, y)
    if env is None:
        ax.plot(t, y, **kw)  # type: ignore[attr-defined]
    else:
        # a thin band (a smooth ramp) still shows: its edge is drawn
        ax.fill_between(env[0], env[1], env[2], color=kw.get("color"), lw=kw.get("lw", 0.6))  # type: ignore[attr-defined]


def record_figure(record: Record, result: RecordResult, path: PathLike | None = None) -> Figure:
    """The figure of ``record`` and its steady states; saved as PNG when ``path`` is given.

    Parameters
    ----------
    record : the record's samples.
    result : its steady states (:func:`eodarm.analysis.records.analyse_record`).
    path : where to save the PNG.
    """
    chans = record.channels
    c = len(chans)
    fig = figure(10.0, 1.0 + 1.55 * c)
    axes = fig.subplots(c, 1, sharex=True, squeeze=False)[:, 0]
    t = record.time_s
    masses = result.spec.masses_kg
    matched = len(result.states) == len(masses)
    for j, (ax, ch) in enumerate(zip(axes, chans, strict=True)):
        y = record.values[:, j]
        _line(ax, t, y, color="0.6", lw=0.6)
        for k, s in enumerate(result.states):
            if not matched:
                shade = UNMATCHED
            elif k in result.refused_states:
                shade = REFUSED
            else:
                shade = GOOD
            ax.axvspan(t[s.span[0]], t[s.span[1]], color=shade, alpha=0.12, lw=0)
            colour = REFUSED if k in result.refused_states else PALETTE[0]
            _line(ax, t[s.start : s.stop], y[s.start : s.stop], color=colour, lw=0.8)
            ax.hlines(s.mean[j], s.t0, s.t1, color="black", lw=1.2)
        for tr in result.trends:
            ax.axvspan(
                t[tr.span[0]],
                t[tr.span[1]],
                facecolor="none",
                edgecolor=TREND,
                hatch="//",
                lw=0,
                alpha=0.25,
                zorder=0,
            )
        ax.set_ylabel(f"{short_channel(ch)} ({channel_unit(ch)})")
        ax.grid(alpha=0.3)
        ax.margins(x=0.01)
    top = axes[0]

    def label(text: str, t0: float, t1: float, color: str) -> None:
        top.annotate(
            text,
            xy=((t0 + t1) / 2, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(0, 3),
            textcoords="offset points",
            ha="center",
            va="bottom",
            fontsize=8,
            color=color,
        )

    for k, s in enumerate(result.states):
        if matched:
            text = ("ref " if k == 0 else "") + f"{masses[k]:g} kg"
            if s.drift:
                text += " (drifts)"
        else:
            text = f"state {k + 1}"
        refused = k in result.refused_states or not matched
        label(text, s.t0, s.t1, REFUSED if refused else "black")
    for tr in result.trends:
        label("trend", tr.t0, tr.t1, TREND)
    axes[-1].set_xlabel("time (s)")
    name = f"{result.spec.config}: {record.path.name}"
    if result.refused:
        title = "refused: " + result.refused.split(": ", 1)[-1]
        fig.suptitle("\n".join(textwrap.wrap(f"{name}, {title}", 110)), color=REFUSED, fontsize=10)
    else:
        fig.suptitle(
            f"{name}: {len(result.states)} steady states (shaded; coloured: the samples "
            "averaged; black: their mean)",
            fontsize=10,
        )
    return finish(fig, path)


#: The report's appendix draws at most this many records (a figure is ~0.3 MB of the page).
MAX_REPORT_RECORDS = 20


def record_html(record: Record, result: RecordResult) -> str:
    """The record's figure as an embedded PNG with its caption, for the report's appendix."""
    from eodarm.viz.html import img

    fig = record_figure(record, result)
    rows = len(result.rows)
    caption = (
        f"{result.spec.config} ({record.path.name}): {record.time_s.size} samples, "
        f"{len(result.states)} steady states; {rows} rows written, each state's mean minus the "
        "reference's (shaded: the state; coloured: the samples averaged)."
    )
    return img(fig, f"record {result.spec.config}", caption)


def records_appendix(figures: list[str], total: int) -> str:
    """The report's appendix: the records' figures (``figures``, from :func:`record_html`)
    of a campaign of ``total`` records."""
    more = (
        f" The first {len(figures)} of {total} records are shown." if total > len(figures) else ""
    )
    return (
        "<p>The measurements were found by <code>eodarm records</code> in the raw records of "
        "the campaign: each steady state's mean minus the reference's, with the standard error "
        f"of that difference, correlation in time included (docs/records.md).{more}</p>"
        + "\n".join(figures)
    )
