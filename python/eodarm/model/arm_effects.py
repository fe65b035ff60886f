"""The model of an arm: its own fitted effects (``[[effect]]`` tables) with the caller's.

CONTRACT §7: every solver and command includes the arm's effects, and the effects a caller
gives come on top of them; an effect at a place the file already has replaces the file's.
"""

from __future__ import annotations

from typing import Any

from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, as_effects

__all__ = ["model_effects"]


def model_effects(arm: Arm, effects: Any = None) -> list[Effect]:
    """``arm.effects`` with ``effects`` on top: the same ``effect@place`` in both → the
    argument's (whatever its ``unloaded`` mode); the others are kept, the arm's first.

    Parameters
    ----------
    arm : the arm; its :attr:`~eodarm.Arm.effects` come from its file's ``[[effect]]`` tables.
    effects : None, one :class:`~eodarm.Effect` or an iterable of them (checked later, with
        the arm, by :func:`~eodarm.model.effects.effect_arrays`).
    """
    given = as_effects(effects)
    keys = {e.key for e in given if isinstance(e, Effect)}
    return [e for e in arm.effects if e.key not in keys] + given
