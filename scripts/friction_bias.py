"""The friction estimates' bias and the coverage of their error bars on synthetic load cycles.

For each case (an arm, a hidden friction alone or with a gap) and each seed: synthetic load
cycles (``synth(..., sequence=True)``) from the hidden effects, a fit of the same effects,
and z = (estimate − truth)/σ of the friction. Prints per case the mean of z, its spread and
standard error, the fraction of 2σ intervals that cover the truth, the mean bias and σ in
units of the truth, the fraction of 95 % intervals (``Param.interval``, without an upper end
for a friction that could hold every state) that cover it, and how often that flag was set.
Configurations are drawn as ``eodarm synth`` draws them (``rng = [1, seed]``).

Run: ``PYTHONPATH=python python scripts/friction_bias.py [--seeds 30] [--seed0 0]
[--case NAME]… [--scale F]… [--noise F] [--k 16] [--channels dx_mm,dy_mm]``; ``--scale``
multiplies the hidden friction, ``--noise`` the noise with the same draws (a z that changes
with it is the estimator's nonlinearity, docs/model.md §9 "Fitting a friction").
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

import eodarm
from eodarm.analysis.fit import FitWarning
from eodarm.analysis.synth import random_configs, synth

ROOT = Path(__file__).resolve().parents[1]
CYCLE = [0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0]
E = eodarm.Effect

CASES = {
    "lin actuator_friction": ("example_arm", [E("actuator_friction", "M2", friction_n=40.0)]),
    "lin actuator_friction+play": (
        "example_arm",
        [E("actuator_friction", "M2", friction_n=40.0), E("actuator_play", "M2", play_mm=0.05)],
    ),
    "lin joint_friction": ("example_arm", [E("joint_friction", "O2", torque_nmm=5000.0)]),
    "lin joint_friction+clearance": (
        "example_arm",
        [
            E("joint_friction", "O2", torque_nmm=5000.0),
            E("joint_clearance", "O2", clearance_mm=0.1),
        ],
    ),
    "rot joint_friction": ("rotary_arm", [E("joint_friction", "O2", torque_nmm=3000.0)]),
    "rot joint_friction+backlash": (
        "rotary_arm",
        [
            E("joint_friction", "O2", torque_nmm=3000.0),
            E("drive_backlash", "O2", backlash_deg=0.05),
        ],
    ),
    "rot drive_friction": ("rotary_arm", [E("drive_friction", "O2", torque_nmm=3000.0)]),
    "rot drive_friction+backlash": (
        "rotary_arm",
        [
            E("drive_friction", "O2", torque_nmm=3000.0),
            E("drive_backlash", "O2", backlash_deg=0.05),
        ],
    ),
}


def run_case(
    name: str,
    seeds: int,
    k: int = 16,
    channels: list[str] | None = None,
    scale: float = 1.0,
    noise: float = 1.0,
    seed0: int = 0,
) -> dict[str, np.ndarray]:
    arm_name, hidden = CASES[name]
    hidden = [hidden[0].with_value(hidden[0].value * scale), *hidden[1:]]
    arm = eodarm.Arm.from_toml(ROOT / "examples" / f"{arm_name}.toml")
    truth = hidden[0].value
    keys = [f"{e.key}" for e in hidden]
    est, err, lower, upper, flagged = [], [], [], [], []
    for seed in range(seed0, seed0 + seeds):
        alpha = random_configs(arm, k, rng=np.random.default_rng([1, seed]))
        meas = synth(
            arm, alpha, CYCLE, hidden, channels=channels, seed=seed, sequence=True, noise=noise
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)
            res = eodarm.fit(arm, meas, keys)
        p = next(iter(res.params.values()))
        est.append(p.value)
        err.append(p.stderr)
        lower.append(p.interval[0])
        upper.append(p.interval[1])
        flagged.append(res.only_lower_limit(0))
    est_a, err_a = np.array(est), np.array(err)
    return {
        "truth": np.full(seeds, truth),
        "est": est_a,
        "err": err_a,
        "z": (est_a - truth) / err_a,
        "covered95": (np.array(lower) <= truth) & (truth <= np.array(upper)),
        "lower_only": np.array(flagged),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--case", action="append")
    ap.add_argument("--k", type=int, default=16)
    ap.add_argument("--channels", default=None)
    ap.add_argument("--scale", type=float, action="append")
    ap.add_argument("--noise", type=float, default=1.0)
    ap.add_argument("--seed0", type=int, default=0)
    a = ap.parse_args()
    chans = a.channels.split(",") if a.channels else None
    print(
        f"{'case':32s} {'mean z':>7s} {'sd z':>6s} {'se':>5s} {'cov2σ':>6s} {'bias/truth':>10s} "
        f"{'σ/truth':>8s} {'cov95':>6s} {'lower-only':>10s}"
    )
    for name, scale in [(n, f) for n in (a.case or CASES) for f in (a.scale or [1.0])]:
        r = run_case(name, a.seeds, a.k, chans, scale, a.noise, a.seed0)
        name = f"{name} x{scale:g}" if a.scale else name
        z = r["z"]
        n = z.size
        bias = np.mean(r["est"] - r["truth"]) / r["truth"][0]
        print(
            f"{name:32s} {z.mean():7.2f} {z.std(ddof=1):6.2f} {z.std(ddof=1) / np.sqrt(n):5.2f} "
            f"{np.mean(np.abs(z) <= 2):6.2f} {bias:10.4f} {np.mean(r['err']) / r['truth'][0]:8.4f} "
            f"{np.mean(r['covered95']):6.2f} {np.mean(r['lower_only']):10.2f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
