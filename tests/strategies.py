"""Hypothesis strategies for eodarm: valid random arms, poses, payloads and effects.

This is the one place where random inputs are built; every property test draws from here.

Design (why the inputs are always valid, without heavy filtering):

* **Arms** (:func:`arms`) resemble real ones: links 150–600 mm long, actuator pins 40–150 mm
  from their joint, offsets within ±80 mm, masses 0–5 kg, actuator stiffness 200–20000 N/mm
  (log-uniform), an optional measurement point, an optional chassis pivot and an optional
  section stiffness ``ei_n_mm2``. Every actuator's base pin sits at least 100 mm from the joint
  its actuator turns (``|B0 − O1| ≥ 100``; on a link ``B`` lies ≥ 100 mm behind ``next``).
* **Poses** (:func:`poses_for`) are *constructed*, not filtered: link by link from the base,
  the angle φ_i at joint O_i between the actuator's base pin B_{i−1} and its pin A_i is drawn
  in [35°, 145°] on either side. With |B_{i−1} − O_i| ≥ 100 mm and |A_i − O_i| ≤ 150 mm the
  actuator's moment arm is then ``|h_i| = |D|·|A|·sin φ / ℓ ≥ 0.23·|A_i − O_i|`` and the
  triangle (O_i, B_{i−1}, A_i) is far from degenerate (an angle change of up to ±35° still
  closes it), so every pose is non-singular and well conditioned.
* **Loads**: :func:`arm_and_poses` makes the arm physically plausible for the largest payload
  the tests use (8 kg, or a force of that size in any direction) at the drawn poses: where the
  drawn actuator is so soft that the payload would turn a triangle by more than 0.01 rad, its
  stiffness is raised to that limit; the link's ``ei_n_mm2`` is raised likewise for bending.
  (A 40 mm lever with a 200 N/mm actuator cannot carry 8 kg at 2 m; a real arm would not be
  built so.)
* **Effects** (:func:`effects_for`) draw parameters in physical ranges, never more than 4×
  softer than the arm's own actuator stiffness / section stiffness. Together with the 0.01 rad
  design limit, all effects at once turn a triangle by well under 0.35 rad, so every loaded
  triangle still closes.
* **Mixed arms** (:func:`mixed_arm_and_poses`, ``arm_dicts(..., rotary=True)``): 1–7 links,
  each joint a linear actuator or a rotary drive (drawn independently, so all-linear and
  all-rotary arms come up too). A drive has no pins (the link's ``A``, the previous body's
  ``B`` or ``B0`` are left out), a torsional stiffness of 10⁶–10⁸ N·mm/rad (log-uniform, then
  raised like an actuator's so that the largest payload turns it by at most
  :data:`DESIGN_TURN`), 0–5 kg, and sometimes a torque limit and an angle range. At a drive
  the pose draws the relative angle q_i in ±:data:`Q_RANGE` instead of a triangle's angle.
  Each joint's effects are those of its kind (the drive's: ``drive_compliance``,
  ``drive_backlash``, ``drive_friction``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from hypothesis import strategies as st
from hypothesis.strategies import SearchStrategy

import eodarm
from eodarm.model import reference
from eodarm.model.effects import candidate_places

#: Largest payload mass the tests apply (kg).
MAX_PAYLOAD_KG = 8.0
#: Rotation (rad) of any actuator triangle that the largest payload may cause with the arm's own
#: stiffnesses (actuators and link sections) at the drawn poses.
DESIGN_TURN = 0.01
#: Angle at the joint between the actuator's base pin and its link pin (degrees).
PHI_RANGE = (35.0, 145.0)
#: The largest |q_i| (degrees) a pose gives a rotary drive.
Q_RANGE = 150.0
#: The torsional stiffness (N·mm/rad) a drive is drawn with, before :func:`make_plausible`.
DRIVE_STIFFNESS = (1e6, 1e8)
#: An actuator stiffness that does not deform measurably (N/mm).
RIGID = 1e18

#: Default number of links of a random arm.
LINK_COUNTS = st.integers(1, 4)
ELASTIC = (
    "actuator_compliance",
    "mount_compliance",
    "link_bending",
    "base_compliance",
    "drive_compliance",
)
#: The effects with memory (codes 8, 9): drawn where a test asks for them (``kinds=``). The
#: compiled core's own kernels (sweep, block kernel, Jacobian) are tested without them until
#: the core has them; ``solve`` and ``solve_sequence`` take them on both backends.
FRICTIONS = ("actuator_friction", "joint_friction", "drive_friction")
ALL_KINDS = tuple(k for k in eodarm.CATALOGUE if k not in FRICTIONS)


def _f(lo: float, hi: float) -> SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


def _log(lo: float, hi: float) -> SearchStrategy[float]:
    """Log-uniform floats in [lo, hi]."""
    return _f(math.log(lo), math.log(hi)).map(lambda t: min(max(math.exp(t), lo), hi))


def _rot(theta: float, v: np.ndarray) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


# ---------------------------------------------------------------------------- arms
@st.composite
def arm_dicts(
    draw: Any, n: int | SearchStrategy[int] = LINK_COUNTS, rotary: bool = False
) -> dict[str, Any]:
    """A valid arm as the dict of its arm file (see :func:`arms`); with ``rotary`` each joint
    is a linear actuator or a rotary drive (see the module notes), else every joint linear."""
    n_links = draw(n) if isinstance(n, SearchStrategy) else int(n)
    kinds = ["linear"] * n_links
    if rotary:
        kinds = draw(
            st.lists(st.sampled_from(["linear", "rotary"]), min_size=n_links, max_size=n_links),
            label="kinds",
        )
    o1 = [draw(_f(-100.0, 100.0)), draw(_f(-100.0, 100.0))]
    base: dict[str, Any] = {"O1": o1}
    if kinds[0] == "linear":
        r_b0 = draw(_f(100.0, 350.0))
        t_b0 = math.radians(draw(_f(-180.0, 180.0)))
        base["B0"] = [o1[0] + r_b0 * math.cos(t_b0), o1[1] + r_b0 * math.sin(t_b0)]
    if draw(st.booleans()):
        base["pivot"] = [o1[0] + draw(_f(-300.0, 300.0)), o1[1] + draw(_f(-300.0, 300.0))]
    links = []
    for i in range(n_links):
        last = i == n_links - 1
        length = draw(_f(150.0, 600.0))
        rho = draw(_f(40.0, 150.0))  # |A|: actuator pin distance from the joint
        y_a = draw(_f(-1.0, 1.0)) * min(80.0, 0.9 * rho)
        x_a = math.copysign(math.sqrt(rho * rho - y_a * y_a), draw(st.sampled_from([1.0, -1.0])))
        link: dict[str, Any] = {"next": [length, draw(_f(-40.0, 40.0))]}
        if kinds[i] == "linear":
            link["A"] = [x_a, y_a]
        if not last and kinds[i + 1] == "linear":
            # the next actuator's base pin: ≥ 100 mm behind the next joint
            link["B"] = [draw(_f(-150.0, length - 100.0)), draw(_f(-80.0, 80.0))]
        link["C"] = [draw(_f(-50.0, length)), draw(_f(-80.0, 80.0))]
        link["mass_kg"] = draw(_f(0.0, 5.0))
        if last and draw(st.booleans()):
            link["measure"] = [draw(_f(0.0, length)), draw(_f(-80.0, 80.0))]
        if draw(st.booleans()):
            link["ei_n_mm2"] = draw(_log(1e8, 1e11))
        links.append(link)
    actuators = [
        {"stiffness_n_per_mm": draw(_log(200.0, 20000.0)), "mass_kg": draw(_f(0.0, 5.0))}
        if kind == "linear"
        else _drive_table(draw)
        for kind in kinds
    ]
    d: dict[str, Any] = {"name": "random-arm", "base": base, "link": links, "actuator": actuators}
    if draw(st.booleans()):
        d["g"] = draw(_f(9.7, 9.9))
    return d


def _drive_table(draw: Any) -> dict[str, Any]:
    """A rotary drive's ``[[actuator]]`` table: stiffness, mass, sometimes limits."""
    table: dict[str, Any] = {
        "kind": "rotary",
        "stiffness_nmm_per_rad": draw(_log(*DRIVE_STIFFNESS)),
        "mass_kg": draw(_f(0.0, 5.0)),
    }
    if draw(st.booleans(), label="torque limit"):
        table["max_torque_nmm"] = draw(_log(1e4, 1e7))
    if draw(st.booleans(), label="angle range"):
        lo, hi = sorted(draw(st.lists(_f(-180.0, 180.0), min_size=2, max_size=2)))
        table["min_angle_deg"], table["max_angle_deg"] = lo, hi
    return table


def arms(n: int | SearchStrategy[int] = LINK_COUNTS) -> SearchStrategy[eodarm.Arm]:
    """Random valid arms of ``n`` links, built with :meth:`eodarm.Arm.from_dict`.

    Their stiffnesses are as drawn; for loads use :func:`arm_and_poses`, which makes them
    plausible for the payloads the tests apply.
    """
    return arm_dicts(n).map(eodarm.Arm.from_dict)


# ---------------------------------------------------------------------------- poses
def pose_from_joint_angles(
    arm: eodarm.Arm, sides: list[float], phis_deg: list[float]
) -> list[float]:
    """Absolute angles (deg) that put A_i at angle ``side·φ_i`` from B_{i−1}, seen from O_i, at
    a linear joint; at a rotary joint, ``side·φ_i`` is the drive's angle q_i = α_i − α_{i−1}."""
    o = np.array(arm.O1, dtype=float)
    b = np.array(arm.B0 or (0.0, 0.0), dtype=float)
    out = []
    prev = 0.0
    for i, lk in enumerate(arm.links):
        if lk.A is None:
            al = prev + sides[i] * math.radians(phis_deg[i])
        else:
            d = b - o
            a = np.array(lk.A, dtype=float)
            al = (
                math.atan2(d[1], d[0])
                + sides[i] * math.radians(phis_deg[i])
                - math.atan2(a[1], a[0])
            )
        al = (al + math.pi) % (2.0 * math.pi) - math.pi
        prev = al
        out.append(math.degrees(al))
        if lk.B is not None:
            b = o + _rot(al, np.array(lk.B, dtype=float))
        o = o + _rot(al, np.array(lk.next, dtype=float))
    return out


@st.composite
def poses_for(draw: Any, arm: eodarm.Arm, min_size: int = 1, max_size: int = 8) -> np.ndarray:
    """(N, n) well-conditioned unloaded poses (degrees) of ``arm`` (see the module notes)."""
    rows = draw(st.integers(min_size, max_size))
    out = []
    for _ in range(rows):
        sides = [draw(st.sampled_from([1.0, -1.0])) for _ in range(arm.n)]
        phis = [
            draw(_f(*PHI_RANGE)) if kind == "linear" else draw(_f(0.0, Q_RANGE))
            for kind in arm.kinds
        ]
        out.append(pose_from_joint_angles(arm, sides, phis))
    return np.array(out, dtype=float).reshape(rows, arm.n)


def masses(rows: int, max_kg: float = MAX_PAYLOAD_KG) -> SearchStrategy[np.ndarray]:
    """(rows,) payload masses in [0, max_kg] kg."""
    return st.lists(_f(0.0, max_kg), min_size=rows, max_size=rows).map(np.array)


@st.composite
def payload_vectors(draw: Any, rows: int, g: float = 9.81) -> np.ndarray:
    """(rows, 2) payload forces (N) of any direction, at most the weight of the largest payload."""
    out = []
    for _ in range(rows):
        mag = draw(_f(0.0, MAX_PAYLOAD_KG * g))
        t = math.radians(draw(_f(-180.0, 180.0)))
        out.append([mag * math.cos(t), mag * math.sin(t)])
    return np.array(out, dtype=float).reshape(rows, 2)


# ---------------------------------------------------------------------------- plausible loads
def moment_arms(arm: eodarm.Arm, alpha_deg: np.ndarray) -> np.ndarray:
    """|h_i| (N, n): distance from joint O_i to actuator i's line, mm (NaN at a drive)."""
    geo = eodarm.forward(arm, alpha_deg, backend="numpy")
    n = arm.n
    r = geo["A"] - geo["O"][:, :n]
    e = (geo["A"] - geo["B"]) / geo["length_mm"][..., None]
    return np.abs(r[..., 0] * e[..., 1] - r[..., 1] * e[..., 0])


def _stiffness_key(table: dict[str, Any]) -> str:
    """The stiffness key of an ``[[actuator]]`` table: its kind's."""
    return "stiffness_nmm_per_rad" if table.get("kind") == "rotary" else "stiffness_n_per_mm"


def _with(d: dict[str, Any], **actuator_or_link: Any) -> dict[str, Any]:
    """A copy of an arm dict with per-joint values set: ``stiffness`` (each actuator table's
    own stiffness key) or a link key such as ``ei_n_mm2``."""
    out = {**d, "base": dict(d["base"])}
    out["link"] = [dict(lk) for lk in d["link"]]
    out["actuator"] = [dict(a) for a in d["actuator"]]
    for key, values in actuator_or_link.items():
        if key == "stiffness":
            for row, v in zip(out["actuator"], values, strict=True):
                row[_stiffness_key(row)] = float(v)
            continue
        for row, v in zip(out["link"], values, strict=True):
            row[key] = float(v)
    return out


def make_plausible(d: dict[str, Any], alpha_deg: np.ndarray) -> dict[str, Any]:
    """Raise actuator and drive stiffness and link EI where the largest payload, in any
    direction, would turn a joint of a drawn pose by more than :data:`DESIGN_TURN` rad (an
    actuator's triangle, Δq = ΔF/(k·h); a drive, Δq = ΔT/k)."""
    arm0 = eodarm.Arm.from_dict(d)
    n = arm0.n
    p_max = MAX_PAYLOAD_KG * arm0.g
    h = moment_arms(arm0, alpha_deg)  # (N, n)
    unit = [
        reference.statics(arm0, alpha_deg, np.array(p), self_weight=False)
        for p in ([1.0, 0.0], [0.0, 1.0])
    ]
    rot = np.array(arm0.kinds) == "rotary"
    # |ΔF_i| or |ΔT_i| per N of payload, worst direction, over the arm of each
    gain = np.where(
        rot,
        np.hypot(unit[0]["torque_nmm"], unit[1]["torque_nmm"]),
        np.hypot(unit[0]["force_n"], unit[1]["force_n"]) / np.where(rot, 1.0, h),
    )
    k_need = (gain * p_max / DESIGN_TURN).max(axis=0)
    k = [max(a[_stiffness_key(a)], float(kn)) for a, kn in zip(d["actuator"], k_need, strict=True)]

    # Bending: response of all links bent at a huge test EI with rigid actuators, linear in 1/EI.
    # Both the turn of every triangle and the load point's displacement over the arm's reach
    # (a link bent like a long overhanging beam moves the next joint sideways) are bounded.
    ei_test = 1e16
    rigid = _with(d, stiffness=[RIGID] * n)
    rigid["link"][-1].pop("measure", None)
    rigid_arm = eodarm.Arm.from_dict(rigid)
    reach = np.linalg.norm(
        np.diff(eodarm.forward(rigid_arm, alpha_deg, backend="numpy")["O"], axis=1), axis=-1
    ).sum(axis=1)
    effs = [eodarm.Effect("link_bending", f"L{i + 1}", ei_n_mm2=ei_test) for i in range(n)]
    turn = 0.0
    for p in ([p_max, 0.0], [0.0, p_max], [-p_max, 0.0], [0.0, -p_max]):
        out = reference.solve_payload(rigid_arm, alpha_deg, np.array(p), effs, self_weight=False)
        rel = np.diff(np.radians(out["dalpha_deg"]), axis=1, prepend=0.0)
        shift = np.hypot(out["dx_mm"], out["dy_mm"]) / reach
        turn = max(turn, float(np.abs(rel).max()), float(shift.max()))
    ei_need = ei_test * turn / DESIGN_TURN
    ei = [max(lk.get("ei_n_mm2", 1e8), ei_need) for lk in d["link"]]
    return _with(d, stiffness=k, ei_n_mm2=ei)


@st.composite
def arm_and_poses(
    draw: Any, max_links: int = 4, max_poses: int = 8, min_links: int = 1
) -> tuple[eodarm.Arm, np.ndarray, np.ndarray]:
    """(arm, alpha_deg (N, n), mass_kg (N,)): a plausible arm, well-conditioned poses, payloads
    of 0–8 kg. Every actuator has |h_i| ≥ 0.23·|A_i − O_i| in every pose."""
    d = draw(arm_dicts(st.integers(min_links, max_links)))
    arm0 = eodarm.Arm.from_dict(d)
    alpha = draw(poses_for(arm0, max_size=max_poses))
    mass = draw(masses(alpha.shape[0]))
    return eodarm.Arm.from_dict(make_plausible(d, alpha)), alpha, mass


@st.composite
def mixed_arm_and_poses(
    draw: Any, max_links: int = 7, max_poses: int = 6, min_links: int = 1
) -> tuple[eodarm.Arm, np.ndarray, np.ndarray]:
    """(arm, alpha_deg (N, n), mass_kg (N,)) as :func:`arm_and_poses`, the arm's joints each a
    linear actuator or a rotary drive (1–7 links; see the module notes)."""
    d = draw(arm_dicts(st.integers(min_links, max_links), rotary=True))
    arm0 = eodarm.Arm.from_dict(d)
    alpha = draw(poses_for(arm0, max_size=max_poses))
    mass = draw(masses(alpha.shape[0]))
    return eodarm.Arm.from_dict(make_plausible(d, alpha)), alpha, mass


# ---------------------------------------------------------------------------- effects
def effect_places(arm: eodarm.Arm, kinds: tuple[str, ...] = ALL_KINDS) -> list[tuple[str, str]]:
    """Every (effect, place) that may sit on ``arm``: each joint's effects of its kind of
    drive only, no bending of a link turned by a linear actuator whose pin A has x ≈ 0."""
    out = []
    for name in kinds:
        for at in candidate_places(name, arm.n, arm.kinds):
            pin = arm.links[int(at[1:]) - 1].A if at != "base" else None
            if (
                name == "link_bending"
                and pin is not None
                and abs(pin[0]) <= 0.05 * math.hypot(*pin)
            ):
                continue
            out.append((name, at))
    return out


def effect_value(
    draw: Any, arm: eodarm.Arm, name: str, at: str, unloaded: tuple[str, ...] = ("centred",)
) -> eodarm.Effect:
    """One effect with a physically plausible parameter (see the module notes); a gap (play,
    clearance) in one of the ``unloaded`` modes (drawn only when there is a choice)."""
    i = int(at[1:]) - 1 if at != "base" else 0
    if name in ("actuator_compliance", "mount_compliance"):
        lo = max(200.0, arm.actuators[i].stiffness_n_per_mm / 4.0)
        value = draw(_log(lo, max(20000.0, 4.0 * lo)))
    elif name in ("actuator_play", "joint_clearance"):
        value = draw(_f(0.0, 0.3))
    elif name == "actuator_friction":
        value = draw(_f(0.0, 300.0))
    elif name == "joint_friction":
        value = draw(_f(0.0, 3.0e4))
    elif name == "link_bending":
        lo = max(1e8, (arm.links[i].ei_n_mm2 or 4e8) / 4.0)
        value = draw(_log(lo, max(1e11, 4.0 * lo)))
    elif name == "drive_compliance":
        lo = max(DRIVE_STIFFNESS[0], arm.arrays()["stiffness"][i] / 4.0)
        value = draw(_log(lo, max(DRIVE_STIFFNESS[1], 4.0 * lo)))
    elif name == "drive_backlash":
        value = draw(_f(0.0, 0.2))  # degrees: a worn planetary stage has a few tenths
    elif name == "drive_friction":
        value = draw(_f(0.0, 3.0e4))  # N·mm: up to 30 N·m in the gear
    else:
        value = draw(_log(1e7, 1e9))
    mode = "centred"
    if eodarm.CATALOGUE[name].taken_up_code is not None and len(unloaded) > 1:
        mode = draw(st.sampled_from(unloaded))
    elif eodarm.CATALOGUE[name].taken_up_code is not None:
        mode = unloaded[0]
    return eodarm.Effect(name, at, unloaded=mode, **{eodarm.CATALOGUE[name].param: value})


@st.composite
def effect_at(draw: Any, arm: eodarm.Arm, name: str, at: str) -> eodarm.Effect:
    """One effect ``name`` at place ``at`` of ``arm`` with a plausible parameter."""
    return effect_value(draw, arm, name, at)


@st.composite
def effects_for(
    draw: Any,
    arm: eodarm.Arm,
    kinds: tuple[str, ...] = ALL_KINDS,
    max_size: int = 6,
    unloaded: tuple[str, ...] = ("centred",),
    min_size: int = 0,
) -> list[eodarm.Effect]:
    """``min_size``–``max_size`` distinct effects (any of ``kinds``, any valid place) for
    ``arm``; gaps in the ``unloaded`` modes (``eodarm.effects.UNLOADED`` for both)."""
    places = effect_places(arm, kinds)
    chosen = draw(
        st.lists(
            st.sampled_from(places),
            unique=True,
            min_size=min(min_size, len(places)),
            max_size=min(max_size, len(places)),
        )
    )
    return [effect_value(draw, arm, name, at, unloaded) for name, at in chosen]


@st.composite
def extra_deformations(draw: Any, arm: eodarm.Arm, rows: int) -> dict[str, np.ndarray]:
    """What user-written effects add (custom-effects.md), as ``solve(extra=...)`` takes it: each key
    present or not, in sizes a real mechanism shows (length changes and joint offsets up to
    0.3 mm, a chassis tilt up to 1e-4 rad, a measure-point shift up to 1 mm), small enough that
    every loaded triangle still closes."""
    n = arm.n
    sizes = {
        "extra_seen_mm": ((rows, n), 0.3),
        "extra_unseen_mm": ((rows, n), 0.3),
        "extra_joint_mm": ((rows, n, 2), 0.3),
        "extra_tilt_rad": ((rows,), 1e-4),
        "extra_measure_mm": ((rows, 2), 1.0),
    }
    out = {}
    for key, (shape, size) in sizes.items():
        if draw(st.booleans(), label=f"{key} given"):
            values = draw(
                st.lists(_f(-size, size), min_size=math.prod(shape), max_size=math.prod(shape)),
                label=key,
            )
            out[key] = np.array(values).reshape(shape)
    return out


# ---------------------------------------------------------------------------- arm variants
def rigid_copy(arm: eodarm.Arm) -> eodarm.Arm:
    """The same arm with actuators and drives that do not deform measurably (k = 1e18 N/mm or
    N·mm/rad)."""
    d = arm.to_dict()
    for a in d["actuator"]:
        a[_stiffness_key(a)] = RIGID
    return eodarm.Arm.from_dict(d)


def measuring_at_load_point(arm: eodarm.Arm) -> eodarm.Arm:
    """The same arm with its measurement point at the load point."""
    d = arm.to_dict()
    d["link"][-1].pop("measure", None)
    return eodarm.Arm.from_dict(d)


# ---------------------------------------------------------------------------- repeats
@st.composite
def repeated_values(draw: Any) -> tuple[np.ndarray, np.ndarray]:
    """Values of one channel over states measured 1–6 times: ``(values, state)``, both (N,).

    Each state has its own level (up to ±1000, so that cancellation matters) and its repeats
    scatter around it by up to ±1 (some states not at all: identical repeats); some cells are
    ``NaN`` (not measured), and the rows of the states are shuffled together.
    """
    k = draw(st.integers(1, 12))
    levels = draw(st.lists(_f(-1000.0, 1000.0), min_size=k, max_size=k))
    vals: list[float] = []
    state: list[int] = []
    for g, level in enumerate(levels):
        size = draw(st.integers(1, 6))
        spread = draw(st.sampled_from([0.0, 1e-3, 1.0]))
        for _ in range(size):
            # scatter in steps of 1e-3 of the spread: real readings are never subnormal,
            # whose squared differences would underflow to zero
            x = level + spread * draw(st.integers(-1000, 1000)) / 1000.0
            vals.append(math.nan if draw(st.integers(0, 9)) == 0 else x)
            state.append(g)
    order = draw(st.permutations(range(len(vals))))
    return np.array(vals)[list(order)], np.array(state)[list(order)]


def output_subsets() -> SearchStrategy[list[str]]:
    """Subsets of the analytic solve's outputs and ``status``, in any order, for ``outputs=``
    of :func:`eodarm.solve` and :func:`eodarm.solve_sequence`."""
    from eodarm.model.outputs import SOLVE_KEYS

    return st.lists(st.sampled_from([*SOLVE_KEYS, "status"]), min_size=1, unique=True)
