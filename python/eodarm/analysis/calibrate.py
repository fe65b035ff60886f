"""Calibrating arm-file geometry against force data: the smallest correction that fits.

A user who knows some forces (a published table, load-cell readings) and doubts some numbers
of the arm file (an unknown chassis pin, a garbled coordinate) fits those numbers, each pulled
towards its printed value with a prior standard deviation that says how much it is trusted:

    minimise  Σ ((F_model − F_given)/σ_F)²  +  Σ ((p − p_printed)/σ_p)²

F_model comes from the compiled core's statics (:func:`eodarm.solve_payload`). A parameter is
*identified* by the data when its posterior standard deviation is well below its prior one;
otherwise the data cannot tell and it stays where it was printed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.data.datasets import seed2022_published_dict
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.solver import solve_payload

__all__ = [
    "SEED2022_ASSUMED_MASSES",
    "Calibration",
    "GeomParam",
    "calibrate_geometry",
    "get_key",
    "seed2022_calibration",
    "set_key",
]


@dataclass(frozen=True)
class GeomParam:
    """One scalar of the arm file, by its key, e.g. ``"base.B0.x"``, ``"link[3].next.x"``,
    ``"link[3].mass_kg"``, ``"g"``, with its prior standard deviation (same unit)."""

    key: str
    prior_sigma: float
    start: float | None = None  # where the search starts (default: the printed value)


def _path(key: str) -> tuple[list[str | int], int | None]:
    """ "link[3].A.x" → (["link", 2, "A"], 0)."""
    parts: list[str | int] = []
    comp: int | None = None
    for tok in key.split("."):
        if tok in ("x", "y"):
            comp = 0 if tok == "x" else 1
            continue
        if "[" in tok:
            name, idx = tok[:-1].split("[")
            parts += [name, int(idx) - 1]
        else:
            parts.append(tok)
    return parts, comp


def get_key(d: dict[str, Any], key: str) -> float:
    """Value of an arm-dict key such as ``"base.B0.x"``."""
    parts, comp = _path(key)
    node: Any = d
    try:
        for p in parts:
            node = node[p]
        return float(node[comp] if comp is not None else node)
    except (KeyError, IndexError, TypeError):
        raise EodarmError(f"calibration key '{key}' is not in the arm") from None


def set_key(d: dict[str, Any], key: str, value: float) -> None:
    """Set an arm-dict key such as ``"link[2].B.y"`` (in place)."""
    parts, comp = _path(key)
    node: Any = d
    for p in parts[:-1]:
        node = node[p]
    last = parts[-1]
    if comp is None:
        node[last] = float(value)
    else:
        pt = list(node[last])
        pt[comp] = float(value)
        node[last] = pt


@dataclass
class Calibration:
    """Result of :func:`calibrate_geometry`."""

    arm: Arm
    params: list[GeomParam]
    printed: npt.NDArray[np.float64]
    value: npt.NDArray[np.float64]
    posterior_sigma: npt.NDArray[np.float64]
    force_model: npt.NDArray[np.float64]
    force_given: npt.NDArray[np.float64]
    force_sigma: float

    @property
    def moved(self) -> npt.NDArray[np.float64]:
        return self.value - self.printed

    @property
    def identified(self) -> npt.NDArray[np.bool_]:
        """The data pin the parameter down: posterior σ below a tenth of the prior σ."""
        prior = np.array([p.prior_sigma for p in self.params])
        return self.posterior_sigma < 0.1 * prior

    @property
    def residual(self) -> npt.NDArray[np.float64]:
        return self.force_model - self.force_given

    def table(self) -> list[dict[str, Any]]:
        return [
            {
                "key": p.key,
                "printed": float(self.printed[i]),
                "calibrated": float(self.value[i]),
                "moved": float(self.moved[i]),
                "prior_sigma": p.prior_sigma,
                "posterior_sigma": float(self.posterior_sigma[i]),
                "identified": bool(self.identified[i]),
            }
            for i, p in enumerate(self.params)
        ]


def calibrate_geometry(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    payload_n: npt.ArrayLike | None,
    force_n: npt.ArrayLike,
    params: Sequence[GeomParam],
    force_sigma: float = 0.05,
    self_weight: bool = False,
    payload_fn: Callable[[Arm], npt.NDArray[np.float64]] | None = None,
) -> Calibration:
    """Fit arm-file numbers so that the statics reproduce given actuator forces.

    Parameters
    ----------
    arm : the arm as printed (the priors' centres).
    alpha_deg : (N, n) poses; payload_n : (N, 2) payload force at the load point (N);
    force_n : (N, n) given loaded actuator forces (N); NaN cells are ignored.
    params : the numbers to fit, with their prior σ (use a large σ for an unknown).
    force_sigma : σ of the given forces (N), e.g. half the printed rounding step.
    self_weight : include the arm's weights (as given by its masses) in the statics.
    payload_fn : optional ``arm → (N, 2)`` payload, when the payload depends on a fitted
        number (e.g. ``g``); by default ``payload_n`` is used as given.

    Returns
    -------
    Calibration
        Calibrated arm, values, how far each moved, posterior σ (from the Gauss–Newton
        covariance at the optimum) and whether the data identify it.
    """
    from scipy.optimize import least_squares

    base = arm.to_dict()
    printed = np.array([get_key(base, p.key) for p in params])
    start = np.array([p.start if p.start is not None else printed[i] for i, p in enumerate(params)])
    prior = np.array([p.prior_sigma for p in params], dtype=float)
    if (prior <= 0).any() or not np.isfinite(prior).all():
        raise EodarmError("calibration: every prior_sigma must be finite and > 0")
    alpha = np.asarray(alpha_deg, dtype=float)
    given = np.asarray(force_n, dtype=float)
    use = np.isfinite(given)

    def build(x: npt.NDArray[np.float64]) -> Arm:
        d = arm.to_dict()
        for p, v in zip(params, x, strict=True):
            set_key(d, p.key, float(v))
        return Arm.from_dict(d, source=f"{arm.source} (calibrated)")

    def forces(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        a = build(x)
        if payload_fn is not None:
            pay = payload_fn(a)
        elif payload_n is not None:
            pay = np.asarray(payload_n, dtype=float)
        else:
            raise EodarmError("calibration: give payload_n or payload_fn")
        return solve_payload(a, alpha, pay, [], self_weight=self_weight, strict=True)["force_n"]

    def resid(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        try:
            f = forces(x)
        except ValueError:
            return np.full(int(use.sum()) + len(x), 1e6)
        return np.concatenate([(f - given)[use] / force_sigma, (x - printed) / prior])

    sol = least_squares(resid, start, x_scale=prior, method="trf", xtol=1e-12, ftol=1e-12)
    x = sol.x
    jac = sol.jac
    try:
        cov = np.linalg.inv(jac.T @ jac)
        post = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        post = np.full(len(x), math.inf)
    return Calibration(
        arm=build(x),
        params=list(params),
        printed=printed,
        value=x,
        posterior_sigma=post,
        force_model=forces(x),
        force_given=given,
        force_sigma=force_sigma,
    )


# Masses assumed for the measured arm (none is published; NOTES.md). Link 3's is the 28.8 N
# that Table 5 carries at O3 (divided by the paper's g = 10).
SEED2022_ASSUMED_MASSES = {
    "link": [3.0, 2.5, 2.88],
    "actuator": [1.5, 1.2, 1.0],
}


def seed2022_calibration(tables: dict[str, Any]) -> dict[str, Any]:
    """Calibrate the printed geometry on Table 5 (self-weight off, as the paper says).

    Fitted: B0 (unknown, free), the paper's g (prior 9.81 ± 0.5), the payload point on arm 3
    (printed O4 = (400, 0), prior ± 200 mm), the garbled cells A1 and B2 (± 5 mm), the clearly
    printed pins and link lengths (± 0.5 mm, their rounding), and a lumped weight at O3
    (Table 5's offsets in F1 and F2, which no geometry produces with self-weight off: it is
    modelled as link 3's mass at its joint, contributing no moment to arm 3).

    Returns the :class:`~eodarm.analysis.calibrate.Calibration` of every parameter and the two arms:
    ``published`` (Table 1 with the calibrated B0) and ``calibrated`` (the measured arm:
    calibrated geometry, the real g = 9.81, assumed masses).
    """
    t3 = tables["table3"].sort_values(["config", "mass_kg"]).reset_index(drop=True)
    t5 = tables["table5"].sort_values(["config", "mass_kg"]).reset_index(drop=True)
    alpha = t3[[f"alpha{k}_unloaded_deg" for k in (1, 2, 3)]].to_numpy(dtype=float)
    mass = t3["mass_kg"].to_numpy(dtype=float)
    forces = t5[["F1_N", "F2_N", "F3_N"]].to_numpy(dtype=float)
    d = seed2022_published_dict()
    d["link"][2]["C"] = [0.0, 0.0]  # the O3 lump: a weight at the joint of arm 3
    start = Arm.from_dict(d, source="seed2022 Table 1")

    def payload(a: Arm) -> npt.NDArray[np.float64]:
        return np.column_stack([np.zeros_like(mass), -mass * a.g])

    params = [
        GeomParam("base.B0.x", 1000.0, -550.0),
        GeomParam("base.B0.y", 1000.0, -60.0),
        GeomParam("g", 0.5),
        GeomParam("link[3].next.x", 200.0),
        GeomParam("link[3].next.y", 200.0),
        GeomParam("link[3].mass_kg", 10.0),
        GeomParam("link[1].A.x", 5.0),
        GeomParam("link[1].A.y", 5.0),
        GeomParam("link[2].B.x", 5.0),
        GeomParam("link[2].B.y", 5.0),
        GeomParam("link[1].B.x", 0.5),
        GeomParam("link[1].B.y", 0.5),
        GeomParam("link[2].A.x", 0.5),
        GeomParam("link[2].A.y", 0.5),
        GeomParam("link[3].A.x", 0.5),
        GeomParam("link[3].A.y", 0.5),
        GeomParam("link[1].next.x", 0.5),
        GeomParam("link[2].next.x", 0.5),
    ]
    cal = calibrate_geometry(
        start,
        alpha,
        None,
        forces,
        params,
        force_sigma=0.05,
        self_weight=True,
        payload_fn=payload,
    )
    b0 = [float(cal.value[0]), float(cal.value[1])]
    pub = seed2022_published_dict()
    pub["base"]["B0"] = b0
    published = Arm.from_dict(pub, source="seed2022 arm_published")
    measured = cal.arm.to_dict()
    measured["name"] = "seed2022"
    measured["g"] = 9.81
    measured["link"][2]["C"] = list(seed2022_published_dict()["link"][2]["C"])
    for i, m in enumerate(SEED2022_ASSUMED_MASSES["link"]):
        measured["link"][i]["mass_kg"] = m
    for i, m in enumerate(SEED2022_ASSUMED_MASSES["actuator"]):
        measured["actuator"][i]["mass_kg"] = m
    calibrated = Arm.from_dict(measured, source="seed2022 arm")
    return {"calibration": cal, "published": published, "calibrated": calibrated}
