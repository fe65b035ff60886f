"""The core's Jacobian (``_core.jacobian``: what ``fit`` and ``diagnose`` call, on the block
kernel for arms of 1–6 links) is the derivative of what ``eodarm.solve`` answers, and fails
like ``solve``: NaN rows where a pose cannot be solved, or one error naming the lowest row.

Tolerances. The channels y are ``solve``'s to 1e-9 mm / 1e-9 deg (two implementations of one
model agree to ~1e-13). The Jacobian is compared with central differences of ``solve`` taken
with a step of 1 % of θ, much larger than the core's 0.1 %: the deflections are linear in θ up
to the geometric nonlinearity of the closure, so the two differences agree to ~1e-6 of a
column's size; 1e-4 is allowed (and 1e-8 of the probe's largest channel in a channel it does
not move, where the difference is rounding). A wrong channel, probe or row is off by order one.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import eodarm
from eodarm.model import native as _core
from eodarm.model.effects import Slot, param_from_theta
from eodarm.model.solver import _core_arm

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
G = 9.81

#: The model (slot, θ) whose parameters are differentiated: an actuator body, a mount, a
#: clearance taken up, a play, a bent link and the base (θ = 1/k, gap, 1/EI, 1/k_base).
MODEL = [
    (Slot.parse("actuator_compliance@M1"), 1.0 / 2000.0),
    (Slot.parse("mount_compliance@M2"), 1.0 / 1500.0),
    (Slot("joint_clearance", "O3", "taken_up"), 0.12),
    (Slot.parse("actuator_play@M3"), 0.08),
    (Slot.parse("link_bending@L2"), 1.0 / 2e10),
    (Slot.parse("base_compliance@base"), 1.0 / 5e8),
]


def poses(rows: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    alpha = np.array([60.0, 0.0, -10.0]) + np.array([50.0, 30.0, 20.0]) * rng.random((rows, 3))
    return alpha, 1.0 + 7.0 * rng.random(rows)


def jacobian(
    arm: eodarm.Arm, alpha: np.ndarray, mass: np.ndarray, nan_on_failure: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    payload = np.column_stack([np.zeros(len(mass)), -G * mass])
    n = arm.n
    ints = lambda xs: np.array(xs, dtype=np.int64)  # noqa: E731
    return _core.jacobian(  # type: ignore[no-any-return]
        _core_arm(arm),
        np.ascontiguousarray(alpha),
        payload,
        ints([s.code for s, _ in MODEL]),
        ints([s.index(n) for s, _ in MODEL]),
        np.array([t for _, t in MODEL]),
        ints([s.code for s, _ in MODEL]),
        ints([s.index(n) for s, _ in MODEL]),
        True,
        nan_on_failure,
    )


def channels(arm: eodarm.Arm, alpha: np.ndarray, mass: np.ndarray, thetas: list[float]):
    """dx, dy, dα (deg), dl (mm) of ``eodarm.solve`` with the model at ``thetas``."""
    effects = [
        s.effect(param_from_theta(s.name, t)) for (s, _), t in zip(MODEL, thetas, strict=True)
    ]
    out = eodarm.solve(arm, alpha, mass, effects)
    return np.column_stack([out["dx_mm"], out["dy_mm"], out["dalpha_deg"], out["dl_mm"]])


@pytest.mark.parametrize("rows", [5, 700])  # one partial block; parallel chunks
def test_the_jacobian_is_the_derivative_of_solve(rows: int) -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha, mass = poses(rows, rows)
    y, jac = jacobian(arm, alpha, mass)
    thetas = [t for _, t in MODEL]
    assert y.shape == (rows, 2 + 2 * arm.n) and jac.shape == (*y.shape, len(MODEL))
    np.testing.assert_allclose(y, channels(arm, alpha, mass, thetas), rtol=0, atol=1e-9)
    for j, t in enumerate(thetas):
        up, down = list(thetas), list(thetas)
        up[j], down[j] = 1.01 * t, 0.99 * t
        fd = (channels(arm, alpha, mass, up) - channels(arm, alpha, mass, down)) / (0.02 * t)
        scale = np.abs(fd).max(axis=0)  # per channel
        assert (scale > 0).any(), MODEL[j][0].key
        # + 1e-8 of the largest channel: a channel the probe does not move (a zero difference)
        # has the rounding of the others
        tol = np.broadcast_to(1e-4 * scale + 1e-8 * scale.max(), fd.shape)
        np.testing.assert_array_less(np.abs(jac[:, :, j] - fd), tol, err_msg=MODEL[j][0].key)


def test_failing_rows_are_nan_or_the_lowest_rows_error() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha, mass = poses(700, 3)
    o1, b0, a1 = np.array(arm.O1), np.array(arm.B0), np.array(arm.links[0].A)
    away = o1 - b0
    singular = math.degrees(math.atan2(away[1], away[0]) - math.atan2(a1[1], a1[0]))
    alpha[333] = [singular, 10.0, 0.0]  # actuator 1 through its joint
    mass[600] = 1e8  # a triangle that cannot close
    y, jac = jacobian(arm, alpha, mass, nan_on_failure=True)
    bad = np.isnan(y).any(axis=1)
    assert list(np.flatnonzero(bad)) == [333, 600]
    assert np.isnan(y[bad]).all() and np.isnan(jac[bad]).all()
    assert np.isfinite(y[~bad]).all() and np.isfinite(jac[~bad]).all()
    with pytest.raises(ValueError, match="row 333") as exc:
        jacobian(arm, alpha, mass)
    assert "\n" not in str(exc.value)
