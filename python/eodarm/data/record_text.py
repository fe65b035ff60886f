"""The bytes of a campaign file or a raw record, read with bounds (docs/records.md, "What is
refused").

A record is a logger's file: it may be huge, binary, cut short, a device (``/dev/zero``), a
symbolic link that loops, a file of one endless line. Before any parsing, the file is checked
here, every refusal one line naming the file (and the line, 1-based, blank lines counted):

* it is a regular file of at most :data:`MAX_RECORD_BYTES` (a campaign file
  :data:`MAX_CAMPAIGN_BYTES`), read in one bounded read;
* it holds no NUL byte (a binary file) and is UTF-8 text;
* no line is longer than :data:`MAX_LINE` characters (a file without newlines);
* every non-blank line has as many fields as the header (a leading unnamed index column,
  a stray comma).

:func:`listing` writes "the first three and the count" of what was found, so that a message
stays under 300 characters however many lines are bad.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from eodarm.errors import RecordError, printable

__all__ = [
    "MAX_CAMPAIGN_BYTES",
    "MAX_LINE",
    "MAX_RECORD_BYTES",
    "Lines",
    "listing",
    "read_bounded",
    "shown",
]

#: The largest record, bytes (10⁷ samples of 8 channels, about 0.9 GB of CSV).
MAX_RECORD_BYTES = 1 << 30
#: The largest campaign file, bytes.
MAX_CAMPAIGN_BYTES = 1 << 24
#: The longest line of a record, characters (a logger's line is a few hundred).
MAX_LINE = 1 << 16
#: How many offending items a message lists before it counts the rest.
LISTED = 3


def shown(path: str | Path) -> str:
    """A path as a message shows it: escaped, at most 72 characters (its end kept)."""
    return printable(str(path), 72, tail=True)


def listing(items: Sequence[str], count: int) -> str:
    """The first :data:`LISTED` of ``items`` and, when there are more, how many in all:
    ``"a; b; c (and 17 more)"``."""
    head = "; ".join(items[:LISTED])
    return head + (f" (and {count - LISTED} more)" if count > LISTED else "")


def read_bounded(path: str | Path, limit: int, what: str) -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them.

    Raises
    ------
    RecordError
        The file cannot be opened (missing, no permission, a symbolic link that loops, a
        NUL byte in its name), is a folder, a device or a pipe, or is larger than ``limit``.
    """
    name = shown(path)
    try:
        st = os.stat(path)
    except OSError as exc:
        raise RecordError(f"{name}: cannot read {what}: {exc.strerror or exc}") from None
    except ValueError:  # "embedded null byte": the name, not the file
        raise RecordError(f"{name}: cannot read {what}: its name holds a NUL byte") from None
    if stat.S_ISDIR(st.st_mode):
        raise RecordError(f"{name}: is a folder, not a {what}")
    if not stat.S_ISREG(st.st_mode):
        raise RecordError(f"{name}: not a regular file (a device or a pipe?); a {what} is a file")
    if st.st_size > limit:
        raise RecordError(
            f"{name}: {st.st_size} bytes, more than a {what} may have ({limit}; docs/records.md)"
        )
    try:
        with open(path, "rb") as f:
            data = f.read(limit + 1)
    except OSError as exc:
        raise RecordError(f"{name}: cannot read {what}: {exc.strerror or exc}") from None
    if len(data) > limit:  # it grew while being read
        raise RecordError(f"{name}: more than {limit} bytes, more than a {what} may have")
    return data


class Lines:
    """The lines of a record's bytes: where each ends, how many commas it has, which are
    blank, and the checks of the module docstring (:meth:`check`, :meth:`check_fields`).

    Line numbers are 1-based and count every line, blank ones included.
    """

    def __init__(self, data: bytes, name: str) -> None:
        self.data = data
        self.name = name
        buf = np.frombuffer(data, dtype=np.uint8)
        nl = np.flatnonzero(buf == 10)
        # the last line, unless the file ends with a newline
        self.ends: npt.NDArray[np.int64] = (
            nl if nl.size and nl[-1] == len(data) - 1 else np.append(nl, len(data))
        )
        self.starts = np.concatenate([[0], self.ends[:-1] + 1])
        commas = np.flatnonzero(buf == 44)
        self.commas = np.bincount(np.searchsorted(self.ends, commas), minlength=self.count)

    @property
    def count(self) -> int:
        """Number of lines."""
        return int(self.ends.size)

    def line(self, i: int) -> str:
        """Line ``i`` (0-based) decoded, without its line end."""
        raw = self.data[int(self.starts[i]) : int(self.ends[i])]
        return raw.decode("utf-8", errors="replace").rstrip("\r")

    def check(self) -> None:
        """Refuse a NUL byte, a line longer than :data:`MAX_LINE` characters, or bytes that
        are not UTF-8, naming the first line at fault."""
        nul = self.data.find(b"\0")
        if nul >= 0:
            raise RecordError(
                f"{self.name} line {self._line_of(nul)}: a NUL byte (a binary file, not a CSV?)"
            )
        lengths = self.ends - self.starts
        long = np.flatnonzero(lengths > MAX_LINE)
        if long.size:
            whole = ", the whole file" if self.count == 1 else ""
            raise RecordError(
                f"{self.name} line {int(long[0]) + 1}: longer than {MAX_LINE} characters "
                f"({int(lengths[long[0]])} bytes{whole}); a record has one sample per line"
            )
        if not self.data.isascii():
            try:
                self.data.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise RecordError(
                    f"{self.name} line {self._line_of(exc.start)}: not UTF-8 text ({exc.reason})"
                ) from None

    def _line_of(self, offset: int) -> int:
        return int(np.searchsorted(self.ends, offset)) + 1

    def _blank(self, i: int) -> bool:
        return not self.data[int(self.starts[i]) : int(self.ends[i])].strip()

    def row_lines(self) -> npt.NDArray[np.int64]:
        """The 1-based line number of every sample: the non-blank lines after the header
        (a line with a comma is not blank)."""
        rows = np.arange(1, self.count, dtype=np.int64)
        maybe = rows[self.commas[1:] == 0]
        blank = [i for i in maybe.tolist() if self._blank(i)]
        if blank:
            rows = rows[~np.isin(rows, np.asarray(blank, dtype=np.int64))]
        return rows + 1

    def check_fields(self, header: Sequence[str], time_col: int) -> None:
        """Refuse the non-blank lines after the header whose number of fields (counted by
        commas: the caller skips this for a file with quotes) is not the header's. When every
        line has one field more, it is a leading unnamed field (an index column)."""
        fields = len(header)
        rows = self.row_lines() - 1  # 0-based
        got = self.commas[rows] + 1
        bad = rows[got != fields]
        if not bad.size:
            return
        if bad.size == rows.size and (got == fields + 1).all():
            raise RecordError(
                f"{self.name}: every line has {fields + 1} fields, the header {fields} "
                f"({printable(','.join(header), 40)}): a leading unnamed field (an index "
                "column)? name it or drop it"
            )
        items = []
        for i in bad[:LISTED].tolist():
            cells = self.line(i).split(",")
            when = cells[time_col].strip() if time_col < len(cells) else ""
            at = f" (time {printable(when, 20)} s)" if when else ""
            items.append(f"line {i + 1}{at} has {int(self.commas[i]) + 1}")
        cut = bad[-1] == rows[-1] and self.commas[bad[-1]] + 1 < fields
        raise RecordError(
            f"{self.name}: {bad.size} line{'s' if bad.size > 1 else ''} with other than the "
            f"header's {fields} fields: {listing(items, int(bad.size))}"
            + ("; the last line cut short: a truncated record?" if cut else "")
        )
