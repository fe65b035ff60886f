"""Which physical effect is missing? Rank every candidate, search sets, name confusions.

The procedure (docs/diagnosis.md explains it with the statistics):

1. Fit the model's own effects (``--add``): the *baseline*.
2. Ask the core for the sensitivity of every measured channel to every candidate effect
   × place not in the model, at the baseline (one compiled call).
3. Every set of up to three candidates is fitted on the linearised problem, exactly and
   within bounds, all sets at once; the best sets of each size, and every single candidate,
   are then refitted with the exact nonlinear model.
4. Verdict: the baseline is *adequate* when its χ² is consistent with the noise
   (p ≥ 0.001) and no candidate improves it significantly (likelihood-ratio Δχ² beyond the
   0.1 % quantile of χ²₁, Bonferroni-corrected for the number of candidates, and BIC).
   Otherwise sets are judged smallest first, better χ² first within a size, by the one
   rule of :func:`eodarm.analysis.acceptance.accept`; the first accepted set is
   ``suggested`` (verdict *missing*). If none is and the baseline's χ² is not consistent
   with the noise, the verdict is *unexplained*, and ``best_effort`` is the set (or the
   baseline) with the lowest BIC.
5. Two candidates are *confused* when either can reproduce the other's fitted contribution
   to within the noise (residual χ² < 3.84, the 95 % point of χ²₁) on the given channels and
   poses, while that contribution itself is detectable (χ² > 3.84).
6. Cells more than 4σ off after the best fit (at most 2 % of them) are named as outliers and
   left out of a second pass.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.acceptance import MIN_CV_CONFIGS, Acceptance, accept, bic, held_out
from eodarm.analysis.confusions import CONFUSION_CHI2, advice, alternatives, confusions
from eodarm.analysis.confusions import friction_advice as friction_advice
from eodarm.analysis.consistency import P_PASS, effective_nu, fit_p_value, lr_threshold
from eodarm.analysis.datacheck import DataCheck, check_data
from eodarm.analysis.fit import FitResult, FitWarning, Problem, fit
from eodarm.analysis.outliers import outlier_table, peel_outliers
from eodarm.analysis.sequences import FRICTIONS
from eodarm.data.measurements import Measurements
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import CATALOGUE, Slot, candidate_places, known_effects

__all__ = [
    "CONFUSION_CHI2",
    "P_PASS",
    "VERDICTS",
    "Candidate",
    "Diagnosis",
    "all_slots",
    "diagnose",
]

# When the data cannot tell two candidates apart (equal χ² to 1e-9), prefer the one that does
# not overrule the arm file: an unknown mount or joint over a changed actuator body stiffness.
TIE_ORDER = (
    "mount_compliance",
    "joint_clearance",
    "actuator_play",
    "drive_backlash",
    "link_bending",
    "base_compliance",
    "actuator_compliance",
    "drive_compliance",
)
#: The verdicts of docs/formats.md §7: ``check_data`` when the data look mistaken
#: (:mod:`eodarm.analysis.datacheck`), before any effect is looked for.
VERDICTS = ("adequate", "missing", "unexplained", "check_data")
OUTLIER_Z = 4.0


def all_slots(
    n: int, taken_up: bool = True, custom: bool = True, kinds: Sequence[str] | None = None
) -> list[Slot]:
    """Every candidate effect × place on an n-link arm: the catalogue's (7n + 1 when every
    joint is linear), with ``taken_up`` the gaps taken up when unloaded too (play and
    clearance, 2n more), and with ``custom`` every registered user-written effect at every
    place of its kind. ``kinds`` (:attr:`Arm.kinds`, default all linear) keeps each joint's
    effects to its kind of drive (an actuator's effects at a linear actuator, a drive's at a
    rotary drive)."""
    names = known_effects() if custom else list(CATALOGUE)
    joints = tuple(kinds) if kinds is not None else ("linear",) * n
    out = []
    for name in names:
        for at in candidate_places(name, n, joints):
            out.append(Slot(name, at))
            if taken_up and name in CATALOGUE and CATALOGUE[name].taken_up_code is not None:
                out.append(Slot(name, at, "taken_up"))
    return out


def _tie_rank(slot: Slot) -> tuple[int, int]:
    """TIE_ORDER's rank of a slot; user-written effects after the catalogue's, a gap taken
    up after the same gap centred."""
    name = slot.name
    rank = TIE_ORDER.index(name) if name in TIE_ORDER else len(TIE_ORDER)
    return rank, int(slot.unloaded != "centred")


def _combinations(cands: Sequence[Slot], size: int) -> list[tuple[int, ...]]:
    """Sets of ``size`` candidates, never two of one effect@place (a gap centred and the same
    gap taken up)."""
    return [
        st
        for st in itertools.combinations(range(len(cands)), size)
        if len({cands[c].key for c in st}) == size
    ]


@dataclass
class Candidate:
    """One candidate added alone to the model, its parameter fitted."""

    slot: Slot
    fit: FitResult
    delta_chi2: float
    confused_with: list[str] = field(default_factory=list)

    def __repr__(self) -> str:
        from eodarm.analysis.diagnosis_display import candidate_repr

        return candidate_repr(self)

    def to_json(self) -> dict[str, Any]:
        i = self.fit.slots.index(self.slot)
        value = self.fit.estimate(i)
        out = {
            "effect": self.slot.name,
            "at": self.slot.at,
            "estimate": {self.slot.kind.param: value if math.isfinite(value) else None},
            "rms": dict(self.fit.rms),
            "chi2_per_dof": self.fit.chi2_per_dof,
            "confused_with": list(self.confused_with),
        }
        if self.slot.unloaded != "centred":
            out["unloaded"] = self.slot.unloaded  # a gap taken up when unloaded
        return out


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`; ``to_json()`` is the CLI's JSON (docs/formats.md §7).

    ``verdict`` is one of :data:`VERDICTS`. With *missing*, ``suggested`` is the first set
    the rule accepted and ``acceptance`` its judgement. With *unexplained*, ``best_effort``
    is the set the BIC prefers (empty when it prefers the baseline), ``best_effort_fit`` its
    fit, ``best_effort_cv`` its leave-one-configuration-out cross-validation (≥ 3
    configurations) and ``acceptance`` its judgement by the same rule, every criterion
    evaluated. ``examined`` lists the judgement of every set looked at, in search order.
    ``significance`` is the Δχ² a single candidate must exceed to improve the baseline
    significantly (the Bonferroni-corrected likelihood-ratio threshold or the BIC penalty
    ln N, whichever is larger; docs/diagnosis.md, step 4). ``alternatives`` maps each
    suggested effect's spec to the candidates the data cannot tell apart from it in the set
    (:func:`eodarm.analysis.confusions.alternatives`; empty lists when none), and
    ``alternative_fits`` holds the set refitted with each alternative in its member's place.
    ``data_checks`` lists the mistakes the data look like
    (:func:`eodarm.analysis.datacheck.check_data`); when there is any, the verdict is
    *check_data*: no candidate is ranked or suggested, the baseline is only fitted.
    """

    model: list[Slot]
    baseline: FitResult
    verdict: str
    suggested: list[Slot]
    suggested_fit: FitResult | None
    ranking: list[Candidate]
    outliers: list[dict[str, Any]]
    advice: list[dict[str, Any]]
    p_baseline: float
    sets_searched: int
    best_effort: list[Slot] = field(default_factory=list)
    best_effort_fit: FitResult | None = None
    best_effort_cv: Mapping[str, Any] | None = None
    acceptance: Acceptance | None = None
    examined: list[Acceptance] = field(default_factory=list)
    significance: float = math.nan
    alternatives: dict[str, list[str]] = field(default_factory=dict)
    alternative_fits: dict[tuple[str, str], FitResult] = field(default_factory=dict)
    data_checks: list[DataCheck] = field(default_factory=list)

    def __repr__(self) -> str:
        from eodarm.analysis.diagnosis_display import diagnosis_repr

        return diagnosis_repr(self)

    def _repr_html_(self) -> str:
        from eodarm.analysis.diagnosis_display import diagnosis_html

        return diagnosis_html(self)

    @property
    def suggested_explains(self) -> bool:
        """Whether a set is suggested, i.e. accepted by the rule (it explains the data within
        their noise, away from its bounds, and predicts held-out configurations no worse)."""
        return bool(self.suggested) and self.acceptance is not None and self.acceptance.accepted

    @property
    def best_fit(self) -> FitResult:
        """The fit the diagnosis ends with: the suggested set's, the best effort's, or the
        baseline."""
        return self.suggested_fit or self.best_effort_fit or self.baseline

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "model": [s.spec for s in self.model],
            "baseline": {
                "rms": dict(self.baseline.rms),
                "chi2_per_dof": self.baseline.chi2_per_dof,
            },
            "verdict": self.verdict,
            "suggested": [s.spec for s in self.suggested],
            "alternatives": {k: list(v) for k, v in self.alternatives.items() if v},
            "data_checks": [c.to_json() for c in self.data_checks],
        }
        if self.verdict == "unexplained":
            be = self.best_effort_fit or self.baseline
            best: dict[str, Any] = {
                "set": [s.spec for s in self.best_effort],
                "chi2_per_dof": be.chi2_per_dof,
            }
            if self.best_effort_cv is not None:
                best["cv"] = {"rms": dict(self.best_effort_cv["rms"])}
            out["best_effort"] = best
        out["ranking"] = [c.to_json() for c in self.ranking]
        return out


def _bounded_qp_batch(
    g: npt.NDArray[np.float64],
    b: npt.NDArray[np.float64],
    lo: npt.NDArray[np.float64],
    hi: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """min ½dᵀGd − bᵀd s.t. lo ≤ d ≤ hi, for K small problems at once (K, k, k).

    Exact: every pattern of variables held at a bound is tried (≤ 3^k faces, small k), and the
    feasible face solution of least objective is the global optimum of this convex problem.
    """
    kset, k = b.shape
    best = np.full(kset, np.inf)
    best_d = np.zeros((kset, k))
    ridge = np.eye(k) * 1e-12
    # 0: free, 1: at the lower bound, 2: at the upper bound (only where one is finite).
    options = [(0, 1, 2) if np.isfinite(hi[:, j]).any() else (0, 1) for j in range(k)]
    # Faces with fewer variables held first. A feasible face solution that satisfies the KKT
    # conditions (the gradient pushes every held variable against its bound) is the global
    # optimum of the convex problem, so its problem needs no further face: the result is the
    # exhaustive search's, found sooner.
    patterns = sorted(itertools.product(*options), key=lambda p: sum(v != 0 for v in p))
    done = np.zeros(kset, dtype=bool)
    tol = 1e-9 * (1.0 + np.abs(b).max(axis=1))
    for pattern in patterns:
        todo = np.flatnonzero(~done)
        if todo.size == 0:
            break
        pat = np.array(pattern)
        gt, bt, lot, hit = g[todo], b[todo], lo[todo], hi[todo]
        held = np.where(pat == 1, lot, np.where(pat == 2, hit, 0.0))
        valid = np.isfinite(held).all(axis=1)
        if not valid.any():
            continue
        d = np.where(np.isfinite(held), held, 0.0)
        free = np.flatnonzero(pat == 0)
        fixed = np.flatnonzero(pat != 0)
        if free.size:
            gff = gt[:, free][:, :, free] + ridge[: free.size, : free.size]
            rhs = bt[:, free] - np.einsum("kij,kj->ki", gt[:, free][:, :, fixed], d[:, fixed])
            sol = np.linalg.solve(gff, rhs[..., None])[..., 0]
            d[:, free] = sol
            valid &= np.all(sol >= lot[:, free] - 1e-12, axis=1)
            valid &= np.all(sol <= hit[:, free] + 1e-12, axis=1)
        obj = 0.5 * np.einsum("ki,kij,kj->k", d, gt, d) - np.einsum("ki,ki->k", bt, d)
        better = valid & (obj < best[todo])
        best[todo[better]] = obj[better]
        best_d[todo[better]] = d[better]
        grad = np.einsum("kij,kj->ki", gt, d) - bt
        kkt = valid.copy()
        t = tol[todo][:, None]
        if (pat == 1).any():
            kkt &= np.all(grad[:, pat == 1] >= -t, axis=1)
        if (pat == 2).any():
            kkt &= np.all(grad[:, pat == 2] <= t, axis=1)
        done[todo[kkt]] = True
    return best_d, best


#: The largest ``max_set`` of :func:`diagnose`: sets of up to five effects of some twenty
#: candidates are tens of thousands of fits; beyond, the search would not end in a session.
MAX_SET = 5


def diagnose(
    arm: Arm,
    meas: Measurements,
    model: Sequence[Slot | str] = (),
    self_weight: bool = True,
    max_set: int = 3,
    candidates: Sequence[Slot | str] | None = None,
    refine_per_size: int = 3,
    outliers: bool = True,
    advise: bool = True,
    solver_model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
    check: bool = True,
) -> Diagnosis:
    """Rank every candidate effect × place, search sets of up to ``max_set``, and decide.

    Parameters
    ----------
    arm, meas : the arm and the measurements.
    model : effects already in the model (their parameters are fitted).
    candidates : the candidates to consider (default: every effect × place not in the model).
    max_set : the largest set searched for ``suggested`` (≤ 3 is cheap; sets are exact; at
        most :data:`MAX_SET`: the search grows with the number of candidate sets).
    outliers : name cells > 4σ off after the best fit and run a second pass without them.
    advise : for confused pairs, search for the channel and the pose that separate them.
    solver_model : ``"analytic"`` or ``"fem"``: the model that predicts the channels, the
        ``model=`` of :func:`eodarm.solve` and :func:`eodarm.fit` (named so here because
        ``model`` is the list of effects already in the model); ``fem_options`` go with it.
    check : first hold the data against the baseline model's scale and sign
        (:func:`eodarm.analysis.datacheck.check_data`); if they look mistaken, the verdict
        is *check_data* and nothing is searched.
    """
    from eodarm.model.kinds import integer

    max_set = integer(max_set, "diagnose: max_set", 1, MAX_SET)
    refine_per_size = integer(refine_per_size, "diagnose: refine_per_size", 1, 10**4)
    kw: dict[str, Any] = {"model": solver_model, "fem_options": fem_options}
    Problem(arm, meas, self_weight, **kw)  # refuses a bad solver_model before any work
    model_slots = [Slot.of(s) for s in model]
    checks = check_data(arm, meas, self_weight, solver_model, fem_options) if check else []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        if checks:
            return _mistaken(arm, meas, model_slots, self_weight, checks, kw)
        first = _diagnose_pass(
            arm, meas, model_slots, self_weight, max_set, candidates, refine_per_size, None, kw
        )
        found: list[dict[str, Any]] = []
        if outliers:
            first, found = _without_outliers(
                first,
                arm,
                meas,
                model_slots,
                self_weight,
                max_set,
                candidates,
                refine_per_size,
                kw,
            )
        first.outliers = found
        if first.verdict == "unexplained":
            _judge_best_effort(first)
        if advise and first.ranking:
            first.advice = advice(arm, meas, first, self_weight, kw)
    return first


def _mistaken(
    arm: Arm,
    meas: Measurements,
    model_slots: list[Slot],
    self_weight: bool,
    checks: list[DataCheck],
    kw: dict[str, Any],
) -> Diagnosis:
    """The diagnosis of data that look mistaken: the baseline fitted, nothing searched."""
    prob = Problem(arm, meas, self_weight=self_weight, **kw)
    if prob.n_values == 0:
        raise EodarmError(f"{meas.source}: no measured values to diagnose")
    base = fit(arm, meas, model_slots, problem=prob)
    return Diagnosis(
        model=model_slots,
        baseline=base,
        verdict="check_data",
        suggested=[],
        suggested_fit=None,
        ranking=[],
        outliers=[],
        advice=[],
        p_baseline=fit_p_value(base),
        sets_searched=0,
        data_checks=checks,
    )


def _judge_best_effort(d: Diagnosis) -> None:
    """The best effort's cross-validation and its judgement, every criterion evaluated.

    Done once, after the outliers are settled: it refits the model per configuration.
    """
    if len(d.baseline.problem.meas.configs) < MIN_CV_CONFIGS:
        if d.best_effort and d.best_effort_fit is not None:
            d.acceptance = accept(d.baseline, d.best_effort_fit)
        return
    base_cv = next((a.baseline_cv for a in d.examined if a.baseline_cv is not None), None)
    if not d.best_effort or d.best_effort_fit is None:
        d.best_effort_cv = base_cv if base_cv is not None else held_out(d.baseline)
        return
    keys = [s.key for s in d.best_effort]
    done = next((a for a in d.examined if a.keys == keys and a.cv is not None), None)
    d.acceptance = done or accept(
        d.baseline, d.best_effort_fit, baseline_cv=base_cv, always_cross_validate=True
    )
    d.best_effort_cv = d.acceptance.cv


def _without_outliers(
    first: Diagnosis,
    arm: Arm,
    meas: Measurements,
    model_slots: list[Slot],
    self_weight: bool,
    max_set: int,
    candidates: Sequence[Slot | str] | None,
    refine_per_size: int,
    kw: dict[str, Any],
) -> tuple[Diagnosis, list[dict[str, Any]]]:
    """Leave out the cells > 4σ off the best model, and diagnose again (a few rounds at most:
    :func:`eodarm.analysis.outliers.peel_outliers`).

    Accepted only if, with at most 2 % of the values left out, the best model then explains
    the rest within the noise; otherwise the first diagnosis stands and nothing is flagged.
    """
    current, mask = peel_outliers(
        first,
        lambda m: _diagnose_pass(
            arm, meas, model_slots, self_weight, max_set, candidates, refine_per_size, m, kw
        ),
        lambda d: d.best_fit,
        OUTLIER_Z,
        0.02,
    )
    if not mask.any():
        return first, []
    return current, outlier_table(current.best_fit, mask)


def _diagnose_pass(
    arm: Arm,
    meas: Measurements,
    model_slots: list[Slot],
    self_weight: bool,
    max_set: int,
    candidates: Sequence[Slot | str] | None,
    refine_per_size: int,
    exclude: npt.NDArray[np.bool_] | None,
    kw: dict[str, Any],
) -> Diagnosis:
    prob = Problem(arm, meas, self_weight=self_weight, exclude=exclude, **kw)
    if prob.n_values == 0:
        raise EodarmError(f"{meas.source}: no measured values to diagnose")
    base = fit(arm, meas, model_slots, problem=prob)
    taken = {s.key for s in model_slots}
    if candidates is None:
        # the FE model has neither taken-up gaps nor user effects; without self-weight a
        # taken-up gap is the centred one
        analytic = kw.get("model", "analytic") == "analytic"
        every = all_slots(
            arm.n, taken_up=analytic and self_weight, custom=analytic, kinds=arm.kinds
        )
        if not analytic:  # frictions are modelled by the analytic model only
            every = [s for s in every if s.name not in FRICTIONS]
        cands = [s for s in every if s.key not in taken]
    else:
        cands = [Slot.of(s) for s in candidates if Slot.of(s).key not in taken]
    m, k = len(model_slots), len(cands)
    probes = model_slots + cands
    y0, jac = prob.evaluate(list(zip(model_slots, base.theta, strict=True)), probes)
    r0 = prob.whiten(y0)
    a = prob.whiten_jac(jac)
    norms = np.linalg.norm(a, axis=0)
    norms[norms == 0] = 1.0
    an = a / norms
    gram = an.T @ an
    bvec = an.T @ r0
    chi2_0 = float(r0 @ r0)
    lo = np.empty(m + k)
    hi = np.empty(m + k)
    for j, s in enumerate(probes):
        start = base.theta[j] if j < m else prob.neutral(s)
        blo, bhi = prob.bounds(s)
        lo[j], hi[j] = (blo - start) * norms[j], (bhi - start) * norms[j]

    def solve_sets(
        sets: Sequence[tuple[int, ...]],
    ) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
        idx = np.array([tuple(range(m)) + tuple(m + c for c in st) for st in sets], dtype=int)
        g = gram[idx[:, :, None], idx[:, None, :]]
        d, obj = _bounded_qp_batch(g, bvec[idx], lo[idx], hi[idx])
        return d, chi2_0 + 2 * obj

    # Exact refits of a set with the nonlinear model, from the linearised solution.
    cache: dict[tuple[int, ...], FitResult] = {}

    def refine(st: tuple[int, ...], d: npt.NDArray[np.float64]) -> FitResult:
        if st not in cache:
            slots = model_slots + [cands[c] for c in st]
            cols = list(range(m)) + [m + c for c in st]
            start = (
                np.array([base.theta[j] if j < m else prob.neutral(probes[j]) for j in cols])
                + d / norms[cols]
            )
            res = fit(arm, meas, slots, problem=prob, start=start)
            if res.chi2 > base.chi2 * (1 + 1e-9) + 1e-9:
                # The linearised start was a poor one (a friction that sticks there, a gap
                # that changes sides) and the fit, which only takes steps that lower χ², got
                # stuck above the model without the set: start again from that model (the
                # set's effects absent), which it can only improve on, and keep the better.
                nested = np.array(
                    [base.theta[j] if j < m else prob.neutral(probes[j]) for j in cols]
                )
                again = fit(arm, meas, slots, problem=prob, start=nested)
                res = again if again.chi2 < res.chi2 else res
            cache[st] = res
        return cache[st]

    singles: list[tuple[int, ...]] = [(c,) for c in range(k)]
    d1, _ = solve_sets(singles)
    ranking = []
    for c in range(k):
        res = refine((c,), d1[c])
        ranking.append(Candidate(cands[c], res, base.chi2 - res.chi2))
    _rank(ranking)

    # Verdict.
    n_val = prob.n_values
    p_base = fit_p_value(base)
    lrt = lr_threshold(1e-3 / max(k, 1), effective_nu(prob.meas, prob.use))

    # Confusions, on the linearised columns with the model's columns projected out.
    confusions(ranking, cands, an[:, :m], an[:, m:], norms[m:], prob, max(lrt, math.log(n_val)))
    best1 = ranking[0] if ranking else None
    threshold = max(lrt, math.log(n_val))
    significant = best1 is not None and best1.delta_chi2 > threshold
    explained = p_base >= P_PASS

    # Sets, smallest first and better χ² first within a size, judged by the one rule.
    accepted: Acceptance | None = None
    examined: list[Acceptance] = []
    tried: list[FitResult] = []
    searched = k
    if not explained or significant:
        base_cv: Mapping[str, Any] | None = None
        for size in range(1, min(max_set, k) + 1):
            sets = _combinations(cands, size)
            searched += len(sets) if size > 1 else 0
            if size > 1:
                d, chis = solve_sets(sets)
            else:
                # every single is already refitted exactly (the ranking): judge the best of
                # those first, not of the linearised χ², which misjudges an effect whose
                # response is far from linear (a friction that moves a backlash's side)
                d, chis = d1, np.array([cache[st].chi2 for st in singles])
            order = np.argsort(chis)[:refine_per_size]
            fits = _by_chi2([refine(sets[i], d[i]) for i in order], m)
            tried += fits
            for f in fits:
                acc = accept(base, f, baseline_cv=base_cv)
                examined.append(acc)
                if acc.baseline_cv is not None:
                    base_cv = acc.baseline_cv
                if acc.accepted:
                    accepted = acc
                    break
            if accepted is not None:
                break
    if accepted is not None:
        verdict = "missing"
    else:
        verdict = "adequate" if explained else "unexplained"
    best_effort: FitResult | None = None
    if verdict == "unexplained":
        best_effort = min([base, *tried], key=bic)
    alts: dict[str, list[str]] = {}
    alt_fits: dict[tuple[str, str], FitResult] = {}
    if accepted is not None:
        alts, alt_fits = alternatives(arm, meas, accepted.fit, m, cands, an, norms, prob, threshold)
    return Diagnosis(
        model=model_slots,
        baseline=base,
        verdict=verdict,
        suggested=accepted.fit.slots[m:] if accepted else [],
        suggested_fit=accepted.fit if accepted else None,
        ranking=ranking,
        outliers=[],
        advice=[],
        p_baseline=p_base,
        sets_searched=searched,
        best_effort=best_effort.slots[m:] if best_effort is not None else [],
        best_effort_fit=best_effort,
        acceptance=accepted,
        examined=examined,
        significance=threshold,
        alternatives=alts,
        alternative_fits=alt_fits,
    )


def _by_chi2(fits: list[FitResult], m: int) -> list[FitResult]:
    """Fits of sets of one size, least χ² first; χ² equal to 1e-9 of the largest are ties,
    broken by TIE_ORDER of their members (the arm file's own stiffness last)."""
    quantum = 1e-9 * max([abs(f.chi2) for f in fits] + [1e-300])
    return sorted(
        fits,
        key=lambda f: (
            round(f.chi2 / quantum),
            sorted(_tie_rank(s) for s in f.slots[m:]),
        ),
    )


def _rank(ranking: list[Candidate]) -> None:
    """Best (least χ²) first; χ² equal to 1e-9 of the largest are ties, broken by TIE_ORDER."""
    quantum = 1e-9 * max([abs(c.fit.chi2) for c in ranking] + [1e-300])
    ranking.sort(key=lambda c: (round(c.fit.chi2 / quantum), _tie_rank(c.slot), c.slot.at))


def describe(param: str, value: float) -> str:
    """A parameter value as text (``inf`` stiffness → 'rigid')."""
    if not math.isfinite(value):
        return "rigid (absent)"
    return f"{value:.4g}"
