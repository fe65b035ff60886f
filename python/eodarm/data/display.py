"""How measurements show in a shell or a notebook: what was measured, on how many states and
payloads, and where each channel's σ came from, in a few lines (``repr``) or a small table
(``_repr_html_``), never the arrays (docs/python.md).

The measurements are read by their attributes rather than imported, because
:mod:`eodarm.data.measurements` calls these functions.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from eodarm import reprs
from eodarm import text as fmt

__all__ = ["measurements_html", "measurements_repr"]


def _title(meas: Any) -> str:
    masses = sorted({float(m) for m in np.asarray(meas.mass_kg)} - {0.0})
    shown = ", ".join(fmt.value(m) for m in masses[:8]) + (" …" if len(masses) > 8 else "")
    seq = ", load sequences (step column)" if meas.has_sequences else ""
    return (
        f"Measurements {meas.source}: {meas.n_rows} states of a {meas.n}-link arm, "
        f"{len(meas.configs)} configurations, payloads {shown or 'none'} kg{seq}"
    )


def _rows(meas: Any) -> list[list[str]]:
    """Per measured channel: its values, the median σ and where the σ came from."""
    rows = []
    for j, ch in enumerate(meas.channels):
        seen = np.isfinite(np.asarray(meas.values)[:, j])
        if not seen.any():
            continue
        unit = ch.rsplit("_", 1)[1]
        sigma = float(np.median(np.asarray(meas.sigma)[seen, j]))
        noise = meas.noise.get(ch)
        where = "" if noise is None else noise.source
        rows.append([ch, f"{int(seen.sum())}", fmt.value(sigma, unit, 3), where])
    return rows


def measurements_repr(meas: Any) -> str:
    """``<Measurements file: N states …`` then one line per measured channel."""
    lines = [f"{ch}: {k} values, σ {s} ({where})" for ch, k, s, where in _rows(meas)]
    return reprs.block(_title(meas), lines or ["no channel measured"])


def measurements_html(meas: Any) -> str:
    """The measured channels in a table under the title."""
    headers = ["channel", "values", "σ (median)", "σ from"]
    return reprs.html_table(headers, _rows(meas), _title(meas))
