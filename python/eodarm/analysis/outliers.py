"""Outliers: the cells a fit leaves out, and the rule that decides (docs/diagnosis.md,
"Outliers"). :func:`robust_fit` is :func:`eodarm.analysis.fit.fit` with that rule."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt

from eodarm.analysis.fit import FitResult, fit
from eodarm.data.measurements import Measurements
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, Slot

__all__ = ["PEEL_ROUNDS", "outlier_table", "peel_outliers", "robust_fit"]

T = TypeVar("T")

#: At most this many refits when leaving outliers out (each round leaves out every cell beyond
#: the threshold at once; docs/diagnosis.md, "Outliers").
PEEL_ROUNDS = 8


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
