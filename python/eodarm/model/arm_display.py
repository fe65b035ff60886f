"""How an arm and its fitted model show in a shell or a notebook: a few lines (``repr``) or
a small table (``_repr_html_``), never the whole file (docs/python.md).

The arm is read by its attributes (``name``, ``links``, ``actuators``, ``effects``, ``fit``)
rather than imported, because :mod:`eodarm.model.arm` calls these functions.
"""

from __future__ import annotations

import math
from typing import Any

from eodarm import reprs
from eodarm import text as fmt

__all__ = ["arm_html", "arm_repr", "record_line", "record_repr"]


def _effect_line(effect: Any, stderr: float | None, mark: Any) -> str:
    unit = effect.kind.unit
    if mark is not None and mark.bound is not None and mark.limit is not None:
        side = "≥" if mark.bound == "lower" else "≤"
        return f"{effect.key} {side} {fmt.value(mark.limit, unit, 3)} (only a bound)"
    text = (
        fmt.value(effect.value, unit)
        if stderr is None
        else fmt.value_error(effect.value, stderr, unit)
    )
    return f"{effect.key} = {text}" + ("" if mark is None else " (not determined)")


def record_line(rec: Any) -> str:
    """The ``[fit]`` table in one line: parameters, χ²/dof, explained, data."""
    k = len(rec.parameters)
    parts = [f"{k} parameter{'s' * (k != 1)} with covariance"]
    if math.isfinite(rec.chi2_per_dof):
        parts.append(f"χ²/dof {fmt.value(rec.chi2_per_dof, digits=3)}")
    if rec.explained is True:
        parts.append("explains its data")
    elif rec.explained is False:
        dy = dict(rec.sigma_model).get("dy_mm")
        miss = "" if dy is None else f", σ_model(dy) {fmt.value(dy, 'mm', 2)}"
        parts.append(f"does not explain its data{miss}")
    if rec.data:
        parts.append(f"data {rec.data}")
    return "fit: " + ", ".join(parts)


def record_repr(rec: Any) -> str:
    return reprs.block("FitRecord " + record_line(rec).removeprefix("fit: "), rec.parameters)


def arm_repr(arm: Any) -> str:
    """``<Arm 'name' (file): n links, …`` then its effects and its fit, a line each."""
    where = "" if arm.source == "<dict>" else f" ({arm.source})"
    mass = sum(lk.mass_kg for lk in arm.links) + sum(a.mass_kg for a in arm.actuators)
    title = (
        f"Arm '{arm.name}'{where}: {arm.n} link{'s' * (arm.n != 1)}, "
        f"{fmt.value(mass, 'kg')} of links and actuators, g {fmt.value(arm.g, 'm/s²')}"
    )
    lines = [
        _effect_line(e, s, m)
        for e, s, m in zip(arm.effects, arm.stderrs(), arm.marks(), strict=True)
    ]
    if not lines:
        lines = ["no effects: the baseline model"]
    if arm.fit is not None:
        lines.append(record_line(arm.fit))
    return reprs.block(title, lines)


def arm_html(arm: Any) -> str:
    """The links and actuators in a table, then the effects and the fit as its caption."""
    rows = []
    for i, (lk, act) in enumerate(zip(arm.links, arm.actuators, strict=True)):
        length = math.hypot(*lk.next)
        rows.append(
            [
                f"{i + 1}",
                fmt.value(length, "mm"),
                fmt.value(lk.mass_kg, "kg"),
                fmt.value(getattr(act, "stiffness_n_per_mm", math.nan), "N/mm"),
                fmt.value(act.mass_kg, "kg"),
            ]
        )
    effects = [
        _effect_line(e, s, m)
        for e, s, m in zip(arm.effects, arm.stderrs(), arm.marks(), strict=True)
    ]
    caption = f"Arm '{arm.name}'" + (f"; effects: {'; '.join(effects)}" if effects else "")
    if arm.fit is not None:
        caption += "; " + record_line(arm.fit)
    headers = ["link", "length O→next", "link mass", "actuator stiffness", "actuator mass"]
    return reprs.html_table(headers, rows, caption)
