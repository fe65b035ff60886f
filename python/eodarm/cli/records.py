"""``eodarm records``: the steady states of raw records, written as a measurement file."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from eodarm.cli._common import _next, _note, run_records
from eodarm.cli._help import HELP
from eodarm.cli._outputs import _claim, _force_arg
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register the ``records`` subcommand on an argparse ``add_subparsers()`` object."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        "records",
        help=HELP["records"],
        description="Find the steady states of every record of a campaign (every channel "
        "settled: no transient, no trend beyond its noise), match them in order to the "
        "record's masses_kg and write one row per state after the reference: its mean minus "
        "the reference's, with the standard error of that difference (noise correlated in "
        "time included). docs/records.md.",
    )
    p.add_argument("campaign", metavar="CAMPAIGN.toml", help="campaign file (docs/records.md)")
    p.add_argument(
        "--arm",
        metavar="ARM.toml",
        help="the arm the records were taken on: its links are checked against the "
        "campaign's alpha_deg, and the next: line (diagnose) carries it",
    )
    p.add_argument(
        "-o",
        "--output",
        metavar="MEAS.csv",
        help="the measurement file to write (default: stdout, unless --json)",
    )
    _force_arg(p, "an existing -o file")
    p.add_argument(
        "--plot",
        metavar="DIR",
        help="draw each record (channels, steady states, payloads, averaged samples) into DIR",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print, per record, the steady states (times, payload, means, standard errors, "
        "drift rates) as one JSON object on stdout",
    )
    p.add_argument(
        "--allow-drift",
        action="store_true",
        help="keep a state that drifts beyond its noise (marked in --json and the figures)",
    )
    p.add_argument(
        "--min-duration",
        type=float,
        default=2.0,
        metavar="S",
        help="shortest steady state, seconds (default 2)",
    )
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``eodarm records``; return the exit status 0 (bad input raises, exit 2)."""
    if args.output:  # never a record of the campaign, nor its file
        _claim(args, args.output, "-o")
    arm = Arm.from_toml(args.arm) if args.arm else None
    if arm is not None:  # before any record is read
        from eodarm.data.records import read_campaign

        n = read_campaign(args.campaign).n
        if n != arm.n:
            raise EodarmError(
                f"{args.campaign}: its records give {n} angles (alpha_deg), the arm "
                f"{args.arm} has {arm.n} links: records of another arm?"
            )
    results, write, _ = run_records(  # its payload hint (grams?) is a note
        args.campaign,
        allow_drift=args.allow_drift,
        plot_dir=args.plot,
        min_duration_s=args.min_duration,
        arm=arm,
    )
    rows = sum(len(r.rows) for r in results)
    if args.output:
        write(args.output)
        _note(f"wrote {rows} states of {len(results)} records to {args.output}")
    elif not args.json:
        write(sys.stdout)
        sys.stdout.flush()
    if args.json:
        doc = {"records": [r.to_json() for r in results], "output": args.output}
        print(json.dumps(doc, allow_nan=False))
    drifting = [
        f"{r.spec.config} step {row['step']}" for r in results for row in r.rows if row["drift"]
    ]
    if drifting:
        _note("kept with --allow-drift, drifting: " + ", ".join(drifting))
    if args.output and arm is not None:
        _next("diagnose", args.output, "--arm", args.arm, args=args)
    elif args.output:  # no next: line with a placeholder in it: say what the next one needs
        _note(
            f"to diagnose {args.output}, give the arm the records were taken on: with "
            "--arm ARM.toml here, the next: line is that command"
        )
    return 0
