"""``eodarm diagnose``: which effect is missing."""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING, Any

import numpy as np

from eodarm.model.arm import Arm
from eodarm.model.effects import Effect

if TYPE_CHECKING:
    from eodarm.data.measurements import Measurements
from eodarm.cli._common import (
    _describe_data,
    _fmt,
    _load_arm,
    _model,
    _model_kw,
    _noise_json,
    _plots,
    _print_table,
    _read,
    _rms_line,
    data_command,
)


def run(args: argparse.Namespace) -> int:
    from eodarm.analysis.diagnose import diagnose

    arm = _load_arm(args.arm)
    meas = _read(args.measurements, arm)
    sw = not args.no_self_weight
    model = [m for m in _model(args.add, allow_values=False) if not isinstance(m, Effect)]
    mk = _model_kw(args)
    d = diagnose(
        arm,
        meas,
        model,
        self_weight=sw,
        max_set=args.max_set,
        solver_model=mk["model"],
        fem_options=mk["fem_options"],
    )
    if args.json:
        # the contract's keys, and where each channel's σ came from
        print(json.dumps({**d.to_json(), "noise": _noise_json(meas)}))
    else:
        _print_diagnosis(d, arm, meas)
    best = d.suggested_fit or d.baseline
    _plots(args.plot, meas, d.baseline, best, list(best.effects), arm, sw, None, mk)
    return 0


def _print_diagnosis(d: Any, arm: Arm, meas: Measurements) -> None:
    print(
        f"diagnose {meas.source} with arm '{arm.name}', model: baseline"
        + "".join(f" + {s.key}" for s in d.model)
    )
    print(_describe_data(meas))
    print(
        f"baseline: chi2/dof {d.baseline.chi2_per_dof:.4g} (p = {d.p_baseline:.2g})   "
        f"RMS {_rms_line(d.baseline.rms())}"
    )
    print(f"verdict: {d.verdict.upper()}", end="")
    if d.verdict == "adequate":
        print(" — the model explains the data within their noise; nothing is missing")
    else:
        print(
            f" — suggested: {' + '.join(s.label for s in d.suggested) or '(none)'}"
            f"  ({d.sets_searched} candidate sets searched)"
        )
    if d.suggested_fit is not None:
        f = d.suggested_fit
        for i, s in enumerate(f.slots):
            print(f"    {s.label:28s} {s.kind.param} = {_fmt(f.estimate(i))} ± {_fmt(f.stderr(i))}")
        print(f"    chi2/dof {f.chi2_per_dof:.4g}   RMS {_rms_line(f.rms())}")
    print("\nranking (each candidate added alone, parameter fitted):")
    chans = list(d.baseline.rms())
    rows = []
    for i, c in enumerate(d.ranking):
        j = c.fit.slots.index(c.slot)
        rms = c.fit.rms()
        rows.append(
            [
                str(i + 1),
                c.slot.label,
                f"{c.slot.kind.param}={_fmt(c.fit.estimate(j))}",
                f"{c.fit.chi2_per_dof:.4g}",
                *(_fmt(rms.get(ch, np.nan)) for ch in chans),
                ", ".join(c.confused_with),
            ]
        )
    _print_table(["#", "effect@place", "estimate", "chi2/dof", *chans, "confused with"], rows)
    for a in d.advice:
        x, y = a["pair"]
        print(f"\n{x} and {y} cannot be told apart with these channels and poses.")
        if a["channel"]:
            print(
                f"  measure {a['channel']['channel']}: it separates them by "
                f"chi2 = {a['channel']['chi2_separation']:.3g} on the same poses"
            )
        pose = a["pose"]
        if pose and pose["chi2_separation"] > 3.84:
            ang = ", ".join(f"{v:.1f}" for v in pose["alpha_deg"])
            print(
                f"  or add the pose alpha = ({ang}) deg at {pose['mass_kg']:g} kg: "
                f"chi2 = {pose['chi2_separation']:.3g} between them on the measured channels"
            )
        elif pose:
            print("  no reachable pose separates them on the measured channels alone")
    if d.outliers:
        print(
            "\noutliers (> 4σ after the best fit, left out): "
            + "; ".join(f"line {r['line']} {r['channel']} z={r['z']:+.1f}" for r in d.outliers)
        )


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register ``eodarm diagnose`` on the sub-parser collection."""
    c = data_command(
        sub,
        "diagnose",
        "rank every candidate effect; find the missing set",
        "Rank every candidate effect x place not in the model by how well it explains "
        "the measurements, and search sets of up to three for the smallest that does.",
    )
    c.add_argument(
        "--add",
        action="append",
        metavar="EFFECT@PLACE",
        help="an effect already in the model (its parameter is fitted)",
    )
    c.add_argument(
        "--max-set",
        type=int,
        default=3,
        choices=(1, 2, 3),
        help="largest set searched for 'suggested' (default 3)",
    )
    c.set_defaults(func=run)
    return c
