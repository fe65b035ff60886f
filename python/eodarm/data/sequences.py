"""The rules of a measurement file with a ``step`` column: each ``config`` label one load
sequence (docs/formats.md §4)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from eodarm.data.cells import Cell, _show
from eodarm.data.channels import channel_names

FloatArray = npt.NDArray[np.float64]


def sequence_rows(
    config: Sequence[str] | npt.ArrayLike,
    step: npt.ArrayLike,
    reference: npt.ArrayLike,
) -> list[npt.NDArray[np.int64]]:
    """The rows of each load sequence in the order its states were applied: one sequence
    per config label, in the order the labels first appear, its rows in ascending step,
    the written reference rows left out (a label with nothing else gives no sequence).

    One sort of all the rows by (label, step), then one cut per label: O(N log N) for N
    rows, whatever the number of labels (a mask per label would cost labels × rows).
    """
    labels = np.asarray(config).ravel()
    steps = np.asarray(step, dtype=np.int64).ravel()
    refs = np.asarray(reference, dtype=bool).ravel()
    if labels.size == 0:
        return []
    _, first, code = np.unique(labels, return_index=True, return_inverse=True)
    rank = np.empty(first.size, dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(first.size)
    rows = np.flatnonzero(~refs)
    key = rank[code.ravel()[rows]]
    order = np.lexsort((steps[rows], key))
    rows, key = rows[order], key[order]
    cuts = np.flatnonzero(np.diff(key)) + 1
    return [part.astype(np.int64) for part in np.split(rows, cuts)] if rows.size else []


def _first_rows(config: Sequence[str], step: npt.NDArray[np.int64]) -> dict[str, int]:
    """Each label's row with the lowest step."""
    first: dict[str, int] = {}
    for r, label in enumerate(config):
        if label not in first or step[r] < step[first[label]]:
            first[label] = r
    return first


def _check_sequences(
    config: Sequence[str],
    alpha: FloatArray,
    mass: FloatArray,
    step: npt.NDArray[np.int64],
    step_given: npt.NDArray[np.bool_],
    values: FloatArray,
    line: npt.NDArray[np.int64],
    step_cells: Sequence[Cell],
) -> list[str]:
    """The rules of a file with a ``step`` column: every problem, one entry per bad row.

    A step that is empty while others are given (a partly empty column), a step that repeats
    within a label, a label whose rows have different angles, a written reference row (the
    first of its label, mass 0) whose channels are not all 0 or empty.
    """
    bad: list[str] = []
    for empty in np.flatnonzero(~step_given).tolist():
        bad.append(
            f"line {line[empty]}: step is empty (the step column must be filled in every row)"
        )
    if bad:
        return bad
    seen: dict[tuple[str, int], int] = {}
    first_angles: dict[str, int] = {}
    for r, label in enumerate(config):
        key = (label, int(step[r]))
        if key in seen:
            bad.append(
                f"line {line[r]}: step {_show(step_cells[r])} repeats within config "
                f"'{_show(label)}' (line {line[seen[key]]})"
            )
        else:
            seen[key] = r
        f = first_angles.setdefault(label, r)
        if not np.array_equal(alpha[r], alpha[f]):
            bad.append(
                f"line {line[r]}: config '{_show(label)}' is one sequence, its angles must be "
                f"those of line {line[f]} ({', '.join(f'{a:g}' for a in alpha[r])} vs "
                f"{', '.join(f'{a:g}' for a in alpha[f])})"
            )
    for label, r in _first_rows(config, step).items():
        v = values[r]
        if mass[r] == 0 and np.any(np.isfinite(v) & (v != 0)):
            c = int(np.flatnonzero(np.isfinite(v) & (v != 0))[0])
            bad.append(
                f"line {line[r]}: the reference row of config '{_show(label)}' (mass 0 before any "
                f"load) must read 0 or be empty; {channel_names(alpha.shape[1])[c]} is {v[c]:g}"
            )
    return bad


def _reference_rows(
    config: Sequence[str],
    mass: FloatArray,
    step: npt.NDArray[np.int64],
    values: FloatArray,
) -> npt.NDArray[np.bool_]:
    """(N,) the written reference rows: the first row of a label, with mass 0."""
    out = np.zeros(len(config), dtype=bool)
    for r in _first_rows(config, step).values():
        out[r] = mass[r] == 0
    return out
