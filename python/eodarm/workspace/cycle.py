"""What a load cycle leaves behind, per sweep cell (docs/model.md §9, docs/sweeps.md).

Each cell (pose, payload m) is the sequence reference → m → 0: the arm zeroed unloaded,
loaded with m, unloaded again. ``return_dx_mm``, ``return_dy_mm`` are the measure point at the
return relative to the reference: zero for an elastic arm, what the frictions hold (and where
the gaps sit after the payload pushed them) otherwise.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, split_effects, with_arm_effects

__all__ = ["CHUNK", "add_return"]

#: Sequences per call of the core (bounds the temporary outputs: ~1 kB per sequence).
CHUNK = 65_536
#: The effects that leave the arm off its reference after a cycle: the frictions (what they
#: hold) and the gaps (a centred gap stays where the self-weight pushes it).
MEMORY = frozenset({"actuator_friction", "joint_friction", "actuator_play", "joint_clearance"})

_ATTRS = {
    "return_dx_mm": {
        "units": "mm",
        "long_name": "measure point x at the return to zero payload (reference -> payload -> 0)",
    },
    "return_dy_mm": {
        "units": "mm",
        "long_name": "measure point y at the return to zero payload (reference -> payload -> 0)",
    },
}


def add_return(
    ds: Any, arm: Arm, effects: Effect | Iterable[Effect] | None, self_weight: bool
) -> Any:
    """``ds`` (an unreduced sweep) with ``return_dx_mm`` and ``return_dy_mm`` per cell (mm),
    NaN where the cell is not ok or its cycle cannot be solved."""
    from eodarm.model.solver import solve_sequence

    n = arm.n
    dims = [d for d in ds["dx_mm"].dims if d != "mass_kg"]
    effs = None if effects is None else [effects] if isinstance(effects, Effect) else list(effects)
    model = with_arm_effects(arm.effects, effs)
    if not {e.name for e in model} & MEMORY and not split_effects(model)[1]:
        # Nothing holds anything and no gap is left off-centre: an elastic arm unloaded is
        # its reference, so every cell comes back exactly (docs/model.md §9).
        poses = int(np.prod([ds.sizes[d] for d in dims]))
        zero = {k: np.zeros((poses, ds.sizes["mass_kg"])) for k in _ATTRS}
        return _store(ds, dims, zero, poses, ds.sizes["mass_kg"])
    if "alpha_deg" in ds:
        alpha = ds["alpha_deg"].transpose(*dims, "link").values.reshape(-1, n)
    else:
        mesh = np.meshgrid(*[ds[d].values for d in dims], indexing="ij")
        by_name = dict(zip(dims, (m.ravel() for m in mesh), strict=True))
        alpha = np.stack([by_name[f"alpha{i + 1}"] for i in range(n)], axis=1)
    mass = np.asarray(ds["mass_kg"].values, dtype=float)
    poses, masses = alpha.shape[0], mass.shape[0]
    out = {k: np.full((poses, masses), np.nan) for k in _ATTRS}
    good = np.flatnonzero(np.isfinite(alpha).all(axis=1))
    kinds = {e.name for e in with_arm_effects(arm.effects, effs)}
    if not kinds & {"actuator_friction", "joint_friction"}:
        # Nothing remembers the payload: the return is the pose loaded with nothing (the gaps
        # along the self-weight's force), the same for every payload: one state per pose.
        for start in range(0, good.size, CHUNK):
            p = good[start : start + CHUNK]
            res = solve_sequence(
                arm,
                np.ascontiguousarray(alpha[p]),
                [0.0],
                effs,
                self_weight=self_weight,
                nan_on_failure=True,
            )
            out["return_dx_mm"][p] = res["dx_mm"][:, :1]
            out["return_dy_mm"][p] = res["dy_mm"][:, :1]
        return _store(ds, dims, out, poses, masses)
    # one sequence per cell: (pose, m) → states (m, 0)
    states = np.column_stack([mass, np.zeros_like(mass)])
    for start in range(0, good.size * masses, CHUNK):
        cells = np.arange(start, min(start + CHUNK, good.size * masses))
        p, m = good[cells // masses], cells % masses
        res = solve_sequence(
            arm,
            np.ascontiguousarray(alpha[p]),
            states[m],
            effs,
            self_weight=self_weight,
            nan_on_failure=True,
        )
        out["return_dx_mm"][p, m] = res["dx_mm"][:, 1]
        out["return_dy_mm"][p, m] = res["dy_mm"][:, 1]
    return _store(ds, dims, out, poses, masses)


def _store(ds: Any, dims: list[str], out: dict[str, Any], poses: int, masses: int) -> Any:
    """``ds`` with the returns ``out`` (poses × masses), NaN where a cell is not ok."""
    ok = ds["ok"].transpose(*dims, "mass_kg").values.reshape(poses, masses)
    shape = (*(ds.sizes[d] for d in dims), masses)
    for key, attrs in _ATTRS.items():
        values = np.where(ok, out[key], np.nan).reshape(shape)
        ds[key] = ([*dims, "mass_kg"], values, attrs)
    return ds
