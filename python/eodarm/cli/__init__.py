"""The ``eodarm`` command line: one module per command, each with ``add_parser`` and ``run``.

Data goes to stdout, messages to stderr. Exit status: 0 on success, 2 on bad input (with a
one-line reason on stderr), 1 on an unexpected internal error. This package is the only place
that parses command lines.
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import sys
import traceback
import warnings
from collections.abc import Sequence
from typing import Any, NoReturn

from eodarm._version import __version__
from eodarm.cli._help import HELP, NEGATIVE_VALUE
from eodarm.errors import EodarmError

# One BLAS thread unless the user says otherwise, set before numpy is imported (nothing above
# imports it): eodarm's linear algebra is on tall, narrow matrices (values × a few
# parameters), where a threaded BLAS gains nothing, and the compiled core runs its own
# threads. On a busy 2-core machine a two-thread dot product of 10 500 values took 14–36 ms
# instead of 0.01 ms (docs/benchmarks.md, "Scaling").
for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

__all__ = ["COMMANDS", "main"]

#: The commands, in the order of ``eodarm --help``: each is the module of that name here.
COMMANDS = tuple(HELP)


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line on stderr, exit status 2, like every other bad input; a value
    that starts with ``-`` (a negative angle first in a list) is a value, not an option."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_VALUE

    def error(self, message: str) -> NoReturn:
        m = re.match(r"argument (--[\w-]+)(?:/\S+)?: expected one argument", message)
        if m:  # the value started with "-" and looked like an option
            message += f" (a value that starts with '-' is given as {m[1]}=VALUE)"
        self.exit(2, f"{self.prog}: error: {message}\n")


def _parser(argv: Sequence[str]) -> argparse.ArgumentParser:
    """The parser, with only the chosen command's module imported: the others are listed by
    their help line, so that ``eodarm --help`` and each command start without importing the
    rest (numpy, the compiled core, matplotlib, xarray)."""
    p = _Parser(
        prog="eodarm",
        description="Why does the arm not go where its model says? Solve, compare and diagnose "
        "the statics, compliance and backlash of planar arms driven by linear actuators.",
    )
    p.add_argument("--version", action="version", version=f"eodarm {__version__}")
    p.add_argument(
        "--debug",
        action="store_true",
        help="on an error, show its traceback instead of the one-line reason",
    )
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    chosen = next((a for a in argv if not a.startswith("-")), None)
    for name in COMMANDS:
        if name == chosen:
            importlib.import_module(f"eodarm.cli.{name}").add_parser(sub)
        else:
            sub.add_parser(name, help=HELP[name], add_help=False)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``eodarm`` command; returns the exit status.

    Warnings raised while a command runs (an ignored key of an arm file, say) are held back:
    after a success they are printed as notes on stderr, each once, followed by the held
    notes (where σ came from, which arm was used, what was written) and the ``next:`` line;
    after a failure (or an interruption) only its one line is printed, so that bad input
    always gives exactly one line.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = _parser(argv)
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    from eodarm.cli import _common

    _common.HELD.clear()
    _common.NEXT.clear()
    _common.HOLD[0] = True
    _common.PARSER[:] = [_parser]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            from eodarm.cli._common import load_effects

            load_effects(args)  # --effects FILE.py and installed packages' effects
            code = int(args.func(args))
        except (EodarmError, ValueError) as exc:  # ValueError: e.g. eodarm._core.CoreError
            _error(exc, args.debug)
            return 2
        except BrokenPipeError:  # e.g. `eodarm diagnose ... | head`
            sys.stderr.close()
            return 0
        except OSError as exc:
            _error(exc, args.debug)
            return 2
        except KeyboardInterrupt:
            print("eodarm: interrupted", file=sys.stderr)
            return 130
        finally:
            _common.HOLD[0] = False
    if code != 0:  # interrupted (130): the one line that says what is on disk is all
        return code
    _notes(caught)
    for line in _common.HELD:  # which arm was used
        _common._say(line, file=sys.stderr)
    for line in _common.NEXT:  # what to run next, last (already wrapped)
        print(line, file=sys.stderr)
    return code


def _error(exc: BaseException, debug: bool = False) -> None:
    """The one line of a failed command (a message is never more than one line); with
    ``--debug`` the traceback instead (with the exception it came from, e.g. in a
    user-written effect)."""
    if debug:
        traceback.print_exception(exc, file=sys.stderr)
        return
    from eodarm.errors import MAX_MESSAGE, show, show_source

    if isinstance(exc, OSError) and exc.strerror and exc.filename is not None:
        text = f"{show_source(exc.filename)}: {exc.strerror}"  # not a bare [Errno 2]
    else:
        # a safety net: every message of bad input is one line under MAX_MESSAGE already
        text = show(" ".join(str(exc).split()) or type(exc).__name__, 4 * MAX_MESSAGE)
    print(f"eodarm: error: {text}", file=sys.stderr)


#: At most this many notes after a command (the rest are counted).
MAX_NOTES = 5


def _notes(caught: list[warnings.WarningMessage]) -> None:
    import textwrap

    seen = list(dict.fromkeys(" ".join(str(w.message).split()) for w in caught))
    for text in seen[:MAX_NOTES]:
        print(textwrap.fill(f"eodarm: note: {text}", 100, subsequent_indent="  "), file=sys.stderr)
    if len(seen) > MAX_NOTES:
        print(f"eodarm: note: … and {len(seen) - MAX_NOTES} more", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
