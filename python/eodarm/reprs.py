"""Short reprs and notebook tables of the package's objects (docs/python.md, "Looking at
results").

Every result a user meets in a shell or a notebook (an arm, measurements, a fit and its
parameters, a diagnosis) prints in a few lines naming what matters (the verdict, the
parameters, χ²/dof), never its arrays; in Jupyter its ``_repr_html_`` is a small table. The
pieces are here, below every layer, so that the model's :class:`~eodarm.model.arm.Arm` and
the analysis' results use the same ones; their numbers are :mod:`eodarm.text`'s, the
formatter of every table, line and page.
"""

from __future__ import annotations

import html
from collections.abc import Iterable, Sequence

__all__ = ["MAX_LINES", "block", "html_table", "wrap"]

#: Most lines of a repr; the rest are counted (``… and 12 more``).
MAX_LINES = 12


def block(title: str, lines: Iterable[str] = (), limit: int = MAX_LINES) -> str:
    """``<title`` then each line indented, ``>`` closing the last: at most ``limit`` lines,
    the rest counted."""
    shown = list(lines)
    if len(shown) > limit:
        shown = [*shown[: limit - 1], f"… and {len(shown) - limit + 1} more"]
    return "<" + "\n  ".join([title, *shown]) + ">"


def wrap(prefix: str, items: Iterable[str], width: int = 96) -> list[str]:
    """``prefix`` and the items joined by ``", "``, in lines of about ``width`` characters
    broken between items (never inside one), the later lines indented."""
    lines = [prefix]
    for item in items:
        if lines[-1] != prefix and len(lines[-1]) + 2 + len(item) > width:
            lines[-1] += ","
            lines.append("    " + item)
        else:
            lines[-1] += (" " if lines[-1] == prefix else ", ") + item
    return lines


def html_table(
    headers: Sequence[str], rows: Iterable[Sequence[str]], caption: str = "", limit: int = 50
) -> str:
    """A small HTML table (every cell escaped; well-formed XHTML), at most ``limit`` rows,
    the rest counted in a last row."""
    rows = list(rows)
    more = len(rows) - limit
    if more > 0:
        rows = [*rows[:limit], [f"… and {more} more", *([""] * (len(headers) - 1))]]
    parts = ["<table>"]
    if caption:
        parts.append(f"<caption>{html.escape(caption)}</caption>")
    parts.append("<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in headers) + "</tr>")
    for r in rows:
        parts.append("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>")
    parts.append("</table>")
    return "".join(parts)
