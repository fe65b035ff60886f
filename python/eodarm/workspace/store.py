"""Sweep results on disk that are never lost: atomic writes, and a Zarr sweep written chunk by
chunk that an interrupted run can resume.

* :func:`save` writes an in-memory sweep (NetCDF or Zarr) to a temporary sibling,
  ``.OUT.partial-<pid>``, and renames it into place only when it is complete; a previous
  result at ``OUT`` stays whole until then, and nothing partial is ever left under ``OUT``.
  A directory replaces a previous one in one atomic exchange (Linux ``renameat2``), so that
  even a kill leaves the old result or the new one at ``OUT``; the temporaries of a killed
  process (they name its PID) are removed by the next write into that folder.
* :func:`sweep_to_netcdf` checks memory and disk up front, sweeps, and saves.
* :func:`sweep_to_zarr` solves the grid chunk by chunk into the directory ``.OUT.partial``
  (the Zarr store ``.OUT.partial/OUT``, whose chunks are exactly the sweep's chunks, beside
  the record of its inputs and of its completed chunks), records each chunk once its data is
  written, and renames the store into place at the end. Its memory is one chunk's; an
  interrupted run keeps the partial store, and ``resume=True`` continues it from its
  recorded chunks, after checking that the arm, grid, payloads, effects and options are the
  same.

The rules are in ``docs/sweeps.md`` ("Writes that never lose a result").
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import warnings
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from eodarm.atomic import (
    KILL_AT_ENV,
    _fsync_path,
    _kill_point,
    _remove,
    clean_leftovers,
    deferred_sigint,
    replace,
    temporary,
)
from eodarm.errors import ClusterError, EodarmError, SweepTooLargeError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect
from eodarm.workspace import limits
from eodarm.workspace.sweep import (
    CHUNK_SIZE,
    _dataset,
    _layout,
    _prepare,
    _progress_bar,
    _run,
    _Setup,
    _solve_span,
    sweep,
)

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "KILL_AT_ENV",
    "SweepInterrupted",
    "clean_leftovers",
    "deferred_sigint",
    "output_kind",
    "partial_path",
    "replace",
    "save",
    "sweep_to_netcdf",
    "sweep_to_zarr",
]

#: The record of a partial Zarr sweep (inputs' fingerprint, chunk layout), beside its store.
RECORD = "eodarm-sweep.json"
#: The chunks written so far, one index a line, appended after each chunk's data.
DONE = "eodarm-done.txt"
#: NetCDF-3 (64-bit offset, what xarray's scipy engine writes) holds no variable this large.
NETCDF3_MAX_VAR_BYTES = 2**32 - 4
# The atomic writes themselves (temporaries, renames, Ctrl-C held, leftovers of killed
# processes, the test hook KILL_AT_ENV) are eodarm.atomic's, shared with every other output.


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C while a sweep was being solved or written; says what is on disk.

    Attributes
    ----------
    out : the output path.
    phase : ``"solving"``, ``"writing"`` (a whole Dataset) or ``"sweeping"`` (chunk by chunk
        into Zarr); ``"done"`` when the result was already complete and in place.
    previous : ``out`` held a result before (it is untouched unless ``phase == "done"``).
    partial : the directory of the partial Zarr sweep kept for ``resume`` (None when
        nothing was kept).
    done, total : chunks written and chunks in all (Zarr).
    """

    def __init__(
        self,
        out: Path,
        phase: str,
        previous: bool,
        partial: Path | None = None,
        done: int = 0,
        total: int = 0,
    ) -> None:
        super().__init__(f"interrupted while {phase} {out}")
        self.out, self.phase, self.previous = out, phase, previous
        self.partial, self.done, self.total = partial, done, total


# ---------------------------------------------------------------------------- paths
def output_kind(path: str | os.PathLike[str]) -> str:
    """``"netcdf"`` or ``"zarr"`` from the name's ending.

    Raises
    ------
    EodarmError
        For any other ending.
    """
    suffix = Path(path).suffix
    if suffix == ".zarr":
        return "zarr"
    if suffix in (".nc", ".nc4", ".netcdf"):
        return "netcdf"
    raise EodarmError(f"-o '{path}': the file must end in .nc (NetCDF) or .zarr (Zarr)")


def partial_path(out: str | os.PathLike[str]) -> Path:
    """Where a resumable Zarr sweep of ``out`` is written: the hidden sibling directory
    ``.OUT.partial``, which holds the store (``.OUT.partial/OUT``, readable as it grows) and
    the record of its inputs and completed chunks."""
    p = Path(out)
    return p.with_name(f".{p.name}.partial")


# ---------------------------------------------------------------------------- whole Datasets
def save(ds: xr.Dataset, path: str | os.PathLike[str]) -> None:
    """Write a sweep's Dataset to ``path`` (.nc: NetCDF-3 by xarray's scipy engine, .zarr:
    Zarr) through a temporary sibling renamed into place when complete.

    Raises
    ------
    SweepInterrupted
        On Ctrl-C while writing: the temporary is removed, a previous ``path`` is untouched
        (``phase`` "writing"); during the rename into place: the new result is whole at
        ``path`` (``phase`` "done").
    EodarmError
        For another ending, or Zarr without the zarr package.
    """
    out = Path(path)
    kind = output_kind(out)
    if kind == "zarr":
        _need_zarr(with_dask=False)
    previous = out.exists()
    clean_leftovers(out.parent)
    tmp = temporary(out)
    try:
        _remove(tmp)
        if kind == "zarr":
            with _consolidating():
                ds.to_zarr(tmp, mode="w", consolidated=True)
        else:
            _netcdf3(ds).to_netcdf(tmp, engine="scipy")
            _fsync_path(tmp)  # on disk before it replaces a previous result
        _kill_point("save-written")
    except KeyboardInterrupt:
        with deferred_sigint():
            _remove(tmp)
        raise SweepInterrupted(out, "writing", previous) from None
    except BaseException:
        _remove(tmp)
        raise
    try:
        replace(tmp, out)
    except KeyboardInterrupt:
        # replace() holds Ctrl-C until the new result is in place, then raises it
        raise SweepInterrupted(out, "done", previous) from None
    except BaseException:
        _remove(tmp)
        raise


def _netcdf3(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` ready for NetCDF-3, which has no unsigned bytes: ``status`` (uint8) marked
    ``_Unsigned`` so that it is stored as a byte and read back as uint8 (its codes < 128)."""
    if "status" not in ds or ds["status"].dtype != np.uint8:
        return ds
    out = ds.copy()
    out["status"].attrs["_Unsigned"] = "true"
    return out


def _need_zarr(with_dask: bool) -> None:
    try:
        import zarr  # noqa: F401

        if with_dask:
            import dask.array  # noqa: F401
    except ImportError:
        what = "zarr and dask" if with_dask else "the zarr package"
        raise EodarmError(f"writing Zarr needs {what}: pip install 'eodarm[zarr]'") from None


def _check_netcdf(setup: _Setup, out: Path) -> None:
    """NetCDF-3 limits and the disk, before solving."""
    for key, shape in setup.shapes.items():
        dtype = np.dtype(setup.dtypes[key])
        size = 1 if dtype == np.bool_ else 4 if dtype == np.int64 else dtype.itemsize
        nbytes = math.prod(shape) * size
        if nbytes > NETCDF3_MAX_VAR_BYTES:
            raise SweepTooLargeError(
                f"sweep: NetCDF-3 holds no variable over 4 GiB and {key} would take "
                f"{limits.sci(nbytes)} bytes: write Zarr (-o OUT.zarr) or reduce the grid"
            )
    limits.check_disk(setup.cells, setup.nbytes, out)


def sweep_to_netcdf(path: str | os.PathLike[str], arm: Arm, **kwargs: Any) -> xr.Dataset:
    """:func:`eodarm.sweep` (same keywords), checked against memory, disk and NetCDF-3's
    limits before it starts, then :func:`save`\\ d to ``path``; returns the Dataset.

    Raises
    ------
    SweepTooLargeError
        Before anything is solved, when the output cannot fit.
    SweepInterrupted
        On Ctrl-C (``phase`` "solving" or "writing"); a previous ``path`` is untouched.
    """
    out = Path(path)
    previous = out.exists()
    skip = ("progress", "scheduler", "uncertainty", "compensated_miss", "cycle")  # not _prepare's
    plan = {k: v for k, v in kwargs.items() if k not in skip}
    setup = _prepare(arm, **{**_DEFAULTS, **plan})
    limits.check_memory(setup.cells, setup.nbytes)
    _check_netcdf(setup, out)
    try:
        ds = sweep(arm, **kwargs)
    except KeyboardInterrupt:
        raise SweepInterrupted(out, "solving", previous) from None
    save(ds, out)
    return ds


#: sweep()'s defaults of the keywords _prepare takes.
_DEFAULTS: dict[str, Any] = {
    "alpha_deg": None,
    "lengths": None,
    "effector": None,
    "effects": (),
    "self_weight": True,
    "reduce": None,
    "chunk_size": CHUNK_SIZE,
    "threads": None,
    "alpha_ref_deg": None,
    "elbow": -1,
    "mask_unreachable": False,
    "model": "analytic",
    "fem_options": None,
}


# ---------------------------------------------------------------------------- chunked Zarr
@dataclass(frozen=True)
class _Chunks:
    """The chunks of a Zarr sweep: hyper-rectangles of the output, so that each is a region
    of every variable and exactly one Zarr chunk of it.

    The grid's dims before ``split`` are taken one value at a time, ``split`` ``rows`` values
    at a time, the dims after it whole (the reduced dims are always whole).
    """

    shape: tuple[int, ...]  # the grid's
    kept: int  # grid dims in the output
    split: int  # -1: one chunk, the whole output (every grid dim reduced)
    rows: int

    @classmethod
    def plan(cls, setup: _Setup) -> _Chunks:
        shape, kept = setup.job.grid.shape, len(_kept_dims(setup))
        if kept == 0:
            return cls(shape, 0, -1, 1)
        for k in range(kept):
            inner = math.prod(shape[k + 1 :])
            if inner <= setup.step:
                return cls(shape, kept, k, max(1, min(shape[k], setup.step // inner)))
        raise AssertionError("unreachable: the last kept dim's inner size is one group")

    @property
    def inner(self) -> int:
        return math.prod(self.shape[self.split + 1 :])

    @property
    def per_outer(self) -> int:
        return -(-self.shape[self.split] // self.rows)

    @property
    def count(self) -> int:
        if self.split < 0:
            return 1
        return math.prod(self.shape[: self.split]) * self.per_outer

    def span(self, i: int) -> tuple[int, int, tuple[slice, ...]]:
        """Flat poses [start, stop) of chunk ``i`` and its region over the output's grid
        dims."""
        if self.split < 0:
            return 0, math.prod(self.shape), ()
        k = self.split
        outer, j = divmod(i, self.per_outer)
        idx: list[int] = []
        rest = outer
        for d in reversed(self.shape[:k]):
            rest, r = divmod(rest, d)
            idx.append(r)
        idx.reverse()
        a, b = j * self.rows, min((j + 1) * self.rows, self.shape[k])
        base = outer * self.shape[k]
        region = (
            *(slice(x, x + 1) for x in idx),
            slice(a, b),
            *(slice(None) for _ in range(self.kept - k - 1)),
        )
        return (base + a) * self.inner, (base + b) * self.inner, region

    def zarr_chunks(self, shape: list[int]) -> tuple[int, ...]:
        """A variable's Zarr chunk shape (its dims: the kept grid dims first)."""
        if self.split < 0:
            return tuple(shape)
        k = self.split
        return (*([1] * k), self.rows, *shape[k + 1 :])


def _kept_dims(setup: _Setup) -> list[str]:
    names, op, rdims = setup.job.grid.names, setup.job.op, setup.rdims
    return list(names[: len(names) - (len(rdims) - 1)] if op else names)


def _fingerprint(setup: _Setup) -> dict[str, str]:
    """Hashes of what a sweep's numbers depend on, part by part (to name what differs)."""
    job, g = setup.job, setup.job.grid

    def digest(*parts: Any) -> str:
        h = hashlib.sha256()
        for p in parts:
            h.update(p.tobytes() if isinstance(p, np.ndarray) else repr(p).encode())
            h.update(b"\x00")
        return h.hexdigest()[:32]

    return {
        "arm": digest(job.arm.to_toml(), job.arm.g),
        "grid": digest(
            g.kind,
            g.names,
            *(np.asarray(c, float) for c in g.coords),
            g.columns,
            g.elbow,
            None if g.ref is None else np.asarray(g.ref, float),
        ),
        "payloads": digest(np.asarray(job.mass, float)),
        "effects": digest(job.effects),
        "options": digest(
            job.self_weight,
            job.op,
            setup.rdims,
            job.mask_unreachable,
            job.model,
            job.fem_options,
        ),
    }


_WHAT = {
    "arm": "arm",
    "grid": "grid",
    "payloads": "list of payloads",
    "effects": "set of effects",
    "options": "self-weight, reduction, mask or model",
}


def _read_record(part: Path, want: Mapping[str, str], chunks: _Chunks) -> tuple[_Chunks, set[int]]:
    """The partial store's chunk layout and its completed chunks, after checking that it
    was started with the same inputs."""
    try:
        rec = json.loads((part / RECORD).read_text(encoding="utf-8"))
        got = rec["fingerprint"]
        lay = _Chunks(chunks.shape, chunks.kept, int(rec["split"]), int(rec["rows"]))
    except (OSError, ValueError, KeyError, TypeError):
        raise EodarmError(
            f"sweep: cannot resume {part}: it has no readable record of its chunks "
            f"({RECORD}); remove it to start over"
        ) from None
    for key, what in _WHAT.items():
        if got.get(key) != want[key]:
            raise EodarmError(
                f"sweep: cannot resume {part}: it was started with a different {what}; "
                "remove it to start over"
            )
    if not (-1 <= lay.split < max(lay.kept, 1)) or lay.rows < 1 or rec.get("chunks") != lay.count:
        raise EodarmError(f"sweep: cannot resume {part}: its record is damaged; remove it")
    done: set[int] = set()
    with contextlib.suppress(FileNotFoundError):
        for line in (part / DONE).read_text(encoding="ascii", errors="replace").splitlines():
            if line.strip().isdigit() and int(line) < lay.count:
                done.add(int(line))
    return lay, done


def _template(setup: _Setup, chunks: _Chunks, part: Path) -> None:
    """The empty store: coordinates, attributes and every variable's metadata; no data."""
    import dask.array as da

    arrays, encoding = {}, {}
    for key, (_dims, shape, _attrs) in _layout(setup).items():
        zc = chunks.zarr_chunks(shape)
        arrays[key] = da.empty(tuple(shape), chunks=zc, dtype=setup.dtypes[key])
        encoding[key] = {"chunks": zc}
    ds = _dataset(setup, arrays)
    # the metadata is complete here (chunks only add data): consolidated once, so that
    # xarray.open_zarr finds it in one read and does not warn
    with _consolidating():
        ds.to_zarr(part, mode="w", compute=False, consolidated=True, encoding=encoding)


@contextlib.contextmanager
def _consolidating() -> Iterator[None]:
    """zarr 3 warns on every consolidation that consolidated metadata is not yet in the Zarr 3
    specification; it is what xarray reads first (and warns without), so it is written."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Consolidated metadata is currently not part")
        yield


def sweep_to_zarr(
    path: str | os.PathLike[str],
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
    resume: bool = False,
) -> Path:
    """:func:`eodarm.sweep` written chunk by chunk into the Zarr store ``path``; resumable.

    The keywords are :func:`eodarm.sweep`'s; the store (consolidated metadata), opened with
    ``xarray.open_zarr(path)``, equals that Dataset. Chunks of
    ``chunk_size`` poses (rounded to whole rows of the grid's dims and to whole reduction
    groups) are solved here (an angle grid by the core's own grid walker) or on ``scheduler``
    and written into ``.OUT.partial/OUT``, each recorded once its data is in; memory is a few
    chunks'. The complete store is renamed to ``path``; a previous ``path`` stays whole until
    then. Needs the zarr and dask packages.

    Parameters
    ----------
    resume : continue the interrupted sweep kept in ``.OUT.partial`` from its recorded chunks
        (its chunk layout is kept; ``chunk_size`` is then ignored). Without a partial store,
        the sweep starts from the beginning.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    SweepTooLargeError
        Before anything is written, when the store would not fit on its disk.
    EodarmError
        A partial store exists and ``resume`` is False; or it was started with another arm,
        grid, payloads, effects or options (named).
    ClusterError
        The Dask cluster was lost; the chunks written so far are kept for ``resume``.
    SweepInterrupted
        On Ctrl-C; the chunks written so far are kept for ``resume``.
    """
    _need_zarr(with_dask=True)
    import zarr

    out = Path(path)
    if output_kind(out) != "zarr":
        raise EodarmError(f"sweep_to_zarr: '{out}' must end in .zarr")
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
    part, previous = partial_path(out), out.exists()
    want, chunks = _fingerprint(setup), _Chunks.plan(setup)
    done: set[int] = set()
    clean_leftovers(out.parent)
    if part.exists() and _put_in_place(part, out):
        # killed after its store was put in place: what is left in `part` is the previous
        # result being removed. --resume has nothing left to do; a new run starts afresh.
        same = _record_of(part).get("fingerprint") == want
        _remove(part)
        if resume and same:
            return out
    if part.exists():
        if not resume:
            raise EodarmError(
                f"sweep: an interrupted sweep of {out} is kept in {part}: resume it "
                "(--resume, resume=True) or remove it to start over"
            )
        chunks, done = _read_record(part, want, chunks)
    left = chunks.count - len(done)
    limits.check_disk(setup.cells, setup.nbytes * left // chunks.count, out.parent)
    zstore = part / out.name
    if not part.exists():
        with deferred_sigint():  # the template and its record, or nothing
            try:
                part.mkdir(parents=True)
                _template(setup, chunks, zstore)
                record = {"fingerprint": want, "split": chunks.split, "rows": chunks.rows}
                record["chunks"] = chunks.count
                record["store"] = _identity(zstore)
                (part / RECORD).write_text(json.dumps(record, indent=1), encoding="utf-8")
            except BaseException:
                _remove(part)
                raise

    group = zarr.open_group(str(zstore), mode="r+")
    layout = _layout(setup)
    lacking = [key for key in layout if key not in group]
    if lacking:  # started by an eodarm whose sweep had fewer outputs (the drives' torques)
        raise EodarmError(
            f"sweep: cannot resume {part}: its store has no {lacking[0]} (an older eodarm "
            "started it); remove it to start over"
        )
    targets: dict[str, Any] = {key: group[key] for key in layout}
    bar = _progress_bar(chunks.count, progress)
    if bar is not None and done:
        bar.update(len(done))
    written = len(done)
    try:
        with open(part / DONE, "a", encoding="ascii") as log:
            for i, region, res in _solved(setup, chunks, done, scheduler):
                with deferred_sigint():
                    for key, data in res.items():
                        rshape = tuple(s.stop - s.start for s in _bounded(region, layout[key][1]))
                        targets[key][(*region, Ellipsis)] = data.reshape(rshape + data.shape[1:])
                    log.write(f"{i}\n")
                    log.flush()
                    written += 1
                _kill_point(f"zarr-chunk-{written}")
                if bar is not None:
                    bar.update(1)
    except KeyboardInterrupt:
        raise SweepInterrupted(out, "sweeping", previous, part, written, chunks.count) from None
    except ClusterError as exc:
        raise ClusterError(
            f"{exc}; {written} of {chunks.count} chunks are kept in {part} (resume: --resume, "
            "resume=True)"
        ) from None
    finally:
        if bar is not None:
            bar.close()
    _kill_point("zarr-complete")
    try:
        with deferred_sigint():
            replace(zstore, out)
            _kill_point("zarr-in-place")
            _remove(part)  # the record
    except KeyboardInterrupt:  # held until the result was in place
        raise SweepInterrupted(out, "done", previous) from None
    return out


def _record_of(part: Path) -> dict[str, Any]:
    """The partial directory's record, or {} when it has none readable."""
    try:
        rec = json.loads((part / RECORD).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return rec if isinstance(rec, dict) else {}


def _identity(path: Path) -> list[int]:
    """(device, inode) of a directory: what a rename keeps."""
    st = os.stat(path)
    return [st.st_dev, st.st_ino]


def _put_in_place(part: Path, out: Path) -> bool:
    """The store of the partial directory ``part`` is already at ``out`` (the directory at
    ``out`` is the one the record names): the run that wrote it died while removing what it
    replaced."""
    want = _record_of(part).get("store")
    try:
        return want is not None and out.is_dir() and _identity(out) == want
    except OSError:
        return False


def _bounded(region: tuple[slice, ...], shape: list[int]) -> list[slice]:
    return [slice(*s.indices(n)[:2]) for s, n in zip(region, shape, strict=False)]


def _solved(
    setup: _Setup, chunks: _Chunks, done: set[int], scheduler: Any
) -> Iterator[tuple[int, tuple[slice, ...], dict[str, npt.NDArray[Any]]]]:
    """(chunk index, region, result) of every chunk not yet done, here or on ``scheduler``
    (in the order they finish)."""
    todo = (i for i in range(chunks.count) if i not in done)
    if scheduler is None:
        for i in todo:
            a, b, region = chunks.span(i)
            yield i, region, _solve_span(setup, a, b)
        return
    where: dict[int, tuple[int, tuple[slice, ...]]] = {}

    def spans() -> Iterator[tuple[int, int]]:
        for i in todo:
            a, b, region = chunks.span(i)
            where[a] = (i, region)
            yield a, b

    for (a, _b), res in _run(setup.job, spans(), scheduler):
        i, region = where.pop(a)
        yield i, region, res
