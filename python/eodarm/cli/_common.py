"""What every command shares: arm and effect arguments, the model switch, reading
measurements, number formatting, tables and figures.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
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
#: ``report``'s output when no ``-o`` is given.
DEFAULT_REPORT = "eodarm-report.html"


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
        _note(f"no --arm: used the bundled {DEFAULT_DATASET} arm '{arm.name}' ({arm.n} links)")
        return arm
    name = datasets.dataset_of(measurements)
    if name is None:
        raise EodarmError(
            f"{measurements}: give the arm these were measured on with --arm ARM.toml (only "
            "bundled data have a known arm)"
        )
    arm = datasets.bundled_arm(name)
    _note(f"no --arm: these are the bundled {name} data; used their arm '{arm.name}'")
    return arm


#: ``--arm`` of a command that reads no measurements.
ARM_HELP = f"arm file (default: the bundled {DEFAULT_DATASET} arm)"


def check_kinds_of(arm: Arm, specs: Sequence[str] | None, flag: str = "--add") -> None:
    """Refuse, before anything is solved, an ``EFFECT@PLACE[=VALUE]`` of ``specs`` at a joint
    of the wrong kind (an actuator's effect at a rotary drive, a drive's at a linear
    actuator), in one line naming the flag, the effect and what applies there."""
    from eodarm.model.effects import Slot, kind_mismatch

    for spec in specs or []:
        try:
            slot = Slot.parse(spec.partition("=")[0].strip())
            why = kind_mismatch(slot.example, arm.kinds)
        except EodarmError:
            continue  # the effect's own parser names what is wrong with it
        if why is not None:
            raise EodarmError(f"{flag} {spec}: {why}")


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
        from eodarm.model.effects import did_you_mean, known_effects

        known = known_effects()
        raise EodarmError(
            f"{flag} '{spec}': unknown effect '{name}'{did_you_mean(name, known)}; known: "
            f"{', '.join(known)} (user-written effects come with --effects FILE.py)"
        )
    try:
        x = float(value)
    except ValueError:
        raise EodarmError(f"{flag} '{spec}': '{value}' is not a number") from None
    return Effect.parse(head.strip(), **{kind.param: x})


def _effects_args(p: argparse.ArgumentParser) -> None:
    """``--effects FILE.py``: user-written effects (custom-effects.md), loaded before any effect is
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
    """A message on stderr, ``eodarm: …``, wrapped within :data:`WIDTH` columns.

    Under the main CLI (:data:`HOLD`) it is held until the command has succeeded, like every
    note: a refusal that comes after it (a pose that cannot close, a bad ``-o``) is then the
    one line on stderr (docs/terminal.md, "One line on a refusal").
    """
    if HOLD[0]:
        HELD.append(f"eodarm: {msg}")
        return
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
#: The command line's parser factory (``eodarm.cli._parser``), handed over by ``main`` so that
#: this module need not import the package that imports it (no import cycle).
PARSER: list[Callable[[Sequence[str]], argparse.ArgumentParser]] = []


def _read(
    path: str, arm: Arm, self_weight: bool = True, record_figures: list[str] | None = None
) -> Measurements:
    """Read the measurements, refuse the states the arm cannot take
    (:func:`eodarm.data.plausible.check_states`: out of stroke, cannot close under load,
    radians, grams) and say on stderr, once the command has succeeded, where σ was not
    given: one line for the channels whose σ was pooled from the repeats, one for those that
    use the defaults.

    A campaign file (docs/records.md) is run through ``eodarm records`` first; with
    ``record_figures`` (a list) each record's figure is appended to it as HTML."""
    from eodarm.data.plausible import check_states
    from eodarm.data.reader import read_measurements
    from eodarm.data.records import is_campaign

    hint: str | None = None
    if is_campaign(path):
        # its masses_kg in grams? said in a note, and first in a refusal of its rows
        meas, hint = _read_campaign_as_measurements(path, arm, record_figures)
    else:
        meas = read_measurements(path, arm.n)
    with _Hinted(hint):
        check_states(arm, meas, self_weight=self_weight)
    for line in _noise_notes(meas):
        _note(line)
    return meas


class _Hinted:
    """A context whose refusals carry a hint first in their one line (reusable)."""

    def __init__(self, hint: str | None) -> None:
        self.hint = hint

    def __enter__(self) -> _Hinted:
        return self

    def __exit__(self, kind: Any, exc: BaseException | None, tb: Any) -> None:
        if self.hint is None or not isinstance(exc, (EodarmError, ValueError)):
            return  # ValueError: the core's errors
        from eodarm.errors import MESSAGE_ROOM, show

        text = f"{self.hint}; {' '.join(str(exc).split())}"  # the likely cause first
        raise EodarmError(show(text, MESSAGE_ROOM)) from None


def _payload_hint(arm: Arm, masses: Sequence[float] | np.ndarray, flag: str = "--mass") -> _Hinted:
    """The payload hint of :func:`eodarm.data.plausible.payload_hint` for the largest of
    ``masses`` (``--mass 5000``: is it grams?): a note (held until the command succeeds),
    and a context whose refusals carry the hint first in their one line:
    ``with _payload_hint(arm, masses): ...``."""
    from eodarm.data.plausible import payload_hint

    heavy = float(np.max(masses)) if len(masses) else 0.0
    hint = payload_hint(heavy, arm)
    if hint is not None:
        hint = f"{flag} {hint}"
        _note(hint)
    return _Hinted(hint)


def _check_data(meas: Measurements, arm: Arm, self_weight: bool, model_kw: Any) -> list[Any]:
    """The mistakes the data look like (:func:`eodarm.analysis.datacheck.check_data`), each
    said in a note on stderr (``check the data: …``); the checks, for the JSON."""
    from eodarm.analysis.datacheck import check_data

    checks = check_data(arm, meas, self_weight, **model_kw)
    for c in checks:
        _note(f"check the data: {c.message}")
    return checks


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
    """``36 states, 6 configurations, payloads 1.5, 5, 6.5 and 0 kg, 288 values on …`` (the
    payloads in the order they first appear)."""
    from eodarm.viz.format import listing, plural

    masses = list(dict.fromkeys(np.asarray(meas.mass_kg).tolist()))
    what = "payload" if len(masses) == 1 else "payloads"
    return (
        f"{plural(meas.n_rows, 'state')}, {plural(len(meas.configs), 'configuration')}, "
        f"{what} {listing(masses, 'kg')}, {plural(meas.n_values, 'value')} on "
        f"{', '.join(meas.measured_channels)}"
    )


def _stages(names: list[str], command: str) -> Any:
    """A progress bar over the named stages of a command (eodarm.progress: on stderr, on a
    terminal only, once the work has run 2 s); ``with _stages([...], "diagnose") as step:``
    then ``step(name)`` before each stage."""
    from eodarm.progress import stages

    return stages(names, f"eodarm {command}")


def _next(*argv: str, args: argparse.Namespace | None = None) -> None:
    """The ``next:`` line on stderr (stdout is data): the command to run next.

    With the command's ``args``, the options that the next command needs to see the same
    model are carried over when it takes them (:func:`_carried`): ``--effects FILE.py``,
    ``--model``, ``--elements-per-link``, ``--no-self-weight``.
    """
    import shlex

    if args is not None:
        argv = (*argv, *_carried(args, argv[0], argv))
    words = ["eodarm:", "next:", "eodarm", *(shlex.quote(a) for a in argv)]
    lines = [words[0]]
    for w in words[1:]:  # wrapped as the shell continues a line, so that it pastes whole
        if len(lines[-1]) + 1 + len(w) + 2 > WIDTH:
            lines[-1] += " \\"
            lines.append("  " + w)
        else:
            lines[-1] += " " + w
    NEXT[:] = ["\n".join(lines)]


def _options_of(command: str) -> set[str]:
    """Every option string of ``command`` (``--add``, ``--effects`` …)."""
    if not PARSER:  # not run through eodarm.cli.main: no parser to ask
        return set()
    parser = PARSER[0]([command])
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return set(action.choices[command]._option_string_actions)
    return set()


def _carried(args: argparse.Namespace, command: str, given: Sequence[str] = ()) -> list[str]:
    """The options of ``args`` that the next ``command`` needs in order to run the same model
    (and that it takes, and that ``given`` does not already hold): the user-written effects'
    files (an ``--add`` of theirs is unknown without them), the model (not to a command asked
    for ``--uncertainty``, which is propagated with the analytic model), self-weight."""
    takes = _options_of(command) - set(given)
    out: list[str] = []
    if "--effects" in takes:
        for path in getattr(args, "effects", None) or []:
            out += ["--effects", path]
    uncertainty = "--uncertainty" in given  # propagated with the analytic model only
    if getattr(args, "model", "analytic") != "analytic" and "--model" in takes and not uncertainty:
        out += ["--model", args.model]
        epl = getattr(args, "elements_per_link", None)
        if epl is not None and "--elements-per-link" in takes:
            out += ["--elements-per-link", str(epl)]
    if getattr(args, "no_self_weight", False) and "--no-self-weight" in takes:
        out.append("--no-self-weight")
    return out


def file_part(label: str, taken: set[str] | None = None) -> str:
    """A label (a configuration's, say) as part of a file name: every character but
    letters, digits, ``.``, ``-`` and ``_`` becomes ``_`` (a ``/`` would name a folder, a
    NUL no file at all), cut to 60 characters. With ``taken`` (the parts given so far, to
    which the new one is added), ``-2``, ``-3`` … make two labels that differ only in such
    characters two files."""
    import re

    base = re.sub(r"[^A-Za-z0-9._-]", "_", str(label))[:60].lstrip(".") or "_"
    name, k = base, 2
    while taken is not None and name in taken:
        name, k = f"{base}-{k}", k + 1
    if taken is not None:
        taken.add(name)
    return name


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
    names = [
        "measured vs model",
        "residuals",
        *(["loops"] if meas.has_sequences else []),
        *(["sag budget"] if effects else []),
    ]
    with _stages([*names, *(["ladder"] if steps else [])], "--plot") as step:
        step("measured vs model")
        p = out / "measured_vs_model.png"
        plots.measured_vs_model(meas, {"before": before, "after": after}, path=p)
        written.append(p)
        step("residuals")
        p = out / "residual_vs_payload.png"
        plots.residual_vs_payload(meas, before, after, path=p)
        written.append(p)
        if meas.has_sequences:
            step("loops")
            from eodarm.viz.hysteresis import loops

            p = out / "loops.png"
            loops(meas, before, after, path=p)
            written.append(p)
        if effects:
            step("sag budget")
            p = out / "deflection_share.png"
            plots.deflection_share(
                arm, meas, effects, self_weight=self_weight, path=p, **(model_kw or {})
            )
            written.append(p)
        if steps:
            step("ladder")
            p = out / "ladder.png"
            plots.ladder(steps, path=p)
            written.append(p)
    _note("wrote " + ", ".join(str(w) for w in written))


def data_command(sub: Any, name: str, helptext: str, desc: str) -> argparse.ArgumentParser:
    c = sub.add_parser(name, help=helptext, description=desc)
    c.add_argument("measurements", metavar="MEAS.csv", help="measurement file (docs/formats.md §3)")
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


# ---------------------------------------------------------------------------- the model named
def _model_keys(arm: Arm, added: Any) -> list[str]:
    """The model of a command as ``effect@place`` keys: the arm file's effects (those not given
    again), then the added ones (``--add``: effects or fitted slots), in order, with
    ``:taken_up`` where a gap is taken up. This is the
    JSON ``model`` key of solve, compare, diagnose, fit and compensate (docs/formats.md)."""
    keys = {m.key for m in added}
    return [e.spec for e in arm.effects if e.key not in keys] + [m.spec for m in added]


def _model_words(arm: Arm, added: Any) -> str:
    """The model in a header: ``baseline + mount_compliance@M1, M2 (arm file) +
    joint_clearance@O3``; places of one effect after the first are shortened to the place."""
    keys = [m.spec for m in added]
    given = {m.key for m in added}
    file_keys = [e.spec for e in arm.effects if e.key not in given]
    parts = ["baseline"]
    if file_keys:
        parts.append(f"{_grouped_keys(file_keys)} (arm file)")
    if keys:
        parts.append(_grouped_keys(keys))
    return " + ".join(parts)


def _grouped_keys(keys: list[str]) -> str:
    """``a@M1, a@M2, b@O3`` → ``a@M1, M2, b@O3`` (consecutive keys of one effect)."""
    out: list[str] = []
    last = None
    for k in keys:
        name, _, at = k.partition("@")
        out.append(at if name == last else k)
        last = name
    return ", ".join(out)


# ----------------------------------------------------------------------------- records
def run_records(
    campaign: str,
    allow_drift: bool = False,
    plot_dir: str | None = None,
    min_duration_s: float = 2.0,
    record_figures: list[str] | None = None,
    arm: Arm | None = None,
) -> tuple[list[Any], Any, str | None]:
    """Run the records of a campaign file (docs/records.md), one in memory at a time; draw
    each into ``plot_dir`` when given (the refused one too, before the refusal is raised),
    and as HTML into ``record_figures`` when given (the report's appendix).

    Returns the records' results, ``write(out)``, which writes the measurement file to a
    path or an open text file, and the line of
    :func:`eodarm.data.plausible.campaign_payload_hint` (``masses_kg`` in grams? held against
    ``arm``, or a plain range without it), already said in a note, or None. Nothing is
    written when a record is refused.
    """
    import math

    from eodarm.analysis.records import analyse_campaign
    from eodarm.data.plausible import campaign_payload_hint
    from eodarm.data.records import read_campaign, write_rows

    if not (math.isfinite(min_duration_s) and min_duration_s > 0):
        raise EodarmError(f"--min-duration must be > 0 s, got {min_duration_s}")
    camp = read_campaign(campaign)
    hint = campaign_payload_hint(camp, arm)
    if hint is not None:
        _note(hint)
    drawn: list[str] = []
    parts: set[str] = set()  # the labels' parts of the figures' names
    draw = None
    if plot_dir or record_figures is not None:
        from eodarm.viz.records_plot import MAX_REPORT_RECORDS, record_figure, record_html

        out = Path(plot_dir) if plot_dir else None
        if out is not None:
            out.mkdir(parents=True, exist_ok=True)

        def draw(record: Any, result: Any) -> None:
            if out is not None:
                p = out / f"record_{file_part(result.spec.config, parts)}.png"
                record_figure(record, result, path=p)
                drawn.append(str(p))
            if record_figures is not None and len(record_figures) < MAX_REPORT_RECORDS:
                record_figures.append(record_html(record, result))

    try:
        results = analyse_campaign(camp, allow_drift, min_duration_s, on_record=draw)
    finally:
        if drawn:
            _note(f"drew {len(drawn)} records into {plot_dir}")
    channels = list(dict.fromkeys(c for r in results for c in r.channels))
    rows = [row for r in results for row in r.rows]

    def write(target: Any) -> None:
        write_rows(target, camp.n, rows, channels)

    if any(r.spec.masses_kg[0] != 0 for r in results):
        _note(
            "a record's reference carries a payload (masses_kg[0] > 0): its rows are relative "
            "to that loaded reference"
        )
    return results, write, hint


def _read_campaign_as_measurements(
    path: str, arm: Arm, record_figures: list[str] | None = None
) -> tuple[Measurements, str | None]:
    """A campaign file given where a measurement file goes: run ``eodarm records`` on it
    (saying so on stderr) and read the rows it would write; with the campaign's payload
    hint (:func:`run_records`)."""
    import io

    from eodarm.data.reader import read_measurements

    results, write, hint = run_records(path, record_figures=record_figures, arm=arm)
    buf = io.StringIO()
    write(buf)
    buf.seek(0)
    buf.name = f"{path} (records)"  # type: ignore[attr-defined]
    rows = sum(len(r.rows) for r in results)
    _note(
        f"{path} is a campaign: ran `eodarm records` on it ({rows} states of "
        f"{len(results)} records; docs/records.md)"
    )
    CAMPAIGN_RESULTS[:] = results
    return read_measurements(buf, arm.n), hint


#: The records of the last campaign read by :func:`_read` (for the report's appendix).
CAMPAIGN_RESULTS: list[Any] = []
