"""The report's next measurement, planned: when the diagnosis leaves its leading candidates
confused, the configurations to add that tell them apart
(:func:`eodarm.analysis.plan.follow.follow_up`, the machinery of ``eodarm plan``)."""

from __future__ import annotations

from eodarm.analysis.diagnose import Diagnosis
from eodarm.analysis.plan.follow import FOLLOW_CONFIGS, follow_up
from eodarm.viz import html as page

__all__ = ["planned_next"]


def planned_next(d: Diagnosis) -> list[str]:
    """HTML: the planned configurations, the separation of each confused pair with the data
    alone and with them, the pairs no configuration separates with the channel that would,
    and the command of the whole plan; nothing when the leading candidate is not confused."""
    p = follow_up(d)
    if p is None:
        return []
    n = p.arm.n
    names = [c.spec for c in p.candidates]
    rows = [
        [label, *(page.Num(a, 4) for a in pose)]
        for label, pose in zip(p.labels, p.configs, strict=True)
    ]
    loads = (
        "the load cycle " + " → ".join(f"{m:g}" for m in p.payloads.masses_kg) + " kg"
        if p.payloads.sequence
        else "the payloads " + ", ".join(f"{m:g}" for m in p.payloads.masses_kg) + " kg"
    )
    out = [
        f"<p>Planned (<code>eodarm plan</code>, docs/plan.md): {FOLLOW_CONFIGS} configurations "
        f"to add, each with {page.esc(loads)}, measured on "
        f"{page.esc(', '.join(p.channels))} as now:</p>",
        page.table(["config", *(f"α{i + 1} [deg]" for i in range(n))], rows),
    ]
    before = p.before_separation
    pairs = []
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            if not p.separable[a, b]:
                continue
            was = page.num(float(before[a, b]), 3) if before is not None else "–"
            pairs.append([f"{names[a]} ~ {names[b]}", page.Num(float(p.separation[a, b]), 3), was])
    if pairs:
        out.append(
            page.table(
                ["pair", "separation χ² with them (25: separable)", "with the data alone"], pairs
            )
        )
    for a, b, ch in p.inseparable:
        how = (
            f"measure <code>{page.esc(ch)}</code>"
            if ch
            else "no channel of this arm separates them"
        )
        out.append(
            f"<p>No reachable configuration separates {page.esc(names[a])} and "
            f"{page.esc(names[b])} on these channels: {how}.</p>"
        )
    source = d.baseline.problem.meas.source
    out.append(
        '<p class="note">The whole catalogue, planned the same way: <code>eodarm plan --fixed '
        f"{page.esc(source)} --arm ARM.toml --configs {FOLLOW_CONFIGS}</code>.</p>"
    )
    return out
