"""Thresholds in series with the actuators: preload or stiction in a mount or in a joint,
as user-written effects (docs/custom-effects.md), written for the seed data's residual shape.

On the seed data (Ștefan et al. 2022, docs/seed-reproduction.md §6) a straight line through
each configuration's three measured sags meets zero payload *below* zero in 4 of 5
configurations: the first newtons of load move less than the rest, which is what a threshold
does (friction, stiction, a preloaded spring). A compliance k that only starts to give once the
force change passes a threshold f deforms by −sign(ΔF)·max(|ΔF| − f, 0)/k: once past the
threshold, the plain spring −ΔF/k plus a constant relief +sign(ΔF)·f/k. These two effects add
that relief, with the relief itself (δ = f/k, mm) as the one parameter, so that they need not
know k and combine with the catalogue's mount compliance:

* ``mount_preload`` @ M_i: pin-to-pin length change that the actuator's sensor does not see
  (the mount, outside the body), ``+sign(ΔF)·δ·min(|ΔF|/F_T, 1)``;
* ``joint_preload`` @ O_i: link i's pin held back against the change of the joint force,
  ``−δ·ΔR/|ΔR|·min(|ΔR|/F_T, 1)`` (ΔR = R_loaded − R_unloaded, the force of body i−1 on link i,
  so −ΔR is the direction the change pushes the pin; the relief is opposite to it).

F_T (``THRESHOLD_N``, 10 N) is where the relief has grown to its full value. Only states whose
force change lies below F_T see it; in the seed data every force change of every state is far
above it (≥ 60 N at 1.5 kg), so the data cannot determine F_T and these effects act there as a
constant relief δ per actuator (or joint) whose sign follows the force change. The relief is
bounded by δ ≥ 0 (it holds motion back; it never adds to it: that would be a play).

Use::

    eodarm diagnose MEAS.csv --arm ARM.toml --effects examples/thresholds.py
    eodarm fit MEAS.csv --arm ARM.toml --effects examples/thresholds.py \\
        --add mount_compliance@M2 --add mount_preload@M2 --cv config
"""

from __future__ import annotations

import numpy as np

import eodarm

THRESHOLD_N = 10.0


@eodarm.custom_effect(
    "mount_preload",
    places="M",
    parameter="relief_mm",
    lower=0.0,
    upper=None,
    start=0.1,
    neutral=0.0,
    unit="mm",
)
def mount_preload(state: eodarm.EffectState, i: int, relief_mm: float) -> dict:
    """A mount of actuator i+1 that holds the first newtons of a force change: relief
    ``relief_mm`` against the force change's deformation, outside the actuator's sensor."""
    df = state.force_n[:, i] - state.force0_n[:, i]  # compression +
    ramp = np.minimum(np.abs(df) / THRESHOLD_N, 1.0)
    # a compression (df > 0) shortens a spring; the relief gives some of it back (+)
    return {"actuator_unseen_mm": np.sign(df) * relief_mm * ramp}


@eodarm.custom_effect(
    "joint_preload",
    places="O",
    parameter="relief_mm",
    lower=0.0,
    upper=None,
    start=0.1,
    neutral=0.0,
    unit="mm",
)
def joint_preload(state: eodarm.EffectState, i: int, relief_mm: float) -> dict:
    """Joint O_{i+1} that holds the first newtons of a change of its force: the pin of link
    i+1 is held ``relief_mm`` against the direction the change pushes it."""
    dr = state.reaction_n[:, i, :] - state.reaction0_n[:, i, :]  # (N, 2), on link i
    mag = np.hypot(dr[:, 0], dr[:, 1])
    unit = np.zeros_like(dr)
    nz = mag > 1e-9
    unit[nz] = dr[nz] / mag[nz, None]
    ramp = np.minimum(mag / THRESHOLD_N, 1.0)
    # the change pushes link i's pin along -dr (body i-1 pushes link i by +dr); relief: +dr
    return {"joint_offset_mm": unit * (relief_mm * ramp)[:, None]}
