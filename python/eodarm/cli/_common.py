"""What every command shares: arm and effect arguments, the model switch, reading
measurements, number formatting, tables and figures.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from eodarm.errors import EodarmError
from eodarm.model.arm import Arm
from eodarm.model.effects import Effect, kind_of

if TYPE_CHECKING:
    from eodarm.analysis.fit import FitResult
    from eodarm.data.measurements import Measurements
    from eodarm.model.effects import Slot


#: The bundled data set whose arm every command uses when ``--arm`` is absent
#: (docs/walkthrough.md, "Which arm").
DEFAULT_DATASET = "seed2022"


def _load_arm(path: str | None, measurements: str | None = None) -> Arm:
    """The arm of a command: the ``--arm`` file; without one, the arm that belongs to the data.

    * a command that reads no measurements (solve, synth, compensate, sweep): the bundled
      :data:`DEFAULT_DATASET` arm;
    * a command that reads ``measurements``: the arm of the bundled data set whose file it is
      (by content: the bundled file or an exported copy). The arm of any other file is
      unknown, and a model of another arm would explain nothing about it: refused, one line.

    Says on stderr which arm was chosen when ``--arm`` is absent (after the command
    succeeded, so that a failure stays one line).
    """
    if path is not None:
        return Arm.from_toml(path)
    from eodarm.data import datasets

    if measurements is None:
        arm = datasets.bundled_arm(DEFAULT_DATASET)
        _held_note(f"no --arm: used the bundled {DEFAULT_DATASET} arm '{arm.name}' ({arm.n} links)")
        return arm
    name = datasets.dataset_of(measurements)
    if name is None:
        raise EodarmError(
            f"{measurements}: give the arm these were measured on with --arm ARM.toml (only "
            "bundled data have a known arm)"
        )
    arm = datasets.bundled_arm(name)
    _held_note(f"no --arm: these are the bundled {name} data; used their arm '{arm.name}'")
    return arm


#: ``--arm`` of a command that reads no measurements.
ARM_HELP = f"arm file (default: the bundled {DEFAULT_DATASET} arm)"


def _valued_effect(spec: str, flag: str = "--add") -> Effect:
    """``effect@place=value`` → Effect (a catalogue effect or a registered user-written one)."""
    head, sep, value = spec.partition("=")
    name = head.partition("@")[0].strip()
    if not sep:
        raise EodarmError(
            f"{flag} '{spec}': expected EFFECT@PLACE=VALUE, e.g. joint_clearance@O3=0.15"
        )
    kind = kind_of(name)
    if kind is None:
        from eodarm.model.effects import known_effects

        raise EodarmError(
            f"{flag} '{spec}': unknown effect '{name}'; known: {', '.join(known_effects())} "
            "(user-written effects come with --effects FILE.py)"
        )
    try:
        x = float(value)
    except ValueError:
        raise EodarmError(f"{flag} '{spec}': '{value}' is not a number") from None
    return Effect.parse(head.strip(), **{kind.param: x})


def _effects_args(p: argparse.ArgumentParser) -> None:
    """``--effects FILE.py``: user-written effects (CONTRACT §8), loaded before any effect is
    parsed."""
    p.add_argument(
        "--effects",
        action="append",
        metavar="FILE.py",
        help="a Python file that registers user-written effects with eodarm.custom_effect "
        "(repeatable; docs/custom-effects.md)",
    )


def load_effects(args: argparse.Namespace) -> None:
    """Register the installed packages' effects (entry-point group ``eodarm.effects``) and
    run the ``--effects`` files of a command that takes effects."""
    if not hasattr(args, "effects"):
        return
    from eodarm.model import custom

    custom.load_entry_points()
    for path in args.effects or []:
        custom.load_file(path)


def _floats(text: str, what: str) -> list[float]:
    try:
        return [float(t) for t in text.replace(";", ",").split(",") if t.strip()]
    except ValueError:
        raise EodarmError(f"{what} '{text}': expected comma-separated numbers") from None


def _model_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--model",
        choices=("analytic", "fem"),
        default="analytic",
        help="analytic (closed forms, exact pose; default) or fem (the frame finite-element "
        "model: linear, uses the links' ei_n_mm2/ea_n)",
    )
    p.add_argument(
        "--elements-per-link",
        type=int,
        metavar="N",
        help="with --model fem: beam elements per flexible link (default 8)",
    )


def _model_kw(args: argparse.Namespace) -> dict[str, Any]:
    """The model=/fem_options= keywords of the command's --model."""
    if args.model != "fem":
        if args.elements_per_link is not None:
            raise EodarmError("--elements-per-link needs --model fem")
        return {"model": "analytic", "fem_options": None}
    opts = {} if args.elements_per_link is None else {"elements_per_link": args.elements_per_link}
    return {"model": "fem", "fem_options": opts}


# ----------------------------------------------------------------- compare / fit / diagnose
def _note(msg: str) -> None:
    """A message on stderr, ``eodarm: …``, wrapped within :data:`WIDTH` columns."""
    _say(f"eodarm: {msg}", file=sys.stderr)


def _one_line(msg: str) -> None:
    """A message that ends a command (interrupted, failed): one line, never wrapped, so that
    it is all there is on stderr."""
    print(f"eodarm: {' '.join(msg.split())}", file=sys.stderr)


#: Messages held until the command has succeeded (the main CLI prints them, then the
#: ``next:`` line, and drops them after a failure, whose one line is then all of stderr).
#: ``HOLD`` is set by the main CLI; a command run by itself prints them at once.
HELD: list[str] = []
NEXT: list[str] = []
HOLD = [False]


def _held_note(msg: str) -> None:
    if HOLD[0]:
        HELD.append(f"eodarm: {msg}")
    else:
        _note(msg)


def _read(path: str, arm: Arm) -> Measurements:
    """Read the measurements and say on stderr where σ was not given: one line for the
    channels whose σ was pooled from the repeats, one for those that use the defaults."""
    from eodarm.data.reader import read_measurements

    meas = read_measurements(path, arm.n)
    for line in _noise_notes(meas):
        _note(line)
    return meas


def _unit(channel: str) -> str:
    return "deg" if channel.endswith("_deg") else "mm"


def _noise_notes(meas: Measurements) -> list[str]:
    """The notes of :func:`_read`: at most one line per kind (pooled, default)."""
    notes = []
    pooled = [meas.noise[ch] for ch in meas.pooled]
    if pooled:
        pools: dict[tuple[int, int, int], list[str]] = {}
        for r in pooled:
            pools.setdefault((r.states, r.rows, r.repeat_dof), []).append(
                f"{r.channel} {r.sigma:.2g} {_unit(r.channel)}"
            )
        sizes = {k: f"{k[0]} states, {k[1]} rows, {k[2]} dof" for k in pools}
        if len(pools) == 1:
            ((key, names),) = pools.items()
            text = f"{', '.join(names)} pooled from the repeats ({sizes[key]}; docs/diagnosis.md)"
        else:
            groups = ", ".join(f"{', '.join(v)} ({sizes[k]})" for k, v in pools.items())
            text = f"{groups} pooled from the repeats (docs/diagnosis.md)"
        notes.append("noise of " + text)
    if meas.defaulted:
        why: dict[str, list[str]] = {}
        for ch in meas.defaulted:
            r = meas.noise[ch]
            why.setdefault(r.reason, []).append(f"{ch} {r.sigma:g}")
        if len(why) == 1:
            ((reason, names),) = why.items()
            parts = ", ".join(names)
            tail = f", as {reason}" if reason else ""
        else:
            parts = "; ".join(
                ", ".join(names) + (f" ({reason})" if reason else "")
                for reason, names in why.items()
            )
            tail = ""
        notes.append(
            f"no sigma given for {parts}: using the default noise levels{tail} (docs/diagnosis.md)"
        )
    return notes


def _noise_json(meas: Measurements) -> dict[str, dict[str, Any]]:
    """The ``"noise"`` key of compare's and diagnose's JSON: per measured channel, its σ
    (``null`` when each value has its own, given in the file), its source
    (``"given"``/``"repeats"``/``"default"``) and the degrees of freedom of a pooled σ
    (``null`` for an exact one)."""
    return {ch: rec.to_json() for ch, rec in meas.noise.items()}


def _model(specs: list[str] | None, allow_values: bool) -> list[Effect | Slot]:
    """--add EFFECT@PLACE (fitted) or EFFECT@PLACE=VALUE (fixed / starting value)."""
    from eodarm.model.effects import Slot

    out: list[Effect | Slot] = []
    for spec in specs or []:
        if "=" in spec:
            if not allow_values:
                raise EodarmError(f"--add '{spec}': give EFFECT@PLACE only; it is fitted")
            out.append(_valued_effect(spec))
        else:
            out.append(Slot.parse(spec))
    return out


#: Terminal output is kept within this many columns.
WIDTH = 100


def _fmt(x: float, unit: str = "") -> str:
    """A number alone (viz.format.value: 4 significant digits, words for ∞ and NaN)."""
    from eodarm.viz.format import value

    return value(x, unit)


def _channel(ch: str) -> tuple[str, str]:
    """A channel identifier as (name, unit): ``dy_mm`` → (``dy``, ``mm``)."""
    for suffix, unit in (("_mm", "mm"), ("_deg", "deg")):
        if ch.endswith(suffix):
            return ch.removesuffix(suffix), unit
    return ch, ""


def _rms_line(rms: dict[str, float]) -> str:
    """``dy 7.84 mm, dalpha1 0.510 deg, …``: each channel by name, value and unit once."""
    from eodarm.viz.format import value

    parts = []
    for ch, v in rms.items():
        name, unit = _channel(ch)
        # no-break spaces: a wrapped line never parts a value from its name or unit
        parts.append(f"{name}\u00a0{value(v, unit, digits=3)}".replace(" ", "\u00a0"))
    return ", ".join(parts)


def _say(text: str, indent: str = "", width: int = WIDTH, file: Any = None) -> None:
    """Print ``text`` wrapped within ``width`` columns, continuation lines indented more."""
    import textwrap

    print(
        textwrap.fill(
            text,
            width,
            initial_indent=indent,
            subsequent_indent=indent + "  ",
            break_on_hyphens=False,
        ),
        file=file,
    )


def _print_table(
    head: list[str], rows: list[list[str]], width: int = WIDTH, left: tuple[int, ...] = ()
) -> None:
    """Columns right-aligned (those in ``left``: left-aligned, for words); a table wider than
    ``width`` is printed as one block per row (``head  cell`` lines) instead, so that no line
    is wider."""
    widths = [
        max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(head)
    ]

    def line(cells: list[str]) -> str:
        return "  ".join(
            c.ljust(w) if i in left else c.rjust(w)
            for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        ).rstrip()

    if sum(widths) + 2 * (len(widths) - 1) <= width:
        print(line(head))
        for r in rows:
            print(line(r))
        return
    key_w = max(len(h) for h in head[1:]) if len(head) > 1 else 0
    for r in rows:
        print(f"{head[0]} {r[0]}")
        for h, c in zip(head[1:], r[1:], strict=True):
            cell = f"  {h.ljust(key_w)}  {c}"
            if len(cell) <= width:  # the common case, without textwrap's cost per cell
                print(cell.rstrip())
            else:
                _say(f"{h.ljust(key_w)}  {c}", "  ", width)


def _describe_data(meas: Measurements) -> str:
    masses = "/".join(f"{m:g}" for m in dict.fromkeys(np.asarray(meas.mass_kg).tolist()))
    return (
        f"{meas.n_rows} states, {len(meas.configs)} configurations, payloads {masses} kg, "
        f"{meas.n_values} values on {', '.join(meas.measured_channels)}"
    )


def _stages(names: list[str], command: str) -> Any:
    """A progress bar over the named stages of a command (eodarm.progress: on stderr, on a
    terminal only, once the work has run 2 s); ``with _stages([...], "diagnose") as step:``
    then ``step(name)`` before each stage."""
    from eodarm.progress import stages

    return stages(names, f"eodarm {command}")


def _next(*argv: str) -> None:
    """The ``next:`` line on stderr (stdout is data): the command to run next."""
    import shlex

    words = ["eodarm:", "next:", "eodarm", *(shlex.quote(a) for a in argv)]
    lines = [words[0]]
    for w in words[1:]:  # wrapped as the shell continues a line, so that it pastes whole
        if len(lines[-1]) + 1 + len(w) + 2 > WIDTH:
            lines[-1] += " \\"
            lines.append("  " + w)
        else:
            lines[-1] += " " + w
    NEXT[:] = ["\n".join(lines)]


def _arm_argv(args: argparse.Namespace, always: bool = False) -> list[str]:
    """``--arm FILE`` as the user gave it; without one, nothing, or with ``always`` the file
    of the default arm (for data that will not be bundled data: a synthetic file)."""
    if getattr(args, "arm", None):
        return ["--arm", args.arm]
    if not always:
        return []
    from eodarm.data.datasets import bundled_arm_path

    return ["--arm", str(bundled_arm_path(DEFAULT_DATASET))]


def _plots(
    dirname: str | None,
    meas: Measurements,
    before: FitResult,
    after: FitResult,
    effects: list[Effect],
    arm: Arm,
    self_weight: bool,
    steps: list[dict[str, Any]] | None = None,
    model_kw: dict[str, Any] | None = None,
) -> None:
    """The command's figures into ``dirname``; ``model_kw`` (``_model_kw``) is the model that
    solves where a figure solves (the deflection shares)."""
    if not dirname:
        return

    from eodarm.viz import plots

    out = Path(dirname)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    p = out / "measured_vs_model.png"
    plots.measured_vs_model(meas, {"before": before, "after": after}, path=p)
    written.append(p)
    p = out / "residual_vs_payload.png"
    plots.residual_vs_payload(meas, before, after, path=p)
    written.append(p)
    if effects:
        p = out / "deflection_share.png"
        plots.deflection_share(
            arm, meas, effects, self_weight=self_weight, path=p, **(model_kw or {})
        )
        written.append(p)
    if steps:
        p = out / "ladder.png"
        plots.ladder(steps, path=p)
        written.append(p)
    _note("wrote " + ", ".join(str(w) for w in written))


def data_command(sub: Any, name: str, helptext: str, desc: str) -> argparse.ArgumentParser:
    c = sub.add_parser(name, help=helptext, description=desc)
    c.add_argument("measurements", metavar="MEAS.csv", help="measurement file (CONTRACT §3)")
    c.add_argument(
        "--arm",
        metavar="ARM.toml",
        help="arm file (default: the bundled data set's arm when MEAS.csv is bundled data; "
        "required otherwise)",
    )
    c.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    c.add_argument("--plot", metavar="DIR", help="write PNG figures into DIR")
    c.add_argument(
        "--no-self-weight",
        action="store_true",
        help="the measured arm carried no self-weight in the model",
    )
    _model_args(c)
    _effects_args(c)
    return c
