"""The ``eodarm`` command line.

Data goes to stdout, messages to stderr. Exit status: 0 on success, 2 on bad input (with a
one-line reason on stderr), 1 on an unexpected internal error.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from importlib import resources

import numpy as np

from . import __version__
from .arm import Arm
from .effects import CATALOGUE, Effect
from .errors import EodarmError
from .solver import solve

__all__ = ["main"]


def _bundled_arm() -> Arm:
    ref = resources.files("eodarm").joinpath("data/example_arm.toml")
    with resources.as_file(ref) as path:
        return Arm.from_toml(path)


def _load_arm(path: str | None) -> Arm:
    return _bundled_arm() if path is None else Arm.from_toml(path)


def _valued_effect(spec: str) -> Effect:
    """``effect@place=value`` → Effect."""
    head, sep, value = spec.partition("=")
    name = head.partition("@")[0]
    if not sep or name not in CATALOGUE:
        raise EodarmError(
            f"--add '{spec}': expected EFFECT@PLACE=VALUE, e.g. joint_clearance@O3=0.15"
        )
    try:
        x = float(value)
    except ValueError:
        raise EodarmError(f"--add '{spec}': '{value}' is not a number") from None
    return Effect.parse(head, **{CATALOGUE[name].param: x})


def _floats(text: str, what: str) -> list[float]:
    try:
        return [float(t) for t in text.replace(";", ",").split(",") if t.strip()]
    except ValueError:
        raise EodarmError(f"{what} '{text}': expected comma-separated numbers") from None


def _cmd_solve(args: argparse.Namespace) -> int:
    arm = _load_arm(args.arm)
    alphas = [_floats(a, "--alpha") for a in (args.alpha or [])]
    if not alphas:
        alphas = [[90.0] + [10.0] * (arm.n - 2) + [0.0]] if arm.n >= 2 else [[60.0]]
    masses = _floats(args.mass, "--mass")
    effects = [_valued_effect(s) for s in args.add or []]
    rows = [(a, m) for a in alphas for m in masses]
    alpha = np.array([r[0] for r in rows], dtype=float)
    mass = np.array([r[1] for r in rows], dtype=float)
    out = solve(
        arm, alpha, mass, effects, backend=args.backend, self_weight=not args.no_self_weight
    )
    if args.json:
        doc = {
            "arm": arm.name,
            "model": [e.key for e in effects],
            "self_weight": not args.no_self_weight,
            "poses": [
                {
                    "alpha_deg": alpha[i].tolist(),
                    "mass_kg": float(mass[i]),
                    **{k: np.asarray(v[i]).tolist() for k, v in out.items()},
                }
                for i in range(len(rows))
            ],
        }
        json.dump(doc, sys.stdout, indent=None if args.compact else 1)
        sys.stdout.write("\n")
        return 0
    n = arm.n
    print(
        f"arm {arm.name!r} ({n} links), model: baseline"
        + "".join(f" + {e.name}@{e.at}" for e in effects)
        + ("" if not args.no_self_weight else ", self-weight off")
    )
    head = ["alpha_deg", "mass_kg", "dx_mm", "dy_mm"]
    head += [f"F{i + 1}_N" for i in range(n)] + [f"da{i + 1}_deg" for i in range(n)]
    head += [f"dl{i + 1}_mm" for i in range(n)]
    print("  ".join(f"{h:>12}" for h in head))
    for i in range(len(rows)):
        cells = [
            "/".join(f"{a:g}" for a in alpha[i]),
            f"{mass[i]:g}",
            f"{out['dx_mm'][i]:.4f}",
            f"{out['dy_mm'][i]:.4f}",
        ]
        cells += [f"{f:.1f}" for f in out["force_n"][i]]
        cells += [f"{d:.5f}" for d in out["dalpha_deg"][i]]
        cells += [f"{d:.5f}" for d in out["dl_mm"][i]]
        print("  ".join(f"{c:>12}" for c in cells))
    return 0


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="eodarm",
        description="Why does the arm not go where its model says? Solve, compare and diagnose "
        "the statics, compliance and backlash of planar arms driven by linear actuators.",
    )
    p.add_argument("--version", action="version", version=f"eodarm {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    s = sub.add_parser(
        "solve",
        help="loaded minus unloaded pose, actuator forces and deflections for given poses",
        description="Solve the arm model for poses × payloads and print deflections and forces.",
    )
    s.add_argument("--arm", metavar="ARM.toml", help="arm file (default: the bundled example)")
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
    s.add_argument("--no-self-weight", action="store_true", help="drop link/actuator weights")
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    s.add_argument("--compact", action="store_true", help="with --json: no indentation")
    s.set_defaults(func=_cmd_solve)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``eodarm`` command; returns the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    try:
        return int(args.func(args))
    except EodarmError as exc:
        print(f"eodarm: error: {exc}", file=sys.stderr)
        return 2
    except ValueError as exc:  # e.g. eodarm._core.CoreError
        print(f"eodarm: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
