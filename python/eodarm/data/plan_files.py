"""The files a plan writes for the lab to fill in (docs/plan.md, docs/formats.md).

* a **measurement file** (docs/formats.md §3, with a ``step`` column for a load cycle): one
  row per planned configuration × state, the planned channels' columns empty;
* a **campaign file** (docs/records.md): one ``[[record]]`` per configuration, its record file
  ``<config>.csv`` beside it (to be recorded), its angles and its payloads in order, the
  reference first.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

import numpy as np
import numpy.typing as npt

from eodarm.atomic import atomic_write
from eodarm.data.channels import channel_names
from eodarm.data.records import RecordSpec, write_campaign
from eodarm.errors import EodarmError

__all__ = ["write_plan_campaign", "write_plan_csv"]


def write_plan_csv(
    out: str | Path | TextIO,
    labels: Sequence[str],
    alpha_deg: npt.ArrayLike,
    states_kg: Sequence[float],
    sequence: bool,
    channels: Sequence[str],
) -> None:
    """Write the measurement file to fill: ``config``, the angles, ``mass_kg``, ``step`` (a
    load cycle: 1, 2, … after the zeroed reference, which is not a row), and the channels,
    empty. Angles are written with ``repr`` (the exact planned values)."""
    alpha = np.atleast_2d(np.asarray(alpha_deg, dtype=float))
    n = alpha.shape[1]
    order = [c for c in channel_names(n) if c in set(channels)]
    head = ["config", *(f"alpha{i}_deg" for i in range(1, n + 1)), "mass_kg"]
    head += ["step"] if sequence else []
    head += order

    def write(f: TextIO) -> None:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(head)
        for label, pose in zip(labels, alpha, strict=True):
            for k, m in enumerate(states_kg, start=1):
                row = [label, *(repr(float(a)) for a in pose), repr(float(m))]
                row += [str(k)] if sequence else []
                w.writerow(row + [""] * len(order))

    if isinstance(out, (str, Path)):
        try:
            with atomic_write(out, newline="") as f:  # whole or not at all
                write(f)
        except OSError as exc:
            raise EodarmError(f"{out}: cannot write: {exc.strerror or exc}") from None
    else:
        write(out)


def write_plan_campaign(
    path: str | Path,
    labels: Sequence[str],
    alpha_deg: npt.ArrayLike,
    masses_kg: Sequence[float],
) -> None:
    """Write a campaign file: one ``[[record]]`` per configuration, ``file = "<label>.csv"``
    beside the campaign file, ``masses_kg`` the payloads in order from the reference."""
    p = Path(path)
    alpha = np.atleast_2d(np.asarray(alpha_deg, dtype=float))
    specs = [
        RecordSpec(p.parent / f"{label}.csv", label, tuple(map(float, pose)), tuple(masses_kg))
        for label, pose in zip(labels, alpha, strict=True)
    ]
    try:
        write_campaign(p, specs)
    except OSError as exc:
        raise EodarmError(f"{path}: cannot write: {exc.strerror or exc}") from None
