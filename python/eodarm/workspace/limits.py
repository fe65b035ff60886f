"""What a sweep may take: the memory and disk its output needs against what the machine has.

A sweep is checked before anything of its grid's size is built: its output (every per-cell
and per-pose array, or the reduced ones) is counted from the grid's shape alone, and a sweep
whose output cannot fit is refused in one line that gives the estimate
(``docs/sweeps.md``, "Size checks").
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from eodarm.errors import SweepTooLargeError
from eodarm.model.resources import available_memory, sci

__all__ = ["available_memory", "check_disk", "check_memory", "free_disk", "sci"]

#: What a refused sweep can do instead (both the API's and the command line's names).
_HINT = "reduce the grid, reduce it while it runs (reduce=, --reduce)"


def free_disk(path: str | os.PathLike[str]) -> int | None:
    """Free bytes on the file system that holds ``path`` (or would: its nearest existing
    parent), None if it cannot be asked."""
    p = Path(path).absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        return int(shutil.disk_usage(p).free)
    except OSError:
        return None


def check_memory(cells: int, nbytes: int) -> None:
    """Refuse a sweep whose output (``nbytes``) would not fit in the memory available.

    Raises
    ------
    SweepTooLargeError
        In one line, with the estimate and what the machine has.
    """
    avail = available_memory()
    if avail is not None and nbytes > avail:
        raise SweepTooLargeError(
            f"sweep: {sci(cells)} cells would need {sci(nbytes)} bytes of output; the machine "
            f"has {sci(avail)} available: {_HINT} or write it chunk by chunk to Zarr "
            "(-o OUT.zarr)"
        )


def check_disk(cells: int, nbytes: int, path: str | os.PathLike[str]) -> None:
    """Refuse to write ``nbytes`` (uncompressed) where the disk has less free.

    Raises
    ------
    SweepTooLargeError
        In one line, with the estimate and the free space.
    """
    free = free_disk(path)
    if free is not None and nbytes > free:
        raise SweepTooLargeError(
            f"sweep: {sci(cells)} cells would need {sci(nbytes)} bytes in {path}; its disk "
            f"has {sci(free)} free: {_HINT} or write it elsewhere"
        )
