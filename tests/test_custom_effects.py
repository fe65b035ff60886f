"""User-written effects (docs/custom-effects.md): registered in Python, used like the catalogue's.

* A user effect that returns a built-in effect's cause gives that effect's numbers (mount
  compliance as an unseen length −ΔF/k, joint clearance as a pin offset c·û), through
  ``solve`` on both backends and through a sweep, on hypothesis arms of 1–4 links.
* It is fitted with a standard error that matches the scatter of its estimates, and a fit of
  the re-implemented mount agrees with the built-in one.
* Hidden in synthetic data, a worn contact mount is found by ``diagnose`` (first, suggested,
  χ²/dof ≈ 1) on 2-, 3- and 4-link arms, in the API and with ``--effects FILE.py``.
* Whatever a user function gets wrong is refused in one line naming effect@place and the key,
  in the API and the command line (exit 2), with the traceback only under ``--debug``.
* Names, places, ranges, ``[[effect]]`` tables, the entry-point group (lazy, never at
  ``import eodarm``).
"""

from __future__ import annotations

import contextlib
import json
import subprocess
import sys
import textwrap
import tomllib
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from arms import ARMS, example_arm, four_link_arm
from eodarm.analysis.fit import FitWarning, Problem, fit
from eodarm.analysis.synth import random_configs, synth
from eodarm.errors import CustomEffectError, EffectError, EodarmError
from eodarm.model import custom
from eodarm.model.effects import UNLOADED, Slot
from strategies import arm_and_poses, effect_at, effects_for

ROOT = Path(__file__).resolve().parents[1]
CONTACT_PY = ROOT / "examples" / "contact_mount.py"
EXAMPLE_TOML = ROOT / "examples" / "example_arm.toml"
MASSES = [1.5, 3.0, 5.0, 6.5]
CHANNELS = ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "dlength_mm", "force_n")


# ---------------------------------------------------------------------------- the effects
def mount_like(state: eodarm.EffectState, i: int, k: float) -> dict[str, Any]:
    """``mount_compliance`` written by a user: a spring in series that the sensor misses."""
    return {"actuator_unseen_mm": -(state.force_n[:, i] - state.force0_n[:, i]) / k}


def _press(r: np.ndarray) -> np.ndarray:
    """Where the pin goes in its bore: along −R, none below the core's 1e-9 N."""
    norm = np.linalg.norm(r, axis=-1, keepdims=True)
    return np.where(norm >= 1e-9, -r / np.where(norm > 0, norm, 1.0), 0.0)


def clearance_like(state: eodarm.EffectState, i: int, c: float) -> dict[str, Any]:
    """``joint_clearance`` (centred when unloaded) written by a user."""
    return {"joint_offset_mm": c * _press(state.reaction_n[:, i])}


def clearance_up_like(state: eodarm.EffectState, i: int, c: float) -> dict[str, Any]:
    """``joint_clearance`` taken up by the unloaded forces, written by a user."""
    return {
        "joint_offset_mm": c * (_press(state.reaction_n[:, i]) - _press(state.reaction0_n[:, i]))
    }


def mount_compliance_like(state: eodarm.EffectState, i: int, c: float) -> dict[str, Any]:
    """``mount_compliance`` through its compliance c = 1/k (absent at 0, as a diagnosis
    wants a candidate's neutral value)."""
    return {"actuator_unseen_mm": -(state.force_n[:, i] - state.force0_n[:, i]) * c}


def contact(state: eodarm.EffectState, i: int, c_mm_per_n23: float) -> dict[str, Any]:
    """The worn mount of examples/contact_mount.py (the example of docs/custom-effects.md)."""
    df = state.force_n[:, i] - state.force0_n[:, i]
    return {"actuator_unseen_mm": -np.sign(df) * c_mm_per_n23 * np.abs(df) ** (2 / 3)}


EFFECTS: dict[str, tuple[dict[str, Any], Callable[..., dict[str, Any]]]] = {
    "mount_like": (
        {"places": "M", "parameter": "stiffness_n_per_mm", "lower": 1.0, "start": 1000.0},
        mount_like,
    ),
    "clearance_like": (
        {"places": "O", "parameter": "clearance_mm", "upper": 5.0, "start": 0.05},
        clearance_like,
    ),
    "clearance_up_like": (
        {"places": "O", "parameter": "clearance_mm", "upper": 5.0, "start": 0.05},
        clearance_up_like,
    ),
    "mount_compliance_like": (
        {"places": "M", "parameter": "compliance_mm_per_n", "start": 1e-4},
        mount_compliance_like,
    ),
    "contact_mount": (
        {"places": "M", "parameter": "c_mm_per_n23", "start": 1e-3, "unit": "mm/N^(2/3)"},
        contact,
    ),
}


@contextlib.contextmanager
def registered(*names: str) -> Iterator[None]:
    """The named test effects registered for the duration (and forgotten after, so that
    other tests see the catalogue alone)."""
    for name in names:
        kw, fn = EFFECTS[name]
        eodarm.custom_effect(name, **kw)(fn)
    try:
        yield
    finally:
        for name in names:
            custom.unregister(name)


def assert_close(a: dict, b: dict, atol: float = 1e-9) -> None:
    for key in CHANNELS:
        np.testing.assert_allclose(a[key], b[key], rtol=0.0, atol=atol, err_msg=key)


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", "import sys; from eodarm.cli import main; sys.exit(main())", *args],
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
    )


# ---------------------------------------------------------------------------- solve
@settings(max_examples=60, deadline=None)
@given(case=arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_user_mount_compliance_gives_the_builtin_numbers(case, self_weight, data) -> None:
    """−ΔF/k as ``actuator_unseen_mm`` is ``mount_compliance``, with other effects on top."""
    arm, alpha, mass = case
    i = data.draw(st.integers(0, arm.n - 1), label="i")
    k = data.draw(effect_at(arm, "mount_compliance", f"M{i + 1}"), label="k").value
    others = data.draw(effects_for(arm, max_size=3, unloaded=UNLOADED), label="others")
    # A joint friction at O_i changes the force the mount takes; a user effect reads the
    # frictionless statics (docs/custom-effects.md), so the two differ there by design.
    skip = (f"mount_compliance@M{i + 1}", f"joint_friction@O{i + 1}")
    others = [e for e in others if e.key not in skip]
    builtin = eodarm.Effect("mount_compliance", f"M{i + 1}", stiffness_n_per_mm=k)
    with registered("mount_like"):
        user = eodarm.Effect("mount_like", f"M{i + 1}", stiffness_n_per_mm=k)
        for backend in ("rust", "numpy"):
            kw = {"backend": backend, "self_weight": self_weight}
            want = eodarm.solve(arm, alpha, mass, [*others, builtin], **kw)
            got = eodarm.solve(arm, alpha, mass, [*others, user], **kw)
            assert_close(got, want)


@settings(max_examples=60, deadline=None)
@given(case=arm_and_poses(), self_weight=st.booleans(), data=st.data())
def test_user_joint_clearance_gives_the_builtin_numbers(case, self_weight, data) -> None:
    """c·û as ``joint_offset_mm`` is ``joint_clearance``, centred or taken up."""
    arm, alpha, mass = case
    j = data.draw(st.integers(0, arm.n - 1), label="j")
    c = data.draw(st.floats(0.0, 0.3), label="c")
    mode = data.draw(st.sampled_from(UNLOADED), label="unloaded")
    name = "clearance_like" if mode == "centred" else "clearance_up_like"
    others = data.draw(effects_for(arm, max_size=3), label="others")
    # A joint friction at O_j changes the reaction the clearance follows (see the mount).
    skip = (f"joint_clearance@O{j + 1}", f"joint_friction@O{j + 1}")
    others = [e for e in others if e.key not in skip]
    builtin = eodarm.Effect("joint_clearance", f"O{j + 1}", clearance_mm=c, unloaded=mode)
    with registered(name):
        user = eodarm.Effect(name, f"O{j + 1}", clearance_mm=c)
        for backend in ("rust", "numpy"):
            kw = {"backend": backend, "self_weight": self_weight}
            want = eodarm.solve(arm, alpha, mass, [*others, builtin], **kw)
            got = eodarm.solve(arm, alpha, mass, [*others, user], **kw)
            assert_close(got, want)


def test_the_function_is_called_once_per_place_on_every_state() -> None:
    arm = example_arm()
    alpha = random_configs(arm, 7, np.random.default_rng(0))
    calls: list[tuple[int, int]] = []

    @eodarm.custom_effect("counted", places="M", parameter="x_mm", start=0.01)
    def counted(state: eodarm.EffectState, i: int, x_mm: float) -> dict[str, Any]:
        calls.append((state.n_states, i))
        return {"actuator_unseen_mm": np.full(state.n_states, -x_mm)}

    try:
        effs = [eodarm.Effect("counted", f"M{i}", x_mm=0.01) for i in (1, 3)]
        eodarm.solve(arm, alpha, 4.0, effs)
        assert calls == [(7, 0), (7, 2)]  # one vectorised call per place, never per state
    finally:
        custom.unregister("counted")


def test_a_payload_force_reaches_the_state_and_the_arrays_are_read_only() -> None:
    arm = example_arm()
    seen: dict[str, Any] = {}

    @eodarm.custom_effect("peek", places="base", parameter="x", start=1.0)
    def peek(state: eodarm.EffectState, i: int, x: float) -> dict[str, Any]:
        seen["state"] = state
        return {}

    try:
        alpha = np.array([[90.0, 10.0, 0.0], [80.0, 20.0, -5.0]])
        eodarm.solve(arm, alpha, [2.0, 5.0], [eodarm.Effect("peek", "base", x=1.0)])
        s = seen["state"]
        np.testing.assert_allclose(s.mass_kg, [2.0, 5.0])
        np.testing.assert_allclose(s.payload_n[:, 1], [-2.0 * arm.g, -5.0 * arm.g])
        stat = eodarm.solve(arm, alpha, [2.0, 5.0])
        np.testing.assert_allclose(s.force_n, stat["force_n"], rtol=1e-12)
        np.testing.assert_allclose(s.length_mm, stat["length_mm"], rtol=1e-12)
        assert s.alpha_deg.shape == (2, 3) and s.reaction0_n.shape == (2, 3, 2)
        with pytest.raises(ValueError, match="read-only"):
            s.force_n[0, 0] = 1.0
    finally:
        custom.unregister("peek")


def test_the_fem_model_refuses_user_effects_in_one_line() -> None:
    arm = example_arm()
    with registered("contact_mount"):
        eff = eodarm.Effect("contact_mount", "M2", c_mm_per_n23=1e-3)
        with pytest.raises(EodarmError, match=r"custom effect contact_mount@M2: the finite"):
            eodarm.solve(arm, [90.0, 10.0, 0.0], 5.0, [eff], model="fem")


def test_a_sweep_with_a_user_effect_equals_the_builtin_sweep() -> None:
    """User effects take the chunked path, which passes their extras; the built-in effect
    takes the core's kernel: the same numbers (and the same unsolvable cells)."""
    arm = example_arm()
    grid = {
        "alpha1": np.linspace(40.0, 130.0, 10),
        "alpha2": np.linspace(-60.0, 60.0, 7),
        "alpha3": np.linspace(-90.0, 90.0, 5),
    }
    builtin = eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=800.0)
    with registered("mount_like"):
        user = eodarm.Effect("mount_like", "M2", stiffness_n_per_mm=800.0)
        for reduce in (None, {"op": "max", "dims": ["mass_kg"]}):
            kw: dict[str, Any] = {"alpha_deg": grid, "mass_kg": [0.0, 3.0, 6.0], "reduce": reduce}
            a = eodarm.sweep(arm, effects=[builtin], **kw)
            b = eodarm.sweep(arm, effects=[user], **kw)
            np.testing.assert_array_equal(a["ok"].values, b["ok"].values)
            for key in ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm", "force_n"):
                np.testing.assert_allclose(b[key].values, a[key].values, atol=1e-8, err_msg=key)


def test_a_zarr_sweep_with_a_user_effect_includes_it(tmp_path: Path) -> None:
    """The chunk-by-chunk Zarr path routes user effects like the in-memory sweep (its core
    grid walker would drop them): the same numbers as the built-in effect."""
    pytest.importorskip("zarr")
    import xarray as xr

    from eodarm.workspace import store

    arm = example_arm()
    grid = {"alpha1": np.linspace(60.0, 120.0, 6), "alpha2": [0.0, 20.0], "alpha3": [0.0]}
    builtin = eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=800.0)
    with registered("mount_like"):
        user = eodarm.Effect("mount_like", "M2", stiffness_n_per_mm=800.0)
        out = store.sweep_to_zarr(
            tmp_path / "u.zarr",
            arm,
            alpha_deg=grid,
            mass_kg=[3.0],
            effects=[user],
            progress=False,
            chunk_size=4,
        )
        got = xr.open_zarr(out, consolidated=False).load()
    want = eodarm.sweep(arm, alpha_deg=grid, mass_kg=[3.0], effects=[builtin], progress=False)
    np.testing.assert_allclose(got["dy_mm"].values, want["dy_mm"].values, atol=1e-8)


# ---------------------------------------------------------------------------- fit
def test_fit_of_the_user_mount_agrees_with_the_builtin_fit() -> None:
    """Same optimum, same standard error: the forward-difference Jacobian of a user effect
    and the core's central one of the catalogue agree."""
    arm = example_arm()
    hidden = eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=2000.0)
    meas = synth(arm, random_configs(arm, 12, np.random.default_rng(7)), MASSES, [hidden], seed=4)
    with registered("mount_like"):
        want = fit(arm, meas, ["mount_compliance@M2"])
        got = fit(arm, meas, ["mount_like@M2"])
        assert got.estimate(0) == pytest.approx(want.estimate(0), abs=0.01 * want.stderr(0))
        assert got.stderr(0) == pytest.approx(want.stderr(0), rel=1e-3)
        assert got.chi2 == pytest.approx(want.chi2, rel=1e-9)


def test_user_probe_columns_match_the_core_jacobian() -> None:
    """∂y/∂k of the user mount is the core's ∂y/∂θ of the built-in one times dθ/dk = −1/k²,
    and with a user effect in the model the catalogue's columns (forward differences, the
    extras held) are the core's at the equivalent model."""
    arm = example_arm()
    meas = synth(arm, random_configs(arm, 6, np.random.default_rng(1)), MASSES, seed=2)
    prob = Problem(arm, meas)
    k = 2000.0
    probes = [
        Slot("joint_clearance", "O2"),
        Slot("link_bending", "L2"),
        Slot("base_compliance", "base"),
    ]
    with registered("mount_like"):
        user = Slot("mount_like", "M1")
        y_user, j_user = prob.evaluate([(user, k)], [user, *probes])
    y_core, j_core = prob.evaluate(
        [(Slot("mount_compliance", "M1"), 1.0 / k)], [Slot("mount_compliance", "M1"), *probes]
    )
    # the user effect's model goes through the general path (extras), the core's Jacobian
    # through the block kernel: equal to rounding (~1e-13 relative), 1e-9 mm as test_solve_kernel
    np.testing.assert_allclose(y_user, y_core, rtol=0.0, atol=1e-9)
    scale = np.abs(j_core).max(axis=(0, 1))
    np.testing.assert_allclose(j_user[..., 0], -j_core[..., 0] / k**2, atol=1e-4 * scale[0] / k**2)
    for p in range(1, len(probes) + 1):
        np.testing.assert_allclose(j_user[..., p], j_core[..., p], atol=1e-4 * scale[p])


def test_fit_recovers_the_contact_within_its_standard_error() -> None:
    """Over 20 noise realisations the estimates scatter as their standard errors say."""
    arm = example_arm()
    cfg = random_configs(arm, 12, np.random.default_rng(5))
    truth = 1e-3
    z = []
    with registered("contact_mount"):
        hidden = [eodarm.Effect("contact_mount", "M2", c_mm_per_n23=truth)]
        for seed in range(20):
            meas = synth(arm, cfg, MASSES, hidden, seed=seed)
            res = fit(arm, meas, ["contact_mount@M2"])
            assert not res.at_bound[0]
            z.append((res.estimate(0) - truth) / res.stderr(0))
            assert 0.7 < res.chi2_per_dof < 1.4
    z_arr = np.array(z)
    assert np.all(np.abs(z_arr) < 4.0), z_arr
    assert 0.5 < z_arr.std() < 1.6, z_arr
    assert abs(z_arr.mean()) < 1.0, z_arr


def test_fit_respects_the_bounds_of_a_user_effect() -> None:
    """Data without friction: the estimate stays at the lower bound (absent) and says so."""
    arm = example_arm()
    meas = synth(arm, random_configs(arm, 8, np.random.default_rng(2)), MASSES, seed=3)
    with registered("contact_mount"), warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        res = fit(arm, meas, ["contact_mount@M1"])
    assert res.theta[0] >= 0.0
    if res.at_bound[0]:
        assert res.effects == [eodarm.Effect("contact_mount", "M1", c_mm_per_n23=0.0)]


# ---------------------------------------------------------------------------- diagnose
FOUND = [(name, "M2") for name in ARMS if ARMS[name]().n >= 2] + [("four-link", "M3")]


@pytest.mark.parametrize(("arm_name", "at"), FOUND)
def test_hidden_contact_mount_is_found_by_diagnose(arm_name: str, at: str) -> None:
    arm = four_link_arm() if arm_name == "four-link" else ARMS[arm_name]()
    cfg = random_configs(arm, 12, np.random.default_rng(7))
    with registered("contact_mount"):
        hidden = [eodarm.Effect("contact_mount", at, c_mm_per_n23=1e-3)]
        meas = synth(arm, cfg, MASSES, hidden, seed=11)
        d = eodarm.diagnose(arm, meas, advise=False)
        key = f"contact_mount@{at}"
        # every registered effect is a candidate at every place of its kind
        every = {f"contact_mount@M{i + 1}" for i in range(arm.n)}
        assert {c.slot.key for c in d.ranking} >= every
        assert d.verdict == "missing"
        top = d.ranking[0]
        assert top.slot.key == key
        assert [s.key for s in d.suggested] == [key]
        assert 0.7 < top.fit.chi2_per_dof < 1.4
        assert top.fit.estimate(0) == pytest.approx(1e-3, abs=4 * top.fit.stderr(0))
        assert d.baseline.chi2_per_dof > 3.0


def test_a_user_copy_of_a_builtin_effect_ties_with_it_and_is_confused_with_it() -> None:
    """The data cannot tell a user effect from the catalogue effect it copies: equal χ², each
    in the other's ``confused_with``, and the tie goes to the catalogue's."""
    arm = example_arm()
    cfg = random_configs(arm, 12, np.random.default_rng(7))
    hidden = [eodarm.Effect("mount_compliance", "M2", stiffness_n_per_mm=2000.0)]
    meas = synth(arm, cfg, MASSES, hidden, seed=3)
    with registered("mount_compliance_like"):
        d = eodarm.diagnose(arm, meas, advise=False)
        first, second = d.ranking[0], d.ranking[1]
        assert first.slot.key == "mount_compliance@M2"
        assert second.slot.key == "mount_compliance_like@M2"
        assert second.fit.chi2 == pytest.approx(first.fit.chi2, rel=1e-6)
        assert 1.0 / second.fit.estimate(0) == pytest.approx(first.fit.estimate(0), rel=1e-4)
        assert "mount_compliance_like@M2" in first.confused_with
        assert "mount_compliance@M2" in second.confused_with
        assert [s.key for s in d.suggested] == ["mount_compliance@M2"]


def test_unregistered_contact_mount_is_not_explained_by_the_catalogue() -> None:
    arm = example_arm()
    cfg = random_configs(arm, 12, np.random.default_rng(7))
    with registered("contact_mount"):
        meas = synth(arm, cfg, MASSES, [eodarm.Effect("contact_mount", "M2", c_mm_per_n23=1e-3)])
    d = eodarm.diagnose(arm, meas, advise=False, outliers=False)
    assert all(not c.slot.kind.custom for c in d.ranking)
    assert d.ranking[0].fit.chi2_per_dof > 2.0


def test_taken_up_gaps_are_candidates_but_never_twice_in_one_set() -> None:
    arm = example_arm()
    cfg = random_configs(arm, 12, np.random.default_rng(7))
    hidden = [eodarm.Effect("joint_clearance", "O2", clearance_mm=0.15, unloaded="taken_up")]
    meas = synth(arm, cfg, MASSES, hidden, seed=5)
    d = eodarm.diagnose(arm, meas, advise=False)
    specs = [c.slot.spec for c in d.ranking]
    assert "joint_clearance@O2:taken_up" in specs and "joint_clearance@O2" in specs
    assert d.verdict == "missing"
    assert [s.spec for s in d.suggested] == ["joint_clearance@O2:taken_up"]
    assert d.to_json()["suggested"] == ["joint_clearance@O2:taken_up"]
    entry = next(e for e in d.to_json()["ranking"] if e.get("unloaded") == "taken_up")
    assert entry["effect"] in ("actuator_play", "joint_clearance")
    # 28 candidates (22, and the two frictions at M1–M3 and O1–O3); no set holds both modes of
    # one gap
    from eodarm.analysis.diagnose import _combinations

    sets = _combinations([c.slot for c in d.ranking], 2)
    assert all(d.ranking[a].slot.key != d.ranking[b].slot.key for a, b in sets)
    assert len(sets) == 28 * 27 // 2 - 6


# ---------------------------------------------------------------------------- registry
def test_names_places_and_ranges_are_checked() -> None:
    def fn(state: Any, i: int, x: float) -> dict[str, Any]:
        return {}

    with pytest.raises(EffectError, match="built-in"):
        eodarm.custom_effect("mount_compliance", places="M", parameter="k")(fn)
    with pytest.raises(EffectError, match="places must be"):
        eodarm.custom_effect("x_eff", places="Q", parameter="k")
    with pytest.raises(EffectError, match="a name is"):
        eodarm.custom_effect("bad name", places="M", parameter="k")
    with pytest.raises(EffectError, match="parameter must be"):
        eodarm.custom_effect("x_eff", places="M", parameter="at")
    with pytest.raises(EffectError, match="upper 1 must exceed lower 2"):
        eodarm.custom_effect("x_eff", places="M", parameter="k", lower=2.0, upper=1.0)
    with pytest.raises(EffectError, match="start 9 is outside"):
        eodarm.custom_effect("x_eff", places="M", parameter="k", upper=5.0, start=9.0)
    assert "x_eff" not in custom.registered()
    with registered("contact_mount"):
        with pytest.raises(EffectError, match=r"sits at M1…Mn, not 'O2'"):
            eodarm.Effect("contact_mount", "O2", c_mm_per_n23=1e-4)
        with pytest.raises(EffectError, match=r"c_mm_per_n23 must be finite and within \[0, inf\]"):
            eodarm.Effect("contact_mount", "M2", c_mm_per_n23=-1.0)
        with pytest.raises(EffectError, match="takes exactly the parameter 'c_mm_per_n23'"):
            eodarm.Effect("contact_mount", "M2", play_mm=1.0)
        with pytest.raises(
            EffectError, match="only actuator_play, joint_clearance, drive_backlash take"
        ):
            eodarm.Effect("contact_mount", "M2", c_mm_per_n23=1e-4, unloaded="taken_up")
        with pytest.raises(EffectError, match="the arm has only 3 links"):
            eodarm.solve(
                example_arm(),
                [90, 10, 0],
                1.0,
                eodarm.Effect.parse("contact_mount@M4", c_mm_per_n23=1e-4),
            )
        with pytest.raises(EffectError, match=r"known: .*contact_mount"):
            eodarm.Effect("no_such_effect", "M1", x=1.0)


def test_registering_a_name_again_replaces_it() -> None:
    arm = example_arm()
    alpha = [[90.0, 10.0, 0.0]]
    try:
        eodarm.custom_effect("shift", places="base", parameter="d_mm", lower=-1.0, upper=1.0)(
            lambda s, i, d: {"measure_mm": np.tile([d, 0.0], (s.n_states, 1))}
        )
        base = eodarm.solve(arm, alpha, 3.0)
        one = eodarm.solve(arm, alpha, 3.0, [eodarm.Effect("shift", "base", d_mm=0.5)])
        assert one["dx_mm"][0] == pytest.approx(base["dx_mm"][0] + 0.5, abs=1e-12)
        assert one["dy_mm"][0] == pytest.approx(base["dy_mm"][0], abs=1e-12)
        eodarm.custom_effect("shift", places="base", parameter="d_mm", lower=-1.0, upper=1.0)(
            lambda s, i, d: {"measure_mm": np.tile([0.0, d], (s.n_states, 1))}
        )
        two = eodarm.solve(arm, alpha, 3.0, [eodarm.Effect("shift", "base", d_mm=0.5)])
        assert two["dy_mm"][0] == pytest.approx(base["dy_mm"][0] + 0.5, abs=1e-12)
        assert custom.registered().count("shift") == 1
    finally:
        custom.unregister("shift")


def test_effect_tables_of_user_effects_round_trip(tmp_path: Path) -> None:
    arm = example_arm()
    with registered("contact_mount"):
        eff = eodarm.Effect("contact_mount", "M2", c_mm_per_n23=1.2e-3)
        fitted = arm.with_effects([eff], [0.5])
        back = eodarm.Arm.from_dict(tomllib.loads(fitted.to_toml()))
        assert back.effects == (eff,) and back.effect_stderr == (0.5,)
        path = tmp_path / "bad.toml"
        path.write_text(fitted.to_toml().replace("c_mm_per_n23 = ", "c_mm_per_n23n = "))
        with pytest.raises(EodarmError, match=r"effect\[1\]\.c_mm_per_n23n"):
            eodarm.Arm.from_toml(path)
        text = fitted.to_toml()
    with pytest.raises(EodarmError, match=r"effect\[1\]\.effect.*unknown effect 'contact_mount'"):
        eodarm.Arm.from_dict(tomllib.loads(text))


# ---------------------------------------------------------------------------- bad functions
BAD = {
    "raises": ("raise RuntimeError('stuck')", "the function raised RuntimeError: stuck"),
    "not_a_dict": ("return np.zeros(s.n_states)", "the function returned ndarray, expected a dict"),
    "unknown_key": (
        "return {'actuator_um': np.zeros(s.n_states)}",
        "unknown key 'actuator_um'; the keys are actuator_mm,",
    ),
    "wrong_shape": (
        "return {'actuator_mm': np.zeros((s.n_states, 1))}",
        "'actuator_mm' has shape (5, 1), expected (5,)",
    ),
    "wrong_type": (
        "return {'joint_offset_mm': 'far'}",
        "'joint_offset_mm' is a str, expected float",
    ),
    "complex": (
        "return {'base_tilt_rad': np.zeros(s.n_states) + 1j}",
        "'base_tilt_rad' is a ndarray of complex128, expected float",
    ),
    "not_finite": (
        "m = np.zeros((s.n_states, 2)); m[3, 1] = np.nan; return {'measure_mm': m}",
        "'measure_mm' is not finite in pose row 3 ([0.0, nan])",
    ),
    "mutates": (
        "s.force_n[:, i] = 0.0; return {}",
        "the function raised ValueError: assignment destination is read-only",
    ),
}


def _bad_source() -> str:
    lines = ["import numpy as np", "import eodarm", ""]
    for case, (body, _) in BAD.items():
        lines += [
            f"@eodarm.custom_effect('bad_{case}', places='M', parameter='x', start=1.0)",
            f"def bad_{case}(s, i, x):",
            f"    {body}",
            "",
        ]
    return "\n".join(lines)


@pytest.fixture(scope="module")
def bad_py(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("bad") / "bad_effects.py"
    path.write_text(_bad_source())
    return path


@pytest.mark.parametrize("case", list(BAD))
def test_a_bad_user_function_is_refused_in_one_line(case: str, bad_py: Path) -> None:
    arm = example_arm()
    alpha = random_configs(arm, 5, np.random.default_rng(0))
    want = f"custom effect bad_{case}@M2: {BAD[case][1]}"
    custom.load_file(bad_py)
    try:
        eff = eodarm.Effect(f"bad_{case}", "M2", x=1.0)
        for backend in ("rust", "numpy"):
            with pytest.raises(CustomEffectError) as err:
                eodarm.solve(arm, alpha, 3.0, [eff], backend=backend)
            assert str(err.value).startswith(want), str(err.value)
            assert "\n" not in str(err.value)
    finally:
        for name in BAD:
            custom.unregister(f"bad_{name}")
    alpha_args = [a for row in alpha for a in ("--alpha", ",".join(f"{x:g}" for x in row))]
    out = run_cli(
        "solve", "--effects", str(bad_py), "--add", f"bad_{case}@M2=1", "--mass", "3", *alpha_args
    )
    assert out.returncode == 2
    assert out.stdout == ""
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"eodarm: error: {want}"), out.stderr


def test_a_bad_function_stops_diagnose_in_one_line_and_debug_shows_the_traceback(
    bad_py: Path, tmp_path: Path
) -> None:
    arm = example_arm()
    meas = synth(arm, random_configs(arm, 4, np.random.default_rng(0)), MASSES, seed=1)
    csv = tmp_path / "m.csv"
    meas.to_csv(csv)
    args = ["diagnose", str(csv), "--arm", str(EXAMPLE_TOML), "--effects", str(bad_py)]
    out = run_cli(*args)
    assert out.returncode == 2
    assert out.stderr.splitlines() == [
        "eodarm: error: custom effect bad_raises@M1: the function raised RuntimeError: stuck"
    ]
    out = run_cli("--debug", *args)
    assert out.returncode == 2
    assert "Traceback" in out.stderr and "in bad_raises" in out.stderr
    assert "CustomEffectError: custom effect bad_raises@M1" in out.stderr


@pytest.mark.parametrize(
    ("source", "message"),
    [
        ("import numpy as np\nx = 1 / 0\n", "ZeroDivisionError: division by zero (line 2)"),
        ("def (:\n", "SyntaxError: invalid syntax"),
        (
            "import eodarm\neodarm.custom_effect('joint_clearance', places='O', parameter='c')\n",
            "custom effect 'joint_clearance': the name is a built-in effect's",
        ),
    ],
)
def test_an_effects_file_that_fails_is_one_line(source: str, message: str, tmp_path: Path) -> None:
    path = tmp_path / "broken.py"
    path.write_text(source)
    with pytest.raises(CustomEffectError, match="effects file .*broken.py: " + message[:12]):
        custom.load_file(path)
    out = run_cli("solve", "--effects", str(path))
    assert out.returncode == 2
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("eodarm: error: effects file "), out.stderr
    assert message in lines[0]
    out = run_cli("solve", "--effects", str(tmp_path / "missing.py"))
    assert out.returncode == 2 and out.stderr.strip().endswith("missing.py: no such file")


# ---------------------------------------------------------------------------- the CLI
@pytest.fixture(scope="module")
def friction_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``eodarm synth --effects examples/contact_mount.py --hidden contact_mount@M2=0.001``."""
    path = tmp_path_factory.mktemp("friction") / "friction.csv"
    out = run_cli(
        "synth",
        "--arm",
        str(EXAMPLE_TOML),
        "--effects",
        str(CONTACT_PY),
        "--hidden",
        "contact_mount@M2=0.001",
        "--configs",
        "16",
        "--masses",
        "1.5,3,5,6.5",
        "--seed",
        "1",
        "-o",
        str(path),
    )
    assert out.returncode == 0, out.stderr
    return path


def test_cli_diagnose_with_effects_finds_the_contact_mount(friction_csv: Path) -> None:
    args = ["diagnose", str(friction_csv), "--arm", str(EXAMPLE_TOML), "--json"]
    out = run_cli(*args, "--effects", str(CONTACT_PY))
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert doc["verdict"] == "missing"
    assert doc["suggested"] == ["contact_mount@M2"]
    top = doc["ranking"][0]
    assert (top["effect"], top["at"]) == ("contact_mount", "M2")
    assert top["estimate"]["c_mm_per_n23"] == pytest.approx(1e-3, rel=0.1)
    assert 0.7 < top["chi2_per_dof"] < 1.4
    # without the file the name is unknown to every command
    out = run_cli("fit", str(friction_csv), "--arm", str(EXAMPLE_TOML), "--add", "contact_mount@M2")
    assert out.returncode == 2 and "contact_mount" in out.stderr


def test_cli_fit_with_effects_and_the_arm_file_carrying_it(
    friction_csv: Path, tmp_path: Path
) -> None:
    args = ["fit", str(friction_csv), "--arm", str(EXAMPLE_TOML), "--effects", str(CONTACT_PY)]
    out = run_cli(*args, "--add", "contact_mount@M2", "--json")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    [eff] = doc["effects"]
    assert eff["effect"] == "contact_mount" and eff["at"] == "M2"
    est, err = eff["estimate"]["c_mm_per_n23"], eff["stderr"]["c_mm_per_n23"]
    assert abs(est - 1e-3) < 4 * err and 0 < err < 1e-4
    assert doc["after"]["chi2_per_dof"] < 1.4 < doc["before"]["chi2_per_dof"]
    assert doc["after"]["rms"]["dy_mm"] < 0.3 * doc["before"]["rms"]["dy_mm"]
    # an [[effect]] table of a user effect, read with --effects
    arm = tmp_path / "arm.toml"
    arm.write_text(
        EXAMPLE_TOML.read_text()
        + '\n[[effect]]\neffect = "contact_mount"\nat = "M2"\nc_mm_per_n23 = 0.001\n'
    )
    out = run_cli("solve", "--arm", str(arm), "--effects", str(CONTACT_PY), "--json")
    assert out.returncode == 0, out.stderr
    out = run_cli("solve", "--arm", str(arm))
    assert out.returncode == 2 and "effect[1].effect" in out.stderr


def test_cli_report_with_effects(friction_csv: Path, tmp_path: Path) -> None:
    """The investigation's rounds find the friction and the report names it."""
    out_html = tmp_path / "report.html"
    out = run_cli(
        "report", str(friction_csv), "--arm", str(EXAMPLE_TOML), "--effects", str(CONTACT_PY),
        "-o", str(out_html),
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "+ contact_mount@M2" in out.stdout
    assert "contact_mount@M2" in out_html.read_text()


def test_cli_solve_and_sweep_with_effects(tmp_path: Path) -> None:
    args = ["--effects", str(CONTACT_PY), "--add", "contact_mount@M2=0.001"]
    out = run_cli(
        "solve", "--arm", str(EXAMPLE_TOML), *args, "--alpha", "90,10,0", "--mass", "5", "--json"
    )
    assert out.returncode == 0, out.stderr
    pose = json.loads(out.stdout)["poses"][0]
    with registered("contact_mount"):
        want = eodarm.solve(
            example_arm(),
            [90.0, 10.0, 0.0],
            5.0,
            [eodarm.Effect("contact_mount", "M2", c_mm_per_n23=1e-3)],
        )
    assert pose["dy_mm"] == pytest.approx(float(want["dy_mm"][0]), abs=1e-12)
    out = run_cli(
        "sweep", "--arm", str(EXAMPLE_TOML), *args, "--alpha1", "60:120:4", "--alpha2", "0:20:2",
        "--alpha3", "0", "--mass", "0,5", "-o", str(tmp_path / "s.nc"), "--no-progress",
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    out = run_cli("solve", *args, "--model", "fem")
    assert out.returncode == 2
    assert "custom effect contact_mount@M2: the finite-element model" in out.stderr


# ---------------------------------------------------------------------------- entry points
def test_entry_points_register_lazily_and_not_at_import(tmp_path: Path) -> None:
    """An installed package's effects (entry-point group ``eodarm.effects``) are there when
    a name is looked up, and ``import eodarm`` does not load them."""
    site = tmp_path / "site"
    (site / "fakepkg-1.0.dist-info").mkdir(parents=True)
    (site / "fakepkg-1.0.dist-info" / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: fakepkg\nVersion: 1.0\n"
    )
    (site / "fakepkg-1.0.dist-info" / "entry_points.txt").write_text(
        "[eodarm.effects]\nfriction = fake_friction\n"
    )
    (site / "fake_friction.py").write_text(
        CONTACT_PY.read_text().replace('"contact_mount"', '"plugin_friction"')
    )
    code = textwrap.dedent(
        f"""
        import sys
        sys.path.insert(0, {str(site)!r})
        import eodarm
        assert "fake_friction" not in sys.modules and "eodarm.model.custom" not in sys.modules
        e = eodarm.Effect("plugin_friction", "M1", c_mm_per_n23=5e-4)
        assert "fake_friction" in sys.modules
        print(e.key)
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "plugin_friction@M1"
    # the CLI loads the group when a command that takes effects starts
    env_code = (
        f"import sys; sys.path.insert(0, {str(site)!r}); "
        "from eodarm.cli import main; sys.exit(main())"
    )
    out = subprocess.run(
        [
            sys.executable,
            "-c",
            env_code,
            "solve",
            "--add",
            "plugin_friction@M2=0.001",
            "--mass",
            "5",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert out.returncode == 0, out.stderr
    assert "plugin_friction@M2" in out.stdout
