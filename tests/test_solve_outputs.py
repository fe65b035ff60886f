"""``outputs=`` of :func:`eodarm.solve` and :func:`eodarm.solve_sequence` (issue 31,
docs/python.md "Asking for some outputs"): a call returns exactly the asked keys and
``status``, each value exactly that of the call with every output, whatever the subset, the
arm (linear, rotary, mixed example arms), the path (the block kernel; the general path that
a user-written deformation or a joint friction beside a bent link takes), the backend, the
model and ``uncertainty``; a bad ``outputs`` is refused in one line that names it and lists
the valid keys; ``out=`` then holds exactly the asked keys.

Exact equality is the right check: both calls run in the same process through the same code
on the same inputs, and not writing an array changes no arithmetic.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.errors import InputError
from eodarm.model.outputs import FEM_KEYS, SOLVE_KEYS
from strategies import output_subsets

ROOT = Path(__file__).resolve().parent.parent
ARM_FILES = {
    kind: ROOT / "examples" / f"{kind}_arm.toml" for kind in ("example", "rotary", "mixed")
}
#: Working ranges of the relative joint angles q_i (deg), as benches/bench_floor.py's.
RANGES = {
    "example": [(60.0, 110.0), (-80.0, -50.0), (-30.0, -10.0)],
    "rotary": [(0.0, 60.0), (-60.0, 0.0), (-40.0, 20.0)],
    "mixed": [(10.0, 80.0), (-110.0, -40.0), (-90.0, -20.0)],
}
#: Effects the block kernel takes, per arm; the general path adds a bending beside the
#: joint friction (solve and sequences), or an extra deformation (solve).
KERNEL_EFFECTS = {
    "example": [
        eodarm.Effect("joint_friction", "O3", torque_nmm=4000.0),
        eodarm.Effect("joint_clearance", "O3", clearance_mm=0.15),
        eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
    ],
    "rotary": [
        eodarm.Effect("drive_friction", "O2", torque_nmm=2000.0),
        eodarm.Effect("joint_friction", "O3", torque_nmm=1000.0),
        eodarm.Effect("drive_compliance", "O2", stiffness_nmm_per_rad=1.0e7),
    ],
    "mixed": [
        eodarm.Effect("drive_friction", "O1", torque_nmm=4000.0),
        eodarm.Effect("joint_friction", "O3", torque_nmm=4000.0),
        eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=4000.0),
    ],
}
BENT = eodarm.Effect("link_bending", "L2", ei_n_mm2=3.0e9)
PATHS = ("none", "kernel", "general", "extra")


def arm_of(kind: str) -> eodarm.Arm:
    return eodarm.Arm.from_toml(ARM_FILES[kind])


def poses(kind: str, rows: int, seed: int) -> np.ndarray:
    """``rows`` absolute angles (deg) of the arm's working range."""
    rng = np.random.default_rng(seed)
    q = np.column_stack([rng.uniform(lo, hi, rows) for lo, hi in RANGES[kind]])
    return np.cumsum(q, axis=1)


def model(kind: str, path: str) -> dict[str, Any]:
    """The keyword arguments of the path: effects, or an extra deformation."""
    if path == "none":
        return {}
    if path == "extra":
        return {"extra": {"extra_measure_mm": np.full((ROWS, 2), 0.01)}}
    return {"effects": [*KERNEL_EFFECTS[kind], *([BENT] if path == "general" else [])]}


ROWS = 12
#: Masses of the solve's rows (kg): the last one no arm carries (its status not ok; NaN where
#: an actuator's triangle cannot close), so that the failed rows are compared too. On the
#: example arm some actuator's triangle fails under it for every seed (none of the 9363 seeds
#: 0, 7, 14, … below 2¹⁶ gave a number); on the mixed arm the drive at joint 1 can carry it
#: while links 2 and 3 stand so that the two cylinders are almost unloaded (58 of those 9363
#: seeds, 1422 among them: dy −238 mm, status not ok), so only the status is asserted there.
MASSES = np.array([0.0, 1.0, 2.5, 4.0, 7.0, 0.5, 3.0, 6.0, 2.0, 5.0, 1.5, 4e5])
STATES = np.array([1.5, 5.0, 0.0, 3.0])


def assert_subset(full: dict[str, Any], part: dict[str, Any], asked: list[str]) -> None:
    assert list(part) == [*(k for k in asked if k != "status"), "status"]
    for key in part:
        assert np.array_equal(np.asarray(part[key]), np.asarray(full[key]), equal_nan=True), key


@settings(max_examples=40, deadline=None)
@given(
    kind=st.sampled_from(sorted(ARM_FILES)),
    path=st.sampled_from(PATHS),
    asked=output_subsets(),
    sequence=st.booleans(),
    seed=st.integers(0, 2**16),
)
# the mixed arm carrying the last row without a NaN (a soak run's failure of an older check)
@example(kind="mixed", path="none", asked=["force_n"], sequence=False, seed=1422)
def test_any_subset_is_the_full_call(
    kind: str, path: str, asked: list[str], sequence: bool, seed: int
) -> None:
    arm = arm_of(kind)
    alpha = poses(kind, ROWS, seed)
    kw = model(kind, path)
    if sequence:
        kw.pop("extra", None)  # sequences take no extra deformations: the kernel's effects
        full = eodarm.solve_sequence(arm, alpha, STATES, **kw)
        part = eodarm.solve_sequence(arm, alpha, STATES, **kw, outputs=asked)
    else:
        full = eodarm.solve(arm, alpha, MASSES, **kw)
        part = eodarm.solve(arm, alpha, MASSES, **kw, outputs=asked)
        assert full["status"][-1] != 0  # a load no arm carries
        assert kind != "example" or np.isnan(full["dy_mm"][-1])  # a triangle that cannot close
    assert_subset(full, part, asked)


@pytest.mark.parametrize("kind", sorted(ARM_FILES))
def test_subsets_of_a_parallel_solve_are_the_full_solve(kind: str) -> None:
    # 5000 rows: the core cuts the asked outputs into chunks solved on both threads
    arm = arm_of(kind)
    alpha = poses(kind, 5000, 1)
    mass = np.random.default_rng(2).uniform(0.0, 8.0, 5000)
    for kw in ({}, model(kind, "general")):
        full = eodarm.solve(arm, alpha, mass, **kw)
        for asked in (["dx_mm", "dy_mm"], ["status"], ["reaction_n", "torque_nmm", "dl_mm"]):
            assert_subset(full, eodarm.solve(arm, alpha, mass, **kw, outputs=asked), asked)
        seq = eodarm.solve_sequence(arm, alpha[:700], STATES, **kw)
        part = eodarm.solve_sequence(arm, alpha[:700], STATES, **kw, outputs=["dalpha_deg"])
        assert_subset(seq, part, ["dalpha_deg"])


def test_the_numpy_backend_selects_the_same_keys() -> None:
    arm = arm_of("example")
    alpha = poses("example", 6, 3)
    asked = ["dy_mm", "force_n"]
    full = eodarm.solve(arm, alpha, 4.0, backend="numpy")
    assert_subset(full, eodarm.solve(arm, alpha, 4.0, backend="numpy", outputs=asked), asked)
    seq = eodarm.solve_sequence(arm, alpha, STATES, backend="numpy")
    part = eodarm.solve_sequence(arm, alpha, STATES, backend="numpy", outputs=asked)
    assert_subset(seq, part, asked)


def test_the_fem_model_selects_its_own_keys_too() -> None:
    arm = arm_of("example")
    alpha = poses("example", 3, 4)
    full = eodarm.solve(arm, alpha, 4.0, model="fem")
    assert set(full) == {*SOLVE_KEYS, *FEM_KEYS, "status"}  # the keys outputs= knows
    asked = ["pin_force_n", "dy_mm", "n_dof"]
    assert_subset(full, eodarm.solve(arm, alpha, 4.0, model="fem", outputs=asked), asked)
    with pytest.raises(InputError, match="unknown key 'pin_force_n'"):
        eodarm.solve(arm, alpha, 4.0, outputs=["pin_force_n"])  # the analytic model's


@pytest.fixture(scope="module")
def fitted() -> eodarm.Arm:
    """The example arm with a fitted mount compliance (its covariance carried)."""
    from eodarm.analysis.fit import FitWarning
    from eodarm.analysis.synth import random_configs, synth

    arm = arm_of("example")
    hidden = [eodarm.Effect("mount_compliance", "M1", stiffness_n_per_mm=2500.0)]
    meas = synth(arm, random_configs(arm, 8, rng=1), [1.5, 5.0], hidden, seed=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        return eodarm.fit(arm, meas, ["mount_compliance@M1"]).to_arm()


def test_the_sigmas_are_selectable_alone_or_with_outputs(fitted: eodarm.Arm) -> None:
    alpha = poses("example", 5, 5)
    full = eodarm.solve(fitted, alpha, 4.0, uncertainty=True)
    for asked in (["sigma_dy_mm"], ["dx_mm", "sigma_param_dalpha_deg"]):
        part = eodarm.solve(fitted, alpha, 4.0, uncertainty=True, outputs=asked)
        assert_subset(full, part, asked)
    seq = eodarm.solve_sequence(fitted, alpha, STATES, uncertainty=True)
    part = eodarm.solve_sequence(fitted, alpha, STATES, uncertainty=True, outputs=["sigma_dx_mm"])
    assert_subset(seq, part, ["sigma_dx_mm"])


def test_out_holds_exactly_the_asked_keys() -> None:
    arm = arm_of("mixed")
    alpha = poses("mixed", 8, 6)
    asked = ["dx_mm", "dy_mm"]
    full = eodarm.solve(arm, alpha, 3.0)
    out = {k: np.full_like(v, 7) for k, v in eodarm.solve(arm, alpha, 3.0, outputs=asked).items()}
    res = eodarm.solve(arm, alpha, 3.0, out=out, outputs=asked)
    assert_subset(full, res, asked)
    assert all(res[k] is out[k] for k in out)  # written into the caller's arrays
    only_dx = {"dx_mm": out["dx_mm"], "status": out["status"]}
    res = eodarm.solve(arm, alpha, 3.0, out=only_dx, outputs=["dx_mm"])  # strict=False: dy
    assert list(res) == ["dx_mm", "status"] and np.array_equal(res["dx_mm"], full["dx_mm"])
    with pytest.raises(InputError, match="out: missing key 'dy_mm'"):
        eodarm.solve(arm, alpha, 3.0, out=only_dx, outputs=asked)
    extra = {**out, "force_n": np.empty((8, 3))}
    with pytest.raises(InputError, match="out: key 'force_n' is not in outputs"):
        eodarm.solve(arm, alpha, 3.0, out=extra, outputs=asked)


def test_a_pose_singular_unloaded_is_refused_whatever_is_asked() -> None:
    # actuator 1's line through O1 (A1 on the segment O1–B0): invalid input, named by its row
    arm = arm_of("example")
    b0 = np.array(arm.B0) - np.array(arm.O1)
    a_loc = np.array(arm.links[0].A)
    alpha = poses("example", 4, 7)
    alpha[2, 0] = math.degrees(math.atan2(b0[1], b0[0]) - math.atan2(a_loc[1], a_loc[0]))
    with pytest.raises(InputError, match="pose row 2: actuator 1 passes through joint O1"):
        eodarm.solve(arm, alpha, 1.0, outputs=["dx_mm"])
    with pytest.raises(InputError, match="sequence 2: actuator 1 passes through joint O1"):
        eodarm.solve_sequence(arm, alpha, STATES, outputs=["force_n"])


@pytest.mark.parametrize(
    ("outputs", "says"),
    [
        ("dx_mm", "a bare string 'dx_mm'"),
        ((), "empty"),
        (["dx_mm", "dy_mm", "dx_mm"], "key 'dx_mm' asked for twice"),
        (["dx_mm", "dz_mm"], "unknown key 'dz_mm'"),
        ([3], "unknown key 3"),
        (["sigma_dx_mm"], "unknown key 'sigma_dx_mm' (sigma keys need uncertainty=True)"),
        (["x" * 500], "unknown key 'xxxx"),
    ],
)
def test_a_bad_outputs_is_one_line_listing_the_valid_keys(outputs: Any, says: str) -> None:
    arm = arm_of("rotary")
    alpha = poses("rotary", 2, 8)
    for call in (
        lambda: eodarm.solve(arm, alpha, 1.0, outputs=outputs),
        lambda: eodarm.solve_sequence(arm, alpha, STATES, outputs=outputs),
        lambda: eodarm.solve(arm, alpha, 1.0, backend="numpy", outputs=outputs),
    ):
        with pytest.raises(InputError) as err:
            call()
        text = str(err.value)
        assert says in text and "\n" not in text and len(text) < 300, text
        assert text.endswith(f"valid: {', '.join(SOLVE_KEYS)}, status"), text


def test_the_valid_keys_of_fem_and_uncertainty_are_listed_in_one_short_line(
    fitted: eodarm.Arm,
) -> None:
    alpha = poses("example", 2, 9)
    with pytest.raises(InputError) as err:
        eodarm.solve(arm_of("example"), alpha, 1.0, model="fem", outputs=["moment"])
    text = str(err.value)
    assert "pin_force_n" in text and "node_disp" in text and len(text) < 300, text
    with pytest.raises(InputError) as err:
        eodarm.solve(fitted, alpha, 1.0, uncertainty=True, outputs=["sigma"])
    text = str(err.value)
    assert "sigma_dalpha_deg" in text and "length_mm" in text and len(text) < 300, text


def test_the_compiled_core_makes_only_the_asked_arrays() -> None:
    # the binding allocates what is asked and status, nothing else (what a caller pays for)
    from eodarm.model import native
    from eodarm.model.kinematics import _core_arm

    arm = arm_of("example")
    alpha = poses("example", 4, 10)
    payload = np.column_stack([np.zeros(4), np.full(4, -30.0)])
    none = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
    res = native.solve(_core_arm(arm), alpha, payload, *none, True, outputs=["dl_mm"])
    assert sorted(res) == ["dl_mm", "status"] and res["dl_mm"].shape == (4, 3)
    seq = native.solve_sequence(
        _core_arm(arm), alpha, np.full((4, 2), 3.0), *none, True, outputs=["dx_mm"]
    )
    assert sorted(seq) == ["dx_mm", "status"] and seq["dx_mm"].shape == (4, 2)


@pytest.mark.parametrize("effects", [None, KERNEL_EFFECTS["example"]])
def test_a_non_finite_angle_is_refused_in_the_same_words_by_both_backends(effects: Any) -> None:
    # eodarm.solve leaves this check to the compiled core's (one pass over the angles, not
    # two): the same InputError, the same row, as the numpy backend's Python check
    arm = arm_of("example")
    for row, value in ((3, np.nan), (0, np.inf), (5, -np.inf)):
        alpha = poses("example", 6, 11)
        alpha[row, 1] = value
        texts = []
        for backend in ("rust", "numpy"):
            with pytest.raises(InputError) as err:
                eodarm.solve(arm, alpha, 2.0, effects, backend=backend, outputs=["dy_mm"])
            texts.append(str(err.value))
        assert texts[0] == texts[1] == f"pose row {row}: alpha_deg has a non-finite value"
    with pytest.raises(InputError, match="pose row 0: alpha_deg has a non-finite value"):
        eodarm.solve(arm, [90.0, np.nan, 0.0], [1.0, 2.0])  # one pose under two masses
