"""The numerical model: a frame finite-element model of the arm (``model="fem"``).

Built by the compiled core from the same arm and effects as the analytic model: links as
Euler–Bernoulli beams (their ``ei_n_mm2``/``ea_n`` from the arm file, EI overridden by
``link_bending``; a link without either is rigid), actuators as axial bars, rotary drives as
torsional springs between the housing (body i−1) and the flange (link i, clamped to it), pins
with the rotation released, gap elements for clearance, play and backlash, the base on a
rotational spring.
It is linear — the payload's increment on the undeformed geometry — so it agrees with the
analytic model's exact pose to first order in the load. ``docs/fem.md`` derives it.

Users reach it through ``eodarm.solve(..., model="fem")`` and the ``model=`` of the fits;
:func:`fem_solve_payload` is that entry, :func:`evaluate` the fits' channels and
sensitivities (forward differences in each effect's θ, which are exact here: the FE
response is linear in every compliance-like θ).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from eodarm.errors import InputError
from eodarm.model.arm import Arm, RotaryDrive
from eodarm.model.arm_parts import stiffness_of
from eodarm.model.effects import CATALOGUE, Effect, effect_arrays

if TYPE_CHECKING:
    from eodarm.model.effects import Slot

__all__ = [
    "DEFAULTS",
    "SEGMENT_KINDS",
    "Model",
    "check_model",
    "evaluate",
    "fem_solve_payload",
    "options",
]

Model = Literal["analytic", "fem"]

#: Default FE options: beam elements per flexible link, samples of each moment diagram.
DEFAULTS: dict[str, int] = {"elements_per_link": 8, "moment_samples": 101}


def check_model(model: str) -> None:
    """Refuse anything but ``"analytic"`` or ``"fem"``."""
    if model not in ("analytic", "fem"):
        raise InputError(f"model must be 'analytic' or 'fem', got {model!r}")


def options(fem_options: Mapping[str, Any] | None) -> dict[str, int]:
    """The FE options with defaults filled in; unknown keys and bad values are refused."""
    out = dict(DEFAULTS)
    for key, value in (fem_options or {}).items():
        if key not in DEFAULTS:
            raise InputError(
                f"fem_options: unknown key {key!r}; known: {', '.join(sorted(DEFAULTS))}"
            )
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise InputError(f"fem_options: {key} must be an integer, got {value!r}")
        lo, hi = (1, 10_000) if key == "elements_per_link" else (2, 100_000)
        if not lo <= int(value) <= hi:
            raise InputError(f"fem_options: {key} must be in {lo}..{hi}, got {value}")
        out[key] = int(value)
    return out


def sections(arm: Arm) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The arm file's link sections (EI, EA), NaN where not given (rigid)."""
    ei = np.array([np.nan if lk.ei_n_mm2 is None else lk.ei_n_mm2 for lk in arm.links])
    ea = np.array([np.nan if lk.ea_n is None else lk.ea_n for lk in arm.links])
    return ei, ea


def fem_solve_payload(
    arm: Arm,
    alpha: npt.NDArray[np.float64],
    payload: npt.NDArray[np.float64],
    effects: Sequence[Effect],
    self_weight: bool,
    fem_options: Mapping[str, Any] | None = None,
    nan_on_failure: bool = False,
) -> dict[str, Any]:
    """The FE solve of checked (N, n) angles and (N, 2) payload forces: see ``eodarm.solve``."""
    opts = options(fem_options)
    codes, places, values = effect_arrays(effects, arm.n)
    return _raw(arm, alpha, payload, codes, places, values, self_weight, opts, nan_on_failure)


def _raw(
    arm: Arm,
    alpha: npt.NDArray[np.float64],
    payload: npt.NDArray[np.float64],
    codes: npt.NDArray[np.int64],
    places: npt.NDArray[np.int64],
    values: npt.NDArray[np.float64],
    self_weight: bool,
    opts: dict[str, int],
    nan_on_failure: bool,
) -> dict[str, Any]:
    from eodarm.model import native as _core
    from eodarm.model.kinematics import _core_arm

    ei, ea = sections(arm)
    return _core.fem_solve(
        _core_arm(arm),
        alpha,
        payload,
        codes,
        places,
        values,
        self_weight,
        opts["elements_per_link"],
        ei,
        ea,
        opts["moment_samples"],
        nan_on_failure,
    )


def channels(out: Mapping[str, Any]) -> npt.NDArray[np.float64]:
    """The measurement channels (N, 2 + 2n) of a solve: dx, dy, dα₁…dαₙ, dl₁…dlₙ."""
    return np.column_stack([out["dx_mm"], out["dy_mm"], out["dalpha_deg"], out["dl_mm"]])


def theta_step(arm: Arm, slot: Slot, theta: float) -> float:
    """The forward-difference step of a slot's θ: its scale or a reference scale.

    Reference scales make the effect's deflection comparable to the drives' own: 1/k of the
    actuator or drive (compliances), 1/(k·L³) (bending), 1/(k·R²) (base), 0.05 mm (gaps; 0.05°
    of a backlash), with k the stiffest drive (a rotary one's k/R² as N/mm), L the link's
    length and R the arm's reach. The FE response is linear in θ, so a large step costs no
    accuracy; a tiny one (a nearly rigid element next to the drives' springs) would drown the
    difference in round-off.
    """
    reach = sum(math.hypot(*lk.next) for lk in arm.links)
    k = max(
        stiffness_of(a) / (reach**2 if isinstance(a, RotaryDrive) else 1.0) for a in arm.actuators
    )
    i = slot.index(arm.n)
    if slot.name in ("actuator_compliance", "mount_compliance", "drive_compliance"):
        ref = 1.0 / stiffness_of(arm.actuators[i])
    elif slot.name == "link_bending":
        length = math.hypot(*arm.links[i].next)
        ref = 1.0 / (k * length**3)
    elif slot.name == "base_compliance":
        ref = 1.0 / (k * reach**2)
    else:
        ref = 0.05
    return max(abs(theta), ref)


def neutral(arm: Arm, slot: Slot) -> float:
    """θ of a slot absent from the FE model: the arm file's 1/k (an actuator's body, a
    drive's gear) or 1/EI, else 0."""
    i = slot.index(arm.n)
    if slot.name in ("actuator_compliance", "drive_compliance"):
        return 1.0 / stiffness_of(arm.actuators[i])
    ei = arm.links[i].ei_n_mm2
    if slot.name == "link_bending" and ei is not None:
        return 1.0 / ei
    return 0.0


def evaluate(
    arm: Arm,
    alpha: npt.NDArray[np.float64],
    payload: npt.NDArray[np.float64],
    model: Sequence[tuple[Slot, float]],
    probes: Sequence[Slot],
    self_weight: bool,
    fem_options: Mapping[str, Any] | None = None,
    nan_on_failure: bool = False,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Channels y (N, C) of the FE model with the given θ, and ∂y/∂θ (N, C, P) for ``probes``.

    Each column of the Jacobian is a forward difference ``(y(θ + h) − y(θ))/h`` of one more FE
    solve; a probe not in the model enters at its neutral θ. The FE response is linear in each
    θ (a statically determinate arm: every deflection is a force, fixed by statics, times a
    compliance), so the difference is exact up to round-off whatever the step.
    """
    opts = options(fem_options)
    n = arm.n
    thetas = {s.key: (s, float(t)) for s, t in model}

    def run(th: Mapping[str, tuple[Slot, float]]) -> npt.NDArray[np.float64]:
        codes = np.array([s.code for s, _ in th.values()], dtype=np.int64)
        places = np.array([s.index(n) for s, _ in th.values()], dtype=np.int64)
        values = np.array([_param(s.name, t) for s, t in th.values()], dtype=float)
        out = _raw(arm, alpha, payload, codes, places, values, self_weight, opts, nan_on_failure)
        return channels(out)

    y = run(thetas)
    jac = np.empty((*y.shape, len(probes)))
    for j, slot in enumerate(probes):
        # A probe outside the model sits at its neutral θ, which reproduces its absence.
        base = thetas[slot.key][1] if slot.key in thetas else neutral(arm, slot)
        h = theta_step(arm, slot, base)
        jac[..., j] = (run({**thetas, slot.key: (slot, base + h)}) - y) / h
    return y, jac


def _param(name: str, theta: float) -> float:
    """The physical parameter the core takes for θ: a compliance of 0 is an infinite (rigid)
    stiffness, which the FE model accepts."""
    if CATALOGUE[name].compliance_like:
        return math.inf if theta <= 0 else 1.0 / theta
    return max(float(theta), 0.0)


#: Names of the deformed shape's segment kinds (``segment_kind`` of a FE solve).
SEGMENT_KINDS = ("axis", "offset", "actuator", "chassis")
