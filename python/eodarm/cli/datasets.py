"""``eodarm datasets``: list and export the bundled data sets."""

from __future__ import annotations

import argparse
from typing import Any

from eodarm.cli._common import _note, _say
from eodarm.cli._help import HELP
from eodarm.cli._outputs import _claim_folder, _force_arg
from eodarm.errors import EodarmError


def run(args: argparse.Namespace) -> int:
    from eodarm.data import datasets

    if args.action == "list":
        for name in datasets.names():
            ds = datasets.load(name)
            _say(f"{name}: {ds.description}")
        return 0
    if args.action == "export":
        if not args.name or not args.directory:
            raise EodarmError("usage: eodarm datasets export NAME DIR")
        _claim_folder(args, args.directory, "")
        written = datasets.export(args.name, args.directory)
        for p in written:
            print(p)
        _note(f"wrote {len(written)} files of '{args.name}' to {args.directory}")
        return 0
    raise EodarmError(f"unknown datasets action '{args.action}'")


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register ``eodarm datasets`` on the sub-parser collection."""
    ds = sub.add_parser(
        "datasets",
        help=HELP["datasets"],
        description="List the bundled data sets, or export one (arm files, measurements, "
        "the paper's tables and the provenance notes) into a directory.",
    )
    ds.add_argument("action", choices=("list", "export"))
    ds.add_argument("name", nargs="?", help="data set name, e.g. seed2022")
    ds.add_argument("directory", nargs="?", metavar="DIR", help="where to write (export)")
    _force_arg(ds, "the data set's files in a non-empty DIR (export)")
    ds.set_defaults(func=run)
    return ds
