"""The numbers behind the workspace maps: payload capacity and what each effect contributes.

:func:`payload_capacity` finds, for every pose of a grid, the largest payload before an
actuator reaches its force limit or a stroke limit, and which limit it is;
:func:`effect_contributions` splits the sag of every pose between the model's components, as
the report's sag budget does. The maps that
draw them are in :mod:`eodarm.viz.maps`.
"""

from __future__ import annotations

import itertools
import math
import tomllib
import warnings
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, as_effects, with_arm_effects
from eodarm.model.reference import TORQUE_ZERO_NMM
from eodarm.workspace.grid import grid_kwargs, grid_of
from eodarm.workspace.sweep import sweep

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "F_EPS",
    "arm_of",
    "as_sweep_kwargs",
    "assume_max_force",
    "effect_contributions",
    "model_name",
    "not_ok_points",
    "payload_capacity",
]

FloatArray = npt.NDArray[np.float64]


GridLike = "xr.Dataset | Mapping[str, npt.ArrayLike]"


#: Numerical zero of a force (N), as in the model (docs/model.md §4).
F_EPS = 1e-9


# ---------------------------------------------------------------------------- helpers
def arm_of(ds: xr.Dataset) -> Arm:
    text = ds.attrs.get("arm_toml")
    if not text:
        raise EodarmError("this Dataset does not carry its arm (attrs['arm_toml']); pass arm=")
    return Arm.from_dict(tomllib.loads(str(text)), source=f"sweep of {ds.attrs.get('arm')}")


def not_ok_points(sel: xr.Dataset) -> tuple[FloatArray, FloatArray, dict[str, int]]:
    """The unloaded load points (x, y) of the poses whose cell of a one-payload slice of a
    sweep is not ok (``status`` ≠ 0, docs/model.md §7; poses that exist only), and how many
    have each reason."""
    from eodarm.model.validity import STATUS

    empty = np.empty(0)
    if "status" not in sel or "effector_x_mm" not in sel:
        return empty, empty, {}
    dims = list(sel["effector_x_mm"].dims)
    code = sel["status"].transpose(*dims).values.reshape(-1).astype(np.int64)
    x = sel["effector_x_mm"].transpose(*dims).values.reshape(-1)
    y = sel["effector_y_mm"].transpose(*dims).values.reshape(-1)
    bad = (code != 0) & np.isfinite(x) & np.isfinite(y)
    counts = np.bincount(code[bad], minlength=len(STATUS))
    return x[bad], y[bad], {STATUS[c]: int(k) for c, k in enumerate(counts) if k}


# ---------------------------------------------------------------------------- capacity
def assume_max_force(arm: Arm, max_force_n: float) -> Arm:
    """A copy of ``arm`` where every actuator without ``max_force_n`` gets this one (N)."""
    if not (math.isfinite(max_force_n) and max_force_n > 0):
        raise EodarmError(f"max_force_n must be finite and > 0, got {max_force_n!r}")
    d = arm.to_dict()
    for a in d["actuator"]:
        a.setdefault("max_force_n", float(max_force_n))
    return Arm.from_dict(d, source=arm.source)


def as_sweep_kwargs(grid: Any) -> dict[str, Any]:
    if isinstance(grid, Mapping):
        if {"alpha_deg", "lengths", "effector"} & set(grid):
            return dict(grid)
        return grid_kwargs(grid)
    return grid_of(grid)


def payload_capacity(
    arm: Arm,
    grid: Any,
    *,
    effects: Effect | Iterable[Effect] | None = (),
    self_weight: bool = True,
    max_payload_kg: float = 100.0,
    probe_kg: float = 1.0,
    **sweep_kw: Any,
) -> xr.Dataset:
    """The largest payload each pose carries before an actuator or a drive reaches a limit.

    Statics are solved on the undeformed geometry, so each loaded force is affine in the
    payload: F_i(m) = F_i(0) + m·s_i, with F_i(0) the self-weight force and s_i found from a
    sweep at 0 and ``probe_kg``. The force limit is reached at the smallest m ≥ 0 with
    |F_i(m)| = ``max_force_n``. The loaded pin-to-pin length is
    ℓ_i(m) = ℓ_i − m·s_i·(1/k_body + 1/k_mount) − p·sign(F_i(m)) (body springs from the arm
    file or ``actuator_compliance``, ``mount_compliance``, ``actuator_play``; model §4), and the
    stroke limit is reached at the smallest m ≥ 0 where it leaves
    [``min_length_mm``, ``max_length_mm``] (play jumps where F_i changes sign). The capacity is
    the smallest of these over every actuator and limit, capped at ``max_payload_kg``.
    User-written effects (custom-effects.md) do not change the forces; their length changes are not
    in the stroke limit (a warning says so).

    A rotary drive (docs/model.md §10) is limited alike by its torque: T_i(m) = T_i(0) + m·s_i
    reaches ``max_torque_nmm`` (either sign), and its loaded angle leaves
    [``min_angle_deg``, ``max_angle_deg``]. That angle is the one the solver's status checks,
    q_i + Δα_i − Δα_{i−1} (Δα_0 = 0): the gear's turn −m·s_i/k_i and the backlash's
    −b·sign(T_i(m)), and also the turn of the drive's housing with the body before it (the
    bending slope of body i−1 at O_i, the chassis' tilt for drive 1). Apart from the backlash
    it is affine in the payload, t_i(m) = t_i(0) + m·r_i, read from the same sweep's
    ``dalpha_deg`` at 0 and ``probe_kg``. Frictions at a drive (``drive_friction``, a
    ``joint_friction`` at its joint) are left out of its limits: they only hold part of a load
    change back (docs/model.md §9), so the frictionless drive's torque and turn are affine
    and reach a limit no later (a backlash's jump aside).

    Poses that are not reachable unloaded (out of stroke, singular) have NaN, and so have
    those where the model is not valid at 0 or ``probe_kg`` (near singular, large deflection;
    docs/model.md §7). Whether the loaded pose still closes at the capacity is not checked (it
    does, unless the capacity is near a singular pose).

    Parameters
    ----------
    arm : the arm; actuators without ``max_force_n`` (and without stroke limits) are not
        limited by them (:func:`assume_max_force` sets one).
    grid : a sweep's Dataset (its grid is reused), a grid dict (``{"alpha1": …}``), or
        :func:`eodarm.sweep` keyword arguments (``{"alpha_deg": {…}}``).
    effects, self_weight : the model.
    max_payload_kg : the cap, kg.
    probe_kg : the second payload of the sweep, kg (> 0).

    Returns
    -------
    xarray.Dataset
        ``capacity_kg`` (grid…), ``limit`` (grid…): the code of the binding limit, −1 where
        NaN; ``attrs["limit_labels"]`` names the codes: ``F1 force`` … ``Fn force``,
        ``l1 stroke`` … ``ln stroke``, then ``cap`` (at a rotary drive ``Ti torque`` and
        ``qi range`` in place of ``Fi force`` and ``li stroke``); plus the sweep's ``reachable``,
        ``effector_x_mm``, ``effector_y_mm``.
    """
    if not (math.isfinite(max_payload_kg) and max_payload_kg > 0):
        raise EodarmError(f"max_payload_kg must be finite and > 0, got {max_payload_kg!r}")
    if not (math.isfinite(probe_kg) and probe_kg > 0):
        raise EodarmError(f"probe_kg must be finite and > 0, got {probe_kg!r}")
    effs = list(as_effects(effects))
    for e in with_arm_effects(arm.effects, effs):
        if e.name in ("actuator_play", "drive_backlash") and e.unloaded != "centred":
            # The stroke formula below is the centred play's; never treat this one so.
            raise EodarmError(
                f"effect {e.label}: the capacity map models play centred when unloaded only"
            )
    users = [e.key for e in effs if e.kind.custom]
    if users:
        warnings.warn(
            f"the capacity map's stroke limits leave out the length changes of the "
            f"user-written effects {', '.join(users)} (their forces are in)",
            UserWarning,
            stacklevel=2,
        )
    kw = {**as_sweep_kwargs(grid), **sweep_kw}
    n = arm.n
    rotary = np.array(arm.kinds) == "rotary"
    # The arm file's effects, then these; without the frictions at the drives (see above).
    model = [
        e
        for e in with_arm_effects(arm.effects, effs)
        if not (e.name in ("drive_friction", "joint_friction") and rotary[e.index(n)])
    ]
    # The force limits are this function's to apply (a probe over a limit still gives the
    # forces' slope): swept without them, the cells are dropped only where the model itself
    # cannot be trusted (status other than over_force, docs/model.md §7).
    free = {k: v for k, v in arm.to_dict().items() if k not in ("effect", "fit")}
    for a in free["actuator"]:
        a.pop("max_force_n", None)
        a.pop("max_torque_nmm", None)
    unlimited = Arm.from_dict(free, source=arm.source)
    ds = sweep(unlimited, mass_kg=[0.0, probe_kg], effects=model, self_weight=self_weight, **kw)
    f = ds["force_n"].transpose(..., "mass_kg", "actuator").values
    if rotary.any():  # a drive's torque (N·mm) in place of a force
        f = np.where(rotary, ds["torque_nmm"].transpose(..., "mass_kg", "actuator").values, f)
    f0, f1 = f[..., 0, :], f[..., 1, :]
    s = (f1 - f0) / probe_kg  # N (N·mm at a drive) per kg
    d = arm.arrays()
    # per joint: body and mount compliance (mm/N), gap (mm, deg at a drive), limits
    kb = d["stiffness"].copy()
    km = np.full(n, np.inf)
    play = np.zeros(n)
    for e in model:
        i = e.index(n)
        if e.name == "actuator_compliance":
            kb[i] = e.value
        elif e.name == "mount_compliance":
            km[i] = e.value
        elif e.name in ("actuator_play", "drive_backlash"):
            play[i] = e.value
    eps = np.where(rotary, TORQUE_ZERO_NMM, F_EPS)  # below it a force or torque has no sign
    # the unloaded length (angle at a drive) and its elastic change per kg
    start = ds["length_mm"].values
    rate = -s * (1.0 / kb + 1.0 / km)  # mm per kg
    if rotary.any():
        q, t0, r = _drive_turns(ds, f0, f1, play, eps, probe_kg)
        start = np.where(rotary, q + t0, start)
        rate = np.where(rotary, r, rate)
    fmax = np.array(
        [
            _limit(a, "max_torque_nmm" if r else "max_force_n", np.inf)
            for a, r in zip(arm.actuators, rotary, strict=True)
        ]
    )
    lo = np.array(
        [
            _limit(a, "min_angle_deg" if r else "min_length_mm", -np.inf)
            for a, r in zip(arm.actuators, rotary, strict=True)
        ]
    )
    hi = np.array(
        [
            _limit(a, "max_angle_deg" if r else "max_length_mm", np.inf)
            for a, r in zip(arm.actuators, rotary, strict=True)
        ]
    )
    m_force = _force_limit(f0, s, fmax)
    m_stroke = _stroke_limit(start, f0, s, rate, play, lo, hi, eps)
    cand = np.concatenate(
        [m_force, m_stroke, np.full((*m_force.shape[:-1], 1), max_payload_kg)], -1
    )
    cand = np.minimum(cand, max_payload_kg)
    which = np.argmin(cand, axis=-1)
    # a cap tie goes to the cap
    which = np.where(cand.min(axis=-1) >= max_payload_kg, 2 * n, which)
    cap = cand.min(axis=-1)
    good = ds["reachable"].values & np.isfinite(f0).all(-1) & np.isfinite(s).all(-1)
    cap = np.where(good, cap, np.nan)
    which = np.where(good, which, -1)
    dims = list(ds["reachable"].dims)
    labels = [f"T{i + 1} torque" if r else f"F{i + 1} force" for i, r in enumerate(rotary)] + [
        f"q{i + 1} range" if r else f"l{i + 1} stroke" for i, r in enumerate(rotary)
    ]
    out = ds[["reachable", "effector_x_mm", "effector_y_mm"]].copy()
    out["capacity_kg"] = (
        dims,
        cap,
        {"units": "kg", "long_name": "largest payload before an actuator or drive limit (capped)"},
    )
    out["limit"] = (dims, which.astype(np.int64), {"long_name": "binding limit (see limit_labels)"})
    out = out.drop_vars(["mass_kg"], errors="ignore")
    out.attrs.update(
        ds.attrs,
        limit_labels=", ".join([*labels, "cap"]),
        max_payload_kg=float(max_payload_kg),
        max_force_n=np.where(np.isfinite(fmax), fmax, -1.0),
        arm_toml=arm.to_toml(),  # the arm with its force limits, not the one swept
    )
    swept = {e.key for e in model}
    left = [e.key for e in with_arm_effects(arm.effects, effs) if e.key not in swept]
    if left:  # the title names the whole model, and what its drives' limits leave out
        out.attrs["model"] = (
            model_name(with_arm_effects(arm.effects, effs))
            + f" ({', '.join(left)}: left out of the drives' limits)"
        )
    return out


def _limit(act: Any, key: str, default: float) -> float:
    """An actuator's or drive's optional limit ``key``, ``default`` where it has none."""
    value = getattr(act, key, None)
    return default if value is None else float(value)


def _drive_turns(
    ds: xr.Dataset,
    t0: FloatArray,
    t1: FloatArray,
    play: FloatArray,
    eps: FloatArray,
    probe_kg: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each pose's unloaded joint angles q_i (deg), and the loaded turn of each joint apart
    from its backlash, affine in the payload: its value at 0 (deg) and its rate (deg per kg).

    The loaded turn is Δα_i − Δα_{i−1} (Δα_0 = 0) of the sweep's cells at 0 and ``probe_kg``
    (the solver's, as its status reads it: gear, housing and every other effect), less the
    backlash's −b·sign(T_i) at each (``t0``, ``t1`` the loaded torques, zero below ``eps``).
    Arrays (grid…, n); at a linear joint the numbers mean nothing (the caller uses its own).
    """
    dal = ds["dalpha_deg"].transpose(..., "mass_kg", "link").values
    turn = dal - np.concatenate([np.zeros_like(dal[..., :1]), dal[..., :-1]], axis=-1)
    e0 = turn[..., 0, :] + play * _sign(t0, eps)
    e1 = turn[..., 1, :] + play * _sign(t1, eps)
    return _drive_angles(ds, play.shape[0]), e0, (e1 - e0) / probe_kg


def _drive_angles(ds: xr.Dataset, n: int) -> FloatArray:
    """Each pose's unloaded joint angles q_i = α_i − α_{i−1} (grid…, n), degrees, in the
    layout of the sweep's ``length_mm``."""
    import xarray as xr

    from eodarm.model.validity import drive_angles

    dims = [d for d in ds["length_mm"].dims if d != "actuator"]
    if "alpha_deg" in ds:
        alpha = ds["alpha_deg"].transpose(*dims, "link").values
    else:
        cols = xr.broadcast(*[ds[f"alpha{k + 1}"] for k in range(n)], ds["reachable"])
        alpha = np.stack([c.transpose(*dims).values for c in cols[:n]], axis=-1)
    flat = alpha.reshape(-1, n)
    q, _ = drive_angles(flat, np.zeros_like(flat))
    return np.asarray(q).reshape(alpha.shape)


def _force_limit(f0: FloatArray, s: FloatArray, fmax: FloatArray) -> FloatArray:
    """Smallest m ≥ 0 with |f0 + m·s| = fmax (0 if already beyond, inf if never)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        up = (fmax - f0) / s  # reaches +fmax, for s > 0
        down = (-fmax - f0) / s  # reaches −fmax, for s < 0
    m = np.where(s > 0, up, np.where(s < 0, down, np.inf))
    m = np.where(np.abs(f0) >= fmax, 0.0, m)
    return np.where(np.isfinite(fmax), np.maximum(m, 0.0), np.inf)


def _stroke_limit(
    ell0: FloatArray,
    f0: FloatArray,
    s: FloatArray,
    rate: FloatArray,
    play: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    eps: FloatArray | float = F_EPS,
) -> FloatArray:
    """Smallest m ≥ 0 where ℓ0 + m·rate − play·sign(f0 + m·s) leaves [lo, hi] (the sign 0
    below ``eps``)."""
    sgn0 = _sign(f0, eps)
    with np.errstate(divide="ignore", invalid="ignore"):
        m_flip = np.where(s != 0, -f0 / s, np.inf)
    m_flip = np.where(m_flip > 0, m_flip, np.inf)  # where the force changes sign
    sgn1 = np.where(np.isfinite(m_flip), np.sign(s), sgn0)
    best = np.full(ell0.shape, np.inf)
    for a, b, sg in (
        (np.zeros_like(m_flip), m_flip, sgn0),
        (m_flip, np.full_like(m_flip, np.inf), sgn1),
    ):
        start = ell0 - play * sg  # length at m = 0 of this piece's line
        at_a = start + rate * np.where(np.isfinite(a), a, 0.0)
        out_at_a = np.isfinite(a) & ((at_a < lo) | (at_a > hi))
        with np.errstate(divide="ignore", invalid="ignore"):
            to_lo = np.where(rate < 0, (lo - start) / rate, np.inf)
            to_hi = np.where(rate > 0, (hi - start) / rate, np.inf)
        hit = np.minimum(np.where(to_lo >= a, to_lo, np.inf), np.where(to_hi >= a, to_hi, np.inf))
        hit = np.where(hit < b, hit, np.inf)
        piece = np.where(out_at_a, a, hit)
        best = np.minimum(best, piece)
    return np.where(np.isnan(best), np.inf, best)


def _sign(f: FloatArray, eps: FloatArray | float = F_EPS) -> FloatArray:
    return np.where(np.abs(f) < eps, 0.0, np.sign(f))


# ---------------------------------------------------------------------------- dominant effect
def effect_contributions(
    arm: Arm,
    grid: Any,
    effects: Effect | Iterable[Effect] | None,
    mass: float,
    *,
    self_weight: bool = True,
    channel: str = "dy_mm",
    progress: bool | None = None,
    **sweep_kw: Any,
) -> xr.Dataset:
    """Who makes the sag at each pose of a grid: the sag budget's Shapley shares, per pose.

    The model is the arm file's effects, then ``effects`` (the same effect@place replacing the
    file's), as in every command. Its sag (``channel``, default ``dy_mm``) is split exactly as
    :func:`eodarm.analysis.budget.sag_budget` splits it (the same components: each actuator's
    body, then every other effect; the same rigid arm to start from), with the grid swept for
    each of the 2ⁿ sets of components. A component's contribution is its share of the sag
    taken in the direction of the sag (share × sign of the model's sag, mm): positive where it
    adds to the sag, and the contributions add up to |sag|.

    ``progress`` shows a bar over the 2ⁿ sweeps on stderr (:mod:`eodarm.progress`: None, on a
    terminal after 2 s).

    Returns
    -------
    xarray.Dataset
        ``contribution_mm`` (grid…, effect), ``share`` (grid…, effect: the contribution over
        |sag|), ``dominant`` (grid…): index along ``effect`` of the largest contribution, −1
        where a pose is not reachable or not solved; the ``effect`` coordinate holds the
        component labels; ``ok`` (reachable and solved with every set of components) and
        ``model_ok`` (the whole model's cell ok, as in the plain sweep); plus ``reachable``,
        ``effector_x_mm``, ``effector_y_mm``.
    """
    from eodarm.analysis.budget import (
        RIGID_N_PER_MM,
        bare_arm,
        components,
        rigid_bodies,
        shapley_shares,
    )
    from eodarm.model.effects import with_arm_effects
    from eodarm.progress import bar

    given = list(as_effects(effects))
    model = with_arm_effects(arm.effects, given)
    comps = components(arm, given)
    bare = bare_arm(arm)
    n = len(comps)
    kw = {**as_sweep_kwargs(grid), **sweep_kw}
    common = {"mass_kg": [float(mass)], "self_weight": self_weight, **kw}
    rigid = rigid_bodies(arm, RIGID_N_PER_MM["analytic"])
    values: dict[tuple[int, ...], FloatArray] = {}
    base: xr.Dataset | None = None
    ok: Any = None
    b = bar(2**n, "eodarm: who makes the sag", progress=progress, unit="sweep")
    for size in range(n + 1):
        for members in itertools.combinations(range(n), size):
            on: dict[str, Effect] = dict(rigid)
            for k in members:
                for e in comps[k][2]:
                    on[e.key] = e
            r = sweep(bare, effects=list(on.values()), progress=False, **common).isel(mass_kg=0)
            values[members] = np.asarray(r[channel].values, dtype=float)
            ok = r["ok"].values if ok is None else ok & r["ok"].values
            if size == n:
                base = r
            if b is not None:
                b.update(1)
    if b is not None:
        b.close()
    assert base is not None
    total = values[tuple(range(n))]
    sign = np.where(total < 0.0, -1.0, 1.0)
    c = np.moveaxis(shapley_shares(values, n), 0, -1) * sign[..., None]
    ok = ok & base["reachable"].values
    good = ok & np.isfinite(c).all(axis=-1)
    dom = np.where(good, np.argmax(np.where(np.isfinite(c), c, -np.inf), axis=-1), -1)
    dims = list(base["reachable"].dims)
    out = base[["reachable", "effector_x_mm", "effector_y_mm"]].drop_vars("mass_kg")
    out = out.assign_coords(effect=("effect", np.array([x[0] for x in comps], dtype=object)))
    out["contribution_mm"] = (
        [*dims, "effect"],
        np.where(good[..., None], c, np.nan),
        {"units": "mm", "long_name": f"Shapley share of the sag ({channel}), along the sag"},
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = c / np.abs(total)[..., None]
    out["share"] = (
        [*dims, "effect"],
        np.where(good[..., None], frac, np.nan),
        {"units": "1", "long_name": "the component's fraction of |sag|"},
    )
    out["dominant"] = (dims, dom.astype(np.int64), {"long_name": "index of the largest share"})
    out["ok"] = (dims, good, {"long_name": "reachable and solved with every set of components"})
    out["model_ok"] = (
        dims,
        base["ok"].values & base["reachable"].values,
        {"long_name": "reachable and the whole model's cell ok (as the plain sweep)"},
    )
    out.attrs.update(
        base.attrs,
        payload_kg=float(mass),
        channel=channel,
        model=model_name(model),
        components=", ".join(x[0] for x in comps),
    )
    return out


def model_name(model: Iterable[Effect]) -> str:
    """A model in one line: ``baseline + effect@place=value …`` (the arm file's effects first)."""
    return " + ".join(["baseline", *(f"{e.key}={e.value:g}" for e in model)])
