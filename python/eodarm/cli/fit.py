"""``eodarm fit``: fit the parameters of the added effects."""

from __future__ import annotations

import argparse
import json
from typing import Any

from eodarm.cli._common import (
    _arm_argv,
    _check_data,
    _describe_data,
    _load_arm,
    _model,
    _model_kw,
    _model_words,
    _next,
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
from eodarm.cli._help import HELP
from eodarm.cli._outputs import _claim, _force_arg, _free_name
from eodarm.errors import EodarmError


def run(args: argparse.Namespace) -> int:
    import warnings

    from eodarm.analysis.crossval import cross_validate
    from eodarm.analysis.fit import FitWarning, compare, validity_mark
    from eodarm.analysis.outliers import outlier_table, robust_fit

    if args.output:
        _claim(args, args.output, "-o")
    arm = _load_arm(args.arm, args.measurements)
    check_kinds_of(arm, args.add, "--add")
    sw = not args.no_self_weight
    model = _model(args.add, allow_values=True)
    if not model:
        raise EodarmError("fit needs at least one --add EFFECT@PLACE")
    names = ["reading", "fitting", *(["cross-validation"] if args.cv else [])]
    with _stages(names, "fit") as step:
        step("reading")  # a file of 10⁵ rows takes seconds to read and check
        meas = _read(args.measurements, arm, not args.no_self_weight)
        checks = _check_data(meas, arm, sw, _model_kw(args))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", FitWarning)
            mk = _model_kw(args)
            step("fitting")
            res, flagged = robust_fit(arm, meas, model, self_weight=sw, **mk)
            outside = validity_mark(res)  # states outside the validity: kept, marked
            outliers = outlier_table(res, flagged)
            cv = cv0 = None
            if args.cv:
                step("cross-validation")
                cv = cross_validate(arm, meas, res.slots, self_weight=sw, **mk)
                cv0 = cross_validate(arm, meas, [], self_weight=sw, **mk)
    for w in {str(w.message) for w in caught}:
        _note(w)
    before = compare(arm, meas, [], self_weight=sw, **mk)
    summ = res.summary()
    doc: dict[str, Any] = {
        "effects": summ["effects"],
        "before": {"rms": before.rms(), "chi2_per_dof": before.chi2_per_dof},
        "after": {"rms": res.rms(), "chi2_per_dof": res.chi2_per_dof},
    }
    if cv is not None:
        doc["cv"] = {"rms": cv["rms"]}
    doc |= res.covariance_json()
    undetermined = res.undetermined()
    doc["undetermined"] = [
        {"parameter": f"{res.slots[i].key}:{res.slots[i].kind.param}", "why": why}
        for i, why in undetermined
    ]
    doc["data_checks"] = [c.to_json() for c in checks]
    if outside is not None:
        _note(outside.message)
        doc["outside_validity"] = outside.to_json()
    if args.output:
        # the fit settled, its inadequacy and the [fit] table: FitResult.to_arm, the same
        # arm a script gets (the outliers robust_fit left out stay out); data that look
        # mistaken are never "explained", whatever the χ²
        fitted = res.to_arm(data=args.measurements, trusted=not checks)
        doc["fitted_file"] = _write_fitted(fitted, res.problem.arm, args.output)
    if args.json:
        print(json.dumps(doc, allow_nan=False))
    else:
        _print_fit(res, meas, before, undetermined, cv, cv0, outliers)
    steps = None
    if cv is not None and cv0 is not None:
        steps = [
            {
                "label": "baseline",
                "rms": before.rms(),
                "cv_rms": cv0["rms"],
                "chi2_per_dof": before.chi2_per_dof,
            },
            {
                "label": " + ".join(s.key for s in res.slots),
                "rms": res.rms(),
                "cv_rms": cv["rms"],
                "chi2_per_dof": res.chi2_per_dof,
            },
        ]
    _plots(args.plot, meas, before, res, list(res.effects), arm, sw, steps, _model_kw(args))
    if args.output:
        _next("solve", "--arm", args.output, "--uncertainty", args=args)
    else:
        adds = [a for spec in args.add or [] for a in ("--add", spec)]
        _next(
            "fit",
            args.measurements,
            *_arm_argv(args),
            *adds,
            "-o",
            _free_name("fitted.toml"),
            args=args,
        )
    return 0


def _print_fit(
    res: Any,
    meas: Any,
    before: Any,
    undetermined: list[tuple[int, str]],
    cv: Any,
    cv0: Any,
    outliers: list[dict[str, Any]],
) -> None:
    """The parameter table (value ± error to the error's two digits, 95 % interval, a
    footnote mark on what the data do not determine), then χ² and RMS before and after."""
    from eodarm.analysis.fit import determining_channel
    from eodarm.viz.format import bounded_interval, parameter_name, value_error

    arm = res.problem.arm
    _say(f"fit {meas.source} with arm '{arm.name}', model: {_model_words(arm, res.slots)}")
    _say(_describe_data(meas))
    flags = dict(undetermined)
    rows = []
    for i, s in enumerate(res.slots):
        est, err, unit = res.estimate(i), res.stderr(i), s.kind.unit
        lo, hi = res.interval(i)
        mark = " (at its bound)" if res.at_bound[i] else (" *" if i in flags else "")
        rows.append(
            [
                f"{parameter_name(s.name, s.at)} ({s.spec})",
                value_error(est, err, unit) + mark,
                bounded_interval(lo, hi, unit, err, held=res.only_lower_limit(i))
                if not res.at_bound[i]
                else "—",
            ]
        )
    _print_table(["parameter", "estimate ± standard error", "95 % interval"], rows)
    if undetermined:
        print(
            "* not determined (relative standard error > 100 %, |correlation| > 0.95, "
            "or a lower limit):"
        )
    for i, why in undetermined:
        s = res.slots[i]
        _say(
            f"{s.spec} ({why}): fix or drop it (-o fixes a stiffness whose interval reaches "
            f"∞ as rigid), or "
            f"{determining_channel(s, meas.measured_channels, res.only_lower_limit(i))}",
            "  ",
        )
    print()
    _say(f"before: χ²/dof {before.chi2_per_dof:.4g}; RMS {_rms_line(before.rms())}")
    _say(f"after:  χ²/dof {res.chi2_per_dof:.4g}; RMS {_rms_line(res.rms())}")
    if cv is not None and cv0 is not None:
        _say(f"held-out (leave one configuration out), baseline: RMS {_rms_line(cv0['rms'])}")
        _say(f"held-out (leave one configuration out), fitted:   RMS {_rms_line(cv['rms'])}")
    if outliers:
        _say(
            "outliers (> 4σ, left out of the fit): "
            + "; ".join(f"line {r['line']} {r['channel']} z={r['z']:+.1f}" for r in outliers)
        )


def _write_fitted(fitted: Any, arm: Any, path: str) -> dict[str, Any]:
    """The fitted arm file, whole or not at all (eodarm.atomic). The input
    arm file's text (``arm.source``) is the template, so its comments and layout survive.
    Says in a line each what was fixed at a bound and when the model does not explain its
    data; returns that for the JSON output (``bounded``, ``explained``, ``sigma_model``)."""
    from pathlib import Path

    from eodarm.atomic import atomic_write
    from eodarm.model.uncertainty import inadequacy_note
    from eodarm.viz.format import value

    source = Path(arm.source)
    template = None
    if source.suffix == ".toml" and source.is_file():
        template = source.read_text(encoding="utf-8-sig")
    text = fitted.to_toml(template)
    out = Path(path)
    with atomic_write(out) as f:
        f.write(text)
    _note(f"wrote the fitted arm to {out}")
    bounded = []
    for e, mark in fitted.bounded():
        unit = e.kind.unit
        limit = float("nan") if mark.limit is None else mark.limit  # a bound carries its limit
        if mark.bound == "lower":
            what = f"stiffer than {value(limit, unit, 3)} (95 %): treated as rigid"
        else:
            what = f"at most {value(limit, unit, 3)} (95 %): treated as absent"
        _note(f"{e.key} not determined: {what} in {out}")
        bounded.append(
            {
                "effect": e.name,
                "at": e.at,
                "bound": mark.bound,
                "limit": {e.kind.param: mark.limit},
                "treated_as": "rigid" if mark.bound == "lower" else "absent",
            }
        )
    line = inadequacy_note(fitted)
    if line:
        _note(line)
    record = fitted.fit
    return {
        "path": str(out),
        "bounded": bounded,
        "explained": record.explained,
        "sigma_model": dict(record.sigma_model),
    }


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register ``eodarm fit`` on the sub-parser collection."""
    c = data_command(
        sub,
        "fit",
        HELP["fit"],
        "Least-squares fit of the --add effects' parameters, with bounds.",
    )
    c.add_argument(
        "--add",
        action="append",
        metavar="EFFECT@PLACE[=START]",
        help="an effect to fit (repeat); =START gives a starting value",
    )
    c.add_argument("--cv", choices=("config",), help="leave-one-configuration-out cross-validation")
    c.add_argument(
        "-o",
        "--output",
        metavar="FITTED.toml",
        help="write the arm with the fitted effects, their errors, covariance and the model's "
        "inadequacy (docs/model.md); the input arm file's comments are kept",
    )
    _force_arg(c, "an existing -o file")
    c.set_defaults(func=run)
    return c
