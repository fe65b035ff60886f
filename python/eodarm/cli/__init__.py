"""The ``eodarm`` command line: one module per command, each with ``add_parser`` and ``run``.

Data goes to stdout, messages to stderr. Exit status: 0 on success, 2 on bad input (with a
one-line reason on stderr), 1 on an unexpected internal error. This package is the only place
that parses command lines.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Sequence
from typing import NoReturn

from eodarm._version import __version__
from eodarm.cli import compare, compensate, datasets, diagnose, fit, report, solve, sweep, synth
from eodarm.errors import EodarmError

__all__ = ["COMMANDS", "main"]

#: The commands' modules, in the order of ``eodarm --help``; each has ``add_parser`` and ``run``.
COMMANDS = (solve, compare, diagnose, fit, synth, sweep, report, datasets, compensate)


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line on stderr, exit status 2, like every other bad input."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="eodarm",
        description="Why does the arm not go where its model says? Solve, compare and diagnose "
        "the statics, compliance and backlash of planar arms driven by linear actuators.",
    )
    p.add_argument("--version", action="version", version=f"eodarm {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``eodarm`` command; returns the exit status.

    Warnings raised while a command runs (an ignored key of an arm file, say) are held back:
    after a success they are printed as notes on stderr, each once; after a failure only the
    one-line error is printed, so that bad input always gives exactly one line.
    """
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            code = int(args.func(args))
        except (EodarmError, ValueError) as exc:  # ValueError: e.g. eodarm._core.CoreError
            _error(exc)
            return 2
        except BrokenPipeError:  # e.g. `eodarm diagnose ... | head`
            sys.stderr.close()
            return 0
        except OSError as exc:
            _error(exc)
            return 2
        except KeyboardInterrupt:
            print("eodarm: interrupted", file=sys.stderr)
            return 130
    _notes(caught)
    return code


def _error(exc: BaseException) -> None:
    """The one line of a failed command (a message is never more than one line)."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    print(f"eodarm: error: {text}", file=sys.stderr)


#: At most this many notes after a command (the rest are counted).
MAX_NOTES = 5


def _notes(caught: list[warnings.WarningMessage]) -> None:
    seen = list(dict.fromkeys(" ".join(str(w.message).split()) for w in caught))
    for text in seen[:MAX_NOTES]:
        print(f"eodarm: note: {text}", file=sys.stderr)
    if len(seen) > MAX_NOTES:
        print(f"eodarm: note: … and {len(seen) - MAX_NOTES} more", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
