"""A diagnosis told as one self-contained HTML page, and the error ladder behind it.

:func:`write_report` writes a single ``.html`` file (figures embedded as base64 PNG, inline
CSS, no JavaScript, no external resource) that goes from the data to the conclusion:

1. the data: source, rows, configurations, payloads, measured channels, defaulted σ;
2. the baseline model against the measurements (RMS per channel, χ²/dof);
3. the diagnosis: verdict, suggested set, ranking of every candidate, outliers, advice on the
   next measurement when candidates cannot be told apart;
4. the fitted suggested model (estimates ± standard errors, cross-validation);
5. the error ladder (:func:`build_ladder`), residuals against payload before/after, and each
   effect's share of the sag.

Every number comes from one model, the one the diagnosis was made with: the analytic model, or
with ``diagnose(..., solver_model="fem")`` the finite-element model (``docs/fem.md``); the
report names it.

>>> from eodarm.diagnose import diagnose
>>> from eodarm.report import build_ladder, write_report
>>> d = diagnose(arm, meas)                                              # doctest: +SKIP
>>> write_report("report.html", arm, meas, d, steps=build_ladder(arm, meas, d))  # doctest: +SKIP
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import io
import math
import os
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__
from .arm import Arm
from .diagnose import CONFUSION_CHI2, Candidate, Diagnosis
from .errors import EodarmError, InputError
from .fit import FitResult, FitWarning, cross_validate, fit
from .measurements import Measurements, default_sigma

__all__ = ["build_ladder", "write_report"]

PathLike = str | os.PathLike[str]

_CSS = """
body { font-family: "DejaVu Sans", Helvetica, Arial, sans-serif; color: #222;
       max-width: 1180px; margin: 1.5em auto; padding: 0 1em; line-height: 1.4; }
h1 { font-size: 1.6em; border-bottom: 3px solid #1f77b4; padding-bottom: .2em; }
h2 { font-size: 1.25em; margin-top: 2em; border-bottom: 1px solid #ccc; }
h3 { font-size: 1.05em; margin-bottom: .3em; }
table { border-collapse: collapse; margin: .5em 0 1em 0; font-size: .9em; display: block;
        overflow-x: auto; max-width: 100%; }
th, td { border: 1px solid #ccc; padding: .25em .6em; text-align: left; vertical-align: top; }
th { background: #f0f3f7; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
tr.hl td { background: #fff4d6; font-weight: bold; }
.row { display: flex; flex-wrap: wrap; gap: 1.5em; align-items: flex-start; }
.row > div { flex: 0 1 auto; max-width: 100%; overflow-x: auto; }
.row > figure { flex: 1 1 520px; }
figure.narrow { max-width: 820px; }
figure { margin: .5em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: .85em; color: #555; }
.verdict { display: inline-block; padding: .2em .8em; border-radius: .3em; font-weight: bold;
           font-size: 1.15em; }
.missing { background: #d62728; color: white; }
.adequate { background: #2ca02c; color: white; }
.note { color: #555; font-size: .9em; }
.warn { color: #8c3b00; }
code { background: #f4f4f4; padding: 0 .2em; }
footer { margin-top: 3em; font-size: .8em; color: #777; }
"""


# ---------------------------------------------------------------------------- the model
def _solver(
    diagnosis: Diagnosis, model: str | None, fem_options: Mapping[str, Any] | None
) -> dict[str, Any]:
    """The ``model``/``fem_options`` keywords of every evaluation: the diagnosis's own.

    ``model=None`` takes the diagnosis's model; a model (or FE options) other than the one the
    diagnosis was made with is refused rather than mixed into one report.
    """
    from . import fem

    prob = diagnosis.baseline.problem
    if model is None and fem_options is None:
        return {"model": prob.model, "fem_options": prob.fem_options}
    chosen = prob.model if model is None else model
    fem.check_model(chosen)
    if chosen != "fem" and fem_options is not None:
        raise InputError("fem_options is for model='fem'")
    opts = fem.options(fem_options) if chosen == "fem" else None
    if (chosen, opts) != (prob.model, prob.fem_options):
        raise EodarmError(
            f"the diagnosis was made with the {_model_name(prob.model, prob.fem_options)}, "
            f"not the {_model_name(chosen, opts)}: diagnose with solver_model={chosen!r} "
            "(and the same fem_options)"
        )
    return {"model": chosen, "fem_options": opts}


def _model_name(model: str, fem_options: Mapping[str, Any] | None) -> str:
    if model != "fem":
        return "analytic model"
    epl = (fem_options or {}).get("elements_per_link")
    return "finite-element model" + (f" with {epl} elements per flexible link" if epl else "")


def _same_model(fit_result: FitResult, kw: Mapping[str, Any], what: str) -> None:
    p = fit_result.problem
    if (p.model, p.fem_options) != (kw["model"], kw["fem_options"]):
        raise EodarmError(
            f"{what} was fitted with the {_model_name(p.model, p.fem_options)}, the diagnosis "
            f"with the {_model_name(kw['model'], kw['fem_options'])}"
        )


# ---------------------------------------------------------------------------- the ladder
def build_ladder(
    arm: Arm,
    meas: Measurements,
    diagnosis: Diagnosis,
    self_weight: bool = True,
    cv: bool = True,
    model: str | None = None,
    fem_options: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """The models of the error ladder: baseline, then the suggested effects one at a time.

    The suggested effects are added in the order of their individual improvement Δχ² (the
    candidate's own row of ``diagnosis.ranking``, largest first). Every step is fitted afresh
    with :func:`eodarm.fit.fit` on all its effects jointly (the model's own ``--add`` effects
    included), leaving out the cells the diagnosis named as outliers.

    Parameters
    ----------
    arm, meas : the arm and the measurements the diagnosis was made on.
    diagnosis : the result of :func:`eodarm.diagnose.diagnose`.
    self_weight : as :func:`eodarm.solve`.
    cv : add the leave-one-configuration-out RMS (:func:`eodarm.fit.cross_validate`) of every
        step; only done when the data have at least two configurations. (Cross-validation
        uses every measured cell, outliers included.)
    model, fem_options : ``"analytic"`` or ``"fem"`` and its options, as in
        :func:`eodarm.fit.fit`; default (``None``) the model the diagnosis was made with, and
        nothing else is accepted.

    Returns
    -------
    list of dict
        One per step: ``label`` (``"baseline"``, ``"+ effect@place"``…), ``effects`` (the
        ``effect@place`` keys fitted), ``rms`` ({channel: mm or deg}), ``cv_rms`` (same, or
        ``None``), ``chi2_per_dof``, ``fit`` (the :class:`~eodarm.fit.FitResult`) and
        ``warnings`` (parameters stuck at a bound).
    """
    prob = diagnosis.baseline.problem
    if prob.meas.values.shape != meas.values.shape:
        raise EodarmError(
            f"build_ladder: the diagnosis was made on {prob.meas.n_rows} rows, "
            f"the measurements have {meas.n_rows}"
        )
    kw = _solver(diagnosis, model, fem_options)
    excluded = np.isfinite(meas.values) & ~prob.use
    exclude = excluded if excluded.any() else None
    gain = {c.slot.key: c.delta_chi2 for c in diagnosis.ranking}
    added = sorted(diagnosis.suggested, key=lambda s: -gain.get(s.key, -math.inf))
    do_cv = cv and len(meas.configs) >= 2
    base_label = "baseline"
    if diagnosis.model:
        base_label = "model: " + ", ".join(s.key for s in diagnosis.model)
    steps: list[dict[str, Any]] = []
    for i in range(len(added) + 1):
        slots = list(diagnosis.model) + added[:i]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)
            res = fit(arm, meas, slots, self_weight=self_weight, exclude=exclude, **kw)
            cv_rms = (
                cross_validate(arm, meas, slots, self_weight=self_weight, **kw)["rms"]
                if do_cv
                else None
            )
        steps.append(
            {
                "label": base_label if i == 0 else f"+ {added[i - 1].key}",
                "effects": [s.key for s in slots],
                "rms": res.rms(),
                "cv_rms": cv_rms,
                "chi2_per_dof": res.chi2_per_dof,
                "fit": res,
                "warnings": list(res.warnings),
            }
        )
    return steps


# ---------------------------------------------------------------------------- formatting
def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _num(x: float, digits: int = 4) -> str:
    if x is None or not math.isfinite(x):
        return "∞" if x is not None and x > 0 else "–"
    return f"{x:.{digits}g}"


def _param(param: str, unit: str, value: float, name: str = "") -> str:
    if not math.isfinite(value):
        # θ = 0: for an actuator body that is a rigid body, for anything else no effect.
        what = "rigid body" if name == "actuator_compliance" else "rigid: absent"
        return f"{param} = ∞ ({what})"
    return f"{param} = {_num(value)} {unit}"


def _table(head: Sequence[str], rows: Sequence[Sequence[Any]], hl: Sequence[bool] = ()) -> str:
    """An HTML table; cells are escaped unless given as ``_Raw``; numbers right-aligned.

    Without a ``head`` the first column is a column of row headings (a key/value table).
    """
    out = ["<table>"]
    if head:
        out.append("<tr>" + "".join(f"<th>{_e(h)}</th>" for h in head) + "</tr>")
    for i, row in enumerate(rows):
        cls = ' class="hl"' if i < len(hl) and hl[i] else ""
        cells = []
        for j, cell in enumerate(row):
            if not head and j == 0:
                cells.append(f"<th>{_e(cell)}</th>")
            elif isinstance(cell, _Raw):
                cells.append(f"<td>{cell.html}</td>")
            elif isinstance(cell, _Num):
                cells.append(f'<td class="num">{_e(cell.text)}</td>')
            else:
                cells.append(f"<td>{_e(cell)}</td>")
        out.append(f"<tr{cls}>" + "".join(cells) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


class _Raw:
    """Trusted HTML for a table cell."""

    def __init__(self, text: str) -> None:
        self.html = text


class _Num:
    """A right-aligned number cell."""

    def __init__(self, x: float, digits: int = 4, suffix: str = "") -> None:
        self.text = _num(x, digits) + suffix


def _img(fig: Any, alt: str, caption: str, narrow: bool = False) -> str:
    """A figure as an embedded PNG (base64) with a caption."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    cls = ' class="narrow"' if narrow else ""
    return (
        f"<figure{cls}>"
        f'<img src="data:image/png;base64,{data}" alt="{_e(alt)}">'
        f"<figcaption>{_e(caption)}</figcaption></figure>"
    )


def _row(left: str, right: str) -> str:
    return f'<div class="row"><div>{left}</div>{right}</div>'


def _estimate(cand: Candidate) -> str:
    i = cand.fit.slots.index(cand.slot)
    kind = cand.slot.kind
    return _param(kind.param, kind.unit, cand.fit.estimate(i), cand.slot.name)


def _nice_scale(max_dalpha_deg: float, target_deg: float = 8.0) -> float:
    """A round exaggeration (1, 2 or 5 × 10^k) that turns the largest dα into about 8°."""
    if not (math.isfinite(max_dalpha_deg) and max_dalpha_deg > 0):
        return 50.0
    raw = target_deg / max_dalpha_deg
    k = math.floor(math.log10(raw))
    return max(m * 10.0**k for m in (1, 2, 5) if m * 10.0**k <= raw)


def _p_value(p: float) -> _Num | str:
    return "< 1e-300" if p <= 0 else _Num(p, 3)


def _unit(channel: str) -> str:
    from .plots import channel_unit

    return channel_unit(channel)


def _sigma_typ(meas: Measurements, channel: str) -> float:
    c = meas.index(channel)
    s = meas.sigma[meas.measured[:, c], c]
    return float(np.median(s)) if s.size else math.nan


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
    diagnosis : the result of :func:`eodarm.diagnose.diagnose`.
    steps : the error ladder (:func:`build_ladder`); its figure and table are shown if given.
    cv : cross-validation of the suggested model: the dict returned by
        :func:`eodarm.fit.cross_validate`, or ``True`` to compute it here (needs two or more
        configurations); ``None``/``False`` for none.
    title : the page title; default ``"eodarm diagnosis: <arm> / <source>"``.
    extra_sections : ``(heading, html)`` pairs appended at the end; the heading is escaped,
        the html is inserted as given.
    final_fit : the model the report ends with, when it is not the first diagnosis's
        suggested set (e.g. after several rounds, :func:`eodarm.workflow.investigate`); the
        fitted model, residual and share sections then show it, and ``cv`` belongs to it.
    rounds : every round of diagnosis (the first is ``diagnosis``), summarised in a table.
    intro_html : a paragraph shown under the title (inserted as given).
    model, fem_options : the model of every evaluation (``"analytic"`` or ``"fem"`` and its
        options, as in :func:`eodarm.fit.fit`); default (``None``) the one the diagnosis was
        made with, and only that one is accepted (also for ``final_fit`` and the fits of
        ``steps``). The report names it.

    Returns
    -------
    Path
        The file written.
    """
    from . import plots

    kw = _solver(diagnosis, model, fem_options)
    if final_fit is not None:
        _same_model(final_fit, kw, "final_fit")
    for i, step in enumerate(steps or ()):
        if step.get("fit") is not None:
            _same_model(step["fit"], kw, f"step {i} of the ladder")
    base = diagnosis.baseline
    best = final_fit if final_fit is not None else diagnosis.suggested_fit
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
        f"<title>{_e(doc_title)}</title>",
        f"<style>{_CSS}</style></head><body>",
        f"<h1>{_e(doc_title)}</h1>",
        f'<p>Verdict: <span class="verdict {_e(diagnosis.verdict)}">'
        f"{_e(diagnosis.verdict)}</span> &nbsp; "
        + (
            "suggested: <b>" + _e(", ".join(s.key for s in diagnosis.suggested)) + "</b>"
            if diagnosis.suggested
            else "nothing to add"
        )
        + "</p>",
    ]
    if intro_html:
        parts.append(intro_html)
    parts += _data_section(arm, meas, self_weight, kw)
    parts += _baseline_section(meas, diagnosis, main, kw)
    parts += _diagnosis_section(meas, diagnosis, main, unit)
    if rounds and len(rounds) > 1:
        parts += _rounds_section(rounds, main)
    parts += _fitted_section(meas, diagnosis, cv, final_fit)
    if steps:
        parts += _ladder_section(steps, main, unit)
    parts += _residual_section(meas, base, final, main)
    parts += _share_section(arm, meas, final, self_weight, kw)
    for heading, body in extra_sections or ():
        parts += [f"<h2>{_e(heading)}</h2>", body]
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts += [
        f"<footer>eodarm {_e(__version__)} · {_e(_model_name(**kw))} · {stamp} · every "
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
            f"{ch} ({_num(default_sigma(ch), 3)} {_unit(ch)})" for ch in meas.defaulted
        )
    else:
        sig = "none: every measured value came with its own σ"
    summary = _table(
        [],
        [
            ["source", meas.source],
            ["arm", f"{arm.name} ({arm.n} links)"],
            ["rows (states)", str(meas.n_rows)],
            ["measured values", str(meas.n_values)],
            ["configurations", str(len(meas.configs))],
            ["payloads [kg]", ", ".join(_num(float(m), 4) for m in masses)],
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
                _Raw(", ".join(f"{a:.2f}" for a in meas.alpha_deg[first])),
                ", ".join(_num(float(m), 4) for m in np.unique(meas.mass_kg[sel])),
                _Num(float(sel.sum()), 4),
            ]
        )
    configs = _table(["config", "α unloaded [deg]", "payloads [kg]", "rows"], rows)
    return ["<h2>1. The data</h2>", _row(summary, f"<div>{configs}</div>")]


def _model_line(kw: Mapping[str, Any]) -> str:
    """What the model is, in a sentence."""
    if kw["model"] != "fem":
        return "analytic: closed forms, the loaded pose closed exactly (docs/model.md)"
    return (
        f"{_model_name(**kw)}: beams, bars, pins and springs, linear on the undeformed "
        "geometry; agrees with the analytic model to first order in the load (docs/fem.md)"
    )


def _baseline_section(
    meas: Measurements, d: Diagnosis, main: str, kw: Mapping[str, Any]
) -> list[str]:
    from . import plots

    base, best = d.baseline, d.suggested_fit
    model = ", ".join(s.key for s in d.model)
    what = (
        f"Baseline: the arm file's model with {_e(model)} fitted."
        if model
        else "Baseline: rigid links, pins without clearance, each actuator an axial spring "
        "with the arm file's stiffness, rigid base; nothing fitted."
    )
    what += f" Every model in this report is the {_e(_model_name(**kw))}."
    rb, ra = base.rms(), best.rms() if best is not None else {}
    head = ["channel", "typical σ", "RMS baseline", "RMS/σ"]
    if best is not None:
        head += ["RMS suggested", "RMS/σ"]
    rows = []
    for ch in meas.measured_channels:
        s = _sigma_typ(meas, ch)
        u = _unit(ch)
        row: list[Any] = [
            f"{ch}",
            _Num(s, 3, f" {u}"),
            _Num(rb.get(ch, math.nan), 4, f" {u}"),
            _Num(rb.get(ch, math.nan) / s, 3),
        ]
        if best is not None:
            row += [_Num(ra.get(ch, math.nan), 4, f" {u}"), _Num(ra.get(ch, math.nan) / s, 3)]
        rows.append(row)
    chi: list[list[Any]] = [
        ["χ²/dof baseline", _Num(base.chi2_per_dof)],
        ["p-value of the baseline χ²", _p_value(d.p_baseline)],
    ]
    if best is not None:
        chi.append(["χ²/dof suggested model", _Num(best.chi2_per_dof)])
    tables = f'<div class="row"><div>{_table(head, rows)}</div><div>{_table([], chi)}</div></div>'
    fits = {"baseline": base}
    if best is not None:
        fits["suggested"] = best
    fig = plots.measured_vs_model(meas, fits)
    img = _img(
        fig,
        "measured against model, per channel",
        "Measured (x, ±σ) against model (y) for every measured channel; on the dotted line "
        "y = x the model is right. The legend gives each model's RMS residual.",
    )
    return ["<h2>2. Baseline against the measurements</h2>", f"<p>{what}</p>", tables, img]


def _diagnosis_section(meas: Measurements, d: Diagnosis, main: str, unit: str) -> list[str]:
    sugg = {s.key for s in d.suggested}
    if d.verdict == "adequate":
        story = (
            "The baseline explains the data within their noise and no candidate improves it "
            "significantly: nothing is missing."
        )
    elif d.suggested and d.suggested_explains:
        story = (
            "The baseline does not explain the data. The smallest set of effects that does "
            f"(searched over {d.sets_searched} sets, not just the top of the ranking) is "
            f"<b>{_e(', '.join(sorted(sugg, key=[s.key for s in d.suggested].index)))}</b>."
        )
    elif d.suggested:
        story = (
            "The baseline does not explain the data, and no set of up to three effects explains "
            f"it within the noise (searched over {d.sets_searched} sets). Of those sets, the "
            "information criterion (BIC: χ² + k ln N) prefers "
            f"<b>{_e(', '.join(sorted(sugg, key=[s.key for s in d.suggested].index)))}</b>; "
            "more is missing than one round can add (see the further rounds below)."
        )
    else:
        story = "The baseline does not explain the data, and no set of candidates does better."
    rows, hl = [], []
    for i, c in enumerate(d.ranking, start=1):
        rows.append(
            [
                _Num(i, 3),
                c.slot.key,
                _estimate(c),
                _Num(c.delta_chi2, 4),
                _Num(c.fit.chi2_per_dof, 4),
                _Num(c.fit.rms().get(main, math.nan), 3, f" {unit}"),
                ", ".join(c.confused_with) or "–",
            ]
        )
        hl.append(c.slot.key in sugg)
    ranking = _table(
        [
            "#",
            "effect@place",
            "estimate",
            "Δχ²",
            "χ²/dof",
            f"RMS {main}",
            "confused with",
        ],
        rows,
        hl,
    )
    out = [
        "<h2>3. Diagnosis: which effect is missing?</h2>",
        f'<p>Verdict: <span class="verdict {_e(d.verdict)}">{_e(d.verdict)}</span></p>',
        f"<p>{story}</p>",
        "<h3>Every candidate added alone, its parameter fitted (best first)</h3>",
        f'<p class="note">Highlighted: the suggested set. RMS of the main channel {_e(main)}; '
        "Δχ² is the improvement over the baseline. “Confused with” lists the candidates the "
        "data cannot tell apart from this one.</p>",
        ranking,
    ]
    if d.outliers:
        orows = [
            [
                _Num(o["line"], 6),
                o["config"],
                _Num(o["mass_kg"], 4),
                o["channel"],
                _Num(o["measured"], 4),
                _Num(o["model"], 4),
                _Num(o["z"], 3),
            ]
            for o in d.outliers
        ]
        out += [
            "<h3>Outliers (left out of the fits)</h3>",
            _table(["line", "config", "mass [kg]", "channel", "measured", "model", "z [σ]"], orows),
        ]
    if d.advice:
        items = []
        for a in d.advice:
            pair = " and ".join(a["pair"])
            bits = []
            if a.get("channel"):
                ch = a["channel"]
                bits.append(
                    f"measure <code>{_e(ch['channel'])}</code> (the two would differ by "
                    f"χ² = {_e(_num(ch['chi2_separation'], 3))} on the present poses)"
                )
            pose = a.get("pose")
            if pose and pose["chi2_separation"] > CONFUSION_CHI2:
                ang = ", ".join(f"{v:.1f}" for v in pose["alpha_deg"])
                bits.append(
                    f"add the pose α = ({_e(ang)})° at {_e(_num(pose['mass_kg']))} kg "
                    f"(χ² separation {_e(_num(pose['chi2_separation'], 3))} on the channels "
                    "measured now)"
                )
            todo = "; or ".join(bits) if bits else "no measurement found that separates them"
            if pose and pose["chi2_separation"] <= CONFUSION_CHI2:
                todo += (
                    " (no pose separates them with the channels measured now: they act alike "
                    "in every pose)"
                )
            items.append(f"<li>To tell <b>{_e(pair)}</b> apart: {todo}.</li>")
        out += ["<h3>Next measurement</h3>", "<ul>" + "".join(items) + "</ul>"]
    return out


def _fitted_section(
    meas: Measurements,
    d: Diagnosis,
    cv: Mapping[str, Any] | None,
    final: FitResult | None = None,
) -> list[str]:
    best = final if final is not None else d.suggested_fit
    out = ["<h2>4. The fitted model</h2>"]
    if best is None:
        out.append("<p>No effect is suggested; the baseline stands as it is.</p>")
        return out
    rows = []
    for i, s in enumerate(best.slots):
        kind = s.kind
        est, err = best.estimate(i), best.stderr(i)
        note = "at its bound" if best.at_bound[i] else ""
        rows.append(
            [
                s.key,
                kind.param,
                _Num(est, 5),
                _Num(err, 2),
                kind.unit,
                _Num(100 * err / est if math.isfinite(est) and est else math.nan, 2, " %"),
                note,
            ]
        )
    table = _table(
        ["effect@place", "parameter", "estimate", "± stderr", "unit", "rel.", "note"], rows
    )
    rb, ra = d.baseline.rms(), best.rms()
    rms_rows = [
        [
            ch,
            _Num(rb.get(ch, math.nan), 4, f" {_unit(ch)}"),
            _Num(ra.get(ch, math.nan), 4, f" {_unit(ch)}"),
            _Num(cv["rms"].get(ch, math.nan), 4, f" {_unit(ch)}") if cv else "–",
        ]
        for ch in meas.measured_channels
    ]
    rms_rows.append(
        ["χ²/dof", _Num(d.baseline.chi2_per_dof), _Num(best.chi2_per_dof), "–"],
    )
    out += [
        f"<p>Model: {_e(_model_keys(best))}, all parameters fitted jointly "
        f"({best.problem.n_values} values, {best.n_params} "
        f"parameter{'s' if best.n_params != 1 else ''}).</p>",
        table,
        _table(["channel", "RMS baseline", "RMS fitted", "RMS cross-validated"], rms_rows),
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
                [label, *(_Num(v.get(ch, math.nan), 3) for ch in chans)] for label, v in per.items()
            ]
            out.append(
                _table(
                    ["held-out config", *(f"{ch} [{_unit(ch)}]" for ch in chans)],
                    prow,
                )
            )
    if best.warnings:
        out.append(
            '<p class="warn">' + "<br>".join(_e(w) for w in best.warnings) + "</p>",
        )
    return out


def _rounds_section(rounds: Sequence[Diagnosis], main: str) -> list[str]:
    rows = []
    for i, d in enumerate(rounds):
        top = ", ".join(c.slot.key for c in d.ranking[:3])
        rows.append(
            [
                str(i + 1),
                ", ".join(s.key for s in d.model) or "baseline",
                _Num(d.baseline.chi2_per_dof),
                _Num(d.baseline.rms().get(main, math.nan), 4),
                d.verdict,
                ", ".join(s.key for s in d.suggested) or "—",
                top,
            ]
        )
    return [
        "<h2>3b. Further rounds</h2>",
        "<p>One diagnosis searches sets of up to three effects. Each further round adds the "
        "suggested set to the model, refits, and diagnoses again.</p>",
        _table(
            ["round", "model", "χ²/dof", f"RMS {main}", "verdict", "suggested", "best alone"],
            rows,
        ),
    ]


def _ladder_section(steps: Sequence[Mapping[str, Any]], main: str, unit: str) -> list[str]:
    from . import plots

    rows = []
    for s in steps:
        cvr = s.get("cv_rms")
        rows.append(
            [
                s["label"],
                _Num(s["rms"].get(main, math.nan), 4, f" {unit}"),
                _Num(cvr.get(main, math.nan), 4, f" {unit}") if cvr else "–",
                _Num(s["chi2_per_dof"], 4),
            ]
        )
    table = _table(["step", f"RMS {main}", "cross-validated RMS", "χ²/dof"], rows)
    img = _img(
        plots.ladder(steps, channel=main),
        "error ladder",
        f"RMS of {main} (and its cross-validated value) as the suggested effects are added one "
        "at a time, every step refitted; χ²/dof on the right (1 = within the noise).",
    )
    return ["<h2>5. The error ladder</h2>", _row(table, img)]


def _residual_section(
    meas: Measurements, before: FitResult, after: FitResult, main: str
) -> list[str]:
    from . import plots

    unit = _unit(main)
    c = meas.index(main)
    rows = []
    for label in meas.configs:
        sel = (np.asarray(meas.config) == label) & before.problem.use[:, c]
        rb = float(np.sqrt(np.mean(before.residual[sel, c] ** 2))) if sel.any() else math.nan
        ra = float(np.sqrt(np.mean(after.residual[sel, c] ** 2))) if sel.any() else math.nan
        rows.append([label, _Num(rb, 3, f" {unit}"), _Num(ra, 3, f" {unit}")])
    table = _table(["config", "RMS before", "RMS after"], rows)
    img = _img(
        plots.residual_vs_payload(meas, before, after, channel=main),
        "residuals against payload",
        f"Residual of {main} against payload, per configuration: the baseline (grey, dashed) "
        "and the fitted model (blue); the band is ±1σ of the measurement.",
    )
    return ["<h2>6. Residuals against payload</h2>", _row(table, img)]


def _share_section(
    arm: Arm, meas: Measurements, final: FitResult, sw: bool, kw: Mapping[str, Any]
) -> list[str]:
    from . import plots
    from .solver import solve

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
        [label, _Num(base[i], 3), *(_Num(v[i], 3) for v in contrib), _Num(total[i], 3)]
        for i, label in enumerate(meas.configs)
    ]
    table = _table(
        ["config", "baseline [mm]", *(f"{e.key} [mm]" for e in effects), "total [mm]"],
        rows,
    )
    img = _img(
        plots.deflection_share(arm, meas, effects, self_weight=sw, mass=mass, **kw),
        "contributions to the sag",
        f"Contribution of each effect to the sag dy of the measure point at {mass:g} kg "
        "(the effect alone minus the baseline), per configuration; the diamond is the total "
        "with every effect together.",
    )
    out = [
        "<h2>7. Who makes the sag?</h2>",
        f"<p>dy of the measure point [mm] at payload {mass:g} kg, model: "
        f"{_e(', '.join(plots.effect_label(e) for e in effects) or 'baseline only')} "
        f"({_e(_model_name(**kw))}).</p>",
        _row(table, img),
    ]
    first = meas.configs[0]
    r0 = rows_idx[0]
    one = solve(arm, alpha[:1], mass, effects=effects, self_weight=sw, **kw)
    scale = _nice_scale(float(np.max(np.abs(one["dalpha_deg"]))))
    pose = _img(
        plots.arm_pose(arm, alpha[0], out=one, scale=scale),
        f"the arm in configuration {first}",
        f"Configuration {first} (α = {', '.join(f'{a:.1f}' for a in meas.alpha_deg[r0])}°) "
        f"under {mass:g} kg with the fitted model ({_model_name(**kw)}); the loaded pose is "
        f"exaggerated ×{scale:g}.",
        narrow=True,
    )
    out.append(pose)
    return out
