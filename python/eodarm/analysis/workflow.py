"""The whole investigation: diagnose, add what is missing, diagnose again, until explained.

A single diagnosis searches sets of up to three effects. A real arm can miss more than that
at once (the seed arm: three actuator bodies far stiffer than modelled, *and* compliance in
their three mounts), and the sensible procedure is the engineer's: add the suggested set,
refit, and ask again. :func:`investigate` does that for a few rounds and keeps the ladder of
models with their in-sample and cross-validated errors.

Every decision is the one rule of :func:`eodarm.analysis.acceptance.accept`, as the
diagnosis made it: a round whose verdict is *missing* adds its suggested set; a round whose
verdict is *unexplained* adds its best effort only when the rule finds that it *improves*
the model (away from its bounds, held-out configurations predicted no worse, lower BIC,
every added parameter determined by the data), and otherwise the investigation stops and
says why.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from eodarm.analysis.acceptance import Acceptance, held_out
from eodarm.analysis.diagnose import Diagnosis, diagnose
from eodarm.analysis.fit import FitResult
from eodarm.data.measurements import Measurements
from eodarm.model.arm import Arm
from eodarm.model.effects import Slot

__all__ = ["Investigation", "investigate"]


@dataclass
class Investigation:
    """Rounds of diagnosis and the resulting ladder of models."""

    rounds: list[Diagnosis]
    steps: list[dict[str, Any]] = field(default_factory=list)
    stopped: str = ""

    @property
    def final_model(self) -> list[Slot]:
        last = self.steps[-1] if self.steps else None
        return [Slot.parse(k) for k in last["effects"]] if last else []

    @property
    def final_fit(self) -> FitResult:
        return self.steps[-1]["fit"]


def investigate(
    arm: Arm,
    meas: Measurements,
    model: Sequence[Slot | str] = (),
    self_weight: bool = True,
    max_rounds: int = 3,
    cv: bool = True,
    solver_model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
    on_round: Callable[[int], None] | None = None,
) -> Investigation:
    """Diagnose; while something is missing, add the suggested set and diagnose again.

    A round with the verdict *missing* adds its suggested set. A round with the verdict
    *unexplained* adds its best effort (the set the BIC prefers) only if the rule of
    :func:`~eodarm.analysis.acceptance.accept` finds that it improves the model: every
    parameter away from its bounds, held-out configurations (≥ 3) predicted no worse, a
    lower BIC, and every added parameter determined by the data. The investigation stops
    when the verdict is *adequate* or *check_data* (the data look mistaken: nothing is
    looked for in them), when an unexplained round has nothing that improves the
    model (the reason is in ``stopped``), or after ``max_rounds``. Each step of the ladder is
    the round's own joint fit of all its effects, with its leave-one-configuration-out
    cross-validation when ``cv`` and there are two or more configurations.

    ``solver_model`` (``"analytic"`` or ``"fem"``) and ``fem_options`` choose the model that
    predicts the channels in every diagnosis, fit and cross-validation, as in
    :func:`eodarm.diagnose` (``model`` is the list of effects already in the model).
    ``on_round(k)``, when given, is called as round ``k`` (1-based) begins (progress).
    """
    current = [Slot.of(s) for s in model]
    do_cv = cv and len(meas.configs) >= 2
    rounds: list[Diagnosis] = []
    steps: list[dict[str, Any]] = []

    def step(label: str, res: FitResult, cvr: Mapping[str, Any] | None) -> dict[str, Any]:
        if do_cv and cvr is None:
            cvr = held_out(res)
        cv_chi2 = math.nan
        if cvr is not None:
            use = res.problem.use
            z = cvr["residual"][use] / meas.sigma[use]
            cv_chi2 = float(np.nansum(z**2))
        return {
            "label": label,
            "effects": [s.key for s in res.slots],
            "rms": dict(res.rms),
            "cv_rms": dict(cvr["rms"]) if cvr else None,
            "cv": cvr if do_cv else None,
            "cv_chi2": cv_chi2,
            "chi2_per_dof": res.chi2_per_dof,
            "fit": res,
            "warnings": list(res.warnings),
        }

    stopped = f"the limit of {max_rounds} rounds was reached"
    for k in range(max_rounds):
        if on_round is not None:
            on_round(k + 1)
        d = diagnose(
            arm,
            meas,
            current,
            self_weight=self_weight,
            solver_model=solver_model,
            fem_options=fem_options,
        )
        rounds.append(d)
        if not steps:
            label = "baseline" if not current else "model: " + ", ".join(s.key for s in current)
            steps.append(step(label, d.baseline, _baseline_cv(d)))
        if d.verdict == "adequate":
            stopped = "the model explains the data within their noise"
            break
        if d.verdict == "check_data":
            stopped = (
                "the data look mistaken (a unit, a sign or a zeroing): check them first; "
                "no effect is looked for in them"
            )
            break
        acc = d.acceptance
        if d.verdict == "missing" and acc is not None:
            label = "+ " + " + ".join(s.key for s in d.suggested)
        elif acc is None or not d.best_effort:
            stopped = (
                "no effect of the catalogue explains these data, and no set of them lowers the BIC"
            )
            break
        elif not acc.improves:
            stopped = _why_not(acc)
            break
        else:
            label = "+ " + " + ".join(s.key for s in d.best_effort) + " (best effort)"
        steps.append(step(label, acc.fit, acc.cv))
        current = list(acc.fit.slots)
    return Investigation(rounds, steps, stopped)


def _baseline_cv(d: Diagnosis) -> Mapping[str, Any] | None:
    """The baseline's cross-validation, where the diagnosis already made it."""
    for a in d.examined:
        if a.baseline_cv is not None:
            return a.baseline_cv
    if d.acceptance is not None and d.acceptance.baseline_cv is not None:
        return d.acceptance.baseline_cv
    if d.verdict == "unexplained" and not d.best_effort:
        return d.best_effort_cv
    return None


def _why_not(acc: Acceptance) -> str:
    """Why an unexplained round's best effort is not added, in a sentence."""
    keys = ", ".join(acc.keys)
    why = []
    if acc.stuck:
        why.append(f"{', '.join(acc.stuck)} sit at a bound")
    if acc.predicts is False and acc.cv is not None and acc.baseline_cv is not None:
        why.append(
            "it would predict held-out configurations worse (held-out RMS/σ "
            f"{acc.cv['z_rms']:.3g} against {acc.baseline_cv['z_rms']:.3g} without it)"
        )
    if acc.undetermined:
        why.append(f"the data do not determine {', '.join(acc.undetermined)}")
    if not why:
        why.append("it does not lower the BIC")
    return (
        f"no effect of the catalogue explains these data, and the best effort, {keys}, "
        "does not improve the model: " + "; ".join(why)
    )
