"""``eodarm compare``: the model against the measurements, where it misses."""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING, Any

import numpy as np

from eodarm.cli._help import HELP
from eodarm.model.effects import Effect

if TYPE_CHECKING:
    from eodarm.analysis.fit import FitResult
from eodarm.cli._common import (
    _arm_argv,
    _channel,
    _check_data,
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
from eodarm.cli._outputs import _claim, _force_arg


def _by(result: FitResult, key: str) -> dict[str, dict[str, float]]:
    """RMS per channel of each configuration (or payload), in the file's order: one pass over
    the cells (a mask per label would cost labels × rows)."""
    meas = result.problem.meas
    labels = np.asarray(meas.config if key == "config" else meas.mass_kg)
    first, group = np.unique(labels, return_index=True, return_inverse=True)[1:]
    order = np.argsort(first, kind="stable")  # the labels in the order the file gives them
    use = result.problem.use
    sq = np.where(use, result.residual, 0.0) ** 2
    k = len(first)
    out: dict[str, dict[str, float]] = {str(labels[first[g]]): {} for g in order}
    for c, ch in enumerate(meas.channels):
        n = np.bincount(group, weights=use[:, c], minlength=k)
        total = np.bincount(group, weights=sq[:, c], minlength=k)
        for g in order:
            if n[g] > 0:
                out[str(labels[first[g]])][ch] = float(np.sqrt(total[g] / n[g]))
    return out


def _worst(result: FitResult, k: int = 8) -> list[dict[str, Any]]:
    from eodarm.analysis.outliers import outlier_table

    z = np.abs(result.z)
    z[~result.problem.use] = np.nan
    flat = np.argsort(np.nan_to_num(z, nan=-1.0), axis=None)[::-1][:k]
    mask = np.zeros_like(result.problem.use)
    mask.flat[flat] = True
    mask &= np.isfinite(z)
    rows = outlier_table(result, mask)
    return sorted(rows, key=lambda r: -abs(r["z"]))


def run(args: argparse.Namespace) -> int:
    from eodarm.analysis.fit import FitWarning
    from eodarm.analysis.outliers import outlier_table, robust_fit
    from eodarm.analysis.sequences import hysteresis

    if args.residuals:
        _claim(args, args.residuals, "--residuals")
    arm = _load_arm(args.arm, args.measurements)
    check_kinds_of(arm, args.add, "--add")
    sw = not args.no_self_weight
    model = _model(args.add, allow_values=True)
    fixed = [m for m in model if isinstance(m, Effect)]
    free = [m for m in model if not isinstance(m, Effect)]
    import warnings

    names = ["reading", "comparing", "tables"]
    with _stages(names, "compare") as step:
        step("reading")  # a file of 10⁵ rows takes seconds to read and check
        meas = _read(args.measurements, arm, sw)
        checks = _check_data(meas, arm, sw, _model_kw(args))
        step("comparing")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", FitWarning)
            from eodarm.analysis.fit import compare

            mk = _model_kw(args)
            if free:
                res, flagged = robust_fit(arm, meas, [*fixed, *free], self_weight=sw, **mk)
            else:
                res = compare(arm, meas, fixed, self_weight=sw, **mk)
                # with nothing to fit, flag cells only if they are few and the rest agree
                _, flagged = (
                    robust_fit(arm, meas, [], self_weight=sw, **mk)
                    if not fixed
                    else (res, np.zeros(meas.values.shape, dtype=bool))
                )
            outliers = outlier_table(res, flagged)
        step("tables")
        base = compare(arm, meas, [], self_weight=sw, **mk)
        doc: dict[str, Any] = {
            "model": _model_keys(arm, model),
            "solver_model": args.model,
            "rms": res.rms(),
            "chi2_per_dof": res.chi2_per_dof,
            "by_config": _by(res, "config"),
            "by_payload": _by(res, "mass"),
            "worst": _worst(res),
            "outliers": outliers,
            "noise": _noise_json(meas),
            "data_checks": [c.to_json() for c in checks],
        }
    for w in caught:
        _note(str(w.message))
    if res.slots:
        doc["estimate"] = res.summary()["effects"]
    loops = hysteresis(meas, res.prediction)
    if loops:
        doc["hysteresis"] = [_loop_json(h) for h in loops]
    if args.residuals:
        _write_residuals(args.residuals, res, flagged)
        _note(f"wrote every row's residuals to {args.residuals}")
    if args.json:
        print(json.dumps(doc, allow_nan=False))
    else:
        _print_compare(doc, res, meas, arm, model, outliers)
    _plots(args.plot, meas, base, res, fixed + list(res.effects), arm, sw, None, _model_kw(args))
    _next("diagnose", args.measurements, *_arm_argv(args), *_adds(model), args=args)
    return 0


def _adds(model: list[Any]) -> list[str]:
    """The fitted (``--add EFFECT@PLACE``) part of compare's model, for diagnose."""
    return [a for m in model if not isinstance(m, Effect) for a in ("--add", m.spec)]


def _print_compare(
    doc: dict[str, Any],
    res: FitResult,
    meas: Any,
    arm: Any,
    model: list[Any],
    outliers: list[dict[str, Any]],
) -> None:
    from eodarm.analysis.consistency import fit_p_value
    from eodarm.viz.format import p_value

    _say(f"compare {meas.source} with arm '{arm.name}', model: {_model_words(arm, model)}")
    _say(_describe_data(meas))
    fitted = f", {res.n_params} fitted parameters" if res.n_params else ""
    _say(
        f"χ²/dof {res.chi2_per_dof:.4g} ({p_value(fit_p_value(res))}; "
        f"{res.problem.n_values} values{fitted})"
    )
    _say(f"RMS {_rms_line(res.rms())}")
    chans = list(res.rms())
    heads = [" ".join(_channel(ch)) for ch in chans]
    for key, title in (("by_config", "configuration"), ("by_payload", "payload kg")):
        print(f"\nRMS by {title}:")
        _print_table(
            [title, *heads],
            [[lab, *(_fmt(v.get(c, np.nan)) for c in chans)] for lab, v in doc[key].items()],
        )
    print("\nworst cells (measured − model, in σ):")
    _print_table(
        ["line", "config", "kg", "channel", "measured", "model", "z"],
        [
            [
                str(r["line"]),
                r["config"],
                f"{r['mass_kg']:g}",
                r["channel"],
                _fmt(r["measured"]),
                _fmt(r["model"]),
                f"{r['z']:+.1f}",
            ]
            for r in doc["worst"]
        ],
    )
    for h in doc.get("hysteresis", []):
        _print_loop(h)
    if outliers:
        print()
        _say(
            "outliers (> 4σ after the fit, left out of it): "
            + "; ".join(f"line {r['line']} {r['channel']} z={r['z']:+.1f}" for r in outliers)
        )


def _loop_json(h: dict[str, Any]) -> dict[str, Any]:
    """One sequence's hysteresis as JSON: per state step, payload, branch, and per channel
    the measured and model values; what is left at the return to zero payload."""

    def col(a: Any, j: int) -> list[float | None]:
        return [float(x) if np.isfinite(x) else None for x in np.asarray(a)[:, j]]

    chans = list(h["channels"])
    return {
        "config": h["config"],
        "step": h["step"],
        "mass_kg": h["mass_kg"],
        "branch": h["branch"],
        "measured": {ch: col(h["measured"], j) for j, ch in enumerate(chans)},
        "model": {ch: col(h["model"], j) for j, ch in enumerate(chans)},
        "left_at_return": None
        if h["left"] is None
        else {
            ch: {"measured": (m if np.isfinite(m) else None), "model": mo}
            for ch, (m, mo) in h["left"].items()
        },
    }


def _print_loop(h: dict[str, Any]) -> None:
    """One sequence: every channel against payload on the loading and unloading branch,
    measured and model (three channels per table, within 100 columns), and what is left at
    the return to zero."""
    chans = list(h["measured"])
    print(f"\nload sequence {h['config']} (hysteresis; measured / model):")
    for start in range(0, len(chans), 3):
        group = chans[start : start + 3]
        head = ["step", "kg", "branch"]
        for ch in group:
            head += [f"{ch}", "model"]
        rows = []
        for s, (step, kg, br) in enumerate(zip(h["step"], h["mass_kg"], h["branch"], strict=True)):
            row = [str(step), f"{kg:g}", br]
            for ch in group:
                m, mo = h["measured"][ch][s], h["model"][ch][s]
                row += [_reading(np.nan if m is None else m, ch), _reading(mo, ch)]
            rows.append(row)
        _print_table(head, rows, left=(2,))
    left = h["left_at_return"]
    if left is None:
        _say("the sequence does not return to zero payload", "  ")
    else:
        _say(
            "left at the return to zero: "
            + "; ".join(
                f"{_channel(ch)[0]} "
                f"{_reading(np.nan if v['measured'] is None else v['measured'], ch, True)} "
                f"measured, {_reading(v['model'], ch, True)} model"
                for ch, v in left.items()
            ),
            "  ",
        )


def _reading(x: float, channel: str, unit: bool = False) -> str:
    """A channel's value, four digits, a practical zero as ``0`` (a model without memory
    comes back to 1e-10 mm: rounding); with ``unit``, its unit once."""
    from eodarm.viz.format import channel_value

    u = _channel(channel)[1]
    text = channel_value(x, u, 4)
    return text if unit else text.removesuffix(f" {u}")


def _write_residuals(path: str, res: FitResult, flagged: Any) -> None:
    """Every state's measured value, model value, residual and z for each measured channel."""
    import csv

    meas = res.problem.meas
    chans = list(meas.measured_channels)
    cols = [meas.channels.index(ch) for ch in chans]
    from eodarm.atomic import atomic_write

    with atomic_write(path, newline="") as fh:  # whole or not at all
        wr = csv.writer(fh, lineterminator="\n")  # LF, as every file eodarm writes
        head = ["line", "config", "mass_kg"]
        for ch in chans:
            head += [ch, f"model_{ch}", f"residual_{ch}", f"z_{ch}", f"outlier_{ch}"]
        wr.writerow(head)
        z = res.z
        for r in range(meas.n_rows):
            row: list[Any] = [int(meas.line[r]), str(meas.config[r]), float(meas.mass_kg[r])]
            for c in cols:
                v = meas.values[r, c]
                if np.isfinite(v):
                    row += [
                        repr(float(v)),
                        repr(float(res.prediction[r, c])),
                        repr(float(v - res.prediction[r, c])),
                        f"{z[r, c]:.4g}",
                        int(bool(flagged[r, c])),
                    ]
                else:
                    row += ["", repr(float(res.prediction[r, c])), "", "", ""]
            wr.writerow(row)


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register ``eodarm compare`` on the sub-parser collection."""
    c = data_command(
        sub,
        "compare",
        HELP["compare"],
        "Compare the model (baseline, plus --add effects) with the measurements.",
    )
    c.add_argument(
        "--add",
        action="append",
        metavar="EFFECT@PLACE[=VALUE]",
        help="an effect in the model: fixed at VALUE, or fitted without one",
    )
    c.add_argument(
        "--residuals",
        metavar="FILE.csv",
        help="write every row's measured, model, residual and z for each channel",
    )
    _force_arg(c, "an existing --residuals file")
    c.set_defaults(func=run)
    return c
