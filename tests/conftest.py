"""What every test starts from, whatever ran before it.

**Ctrl-C.** Each test starts with Python's own SIGINT handler (``signal.default_int_handler``:
a SIGINT raises KeyboardInterrupt) and must end with it. A process does not always start
so: one started in the background by a shell without job control (``cmd &`` in a script, a
CI runner) inherits SIGINT *ignored*, and Python then leaves it ignored, so that a SIGINT a
test sends, by ``signal.raise_signal`` or ``_thread.interrupt_main``, does nothing at all
(the tests of Ctrl-C once failed so: "DID NOT RAISE KeyboardInterrupt", exit 0 instead of
130). A test that leaves another handler behind (its own, or one of the sweep's writes that
hold Ctrl-C) fails at its teardown, naming the handler, and the next test starts clean.

**Hypothesis and the clock.** The tests run on any machine, under load: hypothesis's two
wall-clock checks are off for every test (its ``deadline`` per example, and the ``too_slow``
health check on drawing the inputs). A loop of the whole suite at the lowest priority beside
other work once saw one draw take 188 s (the process stopped while it drew) and failed
``test_extras_rust_equals_numpy`` on "Input generation is slow", not on a result.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile("anywhere", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("anywhere")


@pytest.fixture(autouse=True)
def python_handles_sigint() -> Iterator[None]:
    if threading.current_thread() is not threading.main_thread():
        yield  # signal handlers belong to the main thread; another cannot set them
        return
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
        left = signal.getsignal(signal.SIGINT)
    finally:
        signal.signal(signal.SIGINT, inherited)
    assert left is signal.default_int_handler, f"the test left SIGINT handled by {left!r}"
