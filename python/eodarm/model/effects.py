"""The catalogue of physical effects (CONTRACT §4) and the :class:`Effect` value type."""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from eodarm.errors import EffectError, EodarmError

__all__ = [
    "CATALOGUE",
    "THETA_MAX",
    "Effect",
    "EffectKind",
    "Slot",
    "candidate_places",
    "effect_arrays",
    "param_from_theta",
    "theta_from_param",
]


@dataclass(frozen=True)
class EffectKind:
    """One entry of the catalogue: where it may sit, its parameter and physical bounds.

    ``compliance_like`` says whether the deflection grows with ``1/parameter`` (springs,
    bending) rather than with the parameter itself (clearance, play).
    """

    name: str
    code: int
    place_letter: str  # "M", "O", "L" or "" for the base
    param: str
    unit: str
    compliance_like: bool
    allow_zero: bool


CATALOGUE: dict[str, EffectKind] = {
    k.name: k
    for k in (
        EffectKind("actuator_compliance", 0, "M", "stiffness_n_per_mm", "N/mm", True, False),
        EffectKind("mount_compliance", 1, "M", "stiffness_n_per_mm", "N/mm", True, False),
        EffectKind("actuator_play", 2, "M", "play_mm", "mm", False, True),
        EffectKind("joint_clearance", 3, "O", "clearance_mm", "mm", False, True),
        EffectKind("link_bending", 4, "L", "ei_n_mm2", "N·mm²", True, False),
        EffectKind("base_compliance", 5, "", "stiffness_nmm_per_rad", "N·mm/rad", True, False),
    )
}


@dataclass(frozen=True, init=False)
class Effect:
    """One physical effect at one place: ``Effect("joint_clearance", "O3", clearance_mm=0.15)``.

    Parameters
    ----------
    name : one of :data:`CATALOGUE` (``actuator_compliance``, ``mount_compliance``,
        ``actuator_play``, ``joint_clearance``, ``link_bending``, ``base_compliance``).
    at : the place: ``M1``…``Mn`` (actuators), ``O1``…``On`` (joints), ``L1``…``Ln`` (links)
        or ``base``.
    **params : exactly the effect's parameter, e.g. ``stiffness_n_per_mm=500.0``.
    """

    name: str
    at: str
    value: float

    def __init__(self, name: str, at: str, **params: float) -> None:
        kind = CATALOGUE.get(name)
        if kind is None:
            raise EffectError(f"unknown effect '{name}'; known: {', '.join(CATALOGUE)}")
        _place_index(kind, at)  # validates the place's form
        if set(params) != {kind.param}:
            raise EffectError(
                f"effect {name}@{at} takes exactly the parameter '{kind.param}', "
                f"got {sorted(params) or 'none'}"
            )
        raw = params[kind.param]
        try:
            value = float(raw)
        except (TypeError, ValueError):
            raise EffectError(
                f"effect {name}@{at}: {kind.param} must be a number, got {raw!r}"
            ) from None
        if not math.isfinite(value) or value < 0 or (value == 0 and not kind.allow_zero):
            bound = ">= 0" if kind.allow_zero else "> 0"
            raise EffectError(
                f"effect {name}@{at}: {kind.param} must be finite and {bound}, got {raw!r}"
            )
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "at", at)
        object.__setattr__(self, "value", value)

    @classmethod
    def parse(cls, spec: str, **params: float) -> Effect:
        """Build from ``"effect@place"`` (the CLI's ``--add`` form)."""
        name, sep, at = spec.partition("@")
        if not sep:
            raise EffectError(f"'{spec}' is not of the form EFFECT@PLACE (e.g. joint_clearance@O3)")
        return cls(name, at, **params)

    @property
    def kind(self) -> EffectKind:
        return CATALOGUE[self.name]

    @property
    def param(self) -> str:
        """The parameter's name, e.g. ``"clearance_mm"``."""
        return self.kind.param

    @property
    def params(self) -> dict[str, float]:
        return {self.kind.param: self.value}

    @property
    def key(self) -> str:
        """``effect@place``, the form used by the CLI and the JSON output."""
        return f"{self.name}@{self.at}"

    def index(self, n: int) -> int:
        """0-based index of the place on an arm of ``n`` links (0 for the base)."""
        i = _place_index(self.kind, self.at)
        if i >= n:
            raise EffectError(f"effect {self.key}: the arm has only {n} links")
        return i

    def with_value(self, value: float) -> Effect:
        return Effect(self.name, self.at, **{self.kind.param: value})

    def __repr__(self) -> str:
        return f"Effect({self.name!r}, {self.at!r}, {self.kind.param}={self.value!r})"


def _place_index(kind: EffectKind, at: str) -> int:
    if kind.place_letter == "":
        if at != "base":
            raise EffectError(f"effect {kind.name} sits at 'base', not '{at}'")
        return 0
    letter = kind.place_letter
    if not (isinstance(at, str) and at[:1] == letter and at[1:].isdigit() and int(at[1:]) >= 1):
        raise EffectError(f"effect {kind.name} sits at {letter}1…{letter}n, not '{at}'")
    return int(at[1:]) - 1


def candidate_places(name: str, n: int) -> list[str]:
    """Every place an effect can sit on an arm of ``n`` links."""
    kind = CATALOGUE[name]
    if kind.place_letter == "":
        return ["base"]
    return [f"{kind.place_letter}{i + 1}" for i in range(n)]


def effect_arrays(effects: Iterable[Effect], n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Effects as (codes, 0-based place indices, values) for the compiled core.

    Raises
    ------
    EffectError
        On a place beyond the arm or the same effect twice at the same place.
    """
    effs: Sequence[Effect] = list(effects)
    seen: set[str] = set()
    for e in effs:
        if not isinstance(e, Effect):
            raise EffectError(f"effects must be eodarm.Effect values, got {e!r}")
        e.index(n)
        if e.key in seen:
            raise EffectError(f"effect {e.key} is given twice")
        seen.add(e.key)
    codes = np.array([e.kind.code for e in effs], dtype=np.int64)
    places = np.array([e.index(n) for e in effs], dtype=np.int64)
    values = np.array([e.value for e in effs], dtype=float)
    return codes, places, values


def as_effects(effects: Any) -> list[Effect]:
    """Accept None, one Effect, or an iterable of Effects."""
    if effects is None:
        return []
    if isinstance(effects, Effect):
        return [effects]
    return list(effects)


THETA_MAX = {"actuator_play": 5.0, "joint_clearance": 5.0}


@dataclass(frozen=True)
class Slot:
    """An effect kind at a place, without a value: what a fit or a diagnosis varies."""

    name: str
    at: str

    @classmethod
    def parse(cls, spec: str) -> Slot:
        """``"joint_clearance@O3"`` → Slot (validated against the catalogue)."""
        name, sep, at = spec.partition("@")
        if not sep or name not in CATALOGUE:
            raise EodarmError(
                f"'{spec}' is not of the form EFFECT@PLACE with EFFECT one of "
                f"{', '.join(CATALOGUE)}"
            )
        kind = CATALOGUE[name]
        Effect(name, at, **{kind.param: 1.0})  # validates the place's form
        return cls(name, at)

    @classmethod
    def of(cls, effect: Effect | Slot | str) -> Slot:
        if isinstance(effect, Slot):
            return effect
        if isinstance(effect, Effect):
            return cls(effect.name, effect.at)
        return cls.parse(effect)

    @property
    def kind(self) -> EffectKind:
        return CATALOGUE[self.name]

    @property
    def key(self) -> str:
        return f"{self.name}@{self.at}"

    def index(self, n: int) -> int:
        return _slot_index(self.name, self.at, n)

    def __str__(self) -> str:
        return self.key


@functools.lru_cache(maxsize=4096)
def _slot_index(name: str, at: str, n: int) -> int:
    # Every evaluation of a fit asks this of every slot; building an Effect each time to
    # validate the place showed in the profile of a diagnosis (~10 % of it).
    return Effect(name, at, **{CATALOGUE[name].param: 1.0}).index(n)


def theta_from_param(name: str, value: float) -> float:
    """θ of a physical parameter value (``inf`` stiffness → 0)."""
    if CATALOGUE[name].compliance_like:
        return 0.0 if math.isinf(value) else 1.0 / value
    return float(value)


def param_from_theta(name: str, theta: float) -> float:
    """Physical parameter of a θ (θ = 0 of a compliance → ``inf``)."""
    if CATALOGUE[name].compliance_like:
        return math.inf if theta <= 0 else 1.0 / theta
    return float(theta)
