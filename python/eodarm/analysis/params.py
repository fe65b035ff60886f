"""A fit's parameters by name, as lmfit users expect them: ``fit.params["mount_compliance@M1:
stiffness_n_per_mm"].value``, with the standard error, the 95 % interval, the unit and whether
the data determined the value (docs/python.md).

:class:`Params` is a read-only ordered mapping name → :class:`Param`; both have a short
``repr`` and a notebook table (``_repr_html_``). :class:`ChannelRms` is a fit's RMS per
channel, a dict that can still be called as the method it once was.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from eodarm import reprs
from eodarm import text as fmt

__all__ = ["ChannelRms", "Param", "Params"]

#: Where a parameter known only by a bound has it: ``"lower"`` (a stiffness of at least the
#: interval's low end; rigid is possible) or ``"upper"`` (at most its high end; absent is
#: possible). The same words as the fitted arm file's ``bound`` key (docs/formats.md).
BOUNDS = ("lower", "upper")


@dataclass(frozen=True)
class Param:
    """One fitted parameter, in the unit of its effect's parameter.

    Attributes
    ----------
    name : ``"effect@place:parameter"`` (``"joint_clearance@O2:clearance_mm"``), the key of
        the fitted arm file's ``[fit].parameters``.
    value : the estimate (``inf`` for a stiffness fitted as rigid).
    stderr : its standard error (delta method through the fitted θ; ``inf`` or NaN where the
        data do not determine it).
    interval : the 95 % interval (low, high), never across a physical bound (a stiffness in
        (0, ∞], a gap ≥ 0).
    unit : the parameter's unit (``"N/mm"``, ``"mm"``, …).
    determined : False when the data do not pin the value down: relative standard error
        above 100 %, a correlation beyond ±0.95 with another parameter, or the estimate
        stuck at a physical bound.
    bound : when not determined but the 95 % interval reaches the effect's absent end:
        ``"lower"`` (only ``interval[0]`` is known: a stiffness of at least that) or
        ``"upper"`` (only ``interval[1]``: at most that); None otherwise. ``eodarm fit -o``
        and :meth:`FitResult.to_arm <eodarm.analysis.fit.FitResult.to_arm>` fix such a
        parameter at that end (rigid, absent) and write the bound.
    """

    name: str
    value: float
    stderr: float
    interval: tuple[float, float]
    unit: str
    determined: bool = True
    bound: str | None = None

    def __repr__(self) -> str:
        return f"<Param {self.name} = {self.text()}>"

    def text(self) -> str:
        """The value as a person reads it: ``2498 ± 2.6 N/mm``, a bound as ``≥ 1.9×10⁴
        N/mm (95 %)``, an undetermined value marked."""
        lo, hi = self.interval
        if self.bound == "lower":
            return f"≥ {fmt.value(lo, self.unit, 3)} (95 %; only a bound)"
        if self.bound == "upper":
            return f"≤ {fmt.value(hi, self.unit, 3)} (95 %; only a bound)"
        text = fmt.value_error(self.value, self.stderr, self.unit)
        return text if self.determined else f"{text} (not determined)"

    def _row(self) -> list[str]:
        lo, hi = self.interval
        return [
            self.name,
            fmt.value_error(self.value, self.stderr, self.unit),
            fmt.bounded_interval(lo, hi, self.unit, self.stderr),
            "yes" if self.determined else f"no ({self.bound} bound)" if self.bound else "no",
        ]

    def _repr_html_(self) -> str:
        return reprs.html_table(_HEADERS, [self._row()])


_HEADERS = ("parameter", "value ± standard error", "95 % interval", "determined")


class Params(Mapping[str, Param]):
    """The fitted parameters in the fit's order: a read-only mapping name → :class:`Param`.

    ``params["joint_clearance@O2:clearance_mm"].value``, ``for name, p in params.items()``,
    :meth:`valuesdict` (name → value, as lmfit's).
    """

    def __init__(self, params: Iterable[Param]) -> None:
        self._by_name = {p.name: p for p in params}

    def __getitem__(self, name: str) -> Param:
        try:
            return self._by_name[name]
        except KeyError:
            known = ", ".join(self._by_name) or "none"
            raise KeyError(f"no fitted parameter {name!r}; fitted: {known}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._by_name)

    def __len__(self) -> int:
        return len(self._by_name)

    def valuesdict(self) -> dict[str, float]:
        """name → value (lmfit's name for it)."""
        return {k: p.value for k, p in self._by_name.items()}

    def lines(self) -> list[str]:
        """One line per parameter: ``name = value ± error unit``."""
        width = max((len(k) for k in self._by_name), default=0)
        return [f"{k:<{width}}  {p.text()}" for k, p in self._by_name.items()]

    def __repr__(self) -> str:
        return reprs.block(f"Params: {len(self)} fitted", self.lines())

    def html(self, caption: str | None = None) -> str:
        """The parameters as a small HTML table (the notebook's view), under ``caption``."""
        rows = [p._row() for p in self._by_name.values()]
        return reprs.html_table(
            _HEADERS, rows, f"{len(self)} fitted" if caption is None else caption
        )

    def _repr_html_(self) -> str:
        return self.html()


class ChannelRms(dict[str, float]):
    """RMS residual per measured channel (mm or deg), a dict.

    ``fit.rms`` is this dict; calling it, ``fit.rms()``, is the older spelling and gives the
    same numbers, and ``fit.rms(rows)`` the RMS over a boolean mask of rows.
    """

    def __init__(
        self,
        values: Mapping[str, float],
        over: Callable[[Any], dict[str, float]] | None = None,
    ) -> None:
        super().__init__(values)
        self._over = over

    def __call__(self, rows: Any = None) -> dict[str, float]:
        if rows is None or self._over is None:
            return dict(self)
        return self._over(rows)

    def items_text(self) -> list[str]:
        """``["dx 0.019 mm", "dy 0.021 mm", "dalpha1 0.02 deg"]``."""
        return [
            f"{ch.rsplit('_', 1)[0]} {fmt.value(v, ch.rsplit('_', 1)[1], 3)}"
            for ch, v in self.items()
            if math.isfinite(v)
        ]

    def line(self) -> str:
        """``dx 0.019 mm, dy 0.021 mm, dalpha1 0.02 deg``."""
        return ", ".join(self.items_text())
