"""Pose files (CSV): the nominal poses to compensate, one per row.

Columns, with the measurement file's names (docs/formats.md §3): ``alpha1_deg`` … ``alphaN_deg``
(required: unloaded absolute angles), ``mass_kg`` (optional: the payload of each row) and
``config`` (optional: a label carried through). Other columns are ignored. A UTF-8 byte-order
mark is accepted. Bad cells are refused with their line numbers, all in one message.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from eodarm.errors import EodarmError, InputError, listing, show, show_source

__all__ = ["Poses", "read_poses"]


@dataclass(frozen=True)
class Poses:
    """The rows of a pose file: ``alpha_deg`` (N, n); ``mass_kg`` (N,) or None without the
    column; ``config`` (N,) labels or None; ``line`` (N,) each row's line in the file."""

    source: str
    alpha_deg: npt.NDArray[np.float64]
    mass_kg: npt.NDArray[np.float64] | None
    config: tuple[str, ...] | None
    line: tuple[int, ...]


def read_poses(path: str | Path, n: int) -> Poses:
    """Read a pose file for an ``n``-link arm.

    Raises
    ------
    InputError
        If the file cannot be read, has no rows, misses an ``alphaK_deg`` column, or has cells
        that are not finite numbers (or a negative mass): the message names the file, the
        lines and the columns.
    """
    from eodarm.data.reader import _read_capped

    source = show_source(path)
    try:
        with open(path, "rb") as f:
            raw = _read_capped(f, source)  # a binary or huge file: one line
        text = (raw if isinstance(raw, str) else raw.decode("utf-8-sig")).removeprefix("\ufeff")
    except OSError as exc:
        raise InputError(f"{source}: cannot read the pose file ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{source}: not a UTF-8 text file (byte {exc.start})") from None
    except ValueError as exc:
        if isinstance(exc, EodarmError):
            raise InputError(
                str(exc)
                .replace("not a CSV text", "not a pose")
                .replace("not a measurement file", "not a pose file")
            ) from None
        raise InputError(
            f"{source}: cannot read the pose file: its name holds a NUL byte"
        ) from None
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        header = [h.strip() for h in next(reader)]
    except StopIteration:
        raise InputError(f"{source}: the pose file is empty") from None
    except csv.Error as exc:
        raise InputError(f"{source}: line {reader.line_num}: not a CSV file ({exc})") from None
    angles = [f"alpha{k + 1}_deg" for k in range(n)]
    missing = [c for c in angles if c not in header]
    if missing:
        raise InputError(
            f"{source}: line 1: missing column {', '.join(missing)} (a pose file has "
            f"{', '.join(angles)} and optionally mass_kg, config)"
        )
    col = {h: i for i, h in enumerate(header)}
    has_mass = "mass_kg" in col
    has_config = "config" in col
    alpha: list[list[float]] = []
    mass: list[float] = []
    config: list[str] = []
    lines: list[int] = []
    bad: list[str] = []
    bad_rows: set[int] = set()
    prev = reader.line_num
    try:
        for row in reader:  # the line a row starts on: a quoted cell may span lines
            line, prev = prev + 1, reader.line_num
            if not any(cell.strip() for cell in row):
                continue
            values = []
            for name in angles + (["mass_kg"] if has_mass else []):
                i = col[name]
                cell = row[i].strip() if i < len(row) else ""
                try:
                    x = float(cell)
                except ValueError:
                    x = math.nan
                if not math.isfinite(x) or (name == "mass_kg" and x < 0):
                    want = "a mass >= 0" if name == "mass_kg" else "a finite angle"
                    bad.append(f"line {line} {name} '{show(cell, 20)}' (need {want})")
                    bad_rows.add(line)
                values.append(x)
            alpha.append(values[:n])
            if has_mass:
                mass.append(values[n])
            if has_config:
                i = col["config"]
                config.append(row[i].strip() if i < len(row) else "")
            lines.append(line)
    except csv.Error as exc:
        raise InputError(f"{source}: line {reader.line_num}: not a CSV file ({exc})") from None
    if bad:
        raise InputError(listing(f"{source}: {len(bad)} bad cells in {len(bad_rows)} row(s)", bad))
    if not alpha:
        raise InputError(f"{source}: no poses (a header but no rows)")
    return Poses(
        source=source,
        alpha_deg=np.array(alpha, dtype=float).reshape(-1, n),
        mass_kg=np.array(mass, dtype=float) if has_mass else None,
        config=tuple(config) if has_config else None,
        line=tuple(lines),
    )
