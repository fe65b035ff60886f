"""The least-squares problem every fit solves: an arm, measurements, and the whitened
residual (observed − model)/σ over the measured cells, with the model's channels and their
sensitivities ∂y/∂θ from the compiled core, the finite-element model, the sequence evaluator
(memory) or the evaluator of user-written effects (docs/diagnosis.md).

Below :mod:`eodarm.analysis.gauss_newton` (the iteration), :mod:`eodarm.analysis.fit` (the
result) and :mod:`eodarm.analysis.crossval` (held-out folds), which all use it.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.data.measurements import Measurements
from eodarm.data.plausible import check_drive_channels
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Slot, param_from_theta, theta_from_param

__all__ = ["Z95", "FitWarning", "Problem"]

#: z of a two-sided 95 % normal interval.
Z95 = 1.959963984540054

#: The solvers' way of naming a pose: ``pose row k: `` (0-based, in the rows solved).
_POSE_ROW = re.compile(r"pose row (\d+):\s*")


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
        check_drive_channels(arm, meas)
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

    def __repr__(self) -> str:
        return (
            f"<Problem: arm '{self.arm.name}', {self.meas.source} ({self.n_values} values "
            f"used), model {self.model}>"
        )

    def neutral(self, slot: Slot) -> float:
        """θ of a slot when it is not in the model."""
        if self.model == "fem":
            from eodarm.model import fem

            return fem.neutral(self.arm, slot)
        kind = slot.kind
        if kind.custom:
            return float(getattr(kind, "neutral", 0.0))
        from eodarm.model.steps import neutral_theta

        return neutral_theta(self.arm, slot)

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


class FitWarning(UserWarning):
    """A fitted parameter sits at a physical bound."""


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
