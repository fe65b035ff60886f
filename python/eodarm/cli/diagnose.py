"""``eodarm diagnose``: which effect is missing."""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING, Any

import numpy as np

from eodarm.cli._help import HELP
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect

if TYPE_CHECKING:
    from eodarm.data.measurements import Measurements
from eodarm.cli._common import (
    DEFAULT_REPORT,
    WIDTH,
    _arm_argv,
    _channel,
    _describe_data,
    _fmt,
    _load_arm,
    _model,
    _model_keys,
    _model_kw,
    _model_words,
    _next,
    _noise_json,
    _note,
    _plots,
    _print_table,
    _read,
    _rms_line,
    _say,
    _stages,
    check_kinds_of,
    data_command,
)
from eodarm.cli._outputs import _free_name


def run(args: argparse.Namespace) -> int:
    from eodarm.analysis.diagnose import diagnose

    arm = _load_arm(args.arm, args.measurements)
    check_kinds_of(arm, args.add, "--add")
    meas = _read(args.measurements, arm, not args.no_self_weight)
    sw = not args.no_self_weight
    model = [m for m in _model(args.add, allow_values=False) if not isinstance(m, Effect)]
    mk = _model_kw(args)
    with _stages(["diagnosing", "figures"], "diagnose") as step:
        step("diagnosing")
        d = diagnose(
            arm,
            meas,
            model,
            self_weight=sw,
            max_set=args.max_set,
            solver_model=mk["model"],
            fem_options=mk["fem_options"],
        )
        step("figures")
        _output(args, d, arm, meas, sw, mk)
    _say_next(args, d)
    return 0


def _output(args: argparse.Namespace, d: Any, arm: Arm, meas: Any, sw: bool, mk: Any) -> None:
    """The text or JSON on stdout, and the figures."""
    if args.json:
        # the contract's keys, and where each channel's σ came from
        doc = {**d.to_json(), "model": _model_keys(arm, d.model), "noise": _noise_json(meas)}
        print(json.dumps(doc, allow_nan=False))
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


def _say_next(args: argparse.Namespace, d: Any) -> None:
    """What to run next: a plan of more configurations when the leading candidates are
    confused (docs/plan.md); fit the suggested set; the rounds of a report when nothing in
    the catalogue explains the data; the workspace maps when nothing is missing."""
    data = [args.measurements, *_arm_argv(args)]
    from eodarm.analysis.plan.follow import confused_lead

    if confused_lead(d):
        from eodarm.analysis.plan.pool import payloads_of

        pl = payloads_of(d.baseline.problem.meas)
        loads = [
            "--sequence" if pl.sequence else "--masses",
            ",".join(f"{m:g}" for m in pl.masses_kg),
        ]
        _next("plan", "--fixed", *data, "--configs", "3", *loads, args=args)
        return
    adds = [a for s in [*d.model, *d.suggested] for a in ("--add", s.spec)]
    if d.verdict == "check_data":  # the residuals of every row, to look at the data
        _next("compare", *data, "--residuals", _free_name("residuals.csv"), args=args)
    elif d.verdict == "missing":
        _next("fit", *data, *adds, "--cv", "config", args=args)
    elif d.verdict == "unexplained":
        report = ["-o", _free_name(DEFAULT_REPORT)]  # its default may exist: never refused
        _next("report", *data, *[a for s in d.model for a in ("--add", s.spec)], *report, args=args)
    else:
        _next("sweep", *_arm_argv(args), "-o", _free_name("sweep.nc"), "--plot", "maps", args=args)


def _candidate(slot: Any) -> str:
    """A candidate in words with its identifier: ``actuator 3 body stiffness
    (actuator_compliance@M3)``."""
    from eodarm.viz.format import parameter_name

    taken = ", taken up" if getattr(slot, "unloaded", "centred") != "centred" else ""
    return f"{parameter_name(slot.name, slot.at)}{taken} ({slot.spec})"


def _print_diagnosis(d: Any, arm: Arm, meas: Measurements) -> None:
    from eodarm.viz.format import p_value, value

    _say(f"diagnose {meas.source} with arm '{arm.name}', model: {_model_words(arm, d.model)}")
    _say(_describe_data(meas))
    given = "baseline" if not (arm.effects or d.model) else "this model"  # before candidates
    _say(
        f"{given}: χ²/dof {d.baseline.chi2_per_dof:.4g} ({p_value(d.p_baseline)}); "
        f"RMS {_rms_line(d.baseline.rms())}"
    )
    if d.verdict == "check_data":
        _print_checks(d.data_checks)
        return
    if d.verdict == "adequate":
        _say(
            "verdict: ADEQUATE — the model explains the data within their noise; nothing is missing"
        )
    elif d.verdict == "missing":
        _say(
            f"verdict: MISSING — suggested: {suggested_words(d)} "
            f"({d.sets_searched} candidate sets searched)"
        )
        if d.suggested_fit is not None:
            _print_fit(d.suggested_fit, d)
        if d.acceptance is not None:
            _say("accepted: " + "; ".join(d.acceptance.reasons()), "    ")
    else:
        _print_unexplained(d)
    _print_ranking(d)
    for a in d.advice:
        x, y = a["pair"]
        print()
        what = " (suggested)" if a.get("suggested") else ""
        _say(f"{x}{what} and {y} cannot be told apart with these channels and poses.")
        if a.get("memory"):
            _say(f"what separates them: {a['memory']}", "  ")
        if a["channel"]:
            _say(
                f"measure {a['channel']['channel']}: it separates them by "
                f"χ² = {value(a['channel']['chi2_separation'], digits=3)} on the same poses",
                "  ",
            )
        pose = a["pose"]
        if pose and pose["chi2_separation"] > 3.84:
            ang = ", ".join(f"{v:.1f}" for v in pose["alpha_deg"])
            _say(
                f"or add the pose alpha = ({ang}) deg at {pose['mass_kg']:g} kg: "
                f"χ² = {value(pose['chi2_separation'], digits=3)} between them on the measured "
                "channels",
                "  ",
            )
        elif pose:
            _say("no reachable pose separates them on the measured channels alone", "  ")
    if d.outliers:
        print()
        _say(
            "outliers (> 4σ after the best fit, left out): "
            + "; ".join(f"line {r['line']} {r['channel']} z={r['z']:+.1f}" for r in d.outliers)
        )


def _print_checks(checks: Any) -> None:
    """The verdict *check_data*: what the data look like, one line each, with the fix."""
    _say(
        "verdict: CHECK THE DATA — they look mistaken, not like a missing effect; no effect "
        "was looked for (docs/diagnosis.md, Check the data first):"
    )
    for c in checks:
        _say(c.message, "  ")


def suggested_words(d: Any) -> str:
    """The suggested set on the verdict's line, each effect that the data cannot tell apart
    from another with its look-alikes and what would separate them: ``mount_compliance@M4
    (or actuator_compliance@M4: the data cannot tell them apart; a dl4_mm sensor would) +
    joint_clearance@O2``."""
    from eodarm.analysis.confusions import separated_by

    parts = []
    for s in d.suggested:
        alts = d.alternatives.get(s.spec) or []
        if not alts:
            parts.append(s.label)
            continue
        entry = next((a for a in d.advice if a["pair"] == [s.spec, alts[0]]), None)
        how = separated_by(entry)
        tail = f"; {how} would" if how else "; no channel or pose found would"
        parts.append(f"{s.label} (or {' or '.join(alts)}: the data cannot tell them apart{tail})")
    return " + ".join(parts)


def _estimate(fit: Any, j: int) -> str:
    """A ranked candidate's estimate, three digits, marked where it sits at a bound."""
    from eodarm.viz.format import value

    slot = fit.slots[j]
    text = value(fit.estimate(j), slot.kind.unit, digits=3)
    return text + " (at bound)" if fit.at_bound[j] else text


def _print_ranking(d: Any, width: int = WIDTH) -> None:
    """The candidates that lower χ² as a table (the RMS of as many channels as fit within
    ``width`` columns), the others folded into one wrapped line. A suggested effect is a row
    of the table even when it does not help alone, with a line saying so."""
    floor = 1e-6 * max(d.baseline.chi2, 1.0)
    sugg = {s.key for s in d.suggested}
    helping = [c for c in d.ranking if c.delta_chi2 > floor or c.slot.key in sugg]
    idle = [c for c in d.ranking if c.delta_chi2 <= floor and c.slot.key not in sugg]
    print("\nranking (each candidate added alone, its parameter fitted):")
    chans = list(d.baseline.rms())
    main = [ch for ch in ("dy_mm", "dx_mm") if ch in chans]
    chans = main + [ch for ch in chans if ch not in main]
    rows = []
    number = {c.slot.label: str(i + 1) for i, c in enumerate(helping)}
    for i, c in enumerate(helping):
        j = c.fit.slots.index(c.slot)
        rms = c.fit.rms()
        rows.append(
            [
                str(i + 1),
                _candidate(c.slot),
                _estimate(c.fit, j),
                f"{c.fit.chi2_per_dof:.4g}",
                ", ".join(f"#{number[k]}" if k in number else k for k in c.confused_with),
                *(_fmt(rms.get(ch, np.nan)) for ch in chans),
            ]
        )
    head = ["#", "candidate", "estimate", "χ²/dof", "same as"]
    head += [f"{_channel(ch)[0]} {_channel(ch)[1]}" for ch in chans]
    same = [(r[0], r[4]) for r in rows if r[4]]
    if not same or _span(head[:6], rows) > width:  # the column, or a line below the table
        head.pop(4)
        rows = [r[:4] + r[5:] for r in rows]
    fixed = len(head) - len(chans)
    shown = len(chans)
    while rows and shown > 0 and _span(head[: fixed + shown], rows) > width:
        shown -= 1
    if rows:
        _print_table(head[: fixed + shown], [r[: fixed + shown] for r in rows], width, left=(1,))
        if fixed == 4 and same:
            _say(
                "the data cannot tell apart: "
                + ", ".join(f"#{a} and {b}" for a, b in same if f"#{a}" < b or "#" not in b)
            )
        if shown < len(chans):
            _say(
                f"(RMS shown for {', '.join(chans[:shown]) or 'no channel'}; every channel's "
                "in --json)"
            )
    else:
        print("no single candidate lowers χ²")
    _print_alone(d, [c for c in helping if c.delta_chi2 <= floor], number)
    if idle:
        unchanged = idle[0].fit.chi2_per_dof
        _say(
            f"do not help alone (added alone, their parameter stays where the effect is "
            f"absent; χ²/dof {unchanged:.4g}): " + ", ".join(c.slot.spec for c in idle)
        )


def _print_alone(d: Any, alone: list[Any], number: dict[str, str]) -> None:
    """A line for each suggested effect that does not help alone: its value in the set."""
    from eodarm.viz.format import value_error

    f = d.suggested_fit
    for c in alone:
        if f is None:
            continue
        i = [s.key for s in f.slots].index(c.slot.key)
        _say(
            f"#{number[c.slot.label]} {c.slot.spec} does not help alone; with the rest of the "
            f"suggested set it is {value_error(f.estimate(i), f.stderr(i), c.slot.kind.unit)}"
        )


def _span(head: list[str], rows: list[list[str]]) -> int:
    """Columns taken by the first ``len(head)`` columns of a table."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(head)]
    return sum(widths) + 2 * (len(widths) - 1)


def _print_fit(f: Any, d: Any = None) -> None:
    """The fitted parameters of a set, and under each suggested effect that the data cannot
    tell apart from another the look-alike's value in the set refitted with it instead."""
    from eodarm.viz.format import value_error

    rows = []
    for i, s in enumerate(f.slots):
        note = "  (at its bound)" if f.at_bound[i] else ""
        rows.append((_candidate(s), value_error(f.estimate(i), f.stderr(i), s.kind.unit) + note))
        for alt in (d.alternatives.get(s.spec) or []) if d is not None else []:
            g = d.alternative_fits.get((s.spec, alt))
            if g is None:
                continue
            j = [t.spec for t in g.slots].index(alt)
            est = value_error(g.estimate(j), g.stderr(j), g.slots[j].kind.unit)
            rows.append(("  or " + _candidate(g.slots[j]), f"{est}  (as well)"))
    w = max(len(r[0]) for r in rows)
    for name, est in rows:
        _say(f"{name.ljust(w)}  {est}", "    ")
    _say(f"χ²/dof {f.chi2_per_dof:.4g}; RMS {_rms_line(f.rms())}", "    ")


def _print_unexplained(d: Any) -> None:
    """The verdict 'unexplained' in words, the best effort, and the pattern that is left."""
    from eodarm.analysis.residuals import residual_pattern

    print("verdict: UNEXPLAINED — what is missing is not in the catalogue")
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
                "held-out RMS (leave one configuration out): " + _rms_line(d.best_effort_cv["rms"]),
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
