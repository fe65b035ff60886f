"""``eodarm plan``: where to measure so that the missing effect can be named (docs/plan.md)."""

from __future__ import annotations

import argparse
import json
import math
from typing import TYPE_CHECKING, Any

from eodarm.analysis.plan.planner import DEFAULT_POOL
from eodarm.cli._common import (
    ARM_HELP,
    _arm_argv,
    _effects_args,
    _floats,
    _load_arm,
    _next,
    _note,
    _payload_hint,
    _print_table,
    _read,
    _say,
    _stages,
)
from eodarm.cli._help import HELP
from eodarm.cli._outputs import _claim, _force_arg, _free_name
from eodarm.errors import EodarmError

if TYPE_CHECKING:
    from eodarm.analysis.plan import Plan


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register ``eodarm plan`` on the sub-parser collection."""
    p: argparse.ArgumentParser = sub.add_parser(
        "plan",
        help=HELP["plan"],
        description="Choose K configurations the arm can reach that tell every pair of "
        "candidate effects apart (the weakest separation as large as it gets) while every "
        "candidate's parameter is determined; compare them with random configurations and "
        "write the measurement file (or the campaign) to fill in. docs/plan.md.",
    )
    p.add_argument("--arm", metavar="ARM.toml", help=ARM_HELP)
    p.add_argument("--configs", type=int, required=True, metavar="K", help="configurations to plan")
    loads = p.add_mutually_exclusive_group()
    loads.add_argument(
        "--sequence",
        metavar="M0,M1,...",
        help="the load cycle of every configuration, a leading 0 the zeroed reference "
        "(default 0,1.5,5,6.5,5,1.5,0)",
    )
    loads.add_argument(
        "--masses", metavar="M1,M2,...", help="single loadings instead of a load cycle (kg)"
    )
    p.add_argument(
        "--channels",
        metavar="LIST",
        help="channels to measure: names or families dx_mm,dy_mm,dalpha,dl, or 'all' "
        "(default all; with --fixed, those measured in it)",
    )
    p.add_argument(
        "--sigma",
        action="append",
        metavar="CHANNEL=VALUE",
        help="noise of a channel or family, mm or deg (repeatable; default the default "
        "levels, docs/diagnosis.md, or with --fixed its noise)",
    )
    p.add_argument(
        "--candidates",
        action="append",
        metavar="EFFECT@PLACE[=VALUE],...",
        help="the candidates to tell apart, each at a size in its parameter's unit (default "
        "every candidate diagnose ranks, at typical sizes of this arm, docs/plan.md)",
    )
    _effects_args(p)
    p.add_argument(
        "--range",
        action="append",
        metavar="alphaI=LO:HI",
        help="the range of link I's angle, degrees (repeatable; default 40:130 for link 1, "
        "-40:60 for link 2, -30:30 beyond)",
    )
    p.add_argument(
        "--fixed",
        metavar="MEAS.csv",
        help="configurations already measured (a measurement file or a campaign): they "
        "count in, K more are added",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed of the pool (default 0)")
    p.add_argument(
        "--pool",
        type=int,
        default=DEFAULT_POOL,
        metavar="N",
        help=f"reachable configurations drawn to choose from (default {DEFAULT_POOL})",
    )
    p.add_argument(
        "-o",
        "--output",
        metavar="PLAN.csv|CAMPAIGN.toml",
        help="write the measurement file to fill (.csv) or a campaign of raw records (.toml)",
    )
    _force_arg(p, "an existing -o file")
    p.add_argument("--plot", metavar="DIR", help="write the figure plan.png into DIR")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--no-self-weight", action="store_true", help="the arm carries no self-weight")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``eodarm plan``: print the plan, write the file; exit status 0."""
    from eodarm.analysis.plan import DEFAULT_CYCLE, parse_candidates, plan

    arm = _load_arm(args.arm)
    if args.configs < 1:
        raise EodarmError(f"--configs {args.configs}: plan at least one configuration")
    _check_output(args)
    sequence = args.masses is None
    masses = (
        _floats(args.masses, "--masses")
        if args.masses is not None
        else (_floats(args.sequence, "--sequence") if args.sequence else list(DEFAULT_CYCLE))
    )
    sw = not args.no_self_weight
    # --sequence 0,1500,5000: is it grams? (a note, and first in a refusal of the plan)
    hinted = _payload_hint(arm, masses, "--sequence" if sequence else "--masses")
    fixed = _read(args.fixed, arm, sw) if args.fixed else None
    cands = parse_candidates(args.candidates, arm) if args.candidates else None
    with (
        hinted,
        _stages(
            ["pool", "sizes", "signatures", "choosing", "refits", "inseparable", "writing"], "plan"
        ) as step,
    ):
        result = plan(
            arm,
            args.configs,
            masses,
            sequence=sequence,
            channels=args.channels,
            sigma=_sigmas(args.sigma),
            candidates=cands,
            ranges=_ranges(args.range),
            fixed=fixed,
            seed=args.seed,
            pool=args.pool,
            self_weight=sw,
            progress=step,
        )
        step("writing")
        if args.output:
            _write(args.output, result)
        if args.plot:
            _plot(args.plot, result)
    if args.json:
        print(json.dumps(result.to_json(), allow_nan=False))
    else:
        _print_plan(result, args)
    _say_next(args)
    return 0


# ---------------------------------------------------------------------------- arguments
def _sigmas(specs: list[str] | None) -> dict[str, float]:
    out: dict[str, float] = {}
    for spec in specs or []:
        key, sep, value = spec.partition("=")
        try:
            out[key.strip()] = float(value)
        except ValueError:
            raise EodarmError(
                f"--sigma '{spec}': expected CHANNEL=VALUE, e.g. dy_mm=0.01"
            ) from None
        if not sep:
            raise EodarmError(f"--sigma '{spec}': expected CHANNEL=VALUE, e.g. dy_mm=0.01")
    return out


def _ranges(specs: list[str] | None) -> dict[int, tuple[float, float]]:
    """``alphaI=LO:HI`` → {I: (LO, HI)}."""
    out: dict[int, tuple[float, float]] = {}
    for spec in specs or []:
        name, sep, rng = spec.partition("=")
        lo, colon, hi = rng.partition(":")
        name = name.strip()
        if not (sep and colon and name.startswith("alpha") and name[5:].isdigit()):
            raise EodarmError(f"--range '{spec}': expected alphaI=LO:HI, e.g. alpha1=60:120")
        try:
            a, b = float(lo), float(hi)
        except ValueError:
            raise EodarmError(f"--range '{spec}': LO and HI must be numbers (degrees)") from None
        if not (math.isfinite(a) and math.isfinite(b) and a < b):
            raise EodarmError(f"--range '{spec}': need finite LO < HI (degrees)")
        out[int(name[5:])] = (a, b)
    return out


def _check_output(args: argparse.Namespace) -> None:
    """``-o`` is a .csv or a .toml, never an input (the arm, the fixed campaign, an effects
    file), and an existing file only with ``--force`` (``_claim``)."""
    out = args.output
    if not out:
        return
    low = out.lower()
    if not (low.endswith(".csv") or low.endswith(".toml")):
        raise EodarmError(
            f"-o {out}: write a measurement file (.csv) or a campaign of records (.toml)"
        )
    if low.endswith(".toml") and args.masses is not None:
        raise EodarmError(
            f"-o {out}: a campaign records each configuration as one load cycle; plan with "
            "--sequence (or write a .csv of single loadings)"
        )
    _claim(args, out, "-o")


# ---------------------------------------------------------------------------- outputs
def _write(out: str, result: Plan) -> None:
    from eodarm.data.plan_files import write_plan_campaign, write_plan_csv

    pl = result.payloads
    if out.lower().endswith(".toml"):
        masses = [0.0, *pl.states.tolist()]
        write_plan_campaign(out, result.labels, result.configs, masses)
        _note(
            f"wrote {out}: {len(result.labels)} records to make ({', '.join(result.labels[:3])}"
            f"{' …' if len(result.labels) > 3 else ''}.csv beside it), each the load cycle "
            + " → ".join(f"{m:g}" for m in masses)
            + " kg"
        )
        return
    write_plan_csv(
        out, result.labels, result.configs, pl.states.tolist(), pl.sequence, result.channels
    )
    _note(
        f"wrote {out}: {len(result.labels)} configurations × {pl.states.size} states to "
        f"measure, columns {', '.join(result.channels)} empty: fill them in, then run the "
        "next command"
    )


def _plot(dirname: str, result: Plan) -> None:
    from pathlib import Path

    from eodarm.viz.plan_plot import plan_figure

    d = Path(dirname)
    d.mkdir(parents=True, exist_ok=True)
    path = d / "plan.png"
    plan_figure(result, path=path)
    _note(f"wrote {path}")


def _say_next(args: argparse.Namespace) -> None:
    """After the plan: the records of the campaign, the diagnosis of the filled file, or the
    same plan written to a file."""
    out = args.output
    if out and out.lower().endswith(".toml"):
        _next("records", out, "-o", _free_name("meas.csv"))
    elif out:
        _next("diagnose", out, *_arm_argv(args, always=True), args=args)
    else:
        _next(*_replay(args), "-o", _free_name("plan.csv"), args=args)


def _replay(args: argparse.Namespace) -> list[str]:
    """The plan's own command line, as far as it changes the plan."""
    out = ["plan", *_arm_argv(args), "--configs", str(args.configs)]
    if args.masses is not None:
        out += ["--masses", args.masses]
    elif args.sequence:
        out += ["--sequence", args.sequence]
    for flag, value in (("--channels", args.channels), ("--fixed", args.fixed)):
        if value:
            out += [flag, value]
    for flag, values in (
        ("--sigma", args.sigma),
        ("--candidates", args.candidates),
        ("--range", args.range),
    ):
        for v in values or []:
            out += [flag, v]
    if args.seed != 0:
        out += ["--seed", str(args.seed)]
    if args.pool != DEFAULT_POOL:
        out += ["--pool", str(args.pool)]
    return out


# ---------------------------------------------------------------------------- text
def _pct(x: float) -> str:
    if not math.isfinite(x):
        return "∞"
    return f"{100 * x:.2g} %" if x < 0.1 else f"{100 * x:.0f} %"


def _chi2(x: float) -> str:
    if not math.isfinite(x):
        return "∞"
    return f"{x:.3g}" if x < 1000 else f"{x:.0f}"


def _channel_words(result: Plan) -> str:
    from eodarm.viz.format import value

    parts = []
    for ch in result.channels:
        name = ch.removesuffix("_mm").removesuffix("_deg")
        unit = "deg" if ch.endswith("_deg") else "mm"
        parts.append(f"{name} (σ {value(result.sigma[ch], unit, digits=2)})")
    return ", ".join(parts)


def _print_plan(result: Plan, args: argparse.Namespace) -> None:
    from eodarm.viz.format import parameter_name, value

    pl = result.payloads
    arm = result.arm
    loads = (
        "the load cycle " + " → ".join(f"{m:g}" for m in pl.masses_kg) + " kg"
        if pl.sequence
        else "single loadings of " + ", ".join(f"{m:g}" for m in pl.masses_kg) + " kg"
    )
    k = len(result.labels)
    _say(f"plan for arm '{arm.name}': {k} configurations, each with {loads}")
    _say(f"channels {_channel_words(result)}")
    extra = f", added to the {result.fixed.shape[0]} of {args.fixed}" if args.fixed else ""
    _say(
        f"{len(result.candidates)} candidates; {k} configurations chosen among "
        f"{result.pool.shape[0]} reachable ones{extra}"
    )
    print()
    head = ["config", *(f"alpha{i + 1}" for i in range(arm.n))]
    rows = [
        [lb, *(f"{a:.1f}" for a in pose)]
        for lb, pose in zip(result.labels, result.configs, strict=True)
    ]
    print("configurations to measure (unloaded angles, deg):")
    _print_table(head, rows, left=(0,))
    print()
    print("candidates at their sizes (relative standard error of each, fitted alone):")
    crow = []
    for c, r in zip(result.candidates, result.rel_stderr, strict=True):
        taken = ", taken up" if c.slot.unloaded != "centred" else ""
        crow.append(
            [
                f"{parameter_name(c.slot.name, c.slot.at)}{taken} ({c.spec})",
                value(c.value, c.slot.kind.unit, digits=3) + ("" if c.given else " *"),
                _pct(float(r)),
            ]
        )
    _print_table(["candidate", "size", "rel. error"], crow, left=(0,))
    if any(not c.given for c in result.candidates):
        _say("* typical size for this arm (docs/plan.md)")
    if result.unseen:
        _say(
            "not seen on these channels at any reachable configuration (left out): "
            + ", ".join(c.spec for c in result.unseen)
        )
    print()
    names = [c.spec for c in result.candidates]
    sep_ok = result.separable
    pairs = [(a, b, s) for a, b, s in result.pairs() if sep_ok[a, b]]
    print("weakest separations (χ² left when one imitates the other; 25 or more tells them apart):")
    _print_table(
        ["pair", "χ²"],
        [[f"{names[a]} ~ {names[b]}", _chi2(s)] for a, b, s in pairs[:6]],
        left=(0,),
    )
    below = [p for p in pairs if p[2] < 25.0]
    if below:
        _say(f"{len(below)} pairs stay below 25 with {k} configurations: plan more of them")
    bad = [c.spec for c, r in zip(result.candidates, result.rel_stderr, strict=True) if r > 0.1]
    if bad:
        _say("not determined (relative standard error above 10 %): " + ", ".join(bad))
    if result.inseparable:
        print()
        _say(f"no reachable configuration separates these on {', '.join(result.channels)}:")
        for a, b, ch in result.inseparable:
            how = f"measure {ch}" if ch else "no channel of this arm separates them"
            _say(f"{names[a]} and {names[b]}: {how}", "  ")
    print()
    weak, worst = result.random_median
    _say(
        f"the plan against {k} configurations drawn at random from the reachable ones (median "
        f"of {result.random_weakest.size} draws): weakest separation {_chi2(result.weakest)} "
        f"against {_chi2(weak)}; largest relative standard error {_pct(result.max_rel_stderr)} "
        f"against {_pct(worst)}"
    )
    if result.before_separation is not None and result.before_rel_stderr is not None:
        before = result.before_separation[sep_ok]
        _say(
            f"the campaign so far ({args.fixed}) alone: weakest separation "
            f"{_chi2(float(before.min()) if before.size else math.inf)}; largest relative "
            f"standard error {_pct(float(result.before_rel_stderr.max()))}"
        )
