"""Measured deflections: reading, validating and writing the measurement file (docs/formats.md §3).

A measurement file has one row per *state* (a configuration × a payload). Every value is a
difference, loaded minus unloaded, measured on the arm whose unloaded angles the row gives.
:class:`Measurements` holds such a file as arrays, with ``NaN`` where a channel was not
measured, and a standard deviation for every measured value.

Channels of an n-link arm, in this fixed order (:func:`channel_names`)::

    dx_mm, dy_mm, dalpha1_deg … dalphaN_deg, dl1_mm … dlN_mm

Noise: given, pooled from repeats, or default
---------------------------------------------
A value whose ``sigma_<channel>`` cell is filled keeps that σ. The values of a channel that
have none (the file has no ``sigma_`` column for the channel, or leaves the cell empty) share
one σ for the channel (:mod:`eodarm.data.noise`):

* where states were measured more than once (rows with the same config label, unloaded
  angles and mass), the **pooled standard deviation of the repeats** of those values, if it
  has at least 5 degrees of freedom and is not 0. The repeated rows stay separate
  observations; nothing is averaged or dropped;
* otherwise the **default standard deviation** of the channel family (:data:`DEFAULT_SIGMA`),
  and the channel is recorded in :attr:`Measurements.defaulted` so that the tools can say so.

:attr:`Measurements.noise` records, per measured channel, which it was (and the pool's
states, rows and degrees of freedom); :attr:`Measurements.sigma_dof` gives the degrees of
freedom of each channel's σ. The default levels:

* ``dx_mm``, ``dy_mm``: **0.02 mm**. The displacement of the measure point is read by a laser
  (triangulation) displacement sensor; industrial ones repeat to about 0.01–0.02 mm.
* ``dalphaK_deg``: **0.02°**. Link angles are read by inclinometers or angle readouts that
  resolve 0.1°; one quantised reading has a standard deviation of 0.1°/√12 ≈ 0.03°, and the
  average of several readings brings that to about 0.02°.
* ``dlK_mm``: **0.002 mm**. Each actuator's own length change is read by an inductive
  displacement sensor (LVDT-like) between its fixed and moving parts, good to about a µm.

What the reader promises
------------------------
* Header names are exact. Unknown columns are ignored, with one :class:`UserWarning` listing
  them. A column that belongs to a link the arm does not have (``dalpha4_deg`` for a 3-link
  arm) is refused: the data belong to another arm.
* Numbers are parsed strictly (decimal notation, optional exponent; no ``nan``/``inf``, no
  thousands separators, no decimal commas). An empty cell in a channel column means "not
  measured"; an empty required cell is an error.
* Every bad row is collected and the file is refused with one :class:`MeasurementFileError`
  whose one-line message names the file and, for each bad row, its line and column. Nothing is
  silently dropped: a row that measures no channel is kept (it contributes nothing). Entirely
  blank lines are not rows and are skipped.
* Comment lines are not part of the format and are not supported.
* Spreadsheet exports (:mod:`eodarm.data.reader`): a header without a comma but with
  semicolons (or tabs) is read with that separator, with a warning; rows whose every cell is
  empty (``,,,,``) are skipped with one warning; a decimal comma is named as such in the
  error; an unknown or missing column names the close match it probably is.
* A file over :data:`eodarm.data.reader.MAX_FILE_BYTES` (100 MB) or with NUL bytes (a binary
  file, ``/dev/zero``) is refused in one line before it is read whole.
* States that the arm cannot take (out of stroke unloaded, a pose that cannot close under its
  load, angles in radians) are refused by the commands before any fit, naming the line
  (:func:`eodarm.data.plausible.check_states`).
"""

from __future__ import annotations

import csv
import math
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, TextIO

import numpy as np
import numpy.typing as npt

from eodarm.atomic import atomic_write
from eodarm.data.cells import (
    Cell,
    _cells_of,
    _did_you_mean,
    _label,
    _number,
    _show,
)
from eodarm.data.channels import (
    _CHANNEL,
    DEFAULT_SIGMA,
    channel_family,
    channel_link,
    channel_names,
    channel_values,
    default_sigma,
    expand_channels,
)
from eodarm.data.noise import (
    ChannelNoise,
    assign_sigma,
    check_noise,
    sequence_state_groups,
    state_groups,
)
from eodarm.data.sequences import _check_sequences, _reference_rows, sequence_rows
from eodarm.errors import EodarmError, listing, show, show_source

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "DEFAULT_SIGMA",
    "MeasurementFileError",
    "Measurements",
    "build",
    "channel_family",
    "channel_link",
    "channel_names",
    "channel_values",
    "default_sigma",
    "expand_channels",
]

#: The physical range of a measurement file's numbers (docs/diagnosis.md, "Measurement
#: files"): beyond it a number is a typo or a unit mistake, and the small-deflection model
#: it is compared with would not hold. Angles in degrees, lengths in mm, masses in kg.
MAX_ANGLE_DEG = 1e4
MAX_MASS_KG = 1e6
MAX_DISPLACEMENT_MM = 1e5  # dx, dy, dl: 100 m
MAX_DALPHA_DEG = 360.0
#: A σ below this fraction of the channel's default level is not a measurement's: it would
#: make one value outweigh the rest by more than 10¹².
MIN_SIGMA_FRACTION = 1e-6

#: Most bad rows listed in one error message; the rest are counted.
MAX_LISTED = 10

_ALPHA = re.compile(r"^alpha([1-9][0-9]*)_deg$")
_IS_IT = " (is it '{}'?)"

FloatArray = npt.NDArray[np.float64]


class MeasurementFileError(EodarmError):
    """A measurement file (or table) is malformed; the one-line message names the source and,
    for every bad row, its line number and column."""


# ---------------------------------------------------------------------------- the data
@dataclass(frozen=True, eq=False)
class Measurements:
    """Measured states of an ``n``-link arm: one row per configuration × payload.

    Build one with :func:`read_measurements`, :func:`from_dataframe`,
    :meth:`Measurements.from_arrays` or :func:`eodarm.analysis.synth.synth`. The arrays are
    read-only.

    Attributes
    ----------
    source : where the data came from (file name, ``"<arrays>"``, ``"<synth>"`` …).
    n : number of links of the arm the data belong to.
    config : (N,) str, configuration label of each state.
    alpha_deg : (N, n) float, unloaded absolute link angles, degrees.
    mass_kg : (N,) float, payload mass, kg (≥ 0).
    channels : every channel of an n-link arm (:func:`channel_names`), the columns of
        ``values`` and ``sigma``.
    values : (N, C) float, loaded minus unloaded, mm or degrees; ``NaN`` = not measured.
    sigma : (N, C) float, standard deviation of each measured value (same unit); ``NaN``
        where not measured.
    line : (N,) int, 1-based line of each state in its file (the header is line 1); for data
        that did not come from a file, the line it would have in :meth:`to_csv`'s output.
    sigma_default : (N, C) bool, ``True`` where a measured value's sigma is the default of
        its channel (:func:`default_sigma`) because the source gave none.
    sigma_columns : whether :meth:`to_csv` writes ``sigma_`` columns.
    sigma_pooled : (N, C) bool, ``True`` where a measured value's sigma is its channel's
        pooled standard deviation of the repeats because the source gave none.
    step : (N,) int or None, the ``step`` column of a file of load sequences (docs/diagnosis.md,
        "Load sequences"): each config label is one sequence, its rows its states in
        ascending step, every value relative to the sequence's zeroed reference. ``None``:
        no ``step`` column, every row its own sequence loaded once from its reference.
    reference : (N,) bool, the written reference rows of a sequence file (mass 0, every
        channel 0 or empty): kept as rows, with no value (they carry no information).
    noise : measured channel → :class:`~eodarm.data.noise.ChannelNoise`, where that
        channel's sigma came from (``"given"``, ``"repeats"`` with the pool's states, rows and
        degrees of freedom, or ``"default"`` with the reason). Read-only mapping. A
        :meth:`subset` keeps the records (and sigmas) estimated on the whole data: the noise
        is a property of the instrument, not of the rows selected.
    sha256 : SHA-256 (hex) of the file's bytes as they were read, for the ``[fit]`` table
        of a model fitted to them (``data_sha256``); empty for data that did not come whole
        from one file (arrays, a DataFrame, a :meth:`subset`).
    """

    source: str
    n: int
    config: npt.NDArray[np.str_]
    alpha_deg: FloatArray
    mass_kg: FloatArray
    channels: tuple[str, ...]
    values: FloatArray
    sigma: FloatArray
    line: npt.NDArray[np.int64]
    # None means "no default sigmas"; __post_init__ replaces it by the (N, C) array
    sigma_default: npt.NDArray[np.bool_] = field(default=None)  # type: ignore[arg-type]
    sigma_columns: bool = True
    # None means "none pooled" / "derive from the flags"; __post_init__ fills them in
    sigma_pooled: npt.NDArray[np.bool_] = field(default=None)  # type: ignore[arg-type]
    noise: Mapping[str, ChannelNoise] = field(default=None)  # type: ignore[arg-type]
    step: npt.NDArray[np.int64] | None = None
    # None means "no reference rows"; __post_init__ replaces it by the (N,) array
    reference: npt.NDArray[np.bool_] = field(default=None)  # type: ignore[arg-type]
    sha256: str = ""

    def __post_init__(self) -> None:
        n = int(self.n)
        channels = tuple(channel_names(n))
        if tuple(self.channels) != channels:
            raise EodarmError(f"{self.source}: channels must be {channels}, got {self.channels}")
        labels = [str(c) for c in np.asarray(self.config, dtype=object).ravel()]
        config = np.array(labels, dtype=str)
        rows, c = config.shape[0], len(channels)
        try:
            alpha = np.array(self.alpha_deg, dtype=float).reshape(rows, n)
            mass = np.array(self.mass_kg, dtype=float).reshape(rows)
            values = np.array(self.values, dtype=float).reshape(rows, c)
            sigma = np.array(self.sigma, dtype=float).reshape(rows, c)
            line = np.array(self.line, dtype=np.int64).reshape(rows)
            step = None if self.step is None else np.array(self.step, dtype=np.int64).reshape(rows)
            refs = (
                np.zeros(rows, dtype=bool)
                if self.reference is None
                else np.array(self.reference, dtype=bool).reshape(rows)
            )
            dflt, pooled = (
                np.zeros((rows, c), dtype=bool)
                if flags is None
                else np.array(flags, dtype=bool).reshape(rows, c)
                for flags in (self.sigma_default, self.sigma_pooled)
            )
        except (TypeError, ValueError) as exc:
            raise EodarmError(
                f"{self.source}: arrays do not fit {rows} rows of a {n}-link arm ({exc})"
            ) from None
        measured = ~np.isnan(values)
        dflt &= measured
        pooled &= measured
        if (dflt & pooled).any():
            raise EodarmError(f"{self.source}: a sigma cannot be both default and pooled")
        if not (np.isfinite(alpha).all() and np.isfinite(mass).all() and (mass >= 0).all()):
            raise EodarmError(f"{self.source}: angles and masses must be finite, masses >= 0")
        if np.isinf(values).any():
            raise EodarmError(f"{self.source}: measured values must be finite")
        s = sigma[measured]
        if not (np.isfinite(s).all() and (s > 0).all()):
            raise EodarmError(f"{self.source}: every measured value needs a finite sigma > 0")
        sigma[~measured] = np.nan
        for name, arr in (
            ("config", config),
            ("alpha_deg", alpha),
            ("mass_kg", mass),
            ("values", values),
            ("sigma", sigma),
            ("line", line),
            ("sigma_default", dflt),
            ("sigma_pooled", pooled),
            ("reference", refs),
            *((("step", step),) if step is not None else ()),
        ):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        noise = check_noise(channels, measured, dflt, pooled, self.noise, self.source)
        object.__setattr__(self, "noise", MappingProxyType(noise))
        object.__setattr__(self, "n", n)
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "sigma_columns", bool(self.sigma_columns))

    # ------------------------------------------------------------------ views
    def __repr__(self) -> str:
        from eodarm.data.display import measurements_repr

        return measurements_repr(self)

    def _repr_html_(self) -> str:
        from eodarm.data.display import measurements_html

        return measurements_html(self)

    @property
    def n_rows(self) -> int:
        """Number of states (rows)."""
        return int(self.config.shape[0])

    @property
    def measured(self) -> npt.NDArray[np.bool_]:
        """(N, C) bool: where a value was measured."""
        return ~np.isnan(self.values)

    @property
    def measured_channels(self) -> tuple[str, ...]:
        """Channels with at least one measured value, in channel order."""
        return tuple(self.channels[j] for j in np.flatnonzero(self.measured.any(axis=0)))

    @property
    def n_values(self) -> int:
        """Number of measured values (non-NaN cells of :attr:`values`)."""
        return int(self.measured.sum())

    @property
    def configs(self) -> tuple[str, ...]:
        """Configuration labels, each once, in order of first appearance."""
        return tuple(dict.fromkeys(self.config.tolist()))

    @property
    def has_sequences(self) -> bool:
        """Whether the data carry a ``step`` column (load sequences with memory)."""
        return self.step is not None

    def sequences(self) -> list[npt.NDArray[np.int64]]:
        """The rows of each load sequence, in the order its states were applied.

        With a ``step`` column: one sequence per config label (in order of first appearance),
        its rows in ascending step, written reference rows left out (the reference is the
        state before the first row). Without: every row is its own sequence of one state.
        """
        if self.step is None:
            return [np.array([r], dtype=np.int64) for r in range(self.n_rows)]
        return sequence_rows(self.config, self.step, self.reference)

    @property
    def defaulted(self) -> tuple[str, ...]:
        """Channels where at least one measured value got its default sigma."""
        return tuple(self.channels[j] for j in np.flatnonzero(self.sigma_default.any(axis=0)))

    @property
    def pooled(self) -> tuple[str, ...]:
        """Channels whose values without a given sigma got the sigma pooled from the repeats."""
        return tuple(self.channels[j] for j in np.flatnonzero(self.sigma_pooled.any(axis=0)))

    @property
    def sigma_dof(self) -> dict[str, float]:
        """Every channel → the degrees of freedom ν of its sigma estimate.

        ν = Σ_g (n_g − 1) for a channel whose sigma was pooled from the repeats (the pooled
        variance s² is then distributed as σ²·χ²_ν/ν for normal noise); ``math.inf`` for a
        sigma given in the source or a default level (taken as exact), and for a channel not
        measured. Values of a pooled channel whose sigma was given in the source (a partly
        filled ``sigma_`` column) are exact: :attr:`sigma_pooled` tells them apart.
        """
        return {ch: self.noise[ch].dof if ch in self.noise else math.inf for ch in self.channels}

    def index(self, channel: str) -> int:
        """Column of ``channel`` in :attr:`values` and :attr:`sigma`."""
        try:
            return self.channels.index(channel)
        except ValueError:
            raise EodarmError(
                f"{self.source}: '{channel}' is not a channel of a {self.n}-link arm"
            ) from None

    # ------------------------------------------------------------------ derived sets
    def subset(self, rows: npt.ArrayLike) -> Measurements:
        """The states selected by a boolean mask (N,) or by integer indices (in that order).

        The sigmas and :attr:`noise` records are those of the whole data: a sigma pooled from
        the repeats stays the estimate made on every repeat, not re-estimated on the subset.
        In a file of load sequences the rows kept are the states of their sequences that
        remain: select whole sequences (config labels), as a state's model depends on every
        payload before it.
        """
        sel = np.asarray(rows)
        if sel.dtype == bool:
            if sel.shape != (self.n_rows,):
                raise EodarmError(
                    f"{self.source}: mask of shape {sel.shape} for {self.n_rows} rows"
                )
            idx = np.flatnonzero(sel)
        elif sel.size == 0:
            idx = np.zeros(0, dtype=np.int64)
        elif np.issubdtype(sel.dtype, np.integer):
            idx = sel.astype(np.int64).ravel()
            if ((idx < -self.n_rows) | (idx >= self.n_rows)).any():
                raise EodarmError(f"{self.source}: row index out of range 0…{self.n_rows - 1}")
        else:
            raise EodarmError(f"{self.source}: subset needs a bool mask or integer indices")
        return replace(
            self,
            config=self.config[idx],
            alpha_deg=self.alpha_deg[idx],
            mass_kg=self.mass_kg[idx],
            values=self.values[idx],
            sigma=self.sigma[idx],
            line=self.line[idx],
            sigma_default=self.sigma_default[idx],
            sigma_pooled=self.sigma_pooled[idx],
            step=None if self.step is None else self.step[idx],
            reference=self.reference[idx],
            sha256="",  # no longer the whole file's data
        )

    def to_dataframe(self) -> pd.DataFrame:
        """One row per state: ``config``, ``alpha1_deg``…, ``mass_kg``, each measured channel
        followed by its ``sigma_`` column (the sigma used, defaults and pooled ones included),
        ``line``."""
        import pandas as pd

        data: dict[str, Any] = {"config": self.config.astype(object)}
        for i in range(self.n):
            data[f"alpha{i + 1}_deg"] = self.alpha_deg[:, i]
        data["mass_kg"] = self.mass_kg
        if self.step is not None:
            data["step"] = self.step
        for ch in self.measured_channels:
            j = self.index(ch)
            data[ch] = self.values[:, j]
            data["sigma_" + ch] = self.sigma[:, j]
        data["line"] = self.line
        return pd.DataFrame(data)

    def to_csv(self, path: str | Path | TextIO, sigma_columns: bool | None = None) -> None:
        """Write the measurement file of docs/formats.md §3.

        Columns: ``config``, ``alpha1_deg``…, ``mass_kg``, the measured channels, then the
        ``sigma_`` columns (unless ``sigma_columns`` — default :attr:`sigma_columns` — is
        false). A cell is empty where a value was not measured, and a sigma cell is empty where
        the sigma was not given (a default, or pooled from the repeats): reading the file back
        (:func:`read_measurements`) derives them again from the same rows and gives back the
        same values, sigmas, defaults and pooled estimates. (The file of a :meth:`subset` is
        re-estimated from the repeats it holds.) Numbers are written with ``repr`` (exact
        round trip).
        """
        with_sigma = self.sigma_columns if sigma_columns is None else bool(sigma_columns)
        chans = self.measured_channels
        cols = [self.index(c) for c in chans]
        given = self.measured & ~self.sigma_default & ~self.sigma_pooled
        sig_cols = [j for j in cols if with_sigma and given[:, j].any()]
        header = ["config", *(f"alpha{i + 1}_deg" for i in range(self.n)), "mass_kg"]
        header += ["step"] if self.step is not None else []
        header += list(chans) + ["sigma_" + self.channels[j] for j in sig_cols]

        def num(x: float) -> str:
            return "" if math.isnan(x) else repr(float(x))

        def write(f: TextIO) -> None:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(header)
            for r in range(self.n_rows):
                row = [str(self.config[r])]
                row += [num(a) for a in self.alpha_deg[r]]
                row.append(num(self.mass_kg[r]))
                if self.step is not None:
                    row.append(str(int(self.step[r])))
                row += [num(self.values[r, j]) for j in cols]
                row += [num(self.sigma[r, j]) if given[r, j] else "" for j in sig_cols]
                w.writerow(row)

        if isinstance(path, (str, Path)):
            try:
                with atomic_write(path, newline="") as f:  # whole or not at all
                    write(f)
            except OSError as exc:
                raise EodarmError(f"{path}: cannot write: {exc.strerror or exc}") from None
        else:
            write(path)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_arrays(
        cls,
        config: str | Sequence[str] | npt.ArrayLike,
        alpha_deg: npt.ArrayLike,
        mass_kg: npt.ArrayLike,
        values: Mapping[str, npt.ArrayLike],
        sigma: Mapping[str, npt.ArrayLike | float] | None = None,
        source: str = "<arrays>",
        step: npt.ArrayLike | None = None,
    ) -> Measurements:
        """Measurements from arrays, validated exactly like a file.

        Parameters
        ----------
        config : (N,) labels, or one label for every row.
        alpha_deg : (N, n) unloaded absolute angles, degrees; n is taken from its shape.
        mass_kg : scalar or (N,) payload masses, kg.
        values : channel name → (N,) measured values (mm or degrees); ``NaN`` = not measured.
        sigma : channel name → (N,) or scalar standard deviation; missing channels or ``NaN``
            next to a measured value get the sigma pooled from the repeats, or else the
            default (recorded in :attr:`noise` and :attr:`defaulted`), as in a file.
        source : name used in error messages.
        step : (N,) integer steps ≥ 0 making each config label one load sequence (the file's
            ``step`` column, checked as in a file), or None.

        Raises
        ------
        MeasurementFileError
            Naming the row (as the line it would have in a file, header = line 1) and column.
        """
        from eodarm.model.kinds import real_array

        try:
            alpha = np.asarray(real_array(alpha_deg, f"{source}: alpha_deg"), dtype=float)
        except (TypeError, ValueError, OverflowError) as exc:
            raise MeasurementFileError(str(exc)) from None
        if alpha.ndim == 1:
            alpha = alpha[None, :]
        if alpha.ndim != 2 or alpha.shape[1] < 1:
            raise MeasurementFileError(f"{source}: alpha_deg must be (N, n), got {alpha.shape}")
        rows, n = alpha.shape
        if rows == 0:
            raise MeasurementFileError(f"{source}: no rows")
        if isinstance(config, str):
            labels = [config] * rows
        else:
            labels = [str(c) for c in np.asarray(config, dtype=object).ravel()]
        if len(labels) != rows:
            raise MeasurementFileError(f"{source}: {len(labels)} config labels for {rows} rows")

        def column(arr: npt.ArrayLike, what: str) -> FloatArray:
            try:
                real = real_array(arr, f"{source}: {what}")
                return np.broadcast_to(np.asarray(real, dtype=float), (rows,))
            except EodarmError as exc:
                raise MeasurementFileError(str(exc)) from None
            except (TypeError, ValueError, OverflowError):
                raise MeasurementFileError(
                    f"{source}: {what} must be a number or {rows} numbers"
                ) from None

        header = ["config", *(f"alpha{i + 1}_deg" for i in range(n)), "mass_kg"]
        cols = [alpha[:, i] for i in range(n)] + [column(mass_kg, "mass_kg")]
        if step is not None:
            header.append("step")
            cols.append(column(step, "step"))
        for name, table, kind in (("values", values, ""), ("sigma", sigma or {}, "sigma_")):
            for ch, arr in table.items():
                header.append(kind + str(ch))
                cols.append(column(arr, f"{name}['{ch}']"))
        body: list[tuple[int, list[Cell]]] = [
            (r + 2, [labels[r], *(float(c[r]) for c in cols)]) for r in range(rows)
        ]
        return build(header, body, n, source, unknown_is_error=True)


# ---------------------------------------------------------------------------- the validator
def build(
    header: Sequence[str],
    body: Sequence[tuple[int, Sequence[Cell]]],
    n: int,
    source: str,
    *,
    unknown_is_error: bool = False,
    stacklevel: int = 3,
    sha256: str = "",
) -> Measurements:
    """Validate a table (header + rows of cells) and build :class:`Measurements`
    (``sha256``: of the file's bytes, :attr:`Measurements.sha256`)."""
    channels = channel_names(n)
    chan_set = set(channels)
    alphas = [f"alpha{i + 1}_deg" for i in range(n)]
    required = ["config", *alphas, "mass_kg"]
    where = show_source(source)

    # ---- header: every problem at once, on line 1
    problems: list[str] = []
    seen: dict[str, int] = {}
    for j, name in enumerate(header):
        if name in seen:
            problems.append(f"column '{show(name)}' appears twice")
        else:
            seen[name] = j
    missing = [c for c in required if c not in seen]
    known = [*required, *channels, *(f"sigma_{c}" for c in channels)]
    jstep = seen.get("step")
    if missing:
        others = [c for c in seen if c not in known]
        problems.append(
            "missing required column(s) "
            + ", ".join(f"'{c}'{_did_you_mean(c, others, _IS_IT)}" for c in missing)
        )
    unknown: list[str] = []
    foreign: list[str] = []
    for name in seen:
        if name in required or name in chan_set or name == "step":
            continue
        base = name.removeprefix("sigma_")
        if name.startswith("sigma_") and base in chan_set:
            if base not in seen:
                problems.append(f"column '{name}' has no channel column '{base}'")
            continue
        m_ch, m_al = _CHANNEL.match(base), _ALPHA.match(name)
        k = channel_link(base) if m_ch else (int(m_al.group(1)) if m_al else None)
        if k is not None and k > n:
            foreign.append(name)
        else:
            unknown.append(name)
    if foreign:
        problems.append(
            "column(s) "
            + _names(foreign)
            + f" belong to a link beyond the arm's {n} (the data are for another arm)"
        )
    if unknown and unknown_is_error:
        problems.append(
            "unknown column(s) " + _names(unknown, known) + f" (channels: {', '.join(channels)})"
        )
    if problems:
        raise MeasurementFileError(listing(f"{where}: line 1 (header)", problems))
    if not body:
        raise MeasurementFileError(f"{where}: no data rows after the header (line 1)")
    if unknown:
        warnings.warn(
            f"{where}: ignoring column(s) not in the measurement-file format: "
            + _names(unknown, known),
            UserWarning,
            stacklevel=stacklevel,
        )

    # ---- rows
    rows = len(body)
    ncol = len(header)
    c_of = {ch: j for j, ch in enumerate(channels)}
    present = [(c_of[ch], seen[ch], seen.get("sigma_" + ch)) for ch in channels if ch in seen]
    config = ["" for _ in range(rows)]
    alpha = np.zeros((rows, n))
    mass = np.zeros(rows)
    values = np.full((rows, len(channels)), np.nan)
    sigma = np.full((rows, len(channels)), np.nan)
    given = np.zeros((rows, len(channels)), dtype=bool)
    line = np.zeros(rows, dtype=np.int64)
    step = np.full(rows, -1, dtype=np.int64)
    step_given = np.zeros(rows, dtype=bool)
    bad: list[str] = []  # one entry per bad cell: "line L: column why"
    bad_rows = 0
    for r, (ln, cells) in enumerate(body):
        line[r] = ln
        if len(cells) != ncol:
            bad.append(f"line {ln}: {len(cells)} cells, the header has {ncol} columns")
            bad_rows += 1
            continue
        errs: list[str] = []
        label = _label(cells[seen["config"]])
        if not label.strip():
            errs.append("config is empty")
        config[r] = label
        for i, name in enumerate(alphas):
            x, why = _number(cells[seen[name]])
            if why:
                errs.append(f"{name} {why}")
            elif x is None:
                errs.append(f"{name} is empty (unknown config angle)")
            elif abs(x) > MAX_ANGLE_DEG:
                errs.append(f"{name} {x:.6g} is beyond ±{MAX_ANGLE_DEG:g}°")
            else:
                alpha[r, i] = x
        x, why = _number(cells[seen["mass_kg"]])
        if why:
            errs.append(f"mass_kg {why}")
        elif x is None:
            errs.append("mass_kg is empty")
        elif x < 0:
            errs.append(f"mass_kg '{_show(cells[seen['mass_kg']])}' is negative")
        elif x > MAX_MASS_KG:
            errs.append(f"mass_kg {x:.6g} is beyond {MAX_MASS_KG:g} kg")
        else:
            mass[r] = x
        if jstep is not None:
            x, why = _number(cells[jstep])
            if why or (x is not None and (x < 0 or x != math.floor(x) or x > 2**53)):
                errs.append(f"step '{_show(cells[jstep])}' is not an integer >= 0")
            elif x is not None:
                step[r], step_given[r] = int(x), True
        for c, jv, js in present:
            ch = channels[c]
            v, why = _number(cells[jv])
            limit = MAX_DALPHA_DEG if ch.startswith("dalpha") else MAX_DISPLACEMENT_MM
            if why:
                errs.append(f"{ch} {why}")
                v = None
            elif v is not None and abs(v) > limit:
                errs.append(f"{ch} {v:.6g} is beyond ±{limit:g}")
                v = None
            s: float | None = None
            if js is not None:
                s, why = _number(cells[js])
                if why:
                    errs.append(f"sigma_{ch} {why}")
                    s = None
                elif s is not None and s <= 0:
                    errs.append(f"sigma_{ch} '{_show(cells[js])}' must be > 0")
                    s = None
                elif s is not None and s < MIN_SIGMA_FRACTION * default_sigma(ch):
                    errs.append(
                        f"sigma_{ch} {s:.3g} is below {MIN_SIGMA_FRACTION:g} of its default "
                        f"{default_sigma(ch):g}: not a measurement's noise"
                    )
                    s = None
                elif s is not None and s > limit:
                    errs.append(f"sigma_{ch} {s:.6g} is beyond {limit:g}")
                    s = None
            if v is None:
                continue
            values[r, c] = v
            if s is not None:
                sigma[r, c] = s
                given[r, c] = True
        if errs:
            bad += [f"line {ln}: {e}" for e in errs]
            bad_rows += 1
    if bad:
        cells_note = f", {len(bad)} bad cells" if len(bad) != bad_rows else ""
        raise MeasurementFileError(listing(f"{where}: {bad_rows} bad row(s){cells_note}", bad))
    has_step = bool(step_given.any())
    reference = np.zeros(rows, dtype=bool)
    if has_step:
        bad = _check_sequences(
            config, alpha, mass, step, step_given, values, line, _cells_of(body, jstep)
        )
        if bad:
            raise MeasurementFileError(listing(f"{where}: {len(bad)} bad row(s)", bad))
        reference = _reference_rows(config, mass, step, values)
        values[reference] = np.nan  # the written reference carries no information
        groups = sequence_state_groups(config, alpha, mass, step, reference)
    else:
        groups = state_groups(config, alpha, mass)
    # the values without a given sigma: pooled from the repeats, or the default level
    sigma, dflt, pooled, noise = assign_sigma(channels, values, sigma, given, groups)
    return Measurements(
        source=source,
        n=n,
        config=np.array(config, dtype=str),
        alpha_deg=alpha,
        mass_kg=mass,
        channels=tuple(channels),
        values=values,
        sigma=sigma,
        line=line,
        sigma_default=dflt,
        sigma_pooled=pooled,
        noise=noise,
        step=step if has_step else None,
        reference=reference,
        sha256=sha256,
    )


def _names(names: Sequence[str], known: Sequence[str] | None = None) -> str:
    """Column names in a message: the first three, each shown on one short line (with a
    did-you-mean when ``known`` is given), and how many more."""
    shown = [
        f"'{show(c)}'" + (_did_you_mean(c, known) if known is not None else "") for c in names[:3]
    ]
    more = f" and {len(names) - 3} more" if len(names) > 3 else ""
    return ", ".join(shown) + more
