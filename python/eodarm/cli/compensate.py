"""``eodarm compensate``: the angles to command so that the payload does not move the point.

    eodarm compensate --arm ARM.toml --alpha A1,A2,... [--alpha ...] --mass M [--json]
    eodarm compensate --arm ARM.toml --poses POSES.csv [--mass M] [-o OUT.csv]

A pose that cannot be compensated (out of stroke, near-singular, no convergence) fails the
command with one line naming it (exit status 2), unless ``--partial`` asks for the others:
then its angles are empty (``null`` in JSON) and a note on stderr names it.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.compensate import compensate
from eodarm.cli._common import (
    ARM_HELP,
    _arm_argv,
    _effects_args,
    _floats,
    _load_arm,
    _model_words,
    _next,
    _note,
    _payload_hint,
    _print_table,
    _say,
    _stages,
    _valued_effect,
    check_kinds_of,
)
from eodarm.cli._help import HELP
from eodarm.cli._outputs import _claim, _force_arg
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, with_arm_effects
from eodarm.model.hysteresis import has_branch, has_memory


def _nominal_poses(
    args: argparse.Namespace, arm: Arm
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], list[str] | None]:
    """(alpha (N, n), mass (N,), config labels or None) from --alpha/--poses and --mass."""
    n = arm.n
    if args.alpha and args.poses:
        raise EodarmError("give the nominal poses with --alpha or with --poses, not both")
    mass_arg: float | None = None
    if args.mass is not None:
        masses = _floats(args.mass, "--mass")
        if len(masses) != 1:
            raise EodarmError(f"--mass '{args.mass}': expected one payload mass in kg")
        mass_arg = masses[0]
    config = None
    if args.poses:
        from eodarm.data.poses import read_poses

        poses = read_poses(args.poses, n)
        alpha = poses.alpha_deg
        config = list(poses.config) if poses.config is not None else None
        if poses.mass_kg is not None and mass_arg is not None:
            raise EodarmError(f"{args.poses} has a mass_kg column: drop --mass")
        if poses.mass_kg is not None:
            return alpha, poses.mass_kg, config
    elif args.alpha:
        rows = []
        for text in args.alpha:
            a = _floats(text, "--alpha")
            if len(a) != n:
                raise EodarmError(
                    f"--alpha '{text}': expected {n} angles (degrees) for the {n}-link arm "
                    f"'{arm.name}'"
                )
            rows.append(a)
        alpha = np.array(rows, dtype=float)
    else:
        raise EodarmError("give the nominal poses: --alpha A1,A2,... (repeatable) or --poses FILE")
    if mass_arg is None:
        raise EodarmError("give the payload: --mass M (kg)")
    return alpha, np.full(alpha.shape[0], mass_arg), config


def _json_list(a: npt.NDArray[Any]) -> Any:
    """Nested lists with NaN as None (JSON has no NaN)."""
    return [
        _json_list(x) if isinstance(x, np.ndarray) else (None if math.isnan(x) else float(x))
        for x in a
    ]


def _uncompensated_miss(
    arm: Arm,
    alpha: npt.NDArray[np.float64],
    mass: npt.NDArray[np.float64],
    effects: list[Effect],
    self_weight: bool,
) -> npt.NDArray[np.float64]:
    """How far the loaded measure point of the nominal poses misses (mm; NaN where the model
    cannot solve a pose): what compensation removes. User-written effects included."""
    from eodarm.model.solver import solve

    def miss(rows: npt.NDArray[np.intp]) -> npt.NDArray[np.float64]:
        out = solve(arm, alpha[rows], mass[rows], effects, self_weight=self_weight)
        return np.asarray(np.hypot(out["dx_mm"], out["dy_mm"]))

    try:
        return miss(np.arange(alpha.shape[0]))
    except ValueError:  # some pose cannot be solved (the core's error is a ValueError too):
        result = np.full(alpha.shape[0], np.nan)  # the others still can, one by one
        for i in range(alpha.shape[0]):
            try:
                result[i] = miss(np.array([i]))[0]
            except ValueError:
                pass
        return result


def _write_csv(
    path: str,
    arm: Arm,
    alpha: npt.NDArray[np.float64],
    mass: npt.NDArray[np.float64],
    config: list[str] | None,
    out: dict[str, npt.NDArray[Any]],
) -> None:
    n = arm.n
    head = (["config"] if config is not None else []) + [
        f"nominal_alpha{k + 1}_deg" for k in range(n)
    ]
    head += ["mass_kg"] + [f"alpha{k + 1}_deg" for k in range(n)]
    head += [f"length{k + 1}_mm" for k in range(n)] + ["residual_mm", "status", "iterations"]

    def cell(x: float) -> str:
        return "" if math.isnan(x) else repr(float(x))

    from eodarm.atomic import atomic_write

    with atomic_write(path, newline="") as f:  # whole or not at all
        w = csv.writer(f, lineterminator="\n")  # LF, as every other file eodarm writes
        w.writerow(head)
        for i in range(alpha.shape[0]):
            row = [config[i]] if config is not None else []
            row += [repr(float(a)) for a in alpha[i]] + [repr(float(mass[i]))]
            row += [cell(a) for a in out["alpha_deg"][i]]
            row += [cell(x) for x in out["length_mm"][i]]
            row += [cell(out["residual_mm"][i]), str(out["status"][i]), str(out["iterations"][i])]
            w.writerow(row)


def _predicted_miss(
    arm: Arm,
    out: dict[str, npt.NDArray[Any]],
    mass: npt.NDArray[np.float64],
    effects: list[Effect],
    self_weight: bool,
) -> npt.NDArray[np.float64] | None:
    """How far the real arm may still miss at the commanded poses: 2·√(σ_dx² + σ_dy²), the
    total σ of the fitted model (parameters and inadequacy, docs/model.md), mm; NaN where
    not compensated. ``None`` when the arm carries no ``[fit]`` (nothing to propagate) or
    the model holds a user-written effect."""
    from eodarm.model.effects import split_effects
    from eodarm.model.solver import solve
    from eodarm.workspace.compensated import K_SIGMA

    if arm.fit is None or split_effects(with_arm_effects(arm.effects, effects))[1]:
        return None
    miss = np.full(mass.shape[0], np.nan)
    ok = np.asarray(out["status"]) == "ok"
    if ok.any():
        got = solve(
            arm, out["alpha_deg"][ok], mass[ok], effects, self_weight=self_weight, uncertainty=True
        )
        miss[ok] = K_SIGMA * np.hypot(got["sigma_dx_mm"], got["sigma_dy_mm"])
    return miss


def _hysteresis(
    arm: Arm,
    out: dict[str, npt.NDArray[Any]],
    mass: npt.NDArray[np.float64],
    effects: list[Effect],
    self_weight: bool,
) -> npt.NDArray[np.float64]:
    """The hysteresis band at the commanded poses (mm; eodarm.model.hysteresis.band): how
    far the point lands from the nominal one when the payload is reached by unloading; 0
    without friction, NaN where not compensated."""
    from eodarm.model.hysteresis import band

    got = np.full(mass.shape[0], np.nan)
    ok = np.asarray(out["status"]) == "ok"
    if ok.any():
        got[ok] = band(arm, out["alpha_deg"][ok], mass[ok], effects, self_weight)
    return got


def run(args: argparse.Namespace) -> int:
    if args.output:
        _claim(args, args.output, "-o")
    arm = _load_arm(args.arm)
    check_kinds_of(arm, args.add, "--add")
    effects = [_valued_effect(s) for s in args.add or []]
    alpha, mass, config = _nominal_poses(args, arm)
    self_weight = not args.no_self_weight
    import warnings

    from eodarm.analysis.compensate import CompensationWarning, failure_summary

    hinted = _payload_hint(arm, mass)  # --mass 5000: is it grams?
    with (
        hinted,
        warnings.catch_warnings(record=True) as caught,
        _stages(["compensating"], "compensate") as step,
    ):
        warnings.simplefilter("always")
        step("compensating")
        out = compensate(arm, alpha, mass, effects, self_weight=self_weight, strict=False)
    for w in caught:  # the failures are said below, by their lines in a --poses file
        if not issubclass(w.category, CompensationWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    lines = None
    if args.poses:
        from eodarm.data.poses import read_poses

        lines = read_poses(args.poses, arm.n).line
    summary = failure_summary(out, args.poses, lines)
    if summary and not args.partial:
        hint = "; --partial keeps the others" if alpha.shape[0] > 1 else ""
        with hinted:
            raise EodarmError(f"{summary}{hint}")
    if summary:
        warnings.warn(
            summary + "; their alpha_deg and length_mm are NaN", CompensationWarning, stacklevel=1
        )
    if args.output:
        _write_csv(args.output, arm, alpha, mass, config, out)
        _note(f"wrote {args.output}")
    predicted = _predicted_miss(arm, out, mass, effects, self_weight)
    hysteresis = _hysteresis(arm, out, mass, effects, self_weight)
    if predicted is not None:
        from eodarm.model.uncertainty import inadequacy_note

        line = inadequacy_note(arm)
        if line:
            _note(line)
    if args.json:
        doc = {
            "alpha_deg": _json_list(out["alpha_deg"]),
            "length_mm": _json_list(out["length_mm"]),
            "residual_mm": _json_list(out["residual_mm"]),
            "status": [str(s) for s in out["status"]],
        }
        if has_branch(arm, effects):  # friction or a gap: the answer is the loading branch's
            doc |= {"branch": "loading", "hysteresis_mm": _json_list(hysteresis)}
        if predicted is not None:
            doc["predicted_miss_mm"] = _json_list(predicted)
        json.dump(doc, sys.stdout)
        sys.stdout.write("\n")
        return 0
    miss = _uncompensated_miss(arm, alpha, mass, effects, self_weight)
    _say(
        f"arm {arm.name!r} ({arm.n} links), model: {_model_words(arm, effects)}"
        + ("" if self_weight else ", self-weight off")
    )
    head = ["pose", "kg", "nominal α deg", "command α deg", "length mm", "miss mm", "left mm"]
    if predicted is not None:
        head += ["2σ miss mm"]
    memory = has_memory(arm, effects)
    if memory:
        head += ["band mm"]
    head += ["status"]
    from eodarm.text import channel_value

    def mm(x: float, digits: int = 3) -> str:
        """A length of the table (its unit in the header), by the one formatter: a practical
        zero reads 0 or < 1e-6, never 2e−11 (docs/terminal.md)."""
        return channel_value(float(x), "mm", digits).removesuffix(" mm")

    rows = []
    for i in range(alpha.shape[0]):
        ok = out["status"][i] == "ok"
        row = [
            str(i + 1),
            f"{mass[i]:g}",
            "/".join(f"{a:g}" for a in alpha[i]),
            "/".join(f"{a:.4f}" for a in out["alpha_deg"][i]) if ok else "—",
            "/".join("—" if math.isnan(x) else f"{x:.2f}" for x in out["length_mm"][i])
            if ok
            else "—",
            mm(miss[i], 4),
            mm(out["residual_mm"][i], 2),
        ]
        if predicted is not None:
            row.append(mm(predicted[i], 2))
        if memory:
            row.append(mm(hysteresis[i]))
        rows.append([*row, str(out["status"][i])])
    _print_table(head, [[c.replace("-", "−") for c in r] for r in rows])
    _say(
        "command: the unloaded angles to command; length: the actuator lengths that give them; "
        "miss: how far the payload moves the point without compensation; left: what the model "
        "leaves with it"
        + (
            "; 2σ miss: how far the real arm may still miss, from the fitted model's σ "
            "(parameters and inadequacy)" + (" on the loading branch" if memory else "")
            if predicted is not None
            else ""
        )
        + " (--json or -o: full precision)"
    )
    if has_branch(arm, effects):
        _say(
            "on the loading branch: the payload put on from the unloaded pose; "
            + (
                "band: how far the point lands from there when the same payload is reached by "
                "unloading from a heavier one (the frictions hold the other way; "
                "docs/compensation.md §4)"
                if memory
                else "the gaps keep no memory, so unloading to it lands on the same point"
            )
        )
    first = next((i for i in range(alpha.shape[0]) if out["status"][i] == "ok"), None)
    if first is not None:  # check: solve at the command, the point lands on the nominal
        cmd = ",".join(f"{a:.6g}" for a in out["alpha_deg"][first])
        adds = [a for spec in args.add or [] for a in ("--add", spec)]
        _next(
            "solve",
            *_arm_argv(args),
            *adds,
            "--alpha",
            cmd,
            "--mass",
            f"{mass[first]:g}",
            args=args,
        )
    return 0


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register ``eodarm compensate`` on the sub-parser collection."""
    c = sub.add_parser(
        "compensate",
        help=HELP["compensate"],
        description="Compensate nominal poses for the payload: the unloaded angles to command "
        "so that, under the payload, the model's measure point lands where the nominal pose "
        "puts it (and, with 3 links or more, the last link keeps its angle). The arm file's "
        "[[effect]] tables are part of the model. With friction it compensates the loading "
        "branch: the payload reached by loading from the unloaded pose (docs/compensation.md).",
    )
    c.add_argument("--arm", metavar="ARM.toml", help=ARM_HELP)
    c.add_argument(
        "--alpha",
        action="append",
        metavar="A1,A2,...",
        help="a nominal pose: unloaded absolute link angles in degrees (repeat for more)",
    )
    c.add_argument(
        "--poses",
        metavar="POSES.csv",
        help="nominal poses from a CSV file: columns alpha1_deg…alphaN_deg, optional mass_kg "
        "and config",
    )
    c.add_argument("--mass", metavar="M", help="payload mass in kg (every pose)")
    c.add_argument(
        "--add",
        action="append",
        metavar="EFFECT@PLACE=VALUE",
        help="an effect on top of the arm file's, e.g. joint_clearance@O3=0.15",
    )
    c.add_argument("--no-self-weight", action="store_true", help="drop link/actuator weights")
    c.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    c.add_argument(
        "-o", "--output", metavar="OUT.csv", help="write the nominal and commanded poses as CSV"
    )
    _force_arg(c, "an existing -o file")
    c.add_argument(
        "--partial",
        action="store_true",
        help="keep the poses that can be compensated when some cannot (their angles empty, "
        "their status given) instead of failing",
    )
    _effects_args(c)
    c.set_defaults(func=run)
    return c
