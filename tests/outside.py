"""Truths the effect catalogue does not have, for tests of the verdict "unexplained"."""

from __future__ import annotations

import numpy as np

import eodarm
from eodarm.data.measurements import channel_values


def with_stick_slip(
    arm: eodarm.Arm, meas: eodarm.Measurements, i: int, f0: float
) -> eodarm.Measurements:
    """The measurements plus stick-slip friction in actuator i's body (0-based): the body does
    not move until the force change passes ``f0`` (N), then follows its stiffness k:
    its length change is −sign(ΔF)·max(|ΔF| − f0, 0)/k instead of −ΔF/k. No effect of the
    catalogue does this (a play adds length change, a stiffness scales it).

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
    extra_length = np.sign(df) * np.minimum(np.abs(df), f0) / k
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
