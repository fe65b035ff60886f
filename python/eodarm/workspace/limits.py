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

__all__ = ["available_memory", "check_disk", "check_memory", "free_disk", "sci"]

#: What a refused sweep can do instead (both the API's and the command line's names).
_HINT = "reduce the grid, reduce it while it runs (reduce=, --reduce)"


def sci(x: float) -> str:
    """``1.5e17``: a count or a size in one short word."""
    mantissa, exponent = f"{x:.1e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def _meminfo_available() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _cgroup_available() -> int | None:
    """Room left under a cgroup-v2 memory limit (containers), None without one."""
    base = Path("/sys/fs/cgroup")
    try:
        limit = (base / "memory.max").read_text().strip()
        if limit == "max":
            return None
        used = int((base / "memory.current").read_text().strip())
        return max(int(limit) - used, 0)
    except (OSError, ValueError):
        return None


def available_memory() -> int | None:
    """Bytes of memory a sweep's output may take now, None if the system does not say.

    ``MemAvailable`` of ``/proc/meminfo`` (Linux: free memory plus what the kernel can
    reclaim), else the physical memory (``os.sysconf``: ``SC_PHYS_PAGES`` × ``SC_PAGE_SIZE``);
    under a cgroup-v2 memory limit (a container), at most the room left under it.
    """
    avail = _meminfo_available()
    if avail is None:
        try:
            avail = int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
        except (AttributeError, ValueError, OSError):
            avail = None
    cgroup = _cgroup_available()
    if cgroup is not None:
        avail = cgroup if avail is None else min(avail, cgroup)
    return avail


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
