"""Raw records and the campaign file that lists them (docs/records.md).

A *record* is what a logger writes while the weights go on and off: a CSV with ``time_s``
(seconds, increasing; the sampling may be irregular) and any measurement channels
(``dx_mm``, ``dy_mm``, ``dalphaK_deg``, ``dlK_mm``) as the sensors read them, offsets and all.
A *campaign* file (TOML) lists the records, one ``[[record]]`` table each::

    [[record]]
    file = "c1_cycle.csv"                 # relative to the campaign file
    config = "c1"
    alpha_deg = [97.5, 25.4, 8.3]         # the unloaded angles, degrees
    masses_kg = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]   # the payload of each steady state, kg

This module reads and writes both and refuses a malformed one in one line naming the file and
the line (and the time, for a record). Finding the steady states is
:mod:`eodarm.analysis.records`.
"""

from __future__ import annotations

import csv
import math
import tomllib
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import numpy.typing as npt

from eodarm.atomic import atomic_write
from eodarm.data.channels import _CHANNEL, channel_link, channel_names
from eodarm.errors import EodarmError
from eodarm.model.effects import did_you_mean

__all__ = [
    "Campaign",
    "Record",
    "RecordError",
    "RecordSpec",
    "is_campaign",
    "read_campaign",
    "read_record",
    "write_campaign",
    "write_record",
    "write_rows",
]

FloatArray = npt.NDArray[np.float64]

#: The time column of a record.
TIME = "time_s"


class RecordError(EodarmError):
    """A campaign file or a record is malformed, or its steady states cannot be matched to its
    payloads; the one-line message names the file and the line or the time."""


@dataclass(frozen=True)
class RecordSpec:
    """One ``[[record]]`` table of a campaign file.

    Attributes
    ----------
    file : the record's path (resolved against the campaign file's folder).
    config : the configuration label written in the measurement file.
    alpha_deg : the unloaded absolute link angles, degrees.
    masses_kg : the payload of each steady state in order, kg; the first is the reference.
    """

    file: Path
    config: str
    alpha_deg: tuple[float, ...]
    masses_kg: tuple[float, ...]


@dataclass(frozen=True)
class Campaign:
    """A campaign file: its path and its records (``n`` links, from the angles)."""

    path: Path
    records: tuple[RecordSpec, ...]

    @property
    def n(self) -> int:
        """Number of links of the arm (the length of every record's ``alpha_deg``)."""
        return len(self.records[0].alpha_deg)


@dataclass(frozen=True)
class Record:
    """One record in memory.

    Attributes
    ----------
    path : the file it was read from.
    time_s : (N,) sample times, s, strictly increasing.
    channels : the channel names, in the file's order.
    values : (N, C) the sensors' readings (mm or degrees), finite.
    """

    path: Path
    time_s: FloatArray
    channels: tuple[str, ...]
    values: FloatArray


# ---------------------------------------------------------------------------- campaign
def is_campaign(path: str | Path) -> bool:
    """Whether ``path`` names a campaign file (``.toml``) rather than a measurement file."""
    return str(path).lower().endswith(".toml")


def read_campaign(path: str | Path) -> Campaign:
    """Read and check a campaign file.

    Raises
    ------
    RecordError
        One line naming the file and the record (1-based) and key at fault: no ``[[record]]``,
        a missing or mistyped key, angles of different lengths, fewer than two payloads, a
        negative or non-finite payload, two records of one file or of one config label.

    Warns
    -----
    UserWarning
        Naming the keys that are not read (they are ignored).
    """
    p = Path(path)
    try:
        with open(p, "rb") as f:
            doc = tomllib.load(f)
    except OSError as exc:
        raise RecordError(f"{p}: cannot read campaign file: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise RecordError(f"{p}: not a TOML file ({exc})") from None
    unknown = sorted(set(doc) - {"record"})
    for key in unknown:  # a misspelled [[record]] would drop its records with only a note
        if did_you_mean(key, ["record"], cutoff=0.75):
            raise RecordError(
                f"{p}: [[{key}]] is not a table of a campaign (did you mean [[record]]?); "
                "its records would be left out"
            )
    tables = doc.get("record")
    if not isinstance(tables, list) or not tables:
        raise RecordError(
            f"{p}: no [[record]] table (each gives file, config, alpha_deg, masses_kg)"
        )
    if unknown:
        warnings.warn(
            f"{p}: ignoring key(s) {', '.join(unknown)} (a campaign has [[record]] tables)",
            UserWarning,
            stacklevel=2,
        )
    specs: list[RecordSpec] = []
    for i, t in enumerate(tables, start=1):
        where = f"{p}: record {i}"
        if not isinstance(t, dict):
            raise RecordError(f"{where}: expected a table")
        keys = ("file", "config", "alpha_deg", "masses_kg")
        extra = sorted(set(t) - set(keys))
        if extra:
            warnings.warn(
                f"{where}: ignoring key(s) "
                + ", ".join(f"{k}{did_you_mean(k, keys, cutoff=0.75)}" for k in extra)
                + " (file, config, alpha_deg, masses_kg are read)",
                UserWarning,
                stacklevel=2,
            )
        for key in keys:
            if key not in t:  # named with the key given in its place, if one looks like it
                close = did_you_mean(key, extra).replace("did you mean", "is it")
                raise RecordError(f"{where}: missing key '{key}'{close}")
        if not isinstance(t["file"], str) or not t["file"].strip():
            raise RecordError(f"{where}: 'file' must be a file name")
        if not isinstance(t["config"], str) or not t["config"].strip():
            raise RecordError(f"{where}: 'config' must be a non-empty label")
        alpha = _numbers(t["alpha_deg"], f"{where}: 'alpha_deg'")
        masses = _numbers(t["masses_kg"], f"{where}: 'masses_kg'")
        if not alpha:
            raise RecordError(f"{where}: 'alpha_deg' is empty")
        if specs and len(alpha) != len(specs[0].alpha_deg):
            raise RecordError(
                f"{where}: 'alpha_deg' has {len(alpha)} angles, record 1 has "
                f"{len(specs[0].alpha_deg)} (one arm per campaign)"
            )
        if len(masses) < 2:
            raise RecordError(f"{where}: 'masses_kg' needs the reference and at least one payload")
        if any(m < 0 for m in masses):
            raise RecordError(f"{where}: 'masses_kg' has a negative payload")
        rec_file = p.parent / t["file"]  # as the user finds it from here, for messages
        if any(s.file.resolve() == rec_file.resolve() for s in specs):
            raise RecordError(f"{where}: file '{t['file']}' is listed twice")
        if any(s.config == t["config"] for s in specs):
            raise RecordError(f"{where}: config '{t['config']}' is listed twice")
        specs.append(RecordSpec(rec_file, t["config"].strip(), tuple(alpha), tuple(masses)))
    return Campaign(p, tuple(specs))


def _numbers(v: Any, what: str) -> list[float]:
    if not isinstance(v, list) or not all(
        isinstance(x, (int, float)) and not isinstance(x, bool) for x in v
    ):
        raise RecordError(f"{what} must be a list of numbers")
    out = [float(x) for x in v]
    if not all(math.isfinite(x) for x in out):
        raise RecordError(f"{what} must be finite")
    return out


def write_campaign(
    path: str | Path, specs: Sequence[RecordSpec], out: TextIO | None = None
) -> None:
    """Write a campaign file (whole or not at all: eodarm.atomic); each record's ``file``
    relative to the campaign's folder when it lies inside it. With ``out``, the text goes to
    that open file instead (``path`` still names the campaign: its folder)."""
    p = Path(path)

    def arr(v: Sequence[float]) -> str:
        return "[" + ", ".join(repr(float(x)) for x in v) + "]"

    lines = ["# eodarm campaign: one [[record]] table per record file (docs/records.md)", ""]
    for s in specs:
        try:
            name = str(Path(s.file).resolve().relative_to(p.parent.resolve()))
        except ValueError:
            name = str(s.file)
        lines += [
            "[[record]]",
            f'file = "{name}"',
            f'config = "{s.config}"',
            f"alpha_deg = {arr(s.alpha_deg)}",
            f"masses_kg = {arr(s.masses_kg)}",
            "",
        ]
    if out is not None:
        out.write("\n".join(lines))
        return
    with atomic_write(p) as f:
        f.write("\n".join(lines))


# ---------------------------------------------------------------------------- records
def read_record(path: str | Path, n: int) -> Record:
    """Read and check one record of an ``n``-link arm.

    The numbers are parsed by pandas' C reader (10⁶ samples × 8 channels in well under a
    second); only when that fails is the file scanned line by line to name the first bad
    line.

    Raises
    ------
    RecordError
        One line naming the file, the line and the time: the file cannot be read or is empty,
        no ``time_s`` column, an unknown column or a channel of a link beyond ``n``, a repeated
        column, no channel, a cell that is not a finite number or is empty, a truncated last
        line, or a time that does not increase.
    """
    import pandas as pd

    p = Path(path)
    try:
        with open(p, encoding="utf-8-sig", newline="") as f:
            header_line = f.readline()
    except OSError as exc:
        raise RecordError(f"{p}: cannot read record: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise RecordError(f"{p}: not a UTF-8 text file ({exc.reason})") from None
    if not header_line.strip():
        raise RecordError(f"{p}: empty record (no header, no samples)")
    header = [h.strip() for h in next(csv.reader([header_line]))]
    channels = _check_header(p, header, n)
    try:
        df = pd.read_csv(
            p,
            dtype=np.float64,
            na_filter=False,
            engine="c",
            encoding="utf-8-sig",
            skip_blank_lines=True,
        )
        data = df.to_numpy(dtype=np.float64, copy=False)
        ok = data.shape[1] == len(header)
    except (ValueError, pd.errors.ParserError):
        ok = False
    if not ok:
        _scan(p, header)  # raises, naming the line
        raise RecordError(f"{p}: cannot read the samples")  # pragma: no cover
    if data.shape[0] == 0:
        raise RecordError(f"{p}: empty record (a header and no samples)")
    bad = ~np.isfinite(data)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        _scan(p, header)  # an empty or non-finite cell: named with its line
        raise RecordError(  # pragma: no cover - _scan finds it
            f"{p} line {i + 2}: {header[j]} is not a finite number"
        )
    t = np.ascontiguousarray(data[:, header.index(TIME)])
    dt = np.diff(t)
    if dt.size and not (dt > 0).all():
        k = int(np.argmin(dt > 0))
        raise RecordError(
            f"{p} line {k + 3}: time does not increase (time_s {t[k + 1]:g} s after {t[k]:g} s)"
        )
    cols = [header.index(c) for c in channels]
    values = np.ascontiguousarray(data[:, cols])
    return Record(p, t, tuple(channels), values)


def _check_header(p: Path, header: list[str], n: int) -> list[str]:
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise RecordError(f"{p} line 1: column '{dup}' appears twice")
    if TIME not in header:
        raise RecordError(f"{p} line 1: no '{TIME}' column (seconds)")
    known = set(channel_names(n))
    channels = []
    for h in header:
        if h == TIME:
            continue
        if h not in known:
            if _CHANNEL.match(h):
                raise RecordError(
                    f"{p} line 1: channel '{h}' is of link {channel_link(h)}, the arm has {n}"
                )
            raise RecordError(
                f"{p} line 1: unknown channel '{h}'; a record has {TIME} and channels of "
                f"{', '.join(channel_names(n))}"
            )
        channels.append(h)
    if not channels:
        raise RecordError(f"{p} line 1: no channel (dx_mm, dy_mm, dalphaK_deg, dlK_mm)")
    return channels


def _scan(p: Path, header: list[str]) -> None:
    """Find the first bad line of a record the fast reader refused, and raise its one line."""
    with open(p, encoding="utf-8-sig", newline="") as f:
        reader = csv.reader(f)
        next(reader, None)
        last_t: float | None = None
        rows = 0
        lineno = 1
        for lineno, row in enumerate(reader, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            rows += 1
            t_text = row[header.index(TIME)] if header.index(TIME) < len(row) else ""
            if _finite(t_text):
                at = f" (time {t_text.strip()} s)"
            elif last_t is not None:
                at = f" (after time {last_t:g} s)"
            else:
                at = ""
            if len(row) < len(header):
                tail = "the last line" if _is_last(f) else "a line"
                raise RecordError(
                    f"{p} line {lineno}{at}: {tail} has {len(row)} of {len(header)} fields "
                    "(a truncated record?)"
                )
            if len(row) > len(header):
                raise RecordError(
                    f"{p} line {lineno}{at}: {len(row)} fields, the header has {len(header)}"
                )
            for name, cell in zip(header, row, strict=True):
                if not cell.strip():
                    raise RecordError(f"{p} line {lineno}{at}: {name} is missing (empty cell)")
                if not _finite(cell):
                    raise RecordError(
                        f"{p} line {lineno}{at}: {name} '{cell.strip()[:20]}' is not a number"
                    )
            last_t = float(t_text)
        if rows == 0:
            raise RecordError(f"{p}: empty record (a header and no samples)")


def _is_last(f: TextIO) -> bool:
    rest = f.read()
    return not rest.strip()


def _finite(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def write_record(
    path: str | Path | TextIO,
    time_s: npt.ArrayLike,
    channels: Sequence[str],
    values: npt.ArrayLike,
    digits: int = 7,
) -> None:
    """Write a record as a logger would: ``time_s`` and the channels, one sample per line,
    ``digits`` significant digits; to a path (whole or not at all: eodarm.atomic) or an open
    text file."""
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(values, dtype=float).reshape(t.size, len(channels))
    data = np.column_stack([t, v])
    fmt = ["%.6f"] + [f"%.{digits}g"] * len(channels)

    def write(f: TextIO) -> None:
        f.write(",".join([TIME, *channels]) + "\n")
        np.savetxt(f, data, fmt=fmt, delimiter=",")

    if isinstance(path, (str, Path)):
        with atomic_write(path, newline="") as f:
            write(f)
    else:
        write(path)


def write_rows(
    out: str | Path | TextIO,
    n: int,
    rows: Sequence[dict[str, Any]],
    channels: Sequence[str],
) -> None:
    """Write the measurement file of a campaign (docs/formats.md: the file with a ``step``
    column): ``config``, the angles, ``mass_kg``, ``step``, each channel and its ``sigma_``.

    Each row is a dict with ``config``, ``alpha_deg``, ``mass_kg``, ``step``, ``values`` and
    ``sigma`` (dicts by channel; a channel a record did not log is left empty).
    """
    order = [c for c in channel_names(n) if c in set(channels)]
    head = [
        "config",
        *(f"alpha{k}_deg" for k in range(1, n + 1)),
        "mass_kg",
        "step",
        *order,
        *(f"sigma_{c}" for c in order),
    ]

    def num(x: float | None) -> str:
        return "" if x is None or not math.isfinite(x) else f"{x:.9g}"

    def write(f: TextIO) -> None:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(head)
        for r in rows:
            w.writerow(
                [
                    r["config"],
                    *(num(a) for a in r["alpha_deg"]),
                    num(r["mass_kg"]),
                    str(int(r["step"])),
                    *(num(r["values"].get(c)) for c in order),
                    *(num(r["sigma"].get(c)) for c in order),
                ]
            )

    if isinstance(out, (str, Path)):
        with atomic_write(out, newline="") as f:  # whole or not at all
            write(f)
    else:
        write(out)
