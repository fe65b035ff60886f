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
  a stray comma): checked by :mod:`eodarm.data.records` where the fast reader fails.

Messages name the first three of what was found and count the rest (:func:`eodarm.errors.listing`,
:func:`few`), so that a message stays under 300 characters however many lines are bad.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from eodarm.errors import RecordError, show_source

__all__ = [
    "MAX_CAMPAIGN_BYTES",
    "MAX_LINE",
    "MAX_RECORD_BYTES",
    "Lines",
    "few",
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
    """A path as a message shows it (:func:`eodarm.errors.show_source`)."""
    return show_source(path)


def few(items: Sequence[str], count: int, sep: str = ", ") -> str:
    """The first :data:`LISTED` of ``items`` inside a sentence and, when there are more, how
    many: ``"a, b, c (and 17 more)"`` (a message's own list of problems is
    :func:`eodarm.errors.listing`)."""
    head = sep.join(items[:LISTED])
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
            # as many bytes as the file has (a buffer of the limit would be allocated whole),
            # and one more to see that it did not grow while being read
            data = f.read(st.st_size)
            grew = f.read(1)
    except OSError as exc:
        raise RecordError(f"{name}: cannot read {what}: {exc.strerror or exc}") from None
    if grew:
        raise RecordError(f"{name}: grew while it was read (a logger still writing it?)")
    return data


class Lines:
    """The lines of a record's bytes: where each ends, which are blank, and the checks of
    the module docstring (:meth:`check`).

    Line numbers are 1-based and count every line, blank ones included.
    """

    def __init__(self, data: bytes, name: str) -> None:
        self.data = data
        self.name = name
        nl = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) == 10)
        # the last line, unless the file ends with a newline
        self.ends: npt.NDArray[np.int64] = (
            nl if nl.size and nl[-1] == len(data) - 1 else np.append(nl, len(data))
        )
        self.starts = np.concatenate([[0], self.ends[:-1] + 1])

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

    def row_lines(self) -> npt.NDArray[np.int64]:
        """The 1-based line number of every sample: the lines after the header that hold more
        than spaces, tabs and a carriage return (pandas skips the others)."""
        pieces = self.data.split(b"\n")[: self.count]
        full = np.fromiter((bool(x.strip()) for x in pieces), dtype=bool, count=len(pieces))
        return np.flatnonzero(full[1:]) + 2
