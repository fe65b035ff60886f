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
import numpy.typing as npt

try:
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "eodarm.plots needs matplotlib: pip install 'eodarm[plot]' (or matplotlib>=3.8)"
    ) from exc

from eodarm.analysis.fit import FitResult
from eodarm.data.measurements import Measurements
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect
from eodarm.model.solver import solve
from eodarm.viz.arm_drawing import arm_pose
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
    free_corner,
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
        check_fit(meas, f, label)
    ncols = min(3, len(chans))
    nrows = math.ceil(len(chans) / ncols)
    fig = figure(4.3 * ncols, 4.1 * nrows + 0.5)
    axes = axes_grid(fig, len(chans), ncols)
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
                fmt=MARKERS[j % len(MARKERS)],
                ms=4.5,
                mfc="none" if j == 0 and len(fits) > 1 else colour,
                color=colour,
                elinewidth=0.9,
                capsize=0,
                alpha=0.9,
                label=f"{label}: RMS {num(rms)} {unit}",
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
        ax.set_xlabel(f"measured {short_channel(ch)} [{unit}]")
        ax.set_ylabel(f"model {short_channel(ch)} [{unit}]")
        ys = np.concatenate([f.prediction[m, c] for f in fits.values()])
        xs = np.tile(x, len(fits))
        ax.legend(fontsize="small", loc=free_corner(xs, ys, lim), framealpha=0.85)
    fig.suptitle(f"Measured vs model ({source_label(meas)}, {meas.n_rows} states; bars ±σ)")
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
    same = after is before  # one model only: draw it once
    left_out = False
    for i, (ax, label, rows) in enumerate(zip(axes, configs, config_rows(meas), strict=True)):
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
            f"RMS {num(ra, 2)} {unit}" if same else f"RMS {num(rb, 2)} → {num(ra, 2)} {unit}",
            transform=ax.transAxes,
            fontsize="x-small",
            color="0.2",
            bbox={"fc": "white", "ec": "none", "alpha": 0.7, "pad": 1.0},
        )
        first = meas.alpha_deg[rows[0]] if rows.size else meas.alpha_deg[0]
        ax.set_title(f"{label}: α = {angles_text(first)}", fontsize="small")
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.tick_params(labelsize="small")
        if i % ncols == 0:
            ax.set_ylabel(f"residual {short_channel(ch)} [{unit}]", fontsize="small")
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
            ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: num(v, 2)))
            ax.yaxis.set_minor_locator(NullLocator())
    handles = [
        Line2D([], [], ls="--", marker="o", mfc="none", color=GREY),
        Line2D([], [], ls="-", marker="o", color=PALETTE[0]),
        Patch(color=PALETTE[0], alpha=0.15),
    ]
    names = [
        f"before: {_model_name(before)} (RMS {num(before.rms().get(ch, math.nan))} {unit})",
        f"after: {_model_name(after)} (RMS {num(after.rms().get(ch, math.nan))} {unit})",
        "±1σ of the measurement",
    ]
    if same:
        del handles[0], names[0]
        names[0] = f"{_model_name(after)} (RMS {num(after.rms().get(ch, math.nan))} {unit})"
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
    if symlog:
        title += f"\ny axis linear within ±3σ (±{num(3 * s0, 2)} {unit}), logarithmic beyond"
    fig.suptitle(title)
    return finish(fig, path)


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
    ax.legend(h1 + h2, l1 + l2, fontsize="small", loc="upper right", framealpha=0.9)
    ax.set_title(f"Error ladder: {short_channel(channel)} as effects are added")
    ax.set_xlabel("model (each step adds effects to the previous one; all parameters refitted)")
    return finish(fig, path)


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
    rows = [r[0] for r in config_rows(meas)]
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
    fig = figure(width, 4.8)
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
    return finish(fig, path)
