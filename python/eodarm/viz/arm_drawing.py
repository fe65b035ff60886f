"""The arm drawn in a pose, unloaded and loaded (deflections exaggerated)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

try:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "eodarm.plots needs matplotlib: pip install 'eodarm[plot]' (or matplotlib>=3.8)"
    ) from exc

from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.solver import forward
from eodarm.viz.style import (
    LABEL_BOX,
    PALETTE,
    PathLike,
    angles_text,
    figure,
    finish,
)

__all__ = ["arm_pose"]


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
    fig = figure(8.6, 6.4)
    ax = fig.add_subplot()
    geo = forward(arm, alpha[None, :])
    _draw_arm(ax, arm, geo, solid=True)
    title = f"{arm.name}: pose α = {angles_text(alpha)}"
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
    return finish(fig, path)


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
                bbox=LABEL_BOX,
                zorder=9,
            )
            ax.annotate(
                f"O{i + 1}",
                tuple(o[i]),
                textcoords="offset points",
                xytext=(-18, 8),
                fontsize="small",
                bbox=LABEL_BOX,
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
