"""The sag budget: how much of a model's sag each compliance and effect makes, with all the
others present, in shares that add up exactly to the model's sag.

The question a user asks of a fitted model is "of the 14 mm, how many come from the mounts and
how many from the actuator bodies?". Switching one effect on alone against the baseline does
not answer it: a fitted body far stiffer than the baseline's spring then shows as a large
*upward* contribution, and the parts do not add up to anything measured. Switching each one
off in turn from the full model answers it only for a linear model, and the parts then miss
the total by their interactions.

:func:`sag_budget` starts from the **rigid arm** (every actuator body and every drive's gear
rigid, no effect: it does not sag) and splits the model's sag between its *components*: each
actuator's body (its spring, the arm file's stiffness or the fitted ``actuator_compliance``),
each rotary drive's gear (``drive_compliance`` likewise) and every other
effect of the model. The split is the **Shapley value**: a component's share is its added sag
averaged over every order in which the components can be switched on,

    φ_i = Σ_{S ⊆ N∖{i}} |S|! (n − |S| − 1)! / n! · (v(S ∪ {i}) − v(S)),

where v(S) is the sag with the components S present (the rest rigid or absent). The shares
add up exactly to v(N) − v(∅), the model's sag (v(∅) = 0 up to rounding: a rigid arm does not
move). For springs in series in a linear model, the Shapley share of each spring equals its
Castigliano share (the work its force does on the spring's stretch per unit load), so the
budget is the one a hand calculation gives; where the model is not linear (large deflections,
gaps), interactions are split evenly between the components that make them.

The cost is 2ⁿ solves (each vectorised over the poses); beyond :data:`MAX_COMPONENTS`
components the effects are grouped by kind.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.model.arm import Arm, RotaryDrive
from eodarm.model.effects import Effect
from eodarm.model.solver import solve

__all__ = [
    "MAX_COMPONENTS",
    "RIGID_LEVER_MM",
    "RIGID_N_PER_MM",
    "SagBudget",
    "bare_arm",
    "components",
    "rigid_bodies",
    "sag_budget",
    "shapley_shares",
]

#: The largest number of components split one by one (2ⁿ solves).
MAX_COMPONENTS = 10

#: The stiffness of a rigid actuator body per model: analytic 1e15 N/mm (1e-12 mm under
#: 1 kN); the finite-element model's gap elements settle only up to about 1e9 N/mm (1e-6 mm
#: under 1 kN, a sag the rigid arm keeps and the budget shows as its starting point); where
#: they do not settle, 100 and then 10 000 times softer.
RIGID_N_PER_MM = {"analytic": 1e15, "fem": 1e9}
#: The moment arm (mm) that turns a rigid body's stiffness into a rigid gear's (N·mm/rad).
RIGID_LEVER_MM = 1000.0


@dataclass
class SagBudget:
    """Shares of a model's sag: ``shares[k]`` (poses,) per component ``labels[k]``.

    ``rigid`` is the sag of the rigid arm (zero up to rounding, or 1e-6 mm with the FE
    model, :data:`RIGID_N_PER_MM`) and ``total`` the model's own
    sag; ``rigid + Σ shares == total`` to rounding (about 1e-12 mm)."""

    labels: list[str]
    keys: list[list[str]]
    shares: npt.NDArray[np.float64]
    rigid: npt.NDArray[np.float64]
    total: npt.NDArray[np.float64]
    channel: str

    @property
    def closure(self) -> float:
        """The largest |rigid + Σ shares − total| over the poses (the budget's own check)."""
        return float(np.max(np.abs(self.rigid + self.shares.sum(axis=0) - self.total)))


def bare_arm(arm: Arm) -> Arm:
    """The arm without the effects of its file (they become components like the others)."""
    d = arm.to_dict()
    d.pop("effect", None)  # the [[effect]] tables' key
    d.pop("fit", None)
    return Arm.from_dict(d, source=arm.source)


def components(arm: Arm, effects: Sequence[Effect]) -> list[tuple[str, list[str], list[Effect]]]:
    """(label, keys, effects switched on) per component: every actuator body, then every
    other effect of the model (the arm file's, then ``effects``, the later replacing); grouped
    by kind beyond :data:`MAX_COMPONENTS` components."""
    model: dict[str, Effect] = {e.key: e for e in arm.effects}
    for e in effects:
        model[e.key] = e
    out = []
    for i, act in enumerate(arm.actuators, start=1):
        if isinstance(act, RotaryDrive):
            key = f"drive_compliance@O{i}"
            gear = model.pop(key, None) or Effect(
                "drive_compliance", f"O{i}", stiffness_nmm_per_rad=act.stiffness_nmm_per_rad
            )
            out.append((f"drive {i} gear", [key], [gear]))
            continue
        key = f"actuator_compliance@M{i}"
        body = model.pop(key, None)
        if body is None:
            body = Effect("actuator_compliance", f"M{i}", stiffness_n_per_mm=act.stiffness_n_per_mm)
        out.append((f"actuator {i} body", [key], [body]))
    for key, e in model.items():
        out.append((key, [key], [e]))
    return _grouped(out) if len(out) > MAX_COMPONENTS else out


def _grouped(
    comps: list[tuple[str, list[str], list[Effect]]],
) -> list[tuple[str, list[str], list[Effect]]]:
    """Components grouped by effect kind (the bodies one group), for many components."""
    groups: dict[str, tuple[str, list[str], list[Effect]]] = {}
    for _label, keys, effs in comps:
        kind = keys[0].split("@")[0]
        name = {"actuator_compliance": "actuator bodies", "drive_compliance": "drive gears"}.get(
            kind, f"{kind} (all places)"
        )
        g = groups.setdefault(kind, (name, [], []))
        g[1].extend(keys)
        g[2].extend(effs)
    return list(groups.values())


def sag_budget(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    mass_kg: float | npt.ArrayLike,
    effects: Sequence[Effect] = (),
    *,
    self_weight: bool = True,
    channel: str = "dy_mm",
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
) -> SagBudget:
    """Split the sag (``channel``, default ``dy_mm``) of the model ``arm`` + ``effects`` at
    the poses ``alpha_deg`` (P, n) and payload(s) ``mass_kg`` into Shapley shares of its
    components (module docstring). Returns a :class:`SagBudget`."""
    alpha = np.atleast_2d(np.asarray(alpha_deg, dtype=float))
    bare = bare_arm(arm)
    comps = components(arm, effects)
    n = len(comps)
    kw: dict[str, Any] = {"self_weight": self_weight, "model": model, "fem_options": fem_options}

    def values(rigid: float) -> dict[tuple[int, ...], npt.NDArray[np.float64]]:
        bodies = rigid_bodies(arm, rigid)
        v = {}
        for size in range(n + 1):
            for members in itertools.combinations(range(n), size):
                on: dict[str, Effect] = dict(bodies)
                for k in members:
                    for e in comps[k][2]:
                        on[e.key] = e
                out = solve(bare, alpha, mass_kg, effects=list(on.values()), strict=True, **kw)
                v[members] = np.asarray(out[channel], dtype=float).reshape(-1)
        return v

    stiff = RIGID_N_PER_MM[model]
    while True:
        try:
            v = values(stiff)
            break
        except ValueError:  # the FE gap elements may not settle beside a near-rigid body
            if model != "fem" or stiff <= 1e6:
                raise
            stiff /= 100.0
    return SagBudget(
        labels=[c[0] for c in comps],
        keys=[c[1] for c in comps],
        shares=shapley_shares(v, n),
        rigid=v[()],
        total=v[tuple(range(n))],
        channel=channel,
    )


def rigid_bodies(arm: Arm, stiffness_n_per_mm: float) -> dict[str, Effect]:
    """Every actuator body at ``stiffness_n_per_mm`` (the rigid arm's), by effect key; every
    rotary drive's gear at ``stiffness_n_per_mm`` × :data:`RIGID_LEVER_MM`² N·mm/rad, as
    rigid as a body of that stiffness acting at a 1 m moment arm."""
    out = {}
    for i, kind in enumerate(arm.kinds, start=1):
        if kind == "rotary":
            out[f"drive_compliance@O{i}"] = Effect(
                "drive_compliance",
                f"O{i}",
                stiffness_nmm_per_rad=stiffness_n_per_mm * RIGID_LEVER_MM**2,
            )
        else:
            out[f"actuator_compliance@M{i}"] = Effect(
                "actuator_compliance", f"M{i}", stiffness_n_per_mm=stiffness_n_per_mm
            )
    return out


def shapley_shares(
    v: Mapping[tuple[int, ...], npt.NDArray[np.float64]], n: int
) -> npt.NDArray[np.float64]:
    """The Shapley share (n, …) of each of ``n`` components from the values ``v[S]`` of every
    sorted subset S of ``range(n)`` (arrays of one shape, in the unit of the values)."""
    full = np.asarray(v[tuple(range(n))], dtype=float)
    shares = np.zeros((n, *full.shape))
    for members, val in v.items():
        s = len(members)
        if s == n:
            continue
        weight = math.factorial(s) * math.factorial(n - s - 1) / math.factorial(n)
        for i in range(n):
            if i not in members:
                shares[i] += weight * (v[tuple(sorted((*members, i)))] - val)
    return shares
