"""A harmonic drive's soft band, a user-written effect at a rotary joint (docs/custom-effects.md).

A strain-wave (harmonic) gear is not one torsional spring: below a knee torque T1 its
flexspline is soft (stiffness K1), above it stiffer (K2, the stiffness a datasheet gives at
rated torque, the arm file's ``stiffness_nmm_per_rad``). Its output turns by

    φ(T) = T/K1                          for |T| ≤ T1,
    φ(T) = sign(T)·(T1/K1 + (|T| − T1)/K2)  above,

against the drive's torque T (N·mm). The model's gear already gives −ΔT/K2 (docs/model.md
§10); what the soft band adds is the rest, −[g(T) − g(T0)] with

    g(T) = sign(T)·min(|T|, T1)·c,   c = 1/K1 − 1/K2  (rad per N·mm, ≥ 0),

an extra turn of link i against body i−1 (``joint_turn_rad``, counter-clockwise +), from the
loaded and unloaded torques of ``EffectState.torque_nmm`` / ``torque0_nmm``. The effect's one
parameter is c, the soft band's extra compliance, absent at c = 0 (a diagnosis measures each
candidate from where it is absent); K1 = 1/(c + 1/K2). T1 is the datasheet's knee torque,
fixed here (:data:`KNEE_NMM`). At a joint turned by a linear actuator (a mixed arm) it adds
nothing. No catalogue effect does this: ``drive_compliance`` is linear
in ΔT, ``drive_backlash`` a constant turn.

From the command line::

    eodarm synth --arm examples/rotary_arm.toml --effects examples/harmonic_drive.py \\
        --configs 10 --hidden harmonic_soft_band@O3=4.2e-7 -o meas.csv
    eodarm diagnose meas.csv --arm examples/rotary_arm.toml --effects examples/harmonic_drive.py
    eodarm fit meas.csv --arm examples/rotary_arm.toml --effects examples/harmonic_drive.py \\
        --add harmonic_soft_band@O3

or run this file for the same story in Python (the wrist drive of the rotary example arm,
K2 = 4.0e6 N·mm/rad, with K1 = 1.5e6 N·mm/rad below 15 N·m)::

    python examples/harmonic_drive.py
"""

from __future__ import annotations

import numpy as np

import eodarm

#: The knee torque T1 below which the flexspline is soft, N·mm (a datasheet's T1).
KNEE_NMM = 15_000.0


@eodarm.custom_effect(
    "harmonic_soft_band",
    places="O",
    parameter="c_rad_per_nmm",
    lower=0.0,
    upper=None,
    start=1e-7,
    neutral=0.0,
    unit="rad/(N·mm)",
)
def harmonic_soft_band(state: eodarm.EffectState, i: int, c_rad_per_nmm: float) -> dict:
    """The soft band of the harmonic drive at joint i+1: an extra turn where |T| < T1."""
    if state.arm.kinds[i] != "rotary":
        return {}  # a joint turned by a linear actuator has no gear: nothing to add

    def g(t: np.ndarray) -> np.ndarray:
        return np.sign(t) * np.minimum(np.abs(t), KNEE_NMM) * c_rad_per_nmm

    turn = -(g(state.torque_nmm[:, i]) - g(state.torque0_nmm[:, i]))
    return {"joint_turn_rad": turn}


def soft_stiffness(c_rad_per_nmm: float, k2_nmm_per_rad: float) -> float:
    """K1 (N·mm/rad) from the fitted c and the gear's stiffness K2 above the knee."""
    return 1.0 / (c_rad_per_nmm + 1.0 / k2_nmm_per_rad)


def main() -> None:
    from pathlib import Path

    from eodarm.analysis.synth import random_configs, synth

    arm = eodarm.Arm.from_toml(Path(__file__).with_name("rotary_arm.toml"))
    k2 = arm.actuators[2].stiffness_nmm_per_rad
    k1 = 1.5e6
    c = 1.0 / k1 - 1.0 / k2
    configs = random_configs(arm, 10, np.random.default_rng(0))
    truth = eodarm.Effect("harmonic_soft_band", "O3", c_rad_per_nmm=c)
    meas = synth(arm, configs, [1.5, 5.0, 6.5], hidden=[truth], seed=1)

    d = eodarm.diagnose(arm, meas)
    print(f"verdict {d.verdict}, suggested {[s.key for s in d.suggested]}")
    for cand in d.ranking[:3]:
        print(f"  {cand.slot.label:40s} chi2/dof {cand.fit.chi2_per_dof:8.3f}")

    res = eodarm.fit(arm, meas, ["harmonic_soft_band@O3"])
    p = res.params["harmonic_soft_band@O3:c_rad_per_nmm"]
    lo, hi = soft_stiffness(p.value + p.stderr, k2), soft_stiffness(p.value - p.stderr, k2)
    print(
        f"c = {p.value:.4g} ± {p.stderr:.2g} rad/(N·mm) (truth {c:.4g}): "
        f"K1 = {soft_stiffness(p.value, k2):.4g} N·mm/rad ({lo:.4g} … {hi:.4g}; truth {k1:.4g}) "
        f"below {KNEE_NMM:g} N·mm, K2 = {k2:.4g} above"
    )


if __name__ == "__main__":
    main()
