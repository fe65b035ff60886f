"""Workspace maps of a sweep, drawn: sag, actuator forces, payload capacity, the dominant effect.

Each map draws every reachable pose of a sweep (:func:`eodarm.sweep`) as a dot at its
unloaded load point (x, y) in the global frame, coloured by a quantity. Many poses of a grid
land near the same (x, y) (the last link's angle is free, for one); the dots are drawn in
order of the quantity, so that where poses overlap **the worst one is on top** (largest sag,
largest |force|, smallest capacity, largest deflection). Poses whose cell is not ok (out of
stroke, near singular, over force, a deflection too large for the model; docs/model.md §7)
have no value: the sag and force maps shade their pixels grey, under the valid ones, and
count them by reason.

Like :mod:`eodarm.viz.plots`, every function returns a :class:`matplotlib.figure.Figure` on its
own Agg canvas and writes a PNG (120 dpi) only when ``path=`` is given.

* :func:`sag_map`: the vertical displacement dy of the measure point at one payload.
* :func:`force_maps`: each actuator's loaded force at one payload.
* :func:`capacity_map` (numbers from :func:`payload_capacity`): the largest payload before an
  actuator reaches its force limit or a stroke limit, and which limit it is.
* :func:`dominant_effect_map` (numbers from :func:`effect_contributions`): which mechanism
  moves the measure point most, each alone on top of the baseline.

:func:`render_all` writes the four (``eodarm sweep --plot DIR``).
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

try:
    from matplotlib.axes import Axes
    from matplotlib.colors import BoundaryNorm, ListedColormap, LogNorm, Normalize
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator
except ImportError as exc:  # pragma: no cover - depends on the environment
    raise ImportError(
        "eodarm.maps needs matplotlib: pip install 'eodarm[plot]' (or matplotlib>=3.8)"
    ) from exc

from eodarm.errors import EodarmError
from eodarm.model.arm import Actuator, Arm
from eodarm.model.effects import Effect
from eodarm.model.solver import forward
from eodarm.viz.format import value
from eodarm.viz.style import PALETTE, PathLike, figure, finish
from eodarm.workspace.maps import (
    arm_of,
    assume_max_force,
    effect_contributions,
    not_ok_points,
    payload_capacity,
)
from eodarm.workspace.sweep import sweep

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "capacity_map",
    "dominant_effect_map",
    "force_maps",
    "render_all",
    "sag_map",
]

FloatArray = npt.NDArray[np.float64]

#: Colour of the pixels whose poses are not ok (outside the model's validity).
NOT_OK_GREY = "0.80"
#: A note in a map's corner is wrapped to this many characters: at fontsize 7 it stays
#: within the narrowest map (the capacity map's left panel), off the y tick labels.
NOTE_CHARS = 64


def _select_mass(ds: xr.Dataset, mass: float | None) -> tuple[xr.Dataset, float]:
    if "mass_kg" not in ds.dims:
        raise EodarmError(
            "this map needs a sweep with a mass_kg dimension (not reduced over the payload)"
        )
    masses = np.asarray(ds["mass_kg"].values, dtype=float)
    m = float(masses.max()) if mass is None else float(mass)
    hit = np.flatnonzero(np.isclose(masses, m, rtol=0.0, atol=1e-12))
    if hit.size == 0:
        listed = ", ".join(f"{v:g}" for v in masses)
        raise EodarmError(f"payload {m:g} kg is not in the sweep (mass_kg: {listed})")
    return ds.isel(mass_kg=int(hit[0])), float(masses[hit[0]])


def _points(ds: xr.Dataset, var: xr.DataArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Flat (x, y, value) of the reachable, solved poses of a per-pose variable."""
    for key in ("effector_x_mm", "effector_y_mm"):
        if key not in ds:
            raise EodarmError(
                "this map needs the effector positions: a sweep not reduced over an angle"
            )
    ok = ds["reachable"]
    if "ok" in ds and "mass_kg" not in ds["ok"].dims:
        ok = ok & ds["ok"]
    dims = list(ds["effector_x_mm"].dims)
    x = ds["effector_x_mm"].transpose(*dims).values.reshape(-1)
    y = ds["effector_y_mm"].transpose(*dims).values.reshape(-1)
    v = var.transpose(*dims).values.reshape(-1).astype(float)
    keep = ok.transpose(*dims).values.reshape(-1) & np.isfinite(v) & np.isfinite(x)
    return x[keep], y[keep], v[keep]


def _frame_points(ds: xr.Dataset) -> tuple[FloatArray, FloatArray]:
    """The unloaded load points of every reachable pose of a sweep's grid (valid or not at
    any payload): every map of one grid is framed and pixelled by these, so that the maps of
    one sweep share their bounds and pixel size whatever each draws."""
    if "effector_x_mm" not in ds:
        return np.empty(0), np.empty(0)
    dims = list(ds["effector_x_mm"].dims)
    x = ds["effector_x_mm"].transpose(*dims).values.reshape(-1)
    y = ds["effector_y_mm"].transpose(*dims).values.reshape(-1)
    keep = np.isfinite(x) & np.isfinite(y)
    if "reachable" in ds:
        keep &= ds["reachable"].transpose(*dims).values.reshape(-1)
    return x[keep], y[keep]


def _ok_poses(ds: xr.Dataset) -> int:
    """Poses of a one-payload slice that are reachable and whose cell is ok (the model valid:
    docs/model.md §7); for a Dataset of :func:`effect_contributions`, its model's own."""
    ok = ds["reachable"]
    for key in ("model_ok", "ok"):
        if key in ds and "mass_kg" not in ds[key].dims:
            return int((ok & ds[key]).sum())
    return int(ok.sum())


class _Canvas:
    """The common frame of the maps: bounds in mm, the pixel grid, the arm drawn thin.

    Poses are binned into square pixels of ``width`` mm over the bounds of the reachable load
    points; each pixel takes the value of the worst pose that lands in it. :meth:`of` frames
    a sweep's grid (every map of one sweep: the same bounds, the same pixels).
    """

    @classmethod
    def of(cls, arm: Arm, ds: xr.Dataset) -> _Canvas:
        """The canvas of a sweep's grid: framed by every reachable pose's load point."""
        return cls(arm, *_frame_points(ds), _ref_pose(ds, arm.n))

    def __init__(self, arm: Arm, xs: FloatArray, ys: FloatArray, ref: FloatArray | None) -> None:
        self.arm = arm
        self.not_ok = ""  # legend text of the grey pixels (set by shade)
        self.ref = ref if ref is not None and np.isfinite(ref).all() else None
        base = [arm.O1] + ([arm.B0] if arm.B0 is not None else [])
        px = [p[0] for p in base]
        py = [p[1] for p in base]
        self.geo = forward(arm, self.ref[None, :]) if self.ref is not None else None
        if self.geo is not None:
            px += [*self.geo["O"][0, :, 0], *self.geo["B"][0, :, 0]]
            py += [*self.geo["O"][0, :, 1], *self.geo["B"][0, :, 1]]
        if xs.size:
            px += [float(xs.min()), float(xs.max())]
            py += [float(ys.min()), float(ys.max())]
        x0, x1, y0, y1 = min(px), max(px), min(py), max(py)
        pad = 0.05 * max(x1 - x0, y1 - y0, 1.0)
        self.bounds = (x0 - pad, x1 + pad, y0 - pad, y1 + pad)
        # pixels: about sqrt(count / 5) across the larger side of the points' box, 24…160
        span = max(float(np.ptp(xs)) if xs.size else 0.0, float(np.ptp(ys)) if ys.size else 0.0)
        nb = int(np.clip(np.sqrt(max(xs.size, 1) / 5.0), 24, 160))
        self.width = max(span / nb, 1e-6 * max(x1 - x0, 1.0))

    @property
    def aspect(self) -> float:
        x0, x1, y0, y1 = self.bounds
        return (y1 - y0) / (x1 - x0)

    def raster(
        self, x: FloatArray, y: FloatArray, value: FloatArray, worst: FloatArray
    ) -> tuple[FloatArray, FloatArray, np.ma.MaskedArray[Any, Any]]:
        """Pixel edges and an image whose every pixel holds the value of its worst pose."""
        x0, _, y0, _ = self.bounds
        w = self.width
        ix = np.floor((x - x0) / w).astype(np.int64)
        iy = np.floor((y - y0) / w).astype(np.int64)
        nx, ny = int(ix.max(initial=0)) + 1, int(iy.max(initial=0)) + 1
        img = np.full((ny, nx), np.nan)
        if x.size:
            cell = iy * nx + ix
            order = np.lexsort((worst, cell))  # by pixel, then by worst: the last one wins
            last = np.r_[cell[order][1:] != cell[order][:-1], True]
            pick = order[last]
            img.flat[cell[pick]] = value[pick]
        xe = x0 + w * np.arange(nx + 1, dtype=float)
        ye = y0 + w * np.arange(ny + 1, dtype=float)
        return xe, ye, np.ma.masked_invalid(img)

    def draw(
        self,
        ax: Axes,
        x: FloatArray,
        y: FloatArray,
        value: FloatArray,
        worst: FloatArray,
        **kw: Any,
    ) -> Any:
        xe, ye, img = self.raster(x, y, value, worst)
        mesh = ax.pcolormesh(xe, ye, img, shading="flat", rasterized=True, **kw)
        self.frame(ax)
        return mesh

    def shade(self, ax: Axes, bad: tuple[FloatArray, FloatArray, dict[str, int]]) -> None:
        """Grey pixels under the map where poses are not ok; :meth:`legend` counts them."""
        x, y, counts = bad
        if not x.size:
            return
        xe, ye, img = self.raster(x, y, np.ones_like(x), np.ones_like(x))
        grey = ListedColormap([NOT_OK_GREY])
        ax.pcolormesh(
            xe, ye, img, shading="flat", rasterized=True, cmap=grey, zorder=0.9, gid="not_ok"
        )
        # one reason per line: the legend stands in a narrow column at the figure's right
        self.not_ok = "\n".join(["poses not ok:", *(f"{k:,} {name}" for name, k in counts.items())])

    def frame(self, ax: Axes) -> None:
        """Equal axes in mm, the chassis pins and the arm drawn thin at its middle pose."""
        x0, x1, y0, y1 = self.bounds
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ax.grid(True, color="0.88", lw=0.6)
        ax.set_axisbelow(True)
        if self.geo is not None:
            o = self.geo["O"][0]
            ax.plot(o[:, 0], o[:, 1], "-", color="0.2", lw=1.3, zorder=3)
            ax.plot(o[:-1, 0], o[:-1, 1], "o", ms=3.5, mfc="white", mec="0.2", zorder=4)
            for a, b in zip(self.geo["A"][0], self.geo["B"][0], strict=True):
                ax.plot([a[0], b[0]], [a[1], b[1]], "-", color="0.45", lw=0.9, zorder=3)
        ax.plot(*self.arm.O1, marker="^", color="k", ms=7, zorder=5, ls="none")
        if self.arm.B0 is not None:
            ax.plot(*self.arm.B0, marker="s", color="k", ms=4, zorder=5, ls="none")

    def legend(self, ax: Axes) -> None:
        """The key to the arm drawing, added without replacing another legend."""
        handles: list[Any] = [
            Line2D(
                [],
                [],
                color="0.2",
                lw=1.3,
                marker="o",
                ms=3.5,
                mfc="white",
                label="arm, middle pose of the grid",
            ),
            Line2D([], [], color="k", marker="^", ls="none", ms=7, label="O1 (first joint)"),
        ]
        if "linear" in self.arm.kinds:  # a rotary drive has no actuator line, no chassis pin
            handles.insert(1, Line2D([], [], color="0.45", lw=0.9, label="actuators"))
        if self.arm.B0 is not None:
            handles.append(
                Line2D([], [], color="k", marker="s", ls="none", ms=4, label="B0 (chassis pin)")
            )
        if self.not_ok:
            handles.append(Patch(fc=NOT_OK_GREY, label=self.not_ok))
        # Outside the axes, at the figure's right, so that it never covers the map (the
        # figures' own legends take the bottom; two outside legends in one place overlap).
        fig = ax.get_figure()
        assert isinstance(fig, Figure)
        fig.legend(
            handles=handles,
            loc="outside right center",
            fontsize=7,
            frameon=False,
        )

    def note(
        self,
        ax: Axes | Figure,
        ds: xr.Dataset,
        shown: int,
        worst: str,
        mass: float | None = None,
        missing: str = "",
        ok: int | None = None,
        what: str = "ok",
        above: str | None = None,
    ) -> None:
        """Say how many poses are ok (the same count on every map of a payload), how many
        are drawn when fewer (``missing`` says why) and what a pixel shows (in an axes, or
        under a figure). In an axes the lines are wrapped to :data:`NOTE_CHARS` (within the
        narrowest map's width, clear of the tick labels), and ``above`` (the map's range, at
        fontsize 8) stands on top of them, however many lines they take."""
        total = int(np.prod([ds.sizes[d] for d in ds["reachable"].dims]))
        good = _ok_poses(ds) if ok is None else ok
        at = f" at {mass:g} kg" if mass is not None else ""
        drawn = f"\n{shown:,} drawn ({missing})" if shown != good else ""
        text = (
            f"{good:,} of {total:,} poses {what}{at}; each {self.width:.3g} mm "
            f"pixel shows its {worst} pose{drawn}"
        )
        if isinstance(ax, Figure):
            text = "\n".join(textwrap.fill(line, 100) for line in text.split("\n"))
            ax.supxlabel(text, fontsize=7, color="0.25")
            return
        text = "\n".join(textwrap.fill(line, NOTE_CHARS) for line in text.split("\n"))
        box = {"fc": "white", "ec": "none", "alpha": 0.8, "pad": 1.0}
        note = ax.text(
            0.99,
            0.01,
            text,
            transform=ax.transAxes,
            ha="right",
            va="bottom",
            fontsize=7,
            color="0.25",
            bbox=box,
        )
        if above:
            ax.annotate(
                above,
                xy=(1.0, 1.0),
                xycoords=note,
                xytext=(0, 3),
                textcoords="offset points",
                ha="right",
                va="bottom",
                fontsize=8,
                bbox=box,
            )


def log_ticks(cb: Any, lo: float, hi: float, most: int = 5) -> None:
    """Label a log-scale colour bar at round numbers (1, 2, 5 × 10ᵏ) between ``lo`` and
    ``hi``, at most ``most`` of them, written as numbers (``0.05``, ``20``: not ``2×10¹``),
    and no labelled minor ticks: on a narrow or horizontal bar those collide."""
    from matplotlib.ticker import FixedFormatter, FixedLocator, NullFormatter, NullLocator

    k0, k1 = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    ticks = [m * 10.0**k for k in range(k0, k1 + 1) for m in (1, 2, 5) if lo <= m * 10.0**k <= hi]
    while len(ticks) > most:
        ticks = ticks[::2]
    if not ticks:
        ticks = [lo, hi]
    axis = cb.ax.xaxis if cb.orientation == "horizontal" else cb.ax.yaxis
    axis.set_major_locator(FixedLocator(ticks))
    axis.set_major_formatter(FixedFormatter([value(t, digits=2) for t in ticks]))
    axis.set_minor_locator(NullLocator())
    axis.set_minor_formatter(NullFormatter())


def _robust(values: FloatArray, lo_q: float, hi_q: float) -> tuple[float, float, str]:
    """Colour limits at quantiles (so near-singular poses do not flatten the scale), and the
    colour bar's ``extend``."""
    lo, hi = (float(v) for v in np.quantile(values, [lo_q, hi_q]))
    if hi <= lo:
        lo, hi = lo - 0.5, hi + 0.5
    below, above = bool(values.min() < lo), bool(values.max() > hi)
    extend = "both" if below and above else "min" if below else "max" if above else "neither"
    return lo, hi, extend


def _ref_pose(ds: xr.Dataset, arm_n: int) -> FloatArray | None:
    """The middle pose of the grid (its angles), for drawing the arm."""
    if ds.attrs.get("grid", "alpha") != "alpha":
        if "alpha_deg" not in ds:
            return None
        a = ds["alpha_deg"]
        mid = {d: a.sizes[d] // 2 for d in a.dims if d != "link"}
        return np.asarray(a.isel(mid).values, dtype=float)
    out = np.empty(arm_n)
    for i in range(arm_n):
        name = f"alpha{i + 1}"
        if name not in ds.coords:
            return None
        c = np.atleast_1d(ds[name].values)
        out[i] = float(c[len(c) // 2])
    return out


def _title(
    ds: xr.Dataset, what: str, mass: float | None, model: str | None = None, width: float = 9.0
) -> str:
    """Two or more lines: what, arm and payload; the model, wrapped to a figure ``width`` in."""
    payload = f", payload {mass:g} kg" if mass is not None else ""
    sw = "" if ds.attrs.get("self_weight", 1) else "; no self-weight"
    text = f"model: {model or ds.attrs.get('model', '?')}{sw}"
    return f"{what} — arm '{ds.attrs.get('arm', '?')}'{payload}\n" + "\n".join(
        textwrap.wrap(text, int(11 * width))
    )


# ---------------------------------------------------------------------------- sag
def sag_map(
    ds: xr.Dataset,
    mass: float | None = None,
    *,
    path: PathLike | None = None,
) -> Figure:
    """Effector sag over the reachable workspace: dy of the measure point at one payload.

    Parameters
    ----------
    ds : a sweep (:func:`eodarm.sweep`) not reduced over the payload or an angle.
    mass : the payload, kg, one of ``ds.mass_kg`` (default: the largest).
    path : where to write a PNG (120 dpi).

    Returns
    -------
    Figure
        The reachable load points binned into pixels, each coloured by the largest sag (most
        negative dy, mm) of the poses that reach it. The colour scale spans the 1st–100th
        percentile so that the few near-singular poses do not flatten it; the colour bar's
        arrow marks the poses beyond.
    """
    arm = arm_of(ds)
    sel, m = _select_mass(ds, mass)
    x, y, dy = _points(sel, sel["dy_mm"])
    bad = not_ok_points(sel)
    cv = _Canvas.of(arm, ds)
    fig = figure(8.4, 7.0 * cv.aspect + 1.6)
    ax = fig.add_subplot()
    cv.shade(ax, bad)
    if dy.size:
        sag = -dy
        clipped = False
        if sag.min() > 0 and sag.max() > 10 * sag.min():  # spans decades: log scale of the sag
            mesh = cv.draw(ax, x, y, sag, sag, cmap="viridis_r", norm=LogNorm(sag.min(), sag.max()))
            cb = fig.colorbar(mesh, ax=ax, shrink=0.9)
            cb.set_label("sag −dy of the measure point (mm, down; log scale)")
            log_ticks(cb, float(sag.min()), float(sag.max()))
        else:
            lo, hi, extend = _robust(dy, 0.02, 0.98)
            clipped = extend != "neither"
            mesh = cv.draw(ax, x, y, dy, -dy, cmap="viridis", norm=Normalize(lo, hi))
            cb = fig.colorbar(mesh, ax=ax, shrink=0.9, extend=extend)
            cb.set_label("dy of the measure point (mm, negative = down)")
        summary = (
            f"dy from {value(float(dy.min()), 'mm', 3)} to {value(float(dy.max()), 'mm', 3)}, "
            f"median {value(float(np.median(dy)), 'mm', 3)}"
            + ("\ncolours span 2–98 % of the poses; arrows: beyond" if clipped else "")
        )
    else:
        cv.frame(ax)
        summary = None
    cv.legend(ax)
    cv.note(ax, sel, dy.size, "most sagging", m, "the others' dy is not finite", above=summary)
    fig.suptitle(_title(ds, "Sag of the measure point", m, width=7.0), fontsize=10)
    return finish(fig, path)


# ---------------------------------------------------------------------------- forces
def force_maps(
    ds: xr.Dataset,
    mass: float | None = None,
    *,
    path: PathLike | None = None,
) -> Figure:
    """Each actuator's loaded force over the reachable workspace, one panel per actuator (a
    rotary drive's panel: its loaded torque, N·mm, counter-clockwise on its link positive).

    Each panel has its own colour scale spanning 2–98 % of its poses (arrows: the
    near-singular poses beyond, whose forces would flatten a full scale): red for compression,
    blue for tension, diverging around zero when the force changes sign. Each pixel shows the
    pose of largest |F|. An actuator's ``max_force_n``, when set, is in its panel's title and
    marked on its colour bar, and a drive's ``max_torque_nmm`` likewise.
    """
    arm = arm_of(ds)
    sel, m = _select_mass(ds, mass)
    n = arm.n
    rotary = [k == "rotary" for k in arm.kinds]
    pts = [
        _points(sel, sel["torque_nmm" if rotary[i] else "force_n"].sel(actuator=i + 1))
        for i in range(n)
    ]
    bad = not_ok_points(sel)
    cv = _Canvas.of(arm, ds)
    ncols = min(n, 3)
    nrows = math.ceil(n / ncols)
    fig = figure(5.0 * ncols + 0.6, (4.8 * cv.aspect + 1.3) * nrows + 1.0)
    axes = list(fig.subplots(nrows, ncols, squeeze=False).flat)
    for i, ax in enumerate(axes):
        if i >= n:
            fig.delaxes(ax)
            continue
        x, y, f = pts[i]
        cv.shade(ax, bad)
        lim = getattr(arm.actuators[i], "max_torque_nmm" if rotary[i] else "max_force_n", None)
        sym, unit = ("T", "N·mm") if rotary[i] else ("F", "N")
        if f.size:
            lo, hi, extend = _robust(f, 0.02, 0.98)
            if lo < 0 < hi:
                top = max(-lo, hi)
                cmap, norm = "RdBu_r", Normalize(-top, top)
            elif hi <= 0:
                cmap, norm = "Blues_r", Normalize(lo, hi)
            else:
                cmap, norm = "Reds", Normalize(lo, hi)
            mesh = cv.draw(ax, x, y, f, np.abs(f), cmap=cmap, norm=norm)
            cb = fig.colorbar(
                mesh, ax=ax, orientation="horizontal", shrink=0.85, pad=0.02, extend=extend
            )
            cb.set_label(f"{sym}{i + 1} ({unit}), 2–98 % of poses", fontsize=8)
            cb.ax.xaxis.set_major_locator(MaxNLocator(5))  # a narrow bar: few labels
            if lim is not None:
                for v in (-lim, lim):
                    if (
                        norm.vmin is not None
                        and norm.vmax is not None
                        and norm.vmin <= v <= norm.vmax
                    ):
                        cb.ax.axvline(v, color="k", lw=1.2)
        else:
            cv.frame(ax)
        extra = f"; limit ±{lim:g} {unit}" if lim is not None else ""
        rng = f"{value(f.min(), digits=4)} … {value(f.max(), unit, 4)}" if f.size else "no pose ok"
        what = "drive" if rotary[i] else "actuator"
        ax.set_title(f"{what} {i + 1}: {sym}{i + 1} from {rng}{extra}", fontsize=9)
    cv.legend(axes[0])
    cv.note(fig, sel, pts[0][2].size, "largest-|F|", m, "the others' forces are not finite")
    head = "Loaded actuator forces (+ compression, − tension)"
    if all(rotary):
        head = "Loaded drive torques (+ counter-clockwise on the link)"
    elif any(rotary):
        head += " and drive torques (+ counter-clockwise on the link)"
    fig.suptitle(
        _title(ds, head, m, width=15.0),
        fontsize=10,
    )
    return finish(fig, path)


def capacity_map(
    arm: Arm,
    grid: Any,
    *,
    effects: Effect | Iterable[Effect] | None = (),
    self_weight: bool = True,
    max_payload_kg: float = 100.0,
    path: PathLike | None = None,
    **sweep_kw: Any,
) -> Figure:
    """Payload capacity over the reachable workspace (:func:`payload_capacity`).

    Two panels: the capacity (kg; where poses overlap the smallest is on top) and which limit
    binds (an actuator's force limit, its stroke, or the cap).
    """
    cap = payload_capacity(
        arm,
        grid,
        effects=effects,
        self_weight=self_weight,
        max_payload_kg=max_payload_kg,
        **sweep_kw,
    )
    labels = str(cap.attrs["limit_labels"]).split(", ")
    x, y, c = _points(cap, cap["capacity_kg"])
    _, _, lim = _points(cap, cap["limit"].where(cap["limit"] >= 0))
    cv = _Canvas.of(arm, cap)
    fig = figure(13.6, 5.6 * cv.aspect + 2.0)
    ax1, ax2 = fig.subplots(1, 2)
    if c.size:
        mesh = cv.draw(ax1, x, y, c, -c, cmap="plasma", norm=Normalize(0.0, max(c.max(), 1e-9)))
        cb = fig.colorbar(mesh, ax=ax1, shrink=0.9)
        cb.set_label(f"payload capacity (kg), capped at {max_payload_kg:g}")
        used = sorted({int(v) for v in lim})
        colours = [PALETTE[k % len(PALETTE)] if labels[k] != "cap" else "0.75" for k in used]
        remap = np.searchsorted(used, lim.astype(int)).astype(float)
        cmap = ListedColormap(colours)
        norm = BoundaryNorm(np.arange(len(used) + 1) - 0.5, len(used))
        cv.draw(ax2, x, y, remap, -c, cmap=cmap, norm=norm)
        handles = [
            Patch(color=col, label=f"{labels[k]} ({100 * np.mean(lim == k):.0f} % of poses)")
            for k, col in zip(used, colours, strict=True)
        ]
        fig.legend(
            handles=handles,
            loc="outside lower center",
            ncols=min(len(handles), 3),
            fontsize=8,
            title="binding limit (right map)",
            title_fontsize=8,
        )
    else:
        cv.frame(ax1)
        cv.frame(ax2)
    cv.legend(ax1)
    cv.note(ax1, cap, c.size, "smallest-capacity", ok=c.size, what="with a capacity")
    limits = []
    for i, a in enumerate(arm.actuators):
        parts = []
        if not isinstance(a, Actuator):
            if a.max_torque_nmm is not None:
                parts.append(f"|T| ≤ {a.max_torque_nmm:g} N·mm")
            if a.min_angle_deg is not None or a.max_angle_deg is not None:
                lo = "−∞" if a.min_angle_deg is None else f"{a.min_angle_deg:g}"
                hi = "∞" if a.max_angle_deg is None else f"{a.max_angle_deg:g}"
                parts.append(f"q {lo}–{hi}°")
            limits.append(f"drive {i + 1}: " + (", ".join(parts) or "no limit"))
            continue
        if a.max_force_n is not None:
            parts.append(f"|F| ≤ {a.max_force_n:g} N")
        if a.min_length_mm is not None or a.max_length_mm is not None:
            lo = "−∞" if a.min_length_mm is None else f"{a.min_length_mm:g}"
            hi = "∞" if a.max_length_mm is None else f"{a.max_length_mm:g}"
            parts.append(f"stroke {lo}–{hi} mm")
        limits.append(f"A{i + 1}: " + (", ".join(parts) or "no limit"))
    ax1.set_title(
        "Largest payload before any actuator limit"
        if "rotary" not in arm.kinds
        else "Largest payload before any actuator or drive limit",
        fontsize=10,
    )
    ax2.set_title("Which limit binds first", fontsize=10)
    fig.suptitle(
        _title(cap, "Payload capacity", None) + "\nlimits: " + "; ".join(limits), fontsize=10
    )
    return finish(fig, path)


def dominant_effect_map(
    arm: Arm,
    grid: Any,
    effects: Effect | Iterable[Effect] | None,
    mass: float,
    *,
    self_weight: bool = True,
    path: PathLike | None = None,
    **sweep_kw: Any,
) -> Figure:
    """Which part of the model makes most of the sag, at each reachable pose (categorical).

    Numbers from :func:`effect_contributions`: the sag budget's Shapley shares (the report's
    "who makes the sag"), of the model the arm file's effects then ``effects``. Where poses
    overlap, the pose with the largest dominant share is on top. The legend gives each
    component's share of the poses it dominates and its mean share of the sag.
    """
    from eodarm.viz.budget_plot import component_colours, component_name

    con = effect_contributions(arm, grid, effects, mass, self_weight=self_weight, **sweep_kw)
    keys = [str(v) for v in con["effect"].values]
    labels = [component_name(k) for k in keys]
    dom = con["dominant"].where(con["dominant"] >= 0)
    x, y, d = _points(con, dom)
    top = con["contribution_mm"].max("effect")
    _, _, size = _points(con, top.where(con["dominant"] >= 0))
    cv = _Canvas.of(arm, con)
    fig = figure(9.6, 7.0 * cv.aspect + 4.0)
    ax = fig.add_subplot()
    if d.size:
        k = len(labels)
        colours = component_colours(keys)
        mean = con["share"].mean([d for d in con["share"].dims if d != "effect"]).values
        cmap = ListedColormap(colours)
        norm = BoundaryNorm(np.arange(k + 1) - 0.5, k)
        cv.draw(ax, x, y, d, size, cmap=cmap, norm=norm)
        handles = [
            Patch(
                color=colours[j],
                label=f"{labels[j]}: dominates {100 * np.mean(d == j):.0f} % of poses, "
                f"{100 * mean[j]:.0f} % of the sag on average",
            )
            for j in range(k)
        ]
        fig.legend(
            handles=handles,
            loc="outside lower center",
            ncols=min(k, 2),
            fontsize=8,
            title="the largest share of the sag dy (Shapley split from the rigid arm, "
            "as the report's sag budget)",
            title_fontsize=8,
        )
    else:
        cv.frame(ax)
    cv.legend(ax)
    cv.note(
        ax,
        con,
        d.size,
        "most deflected",
        mass,
        "in the others a part of the model alone cannot be solved",
    )
    title = _title(con, "Who makes the sag", mass, width=8.0)
    fig.suptitle(title, fontsize=10)
    return finish(fig, path)


# ---------------------------------------------------------------------------- all four
def render_all(
    arm: Arm,
    grid: Mapping[str, Any],
    effects: Sequence[Effect],
    mass: float,
    directory: PathLike,
    *,
    self_weight: bool = True,
    assumed_max_force_n: float | None = None,
    max_payload_kg: float = 100.0,
    ds: xr.Dataset | None = None,
    note: Callable[[str], None] | None = None,
    prefix: str = "",
    step: Callable[[str], None] | None = None,
    progress: bool | None = None,
) -> list[Path]:
    """Write the four maps into ``directory``: ``sag.png``, ``forces.png``, ``capacity.png``,
    ``dominant_effect.png`` (each name after ``prefix``).

    ``grid`` is :func:`eodarm.sweep` keyword arguments (``{"alpha_deg": {…}}``); ``ds`` a sweep
    of it that holds ``mass`` (else the grid is swept at ``mass``). Actuators without
    ``max_force_n`` get ``assumed_max_force_n`` for the capacity map (when given; ``note`` is
    told). ``step(name)`` is called before each map (a progress bar's stages); ``progress``
    is the dominant-effect map's bar over its sweeps (:mod:`eodarm.progress`).
    """
    step = step or (lambda _name: None)
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    if ds is None or "mass_kg" not in ds.dims:
        ds = sweep(arm, **grid, mass_kg=[mass], effects=effects, self_weight=self_weight)
    written = []
    step("sag map")
    p = out / f"{prefix}sag.png"
    sag_map(ds, mass, path=p)
    written.append(p)
    step("force maps")
    p = out / f"{prefix}forces.png"
    force_maps(ds, mass, path=p)
    written.append(p)
    cap_arm = arm
    if assumed_max_force_n is not None:
        missing = [
            str(i + 1)
            for i, a in enumerate(arm.actuators)
            if isinstance(a, Actuator) and a.max_force_n is None
        ]
        if missing:
            cap_arm = assume_max_force(arm, assumed_max_force_n)
            if note is not None:
                note(
                    f"capacity map: actuator(s) {', '.join(missing)} have no max_force_n; "
                    f"assuming {assumed_max_force_n:g} N"
                )
    step("capacity map")
    p = out / f"{prefix}capacity.png"
    capacity_map(
        cap_arm,
        grid,
        effects=effects,
        self_weight=self_weight,
        max_payload_kg=max_payload_kg,
        path=p,
    )
    written.append(p)
    step("who makes the sag")
    p = out / f"{prefix}dominant_effect.png"
    dominant_effect_map(
        arm, grid, effects, mass, self_weight=self_weight, path=p, progress=progress
    )
    written.append(p)
    return written
