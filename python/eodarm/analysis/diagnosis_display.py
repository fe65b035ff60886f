"""How a diagnosis shows in a shell or a notebook: the verdict and the set it names, the
baseline, the best candidates, in a few lines (``repr``) or a small table (``_repr_html_``),
never the fits inside (docs/python.md).

The diagnosis, its candidates and the rule's judgements are read by their attributes rather
than imported, because :mod:`eodarm.analysis.diagnose` and
:mod:`eodarm.analysis.acceptance` call these functions.
"""

from __future__ import annotations

import math
from typing import Any

from eodarm import reprs
from eodarm import text as fmt

__all__ = [
    "RANKED",
    "acceptance_repr",
    "candidate_repr",
    "diagnosis_html",
    "diagnosis_repr",
]

#: Candidates shown: the best of the ranking.
RANKED = 5


def _chi2(fit: Any) -> str:
    return f"χ²/dof {fmt.value(fit.chi2_per_dof, digits=3)}"


def _estimate(cand: Any) -> str:
    i = cand.fit.slots.index(cand.slot)
    return fmt.value_error(cand.fit.estimate(i), cand.fit.stderr(i), cand.slot.kind.unit)


def verdict_line(diag: Any) -> str:
    """``missing: a + b (χ²/dof 1.02)``, ``adequate (χ²/dof 0.98)`` or ``unexplained: …``."""
    if diag.verdict == "missing":
        named = " + ".join(s.spec for s in diag.suggested)
        fit = diag.suggested_fit or diag.baseline
        return f"missing: {named} ({_chi2(fit)})"
    if diag.verdict == "unexplained":
        best = " + ".join(s.spec for s in diag.best_effort) or "the baseline"
        fit = diag.best_effort_fit or diag.baseline
        return (
            "unexplained: no set of up to three catalogue effects explains the data; best "
            f"effort {best} ({_chi2(fit)})"
        )
    if diag.verdict == "check_data":
        k = len(diag.data_checks)
        return f"check_data: the data look mistaken ({k} check{'s' * (k != 1)}); nothing searched"
    return f"{diag.verdict}: the model explains its data ({_chi2(diag.baseline)})"


def candidate_repr(cand: Any) -> str:
    confused = f", confused with {', '.join(cand.confused_with)}" if cand.confused_with else ""
    return (
        f"<Candidate {cand.slot.spec} = {_estimate(cand)}, {_chi2(cand.fit)}, "
        f"Δχ² {fmt.value(cand.delta_chi2, digits=3)}{confused}>"
    )


def acceptance_repr(acc: Any) -> str:
    named = " + ".join(s.spec for s in acc.added) or "nothing added"
    return (
        f"<Acceptance {named}: {'accepted' if acc.accepted else 'not accepted'} "
        f"({fmt.p_value(acc.p_value)}, stuck {list(acc.stuck)}, "
        f"predicts held-out {acc.predicts})>"
    )


def diagnosis_repr(diag: Any) -> str:
    model = " + ".join(s.spec for s in diag.model) or "baseline"
    lines = [
        f"model: {model}, {_chi2(diag.baseline)}, {fmt.p_value(diag.p_baseline)}",
        f"ranking ({len(diag.ranking)} candidates, {diag.sets_searched} sets searched), best:",
    ]
    for c in diag.ranking[:RANKED]:
        lines.append(f"  {c.slot.spec} = {_estimate(c)}, {_chi2(c.fit)}")
    if diag.verdict == "check_data":
        lines = [lines[0], *(f"check the data: {c.message}" for c in diag.data_checks)]
    if diag.outliers:
        lines.append(f"outliers left out: {len(diag.outliers)} cells")
    return reprs.block(f"Diagnosis: {verdict_line(diag)}", lines)


def diagnosis_html(diag: Any) -> str:
    rows = [
        [
            c.slot.spec,
            _estimate(c),
            fmt.value(c.fit.chi2_per_dof, digits=3),
            fmt.value(c.delta_chi2, digits=3) if math.isfinite(c.delta_chi2) else "—",
            ", ".join(c.confused_with),
        ]
        for c in diag.ranking
    ]
    if diag.verdict == "check_data":
        rows = [["", c.message, "", "", ""] for c in diag.data_checks]
    headers = ["candidate", "estimate", "χ²/dof", "Δχ²", "confused with"]
    return reprs.html_table(headers, rows, f"Diagnosis: {verdict_line(diag)}", limit=10)
