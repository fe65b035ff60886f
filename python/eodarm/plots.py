"""Figures of a diagnosis: model against measurement, residuals, the error ladder, who sags.

Every function builds a new :class:`matplotlib.figure.Figure` on the non-interactive Agg
canvas and returns it. Nothing is shown and no global matplotlib state (pyplot, rcParams,
the backend) is touched, so the functions are safe in scripts, tests and servers. A figure is
written only when ``path=`` is given: then as a PNG at 120 dpi, and it is still returned.

>>> from eodarm import plots
>>> fig = plots.measured_vs_model(meas, {"baseline": f0, "fitted": f1})  # doctest: +SKIP
>>> fig.savefig("mvm.png")                                                # doctest: +SKIP

Colours come from matplotlib's colour-blind-friendly "tab10" cycle; "before" curves are grey
and dashed so that they stay distinguishable without colour.
"""

from __future__ import annotations

import math
import os
import textwrap
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

try:
    from matplotlib.axes import Axes
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Polygon
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "eodarm.plots needs matplotlib: pip install 'eodarm[plot]' (or matplotlib>=3.8)"
    ) from exc

from .arm import Arm
from .effects import Effect
from .errors import EodarmError
from .fit import FitResult
from .measurements import Measurements, channel_family, channel_link
from .solver import forward, solve

__all__ = [
    "DPI",
    "PALETTE",
    "arm_pose",
    "channel_title",
    "channel_unit",
    "deflection_share",
    "effect_label",
    "ladder",
    "main_channel",
    "measured_vs_model",
    "residual_vs_payload",
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
_LABEL_BOX = {"fc": "white", "ec": "none", "alpha": 0.75, "pad": 0.5}
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")

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


def _source(meas: Measurements) -> str:
    """The data's source, shortened to its last two path parts for titles."""
    parts = str(meas.source).replace("\\", "/").split("/")
    return "/".join(parts[-2:])


def _short(channel: str) -> str:
    """``dy_mm`` → ``dy``, ``dalpha2_deg`` → ``dα2``, ``dl1_mm`` → ``dl1``."""
    fam, k = channel_family(channel), channel_link(channel)
    return {"dx_mm": "dx", "dy_mm": "dy", "dalpha_deg": f"dα{k}", "dl_mm": f"dl{k}"}[fam]


def _num(x: float, digits: int = 3) -> str:
    """A number for a label: ``digits`` significant figures, ``∞`` for infinity."""
    if not math.isfinite(x):
        return "∞" if x > 0 else ("−∞" if x < 0 else "n/a")
    if 10**digits <= abs(x) < 1e6:
        return f"{x:.0f}".replace("-", "−")
    return f"{x:.{digits}g}".replace("-", "−")


def effect_label(effect: Effect) -> str:
    """``"joint_clearance@O2 (clearance_mm = 0.1 mm)"``: an effect with its value and unit
    (``"actuator_play@M1 (taken up) (play_mm = 0.05 mm)"`` for a gap taken up when unloaded)."""
    return f"{effect.label} ({effect.param} = {_num(effect.value, 4)} {effect.kind.unit})"


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


def _figure(width: float, height: float) -> Figure:
    """A new figure on its own Agg canvas (no pyplot, no global state), laid out tightly."""
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _finish(fig: Figure, path: PathLike | None) -> Figure:
    """Save ``fig`` as PNG at :data:`DPI` when ``path`` is given; return it."""
    if path is not None:
        fig.savefig(os.fspath(path), format="png", dpi=DPI)
    return fig


def _grid(fig: Figure, count: int, ncols: int, **kw: Any) -> list[Axes]:
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


def _check_fit(meas: Measurements, fit: FitResult, label: str) -> None:
    if fit.prediction.shape != meas.values.shape:
        raise EodarmError(
            f"fit '{label}' has predictions for {fit.prediction.shape[0]} rows, "
            f"the measurements have {meas.n_rows}: it was fitted to other data"
        )


def _config_rows(meas: Measurements) -> list[npt.NDArray[np.intp]]:
    return [np.flatnonzero(np.asarray(meas.config) == c) for c in meas.configs]


def _angles(alpha: npt.ArrayLike, digits: int = 0) -> str:
    """Angles as ``"86, 55, −21°"``."""
    a = np.round(np.asarray(alpha, dtype=float), digits) + 0.0  # no "−0"
    return ", ".join(f"{v:.{digits}f}".replace("-", "−") for v in a) + "°"


def _free_corner(
    x: npt.ArrayLike, y: npt.ArrayLike, lim: tuple[float, float]
) -> Literal["upper left", "lower right"]:
    """``"upper left"`` or ``"lower right"``: the corner of a square panel with fewer points."""
    span = lim[1] - lim[0] or 1.0
    u = (np.asarray(x, dtype=float) - lim[0]) / span
    v = (np.asarray(y, dtype=float) - lim[0]) / span
    upper_left = int(np.sum((u < 0.55) & (v > 0.6)))
    lower_right = int(np.sum((u > 0.45) & (v < 0.4)))
    return "upper left" if upper_left <= lower_right else "lower right"


# ---------------------------------------------------------------------------- figures
def measured_vs_model(
    meas: Measurements,
    fits: Mapping[str, FitResult],
    path: PathLike | None = None,
) -> Figure:
    """Measured against model value of every measured channel, one panel per channel.

    Parameters
    ----------
    meas : the measurements.
    fits : label → fit of a model to ``meas`` (e.g. ``{"baseline": f0, "fitted": f1}``).
        Each is drawn in its own colour and marker, with ±σ error bars on the measured value.
    path : where to write a PNG (120 dpi); nothing is written when ``None``.

    Returns
    -------
    Figure
        One axes per measured channel (in channel order) with the line y = x; each panel's
        legend gives every fit's RMS residual on that channel (mm or deg). Cells a fit left out
        (outliers) are ringed in black.
    """
    chans = meas.measured_channels
    if not chans:
        raise EodarmError(f"{meas.source}: no channel is measured")
    if not fits:
        raise EodarmError("measured_vs_model: give at least one fit")
    for label, f in fits.items():
        _check_fit(meas, f, label)
    ncols = min(3, len(chans))
    nrows = math.ceil(len(chans) / ncols)
    fig = _figure(4.3 * ncols, 4.1 * nrows + 0.5)
    axes = _grid(fig, len(chans), ncols)
    for ax, ch in zip(axes, chans, strict=True):
        c = meas.index(ch)
        m = meas.measured[:, c]
        x = meas.values[m, c]
        sig = meas.sigma[m, c]
        unit = channel_unit(ch)
        lo, hi = float(np.min(x - sig)), float(np.max(x + sig))
        for j, (label, f) in enumerate(fits.items()):
            y = f.prediction[m, c]
            rms = f.rms().get(ch, math.nan)
            colour = PALETTE[j % len(PALETTE)]
            cont = ax.errorbar(
                x,
                y,
                xerr=sig,
                fmt=_MARKERS[j % len(_MARKERS)],
                ms=4.5,
                mfc="none" if j == 0 and len(fits) > 1 else colour,
                color=colour,
                elinewidth=0.9,
                capsize=0,
                alpha=0.9,
                label=f"{label}: RMS {_num(rms)} {unit}",
                zorder=3 + j,
            )
            cont.lines[0].set_gid(f"model:{label}")
            out = ~f.problem.use[m, c]
            if out.any():
                ringed = j > 0 and any(
                    (~g.problem.use[m, c]).any() for g in list(fits.values())[:j]
                )
                ax.plot(
                    x[out],
                    y[out],
                    "o",
                    ms=10,
                    mfc="none",
                    mec="k",
                    label="_left out" if ringed else "left out of the fit (outlier)",
                    zorder=10,
                )
            finite = y[np.isfinite(y)]
            if finite.size:
                lo, hi = min(lo, float(finite.min())), max(hi, float(finite.max()))
        pad = 0.06 * (hi - lo) if hi > lo else max(abs(hi), 1e-3) * 0.1
        lim = (lo - pad, hi + pad)
        ax.plot(lim, lim, color="k", lw=0.9, ls=":", label="y = x", zorder=1)
        ax.set_xlim(lim)
        ax.set_ylim(lim)
        ax.set_box_aspect(1)
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.set_title(channel_title(ch), fontsize="medium")
        ax.set_xlabel(f"measured {_short(ch)} [{unit}]")
        ax.set_ylabel(f"model {_short(ch)} [{unit}]")
        ys = np.concatenate([f.prediction[m, c] for f in fits.values()])
        xs = np.tile(x, len(fits))
        ax.legend(fontsize="small", loc=_free_corner(xs, ys, lim), framealpha=0.85)
    fig.suptitle(f"Measured vs model ({_source(meas)}, {meas.n_rows} states; bars ±σ)")
    return _finish(fig, path)


def residual_vs_payload(
    meas: Measurements,
    before: FitResult,
    after: FitResult,
    channel: str | None = None,
    path: PathLike | None = None,
) -> Figure:
    """Residual (measured − model) of one channel against payload, one panel per configuration.

    Parameters
    ----------
    meas : the measurements.
    before, after : two fits to ``meas`` (typically the baseline and the fitted model); the
        same fit object twice draws that one model alone.
    channel : the channel; default :func:`main_channel` (``dy_mm`` when measured, else the
        channel with the largest baseline RMS in units of σ).
    path : where to write a PNG (120 dpi); nothing is written when ``None``.

    Returns
    -------
    Figure
        One axes per configuration (shared axes): ``before`` grey, dashed, open markers;
        ``after`` coloured and solid; a shaded ±1σ band of the measurement around zero. Each
        panel states both RMS values of its configuration.
    """
    _check_fit(meas, before, "before")
    _check_fit(meas, after, "after")
    ch = channel or main_channel(meas, before)
    if ch not in meas.measured_channels:
        raise EodarmError(
            f"residual_vs_payload: channel '{ch}' is not measured "
            f"(measured: {', '.join(meas.measured_channels)})"
        )
    c = meas.index(ch)
    unit = channel_unit(ch)
    configs = meas.configs
    k = len(configs)
    ncols = min(4, math.ceil(math.sqrt(k)))
    nrows = math.ceil(k / ncols)
    fig = _figure(max(2.9 * ncols, 6.5), 2.35 * nrows + 1.2)
    axes = _grid(fig, k, ncols, sharex=True, sharey=True)
    res_b, res_a = before.residual[:, c], after.residual[:, c]
    same = after is before  # one model only: draw it once
    left_out = False
    for i, (ax, label, rows) in enumerate(zip(axes, configs, _config_rows(meas), strict=True)):
        rows = rows[meas.measured[rows, c]]
        rows = rows[np.argsort(meas.mass_kg[rows], kind="stable")]
        m = meas.mass_kg[rows]
        sig = meas.sigma[rows, c]
        if np.unique(m).size > 1:
            ax.fill_between(m, -sig, sig, color=PALETTE[0], alpha=0.15, lw=0)
        elif rows.size:
            ax.axhspan(-float(sig.max()), float(sig.max()), color=PALETTE[0], alpha=0.15, lw=0)
        ax.axhline(0.0, color="k", lw=0.6)
        if not same:
            ax.plot(m, res_b[rows], ls="--", marker="o", mfc="none", color=GREY, ms=5, gid="before")
        ax.plot(m, res_a[rows], ls="-", marker="o", color=PALETTE[0], ms=4.5, gid="after")
        out = ~after.problem.use[rows, c]
        if out.any():
            ax.plot(m[out], res_a[rows][out], "o", ms=10, mfc="none", mec="k", gid="left_out")
            left_out = True
        rb = float(np.sqrt(np.mean(res_b[rows] ** 2))) if rows.size else math.nan
        ra = float(np.sqrt(np.mean(res_a[rows] ** 2))) if rows.size else math.nan
        ax.text(
            0.03,
            0.04,
            f"RMS {_num(ra, 2)} {unit}" if same else f"RMS {_num(rb, 2)} → {_num(ra, 2)} {unit}",
            transform=ax.transAxes,
            fontsize="x-small",
            color="0.2",
            bbox={"fc": "white", "ec": "none", "alpha": 0.7, "pad": 1.0},
        )
        first = meas.alpha_deg[rows[0]] if rows.size else meas.alpha_deg[0]
        ax.set_title(f"{label}: α = {_angles(first)}", fontsize="small")
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.tick_params(labelsize="small")
        if i % ncols == 0:
            ax.set_ylabel(f"residual {_short(ch)} [{unit}]", fontsize="small")
        if i + ncols >= k:
            ax.set_xlabel("payload [kg]", fontsize="small")
    # Before and after differ by orders of magnitude; on a linear axis the ±σ band and the
    # fitted residuals would be a flat line. Linear within ±3σ, logarithmic beyond.
    s0 = float(np.nanmedian(meas.sigma[meas.measured[:, c], c]))
    both = np.abs(np.concatenate([res_b, res_a]))
    worst = float(np.max(both[np.isfinite(both)], initial=0.0))
    symlog = worst > 30 * s0
    if symlog:
        lin = 3 * s0
        ticks = [0.0, lin, -lin]
        p = 10.0 ** math.ceil(math.log10(2 * lin))
        while p <= 1.5 * worst:
            ticks += [p, -p]
            p *= 10
        for ax in axes:
            ax.set_yscale("symlog", linthresh=lin, linscale=1.5)
            ax.yaxis.set_major_locator(FixedLocator(sorted(ticks)))
            ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: _num(v, 2)))
            ax.yaxis.set_minor_locator(NullLocator())
    handles = [
        Line2D([], [], ls="--", marker="o", mfc="none", color=GREY),
        Line2D([], [], ls="-", marker="o", color=PALETTE[0]),
        Patch(color=PALETTE[0], alpha=0.15),
    ]
    names = [
        f"before: {_model_name(before)} (RMS {_num(before.rms().get(ch, math.nan))} {unit})",
        f"after: {_model_name(after)} (RMS {_num(after.rms().get(ch, math.nan))} {unit})",
        "±1σ of the measurement",
    ]
    if same:
        del handles[0], names[0]
        names[0] = f"{_model_name(after)} (RMS {_num(after.rms().get(ch, math.nan))} {unit})"
    if left_out:
        handles.append(Line2D([], [], ls="none", marker="o", ms=10, mfc="none", mec="k"))
        names.append("left out of the fit (outlier)")
    names = [textwrap.fill(nm, 70) for nm in names]
    fig.legend(
        handles,
        names,
        loc="outside lower center",
        ncols=1 if max(map(len, names)) > 60 else 2,
        fontsize="small",
    )
    title = f"Residual of {_short(ch)} (measured − model) against payload, per configuration"
    if symlog:
        title += f"\ny axis linear within ±3σ (±{_num(3 * s0, 2)} {unit}), logarithmic beyond"
    fig.suptitle(title)
    return _finish(fig, path)


def _model_name(fit: FitResult) -> str:
    """The effects a fit carries, or ``"baseline"``."""
    keys = [e.key for e in fit.fixed] + [s.key for s in fit.slots]
    return "baseline" if not keys else "baseline + " + ", ".join(keys)


def ladder(
    steps: Sequence[Mapping[str, Any]],
    channel: str = "dy_mm",
    path: PathLike | None = None,
) -> Figure:
    """The error falling as effects are added: RMS, cross-validated RMS and χ²/dof per step.

    Parameters
    ----------
    steps : one dict per model, in order: ``{"label": str, "rms": {channel: float},
        "cv_rms": {channel: float} | None, "chi2_per_dof": float}``
        (:func:`eodarm.report.build_ladder` makes them).
    channel : the channel whose RMS is drawn.
    path : where to write a PNG (120 dpi); nothing is written when ``None``.

    Returns
    -------
    Figure
        One axes: RMS (solid) and leave-one-configuration-out RMS (dashed, where given) of
        ``channel`` in its unit, each value written beside its marker; χ²/dof on a secondary
        logarithmic axis (dotted, with the line χ²/dof = 1). The RMS axis is logarithmic when
        the values span more than a factor of 20.
    """
    if not steps:
        raise EodarmError("ladder: no steps")
    for s in steps:
        if channel not in s["rms"]:
            raise EodarmError(f"ladder: step '{s['label']}' has no RMS for channel '{channel}'")
    unit = channel_unit(channel)
    labels = [str(s["label"]) for s in steps]
    x = np.arange(len(steps), dtype=float)
    rms = np.array([float(s["rms"][channel]) for s in steps])
    cv = np.array(
        [
            float(s["cv_rms"][channel])
            if s.get("cv_rms") is not None and channel in s["cv_rms"]
            else math.nan
            for s in steps
        ]
    )
    chi = np.array([float(s["chi2_per_dof"]) for s in steps])

    width = max(6.5, 2.1 * len(steps) + 2.5)
    # Rotate the step labels when they would not fit side by side (about 0.085 in a character).
    long = max(len(lb) for lb in labels) * 0.085 > 0.95 * (width - 2.0) / len(steps)
    fig = _figure(width, 5.2 if long else 4.6)
    ax = fig.add_subplot()
    ax.plot(x, rms, "-o", color=PALETTE[0], lw=2, ms=6, label=f"RMS {_short(channel)}", gid="rms")
    values = [rms]
    if np.isfinite(cv).any():
        ax.plot(
            x,
            cv,
            "--s",
            color=PALETTE[1],
            lw=1.6,
            ms=5,
            label=f"cross-validated RMS {_short(channel)} (leave one configuration out)",
            gid="cv_rms",
        )
        values.append(cv)
    allv = np.concatenate(values)
    allv = allv[np.isfinite(allv) & (allv > 0)]
    if allv.size and allv.max() / allv.min() > 20:
        ax.set_yscale("log")
        ax.set_ylim(allv.min() / 1.8, allv.max() * 2.5)
    elif allv.size:
        ax.set_ylim(0.0, allv.max() * 1.25)
    for xi, r, c in zip(x, rms, cv, strict=True):
        show_cv = math.isfinite(c) and abs(c - r) > 0.02 * abs(r)
        cv_below = show_cv and c <= r
        ax.annotate(
            _num(r),
            (xi, r),
            textcoords="offset points",
            xytext=(8, -12 if show_cv and not cv_below else 4),
            fontsize="small",
            color=PALETTE[0],
            bbox=_LABEL_BOX,
            zorder=6,
        )
        if show_cv:
            ax.annotate(
                _num(c),
                (xi, c),
                textcoords="offset points",
                xytext=(8, -12 if cv_below else 4),
                fontsize="small",
                color=PALETTE[1],
                bbox=_LABEL_BOX,
                zorder=6,
            )
    ax.set_ylabel(f"RMS of {_short(channel)} residual [{unit}]")
    # Long labels ("+ a@M1 + b@M2 + c@M3") are wrapped at the "+" into lines, never rotated:
    # a rotated label of 70 characters takes more room than the plot.
    width = max(14, int(90 / max(len(steps), 1)))

    def wrap(lb: str) -> str:
        if len(lb) <= width:
            return lb
        words = lb.replace(" + ", " +\u00a0").split(" ")
        return textwrap.fill(" ".join(words), width).replace("\u00a0", " ")

    ax.set_xticks(x, [f"{wrap(lb)}\nχ²/dof {_num(v)}" for lb, v in zip(labels, chi, strict=True)])
    ax.set_xlim(-0.45, len(steps) - 0.55)
    ax.grid(True, lw=0.4, alpha=0.5)

    ax2 = ax.twinx()
    ax2.plot(
        x,
        chi,
        ":D",
        color=PALETTE[2],
        lw=1.0,
        alpha=0.8,
        ms=6,
        label="χ²/dof (right axis; values under the steps)",
        gid="chi2",
    )
    ax2.axhline(1.0, color=PALETTE[2], lw=0.8, alpha=0.6, ls="-.")
    ax2.set_yscale("log")
    finite = chi[np.isfinite(chi) & (chi > 0)]
    if finite.size:
        ax2.set_ylim(min(0.4, finite.min() / 2.5), max(2.5, finite.max() * 4))
    # draw the RMS axes (lines and their value labels) over the χ² axes
    ax.set_zorder(ax2.get_zorder() + 1)
    ax.patch.set_visible(False)
    ax2.set_ylabel("χ²/dof (log; 1 = within the noise)", color=PALETTE[2])
    ax2.tick_params(axis="y", colors=PALETTE[2])

    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize="small", loc="upper right", framealpha=0.9)
    ax.set_title(f"Error ladder: {_short(channel)} as effects are added")
    ax.set_xlabel("model (each step adds effects to the previous one; all parameters refitted)")
    return _finish(fig, path)


def deflection_share(
    arm: Arm,
    meas: Measurements,
    effects: Sequence[Effect],
    self_weight: bool = True,
    mass: float | None = None,
    path: PathLike | None = None,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
) -> Figure:
    """Who makes the sag: each effect's share of the measure point's dy, per configuration.

    For every configuration (its unloaded angles: the first row of the configuration in
    ``meas``) at payload ``mass``:

    * baseline (actuator springs only): ``solve(arm, α, mass).dy``;
    * each effect e: ``solve(..., effects=[e]).dy − solve(...).dy``;
    * total: ``solve(..., effects=effects).dy`` (black diamond; it differs from the sum of the
      bars only by the interaction of the effects, which is small).

    Parameters
    ----------
    arm, meas : the arm and the measurements (for the configurations and payloads).
    effects : the effects with their values (e.g. ``fit_result.effects``).
    self_weight : as :func:`eodarm.solve`.
    mass : payload, kg; default the largest in ``meas``.
    path : where to write a PNG (120 dpi); nothing is written when ``None``.
    model, fem_options : the model that solves, as in :func:`eodarm.solve`.

    Returns
    -------
    Figure
        One axes of stacked bars per configuration (positive parts stacked upwards from zero,
        negative parts downwards), one colour per component, in mm.
    """
    effects = list(effects)
    m = float(np.max(meas.mass_kg)) if mass is None else float(mass)
    rows = [r[0] for r in _config_rows(meas)]
    alpha = meas.alpha_deg[rows]
    labels = list(meas.configs)

    def dy(effs: list[Effect]) -> npt.NDArray[np.float64]:
        out = solve(
            arm,
            alpha,
            m,
            effects=effs,
            self_weight=self_weight,
            model=model,
            fem_options=fem_options,
        )
        return np.asarray(out["dy_mm"], dtype=float)

    base = dy([])
    parts = [("baseline (actuator springs only)", base, GREY)]
    for j, e in enumerate(effects):
        parts.append((effect_label(e), dy([e]) - base, PALETTE[j % len(PALETTE)]))
    total = dy(effects)

    k = len(labels)
    # the legend sits below the axes: the figure must be as wide as its longest entry
    # (about 0.075 in a character at "small" size), two entries a row when they fit
    entry = 0.075 * max(len(name) for name, _, _ in parts) + 0.6
    width = min(14.0, max(6.5, 0.55 * k + 4.0, entry + 0.4))
    legend_cols = 2 if 2 * entry <= width - 0.3 else 1
    fig = _figure(width, 4.8)
    ax = fig.add_subplot()
    x = np.arange(k, dtype=float)
    up = np.zeros(k)
    down = np.zeros(k)
    bar_w = 0.62
    for name, v, colour in parts:
        pos, neg = np.clip(v, 0, None), np.clip(v, None, 0)
        ax.bar(x, pos, bar_w, bottom=up, color=colour, label=name, edgecolor="white", lw=0.5)
        ax.bar(
            x, neg, bar_w, bottom=down, color=colour, label="_" + name, edgecolor="white", lw=0.5
        )
        up += pos
        down += neg
    (marker,) = ax.plot(
        x, total, "D", color="k", ms=6, label="total, all effects together", gid="total"
    )
    if k <= 16:
        for xi, t in zip(x, total, strict=True):
            ax.annotate(
                f"{t:.2f}".replace("-", "−"),
                (xi, t),
                textcoords="offset points",
                xytext=(0, -13 if t < 0 else 6),
                ha="center",
                fontsize="x-small",
            )
    ax.axhline(0.0, color="k", lw=0.7)
    lo, hi = float(min(down.min(), total.min(), 0.0)), float(max(up.max(), total.max(), 0.0))
    span = hi - lo or 1.0
    ax.set_ylim(lo - 0.12 * span, hi + 0.08 * span)
    ax.set_xticks(x, labels)
    if max(len(lb) for lb in labels) * 0.085 > 0.9 * (width - 1.5) / k:
        ax.tick_params(axis="x", labelrotation=45)
    ax.set_xlabel("configuration")
    ax.set_ylabel("contribution to dy of the measure point [mm]")
    ax.grid(True, axis="y", lw=0.4, alpha=0.5)
    handles: list[Any] = [
        cont for cont in ax.containers if not str(cont.get_label()).startswith("_")
    ]
    fig.legend(
        [*handles, marker],
        [*(str(h.get_label()) for h in handles), str(marker.get_label())],
        loc="outside lower center",
        fontsize="small",
        ncols=legend_cols,
    )
    sw = "with" if self_weight else "without"
    fe = "; FE model" if model == "fem" else ""
    ax.set_title(
        f"Who makes the sag? Contributions to dy at payload {m:g} kg\n"
        f"(each effect alone minus the baseline; {sw} self-weight{fe})"
    )
    return _finish(fig, path)


def arm_pose(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    out: Mapping[str, Any] | None = None,
    scale: float = 50.0,
    path: PathLike | None = None,
) -> Figure:
    """A drawing of the arm in one pose, optionally with its loaded pose exaggerated.

    Parameters
    ----------
    arm : the arm.
    alpha_deg : (n,) (or (1, n)) unloaded absolute link angles, degrees.
    out : optional one row of :func:`eodarm.solve`'s output for this pose (arrays of one row,
        or already indexed): its ``dalpha_deg`` (and ``dx_mm``, ``dy_mm``) are drawn.
    scale : exaggeration of the loaded pose.
    path : where to write a PNG (120 dpi); nothing is written when ``None``.

    Returns
    -------
    Figure
        Links as shaded plates with a thick line through their joints, actuators as lines
        between their pins, joints as open circles, the measure point and the load point.
        With ``out``, the loaded pose is approximated by turning each link by
        ``scale·dα`` (the joints follow the chain; joint clearance shifts are not drawn) and
        the true displacement of the measure point is an arrow ``scale·(dx, dy)``.
    """
    alpha = np.asarray(alpha_deg, dtype=float).reshape(-1)
    if alpha.shape != (arm.n,):
        raise EodarmError(f"arm_pose: alpha_deg must have {arm.n} angles, got {alpha.shape}")
    if not (math.isfinite(scale) and scale > 0):
        raise EodarmError(f"arm_pose: scale must be finite and > 0, got {scale!r}")
    fig = _figure(8.6, 6.4)
    ax = fig.add_subplot()
    geo = forward(arm, alpha[None, :])
    _draw_arm(ax, arm, geo, solid=True)
    title = f"{arm.name}: pose α = {_angles(alpha)}"
    if out is not None:
        dalpha = _one_row(out, "dalpha_deg", arm.n)
        geo2 = forward(arm, (alpha + scale * dalpha)[None, :])
        _draw_arm(ax, arm, geo2, solid=False)
        meas_pt = geo["measure"][0]
        if "dx_mm" in out and "dy_mm" in out:
            d = np.array([_one_value(out, "dx_mm"), _one_value(out, "dy_mm")])
            ax.annotate(
                "",
                xy=tuple(meas_pt + scale * d),
                xytext=tuple(meas_pt),
                arrowprops={"arrowstyle": "-|>", "color": PALETTE[3], "lw": 1.6},
                zorder=8,
            )
            ax.plot([], [], color=PALETTE[3], lw=1.6, label=f"measure point moves ×{scale:g}")
            ax.text(
                0.99,
                0.01,
                (
                    f"dx = {d[0]:.3f} mm, dy = {d[1]:.3f} mm, "
                    f"dα = ({', '.join(f'{v:.4f}' for v in dalpha)})°"
                ).replace("-", "−"),
                transform=ax.transAxes,
                ha="right",
                va="bottom",
                fontsize="small",
            )
        title += (
            f"\nloaded pose dashed, exaggerated ×{scale:g} (approximate: each link turned by "
            f"{scale:g}·dα about its joint chain)"
        )
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.08)
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.set_xlabel("x [mm] (forward)")
    ax.set_ylabel("y [mm] (up)")
    fig.suptitle(title, fontsize="medium")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize="small", borderaxespad=0)
    return _finish(fig, path)


def _one_row(out: Mapping[str, Any], key: str, n: int) -> npt.NDArray[np.float64]:
    if key not in out:
        raise EodarmError(f"arm_pose: the solve output has no '{key}'")
    a = np.asarray(out[key], dtype=float)
    if a.ndim == 2 and a.shape[0] == 1:
        a = a[0]
    if a.shape != (n,):
        raise EodarmError(
            f"arm_pose: '{key}' must be one row of {n} values (index the solve output), "
            f"got shape {a.shape}"
        )
    return a


def _one_value(out: Mapping[str, Any], key: str) -> float:
    a = np.asarray(out[key], dtype=float).reshape(-1)
    if a.shape != (1,):
        raise EodarmError(f"arm_pose: '{key}' must be one value, got shape {a.shape}")
    return float(a[0])


def _hull(points: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Convex hull (counter-clockwise) of a few 2-D points (monotone chain)."""
    pts = sorted({(float(p[0]), float(p[1])) for p in points})
    if len(pts) <= 2:
        return np.array(pts)

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def _draw_arm(ax: Axes, arm: Arm, geo: Mapping[str, Any], solid: bool) -> None:
    """Draw one pose from :func:`eodarm.forward`'s output (first row)."""
    n = arm.n
    o = np.asarray(geo["O"])[0]
    a = np.asarray(geo["A"])[0]
    b = np.asarray(geo["B"])[0]
    meas_pt = np.asarray(geo["measure"])[0]
    ls = "-" if solid else "--"
    z = 2 if solid else 5
    link_colour = "0.25" if solid else PALETTE[3]
    act_colour = PALETTE[1] if solid else PALETTE[3]
    tag = "" if solid else "loaded: "
    if solid:
        chassis = np.array([o[0], b[0], arm.pivot])
        hull = _hull(chassis)
        if len(hull) >= 3:
            ax.add_patch(Polygon(hull, closed=True, fc="0.85", ec="0.6", lw=1, zorder=0))
        ax.plot(*np.array(arm.pivot), marker="x", color="0.4", ms=7, ls="none", label="base pivot")
    for i in range(n):
        pts = [o[i], a[i], o[i + 1]]
        if i < n - 1:
            pts.append(b[i + 1])
        else:
            pts.append(meas_pt)
        if solid:
            hull = _hull(np.array(pts))
            ax.add_patch(
                Polygon(hull, closed=True, fc=PALETTE[0], alpha=0.18, ec=PALETTE[0], lw=0.8)
            )
        ax.plot(
            [o[i][0], o[i + 1][0]],
            [o[i][1], o[i + 1][1]],
            ls=ls,
            color=link_colour,
            lw=5 if solid else 2,
            solid_capstyle="round",
            zorder=z,
            label=f"{tag}links" if i == 0 else None,
        )
        # the actuator: B_{i-1} to A_i (b[i] is its base pin)
        ax.plot(
            [b[i][0], a[i][0]],
            [b[i][1], a[i][1]],
            ls=ls,
            color=act_colour,
            lw=3.5 if solid else 1.5,
            zorder=z + 1,
            label=f"{tag}actuators" if i == 0 else None,
        )
        if solid:
            mid = 0.5 * (b[i] + a[i])
            ax.annotate(
                f"M{i + 1}",
                tuple(mid),
                textcoords="offset points",
                xytext=(6, -4),
                fontsize="small",
                color=PALETTE[1],
                bbox=_LABEL_BOX,
                zorder=9,
            )
            ax.annotate(
                f"O{i + 1}",
                tuple(o[i]),
                textcoords="offset points",
                xytext=(-18, 8),
                fontsize="small",
                bbox=_LABEL_BOX,
                zorder=9,
            )
    pins = np.vstack([a, b])
    ax.plot(
        pins[:, 0],
        pins[:, 1],
        "o",
        color=act_colour,
        ms=4 if solid else 3,
        zorder=z + 2,
        label="pins" if solid else None,
    )
    ax.plot(
        o[:n, 0],
        o[:n, 1],
        "o",
        mfc="white" if solid else "none",
        mec="k" if solid else PALETTE[3],
        mew=1.5,
        ms=10 if solid else 7,
        zorder=z + 3,
        ls="none",
        label="joints" if solid else None,
    )
    ax.plot(
        *meas_pt,
        marker="*",
        color=PALETTE[2] if solid else PALETTE[3],
        ms=13 if solid else 9,
        zorder=z + 4,
        ls="none",
        label="measure point" if solid else "loaded: measure point (as drawn)",
    )
    if solid:
        ax.plot(*o[n], marker="v", color="k", ms=8, zorder=z + 4, ls="none", label="load point")
