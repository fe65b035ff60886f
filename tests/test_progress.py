"""The one progress rule (eodarm.progress): on stderr, only on a terminal unless asked."""

from __future__ import annotations

import io
import sys

import pytest

from eodarm.progress import bar, stages


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_no_bar_when_stderr_is_not_a_terminal_unless_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    assert bar(10, "job") is None
    assert bar(10, "job", progress=False) is None
    b = bar(10, "job", progress=True)
    assert b is not None
    b.update(10)
    b.close()
    assert "job" in sys.stderr.getvalue()


def test_on_a_terminal_the_bar_shows_stage_names(monkeypatch: pytest.MonkeyPatch) -> None:
    err = _Tty()
    monkeypatch.setattr(sys, "stderr", err)
    with stages(["reading", "fitting"], "eodarm report", progress=True) as step:
        step("reading")
        step("fitting")
    text = err.getvalue()
    assert "eodarm report" in text and "fitting" in text
    assert bar(5, "quiet", progress=False) is None


def test_stages_without_a_bar_is_a_no_op(monkeypatch: pytest.MonkeyPatch) -> None:
    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    with stages(["a", "b"], "job") as step:
        step("a")
        step("b")
    assert err.getvalue() == ""
