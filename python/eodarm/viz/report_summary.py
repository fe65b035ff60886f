"""The report's first screen and its hand-over: the final answer, the fitted parameters as
an engineer reads them, and the fitted arm file with the commands that use it.

* :func:`answer_section`: the verdict of the *last* round, the model the investigation ends
  with, the main channel's RMS from the baseline to the final model in-sample and on held-out
  configurations against σ, what is still unexplained, and published models' errors;
* :func:`answer_lines`: the same summary as terminal lines (within 100 columns);
* :func:`parameter_section`: value ± error (two significant digits of the error), the 95 %
  interval, the correlation matrix as a heat map and the "not determined" flag;
* :func:`handover_section`: the fitted arm file embedded as a download (data URI) and the
  commands to reproduce it and to use it.
"""

from __future__ import annotations

import base64
import math
import re
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.diagnose import Diagnosis
from eodarm.analysis.fit import FitResult, determining_channel
from eodarm.data.measurements import Measurements
from eodarm.model.arm import Arm
from eodarm.viz import html as page
from eodarm.viz.format import bounded_interval, parameter_name, value, value_error
from eodarm.viz.report_cycle import CycleReturn, cycle_return, return_line, return_section
from eodarm.viz.report_diagnosis import Lookalike, lookalike_html, lookalikes
from eodarm.viz.style import channel_unit, short_channel

__all__ = [
    "Answer",
    "answer_lines",
    "answer_section",
    "handover_section",
    "parameter_section",
    "sag_word",
]


@dataclass
class Answer:
    """The numbers of the final answer, shared by the page and the terminal."""

    main: str
    unit: str
    sigma: float
    base_rms: float
    final_rms: float
    base_cv: float
    final_cv: float
    base_chi2: float
    final_chi2: float
    model: str
    n_params: int
    verdict: str
    rounds: int
    stopped: str
    left: list[tuple[str, str, float, float]] = field(default_factory=list)
    published: list[tuple[str, float]] = field(default_factory=list)
    #: the final model's effects that the data cannot tell apart from another candidate
    lookalikes: list[Lookalike] = field(default_factory=list)
    #: load cycles: what they leave at the return to zero payload (None without any)
    back: CycleReturn | None = None


def sag_word(meas: Measurements, base: FitResult) -> str | None:
    """``"less"`` when the data sag less than the baseline says, ``"more"`` when more (sum of
    |dy| over the measured rows); ``None`` without dy."""
    if "dy_mm" not in meas.measured_channels:
        return None
    c = meas.index("dy_mm")
    m = meas.measured[:, c]
    measured = float(np.sum(np.abs(meas.values[m, c])))
    model = float(np.sum(np.abs(base.prediction[m, c])))
    return "less" if measured < model else "more"


def model_words(fit: FitResult) -> str:
    """The effects of a model in words, the same kind at several places in one group:
    ``"actuator 1/2/3 body, actuator 1/2/3 mount"``; the arm file's own effects (those the fit
    did not refit) first, marked ``(arm file)``."""
    named = {e.key for e in fit.fixed} | {s.key for s in fit.slots}
    own = [e for e in getattr(fit.problem.arm, "effects", ()) if e.key not in named]
    added = _grouped_words(
        [(e.name, e.at) for e in fit.fixed] + [(s.name, s.at) for s in fit.slots]
    )
    parts = ["baseline"]
    if own:
        parts.append(_grouped_words([(e.name, e.at) for e in own]) + " (arm file)")
    if added:
        parts.append(added)
    return " + ".join(parts) if len(parts) > 1 else "the baseline (nothing added)"


def _grouped_words(effects: Sequence[tuple[str, str]]) -> str:
    """``[("mount_compliance", "M1"), ("mount_compliance", "M2")]`` → ``actuator 1/2 mount``."""
    groups: dict[tuple[str, str], list[str]] = {}
    for name, at in effects:
        n = parameter_name(name, at)
        m = re.fullmatch(r"(\D*?)(\d+)(.*)", n.replace(" stiffness", ""))
        key = (m[1], m[3]) if m else (n, "")
        groups.setdefault(key, []).append(m[2] if m else "")
    return ", ".join(f"{pre}{'/'.join(nums)}{post}" for (pre, post), nums in groups.items())


def _typ_sigma(meas: Measurements, ch: str) -> float:
    c = meas.index(ch)
    s = meas.sigma[meas.measured[:, c], c]
    return float(np.median(s)) if s.size else math.nan


def _config_rms(fit: FitResult, ch: str) -> dict[str, float]:
    meas = fit.problem.meas
    c = meas.index(ch)
    out = {}
    for label in meas.configs:
        sel = (np.asarray(meas.config) == label) & fit.problem.use[:, c]
        if sel.any():
            out[label] = float(np.sqrt(np.mean(fit.residual[sel, c] ** 2)))
    return out


def make_answer(
    meas: Measurements,
    base: FitResult,
    base_cv: Mapping[str, float] | None,
    final: FitResult,
    final_cv: Mapping[str, float] | None,
    rounds: Sequence[Diagnosis],
    stopped: str,
    main: str,
    published: Sequence[tuple[str, float]] = (),
) -> Answer:
    """Collect the answer's numbers: the baseline and the final model, each with its
    held-out RMS per channel (``None`` when not computed), and the rounds."""

    left = []
    for ch in meas.measured_channels:
        per = _config_rms(final, ch)
        if per:
            worst = max(per, key=lambda k: per[k])
            left.append((ch, worst, per[worst], per[worst] / _typ_sigma(meas, ch)))
    left.sort(key=lambda t: -t[3])
    keys = {s.spec for s in final.slots}
    alike = [x for d in rounds for x in lookalikes(d) if x.member in keys]
    return Answer(
        main=main,
        unit=channel_unit(main),
        sigma=_typ_sigma(meas, main),
        base_rms=float(base.rms().get(main, math.nan)),
        final_rms=float(final.rms().get(main, math.nan)),
        base_cv=float((base_cv or {}).get(main, math.nan)),
        final_cv=float((final_cv or {}).get(main, math.nan)),
        base_chi2=float(base.chi2_per_dof),
        final_chi2=float(final.chi2_per_dof),
        model=model_words(final),
        n_params=final.n_params,
        verdict=rounds[-1].verdict if rounds else "adequate",
        rounds=len(rounds),
        stopped=stopped,
        left=left,
        published=list(published),
        lookalikes=alike,
        back=cycle_return(meas, base, final, main),
    )


def _verdict_words(a: Answer) -> str:
    if a.verdict == "adequate":
        return "the final model explains the data within their noise"
    if a.verdict == "missing":
        return "something is still missing (the rounds ran out)"
    if a.verdict == "check_data":
        return "the data look mistaken (a unit, a sign, a zeroing): check them first"
    return "no effect of the catalogue explains what is left"


def answer_lines(a: Answer) -> list[str]:
    """The answer as terminal lines, each within 100 columns."""
    u, s = a.unit, a.sigma
    ch = short_channel(a.main)
    lines = [
        f"final model: {a.model} ({a.n_params} fitted)",
        f"last round ({a.rounds}): {a.verdict}: {_verdict_words(a)}",
        (
            f"{ch} RMS in-sample {a.base_rms:.3g} → {a.final_rms:.3g} {u}, held out "
            f"{a.base_cv:.3g} → {a.final_cv:.3g} {u} (σ {s:.2g} {u}: {a.final_cv / s:.1f}σ "
            "held out)"
            if math.isfinite(a.final_cv) and math.isfinite(a.base_cv)
            else f"{ch} RMS in-sample {a.base_rms:.3g} → {a.final_rms:.3g} {u} (σ {s:.2g} {u}; "
            "not cross-validated: fewer than two configurations)"
        ),
    ]
    if a.back is not None:
        lines.append(return_line(a.back))
    for x in a.lookalikes:
        how = f"; {x.how} would" if x.how else "; no channel or pose found would"
        lines.append(
            f"look-alike: {x.member} could as well be {x.alternative}"
            + (f" = {x.value}" if x.value else "")
            + f": the data cannot tell them apart{how}"
        )
    if a.published:
        lines.append("published models: " + "; ".join(f"{n} {v:.3g} {u}" for n, v in a.published))
    if a.left:
        bits = [
            f"{short_channel(c)} {cfg} {v:.2g} {channel_unit(c)}" for c, cfg, v, _ in a.left[:3]
        ]
        lines.append("largest residual RMS left (channel, configuration): " + ", ".join(bits))
    out: list[str] = []
    for line in lines:
        out += textwrap.wrap(line, 100, subsequent_indent="  ")
    return out


def _held_words(a: Answer) -> str:
    """The held-out half of the answer's RMS sentence, against σ."""
    u, s = a.unit, a.sigma
    if not math.isfinite(a.final_cv):
        return (
            f"not cross-validated (fewer than two configurations); typical σ {page.num(s, 2)} "
            f"{u}: {page.num(a.final_rms / s, 2)}σ in-sample."
        )
    z = a.final_cv / s
    tail = "still " if z > 2 else ""
    return (
        f"<b>{page.num(a.final_cv, 3)} {u}</b> on held-out configurations, against a typical "
        f"σ of {page.num(s, 2)} {u}: {tail}{page.num(z, 2)}σ."
    )


def answer_section(
    a: Answer, meas: Measurements, base: FitResult, final: FitResult, kw_model: str
) -> list[str]:
    """The report's first section: the final answer and its measured-vs-model figure."""
    from eodarm.viz import plots

    u, s = a.unit, a.sigma
    ch = short_channel(a.main)
    v = page.esc(a.verdict)
    rows: list[list[Any]] = [
        [
            "in-sample RMS",
            page.Num(a.base_rms, 3, f" {u}"),
            page.Num(a.final_rms, 3, f" {u}"),
            page.Num(a.final_rms / s, 2, " σ"),
        ],
        [
            "held-out RMS (each configuration predicted without its own data)",
            page.Num(a.base_cv, 3, f" {u}"),
            page.Num(a.final_cv, 3, f" {u}"),
            page.Num(a.final_cv / s, 2, " σ"),
        ],
        ["χ²/dof (1 = within the noise)", page.Num(a.base_chi2, 4), page.Num(a.final_chi2, 4), ""],
    ]
    # with an arm file that carries effects, the starting model is the file's, not the baseline
    start = "arm file's model" if getattr(base.problem.arm, "effects", ()) else "baseline"
    table = page.table([f"{ch}", start, "final model", "final / typical σ"], rows)
    pub = ""
    if a.published:
        pub = (
            "<p>Published models on the same measurements (not fitted to them, so their error "
            "is already out-of-sample): "
            + "; ".join(f"{page.esc(n)}: <b>{page.num(x, 3)} {u}</b> RMS" for n, x in a.published)
            + f". The final model predicts held-out configurations to <b>{page.num(a.final_cv, 3)}"
            f" {u}</b>.</p>"
        )
    left_rows = [
        [
            c,
            cfg,
            page.Num(rms, 3, f" {channel_unit(c)}"),
            page.Num(z, 2, " σ"),
        ]
        for c, cfg, rms, z in a.left
    ]
    left = page.table(
        ["channel", "worst configuration", "its RMS residual", "in units of typical σ"],
        left_rows,
    )
    fig = plots.measured_vs_model(meas, {start: base, "final model": final})
    img = page.img(
        fig,
        f"measured against model: {start} and final model",
        f"Measured (x, ±σ) against model (y), per channel: the {start} (open markers) and the "
        "final model (filled), coloured by configuration; on the dotted line y = x the model "
        f"is right. Each panel's axes fit the final model; the {start}'s points beyond them are "
        "counted in the panel's title.",
    )
    return [
        "<h2>The answer</h2>",
        f'<p class="answer">Final model: <b>{page.esc(a.model)}</b> '
        f"({a.n_params} parameter{'s' if a.n_params != 1 else ''} fitted jointly, "
        f"{page.esc(kw_model)})."
        + "".join(
            f'<br><span class="warn">Look-alike: {lookalike_html(x)}.</span>' for x in a.lookalikes
        )
        + "<br>"
        f'Last round ({a.rounds}): <span class="verdict {v}">{v}</span> '
        f"{page.esc(_verdict_words(a))}"
        + (
            f"; the investigation stopped because {page.esc(a.stopped)}"
            if a.stopped and a.verdict != "adequate"
            else ""
        )
        + ".</p>",
        f'<p class="answer">{page.esc(ch)} RMS <b>{page.num(a.base_rms, 3)} → '
        f"{page.num(a.final_rms, 3)} {u}</b> in-sample, " + _held_words(a) + "</p>",
        table,
        pub,
        *(return_section(a.back, meas, base, final) if a.back is not None else []),
        "<h3>What is left</h3>",
        '<p class="note">For every measured channel, the configuration where the final model '
        "misses most (RMS residual over its payloads), worst first in units of σ.</p>",
        left,
        img,
    ]


# ---------------------------------------------------------------------------- parameters
def _percent(rel: float) -> str:
    if not math.isfinite(rel):
        return "∞"
    return f"{100 * rel:.2g} %" if rel < 0.1 else f"{100 * rel:.0f} %"


def _correlation_figure(fit: FitResult) -> Any:
    from matplotlib.colors import TwoSlopeNorm

    from eodarm.viz.style import figure

    corr = fit.correlation()
    k = len(fit.slots)
    names = [f"{parameter_name(s.name, s.at)}" for s in fit.slots]
    fig = figure(2.2 + 0.75 * k + 2.2, 1.4 + 0.6 * k)
    ax = fig.add_subplot()
    im = ax.imshow(corr, cmap="RdBu_r", norm=TwoSlopeNorm(0.0, -1.0, 1.0))
    for i in range(k):
        for j in range(k):
            x = corr[i, j]
            if not math.isfinite(x):
                txt = "—"
            elif abs(x) < 0.005:
                txt = "0"
            else:
                txt = f"{x:+.2f}".replace("-", "−")
            ax.text(
                j,
                i,
                txt,
                ha="center",
                va="center",
                fontsize="x-small",
                color="white" if math.isfinite(x) and abs(x) > 0.6 else "black",
            )
    ax.set_xticks(range(k), [f"#{i + 1}" for i in range(k)])
    ax.set_yticks(range(k), [f"#{i + 1} {n}" for i, n in enumerate(names)], fontsize="small")
    fig.colorbar(im, ax=ax, shrink=0.8, label="correlation")
    ax.set_title("Correlation of the fitted parameters", fontsize="medium")
    return fig


def parameter_section(
    fit: FitResult, meas: Measurements, alike: Sequence[Lookalike] = ()
) -> list[str]:
    """The fitted parameters as a table and their correlation as a heat map; ``alike``: the
    look-alikes of the fitted effects, noted on their rows."""
    flagged = dict(fit.undetermined())
    rows, hl = [], []
    for i, s in enumerate(fit.slots):
        kind = s.kind
        est, err = fit.estimate(i), fit.stderr(i)
        rel = err / abs(est) if math.isfinite(est) and est and math.isfinite(err) else math.nan
        span = bounded_interval(*fit.interval(i), kind.unit, err, held=fit.only_lower_limit(i))
        note = ""
        if fit.at_bound[i]:
            note = "at its bound"
        elif i in flagged:
            lo, hi = fit.interval(i)
            fixed = (
                f"the fitted file treats it as rigid (stiffer than {value(lo, kind.unit, 3)})"
                if math.isinf(hi) and kind.compliance_like
                else "the fitted file marks it 'determined = false'"
            )
            note = (
                f"NOT DETERMINED ({flagged[i]}): fix it or drop it ({fixed}); to determine "
                f"it, {determining_channel(s, meas.measured_channels, fit.only_lower_limit(i))}"
            )
        for x in alike:
            if x.member == s.spec:
                how = f"; {x.how} would" if x.how else ""
                note = (note + "; " if note else "") + (
                    f"LOOK-ALIKE: could as well be {x.alternative}"
                    + (f" = {x.value}" if x.value else "")
                    + f" (the data cannot tell them apart{how})"
                )
        rows.append(
            [
                f"#{i + 1} {parameter_name(s.name, s.at)}",
                page.Raw(f"<code>{page.esc(s.key)}</code>"),
                page.Raw(f'<span class="num">{page.esc(value_error(est, err, kind.unit))}</span>'),
                page.Raw(f'<span class="num">{page.esc(span)}</span>'),
                page.Raw(f'<span class="num">{_percent(rel)}</span>'),
                note,
            ]
        )
        hl.append(i in flagged or any(x.member == s.spec for x in alike))
    table = page.table(
        ["parameter", "identifier", "value ± standard error", "95 % interval", "rel.", "note"],
        rows,
        hl,
    )
    out = [
        "<h2>The fitted parameters</h2>",
        "<p>Each value is rounded to the second significant digit of its standard error; "
        "the 95 % interval is θ ± 1.96 standard errors in the parameter the fit works in "
        "(1/stiffness for a spring, the gap itself for play and clearance), mapped back, so "
        "that it never crosses a physical bound: a stiffness whose interval reaches θ = 0 "
        "reads ≥ its lower end (up to rigid), and so does a friction that could hold every "
        "measured state (no load change reached it: load the arm harder to bound it). A "
        "parameter is <b>not determined</b> when its relative error exceeds 100 % or its "
        "correlation with another parameter exceeds 0.95 in magnitude: the data then allow "
        "almost any value, and the model is better with it fixed or dropped.</p>",
        table,
    ]
    if len(fit.slots) >= 2:
        caption = (
            "Correlation between the fitted parameters (+1: the data trade one for the "
            "other; 0: independent)."
        )
        keys = {s.key for s in fit.slots}
        if any(
            f"actuator_compliance@{s.at}" in keys and s.name == "mount_compliance"
            for s in fit.slots
        ):
            caption += (
                " A body spring and a mount spring of the same actuator act in series on the "
                "same motion: only the actuator's own length sensor (dlK_mm) tells them apart, "
                "and without it they correlate near ±1."
            )
        out.append(
            page.img(
                _correlation_figure(fit),
                "correlation of the fitted parameters",
                caption,
                narrow=True,
            )
        )
    return out


# ---------------------------------------------------------------------------- hand-over
def _branch_paragraph(
    fitted: Arm, alpha: npt.NDArray[np.float64], mass: float, self_weight: bool
) -> list[str]:
    """With friction in the fitted model: which branch solve and compensate answer on, and
    the hysteresis band at the pose of the commands (eodarm.model.hysteresis.band) against
    the loading branch's 2σ, which does not cover it."""
    from eodarm.model.hysteresis import band, has_memory

    if not has_memory(fitted, None):
        return []
    width = float(band(fitted, alpha[None, :], mass, None, self_weight)[0])
    sigma = ""
    if fitted.fit is not None:
        from eodarm.model.solver import solve

        got = solve(fitted, alpha[None, :], mass, self_weight=self_weight, uncertainty=True)
        two = 2 * float(np.hypot(got["sigma_dx_mm"][0], got["sigma_dy_mm"][0]))
        sigma = f", against a 2σ of {value(two, 'mm', 2)} on the loading branch"
    where = "/".join(f"{a:g}" for a in alpha)
    return [
        "<p>The fitted model holds friction, so its answers depend on the way the payload "
        "came: <code>solve</code> and <code>compensate</code> answer on the <b>loading "
        "branch</b> (the payload put on from the unloaded pose). Reached by unloading from a "
        f"heavier payload, the same {value(mass, 'kg', 3)} at α = {page.esc(where)}° puts the "
        f"measure point {value(width, 'mm', 3)} away (the hysteresis band){sigma}. "
        "<code>solve --uncertainty</code> and <code>compensate</code> give the band per pose "
        "(docs/compensation.md §4).</p>"
    ]


def _grid(meas: Measurements, k: int) -> str:
    a = meas.alpha_deg[:, k]
    lo, hi = math.floor(float(np.min(a)) / 5) * 5, math.ceil(float(np.max(a)) / 5) * 5
    return f"{lo:g}:{hi:g}:5"


def handover_section(
    fit: FitResult,
    arm: Arm,
    meas: Measurements,
    meas_path: str,
    arm_path: str,
    setup: str | None = None,
) -> list[str]:
    """The fitted arm file as a download link and the commands that reproduce and use it."""
    from eodarm.analysis.handover import fitted_arm, settle

    outliers = np.isfinite(meas.values) & ~fit.problem.use
    final = settle(fit, exclude=outliers if outliers.any() else None)
    fitted = fitted_arm(final, data=str(meas.source))
    template = None
    source = Path(arm.source)
    if source.suffix == ".toml" and source.is_file():
        template = source.read_text(encoding="utf-8-sig")  # the user's comments survive
    text = fitted.to_toml(template)
    bounded = "".join(
        f"; {e.key} is not determined: {'stiffer than' if m.bound == 'lower' else 'at most'} "
        f"{value(m.limit or 0.0, e.kind.unit, 3)}, treated as "
        f"{'rigid' if m.bound == 'lower' else 'absent'}"
        for e, m in fitted.bounded()
    )
    rec = fitted.fit
    honest = (
        " The model does not explain its data, so every σ predicted from the file includes its "
        "held-out inadequacy ("
        + ", ".join(f"{ch} {v:.2g}" for ch, v in rec.sigma_model)
        + "; docs/model.md, Prediction errors)."
        if rec is not None and rec.explained is False
        else ""
    )
    uri = "data:application/toml;base64," + base64.b64encode(text.encode("utf-8")).decode()
    adds = " ".join(f"--add {s.key}" for s in fit.slots)
    row0 = int(np.flatnonzero(np.asarray(meas.config) == meas.configs[0])[0])
    alpha = ",".join(f"{x:.1f}" for x in meas.alpha_deg[row0])
    mass = float(np.max(meas.mass_kg))
    grids = " ".join(f"--alpha{k + 1} {_grid(meas, k)}" for k in range(arm.n))
    cmds = []
    if setup:
        cmds.append(("get the data", setup))
    cmds += [
        (
            "reproduce the fit",
            f"eodarm fit {meas_path} --arm {arm_path} {adds} -o fitted.toml",
        ),
        (
            "deflections with their uncertainty",
            f"eodarm solve --arm fitted.toml --alpha {alpha} --mass {mass:g} --uncertainty",
        ),
        (
            "maps over the working range",
            f"eodarm sweep --arm fitted.toml {grids} --mass {mass:g} -o sweep.nc --plot maps",
        ),
        (
            "the angles to command so that the loaded arm reaches its pose",
            f"eodarm compensate --arm fitted.toml --alpha {alpha} --mass {mass:g}",
        ),
    ]
    items = "".join(
        f"<li>{page.esc(what)}:<br><code>{page.esc(cmd)}</code></li>" for what, cmd in cmds
    )
    branch = _branch_paragraph(fitted, meas.alpha_deg[row0], mass, fit.problem.self_weight)
    return [
        "<h2>Take the model with you</h2>",
        f'<p><a download="fitted.toml" href="{uri}">Download the fitted arm file '
        "(fitted.toml)</a>: the arm with the final model's effects at their fitted values, "
        "each with its standard error, and a <code>[fit]</code> table with their covariance "
        f"(χ²/dof {page.num(final.chi2_per_dof, 4)}, {final.problem.n_values} values). Solving "
        "it gives exactly the final model of this report, with what the data do not determine "
        f"fixed at its physical end{page.esc(bounded)}.{page.esc(honest)}</p>",
        f"<ul>{items}</ul>",
        *branch,
        f"<details><summary>The fitted file, as embedded ({value(len(text), digits=6)} "
        f"characters)</summary><pre>{page.esc(text)}</pre></details>",
    ]
