"""Fitting effect parameters to measurements: bounded Gauss–Newton on compliance-like θ.

Every effect is fitted through a parameter θ in which its deflection is (nearly) linear:

=====================  ==========================  =====================================
effect                 θ                           physical bound
=====================  ==========================  =====================================
actuator_compliance    1/stiffness_n_per_mm        θ ≥ 0 (θ = 0: rigid body)
mount_compliance       1/stiffness_n_per_mm        θ ≥ 0 (θ = 0: rigid mount, absent)
actuator_play          play_mm                     0 ≤ θ ≤ 5 mm
joint_clearance        clearance_mm                0 ≤ θ ≤ 5 mm
link_bending           1/ei_n_mm2                  θ ≥ 0 (θ = 0: rigid link)
base_compliance        1/stiffness_nmm_per_rad     θ ≥ 0 (θ = 0: rigid base)
=====================  ==========================  =====================================

The compiled core returns the model's channels and their sensitivities ∂y/∂θ for any set of
places in one call (:func:`eodarm._core.jacobian`); each Gauss–Newton step is then a small
bounded linear least-squares problem. Residuals are whitened by the measurement σ.

With ``model="fem"`` the channels come from the finite-element model (:mod:`eodarm.model.fem`) and
the sensitivities from forward differences of it, one more FE solve per parameter.

A user-written effect (docs/custom-effects.md) is fitted through its parameter itself, within its
``[lower, upper]``, starting from its ``start``; models that hold one are evaluated by
:mod:`eodarm.analysis.sensitivity` (forward differences, the statics computed once).
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt

from eodarm.data.measurements import Measurements
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import (
    Effect,
    Slot,
    param_from_theta,
    theta_from_param,
)

__all__ = [
    "FitResult",
    "FitWarning",
    "Inadequacy",
    "Problem",
    "compare",
    "cross_validate",
    "determining_channel",
    "fit",
    "model_inadequacy",
    "outlier_table",
    "settle",
]

#: z of a two-sided 95 % normal interval.
Z95 = 1.959963984540054

T = TypeVar("T")

#: At most this many refits when leaving outliers out (each round leaves out every cell beyond
#: the threshold at once; docs/diagnosis.md, "Outliers").
PEEL_ROUNDS = 8


class Problem:
    """An arm, measurements and the whitened residual machinery shared by fits.

    Parameters
    ----------
    arm : the arm.
    meas : the measurements (their ``n`` must equal the arm's).
    self_weight : include weights in both states (as the measured arm carried them).
    exclude : optional boolean (N, C) mask of measured cells to leave out (outliers).
    model : ``"analytic"`` or ``"fem"``, the model that predicts the channels (as in
        :func:`eodarm.solve`); ``fem_options`` go with ``"fem"``.
    """

    def __init__(
        self,
        arm: Arm,
        meas: Measurements,
        self_weight: bool = True,
        exclude: npt.NDArray[np.bool_] | None = None,
        model: str = "analytic",
        fem_options: Mapping[str, Any] | None = None,
    ) -> None:
        from eodarm.model import fem

        fem.check_model(model)
        self.model = model
        self.fem_options = fem.options(fem_options) if model == "fem" else None
        if meas.n != arm.n:
            raise EodarmError(
                f"{meas.source}: the measurements are for a {meas.n}-link arm, "
                f"the arm '{arm.name}' has {arm.n} links"
            )
        self.arm = arm
        self.meas = meas
        self.self_weight = self_weight
        self.alpha = np.ascontiguousarray(meas.alpha_deg, dtype=float)
        self.payload = np.zeros((meas.n_rows, 2))
        self.payload[:, 1] = -np.asarray(meas.mass_kg, dtype=float) * arm.g
        use = np.isfinite(meas.values)
        if exclude is not None:
            use &= ~exclude
        self.use = use
        self.obs = meas.values[use]
        self.sig = meas.sigma[use]
        self.n_values = int(use.sum())
        #: The arm file's own effects (docs/formats.md §2), held at their values in every evaluation
        #: unless the same effect@place is in the model being evaluated (then it is refitted).
        self.fixed = [(Slot.of(e), theta_from_param(e.name, e.value)) for e in arm.effects]
        self._custom: Any = None  # the evaluator of user-written effects, made on first use
        self._seq: Any = None  # the evaluator of sequences and frictions, made on first use

    # --------------------------------------------------------------- evaluation
    def evaluate(
        self,
        model: Sequence[tuple[Slot, float]],
        probes: Sequence[Slot] = (),
        rows: npt.NDArray[np.intp] | None = None,
        nan_on_failure: bool = False,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """:meth:`_evaluate`, whose refusal of a pose (``pose row k: …``, k counted in the
        rows solved) names the measurement file and the state's 1-based line instead."""
        try:
            return self._evaluate(model, probes, rows, nan_on_failure)
        except ValueError as exc:
            m = _POSE_ROW.search(str(exc))
            if m is None:
                raise
            k = int(m.group(1))
            index = np.arange(self.meas.n_rows) if rows is None else np.asarray(rows).ravel()
            if k >= index.size:
                raise
            row = int(index[k])
            # a file's 1-based line, or the 0-based row of arrays given in memory
            where = (
                f"row {row}"
                if self.meas.source.startswith("<")
                else f"line {int(self.meas.line[row])}"
            )
            under = ", ".join(  # the effects of the model that the state could not take
                f"{s.spec} = {param_from_theta(s.name, float(t)):.4g} {s.kind.unit}".rstrip()
                for s, t in [
                    *(f for f in self.fixed if f[0].key not in {s.key for s, _ in model}),
                    *model,
                ]
            )
            raise EodarmError(
                f"{self.meas.source} {where}: {str(exc)[m.end() :]}"
                + (f" (with {under})" if under else "")
            ) from None

    def _evaluate(
        self,
        model: Sequence[tuple[Slot, float]],
        probes: Sequence[Slot] = (),
        rows: npt.NDArray[np.intp] | None = None,
        nan_on_failure: bool = False,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Channels (N, C) of the model with θ values, and ∂y/∂θ (N, C, P) for ``probes``.

        With ``nan_on_failure`` a pose the model cannot solve is NaN instead of an error. The
        arm's own effects (:attr:`fixed`) are included where the model and the probes do not
        name the same effect@place.
        A model or probes with user-written effects go through
        :class:`~eodarm.analysis.sensitivity.CustomEvaluator` (forward differences).
        """
        from eodarm.model import native as _core
        from eodarm.model.solver import _core_arm

        if self.fixed:
            named = {s.key for s, _ in model} | {s.key for s in probes}
            model = [*(f for f in self.fixed if f[0].key not in named), *model]

        from eodarm.analysis import sequences

        if self.meas.has_sequences or sequences.has_friction([*(s for s, _ in model), *probes]):
            # Memory (load sequences, frictions): :mod:`eodarm.analysis.sequences`.
            if self.model == "fem":
                raise EodarmError(
                    "load sequences and frictions are modelled by the analytic model only"
                )
            if self._seq is None:
                self._seq = sequences.SequenceEvaluator(self.arm, self.meas, self.self_weight)
            return self._seq.evaluate(  # type: ignore[no-any-return]
                model,
                probes,
                rows,
                nan_on_failure,
                lambda m, p: self.evaluate(m, p, None, nan_on_failure),
            )
        n = self.arm.n
        alpha, payload = self.alpha, self.payload
        if rows is not None:
            alpha = np.ascontiguousarray(alpha[rows])
            payload = np.ascontiguousarray(payload[rows])
        user = [s for s, _ in model if s.kind.custom] + [s for s in probes if s.kind.custom]
        if user and self.model == "fem":
            raise EodarmError(
                f"custom effect {user[0].key}: the finite-element model cannot include "
                "user-written effects; use the analytic model"
            )
        if user:
            from eodarm.analysis.sensitivity import CustomEvaluator

            if self._custom is None:
                self._custom = CustomEvaluator(self.arm, self.alpha, self.payload, self.self_weight)
            return self._custom.evaluate(  # type: ignore[no-any-return]
                model,
                probes,
                rows,
                nan_on_failure,
                lambda m, p: self.evaluate(m, p, rows, nan_on_failure),
            )
        if self.model == "fem":
            from eodarm.model import fem

            return fem.evaluate(
                self.arm,
                alpha,
                payload,
                model,
                probes,
                self.self_weight,
                self.fem_options,
                nan_on_failure,
            )
        mc = np.array([s.code for s, _ in model], dtype=np.int64)
        mp = np.array([s.index(n) for s, _ in model], dtype=np.int64)
        mt = np.array([t for _, t in model], dtype=float)
        pc = np.array([s.code for s in probes], dtype=np.int64)
        pp = np.array([s.index(n) for s in probes], dtype=np.int64)
        return _core.jacobian(
            _core_arm(self.arm),
            alpha,
            payload,
            mc,
            mp,
            mt,
            pc,
            pp,
            self.self_weight,
            nan_on_failure,
        )

    def neutral(self, slot: Slot) -> float:
        """θ of a slot when it is not in the model."""
        if self.model == "fem":
            from eodarm.model import fem

            return fem.neutral(self.arm, slot)
        kind = slot.kind
        if kind.custom:
            return float(getattr(kind, "neutral", 0.0))
        if slot.name == "actuator_compliance":
            return 1.0 / self.arm.actuators[slot.index(self.arm.n)].stiffness_n_per_mm
        return 0.0

    def start(self, slot: Slot) -> float:
        """θ where a fit of a slot without a given value starts: the effect absent, or a
        user-written effect's ``start``."""
        kind = slot.kind
        if kind.custom and self.model != "fem":
            return float(getattr(kind, "start", 0.0))
        return self.neutral(slot)

    @staticmethod
    def bounds(slot: Slot) -> tuple[float, float]:
        return slot.kind.theta_bounds

    def whiten(self, y: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Whitened residual (obs − y)/σ over the used cells."""
        return (self.obs - y[self.use]) / self.sig

    def whiten_jac(self, jac: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        return jac[self.use] / self.sig[:, None]


@dataclass
class FitResult:
    """The outcome of fitting a model's effect parameters to measurements."""

    problem: Problem
    slots: list[Slot]
    theta: npt.NDArray[np.float64]
    theta_stderr: npt.NDArray[np.float64]
    at_bound: list[bool]
    prediction: npt.NDArray[np.float64]  # (N, C)
    chi2: float
    iterations: int
    warnings: list[str] = field(default_factory=list)
    fixed: list[Effect] = field(default_factory=list)  # effects held at given values
    #: Covariance of θ (P, P); a parameter at a bound has its half-normal variance and no
    #: correlation (the data push it against the bound, not along the others).
    theta_cov: npt.NDArray[np.float64] | None = None

    @property
    def effects(self) -> list[Effect]:
        """The fitted effects (a stiffness stuck at θ = 0 is left out: it is absent)."""
        out = []
        for s, t in zip(self.slots, self.theta, strict=True):
            value = param_from_theta(s.name, float(t))
            if s.kind.value_error(value) is None:
                out.append(s.effect(value))
        return out

    @property
    def n_params(self) -> int:
        return len(self.slots)

    @property
    def dof(self) -> int:
        return max(self.problem.n_values - self.n_params, 1)

    @property
    def chi2_per_dof(self) -> float:
        return self.chi2 / self.dof

    @property
    def residual(self) -> npt.NDArray[np.float64]:
        """Measured minus model (N, C); NaN where not measured."""
        return self.problem.meas.values - self.prediction

    @property
    def z(self) -> npt.NDArray[np.float64]:
        """Residual in units of σ (N, C)."""
        return self.residual / self.problem.meas.sigma

    def rms(self, rows: npt.NDArray[np.bool_] | None = None) -> dict[str, float]:
        """RMS residual per measured channel (mm or deg), over the used cells."""
        return _rms(self.residual, self.problem.use, self.problem.meas.channels, rows)

    def estimate(self, i: int) -> float:
        return param_from_theta(self.slots[i].name, float(self.theta[i]))

    def stderr(self, i: int) -> float:
        """Standard error of the physical parameter (delta method through θ)."""
        s, t, e = self.slots[i], float(self.theta[i]), float(self.theta_stderr[i])
        if s.kind.compliance_like:
            return math.inf if t <= 0 else e / (t * t)
        return e

    def covariance(self) -> npt.NDArray[np.float64]:
        """Covariance (P, P) of the physical parameters in their reported units (delta method
        through θ: a stiffness k = 1/θ has ∂k/∂θ = −1/θ²; an infinite stiffness, θ = 0, has
        infinite variance)."""
        k = len(self.slots)
        cov = self.theta_cov if self.theta_cov is not None else np.diag(self.theta_stderr**2)
        d = np.empty(k)
        for i, s in enumerate(self.slots):
            t = float(self.theta[i])
            if s.kind.compliance_like:
                d[i] = -math.inf if t <= 0 else -1.0 / (t * t)
            else:
                d[i] = 1.0
        with np.errstate(invalid="ignore"):
            out = cov * np.outer(d, d)
        out[~np.isfinite(d), :] = np.nan
        out[:, ~np.isfinite(d)] = np.nan
        for j in np.flatnonzero(~np.isfinite(d)).tolist():
            out[j, j] = math.inf
        return out

    def correlation(self) -> npt.NDArray[np.float64]:
        """Correlation matrix (P, P) of the physical parameters (NaN where undefined)."""
        cov = self.theta_cov if self.theta_cov is not None else np.diag(self.theta_stderr**2)
        sd = np.sqrt(np.clip(np.diag(cov), 0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(sd, sd)
        sign = np.array([-1.0 if s.kind.compliance_like else 1.0 for s in self.slots])
        corr = corr * np.outer(sign, sign)
        np.fill_diagonal(corr, np.where(sd > 0, 1.0, np.nan))
        return corr

    def undetermined(
        self, max_relative: float = 1.0, max_correlation: float = 0.95
    ) -> list[tuple[int, str]]:
        """Parameters the data do not determine: relative standard error above
        ``max_relative`` (100 %), or correlation with another parameter beyond
        ``max_correlation`` in magnitude. Returns (index, reason) pairs."""
        out: list[tuple[int, str]] = []
        corr = self.correlation()
        for i in range(len(self.slots)):
            est, err = self.estimate(i), self.stderr(i)
            if self.at_bound[i]:
                continue  # reported as at its bound
            if not math.isfinite(err) or (est != 0 and err / abs(est) > max_relative):
                rel = "∞" if not math.isfinite(err) or est == 0 else f"{100 * err / abs(est):.0f} %"
                out.append((i, f"relative standard error {rel}"))
                continue
            others = [
                (abs(float(corr[i, j])), j)
                for j in range(len(self.slots))
                if j != i and math.isfinite(corr[i, j])
            ]
            if others:
                c, j = max(others)
                if c > max_correlation:
                    out.append((i, f"correlation {corr[i, j]:+.3f} with {self.slots[j].spec}"))
        return out

    def fitted_arm(
        self,
        data: str = "",
        data_sha256: str = "",
        inadequacy: Inadequacy | None = None,
    ) -> Arm:
        """The arm with the fitted effects in it (docs/formats.md, fitted model): the
        problem's arm, its same effect@place replaced, each fitted value with its standard
        error, and a ``[fit]`` table with the covariance of the parameters that have one (a
        parameter at its bound, or an infinite stiffness, is written without covariance), the
        data's name and hash, χ²/dof, the date and the model's inadequacy per channel
        (``inadequacy``, :func:`model_inadequacy` of this fit when not given). A parameter
        the data do not determine is marked ``determined = false`` (use :func:`settle` first
        to fix those the data give only a bound for). Solving the returned arm gives exactly
        this fit's model."""
        import datetime

        from eodarm.model.arm import EffectMark, FitRecord

        if inadequacy is None:
            inadequacy = model_inadequacy(self)
        loose = dict(self.undetermined())
        effects, errs, marks, keep = [], [], [], []
        for i, s in enumerate(self.slots):
            value = self.estimate(i)
            if not math.isfinite(value) or (value == 0 and not s.kind.allow_zero):
                continue  # an absent effect (rigid, θ = 0) is not written
            effects.append(s.effect(value))
            err = self.stderr(i)
            errs.append(err if math.isfinite(err) else None)
            marks.append(EffectMark(determined=False) if i in loose else None)
            if not self.at_bound[i] and math.isfinite(err):
                keep.append(i)
        cov = self.covariance()[np.ix_(keep, keep)]
        record = FitRecord(
            parameters=tuple(f"{self.slots[i].key}:{self.slots[i].kind.param}" for i in keep),
            covariance=tuple(tuple(float(x) for x in row) for row in (cov + cov.T) / 2),
            data=data,
            data_sha256=data_sha256,
            chi2_per_dof=float(self.chi2_per_dof),
            n_values=int(self.problem.n_values),
            date=datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            explained=inadequacy.explained,
            sigma_model=tuple(inadequacy.sigma_model.items()),
            heldout_rms=tuple(inadequacy.heldout_rms.items()),
            noise_rms=tuple(inadequacy.noise_rms.items()),
        )
        arm = self.problem.arm
        fixed = [e for e in self.fixed if e.key not in {s.key for s in self.slots}]
        return arm.with_effects(
            [*fixed, *effects],
            [*([None] * len(fixed)), *errs],
            fit=record,
            marks=[*([None] * len(fixed)), *marks],
        )

    def theta_interval(self, i: int) -> tuple[float, float]:
        """The 95 % interval of θ (module table) clipped to its physical bounds: where it
        reaches θ = 0 a stiffness may be infinite (rigid) and a gap zero (absent)."""
        lo, hi = self.problem.bounds(self.slots[i])
        t, e = float(self.theta[i]), float(self.theta_stderr[i])
        if not math.isfinite(e):
            return lo, hi
        return max(lo, t - Z95 * e), min(hi, t + Z95 * e)

    def interval(self, i: int) -> tuple[float, float]:
        """The 95 % interval of the physical parameter, mapped from :meth:`theta_interval`
        (so it never crosses a physical bound: a stiffness is in (0, ∞], a gap ≥ 0),
        lowest value first."""
        a, b = (param_from_theta(self.slots[i].name, x) for x in self.theta_interval(i))
        return (min(a, b), max(a, b))

    def summary(self) -> dict[str, Any]:
        """Contract-shaped summary: effects with estimate and stderr, rms and χ²/dof."""
        return {
            "effects": [
                {
                    "effect": s.name,
                    "at": s.at,
                    "estimate": {s.kind.param: _json_num(self.estimate(i))},
                    "stderr": {s.kind.param: _json_num(self.stderr(i))},
                }
                for i, s in enumerate(self.slots)
            ],
            "rms": self.rms(),
            "chi2_per_dof": self.chi2_per_dof,
        }

    def covariance_json(self) -> dict[str, Any]:
        """``parameters`` (``effect@place:parameter``, the matrices' order), ``covariance``
        (units² of the reported parameters) and ``correlation``; JSON null where undefined."""
        cov, corr = self.covariance(), self.correlation()
        return {
            "parameters": [f"{s.key}:{s.kind.param}" for s in self.slots],
            "covariance": [[_json_num(float(x)) for x in row] for row in cov],
            "correlation": [[_json_num(float(x)) for x in row] for row in corr],
        }


#: The solvers' way of naming a pose: ``pose row k: `` (0-based, in the rows solved).
_POSE_ROW = re.compile(r"pose row (\d+):\s*")


def check_validity(result: FitResult) -> None:
    """Refuse a fit whose parameters put measured states outside the model's validity
    (:mod:`eodarm.model.validity`): one line naming the reasons and the parameters.

    Raises
    ------
    EodarmError
        When any measured state of the fitted model is not ``ok``.
    """
    from eodarm.model.solver import solve
    from eodarm.model.validity import status_counts

    prob = result.problem
    if prob.model != "analytic" or not result.slots:
        return
    meas = prob.meas
    mass = meas.mass_kg
    effects = [*result.fixed, *result.effects]
    code = np.asarray(
        solve(prob.arm, prob.alpha, mass, effects, self_weight=prob.self_weight)["status"]
    )
    if not (code != 0).any():
        return
    # the states that are outside already without the fitted effects are not the fit's fault
    base = np.asarray(
        solve(prob.arm, prob.alpha, mass, list(result.fixed), self_weight=prob.self_weight)[
            "status"
        ]
    )
    before = (base != 0) & (code != 0)
    if before.any():
        counts = status_counts(base[before])
        lines = ", ".join(str(int(x)) for x in np.asarray(meas.line)[before][:10])
        raise EodarmError(
            f"{meas.source}: {int(before.sum())} of {meas.n_rows} measured states are "
            "outside the model's validity before any effect is fitted ("
            + ", ".join(f"{k} {v}" for k, v in counts.items() if k != "ok")
            + f"; line(s) {lines}; docs/model.md, Validity): a data or geometry problem, not "
            "the fit's"
        )
    counts = status_counts(code)
    params = ", ".join(
        f"{s.spec} = {param_from_theta(s.name, float(t)):.4g} {s.kind.unit}".rstrip()
        for s, t in zip(result.slots, result.theta, strict=True)
    )
    lines = ", ".join(str(int(x)) for x in np.asarray(meas.line)[code != 0][:10])
    raise EodarmError(
        f"the fitted {params} put {int((code != 0).sum())} of {meas.n_rows} measured states "
        f"of {meas.source} outside the model's validity ("
        + ", ".join(f"{k} {v}" for k, v in counts.items() if k != "ok")
        + f"; line(s) {lines}; docs/model.md, Validity): the data do not support this model"
    )


def determining_channel(slot: Slot, measured: Sequence[str]) -> str:
    """The measurement that would pin down a slot's parameter, in words: its own channel if
    the data lack it, else more poses that load it differently."""
    i = slot.index(10**6) + 1  # 1-based place number (the arm's size does not matter here)
    own = {
        "actuator_compliance": f"dl{i}_mm",  # the body's own length sensor
        "mount_compliance": f"dl{i}_mm",  # separates the mount from the body in series
        "actuator_play": f"dl{i}_mm",
        "joint_clearance": f"dalpha{i}_deg",
        "link_bending": f"dalpha{i}_deg",
        "base_compliance": "dalpha1_deg",
        "actuator_friction": f"dl{i}_mm",  # the body's sensor sees what the body spring takes
    }.get(slot.name)
    if own is not None and own not in measured:
        return f"measure {own}"
    if slot.name in ("actuator_friction", "joint_friction"):
        return (
            "load and unload (a load cycle with a step column): the unloading branch and the "
            "return to zero payload show a friction (docs/diagnosis.md, load sequences)"
        )
    return "add poses and payloads that load it differently (docs/diagnosis.md, advice)"


def _json_num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _rms(
    residual: npt.NDArray[np.float64],
    use: npt.NDArray[np.bool_],
    channels: Sequence[str],
    rows: npt.NDArray[np.bool_] | None = None,
) -> dict[str, float]:
    out: dict[str, float] = {}
    for c, ch in enumerate(channels):
        m = use[:, c] if rows is None else use[:, c] & rows
        if m.any():
            out[ch] = float(np.sqrt(np.mean(residual[m, c] ** 2)))
    return out


@dataclass(frozen=True)
class Inadequacy:
    """How far a fitted model misses its own data beyond their noise, per measured channel.

    Attributes
    ----------
    explained : the fit's χ² is consistent with the noise (p ≥ 0.001,
        :func:`eodarm.analysis.consistency.fit_p_value`): then every ``sigma_model`` is 0.
    sigma_model : channel → √max(0, mean r² − mean σ²) over its held-out cells (r the
        leave-one-configuration-out residual, σ the measurement's own), its unit.
    heldout_rms : channel → √(mean r²); ``noise_rms`` channel → √(mean σ²).
    """

    explained: bool
    sigma_model: dict[str, float]
    heldout_rms: dict[str, float]
    noise_rms: dict[str, float]


def model_inadequacy(result: FitResult, cv: Mapping[str, Any] | None = None) -> Inadequacy:
    """The model part of a prediction's σ, per channel (docs/model.md, "Prediction errors").

    Where the fit explains its data the part is zero. Otherwise each configuration is left out
    in turn, the model refitted without it and its cells predicted (``cv``, the result of
    :func:`cross_validate` for this fit's model and outliers, is used when given); the part is
    what the held-out residuals' mean square exceeds the measurements' noise by. With a
    single configuration the fit's own residuals stand in, scaled by values/(values − P).
    """
    from eodarm.analysis.consistency import P_PASS, fit_p_value

    prob = result.problem
    meas = prob.meas
    measured = [ch for c, ch in enumerate(meas.channels) if prob.use[:, c].any()]
    if fit_p_value(result) >= P_PASS:
        return Inadequacy(True, dict.fromkeys(measured, 0.0), {}, {})
    if cv is None and len(meas.configs) >= 2:
        outliers = np.isfinite(meas.values) & ~prob.use
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)
            cv = cross_validate(
                prob.arm,
                meas,
                result.slots,
                self_weight=prob.self_weight,
                model=prob.model,
                fem_options=prob.fem_options,
                exclude=outliers if outliers.any() else None,
                start=result.theta if result.slots else None,
            )
    if cv is not None:
        resid = np.asarray(cv["residual"], dtype=float)
        inflate = 1.0
    else:
        resid = np.where(prob.use, result.residual, np.nan)
        inflate = prob.n_values / max(prob.n_values - result.n_params, 1)
    sm, ho, nr = {}, {}, {}
    for c, ch in enumerate(meas.channels):
        cells = np.isfinite(resid[:, c]) & prob.use[:, c]
        if not cells.any():
            continue
        r2 = float(np.mean(resid[cells, c] ** 2)) * inflate
        s2 = float(np.mean(meas.sigma[cells, c] ** 2))
        ho[ch], nr[ch] = math.sqrt(r2), math.sqrt(s2)
        sm[ch] = math.sqrt(max(r2 - s2, 0.0))
    return Inadequacy(False, sm, ho, nr)


def settle(result: FitResult, exclude: npt.NDArray[np.bool_] | None = None) -> FitResult:
    """The fit with what the data give only a bound for fixed at its physical end, the rest
    refitted (docs/model.md, "Undetermined parameters").

    A parameter whose 95 % interval in θ reaches θ = 0 (a relative error above 100 %, or a
    parameter stuck at that bound) is fixed there: a stiffness "stiffer than X: treated as
    rigid" (written with the arm file's rigid value, 10²⁰), a gap "at most X: treated as
    absent" (0). The arm of the returned fit carries these effects marked with
    ``determined = false``, ``bound`` and ``limit`` (X, the 95 % limit), so that
    :meth:`FitResult.fitted_arm` writes them so and the predictions' σ include them. A
    parameter the data do not see at all (no finite bound) is left as it was. ``exclude``:
    the outlier cells the fit left out.
    """
    from eodarm.model.arm import MAX_STIFFNESS, EffectMark

    res = result
    for _ in range(len(result.slots)):
        loose = {i for i, _why in res.undetermined()}
        pinned = []
        for i, s in enumerate(res.slots):
            if s.kind.custom:
                continue  # a user's effect has its own neutral value and bounds
            lo_b = res.problem.bounds(s)[0]
            t_lo, t_hi = res.theta_interval(i)
            at_low = res.at_bound[i] and float(res.theta[i]) <= lo_b + 1e-15
            if not (i in loose or at_low) or t_lo > lo_b or not math.isfinite(t_hi) or t_hi <= 0:
                continue
            limit = param_from_theta(s.name, t_hi)
            if s.kind.compliance_like:
                fixed_at, bound = MAX_STIFFNESS, "lower"
            else:
                fixed_at, bound = 0.0, "upper"
            pinned.append((i, s.effect(fixed_at), EffectMark(False, bound, limit)))
        if not pinned:
            return res
        prob = res.problem
        gone = {i for i, _, _ in pinned}
        arm = prob.arm.with_effects(
            [e for _, e, _ in pinned], [None] * len(pinned), marks=[m for _, _, m in pinned]
        )
        rest = [s for i, s in enumerate(res.slots) if i not in gone]
        start = [float(res.theta[i]) for i in range(len(res.slots)) if i not in gone]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)
            res = fit(
                arm,
                prob.meas,
                rest,
                self_weight=prob.self_weight,
                exclude=exclude,
                start=start or None,
                model=prob.model,
                fem_options=prob.fem_options,
            )
    return res


def fit(
    arm: Arm,
    meas: Measurements,
    effects: Iterable[Effect | Slot | str] = (),
    self_weight: bool = True,
    exclude: npt.NDArray[np.bool_] | None = None,
    problem: Problem | None = None,
    start: Sequence[float] | npt.NDArray[np.float64] | None = None,
    max_iter: int = 30,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
) -> FitResult:
    """Least-squares fit of the effects' parameters, within their physical bounds.

    Parameters
    ----------
    arm, meas : the arm and the measurements.
    effects : the effects to fit (``Effect`` values give the starting point; ``Slot`` or
        ``"effect@place"`` start from the effect being absent).
    self_weight : as :func:`eodarm.solve`.
    exclude : (N, C) mask of cells left out (outliers).
    model, fem_options : the model that predicts the channels (see :class:`Problem`); a given
        ``problem`` brings its own.

    Returns
    -------
    FitResult
        θ, standard errors (from the covariance ``(JᵀJ)⁻¹`` scaled by ``max(1, χ²/dof)``),
        prediction, χ². A parameter at a bound is flagged, with a warning in
        ``result.warnings``.
    """
    prob = problem or Problem(arm, meas, self_weight, exclude, model=model, fem_options=fem_options)
    given = list(effects)
    slots = [Slot.of(e) for e in given]
    keys = [s.key for s in slots]
    if len(set(keys)) != len(keys):
        raise EodarmError(f"an effect is given twice: {keys}")
    for s in slots:
        s.index(arm.n)
    in_file = {s.key: th for s, th in prob.fixed}
    theta = np.array(
        [
            theta_from_param(e.name, e.value)
            if isinstance(e, Effect)
            else in_file.get(s.key, prob.start(s))  # a file's effect starts at its value
            for s, e in zip(slots, given, strict=True)
        ],
        dtype=float,
    )
    lo = np.array([prob.bounds(s)[0] for s in slots])
    hi = np.array([prob.bounds(s)[1] for s in slots])
    default = np.clip(theta, lo, hi)
    theta = default if start is None else np.clip(np.asarray(start, dtype=float), lo, hi)

    def at(th: npt.NDArray[np.float64]) -> tuple[Any, Any, float]:
        y, jac = prob.evaluate(list(zip(slots, th, strict=True)), slots)
        r = prob.whiten(y)
        return y, jac, float(r @ r)

    # A given start (e.g. diagnose's linearised estimate) may lie outside the model's domain
    # (a measured state that cannot be closed there): move it back towards the default start
    # (the effects absent, or the file's values) until every state closes.
    for lam in (0.5, 0.25, 0.125, 0.0625, 0.0):
        try:
            y, jac, chi2 = at(theta)
            break
        except EodarmError:
            if start is None:
                raise
            theta = default + lam * (np.clip(np.asarray(start, dtype=float), lo, hi) - default)
    else:
        y, jac, chi2 = at(theta)
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007
        if not slots:
            break
        r = prob.whiten(y)
        a = prob.whiten_jac(jac)
        step = _bounded_step(a, r, lo - theta, hi - theta)
        # Backtrack if the exact model disagrees with the linear one (rare: it is ~linear).
        lam = 1.0
        accepted = False
        for _ in range(8):
            trial = np.clip(theta + lam * step, lo, hi)
            try:
                y2, jac2, chi2b = at(trial)
            except EodarmError:
                # The trial left the model's domain (a triangle that cannot close, a singular
                # pose): too long a step, like one that raises χ²; the current θ was solvable.
                lam *= 0.5
                continue
            if chi2b <= chi2 * (1 + 1e-12) + 1e-12:
                accepted = True
                break
            lam *= 0.5
        if not accepted:
            break
        improvement = chi2 - chi2b
        theta, y, jac, chi2 = trial, y2, jac2, chi2b
        if improvement <= 1e-9 * max(chi2, 1.0):
            break
    # Covariance of θ from the whitened Jacobian at the solution.
    stderr = np.full(len(slots), np.nan)
    theta_cov = np.zeros((len(slots), len(slots)))
    at_bound = [bool(theta[i] <= lo[i] + 1e-15 or theta[i] >= hi[i]) for i in range(len(slots))]
    notes: list[str] = []
    if slots:
        a = prob.whiten_jac(jac)
        free = ~np.array(at_bound)
        dof = max(prob.n_values - len(slots), 1)
        scale = max(1.0, chi2 / dof)
        if free.any():
            # Scale the columns first: θ of different effects differ by 1e8 (mm vs 1/EI),
            # and an unscaled pseudo-inverse would cut the small directions off.
            af = a[:, free]
            norms = np.linalg.norm(af, axis=0)
            norms[norms == 0] = 1.0
            an = af / norms
            cov_n = np.linalg.pinv(an.T @ an) * scale
            stderr[free] = np.sqrt(np.clip(np.diag(cov_n), 0, None)) / norms
            theta_cov[np.ix_(free, free)] = cov_n / np.outer(norms, norms)
        for i, s in enumerate(slots):
            if at_bound[i]:
                # Half-normal bound: how far θ could go before χ² rises by 1.
                col = a[:, i]
                stderr[i] = math.sqrt(scale) / max(float(np.linalg.norm(col)), 1e-300)
                # (a column of zeros: the data do not see it at all, an infinite variance)
                theta_cov[i, i] = stderr[i] ** 2 if stderr[i] < 1e150 else math.inf
                where = "its upper bound" if theta[i] >= hi[i] else "its lower bound (absent)"
                notes.append(f"{s.key}: parameter stuck at {where}; the data do not want it")
        for msg in notes:
            warnings.warn(msg, FitWarning, stacklevel=2)
    return FitResult(prob, slots, theta, stderr, at_bound, y, chi2, it, notes, theta_cov=theta_cov)


class FitWarning(UserWarning):
    """A fitted parameter sits at a physical bound."""


def _bounded_step(
    a: npt.NDArray[np.float64],
    r: npt.NDArray[np.float64],
    lo: npt.NDArray[np.float64],
    hi: npt.NDArray[np.float64],
) -> npt.NDArray[np.float64]:
    """argmin ||r − a·d|| subject to lo ≤ d ≤ hi (exact; :mod:`eodarm.analysis.boxlsq`)."""
    from eodarm.analysis.boxlsq import bounded_lstsq

    return bounded_lstsq(a, r, lo, hi)


def robust_fit(
    arm: Arm,
    meas: Measurements,
    effects: Sequence[Effect | Slot | str] = (),
    self_weight: bool = True,
    z_max: float = 4.0,
    share: float = 0.02,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
) -> tuple[FitResult, npt.NDArray[np.bool_]]:
    """Fit, then leave out the cells more than ``z_max`` σ off, and refit (:func:`peel_outliers`).

    At most ``share`` of the values (at least one) may be left out, and only if the fit
    without them is consistent with the noise (χ² p ≥ 0.001): a few typos are named, but a
    model that is wrong everywhere is not "cleaned" into agreement. Returns the fit and the
    (N, C) mask of left-out cells (all False when none).
    """
    kw: dict[str, Any] = {"model": model, "fem_options": fem_options}
    res = fit(arm, meas, list(effects), self_weight=self_weight, **kw)
    return peel_outliers(
        res,
        lambda mask: fit(arm, meas, list(effects), self_weight=self_weight, exclude=mask, **kw),
        lambda r: r,
        z_max,
        share,
    )


def peel_outliers(
    first: T,
    refit: Callable[[npt.NDArray[np.bool_]], T],
    best_of: Callable[[T], FitResult],
    z_max: float = 4.0,
    share: float = 0.02,
    max_rounds: int = PEEL_ROUNDS,
) -> tuple[T, npt.NDArray[np.bool_]]:
    """Leave out every cell more than ``z_max`` σ off, redo the work, and re-check.

    ``first`` is the work on all cells, ``refit(mask)`` redoes it without the masked cells and
    ``best_of`` gives the fit whose residuals judge the cells. Each round judges every measured
    cell, the left-out ones included (the fit predicts them too), against the last fit: the
    mask becomes the cells beyond ``z_max`` (the ``share`` of the values with the largest
    ``|z|`` when more are), and the work is redone. A cell that a typo elsewhere had dragged
    beyond the threshold comes back once the typo is out. The rounds stop when the mask no
    longer changes, after at most ``max_rounds`` refits: the cost is a few fits, whatever the
    size of the file. The exclusion stands only if it leaves out at most ``share`` of the
    values (at least one) and the best fit is then consistent with the noise (p ≥ 0.001 by
    :func:`eodarm.analysis.consistency.fit_p_value`); otherwise ``first`` stands and the mask
    is all False (docs/diagnosis.md, "Outliers").
    """
    from eodarm.analysis.consistency import P_PASS, fit_p_value

    base = best_of(first)
    mask = np.zeros(base.problem.meas.values.shape, dtype=bool)
    budget = max(1, int(share * base.problem.n_values))
    current = first
    for _ in range(max_rounds):
        best = best_of(current)
        z = np.abs(best.z)
        z[~np.isfinite(z)] = 0.0  # not measured (or a non-finite prediction): never flagged
        beyond = np.flatnonzero(z > z_max)
        if beyond.size > budget:
            # keep the worst: the rest may be dragged by them, and the next round says so
            beyond = beyond[np.argsort(z.flat[beyond], kind="stable")[::-1][:budget]]
        new = np.zeros_like(mask)
        new.flat[beyond] = True
        if np.array_equal(new, mask):
            break
        mask = new
        if not mask.any():
            current = first
            break
        current = refit(mask.copy())
    best = best_of(current)
    if mask.any() and fit_p_value(best) >= P_PASS:
        return current, mask
    return first, np.zeros_like(mask)


def outlier_table(result: FitResult, mask: np.ndarray) -> list[dict[str, Any]]:
    """The flagged cells as rows: file line, configuration, payload, channel, values, z."""
    meas = result.problem.meas
    z = result.z
    rows = []
    for r, c in zip(*np.nonzero(mask), strict=True):
        rows.append(
            {
                "line": int(meas.line[r]),
                "config": str(meas.config[r]),
                "mass_kg": float(meas.mass_kg[r]),
                "channel": meas.channels[c],
                "measured": float(meas.values[r, c]),
                "model": float(result.prediction[r, c]),
                "z": float(z[r, c]),
            }
        )
    return rows


def compare(
    arm: Arm,
    meas: Measurements,
    effects: Sequence[Effect] = (),
    self_weight: bool = True,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
) -> FitResult:
    """The model with fixed effects against the measurements (nothing fitted)."""
    prob = Problem(arm, meas, self_weight=self_weight, model=model, fem_options=fem_options)
    slots = [Slot.of(e) for e in effects]
    theta = np.array([theta_from_param(e.name, e.value) for e in effects], dtype=float)
    y, _ = prob.evaluate(list(zip(slots, theta, strict=True)))
    r = prob.whiten(y)
    # A fixed model has no fitted parameters: report it with zero of them.
    return FitResult(
        prob, [], np.zeros(0), np.zeros(0), [], y, float(r @ r), 0, fixed=list(effects)
    )


def cross_validate(
    arm: Arm,
    meas: Measurements,
    effects: Sequence[Effect | Slot | str],
    self_weight: bool = True,
    by: str = "config",
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
    exclude: npt.NDArray[np.bool_] | None = None,
    start: Sequence[float] | npt.NDArray[np.float64] | None = None,
    exact: bool | None = None,
) -> dict[str, Any]:
    """Leave one configuration out: fit without it, predict it.

    ``exclude`` is an (N, C) mask of cells left out everywhere (outliers): they are neither
    fitted nor predicted. ``start`` is a starting θ for every fold (e.g. the fit on all the
    data, which makes each fold converge in a step or two).

    ``exact``: refit every fold to convergence (True), or take each fold's θ one bounded
    Gauss–Newton step from the fit on all the data, with that fold's rows taken out of the
    normal equations (False; the cost of one fit, whatever the number of configurations).
    The default (None) refits exactly up to :data:`CV_EXACT_CONFIGS` configurations
    (docs/diagnosis.md, "Held-out error of many configurations").

    Returns ``{"rms": {channel: rms over every held-out cell}, "per_config": {label: rms},
    "residual": (N, C) held-out residuals (NaN where not used)}``.
    """
    if by != "config":
        raise EodarmError(f"--cv {by}: only 'config' is supported")
    configs = list(meas.configs)
    if len(configs) < 2:
        raise EodarmError("cross-validation needs at least two configurations")
    slots = [Slot.of(e) for e in effects]
    kw: dict[str, Any] = {"model": model, "fem_options": fem_options}
    full = Problem(arm, meas, self_weight=self_weight, exclude=exclude, **kw)
    resid = np.full_like(meas.values, np.nan)
    labels = np.asarray(meas.config)
    if exact is None:
        exact = len(configs) <= CV_EXACT_CONFIGS
    if not slots:
        # Nothing is fitted: every configuration is predicted by the same model.
        y, _ = full.evaluate([])
        resid = np.where(full.use, meas.values - y, np.nan)
    elif not exact:
        resid = _linearised_folds(arm, meas, slots, full, labels, start)
    else:
        for label in configs:
            held = labels == label
            gone = np.broadcast_to(held[:, None], meas.values.shape)
            train = Problem(
                arm,
                meas,
                self_weight=self_weight,
                exclude=gone if exclude is None else gone | exclude,
                **kw,
            )
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", FitWarning)
                res = fit(arm, meas, slots, problem=train, start=start)
            # the fit's prediction covers every row, the held-out ones included
            rows = np.flatnonzero(held)
            y = res.prediction[rows]
            resid[rows] = np.where(full.use[rows], meas.values[rows] - y, np.nan)
    per = _rms_by_label(resid, full.use, meas.channels, labels, configs)
    return {"rms": _rms(resid, full.use, meas.channels), "per_config": per, "residual": resid}


#: Up to this many configurations, leave-one-configuration-out refits every fold to
#: convergence; above, each fold is one linearised step from the fit on all the data.
CV_EXACT_CONFIGS = 40


def _linearised_folds(
    arm: Arm,
    meas: Measurements,
    slots: list[Slot],
    full: Problem,
    labels: npt.NDArray[Any],
    start: Sequence[float] | npt.NDArray[np.float64] | None,
) -> npt.NDArray[np.float64]:
    """Held-out residuals (N, C) of every configuration, its fold's θ one bounded Gauss–Newton
    step from the fit on all the data: with A the whitened Jacobian and r the whitened residual
    there, fold k minimises ‖r − A d‖² over the other configurations' cells, i.e. with
    G − G_k = Aᵀ A − A_kᵀ A_k and b − b_k = Aᵀ r − A_kᵀ r_k, within the bounds of θ + d; its
    rows are then predicted as y_k + J_k d. Exact for a model linear in θ (the compliance-like
    θ are nearly so). Costs one fit and (P × P) work per configuration."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        base = fit(arm, meas, slots, problem=full, start=start)
    theta = base.theta
    y, jac = full.evaluate(list(zip(slots, theta, strict=True)), slots)
    use = full.use
    sig = np.where(use, meas.sigma, 1.0)
    r = np.where(use, (meas.values - y) / sig, 0.0)  # (N, C)
    a = np.where(use[..., None], jac / sig[..., None], 0.0)  # (N, C, P)
    keys, group = np.unique(labels, return_inverse=True)
    k, p = len(keys), len(slots)
    gk = np.zeros((k, p, p))
    bk = np.zeros((k, p))
    np.add.at(gk, group, np.einsum("ncp,ncq->npq", a, a))
    np.add.at(bk, group, np.einsum("ncp,nc->np", a, r))
    g_all, b_all = gk.sum(axis=0), bk.sum(axis=0)
    lo = np.array([full.bounds(s)[0] for s in slots]) - theta
    hi = np.array([full.bounds(s)[1] for s in slots]) - theta
    d = _box_steps(g_all[None] - gk, b_all[None] - bk, lo, hi)
    pred = y + np.einsum("ncp,np->nc", jac, d[group])
    return np.where(use, meas.values - pred, np.nan)


def _box_steps(
    g: npt.NDArray[np.float64],
    b: npt.NDArray[np.float64],
    lo: npt.NDArray[np.float64],
    hi: npt.NDArray[np.float64],
) -> npt.NDArray[np.float64]:
    """argmin dᵀ G_k d − 2 dᵀ b_k subject to lo ≤ d ≤ hi, for K problems at once ((K, P, P),
    (K, P)); G_k positive semi-definite. As :mod:`eodarm.analysis.boxlsq`: the minimiser is
    the unconstrained one of the unknowns not at a bound, so every assignment of each unknown
    to {free, lower, upper} (finite bounds only) is solved for all K at once and the feasible
    one of least cost kept. Unknowns are scaled by √diag(ΣG) first (θ differ by 1e8)."""
    import itertools

    k, p = b.shape
    scale = np.sqrt(np.abs(np.einsum("kii->i", g)))  # Σ over the K problems of diag G_k
    scale[~(scale > 0)] = 1.0
    gn = g / np.outer(scale, scale)
    bn = b / scale
    lon, hin = lo * scale, hi * scale
    best = np.zeros((k, p))
    cost = np.full(k, np.inf)
    choices = [
        [c for c, v in (("free", 0.0), ("lo", lon[j]), ("hi", hin[j])) if np.isfinite(v)]
        for j in range(p)
    ]
    for pattern in itertools.product(*choices):
        free = np.array([c == "free" for c in pattern])
        x = np.zeros((k, p))
        x[:, ~free] = np.where([c == "hi" for c in pattern], hin, lon)[~free]
        if free.any():
            rhs = bn[:, free] - np.einsum("kij,kj->ki", gn[:, free][:, :, ~free], x[:, ~free])
            inv = np.linalg.pinv(gn[:, free][:, :, free], rcond=1e-12, hermitian=True)
            x[:, free] = np.einsum("kij,kj->ki", inv, rhs)
        tol = 1e-9 * (1.0 + np.abs(x))
        ok = np.all((x >= lon - tol) & (x <= hin + tol), axis=1)
        c = np.einsum("ki,kij,kj->k", x, gn, x) - 2 * np.einsum("ki,ki->k", x, bn)
        better = ok & (c < cost)
        best[better], cost[better] = x[better], c[better]
    return np.clip(best / scale, lo, hi)


def _rms_by_label(
    resid: npt.NDArray[np.float64],
    use: npt.NDArray[np.bool_],
    channels: Sequence[str],
    labels: npt.NDArray[Any],
    order: Sequence[str],
) -> dict[str, dict[str, float]]:
    """:func:`_rms` of each label's rows, in one pass over the cells."""
    keys, group = np.unique(labels, return_inverse=True)
    ok = use
    sq = np.where(use, resid, 0.0) ** 2
    out: dict[str, dict[str, float]] = {}
    count = [
        np.bincount(group, weights=ok[:, c], minlength=len(keys)) for c in range(len(channels))
    ]
    total = [
        np.bincount(group, weights=sq[:, c], minlength=len(keys)) for c in range(len(channels))
    ]
    at = {str(lab): g for g, lab in enumerate(keys.tolist())}
    for label in order:
        g = at[str(label)]
        out[label] = {
            ch: float(np.sqrt(total[c][g] / count[c][g]))
            for c, ch in enumerate(channels)
            if count[c][g] > 0
        }
    return out
