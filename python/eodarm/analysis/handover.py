"""What a fitted model hands over: the fitted arm file with its ``[fit]`` table, the model's
own inadequacy it carries, and the undetermined parameters settled at their bounds
(docs/model.md §8, "Prediction errors", "Undetermined parameters").

:meth:`FitResult.to_arm <eodarm.analysis.fit.FitResult.to_arm>` is :func:`hand_over`, and so
is ``eodarm fit -o``. This module reads a fit through the :class:`Fitted` protocol and refits
through the fit's own ``_refit``, instead of importing :mod:`eodarm.analysis.fit`, which
imports it (docs/architecture.md, "No cycles").
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from eodarm.analysis.consistency import FitLike
from eodarm.analysis.crossval import cross_validate
from eodarm.analysis.problem import FitWarning, Problem
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, Slot, param_from_theta

__all__ = ["Fitted", "Inadequacy", "fitted_arm", "hand_over", "model_inadequacy", "settle"]


class Fitted(FitLike, Protocol):
    """What the hand-over reads of a fit (an :class:`eodarm.analysis.fit.FitResult`), named
    by shape, and ``_refit``, the fit's way of fitting its problem again."""

    @property
    def problem(self) -> Problem: ...

    slots: list[Slot]
    theta: npt.NDArray[np.float64]
    at_bound: list[bool]
    fixed: list[Effect]

    @property
    def n_params(self) -> int: ...

    @property
    def chi2_per_dof(self) -> float: ...

    @property
    def residual(self) -> npt.NDArray[np.float64]: ...

    def estimate(self, i: int) -> float: ...

    def stderr(self, i: int) -> float: ...

    def covariance(self) -> npt.NDArray[np.float64]: ...

    def undetermined(
        self, max_relative: float = 1.0, max_correlation: float = 0.95
    ) -> list[tuple[int, str]]: ...

    def theta_interval(self, i: int) -> tuple[float, float]: ...

    def _bound(self, i: int, loose: Mapping[int, str]) -> str | None: ...

    def _refit(
        self,
        arm: Arm,
        slots: Sequence[Slot],
        exclude: npt.NDArray[np.bool_] | None,
        start: Sequence[float] | None,
    ) -> Fitted: ...


@dataclasses.dataclass(frozen=True)
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


def model_inadequacy(
    result: Fitted, cv: Mapping[str, Any] | None = None, trusted: bool = True
) -> Inadequacy:
    """The model part of a prediction's σ, per channel (docs/model.md, "Prediction errors").

    Where the fit explains its data the part is zero, unless ``trusted`` is false (the data
    look mistaken, :mod:`eodarm.analysis.datacheck`: then the fit is never taken as
    explaining them, and the part is computed). Otherwise each configuration is left out
    in turn, the model refitted without it and its cells predicted (``cv``, the result of
    :func:`cross_validate` for this fit's model and outliers, is used when given); the part is
    what the held-out residuals' mean square exceeds the measurements' noise by. With a
    single configuration the fit's own residuals stand in, scaled by values/(values − P).
    """
    from eodarm.analysis.consistency import P_PASS, fit_p_value

    prob = result.problem
    meas = prob.meas
    measured = [ch for c, ch in enumerate(meas.channels) if prob.use[:, c].any()]
    if trusted and fit_p_value(result) >= P_PASS:
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


def settle(result: Fitted, exclude: npt.NDArray[np.bool_] | None = None) -> Fitted:
    """The fit with what the data give only a bound for fixed at its physical end, the rest
    refitted (docs/model.md, "Undetermined parameters").

    A parameter whose 95 % interval in θ reaches θ = 0 (a relative error above 100 %, or a
    parameter stuck at that bound) is fixed there: a stiffness "stiffer than X: treated as
    rigid" (written with the arm file's rigid value, 10²⁰), a gap "at most X: treated as
    absent" (0). The arm of the returned fit carries these effects marked with
    ``determined = false``, ``bound`` and ``limit`` (X, the 95 % limit), so that
    :func:`fitted_arm` writes them so and the predictions' σ include them. A
    parameter the data do not see at all (no finite bound) is left as it was. ``exclude``:
    the outlier cells the fit left out.
    """
    from eodarm.model.arm import MAX_STIFFNESS, EffectMark

    res = result
    for _ in range(len(result.slots)):
        loose = dict(res.undetermined())
        pinned = []
        for i, s in enumerate(res.slots):
            bound = res._bound(i, loose)
            if bound is None:
                continue
            limit = param_from_theta(s.name, res.theta_interval(i)[1])
            fixed_at = MAX_STIFFNESS if bound == "lower" else 0.0
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
            res = res._refit(arm, rest, exclude, start or None)
    return res


def fitted_arm(
    result: Fitted,
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
        inadequacy = model_inadequacy(result)
    loose = dict(result.undetermined())
    effects, errs, marks, keep = [], [], [], []
    for i, s in enumerate(result.slots):
        value = result.estimate(i)
        if not math.isfinite(value) or (value == 0 and not s.kind.allow_zero):
            continue  # an absent effect (rigid, θ = 0) is not written
        effects.append(s.effect(value))
        err = result.stderr(i)
        errs.append(err if math.isfinite(err) else None)
        marks.append(EffectMark(determined=False) if i in loose else None)
        if not result.at_bound[i] and math.isfinite(err):
            keep.append(i)
    cov = result.covariance()[np.ix_(keep, keep)]
    record = FitRecord(
        parameters=tuple(f"{result.slots[i].key}:{result.slots[i].kind.param}" for i in keep),
        covariance=tuple(tuple(float(x) for x in row) for row in (cov + cov.T) / 2),
        data=data,
        data_sha256=data_sha256,
        chi2_per_dof=float(result.chi2_per_dof),
        n_values=int(result.problem.n_values),
        date=datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        explained=inadequacy.explained,
        sigma_model=tuple(inadequacy.sigma_model.items()),
        heldout_rms=tuple(inadequacy.heldout_rms.items()),
        noise_rms=tuple(inadequacy.noise_rms.items()),
    )
    arm = result.problem.arm
    fixed = [e for e in result.fixed if e.key not in {s.key for s in result.slots}]
    return arm.with_effects(
        [*fixed, *effects],
        [*([None] * len(fixed)), *errs],
        fit=record,
        marks=[*([None] * len(fixed)), *marks],
    )


def hand_over(
    result: Fitted, data: str | os.PathLike[str] | None = None, trusted: bool | None = None
) -> Arm:
    """What ``eodarm fit ... -o FITTED.toml`` writes, as an :class:`Arm`: the fit settled
    (:func:`settle`, the outlier cells it left out still left out), its model's inadequacy
    (:func:`model_inadequacy`) and the fitted arm (:func:`fitted_arm`).

    ``data``: the measurement file named in ``[fit]``, with the SHA-256 of its bytes now;
    None: the measurements' own file and the hash of the bytes they were read from
    (nothing for data that did not come whole from a file). ``trusted``: whether a fit
    consistent with the noise may be written as explaining its data; None: when
    :func:`eodarm.analysis.datacheck.check_data` finds no mistake in them (as ``eodarm fit``
    decides).

    Raises
    ------
    EodarmError
        When ``data`` cannot be read.
    """
    prob = result.problem
    if trusted is None:
        from eodarm.analysis.datacheck import check_data

        trusted = not check_data(
            prob.arm, prob.meas, prob.self_weight, prob.model, prob.fem_options
        )
    outliers = np.isfinite(prob.meas.values) & ~prob.use
    final = settle(result, exclude=outliers if outliers.any() else None)
    inadequacy = model_inadequacy(final, trusted=trusted)
    if data is None:
        meas = prob.meas
        name, digest = (Path(meas.source).name, meas.sha256) if meas.sha256 else ("", "")
    else:
        path = Path(data)
        try:
            digest = hashlib.sha256(path.read_bytes()).hexdigest()
        except OSError as exc:
            raise EodarmError(f"{path}: cannot read the data file: {exc.strerror or exc}") from None
        name = path.name
    return fitted_arm(final, data=name, data_sha256=digest, inadequacy=inadequacy)
