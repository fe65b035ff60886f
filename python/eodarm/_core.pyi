"""Type stubs of the private native module ``eodarm._core`` (built from crates/arm_py)."""

from collections.abc import Callable, Sequence
from typing import Any, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "COMPENSATE_STATUSES",
    "CoreArm",
    "CoreError",
    "angles_from_lengths",
    "compensate",
    "cycle_returns",
    "fem_solve",
    "forward",
    "inverse_kinematics",
    "jacobian",
    "solve",
    "solve_sequence",
    "statics",
    "sweep",
]

COMPENSATE_STATUSES: list[str]

class CoreError(ValueError): ...

@final
class CoreArm:
    def __new__(
        cls,
        g: float,
        o1: tuple[float, float] | list[float] | npt.NDArray[np.float64],
        b0: tuple[float, float] | list[float] | npt.NDArray[np.float64],
        pivot: tuple[float, float] | list[float] | npt.NDArray[np.float64],
        next: npt.NDArray[np.float64],
        a: npt.NDArray[np.float64],
        b: npt.NDArray[np.float64],
        c: npt.NDArray[np.float64],
        link_mass: npt.NDArray[np.float64],
        measure: tuple[float, float] | list[float] | npt.NDArray[np.float64],
        stiffness: npt.NDArray[np.float64],
        act_mass: npt.NDArray[np.float64],
        min_length: npt.NDArray[np.float64],
        max_length: npt.NDArray[np.float64],
        max_force: npt.NDArray[np.float64],
        *,
        kind: npt.NDArray[np.float64] | None = None,
        max_torque: npt.NDArray[np.float64] | None = None,
        min_angle_deg: npt.NDArray[np.float64] | None = None,
        max_angle_deg: npt.NDArray[np.float64] | None = None,
    ) -> CoreArm:
        """Each joint's ``kind``: 0 linear actuator (the default), 1 rotary drive, whose
        ``stiffness`` is in N·mm/rad and limits ``max_torque`` (N·mm), ``min_angle_deg``,
        ``max_angle_deg`` (NaN where absent); the pins a drive does not use are ignored."""
        ...
    @property
    def n(self) -> int: ...
    @property
    def kinds(self) -> list[str]:
        """Each joint's ``"linear"`` or ``"rotary"``."""
        ...

def solve(
    arm: CoreArm,
    alpha_deg: npt.NDArray[np.float64],
    payload_n: npt.NDArray[np.float64] | None,
    codes: npt.NDArray[np.int64],
    places: npt.NDArray[np.int64],
    values: npt.NDArray[np.float64],
    self_weight: bool,
    nan_on_failure: bool = False,
    *,
    mass_kg: float | npt.NDArray[np.float64] | None = None,
    extra_seen_mm: npt.NDArray[np.float64] | None = None,
    extra_unseen_mm: npt.NDArray[np.float64] | None = None,
    extra_joint_mm: npt.NDArray[np.float64] | None = None,
    extra_tilt_rad: npt.NDArray[np.float64] | None = None,
    extra_measure_mm: npt.NDArray[np.float64] | None = None,
    extra_turn_rad: npt.NDArray[np.float64] | None = None,
    # a dict of arrays and a list of keys; typed Any so that callers may pass the extras as
    # **kwargs
    out: Any = None,
    outputs: Any = None,
) -> dict[str, npt.NDArray[Any]]:
    """``force_n``, ``dforce_n``, ``torque_nmm``, ``dtorque_nmm``, ``dalpha_deg``, ``dl_mm``,
    ``dlength_mm``, ``length_mm`` (N, n), ``reaction_n`` (N, n, 2), ``dx_mm``, ``dy_mm`` (N,),
    ``status`` (N,) uint8; NaN at the joints of the other kind (forces and lengths at a drive,
    torques at a linear actuator). ``extra_turn_rad`` (N, n): turn of link i against body
    i−1 at a rotary drive (zero at linear actuators). With ``outputs`` only those keys and
    ``status`` are allocated, written and returned (``out`` then holds exactly those).
    ``payload_n`` None with ``mass_kg`` (a float, or (N,)): the payload masses (kg), their
    weight downward; not with the ``extra_*`` arrays."""
    ...

def solve_sequence(
    arm: CoreArm,
    alpha_deg: npt.NDArray[np.float64],
    mass_kg: npt.NDArray[np.float64],
    codes: npt.NDArray[np.int64],
    places: npt.NDArray[np.int64],
    values: npt.NDArray[np.float64],
    self_weight: bool,
    nan_on_failure: bool = False,
    *,
    outputs: Sequence[str] | None = None,
) -> dict[str, npt.NDArray[Any]]:
    """N load sequences of S states. ``alpha_deg`` (N, n) C-contiguous float64; ``mass_kg``
    (N, S) the payload mass of each state (kg, its weight ``m·g`` downward), or (S,) / (1, S)
    the same S for every sequence. Returns the keys of :func:`solve` with shape (N, S, ...),
    relative to each sequence's reference, and ``status`` (N, S) uint8; with ``outputs`` only
    those keys and ``status``."""
    ...

def cycle_returns(
    arm: CoreArm,
    alpha_deg: npt.NDArray[np.float64],
    mass_kg: npt.NDArray[np.float64],
    codes: npt.NDArray[np.int64],
    places: npt.NDArray[np.int64],
    values: npt.NDArray[np.float64],
    self_weight: bool,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Where each cell (pose p, mass m_j) comes back to after reference → m_j → 0: ``(dx,
    dy)`` (P, M) mm from the reference, NaN where the cycle cannot be solved. ``alpha_deg``
    (P, n) and ``mass_kg`` (M,) C-contiguous float64."""
    ...

def statics(
    arm: CoreArm,
    alpha_deg: npt.NDArray[np.float64],
    payload_n: npt.NDArray[np.float64],
    self_weight: bool,
) -> dict[str, npt.NDArray[np.float64]]:
    """``force_n``, ``force0_n``, ``torque_nmm``, ``torque0_nmm``, ``length_mm`` (N, n),
    ``reaction_n``, ``reaction0_n`` (N, n, 2): both states on the undeformed geometry; NaN at
    the joints of the other kind."""
    ...

def sweep(
    arm: CoreArm,
    alpha_deg: npt.NDArray[np.float64] | None,
    mass_kg: npt.NDArray[np.float64],
    codes: npt.NDArray[np.int64],
    places: npt.NDArray[np.int64],
    values: npt.NDArray[np.float64],
    self_weight: bool,
    reduce: str | None = None,
    group: int = 1,
    threads: int | None = None,
    *,
    grid: tuple[Sequence[npt.NDArray[np.float64]], Sequence[int], int, int] | None = None,
    out: dict[str, npt.NDArray[Any]] | None = None,
    mask_unreachable: bool = False,
    progress: Callable[[int], object] | None = None,
    chunk_rows: int | None = None,
) -> dict[str, npt.NDArray[Any]]: ...
def fem_solve(
    arm: CoreArm,
    alpha_deg: npt.NDArray[np.float64],
    payload_n: npt.NDArray[np.float64],
    codes: npt.NDArray[np.int64],
    places: npt.NDArray[np.int64],
    values: npt.NDArray[np.float64],
    self_weight: bool,
    elements_per_link: int,
    link_ei: npt.NDArray[np.float64],
    link_ea: npt.NDArray[np.float64],
    moment_samples: int = 101,
    nan_on_failure: bool = False,
) -> dict[str, Any]: ...
def forward(arm: CoreArm, alpha_deg: npt.NDArray[np.float64]) -> dict[str, npt.NDArray[np.float64]]:
    """``O`` (N, n+1, 2), ``A``, ``B``, ``C`` (N, n, 2), ``measure`` (N, 2), ``length_mm``
    (N, n); ``A``, ``B`` and ``length_mm`` NaN at a rotary drive's joint."""
    ...

def angles_from_lengths(
    arm: CoreArm,
    length_mm: npt.NDArray[np.float64],
    alpha_ref_deg: npt.NDArray[np.float64],
    nan_on_failure: bool = False,
) -> npt.NDArray[np.float64]: ...
def inverse_kinematics(
    arm: CoreArm, target: npt.NDArray[np.float64], elbow: float
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]: ...
def jacobian(
    arm: CoreArm,
    alpha_deg: npt.NDArray[np.float64],
    payload_n: npt.NDArray[np.float64],
    model_codes: npt.NDArray[np.int64],
    model_places: npt.NDArray[np.int64],
    model_thetas: npt.NDArray[np.float64],
    probe_codes: npt.NDArray[np.int64],
    probe_places: npt.NDArray[np.int64],
    self_weight: bool,
    nan_on_failure: bool = False,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def compensate(
    arm: CoreArm,
    alpha_deg: npt.NDArray[np.float64],
    payload_n: npt.NDArray[np.float64],
    codes: npt.NDArray[np.int64],
    places: npt.NDArray[np.int64],
    values: npt.NDArray[np.float64],
    self_weight: bool,
    *,
    jacobian: str = "auto",
    max_iter: int = 50,
    tol_mm: float = 1e-9,
    min_moment_ratio: float = 0.01,
) -> dict[str, npt.NDArray[Any]]: ...
