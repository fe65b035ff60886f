"""eodarm: why does a robot arm not go where its model says?

Statics, actuator/mount compliance, play, joint clearance, link bending and base tilt of planar
arms driven by linear actuators, solved exactly for many poses at once by a compiled Rust core,
with an independent numpy reference.

>>> import eodarm
>>> arm = eodarm.Arm.from_toml("examples/example_arm.toml")            # doctest: +SKIP
>>> eff = [eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15)]  # doctest: +SKIP
>>> out = eodarm.solve(arm, [[90.0, 10.0, 0.0]], 5.0, effects=eff)     # doctest: +SKIP
"""

from __future__ import annotations

import importlib as _importlib
from typing import TYPE_CHECKING as _TYPE_CHECKING
from typing import Any as _Any

from eodarm._version import __version__
from eodarm.errors import ArmFileError, EffectError, EodarmError, InputError

#: Where each public name lives; a name is imported on first use (PEP 562), so that
#: ``import eodarm`` and ``eodarm --help`` do not pay for the layers a script never touches.
_PUBLIC = {
    "CATALOGUE": "eodarm.model.effects",
    "Effect": "eodarm.model.effects",
    "Slot": "eodarm.model.effects",
    "EffectState": "eodarm.model.custom",
    "custom_effect": "eodarm.model.custom",
    "Actuator": "eodarm.model.arm",
    "Arm": "eodarm.model.arm",
    "Link": "eodarm.model.arm",
    "angles_from_lengths": "eodarm.model.solver",
    "forward": "eodarm.model.solver",
    "inverse_kinematics": "eodarm.model.solver",
    "solve": "eodarm.model.solver",
    "solve_payload": "eodarm.model.solver",
    "solve_sequence": "eodarm.model.solver",
    "stroke_violations": "eodarm.model.solver",
    "Measurements": "eodarm.data.measurements",
    "read_measurements": "eodarm.data.reader",
    "FitResult": "eodarm.analysis.fit",
    "cross_validate": "eodarm.analysis.crossval",
    "fit": "eodarm.analysis.fit",
    "Diagnosis": "eodarm.analysis.diagnose",
    "diagnose": "eodarm.analysis.diagnose",
    "Plan": "eodarm.analysis.plan",
    "plan": "eodarm.analysis.plan",
    "compensate": "eodarm.analysis.compensate",
    "sweep": "eodarm.workspace.sweep",
}
#: Public modules under their own name, imported on first use too: ``eodarm.datasets.load``,
#: ``eodarm.reference.solve``.
_MODULES = ("datasets", "reference")

__all__ = [
    "CATALOGUE",
    "Actuator",
    "Arm",
    "ArmFileError",
    "Diagnosis",
    "Effect",
    "EffectError",
    "EffectState",
    "EodarmError",
    "FitResult",
    "InputError",
    "Link",
    "Measurements",
    "Plan",
    "Slot",
    "__version__",
    "angles_from_lengths",
    "compensate",
    "cross_validate",
    "custom_effect",
    "datasets",
    "diagnose",
    "fit",
    "forward",
    "inverse_kinematics",
    "plan",
    "read_measurements",
    "reference",
    "solve",
    "solve_payload",
    "solve_sequence",
    "stroke_violations",
    "sweep",
]


def __getattr__(name: str) -> _Any:
    if name in _MODULES:
        return _importlib.import_module(f"eodarm.{name}")  # the import binds it here
    where = _PUBLIC.get(name)
    if where is None:
        raise AttributeError(f"module 'eodarm' has no attribute '{name}'")
    obj = getattr(_importlib.import_module(where), name)
    globals()[name] = obj  # once imported, an ordinary attribute
    return obj


def __dir__() -> list[str]:
    """The public API (``__all__``, the modules ``datasets`` and ``reference`` among it),
    not the helpers of this module (its imports, the lazy-import tables) nor the subpackages
    (``eodarm.model``, …, importable by name)."""
    return sorted(__all__)


if _TYPE_CHECKING:
    from eodarm import datasets, reference
    from eodarm.analysis.compensate import compensate
    from eodarm.analysis.crossval import cross_validate
    from eodarm.analysis.diagnose import Diagnosis, diagnose
    from eodarm.analysis.fit import FitResult, fit
    from eodarm.analysis.plan import Plan, plan
    from eodarm.data.measurements import Measurements
    from eodarm.data.reader import read_measurements
    from eodarm.model.arm import Actuator, Arm, Link
    from eodarm.model.custom import EffectState, custom_effect
    from eodarm.model.effects import CATALOGUE, Effect, Slot
    from eodarm.model.solver import (
        angles_from_lengths,
        forward,
        inverse_kinematics,
        solve,
        solve_payload,
        solve_sequence,
        stroke_violations,
    )
    from eodarm.workspace.sweep import sweep
