"""eodarm: why does a robot arm not go where its model says?

Statics, actuator/mount compliance, play, joint clearance, link bending and base tilt of planar
arms driven by linear actuators, solved exactly for many poses at once by a compiled Rust core,
with an independent numpy reference.

>>> import eodarm
>>> arm = eodarm.Arm.from_toml("examples/example_arm.toml")            # doctest: +SKIP
>>> eff = [eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15)]  # doctest: +SKIP
>>> out = eodarm.solve(arm, [[90.0, 10.0, 0.0]], 5.0, effects=eff)     # doctest: +SKIP
"""

from eodarm._version import __version__
from eodarm.analysis.diagnose import Diagnosis, diagnose
from eodarm.analysis.fit import FitResult, cross_validate, fit
from eodarm.data.measurements import Measurements
from eodarm.data.reader import read_measurements
from eodarm.errors import ArmFileError, EffectError, EodarmError, InputError
from eodarm.model.arm import Actuator, Arm, Link
from eodarm.model.effects import CATALOGUE, Effect, Slot
from eodarm.model.solver import (
    angles_from_lengths,
    forward,
    inverse_kinematics,
    solve,
    solve_payload,
    stroke_violations,
)
from eodarm.workspace.sweep import sweep

__all__ = [
    "CATALOGUE",
    "Actuator",
    "Arm",
    "ArmFileError",
    "Diagnosis",
    "Effect",
    "EffectError",
    "EodarmError",
    "FitResult",
    "InputError",
    "Link",
    "Measurements",
    "Slot",
    "__version__",
    "angles_from_lengths",
    "cross_validate",
    "diagnose",
    "fit",
    "forward",
    "inverse_kinematics",
    "read_measurements",
    "solve",
    "solve_payload",
    "stroke_violations",
    "sweep",
]
