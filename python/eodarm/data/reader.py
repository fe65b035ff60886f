"""Measurement files (CSV, CONTRACT §3) and pandas DataFrames read into :class:`Measurements`.

The reader turns a file or a DataFrame into a header and rows of cells; the checks and the
assembly of every row are :class:`Measurements`' own (``eodarm.data.measurements``).
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

import numpy as np

from eodarm.data.channels import (
    channel_names,
)

if TYPE_CHECKING:
    import pandas as pd

from eodarm.data.measurements import Cell, MeasurementFileError, Measurements, build

__all__ = ["from_dataframe", "read_measurements"]


# ---------------------------------------------------------------------------- reading
def read_measurements(path: str | Path | TextIO, n: int) -> Measurements:
    """Read and validate a measurement file (CONTRACT §3) for an ``n``-link arm.

    Parameters
    ----------
    path : file name, or an open text (or binary, UTF-8) file.
    n : number of links of the arm (``arm.n``).

    Returns
    -------
    Measurements
        Values in mm and degrees; ``line`` holds each state's line in the file.

    Raises
    ------
    MeasurementFileError
        If the file cannot be read, is empty or header-only, misses a required column, has a
        column for a link beyond ``n``, or has bad rows (all of them listed in one message with
        their lines and columns).

    Warns
    -----
    UserWarning
        Once, listing the columns that are not part of the contract (they are ignored).
    """
    channel_names(n)
    if isinstance(path, (str, Path)):
        source = str(path)
        try:
            with open(path, encoding="utf-8-sig", newline="") as f:
                text = f.read()
        except OSError as exc:
            raise MeasurementFileError(
                f"{source}: cannot read measurement file: {exc.strerror or exc}"
            ) from None
        except UnicodeDecodeError as exc:
            raise MeasurementFileError(f"{source}: not a UTF-8 text file ({exc.reason})") from None
    else:
        source = str(getattr(path, "name", "<stream>"))
        raw = path.read()
        if isinstance(raw, bytes):
            try:
                raw = raw.decode("utf-8-sig")
            except UnicodeDecodeError as exc:
                raise MeasurementFileError(
                    f"{source}: not a UTF-8 text file ({exc.reason})"
                ) from None
        text = raw.removeprefix("\ufeff")

    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    records: list[tuple[int, list[str]]] = []
    prev = 0
    try:
        for cells in reader:
            start, prev = prev + 1, reader.line_num
            if cells:  # an entirely blank line is not a row
                records.append((start, cells))
    except csv.Error as exc:
        raise MeasurementFileError(
            f"{source}: line {reader.line_num}: not valid CSV ({exc})"
        ) from None
    if not records:
        raise MeasurementFileError(
            f"{source}: line 1: the file is empty (expected a header with config, "
            f"alpha1_deg…alpha{n}_deg, mass_kg)"
        )
    (hline, header), body = records[0], records[1:]
    if hline != 1:
        raise MeasurementFileError(f"{source}: line 1: is blank; the header must be line 1")
    return build(header, list(body), n, source, stacklevel=3)


def from_dataframe(df: pd.DataFrame, n: int, source: str = "<DataFrame>") -> Measurements:
    """Measurements from a pandas DataFrame with the file's columns, validated like a file.

    ``NaN``/``None`` cells are empty cells; string cells are parsed as in a file; numbers are
    taken as they are. Row r is reported as line r + 2 (as if written to a CSV with its header),
    unless the frame has an integer ``line`` column (as :meth:`Measurements.to_dataframe`
    writes), which is then used.
    """
    import pandas as pd

    channel_names(n)
    cols = list(df.columns)
    header = [c if isinstance(c, str) else repr(c) for c in cols]
    lines: list[int]
    if "line" in header:
        j = header.index("line")
        raw = df.iloc[:, j]
        if not pd.api.types.is_integer_dtype(raw.dtype):
            raise MeasurementFileError(f"{source}: column 'line' must hold integers")
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
    return build(header, body, n, source, stacklevel=3)


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
