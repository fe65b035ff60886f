"""A diagnosis told as one self-contained HTML page, and the error ladder behind it.

:func:`write_report` writes a single ``.html`` file (figures embedded as base64 PNG, inline
CSS, no JavaScript, no external resource) that goes from the data to the conclusion:

1. the data: source, rows, configurations, payloads, measured channels, defaulted σ;
2. the baseline model against the measurements (RMS per channel, χ²/dof);
3. the diagnosis: verdict, suggested set, the sets the acceptance rule judged and why,
   ranking of every candidate, outliers, advice on the next measurement when candidates cannot
   be told apart (:mod:`eodarm.viz.report_diagnosis`);
4. the fitted suggested model (estimates ± standard errors, cross-validation), or the best
   effort when nothing explains the data;
5. the error ladder (:func:`build_ladder`), residuals against payload before/after, what no
   effect of the catalogue explains (when the verdict is ``unexplained``), and each effect's
   share of the sag.

Every number comes from one model, the one the diagnosis was made with: the analytic model, or
with ``diagnose(..., solver_model="fem")`` the finite-element model (``docs/fem.md``); the
report names it.

>>> from eodarm.diagnose import diagnose
>>> from eodarm.report import build_ladder, write_report
>>> d = diagnose(arm, meas)                                              # doctest: +SKIP
>>> write_report("report.html", arm, meas, d, steps=build_ladder(arm, meas, d))  # doctest: +SKIP
"""

from __future__ import annotations

import datetime as _dt
import math
import os
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from eodarm._version import __version__
from eodarm.analysis.diagnose import Diagnosis
from eodarm.analysis.fit import FitResult, FitWarning, cross_validate
from eodarm.analysis.ladder import build_ladder, check_same_model, model_name, solver_keywords
from eodarm.data.measurements import Measurements, default_sigma
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.viz import html as page
from eodarm.viz.report_diagnosis import (
    diagnosis_section,
    left_section,
    rounds_section,
    verdict_line,
)

__all__ = ["build_ladder", "write_report"]

PathLike = str | os.PathLike[str]


def _nice_scale(max_dalpha_deg: float, target_deg: float = 8.0) -> float:
    """A round exaggeration (1, 2 or 5 × 10^k) that turns the largest dα into about 8°."""
    if not (math.isfinite(max_dalpha_deg) and max_dalpha_deg > 0):
        return 50.0
    raw = target_deg / max_dalpha_deg
    k = math.floor(math.log10(raw))
    return max(m * 10.0**k for m in (1, 2, 5) if m * 10.0**k <= raw)


def _p_value(p: float) -> page.Num | str:
    return "< 1e-300" if p <= 0 else page.Num(p, 3)


def _unit(channel: str) -> str:
    from eodarm.viz.style import channel_unit

    return channel_unit(channel)


def _sigma_typ(meas: Measurements, channel: str) -> float:
    c = meas.index(channel)
    s = meas.sigma[meas.measured[:, c], c]
    return float(np.median(s)) if s.size else math.nan


def _ends_with(d: Diagnosis) -> FitResult | None:
    """The model a lone diagnosis ends with: the suggested set, or the best effort."""
    if d.suggested_fit is not None:
        return d.suggested_fit
    if d.verdict == "unexplained" and d.best_effort:
        return d.best_effort_fit
    return None


def _model_keys(fit_result: FitResult) -> str:
    keys = [s.key for s in fit_result.slots]
    return ", ".join(keys) if keys else "none"


# ---------------------------------------------------------------------------- the report
def write_report(
    path: PathLike,
    arm: Arm,
    meas: Measurements,
    diagnosis: Diagnosis,
    steps: Sequence[Mapping[str, Any]] | None = None,
    cv: Mapping[str, Any] | bool | None = None,
    title: str | None = None,
    extra_sections: Sequence[tuple[str, str]] | None = None,
    final_fit: FitResult | None = None,
    rounds: Sequence[Diagnosis] | None = None,
    intro_html: str | None = None,
    model: str | None = None,
    fem_options: Mapping[str, Any] | None = None,
) -> Path:
    """Write the diagnosis as one self-contained HTML file.

    Parameters
    ----------
    path : the ``.html`` file to write (its folder must exist).
    arm, meas : the arm and the measurements the diagnosis was made on.
    diagnosis : the result of :func:`eodarm.diagnose`.
    steps : the error ladder (:func:`build_ladder`); its figure and table are shown if given.
    cv : cross-validation of the suggested model: the dict returned by
        :func:`eodarm.cross_validate`, or ``True`` to compute it here (needs two or more
        configurations); ``None``/``False`` for none.
    title : the page title; default ``"eodarm diagnosis: <arm> / <source>"``.
    extra_sections : ``(heading, html)`` pairs appended at the end; the heading is escaped,
        the html is inserted as given.
    final_fit : the model the report ends with, when it is not the first diagnosis's
        suggested set (e.g. after several rounds, :func:`eodarm.analysis.workflow.investigate`); the
        fitted model, residual and share sections then show it, and ``cv`` belongs to it.
    rounds : every round of diagnosis (the first is ``diagnosis``), summarised in a table.
    intro_html : a paragraph shown under the title (inserted as given).
    model, fem_options : the model of every evaluation (``"analytic"`` or ``"fem"`` and its
        options, as in :func:`eodarm.fit`); default (``None``) the one the diagnosis was
        made with, and only that one is accepted (also for ``final_fit`` and the fits of
        ``steps``). The report names it.

    Returns
    -------
    Path
        The file written.
    """
    from eodarm.viz import plots

    kw = solver_keywords(diagnosis, model, fem_options)
    if final_fit is not None:
        check_same_model(final_fit, kw, "final_fit")
    for i, step in enumerate(steps or ()):
        if step.get("fit") is not None:
            check_same_model(step["fit"], kw, f"step {i} of the ladder")
    base = diagnosis.baseline
    best = final_fit if final_fit is not None else _ends_with(diagnosis)
    final = best if best is not None else base
    self_weight = base.problem.self_weight
    main = plots.main_channel(meas, base)
    unit = _unit(main)
    doc_title = title or f"eodarm diagnosis: {arm.name} / {meas.source}"
    if cv is True:
        cv = None
        if best is not None and len(meas.configs) >= 2:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", FitWarning)
                cv = cross_validate(arm, meas, best.slots, self_weight=self_weight, **kw)
    elif cv is False:
        cv = None

    parts: list[str] = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{page.esc(doc_title)}</title>",
        f"<style>{page.CSS}</style></head><body>",
        f"<h1>{page.esc(doc_title)}</h1>",
        verdict_line(diagnosis),
    ]
    if intro_html:
        parts.append(intro_html)
    parts += _data_section(arm, meas, self_weight, kw)
    parts += _baseline_section(meas, diagnosis, main, kw)
    parts += diagnosis_section(meas, diagnosis, main, unit)
    if rounds and len(rounds) > 1:
        parts += rounds_section(rounds, main)
    parts += _fitted_section(meas, diagnosis, cv, final_fit)
    if steps:
        parts += _ladder_section(steps, main, unit)
    parts += _residual_section(meas, base, final, main)
    last = rounds[-1] if rounds else diagnosis
    if last.verdict == "unexplained":
        what = "the model the report ends with" if final_fit is not None else "the best effort"
        if final is base:
            what = "the baseline"
        parts += left_section(meas, final, f"{what} ({_model_keys(final)})")
    parts += _share_section(arm, meas, final, self_weight, kw)
    for heading, body in extra_sections or ():
        parts += [f"<h2>{page.esc(heading)}</h2>", body]
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts += [
        f"<footer>eodarm {page.esc(__version__)} · {page.esc(model_name(**kw))} · {stamp} · every "
        "figure is embedded in this file"
        "</footer>",
        "</body></html>",
    ]
    out = Path(path)
    try:
        out.write_text("\n".join(parts) + "\n", encoding="utf-8")
    except OSError as exc:
        raise EodarmError(f"{out}: cannot write the report: {exc.strerror or exc}") from None
    return out


def _data_section(
    arm: Arm, meas: Measurements, self_weight: bool, kw: Mapping[str, Any]
) -> list[str]:
    masses = np.unique(meas.mass_kg)
    chans = meas.measured_channels
    counts = {ch: int(meas.measured[:, meas.index(ch)].sum()) for ch in chans}
    if meas.defaulted:
        sig = "default σ used for " + ", ".join(
            f"{ch} ({page.num(default_sigma(ch), 3)} {_unit(ch)})" for ch in meas.defaulted
        )
    else:
        sig = "none: every measured value came with its own σ"
    summary = page.table(
        [],
        [
            ["source", meas.source],
            ["arm", f"{arm.name} ({arm.n} links)"],
            ["rows (states)", str(meas.n_rows)],
            ["measured values", str(meas.n_values)],
            ["configurations", str(len(meas.configs))],
            ["payloads [kg]", ", ".join(page.num(float(m), 4) for m in masses)],
            [
                "channels measured",
                ", ".join(f"{ch} ({counts[ch]})" for ch in chans) or "none",
            ],
            ["σ defaulted", sig],
            ["self-weight", "included" if self_weight else "left out"],
            ["model", _model_line(kw)],
        ],
    )
    rows = []
    for label in meas.configs:
        sel = np.asarray(meas.config) == label
        first = int(np.flatnonzero(sel)[0])
        rows.append(
            [
                label,
                page.Raw(", ".join(f"{a:.2f}" for a in meas.alpha_deg[first])),
                ", ".join(page.num(float(m), 4) for m in np.unique(meas.mass_kg[sel])),
                page.Num(float(sel.sum()), 4),
            ]
        )
    configs = page.table(["config", "α unloaded [deg]", "payloads [kg]", "rows"], rows)
    return ["<h2>1. The data</h2>", page.row(summary, f"<div>{configs}</div>")]


def _model_line(kw: Mapping[str, Any]) -> str:
    """What the model is, in a sentence."""
    if kw["model"] != "fem":
        return "analytic: closed forms, the loaded pose closed exactly (docs/model.md)"
    return (
        f"{model_name(**kw)}: beams, bars, pins and springs, linear on the undeformed "
        "geometry; agrees with the analytic model to first order in the load (docs/fem.md)"
    )


def _baseline_section(
    meas: Measurements, d: Diagnosis, main: str, kw: Mapping[str, Any]
) -> list[str]:
    from eodarm.viz import plots

    base, best = d.baseline, _ends_with(d)
    name = "suggested" if d.suggested_fit is not None else "best effort"
    model = ", ".join(s.key for s in d.model)
    what = (
        f"Baseline: the arm file's model with {page.esc(model)} fitted."
        if model
        else "Baseline: rigid links, pins without clearance, each actuator an axial spring "
        "with the arm file's stiffness, rigid base; nothing fitted."
    )
    what += f" Every model in this report is the {page.esc(model_name(**kw))}."
    rb, ra = base.rms(), best.rms() if best is not None else {}
    head = ["channel", "typical σ", "RMS baseline", "RMS/σ"]
    if best is not None:
        head += [f"RMS {name}", "RMS/σ"]
    rows = []
    for ch in meas.measured_channels:
        s = _sigma_typ(meas, ch)
        u = _unit(ch)
        row: list[Any] = [
            f"{ch}",
            page.Num(s, 3, f" {u}"),
            page.Num(rb.get(ch, math.nan), 4, f" {u}"),
            page.Num(rb.get(ch, math.nan) / s, 3),
        ]
        if best is not None:
            row += [
                page.Num(ra.get(ch, math.nan), 4, f" {u}"),
                page.Num(ra.get(ch, math.nan) / s, 3),
            ]
        rows.append(row)
    chi: list[list[Any]] = [
        ["χ²/dof baseline", page.Num(base.chi2_per_dof)],
        ["p-value of the baseline χ²", _p_value(d.p_baseline)],
    ]
    if best is not None:
        chi.append([f"χ²/dof {name} model", page.Num(best.chi2_per_dof)])
    tables = (
        f'<div class="row"><div>{page.table(head, rows)}</div>'
        f"<div>{page.table([], chi)}</div></div>"
    )
    fits = {"baseline": base}
    if best is not None:
        fits[name] = best
    fig = plots.measured_vs_model(meas, fits)
    img = page.img(
        fig,
        "measured against model, per channel",
        "Measured (x, ±σ) against model (y) for every measured channel; on the dotted line "
        "y = x the model is right. The legend gives each model's RMS residual.",
    )
    return ["<h2>2. Baseline against the measurements</h2>", f"<p>{what}</p>", tables, img]


def _fitted_section(
    meas: Measurements,
    d: Diagnosis,
    cv: Mapping[str, Any] | None,
    final: FitResult | None = None,
) -> list[str]:
    best = final if final is not None else _ends_with(d)
    out = ["<h2>4. The fitted model</h2>"]
    if best is None:
        out.append("<p>No effect is suggested; the baseline stands as it is.</p>")
        return out
    if final is None and d.suggested_fit is None:
        out.append(
            "<p>No set explains the data: this is the best effort, the set the information "
            "criterion (BIC) prefers. It does not explain the data within their noise.</p>"
        )
    rows = []
    for i, s in enumerate(best.slots):
        kind = s.kind
        est, err = best.estimate(i), best.stderr(i)
        note = "at its bound" if best.at_bound[i] else ""
        rows.append(
            [
                s.key,
                kind.param,
                page.Num(est, 5),
                page.Num(err, 2),
                kind.unit,
                page.Num(100 * err / est if math.isfinite(est) and est else math.nan, 2, " %"),
                note,
            ]
        )
    table = page.table(
        ["effect@place", "parameter", "estimate", "± stderr", "unit", "rel.", "note"], rows
    )
    rb, ra = d.baseline.rms(), best.rms()
    rms_rows = [
        [
            ch,
            page.Num(rb.get(ch, math.nan), 4, f" {_unit(ch)}"),
            page.Num(ra.get(ch, math.nan), 4, f" {_unit(ch)}"),
            page.Num(cv["rms"].get(ch, math.nan), 4, f" {_unit(ch)}") if cv else "–",
        ]
        for ch in meas.measured_channels
    ]
    rms_rows.append(
        ["χ²/dof", page.Num(d.baseline.chi2_per_dof), page.Num(best.chi2_per_dof), "–"],
    )
    out += [
        f"<p>Model: {page.esc(_model_keys(best))}, all parameters fitted jointly "
        f"({best.problem.n_values} values, {best.n_params} "
        f"parameter{'s' if best.n_params != 1 else ''}).</p>",
        table,
        page.table(["channel", "RMS baseline", "RMS fitted", "RMS cross-validated"], rms_rows),
    ]
    if cv:
        out.append(
            '<p class="note">Cross-validated: each configuration predicted by parameters fitted '
            "without it (leave one configuration out).</p>"
        )
        per = cv.get("per_config") or {}
        if per:
            chans = list(meas.measured_channels)
            prow = [
                [label, *(page.Num(v.get(ch, math.nan), 3) for ch in chans)]
                for label, v in per.items()
            ]
            out.append(
                page.table(
                    ["held-out config", *(f"{ch} [{_unit(ch)}]" for ch in chans)],
                    prow,
                )
            )
    if best.warnings:
        out.append(
            '<p class="warn">' + "<br>".join(page.esc(w) for w in best.warnings) + "</p>",
        )
    return out


def _ladder_section(steps: Sequence[Mapping[str, Any]], main: str, unit: str) -> list[str]:
    from eodarm.viz import plots

    rows = []
    for s in steps:
        cvr = s.get("cv_rms")
        rows.append(
            [
                s["label"],
                page.Num(s["rms"].get(main, math.nan), 4, f" {unit}"),
                page.Num(cvr.get(main, math.nan), 4, f" {unit}") if cvr else "–",
                page.Num(s["chi2_per_dof"], 4),
            ]
        )
    table = page.table(["step", f"RMS {main}", "cross-validated RMS", "χ²/dof"], rows)
    img = page.img(
        plots.ladder(steps, channel=main),
        "error ladder",
        f"RMS of {main} (and its cross-validated value) as the suggested effects are added one "
        "at a time, every step refitted; χ²/dof on the right (1 = within the noise).",
    )
    return ["<h2>5. The error ladder</h2>", page.row(table, img)]


def _residual_section(
    meas: Measurements, before: FitResult, after: FitResult, main: str
) -> list[str]:
    from eodarm.viz import plots

    unit = _unit(main)
    c = meas.index(main)
    rows = []
    for label in meas.configs:
        sel = (np.asarray(meas.config) == label) & before.problem.use[:, c]
        rb = float(np.sqrt(np.mean(before.residual[sel, c] ** 2))) if sel.any() else math.nan
        ra = float(np.sqrt(np.mean(after.residual[sel, c] ** 2))) if sel.any() else math.nan
        rows.append([label, page.Num(rb, 3, f" {unit}"), page.Num(ra, 3, f" {unit}")])
    table = page.table(["config", "RMS before", "RMS after"], rows)
    img = page.img(
        plots.residual_vs_payload(meas, before, after, channel=main),
        "residuals against payload",
        f"Residual of {main} against payload, per configuration: the baseline (grey, dashed) "
        "and the fitted model (blue); the band is ±1σ of the measurement.",
    )
    return ["<h2>6. Residuals against payload</h2>", page.row(table, img)]


def _share_section(
    arm: Arm, meas: Measurements, final: FitResult, sw: bool, kw: Mapping[str, Any]
) -> list[str]:
    from eodarm.model.solver import solve
    from eodarm.viz import plots

    effects = final.effects
    mass = float(np.max(meas.mass_kg))
    rows_idx = [int(np.flatnonzero(np.asarray(meas.config) == c)[0]) for c in meas.configs]
    alpha = meas.alpha_deg[rows_idx]
    base = solve(arm, alpha, mass, self_weight=sw, **kw)["dy_mm"]
    contrib = [
        solve(arm, alpha, mass, effects=[e], self_weight=sw, **kw)["dy_mm"] - base for e in effects
    ]
    total = solve(arm, alpha, mass, effects=effects, self_weight=sw, **kw)["dy_mm"]
    rows = [
        [label, page.Num(base[i], 3), *(page.Num(v[i], 3) for v in contrib), page.Num(total[i], 3)]
        for i, label in enumerate(meas.configs)
    ]
    table = page.table(
        ["config", "baseline [mm]", *(f"{e.key} [mm]" for e in effects), "total [mm]"],
        rows,
    )
    img = page.img(
        plots.deflection_share(arm, meas, effects, self_weight=sw, mass=mass, **kw),
        "contributions to the sag",
        f"Contribution of each effect to the sag dy of the measure point at {mass:g} kg "
        "(the effect alone minus the baseline), per configuration; the diamond is the total "
        "with every effect together.",
    )
    out = [
        "<h2>7. Who makes the sag?</h2>",
        f"<p>dy of the measure point [mm] at payload {mass:g} kg, model: "
        f"{page.esc(', '.join(plots.effect_label(e) for e in effects) or 'baseline only')} "
        f"({page.esc(model_name(**kw))}).</p>",
        page.row(table, img),
    ]
    first = meas.configs[0]
    r0 = rows_idx[0]
    one = solve(arm, alpha[:1], mass, effects=effects, self_weight=sw, **kw)
    scale = _nice_scale(float(np.max(np.abs(one["dalpha_deg"]))))
    pose = page.img(
        plots.arm_pose(arm, alpha[0], out=one, scale=scale),
        f"the arm in configuration {first}",
        f"Configuration {first} (α = {', '.join(f'{a:.1f}' for a in meas.alpha_deg[r0])}°) "
        f"under {mass:g} kg with the fitted model ({model_name(**kw)}); the loaded pose is "
        f"exaggerated ×{scale:g}.",
        narrow=True,
    )
    out.append(pose)
    return out
