"""A friction deadband in an actuator, as a user-written effect (CONTRACT §8).

The actuator's moving part sticks until the change of the axial force passes a threshold
(``friction_n``): of a force change ΔF only what exceeds the threshold compresses the body,
so the body's length changes by −sign(ΔF)·max(|ΔF| − friction, 0)/k instead of −ΔF/k. The
effect returns the difference to the baseline's spring, +sign(ΔF)·min(|ΔF|, friction)/k, as a
length change that the actuator's own sensor sees (``actuator_mm``).

Use it from the command line (docs/custom-effects.md)::

    eodarm diagnose MEAS.csv --arm ARM.toml --effects examples/friction.py
    eodarm fit MEAS.csv --arm ARM.toml --effects examples/friction.py --add actuator_friction@M2

or run this file for the whole story in Python: synthetic data of the example arm with a
30 N deadband hidden in actuator 2, the diagnosis that finds it, and the fit::

    python examples/friction.py
"""

from __future__ import annotations

import numpy as np

import eodarm


@eodarm.custom_effect(
    "actuator_friction",
    places="M",
    parameter="friction_n",
    lower=0.0,
    upper=None,
    start=10.0,
    neutral=0.0,
    unit="N",
)
def actuator_friction(state: eodarm.EffectState, i: int, friction_n: float) -> dict:
    """Deadband of ``friction_n`` newtons in actuator i+1: the part of the force change that
    friction holds does not compress the body."""
    df = state.force_n[:, i] - state.force0_n[:, i]  # loaded minus unloaded, compression +
    k = state.arm.actuators[i].stiffness_n_per_mm
    return {"actuator_mm": np.sign(df) * np.minimum(np.abs(df), friction_n) / k}


def main() -> None:
    from pathlib import Path

    from eodarm.analysis.synth import random_configs, synth

    arm = eodarm.Arm.from_toml(Path(__file__).with_name("example_arm.toml"))
    configs = random_configs(arm, 16, np.random.default_rng(0))
    truth = eodarm.Effect("actuator_friction", "M2", friction_n=30.0)
    meas = synth(arm, configs, [1.5, 3.0, 5.0, 6.5], hidden=[truth], seed=1)

    d = eodarm.diagnose(arm, meas)
    print(f"verdict {d.verdict}, suggested {[s.key for s in d.suggested]}")
    for c in d.ranking[:3]:
        print(f"  {c.slot.label:32s} chi2/dof {c.fit.chi2_per_dof:8.3f}")

    res = eodarm.fit(arm, meas, ["actuator_friction@M2"])
    before = eodarm.fit(arm, meas, [])
    print(
        f"friction_n = {res.estimate(0):.1f} ± {res.stderr(0):.1f} N (truth 30); "
        f"RMS dl2_mm {before.rms()['dl2_mm']:.4f} -> {res.rms()['dl2_mm']:.4f} mm"
    )


if __name__ == "__main__":
    main()
