"""User-written effects (docs/custom-effects.md): the registry, the state they read, their checks.

A user describes a mechanism the catalogue lacks as a Python function of the arm's statics
and registers it with :func:`custom_effect`::

    @eodarm.custom_effect("actuator_friction", places="M", parameter="friction_n",
                          lower=0.0, start=10.0)
    def actuator_friction(state, i, friction_n):
        dF = state.force_n[:, i] - state.force0_n[:, i]
        k = state.arm.actuators[i].stiffness_n_per_mm
        return {"actuator_mm": np.sign(dF) * np.minimum(np.abs(dF), friction_n) / k}

From then on ``actuator_friction`` is an effect like the built-in ones: ``eodarm.Effect``,
``[[effect]]`` tables, ``--add``, solve, fit, diagnose, sweep. The function is called once per
place and per evaluation, vectorised over the N states of an :class:`EffectState` (the
undeformed statics of both states, which do not depend on any effect's parameter). What it
returns (:data:`DEFORMATION_KEYS`) becomes the solver's extra deformations
(``solve(extra=...)``, docs/model.md §4) and the pose is closed exactly with them.

Everything a user function can get wrong (it raises; returns something that is not a dict,
an unknown key, an array of the wrong shape or type, a non-finite value) is refused with one
line naming the effect, its place and the key (:class:`~eodarm.errors.CustomEffectError`).

Installed packages register effects through the entry-point group ``eodarm.effects``: each
entry point names a module whose import registers them. The group is read once, lazily: when
a name is looked up that nobody has registered, or when the command line starts a command
that takes effects (never at ``import eodarm``).
"""

from __future__ import annotations

import hashlib
import importlib.util
import math
import re
import sys
import traceback
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
import numpy.typing as npt

from eodarm.errors import CustomEffectError, EffectError
from eodarm.model.catalogue import (
    _REGISTRY,
    CATALOGUE,
    ENTRY_POINT_GROUP,
    CustomKind,
    load_entry_points,
    lookup,
    registered,
    unregister,
)

if TYPE_CHECKING:
    from eodarm.model.arm import Arm
    from eodarm.model.effects import Effect

__all__ = [
    "DEFORMATION_KEYS",
    "ENTRY_POINT_GROUP",
    "CustomKind",
    "EffectState",
    "custom_effect",
    "deformation",
    "extras_of",
    "load_entry_points",
    "load_file",
    "lookup",
    "registered",
    "unregister",
]

FloatArray = npt.NDArray[np.float64]
F = TypeVar("F", bound=Callable[..., Any])

#: What a user function may return, each key optional: key → (the solver's extra
#: deformation it adds to, the shape of one state's value). All in the global frame, mm and
#: rad, applied at the effect's place i (docs/custom-effects.md):
#:
#: * ``actuator_mm`` (N,): pin-to-pin length change of actuator i that its own sensor
#:   (``dlK_mm``) sees; shortening negative;
#: * ``actuator_unseen_mm`` (N,): one its sensor does not see (a mount, a play);
#: * ``joint_offset_mm`` (N, 2): offset of link i's pin centre at joint O_i;
#: * ``base_tilt_rad`` (N,): chassis tilt about the base pivot, counter-clockwise positive;
#: * ``measure_mm`` (N, 2): displacement of the measure point that moves no link;
#: * ``joint_turn_rad`` (N,): at a joint with a rotary drive, an extra turn of link i relative
#:   to body i−1, counter-clockwise positive, added to the gear's own.
DEFORMATION_KEYS: dict[str, tuple[str, tuple[int, ...]]] = {
    "actuator_mm": ("extra_seen_mm", ()),
    "actuator_unseen_mm": ("extra_unseen_mm", ()),
    "joint_offset_mm": ("extra_joint_mm", (2,)),
    "base_tilt_rad": ("extra_tilt_rad", ()),
    "measure_mm": ("extra_measure_mm", (2,)),
    "joint_turn_rad": ("extra_turn_rad", ()),
}
#: The keys that belong to one kind of joint (docs/model.md §10): what a user function may
#: return at place i only when joint i is of that kind.
KEY_KIND = {"actuator_mm": "linear", "actuator_unseen_mm": "linear", "joint_turn_rad": "rotary"}

#: ``places=`` of :func:`custom_effect` → the place letter of :class:`EffectKind`.
PLACES = {"M": "M", "O": "O", "L": "L", "base": ""}

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
#: Keys of an ``[[effect]]`` table that a parameter may not be called.
_RESERVED = {"effect", "at", "unloaded", "stderr"}


# ---------------------------------------------------------------------------- registering
def custom_effect(
    name: str,
    places: str,
    *,
    parameter: str,
    lower: float = 0.0,
    upper: float | None = None,
    start: float | None = None,
    neutral: float | None = None,
    unit: str = "",
) -> Callable[[F], F]:
    """Register a user-written effect (docs/custom-effects.md); use as a decorator.

    Parameters
    ----------
    name : the effect's name, as in ``Effect(name, ...)``, ``--add name@M2`` and
        ``[[effect]]`` tables: letters, digits and ``_``, not a built-in effect's name.
        Registering a name again replaces the earlier effect.
    places : ``"M"`` (actuators M1…Mn), ``"O"`` (joints O1…On), ``"L"`` (links L1…Ln) or
        ``"base"``.
    parameter : the name of its one parameter, e.g. ``"friction_n"``.
    lower, upper : the parameter's physical range (``upper=None``: unbounded); fits stay in it.
    start : where a fit of the effect starts (default: ``neutral``).
    neutral : the value at which the effect is absent (default: ``lower``).
    unit : the parameter's unit, for tables and reports.

    The decorated function ``fn(state: EffectState, i: int, value: float) -> dict`` gets
    the undeformed statics of N states, the 0-based index i of its place (0 for the base)
    and the parameter's value, and returns deformations over all N states: any of
    :data:`DEFORMATION_KEYS`. It is returned unchanged.

    Raises
    ------
    EffectError
        On a bad name (or a built-in one), place kind, parameter name or range, or a
        decorated object that is not callable.
    """
    if not isinstance(name, str) or not _NAME.match(name):
        raise EffectError(
            f"custom effect {name!r}: a name is letters, digits and '_', e.g. 'actuator_friction'"
        )
    if name in CATALOGUE:
        raise EffectError(
            f"custom effect {name!r}: the name is a built-in effect's; choose another"
        )
    if places not in PLACES:
        raise EffectError(
            f"custom effect {name}: places must be 'M', 'O', 'L' or 'base', got {places!r}"
        )
    if not isinstance(parameter, str) or not _NAME.match(parameter) or parameter in _RESERVED:
        raise EffectError(
            f"custom effect {name}: parameter must be a name like 'friction_n' (not one of "
            f"{', '.join(sorted(_RESERVED))}), got {parameter!r}"
        )
    lo = _number(name, "lower", lower)
    hi = None if upper is None else _number(name, "upper", upper)
    if hi is not None and not hi > lo:
        raise EffectError(f"custom effect {name}: upper {hi:g} must exceed lower {lo:g}")
    nu = lo if neutral is None else _number(name, "neutral", neutral)
    s0 = nu if start is None else _number(name, "start", start)
    for what, x in (("neutral", nu), ("start", s0)):
        if x < lo or (hi is not None and x > hi):
            raise EffectError(
                f"custom effect {name}: {what} {x:g} is outside [{lo:g}, "
                f"{'inf' if hi is None else f'{hi:g}'}]"
            )
    if not isinstance(unit, str):
        raise EffectError(f"custom effect {name}: unit must be a string, got {unit!r}")

    def register(fn: F) -> F:
        if not callable(fn):
            raise EffectError(f"custom effect {name}: {fn!r} is not a function")
        _REGISTRY[name] = CustomKind(
            name=name,
            code=-1,
            place_letter=PLACES[places],
            param=parameter,
            unit=unit,
            compliance_like=False,
            allow_zero=True,
            fn=fn,
            lower=lo,
            upper=hi,
            start=s0,
            neutral=nu,
        )
        return fn

    return register


def _number(name: str, what: str, x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError, OverflowError):
        raise EffectError(f"custom effect {name}: {what} must be a number, got {x!r}") from None
    if not math.isfinite(v):
        raise EffectError(f"custom effect {name}: {what} must be finite, got {x!r}")
    return v


def load_file(path: str | Path) -> None:
    """Run a Python file that registers effects (``eodarm ... --effects FILE.py``).

    Raises
    ------
    CustomEffectError
        In one line when the file is missing or fails to run (with the line at fault); the
        original exception is chained.
    """
    p = Path(path)
    if not p.is_file():
        raise CustomEffectError(f"effects file {path}: no such file")
    digest = hashlib.sha1(str(p.resolve()).encode()).hexdigest()[:12]
    module_name = f"eodarm_user_effects_{re.sub(r'[^0-9A-Za-z_]', '_', p.stem)}_{digest}"
    spec = importlib.util.spec_from_file_location(module_name, p)
    if spec is None or spec.loader is None:
        raise CustomEffectError(f"effects file {path}: not a Python file")
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        sys.modules.pop(module_name, None)
        if isinstance(exc, CustomEffectError | EffectError):
            raise CustomEffectError(f"effects file {path}: {exc}") from exc
        where = ""
        if not isinstance(exc, SyntaxError):
            lines = [f.lineno for f in traceback.extract_tb(exc.__traceback__) if _same(f, p)]
            where = f" (line {lines[-1]})" if lines else ""
        text = " ".join(str(exc).split())
        raise CustomEffectError(
            f"effects file {path}: {type(exc).__name__}: {text}{where}"
        ) from exc


def _same(frame: traceback.FrameSummary, path: Path) -> bool:
    try:
        return Path(frame.filename).resolve() == path.resolve()
    except OSError:  # pragma: no cover - a frame of a file that went away
        return False


# ---------------------------------------------------------------------------- the state
@dataclass(frozen=True, eq=False)
class EffectState:
    """What a user effect reads: the undeformed statics of N states (docs/model.md §1).

    Attributes
    ----------
    arm : the arm.
    alpha_deg : (N, n) unloaded absolute link angles, degrees.
    mass_kg : (N,) payload mass, kg (for a payload given as a force, −F_y/g).
    force_n, force0_n : (N, n) loaded / unloaded actuator forces, N, compression positive;
        NaN at a joint with a rotary drive.
    reaction_n, reaction0_n : (N, n, 2) loaded / unloaded joint reactions, N, global: the
        force of body i−1 on link i at O_i.
    length_mm : (N, n) unloaded pin-to-pin actuator lengths, mm; NaN at a rotary joint.
    payload_n : (N, 2) the payload force at the load point, N, global.
    self_weight : whether both states carry the weights.
    torque_nmm, torque0_nmm : (N, n) loaded / unloaded drive torques on link i, N·mm,
        counter-clockwise positive; NaN at a joint with a linear actuator (all NaN on an arm
        of linear actuators).

    The arrays are read-only: the same state serves every evaluation of a fit.
    """

    arm: Arm
    alpha_deg: FloatArray
    mass_kg: FloatArray
    force_n: FloatArray
    force0_n: FloatArray
    reaction_n: FloatArray
    reaction0_n: FloatArray
    length_mm: FloatArray
    payload_n: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    self_weight: bool = True
    torque_nmm: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    torque0_nmm: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))

    def __post_init__(self) -> None:
        # a state built without torques (an arm of linear actuators) has NaN torques
        for key in ("torque_nmm", "torque0_nmm"):
            if getattr(self, key).shape != self.force_n.shape:
                object.__setattr__(self, key, _frozen(np.full(self.force_n.shape, np.nan)))

    @classmethod
    def from_statics(
        cls,
        arm: Arm,
        alpha_deg: npt.ArrayLike,
        payload_n: npt.ArrayLike,
        statics: Mapping[str, npt.ArrayLike],
        self_weight: bool = True,
    ) -> EffectState:
        """The state of N poses from a statics result (``force_n``, ``force0_n``,
        ``reaction_n``, ``reaction0_n``, ``length_mm``, and ``torque_nmm``, ``torque0_nmm``
        where it has them, as :func:`eodarm.solver.statics`)."""
        payload = _frozen(payload_n)
        nan = np.full(np.shape(statics["force_n"]), np.nan)

        def get(key: str) -> FloatArray:
            return _frozen(statics[key] if key in statics else nan)

        return cls(
            arm=arm,
            alpha_deg=_frozen(alpha_deg),
            mass_kg=_frozen(-payload[:, 1] / arm.g),
            force_n=get("force_n"),
            force0_n=get("force0_n"),
            reaction_n=get("reaction_n"),
            reaction0_n=get("reaction0_n"),
            length_mm=get("length_mm"),
            payload_n=payload,
            self_weight=bool(self_weight),
            torque_nmm=get("torque_nmm"),
            torque0_nmm=get("torque0_nmm"),
        )

    @property
    def n_states(self) -> int:
        """N, the number of states."""
        return int(self.alpha_deg.shape[0])

    def rows(self, rows: npt.NDArray[np.intp]) -> EffectState:
        """The state of a subset of the rows."""
        return EffectState(
            arm=self.arm,
            alpha_deg=_frozen(self.alpha_deg[rows]),
            mass_kg=_frozen(self.mass_kg[rows]),
            force_n=_frozen(self.force_n[rows]),
            force0_n=_frozen(self.force0_n[rows]),
            reaction_n=_frozen(self.reaction_n[rows]),
            reaction0_n=_frozen(self.reaction0_n[rows]),
            length_mm=_frozen(self.length_mm[rows]),
            payload_n=_frozen(self.payload_n[rows]),
            self_weight=self.self_weight,
            torque_nmm=_frozen(self.torque_nmm[rows]),
            torque0_nmm=_frozen(self.torque0_nmm[rows]),
        )


def _frozen(x: npt.ArrayLike) -> FloatArray:
    a = np.array(x, dtype=float)  # a copy: the caller's array stays writable and unshared
    a.setflags(write=False)
    return a


# ---------------------------------------------------------------------------- calling
def deformation(
    kind: CustomKind, at: str, i: int, value: float, state: EffectState
) -> dict[str, FloatArray]:
    """Call a user function once for N states and check what it returns.

    Returns the deformations it gave, by key of :data:`DEFORMATION_KEYS`, as float arrays of
    the documented shapes.

    Raises
    ------
    CustomEffectError
        One line naming ``effect@place`` and the key: the function raised (the exception is
        chained), returned no dict, an unknown key, a key that does not fit the kind of joint
        ``i`` (``actuator_mm`` or ``actuator_unseen_mm`` at a rotary drive, ``joint_turn_rad``
        at a linear actuator), an array of the wrong shape or type, or a non-finite value
        (with the first bad row).
    """
    label = f"custom effect {kind.name}@{at}"
    fn = kind.fn
    if fn is None:  # pragma: no cover - every registered kind has one
        raise CustomEffectError(f"{label}: no function")
    try:
        out = fn(state, i, float(value))
    except Exception as exc:
        text = " ".join(str(exc).split())
        raise CustomEffectError(
            f"{label}: the function raised {type(exc).__name__}" + (f": {text}" if text else "")
        ) from exc
    if not isinstance(out, Mapping):
        raise CustomEffectError(
            f"{label}: the function returned {type(out).__name__}, expected a dict of "
            f"deformations ({', '.join(DEFORMATION_KEYS)})"
        )
    rows = state.n_states
    got: dict[str, FloatArray] = {}
    for key, val in out.items():
        if key not in DEFORMATION_KEYS:
            raise CustomEffectError(
                f"{label}: unknown key {key!r}; the keys are {', '.join(DEFORMATION_KEYS)}"
            )
        if val is None:
            continue
        need = KEY_KIND.get(key)
        have = state.arm.kinds[i] if i < state.arm.n else None
        if need is not None and have != need:
            other = "joint_turn_rad" if need == "linear" else "actuator_mm"
            raise CustomEffectError(
                f"{label}: {key!r} is for a joint with a {need} "
                f"{'actuator' if need == 'linear' else 'drive'}; joint {i + 1} is turned by a "
                f"{have} {'actuator' if have == 'linear' else 'drive'} (use {other!r} there)"
            )
        shape = (rows, *DEFORMATION_KEYS[key][1])
        raw = np.asarray(val) if not isinstance(val, str | bytes) else None
        if raw is None or raw.dtype.kind not in "iuf":
            what = type(val).__name__ if raw is None else f"{type(val).__name__} of {raw.dtype}"
            raise CustomEffectError(f"{label}: {key!r} is a {what}, expected float numbers")
        if raw.shape != shape:
            raise CustomEffectError(f"{label}: {key!r} has shape {raw.shape}, expected {shape}")
        a = np.asarray(raw, dtype=float)
        bad = ~np.isfinite(a.reshape(rows, -1)).all(axis=1)
        if bad.any():
            r = int(np.flatnonzero(bad)[0])
            raise CustomEffectError(
                f"{label}: {key!r} is not finite in pose row {r} ({a[r].tolist()})"
            )
        got[key] = a
    return got


def place_extras(got: Mapping[str, FloatArray], i: int, rows: int, n: int) -> dict[str, FloatArray]:
    """One effect's deformations at place i as whole-arm extra deformations (the solver's
    ``extra=`` keys, docs/model.md §4)."""
    out: dict[str, FloatArray] = {}
    for key, a in got.items():
        extra = DEFORMATION_KEYS[key][0]
        if extra in ("extra_seen_mm", "extra_unseen_mm", "extra_turn_rad"):
            full = np.zeros((rows, n))
            full[:, i] = a
        elif extra == "extra_joint_mm":
            full = np.zeros((rows, n, 2))
            full[:, i] = a
        else:
            full = a.copy()
        out[extra] = full
    return out


def add_extras(*parts: Mapping[str, FloatArray | None] | None) -> dict[str, FloatArray]:
    """The sum of extra-deformation dicts (absent or None keys count as zero)."""
    out: dict[str, FloatArray] = {}
    for part in parts:
        for key, a in (part or {}).items():
            if a is None:
                continue
            out[key] = out[key] + a if key in out else np.array(a, dtype=float)
    return out


def extras_of(effects: Sequence[Effect], state: EffectState) -> dict[str, FloatArray]:
    """The summed extra deformations of custom effects at their values (each function
    called once, vectorised over the state's N rows)."""
    n, rows = state.arm.n, state.n_states
    parts = []
    for e in effects:
        kind = e.kind
        if not isinstance(kind, CustomKind):  # pragma: no cover - callers split first
            raise EffectError(f"effect {e.key} is not a custom effect")
        i = e.index(n)
        parts.append(place_extras(deformation(kind, e.at, i, e.value, state), i, rows, n))
    return add_extras(*parts)
