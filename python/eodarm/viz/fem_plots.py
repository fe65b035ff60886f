"""Figures of the finite-element model: deformed shape, bending moments, pin forces.

Each takes one pose's output of ``eodarm.solve(..., model="fem")`` (the arrays of one row, or
the whole output and a ``row``) and returns a new :class:`matplotlib.figure.Figure` on its
own Agg canvas, written as a PNG only when ``path=`` is given (as :mod:`eodarm.viz.plots`).

* :func:`deformed_shape` — the members of the arm drawn in their exaggerated displaced
  positions, coloured by the magnitude of the displacement along them, over the undeformed
  arm: the picture of the seed paper's FEM Figures 14–18;
* :func:`moment_diagrams` — the bending moment along each link, loaded and its change;
* :func:`pin_forces` — the forces the links receive at their pins, as arrows.

>>> out = eodarm.solve(arm, alpha, 1.5, model="fem")          # doctest: +SKIP
>>> fem_plots.deformed_shape(arm, out, path="shape.png")       # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

try:
    from matplotlib.axes import Axes
    from matplotlib.collections import LineCollection
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "eodarm.fem_plots needs matplotlib: pip install 'eodarm[plot]' (or matplotlib>=3.8)"
    ) from exc

from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.viz.style import GREY, PALETTE, PathLike, figure, finish

__all__ = ["deformed_shape", "moment_diagrams", "nice_scale", "pin_forces"]

#: Line widths (points) of the segment kinds: link axis, rigid offset, actuator, chassis.
_WIDTH = (7.0, 4.0, 3.5, 5.0)
#: Node kinds of a FE solve's ``node_kind`` (first column).
_JOINT, _PIN_A, _NEXT, _MEASURE = 4, 5, 6, 8


def _node(node_kind: npt.NDArray[Any], kind: int, body: int) -> int:
    """Index of the node of a kind on a body."""
    return int(np.flatnonzero((node_kind[:, 0] == kind) & (node_kind[:, 1] == body))[0])


def _row(out: Mapping[str, Any], key: str, row: int) -> npt.NDArray[Any]:
    """One pose of a per-pose output (first axis: poses)."""
    if key not in out:
        raise EodarmError(f"the solve output has no '{key}': solve with model='fem'")
    a = np.asarray(out[key])
    if not 0 <= row < a.shape[0]:
        raise EodarmError(f"row {row} is out of range: the output has {a.shape[0]} poses")
    return a[row]


def nice_scale(target: float) -> float:
    """The largest of 1, 2, 5 × 10^k not above ``target`` (at least 1)."""
    if not (math.isfinite(target) and target > 1):
        return 1.0
    k = math.floor(math.log10(target))
    for m in (5.0, 2.0, 1.0):
        if m * 10**k <= target:
            return m * 10**k
    return 10.0**k  # pragma: no cover - one of the three always fits


def deformed_shape(
    arm: Arm,
    out: Mapping[str, Any],
    row: int = 0,
    scale: float | None = None,
    title: str | None = None,
    path: PathLike | None = None,
) -> Figure:
    """The arm's displaced shape, exaggerated, coloured by displacement magnitude.

    Parameters
    ----------
    arm : the arm that was solved.
    out : the output of ``eodarm.solve(..., model="fem")``.
    row : which pose of ``out``.
    scale : exaggeration of the displacements; default: a round number that makes the
        largest displacement about 6 % of the arm's size.
    title : the figure's title (default: arm, pose and payload).
    path : where to write a PNG (120 dpi); nothing is written when ``None``.

    Returns
    -------
    Figure
        The undeformed members in thin grey, the displaced ones thick, each coloured along its
        length by |u| (linear between nodes; mm, colour bar), joints as open circles, the
        largest displacement marked "max". Displacements are loaded minus unloaded (the
        payload's increment, gaps included), as the seed's "total deformation" plots show.
    """
    xy = np.asarray(_row(out, "node_xy", row), dtype=float)
    d = np.asarray(_row(out, "node_disp", row), dtype=float)
    seg = np.asarray(out["segments"], dtype=int)
    kind = np.asarray(out["segment_kind"], dtype=int)
    node_kind = np.asarray(out["node_kind"], dtype=int)
    if not (np.isfinite(xy).all() and np.isfinite(d).all()):
        raise EodarmError(f"row {row}: the FE solve failed for this pose (NaN output)")
    mag = np.hypot(d[:, 0], d[:, 1])
    size = float(np.ptp(xy, axis=0).max())
    top = float(mag.max())
    if scale is None:
        scale = nice_scale(0.06 * size / top) if top > 0 else 1.0
    if not (math.isfinite(scale) and scale > 0):
        raise EodarmError(f"deformed_shape: scale must be finite and > 0, got {scale!r}")
    moved = xy + scale * d
    fig = figure(9.0, 6.6)
    ax = fig.add_subplot()
    # The undeformed arm: a thin wireframe.
    ax.add_collection(
        LineCollection(
            list(np.stack([xy[seg[:, 0]], xy[seg[:, 1]]], axis=1)),
            colors="0.6",
            linewidths=1.0,
            linestyles="--",
            zorder=1,
            label="undeformed",
        )
    )
    # The displaced members, each cut into pieces coloured by the interpolated |u|.
    pieces = 24
    t = np.linspace(0.0, 1.0, pieces + 1)
    lines, values, widths = [], [], []
    for (a, b), k in zip(seg, kind, strict=True):
        pa, pb = moved[a], moved[b]
        if np.allclose(xy[a], xy[b]):
            continue
        pts = pa[None, :] * (1 - t[:, None]) + pb[None, :] * t[:, None]
        du = d[a][None, :] * (1 - t[:, None]) + d[b][None, :] * t[:, None]
        u = np.hypot(du[:, 0], du[:, 1])
        for j in range(pieces):
            lines.append(pts[j : j + 2])
            values.append(0.5 * (u[j] + u[j + 1]))
            widths.append(_WIDTH[k])
    norm = Normalize(vmin=0.0, vmax=top if top > 0 else 1.0)
    coll = LineCollection(
        lines, array=np.array(values), cmap="turbo", norm=norm, linewidths=widths, zorder=3
    )
    coll.set_capstyle("round")
    ax.add_collection(coll)
    bar = fig.colorbar(coll, ax=ax, shrink=0.85, pad=0.02)
    bar.set_label("total displacement |u| [mm] (true size)")
    joints = node_kind[:, 0] == _JOINT
    ax.plot(
        moved[joints, 0],
        moved[joints, 1],
        "o",
        mfc="white",
        mec="k",
        mew=1.4,
        ms=9,
        zorder=6,
        ls="none",
        label="joints (pins)",
    )
    drives = [_node(node_kind, _JOINT, i + 1) for i in range(arm.n) if arm.is_rotary(i)]
    if drives:
        ax.plot(
            *moved[drives].T,
            "s",
            mfc="none",
            mec="k",
            mew=1.4,
            ms=16,
            zorder=6,
            ls="none",
            label="rotary drives",
        )
    measure = node_kind[:, 0] == _MEASURE
    ax.plot(*moved[measure].T, "*", color="k", ms=12, zorder=7, ls="none", label="measure point")
    for i in range(arm.n):
        _tag(ax, f"O{i + 1}", moved[_node(node_kind, _JOINT, i + 1)])
    i = int(np.argmax(mag))
    ax.annotate(
        f"max {mag[i]:.3g} mm",
        tuple(moved[i]),
        xytext=(14, 14),
        textcoords="offset points",
        fontsize="small",
        arrowprops={"arrowstyle": "-|>", "color": "k", "lw": 1.0},
        bbox={"fc": "white", "ec": "0.4", "pad": 2.0},
        zorder=9,
    )
    last = (node_kind[:, 0] == _NEXT) & (node_kind[:, 1] == arm.n)
    if last.any() and "dforce_n" in out:
        tip = moved[np.flatnonzero(last)[0]]
        ax.annotate(
            "",
            xy=tuple(tip),
            xytext=(tip[0], tip[1] + 0.08 * size),
            arrowprops={"arrowstyle": "-|>", "color": PALETTE[3], "lw": 2.0},
            zorder=8,
        )
        ax.plot([], [], color=PALETTE[3], lw=2.0, label="payload")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.margins(0.1)
    ax.grid(True, lw=0.4, alpha=0.4)
    ax.set_xlabel("x [mm] (forward)")
    ax.set_ylabel("y [mm] (up)")
    ax.legend(loc="lower left", fontsize="small", framealpha=0.85)
    head = title or f"{arm.name}: displacement under the payload (FE)"
    fig.suptitle(
        f"{head}\nshape exaggerated ×{scale:g}; colour: |u|, loaded minus unloaded",
        fontsize="medium",
    )
    return finish(fig, path)


def _tag(ax: Axes, text: str, at: npt.NDArray[np.float64]) -> None:
    """A small label next to a point."""
    ax.annotate(
        text,
        tuple(at),
        xytext=(-20, 8),
        textcoords="offset points",
        fontsize="small",
        bbox={"fc": "white", "ec": "none", "alpha": 0.75, "pad": 0.5},
        zorder=9,
    )


def _torque(ax: Axes, at: npt.NDArray[np.float64], t: float, r: float, what: str) -> None:
    """A drive's torque on its link: a curved arrow around the joint, counter-clockwise for
    T > 0, and its value."""
    from matplotlib.patches import FancyArrowPatch

    a0, a1 = (-1.0, 1.0) if t >= 0 else (1.0, -1.0)
    start = at + r * np.array([math.cos(a0), math.sin(a0)])
    end = at + r * np.array([math.cos(a1), math.sin(a1)])
    ax.add_patch(
        FancyArrowPatch(
            tuple(start),
            tuple(end),
            connectionstyle=f"arc3,rad={0.6 if t >= 0 else -0.6}",
            arrowstyle="-|>",
            mutation_scale=14,
            color=PALETTE[4],
            lw=2.2,
            zorder=5,
        )
    )
    ax.annotate(
        what.replace("-", "−"),
        tuple(at + np.array([r, -r])),
        xytext=(6, -10),
        textcoords="offset points",
        fontsize="small",
        color=PALETTE[4],
        bbox={"fc": "white", "ec": "none", "alpha": 0.8, "pad": 0.5},
        zorder=6,
    )


def moment_diagrams(
    arm: Arm,
    out: Mapping[str, Any],
    row: int = 0,
    title: str | None = None,
    path: PathLike | None = None,
) -> Figure:
    """The bending moment along each link: loaded (self-weight + payload) and its change.

    Parameters
    ----------
    arm, out, row : the arm, ``eodarm.solve(..., model="fem")``'s output and its pose.
    title : the figure's title.
    path : where to write a PNG.

    Returns
    -------
    Figure
        One panel per link against its local x (mm): ``moment_nmm`` filled (N·m), the payload's
        change ``dmoment_nmm`` dashed, the pins' abscissae marked. M is the moment of the
        loads beyond the section, counter-clockwise positive (``EI·v″ = M``, docs/fem.md).
    """
    m = np.asarray(_row(out, "moment_nmm", row), dtype=float) / 1000.0
    dm = np.asarray(_row(out, "dmoment_nmm", row), dtype=float) / 1000.0
    xs = np.asarray(out["moment_x_mm"], dtype=float)
    n = arm.n
    fig = figure(8.4, 2.3 * n + 0.8)
    axes = fig.subplots(n, 1, squeeze=False)[:, 0]
    for i, ax in enumerate(axes):
        _moment_panel(ax, arm, i, xs[i], m[i], dm[i])
    axes[-1].set_xlabel("x along the link [mm] (local frame, joint at 0)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=2, fontsize="small")
    fig.suptitle(
        title or f"{arm.name}: bending moment along the links (FE)",
        fontsize="medium",
    )
    return finish(fig, path)


def _moment_panel(
    ax: Axes,
    arm: Arm,
    i: int,
    x: npt.NDArray[np.float64],
    m: npt.NDArray[np.float64],
    dm: npt.NDArray[np.float64],
) -> None:
    ax.fill_between(x, 0.0, m, where=m >= 0, color=PALETTE[0], alpha=0.35, lw=0)
    ax.fill_between(x, 0.0, m, where=m < 0, color=PALETTE[3], alpha=0.35, lw=0)
    ax.plot(x, m, color="k", lw=1.4, label="loaded (weights + payload)")
    ax.plot(x, dm, color=PALETTE[1], lw=1.6, ls="--", label="change under the payload")
    ax.axhline(0.0, color=GREY, lw=0.8)
    link = arm.links[i]
    k = i + 1
    marks = [(f"O{k}", 0.0), (f"C{k}", link.C[0])]
    if link.A is not None:
        marks.insert(1, (f"A{k}", link.A[0]))
    if link.B is not None:
        marks.append((f"B{k}", link.B[0]))
    if k == arm.n:
        marks.append(("measure", arm.measure[0]))
    marks.append((f"O{k + 1}" if k < arm.n else "load", link.next[0]))
    # Marks closer than 2 % of the link share one label.
    tol = 0.02 * float(np.ptp(x))
    merged: list[tuple[str, float]] = []
    for name, xp in sorted(marks, key=lambda m: m[1]):
        if merged and xp - merged[-1][1] <= tol:
            merged[-1] = (f"{merged[-1][0]}/{name}", merged[-1][1])
        else:
            merged.append((name, xp))
    right = float(x.max()) - 0.1 * float(np.ptp(x))
    for name, xp in merged:
        ax.axvline(xp, color="0.5", lw=0.7, ls=":")
        ax.annotate(
            name,
            (xp, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(-2 if xp > right else 2, -2),
            textcoords="offset points",
            ha="right" if xp > right else "left",
            va="top",
            fontsize="x-small",
            color="0.3",
        )
    ax.set_ylabel(f"link {i + 1}\nM [N·m]")
    ax.grid(True, lw=0.4, alpha=0.4)


def pin_forces(
    arm: Arm,
    out: Mapping[str, Any],
    row: int = 0,
    title: str | None = None,
    path: PathLike | None = None,
) -> Figure:
    """The loaded forces on the links at their pins, as arrows on the undeformed arm.

    Parameters
    ----------
    arm, out, row : the arm, ``eodarm.solve(..., model="fem")``'s output and its pose.
    title : the figure's title.
    path : where to write a PNG.

    Returns
    -------
    Figure
        At each joint O_i the force of the proximal body on link i (``pin_force_n[:n]``), at
        each actuator pin A_i the actuator's force on link i (``pin_force_n[n:]``), arrows
        scaled alike and labelled in N; at a rotary drive, its torque on link i
        (``torque_nmm``) as a curved arrow around O_i, counter-clockwise for T > 0, in N·m.
        Actuators in compression push their links (arrow away from the actuator), in tension
        pull them.
    """
    pf = np.asarray(_row(out, "pin_force_n", row), dtype=float)
    xy = np.asarray(_row(out, "node_xy", row), dtype=float)
    seg = np.asarray(out["segments"], dtype=int)
    kind = np.asarray(out["segment_kind"], dtype=int)
    node_kind = np.asarray(out["node_kind"], dtype=int)
    n = arm.n
    joints = [_node(node_kind, _JOINT, i + 1) for i in range(n)]
    fig = figure(9.0, 6.6)
    ax = fig.add_subplot()
    colours = {0: "0.55", 1: "0.65", 2: "#f5c38f", 3: "0.75"}
    for (a, b), k in zip(seg, kind, strict=True):
        ax.plot(*np.stack([xy[a], xy[b]]).T, color=colours[int(k)], lw=_WIDTH[k] * 0.6, zorder=1)
    force = np.asarray(_row(out, "force_n", row), dtype=float)
    torque = np.asarray(_row(out, "torque_nmm", row), dtype=float) if "torque_nmm" in out else None
    size = float(np.ptp(xy, axis=0).max())
    finite = np.isfinite(pf).all(axis=1)
    fmax = float(np.hypot(pf[finite, 0], pf[finite, 1]).max()) or 1.0
    k = 0.22 * size / fmax
    for i in range(n):
        arrows = [(xy[joints[i]], pf[i], PALETTE[0], f"R{i + 1} = {math.hypot(*pf[i]):.0f} N")]
        if arm.is_rotary(i):
            t = float("nan") if torque is None else float(torque[i])
            _torque(ax, xy[joints[i]], t, 0.05 * size, f"T{i + 1} = {t / 1000:.1f} N·m")
        else:
            state = "compression" if force[i] > 0 else "tension"
            a_pin = xy[_node(node_kind, _PIN_A, i + 1)]
            arrows.append((a_pin, pf[n + i], PALETTE[2], f"F{i + 1} = {force[i]:.0f} N ({state})"))
        for at, f, colour, what in arrows:
            ax.annotate(
                "",
                xy=tuple(at + k * f),
                xytext=tuple(at),
                arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 2.2},
                zorder=5,
            )
            ax.annotate(
                what.replace("-", "−"),
                tuple(at + k * f),
                xytext=(4, 4),
                textcoords="offset points",
                fontsize="small",
                color=colour,
                bbox={"fc": "white", "ec": "none", "alpha": 0.8, "pad": 0.5},
                zorder=6,
            )
    ax.plot(*xy[joints].T, "o", mfc="white", mec="k", mew=1.4, ms=9, zorder=4, ls="none")
    for i in range(n):
        _tag(ax, f"O{i + 1}", xy[joints[i]])
    ax.plot([], [], color=PALETTE[0], lw=2.2, label="joint O_i: proximal body on link i")
    if any(arm.is_linear(i) for i in range(n)):
        ax.plot([], [], color=PALETTE[2], lw=2.2, label="pin A_i: actuator i on link i")
    if any(arm.is_rotary(i) for i in range(n)):
        ax.plot([], [], color=PALETTE[4], lw=2.2, label="drive i's torque on link i")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.margins(0.12)
    ax.grid(True, lw=0.4, alpha=0.4)
    ax.set_xlabel("x [mm] (forward)")
    ax.set_ylabel("y [mm] (up)")
    ax.legend(loc="lower left", fontsize="small", framealpha=0.85)
    fig.suptitle(
        title or f"{arm.name}: loaded pin forces on the links (FE; arrows ∝ force)",
        fontsize="medium",
    )
    return finish(fig, path)
