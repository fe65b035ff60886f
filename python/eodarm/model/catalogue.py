"""The kinds of effect: the built-in catalogue and the registry of user-written kinds.

:mod:`eodarm.model.effects` (the :class:`~eodarm.model.effects.Effect` value, places, arrays)
and :mod:`eodarm.model.custom` (writing, checking and evaluating user effects) both stand on
this module, and it imports neither: :func:`lookup` is how ``Effect("my_effect", ...)`` finds
a kind registered by :func:`eodarm.custom_effect` without the effects importing the custom
ones (docs/architecture.md, "No cycles").
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

__all__ = [
    "APPLIES_THERE",
    "CATALOGUE",
    "ENTRY_POINT_GROUP",
    "OWN_SPRINGS",
    "THETA_MAX",
    "CustomKind",
    "EffectKind",
    "load_entry_points",
    "lookup",
    "registered",
    "unregister",
]


@dataclass(frozen=True)
class EffectKind:
    """One entry of the catalogue: where it may sit, its parameter and physical bounds.

    ``compliance_like`` says whether the deflection grows with ``1/parameter`` (springs,
    bending) rather than with the parameter itself (clearance, play). ``joint_kind`` is the
    kind of drive the effect's joint must have (``"linear"`` for the actuator's effects,
    ``"rotary"`` for the drive's), ``None`` where any joint will do.
    """

    name: str
    code: int
    place_letter: str  # "M", "O", "L" or "" for the base
    param: str
    unit: str
    compliance_like: bool
    allow_zero: bool
    #: The compiled core's code of this effect taken up when unloaded (gaps only).
    taken_up_code: int | None = None
    #: The kind of drive at the effect's joint ("linear", "rotary"), None: any.
    joint_kind: str | None = None

    @property
    def custom(self) -> bool:
        """Whether this is a user-written effect (:mod:`eodarm.model.custom`), computed in
        Python and given to the core as extra deformations."""
        return False

    @property
    def theta_bounds(self) -> tuple[float, float]:
        """The bounds of the fitted parameter θ (docs/diagnosis.md)."""
        return 0.0, THETA_MAX.get(self.name, math.inf)

    def value_error(self, value: float) -> str | None:
        """Why ``value`` is not a valid parameter of this effect (None when it is)."""
        if not math.isfinite(value) or value < 0 or (value == 0 and not self.allow_zero):
            return f"must be finite and {'>= 0' if self.allow_zero else '> 0'}"
        return None


CATALOGUE: dict[str, EffectKind] = {
    k.name: k
    for k in (
        EffectKind(
            "actuator_compliance", 0, "M", "stiffness_n_per_mm", "N/mm", True, False, None, "linear"
        ),
        EffectKind(
            "mount_compliance", 1, "M", "stiffness_n_per_mm", "N/mm", True, False, None, "linear"
        ),
        EffectKind("actuator_play", 2, "M", "play_mm", "mm", False, True, 6, "linear"),
        EffectKind("joint_clearance", 3, "O", "clearance_mm", "mm", False, True, 7),
        EffectKind("link_bending", 4, "L", "ei_n_mm2", "N·mm²", True, False),
        EffectKind("base_compliance", 5, "", "stiffness_nmm_per_rad", "N·mm/rad", True, False),
        EffectKind("actuator_friction", 8, "M", "friction_n", "N", False, True, None, "linear"),
        EffectKind("joint_friction", 9, "O", "torque_nmm", "N·mm", False, True),
        # Rotary drives (docs/model.md §10): at the joint O_i of a drive only.
        EffectKind(
            "drive_compliance",
            10,
            "O",
            "stiffness_nmm_per_rad",
            "N·mm/rad",
            True,
            False,
            None,
            "rotary",
        ),
        EffectKind("drive_backlash", 11, "O", "backlash_deg", "deg", False, True, 12, "rotary"),
        EffectKind("drive_friction", 13, "O", "torque_nmm", "N·mm", False, True, None, "rotary"),
    )
}

#: At a joint of the other kind, the effect that applies there instead of each kind-bound one:
#: what a refusal of an effect at the wrong kind of joint names.
APPLIES_THERE = {
    "actuator_compliance": "drive_compliance",
    "mount_compliance": "drive_compliance",
    "actuator_play": "drive_backlash",
    "actuator_friction": "drive_friction",
    "drive_compliance": "actuator_compliance",
    "drive_backlash": "actuator_play",
    "drive_friction": "actuator_friction",
}

#: The effects that replace a drive's own spring (the arm file's stiffness of an actuator's
#: body or a rotary drive's gear): at θ = 0 the body or gear is rigid, whereas θ = 0 of any
#: other spring is the effect absent.
OWN_SPRINGS = frozenset({"actuator_compliance", "drive_compliance"})

#: Upper bound of the fitted θ of the gaps (mm; degrees for a drive's backlash).
THETA_MAX = {"actuator_play": 5.0, "joint_clearance": 5.0, "drive_backlash": 5.0}


# ---------------------------------------------------------------------------- user-written kinds
#: The entry-point group through which installed packages register effects.
ENTRY_POINT_GROUP = "eodarm.effects"


@dataclass(frozen=True)
class CustomKind(EffectKind):
    """A registered user effect: its function, where it sits and its parameter's range.

    The parameter is fitted as it is (θ = the parameter), within ``[lower, upper]``;
    ``neutral`` is the value at which the effect is absent and ``start`` where a fit of it
    starts.
    """

    fn: Callable[..., Any] | None = None
    lower: float = 0.0
    upper: float | None = None
    start: float = 0.0
    neutral: float = 0.0

    @property
    def custom(self) -> bool:
        return True

    @property
    def theta_bounds(self) -> tuple[float, float]:
        return self.lower, math.inf if self.upper is None else self.upper

    def value_error(self, value: float) -> str | None:
        hi = "inf" if self.upper is None else f"{self.upper:g}"
        if not math.isfinite(value) or value < self.lower or value > self.theta_bounds[1]:
            return f"must be finite and within [{self.lower:g}, {hi}]"
        return None


_REGISTRY: dict[str, CustomKind] = {}
_ENTRY_POINTS_LOADED = False


def lookup(name: str) -> CustomKind | None:
    """The registered effect ``name``, or None; an unknown name first loads the installed
    packages' effects (the entry-point group, once)."""
    kind = _REGISTRY.get(name)
    if kind is None and not _ENTRY_POINTS_LOADED:
        load_entry_points()
        kind = _REGISTRY.get(name)
    return kind


def registered() -> list[str]:
    """The names of the registered effects, in the order they were registered."""
    return list(_REGISTRY)


def unregister(name: str) -> None:
    """Forget a registered effect (no error if there is none)."""
    _REGISTRY.pop(name, None)


def load_entry_points() -> list[str]:
    """Import every module of the entry-point group ``eodarm.effects`` (once per process).

    A package declares, in its ``pyproject.toml``::

        [project.entry-points."eodarm.effects"]
        friction = "mypackage.friction"

    and importing ``mypackage.friction`` registers its effects. An entry point that fails to
    load is skipped with a warning naming it. Returns the names of the entry points loaded.
    """
    global _ENTRY_POINTS_LOADED
    if _ENTRY_POINTS_LOADED:
        return []
    _ENTRY_POINTS_LOADED = True
    from importlib.metadata import entry_points

    done = []
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            ep.load()
        except Exception as exc:  # a broken plugin must not stop the others
            warnings.warn(
                f"entry point {ep.name} = {ep.value!r} of {ENTRY_POINT_GROUP} was not loaded: "
                f"{type(exc).__name__}: {' '.join(str(exc).split())}",
                RuntimeWarning,
                stacklevel=2,
            )
            continue
        done.append(ep.name)
    return done
