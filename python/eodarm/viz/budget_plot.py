"""The sag budget as a figure: who makes the sag of a model, in shares that add up to it, and
the residual that takes it to the measured sag (:mod:`eodarm.analysis.budget`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.budget import SagBudget, sag_budget
from eodarm.data.measurements import Measurements
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect
from eodarm.model.solver import solve
from eodarm.viz.format import parameter_name
from eodarm.viz.style import GREY, PALETTE, PathLike, config_rows, figure, finish

try:
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "eodarm.plots needs matplotlib: pip install 'eodarm[plot]' (or matplotlib>=3.8)"
    ) from exc

__all__ = ["budget_at", "component_colours", "component_name", "deflection_share"]


def component_name(label: str) -> str:
    """A budget component in words: ``mount_compliance@M1`` → ``actuator 1 mount``."""
    if "@" not in label:
        return label
    name, at = label.split("@", 1)
    return parameter_name(name, at).replace(" stiffness", "").replace(" EI", "")


def budget_at(
    arm: Arm,
    meas: Measurements,
    effects: Sequence[Effect],
    *,
    self_weight: bool = True,
    mass: float | None = None,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
) -> tuple[SagBudget, float, npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The budget of every configuration at one payload (default the largest), with the
    measured dy there (mean of the configuration's rows at that payload; NaN where not
    measured) and the baseline's dy (the arm file alone). Returns
    ``(budget, mass, measured, baseline)``."""
    m = float(np.max(meas.mass_kg)) if mass is None else float(mass)
    rows = config_rows(meas)
    alpha = meas.alpha_deg[[r[0] for r in rows]]
    kw: dict[str, Any] = {"self_weight": self_weight, "model": model, "fem_options": fem_options}
    budget = sag_budget(arm, alpha, m, effects, **kw)
    base = np.asarray(solve(arm, alpha, m, **kw)["dy_mm"], dtype=float).reshape(-1)
    measured = np.full(len(rows), math.nan)
    if "dy_mm" in meas.channels:
        c = meas.index("dy_mm")
        for i, r in enumerate(rows):
            sel = r[(np.abs(meas.mass_kg[r] - m) < 1e-9) & meas.measured[r, c]]
            if sel.size:
                measured[i] = float(np.mean(meas.values[sel, c]))
    return budget, m, measured, base


def component_colours(labels: Sequence[str]) -> list[str]:
    """Bodies in blues, mounts in oranges, the rest from the palette."""
    blues = ("#1f77b4", "#6baed6", "#08519c", "#9ecae1")
    oranges = ("#ff7f0e", "#fdae6b", "#a63603", "#fdd0a2")
    rest = [c for c in PALETTE if c not in ("#1f77b4", "#ff7f0e", "#7f7f7f")]
    out, nb, nm, nr = [], 0, 0, 0
    for lb in labels:
        if (lb.startswith("actuator") and lb.endswith("body")) or lb == "actuator bodies":
            out.append(blues[nb % len(blues)])
            nb += 1
        elif lb.startswith("mount_compliance"):
            out.append(oranges[nm % len(oranges)])
            nm += 1
        else:
            out.append(rest[nr % len(rest)])
            nr += 1
    return out


def deflection_share(
    arm: Arm,
    meas: Measurements,
    effects: Sequence[Effect],
    self_weight: bool = True,
    mass: float | None = None,
    path: PathLike | None = None,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
    budget: tuple[SagBudget, float, npt.NDArray[np.float64], npt.NDArray[np.float64]] | None = None,
) -> Figure:
    """The sag budget of the model ``arm`` + ``effects``, per configuration, at one payload.

    Each bar stacks, from zero, the Shapley share of every component (each actuator body,
    every other effect: its sag with all the others present, averaged over the orders of
    switching them on; :mod:`eodarm.analysis.budget`); the shares end exactly at the model's
    dy (black diamond). The hatched segment is the residual, measured − model, and ends at
    the measured dy (red cross, mean of the rows at that payload). The grey bar marks the
    baseline's dy (the arm file alone) for comparison.

    ``budget`` is :func:`budget_at`'s result when the caller has it already.

    Returns
    -------
    Figure
        One axes; containers in component order, then the residual; lines with gid
        ``total``, ``measured`` and ``baseline``.
    """
    if budget is None:
        budget = budget_at(
            arm,
            meas,
            effects,
            self_weight=self_weight,
            mass=mass,
            model=model,
            fem_options=fem_options,
        )
    split, m, measured, base = budget
    labels = list(meas.configs)
    k = len(labels)
    names = [component_name(lb) for lb in split.labels]
    colours = component_colours(split.labels)
    width = min(14.0, max(7.0, 0.75 * k + 4.5))
    fig = figure(width, 5.4)
    ax = fig.add_subplot()
    x = np.arange(k, dtype=float)
    bar_w = 0.56
    level = split.rigid.copy()
    for name, share, colour in zip(names, split.shares, colours, strict=True):
        ax.bar(x, share, bar_w, bottom=level, color=colour, label=name, edgecolor="white", lw=0.5)
        level = level + share
    resid = np.where(np.isfinite(measured), measured - split.total, 0.0)
    ax.bar(
        x,
        resid,
        bar_w,
        bottom=split.total,
        color="none",
        edgecolor=PALETTE[3],
        hatch="///",
        lw=0.8,
        label="residual: measured − model",
    )
    ax.plot(x, split.total, "D", color="k", ms=6, gid="total", zorder=5)
    ax.plot(x, measured, "X", color=PALETTE[3], ms=9, gid="measured", zorder=6)
    ax.plot(x, base, "_", color=GREY, ms=28, mew=2.5, gid="baseline", zorder=4)
    for xi, t, me in zip(x, split.total, measured, strict=True):
        text = f"model {t:.1f}".replace("-", "−")
        if math.isfinite(me):
            text += f"\nmeas. {me:.1f}".replace("-", "−")
        ax.annotate(
            text,
            (xi, min(t, me) if math.isfinite(me) else t),
            textcoords="offset points",
            xytext=(0, -9),
            ha="center",
            va="top",
            fontsize="x-small",
        )
    ax.axhline(0.0, color="k", lw=0.7)
    lo = float(np.nanmin([*split.total, *measured, *base, 0.0]))
    hi = float(np.nanmax([*split.total, *measured, *base, 0.0]))
    span = hi - lo or 1.0
    ax.set_ylim(lo - 0.2 * span, hi + 0.05 * span)
    ax.set_xlim(-0.6, k - 0.1)
    ax.set_xticks(x, labels)
    ax.set_xlabel("configuration")
    ax.set_ylabel("dy of the measure point [mm] (negative: down)")
    ax.grid(True, axis="y", lw=0.4, alpha=0.5)
    handles: list[Any] = [Patch(facecolor=c, edgecolor="white") for c in colours]
    handles += [
        Patch(facecolor="none", edgecolor=PALETTE[3], hatch="///"),
        Line2D([], [], ls="none", marker="D", color="k"),
        Line2D([], [], ls="none", marker="X", color=PALETTE[3], ms=8),
        Line2D([], [], ls="none", marker="_", color=GREY, ms=16, mew=2.5),
    ]
    texts = [
        *names,
        "residual (measured − model)",
        "model total",
        "measured",
        "baseline model (arm file only)",
    ]
    fig.legend(
        handles,
        texts,
        loc="outside lower center",
        fontsize="small",
        ncols=min(4, len(texts)),
    )
    sw = "with" if self_weight else "without"
    fe = "; FE model" if model == "fem" else ""
    ax.set_title(
        f"Sag budget at payload {m:g} kg: each part's share with all the others present\n"
        f"(Shapley split from the rigid arm; shares add up to the model; {sw} self-weight{fe})",
        fontsize="medium",
    )
    return finish(fig, path)
