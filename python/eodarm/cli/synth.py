"""``eodarm synth``: a synthetic measurement file (the model with hidden effects + noise)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.synth import random_configs, synth
from eodarm.cli._common import (
    ARM_HELP,
    _arm_argv,
    _effects_args,
    _load_arm,
    _next,
    _note,
    _payload_hint,
    _stages,
    _valued_effect,
    check_kinds_of,
)
from eodarm.cli._help import HELP
from eodarm.cli._outputs import _claim, _claim_folder, _force_arg, _free_name
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect


# ---------------------------------------------------------------------------- CLI
def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register the ``synth`` subcommand on an argparse ``add_subparsers()`` object."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        "synth",
        help=HELP["synth"],
        description="Virtual test bench: solve the arm with hidden effects for configurations "
        "× payloads, add Gaussian noise and write a measurement CSV (docs/formats.md §3).",
    )
    p.add_argument("--arm", metavar="ARM.toml", help=ARM_HELP)
    poses = p.add_mutually_exclusive_group()
    poses.add_argument(
        "--configs",
        type=int,
        metavar="K",
        help="number of random well-conditioned configurations (default 16)",
    )
    poses.add_argument(
        "--alpha",
        action="append",
        metavar="A1,A2,...",
        help="unloaded absolute link angles in degrees (repeat for more configurations)",
    )
    p.add_argument(
        "--masses",
        default="1.5,5,6.5",
        metavar="M1,M2,...",
        help="payload masses in kg, each applied to every configuration (default 1.5,5,6.5)",
    )
    p.add_argument(
        "--sequence",
        metavar="M0,M1,...",
        help="one load sequence applied to every configuration in this order, e.g. "
        "0,1.5,5,6.5,5,1.5,0 (a leading 0 is the zeroed reference): writes a step column, "
        "friction and gaps keep their history (instead of --masses); with --records, the "
        "payloads of each record in the order applied (default 0,1.5,5,6.5,5,1.5,0)",
    )
    p.add_argument(
        "--hidden",
        action="append",
        metavar="EFFECT@PLACE=VALUE",
        help="an effect present in the synthetic arm, e.g. joint_clearance@O3=0.15 (repeatable)",
    )
    p.add_argument(
        "--channels",
        default="all",
        metavar="LIST",
        help="measured channels: names or families dx_mm,dy_mm,dalpha,dl, or 'all' (default)",
    )
    p.add_argument(
        "--noise",
        type=float,
        default=1.0,
        help="multiple of the default noise levels (default 1.0)",
    )
    p.add_argument(
        "--sigma",
        action="append",
        metavar="CHANNEL=VALUE",
        help="noise standard deviation of a channel or family, mm or deg (repeatable)",
    )
    p.add_argument(
        "--repeats",
        type=int,
        default=1,
        metavar="K",
        help="measure each state (configuration × payload) K times, each with its own noise "
        "(default 1); without sigma columns, readers pool the noise from the repeats",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--no-self-weight", action="store_true", help="drop link/actuator weights")
    p.add_argument(
        "--no-sigma-columns",
        action="store_true",
        help="do not write sigma_ columns (readers then pool the noise from the repeats, or "
        "else use the default noise levels)",
    )
    p.add_argument("-o", "--output", metavar="OUT.csv", help="output file (default: stdout)")
    _force_arg(p, "an existing -o file, or the files of --records in a folder that holds some")
    _records_args(p)
    _effects_args(p)
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``eodarm synth``: write the CSV, report on stderr, return the exit status 0.

    Raises
    ------
    EodarmError
        With a one-line reason (the main CLI prints it and exits with status 2).
    """
    if args.records:  # rehearsal records of a campaign instead of a measurement file
        _claim_folder(args, args.records, "--records")
    elif args.output:
        _claim(args, args.output, "-o")
    arm = _load_arm(args.arm)
    check_kinds_of(arm, args.hidden, "--hidden")
    if args.records:
        return _records(args, arm)
    n = arm.n
    sequence = getattr(args, "sequence", None)
    masses = _floats(sequence, "--sequence") if sequence else _floats(args.masses, "--masses")
    if not masses:
        raise EodarmError("--masses: give at least one payload mass")
    if sequence and (any(m < 0 for m in masses) or masses == [0.0]):
        raise EodarmError(
            f"--sequence '{sequence}': payloads must be >= 0, with at least one after the reference"
        )
    hidden = [_hidden_effect(s) for s in args.hidden or []]
    if args.repeats < 1:
        raise EodarmError(f"--repeats: need at least 1 measurement per state, got {args.repeats}")
    sigma: dict[str, float] = {}
    for spec in args.sigma or []:
        key, _, value = spec.partition("=")
        try:
            sigma[key.strip()] = float(value)
        except ValueError:
            raise EodarmError(
                f"--sigma '{spec}': expected CHANNEL=VALUE, e.g. dy_mm=0.01"
            ) from None
    hinted = _payload_hint(arm, masses, "--sequence" if sequence else "--masses")
    if args.alpha:
        alpha = np.array([_angles(a, n) for a in args.alpha])
    else:
        k = 16 if args.configs is None else args.configs
        if k < 1:
            raise EodarmError(f"--configs: need at least 1 configuration, got {k}")
        # configurations from their own stream, so that they do not share draws with the noise
        with hinted:
            alpha = _solvable_configs(
                arm,
                k,
                np.random.default_rng([1, args.seed]),
                masses,
                hidden,
                not args.no_self_weight,
            )
    with hinted, _stages(["solving", "writing"], "synth") as step:
        step("solving")
        meas = synth(
            arm,
            alpha,
            masses,
            hidden=hidden,
            channels=args.channels,
            sigma=sigma,
            noise=args.noise,
            seed=args.seed,
            self_weight=not args.no_self_weight,
            sigma_columns=not args.no_sigma_columns,
            repeats=args.repeats,
            sequence=bool(sequence),
        )
        step("writing")
        if args.output:
            meas.to_csv(args.output)
            where = args.output
        else:
            meas.to_csv(sys.stdout)
            sys.stdout.flush()
            where = "stdout"
    from eodarm.viz.format import plural

    model = ", ".join(f"{e.key}={e.value:g}" for e in hidden) or "none"
    configs = plural(alpha.shape[0], "config")
    repeats = f" × {plural(args.repeats, 'repeat')}" if args.repeats > 1 else ""
    if sequence:
        what = (
            f"{plural(meas.n_rows, 'state')} ({configs}{repeats} × the sequence "
            f"{','.join(f'{m:g}' for m in masses)}"
        )
    else:
        rows = plural(meas.n_rows, "state" if args.repeats == 1 else "row")
        what = f"{rows} ({configs} × {plural(len(masses), 'payload')}{repeats}"
    _note(
        f"wrote {what}, {plural(len(meas.measured_channels), 'channel')}; hidden: {model}) "
        f"to {where}"
    )
    _next("diagnose", args.output or "FILE.csv", *_arm_argv(args, always=True), args=args)
    return 0


def _solvable_configs(
    arm: Arm,
    k: int,
    rng: np.random.Generator,
    masses: list[float],
    hidden: list[Effect],
    self_weight: bool,
) -> npt.NDArray[np.float64]:
    """``k`` random well-conditioned configurations whose every loaded state the model can
    solve: a soft arm (the seed's 500 N/mm springs) pushes an actuator near the edge of its
    triangle past it under the largest payload; such draws are replaced by further ones."""
    from eodarm.model.solver import solve

    def solvable(a: npt.NDArray[np.float64]) -> bool:
        try:
            solve(
                arm,
                np.repeat(a[None, :], len(masses), axis=0),
                np.asarray(masses),
                effects=hidden,
                self_weight=self_weight,
                strict=True,
            )
        except (ValueError, EodarmError):
            return False
        return True

    keep: list[npt.NDArray[np.float64]] = []
    for _ in range(50):
        keep += [a for a in random_configs(arm, k, rng) if solvable(a)]
        if len(keep) >= k:
            return np.ascontiguousarray(np.array(keep[:k]))
    raise EodarmError(
        f"found only {len(keep)} of {k} random configurations that the model can solve under "
        f"{max(masses):g} kg; give the poses with --alpha"
    )


def _floats(text: str, what: str) -> list[float]:
    try:
        vals = [float(t) for t in text.replace(";", ",").split(",") if t.strip()]
    except ValueError:
        raise EodarmError(f"{what} '{text}': expected comma-separated numbers") from None
    if not all(math.isfinite(v) for v in vals):
        raise EodarmError(f"{what} '{text}': numbers must be finite")
    return vals


def _angles(text: str, n: int) -> list[float]:
    vals = _floats(text, "--alpha")
    if len(vals) != n:
        raise EodarmError(f"--alpha '{text}': expected {n} angles for a {n}-link arm")
    return vals


def _hidden_effect(spec: str) -> Effect:
    """``EFFECT@PLACE=VALUE`` → Effect (a catalogue effect or a registered user-written one,
    e.g. from ``--effects FILE.py``)."""
    return _valued_effect(spec, "--hidden")


# ------------------------------------------------------------------- rehearsal records
def _records_args(p: argparse.ArgumentParser) -> None:
    """``--records DIR`` and its options (docs/records.md, "Rehearsal records")."""
    g = p.add_argument_group("rehearsal records (docs/records.md)")
    g.add_argument(
        "--records",
        metavar="DIR",
        help="write a campaign file and one raw record per configuration into DIR, as a "
        "logger would (offsets, a hand on the plate, ringing, correlated noise)",
    )
    g.add_argument(
        "--drift",
        action="append",
        metavar="STEP[=RATE]",
        help="with --records: state STEP (1 = first after the reference) creeps at RATE noise "
        "sigmas per second (default 1) on every channel (repeatable)",
    )
    g.add_argument("--rate", type=float, default=300.0, help="sampling rate, Hz (default 300)")
    g.add_argument("--hold", type=float, default=8.0, help="seconds per state (default 8)")


def _records(args: argparse.Namespace, arm: Arm) -> int:
    from eodarm.analysis.synth_records import synth_records, write_synth_campaign

    if args.output or args.repeats != 1 or args.no_sigma_columns:
        raise EodarmError(
            "--records writes a campaign: -o, --repeats, --no-sigma-columns do not apply"
        )
    seq = _floats(args.sequence or "0,1.5,5,6.5,5,1.5,0", "--sequence")
    hidden = [_hidden_effect(s) for s in args.hidden or []]
    drift: dict[int, float] = {}
    for spec in args.drift or []:
        k, _, rate = spec.partition("=")
        try:
            drift[int(k)] = float(rate) if rate else 1.0
        except ValueError:
            raise EodarmError(f"--drift '{spec}': expected STEP[=RATE], e.g. 3=0.5") from None
    sigma: dict[str, float] = {}
    for spec in args.sigma or []:
        key, _, value = spec.partition("=")
        try:
            sigma[key.strip()] = float(value)
        except ValueError:
            raise EodarmError(f"--sigma '{spec}': expected CHANNEL=VALUE") from None
    if args.alpha:
        alpha = np.array([_angles(a, arm.n) for a in args.alpha])
    else:
        alpha = _solvable_configs(
            arm,
            4 if args.configs is None else args.configs,
            np.random.default_rng([1, args.seed]),
            [max(seq) + 3.0],  # the hand presses up to 3 kg more
            hidden,
            not args.no_self_weight,
        )
    recs = synth_records(
        arm,
        alpha,
        seq,
        hidden=hidden,
        channels=args.channels,
        sigma=sigma,
        noise=args.noise,
        seed=args.seed,
        self_weight=not args.no_self_weight,
        rate_hz=args.rate,
        hold_s=args.hold,
        drift=drift,
    )

    def refuse_inputs(paths: list[Path]) -> None:  # --force replaces no input
        for p in paths:
            _claim(args, p, "--records")

    path = write_synth_campaign(args.records, recs, before=refuse_inputs)
    model = ", ".join(f"{e.key}={e.value:g}" for e in hidden) or "none"
    _note(f"wrote {len(recs)} records ({len(seq)} states each; hidden: {model}) and {path}")
    _next("records", str(path), "-o", _free_name("meas.csv"), *_arm_argv(args, always=True))
    return 0
