"""The parts an arm is made of (docs/formats.md §1): its links, the drive of each joint (a
linear actuator or a rotary drive, docs/model.md §10), and what a fit wrote about its effects
(the ``[fit]`` table and the marks of undetermined parameters, docs/formats.md §2).

Plain immutable values; :mod:`eodarm.model.arm` builds and checks them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal, TypeAlias

import numpy as np

__all__ = [
    "BOUNDS",
    "KINDS",
    "Actuator",
    "Drive",
    "EffectMark",
    "FitRecord",
    "Link",
    "Point",
    "RotaryDrive",
    "stiffness_of",
]

Point = tuple[float, float]
#: The joint kinds, in the order of their code in :meth:`Arm.arrays` (``kind``: 0.0, 1.0).
KINDS = ("linear", "rotary")
#: Where a bounded parameter's 95 % interval reaches: "lower" (a stiffness of at least
#: ``limit``, treated as rigid) or "upper" (a gap of at most ``limit``, treated as absent).
BOUNDS = ("lower", "upper")


@dataclass(frozen=True)
class Link:
    """One rigid link, points in its local frame (mm).

    Attributes
    ----------
    next : next joint O_{i+1} (for the last link: the load point).
    A : pin of the link's own linear actuator (``None`` when a rotary drive turns the link).
    B : base pin of the next linear actuator (``None`` on the last link, and when the next
        joint is turned by a rotary drive).
    C : centre of mass.
    mass_kg : link mass.
    measure : measurement point (last link only; ``None`` means the load point).
    ei_n_mm2, ea_n : optional section properties (N·mm², N).
    """

    next: Point
    A: Point | None
    B: Point | None
    C: Point
    mass_kg: float
    measure: Point | None = None
    ei_n_mm2: float | None = None
    ea_n: float | None = None


@dataclass(frozen=True)
class Actuator:
    """One linear actuator between pin B_{i−1} on body i−1 and pin A_i on link i.

    Attributes
    ----------
    stiffness_n_per_mm : axial stiffness of the body, N/mm.
    mass_kg : mass, kg; half acts at each pin.
    min_length_mm, max_length_mm : optional pin-to-pin stroke limits, mm.
    max_force_n : optional force limit, N, either sign.
    kind : ``"linear"`` (not an argument).
    """

    stiffness_n_per_mm: float
    mass_kg: float
    min_length_mm: float | None = None
    max_length_mm: float | None = None
    max_force_n: float | None = None
    kind: Literal["linear"] = field(default="linear", init=False)


@dataclass(frozen=True)
class RotaryDrive:
    """A rotary drive at joint O_i: its housing fixed to body i−1, its output turning link i.

    It holds the relative angle q_i = α_i − α_{i−1} (α_0 = 0, the chassis) with the torque
    T_i on link i (counter-clockwise +; −T_i on body i−1). docs/model.md §10.

    Attributes
    ----------
    stiffness_nmm_per_rad : torsional stiffness at the output (gear, motor held), N·mm/rad.
    mass_kg : mass of motor and gearbox, kg, acting at O_i on body i−1.
    max_torque_nmm : optional torque limit, N·mm, either sign.
    min_angle_deg, max_angle_deg : optional range of q_i, degrees within [−180, 180].
    kind : ``"rotary"`` (not an argument).
    """

    stiffness_nmm_per_rad: float
    mass_kg: float
    max_torque_nmm: float | None = None
    min_angle_deg: float | None = None
    max_angle_deg: float | None = None
    kind: Literal["rotary"] = field(default="rotary", init=False)


#: What turns a joint: a linear actuator or a rotary drive.
Drive: TypeAlias = Actuator | RotaryDrive


@dataclass(frozen=True)
class FitRecord:
    """What a fit knew about the parameters it wrote into an arm file (its ``[fit]`` table).

    Attributes
    ----------
    parameters : ``effect@place:parameter`` of each fitted parameter, in the covariance's
        order (physical units, as the ``[[effect]]`` tables give them).
    covariance : the parameters' covariance matrix (units²), symmetric.
    data : the measurement file's name; ``data_sha256`` its SHA-256 (hex).
    chi2_per_dof : χ²/dof of the fit; ``n_values`` the number of measured values it used.
    date : when it was fitted (ISO 8601).
    explained : whether the fitted model explained its data within their noise (the χ²
        test, docs/model.md, "Prediction errors"); ``None`` when the file does not say.
    sigma_model : per measured channel (``dy_mm``, ``dalpha1_deg``, …), the model's own
        inadequacy, a standard deviation in the channel's unit that every prediction adds
        in quadrature to the parameters' part; all zero when ``explained``.
    heldout_rms : per channel, the RMS of the leave-one-configuration-out residuals it
        came from; ``noise_rms`` the RMS of the measurements' own σ over the same cells.
    """

    parameters: tuple[str, ...]
    covariance: tuple[tuple[float, ...], ...]
    data: str = ""
    data_sha256: str = ""
    chi2_per_dof: float = math.nan
    n_values: int = 0
    date: str = ""
    explained: bool | None = None
    sigma_model: tuple[tuple[str, float], ...] = ()
    heldout_rms: tuple[tuple[str, float], ...] = ()
    noise_rms: tuple[tuple[str, float], ...] = ()

    def model_sigma(self, channel: str) -> float:
        """The model part of a prediction's σ in ``channel`` (its unit): 0 when the model
        explained its data (or the file predates the key), the stored value for a measured
        channel; for one the fit never saw, the largest of the measured channels of its kind
        (``dx_mm`` ↔ ``dy_mm``; ``dalphaK_deg``), else NaN (unknown)."""
        if self.explained is not False:
            return 0.0
        known = dict(self.sigma_model)
        if channel in known:
            return known[channel]
        # A component the fit never saw: the measured one of the same kind stands in (the
        # measure point's miss is one vector; the links' angle misses are of one order).
        if channel in ("dx_mm", "dy_mm"):
            kin = [known[c] for c in ("dx_mm", "dy_mm") if c in known]
        else:
            kin = [v for c, v in known.items() if c[:6] == channel[:6] and c.endswith("_deg")]
        return max(kin) if kin else math.nan

    def __repr__(self) -> str:
        from eodarm.model.arm_display import record_repr

        return record_repr(self)

    def matrix(self) -> np.ndarray:
        """The covariance as a (P, P) float array."""
        k = len(self.parameters)
        return np.array(self.covariance, dtype=float).reshape(k, k)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "parameters": list(self.parameters),
            "covariance": [list(r) for r in self.covariance],
        }
        for key in ("data", "data_sha256", "date"):
            if getattr(self, key):
                d[key] = getattr(self, key)
        if math.isfinite(self.chi2_per_dof):
            d["chi2_per_dof"] = self.chi2_per_dof
        if self.n_values:
            d["n_values"] = self.n_values
        if self.explained is not None:
            d["explained"] = self.explained
        for key in ("sigma_model", "heldout_rms", "noise_rms"):
            if getattr(self, key):
                d[key] = dict(getattr(self, key))
        return d


@dataclass(frozen=True)
class EffectMark:
    """How far the data determined an ``[[effect]]``'s parameter (docs/model.md).

    Attributes
    ----------
    determined : False when the fit could not pin the value down (relative error above
        100 % or a correlation beyond ±0.95 with another parameter).
    bound : ``"lower"`` or ``"upper"`` when only a bound is known and the effect is fixed
        at its physical end (a stiffness treated as rigid, a gap as absent); ``None`` when
        the value is an estimate (then the ``[fit]`` covariance carries its spread).
    limit : the 95 % bound in the parameter's unit (a stiffness of at least ``limit``, a gap
        of at most ``limit``); ``None`` without a bound.
    """

    determined: bool = True
    bound: str | None = None
    limit: float | None = None

    def to_table(self) -> dict[str, Any]:
        """The marking keys of an ``[[effect]]`` table (none for a determined value)."""
        if self.determined:
            return {}
        d: dict[str, Any] = {"determined": False}
        if self.bound is not None and self.limit is not None:
            d["bound"] = self.bound
            d["limit"] = self.limit
        return d


def stiffness_of(a: Drive) -> float:
    """A drive's stiffness in its own unit: N/mm (linear), N·mm/rad (rotary)."""
    return a.stiffness_nmm_per_rad if isinstance(a, RotaryDrive) else a.stiffness_n_per_mm
