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
    "UNLOADED",
    "Effect",
    "EffectKind",
    "Slot",
    "candidate_places",
    "effect_arrays",
    "effect_from_table",
    "kind_of",
    "known_effects",
    "param_from_theta",
    "split_effects",
    "theta_from_param",
    "with_arm_effects",
]

#: Where a gap (``actuator_play``, ``joint_clearance``) sits in the unloaded state:
#: ``"centred"`` (the whole offset appears under load, CONTRACT §4) or ``"taken_up"`` (the
#: unloaded forces already closed it; only the change of offset shows). docs/model.md §4.
UNLOADED = ("centred", "taken_up")


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
    #: The compiled core's code of this effect taken up when unloaded (gaps only).
    taken_up_code: int | None = None

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
        EffectKind("actuator_compliance", 0, "M", "stiffness_n_per_mm", "N/mm", True, False),
        EffectKind("mount_compliance", 1, "M", "stiffness_n_per_mm", "N/mm", True, False),
        EffectKind("actuator_play", 2, "M", "play_mm", "mm", False, True, 6),
        EffectKind("joint_clearance", 3, "O", "clearance_mm", "mm", False, True, 7),
        EffectKind("link_bending", 4, "L", "ei_n_mm2", "N·mm²", True, False),
        EffectKind("base_compliance", 5, "", "stiffness_nmm_per_rad", "N·mm/rad", True, False),
        EffectKind("actuator_friction", 8, "M", "friction_n", "N", False, True),
        EffectKind("joint_friction", 9, "O", "torque_nmm", "N·mm", False, True),
    )
}


def kind_of(name: str) -> EffectKind | None:
    """The catalogue's entry ``name``, or the user-written effect registered under it
    (:func:`eodarm.custom_effect`), or None."""
    kind = CATALOGUE.get(name)
    if kind is None and isinstance(name, str):
        from eodarm.model import custom

        kind = custom.lookup(name)
    return kind


def known_effects() -> list[str]:
    """Every effect name: the catalogue's, then the registered user-written ones."""
    from eodarm.model import custom

    return [*CATALOGUE, *custom.registered()]


def _unknown(name: object) -> str:
    return f"unknown effect '{name}'; known: {', '.join(known_effects())}"


def _kind(name: str) -> EffectKind:
    kind = kind_of(name)
    if kind is None:
        raise EffectError(_unknown(name))
    return kind


@dataclass(frozen=True, init=False)
class Effect:
    """One physical effect at one place: ``Effect("joint_clearance", "O3", clearance_mm=0.15)``.

    Parameters
    ----------
    name : one of :data:`CATALOGUE` (``actuator_compliance``, ``mount_compliance``,
        ``actuator_play``, ``joint_clearance``, ``link_bending``, ``base_compliance``) or a
        user-written effect registered with :func:`eodarm.custom_effect`.
    at : the place: ``M1``…``Mn`` (actuators), ``O1``…``On`` (joints), ``L1``…``Ln`` (links)
        or ``base``.
    unloaded : keyword, for ``actuator_play`` and ``joint_clearance`` only: ``"centred"``
        (default: the
        gap is centred in the unloaded state, so under load its whole offset appears, even at
        zero payload when the weights load it) or ``"taken_up"`` (the unloaded forces, i.e.
        self-weight, already closed it: only the change of the offset between the states
        shows, zero at zero payload). See docs/model.md §4.
    **params : exactly the effect's parameter, e.g. ``stiffness_n_per_mm=500.0``.
    """

    name: str
    at: str
    value: float
    unloaded: str = "centred"

    def __init__(self, name: str, at: str, **params: float | str) -> None:
        unloaded = params.pop("unloaded", "centred")
        kind = _kind(name)
        _place_index(kind, at)  # validates the place's form
        if unloaded not in UNLOADED:
            raise EffectError(
                f"effect {name}@{at}: unloaded must be 'centred' or 'taken_up', got {unloaded!r}"
            )
        if unloaded != "centred" and kind.taken_up_code is None:
            raise EffectError(
                f"effect {name}@{at}: only actuator_play and joint_clearance take "
                f"unloaded={unloaded!r}"
            )
        if set(params) != {kind.param}:
            raise EffectError(
                f"effect {name}@{at} takes exactly the parameter '{kind.param}', "
                f"got {sorted(params) or 'none'}"
            )
        raw = params[kind.param]
        try:
            value = float(raw)
        except (TypeError, ValueError, OverflowError):
            got = repr(raw) if len(repr(raw)) <= 40 else repr(raw)[:39] + "…"
            raise EffectError(
                f"effect {name}@{at}: {kind.param} must be a finite number, got {got}"
            ) from None
        why = kind.value_error(value)
        if why is not None:
            raise EffectError(f"effect {name}@{at}: {kind.param} {why}, got {raw!r}")
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "at", at)
        object.__setattr__(self, "value", value)
        object.__setattr__(self, "unloaded", unloaded)

    @classmethod
    def parse(cls, spec: str, **params: Any) -> Effect:
        """Build from ``"effect@place"`` (the CLI's ``--add`` form); a gap taken up when
        unloaded is ``"actuator_play@M1:taken_up"``."""
        name, at, unloaded = _split_spec(spec)
        if unloaded != "centred":
            params = {**params, "unloaded": unloaded}
        return cls(name, at, **params)

    @property
    def kind(self) -> EffectKind:
        return _kind(self.name)

    @property
    def param(self) -> str:
        """The parameter's name, e.g. ``"clearance_mm"``."""
        return self.kind.param

    @property
    def params(self) -> dict[str, float]:
        return {self.kind.param: self.value}

    @property
    def key(self) -> str:
        """``effect@place``, the form used by the CLI and the JSON output (one effect of a name
        per place, whatever its ``unloaded`` mode)."""
        return f"{self.name}@{self.at}"

    @property
    def label(self) -> str:
        """``effect@place`` for people: ``actuator_play@M1 (taken up)`` for a taken-up gap."""
        return self.key + (" (taken up)" if self.unloaded == "taken_up" else "")

    @property
    def code(self) -> int:
        """The compiled core's code of this effect (its mode included).

        Raises
        ------
        EffectError
            For a user-written effect: the core gets it as extra deformations.
        """
        kind = self.kind
        if kind.custom:
            raise EffectError(f"effect {self.key} is user-written: it has no code in the core")
        if self.unloaded == "taken_up" and kind.taken_up_code is not None:
            return kind.taken_up_code
        return kind.code

    def index(self, n: int) -> int:
        """0-based index of the place on an arm of ``n`` links (0 for the base)."""
        i = _place_index(self.kind, self.at)
        if i >= n:
            raise EffectError(f"effect {self.key}: the arm has only {n} links")
        return i

    def with_value(self, value: float) -> Effect:
        return Effect(self.name, self.at, unloaded=self.unloaded, **{self.kind.param: value})

    def __repr__(self) -> str:
        mode = "" if self.unloaded == "centred" else f", unloaded={self.unloaded!r}"
        return f"Effect({self.name!r}, {self.at!r}, {self.kind.param}={self.value!r}{mode})"

    @property
    def spec(self) -> str:
        """``effect@place``, or ``effect@place:taken_up`` for a taken-up gap: what ``--add``
        and :meth:`parse` read back."""
        return self.key + (":taken_up" if self.unloaded == "taken_up" else "")

    def to_table(self) -> dict[str, Any]:
        """The effect as an arm file's ``[[effect]]`` table (CONTRACT §7)."""
        table: dict[str, Any] = {"effect": self.name, "at": self.at, self.kind.param: self.value}
        if self.unloaded != "centred":
            table["unloaded"] = self.unloaded
        return table


def _split_spec(spec: str) -> tuple[str, str, str]:
    """``"effect@place[:taken_up]"`` → (effect, place, unloaded mode)."""
    if not isinstance(spec, str):
        raise EffectError(f"an effect is given as 'EFFECT@PLACE', got {spec!r}")
    name, sep, at = spec.strip().partition("@")
    if not sep:
        raise EffectError(f"'{spec}' is not of the form EFFECT@PLACE (e.g. joint_clearance@O3)")
    at, colon, mode = at.partition(":")
    if colon and mode not in UNLOADED:
        raise EffectError(f"'{spec}': the mode after ':' is one of {', '.join(UNLOADED)}")
    return name, at, mode or "centred"


def effect_from_table(table: Any) -> Effect:
    """An :class:`Effect` from an ``[[effect]]`` table's keys (``effect``, ``at``, parameter).

    Raises
    ------
    EffectError
        Naming the offending key (its ``key`` attribute) and what is wrong with it.
    """
    name = table.get("effect")
    kind = kind_of(name) if isinstance(name, str) else None
    if kind is None:
        raise EffectError(
            _unknown(name)
            if isinstance(name, str)
            else 'missing or not a string: the effect\'s name, e.g. "mount_compliance"',
            key="effect",
        )
    at = table.get("at")
    if not isinstance(at, str):
        raise EffectError('missing or not a string: the effect\'s place, e.g. "M2"', key="at")
    try:
        _place_index(kind, at)
    except EffectError as exc:
        raise EffectError(str(exc), key="at") from None
    unloaded = table.get("unloaded", "centred")
    if unloaded not in UNLOADED:
        raise EffectError(f"must be one of {', '.join(UNLOADED)}, got {unloaded!r}", key="unloaded")
    extra = sorted(set(table) - {"effect", "at", kind.param, "unloaded"})
    if extra:
        raise EffectError(
            f"{name} takes the parameter '{kind.param}', not {', '.join(extra)}", key=extra[0]
        )
    if kind.param not in table:
        raise EffectError(f"missing: {name}@{at}'s parameter", key=kind.param)
    raw = table[kind.param]
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        raise EffectError(f"must be a number, got {raw!r}", key=kind.param)
    if unloaded != "centred" and kind.taken_up_code is None:
        raise EffectError(f"{name} has no gap to take up", key="unloaded")
    try:
        return Effect(name, at, unloaded=unloaded, **{kind.param: raw})
    except EffectError as exc:
        raise EffectError(str(exc), key=kind.param) from None


def _place_index(kind: EffectKind, at: str) -> int:
    if kind.place_letter == "":
        if at != "base":
            raise EffectError(f"effect {kind.name} sits at 'base', not '{at}'")
        return 0
    letter = kind.place_letter
    ok = isinstance(at, str) and at[:1] == letter and at[1:].isascii() and at[1:].isdigit()
    if not (ok and int(at[1:]) >= 1):
        raise EffectError(f"effect {kind.name} sits at {letter}1…{letter}n, not '{at}'")
    return int(at[1:]) - 1


def candidate_places(name: str, n: int) -> list[str]:
    """Every place an effect can sit on an arm of ``n`` links."""
    kind = _kind(name)
    if kind.place_letter == "":
        return ["base"]
    return [f"{kind.place_letter}{i + 1}" for i in range(n)]


def effect_arrays(effects: Iterable[Effect], n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Effects as (codes, 0-based place indices, values) for the compiled core.

    The code is the catalogue's, or for a gap taken up when unloaded its ``taken_up_code``
    (6 ``actuator_play``, 7 ``joint_clearance``). Every effect is checked, but user-written
    ones (:mod:`eodarm.model.custom`) are not in the arrays: they reach the core as extra
    deformations (:func:`split_effects`), and every caller must pass them on so.

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
    builtin = [e for e in effs if not e.kind.custom]
    codes = np.array([e.code for e in builtin], dtype=np.int64)
    places = np.array([e.index(n) for e in builtin], dtype=np.int64)
    values = np.array([e.value for e in builtin], dtype=float)
    return codes, places, values


def with_arm_effects(arm_effects: Sequence[Effect], effects: Any) -> list[Effect]:
    """The model of a solve: an arm file's effects, then ``effects`` on top of them (the same
    effect@place given again replaces the file's, CONTRACT §7)."""
    given = as_effects(effects)
    keys = {e.key for e in given if isinstance(e, Effect)}
    return [e for e in arm_effects if e.key not in keys] + given


def split_effects(effects: Iterable[Effect]) -> tuple[list[Effect], list[Effect]]:
    """(catalogue effects, user-written effects), each in the given order."""
    effs = list(effects)
    for e in effs:
        if not isinstance(e, Effect):
            raise EffectError(f"effects must be eodarm.Effect values, got {e!r}")
    return [e for e in effs if not e.kind.custom], [e for e in effs if e.kind.custom]


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
    """An effect kind at a place, without a value: what a fit or a diagnosis varies.

    ``unloaded`` is a gap's mode (``"centred"`` or ``"taken_up"``, see :class:`Effect`); the
    ``key`` is the same for both, as a place has one gap of a kind.
    """

    name: str
    at: str
    unloaded: str = "centred"

    @classmethod
    def parse(cls, spec: str) -> Slot:
        """``"joint_clearance@O3"`` (or ``"joint_clearance@O3:taken_up"``) → Slot, validated
        against the catalogue."""
        try:
            name, at, unloaded = _split_spec(spec)
        except EffectError as exc:
            raise EodarmError(str(exc)) from None
        kind = kind_of(name)
        if kind is None:
            raise EodarmError(
                f"'{spec}' is not of the form EFFECT@PLACE with EFFECT one of "
                f"{', '.join(known_effects())}"
            )
        slot = cls(name, at, unloaded)
        slot.example  # noqa: B018 - validates place and mode
        return slot

    @classmethod
    def of(cls, effect: Effect | Slot | str) -> Slot:
        if isinstance(effect, Slot):
            return effect
        if isinstance(effect, Effect):
            return cls(effect.name, effect.at, effect.unloaded)
        return cls.parse(effect)

    @property
    def kind(self) -> EffectKind:
        return _kind(self.name)

    @property
    def key(self) -> str:
        return f"{self.name}@{self.at}"

    @property
    def example(self) -> Effect:
        """This slot with a valid value (checks the place and the mode)."""
        kind = self.kind
        value = float(getattr(kind, "start", 1.0)) if kind.custom else 1.0
        return self.effect(value)

    @property
    def spec(self) -> str:
        """What :meth:`parse` reads back (the key, with ``:taken_up`` for a taken-up gap)."""
        return self.key + (":taken_up" if self.unloaded == "taken_up" else "")

    @property
    def label(self) -> str:
        """For people: ``actuator_play@M1 (taken up)`` for a taken-up gap."""
        return self.key + (" (taken up)" if self.unloaded == "taken_up" else "")

    @property
    def code(self) -> int:
        """The compiled core's code of this slot (its mode included)."""
        return self.example.code

    def effect(self, value: float) -> Effect:
        """This slot with a value."""
        return Effect(self.name, self.at, unloaded=self.unloaded, **{self.kind.param: value})

    def index(self, n: int) -> int:
        return _slot_index(self, self.kind.place_letter, n)

    def __str__(self) -> str:
        return self.spec


@functools.lru_cache(maxsize=4096)
def _slot_index(slot: Slot, place_letter: str, n: int) -> int:
    # Every evaluation of a fit asks this of every slot; building an Effect each time to
    # validate the place showed in the profile of a diagnosis (~10 % of it). The place
    # letter is part of the key: a user effect registered again may sit elsewhere.
    return slot.example.index(n)


def theta_from_param(name: str, value: float) -> float:
    """θ of a physical parameter value (``inf`` stiffness → 0); a user-written effect's θ is
    its parameter."""
    if _kind(name).compliance_like:
        return 0.0 if math.isinf(value) else 1.0 / value
    return float(value)


def param_from_theta(name: str, theta: float) -> float:
    """Physical parameter of a θ (θ = 0 of a compliance → ``inf``)."""
    if _kind(name).compliance_like:
        return math.inf if theta <= 0 else 1.0 / theta
    return float(theta)
