"""Exception types raised by eodarm.

Every error a user's input can cause is a :class:`ValueError` subclass with a one-line message
that names the file and key, the row, or the pose at fault.
"""

from __future__ import annotations

__all__ = ["ArmFileError", "EffectError", "EodarmError", "InputError"]


class EodarmError(ValueError):
    """Base class of every input error eodarm raises."""


class ArmFileError(EodarmError):
    """An arm file (or dict) is malformed; the message names the source and the key."""


class EffectError(EodarmError):
    """An effect is unknown, placed where it cannot be, or has a bad parameter."""


class InputError(EodarmError):
    """Arrays given to a solver have the wrong shape or non-finite values (row named)."""
