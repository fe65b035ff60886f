"""Short reprs and notebook tables of the package's objects (docs/python.md, "Looking at
results").

Every result a user meets in a shell or a notebook (an arm, measurements, a fit and its
parameters, a diagnosis) prints in a few lines naming what matters (the verdict, the
parameters, χ²/dof), never its arrays; in Jupyter its ``_repr_html_`` is a small table. The
pieces are here, below every layer, so that the model's :class:`~eodarm.model.arm.Arm` and
the analysis' results use the same ones.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Sequence

__all__ = ["MAX_LINES", "block", "html_table", "value", "value_error", "wrap"]

#: Most lines of a repr; the rest are counted (``… and 12 more``).
MAX_LINES = 12

_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


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


def _with_unit(text: str, unit: str) -> str:
    return f"{text} {unit}" if unit else text


def value(x: float | None, unit: str = "", digits: int = 4) -> str:
    """``x`` to ``digits`` significant digits with its unit; ``∞`` and ``—`` (undefined)
    as words."""
    if x is None or math.isnan(x):
        return "—"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    x = x + 0.0  # −0 reads as 0
    if x == 0:
        return _with_unit("0", unit)
    exp = math.floor(math.log10(abs(x)))
    if -5 <= exp < 5:
        if exp >= digits:
            x = round(x, digits - 1 - exp)
        text = f"{x:.{max(digits - 1 - exp, 0)}f}"
        if "." in text:
            text = text.rstrip("0").rstrip(".")
    else:
        mant = f"{x / 10**exp:.{digits - 1}f}".rstrip("0").rstrip(".")
        if mant.lstrip("-") == "10":
            mant, exp = mant.replace("10", "1"), exp + 1
        text = f"{mant}×10{str(exp).translate(_SUPERSCRIPT)}"
    return _with_unit(text.replace("-", "−"), unit)


def value_error(x: float, err: float, unit: str = "", digits: int = 2) -> str:
    """``x ± err``, the error to ``digits`` significant digits and the value to the same
    decimal place; an undefined or infinite error as ``(± ?)``."""
    if x is None or math.isnan(x):
        return "—"
    if math.isinf(x):
        return value(x, unit)
    if err is None or not math.isfinite(err) or err < 0:
        return _with_unit(f"{value(x)} (± ?)", unit)
    if err == 0:
        return _with_unit(f"{value(x, digits=6)} ± 0", unit)
    decimals = digits - 1 - math.floor(math.log10(err))
    big = max(abs(x), err)
    scale = math.floor(math.log10(big))
    if scale >= 5 or scale < -3:
        d = max(decimals + scale, 0)
        xs, es = x / 10**scale, err / 10**scale
        body = f"({xs:.{d}f} ± {es:.{d}f})×10{str(scale).translate(_SUPERSCRIPT)}"
        return _with_unit(body.replace("-", "−"), unit)
    if decimals < 0:
        q = 10 ** (-decimals)
        return _with_unit(
            f"{round(x / q) * q:.0f} ± {round(err / q) * q:.0f}".replace("-", "−"), unit
        )
    return _with_unit(f"{x:.{decimals}f} ± {err:.{decimals}f}".replace("-", "−"), unit)
