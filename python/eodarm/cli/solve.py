"""``eodarm solve``: deflections and forces of given poses × payloads."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from eodarm.cli._common import (
    ARM_HELP,
    _arm_argv,
    _effects_args,
    _floats,
    _load_arm,
    _model_args,
    _model_keys,
    _model_kw,
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
from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.outputs import SOLVE_KEYS
from eodarm.model.solver import solve

_SOLVE_KEYS = (*SOLVE_KEYS, "status")


def _fem_plots(
    directory: str, arm: Arm, out: dict[str, Any], alpha: Any, mass: Any, model: str
) -> None:
    """The FE figures of the first pose (deformed shape, moments, pin forces) into DIR."""

    if model != "fem":
        raise EodarmError("solve --plot draws the finite-element model: add --model fem")
    from eodarm.viz import fem_plots

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    pose = ", ".join(f"{a:g}" for a in alpha[0])
    head = f"{arm.name}: α = {pose}°, {mass[0]:g} kg"
    paths = [d / f"fem-{k}.png" for k in ("deformed-shape", "moments", "pin-forces")]
    with _stages(["deformed shape", "moments", "pin forces"], "solve --plot") as step:
        step("deformed shape")
        title = f"{head} (FE, {out['n_dof']} DOF)"
        fem_plots.deformed_shape(arm, out, title=title, path=paths[0])
        step("moments")
        fem_plots.moment_diagrams(arm, out, title=f"{head}: bending moments (FE)", path=paths[1])
        step("pin forces")
        fem_plots.pin_forces(
            arm, out, title=f"{head}: forces on the links at their pins", path=paths[2]
        )
    _note("wrote " + ", ".join(str(p) for p in paths))


def _json_safe(v: Any) -> Any:
    """NaN (an unknown σ, or a pose that cannot be closed under its load) as JSON null, inside
    lists too."""
    if isinstance(v, list):
        return [_json_safe(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def _sd(x: float) -> str:
    """A standard deviation to two significant digits; ``—`` when unknown."""
    return f"{x:.2g}" if math.isfinite(x) else "—"


def run(args: argparse.Namespace) -> int:
    arm = _load_arm(args.arm)
    check_kinds_of(arm, args.add, "--add")
    alphas = [_floats(a, "--alpha") for a in (args.alpha or [])]
    if not alphas:
        alphas = [[90.0] + [10.0] * (arm.n - 2) + [0.0]] if arm.n >= 2 else [[60.0]]
    masses = _floats(args.mass, "--mass")
    effects = [_valued_effect(s) for s in args.add or []]
    rows_in = [(a, m) for a in alphas for m in masses]
    alpha = np.array([r[0] for r in rows_in], dtype=float)
    mass = np.array([r[1] for r in rows_in], dtype=float)
    adds = [a for spec in args.add or [] for a in ("--add", spec)]
    with _payload_hint(arm, mass):
        out = solve(
            arm,
            alpha,
            mass,
            effects,
            backend=args.backend,
            self_weight=not args.no_self_weight,
            uncertainty=args.uncertainty,
            strict=args.strict,
            **_model_kw(args),
        )
    dofs = int(out["n_dof"]) if args.model == "fem" else 0
    if args.plot:
        _fem_plots(args.plot, arm, out, alpha, mass, args.model)
    if args.model == "fem":
        # The plotting extras (shape, moments) stay in the Python API; print the channels.
        out = {k: out[k] for k in (*_SOLVE_KEYS, "pin_force_n") if k in out}
    from eodarm.model.validity import STATUS, status_counts

    failed = int(np.isnan(np.asarray(out["dy_mm"], dtype=float)).sum())
    if failed:
        _note(
            f"{failed} of {len(out['status'])} poses cannot be closed under their load: their "
            "values are NaN (null in --json) and their status says why (--strict: an error)"
        )
    counts = status_counts(out["status"])
    if set(counts) - {"ok"}:
        _note(
            "outside the model's validity (docs/model.md, Validity): "
            + ", ".join(f"{k} {v}" for k, v in counts.items() if k != "ok")
            + f" of {len(out['status'])} poses"
        )
    memory = branch = False
    if args.uncertainty:
        from eodarm.model.hysteresis import band, has_branch, has_memory
        from eodarm.model.uncertainty import inadequacy_note

        line = inadequacy_note(arm)
        if line:
            _note(line)
        # σ is the loading branch's; the band is how far the other branch lies from it
        memory, branch = has_memory(arm, effects), has_branch(arm, effects)
        if branch:
            out["hysteresis_mm"] = band(arm, alpha, mass, effects, not args.no_self_weight)
    if args.json:
        doc = {
            "arm": arm.name,
            "model": _model_keys(arm, effects),
            "solver_model": args.model,
            "self_weight": not args.no_self_weight,
            **({"branch": "loading"} if branch else {}),
            "poses": [
                {
                    "alpha_deg": alpha[i].tolist(),
                    "mass_kg": float(mass[i]),
                    **{k: _json_safe(np.asarray(v[i]).tolist()) for k, v in out.items()},
                }
                for i in range(len(rows_in))
            ],
        }
        json.dump(doc, sys.stdout, indent=None if args.compact else 1, allow_nan=False)
        sys.stdout.write("\n")
        return 0
    n = arm.n
    _say(
        f"arm {arm.name!r} ({n} links), model: {_model_words(arm, effects)}"
        + ("" if not args.no_self_weight else ", self-weight off")
        + (f", finite-element model ({dofs} DOF)" if dofs else "")
    )
    rotary = [k == "rotary" for k in arm.kinds]
    # a drive's torque in N·m beside the actuators' forces in N; no length at a drive
    force_head = "force N" if not any(rotary) else "torque N·m" if all(rotary) else "F N | T N·m"
    head = ["α deg", "kg", "dx mm", "dy mm", force_head, "dα deg"]
    if not all(rotary):
        head.append("dl mm")
    if args.uncertainty:
        head += ["σ dx mm", "σ dy mm"]
    if memory:
        head += ["band mm"]
    head += ["status"]
    rows = []
    for i in range(len(rows_in)):
        cells = [
            "/".join(f"{a:g}" for a in alpha[i]),
            f"{mass[i]:g}",
            f"{out['dx_mm'][i]:.4f}",
            f"{out['dy_mm'][i]:.4f}",
            "/".join(_force_cell(out, i, k, rotary[k]) for k in range(n)),
            "/".join(f"{d:.3f}" for d in out["dalpha_deg"][i]),
        ]
        if not all(rotary):
            cells.append(
                "/".join(
                    "—" if r else f"{d:.3f}" for d, r in zip(out["dl_mm"][i], rotary, strict=True)
                )
            )
        if args.uncertainty:
            cells += [_sd(out["sigma_dx_mm"][i]), _sd(out["sigma_dy_mm"][i])]
        if memory:
            cells += [_sd(out["hysteresis_mm"][i])]
        cells += [STATUS[int(out["status"][i])]]
        rows.append([c.replace("-", "−") for c in cells])
    _print_table(head, rows)
    _say(
        "a/b/c: links or actuators 1…n; dα: loaded − unloaded angle"
        + ("; dl: actuator length change" if not all(rotary) else "")
        + ("; T: drive torque on its link, counter-clockwise +" if any(rotary) else "")
        + " (--json: every output, full precision)"
        + (
            "; on the loading branch (the payload put on from the unloaded pose): band is how "
            "far the point lands from it when the payload is reached by unloading from a "
            "heavier one, which σ does not cover (docs/compensation.md §4)"
            if memory
            else ""
        )
    )
    a0 = ",".join(f"{a:g}" for a in alpha[0])
    _next("compensate", *_arm_argv(args), *adds, "--alpha", a0, "--mass", f"{mass[0]:g}", args=args)
    return 0


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register ``eodarm solve`` on the sub-parser collection."""
    s = sub.add_parser(
        "solve",
        help=HELP["solve"],
        description="Solve the arm model for poses × payloads and print deflections and forces.",
    )
    s.add_argument("--arm", metavar="ARM.toml", help=ARM_HELP)
    s.add_argument(
        "--alpha",
        action="append",
        metavar="A1,A2,...",
        help="unloaded absolute link angles in degrees (repeat for more poses)",
    )
    s.add_argument(
        "--mass",
        default="1.5,5,6.5",
        metavar="M1,M2,...",
        help="payload masses in kg (default: 1.5,5,6.5, the seed's)",
    )
    s.add_argument(
        "--add",
        action="append",
        metavar="EFFECT@PLACE=VALUE",
        help="add an effect with its parameter, e.g. joint_clearance@O3=0.15",
    )
    s.add_argument("--backend", choices=("rust", "numpy"), default="rust")
    _model_args(s)
    _effects_args(s)
    s.add_argument(
        "--plot",
        metavar="DIR",
        help="with --model fem: write the first pose's deformed shape, bending moments and "
        "pin forces as PNG figures into DIR",
    )
    s.add_argument("--no-self-weight", action="store_true", help="drop link/actuator weights")
    s.add_argument(
        "--uncertainty",
        action="store_true",
        help="standard deviations of dx, dy and the angle changes (an arm written by 'eodarm "
        "fit -o'): sigma_* the total, sigma_param_* from the fitted parameters' covariance, "
        "sigma_model_* the model's own inadequacy (docs/model.md, Prediction errors)",
    )
    s.add_argument(
        "--strict",
        action="store_true",
        help="a pose that cannot be closed under its load is an error (exit 2) naming it, "
        "instead of a row of NaN with its status (the default)",
    )
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    s.add_argument("--compact", action="store_true", help="with --json: no indentation")
    s.set_defaults(func=run)

    return s


def _force_cell(out: Any, row: int, joint: int, rotary: bool) -> str:
    """An actuator's loaded force (N), or a drive's loaded torque (N·m), of one pose."""
    if rotary:
        return f"{out['torque_nmm'][row][joint] / 1000.0:.1f}"
    return f"{out['force_n'][row][joint]:.0f}"
