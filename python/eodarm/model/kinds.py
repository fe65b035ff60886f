"""Numbers of the right kind at the Python API: what is not one is refused in one line.

numpy converts almost anything to float64: a complex number loses its imaginary part (with
only a warning), a ``datetime64`` becomes its count of days or seconds since 1970, ``True``
becomes 1.0 and the string ``"80"`` becomes 80.0. None of these is an angle, a mass or a
length in the units the API states, so every array and number the solvers, sweeps,
compensation and effects take goes through these checks first (docs/model.md, "Input"):

* :func:`real_array`: integers and floats only (any shape; Python ints too large for a float
  and ``object`` arrays of numbers are looked at one by one);
* :func:`real_number`: one such number (a numpy scalar or a 0-d array included);
* :func:`integer`: a whole number in a range, where a Python ``int`` beyond the range (e.g.
  ``max_iter=2**32``) is a :class:`~eodarm.errors.InputError`, never an ``OverflowError``.
"""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import InputError

__all__ = ["integer", "kind_name", "real_array", "real_number"]

#: numpy dtype kinds that are numbers of a real quantity: signed, unsigned integers, floats.
_REAL_KINDS = "iuf"


def kind_name(x: Any) -> str:
    """What ``x`` is, in a few words, for a message ("a complex number", "a string" …)."""
    if isinstance(x, (bool, np.bool_)):
        return f"a boolean ({x!r})"
    if isinstance(x, (str, bytes)):
        text = repr(x) if len(repr(x)) <= 30 else repr(x)[:29] + "…"
        return f"a string ({text})"
    if isinstance(x, (complex, np.complexfloating)):
        return f"a complex number ({x!r})"
    if isinstance(x, (np.datetime64, np.timedelta64)):
        return f"a {type(x).__name__} ({x!r})"
    if isinstance(x, np.ndarray):
        return {
            "b": "booleans",
            "c": "complex numbers",
            "M": "datetime64 values",
            "m": "timedelta64 values",
            "U": "strings",
            "S": "bytes",
            "V": "records",
        }.get(x.dtype.kind, f"values of dtype {x.dtype}")
    return f"a {type(x).__name__}"


def real_array(values: npt.ArrayLike, name: str) -> npt.NDArray[Any]:
    """``values`` as a numpy array of real numbers (integers or floats, not yet float64).

    Raises
    ------
    InputError
        One line naming ``name`` and what was given instead: booleans, complex numbers,
        datetimes, strings, or objects that are not real numbers.
    """
    if isinstance(values, np.ndarray) and values.dtype.kind in _REAL_KINDS:
        return values
    try:
        a = np.asarray(values)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{name}: cannot be read as an array of numbers") from None
    if a.dtype.kind in _REAL_KINDS:
        return a
    if a.dtype.kind == "O":
        for x in a.ravel():
            if isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Real):
                raise InputError(f"{name}: expected real numbers, got {kind_name(x)}")
        try:
            return np.asarray(a, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise InputError(f"{name}: a number is too large for a float") from None
    raise InputError(f"{name}: expected real numbers, got {kind_name(a)}")


def real_number(x: Any, name: str) -> float:
    """``x`` as a float, if it is one real number (an int, a float, a numpy real scalar or a
    0-d array of one); :class:`~eodarm.errors.InputError` naming ``name`` otherwise."""
    if isinstance(x, np.ndarray) and x.ndim == 0:
        x = x[()]
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Real):
        raise InputError(f"{name}: expected a real number, got {kind_name(x)}")
    try:
        return float(x)
    except (OverflowError, ValueError, TypeError):
        raise InputError(f"{name}: {x!r} is too large for a float") from None


def integer(x: Any, name: str, lo: int = 1, hi: int = 2**31 - 1) -> int:
    """``x`` as an int in ``[lo, hi]``; booleans, floats and anything else refused.

    Raises
    ------
    InputError
        Naming ``name``, the value and the range (a huge Python int included).
    """
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)):
        raise InputError(f"{name} must be an integer >= {lo}, got {kind_name(x)}")
    v = int(x)
    if v < lo:
        raise InputError(f"{name} must be >= {lo}, got {v}")
    if v > hi:
        shown = str(v) if len(str(v)) <= 24 else f"{str(v)[:20]}… ({len(str(v))} digits)"
        raise InputError(f"{name} must be <= {hi}, got {shown}")
    return v
