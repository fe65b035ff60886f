"""The ``eodarm`` command line.

Data goes to stdout, messages to stderr. Exit status: 0 on success, 2 on bad input (with a
one-line reason on stderr), 1 on an unexpected internal error.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from importlib import resources
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np

from . import __version__
from .arm import Arm
from .effects import CATALOGUE, Effect
from .errors import EodarmError
from .solver import solve

if TYPE_CHECKING:
    from .fit import FitResult, Slot
    from .measurements import Measurements

__all__ = ["main"]


def _bundled_arm() -> Arm:
    ref = resources.files("eodarm").joinpath("data/example_arm.toml")
    with resources.as_file(ref) as path:
        return Arm.from_toml(path)


def _load_arm(path: str | None) -> Arm:
    return _bundled_arm() if path is None else Arm.from_toml(path)


def _valued_effect(spec: str) -> Effect:
    """``effect@place=value`` → Effect."""
    head, sep, value = spec.partition("=")
    name = head.partition("@")[0]
    if not sep or name not in CATALOGUE:
        raise EodarmError(
            f"--add '{spec}': expected EFFECT@PLACE=VALUE, e.g. joint_clearance@O3=0.15"
        )
    try:
        x = float(value)
    except ValueError:
        raise EodarmError(f"--add '{spec}': '{value}' is not a number") from None
    return Effect.parse(head, **{CATALOGUE[name].param: x})


def _floats(text: str, what: str) -> list[float]:
    try:
        return [float(t) for t in text.replace(";", ",").split(",") if t.strip()]
    except ValueError:
        raise EodarmError(f"{what} '{text}': expected comma-separated numbers") from None


_SOLVE_KEYS = (
    "force_n",
    "reaction_n",
    "dforce_n",
    "dx_mm",
    "dy_mm",
    "dalpha_deg",
    "dl_mm",
    "dlength_mm",
    "length_mm",
)


def _model_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--model",
        choices=("analytic", "fem"),
        default="analytic",
        help="analytic (closed forms, exact pose; default) or fem (the frame finite-element "
        "model: linear, uses the links' ei_n_mm2/ea_n)",
    )
    p.add_argument(
        "--elements-per-link",
        type=int,
        metavar="N",
        help="with --model fem: beam elements per flexible link (default 8)",
    )


def _model_kw(args: argparse.Namespace) -> dict[str, Any]:
    """The model=/fem_options= keywords of the command's --model."""
    if args.model != "fem":
        if args.elements_per_link is not None:
            raise EodarmError("--elements-per-link needs --model fem")
        return {"model": "analytic", "fem_options": None}
    opts = {} if args.elements_per_link is None else {"elements_per_link": args.elements_per_link}
    return {"model": "fem", "fem_options": opts}


def _fem_plots(
    directory: str, arm: Arm, out: dict[str, Any], alpha: Any, mass: Any, model: str
) -> None:
    """The FE figures of the first pose (deformed shape, moments, pin forces) into DIR."""
    from pathlib import Path

    if model != "fem":
        raise EodarmError("solve --plot draws the finite-element model: add --model fem")
    from . import fem_plots

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    pose = ", ".join(f"{a:g}" for a in alpha[0])
    head = f"{arm.name}: α = {pose}°, {mass[0]:g} kg"
    paths = [d / f"fem-{k}.png" for k in ("deformed-shape", "moments", "pin-forces")]
    fem_plots.deformed_shape(arm, out, title=f"{head} (FE, {out['n_dof']} DOF)", path=paths[0])
    fem_plots.moment_diagrams(arm, out, title=f"{head}: bending moments (FE)", path=paths[1])
    fem_plots.pin_forces(
        arm, out, title=f"{head}: forces on the links at their pins", path=paths[2]
    )
    _note("wrote " + ", ".join(str(p) for p in paths))


def _cmd_solve(args: argparse.Namespace) -> int:
    arm = _load_arm(args.arm)
    alphas = [_floats(a, "--alpha") for a in (args.alpha or [])]
    if not alphas:
        alphas = [[90.0] + [10.0] * (arm.n - 2) + [0.0]] if arm.n >= 2 else [[60.0]]
    masses = _floats(args.mass, "--mass")
    effects = [_valued_effect(s) for s in args.add or []]
    rows = [(a, m) for a in alphas for m in masses]
    alpha = np.array([r[0] for r in rows], dtype=float)
    mass = np.array([r[1] for r in rows], dtype=float)
    out = solve(
        arm,
        alpha,
        mass,
        effects,
        backend=args.backend,
        self_weight=not args.no_self_weight,
        **_model_kw(args),
    )
    dofs = int(out["n_dof"]) if args.model == "fem" else 0
    if args.plot:
        _fem_plots(args.plot, arm, out, alpha, mass, args.model)
    if args.model == "fem":
        # The plotting extras (shape, moments) stay in the Python API; print the channels.
        out = {k: out[k] for k in (*_SOLVE_KEYS, "pin_force_n")}
    if args.json:
        doc = {
            "arm": arm.name,
            "model": [e.key for e in effects],
            "solver_model": args.model,
            "self_weight": not args.no_self_weight,
            "poses": [
                {
                    "alpha_deg": alpha[i].tolist(),
                    "mass_kg": float(mass[i]),
                    **{k: np.asarray(v[i]).tolist() for k, v in out.items()},
                }
                for i in range(len(rows))
            ],
        }
        json.dump(doc, sys.stdout, indent=None if args.compact else 1)
        sys.stdout.write("\n")
        return 0
    n = arm.n
    print(
        f"arm {arm.name!r} ({n} links), model: baseline"
        + "".join(f" + {e.name}@{e.at}" for e in effects)
        + ("" if not args.no_self_weight else ", self-weight off")
        + (f", finite-element model ({dofs} DOF)" if dofs else "")
    )
    head = ["alpha_deg", "mass_kg", "dx_mm", "dy_mm"]
    head += [f"F{i + 1}_N" for i in range(n)] + [f"da{i + 1}_deg" for i in range(n)]
    head += [f"dl{i + 1}_mm" for i in range(n)]
    print("  ".join(f"{h:>12}" for h in head))
    for i in range(len(rows)):
        cells = [
            "/".join(f"{a:g}" for a in alpha[i]),
            f"{mass[i]:g}",
            f"{out['dx_mm'][i]:.4f}",
            f"{out['dy_mm'][i]:.4f}",
        ]
        cells += [f"{f:.1f}" for f in out["force_n"][i]]
        cells += [f"{d:.5f}" for d in out["dalpha_deg"][i]]
        cells += [f"{d:.5f}" for d in out["dl_mm"][i]]
        print("  ".join(f"{c:>12}" for c in cells))
    return 0


# ----------------------------------------------------------------- compare / fit / diagnose
def _note(msg: str) -> None:
    print(f"eodarm: {msg}", file=sys.stderr)


def _read(path: str, arm: Arm) -> Measurements:
    from .measurements import read_measurements

    meas = read_measurements(path, arm.n)
    if meas.defaulted:
        from .measurements import default_sigma

        parts = ", ".join(f"{ch} {default_sigma(ch):g}" for ch in meas.defaulted)
        _note(f"no sigma given for {parts}: using the default noise levels (docs/diagnosis.md)")
    return meas


def _model(specs: list[str] | None, allow_values: bool) -> list[Effect | Slot]:
    """--add EFFECT@PLACE (fitted) or EFFECT@PLACE=VALUE (fixed / starting value)."""
    from .fit import Slot

    out: list[Effect | Slot] = []
    for spec in specs or []:
        if "=" in spec:
            if not allow_values:
                raise EodarmError(f"--add '{spec}': give EFFECT@PLACE only; it is fitted")
            out.append(_valued_effect(spec))
        else:
            out.append(Slot.parse(spec))
    return out


def _fmt(x: float, unit: str = "") -> str:
    if x is None or not np.isfinite(x):
        return "—"
    return f"{x:.4g}{unit}"


def _rms_line(rms: dict[str, float]) -> str:
    return "  ".join(f"{ch} {v:.4g}" for ch, v in rms.items())


def _by(result: FitResult, key: str) -> dict[str, dict[str, float]]:
    meas = result.problem.meas
    labels = meas.config if key == "config" else np.asarray(meas.mass_kg)
    out: dict[str, dict[str, float]] = {}
    for lab in dict.fromkeys(labels.tolist()):
        out[str(lab)] = result.rms(np.asarray(labels) == lab)
    return out


def _worst(result: FitResult, k: int = 8) -> list[dict[str, Any]]:
    from .fit import outlier_table

    z = np.abs(result.z)
    z[~result.problem.use] = np.nan
    flat = np.argsort(np.nan_to_num(z, nan=-1.0), axis=None)[::-1][:k]
    mask = np.zeros_like(result.problem.use)
    mask.flat[flat] = True
    mask &= np.isfinite(z)
    rows = outlier_table(result, mask)
    return sorted(rows, key=lambda r: -abs(r["z"]))


def _print_table(head: list[str], rows: list[list[str]]) -> None:
    widths = [
        max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(head)
    ]
    print("  ".join(h.rjust(w) for h, w in zip(head, widths, strict=True)))
    for r in rows:
        print("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)))


def _describe_data(meas: Measurements) -> str:
    masses = "/".join(f"{m:g}" for m in dict.fromkeys(np.asarray(meas.mass_kg).tolist()))
    return (
        f"{meas.n_rows} states, {len(meas.configs)} configurations, payloads {masses} kg, "
        f"{meas.n_values} values on {', '.join(meas.measured_channels)}"
    )


def _plots(
    dirname: str | None,
    meas: Measurements,
    before: FitResult,
    after: FitResult,
    effects: list[Effect],
    arm: Arm,
    self_weight: bool,
    steps: list[dict[str, Any]] | None = None,
    model_kw: dict[str, Any] | None = None,
) -> None:
    """The command's figures into ``dirname``; ``model_kw`` (``_model_kw``) is the model that
    solves where a figure solves (the deflection shares)."""
    if not dirname:
        return
    from pathlib import Path

    from . import plots

    out = Path(dirname)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    p = out / "measured_vs_model.png"
    plots.measured_vs_model(meas, {"before": before, "after": after}, path=p)
    written.append(p)
    p = out / "residual_vs_payload.png"
    plots.residual_vs_payload(meas, before, after, path=p)
    written.append(p)
    if effects:
        p = out / "deflection_share.png"
        plots.deflection_share(
            arm, meas, effects, self_weight=self_weight, path=p, **(model_kw or {})
        )
        written.append(p)
    if steps:
        p = out / "ladder.png"
        plots.ladder(steps, path=p)
        written.append(p)
    _note("wrote " + ", ".join(str(w) for w in written))


def _cmd_compare(args: argparse.Namespace) -> int:
    from .fit import FitWarning, outlier_table, robust_fit

    arm = _load_arm(args.arm)
    meas = _read(args.measurements, arm)
    sw = not args.no_self_weight
    model = _model(args.add, allow_values=True)
    fixed = [m for m in model if isinstance(m, Effect)]
    free = [m for m in model if not isinstance(m, Effect)]
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", FitWarning)
        from .fit import compare

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
    for w in caught:
        _note(str(w.message))
    base = compare(arm, meas, [], self_weight=sw, **mk)
    doc: dict[str, Any] = {
        "model": [m.key for m in model],
        "solver_model": args.model,
        "rms": res.rms(),
        "chi2_per_dof": res.chi2_per_dof,
        "by_config": _by(res, "config"),
        "by_payload": _by(res, "mass"),
        "worst": _worst(res),
        "outliers": outliers,
    }
    if res.slots:
        doc["estimate"] = res.summary()["effects"]
    if args.residuals:
        _write_residuals(args.residuals, res, flagged)
        _note(f"wrote every row's residuals to {args.residuals}")
    if args.json:
        print(json.dumps(doc))
    else:
        print(
            f"compare {meas.source} with arm '{arm.name}', model: baseline"
            + "".join(f" + {m.key}" for m in model)
        )
        print(_describe_data(meas))
        print(
            f"chi2/dof = {res.chi2_per_dof:.4g}  ({res.problem.n_values} values, "
            f"{res.n_params} fitted parameters)"
        )
        print(f"RMS       {_rms_line(res.rms())}")
        chans = list(res.rms())
        for key, title in (("by_config", "configuration"), ("by_payload", "payload kg")):
            print(f"\nRMS by {title}:")
            _print_table(
                [title, *chans],
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
        if outliers:
            print(
                "\noutliers (> 4σ after the fit, left out of it): "
                + "; ".join(f"line {r['line']} {r['channel']} z={r['z']:+.1f}" for r in outliers)
            )
    _plots(args.plot, meas, base, res, fixed + list(res.effects), arm, sw, None, _model_kw(args))
    return 0


def _write_residuals(path: str, res: FitResult, flagged: Any) -> None:
    """Every state's measured value, model value, residual and z for each measured channel."""
    import csv

    meas = res.problem.meas
    chans = list(meas.measured_channels)
    cols = [meas.channels.index(ch) for ch in chans]
    with open(path, "w", newline="", encoding="utf-8") as fh:
        wr = csv.writer(fh)
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


def _cmd_fit(args: argparse.Namespace) -> int:
    import warnings

    from .fit import FitWarning, compare, cross_validate, outlier_table, robust_fit

    arm = _load_arm(args.arm)
    meas = _read(args.measurements, arm)
    sw = not args.no_self_weight
    model = _model(args.add, allow_values=True)
    if not model:
        raise EodarmError("fit needs at least one --add EFFECT@PLACE")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", FitWarning)
        mk = _model_kw(args)
        res, flagged = robust_fit(arm, meas, model, self_weight=sw, **mk)
        outliers = outlier_table(res, flagged)
        cv = cross_validate(arm, meas, res.slots, self_weight=sw, **mk) if args.cv else None
        cv0 = cross_validate(arm, meas, [], self_weight=sw, **mk) if args.cv else None
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
    if args.json:
        print(json.dumps(doc))
    else:
        print(f"fit {meas.source} with arm '{arm.name}'")
        print(_describe_data(meas))
        rows = []
        for i, s in enumerate(res.slots):
            flag = "  (at bound)" if res.at_bound[i] else ""
            rows.append([s.key, s.kind.param, _fmt(res.estimate(i)), _fmt(res.stderr(i)) + flag])
        _print_table(["effect", "parameter", "estimate", "stderr"], rows)
        print(f"\nbefore  chi2/dof {before.chi2_per_dof:10.4g}   RMS {_rms_line(before.rms())}")
        print(f"after   chi2/dof {res.chi2_per_dof:10.4g}   RMS {_rms_line(res.rms())}")
        if cv is not None and cv0 is not None:
            print(f"CV (leave one configuration out)  baseline RMS {_rms_line(cv0['rms'])}")
            print(f"CV (leave one configuration out)  fitted   RMS {_rms_line(cv['rms'])}")
        if outliers:
            print(
                "outliers (> 4σ, left out of the fit): "
                + "; ".join(f"line {r['line']} {r['channel']} z={r['z']:+.1f}" for r in outliers)
            )
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
    return 0


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from .diagnose import diagnose

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
        print(json.dumps(d.to_json()))
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
            f" — suggested: {' + '.join(s.key for s in d.suggested) or '(none)'}"
            f"  ({d.sets_searched} candidate sets searched)"
        )
    if d.suggested_fit is not None:
        f = d.suggested_fit
        for i, s in enumerate(f.slots):
            print(f"    {s.key:28s} {s.kind.param} = {_fmt(f.estimate(i))} ± {_fmt(f.stderr(i))}")
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
                c.slot.key,
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


def _cmd_report(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .report import write_report
    from .workflow import investigate

    mk = _model_kw(args)
    if args.measurements is None:
        from . import datasets

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
        arm = _load_arm(args.arm)
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


def _cmd_datasets(args: argparse.Namespace) -> int:
    from . import datasets

    if args.action == "list":
        for name in datasets.names():
            ds = datasets.load(name)
            print(f"{name}\t{ds.description}")
        return 0
    if args.action == "export":
        if not args.name or not args.directory:
            raise EodarmError("usage: eodarm datasets export NAME DIR")
        written = datasets.export(args.name, args.directory)
        for p in written:
            print(p)
        _note(f"wrote {len(written)} files of '{args.name}' to {args.directory}")
        return 0
    raise EodarmError(f"unknown datasets action '{args.action}'")


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line on stderr, exit status 2, like every other bad input."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="eodarm",
        description="Why does the arm not go where its model says? Solve, compare and diagnose "
        "the statics, compliance and backlash of planar arms driven by linear actuators.",
    )
    p.add_argument("--version", action="version", version=f"eodarm {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    s = sub.add_parser(
        "solve",
        help="loaded minus unloaded pose, actuator forces and deflections for given poses",
        description="Solve the arm model for poses × payloads and print deflections and forces.",
    )
    s.add_argument("--arm", metavar="ARM.toml", help="arm file (default: the bundled example)")
    s.add_argument(
        "--alpha",
        action="append",
        metavar="A1,A2,...",
        help="unloaded absolute link angles in degrees (repeat for more poses)",
    )
    s.add_argument(
        "--mass",
        default="1.5,5,6.5",
        metavar="M1,M2,...",
        help="payload masses in kg (default: 1.5,5,6.5, the seed's)",
    )
    s.add_argument(
        "--add",
        action="append",
        metavar="EFFECT@PLACE=VALUE",
        help="add an effect with its parameter, e.g. joint_clearance@O3=0.15",
    )
    s.add_argument("--backend", choices=("rust", "numpy"), default="rust")
    _model_args(s)
    s.add_argument(
        "--plot",
        metavar="DIR",
        help="with --model fem: write the first pose's deformed shape, bending moments and "
        "pin forces as PNG figures into DIR",
    )
    s.add_argument("--no-self-weight", action="store_true", help="drop link/actuator weights")
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    s.add_argument("--compact", action="store_true", help="with --json: no indentation")
    s.set_defaults(func=_cmd_solve)

    def data_cmd(name: str, helptext: str, desc: str) -> argparse.ArgumentParser:
        c = sub.add_parser(name, help=helptext, description=desc)
        c.add_argument("measurements", metavar="MEAS.csv", help="measurement file (CONTRACT §3)")
        c.add_argument("--arm", metavar="ARM.toml", help="arm file (default: the bundled example)")
        c.add_argument("--json", action="store_true", help="print one JSON object on stdout")
        c.add_argument("--plot", metavar="DIR", help="write PNG figures into DIR")
        c.add_argument(
            "--no-self-weight",
            action="store_true",
            help="the measured arm carried no self-weight in the model",
        )
        _model_args(c)
        return c

    c = data_cmd(
        "compare",
        "model vs measurements: residuals, RMS, chi2, worst rows, outliers",
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
    c.set_defaults(func=_cmd_compare)
    c = data_cmd(
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
    c.set_defaults(func=_cmd_diagnose)
    c = data_cmd(
        "fit",
        "fit the parameters of the added effects",
        "Least-squares fit of the --add effects' parameters, with bounds.",
    )
    c.add_argument(
        "--add",
        action="append",
        metavar="EFFECT@PLACE[=START]",
        help="an effect to fit (repeat); =START gives a starting value",
    )
    c.add_argument("--cv", choices=("config",), help="leave-one-configuration-out cross-validation")
    c.set_defaults(func=_cmd_fit)
    from .sweep import add_parser as add_sweep
    from .synth import add_parser as add_synth

    add_synth(sub)
    add_sweep(sub)
    r = sub.add_parser(
        "report",
        help="the whole story as one HTML report (default: the bundled seed data)",
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
    r.set_defaults(func=_cmd_report)
    ds = sub.add_parser(
        "datasets",
        help="bundled data sets: list, export",
        description="List the bundled data sets, or export one (arm files, measurements, "
        "the paper's tables and the provenance notes) into a directory.",
    )
    ds.add_argument("action", choices=("list", "export"))
    ds.add_argument("name", nargs="?", help="data set name, e.g. seed2022")
    ds.add_argument("directory", nargs="?", metavar="DIR", help="where to write (export)")
    ds.set_defaults(func=_cmd_datasets)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``eodarm`` command; returns the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    try:
        return int(args.func(args))
    except (EodarmError, ValueError) as exc:  # ValueError: e.g. eodarm._core.CoreError
        print(f"eodarm: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `eodarm diagnose ... | head`
        sys.stderr.close()
        return 0
    except OSError as exc:
        print(f"eodarm: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
