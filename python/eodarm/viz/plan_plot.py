"""The figure of a plan: the planned configurations drawn on the arm's workspace, and the
separations of every pair with the plan against a random plan (and the campaign so far)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

try:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "eodarm.plots needs matplotlib: pip install 'eodarm[plot]' (or matplotlib>=3.8)"
    ) from exc

from eodarm.model.solver import forward
from eodarm.viz.style import GREY, LABEL_BOX, PALETTE, PathLike, figure, finish

if TYPE_CHECKING:
    from eodarm.analysis.plan import Plan

__all__ = ["plan_figure"]

#: The separable χ² (docs/plan.md).
SEPARABLE = 25.0


def plan_figure(result: Plan, path: PathLike | None = None) -> Figure:
    """Two panels: the workspace (every reachable configuration of the pool as its measure
    point, the planned configurations drawn as arms, a fixed campaign's dashed) and the
    separation of every pair that some plan can separate, weakest first, with the plan, the
    median random plan and the fixed campaign alone, against the separable χ² of 25.

    Parameters
    ----------
    result : a plan (:func:`eodarm.analysis.plan.plan`).
    path : where to write a PNG; nothing is written when ``None``.
    """
    fig = figure(12.0, 6.0)
    left, right = fig.subplots(1, 2, width_ratios=[1.15, 1.0])
    _workspace(left, result)
    _separations(right, result)
    return finish(fig, path)


def _chain(arm_geo: dict[str, npt.NDArray[np.float64]], n: int) -> npt.NDArray[np.float64]:
    """(P, n + 2, 2) the joints, the load point and the measure point of each pose."""
    o = arm_geo["O"][:, : n + 1]
    return np.concatenate([o, arm_geo["measure"][:, None, :]], axis=1)


def _workspace(ax: Axes, result: Plan) -> None:
    arm = result.arm
    n = arm.n
    pool = forward(arm, result.pool)
    ax.plot(
        pool["measure"][:, 0],
        pool["measure"][:, 1],
        ".",
        color="0.75",
        ms=3,
        label=f"measure point, {result.pool.shape[0]} reachable configurations",
        zorder=1,
    )
    if result.fixed.shape[0]:
        fixed = _chain(forward(arm, result.fixed), n)
        for k, pts in enumerate(fixed):
            ax.plot(
                pts[: n + 1, 0],
                pts[: n + 1, 1],
                "--",
                color=GREY,
                lw=1.5,
                marker="o",
                ms=3,
                label="measured already (--fixed)" if k == 0 else None,
                zorder=2,
            )
    planned = _chain(forward(arm, result.configs), n)
    for k, (pts, label) in enumerate(zip(planned, result.labels, strict=True)):
        colour = PALETTE[k % len(PALETTE)]
        ax.plot(pts[: n + 1, 0], pts[: n + 1, 1], "-", color=colour, lw=2.2, zorder=3)
        ax.plot(pts[:n, 0], pts[:n, 1], "o", mfc="white", mec=colour, ms=5, zorder=4)
        ax.plot(*pts[n + 1], "*", color=colour, ms=11, zorder=5)
        ax.annotate(
            label,
            tuple(pts[n + 1]),
            textcoords="offset points",
            xytext=(6, 4),
            fontsize="small",
            color=colour,
            bbox=LABEL_BOX,
            zorder=6,
        )
    ax.plot([], [], "-*", color="0.2", label="planned configuration (★ measure point)")
    ax.plot(*arm.O1, "s", color="k", ms=7, label="O1 (chassis)", zorder=6)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"{arm.name}: {len(result.labels)} planned configurations")
    ax.legend(fontsize="small", loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2)
    ax.grid(True, lw=0.3)


def _separations(ax: Axes, result: Plan) -> None:
    mask = np.triu(result.separable, 1)
    k = len(result.labels)
    so_far = "measured already + " if result.before_separation is not None else ""
    curves = [(f"{so_far}the plan", result.separation, PALETTE[0], "-")]
    if result.random_separation is not None:
        curves.append(
            (
                f"{so_far}{k} random configurations (median draw)",
                result.random_separation,
                GREY,
                "--",
            )
        )
    if result.before_separation is not None:
        curves.append(("measured already (--fixed)", result.before_separation, PALETTE[3], ":"))
    floor = 1e-2
    for label, sep, colour, ls in curves:
        values = np.sort(np.clip(sep[mask], floor, None))
        ax.step(np.arange(1, values.size + 1), values, ls=ls, color=colour, lw=2, label=label,
                where="mid")  # fmt: skip
    ax.axhline(SEPARABLE, color="k", lw=1, ls="-.")
    ax.annotate(
        "25: separable",
        (1, SEPARABLE),
        textcoords="offset points",
        xytext=(2, 3),
        fontsize="small",
    )
    ax.set_yscale("log")
    ax.set_xlabel("pairs of candidates that some plan separates, weakest first")
    ax.set_ylabel("separation χ²")
    named = len(result.inseparable)
    extra = f"; {named} pairs no configuration separates (not shown)" if named else ""
    ax.set_title(f"separations{extra}", fontsize="medium")
    ax.legend(fontsize="small", loc="lower right")
    ax.grid(True, which="both", lw=0.3)
