"""The error ladder: the model fitted afresh as each suggested effect is added in turn.

Each step is a joint fit of all its effects (with the leave-one-configuration-out RMS when
there are configurations to leave out); the report and its figure show the steps.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np

from eodarm.analysis.crossval import cross_validate
from eodarm.analysis.diagnose import Diagnosis
from eodarm.analysis.fit import FitResult, FitWarning, fit
from eodarm.data.measurements import Measurements
from eodarm.errors import EodarmError, InputError
from eodarm.model.arm import Arm

__all__ = ["build_ladder", "check_same_model", "model_name", "solver_keywords"]


# ---------------------------------------------------------------------------- the model
def solver_keywords(
    diagnosis: Diagnosis, model: str | None, fem_options: Mapping[str, Any] | None
) -> dict[str, Any]:
    """The ``model``/``fem_options`` keywords of every evaluation: the diagnosis's own.

    ``model=None`` takes the diagnosis's model; a model (or FE options) other than the one the
    diagnosis was made with is refused rather than mixed into one report.
    """
    from eodarm.model import fem

    prob = diagnosis.baseline.problem
    if model is None and fem_options is None:
        return {"model": prob.model, "fem_options": prob.fem_options}
    chosen = prob.model if model is None else model
    fem.check_model(chosen)
    if chosen != "fem" and fem_options is not None:
        raise InputError("fem_options is for model='fem'")
    opts = fem.options(fem_options) if chosen == "fem" else None
    if (chosen, opts) != (prob.model, prob.fem_options):
        raise EodarmError(
            f"the diagnosis was made with the {model_name(prob.model, prob.fem_options)}, "
            f"not the {model_name(chosen, opts)}: diagnose with solver_model={chosen!r} "
            "(and the same fem_options)"
        )
    return {"model": chosen, "fem_options": opts}


def model_name(model: str, fem_options: Mapping[str, Any] | None) -> str:
    if model != "fem":
        return "analytic model"
    epl = (fem_options or {}).get("elements_per_link")
    return "finite-element model" + (f" with {epl} elements per flexible link" if epl else "")


def check_same_model(fit_result: FitResult, kw: Mapping[str, Any], what: str) -> None:
    p = fit_result.problem
    if (p.model, p.fem_options) != (kw["model"], kw["fem_options"]):
        raise EodarmError(
            f"{what} was fitted with the {model_name(p.model, p.fem_options)}, the diagnosis "
            f"with the {model_name(kw['model'], kw['fem_options'])}"
        )


# ---------------------------------------------------------------------------- the ladder
def build_ladder(
    arm: Arm,
    meas: Measurements,
    diagnosis: Diagnosis,
    self_weight: bool = True,
    cv: bool = True,
    model: str | None = None,
    fem_options: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """The models of the error ladder: baseline, then the suggested effects one at a time.

    The suggested effects are added in the order of their individual improvement Δχ² (the
    candidate's own row of ``diagnosis.ranking``, largest first). Every step is fitted afresh
    with :func:`eodarm.fit` on all its effects jointly (the model's own ``--add`` effects
    included), leaving out the cells the diagnosis named as outliers.

    Parameters
    ----------
    arm, meas : the arm and the measurements the diagnosis was made on.
    diagnosis : the result of :func:`eodarm.diagnose`.
    self_weight : as :func:`eodarm.solve`.
    cv : add the leave-one-configuration-out RMS (:func:`eodarm.cross_validate`) of every
        step; only done when the data have at least two configurations. (Cross-validation
        uses every measured cell, outliers included.)
    model, fem_options : ``"analytic"`` or ``"fem"`` and its options, as in
        :func:`eodarm.fit`; default (``None``) the model the diagnosis was made with, and
        nothing else is accepted.

    Returns
    -------
    list of dict
        One per step: ``label`` (``"baseline"``, ``"+ effect@place"``…), ``effects`` (the
        ``effect@place`` keys fitted), ``rms`` ({channel: mm or deg}), ``cv_rms`` (same, or
        ``None``), ``chi2_per_dof``, ``fit`` (the :class:`~eodarm.analysis.fit.FitResult`) and
        ``warnings`` (parameters stuck at a bound).
    """
    prob = diagnosis.baseline.problem
    if prob.meas.values.shape != meas.values.shape:
        raise EodarmError(
            f"build_ladder: the diagnosis was made on {prob.meas.n_rows} rows, "
            f"the measurements have {meas.n_rows}"
        )
    kw = solver_keywords(diagnosis, model, fem_options)
    excluded = np.isfinite(meas.values) & ~prob.use
    exclude = excluded if excluded.any() else None
    gain = {c.slot.key: c.delta_chi2 for c in diagnosis.ranking}
    added = sorted(diagnosis.suggested, key=lambda s: -gain.get(s.key, -math.inf))
    do_cv = cv and len(meas.configs) >= 2
    base_label = "baseline"
    if diagnosis.model:
        base_label = "model: " + ", ".join(s.key for s in diagnosis.model)
    steps: list[dict[str, Any]] = []
    for i in range(len(added) + 1):
        slots = list(diagnosis.model) + added[:i]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)
            res = fit(arm, meas, slots, self_weight=self_weight, exclude=exclude, **kw)
            cv_rms = (
                cross_validate(arm, meas, slots, self_weight=self_weight, **kw)["rms"]
                if do_cv
                else None
            )
        steps.append(
            {
                "label": base_label if i == 0 else f"+ {added[i - 1].key}",
                "effects": [s.key for s in slots],
                "rms": dict(res.rms),
                "cv_rms": cv_rms,
                "chi2_per_dof": res.chi2_per_dof,
                "fit": res,
                "warnings": list(res.warnings),
            }
        )
    return steps
