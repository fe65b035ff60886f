"""Unit slips an arm file may hold: lengths in metres, masses in grams (warnings, not refusals).

An arm file is read in mm and kg (docs/formats.md §1). Two slips are common and leave a file
that is well formed and in range, yet describes another arm:

* **lengths in metres**: ``next = [0.48, 0.0]``. The arm's reach, Σ|next_i| over its links,
  is then a few "mm". A planar arm turned by linear actuators is not that small: a reach
  below :data:`MIN_REACH_MM` gets a warning that the lengths look like metres.
* **masses in grams**: ``mass_kg = 3000``. A link of length L (its |next|) is taken to weigh
  at most as much as a solid steel block as long as the link and half as wide and deep,
  ρ·L·(L/2)² with ρ = 7.85·10⁻⁶ kg/mm³ (217 kg for a 480 mm link, 106 t for a 6 m boom),
  and never less than :data:`MIN_MASS_LIMIT_KG`; an actuator by the same bound on the
  length of the link it turns. A heavier part gets a warning that its mass looks like
  grams (the value / 1000 is shown).

They are warnings: an unusual arm is possible, and the file is used as written. Numbers out
of any physical range are refused by the reader itself (:mod:`eodarm.model.arm`).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

from eodarm.errors import listing

__all__ = ["MIN_MASS_LIMIT_KG", "MIN_REACH_MM", "STEEL_KG_PER_MM3", "mass_limit_kg", "unit_hints"]

#: Below this reach (mm, the sum of the links' lengths) the lengths look like metres.
MIN_REACH_MM = 20.0
#: Density of steel, kg/mm³.
STEEL_KG_PER_MM3 = 7.85e-6
#: The mass bound of a part is never below this (kg): small links carry pins and bearings.
MIN_MASS_LIMIT_KG = 5.0


def mass_limit_kg(length_mm: float) -> float:
    """The most a part of a link ``length_mm`` long is taken to weigh: a solid steel block
    of that length, half as wide and half as deep (kg), at least :data:`MIN_MASS_LIMIT_KG`."""
    return max(STEEL_KG_PER_MM3 * length_mm * (length_mm / 2.0) ** 2, MIN_MASS_LIMIT_KG)


def unit_hints(arm: Any, name: str) -> list[str]:
    """Warn (``UserWarning``, one line each, at most two) when the lengths of ``arm`` look
    like metres or some of its masses like grams; return the messages.

    Parameters
    ----------
    arm : an :class:`~eodarm.model.arm.Arm` (read only: ``links`` with ``next`` and
        ``mass_kg``, ``actuators`` with ``mass_kg``).
    name : the file as messages name it.
    """
    lengths = [math.hypot(*link.next) for link in arm.links]
    reach = sum(lengths)
    out: list[str] = []
    if reach < MIN_REACH_MM:
        out.append(
            f"{name}: the arm is {reach:.4g} mm long in all (links "
            + ", ".join(f"{x:.3g}" for x in lengths[:3])
            + f"{' …' if len(lengths) > 3 else ''} mm): are the lengths in metres? "
            f"(write mm: {reach * 1000:.4g} mm)"
        )
    else:
        heavy = []
        for kind, parts in (("link", arm.links), ("actuator", arm.actuators)):
            for i, part in enumerate(parts):
                limit = mass_limit_kg(lengths[min(i, len(lengths) - 1)])
                if part.mass_kg > limit:
                    heavy.append(
                        f"{kind}[{i + 1}].mass_kg {part.mass_kg:.4g} kg (over {limit:.3g} kg, "
                        f"solid steel of its link's size): {part.mass_kg / 1000:.4g} kg?"
                    )
        if heavy:
            out.append(listing(f"{name}: masses that look like grams", heavy))
    for msg in out:
        warnings.warn(msg, UserWarning, stacklevel=3)
    return out
