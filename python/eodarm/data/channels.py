"""The measurement channels (docs/formats.md §3): names, families, default noise levels.

``dx_mm``, ``dy_mm`` (the measure point), ``dalphaK_deg`` (link K's absolute angle) and
``dlK_mm`` (actuator K's body as its own sensor sees it), in that fixed order.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import EodarmError

__all__ = [
    "DEFAULT_SIGMA",
    "channel_family",
    "channel_link",
    "channel_names",
    "channel_values",
    "default_sigma",
    "expand_channels",
]

FloatArray = npt.NDArray[np.float64]


#: Default standard deviation of one measured value, per channel family (mm or degrees).
#: See the module docstring for where the numbers come from.
DEFAULT_SIGMA: dict[str, float] = {
    "dx_mm": 0.02,
    "dy_mm": 0.02,
    "dalpha_deg": 0.02,
    "dl_mm": 0.002,
}


_CHANNEL = re.compile(r"^(?:(dx_mm|dy_mm)|dalpha([1-9][0-9]*)_deg|dl([1-9][0-9]*)_mm)$")


_FAMILY_ALIASES = {
    "dx": "dx_mm",
    "dx_mm": "dx_mm",
    "dy": "dy_mm",
    "dy_mm": "dy_mm",
    "dalpha": "dalpha_deg",
    "dalpha_deg": "dalpha_deg",
    "dl": "dl_mm",
    "dl_mm": "dl_mm",
}


# ---------------------------------------------------------------------------- channels
def channel_names(n: int) -> list[str]:
    """The measurement channels of an ``n``-link arm, in the fixed order of the contract.

    >>> channel_names(2)
    ['dx_mm', 'dy_mm', 'dalpha1_deg', 'dalpha2_deg', 'dl1_mm', 'dl2_mm']
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise EodarmError(f"the number of links must be an integer >= 1, got {n!r}")
    k = range(1, int(n) + 1)
    return ["dx_mm", "dy_mm", *(f"dalpha{i}_deg" for i in k), *(f"dl{i}_mm" for i in k)]


def channel_family(channel: str) -> str:
    """The family of a channel: ``"dx_mm"``, ``"dy_mm"``, ``"dalpha_deg"`` or ``"dl_mm"``.

    Raises
    ------
    EodarmError
        If ``channel`` is not a channel name.
    """
    m = _CHANNEL.match(channel) if isinstance(channel, str) else None
    if m is None:
        raise EodarmError(
            f"'{channel}' is not a measurement channel (dx_mm, dy_mm, dalphaK_deg, dlK_mm)"
        )
    if m.group(1):
        return m.group(1)
    return "dalpha_deg" if m.group(2) else "dl_mm"


def channel_link(channel: str) -> int | None:
    """The 1-based link (or actuator) number of a channel, ``None`` for ``dx_mm``/``dy_mm``."""
    m = _CHANNEL.match(channel) if isinstance(channel, str) else None
    if m is None:
        raise EodarmError(f"'{channel}' is not a measurement channel")
    k = m.group(2) or m.group(3)
    return int(k) if k else None


def default_sigma(channel: str) -> float:
    """Default standard deviation of one value of ``channel`` (mm, or degrees for angles)."""
    return DEFAULT_SIGMA[channel_family(channel)]


def expand_channels(
    spec: str | Iterable[str] | None, n: int, kinds: Sequence[str] | None = None
) -> list[str]:
    """Channel names from a user's selection, in the fixed channel order, without repeats.

    Parameters
    ----------
    spec : ``None`` or ``"all"`` for every channel; otherwise channel names and family names
        (``dx``/``dx_mm``, ``dy``/``dy_mm``, ``dalpha``/``dalpha_deg`` for every link's angle,
        ``dl``/``dl_mm`` for every actuator), as an iterable or one comma-separated string.
    n : number of links.
    kinds : each joint's kind (``Arm.kinds``): a joint turned by a ``"rotary"`` drive has no
        length channel, so ``all`` and ``dl`` leave its ``dlK_mm`` out and naming it is an
        error. Default: every joint linear.

    Raises
    ------
    EodarmError
        On an unknown name, a channel of a link beyond ``n`` or the length of a drive.
    """
    every = channel_names(n)
    drives = [f"dl{i + 1}_mm" for i, k in enumerate(kinds or ()) if k == "rotary"]
    if drives:
        for item in spec.split(",") if isinstance(spec, str) else list(spec or ()):
            if str(item).strip() in drives:
                i = str(item).strip()[2:-3]
                raise EodarmError(
                    f"channel '{str(item).strip()}': joint {i} is turned by a rotary drive, "
                    f"which has no length channel (its turn is in dalpha{i}_deg)"
                )
        every = [c for c in every if c not in drives]
    if spec is None:
        return every
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    chosen: set[str] = set()
    for raw in items:
        item = str(raw).strip()
        if not item:
            continue
        if item == "all":
            chosen.update(every)
        elif item in _FAMILY_ALIASES:
            fam = _FAMILY_ALIASES[item]
            chosen.update(c for c in every if channel_family(c) == fam)
        elif item in every:
            chosen.add(item)
        else:
            link = channel_link(item) if _CHANNEL.match(item) else None
            if link is not None:
                raise EodarmError(f"channel '{item}': the arm has only {n} links")
            raise EodarmError(
                f"unknown channel '{item}'; expected 'all', dx_mm, dy_mm, dalpha, dl "
                f"or one of {', '.join(every)}"
            )
    if not chosen:
        raise EodarmError("no channel selected")
    return [c for c in every if c in chosen]


def channel_values(out: Mapping[str, Any], channels: Sequence[str]) -> FloatArray:
    """Arrange a solver result (:func:`eodarm.solve`) as a (N, C) array of ``channels``.

    ``dx_mm``/``dy_mm`` come from ``out["dx_mm"]``/``out["dy_mm"]``, ``dalphaK_deg`` from
    column K−1 of ``out["dalpha_deg"]`` and ``dlK_mm`` from column K−1 of ``out["dl_mm"]``.
    """
    cols = []
    for ch in channels:
        fam, k = channel_family(ch), channel_link(ch)
        a = np.asarray(out[fam], dtype=float)
        cols.append(a if k is None else a[:, k - 1])
    rows = len(np.asarray(out["dx_mm"]))
    return np.column_stack(cols) if cols else np.zeros((rows, 0))
