"""Arm description: loading, validating and exporting the arm file of docs/formats.md §1.

An :class:`Arm` is immutable and always valid: every constructor goes through
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
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from eodarm.errors import ArgumentTypeError, ArmFileError, EffectError, show, show_source
from eodarm.model.arm_toml import over_template, render
from eodarm.model.arm_units import unit_hints
from eodarm.model.effects import Effect, effect_from_table

__all__ = ["Actuator", "Arm", "EffectMark", "FitRecord", "Link", "check_arm"]

Point = tuple[float, float]

_BASE_KEYS = {"O1", "B0", "pivot"}
_LINK_KEYS = {"next", "A", "B", "C", "mass_kg", "measure", "ei_n_mm2", "ea_n"}
_ACT_KEYS = {"stiffness_n_per_mm", "mass_kg", "min_length_mm", "max_length_mm", "max_force_n"}
_TOP_KEYS = {"name", "g", "base", "link", "actuator", "effect", "fit"}
#: An arm file is a few kB; anything this large is not one (and would be slow to parse).
MAX_FILE_BYTES = 1_000_000
#: The physical range of an arm file's numbers (docs/model.md §8): beyond it a number is a typo
#: or a unit mistake, and the small-deflection model would not apply anyway.
MAX_LENGTH_MM = 1e6  # coordinates: 1 km
MAX_MASS_KG = 1e6
MAX_STIFFNESS = 1e20  # N/mm, N·mm² and N: "rigid" (tests use 1e18), not an overflow
MAX_G = 100.0  # m/s², ten times Earth's

_FIT_KEYS = {
    "parameters",
    "covariance",
    "data",
    "data_sha256",
    "chi2_per_dof",
    "date",
    "n_values",
    "explained",
    "sigma_model",
    "heldout_rms",
    "noise_rms",
}
#: Keys of an ``[[effect]]`` table that mark a parameter the data did not determine
#: (docs/model.md, "Undetermined parameters"): they describe the value, not the effect.
_MARK_KEYS = ("determined", "bound", "limit")
#: Where a bounded parameter's 95 % interval reaches: "lower" (a stiffness of at least
#: ``limit``, treated as rigid) or "upper" (a gap of at most ``limit``, treated as absent).
BOUNDS = ("lower", "upper")


@dataclass(frozen=True)
class Link:
    """One rigid link, points in its local frame (mm).

    Attributes
    ----------
    next : next joint O_{i+1} (for the last link: the load point).
    A : pin of the link's own actuator.
    B : base pin of the next actuator (``None`` on the last link).
    C : centre of mass.
    mass_kg : link mass.
    measure : measurement point (last link only; ``None`` means the load point).
    ei_n_mm2, ea_n : optional section properties (N·mm², N).
    """

    next: Point
    A: Point
    B: Point | None
    C: Point
    mass_kg: float
    measure: Point | None = None
    ei_n_mm2: float | None = None
    ea_n: float | None = None


@dataclass(frozen=True)
class Actuator:
    """One linear actuator: axial stiffness (N/mm), mass (kg) and optional limits."""

    stiffness_n_per_mm: float
    mass_kg: float
    min_length_mm: float | None = None
    max_length_mm: float | None = None
    max_force_n: float | None = None


@dataclass(frozen=True)
class FitRecord:
    """What a fit knew about the parameters it wrote into an arm file (its ``[fit]`` table).

    Attributes
    ----------
    parameters : ``effect@place:parameter`` of each fitted parameter, in the covariance's
        order (physical units, as the ``[[effect]]`` tables give them).
    covariance : the parameters' covariance matrix (units²), symmetric.
    data : the measurement file's name; ``data_sha256`` its SHA-256 (hex).
    chi2_per_dof : χ²/dof of the fit; ``n_values`` the number of measured values it used.
    date : when it was fitted (ISO 8601).
    explained : whether the fitted model explained its data within their noise (the χ²
        test, docs/model.md, "Prediction errors"); ``None`` when the file does not say.
    sigma_model : per measured channel (``dy_mm``, ``dalpha1_deg``, …), the model's own
        inadequacy, a standard deviation in the channel's unit that every prediction adds
        in quadrature to the parameters' part; all zero when ``explained``.
    heldout_rms : per channel, the RMS of the leave-one-configuration-out residuals it
        came from; ``noise_rms`` the RMS of the measurements' own σ over the same cells.
    """

    parameters: tuple[str, ...]
    covariance: tuple[tuple[float, ...], ...]
    data: str = ""
    data_sha256: str = ""
    chi2_per_dof: float = math.nan
    n_values: int = 0
    date: str = ""
    explained: bool | None = None
    sigma_model: tuple[tuple[str, float], ...] = ()
    heldout_rms: tuple[tuple[str, float], ...] = ()
    noise_rms: tuple[tuple[str, float], ...] = ()

    def model_sigma(self, channel: str) -> float:
        """The model part of a prediction's σ in ``channel`` (its unit): 0 when the model
        explained its data (or the file predates the key), the stored value for a measured
        channel; for one the fit never saw, the largest of the measured channels of its kind
        (``dx_mm`` ↔ ``dy_mm``; ``dalphaK_deg``), else NaN (unknown)."""
        if self.explained is not False:
            return 0.0
        known = dict(self.sigma_model)
        if channel in known:
            return known[channel]
        # A component the fit never saw: the measured one of the same kind stands in (the
        # measure point's miss is one vector; the links' angle misses are of one order).
        if channel in ("dx_mm", "dy_mm"):
            kin = [known[c] for c in ("dx_mm", "dy_mm") if c in known]
        else:
            kin = [v for c, v in known.items() if c[:6] == channel[:6] and c.endswith("_deg")]
        return max(kin) if kin else math.nan

    def __repr__(self) -> str:
        from eodarm.model.arm_display import record_repr

        return record_repr(self)

    def matrix(self) -> np.ndarray:
        """The covariance as a (P, P) float array."""
        k = len(self.parameters)
        return np.array(self.covariance, dtype=float).reshape(k, k)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "parameters": list(self.parameters),
            "covariance": [list(r) for r in self.covariance],
        }
        for key in ("data", "data_sha256", "date"):
            if getattr(self, key):
                d[key] = getattr(self, key)
        if math.isfinite(self.chi2_per_dof):
            d["chi2_per_dof"] = self.chi2_per_dof
        if self.n_values:
            d["n_values"] = self.n_values
        if self.explained is not None:
            d["explained"] = self.explained
        for key in ("sigma_model", "heldout_rms", "noise_rms"):
            if getattr(self, key):
                d[key] = dict(getattr(self, key))
        return d


@dataclass(frozen=True)
class EffectMark:
    """How far the data determined an ``[[effect]]``'s parameter (docs/model.md).

    Attributes
    ----------
    determined : False when the fit could not pin the value down (relative error above
        100 % or a correlation beyond ±0.95 with another parameter).
    bound : ``"lower"`` or ``"upper"`` when only a bound is known and the effect is fixed
        at its physical end (a stiffness treated as rigid, a gap as absent); ``None`` when
        the value is an estimate (then the ``[fit]`` covariance carries its spread).
    limit : the 95 % bound in the parameter's unit (a stiffness of at least ``limit``, a gap
        of at most ``limit``); ``None`` without a bound.
    """

    determined: bool = True
    bound: str | None = None
    limit: float | None = None

    def to_table(self) -> dict[str, Any]:
        """The marking keys of an ``[[effect]]`` table (none for a determined value)."""
        if self.determined:
            return {}
        d: dict[str, Any] = {"determined": False}
        if self.bound is not None and self.limit is not None:
            d["bound"] = self.bound
            d["limit"] = self.limit
        return d


@dataclass(frozen=True)
class Arm:
    """A planar arm of n links, each driven by a linear actuator (docs/formats.md §1).

    Build one with :meth:`from_toml` or :meth:`from_dict`.
    """

    name: str
    O1: Point
    B0: Point
    pivot: Point
    links: tuple[Link, ...]
    actuators: tuple[Actuator, ...]
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
            raise ArmFileError(f"an arm file's path must be a str or Path, got {_short(path)}")
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
        v = _Validator(source)
        if not isinstance(data, Mapping):
            v.fail("<top>", "the arm must be a table of keys")
        v.unknown(data, _TOP_KEYS, "")
        name = data.get("name", Path(source).stem if source != "<dict>" else "arm")
        if not isinstance(name, str) or len(name) > 200 or not name.isprintable():
            v.fail(
                "name", f"must be a printable string of at most 200 characters, got {_short(name)}"
            )
        g = v.number(data, "g", "", default=9.81, positive=True)

        base = data.get("base")
        if not isinstance(base, Mapping):
            v.fail("base", "missing table [base]")
        v.unknown(base, _BASE_KEYS, "base.")
        o1 = v.point(base, "O1", "base.")
        b0 = v.point(base, "B0", "base.")
        pivot = v.point(base, "pivot", "base.", default=o1)
        if _same(o1, b0):
            v.fail("base.B0", f"coincides with base.O1 {o1}")

        raw_links = data.get("link")
        if not isinstance(raw_links, list) or not raw_links:
            v.fail("link", "need at least one [[link]] table")
        raw_acts = data.get("actuator")
        if not isinstance(raw_acts, list):
            v.fail("actuator", "need one [[actuator]] table per [[link]]")
        n = len(raw_links)
        if len(raw_acts) != n:
            v.fail("actuator", f"{len(raw_acts)} [[actuator]] tables for {n} [[link]] tables")

        links = []
        for i, raw in enumerate(raw_links):
            pre = f"link[{i + 1}]."
            if not isinstance(raw, Mapping):
                v.fail(pre[:-1], "must be a table")
            v.unknown(raw, _LINK_KEYS, pre)
            last = i == n - 1
            nxt = v.point(raw, "next", pre)
            a = v.point(raw, "A", pre)
            b = None if last else v.point(raw, "B", pre)
            if last and "B" in raw:
                v.warn(pre + "B", "is ignored on the last link (no actuator follows)")
            c = v.point(raw, "C", pre)
            mass = v.number(raw, "mass_kg", pre, nonneg=True)
            measure = v.point(raw, "measure", pre, default=None) if last else None
            if not last and "measure" in raw:
                v.fail(pre + "measure", "only the last link has a measurement point")
            ei = v.number(raw, "ei_n_mm2", pre, default=None, positive=True)
            ea = v.number(raw, "ea_n", pre, default=None, positive=True)
            if _same(nxt, (0.0, 0.0)):
                v.fail(pre + "next", "coincides with the link's own joint (zero-length link)")
            if _same(a, (0.0, 0.0)):
                v.fail(pre + "A", "coincides with the link's own joint O (no moment arm)")
            if b is not None and _same(b, nxt):
                v.fail(pre + "B", f"coincides with the next joint {nxt}")
            links.append(Link(nxt, a, b, c, mass, measure, ei, ea))

        acts = []
        for i, raw in enumerate(raw_acts):
            pre = f"actuator[{i + 1}]."
            if not isinstance(raw, Mapping):
                v.fail(pre[:-1], "must be a table")
            v.unknown(raw, _ACT_KEYS, pre)
            k = v.number(raw, "stiffness_n_per_mm", pre, positive=True)
            m = v.number(raw, "mass_kg", pre, nonneg=True)
            lo = v.number(raw, "min_length_mm", pre, default=None, positive=True)
            hi = v.number(raw, "max_length_mm", pre, default=None, positive=True)
            if lo is not None and hi is not None and lo > hi:
                v.fail(pre + "min_length_mm", f"{lo} exceeds max_length_mm {hi}")
            fmax = v.number(raw, "max_force_n", pre, default=None, positive=True)
            acts.append(Actuator(k, m, lo, hi, fmax))

        effects, stderr, marks = _effects(v, data.get("effect", []), n)
        fit = _fit_record(v, data["fit"], effects) if "fit" in data else None
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

    def arrays(self) -> dict[str, np.ndarray]:
        """Contiguous float64 arrays describing the arm, as the solvers consume them.

        ``B`` has a zero row for the last link (it has no B pin).
        """
        n = self.n
        zero = (0.0, 0.0)
        return {
            "O1": np.array(self.O1, dtype=float),
            "B0": np.array(self.B0, dtype=float),
            "pivot": np.array(self.pivot, dtype=float),
            "next": np.array([lk.next for lk in self.links], dtype=float).reshape(n, 2),
            "A": np.array([lk.A for lk in self.links], dtype=float).reshape(n, 2),
            "B": np.array([lk.B or zero for lk in self.links], dtype=float).reshape(n, 2),
            "C": np.array([lk.C for lk in self.links], dtype=float).reshape(n, 2),
            "link_mass": np.array([lk.mass_kg for lk in self.links], dtype=float),
            "measure": np.array(self.measure, dtype=float),
            "stiffness": np.array([a.stiffness_n_per_mm for a in self.actuators], dtype=float),
            "act_mass": np.array([a.mass_kg for a in self.actuators], dtype=float),
            "g": np.array(self.g, dtype=float),
        }

    def to_dict(self) -> dict[str, Any]:
        """The arm as a dict with the arm file's keys (inverse of :meth:`from_dict`)."""
        out: dict[str, Any] = {"name": self.name, "g": self.g}
        out["base"] = {"O1": list(self.O1), "B0": list(self.B0), "pivot": list(self.pivot)}
        links = []
        for lk in self.links:
            d: dict[str, Any] = {"next": list(lk.next), "A": list(lk.A)}
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
            d = {"stiffness_n_per_mm": a.stiffness_n_per_mm, "mass_kg": a.mass_kg}
            for key in ("min_length_mm", "max_length_mm", "max_force_n"):
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


def _limit(key: str) -> float:
    """The largest magnitude an arm file's number may have (by the key's unit)."""
    if key in ("stiffness_n_per_mm", "ei_n_mm2", "ea_n", "max_force_n"):
        return MAX_STIFFNESS
    if key == "g":
        return MAX_G
    if key == "mass_kg":
        return MAX_MASS_KG
    if key.endswith("_mm"):
        return MAX_LENGTH_MM
    return math.inf


def _short(val: Any, limit: int = 40) -> str:
    """``repr`` of a value, cut to one short line (messages stay one line)."""
    text = _one_line(repr(val))
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _one_line(text: str) -> str:
    return " ".join(text.split())


def _same(p: Point, q: Point) -> bool:
    return math.hypot(p[0] - q[0], p[1] - q[1]) <= 1e-9 * (1.0 + math.hypot(*p) + math.hypot(*q))


def _effect_table(e: Effect, stderr: float | None, mark: EffectMark | None) -> dict[str, Any]:
    """An ``[[effect]]`` table: the effect, its standard error and how far it is determined."""
    table = e.to_table() | ({} if stderr is None else {"stderr": stderr})
    return table | (mark.to_table() if mark is not None else {})


def _effects(
    v: _Validator, raw: Any, n: int
) -> tuple[tuple[Effect, ...], tuple[float | None, ...], tuple[EffectMark | None, ...]]:
    """The ``[[effect]]`` tables: validated effects, their optional standard errors and
    marks of what the data did not determine."""
    if not isinstance(raw, list):
        v.fail("effect", "must be [[effect]] tables")
    effects: list[Effect] = []
    errs: list[float | None] = []
    marks: list[EffectMark | None] = []
    for i, table in enumerate(raw):
        pre = f"effect[{i + 1}]"
        if not isinstance(table, Mapping):
            v.fail(pre, "must be a table")
        body = {k: val for k, val in table.items() if k != "stderr" and k not in _MARK_KEYS}
        try:
            e = effect_from_table(body)
        except EffectError as exc:
            v.fail(f"{pre}.{exc.key}" if exc.key else pre, str(exc))
        try:
            e.index(n)
        except EffectError as exc:
            v.fail(f"{pre}.at", str(exc))
        if any(p.key == e.key for p in effects):
            v.fail(f"{pre}.at", f"{e.key} is given twice")
        effects.append(e)
        errs.append(v.number(table, "stderr", pre + ".", default=None, nonneg=True))
        marks.append(_mark(v, table, pre))
    return tuple(effects), tuple(errs), tuple(marks)


def _mark(v: _Validator, table: Mapping[str, Any], pre: str) -> EffectMark | None:
    """An ``[[effect]]`` table's ``determined``, ``bound`` and ``limit`` keys."""
    if not any(k in table for k in _MARK_KEYS):
        return None
    det = table.get("determined", True)
    if not isinstance(det, bool):
        v.fail(f"{pre}.determined", f"must be true or false, got {_short(det)}")
    bound = table.get("bound")
    if bound is not None and bound not in BOUNDS:
        v.fail(f"{pre}.bound", f'must be "lower" or "upper", got {_short(bound)}')
    limit = v.number(table, "limit", pre + ".", default=None, positive=True)
    if (bound is None) != (limit is None):
        v.fail(f"{pre}.{'limit' if limit is None else 'bound'}", "bound and limit go together")
    if bound is not None and det:
        v.fail(f"{pre}.determined", "a value given only by a bound is not determined")
    return None if det else EffectMark(False, bound, limit)


def _fit_record(v: _Validator, raw: Any, effects: tuple[Effect, ...]) -> FitRecord:
    """The ``[fit]`` table, checked against the effects it describes."""
    if not isinstance(raw, Mapping):
        v.fail("fit", "must be a table [fit]")
    v.unknown(raw, _FIT_KEYS, "fit.")
    names = raw.get("parameters")
    if not isinstance(names, list) or not all(isinstance(s, str) for s in names):
        v.fail("fit.parameters", "must be a list of 'effect@place:parameter' strings")
    known = {f"{e.key}:{e.param}" for e in effects}
    for s in names:
        if s not in known:
            v.fail("fit.parameters", f"'{s}' is not a parameter of the file's [[effect]] tables")
    k = len(names)
    cov = raw.get("covariance")
    if (
        not isinstance(cov, list)
        or len(cov) != k
        or not all(isinstance(r, list) and len(r) == k for r in cov)
    ):
        v.fail("fit.covariance", f"must be a {k}×{k} matrix (one row per parameter)")
    rows = []
    for i, r in enumerate(cov):
        row = []
        for j, x in enumerate(r):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                v.fail(
                    f"fit.covariance[{i + 1}][{j + 1}]", f"must be a finite number, got {_short(x)}"
                )
            row.append(float(x))
        rows.append(tuple(row))
    m = np.array(rows, dtype=float).reshape(k, k)
    if k and (not np.allclose(m, m.T, rtol=1e-9, atol=0.0) or (np.diag(m) < 0).any()):
        v.fail("fit.covariance", "must be symmetric with a non-negative diagonal")
    texts = {}
    for key in ("data", "data_sha256", "date"):
        val = raw.get(key, "")
        if not isinstance(val, str):
            v.fail(f"fit.{key}", f"must be a string, got {_short(val)}")
        texts[key] = val
    chi = v.number(raw, "chi2_per_dof", "fit.", default=math.nan, nonneg=True)
    nv = raw.get("n_values", 0)
    if isinstance(nv, bool) or not isinstance(nv, int) or nv < 0:
        v.fail("fit.n_values", f"must be a non-negative integer, got {_short(nv)}")
    explained = raw.get("explained")
    if explained is not None and not isinstance(explained, bool):
        v.fail("fit.explained", f"must be true or false, got {_short(explained)}")
    per: dict[str, tuple[tuple[str, float], ...]] = {}
    for key in ("sigma_model", "heldout_rms", "noise_rms"):
        table = raw.get(key, {})
        if not isinstance(table, Mapping):
            v.fail(f"fit.{key}", "must be a table of channel = value, e.g. { dy_mm = 1.9 }")
        per[key] = tuple(
            (str(ch), float(v.number(table, ch, f"fit.{key}.", nonneg=True))) for ch in table
        )
    return FitRecord(
        tuple(names),
        tuple(rows),
        chi2_per_dof=chi,
        n_values=nv,
        explained=explained,
        sigma_model=per["sigma_model"],
        heldout_rms=per["heldout_rms"],
        noise_rms=per["noise_rms"],
        data=texts["data"],
        data_sha256=texts["data_sha256"],
        date=texts["date"],
    )


class _Validator:
    """Checks keys of one source and raises ArmFileError naming the source and key."""

    _MISSING = object()

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, key: str, why: str) -> NoReturn:
        raise ArmFileError(f"{show_source(self.source)}: key '{show(key, 60)}': {why}")

    def warn(self, key: str, why: str) -> None:
        warnings.warn(
            f"{show_source(self.source)}: key '{show(key, 60)}' {why}", UserWarning, stacklevel=4
        )

    def unknown(self, table: Mapping[str, Any], allowed: set[str], prefix: str) -> None:
        """A key not in ``allowed``: refused when it looks like a misspelling of one (its
        default would be used silently in its place), else ignored with a warning (a note
        of the user's own, say). docs/model.md, "Arm file keys"."""
        for key in table:
            if key in allowed:
                continue
            meant = misspelling_of(key, allowed)
            if meant is not None:
                self.fail(
                    prefix + key,
                    f"is not an arm-file key: did you mean '{meant}'? (a misspelled key is "
                    "refused rather than left to its default)",
                )
            self.warn(prefix + key, "is not an arm-file key and is ignored")

    def number(
        self,
        table: Mapping[str, Any],
        key: str,
        prefix: str,
        default: Any = _MISSING,
        positive: bool = False,
        nonneg: bool = False,
    ) -> Any:
        if key not in table:
            if default is self._MISSING:
                self.fail(prefix + key, "missing")
            return default
        x = self.finite(table[key], prefix + key)
        if positive and x <= 0:
            self.fail(prefix + key, f"must be > 0, got {x!r}")
        if nonneg and x < 0:
            self.fail(prefix + key, f"must be >= 0, got {x!r}")
        limit = _limit(key)
        if abs(x) > limit:
            self.fail(prefix + key, f"{x:.6g} is beyond the physical range (|x| <= {limit:g})")
        return x

    def finite(self, val: Any, key: str) -> float:
        """A finite float from a TOML number (an integer too large for a float is refused)."""
        if isinstance(val, bool) or not isinstance(val, (int, float)):
            self.fail(key, f"must be a number, got {_short(val)}")
        try:
            x = float(val)
        except OverflowError:
            self.fail(key, f"the number {_short(val)} is too large")
        if not math.isfinite(x):
            self.fail(key, f"must be finite, got {val!r}")
        return x

    def point(
        self, table: Mapping[str, Any], key: str, prefix: str, default: Any = _MISSING
    ) -> Any:
        if key not in table:
            if default is self._MISSING:
                self.fail(prefix + key, "missing")
            return default
        val = table[key]
        if (
            not isinstance(val, (list, tuple))
            or len(val) != 2
            or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in val)
        ):
            self.fail(prefix + key, f"must be a pair of numbers [x, y], got {_short(val)}")
        x, y = (self.finite(c, prefix + key) for c in val)
        if max(abs(x), abs(y)) > MAX_LENGTH_MM:
            self.fail(
                prefix + key,
                f"[{x:.6g}, {y:.6g}] is beyond the physical range "
                f"(|x|, |y| <= {MAX_LENGTH_MM:g} mm)",
            )
        return (x, y)


def misspelling_of(key: str, allowed: Iterable[str], cutoff: float = 0.6) -> str | None:
    """The key of ``allowed`` that ``key`` most probably misspells, or None.

    A close match by difflib's ratio (≥ ``cutoff``, case ignored), or a known key that
    ``key`` starts with followed by ``_`` (``measure_point`` for ``measure``).
    """
    import difflib

    lower = {k.lower(): k for k in allowed}
    k = key.strip().lower()
    close = difflib.get_close_matches(k, list(lower), n=1, cutoff=cutoff)
    if close:
        return lower[close[0]]
    prefix = [v for lk, v in lower.items() if k.startswith(lk + "_") or lk.startswith(k + "_")]
    return prefix[0] if len(prefix) == 1 else None
