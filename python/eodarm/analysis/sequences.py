"""Channels and sensitivities of models with memory: load sequences and friction.

:meth:`Problem.evaluate <eodarm.analysis.fit.Problem.evaluate>` hands a model here when the
measurements carry a ``step`` column (each config label one load sequence, values relative to
its zeroed reference) or when the model or the probes hold a friction
(``actuator_friction``, ``joint_friction``). The states are then solved in their order by
:func:`eodarm.solve_sequence`, all sequences in one call: sequences of different lengths are
padded at their end with their last payload (a state after the last one cannot change the
ones before it: the padding is causal and its answers are dropped). A file without ``step``
is N sequences of one state, which is ``solve``.

Why finite differences with a wide step for friction
----------------------------------------------------
A friction's response is piecewise linear in its limit L: each state either sticks (its
response does not depend on L at all) or slips (S = ΔF ∓ L, linear in L), and which one
changes at the values of L where a state's force change reaches the limit. ∂y/∂L is
therefore a step function: it exists between the kinks and jumps at them. A derivative taken
at a point (an infinitesimal step, or the core's central difference at 1e-4 of the scale)
reads the slope of one side, and a Gauss–Newton step computed from it overshoots or stalls
where a state is about to switch. The Jacobian of a friction is taken instead as a secant
over a wide step, ``h = 5 %`` of max(L, L_typical) (central where the bounds allow, forward
from L = 0): it averages the slopes of the states that switch within ±h, which is what a
Gauss–Newton step of that size will meet. The fit's backtracking (a step is accepted only
when the exact χ² does not rise) keeps every iteration honest, but where the data sit near
a kink the secant's step can stop short of the least χ² (measured up to 0.4 σ): the fit then
searches each friction's χ² slice directly (:mod:`eodarm.analysis.gauss_newton`). The
standard error from the secant covers as promised (docs/model.md §9, "Fitting a friction").
The other effects keep their small steps (:func:`eodarm.analysis.sensitivity.step`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from eodarm.analysis import sensitivity
from eodarm.errors import EodarmError
from eodarm.model.catalogue import OWN_SPRINGS
from eodarm.model.effects import Effect, Slot, param_from_theta

if TYPE_CHECKING:
    from eodarm.data.measurements import Measurements
    from eodarm.model.arm import Arm

__all__ = [
    "FRICTIONS",
    "FRICTION_STEP",
    "SequenceEvaluator",
    "branches",
    "friction_step",
    "hysteresis",
    "layout",
]

FloatArray = npt.NDArray[np.float64]
Model = Sequence[tuple[Slot, float]]

#: The effects with memory: friction elements (docs/model.md, load sequences).
FRICTIONS = ("actuator_friction", "joint_friction", "drive_friction")
#: The secant step of a friction's limit, relative to max(L, typical L) (module notes).
FRICTION_STEP = 0.05
#: A typical limit, the scale of a step from L = 0: 1 N of actuator friction, and
#: 100 N·mm of joint or gear friction (1 N on a 100 mm moment arm).
_TYPICAL = {"actuator_friction": 1.0, "joint_friction": 100.0, "drive_friction": 100.0}
#: A stiffness standing for a rigid actuator body or gear (θ = 0 of an ``OWN_SPRINGS`` effect).
_RIGID = 1e300


def has_friction(slots: Sequence[Slot]) -> bool:
    """Whether any of the slots is a friction."""
    return any(s.name in FRICTIONS for s in slots)


def friction_step(slot: Slot, theta: float) -> float:
    """The secant step of a friction's limit at ``theta`` (always forward: θ ≥ 0)."""
    return FRICTION_STEP * max(abs(theta), _TYPICAL[slot.name])


def layout(
    meas: Measurements,
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp], npt.NDArray[np.intp], FloatArray]:
    """Where each row's state sits among the sequences.

    Returns
    -------
    first : (K,) the first row of each of the K sequences (its angles are the sequence's).
    seq, state : (N,) each row's sequence and state index; −1 for a written reference row
        (its model is 0: the reference itself).
    mass : (K, S) the payloads (kg) of each sequence's states, padded at the end with its
        last payload.
    """
    seqs = meas.sequences()
    n_states = max((len(s) for s in seqs), default=1)
    seq = np.full(meas.n_rows, -1, dtype=np.intp)
    state = np.full(meas.n_rows, -1, dtype=np.intp)
    mass = np.zeros((len(seqs), n_states))
    first = np.zeros(len(seqs), dtype=np.intp)
    for k, rows in enumerate(seqs):
        first[k] = rows[0]
        seq[rows] = k
        state[rows] = np.arange(len(rows))
        m = meas.mass_kg[rows]
        mass[k, : len(rows)] = m
        mass[k, len(rows) :] = m[-1]
    return first, seq, state, mass


def effects_of(model: Model) -> list[Effect]:
    """The effects of a model given by θ values (θ = 0 of a spring: absent; of the actuator's
    own body or the drive's own gear: rigid)."""
    out = []
    for s, t in model:
        value = param_from_theta(s.name, float(t))
        if math.isinf(value):
            if s.name not in OWN_SPRINGS:
                continue
            value = _RIGID
        if value == 0.0 and s.name in FRICTIONS:
            continue
        out.append(s.effect(value))
    return out


class SequenceEvaluator:
    """y (N, C) and ∂y/∂θ (N, C, P) of models on a Problem's states, with memory.

    Parameters
    ----------
    arm : the arm.
    meas : the Problem's measurements (their sequences, :meth:`Measurements.sequences`).
    self_weight : as the Problem.
    """

    def __init__(self, arm: Arm, meas: Measurements, self_weight: bool) -> None:
        self.arm = arm
        self.meas = meas
        self.self_weight = self_weight
        self.first, self.seq, self.state, self.mass = layout(meas)
        self.alpha = np.ascontiguousarray(meas.alpha_deg[self.first], dtype=np.float64)
        # the model's θ include the arm file's effects (Problem.evaluate adds them)
        self.bare = dataclasses.replace(arm, effects=(), effect_stderr=(), fit=None)
        self.solves = 0

    def channels(self, effects: list[Effect], nan_on_failure: bool = False) -> FloatArray:
        """The channels (N, C) of every row under ``effects`` (the arm's own are the model's)."""
        from eodarm.model.solver import solve_sequence

        self.solves += 1
        try:
            out = solve_sequence(
                self.bare,
                self.alpha,
                self.mass,
                effects=effects,
                self_weight=self.self_weight,
                strict=True,
            )
            ch = _stack(out)
        except EodarmError:  # the fit's backtracking catches these
            if not nan_on_failure:
                raise
            ch = self._one_by_one(effects)
        y = np.zeros((self.meas.n_rows, ch.shape[-1]))
        live = self.seq >= 0
        y[live] = ch[self.seq[live], self.state[live]]
        return y

    def _one_by_one(self, effects: list[Effect]) -> FloatArray:
        """Each sequence alone, NaN for those the model cannot solve."""
        from eodarm.model.solver import solve_sequence

        c = 2 + 2 * self.arm.n
        ch = np.full((*self.mass.shape, c), np.nan)
        for k in range(len(self.first)):
            try:
                out = solve_sequence(
                    self.bare,
                    self.alpha[k : k + 1],
                    self.mass[k : k + 1],
                    effects=effects,
                    self_weight=self.self_weight,
                    strict=True,
                )
            except ValueError:  # an EodarmError naming the sequence and state
                continue
            ch[k] = _stack(out)[0]
        return ch

    def evaluate(
        self,
        model: Model,
        probes: Sequence[Slot],
        rows: npt.NDArray[np.intp] | None,
        nan_on_failure: bool,
        core_jacobian: Callable[[Model, Sequence[Slot]], tuple[FloatArray, FloatArray]],
    ) -> tuple[FloatArray, FloatArray]:
        """y (N, C) and ∂y/∂θ (N, C, P) of ``model`` for ``probes`` (module notes).

        ``core_jacobian(model, probes)`` answers for models and probes without memory on
        data without sequences (the compiled core's ``jacobian``); it is used for them when
        only some probes are frictions.
        """
        at = dict(model)
        n_rows = self.meas.n_rows
        c = 2 + 2 * self.arm.n
        jac = np.zeros((n_rows, c, len(probes)))
        memoryless = not self.meas.has_sequences and not has_friction([s for s, _ in model])
        if memoryless:
            # Single loadings without friction in the model: the core answers y and the
            # other probes; each friction probe is a secant from L = 0.
            others = [j for j, s in enumerate(probes) if s.name not in FRICTIONS]
            y, jc = core_jacobian(model, [probes[j] for j in others])
            jac[:, :, others] = jc
            fr = [j for j, s in enumerate(probes) if s.name in FRICTIONS]
            base = effects_of(model)
            for j in fr:
                s = probes[j]
                h = friction_step(s, 0.0)
                y1 = self.channels([*base, s.effect(h)], nan_on_failure)
                jac[:, :, j] = (y1 - y) / h
        else:
            y = self.channels(effects_of(model), nan_on_failure)
            for j, s in enumerate(probes):
                t0 = float(at[s]) if s in at else _neutral(self.arm, s)
                jac[:, :, j] = self._column(model, s, t0, y, nan_on_failure)
        if rows is not None:
            return y[rows], jac[rows]
        return y, jac

    def _column(
        self, model: Model, s: Slot, t0: float, y: FloatArray, nan_on_failure: bool
    ) -> FloatArray:
        """∂y/∂θ of one slot: a secant (friction) or a small step (the others), central
        where both sides are inside the bounds, else forward (backward at an upper bound)."""
        lo, hi = s.kind.theta_bounds
        h = friction_step(s, t0) if s.name in FRICTIONS else abs(sensitivity.step(self.arm, s, t0))
        rest = [(q, t) for q, t in model if q != s]

        def at(theta: float) -> FloatArray:
            return self.channels(effects_of([*rest, (s, theta)]), nan_on_failure)

        if t0 - h >= lo and t0 + h <= hi:
            return (at(t0 + h) - at(t0 - h)) / (2 * h)
        if t0 + h <= hi:
            return (at(t0 + h) - y) / h
        return (y - at(t0 - h)) / h


def _neutral(arm: Arm, slot: Slot) -> float:
    """θ of a slot that is not in the model (as ``Problem.neutral``)."""
    kind = slot.kind
    if kind.custom:
        return float(getattr(kind, "neutral", 0.0))
    return sensitivity._neutral(arm, slot)


def _stack(out: dict[str, FloatArray]) -> FloatArray:
    """(K, S, C) channels dx, dy, dalpha…, dl… of a sequence solve."""
    return np.concatenate(
        [out["dx_mm"][..., None], out["dy_mm"][..., None], out["dalpha_deg"], out["dl_mm"]],
        axis=-1,
    )


def branches(mass: npt.ArrayLike) -> list[str]:
    """The branch of each state of one sequence: ``"loading"`` where the payload rose from
    the state before it (the first state rises from the reference's 0), ``"unloading"`` where
    it fell; a payload held keeps the branch of the state before it."""
    out: list[str] = []
    prev, branch = 0.0, "loading"
    for m in np.asarray(mass, dtype=float).tolist():
        if m > prev:
            branch = "loading"
        elif m < prev:
            branch = "unloading"
        out.append(branch)
        prev = m
    return out


def hysteresis(
    meas: Measurements,
    model: FloatArray,
    before: FloatArray | None = None,
) -> list[dict[str, object]]:
    """Each sequence's states against payload, measured and model, and what is left at the
    return to zero payload (the numbers the text output and the report show).

    Parameters
    ----------
    meas : measurements with a ``step`` column (an empty list without one).
    model : (N, C) the model's channels at every row (a fit's ``prediction``).
    before : (N, C) optionally a second model (the baseline), shown beside it.

    Returns
    -------
    list of dict, one per sequence: ``config``; ``rows`` (N_s,) row indices in order;
    ``step``, ``mass_kg``, ``branch`` per state; ``channels`` the measured channels;
    ``measured``, ``sigma``, ``model`` (and ``before``) (N_s, C_s) arrays; ``left``: at the
    last state, if its payload is 0, channel → (measured, model) left at the return, else
    None.
    """
    if not meas.has_sequences or meas.step is None:
        return []
    chans = list(meas.measured_channels)
    cols = np.array([meas.index(c) for c in chans], dtype=np.intp)
    out: list[dict[str, object]] = []
    for rows in meas.sequences():
        mass = meas.mass_kg[rows]
        entry: dict[str, object] = {
            "config": str(meas.config[rows[0]]),
            "rows": rows,
            "step": meas.step[rows].tolist(),
            "mass_kg": mass.tolist(),
            "branch": branches(mass),
            "channels": chans,
            "measured": meas.values[np.ix_(rows, cols)],
            "sigma": meas.sigma[np.ix_(rows, cols)],
            "model": model[np.ix_(rows, cols)],
        }
        if before is not None:
            entry["before"] = before[np.ix_(rows, cols)]
        left = None
        if len(rows) > 1 and mass[-1] == 0.0:
            last = rows[-1]
            left = {
                ch: (float(meas.values[last, c]), float(model[last, c]))
                for ch, c in zip(chans, cols, strict=True)
            }
        entry["left"] = left
        out.append(entry)
    return out
