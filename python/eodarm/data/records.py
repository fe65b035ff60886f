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
the record and key, or the line (1-based, blank lines counted) and the time, for a record; the
bytes are read with bounds first (:mod:`eodarm.data.record_text`). Finding the steady states
is :mod:`eodarm.analysis.records`.
"""

from __future__ import annotations

import csv
import io
import math
import os
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
from eodarm.data.measurements import MAX_ANGLE_DEG, MAX_MASS_KG
from eodarm.data.record_text import (
    MAX_CAMPAIGN_BYTES,
    MAX_RECORD_BYTES,
    Lines,
    few,
    read_bounded,
    shown,
)
from eodarm.errors import RecordError, listing, show
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


#: The longest config label, characters.
MAX_LABEL = 64


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
        One line naming the file and the record (1-based) and key at fault: the file cannot
        be read or is larger than :data:`~eodarm.data.record_text.MAX_CAMPAIGN_BYTES`, no
        ``[[record]]``, a missing or mistyped key, a file name with a control character,
        angles of different lengths or beyond ±``MAX_ANGLE_DEG``, fewer than two payloads, a
        negative payload or one beyond ``MAX_MASS_KG`` (the measurement file's range), two
        records of one file, a config label that is not printable text of at most
        :data:`MAX_LABEL` characters, or two labels equal but for spaces.

    Warns
    -----
    UserWarning
        Naming the keys that are not read (they are ignored).
    """
    p = Path(path)
    name = shown(p)
    data = read_bounded(p, MAX_CAMPAIGN_BYTES, "campaign file")
    try:
        doc = tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise RecordError(f"{name} line {line}: not UTF-8 text ({exc.reason})") from None
    except tomllib.TOMLDecodeError as exc:
        raise RecordError(f"{name}: not a TOML file ({show(exc, 120)})") from None
    unknown = sorted(set(doc) - {"record"})
    for key in unknown:  # a misspelled [[record]] would drop its records with only a note
        if did_you_mean(key, ["record"], cutoff=0.75):
            raise RecordError(
                f"{name}: [[{show(key)}]] is not a table of a campaign (did you mean "
                "[[record]]?); its records would be left out"
            )
    tables = doc.get("record")
    if not isinstance(tables, list) or not tables:
        raise RecordError(
            f"{name}: no [[record]] table (each gives file, config, alpha_deg, masses_kg)"
        )
    if unknown:
        warnings.warn(
            f"{name}: ignoring key(s) {_keys(unknown)} (a campaign has [[record]] tables)",
            UserWarning,
            stacklevel=2,
        )
    specs: list[RecordSpec] = []
    seen: dict[str, int] = {}
    for i, t in enumerate(tables, start=1):
        where = f"{name}: record {i}"
        if not isinstance(t, dict):
            raise RecordError(f"{where}: expected a table")
        keys = ("file", "config", "alpha_deg", "masses_kg")
        extra = sorted(set(t) - set(keys))
        if extra:
            warnings.warn(
                f"{where}: ignoring key(s) "
                + few([f"{show(k)}{did_you_mean(k, keys, cutoff=0.75)}" for k in extra], len(extra))
                + " (file, config, alpha_deg, masses_kg are read)",
                UserWarning,
                stacklevel=2,
            )
        for key in keys:
            if key not in t:  # named with the key given in its place, if one looks like it
                close = did_you_mean(key, extra).replace("did you mean", "is it")
                raise RecordError(f"{where}: missing key '{key}'{close}")
        file, config = t["file"], t["config"]
        if not isinstance(file, str) or not file.strip():
            raise RecordError(f"{where}: 'file' must be a file name")
        if not file.isprintable():
            raise RecordError(f"{where}: 'file' '{show(file)}' holds a control character")
        if not isinstance(config, str) or not config.strip():
            raise RecordError(f"{where}: 'config' must be a non-empty label")
        label = config.strip()
        if not label.isprintable() or len(label) > MAX_LABEL:
            raise RecordError(
                f"{where}: 'config' '{show(label)}' must be printable text of at most "
                f"{MAX_LABEL} characters"
            )
        alpha = _numbers(t["alpha_deg"], f"{where}: 'alpha_deg'")
        masses = _numbers(t["masses_kg"], f"{where}: 'masses_kg'")
        if not alpha:
            raise RecordError(f"{where}: 'alpha_deg' is empty")
        if specs and len(alpha) != len(specs[0].alpha_deg):
            raise RecordError(
                f"{where}: 'alpha_deg' has {len(alpha)} angles, record 1 has "
                f"{len(specs[0].alpha_deg)} (one arm per campaign)"
            )
        wild = [a for a in alpha if abs(a) > MAX_ANGLE_DEG]
        if wild:
            raise RecordError(
                f"{where}: 'alpha_deg' {wild[0]:.6g} is beyond ±{MAX_ANGLE_DEG:g}° (the range "
                "of a measurement file)"
            )
        if len(masses) < 2:
            raise RecordError(f"{where}: 'masses_kg' needs the reference and at least one payload")
        if any(m < 0 for m in masses):
            raise RecordError(f"{where}: 'masses_kg' has a negative payload")
        heavy = [m for m in masses if m > MAX_MASS_KG]
        if heavy:
            raise RecordError(
                f"{where}: 'masses_kg' {heavy[0]:.6g} is beyond {MAX_MASS_KG:g} kg (the range of "
                "a measurement file)"
            )
        rec_file = p.parent / file  # as the user finds it from here, for messages
        real = os.path.realpath(rec_file)  # no error on a loop: reading it says so
        twice = next((s for s in specs if os.path.realpath(s.file) == real), None)
        if twice is not None:
            raise RecordError(
                f"{where}: file '{show(file)}' is listed twice (record "
                f"{specs.index(twice) + 1} too)"
            )
        if label in seen:
            same = specs[seen[label] - 1].config
            but = "" if config == same else " but for spaces"
            raise RecordError(
                f"{where}: config '{show(config)}' is record {seen[label]}'s "
                f"'{show(same)}'{but}: one label per configuration"
            )
        seen[label] = i
        specs.append(RecordSpec(rec_file, label, tuple(alpha), tuple(masses)))
    return Campaign(p, tuple(specs))


def _keys(keys: Sequence[str]) -> str:
    """Key names for a message: escaped, the first few and the count."""
    return few([show(k) for k in keys], len(keys))


def _numbers(v: Any, what: str) -> list[float]:
    if not isinstance(v, list) or not all(
        isinstance(x, (int, float)) and not isinstance(x, bool) for x in v
    ):
        raise RecordError(f"{what} must be a list of numbers")
    try:
        out = [float(x) for x in v]
    except OverflowError:  # an integer beyond a float
        raise RecordError(f"{what} must be finite") from None
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

    The bytes are read with bounds and checked first (:mod:`eodarm.data.record_text`); the
    numbers are then parsed by pandas' C reader (10⁶ samples × 8 channels in well under a
    second); only when that fails is the text scanned line by line to name the bad cells.

    Raises
    ------
    RecordError
        One line naming the file, the line (1-based, blank lines counted) and the time: the
        file cannot be read, is not a regular file, is too large, binary or not UTF-8, has a
        line longer than ``MAX_LINE``, is empty; no ``time_s`` column, an unknown column or a
        channel of a link beyond ``n``, a repeated or unnamed column, no channel; a line with
        other than the header's number of fields (a leading unnamed field on every line);
        cells that are not finite numbers or are empty (the first three and the count); a
        time that does not increase; a channel that is constant (a sensor that did not log).
    """
    import pandas as pd

    p = Path(path)
    name = shown(p)
    data = read_bounded(p, MAX_RECORD_BYTES, "record")
    if data.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte order mark
        data = data[3:]
    lines = Lines(data, name)
    lines.check()
    header_line = lines.line(0)
    if not header_line.strip():
        raise RecordError(f"{name}: empty record (no header, no samples)")
    header = [h.strip() for h in next(csv.reader([header_line]))]
    channels = _check_header(name, header, n)
    jt = header.index(TIME)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # pandas' ParserWarning: a line it would cut
            df = pd.read_csv(
                io.BytesIO(data),
                header=0,
                index_col=False,
                dtype=np.float64,
                na_filter=False,
                engine="c",
                encoding="utf-8",
                skip_blank_lines=True,
            )
        values = df.to_numpy(dtype=np.float64, copy=False)
        ok = values.shape[1] == len(header) and bool(np.isfinite(values).all())
    except (ValueError, Warning, pd.errors.ParserError):
        ok = False
    if not ok:
        _scan(name, lines, header)  # raises, naming the lines
        raise RecordError(f"{name}: cannot read the samples")  # pragma: no cover
    if values.shape[0] == 0:
        raise RecordError(f"{name}: empty record (a header and no samples)")
    t = np.ascontiguousarray(values[:, jt])
    dt = np.diff(t)
    back = np.flatnonzero(~(dt > 0))
    if back.size:
        rows = lines.row_lines()
        items = [f"line {rows[k + 1]}: time_s {t[k + 1]:g} s after {t[k]:g} s" for k in back[:3]]
        head = f"{name}: time does not increase at {back.size} place{'s' if back.size > 1 else ''}"
        raise RecordError(listing(head, items, int(back.size)))
    cols = [header.index(c) for c in channels]
    out = np.ascontiguousarray(values[:, cols])
    flat = np.flatnonzero(out.min(axis=0) == out.max(axis=0))
    if flat.size and out.shape[0] > 1:
        j = int(flat[0])
        raise RecordError(
            f"{name}: {channels[j]} is constant ({out[0, j]:g} in all {out.shape[0]} samples): "
            "a sensor that did not log? a constant tells nothing and has no noise; drop the column"
        )
    return Record(p, t, tuple(channels), out)


def _check_header(name: str, header: list[str], n: int) -> list[str]:
    for k, h in enumerate(header, start=1):
        if not h:
            why = (
                "an index column, as pandas writes one? drop it (index=False) or name it"
                if k == 1
                else "a trailing comma?"
                if k == len(header)
                else "two commas in a row?"
            )
            raise RecordError(f"{name} line 1: column {k} has no name ({why})")
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise RecordError(f"{name} line 1: column '{show(dup)}' appears twice")
    if TIME not in header:
        raise RecordError(f"{name} line 1: no '{TIME}' column (seconds)")
    known = set(channel_names(n))
    channels = []
    for h in header:
        if h == TIME:
            continue
        if h not in known:
            if _CHANNEL.match(h):
                raise RecordError(
                    f"{name} line 1: channel '{h}' is of link {channel_link(h)}, the arm has {n}"
                )
            raise RecordError(
                f"{name} line 1: unknown channel '{show(h)}'; a record has {TIME} and "
                "channels dx_mm, dy_mm, dalphaK_deg, dlK_mm"
                + (f" (K = 1…{n})" if n > 1 else " (K = 1)")
            )
        channels.append(h)
    if not channels:
        raise RecordError(f"{name} line 1: no channel (dx_mm, dy_mm, dalphaK_deg, dlK_mm)")
    return channels


def _scan(name: str, lines: Lines, header: list[str]) -> None:
    """Name what the fast reader refused, scanning the text with the csv module (true line
    numbers): lines with other than the header's number of fields, else bad cells; the first
    three and the count. Raise their one line."""
    jt = header.index(TIME)
    fields = len(header)
    reader = csv.reader(io.StringIO(lines.data.decode("utf-8"), newline=""))
    next(reader, None)
    shape: list[str] = []  # lines with a wrong number of fields: the first three
    shapes = 0
    extra_one = 0  # lines with exactly one field more
    last_short = False
    bad: list[tuple[str, str]] = []  # (where, what) of the first bad cells
    count = 0
    rows = 0
    last_t: float | None = None
    for row in reader:
        if not row or all(not c.strip() for c in row):
            continue
        lineno = reader.line_num
        rows += 1
        t_text = row[jt] if jt < len(row) else ""
        if _finite(t_text):
            at = f" (time {show(t_text.strip(), 20)} s)"
        elif last_t is not None:
            at = f" (after time {last_t:g} s)"
        else:
            at = ""
        last_short = len(row) < fields
        if len(row) != fields:
            shapes += 1
            extra_one += len(row) == fields + 1
            if len(shape) < 3:
                shape.append(f"line {lineno}{at if not shape else ''} has {len(row)}")
            continue
        for col, cell in zip(header, row, strict=True):
            if not cell.strip():
                what = f"{col} is missing (empty cell)"
            elif not _finite(cell):
                why = "is not finite" if _number(cell) else "is not a number"
                what = f"{col} '{show(cell.strip(), 20)}' {why}"
            else:
                continue
            count += 1
            if len(bad) < 3:
                bad.append((f"line {lineno}{at}", what))
        if _finite(t_text):
            last_t = float(t_text)
    if rows == 0:
        raise RecordError(f"{name}: empty record (a header and no samples)")
    if shapes and extra_one == rows:
        raise RecordError(
            f"{name}: every line has {fields + 1} fields, the header {fields} "
            f"({show(','.join(header), 40)}): a leading unnamed field (an index column)? "
            "name it or drop it"
        )
    if shapes:
        cut = " (the last cut short: a truncated record?)" if last_short else ""
        head = (
            f"{name}: {shapes} line{'s' if shapes > 1 else ''} with other than the header's "
            f"{fields} fields{cut}"
        )
        raise RecordError(listing(head, shape, shapes))
    if count == 1:
        raise RecordError(f"{name} {bad[0][0]}: {bad[0][1]}")
    if count:
        # the time on the first only: the line numbers say where the others are
        items = [_short_item(w if k == 0 else w.split(" (")[0], x) for k, (w, x) in enumerate(bad)]
        raise RecordError(listing(f"{name}: {count} bad cells", items, count))


def _short_item(where: str, what: str) -> str:
    """One bad cell in a list of several: its line and its cell (at most 12 characters of
    it), without the reason."""
    for reason in (" is not a number", " is not finite", " is missing (empty cell)"):
        if what.endswith(reason):
            what = what[: -len(reason)] + (" ''" if "missing" in reason else "")
    col, _, cell = what.partition(" '")
    if cell:
        what = f"{col} '{show(cell[:-1], 12)}'" if cell.endswith("'") else what
    return f"{where} {show(what, 40)}"


def _number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


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
