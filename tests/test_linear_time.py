"""Files of load sequences are read in linear time (issue 27 item 6).

A file with a ``step`` column was read in quadratic time: the repeats' states
(``noise.sequence_state_groups``) and the sequences (``Measurements.sequences``) looped over
labels × rows (compare took 0.5 s at 5 000 rows, 18 s at 50 000, 404 s at 200 000). The work
is counted here, not timed: the lines of eodarm's Python executed (``sys.settrace``) plus the
array elements handed to numpy's functions (each wrapped to count the sizes of its array
arguments). Ten times the rows must cost at most twenty times the work; a loop over labels ×
rows costs a hundred times.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np
import pytest

import eodarm
from eodarm.analysis.sequences import hysteresis, layout
from eodarm.analysis.synth import synth
from eodarm.data import noise
from eodarm.data.reader import read_measurements

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "example_arm.toml"
PACKAGE = str(Path(eodarm.__file__).parent)
#: numpy functions whose array arguments count as work (those the readers use, and more).
COUNTED = (
    "flatnonzero nonzero where argsort sort lexsort unique split diff concatenate isin "
    "array_equal bincount cumsum any all sum argmax ix_ repeat tile full zeros"
).split()


def counted_work(call: Callable[[], Any], monkeypatch: pytest.MonkeyPatch) -> int:
    """Lines of eodarm's own code executed by ``call()`` plus array elements passed to the
    :data:`COUNTED` numpy functions."""
    work = 0

    def size(x: Any) -> int:
        return int(x.size) if isinstance(x, np.ndarray) else 0

    with monkeypatch.context() as m:
        for name in COUNTED:
            real = getattr(np, name)

            def wrapped(*args: Any, _real: Any = real, **kwargs: Any) -> Any:
                nonlocal work
                work += sum(size(a) for a in (*args, *kwargs.values()))
                return _real(*args, **kwargs)

            m.setattr(np, name, wrapped)

        def local(frame: FrameType, event: str, arg: Any) -> Any:
            nonlocal work
            if event == "line":
                work += 1
            return local

        def tracer(frame: FrameType, event: str, arg: Any) -> Any:
            return local if frame.f_code.co_filename.startswith(PACKAGE) else None

        sys.settrace(tracer)
        try:
            call()
        finally:
            sys.settrace(None)
    return work


def step_file(tmp_path: Path, configs: int) -> Path:
    """``configs`` load cycles 0 → 1.5 → 5 → 6.5 → 5 → 1.5 → 0 kg, one label each, written
    as a measurement file with a step column (6 rows per label)."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    alpha = np.tile([[90.0, 10.0, 0.0], [100.0, 0.0, -10.0]], (configs // 2, 1))
    meas = synth(arm, alpha, [0, 1.5, 5, 6.5, 5, 1.5, 0], channels="dy_mm,dl", sequence=True)
    path = tmp_path / f"seq{configs}.csv"
    meas.to_csv(path)
    return path


def test_reading_a_step_file_is_linear_in_its_rows(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    small, large = step_file(tmp_path, 200), step_file(tmp_path, 2000)

    def use(path: Path) -> Callable[[], Any]:
        def run() -> None:
            meas = read_measurements(path, 3)  # the repeats' states: sequence_state_groups
            meas.sequences()
            layout(meas)
            hysteresis(meas, np.zeros(meas.values.shape))

        return run

    w_small = counted_work(use(small), monkeypatch)
    w_large = counted_work(use(large), monkeypatch)
    assert w_large <= 20 * w_small, (w_small, w_large, w_large / w_small)


def test_the_states_of_one_long_sequence_are_numbered_in_linear_time(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """One label of many states: each state's history (the payloads before it) is a key of
    its own. Kept as a tuple of every payload before it, it cost the square of the length
    in copies and in memory; numbered by a trie, one entry per state. Counted: the work as
    above, and the memory held at the peak (tracemalloc, which numpy reports to)."""
    import tracemalloc

    def groups(rows: int) -> Callable[[], Any]:
        mass = np.tile([1.5, 5.0, 6.5, 5.0, 1.5, 0.0], rows // 6)
        alpha = np.tile([90.0, 10.0, 0.0], (rows, 1))
        return lambda: noise.sequence_state_groups(
            ["c1"] * rows, alpha, mass, np.arange(1, rows + 1), np.zeros(rows, dtype=bool)
        )

    def peak(call: Callable[[], Any]) -> int:
        tracemalloc.start()
        try:
            call()
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    small, large = groups(3000), groups(30000)
    assert counted_work(large, monkeypatch) <= 20 * counted_work(small, monkeypatch)
    assert peak(large) <= 20 * peak(small), (peak(small), peak(large))


def test_the_sequences_are_those_of_a_mask_per_label() -> None:
    """The group-by gives what a mask per label gave: labels in the order they first appear
    (a reference row counts), rows in ascending step, references left out."""
    arm = eodarm.Arm.from_toml(EXAMPLE)
    rng = np.random.default_rng(4)
    labels = np.array(["b", "a", "c", "a", "b", "c", "a", "b", "d"])
    step = np.array([3, 2, 0, 0, 1, 2, 5, 2, 0])
    mass = np.where(step == 0, 0.0, 1.5 * step)
    alpha = np.array([[90.0, 10.0, 0.0]] * labels.size)
    meas = eodarm.Measurements.from_arrays(
        labels, alpha, mass, {"dy_mm": -rng.random(labels.size) * (mass > 0)}, step=step
    )
    del arm
    expect = []
    for label in dict.fromkeys(labels.tolist()):
        rows = np.flatnonzero((labels == label) & ~meas.reference)
        if rows.size:
            expect.append(rows[np.argsort(step[rows], kind="stable")].tolist())
    assert [s.tolist() for s in meas.sequences()] == expect
    assert expect == [[4, 7, 0], [1, 6], [5]]  # "d": its one row is its reference
