"""The candidates of a plan: every effect × place that ``diagnose`` would rank, each at a size.

A candidate is a :class:`~eodarm.model.effects.Slot` (an effect, a place and, for a gap, its
unloaded mode) with the value of its fitted parameter θ (docs/diagnosis.md, "Parameters that
make fitting well posed") where the effect is absent (*neutral*: 0, the arm file's ``1/k``
for an actuator body, or the arm file's own value of that effect) and where it is at its
*size*: given by the user (``EFFECT@PLACE=VALUE``, in the parameter's unit) or the typical
size of :mod:`eodarm.analysis.plan.sizes`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from eodarm.analysis.diagnose import all_slots
from eodarm.analysis.sequences import FRICTIONS
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Slot, check_kinds, kind_of, param_from_theta, theta_from_param

__all__ = ["Candidate", "CandidateSpec", "candidate_specs", "parse_candidates"]

#: The sample values of a curve's parameter, in multiples of its size (beyond the bounds
#: they are dropped): dense around the size, where its slope is taken (0.95, 1.05), and out
#: to where a friction holds every force change of the campaign.
CURVE_SAMPLES = (
    0.0,
    0.1,
    0.25,
    0.5,
    0.75,
    0.95,
    1.0,
    1.05,
    1.25,
    1.5,
    2.0,
    3.0,
    4.0,
    6.0,
    8.0,
    12.0,
    16.0,
    24.0,
    32.0,
)


@dataclass(frozen=True)
class CandidateSpec:
    """A candidate as asked for: its slot and, when given, its size (parameter unit)."""

    slot: Slot
    value: float | None = None

    @property
    def spec(self) -> str:
        return self.slot.spec


@dataclass(frozen=True)
class Candidate:
    """A candidate at its size.

    Attributes
    ----------
    slot : the effect, place and gap mode.
    neutral : θ where the effect is as the arm file has it (absent, or the file's value).
    theta : θ at the size.
    given : the size was given by the user.
    curve : fitted as a sampled curve (frictions, user-written effects) rather than a ray.
    samples : θ − neutral at the samples of its response; the first is 0.
    """

    slot: Slot
    neutral: float
    theta: float
    given: bool
    curve: bool
    samples: tuple[float, ...]

    @classmethod
    def make(cls, slot: Slot, neutral: float, theta: float, given: bool) -> Candidate:
        """A candidate with its samples (a ray: neutral and size; a curve:
        :data:`CURVE_SAMPLES` within the parameter's bounds)."""
        curve = slot.name in FRICTIONS or slot.kind.custom
        delta = theta - neutral
        if not curve:
            return cls(slot, neutral, theta, given, False, (0.0, delta))
        lo, hi = slot.kind.theta_bounds
        ts = [m * delta for m in CURVE_SAMPLES]
        if lo < neutral and delta > 0:  # a user effect may go below its neutral value
            ts = [-m * delta for m in reversed(CURVE_SAMPLES[1:])] + ts
        ts = [t for t in ts if lo <= neutral + t <= hi]
        return cls(slot, neutral, theta, given, True, tuple(ts))

    @property
    def delta(self) -> float:
        """θ at the size minus θ neutral."""
        return self.theta - self.neutral

    @property
    def value(self) -> float:
        """The size in the parameter's unit (a stiffness for a spring)."""
        return param_from_theta(self.slot.name, self.theta)

    @property
    def at_size(self) -> int:
        """The index of the size among the samples."""
        return int(min(range(len(self.samples)), key=lambda k: abs(self.samples[k] - self.delta)))

    @property
    def spec(self) -> str:
        return self.slot.spec

    @property
    def bounds(self) -> tuple[float, float]:
        """The bounds of θ − neutral."""
        lo, hi = self.slot.kind.theta_bounds
        return lo - self.neutral, hi - self.neutral


def candidate_specs(arm: Arm, self_weight: bool = True) -> list[CandidateSpec]:
    """Every candidate ``diagnose`` ranks on this arm (its catalogue at every place, the gaps
    taken up when unloaded where the arm carries its weight, every registered user-written
    effect at every place of its kind), without sizes."""
    return [CandidateSpec(s) for s in all_slots(arm.n, taken_up=self_weight, kinds=arm.kinds)]


def parse_candidates(specs: Sequence[str], arm: Arm) -> list[CandidateSpec]:
    """``EFFECT@PLACE[=VALUE]`` (comma-separated lists too) → candidates.

    Raises
    ------
    EodarmError
        One line naming the candidate: an unknown effect or place, a place the arm does not
        have, a size that is not a valid value of the parameter, a candidate given twice.
    """
    out: list[CandidateSpec] = []
    for group in specs:
        for raw in str(group).split(","):
            text = raw.strip()
            if not text:
                continue
            head, sep, value = text.partition("=")
            try:
                slot = Slot.parse(head.strip())
                slot.index(arm.n)
                check_kinds([slot.example], arm.kinds)
            except EodarmError as exc:
                raise EodarmError(f"--candidates '{text}': {exc}") from None
            size = None
            if sep:
                try:
                    size = float(value)
                except ValueError:
                    raise EodarmError(f"--candidates '{text}': '{value}' is not a number") from None
                kind = kind_of(slot.name)
                assert kind is not None
                why = kind.value_error(size)
                if why is None and size == 0:
                    why = "must be > 0 (a candidate of size 0 is no effect)"
                if why is not None:
                    raise EodarmError(f"--candidates '{text}': {kind.param} {why}")
            if any(c.slot.key == slot.key and c.slot.unloaded == slot.unloaded for c in out):
                raise EodarmError(f"--candidates: {slot.spec} is given twice")
            out.append(CandidateSpec(slot, size))
    if len(out) < 2:
        raise EodarmError("--candidates: a plan separates candidates; give at least two")
    return out


def theta_of(spec: CandidateSpec) -> float:
    """θ of a given size."""
    assert spec.value is not None
    t = theta_from_param(spec.slot.name, spec.value)
    if not math.isfinite(t):
        raise EodarmError(f"--candidates {spec.spec}={spec.value:g}: not a finite size")
    return t
