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
import textwrap
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

try:
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "eodarm.plots needs matplotlib: pip install 'eodarm[plot]' (or matplotlib>=3.8)"
    ) from exc

from eodarm.analysis.fit import FitResult
from eodarm.data.measurements import Measurements
from eodarm.errors import EodarmError
from eodarm.viz.arm_drawing import arm_pose
from eodarm.viz.budget_plot import deflection_share
from eodarm.viz.style import (
    DPI,
    GREY,
    LABEL_BOX,
    MARKERS,
    PALETTE,
    PathLike,
    angles_text,
    axes_grid,
    channel_title,
    channel_unit,
    check_fit,
    config_rows,
    effect_label,
    figure,
    finish,
    main_channel,
    num,
    short_channel,
    source_label,
)

__all__ = [
    "DPI",
    "PALETTE",
    "arm_pose",
    "channel_title",
    "channel_unit",
    "compact_label",
    "deflection_share",
    "effect_label",
    "ladder",
    "main_channel",
    "measured_vs_model",
    "residual_vs_payload",
]


# ---------------------------------------------------------------------------- figures
def measured_vs_model(
    meas: Measurements,
    fits: Mapping[str, FitResult],
    path: PathLike | None = None,
    axes_from: str | None = None,
) -> Figure:
    """Measured against model value of every measured channel, one panel per channel.

    Parameters
    ----------
    meas : the measurements.
    fits : label → fit of a model to ``meas`` (e.g. ``{"baseline": f0, "fitted": f1}``).
        Each model has its own marker (the first open, the others filled); the colour is the
        configuration (up to ten; beyond, the model). A fit whose predictions equal an earlier
        one's (nothing fitted, same model) is drawn once, under the earlier label.
    path : where to write a PNG (120 dpi); nothing is written when ``None``.
    axes_from : the label of the fit whose values (with the measurements ±σ) set each
        panel's axes; default the last. Points of other fits beyond the axes are counted in
        the panel ("n off the axes").

    Returns
    -------
    Figure
        One axes per measured channel (in channel order) with the line y = x; each panel's
        title gives every model's RMS residual on that channel (mm or deg); one legend
        below the panels. Cells a fit left out (outliers) are ringed in black.
    """
    chans = meas.measured_channels
    if not chans:
        raise EodarmError(f"{meas.source}: no channel is measured")
    if not fits:
        raise EodarmError("measured_vs_model: give at least one fit")
    for label, f in fits.items():
        check_fit(meas, f, label)
    shown: dict[str, FitResult] = {}
    for label, f in fits.items():
        if not any(
            np.array_equal(f.prediction, g.prediction, equal_nan=True) for g in shown.values()
        ):
            shown[label] = f
    ref = axes_from if axes_from in shown else list(shown)[-1]
    by_config = len(meas.configs) <= len(PALETTE)
    cfg_rows = config_rows(meas)
    ncols = min(3, len(chans))
    nrows = math.ceil(len(chans) / ncols)
    fig = figure(4.3 * ncols, 4.3 * nrows + 0.9)
    axes = axes_grid(fig, len(chans), ncols)
    left_out = False
    for ax, ch in zip(axes, chans, strict=True):
        c = meas.index(ch)
        unit = channel_unit(ch)
        m = meas.measured[:, c]
        x_all, sig_all = meas.values[:, c], meas.sigma[:, c]
        ref_y = shown[ref].prediction[m, c]
        vals = np.concatenate([x_all[m] - sig_all[m], x_all[m] + sig_all[m], ref_y])
        vals = vals[np.isfinite(vals)]
        lo, hi = float(vals.min()), float(vals.max())
        pad = 0.06 * (hi - lo) if hi > lo else max(abs(hi), 1e-3) * 0.1
        lim = (lo - pad, hi + pad)
        rms_text = []
        for j, (label, f) in enumerate(shown.items()):
            marker = MARKERS[j % len(MARKERS)]
            colour_of = np.empty(meas.n_rows, dtype=object)
            for g, rows in enumerate(cfg_rows):
                colour_of[rows] = PALETTE[(g if by_config else j) % len(PALETTE)]
            cols = list(colour_of[m])
            y = f.prediction[m, c]
            # one collection of bars and one of markers per model (cheap to draw)
            ax.hlines(
                y,
                x_all[m] - sig_all[m],
                x_all[m] + sig_all[m],
                colors=cols,
                lw=0.8,
                alpha=0.9,
                zorder=3 + j,
            )
            hollow = j == 0 and len(shown) > 1
            ax.scatter(
                x_all[m],
                y,
                s=25 if j == 0 else 20,
                marker=marker,
                facecolors="none" if hollow else cols,
                edgecolors=cols,
                linewidths=1.0,
                alpha=0.9,
                zorder=3 + j,
            )
            # one invisible line per model carries its data, in row order, for readers
            ax.plot(x_all[m], y, ls="none", marker="none", gid=f"model:{label}")
            off = int(np.sum((y < lim[0]) | (y > lim[1])))
            rms = f.rms().get(ch, math.nan)
            rms_text.append(
                f"{label} {num(rms)} {unit}" + (f" ({off} off the axes)" if off else "")
            )
            out = ~f.problem.use[m, c]
            if out.any():
                ax.plot(x_all[m][out], y[out], "o", ms=10, mfc="none", mec="k", zorder=10)
                left_out = True
        ax.plot(lim, lim, color="k", lw=0.9, ls=":", zorder=1)
        ax.set_xlim(lim)
        ax.set_ylim(lim)
        ax.set_box_aspect(1)
        ax.xaxis.set_major_locator(MaxNLocator(nbins=5))
        ax.yaxis.set_major_locator(MaxNLocator(nbins=5))
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.set_title(
            channel_title(ch) + "\nRMS: " + textwrap.fill("; ".join(rms_text), 48),
            fontsize="small",
        )
        ax.set_xlabel(f"measured {short_channel(ch)} [{unit}]")
        ax.set_ylabel(f"model {short_channel(ch)} [{unit}]")
    handles: list[Any] = []
    names: list[str] = []
    for j, label in enumerate(shown):
        colour = "0.3" if by_config else PALETTE[j % len(PALETTE)]
        mfc = "none" if j == 0 and len(shown) > 1 else colour
        handles.append(
            Line2D([], [], ls="none", marker=MARKERS[j % len(MARKERS)], color=colour, mfc=mfc)
        )
        names.append(f"model: {label}")
    if by_config:
        for g, label in enumerate(meas.configs):
            handles.append(Patch(color=PALETTE[g % len(PALETTE)]))
            names.append(f"configuration {label}")
    handles.append(Line2D([], [], color="k", lw=0.9, ls=":"))
    names.append("y = x (model right)")
    if left_out:
        handles.append(Line2D([], [], ls="none", marker="o", ms=10, mfc="none", mec="k"))
        names.append("left out of the fit (outlier)")
    fig.legend(
        handles, names, loc="outside lower center", fontsize="small", ncols=min(4, len(names))
    )
    fig.suptitle(
        f"Measured vs model ({source_label(meas)}, {meas.n_rows} states; bars ±σ; axes fit {ref})"
    )
    return finish(fig, path)


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
        same model twice (the same object, or equal predictions: nothing fitted) draws that
        one model alone, with no "before → after".
    channel : the channel; default :func:`main_channel` (``dy_mm`` when measured, else the
        channel with the largest baseline RMS in units of σ).
    path : where to write a PNG (120 dpi); nothing is written when ``None``.

    Returns
    -------
    Figure
        One axes per configuration (shared axes): ``before`` grey, dashed, open markers;
        ``after`` coloured and solid; shaded ±1σ and ±3σ bands of the measurement around
        zero. The linear y axis fits ``after`` (and ``before`` when it is within three times
        that range); ``before`` points beyond it are counted in the panel. Each panel states
        both RMS values of its configuration.
    """
    check_fit(meas, before, "before")
    check_fit(meas, after, "after")
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
    fig = figure(max(2.9 * ncols, 6.5), 2.35 * nrows + 1.2)
    axes = axes_grid(fig, k, ncols, sharex=True, sharey=True)
    res_b, res_a = before.residual[:, c], after.residual[:, c]
    # one model only (nothing fitted): draw it once
    same = after is before or np.array_equal(before.prediction, after.prediction, equal_nan=True)
    s0 = float(np.nanmedian(meas.sigma[meas.measured[:, c], c]))
    fin_a = np.abs(res_a[np.isfinite(res_a)])
    fin_b = np.abs(res_b[np.isfinite(res_b)])
    top = max(float(fin_a.max(initial=0.0)), 3.2 * s0) * 1.15
    if float(fin_b.max(initial=0.0)) <= 3 * top:
        top = max(top, float(fin_b.max(initial=0.0)) * 1.1)
    left_out = False
    off = [0, 0.0]  # before-points beyond the axes: how many, the largest |residual|
    for i, (ax, label, rows) in enumerate(zip(axes, configs, config_rows(meas), strict=True)):
        rows = rows[meas.measured[rows, c]]
        rows = rows[np.argsort(meas.mass_kg[rows], kind="stable")]
        m = meas.mass_kg[rows]
        sig = meas.sigma[rows, c]
        for k_sig, alpha in ((3, 0.08), (1, 0.16)):
            if np.unique(m).size > 1:
                ax.fill_between(m, -k_sig * sig, k_sig * sig, color=PALETTE[0], alpha=alpha, lw=0)
            elif rows.size:
                half = k_sig * float(sig.max())
                ax.axhspan(-half, half, color=PALETTE[0], alpha=alpha, lw=0)
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
        beyond = np.abs(res_b[rows]) > top
        if not same and beyond.any():
            off[0] += int(beyond.sum())
            off[1] = max(off[1], float(np.max(np.abs(res_b[rows]))))
        note = f"RMS {num(ra, 2)} {unit}" if same else f"RMS {num(rb, 2)} → {num(ra, 2)} {unit}"
        first = meas.alpha_deg[rows[0]] if rows.size else meas.alpha_deg[0]
        ax.set_title(f"{label}: α = {angles_text(first)}\n{note}", fontsize="small")
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.tick_params(labelsize="small")
        if i % ncols == 0:
            ax.set_ylabel(f"residual {short_channel(ch)} [{unit}]", fontsize="small")
        if i + ncols >= k:
            ax.set_xlabel("payload [kg]", fontsize="small")
    for ax in axes:
        ax.set_ylim(-top, top)
        ax.yaxis.set_major_locator(MaxNLocator(nbins=7, steps=[1, 2, 5, 10], symmetric=True))
    handles = [
        Line2D([], [], ls="--", marker="o", mfc="none", color=GREY),
        Line2D([], [], ls="-", marker="o", color=PALETTE[0]),
        Patch(color=PALETTE[0], alpha=0.16),
        Patch(color=PALETTE[0], alpha=0.08),
    ]
    names = [
        f"before: {_model_name(before)} (RMS {num(before.rms().get(ch, math.nan))} {unit})",
        f"after: {_model_name(after)} (RMS {num(after.rms().get(ch, math.nan))} {unit})",
        "±1σ of the measurement",
        "±3σ",
    ]
    if same:
        del handles[0], names[0]
        names[0] = f"model: {_model_name(after)} (RMS {num(after.rms().get(ch, math.nan))} {unit})"
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
    title = f"Residual of {short_channel(ch)} (measured − model) against payload, per configuration"
    if off[0]:
        title += (
            f"\nthe axes fit the after model; {off[0]} before-points lie beyond them "
            f"(up to ±{num(off[1], 2)} {unit})"
        )
    fig.suptitle(title)
    return finish(fig, path)


def compact_label(label: str) -> str:
    """A ladder step's label with one effect at several places written once:
    ``"+ a@M1 + a@M2 + b@O1"`` → ``"+ a@M1, M2 + b@O1"``."""
    parts = label.split(" + ")
    out: list[str] = []
    last = ""
    for p in parts:
        name, at = p.split("@", 1) if "@" in p else ("", "")
        bare = name.removeprefix("+ ")
        if bare and bare == last and out:
            tail = ""
            if " (" in at:
                at, tail = at.split(" (", 1)
                tail = " (" + tail
            out[-1] += f", {at}{tail}"
        else:
            out.append(p)
        last = bare
    return " + ".join(out)


def _model_name(fit: FitResult) -> str:
    """The effects a fit carries (the arm file's first, marked), or ``"baseline"``."""
    keys = [e.key for e in fit.fixed] + [s.key for s in fit.slots]
    own = [e.key for e in getattr(fit.problem.arm, "effects", ()) if e.key not in keys]
    parts = ([", ".join(own) + " (arm file)"] if own else []) + ([", ".join(keys)] if keys else [])
    return " + ".join(["baseline", *parts])


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
        (:func:`eodarm.viz.report.build_ladder` makes them).
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
    labels = [compact_label(str(s["label"])) for s in steps]
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
    fig = figure(width, 5.2 if long else 4.6)
    ax = fig.add_subplot()
    ax.plot(
        x, rms, "-o", color=PALETTE[0], lw=2, ms=6, label=f"RMS {short_channel(channel)}", gid="rms"
    )
    values = [rms]
    if np.isfinite(cv).any():
        ax.plot(
            x,
            cv,
            "--s",
            color=PALETTE[1],
            lw=1.6,
            ms=5,
            label=f"cross-validated RMS {short_channel(channel)} (leave one configuration out)",
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
            num(r),
            (xi, r),
            textcoords="offset points",
            xytext=(8, -12 if show_cv and not cv_below else 4),
            fontsize="small",
            color=PALETTE[0],
            bbox=LABEL_BOX,
            zorder=6,
        )
        if show_cv:
            ax.annotate(
                num(c),
                (xi, c),
                textcoords="offset points",
                xytext=(8, -12 if cv_below else 4),
                fontsize="small",
                color=PALETTE[1],
                bbox=LABEL_BOX,
                zorder=6,
            )
    ax.set_ylabel(f"RMS of {short_channel(channel)} residual [{unit}]")
    # Long labels ("+ a@M1 + b@M2 + c@M3") are wrapped at the "+" into lines, never rotated:
    # a rotated label of 70 characters takes more room than the plot.
    width = max(14, int(90 / max(len(steps), 1)))

    def wrap(lb: str) -> str:
        if len(lb) <= width:
            return lb
        words = lb.replace(" + ", " +\u00a0").split(" ")
        return textwrap.fill(" ".join(words), width).replace("\u00a0", " ")

    ax.set_xticks(x, [f"{wrap(lb)}\nχ²/dof {num(v)}" for lb, v in zip(labels, chi, strict=True)])
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
    # below the axes, never over the data
    fig.legend(h1 + h2, l1 + l2, fontsize="small", loc="outside lower center", ncols=2)
    ax.set_title(f"Error ladder: {short_channel(channel)} as effects are added")
    ax.set_xlabel("model (each step adds effects to the previous one; all parameters refitted)")
    return finish(fig, path)
