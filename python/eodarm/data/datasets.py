"""Bundled data sets: ``eodarm.data.datasets.load("seed2022")``.

``seed2022`` is the bomb-disposal arm of Ștefan et al., *Electronics* 2022, 11, 2355: its
Tables 1–9 as published (``paper_tables/``), every interpretation in ``NOTES.md``, the arm as
printed (``arm_published.toml``), the arm calibrated on Table 5 (``arm.toml``, see
:func:`eodarm.analysis.calibrate.seed2022_calibration`) and the measurements of Tables 3–4
in the measurement-file format (``measurements.csv``).
"""

from __future__ import annotations

import dataclasses
import shutil
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from eodarm.atomic import atomic_files
from eodarm.data.measurements import Measurements
from eodarm.data.reader import read_measurements
from eodarm.errors import EodarmError, show
from eodarm.model.arm import Arm

__all__ = [
    "SEED2022_SIGMA",
    "Dataset",
    "bundled_arm",
    "bundled_arm_path",
    "dataset_of",
    "example_arm",
    "export",
    "load",
    "names",
    "seed2022_measurements",
]

_DESCRIPTIONS = {
    "seed2022": "Ștefan et al. 2022, Electronics 11, 2355: 3-link EOD arm, 5 configurations × "
    "3 payloads, measured angles, motor displacements and effector sag (Tables 1–9)",
}

# Standard deviations stated for the seed measurements (docs/seed-reproduction.md, NOTES.md).
SEED2022_SIGMA = {
    # Angles printed to 0.1°: a difference of two rounded readings has σ = 0.1/√6 ≈ 0.041°;
    # rounded up for the unstated accuracy of the angle measurement itself.
    "dalpha_deg": 0.05,
    # Motor sensors (HBM WA 200 mm): the printed readings fall by up to 0.002 mm when the load
    # rises (configuration 4, motor 1: 0.034 → 0.032), which bounds their repeatability.
    "dl_mm": 0.005,
    # Laser sag: the paper states a 0.5 mm margin for the chassis on its rubber tracks; half of
    # it is taken as σ.
    "dy_mm": 0.25,
}


def names() -> list[str]:
    """The bundled data sets."""
    return list(_DESCRIPTIONS)


def _root(name: str) -> Path:
    if name not in _DESCRIPTIONS:
        raise EodarmError(f"unknown data set '{show(name)}'; bundled: {', '.join(_DESCRIPTIONS)}")
    return Path(str(resources.files("eodarm").joinpath("data", name)))


@dataclass
class Dataset:
    """A bundled data set."""

    name: str
    description: str
    root: Path
    arm: Arm
    arm_published: Arm
    measurements: Measurements
    tables: dict[str, Any] = field(default_factory=dict)

    def __repr__(self) -> str:
        from eodarm import reprs

        tables = ", ".join(self.tables) or "not loaded"
        return reprs.block(
            f"Dataset {self.name}: {self.description}",
            [
                f"arm: '{self.arm.name}', {self.arm.n} links (calibrated; also arm_published)",
                f"measurements: {self.measurements.n_rows} states ({self.measurements.source})",
                f"tables: {tables}",
                f"files: {self.root}",
            ],
        )

    @property
    def notes(self) -> str:
        return (self.root / "NOTES.md").read_text(encoding="utf-8")


def load(name: str = "seed2022", tables: bool = True) -> Dataset:
    """Load a bundled data set (tables as pandas DataFrames; ``tables=False`` leaves them
    out, and pandas unimported, for callers that need only the arm and the measurements)."""
    root = _root(name)
    arm = Arm.from_toml(root / "arm.toml")
    published = Arm.from_toml(root / "arm_published.toml")
    found: dict[str, Any] = {}
    if tables:
        import pandas as pd

        found = {p.stem: pd.read_csv(p) for p in sorted(root.glob("table*.csv"))}
    meas = dataclasses.replace(
        read_measurements(root / "measurements.csv", arm.n), source=f"{name}/measurements.csv"
    )
    return Dataset(name, _DESCRIPTIONS[name], root, arm, published, meas, found)


def bundled_arm_path(name: str = "seed2022") -> Path:
    """The file of a bundled data set's arm (its calibrated ``arm.toml``)."""
    return _root(name) / "arm.toml"


def bundled_arm(name: str = "seed2022") -> Arm:
    """The arm of a bundled data set (its calibrated ``arm.toml``), without loading the rest."""
    return Arm.from_toml(bundled_arm_path(name))


def dataset_of(path: str | Path) -> str | None:
    """The bundled data set whose measurement file has exactly the bytes of ``path`` (the
    bundled file itself or an exported copy), or None."""
    import hashlib

    try:
        data = Path(path).read_bytes()
    except OSError:
        return None
    digest = hashlib.sha256(data).digest()
    for name in _DESCRIPTIONS:
        ours = (_root(name) / "measurements.csv").read_bytes()
        if len(ours) == len(data) and hashlib.sha256(ours).digest() == digest:
            return name
    return None


def export(name: str, directory: str | Path) -> list[Path]:
    """Write the data set's files into ``directory`` (created if needed).

    Writes ``arm_published.toml``, ``arm.toml``, ``measurements.csv``, ``NOTES.md`` and
    ``paper_tables/table1.csv`` … ``table9.csv``, all or none (each to a temporary sibling,
    renamed into place when the last is complete: eodarm.atomic). Returns the paths written.
    """
    root = _root(name)
    out = Path(directory)
    (out / "paper_tables").mkdir(parents=True, exist_ok=True)
    pairs = [(root / f, out / f) for f in ("arm_published.toml", "arm.toml")]
    pairs += [(root / f, out / f) for f in ("measurements.csv", "NOTES.md")]
    pairs += [(p, out / "paper_tables" / p.name) for p in sorted(root.glob("table*.csv"))]
    with atomic_files() as batch:
        for src, dst in pairs:
            with open(src, "rb") as f:
                shutil.copyfileobj(f, batch.open(dst, "wb"))
    return [dst for _, dst in pairs]


# ------------------------------------------------------------------ building seed2022
def seed2022_measurements(tables: dict[str, Any]) -> Measurements:
    """Tables 3 and 4 as a measurement file (docs/formats.md §3).

    * ``alphaK_deg``: Table 3's unloaded angles (configuration 3's α1 = 89.9, not Table 2's 0.1);
    * ``dalphaK_deg``: loaded − unloaded (Table 3), as printed (configuration 2's α1 rises);
    * ``dlK_mm``: Table 4's motors with the signs of §6: motor 1 stretched (+), motors 2 and 3
      compressed (−); configuration 5's missing motor-3 cells stay empty (not measured);
    * ``dy_mm``: −sag (Table 4), a sag is negative;
    * σ as in :data:`SEED2022_SIGMA`, stated in ``sigma_`` columns.
    """
    t3 = tables["table3"].sort_values(["config", "mass_kg"]).reset_index(drop=True)
    t4 = tables["table4"].sort_values(["config", "mass_kg"]).reset_index(drop=True)
    if not np.array_equal(
        t3[["config", "mass_kg"]].to_numpy(), t4[["config", "mass_kg"]].to_numpy()
    ):
        raise EodarmError("seed2022: Tables 3 and 4 list different states")
    n = len(t3)
    values: dict[str, npt.NDArray[np.float64]] = {}
    sigma: dict[str, npt.NDArray[np.float64]] = {}
    for k in (1, 2, 3):
        values[f"dalpha{k}_deg"] = (
            t3[f"alpha{k}_loaded_deg"] - t3[f"alpha{k}_unloaded_deg"]
        ).to_numpy(dtype=float)
        sigma[f"dalpha{k}_deg"] = np.full(n, SEED2022_SIGMA["dalpha_deg"])
        sign = 1.0 if k == 1 else -1.0
        values[f"dl{k}_mm"] = sign * t4[f"motor{k}_mm"].to_numpy(dtype=float)
        sigma[f"dl{k}_mm"] = np.full(n, SEED2022_SIGMA["dl_mm"])
    values["dy_mm"] = -t4["sag_mm"].to_numpy(dtype=float)
    sigma["dy_mm"] = np.full(n, SEED2022_SIGMA["dy_mm"])
    # round away float noise of the subtraction (inputs have one decimal)
    for k in (1, 2, 3):
        values[f"dalpha{k}_deg"] = np.round(values[f"dalpha{k}_deg"], 6)
    for ch in values:
        sigma[ch] = np.where(np.isfinite(values[ch]), sigma[ch], np.nan)
    alpha = t3[[f"alpha{k}_unloaded_deg" for k in (1, 2, 3)]].to_numpy(dtype=float)
    return Measurements.from_arrays(
        config=np.array([f"c{c}" for c in t3["config"]]),
        alpha_deg=alpha,
        mass_kg=t3["mass_kg"].to_numpy(dtype=float),
        values=values,
        sigma=sigma,
        source="seed2022/measurements.csv",
    )


def seed2022_published_dict() -> dict[str, Any]:
    """Table 1 as printed (NOTES.md for each split), the paper's 500 N/mm springs, no masses.

    B0 is not published; it is filled in by :func:`eodarm.analysis.calibrate.seed2022_calibration`.
    """
    return {
        "name": "seed2022-published",
        "g": 9.81,
        "base": {"O1": [0.0, 0.0], "B0": [-500.0, -50.0]},
        "link": [
            {
                "next": [500.0, 0.0],
                "A": [80.94, 65.0],
                "B": [-50.0, -44.0],
                "C": [230.12, -2.4],
                "mass_kg": 0.0,
            },
            {
                "next": [400.0, 0.0],
                "A": [90.5, -51.0],
                "B": [-128.0, 0.0],
                "C": [165.5, -1.3],
                "mass_kg": 0.0,
            },
            {
                "next": [400.0, 0.0],
                "A": [44.8, -31.4],
                "C": [230.12, -2.4],
                "measure": [300.0, -44.0],
                "mass_kg": 0.0,
            },
        ],
        "actuator": [{"stiffness_n_per_mm": 500.0, "mass_kg": 0.0} for _ in range(3)],
    }


def example_arm() -> Arm:
    """The bundled example arm (``data/example_arm.toml``, docs/formats.md §1)."""
    ref = resources.files("eodarm.data").joinpath("example_arm.toml")
    with resources.as_file(ref) as path:
        return Arm.from_toml(path)
