"""Arm description: loading, validating and exporting the arm file of docs/formats.md §1.

Each joint is turned by a linear actuator (:class:`Actuator`, the default) or by a rotary
drive at the joint (:class:`RotaryDrive`, a motor and gearbox), in any mix
(docs/model.md §10). An :class:`Arm` is immutable and always valid: every constructor goes through
:meth:`Arm.from_dict`, which checks every key before anything is built, so nothing
half-loaded is ever used.

An arm file may carry a fitted model (docs/formats.md §2): ``[[effect]]`` tables (effect, place,
parameter, optional standard error) become :attr:`Arm.effects`, and an optional ``[fit]``
table keeps what the fit knew: the covariance of the fitted parameters, the data it was
fitted to (name and SHA-256) and its χ²/dof (:class:`FitRecord`).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from eodarm.errors import ArgumentTypeError, ArmFileError, InputError, show, show_source
from eodarm.model.arm_check import (
    BASE_KEYS,
    LINK_KEYS,
    MAX_FILE_BYTES,
    MAX_STIFFNESS,
    TOP_KEYS,
    Validator,
    misspelling_of,
    read_drive,
    read_effects,
    read_fit,
    same_point,
    short,
)
from eodarm.model.arm_parts import (
    BOUNDS,
    KINDS,
    Actuator,
    Drive,
    EffectMark,
    FitRecord,
    Link,
    Point,
    RotaryDrive,
    stiffness_of,
)
from eodarm.model.arm_toml import over_template, render
from eodarm.model.arm_units import unit_hints
from eodarm.model.effects import Effect

__all__ = [
    "BOUNDS",
    "KINDS",
    "MAX_FILE_BYTES",
    "MAX_STIFFNESS",
    "Actuator",
    "Arm",
    "Drive",
    "EffectMark",
    "FitRecord",
    "Link",
    "Point",
    "RotaryDrive",
    "check_arm",
    "misspelling_of",
]


@dataclass(frozen=True)
class Arm:
    """A planar arm of n links, each turned by a linear actuator or a rotary drive
    (docs/formats.md §1).

    Build one with :meth:`from_toml` or :meth:`from_dict`. ``B0`` is ``None`` when joint 1
    is turned by a rotary drive.
    """

    name: str
    O1: Point
    B0: Point | None
    pivot: Point
    links: tuple[Link, ...]
    actuators: tuple[Drive, ...]
    g: float = 9.81
    source: str = field(default="<dict>", compare=False)
    #: The fitted model the file carries (``[[effect]]`` tables); every solver includes it.
    effects: tuple[Effect, ...] = ()
    #: Standard error of each effect's parameter (same order; ``None`` when not given).
    effect_stderr: tuple[float | None, ...] = ()
    #: The ``[fit]`` table: covariance and provenance of the fitted parameters.
    fit: FitRecord | None = None
    #: How far the data determined each effect's value (same order; ``None``: determined).
    effect_marks: tuple[EffectMark | None, ...] = ()

    # ------------------------------------------------------------------ loading
    @classmethod
    def from_toml(cls, path: str | Path) -> Arm:
        """Load and validate an arm file.

        Raises
        ------
        ArmFileError
            If the file cannot be read or parsed, or any key is missing or invalid. The message
            names the file and the key.
        """
        if not isinstance(path, (str, Path)):
            raise ArmFileError(f"an arm file's path must be a str or Path, got {short(path)}")
        p = Path(path)
        name = show_source(p)  # the file as messages name it: one short printable line
        try:
            with open(p, "rb") as fh:
                raw = fh.read(MAX_FILE_BYTES + 1)
        except OSError as exc:
            raise ArmFileError(f"{name}: cannot read arm file: {exc.strerror or exc}") from None
        except ValueError:  # open() of a name with a NUL byte
            raise ArmFileError(f"{name}: cannot read arm file: its name holds a NUL byte") from None
        if len(raw) > MAX_FILE_BYTES:
            raise ArmFileError(f"{name}: larger than {MAX_FILE_BYTES:,} bytes: not an arm file")
        try:
            text = raw.decode("utf-8-sig")  # a byte-order mark is allowed, as in CSV files
        except UnicodeDecodeError as exc:
            raise ArmFileError(f"{name}: not UTF-8 text (byte {exc.start})") from None
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ArmFileError(f"{name}: not valid TOML: {show(str(exc), 120)}") from None
        except RecursionError:
            raise ArmFileError(
                f"{name}: not an arm file: arrays or tables nested too deeply"
            ) from None
        arm = cls.from_dict(data, source=str(p))
        unit_hints(arm, name)
        return arm

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<dict>") -> Arm:
        """Validate a parsed arm file (same keys as the TOML) and build the arm."""
        v = Validator(source)
        if not isinstance(data, Mapping):
            v.fail("<top>", "the arm must be a table of keys")
        v.unknown(data, TOP_KEYS, "")
        name = data.get("name", Path(source).stem if source != "<dict>" else "arm")
        if not isinstance(name, str) or len(name) > 200 or not name.isprintable():
            v.fail(
                "name", f"must be a printable string of at most 200 characters, got {short(name)}"
            )
        g = v.number(data, "g", "", default=9.81, positive=True)

        base = data.get("base")
        if not isinstance(base, Mapping):
            v.fail("base", "missing table [base]")
        v.unknown(base, BASE_KEYS, "base.")
        o1 = v.point(base, "O1", "base.")

        raw_links = data.get("link")
        if not isinstance(raw_links, list) or not raw_links:
            v.fail("link", "need at least one [[link]] table")
        raw_acts = data.get("actuator")
        if not isinstance(raw_acts, list):
            v.fail("actuator", "need one [[actuator]] table per [[link]]")
        n = len(raw_links)
        if len(raw_acts) != n:
            v.fail("actuator", f"{len(raw_acts)} [[actuator]] tables for {n} [[link]] tables")
        acts = [read_drive(v, raw, i) for i, raw in enumerate(raw_acts)]
        linear = [a.kind == "linear" for a in acts]

        b0 = v.pin(base, "B0", "base.", linear[0], "actuator 1's chassis pin", 1)
        pivot = v.point(base, "pivot", "base.", default=o1)
        if b0 is not None and same_point(o1, b0):
            v.fail("base.B0", f"coincides with base.O1 {o1}")

        links = []
        for i, raw in enumerate(raw_links):
            pre = f"link[{i + 1}]."
            if not isinstance(raw, Mapping):
                v.fail(pre[:-1], "must be a table")
            v.unknown(raw, LINK_KEYS, pre)
            last = i == n - 1
            nxt = v.point(raw, "next", pre)
            a = v.pin(raw, "A", pre, linear[i], f"actuator {i + 1}'s pin on the link", i + 1)
            if last:
                b = None
                if "B" in raw:
                    v.warn(pre + "B", "is ignored on the last link (no actuator follows)")
            else:
                b = v.pin(raw, "B", pre, linear[i + 1], f"actuator {i + 2}'s base pin", i + 2)
            c = v.point(raw, "C", pre)
            mass = v.number(raw, "mass_kg", pre, nonneg=True)
            measure = v.point(raw, "measure", pre, default=None) if last else None
            if not last and "measure" in raw:
                v.fail(pre + "measure", "only the last link has a measurement point")
            ei = v.number(raw, "ei_n_mm2", pre, default=None, positive=True)
            ea = v.number(raw, "ea_n", pre, default=None, positive=True)
            if same_point(nxt, (0.0, 0.0)):
                v.fail(pre + "next", "coincides with the link's own joint (zero-length link)")
            if a is not None and same_point(a, (0.0, 0.0)):
                v.fail(pre + "A", "coincides with the link's own joint O (no moment arm)")
            if b is not None and same_point(b, nxt):
                v.fail(pre + "B", f"coincides with the next joint {nxt}")
            links.append(Link(nxt, a, b, c, mass, measure, ei, ea))

        effects, stderr, marks = read_effects(
            v, data.get("effect", []), tuple(a.kind for a in acts)
        )
        fit = read_fit(v, data["fit"], effects) if "fit" in data else None
        return cls(
            name=name,
            O1=o1,
            B0=b0,
            pivot=pivot,
            links=tuple(links),
            actuators=tuple(acts),
            g=g,
            source=source,
            effects=effects,
            effect_stderr=stderr,
            fit=fit,
            effect_marks=marks if any(m is not None for m in marks) else (),
        )

    # ------------------------------------------------------------------ views
    def __repr__(self) -> str:
        from eodarm.model.arm_display import arm_repr

        return arm_repr(self)

    def _repr_html_(self) -> str:
        from eodarm.model.arm_display import arm_html

        return arm_html(self)

    @property
    def n(self) -> int:
        """Number of links (and actuators)."""
        return len(self.links)

    @property
    def measure(self) -> Point:
        """Measurement point in the last link's frame (the load point unless set)."""
        last = self.links[-1]
        return last.measure if last.measure is not None else last.next

    @property
    def kinds(self) -> tuple[str, ...]:
        """The kind of each joint's drive, ``"linear"`` or ``"rotary"`` (n,)."""
        return tuple(a.kind for a in self.actuators)

    def is_linear(self, i: int) -> bool:
        """Whether joint ``i`` (0-based) is turned by a linear actuator."""
        return self.actuators[i].kind == "linear"

    def is_rotary(self, i: int) -> bool:
        """Whether joint ``i`` (0-based) is turned by a rotary drive."""
        return self.actuators[i].kind == "rotary"

    def linear(self, i: int) -> Actuator:
        """Joint ``i``'s (0-based) linear actuator.

        Raises
        ------
        InputError
            When a rotary drive turns joint ``i`` (it has no actuator's stiffness or stroke).
        """
        a = self.actuators[i]
        if not isinstance(a, Actuator):
            raise InputError(
                f"arm '{self.name}': joint {i + 1} is turned by a rotary drive, not a linear "
                "actuator"
            )
        return a

    def arrays(self) -> dict[str, np.ndarray]:
        """Contiguous float64 arrays describing the arm, as the solvers consume them.

        ``B`` has a zero row for the last link (it has no B pin). A pin no drive uses (``A``
        of a link turned by a rotary drive, ``B`` before one, ``B0`` when joint 1 is rotary)
        is zero: ``kind`` says it is unused. ``kind`` (n,) is 0.0 for a linear actuator and
        1.0 for a rotary drive; ``stiffness`` (n,) each joint's stiffness in its own unit
        (N/mm linear, N·mm/rad rotary); ``max_torque`` (N·mm), ``min_angle_deg`` and
        ``max_angle_deg`` (n,) the rotary limits, NaN where absent or linear.
        """
        n = self.n
        zero = (0.0, 0.0)
        nan = math.nan

        def rotary(key: str) -> np.ndarray:
            vals = [getattr(a, key) if isinstance(a, RotaryDrive) else None for a in self.actuators]
            return np.array([nan if x is None else x for x in vals], dtype=float)

        return {
            "O1": np.array(self.O1, dtype=float),
            "B0": np.array(self.B0 or zero, dtype=float),
            "pivot": np.array(self.pivot, dtype=float),
            "next": np.array([lk.next for lk in self.links], dtype=float).reshape(n, 2),
            "A": np.array([lk.A or zero for lk in self.links], dtype=float).reshape(n, 2),
            "B": np.array([lk.B or zero for lk in self.links], dtype=float).reshape(n, 2),
            "C": np.array([lk.C for lk in self.links], dtype=float).reshape(n, 2),
            "link_mass": np.array([lk.mass_kg for lk in self.links], dtype=float),
            "measure": np.array(self.measure, dtype=float),
            "kind": np.array([KINDS.index(a.kind) for a in self.actuators], dtype=float),
            "stiffness": np.array([stiffness_of(a) for a in self.actuators], dtype=float),
            "act_mass": np.array([a.mass_kg for a in self.actuators], dtype=float),
            "max_torque": rotary("max_torque_nmm"),
            "min_angle_deg": rotary("min_angle_deg"),
            "max_angle_deg": rotary("max_angle_deg"),
            "g": np.array(self.g, dtype=float),
        }

    def to_dict(self) -> dict[str, Any]:
        """The arm as a dict with the arm file's keys (inverse of :meth:`from_dict`).

        A linear actuator's table has no ``kind`` key (the default), a rotary drive's has
        ``kind = "rotary"``; pins no drive uses are not written."""
        out: dict[str, Any] = {"name": self.name, "g": self.g}
        out["base"] = {"O1": list(self.O1)}
        if self.B0 is not None:
            out["base"]["B0"] = list(self.B0)
        out["base"]["pivot"] = list(self.pivot)
        links = []
        for lk in self.links:
            d: dict[str, Any] = {"next": list(lk.next)}
            if lk.A is not None:
                d["A"] = list(lk.A)
            if lk.B is not None:
                d["B"] = list(lk.B)
            d["C"] = list(lk.C)
            if lk.measure is not None:
                d["measure"] = list(lk.measure)
            d["mass_kg"] = lk.mass_kg
            for key in ("ei_n_mm2", "ea_n"):
                if getattr(lk, key) is not None:
                    d[key] = getattr(lk, key)
            links.append(d)
        out["link"] = links
        acts = []
        for a in self.actuators:
            if isinstance(a, RotaryDrive):
                d = {"kind": "rotary", "stiffness_nmm_per_rad": a.stiffness_nmm_per_rad}
                optional: tuple[str, ...] = ("max_torque_nmm", "min_angle_deg", "max_angle_deg")
            else:
                d = {"stiffness_n_per_mm": a.stiffness_n_per_mm}
                optional = ("min_length_mm", "max_length_mm", "max_force_n")
            d["mass_kg"] = a.mass_kg
            for key in optional:
                if getattr(a, key) is not None:
                    d[key] = getattr(a, key)
            acts.append(d)
        out["actuator"] = acts
        if self.effects:
            out["effect"] = [
                _effect_table(e, s, m)
                for e, s, m in zip(self.effects, self.stderrs(), self.marks(), strict=True)
            ]
        if self.fit is not None:
            out["fit"] = self.fit.to_dict()
        return out

    def stderrs(self) -> tuple[float | None, ...]:
        """The standard error of each of :attr:`effects` (``None`` where unknown)."""
        return self.effect_stderr or (None,) * len(self.effects)

    def marks(self) -> tuple[EffectMark | None, ...]:
        """How far each of :attr:`effects` was determined (``None``: determined)."""
        return self.effect_marks or (None,) * len(self.effects)

    def bounded(self) -> list[tuple[Effect, EffectMark]]:
        """The effects fixed at a physical end because the data gave only a bound."""
        return [
            (e, m)
            for e, m in zip(self.effects, self.marks(), strict=True)
            if m is not None and m.bound is not None
        ]

    def with_effects(
        self,
        effects: Any,
        stderr: Any = None,
        fit: FitRecord | None = None,
        marks: Any = None,
    ) -> Arm:
        """A copy carrying ``effects`` (replacing the same effect@place, appending others).

        ``stderr`` gives the new effects' standard errors (same order, ``None`` for unknown);
        ``marks`` how far each was determined (:class:`EffectMark`, ``None``: determined);
        ``fit`` replaces the ``[fit]`` table (the old one is dropped whenever effects change,
        as its covariance no longer describes them).
        """
        new = list(effects)
        errs = list(stderr) if stderr is not None else [None] * len(new)
        marks_new = list(marks) if marks is not None else [None] * len(new)
        if len(errs) != len(new) or len(marks_new) != len(new):
            raise ArmFileError(f"{self.source}: {len(errs)} standard errors for {len(new)} effects")
        keys = {e.key for e in new}
        kept = [
            (e, s, m)
            for e, s, m in zip(self.effects, self.stderrs(), self.marks(), strict=True)
            if e.key not in keys
        ]
        triples = kept + list(zip(new, errs, marks_new, strict=True))
        d = self.to_dict()
        d["effect"] = [_effect_table(e, s, m) for e, s, m in triples]
        d.pop("fit", None)
        if fit is not None:
            d["fit"] = fit.to_dict()
        return Arm.from_dict(d, source=self.source)

    def to_toml(self, template: str | None = None) -> str:
        """Render the arm as an arm file (docs/formats.md).

        ``template``: the text of the arm file this arm came from (e.g. the input of a fit).
        When its arm (name, base, links, actuators) is this arm's, the result is that text
        with its ``[[effect]]`` tables and ``[fit]`` table brought up to date, so that the
        user's comments and layout survive; otherwise the arm is rendered afresh.
        """
        mine = self.to_dict()
        if template is not None:
            kept = over_template(mine, template, lambda plain: Arm.from_dict(plain).to_dict())
            if kept is not None:
                return kept
        return render(mine)

    def replace(self, **changes: Any) -> Arm:
        """A validated copy with top-level fields changed (e.g. ``B0=(240.0, -35.0)``)."""
        d = self.to_dict()
        for key, value in changes.items():
            if key in ("O1", "B0", "pivot"):
                d["base"][key] = list(value)
            elif key in ("name", "g"):
                d[key] = value
            else:
                raise ArmFileError(f"{self.source}: key '{key}': cannot be replaced this way")
        return Arm.from_dict(d, source=self.source)


def check_arm(arm: Any, where: str) -> Arm:
    """``arm`` if it is an :class:`Arm`; else an :class:`ArgumentTypeError` saying what to do."""
    if isinstance(arm, Arm):
        return arm
    hint = (
        f": load it first with eodarm.Arm.from_toml({str(arm)!r})"
        if isinstance(arm, (str, Path))
        else ""
    )
    raise ArgumentTypeError(f"{where}: arm must be an eodarm.Arm, got {type(arm).__name__}{hint}")


def _effect_table(e: Effect, stderr: float | None, mark: EffectMark | None) -> dict[str, Any]:
    """An ``[[effect]]`` table: the effect, its standard error and how far it is determined."""
    table = e.to_table() | ({} if stderr is None else {"stderr": stderr})
    return table | (mark.to_table() if mark is not None else {})
