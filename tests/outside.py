"""Truths the effect catalogue does not have, for tests of the verdict "unexplained"."""

from __future__ import annotations

import numpy as np

import eodarm
from eodarm.data.measurements import channel_values


def with_softening(
    arm: eodarm.Arm, meas: eodarm.Measurements, i: int, f0: float
) -> eodarm.Measurements:
    """The measurements plus a softening body in actuator i (0-based): its stiffness falls with
    the load as k/(1 + |ΔF|/f0) (``f0`` in N), so its length change is −ΔF/k − ΔF·|ΔF|/(k·f0),
    quadratic in the load. No effect of the catalogue does this (a stiffness scales the length
    change, a play or a friction shifts it by a constant).

    The core cannot solve it, so it is added to the data to first order: the channels' response
    to a pin-to-pin length change of actuator i is read off a very stiff mount there (whose
    extra length change is −ΔF/k_m), ΔF from ``eodarm.solve``'s ``force_n``.
    """
    a, m = meas.alpha_deg, meas.mass_kg
    k = arm.actuators[i].stiffness_n_per_mm
    plain = eodarm.solve(arm, a, m)
    df = plain["force_n"][:, i] - eodarm.solve(arm, a, 0.0)["force_n"][:, i]
    km = 1e6
    mount = eodarm.Effect("mount_compliance", f"M{i + 1}", stiffness_n_per_mm=km)
    soft = eodarm.solve(arm, a, m, effects=[mount])
    ch = meas.channels
    per_mount = channel_values(soft, ch) - channel_values(plain, ch)  # response to −ΔF/k_m
    extra_length = -df * np.abs(df) / (k * f0)
    extra = per_mount * (-km * extra_length / np.where(df == 0, 1.0, df))[:, None]
    extra[:, ch.index(f"dl{i + 1}_mm")] = extra_length  # the body's own sensor sees it
    values = meas.values + extra
    return eodarm.Measurements.from_arrays(
        config=meas.config,
        alpha_deg=a,
        mass_kg=m,
        values={c: values[:, j] for j, c in enumerate(ch)},
        sigma={c: meas.sigma[:, j] for j, c in enumerate(ch)},
    )
