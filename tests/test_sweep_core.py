"""The compiled sweep (``eodarm._core.sweep``) against ``eodarm.solve`` on both backends.

A sweep cell (pose p, mass j) must be the pose solved alone under that payload: the same
forces, deflections, angle changes and sensor readings, whichever kernel the core picks (the
sweep's block kernel for the baseline and the length-only effects, ``solve``'s block kernel for
the others, frictions included, and ``Workspace::solve`` per cell beyond six links). Cells
that cannot be solved are NaN with ``ok`` false; reductions equal numpy's; Ctrl-C stops a
running sweep and a sweep that is not interrupted runs to the end.
"""

from __future__ import annotations

import signal
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from eodarm import _core
from eodarm.model.effects import effect_arrays
from eodarm.model.solver import _core_arm
from strategies import ALL_KINDS, FRICTIONS, arm_and_poses, effects_for

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
CELL_KEYS = ("force_n", "dx_mm", "dy_mm", "dalpha_deg", "dl_mm")
LENGTH_ONLY = [
    eodarm.Effect("actuator_compliance", "M1", stiffness_n_per_mm=1500.0),
    eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=900.0),
    eodarm.Effect("actuator_play", "M3", play_mm=0.05),
]
OTHERS = [
    eodarm.Effect("joint_clearance", "O2", clearance_mm=0.1),
    eodarm.Effect("link_bending", "L2", ei_n_mm2=8e8),
    eodarm.Effect("base_compliance", "base", stiffness_nmm_per_rad=5e7),
]


def core_sweep(
    arm: eodarm.Arm,
    alpha: np.ndarray,
    mass: np.ndarray,
    effects: list[eodarm.Effect] | None = None,
    self_weight: bool = True,
    **kw: Any,
) -> dict[str, np.ndarray]:
    codes, places, values = effect_arrays(effects or [], arm.n)
    return _core.sweep(
        _core_arm(arm),
        np.ascontiguousarray(alpha, dtype=np.float64),
        np.ascontiguousarray(mass, dtype=np.float64),
        codes,
        places,
        values,
        self_weight,
        **kw,
    )


def every_cell(
    arm: eodarm.Arm,
    alpha: np.ndarray,
    mass: np.ndarray,
    effects: list[eodarm.Effect],
    backend: str,
    self_weight: bool,
) -> dict[str, np.ndarray]:
    """``eodarm.solve`` of every (pose, mass) pair, shaped (N, M[, n]) like the sweep."""
    n_poses, m = alpha.shape[0], mass.shape[0]
    out = eodarm.solve(
        arm,
        np.repeat(alpha, m, axis=0),
        np.tile(mass, n_poses),
        effects,
        backend=backend,  # type: ignore[arg-type]
        self_weight=self_weight,
    )
    return {k: v.reshape((n_poses, m, *v.shape[1:])) for k, v in out.items()}


def assert_close(got: np.ndarray, want: np.ndarray, key: str) -> None:
    """1e-9 of the field's magnitude with a floor of 1 in its unit (see test_backends)."""
    assert got.shape == want.shape, key
    atol = 1e-9 * max(1.0, float(np.nanmax(np.abs(want), initial=0.0)))
    np.testing.assert_allclose(got, want, rtol=0.0, atol=atol, err_msg=key)


# ---------------------------------------------------------------------------- cells
@settings(max_examples=150, deadline=None)
@given(
    case=arm_and_poses(),
    self_weight=st.booleans(),
    n_mass=st.integers(1, 4),
    length_only=st.booleans(),
    friction=st.booleans(),
    data=st.data(),
)
def test_sweep_cells_equal_solve_on_both_backends(
    case, self_weight, n_mass, length_only, friction, data
) -> None:
    arm, alpha, _ = case
    kinds = ("actuator_compliance", "mount_compliance", "actuator_play") if length_only else None
    if friction:  # each cell a single loading from its reference: what a friction lets through
        kinds = (*(kinds or ALL_KINDS), *FRICTIONS)
    effects = data.draw(effects_for(arm, kinds) if kinds else effects_for(arm), label="effects")
    mass = np.array(data.draw(st.lists(st.floats(0.0, 8.0), min_size=n_mass, max_size=n_mass)))
    got = core_sweep(arm, alpha, mass, effects, self_weight)
    ok = got["ok"]
    assert ok.shape == (alpha.shape[0], n_mass)
    np.testing.assert_array_equal(ok, got["status"] == 0)
    for backend in ("rust", "numpy"):
        want = every_cell(arm, alpha, mass, effects, backend, self_weight)
        # the status of each cell is solve's (eodarm.model.validity on the solved pose)
        np.testing.assert_array_equal(got["status"], want["status"], err_msg=backend)
        for key in CELL_KEYS:
            assert np.isnan(got[key][~ok]).all(), key
            assert_close(got[key][ok], want[key][ok], f"{key} vs {backend}")
    geo = eodarm.forward(arm, alpha, backend="numpy")
    assert_close(got["length_mm"], geo["length_mm"], "length_mm")
    assert_close(got["effector_x_mm"], geo["O"][:, arm.n, 0], "effector_x_mm")
    assert_close(got["effector_y_mm"], geo["O"][:, arm.n, 1], "effector_y_mm")


@pytest.mark.parametrize("effects", [[], LENGTH_ONLY, OTHERS], ids=["baseline", "length", "other"])
def test_large_sweep_equals_numpy_reference(effects: list[eodarm.Effect]) -> None:
    """Many chunks on several threads, masses including 0: every cell is the numpy reference's."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    rng = np.random.default_rng(3)
    n_poses = 5003  # not a multiple of the block width nor of any chunk
    alpha = np.array([60.0, 0.0, -10.0]) + np.array([50.0, 30.0, 20.0]) * rng.random((n_poses, 3))
    mass = np.array([0.0, 2.5, 7.0])
    got = core_sweep(arm, alpha, mass, effects)
    want = every_cell(arm, alpha, mass, effects, "numpy", True)
    ok = got["ok"]
    assert ok.mean() > 0.5
    np.testing.assert_array_equal(got["status"], want["status"])
    for key in CELL_KEYS:
        assert_close(got[key][ok], want[key][ok], key)
    one = core_sweep(arm, alpha, mass, effects, threads=1)
    for key in (*CELL_KEYS, "length_mm", "effector_x_mm", "effector_y_mm"):
        np.testing.assert_array_equal(one[key], got[key], err_msg=f"{key}: threads")


def singular_angle(arm: eodarm.Arm) -> float:
    """α₁ (deg) that puts A₁ on the line O₁–B₀: actuator 1 passes through its joint."""
    d = np.asarray(arm.arrays()["B0"]) - np.asarray(arm.arrays()["O1"])
    a = np.asarray(arm.arrays()["A"])[0]
    return float(np.degrees(np.arctan2(d[1], d[0]) - np.arctan2(a[1], a[0])))


def test_unsolvable_cells_are_nan_not_errors() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = np.array([[80.0, 10.0, 0.0], [singular_angle(arm), 10.0, 0.0], [95.0, 20.0, 5.0]])
    soft = [eodarm.Effect("actuator_compliance", "M3", stiffness_n_per_mm=500.0)]
    mass = np.array([1.0, 1e5])  # 1e5 kg cannot be held by a 500 N/mm actuator
    out = core_sweep(arm, alpha, mass, soft)
    np.testing.assert_array_equal(out["ok"], [[True, False], [False, False], [True, False]])
    # the singular pose is out of the example arm's stroke too (the first reason); a triangle
    # that cannot close is a large deflection
    np.testing.assert_array_equal(out["status"], [[0, 5], [1, 1], [0, 5]])
    for key in CELL_KEYS:
        assert np.isnan(out[key][~out["ok"]]).all(), key
        assert np.isfinite(out[key][out["ok"]]).all(), key
    assert list(out["reachable"]) == [True, False, True]
    assert np.isfinite(out["length_mm"]).all()
    for row, col in [(1, 0), (0, 1)]:
        with pytest.raises(ValueError):
            eodarm.solve(arm, alpha[row], mass[col], soft, backend="rust", strict=True)
    # not strict: the singular pose is still refused, the heavy cell is NaN with its status
    with pytest.raises(ValueError):
        eodarm.solve(arm, alpha[1], mass[0], soft, backend="rust")
    heavy = eodarm.solve(arm, alpha[0], mass[1], soft, backend="rust")
    assert np.isnan(heavy["dy_mm"]).all() and list(heavy["status"]) == [out["status"][0, 1]]
    want = every_cell(arm, alpha[[0, 2]], mass[:1], soft, "numpy", True)
    for key in CELL_KEYS:
        assert_close(out[key][[0, 2], :1], want[key], key)


def test_reachable_is_the_stroke_mask() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)  # has min/max lengths on every actuator
    rng = np.random.default_rng(5)
    alpha = np.array([30.0, -40.0, -60.0]) + np.array([120.0, 100.0, 100.0]) * rng.random((4000, 3))
    out = core_sweep(arm, alpha, np.array([1.0]))
    lo = np.array([a.min_length_mm for a in arm.actuators], dtype=float)
    hi = np.array([a.max_length_mm for a in arm.actuators], dtype=float)
    length = eodarm.forward(arm, alpha, backend="numpy")["length_mm"]
    within = ((length >= lo) & (length <= hi)).all(axis=1)
    assert 100 < within.sum() < 3900  # both kinds occur
    np.testing.assert_array_equal(out["reachable"], within)


# ---------------------------------------------------------------------------- reductions
def numpy_reduce(x: np.ndarray, op: str, group: int) -> np.ndarray:
    """Reduce (rows[, n]) cells over groups of ``group`` consecutive rows, ignoring NaN."""
    width = x.shape[1:]
    g = x.reshape((-1, group, *width))
    if op in ("max", "min"):
        fn = np.fmax if op == "max" else np.fmin  # ignore NaN, all-NaN stays NaN
        return fn.reduce(g, axis=1)
    fill = -np.inf if op == "argmax" else np.inf
    filled = np.where(np.isnan(g), fill, g)
    idx = np.argmax(filled, axis=1) if op == "argmax" else np.argmin(filled, axis=1)
    return np.where(np.isnan(g).all(axis=1), -1, idx)


@pytest.mark.parametrize("op", ["max", "min", "argmax", "argmin"])
@pytest.mark.parametrize("effects", [[], OTHERS], ids=["fast", "per-cell"])
def test_reductions_equal_numpy(op: str, effects: list[eodarm.Effect]) -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    rng = np.random.default_rng(11)
    alpha = np.array([60.0, 0.0, -10.0]) + np.array([50.0, 30.0, 20.0]) * rng.random((3000, 3))
    alpha[[40, 41, 42, 43, 1000]] = [singular_angle(arm), 10.0, 0.0]  # NaN cells and groups
    mass = np.array([0.0, 3.0, 1.0, 6.0])
    full = core_sweep(arm, alpha, mass, effects)
    for group in (1, 2, 4, 8, 12000 // 5):
        red = core_sweep(arm, alpha, mass, effects, reduce=op, group=group)
        rows = 3000 * 4 // group
        np.testing.assert_array_equal(red["ok"], full["ok"].reshape(rows, group).any(axis=1))
        np.testing.assert_array_equal(red["length_mm"], full["length_mm"])
        for key in CELL_KEYS:
            want = numpy_reduce(full[key].reshape((rows * group, *full[key].shape[2:])), op, group)
            assert red[key].shape == want.shape, key
            if op.startswith("arg"):
                assert red[key].dtype == np.int64, key
            np.testing.assert_array_equal(red[key], want, err_msg=f"{key}, group {group}")


def test_bad_sweep_arguments_are_refused() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = np.tile([80.0, 10.0, 0.0], (10, 1))
    mass = np.array([1.0, 2.0])
    with pytest.raises(ValueError, match="divide"):
        core_sweep(arm, alpha, mass, reduce="max", group=3)
    with pytest.raises(ValueError, match="reduce"):
        core_sweep(arm, alpha, mass, reduce="median", group=2)
    with pytest.raises(ValueError, match="group"):
        core_sweep(arm, alpha, mass, reduce="max", group=0)
    with pytest.raises(ValueError, match="threads"):
        core_sweep(arm, alpha, mass, threads=0)
    bad = alpha.copy()
    bad[7, 1] = np.nan
    with pytest.raises(ValueError, match="row 7"):
        core_sweep(arm, bad, mass)
    with pytest.raises(ValueError, match="mass_kg"):
        core_sweep(arm, alpha, np.array([1.0, -1.0]))
    with pytest.raises(ValueError):
        core_sweep(arm, alpha[:, :2], mass)


# ---------------------------------------------------------------------------- Ctrl-C
def test_uninterrupted_sweep_runs_to_the_end() -> None:
    """Many chunks, signal checks between them, and no interrupt: complete, no exception."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    rng = np.random.default_rng(2)
    alpha = np.array([60.0, 0.0, -10.0]) + np.array([50.0, 30.0, 20.0]) * rng.random((200_000, 3))
    for threads in (None, 1, 2):
        out = core_sweep(arm, alpha, np.array([0.0, 4.0]), threads=threads)
        assert out["ok"].all() and np.isfinite(out["dy_mm"]).all()
        assert (out["dy_mm"][:, 1] < 0).all()  # the payload sags the arm


class _Interrupted(Exception):
    """Raised by the test's SIGINT handler (not KeyboardInterrupt, which would end pytest)."""


def test_ctrl_c_stops_a_running_sweep() -> None:
    """A SIGINT stops the core at its first check after it, and what the SIGINT handler in
    place raises (here the test's own exception) comes out of the call.

    On the per-cell path (effects that move pins), reduced over the payloads, on one thread:
    the SIGINT is sent, synchronously, from the progress report that the core makes before
    its first chunk (no timer races the work, so a busy machine changes nothing), and no
    chunk after the first is solved: every later row keeps what the caller's array held.
    """
    arm = eodarm.Arm.from_toml(EXAMPLE)
    rng = np.random.default_rng(4)
    alpha = np.array([60.0, 0.0, -10.0]) + np.array([50.0, 30.0, 20.0]) * rng.random((4_000, 3))
    mass = np.linspace(0.0, 8.0, 16)
    kw: dict[str, Any] = {"reduce": "max", "group": 16, "threads": 1}
    whole = core_sweep(arm, alpha, mass, OTHERS, **kw)
    assert np.isfinite(whole["dy_mm"]).all()  # uninterrupted, every pose is written
    out = {
        k: np.full_like(v, np.nan) if v.dtype.kind == "f" else np.zeros_like(v)
        for k, v in whole.items()
    }
    reports: list[int] = []

    def progress(done: int) -> None:
        reports.append(done)
        signal.raise_signal(signal.SIGINT)

    def handler(signum: int, frame: object) -> None:
        raise _Interrupted

    previous = signal.signal(signal.SIGINT, handler)
    try:
        with pytest.raises(_Interrupted):
            # 1024 rows a chunk: 64 poses of 16 payloads, 63 chunks
            core_sweep(arm, alpha, mass, OTHERS, **kw, out=out, progress=progress, chunk_rows=1024)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert reports == [0], "one report, before the first chunk, and no check after the SIGINT"
    assert not np.isfinite(out["dy_mm"][64:]).any(), "nothing after the first chunk"


# ---------------------------------------------------------------------------- grid= and out=
def test_a_grid_source_equals_its_poses_given_as_rows() -> None:
    """``grid=(axes, links, start, count)`` is the C-order product of the axes (dimension d
    setting link ``links[d]``), a sub-range of it included, written into caller arrays."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    axes = [np.linspace(0, 30, 7), np.linspace(60, 110, 11), np.linspace(-10, 10, 5)]
    links = [1, 0, 2]
    mesh = np.meshgrid(*axes, indexing="ij")
    rows = np.empty((385, 3))
    for d, link in enumerate(links):
        rows[:, link] = mesh[d].reshape(-1)
    mass = np.array([1.0, 6.0])
    codes, places, values = effect_arrays(LENGTH_ONLY, arm.n)
    for start, count in ((0, 385), (40, 123)):
        want = core_sweep(arm, rows[start : start + count], mass, LENGTH_ONLY)
        out = {k: np.empty_like(v) for k, v in want.items()}
        got = _core.sweep(
            _core_arm(arm),
            None,
            mass,
            codes,
            places,
            values,
            True,
            grid=(axes, links, start, count),
            out=out,
        )
        assert got is out
        for key, val in want.items():
            np.testing.assert_array_equal(out[key], val, err_msg=key)


def test_out_arrays_that_do_not_fit_get_a_clear_error() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = np.array([[90.0, 10.0, 0.0], [80.0, 5.0, 2.0]])
    mass = np.array([1.0])
    good = core_sweep(arm, alpha, mass)
    cases = [
        ({"dy_mm": None}, r"out: missing the array 'dy_mm'"),
        ({"force_n": np.empty((2, 1, 3), dtype=np.float32)}, r"out\['force_n'\].*float64"),
        ({"ok": np.empty((2, 1))}, r"out\['ok'\].*bool"),
        ({"dl_mm": np.empty((2, 1, 4))}, r"dl_mm: expected 6 values, got 8"),
        ({"dx_mm": np.empty((4, 1))[::2]}, r"out\['dx_mm'\].*C-contiguous"),
        ({"length_mm": np.empty((2, 3))[:, :2].copy()}, r"length_mm: expected 6"),
    ]
    for change, message in cases:
        out = {k: np.empty_like(v) for k, v in good.items()}
        for k, v in change.items():
            if v is None:
                del out[k]
            else:
                out[k] = v
        with pytest.raises(_core.CoreError, match=message) as info:
            core_sweep(arm, alpha, mass, out=out)
        assert "\n" not in str(info.value)
    shared = {k: np.empty_like(v) for k, v in good.items()}
    shared["dy_mm"] = shared["dx_mm"]  # the same array twice
    with pytest.raises(_core.CoreError, match=r"out\['dy_mm'\].*borrowed"):
        core_sweep(arm, alpha, mass, out=shared)
    with pytest.raises(_core.CoreError, match="exactly one of alpha_deg"):
        core_sweep(arm, alpha, mass, grid=([alpha[:, 0]], [0], 0, 2))
    # Per-pose arrays may be left out: they are then not written.
    out = {k: np.empty_like(good[k]) for k in (*CELL_KEYS, "ok")}
    core_sweep(arm, alpha, mass, out=out)
    for key in (*CELL_KEYS, "ok"):
        np.testing.assert_array_equal(out[key], good[key], err_msg=key)


def test_an_exception_in_the_progress_callback_stops_the_sweep() -> None:
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = np.tile([[90.0, 10.0, 0.0]], (200_000, 1))
    seen: list[int] = []

    def progress(done: int) -> None:
        seen.append(done)
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        core_sweep(arm, alpha, np.array([1.0]), progress=progress, threads=1)
    assert seen == [0], "the first report comes before the first chunk; none after it"
