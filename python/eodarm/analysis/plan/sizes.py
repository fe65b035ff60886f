"""The typical size of a candidate: how large a missing effect a plan should be able to name.

A size that is a fixed number (0.1 mm of play, 1000 N/mm of mount) would be invisible on a
crane and enormous on a desk arm. The sizes here are set by the arm itself, at the reachable
configurations of the plan's pool under its heaviest planned payload m (docs/plan.md):

* **an elastic effect or a gap** (every effect whose response is linear in its parameter, and
  a user-written effect): the size at which the effect alone moves the measure point by
  :data:`SAG_FRACTION` (a quarter) of the arm's own elastic sag there, RMS over the pool. The
  seed paper's models missed 3 mm of a 12–15 mm sag; a quarter is the missing effect that
  matters;
* **a friction**: the limit at which it holds :data:`FRICTION_FRACTION` (a tenth) of what it
  would hold if it held everything, RMS over the pool: loaded once, a friction of limit L
  holds min(L, |ΔF|) of a force change ΔF, so its limit is a tenth of the force (or torque)
  change that m makes at its place, as measured by the arm's own response.

The response is solved, not assumed: the size is found by a few secant steps (elastic) or by
bisection (friction) on the exact model.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from eodarm.analysis.plan.candidates import Candidate, CandidateSpec, theta_of
from eodarm.analysis.plan.pool import Payloads, states_of
from eodarm.analysis.plan.signatures import StateSet
from eodarm.analysis.sensitivity import step
from eodarm.analysis.sequences import FRICTIONS
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Slot

__all__ = ["FRICTION_FRACTION", "SAG_FRACTION", "size_candidates"]

FloatArray = npt.NDArray[np.float64]

#: An elastic effect or a gap at its typical size moves the measure point by this fraction of
#: the arm's own sag under the heaviest payload (RMS over the pool).
SAG_FRACTION = 0.25
#: A friction at its typical size holds this fraction of the force (torque) change of the
#: heaviest payload at its place.
FRICTION_FRACTION = 0.1


def _rms_motion(y: FloatArray) -> float:
    """RMS over states of the measure point's displacement |(dx, dy)| (mm); the states the
    model cannot solve (NaN) left out."""
    sq = y[:, 0] ** 2 + y[:, 1] ** 2
    sq = sq[np.isfinite(sq)]
    return float(np.sqrt(np.mean(sq))) if sq.size else math.nan


def size_candidates(
    arm: Arm,
    specs: Sequence[CandidateSpec],
    pool: FloatArray,
    payloads: Payloads,
    self_weight: bool,
) -> list[Candidate]:
    """Every candidate at its size: the given one, or the typical one (module notes).

    Raises
    ------
    EodarmError
        One line naming a candidate whose given size is the arm file's own value, or whose
        effect does not move the measure point under the planned payloads (its size must be
        given).
    """
    heavy = Payloads((payloads.heaviest,), sequence=False)
    states = StateSet(arm, states_of(arm, pool, heavy), self_weight)
    fixed = {s.key: th for s, th in states.prob.fixed}
    sag = _rms_motion(states.y0)  # the baseline's own sag (loaded minus unloaded)
    out = []
    for spec in specs:
        slot = spec.slot
        neutral = fixed.get(slot.key, states.prob.neutral(slot))
        if spec.value is not None:
            theta = theta_of(spec)
            if theta == neutral:
                raise EodarmError(
                    f"--candidates {slot.spec}={spec.value:g}: that is the arm file's own value "
                    "(no effect); give another size"
                )
            out.append(Candidate.make(slot, neutral, theta, given=True))
            continue

        if slot.unloaded != "centred":
            # A gap taken up when unloaded shows only where the force turns; it is the same
            # gap as the centred one: the same size.
            centred = Slot(slot.name, slot.at)
            twin = next((c for c in out if c.slot == centred), None)
            delta = (
                twin.delta
                if twin is not None
                else _typical(states, arm, centred, neutral, SAG_FRACTION * sag)
            )
        else:
            delta = _typical(states, arm, slot, neutral, SAG_FRACTION * sag)
        out.append(Candidate.make(slot, neutral, neutral + delta, given=False))
    return out


def _typical(states: StateSet, arm: Arm, slot: Slot, neutral: float, target: float) -> float:
    """θ − neutral of a candidate's typical size (module notes); ``target`` the motion of
    an elastic effect's size (mm, RMS)."""

    def motion(t: float) -> float:
        return _rms_motion(states.response(slot, neutral + t, nan_on_failure=True))

    if slot.name in FRICTIONS:
        return _friction_size(motion, slot)
    return _elastic_size(motion, arm, slot, neutral, target)


def _elastic_size(
    motion: Callable[[float], float], arm: Arm, slot: Slot, neutral: float, target: float
) -> float:
    """θ − neutral at which ``motion`` reaches ``target`` (secant steps on the exact model,
    within the parameter's bounds)."""
    lo, hi = (b - neutral for b in slot.kind.theta_bounds)
    t = 0.1 * abs(step(arm, slot, neutral)) / 1e-4  # a tenth of the parameter's scale
    t = min(t, 0.5 * hi) if math.isfinite(hi) else t
    for _ in range(6):
        m = motion(t)
        if not (math.isfinite(m) and m > 0):
            raise EodarmError(
                f"candidate {slot.spec}: it does not move the measure point under the planned "
                "payloads; give its size as EFFECT@PLACE=VALUE"
            )
        new = t * target / m
        new = min(max(new, lo), hi)
        if abs(new - t) <= 1e-3 * abs(t):
            return new
        t = new
    return t


def _friction_size(motion: Callable[[float], float], slot: Slot) -> float:
    """The limit at which a friction holds FRICTION_FRACTION of what it holds when it holds
    everything (bisection on the exact model)."""
    from eodarm.analysis.sequences import friction_step

    t = friction_step(slot, 0.0) / 0.05  # its typical limit
    full = motion(t)
    for _ in range(80):  # double until it holds every force change
        more = motion(2 * t)
        if more <= full * (1 + 1e-9):
            break
        t, full = 2 * t, more
    if not (math.isfinite(full) and full > 0):
        raise EodarmError(
            f"candidate {slot.spec}: the planned payloads do not load it; give its size as "
            "EFFECT@PLACE=VALUE"
        )
    a, b = 0.0, 2 * t
    goal = FRICTION_FRACTION * full
    for _ in range(60):
        mid = 0.5 * (a + b)
        if motion(mid) < goal:
            a = mid
        else:
            b = mid
        if b - a <= 1e-4 * b:
            break
    return 0.5 * (a + b)
