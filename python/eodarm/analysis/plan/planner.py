"""``plan``: choose K configurations so that the missing effect can be named (docs/plan.md).

1. The pool: up to ``pool`` reachable configurations within the angle ranges, each with every
   planned state ``ok`` under the baseline and every candidate at its size
   (:mod:`~eodarm.analysis.plan.pool`); the candidates' sizes from the arm itself
   (:mod:`~eodarm.analysis.plan.sizes`).
2. Each candidate's signature over the whole pool, once (and over a campaign already measured,
   ``fixed``), reduced to per-configuration sums under the planned channels and noise
   (:mod:`~eodarm.analysis.plan.signatures`).
3. The pairs that the whole pool cannot separate are named apart, with the channel that would
   separate them; the others are the objective's (:mod:`~eodarm.analysis.plan.selection`).
4. Greedy choice and exchanges; the same figures for random plans (the median of 20 draws).
5. The plan's separations where a friction or a user-written effect imitates another are
   refitted on the exact model (:func:`eodarm.analysis.fit.fit`), from the sampled optimum.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.plan.candidates import (
    Candidate,
    CandidateSpec,
    candidate_specs,
    parse_candidates,
)
from eodarm.analysis.plan.pool import (
    DEFAULT_CYCLE,
    Payloads,
    angle_ranges,
    combined,
    draw_pool,
    reachable,
    states_of,
)
from eodarm.analysis.plan.result import Plan
from eodarm.analysis.plan.selection import Objective, exchange, greedy, random_plans
from eodarm.analysis.plan.separation import (
    MAX_REL_STDERR,
    SEPARABLE,
    directed,
    fitted_curve_value,
    rel_stderr,
    separations,
)
from eodarm.analysis.plan.signatures import Reduced, Responses, StateSet, reduce
from eodarm.analysis.plan.sizes import size_candidates
from eodarm.data.channels import channel_names, default_sigma, expand_channels
from eodarm.data.measurements import Measurements
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm

__all__ = ["DEFAULT_POOL", "RANDOM_DRAWS", "REFITS", "plan"]

FloatArray = npt.NDArray[np.float64]

#: Reachable configurations drawn for the pool.
DEFAULT_POOL = 500
#: Random plans drawn for the comparison (their median is reported).
RANDOM_DRAWS = 20
#: The weakest imitations by a curve refitted on the exact model (and every one below twice
#: the separable χ²).
REFITS = 12


def plan(
    arm: Arm,
    configs: int,
    masses_kg: Sequence[float] = DEFAULT_CYCLE,
    sequence: bool = True,
    channels: str | Sequence[str] | None = None,
    sigma: Mapping[str, float] | None = None,
    candidates: Sequence[CandidateSpec | str] | None = None,
    ranges: Mapping[int, tuple[float, float]] | None = None,
    fixed: Measurements | None = None,
    seed: int = 0,
    pool: int = DEFAULT_POOL,
    self_weight: bool = True,
    refine: bool = True,
    progress: Any = None,
) -> Plan:
    """Choose ``configs`` configurations that tell the candidates apart (module notes).

    Parameters
    ----------
    arm : the arm.
    configs : K, the number of configurations to plan (≥ 1, at most the reachable pool).
    masses_kg, sequence : the payloads of every configuration: a load cycle from a zeroed
        reference (``sequence``, a leading 0 the reference) or single loadings.
    channels : the channels to measure (names or families, ``"all"``); default every channel
        of the arm, or with ``fixed`` those measured in it.
    sigma : noise per channel or family (mm or deg); default the default noise levels, or
        with ``fixed`` the noise of its channels.
    candidates : the candidates, ``"EFFECT@PLACE[=VALUE]"`` (VALUE in the parameter's unit)
        or :class:`~eodarm.analysis.plan.CandidateSpec`; default every one ``diagnose``
        ranks, each at its typical size.
    ranges : 1-based link → (lo, hi) degrees, the angles the configurations are drawn in.
    fixed : a campaign already measured: its states count in, K more are added.
    seed : the random pool and the random plans.
    pool : reachable configurations drawn.
    refine : refit on the exact model the separations where a friction or a user-written
        effect imitates another (the reported numbers; the choice uses the sampled ones).
    progress : ``step(name)`` called before each stage (a progress bar), or None.

    Raises
    ------
    EodarmError
        One line: K of 0 or more than the reachable pool, a candidate the arm cannot hold
        at its size, an impossible range, a fixed campaign of another arm.
    """
    from eodarm.model.kinds import integer

    step = progress or (lambda name: None)
    k = integer(configs, "--configs", 1, 10**6)
    n_pool = integer(pool, "--pool", 1, 10**6)
    payloads = Payloads.of(masses_kg, sequence)
    if fixed is not None and fixed.n != arm.n:
        raise EodarmError(
            f"--fixed {fixed.source}: its configurations have {fixed.n} angles, the arm "
            f"'{arm.name}' has {arm.n} links (a campaign of another arm)"
        )
    chans, sig = _channels(arm, channels, sigma, fixed)
    if candidates is None:
        specs = candidate_specs(arm, self_weight)
    else:
        text = [c for c in candidates if isinstance(c, str)]
        specs = [c for c in candidates if not isinstance(c, str)]
        specs += parse_candidates(text, arm) if text else []
    for spec in specs:
        spec.slot.index(arm.n)
    rng = np.random.default_rng(seed)

    step("pool")
    reach, cands = _reachable_pool(
        arm, k, n_pool, ranges, rng, payloads, specs, self_weight, lambda: step("sizes")
    )

    step("signatures")
    s_count = payloads.states.size
    pool_meas = states_of(arm, reach, payloads)
    pool_states = StateSet(arm, pool_meas, self_weight)
    pool_resp = Responses.compute(pool_states, cands)
    fixed_states = StateSet(arm, fixed, self_weight) if fixed is not None else None
    fixed_resp = Responses.compute(fixed_states, cands) if fixed_states is not None else None
    pool_resp, fixed_resp = _solvable(pool_resp, fixed_resp)
    cands = pool_resp.candidates
    weight = _weights(arm, chans, sig, pool_meas.n_rows)
    seen = np.array(
        [float(((pool_resp.signature(i) * weight) ** 2).sum()) for i in range(len(cands))]
    )
    unseen = [c for c, x in zip(cands, seen, strict=True) if not x >= SEPARABLE]
    if unseen:
        keep = [i for i, x in enumerate(seen) if x >= SEPARABLE]
        if len(keep) < 2:
            raise EodarmError(
                "no two candidates show in the planned channels at any reachable configuration "
                f"({', '.join(c.spec for c in unseen)}): change --channels, --range or the sizes"
            )
        cands = [cands[i] for i in keep]
        pool_resp = Responses(cands, [pool_resp.curves[i] for i in keep])
        if fixed_resp is not None:
            fixed_resp = Responses(cands, [fixed_resp.curves[i] for i in keep])
    per = reduce(pool_resp, weight, np.arange(reach.shape[0]) * s_count)
    base, fixed_weight = _fixed_sums(fixed, fixed_resp, per)

    step("choosing")
    every = separations(base + per.total(), cands)[0]
    iu, ju = np.triu_indices(len(cands), 1)
    separable = every[iu, ju] >= SEPARABLE
    # a candidate that the whole pool does not determine cannot be determined by any plan
    # from it: it is said, and left out of the objective's first term
    determinable = np.flatnonzero(rel_stderr(base + per.total(), cands)[0] <= MAX_REL_STDERR)
    objective = Objective(cands, iu[separable], ju[separable], determinable)
    chosen = greedy(per, base, k, objective)
    chosen, _ = exchange(per, base, chosen, objective)
    tot = base + per.total(np.array(chosen))
    weak, worst, draws = random_plans(per, base, k, objective, rng, RANDOM_DRAWS)
    middle = draws[int(np.argsort(weak, kind="stable")[len(weak) // 2])]  # random_median's

    imitated = directed(tot, cands)[0]
    labels = _labels(k, fixed)
    configs_arr = reach[np.array(chosen)]
    rows = _rows_of(chosen, s_count)
    planned = _Part(
        states_of(arm, configs_arr, payloads, labels),
        pool_states.y0[rows],
        pool_resp.rows(rows),
        weight[rows],
    )
    fixed_part = None
    if fixed is not None:
        assert fixed_resp is not None and fixed_states is not None and fixed_weight is not None
        fixed_part = _Part(fixed, fixed_states.y0, fixed_resp, fixed_weight)
    if refine:
        step("refits")
        parts = [planned] if fixed_part is None else [planned, fixed_part]
        imitated = _refine(arm, cands, tot, imitated, parts, self_weight)
    sep = np.minimum(imitated, imitated.T)
    np.fill_diagonal(sep, np.inf)
    step("inseparable")
    whole = _Part(pool_meas, pool_states.y0, pool_resp, weight)
    named = [
        (
            int(a),
            int(b),
            _channel_that_separates(arm, whole, fixed_part, int(a), int(b), rows, chans, sig),
        )
        for a, b in zip(iu[~separable], ju[~separable], strict=True)
    ]
    before_sep = before_rel = None
    if fixed is not None:
        before_sep = separations(base, cands)[0]
        before_rel = rel_stderr(base, cands)[0]
    return Plan(
        arm=arm,
        configs=configs_arr,
        labels=labels,
        payloads=payloads,
        channels=chans,
        sigma={ch: sig[ch] for ch in chans},
        candidates=cands,
        rel_stderr=rel_stderr(tot, cands)[0],
        separation=sep,
        imitated=imitated,
        inseparable=named,
        random_weakest=weak,
        random_max_rel=worst,
        fixed=_fixed_configs(fixed, arm.n),
        pool=reach,
        random_separation=separations(base + per.total(middle), cands)[0],
        before_separation=before_sep,
        before_rel_stderr=before_rel,
        unseen=unseen,
    )


# ---------------------------------------------------------------------------- helpers
def _channels(
    arm: Arm,
    channels: str | Sequence[str] | None,
    sigma: Mapping[str, float] | None,
    fixed: Measurements | None,
) -> tuple[list[str], dict[str, float]]:
    """The planned channels and the noise of every channel of the arm (given, else the fixed
    campaign's, else the default level)."""
    from eodarm.analysis.synth import _sigmas

    every = channel_names(arm.n)
    if channels is None:
        chans = (
            list(fixed.measured_channels)
            if fixed is not None
            else expand_channels(None, arm.n, arm.kinds)
        )
    else:
        chans = expand_channels(channels, arm.n, arm.kinds)
    given = _sigmas(dict(sigma or {}), every, math.nan)  # NaN where not given
    sig: dict[str, float] = {}
    for j, ch in enumerate(every):
        s = float(given[j])
        if not math.isfinite(s) and fixed is not None and ch in fixed.measured_channels:
            rec = fixed.noise.get(ch)
            s = float(rec.sigma) if rec is not None and rec.sigma is not None else math.nan
            if not math.isfinite(s):
                s = float(np.nanmedian(fixed.sigma[:, fixed.index(ch)]))
        sig[ch] = s if math.isfinite(s) else default_sigma(ch)
    return chans, sig


def _weights(arm: Arm, chans: Sequence[str], sig: Mapping[str, float], rows: int) -> FloatArray:
    """(rows, C) 1/σ of the planned channels, 0 for the others."""
    w = np.array([1.0 / sig[ch] if ch in chans else 0.0 for ch in channel_names(arm.n)])
    return np.tile(w, (rows, 1))


def _reachable_pool(
    arm: Arm,
    k: int,
    n_pool: int,
    ranges: Mapping[int, tuple[float, float]] | None,
    rng: np.random.Generator,
    payloads: Payloads,
    specs: Sequence[CandidateSpec],
    self_weight: bool,
    sizing: Any,
) -> tuple[FloatArray, list[Candidate]]:
    """The pool's configurations where every planned state is ``ok`` under the baseline and
    every candidate at its size, and the candidates at their sizes (``sizing()`` is called
    before the sizes are found).

    Raises
    ------
    EodarmError
        One line: fewer than K reachable configurations, or a candidate the arm cannot hold.
    """
    drawn = draw_pool(arm, n_pool, angle_ranges(arm, ranges), rng)
    ok, _ = reachable(arm, drawn, payloads, [], self_weight)
    if not ok.any():
        raise EodarmError(
            f"none of the {drawn.shape[0]} configurations drawn within the ranges keeps every "
            "planned state within the model's validity under the baseline (docs/model.md §7): "
            "change --range or the payloads"
        )
    base_pool = drawn[ok]
    if k > base_pool.shape[0]:
        raise EodarmError(
            f"--configs {k}: only {base_pool.shape[0]} reachable configurations were found (of "
            f"{drawn.shape[0]} drawn; --pool, --range); plan fewer"
        )
    sizing()
    cands = size_candidates(arm, specs, base_pool, payloads, self_weight)
    ok, under = reachable(
        arm, base_pool, payloads, [c.slot.effect(c.value) for c in cands], self_weight
    )
    for c in cands:
        held = int(under[c.spec].sum())
        if held < k:
            raise EodarmError(
                f"candidate {c.spec} = {c.value:.4g} {c.slot.kind.unit}: the arm cannot hold "
                f"the planned payloads with it at {base_pool.shape[0] - held} of "
                f"{base_pool.shape[0]} reachable configurations (their states leave the "
                "model's validity, docs/model.md §7); give a smaller size"
            )
    reach = base_pool[ok]
    if k > reach.shape[0]:
        raise EodarmError(
            f"--configs {k}: only {reach.shape[0]} of the {base_pool.shape[0]} reachable "
            "configurations keep every state within the model's validity under every "
            "candidate at its size (docs/model.md §7); plan fewer, or give smaller sizes"
        )
    return reach, cands


def _fixed_sums(
    fixed: Measurements | None, resp: Responses | None, like: Reduced
) -> tuple[Reduced, FloatArray | None]:
    """A campaign already measured: its sums (its own cells and σ) and its weights."""
    if fixed is None or resp is None:
        return like.zeros_like(), None
    weight = np.where(fixed.measured, 1.0 / np.where(fixed.measured, fixed.sigma, 1.0), 0.0)
    return reduce(resp, weight, np.array([0])), weight


def _solvable(pool: Responses, fixed: Responses | None) -> tuple[Responses, Responses | None]:
    """The responses with each curve cut before its first sample that some state cannot
    solve (a curve is fitted within the range where it solves everywhere).

    Raises
    ------
    EodarmError
        When that leaves a curve without the samples beside its size (its slope).
    """
    keep = pool.solvable()
    if fixed is not None:
        keep = [min(a, b) for a, b in zip(keep, fixed.solvable(), strict=True)]
    for c, k in zip(pool.candidates, keep, strict=True):
        if k <= (c.at_size + 1 if c.curve else 1):
            raise EodarmError(
                f"candidate {c.spec} = {c.value:.4g} {c.slot.kind.unit}: some states cannot be "
                "solved with it near its size; give a smaller size"
            )
    return pool.truncated(keep), (fixed.truncated(keep) if fixed is not None else None)


def _labels(k: int, fixed: Measurements | None) -> list[str]:
    """``c1`` … ``cK``, skipping the labels of the fixed campaign."""
    taken = set(fixed.configs) if fixed is not None else set()
    out: list[str] = []
    i = 1
    while len(out) < k:
        if f"c{i}" not in taken:
            out.append(f"c{i}")
        i += 1
    return out


def _fixed_configs(fixed: Measurements | None, n: int) -> FloatArray:
    """(F, n) the angles of each configuration of the fixed campaign (each label once)."""
    if fixed is None:
        return np.zeros((0, n))
    first = [int(np.flatnonzero(fixed.config == c)[0]) for c in fixed.configs]
    return np.asarray(fixed.alpha_deg[first], dtype=float)


def _rows_of(chosen: Sequence[int], s_count: int) -> npt.NDArray[np.intp]:
    """The pool's rows (states) of the chosen configurations, in order."""
    return np.concatenate([np.arange(c * s_count, (c + 1) * s_count) for c in chosen])


@dataclass
class _Part:
    """One set of measured states of the final plan: its states, baseline channels, the
    candidates' responses there and the weights (1/σ, 0 where not measured)."""

    meas: Measurements
    y0: FloatArray
    resp: Responses
    weight: FloatArray


def _refine(
    arm: Arm,
    cands: Sequence[Candidate],
    tot: Reduced,
    imitated: FloatArray,
    parts: Sequence[_Part],
    self_weight: bool,
) -> FloatArray:
    """``imitated`` with the weakest χ²(a → b) where b is a curve (a friction, a user-written
    effect) refitted on the exact model (:func:`eodarm.analysis.fit.fit`), from the sampled
    optimum: the :data:`REFITS` weakest and every one below twice the separable χ². A refit
    can only lower it. (Those decide whether a pair is separable and which is the weakest;
    the sampled fit of the others agrees with the refit to about 1 %, docs/plan.md.)"""
    from eodarm.analysis.fit import FitWarning, Problem, fit

    curves = [i for i, c in enumerate(cands) if c.curve]
    pairs = sorted(
        (float(imitated[a, b]), a, b) for a in range(len(cands)) for b in curves if a != b
    )
    chosen = {(a, b) for k, (x, a, b) in enumerate(pairs) if k < REFITS or x < 2 * SEPARABLE}
    out = imitated.copy()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        for a in range(len(cands)):
            todo = [b for b in curves if (a, b) in chosen]
            if not todo:
                continue
            data = [p.y0 + p.resp.signature(a) for p in parts]
            meas = combined([p.meas for p in parts], data, [p.weight for p in parts])
            prob = Problem(arm, meas, self_weight)
            for b in todo:
                cb = cands[b]
                t0 = fitted_curve_value(tot, cands, a, b)
                try:
                    res = fit(arm, meas, [cb.slot], problem=prob, start=[cb.neutral + t0])
                except EodarmError:  # a start the model cannot solve: keep the sampled value
                    continue
                out[a, b] = min(out[a, b], max(float(res.chi2), 0.0))
    return out


def _channel_that_separates(
    arm: Arm,
    pool: _Part,
    fixed: _Part | None,
    a: int,
    b: int,
    rows: npt.NDArray[np.intp],
    chans: Sequence[str],
    sig: Mapping[str, float],
) -> str | None:
    """The channel not planned that, added, separates candidates a and b best: at the planned
    configurations if it separates them there, else anywhere in the pool; None if none."""
    sub = Responses(
        [pool.resp.candidates[a], pool.resp.candidates[b]],
        [pool.resp.curves[a], pool.resp.curves[b]],
    )
    base = None
    if fixed is not None:
        fsub = Responses(
            [sub.candidates[0], sub.candidates[1]], [fixed.resp.curves[a], fixed.resp.curves[b]]
        )
        base = reduce(fsub, fixed.weight, np.array([0]))
    every = channel_names(arm.n)
    others = [ch for ch in every if ch not in chans]
    best: tuple[float, str] | None = None
    for where in (rows, np.arange(pool.y0.shape[0])):
        for ch in others:
            w = _weights(arm, [*chans, ch], sig, where.size)
            tot = reduce(sub.rows(where), w, np.array([0]))
            if base is not None:
                tot = tot + base
            s = float(separations(tot, sub.candidates)[0, 0, 1])
            if best is None or s > best[0]:
                best = (s, ch)
        if best is not None and best[0] >= SEPARABLE:
            return best[1]
    return None
