"""Numbers and names as people read them: one formatter for every table, line, page and repr
(``eodarm.viz.format`` is its name in the figures and the commands; it sits here, below every
layer, for :mod:`eodarm.reprs`).

* :func:`value_error`: a value with its standard error, the error rounded to two
  significant digits and the value to the same decimal place, the unit once
  (``"1290 ± 300 N/mm"``, ``"0.151 ± 0.0020 mm"``, ``"(4.4 ± 3.3)×10⁵ N/mm"``);
* :func:`value`: a value alone, to a few significant digits, the unit once;
* :func:`interval95`: the 95 % interval of a normal estimate;
* :func:`bounded_interval`: a 95 % interval given by its ends (from the fit's own
  parameterisation, so that it never crosses a physical bound), ``≥ lo`` when it reaches ∞;
* :func:`parameter_name`: a parameter in words (``"actuator 1 body stiffness"``), for the
  identifier ``mount_compliance@M1`` shown alongside;
* :func:`channel_value`: a length or angle of a channel, a practical zero as ``0`` or
  ``< 1e-6 mm`` rather than ``3e−10 mm``;
* :func:`plural` and :func:`listing`: ``1 payload``, ``4 payloads``, ``1.5, 5, 6.5 and 0 kg``.

Infinite and undefined numbers read as words, never as ``inf`` or ``nan``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

__all__ = [
    "HOLDS_EVERY_STATE",
    "RESOLUTION",
    "bounded_interval",
    "channel_value",
    "interval95",
    "listing",
    "p_value",
    "parameter_name",
    "plural",
    "value",
    "value_error",
]

#: Below these a channel's value is a practical zero: a length in mm, an angle in deg. The
#: model's kernels agree to about 1e-10 mm; no sensor of an arm resolves 1e-6 mm.
RESOLUTION = {"mm": 1e-6, "deg": 1e-6, "µm": 1e-3}
#: Below this a value is the rounding of the solvers (it reads 0, not "< 1e-6").
ROUNDING = 1e-9

#: z of a two-sided 95 % normal interval.
Z95 = 1.959963984540054

_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")

_NAMES = {
    "actuator_compliance": "actuator {i} body stiffness",
    "mount_compliance": "actuator {i} mount stiffness",
    "actuator_play": "actuator {i} play",
    "joint_clearance": "joint O{i} clearance",
    "link_bending": "link {i} bending stiffness EI",
    "base_compliance": "chassis tilt stiffness",
}


def _with_unit(text: str, unit: str) -> str:
    return f"{text} {unit}" if unit else text


def value(x: float, unit: str = "", digits: int = 4, zeros: bool = False) -> str:
    """``x`` to ``digits`` significant digits with its unit; words for ∞ and NaN.

    Trailing zeros are dropped as ``%g`` drops them (``1.5``, not ``1.500``: a payload, an
    angle) unless ``zeros``: then a computed quantity keeps its ``digits`` figures, so that a
    column reads ``0.00030`` beside ``0.00033``, not ``0.0003`` (an integer stays one).
    """
    if x is None or math.isnan(x):
        return "—"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    x = x + 0.0  # −0 reads as 0
    if x == 0:
        return _with_unit("0", unit)
    exp = math.floor(math.log10(abs(x)))
    keep = zeros and x != round(x)
    if -5 <= exp < 5:  # positional: 2002, 0.257, 71100, 0.00033, not 2e+03
        if exp >= digits:  # round the integer to the digits asked for
            x = round(x, digits - 1 - exp)
        text = f"{x:.{max(digits - 1 - exp, 0)}f}"
        if "." in text and not keep:
            text = text.rstrip("0").rstrip(".")  # as %g: 1.5, not 1.500
    else:  # a power of ten as in value_error: 4.87×10⁸
        mant = f"{x / 10**exp:.{digits - 1}f}"
        if not keep:
            mant = mant.rstrip("0").rstrip(".")
        if mant.lstrip("-") == "10":  # 9.9996e4 to 4 digits: 1×10⁵, not 10×10⁴
            mant, exp = mant.replace("10", "1"), exp + 1
        text = f"{mant}×10{str(exp).translate(_SUPERSCRIPT)}"
    return _with_unit(text.replace("-", "−"), unit)


def channel_value(x: float, unit: str = "mm", digits: int = 3) -> str:
    """A channel's value (a deflection, a residual, what a cycle leaves), to ``digits``
    significant digits with its unit, a practical zero as words: ``0 mm`` below the solvers'
    rounding (10⁻⁹), ``< 1e-6 mm`` below the resolution of :data:`RESOLUTION`."""
    res = RESOLUTION.get(unit)
    if res is not None and x is not None and math.isfinite(x) and abs(x) < res:
        if abs(x) < ROUNDING:
            return _with_unit("0", unit)
        return _with_unit(f"< {res:.0e}".replace("e-0", "e-"), unit)
    return value(x, unit, digits)


def plural(count: int, word: str, words: str | None = None) -> str:
    """``1 payload``, ``4 payloads``, ``12,345 poses`` (``words``: an irregular plural)."""
    return f"{count:,} {word if count == 1 else words or word + 's'}"


def listing(values: Sequence[float], unit: str = "", digits: int = 4) -> str:
    """Numbers in words' order: ``1.5, 5, 6.5 and 0 kg`` (the unit once)."""
    texts = [value(float(v), digits=digits) for v in values]
    if len(texts) > 1:
        texts = [", ".join(texts[:-1]) + " and " + texts[-1]]
    return _with_unit(texts[0] if texts else "none", unit)


def value_error(x: float, err: float, unit: str = "", digits: int = 2) -> str:
    """``x ± err`` with the error rounded to ``digits`` significant digits.

    The value is rounded to the error's last digit. Beyond 10⁵ or below 10⁻³ a common power
    of ten is factored out. An undefined or infinite error gives the value alone, marked
    ``(± ?)`` — the data did not determine it.
    """
    if x is None or math.isnan(x):
        return "—"
    if math.isinf(x):
        return value(x, unit)
    if err is None or not math.isfinite(err) or err < 0:
        return _with_unit(f"{value(x)} (± ?)", unit)
    if err == 0:
        return _with_unit(f"{value(x, digits=6)} ± 0", unit)
    exp_err = math.floor(math.log10(err))
    decimals = digits - 1 - exp_err  # decimal places that keep `digits` digits of err
    big = max(abs(x), err)
    scale = math.floor(math.log10(big)) if big > 0 else 0
    if scale >= 5 or scale < -3:
        k = scale
        xs, es = x / 10**k, err / 10**k
        d = max(decimals + k, 0)
        body = f"({xs:.{d}f} ± {es:.{d}f})×10{str(k).translate(_SUPERSCRIPT)}"
        return _with_unit(body.replace("-", "−"), unit)
    d = max(decimals, 0)
    if decimals < 0:  # round to tens, hundreds, ...
        q = 10 ** (-decimals)
        xr, er = round(x / q) * q, round(err / q) * q
        return _with_unit(f"{xr:.0f} ± {er:.0f}".replace("-", "−"), unit)
    return _with_unit(f"{x:.{d}f} ± {err:.{d}f}".replace("-", "−"), unit)


def interval95(x: float, err: float, unit: str = "", digits: int = 2) -> str:
    """The 95 % interval ``[x − 1.96σ, x + 1.96σ]``, at the precision of :func:`value_error`."""
    if not (math.isfinite(x) and err is not None and math.isfinite(err) and err > 0):
        return "—"
    return _pair(x - Z95 * err, x + Z95 * err, err, unit, digits)


def _pair(lo: float, hi: float, err: float, unit: str, digits: int) -> str:
    """``[lo, hi]`` rounded at the last of ``digits`` significant digits of ``err``."""
    decimals = digits - 1 - math.floor(math.log10(err))
    big = max(abs(lo), abs(hi))
    scale = math.floor(math.log10(big)) if big > 0 else 0
    if scale >= 5 or scale < -3:
        return _with_unit(f"[{lo:.2e}, {hi:.2e}]".replace("-", "−"), unit)
    if decimals < 0:
        q = 10 ** (-decimals)
        lo, hi = round(lo / q) * q, round(hi / q) * q
    d = max(decimals, 0)
    return _with_unit(f"[{lo:.{d}f}, {hi:.{d}f}]".replace("-", "−"), unit)


#: How an interval open upwards reads for a friction that could hold every measured state.
HOLDS_EVERY_STATE = "held every state: load harder"


def bounded_interval(
    lo: float,
    hi: float,
    unit: str = "",
    err: float | None = None,
    digits: int = 3,
    held: bool = False,
) -> str:
    """A 95 % interval ``[lo, hi]`` given by its ends (which need not be symmetric about the
    value: :meth:`eodarm.analysis.fit.FitResult.interval` maps it from the fit's θ).

    With the value's standard error ``err`` the ends are rounded as :func:`interval95`
    rounds them (at the error's second significant digit); otherwise each to ``digits``
    significant digits. An interval that reaches +∞ reads ``≥ lo (up to rigid)`` (a stiffness
    that may be rigid), or with ``held`` ``≥ lo (held every state: load harder)`` (a friction
    that could hold every measured state); one with no finite end reads ``—``.
    """
    if math.isnan(lo) or math.isnan(hi) or (math.isinf(hi) and lo <= 0):
        return "—"
    if math.isinf(hi):
        return f"≥ {value(lo, unit, digits)} ({HOLDS_EVERY_STATE if held else 'up to rigid'})"
    if err is not None and math.isfinite(err) and err > 0:
        return _pair(lo, hi, err, unit, 2)
    return _with_unit(f"[{value(lo, digits=digits)}, {value(hi, digits=digits)}]", unit)


def parameter_name(effect: str, at: str) -> str:
    """A parameter in words, e.g. ``parameter_name("mount_compliance", "M1")`` →
    ``"actuator 1 mount stiffness"``; effects outside the catalogue read as
    ``"<effect> at <place>"``."""
    template = _NAMES.get(effect)
    index = at[1:] if at[:1] in ("M", "O", "L") and at[1:].isdigit() else at
    if template is None:
        return f"{effect.replace('_', ' ')} at {at}"
    return template.format(i=index)


def p_value(p: float) -> str:
    """A p-value, one way everywhere: ``"p = 0.044"``, ``"p = 3.1e-12"``, ``"p < 1e-300"``
    (below 1e-300, down to the 0 of floating-point underflow)."""
    if p is None or math.isnan(p):
        return "p = —"
    if p < 1e-300:
        return "p < 1e-300"
    return f"p = {p:.2g}"
