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
drive_compliance       1/stiffness_nmm_per_rad     θ ≥ 0 (θ = 0: rigid gear)
drive_backlash         backlash_deg                0 ≤ θ ≤ 5°
actuator_friction      friction_n                  θ ≥ 0 (θ = 0: absent)
joint_friction         torque_nmm                  θ ≥ 0 (θ = 0: absent)
drive_friction         torque_nmm                  θ ≥ 0 (θ = 0: absent)
=====================  ==========================  =====================================

The compiled core returns the model's channels and their sensitivities ∂y/∂θ for any set of
places in one call (:func:`eodarm._core.jacobian`); each Gauss–Newton step is then a small
bounded linear least-squares problem (:mod:`eodarm.analysis.gauss_newton`). Residuals are
whitened by the measurement σ (:class:`~eodarm.analysis.problem.Problem`).

With ``model="fem"`` the channels come from the finite-element model (:mod:`eodarm.model.fem`) and
the sensitivities from forward differences of it, one more FE solve per parameter.

A user-written effect (docs/custom-effects.md) is fitted through its parameter itself, within its
``[lower, upper]``, starting from its ``start``; models that hold one are evaluated by
:mod:`eodarm.analysis.sensitivity` (forward differences, the statics computed once).
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm import reprs
from eodarm import text as fmt
from eodarm.analysis.gauss_newton import iterate
from eodarm.analysis.params import ChannelRms, Param, Params
from eodarm.analysis.problem import Z95, FitWarning, Problem, _rms
from eodarm.data.measurements import Measurements
from eodarm.errors import show, show_source
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, Slot, param_from_theta, theta_from_param

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


@dataclass(repr=False)
class FitResult:
    """The outcome of fitting a model's effect parameters to measurements (:func:`fit`), or
    of a model with nothing fitted (:func:`compare`).

    By name: :attr:`params` (``"effect@place:parameter"`` → value, standard error, 95 %
    interval, unit, determined), :attr:`chi2_per_dof`, :attr:`rms` (channel → mm or deg),
    :attr:`effects`; :meth:`to_arm` the fitted arm that predicts with uncertainty. The
    methods by index (:meth:`estimate`, :meth:`stderr`, :meth:`interval`) serve the package's
    own tables. Its ``repr`` is a few lines; in a notebook, a table.
    """

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
    #: Per parameter, whether the data give it only a lower limit: a friction that could hold
    #: every measured state (:func:`eodarm.analysis.gauss_newton.holds_everything`); its
    #: interval has no upper end and it is not determined.
    lower_only: list[bool] = field(default_factory=list)

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
        """Number of fitted parameters P."""
        return len(self.slots)

    @property
    def dof(self) -> int:
        """Degrees of freedom: measured values used minus P (at least 1)."""
        return max(self.problem.n_values - self.n_params, 1)

    @property
    def chi2_per_dof(self) -> float:
        """χ²/dof: about 1 when the model explains the data within their σ."""
        return self.chi2 / self.dof

    @property
    def params(self) -> Params:
        """The fitted parameters by name, in the fit's order: ``"effect@place:parameter"`` →
        :class:`~eodarm.analysis.params.Param` (``value``, ``stderr``, ``interval``, ``unit``,
        ``determined``, ``bound``)."""
        loose = dict(self.undetermined())
        return Params(
            Param(
                name=f"{s.key}:{s.kind.param}",
                value=self.estimate(i),
                stderr=self.stderr(i),
                interval=self.interval(i),
                unit=s.kind.unit,
                determined=not self.at_bound[i] and i not in loose,
                bound=self._bound(i, loose),
            )
            for i, s in enumerate(self.slots)
        )

    @property
    def residual(self) -> npt.NDArray[np.float64]:
        """Measured minus model (N, C); NaN where not measured."""
        return self.problem.meas.values - self.prediction

    @property
    def z(self) -> npt.NDArray[np.float64]:
        """Residual in units of σ (N, C)."""
        return self.residual / self.problem.meas.sigma

    @property
    def rms(self) -> ChannelRms:
        """RMS residual per measured channel (mm or deg) over the cells used: a dict.
        (``rms()``, called as the method it was, gives the same; ``rms(rows)`` the RMS over
        a boolean mask of rows.)"""
        prob = self.problem

        def over(rows: npt.NDArray[np.bool_] | None) -> dict[str, float]:
            return _rms(self.residual, prob.use, prob.meas.channels, rows)

        return ChannelRms(over(None), over)

    def estimate(self, i: int) -> float:
        """The physical value of parameter ``i`` (its unit: :attr:`params` names it);
        ``inf`` for a stiffness fitted as rigid."""
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
            if self.only_lower_limit(i):
                low = fmt.value(self.interval(i)[0], self.slots[i].kind.unit)
                out.append((i, f"could hold every state: at least {low}"))
                continue
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
        if self.only_lower_limit(i):
            return max(lo, t - Z95 * e), hi
        return max(lo, t - Z95 * e), min(hi, t + Z95 * e)

    def only_lower_limit(self, i: int) -> bool:
        """Whether the data give parameter ``i`` only a lower limit: a friction that could
        hold every measured state (:attr:`lower_only`)."""
        return i < len(self.lower_only) and self.lower_only[i]

    def interval(self, i: int) -> tuple[float, float]:
        """The 95 % interval of the physical parameter, mapped from :meth:`theta_interval`
        (so it never crosses a physical bound: a stiffness is in (0, ∞], a gap ≥ 0),
        lowest value first."""
        a, b = (param_from_theta(self.slots[i].name, x) for x in self.theta_interval(i))
        return (min(a, b), max(a, b))

    def _bound(self, i: int, loose: Mapping[int, str]) -> str | None:
        """``"lower"``/``"upper"`` when the data give parameter ``i`` only a bound: it is not
        determined (``loose``, or stuck at θ = 0) and its 95 % interval in θ reaches θ = 0 but
        has a finite other end (:class:`~eodarm.analysis.params.Param`); None otherwise, and
        for a user-written effect (its own neutral value and bounds)."""
        s = self.slots[i]
        if s.kind.custom:
            return None
        lo_b = self.problem.bounds(s)[0]
        t_lo, t_hi = self.theta_interval(i)
        at_low = self.at_bound[i] and float(self.theta[i]) <= lo_b + 1e-15
        if not (i in loose or at_low) or t_lo > lo_b or not math.isfinite(t_hi) or t_hi <= 0:
            return None
        return "lower" if s.kind.compliance_like else "upper"

    # ------------------------------------------------------------------ hand-over
    def to_arm(
        self, data: str | os.PathLike[str] | None = None, *, trusted: bool | None = None
    ) -> Arm:
        """The fitted arm: what ``eodarm fit ... -o FITTED.toml`` writes, as an
        :class:`~eodarm.model.arm.Arm` (:func:`eodarm.analysis.handover.hand_over`).

        The problem's arm with the fitted effects and their standard errors, a parameter the
        data give only a bound for fixed at its physical end (rigid, absent) and marked, and
        the ``[fit]`` table: the parameters' covariance, χ²/dof and the model's held-out
        inadequacy. ``eodarm.solve(fit.to_arm(), ..., uncertainty=True)`` then gives the σ of
        ``eodarm solve --uncertainty`` on that file (docs/model.md §8); ``to_toml()`` is the
        file's text.

        Parameters
        ----------
        data : the measurement file to name in ``[fit]`` with its SHA-256; by default the
            measurements' own file (:attr:`Measurements.sha256`), none for data that did not
            come whole from a file.
        trusted : whether a fit consistent with the noise may be written as explaining its
            data; by default, when :func:`eodarm.analysis.datacheck.check_data` finds no
            mistake in them (metres in an ``_mm`` column, a flipped sign …), as ``eodarm
            fit`` decides.
        """
        from eodarm.analysis.handover import hand_over

        return hand_over(self, data, trusted)

    def _refit(
        self,
        arm: Arm,
        slots: Sequence[Slot],
        exclude: npt.NDArray[np.bool_] | None,
        start: Sequence[float] | None,
    ) -> FitResult:
        """The same measurements and model options fitted again, on ``arm`` with ``slots``
        (for :func:`eodarm.analysis.handover.settle`, which does not import this module)."""
        prob = self.problem
        return fit(
            arm,
            prob.meas,
            slots,
            self_weight=prob.self_weight,
            exclude=exclude,
            start=start,
            model=prob.model,
            fem_options=prob.fem_options,
        )

    # ------------------------------------------------------------------ display
    def __repr__(self) -> str:
        meas = self.problem.meas
        if self.slots:
            what = f"{self.n_params} parameter{'s' * (self.n_params != 1)} fitted to"
            lines = self.params.lines()
        else:
            fixed = ", ".join(e.key for e in self.fixed) or "the baseline"
            what = f"nothing fitted ({fixed}) against"
            lines = []
        title = (
            f"FitResult: {what} {meas.n_rows} states of {meas.source} "
            f"({self.problem.n_values} values), χ²/dof {fmt.value(self.chi2_per_dof, digits=4)}"
        )
        return reprs.block(title, [*lines, *reprs.wrap("RMS", self.rms.items_text())])

    def _repr_html_(self) -> str:
        meas = self.problem.meas
        caption = (
            f"{meas.source}: {meas.n_rows} states, {self.problem.n_values} values; "
            f"χ²/dof {fmt.value(self.chi2_per_dof, digits=4)}; RMS {self.rms.line()}"
        )
        if self.slots:
            return self.params.html(caption)
        model = ", ".join(e.key for e in self.fixed) or "the baseline"
        return reprs.html_table(["model", "fitted parameters"], [[model, "none"]], caption)

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
            "rms": dict(self.rms),
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


def determining_channel(slot: Slot, measured: Sequence[str], lower_only: bool = False) -> str:
    """The measurement that would pin down a slot's parameter, in words: its own channel if
    the data lack it, else more poses that load it differently; for a friction that could
    hold every measured state (``lower_only``), heavier loads that make it slip."""
    if lower_only:
        return (
            "load it harder: a payload whose force or torque change at it exceeds the "
            "friction makes it slip (docs/model.md §9, a friction that holds every state)"
        )
    i = slot.index(10**6) + 1  # 1-based place number (the arm's size does not matter here)
    own = {
        "actuator_compliance": f"dl{i}_mm",  # the body's own length sensor
        "mount_compliance": f"dl{i}_mm",  # separates the mount from the body in series
        "actuator_play": f"dl{i}_mm",
        "joint_clearance": f"dalpha{i}_deg",
        "link_bending": f"dalpha{i}_deg",
        "base_compliance": "dalpha1_deg",
        "actuator_friction": f"dl{i}_mm",  # the body's sensor sees what the body spring takes
        "drive_compliance": f"dalpha{i}_deg",  # the gear turns link i against body i-1
        "drive_backlash": f"dalpha{i}_deg",
    }.get(slot.name)
    if own is not None and own not in measured:
        return f"measure {own}"
    if slot.name in ("actuator_friction", "joint_friction", "drive_friction"):
        return (
            "load and unload (a load cycle with a step column): the unloading branch and the "
            "return to zero payload show a friction (docs/diagnosis.md, load sequences)"
        )
    return "add poses and payloads that load it differently (docs/diagnosis.md, advice)"


def _json_num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


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
    sol = iterate(prob, effects, start, max_iter)
    for msg in sol.notes:
        warnings.warn(msg, FitWarning, stacklevel=2)
    return FitResult(
        prob,
        sol.slots,
        sol.theta,
        sol.theta_stderr,
        sol.at_bound,
        sol.prediction,
        sol.chi2,
        sol.iterations,
        sol.notes,
        theta_cov=sol.theta_cov,
        lower_only=sol.lower_only,
    )


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
