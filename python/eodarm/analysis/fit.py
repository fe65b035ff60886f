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
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.data.measurements import Measurements
from eodarm.errors import EodarmError, show, show_source
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
    "Problem",
    "ValidityMark",
    "compare",
    "determining_channel",
    "fit",
    "validity_mark",
]

#: z of a two-sided 95 % normal interval.
Z95 = 1.959963984540054


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
            return 1.0 / self.arm.linear(slot.index(self.arm.n)).stiffness_n_per_mm
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


@dataclass(frozen=True)
class ValidityMark:
    """The measured states a fitted model puts outside its validity (docs/model.md §7),
    kept in the fit and marked (:func:`validity_mark`).

    Attributes
    ----------
    states : how many; ``of``: of how many measured states.
    status : status name → count (``large_deflection`` …).
    lines : the first ten states' lines in the measurement file.
    before_fit : whether the model without the fitted effects (the arm file's) already puts
        them there: then the data or the geometry hold them, not the fitted values.
    message : the one line the commands print.
    """

    states: int
    of: int
    status: dict[str, int]
    lines: list[int]
    before_fit: bool
    message: str

    def to_json(self) -> dict[str, Any]:
        return {
            "states": self.states,
            "of": self.of,
            "status": dict(self.status),
            "lines": list(self.lines),
            "before_fit": self.before_fit,
        }


def validity_mark(result: FitResult) -> ValidityMark | None:
    """The measured states that the fitted model puts outside its validity
    (:mod:`eodarm.model.validity`), or None.

    Such states are not refused: data measured on a heavily loaded arm, or made by
    :func:`eodarm.analysis.synth.synth` from this very model, can hold them, and the model
    still predicts them (the loaded pose is closed exactly). They stay in the fit and are
    marked: the model is not trusted there (its forces come from the undeformed geometry),
    and the commands say so in one line naming the file, the statuses and the lines.
    """
    from eodarm.model.solver import solve
    from eodarm.model.validity import status_counts

    prob = result.problem
    if prob.model != "analytic":
        return None
    meas = prob.meas
    mass = meas.mass_kg
    effects = [*result.fixed, *result.effects]
    code = np.asarray(
        solve(prob.arm, prob.alpha, mass, effects, self_weight=prob.self_weight)["status"]
    )
    if not (code != 0).any():
        return None
    base = np.asarray(
        solve(prob.arm, prob.alpha, mass, list(result.fixed), self_weight=prob.self_weight)[
            "status"
        ]
    )
    bad = code != 0
    before = bool(((base != 0) & bad).sum() == bad.sum())
    counts = {k: v for k, v in status_counts(code[bad]).items() if k != "ok"}
    lines = [int(x) for x in np.asarray(meas.line)[bad][:10]]
    where = show_source(meas.source)
    shown = ", ".join(str(x) for x in lines[:3]) + (" …" if bad.sum() > 3 else "")
    what = (
        f"{int(bad.sum())} of {meas.n_rows} measured states ("
        + ", ".join(f"{k} {v}" for k, v in counts.items())
        + f"; line(s) {shown})"
    )
    if before:
        msg = f"{where}: {what} are outside the model's validity before any effect is fitted"
    else:
        params = ", ".join(
            f"{s.spec} = {param_from_theta(s.name, float(t)):.4g} {s.kind.unit}".rstrip()
            for s, t in zip(result.slots, result.theta, strict=True)
        )
        msg = f"the fitted {show(params, 80)} puts {what} of {where} outside the model's validity"
    msg += ": kept in the fit, the model is not trusted there (docs/model.md, Validity)"
    return ValidityMark(int(bad.sum()), meas.n_rows, counts, lines, before, msg)


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
