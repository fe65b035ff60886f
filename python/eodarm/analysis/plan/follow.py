"""The measurement that follows a diagnosis whose leading candidates the data cannot tell
apart: a plan of a few configurations added to the campaign, for those candidates at the
sizes the diagnosis fitted (docs/plan.md, "After a diagnosis").

``diagnose`` proposes the whole plan on its ``next:`` line (``eodarm plan --fixed``); the
report shows this one in its "next measurement" section.
"""

from __future__ import annotations

import math

from eodarm.analysis.diagnose import Diagnosis
from eodarm.analysis.plan.candidates import CandidateSpec
from eodarm.analysis.plan.planner import plan
from eodarm.analysis.plan.pool import payloads_of
from eodarm.analysis.plan.result import Plan
from eodarm.errors import EodarmError

__all__ = ["FOLLOW_CONFIGS", "FOLLOW_POOL", "confused_lead", "follow_up"]

#: Configurations a follow-up adds.
FOLLOW_CONFIGS = 3
#: Reachable configurations drawn for a follow-up (a few candidates: a small pool will do).
FOLLOW_POOL = 200


def confused_lead(d: Diagnosis) -> list[CandidateSpec]:
    """The leading candidates the data cannot tell apart, each at its fitted size alone (its
    typical size where that fit left it absent): the first suggested effect that has
    alternatives in its set and those alternatives, else the best single candidate and those
    it is confused with; empty when neither is confused, or when the verdict is not
    *missing* or *unexplained* (nothing to tell apart, or the data to check first)."""
    if d.verdict not in ("missing", "unexplained") or not d.ranking:
        return []
    alts = d.alternatives
    lead = next(([s, *alts[s]] for s in (x.spec for x in d.suggested) if alts.get(s)), None)
    if lead is None:
        if not d.ranking[0].confused_with:
            return []
        lead = [d.ranking[0].slot.spec, *d.ranking[0].confused_with]
    by_spec = {c.slot.spec: c for c in d.ranking}
    out = []
    for spec in lead:
        cand = by_spec.get(spec)
        if cand is None:
            continue
        value = cand.fit.estimate(cand.fit.slots.index(cand.slot))
        kind = cand.slot.kind
        ok = math.isfinite(value) and value > 0 and kind.value_error(value) is None
        out.append(CandidateSpec(cand.slot, value if ok else None))
    return out


def follow_up(
    d: Diagnosis, configs: int = FOLLOW_CONFIGS, pool: int = FOLLOW_POOL, seed: int = 0
) -> Plan | None:
    """``configs`` configurations that, added to the diagnosed data (same payloads, same
    channels and noise), tell the leading candidate from those it is confused with; None
    when it is not confused or no plan can be made (too few reachable configurations)."""
    specs = confused_lead(d)
    if len(specs) < 2:
        return None
    prob = d.baseline.problem
    try:
        return plan(
            prob.arm,
            configs,
            masses_kg=payloads_of(prob.meas).masses_kg,
            sequence=prob.meas.has_sequences,
            candidates=specs,
            fixed=prob.meas,
            seed=seed,
            pool=pool,
            self_weight=prob.self_weight,
        )
    except EodarmError:
        return None
