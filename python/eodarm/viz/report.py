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
from eodarm.analysis.crossval import cross_validate
from eodarm.analysis.diagnose import Diagnosis
from eodarm.analysis.fit import FitResult, FitWarning
from eodarm.analysis.ladder import build_ladder, check_same_model, model_name, solver_keywords
from eodarm.atomic import atomic_write
from eodarm.data.measurements import Measurements, default_sigma
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.viz import html as page
from eodarm.viz.format import channel_value, value
from eodarm.viz.report_cycle import loops_section
from eodarm.viz.report_diagnosis import diagnosis_section, left_section, rounds_section
from eodarm.viz.report_summary import (
    answer_section,
    handover_section,
    make_answer,
    parameter_section,
)

__all__ = ["build_ladder", "write_report"]

PathLike = str | os.PathLike[str]


def _p_value(p: float) -> page.Num | page.Raw:
    if p <= 0:  # the same words as the sets' table
        return page.Raw('<span class="num">&lt; 1e-300</span>')
    return page.Num(p, 3)


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
    stopped: str | None = None,
    published: Sequence[tuple[str, float]] | None = None,
    handover: Mapping[str, str] | None = None,
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
    stopped : why the investigation stopped, in words (shown with the final answer).
    published : ``(name, RMS of the main channel)`` of published models on the same data,
        shown beside the final model's error.
    handover : ``measurements``, ``arm`` (paths for the commands that reproduce the fit) and
        optionally ``setup`` (a command to run first); default the data's and arm's sources.

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

    base_cv = None
    if steps and steps[0].get("cv_rms"):
        base_cv = steps[0]["cv_rms"]
    answer = make_answer(
        meas,
        base,
        base_cv,
        final,
        (cv or {}).get("rms") if best is not None else base_cv,
        list(rounds) if rounds else [diagnosis],
        stopped or "",
        main,
        published or (),
    )
    with page.deferred() as figs:
        parts, forked = _page(
            arm,
            meas,
            diagnosis,
            steps,
            cv,
            doc_title,
            extra_sections,
            final_fit,
            rounds,
            intro_html,
            kw,
            answer,
            base,
            final,
            best,
            main,
            unit,
            self_weight,
            handover,
        )
    text = page.render_deferred("\n".join(parts) + "\n", figs, parallel=not forked)
    out = Path(path)
    try:
        with atomic_write(out) as f:  # whole or not at all: a previous report stays whole
            f.write(text)
    except OSError as exc:
        raise EodarmError(f"{out}: cannot write the report: {exc.strerror or exc}") from None
    return out


def _page(
    arm: Arm,
    meas: Measurements,
    diagnosis: Diagnosis,
    steps: Sequence[Mapping[str, Any]] | None,
    cv: Mapping[str, Any] | None,
    doc_title: str,
    extra_sections: Sequence[tuple[str, str]] | None,
    final_fit: FitResult | None,
    rounds: Sequence[Diagnosis] | None,
    intro_html: str | None,
    kw: Mapping[str, Any],
    answer: Any,
    base: FitResult,
    final: FitResult,
    best: FitResult | None,
    main: str,
    unit: str,
    self_weight: bool,
    handover: Mapping[str, str] | None,
) -> tuple[list[str], bool]:
    """The page's parts, in order (figures as placeholders inside :func:`page.deferred`).

    The second half, how the investigation got there, is built in this process; the drawing
    of all figures is shared with a forked child (:func:`page.render_deferred`).
    """

    def steps_behind() -> str:
        out = [
            '<h2 class="part">How the investigation got there</h2>',
            "<p>The steps behind the answer above, in order: the data, the baseline, the first "
            "diagnosis, the further rounds, the fitted model, the ladder of models and the "
            "residuals.</p>",
        ]
        out += _data_section(arm, meas, self_weight, kw)
        out += _baseline_section(meas, diagnosis, main, kw)
        out += diagnosis_section(meas, diagnosis, main, unit)
        if rounds and len(rounds) > 1:
            out += rounds_section(rounds, main)
        out += _fitted_section(meas, diagnosis, cv, final_fit)
        if steps:
            out += _ladder_section(steps, main, unit)
        out += _residual_section(meas, base, final, main)
        if meas.has_sequences:
            out += loops_section(meas, base, final, main)
        last = rounds[-1] if rounds else diagnosis
        if last.verdict == "unexplained":
            what = "the model the report ends with" if final_fit is not None else "the best effort"
            if final is base:
                what = "the baseline"
            out += left_section(meas, final, f"{what} ({_model_keys(final)})")
        return "\n".join(out)

    # Built here, not in a forked child: building solves with the compiled core, whose
    # thread pool (rayon) does not survive fork(); only the drawing of finished figures,
    # pure matplotlib, is forked (page.render_deferred).
    history = page.Aside(steps_behind, parallel=False)
    forked = history.forked
    parts: list[str] = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{page.esc(doc_title)}</title>",
        f"<style>{page.CSS}</style></head><body>",
        f"<h1>{page.esc(doc_title)}</h1>",
    ]
    if intro_html:
        parts.append(intro_html)
    parts += answer_section(answer, meas, base, final, model_name(**kw))
    if final.slots:
        parts += parameter_section(final, meas, answer.lookalikes)
    parts += _share_section(arm, meas, final, self_weight, kw)
    if final.slots:
        ho = handover or {}
        parts += handover_section(
            final,
            arm,
            meas,
            ho.get("measurements", str(meas.source)),
            ho.get("arm", str(arm.source)),
            ho.get("setup"),
        )
    parts.append(history())
    for heading, body in extra_sections or ():
        parts += [f"<h2>{page.esc(heading)}</h2>", body]
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts += [
        f"<footer>eodarm {page.esc(__version__)} · {page.esc(model_name(**kw))} · {stamp} · every "
        "figure is embedded in this file"
        "</footer>",
        "</body></html>",
    ]
    return parts, forked


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
            ["payloads [kg]", ", ".join(value(float(m)) for m in masses)],
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
                ", ".join(value(float(m)) for m in np.unique(meas.mass_kg[sel])),
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


def _springs(kinds: Sequence[str]) -> str:
    """The baseline's springs in words: the actuators' axial ones, the drives' torsional ones."""
    linear, rotary = "linear" in kinds, "rotary" in kinds
    if linear and rotary:
        return "each actuator an axial spring and each rotary drive a torsional spring"
    return "each rotary drive a torsional spring" if rotary else "each actuator an axial spring"


def _baseline_section(
    meas: Measurements, d: Diagnosis, main: str, kw: Mapping[str, Any]
) -> list[str]:
    base = d.baseline
    model = ", ".join(s.key for s in d.model)
    what = (
        f"Baseline: the arm file's model with {page.esc(model)} fitted."
        if model
        else "Baseline: rigid links, pins without clearance, "
        + _springs(d.baseline.problem.arm.kinds)
        + " with the arm file's stiffness, rigid base; nothing fitted."
    )
    what += (
        f" Every model in this report is the {page.esc(model_name(**kw))}. The baseline's "
        "points are the open markers of the measured-vs-model figure in “The answer”."
    )
    rb = base.rms()
    rows = []
    for ch in meas.measured_channels:
        s = _sigma_typ(meas, ch)
        u = _unit(ch)
        rows.append(
            [
                f"{ch}",
                page.Num(s, 3, f" {u}"),
                page.Num(rb.get(ch, math.nan), 3, f" {u}"),
                page.Num(rb.get(ch, math.nan) / s, 3),
            ]
        )
    chi: list[list[Any]] = [
        ["χ²/dof baseline", page.Num(base.chi2_per_dof)],
        ["p-value of the baseline χ²", _p_value(d.p_baseline)],
    ]
    tables = page.row(
        page.table(["channel", "typical σ", "RMS baseline", "RMS/σ"], rows),
        f"<div>{page.table([], chi)}</div>",
    )
    return ["<h2>2. Baseline against the measurements</h2>", f"<p>{what}</p>", tables]


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
    rb, ra = d.baseline.rms(), best.rms()
    rms_rows = [
        [
            ch,
            page.Num(rb.get(ch, math.nan), 3, f" {_unit(ch)}"),
            page.Num(ra.get(ch, math.nan), 3, f" {_unit(ch)}"),
            page.Num(cv["rms"].get(ch, math.nan), 3, f" {_unit(ch)}") if cv else "–",
        ]
        for ch in meas.measured_channels
    ]
    rms_rows.append(
        ["χ²/dof", page.Num(d.baseline.chi2_per_dof), page.Num(best.chi2_per_dof), "–"],
    )
    out += [
        f"<p>Model: {page.esc(_model_keys(best))}, all parameters fitted jointly "
        f"({best.problem.n_values} values, {best.n_params} "
        f"parameter{'s' if best.n_params != 1 else ''}; their values, errors "
        "and correlations: “The fitted parameters” above).</p>",
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
                page.Num(s["rms"].get(main, math.nan), 3, f" {unit}"),
                page.Num(cvr.get(main, math.nan), 3, f" {unit}") if cvr else "–",
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
    from eodarm.model.solver import forward, solve
    from eodarm.viz import plots
    from eodarm.viz.budget_plot import budget_at, component_name

    effects = [*final.fixed, *final.effects]
    budget, mass, measured, base = budget_at(arm, meas, effects, self_weight=sw, mass=None, **kw)
    names = [component_name(lb) for lb in budget.labels]
    rows = [
        [
            label,
            *(page.Num(v[i], 3) for v in budget.shares),
            page.Num(budget.total[i], 3),
            page.Num(measured[i], 3),
            page.Num(measured[i] - budget.total[i], 3),
            page.Num(base[i], 3),
        ]
        for i, label in enumerate(meas.configs)
    ]
    table = page.table(
        ["config", *names, "model", "measured", "residual", "baseline"],
        rows,
    )
    img = page.img(
        plots.deflection_share(
            arm,
            meas,
            effects,
            self_weight=sw,
            mass=mass,
            budget=(budget, mass, measured, base),
            **kw,
        ),
        "the sag budget",
        f"Sag budget of the final model at {mass:g} kg, per configuration. Starting from the "
        "rigid arm (which does not sag), each part's share is its added sag averaged over "
        "every order in which the parts can be switched on (the Shapley value), so each "
        "share is counted with all the others present and the shares add up exactly to the "
        "model's sag (black diamond); for springs in series this is each spring's share of "
        "the work, as a hand calculation splits it. The hatched part is what the model "
        "misses, up to the measured sag (cross). The grey bar is the baseline's sag.",
    )
    out = [
        "<h2>Who makes the sag?</h2>",
        f"<p>dy of the measure point [mm] at payload {mass:g} kg, split between the parts of "
        f"the final model ({page.esc(model_name(**kw))}); the shares add up to the model "
        + (
            f"within {channel_value(budget.closure, 'mm')}.</p>"
            if budget.closure >= 1e-6
            else "to 10⁻⁶ mm.</p>"
        ),
        page.row(table, img),
    ]
    # the configuration the final model misses most, drawn with its sag made visible
    per = {}
    c = meas.index("dy_mm") if "dy_mm" in meas.measured_channels else None
    for k, label in enumerate(meas.configs):
        per[label] = abs(measured[k] - budget.total[k]) if c is not None else 0.0
    finite = {k: v for k, v in per.items() if math.isfinite(v)}
    worst = max(finite, key=lambda k: finite[k]) if finite else meas.configs[0]
    k = list(meas.configs).index(worst)
    r0 = int(np.flatnonzero(np.asarray(meas.config) == worst)[0])
    alpha = meas.alpha_deg[r0 : r0 + 1]
    one = solve(arm, alpha, mass, effects=effects, self_weight=sw, **kw)
    geo = forward(arm, alpha)
    reach = float(np.hypot(*(geo["measure"][0] - np.asarray(arm.O1, dtype=float))))
    sag = math.hypot(float(one["dx_mm"][0]), float(one["dy_mm"][0]))
    scale = _nice_scale_length(sag, 0.15 * reach)
    pose = page.img(
        plots.arm_pose(arm, alpha[0], out=one, scale=scale),
        f"the arm in configuration {worst}",
        f"Configuration {worst}, the one the final model misses most at {mass:g} kg "
        f"(α = {', '.join(f'{a:.1f}' for a in alpha[0])}°): the final model's loaded pose, "
        f"deflections exaggerated ×{scale:g} so that {value(sag, 'mm', 3)} on a "
        f"{reach:.0f} mm arm can be seen (measured dy {value(measured[k], 'mm', 3)}, "
        f"model {value(budget.total[k], 'mm', 3)}).",
        narrow=True,
    )
    out.append(pose)
    return out


def _nice_scale_length(length: float, target: float) -> float:
    """A round exaggeration (1, 2 or 5 × 10^k) that draws ``length`` as about ``target``."""
    if not (math.isfinite(length) and length > 0 and target > 0):
        return 1.0
    raw = target / length
    k = math.floor(math.log10(raw))
    return max(m * 10.0**k for m in (1, 2, 5) if m * 10.0**k <= raw)
