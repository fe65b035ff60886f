"""Planning a campaign: where to measure so that the missing effect can be named
(docs/plan.md).

:func:`plan` chooses K configurations among those the arm can reach that maximise the weakest
separation between two candidate effects while every candidate's parameter is determined;
the modules split the job: :mod:`.pool` (the configurations and their states),
:mod:`.candidates` and :mod:`.sizes` (what is looked for, and how large),
:mod:`.signatures` (what each candidate does to the channels), :mod:`.separation` (how well
states tell two apart), :mod:`.selection` (greedy and exchanges), :mod:`.planner` (the
stages) and :mod:`.result` (what a plan says).
"""

from eodarm.analysis.plan.candidates import Candidate, CandidateSpec, parse_candidates
from eodarm.analysis.plan.planner import plan
from eodarm.analysis.plan.pool import DEFAULT_CYCLE, Payloads
from eodarm.analysis.plan.result import Plan

__all__ = [
    "DEFAULT_CYCLE",
    "Candidate",
    "CandidateSpec",
    "Payloads",
    "Plan",
    "parse_candidates",
    "plan",
]
