"""The diagnosis's judgements in the words of docs/seed-reproduction.md: why the acceptance
rule refuses a set, the sentence on a diagnosis's best candidate, and the rule's judgement of
a set. Shared by scripts/seed_reproduction.py (§4, §5) and scripts/seed_investigation.py
(§6), below both, so that neither imports the other back.
"""

from __future__ import annotations

from typing import Any

#: The criteria of the acceptance rule in the order of ``Acceptance.reasons()``: (a), (b), (c).
CRITERIA = ("noise", "bounds", "held_out")


def refusal(acc: Any) -> str:
    """Why the acceptance rule refuses a set, in the tool's own words.

    The phrases of ``acc.reasons()`` (one per criterion, (a), (b), (c) in that order) of the
    criteria listed in ``acc.failed``, then the members whose parameter the data do not
    determine (``acc.undetermined``: relative standard error above 100 %), which keeps a set
    from counting as an improvement (docs/diagnosis.md, the acceptance rule).
    """
    phrases = acc.reasons()
    out = [phrases[CRITERIA.index(c)] for c in acc.failed]
    if acc.undetermined:
        out.append(f"the data do not determine {', '.join(acc.undetermined)}")
    return "; ".join(out) if out else "; ".join(phrases)


def best_candidate(key: str, delta_chi2: float, threshold: float, n: int, acc: Any) -> str:
    """The sentence on the best single candidate of a diagnosis: its χ² drop against the
    significance threshold the diagnosis used (``Diagnosis.significance``) and, when the drop
    is beyond it, why the rule still refuses it (``acc``: the rule's judgement of that single
    candidate, from ``Diagnosis.examined``; ``None`` when the rule did not judge it)."""
    test = (
        f"the {threshold:.1f} that the diagnosis requires of a real effect (the 0.1 % "
        f"likelihood-ratio threshold, Bonferroni-corrected for {n} candidates, or the BIC "
        "penalty ln N where larger; docs/diagnosis.md)"
    )
    head = f"the best candidate, {key}, lowers χ² by {delta_chi2:.1f}"
    if delta_chi2 <= threshold:
        return f"{head}, short of {test}"
    if acc is None:
        return f"{head}, beyond {test}; the rule did not judge it alone"
    if acc.accepted:
        return f"{head}, beyond {test}, and the acceptance rule accepts it"
    return f"{head}, beyond {test}, yet the acceptance rule refuses it: {refusal(acc)}"


def judged(d: Any, keys: list[str]) -> Any:
    """The rule's judgement of the set ``keys`` in a diagnosis, or ``None`` if not judged."""
    return next((a for a in d.examined if a.keys == keys), None)
