"""Mistakes caught at the door: measured states that the arm cannot take, and unit slips.

A measurement file can be well formed and still be wrong for its arm. Before any model is
compared or fitted, :func:`check_states` solves the baseline model (the arm file as it is,
its own effects included) at every measured state and refuses, in one line naming the file,
the 1-based line and the column, what no model of this arm could explain:

* an unloaded pose **out of stroke**: an actuator's pin-to-pin length outside the arm file's
  ``[min_length_mm, max_length_mm]``;
* a pose that **cannot close under its load**: an actuator triangle with no solution at the
  loaded length. Where the mass is more than :data:`GRAMS_FACTOR` times the arm's own and
  the same pose closes under ``mass_kg / 1000``, the mass was most probably written in
  grams, and the message says so.

These are data or geometry problems, not the fault of a fitted effect: they are refused
before fitting (docs/terminal.md, "Mistakes caught at the door").

Angles in radians
-----------------
A file whose every unloaded angle lies within ±2π (±6.3 "degrees") is suspect: a real arm
is rarely measured with every link within 6° of the horizontal. Its angles are read both ways
(as degrees, and as radians turned into degrees) and the baseline model's χ² of the measured
deflections is computed for each. When the radian reading explains the data at least
:data:`RADIAN_CHI2_RATIO` times better (or the degree reading cannot be solved where the
radian one can), the file is refused: the angles are radians. Otherwise a warning says that
the angles would be radians if they were meant so, and the file is used as degrees.

Masses in grams (warning)
-------------------------
A state that closes but whose deflection is outside the model's validity
(:mod:`eodarm.model.validity`: ``large_deflection``, ``branch_flip``) under a mass more than
:data:`GRAMS_FACTOR` times the arm's own, while ``mass_kg / 1000`` would be inside it, gets a
warning naming the lines: grams are likely, but a heavily loaded arm is possible, so it is not
refused. Where every state closes inside the validity (a stiff arm) and the heaviest mass is
still over :data:`GRAMS_FACTOR` times the arm's own, its line gets :func:`payload_hint`'s
warning, as ``--mass`` does: ``meas.csv line 4: mass_kg 6500 kg is over 10 times the arm's
own 10.1 kg: is it grams? (6.5 kg); 23 other lines over 101 kg too``.

A campaign file's ``masses_kg`` (:func:`campaign_payload_hint`) get :func:`payload_hint`'s
line, naming the campaign, the record and the key; without the arm, a plain range
(:data:`PLAIN_PAYLOAD_KG`).
"""

from __future__ import annotations

import math
import re
import warnings
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.data.channels import channel_values
from eodarm.data.measurements import MAX_LISTED, MeasurementFileError, Measurements
from eodarm.data.records import Campaign
from eodarm.errors import MESSAGE_ROOM, listing, show, show_source
from eodarm.model.arm import Arm

__all__ = [
    "GRAMS_FACTOR",
    "PLAIN_PAYLOAD_KG",
    "RADIAN_CHI2_RATIO",
    "campaign_payload_hint",
    "check_drive_channels",
    "check_states",
    "own_mass_kg",
    "payload_hint",
]

#: The radian reading of angles within ±2π must explain the measured deflections this many
#: times better (in χ²) than the degree reading for the file to be refused as radians.
RADIAN_CHI2_RATIO = 10.0

#: A payload above this many times the arm's own mass (links and actuators) whose state
#: fails where a thousandth of it would not is taken for grams: arms of this kind carry a
#: fraction of their own weight (the seed's 10 kg arm, 6.5 kg), not tens of times it.
GRAMS_FACTOR = 10.0

#: Without the arm, a campaign's payload above this (kg) is named: ten times the own mass of
#: the arms eodarm is made for (the seed's 10 kg, the example's 10.1 kg), the limit
#: :func:`payload_hint` would set for them. A plain range: ``--arm`` gives the true scale.
PLAIN_PAYLOAD_KG = 100.0

_ROW = re.compile(r"pose row (\d+):\s*")

FloatArray = npt.NDArray[np.float64]


def _solve(
    arm: Arm, alpha: FloatArray, mass: FloatArray, self_weight: bool
) -> tuple[dict[str, Any] | None, dict[int, str]]:
    """The baseline solve of every row, and the rows that cannot be solved (row → reason).

    The solver refuses a batch naming its first bad row (or gives NaN there): the bad rows
    are found and set aside, at most :data:`MAX_LISTED` + 1 of them, so that the message can
    list them. Returns ``None`` for the solution when more rows failed than that.
    """
    from eodarm.model.solver import solve

    failed: dict[int, str] = {}
    keep = np.arange(alpha.shape[0])
    while keep.size:
        try:
            out = dict(solve(arm, alpha[keep], mass[keep], self_weight=self_weight))
        except ValueError as exc:
            m = _ROW.search(str(exc))
            if m is None:
                raise
            r = int(keep[int(m.group(1))])
            failed[r] = str(exc)[m.end() :]
            keep = keep[keep != r]
            if len(failed) > MAX_LISTED:
                return None, failed
            continue
        dy = np.asarray(out["dy_mm"], dtype=float)
        for j in np.flatnonzero(~np.isfinite(dy)):
            failed[int(keep[j])] = "the loaded pose cannot close"
        full: dict[str, Any] = {}
        for k, v in out.items():
            v = np.asarray(v)
            a = np.full((alpha.shape[0], *v.shape[1:]), np.nan if v.dtype.kind == "f" else 0)
            a = a.astype(v.dtype)
            a[keep] = v
            full[k] = a
        for r in failed:
            if "dy_mm" in full:
                full["dy_mm"][r] = np.nan
        return full, failed
    return None, failed


def _chi2(meas: Measurements, out: dict[str, Any] | None, failed: dict[int, str]) -> float:
    """χ² of the baseline's prediction of every measured value (∞ when a state failed)."""
    if out is None or failed:
        return math.inf
    pred = channel_values(out, meas.channels)
    z = (meas.values - pred) / meas.sigma
    return float(np.nansum(z * z))


def own_mass_kg(arm: Arm) -> float:
    """The arm's own mass, kg: its links and actuators."""
    return float(sum(x.mass_kg for x in arm.links) + sum(x.mass_kg for x in arm.actuators))


def payload_hint(mass_kg: float, arm: Arm) -> str | None:
    """One line when a payload is more than the arm can plausibly carry, else None.

    The rule: a payload above :data:`GRAMS_FACTOR` (10) times the arm's own mass (its links
    and actuators, :func:`own_mass_kg`). Arms of this kind carry a fraction of their own
    weight (the seed's 10 kg arm, 6.5 kg); ten times it loads every actuator and pin far
    beyond what they were sized for. When ``mass_kg / 1000`` is within that limit the mass
    was most probably written in grams, and the line says so: ``5000 kg is over 10 times
    the arm's own 10.1 kg: is it grams? (5 kg)``; the caller puts in front what names the
    mass (``--mass``, ``masses_kg[3]``, ``line 7 mass_kg``). An arm file without masses (own
    mass 0) gives no hint. A warning, not a refusal: a light arm with a heavy payload is
    possible, and the states it cannot take are refused on their own (``check_states``, the
    solver).
    """
    own = own_mass_kg(arm)
    limit = GRAMS_FACTOR * own
    if not (own > 0 and math.isfinite(mass_kg) and mass_kg > limit):
        return None
    line = f"{mass_kg:g} kg is over {GRAMS_FACTOR:g} times the arm's own {own:.3g} kg"
    if mass_kg / 1000.0 <= limit:
        return f"{line}: is it grams? ({mass_kg / 1000.0:g} kg)"
    return f"{line}: check its unit (kg)"


def campaign_payload_hint(campaign: Campaign, arm: Arm | None = None) -> str | None:
    """One line when a campaign file's ``masses_kg`` look like grams, else None.

    The heaviest payload of the campaign is held against the arm as :func:`payload_hint`
    holds ``--mass`` (over :data:`GRAMS_FACTOR` times the arm's own mass; an arm file
    without masses gives no hint). Without the arm only a plain range can be said: a payload
    above :data:`PLAIN_PAYLOAD_KG` is named in the same words, and the line adds that
    ``--arm`` checks it against the arm. The line names the campaign file, the record
    (1-based, with its config label) and the key: ``campaign.toml: record 1 ('c1')
    masses_kg[3] 6500 kg is over 10 times the arm's own 10.1 kg: is it grams? (6.5 kg)``,
    and how many other records hold a payload over the limit. A warning, not a
    refusal, as :func:`payload_hint`'s: the states an arm cannot take are refused on their
    own (:func:`check_states`, when the campaign's rows are compared with the arm).
    """
    heaviest = max(  # the first of the heaviest
        ((m, -i, -j) for i, s in enumerate(campaign.records) for j, m in enumerate(s.masses_kg)),
        default=None,
    )
    if heaviest is None:
        return None
    mass, i, j = heaviest[0], -heaviest[1], -heaviest[2]
    if arm is not None:
        hint = payload_hint(mass, arm)
        limit = GRAMS_FACTOR * own_mass_kg(arm)
        ask = ""
    elif mass > PLAIN_PAYLOAD_KG:
        limit = PLAIN_PAYLOAD_KG
        unit = "is it grams?" if mass / 1000.0 <= limit else "check its unit (kg)"
        hint = f"{mass:g} kg is over {limit:g} kg, more than an arm of this kind carries: {unit}"
        if mass / 1000.0 <= limit:
            hint += f" ({mass / 1000.0:g} kg)"
        ask = "; --arm ARM.toml checks it against the arm's own mass"
    else:
        return None
    if hint is None:
        return None
    others = sum(1 for s in campaign.records if max(s.masses_kg) > limit) - 1
    more = f"; {others} other record{'s' if others > 1 else ''} over {limit:.3g} kg too"
    more = more if others > 0 else ""
    spec = campaign.records[i]
    return show(
        f"{show_source(campaign.path, 80)}: record {i + 1} ('{show(spec.config)}') "
        f"masses_kg[{j}] {hint}{more}{ask}",
        MESSAGE_ROOM,
    )


def _outside(out: dict[str, Any] | None, failed: dict[int, str], rows: int) -> int:
    """How many states cannot be solved or are outside the model's validity (status ≠ ok)."""
    if out is None:
        return rows
    bad = np.asarray(out.get("status", np.zeros(rows)), dtype=np.int64) != 0
    bad[list(failed)] = True
    return int(bad.sum())


def _check_radians(arm: Arm, meas: Measurements, self_weight: bool) -> None:
    alpha = np.asarray(meas.alpha_deg, dtype=float)
    if not (np.abs(alpha) <= 2 * math.pi).all() or not (np.abs(alpha) > 0.05).any():
        return
    mass = np.asarray(meas.mass_kg, dtype=float)
    as_rad = np.degrees(alpha)
    deg_out, deg_failed = _solve(arm, alpha, mass, self_weight)
    rad_out, rad_failed = _solve(arm, as_rad, mass, self_weight)
    chi_deg, chi_rad = _chi2(meas, deg_out, deg_failed), _chi2(meas, rad_out, rad_failed)
    outside_deg = _outside(deg_out, deg_failed, alpha.shape[0])
    outside_rad = _outside(rad_out, rad_failed, alpha.shape[0])
    r, j = np.unravel_index(int(np.argmax(np.abs(alpha))), alpha.shape)
    example = (
        f"line {int(meas.line[r])} alpha{j + 1}_deg {alpha[r, j]:.6g} is "
        f"{as_rad[r, j]:.4g}° if it is in radians"
    )
    if outside_deg and not outside_rad:
        why = (
            f"read as degrees, {outside_deg} of {alpha.shape[0]} states cannot be solved or "
            "leave the model's validity; read as radians, none does"
        )
    elif math.isfinite(chi_rad) and chi_rad * RADIAN_CHI2_RATIO < chi_deg:
        why = (
            f"read as radians they explain the data {chi_deg / max(chi_rad, 1e-300):.3g}× "
            "better (χ²)"
        )
    else:
        why = ""
    if why:
        raise MeasurementFileError(
            f"{show_source(meas.source)}: every alphaK_deg is within ±2π: the angles look like "
            "radians "
            f"({example}; {why}); give degrees (multiply by 180/π)"
        )
    warnings.warn(
        f"{show_source(meas.source)}: every alphaK_deg is within ±2π, read as degrees ({example}); "
        "convert them if they are radians",
        UserWarning,
        stacklevel=3,
    )


def check_drive_channels(arm: Arm, meas: Measurements) -> None:
    """Refuse a measured ``dlK_mm`` of a joint turned by a rotary drive: a drive has no
    length, so the column is a mistake (a wrong arm file, a shifted column), not a channel to
    ignore (docs/formats.md §3). A column left empty carries nothing and passes."""
    for i, kind in enumerate(arm.kinds):
        name = f"dl{i + 1}_mm"
        if kind != "rotary" or name not in meas.channels:
            continue
        col = meas.values[:, meas.channels.index(name)]
        rows = np.flatnonzero(np.isfinite(col))
        if rows.size:
            raise MeasurementFileError(
                f"{meas.source}: column {name} (line {int(meas.line[rows[0]])}): joint "
                f"{i + 1} of arm '{arm.name}' is turned by a rotary drive, which has no "
                f"length to measure (its turn is in dalpha{i + 1}_deg)"
            )


def check_states(arm: Arm, meas: Measurements, self_weight: bool = True) -> None:
    """Refuse measured states that the arm cannot take; warn about likely unit slips.

    Parameters
    ----------
    arm : the arm the data were measured on (its file's effects are part of the baseline).
    meas : the measurements (``meas.line`` names each state's line in its file).
    self_weight : whether the links' and actuators' weights load the arm.

    Raises
    ------
    MeasurementFileError
        A measured length of a joint turned by a rotary drive (:func:`check_drive_channels`);
        one line naming the file and, for each bad state (at most :data:`MAX_LISTED`), its
        1-based line, the column at fault and what was probably meant: angles in radians,
        an unloaded pose out of stroke, a pose that cannot close under its load (in grams?).

    Warns
    -----
    UserWarning
        Angles within ±2π that might be radians; masses whose states leave the model's
        validity where ``mass_kg / 1000`` would not (grams?); else a heaviest mass over
        :data:`GRAMS_FACTOR` times the arm's own (:func:`payload_hint`).
    """
    from eodarm.model.solver import forward, stroke_violations

    if meas.n != arm.n or meas.n_rows == 0:
        return
    check_drive_channels(arm, meas)
    _check_radians(arm, meas, self_weight)
    alpha = np.asarray(meas.alpha_deg, dtype=float)
    mass = np.asarray(meas.mass_kg, dtype=float)
    lines = np.asarray(meas.line)
    bad: dict[int, str] = {}
    # unloaded: out of stroke (no load, no model: the pose itself)
    lengths = np.asarray(forward(arm, alpha)["length_mm"], dtype=float)
    viol = np.asarray(stroke_violations(arm, lengths), dtype=bool)
    for r in np.flatnonzero(viol.any(axis=1))[: MAX_LISTED + 1]:
        i = int(np.flatnonzero(viol[r])[0])
        act = arm.linear(i)  # only a linear actuator has a stroke
        cols = ",".join(f"alpha{k}_deg" for k in (i, i + 1) if k >= 1)
        bad[int(r)] = (
            f"{cols}: actuator {i + 1} is out of stroke unloaded (pin-to-pin "
            f"{lengths[r, i]:.5g} mm outside [{act.min_length_mm or 0:g}, "
            f"{act.max_length_mm if act.max_length_mm is not None else math.inf:g}] mm)"
        )
    rest = np.array([r for r in range(meas.n_rows) if r not in bad], dtype=np.int64)
    out, failed = _solve(arm, alpha[rest], mass[rest], self_weight) if rest.size else (None, {})
    failed = {int(rest[k]): v for k, v in failed.items()}
    if failed:
        rows = np.array(sorted(failed), dtype=np.int64)
        _, in_grams = _solve(arm, alpha[rows], mass[rows] / 1000.0, self_weight)
        heavy = GRAMS_FACTOR * own_mass_kg(arm)
        for k, r in enumerate(rows):
            why = failed[int(r)]
            if k in in_grams and "cannot close" not in why:  # the unloaded pose itself
                cols = ",".join(f"alpha{j + 1}_deg" for j in range(arm.n))
                bad[int(r)] = f"{cols}: {why}"
                continue
            hint = ""
            if k not in in_grams and mass[r] > heavy:
                hint = f"; in grams? {mass[r] / 1000:g} kg closes: give kilograms"
            bad[int(r)] = f"mass_kg {mass[r]:g}: {why} under this load{hint}"
    if bad:
        order = sorted(bad)
        where = show_source(meas.source)
        if len(order) == 1:
            raise MeasurementFileError(
                f"{where} line {int(lines[order[0]])}: {bad[order[0]]} (a data or "
                "geometry problem, not the model's)"
            )
        counted = f"{'at least ' if len(order) > MAX_LISTED else ''}{len(order)}"
        raise MeasurementFileError(
            listing(
                f"{where}: {counted} states that this arm cannot take, a data or geometry "
                "problem, not the model's",
                [f"line {int(lines[r])}: {bad[r]}" for r in order],
            )
        )
    if out is not None and "status" in out and _validity_grams(arm, meas, out, self_weight):
        return
    heavy = int(np.argmax(mass))
    too_heavy = payload_hint(float(mass[heavy]), arm)
    if too_heavy is not None:  # every state closes, and the masses are still too heavy
        limit = GRAMS_FACTOR * own_mass_kg(arm)
        over = int((mass > limit).sum()) - 1
        more = f"; {over} other line{'s' if over > 1 else ''} over {limit:.3g} kg too"
        more = more if over > 0 else ""
        warnings.warn(
            f"{show_source(meas.source)} line {int(lines[heavy])}: mass_kg {too_heavy}{more}",
            UserWarning,
            stacklevel=2,
        )


def _validity_grams(arm: Arm, meas: Measurements, out: dict[str, Any], self_weight: bool) -> bool:
    """Warn when states leave the model's validity under ``mass_kg`` where a thousandth of it
    would not (are the masses in grams?); return whether it warned."""
    from eodarm.model.validity import STATUS

    alpha = np.asarray(meas.alpha_deg, dtype=float)
    mass = np.asarray(meas.mass_kg, dtype=float)
    code = np.asarray(out["status"], dtype=np.int64)
    loaded_bad = np.isin(code, [STATUS.index(s) for s in ("branch_flip", "large_deflection")])
    suspects = np.flatnonzero(loaded_bad & (mass > GRAMS_FACTOR * own_mass_kg(arm)))
    if not suspects.size:
        return False
    light, light_failed = _solve(arm, alpha[suspects], mass[suspects] / 1000, self_weight)
    if light is None or light_failed:
        return False
    grams = suspects[np.asarray(light["status"]) == 0]
    if not grams.size:
        return False
    lines = np.asarray(meas.line)
    warnings.warn(
        f"{show_source(meas.source)}: under mass_kg the deflection leaves the "
        "model's validity on line(s) "
        f"{', '.join(str(int(lines[r])) for r in grams[:3])}"
        f"{' …' if grams.size > 3 else ''}"
        f" (e.g. {mass[grams[0]]:g} kg); are the masses in grams?",
        UserWarning,
        stacklevel=3,
    )
    return True
