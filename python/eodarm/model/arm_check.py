"""Reading an arm file's tables: every key checked, one line naming the file and the key for
anything wrong (docs/formats.md §1–§2, docs/model.md §7 "The physical range of an arm file").

:meth:`eodarm.model.arm.Arm.from_dict` reads the file with these; nothing here builds an arm.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping
from typing import Any, NoReturn

import numpy as np

from eodarm.errors import ArmFileError, EffectError, show, show_source
from eodarm.model.arm_parts import (
    BOUNDS,
    KINDS,
    Actuator,
    Drive,
    EffectMark,
    FitRecord,
    Point,
    RotaryDrive,
)
from eodarm.model.effects import Effect, check_kinds, effect_from_table

__all__ = [
    "BASE_KEYS",
    "LINK_KEYS",
    "MAX_ANGLE_DEG",
    "MAX_FILE_BYTES",
    "MAX_G",
    "MAX_LENGTH_MM",
    "MAX_MASS_KG",
    "MAX_STIFFNESS",
    "TOP_KEYS",
    "Validator",
    "misspelling_of",
    "one_line",
    "read_drive",
    "read_effects",
    "read_fit",
    "same_point",
    "short",
]

BASE_KEYS = {"O1", "B0", "pivot"}
LINK_KEYS = {"next", "A", "B", "C", "mass_kg", "measure", "ei_n_mm2", "ea_n"}
#: The keys of an ``[[actuator]]`` table by its ``kind``; ``mass_kg`` and ``kind`` are shared.
_KIND_KEYS = {
    "linear": {"stiffness_n_per_mm", "min_length_mm", "max_length_mm", "max_force_n"},
    "rotary": {"stiffness_nmm_per_rad", "max_torque_nmm", "min_angle_deg", "max_angle_deg"},
}
_ACT_KEYS = {"kind", "mass_kg"}
TOP_KEYS = {"name", "g", "base", "link", "actuator", "effect", "fit"}
#: An arm file is a few kB; anything this large is not one (and would be slow to parse).
MAX_FILE_BYTES = 1_000_000
#: The physical range of an arm file's numbers (docs/model.md §8): beyond it a number is a typo
#: or a unit mistake, and the small-deflection model would not apply anyway.
MAX_LENGTH_MM = 1e6  # coordinates: 1 km
MAX_MASS_KG = 1e6
MAX_STIFFNESS = 1e20  # N/mm, N·mm² and N: "rigid" (tests use 1e18), not an overflow
MAX_G = 100.0  # m/s², ten times Earth's
#: A drive's angle limits bound q_i = α_i − α_{i−1}, taken in [−180°, 180°) (docs/model.md §10).
MAX_ANGLE_DEG = 180.0

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


def _limit(key: str) -> float:
    """The largest magnitude an arm file's number may have (by the key's unit)."""
    if key in (
        "stiffness_n_per_mm",
        "stiffness_nmm_per_rad",
        "ei_n_mm2",
        "ea_n",
        "max_force_n",
        "max_torque_nmm",
    ):
        return MAX_STIFFNESS
    if key.endswith("_deg"):
        return MAX_ANGLE_DEG
    if key == "g":
        return MAX_G
    if key == "mass_kg":
        return MAX_MASS_KG
    if key.endswith("_mm"):
        return MAX_LENGTH_MM
    return math.inf


def short(val: Any, limit: int = 40) -> str:
    """``repr`` of a value, cut to one short line (messages stay one line)."""
    text = one_line(repr(val))
    return text if len(text) <= limit else text[: limit - 1] + "…"


def one_line(text: str) -> str:
    return " ".join(text.split())


def same_point(p: Point, q: Point) -> bool:
    return math.hypot(p[0] - q[0], p[1] - q[1]) <= 1e-9 * (1.0 + math.hypot(*p) + math.hypot(*q))


def read_drive(v: Validator, raw: Any, i: int) -> Drive:
    """Actuator table ``i`` (0-based): a linear actuator or, with ``kind = "rotary"``, a
    rotary drive. A key of the other kind is refused, naming the key and what this kind
    takes instead (docs/formats.md §1)."""
    pre = f"actuator[{i + 1}]."
    if not isinstance(raw, Mapping):
        v.fail(pre[:-1], "must be a table")
    kind = raw.get("kind", "linear")
    if kind not in KINDS:
        v.fail(pre + "kind", f'must be "linear" or "rotary", got {short(kind)}')
    other = "rotary" if kind == "linear" else "linear"
    for key in raw:
        if key in _KIND_KEYS[other]:
            mine = sorted(_KIND_KEYS[kind])
            what = "a rotary drive's" if other == "rotary" else "a linear actuator's"
            this = 'kind = "rotary"' if kind == "rotary" else "a linear actuator"
            v.fail(pre + key, f"is {what} key; this table is {this} (keys {', '.join(mine)})")
    v.unknown(raw, _ACT_KEYS | _KIND_KEYS[kind], pre)
    m = v.number(raw, "mass_kg", pre, nonneg=True)
    if kind == "rotary":
        k = v.number(raw, "stiffness_nmm_per_rad", pre, positive=True)
        tmax = v.number(raw, "max_torque_nmm", pre, default=None, positive=True)
        qlo = v.number(raw, "min_angle_deg", pre, default=None)
        qhi = v.number(raw, "max_angle_deg", pre, default=None)
        if qlo is not None and qhi is not None and qlo > qhi:
            v.fail(pre + "min_angle_deg", f"{qlo} exceeds max_angle_deg {qhi}")
        return RotaryDrive(k, m, tmax, qlo, qhi)
    k = v.number(raw, "stiffness_n_per_mm", pre, positive=True)
    lo = v.number(raw, "min_length_mm", pre, default=None, positive=True)
    hi = v.number(raw, "max_length_mm", pre, default=None, positive=True)
    if lo is not None and hi is not None and lo > hi:
        v.fail(pre + "min_length_mm", f"{lo} exceeds max_length_mm {hi}")
    fmax = v.number(raw, "max_force_n", pre, default=None, positive=True)
    return Actuator(k, m, lo, hi, fmax)


def read_effects(
    v: Validator, raw: Any, kinds: tuple[str, ...]
) -> tuple[tuple[Effect, ...], tuple[float | None, ...], tuple[EffectMark | None, ...]]:
    """The ``[[effect]]`` tables: validated effects (each at a joint of its kind of drive),
    their optional standard errors and marks of what the data did not determine."""
    n = len(kinds)
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
            check_kinds([e], kinds)
        except EffectError as exc:
            v.fail(f"{pre}.at", str(exc))
        if any(p.key == e.key for p in effects):
            v.fail(f"{pre}.at", f"{e.key} is given twice")
        effects.append(e)
        errs.append(v.number(table, "stderr", pre + ".", default=None, nonneg=True))
        marks.append(_mark(v, table, pre))
    return tuple(effects), tuple(errs), tuple(marks)


def _mark(v: Validator, table: Mapping[str, Any], pre: str) -> EffectMark | None:
    """An ``[[effect]]`` table's ``determined``, ``bound`` and ``limit`` keys."""
    if not any(k in table for k in _MARK_KEYS):
        return None
    det = table.get("determined", True)
    if not isinstance(det, bool):
        v.fail(f"{pre}.determined", f"must be true or false, got {short(det)}")
    bound = table.get("bound")
    if bound is not None and bound not in BOUNDS:
        v.fail(f"{pre}.bound", f'must be "lower" or "upper", got {short(bound)}')
    limit = v.number(table, "limit", pre + ".", default=None, positive=True)
    if (bound is None) != (limit is None):
        v.fail(f"{pre}.{'limit' if limit is None else 'bound'}", "bound and limit go together")
    if bound is not None and det:
        v.fail(f"{pre}.determined", "a value given only by a bound is not determined")
    return None if det else EffectMark(False, bound, limit)


def read_fit(v: Validator, raw: Any, effects: tuple[Effect, ...]) -> FitRecord:
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
                    f"fit.covariance[{i + 1}][{j + 1}]", f"must be a finite number, got {short(x)}"
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
            v.fail(f"fit.{key}", f"must be a string, got {short(val)}")
        texts[key] = val
    chi = v.number(raw, "chi2_per_dof", "fit.", default=math.nan, nonneg=True)
    nv = raw.get("n_values", 0)
    if isinstance(nv, bool) or not isinstance(nv, int) or nv < 0:
        v.fail("fit.n_values", f"must be a non-negative integer, got {short(nv)}")
    explained = raw.get("explained")
    if explained is not None and not isinstance(explained, bool):
        v.fail("fit.explained", f"must be true or false, got {short(explained)}")
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


class Validator:
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
            self.fail(key, f"must be a number, got {short(val)}")
        try:
            x = float(val)
        except OverflowError:
            self.fail(key, f"the number {short(val)} is too large")
        if not math.isfinite(x):
            self.fail(key, f"must be finite, got {val!r}")
        return x

    def pin(
        self, table: Mapping[str, Any], key: str, prefix: str, used: bool, what: str, joint: int
    ) -> Point | None:
        """A pin of a linear actuator: required when ``used`` (joint ``joint``, 1-based, is
        linear); otherwise ignored with a warning naming it (the joint has a rotary drive)."""
        if used:
            if key not in table:
                self.fail(prefix + key, f"missing: {what} (joint {joint} is a linear actuator)")
            return tuple(self.point(table, key, prefix))
        if key in table:
            self.warn(
                prefix + key,
                f"is ignored: joint {joint} is turned by a rotary drive, no actuator uses the pin",
            )
        return None

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
            self.fail(prefix + key, f"must be a pair of numbers [x, y], got {short(val)}")
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
