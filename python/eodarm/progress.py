"""Progress bars on stderr for work that takes more than a moment (tqdm).

One rule for every command and API call that reports progress: ``progress=True`` shows the bar
at once, ``False`` never, ``None`` (the default) only when stderr is a terminal and the work is
still running after ``delay`` seconds (2 s by default), so that quick calls, pipes and logs stay
clean. Bars are removed when done (``leave=False``); data never goes to stderr.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

__all__ = ["bar", "stages"]

#: Seconds of work after which an automatic (``progress=None``) bar appears.
DELAY_S = 2.0


def bar(
    total: int,
    desc: str,
    *,
    progress: bool | None = None,
    unit: str = "it",
    unit_scale: bool = False,
    delay: float = DELAY_S,
) -> Any:
    """A tqdm bar over ``total`` units on stderr, or None when no bar is to be shown (see the
    module docstring for ``progress``). Call ``update(k)`` and ``close()`` on it."""
    if progress is False or total <= 0:
        return None
    if progress is None and not _stderr_is_terminal():
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is a dependency
        return None
    return tqdm(
        total=total,
        desc=desc,
        unit=unit,
        unit_scale=unit_scale,
        file=sys.stderr,
        delay=0.0 if progress else delay,
        leave=False,
        dynamic_ncols=True,
    )


@contextmanager
def stages(names: Sequence[str], desc: str, *, progress: bool | None = None) -> Iterator[Any]:
    """A bar over named stages of one job: ``with stages([...], "eodarm report") as step:``
    then ``step("fitting")`` before each stage; the bar shows the stage's name."""
    b = bar(len(names), desc, progress=progress, unit="step")
    started = False

    def step(name: str) -> None:
        nonlocal started
        if b is None:
            return
        if started:
            b.update(1)
        started = True
        b.set_postfix_str(name, refresh=True)

    try:
        yield step
    finally:
        if b is not None:
            b.close()


def _stderr_is_terminal() -> bool:
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False
