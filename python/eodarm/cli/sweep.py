"""``eodarm sweep``: a whole grid of poses × payloads, written as NetCDF/Zarr, and its maps."""

from __future__ import annotations

import argparse
import math
import time
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from eodarm.cli._common import (
    ARM_HELP,
    _effects_args,
    _load_arm,
    _note,
    _one_line,
    _payload_hint,
    _say,
    _valued_effect,
    check_kinds_of,
)
from eodarm.cli._help import HELP, NEGATIVE_VALUE
from eodarm.cli._outputs import _claim, _force_arg
from eodarm.errors import EodarmError
from eodarm.workspace import store
from eodarm.workspace.sweep import CHUNK_SIZE, REDUCE_OPS, sweep

if TYPE_CHECKING:
    import xarray as xr

    from eodarm.model.arm import Arm

FloatArray = npt.NDArray[np.float64]


def parse_range(text: str, what: str) -> FloatArray:
    """``LO:HI:N`` → N values from LO to HI; ``V`` → [V]; ``a,b,c`` → [a, b, c]."""
    t = text.strip()
    try:
        if ":" in t:
            parts = t.split(":")
            if len(parts) != 3:
                raise ValueError
            lo, hi, k = float(parts[0]), float(parts[1]), int(parts[2])
            if k < 1 or not (math.isfinite(lo) and math.isfinite(hi)):
                raise ValueError
            vals = np.linspace(lo, hi, k)
        else:
            vals = np.array([float(v) for v in t.replace(";", ",").split(",") if v.strip()])
    except ValueError:
        raise EodarmError(
            f"{what} '{text}': expected LO:HI:N (N values from LO to HI), one value, or a "
            "comma-separated list"
        ) from None
    if vals.size == 0 or not np.isfinite(vals).all():
        raise EodarmError(f"{what} '{text}': give finite numbers")
    return vals


#: The CLI's default angle grid (degrees): link 1, link 2, and every further link. It spans
#: the seed arm's measured configurations with a margin.
DEFAULT_ALPHA = ("40:130:46", "-20:40:31", "-20:20:21")

#: Force limit (N) assumed by the CLI's capacity map for actuators without ``max_force_n``.
ASSUMED_MAX_FORCE_N = 1000.0

_MAX_LINKS = 9


# ---------------------------------------------------------------------------- command line
def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``eodarm sweep`` on an argparse sub-parser collection."""
    p = subparsers.add_parser(
        "sweep",
        help=HELP["sweep"],
        description="Sweep a grid of joint angles (--alphaK), actuator lengths (--lK) or "
        "effector positions (--x --y --phi) under payloads (--mass), write the result as "
        "NetCDF (.nc) or Zarr (.zarr) and, with --plot, the four maps: sag, actuator forces, "
        "payload capacity and the dominant effect. Without --arm: the bundled seed2022 arm; "
        "without a grid: alpha1 40:130:46, alpha2 -20:40:31, alpha3 -20:20:21 (degrees).",
    )
    # "--alpha3 -20:20:21" reads the range as a value, not as an option (argparse only knows
    # plain negative numbers; eodarm.cli's parser class sets the same for every command)
    p._negative_number_matcher = NEGATIVE_VALUE
    p.add_argument("--arm", metavar="ARM.toml", help=ARM_HELP)
    for k in range(1, _MAX_LINKS + 1):
        p.add_argument(
            f"--alpha{k}",
            metavar="LO:HI:N",
            help="grid of link K's absolute angle, degrees (LO:HI:N, a value or a list)"
            if k == 1
            else argparse.SUPPRESS,
        )
    for k in range(1, _MAX_LINKS + 1):
        p.add_argument(
            f"--l{k}",
            metavar="LO:HI:N",
            help="or a grid of actuator K's pin-to-pin length, mm" if k == 1 else argparse.SUPPRESS,
        )
    p.add_argument("--x", metavar="LO:HI:N", help="or an effector grid: load point x, mm")
    p.add_argument("--y", metavar="LO:HI:N", help="load point y, mm")
    p.add_argument("--phi", metavar="LO:HI:N", help="last link's absolute angle, degrees")
    p.add_argument("--elbow", type=int, choices=(-1, 1), default=-1, help="IK branch (-1)")
    p.add_argument(
        "--mass",
        default="1.5,5,6.5",
        metavar="M1,M2,...",
        help="payload masses, kg (default 1.5,5,6.5; also LO:HI:N)",
    )
    p.add_argument(
        "--add",
        action="append",
        metavar="EFFECT@PLACE=VALUE",
        help="add an effect to the model, e.g. mount_compliance@M2=580 (repeatable)",
    )
    p.add_argument(
        "--reduce",
        metavar="OP:DIM[,DIM]",
        help="reduce in the core, e.g. max:mass_kg or min:alpha3,mass_kg "
        "(OP: max, min, argmax, argmin)",
    )
    p.add_argument(
        "--mask-unreachable",
        action="store_true",
        help=argparse.SUPPRESS,  # accepted for old scripts: out-of-stroke cells are never ok
    )
    p.add_argument("--no-self-weight", action="store_true", help="drop link/actuator weights")
    p.add_argument(
        "-o",
        "--output",
        metavar="OUT.nc|OUT.zarr",
        help="write the Dataset (to a temporary sibling renamed into place when complete; "
        "Zarr chunk by chunk)",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted sweep into OUT.zarr from its completed chunks "
        "(same arm, grid, payloads, effects and options)",
    )
    _force_arg(p, "an existing -o result (the previous one stays whole until the new is in)")
    p.add_argument("--plot", metavar="DIR", help="write the four maps as PNGs into DIR")
    p.add_argument(
        "--plot-prefix",
        default="",
        metavar="TEXT",
        help="prefix of the map file names (sag.png, forces.png, capacity.png, "
        "dominant_effect.png)",
    )
    p.add_argument(
        "--plot-mass",
        type=float,
        metavar="KG",
        help="payload of the sag, force and dominant-effect maps (default: the largest --mass)",
    )
    p.add_argument(
        "--max-force",
        type=float,
        default=ASSUMED_MAX_FORCE_N,
        metavar="N",
        help="force limit assumed for actuators without max_force_n in the capacity map "
        f"(default {ASSUMED_MAX_FORCE_N:g} N)",
    )
    p.add_argument(
        "--max-payload",
        type=float,
        default=100.0,
        metavar="KG",
        help="cap of the capacity map, kg (default 100)",
    )
    p.add_argument("--chunk-size", type=int, default=CHUNK_SIZE, help="poses per chunk")
    p.add_argument("--threads", type=int, metavar="K", help="threads of the core")
    p.add_argument(
        "--model",
        choices=("analytic", "fem"),
        default="analytic",
        help="the exact-pose analytic model (default) or the finite-element model",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="Dask scheduler address (tcp://host:8786) to run the chunks on (eodarm[dask])",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    _uncertainty_args(p)
    _effects_args(p)
    p.set_defaults(func=run)
    return p


def _uncertainty_args(p: argparse.ArgumentParser) -> None:
    """--uncertainty and --compensated-miss (a fitted arm file: its [fit] covariance)."""
    p.add_argument(
        "--uncertainty",
        action="store_true",
        help="add sigma_dx_mm, sigma_dy_mm, sigma_dalpha_deg (the total σ) and their parts "
        "sigma_param_* and sigma_model_* from the arm file's [fit] table (an arm written by "
        "'eodarm fit -o'; docs/model.md); with --plot, sag_uncertainty.png",
    )
    p.add_argument(
        "--compensated-miss",
        action="store_true",
        help="compensate every cell with the fitted model and add compensated_miss_mm "
        "(2 sigma at the compensated pose), compensation_residual_mm, compensation_status; "
        "with --plot, compensated_miss.png",
    )
    p.add_argument(
        "--cycle",
        action="store_true",
        help="add return_dx_mm, return_dy_mm: where each cell's measure point sits after "
        "the cycle reference -> payload -> 0 (friction and gaps; -o OUT.nc, no --reduce)",
    )


def _cli_grid(args: argparse.Namespace, n: int) -> dict[str, Any]:
    alphas = {k: getattr(args, f"alpha{k}", None) for k in range(1, _MAX_LINKS + 1)}
    lens = {k: getattr(args, f"l{k}", None) for k in range(1, _MAX_LINKS + 1)}
    eff = {"x": args.x, "y": args.y, "phi": args.phi}
    kinds = [
        name
        for name, d in (("alpha", alphas), ("lengths", lens), ("effector", eff))
        if any(v is not None for v in d.values())
    ]
    if len(kinds) > 1:
        raise EodarmError("sweep: give one kind of grid: --alphaK, --lK, or --x --y --phi")
    for d, flag in ((alphas, "alpha"), (lens, "l")):
        beyond = [k for k, v in d.items() if v is not None and k > n]
        if beyond:
            raise EodarmError(f"--{flag}{beyond[0]}: the arm has only {n} links")
    if kinds == ["lengths"]:
        missing = [k for k in range(1, n + 1) if lens[k] is None]
        if missing:
            raise EodarmError(
                f"sweep: a lengths grid needs --l1 … --l{n} (missing --l{missing[0]})"
            )
        return {"lengths": {f"l{k}": parse_range(str(lens[k]), f"--l{k}") for k in range(1, n + 1)}}
    if kinds == ["effector"]:
        missing_e = [k for k, v in eff.items() if v is None]
        if missing_e:
            raise EodarmError(
                f"sweep: an effector grid needs --x, --y and --phi (missing --{missing_e[0]})"
            )
        return {
            "effector": {k: parse_range(v, f"--{k}") for k, v in eff.items() if v is not None},
            "elbow": args.elbow,
        }
    grid = {}
    for k in range(1, n + 1):
        text = alphas[k] or DEFAULT_ALPHA[min(k - 1, len(DEFAULT_ALPHA) - 1)]
        grid[f"alpha{k}"] = parse_range(text, f"--alpha{k}")
    return {"alpha_deg": grid}


def _cli_reduce(text: str | None) -> dict[str, Any] | None:
    if not text:
        return None
    op, sep, dims = text.partition(":")
    if not sep or op not in REDUCE_OPS or not dims.strip():
        raise EodarmError(
            f"--reduce '{text}': expected OP:DIM[,DIM] with OP one of {', '.join(REDUCE_OPS)}, "
            "e.g. max:mass_kg"
        )
    return {"op": op, "dims": [d.strip() for d in dims.split(",") if d.strip()]}


def run(args: argparse.Namespace) -> int:
    """Run ``eodarm sweep``: sweep, write the Dataset and the maps, summarise on stdout.

    ``-o OUT.nc`` is solved in memory and written to a temporary sibling renamed into place;
    ``-o OUT.zarr`` is written chunk by chunk into ``.OUT.zarr.partial`` and renamed into
    place when complete (``--resume`` continues an interrupted one). A previous ``OUT`` stays
    whole until the new one replaces it.

    Returns 0, or 130 when interrupted with Ctrl-C (one line on stderr says what is on disk).

    Raises
    ------
    EodarmError
        With a one-line reason (the main CLI prints it and exits with status 2): bad input,
        a sweep too large for memory or disk, a lost Dask cluster.
    """
    arm = _load_arm(args.arm)
    check_kinds_of(arm, args.add, "--add")
    grid = _cli_grid(args, arm.n)
    mass = parse_range(args.mass, "--mass")
    _payload_hint(arm, mass)  # --mass 5000: is it grams? (a note)
    effects = [_valued_effect(s) for s in args.add or []]
    reduce = _cli_reduce(args.reduce)
    out = args.output
    kind = store.output_kind(out) if out else None
    if kind == "zarr" and (args.uncertainty or args.compensated_miss):
        raise EodarmError(
            "--uncertainty and --compensated-miss are computed in memory: write -o OUT.nc"
        )
    if args.resume and kind != "zarr":
        raise EodarmError("--resume continues an interrupted Zarr sweep: give -o OUT.zarr")
    if out:  # a resumed overwrite was asked for when it started
        resumed = args.resume and store.partial_path(out).exists()
        _claim(args, out, "-o", force=True if resumed else None, folder=kind == "zarr")
    scheduler: Any = None
    client = None
    if args.scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise EodarmError("--scheduler needs Dask: pip install 'eodarm[dask]'") from None
        client = Client(args.scheduler)
        scheduler = client
    import xarray  # imported here so that the time below is the sweep's

    kwargs: dict[str, Any] = dict(
        **grid,
        mass_kg=mass,
        effects=effects,
        self_weight=not args.no_self_weight,
        reduce=reduce,
        chunk_size=args.chunk_size,
        progress=False if args.no_progress else None,
        scheduler=scheduler,
        model=args.model,
        threads=args.threads,
        mask_unreachable=args.mask_unreachable,
    )
    if args.uncertainty or args.compensated_miss:
        kwargs.update(uncertainty=args.uncertainty, compensated_miss=args.compensated_miss)
        from eodarm.model.uncertainty import inadequacy_note

        line = inadequacy_note(arm)
        if line:
            _note(line)
    if args.cycle:
        if kind == "zarr":
            raise EodarmError("--cycle is computed in memory: write -o OUT.nc")
        kwargs.update(cycle=True)
    t0 = time.perf_counter()
    try:
        try:
            if kind == "zarr":
                if args.resume and not store.partial_path(out).exists():
                    _note(f"--resume: no interrupted sweep of {out} to resume; starting it")
                store.sweep_to_zarr(out, arm, **kwargs, resume=args.resume)
                ds = xarray.open_zarr(out, consolidated=False)
            elif kind == "netcdf":
                ds = store.sweep_to_netcdf(out, arm, **kwargs)
            else:
                ds = sweep(arm, **kwargs)
        finally:
            if client is not None:
                client.close()
    except store.SweepInterrupted as exc:
        _one_line(_interrupted(exc))
        return 130
    except KeyboardInterrupt:
        _one_line("interrupted while solving: nothing written")
        return 130
    dt = time.perf_counter() - t0
    size = math.prod(len(v) for v in next(v for v in grid.values() if isinstance(v, dict)).values())
    from eodarm.viz.format import plural

    _note(
        f"swept {plural(size, 'pose')} × {plural(len(mass), 'payload')} in {dt:.2f} s "
        f"({size * len(mass) / max(dt, 1e-9):,.0f} cells/s, {args.model} model)"
        + (f"; wrote {out}" if out else "")
    )
    try:
        _summary(ds)
    except KeyboardInterrupt:  # the result is whole and in place: say so, not just "interrupted"
        _one_line(
            f"interrupted: {out} was written completely; the summary was not printed"
            if out
            else "interrupted while summarising: nothing written"
        )
        return 130
    if args.plot:
        from eodarm.progress import stages
        from eodarm.viz import maps

        plot_mass = args.plot_mass if args.plot_mass is not None else float(np.max(mass))
        names = ["sag map", "force maps", "capacity map", "who makes the sag"]
        if args.uncertainty or args.compensated_miss:
            names.append("uncertainty maps")
        try:
            quiet = False if args.no_progress else None
            with stages(names, "eodarm sweep --plot", progress=quiet) as step:
                written = maps.render_all(
                    arm,
                    grid,
                    effects,
                    plot_mass,
                    args.plot,
                    self_weight=not args.no_self_weight,
                    assumed_max_force_n=args.max_force,
                    max_payload_kg=args.max_payload,
                    ds=ds if reduce is None and plot_mass in mass else None,
                    note=_note,
                    prefix=args.plot_prefix,
                    step=step,
                    progress=quiet,
                )
                if len(names) > 4:
                    step("uncertainty maps")
                written += _uncertainty_maps(args, arm, grid, effects, plot_mass, mass, reduce, ds)
                written += _return_map(args, plot_mass, mass, ds)
        except KeyboardInterrupt:
            done = f": {out} is complete, the maps are not" if out else ""
            _one_line(f"interrupted while plotting into {args.plot}{done}")
            return 130
        _note("wrote " + ", ".join(str(w) for w in written))
    return 0


def _uncertainty_maps(
    args: argparse.Namespace,
    arm: Arm,
    grid: dict[str, Any],
    effects: list[Any],
    plot_mass: float,
    mass: FloatArray,
    reduce: dict[str, Any] | None,
    ds: xr.Dataset,
) -> list[Any]:
    """The maps of --uncertainty and --compensated-miss (none without them)."""
    if not (args.uncertainty or args.compensated_miss):
        return []
    from eodarm.viz import uncertainty_maps

    return uncertainty_maps.render(
        arm,
        grid,
        effects,
        plot_mass,
        args.plot,
        ds=ds if reduce is None and plot_mass in mass else None,
        uncertainty=args.uncertainty,
        compensated_miss=args.compensated_miss,
        self_weight=not args.no_self_weight,
        prefix=args.plot_prefix,
    )


def _return_map(
    args: argparse.Namespace, plot_mass: float, mass: FloatArray, ds: xr.Dataset
) -> list[Any]:
    """return_error.png of --cycle: where the arm does not come back (none without it)."""
    if not args.cycle or plot_mass not in mass:
        return []
    from pathlib import Path

    from eodarm.viz.cycle_map import return_map

    path = Path(args.plot) / f"{args.plot_prefix}return_error.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    return_map(ds, plot_mass, path=path)
    return [path]


def _interrupted(exc: store.SweepInterrupted) -> str:
    """The one line of an interrupted sweep: what is on disk now."""
    out = exc.out
    if exc.phase == "done":
        return f"interrupted: {out} was written completely"
    if exc.phase == "sweeping":
        return (
            f"interrupted while sweeping into {out}: {exc.done} of {exc.total} chunks are "
            f"kept in {exc.partial} (--resume continues)"
            + ("; the previous result is untouched" if exc.previous else "")
        )
    if exc.phase == "writing":
        return f"interrupted while writing {out}: " + (
            "the previous result is untouched" if exc.previous else "nothing written"
        )
    return "interrupted while solving: nothing written" + (
        f"; the previous {out} is untouched" if exc.previous else ""
    )


def status_counts(status: xr.DataArray) -> dict[str, int]:
    """How many cells (or reduced groups) have each status, every code listed; a Dask-backed
    variable (a Zarr store) is counted chunk by chunk."""
    from eodarm.model.validity import STATUS

    if status.chunks is None:
        c = np.bincount(np.asarray(status.values, dtype=np.int64).ravel(), minlength=len(STATUS))
        return {name: int(c[i]) for i, name in enumerate(STATUS)}
    return {name: int((status == i).sum()) for i, name in enumerate(STATUS)}


def status_lines(status: xr.DataArray, reduced: bool, width: int = 100) -> list[str]:
    """The summary's count of each status (ok first, then the reasons that occur), wrapped
    to ``width`` columns: "cells: 87,741 ok, 2,233 large_deflection, …"."""
    counts = status_counts(status)
    parts = [f"{counts['ok']:,} ok"] + [
        f"{k:,} {name}" for name, k in counts.items() if name != "ok" and k
    ]
    head = "group status: " if reduced else "cell status: "
    lines, line = [], head
    for i, part in enumerate(parts):
        piece = part + ("," if i < len(parts) - 1 else "")
        if len(line) + len(piece) + 1 > width and line.strip():
            lines.append(line.rstrip())
            line = "  "
        line += piece + " "
    lines.append(line.rstrip())
    return lines


#: Above this many values the summary gives dy's range without its quantiles (a Zarr sweep
#: may be larger than memory).
SUMMARY_QUANTILES_MAX = 10**8


def _summary(ds: xr.Dataset) -> None:
    """A few lines on stdout: the sweep's shape, reachable share, extreme sag and forces."""
    from eodarm.viz.format import value

    dims = ", ".join(f"{d} {s}" for d, s in ds.sizes.items())
    _say(f"arm '{ds.attrs['arm']}', model {ds.attrs['model']}, reduce: {ds.attrs['reduce']}")
    print(f"dimensions: {dims}")
    reach = float(ds["reachable"].mean())
    ok = float(ds["ok"].mean())
    print(f"reachable poses: {100 * reach:.1f} %   ok cells: {100 * ok:.1f} %")
    if "status" in ds:
        for line in status_lines(ds["status"], ds.attrs["reduce"] != "none"):
            print(line)
    if ds.attrs["reduce"] == "none" or ds.attrs["reduce"].split()[0] in ("max", "min"):
        dy_all = ds["dy_mm"].where(ds["reachable"])
        if dy_all.size > SUMMARY_QUANTILES_MAX:
            lo, hi = float(dy_all.min()), float(dy_all.max())
            if math.isfinite(lo):
                print(f"dy over the ok cells: {value(lo)} … {value(hi, 'mm')}")
            dy = np.empty(0)
        else:
            dy = dy_all.values
            dy = dy[np.isfinite(dy)]
        if dy.size:
            q = np.quantile(dy, [0.02, 0.5, 0.98])
            print(
                f"dy over the ok cells: {value(dy.min())} … {value(dy.max(), 'mm')} "
                f"(2 %, 50 %, 98 %: {value(q[0])}, {value(q[1])}, {value(q[2], 'mm')})"
            )
        f = abs(ds["force_n"].where(ds["reachable"]))
        for i in ds["actuator"].values:
            fi = f.sel(actuator=i)
            if bool(np.isfinite(fi).any()):
                print(f"|F{i}| up to {value(float(fi.max()), 'N')}")
            elif "torque_nmm" in ds:  # a rotary drive
                ti = abs(ds["torque_nmm"].where(ds["reachable"])).sel(actuator=i)
                if bool(np.isfinite(ti).any()):
                    print(f"|T{i}| up to {value(float(ti.max()), 'N·mm')}")
    from eodarm.workspace.uncertainty import summary_lines

    for line in summary_lines(ds):
        print(line)
    for line in return_lines(ds):
        _say(line)


def return_lines(ds: xr.Dataset) -> list[str]:
    """The summary of ``--cycle``: where the arm comes back worst after a cycle reference →
    payload → 0, and by how much; or that nothing in the model can hold it off."""
    from eodarm.viz.format import channel_value, value
    from eodarm.workspace.cycle import worst_return

    w = worst_return(ds)
    if w is None:
        return [] if "return_dx_mm" not in ds else ["return to 0 kg: no ok cell"]
    if not w["memory"] or w["distance_mm"] == 0.0:
        return [
            "return to 0 kg: the arm comes back exactly in every ok cell (no friction or gap "
            "in the model holds it off its reference)"
        ]
    angles = ", ".join(value(a, digits=4) for a in w["alpha_deg"])
    where = f"alpha ({angles}) deg"
    if "x_mm" in w:
        where += f", load point ({w['x_mm']:.0f}, {w['y_mm']:.0f}) mm"
    return [
        f"return to 0 kg: worst at {where} after {value(w['mass_kg'])} kg: "
        f"{channel_value(w['distance_mm'], 'mm')} off its reference (dx "
        f"{channel_value(w['dx_mm'], 'mm')}, dy {channel_value(w['dy_mm'], 'mm')}); median "
        f"{channel_value(w['median_mm'], 'mm')} over the {w['cells']:,} ok cells"
    ]
