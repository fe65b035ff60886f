"""What a model leaves: its residuals in units of σ, by channel, configuration and payload.

When no effect of the catalogue explains the data (verdict ``unexplained``), the shape of
what is left is the best clue to what is missing: on which channel, in which poses, growing
with the payload or not, of one sign or both. :func:`residual_pattern` gives those numbers;
the command line prints them as a table and the report draws them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.analysis.fit import FitResult

__all__ = ["ResidualPattern", "residual_pattern"]


@dataclass(frozen=True)
class ResidualPattern:
    """Mean residual/σ of a fit, by configuration × payload × channel.

    Attributes
    ----------
    channels : the channels with used cells, in channel order.
    configs : configuration labels, in order of first appearance.
    payloads : the payload masses (kg), ascending.
    mean_z : (configs, payloads, channels) mean of (measured − model)/σ over the used cells
        of that configuration, payload and channel; NaN where there is none.
    count : (configs, payloads, channels) number of used cells behind each mean.
    by_config : (configs, channels) mean z per configuration (all payloads).
    by_payload : (payloads, channels) mean z per payload (all configurations).
    rms_z : (channels,) RMS of z per channel: how much of the misfit each channel carries.
    largest : the cells of largest |z|, largest first: ``line``, ``config``, ``mass_kg``,
        ``channel``, ``z``.
    """

    channels: tuple[str, ...]
    configs: tuple[str, ...]
    payloads: tuple[float, ...]
    mean_z: npt.NDArray[np.float64]
    count: npt.NDArray[np.int64]
    by_config: npt.NDArray[np.float64]
    by_payload: npt.NDArray[np.float64]
    rms_z: npt.NDArray[np.float64]
    largest: list[dict[str, Any]]

    def to_json(self) -> dict[str, Any]:
        def num(x: float) -> float | None:
            return float(x) if np.isfinite(x) else None

        return {
            "channels": list(self.channels),
            "configs": list(self.configs),
            "payloads": list(self.payloads),
            "mean_z": [[[num(v) for v in row] for row in cfg] for cfg in self.mean_z],
            "rms_z": {ch: num(v) for ch, v in zip(self.channels, self.rms_z, strict=True)},
            "largest": list(self.largest),
        }


def _mean(z: npt.NDArray[np.float64], m: npt.NDArray[np.bool_]) -> float:
    return float(z[m].mean()) if m.any() else float("nan")


def residual_pattern(fit: FitResult, top: int = 5) -> ResidualPattern:
    """The residual/σ that ``fit`` leaves, grouped by configuration, payload and channel.

    Only the cells the fit used count (outliers left out of it are not part of the
    pattern). ``top`` is the number of cells listed in ``largest``.
    """
    prob = fit.problem
    meas = prob.meas
    use = prob.use
    z = np.where(use, fit.z, np.nan)
    cols = [c for c in range(len(meas.channels)) if use[:, c].any()]
    labels = np.asarray(meas.config)
    configs = tuple(meas.configs)
    mass = np.asarray(meas.mass_kg, dtype=float)
    payloads = tuple(float(x) for x in np.unique(mass))
    shape = (len(configs), len(payloads), len(cols))
    mean_z = np.full(shape, np.nan)
    count = np.zeros(shape, dtype=np.int64)
    by_config = np.full((len(configs), len(cols)), np.nan)
    by_payload = np.full((len(payloads), len(cols)), np.nan)
    rms_z = np.full(len(cols), np.nan)
    for j, c in enumerate(cols):
        zc, uc = z[:, c], use[:, c]
        rms_z[j] = float(np.sqrt(np.mean(zc[uc] ** 2)))
        for i, label in enumerate(configs):
            in_cfg = uc & (labels == label)
            by_config[i, j] = _mean(zc, in_cfg)
            for p, mp in enumerate(payloads):
                cell = in_cfg & (mass == mp)
                count[i, p, j] = int(cell.sum())
                mean_z[i, p, j] = _mean(zc, cell)
        for p, mp in enumerate(payloads):
            by_payload[p, j] = _mean(zc, uc & (mass == mp))
    flat = np.where(use, np.abs(np.nan_to_num(z)), -1.0)
    order = np.argsort(flat, axis=None)[::-1][: max(top, 0)]
    largest = []
    for r, c in zip(*np.unravel_index(order, flat.shape), strict=True):
        if flat[r, c] < 0:
            break
        largest.append(
            {
                "line": int(meas.line[r]),
                "config": str(labels[r]),
                "mass_kg": float(mass[r]),
                "channel": meas.channels[c],
                "z": float(z[r, c]),
            }
        )
    return ResidualPattern(
        channels=tuple(meas.channels[c] for c in cols),
        configs=configs,
        payloads=payloads,
        mean_z=mean_z,
        count=count,
        by_config=by_config,
        by_payload=by_payload,
        rms_z=rms_z,
        largest=largest,
    )
