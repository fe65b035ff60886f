"""The report's sections on the diagnosis: the verdict told in words, the ranking, the sets
the rule judged (with its reasons), the rounds, and what no effect of the catalogue explains.

Every judgement shown here is the one made by :func:`eodarm.analysis.acceptance.accept`
inside :func:`eodarm.diagnose`; these sections only tell it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

from eodarm.analysis.acceptance import Acceptance
from eodarm.analysis.confusions import separated_by
from eodarm.analysis.consistency import P_PASS
from eodarm.analysis.diagnose import CONFUSION_CHI2, Candidate, Diagnosis
from eodarm.analysis.fit import FitResult
from eodarm.analysis.residuals import residual_pattern
from eodarm.data.measurements import Measurements
from eodarm.model.effects import Slot
from eodarm.viz import html as page
from eodarm.viz.format import parameter_name, value, value_error

__all__ = [
    "Lookalike",
    "diagnosis_section",
    "left_section",
    "lookalikes",
    "rounds_section",
    "verdict_line",
]


class Lookalike(NamedTuple):
    """A suggested effect that the data cannot tell apart from another candidate."""

    member: str  #: the suggested effect's spec
    alternative: str  #: the look-alike's spec
    value: str  #: the look-alike's value in the set refitted with it, ``"1002 ± 2.4 N/mm"``
    how: str  #: what would tell them apart (``"a dl4_mm sensor"``), ``""`` when nothing found


def lookalikes(d: Diagnosis) -> list[Lookalike]:
    """Every suggested effect's look-alikes (``Diagnosis.alternatives``), with the value each
    takes in the set and what would separate them (``Diagnosis.advice``)."""
    out = []
    for member, alts in d.alternatives.items():
        for alt in alts:
            g = d.alternative_fits.get((member, alt))
            text = ""
            if g is not None:
                j = [t.spec for t in g.slots].index(alt)
                text = value_error(g.estimate(j), g.stderr(j), g.slots[j].kind.unit)
            entry = next((a for a in d.advice if a["pair"] == [member, alt]), None)
            out.append(Lookalike(member, alt, text, separated_by(entry)))
    return out


def lookalike_html(item: Lookalike) -> str:
    """One look-alike in a sentence, for the page."""
    alt = Slot.parse(item.alternative)
    how = f"; {page.esc(item.how)} would" if item.how else "; no channel or pose found would"
    val = f" = {page.esc(item.value)}" if item.value else ""
    return (
        f"<code>{page.esc(item.member)}</code> could as well be "
        f"<b>{page.esc(parameter_name(alt.name, alt.at))}</b> "
        f"(<code>{page.esc(item.alternative)}</code>{val}): the data cannot tell them "
        f"apart{how}"
    )


def _keys(slots: Sequence[Any]) -> str:
    return ", ".join(s.key for s in slots)


def _param(param: str, unit: str, x: float, name: str = "") -> str:
    if not math.isfinite(x):
        # θ = 0: for an actuator body a rigid body, a drive's gear a rigid gear, for anything
        # else no effect.
        what = {"actuator_compliance": "rigid body", "drive_compliance": "rigid gear"}.get(
            name, "rigid: absent"
        )
        return f"{param} = ∞ ({what})"
    return f"{param} = {page.num(x, 3)} {unit}"


def _estimate(cand: Candidate) -> str:
    i = cand.fit.slots.index(cand.slot)
    kind = cand.slot.kind
    text = _param(kind.param, kind.unit, cand.fit.estimate(i), cand.slot.name)
    return text + " (at bound)" if cand.fit.at_bound[i] else text


def _in_set(d: Diagnosis, cand: Candidate) -> str:
    """A suggested candidate's estimate: its value in the suggested set, then alone."""
    f = d.suggested_fit
    if f is None:
        return _estimate(cand)
    i = [s.key for s in f.slots].index(cand.slot.key)
    kind = cand.slot.kind
    alone = cand.fit.estimate(cand.fit.slots.index(cand.slot))
    bound = " (at bound)" if cand.fit.at_bound[cand.fit.slots.index(cand.slot)] else ""
    return (
        f"{kind.param} = {value_error(f.estimate(i), f.stderr(i), kind.unit)} in the suggested "
        f"set (alone: {value(alone, kind.unit, 3)}{bound})"
    )


def verdict_line(d: Diagnosis) -> str:
    """The page's first line: the verdict and what it names."""
    if d.verdict == "missing":
        what = "suggested: <b>" + page.esc(_keys(d.suggested)) + "</b>"
        alike = [lookalike_html(x) for x in lookalikes(d)]
        if alike:
            what += " (" + "; ".join(alike) + ")"
    elif d.verdict == "unexplained":
        what = "no effect of the catalogue explains these data"
        if d.best_effort:
            what += " (best effort: " + page.esc(_keys(d.best_effort)) + ")"
    elif d.verdict == "check_data":
        what = "the data look mistaken: check them first"
    else:
        what = "nothing to add"
    v = page.esc(d.verdict)
    return f'<p>Verdict: <span class="verdict {v}">{v}</span> &nbsp; {what}</p>'


def _rule(acc: Acceptance) -> str:
    return "; ".join(acc.reasons())


def _story(d: Diagnosis, main: str, unit: str) -> str:
    if d.verdict == "check_data":  # docs/diagnosis.md, "Check the data first"
        return (
            "<b>Check the data first.</b> They look mistaken, not like a missing effect, and "
            "no effect was looked for in them:</p><ul>"
            + "".join(f"<li>{page.esc(c.message)}</li>" for c in d.data_checks)
            + "</ul><p>"
        )
    if d.verdict == "adequate":
        text = (
            "The baseline explains the data within their noise and no candidate improves it "
            "significantly: nothing is missing."
        )
        if d.examined:
            text = (
                "The baseline explains the data within their noise. A candidate improves "
                "its χ², but no set passes the rule for what is missing (below): nothing "
                "is missing."
            )
        return text
    if d.verdict == "missing" and d.acceptance is not None:
        lead = (
            "The baseline does not explain the data."
            if d.p_baseline < P_PASS
            else "The baseline's χ² is within the noise, but a candidate improves it significantly."
        )
        alike = "".join(f" But {lookalike_html(x)}." for x in lookalikes(d))
        return (
            f"{lead} The smallest set of effects that explains the data (searched over "
            f"{d.sets_searched} sets, not just the top of the ranking) is "
            f"<b>{page.esc(_keys(d.suggested))}</b>: {page.esc(_rule(d.acceptance))}.{alike}"
        )
    text = (
        "<b>No effect of the catalogue explains these data.</b> None of the "
        f"{d.sets_searched} sets of up to three candidate effects fits them within their "
        "noise with every parameter away from its bounds and predicts held-out "
        "configurations no worse than the baseline. What is missing is not in the "
        "catalogue, or the stated σ are too small."
    )
    if d.best_effort and d.best_effort_fit is not None:
        f = d.best_effort_fit
        text += (
            " As a best effort, the information criterion (BIC: χ² + k ln N) prefers "
            f"<b>{page.esc(_keys(d.best_effort))}</b> (χ²/dof "
            f"{page.esc(page.num(f.chi2_per_dof))}, RMS {page.esc(main)} "
            f"{page.esc(page.num(f.rms().get(main, math.nan), 3))} {page.esc(unit)}"
        )
        cv = d.best_effort_cv
        if cv is not None:
            text += (
                f", held out {page.esc(page.num(cv['rms'].get(main, math.nan), 3))} "
                f"{page.esc(unit)}"
            )
        text += "); it does not explain the data."
        if d.acceptance is not None:
            text += f" The rule: {page.esc(_rule(d.acceptance))}."
    else:
        text += " No set of candidates even lowers the BIC: the best effort is the model as it is."
    return text


def _examined_table(d: Diagnosis) -> str:
    judged = list(d.examined)
    acc = d.acceptance
    if acc is not None:
        # the final judgement (every criterion evaluated) replaces the search's
        same = [i for i, a in enumerate(judged) if a.keys == acc.keys]
        if same:
            judged[same[0]] = acc
        else:
            judged.append(acc)
    rows, hl = [], []
    for a in judged:
        cv = a.cv
        base = a.baseline_cv
        if not a.cv_applies:
            held = "n/a (< 3 configurations)"
        elif cv is None or base is None:
            held = "not run"
        else:
            held = f"{page.num(cv['z_rms'], 3)} / {page.num(base['z_rms'], 3)}"
        outcome = "accepted" if a.accepted else ("improves" if a.improves else "refused")
        rows.append(
            [
                ", ".join(a.keys),
                page.Num(a.fit.chi2_per_dof, 4),
                page.Raw('<span class="num">&lt; 1e-300</span>')
                if a.p_value <= 0
                else page.Num(a.p_value, 2),
                "yes" if a.consistent else "no",
                "yes" if a.away_from_bounds else "stuck: " + ", ".join(a.stuck),
                held,
                outcome,
            ]
        )
        hl.append(a.accepted)
    return page.table(
        [
            "set (added to the baseline)",
            "χ²/dof",
            "p",
            "(a) within noise",
            "(b) off its bounds",
            "(c) held-out RMS/σ: set / baseline",
            "outcome",
        ],
        rows,
        hl,
    )


def diagnosis_section(meas: Measurements, d: Diagnosis, main: str, unit: str) -> list[str]:
    """Section 3: the verdict in words, the sets the rule judged, the ranking, outliers and
    the next measurement."""
    sugg = {s.key for s in d.suggested}
    rows, hl = [], []
    # candidates that fit to no effect at all (Δχ² = 0 to rounding) are named in one line
    tiny = 1e-9 * max(1.0, d.baseline.chi2)
    idle = [c for c in d.ranking if c.delta_chi2 <= tiny and c.slot.key not in sugg]
    if len(idle) < 2:
        idle = []
    for i, c in enumerate(d.ranking, start=1):
        if c in idle:
            continue
        rows.append(
            [
                page.Num(i, 3),
                c.slot.label,
                _in_set(d, c) if c.slot.key in sugg else _estimate(c),
                page.Num(c.delta_chi2, 4),
                page.Num(c.fit.chi2_per_dof, 4),
                page.Num(c.fit.rms().get(main, math.nan), 3, f" {unit}"),
                ", ".join(c.confused_with) or "–",
            ]
        )
        hl.append(c.slot.key in sugg)
    ranking = page.table(
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
    v = page.esc(d.verdict)
    out = [
        "<h2>3. The first diagnosis (round 1): which effect is missing?</h2>",
        f'<p>Verdict: <span class="verdict {v}">{v}</span></p>',
        f"<p>{_story(d, main, unit)}</p>",
    ]
    if d.examined or d.acceptance is not None:
        out += [
            "<h3>The sets judged, in search order</h3>",
            '<p class="note">A set is what is missing when, added to the baseline with its '
            "parameters fitted, (a) its χ² is consistent with the noise (p ≥ "
            f"{page.esc(value(P_PASS))}), (b) every parameter is away from its bounds, "
            "and (c) with three or more configurations, it predicts held-out configurations "
            "(each left out of the fit in turn) no worse than the baseline, in RMS "
            "residual/σ over every measured channel. Sets are judged smallest first, better "
            "χ² first; the first accepted is suggested. “Improves”: (b) and (c) hold, "
            "the BIC falls and the data determine every added parameter (relative standard "
            "error ≤ 100 %), a step toward an explanation but not one.</p>",
            _examined_table(d),
        ]
    out += [
        "<h3>Every candidate added alone, its parameter fitted (best first)</h3>",
        '<p class="note">Highlighted: the suggested set, each with its value fitted in the '
        "set and alone. RMS of the main channel "
        f"{page.esc(main)}; "
        "Δχ² is the improvement over the baseline of the candidate alone. “Confused with” "
        "lists the candidates the data cannot tell apart from this one, each alone.</p>",
        ranking,
    ]
    if idle:
        out.append(
            f"<p>The other {len(idle)} candidates do not help alone: added alone, each fits to "
            "no effect (a rigid part, a zero gap or friction, Δχ² = 0): "
            + page.esc(", ".join(c.slot.label for c in idle))
            + ".</p>"
        )
    if d.outliers:
        orows = [
            [
                page.Num(o["line"], 6),
                o["config"],
                value(float(o["mass_kg"])),
                o["channel"],
                page.Num(o["measured"], 3),
                page.Num(o["model"], 3),
                page.Num(o["z"], 3),
            ]
            for o in d.outliers
        ]
        out += [
            "<h3>Outliers (left out of the fits)</h3>",
            page.table(
                ["line", "config", "mass [kg]", "channel", "measured", "model", "z [σ]"], orows
            ),
        ]
    if d.advice:
        from eodarm.viz.report_plan import planned_next

        out += ["<h3>Next measurement</h3>", "<ul>" + "".join(_advice(d)) + "</ul>"]
        out += planned_next(d)
    return out


def _advice(d: Diagnosis) -> list[str]:
    items = []
    for a in d.advice:
        pair = " and ".join(a["pair"])
        bits = []
        if a.get("channel"):
            ch = a["channel"]
            bits.append(
                f"measure <code>{page.esc(ch['channel'])}</code> (the two would differ by "
                f"χ² = {page.esc(page.num(ch['chi2_separation'], 3))} on the present poses)"
            )
        pose = a.get("pose")
        if pose and pose["chi2_separation"] > CONFUSION_CHI2:
            ang = ", ".join(f"{v:.1f}" for v in pose["alpha_deg"])
            bits.append(
                f"add the pose α = ({page.esc(ang)})° at "
                f"{page.esc(value(pose['mass_kg']))} kg (χ² separation "
                f"{page.esc(page.num(pose['chi2_separation'], 3))} on the channels "
                "measured now)"
            )
        if a.get("memory"):
            bits.append(page.esc(a["memory"]))
        todo = "; or ".join(bits) if bits else "no measurement found that separates them"
        if pose and pose["chi2_separation"] <= CONFUSION_CHI2:
            todo += (
                " (no pose separates them with the channels measured now: they act alike "
                "in every pose)"
            )
        which = (
            " (the suggested effect and its look-alike, in the set)" if a.get("suggested") else ""
        )
        items.append(f"<li>To tell <b>{page.esc(pair)}</b>{which} apart: {todo}.</li>")
    return items


def _round_rule(d: Diagnosis) -> str:
    acc = d.acceptance
    if d.verdict == "adequate":
        return "within the noise"
    if acc is None:
        return "no set lowers the BIC"
    if acc.accepted:
        return "accepted"
    if acc.improves:
        return "does not explain the data; improves the model: added"
    why = {
        "noise": "χ² beyond the noise",
        "bounds": "a parameter at its bound",
        "held_out": "held-out configurations predicted worse",
    }
    failed = [why[f] for f in acc.failed]
    if acc.away_from_bounds and acc.predicts is True:
        failed.append("the BIC does not fall")
    return "refused: " + ", ".join(failed)


def rounds_section(rounds: Sequence[Diagnosis], main: str) -> list[str]:
    """Section 3b: every round of the investigation and what the rule made of it."""
    rows = []
    for i, d in enumerate(rounds):
        top = ", ".join(c.slot.key for c in d.ranking[:3])
        if d.verdict == "missing":
            named = _keys(d.suggested)
        elif d.verdict == "unexplained":
            named = "best effort: " + (_keys(d.best_effort) or "none")
        else:
            named = "—"
        rows.append(
            [
                str(i + 1),
                _keys(d.model) or "baseline",
                page.Num(d.baseline.chi2_per_dof),
                page.Num(d.baseline.rms().get(main, math.nan), 3),
                d.verdict,
                named,
                _round_rule(d),
                top,
            ]
        )
    return [
        "<h2>3b. The rounds: what each added</h2>",
        "<p>One diagnosis searches sets of up to three effects. Each further round adds to "
        "the model the set the rule accepted or, when nothing explains the data, the best "
        "effort if the rule finds that it improves the model (away from its bounds, "
        "held-out configurations predicted no worse, lower BIC), refits, and diagnoses "
        "again.</p>",
        page.table(
            [
                "round",
                "model",
                "χ²/dof",
                f"RMS {main}",
                "verdict",
                "suggested / best effort",
                "the rule",
                "best alone",
            ],
            rows,
        ),
    ]


def left_section(meas: Measurements, fit: FitResult, what: str) -> list[str]:
    """Section 6b: what no effect of the catalogue explains, in words, a table and a figure.

    ``fit`` is the model whose residuals are shown; ``what`` names it in the text.
    """
    from eodarm.viz.residual_map import residual_map

    pat = residual_pattern(fit)
    cells = [
        f"{c['channel']} in configuration {c['config']} at {value(c['mass_kg'])} kg "
        f"({c['z']:+.1f}σ, line {c['line']})"
        for c in pat.largest[:3]
    ]
    rows = []
    for j, ch in enumerate(pat.channels):
        grid = pat.mean_z[:, :, j]
        flat = [
            (abs(float(grid[i, p])), i, p)
            for i in range(grid.shape[0])
            for p in range(grid.shape[1])
            if math.isfinite(float(grid[i, p]))
        ]
        _, i, p = max(flat) if flat else (0.0, 0, 0)
        rows.append(
            [
                ch,
                page.Num(float(pat.rms_z[j]), 3),
                page.Num(fit.rms().get(ch, math.nan), 3),
                f"{pat.configs[i]} at {value(float(pat.payloads[p]))} kg",
                page.Num(float(grid[i, p]), 3),
            ]
        )
    table = page.table(
        ["channel", "RMS residual/σ", "RMS residual", "largest mean at", "mean residual/σ"],
        rows,
    )
    img = page.img(
        residual_map(pat),
        "the residual pattern that is left",
        f"Mean residual/σ of {what}, per configuration (rows) and payload (columns), one "
        "panel per measured channel. The shape is what a missing mechanism would have to "
        "produce: growing with the payload or not, in some poses and not others, of one "
        "sign or both.",
    )
    return [
        "<h2>6b. What no effect of the catalogue explains</h2>",
        "<p>No effect of the catalogue explains these data; the largest remaining residuals "
        f"are {page.esc('; '.join(cells))}. By channel (residuals of {page.esc(what)}):</p>",
        table,
        img,
    ]
