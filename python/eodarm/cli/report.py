"""``eodarm report``: the whole investigation as one HTML page."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from eodarm.cli._common import (
    _effects_args,
    _load_arm,
    _model,
    _model_args,
    _model_kw,
    _note,
    _read,
)
from eodarm.cli._help import HELP
from eodarm.model.effects import Effect


def run(args: argparse.Namespace) -> int:

    from eodarm.analysis.workflow import investigate
    from eodarm.viz.report import write_report

    mk = _model_kw(args)
    if args.measurements is None:
        from eodarm.data import datasets

        ds = datasets.load("seed2022")
        arm = _load_arm(args.arm) if args.arm else ds.arm
        meas = ds.measurements
        title = args.title or "eodarm: why the seed paper's arm sags more than its model says"
        intro = (
            "<p>The bundled data set <code>seed2022</code>: Table 1 geometry calibrated on "
            "Table 5, "
            "the measured angles, motor elongations and effector sag of Tables 3–4 "
            "(Ștefan et al., <i>Electronics</i> 2022, 11, 2355). The baseline is the paper's "
            "spring model: every actuator a 500 N/mm spring. Provenance and every "
            "interpretation: <code>eodarm datasets export seed2022 DIR</code> → NOTES.md; the "
            "reproduction of the paper's tables: docs/seed-reproduction.md.</p>"
        )
        _note("no measurements given: reporting on the bundled data set seed2022")
    else:
        arm = _load_arm(args.arm, args.measurements)
        meas = _read(args.measurements, arm)
        title = args.title
        intro = None
    sw = not args.no_self_weight
    model = [m for m in _model(args.add, allow_values=False) if not isinstance(m, Effect)]
    inv = investigate(
        arm,
        meas,
        model,
        self_weight=sw,
        max_rounds=args.rounds,
        solver_model=mk["model"],
        fem_options=mk["fem_options"],
    )
    last = inv.steps[-1]
    import html

    extra = [
        (
            "How the rounds ended",
            f"<p>{len(inv.rounds)} round(s) of diagnosis; stopped because "
            f"{html.escape(inv.stopped)}. The model reported above is the last step of the "
            "ladder.</p>",
        )
    ]
    out = Path(args.output)
    if out.parent and not out.parent.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
    write_report(
        out,
        arm,
        meas,
        inv.rounds[0],
        steps=inv.steps,
        cv=last.get("cv"),
        title=title,
        extra_sections=extra,
        final_fit=last["fit"] if len(inv.steps) > 1 else None,
        rounds=inv.rounds,
        intro_html=intro,
        **mk,
    )
    main = "dy_mm" if "dy_mm" in meas.measured_channels else meas.measured_channels[0]
    for s in inv.steps:
        cvr = s["cv_rms"] or {}
        print(
            f"{s['label']:60s}  chi2/dof {s['chi2_per_dof']:10.4g}  RMS {main} "
            f"{s['rms'].get(main, float('nan')):.4g}  CV {cvr.get(main, float('nan')):.4g}"
        )
    solver = "analytic" if mk["model"] == "analytic" else f"fem {mk['fem_options'] or {}}"
    _note(f"model: {solver}; stopped: {inv.stopped}")
    _note(f"wrote {out}")
    return 0


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register ``eodarm report`` on the sub-parser collection."""
    r = sub.add_parser(
        "report",
        help=HELP["report"],
        description="Compare, diagnose, add what is missing and diagnose again (a few "
        "rounds), then write one self-contained HTML report with the figures and the ladder "
        "of models. Without MEAS.csv, reports on the bundled seed2022 data set.",
    )
    r.add_argument(
        "measurements",
        metavar="MEAS.csv",
        nargs="?",
        help="measurement file (default: the bundled seed2022 data)",
    )
    r.add_argument("--arm", metavar="ARM.toml", help="arm file")
    r.add_argument(
        "--add",
        action="append",
        metavar="EFFECT@PLACE",
        help="an effect already in the model (its parameter is fitted)",
    )
    r.add_argument(
        "-o",
        "--output",
        default="eodarm-report.html",
        metavar="FILE.html",
        help="where to write the report (default: eodarm-report.html)",
    )
    r.add_argument("--rounds", type=int, default=3, help="at most this many rounds (default 3)")
    r.add_argument("--title", help="the report's title")
    r.add_argument("--no-self-weight", action="store_true")
    _model_args(r)
    _effects_args(r)
    r.set_defaults(func=run)
    return r
