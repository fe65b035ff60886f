"""The one progress rule (eodarm.progress): on stderr, only on a terminal unless asked."""

from __future__ import annotations

import io
import sys
from pathlib import Path

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


def _bars_at_once(monkeypatch: pytest.MonkeyPatch) -> _Tty:
    """stderr a terminal, and every automatic bar shown at once instead of after 2 s (the rule
    itself is the one tested above)."""
    import functools

    from eodarm import progress

    monkeypatch.setattr(progress, "bar", functools.partial(progress.bar, delay=0.0))
    err = _Tty()
    monkeypatch.setattr(sys, "stderr", err)
    return err


def test_sweep_plot_shows_its_maps_as_stages_on_a_terminal(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from eodarm.cli import main

    err = _bars_at_once(monkeypatch)
    args = ["sweep", "--alpha1", "60:100:3", "--alpha2", "0:20:3", "--alpha3", "0:0:1"]
    assert main([*args, "--mass", "5", "--add", "mount_compliance@M2=600"]) == 0
    assert "sweep --plot" not in err.getvalue()  # no maps asked, no map bar
    assert main([*args, "--mass", "5", "--plot", str(tmp_path)]) == 0
    text = err.getvalue()
    assert "eodarm sweep --plot" in text and "who makes the sag" in text


def test_compare_plot_shows_progress_on_a_terminal_only(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from eodarm.cli import main
    from eodarm.data import datasets

    meas = str(datasets.load("seed2022", tables=False).root / "measurements.csv")
    err = _bars_at_once(monkeypatch)
    assert main(["compare", meas, "--plot", str(tmp_path)]) == 0
    assert "eodarm --plot" in err.getvalue() and "eodarm compare" in err.getvalue()
    quiet = io.StringIO()
    monkeypatch.setattr(sys, "stderr", quiet)
    assert main(["compare", meas, "--plot", str(tmp_path)]) == 0
    assert "eodarm --plot" not in quiet.getvalue()
