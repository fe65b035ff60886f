"""One answer per pose (issue 23 item 4): a pose that cannot be closed under its load is NaN
with a status in ``eodarm.solve``, as ``eodarm.sweep`` marks its cell, and the other poses of
the batch are solved; ``strict=True`` raises naming the row; invalid input (a pose singular
unloaded) raises either way; the data commands still refuse a row that cannot be closed."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import eodarm
from eodarm.data import datasets
from eodarm.errors import InputError
from eodarm.model import native

#: A grid over the seed arm's workspace (its soft 500 N/mm springs): at 6.5 kg dozens of its
#: poses cannot close an actuator triangle under the load, and a few are near singular.
A1, A2, A3 = np.arange(20, 161, 10.0), np.arange(-60, 61, 10.0), np.arange(-60, 61, 15.0)
MASSES = [1.0, 6.5]


@pytest.fixture(scope="module")
def arm() -> eodarm.Arm:
    return datasets.load("seed2022").arm


def _grid() -> np.ndarray:
    return np.stack(np.meshgrid(A1, A2, A3, indexing="ij"), -1).reshape(-1, 3)


def _cannot_close(arm: eodarm.Arm) -> tuple[np.ndarray, np.ndarray]:
    """Poses of the grid that close at 1 kg (status ok) but not at 6.5 kg, and the rest."""
    alpha = _grid()
    light = eodarm.solve(arm, alpha, 1.0)
    heavy = eodarm.solve(arm, alpha, 6.5)
    bad = np.isnan(heavy["dy_mm"]) & (light["status"] == 0)
    assert bad.sum() >= 10, "the grid no longer holds poses that fail under load"
    return alpha[bad], alpha[np.isfinite(heavy["dy_mm"])]


def _singular(arm: eodarm.Arm) -> float:
    """α1 at which actuator 1's line passes through O1 (A1 between O1 and B0)."""
    b0 = np.array(arm.B0) - np.array(arm.O1)
    a = np.array(arm.links[0].A)
    return math.degrees(math.atan2(b0[1], b0[0]) - math.atan2(a[1], a[0]))


@pytest.mark.parametrize("backend", ["rust", "numpy"])
def test_solve_and_sweep_agree_pose_by_pose(arm: eodarm.Arm, backend: str) -> None:
    ds = eodarm.sweep(arm, alpha_deg={"alpha1": A1, "alpha2": A2, "alpha3": A3}, mass_kg=MASSES)
    cells = ds.status.transpose("alpha1", "alpha2", "alpha3", "mass_kg").values
    alpha = _grid()
    for j, m in enumerate(MASSES):
        out = eodarm.solve(arm, alpha, m, backend=backend)  # the whole batch, never raising
        want = cells[..., j].reshape(-1)
        np.testing.assert_array_equal(out["status"], want, err_msg=f"{m} kg")
        failed = np.isnan(out["dy_mm"])
        assert (out["status"][failed] != 0).all()
        # every output of a failed pose is NaN, none of a solved one
        for key in ("dx_mm", "force_n", "dalpha_deg", "dl_mm"):
            v = np.asarray(out[key]).reshape(len(alpha), -1)
            assert np.isnan(v[failed]).all() and np.isfinite(v[~failed]).all(), key
    assert np.isnan(eodarm.solve(arm, alpha, 6.5, backend=backend)["dy_mm"]).sum() > 0


def test_the_other_poses_are_the_same_as_alone(arm: eodarm.Arm) -> None:
    bad, good = _cannot_close(arm)
    mixed = np.vstack([good[:3], bad[:1], good[3:6]])
    out = eodarm.solve(arm, mixed, 6.5)
    alone = eodarm.solve(arm, np.vstack([good[:3], good[3:6]]), 6.5)
    np.testing.assert_array_equal(np.isnan(out["dy_mm"]), [0, 0, 0, 1, 0, 0, 0])
    # the same kernel on the same rows: equal to rounding (1e-9 mm)
    np.testing.assert_allclose(np.delete(out["dy_mm"], 3), alone["dy_mm"], rtol=0, atol=1e-9)


@pytest.mark.parametrize("backend", ["rust", "numpy"])
def test_strict_raises_naming_the_row(arm: eodarm.Arm, backend: str) -> None:
    bad, good = _cannot_close(arm)
    alpha = np.vstack([good[:2], bad[:1], good[2:3]])
    with pytest.raises(InputError, match=r"pose row 2: actuator \d cannot close") as exc:
        eodarm.solve(arm, alpha, 6.5, backend=backend, strict=True)
    assert "\n" not in str(exc.value)
    # the eodarm error the docstring promises, not the compiled core's own class
    assert not isinstance(exc.value, native.CoreError)


@pytest.mark.parametrize("strict", [False, True])
def test_a_pose_singular_unloaded_is_invalid_input_either_way(
    arm: eodarm.Arm, strict: bool
) -> None:
    bad, good = _cannot_close(arm)
    singular = [_singular(arm), 10.0, 0.0]
    if strict:  # the first failing row is named
        alpha, row = np.vstack([good[:2], [singular], bad[:1]]), 2
    else:  # after a pose failing under load: the caller's row is named, not a sub-batch's
        alpha, row = np.vstack([bad[:1], good[:2], [singular], good[2:3]]), 3
    with pytest.raises(InputError, match=rf"pose row {row}: actuator 1") as exc:
        eodarm.solve(arm, alpha, 6.5, strict=strict)
    assert "singular" in str(exc.value) or "passes through" in str(exc.value)
    assert not isinstance(exc.value, native.CoreError)


def test_the_command_line_gives_each_pose_its_answer(arm: eodarm.Arm, tmp_path: Path) -> None:
    bad, good = _cannot_close(arm)
    argv = [sys.executable, "-m", "eodarm", "solve", "--mass", "6.5"]
    for a in (good[0], bad[0]):
        argv += ["--alpha", ",".join(f"{x:g}" for x in a)]
    done = subprocess.run([*argv, "--json"], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    poses = json.loads(done.stdout, parse_constant=lambda t: pytest.fail(f"JSON with {t}"))["poses"]
    assert poses[0]["status"] == 0 and poses[0]["dy_mm"] < 0
    assert poses[1]["dy_mm"] is None and poses[1]["status"] != 0
    assert "cannot be closed under their load" in done.stderr
    strict = subprocess.run([*argv, "--strict"], capture_output=True, text=True, check=False)
    assert strict.returncode == 2
    assert strict.stdout == ""
    lines = strict.stderr.strip().splitlines()
    assert len(lines) == 1 and "pose row 1" in lines[0] and "cannot close" in lines[0]


def test_fit_still_refuses_a_data_row_that_cannot_be_closed(arm: eodarm.Arm) -> None:
    bad, good = _cannot_close(arm)
    alpha = np.vstack([good[:4], bad[:1]])
    meas = eodarm.Measurements.from_arrays(
        config=[f"c{i}" for i in range(5)],
        alpha_deg=alpha,
        mass_kg=np.full(5, 6.5),
        values={"dy_mm": np.full(5, -20.0)},
        sigma={"dy_mm": np.full(5, 0.05)},
    )
    with pytest.raises(ValueError, match="row 4: actuator 3 cannot close"):
        eodarm.fit(arm, meas, ["joint_clearance@O2"])
