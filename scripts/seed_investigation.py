"""The seed data against thresholds, taken-up gaps and a line through zero (issue 11).

Usage: python scripts/seed_investigation.py            (prints the table and the notes)

Every model is fitted to the bundled seed2022 data (``eodarm.fit``) and cross-validated by
leaving one configuration out (``eodarm.cross_validate``); the line through zero (sag ∝
payload, one slope) is held out the same way: its slope is fitted on four configurations'
sags and the fifth predicted. ``section()`` returns the markdown that
scripts/seed_reproduction.py writes as §6 of docs/seed-reproduction.md.
"""

from __future__ import annotations

import runpy
import warnings
from pathlib import Path
from typing import Any

import numpy as np

import eodarm
from eodarm.analysis.fit import FitWarning, cross_validate, fit
from eodarm.data import datasets

ROOT = Path(__file__).resolve().parent.parent
BODIES = [f"actuator_compliance@M{i}" for i in (1, 2, 3)]
MOUNTS = [f"mount_compliance@M{i}" for i in (1, 2, 3)]
BEST = BODIES + MOUNTS


def _load_effects() -> None:
    runpy.run_path(str(ROOT / "examples" / "friction.py"))
    runpy.run_path(str(ROOT / "examples" / "thresholds.py"))


def models() -> list[tuple[str, list[str]]]:
    ms: list[tuple[str, list[str]]] = [
        ("500 N/mm springs (nothing fitted)", []),
        ("bodies + mounts (§4's best)", BEST),
    ]
    for k in (1, 2, 3):
        ms.append((f"+ actuator_play@M{k}:taken_up", [*BEST, f"actuator_play@M{k}:taken_up"]))
    ms.append(
        ("+ actuator_play@M1–M3:taken_up", [*BEST, *(f"actuator_play@M{k}:taken_up" for k in (1, 2, 3))])
    )
    for k in (1, 2, 3):
        ms.append((f"+ joint_clearance@O{k}:taken_up", [*BEST, f"joint_clearance@O{k}:taken_up"]))
    ms.append(
        ("+ actuator_friction@M1–M3 (user)", [*BEST, *(f"actuator_friction@M{k}" for k in (1, 2, 3))])
    )
    for k in (1, 2, 3):
        ms.append((f"+ mount_preload@M{k} (user)", [*BEST, f"mount_preload@M{k}"]))
    ms.append(("+ mount_preload@M1–M3 (user)", [*BEST, *(f"mount_preload@M{k}" for k in (1, 2, 3))]))
    for k in (1, 2, 3):
        ms.append((f"+ joint_preload@O{k} (user)", [*BEST, f"joint_preload@O{k}"]))
    return ms


def line_through_zero(meas: eodarm.Measurements) -> dict[str, Any]:
    """dy = b·m, one slope b: in-sample and held out by configuration."""
    j = meas.channels.index("dy_mm")
    y = meas.values[:, j]
    sig = meas.sigma[:, j]
    m = meas.mass_kg
    cfg = np.asarray(meas.config)
    ok = np.isfinite(y)

    def slope(sel: np.ndarray) -> float:
        w = 1.0 / sig[sel] ** 2
        return float(np.sum(w * m[sel] * y[sel]) / np.sum(w * m[sel] ** 2))

    b = slope(ok)
    r_in = (y - b * m)[ok]
    held = np.full_like(y, np.nan)
    per = {}
    for c in meas.configs:
        test = (cfg == c) & ok
        bc = slope(ok & ~test)
        held[test] = y[test] - bc * m[test]
        per[str(c)] = float(np.sqrt(np.mean(held[test] ** 2)))
    chi2 = float(np.sum((r_in / sig[ok]) ** 2))
    return {
        "slope": b,
        "rms": float(np.sqrt(np.mean(r_in**2))),
        "cv": float(np.sqrt(np.nanmean(held**2))),
        "chi2_per_dof": chi2 / (int(ok.sum()) - 1),
        "per_config": per,
    }


def without_angles(meas: eodarm.Measurements) -> eodarm.Measurements:
    """The same states with the three angle channels dropped (sag and motor sensors only)."""
    import tempfile

    df = meas.to_dataframe()
    drop = [c for c in df.columns if "dalpha" in c]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "seed2022_no_angles.csv"
        df.drop(columns=[*drop, "line"], errors="ignore").to_csv(path, index=False)
        return eodarm.read_measurements(path, meas.alpha_deg.shape[1])


def run(angles: bool = True) -> dict[str, Any]:
    warnings.simplefilter("ignore", FitWarning)
    _load_effects()
    ds = datasets.load("seed2022")
    arm, meas = ds.arm, ds.measurements
    if not angles:
        meas = without_angles(meas)
    rows = []
    line = line_through_zero(meas)
    rows.append(
        {
            "label": "line through zero, sag ∝ payload (1 slope)",
            "n": 1,
            "rms": line["rms"],
            "cv": line["cv"],
            "chi2_per_dof": line["chi2_per_dof"],
            "per_config": line["per_config"],
            "estimates": f"{line['slope']:.3f} mm/kg",
            "undetermined": [],
        }
    )
    for label, eff in models():
        r = fit(arm, meas, eff)
        cv = cross_validate(arm, meas, eff, start=r.theta if eff else None) if eff else None
        und = [f"{r.slots[i].spec} ({why})" for i, why in r.undetermined()]
        bounds = [r.slots[i].spec for i in range(len(r.slots)) if r.at_bound[i]]
        extra = [
            f"{r.slots[i].spec}={r.estimate(i):.3g}±{r.stderr(i):.2g}"
            for i in range(len(r.slots))
            if r.slots[i].spec not in BEST
        ]
        rows.append(
            {
                "label": label,
                "n": len(eff),
                "rms": r.rms()["dy_mm"],
                "cv": cv["rms"]["dy_mm"] if cv else r.rms()["dy_mm"],
                "chi2_per_dof": r.chi2_per_dof,
                "per_config": {k: v["dy_mm"] for k, v in cv["per_config"].items()} if cv else {},
                "estimates": "; ".join(extra),
                "undetermined": und,
                "at_bound": bounds,
            }
        )
    return {"rows": rows, "line": line}


def table(rows: list[dict[str, Any]]) -> str:
    out = [
        "| model | fitted | sag RMS in-sample (mm) | sag RMS held out (mm) | χ²/dof | added effect(s), estimate ± stderr |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        out.append(
            f"| {r['label']} | {r['n']} | {r['rms']:.2f} | {r['cv']:.2f} | "
            f"{r['chi2_per_dof']:.3g} | {r['estimates'] or '—'} |"
        )
    return "\n".join(out)


def main() -> None:
    for angles in (True, False):
        _report(angles)


def _report(angles: bool) -> None:
    res = run(angles)
    print("## all channels" if angles else "## angle channels dropped (dy, dl1-dl3 only)")
    print(table(res["rows"]))
    print()
    for r in res["rows"]:
        pc = ", ".join(f"{k} {v:.2f}" for k, v in r["per_config"].items())
        print(f"{r['label']}: held out per config: {pc}")
        if r.get("at_bound"):
            print(f"    at a bound: {', '.join(r['at_bound'])}")
        for u in r["undetermined"]:
            print(f"    not determined: {u}")


if __name__ == "__main__":
    main()
