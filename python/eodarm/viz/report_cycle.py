"""The report of load cycles: where the arm comes back after the payload comes off.

A load cycle's engineering answer is the return to zero load ("the arm comes back 0.2 mm
short"): :func:`cycle_return` collects it per sequence, :func:`return_section` puts it on the
report's first screen with the loops large enough to read, :func:`return_line` says it in the
terminal, and :func:`loops_section` keeps every channel of every sequence further down.
Numbers from :func:`eodarm.analysis.sequences.hysteresis`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from eodarm.analysis.fit import FitResult
from eodarm.analysis.sequences import hysteresis
from eodarm.data.measurements import Measurements
from eodarm.viz import html as page
from eodarm.viz.format import channel_value, plural, value
from eodarm.viz.style import channel_unit, short_channel

__all__ = ["CycleReturn", "cycle_return", "loops_section", "return_line", "return_section"]

#: |left| beyond this many σ of the measurement is a return the data show (2σ: 95 %).
SHOWN_Z = 2.0


@dataclass
class CycleReturn:
    """What the load cycles leave at the return to zero payload, in the main channel.

    ``rows`` holds, per sequence that ends at 0 kg, ``(config, measured, baseline, final
    model, σ)``; ``worst`` indexes the sequence left furthest from its reference (measured);
    ``others`` the other measured channels at that return, ``(channel, measured, model)``.
    """

    channel: str
    rows: list[tuple[str, float, float, float, float]] = field(default_factory=list)
    worst: int = 0
    others: list[tuple[str, float, float]] = field(default_factory=list)
    not_back: int = 0  #: sequences that do not end at 0 kg

    @property
    def unit(self) -> str:
        return channel_unit(self.channel)

    @property
    def shown(self) -> bool:
        """Whether some return is beyond :data:`SHOWN_Z` σ of its measurement."""
        return any(abs(m) > SHOWN_Z * s for _, m, _, _, s in self.rows if math.isfinite(m))


def cycle_return(
    meas: Measurements, base: FitResult, final: FitResult, main: str
) -> CycleReturn | None:
    """The returns of ``meas``'s load sequences in channel ``main`` (None without
    sequences, or when no sequence comes back to 0 kg)."""
    seqs = hysteresis(meas, final.prediction, base.prediction)
    if not seqs:
        return None
    out = CycleReturn(main)
    for h in seqs:
        left = h["left"]
        if not isinstance(left, dict) or main not in left:
            out.not_back += 1
            continue
        j = list(h["channels"]).index(main)  # type: ignore[call-overload]
        before = float(np.asarray(h["before"])[-1, j])  # type: ignore[call-overload]
        sigma = float(np.asarray(h["sigma"])[-1, j])  # type: ignore[call-overload]
        measured, model = left[main]
        out.rows.append((str(h["config"]), measured, before, model, sigma))
    if not out.rows:
        return None
    size = [abs(m) if math.isfinite(m) else -1.0 for _, m, _, _, _ in out.rows]
    out.worst = int(np.argmax(size))
    worst = seqs[[str(h["config"]) for h in seqs].index(out.rows[out.worst][0])]["left"]
    assert isinstance(worst, dict)
    out.others = [(ch, m, mo) for ch, (m, mo) in worst.items() if ch != main]
    return out


def _where(r: CycleReturn, x: float) -> str:
    """Where the measure point stays, in words: below or above its reference for dy, off it
    for another channel."""
    if r.channel == "dy_mm":
        return f"{channel_value(abs(x), r.unit)} {'below' if x < 0 else 'above'} its reference"
    if r.channel == "dx_mm":
        side = "behind" if x < 0 else "ahead of"
        return f"{channel_value(abs(x), r.unit)} {side} its reference"
    return f"{channel_value(x, r.unit)} off its reference in {short_channel(r.channel)}"


def _span(values: list[float], unit: str) -> str:
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return "—"
    lo, hi = min(finite), max(finite)
    if channel_value(lo, unit) == channel_value(hi, unit):
        return channel_value(lo, unit)
    return f"{channel_value(lo, unit).removesuffix(' ' + unit)} to {channel_value(hi, unit)}"


def return_words(r: CycleReturn) -> str:
    """The return to zero load in a sentence or two (plain text)."""
    config, measured, _, model, sigma = r.rows[r.worst]
    ch = short_channel(r.channel)
    n = len(r.rows)
    if r.shown:
        head = (
            f"After the payload comes off, the arm does not come back: in sequence {config} "
            f"the measure point stays {_where(r, measured)} ({ch} {channel_value(measured, r.unit)}"
            f" measured, σ {value(sigma, r.unit, 2)}; the final model "
            f"{channel_value(model, r.unit)})."
        )
    else:
        head = (
            f"After the payload comes off, the arm comes back within the noise: at most "
            f"{ch} {channel_value(measured, r.unit)} (σ {value(sigma, r.unit, 2)}) in sequence "
            f"{config}; the final model {channel_value(model, r.unit)}."
        )
    if n > 1:
        head += (
            f" Over the {plural(n, 'sequence')}: {_span([m for _, m, _, _, _ in r.rows], r.unit)}"
            f" measured, {_span([a for _, _, _, a, _ in r.rows], r.unit)} by the final model"
        )
        before = [b for _, _, b, _, _ in r.rows]
        if all(abs(b) < 1e-6 for b in before):
            head += "; the baseline, without memory, comes back to 0."
        else:
            head += f", {_span(before, r.unit)} by the baseline."
    if r.not_back:
        head += f" ({plural(r.not_back, 'sequence')} do not end at 0 kg.)".replace(
            "1 sequence do ", "1 sequence does "
        )
    return head


def return_line(r: CycleReturn) -> str:
    """The return in one terminal line (the report's summary)."""
    config, measured, _, model, sigma = r.rows[r.worst]
    ch = short_channel(r.channel)
    if not r.shown:
        return (
            f"return to 0 kg: within the noise (at most {ch} {channel_value(measured, r.unit)}, "
            f"σ {value(sigma, r.unit, 2)}, in {config}; final model {channel_value(model, r.unit)})"
        )
    return (
        f"return to 0 kg: the arm stays {_where(r, measured)} in {config} ({ch} "
        f"{channel_value(measured, r.unit)} measured, final model {channel_value(model, r.unit)})"
    )


def return_section(
    r: CycleReturn, meas: Measurements, base: FitResult, final: FitResult
) -> list[str]:
    """The first screen's block on the return to zero load: the answer in words, the
    return of every sequence, and the loops drawn large."""
    from eodarm.viz import hysteresis as loops_fig

    u = r.unit
    rows = [
        [
            config,
            page.Raw(f'<span class="num">{page.esc(channel_value(m, u))}</span>'),
            page.Raw(f'<span class="num">{page.esc(channel_value(b, u))}</span>'),
            page.Raw(f'<span class="num">{page.esc(channel_value(a, u))}</span>'),
            page.Raw(f'<span class="num">{page.esc(value(s, u, 2))}</span>'),
        ]
        for config, m, b, a, s in r.rows
    ]
    hl = [i == r.worst for i in range(len(rows))]
    ch = short_channel(r.channel)
    table = page.table(
        ["sequence", f"{ch} left at 0 kg: measured", "baseline", "final model", "σ"], rows, hl
    )
    others = ""
    if r.others:
        others = (
            f'<p class="note">At that return ({page.esc(r.rows[r.worst][0])}) the other '
            "channels, measured (final model): "
            + page.esc(
                "; ".join(
                    f"{short_channel(c)} {channel_value(m, channel_unit(c))} "
                    f"({channel_value(mo, channel_unit(c))})"
                    for c, m, mo in r.others
                )
            )
            + ".</p>"
        )
    img = page.img(
        loops_fig.loops(meas, base, final, channel=r.channel, panel_width=4.2),
        "hysteresis loops",
        f"{ch} against payload for each load sequence: the measured states (black, ±1σ "
        "bars) in the order they were applied (arrows), the baseline (grey, dashed) and the "
        "final model (blue). A model without memory has one curve for both branches; "
        "friction opens a loop and leaves the arm off its reference at the return (each "
        "panel's title).",
    )
    return [
        "<h3>The return to zero load</h3>",
        f'<p class="answer">{page.esc(return_words(r))}</p>',
        table,
        others,
        img,
    ]


def loops_section(meas: Measurements, before: FitResult, after: FitResult, main: str) -> list[str]:
    """Further down: every channel of every sequence on its loading and unloading branch,
    measured and the fitted model (the loops themselves are on the first screen)."""
    return [
        "<h2>Load cycles: every channel</h2>",
        f"<p>The return of {page.esc(short_channel(main))} and the loops are in “The answer”. "
        "Here every channel of every sequence on its loading and unloading branch, "
        "measured and the fitted model, and what is left at the return to zero payload:</p>",
        *_loop_tables(meas, after),
    ]


def _loop_tables(meas: Measurements, after: FitResult) -> list[str]:
    """One folded table per sequence: step, payload, branch, each channel measured / model."""
    out = []
    for h in hysteresis(meas, after.prediction):
        chans = list(h["channels"])  # type: ignore[call-overload]
        meas_v = np.asarray(h["measured"])
        model_v = np.asarray(h["model"])
        head = ["step", "kg", "branch"] + [
            f"{short_channel(ch)} [{channel_unit(ch)}] measured / model" for ch in chans
        ]
        rows = []
        for s, (step, kg, br) in enumerate(
            zip(h["step"], h["mass_kg"], h["branch"], strict=True)  # type: ignore[call-overload]
        ):
            cells: list[Any] = [str(step), value(kg), br]
            cells += [
                f"{_bare(meas_v[s, j], ch)} / {_bare(model_v[s, j], ch)}"
                for j, ch in enumerate(chans)
            ]
            rows.append(cells)
        left = h["left"]
        note = (
            "does not return to 0 kg"
            if not isinstance(left, dict)
            else "left at 0 kg: "
            + "; ".join(
                f"{short_channel(ch)} {channel_value(m, channel_unit(ch))} (model "
                f"{channel_value(mo, channel_unit(ch))})"
                for ch, (m, mo) in left.items()
            )
        )
        out.append(
            f"<details><summary>sequence {page.esc(h['config'])}: {page.esc(note)}</summary>"
            + page.table(head, rows)
            + "</details>"
        )
    return out


def _bare(x: float, channel: str) -> str:
    """A channel's value without its unit (the column's heading has it)."""
    unit = channel_unit(channel)
    return channel_value(x, unit).removesuffix(f" {unit}")
