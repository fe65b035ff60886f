"""examples/thresholds.py: the preload reliefs written for the seed data
(docs/seed-reproduction.md §6)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import eodarm
from eodarm.model import custom

ROOT = Path(__file__).resolve().parent.parent
ALPHA = [90.0, 10.0, 0.0]
MASS = [1.5, 3.0, 5.0, 6.5]


@pytest.fixture(scope="module")
def arm() -> Iterator[eodarm.Arm]:
    custom.load_file(ROOT / "examples" / "thresholds.py")
    yield eodarm.Arm.from_toml(ROOT / "examples" / "example_arm.toml")
    custom.unregister("mount_preload")
    custom.unregister("joint_preload")


def _solve(arm: eodarm.Arm, effects: list[eodarm.Effect]) -> dict:
    return eodarm.solve(arm, [ALPHA] * len(MASS), MASS, effects=effects)


@pytest.mark.parametrize("name,place", [("mount_preload", "M2"), ("joint_preload", "O2")])
def test_a_zero_relief_is_the_baseline(arm: eodarm.Arm, name: str, place: str) -> None:
    base = _solve(arm, [])
    got = _solve(arm, [eodarm.Effect(name, place, relief_mm=0.0)])
    np.testing.assert_allclose(got["dy_mm"], base["dy_mm"], rtol=0, atol=1e-12)


def test_a_mount_relief_gives_back_sag_and_is_unseen_by_the_sensors(arm: eodarm.Arm) -> None:
    mount = eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=500.0)
    soft = _solve(arm, [mount])
    relieved = _solve(arm, [mount, eodarm.Effect("mount_preload", "M2", relief_mm=0.02)])
    np.testing.assert_allclose(relieved["dl_mm"], soft["dl_mm"], rtol=0, atol=1e-12)
    # every state's force change is beyond the 10 N threshold: the relief is the same
    # 0.02 mm of actuator length in each, so the sag moves back towards the stiff arm
    assert np.all(np.abs(relieved["dy_mm"]) < np.abs(soft["dy_mm"]))
    shift = np.abs(soft["dy_mm"]) - np.abs(relieved["dy_mm"])
    assert np.ptp(shift) < 0.1 * shift.mean()


def test_a_negative_relief_is_refused(arm: eodarm.Arm) -> None:
    with pytest.raises(eodarm.EodarmError, match="relief_mm"):
        eodarm.Effect("mount_preload", "M2", relief_mm=-0.1)
