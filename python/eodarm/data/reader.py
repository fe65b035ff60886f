"""Measurement files (docs/formats.md §3) and pandas DataFrames read into :class:`Measurements`.

The reader turns a file or a DataFrame into a header and rows of cells; the checks and the
assembly of every row are :class:`Measurements`' own (``eodarm.data.measurements``).
"""

from __future__ import annotations

import csv
import hashlib
import io
import math
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

import numpy as np

from eodarm.data.channels import (
    channel_names,
)
from eodarm.errors import show, show_source

if TYPE_CHECKING:
    import pandas as pd

from eodarm.data.measurements import Cell, MeasurementFileError, Measurements, build
from eodarm.errors import ArgumentTypeError
from eodarm.model.arm import Arm

__all__ = ["from_dataframe", "read_measurements"]


# ---------------------------------------------------------------------------- reading
def read_measurements(path: str | Path | TextIO, arm: Arm | int) -> Measurements:
    """Read and validate a measurement file (docs/formats.md §3) for an arm.

    Parameters
    ----------
    path : file name, or an open text (or binary, UTF-8) file.
    arm : the arm the data were measured on (:class:`~eodarm.model.arm.Arm`), or its number
        of links ``n``: the file's channels are those of an ``n``-link arm.

    Returns
    -------
    Measurements
        Values in mm and degrees; ``line`` holds each state's line in the file.

    Raises
    ------
    MeasurementFileError
        If the file cannot be read, is empty or header-only, misses a required column, has a
        column for a link beyond ``n``, or has bad rows (all of them listed in one message with
        their lines and columns); :class:`~eodarm.errors.ArgumentTypeError` (one line) for an
        ``arm`` that is neither an Arm nor a number of links.

    Warns
    -----
    UserWarning
        Once, listing the columns that are not part of the contract (they are ignored).
    """
    n = links_of(arm, "read_measurements")
    if isinstance(path, (str, Path)):
        source = str(path)
        name = show_source(source)
        try:
            with open(path, "rb") as fb:
                raw = _read_capped(fb, name)
        except OSError as exc:
            raise MeasurementFileError(
                f"{name}: cannot read measurement file: {exc.strerror or exc}"
            ) from None
        except MeasurementFileError:
            raise
        except ValueError:  # open() of a name with a NUL byte
            raise MeasurementFileError(
                f"{name}: cannot read measurement file: its name holds a NUL byte"
            ) from None
    else:
        source = str(getattr(path, "name", "<stream>"))
        name = show_source(source)
        raw = _read_capped(path, name)
    digest = hashlib.sha256(raw).hexdigest() if isinstance(raw, bytes) else ""
    if isinstance(raw, bytes):
        try:
            raw = raw.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise MeasurementFileError(
                f"{name}: not a UTF-8 text file ({exc.reason} at byte {exc.start})"
            ) from None
    text = raw.removeprefix("\ufeff")
    if "\0" in text:
        line = text.count("\n", 0, text.index("\0")) + 1
        raise MeasurementFileError(
            f"{name}: line {line}: a binary file (NUL bytes), not a CSV text file"
        )

    delimiter = _delimiter(text, name)
    reader = csv.reader(io.StringIO(text, newline=""), strict=True, delimiter=delimiter)
    records: list[tuple[int, list[str]]] = []
    empty: list[int] = []
    prev = 0
    try:
        for cells in reader:
            start, prev = prev + 1, reader.line_num
            if not cells:  # an entirely blank line is not a row
                continue
            if records and not any(c.strip() for c in cells):
                empty.append(start)  # a row of separators only (Excel's trailing ",,,,")
                continue
            records.append((start, cells))
    except csv.Error as exc:
        raise MeasurementFileError(
            f"{name}: line {reader.line_num}: not valid CSV ({show(exc, 80)})"
        ) from None
    if not records:
        raise MeasurementFileError(
            f"{name}: line 1: the file is empty (expected a header with config, "
            f"alpha1_deg…alpha{n}_deg, mass_kg)"
        )
    (hline, header), body = records[0], records[1:]
    if hline != 1:
        raise MeasurementFileError(f"{name}: line 1: is blank; the header must be line 1")
    if empty:
        where = f"line {empty[0]}" if len(empty) == 1 else f"lines {empty[0]}…{empty[-1]}"
        warnings.warn(
            f"{name}: skipped {len(empty)} row(s) with every cell empty ({where}; a "
            "spreadsheet's trailing rows)",
            UserWarning,
            stacklevel=2,
        )
    meas = build(header, list(body), n, source, stacklevel=3, sha256=digest)
    return _with_values(meas, name, header)


def _with_values(meas: Measurements, name: str, header: list[str]) -> Measurements:
    """``meas``, refused in one line when it holds no measured value: every cell of its
    channel columns is empty (or it has none), and nothing could be compared or fitted (a
    fit of nothing has χ² = 0 and would "explain" it)."""
    if meas.n_values:
        return meas
    cols = [c for c in meas.channels if c in header]
    what = (
        f"every cell of {', '.join(cols[:3])}{' …' if len(cols) > 3 else ''} is empty"
        if cols
        else "it has no channel column (dx_mm, dy_mm, dalphaK_deg, dlK_mm)"
    )
    raise MeasurementFileError(f"{name}: no measured value: {what}; nothing to compare or fit")


def links_of(arm: Arm | int, where: str) -> int:
    """The number of links of ``arm``: an :class:`~eodarm.model.arm.Arm`'s ``n``, or a
    number of links itself (the older way of calling the readers)."""
    if isinstance(arm, Arm):
        return arm.n
    if isinstance(arm, bool) or not isinstance(arm, (int, np.integer)):
        raise ArgumentTypeError(
            f"{where}: arm must be an eodarm.Arm (or its number of links), got {type(arm).__name__}"
        )
    channel_names(int(arm))  # an integer >= 1, or one line saying so
    return int(arm)


#: Largest measurement file read, bytes: about 600 000 rows of the seed's 19 columns, far
#: beyond a measuring campaign; a larger file (or a device such as /dev/zero) is refused in
#: one line before it fills the memory. Arm files have their own cap
#: (:data:`eodarm.model.arm.MAX_FILE_BYTES`).
MAX_FILE_BYTES = 100_000_000

#: The bytes looked at first for NUL, the mark of a binary file.
_SNIFF_BYTES = 65_536


def _read_capped(f: Any, source: str) -> str | bytes:
    """The whole of an open file, refused in one line when it holds NUL bytes in its first
    :data:`_SNIFF_BYTES` (a binary file) or is longer than :data:`MAX_FILE_BYTES`."""
    head = f.read(_SNIFF_BYTES)
    if head is None:
        head = b""
    nul = b"\0" if isinstance(head, bytes) else "\0"
    if nul in head:
        raise MeasurementFileError(f"{source}: a binary file (NUL bytes), not a CSV text file")
    rest = f.read(MAX_FILE_BYTES + 1 - len(head)) if len(head) >= _SNIFF_BYTES else head[:0]
    raw = head + (rest or head[:0])
    if len(raw) > MAX_FILE_BYTES:
        raise MeasurementFileError(
            f"{source}: larger than {MAX_FILE_BYTES:,} bytes: not a measurement file "
            "(split it, or read it with pandas and eodarm.data.from_dataframe)"
        )
    return raw


def _delimiter(text: str, source: str) -> str:
    """``,``, or the ``;`` (or tab) of a header that has no comma: a spreadsheet's export in
    a locale whose decimal mark is a comma. Said in a warning, since the format's files
    are comma-separated."""
    header = text.split("\n", 1)[0]
    if "," in header:
        return ","
    for sep, name in ((";", "semicolon"), ("\t", "tab")):
        if sep in header:
            warnings.warn(
                f"{source}: read as {name}-separated (the header has no comma)",
                UserWarning,
                stacklevel=3,
            )
            return sep
    return ","


def from_dataframe(df: pd.DataFrame, arm: Arm | int, source: str = "<DataFrame>") -> Measurements:
    """Measurements from a pandas DataFrame with the file's columns, validated like a file,
    for ``arm`` (an :class:`~eodarm.model.arm.Arm` or its number of links).

    ``NaN``/``None`` cells are empty cells; string cells are parsed as in a file; numbers are
    taken as they are. Row r is reported as line r + 2 (as if written to a CSV with its header),
    unless the frame has an integer ``line`` column (as :meth:`Measurements.to_dataframe`
    writes), which is then used.
    """
    import pandas as pd

    n = links_of(arm, "from_dataframe")
    cols = list(df.columns)
    header = [c if isinstance(c, str) else repr(c) for c in cols]
    lines: list[int]
    if "line" in header:
        j = header.index("line")
        raw = df.iloc[:, j]
        if not pd.api.types.is_integer_dtype(raw.dtype):
            raise MeasurementFileError(f"{show_source(source)}: column 'line' must hold integers")
        lines = [int(x) for x in raw]
        keep = [i for i in range(len(header)) if i != j]
    else:
        lines = [r + 2 for r in range(len(df))]
        keep = list(range(len(header)))
    header = [header[i] for i in keep]
    body: list[tuple[int, list[Cell]]] = []
    jc = header.index("config") if "config" in header else -1
    for r, row in enumerate(df.itertuples(index=False, name=None)):
        cells = [_df_cell(row[i]) for i in keep]
        if jc >= 0 and cells[jc] is not None:
            cells[jc] = str(row[keep[jc]])  # a label, even when it looks like a number
        body.append((lines[r], cells))
    meas = build(header, body, n, source, stacklevel=3)
    return _with_values(meas, show_source(source), header)


def _df_cell(x: Any) -> Cell:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return None
    if isinstance(x, (bool, np.bool_)):
        return str(x)  # a boolean is not a number: reported as such
    if isinstance(x, (int, float, np.integer, np.floating)):
        return float(x)
    try:
        import pandas as pd

        if pd.isna(x):
            return None
    except (TypeError, ValueError):
        pass
    return str(x)
