"""Exception types raised by eodarm, and the one-line messages they carry.

Every error a user's input can cause is a :class:`ValueError` subclass with a one-line message
that names the file and key, the row, or the pose at fault. A message stays under
:data:`MAX_MESSAGE` characters whatever the input: :func:`show` writes a cell, a key or a
file name as one short printable line, and :func:`listing` names the first few problems
and counts the rest (docs/formats.md, "Refusals").
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = [
    "MAX_MESSAGE",
    "MESSAGE_ROOM",
    "ArgumentTypeError",
    "ArmFileError",
    "ClusterError",
    "CustomEffectError",
    "EffectError",
    "EodarmError",
    "InputError",
    "OutOfMemoryError",
    "SweepTooLargeError",
    "listing",
    "show",
    "show_source",
]

#: A refusal of bad input prints one line shorter than this (characters), its
#: ``eodarm: error: `` included: the message itself is kept within :data:`MESSAGE_ROOM`.
MAX_MESSAGE = 300
MESSAGE_ROOM = MAX_MESSAGE - 20
#: Problems named in a message before the rest are counted.
SHOWN = 3
#: The longest a cell, key or value is shown in a message, and a file name.
CELL_CHARS = 40
SOURCE_CHARS = 120


def show(value: object, limit: int = CELL_CHARS) -> str:
    """``value`` as a message shows it: one printable line, at most ``limit`` characters.

    A character that is not printable (a NUL, an escape, a newline of a quoted cell, a
    bidirectional control) is written as its Python escape (``\\x00``, ``\\x1b``,
    ``\\n``, ``\\u202e``); printable text (accents, symbols) is kept. Longer text is cut,
    with ``…`` at the cut. A float is shown by ``repr``; other values by ``str``.
    """
    text = repr(value) if isinstance(value, float) else str(value)
    if len(text) > 4 * limit:  # a 100 kB cell: only its start is ever shown
        text = text[: 4 * limit]
    if not text.isprintable():
        text = "".join(
            c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text
        )
    return text if len(text) <= limit else text[: max(limit - 1, 0)] + "…"


def show_source(source: object, limit: int = SOURCE_CHARS) -> str:
    """A file name as a message shows it: printable (:func:`show`'s escapes) and, when
    longer than ``limit``, its start and its end around a ``…`` (the end names the file)."""
    text = show(source, 10 * limit)
    if len(text) <= limit:
        return text
    head = limit // 3
    return text[:head] + "…" + text[-(limit - head - 1) :]


def listing(head: str, items: Sequence[str], count: int | None = None) -> str:
    """``head: item; item; item; …and N more`` in at most :data:`MESSAGE_ROOM` characters.

    Parameters
    ----------
    head : what the message is about, e.g. ``"meas.csv: 24 bad row(s)"`` (cut if it alone
        would not leave room for the items).
    items : the problems, in order (each already one line: :func:`show` its cells); the
        first :data:`SHOWN` are named, each cut to an equal share of the room left.
    count : how many problems there are in all (default ``len(items)``: pass it when only
        the first few were collected).
    """
    total = len(items) if count is None else max(int(count), len(items))
    shown = [" ".join(str(i).split()) for i in items[:SHOWN]]
    more = f"; …and {total - len(shown)} more" if total > len(shown) else ""
    head = " ".join(head.split())
    if len(head) > 2 * MESSAGE_ROOM // 3:
        head = head[: 2 * MESSAGE_ROOM // 3 - 1] + "…"
    if not shown:
        return head
    room = MESSAGE_ROOM - len(head) - 2 - len(more) - 2 * (len(shown) - 1)
    each = max(room // len(shown), 12)
    cut = [s if len(s) <= each else s[: each - 1] + "…" for s in shown]
    return (head + ": " + "; ".join(cut) + more)[:MESSAGE_ROOM]


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
