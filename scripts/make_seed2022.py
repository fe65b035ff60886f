"""Regenerate the derived files of the bundled seed2022 data set from its published tables.

Usage: python scripts/make_seed2022.py [OUT_DIR]   (default: python/eodarm/data/seed2022)

Writes arm_published.toml (Table 1 as printed, B0 from the Table 5 calibration), arm.toml
(calibrated geometry with the real g and assumed masses) and measurements.csv (Tables 3-4).
tests/test_seed2022.py checks that the shipped files equal what this script writes.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

from eodarm.analysis.calibrate import seed2022_calibration
from eodarm.data.datasets import seed2022_measurements

DATA = Path(__file__).resolve().parent.parent / "python" / "eodarm" / "data" / "seed2022"

PUBLISHED_HEADER = """\
# seed2022, the arm AS PRINTED: Table 1 of Stefan et al. 2022 (Electronics 11, 2355), with the
# splits of its run-together cells explained in NOTES.md. Not published, filled in:
#   base.B0  - from the Table 5 calibration (docs/seed-reproduction.md);
#   masses   - 0 (the paper's Table 5 says weights were neglected);
#   stiffness_n_per_mm = 500 - the paper's artificial spring model (section 5).
# The payload point is O4 = (400, 0) as section 5 prints it; measure = B3 = (300, -44).
"""

CALIBRATED_HEADER = """\
# seed2022, the measured arm: Table 1 geometry calibrated on Table 5 (scripts/make_seed2022.py,
# docs/seed-reproduction.md). Table 5 identifies B0, the payload point on arm 3 (at x = 300, not
# at O4 = 400) and the paper's g = 10; this file keeps the real g = 9.81 for the measurements.
# Masses are ASSUMED (none is published): links 3.0 / 2.5 / 2.88 kg (the last is the 28.8 N
# that Table 5 carries at O3), actuators 1.5 / 1.2 / 1.0 kg.
# stiffness_n_per_mm = 500 is the paper's spring model, the baseline the analysis starts from.
"""


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else DATA
    out.mkdir(parents=True, exist_ok=True)
    tables = {p.stem: pd.read_csv(p) for p in sorted(DATA.glob("table*.csv"))}
    result = seed2022_calibration(tables)
    (out / "arm_published.toml").write_text(PUBLISHED_HEADER + result["published"].to_toml())
    (out / "arm.toml").write_text(CALIBRATED_HEADER + result["calibrated"].to_toml())
    seed2022_measurements(tables).to_csv(out / "measurements.csv")
    for row in result["calibration"].table():
        print(
            f"{row['key']:16s} printed {row['printed']:10.3f}  calibrated {row['calibrated']:10.3f}"
            f"  moved {row['moved']:+9.3f}  posterior sigma {row['posterior_sigma']:.3g}"
        )
    print(f"wrote {out}/arm_published.toml, arm.toml, measurements.csv", file=sys.stderr)


if __name__ == "__main__":
    main()
