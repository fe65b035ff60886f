"""One cell of a measurement file: read as a number, shown in a message, matched to a known
name (docs/formats.md §3)."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence

from eodarm.errors import show

Cell = str | float | None

_NUMBER = re.compile(r"^[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?$")


_DECIMAL_COMMA = re.compile(r"^[+-]?[0-9]*,[0-9]+$")


_NONFINITE = {"nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity"}


def _did_you_mean(name: str, known: Sequence[str], form: str = " (did you mean '{}'?)") -> str:
    """`` (did you mean 'x'?)`` for the closest of ``known`` to a misspelled ``name``
    (difflib's ratio ≥ 0.75, case ignored), or nothing. Names longer than 100 characters
    are not compared (difflib's time grows with the square of their length, and no column
    name is that long)."""
    import difflib

    if len(name) > 100:
        return ""
    lower = {k.lower(): k for k in known if len(k) <= 100}
    close = difflib.get_close_matches(name.strip().lower(), list(lower), n=1, cutoff=0.75)
    return form.format(lower[close[0]]) if close else ""


def _cells_of(body: Sequence[tuple[int, Sequence[Cell]]], j: int | None) -> list[Cell]:
    """Column ``j`` of every row (None where the row is short or there is no column)."""
    return [cells[j] if j is not None and j < len(cells) else None for _, cells in body]


def _label(cell: Cell) -> str:
    if cell is None or (isinstance(cell, float) and math.isnan(cell)):
        return ""
    return cell if isinstance(cell, str) else repr(cell)


def _show(cell: Cell, limit: int = 20) -> str:
    """A cell as an error message shows it (:func:`eodarm.errors.show`): one printable line
    (control characters, NUL and newlines of a quoted cell escaped), at most ``limit``
    characters, so that three of them fit in one message."""
    return show(cell if isinstance(cell, float) else str(cell).strip(), limit)


def _number(cell: Cell) -> tuple[float | None, str]:
    """(value, "") for a number, (None, "") for an empty cell, (None, why) otherwise."""
    if cell is None:
        return None, ""
    if isinstance(cell, float):
        if math.isnan(cell):
            return None, ""
        if math.isinf(cell):
            return None, f"'{cell!r}' is not finite"
        return cell, ""
    text = cell.strip()
    if not text:
        return None, ""
    if _NUMBER.match(text):
        x = float(text)
        if math.isinf(x):
            return None, f"'{_show(text)}' is not finite"
        return x, ""
    if text.lower() in _NONFINITE:
        return None, f"'{text}' is not finite"
    if _DECIMAL_COMMA.match(text):
        dot = _show(text.replace(",", "."))
        return None, f"'{_show(text)}': a decimal comma? (write {dot})"
    return None, f"'{_show(text)}' is not a number"
