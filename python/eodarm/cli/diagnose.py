"""``eodarm diagnose``: which effect is missing."""

from __future__ import annotations

import argparse
import json
import textwrap
from typing import TYPE_CHECKING, Any

import numpy as np

from eodarm.cli._help import HELP
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
    _note,
    _plots,
    _print_table,
    _read,
    _rms_line,
    data_command,
)


def run(args: argparse.Namespace) -> int:
    from eodarm.analysis.diagnose import diagnose

    arm = _load_arm(args.arm, args.measurements)
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
        print(json.dumps({**d.to_json(), "noise": _noise_json(meas)}, allow_nan=False))
    else:
        _print_diagnosis(d, arm, meas)
    best = d.best_fit
    _plots(args.plot, meas, d.baseline, best, list(best.effects), arm, sw, None, mk)
    if args.plot and d.verdict == "unexplained":
        from pathlib import Path

        from eodarm.viz.residual_map import residual_map

        path = Path(args.plot) / "residual_pattern.png"
        residual_map(best, path=path)
        _note(f"wrote {path}")
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
    elif d.verdict == "missing":
        print(
            f" — suggested: {' + '.join(s.label for s in d.suggested)}"
            f"  ({d.sets_searched} candidate sets searched)"
        )
        if d.suggested_fit is not None:
            _print_fit(d.suggested_fit)
        if d.acceptance is not None:
            _say("accepted: " + "; ".join(d.acceptance.reasons()), "    ")
    else:
        _print_unexplained(d)
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


def _print_fit(f: Any) -> None:
    for i, s in enumerate(f.slots):
        print(f"    {s.key:28s} {s.kind.param} = {_fmt(f.estimate(i))} ± {_fmt(f.stderr(i))}")
    print(f"    chi2/dof {f.chi2_per_dof:.4g}   RMS {_rms_line(f.rms())}")


def _say(text: str, indent: str = "", width: int = 100) -> None:
    print(textwrap.fill(text, width, initial_indent=indent, subsequent_indent=indent + "  "))


def _print_unexplained(d: Any) -> None:
    """The verdict 'unexplained' in words, the best effort, and the pattern that is left."""
    from eodarm.analysis.residuals import residual_pattern

    print(" — what is missing is not in the catalogue")
    _say(
        f"none of the {d.sets_searched} sets of up to three candidate effects fits the data "
        "within their noise with every parameter away from its bounds and predicts held-out "
        "configurations no worse (or the stated σ are too small)",
        "    ",
    )
    best = d.best_fit
    if d.best_effort:
        _say(
            "best effort (lowest BIC; it does not explain the data): "
            + " + ".join(s.key for s in d.best_effort)
        )
        _print_fit(best)
        if d.best_effort_cv is not None:
            _say(
                "held-out RMS (leave one configuration out) " + _rms_line(d.best_effort_cv["rms"]),
                "    ",
            )
        if d.acceptance is not None:
            _say("; ".join(d.acceptance.reasons()), "    ")
    else:
        _say("best effort (lowest BIC): the model as it is; no set of candidates lowers the BIC")
    pat = residual_pattern(best)
    cells = [
        f"{c['channel']} in {c['config']} at {c['mass_kg']:g} kg ({c['z']:+.1f}σ, line {c['line']})"
        for c in pat.largest[:3]
    ]
    _say(
        "no effect of the catalogue explains these data; the largest remaining residuals are "
        + "; ".join(cells)
    )
    _print_pattern(pat)


def _z(v: float) -> str:
    if not np.isfinite(v):
        return "."
    if abs(v) < 9.95:
        return f"{v:+.1f}"
    if abs(v) < 999.5:
        return f"{v:+.0f}"
    return f"{v:+.0e}"


def _print_pattern(pat: Any, width: int = 100) -> None:
    """Mean residual/sigma by configuration and by payload, one column per channel, within
    ``width`` columns (the channels carrying the least misfit are dropped first)."""
    names = [ch.removesuffix("_mm").removesuffix("_deg") for ch in pat.channels]
    label_w = 12
    col_w = max([7, *(len(n) + 1 for n in names)])
    fits = max(1, (width - label_w - 2) // (col_w + 2))
    keep = sorted(np.argsort(-np.nan_to_num(pat.rms_z))[:fits].tolist())
    print("\nwhat is left, mean (measured − model)/σ by configuration and by payload:")
    head = ["", *(names[j] for j in keep)]
    rows = [
        [c[:label_w], *(_z(pat.by_config[i, j]) for j in keep)] for i, c in enumerate(pat.configs)
    ]
    rows += [
        [f"{m:g} kg", *(_z(pat.by_payload[p, j]) for j in keep)] for p, m in enumerate(pat.payloads)
    ]
    rows.append(["RMS", *(f"{pat.rms_z[j]:.3g}" for j in keep)])
    widths = [label_w] + [col_w] * len(keep)
    print("  ".join(h.rjust(w) for h, w in zip(head, widths, strict=True)))
    for k, r in enumerate(rows):
        if k in (0, len(pat.configs)):
            print("  ".join(("-" * w) for w in widths))
        print("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)))
    if len(keep) < len(names):
        gone = [names[j] for j in range(len(names)) if j not in keep]
        print(f"(not shown, smaller residuals: {', '.join(gone)})")


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register ``eodarm diagnose`` on the sub-parser collection."""
    c = data_command(
        sub,
        "diagnose",
        HELP["diagnose"],
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
