"""Whole-workspace sweeps: a grid of poses × payloads, solved in chunks, as an xarray Dataset.

:func:`sweep` solves every pose of a grid (of joint angles, of actuator lengths, or of
effector positions through inverse kinematics) under every payload of a list, with any
effects, and returns an :class:`xarray.Dataset` with named dimensions, coordinates and units::

    >>> import eodarm, eodarm.datasets, numpy as np
    >>> arm = eodarm.data.datasets.load("seed2022").arm                       # doctest: +SKIP
    >>> ds = eodarm.sweep(arm, alpha_deg={"alpha1": np.linspace(40, 130, 46),
    ...                                   "alpha2": np.linspace(-20, 40, 31),
    ...                                   "alpha3": np.linspace(-20, 20, 21)},
    ...                   mass_kg=[1.5, 5.0, 6.5])                       # doctest: +SKIP
    >>> ds.dy_mm.sel(alpha1=90, alpha2=10, alpha3=0, mass_kg=5.0)        # doctest: +SKIP

A local sweep of an angle grid is one call of the compiled core (``eodarm._core.sweep`` with
``grid=``): the core makes each chunk's poses from the grid's axes, solves, masks and reduces
them in parallel and writes straight into the result arrays. Other grids (lengths, effector
targets), the finite-element model and Dask schedulers walk the grid in chunks of
``chunk_size`` poses from Python; each chunk's poses are made from the flat pose index, solved
by the compiled core (the FE model by :func:`sweep_fallback`) and, for a reduced sweep,
reduced at once. Either way nothing of the grid's size is built for a reduced sweep, so memory
stays bounded by the chunk and the reduced output. The layout, the mask and the reductions
are described in ``docs/sweeps.md``.

Command line (registered by :func:`add_parser`)::

    eodarm sweep [--arm ARM.toml] [--alpha1 LO:HI:N ...] [--mass 1.5,5,6.5]
                 [--add EFFECT@PLACE=VALUE ...] [--reduce max:mass_kg] [-o OUT.nc | OUT.zarr]
                 [--plot DIR] [--threads K] [--no-progress] [--uncertainty] [--compensated-miss]
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Iterator, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import InputError
from eodarm.model.arm import Arm, check_arm
from eodarm.model.effects import Effect, effect_arrays, split_effects, with_arm_effects
from eodarm.model.validity import STATUS
from eodarm.workspace import cluster, limits, torque
from eodarm.workspace.chunk import CELL_VARS, _core_grid_sweep, _Job, _Setup
from eodarm.workspace.fallback import REDUCE_OPS
from eodarm.workspace.grid import Grid, coord_attrs, make_grid, masses_axis

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "CELL_VARS",
    "REDUCE_OPS",
    "sweep",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: A chunk solved, with the drives' torques on an arm that has one: what :func:`_run` runs
#: here or on a Dask worker.
_chunk = torque.chunk

#: Outputs per pose (no payload dimension).
POSE_VARS = ("reachable", "length_mm", "effector_x_mm", "effector_y_mm")
#: Default number of poses per chunk.
CHUNK_SIZE = 2**16
#: A progress bar shows at once for more chunks than this, else after 2 s.
PROGRESS_CHUNKS = 50

_ATTRS: dict[str, dict[str, Any]] = {
    "force_n": {"units": "N", "long_name": "loaded actuator force (compression positive)"},
    "dx_mm": {"units": "mm", "long_name": "horizontal displacement of the measure point"},
    "dy_mm": {
        "units": "mm",
        "long_name": "vertical displacement of the measure point (sag is negative)",
    },
    "dalpha_deg": {"units": "deg", "long_name": "change of the absolute link angle"},
    "dl_mm": {
        "units": "mm",
        "long_name": "change of actuator body length as its sensor sees it",
    },
    "ok": {
        "long_name": "solved and within the model's validity (status 0, docs/model.md §7)",
    },
    "status": {
        "long_name": "validity of the cell (docs/model.md §7): 0 ok, else the first broken limit",
        "flag_values": list(range(len(STATUS))),
        "flag_meanings": " ".join(STATUS),
    },
    "reachable": {
        "long_name": "pose exists, is not singular and every actuator is within its stroke",
    },
    "length_mm": {"units": "mm", "long_name": "unloaded pin-to-pin actuator length"},
    "effector_x_mm": {"units": "mm", "long_name": "x of the unloaded load point (global)"},
    "effector_y_mm": {"units": "mm", "long_name": "y of the unloaded load point (global)"},
    "alpha_deg": {"units": "deg", "long_name": "unloaded absolute link angle of the pose"},
    **torque.ATTRS,
}
#: Outputs per (pose, payload) cell and actuator.
PER_ACTUATOR = ("force_n", "dl_mm", *torque.TORQUE_VARS)


def _plan(grid: Grid, reduce: Mapping[str, Any] | None) -> tuple[str | None, list[str], int]:
    """(op, reduced dims, poses per reduction block) of a reduce spec."""
    if reduce is None:
        return None, [], 1
    if not isinstance(reduce, Mapping) or set(reduce) - {"op", "dims"}:
        raise InputError(
            "sweep: reduce must be a dict {'op': 'max'|'min'|'argmax'|'argmin', 'dims': [...]}"
        )
    op = reduce.get("op")
    if op not in REDUCE_OPS:
        raise InputError(f"sweep: reduce op {op!r} is not one of {', '.join(REDUCE_OPS)}")
    dims_raw = reduce.get("dims", ["mass_kg"])
    dims = [dims_raw] if isinstance(dims_raw, str) else [str(d) for d in dims_raw]
    all_dims = [*grid.names, "mass_kg"]
    for d in dims:
        if d not in all_dims:
            raise InputError(
                f"sweep: reduce over unknown dimension '{d}'; the dimensions are "
                f"{', '.join(all_dims)}"
            )
    if not dims or len(set(dims)) != len(dims):
        raise InputError(f"sweep: reduce dims must be distinct and non-empty, got {dims}")
    suffix = all_dims[len(all_dims) - len(dims) :]
    if set(dims) != set(suffix):
        inner = next(d for d in dims if d not in suffix)
        raise InputError(
            f"sweep: cannot reduce over '{inner}': reduced dimensions must be the innermost of "
            f"({', '.join(all_dims)}), e.g. ['mass_kg'] or ['{grid.names[-1]}', 'mass_kg']; "
            "order the grid dict so that the reduced angles come last"
        )
    block = math.prod(grid.shape[len(grid.names) - (len(dims) - 1) :])
    return str(op), suffix, block


def sweep(
    arm: Arm,
    *,
    alpha_deg: Mapping[str, npt.ArrayLike] | None = None,
    lengths: Mapping[str, npt.ArrayLike] | None = None,
    effector: Mapping[str, npt.ArrayLike] | None = None,
    mass_kg: npt.ArrayLike,
    effects: Effect | Iterable[Effect] | None = (),
    self_weight: bool = True,
    reduce: Mapping[str, Any] | None = None,
    chunk_size: int = CHUNK_SIZE,
    progress: bool | None = None,
    scheduler: Any = None,
    threads: int | None = None,
    alpha_ref_deg: npt.ArrayLike | None = None,
    elbow: int = -1,
    mask_unreachable: bool = False,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
    uncertainty: bool = False,
    compensated_miss: bool = False,
    cycle: bool = False,
) -> xr.Dataset:
    """Solve every pose of a grid under every payload, in chunks; an xarray Dataset.

    Parameters
    ----------
    arm : the arm.
    alpha_deg : a grid of unloaded absolute angles: ``{"alpha1": [...], …, "alphaN": [...]}``
        (degrees; 1-D arrays, a scalar for a fixed angle). The dict's order is the order of
        the dimensions (the last varies fastest).
    lengths : or a grid of unloaded pin-to-pin actuator lengths ``{"l1": …, "lN": …}`` (mm),
        turned into angles by :func:`eodarm.angles_from_lengths` on the side of
        ``alpha_ref_deg`` (default 90°, 10°, …, 0°). Lengths with which the arm cannot be
        assembled give cells that are not ok and not reachable; out-of-stroke lengths give
        poses that are not reachable.
    effector : or a grid of load-point targets ``{"x": mm, "y": mm, "phi": deg}`` (the last
        link's absolute angle), through :func:`eodarm.inverse_kinematics` with ``elbow``
        (3-link arms). Targets out of reach are not ok and not reachable.
    mass_kg : payload masses, kg (1-D); each pose is solved under each.
    effects : effects added to the baseline model (docs/model.md §4), built-in or user-written
        (custom-effects.md; these take the chunked path, each function called once per chunk, and
        a Dask worker must have them registered too, e.g. through the entry-point group).
    self_weight : include link and actuator weights in both states.
    reduce : ``{"op": "max"|"min"|"argmax"|"argmin", "dims": [...]}``: reduce the per-cell
        outputs over the innermost dims (``["mass_kg"]``, or ``["alpha3", "mass_kg"]`` …),
        ignoring cells that are not ok. arg-reductions give int64 indices into the reduced
        dims in C order (``np.unravel_index``), −1 where no cell is ok. The reduced dims'
        coordinates are kept in ``attrs["reduced_<dim>"]``. Per-pose outputs other than
        ``reachable`` (which becomes "any pose of the group") are dropped when an angle is
        reduced.
    chunk_size : poses per chunk (rounded up to whole reduction groups). Memory of a reduced
        sweep is bounded by the chunk and the reduced output. A local angle-grid sweep runs
        in the core's own chunks (about 16 384 cells) unless this is given.
    progress : show a progress bar on stderr: None (auto: at once for more than 50 chunks, or
        more than 50 × 65 536 poses for a local angle grid; else after 2 s), True or False.
    scheduler : None (run here), a ``distributed.Client`` (chunks are submitted to its cluster
        and gathered as they finish) or any Dask scheduler name/callable for
        ``dask.compute`` (``"threads"``, ``"processes"``, ``"synchronous"``).
    threads : threads of the compiled core per chunk (None: its default).
    alpha_ref_deg, elbow : the branch of a lengths grid, of an effector grid.
    mask_unreachable : accepted for old scripts; changes nothing (cells of poses out of
        stroke are never ok: their status is ``out_of_stroke``).
    model : ``"analytic"`` (the exact-pose model of docs/model.md, the fast core) or
        ``"fem"`` (the frame finite-element model of docs/fem.md, solved cell by cell; linear,
        so it agrees with the analytic model to first order in the load).
    fem_options : with ``model="fem"``, e.g. ``{"elements_per_link": 8}``.
    uncertainty : also give ``sigma_dx_mm``, ``sigma_dy_mm``, ``sigma_dalpha_deg`` per cell,
        the total standard deviations from the arm's ``[fit]`` table, and their parts
        ``sigma_param_*`` (the fitted covariance) and ``sigma_model_*`` (the model's
        inadequacy), as :func:`eodarm.solve` does; a reduced sweep gives σ at the cell the
        reduction chose (:mod:`eodarm.workspace.uncertainty`).
    compensated_miss : also compensate every solved cell with the fitted model and give
        ``compensated_miss_mm`` (2σ of the loaded measure point at the compensated pose),
        ``compensation_residual_mm`` and ``compensation_status`` (a reduced sweep: the largest
        miss and residual of each group; :mod:`eodarm.workspace.compensated`).
    cycle : also give ``return_dx_mm``, ``return_dy_mm`` per cell (mm): where the measure point
        sits after the cycle reference → payload → 0, relative to the reference (friction and
        gaps leave it off; docs/model.md §9). Analytic model, no reduction
        (:mod:`eodarm.workspace.cycle`).

    Returns
    -------
    xarray.Dataset
        dims (grid dims…, ``mass_kg``[, ``actuator`` | ``link``]) minus reduced ones, with
        ``force_n``, ``dx_mm``, ``dy_mm``, ``dalpha_deg`` (…, link), ``dl_mm`` (…, actuator),
        ``status`` (uint8, docs/model.md §7) and ``ok`` (status 0) per cell, NaN values
        where a cell is not ok (an arm with a rotary drive: ``torque_nmm``, ``dtorque_nmm``
        (…, actuator) too, NaN at linear joints; :mod:`eodarm.workspace.torque`);
        ``reachable``, ``length_mm`` (…, actuator), ``effector_x_mm``,
        ``effector_y_mm`` (and ``alpha_deg`` for lengths and effector grids) per pose. Every
        variable and coordinate has ``units`` and ``long_name`` attrs; the dataset's attrs
        name the arm (and carry its TOML), the model, self-weight, the grid kind and the
        reduction. With ``uncertainty`` or ``compensated_miss``, the variables above too.

    Raises
    ------
    ValueError
        (:class:`~eodarm.errors.InputError`) with one line naming the problem: no or several
        grids, an unknown or missing grid name, an empty or non-finite grid, a bad mass,
        an unknown reduce dimension or one that is not innermost; ``uncertainty`` or
        ``compensated_miss`` for an arm without a ``[fit]`` table, the FE model or
        user-written effects.
        :class:`~eodarm.errors.SweepTooLargeError` (one of them), before anything is built,
        when the output would not fit in the memory available (docs/sweeps.md, "Size
        checks").
    ClusterError
        (an :class:`~eodarm.errors.EodarmError`) when a Dask cluster lost all its workers or
        its scheduler, or a chunk's workers kept dying.
    KeyboardInterrupt
        On Ctrl-C, between chunks; nothing is returned.
    """
    setup = _prepare(
        arm,
        alpha_deg=alpha_deg,
        lengths=lengths,
        effector=effector,
        mass_kg=mass_kg,
        effects=effects,
        self_weight=self_weight,
        reduce=reduce,
        chunk_size=chunk_size,
        threads=threads,
        alpha_ref_deg=alpha_ref_deg,
        elbow=elbow,
        mask_unreachable=mask_unreachable,
        model=model,
        fem_options=fem_options,
    )
    from eodarm.workspace import uncertainty as _unc

    _unc.check(setup.job, uncertainty, compensated_miss)
    if cycle and (reduce is not None or model != "analytic"):
        raise InputError("sweep: cycle=True gives every cell's return: analytic model, no reduce")
    extra = _unc.extra_nbytes(setup, uncertainty, compensated_miss)
    limits.check_memory(setup.cells, setup.nbytes + extra)
    job, block, step = setup.job, setup.job.block, setup.step
    result = _allocate(setup.shapes, setup.dtypes)

    def place(span: tuple[int, int], res: Mapping[str, npt.NDArray[Any]]) -> None:
        a, b = span[0] // block, span[1] // block
        for key, arr in result.items():
            arr[a:b] = res[key]

    if scheduler is None and _core_walks(job):
        # One call: the core walks the grid itself, in parallel, straight into `result`.
        _sweep_grid(job, result, None if chunk_size == CHUNK_SIZE else step, progress)
        if torque.wanted(job):
            torque.fill(job, result, 0, setup.size)
    else:
        bar = _progress_bar(-(-setup.size // step), progress)
        try:
            for span, res in _run(job, _spans(setup.size, step), scheduler):
                place(span, res)
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
    ds = _unc.add_outputs(_dataset(setup, result), setup, result, uncertainty, compensated_miss)
    if cycle:
        from eodarm.workspace.cycle import add_return

        ds = add_return(ds, job)
    return ds


# ---------------------------------------------------------------------------- the plan
def _prepare(
    arm: Arm,
    *,
    alpha_deg: Mapping[str, npt.ArrayLike] | None,
    lengths: Mapping[str, npt.ArrayLike] | None,
    effector: Mapping[str, npt.ArrayLike] | None,
    mass_kg: npt.ArrayLike,
    effects: Effect | Iterable[Effect] | None,
    self_weight: bool,
    reduce: Mapping[str, Any] | None,
    chunk_size: int,
    threads: int | None,
    alpha_ref_deg: npt.ArrayLike | None,
    elbow: int,
    mask_unreachable: bool,
    model: str,
    fem_options: Mapping[str, Any] | None,
) -> _Setup:
    """Check a sweep's arguments and plan its output: nothing of the grid's size is built."""
    check_arm(arm, "sweep")
    grid = make_grid(arm, alpha_deg, lengths, effector, alpha_ref_deg, elbow)
    mass = masses_axis(mass_kg)
    effs = tuple(with_arm_effects(arm.effects, effects))
    effect_arrays(effs, arm.n)  # validates places and duplicates now
    users = split_effects(effs)[1]
    if users and model == "fem":
        raise InputError(
            f"sweep: custom effect {users[0].key}: the finite-element model cannot include "
            "user-written effects; use model='analytic'"
        )
    op, rdims, block = _plan(grid, reduce)
    from eodarm.model.kinds import integer

    chunk_size = integer(chunk_size, "sweep: chunk_size", 1, 2**62)
    if threads is not None:
        threads = integer(threads, "sweep: threads", 1, 2**16)
    n, m, size = arm.n, mass.shape[0], grid.size
    step = block * max(1, int(chunk_size) // block)
    from eodarm.model.fem import check_model

    check_model(model)
    job = _Job(
        arm,
        grid,
        mass,
        effs,
        bool(self_weight),
        op,
        block,
        mask_unreachable,
        threads,
        model,
        tuple(sorted(fem_options.items())) if fem_options is not None else None,
    )

    out_poses = size // block  # poses (or reduction groups) in the output
    shapes: dict[str, tuple[int, ...]] = {}
    for key in _cell_vars(job):
        per = (n,) if key in (*PER_ACTUATOR, "dalpha_deg") else ()
        shapes[key] = (out_poses, *per) if op else (out_poses, m, *per)
    shapes["reachable"] = (out_poses,)
    if block == 1:
        shapes.update(length_mm=(size, n), effector_x_mm=(size,), effector_y_mm=(size,))
        if grid.kind != "alpha":
            shapes["alpha_deg"] = (size, n)
    arg = op in ("argmax", "argmin")
    dtypes = {
        key: (
            np.bool_
            if key in ("ok", "reachable")
            else np.uint8
            if key == "status"
            else np.int64
            if arg and key in _cell_vars(job)
            else np.float64
        )
        for key in shapes
    }
    return _Setup(job, rdims, step, shapes, dtypes)


def _cell_vars(job: _Job) -> tuple[str, ...]:
    """The job's outputs per (pose, payload) cell: the drives' torques too on an arm with a
    rotary drive."""
    return (*CELL_VARS, *torque.TORQUE_VARS) if torque.wanted(job) else CELL_VARS


def _spans(size: int, step: int) -> Iterator[tuple[int, int]]:
    """The chunks [start, stop) of ``size`` poses, one at a time (never a list of them)."""
    for s in range(0, size, step):
        yield s, min(s + step, size)


# ---------------------------------------------------------------------------- the Dataset
def _layout(setup: _Setup) -> dict[str, tuple[list[str], list[int], dict[str, str]]]:
    """Each output variable's dims, shape and attrs in the Dataset."""
    job, rdims = setup.job, setup.rdims
    grid, op, block, n, m = job.grid, job.op, job.block, job.arm.n, job.mass.shape[0]
    arg = op in ("argmax", "argmin")
    kept = list(grid.names[: len(grid.names) - (len(rdims) - 1)] if op else grid.names)
    kept_shape = [grid.shape[grid.names.index(d)] for d in kept]
    cell_dims = kept if op else [*kept, "mass_kg"]
    cell_shape = kept_shape if op else [*kept_shape, m]
    pose_dims = kept if block > 1 else list(grid.names)
    over = ", ".join(rdims)
    out = {}
    cells = _cell_vars(job)
    for key in setup.shapes:
        inner = ["actuator"] if key in (*PER_ACTUATOR, "length_mm") else []
        inner = ["link"] if key in ("dalpha_deg", "alpha_deg") else inner
        if key in cells:
            dims, shape = [*cell_dims, *inner], [*cell_shape, *([n] if inner else [])]
        else:
            dims = [*pose_dims, *inner]
            shape = [*(grid.shape if block == 1 else kept_shape), *([n] if inner else [])]
        vattrs = dict(_ATTRS[key])
        if op and key in cells:
            if key == "ok":
                vattrs["long_name"] = f"some cell over ({over}) is ok (status 0)"
            elif key == "status":
                vattrs["long_name"] = (
                    f"0 when every cell over ({over}) is ok, else the lowest status code "
                    "among those that are not (docs/sweeps.md)"
                )
            elif arg:
                vattrs = {
                    "units": "1",
                    "long_name": f"{op} of {key} over ({over}): flat index in C order, "
                    "-1 where no cell is solved",
                }
            else:
                vattrs["long_name"] = f"{op} over ({over}) of the {vattrs['long_name']}"
        if key == "reachable" and block > 1:
            vattrs["long_name"] = f"some pose over ({', '.join(rdims[:-1])}) is reachable"
        out[key] = (dims, shape, vattrs)
    return out


def _dataset(setup: _Setup, result: Mapping[str, Any]) -> xr.Dataset:
    """The Dataset of a sweep's output arrays (flat over the poses, or already in shape)."""
    import xarray as xr

    job, rdims = setup.job, setup.rdims
    arm, grid, mass, effs, op, n = job.arm, job.grid, job.mass, job.effects, job.op, job.arm.n
    kept = list(grid.names[: len(grid.names) - (len(rdims) - 1)] if op else grid.names)
    coords: dict[str, Any] = {
        name: (name, c, coord_attrs(grid.kind, name))
        for name, c in zip(grid.names, grid.coords, strict=True)
        if name in kept
    }
    if not op:
        coords["mass_kg"] = ("mass_kg", mass, {"units": "kg", "long_name": "payload mass"})
    coords["actuator"] = ("actuator", np.arange(1, n + 1), {"long_name": "actuator number"})
    coords["link"] = ("link", np.arange(1, n + 1), {"long_name": "link number"})
    variables: dict[str, Any] = {}
    for key, (dims, shape, vattrs) in _layout(setup).items():
        arr = result[key]
        variables[key] = (dims, arr if arr.shape == tuple(shape) else arr.reshape(shape), vattrs)
    model = " + ".join(["baseline", *(f"{e.key}={e.value:g}" for e in effs)])
    over = ", ".join(rdims)
    attrs: dict[str, Any] = {
        "title": f"eodarm sweep of arm '{arm.name}'",
        "arm": arm.name,
        "arm_toml": arm.to_toml(),
        "model": model,
        "effects": " ".join(e.key for e in effs),
        "self_weight": int(bool(job.self_weight)),
        "mask_unreachable": int(bool(job.mask_unreachable)),
        "grid": grid.kind,
        "g": arm.g,
        "reduce": f"{op} over {over}" if op else "none",
        "Conventions": "eodarm (docs/model.md): mm, N, kg, deg; y up; force compression positive",
    }
    if grid.kind == "lengths":
        assert grid.ref is not None
        attrs["alpha_ref_deg"] = grid.ref
    if grid.kind == "effector":
        attrs["elbow"] = grid.elbow
    for d in rdims:
        attrs[f"reduced_{d}"] = mass if d == "mass_kg" else grid.coords[grid.names.index(d)]
    return xr.Dataset(variables, coords=coords, attrs=attrs)


# ---------------------------------------------------------------------------- running
def _allocate(
    shapes: Mapping[str, tuple[int, ...]], dtypes: Mapping[str, Any]
) -> dict[str, npt.NDArray[Any]]:
    """Uninitialised result arrays, those of one dtype as views of one buffer.

    One large allocation instead of ten: numpy asks the kernel for transparent huge pages
    for it, and only its two ends fall on ordinary pages. Ten separate arrays, none aligned
    to 2 MB, leave tens of MB on 4 kB pages, whose page faults cost a sweep of 10⁶ poses
    with all outputs about a quarter of its time (docs/benchmarks.md).
    """
    out: dict[str, npt.NDArray[Any]] = {}
    for dtype in dict.fromkeys(dtypes.values()):
        keys = [k for k in shapes if dtypes[k] == dtype]
        sizes = [math.prod(shapes[k]) for k in keys]
        buf = np.empty(sum(sizes), dtype=dtype)
        at = 0
        for key, size in zip(keys, sizes, strict=True):
            out[key] = buf[at : at + size].reshape(shapes[key])
            at += size
    return {k: out[k] for k in shapes}


def _core_walks(job: _Job) -> bool:
    """Whether the compiled core's grid walker can sweep this job: an angle grid of the
    analytic model with the catalogue's effects only (user-written effects take the chunked
    path, since the core's kernel cannot call Python)."""
    return (
        job.model == "analytic" and job.grid.kind == "alpha" and not split_effects(job.effects)[1]
    )


def _sweep_grid(
    job: _Job,
    result: dict[str, npt.NDArray[Any]],
    chunk_poses: int | None,
    progress: bool | None,
) -> None:
    """Sweep a whole angle grid in one call of the compiled core, into ``result``.

    The core makes each chunk's poses from the grid's axes, solves and (if asked) masks and
    reduces them, and writes straight into the result arrays (a reduction's ``reachable`` as
    "any pose of the group"); it checks for Ctrl-C and reports progress between chunks.
    """
    size = job.grid.size
    bar = _progress_bar(size, progress, unit="pose", auto_at=PROGRESS_CHUNKS * CHUNK_SIZE)

    def report(done: int) -> None:
        bar.update(done - bar.n)

    try:
        _core_grid_sweep(
            job,
            0,
            size,
            result,
            progress=report if bar is not None else None,
            chunk_rows=None if chunk_poses is None else chunk_poses * job.mass.shape[0],
        )
        if bar is not None:
            bar.update(size - bar.n)
    finally:
        if bar is not None:
            bar.close()


def _solve_span(setup: _Setup, start: int, stop: int) -> dict[str, npt.NDArray[Any]]:
    """Flat poses [start, stop) solved here: by the core's grid walker where it can
    (:func:`_core_walks`; its poses are never built in Python), else by
    :func:`_chunk`; with the drives' torques on an arm that has one."""
    job = setup.job
    if not _core_walks(job):
        return _chunk(job, start, stop)
    rows = (stop - start) // job.block
    out = _allocate({k: (rows, *s[1:]) for k, s in setup.shapes.items()}, setup.dtypes)
    _core_grid_sweep(job, start, stop - start, out)
    if torque.wanted(job):
        torque.fill(job, out, start, stop)
    return out


def _run(
    job: _Job, spans: Iterable[tuple[int, int]], scheduler: Any
) -> Iterator[tuple[tuple[int, int], dict[str, npt.NDArray[Any]]]]:
    """Yield (span, chunk result) for every span, here or on a Dask scheduler.

    ``spans`` is iterated lazily: a Dask client holds at most a window of chunks in flight.
    """
    if scheduler is None:
        for span in spans:
            yield span, _chunk(job, *span)
        return
    if hasattr(scheduler, "submit") and hasattr(scheduler, "scatter"):  # distributed.Client
        yield from cluster.run_chunks(scheduler, _chunk, job, spans)
        return
    import dask

    wave = 64
    it = iter(spans)
    while part := list(itertools.islice(it, wave)):
        tasks = [dask.delayed(_chunk, pure=False)(job, a, b) for a, b in part]
        results = dask.compute(*tasks, scheduler=scheduler)
        yield from zip(part, results, strict=True)


def _progress_bar(
    total: int, progress: bool | None, unit: str = "chunk", auto_at: int = PROGRESS_CHUNKS
) -> Any:
    """The sweep's bar (:func:`eodarm.progress.bar`): shown at once when asked, never when
    ``progress`` is False; when None, on a terminal only, at once for more than ``auto_at``
    units, else after 2 s."""
    if progress is None and total <= 1:
        return None
    from eodarm.progress import bar

    delay = 0.0 if total > auto_at else 2.0
    return bar(
        total, "eodarm sweep", progress=progress, unit=unit, unit_scale=unit == "pose", delay=delay
    )
