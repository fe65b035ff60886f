"""The rule of every output (docs/terminal.md, "Nothing overwritten without asking"): an
existing file replaced only with ``--force``, never an input of the run nor a folder, and the
free names that a ``next:`` line proposes. The writes themselves are :mod:`eodarm.atomic`'s.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from eodarm.errors import EodarmError


def _free_name(name: str) -> str:
    """``name``, or ``stem-2.ext``, ``stem-3.ext`` … (in the same folder) the first that does
    not exist: an output the ``next:`` line proposes is never one that would be refused
    (``--force``)."""
    p = Path(name)
    k = 2
    while p.exists() or p.is_symlink():
        p = p.with_name(f"{Path(name).stem}-{k}{Path(name).suffix}")
        k += 1
    return str(p)


def _force_arg(p: argparse.ArgumentParser, what: str) -> None:
    """``--force``: overwrite ``what`` (refused without it; docs/terminal.md, "Nothing
    overwritten without asking"). A command's own inputs are never overwritten."""
    p.add_argument(
        "--force", action="store_true", help=f"overwrite {what} (never one of the inputs)"
    )


#: The options whose files a command reads, and how a refusal names them.
_INPUT_ARGS = (
    ("measurements", "the measurement file"),
    ("campaign", "the campaign file"),
    ("arm", "the --arm file"),
    ("poses", "the --poses file"),
    ("effects", "the --effects file"),
    ("fixed", "the --fixed file"),
)
#: The inputs that may be a campaign file, whose records are then inputs too.
_CAMPAIGN_INPUTS = ("the measurement file", "the campaign file", "the --fixed file")


def _inputs(args: argparse.Namespace) -> list[tuple[str, str]]:
    """``(path, what)`` of every file the command reads: its measurement or campaign file,
    ``--arm``, ``--poses``, ``--effects``, ``--fixed`` and, for a campaign (given as the
    data or as ``--fixed``), the records it lists; and the bundled data sets' files, which a
    command reads when no ``--arm`` or no data are given (the package's own data are never
    an output)."""
    import warnings

    from eodarm.data import datasets
    from eodarm.data.records import is_campaign, read_campaign
    from eodarm.errors import show_source

    out: list[tuple[str, str]] = []
    for attr, what in _INPUT_ARGS:
        given = getattr(args, attr, None)
        for path in given if isinstance(given, list) else [given] if given else []:
            out.append((str(path), what))
    for path, what in list(out):
        if what in _CAMPAIGN_INPUTS and is_campaign(path):
            try:
                with warnings.catch_warnings():  # its notes are the reading's to give
                    warnings.simplefilter("ignore")
                    camp = read_campaign(path)
            except EodarmError:
                continue  # refused with its own line when it is read
            out += [
                (str(r.file), f"a record of the campaign {show_source(path, 80)}")
                for r in camp.records
            ]
    for name in datasets.names():
        root = datasets.bundled_arm_path(name).parent
        out += [
            (str(f), f"the bundled {name} data set's {f.name}")
            for f in sorted(root.iterdir())
            if f.is_file()
        ]
    return out


def _same_file(a: str | Path, b: str | Path) -> bool:
    """Whether two spellings name one file: a symlink, a hard link, ``./x``, relative and
    absolute (``os.path.samefile``; by their resolved paths where one does not exist)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def _claim(
    args: argparse.Namespace,
    path: str | Path,
    flag: str,
    force: bool | None = None,
    folder: bool = False,
) -> None:
    """The rule of every output (docs/terminal.md, "Nothing overwritten without asking"),
    checked before any work: ``path`` is never one of the run's inputs, even with
    ``--force``, and an existing ``path`` is replaced only with ``--force``. (The write
    itself goes through :mod:`eodarm.atomic`: whole or not at all.) ``force`` overrides
    ``args.force`` (a resumed sweep: the overwrite was asked for when it started).

    A file output is never put where a folder is (``-o data`` for ``-o data/meas.csv``
    would have deleted the folder with everything in it); a ``folder`` output (a Zarr
    sweep) replaces an existing folder only when it is empty or a previous Zarr result.

    Raises
    ------
    EodarmError
        One line naming the path, and the input it is or the way out.
    """
    from eodarm.errors import MESSAGE_ROOM, show, show_source

    named = f"{flag} {show_source(path, 80)}" if flag else show_source(path, 80)
    inputs = _inputs(args)
    for given, what in inputs:
        if _same_file(path, given):
            same = "" if str(given) == str(path) else f" ({show_source(given, 80)})"
            raise EodarmError(
                show(
                    f"{named}: is {what}{same}, an input of this run; choose another name "
                    "(--force never replaces an input)",
                    MESSAGE_ROOM,
                )
            )
    if Path(path).is_dir():  # a folder replaced whole (a .zarr sweep): no input inside it
        inside = os.path.realpath(path) + os.sep
        for given, what in inputs:
            if os.path.realpath(given).startswith(inside):
                raise EodarmError(
                    show(
                        f"{named}: holds {what} ({show_source(given, 80)}), an input of this "
                        "run; choose another name (--force never replaces an input)",
                        MESSAGE_ROOM,
                    )
                )
    _not_a_users_folder(Path(path), named, folder)
    if force is None:
        force = bool(getattr(args, "force", False))
    if force or not (Path(path).exists() or Path(path).is_symlink()):
        return
    raise EodarmError(f"{named}: exists; give --force to overwrite it, or choose another name")


#: The files at the top of a Zarr store (format 3, format 2): a previous sweep's result.
_ZARR_MARKS = ("zarr.json", ".zgroup", ".zattrs")


def _not_a_users_folder(path: Path, named: str, folder: bool) -> None:
    """Refuse, even with ``--force``, an output that would replace a folder that is not a
    previous result (:func:`_claim`)."""
    if not path.is_dir():
        return
    if not folder:
        raise EodarmError(
            f"{named}: is a folder; give the name of a file (in it, say) — --force never "
            "replaces a folder"
        )
    if any(path.iterdir()) and not any((path / m).is_file() for m in _ZARR_MARKS):
        raise EodarmError(
            f"{named}: is a folder that holds files but no Zarr result (no zarr.json); "
            "--force replaces only a previous result: choose another name"
        )


def _claim_folder(args: argparse.Namespace, folder: str | Path, flag: str) -> None:
    """An output folder: refused when it is a file, and when it holds any file unless
    ``--force`` (they may be the user's edited copies); the files written into it are then
    each checked by :func:`_claim` once their names are known."""
    from eodarm.errors import show_source

    d = Path(folder)
    named = f"{flag} {show_source(folder, 80)}" if flag else show_source(folder, 80)
    if d.exists() and not d.is_dir():
        raise EodarmError(f"{named}: exists and is not a folder")
    if getattr(args, "force", False) or not d.exists() or not any(d.iterdir()):
        return
    raise EodarmError(
        f"{named}: the folder is not empty; give --force to overwrite the files written "
        "into it, or choose an empty folder"
    )
