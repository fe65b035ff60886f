"""The virtual test bench: measurement files of a known arm with known hidden effects.

:func:`synth` solves the model (:func:`eodarm.solve`) with some effects *hidden* in it, adds
Gaussian noise of a stated standard deviation to every measured channel and returns
:class:`~eodarm.data.measurements.Measurements`, exactly what :func:`~eodarm.measurements.
read_measurements` would give for a real bench. Whatever a diagnosis finds in such data can
be checked against the truth. :func:`random_configs` draws well-conditioned poses to measure.

Command line (registered by :func:`add_parser`)::

    eodarm synth --arm ARM.toml [--configs K | --alpha A1,A2,A3 ...]
                 [--masses 1.5,5,6.5 | --sequence 0,1.5,5,6.5,5,1.5,0]
                 [--hidden EFFECT@PLACE=VALUE ...] [--channels dx_mm,dy_mm,dalpha,dl | all]
                 [--noise 1.0] [--sigma CHANNEL=VALUE ...] [--seed 0] [--no-self-weight]
                 [--repeats 1] [--no-sigma-columns] [-o OUT.csv]
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
import numpy.typing as npt

from eodarm.data.measurements import (
    Measurements,
    channel_family,
    channel_names,
    channel_values,
    default_sigma,
    expand_channels,
)
from eodarm.errors import EodarmError
from eodarm.model.arm import Actuator, Arm
from eodarm.model.effects import Effect, as_effects
from eodarm.model.solver import forward, solve, stroke_violations

__all__ = ["moment_arm_ratio", "random_configs", "synth"]

#: Default ranges of the absolute link angles drawn by :func:`random_configs` (degrees):
#: link 1, link 2, and every further link.
DEFAULT_RANGES: tuple[tuple[float, float], ...] = ((40.0, 130.0), (-40.0, 60.0), (-30.0, 30.0))
#: Payload masses of the seed's tests (kg), the CLI's default.
DEFAULT_MASSES = (1.5, 5.0, 6.5)


# ---------------------------------------------------------------------------- poses
def moment_arm_ratio(arm: Arm, alpha_deg: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """|h_i| / |A_i − O_i| for every actuator of N poses, (N, n), dimensionless.

    ``h_i = (A_i − O_i) × unit(A_i − B_{i−1})`` is actuator i's moment arm about its joint;
    the ratio is the sine of the angle at A_i between the link pin's radius and the actuator
    line. Near 0 the actuator passes through its joint and the pose is (nearly) singular.
    A rotary drive turns its link directly and is never singular: its column is 1.
    """
    geo = forward(arm, alpha_deg)
    o = geo["O"][:, : arm.n]
    r = geo["A"] - o
    e = geo["A"] - geo["B"]
    e = e / np.linalg.norm(e, axis=-1, keepdims=True)
    h = r[..., 0] * e[..., 1] - r[..., 1] * e[..., 0]
    rotary = np.array(arm.kinds) == "rotary"
    return np.where(rotary, 1.0, np.abs(h) / np.linalg.norm(r, axis=-1))


def random_configs(
    arm: Arm,
    k: int,
    rng: np.random.Generator | int | None = None,
    alpha_ranges: Sequence[tuple[float, float]] | None = None,
    *,
    min_moment_ratio: float = 0.2,
    max_draws: int = 200_000,
    partial: bool = False,
) -> npt.NDArray[np.float64]:
    """``k`` reachable, well-conditioned configurations (unloaded absolute angles, degrees).

    Angles are drawn uniformly in ``alpha_ranges`` and a pose is kept when

    * every actuator's moment arm about its joint is at least ``min_moment_ratio`` (20 %) of
      the distance |A_i − O_i| from the joint to its pin (:func:`moment_arm_ratio`): the
      actuator is far from passing through the joint, so forces stay moderate;
    * every pin-to-pin length lies within the arm's stroke limits, where set, and every
      rotary drive's angle q_i = α_i − α_{i−1} within its ``min_angle_deg``/``max_angle_deg``;
    * the load point is ahead of the first joint (x > O1.x).

    Parameters
    ----------
    arm : the arm.
    k : number of configurations wanted (≥ 1).
    rng : a numpy Generator, or a seed for one.
    alpha_ranges : (lo, hi) in degrees per link; default α1 ∈ [40, 130], α2 ∈ [−40, 60],
        α3… ∈ [−30, 30].
    min_moment_ratio : smallest accepted |h_i| / |A_i − O_i|.
    max_draws : poses drawn at most before giving up.
    partial : return the poses found (at least one) when fewer than ``k`` pass within
        ``max_draws`` draws, instead of refusing.

    Returns
    -------
    (k, n) array of angles, degrees, in the order they were found ((m, n), 1 ≤ m ≤ k, with
    ``partial``).

    Raises
    ------
    EodarmError
        If fewer than ``k`` poses (with ``partial``: none) pass after ``max_draws`` draws;
        the message says which condition rejected them (e.g. a stroke that the ranges never
        reach).
    """
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise EodarmError(f"random_configs: k must be an integer >= 1, got {k!r}")
    n = arm.n
    if alpha_ranges is None:
        ranges = [DEFAULT_RANGES[min(i, len(DEFAULT_RANGES) - 1)] for i in range(n)]
    else:
        ranges = [tuple(map(float, r)) for r in alpha_ranges]  # type: ignore[misc]
        if len(ranges) != n or any(len(r) != 2 for r in ranges):
            raise EodarmError(f"random_configs: need {n} (lo, hi) angle ranges, got {ranges}")
        if not all(math.isfinite(a) and math.isfinite(b) and a <= b for a, b in ranges):
            raise EodarmError(f"random_configs: bad angle ranges {ranges} (need lo <= hi)")
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    lo = np.array([r[0] for r in ranges])
    hi = np.array([r[1] for r in ranges])

    found: list[npt.NDArray[np.float64]] = []
    count = 0
    drawn = 0
    rejected = {"moment": 0, "stroke": 0, "behind": 0}
    lmin = np.full(n, np.inf)
    lmax = np.full(n, -np.inf)
    batch = max(256, 8 * k)
    while count < k and drawn < max_draws:
        m = min(batch, max_draws - drawn)
        drawn += m
        alpha = lo + (hi - lo) * gen.random((m, n))
        geo = forward(arm, alpha)
        length = geo["length_mm"]
        lmin = np.minimum(lmin, length.min(axis=0))
        lmax = np.maximum(lmax, length.max(axis=0))
        ok_moment = (moment_arm_ratio(arm, alpha) >= min_moment_ratio).all(axis=1)
        ok_stroke = (stroke_violations(arm, length) == 0).all(axis=1) & _in_drive_range(arm, alpha)
        ok_ahead = geo["O"][:, n, 0] > arm.O1[0]
        rejected["moment"] += int((~ok_moment).sum())
        rejected["stroke"] += int((~ok_stroke).sum())
        rejected["behind"] += int((~ok_ahead).sum())
        good = alpha[ok_moment & ok_stroke & ok_ahead]
        found.append(good)
        count += good.shape[0]
    if count < k and not (partial and count > 0):
        why = [
            f"moment arm < {min_moment_ratio:g}·|A−O| in {rejected['moment']}",
            f"outside the stroke or a drive's range in {rejected['stroke']}",
            f"load point behind O1 in {rejected['behind']}",
        ]
        strokes = []
        for i, act in enumerate(arm.actuators):
            if not isinstance(act, Actuator):
                continue  # a rotary drive has no stroke
            a, b = act.min_length_mm, act.max_length_mm
            if (a is not None and lmax[i] < a) or (b is not None and lmin[i] > b):
                strokes.append(
                    f"actuator {i + 1} spans {lmin[i]:.0f}–{lmax[i]:.0f} mm over these angles "
                    f"but its stroke is {a if a is not None else '-inf'}–"
                    f"{b if b is not None else 'inf'} mm"
                )
        raise EodarmError(
            f"random_configs: found {count} of {k} configurations in {drawn} draws "
            f"(angle ranges {[list(r) for r in ranges]} deg); rejected: "
            + ", ".join(why)
            + ("; " + "; ".join(strokes) if strokes else "")
        )
    return np.ascontiguousarray(np.concatenate(found)[:k])


def _in_drive_range(arm: Arm, alpha: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
    """(N,) whether every rotary drive's unloaded angle q_i lies within its range, as the
    solver's status checks it (:func:`eodarm.model.validity.out_of_angle`: within 10⁻⁹° of a
    limit is inside)."""
    from eodarm.model.validity import out_of_angle

    return ~out_of_angle(arm, alpha, np.zeros_like(alpha))


# ---------------------------------------------------------------------------- data
def synth(
    arm: Arm,
    alpha_deg: npt.ArrayLike,
    masses: npt.ArrayLike,
    hidden: Effect | Iterable[Effect] = (),
    channels: str | Iterable[str] | None = None,
    sigma: Mapping[str, float] | None = None,
    noise: float = 1.0,
    seed: int | np.random.SeedSequence | None = 0,
    self_weight: bool = True,
    configs: Sequence[str] | None = None,
    sigma_columns: bool = True,
    repeats: int = 1,
    sequence: bool = False,
) -> Measurements:
    """Synthetic measurements: the model with ``hidden`` effects, plus Gaussian noise.

    Parameters
    ----------
    arm : the arm.
    alpha_deg : (K, n) unloaded absolute angles of K configurations, degrees.
    masses : (M,) payload masses, kg. Every configuration is measured with every payload:
        K·M states, configuration-major (state ``i·M + j`` is configuration i, mass j).
    hidden : the effects present in the "real" arm, from the catalogue or user-written
        (registered with :func:`eodarm.custom_effect`); the truth is
        ``eodarm.solve(arm, alpha, mass, effects=hidden, self_weight=self_weight)``.
    channels : channels measured (:func:`~eodarm.data.measurements.expand_channels`: names,
        families ``dalpha``/``dl``, or ``"all"``); default all. The others are ``NaN``.
    sigma : standard deviation per channel (mm or degrees); a key may also be a family
        (``dx_mm``, ``dy_mm``, ``dalpha``, ``dl``), an exact channel name wins. Channels not
        given get ``default_sigma(channel) * noise``. A given sigma is used as it is.
    noise : multiple of the default noise levels (> 0); use a tiny value (e.g. 1e-9) for
        practically exact data.
    seed : seed of the noise generator. The noise of a channel does not depend on which other
        channels are measured.
    self_weight : include link and actuator weights in both states.
    configs : K labels; default ``"c1"``, ``"c2"``, ….
    sigma_columns : whether :meth:`Measurements.to_csv` writes the ``sigma_`` columns. Without
        them a reader pools σ from the repeats (with ``repeats`` ≥ 2 and enough of them), or
        else falls back to the default levels (which differ from the true ones when
        ``noise != 1``).
    repeats : how many times each state is measured (≥ 1), each time with independent noise:
        N = K·M·``repeats`` rows, the repeats of a state one after the other (row
        ``(i·M + j)·repeats + r``). With 1, the same data as without the argument.
    sequence : ``masses`` is one load sequence applied to every configuration in that order,
        from its reference (docs/diagnosis.md, "Load sequences"): a leading 0 is the reference
        itself (not written); each configuration's states get ``step`` 1, 2, … and the truth
        is :func:`eodarm.solve_sequence` (friction and gaps with memory). With ``repeats``
        the whole cycle is repeated, each time under its own label (``c1``, ``c1#2``, …).

    Returns
    -------
    Measurements
        ``sigma`` holds the standard deviation of the noise actually added (source
        ``"<synth>"``).

    Raises
    ------
    EodarmError
        On bad masses, channels, sigmas, noise or labels; the solver's own errors (singular
        pose, a triangle that cannot close, a bad effect) pass through.
    """
    n = arm.n
    alpha = np.asarray(alpha_deg, dtype=float)
    if alpha.ndim == 1 and alpha.shape[0] == n:
        alpha = alpha[None, :]
    if alpha.ndim != 2 or alpha.shape[1] != n or alpha.shape[0] < 1:
        raise EodarmError(f"synth: alpha_deg must be (K, {n}), got shape {alpha.shape}")
    mass = np.atleast_1d(np.asarray(masses, dtype=float))
    if mass.ndim != 1 or mass.size < 1:
        raise EodarmError(f"synth: masses must be a list of payload masses, got {masses!r}")
    if not (np.isfinite(mass).all() and (mass >= 0).all()):
        raise EodarmError(f"synth: payload masses must be finite and >= 0, got {mass.tolist()}")
    kc, mm = alpha.shape[0], mass.shape[0]
    labels = [f"c{i + 1}" for i in range(kc)] if configs is None else [str(c) for c in configs]
    if len(labels) != kc:
        raise EodarmError(f"synth: {len(labels)} config labels for {kc} configurations")
    if any(not lb.strip() for lb in labels):
        raise EodarmError("synth: config labels must not be empty")
    from eodarm.model.kinds import integer, real_number

    noise = real_number(noise, "synth: noise")
    if not (math.isfinite(noise) and noise > 0):
        raise EodarmError(f"synth: noise must be finite and > 0, got {noise!r}")
    rep = integer(repeats, "synth: repeats", 1, 10**6)
    chosen = expand_channels(channels, n, arm.kinds)
    every = channel_names(n)
    sig = _sigmas(sigma or {}, every, noise)

    if sequence:
        return _synth_sequence(
            arm,
            alpha,
            mass,
            hidden,
            chosen,
            every,
            sig,
            seed,
            self_weight,
            labels,
            rep,
            sigma_columns,
        )
    rows_alpha = np.repeat(alpha, mm, axis=0)
    rows_mass = np.tile(mass, kc)
    truth = channel_values(
        solve(
            arm,
            rows_alpha,
            rows_mass,
            effects=as_effects(hidden),
            self_weight=self_weight,
            strict=True,
        ),
        every,
    )
    rows_alpha = np.repeat(rows_alpha, rep, axis=0)
    rows_mass = np.repeat(rows_mass, rep)
    truth = np.repeat(truth, rep, axis=0)
    gen = np.random.default_rng(seed)
    z = gen.standard_normal(truth.shape)  # drawn for every channel: selection-independent
    values = truth + z * sig
    sigma_arr = np.broadcast_to(sig, truth.shape).copy()
    off = np.array([c not in chosen for c in every])
    values[:, off] = np.nan
    sigma_arr[:, off] = np.nan
    return Measurements(
        source="<synth>",
        n=n,
        config=np.repeat(np.array(labels, dtype=str), mm * rep),
        alpha_deg=rows_alpha,
        mass_kg=rows_mass,
        channels=tuple(every),
        values=values,
        sigma=sigma_arr,
        line=np.arange(2, kc * mm * rep + 2),
        sigma_default=np.zeros(truth.shape, dtype=bool),
        sigma_columns=sigma_columns,
    )


def _synth_sequence(
    arm: Arm,
    alpha: npt.NDArray[np.float64],
    mass: npt.NDArray[np.float64],
    hidden: Effect | Iterable[Effect],
    chosen: Sequence[str],
    every: list[str],
    sig: npt.NDArray[np.float64],
    seed: int | np.random.SeedSequence | None,
    self_weight: bool,
    labels: list[str],
    rep: int,
    sigma_columns: bool,
) -> Measurements:
    """:func:`synth` of one load sequence per configuration (and per repeat)."""
    from eodarm.model.solver import solve_sequence

    states = mass[1:] if mass[0] == 0 and mass.size > 1 else mass
    s = states.size
    out = solve_sequence(
        arm, alpha, states, effects=as_effects(hidden), self_weight=self_weight, strict=True
    )
    kc = alpha.shape[0]
    truth = np.concatenate(
        [out["dx_mm"][..., None], out["dy_mm"][..., None], out["dalpha_deg"], out["dl_mm"]],
        axis=-1,
    )  # (K, S, C) in channel order
    truth = np.repeat(truth, rep, axis=0).reshape(kc * rep * s, len(every))
    names = [lb if r == 0 else f"{lb}#{r + 1}" for lb in labels for r in range(rep)]
    gen = np.random.default_rng(seed)
    z = gen.standard_normal(truth.shape)
    values = truth + z * sig
    sigma_arr = np.broadcast_to(sig, truth.shape).copy()
    off = np.array([c not in chosen for c in every])
    values[:, off] = np.nan
    sigma_arr[:, off] = np.nan
    rows = truth.shape[0]
    return Measurements(
        source="<synth>",
        n=arm.n,
        config=np.repeat(np.array(names, dtype=str), s),
        alpha_deg=np.repeat(alpha, rep * s, axis=0),
        mass_kg=np.tile(states, kc * rep),
        channels=tuple(every),
        values=values,
        sigma=sigma_arr,
        line=np.arange(2, rows + 2),
        sigma_default=np.zeros(truth.shape, dtype=bool),
        sigma_columns=sigma_columns,
        step=np.tile(np.arange(1, s + 1), kc * rep),
    )


def _sigmas(given: Mapping[str, float], every: list[str], noise: float) -> np.ndarray:
    """Per-channel sigma from exact names, then families, then the scaled defaults."""
    fam_of = {"dx": "dx_mm", "dy": "dy_mm", "dalpha": "dalpha_deg", "dl": "dl_mm"}
    exact: dict[str, float] = {}
    family: dict[str, float] = {}
    for key, val in given.items():
        try:
            s = float(val)
        except (TypeError, ValueError):
            raise EodarmError(f"sigma for '{key}': {val!r} is not a number") from None
        if not (math.isfinite(s) and s > 0):
            raise EodarmError(f"sigma for '{key}' must be finite and > 0, got {val!r}")
        if key in every:
            exact[key] = s
        elif key in fam_of or key in fam_of.values():
            family[fam_of.get(key, key)] = s
        else:
            raise EodarmError(
                f"sigma for '{key}': not a channel of this arm ({', '.join(every)}) "
                "nor a family (dx_mm, dy_mm, dalpha, dl)"
            )
    out = []
    for ch in every:
        fam = channel_family(ch)
        out.append(exact.get(ch, family.get(fam, default_sigma(ch) * noise)))
    return np.array(out)
