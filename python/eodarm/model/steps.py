"""The difference steps of an effect's fitting parameter θ (docs/diagnosis.md): a typical θ of
each place, the scale of a step from θ = 0, as the compiled core's sensitivities take them
(``crates/arm_core/src/sensitivity.rs``, ``typical_theta`` and ``step``).

:func:`core_step` is the core's step, so that a derivative taken in Python by solving twice
(:func:`eodarm.model.uncertainty.sequence_sigma`) is the one the core would take;
:mod:`eodarm.analysis.sensitivity` sizes its own forward differences from
:func:`typical_theta`.
"""

from __future__ import annotations

from eodarm.model.arm import Arm
from eodarm.model.arm_parts import stiffness_of
from eodarm.model.effects import Slot

__all__ = ["CORE_STEP", "core_step", "neutral_theta", "typical_theta"]

#: The core's central-difference step, relative to the larger of |θ| and the typical θ.
CORE_STEP = 1e-3


def neutral_theta(arm: Arm, slot: Slot) -> float:
    """θ of a catalogue effect that is not in the model (the core's ``neutral_theta``): the
    file's own compliance 1/k for an actuator's body or a drive's gear, else 0 (absent)."""
    if slot.name in ("actuator_compliance", "drive_compliance"):
        return 1.0 / stiffness_of(arm.actuators[slot.index(arm.n)])
    return 0.0


def typical_theta(arm: Arm, slot: Slot) -> float:
    """A typical θ of a catalogue effect at its place: the actuator's own compliance 1/k
    for a spring at an actuator (1/k of a drive's gear), 0.1 mm for a gap (0.1° of a
    backlash), 10⁻¹⁰ /(N·mm²) for bending, 10 N and 1000 N·mm for a friction limit,
    10⁻⁸ rad/(N·mm) for the base."""
    name = slot.name
    if name in ("actuator_compliance", "mount_compliance", "drive_compliance"):
        return 1.0 / stiffness_of(arm.actuators[slot.index(arm.n)])
    if name in ("actuator_play", "joint_clearance", "drive_backlash"):
        return 0.1  # mm, or degrees of a backlash
    if name == "actuator_friction":
        return 10.0
    if name in ("joint_friction", "drive_friction"):
        return 1000.0
    return 1e-10 if name == "link_bending" else 1e-8


def core_step(arm: Arm, slot: Slot, theta: float) -> float:
    """The core's step h of a central difference at ``theta``: 10⁻³ of the larger of |θ| and
    :func:`typical_theta`."""
    return CORE_STEP * max(abs(theta), typical_theta(arm, slot))
