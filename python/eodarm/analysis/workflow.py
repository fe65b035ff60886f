"""The whole investigation: diagnose, add what is missing, diagnose again, until explained.

A single diagnosis searches sets of up to three effects. A real arm can miss more than that
at once (the seed arm: three actuator bodies far stiffer than modelled, *and* compliance in
their three mounts), and the sensible procedure is the engineer's: add the suggested set,
refit, and ask again. :func:`investigate` does that for a few rounds and keeps the ladder of
models with their in-sample and cross-validated errors.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from eodarm.analysis.diagnose import Diagnosis, diagnose
from eodarm.analysis.fit import FitResult, FitWarning, cross_validate, fit
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


def _bic(res: FitResult) -> float:
    return res.chi2 + res.n_params * math.log(max(res.problem.n_values, 2))


def investigate(
    arm: Arm,
    meas: Measurements,
    model: Sequence[Slot | str] = (),
    self_weight: bool = True,
    max_rounds: int = 3,
    cv: bool = True,
    solver_model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
) -> Investigation:
    """Diagnose; while something is missing, add the suggested set and diagnose again.

    Stops when the verdict is *adequate*, when nothing is suggested, when the suggested set
    does not lower the BIC (χ² + k ln N), when it makes the held-out configurations worse
    (cross-validated χ², with ``cv``), or after ``max_rounds``. Every step of the ladder is
    refitted on all its effects jointly, with leave-one-configuration-out cross-validation
    when ``cv`` and there are two or more configurations.

    ``solver_model`` (``"analytic"`` or ``"fem"``) and ``fem_options`` choose the model that
    predicts the channels in every diagnosis, fit and cross-validation, as in
    :func:`eodarm.diagnose` (``model`` is the list of effects already in the model).
    """
    kw: dict[str, Any] = {"model": solver_model, "fem_options": fem_options}
    current = [Slot.of(s) for s in model]
    do_cv = cv and len(meas.configs) >= 2
    rounds: list[Diagnosis] = []
    steps: list[dict[str, Any]] = []

    def step(label: str, slots: list[Slot]) -> dict[str, Any]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)
            res = fit(arm, meas, slots, self_weight=self_weight, **kw)
            cvr = cross_validate(arm, meas, slots, self_weight=self_weight, **kw) if do_cv else None
        cv_chi2 = math.nan
        if cvr is not None:
            z = cvr["residual"] / meas.sigma
            cv_chi2 = float(np.nansum(z[res.problem.use] ** 2))
        return {
            "label": label,
            "effects": [s.key for s in slots],
            "rms": res.rms(),
            "cv_rms": cvr["rms"] if cvr else None,
            "cv": cvr,
            "cv_chi2": cv_chi2,
            "chi2_per_dof": res.chi2_per_dof,
            "fit": res,
            "warnings": list(res.warnings),
        }

    base_label = "baseline" if not current else "model: " + ", ".join(s.key for s in current)
    steps.append(step(base_label, current))
    stopped = f"the limit of {max_rounds} rounds was reached"
    for _ in range(max_rounds):
        d = diagnose(
            arm,
            meas,
            current,
            self_weight=self_weight,
            solver_model=solver_model,
            fem_options=fem_options,
        )
        rounds.append(d)
        if d.verdict == "adequate":
            stopped = "the model explains the data within their noise"
            break
        if not d.suggested:
            stopped = "no set of effects improves the model enough"
            break
        nxt = current + list(d.suggested)
        candidate = step("+ " + " + ".join(s.key for s in d.suggested), nxt)
        if _bic(candidate["fit"]) >= _bic(steps[-1]["fit"]):
            stopped = "the suggested set does not lower the BIC"
            break
        if do_cv and not candidate["cv_chi2"] < steps[-1]["cv_chi2"]:
            stopped = (
                f"adding {', '.join(s.key for s in d.suggested)} would predict held-out "
                "configurations worse (cross-validated χ² rises)"
            )
            break
        steps.append(candidate)
        current = nxt
    return Investigation(rounds, steps, stopped)
