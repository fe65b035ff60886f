"""Load sequences on arms with rotary drives (docs/model.md §9, §10): the drive's friction,
a joint friction at a drive, the backlash taken up along each state's torque.

``solve_sequence`` (the numpy reference) equals an exact simulation of the sequence written
here, state by state: the friction elements stepped in Python from the statics, each state
then one ``eodarm.solve`` of the frictionless elastic model with what the frictions and gaps
cause given as user deformations (a drive's turn, an actuator's length, a pin offset). And the
physical facts in angle: the branches bracket the frictionless curve 2L/k apart in the drive's
angle, and L/k is left at the return.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import eodarm
from eodarm.model import reference as ref
from eodarm.model.effects import UNLOADED
from simulation import simulate_drives as simulate
from strategies import FRICTIONS, effects_for, mixed_arm_and_poses

ROTARY = Path(__file__).resolve().parents[1] / "examples" / "rotary_arm.toml"
POSE = [[30.0, 0.0, -20.0]]
CYCLE = np.array([0.0, 1.5, 5.0, 6.5, 5.0, 1.5, 0.0])
MOTION = ("dx_mm", "dy_mm", "dalpha_deg", "dl_mm")
#: Both sides close the same pose from the same causes: they differ by rounding of sums of
#: terms of up to ~1e3 mm (1e-13 mm), far below this.
EXACT_MM = 1e-9


@st.composite
def sequence_cases(draw, max_links: int = 5):
    """A plausible mixed arm, one pose per sequence (1–3), S = 1–8 payloads of 0–8 kg, and
    effects with at least one friction (no link bending beside a linear joint's friction, see
    :func:`simulate`)."""
    arm, alpha, _ = draw(mixed_arm_and_poses(max_links=max_links, max_poses=3))
    states = draw(st.integers(1, 8))
    masses = draw(
        st.lists(
            st.lists(st.floats(0.0, 8.0), min_size=states, max_size=states),
            min_size=alpha.shape[0],
            max_size=alpha.shape[0],
        )
    )
    frictions = draw(effects_for(arm, FRICTIONS, max_size=3, min_size=1))
    kinds = tuple(k for k in eodarm.CATALOGUE if k not in FRICTIONS)
    if any(f.name == "joint_friction" and arm.is_linear(f.index(arm.n)) for f in frictions):
        kinds = tuple(k for k in kinds if k != "link_bending")
    others = draw(effects_for(arm, kinds, max_size=4, unloaded=UNLOADED))
    return arm, alpha, np.array(masses, dtype=float), frictions + others


# ---------------------------------------------------------------------------- the simulation
@settings(max_examples=60, deadline=None)
@given(case=sequence_cases(), self_weight=st.booleans())
def test_solve_sequence_equals_an_exact_simulation_of_the_sequence(case, self_weight) -> None:
    arm, alpha, masses, effects = case
    out = ref.solve_sequence(arm, alpha, masses, effects, self_weight=self_weight)
    rot = np.array(arm.kinds) == "rotary"
    for q in range(alpha.shape[0]):
        sim = simulate(arm, alpha[q], masses[q], effects, self_weight)
        for key in MOTION:
            np.testing.assert_allclose(
                out[key][q], sim[key], rtol=0, atol=EXACT_MM, equal_nan=True, err_msg=key
            )
        # forces and torques: 1e-9 relative to the largest of the sequence
        got = np.where(rot, out["torque_nmm"][q], out["force_n"][q])
        scale = max(1.0, float(np.abs(sim["u"]).max()))
        np.testing.assert_allclose(got, sim["u"], rtol=0, atol=1e-9 * scale)
        scale = max(1.0, float(np.abs(sim["reaction_n"]).max()))
        np.testing.assert_allclose(
            out["reaction_n"][q], sim["reaction_n"], rtol=0, atol=1e-9 * scale
        )


MIXED = ROTARY.with_name("mixed_arm.toml")


@pytest.mark.parametrize(
    ("path", "specs"),
    [
        # a joint friction at a drive beside bent links: the links carry the whole ΔT
        (ROTARY, ["joint_friction@O2:4000", "link_bending@L1:2e9", "link_bending@L2:1e9"]),
        (ROTARY, ["drive_friction@O3:3000", "link_bending@L2:1e9", "drive_backlash@O3:0.1:t"]),
        (MIXED, ["joint_friction@O1:20000", "link_bending@L1:3e9", "actuator_friction@M2:150"]),
        (MIXED, ["drive_backlash@O1:0.05", "joint_clearance@O2:0.1:t", "actuator_play@M3:0.05"]),
    ],
    ids=["joint-friction-bent", "drive-friction-backlash", "mixed-frictions", "mixed-gaps"],
)
def test_the_examples_cycle_equals_the_simulation(path: Path, specs: list[str]) -> None:
    """The campaign's cycle on the example arms, with the frictions where they hold something
    and beside bent links: each state as the simulation has it."""
    arm = eodarm.Arm.from_toml(path)
    effects = []
    for spec in specs:
        key, value, *mode = spec.split(":")
        name, at = key.split("@")
        unloaded = "taken_up" if mode else "centred"
        effects.append(
            eodarm.Effect(
                name, at, unloaded=unloaded, **{eodarm.CATALOGUE[name].param: float(value)}
            )
        )
    alpha = np.array([POSE[0], [55.0, -10.0, -50.0]])
    out = ref.solve_sequence(arm, alpha, CYCLE, effects)
    frictionless = [e for e in effects if "friction" not in e.name]
    free = ref.solve_sequence(arm, alpha, CYCLE, frictionless)
    if len(frictionless) < len(effects):  # the frictions hold something
        assert np.abs(out["dy_mm"] - free["dy_mm"]).max() > 1e-3
    for q in range(2):
        sim = simulate(arm, alpha[q], CYCLE, effects)
        for key in MOTION:
            np.testing.assert_allclose(
                out[key][q], sim[key], rtol=0, atol=EXACT_MM, equal_nan=True, err_msg=key
            )


@settings(max_examples=30, deadline=None)
@given(case=sequence_cases(), self_weight=st.booleans())
def test_a_monotonic_loading_is_a_row_of_single_loadings(case, self_weight) -> None:
    arm, alpha, masses, effects = case
    masses = np.sort(masses, axis=1)  # every force and torque change grows with the payload
    out = ref.solve_sequence(arm, alpha, masses, effects, self_weight=self_weight)
    states = masses.shape[1]
    single = ref.solve(arm, np.repeat(alpha, states, 0), masses.reshape(-1), effects, self_weight)
    for key in (*MOTION, "dtorque_nmm", "dforce_n"):
        np.testing.assert_allclose(
            out[key].reshape(single[key].shape),
            single[key],
            rtol=1e-9,
            atol=EXACT_MM,
            equal_nan=True,
            err_msg=key,
        )


# ---------------------------------------------------------------------------- hysteresis
def drive_turns(out: dict[str, np.ndarray]) -> np.ndarray:
    """Each joint's turn Δq_i = Δα_i − Δα_{i−1} (rad), (S, n) of the first sequence: a drive's
    own turn where no chassis tilt or bent link turns its housing."""
    return np.diff(np.radians(out["dalpha_deg"][0]), axis=1, prepend=0.0)


@pytest.mark.parametrize("name", ["drive_friction", "joint_friction"])
def test_branches_are_2l_over_k_apart_in_the_drives_angle(name: str) -> None:
    """The elbow of the rotary example, L = 5 N·m, loaded 0 → 6.5 kg and back: ΔT_2 grows by
    ~8.5 N·m per kg, so between states it moves by ≥ 12.8 N·m > 2L and the element slips both
    ways. The gear's spring then takes ΔT ∓ L on the two branches: at 1.5 and 5 kg the drive's
    angle differs between them by exactly 2L/k, and the frictionless curve lies between. At
    the return the spring still holds L: the joint stays L/k turned down. A joint friction at a
    drive acts on the whole drive with its limit itself (no moment arm): the same numbers."""
    arm = eodarm.Arm.from_toml(ROTARY)
    limit, j = 5000.0, 1
    k = arm.actuators[j].stiffness_nmm_per_rad  # type: ignore[union-attr]
    eff = [eodarm.Effect(name, "O2", torque_nmm=limit)]
    with_f = ref.solve_sequence(arm, POSE, CYCLE, eff)
    free = ref.solve_sequence(arm, POSE, CYCLE, [])
    dt = free["dtorque_nmm"][0, :, j]
    assert np.diff(dt[:4]).min() > 2 * limit and (dt > -1e-9).all()  # slips every state
    q, q_free = drive_turns(with_f)[:, j], drive_turns(free)[:, j]
    for up, down in ((1, 5), (2, 4)):
        assert q[down] - q[up] == pytest.approx(-2.0 * limit / k, rel=1e-9)
        assert min(q[up], q[down]) < q_free[up] < max(q[up], q[down])
    assert q[-1] == pytest.approx(-limit / k, rel=1e-9)
    assert abs(with_f["dy_mm"][0, -1]) > 1e-3  # the arm does not come back
    # the torque through the drive is the reference's plus what its spring (or the whole
    # drive) took; the friction holds the rest
    st0 = ref.statics(arm, POSE, [0.0, 0.0])["torque0_nmm"][0, j]
    np.testing.assert_allclose(
        with_f["torque_nmm"][0, :, j] - st0, with_f["dtorque_nmm"][0, :, j], rtol=1e-12
    )
    if name == "drive_friction":  # inside the drive: the torque through it is the whole ΔT
        np.testing.assert_allclose(with_f["dtorque_nmm"][0, :, j], dt, rtol=1e-12)
    else:  # the joint holds the rest: the drive takes what its spring took
        np.testing.assert_allclose(-q * k, with_f["dtorque_nmm"][0, :, j], rtol=1e-9)


def test_a_centred_backlash_stays_along_the_self_weight_at_the_return() -> None:
    """A backlash closed by the payload stays closed along the self-weight's torque at the
    return (it does not re-centre): the return equals a single solve at zero payload, and the
    joint is turned by −b·sign(T0)."""
    arm = eodarm.Arm.from_toml(ROTARY)
    b = 0.1
    eff = [eodarm.Effect("drive_backlash", "O3", backlash_deg=b)]
    out = ref.solve_sequence(arm, POSE, [6.5, 0.0], eff)
    once = ref.solve(arm, POSE, 0.0, eff)
    for key in ("dx_mm", "dy_mm", "dalpha_deg"):
        np.testing.assert_allclose(out[key][0, 1], once[key][0], rtol=0, atol=EXACT_MM)
    t0 = ref.statics(arm, POSE, [0.0, 0.0])["torque0_nmm"][0, 2]
    assert drive_turns(out)[1, 2] == pytest.approx(
        -math.radians(b) * math.copysign(1, t0), rel=1e-9
    )
