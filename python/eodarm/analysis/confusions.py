"""What the data cannot tell apart, and the measurement that would (docs/diagnosis.md,
"Confusions and the next measurement").

* :func:`confusions` fills each ranked candidate's ``confused_with``: the candidates that
  reproduce its fitted contribution, added alone, within the noise;
* :func:`alternatives`: the same question asked of each member of the suggested set, with
  the set's other members in the model and at the value the set was fitted with: the
  candidates that would explain the data as well in its place (``Diagnosis.alternatives``);
* :func:`advice`: for each confused pair (the leading candidate's, and every suggested
  effect's alternatives), the unmeasured channel and the pose that separate them best, and
  for frictions what separates them in words (:func:`friction_advice`).

Every test of confusion is made on the whitened, linearised columns of the diagnosis
(Jacobian at the baseline), with the columns already in the model projected out: candidate B
imitates A's contribution ``v`` when B's best bounded multiple leaves less than χ²₁(95 %) =
3.84 and less than a tenth of ``v``'s χ² unexplained, while ``v`` itself is detectable.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.fit import FitResult, Problem, fit
from eodarm.data.measurements import Measurements, default_sigma
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Slot

__all__ = [
    "CONFUSION_CHI2",
    "advice",
    "alternatives",
    "confusions",
    "friction_advice",
    "separated_by",
]

CONFUSION_CHI2 = 3.841458820694124  # 95 % point of χ² with 1 dof

FloatArray = npt.NDArray[np.float64]


def _projector(basis: FloatArray) -> Callable[[FloatArray], FloatArray]:
    """x ↦ x with the span of ``basis``'s columns removed (identity for no column)."""
    if not basis.shape[1]:
        return lambda x: x
    q, _ = np.linalg.qr(basis)
    return lambda x: x - q @ (q.T @ x)


def _imitates(v: FloatArray, vv: float, col: FloatArray, lo: float, hi: float) -> bool:
    """Whether ``coef · col`` with ``lo ≤ coef ≤ hi`` reproduces ``v`` within the noise."""
    cc = float(col @ col)
    if cc == 0:
        return False
    cv = float(col @ v)
    coef = min(max(cv / cc, lo), hi)
    left = max(vv - 2.0 * coef * cv + coef * coef * cc, 0.0)  # never below 0 by rounding
    return left < CONFUSION_CHI2 and left < 0.1 * vv


def confusions(
    ranking: list[Any],
    cands: list[Slot],
    am: FloatArray,
    ac: FloatArray,
    cnorm: FloatArray,
    prob: Problem,
    detectable: float,
) -> None:
    """Fill ``confused_with`` of each :class:`~eodarm.analysis.diagnose.Candidate` of
    ``ranking``: B reproduces A's significant contribution within the noise.

    A's contribution (whitened, the model's own columns ``am`` projected out) must itself be
    significant (χ² above ``detectable``), and B's best imitation must leave less than
    χ²₁(95 %) of it and less than a tenth of it unexplained; B's exact refit (its ranking
    fit) may not differ from A's by more than that either.
    """
    if am.shape[1]:
        q, _ = np.linalg.qr(am)
        ac = ac - q @ (q.T @ ac)
    index = {s.spec: j for j, s in enumerate(cands)}
    # Every quantity below is a product of two columns: from their Gram matrix (one pass over
    # the values, K² numbers), not column by column over the whole file for each pair.
    gram = ac.T @ ac
    scale = np.zeros(len(cands))  # contribution of candidate j = scale[j] · ac[:, j]
    for cand in ranking:
        j = index[cand.slot.spec]
        scale[j] = (cand.fit.theta[-1] - prob.neutral(cand.slot)) * cnorm[j]
    for cand in ranking:
        j = index[cand.slot.spec]
        s = scale[j]
        vv = float(s * s * gram[j, j])
        if vv <= detectable:
            continue
        out = []
        for other in ranking:
            i = index[other.slot.spec]
            if i == j:
                continue
            cc = float(gram[i, i])
            if cc == 0:
                continue
            lo_i = (prob.bounds(other.slot)[0] - prob.neutral(other.slot)) * cnorm[i]
            cv = float(s * gram[i, j])  # col · v
            coef = max(cv / cc, lo_i)
            # |v − coef·col|², never below 0 by rounding
            left = max(vv - 2.0 * coef * cv + coef * coef * cc, 0.0)
            # ... and the exact refits agree: a response far from linear (a friction that moves
            # a backlash's side) can separate what the linearised columns do not
            apart = abs(other.fit.chi2 - cand.fit.chi2) > max(CONFUSION_CHI2, 0.1 * vv)
            if left < CONFUSION_CHI2 and left < 0.1 * vv and not apart:
                out.append(other.slot.spec)
        cand.confused_with = out


def alternatives(
    arm: Arm,
    meas: Measurements,
    found: FitResult,
    m: int,
    cands: list[Slot],
    an: FloatArray,
    norms: FloatArray,
    prob: Problem,
    detectable: float,
) -> tuple[dict[str, list[str]], dict[tuple[str, str], FitResult]]:
    """For each member of the suggested set ``found`` (the model's ``m`` slots first), the
    candidates the data cannot tell apart from it, with the set's other members present.

    A candidate is screened as in :func:`confusions` (it imitates the member's contribution
    at the set's fitted value, the model's and the other members' columns projected out) and
    confirmed by the exact refit of the set with the candidate in the member's place: its χ²
    must be within χ²₁(95 %) of the set's. Returns ``{member spec: [candidate specs]}``
    (every member a key, best alternative first) and the confirming refits by
    ``(member, candidate)``.
    """
    members = found.slots[m:]
    keys = {s.key for s in found.slots}
    index = {s.spec: j for j, s in enumerate(cands)}
    out: dict[str, list[str]] = {}
    refits: dict[tuple[str, str], FitResult] = {}
    for i, s in enumerate(members):
        out[s.spec] = []
        j = index.get(s.spec)
        if j is None:
            continue
        others = [m + index[o.spec] for o in members if o is not s and o.spec in index]
        proj = _projector(an[:, [*range(m), *others]])
        v = (float(found.theta[m + i]) - prob.neutral(s)) * norms[m + j] * proj(an[:, m + j])
        vv = float(v @ v)
        if vv <= detectable:
            continue
        found_alt: list[tuple[float, str]] = []
        for c, slot in enumerate(cands):
            if c == j or slot.key in keys:
                continue
            lo, hi = prob.bounds(slot)
            neutral = prob.neutral(slot)
            col = proj(an[:, m + c])
            scale = norms[m + c]
            if not _imitates(v, vv, col, (lo - neutral) * scale, (hi - neutral) * scale):
                continue
            cc = float(col @ col)
            coef = float(col @ v) / cc
            start = np.array(found.theta, dtype=float)
            start[m + i] = min(max(neutral + coef / scale, lo), hi)
            slots = [*found.slots[: m + i], slot, *found.slots[m + i + 1 :]]
            try:
                res = fit(arm, meas, slots, problem=prob, start=start)
            except (EodarmError, ValueError):
                continue
            if res.chi2 - found.chi2 < CONFUSION_CHI2:
                found_alt.append((res.chi2, slot.spec))
                refits[(s.spec, slot.spec)] = res
        out[s.spec] = [spec for _, spec in sorted(found_alt)]
    return out, refits


def advice(
    arm: Arm, meas: Measurements, diag: Any, self_weight: bool, kw: Mapping[str, Any]
) -> list[dict[str, Any]]:
    """For a :class:`~eodarm.analysis.diagnose.Diagnosis` ``diag``: the leading candidate's
    confusions and every suggested effect's alternatives, the unmeasured channel and the pose
    that separate each pair most, and the friction advice.

    Each entry: ``pair`` (two specs), ``channel`` (``{"channel", "chi2_separation"}`` or
    None), ``pose`` (``{"alpha_deg", "mass_kg", "chi2_separation"}`` or None), ``memory``
    (words, frictions only) and ``suggested`` (True when the pair is a suggested effect and
    its alternative: the two models compared are the suggested set and the set with the
    alternative in its place).
    """
    from eodarm.analysis.synth import random_configs

    prob = diag.baseline.problem
    model = list(zip(diag.model, diag.baseline.theta, strict=True))
    pairs: list[tuple[str, str, list[tuple[Slot, float]], list[tuple[Slot, float]], bool]] = []
    if diag.ranking and diag.ranking[0].confused_with:
        top = diag.ranking[0]
        for other_key in top.confused_with[:3]:
            other = next(c for c in diag.ranking if c.slot.spec == other_key)
            pairs.append(
                (
                    top.slot.spec,
                    other.slot.spec,
                    [*model, (top.slot, float(top.fit.theta[-1]))],
                    [*model, (other.slot, float(other.fit.theta[-1]))],
                    False,
                )
            )
    sugg = diag.suggested_fit
    for member, alts in diag.alternatives.items():
        for alt in alts[:3]:
            refit = diag.alternative_fits.get((member, alt))
            if sugg is None or refit is None:
                continue
            pair = (member, alt)
            done = next((p for p in pairs if {p[0], p[1]} == set(pair)), None)
            if done is not None:
                pairs.remove(done)  # compared in the set's context instead
            pairs.append(
                (
                    member,
                    alt,
                    list(zip(sugg.slots, sugg.theta.tolist(), strict=True)),
                    list(zip(refit.slots, refit.theta.tolist(), strict=True)),
                    True,
                )
            )
    if not pairs:
        return []
    rows_all = np.arange(meas.n_rows)
    measured = set(meas.measured_channels)
    rng = np.random.default_rng(0)
    lo = meas.alpha_deg.min(axis=0) - 15.0
    hi = meas.alpha_deg.max(axis=0) + 15.0
    try:
        poses = random_configs(arm, 400, rng, alpha_ranges=list(zip(lo, hi, strict=True)))
    except EodarmError:
        poses = np.zeros((0, arm.n))
    mass = float(np.max(meas.mass_kg))
    sig = np.array([default_sigma(ch) for ch in meas.channels])
    sub = _problem_at(arm, poses, mass, self_weight, kw) if len(poses) else None
    slots = {s.spec: s for s in [*(c.slot for c in diag.ranking), *diag.suggested]}
    out = []
    for a_key, b_key, model_a, model_b, suggested in pairs:
        ya, _ = prob.evaluate(model_a, rows=rows_all)
        yb, _ = prob.evaluate(model_b, rows=rows_all)
        sep = (((ya - yb) / sig) ** 2).sum(axis=0)
        unmeasured = [c for c, ch in enumerate(meas.channels) if ch not in measured]
        channel = None
        if unmeasured:
            c = max(unmeasured, key=lambda c: sep[c])
            channel = {"channel": meas.channels[c], "chi2_separation": float(sep[c])}
        pose = None
        if sub is not None:
            pa, _ = sub.evaluate(model_a, nan_on_failure=True)
            pb, _ = sub.evaluate(model_b, nan_on_failure=True)
            cols = [c for c, ch in enumerate(meas.channels) if ch in measured]
            score = (((pa - pb)[:, cols] / sig[cols]) ** 2).sum(axis=1)
            score[~np.isfinite(score)] = -1.0  # poses where either model bottoms out
            i = int(np.argmax(score))
            pose = {
                "alpha_deg": [float(x) for x in poses[i]],
                "mass_kg": mass,
                "chi2_separation": float(score[i]),
            }
        entry: dict[str, Any] = {"pair": [a_key, b_key], "channel": channel, "pose": pose}
        memory = friction_advice(slots[a_key], slots[b_key], meas.has_sequences)
        if memory:
            entry["memory"] = memory
        if suggested:
            entry["suggested"] = True
        out.append(entry)
    return out


def separated_by(entry: Mapping[str, Any] | None) -> str:
    """What would tell a pair of :func:`advice` apart, in a few words: ``"a dl4_mm sensor"``,
    ``"the pose α = (80.1, 2.0, −5.3)° at 6.5 kg"``, the friction advice, or ``""`` when
    nothing found separates them."""
    if not entry:
        return ""
    ch = entry.get("channel")
    if ch and ch["chi2_separation"] > CONFUSION_CHI2:
        return f"a {ch['channel']} sensor"
    pose = entry.get("pose")
    if pose and pose["chi2_separation"] > CONFUSION_CHI2:
        ang = ", ".join(f"{v:.1f}" for v in pose["alpha_deg"]).replace("-", "−")
        return f"the pose α = ({ang})° at {pose['mass_kg']:g} kg"
    memory = entry.get("memory")
    return str(memory) if memory else ""


def friction_advice(a: Slot, b: Slot, has_sequences: bool) -> str | None:
    """The measurement that tells a friction from what it is confused with, in words (None
    when neither is a friction).

    Loaded once, a friction is a deadband: it takes a constant off each force change, which
    an elastic effect or a gap can imitate. Only the history shows it for what it is: the
    unloading branch lies on the other side of the frictionless curve and the arm does not
    come back at zero payload. Two frictions on one actuator differ by their limit: an
    actuator friction's is a force, a joint friction's a torque T/r_i, so it changes with
    the moment arm r_i of actuator i about O_i from pose to pose. At a rotary drive the joint
    friction (in parallel with the whole drive) and the gear's friction (in parallel with its
    spring) hold the same torque: only a backlash in the gear tells them apart, as it follows
    the torque through the gear (docs/model.md §10).
    """
    frictions = ("actuator_friction", "joint_friction", "drive_friction")
    if a.name not in frictions and b.name not in frictions:
        return None
    if a.name in frictions and b.name in frictions:
        if {a.name, b.name} == {"joint_friction", "drive_friction"} and a.at == b.at:
            return (
                f"nothing but a backlash in drive {a.at[1:]}: the joint friction and the "
                "gear's friction hold the same torque, and only the backlash, which follows "
                "the torque through the gear, sees where it is held"
            )
        if a.name != b.name and a.at[1:] == b.at[1:]:
            i = a.at[1:]
            return (
                f"poses with a different moment arm of actuator {i} about O{i}: the joint "
                f"friction's limit (torque / moment arm) changes with it, the actuator "
                "friction's does not"
            )
        return "poses and channels that load the two places differently"
    if not has_sequences:
        return (
            "an unloading branch (a load cycle written with a step column): only a friction "
            "leaves the loading and unloading branches apart and the arm short of its "
            "reference at the return to zero payload"
        )
    return "a longer unloading branch, back to zero payload"


def _problem_at(
    arm: Arm, alpha: FloatArray, mass: float, sw: bool, kw: Mapping[str, Any]
) -> Problem:
    """A measurement-less Problem at given poses (for predictions only)."""
    from eodarm.data.measurements import channel_names

    n = len(alpha)
    chans = channel_names(arm.n)
    meas = Measurements.from_arrays(
        config=np.array([f"p{i}" for i in range(n)]),
        alpha_deg=alpha,
        mass_kg=np.full(n, mass),
        values={ch: np.full(n, np.nan) for ch in chans},
        sigma=None,
        source="<poses>",
    )
    return Problem(arm, meas, self_weight=sw, **kw)
