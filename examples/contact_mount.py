"""A worn pin bearing in an actuator's mount, as a user-written effect (docs/custom-effects.md).

The mount's pin sits in a worn bearing: the contact grows with the load, so the mount
stiffens as it is pressed (Hertz-like). Its pin-to-pin length changes by
−sign(ΔF)·c·|ΔF|^(2/3) (ΔF the actuator's force change, compression +, c in mm/N^(2/3)),
which the actuator's own sensor (``dlK_mm``) does not see (``actuator_unseen_mm``). No
effect of the catalogue does this: a ``mount_compliance`` is linear in ΔF, a play constant.

Use it from the command line (docs/custom-effects.md)::

    eodarm diagnose MEAS.csv --arm ARM.toml --effects examples/contact_mount.py
    eodarm fit MEAS.csv --arm ARM.toml --effects examples/contact_mount.py --add contact_mount@M2

or run this file for the whole story in Python: synthetic data of the example arm with a
worn mount hidden at actuator 2 (c = 0.001 mm/N^(2/3)), the diagnosis that finds it, and
the fit::

    python examples/contact_mount.py

(Before the load histories, this example was an actuator friction; friction is now built
in: ``actuator_friction`` and ``joint_friction``, docs/model.md.)
"""

from __future__ import annotations

import numpy as np

import eodarm


@eodarm.custom_effect(
    "contact_mount",
    places="M",
    parameter="c_mm_per_n23",
    lower=0.0,
    upper=None,
    start=1e-3,
    neutral=0.0,
    unit="mm/N^(2/3)",
)
def contact_mount(state: eodarm.EffectState, i: int, c_mm_per_n23: float) -> dict:
    """A worn pin bearing in the mount of actuator i+1: stiffens as the contact grows."""
    df = state.force_n[:, i] - state.force0_n[:, i]  # loaded minus unloaded, compression +
    return {"actuator_unseen_mm": -np.sign(df) * c_mm_per_n23 * np.abs(df) ** (2 / 3)}


def main() -> None:
    from pathlib import Path

    from eodarm.analysis.synth import random_configs, synth

    arm = eodarm.Arm.from_toml(Path(__file__).with_name("example_arm.toml"))
    configs = random_configs(arm, 16, np.random.default_rng(0))
    truth = eodarm.Effect("contact_mount", "M2", c_mm_per_n23=0.001)
    meas = synth(arm, configs, [1.5, 3.0, 5.0, 6.5], hidden=[truth], seed=1)

    d = eodarm.diagnose(arm, meas)
    print(f"verdict {d.verdict}, suggested {[s.key for s in d.suggested]}")
    for c in d.ranking[:3]:
        print(f"  {c.slot.label:32s} chi2/dof {c.fit.chi2_per_dof:8.3f}")

    res = eodarm.fit(arm, meas, ["contact_mount@M2"])
    before = eodarm.fit(arm, meas, [])
    c = res.params["contact_mount@M2:c_mm_per_n23"]
    print(
        f"c_mm_per_n23 = {c.value:.4g} ± {c.stderr:.2g} mm/N^(2/3) (truth 0.001); "
        f"RMS dy_mm {before.rms['dy_mm']:.4f} -> {res.rms['dy_mm']:.4f} mm"
    )


if __name__ == "__main__":
    main()
