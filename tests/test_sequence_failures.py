"""One answer per state (issue 27 item 7): ``eodarm.solve_sequence`` does per state what
``eodarm.solve`` does per pose (docs/model.md §7, "One answer per pose").

* by default a state that cannot be closed under its load gets NaN and its status, and every
  other state is solved: the other sequences, and the states of its own sequence before and
  after it (the frictions step through it), the same on both backends;
* ``strict=True`` raises an ``EodarmError`` (an ``InputError``), never the compiled core's own
  exception, in one line naming the sequence and the state;
* a pose singular unloaded raises either way, naming the sequence;
* a batch too large for memory is refused from the shapes, before any input is copied.
"""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest

import eodarm
from arms import example_arm
from eodarm.errors import EodarmError, InputError, OutOfMemoryError
from eodarm.model import native, resources

POSES = np.array([[90.0, 10.0, 0.0], [70.0, 20.0, -10.0], [110.0, 25.0, 10.0]])
#: A soft mount: 1.5 kg closes (a large deflection), 300 kg cannot close actuator 1's triangle.
SOFT = eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=20.0)
FRICTION = eodarm.Effect("joint_friction", "O2", torque_nmm=20000.0)
LIGHT, HEAVY = 1.5, 300.0
#: Both backends close the same states from the same causes: rounding of ~1e3 mm sums.
EXACT_MM = 1e-9


def masses() -> np.ndarray:
    """Sequence 1 meets the payload it cannot carry in its state 1; the others do not."""
    m = np.full((3, 3), LIGHT)
    m[1, 1] = HEAVY
    return m


@pytest.mark.parametrize("backend", ["rust", "numpy"])
@pytest.mark.parametrize("effects", [[SOFT], [SOFT, FRICTION]], ids=["springs", "friction"])
def test_a_state_that_cannot_close_is_nan_and_the_others_are_solved(
    backend: str, effects: list[eodarm.Effect]
) -> None:
    arm = example_arm()
    out = eodarm.solve_sequence(arm, POSES, masses(), effects, backend=backend)
    failed = np.isnan(out["dy_mm"])
    np.testing.assert_array_equal(failed, [[0, 0, 0], [0, 1, 0], [0, 0, 0]])
    assert out["status"][1, 1] != 0
    for key in ("dx_mm", "force_n", "dalpha_deg", "dl_mm"):
        v = np.asarray(out[key]).reshape(9, -1)
        assert np.isnan(v[failed.ravel()]).all() and np.isfinite(v[~failed.ravel()]).all(), key
    # the states around it are those of the sequence without it where nothing remembers
    # (springs); with a friction the one after it still follows from what was held
    if effects == [SOFT]:
        alone = eodarm.solve(arm, POSES[1:2], LIGHT, effects, backend=backend)
        np.testing.assert_allclose(out["dy_mm"][1, [0, 2]], alone["dy_mm"][0], atol=EXACT_MM)
    other = "numpy" if backend == "rust" else "rust"
    twin = eodarm.solve_sequence(arm, POSES, masses(), effects, backend=other)
    np.testing.assert_array_equal(np.isnan(twin["dy_mm"]), failed)
    np.testing.assert_allclose(out["dy_mm"][~failed], twin["dy_mm"][~failed], atol=EXACT_MM)
    np.testing.assert_array_equal(out["status"], twin["status"])


@pytest.mark.parametrize("backend", ["rust", "numpy"])
def test_strict_raises_an_eodarm_error_naming_the_sequence_and_the_state(backend: str) -> None:
    with pytest.raises(EodarmError) as exc:
        eodarm.solve_sequence(example_arm(), POSES, masses(), [SOFT], backend=backend, strict=True)
    assert isinstance(exc.value, InputError) and not isinstance(exc.value, native.CoreError)
    text = str(exc.value)
    assert text.startswith("sequence 1, state 1 (mass_kg[1, 1] = 300 kg): actuator 1 cannot ")
    assert "\n" not in text and len(text) < 300


@pytest.mark.parametrize("strict", [False, True])
def test_a_pose_singular_unloaded_is_invalid_input_either_way(strict: bool) -> None:
    arm = example_arm()
    b0 = np.array(arm.B0) - np.array(arm.O1)
    a = np.array(arm.links[0].A)
    through = math.degrees(math.atan2(b0[1], b0[0]) - math.atan2(a[1], a[0]))
    alpha = np.vstack([POSES[:2], [[through, 10.0, 0.0]]])
    with pytest.raises(InputError, match=r"^sequence 2\b") as exc:
        eodarm.solve_sequence(arm, alpha, [LIGHT, 0.0], strict=strict)
    assert not isinstance(exc.value, native.CoreError)


def test_a_batch_too_large_is_refused_before_any_input_is_copied(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The issue's case (10⁸ × 6 took 19 s and 8.9 GB to be refused): here 2·10⁶ × 6 states
    against 1 GB of memory; copying the inputs alone would take 144 MB."""
    monkeypatch.setattr(resources, "available_memory", lambda: 10**9)
    n = 2_000_000
    alpha = np.broadcast_to(POSES[0], (n, 3))  # views: no memory of their own
    mass = np.broadcast_to(np.arange(6.0), (n, 6))
    tracemalloc.start()
    try:
        with pytest.raises(OutOfMemoryError, match=r"solve_sequence of 12,000,000 states"):
            eodarm.solve_sequence(example_arm(), alpha, mass)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 10 * 2**20, peak
