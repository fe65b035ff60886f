"""The catalogue of physical effects (docs/model.md §4) and the :class:`Effect` value type."""

from __future__ import annotations

import functools
import math
import numbers
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from eodarm.errors import EffectError, EodarmError
from eodarm.model import catalogue
from eodarm.model.catalogue import CATALOGUE, THETA_MAX, EffectKind

__all__ = [
    "CATALOGUE",
    "GAPS",
    "THETA_MAX",
    "UNLOADED",
    "Effect",
    "EffectKind",
    "Slot",
    "candidate_places",
    "check_kinds",
    "effect_arrays",
    "effect_from_table",
    "kind_mismatch",
    "kind_of",
    "known_effects",
    "param_from_theta",
    "split_effects",
    "theta_from_param",
    "with_arm_effects",
]

#: Where a gap (``actuator_play``, ``joint_clearance``, ``drive_backlash``) sits in the
#: unloaded state: ``"centred"`` (the whole offset appears under load, docs/model.md §4) or
#: ``"taken_up"`` (the unloaded forces already closed it; only the change of offset shows).
UNLOADED = ("centred", "taken_up")
#: The gaps: the effects that take the ``unloaded`` mode.
GAPS = tuple(k.name for k in CATALOGUE.values() if k.taken_up_code is not None)


def kind_of(name: str) -> EffectKind | None:
    """The catalogue's entry ``name``, or the user-written effect registered under it
    (:func:`eodarm.custom_effect`), or None."""
    kind = CATALOGUE.get(name)
    if kind is None and isinstance(name, str):
        kind = catalogue.lookup(name)
    return kind


def known_effects() -> list[str]:
    """Every effect name: the catalogue's, then the registered user-written ones."""
    return [*CATALOGUE, *catalogue.registered()]


def _unknown(name: object) -> str:
    known = known_effects()
    return f"unknown effect '{name}'{did_you_mean(str(name), known)}; known: {', '.join(known)}"


def did_you_mean(name: str, known: Iterable[str], cutoff: float = 0.6) -> str:
    """``": did you mean 'x'?"`` for the closest of ``known`` to a misspelled ``name``
    (difflib's ratio ≥ ``cutoff``, case ignored), or nothing."""
    import difflib

    lower = {k.lower(): k for k in known}
    close = difflib.get_close_matches(name.strip().lower(), list(lower), n=1, cutoff=cutoff)
    return f" (did you mean '{lower[close[0]]}'?)" if close else ""


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
        ``actuator_play``, ``joint_clearance``, ``link_bending``, ``base_compliance``,
        ``actuator_friction``, ``joint_friction``, ``drive_compliance``, ``drive_backlash``,
        ``drive_friction``) or a user-written effect registered with
        :func:`eodarm.custom_effect`.
    at : the place: ``M1``…``Mn`` (actuators), ``O1``…``On`` (joints), ``L1``…``Ln`` (links)
        or ``base``.
    unloaded : keyword, for the gaps ``actuator_play``, ``joint_clearance`` and
        ``drive_backlash`` only: ``"centred"`` (default: the
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
                f"effect {name}@{at}: only {', '.join(GAPS)} take unloaded={unloaded!r}"
            )
        if set(params) != {kind.param}:
            raise EffectError(
                f"effect {name}@{at} takes exactly the parameter '{kind.param}', "
                f"got {sorted(params) or 'none'}"
            )
        raw = params[kind.param]
        try:
            num = raw[()] if isinstance(raw, np.ndarray) and raw.ndim == 0 else raw
            if isinstance(num, (bool, np.bool_)) or not isinstance(num, numbers.Real):
                # True is not 1.0 mm, "0.1" not a number, 0.1+0j not a real one (as in arm files)
                raise TypeError
            value = float(num)
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
        """The effect as an arm file's ``[[effect]]`` table (docs/formats.md §2)."""
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
        raise EffectError(
            f"effect {kind.name} sits at {letter}1…{letter}n, not '{at}'{_place_hint(kind, at)}"
        )
    return int(at[1:]) - 1


#: What sits at each kind of place (the letter of its name).
_PLACE_WORD = {"M": "an actuator", "O": "a joint", "L": "a link"}


def _place_hint(kind: EffectKind, at: object) -> str:
    """What was probably meant by a wrong place: ``o3`` for O3, or, for a place of another
    kind (``joint_clearance@M2``), the effects that sit there."""
    if not isinstance(at, str):
        return ""
    text = at.strip()
    num = text[1:]
    if text[:1].upper() == kind.place_letter and num.isascii() and num.isdigit() and int(num):
        return f" (did you mean '{kind.place_letter}{int(num)}'?)"
    word = _PLACE_WORD.get(text[:1].upper())
    if word and num.isascii() and num.isdigit():
        there = [k.name for k in CATALOGUE.values() if k.place_letter == text[:1].upper()]
        return (
            f" ({text} is {word}: did you mean {kind.place_letter}{int(num)}, or "
            f"{' / '.join(there)}@{text.upper()}?)"
        )
    return ""


def candidate_places(name: str, n: int, kinds: Sequence[str] | None = None) -> list[str]:
    """Every place an effect can sit on an arm of ``n`` links; with ``kinds`` (each joint's
    ``"linear"`` or ``"rotary"``, :attr:`Arm.kinds`) only the joints of the effect's kind."""
    kind = _kind(name)
    if kind.place_letter == "":
        return ["base"]
    need = kind.joint_kind
    return [
        f"{kind.place_letter}{i + 1}"
        for i in range(n)
        if need is None or kinds is None or kinds[i] == need
    ]


#: How a refusal names a joint's kind of drive.
_KIND_WORD = {"linear": "a linear actuator", "rotary": "a rotary drive"}


def kind_mismatch(effect: Effect, kinds: Sequence[str]) -> str | None:
    """Why ``effect`` cannot sit at its joint, given each joint's kind of drive
    (:attr:`Arm.kinds`), naming the effect and what applies there; None when it can."""
    kind = effect.kind
    need = kind.joint_kind
    if need is None:
        return None
    i = effect.index(len(kinds))
    have = kinds[i]
    if have == need:
        return None
    there = catalogue.APPLIES_THERE[effect.name]
    letter = CATALOGUE[there].place_letter
    return (
        f"effect {effect.key}: joint {i + 1} is turned by {_KIND_WORD.get(have, have)}, not "
        f"{_KIND_WORD[need]}: use {there}@{letter}{i + 1} there"
    )


def check_kinds(effects: Iterable[Effect], kinds: Sequence[str]) -> None:
    """Refuse an effect at a joint of the wrong kind of drive (an actuator's effect at a
    rotary drive, a drive's at a linear actuator), naming the effect, its joint and the effect
    that applies there.

    Raises
    ------
    EffectError
        On the first such effect.
    """
    for e in effects:
        why = kind_mismatch(e, kinds)
        if why is not None:
            raise EffectError(why)


def effect_arrays(
    effects: Iterable[Effect], n: int, kinds: Sequence[str] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Effects as (codes, 0-based place indices, values) for the compiled core.

    The code is the catalogue's, or for a gap taken up when unloaded its ``taken_up_code``
    (6 ``actuator_play``, 7 ``joint_clearance``, 12 ``drive_backlash``). Every effect is
    checked, but user-written ones (:mod:`eodarm.model.custom`) are not in the arrays: they
    reach the core as extra deformations (:func:`split_effects`), and every caller must pass
    them on so. With ``kinds`` (:attr:`Arm.kinds`), an effect at a joint of the wrong kind
    of drive is refused too (:func:`check_kinds`).

    Raises
    ------
    EffectError
        On a place beyond the arm, the same effect twice at the same place, or (``kinds``)
        an effect at a joint of the wrong kind.
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
    if kinds is not None:
        check_kinds(effs, kinds)
    builtin = [e for e in effs if not e.kind.custom]
    codes = np.array([e.code for e in builtin], dtype=np.int64)
    places = np.array([e.index(n) for e in builtin], dtype=np.int64)
    values = np.array([e.value for e in builtin], dtype=float)
    return codes, places, values


def with_arm_effects(arm_effects: Sequence[Effect], effects: Any) -> list[Effect]:
    """The model of a solve: an arm file's effects, then ``effects`` on top of them (the same
    effect@place given again replaces the file's, docs/formats.md §2)."""
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
            known = known_effects()
            raise EodarmError(
                f"'{spec}': unknown effect '{name}'{did_you_mean(name, known)}; known: "
                f"{', '.join(known)} (user-written effects come with --effects FILE.py)"
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
