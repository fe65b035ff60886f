"""The lab's mistakes named before any verdict: a channel in the wrong unit or with its sign
flipped, sequences zeroed with the first payload on (docs/diagnosis.md, "Check the data
first").

A mistake of this kind makes every model miss, and the diagnosis would call the data
*unexplained* and search the catalogue for what no effect is. :func:`check_data` holds the
data against the baseline model (the arm file as it is, its own effects included) before
any fit and names what it sees, one line each, with the fix:

**Scale and sign of a channel.** Over the cells where the model predicts a measurable value
(|model| ≥ :data:`MEASURABLE` σ, at least :data:`MIN_CELLS` of them), each cell's ratio
measured/model is taken; k is their median (robust to a few bad cells). The baseline must
miss the channel beyond its noise (χ² p-value below
:data:`~eodarm.analysis.consistency.P_PASS`), and then

* k within a factor :data:`SCALE_TOLERANCE` of 1/1000 or of 1000, with at least
  :data:`MIN_SHARE` of the ratios in that window: a length in metres (or microns) in an
  ``_mm`` column, an angle in other units in a ``_deg`` column;
* k between −4 and −1/4, with at least :data:`MIN_SHARE` of the ratios negative: the
  channel's sign is flipped.

When channels read 1/1000 of the model and the payloads are more than the arm can carry
(:func:`eodarm.data.plausible.payload_hint`: over ten times its own mass, a thousandth of
it not), the masses are in grams, not the channels in metres: one check names ``mass_kg``
instead (a mass 1000 times too large makes the model 1000 times too large on every channel,
the angles too).

Why these rules do not fire on an honest arm that the model gets wrong: no missing effect of
the catalogue turns a channel over in nearly every state (every compliance, gap and bending
adds to the sag it shares the load path with; the forces, and so the sign of every body's
length change, come from the undeformed geometry whatever the effects; a friction takes from
a deformation, down to nothing, never beyond), and none scales a channel by a thousand: the
seed arm's bodies, forty times stiffer than its file says, make its ``dlK_mm`` read 1/40 of
the model, a factor 5 from the window. A channel that a friction holds reads its noise, whose
ratios scatter about 0 and not about 1/1000. Every catalogue effect hidden in synthetic data
at two sizes, alone and in pairs, on five arms, with and without load cycles, on five
selections of channels (4 440 data sets), made none of these checks fire, and every verdict
of the tests with hidden effects is unchanged (``tests/test_datacheck.py``). The price: a
channel whose mistake sits on top of a model that misses by a varying factor of 2 to 6
(a soft mount, a clearance) may not be named (16 of 659 such files in the same study, none
where the model was right).

**Sequences zeroed with the first payload on** (files with a ``step`` column). The first
loaded state of a sequence reads 0 on every measured channel where the model expects a
clearly non-zero reading (its χ² against 0 at least 25), and the later states read the model
*less that first state*: that shifted model misses them at most a quarter as much as the
model does (in χ²), and by at least 25 less. A friction that holds the whole first payload
also reads 0 there, within the noise, and on a loading branch it too reads about the model
less a constant. What tells them apart is the way back: on the unloading branch and at the
return a friction stays on the sagging side, where a zeroed sensor reads the other way, and
the model wins. So a first state that reads 0 within the noise (|y| ≤ 3σ) is called zeroed
only in a sequence that unloads (a payload below an earlier one); a first state that reads
exactly 0 on every channel (a sensor zeroed there, not noise) is called zeroed on the
loading branch alone.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from eodarm.analysis.consistency import P_PASS, chi2_p_value
from eodarm.data.measurements import Measurements
from eodarm.errors import show
from eodarm.model.arm import Arm

__all__ = [
    "MEASURABLE",
    "MIN_CELLS",
    "MIN_SHARE",
    "SCALE_TOLERANCE",
    "DataCheck",
    "check_data",
]

Problem_ = Literal["scale", "sign", "zeroed"]
FloatArray = npt.NDArray[np.float64]

#: A cell's model value is measurable when it is at least this many σ from zero.
MEASURABLE = 3.0
#: Fewest measurable cells for a channel's ratio to the model.
MIN_CELLS = 3
#: At least this share of a channel's measurable cells must agree with the mistake.
MIN_SHARE = 0.9
#: How far (a factor either way) the ratio may be from 1/1000 or 1000 to be a unit slip.
SCALE_TOLERANCE = 5.0
#: The ratio of a flipped sign: between −4 and −1/4 (the model may miss by a factor).
SIGN_RANGE = (-4.0, -0.25)
#: A first loaded state reads 0 when every channel is within this many σ of 0.
ZERO_Z = 3.0
#: The model must expect that state at least this far from 0 (χ²), and the shifted model
#: must miss the later states by at least this much less than the model.
ZEROED_CHI2 = 25.0
#: ... and at most this fraction of the model's χ² there.
ZEROED_RATIO = 0.25

_SIGN_WHY = {
    "dx_mm": "x points away from the chassis",
    "dy_mm": "a sag is negative",
    "dalpha_deg": "angles turn counter-clockwise",
    "dl_mm": "a shortening is negative",
}


@dataclass(frozen=True)
class DataCheck:
    """A mistake the data look like, in one line (:attr:`message`) that says how to fix it.

    Attributes
    ----------
    channel : the channel, or ``None`` for a check of whole states (``"zeroed"``).
    problem : ``"scale"`` (a unit slip), ``"sign"`` (a flipped sign) or ``"zeroed"``
        (sequences zeroed with the first payload on).
    message : the line the commands print (under 300 characters).
    ratio : the channel's ratio to the model (``"scale"``, ``"sign"``); NaN otherwise.
    configs : the sequences concerned (``"zeroed"``).
    """

    channel: str | None
    problem: Problem_
    message: str
    ratio: float = math.nan
    configs: tuple[str, ...] = field(default=())

    def to_json(self) -> dict[str, Any]:
        """``{"channel", "problem", "message"}``, with ``"ratio"`` for a channel's scale or
        sign and ``"configs"`` for zeroed sequences."""
        out: dict[str, Any] = {
            "channel": self.channel,
            "problem": self.problem,
            "message": self.message,
        }
        if math.isfinite(self.ratio):
            out["ratio"] = self.ratio
        if self.configs:
            out["configs"] = list(self.configs)
        return out


def check_data(
    arm: Arm,
    meas: Measurements,
    self_weight: bool = True,
    model: str = "analytic",
    fem_options: Mapping[str, Any] | None = None,
) -> list[DataCheck]:
    """The mistakes the data look like against the baseline model (module notes); empty
    when none.

    Parameters
    ----------
    arm : the arm (its file's effects are part of the baseline).
    meas : the measurements.
    self_weight, model, fem_options : as :func:`eodarm.fit`.
    """
    from eodarm.analysis.problem import Problem

    if meas.n_values == 0:
        return []
    prob = Problem(arm, meas, self_weight=self_weight, model=model, fem_options=fem_options)
    pred, _ = prob.evaluate([], nan_on_failure=True)
    out = [
        c
        for j, ch in enumerate(meas.channels)
        if (c := _channel_check(meas, pred, j, ch)) is not None
    ]
    out = _grams(arm, meas, out)
    zeroed = _zeroed(meas, pred)
    return [*out, *([zeroed] if zeroed is not None else [])]


def _grams(arm: Arm, meas: Measurements, checks: list[DataCheck]) -> list[DataCheck]:
    """Channels that read 1/1000 of the model under payloads that look like grams: the
    masses are the mistake, not the channels (a mass 1000 times too large makes the model,
    not the data, 1000 times too large, on every channel, angles too)."""
    from eodarm.data.plausible import payload_hint

    small = [c for c in checks if c.problem == "scale" and c.ratio < 1]
    heavy = float(np.max(meas.mass_kg))
    hint = payload_hint(heavy, arm)
    if not small or hint is None or "grams" not in hint:
        return checks
    row = int(np.argmax(meas.mass_kg))  # the heaviest: the one the hint is about
    chans = ", ".join(c.channel or "" for c in small[:3]) + (" …" if len(small) > 3 else "")
    ratio = float(np.median([c.ratio for c in small]))
    msg = (
        f"mass_kg looks like grams (line {int(meas.line[row])}: {hint}; and {chans} read "
        f"{_times(ratio)} the model): divide mass_kg by 1000"
    )
    return [DataCheck("mass_kg", "scale", msg, ratio=ratio), *(c for c in checks if c not in small)]


def _channel_check(meas: Measurements, pred: FloatArray, j: int, ch: str) -> DataCheck | None:
    """The scale or sign check of one channel (module notes)."""
    cells = np.isfinite(meas.values[:, j]) & np.isfinite(pred[:, j]) & ~meas.reference
    y, p, s = meas.values[cells, j], pred[cells, j], meas.sigma[cells, j]
    big = np.abs(p) >= MEASURABLE * s
    if int(big.sum()) < MIN_CELLS:
        return None
    chi2 = float(np.sum(((y - p) / s) ** 2))
    if chi2_p_value(chi2, y.size, meas.sigma_dof.get(ch, math.inf)) >= P_PASS:
        return None  # the model explains the channel: nothing to check
    yb, pb = y[big], p[big]
    ratio = yb / pb
    k = float(np.median(ratio))
    problem: Problem_ | None = None
    for factor in (1e-3, 1e3):
        lo, hi = factor / SCALE_TOLERANCE, factor * SCALE_TOLERANCE
        if lo <= k <= hi and np.mean((ratio >= lo) & (ratio <= hi)) >= MIN_SHARE:
            problem = "scale"
    if SIGN_RANGE[0] <= k <= SIGN_RANGE[1] and np.mean(ratio < 0) >= MIN_SHARE:
        problem = "sign"
    if problem is None:
        return None
    i = int(np.argmax(np.abs(pb)))  # the example: the largest reading the model expects
    line = int(meas.line[np.flatnonzero(cells)[np.flatnonzero(big)[i]]])
    unit = "deg" if ch.endswith("_deg") else "mm"
    example = f"e.g. line {line}: {yb[i]:.3g} where the model gives {pb[i]:.3g} {unit}"
    if problem == "scale":
        factor = 1e-3 if k < 1 else 1e3
        return DataCheck(ch, "scale", _scale_message(ch, k, factor, example), ratio=k)
    from eodarm.data.channels import channel_family

    why = _SIGN_WHY[channel_family(ch)]
    msg = f"{ch} looks sign-flipped ({why}; it reads {_times(k)} the model, {example}): "
    return DataCheck(ch, "sign", msg + "change its sign", ratio=k)


def _times(k: float) -> str:
    """A ratio to the model in words: ``1/998 of``, ``1002×``, ``-1.03×``."""
    if 0 < abs(k) < 0.1:
        return f"{'-' if k < 0 else ''}1/{1 / abs(k):.0f} of"
    return f"{k:.0f}×" if abs(k) >= 10 else f"{k:.2g}×"


def _scale_message(ch: str, k: float, factor: float, example: str) -> str:
    """The line of a channel about a thousand times off."""
    small = factor < 1
    reads = f"it reads {_times(k)} the model, {example}"
    if ch.endswith("_mm"):
        what = "metres" if small else "microns"
        fix = "multiply it by 1000" if small else "divide it by 1000"
        return f"{ch} looks like {what} in an _mm column ({reads}): {fix}"
    fix = "multiply by 1000?" if small else "divide by 1000?"
    return f"{ch} is in another unit than degrees ({reads}): check it ({fix})"


def _zeroed(meas: Measurements, pred: FloatArray) -> DataCheck | None:
    """The sequences that look zeroed with the first payload on (module notes), in one
    check."""
    if not meas.has_sequences:
        return None
    found: list[tuple[str, str]] = []  # (label, the example's words)
    values, sigma = meas.values, meas.sigma
    for rows in meas.sequences():
        loaded = rows[meas.mass_kg[rows] > 0]
        if loaded.size < 2:
            continue
        first = int(loaded[0])
        chans = np.isfinite(values[first]) & np.isfinite(pred[first])
        if not chans.any():
            continue
        y1, p1, s1 = values[first, chans], pred[first, chans], sigma[first, chans]
        if np.any(np.abs(y1) > ZERO_Z * s1) or float(np.sum((p1 / s1) ** 2)) < ZEROED_CHI2:
            continue
        later = rows[np.flatnonzero(rows == first)[0] + 1 :]
        mass = meas.mass_kg[later]
        unloads = bool(np.any(mass < np.maximum.accumulate(mass)))
        if np.any(y1 != 0) and not unloads:
            continue  # 0 within the noise, and no unloading branch to tell a friction apart
        y, p, s = (
            values[np.ix_(later, chans)],
            pred[np.ix_(later, chans)],
            sigma[np.ix_(later, chans)],
        )
        ok = np.isfinite(y) & np.isfinite(p)
        if not ok.any():
            continue
        model = float(np.sum(np.where(ok, (y - p) / s, 0.0) ** 2))
        shifted = float(np.sum(np.where(ok, (y - (p - p1)) / s, 0.0) ** 2))
        if shifted > ZEROED_RATIO * model or model - shifted < ZEROED_CHI2:
            continue
        c = int(np.argmax(np.abs(p1 / s1)))
        ch = [meas.channels[j] for j in np.flatnonzero(chans)][c]
        unit = "deg" if ch.endswith("_deg") else "mm"
        found.append(
            (
                str(meas.config[first]),
                f"line {int(meas.line[first])} at {meas.mass_kg[first]:g} kg reads 0 where "
                f"the model expects {ch} {p1[c]:.3g} {unit}",
            )
        )
    if not found:
        return None
    labels = [lab for lab, _ in found]
    names = ", ".join(show(lab, 12) for lab in labels[:3])
    more = f" and {len(labels) - 3} more" if len(labels) > 3 else ""
    which = f"sequence {names}" if len(labels) == 1 else f"sequences {names}{more}"
    msg = (
        f"{which} look{'s' if len(labels) == 1 else ''} zeroed with the first payload on "
        f"({found[0][1]}, and later states read the model less it): zero the sensors "
        "unloaded, before the first payload"
    )
    return DataCheck(None, "zeroed", msg, configs=tuple(labels))
