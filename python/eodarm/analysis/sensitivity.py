"""Channels and sensitivities of a model that holds user-written effects (docs/custom-effects.md).

The compiled core's ``jacobian`` differentiates the catalogue's effects in one call, but it
cannot call Python: a user-written effect reaches the core as extra deformations
(``_core.solve(extra_*=...)``). :class:`CustomEvaluator` gives :meth:`Problem.evaluate
<eodarm.analysis.fit.Problem.evaluate>` the same answer, the channels y (N, C) and ∂y/∂θ
(N, C, P), when a user effect is in the model or among the probes:

* **The state once.** A user function reads the undeformed statics of both states
  (:class:`~eodarm.model.custom.EffectState`), which no effect parameter changes: they are
  computed once per Problem and every call reuses them. Each function is called once per
  place and value, vectorised over the states, and its deformations are kept for the values
  asked again (the base point of a difference is asked at every step).
* **No user effect in the model** (a diagnosis's candidates): y and the catalogue probes'
  columns come from the core's ``jacobian`` as without user effects (central differences,
  exact to ~1e-9), and each user probe costs one more call of its function and one solve.
* **A user effect in the model** (its fit, or a set containing it): y is one solve with the
  model's extras, and every column a forward difference, one solve each: a catalogue probe
  with its θ stepped and the extras held (the core's ``jacobian`` takes no extras), a user
  probe with its deformations at θ + h in place of those at θ.

The forward step is relative to the parameter's scale, ``h = 1e-4·scale``: for a catalogue
effect ``scale = max(|θ|, θ_typical)`` (θ_typical the core's: the actuator's 1/k for the
springs of an actuator, 0.1 mm for play and clearance, 1e-10 /(N·mm²) for bending, 1e-8
rad/(N·mm) for the base), for a user effect ``scale = max(|θ|, |start − neutral|, |start|,
|neutral|)`` (1 when all are 0), at most half the parameter's range. A step that would leave
the upper bound is taken backwards. Responses are linear in θ up to the pose's geometric
nonlinearity, so the forward difference of a catalogue effect agrees with the core's central
one to ~1e-5 relative (measured, ``tests/test_custom_effects.py``), far below what a fit or
its standard errors notice; a user effect's is as good as its function is smooth on the
scale h.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from eodarm.model import custom
from eodarm.model.catalogue import OWN_SPRINGS
from eodarm.model.effects import Slot, param_from_theta
from eodarm.model.steps import typical_theta

if TYPE_CHECKING:
    from eodarm.model.arm import Arm

__all__ = ["FD_STEP", "CustomEvaluator", "step"]

FloatArray = npt.NDArray[np.float64]
Model = Sequence[tuple[Slot, float]]

#: Relative forward-difference step (times the parameter's scale, see the module notes).
FD_STEP = 1e-4
#: Deformations kept per evaluator (values of user effects asked again).
_CACHE_SIZE = 256
#: A stiffness standing for a rigid actuator body or gear (θ = 0 of an ``OWN_SPRINGS`` effect).
_RIGID = 1e300


def step(arm: Arm, slot: Slot, theta: float) -> float:
    """The forward-difference step of ``slot`` at ``theta`` (negative at its upper bound)."""
    kind = slot.kind
    if isinstance(kind, custom.CustomKind):
        scale = max(abs(theta), abs(kind.start - kind.neutral), abs(kind.start), abs(kind.neutral))
    else:
        scale = max(abs(theta), typical_theta(arm, slot))
    h = FD_STEP * (scale if scale > 0 else 1.0)
    lo, hi = kind.theta_bounds
    if math.isfinite(hi):
        h = min(h, 0.5 * (hi - lo))
    return -h if theta + h > hi else h


class CustomEvaluator:
    """y and ∂y/∂θ of models with user-written effects, on one Problem's states.

    Parameters
    ----------
    arm : the arm.
    alpha, payload : (N, n) unloaded angles (deg) and (N, 2) payload forces (N) of all the
        Problem's states.
    self_weight : as the Problem.
    """

    def __init__(self, arm: Arm, alpha: FloatArray, payload: FloatArray, self_weight: bool) -> None:
        self.arm = arm
        self.alpha = alpha
        self.payload = payload
        self.self_weight = self_weight
        self._state: custom.EffectState | None = None
        self._cache: dict[tuple[Slot, float], dict[str, FloatArray]] = {}
        #: Calls of user functions and solves so far (for benchmarks and tests).
        self.calls = 0
        self.solves = 0

    @property
    def state(self) -> custom.EffectState:
        """The undeformed statics of every state, computed on first use."""
        if self._state is None:
            from eodarm.model import native as _core
            from eodarm.model.solver import _core_arm

            st = _core.statics(_core_arm(self.arm), self.alpha, self.payload, self.self_weight)
            self._state = custom.EffectState.from_statics(
                self.arm, self.alpha, self.payload, st, self.self_weight
            )
        return self._state

    def deformation(
        self, slot: Slot, theta: float, rows: npt.NDArray[np.intp] | None
    ) -> dict[str, FloatArray]:
        """The whole-arm extra deformations of a user effect at θ, on ``rows``."""
        key = (slot, float(theta))
        hit = self._cache.get(key)
        if hit is None:
            kind = slot.kind
            assert isinstance(kind, custom.CustomKind)
            n = self.arm.n
            i = slot.index(n)
            got = custom.deformation(kind, slot.at, i, float(theta), self.state)
            self.calls += 1
            hit = custom.place_extras(got, i, self.state.n_states, n)
            if len(self._cache) >= _CACHE_SIZE:
                self._cache.clear()
            self._cache[key] = hit
        return hit if rows is None else {k: v[rows] for k, v in hit.items()}

    def solve(
        self,
        builtin: Model,
        extras: Mapping[str, FloatArray],
        alpha: FloatArray,
        payload: FloatArray,
        nan_on_failure: bool,
    ) -> FloatArray:
        """Channels (N, C) of catalogue effects at θ plus extra deformations: one solve."""
        from eodarm.model import native as _core
        from eodarm.model.solver import _core_arm

        n = self.arm.n
        codes, places, values = [], [], []
        for s, t in builtin:
            value = param_from_theta(s.name, float(t))
            if math.isinf(value):
                if s.name not in OWN_SPRINGS:
                    continue  # θ = 0 of a spring: the effect is absent
                value = _RIGID
            codes.append(s.code)
            places.append(s.index(n))
            values.append(value)
        self.solves += 1
        out = _core.solve(
            _core_arm(self.arm),
            alpha,
            payload,
            np.array(codes, dtype=np.int64),
            np.array(places, dtype=np.int64),
            np.array(values, dtype=float),
            self.self_weight,
            nan_on_failure,
            **{k: np.ascontiguousarray(v) for k, v in extras.items()},
        )
        return np.column_stack([out["dx_mm"], out["dy_mm"], out["dalpha_deg"], out["dl_mm"]])

    def evaluate(
        self,
        model: Model,
        probes: Sequence[Slot],
        rows: npt.NDArray[np.intp] | None,
        nan_on_failure: bool,
        core_jacobian: Callable[[Model, Sequence[Slot]], tuple[FloatArray, FloatArray]],
    ) -> tuple[FloatArray, FloatArray]:
        """y (N, C) and ∂y/∂θ (N, C, P) of ``model`` for ``probes`` (see the module notes).

        ``core_jacobian(model, probes)`` is the core's answer for catalogue effects alone, on
        the same rows.
        """
        alpha, payload = self.alpha, self.payload
        if rows is not None:
            alpha = np.ascontiguousarray(alpha[rows])
            payload = np.ascontiguousarray(payload[rows])
        builtin = [(s, float(t)) for s, t in model if not s.kind.custom]
        users = [(s, float(t)) for s, t in model if s.kind.custom]
        at = dict(model)
        extras = custom.add_extras(*(self.deformation(s, t, rows) for s, t in users))
        c = 2 + 2 * self.arm.n
        jac = np.zeros((alpha.shape[0], c, len(probes)))
        cat = [j for j, s in enumerate(probes) if not s.kind.custom]
        if not users:
            y, jc = core_jacobian(builtin, [probes[j] for j in cat])
            jac[:, :, cat] = jc
        else:
            y = self.solve(builtin, extras, alpha, payload, nan_on_failure)
            for j in cat:
                s = probes[j]
                t0 = float(at[s]) if s in at else _neutral(self.arm, s)
                h = step(self.arm, s, t0)
                varied = [(q, t0 + h if q == s else t) for q, t in builtin]
                if s not in at:
                    varied.append((s, t0 + h))
                y1 = self.solve(varied, extras, alpha, payload, nan_on_failure)
                jac[:, :, j] = (y1 - y) / h
        for j, s in enumerate(probes):
            if not s.kind.custom:
                continue
            kind = s.kind
            assert isinstance(kind, custom.CustomKind)
            t0 = float(at[s]) if s in at else kind.neutral
            h = step(self.arm, s, t0)
            d0 = self.deformation(s, t0, rows)
            d1 = self.deformation(s, t0 + h, rows)
            moved = custom.add_extras(extras, d1, {k: -v for k, v in d0.items()})
            y1 = self.solve(builtin, moved, alpha, payload, nan_on_failure)
            jac[:, :, j] = (y1 - y) / h
        return y, jac


def _neutral(arm: Arm, slot: Slot) -> float:
    """θ of a catalogue slot that is not in the model (as ``Problem.neutral``)."""
    from eodarm.model.steps import neutral_theta

    return neutral_theta(arm, slot)
