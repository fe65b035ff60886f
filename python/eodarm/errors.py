"""Exception types raised by eodarm.

Every error a user's input can cause is a :class:`ValueError` subclass with a one-line message
that names the file and key, the row, or the pose at fault.
"""

from __future__ import annotations

__all__ = [
    "ArgumentTypeError",
    "ArmFileError",
    "ClusterError",
    "CustomEffectError",
    "EffectError",
    "EodarmError",
    "InputError",
    "OutOfMemoryError",
    "RecordError",
    "SweepTooLargeError",
    "printable",
]

#: The longest message of a :class:`RecordError`, so that the command's line
#: (``eodarm: error: `` and the message) stays under 300 characters; what does not fit is cut.
MAX_MESSAGE = 280


class EodarmError(ValueError):
    """Base class of every input error eodarm raises."""


class ArmFileError(EodarmError):
    """An arm file (or dict) is malformed; the message names the source and the key."""


class EffectError(EodarmError):
    """An effect is unknown, placed where it cannot be, or has a bad parameter.

    ``key`` names the offending key of an ``[[effect]]`` table (``effect``, ``at`` or the
    parameter) when the error came from one, so that the arm file's message can name it.
    """

    def __init__(self, message: str, key: str | None = None) -> None:
        super().__init__(message)
        self.key = key


class CustomEffectError(EffectError):
    """A user-written effect (custom-effects.md) failed: its function raised or returned something
    eodarm cannot use, or a file of effects did not load. The message is one line naming
    ``effect@place`` and the key (or the file); the original exception, if any, is chained."""


class InputError(EodarmError):
    """Arrays given to a solver have the wrong shape or non-finite values (row named)."""


class ArgumentTypeError(TypeError):
    """An API function was given an argument of the wrong type (a path where an
    :class:`~eodarm.Arm` belongs, say); the message says what to pass instead."""


class SweepTooLargeError(InputError):
    """A sweep's output would not fit in memory (or on disk); refused before it starts,
    with the estimate in the message."""


class ClusterError(EodarmError):
    """A Dask cluster could not finish a sweep: it lost all its workers (or its scheduler),
    or a chunk's workers kept dying."""


class OutOfMemoryError(EodarmError, MemoryError):
    """An output would not fit in the memory available (a :class:`MemoryError` too): the
    estimate was checked before anything was allocated."""


class RecordError(EodarmError):
    """A campaign file or a raw record is malformed, or a record's steady states cannot be
    matched to its payloads (docs/records.md); the one-line message names the file and the
    record, line, time or key. A message longer than :data:`MAX_MESSAGE` characters is cut."""

    def __init__(self, message: str) -> None:
        super().__init__(printable(" ".join(message.split()), MAX_MESSAGE))


def printable(text: object, limit: int = 40, tail: bool = False) -> str:
    """``text`` as a one-line message shows it: every character that is not printable
    escaped (``\\x00``, ``\\x1b``, ``\\n``, …) and at most ``limit`` characters, cut with
    an ellipsis at the end, or at the start with ``tail=True`` (a path keeps its file name).
    """
    s = str(text)
    if not s.isprintable():
        s = "".join(c if c.isprintable() else repr(c)[1:-1] for c in s)
    if len(s) <= limit:
        return s
    return "…" + s[len(s) - limit + 1 :] if tail else s[: limit - 1] + "…"
