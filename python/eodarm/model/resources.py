"""What the machine has: the memory an output may take, checked before it is allocated.

A solve (and a sweep, ``eodarm.workspace.limits``) counts the bytes of its output from the
shapes alone and refuses, with the estimate, what cannot fit, so that running out of memory
is a clear :class:`~eodarm.errors.OutOfMemoryError` (a ``MemoryError``) and never an abort
of the interpreter inside the compiled core.
"""

from __future__ import annotations

import os
import resource
from pathlib import Path

from eodarm.errors import OutOfMemoryError

__all__ = ["available_memory", "check_output_memory", "sci"]


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


def _address_space_left() -> int | None:
    """Room left under the process's address-space limit (``ulimit -v``), None without one."""
    try:
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft == resource.RLIM_INFINITY:
            return None
        with open("/proc/self/statm", encoding="ascii") as f:
            pages = int(f.read().split()[0])
        return max(soft - pages * os.sysconf("SC_PAGE_SIZE"), 0)
    except (OSError, ValueError, IndexError):
        return None


def available_memory() -> int | None:
    """Bytes of memory a sweep's output may take now, None if the system does not say.

    ``MemAvailable`` of ``/proc/meminfo`` (Linux: free memory plus what the kernel can
    reclaim), else the physical memory (``os.sysconf``: ``SC_PHYS_PAGES`` × ``SC_PAGE_SIZE``);
    under a cgroup-v2 memory limit (a container) or an address-space limit (``ulimit -v``), at
    most the room left under it.
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
    rlimit = _address_space_left()
    if rlimit is not None:
        avail = rlimit if avail is None else min(avail, rlimit)
    return avail


def solve_output_bytes(rows: int, n: int) -> int:
    """Bytes that ``rows`` solved states of an n-link arm take, as much again counted for the
    inputs' copies and the checks on the way: 8 (rows, n) float64 outputs (forces, torques,
    their changes, angles, lengths), the (rows, n, 2) reactions, dx, dy and the status."""
    return 2 * rows * (8 * (10 * n + 2) + 1)


def check_output_memory(nbytes: int, what: str) -> None:
    """Refuse an output of ``nbytes`` that cannot fit in the memory available now.

    Raises
    ------
    OutOfMemoryError
        With the estimate and what is available, in one line.
    """
    avail = available_memory()
    if avail is not None and nbytes > avail:
        raise OutOfMemoryError(
            f"{what} would need {sci(nbytes)} bytes of output; {sci(avail)} are available: "
            "solve fewer poses at a time"
        )
