"""Writing an arm file: afresh, or over the text it came from so that the user's comments and
layout survive (tomlkit; docs/formats.md §2)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

__all__ = ["over_template", "render"]


def render(d: dict[str, Any]) -> str:
    """An arm's ``to_dict()`` as a fresh arm file: top keys, ``[base]``, ``[[link]]``,
    ``[[actuator]]``, ``[[effect]]`` and ``[fit]`` in that order."""
    lines = [f"name = {_toml_value(d['name'])}", f"g = {_toml_value(d['g'])}", "", "[base]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in d["base"].items()]
    for i, lk in enumerate(d["link"]):
        lines += ["", f"[[link]]  # link {i + 1}"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in lk.items()]
    for i, a in enumerate(d["actuator"]):
        lines += ["", f"[[actuator]]  # actuator {i + 1}"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in a.items()]
    for i, e in enumerate(d.get("effect", [])):
        lines += ["", f"[[effect]]  # effect {i + 1}"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in e.items()]
    if "fit" in d:
        lines += ["", "[fit]  # the fit that wrote the effects above"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in d["fit"].items()]
    return "\n".join(lines) + "\n"


def over_template(
    mine: dict[str, Any], template: str, normalise: Callable[[dict[str, Any]], dict[str, Any]]
) -> str | None:
    """``template`` (an arm file's text) with the effects and ``[fit]`` of ``mine`` (an arm's
    ``to_dict()``) written into it, its comments and layout kept; ``None`` when the template
    describes another arm. ``normalise`` turns the template's arm tables into the same form
    as ``mine`` (read and written again), or raises ``ValueError`` (an unreadable arm)."""
    import tomlkit
    from tomlkit.exceptions import TOMLKitError

    try:
        doc = tomlkit.parse(template)
        plain = doc.unwrap()
        theirs = normalise({k: v for k, v in plain.items() if k not in ("effect", "fit")})
    except (TOMLKitError, ValueError):  # ArmFileError is a ValueError
        return None
    if any(mine[k] != theirs[k] for k in ("name", "g", "base", "link", "actuator")):
        return None
    tables = mine.get("effect", [])
    existing = doc.get("effect")
    by_key: dict[str, Any] = {}
    if isinstance(existing, tomlkit.items.AoT):
        for t in existing:
            by_key.setdefault(f"{t.get('effect')}@{t.get('at')}", t)
    aot = tomlkit.aot()
    for new in tables:
        t = by_key.get(f"{new['effect']}@{new['at']}")
        if t is None:
            t = tomlkit.table()
        for key in [k for k in t if k not in new]:
            del t[key]  # a stale standard error or mark
        for key, val in new.items():
            t[key] = val
        aot.append(t)
    if "effect" in doc:
        del doc["effect"]
    if "fit" in doc:
        del doc["fit"]
    if tables:
        doc["effect"] = aot
    if "fit" in mine:
        fit = tomlkit.table()
        fit.comment("the fit that wrote the effects above")
        for key, val in mine["fit"].items():
            if isinstance(val, dict):
                inline = tomlkit.inline_table()
                inline.update(val)
                fit[key] = inline
            else:
                fit[key] = val
        doc["fit"] = fit
    text = tomlkit.dumps(doc)
    return text if text.endswith("\n") else text + "\n"


def _toml_value(v: Any) -> str:
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    x = float(v)
    if math.isinf(x):  # a rigid effect (infinite stiffness) or an unknown error
        return "inf" if x > 0 else "-inf"
    return repr(x)
