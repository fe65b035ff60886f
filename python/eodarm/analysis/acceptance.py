"""The one rule for "suggested": when is a set of effects what the model is missing?

docs/formats.md §7: ``suggested`` is the smallest set of candidate effects that, added together with
their parameters fitted, explains the data within noise and (with ≥ 3 configurations) does
not predict held-out configurations worse than the model without it. :func:`accept` is that
rule, and the only place it is written: :func:`eodarm.diagnose` searches sets with it, the
investigation (:func:`eodarm.analysis.workflow.investigate`) decides its rounds with it and
the report shows its reasons. A set (added to the baseline, every parameter fitted jointly)
is **accepted** when

(a) its χ² is consistent with the noise: p ≥ :data:`~eodarm.analysis.consistency.P_PASS`
    by the χ² test, or the F test where σ was estimated from repeats
    (:func:`~eodarm.analysis.consistency.fit_p_value`);
(b) every member's parameter is away from its bounds: a member stuck at θ = 0 (absent) or at
    its upper bound was not *found*, it only rides along;
(c) with ≥ 3 configurations, it predicts held-out configurations no worse than the baseline:
    leaving one configuration out at a time, fitting without it and predicting it
    (:func:`~eodarm.analysis.crossval.cross_validate`), the RMS of the held-out residuals in units
    of σ over every measured channel is not larger than the baseline's. Channels of
    different units are weighed by their σ, as in the fit itself.

(c) refits the model once per configuration, so it is run only for sets that pass (a) and
(b), unless asked for (``always_cross_validate``).

A set that does not explain the data can still be a step toward an explanation: it
**improves** the model when (b) and (c) hold, it lowers the BIC (χ² + k ln N) and the data
determine every member's parameter (relative standard error ≤ 100 %). The
investigation adds such a set when no set is accepted (verdict ``unexplained``) and goes on;
it is never called ``suggested``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from eodarm.analysis.consistency import P_PASS, fit_p_value
from eodarm.analysis.crossval import cross_validate
from eodarm.analysis.fit import FitResult, FitWarning
from eodarm.model.effects import Slot

__all__ = ["MIN_CV_CONFIGS", "Acceptance", "accept", "bic", "held_out"]

#: Configurations needed before the held-out check (c) applies.
MIN_CV_CONFIGS = 3


def bic(fit: FitResult) -> float:
    """Bayesian information criterion χ² + k ln N (k fitted parameters, N values)."""
    return fit.chi2 + fit.n_params * math.log(max(fit.problem.n_values, 2))


def held_out(fit: FitResult) -> dict[str, Any]:
    """Leave-one-configuration-out cross-validation of a fit's model, on the cells it used.

    The dict of :func:`~eodarm.analysis.crossval.cross_validate` plus ``"z_rms"``: the RMS of the
    held-out residuals in units of σ over every used cell.
    """
    prob = fit.problem
    meas = prob.meas
    excluded = np.isfinite(meas.values) & ~prob.use
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        cv = cross_validate(
            prob.arm,
            meas,
            fit.slots,
            self_weight=prob.self_weight,
            model=prob.model,
            fem_options=prob.fem_options,
            exclude=excluded if excluded.any() else None,
            start=fit.theta if fit.slots else None,
        )
    z = cv["residual"][prob.use] / meas.sigma[prob.use]
    cv["z_rms"] = float(np.sqrt(np.mean(z**2))) if z.size else math.nan
    return cv


@dataclass(frozen=True)
class Acceptance:
    """The rule's judgement of one set: each criterion, its numbers, and the outcome.

    Attributes
    ----------
    added : the set judged (``effect@place`` slots beyond the baseline's own effects).
    fit : the baseline's effects and the set, fitted jointly.
    baseline : the baseline's fit.
    p_value : (a) p-value of ``fit``'s χ² (χ² test, or F with estimated σ).
    stuck : (b) members whose parameter sits at a bound (``effect@place``).
    cv_applies : (c) applies: the data have ≥ :data:`MIN_CV_CONFIGS` configurations.
    cv, baseline_cv : (c) the cross-validations (:func:`held_out`) of the set's model and of
        the baseline; ``None`` where not run.
    """

    added: tuple[Slot, ...]
    fit: FitResult
    baseline: FitResult
    p_value: float
    stuck: tuple[str, ...]
    cv_applies: bool
    cv: Mapping[str, Any] | None = None
    baseline_cv: Mapping[str, Any] | None = None

    def __repr__(self) -> str:
        from eodarm.analysis.diagnosis_display import acceptance_repr

        return acceptance_repr(self)

    @property
    def consistent(self) -> bool:
        """(a) The set's χ² is consistent with the noise."""
        return self.p_value >= P_PASS

    @property
    def away_from_bounds(self) -> bool:
        """(b) Every member's parameter is away from its bounds."""
        return not self.stuck

    @property
    def predicts(self) -> bool | None:
        """(c) Held-out configurations are predicted no worse than by the baseline.

        ``True`` also when (c) does not apply (< 3 configurations); ``None`` when it applies
        but was not run.
        """
        if not self.cv_applies:
            return True
        if self.cv is None or self.baseline_cv is None:
            return None
        return bool(self.cv["z_rms"] <= self.baseline_cv["z_rms"] * (1 + 1e-9))

    @property
    def accepted(self) -> bool:
        """(a), (b) and (c): the set is what the model is missing (``suggested``)."""
        return self.consistent and self.away_from_bounds and self.predicts is True

    @property
    def bic(self) -> float:
        return bic(self.fit)

    @property
    def improves(self) -> bool:
        """(b), (c), a lower BIC and every member determined by the data: a step toward an
        explanation, though not one."""
        return (
            self.away_from_bounds
            and self.predicts is True
            and self.bic < bic(self.baseline)
            and not self.undetermined
        )

    @property
    def undetermined(self) -> list[str]:
        """Members whose parameter the data do not determine (relative standard error above
        100 %, :meth:`FitResult.undetermined`): a set of them, however it lowers the BIC, is
        no step toward an explanation (two gaps or frictions that cancel each other)."""
        first = len(self.fit.slots) - len(self.added)
        return [
            self.fit.slots[i].key
            for i, why in self.fit.undetermined(max_correlation=1.0)
            if i >= first and why.startswith("relative")
        ]

    @property
    def keys(self) -> list[str]:
        return [s.key for s in self.added]

    @property
    def failed(self) -> list[str]:
        """The criteria that failed: ``"noise"`` (a), ``"bounds"`` (b), ``"held_out"`` (c)."""
        out = []
        if not self.consistent:
            out.append("noise")
        if not self.away_from_bounds:
            out.append("bounds")
        if self.predicts is False:
            out.append("held_out")
        return out

    def reasons(self) -> list[str]:
        """One short phrase per criterion, with its numbers."""
        f = self.fit
        p = "p < 1e-300" if self.p_value <= 0 else f"p = {self.p_value:.2g}"
        out = [
            f"χ²/dof {f.chi2_per_dof:.3g} consistent with the noise ({p})"
            if self.consistent
            else f"χ²/dof {f.chi2_per_dof:.3g} not consistent with the noise ({p})"
        ]
        out.append(
            "every parameter away from its bounds"
            if not self.stuck
            else "stuck at a bound (not found): " + ", ".join(self.stuck)
        )
        cv, base = self.cv, self.baseline_cv
        if not self.cv_applies:
            out.append(f"no held-out check (fewer than {MIN_CV_CONFIGS} configurations)")
        elif cv is None or base is None:
            out.append("held-out check not run")
        else:
            word = "no worse than" if self.predicts else "worse than"
            out.append(
                f"held-out configurations predicted {word} without it "
                f"(RMS/σ {cv['z_rms']:.3g} against {base['z_rms']:.3g})"
            )
        return out


def accept(
    baseline: FitResult,
    candidate: FitResult,
    *,
    baseline_cv: Mapping[str, Any] | None = None,
    always_cross_validate: bool = False,
) -> Acceptance:
    """Judge a set of effects added to the baseline by the one rule (module docstring).

    Parameters
    ----------
    baseline : the fit of the model without the set.
    candidate : the fit of the model with the set (the baseline's effects first, then the
        set's), on the same data and cells.
    baseline_cv : the baseline's :func:`held_out`, when already computed (it is the same
        for every set judged against one baseline); computed here when needed.
    always_cross_validate : run the held-out check (c) even when (a) or (b) fails (to
        report it); by default it runs only for sets that pass both, as it refits the model
        once per configuration.

    Returns
    -------
    Acceptance
        Every criterion with its numbers; ``.accepted`` is the outcome.
    """
    m = baseline.n_params
    if [s.key for s in candidate.slots[:m]] != [s.key for s in baseline.slots]:
        raise ValueError(
            "accept: the candidate must hold the baseline's effects first: "
            f"{[s.key for s in baseline.slots]} vs {[s.key for s in candidate.slots]}"
        )
    if candidate.problem.use.shape != baseline.problem.use.shape or not np.array_equal(
        candidate.problem.use, baseline.problem.use
    ):
        raise ValueError("accept: the baseline and the candidate were fitted on other cells")
    added = tuple(candidate.slots[m:])
    stuck = tuple(s.key for s, b in zip(added, candidate.at_bound[m:], strict=True) if b)
    p = fit_p_value(candidate)
    applies = len(candidate.problem.meas.configs) >= MIN_CV_CONFIGS
    cv = base_cv = None
    if applies and (always_cross_validate or (p >= P_PASS and not stuck)):
        base_cv = baseline_cv if baseline_cv is not None else held_out(baseline)
        cv = held_out(candidate)
    return Acceptance(
        added=added,
        fit=candidate,
        baseline=baseline,
        p_value=p,
        stuck=stuck,
        cv_applies=applies,
        cv=cv,
        baseline_cv=base_cv,
    )
